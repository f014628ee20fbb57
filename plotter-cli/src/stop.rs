//! The one way a running command learns that it must stop: SIGINT (Ctrl-C), SIGTERM (a service manager, `kill`),
//! SIGHUP (the terminal closed, an ssh session dropped) and SIGQUIT (Ctrl-\), for every command and every firmware
//! dialect.
//!
//! The signals are taken by signal-hook's iterator: its handler only writes to a self-pipe, and a thread of ours
//! turns each signal into a count here. A handler rather than blocked signals, because the serial port's read
//! waits in `ppoll` with every signal unblocked, where a SIGTERM blocked elsewhere would take its default action
//! and end the process with the pen down. SIGKILL cannot be caught.
//!
//! Two strengths of request, because a plot can be paused but a closed terminal cannot answer a prompt:
//! - a **pause** — one Ctrl-C: the plot job parks with the pen up (or holds) and asks the user
//!   ([`Stop::take_pause`]);
//! - a **stop** — SIGTERM, SIGHUP, SIGQUIT, a second Ctrl-C before the first was taken, or a Ctrl-C during a wait
//!   that cannot pause (connecting, homing, a plotter that withholds buffer space): the command ends the way an
//!   abort does — the dialect's stop, the pen up, the journal kept, a message naming the signal
//!   ([`Stop::stop_cause`], [`Stop::check`]).
//!
//! Every wait on a device checks it (see [`crate::link::wait`]). The stop itself — the dialect's `ES`, `ESC . K`,
//! feed hold and reset, and the pen-up — does not: it runs to its end, within its own deadlines, whatever arrives.

use std::fmt;
use std::sync::atomic::{AtomicBool, AtomicI32, AtomicUsize, Ordering};
use std::sync::{Arc, OnceLock};
use std::time::Duration;

use signal_hook::consts::{SIGHUP, SIGINT, SIGQUIT, SIGTERM};

/// What asked for a stop.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StopCause {
    /// Ctrl-C (SIGINT) where no pause was possible, or a second one before the first was taken.
    Interrupt,
    /// SIGTERM: a service manager, `kill`, a shutdown.
    Terminate,
    /// SIGHUP: the terminal closed or the ssh session dropped.
    Hangup,
    /// SIGQUIT (Ctrl-\).
    Quit,
    /// The front end asked (a stop button, a test).
    Requested,
}

impl StopCause {
    fn code(self) -> i32 {
        match self {
            StopCause::Interrupt => SIGINT,
            StopCause::Terminate => SIGTERM,
            StopCause::Hangup => SIGHUP,
            StopCause::Quit => SIGQUIT,
            StopCause::Requested => -1,
        }
    }

    fn from_code(code: i32) -> Option<StopCause> {
        [StopCause::Interrupt, StopCause::Terminate, StopCause::Hangup, StopCause::Quit, StopCause::Requested]
            .into_iter()
            .find(|c| c.code() == code && code != 0)
    }
}

impl fmt::Display for StopCause {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            StopCause::Interrupt => "Ctrl-C (SIGINT)",
            StopCause::Terminate => "SIGTERM",
            StopCause::Hangup => "SIGHUP (the terminal closed)",
            StopCause::Quit => "SIGQUIT",
            StopCause::Requested => "a stop request",
        })
    }
}

/// The stop was asked while waiting: the error a wait returns (see [`crate::link::wait`]); the plot job turns it
/// into the dialect's stop with the pen up.
#[derive(Debug, Clone, thiserror::Error)]
#[error("stopped by {cause} while {doing}")]
pub struct Stopped {
    /// What asked.
    pub cause: StopCause,
    /// What was going on ("waiting for the answer to QG", "importing lines.gcode").
    pub doing: String,
}

/// Why a wait on a device ([`crate::link::wait::Wait`]) ended without what it waited for: its deadline, or a
/// stop. Beside [`Stopped`] so that the error's kinds ([`crate::Trouble`]) can tell a stopped wait, whatever
/// wraps it.
#[derive(Debug, Clone, thiserror::Error)]
pub enum WaitError {
    /// The deadline passed.
    #[error("{name}: gave up waiting for {what} after {:.1} s", limit.as_secs_f64())]
    TimedOut {
        /// The device.
        name: String,
        /// What was waited for.
        what: String,
        /// The deadline, from the start of the wait.
        limit: Duration,
    },
    /// A stop was asked.
    #[error(transparent)]
    Stopped(#[from] Stopped),
}

#[derive(Debug, Default)]
struct State {
    /// Ctrl-Cs received.
    interrupts: AtomicUsize,
    /// Ctrl-Cs already taken as a pause (or as a stop).
    taken: AtomicUsize,
    /// The first stop that is not a Ctrl-C ([`StopCause::code`]; 0 = none).
    stop: AtomicI32,
    /// A Ctrl-C can be taken as a pause now (a plot is running with a front end that asks the user).
    pausable: AtomicBool,
}

/// A stop flag: the process's own ([`Stop::process`], fed by the signals once [`Stop::install_signals`] ran) or
/// a private one (a web worker's, a test's). Cloning shares it.
#[derive(Debug, Clone, Default)]
pub struct Stop {
    state: Arc<State>,
}

impl Stop {
    /// A private flag nobody has raised.
    pub fn new() -> Stop {
        Stop::default()
    }

    /// The process's flag (raised by the termination signals once [`Stop::install_signals`] ran).
    pub fn process() -> &'static Stop {
        static PROCESS: OnceLock<Stop> = OnceLock::new();
        PROCESS.get_or_init(Stop::new)
    }

    /// Start taking SIGINT, SIGTERM, SIGHUP and SIGQUIT into [`Stop::process`] (once per process; later calls
    /// return the same flag). Also lets imports in `plotter-path` see a stop.
    pub fn install_signals() -> std::io::Result<&'static Stop> {
        static INSTALLED: OnceLock<()> = OnceLock::new();
        let stop = Stop::process();
        if INSTALLED.get().is_some() {
            return Ok(stop);
        }
        let mut signals = signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP, SIGQUIT])?;
        let _ = INSTALLED.set(());
        let flag = stop.clone();
        std::thread::Builder::new().name("stop-signals".into()).spawn(move || {
            for s in signals.forever() {
                match s {
                    SIGINT => flag.interrupt(),
                    SIGTERM => flag.request(StopCause::Terminate),
                    SIGHUP => flag.request(StopCause::Hangup),
                    _ => flag.request(StopCause::Quit),
                }
                // Imports and other long computations end too (a Ctrl-C during a plot is a pause, not an end).
                plotter_path::config::interrupt::raise_if(flag.stop_cause().is_some());
            }
        })?;
        Ok(stop)
    }

    /// Whether a single Ctrl-C is a pause request (a plot is running and someone can be asked) rather than a
    /// stop (loading, planning, connecting: nothing to pause). Off at first.
    pub fn set_pausable(&self, on: bool) {
        self.state.pausable.store(on, Ordering::SeqCst);
    }

    /// Record a Ctrl-C: a pause if the plot can take one, else (or when one is already waiting) a stop.
    pub fn interrupt(&self) {
        self.state.interrupts.fetch_add(1, Ordering::SeqCst);
    }

    /// Ask for a stop (`cause` is kept if it is the first).
    pub fn request(&self, cause: StopCause) {
        let _ = self.state.stop.compare_exchange(0, cause.code(), Ordering::SeqCst, Ordering::SeqCst);
    }

    /// Ctrl-Cs not yet taken.
    fn pending(&self) -> usize {
        let s = &self.state;
        s.interrupts.load(Ordering::SeqCst).saturating_sub(s.taken.load(Ordering::SeqCst))
    }

    /// Whether a Ctrl-C asks for a pause (taking it: the next Ctrl-C asks again).
    pub fn take_pause(&self) -> bool {
        let s = &self.state;
        let n = s.interrupts.load(Ordering::SeqCst);
        n > s.taken.swap(n, Ordering::SeqCst)
    }

    /// Whether a stop was asked: a termination signal, a front end's request, a Ctrl-C while nothing can pause,
    /// or two Ctrl-Cs not taken as a pause.
    pub fn stop_cause(&self) -> Option<StopCause> {
        let ctrl_cs = if self.state.pausable.load(Ordering::SeqCst) { 2 } else { 1 };
        match StopCause::from_code(self.state.stop.load(Ordering::SeqCst)) {
            Some(c) => Some(c),
            None => (self.pending() >= ctrl_cs).then_some(StopCause::Interrupt),
        }
    }

    /// [`Stop::stop_cause`], where a single Ctrl-C counts too (a wait that cannot pause: connecting, homing).
    pub fn stop_cause_or_interrupt(&self) -> Option<StopCause> {
        self.stop_cause().or_else(|| (self.pending() >= 1).then_some(StopCause::Interrupt))
    }

    /// Whether any signal arrived at all (a command that only ends: `sim`, `print`).
    pub fn any(&self) -> bool {
        self.state.interrupts.load(Ordering::SeqCst) > 0 || self.state.stop.load(Ordering::SeqCst) != 0
    }

    /// `Err` naming the cause and `doing` when a stop was asked ([`Stop::stop_cause`]).
    pub fn check(&self, doing: &str) -> Result<(), Stopped> {
        match self.stop_cause() {
            Some(cause) => Err(Stopped { cause, doing: doing.to_string() }),
            None => Ok(()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_ctrl_c_is_a_pause_two_are_a_stop_and_a_taken_pause_is_gone() {
        let s = Stop::new();
        s.set_pausable(true);
        assert!(!s.any());
        assert!(!s.take_pause());
        assert_eq!(s.stop_cause(), None);
        assert_eq!(s.stop_cause_or_interrupt(), None);
        s.interrupt();
        assert!(s.any());
        assert_eq!(s.stop_cause(), None);
        assert_eq!(s.stop_cause_or_interrupt(), Some(StopCause::Interrupt));
        assert!(s.take_pause());
        assert!(!s.take_pause(), "taken once");
        assert_eq!(s.stop_cause_or_interrupt(), None);
        s.interrupt();
        s.interrupt();
        assert_eq!(s.stop_cause(), Some(StopCause::Interrupt));
        assert!(s.check("plotting").is_err());
    }

    #[test]
    fn one_ctrl_c_stops_where_nothing_can_pause() {
        let s = Stop::new();
        s.interrupt();
        assert_eq!(s.stop_cause(), Some(StopCause::Interrupt));
        s.set_pausable(true);
        assert_eq!(s.stop_cause(), None, "a plot takes it as a pause");
        assert!(s.take_pause());
    }

    #[test]
    fn the_first_termination_signal_is_kept_and_named() {
        let s = Stop::new();
        assert!(s.check("waiting for QG").is_ok());
        s.request(StopCause::Hangup);
        s.request(StopCause::Terminate);
        assert_eq!(s.stop_cause(), Some(StopCause::Hangup));
        assert!(!s.take_pause());
        let e = s.check("waiting for the answer to QG").unwrap_err();
        assert_eq!(e.to_string(), "stopped by SIGHUP (the terminal closed) while waiting for the answer to QG");
        // A clone shares the flag.
        let t = s.clone();
        assert_eq!(t.stop_cause(), Some(StopCause::Hangup));
        for c in [StopCause::Interrupt, StopCause::Terminate, StopCause::Hangup, StopCause::Quit, StopCause::Requested]
        {
            assert_eq!(StopCause::from_code(c.code()), Some(c));
        }
        assert_eq!(StopCause::from_code(0), None);
    }
}
