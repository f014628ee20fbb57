//! How `plotter serve` ends on SIGINT, SIGTERM, SIGHUP or SIGQUIT (the library's one stop path,
//! [`plotter_host::stop`]): a plot in progress is cancelled as the page's Cancel does it — the dialect's stop and
//! the pen up, the journal kept — (its stream sees the same stop flag at once; a pause prompt waiting for a page is
//! answered "cancel"), the worker is given a bounded time to finish that, then the server stops listening.

use std::sync::Arc;
use std::time::{Duration, Instant};

use plotter_host::stop::{Stop, StopCause};

use super::state::Shared;

/// How long the worker may take to stop a plot and lift the pen before the server ends anyway.
const STOP_GRACE: Duration = Duration::from_secs(30);

/// Wait for a stop; then cancel the plot, wait (bounded) for the worker to be done, and return what stopped us.
pub(crate) async fn on_stop(shared: Arc<Shared>) -> StopCause {
    let cause = loop {
        if let Some(cause) = Stop::process().stop_cause() {
            break cause;
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    };
    eprintln!("plotter serve: stopping on {cause}");
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
    cause
}
