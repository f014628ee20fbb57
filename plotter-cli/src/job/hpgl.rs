//! The plot job on an HP-GL plotter: stream a program command by command through an [`HpglSession`], with the
//! progress every front end shows ([`JobProgress`], commands standing for blocks), pauses, cancelling, the
//! resume journal ([`crate::link::journal`], counting commands) and resuming.
//!
//! - **Errors** are read back every [`CHECK_BYTES`] bytes and at the end ([`HpglSession::check`]): an `OE` or
//!   `ESC . E` error stops the plot with its meaning.
//! - **Pause** (Ctrl-C): the current command is finished, then `PU;` and a pen-up move to the park corner (the
//!   far corner of the plotting area) are sent and the plotter is let to finish; to continue, the pen travels
//!   back to where it was (and goes down again if it was down) and the next command follows.
//! - **Cancel** (abort at the pause prompt, or any failure): `ESC . K`, then `PU;SP0;` written raw, whatever the
//!   plotter answers ([`HpglSession::cancel`]).
//! - **Stops**: a stop ([`PlotEvents::stop_requested`]: SIGTERM, SIGHUP, SIGQUIT, a second Ctrl-C) is checked
//!   between commands and inside every wait on the plotter, and cancels the plot as above with a message naming
//!   the signal. An HP-GL plotter cannot pause in the middle of its buffer, so a pause request (one Ctrl-C) is a
//!   stop where a pause cannot come: once the last byte is sent (the program sits in the plotter's buffer), and
//!   when the plotter has withheld room for longer than what its buffer holds should take (plus
//!   [`PAUSE_GRACE`]); a pause asked during an ordinary wait for room is kept for the next command.
//! - **The end**: the job waits until the plotter has parsed everything (polling `ESC . B`, reporting progress,
//!   saying what it waits for when it takes long), then reads its errors; only then is the plot a success.
//!   Every wait is bounded by [`patience`] of the estimated time of the work outstanding.
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
use crate::link::hpgl::handshake::Handshake;
use crate::link::hpgl::sender::{HpglSession, SendStats, Waiting};
use crate::link::hpgl::timing::patience;
use crate::link::journal::Journal;
use crate::link::stream::PauseChoice;
use crate::link::wait::{Wait, WaitError};
use crate::stop::{StopCause, Stopped};

/// Bytes sent between two error checks.
pub const CHECK_BYTES: u64 = 4096;

/// How long a pause request may wait for room, beyond the estimated time of what the plotter's buffer holds,
/// before it is taken as a stop (the plotter withholds room: it cannot pause).
pub const PAUSE_GRACE: Duration = Duration::from_secs(2);

/// How often the end of a plot (and, under the xonxoff and hardware handshakes, the whole plot) asks the plotter
/// how far it is (`ESC . B`).
const DRAIN_POLL: Duration = Duration::from_millis(250);

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

/// The page drawing (mm) as the HP-GL program for `device` with `paper` loaded, or, without one, on the sheet
/// the page is (the sheet of the page's size as the plotter takes it: where the layout placed a paper), else the
/// first of the device's sheets whose plotting area holds the drawing (a device without a sheet table plots on
/// the drawing's own page). The program's warnings are the caller's to show.
pub fn program_for(
    profile: &MachineProfile,
    drawing: &Drawing,
    device: &HpglDevice,
    paper: Option<&HpglPaper>,
) -> anyhow::Result<(HpglProgram, HpglPaper)> {
    let papers: Vec<HpglPaper> = match (paper, device.papers.is_empty()) {
        (Some(p), _) => vec![*p],
        (None, false) => {
            let (w, h) = drawing.page_mm.unwrap_or((0.0, 0.0));
            let mut papers = device.papers.to_vec();
            papers.sort_by_key(|s| !plotter_path::geometry::bed::is_sheet(s, w, h));
            papers
        }
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

    /// The estimated plotter time of the commands sent and not yet certainly parsed, and of `more` commands
    /// after them (the one being sent).
    fn work_ahead(&self, more: usize) -> Duration {
        let at = |k: usize| if k == 0 { 0.0 } else { self.cmds.list[k.min(self.cmds.list.len()) - 1].seconds_after };
        Duration::from_secs_f64((at(self.accepted + more) - at(self.executed)).clamp(0.0, 1e9))
    }

    /// How long the plotter may take to parse everything sent ([`patience`] of its estimated time).
    fn wait(&self) -> Duration {
        patience(self.work_ahead(0))
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
        // What the plotter had certainly parsed stands in the journal: a resume starts there.
        if let Some(j) = run.journal.as_mut() {
            let _ = j.record(run.accepted, run.executed, 0);
        }
        let after =
            format!("the plot stopped after command {} of {}{note}{}", run.executed, cmds.list.len(), run.hint());
        // A stop stays a stop (its cause named first; the exit status and the web app tell it from a failure).
        if let Some(stopped) = e.downcast_ref::<Stopped>() {
            return Err(Stopped { cause: stopped.cause, doing: format!("{}; {after}", stopped.doing) }.into());
        }
        let e = format!("{e:#}");
        return Err(match e.starts_with(&s.name) {
            true => anyhow::anyhow!("{e}; {after}"),
            false => anyhow::anyhow!("{}: {e}; {after}", s.name),
        });
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
            s.send_guarded(p.as_bytes(), &mut |_| events.stop_requested())?;
        }
    }
    let start_off = if from == 0 { 0 } else { run.ends[from - 1] };
    run.base = i64::try_from(s.sent_bytes()).unwrap_or(i64::MAX) - i64::try_from(start_off).unwrap_or(0);
    run.report(events)?;
    let mut last_check = s.sent_bytes();
    let mut pause_asked = false;
    let mut next_poll = s.link.now();
    for k in from..total {
        if let Some(cause) = events.stop_requested() {
            let doing = format!("plotting on {} (before command {} of {total})", s.name, k + 1);
            return Err(Stopped { cause, doing }.into());
        }
        if pause_asked || events.pause_requested().is_some() {
            pause_asked = false;
            pause(s, run, k, events)?;
        }
        s.set_work_ahead(run.work_ahead(1));
        // A pause asked while waiting for room comes at the next command, unless the plotter withholds room for
        // longer than what it holds should take: it cannot pause, so that is a stop.
        let grace = run.work_ahead(1) + PAUSE_GRACE;
        let mut told = false;
        let mut guard = |w: Waiting| {
            if let Some(c) = events.stop_requested() {
                return Some(c);
            }
            if events.pause_requested().is_some() {
                if pause_asked {
                    // Asked again before the first could be taken: a stop.
                    return Some(StopCause::Interrupt);
                }
                pause_asked = true;
            }
            // Said once the wait is longer than an ordinary one (a command running out).
            if let Waiting::Room { stalled } = w
                && pause_asked
                && !told
                && stalled >= PAUSE_GRACE / 2
            {
                told = true;
                events.notice(&format!(
                    "pause asked: the plotter has taken no byte for {:.0} s; if it takes none within {:.0} s it \
                     cannot pause and the plot is stopped (ESC . K, pen up). Ctrl-C again stops now.",
                    stalled.as_secs_f64(),
                    grace.saturating_sub(stalled).as_secs_f64()
                ));
            }
            match w {
                Waiting::Room { stalled } if pause_asked && stalled >= grace => Some(StopCause::Interrupt),
                _ => None,
            }
        };
        s.send_guarded(cmds.list[k].text.as_bytes(), &mut guard)?;
        run.accepted = k + 1;
        // Under escb every query tells how far the plotter is; under the other handshakes ask now and then, so
        // that progress and the journal (where a resume starts) follow the plotter.
        if s.handshake != Handshake::Escb && s.link.now() >= next_poll {
            s.poll_space(&mut guard)?;
            next_poll = s.link.now() + DRAIN_POLL;
        }
        if s.sent_bytes() - last_check >= CHECK_BYTES {
            s.set_work_ahead(run.work_ahead(0));
            s.check_guarded(run.wait(), &mut guard)?;
            last_check = s.sent_bytes();
        }
        run.executed = run.executed_of(s.parsed_bytes()).clamp(run.executed, run.accepted);
        run.report(events)?;
    }
    finish(s, run, events)
}

/// The guard of the waits once everything is sent: any stop, and a pause request too (the program sits in the
/// plotter's buffer: it cannot pause, only abort).
fn end_guard(events: &mut dyn PlotEvents, _: Waiting) -> Option<StopCause> {
    events.stop_requested().or_else(|| events.pause_requested().map(|_| StopCause::Interrupt))
}

/// The end of a plot: wait until the plotter has parsed everything (asking `ESC . B` every [`DRAIN_POLL`],
/// reporting progress), then read its errors (`OE` answers once the last command has run). Bounded by
/// [`patience`] of the estimated time left, interruptible by a stop or a pause request.
fn finish<L: HpglLink>(s: &mut HpglSession<L>, run: &mut Run<'_>, events: &mut dyn PlotEvents) -> anyhow::Result<()> {
    let total = run.cmds.list.len();
    let work = run.work_ahead(0);
    let limit = patience(work);
    let what = format!(
        "the plotter to draw the {} commands left in its buffer (about {:.0} s)",
        run.accepted - run.executed,
        work.as_secs_f64()
    );
    let mut wait = Wait::new(&s.name, what, s.link.now(), limit);
    while s.parsed_bytes() < s.sent_bytes() {
        match wait.next(s.link.now(), DRAIN_POLL) {
            Ok(slice) => s.listen(slice, &mut |w| end_guard(events, w))?,
            Err(WaitError::TimedOut { .. }) => bail!(
                "{}: the plotter still held {} bytes after {:.0} s, though what it held should take about {:.0} s                  (1.5 × that + {:.0} s allowed); is it paused (its front-panel pause) or out of paper?",
                s.name,
                s.sent_bytes() - s.parsed_bytes(),
                limit.as_secs_f64(),
                work.as_secs_f64(),
                crate::link::hpgl::timing::PATIENCE_MARGIN.as_secs_f64()
            ),
            Err(e) => return Err(e.into()),
        }
        s.poll_space(&mut |w| end_guard(events, w))?;
        run.executed = run.executed_of(s.parsed_bytes()).clamp(run.executed, run.accepted);
        run.report(events)?;
    }
    // The last command may still be running: OE answers once it has.
    let last = match run.cmds.list.as_slice() {
        [.., a, b] => b.seconds_after - a.seconds_after,
        [b] => b.seconds_after,
        [] => 0.0,
    };
    s.set_work_ahead(Duration::from_secs_f64(last.clamp(0.0, 1e9)));
    s.check_guarded(s.stall_limit(), &mut |w| end_guard(events, w))?;
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
    // A plotter that withholds room past what it holds cannot take the park either: the pause becomes a stop.
    s.set_work_ahead(run.work_ahead(0));
    let grace = run.work_ahead(0) + PAUSE_GRACE;
    // Another pause request while parking (a second Ctrl-C) is a stop.
    let mut guard = |w: Waiting| {
        events.stop_requested().or_else(|| {
            let again = events.pause_requested().is_some();
            (again || matches!(w, Waiting::Room { stalled } if stalled >= grace)).then_some(StopCause::Interrupt)
        })
    };
    s.send_guarded(format!("PU;PU{},{};", park.0, park.1).as_bytes(), &mut guard)?;
    s.set_work_ahead(run.work_ahead(0));
    s.check_guarded(run.wait(), &mut guard)?;
    // Only the park commands are past command k − 1.
    run.executed = k;
    run.report(events)?;
    match events.paused(false) {
        PauseChoice::Resume => {
            let st = run.cmds.list[k].before;
            let back = format!("PU{},{};{}", st.pos.0, st.pos.1, if st.down { "PD;" } else { "" });
            s.send_guarded(back.as_bytes(), &mut |_| events.stop_requested())?;
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

    use crate::link::hpgl::model::{HpglModel, Lie, ModelConfig};
    use crate::link::hpgl::model_link::ModelLink;
    use plotter_path::geometry::hpgl_devices::device;

    /// A 100 mm square at 2 cm/s (20 s of drawing): 101 bytes, all in the 1024-byte buffer within 0.2 s.
    const SQUARE: &str = "IN;PU;SP1;VS2;PU1000,1000;PD5000,1000,5000,5000,1000,5000,1000,1000;PU;SP0;";

    /// A front end that asks for a stop (or a pause) once `after` commands were accepted (and, with `stuck`, once
    /// it is asked that many times without progress: the plot is waiting), counting the pauses asked.
    struct Asks {
        after: usize,
        stop: Option<StopCause>,
        pause: bool,
        accepted: usize,
        asked: usize,
        stuck: usize,
        unchanged: usize,
        /// Ask for a pause again at every question once due (a second Ctrl-C, the web app's cancel).
        again: bool,
    }

    impl Asks {
        fn new(after: usize, stop: Option<StopCause>, pause: bool) -> Asks {
            Asks { after, stop, pause, accepted: 0, asked: 0, stuck: 0, unchanged: 0, again: false }
        }
    }

    impl PlotEvents for Asks {
        fn progress(&mut self, p: &JobProgress) {
            self.accepted = p.accepted;
            self.unchanged = 0;
        }
        fn stop_requested(&mut self) -> Option<StopCause> {
            self.stop.filter(|_| self.accepted >= self.after)
        }
        fn pause_requested(&mut self) -> Option<bool> {
            self.unchanged += 1;
            let due = self.pause && self.accepted >= self.after && self.unchanged >= self.stuck;
            self.asked += usize::from(due);
            self.pause &= !due || self.again;
            due.then_some(false)
        }
    }

    fn run(lie: Option<(Lie, u64)>, program: &str, events: &mut Asks) -> (HpglSession<ModelLink>, String) {
        let d = device("7475a").unwrap();
        let mut model = HpglModel::new(ModelConfig::new(d));
        if let Some((lie, from)) = lie {
            model.set_lie(lie, from);
        }
        let mut s = HpglSession::connect(ModelLink::new(model, 9600), "model", d, Handshake::Escb).unwrap();
        let cmds = Commands::split(program, d);
        let paper = d.paper("a4").unwrap();
        let e = plot(&mut s, &cmds, paper, 0, None, None, events).expect_err("the plot is stopped");
        (s, format!("{e:#}"))
    }

    #[test]
    fn a_stop_or_a_pause_after_the_last_byte_aborts_the_buffer_and_lifts_the_pen() {
        let n = Commands::split(SQUARE, device("7475a").unwrap()).list.len();
        let stop = Asks::new(n, Some(StopCause::Terminate), false);
        let pause = Asks::new(n, None, true);
        for (mut events, cause) in [(stop, "SIGTERM"), (pause, "Ctrl-C (SIGINT)")] {
            let (mut s, e) = run(None, SQUARE, &mut events);
            assert!(e.contains(&format!("stopped by {cause} while waiting for")), "{e}");
            assert!(e.contains("stopped with ESC . K") && e.contains("confirmed by OE"), "{e}");
            let t = s.link.now();
            assert!(t < Duration::from_secs(5), "stopped at once, not after the 20 s square: {t:?}");
            s.link.finish(30.0);
            let m = s.link.model();
            assert_eq!(m.stats().aborts, 1);
            assert!(m.pen_up() && m.pen() == 0, "{e}");
            assert!(m.trace().iter().map(Vec::len).sum::<usize>() < 5, "the square was not finished");
        }
    }

    #[test]
    fn the_end_of_a_plot_waits_for_the_plotter_with_progress() {
        // The square plotted to its end: the plot returns when the plotter has drawn it, not when it was sent.
        let d = device("7475a").unwrap();
        let mut s = HpglSession::connect(
            ModelLink::new(HpglModel::new(ModelConfig::new(d)), 9600),
            "model",
            d,
            Handshake::Escb,
        )
        .unwrap();
        let cmds = Commands::split(SQUARE, d);
        let mut events = Asks::new(usize::MAX, None, false);
        let o = plot(&mut s, &cmds, d.paper("a4").unwrap(), 0, None, None, &mut events).unwrap();
        let m = s.link.model();
        assert!(m.idle() && m.pen_up() && m.trace()[0].len() == 5, "drawn to its end before the plot returned");
        assert!(o.seconds > 20.0 && o.seconds < 30.0, "{}", o.seconds);
        assert!(o.stats.space_queries > 20 * 3, "polled during the 20 s drawing: {}", o.stats.space_queries);
    }

    #[test]
    fn a_pause_while_the_plotter_withholds_room_stops_the_plot() {
        // 200 short strokes (about 2.4 KB): the plotter stops taking bytes after 300 of them.
        let mut program = String::from("IN;SP1;");
        for i in 0..200 {
            program.push_str(&format!("PU{},1000;PD{},1100;", 1000 + 10 * i, 1000 + 10 * i));
        }
        program.push_str("PU;SP0;");
        // The pause is asked during the wait (ten asks without progress).
        let mut events = Asks { stuck: 10, ..Asks::new(0, None, true) };
        let (mut s, e) = run(Some((Lie::NoRoom, 300)), &program, &mut events);
        assert_eq!(events.asked, 1);
        assert!(e.contains("stopped by Ctrl-C (SIGINT) while waiting for room"), "{e}");
        assert!(s.link.now() < Duration::from_secs(30), "within the grace, not 300 s: {:?}", s.link.now());
        s.link.finish(30.0);
        let m = s.link.model();
        assert!(m.pen_up() && m.stats().aborts == 1, "{e}");
        let stalled_at = s.link.now();
        // Asked twice (Ctrl-C again): a stop at once, not after the grace.
        let mut events = Asks { stuck: 10, again: true, ..Asks::new(0, None, true) };
        let (s, e) = run(Some((Lie::NoRoom, 300)), &program, &mut events);
        assert!(e.contains("stopped by Ctrl-C (SIGINT) while waiting for"), "{e}");
        assert!(s.link.now() + PAUSE_GRACE < stalled_at, "{:?} {stalled_at:?}", s.link.now());
        // Asked between two commands just before the plotter stops taking bytes: the park cannot be sent.
        let stuck_at = events.accepted;
        let mut events = Asks::new(stuck_at, None, true);
        let (mut s, e) = run(Some((Lie::NoRoom, 300)), &program, &mut events);
        assert!(e.contains("stopped by Ctrl-C (SIGINT) while waiting for room"), "{e}");
        assert!(s.link.now() < Duration::from_secs(30), "{:?}", s.link.now());
        s.link.finish(30.0);
        assert!(s.link.model().pen_up() && s.link.model().stats().aborts == 1, "{e}");
    }

    /// Segments drawn by a model, whichever polyline they belong to.
    fn segments(m: &HpglModel) -> std::collections::HashSet<((i32, i32), (i32, i32))> {
        m.trace().iter().flat_map(|l| l.windows(2).map(|w| (w[0], w[1]))).collect()
    }

    /// Stops at 20 points of a plot for each way of asking (SIGTERM, SIGHUP, a pause the front end then aborts):
    /// the model ends with the pen up and one abort every time, and the journal resumes the plot on a plotter
    /// switched on afresh, the two runs together drawing every segment.
    #[test]
    fn a_stop_anywhere_lifts_the_pen_and_the_journal_resumes() {
        let d = device("7475a").unwrap();
        let paper = d.paper("a4").unwrap();
        let mut program = String::from("IN;SP1;VS20;");
        for i in 0..12 {
            program.push_str(&format!("PU{},1000;PD{},2000,{},2000;", 1000 + 300 * i, 1000 + 300 * i, 1200 + 300 * i));
        }
        program.push_str("PU;SP0;");
        let cmds = Commands::split(&program, d);
        let fresh = || {
            let model = HpglModel::new(ModelConfig { device: d, buffer: 60, xon_xoff: true });
            HpglSession::connect(ModelLink::new(model, 9600), "model", d, Handshake::Escb).unwrap()
        };
        let mut whole = fresh();
        plot(&mut whole, &cmds, paper, 0, None, None, &mut Asks::new(usize::MAX, None, false)).unwrap();
        let want = segments(whole.link.model());
        assert_eq!(want.len(), 24);
        let dir = std::env::temp_dir().join(format!("plotter-hpgl-stops-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mut seed = 0x2545_f491_4f6c_dd1d_u64;
        let mut resumed_from = std::collections::BTreeSet::new();
        for round in 0..60 {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            let asks = usize::try_from(seed % 400).unwrap();
            let (stop, pause) = match round % 3 {
                0 => (Some(StopCause::Terminate), false),
                1 => (Some(StopCause::Hangup), false),
                _ => (None, true),
            };
            // The stop comes at the `asks`-th question the plot asks its front end.
            struct At(Asks, usize);
            impl PlotEvents for At {
                fn progress(&mut self, p: &JobProgress) {
                    self.0.progress(p);
                }
                fn stop_requested(&mut self) -> Option<StopCause> {
                    self.1 = self.1.saturating_sub(1);
                    self.0.stop.filter(|_| self.1 == 0)
                }
                fn pause_requested(&mut self) -> Option<bool> {
                    (self.0.pause && self.1 == 0).then(|| {
                        self.0.pause = false;
                        false
                    })
                }
            }
            let path = dir.join(format!("{round}.journal"));
            let journal = Journal::create(&path, "{}", program_hash(&program), cmds.list.len()).unwrap();
            let mut s = fresh();
            let mut events = At(Asks::new(0, stop, pause), asks.max(1));
            let e = plot(&mut s, &cmds, paper, 0, Some(journal), Some(&path), &mut events);
            let Err(e) = e else {
                assert!(asks > 150, "round {round}: only a late stop finds the plot over ({asks} asks)");
                continue;
            };
            let e = format!("{e:#}");
            s.link.finish(60.0);
            let first = s.link.model();
            assert!(first.pen_up() && first.stats().aborts == 1, "round {round}: {e}");
            let state = crate::link::journal::load(&path).unwrap();
            assert!(!state.complete, "round {round}");
            let from = resume_point(state.executed, &cmds);
            resumed_from.insert(from);
            let journal = Journal::append(&path, &state).unwrap();
            let mut again = fresh();
            let mut events = Asks::new(usize::MAX, None, false);
            plot(&mut again, &cmds, paper, from, Some(journal), Some(&path), &mut events).unwrap();
            assert!(crate::link::journal::load(&path).unwrap().complete);
            let mut got = segments(first);
            got.extend(segments(again.link.model()));
            assert_eq!(got, want, "round {round}: stopped with {e}, resumed from command {from}");
        }
        assert!(resumed_from.len() > 10, "stops all over the plot: {resumed_from:?}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
