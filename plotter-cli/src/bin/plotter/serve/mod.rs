//! `plotter serve`: the local web app. An HTTP server (axum on tokio) with the page's assets compiled into the
//! binary, a JSON API and a server-sent event stream, in front of the same host library the CLI uses.
//!
//! - [`listen`]: the accept loop, with its connection limit and header timeout;
//! - [`api`]: routes, the Host/Origin/controller guard, handlers;
//! - [`budget`]: the memory budget of the drawings being decoded or prepared;
//! - [`error`]: the error answer;
//! - [`deadline`]: the time limit on request bodies;
//! - [`events`]: the event channel to the pages;
//! - [`export`]: downloads of the prepared drawing (G-code, HP-GL, SVG);
//! - [`heavy`]: CPU-bound work off the async threads, in bounded slots, cancelled with its client;
//! - [`pen_speed`]: the pen-height and speed sliders and what they change in the profile;
//! - [`state`]: the shared state, the limits on clients, and what a page is sent;
//! - [`safety`]: Host/Origin/Referer checks and control tokens;
//! - [`auth`]: signing in with the operator's or a viewer's token (`--token-file`, needed off loopback);
//! - [`control`]: which page drives the machine;
//! - [`command`]: what the HTTP side asks the worker;
//! - [`worker`]: the thread that owns the link to the machine and runs plots;
//! - [`web_journal`]: the resume journals of the web app's serial plots;
//! - [`shutdown`]: ending on a signal with the plot stopped and the pen up;
//! - [`studio_app`] and [`studio_api`]: the studio (`--machine`, `--studio`): several machines fed from one job
//!   queue, with their API and page.
//!
//! The HTTP side never blocks on the machine: it sends commands to the worker and the worker reports through
//! events, so a long plot, a homing cycle or a slow serial port never holds up a page.

pub(crate) mod api;
pub(crate) mod auth;
pub(crate) mod budget;
pub(crate) mod command;
pub(crate) mod control;
pub(crate) mod deadline;
pub(crate) mod error;
pub(crate) mod events;
pub(crate) mod export;
pub(crate) mod heavy;
pub(crate) mod listen;
pub(crate) mod pen_speed;
pub(crate) mod safety;
pub(crate) mod shutdown;
pub(crate) mod state;
pub(crate) mod studio_api;
pub(crate) mod studio_app;
pub(crate) mod web_journal;
pub(crate) mod worker;

use std::sync::Arc;

use state::{Config, Shared};

/// Start the machine worker and build the app for `config`.
pub(crate) fn app(config: Config) -> (Arc<Shared>, axum::Router) {
    let (tx, rx) = std::sync::mpsc::channel();
    let shared = Arc::new(Shared::new(config, tx));
    let worker_shared = Arc::clone(&shared);
    std::thread::Builder::new()
        .name("machine".into())
        .spawn(move || worker::run(worker_shared, rx))
        .map_or_else(|e| eprintln!("error: cannot start the machine worker: {e}"), |_| ());
    let router = api::router(Arc::clone(&shared));
    (shared, router)
}

/// Serve on `listener` until a stop signal (see [`shutdown`]); returns what stopped it. With `tokens`, every
/// request must be signed in ([`auth`]).
pub(crate) async fn serve(
    listener: tokio::net::TcpListener,
    config: Config,
    tokens: Option<auth::Tokens>,
) -> Option<shutdown::Ended> {
    let limits = config.limits;
    let local = config.local;
    let (shared, mut router) = app(config);
    if let Some(tokens) = tokens {
        router = auth::protect(router, auth::Auth::new(tokens, local));
    }
    tokio::select! {
        () = listen::serve(listener, router, limits) => None,
        cause = shutdown::on_stop(shared) => Some(cause),
    }
}

#[cfg(test)]
mod tests;
