//! Turning a parametric curve into a polyline: a fixed number of points (the seed plotter's mode) or adaptively, so
//! that no chord strays from the curve by more than a tolerance in millimetres (the default).
//!
//! ## Adaptive sampling
//!
//! The parameter domain is first cut into [`Curve::min_segments`] equal intervals (and at its corners,
//! [`Curve::breaks`]); each curve asks for about eight per cycle of the fastest relative rotation among its
//! components, so no loop or wiggle can hide between probes. Each interval is then refined by bisection (the
//! classic recursive-subdivision flattening used for Bézier curves, applied here to an arbitrary `t ↦ point` map):
//! the curve is probed at the quarter, half and three-quarter parameters, and the interval is accepted once every
//! probe lies within `0.9 × tolerance` of the chord **and** the probe polyline turns by at most 45°. The turning
//! bound keeps accepted pieces nearly straight, where the curve's deviation from its chord is close to a cubic in
//! `t`, whose maximum the three probes under-estimate by at most 2.5 % — the 10 % margin covers that. (Without it, a
//! piece containing a sharp bend can pass with its probes near the chord while the bend between them strays
//! farther.) A piece that passes is confirmed by four more probes at the odd eighths, which catch the rarer wiggle
//! whose deviation happens to vanish near the quarter points (found by the property test: a sum of four rotations
//! where the three probes saw a fifth of the true error). An interval is also accepted when its probe polyline is
//! shorter than the tolerance: no point of so
//! short an arc can be farther than that from its chord. That is what ends refinement at a cusp, where the
//! direction reverses however small the piece. The property tests check the real chord error of every segment with
//! 64 probes per segment, over random sums of circular motions and random generator parameters.
//!
//! Each bisection reuses the parent's probes (the parent's quarter points are the children's midpoints), so testing
//! an interval costs two curve evaluations, plus four to confirm one that is accepted.

use kurbo::{Line, ParamCurveNearest, Point};

use super::GenError;
use crate::Polyline;

/// Chord tolerance used when none is given, in millimetres: well below a pen's line width.
pub const DEFAULT_TOLERANCE_MM: f64 = 0.01;

/// Smallest accepted chord tolerance, mm (smaller values only chase floating-point noise).
pub const MIN_TOLERANCE_MM: f64 = 1e-6;

/// Most points adaptive or fixed sampling may produce for one curve.
pub const MAX_POINTS: usize = 4_000_000;

/// Deepest bisection of one initial interval (2⁴⁰ pieces; only reached on degenerate curves).
const MAX_DEPTH: u32 = 40;

/// Fraction of the tolerance the probes must meet (see the module docs for why not 1.0).
const PROBE_MARGIN: f64 = 0.9;

/// Most the probe polyline of an accepted interval may turn, radians (see the module docs).
const MAX_TURNING: f64 = std::f64::consts::FRAC_PI_4;

/// A curve `t ↦ point` over a finite parameter interval, in millimetres (math orientation: Y up, centred on the
/// figure's own origin; placement on the page happens later).
pub trait Curve {
    /// Short name of the figure kind, used in error messages.
    fn name(&self) -> &'static str;
    /// The point at parameter `t` (`t` within [`Curve::domain`]).
    fn point(&self, t: f64) -> Point;
    /// The parameter interval `(start, end)`, `start < end`.
    fn domain(&self) -> (f64, f64);
    /// True when `point(end)` equals `point(start)` mathematically; the sampled polyline then ends exactly on its
    /// first point.
    fn is_closed(&self) -> bool;
    /// Number of equal parameter intervals adaptive sampling starts from (see the module docs). At least 1.
    fn min_segments(&self) -> usize;
    /// Parameters strictly inside the domain where the curve has a corner; adaptive sampling puts a vertex on
    /// each. None by default.
    fn breaks(&self) -> Vec<f64> {
        Vec::new()
    }
}

/// How a curve is turned into points.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Sampling {
    /// Exactly this many equally spaced parameter values: for a closed curve `n` distinct points plus the first one
    /// repeated at the end (`n` segments); for an open curve `n` points from start to end inclusive.
    Fixed(usize),
    /// As few points as keep every chord within this distance of the curve, in millimetres.
    Adaptive(f64),
}

impl Default for Sampling {
    fn default() -> Self {
        Sampling::Adaptive(DEFAULT_TOLERANCE_MM)
    }
}

/// Sample `curve` into a polyline (math orientation, like the curve). Closed curves come back closed: the last point
/// is set to exactly the first.
///
/// # Errors
/// [`GenError::BadValue`] for a fixed count below 3 (closed) or 2 (open) or a tolerance below
/// [`MIN_TOLERANCE_MM`] or not finite; [`GenError::TooManyPoints`] past [`MAX_POINTS`]; [`GenError::NonFinite`] if
/// the curve evaluates to a non-finite point.
pub fn sample<C: Curve + ?Sized>(curve: &C, sampling: Sampling) -> Result<Polyline, GenError> {
    Ok(Polyline::new(sample_with_params(curve, sampling)?.into_iter().map(|(_, p)| p).collect()))
}

/// Like [`sample`], but each vertex comes with the curve parameter it was taken at.
///
/// # Errors
/// As [`sample`].
pub fn sample_with_params<C: Curve + ?Sized>(curve: &C, sampling: Sampling) -> Result<Vec<(f64, Point)>, GenError> {
    let mut points = match sampling {
        Sampling::Fixed(n) => sample_fixed(curve, n)?,
        Sampling::Adaptive(tolerance) => sample_adaptive(curve, tolerance)?,
    };
    if let Some(&(t, _)) = points.iter().find(|(_, p)| !(p.x.is_finite() && p.y.is_finite())) {
        return Err(GenError::NonFinite { kind: curve.name().to_string(), t });
    }
    if curve.is_closed() {
        let first = points[0].1;
        if let Some(last) = points.last_mut() {
            last.1 = first;
        }
    }
    Ok(points)
}

fn sample_fixed<C: Curve + ?Sized>(curve: &C, n: usize) -> Result<Vec<(f64, Point)>, GenError> {
    let closed = curve.is_closed();
    let min = if closed { 3 } else { 2 };
    if n < min || n > MAX_POINTS {
        return Err(GenError::BadValue {
            kind: curve.name().to_string(),
            param: "points".to_string(),
            value: n.to_string(),
            problem: format!("needs between {min} and {MAX_POINTS} points"),
        });
    }
    let (t0, t1) = curve.domain();
    let segments = if closed { n } else { n - 1 };
    let out = (0..=segments)
        .map(|i| {
            let t = if i == segments { t1 } else { lerp(t0, t1, ratio(i, segments)) };
            (t, curve.point(t))
        })
        .collect();
    Ok(out)
}

fn sample_adaptive<C: Curve + ?Sized>(curve: &C, tolerance: f64) -> Result<Vec<(f64, Point)>, GenError> {
    if !(tolerance.is_finite() && tolerance >= MIN_TOLERANCE_MM) {
        return Err(GenError::BadValue {
            kind: curve.name().to_string(),
            param: "tol".to_string(),
            value: tolerance.to_string(),
            problem: format!("chord tolerance must be a number ≥ {MIN_TOLERANCE_MM} mm"),
        });
    }
    let (t0, t1) = curve.domain();
    let n0 = curve.min_segments().clamp(1, MAX_POINTS);
    let mut knots: Vec<f64> = (1..n0).map(|i| lerp(t0, t1, ratio(i, n0))).collect();
    knots.extend(curve.breaks().into_iter().filter(|&t| t > t0 && t < t1));
    knots.push(t1);
    knots.sort_by(f64::total_cmp);
    knots.dedup();
    let mut refiner = Refiner { curve, limit: tolerance * PROBE_MARGIN, out: Vec::with_capacity(knots.len() * 4 + 1) };
    let mut a = t0;
    let mut pa = curve.point(t0);
    refiner.out.push((a, pa));
    for b in knots {
        let pb = curve.point(b);
        let pm = curve.point(0.5 * (a + b));
        refiner.refine(a, pa, b, pb, pm, 0);
        if refiner.out.len() > MAX_POINTS {
            return Err(GenError::TooManyPoints {
                kind: curve.name().to_string(),
                tolerance_mm: tolerance,
                limit: MAX_POINTS,
            });
        }
        a = b;
        pa = pb;
    }
    Ok(refiner.out)
}

struct Refiner<'a, C: ?Sized> {
    curve: &'a C,
    limit: f64,
    out: Vec<(f64, Point)>,
}

impl<C: Curve + ?Sized> Refiner<'_, C> {
    /// Emit points for `(a, b]`, given the curve at `a`, `b` and the midpoint.
    fn refine(&mut self, a: f64, pa: Point, b: f64, pb: Point, pm: Point, depth: u32) {
        if self.out.len() > MAX_POINTS {
            return;
        }
        let m = 0.5 * (a + b);
        let q1 = self.curve.point(0.5 * (a + m));
        let q3 = self.curve.point(0.5 * (m + b));
        let chord = Line::new(pa, pb);
        let err = [q1, pm, q3].iter().map(|&q| distance_to_segment(chord, q)).fold(0.0, f64::max);
        let probes = [pa, q1, pm, q3, pb];
        let short = probes.windows(2).map(|w| w[0].distance(w[1])).sum::<f64>() <= self.limit;
        // Confirm a flat-looking piece at the eighths too: a wiggle whose zeros sit near the quarter points would
        // slip past the first three probes.
        let flat = !short
            && err <= self.limit
            && turning(&probes) <= MAX_TURNING
            && [1.0, 3.0, 5.0, 7.0]
                .iter()
                .all(|&k| distance_to_segment(chord, self.curve.point(a + (b - a) * k / 8.0)) <= self.limit);
        // A NaN error is accepted too (no use splitting); `sample_with_params` then reports it as non-finite.
        if flat || short || err.is_nan() || depth >= MAX_DEPTH {
            self.out.push((b, pb));
        } else {
            self.refine(a, pa, m, pm, q1, depth + 1);
            self.refine(m, pm, b, pb, q3, depth + 1);
        }
    }
}

/// Total absolute turning angle (radians) of the polyline through `pts`, skipping zero-length pieces.
fn turning(pts: &[Point]) -> f64 {
    let dirs: Vec<kurbo::Vec2> = pts.windows(2).map(|w| w[1] - w[0]).filter(|v| v.hypot2() > 0.0).collect();
    dirs.windows(2).map(|w| w[0].cross(w[1]).atan2(w[0].dot(w[1])).abs()).sum()
}

/// Distance from `p` to the segment `line` (to its nearest point, endpoints included).
pub fn distance_to_segment(line: Line, p: Point) -> f64 {
    if line.p0 == line.p1 {
        return p.distance(line.p0);
    }
    line.nearest(p, 0.0).distance_sq.sqrt()
}

fn lerp(a: f64, b: f64, s: f64) -> f64 {
    a + (b - a) * s
}

/// `i / n` for counts up to [`MAX_POINTS`].
fn ratio(i: usize, n: usize) -> f64 {
    // Both are ≤ MAX_POINTS < 2^53, so the conversions are exact.
    let (i, n) = (u32::try_from(i).unwrap_or(u32::MAX), u32::try_from(n).unwrap_or(u32::MAX));
    f64::from(i) / f64::from(n)
}

/// Largest distance of the curve from the chord of each segment of its adaptive sampling at `tolerance`, probing each
/// segment's parameter interval at 64 points (the check behind the chord-tolerance property tests).
#[cfg(test)]
pub(crate) fn worst_chord_error(curve: &dyn Curve, tolerance: f64) -> f64 {
    let pts = sample_with_params(curve, Sampling::Adaptive(tolerance)).unwrap();
    let mut worst: f64 = 0.0;
    for w in pts.windows(2) {
        let chord = Line::new(w[0].1, w[1].1);
        for j in 1..64 {
            let t = w[0].0 + (w[1].0 - w[0].0) * f64::from(j) / 64.0;
            worst = worst.max(distance_to_segment(chord, curve.point(t)));
        }
    }
    worst
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use std::f64::consts::TAU;

    /// A sum of circular motions, the most general closed curve the generators produce.
    struct Wheels(Vec<(f64, i32, f64)>); // (radius, frequency, phase)

    impl Curve for Wheels {
        fn name(&self) -> &'static str {
            "wheels"
        }
        fn point(&self, t: f64) -> Point {
            let (mut x, mut y) = (0.0, 0.0);
            for &(r, f, ph) in &self.0 {
                let a = f64::from(f) * t + ph;
                x += r * a.cos();
                y += r * a.sin();
            }
            Point::new(x, y)
        }
        fn domain(&self) -> (f64, f64) {
            (0.0, TAU)
        }
        fn is_closed(&self) -> bool {
            true
        }
        fn min_segments(&self) -> usize {
            // Eight per cycle of the fastest relative rotation (the spread of the frequencies, or the fastest one).
            let hi = self.0.iter().map(|w| w.1).max().unwrap_or(0);
            let lo = self.0.iter().map(|w| w.1).min().unwrap_or(0);
            let spread = (hi - lo).unsigned_abs().max(hi.unsigned_abs()).max(lo.unsigned_abs()).max(1);
            8 * usize::try_from(spread).unwrap()
        }
    }

    #[test]
    fn fixed_count_closed_and_open() {
        let c = Wheels(vec![(10.0, 1, 0.0)]);
        let p = sample(&c, Sampling::Fixed(1000)).unwrap();
        assert_eq!(p.points.len(), 1001);
        assert!(p.is_closed());
        assert!((p.points[250].x - 0.0).abs() < 1e-12 && (p.points[250].y - 10.0).abs() < 1e-12);
        assert!(matches!(sample(&c, Sampling::Fixed(2)), Err(GenError::BadValue { .. })));
    }

    #[test]
    fn rejects_bad_tolerance() {
        let c = Wheels(vec![(10.0, 1, 0.0)]);
        for tol in [0.0, -1.0, f64::NAN, 1e-9] {
            let e = sample(&c, Sampling::Adaptive(tol)).unwrap_err();
            assert!(e.to_string().contains("tol"), "{e}");
        }
    }

    #[test]
    fn circle_point_count_follows_sagitta() {
        // A circle of radius r sampled to tolerance e needs about π / acos(1 - e/r) chords.
        let r = 50.0;
        let tol = 0.01;
        let c = Wheels(vec![(r, 1, 0.0)]);
        let p = sample(&c, Sampling::Adaptive(tol)).unwrap();
        let ideal = std::f64::consts::PI / (1.0 - tol / r).acos();
        let n = p.segment_count() as f64;
        assert!(n >= ideal * 0.95 && n <= ideal * 2.0, "{n} segments vs ideal {ideal}");
        assert!(worst_chord_error(&c, tol) <= tol);
    }

    #[test]
    fn tiny_tolerance_hits_point_limit_or_succeeds() {
        let c = Wheels(vec![(1.0e6, 1, 0.0)]);
        let e = sample(&c, Sampling::Adaptive(MIN_TOLERANCE_MM)).unwrap_err();
        assert!(matches!(e, GenError::TooManyPoints { .. }), "{e}");
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(512))]
        #[test]
        fn adaptive_meets_chord_tolerance(
            wheels in prop::collection::vec((0.5f64..80.0, -9i32..=9, 0.0f64..TAU), 1..5),
            tol in 0.002f64..0.5,
        ) {
            let c = Wheels(wheels);
            let worst = worst_chord_error(&c, tol);
            prop_assert!(worst <= tol, "worst chord error {} > tolerance {}", worst, tol);
        }
    }
}
