//! Pen-up hops that overlap the pen's lift and drop with the travel (Z pens).
//!
//! A hop from the end of one stroke to the start of the next used to be: lift the pen to the pen-up height and
//! settle, travel, drop the pen and settle — the Z moves and both settles on the critical path. The tip is clear
//! of the paper long before the pen-up height, at `pen.clearance_mm` above the pen-down height, so a hop is now:
//!
//! 1. a Z-only rise from the paper to the clearance height (the plan's `PenUp` block; no settle: nothing waits
//!    for the pen to stop rising),
//! 2. the XY travel as straight XY+Z blocks ([`travel_waypoints`]) along which Z keeps rising towards the pen-up
//!    height and comes back down to the clearance height at the destination — on a short hop it peaks lower,
//! 3. a Z-only drop from the clearance height to the paper and the settle dwell (as before).
//!
//! Z changes along the travel at a fixed slope `s` (Z mm per XY mm, [`rise_slope`]) chosen so that the travel is
//! never slower than a flat one: the bend where the slope changes (at most `2·atan s` at a peak) is taken at the
//! travel feed under junction deviation (`v² = a·δ·cos(φ/2)/(1 − cos(φ/2))` for a turn φ, so
//! `tan(φ/2) ≤ tan(acos(F²/(F² + aδ)))`), Z's own feed and acceleration limits never bind (`s ≤ v_z/F`,
//! `s ≤ a_z/a_xy`), with a margin for the rounding of the vertices to steps. The height profile along the travel
//! (distance `d` of `L`) is `min(top, h₀ + s·d, h₁ + s·(L − d))` — a rise from the start height `h₀`, a plateau at
//! the pen-up height `top` when the hop is long enough, and a descent to the end height `h₁` (the clearance height,
//! or higher when a hop that starts at the pen-up height is too short to come down at slope `s`; the final drop
//! then starts from there). It is concave and never below the clearance height, so the stepped Z (within half a
//! step of the line, Bresenham) never dips below it either.
//!
//! Servo pens have no Z to blend; their equivalent is timing, planned in [`crate::motion::plan`].

use crate::MachineProfile;
use crate::geometry::steps::{StepPos, round_steps};

/// Safety factor on the slope for the rounding of the vertices to steps.
const SLOPE_MARGIN: f64 = 0.8;

/// The Z slope of an overlapped hop (Z mm per XY mm) on `profile`: see the module docs.
pub fn rise_slope(profile: &MachineProfile) -> f64 {
    let f = profile.pen.travel_feed_mm_s;
    let a_xy = profile.axes.x.max_accel_mm_s2.min(profile.axes.y.max_accel_mm_s2);
    let ad = a_xy * profile.motion.junction_deviation_mm;
    let half_turn = (f * f / (f * f + ad)).clamp(-1.0, 1.0).acos();
    let z = &profile.axes.z;
    let s = half_turn.tan().min(z.max_feed_mm_s / f).min(z.max_accel_mm_s2 / a_xy);
    SLOPE_MARGIN * s
}

/// The Z heights of a hop, in Z steps: the pen-down height, the clearance height and the pen-up height.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct HopHeights {
    /// The pen on the paper.
    pub down: i32,
    /// The tip just clear of the paper: `clearance_mm` above `down` (towards `up`), at most `up`.
    pub clear: i32,
    /// The pen-up height.
    pub up: i32,
}

impl HopHeights {
    /// The heights for a pen whose down height is `down` (steps), with the profile's pen-up height `up` and
    /// clearance.
    pub fn new(profile: &MachineProfile, down: i32, up: i32) -> HopHeights {
        let c = round_steps(profile.pen.clearance_mm * profile.axes.z.steps_per_mm).unwrap_or(i32::MAX).max(1);
        let span = up.abs_diff(down);
        let c = i32::try_from(span.min(c.unsigned_abs())).unwrap_or(i32::MAX);
        let clear = if up >= down { down + c } else { down - c };
        HopHeights { down, clear, up }
    }

    /// How far `z` is above the clearance height (towards the pen-up height), steps.
    fn above_clear(&self, z: i32) -> i64 {
        let d = i64::from(z) - i64::from(self.clear);
        if self.up >= self.down { d } else { -d }
    }

    /// The Z step `h` steps above the clearance height.
    fn at(&self, h: i64) -> i32 {
        let z = if self.up >= self.down { i64::from(self.clear) + h } else { i64::from(self.clear) - h };
        i32::try_from(z).unwrap_or(self.up)
    }

    /// Whether Z step `z` is below the clearance height (between it and the paper, or under the paper).
    pub fn below_clear(&self, z: i32) -> bool {
        self.above_clear(z) < 0
    }
}

/// The block ends `[x, y, z]` (steps) of the travel from `from` (XY and a Z at or above the clearance height) to
/// `to`, Z following the profile of the module docs; empty when XY does not move. The last end is at `to`, at the
/// clearance height or (a short hop from higher up) above it.
pub fn travel_waypoints(profile: &MachineProfile, from: [i32; 3], to: StepPos, h: HopHeights) -> Vec<[i32; 3]> {
    let (sx, sy, sz) = (profile.axes.x.steps_per_mm, profile.axes.y.steps_per_mm, profile.axes.z.steps_per_mm);
    let (dx, dy) = (f64::from(to.x) - f64::from(from[0]), f64::from(to.y) - f64::from(from[1]));
    let len = (dx / sx).hypot(dy / sy);
    if dx == 0.0 && dy == 0.0 {
        return Vec::new();
    }
    let s = rise_slope(profile);
    // Heights above the clearance height, mm.
    #[allow(clippy::cast_precision_loss, reason = "step counts are far below 2^52")]
    let mm = |steps: i64| steps as f64 / sz;
    let top = mm(h.above_clear(h.up)).max(0.0);
    let h0 = mm(h.above_clear(from[2])).clamp(0.0, top);
    let h1 = (h0 - s * len).max(0.0);
    // The bends: end of the rise and start of the descent, or the peak where they meet.
    let (d1, d2) = ((top - h0) / s, len - (top - h1) / s);
    let mut bends: Vec<(f64, f64)> = if d1 < d2 {
        vec![(d1, top), (d2, top)]
    } else {
        let peak = ((h1 - h0 + s * len) / (2.0 * s)).clamp(0.0, len);
        vec![(peak, h0 + s * peak)]
    };
    bends.retain(|(d, _)| *d > 0.0 && *d < len);
    bends.push((len, h1));
    let mut out: Vec<[i32; 3]> = Vec::with_capacity(bends.len());
    let mut last = from;
    for (d, height) in bends {
        let t = d / len;
        let end = d >= len;
        // Bends round down and the end up, so that no part is steeper than `s` (except by the XY rounding).
        let z_steps = if end { (height * sz).ceil() } else { (height * sz).floor() };
        let z = h.at(round_steps(z_steps).map_or(0, i64::from));
        let p = if end {
            [to.x, to.y, z]
        } else {
            [from[0] + round_steps(dx * t).unwrap_or(0), from[1] + round_steps(dy * t).unwrap_or(0), z]
        };
        if p == last {
            continue;
        }
        // A bend that rounded to the height of the parts before and after it is no bend.
        let before = if out.len() >= 2 { out[out.len() - 2][2] } else { from[2] };
        if out.last().is_some_and(|b| b[2] == z && before == z) {
            out.pop();
        }
        out.push(p);
        last = p;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn kit() -> MachineProfile {
        MachineProfile::default_plotter()
    }

    #[test]
    fn the_kits_slope_keeps_the_travel_feed_through_the_bends() {
        let p = kit();
        // F = 120 mm/s, a = 1500 mm/s², δ = 0.02 mm: cos(φ/2) = 14400/14430, tan(acos(·)) = 0.064 56; Z allows
        // 25/120 and 500/1500, so the junction bound holds; × 0.8.
        let c: f64 = 14400.0 / 14430.0;
        let expect = 0.8 * c.acos().tan();
        assert!((rise_slope(&p) - expect).abs() < 1e-12, "{}", rise_slope(&p));
        assert!((expect - 0.051_65).abs() < 1e-4);
    }

    #[test]
    fn heights_follow_the_clearance_capped_at_the_pen_up_height() {
        let mut p = kit();
        // 400 steps/mm: 1 mm clearance is 400 steps above the paper.
        assert_eq!(HopHeights::new(&p, 0, 1600), HopHeights { down: 0, clear: 400, up: 1600 });
        // A Z axis whose pen-up height is below the paper height (inverted): clearance counts downwards.
        assert_eq!(HopHeights::new(&p, 1600, 0).clear, 1200);
        p.pen.clearance_mm = 9.0;
        assert_eq!(HopHeights::new(&p, 400, 1600).clear, 1600);
        let h = HopHeights::new(&kit(), 0, 1600);
        assert!(h.below_clear(399) && !h.below_clear(400) && !h.below_clear(1600));
    }

    #[test]
    fn a_long_hop_plateaus_at_the_pen_up_height_a_short_one_peaks_lower() {
        let p = kit();
        let h = HopHeights::new(&p, 0, 1600);
        let s = rise_slope(&p);
        // 200 mm along X at 80 steps/mm from the clearance height: rise 3 mm over 3/s mm, plateau, descend.
        let w = travel_waypoints(&p, [0, 0, 400], StepPos::new(16_000, 0), h);
        let run = 3.0 / s;
        #[allow(clippy::cast_possible_truncation, reason = "small values")]
        let r = (run * 80.0).round() as i32;
        assert_eq!(w, vec![[r, 0, 1600], [16_000 - r, 0, 1600], [16_000, 0, 400]]);
        // 10 mm: a peak in the middle, 5 mm · s above the clearance height (rounded down: 103.3 steps → 103).
        let w = travel_waypoints(&p, [0, 0, 400], StepPos::new(800, 0), h);
        #[allow(clippy::cast_possible_truncation, reason = "small values")]
        let peak = 400 + (5.0 * s * 400.0).floor() as i32;
        assert_eq!(peak, 503);
        assert_eq!(w, vec![[400, 0, peak], [800, 0, 400]]);
        // From the pen-up height over 10 mm: it cannot come down 3 mm at slope s, so it ends 10 mm · s lower
        // (206.6 steps, rounded down: the end rounds up).
        let w = travel_waypoints(&p, [0, 0, 1600], StepPos::new(0, 800), h);
        assert_eq!(w, vec![[0, 800, 1600 - 206]]);
        // 0.05 mm: the peak (0.0013 mm, half a Z step) rounds to the clearance height: one flat block.
        assert_eq!(travel_waypoints(&p, [0, 0, 400], StepPos::new(4, 0), h), vec![[4, 0, 400]]);
        // No XY motion, no travel.
        assert!(travel_waypoints(&p, [5, 5, 400], StepPos::new(5, 5), h).is_empty());
        // Every waypoint is at or above the clearance height.
        for to in [StepPos::new(3, 1), StepPos::new(-7000, 123), StepPos::new(40, -4000)] {
            let w = travel_waypoints(&p, [0, 0, 400], to, h);
            assert!(w.iter().all(|q| !h.below_clear(q[2])), "{w:?}");
            assert_eq!(w.last().map(|q| [q[0], q[1]]), Some([to.x, to.y]));
        }
    }
}
