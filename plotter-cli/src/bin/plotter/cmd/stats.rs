//! `plotter stats`: path/segment counts, pen-down and pen-up length, pen lifts, bounding box, and what path
//! optimisation and the motion planner make of the drawing: pen-up length after ordering, a lower bound on it, and
//! the estimated plot time before and after, and what the import left out and why (text or JSON).

use anyhow::Result;
use clap::Args;
use plotter_path::geometry::steps::drawing_to_steps;
use plotter_path::kurbo::Point;
use plotter_path::motion::bound::{TimeBound, drawing_time_lower_bound};
use plotter_path::motion::gap::{TimeGap, time_gap};
use plotter_path::motion::plan::{self, Lookahead, PlanBreakdown};
use plotter_path::optimize::{CostModel, SeamMode, drawing_travel};
use plotter_path::output::stats::{Stats, fixed, percent_above, unsigned_zero};
use plotter_path::{Drawing, MachineProfile};

use plotter_host::input::Source;
use plotter_host::link::machine::Firmware;
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
    /// est_time_parts_optimized: draw_s, travel_s, lifts_s, their *_lower_bound_s (travel_lower_bound_s bounds
    /// travel_s plus what lifts_s spends above lifts_lower_bound_s: a hop's length decides some pen moves), and
    /// above_lower_bound_s: the
    /// time above the bound by cause, axis_limits_s, corners_s, curves_s, stroke_ends_s, step_timing_s, lifts_s,
    /// drops_s, settles_s, hops_s, travel_order_s)
    #[arg(long)]
    pub(crate) json: bool,
    /// Also print the lower bounds (of the pen-up distance, and of the plot time at the machine's limits as its
    /// profile states them: each axis's speed and acceleration, and how fast it may pass each corner or curve
    /// point of a line), where the plot time goes (pen down, lifts, travel and lifts) against each part's bound,
    /// and what the time above the bound is spent on. The optimized plot's bound is for the drawing as optimized:
    /// paths joined where their ends meet or a gap narrower than the pen is drawn through count as one line.
    #[arg(long, short = 'v')]
    pub(crate) verbose: bool,
    /// The machine the time estimate is for.
    #[command(flatten)]
    pub(crate) machine: MachineArgs,
    /// The firmware the time estimate is for: ours and ebb run a servo pen's drop while the carriage travels, grbl
    /// stops the carriage where the drop is commanded (its M3 waits for the moves before it to end); auto plans as
    /// `plot` without --port does (the simulated plotter, our firmware).
    #[arg(long, value_enum, default_value_t = Firmware::Auto)]
    pub(crate) firmware: Firmware,
    #[command(flatten)]
    pub(crate) optimize: OptimizeArgs,
}

/// A plot time, its parts, its lower bound and (when asked for) where the time above the bound goes.
type Estimate = (f64, PlanBreakdown, TimeBound, Option<TimeGap>);

/// Plot time of `drawing` as planned by the firmware's planner over the whole drawing, from the homed position
/// (back home at the end with `return_home`), split into its parts, and a lower bound on it for any order of the
/// drawing's paths from `start`; with `gap`, the time above the bound by cause.
fn estimate(
    profile: &MachineProfile,
    drawing: &Drawing,
    return_home: bool,
    (seam, start): (SeamMode, Option<Point>),
    gap: bool,
) -> Result<Estimate> {
    let steps = drawing_to_steps(profile, drawing)?;
    let home = plan::homed_position(profile)?;
    // The plan and the bound are independent: side by side on two cores.
    let (plan, bound) = plotter_path::geometry::parallel::join(
        || plan::plan_returning(profile, &steps, home, Lookahead::Whole, return_home),
        || drawing_time_lower_bound(profile, &steps, drawing, seam, start),
    );
    let (plan, bound) = (plan?, bound?);
    let gap = if gap { Some(time_gap(profile, &steps, &plan, &bound, return_home)?) } else { None };
    Ok((plan.seconds(), plan.breakdown(), bound, gap))
}

/// Run `plotter stats`.
pub(crate) fn run(args: &StatsArgs) -> Result<()> {
    let mut profile = args.machine.load()?;
    profile.servo_sync = args.firmware.servo_sync();
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
    let gap = args.verbose || args.json;
    let estimate = |d: &Drawing| match estimate(&profile, d, back, (options.seam, options.start), gap) {
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
        let parts = |e: &Estimate| {
            serde_json::json!({
                "draw_s": num(Some(e.1.draw_s())), "travel_s": num(Some(e.1.travel_s())),
                "lifts_s": num(Some(e.1.lift_s())), "draw_lower_bound_s": num(Some(e.2.draw_s)),
                "travel_lower_bound_s": num(Some(e.2.travel_s)), "lifts_lower_bound_s": num(Some(e.2.lifts_s)),
                "above_lower_bound_s": e.3.map(|g| {
                    g.parts().iter().map(|(k, v)| (k.replace(' ', "_") + "_s", num(Some(*v)))).collect::<serde_json::Map<_, _>>()
                }),
            })
        };
        value["est_time_parts"] = serde_json::json!(est.as_ref().map(parts));
        value["est_time_parts_optimized"] = serde_json::json!(est_optimized.as_ref().map(parts));
        println!("{}", serde_json::to_string_pretty(&value)?);
        return Ok(());
    }
    let optimized = report.as_ref().map(|r| Optimized {
        pen_up_mm: pen_up_optimized.unwrap_or(r.pen_up_after_mm),
        pen_up_lower_bound_mm: r.pen_up_lower_bound_mm,
        pen_lifts: r.paths_out,
        est: est_optimized,
    });
    let text = Text { stats: &stats, names: &names, skipped: &skipped.to_string(), profile: &profile.name };
    print!("{}", text.render(back, pen_up_from_home, est, optimized.as_ref(), args.verbose));
    Ok(())
}

/// What the optimizer made of the drawing, as `stats` shows it.
struct Optimized {
    /// Pen-up distance after ordering, with the travel from home (and back), mm.
    pen_up_mm: f64,
    /// The lower bound on the pen-up distance of any order, mm.
    pen_up_lower_bound_mm: Option<f64>,
    /// Pen lifts after merging.
    pen_lifts: usize,
    /// Plot time, its parts and its lower bound.
    est: Option<Estimate>,
}

/// The figures `stats` prints as text that do not come from the plan.
struct Text<'a> {
    stats: &'a Stats,
    names: &'a [&'a str],
    skipped: &'a str,
    profile: &'a str,
}

impl Text<'_> {
    /// The text report: the drawing's figures, its plot time and what ordering saves, in words a plotter owner
    /// reads (`saves 78.3 %` of the pen-up distance, `saves 0:36.6` of the time); with `verbose`, the lower bounds
    /// and each part of the time beside its bound.
    fn render(
        &self,
        back: bool,
        pen_up_from_home: f64,
        est: Option<Estimate>,
        optimized: Option<&Optimized>,
        verbose: bool,
    ) -> String {
        let mut s = format!("{}\n", self.stats);
        let and_back = if back { " and back" } else { "" };
        s += &format!("pen up, home  {} mm (with the travel from home{and_back})\n", fixed(pen_up_from_home, 2));
        s += &format!("layer names   {}\n", self.names.join(", "));
        s += &format!("skipped       {}\n", self.skipped);
        if let Some((t, parts, b, gap)) = &est {
            s += &format!("plot time     {} (profile '{}')", clock(*t), self.profile);
            if verbose {
                s += &format!(
                    ", lower bound {}\n              {}",
                    clock(b.total_s()),
                    crate::time_parts::line(parts, b)
                );
                if let Some(g) = gap {
                    s += &format!("\n              {}", crate::time_parts::gap_line(g));
                }
            }
            s += "\n";
        }
        let Some(o) = optimized else { return s };
        s += &format!("optimized     pen up {} mm", fixed(o.pen_up_mm, 2));
        if pen_up_from_home > 0.0 {
            let saved = 100.0 * (1.0 - o.pen_up_mm / pen_up_from_home);
            let verb = if fixed(saved, 1).starts_with('-') { "adds" } else { "saves" };
            s += &format!(" ({verb} {} % of {} mm)", fixed(saved.abs(), 1), fixed(pen_up_from_home, 2));
        }
        if let (Some(lb), true) = (o.pen_up_lower_bound_mm, verbose) {
            s += &format!(", lower bound {} mm", fixed(lb, 2));
        }
        s += &format!(", {} pen lifts", o.pen_lifts);
        if let Some((t, _, b, _)) = &o.est {
            s += &format!(", plot time {}", clock(*t));
            if let Some((before, _, _, _)) = &est {
                let saved = before - t;
                if clock(saved.abs()) != clock(0.0) {
                    let verb = if saved >= 0.0 { "saves" } else { "adds" };
                    s += &format!(" ({verb} {})", clock(saved.abs()));
                }
            }
            if verbose {
                s += &format!(", lower bound {}", clock(b.total_s()));
                // Nothing to compare with when the bound is zero (nothing to draw).
                if let Some(p) = percent_above(*t, b.total_s()) {
                    let side = if fixed(p, 1).starts_with('-') { "below" } else { "above" };
                    s += &format!(" ({} % {side})", fixed(p.abs(), 1));
                }
            }
        }
        s += "\n";
        if let (Some((_, parts, b, gap)), true) = (&o.est, verbose) {
            s += &format!("              {}\n", crate::time_parts::line(parts, b));
            if let Some(g) = gap {
                s += &format!("              {}\n", crate::time_parts::gap_line(g));
            }
        }
        s
    }
}

/// A figure for JSON: `null` when absent or not a number (JSON has no NaN), never -0.0.
fn num(v: Option<f64>) -> serde_json::Value {
    v.filter(|v| v.is_finite()).map_or(serde_json::Value::Null, |v| serde_json::json!(unsigned_zero(v)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_report_speaks_to_a_plotter_owner_and_details_wait_for_verbose() {
        use plotter_path::Polyline;
        // Two 10 mm lines 10 mm apart; from home, 100 mm of pen-up travel, 40 mm after ordering (60 % saved);
        // the plot takes 2:05.3, 1:30.0 after ordering (35.3 s saved).
        let line = |y: f64| Polyline::new(vec![Point::new(0.0, y), Point::new(10.0, y)]);
        let stats = Stats::of(&Drawing::single_layer("a", vec![line(0.0), line(10.0)]));
        let parts = PlanBreakdown { draw_ticks: 80_000_000, travel_ticks: 6_000_000, lift_ticks: 4_000_000 };
        let bound = TimeBound { draw_s: 70.0, lifts_s: 4.2, travel_s: 3.0 };
        let text = Text { stats: &stats, names: &["a"], skipped: "nothing", profile: "XY" };
        let optimized = Optimized {
            pen_up_mm: 40.0,
            pen_up_lower_bound_mm: Some(35.0),
            pen_lifts: 2,
            est: Some((90.0, parts, bound, None)),
        };
        let shown = text.render(false, 100.0, Some((125.3, parts, bound, None)), Some(&optimized), false);
        let tail: Vec<&str> = shown.lines().skip(7).collect();
        assert_eq!(
            tail,
            [
                "pen up, home  100.00 mm (with the travel from home)",
                "layer names   a",
                "skipped       nothing",
                "plot time     2:05.3 (profile 'XY')",
                "optimized     pen up 40.00 mm (saves 60.0 % of 100.00 mm), 2 pen lifts, plot time 1:30.0 (saves 0:35.3)",
            ]
        );
        // --verbose: the bounds, and each part beside its own in words (here the lifts are below theirs, which
        // the bound rules out in a real plan, and it reads `below`, never `+-`).
        let shown = text.render(false, 100.0, Some((125.3, parts, bound, None)), Some(&optimized), true);
        let tail: Vec<&str> = shown.lines().skip(10).collect();
        assert_eq!(
            tail,
            [
                "plot time     2:05.3 (profile 'XY'), lower bound 1:17.2",
                "              time parts, planned (lower bound): pen down 80.0 s (bound 70.0 s, 14.3 % above), lifts \
                 4.0 s (bound 4.2 s, 4.8 % below), travel and lifts 10.0 s (bound 7.2 s, 38.9 % above)",
                "optimized     pen up 40.00 mm (saves 60.0 % of 100.00 mm), lower bound 35.00 mm, 2 pen lifts, plot \
                 time 1:30.0 (saves 0:35.3), lower bound 1:17.2 (16.6 % above)",
                "              time parts, planned (lower bound): pen down 80.0 s (bound 70.0 s, 14.3 % above), lifts \
                 4.0 s (bound 4.2 s, 4.8 % below), travel and lifts 10.0 s (bound 7.2 s, 38.9 % above)",
            ]
        );
    }

    #[test]
    fn json_figures_are_numbers_or_null() {
        assert_eq!(num(Some(-0.0)).to_string(), "0.0");
        assert_eq!(num(Some(f64::INFINITY)), serde_json::Value::Null);
    }
}
