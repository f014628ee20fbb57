//! The event channel from the server to every open page, sent as server-sent events (`text/event-stream`).
//!
//! Every event is a named JSON message. The names and their data:
//! - `state`: the whole [`super::state::Snapshot`] — sent first on connect and after every change of the
//!   machine, the drawing or control;
//! - `progress`: a plot's [`ProgressEvent`];
//! - `log`: one console line `{ "dir": "in" | "out" | "info" | "error", "text": ... }`;
//! - `prompt`: a question the machine's job is waiting on, [`Prompt`] (a pause decision now; a pen change once
//!   the job asks for pen changes) — answered with `POST /api/prompt`;
//! - `done`: a plot ended `{ "ok": bool, "message": ..., "stepped": bool }` (`stepped`: an as-stepped drawing is
//!   at `GET /api/stepped`).
//!
//! Events go through a broadcast channel; a page that falls too far behind skips what it missed and gets a fresh
//! `state`.

use serde::Serialize;
use tokio::sync::broadcast;

/// How many events a slow page may fall behind before it skips.
const BACKLOG: usize = 1024;

/// One event: its name and its JSON data.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Event {
    /// The SSE event name.
    pub(crate) name: &'static str,
    /// The JSON data.
    pub(crate) data: String,
}

impl Event {
    /// An event named `name` carrying `data` as JSON.
    pub(crate) fn new(name: &'static str, data: &impl Serialize) -> Event {
        // Our event types always serialise (plain structs of numbers and strings).
        Event { name, data: serde_json::to_string(data).unwrap_or_else(|e| format!("{{\"error\":\"{e}\"}}")) }
    }
}

/// A plot's progress, as the page shows it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub(crate) struct ProgressEvent {
    /// Blocks executed by the machine.
    pub(crate) executed: usize,
    /// Blocks in the plan.
    pub(crate) total: usize,
    /// Pen-down mm drawn so far.
    pub(crate) draw_done_mm: f64,
    /// Pen-down mm in all.
    pub(crate) draw_total_mm: f64,
    /// Planned time left, seconds.
    pub(crate) eta_s: f64,
    /// Percent done by blocks executed, 0-100.
    pub(crate) percent: f64,
    /// Resends so far.
    pub(crate) resends: u64,
    /// Where the pen is, page mm (X, Y): the end of the last executed block.
    pub(crate) pen_mm: [f64; 2],
    /// Whether the pen is down there.
    pub(crate) pen_down: bool,
    /// The same place in machine mm from the home corner (as the machine's position is shown outside a plot).
    pub(crate) machine_mm: [f64; 2],
}

/// A question the running job waits on.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub(crate) struct Prompt {
    /// Answer with this id.
    pub(crate) id: u64,
    /// What kind of question: `pause` (resume or cancel), `pen_change` (continue, skip or stop).
    pub(crate) kind: &'static str,
    /// What to tell the user.
    pub(crate) message: String,
    /// The answers the job accepts.
    pub(crate) choices: Vec<&'static str>,
}

/// One console line.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub(crate) struct LogLine {
    /// `out` (sent to the machine), `in` (from the machine), `info`, `error`.
    pub(crate) dir: &'static str,
    /// The line.
    pub(crate) text: String,
}

/// The sending side, shared by the HTTP handlers and the machine worker.
#[derive(Clone)]
pub(crate) struct Hub {
    tx: broadcast::Sender<Event>,
}

impl Hub {
    /// A hub with no listeners yet.
    pub(crate) fn new() -> Hub {
        Hub { tx: broadcast::channel(BACKLOG).0 }
    }

    /// Send `event` to every open page (none listening is fine).
    pub(crate) fn send(&self, event: Event) {
        let _ = self.tx.send(event);
    }

    /// A console line.
    pub(crate) fn log(&self, dir: &'static str, text: impl Into<String>) {
        self.send(Event::new("log", &LogLine { dir, text: text.into() }));
    }

    /// Listen from now on.
    pub(crate) fn subscribe(&self) -> broadcast::Receiver<Event> {
        self.tx.subscribe()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn events_reach_every_listener_as_json() {
        let hub = Hub::new();
        let (mut a, mut b) = (hub.subscribe(), hub.subscribe());
        hub.log("in", "ok");
        let expected = Event { name: "log", data: r#"{"dir":"in","text":"ok"}"#.into() };
        assert_eq!(a.try_recv().unwrap(), expected);
        assert_eq!(b.try_recv().unwrap(), expected);
        assert!(a.try_recv().is_err());
    }
}
