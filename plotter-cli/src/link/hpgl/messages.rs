//! What an HP-GL plotter says and is told outside the HP-GL instructions: the device-control escapes and the
//! meaning of its error numbers.
//!
//! Facts from HP's interfacing and programming manuals (7475A, 7550A) and the error tables plotter makers copied
//! from them: device-control instructions start with `ESC .` and a letter, are executed as soon as they arrive
//! (they do not enter the input buffer), and those that answer send a decimal number followed by the output
//! terminator (a CR unless `ESC . M` changes it). `OE` (an HP-GL instruction, so it waits its turn in the buffer)
//! answers the number of the first HP-GL error since the last `OE` or `IN`; `ESC . E` answers the last
//! device-control / interface error.

/// ESC, the first byte of a device-control instruction.
pub const ESC: u8 = 0x1b;
/// DC1, Xon: the plotter may be sent bytes again.
pub const XON: u8 = 0x11;
/// DC3, Xoff: the plotter's buffer is nearly full, stop sending.
pub const XOFF: u8 = 0x13;
/// The output terminator of the plotter's answers (the default one).
pub const CR: u8 = b'\r';

/// `ESC . B`: output the free space of the input buffer, bytes.
pub const BUFFER_SPACE: &[u8] = b"\x1b.B";
/// `ESC . L`: output the size of the input buffer when it is empty, bytes.
pub const BUFFER_SIZE: &[u8] = b"\x1b.L";
/// `ESC . E`: output the last device-control error number (0: none), and clear it.
pub const EXTENDED_ERROR: &[u8] = b"\x1b.E";
/// `ESC . K`: abort graphics — the input buffer is emptied and the instruction being executed is dropped.
pub const ABORT_GRAPHICS: &[u8] = b"\x1b.K";
/// `ESC . R`: reset the handshake and device-control settings to their defaults.
pub const RESET_HANDSHAKE: &[u8] = b"\x1b.R";

/// `ESC . I threshold ; ; 17 :` and `ESC . N ; 19 :`: Xon/Xoff on — Xoff (DC3) when the free space falls below
/// `threshold` bytes, Xon (DC1) when there is room again.
pub fn xon_xoff_setup(threshold: usize) -> Vec<u8> {
    format!("\x1b.I{threshold};;{XON}:\x1b.N;{XOFF}:").into_bytes()
}

/// The meaning of an HP-GL error number (`OE`, 1–7) or a device-control error number (`ESC . E`, 10–17).
pub fn describe(code: u32) -> &'static str {
    match code {
        0 => "no error",
        1 => "instruction not recognized",
        2 => "wrong number of parameters",
        3 => "parameter out of range",
        4 => "illegal character",
        5 => "unknown character set",
        6 => "position overflow",
        7 => "buffer overflow (polygon or downloadable characters)",
        10 => "output instruction received while another output was pending",
        11 => "invalid byte after ESC .",
        12 => "invalid byte in a device-control instruction",
        13 => "device-control parameter out of range",
        14 => "too many device-control parameters",
        15 => "framing, parity or overrun error on the line",
        16 => "input buffer overflow: bytes were lost",
        17 => "baud rate mismatch",
        _ => "an error number no known plotter uses",
    }
}

/// `N (meaning)` for messages.
pub fn error_text(code: u32) -> String {
    format!("error {code} ({})", describe(code))
}

/// Parse an answer: a decimal number (spaces allowed around it).
pub fn parse_number(answer: &str) -> Option<u32> {
    answer.trim().parse().ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn errors_have_their_manual_meanings() {
        assert_eq!(describe(1), "instruction not recognized");
        assert_eq!(describe(3), "parameter out of range");
        assert_eq!(error_text(16), "error 16 (input buffer overflow: bytes were lost)");
        assert_eq!(describe(99), "an error number no known plotter uses");
        assert_eq!(parse_number(" 1024 "), Some(1024));
        assert_eq!(parse_number("x"), None);
        assert_eq!(xon_xoff_setup(15), b"\x1b.I15;;17:\x1b.N;19:");
    }
}
