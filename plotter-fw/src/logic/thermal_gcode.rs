//! The temperature, fan and emergency-stop commands of the G-code language, parsed into typed commands: the G-code
//! side of the heaters, so the heater driver ([`crate::heater_driver`]) never sees a word or a letter (as in
//! Marlin, whose `gcode/temp/` handlers parse and call the temperature module, never the reverse).
//!
//! | command | parses to |
//! |---------|-----------|
//! | `M104 S<t>` / `M140 S<t>` | [`HeaterCommand::Target`], no wait (`S0` = off) |
//! | `M109 S<t>` / `M109 R<t>` / `M190 S<t>` / `M190 R<t>` | the same, then wait: `S` waits only while heating, `R` also while cooling |
//! | `M105` | [`HeaterCommand::Report`] |
//! | `M155 S<s>` | [`HeaterCommand::ReportEvery`] (0 = off) |
//! | `M106 S<0–255>` / `M107` | [`HeaterCommand::Fan`] |
//! | `M301 P I D` / `M304 P I D` | [`HeaterCommand::Gains`] (no words: report) |
//! | `M302 P<0\|1> S<t>` | [`HeaterCommand::ColdExtrusion`] |
//! | `M303 E<0\|-1> S<t> C<n> U1` | [`HeaterCommand::Autotune`] |
//! | `M112` | [`ThermalLine::EmergencyStop`] — the machine's one stop path, not a heater command |
//!
//! What the words alone decide is checked here (letters, number ranges); what depends on the heaters' state (a
//! target above a heater's maximum, gains, a running autotune) is the driver's. Whether the machine has a fan or any
//! heater is checked first, from its [`ThermalConfig`], so a plotter answers "no heaters configured" to `M104`.

use crate::errors::ErrorCode;
use crate::gcode::Words;
use crate::heater::Heater;
use crate::range::MICRO;
use crate::thermal::ThermalConfig;

/// A command for the heater driver.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum HeaterCommand {
    /// Set (when `target_c` is given) the target of `heater`, °C (0 = off), then, with `wait`, wait until it is
    /// reached: only while heating, or also while cooling with `cooling` (the `R` word).
    Target {
        /// The heater.
        heater: Heater,
        /// The new target, °C; `None` keeps the current one.
        target_c: Option<f32>,
        /// Wait for the target (`M109`, `M190`).
        wait: bool,
        /// `R`: also wait while cooling down.
        cooling: bool,
    },
    /// Write the temperature report (`M105`).
    Report,
    /// Report the temperatures every this many ticks (µs), 0 = off (`M155`).
    ReportEvery(u64),
    /// Part-cooling fan duty, 0–255 (`M106`, `M107` = 0).
    Fan(u8),
    /// PID gains of `heater`: each given one replaces the current; none given reports them (`M301`, `M304`).
    Gains {
        /// The heater.
        heater: Heater,
        /// Proportional gain.
        kp: Option<f32>,
        /// Integral gain.
        ki: Option<f32>,
        /// Derivative gain.
        kd: Option<f32>,
    },
    /// `M302`: the minimum extrusion temperature (°C, `S`) and/or whether cold extrusion is allowed (`P`); neither
    /// reports the setting.
    ColdExtrusion {
        /// `S<t>`: the new minimum, °C (0–10 000; the driver checks it against the hot end's maximum).
        min_c: Option<f32>,
        /// `P1` (true) allows, `P0` (false) prevents.
        allow: Option<bool>,
    },
    /// PID autotune of `heater` around `target_c` over `cycles` cycles; `apply` sets the gains found (`M303`).
    Autotune {
        /// The heater.
        heater: Heater,
        /// The target, °C.
        target_c: f32,
        /// Relay cycles, 3–20.
        cycles: u8,
        /// `U1`: apply the gains found.
        apply: bool,
    },
}

/// A parsed line of this module's commands.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ThermalLine {
    /// `M112`: stop everything.
    EmergencyStop,
    /// A command for the heater driver.
    Heaters(HeaterCommand),
}

/// A refused line: the error code and the detail of the `error:` reply.
pub type Refusal = (ErrorCode, &'static str);

/// Whether `m` is a command of this module.
pub fn handles(m: u16) -> bool {
    matches!(m, 104 | 105 | 106 | 107 | 109 | 112 | 140 | 155 | 190 | 301 | 302 | 303 | 304)
}

/// Parse `w` for a machine with the heaters of `cfg`: `None` when the line holds none of this module's commands.
pub fn parse(w: &Words, cfg: &ThermalConfig) -> Option<Result<ThermalLine, Refusal>> {
    let &m = w.m.iter().find(|m| handles(**m))?;
    Some(parse_code(m, w, cfg))
}

fn parse_code(m: u16, w: &Words, cfg: &ThermalConfig) -> Result<ThermalLine, Refusal> {
    if w.m.len() > 1 || !w.g.is_empty() {
        return Err((ErrorCode::UnsupportedWord, ": a temperature command goes on a line of its own"));
    }
    if m == 112 {
        return Ok(ThermalLine::EmergencyStop);
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
            return Err((ErrorCode::UnsupportedWord, ": not a word of this command"));
        }
    }
    let cmd = if matches!(m, 106 | 107) { parse_fan(m, w, cfg)? } else { parse_heater(m, w, cfg)? };
    Ok(ThermalLine::Heaters(cmd))
}

/// A G-code value (millionths) in its unit, e.g. °C or a gain.
fn units(v: i64) -> f32 {
    v as f32 / MICRO as f32
}

fn parse_fan(m: u16, w: &Words, cfg: &ThermalConfig) -> Result<HeaterCommand, Refusal> {
    if !cfg.fan {
        return Err((ErrorCode::UnknownCommand, ": no fan configured"));
    }
    if w.get(b'P').is_some_and(|p| p != 0) {
        return Err((ErrorCode::InvalidValue, ": only fan P0 exists"));
    }
    let duty = if m == 107 { 0 } else { w.get(b'S').map_or(255, |s| s / MICRO) };
    u8::try_from(duty).map(HeaterCommand::Fan).map_err(|_| (ErrorCode::InvalidValue, ": fan S must lie in 0..=255"))
}

fn parse_heater(m: u16, w: &Words, cfg: &ThermalConfig) -> Result<HeaterCommand, Refusal> {
    if !cfg.is_active() {
        return Err((ErrorCode::UnknownCommand, ": no heaters configured"));
    }
    if w.get(b'T').is_some_and(|t| t != 0) {
        return Err((ErrorCode::InvalidValue, ": only tool T0 exists"));
    }
    match m {
        105 => Ok(HeaterCommand::Report),
        155 => {
            let s = w.get(b'S').unwrap_or(0);
            if !(0..=60 * MICRO).contains(&s) {
                return Err((ErrorCode::InvalidValue, ": M155 S must lie in 0..=60 s"));
            }
            // Seconds in millionths = µs = ticks.
            Ok(HeaterCommand::ReportEvery(u64::try_from(s).unwrap_or(0)))
        }
        301 | 304 => Ok(HeaterCommand::Gains {
            heater: if m == 301 { Heater::HotEnd } else { Heater::Bed },
            kp: w.get(b'P').map(units),
            ki: w.get(b'I').map(units),
            kd: w.get(b'D').map(units),
        }),
        302 => {
            let allow = match w.get(b'P') {
                None => None,
                Some(0) => Some(false),
                Some(MICRO) => Some(true),
                Some(_) => return Err((ErrorCode::InvalidValue, ": M302 P must be 0 (prevent) or 1 (allow)")),
            };
            let min_c = match w.get(b'S') {
                Some(s) if !(0..=MICRO * 10_000).contains(&s) => {
                    return Err((ErrorCode::InvalidValue, ": M302 S must lie from 0 to the hot end's maximum"));
                }
                s => s.map(units),
            };
            Ok(HeaterCommand::ColdExtrusion { min_c, allow })
        }
        303 => {
            let heater = match w.get(b'E').unwrap_or(0) {
                0 => Heater::HotEnd,
                -1_000_000 => Heater::Bed,
                _ => return Err((ErrorCode::InvalidValue, ": M303 E must be 0 (hot end) or -1 (bed)")),
            };
            let Some(s) = w.get(b'S') else {
                return Err((ErrorCode::InvalidValue, ": M303 needs a target S"));
            };
            let cycles = u8::try_from(w.get(b'C').map_or(5, |c| c / MICRO))
                .ok()
                .filter(|c| (3..=crate::thermal::autotune::MAX_CYCLES).contains(c))
                .ok_or((ErrorCode::InvalidValue, ": M303 C must lie in 3..=20"))?;
            let apply = w.get(b'U').is_some_and(|u| u != 0);
            Ok(HeaterCommand::Autotune { heater, target_c: units(s), cycles, apply })
        }
        _ => {
            let heater = if matches!(m, 104 | 109) { Heater::HotEnd } else { Heater::Bed };
            let (value, cooling) = match (w.get(b'S'), w.get(b'R')) {
                (Some(_), Some(_)) => return Err((ErrorCode::UnsupportedWord, ": S or R, not both")),
                (Some(s), None) => (Some(s), false),
                (None, Some(r)) => (Some(r), true),
                (None, None) => (None, false),
            };
            Ok(HeaterCommand::Target { heater, target_c: value.map(units), wait: matches!(m, 109 | 190), cooling })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gcode::parse_words;

    fn p(line: &str, cfg: &ThermalConfig) -> Option<Result<ThermalLine, Refusal>> {
        parse(&parse_words(line.as_bytes()).unwrap(), cfg)
    }

    fn heaters(line: &str) -> HeaterCommand {
        match p(line, &ThermalConfig::printer()) {
            Some(Ok(ThermalLine::Heaters(c))) => c,
            other => panic!("{line}: {other:?}"),
        }
    }

    fn refused(line: &str, cfg: &ThermalConfig) -> ErrorCode {
        match p(line, cfg) {
            Some(Err((code, _))) => code,
            other => panic!("{line}: {other:?}"),
        }
    }

    #[test]
    fn commands_parse_to_their_typed_form() {
        let t = |heater, target_c, wait, cooling| HeaterCommand::Target { heater, target_c, wait, cooling };
        assert_eq!(heaters("M104 S210"), t(Heater::HotEnd, Some(210.0), false, false));
        assert_eq!(heaters("M109 R60.5"), t(Heater::HotEnd, Some(60.5), true, true));
        assert_eq!(heaters("M190 S60"), t(Heater::Bed, Some(60.0), true, false));
        assert_eq!(heaters("M140"), t(Heater::Bed, None, false, false));
        assert_eq!(heaters("M106 S128"), HeaterCommand::Fan(128));
        assert_eq!(heaters("M106"), HeaterCommand::Fan(255));
        assert_eq!(heaters("M107"), HeaterCommand::Fan(0));
        assert_eq!(heaters("M105"), HeaterCommand::Report);
        assert_eq!(heaters("M155 S2"), HeaterCommand::ReportEvery(2_000_000));
        assert_eq!(
            heaters("M304 P10 D2.5"),
            HeaterCommand::Gains { heater: Heater::Bed, kp: Some(10.0), ki: None, kd: Some(2.5) }
        );
        assert_eq!(heaters("M302 S0 P1"), HeaterCommand::ColdExtrusion { min_c: Some(0.0), allow: Some(true) });
        assert_eq!(
            heaters("M303 E-1 S60 C8 U1"),
            HeaterCommand::Autotune { heater: Heater::Bed, target_c: 60.0, cycles: 8, apply: true }
        );
        assert_eq!(p("M112", &ThermalConfig::NONE), Some(Ok(ThermalLine::EmergencyStop)));
        assert_eq!(p("G1 X1", &ThermalConfig::printer()), None);
    }

    #[test]
    fn what_the_words_decide_is_refused_here() {
        let printer = ThermalConfig::printer();
        assert_eq!(refused("M104 S200 M105", &printer), ErrorCode::UnsupportedWord);
        assert_eq!(refused("G1 M112", &printer), ErrorCode::UnsupportedWord);
        assert_eq!(refused("M104 X1", &printer), ErrorCode::UnsupportedWord);
        assert_eq!(refused("M109 S200 R200", &printer), ErrorCode::UnsupportedWord);
        assert_eq!(refused("M104 S200 T1", &printer), ErrorCode::InvalidValue);
        assert_eq!(refused("M106 S256", &printer), ErrorCode::InvalidValue);
        assert_eq!(refused("M106 P1", &printer), ErrorCode::InvalidValue);
        assert_eq!(refused("M155 S61", &printer), ErrorCode::InvalidValue);
        assert_eq!(refused("M302 P2", &printer), ErrorCode::InvalidValue);
        assert_eq!(refused("M302 S-1", &printer), ErrorCode::InvalidValue);
        assert_eq!(refused("M303 E1 S200", &printer), ErrorCode::InvalidValue);
        assert_eq!(refused("M303 S200 C2", &printer), ErrorCode::InvalidValue);
        assert_eq!(refused("M303 S200 C21", &printer), ErrorCode::InvalidValue);
        assert_eq!(refused("M303 E0", &printer), ErrorCode::InvalidValue);
        // A plotter has neither heaters nor a fan: the command is unknown there, whatever its words.
        assert_eq!(refused("M104 S200 T1", &ThermalConfig::NONE), ErrorCode::UnknownCommand);
        assert_eq!(refused("M106", &ThermalConfig::NONE), ErrorCode::UnknownCommand);
    }
}
