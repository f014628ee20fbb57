//! The machine configuration the firmware runs with: a plain `Copy` struct with no parsing.
//!
//! The host builds it from plotter-path's TOML `MachineProfile` (field for field: `axes.*`, `motion`, `homing`,
//! `pen`, `link`); [`MachineConfig::xy_plotter`] mirrors `samples/xy-plotter.toml` for tests and the simulator.
//! All lengths are millimetres, speeds mm/s, accelerations mm/s², times milliseconds.

use core::fmt;

use crate::axis::{Axis, NUM_AXES};

/// Limits and scaling of one axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisConfig {
    /// Whether the axis exists. A disabled axis rejects moves (`error:` for its word) and is never homed.
    pub enabled: bool,
    /// Steps (full steps × microsteps) per millimetre.
    pub steps_per_mm: f32,
    /// Usable travel from the homed origin, mm (0 = unlimited, e.g. an extruder).
    pub travel_mm: f32,
    /// Maximum feed, mm/s.
    pub max_feed_mm_s: f32,
    /// Maximum acceleration, mm/s².
    pub max_accel_mm_s2: f32,
    /// Invert the direction pin.
    pub invert_dir: bool,
    /// The homing switch sits at the maximum end (`travel_mm`) instead of at 0.
    pub home_at_max: bool,
}

impl AxisConfig {
    /// A disabled axis (all limits zero).
    pub const DISABLED: AxisConfig = AxisConfig {
        enabled: false,
        steps_per_mm: 1.0,
        travel_mm: 0.0,
        max_feed_mm_s: 0.0,
        max_accel_mm_s2: 0.0,
        invert_dir: false,
        home_at_max: false,
    };

    /// Travel in steps (rounded), 0 when unlimited.
    pub fn travel_steps(&self) -> i32 {
        crate::fmath::round_i32(f64::from(self.travel_mm) * f64::from(self.steps_per_mm))
    }

    /// Whether this axis takes part in homing and soft limits (enabled with a finite travel).
    pub fn is_limited(&self) -> bool {
        self.enabled && self.travel_mm > 0.0
    }
}

/// Homing cycle settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HomingConfig {
    /// Fast seek rate, mm/s.
    pub seek_mm_s: f32,
    /// Slow locate rate, mm/s.
    pub locate_mm_s: f32,
    /// Pull-off distance after each switch contact, mm.
    pub pull_off_mm: f32,
    /// Switch debounce: dwell after each contact before moving again, ms.
    pub debounce_ms: f32,
    /// Z's switch (at the minimum end) trips while the pen is still clear of the paper, so homing Z where the
    /// carriage stands leaves no mark. `false` (the cautious default) when the pen touches first: then a lost Z
    /// is not homed where the carriage stands (see [`crate::homing`]).
    pub pen_clear_at_z_switch: bool,
}

/// Pen lift on the Z axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PenConfig {
    /// Z with the pen up, mm (homing moves Z here before homing X and Y).
    pub up_z_mm: f32,
    /// Z with the pen on the paper, mm.
    pub down_z_mm: f32,
    /// Servo pens: the angle (degrees, 0..=180) holding the pen up — where `M5` and a fault leave it.
    pub servo_up_deg: f32,
    /// Servo pens: the angle (degrees, 0..=180) putting the pen on the paper.
    pub servo_down_deg: f32,
    /// Servo pens: the time, ms (0..=10000), the servo takes to swing from `servo_up_deg` to `servo_down_deg` or
    /// back, its rate (the host sends the profile's `pen.settle_ms`; the default mirrors the sample's). The stepper
    /// models the servo's angle with it, to hold a drop that a feed hold delayed until the servo is down
    /// ([`crate::stepper::Stepper::model_servo`]); 0 models nothing.
    pub servo_swing_ms: f32,
}

/// Everything the firmware needs to know about the machine.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MachineConfig {
    /// Per-axis limits, indexed by [`Axis::index`].
    pub axes: [AxisConfig; NUM_AXES],
    /// Junction deviation, mm (cornering model, see [`crate::planner`]).
    pub junction_deviation_mm: f32,
    /// Largest deviation, mm, between a polyline and the smooth curve it samples for its vertices to be planned as
    /// points of that curve (speed from the curve's radius) instead of as corners (junction deviation); 0 plans
    /// every vertex as a corner. See [`crate::planner`].
    pub curve_deviation_mm: f32,
    /// Homing cycle.
    pub homing: HomingConfig,
    /// Pen positions.
    pub pen: PenConfig,
    /// Receive buffer announced to the host, bytes (clamped to the compiled capacity).
    pub rx_buffer_bytes: u32,
    /// Planner queue length announced to the host, blocks (clamped to the compiled capacity).
    pub queue_blocks: u32,
    /// Reject moves outside the travel once homed.
    pub soft_limits: bool,
    /// Treat a switch pressed outside homing as a crash: stop and latch an alarm.
    pub hard_limits: bool,
}

/// A configuration value out of range.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ConfigError {
    /// The axis, when the field is per axis.
    pub axis: Option<Axis>,
    /// Field name (as in the TOML profile).
    pub field: &'static str,
    /// What is wrong.
    pub problem: &'static str,
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.axis {
            Some(a) => write!(f, "axes.{}.{}: {}", a.letter().to_ascii_lowercase(), self.field, self.problem),
            None => write!(f, "{}: {}", self.field, self.problem),
        }
    }
}

impl MachineConfig {
    /// The XY plotter kit of `samples/xy-plotter.toml` (80 steps/mm belts, 420 × 297 mm, lead-screw Z).
    pub fn xy_plotter() -> Self {
        let belt = |travel| AxisConfig {
            enabled: true,
            steps_per_mm: 80.0,
            travel_mm: travel,
            max_feed_mm_s: 150.0,
            max_accel_mm_s2: 1500.0,
            invert_dir: false,
            home_at_max: false,
        };
        MachineConfig {
            axes: [
                belt(420.0),
                belt(297.0),
                AxisConfig {
                    enabled: true,
                    steps_per_mm: 400.0,
                    travel_mm: 10.0,
                    max_feed_mm_s: 25.0,
                    max_accel_mm_s2: 500.0,
                    invert_dir: false,
                    home_at_max: false,
                },
                AxisConfig::DISABLED,
            ],
            junction_deviation_mm: 0.02,
            curve_deviation_mm: 0.1,
            homing: HomingConfig {
                seek_mm_s: 40.0,
                locate_mm_s: 4.0,
                pull_off_mm: 2.0,
                debounce_ms: 5.0,
                pen_clear_at_z_switch: false,
            },
            pen: PenConfig {
                up_z_mm: 4.0,
                down_z_mm: 0.0,
                servo_up_deg: 90.0,
                servo_down_deg: 30.0,
                servo_swing_ms: 50.0,
            },
            rx_buffer_bytes: 256,
            queue_blocks: 32,
            soft_limits: true,
            hard_limits: true,
        }
    }

    /// The axis's settings.
    pub fn axis(&self, axis: Axis) -> &AxisConfig {
        &self.axes[axis.index()]
    }

    /// Mask of enabled axes.
    pub fn enabled_mask(&self) -> u8 {
        Axis::ALL.iter().filter(|a| self.axis(**a).enabled).fold(0, |m, a| m | a.bit())
    }

    /// Check every value; the first problem found is returned.
    pub fn validate(&self) -> Result<(), ConfigError> {
        for axis in Axis::ALL {
            let a = self.axis(axis);
            if !a.enabled {
                continue;
            }
            let err = |field, problem| Err(ConfigError { axis: Some(axis), field, problem });
            for (field, v) in [
                ("steps_per_mm", a.steps_per_mm),
                ("max_feed_mm_s", a.max_feed_mm_s),
                ("max_accel_mm_s2", a.max_accel_mm_s2),
            ] {
                if !(v.is_finite() && v > 0.0) {
                    return err(field, "must be a positive number");
                }
            }
            if !(a.travel_mm.is_finite() && a.travel_mm >= 0.0) || a.travel_mm * a.steps_per_mm > 1.0e9 {
                return err("travel_mm", "must be zero or positive and below 1e9 steps");
            }
            if a.max_feed_mm_s * a.steps_per_mm > 1.0e6 {
                return err("max_feed_mm_s", "step rate above 1 MHz");
            }
        }
        let err = |field, problem| Err(ConfigError { axis: None, field, problem });
        if !(self.junction_deviation_mm.is_finite() && self.junction_deviation_mm > 0.0) {
            return err("motion.junction_deviation_mm", "must be a positive number");
        }
        if !(self.curve_deviation_mm.is_finite() && (0.0..=10.0).contains(&self.curve_deviation_mm)) {
            return err("motion.curve_deviation_mm", "must lie in 0..=10 mm");
        }
        let h = &self.homing;
        if !(h.seek_mm_s.is_finite() && h.seek_mm_s > 0.0 && h.locate_mm_s.is_finite() && h.locate_mm_s > 0.0) {
            return err("homing.seek_mm_s/locate_mm_s", "must be positive numbers");
        }
        if !(h.pull_off_mm.is_finite() && h.pull_off_mm > 0.0) {
            return err("homing.pull_off_mm", "must be positive (the switch has to release)");
        }
        if !(h.debounce_ms.is_finite() && (0.0..=10_000.0).contains(&h.debounce_ms)) {
            return err("homing.debounce_ms", "must lie in 0..=10000");
        }
        let z = self.axis(Axis::Z);
        for (field, v) in [("pen.up_z_mm", self.pen.up_z_mm), ("pen.down_z_mm", self.pen.down_z_mm)] {
            if z.enabled && !(v.is_finite() && v >= 0.0 && (z.travel_mm == 0.0 || v <= z.travel_mm)) {
                return err(field, "must lie within the Z travel");
            }
        }
        for (field, a) in [("pen.servo_up_deg", self.pen.servo_up_deg), ("pen.servo_down_deg", self.pen.servo_down_deg)]
        {
            if !(a.is_finite() && (0.0..=180.0).contains(&a)) {
                return err(field, "must be an angle from 0 to 180 degrees");
            }
        }
        if !(self.pen.servo_swing_ms.is_finite() && (0.0..=10_000.0).contains(&self.pen.servo_swing_ms)) {
            return err("pen.servo_swing_ms", "must lie in 0..=10000 ms");
        }
        if self.rx_buffer_bytes < 64 || self.queue_blocks == 0 {
            return err("link", "rx_buffer_bytes must be at least 64 and queue_blocks positive");
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plotter_config_is_valid() {
        let c = MachineConfig::xy_plotter();
        assert_eq!(c.validate(), Ok(()));
        assert_eq!(c.enabled_mask(), 0b0111);
        assert_eq!(c.axis(Axis::X).travel_steps(), 33_600);
    }

    #[test]
    fn bad_values_name_the_field() {
        let mut c = MachineConfig::xy_plotter();
        c.axes[1].max_accel_mm_s2 = -1.0;
        let e = c.validate().unwrap_err();
        assert_eq!((e.axis, e.field), (Some(Axis::Y), "max_accel_mm_s2"));
        assert_eq!(std::format!("{e}"), "axes.y.max_accel_mm_s2: must be a positive number");
        let mut c = MachineConfig::xy_plotter();
        c.homing.pull_off_mm = 0.0;
        assert_eq!(c.validate().unwrap_err().field, "homing.pull_off_mm");
        let mut c = MachineConfig::xy_plotter();
        c.pen.up_z_mm = 11.0;
        assert_eq!(c.validate().unwrap_err().field, "pen.up_z_mm");
        for swing in [-1.0, 10_001.0, f32::NAN, f32::INFINITY] {
            let mut c = MachineConfig::xy_plotter();
            c.pen.servo_swing_ms = swing;
            let e = c.validate().unwrap_err();
            assert_eq!(std::format!("{e}"), "pen.servo_swing_ms: must lie in 0..=10000 ms");
        }
        for swing in [0.0, 10_000.0] {
            let mut c = MachineConfig::xy_plotter();
            c.pen.servo_swing_ms = swing;
            assert_eq!(c.validate(), Ok(()));
        }
    }
}
