//! The start-up note: why the board (re)started, and why the previous run stopped if it crashed.
//!
//! Written as one `[MSG:...]` line just before the firmware's banner (hosts skip lines they do not know; the
//! plotter host's handshake looks only for the banner and the `M115` answer):
//!
//! ```text
//! [MSG:start: reset by watchdog; previous run stopped: panic: src/stepper.rs:200: attempt to add with overflow]
//! plotter-fw 0.1.0 proto 3 rx 256 queue 32 line 96 seq 0
//! ```

use core::fmt;

/// What reset the microcontroller, from its reset-status register.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ResetCause {
    /// Power switched on (or brown-out recovery).
    PowerOn,
    /// The reset pin (the Nucleo's black button, or the debugger).
    Pin,
    /// Supply dipped below the brown-out level.
    Brownout,
    /// The watchdog expired: the main loop stopped running.
    Watchdog,
    /// Software reset (after a panic or fault, or a debugger's reset request).
    Software,
    /// Nothing recorded (an emulator that does not model the register).
    Unknown,
}

impl ResetCause {
    /// Lower-case words for the note.
    pub fn text(self) -> &'static str {
        match self {
            ResetCause::PowerOn => "power-on",
            ResetCause::Pin => "reset pin",
            ResetCause::Brownout => "brown-out",
            ResetCause::Watchdog => "watchdog",
            ResetCause::Software => "software reset",
            ResetCause::Unknown => "unknown cause",
        }
    }
}

/// The note line, with its newline.
pub fn write_note<W: fmt::Write>(w: &mut W, board: &str, cause: ResetCause, fault: Option<&str>) -> fmt::Result {
    write!(w, "[MSG:{board} start: reset by {}", cause.text())?;
    if let Some(f) = fault {
        write!(w, "; previous run stopped: {f}")?;
    }
    w.write_str("]\n")
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::string::String;

    #[test]
    fn the_note_names_the_cause_and_the_fault() {
        let mut s = String::new();
        write_note(&mut s, "nucleo-l476rg", ResetCause::Software, Some("panic: boom")).unwrap();
        assert_eq!(s, "[MSG:nucleo-l476rg start: reset by software reset; previous run stopped: panic: boom]\n");
        let mut s = String::new();
        write_note(&mut s, "qemu", ResetCause::PowerOn, None).unwrap();
        assert_eq!(s, "[MSG:qemu start: reset by power-on]\n");
    }
}
