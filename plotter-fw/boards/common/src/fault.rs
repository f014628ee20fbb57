//! The reason the previous run stopped, kept across the reset in no-init RAM.
//!
//! A board places one [`FaultRecord`] in a RAM section the start-up code neither zeroes nor initialises
//! (cortex-m-rt's `.uninit`). The panic and hard-fault handlers [`FaultRecord::store`] a one-line reason before
//! resetting; at the next start [`FaultRecord::take`] returns it once (for the start-up note, [`crate::note`]) and
//! clears it. After a power cycle the RAM holds garbage: the record is only believed when its magic number and
//! the checksum over its text agree, so a stale or random record reads as "no fault".
//!
//! Both methods go through raw pointers with volatile accesses: the memory may never have been written by Rust,
//! and the handlers run in contexts where nothing else may be trusted.

use core::fmt;
use core::ptr::{addr_of, addr_of_mut};

/// Longest stored reason, bytes (longer ones are cut).
pub const FAULT_TEXT: usize = 120;

const MAGIC: u32 = 0x504C_4F54; // "PLOT"

/// The stored reason. Lives in no-init RAM; see the module docs.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FaultRecord {
    magic: u32,
    len: u32,
    check: u32,
    text: [u8; FAULT_TEXT],
}

/// FNV-1a over the length and the text.
fn checksum(len: u32, text: &[u8]) -> u32 {
    let mut h: u32 = 0x811C_9DC5;
    for b in len.to_le_bytes().iter().chain(text) {
        h ^= u32::from(*b);
        h = h.wrapping_mul(0x0100_0193);
    }
    h
}

/// Formats into a fixed buffer, cutting what does not fit and flattening control characters to spaces (the
/// reason is printed as one line). Never fails.
struct Cut<'a> {
    buf: &'a mut [u8; FAULT_TEXT],
    len: usize,
}

impl fmt::Write for Cut<'_> {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        for &b in s.as_bytes() {
            if self.len == FAULT_TEXT {
                break;
            }
            self.buf[self.len] = if b.is_ascii_graphic() || b == b' ' { b } else { b' ' };
            self.len += 1;
        }
        Ok(())
    }
}

impl FaultRecord {
    /// An empty record (for tests; a board never initialises its no-init copy).
    pub const fn empty() -> Self {
        FaultRecord { magic: 0, len: 0, check: 0, text: [0; FAULT_TEXT] }
    }

    /// Store `reason` (cut to [`FAULT_TEXT`] bytes) in the record at `rec`.
    ///
    /// # Safety
    /// `rec` must point to a `FaultRecord`-sized, aligned, writable memory area that nothing else accesses
    /// meanwhile (the handlers run with interrupts masked).
    pub unsafe fn store(rec: *mut FaultRecord, reason: fmt::Arguments<'_>) {
        let mut text = [0u8; FAULT_TEXT];
        let mut w = Cut { buf: &mut text, len: 0 };
        let _ = fmt::write(&mut w, reason);
        let len = w.len;
        let len32 = u32::try_from(len).unwrap_or(0);
        // SAFETY: the caller guarantees `rec` is valid for writes; fields are plain integers.
        unsafe {
            addr_of_mut!((*rec).magic).write_volatile(0);
            addr_of_mut!((*rec).text).write_volatile(text);
            addr_of_mut!((*rec).len).write_volatile(len32);
            addr_of_mut!((*rec).check).write_volatile(checksum(len32, &text[..len]));
            addr_of_mut!((*rec).magic).write_volatile(MAGIC);
        }
    }

    /// Store a panic's location and plain-text message in the record at `rec`. The message's arguments are not
    /// formatted: that would link every `Debug` impl a panic message can name (float formatting among them,
    /// about 10 KiB of flash).
    ///
    /// # Safety
    /// As for [`FaultRecord::store`].
    pub unsafe fn store_panic(rec: *mut FaultRecord, info: &core::panic::PanicInfo<'_>) {
        let (file, line) = info.location().map_or(("?", 0), |l| (l.file(), l.line()));
        let message = info.message().as_str().unwrap_or("(formatted message)");
        // SAFETY: forwarded from the caller.
        unsafe { FaultRecord::store(rec, format_args!("panic at {file}:{line}: {message}")) };
    }

    /// Take the stored reason, if a valid one is there, and clear the record.
    ///
    /// # Safety
    /// As for [`FaultRecord::store`]; the memory may hold any bit pattern (every one is a valid `FaultRecord`).
    pub unsafe fn take(rec: *mut FaultRecord) -> Option<heapless::String<FAULT_TEXT>> {
        // SAFETY: the caller guarantees `rec` is valid; all bit patterns are valid integers.
        let (magic, len, check, text) = unsafe {
            (
                addr_of!((*rec).magic).read_volatile(),
                addr_of!((*rec).len).read_volatile(),
                addr_of!((*rec).check).read_volatile(),
                addr_of!((*rec).text).read_volatile(),
            )
        };
        // SAFETY: as above.
        unsafe { addr_of_mut!((*rec).magic).write_volatile(0) };
        let n = usize::try_from(len).ok().filter(|&n| n <= FAULT_TEXT)?;
        if magic != MAGIC || checksum(len, &text[..n]) != check {
            return None;
        }
        let s = core::str::from_utf8(&text[..n]).ok()?;
        heapless::String::try_from(s).ok()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn take(r: &mut FaultRecord) -> Option<std::string::String> {
        // SAFETY: a local record.
        unsafe { FaultRecord::take(r) }.map(|s| s.as_str().into())
    }

    #[test]
    fn a_stored_reason_is_read_once() {
        let mut r = FaultRecord::empty();
        // SAFETY: a local record.
        unsafe { FaultRecord::store(&mut r, format_args!("panic at {}:{}", "src/main.rs", 42)) };
        assert_eq!(take(&mut r).as_deref(), Some("panic at src/main.rs:42"));
        assert_eq!(take(&mut r), None);
    }

    #[test]
    fn garbage_ram_is_no_fault() {
        // What RAM holds after power-up: arbitrary bytes, sometimes even the right magic.
        let mut r = FaultRecord { magic: 0x1234_5678, len: 7, check: 99, text: [0xA5; FAULT_TEXT] };
        assert_eq!(take(&mut r), None);
        let mut r = FaultRecord { magic: MAGIC, len: 5000, check: 0, text: [b'x'; FAULT_TEXT] };
        assert_eq!(take(&mut r), None);
        let mut r = FaultRecord { magic: MAGIC, len: 3, check: 0, text: [b'x'; FAULT_TEXT] };
        assert_eq!(take(&mut r), None);
    }

    #[test]
    fn a_damaged_text_is_rejected() {
        let mut r = FaultRecord::empty();
        // SAFETY: a local record.
        unsafe { FaultRecord::store(&mut r, format_args!("hard fault")) };
        r.text[2] ^= 1;
        assert_eq!(take(&mut r), None);
    }

    #[test]
    fn long_reasons_are_cut_and_flattened_to_one_line() {
        let mut r = FaultRecord::empty();
        let long = "x".repeat(300);
        // SAFETY: a local record.
        unsafe { FaultRecord::store(&mut r, format_args!("a\nb\t{long}")) };
        let s = take(&mut r).unwrap();
        assert_eq!(s.len(), FAULT_TEXT);
        assert!(s.starts_with("a b xxx"));
    }
}
