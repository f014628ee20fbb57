//! The wire protocol between host and firmware: G-code lines, compact step-block frames, real-time bytes and the
//! replies. Encoder and decoder live here together and are used by both sides.
//!
//! # Byte stream
//! Host → firmware is a byte stream of *frames*, each ending with `\n` (a `\r` before it is ignored):
//! - **G-code line**: ASCII, at most [`crate::line_buffer::LINE_MAX`] bytes. Optionally numbered and checked as
//!   in RepRap firmwares: `N<n> <words>*<cs>` with `cs` the XOR of all bytes before `*` ([`crate::gcode::xor_checksum`]).
//! - **Step-block frame**: first byte ≥ `0x80` (never valid in G-code), see below.
//! - **Real-time bytes** [`RT_STATUS`] `?`, [`RT_FEED_HOLD`] `!`, [`RT_RESUME`] `~`, [`RT_RESET`] `0x18` are acted
//!   on the moment they are received, wherever they appear; they never enter a frame and are not answered with `ok`.
//!
//! # Sequence numbers and resends
//! Numbered G-code lines and step-block frames share one sequence counter, the *expected number* `E` (0 after
//! start or reset; `M110 N<n>` sets it). A numbered line must carry `N` = `E`; a step-block frame carries no number
//! on the wire but its CRC is computed over `E` too (an *implicit* sequence number), so a frame that is out of
//! order, duplicated or corrupted fails its check just the same. Every accepted frame advances `E` by one —
//! also when its command is then refused with `error:` (it was received intact; the error is about its content).
//! Lines without `N` and `*` are not sequenced (interactive use).
//!
//! On a bad frame (checksum/CRC mismatch, wrong number, malformed frame, lost bytes) the firmware answers
//! `rs <E>` and discards every following sequenced frame (answering each with `rs <E>` again) until one with the
//! expected number arrives intact. The host rewinds to `E` on the first `rs <E>` and resends from there
//! (go-back-N); later `rs <E>` with the same number are only the answers for frames already in flight. A frame is
//! therefore executed exactly once, and never when corrupted.
//!
//! G-code is ASCII, so while a sequenced stream is active (a sequenced frame was accepted or a resend requested
//! since the last reset or plain, unnumbered G-code line), a line holding any byte ≥ `0x80` that is not a valid
//! step-block frame — e.g. one whose marker bit was flipped or whose marker byte was lost — is a damaged frame: it
//! is answered `rs <E>` like any other bad frame, never parsed or executed as G-code. (Noise that leaves no byte
//! ≥ `0x80` can still make a frame look like bad G-code, answered `error:`; the host treats such errors during a
//! stream as a lost frame.)
//!
//! # Replies (firmware → host), one line each, every frame answered exactly once
//! (In framed mode, which a streaming host turns on, every reply carries a number and a CRC-32 and real-time
//! commands are four-byte sequences: see [`crate::framing`].)
//! - `ok` — accepted (queued or done).
//! - `error:<code> <text>` — refused, nothing executed; codes in [`crate::errors::ErrorCode`]. A step block refused
//!   for its content (outside the travel, out of range) makes every later step block refused too
//!   (`error:12 … block <n> was refused`) until a reset, a homing cycle or `M990 S1`, so nothing after a hole in
//!   the plot runs; meanwhile the status report ends with `|R:<n>,<code>` (the refused block's number and code).
//! - `rs <n>` — resend from number `n`.
//! - Unsolicited: `ALARM:<code> <text>` ([`crate::errors::AlarmCode`]), the status report `<...>` for `?`, the
//!   start banner `plotter-fw <version> proto <p> rx <bytes> queue <blocks> line <max> seq <E>` (also sent on
//!   reset), `M114`/`M115` report lines, which precede that command's `ok`, and in framed mode the completion
//!   report `C:<count>` ([`crate::report`]).
//!
//! Flow control: the banner announces the receive buffer size; the host keeps at most that many bytes of
//! unanswered frames in flight. The firmware reports any byte it had to drop (`error:` for the damaged line).
//!
//! # Step-block frame encoding
//! ```text
//! marker   1 byte   1 m m m m w w a     m = axis mask (X=bit3 … E=bit0 of the 4 bits), w = step width class,
//!                                       a = 1: acceleration field present (else the previous frame's is reused)
//! payload  bit string, MSB first, zero-padded to whole bytes:
//!          entry code (2) · exit code (2) · steps of each axis in the mask (signed, width 6/9/13/24 bits for
//!          w = 0/1/2/3) · cruise rate (12) · entry rate (12, code 2 only) · exit rate (12, code 2 only) ·
//!          acceleration (24, when a = 1)
//!          rate codes: 0 = zero, 1 = same as cruise, 2 = explicit
//!          mask = 0 is a dwell: codes and a must be 0; w = 0 is a plain dwell, payload codes · dwell ticks (24);
//!          w = 1 is a servo-pen block, payload codes · angle (12, tenths of a degree, ≤ 1800) · settle ticks (24)
//! crc      2 bytes, CRC-16/CCITT (poly 0x1021, init 0xFFFF) over E as 4 bytes little-endian, the marker and
//!          the payload bytes, big-endian
//! escape   after the marker, each byte of payload+crc that is `\n`, a real-time byte or ESC (0x1B) is sent as
//!          ESC, byte ^ 0x20
//! end      `\n`
//! ```
//! Rates are 12-bit floats: 3-bit exponent `e`, 9-bit mantissa `m`, value `m << e` (exact below 512, at most
//! 0.4 % coarser above, maximum [`RATE_MAX`]). The host rounds its plan down to representable rates with
//! [`quantize`] *before* computing times, so its time estimate is for exactly the block the firmware runs.
//! Sizes: a cruising move with steps within ±255 on X and Y is 9 bytes; a fully accelerating/decelerating one
//! (entry, cruise and exit all different) 12 bytes including `\n`; a new acceleration adds 3 bytes.

use crate::axis::{Axis, NUM_AXES};
use crate::step_block::{SERVO_TENTHS_MAX, StepBlock};

/// Real-time byte: status report.
pub const RT_STATUS: u8 = b'?';
/// Real-time byte: feed hold.
pub const RT_FEED_HOLD: u8 = b'!';
/// Real-time byte: resume (cycle start).
pub const RT_RESUME: u8 = b'~';
/// Real-time byte: soft reset (Ctrl-X).
pub const RT_RESET: u8 = 0x18;
/// Escape byte inside step-block frames.
pub const ESC: u8 = 0x1B;
/// Protocol version announced in the banner and M115 (2: framed mode, [`crate::framing`]; 3: servo-pen step
/// blocks).
pub const PROTOCOL_VERSION: u32 = 3;
/// Longest step-block frame on the wire, including `\n` (everything escaped).
pub const MAX_FRAME: usize = 1 + 2 * (PAYLOAD_MAX + 2) + 1;
/// Largest rate a frame can carry (events/s).
pub const RATE_MAX: u32 = 511 << 7;
/// Largest acceleration a frame can carry (events/s²).
pub const ACCEL_MAX: u32 = (1 << 24) - 1;
/// Longest dwell a frame can carry (ticks).
pub const DWELL_MAX: u32 = (1 << 24) - 1;

const PAYLOAD_MAX: usize = 20;
const WIDTHS: [u32; 4] = [6, 9, 13, 24];

/// Whether `b` is one of the real-time command bytes.
pub const fn is_realtime(b: u8) -> bool {
    matches!(b, RT_STATUS | RT_FEED_HOLD | RT_RESUME | RT_RESET)
}

const fn needs_escape(b: u8) -> bool {
    b == b'\n' || b == ESC || is_realtime(b)
}

fn crc16(seq: u32, marker: u8, payload: &[u8]) -> u16 {
    let mut crc: u16 = 0xFFFF;
    let seq = seq.to_le_bytes();
    for &b in seq.iter().chain(core::iter::once(&marker)).chain(payload) {
        crc ^= u16::from(b) << 8;
        for _ in 0..8 {
            crc = if crc & 0x8000 != 0 { (crc << 1) ^ 0x1021 } else { crc << 1 };
        }
    }
    crc
}

/// Largest rate ≤ `r` that a frame can carry.
pub fn quantize_rate(r: u32) -> u32 {
    let r = r.min(RATE_MAX);
    if r < 512 {
        return r;
    }
    let e = 32 - r.leading_zeros() - 9;
    (r >> e) << e
}

fn rate_code(r: u32) -> Option<u32> {
    if r < 512 {
        return Some(r);
    }
    let e = 32 - r.leading_zeros() - 9;
    let m = r >> e;
    (e <= 7 && m << e == r).then_some((e << 9) | m)
}

fn rate_value(code: u32) -> u32 {
    (code & 0x1FF) << (code >> 9)
}

/// `block` with its rates rounded down to what a frame carries (entry/exit also capped at cruise). Execution time
/// must be computed on the quantized block.
pub fn quantize(block: &StepBlock) -> StepBlock {
    if block.is_dwell() {
        return StepBlock { servo: block.servo, ..StepBlock::dwell(block.dwell_ticks.min(DWELL_MAX)) };
    }
    let cruise = quantize_rate(block.cruise_rate.max(1));
    StepBlock {
        steps: block.steps,
        entry_rate: quantize_rate(block.entry_rate.min(cruise)),
        cruise_rate: cruise,
        exit_rate: quantize_rate(block.exit_rate.min(cruise)),
        accel: block.accel.min(ACCEL_MAX),
        dwell_ticks: 0,
        servo: None,
    }
}

/// Why a block cannot be encoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EncodeError {
    /// A rate is not representable (call [`quantize`] first), or cruise is 0 on a move.
    Rate,
    /// Acceleration above [`ACCEL_MAX`].
    Accel,
    /// Steps beyond ±2²³ on some axis.
    Steps,
    /// Dwell above [`DWELL_MAX`].
    Dwell,
    /// Servo angle above [`SERVO_TENTHS_MAX`].
    Servo,
}

/// Why a received frame was rejected (the firmware asks for a resend in every case).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DecodeError {
    /// Not a step-block frame (first byte below 0x80) or empty.
    NotAFrame,
    /// ESC at the end or a frame longer than [`MAX_FRAME`].
    Framing,
    /// CRC mismatch: corrupted, out of order or duplicated.
    Crc,
    /// Length does not match the fields, or a field holds an invalid value.
    Malformed,
}

struct BitWriter {
    buf: [u8; PAYLOAD_MAX],
    bits: usize,
}

impl BitWriter {
    fn put(&mut self, value: u32, width: u32) {
        for i in (0..width).rev() {
            if (value >> i) & 1 != 0 {
                self.buf[self.bits / 8] |= 0x80 >> (self.bits % 8);
            }
            self.bits += 1;
        }
    }
}

struct BitReader<'a> {
    buf: &'a [u8],
    bits: usize,
}

impl BitReader<'_> {
    fn get(&mut self, width: u32) -> Result<u32, DecodeError> {
        let mut v = 0u32;
        for _ in 0..width {
            let byte = *self.buf.get(self.bits / 8).ok_or(DecodeError::Malformed)?;
            v = (v << 1) | u32::from((byte >> (7 - self.bits % 8)) & 1);
            self.bits += 1;
        }
        Ok(v)
    }
}

fn to_field(v: i32, width: u32) -> u32 {
    // Two's complement in `width` bits.
    v.cast_unsigned() & ((1u32 << width) - 1)
}

fn from_field(v: u32, width: u32) -> i32 {
    let shift = 32 - width;
    (v << shift).cast_signed() >> shift
}

/// Host side: turns step blocks into frames. Remembers the last acceleration sent (frames reuse it).
#[derive(Debug, Clone, Default)]
pub struct Encoder {
    last_accel: u32,
}

impl Encoder {
    /// A fresh encoder, matching a freshly started or reset firmware.
    pub fn new() -> Self {
        Encoder::default()
    }

    /// Encode `block` as the frame with sequence number `seq` into `out`, `\n` included; returns its length.
    /// The block must already be [`quantize`]d. Resend frames by their stored bytes, never by re-encoding.
    pub fn encode(&mut self, block: &StepBlock, seq: u32, out: &mut [u8; MAX_FRAME]) -> Result<usize, EncodeError> {
        let mut w = BitWriter { buf: [0; PAYLOAD_MAX], bits: 0 };
        let marker;
        let mut new_accel = None;
        if block.is_dwell() {
            if block.dwell_ticks > DWELL_MAX {
                return Err(EncodeError::Dwell);
            }
            w.put(0, 4);
            if let Some(tenths) = block.servo {
                if tenths > SERVO_TENTHS_MAX {
                    return Err(EncodeError::Servo);
                }
                marker = 0x82;
                w.put(u32::from(tenths), 12);
            } else {
                marker = 0x80;
            }
            w.put(block.dwell_ticks, 24);
        } else {
            let cruise = rate_code(block.cruise_rate).filter(|_| block.cruise_rate > 0).ok_or(EncodeError::Rate)?;
            let code_of = |r: u32| -> Result<(u32, Option<u32>), EncodeError> {
                if r == 0 {
                    Ok((0, None))
                } else if r == block.cruise_rate {
                    Ok((1, None))
                } else {
                    Ok((2, Some(rate_code(r).ok_or(EncodeError::Rate)?)))
                }
            };
            let (ecode, entry) = code_of(block.entry_rate)?;
            let (xcode, exit) = code_of(block.exit_rate)?;
            if block.accel > ACCEL_MAX {
                return Err(EncodeError::Accel);
            }
            let mut mask = 0u8;
            let mut widest = 0u32;
            for axis in Axis::ALL {
                let s = block.steps[axis.index()];
                if s != 0 {
                    mask |= 0x08 >> axis.index();
                    // Bits for a two's-complement value: magnitude bits + sign bit.
                    let mag = if s < 0 { !s } else { s };
                    widest = widest.max(33 - mag.leading_zeros());
                }
            }
            let class = WIDTHS.iter().position(|&b| b >= widest).ok_or(EncodeError::Steps)?;
            let width = WIDTHS[class];
            let accel_flag = block.accel != self.last_accel;
            if accel_flag {
                new_accel = Some(block.accel);
            }
            let class = u8::try_from(class).map_err(|_| EncodeError::Steps)?;
            marker = 0x80 | (mask << 3) | (class << 1) | u8::from(accel_flag);
            w.put(ecode, 2);
            w.put(xcode, 2);
            for axis in Axis::ALL {
                let s = block.steps[axis.index()];
                if s != 0 {
                    w.put(to_field(s, width), width);
                }
            }
            w.put(cruise, 12);
            if let Some(c) = entry {
                w.put(c, 12);
            }
            if let Some(c) = exit {
                w.put(c, 12);
            }
            if accel_flag {
                w.put(block.accel, 24);
            }
        }
        let len = w.bits.div_ceil(8);
        let crc = crc16(seq, marker, &w.buf[..len]);
        out[0] = marker;
        let mut n = 1;
        for &b in w.buf[..len].iter().chain(&crc.to_be_bytes()) {
            if needs_escape(b) {
                out[n] = ESC;
                out[n + 1] = b ^ 0x20;
                n += 2;
            } else {
                out[n] = b;
                n += 1;
            }
        }
        out[n] = b'\n';
        if let Some(a) = new_accel {
            self.last_accel = a;
        }
        Ok(n + 1)
    }
}

/// Firmware side: turns frames back into step blocks. Remembers the last acceleration received.
#[derive(Debug, Clone, Default)]
pub struct Decoder {
    last_accel: u32,
}

impl Decoder {
    /// A fresh decoder (firmware start or reset).
    pub fn new() -> Self {
        Decoder::default()
    }

    /// Decode `frame` (without the `\n`) expected to carry sequence number `seq`. The decoder's state changes only
    /// when the frame is accepted.
    pub fn decode(&mut self, frame: &[u8], seq: u32) -> Result<StepBlock, DecodeError> {
        let (&marker, rest) = frame.split_first().ok_or(DecodeError::NotAFrame)?;
        if marker < 0x80 {
            return Err(DecodeError::NotAFrame);
        }
        let mut raw = [0u8; PAYLOAD_MAX + 2];
        let mut len = 0;
        let mut it = rest.iter();
        while let Some(&b) = it.next() {
            let v = if b == ESC { it.next().ok_or(DecodeError::Framing)? ^ 0x20 } else { b };
            *raw.get_mut(len).ok_or(DecodeError::Framing)? = v;
            len += 1;
        }
        if len < 2 {
            return Err(DecodeError::Malformed);
        }
        let (payload, crc) = raw[..len].split_at(len - 2);
        if crc16(seq, marker, payload).to_be_bytes() != [crc[0], crc[1]] {
            return Err(DecodeError::Crc);
        }
        let mask = (marker >> 3) & 0x0F;
        let class = usize::from((marker >> 1) & 0x03);
        let accel_flag = marker & 1 != 0;
        let mut r = BitReader { buf: payload, bits: 0 };
        let ecode = r.get(2)?;
        let xcode = r.get(2)?;
        let block = if mask == 0 {
            if class > 1 || accel_flag || ecode != 0 || xcode != 0 {
                return Err(DecodeError::Malformed);
            }
            if class == 1 {
                let tenths = u16::try_from(r.get(12)?).map_err(|_| DecodeError::Malformed)?;
                if tenths > SERVO_TENTHS_MAX {
                    return Err(DecodeError::Malformed);
                }
                StepBlock::servo(tenths, r.get(24)?)
            } else {
                StepBlock::dwell(r.get(24)?)
            }
        } else {
            let width = WIDTHS[class];
            let mut steps = [0i32; NUM_AXES];
            for axis in Axis::ALL {
                if mask & (0x08 >> axis.index()) != 0 {
                    steps[axis.index()] = from_field(r.get(width)?, width);
                    if steps[axis.index()] == 0 {
                        return Err(DecodeError::Malformed);
                    }
                }
            }
            let cruise = rate_value(r.get(12)?);
            let mut rate = |code: u32| -> Result<u32, DecodeError> {
                match code {
                    0 => Ok(0),
                    1 => Ok(cruise),
                    2 => Ok(rate_value(r.get(12)?)),
                    _ => Err(DecodeError::Malformed),
                }
            };
            let entry = rate(ecode)?;
            let exit = rate(xcode)?;
            let accel = if accel_flag { r.get(24)? } else { self.last_accel };
            if cruise == 0 {
                return Err(DecodeError::Malformed);
            }
            StepBlock {
                steps,
                entry_rate: entry,
                cruise_rate: cruise,
                exit_rate: exit,
                accel,
                dwell_ticks: 0,
                servo: None,
            }
        };
        // Exactly the bytes the fields need, padding zero.
        if r.bits.div_ceil(8) != payload.len() || r.get(u32::try_from(payload.len() * 8 - r.bits).unwrap_or(8))? != 0 {
            return Err(DecodeError::Malformed);
        }
        if !block.is_dwell() {
            self.last_accel = block.accel;
        }
        Ok(block)
    }
}

/// One reply line from the firmware, parsed (host side).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reply<'a> {
    /// `ok`.
    Ok,
    /// `error:<code> <text>`.
    Error {
        /// Machine-readable code.
        code: u8,
        /// Human text.
        text: &'a str,
    },
    /// `rs <n>`.
    Resend(u32),
    /// `ALARM:<code> <text>`.
    Alarm {
        /// Machine-readable code.
        code: u8,
        /// Human text.
        text: &'a str,
    },
    /// The start banner (firmware started or was reset).
    Banner(&'a str),
    /// A status report `<...>` (without the brackets).
    Status(&'a str),
    /// `C:<count>`: a completion report (framed mode, see [`crate::report`]).
    Completed(u32),
    /// Any other line (M114/M115 reports).
    Info(&'a str),
}

impl<'a> Reply<'a> {
    /// Parse one reply line (without the line end).
    pub fn parse(line: &'a str) -> Reply<'a> {
        let coded = |rest: &'a str| {
            let (code, text) = rest.split_once(' ').unwrap_or((rest, ""));
            code.parse::<u8>().ok().map(|code| (code, text))
        };
        if line == "ok" {
            Reply::Ok
        } else if let Some((code, text)) = line.strip_prefix("error:").and_then(coded) {
            Reply::Error { code, text }
        } else if let Some((code, text)) = line.strip_prefix("ALARM:").and_then(coded) {
            Reply::Alarm { code, text }
        } else if let Some(n) = line.strip_prefix("rs ").and_then(|n| n.parse().ok()) {
            Reply::Resend(n)
        } else if let Some(n) = line.strip_prefix("C:").and_then(|n| n.parse().ok()) {
            Reply::Completed(n)
        } else if line.starts_with("plotter-fw ") {
            Reply::Banner(line)
        } else if let Some(s) = line.strip_prefix('<').and_then(|s| s.strip_suffix('>')) {
            Reply::Status(s)
        } else {
            Reply::Info(line)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gcode::xor_checksum;
    use proptest::prelude::*;

    fn enc(e: &mut Encoder, b: &StepBlock, seq: u32) -> std::vec::Vec<u8> {
        let mut out = [0u8; MAX_FRAME];
        let n = e.encode(b, seq, &mut out).unwrap();
        out[..n].to_vec()
    }

    #[test]
    fn typical_sizes() {
        let mut e = Encoder::new();
        let first = StepBlock {
            steps: [200, -120, 0, 0],
            entry_rate: 0,
            cruise_rate: 4800,
            exit_rate: 3000,
            accel: 120_000,
            dwell_ticks: 0,
            servo: None,
        };
        assert_eq!(enc(&mut e, &quantize(&first), 0).len(), 13, "9 payload bytes with the acceleration");
        let cruising = StepBlock {
            steps: [200, -120, 0, 0],
            entry_rate: 4800,
            cruise_rate: 4800,
            exit_rate: 4800,
            accel: 120_000,
            dwell_ticks: 0,
            servo: None,
        };
        let f = enc(&mut e, &cruising, 1);
        assert_eq!(f.len(), 9, "5 payload bytes, no escapes here");
        let curve = quantize(&StepBlock {
            steps: [-37, 250, 0, 0],
            entry_rate: 1234,
            cruise_rate: 4800,
            exit_rate: 2345,
            accel: 120_000,
            dwell_ticks: 0,
            servo: None,
        });
        let f = enc(&mut e, &curve, 2);
        assert_eq!(f.len(), 12, "8 payload bytes, no escapes here");
        let dwell = enc(&mut e, &StepBlock::dwell(50_000), 3);
        assert_eq!(dwell.len(), 8);
        // Marker, 5 payload bytes (4 + 12 + 24 bits), CRC, `\n`.
        let servo = enc(&mut e, &StepBlock::servo(900, 150_000), 4);
        assert_eq!((servo.len(), servo[0]), (9, 0x82));
        // 90.0° = 900 = 0x384 and 150 000 = 0x0249F0 after the four zero code bits: 0000 0011 1000 0100 0000 0010
        // 0100 1001 1111 0000.
        assert_eq!(servo[1..6], [0x03, 0x84, 0x02, 0x49, 0xF0]);
        assert_eq!(Decoder::new().decode(&servo[..8], 4), Ok(StepBlock::servo(900, 150_000)));
        let mut too_far = [0u8; MAX_FRAME];
        assert_eq!(e.encode(&StepBlock::servo(1801, 1), 5, &mut too_far), Err(EncodeError::Servo));
    }

    #[test]
    fn quantize_rounds_down_within_0_4_percent() {
        assert_eq!(quantize_rate(511), 511);
        assert_eq!(quantize_rate(4801), 4800);
        assert_eq!(quantize_rate(1_000_000), RATE_MAX);
        for r in 1..200_000u32 {
            let q = quantize_rate(r);
            assert!(q <= r && (r.min(RATE_MAX) - q) as f32 <= r.min(RATE_MAX) as f32 / 256.0, "{r}");
            assert_eq!(rate_value(rate_code(q).unwrap()), q);
        }
    }

    #[test]
    fn replies_parse() {
        assert_eq!(Reply::parse("ok"), Reply::Ok);
        assert_eq!(Reply::parse("rs 17"), Reply::Resend(17));
        assert_eq!(Reply::parse("error:3 unknown command G5"), Reply::Error { code: 3, text: "unknown command G5" });
        assert_eq!(Reply::parse("ALARM:1 hard limit"), Reply::Alarm { code: 1, text: "hard limit" });
        assert_eq!(Reply::parse("<Idle|Q:0/32>"), Reply::Status("Idle|Q:0/32"));
        assert!(matches!(Reply::parse("plotter-fw 0.1.0 proto 1"), Reply::Banner(_)));
        assert_eq!(Reply::parse("X:1.000"), Reply::Info("X:1.000"));
        assert_eq!(Reply::parse("C:4294967295"), Reply::Completed(u32::MAX));
        assert_eq!(Reply::parse("C:x"), Reply::Info("C:x"));
    }

    fn block() -> impl Strategy<Value = StepBlock> {
        let steps = proptest::array::uniform4(prop_oneof![Just(0i32), -40i32..40, -9_000_000i32..9_000_000]);
        let servo = prop_oneof![Just(None), (0u16..=1900).prop_map(Some)];
        (
            steps,
            0u32..70_000,
            1u32..70_000,
            0u32..70_000,
            prop_oneof![Just(0u32), 1u32..20_000_000],
            0u32..20_000_000,
            servo,
        )
            .prop_map(|(steps, e, c, x, a, d, servo)| StepBlock {
                steps,
                entry_rate: e,
                cruise_rate: c,
                exit_rate: x,
                accel: a,
                dwell_ticks: if steps == [0; 4] { d } else { 0 },
                servo: if steps == [0; 4] { servo } else { None },
            })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(500))]
        #[test]
        fn round_trip(blocks in proptest::collection::vec(block(), 1..8), seq0 in any::<u32>()) {
            let mut e = Encoder::new();
            let mut d = Decoder::new();
            for (i, b) in blocks.iter().enumerate() {
                let seq = seq0.wrapping_add(u32::try_from(i).unwrap());
                let q = quantize(b);
                let mut out = [0u8; MAX_FRAME];
                match e.encode(&q, seq, &mut out) {
                    Ok(n) => {
                        let frame = &out[..n];
                        prop_assert_eq!(frame[n - 1], b'\n');
                        prop_assert!(frame[..n - 1].iter().all(|&c| c != b'\n' && !is_realtime(c)));
                        prop_assert!(frame[0] >= 0x80);
                        prop_assert_eq!(d.decode(&frame[..n - 1], seq), Ok(q));
                    }
                    Err(err) => prop_assert!(matches!(err, EncodeError::Steps | EncodeError::Accel | EncodeError::Dwell | EncodeError::Servo), "{err:?}"),
                }
            }
        }

        /// Any single flipped or dropped byte, or the wrong sequence number, is detected.
        #[test]
        fn corruption_detected(b in block(), pos in any::<prop::sample::Index>(), flip in 1u8..=255, seq in any::<u32>()) {
            let mut e = Encoder::new();
            let q = quantize(&b);
            let mut out = [0u8; MAX_FRAME];
            let Ok(n) = e.encode(&q, seq, &mut out) else { return Ok(()) };
            let frame = &out[..n - 1];
            let i = pos.index(frame.len());
            let mut flipped = frame.to_vec();
            flipped[i] ^= flip;
            let mut d = Decoder::new();
            prop_assert!(d.decode(&flipped, seq).is_err());
            let mut dropped = frame.to_vec();
            dropped.remove(i);
            prop_assert!(d.decode(&dropped, seq).is_err());
            prop_assert!(d.decode(frame, seq.wrapping_add(1)).is_err());
            prop_assert!(d.decode(frame, seq.wrapping_sub(1)).is_err());
        }
    }

    #[test]
    fn checksums_match_published_values() {
        // CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF, unreflected, no final XOR): the catalogued check value of
        // "123456789" is 0x29B1. The CRC runs over E's four little-endian bytes, the marker and the payload.
        assert_eq!(crc16(u32::from_le_bytes(*b"1234"), b'5', b"6789"), 0x29B1);
        // Five zero bytes (E = 0, marker 0, no payload): 0x110C.
        assert_eq!(crc16(0, 0, &[]), 0x110C);
        // The RepRap wiki's numbered line `N3 T0*57`.
        assert_eq!(xor_checksum(b"N3 T0"), 57);
        assert_eq!(xor_checksum(b""), 0);
    }

    #[test]
    fn frames_are_the_documented_bytes() {
        let mut e = Encoder::new();
        // X 200, Y −120 (9-bit class: 200 needs 8 magnitude bits + sign), from rest to cruise 4800 = 300 << 4
        // (code 4·512 + 300 = 0x92C), a new acceleration 120 000 = 0x01D4C0.
        // Marker 1 1100 01 1 = 0xE3. Payload bits 00 01 011001000 110001000 100100101100 000000011101010011000000
        // (58 bits, 6 zero bits of padding) = 16 46 22 4B 00 75 30 00; CRC-16 (E = 0) 0xF6DB.
        let first = StepBlock {
            steps: [200, -120, 0, 0],
            entry_rate: 0,
            cruise_rate: 4800,
            exit_rate: 4800,
            accel: 120_000,
            dwell_ticks: 0,
            servo: None,
        };
        let f = enc(&mut e, &first, 0);
        assert_eq!(f, [0xE3, 0x16, 0x46, 0x22, 0x4B, 0x00, 0x75, 0x30, 0x00, 0xF6, 0xDB, b'\n']);
        // Z −5, E 3 (6-bit class), entering at 1000 = 500 << 1 (explicit: code 1·512 + 500 = 0x3F4), stopping, the
        // same acceleration (no field). Marker 1 0011 00 0 = 0x98; payload 10 00 111011 000011 100100101100
        // 001111110100 = 8E C3 92 C3 F4; CRC-16 (E = 1) 0x725F.
        let second = StepBlock { steps: [0, 0, -5, 3], entry_rate: 1000, exit_rate: 0, ..first };
        let f = enc(&mut e, &second, 1);
        assert_eq!(f, [0x98, 0x8E, 0xC3, 0x92, 0xC3, 0xF4, 0x72, 0x5F, b'\n']);
        assert_eq!(Decoder::new().decode(&f[..f.len() - 1], 1), Ok(StepBlock { accel: 0, ..second }));
        // A dwell of 0xA1B2 ticks: payload 0000 + 24 bits = 00 0A 1B 20, whose `\n` and ESC are escaped as
        // ESC 0x2A and ESC 0x3B; CRC-16 (E = 5) 0x7144.
        let f = enc(&mut e, &StepBlock::dwell(0xA1B2), 5);
        assert_eq!(f, [0x80, 0x00, 0x1B, 0x2A, 0x1B, 0x3B, 0x20, 0x71, 0x44, b'\n']);
        assert_eq!(Decoder::new().decode(&f[..f.len() - 1], 5), Ok(StepBlock::dwell(0xA1B2)));
        // A servo block at 3.3° (0x021) settling 0x7E183F ticks: payload 00 21 7E 18 3F holds the four real-time
        // bytes `!`, `~`, 0x18 and `?`, each escaped; CRC-16 (E = 9) 0x54C2.
        let f = enc(&mut e, &StepBlock::servo(0x21, 0x7E_183F), 9);
        assert_eq!(f, [0x82, 0x00, 0x1B, 0x01, 0x1B, 0x5E, 0x1B, 0x38, 0x1B, 0x1F, 0x54, 0xC2, b'\n']);
        assert_eq!(Decoder::new().decode(&f[..f.len() - 1], 9), Ok(StepBlock::servo(0x21, 0x7E_183F)));
    }

    #[test]
    fn step_width_classes_and_encode_errors() {
        let mv = |steps: [i32; NUM_AXES]| StepBlock {
            steps,
            entry_rate: 0,
            cruise_rate: 100,
            exit_rate: 0,
            accel: 0,
            dwell_ticks: 0,
            servo: None,
        };
        // Two's-complement widths 6/9/13/24: the class is bits 2..1 of the marker (X only: mask 1000).
        for (s, class) in [
            (31, 0u8),
            (-32, 0),
            (32, 1),
            (-33, 1),
            (255, 1),
            (-256, 1),
            (256, 2),
            (4095, 2),
            (-4096, 2),
            (4096, 3),
            ((1 << 23) - 1, 3),
            (-(1 << 23), 3),
        ] {
            let f = enc(&mut Encoder::new(), &mv([s, 0, 0, 0]), 0);
            assert_eq!(f[0], 0xC0 | (class << 1), "{s}");
            assert_eq!(Decoder::new().decode(&f[..f.len() - 1], 0), Ok(mv([s, 0, 0, 0])), "{s}");
        }
        let mut out = [0u8; MAX_FRAME];
        let mut e = Encoder::new();
        assert_eq!(e.encode(&mv([1 << 23, 0, 0, 0]), 0, &mut out), Err(EncodeError::Steps));
        assert_eq!(e.encode(&mv([0, 0, 0, -(1 << 23) - 1]), 0, &mut out), Err(EncodeError::Steps));
        assert_eq!(e.encode(&StepBlock { cruise_rate: 0, ..mv([1, 0, 0, 0]) }, 0, &mut out), Err(EncodeError::Rate));
        // 4801 is not representable (call quantize first), as cruise, entry or exit.
        assert_eq!(e.encode(&StepBlock { cruise_rate: 4801, ..mv([1, 0, 0, 0]) }, 0, &mut out), Err(EncodeError::Rate));
        let fast = StepBlock { cruise_rate: 9600, ..mv([1, 0, 0, 0]) };
        assert_eq!(e.encode(&StepBlock { entry_rate: 4801, ..fast }, 0, &mut out), Err(EncodeError::Rate));
        assert_eq!(e.encode(&StepBlock { exit_rate: 4801, ..fast }, 0, &mut out), Err(EncodeError::Rate));
        assert_eq!(e.encode(&StepBlock { accel: ACCEL_MAX + 1, ..fast }, 0, &mut out), Err(EncodeError::Accel));
        assert_eq!(e.encode(&StepBlock::dwell(DWELL_MAX + 1), 0, &mut out), Err(EncodeError::Dwell));
        assert_eq!(e.encode(&StepBlock::servo(SERVO_TENTHS_MAX + 1, 0), 0, &mut out), Err(EncodeError::Servo));
        assert_eq!(e.encode(&StepBlock::servo(SERVO_TENTHS_MAX, 0), 0, &mut out), Ok(9));
        // Refused blocks leave the encoder as it was: the next frame with acceleration 0 carries no field. Codes,
        // X = 1 in 6 bits and cruise 100 = 0x064: 0000 000001 000001100100 + 2 bits of padding = 00 41 90; its
        // CRC-16 (E = 0) 0x3FDE starts with `?`, which is escaped.
        let n = e.encode(&mv([1, 0, 0, 0]), 0, &mut out).unwrap();
        assert_eq!(out[..n], [0xC0, 0x00, 0x41, 0x90, ESC, 0x1F, 0xDE, b'\n']);
        // The largest values each field can carry go through.
        let top = StepBlock { entry_rate: RATE_MAX, cruise_rate: RATE_MAX, exit_rate: 512, accel: ACCEL_MAX, ..fast };
        let n = e.encode(&top, 3, &mut out).unwrap();
        assert_eq!(Decoder::new().decode(&out[..n - 1], 3), Ok(top));
        let n = e.encode(&StepBlock::dwell(DWELL_MAX), 4, &mut out).unwrap();
        assert_eq!(Decoder::new().decode(&out[..n - 1], 4), Ok(StepBlock::dwell(DWELL_MAX)));
    }

    /// A frame from raw payload bytes with a valid CRC (escaped as on the wire, without the `\n`).
    fn raw_frame(marker: u8, payload: &[u8], seq: u32) -> std::vec::Vec<u8> {
        let mut f = std::vec![marker];
        for &b in payload.iter().chain(&crc16(seq, marker, payload).to_be_bytes()) {
            if needs_escape(b) {
                f.extend([ESC, b ^ 0x20]);
            } else {
                f.push(b);
            }
        }
        f
    }

    #[test]
    fn decode_errors_name_the_fault() {
        let mut d = Decoder::new();
        assert_eq!(d.decode(&[], 0), Err(DecodeError::NotAFrame));
        assert_eq!(d.decode(b"G1 X1", 0), Err(DecodeError::NotAFrame));
        assert_eq!(d.decode(&[0x7F, 0, 0, 0], 0), Err(DecodeError::NotAFrame));
        // ESC as the last byte; 23 bytes after the marker (at most 20 payload + 2 CRC).
        assert_eq!(d.decode(&[0x80, 0x00, ESC], 0), Err(DecodeError::Framing));
        assert_eq!(d.decode(&[0x80; 24], 0), Err(DecodeError::Framing));
        // 22 bytes fit the buffer: then it is the CRC that fails.
        assert_eq!(d.decode(&[0x80; 23], 0), Err(DecodeError::Crc));
        // Only the two CRC bytes (an empty payload: the CRC is checked first, and fails), and fewer.
        assert_eq!(d.decode(&[0x80, 0x00, 0x00], 0), Err(DecodeError::Crc));
        assert_eq!(d.decode(&[0x80, 0x00], 0), Err(DecodeError::Malformed));
        assert_eq!(d.decode(&[0x80], 0), Err(DecodeError::Malformed));
        // A dwell of 16 ticks (payload 00 00 01 00) is fine; with the wrong E its CRC fails.
        assert_eq!(d.decode(&raw_frame(0x80, &[0, 0, 1, 0], 7), 7), Ok(StepBlock::dwell(16)));
        assert_eq!(d.decode(&raw_frame(0x80, &[0, 0, 1, 0], 7), 8), Err(DecodeError::Crc));
        // A dwell with rate codes, an acceleration flag or a step class above 1; too short; one byte too many;
        // non-zero padding; a servo angle above 180°.
        for (marker, payload) in [
            (0x80u8, &[0x40u8, 0, 1, 0][..]),
            (0x80, &[0x10, 0, 1, 0]),
            (0x81, &[0, 0, 1, 0]),
            (0x84, &[0, 0, 1, 0]),
            (0x86, &[0, 0, 1, 0]),
            (0x80, &[0, 0, 1]),
            (0x80, &[0, 0, 1, 0, 0]),
            (0x80, &[0, 0, 1, 1]),
            (0x82, &[0x07, 0x09, 0, 0, 1]),
        ] {
            assert_eq!(
                d.decode(&raw_frame(marker, payload, 0), 0),
                Err(DecodeError::Malformed),
                "{marker:x} {payload:?}"
            );
        }
        // 180.0° is the largest angle.
        assert_eq!(d.decode(&raw_frame(0x82, &[0x07, 0x08, 0, 0, 1], 0), 0), Ok(StepBlock::servo(1800, 1)));
        // A move (X only, 6-bit class, marker 0xC0): codes 0000, X 000001, cruise 0x064 (100), 2 bits of padding:
        // 00 41 90.
        let ok = [0x00u8, 0x41, 0x90];
        let block = StepBlock {
            steps: [1, 0, 0, 0],
            entry_rate: 0,
            cruise_rate: 100,
            exit_rate: 0,
            accel: 0,
            dwell_ticks: 0,
            servo: None,
        };
        assert_eq!(Decoder::new().decode(&raw_frame(0xC0, &ok, 0), 0), Ok(block));
        // Rate code 3; a zero step field for an axis in the mask; cruise 0.
        for payload in [[0xC0u8, 0x41, 0x90], [0x00, 0x01, 0x90], [0x00, 0x40, 0x00]] {
            assert_eq!(
                Decoder::new().decode(&raw_frame(0xC0, &payload, 0), 0),
                Err(DecodeError::Malformed),
                "{payload:?}"
            );
        }
    }

    #[test]
    fn decoder_keeps_the_acceleration_of_accepted_moves_only() {
        let mut e = Encoder::new();
        let mut d = Decoder::new();
        let mv = StepBlock {
            steps: [10, 0, 0, 0],
            entry_rate: 0,
            cruise_rate: 100,
            exit_rate: 0,
            accel: 5000,
            dwell_ticks: 0,
            servo: None,
        };
        let f = enc(&mut e, &mv, 0);
        // Rejected (wrong E): the acceleration is not taken.
        assert_eq!(d.decode(&f[..f.len() - 1], 1), Err(DecodeError::Crc));
        let again = enc(&mut Encoder::new(), &StepBlock { accel: 0, ..mv }, 0);
        assert_eq!(d.decode(&again[..again.len() - 1], 0), Ok(StepBlock { accel: 0, ..mv }));
        assert_eq!(d.decode(&f[..f.len() - 1], 0), Ok(mv));
        // A dwell in between does not reset it; the next move without the field reuses 5000.
        let dw = enc(&mut e, &StepBlock::dwell(10), 1);
        assert_eq!(d.decode(&dw[..dw.len() - 1], 1), Ok(StepBlock::dwell(10)));
        let next = enc(&mut e, &StepBlock { steps: [0, -3, 0, 0], ..mv }, 2);
        assert_eq!(next[0] & 1, 0, "no acceleration field");
        assert_eq!(d.decode(&next[..next.len() - 1], 2), Ok(StepBlock { steps: [0, -3, 0, 0], ..mv }));
    }

    #[test]
    fn quantize_and_rate_codes_by_hand() {
        // Exact below 512; 1023 = 0b11_1111_1111 keeps 9 bits: 1022; 4801 → 4800 (300 << 4); 65 535 → 65 408
        // (511 << 7); beyond the largest, the largest.
        assert_eq!(
            [0, 1, 512, 1023, 4801, 65_535, RATE_MAX, RATE_MAX + 1].map(quantize_rate),
            [0, 1, 512, 1022, 4800, 65_408, RATE_MAX, RATE_MAX]
        );
        assert_eq!(RATE_MAX, 65_408);
        assert_eq!(rate_code(511), Some(511));
        assert_eq!(rate_code(512), Some((1 << 9) | 256));
        assert_eq!(rate_code(4800), Some((4 << 9) | 300));
        assert_eq!(rate_code(RATE_MAX), Some((7 << 9) | 511));
        assert_eq!(rate_code(513), None);
        assert_eq!(rate_code(511 << 8), None);
        assert_eq!(rate_value((4 << 9) | 300), 4800);
        // A move: cruise at least 1, entry and exit capped at cruise and rounded down, acceleration capped.
        let b = StepBlock {
            steps: [5, 0, 0, 0],
            entry_rate: 9000,
            cruise_rate: 4801,
            exit_rate: 1023,
            accel: u32::MAX,
            dwell_ticks: 0,
            servo: None,
        };
        let q = quantize(&b);
        assert_eq!((q.entry_rate, q.cruise_rate, q.exit_rate, q.accel), (4800, 4800, 1022, ACCEL_MAX));
        let q = quantize(&StepBlock { cruise_rate: 0, entry_rate: 5, exit_rate: 0, ..b });
        assert_eq!((q.entry_rate, q.cruise_rate), (1, 1));
        // A dwell: ticks capped, the servo angle kept.
        assert_eq!(quantize(&StepBlock::dwell(u32::MAX)), StepBlock::dwell(DWELL_MAX));
        assert_eq!(quantize(&StepBlock::servo(450, u32::MAX)), StepBlock::servo(450, DWELL_MAX));
    }

    #[test]
    fn realtime_bytes_and_more_replies() {
        for b in 0..=255u8 {
            assert_eq!(is_realtime(b), [b'?', b'!', b'~', 0x18].contains(&b), "{b}");
            assert_eq!(needs_escape(b), [b'?', b'!', b'~', 0x18, b'\n', 0x1B].contains(&b), "{b}");
        }
        assert_eq!(Reply::parse("error:7"), Reply::Error { code: 7, text: "" });
        assert_eq!(Reply::parse("error:x bad"), Reply::Info("error:x bad"));
        assert_eq!(Reply::parse("ALARM:300 x"), Reply::Info("ALARM:300 x"));
        assert_eq!(Reply::parse("rs x"), Reply::Info("rs x"));
        assert_eq!(Reply::parse("<Idle"), Reply::Info("<Idle"));
        assert_eq!(Reply::parse("plotter-fwx"), Reply::Info("plotter-fwx"));
        assert_eq!(Reply::parse("ok "), Reply::Info("ok "));
    }

    #[test]
    fn the_longest_frame_fits_max_frame() {
        // The widest move: four axes of 24 bits, explicit entry and exit rates, a new acceleration:
        // 4 + 4·24 + 3·12 + 24 = 160 bits = 20 payload bytes, + 2 CRC bytes; all 22 escaped in the worst case,
        // plus the marker and `\n`: 1 + 2·22 + 1 = 46 bytes.
        assert_eq!(MAX_FRAME, 46);
        let widest = StepBlock {
            steps: [-(1 << 23), (1 << 23) - 1, 4096, -4097],
            entry_rate: 1000,
            cruise_rate: 4800,
            exit_rate: 2000,
            accel: 0xAB_CDEF,
            dwell_ticks: 0,
            servo: None,
        };
        let f = enc(&mut Encoder::new(), &widest, 3);
        let escaped = f.iter().filter(|&&b| b == ESC).count();
        assert_eq!(f.len(), 1 + 22 + escaped + 1);
        assert_eq!(Decoder::new().decode(&f[..f.len() - 1], 3), Ok(widest));
    }
}
