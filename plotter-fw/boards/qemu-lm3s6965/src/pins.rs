//! The pin map of the emulated board — the one place that says which pin does what.
//!
//! | Function                 | Pin        | QEMU model                                   |
//! |--------------------------|------------|----------------------------------------------|
//! | X, Y, Z, E step          | PD0..PD3   | PL061 outputs, traced as `pl061_set_output`  |
//! | X, Y, Z, E direction     | PD4..PD7   | PL061 outputs                                |
//! | drivers enable (low = on)| PB0        | PL061 output                                 |
//! | X, Y, Z, E endstop       | PE0..PE3   | the board's gamepad keys up/down/left/right, |
//! |                          |            | active low (pressed = 0), pull-ups on        |
//! | host serial              | UART0      | PL011, `-serial pty`                         |
//!
//! `plotter sim --qemu` counts the step pulses from QEMU's GPIO trace events and drives the endstops through
//! QEMU's input events (QMP `input-send-event`), so both sides of the wire are checked from outside the
//! firmware.

use plotter_fw::{Axis, NUM_AXES};

use crate::regs::gpio;

/// Port of the step and direction pins.
pub(crate) const STEP_PORT: usize = gpio::PORT_D;
/// Step pin mask per axis (X, Y, Z, E).
pub(crate) const STEP: [u8; NUM_AXES] = [1 << 0, 1 << 1, 1 << 2, 1 << 3];
/// Direction pin mask per axis.
pub(crate) const DIR: [u8; NUM_AXES] = [1 << 4, 1 << 5, 1 << 6, 1 << 7];
/// Port and mask of the drivers' enable line (active low).
pub(crate) const ENABLE_PORT: usize = gpio::PORT_B;
/// Enable pin.
pub(crate) const ENABLE: u8 = 1 << 0;
/// Port of the endstops.
pub(crate) const ENDSTOP_PORT: usize = gpio::PORT_E;
/// Endstop pin mask per axis (active low).
pub(crate) const ENDSTOP: [u8; NUM_AXES] = [1 << 0, 1 << 1, 1 << 2, 1 << 3];

/// Mask of every step pin.
pub(crate) const ALL_STEP: u8 = STEP[0] | STEP[1] | STEP[2] | STEP[3];
/// Mask of every direction pin.
pub(crate) const ALL_DIR: u8 = DIR[0] | DIR[1] | DIR[2] | DIR[3];
/// Mask of every endstop pin.
pub(crate) const ALL_ENDSTOP: u8 = ENDSTOP[0] | ENDSTOP[1] | ENDSTOP[2] | ENDSTOP[3];

/// Axis mask (bit `axis.bit()`) of the endstops that read pressed in a raw port value.
pub(crate) fn endstops_pressed(port: u8) -> u8 {
    Axis::ALL.iter().filter(|a| port & ENDSTOP[a.index()] == 0).fold(0, |m, a| m | a.bit())
}
