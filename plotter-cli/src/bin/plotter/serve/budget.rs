//! The server's memory budget for work in flight: decoding an upload and preparing a drawing reserve an estimate
//! of the memory they may take before they start, and give it back when they end. When the budget cannot hold a
//! new reservation beside those in flight, the request is answered `503 Service Unavailable` at once with what is
//! in use, so concurrent uploads cannot together take the server past it (two 16 MB HP-GL uploads at once took
//! 3.4 GB before this; one more and an allocation failed and the server aborted).
//!
//! Why a budget of bytes rather than fewer import slots: most drawings are small, and a slot count low enough for
//! the worst case (a drawing at the point limit) would make small uploads wait for nothing. The estimate is an
//! upper bound from what is known before the work: for a decode, the upload's size and kind (an HP-GL file makes
//! at most one point per two bytes; SVG, G-code and images can make up to the point limit from a few bytes); for
//! a preparation, the decoded drawing's points and paths. The per-point figures are measured peaks (see
//! [`DECODE_BYTES_PER_POINT`], [`PREPARE_BYTES_PER_POINT`]). A single job whose estimate is larger than the whole
//! budget is not refused for that: it reserves the whole budget and so runs alone.
//!
//! The budget is [`DEFAULT_MIB`] MiB, or `PLOTTER_SERVE_MEMORY_MB` from the environment. It bounds the work in
//! flight; the drawing the server keeps between requests (one decoded and one prepared copy) comes on top.

use std::sync::{Arc, OnceLock};

use axum::http::StatusCode;
use plotter_host::input::{InputKind, input_kind};
use plotter_path::Drawing;
use plotter_path::geometry::limits::MAX_POINTS;
use tokio::sync::{OwnedSemaphorePermit, Semaphore};

use super::error::ApiError;

/// The default budget, MiB.
pub(crate) const DEFAULT_MIB: u32 = 768;

/// The environment variable that sets the budget, MiB.
pub(crate) const ENV: &str = "PLOTTER_SERVE_MEMORY_MB";

/// Peak bytes a decode may take per point it makes (the points, their paths, the import's own lists), measured
/// on HP-GL and G-code at the point limit with room to spare.
pub(crate) const DECODE_BYTES_PER_POINT: u64 = 64;

/// Peak bytes preparing a drawing takes per point (layout, ordering, steps and the motion plan, which holds most):
/// a 4,194,288-point stroke took the server to 1.1 GB.
pub(crate) const PREPARE_BYTES_PER_POINT: u64 = 280;

/// Further bytes per path when preparing (a path's own allocations in each stage).
pub(crate) const PREPARE_BYTES_PER_PATH: u64 = 200;

/// What any job takes besides its points (buffers, the thread's stack), bytes.
const FIXED_BYTES: u64 = 16 << 20;

/// The server's memory budget (see the module docs).
#[derive(Debug)]
pub(crate) struct Budget {
    permits: Arc<Semaphore>,
    total_mib: u32,
}

impl Budget {
    /// A budget of `total_mib` MiB (at least 1).
    pub(crate) fn new(total_mib: u32) -> Budget {
        let total_mib = total_mib.max(1);
        Budget { permits: Arc::new(Semaphore::new(total_mib as usize)), total_mib }
    }

    /// The process's budget: [`ENV`] if it is set to a whole number of MiB, else [`DEFAULT_MIB`].
    pub(crate) fn process() -> &'static Budget {
        static BUDGET: OnceLock<Budget> = OnceLock::new();
        BUDGET.get_or_init(|| {
            let mib = std::env::var(ENV).ok().and_then(|v| v.trim().parse::<u32>().ok()).unwrap_or(DEFAULT_MIB);
            Budget::new(mib)
        })
    }

    /// Reserve `bytes` for `what` (a job larger than the budget takes all of it), or a 503 naming what is in use.
    pub(crate) fn reserve(&self, bytes: u64, what: &str) -> Result<OwnedSemaphorePermit, ApiError> {
        let mib = u32::try_from(bytes.div_ceil(1 << 20)).unwrap_or(u32::MAX).clamp(1, self.total_mib);
        Arc::clone(&self.permits).try_acquire_many_owned(mib).map_err(|_| {
            let in_use = self.total_mib.saturating_sub(u32::try_from(self.permits.available_permits()).unwrap_or(0));
            ApiError(
                StatusCode::SERVICE_UNAVAILABLE,
                format!(
                    "busy: {what} needs about {mib} MB of the server's {} MB memory budget, and {in_use} MB are in \
                     use by other drawings being decoded or prepared; try again when they are done (the budget is \
                     set by {ENV})",
                    self.total_mib
                ),
            )
        })
    }
}

/// The most memory decoding `bytes` of an upload named `name` may take, bytes (see the module docs).
pub(crate) fn decode_estimate(name: &str, bytes: &[u8]) -> u64 {
    let len = bytes.len() as u64;
    let max_points = MAX_POINTS as u64;
    let points = match input_kind(std::path::Path::new(name), &bytes[..bytes.len().min(512)]) {
        // At least two bytes per point: `PDPU` makes a dot of two points from four bytes.
        InputKind::Hpgl => (len / 2 + 2).min(max_points),
        InputKind::Unread(_) => 0,
        // Curves, arcs, generated figures and traced images can reach the limit from a few bytes.
        _ => max_points,
    };
    FIXED_BYTES + 2 * len + points * DECODE_BYTES_PER_POINT
}

/// The most memory preparing `drawing` may take, bytes.
pub(crate) fn prepare_estimate(drawing: &Drawing) -> u64 {
    let (mut points, mut paths) = (0u64, 0u64);
    for p in drawing.paths() {
        points += p.points.len() as u64;
        paths += 1;
    }
    FIXED_BYTES + points * PREPARE_BYTES_PER_POINT + paths * PREPARE_BYTES_PER_PATH
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reservations_share_the_budget_and_a_large_job_runs_alone() {
        let b = Budget::new(100);
        let first = b.reserve(60 << 20, "a.hpgl").ok().expect("fits");
        let Err(e) = b.reserve(50 << 20, "b.hpgl") else { panic!("over the budget") };
        assert_eq!(e.0, StatusCode::SERVICE_UNAVAILABLE);
        assert!(
            e.1.starts_with("busy: b.hpgl needs about 50 MB of the server's 100 MB memory budget, and 60 MB"),
            "{}",
            e.1
        );
        let second = b.reserve(40 << 20, "c.hpgl").ok().expect("fits beside");
        drop((first, second));
        // Larger than the budget: it takes all of it, and nothing else fits beside it.
        let huge = b.reserve(10 << 30, "huge.svg").ok().expect("runs alone");
        assert!(b.reserve(1, "tiny.svg").is_err());
        drop(huge);
        assert!(b.reserve(1, "tiny.svg").is_ok());
    }

    #[test]
    fn estimates_follow_the_kind_and_size() {
        // 16 MB of HP-GL could make 8 M points, more than the limit: the estimate stops at the limit.
        let flood = "PDPU".repeat(4_000_000);
        let at_limit = FIXED_BYTES + 2 * 16_000_000 + (MAX_POINTS as u64) * DECODE_BYTES_PER_POINT;
        assert_eq!(decode_estimate("f.hpgl", flood.as_bytes()), at_limit);
        assert_eq!(decode_estimate("small.hpgl", b"IN;PD1,1;"), FIXED_BYTES + 18 + 6 * DECODE_BYTES_PER_POINT);
        // A small SVG may still flatten into the limit.
        assert_eq!(
            decode_estimate("a.svg", b"<svg/>"),
            FIXED_BYTES + 12 + (MAX_POINTS as u64) * DECODE_BYTES_PER_POINT
        );
        assert_eq!(decode_estimate("a.gif", b"GIF89a"), FIXED_BYTES + 12);
    }
}
