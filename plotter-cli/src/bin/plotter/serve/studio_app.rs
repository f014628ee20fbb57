//! `plotter serve` with machines (`--machine`, `--studio`): the studio's workers started, its API and page
//! served, and its end on a signal — every plot stopped at once with the pen up (its job left interrupted, to
//! resume from its journal once the operator confirms), the workers given a bounded time to do that.

use std::sync::Arc;
use std::time::{Duration, Instant};

use plotter_host::stop::Stop;
use plotter_host::studio::running::Studio;

use super::auth::{self, Tokens};
use super::listen;
use super::shutdown::Ended;
use super::state::Limits;
use super::studio_api::{StudioState, router};

/// How long the machines may take to stop and lift their pens before the server ends anyway.
const STOP_GRACE: Duration = Duration::from_secs(30);

/// Serve `studio` on `listener` until a stop signal; returns what stopped it. With `tokens`, every request must be
/// signed in ([`auth`]).
pub(crate) async fn serve(
    listener: tokio::net::TcpListener,
    studio: Arc<Studio>,
    limits: Limits,
    tokens: Option<Tokens>,
) -> Option<Ended> {
    let local = match listener.local_addr() {
        Ok(a) => a,
        Err(e) => {
            eprintln!("error: cannot read the listening address: {e}");
            return None;
        }
    };
    let workers = match plotter_host::studio::worker::start(&studio) {
        Ok(w) => w,
        Err(e) => {
            eprintln!("error: cannot start the machines' workers: {e}");
            return None;
        }
    };
    let mut app = router(StudioState { studio: Arc::clone(&studio), local });
    if let Some(tokens) = tokens {
        app = auth::protect(app, auth::Auth::new(tokens, local));
    }
    let ended = tokio::select! {
        () = listen::serve(listener, app, limits) => None,
        ended = on_stop(Arc::clone(&studio)) => Some(ended),
    };
    for w in workers {
        if w.is_finished() {
            let _ = w.join();
        }
    }
    ended
}

/// Wait for a stop signal; then end the studio and wait (bounded) for the machines to stop.
async fn on_stop(studio: Arc<Studio>) -> Ended {
    let cause = loop {
        if let Some(cause) = Stop::process().stop_cause() {
            break cause;
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    };
    eprintln!("plotter serve: stopping the studio on {cause}");
    let interrupted = studio.busy();
    studio.end();
    let start = Instant::now();
    while studio.busy() {
        if start.elapsed() > STOP_GRACE {
            eprintln!("plotter serve: a machine is still plotting after {} s; ending anyway", STOP_GRACE.as_secs());
            break;
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    Ended { cause, interrupted }
}
