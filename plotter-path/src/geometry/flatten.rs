//! Curve flattening with a proven chord-error bound.
//!
//! Every Bézier segment is cut into `n` pieces of equal parameter length, with `n` chosen from the curve's second
//! derivative (the bound known as Wang's formula): for a polynomial curve `B` on a parameter interval of length `h`,
//! the distance between `B` and the chord through its endpoints is at most `h² · max‖B''‖ / 8`. For a cubic with
//! control points `P0..P3`, `max‖B''‖ ≤ 6 · max(‖P0 − 2P1 + P2‖, ‖P1 − 2P2 + P3‖)`; for a quadratic `B''` is the
//! constant `2 (P0 − 2P1 + P2)`. Choosing `n = ⌈sqrt(max‖B''‖ / (8 · tol))⌉` therefore guarantees a chord error
//! ≤ `tol` for every emitted segment — a bound we rely on instead of a library's estimate, and which the property
//! tests below check against densely sampled true distances.
//!
//! Elliptical arcs use the same argument on the parametric ellipse `c + R(φ)(rx cos θ, ry sin θ)`, whose second
//! derivative has norm ≤ `max(rx, ry)`.
//!
//! Bounded work: a curve with a control point beyond [`crate::geometry::limits::MAX_COORD_MM`] (or not finite)
//! becomes a single chord — such a drawing is refused by [`crate::geometry::limits::check_drawing`], and flattening
//! a curve of 10²⁰ mm finely would exhaust memory first — and once one path has more than
//! [`crate::geometry::limits::MAX_POINTS`] points, its remaining curves become single chords too (the drawing is
//! then refused for its point count). Within the limits, the tolerance bound always holds.
//!
//! Uniform parameter steps cost a few more points than curvature-adaptive subdivision on very uneven curves, but
//! they are branch-free, need no recursion and run at tens of millions of segments per second.

use kurbo::{Arc, CubicBez, ParamCurve, PathEl, Point, QuadBez, Vec2};

use crate::geometry::limits::{MAX_COORD_MM, MAX_POINTS, point_ok};

/// Smallest accepted tolerance, mm. Below this, coordinates in f32 SVG data carry more error than the bound.
pub const MIN_TOLERANCE: f64 = 1e-6;

/// Upper limit on pieces per curve segment, so a degenerate (huge) curve cannot exhaust memory.
pub const MAX_PIECES_PER_CURVE: usize = 1 << 16;

fn pieces_for(max_second_derivative: f64, tolerance: f64) -> usize {
    let n = (max_second_derivative / (8.0 * tolerance)).sqrt().ceil();
    if n.is_nan() || n < 1.0 {
        1
    } else if n >= MAX_PIECES_PER_CURVE as f64 {
        MAX_PIECES_PER_CURVE
    } else {
        // n is a positive integer below MAX_PIECES_PER_CURVE, so the conversion is exact.
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let n = n as usize;
        n
    }
}

/// Number of equal-parameter pieces that keep `c` within `tolerance` of its chords.
pub fn cubic_pieces(c: &CubicBez, tolerance: f64) -> usize {
    if ![c.p0, c.p1, c.p2, c.p3].into_iter().all(point_ok) {
        return 1;
    }
    let d1 = (c.p0.to_vec2() - 2.0 * c.p1.to_vec2() + c.p2.to_vec2()).hypot();
    let d2 = (c.p1.to_vec2() - 2.0 * c.p2.to_vec2() + c.p3.to_vec2()).hypot();
    pieces_for(6.0 * d1.max(d2), tolerance)
}

/// Number of equal-parameter pieces that keep `q` within `tolerance` of its chords.
pub fn quad_pieces(q: &QuadBez, tolerance: f64) -> usize {
    if ![q.p0, q.p1, q.p2].into_iter().all(point_ok) {
        return 1;
    }
    let d = (q.p0.to_vec2() - 2.0 * q.p1.to_vec2() + q.p2.to_vec2()).hypot();
    pieces_for(2.0 * d, tolerance)
}

/// Append the flattened points of `c` (excluding its start point, including its end point) to `out`.
pub fn flatten_cubic(c: &CubicBez, tolerance: f64, out: &mut Vec<Point>) {
    let n = cubic_pieces(c, tolerance);
    out.reserve(n);
    // Power-basis evaluation: B(t) = a t³ + b t² + c t + d.
    let (p0, p1, p2, p3) = (c.p0.to_vec2(), c.p1.to_vec2(), c.p2.to_vec2(), c.p3.to_vec2());
    let a = p3 - p0 + 3.0 * (p1 - p2);
    let b = 3.0 * (p0 - 2.0 * p1 + p2);
    let cc = 3.0 * (p1 - p0);
    let inv = 1.0 / n as f64;
    for i in 1..n {
        let t = i as f64 * inv;
        out.push((((a * t + b) * t + cc) * t + p0).to_point());
    }
    out.push(c.p3);
}

/// Append the flattened points of `q` (excluding its start point, including its end point) to `out`.
pub fn flatten_quad(q: &QuadBez, tolerance: f64, out: &mut Vec<Point>) {
    let n = quad_pieces(q, tolerance);
    out.reserve(n);
    let inv = 1.0 / n as f64;
    for i in 1..n {
        out.push(q.eval(i as f64 * inv));
    }
    out.push(q.p2);
}

/// Number of equal-angle pieces that keep the elliptical arc within `tolerance` of its chords.
pub fn arc_pieces(arc: &Arc, tolerance: f64) -> usize {
    let r = arc.radii.x.abs().max(arc.radii.y.abs());
    let sweep = arc.sweep_angle.abs();
    if !(point_ok(arc.center) && r <= MAX_COORD_MM && sweep.is_finite()) {
        return 1;
    }
    pieces_for(r * sweep * sweep, tolerance)
}

/// Point of `arc` at angle `theta` (radians, in the ellipse's own frame).
fn arc_point(arc: &Arc, theta: f64) -> Point {
    let (s, c) = theta.sin_cos();
    let (rs, rc) = arc.x_rotation.sin_cos();
    let local = Vec2::new(arc.radii.x * c, arc.radii.y * s);
    arc.center + Vec2::new(local.x * rc - local.y * rs, local.x * rs + local.y * rc)
}

/// Append the flattened points of an elliptical arc (excluding its start point, including its end) to `out`.
pub fn flatten_arc(arc: &Arc, tolerance: f64, out: &mut Vec<Point>) {
    let n = arc_pieces(arc, tolerance);
    out.reserve(n);
    for i in 1..=n {
        let theta = arc.start_angle + arc.sweep_angle * (i as f64 / n as f64);
        out.push(arc_point(arc, theta));
    }
}

/// Flatten a path (move/line/quad/cubic/close elements, already in millimetres) into polylines.
///
/// Each `MoveTo` starts a new polyline; `ClosePath` appends the subpath's start point so the polyline is closed by
/// the first == last rule. Subpaths with fewer than two points are dropped and counted in the returned number
/// (a lone `M` draws nothing).
pub fn flatten_path(elements: impl IntoIterator<Item = PathEl>, tolerance: f64) -> (Vec<Vec<Point>>, usize) {
    let tolerance = tolerance.max(MIN_TOLERANCE);
    let mut out: Vec<Vec<Point>> = Vec::new();
    let mut dropped = 0usize;
    let mut current: Vec<Point> = Vec::new();
    let mut start = Point::ZERO;
    // Points in finished polylines (the running count keeps the whole call under MAX_POINTS, see the module docs).
    let mut done = 0usize;
    let mut finish = |current: &mut Vec<Point>, out: &mut Vec<Vec<Point>>, done: &mut usize| {
        if current.len() >= 2 {
            *done += current.len();
            out.push(std::mem::take(current));
        } else if !current.is_empty() {
            dropped += 1;
            current.clear();
        }
    };
    for el in elements {
        match el {
            PathEl::MoveTo(p) => {
                finish(&mut current, &mut out, &mut done);
                current.push(p);
                start = p;
            }
            PathEl::LineTo(p) => {
                if current.is_empty() {
                    current.push(start);
                }
                current.push(p);
            }
            PathEl::QuadTo(p1, p2) => {
                let p0 = *current.last().unwrap_or(&start);
                if current.is_empty() {
                    current.push(p0);
                }
                if over_budget(done, &current) {
                    current.push(p2);
                } else {
                    flatten_quad(&QuadBez::new(p0, p1, p2), tolerance, &mut current);
                }
            }
            PathEl::CurveTo(p1, p2, p3) => {
                let p0 = *current.last().unwrap_or(&start);
                if current.is_empty() {
                    current.push(p0);
                }
                if over_budget(done, &current) {
                    current.push(p3);
                } else {
                    flatten_cubic(&CubicBez::new(p0, p1, p2, p3), tolerance, &mut current);
                }
            }
            PathEl::ClosePath => {
                if current.len() >= 2 && current.last() != Some(&start) {
                    current.push(start);
                }
                finish(&mut current, &mut out, &mut done);
            }
        }
    }
    finish(&mut current, &mut out, &mut done);
    (out, dropped)
}

/// Whether the points emitted so far exceed [`MAX_POINTS`] (then curves become chords: the drawing is refused).
fn over_budget(done: usize, current: &[Point]) -> bool {
    done + current.len() > MAX_POINTS
}

/// Distance from `p` to the segment `a`–`b`.
pub fn point_segment_distance(p: Point, a: Point, b: Point) -> f64 {
    let ab = b - a;
    let len2 = ab.hypot2();
    if len2 == 0.0 {
        return p.distance(a);
    }
    let t = ((p - a).dot(ab) / len2).clamp(0.0, 1.0);
    p.distance(a + ab * t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Largest distance between the curve on [t0, t1] and the chord from `a` to `b`, sampled densely.
    fn sampled_chord_error(curve: &impl Fn(f64) -> Point, t0: f64, t1: f64, a: Point, b: Point) -> f64 {
        const SAMPLES: usize = 64;
        (0..=SAMPLES)
            .map(|k| curve(t0 + (t1 - t0) * k as f64 / SAMPLES as f64))
            .map(|p| point_segment_distance(p, a, b))
            .fold(0.0, f64::max)
    }

    /// Check every emitted chord of a curve flattened at equal parameter steps.
    fn assert_within(curve: impl Fn(f64) -> Point, points: &[Point], tolerance: f64) -> Result<(), TestCaseError> {
        let n = points.len() - 1;
        for i in 0..n {
            let (t0, t1) = (i as f64 / n as f64, (i + 1) as f64 / n as f64);
            let err = sampled_chord_error(&curve, t0, t1, points[i], points[i + 1]);
            prop_assert!(err <= tolerance * (1.0 + 1e-9), "chord {i}/{n}: error {err} > {tolerance}");
        }
        Ok(())
    }

    #[test]
    fn absurd_curves_flatten_to_chords_in_bounded_work() {
        // The circle of r = 1e20 (four cubics, as SVG converters emit it): one chord per curve, so the
        // drawing reaches the limit check (which refuses it) instead of exhausting memory.
        let r = 1e20;
        let k = 0.552_284_749_831 * r;
        let c = Point::new(50.0, 50.0);
        let els = [
            PathEl::MoveTo(c + Vec2::new(r, 0.0)),
            PathEl::CurveTo(c + Vec2::new(r, k), c + Vec2::new(k, r), c + Vec2::new(0.0, r)),
            PathEl::CurveTo(c + Vec2::new(-k, r), c + Vec2::new(-r, k), c + Vec2::new(-r, 0.0)),
            PathEl::QuadTo(c + Vec2::new(-r, -r), c + Vec2::new(0.0, -r)),
            PathEl::CurveTo(c + Vec2::new(k, -r), c + Vec2::new(r, -k), c + Vec2::new(r, 0.0)),
            PathEl::ClosePath,
        ];
        let (polys, _) = flatten_path(els, 0.05);
        assert_eq!(polys[0].len(), 5);
        let arc = Arc::new(c, Vec2::new(r, r), 0.0, 6.0, 0.0);
        assert_eq!(arc_pieces(&arc, 0.05), 1);
        // At the limit (1 km) a full circle still flattens within tolerance, with a bounded number of chords.
        let q =
            CubicBez::new(Point::new(1e6, 0.0), Point::new(1e6, 0.55e6), Point::new(0.55e6, 1e6), Point::new(0.0, 1e6));
        let n = cubic_pieces(&q, 0.05);
        assert!(n > 1 && n < 10_000, "{n}");
        assert_eq!(
            cubic_pieces(&CubicBez::new(Point::ZERO, Point::new(f64::NAN, 0.0), Point::ZERO, Point::ZERO), 0.05),
            1
        );
    }

    fn pt() -> impl Strategy<Value = Point> {
        (-500.0f64..500.0, -500.0f64..500.0).prop_map(|(x, y)| Point::new(x, y))
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(300))]

        #[test]
        fn cubic_chord_error_within_tolerance(p0 in pt(), p1 in pt(), p2 in pt(), p3 in pt(), tol in 0.001f64..1.0) {
            let c = CubicBez::new(p0, p1, p2, p3);
            let mut pts = vec![p0];
            flatten_cubic(&c, tol, &mut pts);
            prop_assert_eq!(*pts.last().unwrap(), p3);
            assert_within(|t| c.eval(t), &pts, tol)?;
        }

        #[test]
        fn quad_chord_error_within_tolerance(p0 in pt(), p1 in pt(), p2 in pt(), tol in 0.001f64..1.0) {
            let q = QuadBez::new(p0, p1, p2);
            let mut pts = vec![p0];
            flatten_quad(&q, tol, &mut pts);
            prop_assert_eq!(*pts.last().unwrap(), p2);
            assert_within(|t| q.eval(t), &pts, tol)?;
        }

        #[test]
        fn arc_chord_error_within_tolerance(
            c in pt(), rx in 0.01f64..300.0, ry in 0.01f64..300.0, rot in 0.0f64..6.3,
            start in -7.0f64..7.0, sweep in -6.3f64..6.3, tol in 0.001f64..1.0,
        ) {
            let arc = Arc::new(c, Vec2::new(rx, ry), start, sweep, rot);
            let mut pts = vec![arc_point(&arc, start)];
            flatten_arc(&arc, tol, &mut pts);
            assert_within(|t| arc_point(&arc, start + sweep * t), &pts, tol)?;
        }

        /// The bound is not wildly pessimistic: a circle needs no more than ~1.5× the optimal chord count.
        #[test]
        fn arc_piece_count_is_near_optimal(r in 1.0f64..500.0, tol in 0.005f64..0.5) {
            let arc = Arc::new(Point::ZERO, Vec2::new(r, r), 0.0, std::f64::consts::TAU, 0.0);
            let optimal = std::f64::consts::PI / (1.0 - tol / r).acos();
            let n = arc_pieces(&arc, tol) as f64;
            prop_assert!(n >= optimal - 1.0 && n <= optimal * 1.5 + 2.0, "n {n} optimal {optimal}");
        }
    }

    #[test]
    fn path_subpaths_close_and_lone_moves_are_counted() {
        let els = [
            PathEl::MoveTo(Point::new(0.0, 0.0)),
            PathEl::LineTo(Point::new(10.0, 0.0)),
            PathEl::LineTo(Point::new(10.0, 10.0)),
            PathEl::ClosePath,
            PathEl::MoveTo(Point::new(50.0, 50.0)),
            PathEl::MoveTo(Point::new(20.0, 0.0)),
            PathEl::QuadTo(Point::new(25.0, 10.0), Point::new(30.0, 0.0)),
        ];
        let (paths, dropped) = flatten_path(els, 0.01);
        assert_eq!(dropped, 1);
        assert_eq!(paths.len(), 2);
        assert_eq!(paths[0], vec![Point::new(0.0, 0.0), Point::new(10.0, 0.0), Point::new(10.0, 10.0), Point::ZERO]);
        assert_eq!(paths[1].first(), Some(&Point::new(20.0, 0.0)));
        assert_eq!(paths[1].last(), Some(&Point::new(30.0, 0.0)));
        // Quadratic with ‖P0 − 2P1 + P2‖ = 20: n = ceil(sqrt(40 / 0.08)) = 23 pieces.
        assert_eq!(paths[1].len(), 24);
    }

    #[test]
    fn straight_cubic_is_one_segment() {
        let c = CubicBez::new((0.0, 0.0), (1.0, 0.0), (2.0, 0.0), (3.0, 0.0));
        assert_eq!(cubic_pieces(&c, 0.05), 1);
    }
}
