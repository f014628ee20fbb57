//! Outputs: preview PNGs, plain-SVG, G-code and HP-GL export, and figures about a drawing.

pub mod gcode_out;
pub mod hpgl_out;
pub mod preview;
pub mod stats;
pub mod svg_out;
