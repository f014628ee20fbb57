//! # plotter-fw — the firmware core shared by the pen plotter and a 3D printer
//!
//! `#![no_std]`, no allocation. The `std` feature (default) adds [`sim`], the host simulator.
#![cfg_attr(not(feature = "std"), no_std)]

#[cfg(test)]
extern crate std;

pub mod axis;
pub mod config;
pub mod errors;
pub mod fmath;
pub mod gcode;
pub mod hal;
pub mod homing;
pub mod limits;
pub mod line_buffer;
pub mod machine;
pub mod planner;
pub mod protocol;
pub mod realtime;
#[cfg(feature = "std")]
pub mod sim;
pub mod stepper;

pub use axis::{Axis, NUM_AXES};
pub use config::MachineConfig;
pub use stepper::{StepBlock, TICK_HZ};
