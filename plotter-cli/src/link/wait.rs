//! A wait on a device, bounded three ways: an overall deadline derived from the work waited for (not only a quiet
//! gap: a board that babbles blank lines must not hold us for ever), a word to the user when it takes long (what
//! it waits for, how long it may still take), and the stop flag ([`crate::stop`]) checked between reads.
//!
//! A dialect reads in slices: `let left = wait.next(transport.now(), slice)?;` before each read, with `left` as
//! the read's timeout. The waits of a stop itself (the dialect's stop command and the pen-up) are made without
//! [`Wait::interruptible`]: a second signal must not cut the lift short.

use std::time::Duration;

pub use crate::stop::WaitError;
use crate::stop::{Stop, StopCause, Stopped};

/// After how long a wait tells the user what it waits for.
pub const NOTICE_AFTER: Duration = Duration::from_secs(5);

/// Where waits tell the user what they wait for (the standard error unless a front end set its own).
static NOTICE: std::sync::OnceLock<fn(&str)> = std::sync::OnceLock::new();

/// Send the notices of long waits to `sink` instead of the standard error (once per process; the web app routes
/// them to its event log).
pub fn set_notice_sink(sink: fn(&str)) {
    let _ = NOTICE.set(sink);
}

fn notice(text: &str) {
    match NOTICE.get() {
        Some(sink) => sink(text),
        None => eprintln!("{text}"),
    }
}

/// One bounded wait (see the module docs).
#[derive(Debug)]
pub struct Wait {
    name: String,
    what: String,
    started: Duration,
    limit: Duration,
    stop: Option<Stop>,
    any_interrupt: bool,
    told: bool,
}

impl Wait {
    /// A wait of at most `limit` (from `now`, the transport's clock) on device `name` for `what` ("the answer to
    /// QG", "room in the plotter's buffer"). Not interruptible: see [`Wait::interruptible`].
    pub fn new(name: &str, what: impl Into<String>, now: Duration, limit: Duration) -> Wait {
        Wait {
            name: name.to_string(),
            what: what.into(),
            started: now,
            limit,
            stop: None,
            any_interrupt: false,
            told: false,
        }
    }

    /// End the wait when the process is asked to stop (a termination signal, a second Ctrl-C).
    pub fn interruptible(self) -> Wait {
        self.interruptible_by(Stop::process())
    }

    /// End the wait when `stop` is raised.
    pub fn interruptible_by(mut self, stop: &Stop) -> Wait {
        self.stop = Some(stop.clone());
        self
    }

    /// A single Ctrl-C ends it too: a wait that cannot pause (connecting, homing, a drain outside a plot, a
    /// plotter that withholds buffer space).
    pub fn on_any_interrupt(mut self) -> Wait {
        self.any_interrupt = true;
        self
    }

    /// How long the next read may wait (at most `slice`, at least 1 ms), or why the wait is over: the deadline
    /// passed or a stop was asked. Tells the user what it waits for once it has taken [`NOTICE_AFTER`].
    pub fn next(&mut self, now: Duration, slice: Duration) -> Result<Duration, WaitError> {
        if let Some(stop) = &self.stop {
            let cause: Option<StopCause> =
                if self.any_interrupt { stop.stop_cause_or_interrupt() } else { stop.stop_cause() };
            if let Some(cause) = cause {
                return Err(Stopped { cause, doing: format!("waiting for {} from {}", self.what, self.name) }.into());
            }
        }
        let spent = now.saturating_sub(self.started);
        if spent >= self.limit {
            return Err(WaitError::TimedOut { name: self.name.clone(), what: self.what.clone(), limit: self.limit });
        }
        if spent >= NOTICE_AFTER && !self.told && self.limit > NOTICE_AFTER {
            self.told = true;
            let how = if self.stop.is_some() { "; Ctrl-C stops" } else { "" };
            notice(&format!(
                "{}: waiting for {} ({:.0} s so far, at most {:.0} s{how})",
                self.name,
                self.what,
                spent.as_secs_f64(),
                self.limit.as_secs_f64()
            ));
        }
        Ok((self.limit - spent).min(slice).max(Duration::from_millis(1)))
    }

    /// Time since the wait began.
    pub fn elapsed(&self, now: Duration) -> Duration {
        now.saturating_sub(self.started)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: fn(u64) -> Duration = Duration::from_millis;

    #[test]
    fn a_wait_gives_slices_until_its_deadline_whatever_arrives_meanwhile() {
        let mut w = Wait::new("/dev/pts/3", "the answer to QG", MS(1000), MS(3000));
        assert_eq!(w.next(MS(1000), MS(100)).unwrap(), MS(100));
        assert_eq!(w.next(MS(3950), MS(100)).unwrap(), MS(50), "the last slice ends at the deadline");
        assert_eq!(w.next(MS(3999), MS(0)).unwrap(), MS(1), "never a zero timeout");
        assert_eq!(w.elapsed(MS(3500)), MS(2500));
        let e = w.next(MS(4000), MS(100)).unwrap_err();
        assert!(matches!(e, WaitError::TimedOut { .. }));
        assert_eq!(e.to_string(), "/dev/pts/3: gave up waiting for the answer to QG after 3.0 s");
    }

    #[test]
    fn a_stop_ends_an_interruptible_wait_and_not_a_plain_one() {
        let stop = Stop::new();
        stop.set_pausable(true);
        let mut plain = Wait::new("p", "the answer to ES", MS(0), MS(3000));
        let mut inter = Wait::new("p", "room in the buffer", MS(0), MS(3000)).interruptible_by(&stop);
        let mut any = Wait::new("p", "the homing", MS(0), MS(3000)).interruptible_by(&stop).on_any_interrupt();
        stop.interrupt();
        assert!(inter.next(MS(10), MS(100)).is_ok(), "one Ctrl-C is a pause request, not a stop");
        let e = any.next(MS(10), MS(100)).unwrap_err();
        assert_eq!(e.to_string(), "stopped by Ctrl-C (SIGINT) while waiting for the homing from p");
        stop.request(StopCause::Terminate);
        let e = inter.next(MS(20), MS(100)).unwrap_err();
        assert!(matches!(&e, WaitError::Stopped(s) if s.cause == StopCause::Terminate), "{e}");
        assert!(plain.next(MS(20), MS(100)).is_ok(), "the stop's own waits run on");
    }
}
