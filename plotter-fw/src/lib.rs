//! # plotter-fw — the firmware core shared by the pen plotter and a 3D printer
//!
//! `#![no_std]`, no allocation; builds for `thumbv7em-none-eabihf`. The `std` feature (default) adds `sim`, the
//! host simulator. The same code runs on both sides of the wire:
//!
//! - firmware: [`machine::Machine`] on a board's [`hal::Hal`] — line input ([`line_buffer`], [`gcode`]),
//!   sequencing and resends ([`protocol`]), framed replies and real-time commands ([`framing`]), the planner
//!   queue ([`planner`]), the step-block contract ([`step_block`]), the Bresenham [`stepper`], [`homing`],
//!   [`limits`], checked number [`range`]s, [`realtime`] commands, completion [`report`]s, the [`errors`] table,
//!   and the printer's heaters ([`thermal`]: PID, autotune, thermal-runaway protection);
//! - host: the same [`planner`] over a whole drawing, [`step_block::StepBlock::duration_ticks`] for the exact
//!   execution time, and [`protocol::Encoder`] for the compact step-block frames.
//!
//! # Layers
//! The source sits in four folders, one per layer; a module imports only from its own layer or below, never from
//! a higher one (`tests/layers.rs` reads every `crate::` path and fails on an upward import or a cycle):
//!
//! ```text
//!  3  machine/   orchestration    Machine: host link, motion queue, program state, homing, heaters, alarms
//!        │                                                                      (sim, std only, sits above it)
//!  2  drivers/   HAL and drivers  hal (board traits), stepper (step interrupt), heater_driver
//!        │
//!  1  logic/     pure algorithms  gcode, thermal_gcode, estop, protocol, framing, line_buffer, realtime,
//!        │       and codecs       report, planner, limits, homing (state machine), thermal (thermistor,
//!        │       shared with      PID, autotune, safety)
//!        │       the host
//!  0  types/     leaf types       axis, fmath, decimal, range, config, step_block (the timing contract the
//!                                 host reproduces), heater (identities), errors (error and alarm codes)
//! ```
//!
//! The folders are private; every module is public at the crate root (`plotter_fw::planner`), so a path names
//! the concept, not the layer.
//!
//! ```
//! use plotter_fw::planner::{PlanBlock, link_all, plan, step_blocks, total_ticks};
//! use plotter_fw::MachineConfig;
//!
//! let cfg = MachineConfig::xy_plotter();
//! // Two sides of a square, 10 mm each, at 50 mm/s.
//! let mut blocks: Vec<PlanBlock> = [[800, 0, 0, 0], [0, 800, 0, 0]]
//!     .iter()
//!     .filter_map(|s| PlanBlock::line(&cfg, *s, 50.0))
//!     .collect();
//! link_all(&mut blocks, &cfg);
//! plan(&mut blocks, 0.0);
//! let ticks = total_ticks(&blocks); // exactly what the stepper will take, in µs
//! assert!(ticks > 400_000 && ticks < 500_000);
//! assert_eq!(step_blocks(&blocks).last().unwrap().exit_rate, 0);
//! ```
#![cfg_attr(not(feature = "std"), no_std)]

#[cfg(test)]
extern crate std;

mod drivers;
mod logic;
pub mod machine;
#[cfg(feature = "std")]
pub mod sim;
#[cfg(any(test, feature = "proptest"))]
#[doc(hidden)]
pub mod testing;
mod types;

// The layers are private folders; their modules are public at the crate root, so a path names the concept
// (`plotter_fw::planner`), not the layer.
pub use drivers::{hal, heater_driver, stepper};
pub use logic::{
    estop, framing, gcode, homing, limits, line_buffer, planner, protocol, realtime, report, thermal, thermal_gcode,
};
pub use types::{axis, config, decimal, errors, fmath, heater, range, step_block};

pub use axis::{Axis, NUM_AXES};
pub use config::MachineConfig;
pub use step_block::{SERVO_TENTHS_MAX, StepBlock, TICK_HZ};
