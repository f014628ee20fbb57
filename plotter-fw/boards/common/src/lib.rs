//! # plotter-board — the glue every plotter-fw board image shares
//!
//! A board crate (`nucleo-l476rg`, `qemu-lm3s6965`) implements the core's HAL traits
//! ([`plotter_fw::hal`]) on its pins, timer and UART, and wires the three entry points of
//! [`plotter_fw::machine::Machine`] to its interrupts. What does not depend on the chip lives here, so that both
//! boards have the same structure and the logic is tested on the host:
//!
//! - [`shared`]: the machine behind a critical section, called from the UART and timer interrupts and the main
//!   loop;
//! - [`deadline`]: drift-free step-timer deadlines ("`ticks` after the previous event", 32-bit wrapping);
//! - [`debounce`]: the endstop filter (a press needs two readings, a release must hold for a window);
//! - [`fault`]: the panic/fault reason kept in no-init RAM across the reset, and [`note`]: the start-up line that
//!   reports it with the reset cause, just before the firmware's banner;
//! - [`servo`]: a hobby-servo pen lift driven by the Z axis's steps;
//! - [`stm32_step`]: the step-event path of an STM32 board (step pins, compare timer, pulse end by DMA), shared
//!   by the Nucleo image and the tick bench that prices it.
//!
//! No parsing, planning or protocol logic lives in a board: that is the core's.
//!
//! ```
//! use plotter_board::debounce::Debouncer;
//! let mut d = Debouncer::new(1_000);
//! assert_eq!(d.update(0b001, 0), 0); // one reading is not a press yet
//! assert_eq!(d.update(0b001, 50), 0b001); // a second one is
//! ```
#![cfg_attr(not(test), no_std)]

pub mod deadline;
pub mod debounce;
pub mod fault;
pub mod note;
pub mod servo;
pub mod shared;
pub mod stm32_step;
