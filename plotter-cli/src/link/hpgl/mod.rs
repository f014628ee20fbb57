//! Vintage HP-GL pen plotters (HP 7475A, 7550A, Roland DXY and kin) as a firmware dialect: the program of
//! [`plotter_path::output::hpgl_out`] streamed over RS-232 without overrunning the plotter's small input buffer.
//!
//! - [`messages`]: the device-control escapes (`ESC . B`, `ESC . E`, …) and the meaning of every error number;
//! - [`timing`]: how long a pen move takes at a `VS` speed and the device's acceleration;
//! - [`commands`]: a program split into commands, with the plotter's state before each (for progress, pauses and
//!   resuming at command granularity);
//! - [`handshake`]: the three ways of keeping the buffer from overflowing, chosen by `--handshake`;
//! - [`sender`]: the session with a plotter — identify (`OI`), send bytes under the handshake, read errors back,
//!   stop (`ESC . K` and the pen-up, whatever the plotter answers); every wait bounded by a deadline from the work
//!   queued ([`timing::patience`]) and cut short by a stop;
//! - the plot job over a session (progress, pause, cancel, journal and resume) is [`crate::job::hpgl`], above the link;
//! - [`port`]: a serial port (or a pty) as an [`HpglLink`];
//! - [`model`] and [`model_link`]: a plotter of our own for tests and `plotter sim --pty --hpgl`, which can also
//!   lie ([`model::Lie`]: withhold room, babble, garble its answers).
//!
//! HP-GL replies are not lines of the other dialects' kind (they end with a CR, and Xon/Xoff arrive as single
//! bytes between them), so this dialect has its own byte-level link trait, [`HpglLink`], instead of
//! [`crate::link::Transport`].

pub mod commands;
pub mod handshake;
pub mod messages;
pub mod model;
pub mod model_link;
pub mod port;
pub mod sender;
pub mod timing;

use std::io;
use std::time::Duration;

/// A byte pipe to an HP-GL plotter.
pub trait HpglLink {
    /// Write `bytes`; returns once they have left at the line's pace (a serial port drains its output, the
    /// model's link advances its clock by their transmission time).
    fn write(&mut self, bytes: &[u8]) -> io::Result<()>;
    /// The bytes received, waiting at most `timeout` for the first; empty on timeout.
    fn read(&mut self, timeout: Duration) -> io::Result<Vec<u8>>;
    /// The link's clock: wall time on a port, virtual time for the in-process model.
    fn now(&self) -> Duration;
    /// The plotter's CTS line (hardware handshake): `None` when the link has none that can be read (a
    /// pseudo-terminal, a three-wire cable, an adapter without modem lines).
    fn clear_to_send(&mut self) -> io::Result<Option<bool>>;
}

/// A borrowed link is a link (a test, or a caller that keeps the port across sessions).
impl<L: HpglLink + ?Sized> HpglLink for &mut L {
    fn write(&mut self, bytes: &[u8]) -> io::Result<()> {
        (**self).write(bytes)
    }
    fn read(&mut self, timeout: Duration) -> io::Result<Vec<u8>> {
        (**self).read(timeout)
    }
    fn now(&self) -> Duration {
        (**self).now()
    }
    fn clear_to_send(&mut self) -> io::Result<Option<bool>> {
        (**self).clear_to_send()
    }
}
