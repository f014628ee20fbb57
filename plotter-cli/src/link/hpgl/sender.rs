//! A session with an HP-GL plotter: connect (the buffer size with `ESC . L`, the model with `OI`, Xon/Xoff
//! switched on when asked for), send bytes under the chosen [`Handshake`], read errors back (`ESC . E` for the
//! line and the buffer, `OE` for the HP-GL), and stop (`ESC . K`, then `PU;SP0;`).
//!
//! # Flow control
//! - `escb`: the sender keeps a *credit*, the free space the last `ESC . B` reported minus what it sent since
//!   (bytes sent after the query arrive after it, so the count is exact). The next query goes out ahead, once
//!   half the buffer's worth of credit is used, so the line keeps carrying data during the round trip. While the
//!   plotter has less room than a useful chunk (a quarter of its buffer, or the command if shorter) the sender
//!   waits 10, 20, 40, then every 80 ms before asking again, so the queries do not crowd the line. No byte is
//!   ever sent without room for it, whatever the cable.
//! - `xonxoff`: [`PIECE`] bytes at a time; before each, whatever arrived is read and an Xoff stops the sending
//!   until the Xon.
//! - `hardware`: [`PIECE`] bytes at a time while CTS is up.
//!
//! The plotter's answers (a number or a text, then a CR) and the Xon/Xoff bytes share the line: the Xon/Xoff
//! bytes are taken out wherever they arrive, the rest is cut into answers at each CR.
//!
//! # Progress
//! Bytes the plotter has taken out of its buffer have been parsed: each `ESC . B` answer tells how many of the
//! bytes sent are still waiting ([`HpglSession::parsed_bytes`]); an `OE` answer tells that everything sent
//! before it was parsed.

use std::time::Duration;

use anyhow::{Context as _, bail};
use plotter_path::geometry::hpgl_devices::HpglDevice;

use super::HpglLink;
use super::handshake::{Handshake, PIECE, threshold};
use super::messages::{
    ABORT_GRAPHICS, BUFFER_SIZE, BUFFER_SPACE, CR, EXTENDED_ERROR, XOFF, XON, error_text, parse_number, xon_xoff_setup,
};

/// How long an answer to a device-control query may take.
const ANSWER_TIMEOUT: Duration = Duration::from_secs(2);
/// How long the plotter may hold the sender (Xoff, CTS down, no room) before the plot stops: longer than any
/// single move of a sheet-sized plotter at its slowest speed.
const STALL_LIMIT: Duration = Duration::from_secs(300);
/// Longest answer kept, bytes (a plotter that never sends a CR must not grow memory).
const MAX_ANSWER: usize = 256;

/// What the session counted.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SendStats {
    /// HP-GL bytes sent (into the plotter's buffer).
    pub bytes: u64,
    /// `ESC . B` queries.
    pub space_queries: u64,
    /// Xoffs received.
    pub xoffs: u64,
    /// Times the sender waited for room (no credit, Xoff or CTS down).
    pub waits: u64,
}

/// An open session with an HP-GL plotter.
pub struct HpglSession<L: HpglLink> {
    /// The byte pipe.
    pub link: L,
    /// Where it is connected.
    pub name: String,
    /// The device the program was written for.
    pub device: &'static HpglDevice,
    /// The handshake in use.
    pub handshake: Handshake,
    /// What the plotter answered to `OI`.
    pub identity: String,
    /// Its input buffer, bytes (`ESC . L`).
    pub buffer_bytes: usize,
    /// What was counted.
    pub stats: SendStats,
    /// Things the user should know (an identity that is not the device's).
    pub warnings: Vec<String>,
    rx: Vec<u8>,
    xoff: bool,
    credit: usize,
    parsed: u64,
    /// An `ESC . B` sent and not yet answered: the HP-GL byte count when it was sent.
    space_asked_at: Option<u64>,
}

fn lost(name: &str, e: std::io::Error) -> anyhow::Error {
    crate::Error::lost(name, &e, "was the plotter switched off or the cable pulled?").into()
}

impl<L: HpglLink> HpglSession<L> {
    /// Connect: `ESC . L` (three tries) for the buffer size, `OI` for the model, the handshake set up (Xon/Xoff
    /// switched on; CTS checked to be readable), errors left by an earlier job cleared (`ESC . E`, `OE`).
    pub fn connect(link: L, name: &str, device: &'static HpglDevice, handshake: Handshake) -> anyhow::Result<Self> {
        let mut s = HpglSession {
            link,
            name: name.to_string(),
            device,
            handshake,
            identity: String::new(),
            buffer_bytes: 0,
            stats: SendStats::default(),
            warnings: Vec::new(),
            rx: Vec::new(),
            xoff: false,
            credit: 0,
            parsed: 0,
            space_asked_at: None,
        };
        // Whatever an earlier session left on the line.
        while !s.link.read(Duration::from_millis(100)).map_err(|e| lost(name, e))?.is_empty() {}
        let mut size = None;
        for _ in 0..3 {
            if let Ok(n) = s.query(BUFFER_SIZE) {
                size = Some(n);
                break;
            }
        }
        let Some(size) = size.filter(|&n| n > 0) else {
            bail!(
                "{name} does not answer ESC . L like an HP-GL plotter (check that it is switched on and set to the \
                 same baud rate, 8 data bits, no parity, and the cable)"
            );
        };
        s.buffer_bytes = usize::try_from(size).unwrap_or(usize::MAX);
        match handshake {
            Handshake::Xonxoff => s.write_raw(&xon_xoff_setup(threshold(s.buffer_bytes)))?,
            Handshake::Hardware => {
                if s.link.clear_to_send().map_err(|e| lost(name, e))?.is_none() {
                    bail!(
                        "--handshake hardware: {name} has no CTS line that can be read (a pseudo-terminal, a \
                         three-wire cable or a USB adapter without modem lines); use --handshake escb, which needs \
                         no handshake lines"
                    );
                }
            }
            Handshake::Escb => {}
        }
        let _ = s.query(EXTENDED_ERROR)?;
        s.send(b"OI;")?;
        s.settle_space(true)?;
        s.identity = s.answer(ANSWER_TIMEOUT * 5).context("no answer to OI (output identification)")?;
        s.send(b"OE;")?;
        s.settle_space(true)?;
        let _ = s.answer(ANSWER_TIMEOUT * 5).context("no answer to OE (output error)")?;
        s.parsed = s.stats.bytes;
        if !s.identity.eq_ignore_ascii_case(device.identity) {
            s.warnings.push(format!(
                "{name} says it is a {:?}, the program is written for the {} (--hpgl-device)",
                s.identity, device.name
            ));
        }
        Ok(s)
    }

    /// Write bytes that do not enter the buffer (device-control instructions).
    fn write_raw(&mut self, bytes: &[u8]) -> anyhow::Result<()> {
        self.link.write(bytes).map_err(|e| lost(&self.name, e))
    }

    /// Read what arrived within `timeout`: Xon/Xoff are noted, the rest kept for [`Self::answer`].
    fn pump(&mut self, timeout: Duration) -> anyhow::Result<bool> {
        let got = self.link.read(timeout).map_err(|e| lost(&self.name, e))?;
        for &b in &got {
            match b {
                XOFF => {
                    self.xoff = true;
                    self.stats.xoffs += 1;
                }
                XON => self.xoff = false,
                _ if self.rx.len() < MAX_ANSWER => self.rx.push(b),
                _ => {}
            }
        }
        Ok(!got.is_empty())
    }

    /// An answer already received (up to its CR, trimmed), if there is one.
    fn take_answer(&mut self) -> Option<String> {
        while let Some(i) = self.rx.iter().position(|&b| b == CR || b == b'\n') {
            let line: Vec<u8> = self.rx.drain(..=i).collect();
            let text = String::from_utf8_lossy(&line[..i]).trim().to_string();
            if !text.is_empty() {
                return Some(text);
            }
        }
        None
    }

    /// The next answer, waiting at most `timeout`.
    fn answer(&mut self, timeout: Duration) -> anyhow::Result<String> {
        let deadline = self.link.now() + timeout;
        loop {
            if let Some(a) = self.take_answer() {
                return Ok(a);
            }
            let left = deadline.saturating_sub(self.link.now());
            if left.is_zero() {
                bail!("{}: no answer within {:.1} s", self.name, timeout.as_secs_f64());
            }
            self.pump(left.min(Duration::from_millis(50)))?;
        }
    }

    /// Take the answer to an `ESC . B` sent ahead (waiting for it when `wait`): the credit becomes the free space
    /// it reports minus the bytes sent since it was asked (they arrived after it), and the bytes then waiting in
    /// the buffer tell how far the plotter has parsed.
    fn settle_space(&mut self, wait: bool) -> anyhow::Result<()> {
        let Some(at) = self.space_asked_at else { return Ok(()) };
        let a = if wait {
            self.answer(ANSWER_TIMEOUT)?
        } else {
            self.pump(Duration::ZERO)?;
            match self.take_answer() {
                Some(a) => a,
                None => return Ok(()),
            }
        };
        self.space_asked_at = None;
        let free = parse_number(&a).with_context(|| format!("{}: ESC . B answered {a:?}, not a number", self.name))?;
        let free = usize::try_from(free).unwrap_or(0).min(self.buffer_bytes);
        let since = usize::try_from(self.stats.bytes - at).unwrap_or(usize::MAX);
        self.credit = free.saturating_sub(since);
        self.parsed = self.parsed.max(at.saturating_sub((self.buffer_bytes - free) as u64));
        Ok(())
    }

    /// Ask `ESC . B` without waiting for the answer.
    fn ask_space(&mut self) -> anyhow::Result<()> {
        self.write_raw(BUFFER_SPACE)?;
        self.stats.space_queries += 1;
        self.space_asked_at = Some(self.stats.bytes);
        Ok(())
    }

    /// Send a device-control query and read its number.
    pub fn query(&mut self, esc: &[u8]) -> anyhow::Result<u32> {
        self.settle_space(true)?;
        self.write_raw(esc)?;
        let a = self.answer(ANSWER_TIMEOUT)?;
        parse_number(&a).with_context(|| {
            format!("{}: {:?} answered {a:?}, not a number", self.name, String::from_utf8_lossy(&esc[1..]))
        })
    }

    /// HP-GL bytes sent so far.
    pub fn sent_bytes(&self) -> u64 {
        self.stats.bytes
    }

    /// HP-GL bytes the plotter has certainly taken out of its buffer (parsed).
    pub fn parsed_bytes(&self) -> u64 {
        self.parsed
    }

    /// Send HP-GL `bytes` under the handshake.
    pub fn send(&mut self, mut bytes: &[u8]) -> anyhow::Result<()> {
        let mut stalled_since = None;
        let mut waits_before = self.stats.waits;
        while !bytes.is_empty() {
            let room = match self.handshake {
                Handshake::Escb => self.escb_room(bytes.len())?,
                Handshake::Xonxoff => {
                    self.pump(Duration::ZERO)?;
                    if self.xoff { 0 } else { PIECE }
                }
                Handshake::Hardware => match self.link.clear_to_send().map_err(|e| lost(&self.name, e))? {
                    Some(true) => PIECE,
                    Some(false) => 0,
                    None => bail!("{}: the CTS line can no longer be read", self.name),
                },
            };
            if room == 0 {
                let since = *stalled_since.get_or_insert(self.link.now());
                if self.link.now().saturating_sub(since) > STALL_LIMIT {
                    bail!(
                        "{}: the plotter took no byte for {} s ({}); is it paused (its front-panel pause), out of \
                         paper or its cable not wired for this handshake?",
                        self.name,
                        STALL_LIMIT.as_secs(),
                        match self.handshake {
                            Handshake::Escb => "ESC . B kept answering no room",
                            Handshake::Xonxoff => "Xoff, no Xon",
                            Handshake::Hardware => "CTS stayed down",
                        }
                    );
                }
                self.stats.waits += 1;
                // Under escb each look costs a query on the line: look less often the longer the plotter is full.
                let streak = u32::try_from(self.stats.waits - waits_before).unwrap_or(u32::MAX).min(4);
                let pause = if self.handshake == Handshake::Escb { 5 << streak } else { 5 };
                self.pump(Duration::from_millis(pause))?;
                continue;
            }
            stalled_since = None;
            waits_before = self.stats.waits;
            let n = room.min(bytes.len());
            self.link.write(&bytes[..n]).map_err(|e| lost(&self.name, e))?;
            self.stats.bytes += n as u64;
            if self.handshake == Handshake::Escb {
                self.credit -= n;
            }
            bytes = &bytes[n..];
        }
        Ok(())
    }

    /// Under `escb`: how many bytes may go now (0: wait). The next `ESC . B` is asked ahead, once half the
    /// buffer's worth of credit is used, so that its answer is back before the credit runs out and the line does
    /// not stand still for the round trip; only when the credit is too small for a useful chunk does the sender
    /// wait for the answer.
    fn escb_room(&mut self, want: usize) -> anyhow::Result<usize> {
        let useful = want.min(self.buffer_bytes / 4).max(1);
        self.settle_space(false)?;
        if self.credit < useful {
            if self.space_asked_at.is_none() {
                self.ask_space()?;
            }
            self.settle_space(true)?;
            if self.credit < useful {
                return Ok(0);
            }
        }
        if self.space_asked_at.is_none() && self.credit < self.buffer_bytes / 2 {
            self.ask_space()?;
        }
        Ok(self.credit)
    }

    /// Check for errors: `ESC . E` (the line and the buffer: at once), then `OE` (which waits its turn in the
    /// buffer, so everything sent before has been parsed when it answers). `wait` bounds the wait for `OE`.
    pub fn check(&mut self, wait: Duration) -> anyhow::Result<()> {
        self.settle_space(true)?;
        let line = self.query(EXTENDED_ERROR)?;
        if line != 0 {
            bail!("{} reports {}", self.name, error_text(line));
        }
        self.send(b"OE;")?;
        let sent = self.stats.bytes;
        // An `ESC . B` asked ahead while sending `OE` is answered first (on arrival; `OE` when parsed).
        self.settle_space(true)?;
        let a = match self.answer(wait) {
            Ok(a) => a,
            Err(e) => {
                // An OE lost to an overflow never answers: ask the line error once more.
                let line = self.query(EXTENDED_ERROR).unwrap_or(0);
                if line != 0 {
                    bail!("{} reports {}", self.name, error_text(line));
                }
                return Err(e.context("no answer to OE"));
            }
        };
        let code = parse_number(&a).with_context(|| format!("{}: OE answered {a:?}, not a number", self.name))?;
        self.parsed = sent;
        if code != 0 {
            bail!("{} reports HP-GL {}", self.name, error_text(code));
        }
        Ok(())
    }

    /// A console line: send `text` as HP-GL under the handshake and return the plotter's answers (an `OI;` is
    /// answered with the model, an `OE;` with the error number), collected until it has been quiet for `quiet`
    /// (at most 16 answers).
    pub fn exchange(&mut self, text: &[u8], quiet: Duration) -> anyhow::Result<Vec<String>> {
        self.settle_space(true)?;
        self.send(text)?;
        // An `ESC . B` asked ahead while sending is answered on arrival, before any answer of `text`.
        self.settle_space(true)?;
        let mut answers = Vec::new();
        while answers.len() < 16 {
            match self.take_answer() {
                Some(a) => answers.push(a),
                None if self.pump(quiet)? => {}
                None => break,
            }
        }
        Ok(answers)
    }

    /// Stop now: `ESC . K` drops what the buffer holds and the instruction under way, then the pen is lifted and
    /// put away (`PU;SP0;`). Returns what was done, for the user.
    pub fn cancel(&mut self) -> anyhow::Result<String> {
        self.write_raw(ABORT_GRAPHICS)?;
        // An answer still due is of no use now.
        self.space_asked_at = None;
        self.credit = 0;
        self.xoff = false;
        self.send(b"PU;SP0;")?;
        Ok("stopped with ESC . K; the pen is up and put away (PU;SP0;)".into())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::hpgl::model::{HpglModel, ModelConfig};
    use crate::link::hpgl::model_link::ModelLink;
    use plotter_path::geometry::hpgl_devices::device;

    fn link(buffer: usize, xon_xoff: bool) -> ModelLink {
        let d = device("7475a").unwrap();
        ModelLink::new(HpglModel::new(ModelConfig { device: d, buffer, xon_xoff }), 9600)
    }

    /// 60 pen-up moves of 12 bytes each: far more than the 60-byte buffer holds.
    fn moves() -> Vec<u8> {
        (0..60).flat_map(|i| format!("PU{},{};", 1000 + 50 * i, 2000 + 10 * i).into_bytes()).collect()
    }

    #[test]
    fn each_handshake_fills_a_small_buffer_without_losing_a_byte() {
        for h in [Handshake::Escb, Handshake::Xonxoff, Handshake::Hardware] {
            let mut s = HpglSession::connect(link(60, true), "model", device("7475a").unwrap(), h).unwrap();
            assert_eq!((s.identity.as_str(), s.buffer_bytes), ("7475A", 60));
            let m = moves();
            s.send(&m).unwrap();
            s.check(Duration::from_secs(60)).unwrap();
            let model = s.link.model();
            assert_eq!(model.stats().overflow, 0, "{h:?}");
            assert_eq!(model.position(), (1000 + 50 * 59, 2000 + 590), "{h:?}");
            assert!(model.stats().peak > 40, "{h:?}: the buffer was used ({})", model.stats().peak);
            assert_eq!(s.parsed_bytes(), s.sent_bytes());
        }
    }

    #[test]
    fn xon_xoff_to_a_plotter_that_never_sends_xoff_overflows_and_is_caught() {
        let mut s =
            HpglSession::connect(link(60, false), "model", device("7475a").unwrap(), Handshake::Xonxoff).unwrap();
        s.send(&moves()).unwrap();
        let e = s.check(Duration::from_secs(60)).unwrap_err().to_string();
        assert!(e.contains("error 16 (input buffer overflow"), "{e}");
        assert!(s.link.model().stats().overflow > 0);
    }

    #[test]
    fn a_console_line_gets_the_plotters_answers() {
        let mut s = HpglSession::connect(link(60, true), "model", device("7475a").unwrap(), Handshake::Escb).unwrap();
        assert_eq!(s.exchange(b"OI;", Duration::from_millis(500)).unwrap(), vec!["7475A".to_string()]);
        // A pen-up move answers nothing; the error number after it is 0 (none).
        assert!(s.exchange(b"PU100,200;", Duration::from_millis(200)).unwrap().is_empty());
        assert_eq!(s.exchange(b"OE;", Duration::from_millis(500)).unwrap(), vec!["0".to_string()]);
        assert_eq!(s.link.model().position(), (100, 200));
    }

    #[test]
    fn a_cable_without_lines_refuses_hardware_handshake_and_works_with_escb() {
        let mut l = link(60, true);
        l.lines = false;
        let e = HpglSession::connect(l, "model", device("7475a").unwrap(), Handshake::Hardware).err().unwrap();
        assert!(e.to_string().contains("use --handshake escb"), "{e}");
        let mut l = link(60, true);
        l.lines = false;
        let mut s = HpglSession::connect(l, "model", device("7475a").unwrap(), Handshake::Escb).unwrap();
        s.send(&moves()).unwrap();
        s.check(Duration::from_secs(60)).unwrap();
        assert_eq!(s.link.model().stats().overflow, 0);
    }
}
