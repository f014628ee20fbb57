//! Soft limits: a move's target is checked against the travel before anything is queued.
//!
//! Machine coordinates run from 0 to the axis travel (the homing switch defines 0, or `travel` for a switch at the
//! maximum end). Limits apply only to axes with a travel (an extruder has none) that have been homed — before
//! homing, the machine does not know where it is, so there is nothing to check against.

use crate::axis::{Axis, NUM_AXES};
use crate::config::MachineConfig;

/// The first axis whose target (steps) lies outside `0..=travel`, among the `homed` axes (mask).
pub fn violation(config: &MachineConfig, homed: u8, target: &[i32; NUM_AXES]) -> Option<Axis> {
    if !config.soft_limits {
        return None;
    }
    Axis::ALL.into_iter().find(|&axis| {
        let a = config.axis(axis);
        homed & axis.bit() != 0 && a.is_limited() && !(0..=a.travel_steps()).contains(&target[axis.index()])
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_homed_limited_axes() {
        let c = MachineConfig::xy_plotter();
        assert_eq!(violation(&c, 0b111, &[0, 23_760, 4000, 0]), None);
        assert_eq!(violation(&c, 0b111, &[33_601, 0, 0, 0]), Some(Axis::X));
        assert_eq!(violation(&c, 0b111, &[0, -1, 0, 0]), Some(Axis::Y));
        assert_eq!(violation(&c, 0b001, &[0, -1, 0, 0]), None, "Y not homed");
        assert_eq!(violation(&c, 0b1111, &[0, 0, 0, -5_000_000]), None, "E has no travel");
        let mut off = c;
        off.soft_limits = false;
        assert_eq!(violation(&off, 0b111, &[-1, 0, 0, 0]), None);
    }
}
