//! How `plotter serve` ends on SIGINT, SIGTERM, SIGHUP or SIGQUIT (the library's one stop path,
//! [`plotter_host::stop`]): a plot in progress is cancelled as the page's Cancel does it — the dialect's stop and
//! the pen up, the journal kept — (its stream sees the same stop flag at once; a pause prompt waiting for a page is
//! answered "cancel"), the worker is given a bounded time to finish that, then the server stops listening. A
//! server that was idle ends normally (a service manager's stop is no failure); one whose plot the signal cut short
//! ends as a stopped plot does.

use std::sync::Arc;
use std::time::{Duration, Instant};

use plotter_host::stop::{Stop, StopCause};

use super::state::Shared;

/// How long the worker may take to stop a plot and lift the pen before the server ends anyway.
const STOP_GRACE: Duration = Duration::from_secs(30);

/// How the server ended on a signal.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Ended {
    /// The signal.
    pub(crate) cause: StopCause,
    /// Whether it cut a plot (or a connection, a homing) short.
    pub(crate) interrupted: bool,
}

/// Wait for a stop; then cancel the plot, wait (bounded) for the worker to be done, and say what stopped us.
pub(crate) async fn on_stop(shared: Arc<Shared>) -> Ended {
    let cause = loop {
        if let Some(cause) = Stop::process().stop_cause() {
            break cause;
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    };
    eprintln!("plotter serve: stopping on {cause}");
    let interrupted = matches!(shared.lock().machine.activity, "plotting" | "paused" | "busy" | "connecting");
    shared.control.update(|s| s.cancel = true);
    let start = Instant::now();
    loop {
        let activity = shared.lock().machine.activity;
        if !matches!(activity, "plotting" | "paused" | "busy" | "connecting") {
            break;
        }
        if start.elapsed() > STOP_GRACE {
            eprintln!("plotter serve: the machine is still {activity} after {} s; ending anyway", STOP_GRACE.as_secs());
            break;
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    Ended { cause, interrupted }
}
