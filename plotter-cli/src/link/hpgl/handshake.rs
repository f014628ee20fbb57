//! The three ways of not overrunning an HP-GL plotter's input buffer, chosen with `--handshake`:
//!
//! - **`escb`** (the default): before sending, ask the free space with `ESC . B` and send at most that many bytes.
//!   It needs nothing but the two data wires, so it works over any cable and any USB adapter.
//! - **`xonxoff`**: the plotter is told (`ESC . I` / `ESC . N`) to send Xoff (DC3) when its free space falls below
//!   a threshold and Xon (DC1) when there is room again; the sender writes a few bytes at a time and stops on
//!   Xoff. The threshold leaves room for the bytes still on their way when the Xoff arrives.
//! - **`hardware`**: the plotter drops CTS when its buffer is nearly full; the sender writes only while CTS is
//!   up. A link with no CTS line to read (a pseudo-terminal, a three-wire cable, adapters such as the CH340
//!   without modem lines) is refused with a pointer to `escb` — there is no safe emulation of a line that is
//!   not there.

/// How the sender keeps the plotter's buffer from overflowing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum Handshake {
    /// `ESC . B` buffer-space queries (any cable).
    #[default]
    Escb,
    /// Xon/Xoff (DC1/DC3) from the plotter.
    Xonxoff,
    /// RTS/CTS lines.
    Hardware,
}

impl Handshake {
    /// Its name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Handshake::Escb => "escb",
            Handshake::Xonxoff => "xonxoff",
            Handshake::Hardware => "hardware",
        }
    }
}

/// Bytes written at a time under Xon/Xoff and hardware handshake, between looks at the plotter's signal.
pub const PIECE: usize = 4;

/// The Xoff threshold asked for (and the model's CTS margin) on a buffer of `buffer` bytes: a quarter of it,
/// at least enough for a piece in flight and the Xoff's own transmission time, at most 80 bytes.
pub fn threshold(buffer: usize) -> usize {
    (buffer / 4).clamp(PIECE + 4, 80)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thresholds() {
        assert_eq!(threshold(60), 15);
        assert_eq!(threshold(20), 8);
        assert_eq!(threshold(1024), 80);
        assert_eq!(Handshake::default().name(), "escb");
    }
}
