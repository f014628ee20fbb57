//! Endstop debounce.
//!
//! Mechanical switches bounce for a millisecond or so, and long endstop wires pick up spikes from the motor
//! leads. The core reads the switches ([`plotter_fw::hal::Endstops::pressed`]) at every step event of a homing move,
//! from the board's 1 kHz sampling tick (hard limits, `Machine::check_limits`) and in the
//! homing cycle; the board filters the raw pin levels before answering:
//!
//! - a **press** counts once two consecutive readings (at different times) say pressed — a single spike is not a
//!   crash, and a real contact is seen one reading later (one step at the homing rates);
//! - a **release** counts once the switch has read released continuously for the window — a bouncing contact
//!   does not look released between bounces, so the homing cycle's "still pressed after pull-off" check and the
//!   locate move see a clean edge.
//!
//! Each axis bit is filtered on its own.

use plotter_fw::NUM_AXES;

/// The filter for up to [`NUM_AXES`] switches (bit `i` = axis `i`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Debouncer {
    window: u64,
    stable: u8,
    /// Previous raw reading.
    last_raw: u8,
    /// When each switch was first read released (in its current released run).
    released_since: [u64; NUM_AXES],
}

impl Debouncer {
    /// A filter whose releases must hold for `window` clock ticks. All switches start released.
    pub const fn new(window: u64) -> Self {
        Debouncer { window, stable: 0, last_raw: 0, released_since: [0; NUM_AXES] }
    }

    /// Feed a raw reading taken at `now`; returns the filtered mask.
    pub fn update(&mut self, raw: u8, now: u64) -> u8 {
        for i in 0..NUM_AXES {
            let bit = 1u8 << i;
            let pressed = raw & bit != 0;
            let was = self.last_raw & bit != 0;
            if pressed {
                if was {
                    self.stable |= bit;
                }
            } else {
                if was {
                    self.released_since[i] = now;
                }
                if now.saturating_sub(self.released_since[i]) >= self.window {
                    self.stable &= !bit;
                }
            }
        }
        self.last_raw = raw & ((1 << NUM_AXES) - 1);
        self.stable
    }

    /// The filtered mask as of the last reading.
    pub fn stable(&self) -> u8 {
        self.stable
    }

    /// Nothing pressed at the last reading and nothing held as pressed: a reading with no switch pressed then
    /// changes nothing, so [`Debouncer::update`] (and the clock read for it) can be skipped — the step interrupt's
    /// usual case.
    #[inline]
    pub fn is_quiet(&self) -> bool {
        self.stable == 0 && self.last_raw == 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_single_spike_is_not_a_press() {
        let mut d = Debouncer::new(1_000);
        assert_eq!(d.update(0b0001, 10), 0);
        assert_eq!(d.update(0, 20), 0);
        assert_eq!(d.update(0b0001, 30), 0);
        assert_eq!(d.update(0, 40), 0);
    }

    #[test]
    fn a_press_needs_two_readings_and_a_release_the_window() {
        let mut d = Debouncer::new(1_000);
        assert_eq!(d.update(0b0100, 0), 0);
        assert_eq!(d.update(0b0100, 300), 0b0100);
        // Bouncing: released readings interleaved with pressed ones never release it.
        assert_eq!(d.update(0, 400), 0b0100);
        assert_eq!(d.update(0b0100, 500), 0b0100);
        assert_eq!(d.update(0, 600), 0b0100);
        assert_eq!(d.update(0, 1_599), 0b0100);
        // Released continuously since 600: at 1_600 the window is full.
        assert_eq!(d.update(0, 1_600), 0);
        assert_eq!(d.stable(), 0);
    }

    #[test]
    fn axes_are_filtered_independently() {
        let mut d = Debouncer::new(100);
        d.update(0b0011, 0);
        assert_eq!(d.update(0b0011, 1), 0b0011);
        // X releases, Y stays pressed; Z is a spike.
        assert_eq!(d.update(0b0110, 2), 0b0011);
        assert_eq!(d.update(0b0010, 50), 0b0011);
        assert_eq!(d.update(0b0010, 102), 0b0010);
        // Bits beyond the axes are ignored.
        assert_eq!(d.update(0b1111_0010, 103), 0b0010);
        assert_eq!(d.update(0b1111_0010, 104), 0b0010);
    }

    #[test]
    fn a_quiet_filter_is_unchanged_by_a_released_reading() {
        let mut d = Debouncer::new(100);
        assert!(d.is_quiet());
        let before = d;
        assert_eq!(d.update(0, 5), 0);
        assert_eq!(d, before, "nothing to skip over");
        // A spike is not quiet (the next pressed reading would make it a press), nor is a held press.
        d.update(0b0001, 10);
        assert!(!d.is_quiet());
        assert_eq!(d.update(0b0001, 11), 0b0001);
        assert_eq!(d.update(0, 12), 0b0001);
        assert!(!d.is_quiet(), "released but inside the window");
        assert_eq!(d.update(0, 112), 0);
        assert!(d.is_quiet());
    }

    #[test]
    fn a_zero_window_releases_on_the_first_released_reading() {
        let mut d = Debouncer::new(0);
        d.update(1, 0);
        assert_eq!(d.update(1, 1), 1);
        assert_eq!(d.update(0, 2), 0);
    }
}
