//! Configuration every stage reads, below them all: the machine profile (TOML: axes, work area, page → machine
//! mapping, pen lift, speeds, homing, buffers), the pen table and which of its pens draws which layer, and a
//! printer's heaters, and the machine models built in. It imports nothing from the stages.

pub mod color;
pub mod gcode_template;
pub mod heaters;
pub mod interrupt;
pub mod layer_codes;
pub mod models;
pub mod pens;
pub mod profile;
pub mod servo_sync;
