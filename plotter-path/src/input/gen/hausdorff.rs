//! Hausdorff distance between two polylines: the largest distance from a vertex of either one to the other
//! polyline (its segments, not just its vertices).
//!
//! Computed with the early-break scheme of Taha and Hanbury ("An efficient algorithm for calculating the exact
//! Hausdorff distance", 2015): while scanning the other polyline for a vertex's nearest segment, stop as soon as
//! one segment is closer than the largest distance found so far — that vertex cannot raise the maximum. Scanning
//! starts at the previous vertex's nearest segment, which along a polyline is almost always close to the current
//! one, so most vertices cost a single segment test and the whole is close to linear.
//!
//! Both polylines should be dense relative to the distance being measured: between vertices, a segment of one may
//! come farther from the other than its endpoints do.

use kurbo::{Line, Point};

use super::sampler::distance_to_segment;

/// Symmetric Hausdorff distance between polylines `a` and `b` (vertex-to-polyline, both ways). Returns
/// `f64::INFINITY` when either is empty.
pub fn hausdorff(a: &[Point], b: &[Point]) -> f64 {
    directed(a, b).max(directed(b, a))
}

/// Largest distance from a vertex of `from` to the polyline `to`.
pub fn directed(from: &[Point], to: &[Point]) -> f64 {
    if from.is_empty() || to.is_empty() {
        return f64::INFINITY;
    }
    let segment = |i: usize| {
        if to.len() == 1 { Line::new(to[0], to[0]) } else { Line::new(to[i], to[i + 1]) }
    };
    let n = to.len().saturating_sub(1).max(1);
    let mut worst: f64 = 0.0;
    let mut hint = 0;
    for &p in from {
        let mut best = f64::INFINITY;
        let mut best_i = hint;
        for step in 0..n {
            let i = (hint + step) % n;
            let d = distance_to_segment(segment(i), p);
            if d < best {
                best = d;
                best_i = i;
                if best < worst {
                    break;
                }
            }
        }
        hint = best_i;
        worst = worst.max(best);
    }
    worst
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn squares() {
        let sq = |s: f64| {
            vec![Point::new(0.0, 0.0), Point::new(s, 0.0), Point::new(s, s), Point::new(0.0, s), Point::ORIGIN]
        };
        // A 10 mm square and a 12 mm one sharing a corner: the far corner is 2√2 from the small square, and the
        // small square's vertices are all on or inside... at most 2 mm from the big square's edges.
        let (a, b) = (sq(10.0), sq(12.0));
        assert!((directed(&b, &a) - 8f64.sqrt()).abs() < 1e-12);
        assert!((directed(&a, &b) - 2.0).abs() < 1e-12);
        assert!((hausdorff(&a, &b) - 8f64.sqrt()).abs() < 1e-12);
        assert_eq!(hausdorff(&a, &a), 0.0);
        assert_eq!(hausdorff(&a, &[]), f64::INFINITY);
    }

    #[test]
    fn matches_brute_force() {
        let wave = |amp: f64, n: u32| -> Vec<Point> {
            (0..=n)
                .map(|i| {
                    let t = f64::from(i) / f64::from(n) * 20.0;
                    Point::new(t * 3.0, amp * (t * 1.3).sin() + 0.1 * (t * 7.0).cos())
                })
                .collect()
        };
        let (a, b) = (wave(5.0, 400), wave(4.0, 157));
        let brute = |from: &[Point], to: &[Point]| {
            from.iter()
                .map(|&p| {
                    to.windows(2).map(|w| distance_to_segment(Line::new(w[0], w[1]), p)).fold(f64::INFINITY, f64::min)
                })
                .fold(0.0, f64::max)
        };
        assert_eq!(directed(&a, &b), brute(&a, &b));
        assert_eq!(directed(&b, &a), brute(&b, &a));
    }
}
