//! The host side of the link to the firmware: byte transports (a serial port, or the simulator in-process), the
//! session (handshake, homing, status), block streaming with flow control and resends, and the resume journal;
//! GRBL ([`grbl`]) and the EiBotBoard ([`ebb`]) as further firmware dialects, and the machine interface the plot
//! job drives ([`machine`]); what the front ends share to reach and drive a plotter by hand: connecting to a port
//! of any dialect ([`connect`]), jogging ([`jog`]), the manual commands ([`manual`]) and the console's real-time
//! keys ([`console`]).

pub mod babble;
pub mod connect;
pub mod console;
pub mod ebb;
pub mod faults;
pub mod grbl;
pub mod home_axes;
pub mod hpgl;
pub mod jog;
pub mod journal;
pub mod machine;
pub mod manual;
pub mod paced;
pub mod print;
pub mod refused;
pub mod serial;
pub mod session;
pub mod sim;
pub mod standing;
pub mod stream;
pub mod wait;

use std::io;
use std::time::Duration;

/// A byte pipe to the firmware, with line-oriented reading of its replies.
pub trait Transport {
    /// Write all of `bytes` towards the firmware.
    fn send(&mut self, bytes: &[u8]) -> io::Result<()>;

    /// The next complete reply line (without its line end), waiting at most `timeout` of this transport's clock.
    /// `Ok(None)` on timeout.
    fn recv_line(&mut self, timeout: Duration) -> io::Result<Option<String>>;

    /// The transport's clock: wall time for a serial port, virtual time for the in-process simulator.
    fn now(&self) -> Duration;

    /// Told by the streamer whether blocks are still waiting to be sent (used to count queue underruns).
    fn set_streaming(&mut self, _active: bool) {}

    /// Queue underruns seen (motion stopped while blocks were still to come), when the transport can observe them.
    fn underruns(&self) -> Option<u64> {
        None
    }
}

impl<T: Transport + ?Sized> Transport for Box<T> {
    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        (**self).send(bytes)
    }
    fn recv_line(&mut self, timeout: Duration) -> io::Result<Option<String>> {
        (**self).recv_line(timeout)
    }
    fn now(&self) -> Duration {
        (**self).now()
    }
    fn set_streaming(&mut self, active: bool) {
        (**self).set_streaming(active);
    }
    fn underruns(&self) -> Option<u64> {
        (**self).underruns()
    }
}

/// Splits a byte stream into lines (`\n`-terminated, `\r` dropped, invalid UTF-8 replaced).
#[derive(Debug, Default)]
pub struct LineSplitter {
    buf: Vec<u8>,
    lines: std::collections::VecDeque<String>,
}

impl LineSplitter {
    /// Add received bytes.
    pub fn push(&mut self, bytes: &[u8]) {
        for &b in bytes {
            match b {
                b'\n' => {
                    let line = String::from_utf8_lossy(&self.buf).into_owned();
                    self.lines.push_back(line);
                    self.buf.clear();
                }
                b'\r' => {}
                _ => {
                    // A peer that never sends a line end must not grow the buffer without bound.
                    if self.buf.len() < 4096 {
                        self.buf.push(b);
                    }
                }
            }
        }
    }

    /// The next complete line.
    pub fn pop(&mut self) -> Option<String> {
        self.lines.pop_front()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splitter_handles_partial_lines_and_crlf() {
        let mut s = LineSplitter::default();
        s.push(b"ok\r\nerr");
        assert_eq!(s.pop().as_deref(), Some("ok"));
        assert_eq!(s.pop(), None);
        s.push(b"or:1 x\n\n");
        assert_eq!(s.pop().as_deref(), Some("error:1 x"));
        assert_eq!(s.pop().as_deref(), Some(""));
    }
}
