//! Line input: the receive ring buffer filled by the serial interrupt, and the assembly of frames (lines).
//!
//! [`RxBuffer`] is a fixed ring of `N` bytes. When it is full the byte is dropped, but never silently: the loss
//! is counted and its position in the stream remembered, so the frame it belonged to is reported as damaged
//! when the main loop reaches it ([`LineAssembler`] yields [`Frame::Damaged`]). Lines are at most [`LINE_MAX`]
//! bytes (without `\n`); a longer line is discarded up to its `\n` and reported ([`Frame::TooLong`]).

/// Longest accepted line (bytes before `\n`). Step-block frames are at most [`crate::protocol::MAX_FRAME`].
pub const LINE_MAX: usize = 96;

/// Byte ring buffer with loss accounting.
#[derive(Debug)]
pub struct RxBuffer<const N: usize> {
    buf: [u8; N],
    head: usize,
    len: usize,
    /// Bytes pushed (accepted) since start.
    pushed: u64,
    /// Bytes popped since start.
    popped: u64,
    /// Stream index (in accepted bytes) after which bytes were lost, and how many.
    loss_at: Option<u64>,
    lost: u32,
}

impl<const N: usize> Default for RxBuffer<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> RxBuffer<N> {
    /// An empty buffer.
    pub const fn new() -> Self {
        RxBuffer { buf: [0; N], head: 0, len: 0, pushed: 0, popped: 0, loss_at: None, lost: 0 }
    }

    /// Capacity in bytes.
    pub const fn capacity(&self) -> usize {
        N
    }

    /// Bytes waiting.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Nothing waiting.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Append a byte; `false` (and the loss recorded) when full.
    pub fn push(&mut self, b: u8) -> bool {
        if self.len == N {
            if self.loss_at.is_none() {
                self.loss_at = Some(self.pushed);
            }
            self.lost = self.lost.saturating_add(1);
            return false;
        }
        self.buf[(self.head + self.len) % N] = b;
        self.len += 1;
        self.pushed += 1;
        true
    }

    /// Record a byte dropped by the caller (over the announced size although the ring had room).
    pub fn mark_loss(&mut self) {
        if self.loss_at.is_none() {
            self.loss_at = Some(self.pushed);
        }
        self.lost = self.lost.saturating_add(1);
    }

    /// Take the oldest byte. The second value is `true` when bytes were lost right after this one.
    pub fn pop(&mut self) -> Option<(u8, bool)> {
        if self.len == 0 {
            return None;
        }
        let b = self.buf[self.head];
        self.head = (self.head + 1) % N;
        self.len -= 1;
        self.popped += 1;
        let loss = self.loss_at == Some(self.popped);
        if loss {
            self.loss_at = None;
        }
        Some((b, loss))
    }

    /// Bytes lost since the last call (resets the count).
    pub fn take_lost(&mut self) -> u32 {
        core::mem::take(&mut self.lost)
    }

    /// Drop everything (reset).
    pub fn clear(&mut self) {
        self.head = 0;
        self.len = 0;
        self.loss_at = None;
        self.lost = 0;
    }
}

/// A completed frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Frame<'a> {
    /// A complete line without its `\n` (and without a trailing `\r` for text lines).
    Line(&'a [u8]),
    /// A line longer than [`LINE_MAX`]; the start is kept for sequencing decisions.
    TooLong(&'a [u8]),
    /// A line that lost bytes in a receive overflow (its start as received).
    Damaged(&'a [u8]),
}

/// Collects bytes into frames.
#[derive(Debug)]
pub struct LineAssembler {
    buf: [u8; LINE_MAX],
    len: usize,
    too_long: bool,
    damaged: bool,
}

impl Default for LineAssembler {
    fn default() -> Self {
        Self::new()
    }
}

impl LineAssembler {
    /// Empty.
    pub const fn new() -> Self {
        LineAssembler { buf: [0; LINE_MAX], len: 0, too_long: false, damaged: false }
    }

    /// Feed one byte; `lost_after` marks that bytes were lost after it. Returns a frame at each `\n`.
    pub fn feed(&mut self, b: u8, lost_after: bool) -> Option<Frame<'_>> {
        if b == b'\n' {
            let len = self.len;
            let (too_long, damaged) = (self.too_long, self.damaged);
            self.len = 0;
            self.too_long = false;
            self.damaged = lost_after;
            let mut line = &self.buf[..len];
            if damaged {
                return Some(Frame::Damaged(line));
            }
            if too_long {
                return Some(Frame::TooLong(line));
            }
            if line.first().is_some_and(|&c| c < 0x80)
                && let Some(stripped) = line.strip_suffix(b"\r")
            {
                line = stripped;
            }
            return Some(Frame::Line(line));
        }
        if self.len < LINE_MAX {
            self.buf[self.len] = b;
            self.len += 1;
        } else {
            self.too_long = true;
        }
        self.damaged |= lost_after;
        None
    }

    /// Drop the partial line (reset).
    pub fn clear(&mut self) {
        self.len = 0;
        self.too_long = false;
        self.damaged = false;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn feed_all(asm: &mut LineAssembler, bytes: &[u8]) -> std::vec::Vec<std::string::String> {
        let mut out = std::vec::Vec::new();
        for &b in bytes {
            if let Some(f) = asm.feed(b, false) {
                out.push(std::format!("{f:?}"));
            }
        }
        out
    }

    #[test]
    fn lines_and_cr() {
        let mut a = LineAssembler::new();
        let got = feed_all(&mut a, b"G1 X1\r\nM114\n\n");
        assert_eq!(got, ["Line([71, 49, 32, 88, 49])", "Line([77, 49, 49, 52])", "Line([])"]);
    }

    #[test]
    fn too_long_is_reported_once_and_next_line_is_fine() {
        let mut a = LineAssembler::new();
        let mut long = std::vec![b'G'; LINE_MAX + 10];
        long.push(b'\n');
        long.extend_from_slice(b"M2\n");
        let mut frames = std::vec::Vec::new();
        for &b in &long {
            if let Some(f) = a.feed(b, false) {
                frames.push(matches!(f, Frame::TooLong(_)));
            }
        }
        assert_eq!(frames, [true, false]);
    }

    #[test]
    fn ring_counts_and_wraps() {
        let mut rx = RxBuffer::<4>::new();
        assert_eq!((rx.capacity(), rx.len(), rx.is_empty()), (4, 0, true));
        assert_eq!(rx.pop(), None);
        assert!(rx.push(b'a') && rx.push(b'b') && rx.push(b'c'));
        assert_eq!((rx.len(), rx.is_empty()), (3, false));
        assert_eq!(rx.pop(), Some((b'a', false)));
        assert_eq!(rx.pop(), Some((b'b', false)));
        // Three more go round the end of the ring: d at index 3, e at 0, f at 1; then it is full.
        assert!(rx.push(b'd') && rx.push(b'e') && rx.push(b'f'));
        assert_eq!(rx.len(), 4);
        assert!(!rx.push(b'g'));
        let mut out = std::vec::Vec::new();
        while let Some((b, _)) = rx.pop() {
            out.push(b);
        }
        assert_eq!(out, b"cdef");
        assert_eq!((rx.len(), rx.is_empty(), rx.take_lost(), rx.take_lost()), (0, true, 1, 0));
    }

    #[test]
    fn a_byte_dropped_by_the_caller_damages_its_line() {
        let mut rx = RxBuffer::<8>::new();
        assert!(rx.push(b'A'));
        rx.mark_loss();
        rx.mark_loss();
        assert!(rx.push(b'\n'));
        assert_eq!(rx.take_lost(), 2);
        assert_eq!(rx.pop(), Some((b'A', true)), "the loss came right after A");
        assert_eq!(rx.pop(), Some((b'\n', false)));
        let mut a = LineAssembler::new();
        assert_eq!(a.feed(b'A', true), None);
        assert_eq!(a.feed(b'\n', false), Some(Frame::Damaged(b"A")));
    }

    #[test]
    fn clear_drops_bytes_and_losses() {
        let mut rx = RxBuffer::<2>::new();
        assert!(rx.push(b'x') && rx.push(b'y') && !rx.push(b'z'));
        rx.clear();
        assert_eq!((rx.len(), rx.is_empty(), rx.take_lost()), (0, true, 0));
        assert_eq!(rx.pop(), None);
        // The loss position is forgotten too: the next bytes come out clean.
        assert!(rx.push(b'1') && rx.push(b'2'));
        assert_eq!((rx.pop(), rx.pop()), (Some((b'1', false)), Some((b'2', false))));

        let mut a = LineAssembler::new();
        for &b in b"G1 X" {
            assert_eq!(a.feed(b, false), None);
        }
        a.clear();
        assert_eq!(feed_all(&mut a, b"M2\n"), ["Line([77, 50])"]);
        for _ in 0..=LINE_MAX {
            a.feed(b'G', false);
        }
        a.clear();
        assert_eq!(feed_all(&mut a, b"M2\n"), ["Line([77, 50])"], "too long forgotten");
        a.feed(b'G', true);
        a.clear();
        assert_eq!(feed_all(&mut a, b"\n"), ["Line([])"], "damage forgotten");
    }

    #[test]
    fn carriage_return_is_stripped_from_text_lines_only() {
        let mut a = LineAssembler::new();
        // 0x7F is the last text byte; a step-block frame starts at 0x80 and may end in 0x0D (a CRC byte).
        assert_eq!(feed_all(&mut a, b"\x7f\r\n"), ["Line([127])"]);
        assert_eq!(feed_all(&mut a, b"\x80\r\n"), ["Line([128, 13])"]);
        assert_eq!(feed_all(&mut a, b"\r\n"), ["Line([])"]);
        // The longest line fits; one byte more is too long.
        let mut line = std::vec![b'G'; LINE_MAX];
        line.push(b'\n');
        assert_eq!(feed_all(&mut a, &line), [std::format!("{:?}", Frame::Line(&line[..LINE_MAX]))]);
    }

    #[test]
    fn overflow_is_never_silent() {
        let mut rx = RxBuffer::<8>::new();
        let input = b"G1 X1\nG1 X2\n";
        let accepted = input.iter().filter(|&&b| rx.push(b)).count();
        assert_eq!(accepted, 8);
        assert_eq!(rx.take_lost(), 4);
        let mut a = LineAssembler::new();
        let mut frames = std::vec::Vec::new();
        while let Some((b, lost)) = rx.pop() {
            if let Some(f) = a.feed(b, lost) {
                frames.push(std::format!("{f:?}"));
            }
        }
        // "G1 X1" complete; "G1" then loss: the next \n (when it comes) ends a damaged frame.
        assert_eq!(frames, ["Line([71, 49, 32, 88, 49])"]);
        assert_eq!(a.feed(b'\n', false), Some(Frame::Damaged(b"G1")));
        assert_eq!(a.feed(b'\n', false), Some(Frame::Line(b"")));
    }
}
