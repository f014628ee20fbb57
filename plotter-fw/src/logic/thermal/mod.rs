//! The heaters' mathematics and settings, for the printer profile's hot end, bed and part-cooling fan: the
//! thermistor conversion ([`thermistor`]), the PID ([`pid`]), the autotune relay ([`autotune`]), the safety checks
//! ([`safety`]) and the configuration they run with ([`ThermalConfig`]). Plotter profiles configure no heaters
//! ([`ThermalConfig::NONE`]). The driver that runs them on a board's outputs is [`crate::heater_driver`]; the
//! G-code commands that reach it are parsed in [`crate::thermal_gcode`].

pub mod autotune;
pub mod pid;
pub mod safety;
pub mod thermistor;

use core::fmt;

use crate::heater::{Heater, NUM_HEATERS};
use pid::PidGains;
use safety::{SafetyConfig, ticks};
use thermistor::Thermistor;

/// Settings of one heater.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeaterConfig {
    /// Whether the heater exists.
    pub enabled: bool,
    /// Its thermistor and conversion.
    pub sensor: Thermistor,
    /// Safety limits.
    pub safety: SafetyConfig,
    /// PID gains (duty 0–255 per °C).
    pub pid: PidGains,
    /// Highest PWM duty, 1–255.
    pub max_duty: u8,
    /// Highest target a command may set, °C (below MAXTEMP).
    pub max_target_c: f32,
    /// A wait is over once the temperature is within this of the target, °C...
    pub wait_window_c: f32,
    /// ...for this long, s.
    pub wait_residency_s: f32,
}

impl HeaterConfig {
    /// No heater.
    pub const NONE: HeaterConfig = HeaterConfig {
        enabled: false,
        sensor: Thermistor::NTC_100K_3950,
        safety: SafetyConfig {
            min_c: 5.0,
            max_c: 275.0,
            heat_period_s: 20.0,
            heat_rise_c: 2.0,
            hold_period_s: 40.0,
            hold_band_c: 4.0,
            watchdog_s: 2.0,
        },
        pid: PidGains { kp: 1.0, ki: 0.0, kd: 0.0 },
        max_duty: 255,
        max_target_c: 0.0,
        wait_window_c: 1.0,
        wait_residency_s: 0.0,
    };

    fn validate(&self) -> Result<(), &'static str> {
        self.sensor.validate()?;
        self.safety.validate()?;
        if !self.pid.is_valid() {
            return Err("pid gains must be finite, kp positive, ki and kd zero or positive");
        }
        if self.max_duty == 0 {
            return Err("max_duty must be positive");
        }
        if !(self.max_target_c.is_finite()
            && self.max_target_c > self.safety.min_c
            && self.max_target_c <= self.safety.max_c - self.safety.hold_band_c)
        {
            return Err("max_target_c must lie above min_c and at least hold_band_c below max_c");
        }
        if !(self.wait_window_c.is_finite() && self.wait_window_c > 0.0) {
            return Err("wait_window_c must be positive");
        }
        if !(self.wait_residency_s.is_finite() && (0.0..=600.0).contains(&self.wait_residency_s)) {
            return Err("wait_residency_s must lie in 0..=600");
        }
        Ok(())
    }
}

/// The heaters of a machine (board configuration).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ThermalConfig {
    /// Hot end and bed, indexed by [`Heater::index`].
    pub heaters: [HeaterConfig; NUM_HEATERS],
    /// Whether a part-cooling fan is wired.
    pub fan: bool,
    /// PID and safety-check period, ms.
    pub period_ms: u32,
    /// Below this hot-end temperature, °C, moves with extrusion are refused (Marlin's `EXTRUDE_MINTEMP`; 0 allows
    /// them at any temperature). See the module docs.
    pub min_extrude_c: f32,
}

/// The default of [`ThermalConfig::min_extrude_c`], °C (Marlin's).
pub const DEFAULT_MIN_EXTRUDE_C: f32 = 170.0;

/// A heater setting out of range.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ThermalConfigError {
    /// The heater, when per heater.
    pub heater: Option<Heater>,
    /// What is wrong.
    pub problem: &'static str,
}

impl fmt::Display for ThermalConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.heater {
            Some(Heater::HotEnd) => write!(f, "heaters.hotend: {}", self.problem),
            Some(Heater::Bed) => write!(f, "heaters.bed: {}", self.problem),
            None => write!(f, "heaters: {}", self.problem),
        }
    }
}

impl ThermalConfig {
    /// No heaters, no fan (plotters).
    pub const NONE: ThermalConfig = ThermalConfig {
        heaters: [HeaterConfig::NONE; NUM_HEATERS],
        fan: false,
        period_ms: 100,
        min_extrude_c: DEFAULT_MIN_EXTRUDE_C,
    };

    /// The printer of `samples/printer.toml`: a 100k/3950 thermistor on each heater, hot end up to 260 °C, bed up
    /// to 110 °C, fan, extrusion from 170 °C.
    pub fn printer() -> Self {
        let hotend = HeaterConfig {
            enabled: true,
            max_target_c: 260.0,
            pid: PidGains { kp: 20.0, ki: 1.0, kd: 80.0 },
            wait_residency_s: 3.0,
            ..HeaterConfig::NONE
        };
        let bed = HeaterConfig {
            enabled: true,
            safety: SafetyConfig {
                min_c: 5.0,
                max_c: 125.0,
                heat_period_s: 60.0,
                heat_rise_c: 2.0,
                hold_period_s: 60.0,
                hold_band_c: 3.0,
                watchdog_s: 2.0,
            },
            pid: PidGains { kp: 60.0, ki: 1.0, kd: 500.0 },
            max_target_c: 110.0,
            wait_residency_s: 3.0,
            ..HeaterConfig::NONE
        };
        ThermalConfig { heaters: [hotend, bed], fan: true, period_ms: 100, min_extrude_c: DEFAULT_MIN_EXTRUDE_C }
    }

    /// Whether any heater is configured.
    pub fn is_active(&self) -> bool {
        self.heaters.iter().any(|h| h.enabled)
    }

    /// The settings of `heater`.
    pub fn heater(&self, heater: Heater) -> &HeaterConfig {
        &self.heaters[heater.index()]
    }

    /// Check every value; the first problem found is returned.
    pub fn validate(&self) -> Result<(), ThermalConfigError> {
        if !(10..=1000).contains(&self.period_ms) {
            return Err(ThermalConfigError { heater: None, problem: "period_ms must lie in 10..=1000" });
        }
        for h in Heater::ALL {
            let c = self.heater(h);
            if c.enabled {
                c.validate().map_err(|problem| ThermalConfigError { heater: Some(h), problem })?;
                // The watchdog must see at least two periods.
                if ticks(c.safety.watchdog_s) < 2 * u64::from(self.period_ms) * 1000 {
                    return Err(ThermalConfigError {
                        heater: Some(h),
                        problem: "watchdog_s must cover at least two thermal periods",
                    });
                }
            }
        }
        let hotend = self.heater(Heater::HotEnd);
        if hotend.enabled
            && !(self.min_extrude_c.is_finite() && (0.0..=hotend.max_target_c).contains(&self.min_extrude_c))
        {
            return Err(ThermalConfigError {
                heater: None,
                problem: "min_extrude_c must lie from 0 to the hot end's max_target_c (else nothing could extrude)",
            });
        }
        Ok(())
    }
}
