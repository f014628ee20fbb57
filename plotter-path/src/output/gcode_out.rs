//! GRBL-compatible G-code export of a drawing.
//!
//! The program is millimetres (`G21`), absolute (`G90`), machine coordinates (the page → machine mapping is already
//! applied by [`crate::geometry::steps`]). Pen-up travel is `G0`, drawing is `G1` at the profile's drawing feed. The pen is
//! lifted and lowered either as Z moves (`G0 Z<up>` / `G1 Z<down>`, the default) or, for servo pen lifts
//! ([`PenCommand::Servo`] in the profile), as `M3 S<up>` / `M3 S<down>` (the pen's angles in degrees).
//! Each drop, and each lift before a pen change or at the end, is followed by a `G4` dwell of the profile's
//! settle time when it is non-zero. Between two strokes drawn with one pen the hop overlaps the pen's motion with
//! the travel as the motion plan does ([`crate::motion::hop`]): a Z pen rises only to the clearance height
//! (`G1 Z<clear>`, no dwell), travels with combined moves (`G0 X Y Z`) on which it climbs towards the pen-up height
//! and comes back down to the clearance height, and drops from there; a servo pen waits only until its tip is
//! clear after the lift before travelling, timed as the motion plan times it (the swing above the pen's contact
//! fraction, or the profile's `pen.clear_ms`); the drop waits for the travel to end, as GRBL runs spindle words
//! between moves. The first travel, from wherever the machine stands, is flat at the pen-up height. In a
//! file the hops keep above the midpoint between the lowest pen-down height and the pen-up height (the clearance
//! is raised to just above it when smaller): readers that tell travel from drawing by that midpoint, this
//! project's G-code import among them, then see every hop as travel.
//!
//! Between layers drawn with different pens ([`crate::config::pens`]) the program parks the carriage (pen up)
//! and stops with `M0` and a comment naming the pen to load; cycle start (`~` on GRBL) continues. Each layer is
//! drawn with its pen's down height (or servo angle) and drawing feed.
//!
//! A servo pen per firmware — the export raises it with `M3 S<pen.servo_up_deg>` and never writes `M5`:
//!
//! * **Stock GRBL 1.1** with the hobby servo on the spindle PWM (`$30=180`, so that `S` is degrees): `M5` stops the
//!   PWM and an unpowered servo lets the pen fall onto the paper; `M3 S<up>` keeps the pulses on and holds it up.
//!   GRBL's program end (`M2`/`M30`) switches the spindle off as `M5` does, so a servo program ends with the pen
//!   held up and no `M2` (a profile that wants one writes `footer = "M2"`).
//! * **GRBL servo-pen builds** (where `M5` moves the servo to a pen-up angle of its own): `M3 S<up>` lifts there too,
//!   to the profile's angle.
//! * **This project's firmware**: `M3 S<angle>` drives the servo to the angle and `M5` to its configured pen-up
//!   angle; the export's `M3 S<up>` is the same lift, at the profile's angle.
//! * **EiBotBoard** (AxiDraw-class) machines get no G-code: the plot speaks EBB commands (`SP`, `SC`).
//!
//! The profile's `[gcode]` templates ([`crate::config::gcode_template`]) replace the header, the footer, the pen's
//! lifts and drops, and the pen-change stop, and add lines at each layer's start and end, for machines whose
//! dialect differs; without them the program is as described here.
//!
//! Coordinates are written from the step-rounded positions, with enough decimals that the firmware's own rounding
//! (`round(mm × steps/mm)`) lands on exactly the same step: the G-code path and the step-block path draw the same
//! steps.

use std::fmt::Write as _;

use crate::MachineProfile;
use kurbo::Point;

use crate::config::gcode_template::{Values, render};
use crate::config::profile::PenCommand;
use crate::geometry::steps::{StepDrawing, StepMapper, StepPos};
use crate::motion::hop::{HopHeights, travel_waypoints};
use crate::motion::plan::{layer_pens, lift_clear_ticks, park_position};
use crate::motion::servo::ServoTiming;

/// Seconds a servo lift waits before the travel, as the motion plan times it for a pen whose down angle is
/// `down_deg` ([`lift_clear_ticks`]: the profile's `pen.clear_ms`, else until the tip is clear of the paper at the
/// servo's rate, the swing above `pen.contact_fraction`).
fn servo_clear_s(profile: &MachineProfile, down_deg: f64) -> f64 {
    let ticks = lift_clear_ticks(profile, ServoTiming::of(profile, down_deg));
    // At most a few seconds of ticks.
    #[allow(clippy::cast_precision_loss)]
    let ticks = ticks as f64;
    ticks / f64::from(plotter_fw::TICK_HZ)
}

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

/// Write `steps` as a G-code program for `profile`'s machine (with the profile's `[gcode]` templates where given).
pub fn export(profile: &MachineProfile, steps: &StepDrawing) -> String {
    let mapper = StepMapper::new(profile);
    let (sx, sy) = mapper.steps_per_mm();
    let (dx, dy) = (decimals_for(sx), decimals_for(sy));
    let dz = decimals_for(profile.axes.z.steps_per_mm);
    let pen = &profile.pen;
    let t = &profile.gcode;
    let servo = pen.command == PenCommand::Servo;
    // The pen's own lifts and drops replaced by the profile's: each is whole, and the travel between is flat.
    let custom = t.replaces_pen_moves();
    let settle = if pen.settle_ms > 0.0 { Some(fmt_mm(pen.settle_ms / 1000.0, 4)) } else { None };
    let per_min = |mm_s: f64| fmt_mm(mm_s * 60.0, 1);
    let pens = layer_pens(profile, steps);
    let z_of = |mm: f64| mapper.z_steps(mm).unwrap_or(0);
    let z_mm = |steps: i32| fmt_mm(f64::from(steps) / profile.axes.z.steps_per_mm, dz);
    let z_feed = per_min(profile.axes.z.max_feed_mm_s);
    // `{up}` and a layer's `{down}`: Z millimetres, or servo degrees.
    let up_at = if servo { fmt_mm(pen.servo_up_deg, 1) } else { fmt_mm(pen.up_z_mm, dz) };
    let down_at = |l: usize| if servo { fmt_mm(pens[l].servo_down_deg, 1) } else { fmt_mm(pens[l].down_z_mm, dz) };
    let names: Vec<&str> = (0..pens.len()).map(|l| steps.layers.get(l).map_or("", |x| x.name.as_str())).collect();
    let values = |l: usize, m: Point| Values {
        x: fmt_mm(m.x, dx),
        y: fmt_mm(m.y, dy),
        layer: names[l],
        index: l + 1,
        pen: &pens[l].name,
        up: up_at.clone(),
        down: down_at(l),
    };
    // A servo pen is held up at its up angle (`M3 S<up>`), never let go with `M5` (see the module docs).
    let up_line = if servo { format!("M3 S{up_at}") } else { format!("G0 Z{up_at}") };
    let up = |l: usize, m: Point| match &t.pen_up {
        Some(tpl) => render(tpl, &values(l, m)),
        None => vec![up_line.clone()],
    };
    let down = |l: usize, m: Point| match &t.pen_down {
        Some(tpl) => render(tpl, &values(l, m)),
        None if servo => vec![format!("M3 S{}", down_at(l))],
        None => vec![format!("G1 Z{} F{z_feed}", down_at(l))],
    };
    let mut hop_profile = profile.clone();
    let lowest = pens.iter().map(|p| p.down_z_mm).fold(pen.down_z_mm, f64::min);
    let above_mid = (pen.up_z_mm - lowest).abs() / 2.0 + 1.0 / profile.axes.z.steps_per_mm;
    hop_profile.pen.clearance_mm = pen.clearance_mm.max(above_mid);
    let heights: Vec<HopHeights> =
        pens.iter().map(|p| HopHeights::new(&hop_profile, z_of(p.down_z_mm), z_of(pen.up_z_mm))).collect();
    // No dwell where the wait rounds to nothing (a servo the profile gives no swing time).
    let servo_clear: Vec<Option<String>> = pens
        .iter()
        .map(|p| Some(fmt_mm(servo_clear_s(profile, p.servo_down_deg), 4)).filter(|s| s.as_str() != "0"))
        .collect();
    // Without a park position the pen change waits above the homed corner.
    let park = park_position(profile).ok().map(|s| mapper.steps_to_machine(s));
    let mut out = String::new();
    let put = |out: &mut String, lines: &[String]| {
        for l in lines {
            let _ = writeln!(out, "{l}");
        }
    };
    let _ = writeln!(out, "; {} — {} stroke(s)", profile.name, steps.strokes.len());
    match &t.header {
        Some(h) => put(&mut out, &render(h, &Values::default())),
        None => {
            let _ = writeln!(out, "G21 ; millimetres\nG90 ; absolute coordinates");
        }
    }
    let lift = |out: &mut String, lines: &[String]| {
        put(out, lines);
        if let Some(s) = &settle {
            let _ = writeln!(out, "G4 P{s}");
        }
    };
    let machine = |p: StepPos| mapper.steps_to_machine(p);
    let first = steps.strokes.first().map_or(Point::ORIGIN, |s| machine(s.start));
    lift(&mut out, &up(0, first));
    let travel_f = per_min(pen.travel_feed_mm_s);
    let xy = |p: StepPos| {
        let m = machine(p);
        format!("X{} Y{}", fmt_mm(m.x, dx), fmt_mm(m.y, dy))
    };
    let mut layer = 0;
    // Where the carriage is (machine mm), where the last stroke ended, and the pen's Z (steps) after the last line.
    let mut here = first;
    let mut at: Option<StepPos> = None;
    let mut z = z_of(pen.up_z_mm);
    for (si, stroke) in steps.strokes.iter().enumerate() {
        let l = steps.layer_of(si);
        let change = l != layer && !pens[l].same_pen(&pens[layer]);
        if si > 0 {
            match pen.command {
                _ if change || custom => {
                    lift(&mut out, &up(layer, here));
                    z = heights[layer].up;
                }
                PenCommand::Z => {
                    z = heights[layer].clear;
                    let _ = writeln!(out, "G1 Z{} F{z_feed}", z_mm(z));
                }
                PenCommand::Servo => {
                    put(&mut out, &up(layer, here));
                    if let Some(wait) = &servo_clear[layer] {
                        let _ = writeln!(out, "G4 P{wait}");
                    }
                }
            }
            if let (true, Some(tpl)) = (l != layer, &t.layer_end) {
                put(&mut out, &render(tpl, &values(layer, here)));
            }
        }
        if change {
            if let Some(p) = park {
                let _ = writeln!(out, "G0 X{} Y{} F{travel_f}", fmt_mm(p.x, dx), fmt_mm(p.y, dy));
                here = p;
            }
            match &t.tool_change {
                Some(tpl) => put(&mut out, &render(tpl, &values(l, here))),
                None => {
                    let _ = writeln!(out, "M0 ; pen change: load {} for layer {:?}", pens[l].label(), names[l]);
                }
            }
        }
        if let (true, Some(tpl)) = (si == 0 || l != layer, &t.layer_start) {
            put(&mut out, &render(tpl, &values(l, here)));
        }
        layer = l;
        match at {
            Some(from) if pen.command == PenCommand::Z && !change && !custom => {
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
        here = machine(stroke.start);
        lift(&mut out, &down(l, here));
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
        here = machine(stroke.end());
    }
    if !steps.strokes.is_empty() {
        lift(&mut out, &up(layer, here));
        if let Some(tpl) = &t.layer_end {
            put(&mut out, &render(tpl, &values(layer, here)));
        }
    }
    match &t.footer {
        Some(f) => put(&mut out, &render(f, &Values::default())),
        // GRBL's program end switches the spindle output off as `M5` does: a servo pen would drop.
        None if servo => {}
        None => {
            let _ = writeln!(out, "M2");
        }
    }
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
        // A servo pen waits only until its tip is clear after the lift between them: the 30° → 90° swing takes the
        // 50 ms settle, and the tip leaves the paper once the servo is back above 0.7 of its down travel, after
        // 0.3 × 50 = 15 ms.
        let mut servo = p.clone();
        servo.pen.command = PenCommand::Servo;
        let g = export(&servo, &StepDrawing { strokes: vec![dash(800), dash(1680)], layers: vec![] });
        assert!(g.contains("G1 X11 Y10 F3600\nM3 S90\nG4 P0.015\nG0 X21 Y10 F7200\nM3 S30\nG4 P0.05\n"), "{g}");
        // At a contact fraction of 0.5, half the swing: 25 ms; a profile's own clear time wins.
        servo.pen.contact_fraction = 0.5;
        let g = export(&servo, &StepDrawing { strokes: vec![dash(800), dash(1680)], layers: vec![] });
        assert!(g.contains("M3 S90\nG4 P0.025\nG0 X21"), "{g}");
        servo.pen.clear_ms = Some(20.0);
        let g = export(&servo, &StepDrawing { strokes: vec![dash(800), dash(1680)], layers: vec![] });
        assert!(g.contains("M3 S90\nG4 P0.02\nG0 X21"), "{g}");
        // The profile's lift delay comes after either, as in the motion plan: 20 + 40 ms, and 25 + 40 ms.
        servo.pen.lift_delay_ms = 40.0;
        let g = export(&servo, &StepDrawing { strokes: vec![dash(800), dash(1680)], layers: vec![] });
        assert!(g.contains("M3 S90\nG4 P0.06\nG0 X21"), "{g}");
        servo.pen.clear_ms = None;
        let g = export(&servo, &StepDrawing { strokes: vec![dash(800), dash(1680)], layers: vec![] });
        assert!(g.contains("M3 S90\nG4 P0.065\nG0 X21"), "{g}");
    }

    #[test]
    fn a_servo_pen_is_held_up_with_m3_at_its_up_angle_never_m5() {
        let mut p = MachineProfile::default_plotter();
        p.pen.command = PenCommand::Servo;
        (p.pen.settle_ms, p.pen.servo_up_deg) = (0.0, 120.0);
        let dash = |x: i32| StepStroke { start: StepPos::new(x, 800), moves: vec![StepDelta { dx: 80, dy: 0 }] };
        let g = export(&p, &StepDrawing { strokes: vec![dash(800), dash(1680)], layers: vec![] });
        let body: Vec<&str> = g.lines().skip(3).collect();
        // Lifted at the start, between the strokes and at the end with `M3 S120`; no `M5`, and no `M2`, whose
        // program end switches GRBL's spindle output off as `M5` does.
        assert_eq!(
            body,
            [
                "M3 S120",
                "G0 X10 Y10 F7200",
                "M3 S30",
                "G1 X11 Y10 F3600",
                "M3 S120",
                "G0 X21 Y10 F7200",
                "M3 S30",
                "G1 X22 Y10 F3600",
                "M3 S120",
            ]
        );
        // A profile that wants the program ended so says it in its footer.
        p.gcode.footer = Some("M5\nM2".into());
        assert!(export(&p, &square()).ends_with("M3 S120\nM5\nM2\n"));
    }

    #[test]
    fn templates_replace_the_pen_moves_and_frame_the_layers() {
        use crate::geometry::steps::StepLayer;
        use crate::{Pen, Rgb};
        let mut p = MachineProfile::default_plotter();
        p.pens.clear();
        p.park = Some(crate::config::profile::ParkProfile { x_mm: 2.0, y_mm: 3.0 });
        p.gcode = toml::from_str(
            r#"
            header = "G21\nG90\nG28 ; home first"
            footer = "G0 X0 Y0\nM30"
            pen_up = "M3 S{up} ; up over {x},{y}"
            pen_down = "M3 S{down} ; {pen} down at {x},{y}"
            layer_start = "(layer {index}: {layer})"
            layer_end = "(end of {layer})"
            tool_change = "M6 T{index} ; {pen} at {x} {y}"
            "#,
        )
        .unwrap();
        let stroke = |x: i32| StepStroke { start: StepPos::new(x, 8), moves: vec![StepDelta { dx: 80, dy: 0 }] };
        let layer = |name: &str, color: Rgb, first_stroke: usize| StepLayer {
            name: name.into(),
            pen: Pen { color, width_mm: 0.3 },
            first_stroke,
        };
        let d = StepDrawing {
            strokes: vec![stroke(0), stroke(160), stroke(320)],
            layers: vec![layer("ink", Rgb::BLACK, 0), layer("red", Rgb(255, 0, 0), 2)],
        };
        // A Z pen: `{up}` and `{down}` are its heights (4 and 0 mm); every lift and drop is the template's with
        // the settle after it, and the travel flat.
        let g = export(&p, &d);
        let body: Vec<&str> = g.lines().skip(1).collect();
        assert_eq!(
            body,
            [
                "G21",
                "G90",
                "G28 ; home first",
                "M3 S4 ; up over 0,0.1",
                "G4 P0.05",
                "(layer 1: ink)",
                "G0 X0 Y0.1 F7200",
                "M3 S0 ; ink down at 0,0.1",
                "G4 P0.05",
                "G1 X1 Y0.1 F3600",
                "M3 S4 ; up over 1,0.1",
                "G4 P0.05",
                "G0 X2 Y0.1 F7200",
                "M3 S0 ; ink down at 2,0.1",
                "G4 P0.05",
                "G1 X3 Y0.1 F3600",
                "M3 S4 ; up over 3,0.1",
                "G4 P0.05",
                "(end of ink)",
                "G0 X2 Y3 F7200",
                "M6 T2 ; red at 2 3",
                "(layer 2: red)",
                "G0 X4 Y0.1 F7200",
                "M3 S0 ; red down at 4,0.1",
                "G4 P0.05",
                "G1 X5 Y0.1 F3600",
                "M3 S4 ; up over 5,0.1",
                "G4 P0.05",
                "(end of red)",
                "G0 X0 Y0",
                "M30",
            ]
        );
        // Without templates, the export's own lines (the Z pen program pinned in `z_pen_program_is_exact`).
        p.gcode = crate::config::gcode_template::GcodeTemplate::default();
        assert!(export(&p, &d).ends_with("G1 X5 Y0.1 F3600\nG0 Z4\nG4 P0.05\nM2\n"));
    }

    #[test]
    fn an_unknown_placeholder_in_a_profile_is_refused_naming_it_and_the_profile() {
        let text = include_str!("../../../samples/xy-plotter.toml");
        let bad = format!("{text}\n[gcode]\npen_up = \"M3 S{{angle}}\"\n");
        let e = MachineProfile::from_toml(&bad, "my-servo.toml").unwrap_err().to_string();
        assert!(e.contains("my-servo.toml") && e.contains("unknown placeholder {angle}"), "{e}");
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
