//! Where the plotter keeps its own files: the user's state directory (`$XDG_STATE_HOME/plotter`, else
//! `~/.local/state/plotter`; `PLOTTER_STATE_DIR` overrides both), never beside the user's drawings.
//!
//! Resume journals live in its `journals/` folder, one per drawing and machine:
//! `<drawing>-<machine>-<short hash>.journal`, where the names are made file-safe and the hash tells apart two
//! drawings (or machines) whose names look alike. [`journal_for`] says where a plot's journal goes and
//! [`resumable`] lists the journals of plots that did not finish; finished ones are kept a while (a resume of a
//! finished plot can say so) and then removed by [`prune_finished`].
//!
//! ```
//! use plotter_host::state_dir;
//! let dir = std::env::temp_dir().join(format!("state-doc-{}", std::process::id()));
//! let path = state_dir::journal_in(&dir.join("journals"), "/home/me/duck.svg", "AxiDraw V3 (A4)");
//! assert!(path.file_name().unwrap().to_str().unwrap().starts_with("duck-axidraw-v3-a4-"));
//! assert!(state_dir::resumable(&dir.join("journals")).unwrap().is_empty());
//! ```

use std::path::{Path, PathBuf};
use std::time::{Duration, SystemTime};

use crate::link::journal;

/// The environment variable that replaces the state directory (tests, several setups side by side).
pub const STATE_DIR_ENV: &str = "PLOTTER_STATE_DIR";

/// How long a finished plot's journal is kept before [`prune_finished`] removes it.
pub const KEEP_FINISHED: Duration = Duration::from_secs(7 * 24 * 3600);

/// Why the state directory cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum StateDirError {
    /// Neither `PLOTTER_STATE_DIR`, `XDG_STATE_HOME` nor `HOME` is set.
    #[error("no state directory: set HOME, XDG_STATE_HOME or PLOTTER_STATE_DIR")]
    NoHome,
    /// A folder or file there could not be created or read.
    #[error("{path}: {source}")]
    Io {
        /// The folder or file.
        path: PathBuf,
        /// What the system said.
        source: std::io::Error,
    },
}

/// The plotter's state directory: `$PLOTTER_STATE_DIR`, else `$XDG_STATE_HOME/plotter`, else
/// `$HOME/.local/state/plotter` (empty variables count as unset; a relative `XDG_STATE_HOME` is ignored, as the XDG
/// specification asks). Not created here.
pub fn state_dir() -> Result<PathBuf, StateDirError> {
    state_dir_from(|name| std::env::var_os(name))
}

/// [`state_dir`] with the environment read through `var`.
fn state_dir_from(var: impl Fn(&str) -> Option<std::ffi::OsString>) -> Result<PathBuf, StateDirError> {
    let var = |name: &str| var(name).filter(|v| !v.is_empty()).map(PathBuf::from);
    if let Some(dir) = var(STATE_DIR_ENV) {
        return Ok(dir);
    }
    if let Some(xdg) = var("XDG_STATE_HOME").filter(|p| p.is_absolute()) {
        return Ok(xdg.join("plotter"));
    }
    var("HOME").map(|home| home.join(".local/state/plotter")).ok_or(StateDirError::NoHome)
}

/// The journals' folder in the state directory, created if missing.
pub fn journals_dir() -> Result<PathBuf, StateDirError> {
    let dir = state_dir()?.join("journals");
    std::fs::create_dir_all(&dir).map_err(|source| StateDirError::Io { path: dir.clone(), source })?;
    Ok(dir)
}

/// Where the journal of a plot of `drawing` (a path or any name the front end knows the drawing by) on `machine`
/// (the machine's name) goes in the state directory, which is created if missing. Plotting the same drawing on
/// the same machine again reuses the name (the new plot replaces the old journal).
pub fn journal_for(drawing: &str, machine: &str) -> Result<PathBuf, StateDirError> {
    Ok(journal_in(&journals_dir()?, drawing, machine))
}

/// [`journal_for`] in the folder `dir`: `<drawing's file stem>-<machine>-<8 hex digits>.journal`, the names made
/// file-safe (lower-case letters, digits and `-`), the digits a hash of both names as given.
pub fn journal_in(dir: &Path, drawing: &str, machine: &str) -> PathBuf {
    let stem = Path::new(drawing).file_stem().and_then(|s| s.to_str()).unwrap_or(drawing);
    let hash = fnv1a(format!("{drawing}\n{machine}").as_bytes());
    dir.join(format!("{}-{}-{:08x}.journal", slug(stem, "drawing"), slug(machine, "machine"), hash & 0xffff_ffff))
}

/// Lower-case ASCII letters and digits, every other run of characters one `-`, at most 40 characters;
/// `fallback` when nothing is left.
fn slug(name: &str, fallback: &str) -> String {
    let mut out = String::new();
    for c in name.chars() {
        if c.is_ascii_alphanumeric() {
            out.push(c.to_ascii_lowercase());
        } else if !out.is_empty() && !out.ends_with('-') {
            out.push('-');
        }
    }
    out.truncate(40);
    let out = out.trim_end_matches('-');
    if out.is_empty() { fallback.to_string() } else { out.to_string() }
}

/// The 64-bit FNV-1a hash (Fowler, Noll and Vo): stable across builds and platforms, unlike the standard
/// library's hasher, so a drawing keeps its journal name.
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3))
}

/// A journal in the state directory, as [`resumable`] lists it.
#[derive(Debug, Clone, PartialEq)]
pub struct JournalEntry {
    /// The journal file.
    pub path: PathBuf,
    /// The drawing plotted: the `drawing` field of the journal's source when it has one, else the file's name.
    pub drawing: String,
    /// The machine it was plotted on: the source's `machine` field, else empty.
    pub machine: String,
    /// Blocks certainly executed, of `blocks`.
    pub executed: usize,
    /// Blocks in the plot.
    pub blocks: usize,
    /// When the journal was last written.
    pub modified: SystemTime,
}

impl JournalEntry {
    /// How far the plot got, per cent (0 to 100).
    pub fn percent(&self) -> f64 {
        // Block counts far below 2^53: exact in f64.
        #[allow(clippy::cast_precision_loss)]
        let (e, b) = (self.executed as f64, self.blocks.max(1) as f64);
        (100.0 * e / b).min(100.0)
    }
}

/// The key of the copy being drawn in a journal's source record (a JSON object), as the plot job writes it.
pub const COPY_KEY: &str = "copy";

/// The key of the plot's copy count (0 = until stopped) in a journal's source record.
pub const COPIES_KEY: &str = "copies";

/// The copy a journal's source record says was being drawn (1 when it names none).
pub fn copy_of(source: &str) -> u64 {
    serde_json::from_str::<serde_json::Value>(source)
        .ok()
        .and_then(|v| v.get(COPY_KEY).and_then(serde_json::Value::as_u64))
        .filter(|c| *c >= 1)
        .unwrap_or(1)
}

/// The copies a journal's plot still owes once the copy it records is finished: `Some((next copy, count))` when
/// its source record counts more copies than the one it was drawing, so that a plot stopped or killed at a paper
/// change is still there to resume. A plot of one copy, one that runs until stopped (it ends where it is stopped)
/// and a journal that records no count owe none.
pub fn copies_left(source: &str) -> Option<(u64, u64)> {
    let count = serde_json::from_str::<serde_json::Value>(source)
        .ok()
        .and_then(|v| v.get(COPIES_KEY).and_then(serde_json::Value::as_u64))?;
    let copy = copy_of(source);
    (count != 0 && copy < count).then_some((copy + 1, count))
}

/// The journals in `dir` of plots that did not finish (a plot of several copies finishes with its last), the
/// most recent first. Files that are not readable journals are skipped; a missing folder has none.
pub fn resumable(dir: &Path) -> Result<Vec<JournalEntry>, StateDirError> {
    let mut out = Vec::new();
    for (path, modified) in journal_files(dir)? {
        let Ok(state) = journal::load(&path) else { continue };
        // A finished journal of a plot that still owes copies (stopped or killed at a paper change) is resumable.
        if state.complete && copies_left(&state.source).is_none() {
            continue;
        }
        let source: Option<serde_json::Value> = serde_json::from_str(&state.source).ok();
        let field = |k: &str| source.as_ref().and_then(|s| s.get(k)).and_then(|v| v.as_str()).map(str::to_string);
        let file_name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        out.push(JournalEntry {
            drawing: field("drawing").unwrap_or(file_name),
            machine: field("machine").unwrap_or_default(),
            executed: state.executed,
            blocks: state.blocks,
            modified,
            path,
        });
    }
    out.sort_by(|a, b| b.modified.cmp(&a.modified).then_with(|| a.path.cmp(&b.path)));
    Ok(out)
}

/// Remove the journals in `dir` of plots that finished more than `keep` ago (by the file's time); returns how
/// many were removed. Unfinished plots' journals (a plot owing copies among them) are never removed.
pub fn prune_finished(dir: &Path, keep: Duration) -> Result<usize, StateDirError> {
    let now = SystemTime::now();
    let mut removed = 0;
    for (path, modified) in journal_files(dir)? {
        let old = now.duration_since(modified).is_ok_and(|age| age > keep);
        let finished = |s: journal::JournalState| s.complete && copies_left(&s.source).is_none();
        if old && journal::load(&path).is_ok_and(finished) {
            std::fs::remove_file(&path).map_err(|source| StateDirError::Io { path: path.clone(), source })?;
            removed += 1;
        }
    }
    Ok(removed)
}

/// The `*.journal` files in `dir` with their modification times (none when `dir` does not exist).
fn journal_files(dir: &Path) -> Result<Vec<(PathBuf, SystemTime)>, StateDirError> {
    let io = |source| StateDirError::Io { path: dir.to_path_buf(), source };
    let entries = match std::fs::read_dir(dir) {
        Ok(e) => e,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(io(e)),
    };
    let mut out = Vec::new();
    for entry in entries {
        let entry = entry.map_err(io)?;
        let path = entry.path();
        if path.extension().is_some_and(|e| e == "journal")
            && let Ok(meta) = entry.metadata()
            && meta.is_file()
        {
            out.push((path, meta.modified().unwrap_or(SystemTime::UNIX_EPOCH)));
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::journal::Journal;

    fn temp(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("plotter-state-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        d
    }

    #[test]
    fn names_say_drawing_and_machine_and_tell_lookalikes_apart() {
        let dir = Path::new("/s/journals");
        let a = journal_in(dir, "/home/me/Duck Drawing.svg", "AxiDraw V3 (A4)");
        let name = a.file_name().unwrap().to_str().unwrap();
        // FNV-1a of "/home/me/Duck Drawing.svg\nAxiDraw V3 (A4)", low 32 bits, worked out independently.
        assert_eq!(name, format!("duck-drawing-axidraw-v3-a4-{:08x}.journal", expected_hash()));
        assert_eq!(a.parent(), Some(dir));
        // Same names: same journal; another folder's duck.svg or another machine: another journal.
        assert_eq!(journal_in(dir, "/home/me/Duck Drawing.svg", "AxiDraw V3 (A4)"), a);
        assert_ne!(journal_in(dir, "/tmp/Duck Drawing.svg", "AxiDraw V3 (A4)"), a);
        assert_ne!(journal_in(dir, "/home/me/Duck Drawing.svg", "AxiDraw SE/A3"), a);
        // Nothing file-safe left: a word instead.
        let odd = journal_in(dir, "/x/(((.svg", "???");
        assert!(odd.to_str().unwrap().starts_with("/s/journals/drawing-machine-"), "{}", odd.display());
        assert_eq!(fnv1a(b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a(b"a"), 0xaf63_dc4c_8601_ec8c);
    }

    /// The hash by the published FNV-1a definition, byte by byte.
    fn expected_hash() -> u64 {
        let mut h: u64 = 14_695_981_039_346_656_037;
        for b in "/home/me/Duck Drawing.svg\nAxiDraw V3 (A4)".bytes() {
            h ^= u64::from(b);
            h = h.wrapping_mul(1_099_511_628_211);
        }
        h & 0xffff_ffff
    }

    #[test]
    fn the_state_directory_follows_the_environment() {
        fn env<'a>(vars: &'a [(&'a str, &'a str)]) -> impl Fn(&str) -> Option<std::ffi::OsString> + 'a {
            move |k| vars.iter().find(|(n, _)| *n == k).map(|(_, v)| std::ffi::OsString::from(v))
        }
        let all = [("PLOTTER_STATE_DIR", "/p"), ("XDG_STATE_HOME", "/x"), ("HOME", "/h")];
        assert_eq!(state_dir_from(env(&all)).unwrap(), PathBuf::from("/p"));
        let xdg = [("PLOTTER_STATE_DIR", ""), ("XDG_STATE_HOME", "/x"), ("HOME", "/h")];
        assert_eq!(state_dir_from(env(&xdg)).unwrap(), PathBuf::from("/x/plotter"));
        let relative = [("XDG_STATE_HOME", "relative"), ("HOME", "/h")];
        assert_eq!(state_dir_from(env(&relative)).unwrap(), PathBuf::from("/h/.local/state/plotter"));
        assert!(matches!(state_dir_from(env(&[])), Err(StateDirError::NoHome)));
    }

    #[test]
    fn listing_shows_unfinished_plots_newest_first_and_pruning_keeps_them() {
        let dir = temp("list");
        std::fs::create_dir_all(&dir).unwrap();
        let src = |d: &str| format!("{{\"drawing\":\"{d}\",\"machine\":\"XY kit\",\"args\":[]}}");
        let a = journal_in(&dir, "a.svg", "XY kit");
        let mut j = Journal::create(&a, &src("a.svg"), 1, 200).unwrap();
        j.record(60, 50, 60).unwrap();
        drop(j);
        std::thread::sleep(Duration::from_millis(20));
        let b = journal_in(&dir, "b.svg", "XY kit");
        let mut j = Journal::create(&b, &src("b.svg"), 2, 40).unwrap();
        j.record(40, 10, 40).unwrap();
        drop(j);
        let done = journal_in(&dir, "done.svg", "XY kit");
        let mut j = Journal::create(&done, &src("done.svg"), 3, 10).unwrap();
        j.record(10, 10, 10).unwrap();
        j.complete().unwrap();
        drop(j);
        // Copy 1 of 2 finished, stopped at the paper change: the plot still owes copy 2.
        let owed = journal_in(&dir, "owed.svg", "XY kit");
        let owed_src = r#"{"drawing":"owed.svg","machine":"XY kit","args":[],"copy":1,"copies":2}"#;
        let mut j = Journal::create(&owed, owed_src, 4, 10).unwrap();
        j.record(10, 10, 10).unwrap();
        j.complete().unwrap();
        drop(j);
        std::fs::write(dir.join("junk.journal"), "not a journal\n").unwrap();
        std::fs::write(dir.join("notes.txt"), "x").unwrap();
        let list = resumable(&dir).unwrap();
        let seen: Vec<_> = list.iter().map(|e| (e.drawing.as_str(), e.machine.as_str(), e.percent())).collect();
        assert_eq!(seen.len(), 3);
        assert!(seen.contains(&("owed.svg", "XY kit", 100.0)), "{seen:?}");
        let unfinished: Vec<_> = seen.into_iter().filter(|e| e.0 != "owed.svg").collect();
        assert_eq!(unfinished, [("b.svg", "XY kit", 25.0), ("a.svg", "XY kit", 25.0)]);
        assert!(list.iter().position(|e| e.path == b) < list.iter().position(|e| e.path == a));
        // Finished journals go once older than the time kept; unfinished ones stay whatever their age.
        assert_eq!(prune_finished(&dir, KEEP_FINISHED).unwrap(), 0);
        assert!(done.exists());
        assert_eq!(prune_finished(&dir, Duration::ZERO).unwrap(), 1);
        assert!(!done.exists() && a.exists() && b.exists() && owed.exists());
        assert!(resumable(&dir.join("missing")).unwrap().is_empty());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
