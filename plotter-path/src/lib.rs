//! # plotter-path — the geometry pipeline of the plotter
//!
//! Everything before the wire: inputs (SVG, raster images, parametric curves, G-code, trajectory files) become a
//! [`Drawing`] of millimetre polylines; the drawing is laid out on the page, its paths are ordered to waste little
//! pen-up travel, the motion is planned with the firmware's own planner, and the result becomes drift-free step
//! blocks. Every stage can be previewed as a PNG and measured with [`output::stats`].
//!
//! The modules follow the flow: [`config`] (the machine profile and pen table every stage reads) below
//! [`geometry`] (the drawing model, layout, steps), then the stages [`input`] → [`optimize`] → [`motion`] →
//! [`output`]; each imports only from the ones before it (checked by the workspace's `tests/import_layers.rs`).
//!
//! ```
//! use plotter_path::{Drawing, Polyline};
//! use kurbo::Point;
//!
//! let square = Polyline::new(vec![
//!     Point::new(0.0, 0.0), Point::new(10.0, 0.0), Point::new(10.0, 10.0),
//!     Point::new(0.0, 10.0), Point::new(0.0, 0.0),
//! ]);
//! assert!(square.is_closed());
//! let drawing = Drawing::single_layer("square", vec![square]);
//! assert_eq!(drawing.bbox().unwrap().width(), 10.0);
//! ```

pub mod config;
pub mod geometry;
pub mod input;
pub mod motion;
pub mod optimize;
pub mod output;

pub use config::color::Rgb;
pub use config::pens::Pen;
pub use config::profile::MachineProfile;
pub use geometry::drawing::{Drawing, Layer, Polyline};
pub use kurbo;
