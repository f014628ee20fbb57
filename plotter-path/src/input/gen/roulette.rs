//! Roulettes of one circle rolling on another: epi- and hypocycloids, epi- and hypotrochoids (the spirograph).
//!
//! With the rolling circle's radius `r`, the ratio `q = R / r` of the fixed circle's radius to it, and the pen at
//! distance `d` from the rolling circle's centre (`d = r` for the cycloids, the pen on the rim), the seed plotter's
//! parametrisation is, for the rolling angle θ:
//!
//! ```text
//! epi:   x = r(q+1) cos θ − d cos((q+1)θ)     y = r(q+1) sin θ − d sin((q+1)θ)
//! hypo:  x = r(q−1) cos θ + d cos((q−1)θ)     y = r(q−1) sin θ − d sin((q−1)θ)
//! ```
//!
//! (the standard forms, e.g. in Lawrence's *Catalog of Special Plane Curves*, with `R = q r`). For `q = a/b` in
//! lowest terms both angles are whole turns again after θ = 2πb, so the curve closes after `b` turns; a cycloid then
//! has `a` cusps, at θ = 2πj/q, where the rolling point touches the fixed circle and its velocity vanishes.

use std::f64::consts::TAU;

use kurbo::Point;

use super::rational::Ratio;
use super::sampler::Curve;
use super::{GenError, positive};

/// Rolling outside (epi) or inside (hypo) the fixed circle.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Rolling {
    /// Outside the fixed circle: epicycloid / epitrochoid.
    Epi,
    /// Inside the fixed circle: hypocycloid / hypotrochoid.
    Hypo,
}

/// A closed roulette (see the module docs for the equations), centred on the fixed circle's centre.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Roulette {
    /// Rolling outside or inside.
    pub rolling: Rolling,
    /// Radius of the rolling circle, mm.
    pub r: f64,
    /// Fixed radius over rolling radius, a reduced fraction.
    pub q: Ratio,
    /// Pen distance from the rolling circle's centre, mm (`r` for a cycloid).
    pub d: f64,
}

impl Roulette {
    /// An epicycloid or hypocycloid (pen on the rim) with rolling radius `r` and ratio `q`.
    ///
    /// # Errors
    /// [`GenError::BadValue`] if `r` is not positive and finite, or a hypocycloid has `q = 1` (the curve
    /// degenerates to a point).
    pub fn cycloid(rolling: Rolling, r: f64, q: Ratio) -> Result<Self, GenError> {
        let kind = if rolling == Rolling::Epi { "epicycloid" } else { "hypocycloid" };
        let r = positive(kind, "r", r)?;
        Self::checked(Roulette { rolling, r, q, d: r })
    }

    /// An epitrochoid or hypotrochoid with rolling radius `r`, ratio `q` and pen offset `d`.
    ///
    /// # Errors
    /// [`GenError::BadValue`] if `r` or `d` is not positive and finite, or a hypotrochoid has `q = 1`.
    pub fn trochoid(rolling: Rolling, r: f64, q: Ratio, d: f64) -> Result<Self, GenError> {
        let kind = if rolling == Rolling::Epi { "epitrochoid" } else { "hypotrochoid" };
        let r = positive(kind, "r", r)?;
        let d = positive(kind, "d", d)?;
        Self::checked(Roulette { rolling, r, q, d })
    }

    fn checked(self) -> Result<Self, GenError> {
        if self.rolling == Rolling::Hypo && self.q.num == self.q.den {
            return Err(GenError::BadValue {
                kind: self.name().to_string(),
                param: "q".to_string(),
                value: "1".to_string(),
                problem: "a circle rolling inside an equal circle does not move; the curve is a single point"
                    .to_string(),
            });
        }
        Ok(self)
    }

    /// True when the pen sits on the rolling circle's rim (a cycloid).
    pub fn is_cycloid(&self) -> bool {
        self.d == self.r
    }

    /// Turns of the rolling angle until the curve closes (the reduced denominator of `q`).
    pub fn turns(&self) -> u64 {
        self.q.den
    }

    /// Rolling angles of the cusps over one period, for a cycloid (θ = 2πj/q, j = 0 … a−1 for q = a/b); empty for
    /// a trochoid, which has none (or loops instead).
    pub fn cusps(&self) -> Vec<f64> {
        if !self.is_cycloid() {
            return Vec::new();
        }
        #[allow(clippy::cast_precision_loss)] // ratios from user input, far below 2^53
        let (a, b) = (self.q.num as f64, self.q.den as f64);
        (0..self.q.num)
            .map(|j| {
                #[allow(clippy::cast_precision_loss)]
                let j = j as f64;
                TAU * j * b / a
            })
            .collect()
    }

    /// `q + 1` for epi, `q − 1` for hypo: the rolling circle's turning rate relative to θ.
    fn spin(&self) -> f64 {
        match self.rolling {
            Rolling::Epi => self.q.value() + 1.0,
            Rolling::Hypo => self.q.value() - 1.0,
        }
    }
}

impl Curve for Roulette {
    fn name(&self) -> &'static str {
        match (self.rolling, self.is_cycloid()) {
            (Rolling::Epi, true) => "epicycloid",
            (Rolling::Hypo, true) => "hypocycloid",
            (Rolling::Epi, false) => "epitrochoid",
            (Rolling::Hypo, false) => "hypotrochoid",
        }
    }

    fn point(&self, t: f64) -> Point {
        let k = self.spin();
        let big = self.r * k;
        match self.rolling {
            Rolling::Epi => Point::new(big * t.cos() - self.d * (k * t).cos(), big * t.sin() - self.d * (k * t).sin()),
            Rolling::Hypo => Point::new(big * t.cos() + self.d * (k * t).cos(), big * t.sin() - self.d * (k * t).sin()),
        }
    }

    fn domain(&self) -> (f64, f64) {
        #[allow(clippy::cast_precision_loss)] // turn counts are bounded by max_turns
        let turns = self.q.den as f64;
        (0.0, TAU * turns)
    }

    fn is_closed(&self) -> bool {
        true
    }

    fn min_segments(&self) -> usize {
        // Over b turns the two rotations make b and a + b (epi) or b and −(a − b) (hypo) turns; eight intervals per
        // turn of the faster one and of their difference (a for both), whichever is more.
        let (a, b) = (self.q.num, self.q.den);
        let cycles = match self.rolling {
            Rolling::Epi => a.saturating_add(b),
            Rolling::Hypo => a.max(b),
        };
        usize::try_from(cycles.saturating_mul(8)).unwrap_or(usize::MAX)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::r#gen::sampler::{Sampling, sample};
    use std::f64::consts::PI;

    fn q(a: u64, b: u64) -> Ratio {
        Ratio { num: a, den: b }
    }

    fn close(p: Point, x: f64, y: f64) -> bool {
        (p.x - x).abs() < 1e-9 && (p.y - y).abs() < 1e-9
    }

    #[test]
    fn epicycloid_known_points() {
        // q = 3, r = 10: cusp at θ = 0 on the fixed circle R = 30; midway between cusps (θ = π/3) the point is
        // farthest out, at R + 2r = 50: (10(4·½ + ½), 10(4·√3/2 + √3/2)) = (25, 25√3).
        let c = Roulette::cycloid(Rolling::Epi, 10.0, q(3, 1)).unwrap();
        assert!(close(c.point(0.0), 30.0, 0.0));
        assert!(close(c.point(PI / 3.0), 25.0, 25.0 * 3f64.sqrt()));
        // Cardioid (q = 1): θ = π gives x = r(2 cos π − cos 2π) = −3r.
        let card = Roulette::cycloid(Rolling::Epi, 10.0, q(1, 1)).unwrap();
        assert!(close(card.point(PI), -30.0, 0.0));
    }

    #[test]
    fn hypocycloid_q4_is_the_astroid() {
        // r(3cos θ + cos 3θ) = 4r cos³θ and r(3 sin θ − sin 3θ) = 4r sin³θ.
        let c = Roulette::cycloid(Rolling::Hypo, 10.0, q(4, 1)).unwrap();
        for i in 0..100 {
            let t = f64::from(i) * 0.1;
            assert!(close(c.point(t), 40.0 * t.cos().powi(3), 40.0 * t.sin().powi(3)), "θ = {t}");
        }
    }

    #[test]
    fn trochoid_known_points() {
        // Hypotrochoid with q = 2 is an ellipse: x = (r + d) cos θ, y = (r − d) sin θ.
        let h = Roulette::trochoid(Rolling::Hypo, 10.0, q(2, 1), 4.0).unwrap();
        for i in 0..50 {
            let t = f64::from(i) * 0.13;
            assert!(close(h.point(t), 14.0 * t.cos(), 6.0 * t.sin()));
        }
        // Epitrochoid with q = 1 is a limaçon: x = 2r cos θ − d cos 2θ; at θ = π, x = −2r − d.
        let e = Roulette::trochoid(Rolling::Epi, 10.0, q(1, 1), 5.0).unwrap();
        assert!(close(e.point(PI), -25.0, 0.0));
        assert!(close(e.point(PI / 2.0), 5.0, 20.0));
    }

    #[test]
    fn closes_for_rational_q() {
        for (a, b) in [(3, 1), (4, 1), (5, 2), (7, 3), (2, 5), (13, 8), (1, 1), (11, 7)] {
            for rolling in [Rolling::Epi, Rolling::Hypo] {
                if rolling == Rolling::Hypo && a == b {
                    continue;
                }
                for c in [
                    Roulette::cycloid(rolling, 7.5, q(a, b)).unwrap(),
                    Roulette::trochoid(rolling, 7.5, q(a, b), 11.0).unwrap(),
                ] {
                    let (t0, t1) = c.domain();
                    let gap = c.point(t1).distance(c.point(t0));
                    assert!(gap < 1e-9, "{} q = {a}/{b}: gap {gap}", c.name());
                    // ... and not before: half-way through, the curve is elsewhere for b > 1.
                    if b > 1 {
                        assert!(c.point(TAU).distance(c.point(t0)) > 1e-3);
                    }
                    let poly = sample(&c, Sampling::default()).unwrap();
                    assert!(poly.is_closed());
                }
            }
        }
    }

    /// Vertices where the polyline turns back by more than 120°.
    fn reversals(points: &[Point]) -> usize {
        let n = points.len() - 1; // closed: last == first
        (0..n)
            .filter(|&i| {
                let prev = points[(i + n - 1) % n];
                let (p, next) = (points[i], points[i + 1]);
                let (u, v) = (p - prev, next - p);
                let cos = u.dot(v) / (u.hypot() * v.hypot());
                cos < (2.0 * PI / 3.0).cos()
            })
            .count()
    }

    #[test]
    fn cusp_count_matches_numerator() {
        for (a, b) in [(3, 1), (4, 1), (5, 1), (5, 2), (7, 3), (6, 1)] {
            for rolling in [Rolling::Epi, Rolling::Hypo] {
                let c = Roulette::cycloid(rolling, 10.0, q(a, b)).unwrap();
                let cusps = c.cusps();
                assert_eq!(cusps.len(), usize::try_from(a).unwrap());
                let fixed_radius = 10.0 * c.q.value();
                for &t in &cusps {
                    // A cusp lies on the fixed circle and the velocity vanishes there.
                    assert!((c.point(t).to_vec2().hypot() - fixed_radius).abs() < 1e-9);
                    let v = (c.point(t + 1e-6) - c.point(t - 1e-6)).hypot() / 2e-6;
                    assert!(v < 1e-4, "speed {v} at cusp");
                }
                // Geometrically: a fixed sampling with a vertex on each cusp reverses direction exactly there.
                let n = usize::try_from(a * 240).unwrap();
                let poly = sample(&c, Sampling::Fixed(n)).unwrap();
                assert_eq!(reversals(&poly.points), cusps.len(), "{} q = {a}/{b}", c.name());
            }
        }
        // A trochoid has none.
        assert!(Roulette::trochoid(Rolling::Epi, 10.0, q(3, 1), 4.0).unwrap().cusps().is_empty());
    }

    #[test]
    fn rejects_bad_parameters() {
        let e = Roulette::cycloid(Rolling::Epi, 0.0, q(3, 1)).unwrap_err();
        assert_eq!(e.to_string(), "epicycloid: parameter r=\"0\": must be a positive number of millimetres");
        let e = Roulette::trochoid(Rolling::Hypo, 5.0, q(3, 1), -2.0).unwrap_err();
        assert!(e.to_string().starts_with("hypotrochoid: parameter d="), "{e}");
        let e = Roulette::cycloid(Rolling::Hypo, 5.0, q(2, 2)).unwrap_err();
        assert!(e.to_string().contains("single point"), "{e}");
    }
}
