//! A hobby-servo pen lift that follows the Z axis.
//!
//! The core lifts the pen with Z moves (pen-up and pen-down heights from the machine configuration). With a
//! servo instead of a Z stepper, the board counts the Z steps the core emits (direction from the last Z
//! direction level) and turns the Z position into a pulse width: linear between the pen-down pulse at
//! `down_z` and the pen-up pulse at `up_z`, clamped outside. The servo thus moves exactly as far as the planned
//! Z move, at its pace, and a feed hold or alarm stops it where the steps stop. No planning or G-code knowledge
//! is needed in the board.

/// Servo settings: pen heights in Z steps and the matching pulse widths, µs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ServoConfig {
    /// Z (steps) with the pen on the paper.
    pub down_z: i32,
    /// Z (steps) with the pen up.
    pub up_z: i32,
    /// Pulse with the pen down, µs (hobby servos: 1000..2000).
    pub down_us: u16,
    /// Pulse with the pen up, µs.
    pub up_us: u16,
    /// Direction level the core sets for increasing Z (after the configured inversion; usually `false`).
    pub forward_level: bool,
}

/// Z position tracking and the pulse width for it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ServoPen {
    cfg: ServoConfig,
    z: i32,
    forward: bool,
}

impl ServoPen {
    /// Start at `z` steps.
    pub const fn new(cfg: ServoConfig, z: i32) -> Self {
        ServoPen { cfg, z, forward: true }
    }

    /// The core set the Z direction pin to `level`.
    pub fn set_dir(&mut self, level: bool) {
        self.forward = level == self.cfg.forward_level;
    }

    /// One Z step; returns the new pulse width.
    pub fn step(&mut self) -> u16 {
        self.z = self.z.saturating_add(if self.forward { 1 } else { -1 });
        self.pulse_us()
    }

    /// Z position, steps.
    pub fn z(&self) -> i32 {
        self.z
    }

    /// Pulse for the pen-up position (what a fault handler sets).
    pub fn up_pulse(&self) -> u16 {
        self.cfg.up_us
    }

    /// Pulse width for the current Z.
    pub fn pulse_us(&self) -> u16 {
        let (z0, z1) = (i64::from(self.cfg.down_z), i64::from(self.cfg.up_z));
        let (p0, p1) = (i64::from(self.cfg.down_us), i64::from(self.cfg.up_us));
        if z1 == z0 {
            return self.cfg.up_us;
        }
        let (lo, hi) = (z0.min(z1), z0.max(z1));
        let z = i64::from(self.z).clamp(lo, hi);
        // Rounded to the nearest µs; lies between p0 and p1, so it fits u16.
        let (mut num, mut den) = ((z - z0) * (p1 - p0), z1 - z0);
        if den < 0 {
            (num, den) = (-num, -den);
        }
        // Half away from zero.
        let q = if num >= 0 { (2 * num + den) / (2 * den) } else { (2 * num - den) / (2 * den) };
        u16::try_from(p0 + q).unwrap_or(self.cfg.up_us)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cfg() -> ServoConfig {
        // The XY plotter kit: pen down at Z 0, up at 4 mm × 400 steps/mm.
        ServoConfig { down_z: 0, up_z: 1600, down_us: 1000, up_us: 2000, forward_level: false }
    }

    #[test]
    fn pulse_follows_z_linearly_and_clamps() {
        let mut s = ServoPen::new(cfg(), 0);
        assert_eq!(s.pulse_us(), 1000);
        s.set_dir(false);
        for _ in 0..800 {
            s.step();
        }
        assert_eq!((s.z(), s.pulse_us()), (800, 1500));
        for _ in 0..800 {
            s.step();
        }
        assert_eq!(s.pulse_us(), 2000);
        // Beyond the pen-up height (homing pull-off) the servo stays at the end.
        assert_eq!(s.step(), 2000);
        s.set_dir(true);
        assert_eq!(s.step(), 2000);
        assert_eq!(s.z(), 1600);
        assert_eq!(s.step(), 1999); // 1599/1600 of the way: 1999.375 → 1999
    }

    #[test]
    fn inverted_servo_and_rounding() {
        let c = ServoConfig { down_us: 2100, up_us: 900, ..cfg() };
        let mut s = ServoPen::new(c, 1);
        // 2100 − 1200/1600 = 2099.25 → 2099.
        assert_eq!(s.pulse_us(), 2099);
        s.set_dir(true);
        assert_eq!(s.step(), 2100);
        assert_eq!(s.step(), 2100);
        assert_eq!(s.up_pulse(), 900);
    }
}
