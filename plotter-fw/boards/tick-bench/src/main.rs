//! # tick-bench — what one stepper interrupt costs on a Cortex-M4F
//!
//! Runs the firmware core on QEMU's `mps2-an386` (a Cortex-M4 with FPU, like the STM32L476) with a HAL that
//! does exactly what the Nucleo board's does per call — the same GPIO set/reset stores, the same TIM2 compare
//! register reads and writes, the same [`plotter_board::debounce`] and [`plotter_board::deadline`] code — but on
//! registers that live in RAM (the mps2 has no STM32 peripherals). `cargo xtask tick-cost` runs it with QEMU's
//! execution trace and prices every instruction executed between [`bench_tick`]'s entry and
//! [`bench_tick_done`] with the Cortex-M4's documented cycle counts.
//!
//! [`bench_tick`] is the body of the Nucleo's TIM2 interrupt: acknowledge the compare flag, then
//! `Machine::on_timer` through the critical section. The workload is the worst this firmware sees: moves of
//! three axes at once (every event steps several axes), short blocks with acceleration and deceleration at
//! every event (a square root per event), a block change at every block end (the next block's profile is
//! computed in the interrupt), hard limits watched (an endstop read and debounce per event), and a feed hold
//! that decelerates across block boundaries.
#![no_std]
#![no_main]

use core::ptr::addr_of_mut;

use cortex_m_rt::entry;
use cortex_m_semihosting::{debug, hprintln};
use plotter_board::deadline::Deadline;
use plotter_board::debounce::Debouncer;
use plotter_board::shared::Shared;
use plotter_fw::hal::{Clock, Endstops, SerialOut, StepPins, StepTimer};
use plotter_fw::machine::Machine;
use plotter_fw::{Axis, MachineConfig};

/// Stand-ins for the Nucleo's registers: GPIO BSRR/IDR per port, TIM2 SR/DIER/CNT/CCR1/CCR2.
static mut REGS: [u32; 16] = [0; 16];
const BSRR_A: usize = 0;
const BSRR_B: usize = 1;
const IDR_A: usize = 2;
const IDR_B: usize = 3;
const IDR_C: usize = 4;
const SR: usize = 5;
const DIER: usize = 6;
const CNT: usize = 7;
const CCR1: usize = 8;
const CCR2: usize = 9;

#[inline(always)]
fn rd(i: usize) -> u32 {
    // SAFETY: an index into the static register array; volatile like a peripheral access.
    unsafe { addr_of_mut!(REGS).cast::<u32>().add(i).read_volatile() }
}

#[inline(always)]
fn wr(i: usize, v: u32) {
    // SAFETY: as for `rd`.
    unsafe { addr_of_mut!(REGS).cast::<u32>().add(i).write_volatile(v) }
}

/// Port register and pin of each step/dir pin, as on the Nucleo (A = 0, B = 1).
const STEP: [(usize, u32); 4] = [(BSRR_A, 10), (BSRR_B, 3), (BSRR_B, 5), (BSRR_A, 6)];
const DIR: [(usize, u32); 4] = [(BSRR_B, 4), (BSRR_B, 10), (BSRR_A, 8), (BSRR_A, 5)];
const ENDSTOP: [(usize, u32); 3] = [(IDR_C, 7), (IDR_B, 6), (IDR_A, 7)];

/// Axis `I`'s step pin high when it is in `mask` (written out per axis, as the Nucleo board does).
#[inline(always)]
fn step_pin<const I: usize>(mask: u8) {
    if mask & (1 << I) != 0 {
        let (r, n) = STEP[I];
        wr(r, 1 << n);
    }
}

/// Switch `I` as a mask bit: set when its pin reads low (pressed).
#[inline(always)]
fn endstop_low<const I: usize>() -> u8 {
    let (r, n) = ENDSTOP[I];
    u8::from(rd(r) & (1 << n) == 0) << I
}

struct BenchHal {
    deadline: Deadline,
    debounce: Debouncer,
    armed: bool,
    /// Steps emitted (for the steps-per-event figure).
    steps: u32,
    /// Simulated time, µs.
    time: u64,
}

impl StepPins for BenchHal {
    #[inline]
    fn set_dir(&mut self, axis: Axis, level: bool) {
        let (r, n) = DIR[axis.index()];
        wr(r, if level { 1 << n } else { 1 << (n + 16) });
    }
    #[inline]
    fn step(&mut self, axis: Axis) {
        let (r, n) = STEP[axis.index()];
        wr(r, 1 << n);
        self.steps += 1;
        wr(CCR2, rd(CNT).wrapping_add(3));
        wr(SR, !4);
        wr(DIER, rd(DIER) | 4);
    }
    /// As the Nucleo board: the event's step pins, then one pulse-end compare.
    #[inline]
    fn step_axes(&mut self, mask: u8) {
        step_pin::<0>(mask);
        step_pin::<1>(mask);
        step_pin::<2>(mask);
        step_pin::<3>(mask);
        self.steps += mask.count_ones();
        wr(CCR2, rd(CNT).wrapping_add(3));
        wr(SR, !4);
        wr(DIER, rd(DIER) | 4);
    }
    fn enable_motors(&mut self, _on: bool) {}
}

impl Endstops for BenchHal {
    #[inline]
    fn pressed(&mut self) -> u8 {
        let raw = endstop_low::<0>() | endstop_low::<1>() | endstop_low::<2>();
        if raw == 0 && self.debounce.is_quiet() {
            return 0;
        }
        let now = self.now();
        self.debounce.update(raw, now)
    }
}

impl StepTimer for BenchHal {
    fn schedule(&mut self, ticks: u32) {
        let at = self.deadline.schedule(self.now(), ticks);
        #[allow(clippy::cast_possible_truncation, reason = "the compare register holds the low 32 bits")]
        let at32 = at as u32;
        wr(CCR1, at32);
        wr(SR, !2);
        wr(DIER, rd(DIER) | 2);
        #[allow(clippy::cast_possible_wrap, reason = "wrapping difference of two counter values")]
        if rd(CNT).wrapping_sub(at32) as i32 >= 0 {
            wr(SR, 2);
        }
        self.armed = true;
        self.time = at;
    }
    fn cancel(&mut self) {
        wr(DIER, rd(DIER) & !2);
        self.deadline.cancel();
        self.armed = false;
    }
}

impl SerialOut for BenchHal {
    fn write(&mut self, _bytes: &[u8]) {}
}

impl Clock for BenchHal {
    #[inline]
    fn now(&self) -> u64 {
        // As the Nucleo's: the 32-bit counter and the overflow count.
        let cnt = rd(CNT);
        let pending = rd(SR) & 1 != 0;
        let wraps = (self.time >> 32) + u64::from(pending && cnt < u32::MAX / 2);
        (wraps << 32) | u64::from(cnt)
    }
}

static MACHINE: Shared<BenchHal> = Shared::new();

/// The Nucleo's TIM2 interrupt body.
#[unsafe(no_mangle)]
#[inline(never)]
pub extern "C" fn bench_tick() {
    let sr = rd(SR) & rd(DIER);
    wr(SR, !sr);
    if sr & 2 != 0 || sr == 0 {
        MACHINE.on_timer();
    }
}

/// The Nucleo's pulse-end work (TIM2 compare 2): clear every step pin, stop the compare interrupt.
#[unsafe(no_mangle)]
#[inline(never)]
pub extern "C" fn bench_pulse_end() {
    let sr = rd(SR) & rd(DIER);
    wr(SR, !sr);
    if sr & 4 != 0 {
        for &(r, n) in &STEP {
            wr(r, 1 << (n + 16));
        }
        wr(DIER, rd(DIER) & !4);
    }
}

/// Marks the end of a measured tick in the execution trace.
#[unsafe(no_mangle)]
#[inline(never)]
pub extern "C" fn bench_tick_done() {
    cortex_m::asm::nop();
}

/// The workload, G-code.
const PROGRAM: &[&[u8]] = &[
    b"G91\n",
    // A long three-axis move: acceleration, cruise and deceleration.
    b"G1 X12 Y8 Z2 F9000\n",
    // Short zig-zag moves: sharp corners, so every block accelerates and decelerates; direction changes.
    b"G1 X0.6 Y0.5 Z0.2 F6000\n",
    b"G1 X-0.5 Y0.6 Z-0.2\n",
    b"G1 X0.6 Y-0.4 Z0.2\n",
    b"G1 X-0.6 Y-0.5 Z-0.2\n",
];

fn feed(line: &[u8]) {
    for &b in line {
        MACHINE.receive(b);
    }
}

#[entry]
fn main() -> ! {
    // Endstops released (pins high).
    wr(IDR_A, 0xFFFF);
    wr(IDR_B, 0xFFFF);
    wr(IDR_C, 0xFFFF);
    let cfg = MachineConfig::xy_plotter();
    let hal = BenchHal { deadline: Deadline::new(), debounce: Debouncer::new(1_000), armed: false, steps: 0, time: 0 };
    MACHINE.install(Machine::new(hal, cfg));
    let mut ticks = 0u32;
    let mut lines = 0usize;
    let mut held = false;
    loop {
        // The timer "fires": the counter jumps to the compare value.
        let armed = MACHINE.with(|m| m.hal().armed).unwrap_or(false);
        if armed {
            #[allow(clippy::cast_possible_truncation, reason = "the counter holds the low 32 bits")]
            MACHINE.with(|m| wr(CNT, m.hal().time as u32));
            bench_tick();
            bench_tick_done();
            wr(SR, rd(SR) | 4);
            bench_pulse_end();
            bench_tick_done();
            ticks += 1;
            // A feed hold in the middle of the zig-zags, resumed once stopped.
            if ticks == 1_500 {
                MACHINE.receive(b'!');
                held = true;
            }
        }
        let (idle, held_now, room) = MACHINE
            .with(|m| {
                m.poll();
                (m.is_idle(), m.state() == plotter_fw::realtime::MachineState::Held, m.rx_free())
            })
            .unwrap_or((true, false, 0));
        if held && held_now {
            held = false;
            MACHINE.receive(b'~');
            continue;
        }
        // Keep the planner queue filled, so block changes happen inside the interrupt as in a real plot.
        if room > 64 {
            let next = match lines {
                0 | 1 => Some(PROGRAM[lines]),
                n if n < 2 + 4 * 12 => Some(PROGRAM[2 + (n - 2) % 4]),
                _ => None,
            };
            if let Some(next) = next {
                feed(next);
                lines += 1;
                continue;
            }
        }
        if idle && lines >= 2 + 4 * 12 {
            break;
        }
    }
    let steps = MACHINE.with(|m| m.hal().steps).unwrap_or(0);
    hprintln!("tick-bench: {} ticks {} steps", ticks, steps);
    debug::exit(debug::EXIT_SUCCESS);
    loop {
        cortex_m::asm::bkpt();
    }
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo<'_>) -> ! {
    hprintln!("tick-bench panicked: {}", info);
    debug::exit(debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::bkpt();
    }
}
