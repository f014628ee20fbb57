//! Heaters of the printer profile: the hot end and the bed, each a PWM output with a thermistor input, plus the
//! part-cooling fan. Plotter profiles configure none ([`ThermalConfig::NONE`]) and never reach this code.
//!
//! # Scheduling
//! [`Thermal::tick`] runs at the fixed rate [`ThermalConfig::period_ms`] from the core's main loop
//! ([`crate::machine::Machine::poll`], which the scheduler wakes at [`Thermal::next_deadline`]). Each period it
//! reads every configured thermistor ([`crate::hal::Heaters::read_thermistor`]), runs the safety checks
//! ([`safety`]), then the PID ([`pid`]) or the autotune relay ([`autotune`]), and writes the PWM duty.
//!
//! # Commands (Marlin's meanings)
//! | command | does |
//! |---------|------|
//! | `M104 S<t>` | hot-end target, no wait (`S0` = off) |
//! | `M109 S<t>` / `M109 R<t>` | hot-end target, then wait: `S` waits only while heating, `R` also while cooling |
//! | `M140 S<t>` / `M190 S<t>` / `M190 R<t>` | the same for the bed |
//! | `M105` | temperature report `T:<t> /<target> B:<t> /<target> @:<duty> B@:<duty>` |
//! | `M155 S<s>` | report temperatures every `s` seconds (0 = off) |
//! | `M106 S<0–255>` / `M107` | part-cooling fan duty / off |
//! | `M303 E<0\|-1> S<t> C<n> U1` | PID autotune of the hot end (E0) or bed (E−1) at `t` over `n` cycles; `U1` applies the gains |
//! | `M301 P I D` / `M304 P I D` | set (or, without words, report) the hot-end / bed PID gains |
//! | `M112` | emergency stop: heaters off, motion stopped, motors off, alarm (acts as soon as the line is received) |
//! | `M302` | cold extrusion: `P1` allows it, `P0` prevents it, `S<t>` sets the minimum (`S0` allows), no words report |
//!
//! A wait (`M109`, `M190`, `M303`) keeps its line pending, so the commands after it wait too, and reports the
//! temperatures every second meanwhile. A target is reached once the temperature has stayed within
//! [`HeaterConfig::wait_window_c`] of it for [`HeaterConfig::wait_residency_s`].
//!
//! # Cold extrusion
//! Pushing filament through a nozzle too cold to melt it grinds the filament or jams the extruder, so, as in Marlin,
//! a move with extrusion is refused ([`crate::errors::ErrorCode::ColdExtrusion`], nothing moves) while the hot end
//! reads below [`ThermalConfig::min_extrude_c`] — G-code moves and host-planned step blocks alike, checked when the
//! move is queued ([`Thermal::cold_extrusion`]). A hot end without a valid reading counts as cold. `M302 P1`
//! allows cold extrusion deliberately (loading filament by hand, testing the extruder); a reset restores the
//! profile's setting. Machines without a hot end (plotters, a paste extruder) are never checked.
//!
//! # Safety
//! Every fault switches all heaters and the fan off and returns a [`ThermalAlarm`] naming the sensor; the machine
//! latches it as an alarm, stops motion and disables the motors. See [`safety`] for the checks and their times.

pub mod autotune;
pub mod pid;
pub mod safety;
pub mod thermistor;

use core::fmt::{self, Write};

use crate::decimal::Decimal;
use crate::errors::{ErrorCode, Fault, ThermalAlarm};
use crate::gcode::Words;
use crate::hal::Heaters;
use crate::heater::{Heater, NUM_HEATERS};
use crate::range::MICRO;
use autotune::{Autotune, Step};
use pid::{Pid, PidGains};
use safety::{Guard, SafetyConfig, ticks};
use thermistor::{Reading, Thermistor};

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

/// What a thermal command asks the machine to do.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Cmd {
    /// Done: answer `ok`.
    Ok,
    /// Waiting (for a temperature or an autotune): keep the line and retry.
    Blocked,
    /// Refused: answer `error:` with this code and detail.
    Error(ErrorCode, &'static str),
    /// `M112`: stop everything.
    EmergencyStop,
}

/// Whether `m` is a command of this module.
pub fn handles(m: u16) -> bool {
    matches!(m, 104 | 105 | 106 | 107 | 109 | 112 | 140 | 155 | 190 | 301 | 302 | 303 | 304)
}

/// Why a move with extrusion was refused: the hot end's temperature (NaN without a valid reading) and the minimum.
/// `Display` gives the detail of the `error:15` reply, e.g. `: hot end 20.0 C, below the minimum of 170.0 C (M302
/// P1 allows cold extrusion)` (ASCII: replies stay 7-bit).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TooCold {
    /// The hot end's last temperature, °C.
    pub temp_c: f32,
    /// The minimum extrusion temperature in force, °C.
    pub min_c: f32,
}

impl fmt::Display for TooCold {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(": hot end ")?;
        if self.temp_c.is_finite() {
            write!(f, "{} C", Decimal::new(self.temp_c, 1))?;
        } else {
            f.write_str("without a valid reading")?;
        }
        write!(f, ", below the minimum of {} C (M302 P1 allows cold extrusion)", Decimal::new(self.min_c, 1))
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct Channel {
    target: f32,
    reading: Option<Reading>,
    temp: f32,
    last_fresh: u64,
    pid: Pid,
    gains: PidGains,
    guard: Guard,
    duty: u8,
    in_window_since: Option<u64>,
}

/// The heater controller (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct Thermal {
    cfg: ThermalConfig,
    ch: [Channel; NUM_HEATERS],
    fan: u8,
    next_tick: u64,
    autotune: Option<(Heater, Autotune, bool)>,
    autotune_result: Option<Result<PidGains, &'static str>>,
    report_every: u64,
    next_report: u64,
    waiting: bool,
    /// `M302 P1`: cold extrusion allowed.
    cold_allowed: bool,
    /// The minimum extrusion temperature in force (`M302 S`), °C.
    min_extrude_c: f32,
}

impl Thermal {
    /// The controller for `cfg` (validate it first), started at `now`.
    pub fn new(cfg: ThermalConfig, now: u64) -> Self {
        let ch = |h: Heater| Channel {
            target: 0.0,
            reading: None,
            temp: f32::NAN,
            last_fresh: now,
            pid: Pid::new(),
            gains: cfg.heater(h).pid,
            guard: Guard::new(),
            duty: 0,
            in_window_since: None,
        };
        Thermal {
            cfg,
            ch: [ch(Heater::HotEnd), ch(Heater::Bed)],
            fan: 0,
            next_tick: now,
            autotune: None,
            autotune_result: None,
            report_every: 0,
            next_report: 0,
            waiting: false,
            cold_allowed: cfg.min_extrude_c <= 0.0,
            min_extrude_c: cfg.min_extrude_c,
        }
    }

    /// `Some` when a move with extrusion must be refused now: a hot end is configured, cold extrusion is not
    /// allowed (`M302`) and the hot end reads below the minimum extrusion temperature (or has no valid reading).
    pub fn cold_extrusion(&self) -> Option<TooCold> {
        let temp_c = self.ch[Heater::HotEnd.index()].temp;
        // NaN (no valid reading) counts as cold.
        let warm = temp_c.is_finite() && temp_c >= self.min_extrude_c;
        let cold = self.cfg.heater(Heater::HotEnd).enabled && !self.cold_allowed && !warm;
        cold.then_some(TooCold { temp_c, min_c: self.min_extrude_c })
    }

    /// Back to the profile's cold-extrusion setting (a reset undoes `M302`).
    pub fn restore_cold_extrusion(&mut self) {
        self.cold_allowed = self.cfg.min_extrude_c <= 0.0;
        self.min_extrude_c = self.cfg.min_extrude_c;
    }

    /// The configuration.
    pub fn config(&self) -> &ThermalConfig {
        &self.cfg
    }

    /// Whether any heater is configured.
    pub fn is_active(&self) -> bool {
        self.cfg.is_active()
    }

    /// When the next period is due (ticks); `None` without heaters.
    pub fn next_deadline(&self) -> Option<u64> {
        self.is_active().then_some(self.next_tick)
    }

    /// Whether a period is due at `now`.
    pub fn due(&self, now: u64) -> bool {
        self.is_active() && now >= self.next_tick
    }

    /// Last temperature of `heater`, °C (NaN before the first valid reading).
    pub fn temperature(&self, heater: Heater) -> f32 {
        self.ch[heater.index()].temp
    }

    /// Target of `heater`, °C (0 = off).
    pub fn target(&self, heater: Heater) -> f32 {
        self.ch[heater.index()].target
    }

    /// PWM duty last written to `heater`.
    pub fn duty(&self, heater: Heater) -> u8 {
        self.ch[heater.index()].duty
    }

    /// PID gains in use for `heater`.
    pub fn gains(&self, heater: Heater) -> PidGains {
        self.ch[heater.index()].gains
    }

    /// Fan duty.
    pub fn fan(&self) -> u8 {
        self.fan
    }

    /// Whether an autotune is running.
    pub fn autotuning(&self) -> bool {
        self.autotune.is_some()
    }

    /// All heaters and the fan off, targets cleared, autotune cancelled (emergency stop, alarms).
    pub fn shutdown<IO: Heaters>(&mut self, io: &mut IO) {
        for h in Heater::ALL {
            let c = &mut self.ch[h.index()];
            c.target = 0.0;
            c.duty = 0;
            c.pid.reset();
            c.guard = Guard::new();
            c.in_window_since = None;
            if self.cfg.heater(h).enabled {
                io.set_heater(h, 0);
            }
        }
        if self.autotune.take().is_some() {
            self.autotune_result = Some(Err("stopped"));
        }
        self.waiting = false;
        self.fan = 0;
        if self.cfg.fan {
            io.set_fan(0);
        }
    }

    /// Set a target (°C, 0 = off) at `now`.
    pub fn set_target(&mut self, heater: Heater, target: f32, now: u64) -> Result<(), &'static str> {
        let cfg = *self.cfg.heater(heater);
        if !cfg.enabled {
            return Err("no such heater");
        }
        if !(target.is_finite() && (0.0..=cfg.max_target_c).contains(&target)) {
            return Err("target above the heater's maximum (or negative)");
        }
        let c = &mut self.ch[heater.index()];
        if target == c.target {
            return Ok(());
        }
        if c.target <= 0.0 {
            c.pid.reset();
        }
        c.target = target;
        c.in_window_since = None;
        let temp = if c.temp.is_finite() { c.temp } else { 0.0 };
        c.guard.set_target(&cfg.safety, now, target, temp);
        Ok(())
    }

    /// Run the periods due at `now`: read, check, control, write. `Some` when a safety check tripped (everything
    /// is off already). Temperature reports are written to `out`.
    pub fn tick<IO: Heaters, W: Write>(&mut self, io: &mut IO, now: u64, out: &mut W) -> Option<ThermalAlarm> {
        if !self.due(now) {
            return None;
        }
        let period = u64::from(self.cfg.period_ms) * 1000;
        // One control step per call; a late call does not replay missed periods.
        self.next_tick = if now - self.next_tick >= period { now + period } else { self.next_tick + period };
        let dt = self.cfg.period_ms as f32 / 1000.0;
        for h in Heater::ALL {
            let cfg = *self.cfg.heater(h);
            if !cfg.enabled {
                continue;
            }
            if let Some(counts) = io.read_thermistor(h) {
                let c = &mut self.ch[h.index()];
                c.reading = Some(cfg.sensor.read(counts));
                c.last_fresh = now;
            }
            if let Err(fault) = self.check(h, now) {
                self.shutdown(io);
                return Some(ThermalAlarm { heater: h, fault });
            }
            let c = &mut self.ch[h.index()];
            let mut duty = if c.target > 0.0 {
                c.pid.update(&c.gains, c.target, c.temp, dt, f32::from(cfg.max_duty))
            } else {
                0.0
            };
            if let Some((th, at, apply)) = self.autotune.as_mut()
                && *th == h
            {
                match at.tick(now, c.temp) {
                    Step::Drive(d) => duty = d,
                    Step::Done(g) => {
                        if *apply {
                            c.gains = g;
                        }
                        self.autotune_result = Some(Ok(g));
                        self.autotune = None;
                        c.target = 0.0;
                        c.guard = Guard::new();
                        duty = 0.0;
                    }
                    Step::Failed(why) => {
                        self.autotune_result = Some(Err(why));
                        self.autotune = None;
                        c.target = 0.0;
                        c.guard = Guard::new();
                        duty = 0.0;
                    }
                }
            }
            let duty = crate::fmath::round_u32(crate::fmath::clamp(duty, 0.0, f32::from(cfg.max_duty)));
            let duty = u8::try_from(duty).unwrap_or(cfg.max_duty);
            c.duty = duty;
            io.set_heater(h, duty);
            // Wait bookkeeping.
            if c.target > 0.0 && (c.temp - c.target).abs() <= cfg.wait_window_c {
                c.in_window_since.get_or_insert(now);
            } else {
                c.in_window_since = None;
            }
        }
        let auto = self.report_every > 0 && now >= self.next_report;
        let waiting = self.waiting && now >= self.next_report;
        if auto || waiting {
            let every = if self.report_every > 0 { self.report_every } else { 1_000_000 };
            self.next_report = now + every;
            self.report(out);
        }
        None
    }

    /// The safety checks of one heater at `now` (updates its temperature from the last reading).
    fn check(&mut self, h: Heater, now: u64) -> Result<(), Fault> {
        let cfg = self.cfg.heater(h);
        let c = &mut self.ch[h.index()];
        safety::check_watchdog(&cfg.safety, now, c.last_fresh)?;
        let Some(reading) = c.reading else {
            // No reading yet: only the watchdog applies.
            return Ok(());
        };
        c.temp = safety::check_reading(&cfg.safety, reading)?;
        let target = match self.autotune {
            Some((th, at, _)) if th == h => at.target(),
            _ => c.target,
        };
        c.guard.check(&cfg.safety, now, target, c.temp)
    }

    /// Write the temperature report line (`M105`).
    pub fn report<W: Write>(&self, out: &mut W) {
        let mut first = true;
        for h in Heater::ALL {
            if !self.cfg.heater(h).enabled {
                continue;
            }
            let c = &self.ch[h.index()];
            let label = if h == Heater::HotEnd { "T" } else { "B" };
            let sep = if first { "" } else { " " };
            first = false;
            let _ = match c.reading {
                Some(Reading::Open) => write!(out, "{sep}{label}:open /{}", Decimal::new(c.target, 2)),
                Some(Reading::Short) => write!(out, "{sep}{label}:short /{}", Decimal::new(c.target, 2)),
                _ if !c.temp.is_finite() => write!(out, "{sep}{label}:none /{}", Decimal::new(c.target, 2)),
                _ => write!(out, "{sep}{label}:{} /{}", Decimal::new(c.temp, 2), Decimal::new(c.target, 2)),
            };
        }
        for h in Heater::ALL {
            if self.cfg.heater(h).enabled {
                let label = if h == Heater::HotEnd { "@" } else { "B@" };
                let _ = write!(out, " {label}:{}", self.ch[h.index()].duty);
            }
        }
        let _ = writeln!(out);
    }

    /// Whether a wait for `heater` is over at `now` (`cooling`: `R` semantics, also wait for it to cool down).
    fn wait_over(&self, heater: Heater, now: u64, cooling: bool) -> bool {
        let cfg = self.cfg.heater(heater);
        let c = &self.ch[heater.index()];
        if c.target <= 0.0 {
            return true;
        }
        if !cooling && c.temp.is_finite() && c.temp >= c.target + cfg.wait_window_c {
            return true;
        }
        c.in_window_since.is_some_and(|since| now - since >= ticks(cfg.wait_residency_s))
    }

    /// Run a thermal command (`handles(m)` for one of its M codes). `alarm`: the machine is in alarm (heating is
    /// refused then). Reports go to `out`.
    pub fn command<IO: Heaters, W: Write>(
        &mut self,
        w: &Words,
        now: u64,
        io: &mut IO,
        out: &mut W,
        alarm: bool,
    ) -> Cmd {
        let Some(&m) = w.m.iter().find(|m| handles(**m)) else { return Cmd::Ok };
        if w.m.len() > 1 || !w.g.is_empty() {
            return Cmd::Error(ErrorCode::UnsupportedWord, ": a temperature command goes on a line of its own");
        }
        if m == 112 {
            return Cmd::EmergencyStop;
        }
        let allowed: &[u8] = match m {
            104 | 109 | 140 | 190 => b"SRTN",
            106 => b"SPN",
            107 | 105 => b"PTN",
            155 => b"SN",
            302 => b"PSN",
            303 => b"ESCUN",
            301 | 304 => b"PIDN",
            _ => b"N",
        };
        for bit in 0..26u8 {
            if w.letters() & (1 << bit) != 0 && !allowed.contains(&(b'A' + bit)) {
                return Cmd::Error(ErrorCode::UnsupportedWord, ": not a word of this command");
            }
        }
        let celsius = |v: i64| v as f32 / MICRO as f32;
        if matches!(m, 106 | 107) {
            if !self.cfg.fan {
                return Cmd::Error(ErrorCode::UnknownCommand, ": no fan configured");
            }
            if w.get(b'P').is_some_and(|p| p != 0) {
                return Cmd::Error(ErrorCode::InvalidValue, ": only fan P0 exists");
            }
            let duty = if m == 107 { 0 } else { w.get(b'S').map_or(255, |s| s / MICRO) };
            let Ok(duty) = u8::try_from(duty) else {
                return Cmd::Error(ErrorCode::InvalidValue, ": fan S must lie in 0..=255");
            };
            self.fan = duty;
            io.set_fan(duty);
            return Cmd::Ok;
        }
        if !self.is_active() {
            return Cmd::Error(ErrorCode::UnknownCommand, ": no heaters configured");
        }
        if w.get(b'T').is_some_and(|t| t != 0) {
            return Cmd::Error(ErrorCode::InvalidValue, ": only tool T0 exists");
        }
        match m {
            105 => {
                self.report(out);
                Cmd::Ok
            }
            155 => {
                let s = w.get(b'S').unwrap_or(0);
                if !(0..=60 * MICRO).contains(&s) {
                    return Cmd::Error(ErrorCode::InvalidValue, ": M155 S must lie in 0..=60 s");
                }
                self.report_every = u64::try_from(s).unwrap_or(0);
                self.next_report = now;
                Cmd::Ok
            }
            301 | 304 => {
                let h = if m == 301 { Heater::HotEnd } else { Heater::Bed };
                if !self.cfg.heater(h).enabled {
                    return Cmd::Error(ErrorCode::InvalidValue, ": no such heater");
                }
                let mut g = self.ch[h.index()].gains;
                if !(w.has(b'P') || w.has(b'I') || w.has(b'D')) {
                    let _ = writeln!(
                        out,
                        "{} Kp:{} Ki:{} Kd:{}",
                        pid_label(h),
                        Decimal::new(g.kp, 3),
                        Decimal::new(g.ki, 4),
                        Decimal::new(g.kd, 3)
                    );
                    return Cmd::Ok;
                }
                g.kp = w.get(b'P').map_or(g.kp, celsius);
                g.ki = w.get(b'I').map_or(g.ki, celsius);
                g.kd = w.get(b'D').map_or(g.kd, celsius);
                if !g.is_valid() {
                    return Cmd::Error(ErrorCode::InvalidValue, ": PID gains must be non-negative, P positive");
                }
                self.ch[h.index()].gains = g;
                Cmd::Ok
            }
            302 => self.cold_extrusion_command(w, out),
            303 => self.autotune_command(w, now, out, alarm),
            _ => {
                let h = if matches!(m, 104 | 109) { Heater::HotEnd } else { Heater::Bed };
                let wait = matches!(m, 109 | 190);
                let (value, cooling) = match (w.get(b'S'), w.get(b'R')) {
                    (Some(_), Some(_)) => return Cmd::Error(ErrorCode::UnsupportedWord, ": S or R, not both"),
                    (Some(s), None) => (Some(s), false),
                    (None, Some(r)) => (Some(r), true),
                    (None, None) => (None, false),
                };
                if let Some(v) = value {
                    let t = celsius(v);
                    if alarm && t > 0.0 {
                        return Cmd::Error(ErrorCode::Alarm, "");
                    }
                    if self.autotune.is_some_and(|(th, _, _)| th == h) {
                        return Cmd::Error(ErrorCode::InvalidValue, ": autotune running on this heater");
                    }
                    if let Err(why) = self.set_target(h, t, now) {
                        self.waiting = false;
                        return Cmd::Error(ErrorCode::InvalidValue, detail(why));
                    }
                }
                if wait && !self.wait_over(h, now, cooling) {
                    if !self.waiting {
                        self.waiting = true;
                        self.next_report = now;
                    }
                    return Cmd::Blocked;
                }
                self.waiting = false;
                Cmd::Ok
            }
        }
    }

    /// `M302` as in Marlin: `S<t>` sets the minimum (and `S0` allows cold extrusion, any other `S` prevents it),
    /// `P1`/`P0` allows/prevents it, neither reports the setting.
    fn cold_extrusion_command<W: Write>(&mut self, w: &Words, out: &mut W) -> Cmd {
        let hotend = *self.cfg.heater(Heater::HotEnd);
        if !hotend.enabled {
            return Cmd::Error(ErrorCode::InvalidValue, ": no hot end");
        }
        let s = w.get(b'S');
        let p = w.get(b'P');
        if s.is_none() && p.is_none() {
            let _ = writeln!(
                out,
                "cold extrusion {} (minimum {} C, hot end {})",
                if self.cold_allowed { "allowed" } else { "prevented" },
                Decimal::new(self.min_extrude_c, 1),
                Decimal::new(self.temperature(Heater::HotEnd), 1)
            );
            return Cmd::Ok;
        }
        if p.is_some_and(|p| p != 0 && p != MICRO) {
            return Cmd::Error(ErrorCode::InvalidValue, ": M302 P must be 0 (prevent) or 1 (allow)");
        }
        let min = match s {
            Some(s) if !(0..=MICRO * 10_000).contains(&s) || s as f32 / MICRO as f32 > hotend.max_target_c => {
                return Cmd::Error(ErrorCode::InvalidValue, ": M302 S must lie from 0 to the hot end's maximum");
            }
            Some(s) => s as f32 / MICRO as f32,
            None => self.min_extrude_c,
        };
        self.min_extrude_c = min;
        if s.is_some() {
            self.cold_allowed = min <= 0.0;
        }
        if let Some(p) = p {
            self.cold_allowed = min <= 0.0 || p != 0;
        }
        Cmd::Ok
    }

    fn autotune_command<W: Write>(&mut self, w: &Words, now: u64, out: &mut W, alarm: bool) -> Cmd {
        if self.autotune.is_some() {
            return Cmd::Blocked;
        }
        let h = match w.get(b'E').unwrap_or(0) {
            0 => Heater::HotEnd,
            -1_000_000 => Heater::Bed,
            _ => return Cmd::Error(ErrorCode::InvalidValue, ": M303 E must be 0 (hot end) or -1 (bed)"),
        };
        if let Some(result) = self.autotune_result.take() {
            self.waiting = false;
            return match result {
                Ok(g) => {
                    let _ = writeln!(
                        out,
                        "PID autotune {} Kp:{} Ki:{} Kd:{}",
                        pid_label(h),
                        Decimal::new(g.kp, 3),
                        Decimal::new(g.ki, 4),
                        Decimal::new(g.kd, 3)
                    );
                    Cmd::Ok
                }
                Err(why) => {
                    let _ = writeln!(out, "PID autotune failed: {why}");
                    Cmd::Error(ErrorCode::InvalidValue, ": PID autotune failed")
                }
            };
        }
        if alarm {
            return Cmd::Error(ErrorCode::Alarm, "");
        }
        let cfg = *self.cfg.heater(h);
        if !cfg.enabled {
            return Cmd::Error(ErrorCode::InvalidValue, ": no such heater");
        }
        let Some(s) = w.get(b'S') else {
            return Cmd::Error(ErrorCode::InvalidValue, ": M303 needs a target S");
        };
        let target = s as f32 / MICRO as f32;
        if !(target > 0.0 && target <= cfg.max_target_c - autotune::HYSTERESIS_C) {
            return Cmd::Error(ErrorCode::InvalidValue, ": M303 target above the heater's maximum");
        }
        let cycles = w.get(b'C').map_or(5, |c| c / MICRO);
        let Ok(cycles) = u8::try_from(cycles) else {
            return Cmd::Error(ErrorCode::InvalidValue, ": M303 C must lie in 3..=20");
        };
        if !(3..=autotune::MAX_CYCLES).contains(&cycles) {
            return Cmd::Error(ErrorCode::InvalidValue, ": M303 C must lie in 3..=20");
        }
        let apply = w.get(b'U').is_some_and(|u| u != 0);
        let c = &mut self.ch[h.index()];
        c.target = 0.0;
        c.pid.reset();
        let temp = if c.temp.is_finite() { c.temp } else { 0.0 };
        c.guard.set_target(&cfg.safety, now, target, temp);
        self.autotune = Some((h, Autotune::new(now, target, f32::from(cfg.max_duty), cycles), apply));
        self.waiting = true;
        self.next_report = now;
        Cmd::Blocked
    }
}

fn pid_label(h: Heater) -> &'static str {
    match h {
        Heater::HotEnd => "E0",
        Heater::Bed => "bed",
    }
}

fn detail(why: &'static str) -> &'static str {
    match why {
        "no such heater" => ": no such heater",
        _ => ": target above the heater's maximum (or negative)",
    }
}

/// Spots `M112` in the received bytes, before the line is queued: an emergency stop must act even while earlier
/// lines wait (a heating wait, a full planner queue). It accepts the line start, an optional `N<n>` line number and
/// spaces, then `M112` followed by a non-digit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct EmergencyParser {
    state: u8,
}

impl EmergencyParser {
    const START: u8 = 0;
    const NUMBER: u8 = 1;
    const SKIP: u8 = 10;

    /// A parser at a line start.
    pub const fn new() -> Self {
        EmergencyParser { state: Self::START }
    }

    /// Feed one received byte; `true` when it completed an `M112`.
    pub fn feed(&mut self, b: u8) -> bool {
        if b == b'\n' || b == b'\r' {
            let fire = self.state == 5;
            self.state = Self::START;
            return fire;
        }
        let next = match (self.state, b.to_ascii_uppercase()) {
            (Self::START, b' ') => Self::START,
            (Self::START, b'N') => Self::NUMBER,
            (Self::NUMBER, c) if c.is_ascii_digit() => Self::NUMBER,
            (Self::NUMBER, b' ') => Self::NUMBER,
            (Self::START | Self::NUMBER, b'M') => 2,
            (2, b'1') => 3,
            (3, b'1') => 4,
            (4, b'2') => 5,
            (5, c) if c.is_ascii_digit() => Self::SKIP,
            (5, _) => {
                self.state = Self::SKIP;
                return true;
            }
            _ => Self::SKIP,
        };
        self.state = next;
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gcode::parse_words;
    use std::string::String;

    #[derive(Default)]
    struct Bench {
        counts: [Option<u16>; 2],
        duty: [u8; 2],
        fan: u8,
    }

    impl Heaters for Bench {
        fn set_heater(&mut self, heater: Heater, duty: u8) {
            self.duty[heater.index()] = duty;
        }
        fn read_thermistor(&mut self, heater: Heater) -> Option<u16> {
            self.counts[heater.index()]
        }
        fn set_fan(&mut self, duty: u8) {
            self.fan = duty;
        }
    }

    fn counts_at(t_c: f64) -> u16 {
        // Independent f64 inverse of the beta curve (100k, 3950, 4.7k pull-up, 12 bits).
        let r = 100_000.0 * (3950.0 * (1.0 / (t_c + 273.15) - 1.0 / 298.15)).exp();
        let c = (4095.0 * r / (r + 4700.0)).round();
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss, reason = "0..=4095 by construction")]
        let c = c as u16;
        c
    }

    fn cmd(t: &mut Thermal, io: &mut Bench, line: &str, now: u64) -> (Cmd, String) {
        let mut out = String::new();
        let w = parse_words(line.as_bytes()).unwrap();
        (t.command(&w, now, io, &mut out, false), out)
    }

    #[test]
    fn report_and_targets() {
        let mut t = Thermal::new(ThermalConfig::printer(), 0);
        let mut io = Bench { counts: [Some(counts_at(21.0)), Some(counts_at(20.0))], ..Bench::default() };
        let mut out = String::new();
        assert_eq!(t.tick(&mut io, 0, &mut out), None);
        let (r, text) = cmd(&mut t, &mut io, "M105", 0);
        assert_eq!(r, Cmd::Ok);
        assert!(text.starts_with("T:2") && text.contains("/0.00 B:") && text.ends_with("@:0 B@:0\n"), "{text}");
        assert_eq!(cmd(&mut t, &mut io, "M104 S210", 0).0, Cmd::Ok);
        assert_eq!(t.target(Heater::HotEnd), 210.0);
        assert_eq!(cmd(&mut t, &mut io, "M104 S300", 0).0, Cmd::Error(ErrorCode::InvalidValue, detail("x")));
        assert!(matches!(cmd(&mut t, &mut io, "M104 S200 T1", 0).0, Cmd::Error(ErrorCode::InvalidValue, _)));
        // Heating: full duty far below the target.
        assert_eq!(t.tick(&mut io, 100_000, &mut out), None);
        assert_eq!(io.duty[0], 255);
        // M109 blocks while cold, M109 S with the heater hotter than the target does not wait for it to cool.
        assert_eq!(cmd(&mut t, &mut io, "M109 S210", 100_000).0, Cmd::Blocked);
        io.counts[0] = Some(counts_at(230.0));
        t.tick(&mut io, 200_000, &mut out);
        assert_eq!(cmd(&mut t, &mut io, "M109 S210", 200_000).0, Cmd::Ok);
        assert_eq!(cmd(&mut t, &mut io, "M109 R210", 200_000).0, Cmd::Blocked);
        // Fan.
        assert_eq!(cmd(&mut t, &mut io, "M106 S128", 0).0, Cmd::Ok);
        assert_eq!(io.fan, 128);
        assert_eq!(cmd(&mut t, &mut io, "M107", 0).0, Cmd::Ok);
        assert_eq!(io.fan, 0);
        assert_eq!(cmd(&mut t, &mut io, "M112", 0).0, Cmd::EmergencyStop);
    }

    #[test]
    fn plotter_has_no_heaters() {
        let mut t = Thermal::new(ThermalConfig::NONE, 0);
        let mut io = Bench::default();
        assert_eq!(t.next_deadline(), None);
        assert!(matches!(cmd(&mut t, &mut io, "M104 S200", 0).0, Cmd::Error(ErrorCode::UnknownCommand, _)));
        assert!(matches!(cmd(&mut t, &mut io, "M106", 0).0, Cmd::Error(ErrorCode::UnknownCommand, _)));
        assert_eq!(cmd(&mut t, &mut io, "M112", 0).0, Cmd::EmergencyStop);
    }

    #[test]
    fn open_thermistor_trips_mintemp_and_switches_off() {
        let mut t = Thermal::new(ThermalConfig::printer(), 0);
        let mut io = Bench { counts: [Some(counts_at(150.0)), Some(counts_at(20.0))], ..Bench::default() };
        let mut out = String::new();
        cmd(&mut t, &mut io, "M104 S200", 0);
        assert_eq!(t.tick(&mut io, 0, &mut out), None);
        assert_eq!(io.duty[0], 255);
        io.counts[0] = Some(4095);
        let alarm = t.tick(&mut io, 100_000, &mut out);
        assert_eq!(alarm, Some(ThermalAlarm { heater: Heater::HotEnd, fault: Fault::MinTemp }));
        assert_eq!((io.duty, t.target(Heater::HotEnd)), ([0, 0], 0.0));
    }

    #[test]
    fn config_validation_names_the_heater() {
        let mut c = ThermalConfig::printer();
        assert_eq!(c.validate(), Ok(()));
        c.heaters[1].max_target_c = 124.0;
        let e = c.validate().unwrap_err();
        assert_eq!(e.heater, Some(Heater::Bed));
        assert!(std::format!("{e}").starts_with("heaters.bed: max_target_c"));
        let mut c = ThermalConfig::printer();
        c.heaters[0].safety.watchdog_s = 0.15;
        assert!(c.validate().is_err());
    }

    #[test]
    fn cold_extrusion_guard_and_m302() {
        let mut t = Thermal::new(ThermalConfig::printer(), 0);
        let mut io = Bench { counts: [Some(counts_at(20.0)), Some(counts_at(20.0))], ..Bench::default() };
        let mut out = String::new();
        // No reading yet: cold.
        assert!(t.cold_extrusion().is_some_and(|c| c.temp_c.is_nan() && c.min_c == 170.0));
        assert_eq!(
            std::format!("{}", t.cold_extrusion().unwrap()),
            ": hot end without a valid reading, below the minimum of 170.0 C (M302 P1 allows cold extrusion)"
        );
        t.tick(&mut io, 0, &mut out);
        let cold = t.cold_extrusion().unwrap();
        assert!((cold.temp_c - 20.0).abs() < 0.5, "{cold:?}");
        // Marlin's M302: S sets the minimum (S0 allows), P allows (1) or prevents (0), neither reports.
        assert_eq!(cmd(&mut t, &mut io, "M302 P1", 0).0, Cmd::Ok);
        assert_eq!(t.cold_extrusion(), None);
        let (r, text) = cmd(&mut t, &mut io, "M302", 0);
        assert_eq!(
            (r, text.starts_with("cold extrusion allowed (minimum 170.0 C, hot end 2")),
            (Cmd::Ok, true),
            "{text}"
        );
        assert_eq!(cmd(&mut t, &mut io, "M302 P0", 0).0, Cmd::Ok);
        assert!(t.cold_extrusion().is_some());
        assert_eq!(cmd(&mut t, &mut io, "M302 S0", 0).0, Cmd::Ok);
        assert_eq!(t.cold_extrusion(), None);
        assert_eq!(cmd(&mut t, &mut io, "M302 S0 P0", 0).0, Cmd::Ok, "S0 allows whatever P says");
        assert_eq!(t.cold_extrusion(), None);
        assert_eq!(cmd(&mut t, &mut io, "M302 S19", 0).0, Cmd::Ok);
        assert_eq!(t.cold_extrusion(), None, "20 C is above a 19 C minimum");
        assert_eq!(cmd(&mut t, &mut io, "M302 S25 P1", 0).0, Cmd::Ok);
        assert_eq!(t.cold_extrusion(), None);
        assert_eq!(cmd(&mut t, &mut io, "M302 P0", 0).0, Cmd::Ok);
        assert_eq!(t.cold_extrusion().map(|c| c.min_c), Some(25.0));
        assert!(matches!(cmd(&mut t, &mut io, "M302 S261", 0).0, Cmd::Error(ErrorCode::InvalidValue, _)));
        assert!(matches!(cmd(&mut t, &mut io, "M302 S-1", 0).0, Cmd::Error(ErrorCode::InvalidValue, _)));
        assert!(matches!(cmd(&mut t, &mut io, "M302 P2", 0).0, Cmd::Error(ErrorCode::InvalidValue, _)));
        assert!(matches!(cmd(&mut t, &mut io, "M302 X1", 0).0, Cmd::Error(ErrorCode::UnsupportedWord, _)));
        t.restore_cold_extrusion();
        assert_eq!(t.cold_extrusion().map(|c| c.min_c), Some(170.0));
        // Hot enough: no guard. At 170.0 exactly it is allowed (Marlin refuses only below the minimum).
        io.counts[0] = Some(counts_at(171.0));
        t.tick(&mut io, 100_000, &mut out);
        assert_eq!(t.cold_extrusion(), None);
        // A plotter, or a printer without a hot end: never checked.
        assert_eq!(Thermal::new(ThermalConfig::NONE, 0).cold_extrusion(), None);
        let mut bed_only = ThermalConfig::printer();
        bed_only.heaters[0] = HeaterConfig::NONE;
        assert_eq!(bed_only.validate(), Ok(()));
        assert_eq!(Thermal::new(bed_only, 0).cold_extrusion(), None);
        // The profile's minimum must be reachable.
        let mut c = ThermalConfig::printer();
        c.min_extrude_c = 261.0;
        assert!(std::format!("{}", c.validate().unwrap_err()).starts_with("heaters: min_extrude_c"));
        c.min_extrude_c = 0.0;
        assert_eq!(c.validate(), Ok(()));
        assert_eq!(Thermal::new(c, 0).cold_extrusion(), None, "0 allows cold extrusion");
    }

    #[test]
    fn emergency_parser() {
        let fire = |s: &str| {
            let mut p = EmergencyParser::new();
            s.bytes().filter(|b| p.feed(*b)).count()
        };
        assert_eq!(fire("M112\n"), 1);
        assert_eq!(fire("N12 M112*33\n"), 1);
        assert_eq!(fire("G1 X1\nm112 ; stop\n"), 1);
        assert_eq!(fire("M1120\n"), 0);
        assert_eq!(fire("G1 M112\n"), 0);
        assert_eq!(fire("M11\n"), 0);
    }
}
