//! Completion reports: in framed mode the firmware tells the host, unasked, how many blocks it has completed, so
//! the host's resume journal can follow execution to the very last block.
//!
//! The report is the framed line `C:<count> #<E> <crc>` ([`crate::framing`]): `<count>` is the stepper's
//! completed-block count since start or the last reset (the same figure as the status report's `C:`), `<E>` the
//! expected sequence number at the time of the report (so the host knows which frames the count can refer to).
//!
//! When to send: a status poll at a fixed period leaves the host up to a whole period behind, which after a power
//! loss means redrawing every block completed in that period. Reports sent as blocks complete leave it behind by
//! one line's transmission time only. To keep the link free for acknowledgements while many tiny blocks complete
//! in a burst, reports are at least [`MIN_INTERVAL_TICKS`] (5 ms) apart; a completion inside that interval is
//! reported when it ends, folded into one report with any later ones. The report that says the queue has run dry
//! (the last block of a plot, or an underrun) goes out at once: after it nothing else would prompt one.
//!
//! Plain G-code mode never sends them: consoles and GRBL-style senders would not know the line.

use crate::step_block::TICK_HZ;

/// Smallest gap between two completion reports, timer ticks (5 ms).
pub const MIN_INTERVAL_TICKS: u64 = TICK_HZ as u64 / 200;

/// Decides when a completion report is due (the caller writes it).
#[derive(Debug, Clone, Copy, Default)]
pub struct CompletionReporter {
    /// The count in the last report sent.
    sent: u32,
    /// When it was sent, ticks (`None` before the first report).
    sent_at: Option<u64>,
}

impl CompletionReporter {
    /// Nothing reported yet; the count stands at `completed`.
    pub const fn new(completed: u32) -> Self {
        CompletionReporter { sent: completed, sent_at: None }
    }

    /// Forget what was sent (reset, framed mode switched on): the count now stands at `completed`.
    pub fn restart(&mut self, completed: u32) {
        *self = CompletionReporter::new(completed);
    }

    /// Whether a report of `completed` is due at `now`; `drained` = nothing left to run (queue and stepper empty).
    pub fn due(&self, completed: u32, now: u64, drained: bool) -> bool {
        completed != self.sent && (drained || self.sent_at.is_none_or(|t| now.saturating_sub(t) >= MIN_INTERVAL_TICKS))
    }

    /// A report of `completed` was sent at `now`.
    pub fn sent(&mut self, completed: u32, now: u64) {
        self.sent = completed;
        self.sent_at = Some(now);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reports_are_five_ms_apart_except_the_last() {
        let mut r = CompletionReporter::new(7);
        assert!(!r.due(7, 0, false), "nothing completed");
        assert!(r.due(8, 100, false), "the first completion at once");
        r.sent(8, 100);
        // 4.999 ms later: held back; 5 ms later: due.
        assert!(!r.due(9, 5_099, false));
        assert!(r.due(9, 5_100, false));
        // Queue drained: at once, whatever the gap.
        assert!(r.due(9, 101, true));
        r.sent(9, 101);
        assert!(!r.due(9, 20_000, true), "the same count is never sent twice");
        // The count wraps like the stepper's.
        let mut r = CompletionReporter::new(u32::MAX);
        assert!(r.due(0, 0, false));
        r.restart(0);
        assert!(!r.due(0, 0, true));
    }
}
