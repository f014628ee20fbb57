//! # plotter-host — the host library behind every front end of the plotter
//!
//! The `plotter` command and the local web app both drive the machine through this library; they only parse
//! their arguments and display. The package is `plotter-cli` because it ships the `plotter` command (its files are
//! all under `src/bin/plotter/`: `cmd/` one file per subcommand, `serve/` the web app); the library is named
//! `plotter_host` because it is the host side of the link whose other side is the firmware, `plotter-fw`, and both
//! front ends are built on it. `src/` outside `bin/` is the library alone; no library module imports a front end.
//! It holds:
//!
//! - [`options`]: the layout, optimization and tracing options (as `clap` flag groups, which the web app fills
//!   in directly);
//! - [`input`]: the one loader for every input kind (SVG, PNG/JPEG traced, G-code, trajectory files, `gen:`
//!   figures);
//! - [`job`]: the plot job — load, lay out, optimize, plan, stream with pauses and a journal, resume, progress
//!   events — and the as-stepped drawing of a simulated plot;
//! - [`link`]: the byte transports (serial port, in-process simulator, fault injection), the session with the
//!   firmware, block streaming with flow control and resends, and the resume journal; connecting to a port of any
//!   firmware dialect, jogging and the console's keys, which both front ends offer;
//! - [`studio`]: the plot studio's job queue for several machines, kept in a SQLite database in the state
//!   directory so that it survives a crash;
//! - [`state_dir`]: where the plotter keeps its own files (resume journals), in the user's state directory;
//! - [`error`]: the typed [`Error`] its functions return, with the causes a front end acts on (a refused block,
//!   an alarm, a lost port, a firmware that is not the expected one, a bad input file, a plot the user stopped).
//!
//! ```
//! use plotter_host::job::{self, load::load_profile, progress::{JobProgress, PlotEvents}};
//! use plotter_host::link::{session::Session, sim::SimTransport};
//! use plotter_path::kurbo::Point;
//! use plotter_path::{geometry::steps::drawing_to_steps, motion::plan::machine_config};
//! use plotter_path::{Drawing, Polyline};
//!
//! struct Quiet;
//! impl PlotEvents for Quiet {
//!     fn progress(&mut self, _: &JobProgress) {}
//! }
//! # fn main() -> anyhow::Result<()> {
//! let profile = load_profile(None)?; // the built-in XY plotter kit
//! let square = Polyline::new(vec![
//!     Point::new(20.0, 20.0), Point::new(30.0, 20.0), Point::new(30.0, 30.0), Point::new(20.0, 20.0),
//! ]);
//! let steps = drawing_to_steps(&profile, &Drawing::single_layer("square", vec![square]))?;
//! let mut session = Session::connect(SimTransport::new(machine_config(&profile)?, None), "simulated plotter")?;
//! let outcome = job::plot(&mut session, &profile, &steps, true, false, None, &mut Quiet)?;
//! assert!(outcome.plan.draw_mm > 34.0 && outcome.plan.draw_mm < 34.2); // 10 + 10 + 10√2 mm
//! # Ok(()) }
//! ```

pub mod error;
pub mod input;
pub mod job;
pub mod link;
pub mod options;
pub mod state_dir;
pub mod stop;
pub mod studio;

pub use error::{Error, Result, Trouble};
