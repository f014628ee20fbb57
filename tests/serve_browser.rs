//! The web app end to end in Debian's headless Chromium, driven over the DevTools protocol (a minimal client over
//! a WebSocket): load the page, upload samples/duck.svg through the file input, check the vector preview and the
//! estimate, plot on the simulator and watch progress reach 100 % and the as-stepped drawing appear, with the pen
//! marker on the duck's strokes all along; a second test pauses and resumes, then fills the connect form's HP-GL
//! device, sheet and handshake selectors from the server's table. A screenshot of the page mid-plot is saved to `target/serve-mid-plot.png`.
//! After the first plot the same page moves a speed slider, switches the simulator's motors off, sets a custom
//! paper size and downloads the G-code export; `target/serve-controls.png` shows the page with those controls.
//!
//! Needs `chromium` (or `PLOTTER_CHROMIUM=/path`); without it the tests say so and pass, except under CI
//! (`CI` set), where a missing browser is a failure.

use std::path::Path;
use std::time::{Duration, Instant};

use plotter_e2e::{Served, SimPty, sample, scratch, workspace_root};
use serde_json::json;

use crate::browser::{Cdp, ONE_BROWSER, chromium};

/// `plotter serve` on an ephemeral loopback port at `sim_speed`.
fn start_server(sim_speed: &str) -> (Served, String) {
    let served = Served::start(&["--listen", "127.0.0.1:0", "--sim-speed", sim_speed]);
    let url = served.url.clone();
    (served, url)
}

impl Cdp {
    /// Open the page, upload the duck through the file input, check the preview and the estimate, connect to the
    /// simulator.
    fn load_duck(&mut self, url: &str) {
        self.call("Page.navigate", json!({ "url": url }));
        self.wait_for(
            "the page to take control",
            "document.getElementById('control-status').textContent === 'you control the plotter'",
            Duration::from_secs(20),
        );
        let root = self.call("DOM.getDocument", json!({}))["root"]["nodeId"].clone();
        let input = self.call("DOM.querySelector", json!({ "nodeId": root, "selector": "#file" }))["nodeId"].clone();
        let duck = sample("duck.svg");
        self.call("DOM.setFileInputFiles", json!({ "nodeId": input, "files": [duck.display().to_string()] }));
        // samples/duck.svg has 6 paths; `plotter stats` plans it in 13.2 s with ordering on.
        self.wait_for(
            "the vector preview",
            "document.querySelectorAll('#g-drawing polyline').length === 6",
            Duration::from_secs(20),
        );
        assert_eq!(self.text("#drawing-name"), "duck.svg");
        assert_eq!(self.text("#estimate"), "0:13.2");
        assert_eq!(self.eval("document.querySelectorAll('#g-travel line').length"), json!(5));
        self.connect_to("sim", "simulated plotter");
    }

    /// Connect to `target` (`sim` or a listed port) and wait until the status names `name` and the machine is idle.
    fn connect_to(&mut self, target: &str, name: &str) {
        self.wait_for(
            "the target in the list",
            &format!("[...document.getElementById('target').options].some((o) => o.value === '{target}')"),
            Duration::from_secs(10),
        );
        self.eval(&format!("document.getElementById('target').value = '{target}'"));
        self.click("connect");
        self.wait_for(
            "the connection",
            &format!(
                "document.getElementById('machine-status').textContent.startsWith('{name}') && \
                 document.getElementById('activity').textContent === 'idle'"
            ),
            Duration::from_secs(20),
        );
    }
}

fn percent(cdp: &mut Cdp) -> f64 {
    cdp.text("#percent").trim_end_matches(" %").parse().unwrap_or(-1.0)
}

/// The pen marker as the page shows it.
#[derive(Debug)]
struct Pen {
    /// The marker's centre, page mm.
    at: (f64, f64),
    /// Whether it is filled (pen down).
    down: bool,
    /// The status bar's readout.
    readout: String,
    /// Distance from the centre to the nearest segment of the drawing's polylines (the preview, not the plan), mm.
    off_drawing: f64,
}

fn pen(cdp: &mut Cdp) -> Pen {
    let v = cdp.eval(
        r"(() => {
        const m = document.getElementById('pen-marker');
        const x = parseFloat(m.getAttribute('cx')), y = parseFloat(m.getAttribute('cy'));
        let best = Infinity;
        for (const pl of document.querySelectorAll('#g-drawing polyline')) {
            const p = pl.getAttribute('points').trim().split(/\s+/).map((s) => s.split(',').map(Number));
            for (let k = 1; k < p.length; k++) {
                const [ax, ay] = p[k - 1], dx = p[k][0] - ax, dy = p[k][1] - ay, l2 = dx * dx + dy * dy;
                const t = l2 > 0 ? Math.max(0, Math.min(1, ((x - ax) * dx + (y - ay) * dy) / l2)) : 0;
                best = Math.min(best, Math.hypot(x - ax - t * dx, y - ay - t * dy));
            }
        }
        return { x, y, down: m.classList.contains('down'), visible: m.getAttribute('visibility') === 'visible',
                 readout: document.getElementById('pen-pos').textContent, best };
    })()",
    );
    assert_eq!(v["visible"], json!(true), "the pen marker is shown: {v}");
    Pen {
        at: (v["x"].as_f64().expect("cx"), v["y"].as_f64().expect("cy")),
        down: v["down"].as_bool().expect("down"),
        readout: v["readout"].as_str().unwrap_or("").to_string(),
        off_drawing: v["best"].as_f64().unwrap_or(f64::INFINITY),
    }
}

/// The marker sits on one of the drawing's strokes (once a block has run, every block ends on one: a travel at a
/// stroke's start, a line on its path, a lift at its end; within a step, 1/80 mm, of the ideal path) and the readout
/// names its position to 0.1 mm.
fn check_pen(p: &Pen) {
    assert!(p.off_drawing <= 0.05, "the pen marker is {} mm off the drawing: {p:?}", p.off_drawing);
    let expected = format!("X {:.1} mm, Y {:.1} mm, pen {}", p.at.0, p.at.1, if p.down { "down" } else { "up" });
    assert_eq!(p.readout, expected, "{p:?}");
}

#[test]
fn upload_preview_plot_to_the_end_on_the_simulator() {
    let _one = ONE_BROWSER.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let Some(browser) = chromium() else { return };
    let (_server, url) = start_server("4");
    let profile = scratch("chromium-plot");
    let (_chromium, mut cdp) = Cdp::launch(&browser, &profile);
    cdp.load_duck(&url);
    cdp.click("plot");
    // Mid-plot: some of the duck inked, the bar part-way.
    cdp.wait_for("the plot to be under way", "parseFloat(document.getElementById('percent').textContent) >= 30 && document.querySelectorAll('#g-ink polyline').length > 0", Duration::from_secs(60));
    // The pen marker follows the plot: on the duck at every look, filled at least once while drawing.
    let (mut looks, mut seen_down) = (0, false);
    while percent(&mut cdp) < 100.0 && looks < 200 && !(seen_down && looks >= 5) {
        let p = pen(&mut cdp);
        check_pen(&p);
        seen_down |= p.down;
        looks += 1;
        std::thread::sleep(Duration::from_millis(20));
    }
    assert!(seen_down, "the marker was never filled in {looks} looks while the duck was drawn");
    let mid = percent(&mut cdp);
    assert!(mid < 100.0, "the plot should still be running at the screenshot ({mid} %)");
    let shot = workspace_root().join("target").join("serve-mid-plot.png");
    cdp.screenshot(&shot);
    assert!(std::fs::read(&shot).expect("screenshot").starts_with(b"\x89PNG"));
    cdp.wait_for("100 %", "document.getElementById('percent').textContent === '100 %'", Duration::from_secs(60));
    // The as-stepped drawing arrives on the page: the duck's six strokes as the machine drew them.
    cdp.wait_for(
        "the as-stepped drawing",
        "document.querySelectorAll('#g-stepped polyline').length === 6",
        Duration::from_secs(20),
    );
    assert_eq!(cdp.eval("document.querySelectorAll('#g-ink polyline').length"), json!(6));
    // At the end the pen is up where the last stroke ended: the ordered plot draws the water last, right to left,
    // ending at its first point (8, 82) in samples/duck.svg; the simulator reports the same place, 80 steps/mm.
    let end = pen(&mut cdp);
    check_pen(&end);
    assert_eq!(end.readout, "X 8.0 mm, Y 82.0 mm, pen up");
    // The machine's position in millimetres (the simulator reports 640, 6560 steps at 80 steps/mm), not steps.
    assert_eq!(cdp.text("#machine-pos"), "X 8.0 mm, Y 82.0 mm, pen up");
    assert!(!cdp.text("#machine-status").contains("steps"), "{}", cdp.text("#machine-status"));
    assert!(cdp.text("#message").starts_with("done:"), "{}", cdp.text("#message"));
    cdp.screenshot(&workspace_root().join("target").join("serve-done.png"));
    new_controls(&mut cdp, &profile);
    let _ = std::fs::remove_dir_all(profile);
}

/// The controls a saxi user reaches for, in the open page after the plot (to spare a browser start): a speed
/// slider moved and sent, motors off on the simulator, a custom paper size that changes the preview's page, and the
/// G-code export downloaded as a file. A screenshot of the page with them is saved to `target/serve-controls.png`.
fn new_controls(cdp: &mut Cdp, scratch_dir: &Path) {
    let set = |cdp: &mut Cdp, id: &str, value: &str, events: &[&str]| {
        let fire: String = events.iter().map(|e| format!("e.dispatchEvent(new Event('{e}'));")).collect();
        cdp.eval(&format!(
            "(() => {{ const e = document.getElementById('{id}'); e.value = '{value}'; {fire} return e.value; }})()"
        ))
    };
    // The drawing-speed slider starts at the profile's own 40 % and, once moved, is what the server plans with.
    assert_eq!(cdp.eval("document.getElementById('speed-pendown-pct').value"), json!("40"));
    assert_eq!(set(cdp, "speed-pendown-pct", "20", &["input", "change"]), json!("20"));
    assert_eq!(cdp.text("#speed-pendown-pct-v"), "20 %");
    cdp.wait_for("the server to take the speed", "snap.pen_speed.speed_pendown_pct === 20", Duration::from_secs(10));
    // Drawing the duck's 565.5 mm at 30 mm/s instead of 60: the estimate grows (13.2 s before).
    cdp.wait_for(
        "a longer estimate",
        "parseFloat(document.getElementById('estimate').textContent.split(':')[1]) > 20",
        Duration::from_secs(10),
    );
    // Motors off on the simulator: our firmware's M18, and the status says so.
    cdp.click("motors-off");
    cdp.wait_for(
        "the motors to be off",
        "document.getElementById('machine-status').textContent.includes('motors off') && document.getElementById('console').textContent.includes('motors off (M18)')",
        Duration::from_secs(10),
    );
    // A custom paper, 30 × 20 cm: the row appears, and the preview's page becomes 300 × 200 mm.
    assert_eq!(set(cdp, "paper", "custom", &["change"]), json!("custom"));
    assert_eq!(cdp.eval("document.getElementById('custom-paper').hidden"), json!(false));
    cdp.wait_for("the custom paper setting", "snap.settings.paper === 'custom'", Duration::from_secs(10));
    // Typed in one go (a state arriving between two fields would otherwise show the server's values again).
    cdp.eval(
        "(() => { const v = { 'paper-unit': 'cm', 'paper-width': '30', 'paper-height': '20' }; \
         for (const id in v) document.getElementById(id).value = v[id]; \
         document.getElementById('paper-height').dispatchEvent(new Event('change')); })()",
    );
    cdp.wait_for(
        "the 30 × 20 cm page",
        "document.getElementById('paper-rect').getAttribute('width') === '300' && document.getElementById('paper-rect').getAttribute('height') === '200'",
        Duration::from_secs(10),
    );
    // The G-code export downloads as a file named after the drawing, starting with its header.
    let downloads = scratch_dir.join("downloads");
    std::fs::create_dir_all(&downloads).expect("download folder");
    cdp.call_browser(
        "Browser.setDownloadBehavior",
        json!({ "behavior": "allow", "downloadPath": downloads.display().to_string() }),
    );
    // Tall enough to show the machine panel's sliders and buttons below the layout.
    cdp.call(
        "Emulation.setDeviceMetricsOverride",
        json!({ "width": 1400, "height": 1450, "deviceScaleFactor": 1, "mobile": false }),
    );
    let shot = workspace_root().join("target").join("serve-controls.png");
    cdp.screenshot(&shot);
    assert!(std::fs::read(&shot).expect("screenshot").starts_with(b"\x89PNG"));
    cdp.click("export-gcode");
    let file = downloads.join("duck.gcode");
    let t0 = Instant::now();
    while !file.exists() {
        assert!(
            t0.elapsed() < Duration::from_secs(20),
            "no {} downloaded; page says {}",
            file.display(),
            cdp.text("#message")
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    let gcode = std::fs::read_to_string(&file).expect("the download");
    assert!(gcode.starts_with("; XY plotter kit (A3 frame)"), "{}", &gcode[..gcode.len().min(200)]);
    assert!(gcode.contains("G21"), "millimetres");
}

#[test]
fn pause_and_resume_from_the_page() {
    let _one = ONE_BROWSER.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let Some(browser) = chromium() else { return };
    let (_server, url) = start_server("3");
    let profile = scratch("chromium-pause");
    let (_chromium, mut cdp) = Cdp::launch(&browser, &profile);
    cdp.load_duck(&url);
    cdp.click("plot");
    cdp.wait_for(
        "the plot to be under way",
        "parseFloat(document.getElementById('percent').textContent) >= 10",
        Duration::from_secs(60),
    );
    cdp.click("pause");
    cdp.wait_for("the pause prompt", "!document.getElementById('prompt').hidden && document.getElementById('prompt').dataset.kind === 'pause' && !document.getElementById('resume').disabled", Duration::from_secs(30));
    assert_eq!(cdp.text("#activity"), "paused");
    // Paused means paused: no progress while the prompt is up.
    let at = percent(&mut cdp);
    assert!(at > 0.0 && at < 100.0, "paused at {at} %");
    std::thread::sleep(Duration::from_millis(700));
    assert_eq!(percent(&mut cdp), at, "progress moved while paused");
    cdp.click("resume");
    cdp.wait_for("the prompt to close", "document.getElementById('prompt').hidden", Duration::from_secs(10));
    cdp.wait_for("100 %", "document.getElementById('percent').textContent === '100 %'", Duration::from_secs(60));
    cdp.wait_for(
        "the as-stepped drawing",
        "document.querySelectorAll('#g-stepped polyline').length === 6",
        Duration::from_secs(20),
    );
    hpgl_controls(&mut cdp);
    let _ = std::fs::remove_dir_all(profile);
}

/// The connect form's HP-GL selectors (in an open page, to spare a browser start): hidden until HP-GL is chosen,
/// then filled from the server's device table — the 7475A first with its four sheets, the 7550A's two, the
/// generic plotter's drawing page — and sent with the connect request.
fn hpgl_controls(cdp: &mut Cdp) {
    assert_eq!(cdp.eval("getComputedStyle(document.getElementById('hpgl-row')).display"), json!("none"));
    let choose = |cdp: &mut Cdp, id: &str, value: &str| {
        cdp.eval(&format!(
            "(() => {{ const e = document.getElementById('{id}'); e.value = '{value}'; \
             e.dispatchEvent(new Event('change')); return e.value; }})()"
        ))
    };
    assert_eq!(choose(cdp, "firmware", "hpgl"), json!("hpgl"));
    cdp.wait_for(
        "the HP-GL selectors",
        "!document.getElementById('hpgl-row').hidden && getComputedStyle(document.getElementById('hpgl-row')).display !== 'none'",
        Duration::from_secs(10),
    );
    let values = |cdp: &mut Cdp, id: &str| {
        cdp.eval(&format!("[...document.getElementById('{id}').options].map((o) => o.value)"))
    };
    assert_eq!(values(cdp, "hpgl-device"), json!(["7475a", "7550a", "dxy-1300", "generic"]));
    assert_eq!(values(cdp, "hpgl-paper"), json!(["", "a4", "letter", "a3", "tabloid"]));
    assert_eq!(values(cdp, "handshake"), json!(["escb", "xonxoff", "hardware"]));
    assert_eq!(choose(cdp, "hpgl-device", "7550a"), json!("7550a"));
    assert_eq!(values(cdp, "hpgl-paper"), json!(["", "a4", "a3"]));
    choose(cdp, "hpgl-paper", "a3");
    choose(cdp, "handshake", "xonxoff");
    assert_eq!(
        cdp.eval("connectBody()"),
        json!({ "target": "sim", "firmware": "hpgl", "hpgl_device": "7550a", "hpgl_paper": "a3", "handshake": "xonxoff" })
    );
    choose(cdp, "hpgl-device", "generic");
    assert_eq!(values(cdp, "hpgl-paper"), json!([""]));
    // The built-in simulator is no HP-GL plotter: the server refuses, and the page says why.
    cdp.click("connect");
    cdp.wait_for(
        "the refusal",
        "document.getElementById('message').textContent.includes('plotter sim --pty --hpgl')",
        Duration::from_secs(10),
    );
}

/// An interrupted plot on a serial port is offered for resuming, and resumed from the page: `plotter serve` in
/// front of `plotter sim --pty` (our firmware on a pseudo-terminal, in real time) with its journals in a scratch
/// folder plots the duck at full speed (the sliders), is cancelled part-way, offers "Resume it" with how far it
/// got, and finishes from there; the journal then says the plot is complete and the offer goes.
#[test]
fn an_interrupted_serial_plot_resumes_from_the_page() {
    let _one = ONE_BROWSER.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let Some(browser) = chromium() else { return };
    let dir = scratch("chromium-resume");
    let sim = SimPty::start(&dir, &[]);
    let journals = dir.join("journals");
    let served = Served::start(&[
        "--listen",
        "127.0.0.1:0",
        "--port",
        &sim.port,
        "--journal-dir",
        journals.to_str().expect("a UTF-8 path"),
    ]);
    let (_chromium, mut cdp) = Cdp::launch(&browser, &dir.join("profile"));
    cdp.load_duck(&served.url);
    cdp.connect_to(&sim.port, "plotter-fw");
    // Full speed both ways (the XY kit's 150 mm/s), so the real-time plot is short.
    cdp.eval(
        "(() => { for (const id of ['speed-pendown-pct', 'speed-penup-pct']) document.getElementById(id).value = '100'; \
         document.getElementById('speed-penup-pct').dispatchEvent(new Event('change')); })()",
    );
    cdp.wait_for("full speed", "snap.pen_speed.speed_pendown_pct === 100", Duration::from_secs(10));
    assert_eq!(cdp.eval("document.getElementById('resumable').hidden"), json!(true), "nothing to resume yet");
    cdp.click("plot");
    cdp.wait_for(
        "the plot to be under way",
        "parseFloat(document.getElementById('percent').textContent) >= 20",
        Duration::from_secs(60),
    );
    cdp.click("cancel");
    cdp.wait_for(
        "the stop",
        "document.getElementById('message').textContent.startsWith('plot stopped')",
        Duration::from_secs(30),
    );
    cdp.wait_for(
        "the offer to resume",
        "!document.getElementById('resumable').hidden && !document.getElementById('resume-plot').disabled",
        Duration::from_secs(10),
    );
    let offer = cdp.text("#resumable");
    let at: f64 = offer
        .strip_prefix("The last plot of this drawing on this machine stopped at ")
        .and_then(|r| r.split(' ').next())
        .and_then(|p| p.parse().ok())
        .unwrap_or_else(|| panic!("{offer}"));
    assert!((15.0..100.0).contains(&at), "{offer}");
    let journal: Vec<_> =
        std::fs::read_dir(&journals).expect("the journal folder").flatten().map(|e| e.path()).collect();
    assert_eq!(journal.len(), 1, "{journal:?}");
    let name = journal[0].file_name().and_then(|n| n.to_str()).unwrap_or("").to_string();
    assert!(name.starts_with("duck-xy-plotter-kit-a3-frame-") && name.ends_with(".journal"), "{name}");
    cdp.click("resume-plot");
    cdp.wait_for(
        "the resumed plot's end",
        "document.getElementById('message').textContent.startsWith('done:')",
        Duration::from_secs(90),
    );
    assert_eq!(cdp.text("#percent"), "100 %");
    cdp.wait_for("the offer to go", "document.getElementById('resumable').hidden", Duration::from_secs(10));
    let text = std::fs::read_to_string(&journal[0]).expect("the journal");
    assert!(text.lines().any(|l| l.trim() == "complete"), "{text}");
    assert!(text.contains("\"front_end\":\"plotter serve\"") && text.contains("\"drawing\":\"duck.svg\""), "{text}");
    drop(served);
    let _ = std::fs::remove_dir_all(dir);
}
