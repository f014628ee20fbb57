//! Progress of a running plot: the figures a front end shows (blocks, pen-down millimetres, time left, where the
//! pen is) and the journal that lets an interrupted plot resume, kept in step with what the firmware reports.

use plotter_fw::TICK_HZ;
use plotter_path::MachineProfile;
use plotter_path::geometry::steps::{StepMapper, StepPos};
use plotter_path::kurbo::Point;
use plotter_path::motion::plan::{MachinePos, MotionPlan, MoveKind};

use plotter_path::config::pens::LayerPen;

use crate::link::journal::Journal;
use crate::link::stream::{Control, PauseChoice, Progress};

/// Whether the plot stops between layers drawn with different pens.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum PenChangeMode {
    /// Park with the pen up and wait for the user at every pen change.
    Pause,
    /// Plot straight through (one pen, or a machine with a tool changer of its own).
    #[default]
    None,
}

/// A pen change the plot is waiting for.
#[derive(Debug, Clone, PartialEq)]
pub struct PenChangeRequest {
    /// Index of the layer about to be drawn.
    pub layer: usize,
    /// Its name.
    pub layer_name: String,
    /// The pen to load.
    pub pen: LayerPen,
    /// The pen in the machine before (none when a resumed plot starts).
    pub previous: Option<LayerPen>,
    /// 1-based number of this change, of `total`.
    pub number: usize,
    /// Pen changes in the plot.
    pub total: usize,
    /// Where the carriage waits, machine mm (X, Y).
    pub park_mm: (f64, f64),
}

/// What the user decided at a pen change.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PenChangeChoice {
    /// The pen is loaded: draw the layer.
    Continue,
    /// Skip the layer (every layer up to the next pen change) and go on with the next pen change.
    SkipLayer,
    /// Stop here and keep the journal: `--resume` continues with this layer.
    Stop,
}

/// What a front end is told as the plot advances.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JobProgress {
    /// Blocks of this run's plan certainly executed by the machine.
    pub executed: usize,
    /// Blocks accepted by the firmware (queued or executed).
    pub accepted: usize,
    /// Blocks in this run's plan.
    pub total: usize,
    /// Pen-down millimetres drawn so far (of this run's plan).
    pub draw_done_mm: f64,
    /// Pen-down millimetres of this run's plan.
    pub draw_total_mm: f64,
    /// Planned time left, seconds.
    pub eta_s: f64,
    /// Resend requests acted on so far.
    pub resends: u64,
    /// Where the pen is, page millimetres: the end of the last executed block, taken from the plan (no traffic).
    pub pen_mm: Point,
    /// Whether the pen is down there (the last executed pen move lowered it).
    pub pen_down: bool,
}

/// `seconds` as `h:mm:ss` (rounded to the second; negative or not a number: `0:00:00`), the way a person reads a
/// time left: `0:00:00`, `0:01:05`, `2:00:00`, `27:46:40`.
pub fn hms(seconds: f64) -> String {
    let s = if seconds.is_finite() && seconds > 0.0 { seconds.round() } else { 0.0 };
    // Rounded, non-negative, and below 2^64 for any plot (u64::MAX seconds is longer than the universe).
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let s = s.min(9.0e15) as u64;
    format!("{}:{:02}:{:02}", s / 3600, s / 60 % 60, s % 60)
}

impl JobProgress {
    /// Whole per cent of the blocks executed (0 to 100; 100 for an empty plan).
    pub fn percent(&self) -> u32 {
        if self.total == 0 {
            return 100;
        }
        let p = self.executed.min(self.total).saturating_mul(100) / self.total;
        u32::try_from(p).unwrap_or(100)
    }

    /// One line for a person: per cent done, time left (h:mm:ss), pen-down millimetres drawn of the total, the
    /// pen (up or down) and where it is, and resends when there were any. With `width` (a terminal's columns) a
    /// bar comes first and the line fits in `width - 1` columns (never reaching the last column, so it never
    /// wraps): the least useful figures are left out first — resends, the pen, the bar, the millimetres, the time
    /// — and the per cent is always there. Without `width` (a log), no bar and every figure.
    pub fn line(&self, width: Option<usize>) -> String {
        const BAR: usize = 20;
        let pct = self.percent();
        let mut fields: Vec<(u8, String)> = Vec::with_capacity(6);
        if width.is_some() {
            let full = usize::try_from(pct).unwrap_or(100) * BAR / 100;
            fields.push((3, format!("[{}{}]", "#".repeat(full), "-".repeat(BAR - full))));
        }
        fields.push((0, format!("{pct:>3}%")));
        fields.push((1, format!("{} left", hms(self.eta_s))));
        fields.push((2, format!("pen-down {:.0}/{:.0} mm", self.draw_done_mm, self.draw_total_mm)));
        let pen = if self.pen_down { "down" } else { "up" };
        fields.push((4, format!("pen {pen} at X {:.1} Y {:.1} mm", self.pen_mm.x, self.pen_mm.y)));
        if self.resends > 0 {
            fields.push((5, format!("{} resends", self.resends)));
        }
        let join = |f: &[(u8, String)]| f.iter().map(|(_, t)| t.as_str()).collect::<Vec<_>>().join("  ");
        let Some(width) = width else { return join(&fields) };
        let room = width.saturating_sub(1);
        loop {
            let line = join(&fields);
            if line.chars().count() <= room {
                return line;
            }
            match fields.iter().enumerate().filter(|(_, (rank, _))| *rank > 0).max_by_key(|(_, (rank, _))| *rank) {
                Some((i, _)) => {
                    fields.remove(i);
                }
                None => return line.chars().take(room).collect(),
            }
        }
    }
}

/// When a log (not a terminal) gets a progress line: each time the plot passes another 5 % of its blocks, and
/// at its end, once each.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct LogCadence {
    /// The per cent already logged (`None` before the first line).
    logged: Option<u32>,
}

impl LogCadence {
    /// Whether `p` deserves a line: its per cent reached a multiple of 5 past the last one logged (a jump over
    /// several gives one line).
    pub fn due(&mut self, p: &JobProgress) -> bool {
        let step = p.percent() / 5 * 5;
        if p.executed == 0 || self.logged.is_some_and(|l| step <= l) || (step == 0 && p.percent() < 100) {
            return false;
        }
        self.logged = Some(step);
        true
    }
}

/// A front end's side of a plot job: it sees progress and decides about pauses.
pub trait PlotEvents {
    /// The plot advanced.
    fn progress(&mut self, p: &JobProgress);
    /// Whether a pause was requested since the last call; `Some(true)` = at once (feed hold, pen stays where it
    /// is), `Some(false)` = at the next pen-up.
    fn pause_requested(&mut self) -> Option<bool> {
        None
    }
    /// The machine is paused (`held`: feed hold, else pen up); resume or abort?
    fn paused(&mut self, _held: bool) -> PauseChoice {
        PauseChoice::Abort
    }
    /// Whether the plot stops for pen changes (the default front end plots straight through).
    fn pen_change_mode(&self) -> PenChangeMode {
        PenChangeMode::None
    }
    /// The plot stands parked with the pen up, waiting for the user to load `change.pen`.
    fn pen_change(&mut self, _change: &PenChangeRequest) -> PenChangeChoice {
        PenChangeChoice::Continue
    }
    /// The plot stands parked with the pen up for `pause` (a layer's `!`, a refill, fresh paper between copies):
    /// go on, or stop (a skip counts as going on). The default front end goes on at once.
    fn plot_pause(&mut self, _pause: &super::stops::PauseRequest) -> PenChangeChoice {
        PenChangeChoice::Continue
    }
    /// The plot starts with `first_pen` and has `pen_changes` pen changes ahead.
    fn plot_started(&mut self, _first_pen: &LayerPen, _pen_changes: usize) {}
    /// The machine reports an alarm (`what`); may it be unlocked (`$X` on GRBL)? The position may be wrong
    /// after some alarms, so the default is no.
    fn unlock_alarm(&mut self, _what: &str) -> bool {
        false
    }
    /// Something the user should know now, while the plot runs (a feed hold the controller reports, and how to
    /// get out of it).
    fn notice(&mut self, _text: &str) {}
    /// Whether the plot must stop now, with the pen up and the journal kept (by default: whether the process was
    /// asked to, see [`crate::stop`]).
    fn stop_requested(&mut self) -> Option<crate::stop::StopCause> {
        crate::stop::Stop::process().stop_cause()
    }
}

/// Cumulative pen-down millimetres after each block of `plan`.
fn cumulative_draw(plan: &MotionPlan, mapper: &StepMapper) -> Vec<f64> {
    let mut acc = 0.0;
    plan.blocks
        .iter()
        .map(|b| {
            if b.kind == MoveKind::Draw {
                acc += mapper.steps_to_machine(StepPos::new(b.block.steps[0], b.block.steps[1])).to_vec2().hypot();
            }
            acc
        })
        .collect()
}

/// The whole plot around a streamed part: its blocks, its pen-down millimetres (cumulative per block, and in
/// all), and the planned ticks after the part's last block.
struct Whole {
    total: usize,
    draw_mm: Vec<f64>,
    total_draw: f64,
    after_part: u64,
}

/// Turns the stream's raw progress into [`JobProgress`] for the front end and keeps the journal up to date.
pub(crate) struct Tracker<'a> {
    events: &'a mut dyn PlotEvents,
    pub(crate) journal: Option<Journal>,
    /// Cumulative pen-down mm after each block.
    draw_mm: Vec<f64>,
    /// Remaining planned time after each block, ticks.
    remaining: Vec<u64>,
    /// Where the plan starts, page mm.
    start_mm: Point,
    /// Pen position (page mm) and whether it is down after each block.
    pen_at: Vec<(Point, bool)>,
    total_draw: f64,
    resumed_from: usize,
    preamble: usize,
    /// The whole plot this part belongs to (see [`Tracker::within`]).
    whole: Option<Whole>,
    /// The first journal error: the plot stops on it (a plot whose journal cannot be written cannot resume).
    pub(crate) error: Option<anyhow::Error>,
}

impl<'a> Tracker<'a> {
    /// A tracker for `plan`, reporting to `events` and recording in `journal`.
    pub(crate) fn new(
        plan: &MotionPlan,
        profile: &MachineProfile,
        journal: Option<Journal>,
        events: &'a mut dyn PlotEvents,
    ) -> Self {
        let n = plan.blocks.len();
        let mapper = StepMapper::new(profile);
        let draw_mm = cumulative_draw(plan, &mapper);
        let acc = draw_mm.last().copied().unwrap_or(0.0);
        let on_page = |p: MachinePos| mapper.steps_to_page(StepPos::new(p[0], p[1]));
        // Plans begin with the pen up (a first pen move lifts it when it is not).
        let mut down = false;
        let pen_at = plan
            .blocks
            .iter()
            .zip(plan.positions())
            .map(|(b, p)| {
                match b.kind {
                    MoveKind::PenDown => down = true,
                    MoveKind::PenUp => down = false,
                    MoveKind::Settle | MoveKind::Travel | MoveKind::Draw => {}
                }
                (on_page(p), down)
            })
            .collect();
        let mut remaining = vec![0u64; n];
        let mut r = 0u64;
        for (i, b) in plan.blocks.iter().enumerate().rev() {
            remaining[i] = r;
            r += u64::from(b.block.duration_ticks());
        }
        Tracker {
            events,
            journal,
            draw_mm,
            remaining,
            start_mm: on_page(plan.start),
            pen_at,
            total_draw: acc,
            resumed_from: plan.resumed_from,
            preamble: plan.preamble,
            whole: None,
            error: None,
        }
    }

    /// Report the figures of the whole plot `full` (the original plan) instead of this part's: blocks done of all
    /// of them, pen-down millimetres of the whole drawing, the time left to the plot's end (this part's, then the
    /// plan's after it) — so that a plot cut at pen changes, or resumed, counts towards its end, not the next stop.
    pub(crate) fn within(mut self, full: &MotionPlan, profile: &MachineProfile) -> Self {
        let draw_mm = cumulative_draw(full, &StepMapper::new(profile));
        let part_end = (self.resumed_from + self.draw_mm.len().saturating_sub(self.preamble)).min(full.blocks.len());
        let after_part = full.blocks[part_end..].iter().map(|b| u64::from(b.block.duration_ticks())).sum();
        self.whole = Some(Whole {
            total: full.blocks.len(),
            total_draw: draw_mm.last().copied().unwrap_or(0.0),
            draw_mm,
            after_part,
        });
        self
    }

    /// Blocks of the original (un-resumed) plan done once `frames` frames of this run are (the number of the
    /// original block the `frames`-th frame is).
    fn original(&self, frames: usize) -> usize {
        self.resumed_from + frames.saturating_sub(self.preamble)
    }
}

impl Control for Tracker<'_> {
    fn progress(&mut self, p: &Progress) {
        let i = p.executed.saturating_sub(1);
        let left = if p.executed == 0 { self.remaining.first().copied() } else { self.remaining.get(i).copied() };
        // Tick counts far below 2^53: exact in f64.
        #[allow(clippy::cast_precision_loss)]
        let eta_s = left.unwrap_or(0) as f64 / f64::from(TICK_HZ);
        let (pen_mm, pen_down) = if p.executed == 0 {
            (self.start_mm, false)
        } else {
            self.pen_at.get(i).or(self.pen_at.last()).copied().unwrap_or((self.start_mm, false))
        };
        let mut shown = JobProgress {
            executed: p.executed,
            accepted: p.accepted,
            total: self.draw_mm.len(),
            draw_done_mm: if p.executed == 0 { 0.0 } else { self.draw_mm.get(i).copied().unwrap_or(self.total_draw) },
            draw_total_mm: self.total_draw,
            eta_s,
            resends: p.resends,
            pen_mm,
            pen_down,
        };
        if let Some(w) = &self.whole {
            let (executed, accepted) = (self.original(p.executed).min(w.total), self.original(p.accepted).min(w.total));
            // Tick counts far below 2^53: exact in f64.
            #[allow(clippy::cast_precision_loss)]
            let after_s = w.after_part as f64 / f64::from(TICK_HZ);
            shown = JobProgress {
                executed,
                accepted,
                total: w.total,
                draw_done_mm: executed.checked_sub(1).and_then(|k| w.draw_mm.get(k).copied()).unwrap_or(0.0),
                draw_total_mm: w.total_draw,
                eta_s: eta_s + after_s,
                ..shown
            };
        }
        self.events.progress(&shown);
        let (a, e) = (self.original(p.accepted), self.original(p.executed));
        // The journal pairs a block number with the sequence number after it; during a resume preamble that is
        // the number the firmware will have once the preamble is through.
        let pending = u32::try_from(self.preamble.saturating_sub(p.accepted)).unwrap_or(u32::MAX);
        let seq = p.seq_after_accepted.wrapping_add(pending);
        if let Some(j) = self.journal.as_mut()
            && self.error.is_none()
            && let Err(err) = j.record(a, e, seq)
        {
            self.error = Some(err);
        }
    }

    fn pause_requested(&mut self) -> Option<bool> {
        self.events.pause_requested()
    }

    fn paused(&mut self, held: bool) -> PauseChoice {
        self.events.paused(held)
    }

    fn notice(&mut self, text: &str) {
        self.events.notice(text);
    }

    fn stop_requested(&mut self) -> Option<crate::stop::StopCause> {
        self.events.stop_requested()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use plotter_path::geometry::steps::drawing_to_steps;
    use plotter_path::motion::plan::{Lookahead, homed_position, plan};
    use plotter_path::{Drawing, Polyline};

    /// Keeps the last progress it was told.
    #[derive(Default)]
    struct Last(Option<JobProgress>);

    impl PlotEvents for Last {
        fn progress(&mut self, p: &JobProgress) {
            self.0 = Some(*p);
        }
    }

    fn progress(executed: usize, total: usize) -> JobProgress {
        JobProgress {
            executed,
            accepted: executed,
            total,
            draw_done_mm: 120.4,
            draw_total_mm: 300.0,
            eta_s: 754.4,
            resends: 0,
            pen_mm: Point::new(10.0, 20.24),
            pen_down: true,
        }
    }

    #[test]
    fn hours_minutes_seconds() {
        assert_eq!(hms(0.0), "0:00:00");
        assert_eq!(hms(0.4), "0:00:00");
        assert_eq!(hms(59.5), "0:01:00");
        assert_eq!(hms(65.0), "0:01:05");
        assert_eq!(hms(2484.0), "0:41:24");
        assert_eq!(hms(3600.0), "1:00:00");
        assert_eq!(hms(100_000.0), "27:46:40");
        assert_eq!(hms(-3.0), "0:00:00");
        assert_eq!(hms(f64::NAN), "0:00:00");
    }

    #[test]
    fn the_line_fits_the_width_by_leaving_figures_out() {
        let p = progress(42, 100);
        let full = "[########------------]   42%  0:12:34 left  pen-down 120/300 mm  pen down at X 10.0 Y 20.2 mm";
        assert_eq!(p.line(Some(200)), full);
        assert_eq!(p.line(Some(full.len() + 1)), full);
        // One column less: the pen goes first.
        assert_eq!(p.line(Some(full.len())), "[########------------]   42%  0:12:34 left  pen-down 120/300 mm");
        assert_eq!(p.line(Some(80)), "[########------------]   42%  0:12:34 left  pen-down 120/300 mm");
        assert_eq!(p.line(Some(60)), " 42%  0:12:34 left  pen-down 120/300 mm");
        assert_eq!(p.line(Some(40)), " 42%  0:12:34 left  pen-down 120/300 mm");
        assert_eq!(p.line(Some(39)), " 42%  0:12:34 left");
        assert_eq!(p.line(Some(10)), " 42%");
        assert_eq!(p.line(Some(3)), " 4");
        assert_eq!(p.line(Some(0)), "");
        for w in 0..200 {
            assert!(p.line(Some(w)).chars().count() < w.max(1), "width {w}");
        }
        // Resends, when there are any, are the first to go.
        let r = JobProgress { resends: 3, ..progress(100, 100) };
        assert_eq!(r.line(None), "100%  0:12:34 left  pen-down 120/300 mm  pen down at X 10.0 Y 20.2 mm  3 resends");
        assert_eq!(
            r.line(Some(100)),
            "[####################]  100%  0:12:34 left  pen-down 120/300 mm  pen down at X 10.0 Y 20.2 mm"
        );
        assert_eq!(progress(0, 0).percent(), 100);
    }

    #[test]
    fn a_log_gets_a_line_every_five_per_cent_and_at_the_end() {
        let mut c = LogCadence::default();
        let logged: Vec<usize> = (0..=1000).filter(|&e| c.due(&progress(e, 1000))).collect();
        let every_50: Vec<usize> = (1..=20).map(|k| k * 50).collect();
        assert_eq!(logged, every_50);
        // Jumps log once; a plan of 7 blocks logs at each block past a multiple of 5 %, and its end.
        let mut c = LogCadence::default();
        let logged: Vec<usize> = [0, 3, 40, 41, 97, 100].into_iter().filter(|&e| c.due(&progress(e, 100))).collect();
        assert_eq!(logged, [40, 97, 100]);
        let mut c = LogCadence::default();
        let logged: Vec<usize> = (0..=7).filter(|&e| c.due(&progress(e, 7))).collect();
        assert_eq!(logged, [1, 2, 3, 4, 5, 6, 7]);
    }

    #[test]
    fn a_part_reports_the_whole_plot() {
        let profile = MachineProfile::default_plotter();
        let line = |a: (f64, f64), b: (f64, f64)| Polyline::new(vec![Point::new(a.0, a.1), Point::new(b.0, b.1)]);
        let d = Drawing::single_layer("a", vec![line((5.0, 10.0), (35.0, 10.0)), line((35.0, 20.0), (5.0, 20.0))]);
        let steps = drawing_to_steps(&profile, &d).unwrap();
        let full = plan(&profile, &steps, homed_position(&profile).unwrap(), Lookahead::Whole).unwrap();
        // The first five blocks (travel, drop, settle, the first line, the lift) streamed as a part of their own,
        // as at a pen change: at each block it must say what the whole plan says there.
        let mut part = full.clone();
        part.blocks.truncate(5);
        for executed in 0..=5 {
            let at = |plan: &MotionPlan, whole: bool| {
                let mut last = Last::default();
                let tracker = Tracker::new(plan, &profile, None, &mut last);
                let mut tracker = if whole { tracker.within(&full, &profile) } else { tracker };
                tracker.progress(&Progress { accepted: 5, executed, seq_after_accepted: 5, resends: 0 });
                last.0.expect("progress reported")
            };
            let (whole, alone, reference) = (at(&part, true), at(&part, false), at(&full, false));
            assert_eq!((whole.executed, whole.total), (executed, 12));
            assert_eq!(whole.draw_total_mm, 60.0);
            assert_eq!(whole.draw_done_mm, reference.draw_done_mm, "after {executed}");
            assert!((whole.eta_s - reference.eta_s).abs() < 1e-9, "{} {}", whole.eta_s, reference.eta_s);
            // Alone, the part counts to its own end.
            assert_eq!((alone.total, alone.draw_total_mm), (5, 30.0));
        }
    }

    #[test]
    fn the_pen_is_at_the_end_of_the_last_executed_block() {
        let profile = MachineProfile::default_plotter();
        let line = |a: (f64, f64), b: (f64, f64)| Polyline::new(vec![Point::new(a.0, a.1), Point::new(b.0, b.1)]);
        let d = Drawing::single_layer("a", vec![line((5.0, 10.0), (35.0, 10.0)), line((35.0, 20.0), (5.0, 20.0))]);
        let steps = drawing_to_steps(&profile, &d).unwrap();
        let plan = plan(&profile, &steps, homed_position(&profile).unwrap(), Lookahead::Whole).unwrap();
        // Travel, drop, settle, line; the rise to the clearance and the hop in two travel blocks (climbing, then
        // descending), drop, settle, line; the last lift and its settle.
        use MoveKind::*;
        let kinds: Vec<MoveKind> = plan.blocks.iter().map(|b| b.kind).collect();
        assert_eq!(kinds, [Travel, PenDown, Settle, Draw, PenUp, Travel, Travel, PenDown, Settle, Draw, PenUp, Settle]);
        // After block k (1-based count of executed blocks): where the pen is on the page and whether it is down.
        let expected = [
            (0, (0.0, 0.0), false),
            (1, (5.0, 10.0), false),
            (2, (5.0, 10.0), true),
            (3, (5.0, 10.0), true),
            (4, (35.0, 10.0), true),
            (5, (35.0, 10.0), false),
            (7, (35.0, 20.0), false),
            (10, (5.0, 20.0), true),
            (12, (5.0, 20.0), false),
        ];
        for (executed, (x, y), down) in expected {
            let mut last = Last::default();
            Tracker::new(&plan, &profile, None, &mut last).progress(&Progress {
                accepted: 12,
                executed,
                seq_after_accepted: 12,
                resends: 0,
            });
            let p = last.0.expect("progress reported");
            assert_eq!((p.pen_mm.x, p.pen_mm.y, p.pen_down), (x, y, down), "after {executed} blocks");
        }
    }
}
