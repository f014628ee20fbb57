//! The plot studio: several plotters served from one computer, fed from one job queue that survives a crash.
//!
//! It sits above the plot job: a job in the queue is a drawing with its layout and plot options, for one named
//! machine or for the first idle machine whose work area fits it, and each machine's worker takes its
//! next job from the queue and drives the same job API the `plot` command uses.
//!
//! - [`store`]: the SQLite database under the state directory that holds the machines, the jobs (with the
//!   drawing's bytes) and their history; its schema is versioned and migrated on open, every change is one
//!   transaction, and a database from a newer version is refused.
//! - [`queue`]: what can be done to the queue — add, list, reorder, cancel, retry, claim a machine's next job,
//!   record its end — and what a crash leaves behind: a job that was plotting comes back *interrupted*, waiting for
//!   the operator to confirm the paper is still in place, never restarted on its own.
//! - [`lock`]: one process at a time opens a folder's queue;
//! - [`machines`]: the machines as the user names them (`--machine`, a studio file);
//! - [`job_args`]: a job's stored plot flags, read as `plotter plot` reads them, and whether its paper fits a
//!   machine;
//! - [`running`]: a running studio — the queue and the machines, and what the operator does to them;
//! - [`status`]: what each machine is doing and what the operator asked of it;
//! - [`worker`]: one thread per machine that owns its link and plots the jobs the queue gives it;
//! - [`state`]: where a job is in its life (queued, plotting, paused, interrupted, done, failed, cancelled);
//! - [`error`]: the studio's errors, each naming the job, machine or file concerned.
//!
//! ```
//! use plotter_host::studio::queue::{NewJob, Queue};
//! let dir = std::env::temp_dir().join(format!("studio-doc-{}", std::process::id()));
//! let mut queue = Queue::open_in(&dir)?;
//! queue.add_machine("left", "/dev/ttyACM0", "auto", None)?;
//! let id = queue.add(&NewJob::new("duck.svg", b"<svg/>".to_vec()).for_machine("left"))?;
//! let job = queue.claim_next("left", &mut |_| true)?.expect("the duck is waiting");
//! assert_eq!(job.summary.id, id);
//! # std::fs::remove_dir_all(&dir).ok();
//! # Ok::<(), plotter_host::studio::error::StudioError>(())
//! ```

pub mod error;
pub mod job_args;
pub mod lock;
pub mod machines;
pub mod queue;
pub mod running;
pub mod state;
pub mod status;
pub mod store;
pub mod worker;
