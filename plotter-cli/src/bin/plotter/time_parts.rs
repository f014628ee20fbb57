//! A plan's time as people see it: one line comparing where the time goes (drawing, travel, lifts) with the lower
//! bound of each part, so the gap to the machine's limit shows per part (`plot`, `stats`); durations as a clock
//! (`h:mm:ss.s`); and the announcement of a plan before anything moves, with its dwell and the long-dwell guard
//! (`plot`, `plot --as-written`).
//!
//! The guard: a plan that spends more than [`LONG_DWELL_S`] (an hour) standing still in dwells — `G4` in a file
//! played as written, or the pen's settle time over many lifts — is announced with a loud warning before the
//! machine homes. Someone at a terminal sees it and can stop with Ctrl-C; a run without a terminal on stdin (a
//! script, a service) is refused unless `--allow-long-dwell` says the wait is meant, because nobody would see the
//! warning before the machine sat still for hours.

use std::io::IsTerminal as _;

use plotter_path::motion::bound::TimeBound;
use plotter_path::motion::gap::TimeGap;
use plotter_path::motion::plan::{MotionPlan, PlanBreakdown};
use plotter_path::output::stats::{fixed, percent_above};

/// Pure dwell, seconds, above which a plan is announced with a warning and, without a terminal on stdin, refused
/// unless `--allow-long-dwell` is given.
pub(crate) const LONG_DWELL_S: f64 = 3600.0;

/// Seconds of `ticks` of the step timer. Display only: tick counts of any plot fit f64's mantissa.
#[allow(clippy::cast_precision_loss)]
fn ticks_s(ticks: u64) -> f64 {
    ticks as f64 / f64::from(plotter_fw::TICK_HZ)
}

/// The time `plan` stands still in dwells (pen settles, servo moves), seconds.
pub(crate) fn dwell_s(plan: &MotionPlan) -> f64 {
    ticks_s(plan.blocks.iter().filter(|b| b.block.is_dwell()).map(|b| u64::from(b.ticks)).sum())
}

/// Say, before anything moves, how long the plan of `what` takes and how much of it is dwell; a plan with more
/// than [`LONG_DWELL_S`] of dwell gets a loud warning and, unless `allow_long_dwell` or stdin is a terminal, is
/// refused (see the module docs).
pub(crate) fn announce(what: &str, total_s: f64, dwell_s: f64, allow_long_dwell: bool) -> anyhow::Result<()> {
    eprintln!("{}", announcement(what, total_s, dwell_s));
    if dwell_s <= LONG_DWELL_S {
        return Ok(());
    }
    eprintln!(
        "warning: ***** this plan stands still for {} in dwells: the machine will wait that long with the pen \
         where it is *****",
        clock(dwell_s)
    );
    if allow_long_dwell {
        return Ok(());
    }
    if std::io::stdin().is_terminal() {
        eprintln!("warning: press Ctrl-C now if that wait is not meant (or plot with --allow-long-dwell)");
        return Ok(());
    }
    anyhow::bail!(
        "{what}: refused to start a plan with {} of dwell (over {}) without a terminal to warn: pass \
         --allow-long-dwell if the wait is meant",
        clock(dwell_s),
        clock(LONG_DWELL_S)
    )
}

/// `planned time 1:02:05.0, dwell 0:50.0 (the machine standing still)`.
fn announcement(what: &str, total_s: f64, dwell_s: f64) -> String {
    format!("{what}: planned time {}, of which dwell {} (standing still)", clock(total_s), clock(dwell_s))
}

/// `h:mm:ss.s` or `m:ss.s`, rounded to the tenth (`n/a` for a time that is not a number; never negative).
pub(crate) fn clock(seconds: f64) -> String {
    if !seconds.is_finite() {
        return "n/a".to_string();
    }
    // Whole tenths, counted in f64 (exact for any plot's length): no `0:60.0` from rounding 59.96 s up.
    let tenths = (seconds.max(0.0) * 10.0).round();
    let h = (tenths / 36_000.0).floor();
    let m = ((tenths - h * 36_000.0) / 600.0).floor();
    let s = (tenths - h * 36_000.0 - m * 600.0) / 10.0;
    if h > 0.0 { format!("{h:.0}:{m:02.0}:{s:04.1}") } else { format!("{m:.0}:{s:04.1}") }
}

/// Each part's planned time with its lower bound and how far above it the plan is, in words (`11.2 % above`), so no
/// percentage carries a sign; a plan below its bound (which the bound's own tests rule out) would read `below`.
///
/// The parts are pen down, lifts, and travel together with the lifts: the bound's travel part charges each hop the
/// pen's moves its length forces (the corners at the Z joins of a long hop, the wider servo drop window after a
/// short one), which the plan counts among its lifts. So travel alone has no bound of its own, and showing it
/// beside one would read as a plan below its bound.
pub(crate) fn line(plan: &PlanBreakdown, bound: &TimeBound) -> String {
    let part = |name: &str, t: f64, b: f64| {
        // No percentage against a zero bound (a part that takes no time).
        let gap = percent_above(t, b).map_or(String::new(), |p| {
            let side = if fixed(p, 1).starts_with('-') { "below" } else { "above" };
            format!(", {} % {side}", fixed(p.abs(), 1))
        });
        format!("{name} {} s (bound {} s{gap})", fixed(t, 1), fixed(b, 1))
    };
    format!(
        "time parts, planned (lower bound): {}, {}, {}",
        part("pen down", plan.draw_s(), bound.draw_s),
        part("lifts", plan.lift_s(), bound.lifts_s),
        part("travel and lifts", plan.travel_s() + plan.lift_s(), bound.travel_s + bound.lifts_s)
    )
}

/// Where the plan's time above its lower bound goes, by cause, in the order of [`TimeGap::parts`]:
/// `above the bound by 12.3 s: axis limits 1.2 s, corners 3.4 s, ...`. A part the plan spends less on than the
/// bound allowed for it (another part then takes more) reads `0.4 s less`, never a sign.
pub(crate) fn gap_line(gap: &TimeGap) -> String {
    let parts: Vec<String> = gap
        .parts()
        .iter()
        .map(|(name, t)| {
            let shown = fixed(t.abs(), 1);
            if fixed(*t, 1).starts_with('-') { format!("{name} {shown} s less") } else { format!("{name} {shown} s") }
        })
        .collect();
    format!("above the bound by {} s: {}", fixed(gap.total_s().max(0.0), 1), parts.join(", "))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clock_format() {
        // Tenths rounded half away from zero (75.25 s is exact in binary).
        assert_eq!(clock(75.25), "1:15.3");
        assert_eq!(clock(75.24), "1:15.2");
        assert_eq!(clock(3725.0), "1:02:05.0");
        assert_eq!(clock(4.0), "0:04.0");
        assert_eq!(clock(59.96), "1:00.0");
        assert_eq!(clock(3599.96), "1:00:00.0");
        assert_eq!(clock(172_800.0), "48:00:00.0");
        assert_eq!(clock(-0.0), "0:00.0");
        assert_eq!(clock(f64::NAN), "n/a");
    }

    #[test]
    fn long_dwell_is_refused_unless_allowed() {
        assert_eq!(
            announcement("f.gcode", 172_801.5, 172_800.0),
            "f.gcode: planned time 48:00:01.5, of which dwell 48:00:00.0 (standing still)"
        );
        // An hour exactly passes; above it, only with the flag (the test's stdin is not a terminal).
        assert!(announce("f.gcode", 3700.0, LONG_DWELL_S, false).is_ok());
        if !std::io::stdin().is_terminal() {
            let err = announce("f.gcode", 172_801.5, 172_800.0, false).unwrap_err().to_string();
            assert!(err.contains("48:00:00.0 of dwell") && err.contains("--allow-long-dwell"), "{err}");
        }
        assert!(announce("f.gcode", 172_801.5, 172_800.0, true).is_ok());
    }

    #[test]
    fn the_gap_by_cause() {
        let gap = TimeGap {
            axis_limits_s: 1.24,
            corners_s: 3.4,
            curves_s: 0.5,
            stroke_ends_s: -0.26,
            step_timing_s: 0.01,
            lifts_s: 0.3,
            drops_s: 0.2,
            settles_s: 0.0,
            hops_s: 1.0,
            travel_order_s: 2.0,
        };
        assert_eq!(
            gap_line(&gap),
            "above the bound by 8.4 s: axis limits 1.2 s, corners 3.4 s, curves 0.5 s, stroke ends 0.3 s less, step \
             timing 0.0 s, lifts 0.3 s, drops 0.2 s, settles 0.0 s, hops 1.0 s, travel order 2.0 s"
        );
    }

    #[test]
    fn parts_and_gaps() {
        let plan = PlanBreakdown { draw_ticks: 12_000_000, travel_ticks: 3_000_000, lift_ticks: 2_000_000 };
        let bound = TimeBound { draw_s: 10.0, lifts_s: 2.0, travel_s: 0.0 };
        assert_eq!(
            line(&plan, &bound),
            "time parts, planned (lower bound): pen down 12.0 s (bound 10.0 s, 20.0 % above), lifts 2.0 s (bound 2.0 \
             s, 0.0 % above), travel and lifts 5.0 s (bound 2.0 s, 150.0 % above)"
        );
        // Nothing drawn: no NaN, no -0.0, no percentage against a zero bound.
        let bound = TimeBound { draw_s: -0.0, lifts_s: 0.0, travel_s: f64::NAN };
        assert_eq!(
            line(&PlanBreakdown::default(), &bound),
            "time parts, planned (lower bound): pen down 0.0 s (bound 0.0 s), lifts 0.0 s (bound 0.0 s), travel and \
             lifts 0.0 s (bound n/a s)"
        );
        // Were a part below its bound, it would say so in words, never as `+-4.0 %`.
        let plan = PlanBreakdown { draw_ticks: 0, travel_ticks: 0, lift_ticks: 34_000_000 };
        let bound = TimeBound { draw_s: 0.0, lifts_s: 35.5, travel_s: 0.0 };
        let shown = line(&plan, &bound);
        assert!(shown.contains(", lifts 34.0 s (bound 35.5 s, 4.2 % below)"), "{shown}");
        assert!(!shown.contains("+-") && !shown.contains("-4"), "{shown}");
    }
}
