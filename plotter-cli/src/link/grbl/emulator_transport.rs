//! The GRBL emulator in-process, on virtual time, as a [`Transport`]: bytes sent cross a simulated serial line
//! at the baud rate (when set) into the emulator's 128-byte buffer; receiving runs the emulator forward until a
//! reply line is complete. Counts queue underruns (motion stopped while lines were still to come) like
//! [`crate::link::sim::SimTransport`], and can make the port vanish after a number of bytes (tests).

use std::io;
use std::time::Duration;

use super::emulator::GrblEmulator;
use crate::link::{LineSplitter, Transport};

/// The emulated GRBL controller behind the [`Transport`] trait.
pub struct EmulatorTransport {
    emu: GrblEmulator,
    lines: LineSplitter,
    streaming: bool,
    was_moving: bool,
    underruns: u64,
    /// The port disappears once this many more bytes have been sent.
    vanish_after: Option<u64>,
    sent: u64,
}

impl EmulatorTransport {
    /// Wrap `emu`.
    pub fn new(emu: GrblEmulator) -> Self {
        EmulatorTransport {
            emu,
            lines: LineSplitter::default(),
            streaming: false,
            was_moving: false,
            underruns: 0,
            vanish_after: None,
            sent: 0,
        }
    }

    /// Make the port fail (as an unplugged USB adapter does) once `bytes` bytes have been sent.
    pub fn vanish_after(mut self, bytes: u64) -> Self {
        self.vanish_after = Some(bytes);
        self
    }

    /// The emulator.
    pub fn emulator(&self) -> &GrblEmulator {
        &self.emu
    }

    /// The emulator, mutable (fault injection).
    pub fn emulator_mut(&mut self) -> &mut GrblEmulator {
        &mut self.emu
    }

    fn gone(&self) -> bool {
        self.vanish_after.is_some_and(|n| self.sent >= n)
    }

    fn collect(&mut self) {
        for l in self.emu.take_replies() {
            self.lines.push(l.as_bytes());
            self.lines.push(b"\n");
        }
    }

    fn watch_underrun(&mut self) {
        let moving = !self.emu.backend().machine().stepper().is_idle();
        if self.streaming && self.was_moving && !moving {
            self.underruns += 1;
        }
        self.was_moving = moving;
    }
}

fn vanished() -> io::Error {
    io::Error::new(io::ErrorKind::BrokenPipe, "the device disappeared")
}

impl Transport for EmulatorTransport {
    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        if self.gone() {
            return Err(vanished());
        }
        self.sent += u64::try_from(bytes.len()).unwrap_or(u64::MAX);
        self.emu.feed(bytes);
        Ok(())
    }

    fn recv_line(&mut self, timeout: Duration) -> io::Result<Option<String>> {
        if self.gone() {
            return Err(vanished());
        }
        self.collect();
        if let Some(l) = self.lines.pop() {
            return Ok(Some(l));
        }
        let end = self.emu.now().saturating_add(u64::try_from(timeout.as_micros()).unwrap_or(u64::MAX));
        while self.emu.now() < end {
            // Slices of 100 µs: the emulator runs byte by byte inside, and the host reacts within a slice.
            let step = (end - self.emu.now()).min(100);
            self.emu.run_for(step);
            self.watch_underrun();
            self.collect();
            if let Some(l) = self.lines.pop() {
                return Ok(Some(l));
            }
        }
        Ok(None)
    }

    fn now(&self) -> Duration {
        Duration::from_micros(self.emu.now())
    }

    fn set_streaming(&mut self, active: bool) {
        self.streaming = active;
    }

    fn underruns(&self) -> Option<u64> {
        Some(self.underruns)
    }
}
