//! The studio's errors: each says what went wrong and names the job, machine or database file concerned.

use std::path::PathBuf;

use super::state::JobState;

/// What went wrong in the studio's queue or its database.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum StudioError {
    /// The state directory (or the database's folder) could not be created.
    #[error("{path}: cannot create the studio's folder: {source}")]
    Folder {
        /// The folder.
        path: PathBuf,
        /// What the system said.
        source: std::io::Error,
    },
    /// Another process (a studio or server started earlier) has the queue in this folder open.
    #[error(
        "{dir}: another plotter studio is using this folder; stop it first, or give this one another --state folder"
    )]
    InUse {
        /// The state directory.
        dir: PathBuf,
    },
    /// The database file could not be opened or read.
    #[error("{path}: cannot open the studio's database: {source}")]
    Open {
        /// The database file.
        path: PathBuf,
        /// What SQLite said.
        source: rusqlite::Error,
    },
    /// The database was written by a newer version of the plotter, whose changes this one does not know.
    #[error(
        "{path}: the studio's database is at schema version {found}, newer than this plotter knows ({supported}); \
         use the newer plotter, or give this one another --state folder"
    )]
    Newer {
        /// The database file.
        path: PathBuf,
        /// Its schema version.
        found: i64,
        /// The newest version this build knows.
        supported: i64,
    },
    /// A read or a change of the database failed (nothing of a failed change was kept).
    #[error("the studio's database, while {doing}: {source}")]
    Db {
        /// What was being done.
        doing: &'static str,
        /// What SQLite said.
        source: rusqlite::Error,
    },
    /// The database holds a value this version cannot read.
    #[error("the studio's database holds {what}, which this plotter cannot read")]
    Corrupt {
        /// The value and where it was.
        what: String,
    },
    /// Something given to the queue is over its limit.
    #[error("{what} is {size} bytes, more than the {limit} bytes the queue accepts")]
    TooLarge {
        /// What is too large.
        what: String,
        /// Its size in bytes.
        size: usize,
        /// The limit in bytes.
        limit: usize,
    },
    /// A name or value given to the queue is not acceptable.
    #[error("{0}")]
    Invalid(String),
    /// The queue already holds as many waiting jobs as it accepts.
    #[error("the queue already holds {0} waiting jobs; cancel or finish some before adding more")]
    QueueFull(usize),
    /// No job has this number.
    #[error("there is no job {0} in the queue")]
    NoJob(i64),
    /// No machine has this name.
    #[error("there is no machine named \"{0}\" in the studio")]
    NoMachine(String),
    /// The job is not in a state that allows this.
    #[error("job {id} is {state}: it cannot be {action}")]
    WrongState {
        /// The job.
        id: i64,
        /// The state it is in.
        state: JobState,
        /// What was asked (in words: "moved", "retried", …).
        action: &'static str,
    },
    /// The machine is not idle: it holds a job that is plotting, paused, or interrupted and waiting for the
    /// operator.
    #[error("machine \"{machine}\" is not idle: job {job} is {state} on it")]
    Busy {
        /// The machine.
        machine: String,
        /// The job it holds.
        job: i64,
        /// That job's state.
        state: JobState,
    },
}

/// The studio's result.
pub type Result<T, E = StudioError> = std::result::Result<T, E>;
