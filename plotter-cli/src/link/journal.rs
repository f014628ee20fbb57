//! The resume journal: which blocks of a plot the firmware has accepted and executed, written as the plot runs.
//!
//! A small append-only text file. Every line is handed to the operating system with one `write` as it happens (so
//! it survives the host process being killed), and a background thread makes it durable with `fdatasync` (so it
//! survives a power loss too) without the stream ever waiting for the disk: the syncer folds all lines written
//! since its last sync into the next one.
//!
//! ```text
//! plotter-journal 1
//! source <JSON: what was plotted and how, enough to rebuild the same plan>
//! plan <geometry hash> <number of blocks>
//! progress <accepted> <executed> <firmware sequence number after the accepted blocks>
//! progress ...
//! complete
//! ```
//!
//! Block numbers are those of the original plan, also after a resume. Reading takes the last complete
//! `progress` line; a torn last line (the host died while writing) is ignored.

use std::fs::{File, OpenOptions};
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Condvar, Mutex};
use std::thread::JoinHandle;

use anyhow::{Context as _, bail};

/// What a journal file says.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct JournalState {
    /// The plot's source description (JSON written by the caller).
    pub source: String,
    /// Geometry hash of the original plan.
    pub plan_hash: u64,
    /// Blocks in the original plan.
    pub blocks: usize,
    /// Blocks accepted by the firmware.
    pub accepted: usize,
    /// Blocks certainly executed.
    pub executed: usize,
    /// The firmware's sequence number once it has taken every accepted block.
    pub seq_after_accepted: u32,
    /// The plot finished.
    pub complete: bool,
}

/// An open journal being written.
pub struct Journal {
    file: File,
    path: PathBuf,
    last: (usize, usize, u32),
    syncer: Syncer,
}

/// What the journal and its syncer thread share: lines written and not yet synced; the journal is closing.
#[derive(Default)]
struct SyncState {
    dirty: bool,
    closing: bool,
}

/// The background thread that makes written lines durable (see the module docs).
struct Syncer {
    shared: Arc<(Mutex<SyncState>, Condvar)>,
    thread: Option<JoinHandle<()>>,
}

impl Syncer {
    fn start(file: &File, path: &Path) -> anyhow::Result<Syncer> {
        let file = file.try_clone().with_context(|| format!("cannot open journal {} twice", path.display()))?;
        let shared = Arc::new((Mutex::new(SyncState::default()), Condvar::new()));
        let theirs = Arc::clone(&shared);
        let thread = std::thread::Builder::new()
            .name("journal-sync".into())
            .spawn(move || {
                let (lock, wake) = &*theirs;
                loop {
                    let mut st = lock.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
                    while !st.dirty && !st.closing {
                        st = wake.wait(st).unwrap_or_else(std::sync::PoisonError::into_inner);
                    }
                    let (dirty, closing) = (st.dirty, st.closing);
                    st.dirty = false;
                    drop(st);
                    if dirty {
                        // A failed sync leaves the lines in the page cache: still good against a killed host.
                        let _ = file.sync_data();
                    }
                    if closing {
                        return;
                    }
                }
            })
            .context("cannot start the journal's sync thread")?;
        Ok(Syncer { shared, thread: Some(thread) })
    }

    /// New lines were written: sync them soon.
    fn poke(&self) {
        let (lock, wake) = &*self.shared;
        lock.lock().unwrap_or_else(std::sync::PoisonError::into_inner).dirty = true;
        wake.notify_one();
    }
}

impl Drop for Syncer {
    /// The last lines are synced before the journal is closed.
    fn drop(&mut self) {
        let (lock, wake) = &*self.shared;
        lock.lock().unwrap_or_else(std::sync::PoisonError::into_inner).closing = true;
        wake.notify_one();
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Journal {
    /// Start a new journal at `path` (replacing an old one).
    pub fn create(path: &Path, source: &str, plan_hash: u64, blocks: usize) -> anyhow::Result<Journal> {
        let mut file = File::create(path).with_context(|| format!("cannot create journal {}", path.display()))?;
        file.write_all(format!("plotter-journal 1\nsource {source}\nplan {plan_hash:016x} {blocks}\n").as_bytes())?;
        file.sync_data().with_context(|| format!("cannot sync journal {}", path.display()))?;
        let syncer = Syncer::start(&file, path)?;
        Ok(Journal { file, path: path.to_path_buf(), last: (0, 0, 0), syncer })
    }

    /// Continue an existing journal (after a resume); a torn last line is cut off first.
    pub fn append(path: &Path, state: &JournalState) -> anyhow::Result<Journal> {
        let text = std::fs::read(path).with_context(|| format!("cannot read journal {}", path.display()))?;
        let keep = text.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
        let file = OpenOptions::new()
            .append(true)
            .open(path)
            .with_context(|| format!("cannot open journal {}", path.display()))?;
        file.set_len(u64::try_from(keep).unwrap_or(u64::MAX))?;
        let syncer = Syncer::start(&file, path)?;
        Ok(Journal {
            file,
            path: path.to_path_buf(),
            last: (state.accepted, state.executed, state.seq_after_accepted),
            syncer,
        })
    }

    /// Record progress (in original block numbers); unchanged values are not written again. The line is written
    /// at once (one `write`), made durable in the background.
    pub fn record(&mut self, accepted: usize, executed: usize, seq_after_accepted: u32) -> anyhow::Result<()> {
        let now = (accepted, executed, seq_after_accepted);
        if now != self.last {
            self.file
                .write_all(format!("progress {accepted} {executed} {seq_after_accepted}\n").as_bytes())
                .with_context(|| format!("cannot write journal {}", self.path.display()))?;
            self.syncer.poke();
            self.last = now;
        }
        Ok(())
    }

    /// Mark the plot complete (synced before returning).
    pub fn complete(&mut self) -> anyhow::Result<()> {
        self.file.write_all(b"complete\n")?;
        self.file.sync_data().with_context(|| format!("cannot sync journal {}", self.path.display()))?;
        Ok(())
    }
}

/// Read a journal file.
pub fn load(path: &Path) -> anyhow::Result<JournalState> {
    let text = std::fs::read_to_string(path).with_context(|| format!("cannot read journal {}", path.display()))?;
    let shown = path.display();
    // Only lines terminated by '\n' count: the last one may be torn.
    let complete_text = &text[..text.rfind('\n').map_or(0, |i| i + 1)];
    let mut lines = complete_text.lines();
    if lines.next() != Some("plotter-journal 1") {
        bail!("{shown}: not a plotter journal");
    }
    let source = lines
        .next()
        .and_then(|l| l.strip_prefix("source "))
        .with_context(|| format!("{shown}:2: missing source line"))?
        .to_string();
    let plan =
        lines.next().and_then(|l| l.strip_prefix("plan ")).with_context(|| format!("{shown}:3: missing plan"))?;
    let (hash, blocks) = plan.split_once(' ').with_context(|| format!("{shown}:3: bad plan line"))?;
    let plan_hash = u64::from_str_radix(hash, 16).with_context(|| format!("{shown}:3: bad plan hash"))?;
    let blocks = blocks.parse().with_context(|| format!("{shown}:3: bad block count"))?;
    let mut st =
        JournalState { source, plan_hash, blocks, accepted: 0, executed: 0, seq_after_accepted: 0, complete: false };
    for (i, l) in lines.enumerate() {
        if l == "complete" {
            st.complete = true;
            continue;
        }
        let v: Vec<&str> = l.split(' ').collect();
        let parsed = match v.as_slice() {
            ["progress", a, e, s] => a.parse().ok().zip(e.parse().ok()).zip(s.parse().ok()),
            _ => None,
        };
        let ((a, e), s) = parsed.with_context(|| format!("{shown}:{}: unreadable line {l:?}", i + 4))?;
        if a > blocks || e > a {
            bail!("{shown}:{}: progress {a} {e} does not fit a plan of {blocks} blocks", i + 4);
        }
        (st.accepted, st.executed, st.seq_after_accepted) = (a, e, s);
    }
    Ok(st)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn write_read_and_torn_lines() {
        let dir = std::env::temp_dir().join(format!("plotter-journal-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("j");
        let mut j = Journal::create(&p, "{\"input\":\"a.svg\"}", 0xabc, 100).unwrap();
        j.record(10, 2, 10).unwrap();
        j.record(10, 2, 10).unwrap();
        j.record(40, 30, 40).unwrap();
        let st = load(&p).unwrap();
        assert_eq!(
            (st.accepted, st.executed, st.seq_after_accepted, st.blocks, st.plan_hash),
            (40, 30, 40, 100, 0xabc)
        );
        assert_eq!(st.source, "{\"input\":\"a.svg\"}");
        assert!(!st.complete);
        assert_eq!(std::fs::read_to_string(&p).unwrap().matches("progress").count(), 2);
        // A torn line is ignored.
        let mut f = OpenOptions::new().append(true).open(&p).unwrap();
        write!(f, "progress 99 9").unwrap();
        assert_eq!(load(&p).unwrap().accepted, 40);
        drop(f);
        let mut j = Journal::append(&p, &st).unwrap();
        j.record(100, 100, 100).unwrap();
        j.complete().unwrap();
        let st = load(&p).unwrap();
        assert!(st.complete && st.accepted == 100);
        std::fs::write(&p, "plotter-journal 1\nsource x\nplan 1 5\nprogress 6 1 6\n").unwrap();
        assert!(load(&p).unwrap_err().to_string().contains(":4: progress 6 1"));
        std::fs::write(&p, "hello\n").unwrap();
        assert!(load(&p).unwrap_err().to_string().contains("not a plotter journal"));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
