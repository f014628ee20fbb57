//! One line comparing where a plan's time goes (drawing, travel, lifts) with the lower bound of each part, so the
//! gap to the machine's limit shows per part. Shared by `plot` and `stats`.

use plotter_path::motion::bound::TimeBound;
use plotter_path::motion::plan::PlanBreakdown;

/// `planned / bound` per part, with how far above its bound each part is.
pub(crate) fn line(plan: &PlanBreakdown, bound: &TimeBound) -> String {
    let part = |name: &str, t: f64, b: f64| {
        let above = if b > 0.0 { format!(" (+{:.1} %)", 100.0 * (t / b - 1.0)) } else { String::new() };
        format!("{name} {t:.1} / {b:.1} s{above}")
    };
    format!(
        "time parts, planned / lower bound: {}, {}, {}",
        part("pen down", plan.draw_s(), bound.draw_s),
        part("travel", plan.travel_s(), bound.travel_s),
        part("lifts", plan.lift_s(), bound.lifts_s)
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parts_and_gaps() {
        let plan = PlanBreakdown { draw_ticks: 12_000_000, travel_ticks: 3_000_000, lift_ticks: 2_000_000 };
        let bound = TimeBound { draw_s: 10.0, lifts_s: 2.0, travel_s: 0.0 };
        assert_eq!(
            line(&plan, &bound),
            "time parts, planned / lower bound: pen down 12.0 / 10.0 s (+20.0 %), travel 3.0 / 0.0 s, lifts 2.0 / 2.0 s \
             (+0.0 %)"
        );
    }
}
