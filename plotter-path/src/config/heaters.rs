//! The `[heaters]` section of a printer profile and its conversion to the firmware's
//! [`plotter_fw::thermal::ThermalConfig`]. Plotter profiles have no such section and get no heaters.
//!
//! ```toml
//! [heaters]
//! fan = true
//! period_ms = 100
//! min_extrude_c = 170.0      # moves with extrusion are refused below this hot-end temperature (0: never)
//!
//! [heaters.hotend]
//! thermistor = { beta = 3950.0, r0_ohm = 100000.0, t0_c = 25.0 }   # or { a = …, b = …, c = … } (Steinhart–Hart)
//! pullup_ohm = 4700.0
//! adc_max = 4095
//! min_c = 5.0
//! max_c = 275.0
//! max_target_c = 260.0
//! pid = { kp = 20.0, ki = 1.0, kd = 80.0 }
//! heat_period_s = 20.0       # heating check: rise by heat_rise_c every heat_period_s
//! heat_rise_c = 2.0
//! hold_period_s = 40.0       # holding check: at most hold_period_s below target − hold_band_c
//! hold_band_c = 4.0
//! watchdog_s = 2.0           # no fresh reading for this long: off
//! ```
//!
//! The safety fields are required: they are never optional in the firmware and a profile states them.

use plotter_fw::thermal::pid::PidGains;
use plotter_fw::thermal::safety::SafetyConfig;
use plotter_fw::thermal::thermistor::{Curve, Thermistor};
use plotter_fw::thermal::{HeaterConfig, ThermalConfig};
use serde::{Deserialize, Serialize};

/// The heaters of a printer.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HeatersProfile {
    /// The hot end (tool 0).
    pub hotend: Option<HeaterProfile>,
    /// The heated bed.
    pub bed: Option<HeaterProfile>,
    /// Whether a part-cooling fan is wired.
    #[serde(default)]
    pub fan: bool,
    /// PID and safety-check period, ms.
    #[serde(default = "default_period")]
    pub period_ms: u32,
    /// Cold-extrusion guard: below this hot-end temperature, °C, the firmware refuses moves with extrusion (`M302`
    /// changes it at run time); 0 allows extrusion at any temperature. Default 170 °C, as in Marlin.
    #[serde(default = "default_min_extrude")]
    pub min_extrude_c: f64,
}

fn default_min_extrude() -> f64 {
    f64::from(plotter_fw::thermal::DEFAULT_MIN_EXTRUDE_C)
}

fn default_period() -> u32 {
    100
}

/// A thermistor curve.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(untagged, deny_unknown_fields)]
pub enum ThermistorProfile {
    /// β model.
    Beta {
        /// β, K.
        beta: f64,
        /// Resistance at `t0_c`, Ω.
        r0_ohm: f64,
        /// Reference temperature, °C.
        t0_c: f64,
    },
    /// Steinhart–Hart coefficients.
    SteinhartHart {
        /// A.
        a: f64,
        /// B.
        b: f64,
        /// C.
        c: f64,
    },
}

/// PID gains (duty 0–255 per °C; ki per second, kd in seconds).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PidProfile {
    /// Proportional gain.
    pub kp: f64,
    /// Integral gain.
    pub ki: f64,
    /// Derivative gain.
    pub kd: f64,
}

/// One heater.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HeaterProfile {
    /// The thermistor curve.
    pub thermistor: ThermistorProfile,
    /// Pull-up resistor, Ω.
    pub pullup_ohm: f64,
    /// ADC full scale.
    #[serde(default = "default_adc_max")]
    pub adc_max: u16,
    /// MINTEMP, °C.
    pub min_c: f64,
    /// MAXTEMP, °C.
    pub max_c: f64,
    /// Highest target a command may set, °C.
    pub max_target_c: f64,
    /// PID gains.
    pub pid: PidProfile,
    /// Highest PWM duty (0–255).
    #[serde(default = "default_max_duty")]
    pub max_duty: u8,
    /// Heating check period, s.
    pub heat_period_s: f64,
    /// Least rise per heating period, °C.
    pub heat_rise_c: f64,
    /// Longest time below the holding band, s.
    pub hold_period_s: f64,
    /// Holding band below the target, °C.
    pub hold_band_c: f64,
    /// Longest time without a fresh reading, s.
    pub watchdog_s: f64,
    /// M109/M190 are done once within this of the target, °C...
    #[serde(default = "default_window")]
    pub wait_window_c: f64,
    /// ...for this long, s.
    #[serde(default = "default_residency")]
    pub wait_residency_s: f64,
}

fn default_adc_max() -> u16 {
    4095
}
fn default_max_duty() -> u8 {
    255
}
fn default_window() -> f64 {
    1.0
}
fn default_residency() -> f64 {
    3.0
}

// Profile values are physical quantities far inside the f32 range.
#[allow(clippy::cast_possible_truncation)]
fn f(v: f64) -> f32 {
    v as f32
}

impl HeaterProfile {
    fn to_config(self) -> HeaterConfig {
        let curve = match self.thermistor {
            ThermistorProfile::Beta { beta, r0_ohm, t0_c } => {
                Curve::Beta { r0_ohm: f(r0_ohm), t0_c: f(t0_c), beta: f(beta) }
            }
            ThermistorProfile::SteinhartHart { a, b, c } => Curve::SteinhartHart { a: f(a), b: f(b), c: f(c) },
        };
        HeaterConfig {
            enabled: true,
            sensor: Thermistor { curve, pullup_ohm: f(self.pullup_ohm), adc_max: self.adc_max },
            safety: SafetyConfig {
                min_c: f(self.min_c),
                max_c: f(self.max_c),
                heat_period_s: f(self.heat_period_s),
                heat_rise_c: f(self.heat_rise_c),
                hold_period_s: f(self.hold_period_s),
                hold_band_c: f(self.hold_band_c),
                watchdog_s: f(self.watchdog_s),
            },
            pid: PidGains { kp: f(self.pid.kp), ki: f(self.pid.ki), kd: f(self.pid.kd) },
            max_duty: self.max_duty,
            max_target_c: f(self.max_target_c),
            wait_window_c: f(self.wait_window_c),
            wait_residency_s: f(self.wait_residency_s),
        }
    }
}

impl HeatersProfile {
    /// The firmware's heater configuration, validated (errors name the heater and field).
    pub fn to_config(&self) -> Result<ThermalConfig, String> {
        let mut cfg = ThermalConfig::NONE;
        cfg.fan = self.fan;
        cfg.period_ms = self.period_ms;
        cfg.min_extrude_c = f(self.min_extrude_c);
        if let Some(h) = self.hotend {
            cfg.heaters[0] = h.to_config();
        }
        if let Some(b) = self.bed {
            cfg.heaters[1] = b.to_config();
        }
        cfg.validate().map_err(|e| e.to_string())?;
        Ok(cfg)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::MachineProfile;
    use crate::config::profile::thermal_config;

    #[test]
    fn printer_sample_matches_the_firmware_printer() {
        let p = MachineProfile::from_toml(include_str!("../../../samples/printer.toml"), "printer.toml").unwrap();
        let c = thermal_config(&p).unwrap();
        assert_eq!(c, ThermalConfig::printer());
        let plotter = MachineProfile::default_plotter();
        assert_eq!(thermal_config(&plotter).unwrap(), ThermalConfig::NONE);
    }

    #[test]
    fn bad_heater_values_name_the_heater() {
        let text = include_str!("../../../samples/printer.toml").replace("max_c = 125.0", "max_c = 100.0");
        let err = MachineProfile::from_toml(&text, "p.toml").unwrap_err().to_string();
        assert!(err.contains("p.toml") && err.contains("heaters.bed"), "{err}");
    }

    #[test]
    fn cold_extrusion_minimum_defaults_to_170_and_is_checked() {
        let sample = include_str!("../../../samples/printer.toml");
        let without = sample.replace("min_extrude_c = 170.0\n", "");
        assert_ne!(without, sample, "the sample states the setting");
        let p = MachineProfile::from_toml(&without, "p.toml").unwrap();
        assert_eq!(thermal_config(&p).unwrap().min_extrude_c, 170.0);
        let p = MachineProfile::from_toml(&sample.replace("min_extrude_c = 170.0", "min_extrude_c = 0.0"), "p.toml");
        assert_eq!(thermal_config(&p.unwrap()).unwrap().min_extrude_c, 0.0);
        let text = sample.replace("min_extrude_c = 170.0", "min_extrude_c = 300.0");
        let err = MachineProfile::from_toml(&text, "p.toml").unwrap_err().to_string();
        assert!(err.contains("p.toml") && err.contains("min_extrude_c"), "{err}");
    }
}
