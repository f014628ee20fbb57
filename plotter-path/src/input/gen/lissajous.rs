//! Lissajous figures: `x = A sin(a t + φ)`, `y = B sin(b t)`, `t ∈ [0, 2π]`, for whole frequencies `a`, `b`.

use std::f64::consts::TAU;

use kurbo::Point;

use super::sampler::Curve;
use super::{GenError, positive};

/// A Lissajous figure centred on the origin, filling the box `[−A, A] × [−B, B]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lissajous {
    /// Half-width `A`, mm.
    pub ax: f64,
    /// Half-height `B`, mm.
    pub ay: f64,
    /// Frequency along X, ≥ 1.
    pub fx: u32,
    /// Frequency along Y, ≥ 1.
    pub fy: u32,
    /// Phase of the X motion, radians.
    pub phase: f64,
}

/// Largest accepted frequency (more only produces a filled box).
pub const MAX_FREQUENCY: u32 = 10_000;

impl Lissajous {
    /// A Lissajous figure.
    ///
    /// # Errors
    /// [`GenError::BadValue`] if an amplitude is not positive and finite, a frequency is 0 or above
    /// [`MAX_FREQUENCY`], or the phase is not finite.
    pub fn new(ax: f64, ay: f64, fx: u32, fy: u32, phase: f64) -> Result<Self, GenError> {
        for (param, f) in [("fx", fx), ("fy", fy)] {
            if f == 0 || f > MAX_FREQUENCY {
                return Err(GenError::BadValue {
                    kind: "lissajous".to_string(),
                    param: param.to_string(),
                    value: f.to_string(),
                    problem: format!("frequency must be a whole number from 1 to {MAX_FREQUENCY}"),
                });
            }
        }
        if !phase.is_finite() {
            return Err(GenError::BadValue {
                kind: "lissajous".to_string(),
                param: "phase".to_string(),
                value: phase.to_string(),
                problem: "must be a finite angle in degrees".to_string(),
            });
        }
        Ok(Lissajous { ax: positive("lissajous", "ax", ax)?, ay: positive("lissajous", "ay", ay)?, fx, fy, phase })
    }
}

impl Curve for Lissajous {
    fn name(&self) -> &'static str {
        "lissajous"
    }

    fn point(&self, t: f64) -> Point {
        Point::new(self.ax * (f64::from(self.fx) * t + self.phase).sin(), self.ay * (f64::from(self.fy) * t).sin())
    }

    fn domain(&self) -> (f64, f64) {
        (0.0, TAU)
    }

    fn is_closed(&self) -> bool {
        true
    }

    fn min_segments(&self) -> usize {
        // Each axis is a pair of opposite rotations (e^{±i·f·t}), whose difference turns 2f times per period; eight
        // intervals per such cycle.
        usize::try_from(self.fx.max(self.fy)).unwrap_or(1).saturating_mul(16)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::r#gen::sampler::{Sampling, sample};
    use std::f64::consts::{FRAC_PI_2, PI};

    #[test]
    fn known_points() {
        let l = Lissajous::new(50.0, 40.0, 3, 2, FRAC_PI_2).unwrap();
        assert!(l.point(0.0).distance(Point::new(50.0, 0.0)) < 1e-12);
        // t = π/4: x = 50 sin(3π/4 + π/2) = 50 cos(3π/4) = −25√2, y = 40 sin(π/2) = 40.
        assert!(l.point(PI / 4.0).distance(Point::new(-25.0 * 2f64.sqrt(), 40.0)) < 1e-12);
        // a = b = 1 with a quarter-turn phase is an ellipse.
        let e = Lissajous::new(30.0, 20.0, 1, 1, FRAC_PI_2).unwrap();
        for i in 0..40 {
            let p = e.point(f64::from(i) * 0.17);
            assert!(((p.x / 30.0).powi(2) + (p.y / 20.0).powi(2) - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn closes_and_fills_its_box() {
        let l = Lissajous::new(50.0, 40.0, 5, 4, 0.3).unwrap();
        let poly = sample(&l, Sampling::Adaptive(0.01)).unwrap();
        assert!(poly.is_closed());
        assert!(l.point(TAU).distance(l.point(0.0)) < 1e-9);
        let b = poly.bbox().unwrap();
        assert!((b.width() - 100.0).abs() < 0.02 && (b.height() - 80.0).abs() < 0.02, "{b:?}");
    }

    #[test]
    fn rejects_bad_parameters() {
        assert!(Lissajous::new(50.0, 40.0, 0, 2, 0.0).unwrap_err().to_string().contains("fx"));
        assert!(Lissajous::new(50.0, -4.0, 1, 2, 0.0).unwrap_err().to_string().contains("ay"));
        assert!(Lissajous::new(50.0, 4.0, 1, 2, f64::NAN).unwrap_err().to_string().contains("phase"));
    }
}
