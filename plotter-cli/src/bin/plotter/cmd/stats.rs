//! `plotter stats`: path/segment counts, pen-down and pen-up length, pen lifts, bounding box, and what path
//! optimisation and the motion planner make of the drawing: pen-up length after ordering, a lower bound on it, and
//! the estimated plot time before and after, and what the import left out and why (text or JSON).

use anyhow::Result;
use clap::Args;
use plotter_path::geometry::steps::drawing_to_steps;
use plotter_path::kurbo::Point;
use plotter_path::motion::bound::{TimeBound, drawing_time_lower_bound};
use plotter_path::motion::plan::{self, Lookahead, PlanBreakdown};
use plotter_path::optimize::{CostModel, SeamMode, drawing_travel};
use plotter_path::output::stats::{Stats, fixed, percent_above, unsigned_zero};
use plotter_path::{Drawing, MachineProfile};

use plotter_host::input::Source;
use plotter_host::options::machine::MachineArgs;
use plotter_host::options::optimize::{OptimizeArgs, optimize_quietly};

use crate::time_parts::clock;

/// Print figures about a drawing.
#[derive(Debug, Args)]
pub(crate) struct StatsArgs {
    #[command(flatten)]
    pub(crate) source: Source,
    /// Print JSON (keys: layers, paths, segments, pen_down_mm, pen_up_mm, pen_lifts, bbox_mm, layer_names, skipped
    /// (count per reason: invisible, same_colour_fill, image_not_traced, pattern_too_fine…),
    /// pen_up_mm_from_home, pen_up_mm_optimized, pen_up_lower_bound_mm, pen_lifts_optimized, est_time_s,
    /// est_time_lower_bound_s, est_time_s_optimized, est_time_lower_bound_s_optimized, and est_time_parts /
    /// est_time_parts_optimized: draw_s, travel_s, lifts_s and their *_lower_bound_s)
    #[arg(long)]
    pub(crate) json: bool,
    /// The machine the time estimate is for.
    #[command(flatten)]
    pub(crate) machine: MachineArgs,
    #[command(flatten)]
    pub(crate) optimize: OptimizeArgs,
}

/// Plot time of `drawing` as planned by the firmware's planner over the whole drawing, from the homed position
/// (back home at the end with `return_home`), split into its parts, and a lower bound on it for any order of the
/// drawing's paths from `start`.
fn estimate(
    profile: &MachineProfile,
    drawing: &Drawing,
    return_home: bool,
    seam: SeamMode,
    start: Option<Point>,
) -> Result<(f64, PlanBreakdown, TimeBound)> {
    let steps = drawing_to_steps(profile, drawing)?;
    let home = plan::homed_position(profile)?;
    // The plan and the bound are independent: side by side on two cores.
    let (plan, bound) = plotter_path::geometry::parallel::join(
        || plan::plan_returning(profile, &steps, home, Lookahead::Whole, return_home),
        || drawing_time_lower_bound(profile, &steps, drawing, seam, start),
    );
    let plan = plan?;
    Ok((plan.seconds(), plan.breakdown(), bound?))
}

/// Run `plotter stats`.
pub(crate) fn run(args: &StatsArgs) -> Result<()> {
    let profile = args.machine.load()?;
    let decoded = args.source.load_decoded(&profile)?;
    let (drawing, skipped) = (decoded.drawing, decoded.skipped);
    let stats = Stats::of(&drawing);
    let names: Vec<&str> = drawing.layers.iter().map(|l| l.name.as_str()).collect();
    let options = args.optimize.options(Some(&profile))?;
    let back = args.optimize.return_home;
    // The legs a plot makes: from home to the first path, between paths, and back home when asked.
    let legs = |d: &Drawing| {
        let mut mm = drawing_travel(d, options.start, &CostModel::Distance);
        let last = d.paths().filter(|p| p.points.len() >= 2).last().and_then(|p| p.end());
        if let (true, Some(e), Some(h)) = (back, last, options.start) {
            mm += e.distance(h);
        }
        mm
    };
    let estimate = |d: &Drawing| match estimate(&profile, d, back, options.seam, options.start) {
        Ok(s) => Some(s),
        Err(e) => {
            eprintln!("warning: no time estimate on profile '{}': {e:#}", profile.name);
            None
        }
    };
    let pen_up_from_home = legs(&drawing);
    let mut optimized = drawing.clone();
    // The input's estimate and the optimization are independent: side by side on two cores.
    let (est, report) = plotter_path::geometry::parallel::join(
        || estimate(&drawing),
        || optimize_quietly(&mut optimized, &args.optimize, Some(&profile)),
    );
    let report = report?;
    let est_optimized = report.as_ref().and_then(|_| est.and_then(|_| estimate(&optimized)));
    let pen_up_optimized = report.as_ref().map(|_| legs(&optimized));
    if args.json {
        let mut value = serde_json::to_value(&stats)?;
        value["layer_names"] = serde_json::json!(names);
        value["skipped"] = skipped.iter().map(|(reason, n)| (reason.key().to_string(), serde_json::json!(n))).collect();
        value["pen_up_mm_from_home"] = num(Some(pen_up_from_home));
        value["pen_up_mm_optimized"] = num(pen_up_optimized);
        value["pen_up_lower_bound_mm"] = num(report.as_ref().and_then(|r| r.pen_up_lower_bound_mm));
        value["pen_lifts_optimized"] = serde_json::json!(report.as_ref().map(|r| r.paths_out));
        value["est_time_s"] = num(est.map(|e| e.0));
        value["est_time_lower_bound_s"] = num(est.map(|e| e.2.total_s()));
        value["est_time_s_optimized"] = num(est_optimized.map(|e| e.0));
        value["est_time_lower_bound_s_optimized"] = num(est_optimized.map(|e| e.2.total_s()));
        let parts = |e: &(f64, PlanBreakdown, TimeBound)| {
            serde_json::json!({
                "draw_s": num(Some(e.1.draw_s())), "travel_s": num(Some(e.1.travel_s())),
                "lifts_s": num(Some(e.1.lift_s())), "draw_lower_bound_s": num(Some(e.2.draw_s)),
                "travel_lower_bound_s": num(Some(e.2.travel_s)), "lifts_lower_bound_s": num(Some(e.2.lifts_s)),
            })
        };
        value["est_time_parts"] = serde_json::json!(est.as_ref().map(parts));
        value["est_time_parts_optimized"] = serde_json::json!(est_optimized.as_ref().map(parts));
        println!("{}", serde_json::to_string_pretty(&value)?);
        return Ok(());
    }
    println!("{stats}");
    println!(
        "pen up, home  {} mm (with the travel from home{})",
        fixed(pen_up_from_home, 2),
        if back { " and back" } else { "" }
    );
    println!("layer names   {}", names.join(", "));
    println!("skipped       {skipped}");
    if let Some((t, parts, b)) = &est {
        println!("plot time     {} (profile '{}'), lower bound {}", clock(*t), profile.name, clock(b.total_s()));
        println!("              {}", crate::time_parts::line(parts, b));
    }
    if let Some(r) = &report {
        print!("optimized     pen up {} mm", fixed(pen_up_optimized.unwrap_or(r.pen_up_after_mm), 2));
        if let Some(lb) = r.pen_up_lower_bound_mm {
            print!(", lower bound {} mm", fixed(lb, 2));
        }
        print!(", {} pen lifts", r.paths_out);
        if let Some((t, _, b)) = &est_optimized {
            print!(", plot time {}, lower bound {}", clock(*t), clock(b.total_s()));
            // Nothing to compare with when the bound is zero (nothing to draw).
            if let Some(p) = percent_above(*t, b.total_s()) {
                print!(" ({} % above)", fixed(p, 1));
            }
        }
        println!();
        if let Some((_, parts, b)) = &est_optimized {
            println!("              {}", crate::time_parts::line(parts, b));
        }
    }
    Ok(())
}

/// A figure for JSON: `null` when absent or not a number (JSON has no NaN), never -0.0.
fn num(v: Option<f64>) -> serde_json::Value {
    v.filter(|v| v.is_finite()).map_or(serde_json::Value::Null, |v| serde_json::json!(unsigned_zero(v)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn json_figures_are_numbers_or_null() {
        assert_eq!(num(Some(-0.0)).to_string(), "0.0");
        assert_eq!(num(Some(f64::INFINITY)), serde_json::Value::Null);
    }
}
