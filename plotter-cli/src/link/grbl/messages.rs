//! GRBL 1.1's serial messages: what each line the controller sends means, and the documented meaning of its
//! error and alarm codes, in the words the user sees.
//!
//! Response messages answer one line each (`ok`, `error:N`); push messages come at any time: the start-up banner
//! `Grbl 1.1h ['$' for help]`, `ALARM:N`, `[MSG:…]` feedback, `[VER:…]`/`[OPT:…]` build info, `$n=value`
//! settings, and the `<…>` status report answering the real-time `?`. The code tables follow GRBL 1.1's
//! published error and alarm lists (grbl's `doc/csv/*_codes_en_US.csv`), worded here for a plotter user.

/// Real-time status report request.
pub const RT_STATUS: u8 = b'?';
/// Real-time feed hold.
pub const RT_FEED_HOLD: u8 = b'!';
/// Real-time cycle start / resume.
pub const RT_CYCLE_START: u8 = b'~';
/// Real-time soft reset (Ctrl-X).
pub const RT_RESET: u8 = 0x18;

/// One line from a GRBL controller.
#[derive(Debug, Clone, PartialEq)]
pub enum GrblLine {
    /// `ok`: the line was parsed and executed or queued.
    Ok,
    /// `error:N`: the line was refused (and nothing of it was executed).
    Error(u8),
    /// `ALARM:N`: the controller stopped and locked out G-code.
    Alarm(u8),
    /// The start-up banner (after power-up or a soft reset), with the version (`1.1h`).
    Banner(String),
    /// `[MSG:text]` feedback.
    Msg(String),
    /// `[VER:…]` (build version) or other bracketed feedback (`[OPT:…]`, `[G54:…]`, `[GC:…]`), kept whole
    /// without the brackets.
    Feedback(String),
    /// A status report (`<…>`).
    Status(GrblStatus),
    /// `$n=value`, one line of the `$$` settings listing.
    Setting(u16, f64),
    /// Anything else (echo, noise).
    Other(String),
}

/// A parsed status report `<State|MPos:x,y,z|FS:f,s|WCO:…|Bf:…>` (field order and presence vary with `$10`).
#[derive(Debug, Clone, PartialEq)]
pub struct GrblStatus {
    /// `Idle`, `Run`, `Hold:0`, `Hold:1`, `Jog`, `Alarm`, `Door:N`, `Check`, `Home`, `Sleep`.
    pub state: String,
    /// Machine position, mm, when reported (`MPos`).
    pub mpos: Option<[f64; 3]>,
    /// Work position, mm, when reported instead (`WPos`).
    pub wpos: Option<[f64; 3]>,
    /// Work coordinate offset, mm, when included in this report.
    pub wco: Option<[f64; 3]>,
    /// Free planner blocks and free receive-buffer bytes (`Bf:`), when reported.
    pub buffer: Option<(u32, u32)>,
}

impl GrblStatus {
    /// Whether nothing is moving or queued.
    pub fn is_idle(&self) -> bool {
        self.state == "Idle"
    }

    /// Whether a feed hold has come to a stop (`Hold:0`).
    pub fn is_held(&self) -> bool {
        self.state == "Hold:0"
    }
}

fn xyz(v: &str) -> Option<[f64; 3]> {
    let mut it = v.split(',').map(|x| x.trim().parse::<f64>().ok().filter(|f| f.is_finite()));
    let a = [it.next()??, it.next()??, it.next()??];
    // A fourth axis (grblHAL) is accepted and ignored.
    Some(a)
}

impl GrblStatus {
    /// Parse the inside of `<…>`.
    pub fn parse(s: &str) -> Option<GrblStatus> {
        let mut parts = s.split('|');
        let state = parts.next()?.trim().to_string();
        if state.is_empty() {
            return None;
        }
        let mut st = GrblStatus { state, mpos: None, wpos: None, wco: None, buffer: None };
        for p in parts {
            if let Some(v) = p.strip_prefix("MPos:") {
                st.mpos = Some(xyz(v)?);
            } else if let Some(v) = p.strip_prefix("WPos:") {
                st.wpos = Some(xyz(v)?);
            } else if let Some(v) = p.strip_prefix("WCO:") {
                st.wco = Some(xyz(v)?);
            } else if let Some(v) = p.strip_prefix("Bf:") {
                let (a, b) = v.split_once(',')?;
                st.buffer = Some((a.trim().parse().ok()?, b.trim().parse().ok()?));
            }
        }
        if st.mpos.is_none() && st.wpos.is_none() {
            return None;
        }
        Some(st)
    }
}

impl GrblLine {
    /// Classify one received line.
    pub fn parse(line: &str) -> GrblLine {
        let l = line.trim();
        if l == "ok" {
            return GrblLine::Ok;
        }
        if let Some(n) = l.strip_prefix("error:").and_then(|n| n.trim().parse().ok()) {
            return GrblLine::Error(n);
        }
        if let Some(n) = l.strip_prefix("ALARM:").and_then(|n| n.trim().parse().ok()) {
            return GrblLine::Alarm(n);
        }
        if let Some(rest) = l.strip_prefix("Grbl ") {
            let version = rest.split_whitespace().next().unwrap_or("").to_string();
            return GrblLine::Banner(version);
        }
        if let Some(inner) = l.strip_prefix('<').and_then(|x| x.strip_suffix('>')) {
            return match GrblStatus::parse(inner) {
                Some(s) => GrblLine::Status(s),
                None => GrblLine::Other(l.to_string()),
            };
        }
        if let Some(inner) = l.strip_prefix('[').and_then(|x| x.strip_suffix(']')) {
            return match inner.strip_prefix("MSG:") {
                Some(m) => GrblLine::Msg(m.to_string()),
                None => GrblLine::Feedback(inner.to_string()),
            };
        }
        if let Some((k, v)) = l.strip_prefix('$').and_then(|x| x.split_once('='))
            && let (Ok(k), Ok(v)) = (k.trim().parse(), v.trim().parse::<f64>())
            && v.is_finite()
        {
            return GrblLine::Setting(k, v);
        }
        GrblLine::Other(l.to_string())
    }
}

/// What GRBL 1.1 means by `error:code`.
pub fn error_meaning(code: u8) -> &'static str {
    match code {
        1 => "a G-code word lacks its letter",
        2 => "a number is missing or badly formatted",
        3 => "unknown or unsupported '$' command",
        4 => "a value that must be positive is negative",
        5 => "homing is not enabled in the settings ($22)",
        6 => "the step pulse time must be at least 3 µs",
        7 => "EEPROM read failed; settings were restored to their defaults",
        8 => "this '$' command needs the machine to be idle",
        9 => "G-code is locked out during an alarm or a jog",
        10 => "soft limits need homing to be enabled",
        11 => "the line is longer than the controller accepts; it was not executed",
        12 => "this setting would make the step rate exceed the maximum",
        13 => "the safety door is open",
        14 => "the build info or start-up line is too long to store",
        15 => "the jog target lies outside the machine travel; the jog was ignored",
        16 => "invalid jog command (no '=' or a forbidden G-code)",
        17 => "laser mode needs PWM spindle output",
        20 => "unsupported or invalid G-code command",
        21 => "two commands of the same modal group in one line",
        22 => "no feed rate set",
        23 => "a G-code command needs an integer value",
        24 => "more than one command needing axis words in one line",
        25 => "a G-code word is repeated in the line",
        26 => "axis words are missing for the command",
        27 => "invalid line number",
        28 => "a required value word is missing",
        29 => "G59.x work coordinate systems are not supported",
        30 => "G53 is only allowed with G0 and G1",
        31 => "axis words given that no command uses",
        32 => "an arc (G2/G3) needs at least one in-plane axis word",
        33 => "invalid motion target",
        34 => "invalid arc radius",
        35 => "an arc (G2/G3) needs at least one in-plane offset word",
        36 => "unused value words in the line",
        37 => "the dynamic tool length offset is not on the tool length axis",
        38 => "tool number above the supported maximum",
        _ => "unknown error code",
    }
}

/// What GRBL 1.1 means by `ALARM:code`, and whether the machine position survived it.
pub fn alarm_meaning(code: u8) -> (&'static str, bool) {
    match code {
        1 => ("hard limit switch triggered; the position is probably lost — home again", false),
        2 => ("a motion target exceeds the machine travel (soft limit); the position was kept", true),
        3 => ("reset while moving; the position is probably lost — home again", false),
        4 => ("probe fail: the probe was not in its expected initial state", true),
        5 => ("probe fail: the probe made no contact within the programmed travel", true),
        6 => ("homing fail: the homing cycle was reset", false),
        7 => ("homing fail: the safety door was opened during homing", false),
        8 => ("homing fail: the pull-off did not clear the limit switch (check pull-off $27 and wiring)", false),
        9 => {
            ("homing fail: no limit switch found within the search distance (check max travel $13x and wiring)", false)
        }
        _ => ("unknown alarm", false),
    }
}

/// `error:N (meaning)`.
pub fn describe_error(code: u8) -> String {
    format!("error:{code} ({})", error_meaning(code))
}

/// `ALARM:N (meaning)`.
pub fn describe_alarm(code: u8) -> String {
    format!("ALARM:{code} ({})", alarm_meaning(code).0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn classify_lines() {
        assert_eq!(GrblLine::parse("ok\r"), GrblLine::Ok);
        assert_eq!(GrblLine::parse("error:22"), GrblLine::Error(22));
        assert_eq!(GrblLine::parse("ALARM:9"), GrblLine::Alarm(9));
        assert_eq!(GrblLine::parse("Grbl 1.1h ['$' for help]"), GrblLine::Banner("1.1h".into()));
        assert_eq!(GrblLine::parse("[MSG:'$H'|'$X' to unlock]"), GrblLine::Msg("'$H'|'$X' to unlock".into()));
        assert_eq!(GrblLine::parse("[VER:1.1h.20190825:]"), GrblLine::Feedback("VER:1.1h.20190825:".into()));
        assert_eq!(GrblLine::parse("$110=5000.000"), GrblLine::Setting(110, 5000.0));
        assert_eq!(GrblLine::parse("$N0="), GrblLine::Other("$N0=".into()));
        assert!(matches!(GrblLine::parse("<Idle>"), GrblLine::Other(_)), "a report without a position");
    }

    #[test]
    fn status_reports() {
        let GrblLine::Status(s) = GrblLine::parse("<Hold:0|MPos:1.000,-2.5,0.000|FS:0,0|WCO:0.000,1.000,2.000>") else {
            panic!()
        };
        assert!(s.is_held() && !s.is_idle());
        assert_eq!((s.mpos, s.wco), (Some([1.0, -2.5, 0.0]), Some([0.0, 1.0, 2.0])));
        let s = GrblStatus::parse("Run|WPos:3,4,5,6|Bf:15,128").unwrap();
        assert_eq!((s.wpos, s.mpos, s.buffer), (Some([3.0, 4.0, 5.0]), None, Some((15, 128))));
        assert_eq!(GrblStatus::parse("Idle|MPos:1,2"), None);
    }

    #[test]
    fn meanings_come_from_the_grbl_tables() {
        assert_eq!(describe_error(9), "error:9 (G-code is locked out during an alarm or a jog)");
        assert!(describe_error(22).contains("no feed rate"));
        assert!(describe_alarm(1).contains("hard limit") && !alarm_meaning(1).1);
        assert!(alarm_meaning(2).1, "a soft-limit alarm keeps the position");
        assert_eq!(error_meaning(200), "unknown error code");
    }
}
