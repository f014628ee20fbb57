//! The web app drives a GRBL controller and an EiBotBoard as well as our firmware: `plotter serve --port <pty>`
//! in front of `plotter sim --pty --grbl` / `--ebb`, connected with firmware `auto` through the HTTP API, plots a
//! generated circle after a home and a jog through the same connection; the emulator's trace must show pen-down
//! steps that moved and the pen up at the end. An HP-GL plotter (`plotter sim --pty --hpgl`, the HP 7440A's
//! 60-byte buffer) is connected with firmware `hpgl` (an unknown device, sheet or handshake, or a body of the wrong
//! shape, refused with a 400 first): home and jog are refused, the console and the pen buttons
//! speak HP-GL, the circle is streamed without an overflow, and a second plot paused and cancelled from the page
//! ends with the pen up and put away.

use std::io::{BufRead as _, BufReader, Read as _, Write as _};
use std::net::TcpStream;
use std::sync::mpsc;
use std::time::{Duration, Instant};

use plotter_e2e::{Served, SimPty, Trace, sample, scratch};
use serde_json::{Value, json};

/// One request with the control token and a JSON body; its status and JSON answer.
fn api(served: &Served, token: &str, method: &str, path: &str, body: &Value) -> (u16, Value) {
    let mut stream = TcpStream::connect(&served.authority).expect("connect to plotter serve");
    stream.set_read_timeout(Some(Duration::from_secs(30))).expect("read timeout");
    let body = body.to_string();
    let head = format!(
        "{method} {path} HTTP/1.1\r\nHost: {}\r\nConnection: close\r\nX-Plotter-Token: {token}\r\n\
         Content-Type: application/json\r\nContent-Length: {}\r\n\r\n{body}",
        served.authority,
        body.len()
    );
    stream.write_all(head.as_bytes()).expect("send");
    let mut answer = String::new();
    stream.read_to_string(&mut answer).expect("the server answers and closes");
    let status = answer.split(' ').nth(1).and_then(|s| s.parse().ok()).unwrap_or(0);
    let json = answer.split_once("\r\n\r\n").map_or("", |(_, b)| b);
    (status, serde_json::from_str(json).unwrap_or(Value::Null))
}

/// A page: it holds control and listens to the event stream (the claim lapses without one).
struct Page {
    token: String,
    /// `(event name, data)` of every server-sent event.
    events: mpsc::Receiver<(String, String)>,
}

impl Page {
    fn open(served: &Served) -> Page {
        let (status, v) = api(served, "", "POST", "/api/control/claim", &Value::Null);
        assert_eq!(status, 200, "{v}");
        let token = v["token"].as_str().expect("a token").to_string();
        let mut stream = TcpStream::connect(&served.authority).expect("connect to plotter serve");
        let get = format!("GET /api/events?token={token} HTTP/1.1\r\nHost: {}\r\n\r\n", served.authority);
        stream.write_all(get.as_bytes()).expect("send");
        let (tx, events) = mpsc::channel();
        std::thread::spawn(move || {
            let mut name = String::new();
            for line in BufReader::new(stream).lines() {
                let Ok(line) = line else { break };
                if let Some(n) = line.strip_prefix("event: ") {
                    name = n.to_string();
                } else if let Some(d) = line.strip_prefix("data: ")
                    && tx.send((name.clone(), d.to_string())).is_err()
                {
                    break;
                }
            }
        });
        Page { token, events }
    }

    fn post(&self, served: &Served, path: &str, body: Value) -> (u16, Value) {
        api(served, &self.token, "POST", path, &body)
    }

    /// The data of the next event named `name` within `limit`; every `log` line seen meanwhile goes to `log`.
    fn wait_event(&self, name: &str, limit: Duration, log: &mut Vec<String>) -> Value {
        let end = Instant::now() + limit;
        loop {
            let left = end.saturating_duration_since(Instant::now());
            let (n, d) = self.events.recv_timeout(left).unwrap_or_else(|_| panic!("no {name} event; log: {log:#?}"));
            if n == "log" {
                log.push(d.clone());
            }
            if n == name {
                return serde_json::from_str(&d).expect("JSON event data");
            }
        }
    }

    /// Wait (within `limit`) for a `log` line whose text starts with `start`; the first `error` line fails.
    fn wait_log(&self, start: &str, limit: Duration) {
        let mut log = Vec::new();
        loop {
            let line = self.wait_event("log", limit, &mut log);
            let text = line["text"].as_str().unwrap_or_default();
            assert_ne!(line["dir"], "error", "{text}");
            if text.starts_with(start) {
                return;
            }
        }
    }

    /// The state once `ready` holds of it (polled), within `limit`.
    fn wait_state(&self, served: &Served, what: &str, limit: Duration, ready: impl Fn(&Value) -> bool) -> Value {
        let end = Instant::now() + limit;
        loop {
            let (_, s) = api(served, &self.token, "GET", "/api/state", &Value::Null);
            if ready(&s) {
                return s;
            }
            assert!(Instant::now() < end, "{what} not reached: {s}");
            std::thread::sleep(Duration::from_millis(50));
        }
    }
}

/// Serve `sim`'s port (with `profile`, when given, chosen), connect with firmware auto and plot a circle; the
/// connected machine's description and the emulator's trace.
fn plot_through_the_web_app(sim: SimPty, profile: Option<(&str, &str)>) -> (String, Trace) {
    let mut args = vec!["--listen", "127.0.0.1:0", "--port", sim.port.as_str()];
    let path;
    if let Some((file, _)) = profile {
        path = sample(file).to_str().expect("utf-8 path").to_string();
        args.extend(["--profile", path.as_str()]);
    }
    let served = Served::start(&args);
    let page = Page::open(&served);
    if let Some((_, name)) = profile {
        let (status, v) = page.post(&served, "/api/profile", json!({ "name": name }));
        assert_eq!(status, 200, "{v}");
    }
    let (status, v) = page.post(&served, "/api/gen", json!({ "spec": "circle?r=10&cx=50&cy=50" }));
    assert_eq!(status, 200, "{v}");
    page.wait_state(&served, "a prepared drawing", Duration::from_secs(60), |s| !s["prepared"].is_null());
    let (status, v) = page.post(&served, "/api/connect", json!({ "target": sim.port, "firmware": "auto" }));
    assert_eq!(status, 200, "{v}");
    let state = page.wait_state(&served, "connected", Duration::from_secs(60), |s| {
        !s["machine"]["connected"].is_null() || !s["machine"]["error"].is_null()
    });
    let connected = state["machine"]["connected"].as_str().unwrap_or_else(|| panic!("not connected: {state}"));
    let connected = connected.to_string();
    // Home and jog go through the connected dialect: 10 mm of X at 80 steps/mm (both profiles) is 800 steps.
    let (status, v) = page.post(&served, "/api/home", json!({}));
    assert_eq!(status, 200, "{v}");
    page.wait_log("homed", Duration::from_secs(60));
    let homed = page.wait_state(&served, "idle", Duration::from_secs(60), |s| s["machine"]["activity"] == "idle");
    let x0 = homed["machine"]["position"][0].as_i64().expect("x steps");
    let (status, v) = page.post(&served, "/api/jog", json!({ "axis": "x", "mm": 10.0 }));
    assert_eq!(status, 200, "{v}");
    page.wait_log("at X 10.00 Y 0.00 mm", Duration::from_secs(60));
    let jogged = page.wait_state(&served, "idle", Duration::from_secs(60), |s| s["machine"]["activity"] == "idle");
    assert_eq!(jogged["machine"]["position"][0].as_i64(), Some(x0 + 800), "{jogged}");
    let (status, v) = page.post(&served, "/api/plot", json!({}));
    assert_eq!(status, 200, "{v}");
    let mut log = Vec::new();
    let done = page.wait_event("done", Duration::from_secs(120), &mut log);
    assert_eq!(done["ok"], true, "{done}; log: {log:#?}");
    drop(page);
    drop(served);
    (connected, sim.stop())
}

#[test]
fn the_web_app_plots_on_a_grbl_controller_told_by_auto() {
    let dir = scratch("serve-grbl");
    let sim = SimPty::start(&dir, &["--grbl", "--fast"]);
    let (connected, trace) = plot_through_the_web_app(sim, None);
    assert!(connected.starts_with("GRBL 1.1"), "{connected}");
    assert_eq!(SimPty::figure(&trace, "grbl", "errors"), Some(0));
    assert_eq!(SimPty::figure(&trace, "grbl", "overflow"), Some(0));
    // The built-in profile: 400 Z steps per mm, pen down at 0 mm, up at 4 mm (1600 steps); the clearance is 1 mm.
    let moving = trace.pen_down_runs(400).into_iter().filter(|r| r.iter().any(|p| *p != r[0])).count();
    assert_eq!(moving, 1, "one circle, drawn in one stroke");
    let last = trace.positions.last().copied().expect("the emulator moved");
    assert_eq!(last[2], 1600, "the plot ends with the pen up: {last:?}");
}

#[test]
fn the_web_app_plots_on_an_eibotboard_told_by_auto() {
    let dir = scratch("serve-ebb");
    let sim = SimPty::start(&dir, &["--ebb", "--fast"]);
    let (connected, trace) = plot_through_the_web_app(sim, Some(("axidraw-v3.toml", "AxiDraw V3 (A4)")));
    assert!(connected.starts_with("EiBotBoard firmware"), "{connected}");
    // Auto's probe `$I` is answered with an unknown-command error: that one, nothing else.
    assert_eq!(SimPty::figure(&trace, "ebb", "errors"), Some(1));
    assert_eq!(SimPty::figure(&trace, "ebb", "estops"), Some(0));
    assert_eq!(SimPty::figure(&trace, "ebb", "pen_up"), Some(1), "the plot ends with the pen up");
    // The trace's third column is the pen, 1 while up.
    let moving = trace.pen_down_runs(1).into_iter().filter(|r| r.iter().any(|p| *p != r[0])).count();
    assert_eq!(moving, 1, "one circle, drawn in one stroke");
}

#[test]
fn the_web_app_plots_on_an_hpgl_plotter_with_a_60_byte_buffer() {
    let dir = scratch("serve-hpgl");
    let sim = SimPty::start(&dir, &["--hpgl", "--hpgl-buffer", "60", "--fast"]);
    let served = Served::start(&["--listen", "127.0.0.1:0", "--port", sim.port.as_str()]);
    let page = Page::open(&served);
    let (status, v) = page.post(&served, "/api/gen", json!({ "spec": "circle?r=10&cx=50&cy=50" }));
    assert_eq!(status, 200, "{v}");
    page.wait_state(&served, "a prepared drawing", Duration::from_secs(60), |s| !s["prepared"].is_null());
    // A handshake that is not one is refused before anything is opened.
    let (status, v) =
        page.post(&served, "/api/connect", json!({ "target": sim.port, "firmware": "hpgl", "handshake": "rts" }));
    assert_eq!(status, 400, "{v}");
    assert_eq!(v["error"], "handshake \"rts\": use escb, xonxoff or hardware", "{v}");
    // So is a plotter not in the device table, a sheet the device does not take, and a body of the wrong shape:
    // each a 400 naming the field and the choices.
    for (body, want) in [
        (
            json!({ "target": sim.port, "firmware": "hpgl", "hpgl_device": "7470b" }),
            "hpgl_device \"7470b\": not a known plotter (known: 7475a, 7550a, dxy-1300, generic)",
        ),
        (
            json!({ "target": sim.port, "firmware": "hpgl", "hpgl_device": "dxy-1300", "hpgl_paper": "a4" }),
            "hpgl_paper \"a4\": the Roland DXY-1300 takes a3",
        ),
        (json!({ "target": sim.port, "firmware": "hpgl", "hpgl_device": 7475 }), "connect: "),
    ] {
        let (status, v) = page.post(&served, "/api/connect", body.clone());
        assert_eq!(status, 400, "{body}: {v}");
        assert!(v["error"].as_str().is_some_and(|e| e.starts_with(want)), "{body}: {v}");
    }
    // The page's selectors come from the same table.
    let (status, table) = api(&served, &page.token, "GET", "/api/hpgl", &Value::Null);
    assert_eq!(status, 200, "{table}");
    let ids: Vec<&str> = table["devices"].as_array().unwrap().iter().filter_map(|d| d["id"].as_str()).collect();
    assert_eq!(ids, ["7475a", "7550a", "dxy-1300", "generic"]);
    assert_eq!(table["devices"][2]["buffer_bytes"], 1024, "{table}");
    let (status, v) = page.post(&served, "/api/connect", json!({ "target": sim.port, "firmware": "hpgl" }));
    assert_eq!(status, 200, "{v}");
    let state = page.wait_state(&served, "connected", Duration::from_secs(60), |s| {
        !s["machine"]["connected"].is_null() || !s["machine"]["error"].is_null()
    });
    let connected = state["machine"]["connected"].as_str().unwrap_or_else(|| panic!("not connected: {state}"));
    assert!(connected.starts_with("7475A on ") && connected.contains("buffer 60 bytes, handshake escb"), "{connected}");
    assert_eq!(state["machine"]["hpgl"], true, "{state}");
    // No homing and no jogging on an HP-GL plotter: refused, with what to do instead.
    for (path, body) in [("/api/home", json!({})), ("/api/jog", json!({ "axis": "x", "mm": 10.0 }))] {
        let (status, v) = page.post(&served, path, body);
        assert_eq!(status, 409, "{path}: {v}");
        assert!(v["error"].as_str().unwrap_or_default().contains("no homing cycle"), "{path}: {v}");
    }
    // The console sends HP-GL: OI is answered with the model. The pen lifts with PU.
    let (status, v) = page.post(&served, "/api/console", json!({ "line": "OI;" }));
    assert_eq!(status, 200, "{v}");
    page.wait_log("7475A", Duration::from_secs(30));
    page.wait_state(&served, "idle", Duration::from_secs(30), |s| s["machine"]["activity"] == "idle");
    let (status, v) = page.post(&served, "/api/pen", json!({ "down": false }));
    assert_eq!(status, 200, "{v}");
    page.wait_log("pen up", Duration::from_secs(30));
    page.wait_state(&served, "idle", Duration::from_secs(30), |s| s["machine"]["activity"] == "idle");
    let (status, v) = page.post(&served, "/api/plot", json!({}));
    assert_eq!(status, 200, "{v}");
    let mut log = Vec::new();
    let done = page.wait_event("done", Duration::from_secs(120), &mut log);
    assert_eq!(done["ok"], true, "{done}; log: {log:#?}");
    let message = done["message"].as_str().unwrap_or_default();
    assert!(message.contains("HP-GL commands for the HP 7475A on a4"), "{message}");
    let (_, s) = api(&served, &page.token, "GET", "/api/state", &Value::Null);
    let progress = &s["progress"];
    assert!(progress["total"].as_u64().is_some_and(|t| t > 10), "{s}");
    assert_eq!(progress["executed"], progress["total"], "{s}");
    assert_eq!(progress["percent"], 100.0, "{s}");
    let drawn = progress["draw_done_mm"].as_f64().unwrap_or_default();
    assert!((drawn / (std::f64::consts::TAU * 10.0) - 1.0).abs() < 0.01, "{drawn} mm pen-down: {s}");
    drop(page);
    drop(served);
    let trace = sim.stop();
    assert_eq!(SimPty::figure(&trace, "hpgl", "overflow"), Some(0));
    assert_eq!(SimPty::figure(&trace, "hpgl", "errors"), Some(0));
    assert_eq!(SimPty::figure(&trace, "hpgl", "pen_up"), Some(1), "the plot ends with the pen up");
    assert_eq!(SimPty::figure(&trace, "hpgl", "pen"), Some(0), "and the pen put away");
    // One circle in one stroke: 10 mm is 400 plotter units from its centre (rounding to a unit and the
    // flattening of the arc leave less than 4), closed, 2π·10 mm = 2513 units round within 1 %.
    assert_eq!(trace.pen_down_lines.len(), 1, "{:?}", trace.pen_down_lines);
    let line = &trace.pen_down_lines[0];
    // Plotter units: far below 2^53.
    #[allow(clippy::cast_precision_loss)]
    let pts: Vec<(f64, f64)> = line.iter().map(|&(x, y)| (x as f64, y as f64)).collect();
    #[allow(clippy::cast_precision_loss)]
    let n = pts.len() as f64;
    let centre = (pts.iter().map(|p| p.0).sum::<f64>() / n, pts.iter().map(|p| p.1).sum::<f64>() / n);
    for p in &pts {
        let r = (p.0 - centre.0).hypot(p.1 - centre.1);
        assert!((r - 400.0).abs() < 4.0, "{p:?} is {r} units from the centre {centre:?}");
    }
    let (first, last) = (pts[0], pts[pts.len() - 1]);
    assert!((first.0 - last.0).hypot(first.1 - last.1) <= 1.5, "not closed: {first:?} {last:?}");
    let length: f64 = pts.windows(2).map(|w| (w[1].0 - w[0].0).hypot(w[1].1 - w[0].1)).sum();
    let want = std::f64::consts::TAU * 400.0;
    assert!((length / want - 1.0).abs() < 0.01, "{length} units drawn, {want} wanted");
}

#[test]
fn an_hpgl_plot_paused_and_cancelled_from_the_page_puts_the_pen_away() {
    let dir = scratch("serve-hpgl-cancel");
    let sim = SimPty::start(&dir, &["--hpgl", "--hpgl-buffer", "60", "--fast"]);
    let served = Served::start(&["--listen", "127.0.0.1:0", "--port", sim.port.as_str()]);
    let page = Page::open(&served);
    // A spiral of 40 turns: some 10 kB of HP-GL, several seconds of a 9600-baud line.
    let (status, v) = page.post(&served, "/api/gen", json!({ "spec": "spiral?r0=5&r1=60&turns=40&cx=100&cy=100" }));
    assert_eq!(status, 200, "{v}");
    page.wait_state(&served, "a prepared drawing", Duration::from_secs(60), |s| !s["prepared"].is_null());
    let (status, v) = page.post(&served, "/api/connect", json!({ "target": sim.port, "firmware": "hpgl" }));
    assert_eq!(status, 200, "{v}");
    page.wait_state(&served, "connected", Duration::from_secs(60), |s| s["machine"]["hpgl"] == true);
    let (status, v) = page.post(&served, "/api/plot", json!({}));
    assert_eq!(status, 200, "{v}");
    let mut log = Vec::new();
    page.wait_event("progress", Duration::from_secs(30), &mut log);
    let (status, v) = page.post(&served, "/api/pause", json!({ "now": false }));
    assert_eq!(status, 200, "{v}");
    let prompt = page.wait_event("prompt", Duration::from_secs(60), &mut log);
    assert_eq!(prompt["kind"], "pause", "{prompt}");
    let paused = page.wait_state(&served, "paused", Duration::from_secs(30), |s| s["machine"]["activity"] == "paused");
    let percent = paused["progress"]["percent"].as_f64().unwrap_or_default();
    assert!((0.0..100.0).contains(&percent), "paused at {percent} %: {paused}");
    let (status, v) = page.post(&served, "/api/cancel", json!({}));
    assert_eq!(status, 200, "{v}");
    let done = page.wait_event("done", Duration::from_secs(60), &mut log);
    assert_eq!(done["ok"], false, "{done}");
    let message = done["message"].as_str().unwrap_or_default();
    assert!(message.contains("stopped at the user's request"), "{message}");
    assert!(message.contains("the pen is up and put away"), "{message}");
    drop(page);
    drop(served);
    let trace = sim.stop();
    assert_eq!(SimPty::figure(&trace, "hpgl", "overflow"), Some(0));
    assert_eq!(SimPty::figure(&trace, "hpgl", "errors"), Some(0));
    assert_eq!(SimPty::figure(&trace, "hpgl", "aborts"), Some(1), "ESC . K once");
    assert_eq!(SimPty::figure(&trace, "hpgl", "pen_up"), Some(1));
    assert_eq!(SimPty::figure(&trace, "hpgl", "pen"), Some(0));
}

#[test]
fn a_port_lost_mid_plot_is_told_as_link_trouble_and_the_link_is_dropped() {
    let dir = scratch("serve-lost");
    // Real time (not --fast): a 250 mm circle takes seconds, time to pull the plug half-way.
    let sim = SimPty::start(&dir, &["--grbl"]);
    let served = Served::start(&["--listen", "127.0.0.1:0", "--port", sim.port.as_str()]);
    let page = Page::open(&served);
    let (status, v) = page.post(&served, "/api/gen", json!({ "spec": "circle?r=40&cx=100&cy=100" }));
    assert_eq!(status, 200, "{v}");
    page.wait_state(&served, "a prepared drawing", Duration::from_secs(60), |s| !s["prepared"].is_null());
    let (status, v) = page.post(&served, "/api/connect", json!({ "target": sim.port, "firmware": "grbl" }));
    assert_eq!(status, 200, "{v}");
    page.wait_state(&served, "connected", Duration::from_secs(60), |s| !s["machine"]["connected"].is_null());
    let (status, v) = page.post(&served, "/api/plot", json!({}));
    assert_eq!(status, 200, "{v}");
    page.wait_state(&served, "plotting", Duration::from_secs(60), |s| s["machine"]["activity"] == "plotting");
    std::thread::sleep(Duration::from_millis(1500));
    // The emulator goes away, as an unplugged USB adapter does.
    drop(sim.stop());
    let mut log = Vec::new();
    let done = page.wait_event("done", Duration::from_secs(60), &mut log);
    assert_eq!(done["ok"], false, "{done}");
    assert_eq!(done["trouble"], "link", "{done}; log: {log:#?}");
    let message = done["message"].as_str().unwrap_or_default();
    assert!(message.contains("lost the connection to") && message.contains("connect again"), "{message}");
    // The page is told it is no longer connected, so it offers to connect again.
    let state = page.wait_state(&served, "idle", Duration::from_secs(30), |s| s["machine"]["activity"] == "idle");
    assert!(state["machine"]["connected"].is_null(), "{state}");
}

#[test]
fn sigterm_to_the_server_mid_plot_stops_the_plot_with_the_pen_up_and_ends_the_server() {
    let dir = scratch("serve-sigterm");
    let log = dir.join("pen.log");
    // Our firmware in real time: the circle takes seconds, the signal comes while the pen is down.
    let sim = SimPty::start(&dir, &["--pen-log", log.to_str().expect("utf-8")]);
    let served = Served::start(&["--listen", "127.0.0.1:0", "--port", sim.port.as_str()]);
    let page = Page::open(&served);
    let (status, v) = page.post(&served, "/api/gen", json!({ "spec": "circle?r=20&cx=60&cy=60" }));
    assert_eq!(status, 200, "{v}");
    page.wait_state(&served, "a prepared drawing", Duration::from_secs(60), |s| !s["prepared"].is_null());
    let (status, v) = page.post(&served, "/api/connect", json!({ "target": sim.port, "firmware": "ours" }));
    assert_eq!(status, 200, "{v}");
    page.wait_state(&served, "connected", Duration::from_secs(60), |s| !s["machine"]["connected"].is_null());
    let (status, v) = page.post(&served, "/api/plot", json!({}));
    assert_eq!(status, 200, "{v}");
    let mut seen = Vec::new();
    loop {
        let p = page.wait_event("progress", Duration::from_secs(60), &mut seen);
        if p["pen_down"] == true {
            break;
        }
    }
    assert!(std::fs::read_to_string(&log).unwrap().ends_with("down\n"), "the pen is on the paper");
    let status = served.stop_with(nix::sys::signal::Signal::SIGTERM, Duration::from_secs(30));
    assert!(!status.success(), "a server stopped by a signal says so: {status}");
    let text = std::fs::read_to_string(&log).unwrap();
    assert!(text.ends_with("up\n"), "the pen went up before the server ended: {text}");
    drop(sim);
}
