//! Positive rational ratios for curves that close only after several turns (roulettes, roses).
//!
//! A ratio is given as a fraction `a/b` or as a decimal. A decimal is turned into the fraction with the smallest
//! denominator within `1e-9` (relative) of it, found with the continued-fraction expansion: its convergents are the
//! best rational approximations, so the first convergent within the tolerance has the smallest possible
//! denominator among them. A curve whose ratio reduces to `a/b` closes after `b` turns; if that is more than the
//! allowed number of turns (or no convergent comes close enough), the caller reports the ratio as non-closing.

/// Relative tolerance for reading a decimal as a fraction.
const DECIMAL_TOLERANCE: f64 = 1e-9;

/// A reduced positive fraction `num / den`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Ratio {
    /// Numerator, ≥ 1.
    pub num: u64,
    /// Denominator, ≥ 1, coprime with `num`.
    pub den: u64,
}

/// Why a ratio could not be read.
#[derive(Debug, Clone, PartialEq)]
pub enum RatioError {
    /// Not a number or fraction, or not positive and finite.
    Invalid(String),
    /// An exact fraction whose reduced denominator exceeds the turn limit.
    TooManyTurns(u64),
    /// A decimal with no fraction of denominator ≤ the limit within tolerance.
    NoCloseFraction,
}

impl Ratio {
    /// The fraction's value.
    #[allow(clippy::cast_precision_loss)] // values are user-sized ratios; rounding to f64 is the intent
    pub fn value(self) -> f64 {
        self.num as f64 / self.den as f64
    }

    /// Read `text` (`a/b` or a decimal) as a reduced fraction with denominator at most `max_den`.
    ///
    /// # Errors
    /// [`RatioError`] saying whether the text is invalid, or needs a larger denominator than `max_den`.
    pub fn parse(text: &str, max_den: u64) -> Result<Ratio, RatioError> {
        let text = text.trim();
        if let Some((a, b)) = text.split_once('/') {
            let parse = |s: &str| {
                s.trim()
                    .parse::<u64>()
                    .ok()
                    .filter(|&v| v > 0)
                    .ok_or_else(|| RatioError::Invalid(format!("{s:?} is not a positive whole number")))
            };
            let (a, b) = (parse(a)?, parse(b)?);
            let g = gcd(a, b);
            let r = Ratio { num: a / g, den: b / g };
            return if r.den > max_den { Err(RatioError::TooManyTurns(r.den)) } else { Ok(r) };
        }
        let v: f64 = text.parse().map_err(|_| RatioError::Invalid("not a number or fraction a/b".to_string()))?;
        if !(v.is_finite() && v > 0.0) {
            return Err(RatioError::Invalid("must be positive".to_string()));
        }
        if !(1e-12..=1e12).contains(&v) {
            return Err(RatioError::Invalid("out of range".to_string()));
        }
        best_fraction(v, max_den).ok_or(RatioError::NoCloseFraction)
    }
}

/// The convergent of `v`'s continued fraction with the smallest denominator ≤ `max_den` within
/// [`DECIMAL_TOLERANCE`] of `v`.
fn best_fraction(v: f64, max_den: u64) -> Option<Ratio> {
    // Convergents h/k: h_n = a_n h_{n-1} + h_{n-2}, likewise k.
    let (mut h0, mut h1) = (0u64, 1u64);
    let (mut k0, mut k1) = (1u64, 0u64);
    let mut x = v;
    for _ in 0..64 {
        let a = x.floor();
        if !(0.0..1e15).contains(&a) {
            return None;
        }
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)] // 0 ≤ a < 1e15, checked above
        let ai = a as u64;
        let h = ai.checked_mul(h1)?.checked_add(h0)?;
        let k = ai.checked_mul(k1)?.checked_add(k0)?;
        if k > max_den {
            return None;
        }
        (h0, h1, k0, k1) = (h1, h, k1, k);
        let r = Ratio { num: h, den: k };
        if h > 0 && (r.value() - v).abs() <= DECIMAL_TOLERANCE * v.max(1.0) {
            return Some(r);
        }
        let frac = x - a;
        if frac <= 0.0 {
            return None;
        }
        x = 1.0 / frac;
    }
    None
}

fn gcd(mut a: u64, mut b: u64) -> u64 {
    while b != 0 {
        (a, b) = (b, a % b);
    }
    a
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fractions_reduce() {
        assert_eq!(Ratio::parse("6/4", 100), Ok(Ratio { num: 3, den: 2 }));
        assert_eq!(Ratio::parse(" 3 ", 100), Ok(Ratio { num: 3, den: 1 }));
        assert_eq!(Ratio::parse("1000/999", 100), Err(RatioError::TooManyTurns(999)));
        assert!(matches!(Ratio::parse("0/3", 100), Err(RatioError::Invalid(_))));
        assert!(matches!(Ratio::parse("-2", 100), Err(RatioError::Invalid(_))));
        assert!(matches!(Ratio::parse("abc", 100), Err(RatioError::Invalid(_))));
    }

    #[test]
    fn decimals_find_smallest_denominator() {
        assert_eq!(Ratio::parse("2.5", 100), Ok(Ratio { num: 5, den: 2 }));
        assert_eq!(Ratio::parse("0.375", 100), Ok(Ratio { num: 3, den: 8 }));
        assert_eq!(Ratio::parse("1.6666666666666667", 100), Ok(Ratio { num: 5, den: 3 }));
        // π is not within 1e-9 of any fraction with a denominator ≤ 1000.
        assert_eq!(Ratio::parse("3.141592653589793", 1000), Err(RatioError::NoCloseFraction));
        // √2 to 4 digits is exactly 14142/10000 = 7071/5000: too many turns for a limit of 100.
        assert_eq!(Ratio::parse("1.4142", 100), Err(RatioError::NoCloseFraction));
        assert_eq!(Ratio::parse("1.4142", 5000), Ok(Ratio { num: 7071, den: 5000 }));
    }

    #[test]
    fn random_fractions_round_trip() {
        for num in 1..60u64 {
            for den in 1..60u64 {
                let g = gcd(num, den);
                #[allow(clippy::cast_precision_loss)]
                let v = num as f64 / den as f64;
                let r = Ratio::parse(&v.to_string(), 100).unwrap();
                assert_eq!(r, Ratio { num: num / g, den: den / g }, "{num}/{den}");
            }
        }
    }
}
