//! Headless Chromium driven over the DevTools protocol, for the page tests (`serve_browser`, `studio_browser`): a
//! minimal client over a WebSocket that starts the browser, evaluates script in a page, waits for conditions and
//! takes screenshots. Each page test uses its own share of it.
#![allow(dead_code)]

use std::io::{BufRead as _, BufReader};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use serde_json::{Value, json};
use tungstenite::{Message, WebSocket};

/// One browser at a time, held by each page test while its browser runs: a headless Chromium takes much of a
/// two-core machine, and the page tests time what the page shows.
pub(crate) static ONE_BROWSER: Mutex<()> = Mutex::new(());

/// A child process killed when dropped.
pub(crate) struct Killed(Child);

impl Drop for Killed {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

pub(crate) fn chromium() -> Option<PathBuf> {
    let path = std::env::var_os("PLOTTER_CHROMIUM").map_or_else(|| PathBuf::from("/usr/bin/chromium"), PathBuf::from);
    if path.exists() {
        return Some(path);
    }
    assert!(std::env::var_os("CI").is_none(), "{} is missing: CI must install chromium", path.display());
    eprintln!("SKIP: {} not found (apt-get install chromium)", path.display());
    None
}

/// A DevTools-protocol session with one page.
pub(crate) struct Cdp {
    ws: WebSocket<TcpStream>,
    next_id: u64,
    session: String,
    /// The elements whose text a timed-out wait reports (CSS selectors).
    pub(crate) shown: Vec<&'static str>,
}

impl Cdp {
    /// Start Chromium headless with a fresh profile in `profile_dir` and attach to a blank page.
    pub(crate) fn launch(browser: &Path, profile_dir: &Path) -> (Killed, Cdp) {
        let mut child = Command::new(browser)
            .args([
                "--headless",
                "--no-sandbox",
                "--disable-gpu",
                "--disable-background-networking",
                "--disable-component-update",
                "--disable-sync",
                "--no-first-run",
                "--window-size=1400,1000",
                "--remote-debugging-port=0",
            ])
            .arg(format!("--user-data-dir={}", profile_dir.display()))
            .arg("about:blank")
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .expect("chromium starts");
        let stderr = child.stderr.take().expect("stderr");
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stderr).lines().map_while(Result::ok) {
                if let Some(url) = line.strip_prefix("DevTools listening on ") {
                    let _ = tx.send(url.trim().to_string());
                }
            }
        });
        let child = Killed(child);
        let url = rx.recv_timeout(Duration::from_secs(30)).expect("chromium prints its DevTools address");
        let authority = url.trim_start_matches("ws://").split('/').next().expect("host:port").to_string();
        let stream = TcpStream::connect(&authority).expect("connect to DevTools");
        stream.set_read_timeout(Some(Duration::from_secs(30))).expect("timeout");
        let (ws, _) = tungstenite::client(url.as_str(), stream).expect("DevTools WebSocket handshake");
        let mut cdp = Cdp { ws, next_id: 0, session: String::new(), shown: vec!["#message", "#percent", "#activity"] };
        let target = cdp.call("Target.createTarget", json!({ "url": "about:blank" }))["targetId"].clone();
        let attached = cdp.call("Target.attachToTarget", json!({ "targetId": target, "flatten": true }));
        cdp.session = attached["sessionId"].as_str().expect("session id").to_string();
        cdp.call("Page.enable", json!({}));
        cdp.call("Runtime.enable", json!({}));
        (child, cdp)
    }

    /// Send a command and wait for its result (events in between are skipped).
    pub(crate) fn call(&mut self, method: &str, params: Value) -> Value {
        self.next_id += 1;
        let id = self.next_id;
        let mut msg = json!({ "id": id, "method": method, "params": params });
        if !self.session.is_empty() {
            msg["sessionId"] = json!(self.session);
        }
        self.ws.send(Message::text(msg.to_string())).expect("send to DevTools");
        loop {
            let reply = self.ws.read().expect("DevTools answers");
            let Message::Text(text) = reply else { continue };
            let v: Value = serde_json::from_str(text.as_str()).expect("DevTools sends JSON");
            if v["id"] == json!(id) {
                assert!(v["error"].is_null(), "{method} failed: {}", v["error"]);
                return v["result"].clone();
            }
        }
    }

    /// Send a command to the browser itself (not the page) and wait for its result.
    pub(crate) fn call_browser(&mut self, method: &str, params: Value) -> Value {
        let session = std::mem::take(&mut self.session);
        let result = self.call(method, params);
        self.session = session;
        result
    }

    /// Evaluate `expr` in the page; its value.
    pub(crate) fn eval(&mut self, expr: &str) -> Value {
        let r =
            self.call("Runtime.evaluate", json!({ "expression": expr, "returnByValue": true, "awaitPromise": true }));
        assert!(r["exceptionDetails"].is_null(), "{expr} threw: {}", r["exceptionDetails"]);
        r["result"]["value"].clone()
    }

    /// Evaluate `expr` until it is true (bounded).
    pub(crate) fn wait_for(&mut self, what: &str, expr: &str, limit: Duration) {
        let t0 = Instant::now();
        // While the page loads, the elements may not be there yet: that is "not yet", not an error.
        let guarded = format!("(() => {{ try {{ return ({expr}); }} catch (_) {{ return false; }} }})()");
        while self.eval(&guarded) != json!(true) {
            let shown = self.shown.clone();
            let seen = shown.iter().map(|s| self.text(s)).collect::<Vec<_>>().join(" | ");
            assert!(t0.elapsed() < limit, "timed out waiting for {what}; page says: {seen}");
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    pub(crate) fn click(&mut self, id: &str) {
        self.eval(&format!("document.getElementById('{id}').click()"));
    }

    pub(crate) fn text(&mut self, selector: &str) -> String {
        self.eval(&format!("(document.querySelector('{selector}')||{{}}).textContent||''"))
            .as_str()
            .unwrap_or("")
            .to_string()
    }

    pub(crate) fn screenshot(&mut self, path: &Path) {
        let data =
            self.call("Page.captureScreenshot", json!({ "format": "png" }))["data"].as_str().unwrap_or("").to_string();
        std::fs::write(path, base64_decode(&data)).expect("write the screenshot");
    }
}

/// Standard base64 (as DevTools sends screenshots).
fn base64_decode(s: &str) -> Vec<u8> {
    let value = |c: u8| match c {
        b'A'..=b'Z' => Some(c - b'A'),
        b'a'..=b'z' => Some(c - b'a' + 26),
        b'0'..=b'9' => Some(c - b'0' + 52),
        b'+' => Some(62),
        b'/' => Some(63),
        _ => None,
    };
    let (mut out, mut acc, mut bits) = (Vec::new(), 0u32, 0);
    for v in s.bytes().filter_map(value) {
        acc = (acc << 6) | u32::from(v);
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push(u8::try_from((acc >> bits) & 0xff).unwrap_or(0));
        }
    }
    out
}
