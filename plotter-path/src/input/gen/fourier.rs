//! Fourier series of closed outlines: fit N harmonics, evaluate anywhere, and show the result as epicycles.
//!
//! A closed outline is read as a complex function `z(s) = x(s) + i·y(s)` of its normalised arc length
//! `s ∈ [0, 1)`. Fitting resamples the outline at `M` points equally spaced along its length and takes the discrete
//! Fourier transform `c_k = (1/M) Σ_j z_j e^{−2πi·kj/M}` for `k = −N … N`; the fitted curve is
//! `z(s) = Σ_k c_k e^{2πi·ks}`. When `M ≥ 2N + 1` and the samples come from a trigonometric polynomial of degree
//! ≤ N, the transform returns its coefficients exactly (the exponentials are orthogonal on the M-point grid and no
//! other frequency aliases onto `−N … N`), so such a curve is reproduced to rounding error; otherwise the fit is the
//! trigonometric interpolant's truncation, whose error falls as N grows. With `M < 2N + 1` the higher
//! coefficients would only be aliases of lower ones, so that is refused.
//!
//! Each term `c_k e^{2πi·ks}` is a circle of radius `|c_k|` turning `k` times per traversal; chaining them, largest
//! first, draws the curve with the last circle's rim — the "epicycles" view.
//!
//! The transform is the direct O(M·N) sum with a table of the M roots of unity (indexed by `k·j mod M`, so no angle
//! grows large and loses precision); for the sizes used here (N ≤ a few hundred) it is faster than setting up an FFT.

use std::f64::consts::TAU;

use kurbo::{Point, Vec2};

use super::GenError;
use super::sampler::Curve;
use crate::Polyline;

/// One term `c·e^{2πi·freq·s}` of a Fourier series; the complex coefficient is stored as a vector (re, im) in mm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Term {
    /// Turns per traversal (negative: clockwise).
    pub freq: i64,
    /// Complex coefficient `c_k` as (re, im), mm.
    pub coeff: Vec2,
}

/// One circle of the epicycle chain at a given instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Epicycle {
    /// Centre of the circle (the tip of the previous arm).
    pub centre: Point,
    /// Radius `|c_k|`, mm.
    pub radius: f64,
    /// Where this circle's arm points at the instant (the next circle's centre).
    pub tip: Point,
}

/// A truncated complex Fourier series describing a closed curve, parameter `s ∈ [0, 1]`.
#[derive(Debug, Clone, PartialEq)]
pub struct FourierSeries {
    /// Terms in the order 0, 1, −1, 2, −2, …, N, −N.
    terms: Vec<Term>,
    /// The highest |frequency|.
    harmonics: usize,
}

/// Up to this many harmonics, [`FourierSeries::eval`] builds a table of powers; beyond, it evaluates each term's
/// exponential directly (sparse series with a few very high frequencies).
const POWER_TABLE_LIMIT: usize = 1 << 16;

/// Complex product of (re, im) pairs.
fn cmul(a: Vec2, b: Vec2) -> Vec2 {
    Vec2::new(a.x * b.x - a.y * b.y, a.x * b.y + a.y * b.x)
}

impl FourierSeries {
    /// A series from explicit terms (any order, each frequency at most once is the caller's business).
    pub fn from_terms(terms: Vec<Term>) -> Self {
        let harmonics =
            terms.iter().map(|t| usize::try_from(t.freq.unsigned_abs()).unwrap_or(usize::MAX)).max().unwrap_or(0);
        FourierSeries { terms, harmonics }
    }

    /// Fit `harmonics` harmonics to `samples`, taken as equally spaced parameter values over one period of a closed
    /// curve (the first point not repeated at the end).
    ///
    /// # Errors
    /// [`GenError::TooManyHarmonics`] when `2·harmonics + 1 > samples.len()`.
    pub fn fit_samples(samples: &[Point], harmonics: usize) -> Result<Self, GenError> {
        let m = samples.len();
        if harmonics.checked_mul(2).and_then(|v| v.checked_add(1)).is_none_or(|need| need > m) {
            return Err(GenError::TooManyHarmonics { harmonics, samples: m });
        }
        // roots[j] = e^{−2πi·j/M}.
        let roots: Vec<Vec2> = (0..m)
            .map(|j| {
                let a = -TAU * index_ratio(j, m);
                Vec2::new(a.cos(), a.sin())
            })
            .collect();
        let inv_m = 1.0 / index_ratio(m, 1);
        let coefficient = |k: usize, negative: bool| {
            // Frequency −k is the same as M − k modulo M.
            let step = if negative { m - k } else { k };
            let mut acc = Vec2::ZERO;
            let mut idx = 0usize;
            for z in samples {
                acc += cmul(z.to_vec2(), roots[idx]);
                idx += step;
                if idx >= m {
                    idx -= m;
                }
            }
            acc * inv_m
        };
        let mut terms = Vec::with_capacity(2 * harmonics + 1);
        terms.push(Term { freq: 0, coeff: coefficient(0, false) });
        for k in 1..=harmonics {
            let f = i64::try_from(k).unwrap_or(i64::MAX);
            terms.push(Term { freq: f, coeff: coefficient(k, false) });
            terms.push(Term { freq: -f, coeff: coefficient(k, true) });
        }
        Ok(FourierSeries { terms, harmonics })
    }

    /// Fit `harmonics` harmonics to a closed polyline, resampled at `samples` points equally spaced along its
    /// length, starting at its first vertex.
    ///
    /// # Errors
    /// [`GenError::BadOutline`] if the polyline is not closed or has zero length; [`GenError::TooManyHarmonics`]
    /// when `2·harmonics + 1 > samples`.
    pub fn fit_outline(outline: &Polyline, harmonics: usize, samples: usize) -> Result<Self, GenError> {
        let resampled = resample_closed(outline, samples)?;
        Self::fit_samples(&resampled, harmonics)
    }

    /// The highest harmonic N.
    pub fn harmonics(&self) -> usize {
        self.harmonics
    }

    /// The terms (for a fit: 0, 1, −1, 2, −2, …).
    pub fn terms(&self) -> &[Term] {
        &self.terms
    }

    /// The curve at parameter `s` (period 1).
    ///
    /// The powers `e^{2πi·ks}` are built by repeated multiplication with `e^{2πis}` (one sine and cosine per call
    /// rather than one per term); the rounding error grows with `k·ε`, far below a nanometre for any usable N.
    pub fn eval(&self, s: f64) -> Point {
        let n = self.harmonics;
        if n > POWER_TABLE_LIMIT {
            return self.terms.iter().map(|t| cmul(t.coeff, unit(t.freq, s))).sum::<Vec2>().to_point();
        }
        let base = unit(1, s);
        let mut powers = Vec::with_capacity(n + 1);
        let mut p = Vec2::new(1.0, 0.0);
        for _ in 0..=n {
            powers.push(p);
            p = cmul(p, base);
        }
        let mut acc = Vec2::ZERO;
        for t in &self.terms {
            let w = powers[usize::try_from(t.freq.unsigned_abs()).unwrap_or(0)];
            let w = if t.freq < 0 { Vec2::new(w.x, -w.y) } else { w };
            acc += cmul(t.coeff, w);
        }
        acc.to_point()
    }

    /// The epicycle chain at parameter `s`: the constant term places the first centre, then one circle per other
    /// term, largest radius first. The last circle's tip is [`FourierSeries::eval`]`(s)`.
    pub fn epicycles(&self, s: f64) -> Vec<Epicycle> {
        let mut order: Vec<&Term> = self.terms.iter().filter(|t| t.freq != 0).collect();
        order.sort_by(|a, b| b.coeff.hypot().total_cmp(&a.coeff.hypot()));
        let mut at = self.terms.iter().filter(|t| t.freq == 0).map(|t| t.coeff).sum::<Vec2>().to_point();
        order
            .into_iter()
            .map(|t| {
                let tip = at + cmul(t.coeff, unit(t.freq, s));
                let e = Epicycle { centre: at, radius: t.coeff.hypot(), tip };
                at = tip;
                e
            })
            .collect()
    }
}

/// `e^{2πi·freq·s}`, with the angle reduced to one turn before scaling so large `freq·s` keeps its precision.
fn unit(freq: i64, s: f64) -> Vec2 {
    #[allow(clippy::cast_precision_loss)] // harmonic numbers are small
    let turns = (freq as f64 * s).rem_euclid(1.0);
    let a = TAU * turns;
    Vec2::new(a.cos(), a.sin())
}

/// `i / n` as f64 for in-memory counts.
fn index_ratio(i: usize, n: usize) -> f64 {
    #[allow(clippy::cast_precision_loss)] // counts of in-memory samples are far below 2^53
    let r = i as f64 / n as f64;
    r
}

/// `samples` points equally spaced along a closed polyline's length, starting at its first vertex (the first point
/// is not repeated at the end).
///
/// # Errors
/// [`GenError::BadOutline`] when the polyline is not closed, has zero length or `samples` is 0.
pub fn resample_closed(outline: &Polyline, samples: usize) -> Result<Vec<Point>, GenError> {
    let bad = |problem: &str| GenError::BadOutline { what: "the outline".to_string(), problem: problem.to_string() };
    if !outline.is_closed() {
        return Err(bad("it is not a closed path (its first and last points differ)"));
    }
    let pts = &outline.points;
    let total = outline.length();
    if !(total > 0.0 && total.is_finite()) {
        return Err(bad("it has no length"));
    }
    if samples == 0 {
        return Err(bad("zero samples asked for"));
    }
    let mut out = Vec::with_capacity(samples);
    let mut seg = 0;
    let mut seg_start = 0.0;
    let mut seg_len = pts[0].distance(pts[1]);
    for j in 0..samples {
        let s = total * index_ratio(j, samples);
        while seg + 2 < pts.len() && seg_start + seg_len < s {
            seg_start += seg_len;
            seg += 1;
            seg_len = pts[seg].distance(pts[seg + 1]);
        }
        let u = if seg_len > 0.0 { ((s - seg_start) / seg_len).clamp(0.0, 1.0) } else { 0.0 };
        out.push(pts[seg].lerp(pts[seg + 1], u));
    }
    Ok(out)
}

impl Curve for FourierSeries {
    fn name(&self) -> &'static str {
        "fourier"
    }

    fn point(&self, s: f64) -> Point {
        self.eval(s)
    }

    fn domain(&self) -> (f64, f64) {
        (0.0, 1.0)
    }

    fn is_closed(&self) -> bool {
        true
    }

    fn min_segments(&self) -> usize {
        // Terms turn from −N to N times: eight intervals per cycle of the widest difference, 2N.
        self.harmonics().max(1).saturating_mul(16)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::r#gen::hausdorff::hausdorff;
    use crate::input::r#gen::mickey::MickeyOutline;
    use crate::input::r#gen::sampler::{Sampling, sample};
    use proptest::prelude::*;

    fn random_series(coeffs: &[(f64, f64)]) -> FourierSeries {
        // coeffs[0] is c_0, then c_1, c_−1, c_2, c_−2, ...
        let terms = coeffs
            .iter()
            .enumerate()
            .map(|(i, &(re, im))| {
                let k = i64::try_from(i.div_ceil(2)).unwrap();
                Term { freq: if i % 2 == 0 { -k } else { k }, coeff: Vec2::new(re, im) }
            })
            .collect();
        FourierSeries::from_terms(terms)
    }

    #[test]
    fn circle_has_one_harmonic() {
        // z(s) = 10 + 5i + 20 e^{2πis}: uniform samples give exactly c_0 = 10 + 5i, c_1 = 20, nothing else.
        let pts: Vec<Point> = (0..16)
            .map(|j| {
                let a = TAU * f64::from(j) / 16.0;
                Point::new(10.0 + 20.0 * a.cos(), 5.0 + 20.0 * a.sin())
            })
            .collect();
        let f = FourierSeries::fit_samples(&pts, 3).unwrap();
        assert_eq!(f.terms().len(), 7);
        assert!((f.terms()[0].coeff - Vec2::new(10.0, 5.0)).hypot() < 1e-12);
        assert!((f.terms()[1].coeff - Vec2::new(20.0, 0.0)).hypot() < 1e-12);
        assert!(f.terms()[2..].iter().all(|t| t.coeff.hypot() < 1e-12));
        assert!(f.eval(0.25).distance(Point::new(10.0, 25.0)) < 1e-12);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]
        /// A trigonometric polynomial of degree ≤ N, sampled on M ≥ 2N + 1 points, is reproduced to 1e-9 mm.
        #[test]
        fn reproduces_trig_polynomials(
            coeffs in prop::collection::vec((-50.0f64..50.0, -50.0f64..50.0), 1..40),
            extra_harmonics in 0usize..6,
            extra_samples in 0usize..200,
            probe in 0.0f64..1.0,
        ) {
            let truth = random_series(&coeffs);
            let degree = truth.harmonics();
            let n = degree + extra_harmonics;
            let m = 2 * n + 1 + extra_samples;
            let pts: Vec<Point> = (0..m).map(|j| truth.eval(index_ratio(j, m))).collect();
            let fit = FourierSeries::fit_samples(&pts, n).unwrap();
            for t in fit.terms() {
                let want = truth.terms().iter().find(|u| u.freq == t.freq).map_or(Vec2::ZERO, |u| u.coeff);
                prop_assert!((t.coeff - want).hypot() < 1e-9, "freq {}: {:?} vs {:?}", t.freq, t.coeff, want);
            }
            for s in [probe, 0.0, 0.5, probe * 0.37] {
                prop_assert!(fit.eval(s).distance(truth.eval(s)) < 1e-9);
            }
            // The epicycle chain ends on the curve.
            let chain = fit.epicycles(probe);
            prop_assert!(chain.last().map_or(fit.eval(probe), |e| e.tip).distance(fit.eval(probe)) < 1e-9);
        }
    }

    #[test]
    fn power_table_matches_direct_terms() {
        // 300 harmonics through the power table, and a sparse series past the table limit, against the per-term
        // exponentials.
        let dense: Vec<Term> = (-300..=300)
            .map(|k: i64| Term { freq: k, coeff: Vec2::new((k as f64 * 0.7).sin(), (k as f64 * 1.3).cos()) })
            .collect();
        let sparse = vec![
            Term { freq: 0, coeff: Vec2::new(1.0, 2.0) },
            Term { freq: 100_000, coeff: Vec2::new(3.0, -1.0) },
            Term { freq: -250_000, coeff: Vec2::new(0.5, 0.25) },
        ];
        for terms in [dense, sparse] {
            let f = FourierSeries::from_terms(terms.clone());
            for s in [0.0, 0.123, 0.5, 0.999] {
                let direct: Vec2 = terms.iter().map(|t| cmul(t.coeff, unit(t.freq, s))).sum();
                assert!(f.eval(s).distance(direct.to_point()) < 1e-9, "s = {s}");
            }
        }
    }

    #[test]
    fn too_many_harmonics_is_an_error() {
        let pts: Vec<Point> = (0..64).map(|j| Point::new(f64::from(j).cos(), f64::from(j).sin())).collect();
        assert!(FourierSeries::fit_samples(&pts, 31).is_ok());
        let e = FourierSeries::fit_samples(&pts, 32).unwrap_err();
        assert_eq!(e, GenError::TooManyHarmonics { harmonics: 32, samples: 64 });
        assert_eq!(e.to_string(), "32 harmonics need at least 65 samples of the outline, but only 64 were asked for");
        assert!(FourierSeries::fit_samples(&pts, usize::MAX).is_err());
    }

    #[test]
    fn bad_outlines_are_errors() {
        let open = Polyline::new(vec![Point::ORIGIN, Point::new(1.0, 0.0), Point::new(1.0, 1.0)]);
        let e = FourierSeries::fit_outline(&open, 4, 100).unwrap_err();
        assert!(e.to_string().contains("not a closed path"), "{e}");
        let dot = Polyline::new(vec![Point::ORIGIN; 4]);
        assert!(FourierSeries::fit_outline(&dot, 4, 100).unwrap_err().to_string().contains("no length"));
    }

    #[test]
    fn resampling_is_equally_spaced() {
        // A 10 × 30 rectangle (length 80) at 16 samples: every 5 mm along the edges.
        let rect = Polyline::new(vec![
            Point::ORIGIN,
            Point::new(10.0, 0.0),
            Point::new(10.0, 30.0),
            Point::new(0.0, 30.0),
            Point::ORIGIN,
        ]);
        let pts = resample_closed(&rect, 16).unwrap();
        assert_eq!(pts.len(), 16);
        assert_eq!(pts[0], Point::ORIGIN);
        assert!(pts[1].distance(Point::new(5.0, 0.0)) < 1e-12);
        assert!(pts[3].distance(Point::new(10.0, 5.0)) < 1e-12);
        assert!(pts[10].distance(Point::new(0.0, 30.0)) < 1e-12);
        assert!(pts[15].distance(Point::new(0.0, 5.0)) < 1e-12);
    }

    /// Hausdorff error (mm) of the N-harmonic Mickey (head radius 40 mm) against the exact outline.
    fn mickey_error(n: usize) -> f64 {
        let m = MickeyOutline::new(40.0).unwrap();
        let exact = sample(&m, Sampling::Adaptive(1e-4)).unwrap();
        let fit = FourierSeries::fit_outline(&exact, n, 4096).unwrap();
        let recon = sample(&fit, Sampling::Adaptive(1e-4)).unwrap();
        hausdorff(&recon.points, &exact.points)
    }

    /// The table the issue asks for; run with `--nocapture` to see it.
    #[test]
    fn mickey_error_falls_with_harmonics() {
        println!("Mickey outline, head radius 40 mm (124 × 106 mm), 4096 arc-length samples");
        println!("{:>4}  {:>14}", "N", "Hausdorff (mm)");
        let mut last = f64::INFINITY;
        for n in [4, 8, 16, 32, 64] {
            let e = mickey_error(n);
            println!("{n:>4}  {e:>14.4}");
            assert!(e < last, "error did not fall at N = {n}: {e} ≥ {last}");
            last = e;
        }
        assert!(last < 1.0, "64 harmonics should be within a millimetre: {last}");
        // The seed's configuration: 1000 arc-length samples, evaluated on 1000 points.
        let m = MickeyOutline::new(40.0).unwrap();
        let exact = sample(&m, Sampling::Adaptive(1e-4)).unwrap();
        let fit = FourierSeries::fit_outline(&exact, 32, 1000).unwrap();
        let seed = hausdorff(&sample(&fit, Sampling::Fixed(1000)).unwrap().points, &exact.points);
        println!("N = 32 with 1000 samples on 1000 points (the `mickey` default): {seed:.4} mm");
        assert!((seed - mickey_error(32)).abs() < 0.05, "{seed}");
    }
}
