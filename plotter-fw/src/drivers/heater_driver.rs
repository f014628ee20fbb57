//! The heater driver of the printer profile: the hot end and the bed, each a PWM output with a thermistor input, plus
//! the part-cooling fan, run through [`Heaters`]. Plotter profiles configure none ([`ThermalConfig::NONE`]) and never
//! reach this code. It takes typed commands ([`HeaterCommand`], parsed from G-code by [`crate::thermal_gcode`]).
//!
//! # Scheduling
//! [`Thermal::tick`] runs at the fixed rate [`ThermalConfig::period_ms`] from the core's main loop
//! ([`crate::machine::Machine::poll`], which the scheduler wakes at [`Thermal::next_deadline`]). Each period it
//! reads every configured thermistor ([`crate::hal::Heaters::read_thermistor`]), runs the safety checks
//! ([`crate::thermal::safety`]), then the PID ([`crate::thermal::pid`]) or the autotune relay
//! ([`crate::thermal::autotune`]), and writes the PWM duty.
//!
//! # Commands (Marlin's meanings; M112, the emergency stop, is the machine's)
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
//! //! | `M302` | cold extrusion: `P1` allows it, `P0` prevents it, `S<t>` sets the minimum (`S0` allows), no words report |
//!
//! A wait (`M109`, `M190`, `M303`) keeps its line pending, so the commands after it wait too, and reports the
//! temperatures every second meanwhile. A target is reached once the temperature has stayed within
//! [`crate::thermal::HeaterConfig::wait_window_c`] of it for [`crate::thermal::HeaterConfig::wait_residency_s`].
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
//! latches it as an alarm, stops motion and disables the motors. See [`crate::thermal::safety`] for the checks and
//! their times.

use core::fmt::{self, Write};

use crate::decimal::Decimal;
use crate::errors::{ErrorCode, Fault, ThermalAlarm};
use crate::hal::Heaters;
use crate::heater::{Heater, NUM_HEATERS};
use crate::thermal::ThermalConfig;
use crate::thermal::autotune::{self, Autotune, Step};
use crate::thermal::pid::{Pid, PidGains};
use crate::thermal::safety::{self, Guard, ticks};
use crate::thermal::thermistor::Reading;
use crate::thermal_gcode::HeaterCommand;

/// What a heater command asks the machine to do.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Cmd {
    /// Done: answer `ok`.
    Ok,
    /// Waiting (for a temperature or an autotune): keep the line and retry.
    Blocked,
    /// Refused: answer `error:` with this code and detail.
    Error(ErrorCode, &'static str),
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

    /// Run a command parsed from G-code ([`crate::thermal_gcode`]). `alarm`: the machine is in alarm (heating is
    /// refused then). Reports go to `out`.
    pub fn command<IO: Heaters, W: Write>(
        &mut self,
        cmd: HeaterCommand,
        now: u64,
        io: &mut IO,
        out: &mut W,
        alarm: bool,
    ) -> Cmd {
        match cmd {
            HeaterCommand::Fan(_) if !self.cfg.fan => Cmd::Error(ErrorCode::UnknownCommand, ": no fan configured"),
            HeaterCommand::Fan(duty) => {
                self.fan = duty;
                io.set_fan(duty);
                Cmd::Ok
            }
            HeaterCommand::Report => {
                self.report(out);
                Cmd::Ok
            }
            HeaterCommand::ReportEvery(every) => {
                self.report_every = every;
                self.next_report = now;
                Cmd::Ok
            }
            HeaterCommand::Gains { heater, kp, ki, kd } => self.gains_command(heater, [kp, ki, kd], out),
            HeaterCommand::ColdExtrusion { min_c, allow } => self.cold_extrusion_command(min_c, allow, out),
            HeaterCommand::Autotune { heater, target_c, cycles, apply } => {
                self.autotune_command(heater, target_c, cycles, apply, now, out, alarm)
            }
            HeaterCommand::Target { heater, target_c, wait, cooling } => {
                self.target_command(heater, target_c, wait, cooling, now, alarm)
            }
        }
    }

    /// `M104`/`M109`/`M140`/`M190`: set the target, then (with `wait`) keep the line pending until it is reached.
    fn target_command(
        &mut self,
        h: Heater,
        target: Option<f32>,
        wait: bool,
        cooling: bool,
        now: u64,
        alarm: bool,
    ) -> Cmd {
        if let Some(t) = target {
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

    /// `M301`/`M304`: replace the given gains (`[kp, ki, kd]`), or report them when none is given.
    fn gains_command<W: Write>(&mut self, h: Heater, given: [Option<f32>; 3], out: &mut W) -> Cmd {
        if !self.cfg.heater(h).enabled {
            return Cmd::Error(ErrorCode::InvalidValue, ": no such heater");
        }
        let mut g = self.ch[h.index()].gains;
        if given.iter().all(Option::is_none) {
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
        let [kp, ki, kd] = given;
        g.kp = kp.unwrap_or(g.kp);
        g.ki = ki.unwrap_or(g.ki);
        g.kd = kd.unwrap_or(g.kd);
        if !g.is_valid() {
            return Cmd::Error(ErrorCode::InvalidValue, ": PID gains must be non-negative, P positive");
        }
        self.ch[h.index()].gains = g;
        Cmd::Ok
    }

    /// `M302` as in Marlin: `S<t>` sets the minimum (and `S0` allows cold extrusion, any other `S` prevents it),
    /// `P1`/`P0` allows/prevents it, neither reports the setting.
    fn cold_extrusion_command<W: Write>(&mut self, s: Option<f32>, p: Option<bool>, out: &mut W) -> Cmd {
        let hotend = *self.cfg.heater(Heater::HotEnd);
        if !hotend.enabled {
            return Cmd::Error(ErrorCode::InvalidValue, ": no hot end");
        }
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
        let min = match s {
            Some(s) if !(0.0..=hotend.max_target_c).contains(&s) => {
                return Cmd::Error(ErrorCode::InvalidValue, ": M302 S must lie from 0 to the hot end's maximum");
            }
            Some(s) => s,
            None => self.min_extrude_c,
        };
        self.min_extrude_c = min;
        if s.is_some() {
            self.cold_allowed = min <= 0.0;
        }
        if let Some(p) = p {
            self.cold_allowed = min <= 0.0 || p;
        }
        Cmd::Ok
    }

    /// `M303`: start an autotune (the line stays pending), or, once it ended, report its result.
    #[allow(clippy::too_many_arguments, reason = "the command's four values plus the call's context")]
    fn autotune_command<W: Write>(
        &mut self,
        h: Heater,
        target: f32,
        cycles: u8,
        apply: bool,
        now: u64,
        out: &mut W,
        alarm: bool,
    ) -> Cmd {
        if self.autotune.is_some() {
            return Cmd::Blocked;
        }
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
        if !(target > 0.0 && target <= cfg.max_target_c - autotune::HYSTERESIS_C) {
            return Cmd::Error(ErrorCode::InvalidValue, ": M303 target above the heater's maximum");
        }
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gcode::parse_words;
    use crate::thermal::HeaterConfig;
    use crate::thermal_gcode::{ThermalLine, parse};
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
        let r = match parse(&w, t.config()) {
            Some(Ok(ThermalLine::Heaters(c))) => t.command(c, now, io, &mut out, false),
            Some(Err((code, detail))) => Cmd::Error(code, detail),
            other => panic!("{line}: {other:?}"),
        };
        (r, out)
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
    }

    #[test]
    fn plotter_has_no_heaters() {
        let mut t = Thermal::new(ThermalConfig::NONE, 0);
        let mut io = Bench::default();
        assert_eq!(t.next_deadline(), None);
        assert!(matches!(cmd(&mut t, &mut io, "M104 S200", 0).0, Cmd::Error(ErrorCode::UnknownCommand, _)));
        assert!(matches!(cmd(&mut t, &mut io, "M106", 0).0, Cmd::Error(ErrorCode::UnknownCommand, _)));
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
}
