//! End to end on the emulated microcontroller: the real firmware image (`qemu-lm3s6965` board) runs under
//! `qemu-system-arm`, `plotter sim --qemu` puts its UART on a pty, counts the step pulses from QEMU's GPIO trace
//! and drives the endstops — all outside the firmware. Checked here:
//!
//! - homing against those endstops, then `plotter plot samples/duck.svg --port <pty>` (scaled to 30 % to keep
//!   CI quick): the pulses counted per axis equal the host plan's step totals exactly, the net motion is the
//!   plan's, and `M114` reports the planned end;
//! - `?` status, feed hold (`!`) and resume (`~`): motion stops (no pulses while held) and completes exactly;
//! - bad input over the real UART path (garbage bytes, an overlong line, a step frame with a damaged CRC)
//!   gets exactly the replies the host simulator gives for the same bytes, and nothing runs that should not.
//!
//! Skipped with a message when `qemu-system-arm` is absent outside CI; in CI (`CI` set) its absence fails.

use std::path::Path;
use std::time::Duration;

use plotter_e2e::{RawPort, SimPty, plotter, qemu_available, sample, scratch};
use plotter_fw::MachineConfig;
use plotter_fw::protocol::{Encoder, MAX_FRAME};
use plotter_fw::sim::Sim;
use plotter_fw::step_block::StepBlock;
use plotter_path::geometry::layout::{self, LayoutOptions};
use plotter_path::geometry::steps::drawing_to_steps;
use plotter_path::motion::plan::{self, Lookahead};
use plotter_path::{MachineProfile, input::svg};

const SCALE: f64 = 0.3;
// How long the line stays silent before a chunk's replies count as complete: three times the 0.4 s that sufficed on an
// idle machine, so a loaded one does not split one chunk's replies into the next.
const QUIET: Duration = Duration::from_millis(1200);
const LIMIT: Duration = Duration::from_secs(30);

fn ok(out: &std::process::Output) -> String {
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(out.status.success(), "plotter failed: {}\n{stdout}", String::from_utf8_lossy(&out.stderr));
    stdout
}

/// Step lines in a trace written so far (`t x y z`, one per pulse).
fn trace_lines(path: &Path) -> Vec<[i64; 3]> {
    let text = std::fs::read_to_string(path).unwrap_or_default();
    text.lines()
        .filter(|l| !l.starts_with('#') && l.ends_with(|c: char| c.is_ascii_digit()))
        .map(|l| {
            let v: Vec<i64> = l.split_whitespace().skip(1).map(|t| t.parse().expect("integer")).collect();
            [v[0], v[1], v[2]]
        })
        .collect()
}

/// Trace lines once the trace has stopped growing (the machine is idle and every pulse has been read).
fn settled_trace(path: &Path) -> Vec<[i64; 3]> {
    let mut last = trace_lines(path);
    loop {
        std::thread::sleep(QUIET);
        let now = trace_lines(path);
        if now.len() == last.len() {
            return now;
        }
        last = now;
    }
}

/// Pulses per axis (X, Y, Z) between consecutive positions, and the net motion.
fn pulses(positions: &[[i64; 3]], from: [i64; 3]) -> ([u64; 3], [i64; 3]) {
    let mut counts = [0u64; 3];
    let mut prev = from;
    for p in positions {
        for i in 0..3 {
            let d = p[i] - prev[i];
            assert!(d.abs() <= 1, "one pulse per trace line: {prev:?} -> {p:?}");
            counts[i] += d.unsigned_abs();
        }
        assert_eq!(p.iter().zip(&prev).filter(|(a, b)| a != b).count(), 1, "{prev:?} -> {p:?}");
        prev = *p;
    }
    let net = [prev[0] - from[0], prev[1] - from[1], prev[2] - from[2]];
    (counts, net)
}

fn count_field(m114: &str, axis: &str) -> i64 {
    let counts = m114.split("Count").nth(1).expect("Count part");
    counts
        .split_whitespace()
        .find_map(|w| w.strip_prefix(&format!("{axis}:")))
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("no {axis} count in {m114:?}"))
}

#[test]
fn duck_on_the_emulated_board_steps_exactly_the_plan() {
    if !qemu_available("duck_on_the_emulated_board_steps_exactly_the_plan") {
        return;
    }
    let dir = scratch("qemu-duck");
    let sim = SimPty::start_qemu(&dir);
    // Homing against the endstops `sim --qemu` drives from the counted pulses.
    let home = ok(&plotter(&dir, &["home", "--port", &sim.port]));
    assert!(home.contains("homed: X 0.00 Y 0.00 mm, pen up"), "{home}");
    let homing = settled_trace(sim.trace_path());
    assert!(homing.len() > 1_000, "homing moved every axis to its switch and back: {} pulses", homing.len());
    let start_phys = *homing.last().expect("homing pulses");

    let duck = sample("duck.svg");
    let scale = SCALE.to_string();
    let out = ok(&plotter(
        &dir,
        &["plot", duck.to_str().unwrap(), "--port", &sim.port, "--no-home", "--no-optimize", "--scale", &scale, "-v"],
    ));
    assert!(out.contains("0 resends"), "{out}");

    // The host plan, computed here from the library: the same drawing, layout and start position.
    let profile = MachineProfile::default_plotter();
    let opts = svg::SvgOptions { tolerance_mm: svg::DEFAULT_TOLERANCE_MM, ..svg::SvgOptions::default() };
    let bytes = std::fs::read(&duck).unwrap();
    let mut drawing = svg::import_svg(&bytes, "duck.svg", &svg::ResourcePolicy::DataUrlsOnly, &opts).unwrap().drawing;
    layout::apply(&mut drawing, &LayoutOptions { scale: Some(SCALE), ..LayoutOptions::default() }).unwrap();
    let steps = drawing_to_steps(&profile, &drawing).unwrap();
    let plan = plan::plan(&profile, &steps, [0, 0, 1600, 0], Lookahead::Whole).unwrap();
    let mut planned = [0u64; 3];
    for b in &plan.blocks {
        for (i, p) in planned.iter_mut().enumerate() {
            *p += u64::from(b.block.steps[i].unsigned_abs());
        }
    }
    assert!(out.contains(&format!("{} blocks", plan.blocks.len())), "{out}");

    let all = settled_trace(sim.trace_path());
    let (counted, net) = pulses(&all[homing.len()..], start_phys);
    eprintln!("step pulses counted from QEMU's GPIO trace {counted:?}, host plan {planned:?}");
    assert_eq!(counted, planned, "pulses per axis (X, Y, Z) against the host plan");
    let planned_net: Vec<i64> = (0..3).map(|i| i64::from(plan.end[i] - plan.start[i])).collect();
    assert_eq!(net.to_vec(), planned_net);

    let mut port = RawPort::open(&sim.port);
    port.lines_until_quiet(QUIET, LIMIT);
    port.send(b"M114\n");
    let lines = port.lines_until(|l| l == "ok", LIMIT);
    let m114 = lines.iter().find(|l| l.contains("Count")).expect("M114 answer");
    for (i, axis) in ["X", "Y", "Z"].iter().enumerate() {
        assert_eq!(count_field(m114, axis), i64::from(plan.end[i]), "{m114}");
    }
    drop(port);
    let trace = sim.trace_path().to_path_buf();
    sim.stop();
    assert_eq!(trace_lines(&trace).len(), all.len(), "no pulse after the plot");
}

/// The state field of a status report.
fn state(line: &str) -> &str {
    line.trim_start_matches('<').split('|').next().unwrap_or("")
}

fn status(port: &mut RawPort) -> String {
    port.send(b"?");
    let lines = port.lines_until(|l| l.starts_with('<'), LIMIT);
    lines.into_iter().rfind(|l| l.starts_with('<')).expect("a status report")
}

#[test]
fn status_feed_hold_and_resume_on_the_emulated_board() {
    if !qemu_available("status_feed_hold_and_resume_on_the_emulated_board") {
        return;
    }
    let dir = scratch("qemu-hold");
    let sim = SimPty::start_qemu(&dir);
    let mut port = RawPort::open(&sim.port);
    assert!(status(&mut port).starts_with("<Idle|"));
    // 60 mm at 20 mm/s: about three seconds of motion, X only.
    port.send(b"G1 X60 F1200\n");
    port.lines_until(|l| l == "ok", LIMIT);
    std::thread::sleep(Duration::from_millis(800));
    assert!(status(&mut port).starts_with("<Run|"));
    port.send(b"!");
    std::thread::sleep(Duration::from_millis(600));
    let held = status(&mut port);
    assert_eq!(state(&held), "Hold:0", "{held}");
    let before = settled_trace(sim.trace_path()).len();
    std::thread::sleep(Duration::from_millis(500));
    let still = status(&mut port);
    assert_eq!(still, held, "nothing moves while held");
    assert_eq!(trace_lines(sim.trace_path()).len(), before, "no pulse while held");
    assert!(before > 100 && before < 4_800, "held part-way: {before} pulses");
    port.send(b"~");
    port.lines_until_quiet(Duration::from_millis(100), LIMIT);
    let deadline = std::time::Instant::now() + LIMIT;
    while !status(&mut port).starts_with("<Idle|") {
        assert!(std::time::Instant::now() < deadline, "never finished after resume");
        std::thread::sleep(Duration::from_millis(200));
    }
    port.send(b"M114\n");
    let lines = port.lines_until(|l| l == "ok", LIMIT);
    let m114 = lines.iter().find(|l| l.contains("Count")).expect("M114");
    assert_eq!(count_field(m114, "X"), 4_800, "{m114}");
    let all = settled_trace(sim.trace_path());
    let (counted, net) = pulses(&all, [0, 0, 0]);
    assert_eq!((counted, net), ([4_800, 0, 0], [4_800, 0, 0]), "pulses counted outside the firmware");
}

/// The replies (without the start-up note and banner) to each chunk, from the in-process simulator.
fn sim_replies(chunks: &[Vec<u8>]) -> Vec<Vec<String>> {
    let mut sim = Sim::new(MachineConfig::xy_plotter());
    sim.take_replies();
    chunks
        .iter()
        .map(|c| {
            sim.feed(c);
            sim.run_until_idle();
            sim.take_replies()
        })
        .collect()
}

#[test]
fn bad_input_over_the_uart_behaves_as_in_the_simulator() {
    if !qemu_available("bad_input_over_the_uart_behaves_as_in_the_simulator") {
        return;
    }
    let mut enc = Encoder::new();
    let mut frame = [0u8; MAX_FRAME];
    let block = StepBlock {
        steps: [400, 160, 0, 0],
        entry_rate: 0,
        cruise_rate: 4_000,
        exit_rate: 0,
        accel: 40_000,
        dwell_ticks: 0,
        servo: None,
    };
    let n = enc.encode(&block, 0, &mut frame).unwrap();
    let good = frame[..n].to_vec();
    // Damage the CRC: the byte before the terminator (kept below 0x80 and off the escape/marker values).
    let mut bad_crc = good.clone();
    let at = bad_crc.len() - 2;
    bad_crc[at] ^= 0x01;
    let chunks: Vec<Vec<u8>> = vec![
        b"\x01\x02 garbage \x7f;;\n".to_vec(),
        b"Q1 X5\n".to_vec(),
        [b"G1 X".to_vec(), vec![b'1'; 200], b"\n".to_vec()].concat(),
        bad_crc,
        good,
        b"G4 P1\n".to_vec(),
        b"?".to_vec(),
    ];
    let expected = sim_replies(&chunks);

    let dir = scratch("qemu-bad");
    let sim = SimPty::start_qemu(&dir);
    let mut port = RawPort::open(&sim.port);
    // QEMU notices a newly opened pty within a second; a status report shows the line is up.
    status(&mut port);
    let mut got = Vec::new();
    for c in &chunks {
        port.send(c);
        got.push(port.lines_until_quiet(QUIET, LIMIT));
    }
    for (i, (g, e)) in got.iter().zip(&expected).enumerate() {
        assert_eq!(g, e, "chunk {i} ({:?}): emulated board vs simulator", String::from_utf8_lossy(&chunks[i]));
    }
    // And what they are: errors for the garbage and the long line, a resend for the damaged frame, then the
    // good frame runs (400 X and 160 Y pulses, nothing else).
    assert!(expected[0].iter().all(|l| l.starts_with("error:")), "{:?}", expected[0]);
    assert!(expected[2][0].starts_with("error:"), "{:?}", expected[2]);
    assert_eq!(expected[3], ["rs 0"]);
    assert_eq!(expected[4], ["ok"]);
    let all = settled_trace(sim.trace_path());
    assert_eq!(pulses(&all, [0, 0, 0]), ([400, 160, 0], [400, 160, 0]));
}

/// The processes whose parent is `parent` and whose command name is `name` (from `/proc/<pid>/stat`).
fn children_named(parent: i32, name: &str) -> Vec<i32> {
    let mut found = Vec::new();
    for entry in std::fs::read_dir("/proc").expect("/proc").flatten() {
        let Ok(pid) = entry.file_name().to_string_lossy().parse::<i32>() else { continue };
        let Ok(stat) = std::fs::read_to_string(format!("/proc/{pid}/stat")) else { continue };
        // "pid (comm) state ppid ...": the name may hold spaces, so split after its closing parenthesis.
        let (Some(open), Some(close)) = (stat.find('('), stat.rfind(')')) else { continue };
        let ppid = stat[close + 1..].split_whitespace().nth(1).and_then(|p| p.parse::<i32>().ok());
        if &stat[open + 1..close] == name && ppid == Some(parent) {
            found.push(pid);
        }
    }
    found
}

/// Whether `pid` still runs (a zombie nobody reaped does not).
fn running(pid: i32) -> bool {
    std::fs::read_to_string(format!("/proc/{pid}/stat"))
        .ok()
        .and_then(|s| s.rfind(')').and_then(|c| s[c + 1..].split_whitespace().next().map(|st| st != "Z")))
        .unwrap_or(false)
}

#[test]
fn sigterm_ends_sim_qemu_and_its_emulator_with_the_trace_written() {
    if !qemu_available("sigterm_ends_sim_qemu_and_its_emulator_with_the_trace_written") {
        return;
    }
    let dir = scratch("qemu-sigterm");
    let sim = SimPty::start_qemu(&dir);
    let qemu = children_named(sim.pid(), "qemu-system-arm");
    assert_eq!(qemu.len(), 1, "one QEMU under plotter sim --qemu: {qemu:?}");
    assert!(running(qemu[0]));
    let trace_path = sim.trace_path().to_path_buf();
    sim.stop_with(nix::sys::signal::Signal::SIGTERM);
    // `stop_with` waited for plotter to exit; it kills and reaps QEMU before it does.
    assert!(!running(qemu[0]), "QEMU {} outlived plotter sim --qemu", qemu[0]);
    // The summary line is the last thing written, on the way out.
    let text = std::fs::read_to_string(&trace_path).expect("trace written");
    assert!(text.lines().last().is_some_and(|l| l.starts_with("# busy_ticks ")), "{text}");
}
