//! # plotter-host — the host library behind every front end of the plotter
//!
//! The `plotter` command and the local web app both drive the machine through this library; they only parse
//! their arguments and display. It holds:
//!
//! - [`options`]: the layout, optimization and tracing options (as `clap` flag groups, which the web app fills
//!   in directly);
//! - [`input`]: the one loader for every input kind (SVG, PNG/JPEG traced, G-code, trajectory files, `gen:`
//!   figures);
//! - [`job`]: the plot job — load, lay out, optimize, plan, stream with pauses and a journal, resume, progress
//!   events — and the as-stepped drawing of a simulated plot;
//! - [`link`]: the byte transports (serial port, in-process simulator, fault injection), the session with the
//!   firmware, block streaming with flow control and resends, and the resume journal.
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

pub mod input;
pub mod job;
pub mod link;
pub mod options;
