//! The resume journals of the web app's plots on a serial port: where one goes (the user's state directory, named
//! apart from the command line's), and what it records as its source.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

/// Who wrote a journal, in its source record (`plotter plot` records its arguments instead).
pub(crate) const WEB_FRONT_END: &str = "plotter serve";

/// What a web plot's journal records as its source: enough to list it (`plotter resume --list` reads `drawing`
/// and `machine`) and to check, on resume, that the drawing prepared now is the one that was plotted from `start`.
#[derive(Debug, Serialize, Deserialize)]
pub(crate) struct WebJournal {
    /// [`WEB_FRONT_END`].
    pub(crate) front_end: String,
    /// The drawing's name, as the page shows it.
    pub(crate) drawing: String,
    /// The machine profile's name.
    pub(crate) machine: String,
    /// Where the plan started, steps.
    pub(crate) start: [i32; 4],
}

/// The journal of a web plot of `drawing` on `machine` in `dir`: the state directory's file for that pair, named
/// apart from the command line's journals of the same file (whose records a web resume could not use).
pub(crate) fn journal_path(dir: &Path, drawing: &str, machine: &str) -> PathBuf {
    plotter_host::state_dir::journal_in(dir, &format!("{WEB_FRONT_END}/{drawing}"), machine)
}
