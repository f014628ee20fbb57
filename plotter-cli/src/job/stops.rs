//! Where a plot stops besides pen changes, worked out from the drawing and its plan before anything moves: a
//! pause before a layer whose name starts with `!`, a delay after each pen drop in a layer whose name carries
//! `+D<ms>` (the layer codes, see [`plotter_path::config::layer_codes`]), and a refill after at most
//! `--split-distance` millimetres drawn within a layer (always at a stroke boundary, so that fountain pens and
//! brushes can be reloaded).

use plotter_path::MachineProfile;
use plotter_path::config::layer_codes::LayerCodes;
use plotter_path::geometry::steps::{StepDrawing, StepMapper};
use plotter_path::motion::plan::{MotionPlan, MoveKind};

/// Stops a plot makes on request (beside those its layers' names ask for).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StopOptions {
    /// `--split-distance`: refill after at most this many millimetres drawn within a layer.
    pub split_mm: Option<f64>,
}

/// Why the plot stops.
#[derive(Debug, Clone, PartialEq)]
pub enum StopWhy {
    /// The layer's name asks for a pause before it (`!`).
    Pause,
    /// The pen has drawn what `--split-distance` allows: refill it before part `part` (2, 3, ...) of the layer.
    Refill {
        /// The part of the layer about to be drawn, counted from 1.
        part: usize,
    },
    /// The layer's name asks for a delay after each pen drop (`+D`), milliseconds: the pen waits on the paper
    /// before it draws the stroke.
    Delay {
        /// How long, milliseconds.
        ms: u32,
    },
    /// The layer's delay after each pen drop (`+D`) on a stroke whose drop the plan blends into its travel (a
    /// servo pen lowered while the carriage still moves, so the pen never stands on the paper at rest before the
    /// stroke): the plot travels to the stroke's start with the pen up, lowers the pen in full (its whole settle),
    /// waits, then draws from block `draw`.
    DropThenDelay {
        /// How long, milliseconds.
        ms: u32,
        /// The stroke's first drawing block.
        draw: usize,
    },
}

/// A stop before block `block` of the plan (in the original plan's numbering; the pen is up there, but for a
/// delay after a pen drop, where the pen stands on the paper at rest; a delay after a blended drop stops before
/// the stroke's travel).
#[derive(Debug, Clone, PartialEq)]
pub struct PlotStop {
    /// The first block after the stop: the travel to the next stroke (or its pen drop when it needs no travel);
    /// for a delay, the stroke's first drawing block, after its pen drop has settled.
    pub block: usize,
    /// Index of the layer in [`StepDrawing::layers`].
    pub layer: usize,
    /// Its name.
    pub layer_name: String,
    /// Why.
    pub why: StopWhy,
}

/// Why the plot waits for the user with the pen up.
#[derive(Debug, Clone, PartialEq)]
pub enum PauseWhy {
    /// Before a layer whose name starts with `!`.
    Layer,
    /// A refill before part `part` of the layer (`--split-distance`).
    Refill {
        /// The part about to be drawn, counted from 1.
        part: usize,
    },
    /// Between copies (`--copies`): put in fresh paper for copy `copy` of `copies` (0: until stopped).
    Paper {
        /// The copy about to be drawn, counted from 1.
        copy: u64,
        /// Copies asked for (0: until stopped).
        copies: u64,
    },
}

/// A pause the plot is waiting in, parked with the pen up.
#[derive(Debug, Clone, PartialEq)]
pub struct PauseRequest {
    /// Why.
    pub why: PauseWhy,
    /// The layer about to be drawn (empty between copies).
    pub layer_name: String,
    /// Its pen.
    pub pen: plotter_path::config::pens::LayerPen,
    /// Where the carriage waits, machine mm (X, Y).
    pub park_mm: (f64, f64),
}

impl PauseRequest {
    /// What the user is asked to do, as a sentence: "refill pen black (#000000) for part 2 of layer \"a\"".
    pub fn ask(&self) -> String {
        match &self.why {
            PauseWhy::Layer => format!("paused before layer {:?} (its name starts with !)", self.layer_name),
            PauseWhy::Refill { part } => {
                format!("refill pen {} for part {part} of layer {:?}", self.pen.label(), self.layer_name)
            }
            PauseWhy::Paper { copy, copies: 0 } => format!("put in fresh paper for copy {copy}"),
            PauseWhy::Paper { copy, copies } => format!("put in fresh paper for copy {copy} of {copies}"),
        }
    }
}

/// The first block of stroke `stroke` in `plan` that the plot may stop before: its travel (the pen is up, or at
/// the clearance height of a hop, there), else its first block.
fn stroke_start(plan: &MotionPlan, stroke: usize) -> Option<usize> {
    let first = plan.blocks.iter().position(|b| b.stroke == stroke)?;
    let travel = plan.blocks[first..]
        .iter()
        .take_while(|b| b.stroke == stroke)
        .position(|b| b.kind == MoveKind::Travel)
        .map(|i| first + i);
    Some(travel.unwrap_or(first))
}

/// Pen-down length of each stroke of `steps`, mm (the machine's axes, as drawn).
pub fn stroke_lengths(profile: &MachineProfile, steps: &StepDrawing) -> Vec<f64> {
    let (sx, sy) = StepMapper::new(profile).steps_per_mm();
    steps
        .strokes
        .iter()
        .map(|s| s.moves.iter().map(|d| (f64::from(d.dx) / sx).hypot(f64::from(d.dy) / sy)).sum())
        .collect()
}

/// The first drawing block of stroke `stroke` in `plan`.
fn first_draw(plan: &MotionPlan, stroke: usize) -> Option<usize> {
    plan.blocks.iter().position(|b| b.stroke == stroke && b.kind == MoveKind::Draw)
}

/// The first drawing block of stroke `stroke` in `plan` when the pen stands on the paper at rest before it (its
/// drop settled), where a delay after the drop may wait.
fn after_drop(plan: &MotionPlan, stroke: usize) -> Option<usize> {
    let i = first_draw(plan, stroke)?;
    let before = plan.blocks.get(i.checked_sub(1)?)?;
    (before.kind != MoveKind::Draw && before.block.exit_rate == 0 && plan.blocks[i].block.entry_rate == 0).then_some(i)
}

/// The stops of `plan` (planned from `steps`), in block order: per layer, its pause (from its name's codes) before
/// its first stroke and its delay (`+D`) after each of its pen drops, then a refill before each stroke that would
/// take the layer's part past
/// `split_mm` of drawn length (a part always holds at least one stroke, so a stroke longer than `split_mm` is
/// drawn whole).
pub fn plot_stops(
    profile: &MachineProfile,
    steps: &StepDrawing,
    plan: &MotionPlan,
    split_mm: Option<f64>,
) -> Vec<PlotStop> {
    let mut stops = Vec::new();
    let lengths = split_mm.map(|_| stroke_lengths(profile, steps)).unwrap_or_default();
    for (li, layer) in steps.layers.iter().enumerate() {
        let end = steps.layers.get(li + 1).map_or(steps.strokes.len(), |n| n.first_stroke);
        let codes = LayerCodes::parse(&layer.name);
        let stop = |block: usize, why: StopWhy| PlotStop { block, layer: li, layer_name: layer.name.clone(), why };
        if codes.pause
            && let Some(block) = stroke_start(plan, layer.first_stroke)
        {
            stops.push(stop(block, StopWhy::Pause));
        }
        if let Some(ms) = codes.delay_ms {
            for si in layer.first_stroke..end {
                if let Some(block) = after_drop(plan, si) {
                    stops.push(stop(block, StopWhy::Delay { ms }));
                } else if let (Some(block), Some(draw)) = (stroke_start(plan, si), first_draw(plan, si)) {
                    stops.push(stop(block, StopWhy::DropThenDelay { ms, draw }));
                }
            }
        }
        let Some(split) = split_mm else { continue };
        let (mut drawn, mut part) = (0.0, 1);
        for (si, &len) in lengths.iter().enumerate().take(end).skip(layer.first_stroke) {
            if drawn > 0.0 && drawn + len > split {
                part += 1;
                drawn = 0.0;
                if let Some(block) = stroke_start(plan, si) {
                    stops.push(stop(block, StopWhy::Refill { part }));
                }
            }
            drawn += len;
        }
    }
    stops.sort_by_key(|s| s.block);
    stops
}

#[cfg(test)]
mod tests {
    use super::*;
    use plotter_path::geometry::steps::drawing_to_steps;
    use plotter_path::kurbo::Point;
    use plotter_path::motion::plan::{self, Lookahead};
    use plotter_path::{Drawing, Layer, Polyline};

    /// A horizontal line `len` mm long at height `y`, from X 20 mm.
    fn line(y: f64, len: f64) -> Polyline {
        Polyline::new(vec![Point::new(20.0, y), Point::new(20.0 + len, y)])
    }

    /// Layers "a" with lines of 30, 50, 20, 40 and 90 mm, and "!2+D250 b" with one of 10 mm.
    fn drawing() -> Drawing {
        let mut a = Layer::new("a");
        a.paths =
            [30.0, 50.0, 20.0, 40.0, 90.0].iter().enumerate().map(|(i, l)| line(10.0 + 5.0 * i as f64, *l)).collect();
        let mut b = Layer::new("!2+D250 b");
        b.paths = vec![line(80.0, 10.0)];
        Drawing { layers: vec![a, b], page_mm: None }
    }

    #[test]
    fn refills_split_a_layer_at_stroke_boundaries_and_codes_stop_before_their_layer() {
        let profile = MachineProfile::default_plotter();
        let steps = drawing_to_steps(&profile, &drawing()).unwrap();
        let lengths = stroke_lengths(&profile, &steps);
        assert_eq!(lengths, [30.0, 50.0, 20.0, 40.0, 90.0, 10.0]);
        let full = plan::plan(&profile, &steps, plan::homed_position(&profile).unwrap(), Lookahead::Whole).unwrap();
        let stops = plot_stops(&profile, &steps, &full, Some(100.0));
        // At most 100 mm per part: 30 + 50 + 20 = 100 (part 1); 40 (part 2, + 90 would be 130); 90 (part 3). Layer
        // "b" starts afresh: its 10 mm need no refill; it has its pause first and its delay after its pen drop.
        let whys: Vec<(usize, &StopWhy)> = stops.iter().map(|s| (s.layer, &s.why)).collect();
        assert_eq!(
            whys,
            [
                (0, &StopWhy::Refill { part: 2 }),
                (0, &StopWhy::Refill { part: 3 }),
                (1, &StopWhy::Pause),
                (1, &StopWhy::Delay { ms: 250 }),
            ]
        );
        // Each stop but the delay is the travel to its stroke: strokes 3, 4 and 5.
        for (s, stroke) in stops.iter().zip([3, 4, 5]) {
            assert_eq!((full.blocks[s.block].kind, full.blocks[s.block].stroke), (MoveKind::Travel, stroke));
            assert!(full.blocks[..s.block].iter().all(|b| b.stroke < stroke));
        }
        // The delay: stroke 5's first drawing block, after its pen drop and settle.
        let d = stops[3].block;
        assert_eq!((full.blocks[d].kind, full.blocks[d].stroke), (MoveKind::Draw, 5));
        assert_eq!((full.blocks[d - 2].kind, full.blocks[d - 1].kind), (MoveKind::PenDown, MoveKind::Settle));
        // Without --split-distance: only the codes.
        assert_eq!(plot_stops(&profile, &steps, &full, None).len(), 2);
        // A split shorter than every stroke: a refill before each stroke but a layer's first.
        assert_eq!(plot_stops(&profile, &steps, &full, Some(5.0)).len(), 4 + 2);
    }

    /// Records the pauses and says `answer` to each.
    struct Pauses {
        seen: Vec<PauseRequest>,
        answer: crate::job::progress::PenChangeChoice,
    }

    impl crate::job::progress::PlotEvents for Pauses {
        fn progress(&mut self, _: &crate::job::progress::JobProgress) {}
        fn plot_pause(&mut self, p: &PauseRequest) -> crate::job::progress::PenChangeChoice {
            self.seen.push(p.clone());
            self.answer
        }
    }

    /// Two layers named `first` (a 100 mm line along X from (20, 10)) and `second` (a 20 mm line at Y 30), one
    /// pen; plotted on our simulated firmware: (the plan, the executed ticks, the pauses seen).
    fn plot_named(first: &str, second: &str) -> (MotionPlan, u64, Vec<PauseRequest>) {
        let (out, executed, seen) = plot_answering(first, second, crate::job::progress::PenChangeChoice::Continue);
        (out.unwrap().plan, executed, seen)
    }

    /// [`plot_named`] answering every pause with `answer`: (the plot's result, the executed ticks, the pauses).
    fn plot_answering(
        first: &str,
        second: &str,
        answer: crate::job::progress::PenChangeChoice,
    ) -> (crate::Result<crate::job::JobOutcome>, u64, Vec<PauseRequest>) {
        use crate::link::machine::PlotMachine as _;
        let mut profile = MachineProfile::default_plotter();
        profile.pens.clear();
        let mut a = Layer::new(first);
        a.paths = vec![line(10.0, 100.0)];
        let mut b = Layer::new(second);
        b.paths = vec![line(30.0, 20.0)];
        let steps = drawing_to_steps(&profile, &Drawing { layers: vec![a, b], page_mm: None }).unwrap();
        let cfg = plan::machine_config(&profile).unwrap();
        let mut s =
            crate::link::session::Session::connect(crate::link::sim::SimTransport::new(cfg, None), "sim").unwrap();
        let mut events = Pauses { seen: vec![], answer };
        let before = s.busy_ticks();
        let out = crate::job::plot(&mut s, &profile, &steps, true, false, None, &mut events);
        let executed = s.busy_ticks() - out.as_ref().map_or(before, |o| o.busy_before);
        (out, executed, events.seen)
    }

    /// Stopping at a `!` layer's pause is the user's stop, typed as such (the exit status and the web app's words
    /// for a stop come from it), saying what the pause asked; the first layer was drawn, the second not.
    #[test]
    fn stopping_at_a_layer_pause_is_a_typed_stop() {
        use crate::error::{Error, Trouble};
        let (out, _, seen) = plot_answering("1 a", "!2 b", crate::job::progress::PenChangeChoice::Stop);
        assert_eq!(seen.len(), 1);
        let err = out.unwrap_err();
        assert_eq!(err.trouble(), Trouble::Stopped);
        match &err {
            Error::StoppedAtPause { asked, .. } => {
                assert_eq!(asked, "paused before layer \"!2 b\" (its name starts with !)");
            }
            other => panic!("{other:?}"),
        }
        assert!(err.to_string().starts_with("stopped at the pause (paused before layer \"!2 b\""), "{err}");
    }

    /// The drawing speed and the pen-down height of a layer's codes reach the plan, and its delay and pause the
    /// plot. The 100 mm line from rest to rest at feed v and 1500 mm/s² takes 100/v + v/1500 s: 1.706 667 s at
    /// the pen's 60 mm/s, 3.353 333 s at +S50 (30 mm/s). +H25 puts the pen down a quarter of the way from its
    /// down Z (0 mm) to its up Z (4 mm): 1 mm, 400 steps at 400 steps/mm. +D250 adds 0.25 s before the second
    /// layer, and ! parks and asks before it.
    #[test]
    fn layer_codes_reach_the_plan_and_the_plot() {
        let draw_s = |p: &MotionPlan, stroke: usize| -> f64 {
            let t: u32 =
                p.blocks.iter().filter(|b| b.kind == MoveKind::Draw && b.stroke == stroke).map(|b| b.ticks).sum();
            f64::from(t) / 1e6
        };
        let cruise = |p: &MotionPlan, stroke: usize| {
            p.blocks
                .iter()
                .filter(|b| b.kind == MoveKind::Draw && b.stroke == stroke)
                .map(|b| b.block.cruise_rate)
                .max()
                .unwrap()
        };
        let down_z = |p: &MotionPlan, stroke: usize| {
            let i = p.blocks.iter().position(|b| b.kind == MoveKind::PenDown && b.stroke == stroke).unwrap();
            p.position_after(i)[2]
        };
        let (plain, plain_ticks, none) = plot_named("1 a", "2 b");
        assert!(none.is_empty());
        // The drop and the lift meet the line at a corner speed of a few mm/s, which saves a few ms of ramp.
        assert!((draw_s(&plain, 0) - (100.0 / 60.0 + 60.0 / 1500.0)).abs() < 5e-3, "{}", draw_s(&plain, 0));
        assert_eq!(cruise(&plain, 0), 60 * 80, "60 mm/s at 80 steps/mm");
        assert_eq!(down_z(&plain, 0), 0);
        let (coded, coded_ticks, seen) = plot_named("1+S50+H25 a", "!2+D250 b");
        assert!((draw_s(&coded, 0) - (100.0 / 30.0 + 30.0 / 1500.0)).abs() < 5e-3, "{}", draw_s(&coded, 0));
        assert_eq!(cruise(&coded, 0), 30 * 80, "30 mm/s at 80 steps/mm");
        assert_eq!(down_z(&coded, 0), 400);
        // The second layer keeps the pen's own speed and height.
        assert!((draw_s(&coded, 1) - draw_s(&plain, 1)).abs() < 1e-6);
        assert_eq!(down_z(&coded, 1), 0);
        assert_eq!(seen.len(), 1);
        assert_eq!(seen[0].why, PauseWhy::Layer);
        assert_eq!(seen[0].ask(), "paused before layer \"!2+D250 b\" (its name starts with !)");
        // Executed on the simulator: the plan's own time (the slower first layer, the higher drop, the park and
        // the way back) plus the delay.
        let park_and_back = coded_ticks - coded.total_ticks - 250_000;
        assert!(coded_ticks > coded.total_ticks + 250_000, "{coded_ticks} vs {}", coded.total_ticks);
        assert!(park_and_back > 0 && plain_ticks == plain.total_ticks, "{park_and_back} {plain_ticks}");
        // The delay alone: the same plan, and the pen waits 0.25 s on the paper after its one drop in the second
        // layer, where it stands at rest: executed exactly 0.25 s longer.
        let (delayed, delayed_ticks, _) = plot_named("1 a", "2+D250 b");
        assert_eq!(delayed.total_ticks, plain.total_ticks);
        assert_eq!(delayed_ticks - plain_ticks, 250_000);
    }

    /// One layer named `name` with three 20 mm lines (at Y 10, 20 and 30 mm), each its own pen drop, plotted on
    /// our simulated firmware: (the plan, the executed ticks).
    fn three_strokes(name: &str) -> (MotionPlan, u64) {
        use crate::link::machine::PlotMachine as _;
        let profile = MachineProfile::default_plotter();
        let mut l = Layer::new(name);
        l.paths = vec![line(10.0, 20.0), line(20.0, 20.0), line(30.0, 20.0)];
        let steps = drawing_to_steps(&profile, &Drawing { layers: vec![l], page_mm: None }).unwrap();
        let cfg = plan::machine_config(&profile).unwrap();
        let mut s =
            crate::link::session::Session::connect(crate::link::sim::SimTransport::new(cfg, None), "sim").unwrap();
        let mut events = Pauses { seen: vec![], answer: crate::job::progress::PenChangeChoice::Continue };
        let out = crate::job::plot(&mut s, &profile, &steps, true, false, None, &mut events).unwrap();
        let executed = s.busy_ticks() - out.busy_before;
        (out.plan, executed)
    }

    /// Three 20 mm lines (at Y 10, 20 and 30 mm) in one layer named `name`, plotted with `profile` on `machine`:
    /// (the plan, the machine's executed ticks).
    fn three_on(
        profile: &MachineProfile,
        machine: &mut dyn crate::link::machine::PlotMachine,
        name: &str,
    ) -> (MotionPlan, u64) {
        let mut l = Layer::new(name);
        l.paths = vec![line(10.0, 20.0), line(20.0, 20.0), line(30.0, 20.0)];
        let steps = drawing_to_steps(profile, &Drawing { layers: vec![l], page_mm: None }).unwrap();
        let mut events = Pauses { seen: vec![], answer: crate::job::progress::PenChangeChoice::Continue };
        let out = crate::job::plot(machine, profile, &steps, true, false, None, &mut events).unwrap();
        (out.plan, machine.busy_ticks() - out.busy_before)
    }

    /// `+D250` on servo pens, on every dialect that runs a servo pen: our firmware and GRBL with the kit's servo
    /// (`--model servo-grbl`), an EBB with the AxiDraw V3. Their drops are commanded while the carriage still
    /// travels (`pen.contact_fraction`), the plan holding the pen where it touches until its latest contact, so
    /// each stroke's wait comes after that hold: three strokes execute 3 × 250 ms = 750 000 ticks longer (exactly
    /// on ours and GRBL), the plan unchanged.
    #[test]
    fn a_layer_delay_waits_after_each_servo_drop_on_every_dialect() {
        use crate::link::ebb::emulator::EbbEmulator;
        use crate::link::ebb::emulator_transport::EbbTransport;
        use crate::link::ebb::messages::EbbVersion;
        use crate::link::ebb::session::EbbSession;
        use crate::link::grbl::emulator::{Faults, GrblEmulator};
        use crate::link::grbl::emulator_transport::EmulatorTransport;
        use crate::link::grbl::session::GrblSession;
        use crate::link::grbl::settings::GrblSettings;
        use crate::link::machine::PlotMachine;
        let servo = plotter_path::config::models::find("servo-grbl").unwrap().profile();
        let v3 = plotter_path::config::models::find("axidraw-v3").unwrap().profile();
        let ours = |p: &MachineProfile| -> Box<dyn PlotMachine> {
            let cfg = plan::machine_config(p).unwrap();
            Box::new(
                crate::link::session::Session::connect(crate::link::sim::SimTransport::new(cfg, None), "sim").unwrap(),
            )
        };
        let grbl = |p: &MachineProfile| -> Box<dyn PlotMachine> {
            let cfg = plan::machine_config(p).unwrap();
            let emu = GrblEmulator::with_settings(cfg, GrblSettings::for_profile(p), None, Faults::default());
            Box::new(GrblSession::connect(EmulatorTransport::new(emu), "emulator", p).unwrap())
        };
        let ebb = |p: &MachineProfile| -> Box<dyn PlotMachine> {
            let emu = EbbEmulator::new(EbbVersion(3, 0, 2));
            Box::new(EbbSession::connect(EbbTransport::new(emu), "ebb", p).unwrap())
        };
        type Connect = dyn Fn(&MachineProfile) -> Box<dyn PlotMachine>;
        let runs: [(&str, &MachineProfile, &Connect); 3] =
            [("ours", &servo, &ours), ("grbl", &servo, &grbl), ("ebb", &v3, &ebb)];
        for (dialect, profile, machine) in runs {
            let (plain, plain_ticks) = three_on(profile, machine(profile).as_mut(), "1 a");
            let (delayed, delayed_ticks) = three_on(profile, machine(profile).as_mut(), "1+D250 a");
            assert!(plain.blocks.iter().any(|b| b.block.servo.is_some()), "{dialect}: a servo pen");
            assert_eq!(plain.blocks.iter().filter(|b| b.kind == MoveKind::PenDown).count(), 3, "{dialect}");
            assert_eq!(delayed.total_ticks, plain.total_ticks, "{dialect}");
            // The EBB times its moves and waits in whole intervals and milliseconds, rounding each part of the
            // plan it is sent on its own: a part ends at each of the three waits, each within a millisecond.
            let slack = if dialect == "ebb" { 3 * 1000 } else { 0 };
            assert!(delayed_ticks.abs_diff(plain_ticks + 750_000) <= slack, "{dialect}: {delayed_ticks} {plain_ticks}");
        }
    }

    /// Should a plan ever blend a servo drop into its stroke (a travel's last part joining the first drawing block
    /// at speed, with no hold between them), the layer's delay still waits: its stop (`DropThenDelay`) comes
    /// before the stroke's travel, and the plot travels there with the pen up, lowers it in full and waits. Run
    /// here on our simulated firmware with the kit's servo (settle 150 ms) for each of three strokes: from each
    /// drop command, the carriage stands still for the whole settle and the 250 ms, 400 000 ticks at least, at
    /// the stroke's start; without the stops its next step comes within 10 ms (the drop is commanded while it
    /// travels). Stop blocks and drawing blocks as `plot_stops` finds them for a blended stroke.
    #[test]
    fn a_drop_then_delay_stop_lowers_the_pen_in_full_at_the_stroke_start_and_waits() {
        use crate::link::machine::PlotMachine as _;
        let profile = plotter_path::config::models::find("servo-grbl").unwrap().profile();
        assert_eq!((profile.pen.settle_ms, profile.pen.servo_down_deg), (150.0, 30.0));
        let mut l = Layer::new("1+D250 a");
        l.paths = vec![line(10.0, 20.0), line(20.0, 20.0), line(30.0, 20.0)];
        let steps = drawing_to_steps(&profile, &Drawing { layers: vec![l], page_mm: None }).unwrap();
        // (From each drop command to the carriage's next step, ticks; where the carriage stood then, steps.)
        let waits = |blended: bool| -> Vec<(u64, (i64, i64))> {
            let cfg = plan::machine_config(&profile).unwrap();
            let mut s =
                crate::link::session::Session::connect(crate::link::sim::SimTransport::new(cfg, None), "sim").unwrap();
            s.begin().unwrap();
            s.home().unwrap();
            let start = plan::homed_position(&profile).unwrap();
            let full = plan::plan(&profile, &steps, start, Lookahead::Whole).unwrap();
            let stops = if blended {
                (0..3)
                    .map(|si| PlotStop {
                        block: stroke_start(&full, si).unwrap(),
                        layer: 0,
                        layer_name: "1+D250 a".into(),
                        why: StopWhy::DropThenDelay { ms: 250, draw: first_draw(&full, si).unwrap() },
                    })
                    .collect()
            } else {
                Vec::new()
            };
            let run = crate::job::Run {
                profile: &profile,
                steps: &steps,
                start,
                full: &full,
                journal_path: None,
                return_home: false,
                stops,
            };
            let mut events = Pauses { seen: vec![], answer: crate::job::progress::PenChangeChoice::Continue };
            run.stream(&mut s, &full, None, None, &mut events).unwrap();
            let sim = s.transport.sim().hal();
            let mut pos = sim.physical_position();
            for e in sim.steps().iter().rev() {
                pos[e.axis.index()] -= if e.forward { 1 } else { -1 };
            }
            let mut at = Vec::new();
            for e in sim.steps() {
                pos[e.axis.index()] += if e.forward { 1 } else { -1 };
                at.push((e.time, (pos[0], pos[1]), e.axis.index() < 2));
            }
            sim.servo_trace()
                .iter()
                .filter(|(_, deg, _)| *deg == 30.0)
                .map(|&(t, _, _)| {
                    let stood = at.iter().rev().find(|a| a.0 <= t).map_or((0, 0), |a| a.1);
                    let next = at.iter().find(|a| a.2 && a.0 > t).map_or(u64::MAX, |a| a.0 - t);
                    (next, stood)
                })
                .collect()
        };
        // Where plot_stops puts them: a stroke whose first drawing block the plan enters at speed (as if blended)
        // gets its delay before its travel. The plan: per stroke a travel, the drop command, the travel's last
        // part, the hold until the latest contact, then the line (blocks 5, 11 and 17), the lift after it.
        let mut blended =
            plan::plan(&profile, &steps, plan::homed_position(&profile).unwrap(), Lookahead::Whole).unwrap();
        let found = |p: &MotionPlan| -> Vec<(usize, StopWhy)> {
            plot_stops(&profile, &steps, p, None).into_iter().map(|s| (s.block, s.why)).collect()
        };
        let delay = StopWhy::Delay { ms: 250 };
        assert_eq!(found(&blended), [(5, delay.clone()), (11, delay.clone()), (17, delay.clone())]);
        blended.blocks[11].block.entry_rate = 1000;
        let then = StopWhy::DropThenDelay { ms: 250, draw: 11 };
        assert_eq!(found(&blended), [(5, delay.clone()), (7, then), (17, delay)]);
        let plain = waits(false);
        assert_eq!(plain.len(), 3);
        assert!(plain.iter().all(|w| w.0 < 10_000), "the carriage travels on as the pen drops: {plain:?}");
        let delayed = waits(true);
        assert_eq!(delayed.len(), 3, "one drop per stroke: {delayed:?}");
        // The lines start at X 20 mm and Y 10, 20, 30 mm: 80 steps/mm.
        let starts: Vec<(i64, i64)> = delayed.iter().map(|w| w.1).collect();
        assert_eq!(starts, [(1600, 800), (1600, 1600), (1600, 2400)]);
        assert!(delayed.iter().all(|w| w.0 >= 400_000), "{delayed:?}");
    }

    /// `+D250` is 250 ms after each pen drop of its layer: three strokes plot 3 × 0.25 = 0.75 s longer than the
    /// same layer without it (the plan itself unchanged), the pen each time on the paper before it draws.
    #[test]
    fn a_layer_delay_waits_after_each_pen_drop() {
        let (plain, plain_ticks) = three_strokes("1 a");
        let (delayed, delayed_ticks) = three_strokes("1+D250 a");
        assert_eq!(plain.blocks.iter().filter(|b| b.kind == MoveKind::PenDown).count(), 3);
        assert_eq!(delayed.total_ticks, plain.total_ticks);
        assert_eq!(plain_ticks, plain.total_ticks);
        assert_eq!(delayed_ticks - plain_ticks, 750_000);
    }
}
