//! The plot-time lower bound stays a bound (issue 39, item 5): on random drawings and every built-in machine model
//! (the sample profiles; a servo pen's also planned for GRBL, where the carriage stops for the drop), the planned
//! time — which the firmware executes to the tick — is never below the lower bound, each part of the plan (pen
//! down, lifts; travel with the pen's time above the lifts part) is at least its part of the bound, and each cause
//! of the
//! time above the bound (`plotter stats --verbose`) is time the plan spends above it, as worded, adding up to the
//! whole gap. Rows of dashes along X or Y make hops along one axis, where the bound charges each hop that axis's
//! own limits (its "hops" cause is the plan's travel less those charges, hop by hop, so it stays ≥ 0 only if
//! every charge is a true least time).

use plotter_path::config::models::MODELS;
use plotter_path::geometry::steps::drawing_to_steps;
use plotter_path::kurbo::Point;
use plotter_path::motion::bound::drawing_time_lower_bound;
use plotter_path::motion::gap::time_gap;
use plotter_path::motion::plan::{Lookahead, homed_position, plan_returning};
use plotter_path::motion::servo::ServoSync;
use plotter_path::optimize::SeamMode;
use plotter_path::{Drawing, MachineProfile, Polyline};
use proptest::prelude::*;

/// One path: straight legs between random points, or an arc finely cut (so the planner's curve rule is met).
#[derive(Debug, Clone)]
enum Shape {
    Legs(Vec<(f64, f64)>),
    Arc {
        centre: (f64, f64),
        radius: f64,
        from: f64,
        sweep: f64,
        chords: u32,
    },
    /// Dashes of `dash` mm in a row along X (or Y), `gap` mm apart: one path per dash.
    Row {
        at: (f64, f64),
        count: u32,
        dash: f64,
        gap: f64,
        along_y: bool,
    },
}

fn shape() -> impl Strategy<Value = Shape> {
    let point = (0.0..100.0f64, 0.0..100.0f64);
    prop_oneof![
        prop::collection::vec(point.clone(), 2..10).prop_map(Shape::Legs),
        (point.clone(), 0.5..40.0f64, 0.0..6.3f64, -6.3..6.3f64, 3..80u32)
            .prop_map(|(centre, radius, from, sweep, chords)| Shape::Arc { centre, radius, from, sweep, chords }),
        (point, 2..8u32, 0.2..5.0f64, 0.05..30.0f64, any::<bool>())
            .prop_map(|(at, count, dash, gap, along_y)| Shape::Row { at, count, dash, gap, along_y }),
    ]
}

/// The paths of a shape.
fn polylines(s: &Shape) -> Vec<Polyline> {
    let Shape::Row { at, count, dash, gap, along_y } = s else { return vec![polyline(s)] };
    (0..*count)
        .map(|i| {
            let a = f64::from(i) * (dash + gap);
            let p = |t: f64| if *along_y { Point::new(at.0, at.1 + t) } else { Point::new(at.0 + t, at.1) };
            Polyline::new(vec![p(a), p(a + dash)])
        })
        .collect()
}

fn polyline(s: &Shape) -> Polyline {
    match s {
        Shape::Legs(p) => Polyline::new(p.iter().map(|&(x, y)| Point::new(x, y)).collect()),
        Shape::Arc { centre, radius, from, sweep, chords } => Polyline::new(
            (0..=*chords)
                .map(|k| {
                    let t = from + sweep * f64::from(k) / f64::from(*chords);
                    Point::new(centre.0 + radius * t.cos(), centre.1 + radius * t.sin())
                })
                .collect(),
        ),
        Shape::Row { .. } => polylines(s).swap_remove(0),
    }
}

/// Every built-in model that plots with a pen (the printer's extruder plans another way); a servo pen's also as
/// planned for GRBL, which stops the carriage for the pen's drop ([`ServoSync::AtRest`]).
fn profiles() -> Vec<(String, MachineProfile)> {
    let pens = MODELS.iter().map(|m| (m.name.to_string(), m.profile())).filter(|(_, p)| p.axes.e.is_none());
    pens.flat_map(|(name, p)| {
        let grbl = p
            .pen
            .uses_servo()
            .then(|| (format!("{name} on GRBL"), MachineProfile { servo_sync: ServoSync::AtRest, ..p.clone() }));
        std::iter::once((name, p)).chain(grbl)
    })
    .collect()
}

/// `shapes` as a drawing scaled into `profile`'s work area, 5 mm in from its edges, or `None` when it has no
/// extent to scale.
fn drawing_on(profile: &MachineProfile, shapes: &[Shape]) -> Option<Drawing> {
    let mut d = Drawing::single_layer("random", shapes.iter().flat_map(polylines).collect());
    let r = d.bbox()?;
    if r.width() < 1e-3 || r.height() < 1e-3 {
        return None;
    }
    let (w, h) = (profile.axes.x.travel_mm - 10.0, profile.axes.y.travel_mm - 10.0);
    let k = (w / r.width()).min(h / r.height()).min(2.0);
    d.map_points(|q| Point::new(5.0 + k * (q.x - r.x0), 5.0 + k * (q.y - r.y0)));
    Some(d)
}

proptest! {
    // Small by default so the suite stays fast (`PROPTEST_CASES` raises it).
    #![proptest_config(ProptestConfig::with_cases(
        std::env::var("PROPTEST_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(12)
    ))]

    #[test]
    fn the_plan_is_never_below_its_bound(shapes in prop::collection::vec(shape(), 1..6), back in any::<bool>()) {
        for (name, p) in profiles() {
            let Some(d) = drawing_on(&p, &shapes) else { continue };
            let steps = drawing_to_steps(&p, &d).unwrap();
            let home = homed_position(&p).unwrap();
            let planned = plan_returning(&p, &steps, home, Lookahead::Whole, back).unwrap();
            // Any order and seam, from anywhere: the weakest travel bound, which any plan must still meet.
            let b = drawing_time_lower_bound(&p, &steps, &d, SeamMode::Any, None).unwrap();
            let parts = planned.breakdown();
            let what = format!("{name}: plan {parts:?}, bound {b:?}");
            prop_assert!(planned.seconds() >= b.total_s(), "total: {}", what);
            prop_assert!(parts.draw_s() >= b.draw_s, "pen down: {}", what);
            prop_assert!(parts.lift_s() >= b.lifts_s, "lifts: {}", what);
            // The travel part charges each hop what its length adds to the pen's moves too (a Z pen's corners, a
            // servo's wider drop window): it bounds the travel with the pen's time above the lifts part.
            prop_assert!(parts.travel_s() + (parts.lift_s() - b.lifts_s) >= b.travel_s, "travel: {}", what);
            let gap = time_gap(&p, &steps, &planned, &b, back).unwrap();
            let above = planned.seconds() - b.total_s();
            prop_assert!((gap.total_s() - above).abs() < 1e-6, "{}: {:?} adds up to {} of {}", what, gap,
                gap.total_s(), above);
            // Each cause is time spent above the bound; what f32 speeds and whole ticks may leave is a tick per
            // block at most.
            #[allow(clippy::cast_precision_loss)]
            let slack = 2e-6 * planned.blocks.len() as f64;
            for (cause, t) in gap.parts() {
                prop_assert!(t >= -slack, "{}: {} is {} s: {:?}", what, cause, t, gap);
            }
        }
    }
}
