//! The plot's webhook (`--webhook URL`): a JSON POST for each event a person away from the machine wants to know
//! of — the plot finished, failed, or waits for a pen change or a pause. Deliveries run on a thread of their own,
//! so a slow or absent receiver never holds the plot up: each has a short timeout and is tried three more times
//! (after 0.5, 1 and 2 s); a delivery that still fails is reported as a warning.
//!
//! The body: `{"machine": ..., "job": ..., "event": "finished" | "stopped" | "error" | "pen_change" | "pause",
//! "message": ..., "time": <seconds since 1970>, "elapsed_s": <seconds since the plot started>}`. `stopped`: the
//! plot ended before it finished because it was asked to — the user's stop, a signal, a studio shutting down — and
//! its journal keeps it to resume (the message says why and where); `error`: it failed.

use std::sync::mpsc::{Receiver, Sender, channel};
use std::thread::JoinHandle;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use serde::Serialize;

use super::progress::{JobProgress, PenChangeChoice, PenChangeMode, PenChangeRequest, PlotEvents};
use super::stops::PauseRequest;
use crate::link::stream::PauseChoice;

/// How long one delivery may take.
pub const TIMEOUT: Duration = Duration::from_secs(5);
/// The waits before the retries of a failed delivery.
pub const RETRY_AFTER: [Duration; 3] = [Duration::from_millis(500), Duration::from_secs(1), Duration::from_secs(2)];

/// One event as posted.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct HookEvent {
    /// The machine's name.
    pub machine: String,
    /// The job (the drawing's name, or the queue's job).
    pub job: String,
    /// `finished`, `stopped`, `error`, `pen_change` or `pause`.
    pub event: String,
    /// What happened, for a person.
    pub message: String,
    /// When, seconds since 1970-01-01 UTC.
    pub time: f64,
    /// Seconds since the plot started.
    pub elapsed_s: f64,
}

/// A webhook: events go to a delivery thread.
pub struct Webhook {
    machine: String,
    job: String,
    started: Instant,
    tx: Option<Sender<HookEvent>>,
    thread: Option<JoinHandle<Vec<String>>>,
}

/// Post `body` to `url`, retrying; the error of the last attempt when all failed.
fn deliver(agent: &ureq::Agent, url: &str, body: &str) -> Result<(), String> {
    let mut last = String::new();
    for wait in std::iter::once(Duration::ZERO).chain(RETRY_AFTER) {
        std::thread::sleep(wait);
        match agent.post(url).header("Content-Type", "application/json").send(body) {
            Ok(_) => return Ok(()),
            Err(e) => last = e.to_string(),
        }
    }
    Err(last)
}

fn worker(url: String, rx: Receiver<HookEvent>) -> Vec<String> {
    let config = ureq::Agent::config_builder().timeout_global(Some(TIMEOUT)).http_status_as_error(true).build();
    let agent: ureq::Agent = config.into();
    let mut failures = Vec::new();
    for event in rx {
        let body = serde_json::to_string(&event).unwrap_or_default();
        if let Err(e) = deliver(&agent, &url, &body) {
            let text = format!("webhook {url}: the '{}' event was not delivered after 4 tries: {e}", event.event);
            eprintln!("warning: {text}");
            failures.push(text);
        }
    }
    failures
}

/// Whether `url` is an address the webhook can post to (plain `http://`); the error names the flag and the problem.
pub fn check_url(url: &str) -> anyhow::Result<()> {
    if !url.starts_with("http://") {
        anyhow::bail!("--webhook {url}: give an http:// address (https is not supported)");
    }
    url.parse::<ureq::http::Uri>().map_err(|e| anyhow::anyhow!("--webhook {url}: not an address: {e}"))?;
    Ok(())
}

impl Webhook {
    /// A webhook posting to `url` (plain `http://`) for `job` on `machine`.
    pub fn new(url: &str, machine: &str, job: &str) -> anyhow::Result<Webhook> {
        check_url(url)?;
        let (tx, rx) = channel();
        let owned = url.to_string();
        let thread = std::thread::Builder::new().name("webhook".into()).spawn(move || worker(owned, rx))?;
        Ok(Webhook {
            machine: machine.to_string(),
            job: job.to_string(),
            started: Instant::now(),
            tx: Some(tx),
            thread: Some(thread),
        })
    }

    /// Queue `event` with `message` for delivery (returns at once).
    pub fn send(&self, event: &str, message: &str) {
        let time = SystemTime::now().duration_since(UNIX_EPOCH).map_or(0.0, |d| d.as_secs_f64());
        let e = HookEvent {
            machine: self.machine.clone(),
            job: self.job.clone(),
            event: event.to_string(),
            message: message.to_string(),
            time,
            elapsed_s: self.started.elapsed().as_secs_f64(),
        };
        if let Some(tx) = &self.tx {
            let _ = tx.send(e);
        }
    }

    /// Wait until every queued event is delivered or given up on; returns the failures (already warned about).
    pub fn finish(mut self) -> Vec<String> {
        self.tx.take();
        self.thread.take().and_then(|t| t.join().ok()).unwrap_or_default()
    }
}

/// How a plot's error reaches its webhook: a stop (see [`crate::Trouble::Stopped`]: the user's, a signal's, a
/// studio shutting down) is the event `stopped` — nothing went wrong, and the plot can be resumed — anything else
/// `error`.
pub trait PlotEnd: std::fmt::Display {
    /// Whether the plot was stopped rather than failed.
    fn stopped(&self) -> bool;
}

impl PlotEnd for anyhow::Error {
    fn stopped(&self) -> bool {
        crate::Trouble::of(self) == crate::Trouble::Stopped
    }
}

impl PlotEnd for crate::Error {
    fn stopped(&self) -> bool {
        self.trouble() == crate::Trouble::Stopped
    }
}

/// Run `plot` (a plot, or a resume from its journal) with `events`, and with the webhook at `url`, when there is
/// one, told of its pen changes and pauses as they come and of its end: `finished` with `done`'s text, `stopped`
/// or `error` with the error's (see [`PlotEnd`]). The deliveries are waited for when `wait` (a command that ends
/// with the plot), and otherwise go on on their own thread (a studio machine goes on to its next job). The outer
/// error: the webhook could not be set up (the plot did not start); the inner result is the plot's.
pub fn hooked<T, E: PlotEnd>(
    url: Option<&str>,
    machine: &str,
    job: &str,
    wait: bool,
    events: &mut dyn PlotEvents,
    plot: impl FnOnce(&mut dyn PlotEvents) -> Result<T, E>,
    done: impl FnOnce(&T) -> String,
) -> anyhow::Result<Result<T, E>> {
    let Some(url) = url else { return Ok(plot(events)) };
    let hook = Webhook::new(url, machine, job)?;
    let result = plot(&mut HookedEvents { inner: events, hook: &hook });
    match &result {
        Ok(out) => hook.send("finished", &done(out)),
        Err(e) => hook.send(if e.stopped() { "stopped" } else { "error" }, &format!("{e:#}")),
    }
    if wait {
        hook.finish();
    }
    Ok(result)
}

/// A front end's events with the webhook told of pen changes and pauses.
pub struct HookedEvents<'a> {
    /// The front end.
    pub inner: &'a mut dyn PlotEvents,
    /// The webhook.
    pub hook: &'a Webhook,
}

impl PlotEvents for HookedEvents<'_> {
    fn progress(&mut self, p: &JobProgress) {
        self.inner.progress(p);
    }
    fn pause_requested(&mut self) -> Option<bool> {
        self.inner.pause_requested()
    }
    fn paused(&mut self, held: bool) -> PauseChoice {
        self.inner.paused(held)
    }
    fn pen_change_mode(&self) -> PenChangeMode {
        self.inner.pen_change_mode()
    }
    fn pen_change(&mut self, c: &PenChangeRequest) -> PenChangeChoice {
        let text =
            format!("pen change {}/{}: load pen {} for layer {:?}", c.number, c.total, c.pen.label(), c.layer_name);
        self.hook.send("pen_change", &text);
        self.inner.pen_change(c)
    }
    fn plot_pause(&mut self, p: &PauseRequest) -> PenChangeChoice {
        self.hook.send("pause", &p.ask());
        self.inner.plot_pause(p)
    }
    fn plot_started(&mut self, first_pen: &plotter_path::config::pens::LayerPen, pen_changes: usize) {
        self.inner.plot_started(first_pen, pen_changes);
    }
    fn unlock_alarm(&mut self, what: &str) -> bool {
        self.inner.unlock_alarm(what)
    }
    fn notice(&mut self, text: &str) {
        self.inner.notice(text);
    }
    fn stop_requested(&mut self) -> Option<crate::stop::StopCause> {
        self.inner.stop_requested()
    }
}

/// A local webhook receiver for tests.
#[cfg(test)]
pub(crate) mod receiver {
    use std::io::{BufRead as _, BufReader, Read as _, Write as _};
    use std::net::TcpListener;
    use std::sync::{Arc, Mutex};

    /// What a receiver saw: (the status it answered, the body) per request.
    pub(crate) type Seen = Arc<Mutex<Vec<(u16, String)>>>;

    /// A local receiver: answers the first `fail` requests with 500, the rest with 200, and keeps the bodies.
    pub(crate) fn receiver(fail: usize) -> (String, Seen) {
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let url = format!("http://{}/hook", listener.local_addr().unwrap());
        let seen = Arc::new(Mutex::new(Vec::new()));
        let log = Arc::clone(&seen);
        std::thread::spawn(move || {
            for (n, stream) in listener.incoming().enumerate() {
                let Ok(mut stream) = stream else { continue };
                let mut reader = BufReader::new(stream.try_clone().unwrap());
                let mut length = 0;
                loop {
                    let mut line = String::new();
                    if reader.read_line(&mut line).unwrap_or(0) == 0 || line == "\r\n" {
                        break;
                    }
                    if let Some(v) = line.to_ascii_lowercase().strip_prefix("content-length:") {
                        length = v.trim().parse().unwrap_or(0);
                    }
                }
                let mut body = vec![0; length];
                reader.read_exact(&mut body).unwrap();
                let status: u16 = if n < fail { 500 } else { 200 };
                log.lock().unwrap().push((status, String::from_utf8(body).unwrap()));
                let _ = write!(stream, "HTTP/1.1 {status} X\r\nContent-Length: 0\r\nConnection: close\r\n\r\n");
            }
        });
        (url, seen)
    }

    /// The events a receiver saw: (event, message) each, in order.
    pub(crate) fn events(seen: &Seen) -> Vec<(String, String)> {
        seen.lock()
            .unwrap()
            .iter()
            .map(|(_, body)| {
                let v: serde_json::Value = serde_json::from_str(body).unwrap();
                (v["event"].as_str().unwrap().to_string(), v["message"].as_str().unwrap().to_string())
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::receiver::receiver;
    use super::*;
    use std::net::TcpListener;

    #[test]
    fn an_event_is_posted_as_json() {
        let (url, seen) = receiver(0);
        let hook = Webhook::new(&url, "left", "bird.svg").unwrap();
        hook.send("finished", "done in 12 s");
        assert!(hook.finish().is_empty());
        let seen = seen.lock().unwrap();
        assert_eq!(seen.len(), 1);
        let v: serde_json::Value = serde_json::from_str(&seen[0].1).unwrap();
        assert_eq!((v["machine"].as_str(), v["job"].as_str()), (Some("left"), Some("bird.svg")));
        assert_eq!((v["event"].as_str(), v["message"].as_str()), (Some("finished"), Some("done in 12 s")));
        assert!(v["time"].as_f64().unwrap() > 1.7e9 && v["elapsed_s"].as_f64().unwrap() >= 0.0);
    }

    /// Two failures (500), then delivered on the third try; a receiver failing four times is warned about.
    #[test]
    fn a_failed_delivery_is_retried_then_given_up_with_a_warning() {
        let (url, seen) = receiver(2);
        let hook = Webhook::new(&url, "m", "j").unwrap();
        hook.send("error", "alarm 2");
        assert!(hook.finish().is_empty());
        let statuses: Vec<u16> = seen.lock().unwrap().iter().map(|s| s.0).collect();
        assert_eq!(statuses, [500, 500, 200]);
        let (url, seen) = receiver(10);
        let hook = Webhook::new(&url, "m", "j").unwrap();
        hook.send("pause", "refill");
        let failures = hook.finish();
        assert_eq!(seen.lock().unwrap().len(), 4, "one try and three retries");
        assert_eq!(failures.len(), 1);
        assert!(failures[0].contains("the 'pause' event was not delivered after 4 tries"), "{failures:?}");
    }

    /// A plot of two copies stopped during its first copy's line and resumed from its journal through [`hooked`]
    /// (as `plotter resume` runs it, the plot's --webhook read back from the journal) tells the webhook again: the
    /// paper change before copy 2 of 2, then the end with both copies.
    #[test]
    fn a_resumed_plot_tells_its_webhook_again() {
        use crate::job::copies::{CopiesOutcome, plot_copies, resume_copies};
        use crate::job::stops::StopOptions;
        use crate::link::session::Session;
        use crate::link::sim::SimTransport;
        use crate::options::workflow::Copies;
        use crate::stop::StopCause;
        use plotter_path::MachineProfile;
        use plotter_path::geometry::steps::drawing_to_steps;
        use plotter_path::kurbo::Point;
        use plotter_path::motion::plan;
        use plotter_path::{Drawing, Polyline};

        /// Stops once `stop_at` blocks are executed (when set); goes on at every pause.
        struct Events {
            stop_at: Option<usize>,
            executed: usize,
        }
        impl PlotEvents for Events {
            fn progress(&mut self, p: &JobProgress) {
                self.executed = p.executed;
            }
            fn plot_pause(&mut self, _: &PauseRequest) -> PenChangeChoice {
                PenChangeChoice::Continue
            }
            fn stop_requested(&mut self) -> Option<StopCause> {
                self.stop_at.filter(|at| self.executed >= *at).map(|_| StopCause::Requested)
            }
        }
        let profile = MachineProfile::default_plotter();
        let line = Polyline::new(vec![Point::new(20.0, 40.0), Point::new(50.0, 40.0)]);
        let steps = drawing_to_steps(&profile, &Drawing::single_layer("l", vec![line])).unwrap();
        let dir = std::env::temp_dir().join(format!("plotter-hook-resume-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let jp = dir.join("line.journal");
        let source =
            |start: [i32; 4]| -> anyhow::Result<String> { Ok(serde_json::json!({ "start": start }).to_string()) };
        let spec = crate::job::JournalSpec { path: &jp, source: &source };
        let copies = Copies { count: 2, page_delay_s: 0.0, paper_pause: true };
        let none = StopOptions::default();
        let cfg = plan::machine_config(&profile).unwrap();
        let mut s = Session::connect(SimTransport::new(cfg, None), "sim").unwrap();
        // Blocks: travel, pen down, settle, the line (3): stopped while it is drawn.
        let mut first = Events { stop_at: Some(3), executed: 0 };
        assert!(plot_copies(&mut s, &profile, &steps, true, false, Some(spec), &none, &copies, &mut first).is_err());
        let state = crate::link::journal::load(&jp).unwrap();
        let v: serde_json::Value = serde_json::from_str(&state.source).unwrap();
        let start: [i32; 4] = serde_json::from_value(v["start"].clone()).unwrap();
        let resume = |events: &mut dyn PlotEvents, s: &mut Session<SimTransport>| {
            resume_copies(s, &profile, &steps, start, &state, &jp, false, false, &none, &copies, events)
        };
        let (url, seen) = receiver(0);
        let mut go_on = Events { stop_at: None, executed: 0 };
        let out = hooked(Some(&url), "m", "line.svg", true, &mut go_on, |e| resume(e, &mut s), CopiesOutcome::summary)
            .unwrap()
            .unwrap();
        assert_eq!(out.copies.len(), 2, "the copy under way and the one left");
        let planned: f64 = out.copies.iter().map(|c| c.plan.seconds()).sum();
        let seen = super::receiver::events(&seen);
        let expected = [
            ("pause".to_string(), "put in fresh paper for copy 2 of 2".to_string()),
            ("finished".to_string(), format!("2 copies plotted, {planned:.1} s planned")),
        ];
        assert_eq!(seen, expected);
        std::fs::remove_dir_all(&dir).ok();
    }

    /// The plot does not wait for the webhook: a receiver that takes every connection and never answers, and a
    /// plot with a pen change told to it, executes exactly the ticks of the same plot without a webhook, and
    /// sending takes no time.
    #[test]
    fn a_stalled_receiver_does_not_touch_the_plot() {
        use crate::link::machine::PlotMachine as _;
        use crate::link::session::Session;
        use crate::link::sim::SimTransport;
        use plotter_path::MachineProfile;
        use plotter_path::geometry::steps::drawing_to_steps;
        use plotter_path::kurbo::Point;
        use plotter_path::motion::plan;
        use plotter_path::{Drawing, Layer, Polyline, Rgb};

        struct Pens;
        impl PlotEvents for Pens {
            fn progress(&mut self, _: &JobProgress) {}
            fn pen_change_mode(&self) -> PenChangeMode {
                PenChangeMode::Pause
            }
        }
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let url = format!("http://{}/hook", listener.local_addr().unwrap());
        std::thread::spawn(move || {
            let mut held = Vec::new();
            for s in listener.incoming() {
                held.push(s);
            }
        });
        let profile = MachineProfile::default_plotter();
        let mut d = Drawing::default();
        for (i, color) in [Rgb::BLACK, Rgb(255, 0, 0)].into_iter().enumerate() {
            let mut l = Layer::new(format!("l{i}"));
            l.pen.color = color;
            let y = 20.0 + 10.0 * f64::from(u8::try_from(i).unwrap());
            l.paths = vec![Polyline::new(vec![Point::new(20.0, y), Point::new(60.0, y)])];
            d.layers.push(l);
        }
        let steps = drawing_to_steps(&profile, &d).unwrap();
        let executed = |hook: Option<&Webhook>| {
            let cfg = plan::machine_config(&profile).unwrap();
            let mut s = Session::connect(SimTransport::new(cfg, None), "sim").unwrap();
            let mut pens = Pens;
            let out = match hook {
                Some(hook) => {
                    let mut events = HookedEvents { inner: &mut pens, hook };
                    let t = Instant::now();
                    let out = crate::job::plot(&mut s, &profile, &steps, true, false, None, &mut events).unwrap();
                    assert!(t.elapsed() < TIMEOUT, "the plot waited for the webhook");
                    out
                }
                None => crate::job::plot(&mut s, &profile, &steps, true, false, None, &mut pens).unwrap(),
            };
            assert_eq!(out.pen_stops, 1);
            s.busy_ticks() - out.busy_before
        };
        let plain = executed(None);
        let hook = Webhook::new(&url, "m", "j").unwrap();
        assert_eq!(executed(Some(&hook)), plain);
        // Not waited for: the delivery thread is left to time out on its own.
        drop(hook);
    }
}
