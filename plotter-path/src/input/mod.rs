//! Inputs: everything that becomes a [`crate::Drawing`] — SVG files, G-code from other tools, the seed trajectory
//! format, HP-GL plot files, raster images traced into paths, and parametric figures.

pub mod gcode_in;
pub mod gcode_print;
pub mod gcode_words;
pub mod r#gen;
pub mod hpgl_in;
pub mod raster;
pub mod skipped;
pub mod svg;
pub mod trajectory;
pub(crate) mod warn_tally;

#[cfg(test)]
mod fuzz;
