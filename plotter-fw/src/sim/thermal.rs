//! The simulated printer's heaters: a first-order thermal model per heater behind a lagging, noisy thermistor, with
//! injectable faults. [`SimHeaters`] is the [`Heaters`] I/O the simulated firmware drives.
//!
//! # Model
//! The heated mass (hot-end block, bed plate) has heat capacity `C` and loses heat to the ambient air in proportion
//! to the temperature difference (`k`, plus `k_fan` more at full part-cooling fan):
//!
//! ```text
//! C·dT/dt = P·duty/255 − (k + k_fan·fan/255)·(T − T_amb)
//! ```
//!
//! With the duty constant over a step `h` this has the exact solution `T(h) = T∞ + (T(0) − T∞)·e^(−k·h/C)`,
//! `T∞ = T_amb + P·duty/(255·k)`, which is what [`SimHeaters::advance_to`] applies in steps of at most 10 ms. The
//! thermistor follows the mass with its own first-order lag `τ` (`dS/dt = (T − S)/τ`, the bead's contact), and each
//! reading adds Gaussian noise (an Irwin–Hall sum of twelve uniforms from a seeded xorshift generator, so runs
//! repeat). The reading is turned into ADC counts by the *physics* of the configured thermistor — the resistance
//! at the sensed temperature, solved in `f64` from the curve by bisection, behind the pull-up — independently of
//! the firmware's `f32` conversion back.
//!
//! # Faults
//! [`SimFault`]: the thermistor breaks open (full-scale counts) or shorts (zero counts), the heater cartridge falls
//! out of the block (its power no longer reaches the mass, the thermistor stays in), or the ADC stops delivering
//! conversions.

use std::vec::Vec;

use crate::hal::Heaters;
use crate::heater::{Heater, NUM_HEATERS};
use crate::thermal::ThermalConfig;
use crate::thermal::thermistor::{Curve, KELVIN, Thermistor};

/// Physical parameters of one heater.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeaterModel {
    /// Heater power at full duty, W.
    pub power_w: f64,
    /// Heat capacity of the heated mass, J/K.
    pub capacity_j_k: f64,
    /// Heat loss to ambient, W/K.
    pub loss_w_k: f64,
    /// Extra loss at full fan, W/K.
    pub fan_loss_w_k: f64,
    /// Ambient (and starting) temperature, °C.
    pub ambient_c: f64,
    /// Thermistor time constant, s.
    pub sensor_lag_s: f64,
    /// Reading noise (standard deviation), °C.
    pub noise_c: f64,
}

impl HeaterModel {
    /// A 40 W cartridge in an aluminium block (about 12 J/K): 20 → 210 °C in a bit over a minute at full power,
    /// 420 °C if never switched off.
    pub const HOT_END: HeaterModel = HeaterModel {
        power_w: 40.0,
        capacity_j_k: 12.0,
        loss_w_k: 0.1,
        fan_loss_w_k: 0.05,
        ambient_c: 20.0,
        sensor_lag_s: 2.0,
        noise_c: 0.1,
    };

    /// A 220 W heated bed, 235 × 235 × 3 mm aluminium (about 400 J/K): 60 °C in about 90 s.
    pub const BED: HeaterModel = HeaterModel {
        power_w: 220.0,
        capacity_j_k: 400.0,
        loss_w_k: 1.6,
        fan_loss_w_k: 0.0,
        ambient_c: 20.0,
        sensor_lag_s: 5.0,
        noise_c: 0.1,
    };
}

/// An injectable fault.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SimFault {
    /// The thermistor circuit is open (broken wire): the ADC reads full scale.
    ThermistorOpen,
    /// The thermistor is shorted: the ADC reads zero.
    ThermistorShort,
    /// The heater cartridge fell out of the block: its power heats the air, not the block.
    CartridgeOut,
    /// The ADC delivers no more conversions.
    AdcStalled,
}

#[derive(Debug, Clone, PartialEq)]
struct Channel {
    enabled: bool,
    model: HeaterModel,
    sensor: Thermistor,
    temp: f64,
    sensed: f64,
    duty: u8,
    fault: Option<SimFault>,
}

/// The simulated heater board (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct SimHeaters {
    ch: [Channel; NUM_HEATERS],
    fan: u8,
    now: u64,
    rng: u64,
    duty_log: Vec<(u64, Heater, u8)>,
}

impl SimHeaters {
    /// The heaters `cfg` configures, with the default models ([`HeaterModel::HOT_END`], [`HeaterModel::BED`]) at
    /// ambient temperature.
    pub fn new(cfg: &ThermalConfig) -> Self {
        let ch = |h: Heater, model: HeaterModel| Channel {
            enabled: cfg.heater(h).enabled,
            model,
            sensor: cfg.heater(h).sensor,
            temp: model.ambient_c,
            sensed: model.ambient_c,
            duty: 0,
            fault: None,
        };
        SimHeaters {
            ch: [ch(Heater::HotEnd, HeaterModel::HOT_END), ch(Heater::Bed, HeaterModel::BED)],
            fan: 0,
            now: 0,
            rng: 0x9E37_79B9_7F4A_7C15,
            duty_log: Vec::new(),
        }
    }

    /// Replace the model of `heater` (starting at its ambient temperature).
    pub fn set_model(&mut self, heater: Heater, model: HeaterModel) {
        let c = &mut self.ch[heater.index()];
        c.model = model;
        c.temp = model.ambient_c;
        c.sensed = model.ambient_c;
    }

    /// Seed the reading noise.
    pub fn seed(&mut self, seed: u64) {
        self.rng = seed | 1;
    }

    /// Inject (or with `None` clear) a fault on `heater`.
    pub fn inject(&mut self, heater: Heater, fault: Option<SimFault>) {
        self.ch[heater.index()].fault = fault;
    }

    /// The true temperature of the heated mass, °C.
    pub fn temperature(&self, heater: Heater) -> f64 {
        self.ch[heater.index()].temp
    }

    /// The duty the firmware last wrote.
    pub fn duty(&self, heater: Heater) -> u8 {
        self.ch[heater.index()].duty
    }

    /// The fan duty.
    pub fn fan(&self) -> u8 {
        self.fan
    }

    /// Every change of a heater's duty: `(time, heater, duty)`.
    pub fn duty_log(&self) -> &[(u64, Heater, u8)] {
        &self.duty_log
    }

    /// Model time, ticks.
    pub fn now(&self) -> u64 {
        self.now
    }

    /// Integrate the model up to `now` (ticks) with the duties as they are.
    pub fn advance_to(&mut self, now: u64) {
        const STEP: u64 = 10_000;
        while self.now < now {
            let h_ticks = (now - self.now).min(STEP);
            let h = h_ticks as f64 / 1e6;
            let fan = f64::from(self.fan) / 255.0;
            for c in self.ch.iter_mut().filter(|c| c.enabled) {
                let m = &c.model;
                let power =
                    if c.fault == Some(SimFault::CartridgeOut) { 0.0 } else { m.power_w * f64::from(c.duty) / 255.0 };
                let k = m.loss_w_k + m.fan_loss_w_k * fan;
                let t_inf = m.ambient_c + power / k;
                c.temp = t_inf + (c.temp - t_inf) * (-k * h / m.capacity_j_k).exp();
                c.sensed += (c.temp - c.sensed) * (1.0 - (-h / m.sensor_lag_s).exp());
            }
            self.now += h_ticks;
        }
    }

    fn gaussian(&mut self) -> f64 {
        let mut sum = 0.0;
        for _ in 0..12 {
            // xorshift64*.
            self.rng ^= self.rng >> 12;
            self.rng ^= self.rng << 25;
            self.rng ^= self.rng >> 27;
            let r = self.rng.wrapping_mul(0x2545_F491_4F6C_DD1D);
            sum += (r >> 11) as f64 / (1u64 << 53) as f64;
        }
        sum - 6.0
    }
}

/// The thermistor's resistance at `t_c`, Ω (f64; the Steinhart–Hart curve is inverted by bisection on ln R).
pub fn resistance_at(sensor: &Thermistor, t_c: f64) -> f64 {
    let t_k = t_c + f64::from(KELVIN);
    match sensor.curve {
        Curve::Beta { r0_ohm, t0_c, beta } => {
            f64::from(r0_ohm) * (f64::from(beta) * (1.0 / t_k - 1.0 / (f64::from(t0_c) + f64::from(KELVIN)))).exp()
        }
        Curve::SteinhartHart { a, b, c } => {
            let (a, b, c) = (f64::from(a), f64::from(b), f64::from(c));
            let inv = |l: f64| a + b * l + c * l * l * l;
            let (mut lo, mut hi) = (-5.0f64, 25.0f64);
            for _ in 0..100 {
                let mid = 0.5 * (lo + hi);
                // 1/T rises with ln R.
                if inv(mid) < 1.0 / t_k { lo = mid } else { hi = mid }
            }
            (0.5 * (lo + hi)).exp()
        }
    }
}

impl Heaters for SimHeaters {
    fn set_heater(&mut self, heater: Heater, duty: u8) {
        let c = &mut self.ch[heater.index()];
        if c.duty != duty {
            c.duty = duty;
            self.duty_log.push((self.now, heater, duty));
        }
    }

    fn read_thermistor(&mut self, heater: Heater) -> Option<u16> {
        let (enabled, fault, sensed, noise, sensor) = {
            let c = &self.ch[heater.index()];
            (c.enabled, c.fault, c.sensed, c.model.noise_c, c.sensor)
        };
        if !enabled {
            return None;
        }
        match fault {
            Some(SimFault::ThermistorOpen) => return Some(sensor.adc_max),
            Some(SimFault::ThermistorShort) => return Some(0),
            Some(SimFault::AdcStalled) => return None,
            Some(SimFault::CartridgeOut) | None => {}
        }
        let t = sensed + noise * self.gaussian();
        let r = resistance_at(&sensor, t);
        let full = f64::from(sensor.adc_max);
        let counts = (full * r / (r + f64::from(sensor.pullup_ohm))).round().clamp(0.0, full);
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss, reason = "clamped to 0..=adc_max")]
        let counts = counts as u16;
        Some(counts)
    }

    fn set_fan(&mut self, duty: u8) {
        self.fan = duty;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn full_power_follows_the_exponential() {
        let mut h = SimHeaters::new(&ThermalConfig::printer());
        h.set_heater(Heater::HotEnd, 255);
        h.advance_to(60_000_000);
        // T(60 s) = 20 + 400·(1 − e^(−60·0.1/12)) = 20 + 400·(1 − e^−0.5) = 177.39 °C.
        assert!((h.temperature(Heater::HotEnd) - 177.388).abs() < 0.01, "{}", h.temperature(Heater::HotEnd));
        // Off: decays towards ambient with τ = 120 s.
        h.set_heater(Heater::HotEnd, 0);
        h.advance_to(180_000_000);
        let expect = 20.0 + 157.388 * (-1.0f64).exp();
        assert!((h.temperature(Heater::HotEnd) - expect).abs() < 0.01);
        // The bed is untouched.
        assert_eq!(h.temperature(Heater::Bed), 20.0);
    }

    #[test]
    fn cartridge_out_and_broken_thermistors() {
        let mut h = SimHeaters::new(&ThermalConfig::printer());
        h.inject(Heater::HotEnd, Some(SimFault::CartridgeOut));
        h.set_heater(Heater::HotEnd, 255);
        h.advance_to(10_000_000);
        assert_eq!(h.temperature(Heater::HotEnd), 20.0);
        h.inject(Heater::HotEnd, Some(SimFault::ThermistorOpen));
        assert_eq!(h.read_thermistor(Heater::HotEnd), Some(4095));
        h.inject(Heater::HotEnd, Some(SimFault::ThermistorShort));
        assert_eq!(h.read_thermistor(Heater::HotEnd), Some(0));
        h.inject(Heater::HotEnd, Some(SimFault::AdcStalled));
        assert_eq!(h.read_thermistor(Heater::HotEnd), None);
        // No heaters configured: no readings.
        let mut none = SimHeaters::new(&ThermalConfig::NONE);
        assert_eq!(none.read_thermistor(Heater::HotEnd), None);
    }

    #[test]
    fn resistance_inverts_both_curves() {
        let beta = Thermistor::NTC_100K_3950;
        assert!((resistance_at(&beta, 25.0) - 100_000.0).abs() < 1e-6);
        #[allow(clippy::cast_possible_truncation, reason = "a resistance of 626 Ω, far inside f32")]
        let r = resistance_at(&beta, 210.0) as f32;
        assert!((f64::from(beta.celsius_at(r)) - 210.0).abs() < 0.01);
        let sh = Thermistor {
            curve: Curve::SteinhartHart { a: 1.009_249_5e-3, b: 2.378_405_4e-4, c: 2.019_202_7e-7 },
            ..beta
        };
        // 10 kΩ ↔ 24.68 °C (see the thermistor tests).
        assert!((resistance_at(&sh, 24.681_298) - 10_000.0).abs() < 1.0);
    }
}
