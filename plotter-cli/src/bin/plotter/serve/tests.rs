//! HTTP API tests, in-process through the router (`tower::ServiceExt::oneshot`), with the machine worker running
//! the paced simulator.

use std::sync::Arc;
use std::time::{Duration, Instant};

use axum::Router;
use axum::body::{Body, to_bytes};
use axum::http::{Request, StatusCode, header};
use serde_json::{Value, json};
use tower::ServiceExt as _;

use super::state::{Config, Shared};

const HOST: &str = "127.0.0.1:8040";
const DUCK: &[u8] = include_bytes!("../../../../../samples/duck.svg");

fn test_app(max_upload: usize, sim_speed: f64) -> (Arc<Shared>, Router) {
    test_app_with(max_upload, sim_speed, plotter_path::MachineProfile::default_plotter())
}

/// [`test_app`] serving `profile`.
fn test_app_with(max_upload: usize, sim_speed: f64, profile: plotter_path::MachineProfile) -> (Arc<Shared>, Router) {
    super::app(Config {
        local: HOST.parse().unwrap(),
        max_upload,
        sim_speed,
        extra_ports: Vec::new(),
        profiles: vec![profile],
        limits: super::state::Limits::default(),
        journals: None,
    })
}

struct Client {
    router: Router,
    token: Option<String>,
}

impl Client {
    fn new(router: &Router) -> Client {
        Client { router: router.clone(), token: None }
    }

    async fn send(&self, req: Request<Body>) -> (StatusCode, Value) {
        let res = self.router.clone().oneshot(req).await.unwrap();
        let status = res.status();
        let bytes = to_bytes(res.into_body(), 1 << 24).await.unwrap();
        (status, serde_json::from_slice(&bytes).unwrap_or(Value::Null))
    }

    fn request(&self, method: &str, uri: &str) -> axum::http::request::Builder {
        let b = Request::builder().method(method).uri(uri).header(header::HOST, HOST);
        match &self.token {
            Some(t) => b.header("x-plotter-token", t),
            None => b,
        }
    }

    async fn get(&self, uri: &str) -> (StatusCode, Value) {
        self.send(self.request("GET", uri).body(Body::empty()).unwrap()).await
    }

    async fn post(&self, uri: &str, body: Value) -> (StatusCode, Value) {
        let req = self.request("POST", uri).header(header::CONTENT_TYPE, "application/json");
        self.send(req.body(Body::from(body.to_string())).unwrap()).await
    }

    async fn upload(&self, name: &str, bytes: &[u8]) -> (StatusCode, Value) {
        let uri = format!("/api/drawing?name={name}");
        self.send(self.request("POST", &uri).body(Body::from(bytes.to_vec())).unwrap()).await
    }

    async fn claim(&mut self) {
        let (s, v) = self.post("/api/control/claim", json!({})).await;
        assert_eq!(s, StatusCode::OK, "{v}");
        self.token = Some(v["token"].as_str().unwrap().to_string());
    }
}

/// Poll the state until `f` holds (bounded: fails after 60 s).
async fn wait_state(c: &Client, what: &str, f: impl Fn(&Value) -> bool) -> Value {
    let t0 = Instant::now();
    loop {
        let (_, s) = c.get("/api/state").await;
        if f(&s) {
            return s;
        }
        assert!(t0.elapsed() < Duration::from_secs(60), "timed out waiting for {what}; state {s}");
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

#[tokio::test]
async fn the_page_and_its_assets_are_served_from_the_binary() {
    let (_, router) = test_app(1 << 20, 10.0);
    let c = Client::new(&router);
    for (path, kind, needle) in [
        ("/", "text/html", "id=\"preview\""),
        ("/app.js", "text/javascript", "EventSource"),
        ("/style.css", "text/css", "#preview"),
    ] {
        let res = router.clone().oneshot(c.request("GET", path).body(Body::empty()).unwrap()).await.unwrap();
        assert_eq!(res.status(), StatusCode::OK, "{path}");
        assert!(res.headers()[header::CONTENT_TYPE].to_str().unwrap().starts_with(kind), "{path}");
        let body = to_bytes(res.into_body(), 1 << 20).await.unwrap();
        assert!(String::from_utf8_lossy(&body).contains(needle), "{path}");
    }
}

#[tokio::test]
async fn foreign_host_or_origin_is_refused() {
    let (_, router) = test_app(1 << 20, 10.0);
    let c = Client::new(&router);
    // DNS rebinding: the attacker's name resolving to 127.0.0.1.
    let req = Request::get("/api/state").header(header::HOST, "rebind.attacker.example:8040").body(Body::empty());
    let (s, v) = c.send(req.unwrap()).await;
    assert_eq!(s, StatusCode::FORBIDDEN);
    assert!(v["error"].as_str().unwrap().contains("Host \"rebind.attacker.example:8040\""), "{v}");
    // A cross-site POST: right Host, another site's Origin. Refused before anything else is looked at.
    let req = c.request("POST", "/api/control/claim").header(header::ORIGIN, "http://evil.example").body(Body::empty());
    let (s, v) = c.send(req.unwrap()).await;
    assert_eq!(s, StatusCode::FORBIDDEN);
    assert!(v["error"].as_str().unwrap().contains("cross-site"), "{v}");
    // No Host at all.
    let (s, _) = c.send(Request::get("/").body(Body::empty()).unwrap()).await;
    assert_eq!(s, StatusCode::FORBIDDEN);
    // The same request from our own page is fine.
    let req = c.request("POST", "/api/control/claim").header(header::ORIGIN, format!("http://{HOST}"));
    let (s, _) = c.send(req.body(Body::empty()).unwrap()).await;
    assert_eq!(s, StatusCode::OK);
}

#[tokio::test]
async fn one_controller_at_a_time_others_read_only() {
    let (_, router) = test_app(1 << 20, 10.0);
    let mut a = Client::new(&router);
    let mut b = Client::new(&router);
    // Nobody controls yet: changes are refused until control is taken.
    let (s, v) = a.upload("duck.svg", DUCK).await;
    assert_eq!(s, StatusCode::FORBIDDEN, "{v}");
    a.claim().await;
    let (s, v) = b.post("/api/control/claim", json!({})).await;
    assert_eq!(s, StatusCode::CONFLICT, "{v}");
    // A wrong token is as good as none.
    b.token = Some("0".repeat(32));
    let (s, v) = b.upload("duck.svg", DUCK).await;
    assert_eq!(s, StatusCode::FORBIDDEN);
    assert!(v["error"].as_str().unwrap().contains("read-only"), "{v}");
    // Reading is open to all.
    let (s, v) = b.get("/api/state").await;
    assert_eq!((s, v["controlled"].clone()), (StatusCode::OK, json!(true)));
    // Once released, the other page may take over; the first one's token is then worthless.
    let (s, _) = a.post("/api/control/release", json!({})).await;
    assert_eq!(s, StatusCode::OK);
    b.claim().await;
    let (s, _) = a.upload("duck.svg", DUCK).await;
    assert_eq!(s, StatusCode::FORBIDDEN);
}

#[tokio::test]
async fn an_upload_over_the_limit_gets_a_clear_error() {
    let (_, router) = test_app(1000, 10.0);
    let mut c = Client::new(&router);
    c.claim().await;
    let (s, v) = c.upload("duck.svg", DUCK).await;
    assert_eq!(s, StatusCode::PAYLOAD_TOO_LARGE, "{v}");
    let e = v["error"].as_str().unwrap();
    assert!(
        e.contains("duck.svg is too large") && e.contains("limited to 0.0 MB") && e.contains("--max-upload-mb"),
        "{e}"
    );
    // Without a declared length (a chunked body), the cut-off body gets the same message.
    let chunks = futures_util::stream::iter(vec![Ok::<_, std::io::Error>(DUCK.to_vec())]);
    let req = c.request("POST", "/api/drawing?name=duck.svg").body(Body::from_stream(chunks)).unwrap();
    let (s, v) = c.send(req).await;
    assert_eq!(s, StatusCode::PAYLOAD_TOO_LARGE, "{v}");
    assert!(v["error"].as_str().unwrap().contains("too large"), "{v}");
}

#[tokio::test]
async fn upload_gives_layers_figures_estimate_and_a_vector_view() {
    let (_, router) = test_app(1 << 20, 10.0);
    let mut c = Client::new(&router);
    c.claim().await;
    // A path in the name is reduced to the file name: it only tells the kind.
    let (s, v) = c.upload("..%2F..%2Fetc%2Fduck.svg", DUCK).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    let (_, st) = c.get("/api/state").await;
    assert_eq!(st["drawing"]["name"], "duck.svg");
    assert_eq!(st["drawing"]["layers"][0]["name"], "drawing");
    // samples/duck.svg: 6 paths; the figures `plotter stats samples/duck.svg` prints: 565.50 mm pen-down, pen-up
    // 191.86 mm between paths in file order (248.32 mm with the 56.46 mm travel from home to the first path, which
    // the optimizer's figures count since it orders from home), 152.34 mm ordered from home for the least pen-up
    // time (150.78 mm with --opt-cost distance), plot time 13.2 s (14.8 s before the hops overlapped the pen's
    // lift and drop with the travel).
    let p = &st["prepared"];
    assert_eq!(p["stats"]["paths"], 6);
    assert!((p["stats"]["pen_down_mm"].as_f64().unwrap() - 565.50).abs() < 0.01, "{p}");
    assert!((p["pen_up_before_mm"].as_f64().unwrap() - 248.32).abs() < 0.01, "{p}");
    assert!((p["pen_up_after_mm"].as_f64().unwrap() - 152.34).abs() < 0.01, "{p}");
    assert!((p["estimate_s"].as_f64().unwrap() - 13.17).abs() < 0.05, "{p}");
    let (s, view) = c.get("/api/view").await;
    assert_eq!(s, StatusCode::OK);
    let paths = view["layers"][0]["paths"].as_array().unwrap();
    assert_eq!(paths.len(), 6);
    assert_eq!(view["page_mm"], json!([120.0, 90.0]));
    assert_eq!(view["travel"].as_array().unwrap().len(), 5);
    // Without ordering: file order, and the eye (a 6-sided polygon, 7 points) second.
    let (s, v) = c.post("/api/settings", json!({ "optimize": false })).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    let (_, view) = c.get("/api/view").await;
    assert_eq!(view["layers"][0]["paths"][1]["points"].as_array().unwrap().len(), 7);
    assert_eq!(view["layers"][0]["paths"][1]["points"][0], json!([61.0, 17.0]));
    // Hiding the only layer leaves nothing to plot, said plainly.
    let hide = json!({ "layers": [{ "name": "drawing", "visible": false }] });
    let (s, v) = c.post("/api/settings", hide).await;
    assert_eq!(s, StatusCode::BAD_REQUEST);
    assert!(v["error"].as_str().unwrap().contains("nothing to plot"), "{v}");
    // A bad setting is refused and names itself.
    let (s, v) = c.post("/api/settings", json!({ "paper": "b52" })).await;
    assert_eq!(s, StatusCode::BAD_REQUEST);
    assert!(v["error"].as_str().unwrap().contains("b52"), "{v}");
    // Undecodable input names the file.
    let (s, v) = c.upload("broken.svg", b"<svg><g></svg>").await;
    assert_eq!(s, StatusCode::BAD_REQUEST);
    assert!(v["error"].as_str().unwrap().contains("broken.svg"), "{v}");
}

#[tokio::test]
async fn generated_figures_load_too() {
    let (_, router) = test_app(1 << 20, 10.0);
    let mut c = Client::new(&router);
    c.claim().await;
    let (s, v) = c.post("/api/gen", json!({ "spec": "gen:rose?k=5" })).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    let (_, st) = c.get("/api/state").await;
    assert_eq!(st["drawing"]["name"], "gen:rose?k=5");
    let (s, v) = c.post("/api/gen", json!({ "spec": "gen:nonsense" })).await;
    assert_eq!(s, StatusCode::BAD_REQUEST);
    assert!(v["error"].as_str().unwrap().contains("nonsense"), "{v}");
}

#[tokio::test]
async fn only_listed_ports_can_be_opened() {
    let (_, router) = test_app(1 << 20, 10.0);
    let mut c = Client::new(&router);
    c.claim().await;
    let (s, v) = c.post("/api/connect", json!({ "target": "/etc/passwd" })).await;
    assert_eq!(s, StatusCode::BAD_REQUEST);
    assert!(v["error"].as_str().unwrap().contains("not a listed serial port"), "{v}");
    // The simulator runs our firmware: asking it for another dialect, or for an unknown one, is refused.
    let (s, v) = c.post("/api/connect", json!({ "target": "sim", "firmware": "grbl" })).await;
    assert_eq!(s, StatusCode::BAD_REQUEST);
    assert!(v["error"].as_str().unwrap().contains("plotter sim --pty --grbl"), "{v}");
    let (s, v) = c.post("/api/connect", json!({ "target": "sim", "firmware": "marlin" })).await;
    assert_eq!(s, StatusCode::BAD_REQUEST);
    assert!(v["error"].as_str().unwrap().contains("unknown firmware \"marlin\""), "{v}");
    let (_, st) = c.get("/api/state").await;
    assert!(st["machine"]["connected"].is_null(), "{st}");
    let (s, v) = c.post("/api/plot", json!({})).await;
    assert_eq!(s, StatusCode::CONFLICT);
    assert!(v["error"].as_str().unwrap().contains("not connected"), "{v}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn plot_on_the_simulator_pause_resume_and_finish() {
    let (_, router) = test_app(1 << 20, 50.0);
    let mut c = Client::new(&router);
    c.claim().await;
    let (s, v) = c.upload("duck.svg", DUCK).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    c.post("/api/connect", json!({ "target": "sim" })).await;
    wait_state(&c, "connected", |s| s["machine"]["connected"].is_string() && s["machine"]["activity"] == "idle").await;
    // Jog and pen commands reach the machine and move it: 10 mm at 80 steps/mm.
    let (s, v) = c.post("/api/home", json!({})).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    wait_state(&c, "homed", |s| s["machine"]["activity"] == "idle").await;
    let (_, before) = c.get("/api/state").await;
    let x0 = before["machine"]["position"][0].as_i64().unwrap();
    c.post("/api/jog", json!({ "axis": "x", "mm": 10.0 })).await;
    let after = wait_state(&c, "jogged", |s| {
        s["machine"]["activity"] == "idle" && s["machine"]["position"][0].as_i64() != Some(x0)
    })
    .await;
    let steps_per_mm = plotter_path::MachineProfile::default_plotter().axes.x.steps_per_mm;
    let moved = after["machine"]["position"][0].as_i64().unwrap() - x0;
    assert_eq!(moved as f64, (10.0 * steps_per_mm).round());
    // People are shown millimetres: the same position, 10 mm further along X.
    let mm = |s: &Value, axis: usize| s["machine"]["position_mm"][axis].as_f64().unwrap();
    assert!((mm(&after, 0) - mm(&before, 0) - 10.0).abs() < 1e-9, "{after}");
    // Plot, pause at the next pen-up, resume, finish.
    let (s, v) = c.post("/api/plot", json!({})).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    let (s, _) = c.post("/api/plot", json!({})).await;
    assert_eq!(s, StatusCode::CONFLICT, "a second plot while one runs");
    wait_state(&c, "some progress", |s| s["progress"]["executed"].as_u64().unwrap_or(0) > 0).await;
    let (s, v) = c.post("/api/pause", json!({ "now": false })).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    let paused = wait_state(&c, "the pause prompt", |s| s["prompt"]["kind"] == "pause").await;
    assert_eq!(paused["machine"]["activity"], "paused");
    // The machine's position followed the plot, in millimetres (it was frozen in steps until the plot ended).
    let m = &paused["machine"];
    assert_eq!(m["position_mm"], paused["progress"]["machine_mm"], "{paused}");
    assert_ne!(m["position_mm"], after["machine"]["position_mm"], "{paused}");
    assert_eq!(m["pen_down"], paused["progress"]["pen_down"], "{paused}");
    assert_eq!(paused["prompt"]["choices"], json!(["resume", "cancel"]));
    let (s, _) = c.post("/api/prompt", json!({ "id": paused["prompt"]["id"], "answer": "skip" })).await;
    assert_eq!(s, StatusCode::BAD_REQUEST, "not one of the choices");
    let (s, v) = c.post("/api/resume", json!({})).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    let done = wait_state(&c, "the end", |s| s["machine"]["activity"] == "idle" && s["stepped_version"].is_u64()).await;
    let p = &done["progress"];
    assert_eq!(p["executed"], p["total"]);
    assert_eq!(p["percent"], 100.0);
    assert!((p["draw_done_mm"].as_f64().unwrap() - 565.5).abs() < 1.0, "{p}");
    // The pen ends up where the ordered duck's last stroke (the water, right to left) ends: (8, 82) mm.
    assert_eq!((&p["pen_mm"], &p["pen_down"]), (&json!([8.0, 82.0]), &json!(false)), "{p}");
    // The machine reports the same place after the plot: 640, 6560 steps at 80 steps/mm; the pen (a Z pen) up.
    let m = &done["machine"];
    assert_eq!((&m["position_mm"], &m["pen_down"]), (&json!([8.0, 82.0]), &json!(false)), "{m}");
    assert_eq!((&m["position"][0], &m["position"][1]), (&json!(640), &json!(6560)), "{m}");
    // The as-stepped drawing covers the duck's box (x 8..116, y 9..82 mm in samples/duck.svg) within a step, and
    // its staircase is at least as long as the straight pen-down length and at most sqrt(2) times it.
    let (s, stepped) = c.get("/api/stepped").await;
    assert_eq!(s, StatusCode::OK);
    let bbox: Vec<f64> = stepped["bbox_mm"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
    for (got, want) in bbox.iter().zip([8.0, 9.0, 116.0, 82.0]) {
        assert!((got - want).abs() <= 1.0 / steps_per_mm, "as-stepped box {bbox:?}");
    }
    let drawn: f64 = stepped["draw_mm"].as_f64().unwrap();
    assert!(drawn >= 565.0 && drawn <= 565.5 * 2f64.sqrt(), "as-stepped pen-down {drawn} mm");
}

#[tokio::test]
async fn uploads_beyond_the_import_slots_are_answered_busy() {
    let (shared, router) = test_app(1 << 20, 10.0);
    let mut c = Client::new(&router);
    c.claim().await;
    let n = u32::try_from(shared.config.limits.max_imports).unwrap();
    let taken = Arc::clone(&shared.imports).acquire_many_owned(n).await.unwrap();
    let (s, v) = c.upload("duck.svg", DUCK).await;
    assert_eq!(s, StatusCode::SERVICE_UNAVAILABLE, "{v}");
    assert!(v["error"].as_str().unwrap().contains(&format!("busy: {n} drawing(s)")), "{v}");
    let (_, st) = c.get("/api/state").await;
    assert!(st["drawing"].is_null(), "nothing loaded: {st}");
    drop(taken);
    let (s, v) = c.upload("duck.svg", DUCK).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    assert_eq!(shared.imports.available_permits(), shared.config.limits.max_imports);
    // New settings that cannot be prepared for want of a slot drop the old plot rather than keep one that no
    // longer matches them.
    let taken = Arc::clone(&shared.imports).acquire_many_owned(n).await.unwrap();
    let (s, v) = c.post("/api/settings", json!({ "optimize": false })).await;
    assert_eq!(s, StatusCode::SERVICE_UNAVAILABLE, "{v}");
    let (_, st) = c.get("/api/state").await;
    assert!(st["prepared"].is_null(), "{st}");
    assert!(st["prepare_error"].as_str().unwrap().starts_with("busy:"), "{st}");
    drop(taken);
    let (s, v) = c.post("/api/settings", json!({ "optimize": false })).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    let (_, st) = c.get("/api/state").await;
    assert_eq!(st["prepared"]["stats"]["paths"], 6, "{st}");
}

/// An SVG of `n` overlapping white discs outlined in black, each hiding parts of the outlines under it: quick to
/// parse, slow to import (hidden-line removal cuts every outline against the discs painted after it), so most of
/// its work comes after the points where an import checks for cancellation.
fn overlapping_discs(n: usize) -> Vec<u8> {
    let mut svg =
        String::from(r#"<svg xmlns="http://www.w3.org/2000/svg" width="200mm" height="200mm" viewBox="0 0 200 200">"#);
    for i in 0..n {
        let (x, y) = ((i * 7) % 180 + 10, (i * 13 / 180) % 180 + 10);
        svg.push_str(&format!(r#"<circle cx="{x}" cy="{y}" r="8" fill="white" stroke="black"/>"#));
    }
    svg.push_str("</svg>");
    svg.into_bytes()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_client_that_hangs_up_mid_decode_loads_nothing_and_frees_its_slot_promptly() {
    let (shared, router) = test_app(16 << 20, 10.0);
    let mut c = Client::new(&router);
    c.claim().await;
    let slots = shared.config.limits.max_imports;
    let big = overlapping_discs(8000);
    // How long the decode takes when nobody cancels it (the importer with the command line's default settings).
    let uncancelled = {
        #[derive(clap::Parser)]
        struct W {
            #[command(flatten)]
            input: plotter_host::input::InputArgs,
        }
        let input = <W as clap::Parser>::parse_from(["w"]).input;
        let bytes = big.clone();
        tokio::task::spawn_blocking(move || {
            let t0 = Instant::now();
            let profile = plotter_path::MachineProfile::default_plotter();
            let only_data = plotter_path::input::svg::ResourcePolicy::DataUrlsOnly;
            let never = plotter_path::geometry::cancel::Cancel::never();
            let name = std::path::Path::new("big.svg");
            let d = plotter_host::input::decode_drawing(&bytes, name, "big.svg", &only_data, &input, &profile, &never);
            assert!(d.unwrap().drawing.path_count() > 1000);
            t0.elapsed()
        })
        .await
        .unwrap()
    };
    let req = c.request("POST", "/api/drawing?name=big.svg").body(Body::from(big)).unwrap();
    let r = router.clone();
    let handler = tokio::spawn(async move { r.oneshot(req).await });
    let t0 = Instant::now();
    while shared.imports.available_permits() == slots {
        assert!(t0.elapsed() < Duration::from_secs(10), "the decode never started");
        tokio::time::sleep(Duration::from_millis(1)).await;
    }
    // The client goes away: hyper drops the handler, as aborting it does here.
    handler.abort();
    assert!(handler.await.unwrap_err().is_cancelled());
    let hung_up = Instant::now();
    while shared.imports.available_permits() < slots {
        assert!(hung_up.elapsed() < uncancelled, "the decode ran on as long as an uncancelled one ({uncancelled:?})");
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    let freed = hung_up.elapsed();
    eprintln!("slot freed {freed:?} after the hang-up; the uncancelled decode takes {uncancelled:?}");
    // Only what comes before the first check (reading the XML and usvg's parse, about a tenth of this input's
    // work) may still run.
    assert!(freed < uncancelled / 3, "freed after {freed:?}, the uncancelled decode takes {uncancelled:?}");
    let (_, st) = c.get("/api/state").await;
    assert!(st["drawing"].is_null(), "the abandoned drawing was not loaded: {st}");
}

/// A GET's status, headers and body text.
async fn fetch(c: &Client, uri: &str) -> (StatusCode, axum::http::HeaderMap, String) {
    let res = c.router.clone().oneshot(c.request("GET", uri).body(Body::empty()).unwrap()).await.unwrap();
    let (status, headers) = (res.status(), res.headers().clone());
    let bytes = to_bytes(res.into_body(), 1 << 24).await.unwrap();
    (status, headers, String::from_utf8_lossy(&bytes).into_owned())
}

#[tokio::test]
async fn pen_and_speed_sliders_are_checked_and_change_the_next_plot() {
    let (shared, router) = test_app(1 << 20, 10.0);
    let mut c = Client::new(&router);
    c.claim().await;
    let (s, v) = c.upload("duck.svg", DUCK).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    let (_, st) = c.get("/api/state").await;
    let planned = st["prepared"]["estimate_s"].as_f64().unwrap();
    // The sliders start at the profile's own values: the XY kit draws at 60 of its 150 mm/s (40 %).
    let own = &st["pen_speed_profile"];
    assert_eq!(own["speed_pendown_pct"], 40.0, "{own}");
    assert!(st["pen_speed"]["speed_pendown_pct"].is_null(), "{st}");
    // Out of range, not a number, unknown: refused with what is wrong.
    for (body, says) in [
        (json!({ "pen_up_pct": 120 }), "pen up position 120 % is not in 0..100 %"),
        (json!({ "speed_pendown_pct": 0 }), "pen-down speed 0 % is not in 1..100 %"),
        (json!({ "pen_up_pct": 30, "pen_down_pct": 30 }), "the pen would not lift"),
        (json!({ "speed_penup_pct": "fast" }), "pen and speed settings:"),
        (json!({ "pen_height": 50 }), "unknown field `pen_height`"),
    ] {
        let (s, v) = c.post("/api/pen-speed", body.clone()).await;
        assert_eq!(s, StatusCode::BAD_REQUEST, "{body}: {v}");
        assert!(v["error"].as_str().unwrap().contains(says), "{body}: {v}");
    }
    let (_, st) = c.get("/api/state").await;
    assert!(st["pen_speed"]["speed_pendown_pct"].is_null(), "a refused setting does not stick: {st}");
    // Drawing at 10 % (15 mm/s) instead of 40 %: the 565.5 mm of the duck take longer to plot.
    let (s, v) = c.post("/api/pen-speed", json!({ "speed_pendown_pct": 10, "pen_down_pct": 5 })).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    let (_, st) = c.get("/api/state").await;
    assert_eq!(st["pen_speed"]["speed_pendown_pct"], 10.0);
    let slower = st["prepared"]["estimate_s"].as_f64().unwrap();
    assert!(slower > planned + 565.5 / 15.0 - 565.5 / 60.0 - 1.0, "{planned} s -> {slower} s");
    // The pen test needs a machine.
    let (s, v) = c.post("/api/test-pen", json!({})).await;
    assert_eq!(s, StatusCode::CONFLICT);
    assert!(v["error"].as_str().unwrap().contains("not connected"), "{v}");
    c.post("/api/connect", json!({ "target": "sim" })).await;
    wait_state(&c, "connected", |s| s["machine"]["connected"].is_string() && s["machine"]["activity"] == "idle").await;
    let mut events = shared.hub.subscribe();
    let (s, v) = c.post("/api/test-pen", json!({})).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    // The pen goes down to the slider's 5 % of the Z travel, then back up to the profile's pen-up height.
    let profile = plotter_path::MachineProfile::default_plotter();
    let down = format!("G1 Z{:.4} ", 0.05 * profile.axes.z.travel_mm);
    let up = format!("G1 Z{:.4} ", profile.pen.up_z_mm);
    let mut moves = Vec::new();
    while moves.len() < 2 {
        let e = tokio::time::timeout(Duration::from_secs(20), events.recv()).await.expect("the pen moves").unwrap();
        let line: Value = serde_json::from_str(&e.data).unwrap();
        if e.name == "log" && line["dir"] == "out" && line["text"].as_str().unwrap().starts_with("G1 Z") {
            moves.push(line["text"].as_str().unwrap().to_string());
        }
    }
    assert!(moves[0].starts_with(&down) && moves[1].starts_with(&up), "{moves:?}");
    let st = wait_state(&c, "the pen test's end", |s| s["machine"]["activity"] == "idle").await;
    assert!(st["machine"]["error"].is_null(), "{st}");
    assert_eq!(st["machine"]["pen_down"], false, "{st}");
}

#[tokio::test]
async fn motors_off_on_a_connected_idle_machine_only() {
    let (_, router) = test_app(1 << 20, 10.0);
    let mut c = Client::new(&router);
    c.claim().await;
    let (s, v) = c.post("/api/motors-off", json!({})).await;
    assert_eq!(s, StatusCode::CONFLICT);
    assert!(v["error"].as_str().unwrap().contains("not connected"), "{v}");
    c.post("/api/connect", json!({ "target": "sim" })).await;
    wait_state(&c, "connected", |s| s["machine"]["connected"].is_string() && s["machine"]["activity"] == "idle").await;
    let (s, v) = c.post("/api/motors-off", json!({})).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    let st = wait_state(&c, "motors off", |s| s["machine"]["motors_off"] == true).await;
    assert!(st["machine"]["error"].is_null(), "{st}");
    // Homing puts them back to work.
    c.post("/api/home", json!({})).await;
    wait_state(&c, "homed", |s| s["machine"]["motors_off"] == false && s["machine"]["activity"] == "idle").await;
}

#[tokio::test]
async fn custom_paper_hatching_and_hidden_lines_are_settings() {
    let (_, router) = test_app(1 << 20, 10.0);
    let mut c = Client::new(&router);
    c.claim().await;
    c.upload("duck.svg", DUCK).await;
    // 11 × 8.5 in is 279.4 × 215.9 mm.
    let letter = json!({ "paper": "custom", "paper_width": 11, "paper_height": 8.5, "paper_unit": "in", "orientation": "landscape" });
    let (s, v) = c.post("/api/settings", letter).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    let (_, view) = c.get("/api/view").await;
    assert_eq!(view["page_mm"], json!([279.4, 215.9]));
    let (s, _) = c
        .post("/api/settings", json!({ "paper": "custom", "paper_width": 30, "paper_height": 20, "paper_unit": "cm" }))
        .await;
    assert_eq!(s, StatusCode::OK);
    let (_, view) = c.get("/api/view").await;
    assert_eq!(view["page_mm"], json!([300.0, 200.0]));
    for (body, says) in [
        (
            json!({ "paper": "custom", "paper_width": 0.5, "paper_height": 20, "paper_unit": "cm" }),
            "custom paper width 0.5 cm is not in 10..5000 mm",
        ),
        (
            json!({ "paper": "custom", "paper_width": 210, "paper_height": 1e9, "paper_unit": "mm" }),
            "custom paper height 1000000000 mm is not in 10..5000 mm",
        ),
        (
            json!({ "paper": "custom", "paper_width": 8, "paper_height": 10, "paper_unit": "ft" }),
            "custom paper unit \"ft\" is not mm, cm or in",
        ),
        (json!({ "hatch_mm": 0.01 }), "hatch spacing 0.01 mm is not in 0.1..50 mm (0 turns hatching off)"),
        (json!({ "hatch_mm": -1 }), "hatch spacing -1 mm"),
    ] {
        let (s, v) = c.post("/api/settings", body.clone()).await;
        assert_eq!(s, StatusCode::BAD_REQUEST, "{body}: {v}");
        assert!(v["error"].as_str().unwrap().contains(says), "{body}: {v}");
    }
    // Hatching shades the filled 20 mm square of this SVG with 20 mm lines 1 mm apart, about 400 mm of ink (the
    // optimizer may join them into fewer paths); cross-hatching as much again at right angles. Hidden lines: the
    // filled square drawn over the 100 mm line hides 20 mm of it.
    const FILLED: &[u8] =
        br#"<svg xmlns="http://www.w3.org/2000/svg" width="100mm" height="100mm" viewBox="0 0 100 100">
        <path d="M 0 50 L 100 50" stroke="black" fill="none"/>
        <rect x="40" y="40" width="20" height="20" fill="black" stroke="black"/></svg>"#;
    c.upload("filled.svg", FILLED).await;
    let pen_down = |st: &Value| st["prepared"]["stats"]["pen_down_mm"].as_f64().unwrap();
    let (_, plain) = c.get("/api/state").await;
    let (s, v) = c.post("/api/settings", json!({ "hatch_mm": 1.0 })).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    let (_, hatched) = c.get("/api/state").await;
    assert!(pen_down(&hatched) >= pen_down(&plain) + 350.0, "{} -> {} mm", pen_down(&plain), pen_down(&hatched));
    c.post("/api/settings", json!({ "hatch_mm": 1.0, "cross_hatch": true })).await;
    let (_, crossed) = c.get("/api/state").await;
    assert!(pen_down(&crossed) >= pen_down(&hatched) + 350.0, "{} -> {} mm", pen_down(&hatched), pen_down(&crossed));
    c.post("/api/settings", json!({ "hidden_lines": false })).await;
    let (_, all) = c.get("/api/state").await;
    // The line under the square: 100 mm in full, 80 mm with the 20 mm under the square hidden.
    assert!((pen_down(&all) - pen_down(&plain) - 20.0).abs() < 0.5, "{} vs {}", pen_down(&all), pen_down(&plain));
}

#[tokio::test]
async fn hatch_spacing_is_a_page_size_whatever_the_layout_magnifies() {
    // A filled 20 mm square fitted onto A4 portrait within 10 mm margins is magnified 9.5 times to 190 mm; hatched
    // at 1 mm on the page it gets 189 to 191 lines of 190 mm (at most 36.29 m) plus its 760 mm outline and the
    // zig-zags' joins (at most 191 mm): not the 20 document lines, magnified, of hatching before the layout
    // (3.8 m). Margins of 55 mm fit it to 100 mm: 99 to 101 lines of 100 mm plus 400 mm of outline and at most
    // 101 mm of joins, hatched again for the new factor (the 190 lines kept from before would come to 19 m).
    let (_, router) = test_app(1 << 20, 10.0);
    let mut c = Client::new(&router);
    c.claim().await;
    const SQUARE: &[u8] = br#"<svg xmlns="http://www.w3.org/2000/svg" width="20mm" height="20mm" viewBox="0 0 20 20">
        <rect x="0" y="0" width="20" height="20" fill="black" stroke="black"/></svg>"#;
    c.upload("square.svg", SQUARE).await;
    let pen_down = |st: &Value| st["prepared"]["stats"]["pen_down_mm"].as_f64().unwrap();
    let fit = |margin: f64| json!({ "paper": "a4", "fit": true, "margin": margin, "hatch_mm": 1.0 });
    let (s, v) = c.post("/api/settings", fit(10.0)).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    let (_, st) = c.get("/api/state").await;
    assert!((36_600.0..=37_250.0).contains(&pen_down(&st)), "{} mm", pen_down(&st));
    let (s, v) = c.post("/api/settings", fit(55.0)).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    let (_, st) = c.get("/api/state").await;
    assert!((10_250.0..=10_610.0).contains(&pen_down(&st)), "{} mm", pen_down(&st));
}

#[tokio::test]
async fn the_export_downloads_as_an_attachment() {
    let (_, router) = test_app(1 << 20, 10.0);
    let mut c = Client::new(&router);
    c.claim().await;
    let (s, _, body) = fetch(&c, "/api/export?format=gcode").await;
    assert_eq!(s, StatusCode::CONFLICT, "{body}");
    assert!(body.contains("load a drawing first"), "{body}");
    c.upload("duck.svg", DUCK).await;
    // On A4 landscape with 20 mm margins, where an HP 7475A's A4 sheet holds it too.
    let a4 = json!({ "paper": "a4", "orientation": "landscape", "fit": true, "margin": 20 });
    let (s, v) = c.post("/api/settings", a4).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    let (s, _, body) = fetch(&c, "/api/export?format=pdf").await;
    assert_eq!(s, StatusCode::BAD_REQUEST);
    assert!(body.contains(r#"export format \"pdf\" is not gcode, hpgl or svg"#), "{body}");
    let (s, _, body) = fetch(&c, "/api/export").await;
    assert_eq!(s, StatusCode::BAD_REQUEST);
    assert!(body.contains("export:") && body.contains("format"), "{body}");
    let (s, _, body) = fetch(&c, "/api/export?format=hpgl&hpgl_device=7470b").await;
    assert_eq!(s, StatusCode::BAD_REQUEST);
    assert!(body.contains("not a known plotter"), "{body}");
    // Each format is the file the command line's --export writes for the same layout.
    for (format, name, starts) in
        [("gcode", "duck.gcode", "G21"), ("svg", "duck.svg", "<svg"), ("hpgl", "duck.hpgl", "IN;")]
    {
        let (s, headers, body) = fetch(&c, &format!("/api/export?format={format}")).await;
        assert_eq!(s, StatusCode::OK, "{format}: {body}");
        assert_eq!(headers[header::CONTENT_DISPOSITION], format!("attachment; filename=\"{name}\""));
        assert!(
            body.trim_start().starts_with(starts) || body.contains(starts),
            "{format}: {}",
            &body[..body.len().min(200)]
        );
    }
    let (_, _, gcode) = fetch(&c, "/api/export?format=gcode").await;
    let profile = plotter_path::MachineProfile::default_plotter();
    let (_, st) = c.get("/api/state").await;
    assert!(st["prepared"].is_object());
    // Six strokes: six drops of the pen after the first travel of each.
    let drops = gcode
        .lines()
        .filter(|l| {
            l.starts_with(&format!("G1 Z{}", plotter_path::output::gcode_out::fmt_mm(profile.pen.down_z_mm, 2)))
        })
        .count();
    assert_eq!(drops, 6, "{gcode}");
}

#[tokio::test]
async fn the_preview_draws_each_layer_with_the_pen_that_plots_it() {
    let (_, router) = test_app(1 << 20, 10.0);
    let mut c = Client::new(&router);
    c.claim().await;
    // A 0.01 mm black hairline and a 1.69 mm grey drop shadow.
    const SVG: &[u8] = br##"<svg xmlns="http://www.w3.org/2000/svg" width="100mm" height="100mm" viewBox="0 0 100 100">
        <path d="M 10 10 L 90 10" stroke="#000000" stroke-width="0.01" fill="none"/>
        <path d="M 12 12 L 92 12" stroke="#808080" stroke-width="1.69" fill="none"/></svg>"##;
    let (s, v) = c.upload("shadow.svg", SVG).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    let (_, view) = c.get("/api/view").await;
    let profile = plotter_path::MachineProfile::default_plotter();
    for layer in view["layers"].as_array().unwrap() {
        let w = layer["width_mm"].as_f64().unwrap();
        // The XY kit's pen table: a 0.3 mm black fineliner; a grey layer matches no pen and takes [pen] 0.3 mm.
        assert!(w == 0.3 && w == profile.pen.width_mm, "{layer}");
    }
    let (_, st) = c.get("/api/state").await;
    for l in st["drawing"]["layers"].as_array().unwrap() {
        assert_eq!(l["width_mm"], 0.3, "{l}");
    }
    // A width chosen for a layer on the page wins.
    let name = view["layers"][0]["name"].as_str().unwrap().to_string();
    c.post("/api/settings", json!({ "layers": [{ "name": name, "visible": true, "width_mm": 0.8 }] })).await;
    let (_, view) = c.get("/api/view").await;
    assert_eq!(view["layers"][0]["width_mm"], 0.8);
}

/// The CRC-32 of ISO 3309 (gzip's and PNG's), bit by bit.
fn crc32(data: &[u8]) -> u32 {
    data.iter().fold(!0u32, |mut c, &b| {
        c ^= u32::from(b);
        for _ in 0..8 {
            c = if c & 1 == 1 { (c >> 1) ^ 0xedb8_8320 } else { c >> 1 };
        }
        c
    }) ^ !0u32
}

/// `data` as stored (uncompressed) deflate blocks, as RFC 1951 lays them out.
fn deflate_stored(data: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    let chunks: Vec<&[u8]> = data.chunks(65_535).collect();
    for (i, chunk) in chunks.iter().enumerate() {
        out.push(u8::from(i + 1 == chunks.len()));
        let len = u16::try_from(chunk.len()).unwrap();
        out.extend(len.to_le_bytes());
        out.extend((!len).to_le_bytes());
        out.extend(*chunk);
    }
    out
}

/// A gzip file of `data` in stored deflate blocks, as RFC 1952 lays it out.
fn gzip_stored(data: &[u8]) -> Vec<u8> {
    let mut out = vec![0x1f, 0x8b, 8, 0, 0, 0, 0, 0, 0, 255];
    out.extend(deflate_stored(data));
    out.extend(crc32(data).to_le_bytes());
    out.extend(u32::try_from(data.len()).unwrap().to_le_bytes());
    out
}

/// A `w` × `h` PNG of one 8-bit RGB colour, its pixels in a zlib stream of stored blocks (PNG specification §5, §10
/// and RFC 1950), written here so the test depends on no encoder of ours.
fn png_of_one_colour(w: u32, h: u32, rgb: [u8; 3]) -> Vec<u8> {
    let chunk = |out: &mut Vec<u8>, kind: &[u8; 4], data: &[u8]| {
        out.extend(u32::try_from(data.len()).unwrap().to_be_bytes());
        let typed: Vec<u8> = kind.iter().chain(data).copied().collect();
        out.extend(&typed);
        out.extend(crc32(&typed).to_be_bytes());
    };
    let row: Vec<u8> = std::iter::once(0).chain((0..w).flat_map(|_| rgb)).collect();
    let raw: Vec<u8> = (0..h).flat_map(|_| row.iter().copied()).collect();
    let (a, b) = raw.iter().fold((1u32, 0u32), |(a, b), &x| {
        let a = (a + u32::from(x)) % 65_521;
        (a, (b + a) % 65_521)
    });
    let mut zlib = vec![0x78, 0x01];
    zlib.extend(deflate_stored(&raw));
    zlib.extend(((b << 16) | a).to_be_bytes());
    let mut ihdr = Vec::new();
    ihdr.extend(w.to_be_bytes());
    ihdr.extend(h.to_be_bytes());
    ihdr.extend([8, 2, 0, 0, 0]);
    let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
    chunk(&mut out, b"IHDR", &ihdr);
    chunk(&mut out, b"IDAT", &zlib);
    chunk(&mut out, b"IEND", &[]);
    out
}

/// The page's colour and fill-tone settings trace as `--colors` and `--hatch tone` do: an orange picture hatched
/// in gray is one layer, and separated into CMYK it is magenta and yellow (orange has no cyan, and black takes only
/// the gray the three inks share: none); with the XY kit's pens it is the red pen's.
/// A white fill stays empty under the tone hatch (its 20 mm square's 80 mm outline only); a mid-gray fill (#808080: 0.784 of the paper inked, in linear light) gets
/// 0.784 of its 400 mm² inked by 0.3 mm lines: 1045 mm as one family of lines, and up to 1600 mm as three crossing
/// families (k families each covering 1 − 0.216^(1/k) of the paper: k · that · 400 / 0.3 mm), where one spacing of
/// 1 mm gives it 400 mm.
#[tokio::test]
async fn the_page_separates_pictures_into_inks_and_hatches_fills_by_their_tone() {
    let (_, router) = test_app(1 << 20, 10.0);
    let mut c = Client::new(&router);
    c.claim().await;
    // A flat picture has no outline to trace: hatch it from the start.
    let (s, v) = c.post("/api/settings", json!({ "trace": "hatch" })).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    let (s, v) = c.upload("orange.png", &png_of_one_colour(100, 100, [255, 128, 0])).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    let layer_names = |st: &Value| -> Vec<String> {
        st["drawing"]["layers"].as_array().unwrap().iter().map(|l| l["name"].as_str().unwrap().to_owned()).collect()
    };
    assert_eq!(layer_names(&c.get("/api/state").await.1).len(), 1);
    let (s, v) = c.post("/api/settings", json!({ "trace": "hatch", "colors": "cmyk" })).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    assert_eq!(layer_names(&c.get("/api/state").await.1), ["magenta", "yellow"]);
    // The XY kit's pens are black, red and blue: orange (red light, a fifth of the green, no blue) is the red pen's;
    // blue ink would take the red light orange reflects in full.
    let (s, v) = c.post("/api/settings", json!({ "trace": "hatch", "colors": "pens" })).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    let names = layer_names(&c.get("/api/state").await.1);
    assert!(
        names.contains(&"red fineliner 0.5".to_owned()) && !names.contains(&"blue brush pen".to_owned()),
        "{names:?}"
    );
    // A separation of a style that does not shade is refused by name, and the settings the drawing was read with stay.
    let (s, v) = c.post("/api/settings", json!({ "trace": "outline", "colors": "cmyk" })).await;
    assert_eq!(s, StatusCode::BAD_REQUEST, "{v}");
    assert!(v.to_string().contains("--colors"), "{v}");
    let (_, st) = c.get("/api/state").await;
    assert_eq!((&st["settings"]["trace"], &st["settings"]["colors"]), (&json!("hatch"), &json!("pens")));
    let (s, v) = c.post("/api/settings", json!({ "trace": "hatch", "colors": "rgb" })).await;
    assert_eq!(s, StatusCode::BAD_REQUEST, "{v}");
    assert!(v.to_string().contains(r#"unknown colour separation \"rgb\""#), "{v}");

    let square = |fill: &str| {
        format!(
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="20mm" height="20mm" viewBox="0 0 20 20">
            <rect x="0" y="0" width="20" height="20" fill="{fill}" stroke="black"/></svg>"#
        )
    };
    let pen_down = |st: &Value| st["prepared"]["stats"]["pen_down_mm"].as_f64().unwrap();
    c.upload("white.svg", square("white").as_bytes()).await;
    let (s, v) = c.post("/api/settings", json!({ "hatch_tone": true })).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    assert!((pen_down(&c.get("/api/state").await.1) - 80.0).abs() < 0.5);
    c.upload("gray.svg", square("#808080").as_bytes()).await;
    let hatched = pen_down(&c.get("/api/state").await.1) - 80.0;
    assert!((0.95 * 1045.0..=1.05 * 1600.0).contains(&hatched), "{hatched} mm of hatching");
    // One spacing for every fill: 19 or 20 lines of 20 mm at 1 mm, whatever the fill's gray, and their joins.
    c.post("/api/settings", json!({ "hatch_mm": 1.0 })).await;
    let hatched = pen_down(&c.get("/api/state").await.1) - 80.0;
    assert!((380.0..=420.0 + 20.0).contains(&hatched), "{hatched} mm of hatching");
}

/// What the page's file picker offers besides SVG and images is decoded: a compressed SVG and HP-GL files.
#[tokio::test]
async fn svgz_hpgl_and_plt_uploads_are_decoded() {
    let (_, router) = test_app(1 << 20, 10.0);
    let mut c = Client::new(&router);
    c.claim().await;
    let (s, v) = c.upload("duck.svgz", &gzip_stored(DUCK)).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    let (_, st) = c.get("/api/state").await;
    assert_eq!((&st["drawing"]["name"], &st["prepared"]["stats"]["paths"]), (&json!("duck.svgz"), &json!(6)));
    // A 10 mm square at 40 plotter units per mm: 40 mm of ink.
    let square = b"IN;SP1;PU0,0;PD400,0,400,400,0,400,0,0;PU;SP0;";
    for name in ["square.hpgl", "square.plt"] {
        let (s, v) = c.upload(name, square).await;
        assert_eq!(s, StatusCode::OK, "{name}: {v}");
        let (_, st) = c.get("/api/state").await;
        let ink = st["prepared"]["stats"]["pen_down_mm"].as_f64().unwrap();
        assert!((ink - 40.0).abs() < 1e-6, "{name}: {ink} mm");
    }
    let page = fetch(&c, "/").await.2;
    assert!(page.contains("accept=\".svg,.svgz,") && page.contains(".hpgl,.hgl,.plt,"), "the picker offers them");
}

/// The page measures strokes on the plotted page as `plotter plot` does, hatching or not. A 37 × 20 mm card: a thin
/// line across its middle under a 0.5 mm black stroke down its middle. As it is (57 mm of ink) the stroke is under
/// four 0.3 mm pens wide and the line stays whole; fitted to 180 mm (200 mm paper, 10 mm margins: 4.865×) the stroke
/// is 2.432 mm wide on the page and hides 2.432 mm of the 180 mm line: 177.568 + 97.297 (the stroke, 20 mm tall) =
/// 274.865 mm of ink. (Read once at the document's size, the page kept the line whole: 277.297 mm.)
#[tokio::test]
async fn the_page_measures_strokes_at_the_page_scale() {
    let (_, router) = test_app(1 << 20, 10.0);
    let mut c = Client::new(&router);
    c.claim().await;
    let card = r#"<svg xmlns="http://www.w3.org/2000/svg" width="37mm" height="20mm" viewBox="0 0 37 20">
        <path d="M0 10H37" stroke="black" stroke-width="0.1" fill="none"/>
        <path d="M18.5 0V20" stroke="black" stroke-width="0.5" fill="none"/></svg>"#;
    let (s, v) = c.upload("card.svg", card.as_bytes()).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    let pen_down = |st: &Value| st["prepared"]["stats"]["pen_down_mm"].as_f64().unwrap();
    let ink = pen_down(&c.get("/api/state").await.1);
    assert!((ink - 57.0).abs() < 1e-6, "{ink} mm");
    let (s, v) = c.post("/api/settings", json!({ "paper": "200x200", "margin": 10.0, "fit": true })).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    let ink = pen_down(&c.get("/api/state").await.1);
    let want = 180.0 - 0.5 * 180.0 / 37.0 + 20.0 * 180.0 / 37.0;
    assert!((ink - want).abs() < 0.01, "{ink} mm, want {want}");
}

#[tokio::test]
async fn a_servo_pens_estimate_is_planned_again_for_the_grbl_machine_connected() {
    use plotter_host::link::machine::{Firmware, profile_for};
    use plotter_path::motion::plan::{self, Lookahead};
    // The servo kit: our firmware (and the EBB) command the pen's drop while the carriage travels; GRBL's M3
    // waits for the moves before it to end, so there the carriage stops where the drop is commanded.
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../samples/servo-plotter.toml");
    let kit =
        plotter_path::MachineProfile::from_toml(&std::fs::read_to_string(path).unwrap(), "servo-plotter.toml").unwrap();
    let (shared, router) = test_app_with(1 << 20, 10.0, kit.clone());
    let mut c = Client::new(&router);
    c.claim().await;
    let (s, v) = c.upload("duck.svg", DUCK).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    let st = wait_state(&c, "a prepared drawing", |s| !s["prepared"].is_null()).await;
    let steps = shared.lock().prepared.as_ref().unwrap().steps.clone();
    let planned = |p: &plotter_path::MachineProfile| {
        plan::plan(p, &steps, plan::homed_position(p).unwrap(), Lookahead::Whole).unwrap().seconds()
    };
    let (ours, grbl) = (planned(&kit), planned(&profile_for(&kit, Firmware::Grbl)));
    // Six strokes, six hops that stop for the drop on GRBL: some 70 ms each on a long hop.
    assert!(grbl - ours > 0.1, "ours {ours} s, GRBL {grbl} s");
    // Before a machine is connected: planned for our firmware, and said so.
    assert_eq!(st["prepared"]["estimate_s"].as_f64(), Some(ours), "{st}");
    assert_eq!(st["prepared"]["estimate_for"], "our firmware or an EiBotBoard", "{st}");
    // A GRBL controller connected: the estimate is GRBL's plan, and so are the next preparations'.
    super::worker::firmware_known(&shared, Firmware::Grbl);
    let (_, st) = c.get("/api/state").await;
    assert_eq!(st["prepared"]["estimate_s"].as_f64(), Some(grbl), "{st}");
    assert_eq!(st["prepared"]["estimate_for"], "GRBL", "{st}");
    assert_eq!(shared.lock().machine_profile(), profile_for(&kit, Firmware::Grbl).into_owned());
}

/// The page flattens an SVG's curves for the plotted page as `plotter stats` does. A 10 × 5 mm card, framed by a
/// thin line, holds a 1 mm circle centred at (2.5, 2.5). Fitted to 180 mm (200 mm paper, 10 mm margins) it is
/// magnified k = 180 / 10 = 18×: a circle of R = 18 mm on the page, whose chords must miss it by at most the
/// 0.05 mm tolerance: a chord spanning θ misses it by R(1 − cos θ/2), so at least π / acos(1 − 0.05/18) = 42.1, 43
/// chords. (Flattened at the document's size, 39 chords missed it by up to 0.146 mm on the page.) The vertices lie
/// on SVG's four cubic Béziers, off the true circle by up to 0.0273 % of R (3e-4 R allowed), so each chord's
/// midpoint lies within 0.05 + 3e-4 R of it. And the ink is what `plotter stats` reads for the same card and flags.
#[tokio::test]
async fn the_page_flattens_curves_for_an_enlarged_drawing() {
    let (shared, router) = test_app(1 << 20, 10.0);
    let mut c = Client::new(&router);
    c.claim().await;
    let card = r#"<svg xmlns="http://www.w3.org/2000/svg" width="10mm" height="5mm" viewBox="0 0 10 5">
        <rect x="0" y="0" width="10" height="5" fill="none" stroke="black" stroke-width="0.05"/>
        <circle cx="2.5" cy="2.5" r="1" fill="none" stroke="black" stroke-width="0.05"/></svg>"#;
    let (s, v) = c.upload("card.svg", card.as_bytes()).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    let (s, v) = c.post("/api/settings", json!({ "paper": "200x200", "margin": 10.0, "fit": true })).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    let drawing = shared.lock().prepared.as_ref().unwrap().drawing.clone();
    // The frame is the drawing's box: it gives the magnification and where the circle is, independently of it.
    let b = drawing.bbox().unwrap();
    let k = b.width() / 10.0;
    assert!((k - 18.0).abs() < 1e-9, "{k}");
    let (centre, r) = (plotter_path::kurbo::Point::new(b.x0 + 2.5 * k, b.y0 + 2.5 * k), k);
    let circle: Vec<_> = drawing.paths().filter(|p| p.points.iter().all(|q| q.distance(centre) < r + 0.1)).collect();
    assert_eq!(circle.len(), 1);
    let points = &circle[0].points;
    let cubic = 3e-4 * r;
    let off = points.iter().map(|q| (q.distance(centre) - r).abs()).fold(0.0, f64::max);
    assert!(off <= cubic, "vertices up to {off} mm off the circle");
    let worst = points.windows(2).map(|w| r - w[0].midpoint(w[1]).distance(centre)).fold(0.0, f64::max);
    assert!(points.len() > 43 && worst <= 0.05 + cubic, "{} points, worst chord {worst} mm", points.len());
    // `plotter stats` with the same flags: the ink of `load_laid_out`.
    let dir = std::env::temp_dir().join(format!("plotter-serve-flatten-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("card.svg");
    std::fs::write(&file, card).unwrap();
    #[derive(clap::Parser)]
    struct W {
        #[command(flatten)]
        input: plotter_host::input::InputArgs,
        #[command(flatten)]
        layout: plotter_host::options::layout::LayoutArgs,
    }
    let w = <W as clap::Parser>::parse_from(["w", "--paper", "200x200", "--margin", "10", "--fit"]);
    let profile = plotter_path::MachineProfile::default_plotter();
    let cli = plotter_host::input::load_laid_out(&file, &w.input, &profile, &w.layout).unwrap().drawing;
    std::fs::remove_dir_all(&dir).ok();
    let ink = |d: &plotter_path::Drawing| d.paths().map(plotter_path::Polyline::length).sum::<f64>();
    let page = c.get("/api/state").await.1["prepared"]["stats"]["pen_down_mm"].as_f64().unwrap();
    assert!((ink(&drawing) - ink(&cli)).abs() < 1e-9 && (page - ink(&cli)).abs() < 1e-6, "{page} vs {}", ink(&cli));
}

/// "Machine's pens" with a machine profile whose pens have no colour is refused naming what the page offers: the
/// Machine profile choice, Upload profile, Picture colours (it named preview and plot, commands of the command line).
#[tokio::test]
async fn the_page_says_what_to_do_when_the_machine_has_no_coloured_pen() {
    let (_, router) = test_app(1 << 22, 10.0);
    let mut c = Client::new(&router);
    c.claim().await;
    let toml = plotter_path::config::profile::DEFAULT_PROFILE_TOML;
    let plain: Vec<&str> = toml.lines().filter(|l| !l.trim_start().starts_with("color =")).collect();
    let plain = plain.join("\n");
    let name = plotter_path::MachineProfile::from_toml(&plain, "plain.toml").unwrap().name;
    let upload = c.request("POST", "/api/profile/upload?name=plain.toml").body(Body::from(plain)).unwrap();
    let (s, v) = c.send(upload).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    let (s, v) = c.post("/api/settings", json!({ "trace": "mosaic", "colors": "pens" })).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    let photo = include_bytes!("../../../../../samples/photo.png");
    let (s, v) = c.upload("photo.png", photo).await;
    assert_eq!(s, StatusCode::BAD_REQUEST, "{v}");
    let e = v["error"].as_str().unwrap();
    assert!(e.contains(&format!("machine profile {name:?} has no pen with a colour")), "{e}");
    assert!(e.contains("under Machine") && e.contains("Upload profile") && e.contains("Picture colours"), "{e}");
    assert!(!e.contains("--") && !e.contains("preview"), "{e}");
}
