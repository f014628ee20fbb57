//! Framed mode: the step-block stream's protection in the firmware → host direction and for real-time commands.
//! Encoder and decoder live here together and serve both sides of the wire.
//!
//! Plain G-code mode (the default after start or reset) is what consoles and third-party senders speak: plain
//! `ok`/`error:` replies and single real-time bytes, as in grbl. A host streaming step blocks switches to *framed
//! mode* with the checked line `N<n> M990 S1*<cs>`, and back with `M990 S0` (or any reset). In framed mode:
//!
//! # Framed replies
//! Every reply line is `<text> #<n> <crc>`: `<text>` is the plain reply (`ok`, `error:…`, `rs <E>`, the status
//! report `<…>`, `ALARM:…`), `<n>` a sequence number in decimal and `<crc>` eight lowercase hex digits, the
//! CRC-32 (IEEE 802.3, as in zlib) of the bytes `<text> #<n>`. The number says what the line is about:
//! - `ok` and `error:`: the sequence number of the frame (or numbered line) it answers;
//! - `rs <E>`, status reports and alarms: the expected number `E` at the time of the reply.
//!
//! So an `ok` names the frame it accepts, and a lost `ok` costs nothing (the next one says as much). A host acts on
//! a line only when its CRC verifies ([`parse_reply`]); a damaged line is dropped, and a damaged status report is
//! asked for again. Line noise thus never moves the host's idea of the position or progress: with CRC-32 an
//! undetected corruption needs about 4·10⁹ damaged lines. Also in framed mode, any received line that is not a
//! valid sequenced frame or numbered line — plain G-code included — is answered `rs <E>` (it can only be a
//! damaged frame), never executed.
//!
//! # Real-time commands
//! A single real-time byte (`?`, `!`, `~`, Ctrl-X) is what one flipped bit can make out of a frame byte, so in framed
//! mode a real-time command is the four-byte sequence `c, !c, c, !c` ([`rt_sequence`]): noise would have to forge
//! four exact bytes in a row. A lone real-time byte is data there (a frame byte damaged into it: the frame then
//! fails its CRC and is resent). The bytes of a started sequence are held back until it completes or breaks; a
//! broken sequence releases its bytes as data. The one escape hatch for a console that finds a firmware left in
//! framed mode: three plain Ctrl-X bytes in a row reset it (a framed reset is `0x18, 0xE7, 0x18, 0xE7`, never
//! three 0x18 in a row).

use core::fmt;

use crate::protocol::{RT_RESET, is_realtime};

/// The M code that switches framed mode (`S1` on, `S0` off).
pub const M_FRAMED: u16 = 990;

/// The four bytes of the framed real-time command `cmd`.
pub const fn rt_sequence(cmd: u8) -> [u8; 4] {
    [cmd, !cmd, cmd, !cmd]
}

/// CRC-32 (IEEE 802.3, reflected polynomial 0xEDB88320), incremental.
#[derive(Debug, Clone, Copy)]
pub struct Crc32(u32);

impl Default for Crc32 {
    fn default() -> Self {
        Crc32(0xFFFF_FFFF)
    }
}

impl Crc32 {
    /// Feed bytes.
    pub fn update(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 ^= u32::from(b);
            for _ in 0..8 {
                self.0 = if self.0 & 1 != 0 { (self.0 >> 1) ^ 0xEDB8_8320 } else { self.0 >> 1 };
            }
        }
    }

    /// The checksum of everything fed.
    pub fn finish(self) -> u32 {
        !self.0
    }
}

/// Writes through to `out` while computing the CRC of what was written.
pub struct CrcWriter<W: fmt::Write> {
    /// Destination.
    pub out: W,
    /// CRC so far.
    pub crc: Crc32,
}

impl<W: fmt::Write> fmt::Write for CrcWriter<W> {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        self.crc.update(s.as_bytes());
        self.out.write_str(s)
    }
}

/// Write one framed reply line (`\n` included) with text `text` and number `n` to `out`.
pub fn write_reply<W: fmt::Write>(out: W, n: u32, text: fmt::Arguments<'_>) -> fmt::Result {
    let mut w = CrcWriter { out, crc: Crc32::default() };
    fmt::Write::write_fmt(&mut w, text)?;
    fmt::Write::write_fmt(&mut w, format_args!(" #{n}"))?;
    let crc = w.crc.finish();
    fmt::Write::write_fmt(&mut w.out, format_args!(" {crc:08x}\n"))
}

/// Host side: the number and text of a framed reply line (without its line end), when its CRC verifies.
pub fn parse_reply(line: &str) -> Option<(u32, &str)> {
    let (body, crc) = line.rsplit_once(' ')?;
    if crc.len() != 8 || !crc.bytes().all(|c| c.is_ascii_digit() || (b'a'..=b'f').contains(&c)) {
        return None;
    }
    let crc = u32::from_str_radix(crc, 16).ok()?;
    let mut c = Crc32::default();
    c.update(body.as_bytes());
    if c.finish() != crc {
        return None;
    }
    let (text, n) = body.rsplit_once(" #")?;
    Some((n.parse().ok()?, text))
}

/// Firmware side: picks framed real-time commands out of the received bytes (see the module docs).
#[derive(Debug, Clone, Default)]
pub struct RtMatcher {
    held: [u8; 3],
    len: usize,
    resets_in_row: u8,
}

impl RtMatcher {
    /// A matcher with nothing held.
    pub const fn new() -> Self {
        RtMatcher { held: [0; 3], len: 0, resets_in_row: 0 }
    }

    /// Take one received byte. Bytes that turn out to be data are passed to `data` (in order); a completed
    /// real-time command is returned.
    pub fn feed(&mut self, b: u8, mut data: impl FnMut(u8)) -> Option<u8> {
        self.resets_in_row = if b == RT_RESET { self.resets_in_row.saturating_add(1) } else { 0 };
        if self.resets_in_row >= 3 {
            self.resets_in_row = 0;
            self.len = 0;
            return Some(RT_RESET);
        }
        if self.len > 0 {
            let first = self.held[0];
            let expected = if self.len % 2 == 1 { !first } else { first };
            if b == expected {
                if self.len == 3 {
                    self.len = 0;
                    return Some(first);
                }
                self.held[self.len] = b;
                self.len += 1;
                return None;
            }
            // Broken: what was held is data.
            for &h in &self.held[..self.len] {
                data(h);
            }
            self.len = 0;
        }
        if is_realtime(b) {
            self.held[0] = b;
            self.len = 1;
        } else {
            data(b);
        }
        None
    }

    /// Forget held bytes (reset).
    pub fn clear(&mut self) {
        *self = RtMatcher::new();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::protocol::{RT_FEED_HOLD, RT_STATUS};
    use proptest::prelude::*;
    use std::string::String;
    use std::vec::Vec;

    #[test]
    fn crc32_check_value() {
        // The standard check value of CRC-32/ISO-HDLC.
        let mut c = Crc32::default();
        c.update(b"123456789");
        assert_eq!(c.finish(), 0xCBF4_3926);
    }

    #[test]
    fn replies_round_trip_and_damage_is_refused() {
        let mut s = String::new();
        write_reply(&mut s, 17, format_args!("ok")).unwrap();
        assert!(s.starts_with("ok #17 ") && s.ends_with('\n') && s.len() == "ok #17 ".len() + 9, "{s}");
        let line = s.trim_end();
        assert_eq!(parse_reply(line), Some((17, "ok")));
        let mut st = String::new();
        write_reply(&mut st, 5, format_args!("<Run|MPos:1.000,0.000,4.000,0.000|Steps:80,0,1600,0|Q:3/32|N:5|C:2>"))
            .unwrap();
        assert_eq!(
            parse_reply(st.trim_end()).unwrap().1,
            "<Run|MPos:1.000,0.000,4.000,0.000|Steps:80,0,1600,0|Q:3/32|N:5|C:2>"
        );
        // The digit flip: Steps:0 → Steps:8 is refused.
        let flipped = st.trim_end().replacen("Steps:80", "Steps:88", 1);
        assert_eq!(parse_reply(&flipped), None);
        assert_eq!(parse_reply("ok"), None, "plain replies are not framed");
        assert_eq!(parse_reply("ok #17 CBF43926"), None, "uppercase hex is not ours");
    }

    #[test]
    fn crc_digits_are_exactly_eight_lowercase() {
        // Values from an independent CRC-32 (Python's `zlib.crc32`): b"ok #17" → 0x425baf4a, b"ok #3" → 0x08533714.
        let mut s = String::new();
        write_reply(&mut s, 17, format_args!("ok")).unwrap();
        assert_eq!(s, "ok #17 425baf4a\n");
        s.clear();
        write_reply(&mut s, 3, format_args!("ok")).unwrap();
        assert_eq!(s, "ok #3 08533714\n", "leading zeros are written");
        assert_eq!(parse_reply("ok #17 425baf4a"), Some((17, "ok")));
        assert_eq!(parse_reply("ok #3 08533714"), Some((3, "ok")));
        // The right value in another spelling is not a framed line: uppercase, a ninth digit, a dropped zero.
        assert_eq!(parse_reply("ok #17 425BAF4A"), None);
        assert_eq!(parse_reply("ok #17 0425baf4a"), None);
        assert_eq!(parse_reply("ok #3 8533714"), None);
        // A verified CRC over a body without ` #<n>` is still refused: b"123456789" → 0xcbf43926 (the check value).
        assert_eq!(parse_reply("123456789 cbf43926"), None);
    }

    fn run(m: &mut RtMatcher, bytes: &[u8]) -> (Vec<u8>, Vec<u8>) {
        let (mut data, mut cmds) = (Vec::new(), Vec::new());
        for &b in bytes {
            if let Some(c) = m.feed(b, |d| data.push(d)) {
                cmds.push(c);
            }
        }
        (data, cmds)
    }

    #[test]
    fn sequences_act_and_lone_bytes_are_data() {
        let mut m = RtMatcher::new();
        let mut input = b"ab".to_vec();
        input.extend(rt_sequence(RT_FEED_HOLD));
        input.extend(b"c!d?");
        input.extend(&rt_sequence(RT_STATUS)[..3]);
        input.push(b'e');
        let (data, cmds) = run(&mut m, &input);
        assert_eq!(cmds, [RT_FEED_HOLD]);
        let mut want = b"abc!d?".to_vec();
        want.extend(&rt_sequence(RT_STATUS)[..3]);
        want.push(b'e');
        assert_eq!(data, want, "a broken sequence is released as data, in order");
        // Three plain Ctrl-X in a row: the console's escape hatch.
        let (_, cmds) = run(&mut m, &[0x18, 0x18, 0x18]);
        assert_eq!(cmds, [RT_RESET]);
        let (_, cmds) = run(&mut m, &rt_sequence(RT_RESET));
        assert_eq!(cmds, [RT_RESET]);
    }

    #[test]
    fn only_realtime_bytes_are_held_back() {
        let mut m = RtMatcher::new();
        // A data byte is released at once, also the zero byte (the held buffer's initial contents) and 0xE7 (!0x18).
        for b in [0x00, b'a', 0xE7, 0xFF] {
            let mut got = Vec::new();
            assert_eq!(m.feed(b, |d| got.push(d)), None);
            assert_eq!(got, [b], "{b:#x}");
        }
        // A completed sequence leaves nothing held: the next byte equal to its first is a new start, held.
        let (data, cmds) = run(&mut m, &rt_sequence(RT_STATUS));
        assert_eq!((data.len(), cmds), (0, std::vec![RT_STATUS]));
        let (data, cmds) = run(&mut m, &[RT_STATUS]);
        assert_eq!((data.len(), cmds.len()), (0, 0));
        let (data, _) = run(&mut m, b"x");
        assert_eq!(data, [RT_STATUS, b'x']);
    }

    #[test]
    fn clear_forgets_held_bytes_and_resets_in_a_row() {
        let mut m = RtMatcher::new();
        let (data, _) = run(&mut m, &[RT_FEED_HOLD, !RT_FEED_HOLD]);
        assert!(data.is_empty(), "two bytes of a sequence held");
        m.clear();
        assert_eq!(run(&mut m, b"a"), (b"a".to_vec(), Vec::new()), "nothing held is released after clear");
        let _ = run(&mut m, &[RT_RESET, RT_RESET]);
        m.clear();
        // Two Ctrl-X, clear, one Ctrl-X: not three in a row.
        let (_, cmds) = run(&mut m, &[RT_RESET]);
        assert!(cmds.is_empty());
    }

    proptest! {
        /// Data bytes pass through unchanged and in order whatever real-time sequences are interleaved, as long
        /// as the data holds no real-time byte (frames escape them).
        #[test]
        fn data_passes_through(chunks in proptest::collection::vec((proptest::collection::vec(any::<u8>().prop_filter("rt", |b| !is_realtime(*b)), 0..20), proptest::option::of(prop_oneof![Just(RT_STATUS), Just(RT_FEED_HOLD), Just(b'~'), Just(RT_RESET)])), 0..10)) {
            let mut m = RtMatcher::new();
            let (mut want_data, mut want_cmds, mut input) = (Vec::<u8>::new(), Vec::new(), Vec::new());
            for (d, c) in &chunks {
                want_data.extend(d);
                input.extend(d);
                if let Some(c) = c {
                    want_cmds.push(*c);
                    input.extend(rt_sequence(*c));
                }
            }
            let (data, cmds) = run(&mut m, &input);
            prop_assert_eq!(data, want_data);
            prop_assert_eq!(cmds, want_cmds);
        }
    }
}
