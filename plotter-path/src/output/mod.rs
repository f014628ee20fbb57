//! Outputs: preview PNGs, plain-SVG and G-code export, and figures about a drawing.

pub mod gcode_out;
pub mod preview;
pub mod stats;
pub mod svg_out;
