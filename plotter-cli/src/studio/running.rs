//! A running studio: the queue in its folder, the machines with their workers (one thread each, see
//! [`super::worker`]), and what the operator and the API do to them — add, list, reorder, cancel, retry, confirm a
//! resume; pause, resume, stop and emergency-stop a machine, or all of them.
//!
//! The machines share nothing but the queue (held for the length of one transaction at a time): a machine whose
//! port fails, or that is slow, holds up no other. Every change bumps [`Studio::version`], which the server's event
//! stream watches.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::time::Duration;

use serde::Serialize;

use super::error::{Result, StudioError};
use super::job_args::{self, JobArgs};
use super::machines::MachineSpec;
use super::queue::{Attempt, Cancelled, JobSummary, NewJob, Place, Queue};
use super::state::JobState;
use super::status::{MachineStatus, Slot};

/// How a studio runs.
#[derive(Debug, Clone, Copy)]
pub struct StudioOptions {
    /// The pace of simulated machines (`sim`), × real time (infinity: as fast as the computer can).
    pub sim_speed: f64,
    /// The longest wait before a machine whose port failed is tried again.
    pub max_retry: Duration,
}

impl Default for StudioOptions {
    fn default() -> StudioOptions {
        StudioOptions { sim_speed: 1.0, max_retry: Duration::from_secs(10) }
    }
}

/// A job as the API lists it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct JobView {
    /// Its number.
    pub id: i64,
    /// Its drawing's name.
    pub drawing: String,
    /// The drawing's size, bytes.
    pub bytes: usize,
    /// The machine it is for (`null`: the first idle machine it fits).
    pub machine: Option<String>,
    /// The machine that has (or had) it.
    pub claimed_by: Option<String>,
    /// Where it is in its life.
    pub state: &'static str,
    /// Its place in the queue.
    pub position: i64,
    /// How many times a machine took it.
    pub attempts: u32,
    /// Its plot flags.
    pub args: Vec<String>,
    /// Added, ms since 1970.
    pub created_ms: i64,
    /// It goes on from its journal when its machine takes it.
    pub resume: bool,
    /// Its attempts, oldest first.
    pub history: Vec<AttemptView>,
}

/// One attempt at a job.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AttemptView {
    /// The machine.
    pub machine: String,
    /// Started, ms since 1970.
    pub started_ms: i64,
    /// Ended, ms since 1970.
    pub ended_ms: Option<i64>,
    /// Time spent plotting, seconds (pauses left out).
    pub plot_s: Option<f64>,
    /// How it ended.
    pub outcome: Option<String>,
}

impl From<Attempt> for AttemptView {
    fn from(a: Attempt) -> AttemptView {
        AttemptView {
            machine: a.machine,
            started_ms: a.started_ms,
            ended_ms: a.ended_ms,
            plot_s: a.plot_time.map(|t| t.as_secs_f64()),
            outcome: a.outcome,
        }
    }
}

/// The whole studio at one moment.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Snapshot {
    /// Bumped on every change.
    pub version: u64,
    /// The machines, in the order they were given.
    pub machines: Vec<MachineStatus>,
    /// Every job, in queue order.
    pub jobs: Vec<JobView>,
}

/// A running studio.
#[derive(Debug)]
pub struct Studio {
    dir: PathBuf,
    queue: Mutex<Queue>,
    slots: Vec<Arc<Slot>>,
    options: StudioOptions,
    version: AtomicU64,
    ending: AtomicBool,
    /// Bumped when a job is added or freed; idle workers wait on it.
    work: Mutex<u64>,
    work_signal: Condvar,
    /// The last snapshot's version and JSON text ([`Studio::snapshot_json`]).
    shared: Mutex<Option<(u64, Arc<str>)>>,
}

impl Studio {
    /// Opens the queue in `dir` (refused while another studio has it) and records the machines. The workers are
    /// not started ([`super::worker::start`] starts them).
    pub fn open(dir: &Path, machines: Vec<MachineSpec>, options: StudioOptions) -> Result<Arc<Studio>> {
        super::machines::check_unique(&machines)?;
        let mut queue = Queue::open_in(dir)?;
        for m in &machines {
            let firmware = format!("{:?}", m.firmware).to_ascii_lowercase();
            queue.add_machine(&m.name, &m.device, &firmware, m.profile_name.as_deref())?;
        }
        for dir in [dir.join("drawings"), dir.join("journals")] {
            std::fs::create_dir_all(&dir).map_err(|source| StudioError::Folder { path: dir.clone(), source })?;
        }
        Ok(Arc::new(Studio {
            dir: dir.to_path_buf(),
            queue: Mutex::new(queue),
            slots: machines.into_iter().map(|m| Arc::new(Slot::new(m))).collect(),
            options,
            version: AtomicU64::new(1),
            ending: AtomicBool::new(false),
            work: Mutex::new(0),
            work_signal: Condvar::new(),
            shared: Mutex::new(None),
        }))
    }

    /// The studio's folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// How it runs.
    pub fn options(&self) -> StudioOptions {
        self.options
    }

    /// The queue, for one operation.
    pub fn queue(&self) -> MutexGuard<'_, Queue> {
        self.queue.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// The machines.
    pub fn slots(&self) -> &[Arc<Slot>] {
        &self.slots
    }

    /// The machine named `name`.
    pub fn slot(&self, name: &str) -> Result<&Arc<Slot>> {
        self.slots.iter().find(|s| s.spec.name == name).ok_or_else(|| StudioError::NoMachine(name.to_string()))
    }

    /// The change counter: it grows with every change a page would show.
    pub fn version(&self) -> u64 {
        self.version.load(Ordering::SeqCst)
    }

    /// Something changed.
    pub fn touch(&self) {
        self.version.fetch_add(1, Ordering::SeqCst);
    }

    /// There may be work for an idle machine.
    pub fn wake_workers(&self) {
        *self.work.lock().unwrap_or_else(std::sync::PoisonError::into_inner) += 1;
        self.work_signal.notify_all();
        self.touch();
    }

    /// Wait until work may be there or `limit` passed.
    pub fn wait_for_work(&self, limit: Duration) {
        let seen = self.work.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        let start = *seen;
        let _ = self
            .work_signal
            .wait_timeout_while(seen, limit, |n| *n == start && !self.ending())
            .unwrap_or_else(std::sync::PoisonError::into_inner);
    }

    /// Is the studio ending?
    pub fn ending(&self) -> bool {
        self.ending.load(Ordering::SeqCst)
    }

    /// End the studio: every plot stops at once with the pen up (its job stays interrupted, to resume once the
    /// studio is back and the operator confirms) and the workers end.
    pub fn end(&self) {
        self.ending.store(true, Ordering::SeqCst);
        for s in &self.slots {
            s.wake();
        }
        self.work_signal.notify_all();
    }

    /// Whether any machine is still plotting or paused.
    pub fn busy(&self) -> bool {
        self.slots
            .iter()
            .any(|s| matches!(s.status().state, super::status::Activity::Plotting | super::status::Activity::Paused))
    }

    /// Adds a job (its flags checked as `plotter plot` checks them, its machine known) and returns its number.
    pub fn add(&self, job: &NewJob) -> Result<i64> {
        JobArgs::from_options(&job.options)?;
        if let Some(m) = &job.machine {
            self.slot(m)?;
        }
        let id = self.queue().add(job)?;
        self.wake_workers();
        Ok(id)
    }

    /// One job with its history.
    pub fn job(&self, id: i64) -> Result<JobView> {
        let q = self.queue();
        let s = q.get(id)?;
        let history = q.history(id)?;
        Ok(view(s, history))
    }

    /// Every job with its history, in queue order.
    pub fn jobs(&self) -> Result<Vec<JobView>> {
        let q = self.queue();
        let mut histories = q.histories()?;
        Ok(q.list()?
            .into_iter()
            .map(|s| {
                let h = histories.remove(&s.id).unwrap_or_default();
                view(s, h)
            })
            .collect())
    }

    /// The machines and the queue.
    pub fn snapshot(&self) -> Result<Snapshot> {
        let version = self.version();
        let machines = self.slots.iter().map(|s| s.status().clone()).collect();
        Ok(Snapshot { version, machines, jobs: self.jobs()? })
    }

    /// The latest [`Studio::snapshot`] as JSON text, made once per change however many pages watch: the first
    /// caller after a change reads the queue, the others (waiting meanwhile) share its text.
    pub fn snapshot_json(&self) -> Result<Arc<str>> {
        let mut shared = self.shared.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        let now = self.version();
        if let Some((version, text)) = shared.as_ref()
            && *version == now
        {
            return Ok(Arc::clone(text));
        }
        let snap = self.snapshot()?;
        // A snapshot is plain strings and numbers: it always serialises.
        let text: Arc<str> = serde_json::to_string(&snap).unwrap_or_default().into();
        *shared = Some((snap.version, Arc::clone(&text)));
        Ok(text)
    }

    /// Cancels a job: a waiting one at once; one on a machine is stopped there (at once, with the pen up) and
    /// ends cancelled.
    pub fn cancel(&self, id: i64) -> Result<Cancelled> {
        let (done, machine) = {
            let mut q = self.queue();
            let done = q.cancel(id)?;
            (done, q.get(id)?.claimed_by)
        };
        if done == Cancelled::StopRequested
            && let Some(m) = machine
            && let Ok(slot) = self.slot(&m)
        {
            slot.request(|r| r.estop = true);
        }
        self.wake_workers();
        Ok(done)
    }

    /// Moves a waiting job before or after another.
    pub fn move_job(&self, id: i64, place: Place) -> Result<()> {
        self.queue().move_job(id, place)?;
        self.touch();
        Ok(())
    }

    /// Puts a failed or cancelled job back in the queue.
    pub fn retry(&self, id: i64) -> Result<()> {
        self.queue().retry(id)?;
        self.wake_workers();
        Ok(())
    }

    /// The operator confirmed an interrupted job's paper is in place: it resumes from its journal.
    pub fn confirm_resume(&self, id: i64) -> Result<()> {
        self.queue().confirm_resume(id)?;
        self.wake_workers();
        Ok(())
    }

    /// Pause a machine's job at its next pen-up.
    pub fn pause(&self, machine: &str) -> Result<()> {
        self.slot(machine)?.request(|r| {
            r.pause = true;
            r.resume = false;
        });
        self.touch();
        Ok(())
    }

    /// Resume a machine's paused job.
    pub fn resume(&self, machine: &str) -> Result<()> {
        self.slot(machine)?.request(|r| {
            r.resume = true;
            r.pause = false;
        });
        self.touch();
        Ok(())
    }

    /// End a machine's job at its next pen-up (cancelled).
    pub fn stop(&self, machine: &str) -> Result<()> {
        self.slot(machine)?.request(|r| r.stop = true);
        self.touch();
        Ok(())
    }

    /// Stop a machine at once with the pen up (its job ends cancelled).
    pub fn estop(&self, machine: &str) -> Result<()> {
        self.slot(machine)?.request(|r| r.estop = true);
        self.touch();
        Ok(())
    }

    /// Emergency-stop every machine.
    pub fn stop_all(&self) {
        for s in &self.slots {
            s.request(|r| r.estop = true);
        }
        self.touch();
    }

    /// Whether `job` may go to the machine in `slot`: its flags read and its paper fits.
    pub fn fits(slot: &Slot, job: &JobSummary) -> bool {
        JobArgs::from_options(&job.options)
            .and_then(|a| a.paper())
            .is_ok_and(|paper| job_args::paper_fits(paper, &slot.spec.profile, slot.spec.paper))
    }
}

fn view(s: JobSummary, history: Vec<Attempt>) -> JobView {
    JobView {
        args: job_args::words(&s.options).unwrap_or_default(),
        id: s.id,
        drawing: s.drawing_name,
        bytes: s.drawing_bytes,
        machine: s.machine,
        claimed_by: s.claimed_by,
        state: s.state.as_str(),
        position: s.position,
        attempts: s.attempts,
        created_ms: s.created_ms,
        resume: s.resume,
        history: history.into_iter().map(AttemptView::from).collect(),
    }
}

/// Whether a job in `state` has ended (done, failed or cancelled).
pub fn ended(state: &str) -> bool {
    JobState::parse(state).is_some_and(JobState::is_final)
}
