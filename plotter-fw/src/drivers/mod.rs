//! Layer 2, the hardware-abstraction traits and the drivers built on them: [`hal`] (what a board provides), the
//! interrupt-driven step executor ([`stepper`]) and the heater driver. They import layers 0 and 1, never the
//! machine.

pub mod hal;
pub mod heater_driver;
pub mod stepper;
