//! What each machine of a running studio is doing, as the page and the API show it, and what the operator asked
//! of it (pause, resume, stop, emergency stop), read by its worker.

use std::sync::{Condvar, Mutex, MutexGuard};
use std::time::Duration;

use serde::Serialize;

use super::machines::MachineSpec;

/// What a machine is doing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Activity {
    /// Opening its port and greeting its firmware.
    Connecting,
    /// Its port could not be opened or was lost; its worker tries again after a while.
    Offline,
    /// Connected, with nothing to plot.
    Idle,
    /// Plotting a job.
    Plotting,
    /// Its job is paused (pen up), waiting for resume or stop.
    Paused,
    /// It holds an interrupted job that waits for the operator to confirm the paper is in place (or cancel it).
    Waiting,
    /// The studio is ending.
    Stopped,
}

/// A machine as the page shows it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MachineStatus {
    /// Its name.
    pub name: String,
    /// Its port.
    pub device: String,
    /// Its profile's name.
    pub profile: String,
    /// What it is doing.
    pub state: Activity,
    /// What is connected (firmware and port), once it is.
    pub connected: Option<String>,
    /// The last problem, in words (a port that failed, a job that failed).
    pub error: Option<String>,
    /// The job it holds.
    pub job: Option<i64>,
    /// That job's drawing.
    pub drawing: Option<String>,
    /// Per cent of the plan's blocks done.
    pub percent: f64,
    /// Time left from the plan, seconds.
    pub remaining_s: Option<f64>,
    /// Where the pen is, page mm.
    pub pen_mm: Option<[f64; 2]>,
    /// Whether the pen is down there.
    pub pen_down: Option<bool>,
    /// How the last job ended, in words.
    pub last: Option<String>,
    /// What the paused machine waits for the operator to do before it is resumed (a layer's pause, a refill,
    /// a pen change, fresh paper for the next copy).
    pub prompt: Option<String>,
    /// Which copy of a job of several it draws: "copy 2 of 3", "copy 4 (until stopped)".
    pub copy: Option<String>,
}

/// What the operator asked of a machine, taken by its worker.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Requests {
    /// Pause the job at the next pen-up.
    pub pause: bool,
    /// Go on after a pause.
    pub resume: bool,
    /// End the job at the next pen-up (it ends cancelled).
    pub stop: bool,
    /// Stop at once with the pen up (the job ends cancelled).
    pub estop: bool,
}

/// One machine of a running studio: its settings, its status and the operator's requests.
#[derive(Debug)]
pub struct Slot {
    /// The machine's settings.
    pub spec: MachineSpec,
    status: Mutex<MachineStatus>,
    requests: Mutex<Requests>,
    signal: Condvar,
}

impl Slot {
    /// A machine that is not connected yet.
    pub fn new(spec: MachineSpec) -> Slot {
        let status = MachineStatus {
            name: spec.name.clone(),
            device: spec.device.clone(),
            profile: spec.profile.name.clone(),
            state: Activity::Connecting,
            connected: None,
            error: None,
            job: None,
            drawing: None,
            percent: 0.0,
            remaining_s: None,
            pen_mm: None,
            pen_down: None,
            last: None,
            prompt: None,
            copy: None,
        };
        Slot { spec, status: Mutex::new(status), requests: Mutex::new(Requests::default()), signal: Condvar::new() }
    }

    /// Its status, to read or change.
    pub fn status(&self) -> MutexGuard<'_, MachineStatus> {
        self.status.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    fn requests(&self) -> MutexGuard<'_, Requests> {
        self.requests.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// Ask something of the machine (and wake its worker if it waits in a pause).
    pub fn request(&self, change: impl FnOnce(&mut Requests)) {
        change(&mut self.requests());
        self.signal.notify_all();
    }

    /// The requests as they stand.
    pub fn peek(&self) -> Requests {
        *self.requests()
    }

    /// Take a pause request: true once per request.
    pub fn take_pause(&self) -> bool {
        std::mem::take(&mut self.requests().pause)
    }

    /// Forget every request (a new job starts).
    pub fn clear(&self) {
        *self.requests() = Requests::default();
    }

    /// Wait until `done` says so (checked at least every `tick`); returns its answer.
    pub fn wait_for<R>(&self, tick: Duration, mut done: impl FnMut(&mut Requests) -> Option<R>) -> R {
        let mut r = self.requests();
        loop {
            if let Some(answer) = done(&mut r) {
                return answer;
            }
            r = self.signal.wait_timeout(r, tick).unwrap_or_else(std::sync::PoisonError::into_inner).0;
        }
    }

    /// Wake its worker (a wait in a pause re-checks).
    pub fn wake(&self) {
        self.signal.notify_all();
    }
}
