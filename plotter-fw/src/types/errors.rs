//! The error and alarm tables: stable numeric codes (machine-readable) with fixed texts.
//!
//! A refused line is answered `error:<code> <text>`, where `<text>` starts with [`ErrorCode::text`] and may add a
//! detail (`error:8 target outside the travel: X`). Alarms are sent unsolicited as `ALARM:<code> <text>` and latch
//! until a reset (0x18); while latched, motion commands are refused with [`ErrorCode::Alarm`].
//!
//! Damaged sequenced frames get no error code: a numbered line or step-block frame that fails its check, and
//! during a sequenced stream any line with a byte ≥ 0x80 that is not a valid frame, is answered `rs <n>` (see
//! [`crate::protocol`]).
//!
//! | code | error | meaning |
//! |-----:|-------|---------|
//! | 1 | `ExpectedCommand` | a word without a letter, or a letter without a number |
//! | 2 | `BadNumber` | a number that does not parse or is out of range |
//! | 3 | `UnknownCommand` | a G or M code this firmware does not implement |
//! | 4 | `UnsupportedWord` | a word letter not used by this firmware, or repeated |
//! | 5 | `LineTooLong` | more than `LINE_MAX` bytes before `\n`; the line was discarded |
//! | 6 | `RxOverflow` | the receive buffer overflowed and bytes of this line were lost |
//! | 7 | `SoftLimit` | the target lies outside the travel; nothing moved |
//! | 8 | `Alarm` | the machine is in alarm; send a reset first |
//! | 9 | `InvalidValue` | a value out of its allowed range (feed ≤ 0, negative dwell, …) |
//! | 10 | `AxisDisabled` | a word for an axis the machine does not have |
//! | 11 | `Checksum` | an unnumbered line carried a bad checksum (numbered ones get `rs`) |
//! | 12 | `BadFrame` | a step-block frame outside the sequenced stream, or one the stepper cannot run |
//! | 13 | `OutOfRange` | a number or target beyond what the machine can represent (see [`crate::range`]); nothing moved |
//! | 14 | `AmbiguousE` | a number runs straight into an `E` word (`X1E5`: X1 and E5 as Marlin reads it, or 1·10⁵ as a script meant it); the line was not executed |
//! | 15 | `ColdExtrusion` | a move with extrusion while the hot end is below the minimum extrusion temperature (see [`crate::thermal`], `M302`); nothing moved |
//!
//! | code | alarm | meaning |
//! |-----:|-------|---------|
//! | 1 | `HardLimit` | a switch was pressed outside homing: motion stopped, queue flushed, position unhomed |
//! | 2 | `HomingNotFound` | homing travelled its maximum distance without reaching the switch |
//! | 3 | `HomingNotReleased` | the switch was still pressed after the pull-off |
//! | 4 | `EmergencyStop` | `M112`: heaters off, motion stopped, motors off |
//! | 5–9 | `Thermal` | a thermal safety check tripped (5 MINTEMP, 6 MAXTEMP, 7 heating failed, 8 thermal runaway, 9 sensor timeout); the text names the sensor; heaters off, motion stopped, motors off |

use core::fmt;

use crate::heater::Heater;

/// Why a line was refused (see the module table).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum ErrorCode {
    /// A word without a letter or a letter without a number.
    ExpectedCommand = 1,
    /// A number that does not parse or is out of range.
    BadNumber = 2,
    /// An unimplemented G or M code.
    UnknownCommand = 3,
    /// A word letter not used here, or repeated.
    UnsupportedWord = 4,
    /// Line longer than the line buffer.
    LineTooLong = 5,
    /// Receive buffer overflow: bytes of this line were lost.
    RxOverflow = 6,
    /// Target outside the travel.
    SoftLimit = 7,
    /// Machine in alarm.
    Alarm = 8,
    /// Value out of range.
    InvalidValue = 9,
    /// Word for an axis the machine lacks.
    AxisDisabled = 10,
    /// Bad checksum on an unnumbered line.
    Checksum = 11,
    /// Step-block frame refused.
    BadFrame = 12,
    /// A number or target the machine cannot represent.
    OutOfRange = 13,
    /// A number run into an `E` word: exponent or extrusion, not guessed.
    AmbiguousE = 14,
    /// Extrusion refused: the hot end is below the minimum extrusion temperature.
    ColdExtrusion = 15,
    /// Homing refused: Z's height was lost and its switch lies past the pen's touch, so homing it where the
    /// carriage stands would press the pen onto the paper (see [`crate::homing`]).
    HomingWouldMark = 16,
}

impl ErrorCode {
    /// The numeric code.
    pub const fn code(self) -> u8 {
        self as u8
    }

    /// The fixed text.
    pub const fn text(self) -> &'static str {
        match self {
            ErrorCode::ExpectedCommand => "expected a letter followed by a number",
            ErrorCode::BadNumber => "bad number",
            ErrorCode::UnknownCommand => "unsupported command",
            ErrorCode::UnsupportedWord => "unsupported or repeated word",
            ErrorCode::LineTooLong => "line too long, discarded",
            ErrorCode::RxOverflow => "receive buffer overflow, bytes lost",
            ErrorCode::SoftLimit => "target outside the travel",
            ErrorCode::Alarm => "alarm active, reset required",
            ErrorCode::InvalidValue => "value out of range",
            ErrorCode::AxisDisabled => "axis not configured",
            ErrorCode::Checksum => "checksum mismatch",
            ErrorCode::BadFrame => "step block refused",
            ErrorCode::OutOfRange => "number out of range",
            ErrorCode::AmbiguousE => "ambiguous number: a number runs into an E word (put a space before E)",
            ErrorCode::ColdExtrusion => "cold extrusion prevented",
            ErrorCode::HomingWouldMark => {
                "homing refused: the pen's height is lost and homing Z here would press the pen onto the paper"
            }
        }
    }
}

impl fmt::Display for ErrorCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "error:{} {}", self.code(), self.text())
    }
}

/// A latched alarm (see the module table).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AlarmCode {
    /// Switch pressed outside homing.
    HardLimit,
    /// Homing switch never found.
    HomingNotFound,
    /// Homing switch still pressed after pull-off.
    HomingNotReleased,
    /// `M112`.
    EmergencyStop,
    /// A thermal safety check tripped.
    Thermal(ThermalAlarm),
}

impl AlarmCode {
    /// The numeric code.
    pub const fn code(self) -> u8 {
        match self {
            AlarmCode::HardLimit => 1,
            AlarmCode::HomingNotFound => 2,
            AlarmCode::HomingNotReleased => 3,
            AlarmCode::EmergencyStop => 4,
            AlarmCode::Thermal(t) => match t.fault {
                Fault::MinTemp => 5,
                Fault::MaxTemp => 6,
                Fault::HeatingFailed => 7,
                Fault::Runaway => 8,
                Fault::SensorTimeout => 9,
            },
        }
    }

    /// The fixed text (for a thermal alarm, without the sensor: see `Display`).
    pub const fn text(self) -> &'static str {
        match self {
            AlarmCode::HardLimit => "hard limit: switch pressed outside homing",
            AlarmCode::HomingNotFound => "homing failed: switch not found",
            AlarmCode::HomingNotReleased => "homing failed: switch still pressed after pull-off",
            AlarmCode::EmergencyStop => "emergency stop (M112): heaters off, motors off",
            AlarmCode::Thermal(t) => match t.fault {
                Fault::MinTemp => "MINTEMP: reading below the minimum or thermistor open",
                Fault::MaxTemp => "MAXTEMP: reading above the maximum or thermistor shorted",
                Fault::HeatingFailed => "heating failed: temperature not rising with the heater on",
                Fault::Runaway => "thermal runaway: temperature fell away from the target while holding",
                Fault::SensorTimeout => "sensor timeout: no fresh temperature reading",
            },
        }
    }

    /// Whether the alarm also switched the heaters and motors off (thermal alarms and the emergency stop).
    pub const fn is_shutdown(self) -> bool {
        matches!(self, AlarmCode::EmergencyStop | AlarmCode::Thermal(_))
    }
}

impl fmt::Display for AlarmCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "ALARM:{} {}", self.code(), self.text())?;
        if let AlarmCode::Thermal(t) = self {
            write!(f, " ({}; heaters off, motors off)", t.heater.name())?;
        }
        Ok(())
    }
}

/// A thermal fault of one heater: what the machine latches as its alarm.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ThermalAlarm {
    /// The heater whose sensor tripped.
    pub heater: Heater,
    /// What tripped.
    pub fault: Fault,
}

/// A safety trip.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fault {
    /// Below the minimum, or the thermistor is open.
    MinTemp,
    /// Above the maximum, or the thermistor is shorted.
    MaxTemp,
    /// Heating but not rising.
    HeatingFailed,
    /// Fell out of the holding band for too long.
    Runaway,
    /// No fresh reading.
    SensorTimeout,
}

impl Fault {
    /// Short name, as printer firmwares print it.
    pub const fn name(self) -> &'static str {
        match self {
            Fault::MinTemp => "MINTEMP",
            Fault::MaxTemp => "MAXTEMP",
            Fault::HeatingFailed => "heating failed",
            Fault::Runaway => "thermal runaway",
            Fault::SensorTimeout => "sensor timeout",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::string::ToString;

    #[test]
    fn codes_are_stable_and_unique() {
        let all = [
            ErrorCode::ExpectedCommand,
            ErrorCode::BadNumber,
            ErrorCode::UnknownCommand,
            ErrorCode::UnsupportedWord,
            ErrorCode::LineTooLong,
            ErrorCode::RxOverflow,
            ErrorCode::SoftLimit,
            ErrorCode::Alarm,
            ErrorCode::InvalidValue,
            ErrorCode::AxisDisabled,
            ErrorCode::Checksum,
            ErrorCode::BadFrame,
            ErrorCode::OutOfRange,
            ErrorCode::AmbiguousE,
            ErrorCode::ColdExtrusion,
            ErrorCode::HomingWouldMark,
        ];
        for (i, e) in all.iter().enumerate() {
            assert_eq!(usize::from(e.code()), i + 1);
        }
        assert_eq!(ErrorCode::SoftLimit.to_string(), "error:7 target outside the travel");
        assert_eq!(AlarmCode::HomingNotFound.to_string(), "ALARM:2 homing failed: switch not found");
        let t = AlarmCode::Thermal(ThermalAlarm { heater: Heater::Bed, fault: Fault::Runaway });
        assert_eq!(t.code(), 8);
        assert_eq!(
            t.to_string(),
            "ALARM:8 thermal runaway: temperature fell away from the target while holding (bed sensor B; heaters \
             off, motors off)"
        );
    }
}
