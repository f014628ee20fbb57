//! A drawing made ready to plot for an interactive front end: the layers the user keeps, with the pens they chose,
//! laid out, ordered, converted to steps, measured, and timed by the firmware's planner — all in memory, from a
//! drawing already decoded (see [`crate::input::decode_drawing`]), so a front end can re-run it on every change of
//! a setting.

use anyhow::{Context as _, bail};
use plotter_path::geometry::cancel::Cancel;
use plotter_path::geometry::steps::{StepDrawing, drawing_to_steps};
use plotter_path::motion::plan::{self, Lookahead, PlanError};
use plotter_path::motion::servo::ServoSync;
use plotter_path::optimize::OptimizeReport;
use plotter_path::output::stats::Stats;
use plotter_path::{Drawing, MachineProfile, Pen};

use crate::options::layout::LayoutArgs;
use crate::options::optimize::{OptimizeArgs, optimize_quietly};

/// What the user chose for one layer (by name).
#[derive(Debug, Clone, PartialEq)]
pub struct LayerChoice {
    /// The layer's name in the drawing.
    pub name: String,
    /// Whether it is plotted.
    pub visible: bool,
    /// The pen it is drawn with (`None`: the drawing's own).
    pub pen: Option<Pen>,
}

/// A drawing ready to plot.
#[derive(Debug, Clone)]
pub struct Prepared {
    /// The visible layers, laid out and in plotting order, in page mm.
    pub drawing: Drawing,
    /// The same as machine steps.
    pub steps: StepDrawing,
    /// Figures of `drawing`.
    pub stats: Stats,
    /// Plot time planned by the firmware's planner from the homed position, seconds (`None` with the reason in
    /// `warnings` when the planner refuses the drawing, e.g. outside the work area).
    pub estimate_s: Option<f64>,
    /// The firmware timing `estimate_s` was planned for: whether a servo pen's drop is commanded on the way (our
    /// firmware, the EBB) or with the carriage at rest (GRBL); the profile's
    /// [`MachineProfile::servo_sync`] as the front end set it from the firmware it knows.
    pub estimate_sync: ServoSync,
    /// What path ordering did (`None` when it is off).
    pub optimize: Option<OptimizeReport>,
    /// What the user should know: unknown layer names, work-area problems.
    pub warnings: Vec<String>,
}

/// Keep the visible layers of `drawing` with their chosen pens, lay them out, order the paths, and plan.
/// Layers the choices do not name are kept as they are; a choice naming no layer is a warning. Once `cancel` is
/// set, the next check between these stages ends the work with
/// [`plotter_path::geometry::cancel::Cancelled`] (an error that downcasts to it).
pub fn prepare(
    mut drawing: Drawing,
    profile: &MachineProfile,
    layers: &[LayerChoice],
    layout: &LayoutArgs,
    optimize: &OptimizeArgs,
    cancel: &Cancel,
) -> anyhow::Result<Prepared> {
    let mut warnings = Vec::new();
    for choice in layers {
        if !drawing.layers.iter().any(|l| l.name == choice.name) {
            warnings.push(format!("layer '{}' is not in the drawing", choice.name));
        }
    }
    drawing.layers.retain_mut(|layer| match layers.iter().find(|c| c.name == layer.name) {
        Some(c) => {
            if let Some(pen) = c.pen {
                layer.pen = pen;
            }
            c.visible
        }
        None => true,
    });
    if drawing.paths().all(|p| p.points.len() < 2) {
        bail!("nothing to plot: every layer is hidden or empty");
    }
    cancel.check()?;
    layout.apply(&mut drawing)?;
    cancel.check()?;
    let report = optimize_quietly(&mut drawing, optimize, Some(profile))?;
    cancel.check()?;
    let steps = drawing_to_steps(profile, &drawing).context("cannot convert the drawing to machine steps")?;
    cancel.check()?;
    let estimate_s = match plan_seconds(profile, &steps) {
        Ok(t) => Some(t),
        Err(e) => {
            warnings.push(format!("cannot plot on '{}': {e}", profile.name));
            None
        }
    };
    let estimate_sync = profile.servo_sync;
    Ok(Prepared { stats: Stats::of(&drawing), drawing, steps, estimate_s, estimate_sync, optimize: report, warnings })
}

/// The plot time of `steps` on `profile` as the firmware's planner makes it from the homed position, seconds;
/// the planner's error for a drawing it refuses (outside the work area).
pub fn plan_seconds(profile: &MachineProfile, steps: &StepDrawing) -> Result<f64, PlanError> {
    plan::check_work_area(profile, steps)?;
    Ok(plan::plan(profile, steps, plan::homed_position(profile)?, Lookahead::Whole)?.seconds())
}

impl Prepared {
    /// The same drawing estimated for `profile`, whose servo timing ([`MachineProfile::servo_sync`]) the firmware
    /// now known has set: `None` when the estimate was already made for that timing (or the drawing cannot be
    /// planned, whose warning stays), else a copy whose estimate is planned again.
    #[must_use]
    pub fn estimated_for(&self, profile: &MachineProfile) -> Option<Prepared> {
        if self.estimate_sync == profile.servo_sync || self.estimate_s.is_none() {
            return None;
        }
        let estimate_s = plan_seconds(profile, &self.steps).ok();
        Some(Prepared { estimate_s, estimate_sync: profile.servo_sync, ..self.clone() })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use plotter_path::kurbo::Point;
    use plotter_path::{Layer, Polyline, Rgb};

    fn square(x: f64, y: f64, side: f64) -> Polyline {
        let p = |dx: f64, dy: f64| Point::new(x + dx, y + dy);
        Polyline::new(vec![p(0.0, 0.0), p(side, 0.0), p(side, side), p(0.0, side), p(0.0, 0.0)])
    }

    fn two_layers() -> Drawing {
        let mut a = Layer::new("a");
        a.paths = vec![square(20.0, 20.0, 10.0)];
        let mut b = Layer::new("b");
        b.paths = vec![square(60.0, 20.0, 5.0)];
        Drawing { layers: vec![a, b], page_mm: None }
    }

    fn no_optimize() -> OptimizeArgs {
        #[derive(clap::Parser)]
        struct W {
            #[command(flatten)]
            o: OptimizeArgs,
        }
        <W as clap::Parser>::parse_from(["w", "--no-optimize"]).o
    }

    #[test]
    fn a_cancelled_preparation_ends_with_the_typed_error() {
        let profile = MachineProfile::default_plotter();
        let cancel = Cancel::new();
        cancel.cancel();
        let e = prepare(two_layers(), &profile, &[], &LayoutArgs::default(), &no_optimize(), &cancel).unwrap_err();
        assert_eq!(
            e.downcast_ref::<plotter_path::geometry::cancel::Cancelled>(),
            Some(&plotter_path::geometry::cancel::Cancelled)
        );
    }

    #[test]
    fn hidden_layers_are_dropped_and_pens_applied() {
        let red = Pen { color: Rgb(200, 0, 0), width_mm: 0.8 };
        let choices = [
            LayerChoice { name: "a".into(), visible: true, pen: Some(red) },
            LayerChoice { name: "b".into(), visible: false, pen: None },
            LayerChoice { name: "ghost".into(), visible: true, pen: None },
        ];
        let profile = MachineProfile::default_plotter();
        let p = prepare(two_layers(), &profile, &choices, &LayoutArgs::default(), &no_optimize(), &Cancel::never())
            .unwrap();
        assert_eq!(p.drawing.layers.len(), 1);
        assert_eq!(p.drawing.layers[0].pen, red);
        assert!((p.stats.pen_down_mm - 40.0).abs() < 1e-9);
        assert_eq!(p.warnings, ["layer 'ghost' is not in the drawing"]);
        // The 40 mm square cannot be drawn faster than at the pen's drawing feed.
        let t = p.estimate_s.unwrap();
        assert!(t > 40.0 / profile.pen.draw_feed_mm_s, "estimate {t} s");
        assert_eq!(p.steps.strokes.len(), 1);
    }

    #[test]
    fn layout_applies_and_nothing_visible_is_an_error() {
        let profile = MachineProfile::default_plotter();
        let layout = LayoutArgs { translate: Some(plotter_path::kurbo::Vec2::new(5.0, -3.0)), ..LayoutArgs::default() };
        let p = prepare(two_layers(), &profile, &[], &layout, &no_optimize(), &Cancel::never()).unwrap();
        assert_eq!(p.stats.bbox_mm, Some([25.0, 17.0, 70.0, 27.0]));
        let hide = |n: &str| LayerChoice { name: n.into(), visible: false, pen: None };
        let e = prepare(two_layers(), &profile, &[hide("a"), hide("b")], &layout, &no_optimize(), &Cancel::never())
            .unwrap_err();
        assert!(e.to_string().contains("nothing to plot"), "{e}");
    }

    #[test]
    fn a_servo_pens_estimate_is_planned_again_for_grbl() {
        // The servo kit: planned as given (for our firmware), its drop is commanded on the way; GRBL stops the
        // carriage for it, so the estimate for a GRBL machine is GRBL's plan, longer by the hops' stops.
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../samples/servo-plotter.toml");
        let kit = MachineProfile::from_toml(&std::fs::read_to_string(path).unwrap(), "servo-plotter.toml").unwrap();
        let p = prepare(two_layers(), &kit, &[], &LayoutArgs::default(), &no_optimize(), &Cancel::never()).unwrap();
        assert_eq!(p.estimate_sync, ServoSync::InMotion);
        assert!(p.estimated_for(&kit).is_none(), "already planned for that timing");
        let grbl = MachineProfile { servo_sync: ServoSync::AtRest, ..kit.clone() };
        let q = p.estimated_for(&grbl).unwrap();
        let planned = |p: &MachineProfile| {
            plan::plan(p, &q.steps, plan::homed_position(p).unwrap(), Lookahead::Whole).unwrap().seconds()
        };
        assert_eq!(p.estimate_s, Some(planned(&kit)));
        assert_eq!((q.estimate_s, q.estimate_sync), (Some(planned(&grbl)), ServoSync::AtRest));
        // The 40 mm hop along X between the squares alone stops some 70 ms for its drop on GRBL.
        assert!(q.estimate_s.unwrap() > p.estimate_s.unwrap() + 0.07, "{:?} vs {:?}", q.estimate_s, p.estimate_s);
    }

    #[test]
    fn outside_the_work_area_is_a_warning_not_an_estimate() {
        let profile = MachineProfile::default_plotter();
        let d = Drawing::single_layer("far", vec![square(5000.0, 5000.0, 10.0)]);
        let p = prepare(d, &profile, &[], &LayoutArgs::default(), &no_optimize(), &Cancel::never()).unwrap();
        assert_eq!(p.estimate_s, None);
        assert!(p.warnings[0].starts_with("cannot plot on"), "{:?}", p.warnings);
    }
}
