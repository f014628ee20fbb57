//! The least time a pen-up hop can take on a machine, from how far it goes along each axis: the one hop cost the
//! time bound ([`crate::motion::bound`]), its breakdown ([`crate::motion::gap`]) and the travel bound's searches
//! ([`crate::optimize::bound`]) all read.
//!
//! A hop covers `|dx|` mm of X and `|dy|` mm of Y, whatever path it takes. Three things bound its time, each valid
//! for any path between its ends, so their largest is too:
//!
//! * **X alone**: the X carriage covers `|dx|` moving no faster than X's speed limit (and the travel feed: an
//!   axis's speed is a share of the path's), speeding up and slowing down no harder than X's acceleration (and
//!   the travel acceleration cap, `pen.travel_accel_mm_s2`, a limit along the path in any direction), starting and
//!   ending no faster than the hop itself may start and end. That is a one-dimensional motion, whose least time is
//!   a trapezoid (or a triangle): accelerate, cruise, decelerate.
//! * **Y alone**: the same with Y's limits over `|dy|`.
//! * **The path**: the path is at least `√(dx² + dy²)` long, the pen's speed along it is at most the travel feed
//!   and changes no faster than the largest acceleration any direction allows (`√(a_x² + a_y²)`, or the cap where
//!   lower).
//!
//! Along one axis the X term is the tightest of the three (a 30 mm hop along X on axes of 760 mm/s² each takes at
//! least X's 760 mm/s² trapezoid, not the diagonal's 1075 mm/s²); on a diagonal the path term may be.
//!
//! **Where the hop starts and ends.** A servo pen's hop runs from rest to rest (its servo blocks are stops); a Z
//! pen's hop starts and ends at the corner with the pen's Z moves ([`crate::motion::bound`]), or, with the curve
//! model on, at up to the slower of the Z and travel feeds. Each axis's share of that speed is no more than the
//! whole. The plan's hop runs between stroke ends rounded to steps, which may shorten a hop by up to a step
//! along each axis at each end: each axis's distance is taken two of its steps short, the path's two step
//! diagonals short.
//!
//! **A Z pen's hop bends.** It climbs over the paper at a slope `s` ([`crate::motion::hop`]): its blocks are tilted
//! by up to `atan(2s)` out of the paper's plane, and where the tilt changes, the pen's speed along the path is
//! kept but the share of it that X carries grows or shrinks by the cosine of the tilt. Measured against the
//! pen's speed along the path (continuous, and speeding up no harder than each block's limits, which are at most
//! X's limits divided by X's share of that block), X moves no faster than its limits times `1/cos(atan 2s)` =
//! `√(1 + 4s²)`: the X and Y terms of a Z pen take their limits that much higher (0.5 % at the XY kit's
//! 0.052). A servo pen's hop is one straight block (or collinear parts of it): no bend.
//!
//! **One cost, symmetric.** The time depends on `|dx|` and `|dy|` only, so a hop from `a` to `b` costs what the
//! hop from `b` to `a` costs, and it never falls when either distance grows. That is all the travel bound's
//! spanning trees, penalized trees and exact search need ([`crate::optimize::bound`]): a tree of symmetric hop
//! costs is a bound on any route's hops whatever the costs' geometry, and a subtree of a k-d tree whose box lies
//! `bx`, `by` from a point holds no point cheaper than the cost of `(bx, by)`.

use crate::MachineProfile;
use crate::motion::piece_time::{fastest_piece, hop_corner_speed, path_accel, z_joins_may_curve};

/// One axis's limits for a hop: top speed, acceleration, and the distance its steps' rounding may take off.
#[derive(Debug, Clone, Copy, PartialEq)]
struct AxisLimit {
    top: f64,
    accel: f64,
    slack: f64,
}

/// The least time of a pen-up hop on one profile (see the module docs), seconds; build once with
/// [`HopTime::of`], then ask [`HopTime::seconds`] per hop.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HopTime {
    /// The speed the hop may start and end at, mm/s.
    v_end: f64,
    /// The travel feed, mm/s.
    feed: f64,
    /// The largest acceleration along the path, mm/s².
    accel: f64,
    /// What the steps' rounding may take off the path's length, mm.
    slack: f64,
    /// X's and Y's limits.
    axes: [AxisLimit; 2],
}

impl HopTime {
    /// The hop time of `profile`.
    pub fn of(profile: &MachineProfile) -> HopTime {
        let cap = profile.pen.travel_accel_mm_s2;
        let accel = path_accel(profile, cap);
        let feed = profile.pen.travel_feed_mm_s;
        let servo = profile.pen.uses_servo();
        // A servo's blocks are stops (its Z feed is bookkeeping only), whatever the curve model says of Z joins.
        let v_end = if servo {
            0.0
        } else if z_joins_may_curve(profile) {
            feed.min(profile.axes.z.max_feed_mm_s)
        } else {
            hop_corner_speed(profile, accel)
        };
        let tilt = if servo { 1.0 } else { (2.0 * crate::motion::hop::rise_slope(profile)).hypot(1.0) };
        let axis = |a: &crate::config::profile::AxisProfile| AxisLimit {
            top: a.max_feed_mm_s.min(feed) * tilt,
            accel: cap.map_or(a.max_accel_mm_s2, |c| a.max_accel_mm_s2.min(c)) * tilt,
            slack: 2.0 / a.steps_per_mm,
        };
        let (x, y) = (&profile.axes.x, &profile.axes.y);
        HopTime {
            v_end,
            feed,
            accel,
            slack: 2.0 * (1.0 / x.steps_per_mm).hypot(1.0 / y.steps_per_mm),
            axes: [axis(x), axis(y)],
        }
    }

    /// The least time of a hop of `dx` × `dy` mm (signs ignored): the largest of X's, Y's and the path's terms.
    pub fn seconds(&self, dx: f64, dy: f64) -> f64 {
        let along =
            |d: f64, a: &AxisLimit| fastest_piece((d.abs() - a.slack).max(0.0), self.v_end, self.v_end, a.top, a.accel);
        self.along_path(dx.hypot(dy)).max(along(dx, &self.axes[0])).max(along(dy, &self.axes[1]))
    }

    /// The path's term alone: the least time of a hop at least `d` mm long in any direction (the least of
    /// [`seconds`](Self::seconds) over the hops of that length). Non-decreasing in `d`.
    pub fn along_path(&self, d: f64) -> f64 {
        fastest_piece((d - self.slack).max(0.0), self.v_end, self.v_end, self.feed, self.accel)
    }
}

impl crate::optimize::hop_cost::HopCost for HopTime {
    fn cost(&self, dx: f64, dy: f64) -> f64 {
        self.seconds(dx, dy)
    }

    fn along(&self, d: f64) -> f64 {
        self.along_path(d)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The servo kit: samples/servo-plotter.toml (the XY kit's axes, 80 steps/mm, 150 mm/s and 1500 mm/s² each,
    /// travel at 120 mm/s, a servo pen).
    fn servo_kit() -> MachineProfile {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../samples/servo-plotter.toml");
        MachineProfile::from_toml(&std::fs::read_to_string(&dir).unwrap(), "servo-plotter.toml").unwrap()
    }

    #[test]
    fn a_hop_along_x_takes_x_s_own_acceleration() {
        let p = servo_kit();
        assert!(p.pen.uses_servo());
        assert_eq!((p.axes.x.max_accel_mm_s2, p.axes.x.max_feed_mm_s, p.pen.travel_feed_mm_s), (1500.0, 150.0, 120.0));
        assert_eq!(p.pen.travel_accel_mm_s2, None);
        let hop = HopTime::of(&p);
        // 30 mm along X from rest to rest, less two X steps (0.025 mm): 29.975 mm at X's 1500 mm/s² up to the
        // 120 mm/s travel feed: ramps of 120²/1500 = 9.6 mm in all, 0.16 s; cruise 20.375 mm at 120 mm/s,
        // 0.169 79 s: 0.329 79 s. The path's term alone (the diagonal's 2121.3 mm/s², 30 mm less two step
        // diagonals, 29.9646 mm): ramps of 6.788 mm, 0.113 14 s, cruise 0.193 14 s: 0.306 27 s, which is all the
        // bound took before.
        let t = hop.seconds(30.0, 0.0);
        assert!((t - 0.329_79).abs() < 1e-5, "{t}");
        assert!((hop.along_path(30.0) - 0.306_27).abs() < 1e-5, "{}", hop.along_path(30.0));
        // Direction does not matter, nor sign, nor which axis (Y has the same limits).
        assert_eq!(hop.seconds(-30.0, 0.0), t);
        assert_eq!(hop.seconds(0.0, 30.0), t);
    }

    #[test]
    fn a_30_by_40_diagonal_is_bounded_by_its_path_at_the_travel_feed() {
        let hop = HopTime::of(&servo_kit());
        // Y covers 40 − 0.025 = 39.975 mm at 1500 mm/s² up to 120 mm/s: 0.16 s of ramps (9.6 mm), 30.375 mm at
        // 120 mm/s, 0.253 13 s: 0.413 13 s. X's 29.975 mm take 0.329 79 s (above). The path, 50 − 0.0354 =
        // 49.9646 mm at 2121.3 mm/s²: 0.113 14 s of ramps (6.788 mm) and 43.176 mm cruising, 0.359 80 s:
        // 0.472 94 s, the largest: a diagonal moves both axes at once and the path's feed limits it.
        let t = hop.seconds(30.0, 40.0);
        assert!((t - 0.472_94).abs() < 1e-5, "{t}");
        assert_eq!(t, hop.along_path(50.0));
        // A 30 × 4 mm hop: X's term 0.329 79 s is above the path's (30.27 mm at the diagonal's acceleration).
        let t = hop.seconds(30.0, 4.0);
        assert!((t - 0.329_79).abs() < 1e-5, "{t}");
        assert!(hop.along_path(30f64.hypot(4.0)) < t - 0.02);
    }

    #[test]
    fn short_hops_are_triangles_and_never_fall_as_either_distance_grows() {
        let hop = HopTime::of(&servo_kit());
        // 2 mm along X: 1.975 mm from rest to rest at 1500 mm/s², never reaching the feed: 2·√(1.975/1500) =
        // 0.072 572 s.
        assert!((hop.seconds(2.0, 0.0) - 0.072_572).abs() < 1e-6, "{}", hop.seconds(2.0, 0.0));
        // Within the rounding slack: nothing is certain.
        assert_eq!(hop.seconds(0.02, 0.02), 0.0);
        let mut last = 0.0;
        for i in 0..200 {
            let x = f64::from(i) * 0.37;
            let t = hop.seconds(x, 7.0);
            assert!(t >= last, "{x}: {t} < {last}");
            last = t;
        }
    }

    #[test]
    fn a_z_pen_s_axes_allow_for_the_hop_s_tilt() {
        // The XY kit (a Z pen, the curve model on): its hops start and end at up to Z's 25 mm/s, and X's limits
        // count √(1 + 4s²) higher for the slope s = 0.051 67 of its climb: 1.005 32.
        let p = MachineProfile::default_plotter();
        let s = crate::motion::hop::rise_slope(&p);
        assert!((s - 0.051_67).abs() < 1e-5, "{s}");
        let k = (1.0 + 4.0 * s * s).sqrt();
        let hop = HopTime::of(&p);
        let by_hand = fastest_piece(30.0 - 2.0 / 80.0, 25.0, 25.0, 120.0 * k, 1500.0 * k);
        assert_eq!(hop.seconds(30.0, 0.0), by_hand);
        // 29.975 mm from 25 to 120·k = 120.639 mm/s at 1507.99 mm/s²: ramps 2·(14 553.8 − 625)/3015.98 =
        // 9.2367 mm in all, 2·95.639/1507.99 = 0.126 84 s; cruise 20.738 mm, 0.171 90 s: 0.298 75 s.
        assert!((by_hand - 0.298_75).abs() < 2e-5, "{by_hand}");
    }
}
