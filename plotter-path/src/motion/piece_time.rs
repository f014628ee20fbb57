//! The time bound's pieces of motion: the fastest a straight piece can be covered between given speeds, the
//! acceleration an XY path may use, and the speeds at the joins between XY moves and a Z pen's moves. Read by the
//! stroke bound ([`crate::motion::bound`]), the hop cost ([`crate::motion::hop_time`]) and the gap's causes
//! ([`crate::motion::gap`]), which is why they live below all three.

use crate::MachineProfile;

/// Fastest motion over `len` mm starting at ≤ `v0`, ending at ≤ `v1`, top speed `v`, acceleration `a`, seconds.
pub(crate) fn fastest_piece(len: f64, v0: f64, v1: f64, v: f64, a: f64) -> f64 {
    if len <= 0.0 {
        return 0.0;
    }
    // Entry and exit speeds the length can connect.
    let v0 = v0.min(v).min((v1 * v1 + 2.0 * a * len).sqrt());
    let v1 = v1.min(v).min((v0 * v0 + 2.0 * a * len).sqrt());
    let peak = ((2.0 * a * len + v0 * v0 + v1 * v1) / 2.0).sqrt().min(v);
    let d_acc = (peak * peak - v0 * v0) / (2.0 * a);
    let d_dec = (peak * peak - v1 * v1) / (2.0 * a);
    let cruise = (len - d_acc - d_dec).max(0.0);
    (peak - v0) / a + (peak - v1) / a + cruise / v
}

/// The junction speed between a Z-only move and a travel that climbs or descends at up to twice the hop slope
/// (the turn is less than 90° by up to `atan(2·s)`), at acceleration `a`: an over-estimate of what the plan's
/// hops enter and leave their Z moves with.
pub(crate) fn hop_corner_speed(profile: &MachineProfile, a: f64) -> f64 {
    let tilt = (2.0 * crate::motion::hop::rise_slope(profile)).atan();
    let sin_half = ((std::f64::consts::FRAC_PI_2 + tilt) / 2.0).sin();
    (a * profile.motion.junction_deviation_mm * sin_half / (1.0 - sin_half)).sqrt()
}

/// The largest acceleration along an XY path: `√(a_x² + a_y²)` from the axes' limits, lowered to the profile's
/// cap for that kind of move (`pen.draw_accel_mm_s2` or `pen.travel_accel_mm_s2`) when it sets one — the plan caps
/// every such block there ([`crate::motion::plan`]).
pub(crate) fn path_accel(profile: &MachineProfile, cap: Option<f64>) -> f64 {
    let axes = profile.axes.x.max_accel_mm_s2.hypot(profile.axes.y.max_accel_mm_s2);
    cap.map_or(axes, |c| axes.min(c))
}

/// Whether the planner may take the vertex between an XY move and a Z move (a stroke's end into the pen's rise,
/// the rise into the hop, the hop into the drop) as a point of a smooth curve rather than a 90° corner: with the
/// curve model on (`motion.curve_deviation_mm > 0`) a short chord next to the Z move makes it one, and the speed
/// there is then capped only by both moves' feeds. The bound then allows those feeds there.
pub(crate) fn z_joins_may_curve(profile: &MachineProfile) -> bool {
    profile.motion.curve_deviation_mm > 0.0
}
