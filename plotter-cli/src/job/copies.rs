//! Copies of one plot (`--copies`): the same plan again and again from the same start, with a wait
//! (`--page-delay`, run by the machine as dwells) and a pause for fresh paper (unless `--no-paper-pause`) between
//! them; 0 copies plots until the user stops at a paper change or with a stop signal.

use plotter_path::MachineProfile;
use plotter_path::geometry::steps::StepDrawing;

use super::progress::{PenChangeChoice, PlotEvents};
use super::stops::{PauseRequest, PauseWhy, StopOptions};
use super::{JobOutcome, JournalSpec, dwell, park, plot_with};
use crate::link::machine::PlotMachine;
use crate::options::workflow::Copies;
use crate::state_dir::{COPIES_KEY, COPY_KEY, copy_of};

/// What the copies did.
#[derive(Debug)]
pub struct CopiesOutcome {
    /// Each finished copy, in order.
    pub copies: Vec<JobOutcome>,
    /// Why the copies ended before the count (a stop at a paper change, a stop signal), if they did.
    pub ended_early: Option<String>,
}

impl CopiesOutcome {
    /// The copies for a person (and a webhook's `finished` event): "3 copies plotted, 41.2 s planned", with why
    /// they ended early, if they did.
    pub fn summary(&self) -> String {
        let secs: f64 = self.copies.iter().map(|c| c.plan.seconds()).sum();
        let n = self.copies.len();
        let text = format!("{n} cop{} plotted, {secs:.1} s planned", if n == 1 { "y" } else { "ies" });
        match &self.ended_early {
            Some(why) => format!("{text}; {why}"),
            None => text,
        }
    }
}

/// `source` with the copy being drawn and the plot's copy count recorded in it (a source that is no JSON object
/// is left as it is); [`crate::state_dir::copy_of`] and [`crate::state_dir::copies_left`] read them back.
fn with_copy(source: String, copy: u64, count: u64) -> String {
    match serde_json::from_str::<serde_json::Value>(&source) {
        Ok(serde_json::Value::Object(mut o)) => {
            o.insert(COPY_KEY.into(), copy.into());
            o.insert(COPIES_KEY.into(), count.into());
            serde_json::Value::Object(o).to_string()
        }
        _ => source,
    }
}

/// Whether the plans of a plot with `copies` end back where they started: each copy of several must, to start
/// where the first did (a resume plans the same way to find the same plan).
pub fn returns(return_home: bool, copies: &Copies) -> bool {
    return_home || copies.count != 1
}

/// Plot `steps` as `copies` say: home before the first copy only (when `home`), every copy planned from the
/// same start and back to it (so each draws exactly the same), the page delay and the paper pause between them.
/// The journal (if any) records the copy being drawn, so that a resume goes on with the copies left.
#[allow(clippy::too_many_arguments)]
pub fn plot_copies<M: PlotMachine + ?Sized>(
    machine: &mut M,
    profile: &MachineProfile,
    steps: &StepDrawing,
    home: bool,
    return_home: bool,
    journal: Option<JournalSpec<'_>>,
    stops: &StopOptions,
    copies: &Copies,
    events: &mut dyn PlotEvents,
) -> crate::Result<CopiesOutcome> {
    let from = Copy { number: 1, home, done: Vec::new() };
    copies_from(machine, profile, steps, from, return_home, journal, stops, copies, events)
}

/// Resume a plot of `copies` from its journal (see [`super::resume_with`]; `return_home` as the plot was given
/// it, before [`returns`]): finish the copy the journal was drawing, then plot the copies left, with the page
/// delay and the paper pause between them as in the plot.
#[allow(clippy::too_many_arguments)]
pub fn resume_copies<M: PlotMachine + ?Sized>(
    machine: &mut M,
    profile: &MachineProfile,
    steps: &StepDrawing,
    start: [i32; 4],
    state: &crate::link::journal::JournalState,
    journal_path: &std::path::Path,
    trust_position: bool,
    return_home: bool,
    stops: &StopOptions,
    copies: &Copies,
    events: &mut dyn PlotEvents,
) -> crate::Result<CopiesOutcome> {
    let number = copy_of(&state.source);
    let back = returns(return_home, copies);
    let first =
        super::resume_with(machine, profile, steps, start, state, journal_path, trust_position, back, stops, events)?;
    // Every copy starts where the first did, so the same source record serves (its copy number is rewritten).
    let source = |_: [i32; 4]| -> anyhow::Result<String> { Ok(state.source.clone()) };
    let spec = JournalSpec { path: journal_path, source: &source };
    // A copy found finished moved nothing, not even home: the next copy homes first (unless the position is
    // trusted).
    let home = first.drawn_before && !trust_position;
    let from = Copy { number: number + 1, home, done: vec![first] };
    copies_from(machine, profile, steps, from, return_home, Some(spec), stops, copies, events)
}

/// Where a run of copies starts: the copy to draw next, whether to home before it, the copies drawn.
struct Copy {
    number: u64,
    home: bool,
    done: Vec<JobOutcome>,
}

/// The copies from `from.number` on (each after the page delay and the paper pause when a copy came before it).
#[allow(clippy::too_many_arguments)]
fn copies_from<M: PlotMachine + ?Sized>(
    machine: &mut M,
    profile: &MachineProfile,
    steps: &StepDrawing,
    from: Copy,
    return_home: bool,
    journal: Option<JournalSpec<'_>>,
    stops: &StopOptions,
    copies: &Copies,
    events: &mut dyn PlotEvents,
) -> crate::Result<CopiesOutcome> {
    let Copy { number: mut copy, mut home, mut done } = from;
    let back = returns(return_home, copies);
    loop {
        if copies.count != 0 && copy > copies.count {
            return Ok(CopiesOutcome { copies: done, ended_early: None });
        }
        if copy > 1 {
            if home {
                // A resume whose journal's copy was finished (stopped between copies): the machine's position is
                // not known, so it homes before it parks for the paper (where a pen left down would draw).
                super::settle_alarm(machine, true, events)?;
                machine.begin()?;
                super::home_for_plot(machine, profile, events)?;
                machine.end()?;
                home = false;
            }
            if let Some(cause) = events.stop_requested() {
                return Ok(CopiesOutcome {
                    copies: done,
                    ended_early: Some(format!("stopped ({cause:?}) between copies")),
                });
            }
            let pen = plotter_path::motion::plan::layer_pens(profile, steps).swap_remove(0);
            let ms = (copies.page_delay_s * 1000.0).round();
            if ms > 0.0 {
                // Checked to lie within 0..=86 400 000 ms by the options.
                #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
                dwell(machine, profile, ms as u32, &pen)?;
            }
            if copies.paper_pause {
                let park_mm = park(machine, profile)?;
                let req = PauseRequest {
                    why: PauseWhy::Paper { copy, copies: copies.count },
                    layer_name: String::new(),
                    pen,
                    park_mm,
                };
                if events.plot_pause(&req) == PenChangeChoice::Stop {
                    let why = format!("stopped at the paper change before copy {copy}");
                    return Ok(CopiesOutcome { copies: done, ended_early: Some(why) });
                }
            }
        }
        let out = match journal {
            Some(j) => {
                let source = |start: [i32; 4]| -> anyhow::Result<String> {
                    Ok(with_copy((j.source)(start)?, copy, copies.count))
                };
                let spec = JournalSpec { path: j.path, source: &source };
                plot_with(machine, profile, steps, home, back, Some(spec), stops, events)?
            }
            None => plot_with(machine, profile, steps, home, back, None, stops, events)?,
        };
        home = false;
        done.push(out);
        copy += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::job::progress::JobProgress;
    use crate::link::session::Session;
    use crate::link::sim::SimTransport;
    use crate::state_dir::copies_left;
    use plotter_path::geometry::steps::drawing_to_steps;
    use plotter_path::kurbo::Point;
    use plotter_path::motion::plan;
    use plotter_path::{Drawing, Polyline};

    /// Answers every pause with `answer`, counting them.
    struct Paper {
        answer: PenChangeChoice,
        asked: Vec<String>,
    }

    impl PlotEvents for Paper {
        fn progress(&mut self, _: &JobProgress) {}
        fn plot_pause(&mut self, p: &PauseRequest) -> PenChangeChoice {
            self.asked.push(p.ask());
            self.answer
        }
    }

    /// A 10 mm square at (20, 20) mm and a 30 mm line below it, plotted as `copies` say on our simulated
    /// firmware: (the copies, the executed ticks after homing, the pen drops).
    fn run(copies: Copies, events: &mut Paper) -> (CopiesOutcome, u64, usize) {
        use crate::link::machine::PlotMachine as _;
        let profile = MachineProfile::default_plotter();
        let p = |x: f64, y: f64| Point::new(x, y);
        let square = Polyline::new(vec![p(20.0, 20.0), p(30.0, 20.0), p(30.0, 30.0), p(20.0, 30.0), p(20.0, 20.0)]);
        let line = Polyline::new(vec![p(20.0, 40.0), p(50.0, 40.0)]);
        let steps = drawing_to_steps(&profile, &Drawing::single_layer("l", vec![square, line])).unwrap();
        let mut s = Session::connect(SimTransport::new(plan::machine_config(&profile).unwrap(), None), "sim").unwrap();
        let out =
            plot_copies(&mut s, &profile, &steps, true, false, None, &StopOptions::default(), &copies, events).unwrap();
        let executed = s.busy_ticks() - out.copies[0].busy_before;
        // The trace starts with the pen down (Z 0) until homing lifts it; then one entry per drop and lift.
        let drops = s.transport.sim().hal().pen_trace().iter().skip(1).filter(|p| p.1).count();
        (out, executed, drops)
    }

    /// Three copies: the same plan three times (each back home, so each starts where the first did), and two
    /// page delays of 0.5 s between them, run by the machine: executed = 3 × the plan + 2 × 500 000 ticks,
    /// exactly; the pen goes down twice per copy (square, line), six times in all.
    #[test]
    fn three_copies_execute_three_times_the_plan_with_the_delays() {
        let mut quiet = Paper { answer: PenChangeChoice::Continue, asked: vec![] };
        let (out, executed, drops) = run(Copies { count: 3, page_delay_s: 0.5, paper_pause: false }, &mut quiet);
        assert_eq!(out.copies.len(), 3);
        assert!(out.ended_early.is_none() && quiet.asked.is_empty());
        let one = &out.copies[0].plan;
        assert!(out.copies.iter().all(|c| c.plan.blocks == one.blocks), "every copy plans the same blocks");
        assert_eq!(executed, 3 * one.total_ticks + 2 * 500_000);
        // The simulator's pen trace sees a full lift and drop per copy (the hop between the square and the line
        // stays near the paper, at the clearance height); the plan drops the pen twice.
        assert_eq!(one.blocks.iter().filter(|b| b.kind == plan::MoveKind::PenDown).count(), 2);
        assert_eq!(drops, 3);
        // One copy: 2 drops, its plan's time.
        let (single, executed, drops) = run(Copies { count: 1, page_delay_s: 0.5, paper_pause: true }, &mut quiet);
        assert_eq!((single.copies.len(), drops), (1, 1));
        assert_eq!(executed, single.copies[0].plan.total_ticks);
    }

    /// Until stopped (0 copies): the paper pause comes after each copy; stopping at the second one ends the
    /// copies there, two drawn, without an error.
    #[test]
    fn until_stopped_ends_at_a_paper_change() {
        // Continue at the first paper change, stop at the second.
        struct Counting {
            asked: Vec<String>,
        }
        impl PlotEvents for Counting {
            fn progress(&mut self, _: &JobProgress) {}
            fn plot_pause(&mut self, p: &PauseRequest) -> PenChangeChoice {
                self.asked.push(p.ask());
                if self.asked.len() < 2 { PenChangeChoice::Continue } else { PenChangeChoice::Stop }
            }
        }
        let mut counting = Counting { asked: vec![] };
        let profile = MachineProfile::default_plotter();
        let line = Polyline::new(vec![Point::new(20.0, 40.0), Point::new(50.0, 40.0)]);
        let steps = drawing_to_steps(&profile, &Drawing::single_layer("l", vec![line])).unwrap();
        let mut s = Session::connect(SimTransport::new(plan::machine_config(&profile).unwrap(), None), "sim").unwrap();
        let copies = Copies { count: 0, page_delay_s: 0.0, paper_pause: true };
        let out =
            plot_copies(&mut s, &profile, &steps, true, false, None, &StopOptions::default(), &copies, &mut counting)
                .unwrap();
        assert_eq!(out.copies.len(), 2);
        assert_eq!(out.ended_early.as_deref(), Some("stopped at the paper change before copy 3"));
        assert_eq!(counting.asked, ["put in fresh paper for copy 2", "put in fresh paper for copy 3"]);
    }

    /// Stops the plot as a stop signal would once `at` blocks of its `plot`-th plan are executed, and answers
    /// every pause with "go on", keeping what was asked.
    struct StopAt {
        plot: u32,
        at: usize,
        plots: u32,
        executed: usize,
        asked: Vec<String>,
    }

    impl PlotEvents for StopAt {
        fn progress(&mut self, p: &JobProgress) {
            self.executed = p.executed;
        }
        fn plot_started(&mut self, _: &plotter_path::config::pens::LayerPen, _: usize) {
            self.plots += 1;
            self.executed = 0;
        }
        fn plot_pause(&mut self, p: &PauseRequest) -> PenChangeChoice {
            self.asked.push(p.ask());
            PenChangeChoice::Continue
        }
        fn stop_requested(&mut self) -> Option<crate::stop::StopCause> {
            (self.plots == self.plot && self.executed >= self.at).then_some(crate::stop::StopCause::Requested)
        }
    }

    /// The start position a test's journal source record holds.
    fn start_of(source: &str) -> [i32; 4] {
        serde_json::from_str::<serde_json::Value>(source).unwrap()["start"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| i32::try_from(v.as_i64().unwrap()).unwrap())
            .collect::<Vec<_>>()
            .try_into()
            .unwrap()
    }

    /// A plot of two copies with refills every 100 mm, stopped early in its first copy (during its first line)
    /// and resumed from its journal, keeps both: one layer of lines 30, 50, 20, 40 and 90 mm long refills before
    /// the 40 (30 + 50 + 20 = 100 filled part 1) and before the 90 (40 + 90 > 100), so the first copy has its
    /// two refills left, then the paper pause before copy 2 of 2, then copy 2's two refills: five pauses and two
    /// copies in all. The journal knew which copy it was drawing.
    #[test]
    fn a_resume_keeps_the_refills_and_goes_on_with_the_copies_left() {
        let profile = MachineProfile::default_plotter();
        let lines = [30.0, 50.0, 20.0, 40.0, 90.0]
            .iter()
            .enumerate()
            .map(|(i, len)| {
                let y = 10.0 + 5.0 * f64::from(u32::try_from(i).unwrap());
                Polyline::new(vec![Point::new(20.0, y), Point::new(20.0 + len, y)])
            })
            .collect();
        let steps = drawing_to_steps(&profile, &Drawing::single_layer("l", lines)).unwrap();
        let dir = std::env::temp_dir().join(format!("plotter-copies-resume-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let jp = dir.join("copies.journal");
        let source = |start: [i32; 4]| Ok(serde_json::json!({ "start": start }).to_string());
        let spec = JournalSpec { path: &jp, source: &source };
        let stops = StopOptions { split_mm: Some(100.0) };
        let copies = Copies { count: 2, page_delay_s: 0.0, paper_pause: true };
        let mut s = Session::connect(SimTransport::new(plan::machine_config(&profile).unwrap(), None), "sim").unwrap();
        // Blocks: travel, pen down, settle, the 30 mm line (3): stopped while it is drawn.
        let mut stop = StopAt { plot: 1, at: 3, plots: 0, executed: 0, asked: vec![] };
        let e = plot_copies(&mut s, &profile, &steps, true, false, Some(spec), &stops, &copies, &mut stop);
        assert!(e.is_err() && stop.asked.is_empty(), "stopped before its first refill");
        let state = crate::link::journal::load(&jp).unwrap();
        assert!(!state.complete);
        assert_eq!(copy_of(&state.source), 1);
        let start = start_of(&state.source);
        let mut go_on = StopAt { plot: u32::MAX, at: 0, plots: 0, executed: 0, asked: vec![] };
        let out =
            resume_copies(&mut s, &profile, &steps, start, &state, &jp, false, false, &stops, &copies, &mut go_on)
                .unwrap();
        assert_eq!(out.copies.len(), 2, "the copy under way and the one left");
        assert!(out.ended_early.is_none());
        let refill = |part: u32| format!("refill pen black fineliner 0.3 (#000000) for part {part} of layer \"l\"");
        let paper = "put in fresh paper for copy 2 of 2".to_string();
        assert_eq!(go_on.asked, [refill(2), refill(3), paper, refill(2), refill(3)]);
        // The second copy's journal says so, and it finished.
        let state = crate::link::journal::load(&jp).unwrap();
        assert!(state.complete);
        assert_eq!(copy_of(&state.source), 2);
        std::fs::remove_dir_all(&dir).ok();
    }

    /// A plot of three copies stopped at its first paper change has finished its journal's copy, yet owes
    /// copies 2 and 3: the journal says so, and its resume asks for both papers and draws both (three copies in
    /// all, the first found finished). A plot of one copy, and one until stopped, owe none.
    #[test]
    fn a_plot_stopped_at_a_paper_change_still_owes_its_copies() {
        let profile = MachineProfile::default_plotter();
        let line = Polyline::new(vec![Point::new(20.0, 40.0), Point::new(50.0, 40.0)]);
        let steps = drawing_to_steps(&profile, &Drawing::single_layer("l", vec![line])).unwrap();
        let dir = std::env::temp_dir().join(format!("plotter-copies-owed-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let jp = dir.join("copies.journal");
        let source = |start: [i32; 4]| Ok(serde_json::json!({ "start": start }).to_string());
        let spec = JournalSpec { path: &jp, source: &source };
        let copies = Copies { count: 3, page_delay_s: 0.0, paper_pause: true };
        let mut s = Session::connect(SimTransport::new(plan::machine_config(&profile).unwrap(), None), "sim").unwrap();
        let mut stop = Paper { answer: PenChangeChoice::Stop, asked: vec![] };
        let stops = StopOptions::default();
        let out = plot_copies(&mut s, &profile, &steps, true, false, Some(spec), &stops, &copies, &mut stop).unwrap();
        assert_eq!(out.copies.len(), 1);
        assert_eq!(out.ended_early.as_deref(), Some("stopped at the paper change before copy 2"));
        let state = crate::link::journal::load(&jp).unwrap();
        assert!(state.complete, "copy 1 finished");
        assert_eq!(copies_left(&state.source), Some((2, 3)));
        let start = start_of(&state.source);
        let mut go_on = Paper { answer: PenChangeChoice::Continue, asked: vec![] };
        let out =
            resume_copies(&mut s, &profile, &steps, start, &state, &jp, false, false, &stops, &copies, &mut go_on)
                .unwrap();
        assert_eq!(out.copies.len(), 3, "copy 1 found finished, then copies 2 and 3");
        assert!(out.copies[0].drawn_before && !out.copies[1].drawn_before && !out.copies[2].drawn_before);
        assert_eq!(go_on.asked, ["put in fresh paper for copy 2 of 3", "put in fresh paper for copy 3 of 3"]);
        let state = crate::link::journal::load(&jp).unwrap();
        assert!(state.complete);
        assert_eq!(copies_left(&state.source), None, "copy 3 of 3 was the last");
        // One copy, and until stopped, owe nothing; a record without a count (older journals) neither.
        assert_eq!(copies_left(&with_copy("{}".into(), 1, 1)), None);
        assert_eq!(copies_left(&with_copy("{}".into(), 4, 0)), None);
        assert_eq!(copies_left(r#"{"copy": 1}"#), None);
        assert_eq!(copies_left(&with_copy("{}".into(), 2, 5)), Some((3, 5)));
        std::fs::remove_dir_all(&dir).ok();
    }
}
