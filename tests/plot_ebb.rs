//! End to end with an EiBotBoard: `plotter sim --pty --ebb` serves the project's EBB emulator on a
//! pseudo-terminal, and `plotter plot … --port <pty> --firmware ebb --profile samples/axidraw-v3.toml` streams
//! `LM`/`SP` commands to it. The emulator's trace (motor positions after every step, the pen state, the motion
//! time) tells whether the board ran the plan in the planned time, closed closed curves, and ended with the pen up.

use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use plotter_e2e::{SimPty, Trace, plotter_bin, plotter_with_input, sample, scratch};

/// The profile's pen settle, s: `home` raises the pen with it (and enables the motors, one interval) before the
/// plan starts, so the board's motion time is the plan's plus this.
const HOME_S: f64 = 0.126 + 40e-6;

fn axidraw() -> String {
    sample("axidraw-v3.toml").to_str().expect("utf-8 path").to_string()
}

/// Run a plot; returns (success, stdout, stderr). `answers` go to stdin (one line per pen-change prompt).
fn plot(dir: &std::path::Path, args: &[&str], answers: &str) -> (bool, String, String) {
    // --verbose: the tests read the planned time to the millisecond and the EBB's short moves.
    let args: Vec<&str> = args.iter().copied().chain(["--verbose"]).collect();
    let out = plotter_with_input(dir, &args, answers);
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// The planned time printed by `plotter plot`, s.
fn planned_s(stdout: &str) -> f64 {
    let t = stdout.split("planned time ").nth(1).expect("planned time printed");
    t.split(' ').next().and_then(|v| v.parse().ok()).expect("a number of seconds")
}

/// XY steps of motor positions (motor 1 = X+Y, motor 2 = X−Y), doubled to stay integral mid-step.
fn xy2(p: [i64; 3]) -> (i64, i64) {
    (p[0] + p[1], p[0] - p[1])
}

/// Pen-down runs of the trace (its third column is 1 with the pen up).
fn runs(trace: &Trace) -> Vec<Vec<(i64, i64)>> {
    trace.pen_down_runs(1).iter().map(|r| r.iter().map(|s| (i64::from(s.x), i64::from(s.y))).collect()).collect()
}

fn check_board(trace: &Trace, planned: f64) {
    let ran = trace.busy_ticks as f64 / 1e6 - HOME_S;
    assert!((ran - planned).abs() <= planned * 1e-3, "board ran {ran:.6} s, plan {planned:.6} s");
    assert_eq!(SimPty::figure(trace, "ebb", "errors"), Some(0));
    assert_eq!(SimPty::figure(trace, "ebb", "estops"), Some(0));
    assert_eq!(SimPty::figure(trace, "ebb", "pen_up"), Some(1), "the plot ends with the pen up");
}

#[test]
fn the_duck_plots_on_ebb_firmware_3_and_2_in_the_planned_time() {
    for (version, fifo) in [("3.0.2", "FIFO 16"), ("2.8.1", "FIFO 1")] {
        let dir = scratch(&format!("ebb-duck-{version}"));
        let sim = SimPty::start(&dir, &["--ebb", "--ebb-version", version, "--fast"]);
        let duck = sample("duck.svg");
        let profile = axidraw();
        let args = ["plot", duck.to_str().unwrap(), "--port", &sim.port, "--firmware", "ebb", "--profile", &profile];
        let (ok, stdout, stderr) = plot(&dir, &args, "");
        assert!(ok, "plot failed:\n{stderr}\n{stdout}");
        assert!(stderr.contains(&format!("EiBotBoard firmware {version}")) && stderr.contains(fifo), "{stderr}");
        assert!(stdout.contains("0 move(s) shorter than the board sustains"), "{stdout}");
        let planned = planned_s(&stdout);
        let trace = sim.stop();
        check_board(&trace, planned);
        // The board kept its FIFO full: as deep as asked on firmware 3, its one slot on 2.8.1.
        let peak = SimPty::figure(&trace, "ebb", "peak_fifo").unwrap();
        assert_eq!(peak, if version == "3.0.2" { 16 } else { 1 });
        // Pen-down steps happen only between an SP,0 and the next SP,1: every run is a stroke of the duck.
        assert!(runs(&trace).len() >= 5, "{}", runs(&trace).len());
    }
}

#[test]
fn a_spirograph_closes_exactly_on_the_board() {
    let dir = scratch("ebb-spirograph");
    let sim = SimPty::start(&dir, &["--ebb", "--fast"]);
    let profile = axidraw();
    let args =
        ["plot", "gen:spirograph?cx=150&cy=109&r=15", "--port", &sim.port, "--firmware", "ebb", "--profile", &profile];
    let (ok, stdout, stderr) = plot(&dir, &args, "");
    assert!(ok, "plot failed:\n{stderr}\n{stdout}");
    let planned = planned_s(&stdout);
    let trace = sim.stop();
    check_board(&trace, planned);
    // One closed curve: one pen-down run that ends on the motor step where it began.
    let r = runs(&trace);
    assert_eq!(r.len(), 1, "{}", r.len());
    assert_closes(&trace, "the spirograph");
}

/// The drawing's last pen-down step is the step where its first stroke began. The drop is commanded during the
/// last part of the travel (the pen hop overlaps it), so the pen-down run starts on the travel and passes the
/// stroke's start early on: the end must be one of the first half of the run's positions.
fn assert_closes(trace: &Trace, what: &str) {
    let start = trace.positions.iter().position(|p| p[2] == 0).expect("pen went down");
    let run_end = (start..trace.positions.len()).find(|&i| trace.positions[i][2] != 0).unwrap_or(trace.positions.len());
    let end = xy2(*trace.positions.iter().rev().find(|p| p[2] == 0).unwrap());
    let early: Vec<(i64, i64)> =
        trace.positions[start..start + (run_end - start) / 2].iter().map(|p| xy2(*p)).collect();
    assert!(early.contains(&end), "{what} ends at {end:?}, not on a step of its start ({:?} …)", early.first());
}

#[test]
fn three_pens_stop_for_two_pen_changes_on_the_board() {
    let dir = scratch("ebb-three-pens");
    let sim = SimPty::start(&dir, &["--ebb", "--fast"]);
    let svg = sample("three-pens.svg");
    let profile = axidraw();
    let args = [
        "plot",
        svg.to_str().unwrap(),
        "--port",
        &sim.port,
        "--firmware",
        "ebb",
        "--profile",
        &profile,
        "--no-optimize",
        "--pen-change",
        "prompt",
    ];
    let (ok, stdout, stderr) = plot(&dir, &args, "\n\n");
    assert!(ok, "plot failed:\n{stderr}\n{stdout}");
    assert!(stdout.contains("pen changes: 2"), "{stdout}");
    let trace = sim.stop();
    assert_eq!(SimPty::figure(&trace, "ebb", "errors"), Some(0));
    assert_eq!(SimPty::figure(&trace, "ebb", "pen_up"), Some(1));
    // Seven strokes (frame, horizon; circle, three rays; wave), as on the other firmwares.
    let moving = runs(&trace).into_iter().filter(|r| r.iter().any(|p| *p != r[0])).count();
    assert_eq!(moving, 7);
    // Parked at the home corner (motors at 0, 0) with the pen up twice after drawing began.
    let first_draw = trace.positions.iter().position(|p| p[2] == 0).expect("draws");
    let parked: Vec<usize> = (first_draw..trace.positions.len())
        .filter(|&i| trace.positions[i][..2] == [0, 0] && trace.positions[i][2] == 1)
        .collect();
    assert_eq!(parked.len(), 2, "{parked:?}");
}

#[test]
fn ctrl_c_stops_the_board_with_es_and_the_pen_up_and_the_journal_resumes() {
    let dir = scratch("ebb-ctrl-c");
    // Real time: the circle takes about 4 s, the interrupt comes after 1.5.
    let sim = SimPty::start(&dir, &["--ebb"]);
    let profile = axidraw();
    let circle = "gen:circle?r=30&cx=100&cy=80";
    let journal = dir.join("circle.journal");
    let args = [
        "plot",
        circle,
        "--port",
        &sim.port,
        "--firmware",
        "ebb",
        "--profile",
        &profile,
        "--pause-immediately",
        "--journal",
        journal.to_str().unwrap(),
    ];
    let child = Command::new(plotter_bin())
        .args(args)
        .current_dir(&dir)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("plotter runs");
    std::thread::sleep(Duration::from_millis(1500));
    let pid = nix::unistd::Pid::from_raw(i32::try_from(child.id()).expect("pid"));
    nix::sys::signal::kill(pid, nix::sys::signal::Signal::SIGINT).expect("interrupt the plot");
    let out = child.wait_with_output().expect("plotter exits");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(stderr.contains("aborted") && stderr.contains("--resume"), "{stderr}");
    resume_after_one_stop(&dir, &journal, sim);
}

/// The rest of the circle from the journal (the board kept its step counters, so the resume returns to where the
/// stop left it with HM and continues); the board then shows one `ES`, the pen up, no error, and two pen-down runs
/// (before the stop, after the resume) of a circle that closes where its first run began.
fn resume_after_one_stop(dir: &std::path::Path, journal: &std::path::Path, sim: SimPty) {
    let (ok, stdout, stderr) = plot(dir, &["plot", "--resume", journal.to_str().unwrap(), "--port", &sim.port], "");
    assert!(ok, "{stderr}\n{stdout}");
    assert!(stderr.contains("resuming at block"), "{stderr}");
    assert!(std::fs::read_to_string(journal).unwrap().contains("complete"));
    let trace = sim.stop();
    assert_eq!(SimPty::figure(&trace, "ebb", "estops"), Some(1), "ES interrupted the running move");
    assert_eq!(SimPty::figure(&trace, "ebb", "pen_up"), Some(1));
    assert_eq!(SimPty::figure(&trace, "ebb", "errors"), Some(0));
    let r = runs(&trace);
    assert_eq!(r.len(), 2, "{}", r.len());
    assert_closes(&trace, "the circle");
}

/// Run `plotter` with `args` in `dir`, stdin closed, its output to files; send it `signal` after `signal_after`
/// (when given), and kill it if it has not ended after `limit`. Returns (exit status or `None` when killed,
/// stdout, stderr, how long it ran).
fn run_bounded(
    dir: &std::path::Path,
    args: &[&str],
    signal: Option<(nix::sys::signal::Signal, Duration)>,
    limit: Duration,
) -> (Option<std::process::ExitStatus>, String, String, Duration) {
    let (out, err) = (dir.join("plot.out"), dir.join("plot.err"));
    let mut child = Command::new(plotter_bin())
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(std::fs::File::create(&out).expect("stdout file"))
        .stderr(std::fs::File::create(&err).expect("stderr file"))
        .spawn()
        .expect("plotter runs");
    let pid = nix::unistd::Pid::from_raw(i32::try_from(child.id()).expect("pid"));
    let t0 = Instant::now();
    let mut signalled = signal.is_none();
    let status = loop {
        if let Some(status) = child.try_wait().expect("wait for plotter") {
            break Some(status);
        }
        if let Some((sig, after)) = signal
            && !signalled
            && t0.elapsed() >= after
        {
            nix::sys::signal::kill(pid, sig).expect("signal the plot");
            signalled = true;
        }
        if t0.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            break None;
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let took = t0.elapsed();
    let read = |p: &std::path::Path| std::fs::read_to_string(p).unwrap_or_default();
    (status, read(&out), read(&err), took)
}

/// A termination signal in the middle of a plot (a service manager's stop, a closed terminal) ends it like a stop:
/// `ES` interrupts the running move, the pen goes up, the journal stays, and `--resume` draws the rest.
fn a_signal_mid_plot_stops_the_board_with_the_pen_up_and_the_journal_resumes(
    signal: nix::sys::signal::Signal,
    named: &str,
) {
    let dir = scratch(&format!("ebb-{named}"));
    // Real time: the pen draws the circle from about 1.3 s to 3.6 s after the start; the signal comes at 2.
    let sim = SimPty::start(&dir, &["--ebb"]);
    let profile = axidraw();
    let journal = dir.join("circle.journal");
    let args = [
        "plot",
        "gen:circle?r=20&cx=40&cy=40",
        "--port",
        &sim.port,
        "--firmware",
        "ebb",
        "--profile",
        &profile,
        "--journal",
        journal.to_str().unwrap(),
    ];
    let (status, _, stderr, _) =
        run_bounded(&dir, &args, Some((signal, Duration::from_millis(2000))), Duration::from_secs(30));
    let status = status.expect("the plot ends");
    assert!(!status.success(), "{stderr}");
    assert!(
        stderr.contains(&format!("stopped at once on {named}"))
            && stderr.contains("--resume")
            && stderr.contains("motion stopped (ES); the pen is up (SP,2,0,1)"),
        "{stderr}"
    );
    resume_after_one_stop(&dir, &journal, sim);
}

#[test]
fn sigterm_mid_plot_stops_the_board_with_es_and_the_pen_up_and_the_journal_resumes() {
    a_signal_mid_plot_stops_the_board_with_the_pen_up_and_the_journal_resumes(
        nix::sys::signal::Signal::SIGTERM,
        "SIGTERM",
    );
}

#[test]
fn sighup_mid_plot_stops_the_board_with_es_and_the_pen_up_and_the_journal_resumes() {
    a_signal_mid_plot_stops_the_board_with_the_pen_up_and_the_journal_resumes(
        nix::sys::signal::Signal::SIGHUP,
        "SIGHUP",
    );
}

#[test]
fn a_board_that_falls_into_blank_lines_mid_plot_is_given_up_in_seconds_with_the_pen_up() {
    let dir = scratch("ebb-blank");
    // After 60 commands (connecting and homing take about 20) the board obeys but answers only blank lines, one
    // every millisecond.
    let sim = SimPty::start(&dir, &["--ebb", "--ebb-lie", "blank@60"]);
    let profile = axidraw();
    let args = ["plot", "gen:circle?r=20&cx=40&cy=40", "--port", &sim.port, "--firmware", "ebb", "--profile", &profile];
    let (status, _, stderr, took) = run_bounded(&dir, &args, None, Duration::from_secs(30));
    let status = status.unwrap_or_else(|| panic!("the plot still waited after 30 s:\n{stderr}"));
    assert!(!status.success(), "{stderr}");
    // The answer's deadline (3 s and the queued moves ahead), then ES and the lift (about 1 s each).
    assert!(took < Duration::from_secs(15), "{took:?}");
    assert!(
        stderr.contains("gave up waiting for the answer to ")
            && stderr.contains("blank line(s)")
            && stderr.contains("SP,2,0,1"),
        "{stderr}"
    );
    let trace = sim.stop();
    assert!(!runs(&trace).is_empty(), "the lie came mid-plot, with the pen down");
    assert_eq!(SimPty::figure(&trace, "ebb", "pen_up"), Some(1), "the board still obeyed the lift");
}

#[test]
fn auto_recognises_the_board() {
    let dir = scratch("ebb-auto");
    let sim = SimPty::start(&dir, &["--ebb", "--fast"]);
    let profile = axidraw();
    let (ok, stdout, stderr) =
        plot(&dir, &["plot", "gen:circle?r=10&cx=50&cy=50", "--port", &sim.port, "--profile", &profile], "");
    assert!(ok, "{stderr}\n{stdout}");
    assert!(stderr.contains("connected to EiBotBoard firmware 3.0.2"), "{stderr}");
    let planned = planned_s(&stdout);
    // The probe's `$I` is answered with an unknown-command error: one error, nothing else.
    let trace = sim.stop();
    assert_eq!(SimPty::figure(&trace, "ebb", "errors"), Some(1));
    let ran = trace.busy_ticks as f64 / 1e6 - HOME_S;
    assert!((ran - planned).abs() <= planned * 1e-3, "{ran} vs {planned}");
}

/// plotink (the AxiDraw/NextDraw host library: a checkout of evil-mad/plotink, or the folder holding the PyPI
/// package `plotink` as .ci/run installs it, at `PLOTINK_DIR`) and a Python with
/// pyserial and packaging (`PLOTINK_PYTHON`, default `python3`), when available; otherwise the caller skips.
fn plotink(test: &str) -> Option<(String, String)> {
    let Some(dir) = std::env::var_os("PLOTINK_DIR") else {
        eprintln!("SKIP {test}: set PLOTINK_DIR to a checkout of evil-mad/plotink (and PLOTINK_PYTHON)");
        return None;
    };
    let python = std::env::var("PLOTINK_PYTHON").unwrap_or_else(|_| "python3".into());
    let ok = Command::new(&python).args(["-c", "import serial, packaging"]).status().is_ok_and(|s| s.success());
    assert!(ok, "{test}: {python} lacks pyserial or packaging");
    Some((dir.to_string_lossy().into_owned(), python))
}

#[test]
fn plotinks_ebb3_class_drives_the_emulator() {
    let Some((dir, python)) = plotink("plotinks_ebb3_class_drives_the_emulator") else { return };
    let work = scratch("ebb-plotink");
    let sim = SimPty::start(&work, &["--ebb", "--fast"]);
    let script = plotter_e2e::fixture("ebb_plotink_drive.py");
    let out = Command::new(python).arg(script).args([&dir, &sim.port]).output().expect("python runs");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{stdout}\n{}", String::from_utf8_lossy(&out.stderr));
    // plotink checks every reply of the future syntax it switches on; the square and the LM leave motor 1 at
    // 2 × 1600 + 250 and motor 2 at 250, and HM brings both home.
    assert!(stdout.contains("version 3.0.2") && stdout.contains("enabled (1, 1)"), "{stdout}");
    assert!(stdout.contains("steps after square+LM (3450, 250)"), "{stdout}");
    assert!(stdout.contains("steps after HM (0, 0) status 0x10"), "{stdout}");
    let trace = sim.stop();
    assert_eq!(SimPty::figure(&trace, "ebb", "errors"), Some(0));
}

#[test]
fn plotinks_model_of_the_step_generator_agrees_with_the_emulator() {
    use plotter_host::link::ebb::emulator::EbbEmulator;
    use plotter_host::link::ebb::messages::EbbVersion;
    let Some((dir, python)) = plotink("plotinks_model_of_the_step_generator_agrees_with_the_emulator") else {
        return;
    };
    let script = plotter_e2e::fixture("ebb_plotink_calc.py");
    let out = Command::new(python).arg(script).args([dir.as_str(), "7"]).output().expect("python runs");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).expect("utf-8");
    let mut e = EbbEmulator::new(EbbVersion(3, 0, 2));
    let (mut checked, mut wrong) = (0, Vec::new());
    for l in text.lines() {
        let f: Vec<&str> = l.split('|').collect();
        let want: Vec<i64> = f[1..].iter().map(|x| x.parse().expect("integer")).collect();
        let a: Vec<i64> = f[0].split(',').skip(1).map(|x| x.parse().expect("integer")).collect();
        if f[0].starts_with("LM") {
            // A move whose rate would pass one step per interval is no valid move (plotink's formula does not
            // model the firmware's 32-bit overflow): skipped.
            let end_rate = a[0] - a[2] / 2 + a[2] * want[0];
            if end_rate.abs() >= 1 << 31 || !(0..1i64 << 31).contains(&want[2]) {
                continue;
            }
        }
        let (busy, at) = (e.busy_intervals(), e.position()[0]);
        e.feed(format!("{}\r", f[0]).as_bytes());
        while !e.is_idle() {
            e.run_for(1);
        }
        let _ = e.take_output();
        e.feed(b"QU,200\r");
        let qu = String::from_utf8(e.take_output()).expect("ascii");
        let acc: i64 = qu.trim_start_matches("QU,").split(',').next().and_then(|v| v.trim().parse().ok()).expect("acc");
        let got = vec![i64::try_from(e.busy_intervals() - busy).expect("small"), e.position()[0] - at, acc];
        checked += 1;
        if got != want {
            wrong.push(format!("{} ran {got:?}, plotink says {want:?}", f[0]));
        }
    }
    assert!(checked > 2500, "{checked}");
    assert!(wrong.is_empty(), "{} of {checked} disagree: {:?}", wrong.len(), &wrong[..wrong.len().min(5)]);
}

/// saxi (the npm package, 0.15: `SAXI_DIR` is its folder, e.g. `node_modules/saxi`, as .ci/run installs it) and
/// `node`, when available; otherwise the caller skips.
fn saxi(test: &str) -> Option<String> {
    let Some(dir) = std::env::var_os("SAXI_DIR") else {
        eprintln!("SKIP {test}: set SAXI_DIR to the folder of the npm package saxi (0.15)");
        return None;
    };
    let ok = Command::new("node").arg("--version").status().is_ok_and(|s| s.success());
    assert!(ok, "{test}: SAXI_DIR is set but node does not run");
    Some(dir.to_string_lossy().into_owned())
}

#[test]
fn saxi_plans_and_drives_the_emulator_and_the_board_draws_its_square_and_circle() {
    let Some(dir) = saxi("saxi_plans_and_drives_the_emulator_and_the_board_draws_its_square_and_circle") else {
        return;
    };
    let work = scratch("ebb-saxi");
    // saxi lifts to 17750 and lowers to 15700 with raw S2 positions: the tip touches the paper below 16725.
    let sim = SimPty::start(&work, &["--ebb", "--fast", "--ebb-pen-contact", "16725"]);
    let script = plotter_e2e::fixture("ebb_saxi_drive.js");
    let out = Command::new("node").arg(script).args([&dir, &sim.port]).output().expect("node runs");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{stdout}\n{}", String::from_utf8_lossy(&out.stderr));
    assert!(
        stdout.contains("version EBBv13_and_above EB Firmware Version 3.0.2") && stdout.contains("done"),
        "{stdout}"
    );
    let planned: f64 = stdout
        .split("planned ")
        .nth(1)
        .and_then(|t| t.split(' ').next())
        .and_then(|v| v.parse().ok())
        .expect("saxi's planned duration");
    let trace = sim.stop();
    assert_eq!(SimPty::figure(&trace, "ebb", "errors"), Some(0));
    assert_eq!(SimPty::figure(&trace, "ebb", "pen_up"), Some(1), "saxi ends with the pen up");
    // saxi's own plan duration (moves and pen motions) against the board's motion time: within 1 %.
    let ran = trace.busy_ticks as f64 / 1e6;
    assert!((ran - planned).abs() <= planned * 0.01, "board ran {ran:.4} s, saxi planned {planned:.4} s");
    // What the pen drew, in mm (40 motor steps per mm; motor 1 = X+Y, motor 2 = X−Y): the square, then the circle.
    let mm = |p: &[i64; 3]| {
        let (x2, y2) = xy2(*p);
        (x2 as f64 / 80.0, y2 as f64 / 80.0)
    };
    let mut down: Vec<Vec<(f64, f64)>> = Vec::new();
    let mut was_down = false;
    for p in &trace.positions {
        let here = p[2] < 1;
        if here && !was_down {
            down.push(Vec::new());
        }
        if here {
            down.last_mut().expect("a run").push(mm(p));
        }
        was_down = here;
    }
    assert_eq!(down.len(), 2, "two pen-down paths");
    // Each pen-down position lies on the drawing: within 0.1 mm (4 steps; the H-bot's motors step one at a time, so
    // the carriage zigzags by half a step about the line) of the square's sides, of the circle's radius.
    let off_square = |&(x, y): &(f64, f64)| {
        let (dx, dy) = ((x - 40.0).abs(), (y - 40.0).abs());
        if dx.max(dy) >= 20.0 { (dx - 20.0).max(dy - 20.0) } else { (20.0 - dx).min(20.0 - dy) }
    };
    let worst = down[0].iter().map(off_square).fold(0.0, f64::max);
    assert!(worst <= 0.1, "the square's ink strays {worst} mm from its sides");
    let worst = down[1].iter().map(|&(x, y)| ((x - 90.0).hypot(y - 40.0) - 15.0).abs()).fold(0.0, f64::max);
    assert!(worst <= 0.1, "the circle's ink strays {worst} mm from its radius");
    // And the whole drawing is drawn: every corner of the square and every degree of the circle is inked within
    // 0.1 mm, so the pen-down length matches the drawing's.
    let near = |run: &[(f64, f64)], (px, py): (f64, f64)| run.iter().any(|&(x, y)| (x - px).hypot(y - py) <= 0.1);
    for corner in [(20.0, 20.0), (60.0, 20.0), (60.0, 60.0), (20.0, 60.0)] {
        assert!(near(&down[0], corner), "corner {corner:?} not drawn");
    }
    for deg in 0..360 {
        let a = f64::from(deg).to_radians();
        let p = (90.0 + 15.0 * a.cos(), 40.0 + 15.0 * a.sin());
        assert!(near(&down[1], p), "the circle at {deg}° not drawn");
    }
}
