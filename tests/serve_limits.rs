//! `plotter serve` against hostile or careless clients, over raw TCP on a loopback port: half-sent requests and
//! silent connections are closed after the header timeout, connections over the cap are answered 503 and closed at
//! once, a declared oversize body is refused before it is sent, a body that does not arrive in time gets 408, a
//! claim of control without an event stream lapses, cross-site requests without an `Origin` are refused, and a
//! listen address off loopback needs `--allow-remote`, and an upload's `<image>` naming a file gets the same answer
//! whether the file exists or not. The limits are set small by flag so this runs in seconds.

use std::io::{BufRead as _, BufReader, Read as _, Write as _};
use std::net::TcpStream;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use plotter_e2e::{Served, plotter_bin};
use serde_json::Value;

/// A connection to `served` that gives up reading after 10 s (no test here waits that long for an answer).
fn connect(served: &Served) -> TcpStream {
    let stream = TcpStream::connect(&served.authority).expect("connect to plotter serve");
    stream.set_read_timeout(Some(Duration::from_secs(10))).expect("read timeout");
    stream
}

/// Everything the server sends until it closes the connection (the read timeout fails the test).
fn read_all(stream: &mut TcpStream) -> String {
    let mut bytes = Vec::new();
    stream.read_to_end(&mut bytes).expect("the server answers and closes within the read timeout");
    String::from_utf8_lossy(&bytes).into_owned()
}

/// An answer's status and JSON body (`Null` if the body is not JSON).
fn parse(answer: &str) -> (u16, Value) {
    let status = answer.split(' ').nth(1).and_then(|s| s.parse().ok()).unwrap_or(0);
    let body = answer.split_once("\r\n\r\n").map_or("", |(_, b)| b);
    (status, serde_json::from_str(body).unwrap_or(Value::Null))
}

/// Send one request (closing the connection after it) with `headers` and `body`; its status and JSON body.
fn request(served: &Served, method: &str, path: &str, headers: &[(&str, &str)], body: &str) -> (u16, Value) {
    parse(&send(served, method, path, headers, body).expect("the server answers and closes within the read timeout"))
}

/// [`request`]'s raw answer, or the error reading it (a server refusing the connection while the request is still
/// unread resets it).
fn send(served: &Served, method: &str, path: &str, headers: &[(&str, &str)], body: &str) -> std::io::Result<String> {
    send_to(&served.authority, method, path, headers, body)
}

/// [`send`] to the server at `authority`.
fn send_to(authority: &str, method: &str, path: &str, headers: &[(&str, &str)], body: &str) -> std::io::Result<String> {
    let mut stream = TcpStream::connect(authority)?;
    stream.set_read_timeout(Some(Duration::from_secs(60)))?;
    let mut head = format!("{method} {path} HTTP/1.1\r\nHost: {authority}\r\nConnection: close\r\n");
    for (name, value) in headers {
        head.push_str(&format!("{name}: {value}\r\n"));
    }
    head.push_str(&format!("Content-Length: {}\r\n\r\n{body}", body.len()));
    stream.write_all(head.as_bytes())?;
    let mut bytes = Vec::new();
    stream.read_to_end(&mut bytes)?;
    Ok(String::from_utf8_lossy(&bytes).into_owned())
}

/// Take control; the token.
fn claim(served: &Served) -> String {
    let (status, v) = request(served, "POST", "/api/control/claim", &[], "");
    assert_eq!(status, 200, "{v}");
    v["token"].as_str().expect("a token").to_string()
}

#[test]
fn a_half_sent_request_and_a_silent_connection_are_closed_after_the_header_timeout() {
    let served = Served::start(&["--listen", "127.0.0.1:0", "--header-timeout-s", "0.5"]);
    let mut half = connect(&served);
    let t0 = Instant::now();
    half.write_all(format!("GET /api/state HTTP/1.1\r\nHost: {}\r\n", served.authority).as_bytes()).unwrap();
    let mut silent = connect(&served);
    for (what, stream) in [("half-sent request", &mut half), ("silent connection", &mut silent)] {
        let answer = read_all(stream);
        let waited = t0.elapsed();
        assert_eq!(answer, "", "{what}: closed without an answer");
        assert!(
            waited >= Duration::from_millis(450) && waited < Duration::from_secs(10),
            "{what}: closed after {waited:?}"
        );
    }
    // The server itself is fine.
    assert_eq!(request(&served, "GET", "/api/state", &[], "").0, 200);
}

#[test]
fn connections_over_the_cap_are_answered_busy_and_closed_at_once() {
    let served = Served::start(&["--listen", "127.0.0.1:0", "--max-connections", "4", "--header-timeout-s", "30"]);
    let holders: Vec<TcpStream> = (0..4)
        .map(|_| {
            let mut s = connect(&served);
            s.write_all(b"GET /api/state HTTP/1.1\r\n").unwrap();
            s
        })
        .collect();
    for extra in 0..2 {
        let t0 = Instant::now();
        let answer = read_all(&mut connect(&served));
        assert!(
            t0.elapsed() < Duration::from_secs(10),
            "connection {extra} over the cap waited (the header timeout is 30 s) {:?}",
            t0.elapsed()
        );
        let (status, v) = parse(&answer);
        assert_eq!(status, 503, "{answer}");
        let e = v["error"].as_str().unwrap_or_default();
        assert!(e.contains("4 connections open") && e.contains("--max-connections"), "{answer}");
    }
    // Once the holders hang up their slots free, and an ordinary request gets through.
    drop(holders);
    let t0 = Instant::now();
    loop {
        // Until the server has seen the holders go, it answers 503 — or resets, having closed with the request
        // unread: both mean "still full".
        let (status, v) = send(&served, "GET", "/api/state", &[], "").map_or((0, Value::Null), |a| parse(&a));
        if status == 200 {
            assert_eq!(v["controlled"], false);
            break;
        }
        assert!(t0.elapsed() < Duration::from_secs(10), "still refused after the holders left: {status} {v}");
        std::thread::sleep(Duration::from_millis(50));
    }
}

#[test]
fn a_declared_oversize_body_is_refused_before_it_is_sent() {
    let served = Served::start(&["--listen", "127.0.0.1:0", "--max-upload-mb", "1"]);
    let token = claim(&served);
    for (path, length, expected) in [
        ("/api/drawing?name=big.svg", 100_000_000, "big.svg is too large (95.4 MB): uploads are limited to 1.0 MB"),
        (
            "/api/profile/upload?name=kit.toml",
            1_048_577,
            "kit.toml is too large (1.0 MB): uploads are limited to 1.0 MB",
        ),
        (
            "/api/settings",
            65_537,
            "the request body is too large (0.1 MB): requests other than uploads are limited to 64 KB",
        ),
    ] {
        // Headers only, asking to be told to go on: the answer is the refusal, not `100 Continue`.
        let mut stream = connect(&served);
        let head = format!(
            "POST {path} HTTP/1.1\r\nHost: {}\r\nX-Plotter-Token: {token}\r\nContent-Length: {length}\r\n\
             Expect: 100-continue\r\n\r\n",
            served.authority
        );
        stream.write_all(head.as_bytes()).unwrap();
        let t0 = Instant::now();
        let answer = read_all(&mut stream);
        assert!(t0.elapsed() < Duration::from_secs(10), "{path}: answered after {:?}", t0.elapsed());
        assert!(answer.starts_with("HTTP/1.1 413 "), "{path}: {answer}");
        assert!(answer.to_ascii_lowercase().contains("\r\nconnection: close\r\n"), "{path}: {answer}");
        let (_, v) = parse(&answer);
        assert!(v["error"].as_str().is_some_and(|e| e.starts_with(expected)), "{path}: {v}");
    }
}

#[test]
fn a_body_that_does_not_arrive_in_time_is_answered_408() {
    let served = Served::start(&["--listen", "127.0.0.1:0", "--body-timeout-s", "0.5"]);
    let token = claim(&served);
    let mut stream = connect(&served);
    let head = format!(
        "POST /api/settings HTTP/1.1\r\nHost: {}\r\nX-Plotter-Token: {token}\r\nContent-Type: application/json\r\n\
         Content-Length: 100\r\n\r\n{{\"paper\"",
        served.authority
    );
    let t0 = Instant::now();
    stream.write_all(head.as_bytes()).unwrap();
    let answer = read_all(&mut stream);
    let waited = t0.elapsed();
    assert!(waited >= Duration::from_millis(450) && waited < Duration::from_secs(10), "answered after {waited:?}");
    let (status, v) = parse(&answer);
    assert_eq!(status, 408, "{answer}");
    assert_eq!(v["error"], "refused: the request body did not arrive within 0.5 s");
}

#[test]
fn a_claim_without_an_event_stream_lapses_and_another_page_takes_control() {
    let served = Served::start(&["--listen", "127.0.0.1:0", "--claim-grace-s", "1"]);
    let t0 = Instant::now();
    let first = claim(&served);
    // Another page is refused until the claim lapses, about a second later.
    let second = loop {
        let (status, v) = request(&served, "POST", "/api/control/claim", &[], "");
        if status == 200 {
            let waited = t0.elapsed();
            assert!(
                waited >= Duration::from_millis(900) && waited < Duration::from_secs(10),
                "lapsed after {waited:?}"
            );
            break v["token"].as_str().unwrap().to_string();
        }
        assert_eq!(status, 409, "{v}");
        assert!(t0.elapsed() < Duration::from_secs(10), "the claim never lapsed");
        std::thread::sleep(Duration::from_millis(100));
    };
    let (status, _) = request(&served, "POST", "/api/control/release", &[("X-Plotter-Token", &first)], "");
    assert_eq!(status, 403, "the lapsed token is worthless");

    // A page that opens its event stream keeps control past the grace, until the stream closes.
    let mut events = connect(&served);
    let get = format!("GET /api/events?token={second} HTTP/1.1\r\nHost: {}\r\n\r\n", served.authority);
    events.write_all(get.as_bytes()).unwrap();
    let mut status_line = String::new();
    BufReader::new(&mut events).read_line(&mut status_line).unwrap();
    assert!(status_line.starts_with("HTTP/1.1 200"), "{status_line}");
    std::thread::sleep(Duration::from_millis(2500));
    let (status, v) = request(&served, "POST", "/api/control/claim", &[], "");
    assert_eq!(status, 409, "the streaming page still controls: {v}");
    drop(events);
    let t1 = Instant::now();
    while request(&served, "POST", "/api/control/claim", &[], "").0 != 200 {
        assert!(t1.elapsed() < Duration::from_secs(10), "control not given up when the stream closed");
        std::thread::sleep(Duration::from_millis(50));
    }
}

#[test]
fn cross_site_requests_without_an_origin_are_refused() {
    let served = Served::start(&["--listen", "127.0.0.1:0"]);
    let own = format!("http://{}/", served.authority);
    for (name, value, what) in [
        ("Referer", "http://evil.example/page.html", "cross-site request"),
        ("Sec-Fetch-Site", "cross-site", "Sec-Fetch-Site: cross-site"),
        ("Sec-Fetch-Site", "same-site", "Sec-Fetch-Site: same-site"),
    ] {
        for (method, path) in [("GET", "/api/state"), ("POST", "/api/control/claim")] {
            let (status, v) = request(&served, method, path, &[(name, value)], "");
            assert_eq!(status, 403, "{method} {path} with {name}: {value}: {v}");
            assert!(v["error"].as_str().unwrap_or_default().contains(what), "{v}");
        }
    }
    let (status, v) =
        request(&served, "GET", "/api/state", &[("Referer", &own), ("Sec-Fetch-Site", "same-origin")], "");
    assert_eq!((status, &v["controlled"]), (200, &Value::Bool(false)), "{v}");
    let (status, v) = request(&served, "POST", "/api/control/claim", &[("Sec-Fetch-Site", "none")], "");
    assert_eq!(status, 200, "{v}");
}

#[test]
fn a_listen_address_off_loopback_needs_allow_remote() {
    let refused = Command::new(plotter_bin())
        .args(["serve", "--listen", "0.0.0.0:0"])
        .stdin(Stdio::null())
        .output_within(Duration::from_secs(20));
    assert!(!refused.status.success());
    let err = String::from_utf8_lossy(&refused.stderr);
    assert!(
        err.contains("refusing to listen on 0.0.0.0:0")
            && err.contains("--allow-remote")
            && err.contains("--token-file"),
        "{err}"
    );
    assert!(refused.stdout.is_empty(), "nothing served: {}", String::from_utf8_lossy(&refused.stdout));
    // --allow-remote alone: no token, so no start either (issue 41).
    let refused = Command::new(plotter_bin())
        .args(["serve", "--listen", "0.0.0.0:0", "--allow-remote"])
        .stdin(Stdio::null())
        .output_within(Duration::from_secs(20));
    let err = String::from_utf8_lossy(&refused.stderr);
    assert!(!refused.status.success() && err.contains("with no token") && err.contains("--generate-token"), "{err}");
    assert!(refused.stdout.is_empty(), "nothing served: {}", String::from_utf8_lossy(&refused.stdout));

    let mut child = Command::new(plotter_bin())
        .args(["serve", "--listen", "0.0.0.0:0", "--allow-remote", "--generate-token"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("plotter serve starts");
    let mut line = String::new();
    BufReader::new(child.stdout.take().unwrap()).read_line(&mut line).unwrap();
    let _ = child.kill();
    let _ = child.wait();
    let mut err = String::new();
    child.stderr.take().unwrap().read_to_string(&mut err).unwrap();
    assert!(line.starts_with("plotter serve: http://127.0.0.1:"), "{line}");
    assert!(err.contains("listening on 0.0.0.0:") && err.contains("everyone must sign in"), "{err}");
    let token = err.lines().find_map(|l| l.strip_prefix("plotter serve: operator token (queue and control): "));
    assert!(token.is_some_and(|t| t.len() == 32), "the generated token is printed once: {err}");
}

/// `Command::output` with a deadline: a server that starts instead of refusing fails the test, not hangs it.
trait OutputWithin {
    fn output_within(&mut self, limit: Duration) -> std::process::Output;
}

impl OutputWithin for Command {
    fn output_within(&mut self, limit: Duration) -> std::process::Output {
        let mut child = self.stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().expect("plotter runs");
        let t0 = Instant::now();
        while child.try_wait().expect("wait").is_none() {
            if t0.elapsed() > limit {
                let _ = child.kill();
                panic!("still running after {limit:?}");
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        child.wait_with_output().expect("output")
    }
}

/// A line under a mask holding a white square and an `<image>` naming `href`: imported with the image, the mask
/// turns partly transparent (a warning says so) — what made the file-existence oracle of issue 22, item 1.
fn masked_image(href: &str) -> String {
    format!(
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="100" height="100"><mask id="m" maskUnits="userSpaceOnUse" x="0" y="0" width="100" height="100"><rect width="100" height="100" fill="white"/><image x="0" y="0" width="10" height="10" href="{href}"/></mask><g mask="url(#m)"><line x1="0" y1="50" x2="100" y2="50" stroke="black"/></g></svg>"#
    )
}

/// Upload `svg` as `m.svg` with control `token`; the upload's answer, the drawing's warnings and the layers of
/// the view, with `href` replaced by `HREF` so answers about different files compare equal when they say the same.
fn upload_masked(served: &Served, token: &str, href: &str) -> (u16, String) {
    let (status, answer) =
        request(served, "POST", "/api/drawing?name=m.svg", &[("X-Plotter-Token", token)], &masked_image(href));
    let (_, state) = request(served, "GET", "/api/state", &[], "");
    let (_, view) = request(served, "GET", "/api/view", &[], "");
    let seen = format!("{answer} {} {} {}", state["drawing"]["warnings"], state["prepared"]["stats"], view["layers"]);
    (status, seen.replace(href, "HREF"))
}

/// Issue 22, item 1 through `plotter serve`: an upload's `<image>` naming an existing file, a missing one,
/// `/dev/zero`, a FIFO or a path relative to the server's folder gets the same answer at once — nothing on the
/// machine is opened or looked up — while the same image inline as a `data:` URL is read.
#[cfg(unix)]
#[test]
fn an_uploaded_image_naming_a_file_gets_the_same_answer_whether_the_file_exists_or_not() {
    let dir = plotter_e2e::scratch("serve-image-oracle");
    let png = std::fs::read(plotter_e2e::sample("line-art.png")).unwrap();
    std::fs::write(dir.join("there.png"), &png).unwrap();
    let fifo = dir.join("fifo.png");
    assert!(Command::new("mkfifo").arg(&fifo).status().unwrap().success());
    let served = Served::start(&["--listen", "127.0.0.1:0"]);
    let token = claim(&served);
    let path = |name: &str| dir.join(name).display().to_string();
    // Relative to the server's working folder (the tests package): an existing image and a missing one.
    let relative = "../samples/line-art.png";
    assert!(std::path::Path::new(relative).is_file());
    let hrefs = [path("there.png"), path("missing.png"), "/dev/zero".into(), path("fifo.png"), relative.into()];
    let mut answers = Vec::new();
    for href in &hrefs {
        let t0 = Instant::now();
        answers.push(upload_masked(&served, &token, href));
        assert!(t0.elapsed() < Duration::from_secs(5), "{href}: answered after {:?}", t0.elapsed());
    }
    let (status, first) = &answers[0];
    assert_eq!(*status, 200, "{first}");
    assert!(first.contains(r#"m.svg: image \"HREF\" not loaded: only data: URLs are read here"#), "{first}");
    assert!(!first.contains("partly transparent"), "{first}");
    for (href, answer) in hrefs.iter().zip(&answers) {
        assert_eq!(answer, &answers[0], "{href}");
    }
    // The same image inline is read: the mask turns partly transparent, and the answer differs.
    let inline: String = png.iter().map(|b| format!("%{b:02X}")).collect();
    let inline = format!("data:image/png,{inline}");
    let (status, read) = upload_masked(&served, &token, &inline);
    assert_eq!(status, 200, "{read}");
    assert!(read.contains("partly transparent") && !read.contains("not loaded"), "{read}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The server's peak resident memory so far (`VmHWM`), KiB.
#[cfg(target_os = "linux")]
fn peak_rss_kib(pid: u32) -> u64 {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).expect("the server runs");
    let line = status.lines().find(|l| l.starts_with("VmHWM:")).expect("VmHWM");
    line.split_whitespace().nth(1).and_then(|v| v.parse().ok()).expect("a number")
}

/// Issue 37, class 7: two 16 MB HP-GL uploads of `PDPU` (pen down and up in place: a dot of two points per four
/// bytes, eight million points each) at once. Each is answered with the point-limit error, and the server's peak
/// memory stays far under 1 GB (it took 3.4 GB, and aborted when memory ran out).
#[cfg(target_os = "linux")]
#[test]
fn two_16_mb_hpgl_floods_at_once_are_refused_at_the_point_limit_within_the_memory_budget() {
    let served = Served::start(&["--listen", "127.0.0.1:0", "--max-upload-mb", "17"]);
    let request = |method: &str, path: &str, headers: &[(&str, &str)], body: &str| {
        parse(&send_to(&served.authority, method, path, headers, body).expect("an answer"))
    };
    let (status, v) = request("POST", "/api/control/claim", &[], "");
    assert_eq!(status, 200, "{v}");
    let token = v["token"].as_str().expect("a token").to_string();
    let flood = format!("IN;SP1;PA100,100;{}", "PDPU".repeat(4_150_000));
    assert!(flood.len() > 16_500_000);
    let t0 = Instant::now();
    let answers: Vec<(u16, Value)> = std::thread::scope(|s| {
        let uploads: Vec<_> = (0..2)
            .map(|k| {
                let (request, token, flood) = (&request, &token, &flood);
                s.spawn(move || {
                    let path = format!("/api/drawing?name=flood{k}.hpgl");
                    request("POST", &path, &[("X-Plotter-Token", token)], flood)
                })
            })
            .collect();
        uploads.into_iter().map(|u| u.join().expect("upload thread")).collect()
    });
    let took = t0.elapsed();
    for (k, (status, v)) in answers.iter().enumerate() {
        let e = v["error"].as_str().unwrap_or_default();
        // The point-limit error names the file, the command and the limit; or, if the other upload held the
        // memory budget, a 503 saying so.
        let limit = status == &400
            && e.starts_with(&format!("flood{k}.hpgl: command "))
            && e.contains("more than 4194304 points in the drawing");
        let busy = status == &503 && e.starts_with("busy:") && e.contains("memory budget");
        assert!(limit || busy, "upload {k}: {status} {v}");
    }
    assert!(answers.iter().any(|(status, _)| *status == 400), "{answers:?}");
    let peak = peak_rss_kib(served.pid());
    assert!(peak < 1_000_000, "peak RSS {peak} KiB");
    assert!(took < Duration::from_secs(60), "answered after {took:?}");
    // The server goes on answering.
    assert_eq!(request("GET", "/api/state", &[], "").0, 200);
}
