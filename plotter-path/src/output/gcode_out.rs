//! GRBL-compatible G-code export of a drawing.
//!
//! The program is millimetres (`G21`), absolute (`G90`), machine coordinates (the page → machine mapping is already
//! applied by [`crate::geometry::steps`]). Pen-up travel is `G0`, drawing is `G1` at the profile's drawing feed. The pen is
//! lifted and lowered either as Z moves (`G0 Z<up>` / `G1 Z<down>`, the default) or, for servo pen lifts
//! ([`PenCommand::Servo`] in the profile), as `M3 S<angle>` / `M5` (the pen's down angle in degrees, as this
//! project's firmware and GRBL servo-pen builds with `$30=180` take it).
//! Each drop, and each lift before a pen change or at the end, is followed by a `G4` dwell of the profile's
//! settle time when it is non-zero. Between two strokes drawn with one pen the hop overlaps the pen's motion with
//! the travel as the motion plan does ([`crate::motion::hop`]): a Z pen rises only to the clearance height
//! (`G1 Z<clear>`, no dwell), travels with combined moves (`G0 X Y Z`) on which it climbs towards the pen-up height
//! and comes back down to the clearance height, and drops from there; a servo pen waits only its clear time
//! (`pen.clear_ms`) after `M5` before travelling (the drop `M3` waits for the travel to end, as GRBL runs spindle
//! words between moves). The first travel, from wherever the machine stands, is flat at the pen-up height. In a
//! file the hops keep above the midpoint between the lowest pen-down height and the pen-up height (the clearance
//! is raised to just above it when smaller): readers that tell travel from drawing by that midpoint, this
//! project's G-code import among them, then see every hop as travel.
//!
//! Between layers drawn with different pens ([`crate::config::pens`]) the program parks the carriage (pen up)
//! and stops with `M0` and a comment naming the pen to load; cycle start (`~` on GRBL) continues. Each layer is
//! drawn with its pen's down height (or servo angle) and drawing feed.
//!
//! Coordinates are written from the step-rounded positions, with enough decimals that the firmware's own rounding
//! (`round(mm × steps/mm)`) lands on exactly the same step: the G-code path and the step-block path draw the same
//! steps.

use std::fmt::Write as _;

use crate::MachineProfile;
use crate::config::profile::PenCommand;
use crate::geometry::steps::{StepDrawing, StepMapper, StepPos};
use crate::motion::hop::{HopHeights, travel_waypoints};
use crate::motion::plan::{layer_pens, park_position};

/// Format a millimetre value with at most `decimals` decimals, trailing zeros removed (`-0` printed as `0`).
pub fn fmt_mm(v: f64, decimals: usize) -> String {
    let mut s = format!("{v:.decimals$}");
    if s.contains('.') {
        while s.ends_with('0') {
            s.pop();
        }
        if s.ends_with('.') {
            s.pop();
        }
    }
    if s == "-0" { "0".to_string() } else { s }
}

/// Decimals needed so that `round(printed × steps_per_mm)` recovers every step count: the printing error
/// (½·10⁻ᵈ mm) must stay well under half a step.
pub fn decimals_for(steps_per_mm: f64) -> usize {
    let mut d = 3;
    while d < 9 && 0.5 * 10f64.powi(-i32::try_from(d).unwrap_or(9)) * steps_per_mm > 0.005 {
        d += 1;
    }
    d
}

/// Write `steps` as a G-code program for `profile`'s machine.
pub fn export(profile: &MachineProfile, steps: &StepDrawing) -> String {
    let mapper = StepMapper::new(profile);
    let (sx, sy) = mapper.steps_per_mm();
    let (dx, dy) = (decimals_for(sx), decimals_for(sy));
    let dz = decimals_for(profile.axes.z.steps_per_mm);
    let pen = &profile.pen;
    let settle = if pen.settle_ms > 0.0 { Some(fmt_mm(pen.settle_ms / 1000.0, 4)) } else { None };
    let per_min = |mm_s: f64| fmt_mm(mm_s * 60.0, 1);
    let up = match pen.command {
        PenCommand::Z => format!("G0 Z{}", fmt_mm(pen.up_z_mm, dz)),
        PenCommand::Servo => "M5".to_string(),
    };
    let pens = layer_pens(profile, steps);
    let z_of = |mm: f64| mapper.z_steps(mm).unwrap_or(0);
    let z_mm = |steps: i32| fmt_mm(f64::from(steps) / profile.axes.z.steps_per_mm, dz);
    let z_feed = per_min(profile.axes.z.max_feed_mm_s);
    let downs: Vec<String> = pens
        .iter()
        .map(|p| match pen.command {
            PenCommand::Z => format!("G1 Z{} F{z_feed}", fmt_mm(p.down_z_mm, dz)),
            PenCommand::Servo => format!("M3 S{}", fmt_mm(p.servo_down_deg, 1)),
        })
        .collect();
    let mut hop_profile = profile.clone();
    let lowest = pens.iter().map(|p| p.down_z_mm).fold(pen.down_z_mm, f64::min);
    let above_mid = (pen.up_z_mm - lowest).abs() / 2.0 + 1.0 / profile.axes.z.steps_per_mm;
    hop_profile.pen.clearance_mm = pen.clearance_mm.max(above_mid);
    let heights: Vec<HopHeights> =
        pens.iter().map(|p| HopHeights::new(&hop_profile, z_of(p.down_z_mm), z_of(pen.up_z_mm))).collect();
    let servo_clear = fmt_mm(pen.servo_clear_ms() / 1000.0, 4);
    // Without a park position the pen change waits above the homed corner.
    let park = park_position(profile).ok().map(|s| mapper.steps_to_machine(s));
    let mut out = String::new();
    let _ = writeln!(out, "; {} — {} stroke(s)", profile.name, steps.strokes.len());
    let _ = writeln!(out, "G21 ; millimetres\nG90 ; absolute coordinates");
    let lift = |out: &mut String, cmd: &str| {
        let _ = writeln!(out, "{cmd}");
        if let Some(s) = &settle {
            let _ = writeln!(out, "G4 P{s}");
        }
    };
    lift(&mut out, &up);
    let travel_f = per_min(pen.travel_feed_mm_s);
    let xy = |p: StepPos| {
        let m = mapper.steps_to_machine(p);
        format!("X{} Y{}", fmt_mm(m.x, dx), fmt_mm(m.y, dy))
    };
    let mut layer = 0;
    // Where the last stroke ended, and the pen's Z (steps) after the last line.
    let mut at: Option<StepPos> = None;
    let mut z = z_of(pen.up_z_mm);
    for (si, stroke) in steps.strokes.iter().enumerate() {
        let l = steps.layer_of(si);
        let change = l != layer && !pens[l].same_pen(&pens[layer]);
        if si > 0 {
            match pen.command {
                _ if change => {
                    lift(&mut out, &up);
                    z = heights[layer].up;
                }
                PenCommand::Z => {
                    z = heights[layer].clear;
                    let _ = writeln!(out, "G1 Z{} F{z_feed}", z_mm(z));
                }
                PenCommand::Servo => {
                    let _ = writeln!(out, "M5");
                    if pen.servo_clear_ms() > 0.0 {
                        let _ = writeln!(out, "G4 P{servo_clear}");
                    }
                }
            }
        }
        if change {
            if let Some(p) = park {
                let _ = writeln!(out, "G0 X{} Y{} F{travel_f}", fmt_mm(p.x, dx), fmt_mm(p.y, dy));
            }
            let name = steps.layers.get(l).map_or("", |x| x.name.as_str());
            let _ = writeln!(out, "M0 ; pen change: load {} for layer {name:?}", pens[l].label());
        }
        layer = l;
        match at {
            Some(from) if pen.command == PenCommand::Z && !change => {
                let mut f = format!(" F{travel_f}");
                for w in travel_waypoints(&hop_profile, [from.x, from.y, z], stroke.start, heights[l]) {
                    let _ = writeln!(out, "G0 {} Z{}{f}", xy(StepPos::new(w[0], w[1])), z_mm(w[2]));
                    f.clear();
                    z = w[2];
                }
            }
            _ => {
                let _ = writeln!(out, "G0 {} F{travel_f}", xy(stroke.start));
            }
        }
        lift(&mut out, &downs[l]);
        let draw_f = per_min(pens[l].draw_feed_mm_s);
        let mut first = true;
        for pos in stroke.positions().into_iter().skip(1) {
            if first {
                let _ = writeln!(out, "G1 {} F{draw_f}", xy(pos));
                first = false;
            } else {
                let _ = writeln!(out, "G1 {}", xy(pos));
            }
        }
        at = Some(stroke.end());
    }
    if !steps.strokes.is_empty() {
        lift(&mut out, &up);
    }
    let _ = writeln!(out, "M2");
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::steps::{StepDelta, StepPos, StepStroke};

    fn square() -> StepDrawing {
        StepDrawing {
            strokes: vec![StepStroke {
                start: StepPos::new(80, 8),
                moves: vec![
                    StepDelta { dx: 800, dy: 0 },
                    StepDelta { dx: 0, dy: 801 },
                    StepDelta { dx: -800, dy: -801 },
                ],
            }],
            layers: vec![],
        }
    }

    #[test]
    fn z_pen_program_is_exact() {
        let p = MachineProfile::default_plotter();
        let g = export(&p, &square());
        let body: Vec<&str> = g.lines().skip(1).collect();
        assert_eq!(
            body,
            [
                "G21 ; millimetres",
                "G90 ; absolute coordinates",
                "G0 Z4",
                "G4 P0.05",
                "G0 X1 Y0.1 F7200",
                "G1 Z0 F1500",
                "G4 P0.05",
                "G1 X11 Y0.1 F3600",
                "G1 X11 Y10.1125",
                "G1 X1 Y0.1",
                "G0 Z4",
                "G4 P0.05",
                "M2",
            ]
        );
    }

    #[test]
    fn hops_between_strokes_overlap_the_pen_moves_with_the_travel() {
        let p = MachineProfile::default_plotter();
        let dash = |x: i32| StepStroke { start: StepPos::new(x, 800), moves: vec![StepDelta { dx: 80, dy: 0 }] };
        let g = export(&p, &StepDrawing { strokes: vec![dash(800), dash(1680)], layers: vec![] });
        let body: Vec<&str> = g.lines().skip(3).collect();
        // From the first dash's end (11, 10) to (21, 10): rise without a dwell to the clearance, raised in a file
        // to a step above the 2 mm midpoint of the paper and the pen-up height (2.0025 mm), a climb to 5 mm ·
        // 0.051 65 = 0.258 mm above it (103 of 400 steps/mm: 2.26 mm) and back, the drop with its settle.
        assert_eq!(
            body,
            [
                "G0 Z4",
                "G4 P0.05",
                "G0 X10 Y10 F7200",
                "G1 Z0 F1500",
                "G4 P0.05",
                "G1 X11 Y10 F3600",
                "G1 Z2.0025 F1500",
                "G0 X16 Y10 Z2.26 F7200",
                "G0 X21 Y10 Z2.0025",
                "G1 Z0 F1500",
                "G4 P0.05",
                "G1 X22 Y10 F3600",
                "G0 Z4",
                "G4 P0.05",
                "M2",
            ]
        );
        // A servo pen waits only its clear time (a third of the settle) after the lift between them.
        let mut servo = p.clone();
        servo.pen.command = PenCommand::Servo;
        let g = export(&servo, &StepDrawing { strokes: vec![dash(800), dash(1680)], layers: vec![] });
        assert!(g.contains("G1 X11 Y10 F3600\nM5\nG4 P0.0167\nG0 X21 Y10 F7200\nM3 S30\nG4 P0.05\n"), "{g}");
    }

    #[test]
    fn servo_pen_uses_m3_m5_without_dwell() {
        let mut p = MachineProfile::default_plotter();
        p.pen.command = PenCommand::Servo;
        p.pen.settle_ms = 0.0;
        let g = export(&p, &square());
        assert!(g.contains("\nM3 S30\n") && g.contains("\nM5\n"), "{g}");
        assert!(!g.contains('Z') && !g.contains("G4"), "{g}");
    }

    #[test]
    fn pen_changes_park_and_stop_with_m0() {
        use crate::geometry::steps::StepLayer;
        use crate::{Pen, Rgb};
        let mut p = MachineProfile::default_plotter();
        // No pen table: each colour is its own pen, named after its layer.
        p.pens.clear();
        p.park = Some(crate::config::profile::ParkProfile { x_mm: 2.0, y_mm: 3.0 });
        let stroke = |x: i32| StepStroke { start: StepPos::new(x, 8), moves: vec![StepDelta { dx: 80, dy: 0 }] };
        let layer = |name: &str, color: Rgb, first_stroke: usize| StepLayer {
            name: name.into(),
            pen: Pen { color, width_mm: 0.3 },
            first_stroke,
        };
        let red = Rgb(255, 0, 0);
        let d = StepDrawing {
            strokes: vec![stroke(0), stroke(160), stroke(320), stroke(480)],
            // black, red, red (same pen: no stop), black.
            layers: vec![layer("a", Rgb::BLACK, 0), layer("b", red, 1), layer("c", red, 2), layer("d", Rgb::BLACK, 3)],
        };
        let g = export(&p, &d);
        let stops: Vec<&str> = g.lines().filter(|l| l.starts_with("M0")).collect();
        assert_eq!(
            stops,
            ["M0 ; pen change: load b (#ff0000) for layer \"b\"", "M0 ; pen change: load d (#000000) for layer \"d\""]
        );
        // Each stop comes after the lift (and its dwell) and the park move.
        let lines: Vec<&str> = g.lines().collect();
        let i = lines.iter().position(|l| l.starts_with("M0")).unwrap();
        assert_eq!(&lines[i - 3..i], ["G0 Z4", "G4 P0.05", "G0 X2 Y3 F7200"]);
        assert_eq!(lines[i + 1], "G0 X2 Y0.1 F7200", "then the travel to the red layer's first stroke");
    }

    #[test]
    fn printed_coordinates_round_back_to_the_same_steps() {
        for spm in [80.0, 78.74, 100.0 / 3.0, 157.48, 6400.0] {
            let d = decimals_for(spm);
            for steps in [-12345i32, -1, 0, 1, 7, 33333, 1_000_001] {
                let printed: f64 = fmt_mm(f64::from(steps) / spm, d).parse().unwrap();
                assert_eq!((printed * spm).round(), f64::from(steps), "spm {spm} steps {steps}");
            }
        }
        assert_eq!(fmt_mm(-0.00001, 3), "0");
        assert_eq!(fmt_mm(2.5, 3), "2.5");
    }
}
