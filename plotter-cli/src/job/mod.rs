//! The plot job, shared by every front end (the `plotter` command, the web app): inputs → drawing → layout →
//! optimize → steps ([`load`]), then home, plan from the machine's reported position, stream with pauses, keep
//! the journal, and report progress ([`progress`]); resume an interrupted plot from its journal; rebuild what a
//! simulated machine drew ([`stepped`]).
//!
//! A front end supplies a [`progress::PlotEvents`] (progress display, pause requests and decisions) and gets a
//! [`JobOutcome`] or an error that says how to continue.

pub mod copies;
pub mod hpgl;
pub mod load;
pub mod page;
#[cfg(test)]
mod power_cycle_tests;
pub mod prepare;
pub mod progress;
pub mod stepped;
pub mod stops;
pub mod webhook;

use std::borrow::Cow;
use std::path::Path;

use plotter_path::MachineProfile;
use plotter_path::geometry::steps::StepDrawing;
use plotter_path::motion::plan::{self, Lookahead, MachinePos, MotionPlan, MoveKind, PenChange};

use crate::Error;
use crate::link::journal::{Journal, JournalState};
use crate::link::machine::PlotMachine;
use crate::link::stream::{Quiet, StreamError, StreamStats};
use progress::{PenChangeChoice, PenChangeMode, PenChangeRequest, PlotEvents, Tracker};
use stops::{PauseRequest, PauseWhy, PlotStop, StopWhy};

/// A finished plot.
#[derive(Debug)]
pub struct JobOutcome {
    /// The plan that was streamed (the whole plot, or what a resume had left).
    pub plan: MotionPlan,
    /// Link figures (summed over the parts between pen changes).
    pub stats: StreamStats,
    /// The in-process simulator's busy time before the plot started, ticks (0 on a serial port): the executed
    /// plot time is the simulator's busy time afterwards minus this.
    pub busy_before: u64,
    /// Pen changes the plot stopped for.
    pub pen_stops: usize,
    /// Layers skipped at a pen change (by their names).
    pub skipped: Vec<String>,
    /// A resume found the drawing already finished (all that was left was the way home with the pen up): it
    /// marked the journal complete and moved nothing.
    pub drawn_before: bool,
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

/// Settle an alarm before a plot: homing clears it when the plot homes on a machine that can; otherwise the
/// user decides whether to unlock.
fn settle_alarm<M: PlotMachine + ?Sized>(
    machine: &mut M,
    home: bool,
    events: &mut dyn PlotEvents,
) -> anyhow::Result<()> {
    if let Some(what) = machine.alarm_pending()? {
        if home && machine.can_home() {
            return Ok(());
        }
        if !events.unlock_alarm(&what) {
            anyhow::bail!("{what}; not unlocked (home the machine, or unlock it once it is safe)");
        }
        machine.unlock()?;
    }
    Ok(())
}

/// Home before a plot. When the profile names a spot off the paper for homing Z (`[homing] z_home_xy_mm`), a Z
/// the firmware does not know (switched on since it was homed) is homed there, as a resume does (see
/// [`crate::link::home_axes`]): a machine just switched on may stand over the fresh sheet, and on one whose pen
/// touches before its Z switch a plain cycle would press a dot into it. Without a spot, the plain cycle.
pub(crate) fn home_for_plot<M: PlotMachine + ?Sized>(
    machine: &mut M,
    profile: &MachineProfile,
    events: &mut dyn PlotEvents,
) -> anyhow::Result<()> {
    if profile.homing.z_home_xy_mm.is_none() {
        return machine.home();
    }
    home_over_drawing(machine, profile, events)
}

/// Home where the carriage may stand over a drawing ([`PlotMachine::home_over_drawing`]), telling the user
/// what was done beyond a plain homing.
fn home_over_drawing<M: PlotMachine + ?Sized>(
    machine: &mut M,
    profile: &MachineProfile,
    events: &mut dyn PlotEvents,
) -> anyhow::Result<()> {
    if let Some(done) = machine.home_over_drawing(profile)? {
        eprintln!("{done}");
        events.notice(&done);
    }
    Ok(())
}

/// Home (when `home`), plan `steps` from the position the machine reports (and back there at the end when
/// `return_home`), and stream the plan, reporting to `events`, stopping for pen changes when the front end asks
/// for them, and recording in the journal (if any). The layers' names may ask for pauses and delays (see
/// [`stops`]); [`plot_with`] adds refills.
#[allow(clippy::too_many_arguments)]
pub fn plot<M: PlotMachine + ?Sized>(
    machine: &mut M,
    profile: &MachineProfile,
    steps: &StepDrawing,
    home: bool,
    return_home: bool,
    journal: Option<JournalSpec<'_>>,
    events: &mut dyn PlotEvents,
) -> crate::Result<JobOutcome> {
    plot_with(machine, profile, steps, home, return_home, journal, &stops::StopOptions::default(), events)
}

/// [`plot`], stopping also where `options` say (refills after `--split-distance`).
#[allow(clippy::too_many_arguments)]
pub fn plot_with<M: PlotMachine + ?Sized>(
    machine: &mut M,
    profile: &MachineProfile,
    steps: &StepDrawing,
    home: bool,
    return_home: bool,
    journal: Option<JournalSpec<'_>>,
    options: &stops::StopOptions,
    events: &mut dyn PlotEvents,
) -> crate::Result<JobOutcome> {
    // Planned for the firmware it runs on: whether a servo pen's drop may be commanded while the carriage moves.
    let profile = &*crate::link::machine::profile_for(profile, machine.firmware());
    settle_alarm(machine, home, events)?;
    // Our firmware: framed mode for everything the plot acts on (verified replies, real-time commands noise
    // cannot forge).
    machine.begin()?;
    if home {
        home_for_plot(machine, profile, events)?;
    }
    let start = position_within_travel(machine, profile)?;
    let plan = plan::plan_returning(profile, steps, start, Lookahead::Whole, return_home)?;
    let journal_file = match journal {
        Some(j) => Some(Journal::create(j.path, &(j.source)(start)?, plan.geometry_hash(), plan.blocks.len())?),
        None => None,
    };
    events.plot_started(&plan.first_pen, plan.pen_changes.len());
    let busy_before = machine.busy_ticks();
    let stops = stops::plot_stops(profile, steps, &plan, options.split_mm);
    let run = Run { profile, steps, start, full: &plan, journal_path: journal.map(|j| j.path), return_home, stops };
    let streamed = run.stream(machine, &plan, journal_file, None, events)?;
    Ok(streamed.outcome(plan, busy_before))
}

/// Resume the plot recorded in the journal at `journal_path` (already loaded as `state`, and checked by the caller
/// to describe `steps` planned from `start`): let the firmware finish what it still holds, find the first block
/// not certainly executed, home unless `trust_position`, and stream the rest (asking for the pen of the layer it
/// continues with, when the drawing has several). Prints the resume point. [`resume_with`] also keeps the
/// refills the plot was started with.
#[allow(clippy::too_many_arguments)]
pub fn resume<M: PlotMachine + ?Sized>(
    machine: &mut M,
    profile: &MachineProfile,
    steps: &StepDrawing,
    start: [i32; 4],
    state: &JournalState,
    journal_path: &Path,
    trust_position: bool,
    return_home: bool,
    events: &mut dyn PlotEvents,
) -> crate::Result<JobOutcome> {
    let none = stops::StopOptions::default();
    resume_with(machine, profile, steps, start, state, journal_path, trust_position, return_home, &none, events)
}

/// Whether nothing is left to draw from block `done` of `full` on: what remains (if anything) is only the way
/// home with the pen up.
pub fn drawn_from(full: &MotionPlan, done: usize) -> bool {
    full.blocks.iter().skip(done).all(|b| matches!(b.kind, MoveKind::Travel | MoveKind::Settle))
}

/// [`resume`], stopping also where `options` say (the refills after `--split-distance` the plot was started
/// with, at the same places as in the plot). A journal whose drawing was finished (only the way home left, the
/// plot killed before it recorded its end) is marked complete without moving anything.
#[allow(clippy::too_many_arguments)]
pub fn resume_with<M: PlotMachine + ?Sized>(
    machine: &mut M,
    profile: &MachineProfile,
    steps: &StepDrawing,
    start: [i32; 4],
    state: &JournalState,
    journal_path: &Path,
    trust_position: bool,
    return_home: bool,
    options: &stops::StopOptions,
    events: &mut dyn PlotEvents,
) -> crate::Result<JobOutcome> {
    // Planned for the firmware it runs on, as the plot was (see `plot_with`).
    let profile = &*crate::link::machine::profile_for(profile, machine.firmware());
    let full = plan::plan_returning(profile, steps, start, Lookahead::Whole, return_home)?;
    machine.begin()?;
    let done = machine.resume_point(state, &full)?;
    if drawn_from(&full, done) {
        eprintln!(
            "the drawing was finished ({done} of {} blocks executed, the rest the way home): nothing to resume",
            full.blocks.len()
        );
        Journal::append(journal_path, state)?.complete()?;
        machine.end()?;
        let mut plan = truncated(&full, 0);
        plan.resumed_from = done;
        let streamed = Streamed { stats: StreamStats::default(), pen_stops: 0, skipped: Vec::new() };
        let mut out = streamed.outcome(plan, machine.busy_ticks());
        out.drawn_before = true;
        return Ok(out);
    }
    eprintln!("resuming at block {done} of {} ({} certainly executed)", full.blocks.len(), state.executed);
    settle_alarm(machine, !trust_position, events)?;
    if !trust_position {
        // The carriage may stand over the drawing with the pen's height unknown (a power cycle mid-plot): homing
        // never lowers the pen there (see `crate::link::home_axes`).
        home_over_drawing(machine, profile, events)?;
    }
    let journal = Journal::append(journal_path, state)?;
    let busy_before = machine.busy_ticks();
    let stops = stops::plot_stops(profile, steps, &full, options.split_mm);
    let run = Run { profile, steps, start, full: &full, journal_path: Some(journal_path), return_home, stops };
    // The pen of the layer the plot continues with.
    let layer_pen = full.pen_changes.iter().rev().find(|c| c.block <= done);
    let first = PenChange {
        block: done,
        layer: layer_pen.map_or(0, |c| c.layer),
        layer_name: layer_pen
            .map_or_else(|| steps.layers.first().map(|l| l.name.clone()).unwrap_or_default(), |c| c.layer_name.clone()),
        pen: layer_pen.map_or_else(|| full.first_pen.clone(), |c| c.pen.clone()),
        previous: full.first_pen.clone(),
    };
    let ask_first = (!full.pen_changes.is_empty()).then_some(first);
    let now = position_within_travel(machine, profile)?;
    let plan = plan::plan_resume(profile, steps, start, done, now, return_home)?;
    let streamed = run.stream(machine, &plan, Some(journal), ask_first, events)?;
    Ok(streamed.outcome(plan, busy_before))
}

/// What streaming a plan did: the link's figures and the pen changes it stopped for or skipped.
struct Streamed {
    stats: StreamStats,
    pen_stops: usize,
    skipped: Vec<String>,
}

impl Streamed {
    /// The job's outcome for `plan` (the plan streamed), with the simulator's busy time before it.
    fn outcome(self, plan: MotionPlan, busy_before: u64) -> JobOutcome {
        JobOutcome {
            plan,
            stats: self.stats,
            busy_before,
            pen_stops: self.pen_stops,
            skipped: self.skipped,
            drawn_before: false,
        }
    }
}

pub use crate::link::machine::{POSITION_MARGIN_MM, position_within_travel};

/// A plot being streamed, part by part between pen changes.
struct Run<'a> {
    profile: &'a MachineProfile,
    steps: &'a StepDrawing,
    /// Where the original plan started.
    start: MachinePos,
    /// The original plan.
    full: &'a MotionPlan,
    journal_path: Option<&'a Path>,
    /// The plan ends with the travel back to `start`.
    return_home: bool,
    /// Where the plot stops besides pen changes, in block order.
    stops: Vec<PlotStop>,
}

fn add(total: &mut StreamStats, s: &StreamStats) {
    total.frames += s.frames;
    total.frame_bytes += s.frame_bytes;
    total.bytes_sent += s.bytes_sent;
    total.resends += s.resends;
    total.resyncs += s.resyncs;
    total.noise_errors += s.noise_errors;
    total.damaged_replies += s.damaged_replies;
    total.elapsed += s.elapsed;
    total.accept_elapsed += s.accept_elapsed;
    total.underruns = match (total.underruns, s.underruns) {
        (Some(a), Some(b)) => Some(a + b),
        (a, b) => a.or(b),
    };
}

impl Run<'_> {
    /// Stream `plan` (the whole plot or a resume), stopping at each pen change when the front end wants it;
    /// `ask_first` is a pen change to ask for before anything moves (a resumed multi-pen plot). The plan is only
    /// borrowed, and its parts too unless they must be cut at a pen change: a plan at the point limit takes a
    /// quarter of a gigabyte, so no copy of it is made.
    fn stream<M: PlotMachine + ?Sized>(
        &self,
        machine: &mut M,
        plan: &MotionPlan,
        mut journal: Option<Journal>,
        ask_first: Option<PenChange>,
        events: &mut dyn PlotEvents,
    ) -> crate::Result<Streamed> {
        let pause = events.pen_change_mode() == PenChangeMode::Pause;
        let total_changes = plan.pen_changes.len();
        let mut stats = StreamStats::default();
        let mut current = Cow::Borrowed(plan);
        let (mut pen_stops, mut skipped) = (0, Vec::new());
        let mut pending = if pause { ask_first.map(|c| (c, true)) } else { None };
        // The block the plot stands before when it is one where the plot stops (a pen change, or a stop of
        // `self.stops`); a fresh plan may stop before its very first block.
        let mut cut = match &pending {
            Some((c, _)) => Some(c.block),
            None => self.stops.first().filter(|s| s.block == 0 && plan.preamble == 0).map(|s| s.block),
        };
        loop {
            if let Some(at) = cut.take() {
                // The pen change here (if any), then the stops of `self.stops` here.
                let mut from = None;
                let (mut parked, mut changed) = (false, false);
                // The rest of the plan after a pen lowered in full for a delay (`StopWhy::DropThenDelay`).
                let mut dropped = None;
                if let Some((change, resumed)) = pending.take() {
                    pen_stops += 1;
                    changed = true;
                    let number = plan.pen_changes.iter().position(|c| c.block == change.block).map_or(0, |i| i + 1);
                    let park = if resumed { None } else { Some(self.park(machine)?) };
                    parked = park.is_some();
                    let req = PenChangeRequest {
                        layer: change.layer,
                        layer_name: change.layer_name.clone(),
                        pen: change.pen.clone(),
                        previous: (!resumed).then(|| change.previous.clone()),
                        number,
                        total: total_changes,
                        park_mm: park.unwrap_or((f64::NAN, f64::NAN)),
                    };
                    match events.pen_change(&req) {
                        PenChangeChoice::Continue => from = Some(change.block),
                        PenChangeChoice::SkipLayer => {
                            skipped.push(change.layer_name.clone());
                            match plan.pen_changes.iter().find(|c| c.block > change.block) {
                                Some(next) => {
                                    pending = Some((next.clone(), false));
                                    cut = Some(next.block);
                                    continue;
                                }
                                None => break,
                            }
                        }
                        PenChangeChoice::Stop => {
                            return Err(Error::StoppedAtPenChange {
                                layer: change.layer_name.clone(),
                                pen: change.pen.label(),
                                after: self.resume_hint(),
                            });
                        }
                    }
                }
                for stop in self.stops.iter().filter(|s| s.block == at) {
                    from.get_or_insert(at);
                    match &stop.why {
                        StopWhy::Delay { ms } => dwell(machine, self.profile, *ms, &plan.first_pen)?,
                        StopWhy::DropThenDelay { ms, draw } => {
                            // Travel to the stroke's start with the pen up and lower it there in full (the
                            // resume's preamble: it ends at rest once the drop has settled), wait, then draw
                            // from rest.
                            let now = position_within_travel(machine, self.profile)?;
                            let p =
                                plan::plan_resume(self.profile, self.steps, self.start, *draw, now, self.return_home)?;
                            let s = self.stream_part(machine, &truncated(&p, p.preamble), &mut journal, events)?;
                            add(&mut stats, &s);
                            dwell(machine, self.profile, *ms, &plan.first_pen)?;
                            from = Some(*draw);
                            dropped = tail(&p, *draw);
                        }
                        // A pen change here has already stopped the plot.
                        StopWhy::Pause | StopWhy::Refill { .. } if changed => {}
                        why @ (StopWhy::Pause | StopWhy::Refill { .. }) => {
                            let park_mm = self.park(machine)?;
                            parked = true;
                            let pens = plan::layer_pens(self.profile, self.steps);
                            let req = PauseRequest {
                                why: match why {
                                    StopWhy::Refill { part } => PauseWhy::Refill { part: *part },
                                    _ => PauseWhy::Layer,
                                },
                                layer_name: stop.layer_name.clone(),
                                pen: pens.get(stop.layer).cloned().unwrap_or_else(|| plan.first_pen.clone()),
                                park_mm,
                            };
                            if events.plot_pause(&req) == PenChangeChoice::Stop {
                                return Err(Error::StoppedAtPause { asked: req.ask(), after: self.resume_hint() });
                            }
                        }
                    }
                }
                let Some(mut from) = from else { break };
                if from >= self.full.blocks.len() {
                    break;
                }
                if let Some(rest) = dropped {
                    current = Cow::Owned(rest);
                } else {
                    if changed && parked && self.full.blocks[from].kind == MoveKind::Travel {
                        // The carriage is parked: travel from there straight to the layer's first stroke.
                        from += 1;
                    }
                    current = match (parked, tail(&current, from)) {
                        // Only waited: the plan goes on where it stood, from rest.
                        (false, Some(rest)) => Cow::Owned(rest),
                        _ => {
                            let now = position_within_travel(machine, self.profile)?;
                            let p =
                                plan::plan_resume(self.profile, self.steps, self.start, from, now, self.return_home)?;
                            Cow::Owned(p)
                        }
                    };
                }
            }
            // Stream up to the next stop (or to the end).
            let done = current.resumed_from;
            let change = if pause { current.pen_changes.iter().find(|c| c.block > done).cloned() } else { None };
            let next =
                self.stops.iter().map(|s| s.block).filter(|b| *b > done).chain(change.as_ref().map(|c| c.block)).min();
            let part = match next {
                Some(b) => Cow::Owned(truncated(&current, b - current.resumed_from + current.preamble)),
                None => Cow::Borrowed(&*current),
            };
            let s = self.stream_part(machine, &part, &mut journal, events)?;
            add(&mut stats, &s);
            match next {
                Some(b) => {
                    pending = change.filter(|c| c.block == b).map(|c| (c, false));
                    cut = Some(b);
                }
                None => break,
            }
        }
        if let Some(j) = journal.as_mut() {
            j.complete()?;
        }
        machine.end()?;
        Ok(Streamed { stats, pen_stops, skipped })
    }

    /// How to continue a plot stopped on purpose: the resume command when a journal is kept.
    fn resume_hint(&self) -> String {
        self.journal_path
            .map(|j| format!("\ncontinue with: plotter plot --resume {} --port <device>", j.display()))
            .unwrap_or_default()
    }

    /// Stream `part`, reporting progress within the whole plot and keeping the journal; on any error, stop with
    /// the pen up (the journal stays for a resume).
    fn stream_part<M: PlotMachine + ?Sized>(
        &self,
        machine: &mut M,
        part: &MotionPlan,
        journal: &mut Option<Journal>,
        events: &mut dyn PlotEvents,
    ) -> crate::Result<StreamStats> {
        let mut tracker = Tracker::new(part, self.profile, journal.take(), events).within(self.full, self.profile);
        let result = machine.stream(part, &mut tracker).map_err(|e| locate_refusal(e, part, self.profile));
        *journal = tracker.journal.take();
        let journal_error = tracker.error.take();
        if journal_error.is_some() || result.is_err() {
            // Every abort path leaves the pen up when the machine still answers (the journal stays for a
            // resume).
            let note = match machine.stop_and_lift(self.profile) {
                Ok(done) if done.is_empty() => String::new(),
                Ok(done) => format!("\n{done}"),
                Err(e) => format!("\n({e:#})"),
            };
            if let Some(e) = journal_error {
                return Err(if note.is_empty() { e } else { e.context(note.trim().to_string()) }.into());
            }
            if let Err(e) = result {
                let after = hint(&e, self.journal_path) + &note;
                return Err(stopped(e, after));
            }
        }
        result.map_err(|e| {
            let after = hint(&e, self.journal_path);
            stopped(e, after)
        })
    }

    /// Move to the park position with the pen up; returns it (machine mm).
    fn park<M: PlotMachine + ?Sized>(&self, machine: &mut M) -> anyhow::Result<(f64, f64)> {
        park(machine, self.profile)
    }
}

/// Move to the park position with the pen up; returns it (machine mm).
pub(crate) fn park<M: PlotMachine + ?Sized>(machine: &mut M, profile: &MachineProfile) -> anyhow::Result<(f64, f64)> {
    let to = plan::park_position(profile)?;
    let now = position_within_travel(machine, profile)?;
    let travel = plan::plan_travel(profile, now, to)?;
    if !travel.blocks.is_empty() {
        machine.stream(&travel, &mut Quiet).map_err(|e| anyhow::anyhow!("cannot park for the pen change: {e}"))?;
    }
    let m = plotter_path::geometry::steps::StepMapper::new(profile).steps_to_machine(to);
    Ok((m.x, m.y))
}

/// Wait `ms` milliseconds with the pen where it is, as dwells the machine runs (so a simulated plot counts them
/// in its executed time): blocks of at most a second each.
pub(crate) fn dwell<M: PlotMachine + ?Sized>(
    machine: &mut M,
    profile: &MachineProfile,
    ms: u32,
    pen: &plotter_path::config::pens::LayerPen,
) -> anyhow::Result<()> {
    let at = position_within_travel(machine, profile)?;
    let mut left = u64::from(ms) * u64::from(plotter_fw::TICK_HZ / 1000);
    let mut blocks = Vec::new();
    while left > 0 {
        let ticks = u32::try_from(left.min(u64::from(plotter_fw::TICK_HZ))).unwrap_or(plotter_fw::TICK_HZ);
        let block = plotter_fw::StepBlock::dwell(ticks);
        blocks.push(plan::PlannedBlock { block, kind: MoveKind::Settle, stroke: 0, ticks });
        left -= u64::from(ticks);
    }
    let total_ticks = blocks.iter().map(|b| u64::from(b.ticks)).sum();
    let wait = MotionPlan {
        blocks,
        start: at,
        end: at,
        total_ticks,
        draw_mm: 0.0,
        travel_mm: 0.0,
        resumed_from: 0,
        preamble: 0,
        first_pen: pen.clone(),
        pen_changes: Vec::new(),
    };
    machine.stream(&wait, &mut Quiet).map_err(|e| anyhow::anyhow!("cannot wait {ms} ms: {e}"))?;
    Ok(())
}

/// `plan` from block `from` (in the original plan's numbering) on, when the machine comes to rest before it
/// (the block before ends at rest and it starts from rest); `None` otherwise.
fn tail(plan: &MotionPlan, from: usize) -> Option<MotionPlan> {
    let i = (from + plan.preamble).checked_sub(plan.resumed_from).filter(|i| *i > 0 && *i < plan.blocks.len())?;
    if plan.blocks[i].block.entry_rate != 0 || plan.blocks[i - 1].block.exit_rate != 0 {
        return None;
    }
    let blocks = plan.blocks[i..].to_vec();
    Some(MotionPlan {
        total_ticks: blocks.iter().map(|b| u64::from(b.ticks)).sum(),
        blocks,
        start: plan.position_after(i - 1),
        resumed_from: from,
        preamble: 0,
        end: plan.end,
        draw_mm: plan.draw_mm,
        travel_mm: plan.travel_mm,
        first_pen: plan.first_pen.clone(),
        pen_changes: plan.pen_changes.clone(),
    })
}

/// The first `len` blocks of `plan` (a part that ends with the pen up, before a pen change).
fn truncated(plan: &MotionPlan, len: usize) -> MotionPlan {
    let mut p = plan.clone();
    p.blocks.truncate(len);
    p.end = p.position_after(len.saturating_sub(1));
    if len == 0 {
        p.end = p.start;
    }
    p.total_ticks = p.blocks.iter().map(|b| u64::from(b.ticks)).sum();
    p
}

/// A refused block named as in the original plan (block number) and where it ends (machine mm), so the user can
/// tell which part of the drawing lies outside the machine.
fn locate_refusal(e: StreamError, part: &MotionPlan, profile: &MachineProfile) -> StreamError {
    match e {
        StreamError::Refused { block, code, text } if block < part.blocks.len() => {
            let end = part.position_after(block);
            let mm = plotter_path::geometry::steps::StepMapper::new(profile)
                .steps_to_machine(plotter_path::geometry::steps::StepPos::new(end[0], end[1]));
            let original = (part.resumed_from + block).saturating_sub(part.preamble);
            let text = format!("{text} (the block ends at X {:.3} mm, Y {:.3} mm)", mm.x, mm.y);
            StreamError::Refused { block: original, code, text }
        }
        e => e,
    }
}

/// A stream's early end as the library's error, followed by `after` (what the job did then, how to continue).
pub(crate) fn stopped(e: StreamError, after: String) -> Error {
    match e {
        StreamError::Refused { block, code, text } => Error::Refused { block, code, text, after },
        StreamError::Alarm { code, text, executed } => Error::Alarm { code, text, executed, after },
        StreamError::Restarted { executed } => Error::Restarted { executed, after },
        StreamError::Aborted { executed } => Error::Aborted { executed, after },
        StreamError::StoppedAtOnce { name, why, executed } => Error::StoppedAtOnce { name, why, executed, after },
        StreamError::Link(e) => match Error::from(e) {
            Error::PortLost { cause, after: none } => Error::PortLost { cause, after: none + &after },
            // As the message reads (its first line: the causes stay with the link's own error).
            other => Error::Other(anyhow::anyhow!("{other}{after}")),
        },
    }
}

/// How to continue after the stream error `e`, when a journal was kept (nothing after a refused block: resuming
/// would meet the same refusal).
fn hint(e: &StreamError, journal: Option<&Path>) -> String {
    match (e, journal) {
        (StreamError::Refused { .. }, _) | (_, None) => String::new(),
        (_, Some(j)) => format!("\ncontinue with: plotter plot --resume {} --port <device>", j.display()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::job::progress::JobProgress;
    use crate::link::grbl::emulator::{Faults, GrblEmulator};
    use crate::link::grbl::emulator_transport::EmulatorTransport;
    use crate::link::grbl::session::GrblSession;
    use crate::link::grbl::settings::GrblSettings;
    use crate::link::session::Session;
    use crate::link::sim::SimTransport;
    use plotter_path::geometry::steps::drawing_to_steps;
    use plotter_path::kurbo::Point;
    use plotter_path::{Drawing, Layer, Polyline, Rgb};

    /// Three layers, black / red / blue, one 10 mm square each, at x = 20, 50, 80 mm.
    fn three_pens(profile: &MachineProfile) -> StepDrawing {
        let square = |x: f64| {
            Polyline::new(vec![
                Point::new(x, 40.0),
                Point::new(x + 10.0, 40.0),
                Point::new(x + 10.0, 50.0),
                Point::new(x, 50.0),
                Point::new(x, 40.0),
            ])
        };
        let mut d = Drawing::default();
        for (i, (name, color)) in
            [("black", Rgb::BLACK), ("red", Rgb(255, 0, 0)), ("blue", Rgb(0, 0, 255))].into_iter().enumerate()
        {
            let mut l = Layer::new(name);
            l.pen.color = color;
            l.paths = vec![square(20.0 + 30.0 * f64::from(u32::try_from(i).unwrap()))];
            d.layers.push(l);
        }
        drawing_to_steps(profile, &d).unwrap()
    }

    /// Answers pen changes from a script and records them, and where the carriage was at each.
    struct Script {
        answers: Vec<PenChangeChoice>,
        seen: Vec<PenChangeRequest>,
    }

    impl PlotEvents for Script {
        fn progress(&mut self, _: &JobProgress) {}
        fn pen_change_mode(&self) -> PenChangeMode {
            PenChangeMode::Pause
        }
        fn pen_change(&mut self, c: &PenChangeRequest) -> PenChangeChoice {
            self.seen.push(c.clone());
            if self.answers.is_empty() { PenChangeChoice::Continue } else { self.answers.remove(0) }
        }
        fn unlock_alarm(&mut self, _: &str) -> bool {
            true
        }
    }

    fn grbl() -> GrblSession<EmulatorTransport> {
        let profile = MachineProfile::default_plotter();
        let cfg = plan::machine_config(&profile).unwrap();
        let emu =
            GrblEmulator::with_settings(cfg, GrblSettings::for_profile(&profile), Some(115_200), Faults::default());
        GrblSession::connect(EmulatorTransport::new(emu), "emulator", &profile).unwrap()
    }

    /// Pen-down runs (XY step positions while Z is below the kit's 1 mm clearance, 400 steps: the hops travel at
    /// or above it) of a step trace that move in XY (homing Z dips the pen where the carriage stands).
    fn pen_down_runs(sim: &plotter_fw::sim::Sim) -> Vec<Vec<(i64, i64)>> {
        let mut pos = sim.hal().physical_position();
        for e in sim.hal().steps().iter().rev() {
            pos[e.axis.index()] -= if e.forward { 1 } else { -1 };
        }
        let mut runs = Vec::new();
        let mut cur: Vec<(i64, i64)> = Vec::new();
        for e in sim.hal().steps() {
            pos[e.axis.index()] += if e.forward { 1 } else { -1 };
            if pos[2] < 400 {
                cur.push((pos[0], pos[1]));
            } else if !cur.is_empty() {
                runs.push(std::mem::take(&mut cur));
            }
        }
        runs.retain(|r| r.iter().any(|p| *p != r[0]));
        runs
    }

    #[test]
    fn grbl_plot_stops_twice_parked_and_ends_exactly() {
        let profile = MachineProfile::default_plotter();
        let steps = three_pens(&profile);
        let mut m = grbl();
        let mut ev = Script { answers: vec![], seen: vec![] };
        let out = plot(&mut m, &profile, &steps, true, false, None, &mut ev).unwrap();
        assert_eq!(out.pen_stops, 2);
        let names: Vec<&str> = ev.seen.iter().map(|c| c.pen.name.as_str()).collect();
        assert_eq!(names, ["red fineliner 0.5", "blue brush pen"]);
        assert_eq!(ev.seen[1].previous.as_ref().map(|p| p.name.as_str()), Some("red fineliner 0.5"));
        assert_eq!(ev.seen[0].park_mm, (0.0, 0.0), "the kit has no [park]: the home corner");
        let emu = m.transport.emulator();
        let p = emu.backend().machine().stepper().position();
        // The blue square closes at (80, 40) mm = (6400, 3200) steps, pen up.
        assert_eq!([p[0], p[1], p[2]], [6400, 3200, 1600]);
        assert!(emu.stats().peak_rx <= 127 && emu.stats().overflow_bytes == 0);
        // Three pen-down runs, one square each, and the carriage visited the park corner pen up in between.
        let runs = pen_down_runs(emu.backend());
        assert_eq!(runs.len(), 3, "three squares");
        let firsts: Vec<(i64, i64)> = runs.iter().map(|r| r[0]).collect();
        assert_eq!(firsts, [(1600, 3200), (4000, 3200), (6400, 3200)]);
    }

    #[test]
    fn a_grbl_hold_nobody_resumes_ends_the_plot_saying_so_with_the_pen_up() {
        let profile = MachineProfile::default_plotter();
        // A zigzag of 40 strokes of 5 mm: the 16-block planner takes the lines as the pen draws.
        let zigzag = (0..=40).map(|i| Point::new(20.0 + 5.0 * f64::from(i), 40.0 + 5.0 * f64::from(i % 2))).collect();
        let steps = drawing_to_steps(&profile, &Drawing::single_layer("l", vec![Polyline::new(zigzag)])).unwrap();
        let cfg = plan::machine_config(&profile).unwrap();
        // The Hold button, pressed once the 30th G-code line (G21, G90, then the plan's 28th) is queued: the pen
        // is drawing then.
        let faults = Faults { realtime_after_lines: Some((30, b'!')), ..Faults::default() };
        let emu = GrblEmulator::with_settings(cfg, GrblSettings::for_profile(&profile), Some(115_200), faults);
        let mut g = GrblSession::connect(EmulatorTransport::new(emu), "emulator", &profile).unwrap();
        g.hold_timeout = std::time::Duration::from_secs(2);
        let mut ev = Script { answers: vec![], seen: vec![] };
        let e = plot(&mut g, &profile, &steps, true, false, None, &mut ev).unwrap_err().to_string();
        assert!(e.starts_with("emulator: the controller has been in a feed hold (Hold:0) for 2 s and nobody"), "{e}");
        assert!(e.contains("\nemulator: stopped (soft reset); the pen is up (G91 G0 Z4, G90)"), "{e}");
        assert_eq!(g.transport.emulator().pen().z_steps, 1600);
        assert!(g.status().unwrap().is_idle());
    }

    /// A user who presses Ctrl-C (a pause at the next pen-up) `presses` times in a row once `at` blocks have
    /// been executed, and would abort at a pause.
    struct Presses {
        at: usize,
        presses: u32,
        executed: usize,
        notices: Vec<String>,
    }

    impl PlotEvents for Presses {
        fn progress(&mut self, p: &JobProgress) {
            self.executed = p.executed;
        }
        fn pause_requested(&mut self) -> Option<bool> {
            (self.executed >= self.at && self.presses > 0).then(|| {
                self.presses -= 1;
                false
            })
        }
        fn notice(&mut self, text: &str) {
            self.notices.push(text.to_string());
        }
    }

    /// Our firmware, simulated, and a zigzag of 200 pen-down strokes (1 mm apart, 5 mm tall) from X 20 mm: one
    /// stroke of 205 blocks (travel, pen down, settle, 200 lines, pen up, settle), far more than the firmware
    /// queues.
    fn zigzag_on_sim(profile: &MachineProfile) -> (Session<SimTransport>, StepDrawing, MotionPlan) {
        let zigzag = (0..=200).map(|i| Point::new(20.0 + f64::from(i), 40.0 + 5.0 * f64::from(i % 2))).collect();
        let steps = drawing_to_steps(profile, &Drawing::single_layer("l", vec![Polyline::new(zigzag)])).unwrap();
        let cfg = plan::machine_config(profile).unwrap();
        let s = Session::connect(SimTransport::new(cfg, Some(115_200)), "sim").unwrap();
        let full = plan::plan(profile, &steps, plan::homed_position(profile).unwrap(), Lookahead::Whole).unwrap();
        (s, steps, full)
    }

    /// The executed block count an error message names ("after N executed block(s)").
    fn executed_in(e: &str) -> usize {
        e.split("after ").nth(1).and_then(|t| t.split(' ').next()).and_then(|n| n.parse().ok()).unwrap()
    }

    #[test]
    fn a_second_ctrl_c_stops_our_firmware_at_once_with_the_pen_up() {
        let profile = MachineProfile::default_plotter();
        let (mut s, steps, full) = zigzag_on_sim(&profile);
        assert_eq!(full.blocks.len(), 205, "travel, pen down, settle, 200 strokes, pen up, settle");
        // Two presses while the 20th stroke is drawn: the pause at the next pen-up (the zigzag's end) is
        // scheduled, then the second press stops the plot there and then.
        let mut user = Presses { at: 23, presses: 2, executed: 0, notices: vec![] };
        let e = plot(&mut s, &profile, &steps, true, false, None, &mut user).unwrap_err().to_string();
        assert!(
            e.starts_with(
                "sim: stopped at once on a second pause request (Ctrl-C) before the pause at the next pen-up"
            ),
            "{e}"
        );
        let executed = executed_in(&e);
        assert!((23..40).contains(&executed), "{e}");
        let sim = s.transport.sim().hal();
        // The simulated pen starts down (Z 0) until homing lifts it; then it went down once for the zigzag and is
        // up now (lifted by the job after the stop).
        let pen: Vec<bool> = sim.pen_trace().iter().map(|p| p.1).collect();
        assert_eq!(pen, [true, false, true, false]);
        // It stopped where it was, within a few blocks of the executed count the message names, far before the
        // zigzag's end (X 220 mm = 17600 steps); the lift moved Z only.
        let x = sim.physical_position()[0];
        let (lo, hi) = (full.position_after(executed - 1)[0], full.position_after(executed + 3)[0]);
        assert!(i64::from(lo) <= x && x <= i64::from(hi), "{lo} <= {x} <= {hi}");
        assert_eq!(sim.physical_position()[2], 1600);
        assert!(user.notices.is_empty(), "{:?}", user.notices);
    }

    /// A plot stopped at once mid-stroke on the XY kit (its Z switch below the pen's touch) and resumed from its
    /// journal: the stop reset the firmware while X and Y drew, so Z's position is still known and the resume's
    /// homing keeps it (the pen stays up while X and Y home). The pen first goes down where the resumed plan lowers
    /// it, at its stroke's start; the homing used to seek Z's switch, 2 mm below the paper, wherever the carriage
    /// stood: a dot on the drawing at every resume.
    #[test]
    fn a_resume_after_a_stop_mid_stroke_lowers_the_pen_only_at_its_stroke() {
        let profile = MachineProfile::default_plotter();
        let (mut s, steps, _) = zigzag_on_sim(&profile);
        let dir = std::env::temp_dir().join(format!("plotter-resume-dot-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let jp = dir.join("zigzag.journal");
        let source = |start: [i32; 4]| Ok(format!("{start:?}"));
        let spec = JournalSpec { path: &jp, source: &source };
        let mut user = Presses { at: 23, presses: 2, executed: 0, notices: vec![] };
        let e = plot(&mut s, &profile, &steps, true, false, Some(spec), &mut user).unwrap_err();
        assert!(matches!(e, Error::StoppedAtOnce { .. }), "{e:?}");
        let state = crate::link::journal::load(&jp).unwrap();
        let from = s.transport.sim().hal().steps().len();
        let stopped_at = s.transport.sim().physical_position();
        let start = plan::homed_position(&profile).unwrap();
        let mut ev = Script { answers: vec![], seen: vec![] };
        let out = resume(&mut s, &profile, &steps, start, &state, &jp, false, false, &mut ev).unwrap();
        assert!(crate::link::journal::load(&jp).unwrap().complete);
        // Where the resumed plan lowers the pen (machine steps: the switches sit one pull-off beyond the travel,
        // so after homing the simulator's physical steps are machine steps).
        let down = out.plan.blocks.iter().position(|b| b.kind == MoveKind::PenDown).unwrap();
        let at = out.plan.position_after(down);
        // The first step of the resume that takes Z below the simulator's pen-down line (halfway between the
        // pen's 0 and 4 mm: 800 steps).
        let sim = s.transport.sim().hal();
        let mut pos = sim.physical_position();
        for e in sim.steps()[from..].iter().rev() {
            pos[e.axis.index()] -= if e.forward { 1 } else { -1 };
        }
        assert_eq!(pos, stopped_at);
        assert!(pos[2] >= 800, "the stop lifted the pen: {pos:?}");
        let first_down = sim.steps()[from..].iter().find_map(|e| {
            pos[e.axis.index()] += if e.forward { 1 } else { -1 };
            (pos[2] < 800).then_some((pos[0], pos[1]))
        });
        assert_eq!(first_down, Some((i64::from(at[0]), i64::from(at[1]))), "stopped at {stopped_at:?}");
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn once_everything_is_queued_a_first_ctrl_c_says_so_and_a_second_stops_at_once() {
        let profile = MachineProfile::default_plotter();
        let (mut s, steps, full) = zigzag_on_sim(&profile);
        // 196 executed: every block has been accepted, the last strokes are still being drawn.
        let mut user = Presses { at: 196, presses: 2, executed: 0, notices: vec![] };
        let e = plot(&mut s, &profile, &steps, true, false, None, &mut user).unwrap_err().to_string();
        assert!(e.starts_with("sim: stopped at once on a second pause request (Ctrl-C)"), "{e}");
        assert_eq!(user.notices.len(), 1, "{:?}", user.notices);
        assert!(
            user.notices[0].starts_with("sim: every block is queued, so the plot ends with the pen up in a moment")
        );
        let executed = executed_in(&e);
        assert!((196..203).contains(&executed), "{e}");
        let sim = s.transport.sim().hal();
        assert_eq!(sim.pen_trace().last().map(|p| p.1), Some(false));
        assert!(sim.physical_position()[0] < i64::from(full.position_after(202)[0]), "the last stroke was cut short");
    }

    #[test]
    fn a_refused_block_stops_the_plot_and_is_named_with_its_end() {
        // The firmware's X travel is 50 mm, the profile's 420 mm: the line from (10, 10) to (100, 10) mm passes the
        // host's checks and is refused by the firmware (soft limit, error 7) at its end, X 100 mm, Y 10 mm.
        let profile = MachineProfile::default_plotter();
        let mut cfg = plan::machine_config(&profile).unwrap();
        cfg.axes[0].travel_mm = 50.0;
        let mut s = Session::connect(SimTransport::new(cfg, Some(115_200)), "sim").unwrap();
        let d = Drawing::single_layer(
            "l",
            vec![plotter_path::Polyline::new(vec![
                plotter_path::kurbo::Point::new(10.0, 10.0),
                plotter_path::kurbo::Point::new(100.0, 10.0),
            ])],
        );
        let steps = drawing_to_steps(&profile, &d).unwrap();
        let mut events = Script { answers: vec![], seen: vec![] };
        let err = plot(&mut s, &profile, &steps, true, false, None, &mut events).unwrap_err().to_string();
        // Blocks: travel to the start (0), pen down (1), settle (2), the line (3).
        assert!(err.contains("refused block 3: error 7"), "{err}");
        assert!(err.contains("ends at X 100.000 mm, Y 10.000 mm"), "{err}");
        // Nothing beyond X 50 mm (4000 steps) was drawn, and the pen was lifted.
        let phys = s.transport.sim().physical_position();
        assert!(phys[0] <= 4000 && phys[2] > 800, "{phys:?}");
    }

    #[test]
    fn a_stream_error_keeps_its_text_and_gets_what_followed() {
        let e = stopped(StreamError::Alarm { code: 2, text: "hard limit".into(), executed: 9 }, "\nX".into());
        assert!(matches!(e, Error::Alarm { code: 2, executed: 9, .. }));
        assert_eq!(e.to_string(), "alarm 2 (hard limit) after 9 executed block(s)\nX");
        let e = stopped(StreamError::Link(anyhow::anyhow!("sim: no reply").context("x")), "!".into());
        assert_eq!(e.to_string(), "x!");
        let e = stopped(
            StreamError::from(std::io::Error::new(std::io::ErrorKind::BrokenPipe, "the device went away")),
            "\nhint".into(),
        );
        assert!(matches!(e, Error::PortLost { .. }));
        assert_eq!(e.to_string(), "the device went away\nhint");
    }

    #[test]
    fn a_refused_block_is_the_typed_error_with_its_number_and_code() {
        // As above: the firmware's X travel is 50 mm, the line ends at X 100 mm; blocks: travel, pen down, settle,
        // the line (3).
        let profile = MachineProfile::default_plotter();
        let mut cfg = plan::machine_config(&profile).unwrap();
        cfg.axes[0].travel_mm = 50.0;
        let mut s = Session::connect(SimTransport::new(cfg, Some(115_200)), "sim").unwrap();
        let line = Polyline::new(vec![Point::new(10.0, 10.0), Point::new(100.0, 10.0)]);
        let steps = drawing_to_steps(&profile, &Drawing::single_layer("l", vec![line])).unwrap();
        let mut events = Script { answers: vec![], seen: vec![] };
        match plot(&mut s, &profile, &steps, true, false, None, &mut events).unwrap_err() {
            Error::Refused { block, code, text, .. } => {
                assert_eq!((block, code), (3, 7));
                assert!(text.ends_with("(the block ends at X 100.000 mm, Y 10.000 mm)"), "{text}");
            }
            e => panic!("{e:?}"),
        }
    }

    #[test]
    fn a_second_ctrl_c_is_the_typed_stop_at_once() {
        let profile = MachineProfile::default_plotter();
        let (mut s, steps, _) = zigzag_on_sim(&profile);
        let mut user = Presses { at: 23, presses: 2, executed: 0, notices: vec![] };
        match plot(&mut s, &profile, &steps, true, false, None, &mut user).unwrap_err() {
            Error::StoppedAtOnce { name, executed, .. } => {
                assert_eq!(name, "sim");
                assert!((23..40).contains(&executed), "{executed}");
            }
            e => panic!("{e:?}"),
        }
    }

    #[test]
    fn stopping_at_a_pen_change_is_typed_and_names_the_layer() {
        let profile = MachineProfile::default_plotter();
        let steps = three_pens(&profile);
        let mut m = Session::connect(SimTransport::new(plan::machine_config(&profile).unwrap(), None), "sim").unwrap();
        let mut ev = Script { answers: vec![PenChangeChoice::Stop], seen: vec![] };
        match plot(&mut m, &profile, &steps, true, false, None, &mut ev).unwrap_err() {
            // No journal: no resume hint.
            Error::StoppedAtPenChange { layer, pen, after } => {
                assert_eq!((layer.as_str(), after.as_str()), ("red", ""));
                assert!(pen.starts_with("red fineliner 0.5 (#"), "{pen}");
            }
            e => panic!("{e:?}"),
        }
    }

    #[test]
    fn skip_and_stop_then_resume_from_the_journal() {
        let profile = MachineProfile::default_plotter();
        let steps = three_pens(&profile);
        // Skip the red layer: two squares drawn, one pen stop left (for blue).
        let mut m = Session::connect(SimTransport::new(plan::machine_config(&profile).unwrap(), None), "sim").unwrap();
        let mut ev = Script { answers: vec![PenChangeChoice::SkipLayer], seen: vec![] };
        let out = plot(&mut m, &profile, &steps, true, false, None, &mut ev).unwrap();
        assert_eq!((out.pen_stops, out.skipped.clone()), (2, vec!["red".to_string()]));
        let runs = pen_down_runs(m.transport.sim());
        let firsts: Vec<(i64, i64)> = runs.iter().map(|r| r[0]).collect();
        assert_eq!(firsts, [(1600, 3200), (6400, 3200)]);

        // Stop at the first change on GRBL: the journal says where; resume draws red and blue.
        let dir = std::env::temp_dir().join(format!("plotter-pen-journal-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let jp = dir.join("three.journal");
        let mut g = grbl();
        let source = |start: [i32; 4]| Ok(format!("{start:?}"));
        let spec = JournalSpec { path: &jp, source: &source };
        let mut ev = Script { answers: vec![PenChangeChoice::Stop], seen: vec![] };
        let e = plot(&mut g, &profile, &steps, true, false, Some(spec), &mut ev).unwrap_err().to_string();
        assert!(e.contains("stopped at the pen change before layer \"red\"") && e.contains("--resume"), "{e}");
        let state = crate::link::journal::load(&jp).unwrap();
        let full = plan::plan(&profile, &steps, plan::homed_position(&profile).unwrap(), Lookahead::Whole).unwrap();
        assert_eq!(state.executed, full.pen_changes[0].block, "everything before the change was executed");
        assert!(!state.complete);
        let mut ev = Script { answers: vec![], seen: vec![] };
        let start = plan::homed_position(&profile).unwrap();
        let out = resume(&mut g, &profile, &steps, start, &state, &jp, false, false, &mut ev).unwrap();
        // Asked for red first (resuming), then for blue.
        let names: Vec<&str> = ev.seen.iter().map(|c| c.layer_name.as_str()).collect();
        assert_eq!(names, ["red", "blue"]);
        assert!(ev.seen[0].previous.is_none());
        assert_eq!(out.pen_stops, 2);
        assert!(crate::link::journal::load(&jp).unwrap().complete);
        let p = g.transport.emulator().backend().machine().stepper().position();
        assert_eq!([p[0], p[1], p[2]], [6400, 3200, 1600]);
        let runs = pen_down_runs(g.transport.emulator().backend());
        let firsts: Vec<(i64, i64)> = runs.iter().map(|r| r[0]).collect();
        assert_eq!(firsts, [(1600, 3200), (4000, 3200), (6400, 3200)], "black before the stop, red and blue after");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// A machine that reports `at` and must never be asked to move.
    struct Liar {
        at: MachinePos,
    }

    impl PlotMachine for Liar {
        fn name(&self) -> &str {
            "/dev/ttyLIAR"
        }
        fn firmware(&self) -> crate::link::machine::Firmware {
            crate::link::machine::Firmware::Grbl
        }
        fn home(&mut self) -> anyhow::Result<()> {
            Ok(())
        }
        fn position(&mut self) -> anyhow::Result<MachinePos> {
            Ok(self.at)
        }
        fn stream(
            &mut self,
            _: &MotionPlan,
            _: &mut dyn crate::link::stream::Control,
        ) -> Result<StreamStats, StreamError> {
            panic!("asked to move from a position it lied about")
        }
        fn resume_point(&mut self, state: &JournalState, _: &MotionPlan) -> anyhow::Result<usize> {
            Ok(state.executed)
        }
    }

    /// A plot killed after its drawing was done, on its way home, before its end was recorded: the resume marks
    /// the journal complete and moves nothing (the liar panics if asked to move); one block less executed (the
    /// last pen-up not certainly done) is resumed as usual.
    #[test]
    fn a_journal_at_its_end_is_finished_without_moving() {
        let profile = MachineProfile::default_plotter();
        let steps = three_pens(&profile);
        let start = plan::homed_position(&profile).unwrap();
        let full = plan::plan_returning(&profile, &steps, start, Lookahead::Whole, true).unwrap();
        let last_up = full.blocks.iter().rposition(|b| b.kind == MoveKind::PenUp).unwrap();
        assert_eq!(full.blocks[last_up + 1].kind, MoveKind::Settle);
        assert!(full.blocks[last_up + 2..].iter().all(|b| b.kind == MoveKind::Travel));
        assert!(last_up + 2 < full.blocks.len(), "the way home is left");
        let dir = std::env::temp_dir().join(format!("plotter-journal-end-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let jp = dir.join("end.journal");
        let journal_at = |executed: usize| {
            let mut j = Journal::create(&jp, "{}", full.geometry_hash(), full.blocks.len()).unwrap();
            j.record(executed, executed, 0).unwrap();
            drop(j);
            crate::link::journal::load(&jp).unwrap()
        };
        let state = journal_at(last_up + 2);
        assert!(!state.complete);
        let mut ev = Script { answers: vec![], seen: vec![] };
        let out = resume(&mut Liar { at: start }, &profile, &steps, start, &state, &jp, false, true, &mut ev).unwrap();
        assert!(out.drawn_before && out.plan.blocks.is_empty());
        assert!(crate::link::journal::load(&jp).unwrap().complete);
        assert!(ev.seen.is_empty(), "no pen asked for");
        let state = journal_at(last_up);
        let moved = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            let mut ev = Script { answers: vec![], seen: vec![] };
            resume(&mut Liar { at: start }, &profile, &steps, start, &state, &jp, false, true, &mut ev)
        }));
        assert!(moved.is_err(), "the last pen-up is still to make: the resume moves");
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn a_position_outside_the_travel_is_refused_before_anything_moves() {
        let profile = MachineProfile::default_plotter();
        let steps = three_pens(&profile);
        // The built-in kit: 80 steps/mm; X travels 0..420 mm: 33,600 steps, and 10 mm more (800 steps) is let by.
        let (x_max, y_max) = (profile.axes.x.travel_mm, profile.axes.y.travel_mm);
        assert_eq!((profile.axes.x.steps_per_mm, x_max), (80.0, 420.0));
        // A plot from a machine standing at `at`; its error's text.
        let plot_at = |at: MachinePos| {
            let mut events = Script { answers: Vec::new(), seen: Vec::new() };
            plot(&mut Liar { at }, &profile, &steps, false, false, None, &mut events).map_err(|e| e.to_string())
        };
        for at in [[100_000_000, 0, 0, 0], [0, i32::MIN, 0, 0], [34_401, 0, 0, 0], [-801, 10, 0, 0]] {
            let e = plot_at(at).unwrap_err();
            assert!(e.contains("/dev/ttyLIAR reports the pen at") && e.contains("outside its travel"), "{at:?}: {e}");
        }
        let e = plot_at([100_000_000, 0, 0, 0]).unwrap_err();
        assert!(e.contains("X = 100000000 steps (1250000.0 mm), outside its travel 0..420 mm"), "{e}");
        // At the margin's edge it is taken (and the stream is asked: the liar panics there).
        // Y travels 0..297 mm: 23,760 steps.
        assert_eq!(y_max, 297.0);
        let y_edge = 23_760 + 800;
        for at in [[34_400, 0, 0, 0], [-800, 0, 0, 0], [0, y_edge, 0, 0]] {
            let caught = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| plot_at(at)));
            assert!(caught.is_err(), "{at:?} is within the travel and its margin");
        }
    }
}
