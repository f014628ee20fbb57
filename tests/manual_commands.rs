//! The manual commands and the built-in machine models, end to end through the `plotter` binary (issue 38, items 2
//! and 4): `plotter pen up|down|cycle`, `motors off|on`, `walk-home` and `version` against the emulators on a
//! pseudo-terminal (this project's firmware, GRBL 1.1, an EiBotBoard), each checked on the emulator itself — what
//! it answers when asked afterwards (`QP`, `QE`, `?`) or its trace (pen height, position, motors) — and the model
//! names where a user meets them.

use std::time::{Duration, Instant};

use plotter_e2e::{RawPort, SimPty, Trace, plotter, scratch};

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// Run `plotter` with `args`; it must succeed. Returns its standard output.
fn ok(dir: &std::path::Path, args: &[&str]) -> String {
    let out = plotter(dir, args);
    assert!(out.status.success(), "{args:?} failed:\n{}\n{}", text(&out.stderr), text(&out.stdout));
    text(&out.stdout)
}

/// Ask the device on `port` `query` (a line) and return its answer lines up to `done`.
fn ask(port: &str, query: &str, done: impl Fn(&str) -> bool) -> Vec<String> {
    let mut p = RawPort::open(port);
    p.send(query.as_bytes());
    p.lines_until(done, Duration::from_secs(5))
}

/// The EBB's answer to `QP`: 1 with the pen up, 0 down.
fn ebb_pen_up(port: &str) -> bool {
    let lines = ask(port, "QP\r", |l| l.trim() == "OK");
    match lines.iter().map(|l| l.trim()).find(|l| *l == "0" || *l == "1") {
        Some("1") => true,
        Some("0") => false,
        _ => panic!("no QP answer: {lines:?}"),
    }
}

/// The last `# position …` line of a trace, as numbers.
fn position(trace: &Trace) -> Vec<i64> {
    let l = trace.comments.iter().rfind(|c| c.starts_with("position ")).expect("a position line");
    l.split_whitespace().skip(1).map(|v| v.parse().expect("steps")).collect()
}

#[test]
fn pen_up_down_and_cycle_on_an_eibotboard() {
    let dir = scratch("manual-ebb-pen");
    let sim = SimPty::start(&dir, &["--ebb", "--fast"]);
    let link = ["--port", &sim.port, "--firmware", "ebb", "--model", "axidraw-v3"];
    let run = |cmd: &[&str]| ok(&dir, &[cmd, &link[..]].concat());
    assert!(ebb_pen_up(&sim.port), "the board starts with the pen up");
    assert_eq!(run(&["pen", "down"]), "pen down\n");
    assert!(!ebb_pen_up(&sim.port), "QP says the pen is down");
    assert_eq!(run(&["pen", "up"]), "pen up\n");
    assert!(ebb_pen_up(&sim.port));
    let started = Instant::now();
    assert_eq!(run(&["pen", "cycle", "--hold-ms", "300"]), "pen lowered for 300 ms, then raised\n");
    assert!(started.elapsed() >= Duration::from_millis(300));
    assert!(ebb_pen_up(&sim.port), "a cycle ends with the pen up");
    let trace = sim.stop();
    // SP,0 / SP,1 / SP,0 + SP,1, and the queries: no errors.
    assert_eq!(SimPty::figure(&trace, "ebb", "errors"), Some(0));
    assert_eq!(SimPty::figure(&trace, "ebb", "pen_up"), Some(1));
}

#[test]
fn motors_off_walk_home_and_version_on_an_eibotboard() {
    let dir = scratch("manual-ebb-motors");
    let sim = SimPty::start(&dir, &["--ebb", "--fast"]);
    let link = ["--port", &sim.port, "--firmware", "ebb", "--model", "axidraw-v3"];
    let run = |cmd: &[&str]| ok(&dir, &[cmd, &link[..]].concat());
    let version = run(&["version"]);
    assert_eq!(version, "EBBv13_and_above EB Firmware Version 3.0.2\n");
    // Out 20 mm along X and 10 along Y (motor 1 = X+Y, motor 2 = X−Y at 80 steps/mm), then back with the pen up.
    run(&["home"]);
    run(&["jog", "x", "20"]);
    run(&["jog", "y", "10"]);
    let out = run(&["walk-home"]);
    assert_eq!(out, "home: X 0.00 mm, Y 0.00 mm, pen up\n");
    assert!(ebb_pen_up(&sim.port));
    assert_eq!(run(&["motors", "on"]), "motors on (EM,1,1): the carriage's position is now home\n");
    let qe = ask(&sim.port, "QE\r", |l| l.trim() == "OK");
    assert!(qe.contains(&"16,16".to_string()), "both motors at 1/16 steps: {qe:?}");
    assert_eq!(run(&["motors", "off"]), "motors off (EM,0,0): the carriage can be moved by hand\n");
    let qe = ask(&sim.port, "QE\r", |l| l.trim() == "OK");
    assert!(qe.contains(&"0,0".to_string()), "QE says both motors are off: {qe:?}");
    let trace = sim.stop();
    assert_eq!(SimPty::figure(&trace, "ebb", "errors"), Some(0));
    // The jogs reached X 20, Y 10 mm: motor 1 (X+Y) at 30 mm, motor 2 (X−Y) at 10 mm, 80 steps/mm; the last
    // step of the walk home is back at 0, 0 with the pen up (the EM of `motors` then zeroes the counters).
    let steps = &trace.positions;
    assert!(steps.iter().any(|p| p[0] == 2400 && p[1] == 800), "the jogs' end in motor steps");
    assert_eq!(steps.last().copied(), Some([0, 0, 1]));
    assert_eq!(position(&trace), [0, 0]);
}

#[test]
fn pen_motors_walk_home_and_version_on_grbl() {
    let dir = scratch("manual-grbl");
    let sim = SimPty::start(&dir, &["--grbl", "--fast"]);
    let link = ["--port", &sim.port, "--firmware", "grbl"];
    let run = |cmd: &[&str]| ok(&dir, &[cmd, &link[..]].concat());
    assert_eq!(run(&["version"]), "VER:1.1h.20190830:plotter emulator\nOPT:V,15,128\n");
    run(&["home"]);
    // The kit's Z pen: down at Z 0, up at 4 mm (400 steps/mm).
    assert_eq!(run(&["pen", "down"]), "pen down\n");
    let st = ask(&sim.port, "?", |l| l.starts_with('<'));
    assert!(st.iter().any(|l| l.contains("MPos:0.000,0.000,0.000")), "{st:?}");
    run(&["jog", "x", "15"]);
    assert_eq!(run(&["walk-home"]), "home: X 0.00 mm, Y 0.00 mm, pen up\n");
    let st = ask(&sim.port, "?", |l| l.starts_with('<'));
    assert!(st.iter().any(|l| l.starts_with("<Idle|MPos:0.000,0.000,4.000")), "{st:?}");
    // Motors on: GRBL has no such command, said before anything is sent.
    let out = plotter(&dir, &[&["motors", "on"][..], &link[..]].concat());
    assert!(!out.status.success());
    assert!(text(&out.stderr).contains("GRBL powers its motors itself for each move"), "{}", text(&out.stderr));
    assert_eq!(run(&["motors", "off"]), "motors off ($SLP: GRBL sleeps until a reset)\n");
    let st = ask(&sim.port, "?", |l| l.starts_with('<'));
    assert!(st.iter().any(|l| l.starts_with("<Sleep|")), "the controller sleeps: {st:?}");
    let trace = sim.stop();
    assert_eq!(SimPty::figure(&trace, "grbl", "errors"), Some(0));
    assert_eq!(position(&trace), [0, 0, 1600]);
}

#[test]
fn pen_motors_walk_home_and_version_on_our_firmware() {
    let dir = scratch("manual-ours");
    let sim = SimPty::start(&dir, &["--fast"]);
    let link = ["--port", &sim.port, "--firmware", "ours"];
    let run = |cmd: &[&str]| ok(&dir, &[cmd, &link[..]].concat());
    assert!(run(&["version"]).starts_with("FIRMWARE_NAME:plotter-fw "));
    run(&["home"]);
    assert_eq!(run(&["pen", "down"]), "pen down\n");
    run(&["jog", "y", "12.5"]);
    assert_eq!(run(&["walk-home"]), "home: X 0.00 mm, Y 0.00 mm, pen up\n");
    assert_eq!(run(&["motors", "off"]), "motors off (M18): the carriage can be moved by hand\n");
    let trace = sim.stop();
    // Pen down at Z 0, out 12.5 mm (1000 steps) along Y with it, then home with the pen up (4 mm = 1600 steps).
    assert!(trace.positions.iter().any(|p| p[1] == 1000 && p[2] == 0), "the pen went down and Y out");
    assert_eq!(trace.positions.last().copied(), Some([0, 0, 1600]));
    assert_eq!(SimPty::figure(&trace, "motors", "on"), Some(0), "M18 released the motors");
}

#[test]
fn hpgl_has_no_motors_command_and_is_told_before_connecting() {
    let dir = scratch("manual-hpgl");
    let out = plotter(&dir, &["motors", "off", "--port", "/dev/null/none", "--firmware", "hpgl", "--model", "hp7475a"]);
    assert!(!out.status.success());
    assert_eq!(
        text(&out.stderr),
        "error: an HP-GL plotter has no command that turns its motors off; switch it off and on instead\n"
    );
}

#[test]
fn a_detected_eibotboard_with_the_default_machine_suggests_the_models() {
    let dir = scratch("manual-ebb-default");
    let sim = SimPty::start(&dir, &["--ebb", "--fast"]);
    let out = plotter(&dir, &["pen", "up", "--port", &sim.port]);
    let err = text(&out.stderr);
    assert!(!out.status.success(), "{err}");
    assert!(err.contains("connected to") || err.contains("EiBotBoard") || err.contains("[ebb]"), "{err}");
    assert!(
        err.contains(
            "choose the EiBotBoard machine with --model axidraw-v3 (AxiDraw V3 and SE/A4), --model axidraw-se-a3"
        ),
        "{err}"
    );
    assert!(err.contains("--model nextdraw-8511") && !err.contains("samples/"), "{err}");
    drop(sim);
}

#[test]
fn model_names_where_a_user_meets_them() {
    let dir = scratch("manual-models");
    // A model's name given as a profile file: the OS error once, and the flag that was meant.
    let out = plotter(&dir, &["stats", "gen:circle?r=10", "--profile", "axidraw-v3"]);
    assert_eq!(
        text(&out.stderr),
        "error: cannot read machine profile axidraw-v3: no such file; did you mean --model axidraw-v3 (built in)?\n"
    );
    let out = plotter(&dir, &["stats", "gen:circle?r=10", "--profile", "mine.toml"]);
    assert_eq!(
        text(&out.stderr),
        "error: cannot read machine profile mine.toml: No such file or directory (os error 2)\n"
    );
    // `plotter models` lists every sample's model with its work area; --json for scripts.
    let list = ok(&dir, &["models"]);
    for (name, area) in [
        ("xy-kit", "420 × 297 mm"),
        ("servo-grbl", "420 × 297 mm"),
        ("axidraw-v3", "300 × 218 mm"),
        ("axidraw-se-a3", "430 × 297 mm"),
        ("axidraw-minikit", "160 × 101.6 mm"),
        ("axidraw-saxi", "300 × 218 mm"),
        ("nextdraw-8511", "300 × 218 mm"),
        ("idraw-h", "420 × 297 mm"),
        ("hp7475a", "403.95 × 276 mm"),
        ("printer", "235 × 235 mm"),
    ] {
        let line =
            list.lines().find(|l| l.starts_with(&format!("{name} "))).unwrap_or_else(|| panic!("{name}: {list}"));
        assert!(line.contains(area), "{line}");
    }
    let json: serde_json::Value = serde_json::from_str(&ok(&dir, &["models", "--json"])).unwrap();
    let v3 = json.as_array().unwrap().iter().find(|m| m["name"] == "axidraw-v3").unwrap();
    assert_eq!(v3["firmware"], "ebb");
    assert_eq!(v3["work_area_mm"], serde_json::json!([300.0, 218.0]));
    // 25 000 steps/s / (80 steps/mm × √2).
    assert_eq!(v3["top_speed_mm_s"], 220.971);
}
