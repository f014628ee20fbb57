//! The console: what a typed line sends to the firmware (shared by `plotter console` and the web app's console).

use plotter_fw::protocol::{RT_FEED_HOLD, RT_RESET, RT_RESUME, RT_STATUS};

use super::ebb::messages::{EbbLine, describe_error as describe_ebb_error};
use super::grbl::messages::{GrblLine, describe_alarm, describe_error};
use super::machine::Firmware;

/// What a typed line sends: a line holding only `?`, `!` or `~` is that real-time byte (status report, feed hold,
/// resume), `reset` is Ctrl-X; anything else is sent as a line.
pub fn console_bytes(line: &str) -> Vec<u8> {
    match line.trim() {
        "?" => vec![RT_STATUS],
        "!" => vec![RT_FEED_HOLD],
        "~" => vec![RT_RESUME],
        "reset" => vec![RT_RESET],
        other => format!("{other}\n").into_bytes(),
    }
}

/// A reply as the console shows it: GRBL's `error:N` and `ALARM:N` get their meaning, and so do an EiBotBoard's
/// `!N Err: …`; our firmware's lines are shown as they are.
pub fn shown_reply(line: &str, firmware: Firmware) -> String {
    if firmware != Firmware::Grbl {
        if let EbbLine::Error { code, text } = EbbLine::parse(line)
            && line.starts_with('!')
        {
            return describe_ebb_error(code, &text);
        }
        return line.to_string();
    }
    match GrblLine::parse(line) {
        GrblLine::Error(c) => describe_error(c),
        GrblLine::Alarm(c) => describe_alarm(c),
        _ => line.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn real_time_keys() {
        assert_eq!(console_bytes(" ? "), b"?");
        assert_eq!(console_bytes("reset"), [0x18]);
        assert_eq!(console_bytes("G1 X1"), b"G1 X1\n");
    }

    #[test]
    fn replies_shown() {
        assert_eq!(shown_reply("error:22", Firmware::Grbl), "error:22 (no feed rate set)");
        assert_eq!(shown_reply("error:22", Firmware::Ours), "error:22");
        assert_eq!(
            shown_reply("!8 Err: Unknown command 'XX:5858'", Firmware::Ebb),
            "!8 Err: Unknown command 'XX:5858' (unknown command)"
        );
    }
}
