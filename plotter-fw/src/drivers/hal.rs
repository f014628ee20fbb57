//! Hardware abstraction: what the firmware core needs from a board.
//!
//! A board (or the simulator, [`crate::sim`]) implements these small traits; [`Hal`] bundles them. The core is
//! generic over `H: Hal`, so calls are monomorphised and inlined — the stepper tick calls [`StepPins::step`] and
//! [`Endstops::pressed`] directly with no dynamic dispatch.
//!
//! Wiring on a board: the UART receive interrupt passes each byte to [`crate::machine::Machine::receive`], the step
//! timer interrupt calls [`crate::machine::Machine::on_timer`], and the main loop calls
//! [`crate::machine::Machine::poll`].
//!
//! Heaters are not part of [`Hal`]: a printer board hands its heater outputs and thermistor inputs to
//! [`crate::machine::Machine::with_heaters`] as a separate [`Heaters`] value, and a board without heaters (every
//! plotter) uses [`crate::machine::Machine::new`], which plugs in [`NoHeaters`] — so plotter boards implement
//! nothing for them.

use crate::axis::Axis;
use crate::heater::Heater;

/// Step and direction outputs, one pair per axis, plus the drivers' enable line.
pub trait StepPins {
    /// Set the direction pin level of `axis` (the stepper applies the configured inversion before calling).
    /// Always called before the steps it applies to.
    fn set_dir(&mut self, axis: Axis, level: bool);
    /// Emit one step pulse on `axis`.
    fn step(&mut self, axis: Axis);
    /// Emit one step pulse on every axis in `mask` ([`Axis::bit`]s) at once: the stepper calls this once per step
    /// event. The default steps the axes one by one; boards override it to set the pins together and end all
    /// pulses with one timer compare.
    #[inline]
    fn step_axes(&mut self, mask: u8) {
        for axis in Axis::ALL {
            if mask & axis.bit() != 0 {
                self.step(axis);
            }
        }
    }
    /// [`StepPins::step_axes`] for the step interrupt's event in the middle of a block, returning a value that the
    /// board's [`StepTimer::schedule_next_from`] receives right after, for the same event: a board that reads its
    /// timer's counter here (for the pulse end) hands the reading on, so the interrupt reads the counter once. The
    /// default steps and returns 0.
    #[inline(always)]
    fn step_axes_read(&mut self, mask: u8) -> u32 {
        self.step_axes(mask);
        0
    }
    /// Energise (`true`, M17) or release (`false`, M18) the motor drivers.
    fn enable_motors(&mut self, on: bool);
    /// Drive the pen-lift hobby servo to `angle_deg` (0–180°, `M3 S<angle>` / `M5`): a 50 Hz PWM whose pulse is
    /// [`servo_pulse_us`] wide. Boards without a servo keep this default, which does nothing.
    fn set_servo(&mut self, _angle_deg: f32) {}
}

/// The pulse width (µs) of a hobby servo's 50 Hz signal for `angle_deg`: 1000 µs at 0° to 2000 µs at 180°
/// (the common convention; clamped to that range).
pub fn servo_pulse_us(angle_deg: f32) -> u16 {
    let a = if angle_deg.is_nan() { 0.0 } else { angle_deg.clamp(0.0, 180.0) };
    // 1000..=2000 after the clamp.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let us = (1000.0 + a * (1000.0 / 180.0) + 0.5) as u16;
    us
}

/// Endstop (limit/homing switch) inputs.
pub trait Endstops {
    /// Bit mask of pressed switches, bit `axis.bit()` per axis.
    fn pressed(&mut self) -> u8;
}

/// A one-shot step timer counting at [`crate::step_block::TICK_HZ`].
pub trait StepTimer {
    /// Fire the timer interrupt `ticks` timer ticks after the previous timer event (or after now, when the
    /// stepper was idle). `ticks ≥ 1`.
    fn schedule(&mut self, ticks: u32);
    /// [`StepTimer::schedule`] from the timer interrupt itself: the timer is running, so the next event is `ticks`
    /// after the one being handled (a board may skip its idle check here; the default is `schedule`).
    #[inline(always)]
    fn schedule_next(&mut self, ticks: u32) {
        self.schedule(ticks);
    }
    /// [`StepTimer::schedule_next`] right after [`StepPins::step_axes_read`] in the same interrupt, with the value
    /// it returned (only the next interval's integer adds run in between). The default ignores it.
    #[inline(always)]
    fn schedule_next_from(&mut self, read: u32, ticks: u32) {
        let _ = read;
        self.schedule_next(ticks);
    }
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
    /// Time since start in [`crate::step_block::TICK_HZ`] ticks.
    fn now(&self) -> u64;
}

/// Everything a board provides.
pub trait Hal: StepPins + Endstops + StepTimer + SerialOut + Clock {}

impl<T: StepPins + Endstops + StepTimer + SerialOut + Clock> Hal for T {}

/// Heater outputs (PWM), thermistor inputs (ADC) and the part-cooling fan of a printer board. Every method has a
/// "nothing wired" default, so a board implements only what it has.
pub trait Heaters {
    /// Set the PWM duty of `heater`, 0 (off) to 255 (always on). Called once per thermal period for every
    /// configured heater, and with 0 at once on any alarm or emergency stop.
    fn set_heater(&mut self, heater: Heater, duty: u8) {
        let _ = (heater, duty);
    }
    /// The latest thermistor conversion of `heater` in ADC counts (full scale as configured, see
    /// [`crate::thermal::thermistor::Thermistor::adc_max`]), or `None` when no fresh conversion is ready. The
    /// core's watchdog trips when no fresh reading comes for too long.
    fn read_thermistor(&mut self, heater: Heater) -> Option<u16> {
        let _ = heater;
        None
    }
    /// Set the part-cooling fan duty, 0–255.
    fn set_fan(&mut self, duty: u8) {
        let _ = duty;
    }
}

/// A board without heaters (plotters): every [`Heaters`] method is the default.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct NoHeaters;

impl Heaters for NoHeaters {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn servo_pulse_widths() {
        assert_eq!([servo_pulse_us(0.0), servo_pulse_us(90.0), servo_pulse_us(180.0)], [1000, 1500, 2000]);
        assert_eq!([servo_pulse_us(-5.0), servo_pulse_us(400.0), servo_pulse_us(f32::NAN)], [1000, 2000, 1000]);
        assert_eq!(servo_pulse_us(45.0), 1250);
    }
}
