//! The EiBotBoard (EBB) as a firmware dialect: AxiDraw, NextDraw, iDraw and other machines on Evil Mad
//! Scientist's board, driven over USB-CDC with ASCII commands ending in CR.
//!
//! - [`kinematics`]: the mixed-axis motors, the 25 kHz step accumulator, fitting `LM` moves;
//! - [`messages`]: the version, replies and the documented meaning of every error;
//! - [`program`]: a motion plan as `LM`/`SM`/`SP` commands with the board's exact time;
//! - [`session`]: connecting, pen set-up, homing, position, streaming with the FIFO's own flow control, stopping;
//! - [`emulator`] and [`emulator_transport`]: a board of our own for tests and `plotter sim --pty --ebb`.

pub mod emulator;
pub mod emulator_transport;
pub mod kinematics;
pub mod messages;
pub mod program;
pub mod session;
