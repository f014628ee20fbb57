//! Thermistor inputs: ADC counts → resistance → temperature.
//!
//! The usual printer wiring: an NTC thermistor from the ADC pin to ground and a pull-up resistor from the pin to the
//! ADC reference, so `counts / full_scale = R / (R + R_pullup)` and `R = R_pullup · counts / (full_scale − counts)`.
//! A reading at either rail cannot be a working thermistor: at full scale the thermistor is open (broken wire,
//! unplugged — it would read colder than anything), at zero it is shorted (it would read hotter than anything).
//! Both are reported as such and make the safety checks trip (MINTEMP / MAXTEMP).
//!
//! Two curves, as boards usually give them:
//! - the **beta** model, `1/T = 1/T₀ + ln(R/R₀)/β` (datasheets give R₀ at T₀ = 25 °C and β);
//! - the **Steinhart–Hart** equation, `1/T = A + B·ln R + C·(ln R)³` (three fitted coefficients), more accurate over
//!   a wide range.
//!
//! Temperatures are in °C, the equations in kelvin.

/// 0 °C in kelvin.
pub const KELVIN: f32 = 273.15;

/// The resistance–temperature curve of a thermistor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Curve {
    /// Beta model: resistance `r0_ohm` at `t0_c`, and β in kelvin.
    Beta {
        /// Resistance at `t0_c`, Ω.
        r0_ohm: f32,
        /// Reference temperature, °C (usually 25).
        t0_c: f32,
        /// β, K.
        beta: f32,
    },
    /// Steinhart–Hart coefficients (R in Ω, T in K).
    SteinhartHart {
        /// A, 1/K.
        a: f32,
        /// B, 1/K.
        b: f32,
        /// C, 1/K.
        c: f32,
    },
}

/// A thermistor behind a pull-up on an ADC input.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Thermistor {
    /// The curve.
    pub curve: Curve,
    /// Pull-up resistor, Ω.
    pub pullup_ohm: f32,
    /// ADC full scale (4095 for 12 bits).
    pub adc_max: u16,
}

/// What a thermistor input says.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Reading {
    /// A temperature, °C.
    Celsius(f32),
    /// At full scale: the thermistor circuit is open.
    Open,
    /// At zero: the thermistor is shorted.
    Short,
}

impl Thermistor {
    /// The common 100 kΩ NTC (β = 3950 K at 25 °C) behind a 4.7 kΩ pull-up on a 12-bit ADC.
    pub const NTC_100K_3950: Thermistor = Thermistor {
        curve: Curve::Beta { r0_ohm: 100_000.0, t0_c: 25.0, beta: 3950.0 },
        pullup_ohm: 4700.0,
        adc_max: 4095,
    };

    /// The thermistor's resistance for `counts`, Ω; `None` at either rail.
    pub fn resistance(&self, counts: u16) -> Option<f32> {
        if counts == 0 || counts >= self.adc_max {
            return None;
        }
        let c = f32::from(counts);
        Some(self.pullup_ohm * c / (f32::from(self.adc_max) - c))
    }

    /// Temperature for a resistance, °C.
    pub fn celsius_at(&self, r_ohm: f32) -> f32 {
        let ln_r = libm::logf(r_ohm);
        let inv_t = match self.curve {
            Curve::Beta { r0_ohm, t0_c, beta } => 1.0 / (t0_c + KELVIN) + (ln_r - libm::logf(r0_ohm)) / beta,
            Curve::SteinhartHart { a, b, c } => a + b * ln_r + c * ln_r * ln_r * ln_r,
        };
        1.0 / inv_t - KELVIN
    }

    /// Convert an ADC reading.
    pub fn read(&self, counts: u16) -> Reading {
        if counts >= self.adc_max {
            return Reading::Open;
        }
        match self.resistance(counts) {
            None => Reading::Short,
            Some(r) => {
                let t = self.celsius_at(r);
                // A curve evaluated far outside its range can give nonsense; treat it as the rail it is near.
                if t.is_finite() {
                    Reading::Celsius(t)
                } else if counts > self.adc_max / 2 {
                    Reading::Open
                } else {
                    Reading::Short
                }
            }
        }
    }

    /// Check the values: positive resistances, a sensible ADC range, a curve that falls with temperature.
    pub fn validate(&self) -> Result<(), &'static str> {
        if !(self.pullup_ohm.is_finite() && self.pullup_ohm > 0.0) {
            return Err("pullup_ohm must be a positive number");
        }
        if self.adc_max < 255 {
            return Err("adc_max must be at least 255 (8-bit ADC)");
        }
        match self.curve {
            Curve::Beta { r0_ohm, t0_c, beta } => {
                if !(r0_ohm.is_finite() && r0_ohm > 0.0 && beta.is_finite() && beta > 0.0 && t0_c.is_finite()) {
                    return Err("beta curve needs positive r0_ohm and beta");
                }
                if t0_c + KELVIN <= 0.0 {
                    return Err("t0_c must be above absolute zero");
                }
            }
            Curve::SteinhartHart { a, b, c } => {
                if !(a.is_finite() && b.is_finite() && c.is_finite()) {
                    return Err("Steinhart-Hart coefficients must be numbers");
                }
                // An NTC over 10 Ω .. 1 MΩ: 1/T positive and rising with ln R (dT⁻¹/d ln R = B + 3C·ln²R > 0).
                let ok = [10.0f32, 1.0e6].iter().all(|&r| {
                    let l = libm::logf(r);
                    a + b * l + c * l * l * l > 0.0 && b + 3.0 * c * l * l > 0.0
                });
                if !ok {
                    return Err("Steinhart-Hart coefficients do not describe an NTC thermistor");
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn beta_curve_matches_hand_computed_values() {
        let t = Thermistor::NTC_100K_3950;
        // At the reference point: R = R0 exactly.
        assert!((t.celsius_at(100_000.0) - 25.0).abs() < 1e-3);
        // At 210 °C: R = 100k·exp(3950·(1/483.15 − 1/298.15)) = 626.45 Ω.
        assert!((t.celsius_at(626.5) - 210.0).abs() < 0.05, "{}", t.celsius_at(626.5));
        // ADC: 4095·626.5/(626.5 + 4700) = 481.7 counts → the resistance back within one count.
        let r = t.resistance(482).unwrap();
        assert!((r - 4700.0 * 482.0 / 3613.0).abs() < 1e-2);
        let Reading::Celsius(c) = t.read(482) else { panic!() };
        // 482 counts ↔ 209.95 °C by the same equations in f64.
        assert!((c - 209.947).abs() < 0.02, "{c}");
    }

    #[test]
    fn steinhart_hart_published_10k_coefficients() {
        // Widely published coefficients of a 10 kΩ NTC: 10 kΩ ≈ 25 °C (24.68 °C with these values).
        let t = Thermistor {
            curve: Curve::SteinhartHart { a: 1.009_249_5e-3, b: 2.378_405_4e-4, c: 2.019_202_7e-7 },
            pullup_ohm: 4700.0,
            adc_max: 4095,
        };
        assert!((t.celsius_at(10_000.0) - 24.68).abs() < 0.05, "{}", t.celsius_at(10_000.0));
        // 1/T = A + B·ln(3300) + C·ln³(3300) = 1.00925e-3 + 1.92691e-3 + 1.07375e-4 = 3.04353e-3 → 55.42 °C.
        assert!((t.celsius_at(3300.0) - 55.42).abs() < 0.05, "{}", t.celsius_at(3300.0));
        assert_eq!(t.validate(), Ok(()));
    }

    #[test]
    fn rails_are_open_and_short() {
        let t = Thermistor::NTC_100K_3950;
        assert_eq!(t.read(4095), Reading::Open);
        assert_eq!(t.read(0), Reading::Short);
        // Just inside the rails: extreme but finite temperatures.
        let Reading::Celsius(cold) = t.read(4094) else { panic!() };
        let Reading::Celsius(hot) = t.read(1) else { panic!() };
        assert!(cold < -40.0 && hot > 400.0, "{cold} {hot}");
    }

    #[test]
    fn bad_configs_are_refused() {
        let mut t = Thermistor::NTC_100K_3950;
        t.pullup_ohm = 0.0;
        assert!(t.validate().is_err());
        let t = Thermistor { curve: Curve::SteinhartHart { a: 1e-3, b: -2e-4, c: 0.0 }, ..Thermistor::NTC_100K_3950 };
        assert!(t.validate().is_err());
        assert_eq!(Thermistor::NTC_100K_3950.validate(), Ok(()));
    }
}
