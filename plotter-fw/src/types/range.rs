//! Representable numbers: every conversion from a G-code value (or a host step block) to a machine target is
//! checked here, so that no input can overflow the firmware's arithmetic, wrap a target around and flip a move's
//! direction, or saturate a move into something other than what was asked.
//!
//! # The bounds and why
//! - **Positions** (machine coordinates of a queued target, steps) stay within ±[`MAX_POSITION_STEPS`] = ±2³⁰:
//!   the stepper counts positions in `i32`, so the difference of two targets (a move) then always fits `i32` and
//!   the position can never wrap while a move runs (2³⁰ steps is 13 km at 80 steps/mm; even an extruder feeding
//!   100 m of filament at 400 steps/mm stays far below it).
//! - **One move** has at most [`MAX_MOVE_EVENTS`] = 2²⁴ step events (major-axis steps): the stepper evaluates
//!   its time profile in `f32`, whose 24-bit mantissa counts events exactly up to there, and the Bresenham error
//!   terms (`u32`) stay far from overflow. It is also the host frame's range (±2²³ per axis).
//! - **One move lasts** at most [`MAX_MOVE_SECONDS`]: the stepper times a block in `u32` ticks of 1 µs (71.6
//!   minutes); a move needing longer (a huge distance at a tiny feed) would have its step times saturate, so it
//!   is refused, with half of that range kept as margin.
//! - **Intermediate values** (millionths of a millimetre in `i64`, inch conversion, offsets) use checked
//!   arithmetic; an overflow is a refusal, never a wrap.
//!
//! A value outside a bound is answered `error:13 number out of range: <what>` ([`crate::errors::ErrorCode`]);
//! nothing is queued or changed for that line, homed or not.

use crate::step_block::TICK_HZ;

/// Fixed-point scale of the numbers the G-code parser reads ([`crate::gcode`]): 1 unit = 1 000 000, so a length
/// is kept in exact millionths of a millimetre.
pub const MICRO: i64 = 1_000_000;

/// Largest magnitude of a target position, steps.
pub const MAX_POSITION_STEPS: i32 = 1 << 30;

/// Most step events (steps of the axis that moves most) in one move.
pub const MAX_MOVE_EVENTS: u32 = 1 << 24;

/// Longest time one move may take, seconds (half the stepper's `u32` tick range).
pub const MAX_MOVE_SECONDS: f64 = (u32::MAX / 2) as f64 / TICK_HZ as f64;

/// Millionths of an inch → millionths of a millimetre (×25.4, rounded half away from zero); `None` on overflow.
pub fn inches_to_um(value: i64) -> Option<i64> {
    let scaled = value.checked_mul(254)?.checked_add(value.signum() * 5)?;
    Some(scaled / 10)
}

/// A position in millionths of a millimetre → whole steps at `steps_per_mm` (rounded half away from zero);
/// `None` when the result lies beyond ±[`MAX_POSITION_STEPS`].
pub fn um_to_steps(um: i64, steps_per_mm: f32) -> Option<i32> {
    // i64 → f64 loses nothing that matters: any |um| above 2^53 is far out of range anyway.
    #[allow(clippy::cast_precision_loss, reason = "magnitudes above 2^53 µm are rejected by the bound below")]
    let x = um as f64 * f64::from(steps_per_mm) / MICRO as f64;
    let r = if x >= 0.0 { x + 0.5 } else { x - 0.5 };
    // Also rejects NaN (a non-finite steps/mm is refused by the configuration check, but be safe).
    if r.is_nan() || r.abs() >= 2.0 * f64::from(MAX_POSITION_STEPS) {
        return None;
    }
    #[allow(clippy::cast_possible_truncation, reason = "|r| < 2^31 was checked just above; `as` truncates")]
    let r = r as i32;
    (r.unsigned_abs() <= MAX_POSITION_STEPS.unsigned_abs()).then_some(r)
}

/// Whether `target` (steps per axis) lies within ±[`MAX_POSITION_STEPS`] on every axis.
pub fn position_ok(target: &[i32]) -> bool {
    target.iter().all(|t| t.unsigned_abs() <= MAX_POSITION_STEPS.unsigned_abs())
}

/// Why a move cannot be represented.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MoveRange {
    /// The target lies beyond ±[`MAX_POSITION_STEPS`].
    Position,
    /// More than [`MAX_MOVE_EVENTS`] step events.
    Length,
    /// Longer than [`MAX_MOVE_SECONDS`] at its feed.
    Duration,
}

impl MoveRange {
    /// What the refusal names.
    pub const fn text(self) -> &'static str {
        match self {
            MoveRange::Position => "target beyond the machine's position range",
            MoveRange::Length => "move longer than one block can step",
            MoveRange::Duration => "move too slow to time (lasts over 35 minutes)",
        }
    }
}

/// Check a move of `steps` (per axis) whose step events run at `rate` events/s at most (the cruise rate; 0 is
/// taken as the stepper's minimum of 1/s).
pub fn check_move(steps: &[i32], rate: u32) -> Result<(), MoveRange> {
    let events = steps.iter().map(|s| s.unsigned_abs()).max().unwrap_or(0);
    if events > MAX_MOVE_EVENTS {
        return Err(MoveRange::Length);
    }
    // Accelerating from and to rest adds at most the time of the same distance at half the rate again; the margin
    // in MAX_MOVE_SECONDS (half the tick range) covers it.
    if f64::from(events) / f64::from(rate.max(1)) > MAX_MOVE_SECONDS {
        return Err(MoveRange::Duration);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inch_conversion_is_checked_and_rounds_half_away() {
        assert_eq!(inches_to_um(1_000_000), Some(25_400_000));
        // Values are millionths of the unit: 1 µin → 25.4 millionths of a mm → 25; 2 → 50.8 → 51; -3 → -76.2.
        assert_eq!(inches_to_um(1), Some(25));
        assert_eq!(inches_to_um(2), Some(51));
        assert_eq!(inches_to_um(-3), Some(-76));
        // 999999999999 inches in millionths: the parse limit; ×254 overflows i64.
        assert_eq!(inches_to_um(999_999_999_999_000_000), None);
        assert_eq!(inches_to_um(i64::MIN), None);
        assert_eq!(inches_to_um(36_000_000_000_000_000), Some(914_400_000_000_000_000));
    }

    #[test]
    fn steps_are_bounded() {
        assert_eq!(um_to_steps(10_000_000, 80.0), Some(800));
        assert_eq!(um_to_steps(-6_250, 80.0), Some(-1), "-0.5 step rounds away from zero");
        assert_eq!(um_to_steps(6_249, 80.0), Some(0));
        // 2^30 steps at 80 steps/mm = 13421772.8 mm.
        assert_eq!(um_to_steps(13_421_772_800_000, 80.0), Some(MAX_POSITION_STEPS));
        assert_eq!(um_to_steps(13_421_772_900_000, 80.0), None);
        assert_eq!(um_to_steps(-13_421_772_900_000, 80.0), None);
        assert_eq!(um_to_steps(i64::MAX, 80.0), None);
        assert_eq!(um_to_steps(i64::MIN, 0.001), None);
        assert_eq!(um_to_steps(1, f32::NAN), None);
    }

    #[test]
    fn moves_are_bounded_in_length_and_time() {
        assert_eq!(check_move(&[16_777_216, 0, 0, 0], 250_000), Ok(()));
        assert_eq!(check_move(&[0, -16_777_217, 0, 0], 250_000), Err(MoveRange::Length));
        // 2147 s of u32::MAX/2 ticks: 2147 events at 1 event/s fit, 2148 do not.
        assert_eq!(check_move(&[2147, 0, 0, 0], 1), Ok(()));
        assert_eq!(check_move(&[2148, 0, 0, 0], 1), Err(MoveRange::Duration));
        assert_eq!(check_move(&[2148, 0, 0, 0], 0), Err(MoveRange::Duration), "rate 0 runs at 1/s");
        assert!(position_ok(&[MAX_POSITION_STEPS, -MAX_POSITION_STEPS]));
        assert!(!position_ok(&[MAX_POSITION_STEPS + 1]));
        assert!(!position_ok(&[i32::MIN]));
    }
}
