//! Circles and ellipses: `x = rx cos t`, `y = ry sin t`, `t ∈ [0, 2π]`, centred on the origin.

use std::f64::consts::TAU;

use kurbo::Point;

use super::sampler::Curve;
use super::{GenError, positive};

/// An axis-aligned ellipse centred on the origin (a circle when both radii are equal), traced counter-clockwise
/// (math orientation) from `(rx, 0)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ellipse {
    /// Semi-axis along X, mm.
    pub rx: f64,
    /// Semi-axis along Y, mm.
    pub ry: f64,
}

impl Ellipse {
    /// A circle of radius `r` mm.
    ///
    /// # Errors
    /// [`GenError::BadValue`] unless `r` is positive and finite.
    pub fn circle(r: f64) -> Result<Self, GenError> {
        let r = positive("circle", "r", r)?;
        Ok(Ellipse { rx: r, ry: r })
    }

    /// An ellipse with semi-axes `rx`, `ry` mm.
    ///
    /// # Errors
    /// [`GenError::BadValue`] unless both are positive and finite.
    pub fn new(rx: f64, ry: f64) -> Result<Self, GenError> {
        Ok(Ellipse { rx: positive("ellipse", "rx", rx)?, ry: positive("ellipse", "ry", ry)? })
    }
}

impl Curve for Ellipse {
    fn name(&self) -> &'static str {
        if self.rx == self.ry { "circle" } else { "ellipse" }
    }

    fn point(&self, t: f64) -> Point {
        Point::new(self.rx * t.cos(), self.ry * t.sin())
    }

    fn domain(&self) -> (f64, f64) {
        (0.0, TAU)
    }

    fn is_closed(&self) -> bool {
        true
    }

    fn min_segments(&self) -> usize {
        // An ellipse is two opposite rotations (e^{±it}); their difference turns twice per period.
        16
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::r#gen::sampler::{Sampling, sample};
    use std::f64::consts::FRAC_PI_4;

    #[test]
    fn known_points() {
        let e = Ellipse::new(30.0, 20.0).unwrap();
        assert_eq!(e.point(0.0), Point::new(30.0, 0.0));
        let p = e.point(FRAC_PI_4);
        let h = std::f64::consts::FRAC_1_SQRT_2;
        assert!((p.x - 30.0 * h).abs() < 1e-12 && (p.y - 20.0 * h).abs() < 1e-12);
        let c = Ellipse::circle(5.0).unwrap();
        let p = c.point(std::f64::consts::PI);
        assert!((p.x + 5.0).abs() < 1e-12 && p.y.abs() < 1e-12);
    }

    #[test]
    fn closes_and_stays_on_the_ellipse() {
        let e = Ellipse::new(60.0, 25.0).unwrap();
        assert!(e.point(TAU).distance(e.point(0.0)) < 1e-9);
        let poly = sample(&e, Sampling::Adaptive(0.01)).unwrap();
        assert!(poly.is_closed());
        for p in &poly.points {
            let v = (p.x / 60.0).powi(2) + (p.y / 25.0).powi(2);
            assert!((v - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn rejects_bad_radii() {
        for r in [0.0, -3.0, f64::NAN, f64::INFINITY] {
            let e = Ellipse::circle(r).unwrap_err();
            assert!(e.to_string().contains("circle: parameter r="), "{e}");
        }
        let e = Ellipse::new(10.0, -1.0).unwrap_err();
        assert!(e.to_string().contains("ry"), "{e}");
    }
}
