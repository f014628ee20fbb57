//! The EBB emulator in-process as a [`Transport`] on its own virtual clock: sending feeds the board's USB input
//! (USB-CDC has no baud rate: bytes arrive at once), receiving runs the board interval by interval until a reply
//! line is complete or the timeout has passed. Counts queue underruns (the board idle while the plot still had
//! commands to send), which a fast-enough host never causes.

use std::io;
use std::time::Duration;

use super::emulator::EbbEmulator;
use super::kinematics::INTERVAL_US;
use crate::link::{LineSplitter, Transport};

/// The emulated board behind the [`Transport`] trait.
pub struct EbbTransport {
    emu: EbbEmulator,
    lines: LineSplitter,
    streaming: bool,
    was_busy: bool,
    underruns: u64,
}

impl EbbTransport {
    /// Wrap `emu`.
    pub fn new(emu: EbbEmulator) -> Self {
        EbbTransport { emu, lines: LineSplitter::default(), streaming: false, was_busy: false, underruns: 0 }
    }

    /// The board.
    pub fn emulator(&self) -> &EbbEmulator {
        &self.emu
    }

    /// The board, mutable.
    pub fn emulator_mut(&mut self) -> &mut EbbEmulator {
        &mut self.emu
    }
}

impl Transport for EbbTransport {
    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.emu.feed(bytes);
        Ok(())
    }

    fn recv_line(&mut self, timeout: Duration) -> io::Result<Option<String>> {
        self.lines.push(&self.emu.take_output());
        if let Some(l) = self.lines.pop() {
            return Ok(Some(l));
        }
        let intervals = u64::try_from(timeout.as_micros()).unwrap_or(u64::MAX) / u64::from(INTERVAL_US);
        for _ in 0..intervals.max(1) {
            self.emu.run_for(1);
            let busy = !self.emu.is_idle();
            if self.streaming && self.was_busy && !busy {
                self.underruns += 1;
            }
            self.was_busy = busy;
            self.lines.push(&self.emu.take_output());
            if let Some(l) = self.lines.pop() {
                return Ok(Some(l));
            }
        }
        Ok(None)
    }

    fn now(&self) -> Duration {
        Duration::from_micros(self.emu.clock() * u64::from(INTERVAL_US))
    }

    fn set_streaming(&mut self, active: bool) {
        self.streaming = active;
    }

    fn underruns(&self) -> Option<u64> {
        Some(self.underruns)
    }
}
