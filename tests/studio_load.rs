//! The studio under load. One `plotter serve` with two simulated machines on pseudo-terminals (each paced to the
//! wall clock, in a process of its own) and one machine whose port is missing (its jobs wait). The same small job
//! is plotted twice: first on machine `a` with nobody watching, then on machine `b` while 50 clients watch the
//! event stream, one more client opens the stream and never reads it, and 10 concurrent scripts queue 200 jobs
//! with `POST /api/queue`. Then:
//! - the queue holds each of the 200 jobs exactly once (none lost, none duplicated), in the order each script
//!   queued its own;
//! - the 99th percentile of the API's answer times on loopback (each request timed from connect to its last byte)
//!   is under 100 ms;
//! - the plot watched (and stalled on) takes the time the unwatched one took: the span of the machine's step trace
//!   (its clock follows the wall clock, so a host that fell behind would leave it idle and longer) within 0.1 %.
//!
//! The figures are printed; `STUDIO_LOAD_WATCHERS`, `STUDIO_LOAD_SCRIPTS` and `STUDIO_LOAD_JOBS` change the load.

use std::io::{BufRead as _, BufReader, Write as _};
use std::net::TcpStream;
use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use plotter_e2e::{Served, SimPty, scratch};
use serde_json::Value;

/// The job plotted with and without watchers: a few seconds of short strokes.
const GRID: &str = r#"<svg xmlns="http://www.w3.org/2000/svg" width="40mm" height="40mm" viewBox="0 0 40 40">
  <path d="M 5 5 L 35 5 M 35 10 L 5 10 M 5 15 L 35 15 M 35 20 L 5 20 M 5 25 L 35 25 M 35 30 L 5 30" fill="none" stroke="black"/>
  <circle cx="20" cy="20" r="6" fill="none" stroke="black"/>
</svg>"#;

/// The drawing the scripts queue (for the machine that is not there, so they wait).
const DOT: &str = r#"<svg xmlns="http://www.w3.org/2000/svg" width="20mm" height="20mm" viewBox="0 0 20 20">
  <path d="M 5 5 L 15 15" fill="none" stroke="black"/>
</svg>"#;

fn count(var: &str, default: usize) -> usize {
    std::env::var(var).ok().and_then(|v| v.parse().ok()).unwrap_or(default)
}

/// One HTTP request (the connection closed after it): status, JSON body and the time from connect to the answer's
/// last byte.
fn http(authority: &str, method: &str, path: &str, body: &[u8]) -> (u16, Value, Duration) {
    let (status, body, took) = plotter_e2e::http_once(authority, method, path, body);
    (status, serde_json::from_str(&body).unwrap_or(Value::Null), took)
}

/// Queue `svg` named `name` for `machine`; the job's number and the answer time.
fn add(authority: &str, name: &str, machine: &str, svg: &str) -> (i64, Duration) {
    let (status, v, took) =
        http(authority, "POST", &format!("/api/queue?name={name}&machine={machine}"), svg.as_bytes());
    assert_eq!(status, 201, "queueing {name}: {v}");
    (v["id"].as_i64().expect("a job number"), took)
}

/// Wait (at most 60 s) for job `id` to be done.
fn wait_done(authority: &str, id: i64) {
    let start = Instant::now();
    loop {
        let (status, job, _) = http(authority, "GET", &format!("/api/queue/{id}"), b"");
        assert_eq!(status, 200, "{job}");
        if job["state"] == "done" {
            return;
        }
        assert!(!matches!(job["state"].as_str(), Some("failed" | "cancelled" | "interrupted")), "{job}");
        assert!(start.elapsed() < Duration::from_secs(60), "job {id} did not finish: {job}");
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// The span of a simulator's step trace, µs: from its first step event to its last.
fn trace_span_us(path: &Path) -> u64 {
    let text = std::fs::read_to_string(path).expect("trace written");
    let times: Vec<u64> = text
        .lines()
        .filter(|l| !l.starts_with('#'))
        .filter_map(|l| l.split_whitespace().next()?.parse().ok())
        .collect();
    assert!(times.len() > 100, "the plot stepped: {} events", times.len());
    times[times.len() - 1] - times[0]
}

/// A client that watches the event stream, counting the `studio` events, until `stop`.
fn watcher(authority: String, stop: Arc<AtomicBool>, ready: Arc<AtomicUsize>) -> std::thread::JoinHandle<usize> {
    std::thread::spawn(move || {
        let mut stream = TcpStream::connect(&authority).expect("connect to plotter serve");
        stream.set_read_timeout(Some(Duration::from_millis(200))).expect("read timeout");
        let head = format!("GET /api/events HTTP/1.1\r\nHost: {authority}\r\nAccept: text/event-stream\r\n\r\n");
        stream.write_all(head.as_bytes()).expect("ask for events");
        let mut reader = BufReader::new(stream);
        let mut events = 0;
        let mut line = String::new();
        while !stop.load(Ordering::SeqCst) {
            line.clear();
            match reader.read_line(&mut line) {
                Ok(0) => panic!("the server closed a watcher's event stream"),
                Ok(_) if line.starts_with("event: studio") => {
                    events += 1;
                    if events == 1 {
                        ready.fetch_add(1, Ordering::SeqCst);
                    }
                }
                Ok(_) => {}
                Err(e) if matches!(e.kind(), std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut) => {
                    // A partial line stays in `line` only until the next read: keep what was read.
                }
                Err(e) => panic!("a watcher's read failed: {e}"),
            }
        }
        events
    })
}

/// The time at `q` (0..1) of sorted `times`, ms.
fn percentile(times: &[Duration], q: f64) -> f64 {
    // Short lists: the index is small and exact.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss, clippy::cast_precision_loss)]
    let k = ((times.len() as f64 * q).ceil() as usize).clamp(1, times.len()) - 1;
    times[k].as_secs_f64() * 1e3
}

#[test]
fn fifty_watchers_and_ten_scripts_queueing_two_hundred_jobs_lose_nothing_and_slow_no_plot() {
    let watchers = count("STUDIO_LOAD_WATCHERS", 50);
    let scripts = count("STUDIO_LOAD_SCRIPTS", 10);
    let jobs = count("STUDIO_LOAD_JOBS", 200);
    let per_script = jobs.div_ceil(scripts);
    let dir = scratch("studio-load");
    let (a, b) = (SimPty::start(&dir, &[]), SimPty::start(&dir, &[]));
    let state = dir.join("studio");
    let machines = [format!("a={},firmware=ours", a.port), format!("b={},firmware=ours", b.port)];
    let served = Served::start(&[
        "--listen",
        "127.0.0.1:0",
        "--state",
        state.to_str().expect("utf-8"),
        "--max-connections",
        "512",
        "--machine",
        &machines[0],
        "--machine",
        &machines[1],
        "--machine",
        "away=/dev/no-such-plotter-41,firmware=ours",
    ]);
    let authority = served.authority.clone();

    // The plot alone.
    let (alone, _) = add(&authority, "grid.svg", "a", GRID);
    wait_done(&authority, alone);

    // The watchers, and one client that opens the stream and reads nothing.
    let stop = Arc::new(AtomicBool::new(false));
    let ready = Arc::new(AtomicUsize::new(0));
    let watching: Vec<_> =
        (0..watchers).map(|_| watcher(authority.clone(), Arc::clone(&stop), Arc::clone(&ready))).collect();
    let mut stalled = TcpStream::connect(&authority).expect("connect");
    stalled
        .write_all(format!("GET /api/events HTTP/1.1\r\nHost: {authority}\r\n\r\n").as_bytes())
        .expect("ask for events");
    let start = Instant::now();
    while ready.load(Ordering::SeqCst) < watchers {
        assert!(
            start.elapsed() < Duration::from_secs(30),
            "{} of {watchers} watchers heard",
            ready.load(Ordering::SeqCst)
        );
        std::thread::sleep(Duration::from_millis(20));
    }

    // The plot watched, while the scripts queue.
    let (watched, _) = add(&authority, "grid.svg", "b", GRID);
    let queueing: Vec<_> = (0..scripts)
        .map(|s| {
            let authority = authority.clone();
            std::thread::spawn(move || {
                (0..per_script)
                    .filter(|k| s * per_script + k < jobs)
                    .map(|k| {
                        let (id, took) = add(&authority, &format!("s{s}-{k}.svg"), "away", DOT);
                        (format!("s{s}-{k}.svg"), id, took)
                    })
                    .collect::<Vec<_>>()
            })
        })
        .collect();
    let mut queued = Vec::new();
    for q in queueing {
        queued.extend(q.join().expect("a script"));
    }
    let queue_wall = start.elapsed();
    wait_done(&authority, watched);
    stop.store(true, Ordering::SeqCst);
    let heard: Vec<usize> = watching.into_iter().map(|w| w.join().expect("a watcher")).collect();
    drop(stalled);

    // None lost, none duplicated, each script's jobs in its order.
    let (status, list, list_took) = http(&authority, "GET", "/api/queue", b"");
    assert_eq!(status, 200);
    let listed: Vec<(i64, String)> = list
        .as_array()
        .expect("jobs")
        .iter()
        .filter(|j| j["machine"] == "away")
        .map(|j| (j["id"].as_i64().expect("id"), j["drawing"].as_str().expect("name").to_string()))
        .collect();
    assert_eq!(listed.len(), jobs, "every job queued is listed once");
    let mut names: Vec<&str> = listed.iter().map(|j| j.1.as_str()).collect();
    names.sort_unstable();
    names.dedup();
    assert_eq!(names.len(), jobs, "no drawing listed twice");
    for (name, id, _) in &queued {
        assert!(listed.contains(&(*id, name.clone())), "{name} (job {id}) is listed");
    }
    for s in 0..scripts {
        let mine: Vec<String> =
            listed.iter().filter(|j| j.1.starts_with(&format!("s{s}-"))).map(|j| j.1.clone()).collect();
        let sent: Vec<String> =
            queued.iter().filter(|q| q.0.starts_with(&format!("s{s}-"))).map(|q| q.0.clone()).collect();
        assert_eq!(mine, sent, "script {s}'s jobs in the order it queued them");
    }

    // Answer times.
    let mut times: Vec<Duration> = queued.iter().map(|q| q.2).collect();
    times.sort_unstable();
    let (p50, p99, max) = (percentile(&times, 0.5), percentile(&times, 0.99), percentile(&times, 1.0));

    drop(served);
    let (ta, tb) = (a.trace_path().to_path_buf(), b.trace_path().to_path_buf());
    a.stop();
    b.stop();
    let (span_a, span_b) = (trace_span_us(&ta), trace_span_us(&tb));
    // Microseconds of a few seconds' plot: exact in f64.
    #[allow(clippy::cast_precision_loss)]
    let (sa, sb) = (span_a as f64 / 1e6, span_b as f64 / 1e6);
    eprintln!(
        "{jobs} jobs by {scripts} scripts in {:.2} s with {watchers} watchers (events heard: {}..{}) and a stalled \
         client: answer time p50 {p50:.1} ms, p99 {p99:.1} ms, max {max:.1} ms; the list of {} jobs in {:.1} ms; \
         plot alone {sa:.4} s, watched {sb:.4} s ({:+.3} %)",
        queue_wall.as_secs_f64(),
        heard.iter().min().unwrap_or(&0),
        heard.iter().max().unwrap_or(&0),
        jobs + 2,
        list_took.as_secs_f64() * 1e3,
        100.0 * (sb - sa) / sa
    );
    assert!(heard.iter().all(|&n| n >= 2), "every watcher heard the queue change: {heard:?}");
    assert!(p99 < 100.0, "99th percentile answer time {p99:.1} ms");
    assert!((sb - sa).abs() <= sa * 1e-3, "the watched plot took {sb:.4} s, alone {sa:.4} s");
}
