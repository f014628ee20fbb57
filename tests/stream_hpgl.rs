//! Streaming HP-GL to a vintage plotter: the export of a dense two-pen drawing sent to the project's HP-GL plotter
//! model ([`plotter_host::link::hpgl::model`]) with a 60-byte input buffer (the HP 7440A's) under each handshake.
//! The model loses bytes that arrive while its buffer is full, as the real plotters do, so "no byte lost" is
//! something these tests can see fail (the wrong-handshake test shows it does). What the model drew (its pen-down
//! polylines in plotter units) is compared with the export parsed here, independently of the model's parser.

use std::collections::HashSet;
use std::time::Duration;

use plotter_e2e::{plotter, plotter_bin, sample, scratch};
use plotter_host::job::hpgl::{self as hplot, HpglOutcome};
use plotter_host::job::progress::{JobProgress, PlotEvents};
use plotter_host::link::hpgl::commands::Commands;
use plotter_host::link::hpgl::handshake::Handshake;
use plotter_host::link::hpgl::model::{HpglModel, ModelConfig};
use plotter_host::link::hpgl::model_link::ModelLink;
use plotter_host::link::hpgl::sender::HpglSession;
use plotter_host::link::journal::{self, Journal};
use plotter_host::link::stream::PauseChoice;
use plotter_path::geometry::hpgl_devices::{HpglDevice, HpglPaper, device};
use plotter_path::kurbo::Point;
use plotter_path::output::hpgl_out;
use plotter_path::{Drawing, Layer, MachineProfile, Pen, Polyline, Rgb};

type Lines = Vec<Vec<(i32, i32)>>;

fn hp7475a() -> (&'static HpglDevice, HpglPaper) {
    let d = device("7475a").unwrap();
    (d, *d.paper("a4").unwrap())
}

/// A dense two-pen drawing on A4: 30 concentric 96-gons (black) and 60 short hatch strokes (red).
fn dense() -> Drawing {
    let circles = (1..=30)
        .map(|r| {
            let r = f64::from(r) * 2.5;
            Polyline::new(
                (0..=96)
                    .map(|i| {
                        let a = f64::from(i) * std::f64::consts::TAU / 96.0;
                        Point::new(150.0 + r * a.cos(), 105.0 + r * a.sin())
                    })
                    .collect(),
            )
        })
        .collect();
    let hatch = (0..60)
        .map(|i| {
            let x = 30.0 + f64::from(i) * 0.8;
            Polyline::new(vec![Point::new(x, 30.0), Point::new(x + 5.0, 40.0), Point::new(x, 50.0)])
        })
        .collect();
    let pen = |color| Pen { color, width_mm: 0.3 };
    Drawing {
        layers: vec![
            Layer { name: "black".into(), pen: pen(Rgb::BLACK), paths: circles },
            Layer { name: "red".into(), pen: pen(Rgb(255, 0, 0)), paths: hatch },
        ],
        page_mm: Some((297.0, 210.0)),
    }
}

fn program() -> String {
    let (d, paper) = hp7475a();
    hpgl_out::export(&MachineProfile::default_plotter(), &dense(), d, &paper).unwrap().text
}

/// The pen-down polylines of an HP-GL program, read here by the book: `PU`/`PD` with absolute coordinate
/// lists, a `PD` after a pen-up starts a polyline where the pen stands; `SP` and `IN` lift the pen.
fn drawn_by(program: &str) -> Lines {
    let mut lines: Lines = Vec::new();
    let (mut pos, mut down) = ((0, 0), false);
    for cmd in program.split(';').map(str::trim).filter(|c| !c.is_empty()) {
        let (mn, params) = cmd.split_at(2);
        let nums: Vec<i32> = params.split(',').filter(|p| !p.is_empty()).map(|p| p.parse().unwrap()).collect();
        match mn {
            "PU" | "SP" | "IN" => down = false,
            "PD" => {
                if !down {
                    lines.push(vec![pos]);
                }
                down = true;
            }
            _ => continue,
        }
        if matches!(mn, "PU" | "PD") {
            for p in nums.chunks_exact(2) {
                pos = (p[0], p[1]);
                if down {
                    lines.last_mut().unwrap().push(pos);
                }
            }
        }
    }
    lines
}

fn segments(lines: &Lines) -> HashSet<((i32, i32), (i32, i32))> {
    lines.iter().flat_map(|l| l.windows(2).map(|w| (w[0], w[1]))).collect()
}

fn model_link(buffer: usize, xon_xoff: bool) -> ModelLink {
    let (d, _) = hp7475a();
    ModelLink::new(HpglModel::new(ModelConfig { device: d, buffer, xon_xoff }), 9600)
}

/// A front end that never pauses, or asks for one pause once `pause_at` commands are executed and then
/// answers `choice`.
#[derive(Default)]
struct Front {
    pause_at: Option<usize>,
    choice: Option<PauseChoice>,
    asked: bool,
    executed: usize,
    reports: Vec<(usize, usize)>,
}

impl PlotEvents for Front {
    fn progress(&mut self, p: &JobProgress) {
        self.executed = p.executed;
        self.reports.push((p.executed, p.accepted));
    }
    fn pause_requested(&mut self) -> Option<bool> {
        let due = self.pause_at.is_some_and(|n| self.executed >= n) && !self.asked;
        self.asked |= due;
        due.then_some(false)
    }
    fn paused(&mut self, _held: bool) -> PauseChoice {
        self.choice.unwrap_or(PauseChoice::Abort)
    }
}

fn stream(link: ModelLink, h: Handshake, front: &mut Front) -> (HpglSession<ModelLink>, Result<HpglOutcome, String>) {
    let (d, paper) = hp7475a();
    let text = program();
    let cmds = Commands::split(&text, d);
    let mut s = HpglSession::connect(link, "model", d, h).unwrap();
    let r = hplot::plot(&mut s, &cmds, &paper, 0, None, None, front).map_err(|e| format!("{e:#}"));
    (s, r)
}

#[test]
fn a_dense_drawing_streams_to_a_60_byte_buffer_under_each_handshake() {
    let text = program();
    let want = drawn_by(&text);
    assert_eq!(want.len(), 90, "30 circles and 60 hatch strokes");
    for h in [Handshake::Escb, Handshake::Xonxoff, Handshake::Hardware] {
        let mut front = Front::default();
        let (mut s, r) = stream(model_link(60, true), h, &mut front);
        let o = r.unwrap_or_else(|e| panic!("{h:?}: {e}"));
        s.link.finish(60.0);
        let m = s.link.model();
        let st = m.stats();
        assert_eq!((st.overflow, st.errors), (0, 0), "{h:?}: no byte lost, no HP-GL error");
        assert!(st.peak >= 45, "{h:?}: the buffer was kept full ({} of 60 bytes at most)", st.peak);
        // Every byte sent entered the buffer: the program's commands plus the session's own OI/OE checks.
        assert_eq!(st.buffered, s.sent_bytes(), "{h:?}");
        assert_eq!(m.trace(), want.as_slice(), "{h:?}: the plotter drew exactly the export");
        assert!(m.pen_up() && m.pen() == 0, "{h:?}: the pen ends up and put away");
        assert!(front.reports.windows(2).all(|w| w[0].0 <= w[1].0 && w[1].0 <= w[1].1), "{h:?}: progress");
        assert_eq!(front.reports.last(), Some(&(o.commands, o.commands)));
        // The line at 9600 baud carries 960 bytes/s at most; the plotter's moves set the pace below that.
        let bps = o.stats.bytes as f64 / o.seconds;
        let cps = o.commands as f64 / o.seconds;
        assert!(bps > 0.0 && bps <= 960.0, "{h:?}: {bps} bytes/s");
        eprintln!(
            "{:>8}: {} bytes, {} commands in {:.2} s: {:.0} bytes/s, {:.1} commands/s; plotter busy {:.2} s \
             (estimate {:.2} s); {} ESC.B queries, {} Xoffs, {} waits",
            h.name(),
            o.stats.bytes,
            o.commands,
            o.seconds,
            bps,
            cps,
            m.busy_seconds(),
            o.estimated_s,
            o.stats.space_queries,
            o.stats.xoffs,
            o.stats.waits
        );
        match h {
            Handshake::Escb => assert!(o.stats.space_queries > 10),
            Handshake::Xonxoff => assert!(st.xoffs > 10 && o.stats.xoffs > 10),
            Handshake::Hardware => assert!(o.stats.waits > 10),
        }
    }
}

#[test]
fn a_cable_without_handshake_lines_works_with_escb() {
    let mut link = model_link(60, true);
    link.lines = false;
    let (mut s, r) = stream(link, Handshake::Escb, &mut Front::default());
    r.unwrap();
    s.link.finish(60.0);
    assert_eq!(s.link.model().stats().overflow, 0);
    assert_eq!(s.link.model().trace(), drawn_by(&program()).as_slice());
    let mut link = model_link(60, true);
    link.lines = false;
    let e = HpglSession::connect(link, "model", hp7475a().0, Handshake::Hardware).err().expect("refused");
    assert!(e.to_string().contains("no CTS line") && e.to_string().contains("--handshake escb"), "{e}");
}

#[test]
fn the_wrong_handshake_overflows_a_plotter_without_xon_xoff_and_is_caught() {
    let (s, r) = stream(model_link(60, false), Handshake::Xonxoff, &mut Front::default());
    let e = r.expect_err("overflow detected");
    assert!(e.contains("error 16 (input buffer overflow: bytes were lost)"), "{e}");
    assert!(e.contains("ESC . K") && e.contains("PU;SP0;"), "the plot is cancelled: {e}");
    let mut link = s.link;
    link.finish(600.0);
    let m = link.model();
    assert!(m.stats().overflow > 0);
    assert!(m.pen_up(), "the pen ends up");
}

#[test]
fn ctrl_c_parks_with_the_pen_up_and_the_journal_resumes() {
    let dir = scratch("hpgl-ctrl-c");
    let (d, paper) = hp7475a();
    let text = program();
    let cmds = Commands::split(&text, d);
    let n = cmds.list.len();
    let path = dir.join("plot.journal");
    let hash = hplot::program_hash(&text);
    let j = Journal::create(&path, "{}", hash, n).unwrap();
    let mut s = HpglSession::connect(model_link(60, true), "model", d, Handshake::Escb).unwrap();
    let mut front = Front { pause_at: Some(n / 2), ..Front::default() };
    let e = format!("{:#}", hplot::plot(&mut s, &cmds, &paper, 0, Some(j), Some(&path), &mut front).unwrap_err());
    assert!(e.contains("stopped at the user's request") && e.contains("--resume"), "{e}");
    s.link.finish(60.0);
    let first = s.link.model();
    assert!(first.pen_up() && first.pen() == 0, "parked with the pen up, then put away");
    assert_eq!(first.position(), paper.clip_plu, "parked in the far corner");
    let state = journal::load(&path).unwrap();
    assert!(!state.complete && state.blocks == n);
    // The pause came before the next command once half were executed; all sent ones had been parsed by then.
    assert!(state.executed >= n / 2 && state.executed < n, "{} of {n}", state.executed);
    assert_eq!(state.accepted, state.executed, "the park waited for the plotter");
    let drawn_first = first.trace().to_vec();

    // Resume on a plotter switched on afresh.
    let from = hplot::resume_point(state.executed, &cmds);
    let j = Journal::append(&path, &state).unwrap();
    let mut s = HpglSession::connect(model_link(60, true), "model", d, Handshake::Escb).unwrap();
    let o = hplot::plot(&mut s, &cmds, &paper, from, Some(j), Some(&path), &mut Front::default()).unwrap();
    assert_eq!(o.from, from);
    s.link.finish(60.0);
    assert!(journal::load(&path).unwrap().complete);
    let second = s.link.model();
    assert_eq!(second.stats().errors, 0);
    // Together the two runs drew every segment of the export, and nothing else.
    let want = segments(&drawn_by(&text));
    let mut got = segments(&drawn_first);
    got.extend(segments(&second.trace().to_vec()));
    assert_eq!(got, want);
    assert!(!drawn_first.is_empty() && !second.trace().is_empty());
}

/// The whole path over a pseudo-terminal: `plotter sim --pty --hpgl --hpgl-buffer 60` and `plotter plot
/// --firmware hpgl --port <pty>` (which has no handshake lines: `ESC . B`, the default, needs none). The model
/// runs `--fast` (its clock ahead of the wall clock), so the wait for its last moves is short.
#[test]
fn plot_firmware_hpgl_over_a_pty_draws_the_export() {
    let dir = scratch("hpgl-pty");
    let svg = sample("three-pens.svg");
    let svg = svg.to_str().unwrap();
    let layout = ["--paper", "a4", "--landscape", "--center"];
    let out = plotter(&dir, &[&["plot", svg, "--export", "out.hpgl"][..], &layout[..]].concat());
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let want = drawn_by(&std::fs::read_to_string(dir.join("out.hpgl")).unwrap());
    let trace = dir.join("hpgl-trace.txt");
    let mut sim = std::process::Command::new(plotter_bin())
        .args(["sim", "--pty", "--hpgl", "--hpgl-buffer", "60", "--baud", "38400", "--fast", "--trace"])
        .arg(&trace)
        .current_dir(&dir)
        .stdout(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut port = String::new();
    std::io::BufRead::read_line(&mut std::io::BufReader::new(sim.stdout.take().unwrap()), &mut port).unwrap();
    let port = port.trim();
    let out = plotter(
        &dir,
        &[&["plot", svg, "--port", port, "--firmware", "hpgl", "--baud", "38400"][..], &layout[..]].concat(),
    );
    let pid = nix::unistd::Pid::from_raw(i32::try_from(sim.id()).unwrap());
    // Let the model finish the last moves, then stop it (it writes its trace on SIGINT).
    std::thread::sleep(Duration::from_secs(3));
    nix::sys::signal::kill(pid, nix::sys::signal::Signal::SIGINT).unwrap();
    assert!(sim.wait().unwrap().success());
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}\n{stdout}");
    assert!(stderr.contains("7475A on") && stderr.contains("buffer 60 bytes, handshake escb"), "{stderr}");
    assert!(stdout.contains("bytes/s") && stdout.contains("commands/s"), "{stdout}");
    let text = std::fs::read_to_string(&trace).unwrap();
    let got: Lines = text
        .lines()
        .filter_map(|l| l.strip_prefix("pd "))
        .map(|l| {
            l.split(' ')
                .map(|p| {
                    let (x, y) = p.split_once(',').unwrap();
                    (x.parse().unwrap(), y.parse().unwrap())
                })
                .collect()
        })
        .collect();
    assert_eq!(got, want);
    let summary = text.lines().find(|l| l.starts_with("# hpgl ")).unwrap();
    assert!(summary.contains(" overflow 0 ") && summary.contains(" errors 0 "), "{summary}");
    assert!(summary.contains(" pen_up 1 pen 0 "), "{summary}");
}

#[test]
fn a_pause_mid_stroke_resumes_where_the_pen_was() {
    let (d, paper) = hp7475a();
    let text = program();
    let cmds = Commands::split(&text, d);
    // A command inside a circle (its pen is down before it): pause there and carry on.
    let k = (cmds.list.len() / 3..).find(|&k| cmds.list[k].before.down).unwrap();
    let mut front = Front { pause_at: Some(k), choice: Some(PauseChoice::Resume), ..Front::default() };
    let mut s = HpglSession::connect(model_link(60, true), "model", d, Handshake::Escb).unwrap();
    hplot::plot(&mut s, &cmds, &paper, 0, None, None, &mut front).unwrap();
    assert!(front.asked);
    s.link.finish(60.0);
    let m = s.link.model();
    assert_eq!(m.stats().errors, 0);
    // The same segments; the stroke the pause cut is drawn as two polylines meeting where the pen was lifted.
    let want = drawn_by(&text);
    assert_eq!(segments(&m.trace().to_vec()), segments(&want));
    assert_eq!(m.trace().len(), want.len() + 1);
    assert!(m.pen_up() && m.pen() == 0);
}

/// A drawing the line cannot keep up with: 2000 zigzag steps of 0.05 mm × 0.05 mm (2 plotter units each way),
/// each under 4 ms of pen motion but ten bytes (about 10 ms at 9600 baud). Every handshake must keep the line
/// busy.
#[test]
fn a_line_bound_drawing_keeps_the_line_busy_under_each_handshake() {
    let zigzag = Polyline::new(
        (0..=2000).map(|i| Point::new(40.0 + f64::from(i) * 0.05, 100.0 + f64::from(i % 2) * 0.05)).collect(),
    );
    let mut drawing = Drawing::single_layer("zigzag", vec![zigzag]);
    drawing.page_mm = Some((297.0, 210.0));
    let (d, paper) = hp7475a();
    let text = hpgl_out::export(&MachineProfile::default_plotter(), &drawing, d, &paper).unwrap().text;
    let cmds = Commands::split(&text, d);
    for h in [Handshake::Escb, Handshake::Xonxoff, Handshake::Hardware] {
        let mut s = HpglSession::connect(model_link(60, true), "model", d, h).unwrap();
        let o = hplot::plot(&mut s, &cmds, &paper, 0, None, None, &mut Front::default()).unwrap();
        s.link.finish(60.0);
        let m = s.link.model();
        assert_eq!((m.stats().overflow, m.stats().errors), (0, 0));
        assert_eq!(m.trace(), drawn_by(&text).as_slice());
        let bps = o.stats.bytes as f64 / o.seconds;
        eprintln!(
            "{:>8}: {} bytes, {} commands in {:.2} s: {:.0} bytes/s ({:.0} % of the line), {:.1} commands/s; \
             plotter busy {:.2} s; {} ESC.B queries, {} Xoffs, {} waits",
            h.name(),
            o.stats.bytes,
            o.commands,
            o.seconds,
            bps,
            bps / 9.6,
            o.commands as f64 / o.seconds,
            m.busy_seconds(),
            o.stats.space_queries,
            o.stats.xoffs,
            o.stats.waits
        );
        assert!(m.busy_seconds() < o.seconds * 0.5, "{h:?}: the line, not the plotter, sets the pace");
        // The time is the line's: the HP-GL bytes and the 3-byte `ESC . B` queries at 960 bytes/s, plus the two
        // pen changes (SP1 at the start, SP0 before the last check answers) of 2 s each; 6 % for the rest (the
        // round trips of the queries and the error checks, the last moves).
        let line_s = (o.stats.bytes + 3 * o.stats.space_queries) as f64 / 960.0;
        assert!(o.seconds <= (line_s + 4.0) * 1.06, "{h:?}: {:.2} s for {line_s:.2} s of line time", o.seconds);
        assert!(bps <= 960.0);
    }
}

/// Eight 40 mm strokes on A4 at the export's 6 cm/s: about 2 s for the first pen and 6 s of plotting on the
/// model in real time, a 450-byte program.
const STROKES: &str = r#"<svg xmlns="http://www.w3.org/2000/svg" width="297mm" height="210mm" viewBox="0 0 297 210">
<path d="M40 40 H80 M40 50 H80 M40 60 H80 M40 70 H80 M40 80 H80 M40 90 H80 M40 100 H80 M40 110 H80" fill="none"
 stroke="black"/></svg>"#;

/// `plotter plot strokes.svg --firmware hpgl` on `sim` (a child: the test signals it), with the journal at
/// `dir/plot.journal`.
fn spawn_plot(dir: &std::path::Path, port: &str) -> std::process::Child {
    std::process::Command::new(plotter_bin())
        .args(["plot", "strokes.svg", "--no-optimize", "--firmware", "hpgl", "--journal", "plot.journal", "--port"])
        .arg(port)
        .current_dir(dir)
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap()
}

/// Wait (at most 20 s) until the journal says `ready(accepted, executed, commands)`.
fn wait_for_journal(path: &std::path::Path, ready: impl Fn(usize, usize, usize) -> bool) -> journal::JournalState {
    let t0 = std::time::Instant::now();
    loop {
        if let Ok(j) = journal::load(path)
            && ready(j.accepted, j.executed, j.blocks)
        {
            return j;
        }
        assert!(t0.elapsed() < Duration::from_secs(20), "the plot never got there");
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// The pen-down segments of a model's trace.
fn traced(t: &plotter_e2e::Trace) -> HashSet<((i32, i32), (i32, i32))> {
    let lines: Lines = t
        .pen_down_lines
        .iter()
        .map(|l| l.iter().map(|&(x, y)| (i32::try_from(x).unwrap(), i32::try_from(y).unwrap())).collect())
        .collect();
    segments(&lines)
}

/// A signal to `plotter plot --firmware hpgl` once the journal says `when`: the plotter's buffer is aborted
/// (`ESC . K`) and the pen lifted, the host says why and exits with the stop status (5), and `--resume` on a
/// plotter switched on afresh draws the rest: the two runs together drew every segment of the export.
fn signal_an_hpgl_plot(
    name: &str,
    signal: nix::sys::signal::Signal,
    buffer: &str,
    when: impl Fn(usize, usize, usize) -> bool,
    says: &str,
) {
    let dir = scratch(name);
    std::fs::write(dir.join("strokes.svg"), STROKES).unwrap();
    let out = plotter(&dir, &["plot", "strokes.svg", "--no-optimize", "--export", "strokes.hpgl"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let want = segments(&drawn_by(&std::fs::read_to_string(dir.join("strokes.hpgl")).unwrap()));
    let sim = plotter_e2e::SimPty::start(&dir, &["--hpgl", "--hpgl-buffer", buffer]);
    let host = spawn_plot(&dir, &sim.port);
    let journal_path = dir.join("plot.journal");
    let at = wait_for_journal(&journal_path, when);
    let pid = nix::unistd::Pid::from_raw(i32::try_from(host.id()).unwrap());
    let t0 = std::time::Instant::now();
    nix::sys::signal::kill(pid, signal).unwrap();
    let out = host.wait_with_output().unwrap();
    let took = t0.elapsed();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(5), "the stop status: {stderr}");
    assert!(stderr.contains(&format!("stopped by {says}")), "{stderr}");
    assert!(stderr.contains("stopped with ESC . K") && stderr.contains("--resume"), "{stderr}");
    assert!(took < Duration::from_secs(2), "the host stopped at once: {took:?}");
    let first = sim.stop();
    let figure = |k| plotter_e2e::SimPty::figure(&first, "hpgl", k);
    assert_eq!((figure("aborts"), figure("pen_up"), figure("overflow")), (Some(1), Some(1), Some(0)), "{at:?}");
    let state = journal::load(&journal_path).unwrap();
    assert!(!state.complete && state.executed >= at.executed && state.executed < state.blocks, "{state:?}");

    // Resumed on a plotter switched on afresh (running ahead of the clock).
    let sim = plotter_e2e::SimPty::start(&dir, &["--hpgl", "--hpgl-buffer", buffer, "--fast"]);
    let out = plotter(&dir, &["plot", "--resume", "plot.journal", "--port", &sim.port]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(journal::load(&journal_path).unwrap().complete);
    let second = sim.stop();
    assert_eq!(plotter_e2e::SimPty::figure(&second, "hpgl", "pen_up"), Some(1));
    let mut got = traced(&first);
    assert!(!got.is_empty() && got.len() < want.len(), "the first run drew part of the strokes");
    got.extend(traced(&second));
    assert_eq!(got, want, "together the two runs drew the export");
}

#[test]
fn sigterm_mid_plot_aborts_lifts_the_pen_and_the_journal_resumes() {
    // A 60-byte buffer: the host is still sending when the third stroke is under way.
    signal_an_hpgl_plot("hpgl-sigterm", nix::sys::signal::Signal::SIGTERM, "60", |a, e, n| e >= 9 && a < n, "SIGTERM");
}

#[test]
fn sighup_mid_plot_aborts_lifts_the_pen_and_the_journal_resumes() {
    signal_an_hpgl_plot(
        "hpgl-sighup",
        nix::sys::signal::Signal::SIGHUP,
        "60",
        |a, e, n| e >= 9 && a < n,
        "SIGHUP (the terminal closed)",
    );
}

#[test]
fn ctrl_c_after_the_last_byte_aborts_the_plotters_buffer() {
    // The whole program sits in the 1024-byte buffer long before the plotter has drawn it: a pause cannot come,
    // so Ctrl-C aborts what the plotter holds.
    signal_an_hpgl_plot(
        "hpgl-sigint-end",
        nix::sys::signal::Signal::SIGINT,
        "1024",
        |a, e, n| a == n && e >= 9,
        "Ctrl-C (SIGINT)",
    );
}

/// A port where something else talks (`--hpgl-lie chatter`: a GRBL status line every 20 ms): `--firmware hpgl`
/// gives up within a few seconds and quotes what it heard, instead of draining the line for ever.
#[test]
fn a_babbling_port_is_refused_within_seconds_with_what_it_said() {
    let dir = scratch("hpgl-chatter");
    std::fs::write(dir.join("strokes.svg"), STROKES).unwrap();
    let sim = plotter_e2e::SimPty::start(&dir, &["--hpgl", "--hpgl-lie", "chatter"]);
    let t0 = std::time::Instant::now();
    let out = plotter(&dir, &["plot", "strokes.svg", "--firmware", "hpgl", "--journal", "j", "--port", &sim.port]);
    let took = t0.elapsed();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(stderr.contains("does not answer ESC . L like an HP-GL plotter"), "{stderr}");
    assert!(stderr.contains("it kept sending \"<Idle|MPos:0.000,0.000,0.000|FS:0,0>\\r\\n<Idle"), "{stderr}");
    assert!(took < Duration::from_secs(5), "{took:?}");
}
