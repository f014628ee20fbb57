//! A device that babbles, for tests and `plotter sim --pty --babble`: after the host has sent a number of lines,
//! it either goes mute and sends a blank line every millisecond (a crashed board, a bootloader, line noise:
//! [`BabbleKind::Blank`]) or keeps answering but adds a line of its own every 20 ms (a wrong port, a GRBL that
//! auto-reports: [`BabbleKind::Chatter`]). Every wait of the host must end on its own deadline regardless: a
//! babbling device may never hold a command for ever.
//!
//! [`Babble`] is the behaviour on a clock; [`Babbling`] wraps any [`Transport`] with it (virtual time in unit
//! tests), and `plotter sim` applies it to the bytes its emulators write to the pty.

use std::io;
use std::time::Duration;

use super::Transport;

/// How the device babbles.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BabbleKind {
    /// Mute, but a blank line every millisecond.
    Blank,
    /// Answers as before, plus a line of noise every 20 ms.
    Chatter,
}

impl BabbleKind {
    /// Time between two babbled lines.
    fn period(self) -> Duration {
        match self {
            BabbleKind::Blank => Duration::from_millis(1),
            BabbleKind::Chatter => Duration::from_millis(20),
        }
    }
}

/// The babbling, starting after the host sent `after_lines` lines.
#[derive(Debug, Clone)]
pub struct Babble {
    kind: BabbleKind,
    after_lines: u64,
    seen_lines: u64,
    /// When the next babbled line is due (on the caller's clock), once babbling.
    next: Option<Duration>,
    /// Lines babbled so far.
    pub babbled: u64,
}

impl Babble {
    /// `kind`, from the host's `after_lines`-th line end on (0: at once).
    pub fn new(kind: BabbleKind, after_lines: u64) -> Babble {
        Babble { kind, after_lines, seen_lines: 0, next: None, babbled: 0 }
    }

    /// Read `blank@N`, `chatter@N`, `blank` or `chatter` (N host lines first, 0 when not given).
    pub fn parse(spec: &str) -> Result<Babble, String> {
        let (kind, at) = spec.split_once('@').unwrap_or((spec, "0"));
        let kind = match kind {
            "blank" => BabbleKind::Blank,
            "chatter" => BabbleKind::Chatter,
            _ => return Err(format!("{spec:?}: use blank[@N] or chatter[@N] (after N lines from the host)")),
        };
        let at = at.parse().map_err(|_| format!("{spec:?}: N must be a line count"))?;
        Ok(Babble::new(kind, at))
    }

    /// The host sent `bytes` (line ends, `\n` or `\r`, are counted).
    pub fn host_sent(&mut self, bytes: &[u8]) {
        let ends = bytes.iter().filter(|&&b| b == b'\n' || b == b'\r').count();
        self.seen_lines += u64::try_from(ends).unwrap_or(u64::MAX);
    }

    /// Whether the babbling has begun.
    pub fn active(&self) -> bool {
        self.seen_lines >= self.after_lines
    }

    /// Whether what the device itself says still reaches the host.
    pub fn passes_device(&self) -> bool {
        !self.active() || self.kind == BabbleKind::Chatter
    }

    /// How many babbled lines are due at `now` (at most 1000 at a time; none before the babbling begins): the
    /// first at once, then one per period.
    pub fn due(&mut self, now: Duration) -> usize {
        if !self.active() {
            return 0;
        }
        let period = self.kind.period();
        let next = *self.next.get_or_insert(now);
        if now < next {
            return 0;
        }
        let n = u32::try_from(((now - next).as_micros() / period.as_micros() + 1).min(1000)).unwrap_or(1000);
        self.next = Some(next + period * n);
        self.babbled += u64::from(n);
        usize::try_from(n).unwrap_or(1000)
    }

    /// One babbled line (without its line end).
    pub fn line(&self) -> &'static str {
        match self.kind {
            BabbleKind::Blank => "",
            BabbleKind::Chatter => "#%& line noise &%#",
        }
    }

    /// Apply to what the device wrote by `now`: its own bytes (unless mute) and the babbled lines due.
    pub fn filter(&mut self, device: Vec<u8>, now: Duration) -> Vec<u8> {
        let mut out = if self.passes_device() { device } else { Vec::new() };
        for _ in 0..self.due(now) {
            out.extend_from_slice(self.line().as_bytes());
            out.push(b'\n');
        }
        out
    }
}

/// A [`Transport`] whose device babbles (see the module docs).
#[derive(Debug)]
pub struct Babbling<T> {
    inner: T,
    babble: Babble,
    queued: usize,
}

impl<T: Transport> Babbling<T> {
    /// `inner`, babbling as `babble` says.
    pub fn new(inner: T, babble: Babble) -> Self {
        Babbling { inner, babble, queued: 0 }
    }

    /// The babble (how many lines so far).
    pub fn babble(&self) -> &Babble {
        &self.babble
    }

    /// The wrapped transport.
    pub fn inner(&self) -> &T {
        &self.inner
    }
}

impl<T: Transport> Transport for Babbling<T> {
    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.babble.host_sent(bytes);
        self.inner.send(bytes)
    }

    fn recv_line(&mut self, timeout: Duration) -> io::Result<Option<String>> {
        let end = self.inner.now() + timeout;
        loop {
            self.queued += self.babble.due(self.inner.now());
            if self.queued > 0 {
                self.queued -= 1;
                return Ok(Some(self.babble.line().to_string()));
            }
            let now = self.inner.now();
            if now >= end {
                return Ok(None);
            }
            // Read the device in slices no longer than the babble's period, so that its lines come on time.
            let slice = if self.babble.active() { Duration::from_millis(1) } else { end - now };
            match self.inner.recv_line(slice.min(end - now))? {
                Some(l) if self.babble.passes_device() => return Ok(Some(l)),
                // A clock that stood still (an idle simulator): nothing more will come, babble included.
                None if self.inner.now() == now => return Ok(None),
                _ => {}
            }
        }
    }

    fn now(&self) -> Duration {
        self.inner.now()
    }

    fn set_streaming(&mut self, active: bool) {
        self.inner.set_streaming(active);
    }

    fn underruns(&self) -> Option<u64> {
        self.inner.underruns()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: fn(u64) -> Duration = Duration::from_millis;

    #[test]
    fn blank_starts_after_n_host_lines_mutes_the_device_and_says_a_line_a_millisecond() {
        let mut b = Babble::parse("blank@2").unwrap();
        b.host_sent(b"V\r");
        assert!(!b.active());
        assert_eq!(b.filter(b"OK\r\n".to_vec(), MS(5)), b"OK\r\n");
        b.host_sent(b"QS\r");
        assert!(b.active() && !b.passes_device());
        // The first line is due at once, then one per millisecond.
        assert_eq!(b.filter(b"OK\r\n".to_vec(), MS(10)), b"\n");
        assert_eq!(b.filter(Vec::new(), MS(13)), b"\n\n\n");
        assert_eq!(b.babbled, 4);
    }

    #[test]
    fn chatter_keeps_the_answers_and_adds_a_line_every_20_ms() {
        let mut b = Babble::parse("chatter").unwrap();
        assert!(b.active() && b.passes_device());
        let out = b.filter(b"ok\n".to_vec(), MS(0));
        assert_eq!(out, b"ok\n#%& line noise &%#\n");
        assert_eq!(b.filter(Vec::new(), MS(19)), b"");
        assert_eq!(b.filter(Vec::new(), MS(40)), b"#%& line noise &%#\n#%& line noise &%#\n");
        assert!(Babble::parse("mumble@3").is_err());
        assert!(Babble::parse("blank@x").is_err());
    }
}
