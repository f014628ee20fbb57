//! The pin map of the Nucleo-L476RG build — the one place that says which pin does what.
//!
//! CNC-shield style: a GRBL "CNC shield V3" on the Nucleo's Arduino headers (or drivers wired the same way).
//!
//! | Function             | Arduino pin | Nucleo pin | Notes                                          |
//! |----------------------|-------------|------------|------------------------------------------------|
//! | X step               | D2          | PA10       |                                                |
//! | Y step               | D3          | PB3        |                                                |
//! | Z step (pen)         | D4          | PB5        |                                                |
//! | X direction          | D5          | PB4        |                                                |
//! | Y direction          | D6          | PB10       |                                                |
//! | Z direction          | D7          | PA8        |                                                |
//! | drivers enable       | D8          | PA9        | active low (A4988/DRV8825 `EN`)                |
//! | X endstop            | D9          | PC7        | to GND, internal pull-up; pressed = low        |
//! | Y endstop            | D10         | PB6        | "                                              |
//! | Z endstop            | D11         | PA7        | "                                              |
//! | E (A) step           | D12         | PA6        | the shield's A axis (printer extruder)         |
//! | E (A) direction      | D13         | PA5        | also the Nucleo's green LED LD2                |
//! | pen servo signal     | A3          | PB0        | TIM3 CH3, 50 Hz; feature `servo-pen`           |
//! | host serial          | —           | PA2 / PA3  | USART2 = the ST-LINK virtual COM port (USB)    |
//!
//! Drivers and switches share the board's GND; the servo takes 5 V from the shield, its signal from PB0.

use plotter_fw::NUM_AXES;

/// A GPIO pin: port register block address and pin number.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Pin {
    /// GPIOx base address.
    pub(crate) port: usize,
    /// Pin number 0..15.
    pub(crate) n: u8,
}

/// GPIO port A base.
pub(crate) const GPIOA: usize = 0x4800_0000;
/// GPIO port B base.
pub(crate) const GPIOB: usize = 0x4800_0400;
/// GPIO port C base.
pub(crate) const GPIOC: usize = 0x4800_0800;

const fn pin(port: usize, n: u8) -> Pin {
    Pin { port, n }
}

/// Step pins, X Y Z E.
pub(crate) const STEP: [Pin; NUM_AXES] = [pin(GPIOA, 10), pin(GPIOB, 3), pin(GPIOB, 5), pin(GPIOA, 6)];
/// Direction pins, X Y Z E.
pub(crate) const DIR: [Pin; NUM_AXES] = [pin(GPIOB, 4), pin(GPIOB, 10), pin(GPIOA, 8), pin(GPIOA, 5)];
/// Drivers' enable (active low).
pub(crate) const ENABLE: Pin = pin(GPIOA, 9);
/// Endstops X Y Z (E has none), active low with pull-ups.
pub(crate) const ENDSTOP: [Option<Pin>; NUM_AXES] =
    [Some(pin(GPIOC, 7)), Some(pin(GPIOB, 6)), Some(pin(GPIOA, 7)), None];
/// Pen servo on TIM3 CH3 (alternate function 2).
#[cfg_attr(not(feature = "servo-pen"), allow(dead_code, reason = "used with the servo-pen feature"))]
pub(crate) const SERVO: Pin = pin(GPIOB, 0);

/// Host serial speed (8N1). Faster rates: change here and in the machine profile's `link.baud`.
pub(crate) const BAUD: u32 = 115_200;
