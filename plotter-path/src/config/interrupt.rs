//! The process's "stop now" for long computations: an import of a huge file, a long optimization. A front end
//! raises it when the user asks the command to end (the host library does on SIGTERM, SIGHUP, SIGQUIT or a
//! second Ctrl-C); a loop that may run for seconds asks [`raised`] now and then and returns
//! [`Interrupted`] instead of finishing work nobody waits for. Nothing here installs a signal handler: this crate
//! does no I/O beyond files.

use std::sync::atomic::{AtomicBool, Ordering};

static RAISED: AtomicBool = AtomicBool::new(false);

/// A computation ended early because [`raise`] was called.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("interrupted while {doing}")]
pub struct Interrupted {
    /// What was going on ("reading line 120000 of a.gcode").
    pub doing: String,
}

/// Ask every long computation of this process to end.
pub fn raise() {
    RAISED.store(true, Ordering::SeqCst);
}

/// [`raise`] when `cond` holds.
pub fn raise_if(cond: bool) {
    if cond {
        raise();
    }
}

/// Whether [`raise`] was called.
pub fn raised() -> bool {
    RAISED.load(Ordering::Relaxed)
}

/// `Err` naming `doing` once [`raise`] was called (`doing` is only built then).
pub fn check(doing: impl FnOnce() -> String) -> Result<(), Interrupted> {
    if raised() { Err(Interrupted { doing: doing() }) } else { Ok(()) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn check_is_quiet_until_raised() {
        // The flag is process-wide and only ever raised: raising it is tested in tests/interrupt.rs, a test binary
        // of its own, so that no other test of this crate sees it raised.
        raise_if(false);
        assert!(!raised());
        assert!(check(|| unreachable!("built only when raised")).is_ok());
    }
}
