//! The host link: the session state of one serial connection — the receive ring, the line assembler, the frame
//! being answered, sequence numbers and resends ([`crate::protocol`]), framed mode and its real-time sequences
//! ([`crate::framing`]), completion reports ([`crate::report`]) and the refusal that stops a damaged plot. It turns
//! received bytes into [`Input`]s for the machine and writes every reply; it knows nothing of motion or G-code
//! meanings beyond the line envelope.

use core::fmt::{self, Write as _};

use crate::axis::{Axis, NUM_AXES};
use crate::config::MachineConfig;
use crate::decimal::Decimal;
use crate::errors::ErrorCode;
use crate::framing::{self, RtMatcher};
use crate::gcode::{Words, envelope, parse_words};
use crate::hal::SerialOut;
use crate::line_buffer::{Frame, LINE_MAX, LineAssembler, RxBuffer};
use crate::protocol::{Decoder, PROTOCOL_VERSION, RT_RESET, RT_RESUME, RT_STATUS, is_realtime};
use crate::realtime::MachineState;
use crate::report::CompletionReporter;
use crate::step_block::{StepBlock, TICK_HZ};

/// Formatted text to a serial port.
pub(crate) struct Out<'a, S: SerialOut>(pub(crate) &'a mut S);

impl<S: SerialOut> fmt::Write for Out<'_, S> {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        self.0.write(s.as_bytes());
        Ok(())
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum PendingKind {
    Line,
    TooLong,
    Damaged,
}

/// What the pending frame asks of the machine.
#[allow(clippy::large_enum_variant, reason = "no heap in the firmware; one value per frame, moved once")]
pub(crate) enum Input {
    /// Nothing to run: the link answered it (a resend request or an error).
    Answered,
    /// G-code to run; `number` is the line number of a sequenced line (commit it with [`Link::commit_seq`] once
    /// the line has run).
    Line {
        /// The line's words.
        words: Words,
        /// Its line number, if sequenced.
        number: Option<u32>,
    },
    /// A decoded step-block frame; [`Link::accept_frame`] with `decoder` takes it (leaving it pending retries it).
    Frame {
        /// The block.
        block: StepBlock,
        /// The decoder state after it.
        decoder: Decoder,
    },
}

/// A status report (`?`) was asked for.
pub(crate) const RT_FLAG_STATUS: u8 = 1;
/// A resume (`~`) was asked for.
pub(crate) const RT_FLAG_RESUME: u8 = 2;
/// A reset (0x18) was asked for.
pub(crate) const RT_FLAG_RESET: u8 = 4;

/// The session state of the host link (`RX`: receive ring capacity).
pub(crate) struct Link<const RX: usize> {
    /// Real-time commands received and not yet served (`RT_FLAG_*`).
    realtime: u8,
    rx: RxBuffer<RX>,
    /// Receive size announced to the host (≤ `RX`).
    rx_size: usize,
    asm: LineAssembler,
    pending: heapless::Vec<u8, LINE_MAX>,
    pending_kind: Option<PendingKind>,
    decoder: Decoder,
    seq: u32,
    /// A sequenced stream is active: a sequenced frame was accepted or a resend requested since the last reset or
    /// the last plain G-code line. Bytes ≥ 0x80 in a line then mean a damaged frame.
    streaming: bool,
    /// Framed mode ([`crate::framing`]): CRC-framed replies, four-byte real-time commands, sequenced input only.
    framed: bool,
    rt_matcher: RtMatcher,
    /// The sequence number of the frame or line being answered (framed `ok`/`error:` carry it).
    answering: u32,
    /// When to send the next completion report (framed mode, [`crate::report`]).
    reporter: CompletionReporter,
    /// The stepper's completed-block count at start or the last reset (the status report's `C:` counts from it).
    completed_base: u32,
    /// A step block was refused (its sequence number and error code): every later frame is refused too, so nothing
    /// after a hole in the plot runs, until a reset, a homing cycle or framed mode switched on again. The status
    /// report carries it as `R:<n>,<code>`.
    refused: Option<(u32, u8)>,
}

impl<const RX: usize> Link<RX> {
    /// A fresh session announcing `rx_bytes` of receive buffer (clamped to `RX`).
    pub(crate) fn new(rx_bytes: u32) -> Self {
        Link {
            realtime: 0,
            rx: RxBuffer::new(),
            rx_size: usize::try_from(rx_bytes).unwrap_or(RX).min(RX),
            asm: LineAssembler::new(),
            pending: heapless::Vec::new(),
            pending_kind: None,
            decoder: Decoder::new(),
            seq: 0,
            streaming: false,
            framed: false,
            rt_matcher: RtMatcher::new(),
            answering: 0,
            reporter: CompletionReporter::new(0),
            completed_base: 0,
            refused: None,
        }
    }

    /// Back to a fresh session (a reset); `completed` is the stepper's block count now.
    pub(crate) fn reset(&mut self, completed: u32) {
        self.rx.clear();
        self.asm.clear();
        self.pending.clear();
        self.pending_kind = None;
        self.decoder = Decoder::new();
        self.seq = 0;
        self.streaming = false;
        self.framed = false;
        self.rt_matcher.clear();
        self.completed_base = completed;
        self.refused = None;
    }

    /// Free bytes in the receive buffer.
    pub(crate) fn rx_free(&self) -> usize {
        self.rx_size.saturating_sub(self.rx.len())
    }

    /// Whether the receive buffer holds bytes or a frame is waiting.
    pub(crate) fn has_input(&self) -> bool {
        !self.rx.is_empty() || self.pending_kind.is_some()
    }

    /// Next expected sequence number.
    pub(crate) fn seq(&self) -> u32 {
        self.seq
    }

    /// Whether framed mode is on.
    pub(crate) fn is_framed(&self) -> bool {
        self.framed
    }

    /// Framed mode on or off (`M990 S<0|1>`); either way a new completion count and no refusal.
    pub(crate) fn set_framed(&mut self, on: bool, completed: u32) {
        self.framed = on;
        self.reporter.restart(completed);
        self.refused = None;
    }

    /// Blocks completed since the start or the last reset, from the stepper's count `completed`.
    pub(crate) fn completed_since_reset(&self, completed: u32) -> u32 {
        completed.wrapping_sub(self.completed_base)
    }

    /// The refused step block (its number and error code), if any.
    pub(crate) fn refused(&self) -> Option<(u32, u8)> {
        self.refused
    }

    /// Refuse every later frame after the block numbered `number` was refused with `code`.
    pub(crate) fn refuse(&mut self, number: u32, code: ErrorCode) {
        self.refused = Some((number, code.code()));
    }

    /// A homing cycle ended: frames are taken again.
    pub(crate) fn clear_refused(&mut self) {
        self.refused = None;
    }

    /// One received byte (interrupt context): a real-time command is recorded for [`Link::take_realtime`] and
    /// returned for the machine to act on at once; everything else goes to the ring (a byte that does not fit is
    /// counted and reported, see [`RxBuffer`]).
    pub(crate) fn receive(&mut self, b: u8) -> Option<u8> {
        let cmd = if self.framed {
            // Only a complete four-byte sequence is a command; everything else is data (see `crate::framing`).
            let mut matcher = core::mem::take(&mut self.rt_matcher);
            let cmd = matcher.feed(b, |d| self.receive_data(d));
            self.rt_matcher = matcher;
            cmd
        } else if is_realtime(b) {
            Some(b)
        } else {
            self.receive_data(b);
            None
        };
        self.realtime |= match cmd {
            Some(RT_STATUS) => RT_FLAG_STATUS,
            Some(RT_RESUME) => RT_FLAG_RESUME,
            Some(RT_RESET) => RT_FLAG_RESET,
            _ => 0,
        };
        cmd
    }

    /// Real-time commands wait for the main loop.
    pub(crate) fn realtime_pending(&self) -> bool {
        self.realtime != 0
    }

    /// The real-time commands received since the last call (`RT_FLAG_*`).
    pub(crate) fn take_realtime(&mut self) -> u8 {
        core::mem::take(&mut self.realtime)
    }

    fn receive_data(&mut self, b: u8) {
        if self.rx.len() >= self.rx_size {
            // Over the announced size: recorded as a loss, exactly like a full ring.
            self.rx.mark_loss();
            return;
        }
        self.rx.push(b);
    }

    /// Whether a frame is pending, assembling the next one from the ring if none is.
    pub(crate) fn next_frame(&mut self) -> bool {
        if self.pending_kind.is_some() {
            return true;
        }
        while let Some((b, lost)) = self.rx.pop() {
            if let Some(frame) = self.asm.feed(b, lost) {
                let (kind, bytes) = match frame {
                    Frame::Line(l) => (PendingKind::Line, l),
                    Frame::TooLong(l) => (PendingKind::TooLong, l),
                    Frame::Damaged(l) => (PendingKind::Damaged, l),
                };
                self.pending.clear();
                // Cannot fail: frames are at most LINE_MAX bytes.
                let _ = self.pending.extend_from_slice(bytes);
                self.pending_kind = Some(kind);
                return true;
            }
        }
        false
    }

    /// The pending frame has been handled: drop it.
    pub(crate) fn finish_frame(&mut self) {
        self.pending_kind = None;
        self.pending.clear();
    }

    /// Read the pending frame: check its envelope and sequence number, answer what the link answers itself
    /// (resends, damaged or overlong lines, parse errors) and hand the rest to the machine.
    pub(crate) fn input<S: SerialOut>(&mut self, out: &mut S) -> Input {
        let kind = self.pending_kind.unwrap_or(PendingKind::Line);
        let mut buf = [0u8; LINE_MAX];
        let len = self.pending.len();
        buf[..len].copy_from_slice(&self.pending);
        let line = &buf[..len];
        // G-code is ASCII: during a sequenced stream, a line with a byte ≥ 0x80 is a step-block frame whose marker
        // bit (or marker byte) was damaged on the wire, never a command to run.
        let damaged_frame = self.streaming && line.iter().any(|&c| c >= 0x80);
        let sequenced =
            self.framed || damaged_frame || line.first().is_some_and(|&c| c >= 0x80 || c == b'N' || c == b'n');
        self.answering = self.seq;
        if self.framed && kind == PendingKind::Line && line.first().is_none_or(|&c| c < 0x80) {
            // Framed mode takes sequenced input only: anything else is a damaged frame.
            match envelope(line) {
                Ok(e) if e.checked && e.number.is_some() => self.answering = e.number.unwrap_or(self.seq),
                _ => return self.resend(out),
            }
        }
        match kind {
            PendingKind::TooLong | PendingKind::Damaged if sequenced => return self.resend(out),
            PendingKind::TooLong => return self.refuse_line(out, ErrorCode::LineTooLong, format_args!("")),
            PendingKind::Damaged => {
                let lost = self.rx.take_lost();
                return self.refuse_line(out, ErrorCode::RxOverflow, format_args!(": {lost} bytes"));
            }
            PendingKind::Line => {}
        }
        if line.first().is_some_and(|&c| c >= 0x80) {
            let mut decoder = self.decoder.clone();
            return match decoder.decode(line, self.seq) {
                Ok(block) => Input::Frame { block, decoder },
                Err(_) => self.resend(out),
            };
        }
        if damaged_frame {
            return self.resend(out);
        }
        let env = match envelope(line) {
            Ok(e) => e,
            Err(_) if sequenced => return self.resend(out),
            Err(_) => return self.refuse_line(out, ErrorCode::Checksum, format_args!("")),
        };
        let words = match parse_words(env.body) {
            Ok(w) => w,
            Err(e) => {
                if env.number.is_some() && !env.checked {
                    return self.resend(out);
                }
                if let Some(n) = env.number
                    && n != self.seq
                {
                    return self.resend(out);
                }
                self.commit_seq(env.number);
                return self.refuse_line(out, e.code, format_args!(" at column {}", e.column));
            }
        };
        if env.number.is_none() && !env.checked {
            // A plain, well-formed G-code line: interactive use, not a sequenced stream.
            self.streaming = false;
        }
        if let Some(n) = env.number {
            if !env.checked {
                return self.resend(out);
            }
            if words.m.contains(&110) {
                self.seq = n;
            } else if n != self.seq {
                return self.resend(out);
            }
        }
        Input::Line { words, number: env.number }
    }

    /// A sequenced line or frame has run: expect the next number.
    pub(crate) fn commit_seq(&mut self, number: Option<u32>) {
        if number.is_some() {
            self.seq = self.seq.wrapping_add(1);
            self.streaming = true;
        }
    }

    /// Take the step-block frame [`Input::Frame`] returned (with its `decoder`); returns its sequence number.
    pub(crate) fn accept_frame(&mut self, decoder: Decoder) -> u32 {
        self.decoder = decoder;
        let number = self.seq;
        self.commit_seq(Some(0));
        number
    }

    fn resend<S: SerialOut>(&mut self, out: &mut S) -> Input {
        self.streaming = true;
        let seq = self.seq;
        self.reply(out, seq, format_args!("rs {seq}"));
        Input::Answered
    }

    fn refuse_line<S: SerialOut>(&mut self, out: &mut S, code: ErrorCode, detail: fmt::Arguments<'_>) -> Input {
        self.reply_error(out, code, detail);
        Input::Answered
    }

    /// The start-up banner with the buffer sizes (`queue` blocks of planner queue).
    pub(crate) fn banner<S: SerialOut>(&mut self, out: &mut S, version: &str, queue: usize) {
        let (rx, seq) = (self.rx_size, self.seq);
        let _ = writeln!(
            Out(out),
            "plotter-fw {version} proto {PROTOCOL_VERSION} rx {rx} queue {queue} line {LINE_MAX} seq {seq}"
        );
    }

    /// One reply line: plain, or framed with number `n` in framed mode.
    pub(crate) fn reply<S: SerialOut>(&mut self, out: &mut S, n: u32, text: fmt::Arguments<'_>) {
        if self.framed {
            let _ = framing::write_reply(Out(out), n, text);
        } else {
            let _ = writeln!(Out(out), "{text}");
        }
    }

    /// The status report (`?`): `state`, the stepper's position `steps`, the planner queue's fill
    /// `[queued, size]` and the stepper's completed-block count.
    pub(crate) fn status_report<S: SerialOut>(
        &mut self,
        out: &mut S,
        state: MachineState,
        steps: &[i32; NUM_AXES],
        cfg: &MachineConfig,
        [queued, size]: [usize; 2],
        completed: u32,
    ) {
        let seq = self.seq;
        let done = self.completed_since_reset(completed);
        let mm: [f32; NUM_AXES] = core::array::from_fn(|i| steps[i] as f32 / cfg.axis(Axis::ALL[i]).steps_per_mm);
        let refused = Refused(self.refused);
        self.reply(
            out,
            seq,
            format_args!(
                "<{state}|MPos:{},{},{},{}|Steps:{},{},{},{}|Q:{queued}/{size}|N:{seq}|C:{done}{refused}>",
                Decimal::new(mm[0], 3),
                Decimal::new(mm[1], 3),
                Decimal::new(mm[2], 3),
                Decimal::new(mm[3], 3),
                steps[0],
                steps[1],
                steps[2],
                steps[3]
            ),
        );
    }

    /// The `M115` reply: firmware, protocol and buffer sizes (framed in framed mode: the host takes its buffer
    /// sizes from it); `queue` blocks of planner queue.
    pub(crate) fn identify<S: SerialOut>(&mut self, out: &mut S, version: &str, queue: usize) {
        let rx = self.rx_size;
        self.answer(
            out,
            format_args!(
                "FIRMWARE_NAME:plotter-fw FIRMWARE_VERSION:{version} PROTOCOL_VERSION:{PROTOCOL_VERSION} \
                 RX_BUFFER:{rx} QUEUE_BLOCKS:{queue} LINE_MAX:{LINE_MAX} TICK_HZ:{TICK_HZ}"
            ),
        );
    }

    /// A reply to the line or frame being answered.
    pub(crate) fn answer<S: SerialOut>(&mut self, out: &mut S, text: fmt::Arguments<'_>) {
        self.reply(out, self.answering, text);
    }

    /// `ok` to the line or frame being answered.
    pub(crate) fn reply_ok<S: SerialOut>(&mut self, out: &mut S) {
        self.answer(out, format_args!("ok"));
    }

    /// `error:<code> <text><detail>` to the line or frame being answered.
    pub(crate) fn reply_error<S: SerialOut>(&mut self, out: &mut S, code: ErrorCode, detail: fmt::Arguments<'_>) {
        self.answer(out, format_args!("error:{} {}{}", code.code(), code.text(), detail));
    }

    /// Whether a completion report should go out now ([`crate::report`]; framed mode only), for the stepper's
    /// count `completed` at `now`, `drained` when nothing is left to run.
    pub(crate) fn completion_due(&self, completed: u32, now: u64, drained: bool) -> bool {
        self.framed && self.reporter.due(completed, now, drained)
    }

    /// Send the completion report when one is due.
    pub(crate) fn report_completion<S: SerialOut>(&mut self, out: &mut S, completed: u32, now: u64, drained: bool) {
        if self.completion_due(completed, now, drained) {
            let (done, seq) = (self.completed_since_reset(completed), self.seq);
            self.reply(out, seq, format_args!("C:{done}"));
            self.reporter.sent(completed, now);
        }
    }
}

/// The status report's `|R:<n>,<code>` field (nothing when no block was refused).
struct Refused(Option<(u32, u8)>);

impl fmt::Display for Refused {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0 {
            Some((n, code)) => write!(f, "|R:{n},{code}"),
            None => Ok(()),
        }
    }
}
