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
//!
//! Turns (issue 39): the chord error alone lets a tight bend of a curve — a petal's tip of 0.2 mm radius — fall
//! between two chords that meet at 80° at 0.05 mm, where the motion planner sees a corner rather than the
//! curve, and plans it at the corner's speed instead of the curve's centripetal limit `sqrt(a·r)` (see
//! `plotter_fw::planner`'s curve rules). So the flattening also keeps consecutive chords of one curve within
//! [`MAX_TURN_RAD`] of each other: the pieces on both sides of a vertex that turns more are halved (in
//! parameter), round after round, until every vertex that still does has both its chords shorter than
//! [`MIN_SPLIT_CHORD_MM`] (a cusp), or the curve has [`MAX_PIECES_PER_CURVE`] pieces. A piece's chord error only shrinks when it is halved, so the tolerance bound holds
//! as before; only bends of radius below about `tolerance / (1 − cos(MAX_TURN_RAD / 2))` (5.8 mm at 0.05 mm)
//! gain points, and the planner sees them as finely cut as a fine tolerance would (each chord turning at most
//! 15°), so a drawing plans alike at a coarse and a fine tolerance.

use kurbo::{Arc, CubicBez, ParamCurve, PathEl, Point, QuadBez, Vec2};

use crate::geometry::limits::{MAX_COORD_MM, MAX_POINTS, point_ok};

/// Smallest accepted tolerance, mm. Below this, coordinates in f32 SVG data carry more error than the bound.
pub const MIN_TOLERANCE: f64 = 1e-6;

/// Upper limit on pieces per curve segment, so a degenerate (huge) curve cannot exhaust memory.
pub const MAX_PIECES_PER_CURVE: usize = 1 << 16;

/// Largest turn between consecutive chords of one curve, radians (15°; see the module docs): about what a
/// 0.002 mm tolerance gives a 0.2 mm bend (16°), fine enough for the planner to read the bend's radius.
pub const MAX_TURN_RAD: f64 = 15.0 * std::f64::consts::PI / 180.0;

/// A piece whose chord is shorter than this (mm) is not halved for its turn: a finer cut than a plotter's step
/// (0.0125 mm at 80 steps/mm) tells the planner nothing more, and a cusp turns sharply however fine the cut.
pub const MIN_SPLIT_CHORD_MM: f64 = 0.01;

/// Most rounds of halving pieces for their turn. Each round halves the parameter span of the pieces it splits,
/// so their chords (at most the curve's largest speed `‖B'‖` times the span) fall below [`MIN_SPLIT_CHORD_MM`]
/// within about 30 rounds for any curve inside [`MAX_COORD_MM`]; this only guards that argument.
const MAX_SPLIT_ROUNDS: usize = 64;

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

/// Whether the chords `a`→`b` and `b`→`c` turn by more than [`MAX_TURN_RAD`] at `b` (a chord of length 0 never
/// does).
fn turns_sharply(a: Point, b: Point, c: Point) -> bool {
    let (u, v) = (b - a, c - b);
    let lengths = u.hypot() * v.hypot();
    lengths > 0.0 && u.dot(v) < MAX_TURN_RAD.cos() * lengths
}

/// The cut of a curve `eval` over the parameters 0..1 (ending exactly at `end`) into `n` equal-parameter pieces,
/// as (parameter, point) pairs from 0 to 1, with the pieces beside a vertex that turns by more than
/// [`MAX_TURN_RAD`] halved until none does (see the module docs). Every piece spans at most `1 / n` of the
/// parameter, so Wang's bound for `n` pieces holds for each.
fn cut(eval: impl Fn(f64) -> Point, n: usize, end: Point) -> Vec<(f64, Point)> {
    let inv = 1.0 / n as f64;
    let mut cuts: Vec<(f64, Point)> = (0..n).map(|i| (i as f64 * inv, eval(i as f64 * inv))).collect();
    cuts.push((1.0, end));
    let mut split = Vec::new();
    for _ in 0..MAX_SPLIT_ROUNDS {
        // split[i]: the piece from cuts[i] to cuts[i + 1] is halved this round.
        split.clear();
        split.resize(cuts.len() - 1, false);
        for (i, w) in cuts.windows(3).enumerate() {
            if turns_sharply(w[0].1, w[1].1, w[2].1) {
                split[i] = true;
                split[i + 1] = true;
            }
        }
        for (s, w) in split.iter_mut().zip(cuts.windows(2)) {
            *s &= w[0].1.distance(w[1].1) >= MIN_SPLIT_CHORD_MM;
        }
        let more = split.iter().filter(|s| **s).count();
        if more == 0 || cuts.len() - 1 + more > MAX_PIECES_PER_CURVE {
            break;
        }
        let mut next = Vec::with_capacity(cuts.len() + more);
        for (w, s) in cuts.windows(2).zip(&split) {
            next.push(w[0]);
            if *s {
                let t = 0.5 * (w[0].0 + w[1].0);
                next.push((t, eval(t)));
            }
        }
        next.extend(cuts.last().copied());
        cuts = next;
    }
    cuts
}

/// Append the points of [`cut`] after its start point (so ending at `end`) to `out`.
fn append_cut(eval: impl Fn(f64) -> Point, n: usize, end: Point, out: &mut Vec<Point>) {
    let cuts = cut(eval, n, end);
    out.extend(cuts[1..].iter().map(|c| c.1));
}

/// The cubic `c` as a function of its parameter (power-basis evaluation: `B(t) = a t³ + b t² + c t + d`).
fn cubic_eval(c: &CubicBez) -> impl Fn(f64) -> Point {
    let (p0, p1, p2, p3) = (c.p0.to_vec2(), c.p1.to_vec2(), c.p2.to_vec2(), c.p3.to_vec2());
    let a = p3 - p0 + 3.0 * (p1 - p2);
    let b = 3.0 * (p0 - 2.0 * p1 + p2);
    let cc = 3.0 * (p1 - p0);
    move |t| (((a * t + b) * t + cc) * t + p0).to_point()
}

/// Append the flattened points of `c` (excluding its start point, including its end point) to `out`.
pub fn flatten_cubic(c: &CubicBez, tolerance: f64, out: &mut Vec<Point>) {
    append_cut(cubic_eval(c), cubic_pieces(c, tolerance), c.p3, out);
}

/// Append the flattened points of `q` (excluding its start point, including its end point) to `out`.
pub fn flatten_quad(q: &QuadBez, tolerance: f64, out: &mut Vec<Point>) {
    append_cut(|t| q.eval(t), quad_pieces(q, tolerance), q.p2, out);
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

/// The elliptical arc as a function of the fraction of its sweep.
fn arc_eval(arc: &Arc) -> impl Fn(f64) -> Point {
    move |s| arc_point(arc, arc.start_angle + arc.sweep_angle * s)
}

/// Append the flattened points of an elliptical arc (excluding its start point, including its end) to `out`.
pub fn flatten_arc(arc: &Arc, tolerance: f64, out: &mut Vec<Point>) {
    let eval = arc_eval(arc);
    let end = eval(1.0);
    append_cut(eval, arc_pieces(arc, tolerance), end, out);
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

    /// The turn (radians, 0..π) between the chords `a`→`b` and `b`→`c`, from their directions' angles.
    fn turn(a: Point, b: Point, c: Point) -> f64 {
        let d = (c - b).atan2() - (b - a).atan2();
        (d + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI
    }

    /// Check a cut (parameter, point pairs, in order) of `curve`: every chord within `tolerance` of the curve over
    /// its parameter span, and every vertex turning by at most [`MAX_TURN_RAD`] unless both its chords are
    /// shorter than [`MIN_SPLIT_CHORD_MM`] (a cusp).
    fn assert_cut_within(
        curve: impl Fn(f64) -> Point,
        cuts: &[(f64, Point)],
        tolerance: f64,
    ) -> Result<(), TestCaseError> {
        let n = cuts.len() - 1;
        prop_assert!(n < MAX_PIECES_PER_CURVE, "{n} pieces");
        for (i, w) in cuts.windows(2).enumerate() {
            prop_assert!(w[0].0 < w[1].0, "parameters out of order at {i}");
            let err = sampled_chord_error(&curve, w[0].0, w[1].0, w[0].1, w[1].1);
            prop_assert!(err <= tolerance * (1.0 + 1e-9), "chord {i}/{n}: error {err} > {tolerance}");
        }
        for (i, w) in cuts.windows(3).enumerate() {
            let (a, b, c) = (w[0].1, w[1].1, w[2].1);
            let phi = turn(a, b, c).abs();
            let cusp = a.distance(b) < MIN_SPLIT_CHORD_MM && b.distance(c) < MIN_SPLIT_CHORD_MM;
            prop_assert!(phi <= MAX_TURN_RAD + 1e-9 || cusp, "vertex {}/{n} turns {}°", i + 1, phi.to_degrees());
        }
        Ok(())
    }

    /// Check that `points` (a flattening's output after its start point) are the cut's points, ending at `end`.
    fn assert_emits(points: &[Point], cuts: &[(f64, Point)], end: Point) -> Result<(), TestCaseError> {
        let n = cuts.len() - 1;
        prop_assert_eq!(points.len(), n);
        prop_assert_eq!(points[n - 1], end);
        for (p, c) in points[..n - 1].iter().zip(&cuts[1..n]) {
            prop_assert_eq!(*p, c.1);
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
            let mut pts = Vec::new();
            flatten_cubic(&c, tol, &mut pts);
            let cuts = cut(cubic_eval(&c), cubic_pieces(&c, tol), p3);
            assert_emits(&pts, &cuts, p3)?;
            assert_cut_within(|t| c.eval(t), &cuts, tol)?;
        }

        #[test]
        fn quad_chord_error_within_tolerance(p0 in pt(), p1 in pt(), p2 in pt(), tol in 0.001f64..1.0) {
            let q = QuadBez::new(p0, p1, p2);
            let mut pts = Vec::new();
            flatten_quad(&q, tol, &mut pts);
            let cuts = cut(|t| q.eval(t), quad_pieces(&q, tol), p2);
            assert_emits(&pts, &cuts, p2)?;
            assert_cut_within(|t| q.eval(t), &cuts, tol)?;
        }

        #[test]
        fn arc_chord_error_within_tolerance(
            c in pt(), rx in 0.01f64..300.0, ry in 0.01f64..300.0, rot in 0.0f64..6.3,
            start in -7.0f64..7.0, sweep in -6.3f64..6.3, tol in 0.001f64..1.0,
        ) {
            let arc = Arc::new(c, Vec2::new(rx, ry), start, sweep, rot);
            let mut pts = Vec::new();
            flatten_arc(&arc, tol, &mut pts);
            let cuts = cut(arc_eval(&arc), arc_pieces(&arc, tol), arc_point(&arc, start + sweep));
            assert_emits(&pts, &cuts, arc_point(&arc, start + sweep))?;
            assert_cut_within(|t| arc_point(&arc, start + sweep * t), &cuts, tol)?;
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
    fn a_tight_tip_is_cut_into_chords_turning_at_most_fifteen_degrees() {
        // The parabola y = x² / (2 · 0.2) for x in −1.5..1.5, a petal's tip of radius 0.2 mm: the quadratic
        // (−1.5, 5.625), (0, −5.625), (1.5, 5.625), x = 3t − 1.5 uniform in t. ‖P0 − 2P1 + P2‖ = 22.5, so at
        // 0.05 mm n = ⌈√(45 / 0.4)⌉ = 11 pieces of Δx = 3/11, with vertices at x = ±1.5/11 beside the tip: the flat
        // middle chord meets the next, of slope (1.5 + 4.5) / 11 / 0.4 = 1.364, at atan 1.364 = 53.75°.
        let q = QuadBez::new((-1.5, 5.625), (0.0, -5.625), (1.5, 5.625));
        let n = quad_pieces(&q, 0.05);
        assert_eq!(n, 11);
        let uniform: Vec<Point> = (0..=n).map(|i| q.eval(i as f64 / n as f64)).collect();
        assert!((turn(uniform[5], uniform[6], uniform[7]).to_degrees() - 53.75).abs() < 0.01);
        // Flattened, no vertex turns more than 15°, and no chord strays more than 0.05 mm: the middle piece is
        // cut in eighths (Δx = 3/88, the tip's chords 0.0342 mm long, turning by about 2 · atan(3/88 / 0.4) =
        // 9.7°), each piece beside it in a half and two quarters, the next ones in halves, the outer three on
        // each side kept: 8 + 2 · (3 + 2 + 3) = 24 pieces.
        let mut pts = vec![q.p0];
        flatten_quad(&q, 0.05, &mut pts);
        let cuts = cut(|t| q.eval(t), n, q.p2);
        assert_cut_within(|t| q.eval(t), &cuts, 0.05).unwrap();
        assert_eq!(cuts.len() - 1, 24);
        assert_eq!(pts.len(), 25);
        let shortest = cuts.windows(2).map(|w| w[0].1.distance(w[1].1)).fold(f64::INFINITY, f64::min);
        assert!((shortest - 0.034_21).abs() < 1e-4, "{shortest}");
        // The same at 0.002 mm: n = ⌈√(45 / 0.016)⌉ = 54, Δx = 3/54, a vertex at the tip whose chords climb
        // atan(3/54 / 0.4) = 7.91° either side, a turn of 15.8°: its two pieces are halved (then turning by at
        // most 10.8°), nothing else: 56 pieces.
        let fine = cut(|t| q.eval(t), quad_pieces(&q, 0.002), q.p2);
        assert_cut_within(|t| q.eval(t), &fine, 0.002).unwrap();
        assert_eq!(fine.len() - 1, 56);
    }

    #[test]
    fn straight_cubic_is_one_segment() {
        let c = CubicBez::new((0.0, 0.0), (1.0, 0.0), (2.0, 0.0), (3.0, 0.0));
        assert_eq!(cubic_pieces(&c, 0.05), 1);
    }
}
