//! What `plotter plot` prints when a plot has finished: the summary for the person at the plotter (how long it
//! took, how far the pen went down and up, how often it was lifted, the pen changes), and with `--verbose` the
//! figures for whoever studies the link and the plan (blocks, bytes per block, resends, queue underruns, the plan
//! beside its lower bound).

use plotter_fw::TICK_HZ;
use plotter_host::job::JobOutcome;
use plotter_path::motion::plan::{MotionPlan, MoveKind};

use crate::time_parts::clock;

use super::PlotArgs;

/// How many times the plan lowers the pen onto the paper (a servo drop made of several blocks counts once).
fn pen_drops(plan: &MotionPlan) -> usize {
    let mut last = None;
    let mut n = 0;
    for b in plan.blocks.iter().filter(|b| b.kind == MoveKind::PenDown) {
        if last != Some(b.stroke) {
            n += 1;
            last = Some(b.stroke);
        }
    }
    n
}

/// The summary of a finished plot for the person at the plotter: `plot time 2:05.3: 4623.2 mm pen-down,
/// 781.6 mm pen-up, 130 pen lifts` (the time the plotter ran when it is known, else the plan's), the pen changes,
/// and with `verbose` the figures of the plan and the link ([`details`]).
pub(super) fn summary(outcome: &JobOutcome, executed_ticks: Option<u64>, verbose: bool) -> String {
    let plan = &outcome.plan;
    // Display only.
    #[allow(clippy::cast_precision_loss)]
    let ran = executed_ticks.map(|t| t as f64 / f64::from(TICK_HZ));
    let time = match ran {
        // The simulated plotter's own clock: the same as the plan's to the tenth unless something went wrong.
        Some(t) if clock(t) != clock(plan.seconds()) => format!("{} (planned {})", clock(t), clock(plan.seconds())),
        Some(t) => clock(t),
        None => format!("{} (planned)", clock(plan.seconds())),
    };
    let mut s = format!(
        "plot time {time}: {:.1} mm pen-down, {:.1} mm pen-up, {} pen lifts",
        plan.draw_mm,
        plan.travel_mm,
        pen_drops(plan)
    );
    if outcome.pen_stops > 0 {
        s += &format!("\npen changes: {}", outcome.pen_stops);
        if !outcome.skipped.is_empty() {
            let skipped: Vec<String> = outcome.skipped.iter().map(|l| format!("{l:?}")).collect();
            s += &format!(", skipped {}", skipped.join(", "));
        }
    }
    if verbose {
        s = format!("{s}\n{}", details(outcome, executed_ticks));
    }
    s
}

/// The line for several copies (`--copies`), after the last copy's [`summary`]: how many were plotted and, when
/// the plotter's clock is known (`total_ticks`, from before the first copy to after the last), the time of all of
/// them, page delays and paper changes included; else the plotting time they planned. `None` for a single copy.
pub(super) fn copies_line(copies: usize, each: &MotionPlan, total_ticks: Option<u64>) -> Option<String> {
    if copies < 2 {
        return None;
    }
    Some(match total_ticks {
        // Display only.
        #[allow(clippy::cast_precision_loss)]
        Some(t) => format!(
            "{copies} copies in {} (each planned {}; page delays and paper changes included)",
            clock(t as f64 / f64::from(TICK_HZ)),
            clock(each.seconds())
        ),
        // Display only (a copy count is far below 2^52).
        #[allow(clippy::cast_precision_loss)]
        None => format!(
            "{copies} copies: {} of plotting planned (each {}; page delays and paper changes come on top)",
            clock(each.seconds() * copies as f64),
            clock(each.seconds())
        ),
    })
}

/// The plan's and the link's figures (`--verbose`): blocks, lengths and times to the millisecond, bytes per
/// block, resends, resyncs and queue underruns.
fn details(outcome: &JobOutcome, executed_ticks: Option<u64>) -> String {
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
    s
}

/// With `--verbose`: print the plot-time lower bound next to the planned time, and both split into drawing,
/// lifts, and travel with lifts (see [`plotter_path::motion::bound`] and `time_parts::line`); the order's travel
/// bound is taken from `start`, where the order started. Without it, nothing (and nothing is computed).
pub(super) fn print_lower_bound(
    profile: &plotter_path::MachineProfile,
    steps: &plotter_path::geometry::steps::StepDrawing,
    drawing: &plotter_path::Drawing,
    plan: &plotter_path::motion::plan::MotionPlan,
    args: &PlotArgs,
    start: Option<plotter_path::kurbo::Point>,
) -> anyhow::Result<()> {
    use plotter_path::output::stats::{fixed, percent_above};
    if !args.verbose {
        return Ok(());
    }
    let seam = args.optimize.options(Some(profile))?.seam;
    let b = plotter_path::motion::bound::drawing_time_lower_bound(profile, steps, drawing, seam, start)?;
    // Nothing to compare with when the bound is zero (nothing to draw).
    let above = percent_above(plan.seconds(), b.total_s())
        .map_or(String::new(), |p| format!(": planned time is {} % above it", fixed(p, 1)));
    println!(
        "lower bound {} s (pen down {} s, {} lifts {} s, travel with the pen moves its hops force {} s){above}",
        fixed(b.total_s(), 3),
        fixed(b.draw_s, 1),
        steps.strokes.len(),
        fixed(b.lifts_s, 1),
        fixed(b.travel_s, 1),
    );
    println!("{}", crate::time_parts::line(&plan.breakdown(), &b));
    Ok(())
}
