//! What a pen-up travel move costs: its length, or the time the machine needs for it.
//!
//! The time model follows how a plotter actually moves between strokes. At the end of a stroke the pen lifts (a Z
//! move plus a settle dwell), the carriage travels to the next stroke, and the pen drops (another Z move and dwell).
//! Because the pen lifts and drops *at rest*, each travel move starts and ends at standstill: the planner cannot
//! carry speed through a lift. So one hop of length `d` takes a stop-to-stop trapezoidal (or, when too short to reach
//! cruise, triangular) velocity profile, the classic constant-acceleration motion model used by grbl-style planners:
//!
//! * `d ≥ v²/a`: accelerate to `v`, cruise, decelerate — `t = d/v + v/a`;
//! * otherwise: accelerate half way, decelerate half way — `t = 2·√(d/a)`.
//!
//! `v` and `a` depend on the direction, as in grbl: the programmed travel feed is capped so that no axis exceeds its
//! own maximum rate, and the acceleration so that no axis exceeds its own limit (`v = min(F, vₓ/|uₓ|, v_y/|u_y|)` for
//! the unit direction `u`), and lowered to the profile's travel acceleration (`pen.travel_accel_mm_s2`, a cap on
//! the acceleration along the path) where it sets one, as the motion plan does. Every hop also pays a fixed lift + drop cost (two Z moves and two settle dwells). The
//! short-hop branch grows like a square root, so many tiny hops weigh more than their summed length suggests —
//! that is the point of optimizing time instead of distance.

use kurbo::Point;

use crate::MachineProfile;

/// Stop-to-stop time of a move of length `d` with top speed `v` and acceleration `a` (all positive).
fn trapezoid_time(d: f64, v: f64, a: f64) -> f64 {
    if d <= 0.0 {
        0.0
    } else if d * a >= v * v {
        d / v + v / a
    } else {
        2.0 * (d / a).sqrt()
    }
}

/// Pen-up travel timing derived from a machine profile. See the module docs for the motion model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TravelTimeModel {
    /// Programmed travel feed, mm/s.
    pub feed_mm_s: f64,
    /// X axis maximum rate, mm/s.
    pub max_feed_x_mm_s: f64,
    /// Y axis maximum rate, mm/s.
    pub max_feed_y_mm_s: f64,
    /// X axis acceleration limit, mm/s².
    pub accel_x_mm_s2: f64,
    /// Y axis acceleration limit, mm/s².
    pub accel_y_mm_s2: f64,
    /// The profile's cap on the acceleration along a travel move, mm/s² (infinite when it sets none): on a short
    /// hop it decides the time, as the hop never reaches its feed.
    pub travel_accel_mm_s2: f64,
    /// Fixed cost of one lift plus one drop (Z moves and settle dwells), seconds.
    pub lift_drop_s: f64,
}

impl TravelTimeModel {
    /// The travel model of `profile`: travel feed, XY axis limits, and the lift/drop cost from the Z axis limits,
    /// the pen's up/down positions and its settle time.
    pub fn from_profile(profile: &MachineProfile) -> Self {
        let z = &profile.axes.z;
        let stroke = (profile.pen.up_z_mm - profile.pen.down_z_mm).abs();
        let z_move = trapezoid_time(stroke, z.max_feed_mm_s, z.max_accel_mm_s2);
        TravelTimeModel {
            feed_mm_s: profile.pen.travel_feed_mm_s,
            max_feed_x_mm_s: profile.axes.x.max_feed_mm_s,
            max_feed_y_mm_s: profile.axes.y.max_feed_mm_s,
            accel_x_mm_s2: profile.axes.x.max_accel_mm_s2,
            accel_y_mm_s2: profile.axes.y.max_accel_mm_s2,
            travel_accel_mm_s2: profile.pen.travel_accel_mm_s2.unwrap_or(f64::INFINITY),
            lift_drop_s: 2.0 * z_move + 2.0 * profile.pen.settle_ms / 1000.0,
        }
    }

    /// Time of the XY part of a hop from `a` to `b` (no lift/drop), seconds.
    ///
    /// This runs for every candidate move of the improvement, so the common case skips the speed caps (and the
    /// length, unless the profile caps the travel acceleration). Along the unit direction `u = (dx, dy)/d` the
    /// acceleration is `A = min(aₓ/uₓ, a_y/u_y, a_travel)`, so `d/A = max(dx/aₓ, dy/a_y, d/a_travel)` (= `m`). The hop is a triangle when `d·A < v²`, i.e. `d² < v²·m`; the speed `v` is
    /// never below `v₀ = min(F, vₓ, v_y)` (each axis cap `vᵢ/uᵢ ≥ vᵢ`), so `d² < v₀²·m` settles it without
    /// computing `v`, and the triangle's time `2·√(d/A)` is `2·√m`: one square root. Only longer hops take the full
    /// formula.
    pub fn move_time(&self, a: Point, b: Point) -> f64 {
        let dx = (b.x - a.x).abs();
        let dy = (b.y - a.y).abs();
        let d2 = dx * dx + dy * dy;
        if d2 <= 0.0 {
            return 0.0;
        }
        if let Some(t) = self.triangle(dx, dy, d2, self.accel_x_mm_s2.recip(), self.accel_y_mm_s2.recip()) {
            return t;
        }
        // sqrt of the sum of squares rather than `hypot`: the libm routine guards against overflow that page
        // coordinates never reach and costs several times more.
        let d = d2.sqrt();
        let (ux, uy) = (dx / d, dy / d);
        let mut v = self.feed_mm_s;
        let mut acc = f64::INFINITY;
        if ux > 0.0 {
            v = v.min(self.max_feed_x_mm_s / ux);
            acc = acc.min(self.accel_x_mm_s2 / ux);
        }
        if uy > 0.0 {
            v = v.min(self.max_feed_y_mm_s / uy);
            acc = acc.min(self.accel_y_mm_s2 / uy);
        }
        trapezoid_time(d, v, acc.min(self.travel_accel_mm_s2))
    }

    /// The move time of a hop by `(dx, dy)` (absolute, `d2 = dx² + dy²`) when it is surely a triangle (see
    /// [`TravelTimeModel::move_time`]), given the reciprocals of the axis accelerations; `None` for a longer hop.
    #[inline]
    fn triangle(&self, dx: f64, dy: f64, d2: f64, inv_ax: f64, inv_ay: f64) -> Option<f64> {
        let mut m = (dx * inv_ax).max(dy * inv_ay);
        if self.travel_accel_mm_s2.is_finite() {
            m = m.max(d2.sqrt() / self.travel_accel_mm_s2);
        }
        let v0 = self.feed_mm_s.min(self.max_feed_x_mm_s).min(self.max_feed_y_mm_s);
        (d2 < v0 * v0 * m).then(|| 2.0 * m.sqrt())
    }

    /// Time of a whole hop: lift, move, drop.
    pub fn hop_time(&self, a: Point, b: Point) -> f64 {
        self.lift_drop_s + self.move_time(a, b)
    }

    /// A lower bound on [`hop_time`](Self::hop_time) over every direction for a hop of length `d`: the move with
    /// the best possible speed and acceleration any direction allows (the diagonal where both axes run at their
    /// limits). Used by the lower bound, where the direction of a hop is not known.
    pub fn min_hop_time(&self, d: f64) -> f64 {
        let v = self.feed_mm_s.min(self.max_feed_x_mm_s.hypot(self.max_feed_y_mm_s));
        let a = self.accel_x_mm_s2.hypot(self.accel_y_mm_s2).min(self.travel_accel_mm_s2);
        self.lift_drop_s + trapezoid_time(d, v, a)
    }
}

/// A [`CostModel`] made ready for evaluating very many hops (the improvement's candidates): the reciprocals of the
/// axis accelerations are taken once. Agrees with [`CostModel::cost`] to a few units in the last place.
#[derive(Debug, Clone, Copy)]
pub(crate) struct HopCost {
    model: CostModel,
    inv_accel: (f64, f64),
}

impl HopCost {
    pub(crate) fn new(model: CostModel) -> Self {
        let inv_accel = match model {
            CostModel::Distance => (0.0, 0.0),
            CostModel::Time(m) => (m.accel_x_mm_s2.recip(), m.accel_y_mm_s2.recip()),
        };
        HopCost { model, inv_accel }
    }

    /// The cost of a hop from `a` to `b`.
    #[inline]
    pub(crate) fn cost(&self, a: Point, b: Point) -> f64 {
        let CostModel::Time(m) = &self.model else { return self.model.cost(a, b) };
        let (dx, dy) = ((b.x - a.x).abs(), (b.y - a.y).abs());
        let d2 = dx * dx + dy * dy;
        match m.triangle(dx, dy, d2, self.inv_accel.0, self.inv_accel.1) {
            Some(t) => m.lift_drop_s + t,
            None => m.hop_time(a, b),
        }
    }
}

/// The quantity the optimizer minimizes over pen-up hops.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CostModel {
    /// Pen-up distance in millimetres.
    Distance,
    /// Pen-up time in seconds (travel move plus lift and drop).
    Time(TravelTimeModel),
}

impl CostModel {
    /// Cost of one hop from `a` to `b`. Symmetric: `cost(a, b) == cost(b, a)`.
    #[inline]
    pub fn cost(&self, a: Point, b: Point) -> f64 {
        match self {
            CostModel::Distance => {
                let (dx, dy) = (b.x - a.x, b.y - a.y);
                (dx * dx + dy * dy).sqrt()
            }
            CostModel::Time(m) => m.hop_time(a, b),
        }
    }

    /// A lower bound on the cost of any hop of Euclidean length at least `d` (monotone in `d`).
    pub fn min_cost_of_length(&self, d: f64) -> f64 {
        match self {
            CostModel::Distance => d,
            CostModel::Time(m) => m.min_hop_time(d),
        }
    }

    /// Unit of the cost, for reports.
    pub fn unit(&self) -> &'static str {
        match self {
            CostModel::Distance => "mm",
            CostModel::Time(_) => "s",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn model() -> TravelTimeModel {
        TravelTimeModel::from_profile(&MachineProfile::default_plotter())
    }

    #[test]
    fn lift_and_drop_cost_comes_from_the_pen_heights_z_limits_and_settle() {
        // Pen up at Z 5, down at Z 1: a 4 mm move at 10 mm/s and 100 mm/s² ramps over 0.5 mm at each end, so it
        // takes 4/10 + 10/100 = 0.5 s; a lift and a drop with 100 ms settles each: 2 × 0.5 + 2 × 0.1 = 1.2 s.
        let mut p = MachineProfile::default_plotter();
        (p.pen.up_z_mm, p.pen.down_z_mm, p.pen.settle_ms) = (5.0, 1.0, 100.0);
        (p.axes.z.max_feed_mm_s, p.axes.z.max_accel_mm_s2) = (10.0, 100.0);
        let m = TravelTimeModel::from_profile(&p);
        assert!((m.lift_drop_s - 1.2).abs() < 1e-12, "{}", m.lift_drop_s);
        // Only the distance between the heights counts, not their order.
        (p.pen.up_z_mm, p.pen.down_z_mm) = (1.0, 5.0);
        assert!((TravelTimeModel::from_profile(&p).lift_drop_s - 1.2).abs() < 1e-12);
    }

    #[test]
    fn trapezoid_and_triangle_branches() {
        // v = 100, a = 1000: cruise reached after 10 mm of accel + decel.
        assert!((trapezoid_time(100.0, 100.0, 1000.0) - (1.0 + 0.1)).abs() < 1e-12);
        // 2.5 mm: triangle, t = 2·sqrt(2.5/1000) = 0.1.
        assert!((trapezoid_time(2.5, 100.0, 1000.0) - 0.1).abs() < 1e-12);
        // Continuous at the switch distance v²/a = 10 mm: both give 0.2 s.
        assert!((trapezoid_time(10.0, 100.0, 1000.0) - 0.2).abs() < 1e-12);
        assert_eq!(trapezoid_time(0.0, 100.0, 1000.0), 0.0);
    }

    #[test]
    fn profile_lift_drop_and_axis_moves() {
        let m = model();
        // Sample profile: pen stroke 4 mm on Z (25 mm/s, 500 mm/s²): v²/a = 1.25 mm < 4, so t = 4/25 + 25/500 = 0.21 s;
        // twice, plus two 50 ms settles.
        assert!((m.lift_drop_s - (2.0 * 0.21 + 0.1)).abs() < 1e-12, "{}", m.lift_drop_s);
        // X move of 100 mm at 120 mm/s (travel feed), 1500 mm/s²: 100/120 + 120/1500.
        let t = m.move_time(Point::new(0.0, 0.0), Point::new(100.0, 0.0));
        assert!((t - (100.0 / 120.0 + 0.08)).abs() < 1e-12);
        // Symmetric.
        let a = Point::new(3.0, 7.0);
        let b = Point::new(-20.0, 41.0);
        assert_eq!(m.move_time(a, b), m.move_time(b, a));
        assert_eq!(m.move_time(a, a), 0.0);
    }

    #[test]
    fn hop_time_by_hand_on_the_kit_profile() {
        // Kit profile: travel 120 mm/s, X and Y 1500 mm/s² (and fast enough axes), lift + drop 0.52 s.
        let m = model();
        let o = Point::ZERO;
        // Along X, cruise needs v²/a = 9.6 mm. 5 mm is a triangle: 2·√(5/1500) = 0.115470 s.
        assert!((m.hop_time(o, Point::new(5.0, 0.0)) - (0.52 + 2.0 * (5.0f64 / 1500.0).sqrt())).abs() < 1e-12);
        // 60 mm is a trapezoid: 60/120 + 120/1500 = 0.58 s.
        assert!((m.hop_time(o, Point::new(0.0, 60.0)) - (0.52 + 0.58)).abs() < 1e-12);
        // A 3-4-5 hop (direction 0.6, 0.8): the feed stays 120 (X runs 72, Y 96 mm/s, both under 150); the
        // acceleration along it is the smaller of 1500/0.6 and 1500/0.8 = 1875. v²/a = 7.68 > 5 → triangle.
        let d = m.move_time(o, Point::new(3.0, 4.0));
        assert!((d - 2.0 * (5.0f64 / 1875.0).sqrt()).abs() < 1e-12, "{d}");
    }

    #[test]
    fn the_profiles_travel_acceleration_caps_every_hop() {
        // The kit profile with pen.travel_accel_mm_s2 = 800: a 3-4-5 hop could accelerate at 1875 mm/s² on its
        // axes (see above) but the cap holds it to 800: a triangle (v²/a = 18 mm > 5), 2·√(5/800) = 0.158 114 s
        // (2·√(5/1875) = 0.103 280 s uncapped). Along X, 60 mm: 60/120 + 120/800 = 0.65 s.
        let mut p = MachineProfile::default_plotter();
        p.pen.travel_accel_mm_s2 = Some(800.0);
        let m = TravelTimeModel::from_profile(&p);
        let o = Point::ZERO;
        let t = m.move_time(o, Point::new(3.0, 4.0));
        assert!((t - 2.0 * (5.0f64 / 800.0).sqrt()).abs() < 1e-12, "{t}");
        assert!((m.move_time(o, Point::new(60.0, 0.0)) - 0.65).abs() < 1e-12);
        let c = HopCost::new(CostModel::Time(m)).cost(o, Point::new(3.0, 4.0));
        assert!((c - (m.lift_drop_s + 2.0 * (5.0f64 / 800.0).sqrt())).abs() < 1e-12, "{c}");
        // A cap above what the axes allow changes nothing.
        p.pen.travel_accel_mm_s2 = Some(5000.0);
        assert_eq!(
            TravelTimeModel::from_profile(&p).move_time(o, Point::new(3.0, 4.0)),
            model().move_time(o, Point::new(3.0, 4.0))
        );
    }

    #[test]
    fn time_cost_weighs_many_short_hops_more_than_their_length() {
        let c = CostModel::Time(model());
        let o = Point::ZERO;
        let ten_short: f64 = 10.0 * c.cost(o, Point::new(1.0, 0.0));
        let one_long = c.cost(o, Point::new(10.0, 0.0));
        assert!(ten_short > 5.0 * one_long, "{ten_short} vs {one_long}");
        assert_eq!(CostModel::Distance.cost(o, Point::new(3.0, 4.0)), 5.0);
    }

    /// The definition, term by term: unit direction, per-axis capped speed and acceleration, stop-to-stop time.
    /// Returns the time and whether the move reaches cruise.
    fn move_time_by_definition(m: &TravelTimeModel, a: Point, b: Point) -> (f64, bool) {
        let (dx, dy) = ((b.x - a.x).abs(), (b.y - a.y).abs());
        let d = dx.hypot(dy);
        if d == 0.0 {
            return (0.0, false);
        }
        let (ux, uy) = (dx / d, dy / d);
        let mut v = m.feed_mm_s;
        let mut acc = f64::INFINITY;
        if ux > 0.0 {
            v = v.min(m.max_feed_x_mm_s / ux);
            acc = acc.min(m.accel_x_mm_s2 / ux);
        }
        if uy > 0.0 {
            v = v.min(m.max_feed_y_mm_s / uy);
            acc = acc.min(m.accel_y_mm_s2 / uy);
        }
        let acc = acc.min(m.travel_accel_mm_s2);
        let cruise = d * acc >= v * v;
        (if cruise { d / v + v / acc } else { 2.0 * (d / acc).sqrt() }, cruise)
    }

    #[test]
    fn fast_move_time_agrees_with_the_definition() {
        // Kit profile, and one with a slow Y axis and an uncapped feed (the axis caps then decide the speed).
        let slow_y = TravelTimeModel { feed_mm_s: 500.0, max_feed_y_mm_s: 80.0, accel_y_mm_s2: 700.0, ..model() };
        let capped = TravelTimeModel { travel_accel_mm_s2: 900.0, ..model() };
        let mut r = crate::optimize::rng::SplitMix64::new(11);
        for m in [model(), slow_y, capped] {
            let mut cruises = 0;
            for k in 0..20_000 {
                // Lengths from 1 µm to 400 mm on a log scale, any direction, plus exact axis directions.
                let d = 1e-3 * 4e5f64.powf(r.unit());
                let ang = match k % 10 {
                    0 => 0.0,
                    1 => std::f64::consts::FRAC_PI_2,
                    _ => r.unit() * std::f64::consts::TAU,
                };
                let a = Point::new(r.unit() * 300.0, r.unit() * 300.0);
                let b = Point::new(a.x + d * ang.cos(), a.y + d * ang.sin());
                let (fast, (slow, cruise)) = (m.move_time(a, b), move_time_by_definition(&m, a, b));
                assert!((fast - slow).abs() <= 1e-12 * (1.0 + slow), "{a:?} -> {b:?}: {fast} vs {slow}");
                cruises += usize::from(cruise);
            }
            // Both branches are exercised.
            assert!((2000..18_000).contains(&cruises), "{cruises} of 20000 moves reach cruise");
        }
    }

    #[test]
    fn the_prepared_hop_cost_agrees_with_the_model() {
        let slow_y = TravelTimeModel { feed_mm_s: 500.0, max_feed_y_mm_s: 80.0, accel_y_mm_s2: 700.0, ..model() };
        let capped = TravelTimeModel { travel_accel_mm_s2: 900.0, ..model() };
        let mut r = crate::optimize::rng::SplitMix64::new(5);
        for model in [CostModel::Distance, CostModel::Time(model()), CostModel::Time(slow_y), CostModel::Time(capped)] {
            let prepared = HopCost::new(model);
            for k in 0..20_000 {
                let a = Point::new(r.unit() * 300.0, r.unit() * 300.0);
                // Hops from 1 µm to 400 mm, and of no length.
                let d = if k % 100 == 0 { 0.0 } else { 1e-3 * 4e5f64.powf(r.unit()) };
                let ang = r.unit() * std::f64::consts::TAU;
                let b = Point::new(a.x + d * ang.cos(), a.y + d * ang.sin());
                let (fast, exact) = (prepared.cost(a, b), model.cost(a, b));
                assert!((fast - exact).abs() <= 1e-12 * (1.0 + exact), "{model:?} {a:?} -> {b:?}: {fast} vs {exact}");
            }
        }
        // A 5 mm hop along X on the kit profile, by hand: 0.52 s of lift and drop and a 2·√(5/1500) s triangle.
        let t = HopCost::new(CostModel::Time(model())).cost(Point::ZERO, Point::new(5.0, 0.0));
        assert!((t - (0.52 + 2.0 * (5.0f64 / 1500.0).sqrt())).abs() < 1e-12, "{t}");
    }

    #[test]
    fn min_hop_time_bounds_every_direction() {
        let m = TravelTimeModel { feed_mm_s: 500.0, max_feed_y_mm_s: 80.0, accel_y_mm_s2: 700.0, ..model() };
        for d in [0.0, 0.3, 1.0, 5.0, 40.0, 300.0] {
            for k in 0..64 {
                let ang = f64::from(k) * std::f64::consts::TAU / 64.0;
                let b = Point::new(d * ang.cos(), d * ang.sin());
                assert!(m.min_hop_time(d) <= m.hop_time(Point::ZERO, b) + 1e-12, "d={d} k={k}");
            }
        }
    }
}
