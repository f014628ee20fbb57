//! `plotter stats`: path/segment counts, pen-down and pen-up length, pen lifts, bounding box, and what path
//! optimisation and the motion planner make of the drawing: pen-up length after ordering, a lower bound on it, and
//! the estimated plot time before and after (text or JSON).

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use plotter_path::motion::plan::{self, Lookahead};
use plotter_path::motion::steps::drawing_to_steps;
use plotter_path::output::stats::Stats;
use plotter_path::{Drawing, MachineProfile};

use plotter_host::input::Source;
use plotter_host::job::load::load_profile;
use plotter_host::options::optimize::{OptimizeArgs, optimize_quietly};

/// Print figures about a drawing.
#[derive(Debug, Args)]
pub(crate) struct StatsArgs {
    #[command(flatten)]
    pub(crate) source: Source,
    /// Print JSON (keys: layers, paths, segments, pen_down_mm, pen_up_mm, pen_lifts, bbox_mm, layer_names,
    /// pen_up_mm_optimized, pen_up_lower_bound_mm, est_time_s, est_time_s_optimized)
    #[arg(long)]
    pub(crate) json: bool,
    /// Machine profile for the time estimate (TOML) [default: the built-in XY plotter kit]
    #[arg(long)]
    pub(crate) profile: Option<PathBuf>,
    #[command(flatten)]
    pub(crate) optimize: OptimizeArgs,
}

/// Plot time of `drawing` as planned by the firmware's planner over the whole drawing, from the homed position.
fn estimate_seconds(profile: &MachineProfile, drawing: &Drawing) -> Result<f64> {
    let steps = drawing_to_steps(profile, drawing)?;
    let plan = plan::plan(profile, &steps, plan::homed_position(profile)?, Lookahead::Whole)?;
    Ok(plan.seconds())
}

/// Run `plotter stats`.
pub(crate) fn run(args: &StatsArgs) -> Result<()> {
    let profile = load_profile(args.profile.as_deref())?;
    let drawing = args.source.load(&profile)?;
    let stats = Stats::of(&drawing);
    let names: Vec<&str> = drawing.layers.iter().map(|l| l.name.as_str()).collect();
    let estimate = |d: &Drawing| match estimate_seconds(&profile, d) {
        Ok(s) => Some(s),
        Err(e) => {
            eprintln!("warning: no time estimate on profile '{}': {e:#}", profile.name);
            None
        }
    };
    let est_time_s = estimate(&drawing);
    let mut optimized = drawing.clone();
    let report = optimize_quietly(&mut optimized, &args.optimize, Some(&profile))?;
    let est_time_s_optimized = report.as_ref().and_then(|_| est_time_s.and_then(|_| estimate(&optimized)));
    if args.json {
        let mut value = serde_json::to_value(&stats)?;
        value["layer_names"] = serde_json::json!(names);
        value["pen_up_mm_optimized"] = serde_json::json!(report.as_ref().map(|r| r.pen_up_after_mm));
        value["pen_up_lower_bound_mm"] = serde_json::json!(report.as_ref().and_then(|r| r.pen_up_lower_bound_mm));
        value["est_time_s"] = serde_json::json!(est_time_s);
        value["est_time_s_optimized"] = serde_json::json!(est_time_s_optimized);
        println!("{}", serde_json::to_string_pretty(&value)?);
        return Ok(());
    }
    println!("{stats}");
    println!("layer names   {}", names.join(", "));
    if let Some(t) = est_time_s {
        println!("plot time     {} (profile '{}')", clock(t), profile.name);
    }
    if let Some(r) = &report {
        print!("optimized     pen up {:.2} mm", r.pen_up_after_mm);
        if let Some(lb) = r.pen_up_lower_bound_mm {
            print!(", lower bound {lb:.2} mm");
        }
        if let Some(t) = est_time_s_optimized {
            print!(", plot time {}", clock(t));
        }
        println!();
    }
    Ok(())
}

/// `h:mm:ss.s` or `m:ss.s`.
fn clock(seconds: f64) -> String {
    let whole = seconds.max(0.0);
    let h = (whole / 3600.0).floor();
    let m = ((whole - h * 3600.0) / 60.0).floor();
    let s = whole - h * 3600.0 - m * 60.0;
    if h > 0.0 { format!("{h:.0}:{m:02.0}:{s:04.1}") } else { format!("{m:.0}:{s:04.1}") }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clock_format() {
        assert_eq!(clock(75.25), "1:15.2");
        assert_eq!(clock(3725.0), "1:02:05.0");
        assert_eq!(clock(4.0), "0:04.0");
    }
}
