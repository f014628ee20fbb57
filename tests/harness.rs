//! Shared helpers for the cross-crate end-to-end tests: locating (and building) the `plotter` binary and the
//! samples, scratch directories, the simulated plotter on a pseudo-terminal and its step trace.

use std::io::{BufRead as _, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::sync::OnceLock;

use plotter_path::motion::steps::StepPos;

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

/// Run `plotter` with `args` in `dir` and collect its output.
pub fn plotter(dir: &Path, args: &[&str]) -> Output {
    Command::new(plotter_bin()).args(args).current_dir(dir).output().expect("plotter runs")
}

/// A fresh scratch directory for one test.
pub fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("plotter-e2e-{}-{name}", std::process::id()));
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
        SimPty { child: Some(child), port: line.trim().to_string(), trace }
    }

    /// A figure from a summary line `# <line> … <key> <value> …`.
    pub fn figure(trace: &Trace, line: &str, key: &str) -> Option<i64> {
        let l = trace.comments.iter().find(|c| c.starts_with(line))?;
        let words: Vec<&str> = l.split_whitespace().collect();
        words.windows(2).find(|w| w[0] == key).and_then(|w| w[1].parse().ok())
    }

    /// Stop the simulator (SIGINT) and read its step trace.
    pub fn stop(mut self) -> Trace {
        let mut child = self.child.take().expect("running");
        let pid = nix::unistd::Pid::from_raw(i32::try_from(child.id()).expect("pid fits"));
        nix::sys::signal::kill(pid, nix::sys::signal::Signal::SIGINT).expect("signal the simulator");
        let status = child.wait().expect("simulator exits");
        assert!(status.success(), "simulator failed: {status}");
        Trace::load(&self.trace)
    }
}

impl Drop for SimPty {
    fn drop(&mut self) {
        if let Some(mut c) = self.child.take() {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
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
}

impl Trace {
    /// Parse a trace file written by `plotter sim --trace`.
    pub fn load(path: &Path) -> Trace {
        let text = std::fs::read_to_string(path).expect("trace written");
        let mut positions = Vec::new();
        let mut busy_ticks = 0;
        let mut last_time = None;
        let mut comments = Vec::new();
        for l in text.lines() {
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
        Trace { positions, busy_ticks, comments }
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
