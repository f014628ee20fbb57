//! The built-in "Mickey" outline: a head and two ears, each a circle, traced as the boundary of their union.
//!
//! Proportions (head radius 1): ears of radius 0.6 centred at `(±0.95, 1.05)`, Y up. Each ear cuts the head circle
//! in two points; the outline runs counter-clockwise from the bottom of the head along the head circle to the right
//! ear, around the ear's outer arc, along the top of the head between the ears, around the left ear, and back down
//! to the start — five circular arcs meeting in four concave corners. The curve parameter is arc length, so equal
//! parameter steps are equal steps along the outline (what a Fourier fit wants), and the corners are reported to the
//! sampler as break points so polylines hit them exactly.

use std::f64::consts::{FRAC_PI_2, PI, TAU};

use kurbo::{Point, Vec2};

use super::sampler::Curve;
use super::{GenError, positive};

/// Ear radius relative to the head radius.
const EAR_RADIUS: f64 = 0.6;
/// Ear centre relative to the head centre (right ear; the left one is mirrored), in head radii, Y up.
const EAR_CENTRE: Vec2 = Vec2::new(0.95, 1.05);

/// One circular arc: centre, radius, start angle and signed sweep (positive = counter-clockwise), radians.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Arc {
    /// Centre, mm.
    pub centre: Point,
    /// Radius, mm.
    pub radius: f64,
    /// Angle of the start point, radians.
    pub start: f64,
    /// Signed sweep, radians.
    pub sweep: f64,
}

impl Arc {
    /// Arc length, mm.
    pub fn length(&self) -> f64 {
        self.radius * self.sweep.abs()
    }

    /// The point a fraction `u ∈ [0, 1]` along the arc.
    pub fn at(&self, u: f64) -> Point {
        let a = self.start + self.sweep * u;
        self.centre + Vec2::new(a.cos(), a.sin()) * self.radius
    }
}

/// The Mickey outline at a given head radius, centred on the head's centre.
#[derive(Debug, Clone, PartialEq)]
pub struct MickeyOutline {
    arcs: Vec<Arc>,
    /// Cumulative arc length at the start of each arc, plus the total at the end.
    ends: Vec<f64>,
}

impl MickeyOutline {
    /// The outline with head radius `head` mm (overall about 3.1 × 2.65 head radii).
    ///
    /// # Errors
    /// [`GenError::BadValue`] unless `head` is positive and finite.
    pub fn new(head: f64) -> Result<Self, GenError> {
        let head = positive("mickey", "size", head)?;
        let ear = EAR_RADIUS * head;
        let d = EAR_CENTRE.hypot() * head;
        // Half-angles of the chord of intersection, seen from the head's centre (alpha) and the ear's (beta):
        // law of cosines in the triangle head centre, ear centre, intersection point.
        let alpha = ((d * d + head * head - ear * ear) / (2.0 * d * head)).acos();
        let beta = ((d * d + ear * ear - head * head) / (2.0 * d * ear)).acos();
        let phi_r = EAR_CENTRE.y.atan2(EAR_CENTRE.x);
        let phi_l = PI - phi_r;
        let origin = Point::ORIGIN;
        let ear_arc = |phi: f64| Arc {
            centre: origin + Vec2::new(phi.cos(), phi.sin()) * d,
            radius: ear,
            // The intersection clockwise of the centre line, seen from the ear, sits at phi + π + beta.
            start: phi + PI + beta,
            sweep: TAU - 2.0 * beta,
        };
        let head_arc = |from: f64, to: f64| Arc { centre: origin, radius: head, start: from, sweep: to - from };
        let arcs = vec![
            head_arc(-FRAC_PI_2, phi_r - alpha),
            ear_arc(phi_r),
            head_arc(phi_r + alpha, phi_l - alpha),
            ear_arc(phi_l),
            head_arc(phi_l + alpha, 3.0 * FRAC_PI_2),
        ];
        let mut ends = Vec::with_capacity(arcs.len() + 1);
        let mut s = 0.0;
        ends.push(s);
        for a in &arcs {
            s += a.length();
            ends.push(s);
        }
        Ok(MickeyOutline { arcs, ends })
    }

    /// The five arcs, in drawing order.
    pub fn arcs(&self) -> &[Arc] {
        &self.arcs
    }

    /// Total length, mm.
    pub fn length(&self) -> f64 {
        self.ends[self.arcs.len()]
    }

    /// Exact distance from `p` to the outline (to the nearest point of any arc).
    pub fn distance(&self, p: Point) -> f64 {
        self.arcs.iter().map(|a| arc_distance(a, p)).fold(f64::INFINITY, f64::min)
    }
}

/// Distance from `p` to an arc: radial distance when `p`'s direction from the centre falls inside the sweep,
/// otherwise the distance to the nearer endpoint.
fn arc_distance(arc: &Arc, p: Point) -> f64 {
    let v = p - arc.centre;
    let (lo, sweep) = if arc.sweep >= 0.0 { (arc.start, arc.sweep) } else { (arc.start + arc.sweep, -arc.sweep) };
    let rel = (v.y.atan2(v.x) - lo).rem_euclid(TAU);
    if rel <= sweep { (v.hypot() - arc.radius).abs() } else { p.distance(arc.at(0.0)).min(p.distance(arc.at(1.0))) }
}

impl Curve for MickeyOutline {
    fn name(&self) -> &'static str {
        "mickey-outline"
    }

    fn point(&self, s: f64) -> Point {
        let i = self.ends[1..].partition_point(|&e| e < s).min(self.arcs.len() - 1);
        let arc = &self.arcs[i];
        arc.at(((s - self.ends[i]) / arc.length()).clamp(0.0, 1.0))
    }

    fn domain(&self) -> (f64, f64) {
        (0.0, self.length())
    }

    fn is_closed(&self) -> bool {
        true
    }

    fn min_segments(&self) -> usize {
        40
    }

    fn breaks(&self) -> Vec<f64> {
        self.ends[1..self.arcs.len()].to_vec()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::r#gen::sampler::{Sampling, sample};

    #[test]
    fn arcs_join_and_close() {
        let m = MickeyOutline::new(40.0).unwrap();
        let arcs = m.arcs();
        for w in arcs.windows(2) {
            assert!(w[0].at(1.0).distance(w[1].at(0.0)) < 1e-9, "{w:?}");
        }
        assert!(arcs[4].at(1.0).distance(arcs[0].at(0.0)) < 1e-9);
        assert!(m.point(0.0).distance(Point::new(0.0, -40.0)) < 1e-12);
        assert!(m.point(m.length()).distance(m.point(0.0)) < 1e-9);
        // Corners lie on both circles they join.
        let corner = arcs[1].at(0.0);
        assert!((corner.to_vec2().hypot() - 40.0).abs() < 1e-9);
        assert!((corner.distance(arcs[1].centre) - 24.0).abs() < 1e-9);
    }

    #[test]
    fn extent_and_symmetry() {
        let m = MickeyOutline::new(10.0).unwrap();
        let poly = sample(&m, Sampling::Adaptive(1e-4)).unwrap();
        assert!(poly.is_closed());
        let b = poly.bbox().unwrap();
        // Width: ear centre x + ear radius on each side = 2·(0.95 + 0.6)·10; top: 1.05 + 0.6; bottom: −1.
        assert!((b.width() - 31.0).abs() < 1e-3, "{b:?}");
        assert!((b.max_y() - 16.5).abs() < 1e-3 && (b.min_y() + 10.0).abs() < 1e-3, "{b:?}");
        // Every vertex is on the outline, and the corners are vertices.
        assert!(poly.points.iter().all(|&p| m.distance(p) < 1e-9));
        for s in m.breaks() {
            let c = m.point(s);
            assert!(poly.points.iter().any(|&p| p.distance(c) < 1e-12));
        }
        // Mirror symmetry about the Y axis.
        for p in &poly.points {
            assert!(m.distance(Point::new(-p.x, p.y)) < 1e-9);
        }
    }

    #[test]
    fn distance_is_exact() {
        let m = MickeyOutline::new(1.0).unwrap();
        assert!((m.distance(Point::ORIGIN) - 1.0).abs() < 1e-12);
        assert!((m.distance(Point::new(0.0, -3.0)) - 2.0).abs() < 1e-12);
        // The right ear's centre is 0.6 from its own outer arc.
        assert!((m.distance(Point::new(0.95, 1.05)) - 0.6).abs() < 1e-12);
        assert!(MickeyOutline::new(-1.0).is_err());
    }
}
