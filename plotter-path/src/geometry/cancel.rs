//! Cancelling long work from outside: a flag that whoever asked for an import or a preparation sets when the
//! result is no longer wanted (the web app's client hung up), and that the work checks at coarse points — per SVG
//! element, per hidden-line item, between the raster tracer's stages, between the pipeline's stages — ending
//! early with [`Cancelled`].
//!
//! The checks are only a few atomic loads between units of work that are themselves bounded (see
//! [`crate::geometry::limits`]), so a cancelled import ends within one such unit. Work that nobody can cancel
//! carries [`Cancel::never`], the default, which checks nothing.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

/// A cancellation flag shared between the work and whoever may cancel it; clones share the flag.
#[derive(Debug, Clone, Default)]
pub struct Cancel(Option<Arc<AtomicBool>>);

/// The work stopped early because it was cancelled ([`Cancel::cancel`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("cancelled: the work was no longer wanted")]
pub struct Cancelled;

impl Cancel {
    /// A flag that can be set (clone it for the side that cancels).
    pub fn new() -> Cancel {
        Cancel(Some(Arc::new(AtomicBool::new(false))))
    }

    /// No flag: the work can never be cancelled (the default).
    pub fn never() -> Cancel {
        Cancel(None)
    }

    /// Ask the work to stop at its next check (nothing for [`Cancel::never`]).
    pub fn cancel(&self) {
        if let Some(flag) = &self.0 {
            flag.store(true, Ordering::Relaxed);
        }
    }

    /// Whether the work has been asked to stop.
    pub fn is_cancelled(&self) -> bool {
        self.0.as_ref().is_some_and(|flag| flag.load(Ordering::Relaxed))
    }

    /// `Err(Cancelled)` once the work has been asked to stop: `cancel.check()?` at each coarse point.
    pub fn check(&self) -> Result<(), Cancelled> {
        if self.is_cancelled() { Err(Cancelled) } else { Ok(()) }
    }
}

/// Two handles are equal when they are the same flag (or both [`Cancel::never`]), so options that carry one
/// compare by their settings and the flag's identity.
impl PartialEq for Cancel {
    fn eq(&self, other: &Cancel) -> bool {
        match (&self.0, &other.0) {
            (None, None) => true,
            (Some(a), Some(b)) => Arc::ptr_eq(a, b),
            _ => false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_clone_sees_the_cancel_and_never_ignores_it() {
        let work = Cancel::new();
        let asker = work.clone();
        assert_eq!(work.check(), Ok(()));
        asker.cancel();
        assert!(work.is_cancelled());
        assert_eq!(work.check(), Err(Cancelled));
        let never = Cancel::never();
        never.cancel();
        assert_eq!(never.check(), Ok(()));
        assert_eq!(work, asker);
        assert_ne!(work, Cancel::new(), "another flag");
        assert_eq!(never, Cancel::default());
    }
}
