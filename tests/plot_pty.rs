//! End to end over a pseudo-terminal: `plotter sim --pty` runs the simulated firmware, `plotter plot --port` streams
//! a drawing to it through the real serial code path, and the simulator's step trace is checked against the
//! intended paths. Also: line noise, resume after the host is killed, and bad input.

use std::io::{Read as _, Write as _};
use std::path::Path;
use std::time::{Duration, Instant};

use plotter_e2e::{
    SAMPLE_SVG, SimPty, Trace, ink_off_drawing, machine_paths, plotter, plotter_bin, point_segment_distance, scratch,
};
use plotter_path::geometry::steps::{StepDrawing, StepPos, drawing_to_steps};
use plotter_path::{Drawing, MachineProfile, input::svg};

const TOLERANCE_MM: f64 = svg::DEFAULT_TOLERANCE_MM;

fn ideal() -> (MachineProfile, Drawing, StepDrawing) {
    let profile = MachineProfile::default_plotter();
    let opts = svg::SvgOptions { tolerance_mm: TOLERANCE_MM, ..svg::SvgOptions::default() };
    let drawing = svg::import_svg(SAMPLE_SVG.as_bytes(), "sample.svg", &svg::ResourcePolicy::DataUrlsOnly, &opts)
        .unwrap()
        .drawing;
    let steps = drawing_to_steps(&profile, &drawing).unwrap();
    (profile, drawing, steps)
}

/// The pen's clearance height (steps): below it the tip may touch the paper (the hops travel at or above it).
fn pen_threshold(p: &MachineProfile) -> i64 {
    let clear = (p.pen.down_z_mm + p.pen.clearance_mm) * p.axes.z.steps_per_mm;
    // A small positive value.
    #[allow(clippy::cast_possible_truncation)]
    let t = clear.round() as i64;
    t
}

/// The ink check over a pty trace: every position below the clearance lies on a stroke of `drawing`.
fn assert_inks_only_the_drawing(profile: &MachineProfile, drawing: &Drawing, trace: &Trace) {
    let threshold = pen_threshold(profile);
    let samples = trace.positions.iter().map(|p| (p[2] < threshold, [p[0], p[1]]));
    let off = ink_off_drawing(samples, &machine_paths(profile, drawing), profile.axes.x.steps_per_mm, TOLERANCE_MM);
    assert!(off.is_empty(), "{} positions below the clearance off the drawing, first {:?}", off.len(), off.first());
}

fn write_sample(dir: &Path) -> std::path::PathBuf {
    let p = dir.join("sample.svg");
    std::fs::write(&p, SAMPLE_SVG).unwrap();
    p
}

fn ok(out: &std::process::Output) -> String {
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(out.status.success(), "plotter failed: {}\n{stdout}", String::from_utf8_lossy(&out.stderr));
    stdout
}

/// Plot the sample over a pty; `extra_plot` are more `plot` flags.
fn plot_over_pty(extra_sim: &[&str], extra_plot: &[&str]) -> (Trace, String) {
    let dir = scratch(&format!("pty{}-{}", extra_sim.len(), extra_plot.len()));
    let svg = write_sample(&dir);
    let sim = SimPty::start(&dir, &[&["--fast"], extra_sim].concat());
    let out = plotter(&dir, &[&["plot", svg.to_str().unwrap(), "--port", &sim.port, "--verbose"], extra_plot].concat());
    let stdout = ok(&out);
    (sim.stop(), stdout)
}

#[test]
fn svg_plotted_over_a_pty_matches_the_intended_paths() {
    let (profile, drawing, steps) = ideal();
    // In the file's own order, so the trace can be compared stroke by stroke with `ideal()`.
    let (trace, stdout) = plot_over_pty(&[], &["--no-optimize"]);
    assert!(stdout.contains("0 resends"), "{stdout}");
    let mut runs = trace.pen_down_runs(pen_threshold(&profile));
    // The simulated carriage starts with the pen on the paper at the origin: homing Z first lifts it there without
    // any XY motion. That is the only pen-down run that does not move.
    assert_eq!(runs[0], vec![StepPos::new(0, 0)]);
    runs.remove(0);
    assert!(runs.iter().all(|r| r.len() > 1));
    // Pen up on every travel move: one pen-down run per stroke, nothing drawn in between.
    assert_eq!(runs.len(), steps.strokes.len());
    // The hops move Z on the way (issue 25), and never with the pen below the clearance off the drawing.
    assert!(trace.mixed_xy_z_steps() > 0, "no XY+Z travel");
    assert_inks_only_the_drawing(&profile, &drawing, &trace);
    let spm = profile.axes.x.steps_per_mm;
    assert_eq!(spm, profile.axes.y.steps_per_mm);
    let half_step_mm = 0.5 / spm;
    for ((run, stroke), path) in runs.iter().zip(&steps.strokes).zip(drawing.paths()) {
        let verts: Vec<(f64, f64)> = stroke.positions().iter().map(|p| (f64::from(p.x), f64::from(p.y))).collect();
        let ideal_mm: Vec<(f64, f64)> =
            path.points.iter().map(|p| profile.page_to_machine(*p)).map(|p| (p.x, p.y)).collect();
        assert_eq!(run.first(), Some(&stroke.start));
        assert_eq!(run.last(), Some(&stroke.end()));
        if path.is_closed() {
            assert_eq!(run.first(), run.last(), "closed curves close to 0 steps");
        }
        for p in run {
            let q = (f64::from(p.x), f64::from(p.y));
            // Bresenham: within half a step of the line between the rounded vertices.
            let d_steps = verts.windows(2).map(|w| point_segment_distance(q, w[0], w[1])).fold(f64::INFINITY, f64::min);
            assert!(d_steps <= 0.5 + 1e-9, "{d_steps} steps off the stepped path at {p:?}");
            // And within the flattening tolerance + half a step of the intended (flattened) path in mm.
            let qm = (q.0 / spm, q.1 / spm);
            let d_mm =
                ideal_mm.windows(2).map(|w| point_segment_distance(qm, w[0], w[1])).fold(f64::INFINITY, f64::min);
            assert!(d_mm <= TOLERANCE_MM + half_step_mm, "{d_mm} mm off the intended path at {p:?}");
        }
    }
    // Final position exact: the end of the last stroke, pen up.
    let last = steps.strokes.last().unwrap().end();
    let up = (profile.pen.up_z_mm * profile.axes.z.steps_per_mm).round();
    let fin = trace.positions.last().unwrap();
    assert_eq!([fin[0], fin[1]], [i64::from(last.x), i64::from(last.y)]);
    #[allow(clippy::cast_possible_truncation)]
    let up = up as i64;
    assert_eq!(fin[2], up);
}

fn resends(stdout: &str) -> u64 {
    stdout
        .split(',')
        .find_map(|part| part.trim().strip_suffix(" resends").and_then(|n| n.rsplit(' ').next()?.parse().ok()))
        .unwrap_or_else(|| panic!("no resend count in {stdout}"))
}

#[test]
fn line_noise_gives_the_same_trace_and_reports_resends() {
    let (clean, clean_out) = plot_over_pty(&[], &[]);
    assert_eq!(resends(&clean_out), 0);
    let (profile, drawing, _) = ideal();
    assert_inks_only_the_drawing(&profile, &drawing, &clean);
    for seed in ["3", "11"] {
        let (noisy, out) = plot_over_pty(&["--noise", "0.01", "--seed", seed], &[]);
        let n = resends(&out);
        eprintln!("seed {seed}: {n} resends");
        assert!(n > 0, "1 % noise over ~1400 bytes must damage some frames: {out}");
        assert_eq!(noisy.positions, clean.positions, "seed {seed}: the trace differs from the clean run");
    }
}

fn journal_progress(path: &Path) -> Option<(usize, usize)> {
    let text = std::fs::read_to_string(path).ok()?;
    let blocks = text.lines().find_map(|l| l.strip_prefix("plan "))?.split(' ').nth(1)?.parse().ok()?;
    let accepted = text
        .lines()
        .filter_map(|l| l.strip_prefix("progress "))
        .filter_map(|l| l.split(' ').next()?.parse().ok())
        .next_back()
        .unwrap_or(0);
    Some((accepted, blocks))
}

fn concat_runs(t: &Trace, threshold: i64) -> Vec<StepPos> {
    let mut all: Vec<StepPos> = Vec::new();
    for p in t.pen_down_runs(threshold).into_iter().flatten() {
        if all.last() != Some(&p) {
            all.push(p);
        }
    }
    all
}

#[test]
fn resume_after_killing_the_host_at_half() {
    let (profile, drawing, _) = ideal();
    let threshold = pen_threshold(&profile);
    let (clean, _) = plot_over_pty(&[], &[]);

    let dir = scratch("resume");
    let svg = write_sample(&dir);
    let journal = dir.join("plot.journal");
    // Paced (four times real time, not as fast as it can run), so that the plot takes long enough to be
    // interrupted.
    let sim = SimPty::start(&dir, &["--pace", "4"]);
    let mut host = std::process::Command::new(plotter_bin())
        .args(["plot", svg.to_str().unwrap(), "--port", &sim.port, "--journal", journal.to_str().unwrap()])
        .current_dir(&dir)
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    loop {
        if let Some((a, n)) = journal_progress(&journal)
            && a >= n / 2
        {
            break;
        }
        assert!(t0.elapsed() < Duration::from_secs(60), "the plot did not get to half");
        assert!(host.try_wait().unwrap().is_none(), "the host finished before it could be killed");
        std::thread::sleep(Duration::from_millis(20));
    }
    host.kill().unwrap();
    host.wait().unwrap();
    let (accepted, blocks) = journal_progress(&journal).unwrap();
    assert!(accepted < blocks, "killed before the end");
    let out = plotter(&dir, &["plot", "--resume", journal.to_str().unwrap(), "--port", &sim.port, "--trust-position"]);
    ok(&out);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("resuming at block"), "{stderr}");
    let resumed = sim.stop();
    // Every stroke drawn once, none missed: the pen-down steps are those of the uninterrupted plot.
    assert_eq!(concat_runs(&resumed, threshold), concat_runs(&clean, threshold));
    assert_inks_only_the_drawing(&profile, &drawing, &resumed);
    assert!(std::fs::read_to_string(&journal).unwrap().ends_with("complete\n"));
}

fn assert_fails(out: &std::process::Output, needle: &str) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "should fail: {needle}");
    assert!(stderr.contains(needle), "expected {needle:?} in: {stderr}");
}

#[test]
fn bad_gcode_and_out_of_area_moves_execute_nothing() {
    let dir = scratch("bad");
    std::fs::write(dir.join("unknown.gcode"), "G21\nG0 Z5\nG0 X10 Y10\nG7 X3\n").unwrap();
    std::fs::write(dir.join("far.gcode"), "G0 Z5\nG0 X10 Y10\nG1 Z0 F100\nG1 X500 Y10\n").unwrap();
    let sim = SimPty::start(&dir, &["--fast"]);
    let out = plotter(&dir, &["plot", "unknown.gcode", "--port", &sim.port]);
    assert_fails(&out, "unknown.gcode:4: unsupported command G7: unknown G code");
    let out = plotter(&dir, &["plot", "far.gcode", "--port", &sim.port]);
    // Refused by the layout, before connecting: the drawing's extent against the work area, and the fix.
    assert_fails(&out, "the drawing (x 10..500, y 10..10 mm on the page) reaches beyond the XY plotter kit");
    assert_fails(&out, "(A3 frame)'s 420 × 297 mm work area (x 0..420, y 0..297 mm); use --fit with a --paper");
    let trace = sim.stop();
    assert!(trace.positions.is_empty(), "nothing may move: {} steps", trace.positions.len());
}

#[test]
fn missing_port_and_garbage_port() {
    let dir = scratch("ports");
    let svg = write_sample(&dir);
    let out = plotter(&dir, &["plot", svg.to_str().unwrap(), "--port", "/dev/no-such-plotter"]);
    assert_fails(&out, "serial port /dev/no-such-plotter does not exist");
    assert_eq!(out.status.code(), Some(4), "a port that is not there is link trouble");

    // A device that answers everything with noise.
    let pty = nix::pty::openpty(None, None).unwrap();
    let path = nix::unistd::ttyname(&pty.slave).unwrap();
    drop(pty.slave);
    let mut master = std::fs::File::from(pty.master);
    std::thread::spawn(move || {
        let mut buf = [0u8; 256];
        loop {
            match master.read(&mut buf) {
                Ok(n) if n > 0 => {
                    let _ = master.write_all(b"\x07%garbage#1\r\n");
                }
                Ok(_) | Err(_) => std::thread::sleep(Duration::from_millis(10)),
            }
        }
    });
    let out = plotter(&dir, &["plot", svg.to_str().unwrap(), "--port", path.to_str().unwrap()]);
    assert_fails(&out, "does not answer like plotter-fw");
    assert_fails(&out, "garbage");
    assert_eq!(out.status.code(), Some(4), "a device that is not plotter-fw is link trouble");
}

#[test]
fn sigterm_ends_the_simulator_as_ctrl_c_does_with_its_trace_written() {
    let dir = scratch("pty-sigterm");
    let sim = SimPty::start(&dir, &["--fast"]);
    // Homing moves every axis: the trace has steps to write.
    ok(&plotter(&dir, &["home", "--port", &sim.port]));
    let trace = sim.stop_with(nix::sys::signal::Signal::SIGTERM);
    assert!(!trace.positions.is_empty() && trace.busy_ticks > 0, "{trace:?}");
}

/// `home` and `jog` say where the machine stands in millimetres and the pen as up or down (steps only with
/// `--json`), on our firmware and on an EiBotBoard, whose pen is asked with `QP`. The built-in kit: 80 steps/mm on
/// X and Y, the pen up at Z 4 mm = 1600 steps of 400/mm.
#[test]
fn home_and_jog_speak_millimetres_and_the_pen() {
    let dir = scratch("pty-home-jog-mm");
    let sim = SimPty::start(&dir, &["--fast"]);
    let home = ok(&plotter(&dir, &["home", "--port", &sim.port]));
    assert_eq!(home.trim(), "homed: X 0.00 Y 0.00 mm, pen up");
    let jog = ok(&plotter(&dir, &["jog", "--port", &sim.port, "x", "10"]));
    assert_eq!(jog.trim(), "at X 10.00 Y 0.00 mm, pen up");
    let down = ok(&plotter(&dir, &["jog", "--port", &sim.port, "down"]));
    assert_eq!(down.trim(), "at X 10.00 Y 0.00 mm, pen down");
    let json = ok(&plotter(&dir, &["jog", "--port", &sim.port, "y", "2.5", "--json"]));
    let v: serde_json::Value = serde_json::from_str(json.trim()).expect("jog --json prints JSON");
    assert_eq!(v, serde_json::json!({"x_mm": 10.0, "y_mm": 2.5, "pen": "down", "steps": [800, 200, 0, 0]}));
    drop(sim);

    let axidraw = plotter_e2e::sample("axidraw-v3.toml");
    let ebb = SimPty::start(&dir, &["--ebb", "--fast", "--profile", axidraw.to_str().unwrap()]);
    let link = ["--port", ebb.port.as_str(), "--firmware", "ebb", "--profile", axidraw.to_str().unwrap()];
    let home = ok(&plotter(&dir, &[&["home"][..], &link].concat()));
    assert_eq!(home.trim(), "homed: X 0.00 Y 0.00 mm, pen up");
    ok(&plotter(&dir, &[&["jog"][..], &link, &["down"]].concat()));
    let jog = ok(&plotter(&dir, &[&["jog"][..], &link, &["x", "12.5"]].concat()));
    assert_eq!(jog.trim(), "at X 12.50 Y 0.00 mm, pen down");
}

/// `plotter sim --pace N` runs the machine's clock N times as fast as the wall clock, still over the pty: a plot of
/// several seconds of motion ends in well under half of that at --pace 10 (in real time it takes at least its
/// motion time) on top of what the same plot takes on the simulator running as fast as it can (starting the host,
/// planning: slower when other tests share the machine), but never in less than a tenth of it; and it draws the
/// same strokes as the simulator at its own speed. A pace of 0, or with --fast, is refused with what to give.
#[test]
fn a_paced_simulator_runs_its_clock_faster_than_real_time() {
    let dir = scratch("pty-pace");
    let circle = "gen:circle?r=25&cx=60&cy=60";
    let fast = SimPty::start(&dir, &["--fast"]);
    let start = Instant::now();
    ok(&plotter(&dir, &["plot", circle, "--port", &fast.port]));
    let unpaced = start.elapsed();
    let fast = fast.stop();
    let paced = SimPty::start(&dir, &["--pace", "10"]);
    let start = Instant::now();
    ok(&plotter(&dir, &["plot", circle, "--port", &paced.port]));
    let wall = start.elapsed();
    let paced = paced.stop();
    let motion = Duration::from_micros(paced.busy_ticks);
    eprintln!(
        "{:.2} s of motion in {:.2} s at --pace 10 ({:.2} s unpaced)",
        motion.as_secs_f64(),
        wall.as_secs_f64(),
        unpaced.as_secs_f64()
    );
    assert!(motion > Duration::from_secs(4), "the plot moves long enough to time: {motion:?}");
    assert!(wall < unpaced + motion / 2, "{motion:?} of motion took {wall:?} at --pace 10 ({unpaced:?} unpaced)");
    // The simulator runs the machine's clock for ten times the wall time since its last look (a few ms before the
    // host started), never more.
    assert!(wall + Duration::from_millis(100) >= motion / 10, "{motion:?} of motion took only {wall:?} at --pace 10");
    assert_eq!(paced.positions, fast.positions, "the same steps at any pace");
    for (bad, says) in [(&["--pace", "0"][..], "0 is not in 1..=1000"), (&["--pace", "2", "--fast"], "--fast")] {
        let out = plotter(&dir, &[&["sim", "--pty"], bad].concat());
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && stderr.contains(says), "{bad:?}: {stderr}");
    }
}
