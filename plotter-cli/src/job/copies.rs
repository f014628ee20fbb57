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

/// What the copies did.
#[derive(Debug)]
pub struct CopiesOutcome {
    /// Each finished copy, in order.
    pub copies: Vec<JobOutcome>,
    /// Why the copies ended before the count (a stop at a paper change, a stop signal), if they did.
    pub ended_early: Option<String>,
}

/// Plot `steps` as `copies` say: home before the first copy only (when `home`), every copy planned from the
/// same start and back to it (so each draws exactly the same), the page delay and the paper pause between them.
/// The journal (if any) records the copy being drawn.
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
    let mut done = Vec::new();
    let back = return_home || copies.count != 1;
    let mut copy: u64 = 1;
    loop {
        if copy > 1 {
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
        let out = plot_with(machine, profile, steps, home && copy == 1, back, journal, stops, events)?;
        done.push(out);
        if copies.count != 0 && copy >= copies.count {
            return Ok(CopiesOutcome { copies: done, ended_early: None });
        }
        copy += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::job::progress::JobProgress;
    use crate::link::session::Session;
    use crate::link::sim::SimTransport;
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
}
