//! The plot job on an HP-GL plotter: stream a program command by command through an [`HpglSession`], with the
//! progress every front end shows ([`JobProgress`], commands standing for blocks), pauses, cancelling, the
//! resume journal ([`crate::link::journal`], counting commands) and resuming.
//!
//! - **Errors** are read back every [`CHECK_BYTES`] bytes and at the end ([`HpglSession::check`]): an `OE` or
//!   `ESC . E` error stops the plot with its meaning.
//! - **Pause** (Ctrl-C): the current command is finished, then `PU;` and a pen-up move to the park corner (the
//!   far corner of the plotting area) are sent and the plotter is let to finish; to continue, the pen travels
//!   back to where it was (and goes down again if it was down) and the next command follows.
//! - **Cancel** (abort at the pause prompt, or any failure): `ESC . K`, then `PU;SP0;` ([`HpglSession::cancel`]).
//! - **Journal**: `accepted` = commands sent, `executed` = commands the plotter has certainly parsed (its buffer
//!   drained past them). A resumed plot starts at the executed count, after a preamble that restores the set-up,
//!   pen, speed and position ([`Commands::resume_preamble`]): a plotter that ran on after the host died draws a
//!   few strokes twice, none is missed.
//! - Pen changes need no stop: the carousel holds the pens (`SP`); the export warns when layers share a slot.

use std::path::Path;
use std::time::Duration;

use anyhow::{Context as _, bail};
use plotter_path::geometry::hpgl_devices::{HpglDevice, HpglPaper};
use plotter_path::kurbo::Point;
use plotter_path::output::hpgl_out::{self, HpglProgram};
use plotter_path::{Drawing, MachineProfile};

use super::progress::{JobProgress, PlotEvents};
use crate::link::hpgl::HpglLink;
use crate::link::hpgl::commands::Commands;
use crate::link::hpgl::sender::{HpglSession, SendStats};
use crate::link::journal::Journal;
use crate::link::stream::PauseChoice;

/// Bytes sent between two error checks.
pub const CHECK_BYTES: u64 = 4096;

/// Margin on top of the estimated plotter time when waiting for an `OE` answer.
const CHECK_MARGIN: Duration = Duration::from_secs(60);

/// How a plot went.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HpglOutcome {
    /// Commands of the program.
    pub commands: usize,
    /// The first command sent in this run (0, or where a resume started).
    pub from: usize,
    /// Link time from the first byte to the plotter's last answer, s.
    pub seconds: f64,
    /// What the session counted in this run.
    pub stats: SendStats,
    /// Pen-down millimetres of the program.
    pub draw_mm: f64,
    /// The program's estimated plotter time, s.
    pub estimated_s: f64,
}

/// The page drawing (mm) as the HP-GL program for `device` with `paper` loaded, or, without one, on the first
/// of the device's sheets whose plotting area holds the drawing (a device without a sheet table plots on the
/// drawing's own page). The program's warnings are the caller's to show.
pub fn program_for(
    profile: &MachineProfile,
    drawing: &Drawing,
    device: &HpglDevice,
    paper: Option<&HpglPaper>,
) -> anyhow::Result<(HpglProgram, HpglPaper)> {
    let papers: Vec<HpglPaper> = match (paper, device.papers.is_empty()) {
        (Some(p), _) => vec![*p],
        (None, false) => device.papers.to_vec(),
        (None, true) => {
            let (w, h) = drawing.page_mm.or_else(|| drawing.bbox().map(|b| (b.x1, b.y1))).unwrap_or((0.0, 0.0));
            vec![HpglPaper::generic(w, h)]
        }
    };
    let mut first_error = None;
    for paper in &papers {
        match hpgl_out::export(profile, drawing, device, paper) {
            Ok(p) => return Ok((p, *paper)),
            Err(e) => {
                first_error.get_or_insert(e);
            }
        }
    }
    let e = first_error.context("the device has no sheets")?;
    if papers.len() > 1 {
        bail!("{e} (nor does any other of its sheets hold the drawing: {})", device.paper_names());
    }
    Err(e.into())
}

/// FNV-1a of the program text: the journal's check that a resume rebuilds the same program.
pub fn program_hash(text: &str) -> u64 {
    text.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3))
}

/// Where a plot recorded in a journal continues: the first command not certainly parsed.
pub fn resume_point(executed: usize, commands: &Commands) -> usize {
    executed.min(commands.list.len())
}

/// The run's state, for progress and the journal.
struct Run<'a> {
    cmds: &'a Commands,
    paper: &'a HpglPaper,
    ends: Vec<usize>,
    /// Session byte count where the command `from` starts, minus the program offset of that command.
    base: i64,
    accepted: usize,
    executed: usize,
    journal: Option<Journal>,
    journal_path: Option<&'a Path>,
}

impl Run<'_> {
    /// Commands whose last byte the plotter has parsed, given the session's parsed byte count.
    fn executed_of(&self, parsed: u64) -> usize {
        let p = i64::try_from(parsed).unwrap_or(i64::MAX) - self.base;
        self.ends.partition_point(|&e| i64::try_from(e).unwrap_or(i64::MAX) <= p)
    }

    fn report(&mut self, events: &mut dyn PlotEvents) -> anyhow::Result<()> {
        let list = &self.cmds.list;
        let total = list.len();
        let at =
            |k: usize, f: fn(&crate::link::hpgl::commands::Command) -> f64| if k == 0 { 0.0 } else { f(&list[k - 1]) };
        let state = list.get(self.executed).map(|c| c.before);
        let (pos, down) =
            state.map_or_else(|| (list.last().map_or((0, 0), |c| c.before.pos), false), |s| (s.pos, s.down));
        let (x, y) = self.paper.to_page(f64::from(pos.0), f64::from(pos.1));
        events.progress(&JobProgress {
            executed: self.executed,
            accepted: self.accepted,
            total,
            draw_done_mm: at(self.executed, |c| c.draw_mm_after),
            draw_total_mm: self.cmds.draw_mm(),
            eta_s: self.cmds.seconds() - at(self.executed, |c| c.seconds_after),
            resends: 0,
            pen_mm: Point::new(x, y),
            pen_down: down,
        });
        if let Some(j) = self.journal.as_mut() {
            j.record(self.accepted, self.executed, 0)?;
        }
        Ok(())
    }

    /// How long the plotter may take to parse everything sent: the estimated time of the commands not yet
    /// parsed, plus a margin.
    fn wait(&self) -> Duration {
        let at = |k: usize| if k == 0 { 0.0 } else { self.cmds.list[k - 1].seconds_after };
        CHECK_MARGIN + Duration::from_secs_f64((at(self.accepted) - at(self.executed)).max(0.0))
    }

    fn hint(&self) -> String {
        self.journal_path
            .map(|j| format!("\ncontinue with: plotter plot --resume {} --port <device>", j.display()))
            .unwrap_or_default()
    }
}

/// Plot `cmds` (written for `paper`) from command `from` on (0: the whole program; else after the resume
/// preamble). The journal, when given, was created (or reopened) by the caller.
pub fn plot<L: HpglLink>(
    s: &mut HpglSession<L>,
    cmds: &Commands,
    paper: &HpglPaper,
    from: usize,
    journal: Option<Journal>,
    journal_path: Option<&Path>,
    events: &mut dyn PlotEvents,
) -> anyhow::Result<HpglOutcome> {
    let stats0 = s.stats;
    let t0 = s.link.now();
    let mut run =
        Run { cmds, paper, ends: cmds.ends(), base: 0, accepted: from, executed: from, journal, journal_path };
    let result = stream(s, &mut run, from, events);
    if let Err(e) = result {
        let note = match s.cancel() {
            Ok(done) => format!("\n{done}"),
            Err(c) => format!("\n(could not stop the plotter: {c:#})"),
        };
        return Err(anyhow::anyhow!(
            "{}: {e:#}; the plot stopped after command {} of {}{note}{}",
            s.name,
            run.executed,
            cmds.list.len(),
            run.hint()
        ));
    }
    if let Some(j) = run.journal.as_mut() {
        j.complete()?;
    }
    let d = |a: u64, b: u64| a - b;
    Ok(HpglOutcome {
        commands: cmds.list.len(),
        from,
        seconds: (s.link.now() - t0).as_secs_f64(),
        stats: SendStats {
            bytes: d(s.stats.bytes, stats0.bytes),
            space_queries: d(s.stats.space_queries, stats0.space_queries),
            xoffs: d(s.stats.xoffs, stats0.xoffs),
            waits: d(s.stats.waits, stats0.waits),
        },
        draw_mm: cmds.draw_mm(),
        estimated_s: cmds.seconds(),
    })
}

fn stream<L: HpglLink>(
    s: &mut HpglSession<L>,
    run: &mut Run<'_>,
    from: usize,
    events: &mut dyn PlotEvents,
) -> anyhow::Result<()> {
    let cmds = run.cmds;
    let total = cmds.list.len();
    if from > 0 {
        for p in cmds.resume_preamble(from) {
            s.send(p.as_bytes())?;
        }
    }
    let start_off = if from == 0 { 0 } else { run.ends[from - 1] };
    run.base = i64::try_from(s.sent_bytes()).unwrap_or(i64::MAX) - i64::try_from(start_off).unwrap_or(0);
    run.report(events)?;
    let mut last_check = s.sent_bytes();
    for k in from..total {
        if events.pause_requested().is_some() {
            pause(s, run, k, events)?;
        }
        s.send(cmds.list[k].text.as_bytes())?;
        run.accepted = k + 1;
        if s.sent_bytes() - last_check >= CHECK_BYTES {
            s.check(run.wait())?;
            last_check = s.sent_bytes();
        }
        run.executed = run.executed_of(s.parsed_bytes()).clamp(run.executed, run.accepted);
        run.report(events)?;
    }
    s.check(run.wait())?;
    run.executed = total;
    run.report(events)
}

/// A pause before command `k`: pen up, park, let the plotter finish, ask.
fn pause<L: HpglLink>(
    s: &mut HpglSession<L>,
    run: &mut Run<'_>,
    k: usize,
    events: &mut dyn PlotEvents,
) -> anyhow::Result<()> {
    let park = run.paper.clip_plu;
    s.send(format!("PU;PU{},{};", park.0, park.1).as_bytes())?;
    s.check(run.wait())?;
    // Only the park commands are past command k − 1.
    run.executed = k;
    run.report(events)?;
    match events.paused(false) {
        PauseChoice::Resume => {
            let st = run.cmds.list[k].before;
            let back = format!("PU{},{};{}", st.pos.0, st.pos.1, if st.down { "PD;" } else { "" });
            s.send(back.as_bytes())?;
            // The park and return moves are not commands of the program.
            run.base += i64::try_from(format!("PU;PU{},{};", park.0, park.1).len() + back.len()).unwrap_or(0);
            Ok(())
        }
        PauseChoice::Abort => bail!("stopped at the user's request (the pen was parked before command {})", k + 1),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_program_hash_is_fnv_1a() {
        // Published FNV-1a 64 vectors: "" and "a".
        assert_eq!(program_hash(""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(program_hash("a"), 0xaf63_dc4c_8601_ec8c);
    }
}
