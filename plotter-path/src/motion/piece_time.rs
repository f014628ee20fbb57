//! The time bound's pieces of motion: the fastest a straight piece can be covered between given speeds, the
//! acceleration an XY path may use, the speeds at the joins between XY moves and a Z pen's moves, the Z pen's rise
//! as the plan makes it, and the servo pen's least waits. Read by the stroke bound ([`crate::motion::bound`]), the
//! hop cost ([`crate::motion::hop_time`]) and the gap's causes ([`crate::motion::gap`]), which is why they live
//! below all three.

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

/// The 90° junction speed of junction deviation `deviation` at acceleration `a`: the fastest a move may enter or
/// leave a perpendicular one (XY travel into a pen drop, a stroke into the lift).
pub(crate) fn corner_speed(a: f64, deviation: f64) -> f64 {
    let s = std::f64::consts::FRAC_1_SQRT_2;
    (a * deviation * s / (1.0 - s)).sqrt()
}

/// A Z pen's rise off the paper as the plan makes it, mm: the clearance rounded to steps (at least one), capped (as
/// the plan caps it) by every pen's distance from the paper to the pen-up height, less the step either end may
/// round away.
pub(crate) fn clearance_mm(profile: &MachineProfile) -> f64 {
    let (up, sz) = (profile.pen.up_z_mm, profile.axes.z.steps_per_mm);
    std::iter::once(profile.pen.down_z_mm)
        .chain(profile.pens.iter().filter_map(|p| p.down_z_mm))
        .fold((profile.pen.clearance_mm * sz).round().max(1.0) / sz, |c, d| c.min((up - d).abs() - 1.0 / sz))
        .max(0.0)
}

/// The speeds the lifts part of the bound allows a Z pen at its joins, mm/s: `(into the rise from a stroke that
/// may end on a curve point, between the rise or the drop and the hop)`: 90° corners, or with the curve model on
/// (see [`z_joins_may_curve`]) curve points taken at up to the slower move's feed.
pub(crate) fn z_join_speeds(profile: &MachineProfile) -> (f64, f64) {
    let z = &profile.axes.z;
    if z_joins_may_curve(profile) {
        (z.max_feed_mm_s, z.max_feed_mm_s.min(profile.pen.travel_feed_mm_s))
    } else {
        (
            corner_speed(z.max_accel_mm_s2, profile.motion.junction_deviation_mm),
            hop_corner_speed(profile, z.max_accel_mm_s2),
        )
    }
}

/// A servo pen's least waits per stroke as the bound counts them, ticks: `(clear, window)`, the clear time of its
/// lift (the profile's `pen.clear_ms` where set, else the servo's travel back past the contact fraction) and the
/// narrowest contact window of its drop ([`crate::motion::servo::ServoTiming::least_window`]), each the least of
/// every pen the profile names.
pub(crate) fn servo_waits(profile: &MachineProfile) -> (u64, u64) {
    let (mut clear, mut window) = (u64::MAX, u64::MAX);
    for t in servo_timings(profile) {
        clear = clear.min(t.clear_ticks());
        window = window.min(t.least_window());
    }
    if profile.pen.clear_ms.is_some() {
        clear = u64::from(crate::motion::plan::servo_clear_ticks(profile));
    }
    (clear, window)
}

/// The servo timing of every pen the profile names (its own pen first).
pub(crate) fn servo_timings(profile: &MachineProfile) -> impl Iterator<Item = crate::motion::servo::ServoTiming> + '_ {
    std::iter::once(profile.pen.servo_down_deg)
        .chain(profile.pens.iter().filter_map(|p| p.servo_down_deg))
        .map(|d| crate::motion::servo::ServoTiming::of(profile, d))
}
