//! The console: what a typed line sends to the firmware (shared by `plotter console` and the web app's console).

use plotter_fw::protocol::{RT_FEED_HOLD, RT_RESET, RT_RESUME, RT_STATUS};

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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn real_time_keys() {
        assert_eq!(console_bytes(" ? "), b"?");
        assert_eq!(console_bytes("reset"), [0x18]);
        assert_eq!(console_bytes("G1 X1"), b"G1 X1\n");
    }
}
