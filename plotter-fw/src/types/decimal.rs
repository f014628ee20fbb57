//! Fixed-point decimal output of floats for replies (`M114`, status reports, temperatures) without `core`'s float
//! formatting machinery.
//!
//! `core::fmt` prints floats by exact decimal expansion (Grisu with a Dragon4 fallback and their power-of-ten
//! tables): about 10 KiB of flash on a Cortex-M4 — a sixth of the board budget — for replies that only ever need a
//! fixed number of decimals. [`Decimal`] scales by the power of ten and rounds half to even, then prints two
//! integers. For an `f32` with up to three decimals the scaling is exact (24 mantissa bits × 10 bits of 1000 fit
//! in an `f64`), so the digits are exactly `core`'s; for larger scales or `f64` input they can differ only in the
//! last digit of a value within an ulp of a rounding half.

use core::fmt;

/// `value` printed with `decimals` digits after the point (at most 6), like `format!("{value:.decimals$}")`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Decimal {
    value: f64,
    decimals: u8,
}

impl Decimal {
    /// `value` with `decimals` digits after the point (clamped to 6).
    pub fn new(value: impl Into<f64>, decimals: u8) -> Self {
        Decimal { value: value.into(), decimals: decimals.min(6) }
    }
}

impl fmt::Display for Decimal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let v = self.value;
        if v.is_nan() {
            return f.write_str("NaN");
        }
        if v.is_sign_negative() {
            f.write_str("-")?;
        }
        let scale = 10u64.pow(u32::from(self.decimals));
        // Scales up to 10^6: exact in f64.
        #[allow(clippy::cast_precision_loss)]
        let s = v.abs() * scale as f64;
        // A reading beyond 2^63 / 10^6 is nothing a reply ever holds: printed as infinite rather than wrapped.
        if s.is_infinite() || s >= 9.0e18 {
            return f.write_str("inf");
        }
        // In range and non-negative (checked above): truncation is the floor.
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss, clippy::cast_precision_loss)]
        let scaled = {
            let whole = s as u64;
            let frac = s - whole as f64;
            if frac > 0.5 || (frac == 0.5 && whole % 2 == 1) { whole + 1 } else { whole }
        };
        write!(f, "{}", scaled / scale)?;
        if self.decimals > 0 {
            write!(f, ".{:0width$}", scaled % scale, width = usize::from(self.decimals))?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::Decimal;
    use std::format;

    #[test]
    fn prints_fixed_decimals() {
        assert_eq!(format!("{}", Decimal::new(10.0f32, 3)), "10.000");
        assert_eq!(format!("{}", Decimal::new(-3.5f32, 3)), "-3.500");
        assert_eq!(format!("{}", Decimal::new(-0.0f32, 2)), "-0.00");
        assert_eq!(format!("{}", Decimal::new(209.996f32, 2)), "210.00");
        assert_eq!(format!("{}", Decimal::new(1.23456f64, 4)), "1.2346");
        assert_eq!(format!("{}", Decimal::new(7.6f32, 0)), "8");
        assert_eq!(format!("{}", Decimal::new(123.456f64, 9)), "123.456000");
        assert_eq!(format!("{}", Decimal::new(f32::NAN, 3)), "NaN");
        assert_eq!(format!("{}", Decimal::new(f64::INFINITY, 3)), "inf");
        assert_eq!(format!("{}", Decimal::new(f64::NEG_INFINITY, 3)), "-inf");
    }

    #[test]
    fn exact_halves_round_to_even_like_the_standard_formatter() {
        // 5 steps at 80 steps/mm = 0.0625 mm exactly: the standard formatter gives 0.062 (half to even).
        assert_eq!(format!("{}", Decimal::new(0.0625f32, 3)), "0.062");
        assert_eq!(format!("{}", Decimal::new(0.1875f32, 3)), "0.188");
        assert_eq!(format!("{}", Decimal::new(2.5f32, 0)), "2");
        assert_eq!(format!("{}", Decimal::new(-1.125f32, 2)), "-1.12");
    }

    #[test]
    fn agrees_with_the_standard_formatter_on_step_positions() {
        // Positions a status report shows: step counts over steps/mm, as the firmware computes them in f32.
        for spm in [80.0f32, 93.0, 400.0, 6.25] {
            for steps in (-200_000i32..200_000).step_by(331) {
                #[allow(clippy::cast_precision_loss)]
                let mm = steps as f32 / spm;
                assert_eq!(format!("{}", Decimal::new(mm, 3)), format!("{mm:.3}"), "{steps} steps at {spm}/mm");
                assert_eq!(format!("{}", Decimal::new(mm, 2)), format!("{mm:.2}"), "{steps} steps at {spm}/mm");
            }
        }
    }
}
