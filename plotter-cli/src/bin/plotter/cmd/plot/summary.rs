//! What `plotter plot` prints when a plot has finished: the summary, and the plan beside its lower bound.

use plotter_fw::TICK_HZ;
use plotter_host::job::JobOutcome;

use super::PlotArgs;

/// Human summary of a finished plot.
pub(super) fn summary(outcome: &JobOutcome, executed_ticks: Option<u64>) -> String {
    let stops = if outcome.pen_stops > 0 {
        let skipped = if outcome.skipped.is_empty() {
            String::new()
        } else {
            format!(", skipped {}", outcome.skipped.iter().map(|l| format!("{l:?}")).collect::<Vec<_>>().join(", "))
        };
        format!("\npen changes: {}{skipped}", outcome.pen_stops)
    } else {
        String::new()
    };
    let (plan, stats) = (&outcome.plan, &outcome.stats);
    // Display only.
    #[allow(clippy::cast_precision_loss)]
    let per_block = if stats.frames > 0 { stats.frame_bytes as f64 / stats.frames as f64 } else { 0.0 };
    let mut s = format!(
        "{} blocks, {:.1} mm pen-down, {:.1} mm travel; planned time {:.3} s",
        plan.blocks.len(),
        plan.draw_mm,
        plan.travel_mm,
        plan.seconds()
    );
    if let Some(t) = executed_ticks {
        // Display only.
        #[allow(clippy::cast_precision_loss)]
        let secs = t as f64 / f64::from(TICK_HZ);
        s += &format!(", executed {secs:.3} s");
    }
    s += &format!("\nlink: {per_block:.1} bytes/block, {} resends", stats.resends);
    if stats.resyncs > 0 {
        s += &format!(", {} resyncs", stats.resyncs);
    }
    if let Some(u) = stats.underruns {
        s += &format!(", {u} queue underruns");
    }
    s + &stops
}

/// Print the plot-time lower bound next to the planned time, and both split into drawing, travel and lifts (see
/// [`plotter_path::motion::bound`]); the order's travel bound is taken from `start`, where the order started.
pub(super) fn print_lower_bound(
    profile: &plotter_path::MachineProfile,
    steps: &plotter_path::geometry::steps::StepDrawing,
    drawing: &plotter_path::Drawing,
    plan: &plotter_path::motion::plan::MotionPlan,
    args: &PlotArgs,
    start: Option<plotter_path::kurbo::Point>,
) -> anyhow::Result<()> {
    use plotter_path::output::stats::{fixed, percent_above};
    let seam = args.optimize.options(Some(profile))?.seam;
    let b = plotter_path::motion::bound::drawing_time_lower_bound(profile, steps, drawing, seam, start)?;
    // Nothing to compare with when the bound is zero (nothing to draw).
    let above = percent_above(plan.seconds(), b.total_s())
        .map_or(String::new(), |p| format!(": planned time is {} % above it", fixed(p, 1)));
    println!(
        "lower bound {} s (pen down {} s, {} lifts {} s, travel {} s){above}",
        fixed(b.total_s(), 3),
        fixed(b.draw_s, 1),
        steps.strokes.len(),
        fixed(b.lifts_s, 1),
        fixed(b.travel_s, 1),
    );
    println!("{}", crate::time_parts::line(&plan.breakdown(), &b));
    Ok(())
}
