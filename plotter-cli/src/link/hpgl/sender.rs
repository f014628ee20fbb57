//! A session with an HP-GL plotter: connect (the buffer size with `ESC . L`, the model with `OI`, Xon/Xoff
//! switched on when asked for), send bytes under the chosen [`Handshake`], read errors back (`ESC . E` for the
//! line and the buffer, `OE` for the HP-GL), and stop (`ESC . K`, then `PU;SP0;` written raw).
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
//! # Waits
//! Every wait on the plotter is bounded by an overall deadline (a [`Wait`]), not only by a quiet gap, so a device
//! that babbles cannot hold the session: the leftovers drained at connect ([`CONNECT_DRAIN`]), an answer
//! ([`ANSWER_TIMEOUT`], or the work queued ahead of an `OE`), a console exchange, and room in the buffer. The
//! limit of a wait for the plotter's progress follows from the work it holds ([`HpglSession::set_work_ahead`],
//! [`patience`]) and is told to the user when the wait takes long. Between reads each wait asks a [`Guard`]
//! whether to give up: by default the process's stop flag ([`crate::stop`]); the plot job passes its own, which
//! also turns a pause request into a stop where the plotter cannot pause (see [`crate::job::hpgl`]). A stop
//! ends the wait with [`Stopped`], naming the signal. The stop itself ([`HpglSession::cancel`]) is not guarded:
//! it runs to its end within its own deadlines.
//!
//! # Progress
//! Bytes the plotter has taken out of its buffer have been parsed: each `ESC . B` answer tells how many of the
//! bytes sent are still waiting ([`HpglSession::parsed_bytes`]); an `OE` answer tells that everything sent
//! before it was parsed.

use std::time::Duration;

use anyhow::{Context as _, bail};
use plotter_path::geometry::hpgl_devices::HpglDevice;

use super::HpglLink;
use super::commands::Commands;
use super::handshake::{Handshake, PIECE, threshold};
use super::messages::{
    ABORT_GRAPHICS, BUFFER_SIZE, BUFFER_SPACE, CR, EXTENDED_ERROR, XOFF, XON, error_text, parse_number, xon_xoff_setup,
};
use super::timing::patience;
use crate::link::wait::{Wait, WaitError};
use crate::stop::{Stop, StopCause, Stopped};

/// How long an answer to a device-control query may take.
pub const ANSWER_TIMEOUT: Duration = Duration::from_secs(2);
/// How long connect reads what an earlier session (or a device that is not a plotter) left on the line before
/// it asks anything: a device that keeps talking past this is not an idle HP-GL plotter.
pub const CONNECT_DRAIN: Duration = Duration::from_secs(2);
/// How long the stop waits for the plotter to confirm the pen-up (the `OE` written after `PU;`).
const STOP_CONFIRM: Duration = Duration::from_secs(3);
/// Longest answer kept, bytes (a plotter that never sends a CR must not grow memory).
const MAX_ANSWER: usize = 256;
/// Most bytes of a babbling device quoted in a message.
const HEARD_QUOTE: usize = 48;

/// What a guarded wait waits for, as told to its [`Guard`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Waiting {
    /// Room in the plotter's buffer, which it has withheld for `stalled` so far.
    Room {
        /// How long the plotter has taken no byte.
        stalled: Duration,
    },
    /// An answer from the plotter (an `OE` that waits its turn in the buffer included).
    Answer,
}

/// Asked between the reads of a wait: `Some(cause)` ends the wait with [`Stopped`].
pub type Guard<'a> = dyn FnMut(Waiting) -> Option<StopCause> + 'a;

/// The guard of waits outside a plot job: the process's stop flag ([`Stop::stop_cause`]).
pub fn process_guard(_: Waiting) -> Option<StopCause> {
    Stop::process().stop_cause()
}

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
    /// The estimated plotter time of what its buffer holds (see [`HpglSession::set_work_ahead`]).
    work_ahead: Duration,
}

fn lost(name: &str, e: std::io::Error) -> anyhow::Error {
    crate::Error::lost(name, &e, "was the plotter switched off or the cable pulled?").into()
}

/// Bytes heard from a device, quoted short for a message.
fn quote(bytes: &[u8]) -> String {
    let cut = &bytes[..bytes.len().min(HEARD_QUOTE)];
    let more = if bytes.len() > cut.len() { "…" } else { "" };
    format!("\"{}{more}\"", String::from_utf8_lossy(cut).escape_debug())
}

impl<L: HpglLink> HpglSession<L> {
    /// Connect: `ESC . L` (three tries) for the buffer size, `OI` for the model, the handshake set up (Xon/Xoff
    /// switched on; CTS checked to be readable), errors left by an earlier job cleared (`ESC . E`, `OE`). What
    /// the line carries before is read and dropped for at most [`CONNECT_DRAIN`]; a device that keeps talking
    /// (a wrong port, a controller that reports on its own) and does not answer like a plotter is refused with a
    /// quote of what it said. A stop (a single Ctrl-C included: nothing can pause yet) ends it.
    pub fn connect(link: L, name: &str, device: &'static HpglDevice, handshake: Handshake) -> anyhow::Result<Self> {
        Self::connect_guarded(link, name, device, handshake, &mut |_| Stop::process().stop_cause_or_interrupt())
    }

    /// [`HpglSession::connect`], asking `guard` between reads whether to give up.
    pub fn connect_guarded(
        link: L,
        name: &str,
        device: &'static HpglDevice,
        handshake: Handshake,
        guard: &mut Guard<'_>,
    ) -> anyhow::Result<Self> {
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
            work_ahead: Duration::ZERO,
        };
        match s.open(guard) {
            Ok(()) => Ok(s),
            Err(e) => {
                // `OI;` or `OE;` may wait in the buffer (behind a pen change an earlier session asked for): drop
                // them, so that their late answers cannot be taken for the answers of the next session.
                if s.stats.bytes > 0 {
                    let _ = s.write_raw(ABORT_GRAPHICS);
                }
                Err(e)
            }
        }
    }

    /// The conversation of [`HpglSession::connect_guarded`].
    fn open(&mut self, guard: &mut Guard<'_>) -> anyhow::Result<()> {
        let name = self.name.clone();
        let name = name.as_str();
        let (handshake, device) = (self.handshake, self.device);
        let s = self;
        // Whatever an earlier session left on the line: until it is quiet for 100 ms, for a few seconds at most.
        let start = s.link.now();
        let (mut heard, mut heard_bytes, mut babbling) = (Vec::new(), 0usize, false);
        loop {
            s.guarded(guard, Waiting::Answer, "the line to fall quiet")?;
            let got = s.link.read(Duration::from_millis(100)).map_err(|e| lost(name, e))?;
            if got.is_empty() {
                break;
            }
            heard_bytes += got.len();
            heard.extend(got.iter().take(HEARD_QUOTE.saturating_sub(heard.len())));
            if s.link.now().saturating_sub(start) >= CONNECT_DRAIN {
                babbling = true;
                break;
            }
        }
        let mut size = None;
        let mut answered = None;
        for _ in 0..3 {
            match s.query_guarded(BUFFER_SIZE, guard) {
                Ok(n) => {
                    size = Some(n);
                    break;
                }
                Err(e) if e.downcast_ref::<Stopped>().is_some() => return Err(e),
                Err(e) => answered = Some(e),
            }
        }
        let Some(size) = size.filter(|&n| n > 0) else {
            let why = answered.map(|e| format!(" ({e:#})")).unwrap_or_default();
            let talk = if babbling {
                format!(
                    "; it kept sending {} ({heard_bytes} bytes in {:.1} s without a pause): a wrong port, or a \
                     controller that reports on its own (a GRBL)?",
                    quote(&heard),
                    CONNECT_DRAIN.as_secs_f64()
                )
            } else if heard_bytes > 0 {
                format!("; before it was asked it sent {}", quote(&heard))
            } else {
                String::new()
            };
            bail!(
                "{name} does not answer ESC . L like an HP-GL plotter{why} (check that it is switched on and set \
                 to the same baud rate, 8 data bits, no parity, and the cable){talk}"
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
        let _ = s.query_guarded(EXTENDED_ERROR, guard)?;
        s.send_guarded(b"OI;", guard)?;
        s.settle_space(true, guard)?;
        s.identity = s
            .answer("the answer to OI", ANSWER_TIMEOUT * 5, guard)
            .context("no answer to OI (output identification)")?;
        s.send_guarded(b"OE;", guard)?;
        s.settle_space(true, guard)?;
        let _ = s.answer("the answer to OE", ANSWER_TIMEOUT * 5, guard).context("no answer to OE (output error)")?;
        s.parsed = s.stats.bytes;
        if !s.identity.eq_ignore_ascii_case(device.identity) {
            s.warnings.push(format!(
                "{name} says it is a {:?}, the program is written for the {} (--hpgl-device)",
                s.identity, device.name
            ));
        }
        Ok(())
    }

    /// `Err(Stopped)` when `guard` says so.
    fn guarded(&mut self, guard: &mut Guard<'_>, w: Waiting, what: &str) -> anyhow::Result<()> {
        match guard(w) {
            Some(cause) => Err(Stopped { cause, doing: format!("waiting for {what} from {}", self.name) }.into()),
            None => Ok(()),
        }
    }

    /// The estimated plotter time of what its buffer holds (the plot job knows it from the program): waits for
    /// room and for an `OE` give up [`patience`] of it after the plotter stopped taking bytes. 0 by default
    /// (connect, the console: the buffer holds next to nothing).
    pub fn set_work_ahead(&mut self, work: Duration) {
        self.work_ahead = work;
    }

    /// How long the plotter may take no byte before the session gives up (see [`patience`]).
    pub fn stall_limit(&self) -> Duration {
        patience(self.work_ahead)
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

    /// Listen to the line for `d` (Xon/Xoff noted, answers kept), asking `guard` between reads.
    pub fn listen(&mut self, d: Duration, guard: &mut Guard<'_>) -> anyhow::Result<()> {
        let end = self.link.now() + d;
        loop {
            self.guarded(guard, Waiting::Answer, "the plotter")?;
            let left = end.saturating_sub(self.link.now());
            if left.is_zero() {
                return Ok(());
            }
            self.pump(left.min(Duration::from_millis(50)))?;
        }
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

    /// The next answer (`what`, for messages), waiting at most `limit` in all, asking `guard` between reads.
    fn answer(&mut self, what: &str, limit: Duration, guard: &mut Guard<'_>) -> anyhow::Result<String> {
        let mut wait = Wait::new(&self.name, what, self.link.now(), limit);
        loop {
            if let Some(a) = self.take_answer() {
                return Ok(a);
            }
            self.guarded(guard, Waiting::Answer, what)?;
            let slice = wait.next(self.link.now(), Duration::from_millis(50))?;
            self.pump(slice)?;
        }
    }

    /// Take the answer to an `ESC . B` sent ahead (waiting for it when `wait`): the credit becomes the free space
    /// it reports minus the bytes sent since it was asked (they arrived after it), and the bytes then waiting in
    /// the buffer tell how far the plotter has parsed.
    fn settle_space(&mut self, wait: bool, guard: &mut Guard<'_>) -> anyhow::Result<()> {
        let Some(at) = self.space_asked_at else { return Ok(()) };
        let a = if wait {
            self.answer("the answer to ESC . B (free buffer space)", ANSWER_TIMEOUT, guard)?
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

    /// Ask `ESC . B` and wait for its answer: [`Self::parsed_bytes`] is up to date after it. Returns the free
    /// space the plotter reported, less the bytes sent since.
    pub fn poll_space(&mut self, guard: &mut Guard<'_>) -> anyhow::Result<usize> {
        self.settle_space(true, guard)?;
        self.ask_space()?;
        self.settle_space(true, guard)?;
        Ok(self.credit)
    }

    /// Send a device-control query and read its number.
    pub fn query(&mut self, esc: &[u8]) -> anyhow::Result<u32> {
        self.query_guarded(esc, &mut process_guard)
    }

    fn query_guarded(&mut self, esc: &[u8], guard: &mut Guard<'_>) -> anyhow::Result<u32> {
        self.settle_space(true, guard)?;
        self.write_raw(esc)?;
        let name = String::from_utf8_lossy(&esc[1..]).replace('.', ". ");
        let a = self.answer(&format!("the answer to ESC {name}"), ANSWER_TIMEOUT, guard)?;
        parse_number(&a).with_context(|| format!("{}: ESC {name} answered {a:?}, not a number", self.name))
    }

    /// HP-GL bytes sent so far.
    pub fn sent_bytes(&self) -> u64 {
        self.stats.bytes
    }

    /// HP-GL bytes the plotter has certainly taken out of its buffer (parsed).
    pub fn parsed_bytes(&self) -> u64 {
        self.parsed
    }

    /// Send HP-GL `bytes` under the handshake (the waits guarded by the process's stop flag).
    pub fn send(&mut self, bytes: &[u8]) -> anyhow::Result<()> {
        self.send_guarded(bytes, &mut process_guard)
    }

    /// Send HP-GL `bytes` under the handshake, asking `guard` between reads. A plotter that takes no byte for
    /// [`Self::stall_limit`] ends it with a message saying why it waited and how the limit came about.
    pub fn send_guarded(&mut self, mut bytes: &[u8], guard: &mut Guard<'_>) -> anyhow::Result<()> {
        let mut stall: Option<Wait> = None;
        let mut waits_before = self.stats.waits;
        while !bytes.is_empty() {
            let room = match self.handshake {
                Handshake::Escb => self.escb_room(bytes.len(), guard)?,
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
                let why = match self.handshake {
                    Handshake::Escb => "ESC . B answers no room",
                    Handshake::Xonxoff => "an Xoff and no Xon yet",
                    Handshake::Hardware => "CTS is down",
                };
                let now = self.link.now();
                let limit = self.stall_limit();
                let wait = stall.get_or_insert_with(|| {
                    Wait::new(&self.name, format!("room in the plotter's buffer ({why})"), now, limit)
                });
                let stalled = wait.elapsed(now);
                if let Some(cause) = guard(Waiting::Room { stalled }) {
                    return Err(Stopped {
                        cause,
                        doing: format!("waiting for room in the buffer of {} ({why})", self.name),
                    }
                    .into());
                }
                self.stats.waits += 1;
                // Under escb each look costs a query on the line: look less often the longer the plotter is full.
                let streak = u32::try_from(self.stats.waits - waits_before).unwrap_or(u32::MAX).min(4);
                let pause = if self.handshake == Handshake::Escb { 5 << streak } else { 5 };
                match wait.next(now, Duration::from_millis(pause)) {
                    Ok(slice) => {
                        self.pump(slice)?;
                    }
                    Err(WaitError::TimedOut { .. }) => bail!(
                        "{}: the plotter took no byte for {:.0} s ({why}); what its buffer held should take about \
                         {:.1} s, so it was given {:.0} s (1.5 × that + {:.0} s). Is it paused (its front-panel \
                         pause), out of paper, or its cable not wired for this handshake?",
                        self.name,
                        stalled.as_secs_f64(),
                        self.work_ahead.as_secs_f64(),
                        limit.as_secs_f64(),
                        super::timing::PATIENCE_MARGIN.as_secs_f64(),
                    ),
                    Err(e) => return Err(e.into()),
                }
                continue;
            }
            stall = None;
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
    fn escb_room(&mut self, want: usize, guard: &mut Guard<'_>) -> anyhow::Result<usize> {
        let useful = want.min(self.buffer_bytes / 4).max(1);
        self.settle_space(false, guard)?;
        if self.credit < useful {
            if self.space_asked_at.is_none() {
                self.ask_space()?;
            }
            self.settle_space(true, guard)?;
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
        self.check_guarded(wait, &mut process_guard)
    }

    /// [`HpglSession::check`], asking `guard` between reads.
    pub fn check_guarded(&mut self, wait: Duration, guard: &mut Guard<'_>) -> anyhow::Result<()> {
        self.settle_space(true, guard)?;
        let line = self.query_guarded(EXTENDED_ERROR, guard)?;
        if line != 0 {
            bail!("{} reports {}", self.name, error_text(line));
        }
        self.send_guarded(b"OE;", guard)?;
        let sent = self.stats.bytes;
        // An `ESC . B` asked ahead while sending `OE` is answered first (on arrival; `OE` when parsed).
        self.settle_space(true, guard)?;
        let a = match self.answer("the plotter to reach OE in its buffer (its answer)", wait, guard) {
            Ok(a) => a,
            Err(e) if e.downcast_ref::<Stopped>().is_some() => return Err(e),
            Err(e) => {
                // An OE lost to an overflow never answers: ask the line error once more.
                let line = self.query_guarded(EXTENDED_ERROR, guard).unwrap_or(0);
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
    /// (at most 16 answers, and for no longer than the plotter should take to run `text` — [`patience`] of its
    /// estimated time — plus `quiet`, however much it talks).
    pub fn exchange(&mut self, text: &[u8], quiet: Duration) -> anyhow::Result<Vec<String>> {
        let guard = &mut process_guard;
        let work = Commands::split(&String::from_utf8_lossy(text), self.device).seconds();
        self.set_work_ahead(Duration::from_secs_f64(work.clamp(0.0, 1e6)));
        self.settle_space(true, guard)?;
        self.send_guarded(text, guard)?;
        // An `ESC . B` asked ahead while sending is answered on arrival, before any answer of `text`.
        self.settle_space(true, guard)?;
        let mut wait = Wait::new(&self.name, "the plotter's answers", self.link.now(), self.stall_limit() + quiet);
        let mut answers = Vec::new();
        while answers.len() < 16 {
            if let Some(a) = self.take_answer() {
                answers.push(a);
                continue;
            }
            self.guarded(guard, Waiting::Answer, "the plotter's answers")?;
            let slice = match wait.next(self.link.now(), quiet) {
                Ok(slice) => slice,
                Err(WaitError::TimedOut { .. }) => break,
                Err(e) => return Err(e.into()),
            };
            if !self.pump(slice)? {
                break;
            }
        }
        self.set_work_ahead(Duration::ZERO);
        Ok(answers)
    }

    /// Stop now, whatever the plotter answers: `ESC . K` drops what the buffer holds and the instruction under
    /// way; then `PU;OE;SP0;` is written raw — after `ESC . K` the buffer is empty, so no handshake is asked (the
    /// one that may just have failed) — and the `OE` answer, which comes once the `PU` has run, confirms the
    /// lift. Returns what was done and what could not be confirmed, for the user; `Err` only when the lift could
    /// not be written at all (the line is gone).
    pub fn cancel(&mut self) -> anyhow::Result<String> {
        let mut no_guard = |_: Waiting| None;
        // An answer still due (an `ESC . B` asked ahead) is dropped with whatever else is on the line.
        self.space_asked_at = None;
        self.credit = 0;
        self.xoff = false;
        let abort = self.write_raw(ABORT_GRAPHICS);
        let lift = self.write_raw(b"PU;OE;SP0;");
        if lift.is_ok() {
            self.stats.bytes += 10;
        }
        let mut report = match &abort {
            Ok(()) => "stopped with ESC . K".to_string(),
            Err(e) => format!("ESC . K could not be written ({e:#})"),
        };
        if let Err(e) = lift {
            bail!("{report}; the pen-up (PU;SP0;) could not be written either: {e:#}");
        }
        // The confirmation: skip what is not a number (an answer to an abort, which should have none, or noise).
        self.rx.clear();
        let mut odd = Vec::new();
        let confirmed = loop {
            match self.answer("the answer to the OE after the pen-up", STOP_CONFIRM, &mut no_guard) {
                Ok(a) if parse_number(&a).is_some() => break Ok(()),
                Ok(a) if odd.len() < 3 => odd.push(format!("{a:?}")),
                Ok(_) => {}
                Err(e) => break Err(e),
            }
        };
        if !odd.is_empty() {
            report.push_str(&format!(" (the plotter answered {}, which are not answers to it)", odd.join(", ")));
        }
        match confirmed {
            Ok(()) => report.push_str("; the pen is up and put away (PU;SP0;, the lift confirmed by OE)"),
            Err(e) => report.push_str(&format!(
                "; PU;SP0; written to lift the pen and put it away, but not confirmed ({e:#}): check that the pen \
                 is up"
            )),
        }
        Ok(report)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::hpgl::model::{HpglModel, Lie, ModelConfig};
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

    /// A session on an honest 1024-byte 7475A model, the pen down in the middle of a long slow stroke.
    fn drawing(h: Handshake) -> HpglSession<ModelLink> {
        let mut s = HpglSession::connect(link(1024, true), "model", device("7475a").unwrap(), h).unwrap();
        s.send(b"SP1;VS2;PU1000,1000;PD9000,1000;").unwrap();
        s.listen(Duration::from_secs(3), &mut |_| None).unwrap();
        assert!(!s.link.model().pen_up(), "drawing");
        s
    }

    #[test]
    fn a_stop_whose_answers_fail_still_lifts_the_pen() {
        for lie in [Lie::EscbGarbage, Lie::EscbSilent, Lie::NoRoom] {
            let mut s = drawing(Handshake::Escb);
            s.link.model_mut().set_lie(lie, 0);
            let report = s.cancel().unwrap();
            s.link.finish(10.0);
            let m = s.link.model();
            assert!(m.pen_up() && m.pen() == 0, "{lie:?}: the pen ends up and put away: {report}");
            assert_eq!(m.stats().aborts, 1, "{lie:?}");
            assert!(report.contains("ESC . K") && report.contains("confirmed by OE"), "{lie:?}: {report}");
            if lie == Lie::EscbGarbage {
                assert!(report.contains("\"K?\""), "the odd answer is reported: {report}");
            }
        }
    }

    #[test]
    fn a_stop_amid_chatter_takes_the_confirmation_between_the_junk() {
        let mut s = drawing(Handshake::Escb);
        s.link.model_mut().set_lie(Lie::Chatter, 0);
        let t0 = s.link.now();
        let report = s.cancel().unwrap();
        assert!(report.contains("confirmed by OE") && report.contains("\"<Idle|MPos"), "{report}");
        assert!(s.link.now() - t0 < Duration::from_millis(300));
        s.link.finish(10.0);
        assert!(s.link.model().pen_up());
    }

    #[test]
    fn a_plotter_that_withholds_room_ends_the_wait_within_a_limit_from_the_work() {
        for (lie, h, why) in [
            (Lie::NoRoom, Handshake::Escb, "ESC . B answers no room"),
            (Lie::XoffForever, Handshake::Xonxoff, "an Xoff and no Xon yet"),
        ] {
            let mut s = HpglSession::connect(link(1024, true), "model", device("7475a").unwrap(), h).unwrap();
            let at = s.link.model().stats().buffered + 20;
            s.link.model_mut().set_lie(lie, at);
            s.set_work_ahead(Duration::from_secs(10));
            assert_eq!(s.stall_limit(), Duration::from_secs(35), "1.5 × 10 s + 20 s");
            let t0 = s.link.now();
            let e = s.send(&[b'P', b'U', b';'].repeat(2000)).unwrap_err().to_string();
            let took = s.link.now() - t0;
            assert!(e.contains("took no byte for 35 s") && e.contains(why) && e.contains("about 10.0 s"), "{e}");
            assert!(took < Duration::from_secs(37), "{lie:?}: {took:?}");
            // A stop ends the same wait at once, naming its cause.
            let mut asked = 0;
            let mut guard = |w: Waiting| {
                asked += 1;
                matches!(w, Waiting::Room { stalled } if stalled >= Duration::from_secs(1)).then_some(StopCause::Hangup)
            };
            let t0 = s.link.now();
            let e = s.send_guarded(b"PU;PU;", &mut guard).unwrap_err();
            assert!(e.downcast_ref::<Stopped>().is_some());
            assert!(e.to_string().starts_with("stopped by SIGHUP (the terminal closed) while waiting for room"), "{e}");
            assert!(s.link.now() - t0 < Duration::from_millis(1200) && asked > 1);
        }
    }

    #[test]
    fn connect_to_a_chattering_device_ends_with_what_it_heard() {
        let mut l = link(1024, true);
        l.model_mut().set_lie(Lie::Chatter, 0);
        let e = HpglSession::connect(l, "/dev/ttyUSB0", device("7475a").unwrap(), Handshake::Escb).err().unwrap();
        let e = format!("{e:#}");
        assert!(e.starts_with("/dev/ttyUSB0 does not answer ESC . L like an HP-GL plotter"), "{e}");
        assert!(e.contains("it kept sending \"<Idle|MPos:0.000,0.000,0.000|F") && e.contains("GRBL"), "{e}");
    }

    #[test]
    fn a_console_exchange_with_a_babbler_ends() {
        let mut s = HpglSession::connect(link(60, true), "model", device("7475a").unwrap(), Handshake::Escb).unwrap();
        s.link.model_mut().set_lie(Lie::Chatter, 0);
        let t0 = s.link.now();
        let a = s.exchange(b"OI;", Duration::from_millis(500)).unwrap();
        assert_eq!(a.len(), 16, "at most 16 answers");
        assert!(s.link.now() - t0 < Duration::from_secs(1));
    }

    #[test]
    fn a_connect_stopped_while_the_plotter_is_busy_leaves_no_late_answer_to_the_next() {
        let d = device("7475a").unwrap();
        let mut l = link(1024, true);
        // An earlier session's last words: a pen change (2 s) the plotter is still making.
        l.write(b"SP1;").unwrap();
        let mut calls = 0;
        let mut guard = |_: Waiting| {
            calls += 1;
            (calls >= 20).then_some(StopCause::Terminate)
        };
        let e = HpglSession::connect_guarded(&mut l, "model", d, Handshake::Escb, &mut guard).err().unwrap();
        assert!(format!("{e:#}").contains("stopped by SIGTERM while waiting for the answer to OI"), "{e:#}");
        // Whatever answers the stopped session's OI; OE would have given now comes too late for the next one.
        let mut s = HpglSession::connect(&mut l, "model", d, Handshake::Escb).unwrap();
        assert_eq!(s.identity, "7475A");
        s.send(b"PU100,100;").unwrap();
        s.check(Duration::from_secs(10)).unwrap();
        assert_eq!(s.exchange(b"OE;", Duration::from_millis(500)).unwrap(), ["0"]);
        assert_eq!(s.exchange(b"OI;", Duration::from_millis(500)).unwrap(), ["7475A"]);
        assert_eq!(s.link.model().stats().aborts, 1);
    }
}
