//! Configuration every stage reads, below them all: the machine profile (TOML: axes, work area, page → machine
//! mapping, pen lift, speeds, homing, buffers), the pen table and which of its pens draws which layer, and a
//! printer's heaters. It imports nothing from the stages.

pub mod color;
pub mod heaters;
pub mod interrupt;
pub mod pens;
pub mod profile;
