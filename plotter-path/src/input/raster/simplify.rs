//! Ramer–Douglas–Peucker polyline simplification.
//!
//! The method (Ramer 1972; Douglas and Peucker 1973): keep a span's two end points, find the interior point farthest
//! from the chord between them; if it lies within the tolerance, the whole span collapses to the chord, otherwise
//! the span is split at that point and both halves are treated the same way. Every dropped vertex therefore lies
//! within `tolerance` of the simplified polyline. This version uses an explicit stack (no recursion), so a traced
//! contour with tens of thousands of vertices cannot overflow the call stack.
//!
//! Closed paths (first point == last point) are first split at the vertex farthest from the start, so that both
//! halves are open spans with well-separated ends; the result stays closed.

use kurbo::Point;

pub use crate::geometry::flatten::point_segment_distance;

/// Mark in `keep` the vertices of `points[first..=last]` that RDP retains (the ends are marked by the caller).
fn mark(points: &[Point], first: usize, last: usize, tolerance: f64, keep: &mut [bool]) {
    let mut stack = vec![(first, last)];
    while let Some((a, b)) = stack.pop() {
        if b <= a + 1 {
            continue;
        }
        let (mut best, mut best_d) = (a, -1.0);
        for (i, p) in points.iter().enumerate().take(b).skip(a + 1) {
            let d = point_segment_distance(*p, points[a], points[b]);
            if d > best_d {
                best_d = d;
                best = i;
            }
        }
        if best_d > tolerance {
            keep[best] = true;
            stack.push((a, best));
            stack.push((best, b));
        }
    }
}

/// Simplify an open or closed polyline so that every removed vertex lies within `tolerance` of the result.
///
/// The first and last points are always kept, so a closed input stays closed. A closed input whose simplification
/// would have fewer than three distinct vertices keeps its three most significant ones (a closed path never
/// degenerates into a back-and-forth line).
pub fn simplify(points: &[Point], tolerance: f64) -> Vec<Point> {
    if points.len() <= 2 || tolerance <= 0.0 {
        return points.to_vec();
    }
    let last = points.len() - 1;
    let mut keep = vec![false; points.len()];
    keep[0] = true;
    keep[last] = true;
    let closed = points[0] == points[last];
    if closed {
        // Split at the vertex farthest from the start; for a closed path that vertex is always kept.
        let far = (1..last)
            .max_by(|&i, &j| points[0].distance(points[i]).total_cmp(&points[0].distance(points[j])))
            .unwrap_or(0);
        keep[far] = true;
        mark(points, 0, far, tolerance, &mut keep);
        mark(points, far, last, tolerance, &mut keep);
        if keep.iter().filter(|&&k| k).count() < 4 {
            // Only start, far point and the closing copy survive: add the vertex farthest from that chord.
            let third = (1..last).filter(|&i| i != far).max_by(|&i, &j| {
                let di = point_segment_distance(points[i], points[0], points[far]);
                let dj = point_segment_distance(points[j], points[0], points[far]);
                di.total_cmp(&dj)
            });
            if let Some(t) = third {
                keep[t] = true;
            }
        }
    } else {
        mark(points, 0, last, tolerance, &mut keep);
    }
    points.iter().zip(&keep).filter(|(_, k)| **k).map(|(p, _)| *p).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn collinear_points_collapse() {
        let pts: Vec<Point> = (0..=10).map(|i| Point::new(f64::from(i), 0.0)).collect();
        assert_eq!(simplify(&pts, 0.1), vec![Point::new(0.0, 0.0), Point::new(10.0, 0.0)]);
    }

    #[test]
    fn corner_is_kept() {
        let pts = [Point::new(0.0, 0.0), Point::new(5.0, 0.1), Point::new(10.0, 0.0), Point::new(10.0, 10.0)];
        assert_eq!(simplify(&pts, 0.5), vec![pts[0], pts[2], pts[3]]);
    }

    #[test]
    fn closed_square_stays_a_square() {
        let mut pts = Vec::new();
        for i in 0..10 {
            pts.push(Point::new(f64::from(i), 0.0));
        }
        for i in 0..10 {
            pts.push(Point::new(10.0, f64::from(i)));
        }
        for i in 0..10 {
            pts.push(Point::new(10.0 - f64::from(i), 10.0));
        }
        for i in 0..10 {
            pts.push(Point::new(0.0, 10.0 - f64::from(i)));
        }
        pts.push(pts[0]);
        let s = simplify(&pts, 0.25);
        assert_eq!(s.len(), 5);
        assert_eq!(s.first(), s.last());
        for c in [Point::new(10.0, 0.0), Point::new(10.0, 10.0), Point::new(0.0, 10.0)] {
            assert!(s.contains(&c), "{c:?} missing from {s:?}");
        }
    }

    #[test]
    fn tiny_closed_loop_keeps_three_vertices() {
        let diamond = [
            Point::new(1.0, 0.5),
            Point::new(0.5, 1.0),
            Point::new(0.0, 0.5),
            Point::new(0.5, 0.0),
            Point::new(1.0, 0.5),
        ];
        let s = simplify(&diamond, 2.0);
        assert_eq!(s.len(), 4);
        assert_eq!(s.first(), s.last());
    }

    proptest! {
        #[test]
        fn dropped_vertices_stay_within_tolerance(
            raw in prop::collection::vec((-50.0f64..50.0, -50.0f64..50.0), 2..60),
            tol in 0.01f64..5.0,
        ) {
            let pts: Vec<Point> = raw.iter().map(|&(x, y)| Point::new(x, y)).collect();
            let s = simplify(&pts, tol);
            prop_assert_eq!(s.first(), pts.first());
            prop_assert_eq!(s.last(), pts.last());
            // Each original vertex lies within tolerance of the simplified segment that replaced its span.
            let mut j = 0;
            for p in &pts {
                if j + 1 < s.len() && *p == s[j + 1] && s[j] != s[j + 1] {
                    j += 1;
                }
                let d = if j + 1 < s.len() { point_segment_distance(*p, s[j], s[j + 1]) } else { p.distance(s[j]) };
                prop_assert!(d <= tol + 1e-9, "vertex {:?} is {} from the result", p, d);
            }
        }
    }
}
