//! Curves are planned by their centripetal acceleration, not vertex by vertex (issue 39, item 2): the same arcs
//! flattened at 0.05 mm and at 0.002 mm plan within 1 % of each other on every pen-plotter model, and a circle of
//! radius r is drawn at v = sqrt(a·r) — with saxi's limits (pen down at 200 mm/s² along the path, a cap the
//! planner now holds across the path too) and with the AxiDraw V3's (760 mm/s² per axis).

use plotter_fw::TICK_HZ;
use plotter_path::config::models::{self, MODELS};
use plotter_path::geometry::flatten::flatten_arc;
use plotter_path::geometry::steps::drawing_to_steps;
use plotter_path::kurbo::{Arc, Point, Vec2};
use plotter_path::motion::plan::{Lookahead, MotionPlan, MoveKind, homed_position, plan};
use plotter_path::{Drawing, MachineProfile, Polyline};

/// `turns` full turns of a circle (centre, radius) from its rightmost point, cut at `tolerance`.
fn circle(centre: (f64, f64), radius: f64, turns: f64, tolerance: f64) -> Polyline {
    let arc = Arc {
        center: Point::new(centre.0, centre.1),
        radii: Vec2::new(radius, radius),
        start_angle: 0.0,
        sweep_angle: std::f64::consts::TAU * turns,
        x_rotation: 0.0,
    };
    let mut pts = vec![Point::new(centre.0 + radius, centre.1)];
    flatten_arc(&arc, tolerance, &mut pts);
    Polyline::new(pts)
}

fn planned(profile: &MachineProfile, paths: Vec<Polyline>) -> MotionPlan {
    let d = Drawing::single_layer("curves", paths);
    let steps = drawing_to_steps(profile, &d).unwrap();
    plan(profile, &steps, homed_position(profile).unwrap(), Lookahead::Whole).unwrap()
}

/// Arcs of radius 3 to 40 mm, whole circles and parts of them, inside 10..95 mm (every model's work area). Cut at
/// 0.05 mm a 3 mm circle has 17 chords turning 21° each, at 0.002 mm 83 turning 4.2°; vertex by vertex, saxi's
/// rule takes the first at 38.8 mm/s and the second at its 50 mm/s feed. (On smaller circles the coarse cut is
/// itself shorter than the arc by about tolerance / 3r, 1.1 % at r = 1.5 mm, so no rule can plan both alike.)
fn arcs(tolerance: f64) -> Vec<Polyline> {
    [((20.0, 20.0), 3.0, 3.0), ((40.0, 25.0), 5.0, 2.0), ((60.0, 55.0), 40.0, 0.3), ((30.0, 60.0), 12.0, 0.75)]
        .into_iter()
        .map(|(c, r, turns)| circle(c, r, turns, tolerance))
        .collect()
}

#[test]
fn the_same_arcs_cut_finely_or_coarsely_plan_within_one_per_cent() {
    for m in MODELS {
        let p = m.profile();
        // The printer drives an extruder; the HP-GL plotter plans its own motion (ours only estimates it).
        if p.axes.e.is_some() || m.firmware == models::ModelFirmware::Hpgl {
            continue;
        }
        let coarse = planned(&p, arcs(0.05)).breakdown().draw_s();
        let fine = planned(&p, arcs(0.002)).breakdown().draw_s();
        assert!(
            (fine / coarse - 1.0).abs() < 0.01,
            "{}: pen down {coarse:.3} s at 0.05 mm, {fine:.3} s at 0.002 mm",
            m.name
        );
    }
}

/// The speed of each pen-down block of `plan` (mm/s: its length over its time) from block `from` to `to`.
fn draw_speeds(profile: &MachineProfile, plan: &MotionPlan) -> Vec<f64> {
    let (sx, sy) = (profile.axes.x.steps_per_mm, profile.axes.y.steps_per_mm);
    plan.blocks
        .iter()
        .filter(|b| b.kind == MoveKind::Draw)
        .map(|b| {
            let (dx, dy) = (f64::from(b.block.steps[0]) / sx, f64::from(b.block.steps[1]) / sy);
            dx.hypot(dy) / (f64::from(b.ticks) / f64::from(TICK_HZ))
        })
        .collect()
}

#[test]
fn a_circle_is_drawn_at_the_square_root_of_its_acceleration_times_its_radius() {
    // saxi's limits: 200 mm/s² along the path, in any direction, so all the way round the 5 mm circle
    // v = sqrt(200 × 5) = 31.623 mm/s, below the 50 mm/s pen-down feed. (Vertex by vertex, 0.28 mm chords turn
    // by 3.2° and junction deviation lets them through at the full 50 mm/s: 500 mm/s² on the circle.)
    let saxi = models::find("axidraw-saxi").unwrap().profile();
    for tolerance in [0.05, 0.002] {
        let plan = planned(&saxi, vec![circle((50.0, 50.0), 5.0, 3.0, tolerance)]);
        let v = draw_speeds(&saxi, &plan);
        // The middle turn, well away from the start and the stop.
        let n = v.len();
        for (i, s) in v[n / 3..2 * n / 3].iter().enumerate() {
            assert!((s / 31.623 - 1.0).abs() < 0.02, "tolerance {tolerance}, block {}: {s:.3} mm/s", n / 3 + i);
        }
    }
    // The AxiDraw V3: 760 mm/s² per axis. At the top and bottom of a circle the centre lies straight along Y, so
    // there v = sqrt(760 × 3) = 47.749 mm/s (below its 55 mm/s pen-down feed); half-way between the axes each axis
    // carries 1/√2 of it and v = sqrt(760 √2 × 3) = 56.8 mm/s, capped at the feed: 55 mm/s.
    let v3 = models::find("axidraw-v3").unwrap().profile();
    let plan = planned(&v3, vec![circle((50.0, 50.0), 3.0, 3.0, 0.002)]);
    let v = draw_speeds(&v3, &plan);
    let n = v.len();
    // Blocks per turn, and the middle turn's quarter points: 90° (top) and 45°.
    let per_turn = n / 3;
    let at = |deg: usize| v[per_turn + per_turn * deg / 360];
    assert!((at(90) / 47.749 - 1.0).abs() < 0.02, "top: {:.3} mm/s", at(90));
    assert!((at(270) / 47.749 - 1.0).abs() < 0.02, "bottom: {:.3} mm/s", at(270));
    assert!((at(45) / 55.0 - 1.0).abs() < 0.02, "45°: {:.3} mm/s", at(45));
}
