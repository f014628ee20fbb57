//! A lower bound on a plot's time, reported next to the planned time so one sees how far from the machine's limit
//! a plot is.
//!
//! For a drawing whose strokes are each drawn with one pen-down (in any order, any direction) the plan takes at
//! least the sum of three parts, each bounded on its own:
//!
//! * **Pen down**: every stroke starts at rest (after the pen's settle dwell) and ends at no more than the
//!   junction speed of the 90° corner into the pen lift (junction deviation with the largest acceleration any
//!   direction allows, an over-estimate) — or, with the curve model on, at up to the Z feed: the planner may take
//!   a short chord's join with a Z move as a point of a curve, capped only by both moves' feeds. Each stroke is
//!   drawn at its pen's feed. The machine executes straight blocks, so it passes every vertex of a polyline with
//!   a jump in velocity; how large a jump it takes is a machine limit the profile states
//!   (`motion.junction_deviation_mm` and `motion.curve_deviation_mm`), like its axis speeds. So every vertex
//!   inside a stroke is capped at the profile's vertex limit: the more permissive of its junction-deviation speed
//!   and, where the vertex samples a smooth curve, the curve's centripetal speed, computed by the very function
//!   the planner reads ([`plotter_fw::planner::vertex_limit_sqr`]) with every block at the largest acceleration
//!   any direction allows (`√(a_x² + a_y²)`, or the drawing cap where lower), where the planner takes each
//!   corner at the lower acceleration of its two blocks: an over-estimate, so the cap is never below the
//!   planner's. A planner that passed a vertex faster would break the profile's limits. The speeds at the caps
//!   are carried from segment to segment (forward and backward passes), so each stroke's part is the least time
//!   its caps allow. Each straight segment takes at least the fastest one-dimensional motion over its length
//!   that starts and ends within those speeds and stays within the segment's own limits ([`segment_limits`]): on
//!   a straight segment the pen's velocity and acceleration both point along it (a straight path has no normal
//!   acceleration), so an axis moving a share `|u_i|` of the path sees `|u_i|` of them, and no motion on the
//!   machine's per-axis limits goes faster along direction `u` than `min_i v_i/|u_i|` (and the pen's feed) nor
//!   speeds up or slows down faster than `min_i a_i/|u_i|` (and the profile's drawing acceleration,
//!   `pen.draw_accel_mm_s2`, a limit along the path in any direction). A line along X on axes of equal limits is
//!   bounded at X's acceleration, not at the diagonal's `√(a_x² + a_y²)`.
//! * **Pen lifts** (the hop overlaps them with the travel, see [`crate::motion::hop`]): per stroke a Z move of at
//!   least the clearance off the paper (entered no faster than the 90° corner from the drawing allows, left no
//!   faster than the corner into a travel that climbs at up to twice the hop slope), a Z move of at least the
//!   clearance down to it (entered likewise, ending at rest) and the settle dwell; and once, the settle after the
//!   final lift; with the curve model on, those joins are allowed up to the Z feed (and the travel feed on the
//!   hop's side), as for the pen down. The clearance is taken as the plan rounds it to steps. Each part is a
//!   bound of the part the plan's breakdown counts (its pen-up, pen-down and settle blocks), not only of the
//!   total. A servo pen's hop waits at least the clear time for the lift (the servo's travel back past the
//!   contact fraction, [`crate::motion::servo`]) and, for the drop, its one-tick command and the narrowest
//!   window in which the tip may touch (zero for a servo of known timing, a servo cycle on an EiBotBoard): per
//!   stroke; and `2·settle − clear` once for the plot's first lift and last lift. The drawing before a servo
//!   lift ends at rest (the servo block is a stop).
//! * **Travel**: the pen-up hops cost at least the travel lower bound (see [`crate::optimize::bound`]: the largest
//!   of a spanning tree of the paths, their nearest predecessors, Held and Karp's penalized trees on the paths'
//!   ends, and on a small layer the best order itself, each valid for any order), each hop charged on its own the
//!   least time its X and Y distances allow ([`crate::motion::hop_time::HopTime`]): the largest of X's time over
//!   `|dx|` at X's own limits, Y's over `|dy|` at Y's, and the path's over the straight distance at the travel
//!   feed and the largest travel acceleration any direction allows (`√(a_x² + a_y²)`, or `pen.travel_accel_mm_s2`
//!   where lower), each from and into the corners with the pen's Z moves (up to the slower feed with the curve
//!   model on, on a hop short enough that its joins may be curve points). Each hop is charged too what its length
//!   forces the pen's moves to add to the lifts part: a Z pen's rise and drop into and out of the corners of a
//!   long hop, a servo's wider drop window after a lift the hop is too short to finish, or, where the firmware
//!   stops the carriage for a servo's drop (GRBL, [`crate::config::servo_sync::ServoSync::AtRest`]), the least
//!   time of the travel split around the drop commanded at rest and the contact that cannot overlap its first
//!   part (derived in [`crate::motion::hop_time`]: a 30 mm hop along X on the servo kit 0.400 s, not its
//!   0.330 s of travel); the plot's first hop and one after each pen change, which start with the pen fully up,
//!   are given back the most a lift may add ([`crate::motion::hop_time::HopTime::lift_excess`]). So this part
//!   bounds the plan's travel together with its pen moves' time above the lifts part. The cost depends on the
//!   hop's direction but not on which way it is taken, which is all the travel bound's trees need.
//!
//! The cruise limit on a curve's chords (no faster than their ends) is left out; it only adds time, so the bound is
//! valid whatever the order; the gap between it and the plan is what any order and planner could gain.
//!
//! **The drawing bounded** is the one the plan draws. `plotter stats` bounds the optimized drawing, whose paths
//! the optimizer may have joined: ends that meet within the merge tolerance, and consecutive paths whose gap is
//! under the pen's width, drawn through with the pen down (a bridge). Both are decided from the pen (its width)
//! and the drawing, never from the machine's limits, and both change the ink on the paper (a bridge is a line the
//! pen draws), so the joined drawing is the input the machine is given, as a drawing merged by vpype's
//! `linemerge` would be: the bound is of any order of its paths on this machine. Which gaps are bridged depends
//! on the optimizer's order; the bound does not claim that another order, bridging other gaps, could not draw a
//! different drawing faster.

use plotter_fw::config::MachineConfig;
use plotter_fw::planner::{self, PlanBlock, Seg};

use crate::MachineProfile;
use crate::geometry::steps::StepDrawing;
use crate::motion::piece_time::{
    clearance_mm, corner_speed, fastest_piece, path_accel, servo_waits, z_join_speeds, z_joins_may_curve,
};
use crate::motion::plan::{PlanError, machine_config};

/// The parts of a plot-time lower bound, seconds.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct TimeBound {
    /// Pen-down drawing.
    pub draw_s: f64,
    /// Pen drops and lifts with their settle dwells.
    pub lifts_s: f64,
    /// Pen-up travel.
    pub travel_s: f64,
}

impl TimeBound {
    /// The whole bound.
    pub fn total_s(&self) -> f64 {
        self.draw_s + self.lifts_s + self.travel_s
    }
}

/// The least time a pen-up hop of at least `d` mm can take on `profile` in any direction, seconds (no lift): the
/// path's term of [`crate::motion::hop_time::HopTime`] (the travel feed, the largest travel acceleration any
/// direction allows, from and into the corners with the pen's Z moves, two step diagonals short for the rounding
/// of its ends). Non-decreasing in `d`, so it maps a travel lower bound's hop lengths to a time bound
/// ([`crate::optimize::travel_lower_bound_mapped`]); the bound itself charges each hop by its X and Y distances
/// ([`crate::motion::hop_time::HopTime::seconds`]).
pub fn min_hop_seconds(profile: &MachineProfile) -> impl Fn(f64) -> f64 + use<> {
    let hop = crate::motion::hop_time::HopTime::of(profile);
    move |d: f64| hop.along_path(d)
}

/// The pen's moves as the bound counts them, seconds: per stroke its lift, drop and settle, and once per plot
/// (the final lift's settle; for a servo, the first and last lifts' whole settle time beyond their clear time).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct LiftParts {
    /// Per stroke: the lift, the drop, the settle dwell.
    pub(crate) per_stroke: [f64; 3],
    /// Once per plot: lift, drop, settle.
    pub(crate) once: [f64; 3],
    /// The lift after a stroke whose end is surely a corner ([`stroke_end_may_curve`]), entered no faster than
    /// that corner allows (the per-stroke lift where it makes no difference).
    pub(crate) cornered_lift: f64,
}

impl LiftParts {
    /// The lifts' part of the bound for `strokes` strokes, `cornered` of them ending at a corner into their lift
    /// (none without strokes).
    pub(crate) fn total_s(&self, strokes: f64, cornered: f64) -> f64 {
        self.split(strokes, cornered).iter().sum()
    }

    /// Lifts, drops and settles for `strokes` strokes, `cornered` of them ending at a corner into their lift
    /// (nothing without strokes).
    pub(crate) fn split(&self, strokes: f64, cornered: f64) -> [f64; 3] {
        if strokes <= 0.0 {
            return [0.0; 3];
        }
        let mut parts: [f64; 3] = core::array::from_fn(|i| strokes * self.per_stroke[i] + self.once[i]);
        parts[0] -= cornered * (self.per_stroke[0] - self.cornered_lift);
        parts
    }
}

/// The lift, drop and settle parts of the bound (see the module docs).
pub(crate) fn lift_parts(profile: &MachineProfile) -> LiftParts {
    let z = &profile.axes.z;
    let corner = |a: f64| corner_speed(a, profile.motion.junction_deviation_mm);
    let secs = |ticks: u32| f64::from(ticks) / f64::from(plotter_fw::TICK_HZ);
    let settle = secs(crate::motion::plan::settle_ticks(profile));
    if profile.pen.uses_servo() {
        // A servo pen moves no axis: its blocks are dwells. Per stroke the clear time of its lift and, for its
        // drop, the command and the narrowest contact window (the carriage waits through it at the stroke's
        // start); once, the first and the last lift's settle beyond the clear time counted per stroke. Each the
        // least of every pen the profile names.
        let (clear, window) = servo_waits(profile);
        #[allow(clippy::cast_precision_loss, reason = "tick counts are far below 2^52")]
        let secs = |t: u64| t as f64 / f64::from(plotter_fw::TICK_HZ);
        let (clear, drop) = (secs(clear.max(1)), secs(1 + window));
        return LiftParts {
            per_stroke: [clear, drop, 0.0],
            once: [2.0 * settle - clear, 0.0, 0.0],
            cornered_lift: clear,
        };
    }
    let c_mm = clearance_mm(profile);
    let (vz, az) = (z.max_feed_mm_s, z.max_accel_mm_s2);
    // Into the rise from the stroke, out of it into the hop, and into the drop: 90° corners, or (see
    // [`z_joins_may_curve`]) curve points taken at up to the slower move's feed. (A long hop's joins are surely
    // corners: the hop's cost charges what that adds, [`crate::motion::hop_time`].)
    let (v_in, v_hop) = z_join_speeds(profile);
    let rise = fastest_piece(c_mm, v_in, v_hop, vz, az);
    let drop = fastest_piece(c_mm, v_hop, 0.0, vz, az);
    let cornered_lift = fastest_piece(c_mm, corner(az), v_hop, vz, az);
    // The plot's last lift goes all the way to the pen-up height and stops there for the settle: once, what it
    // takes beyond the rise its stroke is charged, whichever way that stroke ends into it.
    let up_mm = std::iter::once(profile.pen.down_z_mm)
        .chain(profile.pens.iter().filter_map(|p| p.down_z_mm))
        .fold(f64::INFINITY, |s, d| s.min((profile.pen.up_z_mm - d).abs() - 1.0 / z.steps_per_mm))
        .max(c_mm);
    let last = (fastest_piece(up_mm, v_in, 0.0, vz, az) - rise)
        .min(fastest_piece(up_mm, corner(az), 0.0, vz, az) - cornered_lift)
        .max(0.0);
    LiftParts { per_stroke: [rise, drop, settle], once: [last, 0.0, settle], cornered_lift }
}

/// Whether the planner may take the join of a stroke whose last chord is `last_chord_mm` long with the pen's rise
/// as a point of a curve (see [`z_joins_may_curve`]). A Z pen's rise is a Z-only move, so the stroke turns by
/// exactly 90° into it, and a vertex is a curve point only where the circle tangent to both chords at half the
/// shorter one stays within `motion.curve_deviation_mm` of it ([`plotter_fw::planner`]'s rule 1): for 90°, half
/// the shorter chord times tan 22.5°. The rise is at least the clearance; a stroke whose last chord and clearance
/// are both longer than `2·curve_deviation_mm / tan 22.5°` (0.483 mm at 0.1 mm) therefore ends at a corner (with
/// a part in a thousand of slack for the planner's single precision).
pub(crate) fn stroke_end_may_curve(profile: &MachineProfile, last_chord_mm: f64) -> bool {
    if profile.pen.uses_servo() || !z_joins_may_curve(profile) {
        return false;
    }
    let m = 0.5 * last_chord_mm.min(clearance_mm(profile));
    m * std::f64::consts::FRAC_PI_8.tan() <= profile.motion.curve_deviation_mm * 1.001
}

/// The fastest a stroke whose last chord is `last_chord_mm` long may end into its pen lift, mm/s, drawing at
/// acceleration `accel` (see the module docs): at rest before a servo's block; else up to the Z feed where the
/// join may be a curve point ([`stroke_end_may_curve`]), and at most the 90° corner's junction speed with the
/// lower of the drawing's and Z's acceleration (the rise is a Z-only move at Z's, and the planner takes a corner
/// at the lower acceleration of its two blocks) where it is a corner.
pub(crate) fn stroke_exit_speed(profile: &MachineProfile, accel: f64, last_chord_mm: f64) -> f64 {
    if profile.pen.uses_servo() {
        0.0
    } else if stroke_end_may_curve(profile, last_chord_mm) {
        profile.axes.z.max_feed_mm_s
    } else {
        corner_speed(accel.min(profile.axes.z.max_accel_mm_s2), profile.motion.junction_deviation_mm)
    }
}

/// A stroke's drawing blocks as the bound's vertex caps see them: each block's geometry as the planner makes it,
/// taken at the largest acceleration any direction allows, `accel` (an over-estimate of the planner's per-block
/// one, so the caps over-estimate its junction speeds; the curve speed reads the axes' limits across the curve,
/// which do not depend on it).
pub(crate) fn vertex_segs(blocks: impl IntoIterator<Item = PlanBlock>, accel: f64) -> Vec<Seg> {
    // One part in a million above the f64 figure, so its rounding to f32 never falls below the planner's.
    #[allow(clippy::cast_possible_truncation, reason = "a physical acceleration, far inside f32")]
    let accel = (accel * (1.0 + 1e-6)) as f32;
    blocks
        .into_iter()
        .map(|mut b| {
            b.acceleration = accel;
            Seg::of(&b)
        })
        .collect()
}

/// The speed cap the bound puts at vertex `j` of a stroke's blocks `segs` (where `segs[j]` starts), mm/s. A vertex
/// whose verdict reads only the stroke's own blocks (at least [`planner::CURVE_SPAN_BLOCKS`] of them on either
/// side) is capped at the planner's own limit there ([`plotter_fw::planner::junction_limit_sqr`]): on a smooth
/// curve its centripetal speed, which no plan within the profile exceeds (a curve's centripetal acceleration is
/// the profile's limit, however finely the curve was cut; junction deviation's larger speed between the short
/// chords of a fine cut is a per-vertex rule, not a limit of the machine), at a corner junction deviation's. Nearer
/// a stroke's ends the plan's verdict also reads the pen's moves around the stroke, so the cap there is the more
/// permissive of both limits ([`plotter_fw::planner::vertex_limit_sqr`]), whichever the plan finds.
pub(crate) fn vertex_cap(cfg: &MachineConfig, segs: &[Seg], j: usize) -> f64 {
    let seg = |k: usize| segs[k];
    let k = planner::CURVE_SPAN_BLOCKS;
    let v2 = if j >= k && j + k <= segs.len() {
        planner::junction_limit_sqr(&seg, segs.len(), j, cfg)
    } else {
        planner::vertex_limit_sqr(&seg, segs.len(), j, cfg)
    };
    f64::from(v2).sqrt()
}

/// What the bound's per-direction limits give away to the planner's single-precision arithmetic: its blocks'
/// limits (`v_i/|u_i|`, `a_i/|u_i|` in f32) may come out a few parts in 10⁷ above or below the exact ones.
const F32_SLACK: f64 = 1.0 - 1e-6;

/// What the bound gives away per drawing segment to the stepper's timing: a block's duration is its step times'
/// end rounded to the nearest tick, which may fall up to half a tick before the exact motion's end (one tick
/// allowed).
const BLOCK_TICK_SLACK_S: f64 = 1.0 / plotter_fw::TICK_HZ as f64;

/// The fastest and the hardest-accelerating any motion may go along a straight segment of `dx` × `dy` mm on
/// `profile`'s axes: top speed `min(feed, v_x/|u_x|, v_y/|u_y|)` and acceleration `min(cap, a_x/|u_x|,
/// a_y/|u_y|)` for its unit direction `u` (an axis that does not move sets no limit), less [`F32_SLACK`]. See the
/// module docs for why no planner can beat them on a straight segment.
pub(crate) fn segment_limits(profile: &MachineProfile, dx: f64, dy: f64, feed: f64, cap: Option<f64>) -> (f64, f64) {
    let len = dx.hypot(dy);
    let (mut top, mut accel) = (feed, cap.unwrap_or(f64::INFINITY));
    for (d, axis) in [(dx, &profile.axes.x), (dy, &profile.axes.y)] {
        let u = d.abs() / len;
        if u > 0.0 {
            top = top.min(axis.max_feed_mm_s / u);
            accel = accel.min(axis.max_accel_mm_s2 / u);
        }
    }
    (top * F32_SLACK, accel * F32_SLACK)
}

/// The acceleration the bound draws with: [`path_accel`] with the drawing cap.
pub(crate) fn draw_accel(profile: &MachineProfile) -> f64 {
    path_accel(profile, profile.pen.draw_accel_mm_s2)
}

/// Lower bound on the time to plot `steps` (strokes as the plan draws them) whose pen-up hops take at least
/// `travel_lb_s` (e.g. [`crate::optimize::travel_lower_bound_mapped`] with [`min_hop_seconds`]). See the module
/// docs.
pub fn plot_time_lower_bound(
    profile: &MachineProfile,
    steps: &StepDrawing,
    travel_lb_s: f64,
) -> Result<TimeBound, PlanError> {
    // Also to refuse a profile the planner refuses.
    let cfg = machine_config(profile)?;
    let accel = path_accel(profile, profile.pen.draw_accel_mm_s2);
    let (sx, sy) = (profile.axes.x.steps_per_mm, profile.axes.y.steps_per_mm);
    // Each layer is drawn at its pen's feed.
    let feeds: Vec<f64> = crate::motion::plan::layer_pens(profile, steps).iter().map(|p| p.draw_feed_mm_s).collect();
    let mut bound = TimeBound::default();
    let lifts = lift_parts(profile);
    let (mut strokes, mut cornered) = (0usize, 0usize);
    for (si, s) in steps.strokes.iter().enumerate() {
        let draw = feeds.get(steps.layer_of(si)).copied().unwrap_or(profile.pen.draw_feed_mm_s);
        #[allow(clippy::cast_possible_truncation, reason = "a physical feed, far inside f32")]
        let feed32 = draw as f32;
        // The stroke's blocks as the planner makes them (every moving delta makes one), for the vertex caps.
        let segs = vertex_segs(s.moves.iter().filter_map(|d| PlanBlock::line(&cfg, [d.dx, d.dy, 0, 0], feed32)), accel);
        if segs.is_empty() {
            continue;
        }
        strokes += 1;
        // Its end into the pen's lift: a corner unless its last chord is short.
        let last_mm = s
            .moves
            .iter()
            .rev()
            .find(|d| !d.is_zero())
            .map_or(0.0, |d| (f64::from(d.dx) / sx).hypot(f64::from(d.dy) / sy));
        let v_lift = stroke_exit_speed(profile, accel, last_mm);
        if !stroke_end_may_curve(profile, last_mm) {
            cornered += 1;
        }
        // Each segment with its own limits (length, top speed, acceleration) and the cap at its end: the
        // profile's vertex limit inside the stroke, the speed into the lift at its end.
        let mut pieces: Vec<(f64, f64, f64, f64)> = Vec::with_capacity(segs.len());
        for (i, d) in s.moves.iter().filter(|d| !d.is_zero()).enumerate() {
            let (dx, dy) = (f64::from(d.dx) / sx, f64::from(d.dy) / sy);
            let (top, a) = segment_limits(profile, dx, dy, draw, profile.pen.draw_accel_mm_s2);
            let cap = if i + 1 == segs.len() { v_lift } else { vertex_cap(&cfg, &segs, i + 1) };
            pieces.push((dx.hypot(dy), top, a, cap));
        }
        // The fastest speeds the caps, the top speeds on either side and the accelerations allow at the segments'
        // ends (forward and backward passes from rest at the start), then each segment at its fastest between
        // them.
        let mut v = vec![0.0; pieces.len() + 1];
        for (i, &(len, top, a, cap)) in pieces.iter().enumerate() {
            let next_top = pieces.get(i + 1).map_or(f64::INFINITY, |p| p.1);
            v[i + 1] = cap.min(top).min(next_top).min((v[i] * v[i] + 2.0 * a * len).sqrt());
        }
        for (i, &(len, _, a, _)) in pieces.iter().enumerate().rev() {
            v[i] = v[i].min((v[i + 1] * v[i + 1] + 2.0 * a * len).sqrt());
        }
        for (i, &(len, top, a, _)) in pieces.iter().enumerate() {
            bound.draw_s += (fastest_piece(len, v[i], v[i + 1], top, a) - BLOCK_TICK_SLACK_S).max(0.0);
        }
    }
    #[allow(clippy::cast_precision_loss, reason = "stroke counts are far below 2^52")]
    {
        bound.lifts_s = if strokes == 0 { 0.0 } else { lifts.total_s(strokes as f64, cornered as f64) };
    }
    bound.travel_s = travel_lb_s;
    Ok(bound)
}

/// [`plot_time_lower_bound`] of `steps` (the step form of `drawing`) with the travel bound of `drawing`'s paths in
/// any order from `start`, each hop charged the least time its X and Y distances allow
/// ([`crate::motion::hop_time::HopTime`]).
pub fn drawing_time_lower_bound(
    profile: &MachineProfile,
    steps: &StepDrawing,
    drawing: &crate::Drawing,
    seam: crate::optimize::SeamMode,
    start: Option<kurbo::Point>,
) -> Result<TimeBound, PlanError> {
    let hop = crate::motion::hop_time::HopTime::of(profile);
    let travel = crate::optimize::travel_lower_bound_hops(drawing, seam, start, &hop);
    // The hops that do not start with a lift from the paper (the first, and one after each pen change) are charged
    // at most the hop cost's lift excess for a lift they do not have.
    let unlifted = lifted_hops(profile, steps).iter().filter(|l| !**l).count().max(1);
    #[allow(clippy::cast_precision_loss, reason = "stroke counts are far below 2^52")]
    let excess = unlifted as f64 * hop.lift_excess();
    plot_time_lower_bound(profile, steps, (travel - excess).max(0.0))
}

/// Whether each stroke's hop starts with a lift of the pen from the paper: every stroke's but the first's and but
/// those after a pen change (where the pen goes fully up and the hop starts from there), as the plan makes them.
pub(crate) fn lifted_hops(profile: &MachineProfile, steps: &StepDrawing) -> Vec<bool> {
    let pens = crate::motion::plan::layer_pens(profile, steps);
    (0..steps.strokes.len())
        .map(|si| {
            si > 0 && {
                let (a, b) = (steps.layer_of(si - 1), steps.layer_of(si));
                a == b || pens[a].same_pen(&pens[b])
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::steps::{StepDelta, StepPos, StepStroke};
    use crate::motion::piece_time::hop_corner_speed;
    use crate::motion::plan::{Lookahead, homed_position, plan};

    /// A sample profile of samples/.
    fn sample(name: &str) -> MachineProfile {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../samples").join(name);
        MachineProfile::from_toml(&std::fs::read_to_string(&path).unwrap(), name).unwrap()
    }

    /// The travel part of the bound of one line from `a` to `b` (page mm), from `start`, on `p`.
    fn travel_to_line(p: &MachineProfile, start: (f64, f64), a: (f64, f64), b: (f64, f64)) -> f64 {
        use crate::geometry::drawing::{Drawing, Polyline};
        use kurbo::Point;
        let d = Drawing::single_layer("l", vec![Polyline::new(vec![Point::new(a.0, a.1), Point::new(b.0, b.1)])]);
        let steps = crate::geometry::steps::drawing_to_steps(p, &d).unwrap();
        let from = Some(Point::new(start.0, start.1));
        drawing_time_lower_bound(p, &steps, &d, crate::optimize::SeamMode::Any, from).unwrap().travel_s
    }

    #[test]
    fn a_hop_along_x_is_bounded_at_x_s_own_acceleration() {
        // The servo kit (samples/servo-plotter.toml: 1500 mm/s² and 150 mm/s per axis, travel at 120 mm/s, a
        // servo pen: hops from rest to rest). From (10, 10) to a line starting 30 mm along X: 30 mm less two X
        // steps, 29.975 mm, at X's 1500 mm/s² up to 120 mm/s: ramps of 9.6 mm in 0.16 s, 20.375 mm cruising in
        // 0.169 79 s: 0.329 79 s. The bound took the diagonal's 2121.3 mm/s² for it before: 0.306 27 s.
        let p = sample("servo-plotter.toml");
        let t = travel_to_line(&p, (10.0, 10.0), (40.0, 10.0), (60.0, 10.0));
        assert!((t - 0.329_79).abs() < 1e-5, "{t}");
        // A 30 × 40 mm diagonal: Y's 39.975 mm at 1500 mm/s² take 0.413 13 s, the path's 49.965 mm at the
        // 120 mm/s travel feed and 2121.3 mm/s² take longer, 0.472 94 s (as before: the feed, not an axis, limits
        // the diagonal).
        let t = travel_to_line(&p, (10.0, 10.0), (40.0, 50.0), (60.0, 50.0));
        assert!((t - 0.472_94).abs() < 1e-5, "{t}");
        // The AxiDraw V3 (760 mm/s² and 155 mm/s per axis, travel at 165 mm/s, a servo pen): there Y's term is the
        // larger on the same diagonal. Y: 39.975 mm up to 155 mm/s at 760 mm/s², ramps of 31.612 mm in
        // 0.407 89 s, 8.363 mm cruising in 0.053 96 s: 0.461 85 s. The path, 49.965 mm up to 165 mm/s at
        // 1074.8 mm/s²: ramps of 25.330 mm in 0.307 03 s, 24.634 mm cruising in 0.149 30 s: 0.456 33 s, all the
        // bound took before.
        // Its hop's travel is that; the hop (the plot's first, with no lift before it) is charged beyond it what
        // the servo's drop window adds after a full lift, less the most a lift may add to a hop
        // ([`crate::motion::hop_time::HopTime::lift_excess`]).
        let v3 = sample("axidraw-v3.toml");
        let hop = crate::motion::hop_time::HopTime::of(&v3);
        assert!((hop.travel_seconds(30.0, 40.0) - 0.461_85).abs() < 1e-5, "{}", hop.travel_seconds(30.0, 40.0));
        let t = travel_to_line(&v3, (10.0, 10.0), (40.0, 50.0), (60.0, 50.0));
        assert!((t - (hop.seconds(30.0, 40.0) - hop.lift_excess())).abs() < 1e-9, "{t}");
    }

    #[test]
    fn a_bridged_drawing_is_bounded_as_the_machine_draws_it() {
        // Two 20 mm lines along X, 0.3 mm apart, on the servo kit (pen 0.3 mm wide by default: the optimizer's
        // bridges join gaps under the pen's width). Bridged, they are one 40.3 mm stroke: one drop, one lift.
        use crate::geometry::drawing::{Drawing, Polyline};
        use crate::optimize::{OptimizeOptions, SeamMode, optimize};
        use kurbo::Point;
        let p = sample("servo-plotter.toml");
        let line = |a: f64, b: f64| Polyline::new(vec![Point::new(a, 20.0), Point::new(b, 20.0)]);
        let apart = Drawing::single_layer("l", vec![line(10.0, 30.0), line(30.3, 50.3)]);
        let mut bridged = apart.clone();
        // From home, where the plan starts.
        let home = homed_position(&p).unwrap();
        let at = Point::new(f64::from(home[0]) / p.axes.x.steps_per_mm, f64::from(home[1]) / p.axes.y.steps_per_mm);
        let start = Some(p.machine_to_page(at));
        let opts = OptimizeOptions { bridge_mm: 0.5, merge: false, start, ..OptimizeOptions::default() };
        assert_eq!(optimize(&mut bridged, &opts).unwrap().bridges, 1);
        assert_eq!(bridged.path_count(), 1);
        let bound_of = |d: &Drawing| {
            let steps = crate::geometry::steps::drawing_to_steps(&p, d).unwrap();
            (drawing_time_lower_bound(&p, &steps, d, SeamMode::Any, start).unwrap(), steps)
        };
        let (b_bridged, steps) = bound_of(&bridged);
        let planned = plan(&p, &steps, home, Lookahead::Whole).unwrap().seconds();
        // The bridged drawing's bound holds for its plan (one stroke: one hop from home, one lift).
        assert!(b_bridged.total_s() <= planned, "{b_bridged:?} vs {planned}");
        // The lines as given would be bounded above that plan: two strokes, so a second lift and drop of the
        // servo (its clear time and contact window, some 0.1 s) that the bridge saves. A bound of the unbridged
        // paths is no bound of what the machine is given once the pen's width has joined them, which is why the
        // bound takes the drawing as optimized (see the module docs).
        let (b_apart, _) = bound_of(&apart);
        assert!(b_apart.total_s() > planned, "{b_apart:?} vs {planned}");
    }

    /// The built-in profile without the curve model: every join of an XY move and a Z move is a 90° corner.
    fn corners_only() -> MachineProfile {
        let mut p = MachineProfile::default_plotter();
        p.motion.curve_deviation_mm = 0.0;
        p
    }

    #[test]
    fn with_the_curve_model_the_z_joins_go_at_the_feeds() {
        // The built-in profile plans with the curve model, so a short chord into the pen's rise may make that join
        // a curve point, taken at up to the slower feed (Z's 25 mm/s). A line whose last chord is 0.25 mm (under
        // 2·0.1/tan 22.5° = 0.483 mm): the rise of the 1 mm clearance may run at 25 mm/s throughout (0.04 s), the
        // drop enter at 25 mm/s and stop at 500 mm/s² (0.04 + 25/1000 = 0.065 s), plus the drop's and the final
        // lift's 50 ms settles: 0.205 s. The line may end at 25 mm/s into the rise: 100.25/60 + 60/(2a) +
        // (60 − 25)²/(2a·60) with a = 1500, X's own acceleration (a line along X cannot speed up faster, whatever
        // the diagonal's 1500·√2), less the microsecond per chord the stepper's rounding may take off.
        let p = MachineProfile::default_plotter();
        let line = |moves: Vec<StepDelta>| {
            StepDrawing::from_strokes(vec![StepStroke { start: StepPos::new(800, 800), moves }])
        };
        let short_end = line(vec![StepDelta { dx: 8000, dy: 0 }, StepDelta { dx: 20, dy: 0 }]);
        let b = plot_time_lower_bound(&p, &short_end, 0.0).unwrap();
        // And the plot's last lift goes on to the pen-up height 4 mm up (less the step rounding may take off) and
        // stops: (3.9975 − 0.625)/25 + 25/500 = 0.1849 s in all, 0.1449 s beyond the rise.
        let last = 0.1849 - 0.04;
        assert!((b.lifts_s - 0.205 - last).abs() < 1e-12, "{b:?}");
        let a = 1500.0;
        let draw = 100.25 / 60.0 + 60.0 / (2.0 * a) + 35.0 * 35.0 / (2.0 * a * 60.0) - 2e-6;
        assert!((b.draw_s - draw).abs() < 5e-6, "{b:?} vs {draw}");
        // A line whose last chord is 100 mm turns by exactly 90° into the Z-only rise, a corner: it ends at the
        // corner's speed with Z's 500 mm/s² (the lower of its two blocks'), v = √(500·0.02·√½/(1 − √½)) =
        // 4.913 mm/s, and the rise starts from there: up to 25 mm/s within (625 − v²)/1000 mm, the rest of the
        // 1 mm at 25 mm/s.
        let b = plot_time_lower_bound(&p, &line(vec![StepDelta { dx: 8000, dy: 0 }]), 0.0).unwrap();
        let s = std::f64::consts::FRAC_1_SQRT_2;
        let v = (500.0 * 0.02 * s / (1.0 - s)).sqrt();
        assert!((v - 4.913).abs() < 1e-3, "{v}");
        let rise = (25.0 - v) / 500.0 + (1.0 - (625.0 - v * v) / 1000.0) / 25.0;
        // The last lift from 4.913 mm/s: its first 1 mm as the rise, the other 2.9975 mm at 25 mm/s and the stop,
        // 2.9975/25 − 0.625/25 + 0.05 s: the same 0.1449 s beyond the rise.
        let lifts = rise + 0.065 + 0.1 + last;
        assert!((b.lifts_s - lifts).abs() < 1e-12, "{b:?} vs {lifts}");
        let draw = 100.0 / 60.0 + 60.0 / (2.0 * a) + (60.0 - v).powi(2) / (2.0 * a * 60.0) - 1e-6;
        assert!((b.draw_s - draw).abs() < 5e-6, "{b:?} vs {draw}");
        let a = 1500f64.hypot(1500.0);
        // A hop shorter than 1.0947 mm may start and end at 25 mm/s too (its joins may be curve points): 1 mm less
        // the slack, from 25 mm/s and back, never reaching the feed.
        let len = 1.0 - 2.0 * (1.0f64 / 80.0).hypot(1.0 / 80.0);
        let t = 2.0 * (((a * len + 625.0).sqrt()) - 25.0) / a;
        assert!((min_hop_seconds(&p)(1.0) - t).abs() < 1e-9, "{} vs {t}", min_hop_seconds(&p)(1.0));
        // A longer one has corners at both joins (5.3707 mm/s, [`crate::motion::hop_time`]), and its rise and
        // drop pay for them (0.015 07 and 0.014 98 s): 100 mm less the slack from 5.3707 to 120 mm/s and back.
        let (len, v) = (100.0 - 2.0 * (1.0f64 / 80.0).hypot(1.0 / 80.0), 5.3707);
        let t = 2.0 * (120.0 - v) / a + (len - (120.0 * 120.0 - v * v) / a) / 120.0 + 0.015_07 + 0.014_98;
        assert!((min_hop_seconds(&p)(100.0) - t).abs() < 2e-5, "{} vs {t}", min_hop_seconds(&p)(100.0));
    }

    #[test]
    fn one_dimensional_minimum_times() {
        // 100 mm at 60 mm/s, 1500 mm/s²: ramps of 1.2 mm each, 0.04 s each; 97.6 mm cruise → 1.6667 + 0.04.
        assert!((fastest_piece(100.0, 0.0, 0.0, 60.0, 1500.0) - (100.0 / 60.0 + 0.04)).abs() < 1e-12);
        // Too short to reach the feed: triangle, 2·√(L/a).
        assert!((fastest_piece(1.0, 0.0, 0.0, 60.0, 1500.0) - 2.0 * (1.0f64 / 1500.0).sqrt()).abs() < 1e-12);
        // Entering at full speed and leaving at rest: only the deceleration ramp.
        assert!((fastest_piece(100.0, 60.0, 0.0, 60.0, 1500.0) - (100.0 / 60.0 + 0.02)).abs() < 1e-12);
    }

    #[test]
    fn min_hop_by_hand() {
        let p = corners_only();
        let hop = min_hop_seconds(&p);
        // a = 1500·√2; the corners with the Z moves, a turn of 90° less the travel's tilt (up to twice the hop
        // slope 0.051 65: atan 0.1033 = 5.897°), v₁ = √(a_z·0.02·sin(θ/2)/(1 − sin(θ/2))) with
        // sin(θ/2) = sin(47.949°) = 0.742 66 at Z's 500 mm/s² (the planner corners at the lower acceleration of
        // its two blocks, and one is Z's); the slack two step diagonals.
        let a = 1500f64.hypot(1500.0);
        let s = 0.742_66;
        let v1 = (500.0f64 * 0.02 * s / (1.0 - s)).sqrt();
        let slack = 2.0 * (1.0f64 / 80.0).hypot(1.0 / 80.0);
        // 100 mm: ramp up from v₁ to 120, ramp down to v₁, cruise the rest.
        let len = 100.0 - slack;
        let ramp = (120.0 * 120.0 - v1 * v1) / (2.0 * a);
        let t = 2.0 * (120.0 - v1) / a + (len - 2.0 * ramp) / 120.0;
        assert!((hop(100.0) - t).abs() < 1e-5, "{} vs {t}", hop(100.0));
        // Shorter than the slack: nothing is certain.
        assert_eq!(hop(slack / 2.0), 0.0);
        // Monotone.
        assert!(hop(1.0) < hop(2.0) && hop(2.0) < hop(100.0));
    }

    #[test]
    fn the_bound_is_below_the_plan_and_tight_on_a_long_line() {
        let p = corners_only();
        // One 100 mm line from (10, 10) mm, reached from home by a 10·√2 mm hop.
        let steps = StepDrawing::from_strokes(vec![StepStroke {
            start: StepPos::new(800, 800),
            moves: vec![StepDelta { dx: 8000, dy: 0 }],
        }]);
        let planned = plan(&p, &steps, homed_position(&p).unwrap(), Lookahead::Whole).unwrap();
        let b = plot_time_lower_bound(&p, &steps, 0.1).unwrap();
        assert!(b.total_s() <= planned.seconds(), "{b:?} vs {}", planned.seconds());
        // Drawing along X: the plan and the bound accelerate at 1500 mm/s² (X alone), and the bound may leave at
        // the 90° corner speed into the lift with the lower acceleration of the line's and the Z-only rise's (Z's
        // 500 mm/s², as the planner takes a corner), √(500·δ·√½/(1 − √½)); less the microsecond of the stepper's
        // rounding.
        let a = 1500.0;
        let s = std::f64::consts::FRAC_1_SQRT_2;
        let v_lift = (500.0 * 0.02 * s / (1.0 - s)).sqrt();
        assert!((b.draw_s - fastest_piece(100.0, 0.0, v_lift, 60.0, a) + 1e-6).abs() < 5e-6, "{b:?}");
        let by_hand = 100.0 / 60.0 + 60.0 / a / 2.0 + (60.0 - v_lift).powi(2) / (2.0 * a * 60.0) - 1e-6;
        assert!((b.draw_s - by_hand).abs() < 5e-6, "{b:?} vs {by_hand}");
        // The plan leaves the line into the lift at that very corner: it is slower only by the rounding of its
        // rates to whole steps per second.
        assert!(planned.breakdown().draw_s() - b.draw_s < 1e-4, "{:?} vs {b:?}", planned.breakdown());
        // Lifts: the drop's and the final lift's 50 ms dwells, and 1 mm of Z (the clearance) off the paper and
        // onto it. Off: from the 90° corner √(500·0.02·√½/(1 − √½)) = 4.913 mm/s into the hop's corner (the
        // travel climbing at up to 2·0.051 65: sin(θ/2) = sin((90° + 5.897°)/2) = 0.742 66, √(10·0.742 66/0.257 34)
        // = 5.371 mm/s); 1 mm is too short to reach 25 mm/s: a triangle peaking at √((2·500·1 + v0² + v1²)/2).
        let vz = (500.0 * 0.02 * s / (1.0 - s)).sqrt();
        let vh = hop_corner_speed(&p, 500.0);
        assert!((vz - 4.913).abs() < 1e-3 && (vh - 5.371).abs() < 1e-3, "{vz} {vh}");
        let tri = |v0: f64, v1: f64| {
            let peak = ((1000.0 + v0 * v0 + v1 * v1) / 2.0).sqrt();
            (2.0 * peak - v0 - v1) / 500.0
        };
        // The last lift goes on to the pen-up height (4 mm less a step of 400 per mm) and stops: from vz up to
        // 25 mm/s, cruise, stop at 500 mm/s², beyond the rise counted for its stroke.
        let full = (25.0 - vz) / 500.0 + (3.9975 - (625.0 - vz * vz) / 1000.0 - 0.625) / 25.0 + 0.05;
        let lifts = tri(vz, vh) + tri(vh, 0.0) + 2.0 * 0.05 + (full - tri(vz, vh));
        assert!((b.lifts_s - lifts).abs() < 1e-9, "{b:?} vs {lifts}");
        // Travel: handed in as it is.
        assert_eq!(b.travel_s, 0.1);
        // A zig-zag stops at each reversal: three 10 mm legs take three rest-to-rest motions.
        let zig = StepDrawing::from_strokes(vec![StepStroke {
            start: StepPos::new(800, 800),
            moves: vec![StepDelta { dx: 800, dy: 0 }, StepDelta { dx: -800, dy: 0 }, StepDelta { dx: 800, dy: 0 }],
        }]);
        let b = plot_time_lower_bound(&p, &zig, 0.0).unwrap();
        assert_eq!(b.travel_s, 0.0);
        assert!(
            (b.draw_s - 2.0 * fastest_piece(10.0, 0.0, 0.0, 60.0, a) - fastest_piece(10.0, 0.0, v_lift, 60.0, a)
                + 3e-6)
                .abs()
                < 5e-6
        );
        let planned = plan(&p, &zig, homed_position(&p).unwrap(), Lookahead::Whole).unwrap();
        assert!(b.total_s() <= planned.seconds());
    }

    #[test]
    fn a_servo_pen_stops_drawing_and_lifts_in_its_settle_time() {
        let mut p = MachineProfile::default_plotter();
        p.pen.command = crate::config::profile::PenCommand::Servo;
        p.pen.settle_ms = 150.0;
        let steps = StepDrawing::from_strokes(vec![StepStroke {
            start: StepPos::new(800, 800),
            moves: vec![StepDelta { dx: 8000, dy: 0 }],
        }]);
        let b = plot_time_lower_bound(&p, &steps, min_hop_seconds(&p)(200f64.sqrt())).unwrap();
        // The servo block is a stop: the 100 mm line runs rest to rest. Lifts: the first and last lifts' 150 ms
        // each, less the one stroke's clear time (0.3 of the 150 ms swing to the contact fraction 0.7: 45 ms,
        // and the tick the rounding slack adds), which is counted per stroke; and the stroke's drop command (one
        // tick: a servo of known timing needs no wait beyond the contact, which the travel may overlap).
        // The line runs along X at X's 1500 mm/s² (less the microsecond of the stepper's rounding).
        assert!((b.draw_s - (100.0 / 60.0 + 60.0 / 1500.0 - 1e-6)).abs() < 5e-6, "{b:?}");
        assert!((b.lifts_s - 0.300_001).abs() < 1e-9, "{b:?}");
        let a = 1500f64.hypot(1500.0);
        let planned = plan(&p, &steps, homed_position(&p).unwrap(), Lookahead::Whole).unwrap();
        assert!(b.total_s() <= planned.seconds(), "{b:?} vs {}", planned.seconds());
        // The hop from home runs rest to rest between the servo's blocks (the Z feed, 25 mm/s, is no servo's
        // speed): 14.142 mm less the two step diagonals (0.035 36 mm) at 120 mm/s and 2121.3 mm/s², reaching
        // 120 mm/s within 3.39 mm at either end: 14.107/120 + 120/2121.3 = 0.174 13 s.
        let t = (200f64.sqrt() - 2.0 * (1.0f64 / 80.0).hypot(1.0 / 80.0)) / 120.0 + 120.0 / a;
        assert!((b.travel_s - t).abs() < 1e-9, "{b:?} vs {t}");
    }

    #[test]
    fn the_profiles_acceleration_caps_bound_drawing_and_travel() {
        // The axes allow 1500 mm/s² each (√2·1500 along a diagonal), but the profile caps drawing at 500 and travel
        // at 800 mm/s², as the plan does.
        let mut p = corners_only();
        (p.pen.draw_accel_mm_s2, p.pen.travel_accel_mm_s2) = (Some(500.0), Some(800.0));
        let steps = StepDrawing::from_strokes(vec![StepStroke {
            start: StepPos::new(800, 800),
            moves: vec![StepDelta { dx: 8000, dy: 0 }],
        }]);
        let b = plot_time_lower_bound(&p, &steps, 0.0).unwrap();
        // 100 mm at 60 mm/s from rest, up at 500 mm/s² (0.12 s, 3.6 mm), leaving at the 90° corner into the lift
        // with the same 500: v₁ = √(500·0.02·√½/(1 − √½)) = 4.913 mm/s, down in (60 − v₁)/500 s:
        // 100/60 + 60/(2·500) + (60 − v₁)²/(2·500·60) = 1.666 67 + 0.06 + 0.050 58 = 1.777 24 s.
        assert!((b.draw_s - 1.777_24).abs() < 1e-4, "{b:?}");
        let planned = plan(&p, &steps, homed_position(&p).unwrap(), Lookahead::Whole).unwrap();
        assert!(b.total_s() <= planned.seconds(), "{b:?} vs {}", planned.seconds());
        // The plan's own drawing time is no shorter: its blocks accelerate at 500 along X.
        assert!(b.draw_s <= planned.breakdown().draw_s(), "{b:?} vs {:?}", planned.breakdown());
        // Travel: a 100 mm hop at 800 mm/s² between corners with the Z moves, v₁ = √(500·0.02·s/(1 − s)) with
        // s = 0.742 66 at Z's 500 mm/s² (see `min_hop_by_hand`), up to the 120 mm/s feed and back down, less the
        // slack.
        let (a, s): (f64, f64) = (800.0, 0.742_66);
        let v1 = (500.0 * 0.02 * s / (1.0 - s)).sqrt();
        let len = 100.0 - 2.0 * (1.0f64 / 80.0).hypot(1.0 / 80.0);
        let t = 2.0 * (120.0 - v1) / a + (len - (120.0 * 120.0 - v1 * v1) / a) / 120.0;
        assert!((min_hop_seconds(&p)(100.0) - t).abs() < 1e-5, "{} vs {t}", min_hop_seconds(&p)(100.0));
        // Caps above what the axes allow change nothing.
        let mut loose = p.clone();
        (loose.pen.draw_accel_mm_s2, loose.pen.travel_accel_mm_s2) = (Some(1e6), Some(1e6));
        let free = corners_only();
        assert_eq!(plot_time_lower_bound(&loose, &steps, 0.0), plot_time_lower_bound(&free, &steps, 0.0));
        assert_eq!(min_hop_seconds(&loose)(100.0), min_hop_seconds(&free)(100.0));
    }

    #[test]
    fn entry_and_exit_speeds_the_length_cannot_connect_are_capped() {
        let t = (3100f64.sqrt() - 10.0) / 1500.0;
        // Entering at 60 mm/s, 1 mm before a 10 mm/s exit at 1500 mm/s²: the entry is at most √(10² + 2·1500·1),
        // and the whole millimetre is deceleration from there to 10.
        assert!((fastest_piece(1.0, 60.0, 10.0, 60.0, 1500.0) - t).abs() < 1e-12);
        // The mirror: from 10 mm/s the exit reaches at most √3100 in 1 mm.
        assert!((fastest_piece(1.0, 10.0, 60.0, 60.0, 1500.0) - t).abs() < 1e-12);
        // From 10 to 20 mm/s over 1 mm: a triangle peaking at √((2·1500·1 + 10² + 20²)/2) = √1750, below the feed.
        let t = (2.0 * 1750f64.sqrt() - 30.0) / 1500.0;
        assert!((fastest_piece(1.0, 10.0, 20.0, 60.0, 1500.0) - t).abs() < 1e-12);
    }

    #[test]
    fn the_total_is_the_sum_of_the_parts() {
        let b = TimeBound { draw_s: 1.5, lifts_s: 2.0, travel_s: 4.25 };
        assert_eq!(b.total_s(), 7.75);
    }

    #[test]
    fn the_z_moves_span_the_clearance_capped_by_the_pen_heights() {
        let mut p = corners_only();
        let steps = StepDrawing::from_strokes(vec![StepStroke {
            start: StepPos::new(800, 800),
            moves: vec![StepDelta { dx: 800, dy: 0 }],
        }]);
        let s = std::f64::consts::FRAC_1_SQRT_2;
        let vz = (500.0 * 0.02 * s / (1.0 - s)).sqrt();
        let vh = hop_corner_speed(&p, 500.0);
        // The clearance `c` up and down, and the plot's last lift on to the pen-up height `u` mm from the paper.
        let lifts =
            |c: f64, u: f64| fastest_piece(u, vz, 0.0, 25.0, 500.0) + fastest_piece(c, vh, 0.0, 25.0, 500.0) + 0.1;
        let at = |p: &MachineProfile| plot_time_lower_bound(p, &steps, 0.0).unwrap().lifts_s;
        // 1 mm of clearance, 4 mm from the paper to the pen-up height (less the step, of 400 per mm, that rounding
        // both heights may take off the span).
        assert!((at(&p) - lifts(1.0, 3.9975)).abs() < 1e-12);
        // Only 0.4 mm between the paper and the pen-up height: the clearance is capped there.
        (p.pen.down_z_mm, p.pen.up_z_mm) = (3.6, 4.0);
        assert!((at(&p) - lifts(0.3975, 0.3975)).abs() < 1e-12);
        // A larger clearance, and a pen-table pen that sits higher and caps it and the last lift.
        (p.pen.down_z_mm, p.pen.clearance_mm) = (0.0, 2.0);
        assert!((at(&p) - lifts(2.0, 3.9975)).abs() < 1e-12);
        p.pens[0].down_z_mm = Some(2.5);
        assert!((at(&p) - lifts(1.4975, 1.4975)).abs() < 1e-12);
        assert!(lifts(1.5, 4.0) < lifts(2.0, 4.0));
    }

    #[test]
    fn without_the_curve_model_every_vertex_is_a_corner() {
        // saxi's limits: drawing at 50 mm/s and 200 mm/s², junction deviation 0.127 mm, a servo pen (strokes end
        // at rest). One stroke of two 10 mm legs turning by 60°.
        let mut p = MachineProfile::from_toml(include_str!("../../../samples/axidraw-saxi.toml"), "saxi.toml").unwrap();
        let stroke = StepDrawing::from_strokes(vec![StepStroke {
            start: StepPos::new(800, 800),
            moves: vec![StepDelta { dx: 800, dy: 0 }, StepDelta { dx: 400, dy: 693 }],
        }]);
        // The second leg is 10.0005 mm long at 60.0° (693 ≈ 400·√3 = 692.8 steps).
        let l2 = (400.0f64).hypot(693.0) / 80.0;
        p.motion.curve_deviation_mm = 0.0;
        let b = plot_time_lower_bound(&p, &stroke, 0.0).unwrap();
        // The corner: cos = 400/800.02 between the legs' directions, sin(θ/2) = √((1 + cos)/2) ≈ √0.75, and
        // v² = 200·0.127·sin(θ/2)/(1 − sin(θ/2)) ≈ 164.2 (12.81 mm/s). Each leg from or to rest is a triangle
        // (peak √((2·200·10 + v²)/2) ≈ 45.6 mm/s, below the feed).
        let cos = 400.0 / (400.0f64).hypot(693.0);
        let sh = ((1.0 + cos) / 2.0).sqrt();
        let vc2 = 200.0 * 0.127 * sh / (1.0 - sh);
        assert!((vc2.sqrt() - 12.81).abs() < 0.01, "{}", vc2.sqrt());
        let tri = |len: f64| {
            let peak = ((2.0 * 200.0 * len + vc2) / 2.0).sqrt();
            (2.0 * peak - vc2.sqrt()) / 200.0
        };
        assert!((b.draw_s - tri(10.0) - tri(l2)).abs() < 5e-6, "{b:?}");
        assert!((b.draw_s - 0.7846).abs() < 1e-3, "{b:?}");
        // With the curve model the 60° vertex is no curve's either (the circle tangent to both 10 mm legs strays
        // 5·tan 15° = 1.34 mm from it, beyond the 0.1 mm curve deviation): the profile's vertex limit is the same
        // junction-deviation speed, and the bound the same.
        p.motion.curve_deviation_mm = 0.1;
        let b = plot_time_lower_bound(&p, &stroke, 0.0).unwrap();
        assert!((b.draw_s - tri(10.0) - tri(l2)).abs() < 5e-6, "{b:?}");
        // Both below what the planner makes of it, within the rounding of rates to whole steps per second.
        for (dev, slack) in [(0.0, 1.001), (0.1, 1.001)] {
            p.motion.curve_deviation_mm = dev;
            let b = plot_time_lower_bound(&p, &stroke, 0.0).unwrap();
            let planned = plan(&p, &stroke, [0; 4], Lookahead::Whole).unwrap();
            let draw_s = planned.breakdown().draw_s();
            assert!(b.draw_s <= draw_s && draw_s < b.draw_s * slack, "{dev}: {b:?} vs {draw_s}");
        }
    }

    /// Fastest motion over `len` mm from `v0` to `v1` at acceleration `a` under top speed `top` (speeds the length
    /// can connect): a trapezoid, or a triangle when the length is too short to reach `top`. Written out apart
    /// from the bound's own, for the hand-computed tests below.
    fn trapezoid(len: f64, v0: f64, v1: f64, top: f64, a: f64) -> f64 {
        let peak = ((2.0 * a * len + v0 * v0 + v1 * v1) / 2.0).sqrt();
        if peak <= top {
            return (2.0 * peak - v0 - v1) / a;
        }
        let ramps = (2.0 * top * top - v0 * v0 - v1 * v1) / (2.0 * a);
        (2.0 * top - v0 - v1) / a + (len - ramps) / top
    }

    /// One stroke from (10, 10) mm with `moves` in steps.
    fn stroke(moves: &[(i32, i32)]) -> StepDrawing {
        StepDrawing::from_strokes(vec![StepStroke {
            start: StepPos::new(800, 800),
            moves: moves.iter().map(|&(dx, dy)| StepDelta { dx, dy }).collect(),
        }])
    }

    #[test]
    fn a_squares_right_angles_are_capped_at_the_junction_deviation_speed() {
        // The built-in profile (80 steps/mm, 1500 mm/s² and 150 mm/s per axis, drawing at 60 mm/s, junction
        // deviation 0.02 mm, the curve model on). A 10 mm square: each 90° vertex is a corner (no curve: the
        // circle tangent to both 10 mm legs strays 5·tan 22.5° = 2.07 mm from it), passed at most at junction
        // deviation's speed with the largest acceleration any direction allows, 1500·√2 = 2121.32 mm/s²:
        // v² = 2121.32·0.02·√½/(1 − √½) = 102.43, v = 10.121 mm/s. Each side runs along one axis at that axis's
        // 1500 mm/s² and 60 mm/s; the stroke starts at rest and ends into the lift at no more than the 90° corner
        // with the Z-only rise, at Z's 500 mm/s² (the lower of the two blocks'): √(500·0.02·√½/(1 − √½)) =
        // 4.913 mm/s.
        let p = MachineProfile::default_plotter();
        let square = stroke(&[(800, 0), (0, 800), (-800, 0), (0, -800)]);
        let b = plot_time_lower_bound(&p, &square, 0.0).unwrap();
        let (vc, ve) = (10.121, 4.913_46);
        // Sides: 0 → vc: 60/1500 + (60 − vc)/1500 + (10 − 1.2 − 1.1659)/60 = 0.200 49 s; vc → vc:
        // 2·(60 − vc)/1500 + (10 − 2·1.1659)/60 = 0.194 31 s (×2); vc → ve: 0.033 25 + 0.036 72 + (10 − 1.1659 −
        // 1.1920)/60 = 0.197 35 s. Less a microsecond each for the stepper's rounding.
        let by_hand = 0.200_49 + 2.0 * 0.194_31 + 0.197_35 - 4e-6;
        assert!((b.draw_s - by_hand).abs() < 5e-5, "{b:?} vs {by_hand}");
        let formula = trapezoid(10.0, 0.0, vc, 60.0, 1500.0)
            + 2.0 * trapezoid(10.0, vc, vc, 60.0, 1500.0)
            + trapezoid(10.0, vc, ve, 60.0, 1500.0)
            - 4e-6;
        assert!((b.draw_s - formula).abs() < 5e-6, "{b:?} vs {formula}");
        let planned = plan(&p, &square, homed_position(&p).unwrap(), Lookahead::Whole).unwrap();
        assert!(b.draw_s <= planned.breakdown().draw_s(), "{b:?} vs {:?}", planned.breakdown());
    }

    #[test]
    fn a_zig_zag_of_30_degree_turns_is_capped_at_each_turn() {
        // Three legs of 10 mm at +15°, −15°, +15° (773 × ±207 steps: 10.0029 mm, 14.99°): each vertex turns by
        // 29.98°, a corner (the circle tangent to both legs strays 5·tan 7.5° = 0.66 mm, beyond the 0.1 mm curve
        // deviation), passed at junction deviation's speed with 2121.32 mm/s²: θ = 150.02° between the reversed
        // incoming and the outgoing leg, sin(θ/2) = 0.965 97, v² = 2121.32·0.02·0.965 97/0.034 03 = 1204.4,
        // v = 34.70 mm/s. Each leg: top speed 60 mm/s (X's 150/0.966 is more), acceleration X's
        // 1500/0.965 97 = 1552.8 mm/s².
        let p = MachineProfile::default_plotter();
        let zig = stroke(&[(773, 207), (773, -207), (773, 207)]);
        let b = plot_time_lower_bound(&p, &zig, 0.0).unwrap();
        let len = 773f64.hypot(207.0) / 80.0;
        let u = 773.0 / 773f64.hypot(207.0);
        let sin_half = ((1.0 + (u * u - (1.0 - u * u))) / 2.0).sqrt();
        let vc = (1500f64.hypot(1500.0) * 0.02 * sin_half / (1.0 - sin_half)).sqrt();
        assert!((vc - 34.70).abs() < 0.01, "{vc}");
        let a = 1500.0 / u;
        assert!((a - 1552.8).abs() < 0.1, "{a}");
        // 0 → vc: 60/a + (60 − vc)/a + (L − (3600 + 3600 − vc²)/2a)/60 = 0.038 64 + 0.016 29 + 0.134 54 =
        // 0.189 47 s; vc → vc: 2·0.016 29 + (L − 2·0.771 36)/60 = 0.173 59 s; vc → ve (the 90° corner into the
        // Z-only rise at Z's 500 mm/s², 4.913 mm/s): 0.016 29 + 0.035 47 + (L − 0.771 36 − 1.151 38)/60 =
        // 0.186 44 s; less a microsecond each.
        let by_hand = 0.189_47 + 0.173_59 + 0.186_44 - 3e-6;
        assert!((b.draw_s - by_hand).abs() < 5e-5, "{b:?} vs {by_hand}");
        let ve = 4.913_46;
        let formula =
            trapezoid(len, 0.0, vc, 60.0, a) + trapezoid(len, vc, vc, 60.0, a) + trapezoid(len, vc, ve, 60.0, a) - 3e-6;
        assert!((b.draw_s - formula).abs() < 5e-6, "{b:?} vs {formula}");
        let planned = plan(&p, &zig, homed_position(&p).unwrap(), Lookahead::Whole).unwrap();
        assert!(b.draw_s <= planned.breakdown().draw_s(), "{b:?} vs {:?}", planned.breakdown());
    }

    /// A circle of radius `r` mm centred at (20, 20) mm in `n` chords, from its rightmost point, on axes of
    /// `spm` steps per mm.
    fn circle(r: f64, n: usize, spm: f64) -> StepDrawing {
        #[allow(clippy::cast_possible_truncation, clippy::cast_precision_loss, reason = "small test geometry")]
        let at = |k: usize| {
            let t = std::f64::consts::TAU * k as f64 / n as f64;
            (((20.0 + r * t.cos()) * spm).round() as i32, ((20.0 + r * t.sin()) * spm).round() as i32)
        };
        let moves = (1..=n).map(|k| StepDelta { dx: at(k).0 - at(k - 1).0, dy: at(k).1 - at(k - 1).1 }).collect();
        let (x, y) = at(0);
        StepDrawing::from_strokes(vec![StepStroke { start: StepPos::new(x, y), moves }])
    }

    #[test]
    fn a_circles_vertices_are_capped_as_the_planner_caps_them() {
        // The built-in profile with a drawing acceleration of 500 mm/s², which then holds along and across the
        // path (the curve's centripetal limit too). A circle of radius 2.5 mm.
        let mut p = MachineProfile::default_plotter();
        p.pen.draw_accel_mm_s2 = Some(500.0);
        // The same at 1000 steps/mm, where a chord's direction is too fine for the steps to round away.
        let mut fine_p = p.clone();
        for axis in [&mut fine_p.axes.x, &mut fine_p.axes.y] {
            axis.steps_per_mm = 1000.0;
        }
        let chord = |n: f64| 2.0 * 2.5 * (std::f64::consts::PI / n).sin();
        // The caps at every vertex inside the stroke, and its drawing time from rest into the lift (`ve`: its last
        // chord is longer than 0.483 mm, so it ends at the 90° corner with the Z-only rise, √(500·0.02·√½/(1 − √½))
        // = 4.913 mm/s; a chord shorter than that may make the join a curve point, at up to Z's 25 mm/s), each
        // chord at 500 mm/s² and up to 60 mm/s between caps `v`.
        let caps = |p: &MachineProfile, steps: &StepDrawing| {
            let cfg = machine_config(p).unwrap();
            let s = &steps.strokes[0];
            let segs =
                vertex_segs(s.moves.iter().filter_map(|d| PlanBlock::line(&cfg, [d.dx, d.dy, 0, 0], 60.0)), 500.0);
            (1..segs.len()).map(|j| vertex_cap(&cfg, &segs, j)).collect::<Vec<f64>>()
        };
        // The speed at vertex k is the least of the cap, what 500 mm/s² reaches from rest over k chords and what
        // still slows to `ve` over the n − k left; each chord the fastest motion between its ends' speeds.
        #[allow(clippy::cast_precision_loss, reason = "a few chords")]
        let time = |n: usize, v: f64| {
            let c = chord(n as f64);
            let ve: f64 = if c > 0.483 { 4.913_46 } else { 25.0 };
            let at = |k: usize| match k {
                0 => 0.0,
                k if k == n => ve,
                k => v.min((1000.0 * c * k as f64).sqrt()).min((ve * ve + 1000.0 * c * (n - k) as f64).sqrt()),
            };
            (0..n).map(|k| trapezoid(c, at(k), at(k + 1), 60.0, 500.0)).sum::<f64>()
        };
        // 16 chords of 0.9755 mm turning 22.5°: vertices of a curve (the circle tangent to both chords strays
        // 0.4877·tan 5.625° = 0.048 mm, within the 0.1 mm curve deviation) of radius 2.5 mm: v² = 500·2.5 = 1250,
        // 35.36 mm/s; junction deviation (θ = 157.5°, sin 78.75° = 0.980 79) allows only v² = 500·0.02·51.05 =
        // 510.5, 22.59 mm/s: the curve's speed is the more permissive, and caps every vertex. Chords from
        // 35.36 mm/s over 0.9755 mm peak at √((975.5 + 2·1250)/2) = 41.69 mm/s: triangles of 0.025 33 s.
        let c16 = circle(2.5, 16, 80.0);
        for (j, v) in caps(&p, &c16).into_iter().enumerate() {
            assert!((v - 35.36).abs() < 0.01 * 35.36, "16 chords, vertex {}: {v}", j + 1);
        }
        let b16 = plot_time_lower_bound(&p, &c16, 0.0).unwrap();
        assert!((b16.draw_s - time(16, 35.36)).abs() < 0.01 * b16.draw_s, "{b16:?} vs {}", time(16, 35.36));
        // 32 chords of 0.4901 mm turning 11.25°: the same curve speed, but junction deviation now allows
        // v² = 500·0.02·sin 84.375°/(1 − sin 84.375°) = 2067, 45.46 mm/s: that caps each vertex instead.
        let c32 = circle(2.5, 32, 1000.0);
        for (j, v) in caps(&fine_p, &c32).into_iter().enumerate() {
            assert!((v - 45.46).abs() < 0.01 * 45.46, "32 chords, vertex {}: {v}", j + 1);
        }
        let b32 = plot_time_lower_bound(&fine_p, &c32, 0.0).unwrap();
        assert!((b32.draw_s - time(32, 45.46)).abs() < 0.01 * b32.draw_s, "{b32:?} vs {}", time(32, 45.46));
        // A finely flattened circle (360 chords of 0.0436 mm): junction deviation allows far more than the
        // 60 mm/s feed at every vertex, but the vertices 16 to 344, whose verdict reads only the stroke's chords,
        // are capped at the curve's 35.36 mm/s, as the planner takes them (the first and last 15 at the feed:
        // their verdict in the plan reads the pen's moves too). Speeds carried over each 0.0436 mm chord at
        // 500 mm/s², from rest, into the lift at 25 mm/s. (Capped at the feed alone it was 0.342 s, up to 60 mm/s.)
        let fine = circle(2.5, 360, 1000.0);
        let b360 = plot_time_lower_bound(&fine_p, &fine, 0.0).unwrap();
        let c = chord(360.0);
        let mut at: Vec<f64> = (0..=360).map(|k| if (16..=344).contains(&k) { 1250f64.sqrt() } else { 60.0 }).collect();
        (at[0], at[360]) = (0.0, 25.0);
        for k in 1..=360 {
            at[k] = at[k].min((at[k - 1] * at[k - 1] + 1000.0 * c).sqrt());
        }
        for k in (0..360).rev() {
            at[k] = at[k].min((at[k + 1] * at[k + 1] + 1000.0 * c).sqrt());
        }
        let t360: f64 = (0..360).map(|k| trapezoid(c, at[k], at[k + 1], 60.0, 500.0)).sum();
        assert!((b360.draw_s - t360).abs() < 0.005 * t360, "{b360:?} vs {t360}");
        assert!(b360.draw_s > 0.4, "{b360:?}");
        for (steps, b, p) in [(&c16, b16, &p), (&c32, b32, &fine_p), (&fine, b360, &fine_p)] {
            let planned = plan(p, steps, [0; 4], Lookahead::Whole).unwrap();
            assert!(b.draw_s <= planned.breakdown().draw_s(), "{b:?} vs {:?}", planned.breakdown());
        }
    }
}

#[cfg(test)]
mod every_part_is_a_bound {
    //! Each part of the plan (pen down, travel, lifts as [`crate::motion::plan::PlanBreakdown`] counts them) is at
    //! least its part of the bound, on the sample drawings and synthetic ones, with every sample profile.
    use super::*;
    use crate::geometry::drawing::{Drawing, Polyline};
    use crate::geometry::steps::drawing_to_steps;
    use crate::input::svg::{SvgOptions, load_svg};
    use crate::motion::plan::{Lookahead, homed_position, plan};
    use crate::optimize::SeamMode;
    use kurbo::Point;

    /// Short strokes of one to three tiny segments scattered over 150 mm, as a traced clip-art drawing has (the
    /// pen lifts into and out of such strokes at more than the 90° corner speed, as the planner's curve rule lets
    /// a short chord into a Z move go).
    fn dashes() -> Drawing {
        let mut paths = Vec::new();
        let mut seed = 7u64;
        let mut next = || {
            seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            f64::from(u32::try_from(seed >> 40).unwrap_or(0)) / f64::from(1u32 << 24)
        };
        for i in 0..120 {
            let (x, y) = (10.0 + 150.0 * next(), 10.0 + 150.0 * next());
            let mut pts = vec![Point::new(x, y)];
            for k in 0..=(i % 3) {
                let at = pts[k];
                pts.push(Point::new(at.x + 0.1 + 0.4 * next(), at.y + 0.3 * next()));
            }
            paths.push(Polyline::new(pts));
        }
        Drawing::single_layer("dashes", paths)
    }

    fn drawings() -> Vec<(String, Drawing)> {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../samples");
        let mut out = vec![("dashes".to_string(), dashes()), ("maze".to_string(), crate::optimize::synth::maze(3))];
        for name in ["duck.svg", "layers.svg", "three-pens.svg", "transforms.svg", "gen/mickey-32.svg"] {
            let d = load_svg(&dir.join(name), &SvgOptions::default()).unwrap().drawing;
            out.push((name.to_string(), d));
        }
        out
    }

    /// Every plotter profile in samples/ (the printer's, with an extruder, plans another way), a servo pen's also
    /// as planned for GRBL.
    fn profiles() -> Vec<(String, MachineProfile)> {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../samples");
        let mut out = Vec::new();
        for e in std::fs::read_dir(dir).unwrap() {
            let path = e.unwrap().path();
            if path.extension().and_then(|x| x.to_str()) != Some("toml") {
                continue;
            }
            let text = std::fs::read_to_string(&path).unwrap();
            let name = path.file_name().unwrap().to_string_lossy().to_string();
            let p = MachineProfile::from_toml(&text, &name).unwrap_or_else(|e| panic!("{name}: {e}"));
            if p.axes.e.is_none() && p.pen.uses_servo() {
                // Planned for GRBL too, which stops the carriage for the drop.
                let grbl = MachineProfile { servo_sync: crate::config::servo_sync::ServoSync::AtRest, ..p.clone() };
                out.push((format!("{name} on GRBL"), grbl));
            }
            if p.axes.e.is_none() {
                out.push((name, p));
            }
        }
        out.sort_by(|a, b| a.0.cmp(&b.0));
        out
    }

    #[test]
    fn no_part_of_the_plan_is_below_its_bound() {
        let profiles = profiles();
        assert!(profiles.len() >= 6, "{:?}", profiles.iter().map(|p| &p.0).collect::<Vec<_>>());
        let drawings = drawings();
        for (pname, p) in &profiles {
            for (dname, d) in &drawings {
                // Scaled into the machine's work area, 5 mm in from its edges (the page's origin is the machine's).
                let mut d = d.clone();
                let r = d.bbox().unwrap();
                let (w, h) = (p.axes.x.travel_mm - 10.0, p.axes.y.travel_mm - 10.0);
                let k = (w / r.width()).min(h / r.height());
                d.map_points(|q| Point::new(5.0 + k * (q.x - r.x0), 5.0 + k * (q.y - r.y0)));
                let d = &d;
                let steps = drawing_to_steps(p, d).unwrap();
                let home = homed_position(p).unwrap();
                let planned = plan(p, &steps, home, Lookahead::Whole).unwrap();
                // Any order and seam, from anywhere: the weakest travel bound, which any plan must still meet.
                let b = drawing_time_lower_bound(p, &steps, d, SeamMode::Any, None).unwrap();
                let parts = planned.breakdown();
                let what = format!("{pname} on {dname}: plan {parts:?}, bound {b:?}");
                assert!(parts.draw_s() >= b.draw_s, "pen down: {what}");
                assert!(parts.lift_s() >= b.lifts_s, "lifts: {what}");
                if p.servo_sync == crate::config::servo_sync::ServoSync::AtRest {
                    // The drop's stop is charged to the hop: the travel with the pen's time above the lifts part.
                    assert!(parts.travel_s() + parts.lift_s() - b.lifts_s >= b.travel_s, "travel: {what}");
                } else {
                    assert!(parts.travel_s() >= b.travel_s, "travel: {what}");
                }
                assert!(planned.seconds() >= b.total_s(), "total: {what}");
            }
        }
    }
}
