//! The plot job, shared by every front end (the `plotter` command, the web app): inputs → drawing → layout →
//! optimize → steps ([`load`]), then home, plan from the machine's reported position, stream with pauses, keep
//! the journal, and report progress ([`progress`]); resume an interrupted plot from its journal; rebuild what a
//! simulated machine drew ([`stepped`]).
//!
//! A front end supplies a [`progress::PlotEvents`] (progress display, pause requests and decisions) and gets a
//! [`JobOutcome`] or an error that says how to continue.

pub mod load;
pub mod page;
pub mod prepare;
pub mod progress;
pub mod stepped;

use std::path::Path;

use plotter_path::MachineProfile;
use plotter_path::motion::plan::{self, Lookahead, MotionPlan};
use plotter_path::motion::steps::StepDrawing;

use crate::link::Transport;
use crate::link::journal::{Journal, JournalState};
use crate::link::session::Session;
use crate::link::sim::SimTransport;
use crate::link::stream::{self, StreamError, StreamOptions, StreamStats};
use progress::{PlotEvents, Tracker};

/// A finished plot.
#[derive(Debug)]
pub struct JobOutcome {
    /// The plan that was streamed.
    pub plan: MotionPlan,
    /// Link figures.
    pub stats: StreamStats,
    /// The in-process simulator's busy time before the plot started, ticks (0 on a serial port): the executed
    /// plot time is the simulator's busy time afterwards minus this.
    pub busy_before: u64,
}

/// Where the journal goes and what it records as the plot's source. The record is opaque to the job: the front
/// end stores what it needs to rebuild the same steps on resume, and the position the plan starts from (known
/// only once the machine has homed) is handed to it.
#[derive(Clone, Copy)]
pub struct JournalSpec<'a> {
    /// Journal file.
    pub path: &'a Path,
    /// Makes the source record (one line of text) from the plan's start position, steps.
    pub source: &'a dyn Fn([i32; 4]) -> anyhow::Result<String>,
}

/// Home (when `home`), plan `steps` from the position the machine reports, and stream the plan, reporting to
/// `events` and recording in the journal (if any).
pub fn plot<T: Transport + 'static>(
    session: &mut Session<T>,
    profile: &MachineProfile,
    steps: &StepDrawing,
    home: bool,
    journal: Option<JournalSpec<'_>>,
    events: &mut dyn PlotEvents,
) -> anyhow::Result<JobOutcome> {
    if home {
        session.home()?;
    }
    let start = session.status()?.steps;
    let plan = plan::plan(profile, steps, start, Lookahead::Whole)?;
    let journal_file = match journal {
        Some(j) => Some(Journal::create(j.path, &(j.source)(start)?, plan.geometry_hash(), plan.blocks.len())?),
        None => None,
    };
    let busy_before = busy_ticks(session);
    let stats = stream_with(session, &plan, profile, journal_file, journal.map(|j| j.path), events)?;
    Ok(JobOutcome { plan, stats, busy_before })
}

/// Resume the plot recorded in the journal at `journal_path` (already loaded as `state`, and checked by the caller
/// to describe `steps` planned from `start`): let the firmware finish what it still holds, find the first block
/// not certainly executed, home unless `trust_position`, and stream the rest. Prints the resume point.
#[allow(clippy::too_many_arguments)]
pub fn resume<T: Transport + 'static>(
    session: &mut Session<T>,
    profile: &MachineProfile,
    steps: &StepDrawing,
    start: [i32; 4],
    state: &JournalState,
    journal_path: &Path,
    trust_position: bool,
    events: &mut dyn PlotEvents,
) -> anyhow::Result<JobOutcome> {
    let full = plan::plan(profile, steps, start, Lookahead::Whole)?;
    // If the firmware is still running the session the host lost, let it finish what it accepted. Frames that
    // were in flight when the host died may have been accepted after the journal's last line: the firmware's
    // sequence number tells how many (one per block). If it then stands exactly where that many blocks end,
    // they were all executed; otherwise (restarted, moved) only the journal's executed count is certain.
    let status = session.wait_idle(std::time::Duration::from_millis(50))?;
    let extra = status.seq.wrapping_sub(state.seq_after_accepted);
    let accepted = usize::try_from(extra).ok().map(|x| state.accepted + x).filter(|&a| a <= full.blocks.len());
    let done = match accepted {
        Some(a) if a > 0 && status.steps == full.position_after(a - 1) => a,
        _ => state.executed,
    };
    eprintln!("resuming at block {done} of {} ({} certainly executed)", full.blocks.len(), state.executed);
    if !trust_position {
        session.home()?;
    }
    let now = session.status()?.steps;
    let plan = plan::plan_resume(profile, steps, start, done, now)?;
    let journal = Journal::append(journal_path, state)?;
    let busy_before = busy_ticks(session);
    let stats = stream_with(session, &plan, profile, Some(journal), Some(journal_path), events)?;
    Ok(JobOutcome { plan, stats, busy_before })
}

/// Stream `plan` with a tracker around `events`; mark the journal complete at the end.
fn stream_with<T: Transport + 'static>(
    session: &mut Session<T>,
    plan: &MotionPlan,
    profile: &MachineProfile,
    journal: Option<Journal>,
    journal_path: Option<&Path>,
    events: &mut dyn PlotEvents,
) -> anyhow::Result<StreamStats> {
    let mut tracker = Tracker::new(plan, profile, journal, events);
    let result = stream::stream_plan(session, plan, StreamOptions::default(), &mut tracker);
    if let Some(e) = tracker.error.take() {
        return Err(e);
    }
    let (_, stats) = result.map_err(|e| explain(e, journal_path))?;
    if let Some(j) = tracker.journal.as_mut() {
        j.complete()?;
    }
    Ok(stats)
}

/// The simulator's executed motion time so far, when the transport is the in-process simulator.
fn busy_ticks<T: Transport + 'static>(session: &Session<T>) -> u64 {
    (&session.transport as &dyn std::any::Any).downcast_ref::<SimTransport>().map_or(0, |s| s.sim().hal().busy_ticks())
}

/// A stream error, with how to continue when a journal was kept.
fn explain(e: StreamError, journal: Option<&Path>) -> anyhow::Error {
    let hint = match (&e, journal) {
        (StreamError::Refused { .. }, _) | (_, None) => String::new(),
        (_, Some(j)) => format!("\ncontinue with: plotter plot --resume {} --port <device>", j.display()),
    };
    anyhow::anyhow!("{e}{hint}")
}
