//! The studio's claim on its state directory: one process at a time opens the queue, because opening it marks the
//! jobs it finds on a machine as interrupted — a second studio (or a second server) on the same folder would mark
//! the first one's running jobs.
//!
//! The claim is an exclusive `flock` on `studio.lock` in the folder, held while the [`StudioLock`] lives; the
//! system drops it when the process ends in any way, a SIGKILL included, so a crash never leaves a stale lock.

use std::fs::{File, OpenOptions};
use std::path::{Path, PathBuf};

use nix::fcntl::{Flock, FlockArg};

use super::error::{Result, StudioError};

/// The lock file's name in the state directory.
pub const LOCK_FILE: &str = "studio.lock";

/// This process's hold on a studio folder.
#[derive(Debug)]
pub struct StudioLock {
    _lock: Flock<File>,
    path: PathBuf,
}

impl StudioLock {
    /// Takes the folder `dir` (which must exist) for this process, or says which folder is already taken.
    pub fn take(dir: &Path) -> Result<StudioLock> {
        let path = dir.join(LOCK_FILE);
        let file = OpenOptions::new()
            .create(true)
            .truncate(false)
            .write(true)
            .open(&path)
            .map_err(|source| StudioError::Folder { path: path.clone(), source })?;
        match Flock::lock(file, FlockArg::LockExclusiveNonblock) {
            Ok(lock) => Ok(StudioLock { _lock: lock, path }),
            Err((_, nix::errno::Errno::EWOULDBLOCK)) => Err(StudioError::InUse { dir: dir.to_path_buf() }),
            Err((_, errno)) => Err(StudioError::Folder { path, source: std::io::Error::from(errno) }),
        }
    }

    /// The lock file.
    pub fn path(&self) -> &Path {
        &self.path
    }
}
