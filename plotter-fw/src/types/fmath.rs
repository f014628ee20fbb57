//! Deterministic float helpers for `no_std`.
//!
//! `core` has no `f32::sqrt` on stable, and the host and the firmware must compute **bit-identical** step times
//! (the host's time estimate is the stepper's own arithmetic, see [`crate::step_block`]). So the square root here is
//! built only from IEEE-754 addition, multiplication and division, which are correctly rounded on every platform
//! (x86-64 SSE and the Cortex-M4 FPU alike): the result depends on nothing but the input bits.

/// Square root of `x` (`x ≥ 0`; negative or NaN input gives 0).
///
/// Method: the classic exponent-halving bit trick gives a first guess within ~4 % (halving the biased exponent
/// of the IEEE representation halves the logarithm), then three Newton–Raphson steps `y ← (y + x/y)/2`, each
/// squaring the relative error (6 % → 2·10⁻³ → 2·10⁻⁶ → rounding level), i.e. within about two ulp of the root.
#[inline]
pub fn sqrt(x: f32) -> f32 {
    // Also rejects NaN (all comparisons false).
    if x.is_nan() || x <= 0.0 {
        return 0.0;
    }
    if x == f32::INFINITY {
        return x;
    }
    let mut y = f32::from_bits((x.to_bits() >> 1) + 0x1fbd_1df5);
    y = 0.5 * (y + x / y);
    y = 0.5 * (y + x / y);
    y = 0.5 * (y + x / y);
    y
}

/// Round a non-negative float to the nearest `u32` (halves away from zero), saturating at the range ends.
#[inline]
pub fn round_u32(x: f32) -> u32 {
    // `as` from float saturates (NaN → 0), which is exactly the clamping wanted here.
    #[allow(
        clippy::cast_possible_truncation,
        clippy::cast_sign_loss,
        reason = "float→int `as` saturates by definition"
    )]
    let r = (x + 0.5) as u32;
    r
}

/// Round to the nearest `i32` (halves away from zero), saturating.
#[inline]
pub fn round_i32(x: f64) -> i32 {
    let r = if x >= 0.0 { x + 0.5 } else { x - 0.5 };
    #[allow(clippy::cast_possible_truncation, reason = "float→int `as` saturates by definition")]
    let r = r as i32;
    r
}

/// Floor of a non-negative float as `u32`, saturating (negative → 0).
#[inline]
pub fn floor_u32(x: f32) -> u32 {
    #[allow(
        clippy::cast_possible_truncation,
        clippy::cast_sign_loss,
        reason = "float→int `as` truncates toward zero and saturates"
    )]
    let r = x as u32;
    r
}

/// `x` limited to `lo..=hi` (`lo ≤ hi`); NaN gives `lo`.
///
/// Unlike `f32::clamp` it carries no assertion whose message formats floats, which would link `core`'s float
/// formatting (about 10 KiB) into every board image; and a NaN (a failed computation) lands on the safe end.
#[inline]
pub fn clamp(x: f32, lo: f32, hi: f32) -> f32 {
    x.max(lo).min(hi)
}

#[cfg(test)]
mod tests {
    #[test]
    fn clamp_limits_and_sends_nan_to_the_low_end() {
        assert_eq!(super::clamp(5.0, 0.0, 2.0), 2.0);
        assert_eq!(super::clamp(-1.0, 0.0, 2.0), 0.0);
        assert_eq!(super::clamp(1.5, 0.0, 2.0), 1.5);
        assert_eq!(super::clamp(f32::NAN, 0.5, 2.0), 0.5);
    }

    use super::*;
    use proptest::prelude::*;

    #[test]
    fn exact_squares_and_edges() {
        assert_eq!(sqrt(0.0), 0.0);
        assert_eq!(sqrt(-4.0), 0.0);
        assert_eq!(sqrt(f32::NAN), 0.0);
        assert_eq!(sqrt(f32::INFINITY), f32::INFINITY);
        for v in [1.0f32, 4.0, 9.0, 1e6, 144.0] {
            assert!((sqrt(v) - v.sqrt()).abs() <= 2.0 * f32::EPSILON * v.sqrt(), "{v}");
        }
    }

    #[test]
    fn rounding_helpers() {
        assert_eq!(round_u32(2.5), 3);
        assert_eq!(round_u32(2.49), 2);
        assert_eq!(round_u32(-3.0), 0);
        assert_eq!(round_i32(-2.5), -3);
        assert_eq!(round_i32(2.4), 2);
        assert_eq!(floor_u32(7.99), 7);
    }

    proptest! {
        #[test]
        fn within_three_ulp(x in 1e-20f32..1e30f32) {
            let ours = sqrt(x);
            let exact = x.sqrt();
            prop_assert!((ours - exact).abs() <= 2.0 * f32::EPSILON * exact, "x={x} ours={ours} std={exact}");
        }
    }
}
