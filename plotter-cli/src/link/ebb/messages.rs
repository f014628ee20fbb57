//! The EBB's side of the conversation: its version string, its replies (`OK`, data lines, errors starting with
//! `!`), and the documented meaning of every error number, as the EBB command reference lists them.
//!
//! Replies are in the firmware's default ("legacy") syntax: a command is answered `OK` once parsed and queued; a
//! query answers its data (some queries follow it with `OK`, some do not); an error replaces the `OK` with one
//! `!<n> Err: <text>` line. Firmware 3's "future syntax" (`CU,10,1`) prefixes every reply with the command's
//! name; the session switches it off when it finds a board left in it.

use std::fmt;

/// A firmware version `major.minor.patch`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub struct EbbVersion(pub u16, pub u16, pub u16);

impl EbbVersion {
    /// The version in the `V` reply (`EBBv13_and_above EB Firmware Version 2.8.1`), in either syntax.
    pub fn parse(line: &str) -> Option<EbbVersion> {
        let line = line.strip_prefix("V,").unwrap_or(line);
        if !line.contains("EB") {
            return None;
        }
        let v = line.rsplit("Version").next()?.trim();
        let mut parts = v.split('.').map(|p| p.trim().parse::<u16>());
        let major = parts.next()?.ok()?;
        let minor = parts.next()?.ok()?;
        let patch = parts.next().and_then(Result::ok).unwrap_or(0);
        Some(EbbVersion(major, minor, patch))
    }

    /// `LM` (low-level move with acceleration) exists: firmware 2.7.0 and later.
    pub fn has_lm(self) -> bool {
        self >= EbbVersion(2, 7, 0)
    }

    /// `QG` (query general) exists: 2.6.2 and later (older boards are asked `QM`).
    pub fn has_qg(self) -> bool {
        self >= EbbVersion(2, 6, 2)
    }

    /// The motion FIFO can be deepened with `CU,4` (and its limit read with `QU,2`): 3.0 and later.
    pub fn has_deep_fifo(self) -> bool {
        self >= EbbVersion(3, 0, 0)
    }

    /// `SP,2` (raise the pen now, bypassing the queue): 3.0.1 and later.
    pub fn has_immediate_pen_up(self) -> bool {
        self >= EbbVersion(3, 0, 1)
    }

    /// `QE` (motor enables and step mode): 2.8.0 and later.
    pub fn has_qe(self) -> bool {
        self >= EbbVersion(2, 8, 0)
    }

    /// `HM` with a target position (absolute move): 2.7.0 and later.
    pub fn has_hm(self) -> bool {
        self >= EbbVersion(2, 7, 0)
    }
}

impl fmt::Display for EbbVersion {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}.{}.{}", self.0, self.1, self.2)
    }
}

/// One reply line.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum EbbLine {
    /// `OK`: the command was parsed (and queued, for motion commands).
    Ok,
    /// `!<code> Err: <text>`: the command was refused.
    Error {
        /// The error number.
        code: u8,
        /// The board's text.
        text: String,
    },
    /// Anything else: a query's data.
    Data(String),
}

impl EbbLine {
    /// Classify one line (line end already removed). A future-syntax error (`SM,!4 Err: …`) is an error too.
    pub fn parse(line: &str) -> EbbLine {
        let l = line.trim();
        if l == "OK" {
            return EbbLine::Ok;
        }
        let err = l.strip_prefix('!').or_else(|| l.split_once(",!").map(|(_, e)| e));
        if let Some(e) = err {
            let digits: String = e.chars().take_while(char::is_ascii_digit).collect();
            if let Ok(code) = digits.parse::<u8>() {
                let text = e[digits.len()..].trim_start().trim_start_matches("Err:").trim().to_string();
                return EbbLine::Error { code, text };
            }
        }
        EbbLine::Data(l.to_string())
    }
}

/// What an EBB error number means (the command reference's "Returned Errors").
pub fn error_meaning(code: u8) -> &'static str {
    match code {
        0 => "a motor's step rate is outside 0.00001164..25000 steps/s",
        1 => "invalid step rate (an internal math error in the move)",
        2 => "the board's reply buffer overflowed",
        3 => "the command is longer than 255 bytes",
        4 => "a parameter is missing",
        5 => "a comma was expected",
        6 => "a parameter is out of its range",
        7 => "one parameter too many",
        8 => "unknown command",
        9 => "checksum incorrect",
        10 => "a checksum is required but missing",
        _ => "undocumented error",
    }
}

/// An error line explained: `!6 Err: Invalid parameter value (a parameter is out of its range)`.
pub fn describe_error(code: u8, text: &str) -> String {
    format!("!{code} Err: {text} ({})", error_meaning(code))
}

/// The `QG` status byte.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct GeneralStatus(pub u8);

impl GeneralStatus {
    /// Parse the two hex digits (either syntax).
    pub fn parse(line: &str) -> Option<GeneralStatus> {
        let l = line.trim();
        let l = l.strip_prefix("QG,").unwrap_or(l);
        (l.len() == 2).then(|| u8::from_str_radix(l, 16).ok().map(GeneralStatus)).flatten()
    }

    /// A command executing, a motor moving, or a command waiting (bits 0..=3): motion not finished.
    pub fn busy(self) -> bool {
        self.0 & 0x0F != 0
    }

    /// The pen is up (bit 4, as firmware 3 documents it).
    pub fn pen_up(self) -> bool {
        self.0 & 0x10 != 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn versions_and_their_features() {
        let v = EbbVersion::parse("EBBv13_and_above EB Firmware Version 2.8.1").unwrap();
        assert_eq!(v, EbbVersion(2, 8, 1));
        assert!(v.has_lm() && v.has_qg() && !v.has_deep_fifo() && !v.has_immediate_pen_up());
        let v3 = EbbVersion::parse("V,EBBv13_and_above EB Firmware Version 3.0.2").unwrap();
        assert!(v3.has_deep_fifo() && v3.has_immediate_pen_up() && v3 > v);
        assert!(!EbbVersion::parse("EBBv13_and_above EB Firmware Version 2.5.1").unwrap().has_lm());
        assert_eq!(EbbVersion::parse("Grbl 1.1h ['$' for help]"), None);
        assert_eq!(v3.to_string(), "3.0.2");
    }

    #[test]
    fn replies_and_errors() {
        assert_eq!(EbbLine::parse("OK"), EbbLine::Ok);
        assert_eq!(EbbLine::parse("12,-4"), EbbLine::Data("12,-4".into()));
        assert_eq!(
            EbbLine::parse("!8 Err: Unknown command 'B:42'"),
            EbbLine::Error { code: 8, text: "Unknown command 'B:42'".into() }
        );
        assert_eq!(
            EbbLine::parse("SM,!4 Err: Missing parameter(s)"),
            EbbLine::Error { code: 4, text: "Missing parameter(s)".into() }
        );
        assert_eq!(
            describe_error(6, "Invalid parameter value"),
            "!6 Err: Invalid parameter value (a parameter is out of its range)"
        );
    }

    #[test]
    fn the_general_status_byte() {
        // 3E = 0011 1110: PRG pressed, pen up (bit 4), command executing, both motors moving, FIFO empty.
        let s = GeneralStatus::parse("3E").unwrap();
        assert!(s.busy() && s.pen_up());
        assert!(!GeneralStatus::parse("QG,10").unwrap().busy());
        assert_eq!(GeneralStatus::parse("3E0"), None);
    }
}
