//! The termination signals of a long-running command (`plotter sim`, `plotter print`, `plotter plot --as-written`)
//! as a flag: SIGINT (Ctrl-C), SIGTERM, SIGHUP
//! and SIGQUIT are blocked in every thread and taken by one thread of their own (`sigwait`), which sets the flag;
//! the command's loop sees it and ends the way it ends on Ctrl-C — the trace written, a QEMU child killed, a print's
//! heaters switched off, a plot's pen raised.
//! SIGKILL cannot be caught.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use anyhow::Context as _;
use nix::sys::signal::{SigSet, Signal};

/// Start taking the termination signals; the flag is set once one arrives. Call it before any other thread is
/// started: a thread inherits the signal mask of the thread that starts it, and a signal delivered to a thread that
/// does not block it would still end the process at once.
pub(crate) fn stop_flag() -> anyhow::Result<Arc<AtomicBool>> {
    let mut set = SigSet::empty();
    for s in [Signal::SIGINT, Signal::SIGTERM, Signal::SIGHUP, Signal::SIGQUIT] {
        set.add(s);
    }
    set.thread_block().context("cannot block the termination signals")?;
    let stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    std::thread::Builder::new()
        .name("signals".into())
        .spawn(move || {
            loop {
                if set.wait().is_ok() {
                    flag.store(true, Ordering::SeqCst);
                }
            }
        })
        .context("cannot start the signal thread")?;
    Ok(stop)
}
