//! A closed outline taken from elsewhere (an SVG path, an image contour) as a curve parametrised by arc length, so
//! it can be fitted with a Fourier series or re-sampled like any generated figure.

use kurbo::Point;

use super::GenError;
use super::sampler::Curve;
use crate::Polyline;

/// A closed polyline as a [`Curve`]: the parameter is the distance travelled along it from its first vertex, and
/// every vertex is a corner ([`Curve::breaks`]), so adaptive sampling gives the polyline back exactly.
#[derive(Debug, Clone, PartialEq)]
pub struct Outline {
    points: Vec<Point>,
    /// Arc length at each vertex (same length as `points`).
    lengths: Vec<f64>,
}

impl Outline {
    /// Wrap a closed polyline; `what` names it in errors (e.g. `"path 3 of duck.svg"`).
    ///
    /// # Errors
    /// [`GenError::BadOutline`] if it is not closed or has no length.
    pub fn new(polyline: Polyline, what: &str) -> Result<Self, GenError> {
        let bad = |problem: &str| GenError::BadOutline { what: what.to_string(), problem: problem.to_string() };
        if !polyline.is_closed() {
            return Err(bad("it is not a closed path (its first and last points differ)"));
        }
        let mut lengths = Vec::with_capacity(polyline.points.len());
        let mut s = 0.0;
        lengths.push(s);
        for w in polyline.points.windows(2) {
            s += w[0].distance(w[1]);
            lengths.push(s);
        }
        if !(s > 0.0 && s.is_finite()) {
            return Err(bad("it has no length"));
        }
        Ok(Outline { points: polyline.points, lengths })
    }

    /// Total length, mm.
    pub fn length(&self) -> f64 {
        self.lengths[self.lengths.len() - 1]
    }

    /// The vertices (closed: last equals first).
    pub fn points(&self) -> &[Point] {
        &self.points
    }
}

impl Curve for Outline {
    fn name(&self) -> &'static str {
        "outline"
    }

    fn point(&self, s: f64) -> Point {
        // Segment i runs from lengths[i] to lengths[i + 1].
        let i = self.lengths.partition_point(|&l| l <= s).saturating_sub(1).min(self.points.len() - 2);
        let len = self.lengths[i + 1] - self.lengths[i];
        let u = if len > 0.0 { ((s - self.lengths[i]) / len).clamp(0.0, 1.0) } else { 0.0 };
        self.points[i].lerp(self.points[i + 1], u)
    }

    fn domain(&self) -> (f64, f64) {
        (0.0, self.length())
    }

    fn is_closed(&self) -> bool {
        true
    }

    fn min_segments(&self) -> usize {
        1
    }

    fn breaks(&self) -> Vec<f64> {
        self.lengths[1..self.lengths.len() - 1].to_vec()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::r#gen::sampler::{Sampling, sample};

    fn triangle() -> Polyline {
        Polyline::new(vec![Point::ORIGIN, Point::new(30.0, 0.0), Point::new(30.0, 40.0), Point::ORIGIN])
    }

    #[test]
    fn arc_length_parameter() {
        let o = Outline::new(triangle(), "triangle").unwrap();
        assert_eq!(o.length(), 120.0);
        assert_eq!(o.point(15.0), Point::new(15.0, 0.0));
        assert_eq!(o.point(50.0), Point::new(30.0, 20.0));
        assert_eq!(o.point(95.0), Point::new(15.0, 20.0));
        assert_eq!(o.point(120.0), Point::ORIGIN);
    }

    #[test]
    fn adaptive_sampling_returns_the_polyline() {
        let o = Outline::new(triangle(), "triangle").unwrap();
        assert_eq!(sample(&o, Sampling::Adaptive(0.01)).unwrap(), triangle());
    }

    #[test]
    fn rejects_open_or_empty() {
        let open = Polyline::new(vec![Point::ORIGIN, Point::new(1.0, 0.0), Point::new(1.0, 1.0)]);
        let e = Outline::new(open, "path 2 of a.svg").unwrap_err();
        assert!(e.to_string().contains("path 2 of a.svg: it is not a closed path"), "{e}");
        assert!(Outline::new(Polyline::new(vec![Point::ORIGIN; 4]), "dot").is_err());
    }
}
