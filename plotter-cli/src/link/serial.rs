//! A real serial device (or a pseudo-terminal from `plotter sim --pty`) as a [`Transport`].

use std::io::{self, Read as _, Write as _};
use std::time::{Duration, Instant};

use anyhow::Context as _;

use super::{LineSplitter, Transport};

/// A serial port, read with short timeouts and split into reply lines.
pub struct SerialTransport {
    port: Box<dyn serialport::SerialPort>,
    lines: LineSplitter,
    start: Instant,
}

impl SerialTransport {
    /// Open `path` at `baud` (8N1, no flow control).
    pub fn open(path: &str, baud: u32) -> anyhow::Result<Self> {
        if !std::path::Path::new(path).exists() {
            anyhow::bail!(
                "serial port {path} does not exist (is the plotter connected, or `plotter sim --pty` running?)"
            );
        }
        let port = serialport::new(path, baud)
            .timeout(Duration::from_millis(20))
            .open()
            .with_context(|| format!("cannot open serial port {path} at {baud} baud"))?;
        Ok(SerialTransport { port, lines: LineSplitter::default(), start: Instant::now() })
    }
}

impl Transport for SerialTransport {
    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.port.write_all(bytes)?;
        self.port.flush()
    }

    fn recv_line(&mut self, timeout: Duration) -> io::Result<Option<String>> {
        let deadline = Instant::now() + timeout;
        let mut buf = [0u8; 512];
        loop {
            if let Some(l) = self.lines.pop() {
                return Ok(Some(l));
            }
            match self.port.read(&mut buf) {
                Ok(0) => {}
                Ok(n) => self.lines.push(&buf[..n]),
                Err(e) if e.kind() == io::ErrorKind::TimedOut || e.kind() == io::ErrorKind::WouldBlock => {}
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Err(e),
            }
            if Instant::now() >= deadline {
                return Ok(self.lines.pop());
            }
        }
    }

    fn now(&self) -> Duration {
        self.start.elapsed()
    }
}
