//! Archimedean spiral: the radius grows linearly with the angle, `ρ(θ) = r0 + (r1 − r0)·θ / (2π·turns)` for
//! `θ ∈ [0, 2π·turns]`, so successive turns are evenly spaced `(r1 − r0) / turns` apart — the spacing a plotter
//! needs for even hatching.

use std::f64::consts::TAU;

use kurbo::Point;

use super::sampler::Curve;
use super::{GenError, positive};

/// Largest accepted number of turns.
pub const MAX_TURNS: f64 = 100_000.0;

/// An Archimedean spiral centred on the origin, from radius `r0` out (or in) to `r1`, counter-clockwise.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spiral {
    /// Start radius, mm (≥ 0).
    pub r0: f64,
    /// End radius, mm (> 0).
    pub r1: f64,
    /// Number of turns (> 0, may be fractional).
    pub turns: f64,
}

impl Spiral {
    /// A spiral from `r0` to `r1` mm over `turns` turns.
    ///
    /// # Errors
    /// [`GenError::BadValue`] if `r0` is negative, `r1` not positive, they are equal (a circle, not a spiral), or
    /// `turns` is not in `(0, MAX_TURNS]`.
    pub fn new(r0: f64, r1: f64, turns: f64) -> Result<Self, GenError> {
        let bad = |param: &str, value: f64, problem: &str| GenError::BadValue {
            kind: "spiral".to_string(),
            param: param.to_string(),
            value: value.to_string(),
            problem: problem.to_string(),
        };
        if !(r0.is_finite() && r0 >= 0.0) {
            return Err(bad("r0", r0, "must be a radius ≥ 0 mm"));
        }
        let r1 = positive("spiral", "r1", r1)?;
        if r0 == r1 {
            return Err(bad("r1", r1, "equals r0: that is a circle, not a spiral"));
        }
        if !(turns > 0.0 && turns <= MAX_TURNS) {
            return Err(bad("turns", turns, "must be more than 0 and at most 100000"));
        }
        Ok(Spiral { r0, r1, turns })
    }
}

impl Curve for Spiral {
    fn name(&self) -> &'static str {
        "spiral"
    }

    fn point(&self, t: f64) -> Point {
        let rho = self.r0 + (self.r1 - self.r0) * t / (TAU * self.turns);
        Point::new(rho * t.cos(), rho * t.sin())
    }

    fn domain(&self) -> (f64, f64) {
        (0.0, TAU * self.turns)
    }

    fn is_closed(&self) -> bool {
        false
    }

    fn min_segments(&self) -> usize {
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)] // 8 ≤ value ≤ 8·MAX_TURNS + 1
        let n = (8.0 * self.turns).ceil().max(8.0) as usize;
        n
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::r#gen::sampler::{Sampling, sample};

    #[test]
    fn known_points_and_even_spacing() {
        let s = Spiral::new(5.0, 45.0, 4.0).unwrap();
        assert_eq!(s.point(0.0), Point::new(5.0, 0.0));
        let end = s.point(s.domain().1);
        assert!((end.x - 45.0).abs() < 1e-9 && end.y.abs() < 1e-9);
        // Crossings of the positive X axis every turn, 10 mm apart; a quarter turn in, ρ = 7.5 on the Y axis.
        for k in 0..=4 {
            let p = s.point(TAU * f64::from(k));
            assert!((p.x - (5.0 + 10.0 * f64::from(k))).abs() < 1e-9);
        }
        let p = s.point(TAU / 4.0);
        assert!(p.x.abs() < 1e-12 && (p.y - 7.5).abs() < 1e-12);
    }

    #[test]
    fn open_polyline_from_centre() {
        let s = Spiral::new(0.0, 30.0, 3.0).unwrap();
        let poly = sample(&s, Sampling::Adaptive(0.01)).unwrap();
        assert!(!poly.is_closed());
        assert_eq!(poly.start(), Some(Point::ORIGIN));
        // Arc length of ρ = bθ from 0 to Θ is (b/2)(Θ√(1+Θ²) + asinh Θ); the chords are a little shorter.
        let (b, big) = (30.0 / (3.0 * TAU), 3.0 * TAU);
        let exact = 0.5 * b * (big * (1.0 + big * big).sqrt() + big.asinh());
        assert!(poly.length() <= exact && exact - poly.length() < 1e-3 * exact, "{} vs {exact}", poly.length());
    }

    #[test]
    fn rejects_bad_parameters() {
        assert!(Spiral::new(-1.0, 10.0, 2.0).unwrap_err().to_string().contains("r0"));
        assert!(Spiral::new(0.0, 0.0, 2.0).unwrap_err().to_string().contains("r1"));
        assert!(Spiral::new(10.0, 10.0, 2.0).unwrap_err().to_string().contains("circle"));
        assert!(Spiral::new(0.0, 10.0, 0.0).unwrap_err().to_string().contains("turns"));
    }
}
