//! `cargo xtask tick-cost`: cycles of the stepper interrupt on a Cortex-M4F, and the step rate that leaves half
//! of an 80 MHz STM32L476 free.
//!
//! Method: the `tick-bench` image (plotter-fw/boards/tick-bench) runs the core with the Nucleo board's tick path
//! on QEMU's `mps2-an386` (Cortex-M4F) under `-d in_asm,exec,nochain`: QEMU prints the disassembly of every
//! translated block once and a line for every block it executes. Every instruction executed between the entry of
//! `bench_tick` (the TIM2 interrupt body) and `bench_tick_done` is priced with the Cortex-M4 Technical Reference
//! Manual's cycle counts (ARM DDI 0439, "Processor instruction timings", and the FPU's instruction timings),
//! taking the pessimistic end of every range:
//!
//! | instructions                                  | cycles                                  |
//! |-----------------------------------------------|-----------------------------------------|
//! | data processing, `mul`, long multiply, `it`   | 1                                       |
//! | `mla`, `mls`                                  | 2                                       |
//! | `ldr*`, `str*` (single)                       | 2 (+3 when loading `pc`)                |
//! | `ldrd`, `strd`                                | 3                                       |
//! | `ldm`/`pop`, `stm`/`push` of N registers      | 1 + N (+3 when popping `pc`)            |
//! | `udiv`, `sdiv`                                | 12                                      |
//! | branch taken / not taken (`bl`, `bx` taken)   | 1 + 3 / 1                               |
//! | `tbb`, `tbh`                                  | 5                                       |
//! | `vdiv`, `vsqrt`                               | 14                                      |
//! | `vmla`/`vfma` and friends                     | 3                                       |
//! | `vldr`, `vstr`, `vmov` of two core registers  | 2                                       |
//! | `vpush`/`vpop`/`vldm`/`vstm` of N registers   | 1 + N                                   |
//! | other FPU instructions                        | 1                                       |
//!
//! Whether a branch was taken is read from the trace (the next block's address). A tick whose path executes an
//! FPU instruction also pays the lazy stacking of the FPU context (17 cycles: the interrupted main loop uses the
//! FPU, and the Cortex-M4 saves its registers at the interrupt's first FPU instruction); it is counted in that
//! tick's body. Added per step event: the interrupt entry (12 cycles) and exit (10), and [`DMA_STALL`] for the
//! pulse end: on the board TIM2's compare channels 2 and 3 trigger two one-word DMA transfers that lower the step
//! pins (no interrupt, no instruction — `plotter_board::stm32_step`); they take bus cycles, and the CPU waits
//! when it accesses the bus matrix in the same cycle, so each is charged as a stalled 2-cycle access.
//! Instruction fetch is assumed to hit the L476's ART accelerator (prefetch and instruction cache, zero wait
//! states); the tick path is far smaller than its cache.

use std::collections::HashMap;
use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};

use anyhow::{Context as _, bail};

/// Interrupt entry + exit, cycles.
const ISR_OVERHEAD: u64 = 12 + 10;
/// Lazy stacking of the FPU context, paid by an interrupt at its first FPU instruction.
const FPU_STACKING: u64 = 17;
/// The aggregate step rate the stepper should sustain with half of the CPU (issue 26), kHz.
const TARGET_KHZ: f64 = 250.0;
/// The pulse end's two DMA transfers, charged as CPU stalls.
const DMA_STALL: u64 = 2 * 2;
/// Core clock of the L476, Hz.
const CLOCK_HZ: f64 = 80.0e6;

#[derive(Debug, Clone)]
struct Insn {
    addr: u64,
    size: u64,
    mnemonic: String,
    operands: String,
}

fn registers_in(ops: &str) -> u64 {
    let inner = ops.split('{').nth(1).and_then(|r| r.split('}').next()).unwrap_or("");
    let mut n = 0;
    for part in inner.split(',') {
        let part = part.trim();
        if let Some((a, b)) = part.split_once('-') {
            let num = |s: &str| s.trim().trim_start_matches(['r', 's', 'd']).parse::<u64>().ok();
            if let (Some(x), Some(y)) = (num(a), num(b)) {
                n += y.saturating_sub(x) + 1;
                continue;
            }
        }
        if !part.is_empty() {
            n += 1;
        }
    }
    n
}

const CONDITIONS: [&str; 16] =
    ["eq", "ne", "cs", "hs", "cc", "lo", "mi", "pl", "vs", "vc", "hi", "ls", "ge", "lt", "gt", "le"];

/// Whether `m` is a branch (`b`, `bl`, `blx`, `bx`, `cbz`, `cbnz`, `b<cond>`), and whether it always branches.
fn branch_kind(m: &str) -> Option<bool> {
    match m {
        "b" | "bl" | "blx" | "bx" => Some(true),
        "cbz" | "cbnz" => Some(false),
        _ => m.strip_prefix('b').filter(|c| CONDITIONS.contains(c)).map(|_| false),
    }
}

/// Cycles of one instruction; `taken` says whether a (conditional) branch was taken.
fn cycles(i: &Insn, taken: bool) -> u64 {
    let m = i.mnemonic.trim_end_matches(".w").trim_end_matches(".n");
    let ops = i.operands.as_str();
    let loads_pc = ops.split(',').next().is_some_and(|d| d.trim() == "pc");
    if let Some(always) = branch_kind(m) {
        return if always || taken { 4 } else { 1 };
    }
    if m.starts_with("vsqrt") || m.starts_with("vdiv") {
        return 14;
    }
    if ["vmla", "vmls", "vnmla", "vnmls", "vfma", "vfms", "vfnma", "vfnms"].iter().any(|p| m.starts_with(p)) {
        return 3;
    }
    if ["vpush", "vpop", "vldm", "vstm"].iter().any(|p| m.starts_with(p)) {
        return 1 + registers_in(ops);
    }
    if m.starts_with("vldr") || m.starts_with("vstr") {
        return 2;
    }
    if m.starts_with("vmov") {
        return if ops.split(',').count() >= 3 { 2 } else { 1 };
    }
    if m.starts_with('v') {
        return 1;
    }
    if m == "push" || m.starts_with("stm") {
        return 1 + registers_in(ops);
    }
    if m == "pop" || m.starts_with("ldm") {
        return 1 + registers_in(ops) + if ops.contains("pc") { 3 } else { 0 };
    }
    if m.starts_with("ldrd") || m.starts_with("strd") {
        return 3;
    }
    if m.starts_with("ldr") {
        return 2 + if loads_pc { 3 } else { 0 };
    }
    if m.starts_with("str") {
        return 2;
    }
    if m.starts_with("udiv") || m.starts_with("sdiv") {
        return 12;
    }
    if m.starts_with("mla") || m.starts_with("mls") {
        return 2;
    }
    if m.starts_with("tbb") || m.starts_with("tbh") {
        return 5;
    }
    1
}

/// "0x0000545c:  f84d 8d04  str      r8, [sp, #-0x4]!" → the instruction.
fn parse_insn(line: &str) -> Option<Insn> {
    let (addr, rest) = line.split_once(":  ")?;
    let addr = u64::from_str_radix(addr.strip_prefix("0x")?, 16).ok()?;
    let rest = rest.trim_start();
    // Encoding: one or two groups of 4 hex digits.
    let mut size = 0;
    let mut tail = rest;
    for _ in 0..2 {
        let (word, after) = tail.split_at(tail.find(' ').unwrap_or(tail.len()));
        if word.len() == 4 && word.chars().all(|c| c.is_ascii_hexdigit()) {
            size += 2;
            tail = after.trim_start();
        } else {
            break;
        }
    }
    if size == 0 {
        return None;
    }
    let (mnemonic, operands) = tail.split_once(char::is_whitespace).unwrap_or((tail, ""));
    Some(Insn { addr, size, mnemonic: mnemonic.to_ascii_lowercase(), operands: operands.trim().to_ascii_lowercase() })
}

/// "Trace 0: 0x7ff2c0000100 [00800408/00000400/00000110/ff000200] Reset" → (pc, symbol).
fn parse_exec(line: &str) -> Option<(u64, &str)> {
    let rest = line.strip_prefix("Trace ")?;
    let inside = rest.split('[').nth(1)?;
    let (fields, sym) = inside.split_once(']')?;
    let pc = u64::from_str_radix(fields.split('/').nth(1)?, 16).ok()?;
    Some((pc, sym.trim()))
}

/// Cost of a sequence of executed blocks, with the lazy FPU stacking when one of them is an FPU instruction.
fn path_cycles(blocks: &[u64], code: &HashMap<u64, Vec<Insn>>) -> anyhow::Result<u64> {
    let mut total = 0;
    let mut fpu = false;
    for (k, pc) in blocks.iter().enumerate() {
        let insns = code.get(pc).with_context(|| format!("no disassembly for the block at {pc:#x}"))?;
        let next = blocks.get(k + 1).copied();
        for (j, i) in insns.iter().enumerate() {
            let last = j + 1 == insns.len();
            let taken = last && next.is_some_and(|n| n != i.addr + i.size);
            total += cycles(i, taken);
            fpu |= i.mnemonic.starts_with('v');
        }
    }
    Ok(total + if fpu { FPU_STACKING } else { 0 })
}

/// Statistics over the measured ticks.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Figures {
    /// Ticks measured.
    pub(crate) ticks: usize,
    /// Worst tick body, cycles.
    pub(crate) worst: u64,
    /// Mean tick body.
    pub(crate) mean: f64,
    /// Median and 90th percentile.
    pub(crate) p50: u64,
    pub(crate) p90: u64,
    /// 99.9th percentile.
    pub(crate) p999: u64,
}

/// Parse QEMU's `in_asm,exec` log.
fn measure(log: impl BufRead) -> anyhow::Result<Figures> {
    let mut code: HashMap<u64, Vec<Insn>> = HashMap::new();
    let mut current: Option<Vec<Insn>> = None;
    let mut ticks = Vec::new();
    let mut open: Option<Vec<u64>> = None;
    for line in log.lines() {
        let line = line?;
        if line.starts_with("IN:") {
            current = Some(Vec::new());
            continue;
        }
        if let Some(block) = current.as_mut() {
            if let Some(i) = parse_insn(&line) {
                block.push(i);
                continue;
            }
            if let Some(b) = current.take()
                && let Some(first) = b.first()
            {
                code.insert(first.addr, b);
            }
        }
        let Some((pc, sym)) = parse_exec(&line) else { continue };
        match (&mut open, sym) {
            (None, "bench_tick") => open = Some(vec![pc]),
            (Some(blocks), "bench_tick_done") => {
                ticks.push(path_cycles(blocks, &code)?);
                open = None;
            }
            (Some(blocks), _) => blocks.push(pc),
            (None, _) => {}
        }
    }
    if ticks.is_empty() {
        bail!("the trace holds no measured tick (did QEMU log `in_asm,exec`?)");
    }
    ticks.sort_unstable();
    let n = ticks.len();
    let sum: u64 = ticks.iter().sum();
    Ok(Figures {
        ticks: n,
        worst: ticks[n - 1],
        mean: sum as f64 / n as f64,
        p50: ticks[n / 2],
        p90: ticks[(n * 9 / 10).min(n - 1)],
        p999: ticks[(n * 999 / 1000).min(n - 1)],
    })
}

/// Run the bench image under QEMU and print the figures.
pub(crate) fn run(elf: &std::path::Path) -> anyhow::Result<()> {
    let mut qemu = Command::new("qemu-system-arm")
        .args(["-M", "mps2-an386", "-display", "none", "-monitor", "none", "-serial", "none"])
        .args(["-semihosting-config", "enable=on,target=native", "-d", "in_asm,exec,nochain", "-kernel"])
        .arg(elf)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .context("cannot start qemu-system-arm (apt-get install qemu-system-arm)")?;
    let log = BufReader::with_capacity(1 << 20, qemu.stderr.take().context("QEMU's stderr")?);
    let mut out = qemu.stdout.take().context("QEMU's stdout")?;
    let printed = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = std::io::Read::read_to_string(&mut out, &mut s);
        s
    });
    let figures = measure(log);
    let status = qemu.wait()?;
    let printed = printed.join().unwrap_or_default();
    // "tick-bench: N ticks M steps"
    let words: Vec<&str> = printed.split_whitespace().collect();
    let steps_per_event = match words.as_slice() {
        ["tick-bench:", t, "ticks", s, "steps"] => s.parse::<f64>().ok().zip(t.parse::<f64>().ok()).map(|(s, t)| s / t),
        _ => None,
    }
    .with_context(|| format!("the tick bench printed {printed:?}"))?;
    if !status.success() {
        bail!("the tick bench failed under QEMU ({status})");
    }
    let f = figures?;
    let overhead = ISR_OVERHEAD + DMA_STALL;
    let per_event = f.worst + overhead;
    let mean_event = f.mean + overhead as f64;
    // Half of the CPU for stepping: events/s = 0.5 × clock / cycles per event.
    let sustained = 0.5 * CLOCK_HZ / mean_event;
    let bounded = 0.5 * CLOCK_HZ / per_event as f64;
    println!("stepper tick on Cortex-M4F (Nucleo tick path, {} ticks measured):", f.ticks);
    println!(
        "  tick body: worst {} cycles, 99.9th percentile {}, 90th {}, median {}, mean {:.0}",
        f.worst, f.p999, f.p90, f.p50, f.mean
    );
    println!(
        "  per step event (worst): {per_event} cycles = tick {} + interrupt entry/exit {ISR_OVERHEAD} + pulse-end DMA \
         stalls {DMA_STALL} (no pulse-end interrupt)",
        f.worst
    );
    println!("  mean per step event: {mean_event:.0} cycles; {steps_per_event:.2} steps per event in this workload");
    println!(
        "  at 80 MHz with half the CPU left free: {:.1} k events/s sustained = {:.1} kHz aggregate step rate \
         (target {TARGET_KHZ:.0} kHz); even if every event cost the worst tick: {:.1} k events/s = {:.1} kHz",
        sustained / 1e3,
        sustained * steps_per_event / 1e3,
        bounded / 1e3,
        bounded * steps_per_event / 1e3
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn instructions_parse_with_their_sizes() {
        let i = parse_insn("0x00005460:  f84d 8d04  str      r8, [sp, #-0x4]!").unwrap();
        assert_eq!((i.addr, i.size, i.mnemonic.as_str(), i.operands.as_str()), (0x5460, 4, "str", "r8, [sp, #-0x4]!"));
        let i = parse_insn("0x0000545c:  b5f0       push     {r4, r5, r6, r7, lr}").unwrap();
        assert_eq!((i.size, cycles(&i, false)), (2, 6));
        assert!(parse_insn("IN: bench_tick").is_none());
        assert_eq!(
            parse_exec("Trace 0: 0x7ff2c0000100 [00800408/0000545c/00000110/ff000200] bench_tick"),
            Some((0x545c, "bench_tick"))
        );
    }

    #[test]
    fn documented_costs() {
        let c = |line: &str, taken| cycles(&parse_insn(line).unwrap(), taken);
        assert_eq!(c("0x0:  4008       ands     r0, r1", false), 1);
        assert_eq!(c("0x0:  6970       ldr      r0, [r6, #0x14]", false), 2);
        assert_eq!(c("0x0:  e8bd 8ff0  pop.w    {r4, r5, r6, r7, r8, r9, r10, r11, pc}", false), 1 + 9 + 3);
        assert_eq!(c("0x0:  eeb1 0ac0  vsqrt.f32 s0, s0", false), 14);
        assert_eq!(c("0x0:  ed2d 8b04  vpush    {d8, d9}", false), 3);
        assert_eq!(c("0x0:  ed2d 8a04  vpush    {s16-s19}", false), 5);
        assert_eq!(c("0x0:  fbb0 f0f1  udiv     r0, r0, r1", false), 12);
        assert_eq!(c("0x0:  d001       beq      #0x6", false), 1);
        assert_eq!(c("0x0:  d001       beq      #0x6", true), 4);
        assert_eq!(c("0x0:  f000 f801  bl       #0x6", false), 4);
        assert_eq!(c("0x0:  b108       cbz      r0, #0x6", true), 4);
        assert_eq!(c("0x0:  bf18       it       ne", false), 1);
        assert_eq!(c("0x0:  fa00 f001  bic      r0, r1", false), 1);
    }

    #[test]
    fn a_tick_is_priced_along_its_executed_blocks() {
        let log = "\
IN: bench_tick
0x00000100:  b580       push     {r7, lr}
0x00000102:  d001       beq      #0x108

IN: bench_tick
0x00000104:  2001       movs     r0, #1
0x00000106:  bd80       pop      {r7, pc}

IN: bench_tick
0x00000108:  bd80       pop      {r7, pc}

IN: bench_tick_done
0x00000200:  4770       bx       lr

Trace 0: 0x1 [0/00000100/0/0] bench_tick
Trace 0: 0x1 [0/00000104/0/0] bench_tick
Trace 0: 0x1 [0/00000200/0/0] bench_tick_done
Trace 0: 0x1 [0/00000100/0/0] bench_tick
Trace 0: 0x1 [0/00000108/0/0] bench_tick
Trace 0: 0x1 [0/00000200/0/0] bench_tick_done
";
        let f = measure(log.as_bytes()).unwrap();
        // push 3 + beq not taken 1 + movs 1 + pop {r7,pc} 6 = 11; push 3 + beq taken 4 + pop 6 = 13.
        assert_eq!((f.ticks, f.worst, f.mean), (2, 13, 12.0));
    }
}
