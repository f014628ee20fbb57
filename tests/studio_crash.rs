//! The studio survives SIGKILL. One `plotter serve` drives our simulated firmware on a pseudo-terminal (a process
//! of its own, so the machine keeps its state and its step trace while the server dies; its clock runs at four
//! times real time) with three queued jobs: one
//! plots, two wait. Twenty times the server is killed with SIGKILL at a random moment (seeded; the seed and every
//! moment are printed), the database is checked with SQLite's `PRAGMA integrity_check`, the server is started again
//! on the same state folder, the queue must hold the same three jobs in the same order (none lost, none
//! duplicated), and the interrupted job is confirmed so that it resumes from its journal. At the end every job has
//! finished exactly once, and the machine's step trace draws exactly what three `plotter plot` runs of the same
//! jobs draw on a fresh simulator: every pen-down step once, in the same order (no stroke drawn twice), and the
//! carriage ends where they end.
//!
//! `STUDIO_CRASH_SEED=N` replays a run.

use std::path::Path;
use std::time::{Duration, Instant};

use plotter_e2e::{Served, SimPty, Trace, plotter, sample, scratch};
use plotter_host::studio::store::{FILE_NAME, Store};
use plotter_path::MachineProfile;
use plotter_path::geometry::steps::StepPos;
use serde_json::Value;

/// How many times the server is killed.
const KILLS: usize = 20;

/// The simulator's clock runs this many times as fast as the wall clock (`plotter sim --pace`): the server still
/// streams to a real serial port, and every wait on the machine (a plot, its queue played out after a kill, homing)
/// takes a quarter of the time. The kill moments are drawn in machine time and waited for in wall time.
const PACE: u32 = 4;

/// The job that plots through the kills: concentric circles near the home corner, each flattened into many short
/// blocks, so that the firmware's queue (which it plays out after the server dies, before a resume can begin) holds
/// about a second of drawing.
fn rings() -> String {
    let circles: String =
        (1..=8).map(|r| format!(r#"<circle cx="18" cy="18" r="{}" fill="none" stroke="black"/>"#, 2 * r)).collect();
    format!(r#"<svg xmlns="http://www.w3.org/2000/svg" width="36mm" height="36mm" viewBox="0 0 36 36">{circles}</svg>"#)
}
/// The two jobs that wait.
const SQUARE: &str = r#"<svg xmlns="http://www.w3.org/2000/svg" width="30mm" height="30mm" viewBox="0 0 30 30">
  <rect x="5" y="5" width="20" height="20" fill="none" stroke="black"/>
</svg>"#;
const CROSS: &str = r#"<svg xmlns="http://www.w3.org/2000/svg" width="30mm" height="30mm" viewBox="0 0 30 30">
  <path d="M 5 5 L 25 25 M 25 5 L 5 25" fill="none" stroke="black"/>
</svg>"#;

/// The plot flags of every job: the drawings at their own size, in the file's order, the circles flattened finely
/// (blocks of about 0.6 mm: the firmware's 32-block queue holds a few tenths of a second of drawing).
const FLAGS: [&str; 3] = ["--no-optimize", "--tolerance", "0.005"];

/// A small seeded generator (xorshift64*), so that a failing run can be replayed.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    /// A duration between `lo` and `hi` milliseconds.
    fn millis(&mut self, lo: u64, hi: u64) -> Duration {
        Duration::from_millis(lo + self.next() % (hi - lo + 1))
    }
}

/// One HTTP request to the server (the connection closed after it): status and JSON body.
fn http(authority: &str, method: &str, path: &str, body: &[u8]) -> (u16, Value) {
    let (status, body, _) = plotter_e2e::http_once(authority, method, path, body);
    (status, serde_json::from_str(&body).unwrap_or(Value::Null))
}

fn start_server(state: &Path, port: &str, profile: &str) -> Served {
    let machine = format!("m={port},firmware=ours,profile={profile}");
    Served::start(&["--listen", "127.0.0.1:0", "--state", state.to_str().expect("utf-8"), "--machine", &machine])
}

/// The queue as the server lists it: (id, state) in queue order.
fn queue(served: &Served) -> Vec<(i64, String)> {
    let (status, jobs) = http(&served.authority, "GET", "/api/queue", b"");
    assert_eq!(status, 200, "{jobs}");
    jobs.as_array()
        .expect("a list of jobs")
        .iter()
        .map(|j| (j["id"].as_i64().expect("an id"), j["state"].as_str().expect("a state").to_string()))
        .collect()
}

/// Wait (at most 30 s) until a job's plot is under way on the machine (homed, blocks executing); its number.
/// `None` once every job is done (the server is then killed idle).
fn wait_for_a_plot(served: &Served) -> Option<i64> {
    let start = Instant::now();
    loop {
        if queue(served).iter().all(|j| j.1 == "done") {
            return None;
        }
        let (status, studio) = http(&served.authority, "GET", "/api/studio", b"");
        assert_eq!(status, 200, "{studio}");
        let m = &studio["machines"][0];
        if m["state"] == "plotting"
            && m["percent"].as_f64().is_some_and(|p| p > 0.0)
            && let Some(job) = m["job"].as_i64()
        {
            return Some(job);
        }
        assert!(start.elapsed() < Duration::from_secs(30), "no plot under way: {m}");
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// The built-in kit with quicker homing (the resumes home the machine 20 times) and its name.
fn quick_homing_profile(dir: &Path) -> String {
    let kit = std::fs::read_to_string(sample("xy-plotter.toml")).expect("the kit's profile");
    let quick: String = kit
        .lines()
        .map(|l| {
            if l.starts_with("seek_mm_s") {
                "seek_mm_s = 100.0".to_string()
            } else if l.starts_with("locate_mm_s") {
                "locate_mm_s = 20.0".to_string()
            } else if l.starts_with("pull_off_mm") {
                "pull_off_mm = 0.5".to_string()
            } else {
                l.to_string()
            }
        })
        .map(|l| l + "\n")
        .collect();
    let path = dir.join("quick-homing.toml");
    std::fs::write(&path, quick).expect("write the profile");
    path.to_str().expect("utf-8").to_string()
}

/// The pen's clearance height (steps): below it the tip may touch the paper.
fn pen_threshold(p: &MachineProfile) -> i64 {
    let clear = (p.pen.down_z_mm + p.pen.clearance_mm) * p.axes.z.steps_per_mm;
    // A small positive value.
    #[allow(clippy::cast_possible_truncation)]
    let t = clear.round() as i64;
    t
}

/// Every pen-down step position of the strokes in order, consecutive repeats merged. A pen-down run that never
/// moves is left out: that is the homing cycle finding the pen's lower switch where the carriage stands (every
/// resume homes the machine first), not a stroke.
fn pen_down_steps(t: &Trace, threshold: i64) -> Vec<StepPos> {
    let mut all: Vec<StepPos> = Vec::new();
    for p in t.pen_down_runs(threshold).into_iter().filter(|r| r.len() > 1).flatten() {
        if all.last() != Some(&p) {
            all.push(p);
        }
    }
    all
}

#[test]
fn sigkill_at_twenty_random_moments_loses_no_job_and_draws_no_stroke_twice() {
    let seed: u64 = std::env::var("STUDIO_CRASH_SEED").ok().and_then(|s| s.parse().ok()).unwrap_or(41);
    eprintln!("seed {seed} (STUDIO_CRASH_SEED={seed} replays this run)");
    let mut rng = Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1);
    let dir = scratch("studio-crash");
    let drawings = [("rings.svg", rings()), ("square.svg", SQUARE.to_string()), ("cross.svg", CROSS.to_string())];
    for (name, svg) in &drawings {
        std::fs::write(dir.join(name), svg).expect("write drawing");
    }
    let t0 = Instant::now();
    // The machine, PACE times real time, outside the server.
    let profile = quick_homing_profile(&dir);
    let sim = SimPty::start(&dir, &["--pace", &PACE.to_string(), "--profile", &profile]);
    let state = dir.join("studio");
    let mut served = start_server(&state, &sim.port, &profile);
    let args = serde_json::to_string(&FLAGS).expect("JSON");
    let ids: Vec<i64> = drawings
        .iter()
        .map(|(name, svg)| {
            let path = format!("/api/queue?name={name}&machine=m&args={}", urlencode(&args));
            let (status, v) = http(&served.authority, "POST", &path, svg.as_bytes());
            assert_eq!(status, 201, "{v}");
            v["id"].as_i64().expect("a job number")
        })
        .collect();
    let mut resumes = 0;
    for kill in 1..=KILLS {
        // A moment while a job is on the machine (the first, resumed, or a later one).
        let on = wait_for_a_plot(&served);
        let after = rng.millis(0, 500);
        std::thread::sleep(after / PACE);
        let before = queue(&served);
        let status = served.stop_with(nix::sys::signal::Signal::SIGKILL, Duration::from_secs(10));
        assert!(!status.success(), "killed");
        // The file is whole as the kill left it.
        let store = Store::open(&state.join(FILE_NAME)).expect("the database opens after the kill");
        assert_eq!(store.integrity_check().expect("integrity check runs"), "ok", "kill {kill}");
        drop(store);
        served = start_server(&state, &sim.port, &profile);
        let after_kill = queue(&served);
        let order: Vec<i64> = after_kill.iter().map(|j| j.0).collect();
        assert_eq!(order, ids, "kill {kill}: the queue holds the same jobs in the same order");
        let interrupted: Vec<i64> = after_kill.iter().filter(|j| j.1 == "interrupted").map(|j| j.0).collect();
        assert!(interrupted.len() <= 1, "kill {kill}: {after_kill:?}");
        eprintln!(
            "kill {kill} {} ms (machine time) into {}: {before:?} -> {after_kill:?} ({:.1} s)",
            after.as_millis(),
            on.map_or_else(|| "the idle studio".to_string(), |j| format!("job {j}'s plot")),
            t0.elapsed().as_secs_f64()
        );
        for id in interrupted {
            let (status, v) = http(&served.authority, "POST", &format!("/api/queue/{id}/confirm"), b"");
            assert_eq!(status, 200, "{v}");
            resumes += 1;
        }
    }
    // Let every job run to its end.
    let deadline = Instant::now() + Duration::from_secs(120);
    loop {
        let q = queue(&served);
        if q.iter().all(|j| j.1 == "done") {
            break;
        }
        assert!(q.iter().all(|j| matches!(j.1.as_str(), "queued" | "plotting" | "done")), "{q:?}");
        assert!(Instant::now() < deadline, "the jobs did not finish: {q:?}");
        std::thread::sleep(Duration::from_millis(100));
    }
    let (_, jobs) = http(&served.authority, "GET", "/api/queue", b"");
    for j in jobs.as_array().expect("jobs") {
        let done = j["history"].as_array().expect("history").iter().filter(|a| a["outcome"] == "done").count();
        assert_eq!(done, 1, "every job finished exactly once: {j}");
    }
    drop(served);
    let crashed = sim.stop();
    let wall = t0.elapsed().as_secs_f64();

    // The same three jobs plotted one after the other by `plotter plot` on a fresh simulator.
    let fresh = SimPty::start(&dir, &["--fast", "--profile", &profile]);
    for (name, _) in &drawings {
        let out = plotter(&dir, &[&["plot", name, "--port", &fresh.port, "--profile", &profile][..], &FLAGS].concat());
        assert!(out.status.success(), "plot {name}: {}", String::from_utf8_lossy(&out.stderr));
    }
    let clean = fresh.stop();
    let threshold = pen_threshold(&MachineProfile::load(Path::new(&profile)).expect("the profile reads"));
    let expected = pen_down_steps(&clean, threshold);
    let got = pen_down_steps(&crashed, threshold);
    assert!(expected.len() > 5000, "the jobs draw: {} pen-down steps", expected.len());
    if got != expected {
        let first = got.iter().zip(&expected).position(|(a, b)| a != b).unwrap_or(got.len().min(expected.len()));
        panic!(
            "pen-down steps differ from the uninterrupted plots: {} vs {} steps, first difference at {first}: {:?} vs \
             {:?}",
            got.len(),
            expected.len(),
            got.get(first),
            expected.get(first)
        );
    }
    assert_eq!(crashed.positions.last(), clean.positions.last(), "the carriage ends where the plots end");
    eprintln!("{KILLS} kills, {resumes} resumes, {} pen-down steps each drawn once; {wall:.1} s", expected.len());
}

/// `text` for a URL's query.
fn urlencode(text: &str) -> String {
    text.bytes()
        .map(|b| {
            if b.is_ascii_alphanumeric() || b"-_.".contains(&b) { (b as char).to_string() } else { format!("%{b:02X}") }
        })
        .collect()
}

/// An idle machine whose port goes away (the simulator ends, as a plotter's USB cable is pulled) shows offline
/// without a job having to fail on it first.
#[test]
fn an_idle_machine_whose_port_goes_away_shows_offline() {
    let dir = scratch("studio-unplugged");
    let sim = SimPty::start(&dir, &["--fast"]);
    let port = sim.port.clone();
    let machine = format!("m={port},firmware=ours");
    let state = dir.join("studio");
    let served =
        Served::start(&["--listen", "127.0.0.1:0", "--state", state.to_str().expect("utf-8"), "--machine", &machine]);
    let machine_state = || {
        let (status, studio) = http(&served.authority, "GET", "/api/studio", b"");
        assert_eq!(status, 200, "{studio}");
        studio["machines"][0].clone()
    };
    let start = Instant::now();
    while machine_state()["state"] != "idle" {
        assert!(start.elapsed() < Duration::from_secs(20), "not idle: {}", machine_state());
        std::thread::sleep(Duration::from_millis(50));
    }
    drop(sim);
    let gone = Instant::now();
    loop {
        let m = machine_state();
        if m["state"] == "offline" {
            let error = m["error"].as_str().unwrap_or_default().to_string();
            assert!(error.contains(&port), "{m}");
            eprintln!("offline {:.2} s after the port went: {error}", gone.elapsed().as_secs_f64());
            break;
        }
        assert!(gone.elapsed() < Duration::from_secs(5), "still {m} 5 s after its port went");
        std::thread::sleep(Duration::from_millis(50));
    }
}
