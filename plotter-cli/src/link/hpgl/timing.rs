//! How long an HP-GL plotter takes: a pen move accelerates at the device's acceleration up to its speed and
//! brakes to a stop at its end (the 1980s plotters do not blend moves), pen-down moves at the `VS` speed,
//! pen-up moves at the device's top speed; lifting or lowering the pen and changing pens take fixed times.
//! Used by the plotter model (its clock) and the sender (time left).

use std::time::Duration;

use plotter_path::geometry::hpgl_devices::{HpglDevice, PLU_PER_MM};

/// Lifting or lowering the pen, s. Estimated, for every device: none of the sources the device table cites
/// (`plotter_path::geometry::hpgl_devices`) gives it; 30 ms is a solenoid's stroke plus the pen settling.
pub const PEN_LIFT_S: f64 = 0.03;
/// A pen change (`SP n`): put the pen back in the carousel and take another, s. Estimated, for every device:
/// not in the sources the device table cites; 2 s covers a carousel turning half way and the two pen strokes.
pub const PEN_CHANGE_S: f64 = 2.0;

/// Fixed part of [`patience`]: a plotter's own hesitations the estimate does not know (a slow pen carousel,
/// an answer's round trip, the last move braking).
pub const PATIENCE_MARGIN: Duration = Duration::from_secs(20);

/// How long to wait for a plotter that should be done with `work` (the estimated time of what its buffer holds)
/// before calling it stuck: half as long again as the estimate (the devices' accelerations and pen times are
/// estimates too), plus [`PATIENCE_MARGIN`]. Every wait of the HP-GL link for the plotter's progress (room in its
/// buffer, its buffer draining, an `OE` that waits its turn) is bounded by this, so the limit follows from the
/// work queued instead of a fixed constant.
pub fn patience(work: Duration) -> Duration {
    work.mul_f64(1.5) + PATIENCE_MARGIN
}

/// Standard gravity, m/s².
const G: f64 = 9.806_65;

/// The device's acceleration, plotter units/s².
pub fn accel_plu(device: &HpglDevice) -> f64 {
    device.accel_g * G * 1000.0 * PLU_PER_MM
}

/// A speed in cm/s as plotter units/s.
pub fn cm_s_to_plu(v: f64) -> f64 {
    v * 10.0 * PLU_PER_MM
}

/// Seconds to move `dist` plotter units from rest to rest at top speed `v` (plu/s) and acceleration `a`
/// (plu/s²): a trapezoid, or a triangle when the move is too short to reach `v`.
pub fn move_seconds(dist: f64, v: f64, a: f64) -> f64 {
    if dist <= 0.0 || v <= 0.0 || a <= 0.0 {
        return 0.0;
    }
    let ramp = v * v / a; // distance to accelerate and brake
    if dist >= ramp { dist / v + v / a } else { 2.0 * (dist / a).sqrt() }
}

#[cfg(test)]
mod tests {
    use super::*;
    use plotter_path::geometry::hpgl_devices::device;

    #[test]
    fn trapezoid_and_triangle_by_hand() {
        // v = 100, a = 1000: each ramp takes 0.1 s over 5 units; 110 units = 10 ramping (0.2 s) + 100 cruising (1 s).
        assert!((move_seconds(110.0, 100.0, 1000.0) - 1.2).abs() < 1e-12);
        // 2.5 units: accelerate 1.25 (t = √(2·1.25/1000) = 0.05 s) and brake the same.
        assert!((move_seconds(2.5, 100.0, 1000.0) - 0.1).abs() < 1e-12);
        assert_eq!(move_seconds(0.0, 100.0, 1000.0), 0.0);
        // The 7475A: 2 g = 19.6133 m/s² = 784 532 plu/s²; 38.1 cm/s = 15 240 plu/s.
        let d = device("7475a").unwrap();
        assert!((accel_plu(d) - 784_532.0).abs() < 1e-6);
        assert!((cm_s_to_plu(38.1) - 15_240.0).abs() < 1e-9);
        assert_eq!(patience(Duration::from_secs(10)), Duration::from_secs(35));
        assert_eq!(patience(Duration::ZERO), PATIENCE_MARGIN);
    }
}
