//! Hardware abstraction: what the firmware core needs from a board.
//!
//! A board (or the simulator, [`crate::sim`]) implements these small traits; [`Hal`] bundles them. The core is
//! generic over `H: Hal`, so calls are monomorphised and inlined — the stepper tick calls [`StepPins::step`] and
//! [`Endstops::pressed`] directly with no dynamic dispatch.
//!
//! Wiring on a board: the UART receive interrupt passes each byte to [`crate::machine::Machine::receive`], the step
//! timer interrupt calls [`crate::machine::Machine::on_timer`], and the main loop calls
//! [`crate::machine::Machine::poll`].

use crate::axis::Axis;

/// Step and direction outputs, one pair per axis, plus the drivers' enable line.
pub trait StepPins {
    /// Set the direction pin level of `axis` (the stepper applies the configured inversion before calling).
    /// Always called before the steps it applies to.
    fn set_dir(&mut self, axis: Axis, level: bool);
    /// Emit one step pulse on `axis`.
    fn step(&mut self, axis: Axis);
    /// Energise (`true`, M17) or release (`false`, M18) the motor drivers.
    fn enable_motors(&mut self, on: bool);
}

/// Endstop (limit/homing switch) inputs.
pub trait Endstops {
    /// Bit mask of pressed switches, bit `axis.bit()` per axis.
    fn pressed(&mut self) -> u8;
}

/// A one-shot step timer counting at [`crate::stepper::TICK_HZ`].
pub trait StepTimer {
    /// Fire the timer interrupt `ticks` timer ticks after the previous timer event (or after now, when the
    /// stepper was idle). `ticks ≥ 1`.
    fn schedule(&mut self, ticks: u32);
    /// Stop the timer (the stepper went idle).
    fn cancel(&mut self);
}

/// Serial output towards the host.
pub trait SerialOut {
    /// Queue `bytes` for transmission. Replies are short; a board buffers them (the simulator keeps them all).
    fn write(&mut self, bytes: &[u8]);
}

/// A free-running clock.
pub trait Clock {
    /// Time since start in [`crate::stepper::TICK_HZ`] ticks.
    fn now(&self) -> u64;
}

/// Everything a board provides.
pub trait Hal: StepPins + Endstops + StepTimer + SerialOut + Clock {}

impl<T: StepPins + Endstops + StepTimer + SerialOut + Clock> Hal for T {}
