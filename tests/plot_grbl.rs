//! End to end with GRBL: `plotter sim --pty --grbl` serves the project's GRBL 1.1 emulator on a pseudo-terminal,
//! and `plotter plot samples/three-pens.svg --port <pty> --firmware grbl` streams the three-pen sample to it in a
//! scripted session that answers the two pen-change prompts. The emulator's trace tells how full its 128-byte
//! receive buffer ever got, where the carriage went, and where it ended.

use std::io::{Read as _, Write as _};
use std::process::{Command, Stdio};

use plotter_e2e::{SimPty, ink_off_drawing, machine_paths, plotter, plotter_bin, sample, scratch};
use plotter_path::{MachineProfile, input::svg};

const PROMPT: &str = "[Enter] continue, [s] skip this layer, [q] stop";

/// Run `plotter` with `args`, answering each pen-change prompt with `answers` in turn (a line each); returns the
/// exit status, stdout, stderr and the number of prompts seen.
fn scripted(dir: &std::path::Path, args: &[&str], answers: &[&str]) -> (bool, String, String, usize) {
    let mut child = Command::new(plotter_bin())
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("plotter runs");
    let mut stdin = child.stdin.take().expect("stdin");
    let mut stderr = child.stderr.take().expect("stderr");
    let mut stdout = child.stdout.take().expect("stdout");
    let out_thread = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = stdout.read_to_string(&mut s);
        s
    });
    let mut err = String::new();
    let mut prompts = 0;
    let mut buf = [0u8; 256];
    loop {
        let n = stderr.read(&mut buf).expect("read stderr");
        if n == 0 {
            break;
        }
        err.push_str(&String::from_utf8_lossy(&buf[..n]));
        // Answer each prompt once it has been shown (the plot is parked and waiting then).
        while err.matches(PROMPT).count() > prompts {
            let answer = answers.get(prompts).copied().unwrap_or("q");
            stdin.write_all(format!("{answer}\n").as_bytes()).expect("answer");
            stdin.flush().expect("flush");
            prompts += 1;
        }
    }
    drop(stdin);
    let status = child.wait().expect("plotter exits");
    (status.success(), out_thread.join().expect("stdout"), err, prompts)
}

#[test]
fn three_pens_over_a_grbl_pty_with_two_pen_changes() {
    let dir = scratch("grbl-three-pens");
    let sim = SimPty::start(&dir, &["--grbl", "--fast"]);
    let svg = sample("three-pens.svg");
    let args = [
        "plot",
        svg.to_str().unwrap(),
        "--port",
        &sim.port,
        "--firmware",
        "grbl",
        "--no-optimize",
        "--pen-change",
        "prompt",
    ];
    let (ok, stdout, stderr, prompts) = scripted(&dir, &args, &["", ""]);
    assert!(ok, "plot failed:\n{stderr}\n{stdout}");
    assert_eq!(prompts, 2, "{stderr}");
    assert!(stderr.contains("connected to GRBL 1.1h"), "{stderr}");
    assert!(stderr.contains("load pen red fineliner 0.5 (#ff0000)") && stderr.contains("load pen blue brush pen"));
    assert!(stdout.contains("pen changes: 2"), "{stdout}");
    let trace = sim.stop();
    // Never more than the receive buffer in flight, nothing lost.
    let peak = SimPty::figure(&trace, "grbl", "peak_rx").expect("peak");
    assert!(peak > 64 && peak <= 128, "{peak}");
    assert_eq!(SimPty::figure(&trace, "grbl", "overflow"), Some(0));
    assert_eq!(SimPty::figure(&trace, "grbl", "errors"), Some(0));
    // In file order the last stroke is the blue wave, ending at (85, 50) mm = (6800, 4000) steps at 80 steps/mm,
    // pen up at 4 mm × 400 steps/mm.
    let pos: Vec<i64> = ["position"]
        .iter()
        .flat_map(|_| trace.comments.iter().find(|c| c.starts_with("position")))
        .flat_map(|c| c.split_whitespace().skip(1).map(|v| v.parse::<i64>().expect("int")))
        .collect();
    assert_eq!(pos, [6800, 4000, 1600]);
    assert_eq!(trace.positions.last().copied(), Some([6800, 4000, 1600]));
    // Never below the 1 mm clearance (400 steps) off the drawing, though the hops move Z on the way.
    let profile = MachineProfile::default_plotter();
    let data = std::fs::read(&svg).expect("sample");
    let drawing =
        svg::import_svg(&data, "three-pens.svg", &svg::ResourcePolicy::DataUrlsOnly, &svg::SvgOptions::default())
            .expect("svg")
            .drawing;
    let samples = trace.positions.iter().map(|p| (p[2] < 400, [p[0], p[1]]));
    let off = ink_off_drawing(samples, &machine_paths(&profile, &drawing), 80.0, svg::DEFAULT_TOLERANCE_MM);
    assert!(off.is_empty(), "{} positions below the clearance off the drawing: {:?}", off.len(), off.first());
    assert!(trace.mixed_xy_z_steps() > 0, "no XY+Z travel");
    // Seven strokes (frame, horizon; circle, three rays; wave), and the carriage parked at the home corner with
    // the pen up between the layers: after the black horizon (2nd run) and after the last red ray (6th run).
    let runs = trace.pen_down_runs(400);
    let moving: Vec<_> = runs.iter().filter(|r| r.iter().any(|p| *p != r[0])).collect();
    assert_eq!(moving.len(), 7, "{}", moving.len());
    let parked = trace.positions.iter().enumerate().filter(|(_, p)| p[0] == 0 && p[1] == 0 && p[2] == 1600);
    let first_draw = trace.positions.iter().position(|p| p[2] < 400 && (p[0], p[1]) != (0, 0)).expect("draws");
    let park_visits = parked.filter(|(i, _)| *i > first_draw).map(|(i, _)| i).collect::<Vec<_>>();
    let separate = park_visits.windows(2).filter(|w| w[1] != w[0] + 1).count() + usize::from(!park_visits.is_empty());
    assert_eq!(separate, 2, "two separate stays at the park position after drawing began");
}

#[test]
fn grbl_alarm_mid_plot_leaves_a_journal_that_resumes() {
    let dir = scratch("grbl-alarm");
    let svg = sample("three-pens.svg");
    let sim = SimPty::start(&dir, &["--grbl", "--fast", "--grbl-fault", "hard-limit@40"]);
    let journal = dir.join("three.journal");
    let args = [
        "plot",
        svg.to_str().unwrap(),
        "--port",
        &sim.port,
        "--firmware",
        "grbl",
        "--pen-change",
        "none",
        "--journal",
        journal.to_str().unwrap(),
    ];
    let out = plotter(&dir, &args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(err.contains("alarm 1 (hard limit switch triggered") && err.contains("--resume"), "{err}");
    let text = std::fs::read_to_string(&journal).expect("journal written");
    assert!(text.contains("progress") && !text.contains("complete"), "{text}");
    // The machine needs a reset after a hard limit; then the resume homes again and finishes.
    let mut port = std::fs::OpenOptions::new().write(true).open(&sim.port).expect("pty");
    port.write_all(&[0x18]).expect("reset");
    drop(port);
    let out = plotter(&dir, &["plot", "--resume", journal.to_str().unwrap(), "--port", &sim.port]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("resuming at block"), "{err}");
    assert!(std::fs::read_to_string(&journal).unwrap().contains("complete"));
    let trace = sim.stop();
    assert_eq!(SimPty::figure(&trace, "grbl", "overflow"), Some(0));
}

/// Plot the three-pen sample straight through (`--pen-change none`) on the GRBL emulator started with
/// `--grbl-fault fault`, with `extra` arguments; when `interrupt_on` appears on stderr, send the plot SIGINT (as
/// Ctrl-C does). Returns its exit status, its stderr, how long it took, and the emulator's end position
/// (`# position x y z`, steps).
fn plot_with_fault(
    name: &str,
    fault: &str,
    extra: &[&str],
    interrupt_on: Option<&str>,
) -> (Option<i32>, String, f64, Vec<i64>) {
    let dir = scratch(name);
    let sim = SimPty::start(&dir, &["--grbl", "--fast", "--grbl-fault", fault]);
    let svg = sample("three-pens.svg");
    let mut args =
        vec!["plot", svg.to_str().unwrap(), "--port", &sim.port, "--firmware", "grbl", "--pen-change", "none"];
    args.extend_from_slice(extra);
    let start = std::time::Instant::now();
    let mut child = Command::new(plotter_bin())
        .args(&args)
        .current_dir(&dir)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("plotter runs");
    let mut stderr = child.stderr.take().expect("stderr");
    let mut err = String::new();
    let mut buf = [0u8; 256];
    let mut interrupted = false;
    loop {
        let n = stderr.read(&mut buf).expect("read stderr");
        if n == 0 {
            break;
        }
        err.push_str(&String::from_utf8_lossy(&buf[..n]));
        if let Some(text) = interrupt_on
            && !interrupted
            && err.contains(text)
        {
            let pid = nix::unistd::Pid::from_raw(i32::try_from(child.id()).expect("pid"));
            nix::sys::signal::kill(pid, nix::sys::signal::Signal::SIGINT).expect("Ctrl-C");
            interrupted = true;
        }
    }
    let status = child.wait().expect("plotter exits");
    let secs = start.elapsed().as_secs_f64();
    let trace = sim.stop();
    let pos = trace
        .comments
        .iter()
        .find(|c| c.starts_with("position"))
        .map(|c| c.split_whitespace().skip(1).map(|v| v.parse::<i64>().expect("int")).collect())
        .unwrap_or_default();
    (status.code(), err, secs, pos)
}

/// Whether `err` says `what` followed by GRBL's hold state: `Hold:1` while decelerating, `Hold:0` once held.
fn held(err: &str, what: &str) -> bool {
    err.contains(&format!("{what} (Hold:0)")) || err.contains(&format!("{what} (Hold:1)"))
}

/// Pen up: Z at 4 mm × 400 steps/mm.
const PEN_UP_Z: i64 = 1600;

#[test]
fn grbl_hold_nobody_resumes_ends_with_a_message_and_the_pen_up() {
    let (code, err, secs, pos) = plot_with_fault("grbl-hold", "hold@40", &["--hold-timeout", "2"], None);
    assert_eq!(code, Some(1), "a stall is none of the typed troubles: {err}");
    // The first status seen may still be decelerating (Hold:1) or already held (Hold:0); both are a hold.
    assert!(held(&err, "reports a feed hold") && err.contains("stops by itself after 2 s on hold"), "{err}");
    assert!(held(&err, "has been in a feed hold") && err.contains("for 2 s and nobody resumed it"), "{err}");
    assert!(err.contains("stopped (soft reset); the pen is up (G91 G0 Z"), "lifted from the paper: {err}");
    assert_eq!(pos.get(2), Some(&PEN_UP_Z), "{pos:?}");
    assert!(secs < 20.0, "{secs} s");
}

#[test]
fn grbl_reset_mid_plot_ends_with_alarm_3_and_the_pen_up() {
    let (code, err, secs, pos) = plot_with_fault("grbl-reset", "reset@40", &[], None);
    assert_eq!(code, Some(3), "an alarm exits with 3: {err}");
    assert!(err.contains("alarm 3 (reset while moving; the position is probably lost"), "{err}");
    assert!(err.contains("stopped (soft reset, unlocked with $X (home before the next plot"), "{err}");
    assert!(err.contains("the pen is up (G91 G0 Z"), "lifted from the paper: {err}");
    assert_eq!(pos.get(2), Some(&PEN_UP_Z), "{pos:?}");
    assert!(secs < 20.0, "{secs} s");
}

#[test]
fn grbl_hard_limit_mid_plot_ends_with_the_pen_up() {
    let (code, err, secs, pos) = plot_with_fault("grbl-limit", "hard-limit@40", &[], None);
    assert_eq!(code, Some(3), "an alarm exits with 3: {err}");
    assert!(err.contains("alarm 1 (hard limit switch triggered"), "{err}");
    assert!(err.contains("stopped (soft reset, unlocked with $X") && err.contains("the pen is up (G91 G0 Z"), "{err}");
    assert_eq!(pos.get(2), Some(&PEN_UP_Z), "{pos:?}");
    assert!(secs < 20.0, "{secs} s");
}

#[test]
fn grbl_ctrl_c_while_held_stops_at_once_with_the_pen_up() {
    // The hold would last 30 s; Ctrl-C as soon as the plot says the controller is held.
    let (code, err, secs, pos) = plot_with_fault("grbl-hold-ctrl-c", "hold@40", &[], Some("reports a feed hold"));
    assert_eq!(code, Some(5), "stopped by the user exits with 5: {err}");
    assert!(held(&err, "stopped at once on a pause request (Ctrl-C) during a feed hold"), "{err}");
    assert!(err.contains("the pen is up (G91 G0 Z"), "lifted from the paper: {err}");
    assert_eq!(pos.get(2), Some(&PEN_UP_Z), "{pos:?}");
    assert!(secs < 20.0, "at once, not after the 30 s hold limit: {secs} s");
}

/// The servo kit's strokes for [`the_servo_kit_on_grbl_runs_its_plan_and_lands_on_each_stroke`]: hops long
/// (55 mm), middling (5 mm) and short (1.5 mm, 0.5 mm), a 0.3 mm stroke (lifted before its servo has gone fully
/// down), as in tests/pen_contact.rs, and a stroke of two lines with a 90° corner, started from rest after its
/// drop.
const SERVO_HOPS_SVG: &str = r##"<svg xmlns="http://www.w3.org/2000/svg" width="150mm" height="120mm" viewBox="0 0 150 120">
<g fill="none" stroke="#000000" stroke-width="0.3">
<path d="M20 20 L40 20"/><path d="M40.5 20 L40.5 30"/><path d="M42 30 L60 30"/><path d="M60 35 L60 45 L70 45"/>
<path d="M100 80 L110 80"/><path d="M110.5 80 L110.8 80"/><path d="M111.5 80 L111.5 90"/>
</g></svg>"##;

/// The servo kit (samples/servo-plotter.toml) on GRBL over a pty (issue 39): `plotter plot --firmware grbl` plans
/// for GRBL, whose `M3` waits for the moves before it to end (each hop stops where the drop is commanded), the
/// emulator runs that plan in the planned time (GRBL plans the lines after a stop together before it starts them,
/// so the corner after a drop is taken at its junction speed, as planned; it dwells in whole 50 ms steps, as
/// planned), and the tip touches each stroke within 0.1 mm of its start and
/// leaves it within 0.1 mm of its end (the measure of tests/pen_contact.rs, on the servo commands and steps the
/// emulator logged).
#[test]
fn the_servo_kit_on_grbl_runs_its_plan_and_lands_on_each_stroke() {
    use plotter_host::link::grbl::emulator::GrblEmulator;
    use plotter_path::geometry::steps::drawing_to_steps;
    use plotter_path::motion::plan::{self, Lookahead};
    use plotter_path::motion::servo::ServoSync;

    let dir = scratch("grbl-servo-kit");
    let svg = dir.join("hops.svg");
    std::fs::write(&svg, SERVO_HOPS_SVG).expect("svg written");
    let kit_path = sample("servo-plotter.toml");
    let kit = kit_path.to_str().expect("utf-8 path");
    let sim = SimPty::start(&dir, &["--grbl", "--fast", "--profile", kit]);
    let args =
        ["plot", svg.to_str().unwrap(), "--port", &sim.port, "--firmware", "grbl", "--profile", kit, "--no-optimize"];
    let args: Vec<&str> = args.into_iter().chain(["--verbose"]).collect();
    let (ok, stdout, stderr, _) = scripted(&dir, &args, &[]);
    assert!(ok, "plot failed:\n{stderr}\n{stdout}");
    let trace_file = sim.trace_path().to_path_buf();
    let trace = sim.stop();
    assert_eq!(SimPty::figure(&trace, "grbl", "errors"), Some(0));

    // The plan for GRBL, made here from the same drawing and profile: the one the plot printed.
    let text = std::fs::read_to_string(&kit_path).expect("profile");
    let p = MachineProfile {
        servo_sync: ServoSync::AtRest,
        ..MachineProfile::from_toml(&text, "servo-plotter.toml").expect("profile")
    };
    let data = std::fs::read(&svg).expect("svg");
    let drawing = svg::import_svg(&data, "hops.svg", &svg::ResourcePolicy::DataUrlsOnly, &svg::SvgOptions::default())
        .expect("svg")
        .drawing;
    let steps = drawing_to_steps(&p, &drawing).expect("steps");
    assert_eq!(steps.strokes.len(), 7);
    let home = plan::homed_position(&p).expect("home");
    let planned = plan::plan(&p, &steps, home, Lookahead::Whole).expect("plan");
    assert!(stdout.contains(&format!("planned time {:.3} s", planned.seconds())), "{stdout}");

    // Executed = planned: the emulator's motion time (its step timer's busy ticks, dwells included) less its
    // homing cycle's, which the same emulator takes on its own here.
    let mut emu = GrblEmulator::new(&p, None).expect("emulator");
    emu.feed(b"$H\n");
    while !emu.take_replies().iter().any(|r| r == "ok") {
        emu.run_for(1000);
    }
    let homing = emu.backend().hal().busy_ticks();
    let ran = trace.busy_ticks - homing;
    // GRBL runs the plan's G-code, not its step blocks, so not to the tick: the plan's stops of a tick (each
    // drop's command, and a landing's wait under half a millisecond, `G4 P0`) take none, and the emulator plans
    // its own blocks at the exact feed while the plan's rates are rounded down to the 9 significant bits our wire
    // frames carry (the 40.7 mm travel to the fifth stroke cruises at 7280 planned, 7287.6 events/s exact: 0.27 ms
    // longer). Together −0.35 ms here; allowed: the design's 0.1 % (3.8 ms). A corner taken from rest instead of
    // at its junction speed costs 10.5 ms, a dwell timed to the millisecond instead of GRBL's 50 ms steps up to
    // 50 ms.
    assert!(
        ran.abs_diff(planned.total_ticks) * 1000 <= planned.total_ticks,
        "executed {ran} ticks, planned {}",
        planned.total_ticks
    );

    // Where the tip touched and left the paper: the servo turning at the kit's rate towards each logged angle.
    let servo: Vec<(u64, f32)> = trace
        .comments
        .iter()
        .filter_map(|c| c.strip_prefix("servo "))
        .map(|c| {
            let (t, a) = c.split_once(' ').expect("time angle");
            (t.parse().expect("time"), a.parse().expect("angle"))
        })
        .collect();
    let (touches, leaves) = crate::pen_contact::servo_contacts(
        &servo,
        p.pen.servo_up_deg,
        crate::pen_contact::kit_rate(&p),
        p.pen.contact_fraction,
    );
    // The carriage's position after each step, in the plan's coordinates (`t x y z` lines).
    let samples: Vec<(u64, [i64; 2])> = std::fs::read_to_string(&trace_file)
        .expect("trace")
        .lines()
        .filter(|l| !l.starts_with('#'))
        .map(|l| {
            let v: Vec<i64> = l.split_whitespace().map(|w| w.parse().expect("integer")).collect();
            (u64::try_from(v[0]).expect("time"), [v[1], v[2]])
        })
        .collect();
    let start = [i64::from(home[0]), i64::from(home[1])];
    let (touch, leave) =
        crate::pen_contact::check_landings(&p, &steps, (&touches, &leaves), &samples, start, "GRBL over a pty");
    eprintln!(
        "servo kit on GRBL: executed {ran} ticks, planned {}; touch {touch:.4} mm, leave {leave:.4} mm",
        planned.total_ticks
    );
}
