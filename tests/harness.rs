//! Shared helpers for the cross-crate end-to-end tests: locating the `plotter` binary and the samples.

use std::path::PathBuf;

/// The workspace root (holds `samples/`).
pub fn workspace_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).parent().map(PathBuf::from).unwrap_or_default()
}

/// Path of a file in `samples/`.
pub fn sample(name: &str) -> PathBuf {
    workspace_root().join("samples").join(name)
}
