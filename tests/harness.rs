//! Shared helpers for the cross-crate end-to-end tests: locating (and building) the `plotter` binary and the
//! samples, scratch directories, the simulated plotter on a pseudo-terminal and its step trace.

use std::io::{BufRead as _, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::sync::OnceLock;

use plotter_path::geometry::steps::StepPos;

/// The workspace root (holds `samples/`).
pub fn workspace_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).parent().map(PathBuf::from).unwrap_or_default()
}

/// Path of a file in `samples/`.
pub fn sample(name: &str) -> PathBuf {
    workspace_root().join("samples").join(name)
}

/// The `plotter` binary, built once per test process (the tests live in another package, so cargo does not build
/// it for them).
pub fn plotter_bin() -> &'static Path {
    static BIN: OnceLock<PathBuf> = OnceLock::new();
    BIN.get_or_init(|| {
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        let status = Command::new(cargo)
            .args(["build", "--quiet", "-p", "plotter-cli", "--bin", "plotter"])
            .current_dir(workspace_root())
            .status()
            .expect("cargo runs");
        assert!(status.success(), "building the plotter binary failed");
        let target =
            std::env::var_os("CARGO_TARGET_DIR").map_or_else(|| workspace_root().join("target"), PathBuf::from);
        target.join("debug").join("plotter")
    })
}

/// Run `plotter` with `args` in `dir` and collect its output. Its state directory (resume journals of plots on a
/// port) is [`test_state_dir`], not the user's.
pub fn plotter(dir: &Path, args: &[&str]) -> Output {
    Command::new(plotter_bin())
        .args(args)
        .current_dir(dir)
        .env("PLOTTER_STATE_DIR", test_state_dir())
        .output()
        .expect("plotter runs")
}

/// The state directory the harness gives `plotter` (`PLOTTER_STATE_DIR`): one per test process, in the temporary
/// folder, so that tests never write journals into the user's own state directory. Tests that read what is in it
/// give `plotter` a state directory of their own instead.
pub fn test_state_dir() -> PathBuf {
    std::env::temp_dir().join(format!("plotter-e2e-{}-state", std::process::id()))
}

/// [`plotter`] with `input` on its standard input (e.g. one line per pen-change prompt).
pub fn plotter_with_input(dir: &Path, args: &[&str], input: &str) -> Output {
    use std::io::Write as _;
    let mut child = Command::new(plotter_bin())
        .args(args)
        .current_dir(dir)
        .env("PLOTTER_STATE_DIR", test_state_dir())
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("plotter runs");
    child.stdin.take().expect("stdin").write_all(input.as_bytes()).expect("write plotter's input");
    child.wait_with_output().expect("plotter exits")
}

/// A fresh scratch directory for one test, `name` in its name. Every call gets a folder of its own, even for a
/// name given before: the tests run side by side in one process, and two of them with the same name (or one
/// helper that names its folder after its arguments) must not empty each other's folder mid-run.
pub fn scratch(name: &str) -> PathBuf {
    static COUNT: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let n = COUNT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let d = std::env::temp_dir().join(format!("plotter-e2e-{}-{n}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("scratch dir");
    d
}

/// A small drawing with closed shapes (a rectangle, a circle, a triangle) and open curves, in mm.
pub const SAMPLE_SVG: &str = r#"<svg xmlns="http://www.w3.org/2000/svg" width="120mm" height="90mm" viewBox="0 0 120 90">
  <rect x="10" y="10" width="30" height="20" fill="none" stroke="black"/>
  <circle cx="70" cy="30" r="15" fill="none" stroke="black"/>
  <path d="M 10 70 C 30 50, 50 90, 110 70" fill="none" stroke="black"/>
  <path d="M 95 10 L 110 35 L 85 35 Z" fill="none" stroke="black"/>
  <polyline points="20,45 25,52 30,45 35,52 40,45" fill="none" stroke="black"/>
</svg>
"#;

/// The simulated plotter running on a pseudo-terminal (`plotter sim --pty`). Stopped (and its trace read) by
/// [`SimPty::stop`]; killed on drop otherwise.
pub struct SimPty {
    child: Option<Child>,
    /// Device path to pass as `--port`.
    pub port: String,
    trace: PathBuf,
    /// An emulated board's hold on [`QEMU_BOARD`], released once the board is gone (after `Drop` stops it).
    _board: Option<std::sync::MutexGuard<'static, ()>>,
}

impl SimPty {
    /// Start `plotter sim --pty` with extra arguments; the trace goes to `dir`.
    pub fn start(dir: &Path, extra: &[&str]) -> SimPty {
        static COUNT: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
        let n = COUNT.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
        let trace = dir.join(format!("trace-{n}.txt"));
        let mut child = Command::new(plotter_bin())
            .args(["sim", "--pty", "--trace"])
            .arg(&trace)
            .args(extra)
            .current_dir(dir)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("plotter sim starts");
        let mut line = String::new();
        let stdout = child.stdout.take().expect("stdout");
        BufReader::new(stdout).read_line(&mut line).expect("sim prints its port");
        SimPty { child: Some(child), port: line.trim().to_string(), trace, _board: None }
    }

    /// A figure from a summary line `# <line> … <key> <value> …`.
    pub fn figure(trace: &Trace, line: &str, key: &str) -> Option<i64> {
        let l = trace.comments.iter().find(|c| c.starts_with(line))?;
        let words: Vec<&str> = l.split_whitespace().collect();
        words.windows(2).find(|w| w[0] == key).and_then(|w| w[1].parse().ok())
    }

    /// Start `plotter sim --qemu` (the firmware image on the emulated board); the trace goes to `dir`. The image
    /// is built first if needed; one board runs at a time ([`QEMU_BOARD`]).
    pub fn start_qemu(dir: &Path) -> SimPty {
        let board = qemu_board();
        let trace = dir.join("trace-qemu.txt");
        let mut child = Command::new(plotter_bin())
            .args(["sim", "--qemu", "--trace"])
            .arg(&trace)
            .current_dir(dir)
            .stdout(Stdio::piped())
            .spawn()
            .expect("plotter sim --qemu starts");
        let mut line = String::new();
        let stdout = child.stdout.take().expect("stdout");
        BufReader::new(stdout).read_line(&mut line).expect("sim prints its port");
        assert!(line.starts_with("/dev/"), "plotter sim --qemu printed {line:?} instead of a pty path");
        SimPty { child: Some(child), port: line.trim().to_string(), trace, _board: Some(board) }
    }

    /// The trace file (written as the steps happen by `sim --qemu`; on exit by `sim --pty`).
    pub fn trace_path(&self) -> &Path {
        &self.trace
    }

    /// Stop the simulator (SIGINT) and read its step trace.
    pub fn stop(self) -> Trace {
        self.stop_with(nix::sys::signal::Signal::SIGINT)
    }

    /// The simulator's process id.
    pub fn pid(&self) -> i32 {
        i32::try_from(self.child.as_ref().expect("running").id()).expect("pid fits")
    }

    /// Stop the simulator with `signal` and read its step trace (it must exit successfully).
    pub fn stop_with(mut self, signal: nix::sys::signal::Signal) -> Trace {
        let mut child = self.child.take().expect("running");
        let pid = nix::unistd::Pid::from_raw(i32::try_from(child.id()).expect("pid fits"));
        nix::sys::signal::kill(pid, signal).expect("signal the simulator");
        let status = child.wait().expect("simulator exits");
        assert!(status.success(), "simulator failed: {status}");
        Trace::load(&self.trace)
    }
}

impl Drop for SimPty {
    fn drop(&mut self) {
        if let Some(mut c) = self.child.take() {
            // SIGINT first, so that `sim --qemu` takes its emulator down with it; then make sure.
            if let Ok(pid) = i32::try_from(c.id()) {
                let _ = nix::sys::signal::kill(nix::unistd::Pid::from_raw(pid), nix::sys::signal::Signal::SIGINT);
                for _ in 0..100 {
                    if c.try_wait().ok().flatten().is_some() {
                        return;
                    }
                    std::thread::sleep(std::time::Duration::from_millis(20));
                }
            }
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

/// A serial device opened raw by the test itself (to type at the firmware like a terminal would).
pub struct RawPort {
    file: std::fs::File,
    pending: Vec<u8>,
}

impl RawPort {
    /// Open `path` in raw mode with 100 ms read time-outs.
    pub fn open(path: &str) -> RawPort {
        use nix::sys::termios::{SetArg, SpecialCharacterIndices, cfmakeraw, tcgetattr, tcsetattr};
        let file = std::fs::OpenOptions::new().read(true).write(true).open(path).expect("open the port");
        let mut tio = tcgetattr(&file).expect("termios");
        cfmakeraw(&mut tio);
        tio.control_chars[SpecialCharacterIndices::VMIN as usize] = 0;
        tio.control_chars[SpecialCharacterIndices::VTIME as usize] = 1;
        tcsetattr(&file, SetArg::TCSANOW, &tio).expect("raw mode");
        RawPort { file, pending: Vec::new() }
    }

    /// Send bytes.
    pub fn send(&mut self, bytes: &[u8]) {
        use std::io::Write as _;
        self.file.write_all(bytes).expect("write to the port");
    }

    /// Lines received until nothing more arrives for `quiet` (or `limit` has passed).
    pub fn lines_until_quiet(&mut self, quiet: std::time::Duration, limit: std::time::Duration) -> Vec<String> {
        use std::io::Read as _;
        let start = std::time::Instant::now();
        let mut last = start;
        let mut buf = [0u8; 1024];
        while last.elapsed() < quiet && start.elapsed() < limit {
            if let Ok(n) = self.file.read(&mut buf)
                && n > 0
            {
                self.pending.extend_from_slice(&buf[..n]);
                last = std::time::Instant::now();
            }
        }
        self.take_lines()
    }

    /// Lines received until one satisfies `done` (included), or `limit` passes (then the test fails).
    pub fn lines_until(&mut self, done: impl Fn(&str) -> bool, limit: std::time::Duration) -> Vec<String> {
        use std::io::Read as _;
        let start = std::time::Instant::now();
        let mut out = Vec::new();
        let mut buf = [0u8; 1024];
        loop {
            out.extend(self.take_lines());
            if out.iter().any(|l| done(l)) {
                return out;
            }
            assert!(start.elapsed() < limit, "no expected line within {limit:?}; got {out:?}");
            if let Ok(n) = self.file.read(&mut buf) {
                self.pending.extend_from_slice(&buf[..n]);
            }
        }
    }

    fn take_lines(&mut self) -> Vec<String> {
        let mut out = Vec::new();
        while let Some(i) = self.pending.iter().position(|&b| b == b'\n') {
            let line: Vec<u8> = self.pending.drain(..=i).collect();
            out.push(String::from_utf8_lossy(&line[..line.len() - 1]).trim_end_matches('\r').to_string());
        }
        out
    }
}

/// Held by each `plotter sim --qemu` board from its start (which builds the firmware image when it is missing or
/// stale) until it is stopped. Tests run side by side in one process (tests/main.rs); two boards at once would build
/// the same image together, and each emulator takes a core to itself, so that a board booting beside another on a
/// loaded machine missed the 12 s handshake. One at a time, every later board finds the image built.
pub static QEMU_BOARD: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// Take [`QEMU_BOARD`] (a test that panicked while holding it left nothing half done that matters here).
pub fn qemu_board() -> std::sync::MutexGuard<'static, ()> {
    QEMU_BOARD.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// Whether `qemu-system-arm` can run here. Absent outside CI: the caller skips with a message; absent in CI
/// (`CI` set): a failure, since CI installs it.
pub fn qemu_available(test: &str) -> bool {
    let found = Command::new("qemu-system-arm").arg("--version").output().is_ok_and(|o| o.status.success());
    // The image builds for thumbv7m-none-eabi; without rustup, assume the toolchain has it.
    let target = Command::new("rustup")
        .args(["target", "list", "--installed"])
        .output()
        .map_or(true, |o| String::from_utf8_lossy(&o.stdout).lines().any(|l| l.trim() == "thumbv7m-none-eabi"));
    let missing = match (found, target) {
        (true, true) => return true,
        (false, _) => "qemu-system-arm is not installed (apt-get install qemu-system-arm)",
        (true, false) => "the thumbv7m-none-eabi target is not installed (rustup target add thumbv7m-none-eabi)",
    };
    assert!(std::env::var_os("CI").is_none(), "{test}: {missing}; CI installs it (.ci/run)");
    eprintln!("SKIP {test}: {missing}");
    false
}

/// A simulator step trace: the position (steps) after every step event. Steps of several axes in the same timer
/// tick belong to one Bresenham event and are merged (the position between them is not a place the pen visits
/// for any measurable time).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Trace {
    /// Positions `[x, y, z]` after each step event (times left out, so that runs with different pauses compare).
    pub positions: Vec<[i64; 3]>,
    /// Motion time the step timer ran, µs.
    pub busy_ticks: u64,
    /// Other summary lines (`# …`, without the `# `), e.g. the GRBL emulator's figures.
    pub comments: Vec<String>,
    /// The HP-GL model's pen-down polylines (`pd x,y x,y …`), plotter units.
    pub pen_down_lines: Vec<Vec<(i64, i64)>>,
}

impl Trace {
    /// Parse a trace file written by `plotter sim --trace`.
    pub fn load(path: &Path) -> Trace {
        let text = std::fs::read_to_string(path).expect("trace written");
        let mut positions = Vec::new();
        let mut busy_ticks = 0;
        let mut last_time = None;
        let mut comments = Vec::new();
        let mut pen_down_lines = Vec::new();
        for l in text.lines() {
            if let Some(rest) = l.strip_prefix("pd ") {
                let point = |p: &str| {
                    let (x, y) = p.split_once(',').expect("x,y");
                    (x.parse().expect("integer x"), y.parse().expect("integer y"))
                };
                pen_down_lines.push(rest.split_whitespace().map(point).collect());
                continue;
            }
            if let Some(rest) = l.strip_prefix("# busy_ticks ") {
                busy_ticks = rest.split_whitespace().next().and_then(|v| v.parse().ok()).expect("busy ticks");
                continue;
            }
            if let Some(rest) = l.strip_prefix("# ") {
                comments.push(rest.to_string());
                continue;
            }
            let v: Vec<i64> = l.split_whitespace().map(|t| t.parse().expect("integer")).collect();
            let p = [v[1], v[2], v[3]];
            if last_time == Some(v[0]) {
                *positions.last_mut().expect("an event") = p;
            } else {
                positions.push(p);
            }
            last_time = Some(v[0]);
        }
        Trace { positions, busy_ticks, comments, pen_down_lines }
    }

    /// The pen-down runs: maximal sequences of XY positions visited while Z is below `z_threshold` (steps),
    /// consecutive repeats removed.
    pub fn pen_down_runs(&self, z_threshold: i64) -> Vec<Vec<StepPos>> {
        let mut runs = Vec::new();
        let mut cur: Vec<StepPos> = Vec::new();
        for p in &self.positions {
            if p[2] < z_threshold {
                let s = StepPos::new(i32::try_from(p[0]).expect("x"), i32::try_from(p[1]).expect("y"));
                if cur.last() != Some(&s) {
                    cur.push(s);
                }
            } else if !cur.is_empty() {
                runs.push(std::mem::take(&mut cur));
            }
        }
        if !cur.is_empty() {
            runs.push(cur);
        }
        runs
    }

    /// Every step position with XY moving while Z is below the threshold must not coincide with a Z step: returns
    /// the number of steps where XY moved between two positions at different Z (should be 0: pen moves are pure Z).
    pub fn mixed_xy_z_steps(&self) -> usize {
        self.positions.windows(2).filter(|w| w[0][2] != w[1][2] && (w[0][0] != w[1][0] || w[0][1] != w[1][1])).count()
    }
}

/// Distance from `p` to segment `a`–`b`.
pub fn point_segment_distance(p: (f64, f64), a: (f64, f64), b: (f64, f64)) -> f64 {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let len2 = dx * dx + dy * dy;
    let t = if len2 > 0.0 { (((p.0 - a.0) * dx + (p.1 - a.1) * dy) / len2).clamp(0.0, 1.0) } else { 0.0 };
    let (cx, cy) = (a.0 + t * dx, a.1 + t * dy);
    (p.0 - cx).hypot(p.1 - cy)
}

/// An axis-aligned cube of edge `size` mm with its minimum corner at the origin, as ASCII STL: 12 triangles, each
/// wound counter-clockwise seen from outside with its outward unit normal (the STL convention slicers expect).
pub fn cube_stl(size: f64) -> String {
    // Corners by bits: x = bit 0, y = bit 1, z = bit 2.
    let corner = |i: usize| {
        let bit = |b: usize| if i & (1 << b) != 0 { size } else { 0.0 };
        [bit(0), bit(1), bit(2)]
    };
    // Each face: outward normal and its four corners counter-clockwise seen from outside.
    let faces: [([f64; 3], [usize; 4]); 6] = [
        ([0.0, 0.0, -1.0], [0, 2, 3, 1]),
        ([0.0, 0.0, 1.0], [4, 5, 7, 6]),
        ([0.0, -1.0, 0.0], [0, 1, 5, 4]),
        ([0.0, 1.0, 0.0], [2, 6, 7, 3]),
        ([-1.0, 0.0, 0.0], [0, 4, 6, 2]),
        ([1.0, 0.0, 0.0], [1, 3, 7, 5]),
    ];
    let mut out = String::from("solid cube\n");
    for (n, q) in faces {
        for tri in [[q[0], q[1], q[2]], [q[0], q[2], q[3]]] {
            out.push_str(&format!(" facet normal {} {} {}\n  outer loop\n", n[0], n[1], n[2]));
            for v in tri {
                let p = corner(v);
                out.push_str(&format!("   vertex {} {} {}\n", p[0], p[1], p[2]));
            }
            out.push_str("  endloop\n endfacet\n");
        }
    }
    out.push_str("endsolid cube\n");
    out
}

/// The G-code fixture sliced by PrusaSlicer from [`cube_stl`]`(20.0)` (see `tests/print_slicer.rs`).
pub fn fixture(name: &str) -> PathBuf {
    workspace_root().join("tests").join("fixtures").join(name)
}

/// Feed every block of `plan` to the simulated firmware as framed step blocks numbered from its expected sequence
/// number, run it until idle, and check that each frame got its `ok`; returns all replies. (The simulated wire is
/// flow-controlled: bytes wait until the receive buffer has room.)
pub fn play_framed(sim: &mut plotter_fw::sim::Sim, plan: &plotter_path::motion::plan::MotionPlan) -> Vec<String> {
    use plotter_fw::protocol::{Encoder, MAX_FRAME};
    let seq0 = sim.machine().expected_seq();
    let mut enc = Encoder::new();
    let mut buf = [0u8; MAX_FRAME];
    for (i, b) in plan.blocks.iter().enumerate() {
        let n =
            enc.encode(&b.block, seq0 + u32::try_from(i).expect("fewer than 2³² blocks"), &mut buf).expect("encodes");
        sim.feed(&buf[..n]);
    }
    sim.run_until_idle();
    let replies = sim.take_replies();
    assert_eq!(replies.iter().filter(|l| *l == "ok").count(), plan.blocks.len(), "{replies:?}");
    replies
}

/// `plotter serve` running in the background (killed when dropped).
pub struct Served {
    child: Child,
    /// The page's address, as the server printed it (`http://127.0.0.1:PORT/`).
    pub url: String,
    /// Its `host:port`, for `Host` headers and connections.
    pub authority: String,
}

impl Served {
    /// Start `plotter serve` with `args` (e.g. `--listen 127.0.0.1:0` for an ephemeral loopback port) and wait
    /// for the address it prints.
    pub fn start(args: &[&str]) -> Served {
        let mut child = Command::new(plotter_bin())
            .arg("serve")
            .args(args)
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .expect("plotter serve starts");
        let mut line = String::new();
        BufReader::new(child.stdout.take().expect("stdout"))
            .read_line(&mut line)
            .expect("plotter serve prints its URL");
        let url =
            line.trim().strip_prefix("plotter serve: ").unwrap_or_else(|| panic!("unexpected first line {line:?}"));
        let authority = url.trim_start_matches("http://").trim_end_matches('/').to_string();
        Served { child, url: url.to_string(), authority }
    }
}

impl Served {
    /// The server's process id.
    pub fn pid(&self) -> u32 {
        self.child.id()
    }

    /// Send `signal` to the server and wait (at most `limit`) for it to exit; its exit status.
    pub fn stop_with(
        mut self,
        signal: nix::sys::signal::Signal,
        limit: std::time::Duration,
    ) -> std::process::ExitStatus {
        let pid = nix::unistd::Pid::from_raw(i32::try_from(self.child.id()).expect("pid fits"));
        nix::sys::signal::kill(pid, signal).expect("signal the server");
        let start = std::time::Instant::now();
        loop {
            if let Some(status) = self.child.try_wait().expect("wait for the server") {
                return status;
            }
            assert!(start.elapsed() < limit, "plotter serve still runs {limit:?} after {signal:?}");
            std::thread::sleep(std::time::Duration::from_millis(20));
        }
    }
}

impl Drop for Served {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// The "never ink off the drawing" check (issue 25): the pen may be below its clearance height only where the XY
/// position lies on a stroke of the drawing. `samples` are the XY positions (steps) after each step event with
/// whether the pen was then below the clearance; `strokes` the drawing's paths in machine millimetres (flattened,
/// as imported); a low position passes when it is within `tolerance_mm` + half a step of one of them. The
/// simulator starts with the pen resting on the paper where the carriage stands, so nothing before the first XY
/// motion counts (homing lifts the pen there first). Returns the offending positions (empty: the check passes).
pub fn ink_off_drawing(
    samples: impl IntoIterator<Item = (bool, [i64; 2])>,
    strokes: &[Vec<(f64, f64)>],
    steps_per_mm: f64,
    tolerance_mm: f64,
) -> Vec<[i64; 2]> {
    let limit = tolerance_mm + 0.5 / steps_per_mm + 1e-9;
    let segments: Vec<((f64, f64), (f64, f64))> = strokes
        .iter()
        .flat_map(|s| {
            let pairs: Vec<_> = s.windows(2).map(|w| (w[0], w[1])).collect();
            if s.len() == 1 { vec![(s[0], s[0])] } else { pairs }
        })
        .collect();
    let mut off = Vec::new();
    let mut first: Option<[i64; 2]> = None;
    let mut moved = false;
    // The segment that matched last: consecutive low positions are nearly always on it or its neighbours.
    let mut hint = 0usize;
    for (low, xy) in samples {
        moved = moved || first.is_some_and(|f| f != xy);
        first.get_or_insert(xy);
        if !low || !moved {
            continue;
        }
        #[allow(clippy::cast_precision_loss, reason = "step positions are far below 2^52")]
        let q = (xy[0] as f64 / steps_per_mm, xy[1] as f64 / steps_per_mm);
        let near = |i: usize| point_segment_distance(q, segments[i].0, segments[i].1) <= limit;
        let lo = hint.saturating_sub(2);
        let hit =
            (lo..(hint + 3).min(segments.len())).find(|&i| near(i)).or_else(|| (0..segments.len()).find(|&i| near(i)));
        match hit {
            Some(i) => hint = i,
            None => off.push(xy),
        }
    }
    off
}

/// The positions `[x, y, z]` (steps) after each step event of an in-process simulator, with their times (ticks);
/// steps of one Bresenham event (the same tick) are merged, as in [`Trace`].
pub fn sim_positions(sim: &plotter_fw::sim::Sim) -> Vec<(u64, [i64; 3])> {
    let mut pos = sim.hal().physical_position();
    for e in sim.hal().steps().iter().rev() {
        pos[e.axis.index()] -= if e.forward { 1 } else { -1 };
    }
    let mut out: Vec<(u64, [i64; 3])> = Vec::new();
    for e in sim.hal().steps() {
        pos[e.axis.index()] += if e.forward { 1 } else { -1 };
        let p = [pos[0], pos[1], pos[2]];
        match out.last_mut() {
            Some(last) if last.0 == e.time => last.1 = p,
            _ => out.push((e.time, p)),
        }
    }
    out
}

/// The times (ticks) during which a servo pen is below its clearance, from the simulator's servo commands: a drop
/// (any angle but `up_deg`) brings the tip down to the clearance `settle − clear` ticks after its command, and a
/// lift takes it back up past the clearance `clear` ticks after its command. Half-open intervals.
pub fn servo_low_intervals(servo: &[(u64, f32, u16)], up_deg: f32, settle: u64, clear: u64) -> Vec<(u64, u64)> {
    let mut out = Vec::new();
    let mut down_since: Option<u64> = None;
    for &(t, angle, _) in servo {
        let is_up = (angle - up_deg).abs() < 0.05;
        match (is_up, down_since) {
            (false, None) => down_since = Some(t),
            (true, Some(d)) => {
                out.push((d + settle - clear, t + clear));
                down_since = None;
            }
            _ => {}
        }
    }
    if let Some(d) = down_since {
        out.push((d + settle - clear, u64::MAX));
    }
    out
}

/// The paths of `drawing` in machine millimetres through `profile`'s page mapping (what [`ink_off_drawing`]
/// checks against).
pub fn machine_paths(profile: &plotter_path::MachineProfile, drawing: &plotter_path::Drawing) -> Vec<Vec<(f64, f64)>> {
    drawing
        .paths()
        .map(|p| p.points.iter().map(|q| profile.page_to_machine(*q)).map(|q| (q.x, q.y)).collect())
        .collect()
}

/// One HTTP/1.1 request to a local server, the connection closed after it: the answer's status (0 when it has
/// none), its body after the headers, and the time from connecting to the answer's last byte.
pub fn http_once(authority: &str, method: &str, path: &str, body: &[u8]) -> (u16, String, std::time::Duration) {
    use std::io::{Read as _, Write as _};
    let start = std::time::Instant::now();
    let mut stream = std::net::TcpStream::connect(authority).expect("connect to the server");
    stream.set_read_timeout(Some(std::time::Duration::from_secs(30))).expect("read timeout");
    let head = format!(
        "{method} {path} HTTP/1.1\r\nHost: {authority}\r\nConnection: close\r\nContent-Length: {}\r\n\r\n",
        body.len()
    );
    stream.write_all(head.as_bytes()).and_then(|()| stream.write_all(body)).expect("send the request");
    let mut bytes = Vec::new();
    stream.read_to_end(&mut bytes).expect("the server answers");
    let took = start.elapsed();
    let text = String::from_utf8_lossy(&bytes);
    let status = text.split(' ').nth(1).and_then(|s| s.parse().ok()).unwrap_or(0);
    let body = text.split_once("\r\n\r\n").map_or("", |(_, b)| b).to_string();
    (status, body, took)
}

#[cfg(test)]
mod tests {
    use super::scratch;

    #[test]
    fn scratch_gives_each_call_its_own_empty_folder_even_under_one_name() {
        let first = scratch("same-name");
        std::fs::write(first.join("trace.txt"), "kept").unwrap();
        let second = scratch("same-name");
        assert_ne!(first, second);
        assert!(second.is_dir() && std::fs::read_dir(&second).unwrap().next().is_none(), "{}", second.display());
        assert_eq!(std::fs::read_to_string(first.join("trace.txt")).unwrap(), "kept", "the first folder is untouched");
        for d in [first, second] {
            std::fs::remove_dir_all(d).unwrap();
        }
    }
}
