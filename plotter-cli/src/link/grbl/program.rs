//! A motion plan as a GRBL G-code program: one line per planned block, so that "lines acknowledged" and "blocks
//! accepted" are the same count (the journal records either).
//!
//! Positions are absolute millimetres in the plot's work coordinates (the sender declares them with `G92` after
//! homing), printed from the plan's exact step positions with enough decimals that GRBL's own rounding
//! (`round(mm × steps/mm)`) lands on the same step, so the machine ends exactly where the plan ends. Travel and
//! drawing are `G1` at the profile's travel feed and the pen's drawing feed (F in mm/min, written when it
//! changes), travel with a `Z` where the plan's hop moves the pen on the way; the pen is a Z move at the Z axis's
//! maximum rate, or `M3 S<angle>` for a servo pen, down and up alike (with its settle dwell on the same line,
//! `M3 S90 G4 P0.149`, as the plan's servo block carries both); a settle dwell is `G4 P<seconds>`, written so
//! that GRBL, which dwells in whole steps of 50 ms, dwells what the plan made for it times
//! ([`plotter_path::motion::plan::grbl_dwell_ticks`]). A servo pen is
//! never lifted with `M5`: on stock GRBL, whose spindle PWM drives the hobby servo, `M5` stops the pulses and the
//! pen may fall onto the paper; `M3 S<pen.servo_up_deg>` holds it up on GRBL servo builds and on our firmware
//! alike (see [`plotter_path::output::gcode_out`]).

use std::fmt::Write as _;

use plotter_path::MachineProfile;
use plotter_path::motion::plan::{GRBL_DWELL_STEP_TICKS, MotionPlan, MoveKind, grbl_dwell_ticks};
use plotter_path::output::gcode_out::{decimals_for, fmt_mm};

/// The program of a plan.
#[derive(Debug, Clone, PartialEq)]
pub struct Program {
    /// One line per plan block, without line end.
    pub lines: Vec<String>,
    /// Whether the pen is up (and settled) after each line: where a pause at the next pen-up may stop.
    pub safe_after: Vec<bool>,
}

/// Millimetres of a step count.
fn mm(steps: i32, spm: f64) -> f64 {
    f64::from(steps) / spm
}

/// A dwell of `ticks` as GRBL's `P` (seconds), for GRBL to dwell what [`grbl_dwell_ticks`] says: `P0` under half a
/// millisecond, else its whole 50 ms steps less a millisecond, since GRBL takes ⌈20·P⌉ steps of P read in single
/// precision, which for some exact multiples comes out one step over (`P1.3` dwells 1.35 s).
fn seconds(ticks: u32) -> String {
    let steps = grbl_dwell_ticks(ticks) / GRBL_DWELL_STEP_TICKS;
    if steps == 0 {
        return "0".into();
    }
    fmt_mm(f64::from(steps) * 0.05 - 0.001, 3)
}

/// Write `plan` (which starts at `plan.start`, in steps of the plot's work coordinates) as G-code lines.
pub fn program(profile: &MachineProfile, plan: &MotionPlan) -> Program {
    let ax = &profile.axes;
    let (sx, sy, sz) = (ax.x.steps_per_mm, ax.y.steps_per_mm, ax.z.steps_per_mm);
    let (dx, dy, dz) = (decimals_for(sx), decimals_for(sy), decimals_for(sz));
    let servo = profile.pen.uses_servo();
    let per_min = |mm_s: f64| fmt_mm(mm_s * 60.0, 1);
    let z_feed = per_min(ax.z.max_feed_mm_s);
    let travel_feed = per_min(profile.pen.travel_feed_mm_s);
    let mut pos = plan.start;
    let mut feed = String::new();
    let mut pen = &plan.first_pen;
    let mut changes = plan.pen_changes.iter().peekable();
    let mut lines = Vec::with_capacity(plan.blocks.len());
    let mut safe_after = Vec::with_capacity(plan.blocks.len());
    let mut pen_up = true;
    for (i, b) in plan.blocks.iter().enumerate() {
        if let Some(orig) = plan.original_index(i) {
            while let Some(c) = changes.next_if(|c| c.block <= orig) {
                pen = &c.pen;
            }
        } else if let Some(c) = plan.pen_changes.iter().rev().find(|c| c.block <= plan.resumed_from) {
            // A resume preamble lowers the pen of the layer being resumed.
            pen = &c.pen;
        }
        for (p, s) in pos.iter_mut().zip(b.block.steps) {
            *p += s;
        }
        let mut line = String::new();
        let xy = |line: &mut String| {
            let _ = write!(line, "X{} Y{}", fmt_mm(mm(pos[0], sx), dx), fmt_mm(mm(pos[1], sy), dy));
        };
        let mut with_feed = |line: &mut String, f: &str| {
            if feed != f {
                let _ = write!(line, " F{f}");
                feed = f.to_string();
            }
        };
        match b.kind {
            MoveKind::Travel | MoveKind::Draw => {
                line.push_str("G1 ");
                xy(&mut line);
                // A pen-up hop lifts and lowers the pen on the way (combined XY+Z moves).
                if b.block.steps[2] != 0 {
                    let _ = write!(line, " Z{}", fmt_mm(mm(pos[2], sz), dz));
                }
                let f = if b.kind == MoveKind::Travel { travel_feed.clone() } else { per_min(pen.draw_feed_mm_s) };
                with_feed(&mut line, &f);
            }
            MoveKind::PenUp | MoveKind::PenDown if servo => {
                // The servo block's own angle; the pen's up or down angle for a block without one.
                let angle = if b.kind == MoveKind::PenUp { profile.pen.servo_up_deg } else { pen.servo_down_deg };
                let deg = b.block.servo.map_or(angle, |t| f64::from(t) / 10.0);
                let _ = write!(line, "M3 S{}", fmt_mm(deg, 1));
                // A servo block carries its settle time: GRBL runs the spindle word, then the dwell, of one line.
                if b.block.servo.is_some() {
                    let _ = write!(line, " G4 P{}", seconds(b.block.duration_ticks()));
                }
            }
            MoveKind::PenUp | MoveKind::PenDown => {
                let _ = write!(line, "G1 Z{}", fmt_mm(mm(pos[2], sz), dz));
                with_feed(&mut line, &z_feed);
            }
            MoveKind::Settle => {
                let _ = write!(line, "G4 P{}", seconds(b.block.duration_ticks()));
            }
        }
        match b.kind {
            MoveKind::PenUp => pen_up = true,
            MoveKind::PenDown => pen_up = false,
            _ => {}
        }
        let next_is_settle = plan.blocks.get(i + 1).is_some_and(|n| n.kind == MoveKind::Settle);
        safe_after.push(pen_up && !next_is_settle);
        lines.push(line);
    }
    Program { lines, safe_after }
}

/// The lines that lift the pen from Z `z_now` (steps of the plot's coordinates) with the command the plot lifts
/// it with: `M3 S<up angle>` for a servo pen (never `M5`, which lets a stock GRBL's servo go limp); for a Z pen a move to the pen-up height written relative (`G91 G0 Z…`, then
/// `G90`), so that it holds whatever work offsets a soft reset dropped — nothing when Z already stands at the
/// pen-up height or beyond it (away from the paper).
pub fn lift(profile: &MachineProfile, z_now: i32) -> Result<Vec<String>, plotter_path::motion::plan::PlanError> {
    if profile.pen.uses_servo() {
        return Ok(vec![format!("M3 S{}", fmt_mm(profile.pen.servo_up_deg, 1))]);
    }
    let up = plotter_path::motion::plan::homed_position(profile)?[2];
    let sz = profile.axes.z.steps_per_mm;
    let down = plotter_path::geometry::steps::round_steps(profile.pen.down_z_mm * sz).unwrap_or(up);
    let lifted = if up >= down { z_now >= up } else { z_now <= up };
    if lifted {
        return Ok(Vec::new());
    }
    let dz = fmt_mm(mm(up - z_now, sz), decimals_for(sz));
    Ok(vec![format!("G91 G0 Z{dz}"), "G90".into()])
}

/// The `G92` line declaring that the machine stands at `pos` (steps of the plot's coordinates); Z is left out for
/// a servo pen.
pub fn declare_position(profile: &MachineProfile, pos: [i32; 4]) -> String {
    let ax = &profile.axes;
    let (sx, sy, sz) = (ax.x.steps_per_mm, ax.y.steps_per_mm, ax.z.steps_per_mm);
    let mut l =
        format!("G92 X{} Y{}", fmt_mm(mm(pos[0], sx), decimals_for(sx)), fmt_mm(mm(pos[1], sy), decimals_for(sy)));
    if !profile.pen.uses_servo() {
        let _ = write!(l, " Z{}", fmt_mm(mm(pos[2], sz), decimals_for(sz)));
    }
    l
}

#[cfg(test)]
mod tests {
    use super::*;
    use plotter_path::geometry::steps::drawing_to_steps;
    use plotter_path::kurbo::Point;
    use plotter_path::motion::plan::{Lookahead, homed_position, plan};
    use plotter_path::{Drawing, Layer, Polyline, Rgb};

    fn two_layers() -> Drawing {
        let mut d = Drawing::single_layer(
            "black",
            vec![Polyline::new(vec![Point::new(10.0, 10.0), Point::new(12.5, 10.0), Point::new(12.5, 11.0125)])],
        );
        let mut red = Layer::new("red");
        red.pen.color = Rgb(255, 0, 0);
        red.paths = vec![Polyline::new(vec![Point::new(20.0, 10.0), Point::new(21.0, 10.0)])];
        d.layers.push(red);
        d
    }

    #[test]
    fn one_line_per_block_with_exact_positions() {
        let mut p = MachineProfile::default_plotter();
        p.pens = vec![plotter_path::config::profile::PenSpec {
            name: "red".into(),
            color: Some("#ff0000".into()),
            width_mm: None,
            down_z_mm: Some(1.0),
            servo_down_deg: None,
            draw_feed_mm_s: Some(10.0),
            hatch: None,
        }];
        let steps = drawing_to_steps(&p, &two_layers()).unwrap();
        let plan = plan(&p, &steps, homed_position(&p).unwrap(), Lookahead::Whole).unwrap();
        let prog = program(&p, &plan);
        assert_eq!(prog.lines.len(), plan.blocks.len());
        // The first hop starts at the pen-up height and comes down on the way (14.14 mm at the hop slope 0.0517:
        // 0.73 mm, to 3.27 mm); after the pen change the travel is flat at the pen-up height.
        assert_eq!(
            prog.lines,
            [
                "G1 X10 Y10 Z3.27 F7200",
                "G1 Z0 F1500",
                "G4 P0.049",
                "G1 X12.5 Y10 F3600",
                "G1 X12.5 Y11.0125",
                "G1 Z4 F1500",
                "G4 P0.049",
                "G1 X20 Y10 F7200",
                "G1 Z1 F1500",
                "G4 P0.049",
                "G1 X21 Y10 F600",
                "G1 Z4 F1500",
                "G4 P0.049",
            ]
        );
        let safe: Vec<usize> = prog.safe_after.iter().enumerate().filter(|(_, s)| **s).map(|(i, _)| i).collect();
        assert_eq!(safe, [0, 6, 7, 12]);
        assert_eq!(declare_position(&p, [0, 80, 1600, 0]), "G92 X0 Y1 Z4");
    }

    #[test]
    fn servo_pens_are_lifted_and_lowered_with_m3_never_m5() {
        let mut p = MachineProfile::default_plotter();
        p.pen.command = plotter_path::config::profile::PenCommand::Servo;
        p.pen.servo_down_deg = 25.0;
        // Planned for GRBL, which stops the motion for `M3`.
        p.servo_sync = plotter_path::motion::servo::ServoSync::AtRest;
        let steps = drawing_to_steps(&p, &two_layers()).unwrap();
        let plan = plan(&p, &steps, homed_position(&p).unwrap(), Lookahead::Whole).unwrap();
        let prog = program(&p, &plan);
        // The servo blocks carry the 50 ms settle (written 0.049 s: GRBL dwells in whole 50 ms steps); the plot starts
        // by lifting the pen (its angle is not known). The tip touches at 0.7 of the servo's swing, 35 ms after the
        // drop is commanded, so the drop goes out before the travel's last 35 ms: the last 33 steps (0.4125 mm) of this
        // deceleration take 33.3 ms, so 36 steps (0.45 mm) take 33.3·√(36/33) = 34.8 ms, and the line starts at
        // contact, a 0.2 ms dwell written P0. Before the pen change the lift is whole and the travel after it flat.
        assert_eq!(
            prog.lines,
            [
                "M3 S90 G4 P0.049",
                "G1 X9.55 Y9.55 F7200",
                "M3 S25 G4 P0",
                "G1 X10 Y10",
                "G4 P0",
                "G1 X12.5 Y10 F3600",
                "G1 X12.5 Y11.0125",
                "M3 S90 G4 P0.049",
                "G1 X20 Y10 F7200",
                "M3 S25 G4 P0.049",
                "G1 X21 Y10 F3600",
                "M3 S90 G4 P0.049",
            ]
        );
        assert_eq!(declare_position(&p, [8, 0, 1600, 0]), "G92 X0.1 Y0");
        // At the profile's up angle (90°), whatever Z says; never `M5`, which lets a stock GRBL's servo go limp.
        assert_eq!(lift(&p, 0).unwrap(), ["M3 S90"], "a servo pen is lifted whatever Z says");
        assert!(prog.lines.iter().all(|l| !l.contains("M5")));
    }

    #[test]
    fn dwells_are_written_for_grbls_50_ms_steps() {
        // GRBL dwells ⌈20·P⌉ steps of 50 ms: each dwell is written a millisecond short of the steps that cover it,
        // out of reach of single precision's rounding, and what is under half a millisecond is no dwell.
        let cases = [(1, "0"), (499, "0"), (500, "0.049"), (45_000, "0.049"), (50_000, "0.049"), (50_001, "0.099")];
        for (ticks, p) in cases.into_iter().chain([(150_000, "0.149"), (1_300_000, "1.299")]) {
            assert_eq!(seconds(ticks), p, "{ticks}");
        }
    }

    #[test]
    fn a_z_pen_is_lifted_by_a_relative_move_to_the_pen_up_height() {
        // The kit: pen up at Z 4 mm, down at 0 mm, 400 steps/mm.
        let p = MachineProfile::default_plotter();
        assert_eq!(lift(&p, 0).unwrap(), ["G91 G0 Z4", "G90"]);
        assert_eq!(lift(&p, 300).unwrap(), ["G91 G0 Z3.25", "G90"]);
        assert_eq!(lift(&p, 1600).unwrap(), Vec::<String>::new(), "already up");
        assert_eq!(lift(&p, 1700).unwrap(), Vec::<String>::new(), "above the pen-up height: never lowered");
    }
}
