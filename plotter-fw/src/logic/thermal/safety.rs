//! Thermal safety: the checks that switch a heater off and stop the machine. None of them can be disabled; only
//! their limits are configured ([`SafetyConfig`], validated so that every check stays armed).
//!
//! | fault | trips when | fires within |
//! |-------|------------|--------------|
//! | MINTEMP | a reading below `min_c`, or an open thermistor | one thermal period after the reading |
//! | MAXTEMP | a reading above `max_c`, or a shorted thermistor | one thermal period after the reading |
//! | heating failed | heater on (target above the temperature) and the temperature has not risen by `heat_rise_c` over `heat_period_s` | 2 × `heat_period_s` + one period after heating stopped working (the lagging sensor may still pass the first check) |
//! | thermal runaway | the temperature has stayed below `target − hold_band_c` for `hold_period_s` after it had reached the target | `hold_period_s` + one period after the reading left the band for good |
//! | sensor timeout | no fresh reading from the ADC for `watchdog_s` | `watchdog_s` + one period after the last reading |
//!
//! MINTEMP, MAXTEMP and the watchdog watch every configured heater all the time (also with the heater off: a broken
//! sensor must be found before anyone switches the heater on). The heating and holding checks follow the target,
//! in the manner of printer firmwares' "thermal runaway protection": heating until the temperature comes within
//! `hold_band_c` of the target, then holding. Raising the target restarts the heating check; switching the heater
//! off (target 0) ends both.

use super::thermistor::Reading;
use crate::errors::Fault;
use crate::fmath::round_u32;

/// Limits of the safety checks of one heater (see the module table).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SafetyConfig {
    /// MINTEMP, °C.
    pub min_c: f32,
    /// MAXTEMP, °C.
    pub max_c: f32,
    /// Heating check period, s.
    pub heat_period_s: f32,
    /// Least rise over one heating period, °C.
    pub heat_rise_c: f32,
    /// How long the temperature may stay below the holding band, s.
    pub hold_period_s: f32,
    /// Width of the holding band below the target, °C.
    pub hold_band_c: f32,
    /// Longest time without a fresh reading, s.
    pub watchdog_s: f32,
}

impl SafetyConfig {
    /// Check that every limit keeps its check armed: finite, positive periods of at most ten minutes, MINTEMP
    /// below MAXTEMP.
    pub fn validate(&self) -> Result<(), &'static str> {
        let all = [
            self.min_c,
            self.max_c,
            self.heat_period_s,
            self.heat_rise_c,
            self.hold_period_s,
            self.hold_band_c,
            self.watchdog_s,
        ];
        if all.iter().any(|v| !v.is_finite()) {
            return Err("safety limits must be numbers");
        }
        if self.min_c >= self.max_c || self.max_c > 500.0 {
            return Err("min_c must lie below max_c, and max_c at most 500");
        }
        for p in [self.heat_period_s, self.hold_period_s, self.watchdog_s] {
            if !(0.1..=600.0).contains(&p) {
                return Err("safety periods must lie in 0.1..=600 s");
            }
        }
        if !(self.heat_rise_c > 0.0 && self.hold_band_c > 0.0) {
            return Err("heat_rise_c and hold_band_c must be positive");
        }
        Ok(())
    }
}

/// Seconds to timer ticks (µs).
pub fn ticks(s: f32) -> u64 {
    u64::from(round_u32(s * 1000.0)) * 1000
}

/// MINTEMP / MAXTEMP for one reading: the temperature when it is within the limits.
pub fn check_reading(cfg: &SafetyConfig, reading: Reading) -> Result<f32, Fault> {
    match reading {
        Reading::Open => Err(Fault::MinTemp),
        Reading::Short => Err(Fault::MaxTemp),
        Reading::Celsius(t) if t < cfg.min_c => Err(Fault::MinTemp),
        Reading::Celsius(t) if t > cfg.max_c => Err(Fault::MaxTemp),
        Reading::Celsius(t) => Ok(t),
    }
}

/// The sensor watchdog: `last_fresh` is the time of the last reading (ticks).
pub fn check_watchdog(cfg: &SafetyConfig, now: u64, last_fresh: u64) -> Result<(), Fault> {
    if now.saturating_sub(last_fresh) > ticks(cfg.watchdog_s) { Err(Fault::SensorTimeout) } else { Ok(()) }
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Mode {
    Off,
    Heating { check_at: u64, reference: f32 },
    Holding { below_since: Option<u64> },
}

/// The heating and holding checks of one heater.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Guard {
    mode: Mode,
}

impl Default for Guard {
    fn default() -> Self {
        Self::new()
    }
}

impl Guard {
    /// No target: nothing to watch.
    pub const fn new() -> Self {
        Guard { mode: Mode::Off }
    }

    /// Whether the heating check is running (the heater is on its way up).
    pub fn is_heating(&self) -> bool {
        matches!(self.mode, Mode::Heating { .. })
    }

    /// A new target at `now` with the heater at `temp`.
    pub fn set_target(&mut self, cfg: &SafetyConfig, now: u64, target: f32, temp: f32) {
        self.mode = if target <= 0.0 {
            Mode::Off
        } else if temp < target - cfg.hold_band_c {
            Mode::Heating { check_at: now + ticks(cfg.heat_period_s), reference: temp }
        } else {
            Mode::Holding { below_since: None }
        };
    }

    /// Check the heater at `now`, at temperature `temp` with `target`.
    pub fn check(&mut self, cfg: &SafetyConfig, now: u64, target: f32, temp: f32) -> Result<(), Fault> {
        match &mut self.mode {
            Mode::Off => Ok(()),
            Mode::Heating { check_at, reference } => {
                if temp >= target - cfg.hold_band_c {
                    self.mode = Mode::Holding { below_since: None };
                    return Ok(());
                }
                if now >= *check_at {
                    if temp < *reference + cfg.heat_rise_c {
                        return Err(Fault::HeatingFailed);
                    }
                    *reference = temp;
                    *check_at = now + ticks(cfg.heat_period_s);
                }
                Ok(())
            }
            Mode::Holding { below_since } => {
                if temp >= target - cfg.hold_band_c {
                    *below_since = None;
                    return Ok(());
                }
                let since = *below_since.get_or_insert(now);
                if now - since >= ticks(cfg.hold_period_s) { Err(Fault::Runaway) } else { Ok(()) }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const CFG: SafetyConfig = SafetyConfig {
        min_c: 5.0,
        max_c: 275.0,
        heat_period_s: 20.0,
        heat_rise_c: 2.0,
        hold_period_s: 40.0,
        hold_band_c: 4.0,
        watchdog_s: 2.0,
    };
    const S: u64 = 1_000_000;

    #[test]
    fn readings_and_rails() {
        assert_eq!(check_reading(&CFG, Reading::Open), Err(Fault::MinTemp));
        assert_eq!(check_reading(&CFG, Reading::Short), Err(Fault::MaxTemp));
        assert_eq!(check_reading(&CFG, Reading::Celsius(4.9)), Err(Fault::MinTemp));
        assert_eq!(check_reading(&CFG, Reading::Celsius(275.1)), Err(Fault::MaxTemp));
        assert_eq!(check_reading(&CFG, Reading::Celsius(210.0)), Ok(210.0));
        assert_eq!(check_watchdog(&CFG, 2 * S, 0), Ok(()));
        assert_eq!(check_watchdog(&CFG, 2 * S + 1, 0), Err(Fault::SensorTimeout));
    }

    #[test]
    fn heating_must_rise_each_period() {
        let mut g = Guard::new();
        g.set_target(&CFG, 0, 210.0, 20.0);
        assert!(g.is_heating());
        // Rising 3 °C per 20 s passes the first check and re-arms from there.
        assert_eq!(g.check(&CFG, 20 * S, 210.0, 23.0), Ok(()));
        // Then stuck at 24 °C (< 23 + 2): the check at 40 s trips, not before.
        assert_eq!(g.check(&CFG, 39 * S, 210.0, 24.0), Ok(()));
        assert_eq!(g.check(&CFG, 40 * S, 210.0, 24.0), Err(Fault::HeatingFailed));
    }

    #[test]
    fn holding_tolerates_short_dips_only() {
        let mut g = Guard::new();
        g.set_target(&CFG, 0, 210.0, 20.0);
        assert_eq!(g.check(&CFG, S, 210.0, 207.0), Ok(()));
        assert!(!g.is_heating());
        // 30 s below the band, then back: fine.
        assert_eq!(g.check(&CFG, 10 * S, 210.0, 205.0), Ok(()));
        assert_eq!(g.check(&CFG, 40 * S, 210.0, 205.0), Ok(()));
        assert_eq!(g.check(&CFG, 41 * S, 210.0, 209.0), Ok(()));
        // Below from 50 s on: trips exactly 40 s later.
        assert_eq!(g.check(&CFG, 50 * S, 210.0, 200.0), Ok(()));
        assert_eq!(g.check(&CFG, 89 * S, 210.0, 150.0), Ok(()));
        assert_eq!(g.check(&CFG, 90 * S, 210.0, 150.0), Err(Fault::Runaway));
        // Off: no checks.
        g.set_target(&CFG, 91 * S, 0.0, 150.0);
        assert_eq!(g.check(&CFG, 500 * S, 0.0, 20.0), Ok(()));
    }

    #[test]
    fn config_checks_keep_every_check_armed() {
        assert_eq!(CFG.validate(), Ok(()));
        assert!(SafetyConfig { hold_period_s: 0.0, ..CFG }.validate().is_err());
        assert!(SafetyConfig { watchdog_s: f32::INFINITY, ..CFG }.validate().is_err());
        assert!(SafetyConfig { min_c: 300.0, ..CFG }.validate().is_err());
        assert!(SafetyConfig { heat_rise_c: 0.0, ..CFG }.validate().is_err());
    }
}
