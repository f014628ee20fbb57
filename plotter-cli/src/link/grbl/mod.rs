//! GRBL 1.1 (and grblHAL / FluidNC, which speak the same protocol) as a firmware dialect: the plot streamed as
//! G-code with character-counting flow control.
//!
//! - [`messages`]: the controller's lines and the documented meaning of its error and alarm codes;
//! - [`settings`]: `$$` against the machine profile;
//! - [`program`]: a motion plan as G-code lines, one per block;
//! - [`session`]: connecting, settings, homing and unlocking, status, the streaming itself;
//! - [`emulator`] and [`emulator_transport`]: a GRBL controller of our own for tests and `plotter sim --grbl`.

pub mod emulator;
pub mod emulator_transport;
pub mod messages;
pub mod program;
pub mod session;
pub mod settings;
