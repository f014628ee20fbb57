//! How long a servo pen takes to leave and to reach the paper, from the servo's rate and travel.
//!
//! The servo's position is counted as the fraction `x` of its travel from the pen-up position (0) to the pen's
//! down position (1); the tip touches the paper while `x` is beyond `pen.contact_fraction` (`c`). The servo
//! moves by `rise` (lifting) or `fall` (lowering) per servo cycle and stops at its target:
//!
//! * on an EiBotBoard the cycle is the board's 24 ms servo refresh and the rates are the `[ebb]` slew rates
//!   (`pen_rate_up`/`pen_rate_down` pulse units per cycle, over the pulse distance between the two positions;
//!   0 moves in one cycle). The host does not know where in its cycle the board is, so a servo command's first
//!   move comes anywhere from one tick to one cycle after it: every time below is a window, and a margin of a
//!   millisecond each side covers the board's whole-millisecond rounding of the plan's times;
//! * on a GRBL servo build and on our firmware the servo is taken to turn at one steady rate from the moment
//!   it is commanded, the profile's up-to-down swing (`servo_up_deg` to `servo_down_deg`) in `settle_ms`; a
//!   pen-table pen with another down angle has its own travel at that rate. The cycle is one tick.
//!
//! A lift from the paper (`x` ≤ 1, taken as 1: the latest) has the tip clear once `x ≤ c`
//! ([`ServoTiming::clear_ticks`]). A drop commanded `D` ticks after a lift reverses the servo where the lift
//! has taken it (`x(D) = max(0, x₀ − n·rise)` after `n` lift moves) and the tip touches after `m` moves down,
//! the first `m` with `x(D) + m·fall > c` ([`ServoTiming::contact_window`]). The planner
//! ([`crate::motion::plan`]) lets the carriage arrive at the stroke's start by the earliest contact and starts
//! the line at the latest, so the tip lands on the stroke's first point.

use plotter_fw::TICK_HZ;

use crate::MachineProfile;
use crate::geometry::steps::StepStroke;

pub use crate::config::servo_sync::ServoSync;

/// Extra ticks each side of an EiBotBoard's times: its whole-millisecond delays and 40 µs intervals put each
/// command within half a millisecond of the plan's time.
const BOARD_MARGIN: u64 = 1000;

/// Slack on the fractions against rounding, in the direction that widens every window.
const EPS: f64 = 1e-9;

/// A servo pen's motion for one pen (its down position), in ticks: see the module docs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ServoTiming {
    /// Ticks per servo cycle.
    cycle: u64,
    /// Whether the cycle's phase is unknown (an EiBotBoard): each servo command's first move comes one tick to
    /// one cycle after it.
    phased: bool,
    /// Fraction of the travel per cycle when lifting.
    rise: f64,
    /// Fraction of the travel per cycle when lowering.
    fall: f64,
    /// Where the tip meets the paper, as a fraction of the travel.
    contact: f64,
    /// The profile's extra wait after the tip is clear, ticks (`pen.lift_delay_ms`).
    lift_delay: u64,
    /// The profile's extra wait after the tip touches, ticks (`pen.drop_delay_ms`).
    drop_delay: u64,
}

impl ServoTiming {
    /// The timing of `profile`'s servo for a pen whose down angle is `down_deg`.
    pub fn of(profile: &MachineProfile, down_deg: f64) -> ServoTiming {
        let timing = ServoTiming::of_servo(profile, down_deg);
        // Whole ticks, as the plan's dwells round them (the profile keeps each delay within 0..=10000 ms).
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss, reason = "at most 10^7 ticks, not negative")]
        let ticks = |ms: f64| (ms.max(0.0) * f64::from(TICK_HZ) / 1000.0).round() as u64;
        ServoTiming {
            lift_delay: ticks(profile.pen.lift_delay_ms),
            drop_delay: ticks(profile.pen.drop_delay_ms),
            ..timing
        }
    }

    /// The servo's own timing, without the profile's extra waits.
    fn of_servo(profile: &MachineProfile, down_deg: f64) -> ServoTiming {
        let contact = profile.pen.contact_fraction;
        let (up_deg, profile_down) = (profile.pen.servo_up_deg, profile.pen.servo_down_deg);
        if let Some(e) = profile.ebb {
            // The pen's pulse position, interpolated between the profile's as the EBB program sends it.
            let (u, d) = (f64::from(e.pen_up_position), f64::from(e.pen_down_position));
            let p = if (profile_down - up_deg).abs() < 1e-9 {
                d
            } else {
                (u + (down_deg - up_deg) / (profile_down - up_deg) * (d - u)).round().clamp(1.0, 65535.0)
            };
            let span = (p - u).abs();
            let per = |rate: u16| if rate == 0 || span <= 0.0 { 1.0 } else { f64::from(rate) / span };
            let cycle = u64::from(TICK_HZ) * 24 / 1000;
            let (rise, fall) = (per(e.pen_rate_up), per(e.pen_rate_down));
            return ServoTiming { cycle, phased: true, rise, fall, contact, lift_delay: 0, drop_delay: 0 };
        }
        // One rate both ways: the profile's swing in its settle time.
        let settle = profile.pen.settle_ms * f64::from(TICK_HZ) / 1000.0;
        let (swing, span) = ((profile_down - up_deg).abs(), (down_deg - up_deg).abs());
        let per_tick = if settle < 1.0 || span <= 0.0 { 1.0 } else { (swing / settle / span).min(1.0) };
        ServoTiming { cycle: 1, phased: false, rise: per_tick, fall: per_tick, contact, lift_delay: 0, drop_delay: 0 }
    }

    /// The ticks each side of a time that the board's rounding may move it by.
    fn margin(&self) -> u64 {
        if self.phased { BOARD_MARGIN } else { 0 }
    }

    /// Ticks from a lift command (the servo at its down position) until the tip is surely clear of the paper,
    /// and the profile's extra wait after that.
    pub fn clear_ticks(&self) -> u64 {
        let k = moves((1.0 - self.contact + EPS) / self.rise);
        k * self.cycle + self.margin() + self.lift_delay
    }

    /// How far down the servo surely is (`x`) after the line has been drawn for `ticks` from the latest contact:
    /// it goes on lowering from the contact fraction.
    pub fn pressed_after(&self, ticks: u64) -> f64 {
        let n = ticks.saturating_sub(self.margin()) / self.cycle;
        #[allow(clippy::cast_precision_loss, reason = "cycle counts are far below 2^52")]
        let x = self.contact + n as f64 * self.fall;
        x.min(1.0)
    }

    /// The earliest and the latest tick, counted from a drop command, at which the tip touches the paper (the
    /// latest with the profile's extra wait after the touch: the line starts then).
    /// `lifted` is `(D, x₀)`: the drop comes `D` ticks after a lift that started from a servo at least `x₀` down
    /// (and at most fully down); `None` for a servo at rest at its up position.
    pub fn contact_window(&self, lifted: Option<(u64, f64)>) -> (u64, u64) {
        let (x_hi, x_lo) = match lifted {
            None => (0.0, 0.0),
            Some((d, x0)) => {
                // Lift moves before the drop: one per cycle, the first one tick to one cycle after the lift.
                let m = self.margin();
                let (few, many) =
                    if self.phased { (d.saturating_sub(m) / self.cycle, (d + m).div_ceil(self.cycle)) } else { (d, d) };
                #[allow(clippy::cast_precision_loss, reason = "cycle counts are far below 2^52")]
                let at = |x: f64, n: u64| (x - n as f64 * self.rise).max(0.0);
                (at(1.0, few), at(x0.min(1.0), many))
            }
        };
        // Moves down until beyond the contact fraction: the first m with x + m·fall > c.
        let moves_from = |x: f64| whole((self.contact - x) / self.fall) + 1;
        let (m_first, m_last) = (moves_from(x_hi + EPS), moves_from((x_lo - EPS).max(0.0)));
        if self.phased {
            let earliest = ((m_first - 1) * self.cycle + 1).saturating_sub(self.margin());
            (earliest, m_last * self.cycle + self.margin() + self.drop_delay)
        } else {
            (m_first, m_last + self.drop_delay)
        }
    }

    /// The least a drop waits, after its one-tick command, before the line starts: the narrowest contact
    /// window (on a board of unknown phase at least one cycle and a margin less the command's tick; nothing for
    /// a servo of known timing), and the profile's extra wait after the touch.
    pub fn least_window(&self) -> u64 {
        (if self.phased { self.cycle + self.margin() - 1 } else { 0 }) + self.drop_delay
    }
}

/// The least time `stroke` takes to draw at `feed_mm_s`, ticks: its length at that feed.
pub(crate) fn min_draw_ticks(profile: &MachineProfile, stroke: &StepStroke, feed_mm_s: f64) -> u64 {
    let (sx, sy) = (profile.axes.x.steps_per_mm, profile.axes.y.steps_per_mm);
    let mm: f64 = stroke.moves.iter().map(|d| (f64::from(d.dx) / sx).hypot(f64::from(d.dy) / sy)).sum();
    // A drawing time in ticks, far inside u64.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let t = (mm / feed_mm_s.max(1e-9) * f64::from(TICK_HZ)).floor().max(0.0) as u64;
    t
}

/// `v` rounded up to a whole number of moves (0 for no distance).
fn moves(v: f64) -> u64 {
    // A count of servo moves or ticks, far inside u64.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let n = v.max(0.0).ceil() as u64;
    n
}

/// The whole moves in `v` (0 for none or less).
fn whole(v: f64) -> u64 {
    // As `moves`.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let n = v.max(0.0).floor() as u64;
    n
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(name: &str) -> MachineProfile {
        let path = format!("{}/../samples/{name}", env!("CARGO_MANIFEST_DIR"));
        MachineProfile::from_toml(&std::fs::read_to_string(&path).unwrap(), name).unwrap()
    }

    #[test]
    fn a_continuous_servo_moves_its_swing_in_the_settle_time() {
        // The kit: 90° up, 30° down, 150 ms for the 60°; contact at 0.7 of the way down.
        let p = sample("servo-plotter.toml");
        let s = ServoTiming::of(&p, 30.0);
        // Lift: clear after 0.3 × 150 ms = 45 ms (and the tick the rounding slack may add).
        assert!((45_000..=45_001).contains(&s.clear_ticks()), "{}", s.clear_ticks());
        // From rest at the up position: contact 0.7 × 150 ms = 105 ms after the drop command (the tick after).
        let (a, b) = s.contact_window(None);
        assert!(a == 105_000 && (105_000..=105_001).contains(&b), "{a} {b}");
        // Dropped 60 ms after a lift from fully down: the servo rose to 0.6 and touches again after 0.1 × 150 ms.
        let (a, b) = s.contact_window(Some((60_000, 1.0)));
        assert!((15_000..=15_002).contains(&a) && (15_000..=15_002).contains(&b), "{a} {b}");
        // A lift from 0.8 down reaches 0.4 by then: 0.3 × 150 ms to contact is the latest.
        let (_, b) = s.contact_window(Some((60_000, 0.8)));
        assert!((45_000..=45_002).contains(&b), "{b}");
        // The brush at 25°: 65° at the same 0.4 °/ms: 0.7 × 162.5 ms.
        let brush = ServoTiming::of(&p, 25.0);
        let (a, _) = brush.contact_window(None);
        assert!((113_749..=113_751).contains(&a), "{a}");
    }

    #[test]
    fn an_ebb_servo_moves_once_per_24_ms_at_its_slew_rate() {
        // AxiDraw V3: up 20641, down 15248 (5393 units), raise 1618 and lower 1079 per 24 ms cycle.
        let p = sample("axidraw-v3.toml");
        let s = ServoTiming::of(&p, p.pen.servo_down_deg);
        // Lift: 0.3 × 5393 = 1617.9 units: one move of 1618, at most one cycle after the command, + 1 ms margin.
        assert_eq!(s.clear_ticks(), 24_000 + 1000);
        // From the up position: 0.7 × 5393 = 3775.1 units, beyond it after 4 moves of 1079 (4316); the first one
        // tick to one cycle after the command: 3 × 24 ms + 1 tick .. 4 × 24 ms, and the margins.
        assert_eq!(s.contact_window(None), (72_001 - 1000, 96_000 + 1000));
        assert_eq!(s.least_window(), 24_000 + 1000 - 1);
        // Dropped 30 ms after a lift from down: 1 or 2 lift moves (x 0.69998 or 0.39996), then 1 or 2 moves down:
        // the tip may touch as soon as the board's first servo move, at the latest 2 cycles and the margin on.
        assert_eq!(s.contact_window(Some((30_000, 1.0))), (0, 2 * 24_000 + 1000));
    }

    #[test]
    fn the_profiles_delays_wait_after_the_clear_and_after_the_touch_not_in_the_swing() {
        // AxiDraw V3 with 40 ms after the lift and 70 ms after the drop: the servo's own times as above, then the
        // waits; the earliest contact (when the carriage must have arrived) does not move.
        let mut p = sample("axidraw-v3.toml");
        (p.pen.lift_delay_ms, p.pen.drop_delay_ms) = (40.0, 70.0);
        let s = ServoTiming::of(&p, p.pen.servo_down_deg);
        assert_eq!(s.clear_ticks(), 24_000 + 1000 + 40_000);
        assert_eq!(s.contact_window(None), (72_001 - 1000, 96_000 + 1000 + 70_000));
        assert_eq!(s.least_window(), 24_000 + 1000 - 1 + 70_000);
        // The kit's continuous servo: 45 ms to clear + 40; contact at 105 ms, the line at 105 + 70.
        let mut k = sample("servo-plotter.toml");
        (k.pen.lift_delay_ms, k.pen.drop_delay_ms) = (40.0, 70.0);
        let s = ServoTiming::of(&k, 30.0);
        assert!((85_000..=85_001).contains(&s.clear_ticks()), "{}", s.clear_ticks());
        let (a, b) = s.contact_window(None);
        assert!(a == 105_000 && (175_000..=175_001).contains(&b), "{a} {b}");
    }
}
