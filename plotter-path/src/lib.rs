//! # plotter-path — the geometry pipeline of the plotter
//!
//! Everything before the wire: inputs (SVG, raster images, parametric curves, G-code, trajectory files) become a
//! [`Drawing`] of millimetre polylines; the drawing is laid out on the page, its paths are ordered to waste little
//! pen-up travel, the motion is planned with the firmware's own planner, and the result becomes drift-free step
//! blocks. Every stage can be previewed as a PNG and measured with [`stats`].
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

pub mod drawing;
pub mod flatten;
pub mod gcode_in;
pub mod gcode_out;
pub mod r#gen;
pub mod layout;
pub mod motion;
pub mod optimize;
pub mod preview;
pub mod profile;
pub mod raster;
pub mod stats;
pub mod steps;
pub mod svg;
pub mod svg_out;
pub mod trajectory;
pub mod travel;

pub use drawing::{Drawing, Layer, Pen, Polyline, Rgb};
pub use kurbo;
pub use profile::MachineProfile;
