//! CPU-bound work for a request (decoding, preparing, exporting), run off the async threads in one of the
//! server's import slots, with its memory reserved in the budget and cancelled when its client goes away.

use std::sync::Arc;

use axum::http::StatusCode;
use plotter_path::geometry::cancel::Cancel;

use super::budget::Budget;
use super::error::ApiError;
use super::state::Shared;

/// Sets its flag when dropped, unless the work it guards has ended.
struct CancelOnDrop(Option<Cancel>);

impl Drop for CancelOnDrop {
    fn drop(&mut self) {
        if let Some(c) = self.0.take() {
            c.cancel();
        }
    }
}

/// Run CPU-bound work (decoding, preparing) on the blocking pool in one of the server's import slots
/// ([`super::state::Limits::max_imports`]); `503 Service Unavailable` when every slot is taken, rather than a
/// queue. The work itself holds the slot, so clients that upload and hang up cannot pile up threads; and it gets
/// a [`Cancel`] flag that a guard held by the request's future sets when that future is dropped (hyper drops the
/// handler when its client goes away): the work then stops at its next coarse check (per SVG element, between
/// stages; see [`plotter_path::geometry::cancel`]) and frees its slot, instead of running to an end nobody waits
/// for. Before it starts, the work reserves `memory` (an estimate in bytes, named `what` in the refusal) in the
/// server's [`Budget`], held while it runs: `503` when the budget cannot hold it beside the work in flight.
pub(crate) async fn heavy<T: Send + 'static>(
    shared: &Shared,
    (memory, what): (u64, &str),
    work: impl FnOnce(&Cancel) -> T + Send + 'static,
) -> Result<T, ApiError> {
    let reserved = Budget::process().reserve(memory, what)?;
    let Ok(slot) = Arc::clone(&shared.imports).try_acquire_owned() else {
        let n = shared.config.limits.max_imports;
        return Err(ApiError(
            StatusCode::SERVICE_UNAVAILABLE,
            format!("busy: {n} drawing(s) are being decoded or prepared, the most at once; try again when done"),
        ));
    };
    let cancel = Cancel::new();
    let mut guard = CancelOnDrop(Some(cancel.clone()));
    let result = tokio::task::spawn_blocking(move || {
        let _held = (slot, reserved);
        work(&cancel)
    })
    .await;
    // Ended: nothing left to cancel.
    guard.0 = None;
    result.map_err(|e| ApiError(StatusCode::INTERNAL_SERVER_ERROR, e.to_string()))
}
