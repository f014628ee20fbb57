//! Rose curves (rhodonea): in polar form `ρ(θ) = a cos(kθ)`, i.e. `x = a cos(kθ) cos θ`, `y = a cos(kθ) sin θ`.
//!
//! For `k = n/d` in lowest terms the curve repeats after θ = πd when `n·d` is odd and after 2πd otherwise; it then
//! has `n` petals (odd `n·d`) or `2n` petals (even `n·d`), each petal tip at distance `a` from the centre, where
//! `kθ` is a whole multiple of π.

use std::f64::consts::PI;

use kurbo::Point;

use super::rational::Ratio;
use super::sampler::Curve;
use super::{GenError, positive};

/// A rose curve centred on the origin.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rose {
    /// Petal length (the polar amplitude), mm.
    pub a: f64,
    /// Angular frequency `k = n/d`, reduced.
    pub k: Ratio,
}

impl Rose {
    /// A rose with petal length `a` mm and frequency `k`.
    ///
    /// # Errors
    /// [`GenError::BadValue`] unless `a` is positive and finite.
    pub fn new(a: f64, k: Ratio) -> Result<Self, GenError> {
        Ok(Rose { a: positive("rose", "a", a)?, k })
    }

    /// True when `n·d` is odd (the curve repeats after half the angle).
    fn odd(&self) -> bool {
        self.k.num % 2 == 1 && self.k.den % 2 == 1
    }

    /// Number of petals: `n` when `n·d` is odd, `2n` otherwise.
    pub fn petals(&self) -> u64 {
        if self.odd() { self.k.num } else { self.k.num.saturating_mul(2) }
    }

    /// Half-turns of θ until the curve closes (`d` or `2d`).
    fn half_turns(&self) -> u64 {
        if self.odd() { self.k.den } else { self.k.den.saturating_mul(2) }
    }
}

impl Curve for Rose {
    fn name(&self) -> &'static str {
        "rose"
    }

    fn point(&self, t: f64) -> Point {
        let rho = self.a * (self.k.value() * t).cos();
        Point::new(rho * t.cos(), rho * t.sin())
    }

    fn domain(&self) -> (f64, f64) {
        #[allow(clippy::cast_precision_loss)] // bounded by max_turns
        let half_turns = self.half_turns() as f64;
        (0.0, PI * half_turns)
    }

    fn is_closed(&self) -> bool {
        true
    }

    fn min_segments(&self) -> usize {
        // cos(kθ)·e^{iθ} = ½e^{i(k+1)θ} + ½e^{−i(k−1)θ}: the faster rotation has frequency k + 1, their difference
        // 2k. Over the domain (half_turns·π) that is (n + d)·h/(2d) and n·h/d cycles; eight intervals per cycle.
        let h = self.half_turns();
        let (n, d) = (self.k.num, self.k.den);
        let fast_x8 = n.saturating_add(d).saturating_mul(h).saturating_mul(4).div_ceil(d);
        let spread_x8 = n.saturating_mul(h).saturating_mul(8).div_ceil(d);
        let n = fast_x8.max(spread_x8).max(8);
        usize::try_from(n).unwrap_or(usize::MAX)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::r#gen::sampler::{Sampling, sample};

    fn rose(a: f64, n: u64, d: u64) -> Rose {
        Rose::new(a, Ratio { num: n, den: d }).unwrap()
    }

    #[test]
    fn known_points() {
        let r = rose(50.0, 2, 1);
        assert_eq!(r.point(0.0), Point::new(50.0, 0.0));
        // k = 2: ρ(π/4) = 50 cos(π/2) = 0 (between petals); ρ(π/2) = 50 cos π = −50 → the point (0, −50).
        assert!(r.point(PI / 4.0).to_vec2().hypot() < 1e-12);
        let p = r.point(PI / 2.0);
        assert!(p.x.abs() < 1e-12 && (p.y + 50.0).abs() < 1e-12);
        // k = 3: ρ(π/6) = 0, ρ(π/3) = −a at angle π/3 → a(−½, −√3/2).
        let r = rose(10.0, 3, 1);
        let p = r.point(PI / 3.0);
        assert!((p.x + 5.0).abs() < 1e-12 && (p.y + 5.0 * 3f64.sqrt()).abs() < 1e-12);
    }

    /// Petal tips: vertices at distance `a` from the centre (to 1e-9).
    fn tips(r: &Rose, n: usize) -> usize {
        let poly = sample(r, Sampling::Fixed(n)).unwrap();
        poly.points[..poly.points.len() - 1].iter().filter(|p| (p.to_vec2().hypot() - r.a).abs() < 1e-9).count()
    }

    #[test]
    fn petal_counts_and_closure() {
        for (n, d, petals) in [(3, 1, 3), (2, 1, 4), (5, 1, 5), (4, 1, 8), (1, 2, 2), (3, 2, 6), (5, 3, 5), (7, 4, 14)]
        {
            let r = rose(40.0, n, d);
            assert_eq!(r.petals(), petals, "k = {n}/{d}");
            let (t0, t1) = r.domain();
            assert!(r.point(t1).distance(r.point(t0)) < 1e-9, "k = {n}/{d} does not close");
            // Fixed sampling with 60 steps between petal tips lands on every tip.
            let steps = usize::try_from(petals * 60).unwrap();
            assert_eq!(tips(&r, steps), usize::try_from(petals).unwrap(), "k = {n}/{d}");
            assert!(sample(&r, Sampling::default()).unwrap().is_closed());
        }
    }

    #[test]
    fn rejects_bad_amplitude() {
        assert!(Rose::new(0.0, Ratio { num: 3, den: 1 }).unwrap_err().to_string().contains("rose: parameter a="));
    }
}
