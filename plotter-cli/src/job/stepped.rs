//! The as-stepped drawing: what the simulated machine really drew, rebuilt from its recorded steps.

use plotter_fw::Axis;
use plotter_fw::sim::Sim;
use plotter_path::geometry::steps::{StepMapper, StepPos};
use plotter_path::kurbo::{Line, Point};
use plotter_path::{Drawing, MachineProfile, Polyline};

/// The as-stepped drawing: pen-down runs of the simulator's step trace as page-millimetre polylines, and the
/// pen-up moves between them.
pub fn stepped_drawing(sim: &Sim, profile: &MachineProfile) -> (Drawing, Vec<Line>) {
    let mapper = StepMapper::new(profile);
    let cfg = sim.machine().config();
    let z = cfg.axis(Axis::Z);
    // The pen draws at its pen-down height; pen-up hops travel at or above the clearance height above it and the
    // Z-only rise and drop between them move no XY: Z at (or beyond) a pen-down height is ink. With pens of
    // different heights, the one nearest the pen-up height counts (no stroke is missed; a hop of a lower pen may
    // show where it passes that height).
    let up = profile.pen.up_z_mm;
    let nearest = profile
        .pens
        .iter()
        .filter_map(|p| p.down_z_mm)
        .fold(profile.pen.down_z_mm, |n, d| if (d - up).abs() < (n - up).abs() { d } else { n });
    let sign = if up >= nearest { 1.0 } else { -1.0 };
    let threshold = sign * (nearest * f64::from(z.steps_per_mm)).round() + 0.5;
    let mut pos = [0i64; 4];
    let mut paths: Vec<Polyline> = Vec::new();
    let mut travel: Vec<Line> = Vec::new();
    let mut current: Vec<Point> = Vec::new();
    let mut last_down_end: Option<Point> = None;
    let to_page = |p: &[i64; 4]| {
        let x = i32::try_from(p[0]).unwrap_or(i32::MAX);
        let y = i32::try_from(p[1]).unwrap_or(i32::MAX);
        mapper.steps_to_page(StepPos::new(x, y))
    };
    // Step counts are far below 2^53, so the comparison in f64 is exact.
    #[allow(clippy::cast_precision_loss)]
    let down = |p: &[i64; 4]| sign * (p[2] as f64) < threshold;
    for e in sim.hal().steps() {
        pos[e.axis.index()] += if e.forward { 1 } else { -1 };
        if down(&pos) {
            let pt = to_page(&pos);
            if current.is_empty() {
                if let Some(prev) = last_down_end {
                    travel.push(Line::new(prev, pt));
                }
                current.push(pt);
            } else if current.last() != Some(&pt) {
                current.push(pt);
            }
        } else if !current.is_empty() {
            last_down_end = current.last().copied();
            if current.len() > 1 {
                paths.push(Polyline::new(std::mem::take(&mut current)));
            }
            current.clear();
        }
    }
    if current.len() > 1 {
        paths.push(Polyline::new(current));
    }
    (Drawing::single_layer("as-stepped", paths), travel)
}
