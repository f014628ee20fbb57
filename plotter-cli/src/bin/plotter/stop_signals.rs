//! The termination signals of a long-running command (`plotter sim`, `plotter print`, `plotter plot --as-written`)
//! as a flag: SIGINT (Ctrl-C), SIGTERM, SIGHUP and SIGQUIT get a handler (signal-hook's) that only sets the flag, in
//! whichever thread takes the signal; the command's loop sees it and ends the way it ends on Ctrl-C — the trace
//! written, a QEMU child killed, a print's heaters switched off, a plot's pen raised. A handler rather than blocking
//! the signals: the serial port's read waits in `ppoll` with every signal unblocked, where a blocked-elsewhere
//! SIGTERM would take its default action and end the process with the pen down. A signal the parent set to be
//! ignored (a background job's SIGINT) is taken too. SIGKILL cannot be caught.

use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use anyhow::Context as _;
use signal_hook::consts::{SIGHUP, SIGINT, SIGQUIT, SIGTERM};

/// Start taking the termination signals; the flag is set once one arrives.
pub(crate) fn stop_flag() -> anyhow::Result<Arc<AtomicBool>> {
    let stop = Arc::new(AtomicBool::new(false));
    for s in [SIGINT, SIGTERM, SIGHUP, SIGQUIT] {
        signal_hook::flag::register(s, Arc::clone(&stop)).context("cannot take the termination signals")?;
    }
    Ok(stop)
}
