//! Joining hatch lines into zig-zags: the pen stays down from the end of one line's span to the nearest end of a
//! span on the next line, when the short connecting stroke stays inside the shaded region.
//!
//! Lines are taken in order. Each chain that ended on the previous line is offered the spans of the current line
//! whose nearer end lies within `max_shift` along the lines; the offers are granted shortest first (each chain and
//! each span once), and only if the caller's `inside` test accepts the connector. A span nobody takes starts a new
//! chain. Every span is drawn exactly once, so the ink is that of the separate spans plus the connectors, which run
//! close to the region's boundary.

use super::lines::{LineFamily, LineSpans};
use kurbo::Point;

struct Chain {
    points: Vec<Point>,
    end_u: f64,
}

/// Join the spans of `lines` (one family's, in line order) into polylines. `max_shift` bounds a connector's
/// length along the lines (pixels); `inside(a, b)` says whether the straight stroke from `a` to `b` may be inked.
pub fn join(
    lines: &[LineSpans],
    family: &LineFamily,
    max_shift: f64,
    inside: impl Fn(Point, Point) -> bool,
) -> Vec<Vec<Point>> {
    let (d, n) = family.frame();
    let at = |u: f64, v: f64| Point::new(u * d.0 + v * n.0, u * d.1 + v * n.1);
    let mut chains: Vec<Chain> = Vec::new();
    // Chains that ended on the previous line, by index into `chains`.
    let mut open: Vec<usize> = Vec::new();
    let mut last_slot: Option<usize> = None;
    for line in lines {
        if last_slot.map(|s| s + 1) != Some(line.slot) {
            open.clear();
        }
        let spans = &line.spans;
        // Offers: (shift, chain, span, enter at the span's start?).
        let mut offers: Vec<(f64, usize, usize, bool)> = Vec::new();
        for &c in &open {
            let e = chains[c].end_u;
            let first = spans.partition_point(|s| s.1 < e - max_shift);
            for (i, &(a, b)) in spans.iter().enumerate().skip(first) {
                if a > e + max_shift {
                    break;
                }
                let (da, db) = ((e - a).abs(), (e - b).abs());
                let (shift, from_start) = if da <= db { (da, true) } else { (db, false) };
                if shift <= max_shift {
                    offers.push((shift, c, i, from_start));
                }
            }
        }
        offers.sort_by(|x, y| x.0.total_cmp(&y.0));
        let mut span_taken = vec![false; spans.len()];
        let mut next_open = Vec::new();
        let mut chain_done: Vec<usize> = Vec::new();
        for (_, c, i, from_start) in offers {
            if span_taken[i] || chain_done.contains(&c) {
                continue;
            }
            let (a, b) = spans[i];
            let (enter, leave) = if from_start { (a, b) } else { (b, a) };
            let p = at(enter, line.v);
            let Some(&last) = chains[c].points.last() else { continue };
            if !inside(last, p) {
                continue;
            }
            span_taken[i] = true;
            chain_done.push(c);
            chains[c].points.push(p);
            chains[c].points.push(at(leave, line.v));
            chains[c].end_u = leave;
            next_open.push(c);
        }
        for (i, &(a, b)) in spans.iter().enumerate() {
            if span_taken[i] {
                continue;
            }
            let (enter, leave) = if line.slot % 2 == 0 { (a, b) } else { (b, a) };
            next_open.push(chains.len());
            chains.push(Chain { points: vec![at(enter, line.v), at(leave, line.v)], end_u: leave });
        }
        open = next_open;
        last_slot = Some(line.slot);
    }
    chains.into_iter().map(|c| c.points).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn horizontal() -> LineFamily {
        LineFamily { angle: 0.0, period: 2.0, phase: 0.0 }
    }

    #[test]
    fn a_rectangle_becomes_one_zigzag() {
        // Four lines y = 0, 2, 4, 6, each spanning u 1..9 (u = x for angle 0).
        let lines: Vec<LineSpans> =
            (0..4).map(|k| LineSpans { slot: k, v: 2.0 * k as f64, spans: vec![(1.0, 9.0)] }).collect();
        let out = join(&lines, &horizontal(), 4.0, |_, _| true);
        assert_eq!(out.len(), 1);
        let xs: Vec<(f64, f64)> = out[0].iter().map(|p| (p.x, p.y)).collect();
        assert_eq!(
            xs,
            vec![(1.0, 0.0), (9.0, 0.0), (9.0, 2.0), (1.0, 2.0), (1.0, 4.0), (9.0, 4.0), (9.0, 6.0), (1.0, 6.0)]
        );
    }

    #[test]
    fn connectors_outside_the_region_or_too_long_lift_the_pen() {
        let lines = vec![
            LineSpans { slot: 0, v: 0.0, spans: vec![(0.0, 4.0), (10.0, 14.0)] },
            LineSpans { slot: 1, v: 2.0, spans: vec![(0.0, 4.0), (10.0, 14.0)] },
            // A gap in the slots: line 3 is not the neighbour of line 1.
            LineSpans { slot: 3, v: 6.0, spans: vec![(0.0, 4.0)] },
        ];
        // Everything allowed: each column joins its two lines, the third line starts anew.
        assert_eq!(join(&lines, &horizontal(), 3.0, |_, _| true).len(), 3);
        // A refused connector: every span its own stroke.
        assert_eq!(join(&lines, &horizontal(), 3.0, |_, _| false).len(), 5);
        // The right column's chain ends at u = 14 and is 10 away from the left spans: never crosses over.
        let out = join(&lines, &horizontal(), 3.0, |_, _| true);
        assert!(out.iter().all(|c| c.iter().all(|p| p.x <= 4.0) || c.iter().all(|p| p.x >= 10.0)), "{out:?}");
        // Every span drawn once: 5 spans of 4 units, plus two vertical connectors of 2.
        let ink: f64 = out.iter().flat_map(|c| c.windows(2).map(|w| w[0].distance(w[1]))).sum();
        assert!((ink - (5.0 * 4.0 + 2.0 * 2.0)).abs() < 1e-9, "{ink}");
    }
}
