//! A serial port (or the pseudo-terminal of `plotter sim --pty --hpgl`) as an [`HpglLink`].
//!
//! Writes are paced to the baud rate (10 bits a byte): a UART drains its output at that pace anyway (the write
//! waits for the driver to send it), and a pseudo-terminal, which has no line speed, would otherwise take every
//! byte at once — the pacing keeps what is "on the wire" when an Xoff or a closed CTS arrives to a few bytes on
//! both. CTS is read with the modem-status ioctl; a pseudo-terminal or an adapter without modem lines cannot
//! answer it, which the hardware handshake refuses (see [`super::handshake`]).

use std::io::{self, Read as _, Write as _};
use std::time::{Duration, Instant};

use anyhow::Context as _;

use super::HpglLink;

/// A serial port speaking to an HP-GL plotter (8N1, no flow control in the driver: the sender does it).
pub struct HpglPort {
    port: Box<dyn serialport::SerialPort>,
    start: Instant,
    byte_time: Duration,
    /// When the line has sent everything written so far.
    line_free: Instant,
}

impl HpglPort {
    /// Open `path` at `baud`.
    pub fn open(path: &str, baud: u32) -> anyhow::Result<HpglPort> {
        if !std::path::Path::new(path).exists() {
            anyhow::bail!(
                "serial port {path} does not exist (is the plotter connected, or `plotter sim --pty --hpgl` running?)"
            );
        }
        let port = serialport::new(path, baud)
            .timeout(Duration::from_millis(10))
            .flow_control(serialport::FlowControl::None)
            .open()
            .with_context(|| format!("cannot open serial port {path} at {baud} baud"))?;
        let now = Instant::now();
        Ok(HpglPort {
            port,
            start: now,
            byte_time: Duration::from_secs_f64(10.0 / f64::from(baud.max(1))),
            line_free: now,
        })
    }
}

impl HpglLink for HpglPort {
    fn write(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.port.write_all(bytes)?;
        self.port.flush()?;
        let n = u32::try_from(bytes.len()).unwrap_or(u32::MAX);
        self.line_free = self.line_free.max(Instant::now()) + self.byte_time * n;
        let wait = self.line_free.saturating_duration_since(Instant::now());
        if !wait.is_zero() {
            std::thread::sleep(wait);
        }
        Ok(())
    }

    fn read(&mut self, timeout: Duration) -> io::Result<Vec<u8>> {
        let deadline = Instant::now() + timeout;
        let mut buf = [0u8; 256];
        loop {
            match self.port.read(&mut buf) {
                Ok(n) if n > 0 => return Ok(buf[..n].to_vec()),
                Ok(_) => {}
                Err(e) if matches!(e.kind(), io::ErrorKind::TimedOut | io::ErrorKind::WouldBlock) => {}
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Err(e),
            }
            if Instant::now() >= deadline {
                return Ok(Vec::new());
            }
        }
    }

    fn now(&self) -> Duration {
        self.start.elapsed()
    }

    fn clear_to_send(&mut self) -> io::Result<Option<bool>> {
        Ok(self.port.read_clear_to_send().ok())
    }
}
