//! The motion planner: trapezoidal velocity profiles with curvature-aware cornering, planned by a reverse and a
//! forward pass over a sequence of blocks.
//!
//! The planner is a plain library over `&mut [PlanBlock]`, so the look-ahead is whatever slice the caller passes:
//! the firmware passes its bounded (heapless) queue and re-plans each time a block arrives
//! ([`crate::machine`], through a [`Linker`]); the host passes a whole drawing ([`link_all`]) and gets the exact
//! speed plan and execution time ([`step_blocks`], [`total_ticks`]). One implementation, two callers.
//!
//! # Model
//! Each block is a straight move at constant acceleration `a` up to its nominal speed. Speeds are planned in mm/s
//! along the path, then converted to the major axis's step-event rates ([`to_step_block`]) for the stepper.
//! - Per-axis limits: a block's nominal speed and acceleration are the largest whose projection on every axis
//!   (`v·|u_i|`, `a·|u_i|` with `u` the unit direction) stays within that axis's maximum feed and acceleration.
//! - Corners (junction deviation, the model grbl's planner uses): the path is imagined to round the corner on a
//!   circle that stays within the deviation `δ` of the sharp corner; the speed at the junction is the one whose
//!   centripetal acceleration on that circle equals `a`: `v² = a·δ·sin(θ/2)/(1 − sin(θ/2))` with θ the angle between
//!   the reversed incoming and the outgoing direction (θ = 180° straight on: unlimited; θ = 0 reversal: stop).
//!   Both blocks' nominal speeds cap it too.
//! - Curves: junction deviation judges each vertex on its own, so a curve cut into many short chords would be
//!   planned by how finely it was cut (fine chords: turns so small that the limit exceeds the curve's real
//!   centripetal acceleration; coarse chords: slower than the curve allows). A vertex that samples a smooth curve is
//!   instead planned at the curve's physical limit, `v² = a_n·r`: `r` the curve's radius, `a_n` the acceleration
//!   the axes allow in the curve's normal direction. Which vertices sample a curve, and its radius, are read from
//!   the block geometry alone, so the firmware planning raw G-code and the host planning a drawing agree:
//!   1. *Locally smooth*: the turn is below 90° and the circle tangent to both chords at the middle of the shorter
//!      one stays within `curve_deviation_mm` of the vertex (`m·tan(φ/4)` for turn φ and half-chord `m`; for
//!      chords of a flattened curve that is the flattening's chord error);
//!   2. *Radius over a span*: from the vertex, the path is followed back and forward over locally smooth vertices
//!      for about [`CURVE_SPAN_MM`] (at most [`CURVE_SPAN_BLOCKS`] blocks, turning at most 60° from the tangent,
//!      stopping at corners and fixed blocks); `r` is the circumradius of the two span ends and the vertex. Three
//!      points of one circle give its radius exactly, whatever the chords between them, and points millimetres
//!      apart keep the step rounding of short chords (±½ step) from swamping it;
//!   3. *Consistent*: the vertex's own turn must be what that circle explains for its two chords (within a factor
//!      3 plus the turn ±½ step of rounding can fake); a kink inside a curve fails and is a corner.
//!
//!   A chord between curve vertices that is itself short enough to be a chord of that curve (its sagitta on the
//!   circle within `curve_deviation_mm`) cruises no faster than the faster of its two ends, so coarse chords do
//!   not speed up between vertices either. The limits of a vertex depend on the [`CURVE_SPAN_BLOCKS`] blocks on
//!   either side of it; the firmware's [`Linker`] recomputes them as blocks arrive, so once that many blocks
//!   follow a vertex it has the very values the host computes over the whole drawing.
//! - Reverse pass (last block to first): each entry speed is lowered to what still allows stopping at the end of
//!   the sequence, `v_in² ≤ v_out² + 2aL`. Forward pass: each entry is lowered to what the previous block can
//!   reach, `v_in² ≤ v_prev_in² + 2aL_prev`. The last block exits at rest, so whatever arrives later can be
//!   appended safely; the first block's entry is fixed (it is what the machine is doing).
//!
//! - Extrusion (the printer's E axis) rides along: a move's length and feed are those of its X/Y/Z path, as in
//!   printer firmwares and slicers (`G1 X10 E0.5 F1800` moves the nozzle at 30 mm/s and the extruder in
//!   proportion), so `u_E = ΔE / L_xyz` may exceed 1 and E's own feed and acceleration limits cap the block like
//!   any other axis's. An E-only move (retraction, prime) has its E length as its length. Cornering looks at the
//!   X/Y/Z direction only; a junction between an E-only move and a nozzle move is taken as a right angle.
//!
//! A block with a fixed step plan (a dwell or a host-planned step block) is executed as-is and is a stop boundary
//! for planning: the move before it ends at rest and the move after it starts at rest.

use crate::axis::{Axis, NUM_AXES};
use crate::config::MachineConfig;
use crate::fmath::{floor_u32, sqrt};
use crate::step_block::{MAX_RATE, StepBlock};

/// Path length (mm) followed on each side of a vertex to measure the radius of the curve through it.
pub const CURVE_SPAN_MM: f32 = 2.0;
/// Most blocks followed on each side of a vertex to measure the curve through it (bounds the firmware's work and
/// memory: a vertex's limits are final once this many blocks follow it).
pub const CURVE_SPAN_BLOCKS: usize = 16;
/// The turn at a vertex is judged between chords of at least this many steps (rule 3).
const KINK_SPAN_STEPS: f32 = 24.0;
/// A span stops before a chord turned more than 60° from the tangent at the vertex (cos 60°).
const SPAN_MIN_COS: f32 = 0.5;
/// Locally smooth vertices turn by less than 90°: cos(φ/2) ≥ cos 45°.
const SMOOTH_MIN_COS_HALF: f32 = core::f32::consts::FRAC_1_SQRT_2;

/// One block in the planner: a straight move in steps with its planning data, or a fixed step plan.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlanBlock {
    /// Signed steps per axis.
    pub steps: [i32; NUM_AXES],
    /// A dwell or a host-planned block executed exactly as given (the planner leaves it alone).
    pub fixed: Option<StepBlock>,
    /// Length, mm (from the steps actually taken).
    pub millimeters: f32,
    /// Unit direction in mm space.
    pub unit: [f32; NUM_AXES],
    /// Nominal (cruise) speed after per-axis limits, mm/s.
    pub nominal_speed: f32,
    /// Acceleration after per-axis limits, mm/s².
    pub acceleration: f32,
    /// Highest entry speed² allowed by the junction with the previous block and both blocks' speed limits.
    pub max_entry_speed_sqr: f32,
    /// Highest cruise speed² on a chord of a curve (from the curve's radius); `f32::INFINITY` when not limited.
    pub curve_speed_sqr: f32,
    /// Planned entry speed², mm²/s² (the output of [`plan`]).
    pub entry_speed_sqr: f32,
    /// Step events (major-axis steps) per mm of path: converts mm/s to events/s.
    pub events_per_mm: f32,
}

impl PlanBlock {
    /// A straight move by `steps` at the requested `feed_mm_s`, limited per axis by `config`. `None` when no axis
    /// moves. The junction with the previous block is set by [`link_all`] or a [`Linker`].
    pub fn line(config: &MachineConfig, steps: [i32; NUM_AXES], feed_mm_s: f32) -> Option<PlanBlock> {
        let mut mm = [0.0f32; NUM_AXES];
        let mut len_sq = 0.0f32;
        for axis in Axis::ALL {
            let i = axis.index();
            mm[i] = steps[i] as f32 / config.axis(axis).steps_per_mm;
            if axis != Axis::E {
                len_sq += mm[i] * mm[i];
            }
        }
        if len_sq == 0.0 {
            // E-only: its own length.
            len_sq = mm[Axis::E.index()] * mm[Axis::E.index()];
        }
        let events = steps.iter().map(|s| s.unsigned_abs()).max().unwrap_or(0);
        if events == 0 {
            return None;
        }
        let length = sqrt(len_sq);
        let mut unit = [0.0f32; NUM_AXES];
        let mut nominal = if feed_mm_s.is_finite() && feed_mm_s > 0.0 { feed_mm_s } else { f32::MAX };
        let mut accel = f32::MAX;
        for axis in Axis::ALL {
            let i = axis.index();
            unit[i] = mm[i] / length;
            // An axis that does not move divides by 0: +∞ (or NaN for a zero limit), which `min` ignores.
            let u = unit[i].abs();
            let a = config.axis(axis);
            nominal = nominal.min(a.max_feed_mm_s / u);
            accel = accel.min(a.max_accel_mm_s2 / u);
        }
        let events_per_mm = events as f32 / length;
        // The step rate must stay within what the stepper can time.
        nominal = nominal.min(MAX_RATE as f32 / events_per_mm);
        Some(PlanBlock {
            steps,
            fixed: None,
            millimeters: length,
            unit,
            nominal_speed: nominal,
            acceleration: accel,
            max_entry_speed_sqr: 0.0,
            curve_speed_sqr: f32::INFINITY,
            entry_speed_sqr: 0.0,
            events_per_mm,
        })
    }

    /// A block executed exactly as `block` says (a dwell or a host-planned step block).
    pub fn fixed(block: StepBlock) -> PlanBlock {
        PlanBlock {
            steps: block.steps,
            fixed: Some(block),
            millimeters: 0.0,
            unit: [0.0; NUM_AXES],
            nominal_speed: 0.0,
            acceleration: 0.0,
            max_entry_speed_sqr: 0.0,
            curve_speed_sqr: f32::INFINITY,
            entry_speed_sqr: 0.0,
            events_per_mm: 0.0,
        }
    }

    /// The speed the block cruises at: its nominal speed, lowered on a chord of a curve.
    pub fn cruise_speed(&self) -> f32 {
        if self.curve_speed_sqr < self.nominal_speed * self.nominal_speed {
            sqrt(self.curve_speed_sqr)
        } else {
            self.nominal_speed
        }
    }
}

/// The geometry of a block that cornering needs (what the firmware's [`Linker`] remembers of past blocks).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Seg {
    unit: [f32; NUM_AXES],
    len: f32,
    accel: f32,
    nominal: f32,
    fixed: bool,
}

impl Seg {
    /// The cornering geometry of `b`.
    pub fn of(b: &PlanBlock) -> Seg {
        Seg {
            unit: path_direction(b),
            len: b.millimeters,
            accel: b.acceleration,
            nominal: b.nominal_speed,
            fixed: b.fixed.is_some(),
        }
    }

    const EMPTY: Seg = Seg { unit: [0.0; NUM_AXES], len: 0.0, accel: 0.0, nominal: 0.0, fixed: true };
}

/// The curve a vertex lies on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Curve {
    /// Radius, mm (`f32::INFINITY` on a straight run).
    pub radius: f32,
    /// Speed² at which the centripetal acceleration reaches what the axes allow, mm²/s².
    pub speed_sqr: f32,
}

/// The cornering verdict on the vertex where a block starts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Junction {
    /// Highest speed² through the vertex from its own geometry (before the chords' curve limits).
    pub speed_sqr: f32,
    /// `Some` when the vertex samples a smooth curve (its speed then comes from the curve), `None` at a corner
    /// (junction deviation), a stop or the start.
    pub curve: Option<Curve>,
}

impl Junction {
    const REST: Junction = Junction { speed_sqr: 0.0, curve: None };
}

fn dot(a: &[f32; NUM_AXES], b: &[f32; NUM_AXES]) -> f32 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Junction-deviation speed² between two moving segments (capped by both nominal speeds).
fn deviation_speed_sqr(prev: &Seg, next: &Seg, deviation_mm: f32) -> f32 {
    let cap = (prev.nominal * prev.nominal).min(next.nominal * next.nominal);
    // For unit vectors p, q at angle φ, |p − q| = 2·sin(φ/2); with p = −u_prev this is |u_prev + u_next|/2, which
    // (unlike going through cos θ) stays accurate for nearly reversing corners.
    // Seg units are already the directions cornering sees (`path_direction`).
    let sum_sq: f32 = prev.unit.iter().zip(next.unit).map(|(a, b)| (a + b) * (a + b)).sum();
    let sin_half = 0.5 * sqrt(sum_sq);
    if sin_half < 1e-4 {
        // Reversal.
        return 0.0;
    }
    if sin_half > 0.999_999 {
        // Straight on.
        return cap;
    }
    let a = prev.accel.min(next.accel);
    (a * deviation_mm * sin_half / (1.0 - sin_half)).min(cap)
}

/// Highest speed² at the junction from `prev` into `next` under junction deviation `deviation_mm` alone (also
/// capped by both nominal speeds). 0 when either block is fixed. This is the corner rule; [`link_all`] and
/// [`Linker`] apply it where a vertex is not part of a curve.
pub fn junction_speed_sqr(prev: &PlanBlock, next: &PlanBlock, deviation_mm: f32) -> f32 {
    if prev.fixed.is_some() || next.fixed.is_some() {
        return 0.0;
    }
    deviation_speed_sqr(&Seg::of(prev), &Seg::of(next), deviation_mm)
}

/// The unit direction cornering sees: X/Y/Z for a nozzle move (E dropped), E for an E-only move.
fn path_direction(b: &PlanBlock) -> [f32; NUM_AXES] {
    let e = Axis::E.index();
    let mut d = b.unit;
    if d.iter().enumerate().any(|(i, v)| i != e && *v != 0.0) {
        d[e] = 0.0;
    }
    d
}

/// Turn halves at the vertex between `a` and `b`: (cos φ/2, sin φ/2) with φ the change of direction.
fn half_turn(a: &Seg, b: &Seg) -> (f32, f32) {
    let (mut s, mut d) = (0.0f32, 0.0f32);
    for i in 0..NUM_AXES {
        s += (a.unit[i] + b.unit[i]) * (a.unit[i] + b.unit[i]);
        d += (b.unit[i] - a.unit[i]) * (b.unit[i] - a.unit[i]);
    }
    (0.5 * sqrt(s), 0.5 * sqrt(d))
}

/// Whether the vertex between moving segments `a` and `b` may belong to a smooth curve (rule 1 of the module docs).
fn locally_smooth(a: &Seg, b: &Seg, curve_deviation_mm: f32) -> bool {
    if a.fixed || b.fixed {
        return false;
    }
    let (cos_half, sin_half) = half_turn(a, b);
    if cos_half < SMOOTH_MIN_COS_HALF {
        return false;
    }
    // Circle tangent to both chords at distance m from the vertex: its distance from the vertex is m·tan(φ/4).
    let m = 0.5 * a.len.min(b.len);
    m * sin_half / (1.0 + cos_half) <= curve_deviation_mm
}

/// Follow the path from vertex `j` (where `seg(j)` starts) backwards (`forward == false`, through `seg(j − 1)`,
/// `seg(j − 2)`, …) or forwards (`seg(j)`, `seg(j + 1)`, …); returns the vector from the vertex to the span's end.
/// The span ends `target` mm along the path from the vertex, or sooner where the path stops being one smooth
/// curve (a corner, a fixed block, a chord turned more than 60° from `tangent`, [`CURVE_SPAN_BLOCKS`] chords).
/// With `exact` (the radius's span) the chord the end falls on is cut there: on the arc of the curve through it
/// when the chord is a chord of that curve ([`arc_offset`]), else on the chord itself (a long straight line after
/// a curve); so the span measures the same stretch of a curve however finely it was flattened. Without it (the
/// kink rule's chords, rule 3) a chord is taken whole up to twice `target`, and one reaching further is cut on
/// itself at `target`.
#[allow(clippy::too_many_arguments, reason = "the span's place, direction and extent, each a plain number")]
fn span<F: Fn(usize) -> Seg>(
    seg: &F,
    n: usize,
    j: usize,
    forward: bool,
    tangent: &[f32; NUM_AXES],
    dev: f32,
    target: f32,
    exact: bool,
) -> [f32; NUM_AXES] {
    let mut v = [0.0f32; NUM_AXES];
    let mut len = 0.0f32;
    let sign = if forward { 1.0 } else { -1.0 };
    // The chord before the current one along the span: at first the one across the vertex.
    let across = if forward { j.checked_sub(1) } else { (j < n).then_some(j) };
    let mut prev: Option<Seg> = across.map(seg);
    for count in 0..CURVE_SPAN_BLOCKS {
        let k = if forward {
            j + count
        } else {
            match j.checked_sub(count + 1) {
                Some(k) => k,
                None => break,
            }
        };
        if k >= n {
            break;
        }
        let s = seg(k);
        if count > 0
            && let Some(p) = prev
        {
            // Crossing the vertex between `p` and `s` (in path order: s then p when going back).
            let smooth = if forward { locally_smooth(&p, &s, dev) } else { locally_smooth(&s, &p, dev) };
            if !smooth || dot(&s.unit, tangent) < SPAN_MIN_COS {
                break;
            }
        }
        if s.fixed {
            break;
        }
        if len + s.len <= if exact { target } else { 2.0 * target } {
            for (vi, u) in v.iter_mut().zip(s.unit) {
                *vi += sign * u * s.len;
            }
            len += s.len;
            if len >= target {
                break;
            }
            prev = Some(s);
            continue;
        }
        // The span ends inside this chord, `take` mm along it.
        let take = target - len;
        let bulge = prev.filter(|p| exact && !p.fixed).and_then(|p| {
            // In path order: the earlier chord, then the later.
            let (early, late) = if forward { (&p, &s) } else { (&s, &p) };
            arc_offset(early, late, forward, take, dev)
        });
        for (i, vi) in v.iter_mut().enumerate() {
            *vi += sign * s.unit[i] * take + bulge.map_or(0.0, |b| b[i]);
        }
        break;
    }
    v
}

/// Where the arc of a curve lies off one of its chords: the curve passes through the chords `early` and `late`
/// (consecutive in path order, meeting at a vertex), and the span being measured ends `take` mm along the later
/// chord going forward (`forward`), or the earlier one going back, from the shared vertex. Returns the offset
/// from that point on the chord to the arc (the circle through the far end of `early`, the vertex and the far
/// end of `late`, bulging away from its centre); `None` when the chords do not bend, or when the cut chord is not
/// a chord of that circle within `dev` (its sagitta larger: a long straight line leaving a curve).
fn arc_offset(early: &Seg, late: &Seg, forward: bool, take: f32, dev: f32) -> Option<[f32; NUM_AXES]> {
    let mut p = [0.0f32; NUM_AXES];
    let mut q = [0.0f32; NUM_AXES];
    for i in 0..NUM_AXES {
        p[i] = -early.unit[i] * early.len;
        q[i] = late.unit[i] * late.len;
    }
    let r = circumradius(&p, &q)?;
    let cut = if forward { late } else { early };
    let half = 0.5 * cut.len;
    if half >= r {
        return None;
    }
    // Distance of the arc from the chord `x` from its middle: √(r² − x²) − √(r² − c²/4), written without the
    // cancellation of two nearly equal roots.
    let height = |x: f32| (half * half - x * x) / (sqrt(r * r - x * x) + sqrt(r * r - half * half));
    if height(0.0) > dev {
        return None;
    }
    let h = height(take - half);
    // The bend's direction along the path (later minus earlier direction) points to the centre; its part across
    // the cut chord, reversed, is the way the arc bulges.
    let mut inward: [f32; NUM_AXES] = core::array::from_fn(|i| late.unit[i] - early.unit[i]);
    let along = dot(&inward, &cut.unit);
    for (w, u) in inward.iter_mut().zip(cut.unit) {
        *w -= along * u;
    }
    let norm = sqrt(dot(&inward, &inward));
    if norm <= 1e-9 {
        return None;
    }
    Some(core::array::from_fn(|i| -h * inward[i] / norm))
}

/// The pairs of distinct axes (index pairs), for cross products in any number of dimensions (the array's type
/// stops the build if [`NUM_AXES`] changes and the list is not updated).
const AXIS_PAIRS: [(usize, usize); NUM_AXES * (NUM_AXES - 1) / 2] = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)];

/// Radius of the circle through the origin and the points `p` and `q`; `None` when they are (nearly) collinear.
fn circumradius(p: &[f32; NUM_AXES], q: &[f32; NUM_AXES]) -> Option<f32> {
    let pp = dot(p, p);
    let qq = dot(q, q);
    let mut dd = 0.0f32;
    for i in 0..NUM_AXES {
        dd += (p[i] - q[i]) * (p[i] - q[i]);
    }
    // |p × q|² as the sum of the squared 2×2 minors over the axis pairs (exact for nearly collinear points, where
    // |p|²|q|² − (p·q)² would cancel).
    let mut cross_sq = 0.0f32;
    for (i, k) in AXIS_PAIRS {
        let c = p[i] * q[k] - p[k] * q[i];
        cross_sq += c * c;
    }
    // |p × q| = |p||q|·sin(angle): below ~1e-6 rad the radius is beyond any plotter's size. A point at the origin
    // (|p| or |q| = 0) is caught too: then both sides are 0.
    if cross_sq <= 1e-12 * pp * qq {
        return None;
    }
    Some(sqrt(pp * qq * dd / (4.0 * cross_sq)))
}

/// Both of the profile's limits at a vertex: its junction-deviation speed and, where the vertex samples a smooth
/// curve, that curve.
#[derive(Debug, Clone, Copy, PartialEq)]
struct VertexLimits {
    /// Junction-deviation speed² (capped by both blocks' nominal speeds); 0 at a stop or the start.
    corner_sqr: f32,
    /// Both blocks' nominal speeds, the lower, squared.
    nominal_sqr: f32,
    /// The curve the vertex samples (rules 1 to 3 of the module docs), `None` where it is a corner.
    curve: Option<Curve>,
}

impl VertexLimits {
    const REST: VertexLimits = VertexLimits { corner_sqr: 0.0, nominal_sqr: 0.0, curve: None };
}

/// The cornering verdict at vertex `j` (where `seg(j)` starts) of a sequence of `n` segments: the curve's speed
/// where the vertex samples one, junction deviation's elsewhere. Reads at most [`CURVE_SPAN_BLOCKS`] segments on
/// either side (`seg(j − K) … seg(j + K − 1)`).
fn junction_at<F: Fn(usize) -> Seg>(seg: &F, n: usize, j: usize, cfg: &MachineConfig) -> Junction {
    let l = vertex_limits(seg, n, j, cfg);
    match l.curve {
        Some(c) => Junction { speed_sqr: c.speed_sqr.min(l.nominal_sqr), curve: Some(c) },
        None => Junction { speed_sqr: l.corner_sqr, curve: None },
    }
}

/// The profile's vertex limit at vertex `j` (where `seg(j)` starts) of a sequence of `n` segments, speed²: the
/// more permissive of its junction-deviation speed and, where the vertex samples a smooth curve, the curve's speed
/// (each capped by both blocks' nominal speeds). The machine executes straight blocks, so it passes every vertex
/// with a jump in velocity; how large a jump it takes is the machine's limit the profile states
/// (`junction_deviation_mm`, `curve_deviation_mm`), and no planner within the profile passes a vertex faster than
/// this. The planner itself takes the curve's speed where there is a curve ([`junction_at`], which reads the same
/// limits); a lower bound on plot time takes this, with segments at the largest acceleration any direction allows.
pub fn vertex_limit_sqr<F: Fn(usize) -> Seg>(seg: &F, n: usize, j: usize, cfg: &MachineConfig) -> f32 {
    let l = vertex_limits(seg, n, j, cfg);
    l.curve.map_or(l.corner_sqr, |c| l.corner_sqr.max(c.speed_sqr.min(l.nominal_sqr)))
}

/// The speed² the planner itself allows at vertex `j` (where `seg(j)` starts) of a sequence of `n` segments: a
/// curve's centripetal speed where the vertex samples a smooth curve, junction deviation's at a corner, each capped
/// by both blocks' nominal speeds (what [`link_all`] sets before the chords' curve caps). Reads at most
/// [`CURVE_SPAN_BLOCKS`] segments on either side (`seg(j − K) … seg(j + K − 1)`), so the verdict is the same in
/// any longer sequence holding those segments.
pub fn junction_limit_sqr<F: Fn(usize) -> Seg>(seg: &F, n: usize, j: usize, cfg: &MachineConfig) -> f32 {
    junction_at(seg, n, j, cfg).speed_sqr
}

/// Both limits at vertex `j` (see [`VertexLimits`], [`junction_at`]).
fn vertex_limits<F: Fn(usize) -> Seg>(seg: &F, n: usize, j: usize, cfg: &MachineConfig) -> VertexLimits {
    if j == 0 || j >= n {
        return VertexLimits::REST;
    }
    let (a, b) = (seg(j - 1), seg(j));
    if a.fixed || b.fixed {
        return VertexLimits::REST;
    }
    let nominal_sqr = (a.nominal * a.nominal).min(b.nominal * b.nominal);
    let corner =
        VertexLimits { corner_sqr: deviation_speed_sqr(&a, &b, cfg.junction_deviation_mm), nominal_sqr, curve: None };
    let dev = cfg.curve_deviation_mm;
    if !locally_smooth(&a, &b, dev) {
        return corner;
    }
    let mut tangent = [0.0f32; NUM_AXES];
    for (t, (x, y)) in tangent.iter_mut().zip(a.unit.iter().zip(b.unit)) {
        *t = x + y;
    }
    let tl = sqrt(dot(&tangent, &tangent));
    tangent.iter_mut().for_each(|t| *t /= tl);
    let p = span(seg, n, j, false, &tangent, dev, CURVE_SPAN_MM, true);
    let q = span(seg, n, j, true, &tangent, dev, CURVE_SPAN_MM, true);
    let Some(radius) = circumradius(&p, &q) else {
        // A straight run.
        return VertexLimits { curve: Some(Curve { radius: f32::INFINITY, speed_sqr: f32::INFINITY }), ..corner };
    };
    // Rule 3: the turn at the vertex against the circle's turn. Chords of a few steps have directions too rough
    // for that (±½ step at each end), so the turn is measured between chords at least KINK_SPAN_STEPS long,
    // made of the vertex's neighbours; 2·sin(φ/2) ≈ φ is compared with the circle's turn over them (with a factor
    // 3 for curvature that varies) plus what step rounding can add.
    let mut step = 0.0f32;
    for axis in Axis::ALL {
        let i = axis.index();
        if a.unit[i] != 0.0 || b.unit[i] != 0.0 {
            step = step.max(1.0 / cfg.axis(axis).steps_per_mm);
        }
    }
    let short = KINK_SPAN_STEPS * step;
    let pa = span(seg, n, j, false, &tangent, dev, short, false);
    let qb = span(seg, n, j, true, &tangent, dev, short, false);
    let (la, lb) = (sqrt(dot(&pa, &pa)), sqrt(dot(&qb, &qb)));
    let mut turn_sq = 0.0f32;
    for i in 0..NUM_AXES {
        // The incoming direction is −pa/|pa|.
        let d = qb[i] / lb + pa[i] / la;
        turn_sq += d * d;
    }
    let explained = 1.5 * (la + lb) / radius + 1.5 * step * (1.0 / la + 1.0 / lb);
    if sqrt(turn_sq) > explained {
        return corner;
    }
    // Centripetal acceleration points to the centre, along the bisector of the two span directions; each axis
    // limits it by its own acceleration.
    let (pl, ql) = (sqrt(dot(&p, &p)), sqrt(dot(&q, &q)));
    let mut normal = [0.0f32; NUM_AXES];
    for i in 0..NUM_AXES {
        normal[i] = p[i] / pl + q[i] / ql;
    }
    let nl = sqrt(dot(&normal, &normal));
    let mut accel = a.accel.min(b.accel);
    if nl > 1e-6 {
        accel = f32::MAX;
        for axis in Axis::ALL {
            // An axis across the normal divides by 0: +∞ (or NaN), which `min` ignores.
            let u = (normal[axis.index()] / nl).abs();
            accel = accel.min(cfg.axis(axis).max_accel_mm_s2 / u);
        }
    }
    // A path acceleration the host sets below the axes' (a pen's drawing acceleration, as saxi's) holds in every
    // direction: a chord accelerating less than its axes allow along it carries such a cap, which then bounds the
    // centripetal acceleration too.
    for s in [&a, &b] {
        let mut along = f32::MAX;
        for axis in Axis::ALL {
            along = along.min(cfg.axis(axis).max_accel_mm_s2 / s.unit[axis.index()].abs());
        }
        if s.accel < along {
            accel = accel.min(s.accel);
        }
    }
    let speed_sqr = accel * radius;
    VertexLimits { curve: Some(Curve { radius, speed_sqr }), ..corner }
}

/// Cruise limit (speed²) of a chord of length `len` between vertices `start` and `end` (`None`: the sequence ends
/// there): the faster curve speed of the ends whose curve the chord belongs to (its sagitta on that circle within
/// the curve deviation); unlimited when neither end's curve claims it.
fn chord_speed_sqr(len: f32, start: &Junction, end: Option<&Junction>, dev: f32) -> f32 {
    let mut cap: Option<f32> = None;
    for c in [start.curve, end.and_then(|e| e.curve)].into_iter().flatten() {
        if len * len <= 8.0 * dev * c.radius {
            cap = Some(cap.map_or(c.speed_sqr, |x: f32| x.max(c.speed_sqr)));
        }
    }
    cap.unwrap_or(f32::INFINITY)
}

/// Set the junction and curve limits (`max_entry_speed_sqr`, `curve_speed_sqr`) of every block of a sequence
/// starting from rest (host use, whole drawing). `O(len · CURVE_SPAN_BLOCKS)`.
pub fn link_all(blocks: &mut [PlanBlock], cfg: &MachineConfig) {
    let n = blocks.len();
    let dev = cfg.curve_deviation_mm;
    let mut prev_j = Junction::REST;
    let mut prev_cap = f32::INFINITY;
    for j in 0..=n {
        let seg = |k: usize| Seg::of(&blocks[k]);
        let jn = junction_at(&seg, n, j, cfg);
        if j > 0 {
            let cap = chord_speed_sqr(blocks[j - 1].millimeters, &prev_j, (j < n).then_some(&jn), dev);
            let b = &mut blocks[j - 1];
            b.curve_speed_sqr = if b.fixed.is_some() { f32::INFINITY } else { cap };
            b.max_entry_speed_sqr = prev_j.speed_sqr.min(cap).min(prev_cap);
            prev_cap = b.curve_speed_sqr;
        }
        prev_j = jn;
    }
}

/// Ring capacity of a [`Linker`]: the vertices still open (`K + 1`) and the `K` segments before the oldest.
const LINK_RING: usize = 2 * CURVE_SPAN_BLOCKS + 2;

/// The firmware's side of [`link_all`]: remembers the last blocks' geometry (also those already handed to the
/// stepper) and, as each block arrives, recomputes the limits of the vertices whose span it extends, writing them
/// into the planner queue. Fixed size, no allocation. Once [`CURVE_SPAN_BLOCKS`] blocks follow a block, its limits
/// equal what [`link_all`] computes over the whole sequence.
#[derive(Debug, Clone)]
pub struct Linker {
    segs: [Seg; LINK_RING],
    junctions: [Junction; LINK_RING],
    caps: [f32; LINK_RING],
    len: usize,
}

impl Default for Linker {
    fn default() -> Self {
        Linker::new()
    }
}

impl Linker {
    /// An empty linker: the next block starts from rest.
    pub const fn new() -> Linker {
        Linker {
            segs: [Seg::EMPTY; LINK_RING],
            junctions: [Junction::REST; LINK_RING],
            caps: [f32::INFINITY; LINK_RING],
            len: 0,
        }
    }

    /// Forget the past (after a reset or an alarm the next block starts from rest).
    pub fn clear(&mut self) {
        self.len = 0;
    }

    /// `queue`'s last block has just been appended (everything before it came through this linker, in order):
    /// update the junction and curve limits of the blocks whose vertices it affects. Blocks that already left
    /// `queue` are accounted for but not written.
    pub fn push(&mut self, queue: &mut [PlanBlock], cfg: &MachineConfig) {
        let Some(last) = queue.last() else { return };
        if self.len == LINK_RING {
            self.segs.copy_within(1.., 0);
            self.junctions.copy_within(1.., 0);
            self.caps.copy_within(1.., 0);
            self.len -= 1;
        }
        let n = self.len;
        self.segs[n] = Seg::of(last);
        self.len += 1;
        let len = self.len;
        let segs = self.segs;
        let seg = |k: usize| segs[k];
        // Vertices whose forward span reaches the new block; ring slot 0 is the sequence start only while the
        // ring has never been full, and is then recomputed as such.
        let lo = (n + 1).saturating_sub(CURVE_SPAN_BLOCKS);
        for j in lo..len {
            self.junctions[j] = junction_at(&seg, len, j, cfg);
        }
        let dev = cfg.curve_deviation_mm;
        let first = lo.saturating_sub(1);
        for (b, sb) in segs.iter().enumerate().take(len).skip(first) {
            let end = (b + 1 < len).then(|| self.junctions[b + 1]);
            self.caps[b] =
                if sb.fixed { f32::INFINITY } else { chord_speed_sqr(sb.len, &self.junctions[b], end.as_ref(), dev) };
        }
        let qn = queue.len();
        for b in first..len {
            let Some(qi) = (qn + b).checked_sub(len) else { continue };
            let before = if b == 0 { f32::INFINITY } else { self.caps[b - 1] };
            let blk = &mut queue[qi];
            blk.curve_speed_sqr = self.caps[b];
            blk.max_entry_speed_sqr = self.junctions[b].speed_sqr.min(self.caps[b]).min(before);
        }
    }
}

/// Plan entry speeds: reverse then forward pass. `blocks[0]` enters at `first_entry_sqr` (the speed the machine
/// has there, already feasible); the last block exits at rest. `O(len)`.
pub fn plan(blocks: &mut [PlanBlock], first_entry_sqr: f32) {
    let mut next_entry = 0.0f32;
    for b in blocks.iter_mut().rev() {
        if b.fixed.is_some() {
            b.entry_speed_sqr = 0.0;
            next_entry = 0.0;
            continue;
        }
        b.entry_speed_sqr = b.max_entry_speed_sqr.min(next_entry + 2.0 * b.acceleration * b.millimeters);
        next_entry = b.entry_speed_sqr;
    }
    let Some((first, rest)) = blocks.split_first_mut() else { return };
    if first.fixed.is_none() {
        first.entry_speed_sqr = first_entry_sqr;
    }
    let mut prev = *first;
    for b in rest.iter_mut() {
        if b.fixed.is_none() {
            let reachable = if prev.fixed.is_some() {
                0.0
            } else {
                prev.entry_speed_sqr + 2.0 * prev.acceleration * prev.millimeters
            };
            b.entry_speed_sqr = b.entry_speed_sqr.min(reachable);
        }
        prev = *b;
    }
}

/// Exit speed² of `blocks[i]` as planned: the next block's entry, or rest at the end.
pub fn exit_speed_sqr(blocks: &[PlanBlock], i: usize) -> f32 {
    blocks.get(i + 1).map_or(0.0, |b| b.entry_speed_sqr)
}

/// The stepper block for a planned block exiting at `exit_speed_sqr`. Rates are rounded down, so the executed
/// speeds and acceleration never exceed the plan. The acceleration is capped at what a frame carries
/// ([`crate::protocol::ACCEL_MAX`] events/s²), not at the step rate's limit: an acceleration is no rate, and a
/// block planned at `a` that ran at less would not reach the speeds its neighbours were planned with.
pub fn to_step_block(block: &PlanBlock, exit_speed_sqr: f32) -> StepBlock {
    if let Some(f) = block.fixed {
        return f;
    }
    let k = block.events_per_mm;
    let rate = |v: f32| floor_u32(v * k).min(MAX_RATE);
    let cruise = rate(block.cruise_speed()).max(1);
    StepBlock {
        steps: block.steps,
        // `sqrt` of a squared speed may land an ulp above the cruise speed: cap at cruise.
        entry_rate: rate(sqrt(block.entry_speed_sqr)).min(cruise),
        cruise_rate: cruise,
        exit_rate: rate(sqrt(exit_speed_sqr)).min(cruise),
        accel: floor_u32(block.acceleration * k).clamp(1, crate::protocol::ACCEL_MAX),
        dwell_ticks: 0,
        servo: None,
    }
}

/// The stepper blocks of a planned sequence, in order.
pub fn step_blocks(blocks: &[PlanBlock]) -> impl Iterator<Item = StepBlock> + '_ {
    (0..blocks.len()).map(|i| to_step_block(&blocks[i], exit_speed_sqr(blocks, i)))
}

/// Exact execution time of a planned sequence, timer ticks ([`crate::step_block::TICK_HZ`]): the sum of the
/// stepper's [`StepBlock::duration_ticks`].
pub fn total_ticks(blocks: &[PlanBlock]) -> u64 {
    step_blocks(blocks).map(|b| u64::from(b.duration_ticks())).sum()
}

/// The cornering verdict at every vertex of `blocks` (vertex `i` is where `blocks[i]` starts), as [`link_all`]
/// judges it: for diagnostics and tests.
pub fn junctions<'a>(blocks: &'a [PlanBlock], cfg: &MachineConfig) -> impl Iterator<Item = Junction> + 'a {
    let cfg = *cfg;
    (0..blocks.len()).map(move |j| junction_at(&|k: usize| Seg::of(&blocks[k]), blocks.len(), j, &cfg))
}

#[cfg(test)]
#[allow(
    clippy::cast_possible_truncation,
    clippy::cast_sign_loss,
    clippy::cast_precision_loss,
    reason = "test geometry: small finite values in mm and steps"
)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use std::vec::Vec;

    fn cfg() -> MachineConfig {
        let mut c = MachineConfig::xy_plotter();
        // Unequal axes make the per-axis limits matter.
        c.axes[1].max_feed_mm_s = 90.0;
        c.axes[1].max_accel_mm_s2 = 700.0;
        c.axes[1].steps_per_mm = 53.0;
        c
    }

    fn build(c: &MachineConfig, moves: &[([i32; NUM_AXES], f32)]) -> Vec<PlanBlock> {
        let mut v: Vec<PlanBlock> = moves.iter().filter_map(|(s, f)| PlanBlock::line(c, *s, *f)).collect();
        link_all(&mut v, c);
        plan(&mut v, 0.0);
        v
    }

    #[test]
    fn straight_line_runs_through_and_stops_at_end() {
        let c = MachineConfig::xy_plotter();
        let v = build(&c, &[([8000, 0, 0, 0], 100.0), ([8000, 0, 0, 0], 100.0)]);
        assert_eq!(v[0].entry_speed_sqr, 0.0);
        assert!((v[1].entry_speed_sqr - 100.0 * 100.0).abs() < 1.0, "{}", v[1].entry_speed_sqr);
        let sb: Vec<_> = step_blocks(&v).collect();
        assert_eq!(sb[0].exit_rate, 8000);
        assert_eq!(sb[1].exit_rate, 0);
        // 200 mm at 100 mm/s with 1500 mm/s² ramps: 2 s + v/a = 2.0667 s.
        let t = total_ticks(&v);
        assert!((t as f64 - 2_066_667.0).abs() < 50.0, "{t}");
    }

    #[test]
    fn right_angle_corner_speed() {
        let c = MachineConfig::xy_plotter();
        let v = build(&c, &[([8000, 0, 0, 0], 100.0), ([0, 8000, 0, 0], 100.0)]);
        // θ = 90°: sin(45°) = 0.7071; v² = 1500 · 0.02 · 0.7071/0.2929 = 72.43.
        assert!((v[1].entry_speed_sqr - 72.426).abs() < 0.05, "{}", v[1].entry_speed_sqr);
        // Reversal stops.
        let v = build(&c, &[([800, 0, 0, 0], 100.0), ([-800, 0, 0, 0], 100.0)]);
        assert_eq!(v[1].entry_speed_sqr, 0.0);
    }

    #[test]
    fn fixed_blocks_are_stop_boundaries() {
        let c = MachineConfig::xy_plotter();
        let mut v = std::vec![
            PlanBlock::line(&c, [8000, 0, 0, 0], 100.0).unwrap(),
            PlanBlock::fixed(StepBlock::dwell(1000)),
            PlanBlock::line(&c, [8000, 0, 0, 0], 100.0).unwrap(),
        ];
        link_all(&mut v, &c);
        plan(&mut v, 0.0);
        assert_eq!(exit_speed_sqr(&v, 0), 0.0);
        assert_eq!(v[2].entry_speed_sqr, 0.0);
        let sb: Vec<_> = step_blocks(&v).collect();
        assert_eq!(sb[1], StepBlock::dwell(1000));
        assert_eq!(sb[0].duration_ticks() + 1000 + sb[2].duration_ticks(), u32::try_from(total_ticks(&v)).unwrap());
    }

    #[test]
    fn extrusion_follows_the_xyz_path() {
        let mut c = MachineConfig::xy_plotter();
        c.axes[3] = crate::config::AxisConfig {
            enabled: true,
            steps_per_mm: 100.0,
            travel_mm: 0.0,
            max_feed_mm_s: 20.0,
            max_accel_mm_s2: 1000.0,
            invert_dir: false,
            home_at_max: false,
        };
        // 10 mm of X with 0.5 mm of E at 50 mm/s: length 10 mm, E at 2.5 mm/s (within its 20 mm/s).
        let b = PlanBlock::line(&c, [800, 0, 0, 50], 50.0).unwrap();
        assert!((b.millimeters - 10.0).abs() < 1e-6 && (b.nominal_speed - 50.0).abs() < 1e-4);
        assert!((b.unit[3] - 0.05).abs() < 1e-7);
        // E's acceleration cap: a·0.05 ≤ 1000 allows 20000 > X's 1500, so X limits.
        assert!((b.acceleration - 1500.0).abs() < 1e-3);
        // 10 mm X with 5 mm E: E at 50·0.5 = 25 mm/s > 20 → the path slows to 40 mm/s.
        let b = PlanBlock::line(&c, [800, 0, 0, 500], 50.0).unwrap();
        assert!((b.nominal_speed - 40.0).abs() < 1e-3, "{}", b.nominal_speed);
        // Retraction: E only, 2 mm at 35 mm/s requested → capped at E's 20 mm/s; 2 mm long.
        let r = PlanBlock::line(&c, [0, 0, 0, -200], 35.0).unwrap();
        assert!((r.millimeters - 2.0).abs() < 1e-6 && (r.nominal_speed - 20.0).abs() < 1e-4);
        // 2 mm at 20 mm/s with 1000 mm/s²: ramps of 20/1000 s each way over 0.2 mm each, 1.6 mm cruise.
        // t = 2·0.02 + 1.6/20 = 0.12 s.
        let mut v = std::vec![r];
        link_all(&mut v, &c);
        plan(&mut v, 0.0);
        let t = total_ticks(&v);
        assert!((t as f64 - 120_000.0).abs() < 20.0, "{t}");
        // Collinear X moves with different E ratios corner as straight on (E ignored in the junction).
        let a = PlanBlock::line(&c, [800, 0, 0, 40], 50.0).unwrap();
        let mut v = std::vec![a, PlanBlock::line(&c, [800, 0, 0, 80], 50.0).unwrap()];
        link_all(&mut v, &c);
        assert_eq!(v[1].max_entry_speed_sqr, 50.0 * 50.0);
        // Retraction after a nozzle move: a right angle.
        let mut v = std::vec![a, PlanBlock::line(&c, [0, 0, 0, -200], 20.0).unwrap()];
        link_all(&mut v, &c);
        let r2 = v[1];
        let right_angle = 1000.0 * c.junction_deviation_mm * core::f32::consts::FRAC_1_SQRT_2
            / (1.0 - core::f32::consts::FRAC_1_SQRT_2);
        assert!((r2.max_entry_speed_sqr - right_angle).abs() < 1e-3, "{}", r2.max_entry_speed_sqr);
    }

    fn moves() -> impl Strategy<Value = Vec<([i32; NUM_AXES], f32)>> {
        proptest::collection::vec(
            ((-4000i32..4000, -4000i32..4000, -200i32..200), 1.0f32..400.0)
                .prop_map(|((x, y, z), f)| ([x, y, z, 0], f)),
            1..60,
        )
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(300))]
        #[test]
        fn plan_respects_limits(ms in moves()) {
            let c = cfg();
            let v = build(&c, &ms);
            prop_assume!(!v.is_empty());
            let tol = 1.0 + 1e-4;
            for (i, b) in v.iter().enumerate() {
                for axis in Axis::ALL {
                    let u = b.unit[axis.index()].abs();
                    let a = c.axis(axis);
                    prop_assert!(b.nominal_speed * u <= a.max_feed_mm_s * tol, "feed on {axis:?}");
                    prop_assert!(b.acceleration * u <= a.max_accel_mm_s2 * tol, "accel on {axis:?}");
                }
                let entry = b.entry_speed_sqr;
                let exit = exit_speed_sqr(&v, i);
                let nominal_sq = b.cruise_speed() * b.cruise_speed();
                prop_assert!(entry <= nominal_sq * tol && exit <= nominal_sq * tol);
                // Reachable within the block at the block's acceleration.
                let ramp = 2.0 * b.acceleration * b.millimeters;
                prop_assert!((exit - entry).abs() <= ramp * tol + 1e-3, "block {i}: {entry} → {exit} over {ramp}");
                // Corners within the deviation limit; curve vertices within the centripetal limit of their curve.
                let verdict = junctions(&v, &c).nth(i).unwrap();
                if i > 0 {
                    let p = &v[i - 1];
                    let sum_sq: f64 = p.unit.iter().zip(b.unit).map(|(x, y)| f64::from(x + y).powi(2)).sum();
                    let sin_half = 0.5 * sum_sq.sqrt();
                    let a = f64::from(p.acceleration.min(b.acceleration));
                    match verdict.curve {
                        None if sin_half < 0.999 => {
                            let limit = a * f64::from(c.junction_deviation_mm) * sin_half / (1.0 - sin_half);
                            prop_assert!(f64::from(entry) <= limit * 1.001 + 1e-6, "junction {i}: {entry} > {limit}");
                        }
                        None => {}
                        Some(curve) => {
                            // The centripetal acceleration v²/r stays within the larger axis limit.
                            let amax = f64::from(c.axes[0].max_accel_mm_s2.max(c.axes[1].max_accel_mm_s2).max(c.axes[2].max_accel_mm_s2));
                            prop_assert!(f64::from(entry) <= amax * 2f64.sqrt() * f64::from(curve.radius) * tol_f64() + 1e-6);
                        }
                    }
                    // Never faster than either chord's cruise speed.
                    prop_assert!(entry <= b.cruise_speed() * b.cruise_speed() * tol && entry <= p.cruise_speed() * p.cruise_speed() * tol);
                } else {
                    prop_assert_eq!(entry, 0.0);
                }
            }
            prop_assert_eq!(exit_speed_sqr(&v, v.len() - 1), 0.0);
            // The step-rate plan respects the per-axis limits as well (rates rounded down).
            for (b, s) in v.iter().zip(step_blocks(&v)) {
                let n = s.events() as f32;
                prop_assert_eq!(s.steps, b.steps);
                for axis in Axis::ALL {
                    let share = s.steps[axis.index()].unsigned_abs() as f32 / n;
                    let a = c.axis(axis);
                    let spm = a.steps_per_mm;
                    prop_assert!(s.cruise_rate as f32 * share <= (a.max_feed_mm_s * spm).max(1.0) * tol);
                    prop_assert!(s.accel as f32 * share <= (a.max_accel_mm_s2 * spm).max(1.0) * tol);
                }
                prop_assert!(s.entry_rate <= s.cruise_rate && s.exit_rate <= s.cruise_rate);
            }
            prop_assert_eq!(step_blocks(&v).last().unwrap().exit_rate, 0);
        }

        /// Planning a growing queue block by block (as the firmware does) never beats the whole-sequence plan
        /// and ends identical once all blocks are in.
        #[test]
        fn incremental_equals_whole(ms in moves()) {
            let c = cfg();
            let whole = build(&c, &ms);
            let mut inc: Vec<PlanBlock> = Vec::new();
            let mut linker = Linker::new();
            for (s, f) in &ms {
                if let Some(b) = PlanBlock::line(&c, *s, *f) {
                    inc.push(b);
                    linker.push(&mut inc, &c);
                    plan(&mut inc, 0.0);
                }
            }
            prop_assert_eq!(inc, whole);
        }

        /// The same over curves (many short chords, some kinks and dwells), with a queue that drops blocks from
        /// its front as the firmware's does: every block that leaves with at least `CURVE_SPAN_BLOCKS` blocks
        /// behind it carries exactly the whole-sequence limits.
        #[test]
        fn incremental_curves_equal_whole(ms in curvy_moves(), keep in (CURVE_SPAN_BLOCKS + 1)..40usize) {
            let c = cfg();
            let mut whole: Vec<PlanBlock> = ms.iter().map(|m| match m {
                Some(s) => PlanBlock::line(&c, *s, 60.0).unwrap(),
                None => PlanBlock::fixed(StepBlock::dwell(100)),
            }).collect();
            link_all(&mut whole, &c);
            let mut queue: Vec<PlanBlock> = Vec::new();
            let mut linker = Linker::new();
            let mut left = 0usize;
            for b in &whole {
                let mut b = *b;
                b.max_entry_speed_sqr = 0.0;
                b.curve_speed_sqr = f32::INFINITY;
                queue.push(b);
                linker.push(&mut queue, &c);
                if queue.len() > keep {
                    let out = queue.remove(0);
                    prop_assert_eq!(out.max_entry_speed_sqr, whole[left].max_entry_speed_sqr, "block {}", left);
                    prop_assert_eq!(out.curve_speed_sqr, whole[left].curve_speed_sqr, "block {}", left);
                    left += 1;
                }
            }
            for (k, b) in queue.iter().enumerate() {
                prop_assert_eq!(b.max_entry_speed_sqr, whole[left + k].max_entry_speed_sqr);
                prop_assert_eq!(b.curve_speed_sqr, whole[left + k].curve_speed_sqr);
            }
        }
    }

    fn tol_f64() -> f64 {
        1.0 + 1e-4
    }

    /// Arcs of random radius and chord length in steps (`None` = a dwell), joined by random kinks.
    fn curvy_moves() -> impl Strategy<Value = Vec<Option<[i32; NUM_AXES]>>> {
        let arc = (0.3f64..20.0, 0.02f64..1.5, 2usize..40, 0.0f64..6.3, any::<bool>(), 0u8..4);
        proptest::collection::vec(arc, 1..8).prop_map(|arcs| {
            let mut out = Vec::new();
            let mut at = [0i32; 2];
            let mut pos = [0.0f64; 2];
            for (r, chord, n, start, ccw, kind) in arcs {
                if kind == 0 {
                    out.push(None);
                }
                let da = (chord / r).min(1.0) * if ccw { 1.0 } else { -1.0 };
                let centre = [pos[0] - r * start.cos(), pos[1] - r * start.sin()];
                for k in 1..=n {
                    let a = start + da * k as f64;
                    pos = [centre[0] + r * a.cos(), centre[1] + r * a.sin()];
                    let t = [(pos[0] * 53.0).round() as i32, (pos[1] * 80.0).round() as i32];
                    let s = [t[0] - at[0], t[1] - at[1], 0, 0];
                    if s != [0, 0, 0, 0] {
                        out.push(Some(s));
                        at = t;
                    }
                }
            }
            out
        })
    }

    /// Points of a circle of radius `r` (mm) cut into `n` chords, as step moves at 80 steps/mm.
    fn circle_moves(r: f64, n: usize, turns: f64) -> Vec<([i32; NUM_AXES], f32)> {
        let mut at = [(r * 80.0).round() as i32, 0];
        let total = (n as f64 * turns) as usize;
        (1..=total)
            .map(|k| {
                let a = std::f64::consts::TAU * k as f64 / n as f64;
                let t = [(r * a.cos() * 80.0).round() as i32, (r * a.sin() * 80.0).round() as i32];
                let s = [t[0] - at[0], t[1] - at[1], 0, 0];
                at = t;
                (s, 60.0f32)
            })
            .collect()
    }

    #[test]
    fn a_circle_runs_at_its_centripetal_limit_whatever_the_chords() {
        let c = MachineConfig::xy_plotter();
        // r = 1.5 mm: √(1500·1.5) = 47.4 mm/s, below the 60 mm/s feed. Chord errors 0.05 mm (n = 17) down to
        // 0.002 mm (n = 60) and 0.0005 mm (n = 120: chords of 6 steps).
        for n in [17usize, 40, 60, 120] {
            let v = build(&c, &circle_moves(1.5, n, 2.0));
            let js: Vec<Junction> = junctions(&v, &c).collect();
            // Vertices away from the start and end: all on the curve, at a·r within 3 % (radius from points
            // rounded to steps).
            // Each axis limits the centripetal acceleration along the radius at angle α: a/max(|cos α|, |sin α|).
            let expect = |i: usize| {
                let a = std::f64::consts::TAU * i as f64 / n as f64;
                (1500.0 * 1.5 / a.cos().abs().max(a.sin().abs())) as f32
            };
            for (i, j) in js.iter().enumerate().skip(n / 2).take(n) {
                let curve = j.curve.unwrap_or_else(|| panic!("n {n}: vertex {i} judged a corner"));
                let e = expect(i);
                assert!((curve.speed_sqr / e - 1.0).abs() < 0.03, "n {n}, vertex {i}: {} vs {e}", curve.speed_sqr);
                // The planned speed there is the curve speed (below the 60 mm/s feed; the circle is long enough
                // to reach it).
                let planned = v[i].entry_speed_sqr;
                assert!((planned / e.min(3600.0) - 1.0).abs() < 0.03, "n {n}, vertex {i}: {planned} vs {e}");
                // Chords cruise no faster than the faster of their ends.
                let cruise = v[i].cruise_speed() * v[i].cruise_speed();
                assert!(cruise <= e.max(expect(i + 1)) * 1.03, "n {n}, chord {i}: {cruise}");
            }
        }
    }

    #[test]
    fn corners_stay_corners() {
        let c = MachineConfig::xy_plotter();
        // A square of 10 mm sides: every corner by junction deviation (90°: 72.43 mm²/s², as above).
        let sq = [[800, 0, 0, 0], [0, 800, 0, 0], [-800, 0, 0, 0], [0, -800, 0, 0], [800, 0, 0, 0]];
        let v = build(&c, &sq.map(|s| (s, 60.0)));
        for (i, j) in junctions(&v, &c).enumerate().skip(1) {
            assert_eq!(j.curve, None, "vertex {i}");
            assert!((v[i].max_entry_speed_sqr - 72.426).abs() < 0.05);
        }
        // An octagon of 50 mm sides turns by 45° at each vertex: a polygon, not a circle.
        let oct: Vec<([i32; NUM_AXES], f32)> = (0..9)
            .map(|k| {
                let a = std::f64::consts::FRAC_PI_4 * f64::from(k);
                ([(4000.0 * a.cos()).round() as i32, (4000.0 * a.sin()).round() as i32, 0, 0], 60.0f32)
            })
            .collect();
        let v = build(&c, &oct);
        assert!(junctions(&v, &c).all(|j| j.curve.is_none()));
        // A kink of 60° inside a circle of fine chords is a corner; its neighbours stay on the curve. (Smaller kinks
        // among chords of a few steps can pass as part of the curve: up to ~45° the step rounding and the circle
        // through the kink explain them.)
        let mut m = circle_moves(5.0, 400, 0.5);
        let mid = m.len() / 2;
        let rot = |s: [i32; NUM_AXES], a: f64| {
            let (x, y) = (f64::from(s[0]), f64::from(s[1]));
            [(x * a.cos() - y * a.sin()).round() as i32, (x * a.sin() + y * a.cos()).round() as i32, 0, 0]
        };
        for mv in m.iter_mut().skip(mid) {
            mv.0 = rot(mv.0, 60f64.to_radians());
        }
        let v = build(&c, &m);
        let js: Vec<Junction> = junctions(&v, &c).collect();
        assert_eq!(js[mid].curve, None);
        assert!(js[mid - 20].curve.is_some() && js[mid + 20].curve.is_some());
    }

    #[test]
    fn linker_forgets_on_clear() {
        let c = MachineConfig::xy_plotter();
        let mut q = Vec::new();
        let mut l = Linker::new();
        for (s, f) in circle_moves(3.0, 50, 0.5) {
            q.push(PlanBlock::line(&c, s, f).unwrap());
            l.push(&mut q, &c);
        }
        l.clear();
        let mut q2 = std::vec![PlanBlock::line(&c, [80, 0, 0, 0], 60.0).unwrap()];
        l.push(&mut q2, &c);
        assert_eq!(q2[0].max_entry_speed_sqr, 0.0);
    }

    /// A moving segment of `len` mm along the XY direction `(x, y)` (a unit vector), 1000 mm/s², 50 mm/s.
    fn seg_xy(x: f32, y: f32, len: f32) -> Seg {
        Seg { unit: [x, y, 0.0, 0.0], len, accel: 1000.0, nominal: 50.0, fixed: false }
    }

    /// A segment of `len` mm at `deg` degrees in the XY plane.
    fn seg_deg(deg: f32, len: f32) -> Seg {
        let r = deg.to_radians();
        seg_xy(r.cos(), r.sin(), len)
    }

    fn close(a: f32, b: f32, tol: f32) -> bool {
        (a - b).abs() <= tol
    }

    #[test]
    fn half_turn_of_hand_computed_turns() {
        // (1, 0) then (0.6, 0.8): cos φ = 0.6, so cos²(φ/2) = (1 + 0.6)/2 = 0.8 and sin²(φ/2) = 0.2.
        let (c, s) = half_turn(&seg_xy(1.0, 0.0, 1.0), &seg_xy(0.6, 0.8, 1.0));
        assert!(close(c, 0.8f32.sqrt(), 1e-6) && close(s, 0.2f32.sqrt(), 1e-6), "{c} {s}");
        // The same turn between Z and Y (other axes, reversed roles): cos φ = 0.8 → cos² = 0.9, sin² = 0.1.
        let a = Seg { unit: [0.0, 0.0, 1.0, 0.0], ..seg_xy(0.0, 0.0, 1.0) };
        let b = Seg { unit: [0.0, 0.6, 0.8, 0.0], ..seg_xy(0.0, 0.0, 1.0) };
        let (c, s) = half_turn(&a, &b);
        assert!(close(c, 0.9f32.sqrt(), 1e-6) && close(s, 0.1f32.sqrt(), 1e-6), "{c} {s}");
        // Straight on: (1, 0); a right angle: (√½, √½); a reversal: (0, 1).
        assert_eq!(half_turn(&seg_xy(0.6, 0.8, 1.0), &seg_xy(0.6, 0.8, 2.0)), (1.0, 0.0));
        let (c, s) = half_turn(&seg_xy(1.0, 0.0, 1.0), &seg_xy(0.0, -1.0, 1.0));
        assert!(close(c, core::f32::consts::FRAC_1_SQRT_2, 1e-6) && close(s, core::f32::consts::FRAC_1_SQRT_2, 1e-6));
        assert_eq!(half_turn(&seg_xy(0.0, 1.0, 1.0), &seg_xy(0.0, -1.0, 1.0)), (0.0, 1.0));
    }

    #[test]
    fn locally_smooth_on_both_sides_of_the_deviation() {
        // Turn φ from (1, 0) to (0.6, 0.8): tan(φ/2) = 0.5, so tan(φ/4) = 0.5/(1 + √1.25) = √5 − 2 = 0.236068.
        // Chords of 2 and 3 mm: half the shorter is m = 1 mm, the tangent circle passes 0.236068 mm from the vertex.
        let (a, b) = (seg_xy(1.0, 0.0, 2.0), seg_xy(0.6, 0.8, 3.0));
        assert!(locally_smooth(&a, &b, 0.2361));
        assert!(!locally_smooth(&a, &b, 0.2360));
        // Either order of the chords (the shorter one decides).
        assert!(locally_smooth(&b, &a, 0.2361) && !locally_smooth(&b, &a, 0.2360));
        // A fixed block on either side is never part of a curve.
        assert!(!locally_smooth(&Seg { fixed: true, ..a }, &b, 10.0));
        assert!(!locally_smooth(&a, &Seg { fixed: true, ..b }, 10.0));
        // The turn must stay below 90°, however short the chords: 89° passes, 91° does not.
        let (a, b) = (seg_deg(0.0, 0.001), seg_deg(89.0, 0.001));
        assert!(locally_smooth(&a, &b, 1.0));
        let b = seg_deg(91.0, 0.001);
        assert!(!locally_smooth(&a, &b, 1.0));
        // Exactly 90° (cos(φ/2) = cos 45°, the limit itself) still passes.
        assert!(locally_smooth(&a, &seg_xy(0.0, 1.0, 0.001), 1.0));
        // Straight on is smooth even with no deviation allowed.
        assert!(locally_smooth(&seg_xy(1.0, 0.0, 5.0), &seg_xy(1.0, 0.0, 5.0), 0.0));
    }

    #[test]
    fn circumradius_of_a_known_circle() {
        // The circle of radius 10 mm centred on (0, 10) passes through the origin; (6, 2) and (−8, 4) lie on it
        // (x² + y² = 20·y). pp = 40, qq = 80, |p − q|² = 200, p × q = 40: r² = 40·80·200/(4·1600) = 100.
        let r = circumradius(&[6.0, 2.0, 0.0, 0.0], &[-8.0, 4.0, 0.0, 0.0]).unwrap();
        assert!(close(r, 10.0, 1e-5), "{r}");
        // The same points in the X/Z and Y/Z planes, and in the other order.
        let r = circumradius(&[6.0, 0.0, 2.0, 0.0], &[-8.0, 0.0, 4.0, 0.0]).unwrap();
        assert!(close(r, 10.0, 1e-5), "{r}");
        let r = circumradius(&[0.0, -8.0, 4.0, 0.0], &[0.0, 6.0, 2.0, 0.0]).unwrap();
        assert!(close(r, 10.0, 1e-5), "{r}");
        // A right angle at the origin: the origin, (6, 0, 0) and (0, 0, 8) lie on the circle whose diameter is the
        // hypotenuse √(6² + 8²) = 10, so r = 5 (X/Z, then Y/E).
        let r = circumradius(&[6.0, 0.0, 0.0, 0.0], &[0.0, 0.0, 8.0, 0.0]).unwrap();
        assert!(close(r, 5.0, 1e-5), "{r}");
        let r = circumradius(&[0.0, 6.0, 0.0, 0.0], &[0.0, 0.0, 0.0, 8.0]).unwrap();
        assert!(close(r, 5.0, 1e-5), "{r}");
        // Points 2 mm either side of a vertex of a circle of radius 10 (the span the planner measures): chord
        // angles ±2·asin(0.1) from the vertex at the bottom of the circle centred on (0, 10).
        let t = 2.0 * 0.1f64.asin();
        let on = |a: f64| [(10.0 * a.sin()) as f32, (10.0 - 10.0 * a.cos()) as f32, 0.0, 0.0];
        let r = circumradius(&on(-t), &on(t)).unwrap();
        assert!(close(r, 10.0, 2e-3), "{r}");
        // Collinear (through the origin, on either side or the same side), and a point at the origin: no circle.
        assert_eq!(circumradius(&[-1.0, -1.0, 0.0, 0.0], &[2.0, 2.0, 0.0, 0.0]), None);
        assert_eq!(circumradius(&[1.0, 2.0, 3.0, 0.0], &[2.0, 4.0, 6.0, 0.0]), None);
        assert_eq!(circumradius(&[0.0; NUM_AXES], &[2.0, 1.0, 0.0, 0.0]), None);
        assert_eq!(circumradius(&[2.0, 1.0, 0.0, 0.0], &[0.0; NUM_AXES]), None);
        // Nearly collinear: p = (−2, 0), q = (1000, y). |p × q|² = 4y² against the bound 10⁻¹²·|p|²|q|² = 4·10⁻⁶:
        // y = 5·10⁻⁴ (a bend of 5·10⁻⁷ rad) is within it, y = 2·10⁻³ (2·10⁻⁶ rad) is a circle of radius
        // |p|·|q|·|p − q|/(2·|p × q|) = 2·1000·1002/(4·2·10⁻³) = 2.505·10⁸ mm.
        assert_eq!(circumradius(&[-2.0, 0.0, 0.0, 0.0], &[1000.0, 5e-4, 0.0, 0.0]), None);
        let r = circumradius(&[-2.0, 0.0, 0.0, 0.0], &[1000.0, 2e-3, 0.0, 0.0]).unwrap();
        assert!((r / 2.505e8 - 1.0).abs() < 1e-2, "{r}");
    }

    /// `span` over the segments `segs` from vertex `j`, whole chords (the kink rule's span).
    fn span_of(segs: &[Seg], j: usize, forward: bool, tangent: [f32; 2], dev: f32, target: f32) -> [f32; 2] {
        span_in(segs, j, forward, tangent, dev, target, false)
    }

    /// `span` over the segments `segs` from vertex `j`, `exact` or of whole chords.
    fn span_in(
        segs: &[Seg],
        j: usize,
        forward: bool,
        tangent: [f32; 2],
        dev: f32,
        target: f32,
        exact: bool,
    ) -> [f32; 2] {
        let seq = |k: usize| segs[k];
        let v = span(&seq, segs.len(), j, forward, &[tangent[0], tangent[1], 0.0, 0.0], dev, target, exact);
        assert_eq!(v[2..], [0.0, 0.0]);
        [v[0], v[1]]
    }

    fn close2(v: [f32; 2], w: [f32; 2]) -> bool {
        close(v[0], w[0], 1e-5) && close(v[1], w[1], 1e-5)
    }

    #[test]
    fn span_follows_whole_chords_to_the_target() {
        let x = [1.0, 0.0];
        // Ten chords of 0.5 mm along X; vertex 5 is where chord 5 starts.
        let line = [seg_xy(1.0, 0.0, 0.5); 10];
        assert!(close2(span_of(&line, 5, true, x, 0.1, 2.0), [2.0, 0.0]));
        assert!(close2(span_of(&line, 5, false, x, 0.1, 2.0), [-2.0, 0.0]));
        // 1.2 mm aimed at: two chords reach 1.0, the third is taken whole (1.5 ≤ 2·1.2), keeping the end on the path.
        assert!(close2(span_of(&line, 5, true, x, 0.1, 1.2), [1.5, 0.0]));
        // The sequence ends: two chords back from vertex 2, two forward from vertex 8, none back from vertex 0.
        assert!(close2(span_of(&line, 2, false, x, 0.1, 2.0), [-1.0, 0.0]));
        assert!(close2(span_of(&line, 8, true, x, 0.1, 2.0), [1.0, 0.0]));
        assert!(close2(span_of(&line, 0, false, x, 0.1, 2.0), [0.0, 0.0]));
        // At most CURVE_SPAN_BLOCKS = 16 chords: 40 chords of 0.05 mm reach 0.8 mm, not 2.
        let fine = [seg_xy(1.0, 0.0, 0.05); 40];
        assert!(close2(span_of(&fine, 20, true, x, 0.1, 2.0), [0.8, 0.0]));
        assert!(close2(span_of(&fine, 20, false, x, 0.1, 2.0), [-0.8, 0.0]));
        // A long chord: taken whole up to twice the target (5.5 ≤ 6), cut at the target beyond (7 > 6 → 3).
        let long = [seg_xy(0.6, 0.8, 5.5), seg_xy(0.6, 0.8, 7.0), seg_xy(0.6, 0.8, 7.0)];
        assert!(close2(span_of(&long, 0, true, [0.6, 0.8], 0.1, 3.0), [3.3, 4.4]));
        assert!(close2(span_of(&long, 1, true, [0.6, 0.8], 0.1, 3.0), [1.8, 2.4]));
        // After 1 mm of chord, 7 more would overshoot 2·3: the rest of the target, 2 mm, is taken.
        let cut = [seg_xy(1.0, 0.0, 1.0), seg_xy(1.0, 0.0, 7.0)];
        assert!(close2(span_of(&cut, 0, true, x, 0.1, 3.0), [3.0, 0.0]));
        assert!(close2(span_of(&cut, 2, false, x, 0.1, 3.0), [-3.0, 0.0]));
    }

    #[test]
    fn span_stops_at_corners_turns_and_fixed_blocks() {
        let x = [1.0, 0.0];
        // A 120° turn after the first chord: forward from vertex 1 only that chord; back from vertex 3 the two
        // chords before the corner.
        let corner = [seg_xy(1.0, 0.0, 0.5), seg_xy(1.0, 0.0, 0.5), seg_deg(120.0, 0.5), seg_deg(120.0, 0.5)];
        assert!(close2(span_of(&corner, 1, true, x, 0.1, 2.0), [0.5, 0.0]));
        let back = span_of(&corner, 4, false, [-0.5, 0.866_025_4], 0.1, 2.0);
        assert!(close2(back, [0.5, -0.866_025_4]), "{back:?}");
        // A turn of 30° between chords of 1 mm: the tangent circle passes 0.5·tan(7.5°) = 0.065826 mm from the
        // vertex, so the span crosses it with 0.07 mm of deviation allowed and stops before it with 0.06.
        let bend = [seg_xy(1.0, 0.0, 1.0), seg_deg(30.0, 1.0), seg_deg(30.0, 1.0)];
        let (c, s) = (30f32.to_radians().cos(), 30f32.to_radians().sin());
        assert!(close2(span_of(&bend, 0, true, x, 0.07, 2.5), [1.0 + 2.0 * c, 2.0 * s]));
        assert!(close2(span_of(&bend, 0, true, x, 0.06, 2.5), [1.0, 0.0]));
        assert!(close2(span_of(&bend, 3, false, [c, s], 0.07, 2.5), [-1.0 - 2.0 * c, -2.0 * s]));
        assert!(close2(span_of(&bend, 3, false, [c, s], 0.06, 2.5), [-2.0 * c, -2.0 * s]));
        // Chords of 0.1 mm turning 25° each (smooth with 0.01 mm: 0.05·tan(6.25°) = 0.0055): the span leaves the
        // tangent (1, 0) by at most 60°, so it stops before the chord at 75° (cos 75° = 0.26 < 0.5).
        let arc: Vec<Seg> = [0.0, 25.0, 50.0, 75.0, 100.0].iter().map(|&d| seg_deg(d, 0.1)).collect();
        let r = |d: f32| d.to_radians();
        let fwd = [0.1 * (1.0 + r(25.0).cos() + r(50.0).cos()), 0.1 * (r(25.0).sin() + r(50.0).sin())];
        assert!(close2(span_of(&arc, 0, true, x, 0.01, 2.0), fwd));
        // Backwards along the mirror image (chords at −75°, −50°, −25°, 0° before the vertex).
        let before: Vec<Seg> = [-75.0, -50.0, -25.0, 0.0].iter().map(|&d| seg_deg(d, 0.1)).collect();
        let back = [-0.1 * (1.0 + r(25.0).cos() + r(50.0).cos()), 0.1 * (r(25.0).sin() + r(50.0).sin())];
        assert!(close2(span_of(&before, 4, false, x, 0.01, 2.0), back));
        // A fixed block ends the span: nothing from a vertex where one starts; forward up to the one that follows.
        let mut fixed = [seg_xy(1.0, 0.0, 0.5); 6];
        fixed[3].fixed = true;
        assert!(close2(span_of(&fixed, 3, true, x, 0.1, 2.0), [0.0, 0.0]));
        assert!(close2(span_of(&fixed, 1, true, x, 0.1, 2.0), [1.0, 0.0]));
        assert!(close2(span_of(&fixed, 6, false, x, 0.1, 2.0), [-1.0, 0.0]));
    }

    #[test]
    fn span_takes_a_chord_at_exactly_the_limits() {
        let x = [1.0, 0.0];
        // A chord exactly 60° off the tangent (cos 60° = 0.5 exactly: unit (0.5, 0.866 025 4)) still belongs to the
        // span; the vertex before it (60° between 0.1 mm chords: 0.05·tan 15° = 0.0134 mm) is smooth.
        let sixty = [seg_xy(1.0, 0.0, 0.1), seg_xy(0.5, 0.866_025_4, 0.1)];
        assert!(close2(span_of(&sixty, 0, true, x, 0.1, 2.0), [0.15, 0.086_602_54]));
        // A chord of exactly twice the target is still taken whole.
        let long = [seg_xy(1.0, 0.0, 6.0)];
        assert!(close2(span_of(&long, 0, true, x, 0.1, 3.0), [6.0, 0.0]));
        assert!(close2(span_of(&long, 1, false, x, 0.1, 3.0), [-6.0, 0.0]));
    }

    #[test]
    fn the_radius_span_ends_exactly_at_its_length_on_the_arc() {
        let x = [1.0, 0.0];
        // Straight chords: the span ends at the target, not at the end of a chord up to twice as long.
        let long = [seg_xy(0.6, 0.8, 5.5), seg_xy(0.6, 0.8, 7.0)];
        assert!(close2(span_in(&long, 0, true, [0.6, 0.8], 0.1, 3.0, true), [1.8, 2.4]));
        let line = [seg_xy(1.0, 0.0, 0.5); 10];
        assert!(close2(span_in(&line, 5, true, x, 0.1, 1.2, true), [1.2, 0.0]));
        assert!(close2(span_in(&line, 5, false, x, 0.1, 1.2, true), [-1.2, 0.0]));
        // Chords of the circle of radius 5 through the origin centred on (0, 5): 1 mm and then 3 mm (sagitta
        // 5 − √(25 − 2.25) = 0.230 mm, within 0.3). Two mm along the path from the origin is 1 mm into the second
        // chord, 0.5 mm before its middle: the arc lies √(25 − 0.25) − √(25 − 2.25) = 0.205 mm off the chord
        // there, outwards, so the span ends on the circle (x² + (y − 5)² = 25), 2.0105 mm from the vertex (the chord
        // 1 mm along the last one and pushed out onto the arc).
        let at = |t: f32| [5.0 * t.sin(), 5.0 - 5.0 * t.cos()];
        let chord = |a: f32, b: f32| {
            let (p, q) = (at(a), at(b));
            let len = ((q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2)).sqrt();
            seg_xy((q[0] - p[0]) / len, (q[1] - p[1]) / len, len)
        };
        let (t1, t2) = (2.0 * 0.1f32.asin(), 2.0 * 0.1f32.asin() + 2.0 * 0.3f32.asin());
        let before: Vec<Seg> = (0..4).map(|i| chord(-0.1 * (4 - i) as f32, -0.1 * (3 - i) as f32)).collect();
        let mut segs = before.clone();
        segs.extend([chord(0.0, t1), chord(t1, t2)]);
        let end = span_in(&segs, 4, true, x, 0.3, 2.0, true);
        assert!(close(end[0].powi(2) + (end[1] - 5.0).powi(2), 25.0, 2e-3), "{end:?} is off the circle");
        let r = (end[0].powi(2) + end[1].powi(2)).sqrt();
        assert!(close(r, 2.0105, 1e-3), "{r}");
    }

    #[test]
    fn a_curves_radius_is_measured_on_the_arc_however_coarse_its_chords() {
        // The circle of radius 5 mm above: four chords of 0.1 rad (0.4998 mm) before the vertex at the origin,
        // a 1 mm chord and a 3.1 mm one after it (sagitta 5 − √(25 − 1.55²) = 0.246 mm, within the 0.3 mm curve
        // deviation). Every span end lies on the circle, so its radius is 5 mm: v² = a·r with Y's 1500 mm/s²
        // (the normal is along Y at the vertex, the chords' own acceleration uncapped) = 7500 mm²/s². (Cut on the
        // 3.1 mm chord itself, 1 mm into it, the forward end lay 0.216 mm inside the circle: r = 3.92 mm.)
        let mut c = MachineConfig::xy_plotter();
        c.curve_deviation_mm = 0.3;
        let at = |t: f32| [5.0 * t.sin(), 5.0 - 5.0 * t.cos()];
        let chord = |a: f32, b: f32| {
            let (p, q) = (at(a), at(b));
            let len = ((q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2)).sqrt();
            Seg { accel: f32::MAX, nominal: 150.0, ..seg_xy((q[0] - p[0]) / len, (q[1] - p[1]) / len, len) }
        };
        let (t1, t2) = (2.0 * 0.1f32.asin(), 2.0 * 0.1f32.asin() + 2.0 * 0.31f32.asin());
        let mut segs: Vec<Seg> = (0..4).map(|i| chord(-0.1 * (4 - i) as f32, -0.1 * (3 - i) as f32)).collect();
        segs.extend([chord(0.0, t1), chord(t1, t2)]);
        let j = verdict(&segs, 4, &c);
        let curve = j.curve.unwrap();
        assert!(close(curve.radius, 5.0, 5e-3), "{j:?}");
        assert!(close(curve.speed_sqr, 7500.0, 10.0), "{j:?}");
    }

    #[test]
    fn the_curve_span_stops_60_degrees_off_the_vertex_tangent() {
        // Chords turning 20° each (−70°, −50°, …, 70°), 0.2 mm long but the first and the last (1 mm), all
        // locally smooth (0.1·tan 5° = 0.0087 mm). At the vertex between −10° and 10° (tangent 0°) each span
        // follows the chords within 60° of the tangent (±10°, ±30°, ±50°) and stops before the 70° ones, so its
        // ends lie on the circle of the regular 18-gon of 0.2 mm sides: r = 0.2/(2·sin 10°) = 0.575 877 mm. (Were
        // the 1 mm chords taken, the ends would leave that circle.) The centre lies along +Y, whose 1500 mm/s²
        // give v² = 1500·0.575 877 = 863.8 mm²/s².
        // (Chords whose acceleration no path cap lowers below their axes': the axes' limits alone apply.)
        let c = MachineConfig::xy_plotter();
        let segs: Vec<Seg> = [-70.0, -50.0, -30.0, -10.0, 10.0, 30.0, 50.0, 70.0]
            .iter()
            .map(|&d: &f32| Seg { accel: f32::MAX, ..seg_deg(d, if d.abs() > 60.0 { 1.0 } else { 0.2 }) })
            .collect();
        let j = verdict(&segs, 4, &c);
        let curve = j.curve.unwrap();
        assert!(close(curve.radius, 0.575_877, 1e-3), "{j:?}");
        assert!(close(curve.speed_sqr, 863.8, 1.0) && close(j.speed_sqr, 863.8, 1.0), "{j:?}");
    }

    #[test]
    fn the_kink_rule_counts_the_rounding_of_every_axis_either_chord_moves() {
        // The 19° kink of `junction_verdict_at_a_kink_on_both_sides_of_the_threshold`, turned so that the chords
        // before the vertex run along X alone (Y unit exactly 0) and those after it at 19°. With Y at 40 steps/mm
        // the step that rounding may add is Y's 0.025 mm (the chords after the vertex move Y): the turn
        // 2·sin 9.5° = 0.330 095 is within 1.5·1.5/6.058 86 + 1.5·0.025·(2/0.75) = 0.471 359, a curve of radius
        // 2·cos 9.5°/sin 19° = 6.058 86 mm. With Y at 80 steps/mm (0.0125 mm) it is a corner (0.322 571).
        let mut c = MachineConfig::xy_plotter();
        c.axes[1].max_accel_mm_s2 = 700.0;
        let k = 19f32.to_radians();
        let mut segs = std::vec![Seg { nominal: 100.0, ..seg_xy(1.0, 0.0, 0.25) }; 10];
        segs.extend([Seg { nominal: 100.0, ..seg_xy(k.cos(), k.sin(), 0.25) }; 10]);
        assert_eq!(verdict(&segs, 10, &c).curve, None);
        c.axes[1].steps_per_mm = 40.0;
        let j = verdict(&segs, 10, &c);
        assert!(close(j.curve.unwrap().radius, 6.058_86, 1e-3), "{j:?}");
    }

    #[test]
    fn a_straight_run_of_short_chords_cruises_at_full_speed() {
        // 100 collinear chords of 20 steps (0.25 mm) at 100 mm/s, 1500 mm/s²: every vertex is straight on, so
        // the plan is one trapezoid over 25 mm. Entry speed² at vertex k: min(100², 2·1500·0.25·k, … (100 − k)),
        // exact in f32 (multiples of 750); vertices 14..=86 are entered at the full 100 mm/s.
        let c = MachineConfig::xy_plotter();
        let v = build(&c, &std::vec![([20, 0, 0, 0], 100.0); 100]);
        for (k, b) in v.iter().enumerate() {
            let k = k as f32;
            assert_eq!(b.entry_speed_sqr, 10_000f32.min(750.0 * k).min(750.0 * (100.0 - k)), "vertex {k}");
            assert_eq!(b.curve_speed_sqr, f32::INFINITY);
        }
        // 25 mm at 100 mm/s plus a ramp's lost time v/a = 1/15 s: 0.316 667 s, to within the rates' rounding.
        let t = total_ticks(&v) as f64;
        assert!((t - 316_667.0).abs() < 0.005 * 316_667.0, "{t}");
    }

    /// Ten chords of 0.25 mm along `rot − kink/2` degrees, then ten along `rot + kink/2` (100 mm/s, 1000 mm/s²):
    /// vertex 10 turns by `kink`.
    fn kinked(kink: f32, rot: f32) -> Vec<Seg> {
        kinked_runs(kink, rot, 10, 0.25)
    }

    /// `n` chords of `len` mm along `rot − kink/2` degrees, then `n` along `rot + kink/2` (100 mm/s, 1000 mm/s²):
    /// vertex `n` turns by `kink`.
    fn kinked_runs(kink: f32, rot: f32, n: usize, len: f32) -> Vec<Seg> {
        let h = (kink / 2.0).to_radians();
        let (c, s) = (rot.to_radians().cos(), rot.to_radians().sin());
        let dir = |y: f32| {
            let (ux, uy) = (h.cos(), y);
            Seg { nominal: 100.0, ..seg_xy(ux * c - uy * s, ux * s + uy * c, len) }
        };
        let mut v = std::vec![dir(-h.sin()); n];
        v.extend(std::vec![dir(h.sin()); n]);
        v
    }

    fn verdict(segs: &[Seg], j: usize, c: &MachineConfig) -> Junction {
        junction_at(&|k: usize| segs[k], segs.len(), j, c)
    }

    #[test]
    fn junction_verdict_at_a_kink_on_both_sides_of_the_threshold() {
        // 80 steps/mm on X and Y (a step of 0.0125 mm), Y limited to 700 mm/s², curve deviation 0.1 mm,
        // junction deviation 0.02 mm. Two straight runs of 0.25 mm chords meeting at a turn κ: locally smooth
        // (0.125·tan(κ/4) ≪ 0.1 mm); the 2 mm spans are exact (8 whole chords each way), so the circle through
        // their ends and the vertex has r = |p − q|/(2·sin(180° − κ)) with |p − q| = 4·cos(κ/2).
        // Rule 3 compares the turn 2·sin(κ/2) with 1.5·(0.5 + 0.5)/r + 1.5·0.0125·(1/0.5 + 1/0.5) (spans of
        // 24 steps = 0.3 mm: two whole chords, 0.5 mm).
        let mut c = MachineConfig::xy_plotter();
        c.axes[1].max_accel_mm_s2 = 700.0;
        // κ = 16°: r = 4·cos 8°/(2·sin 16°) = 7.18530 mm; turn 0.278346 ≤ 0.15/r·… = 0.283760: a curve, whose
        // normal is along Y, so v² = 700·r = 5029.71 (below the chords' 100² mm²/s²).
        let j = verdict(&kinked(16.0, 0.0), 10, &c);
        let curve = j.curve.unwrap();
        assert!(close(curve.radius, 7.185_297, 1e-3), "{j:?}");
        assert!(close(curve.speed_sqr, 5029.71, 1.0) && close(j.speed_sqr, 5029.71, 1.0), "{j:?}");
        // κ = 19°: r = 6.05886 mm; turn 0.330095 > 0.322571: a corner, junction deviation with the chords'
        // 1000 mm/s²: v² = 1000·0.02·cos 9.5°/(1 − cos 9.5°) = 1438.32.
        let j = verdict(&kinked(19.0, 0.0), 10, &c);
        assert_eq!(j.curve, None, "{j:?}");
        assert!(close(j.speed_sqr, 1438.32, 0.5), "{j:?}");
        // The 16° kink turned by 45°: the normal (at 135°) loads both axes by 1/√2, so the Y axis allows
        // 700·√2 = 989.95 mm/s² along it: v² = 989.95·7.18530 = 7113.1.
        let j = verdict(&kinked(16.0, 45.0), 10, &c);
        let curve = j.curve.unwrap();
        assert!(close(curve.radius, 7.185_297, 1e-3), "{j:?}");
        assert!(close(curve.speed_sqr, 7113.1, 1.5) && close(j.speed_sqr, 7113.1, 1.5), "{j:?}");
        // The chords' nominal speed caps the vertex (not the curve's own limit): 60 mm/s → 3600.
        let slow: Vec<Seg> = kinked(16.0, 0.0).into_iter().map(|s| Seg { nominal: 60.0, ..s }).collect();
        let j = verdict(&slow, 10, &c);
        assert!(close(j.speed_sqr, 3600.0, 0.01) && close(j.curve.unwrap().speed_sqr, 5029.71, 1.0), "{j:?}");
        // With Y at 40 steps/mm (a step of 0.025 mm, spans of 24 steps = 0.6 mm: three chords, 0.75 mm) rounding
        // explains more: 1.5·1.5/6.05886 + 1.5·0.025·(2/0.75) = 0.471359 > 0.330095, so 19° is a curve,
        // v² = 700·6.05886 = 4241.2.
        let mut coarse = c;
        coarse.axes[1].steps_per_mm = 40.0;
        let j = verdict(&kinked(19.0, 0.0), 10, &coarse);
        assert!(close(j.curve.unwrap().speed_sqr, 4241.2, 1.0), "{j:?}");
    }

    #[test]
    fn junction_verdict_of_straight_runs_corners_and_stops() {
        let c = cfg();
        // Straight on: no circle, the vertex runs at the chords' speed and lies on a curve of infinite radius.
        let straight = kinked(0.0, 30.0);
        let j = verdict(&straight, 10, &c);
        assert_eq!(
            j,
            Junction { speed_sqr: 10_000.0, curve: Some(Curve { radius: f32::INFINITY, speed_sqr: f32::INFINITY }) }
        );
        // A turn of 120° is not locally smooth (rule 1): junction deviation, 1000·0.02·sin 30°/(1 − sin 30°) = 20.
        let mut sharp = kinked(0.0, 0.0);
        for s in &mut sharp[10..] {
            *s = Seg { nominal: 100.0, ..seg_deg(120.0, 0.25) };
        }
        let j = verdict(&sharp, 10, &c);
        assert_eq!(j.curve, None);
        assert!(close(j.speed_sqr, 20.0, 1e-3), "{j:?}");
        // The start, past the end, and a fixed block on either side: rest.
        assert_eq!(verdict(&straight, 0, &c), Junction::REST);
        assert_eq!(verdict(&straight, 20, &c), Junction::REST);
        let mut fixed = straight.clone();
        fixed[9].fixed = true;
        assert_eq!(verdict(&fixed, 10, &c), Junction::REST);
        assert_ne!(verdict(&fixed, 11, &c), Junction::REST);
        let mut fixed = straight;
        fixed[10].fixed = true;
        assert_eq!(verdict(&fixed, 10, &c), Junction::REST);
    }

    #[test]
    fn chord_cap_by_sagitta_and_passes_by_hand() {
        // A chord of length L on a circle of radius r has sagitta L²/(8r): with r = 10 mm and 0.1 mm allowed,
        // chords up to √8 = 2.828 mm belong to the curve (capped at its speed), longer ones do not.
        let on = |radius: f32, speed_sqr: f32| Junction { speed_sqr, curve: Some(Curve { radius, speed_sqr }) };
        assert_eq!(chord_speed_sqr(2.8, &on(10.0, 400.0), None, 0.1), 400.0);
        assert_eq!(chord_speed_sqr(2.9, &on(10.0, 400.0), None, 0.1), f32::INFINITY);
        // Both ends on curves: the faster one; an end at a corner does not cap.
        assert_eq!(chord_speed_sqr(2.8, &on(10.0, 400.0), Some(&on(10.0, 900.0)), 0.1), 900.0);
        assert_eq!(chord_speed_sqr(2.9, &on(10.0, 400.0), Some(&on(20.0, 900.0)), 0.1), 900.0);
        assert_eq!(chord_speed_sqr(1.0, &Junction::REST, None, 0.1), f32::INFINITY);
        // Forward pass: 40 steps (0.5 mm) from rest, then a long collinear move: the second block can enter at
        // most at 2·1500·0.5 = 1500 mm²/s² (below the straight-on limit 100² and what it needs to stop).
        let c = MachineConfig::xy_plotter();
        let v = build(&c, &[([40, 0, 0, 0], 100.0), ([8000, 0, 0, 0], 100.0)]);
        assert_eq!(v[1].entry_speed_sqr, 1500.0);
        // Reverse pass: a long move, then 0.5 mm to a stop: the last block enters at most at 2·1500·0.5 = 1500.
        let v = build(&c, &[([8000, 0, 0, 0], 100.0), ([40, 0, 0, 0], 100.0)]);
        assert_eq!(v[1].entry_speed_sqr, 1500.0);
    }

    #[test]
    fn the_kink_rule_weighs_the_rounding_by_each_short_chord() {
        // Runs of 0.125 mm chords (20 a side) meeting at a turn κ, 80 steps/mm (a step of 0.0125 mm). The 2 mm spans
        // are 16 whole chords, so r = |p − q|/(2·sin κ) = 4·cos(κ/2)/(2·sin κ) = 1/sin(κ/2); the spans of 24 steps
        // (0.3 mm) take three whole chords, 0.375 mm, so rule 3 allows a turn of
        // 1.5·0.75/r + 1.5·0.0125·(1/0.375 + 1/0.375) = 1.125·sin(κ/2) + 0.1 against the turn 2·sin(κ/2).
        let c = MachineConfig::xy_plotter();
        // κ = 15°: 2·sin 7.5° = 0.261 052 > 0.146 842 + 0.1: a corner, 1000·0.02·cos 7.5°/(1 − cos 7.5°) = 2317.78.
        let j = verdict(&kinked_runs(15.0, 0.0, 20, 0.125), 20, &c);
        assert_eq!(j.curve, None, "{j:?}");
        assert!(close(j.speed_sqr, 2317.78, 0.5), "{j:?}");
        // κ = 12°: 2·sin 6° = 0.209 057 ≤ 0.117 595 + 0.1: a curve of radius 1/sin 6° = 9.566 772 mm, its normal
        // along Y (1500 mm/s²: 14 350.2 mm²/s², above the chords' 100² mm²/s²).
        // (Chords whose acceleration no path cap lowers below their axes': the axes' limits alone apply.)
        let uncapped: Vec<Seg> =
            kinked_runs(12.0, 0.0, 20, 0.125).into_iter().map(|s| Seg { accel: f32::MAX, ..s }).collect();
        let j = verdict(&uncapped, 20, &c);
        let curve = j.curve.unwrap();
        assert!(close(curve.radius, 9.566_772, 2e-3), "{j:?}");
        assert!(close(curve.speed_sqr, 14_350.2, 4.0) && j.speed_sqr == 10_000.0, "{j:?}");
    }

    #[test]
    fn line_feeds_without_a_speed_take_the_axis_limits_and_the_step_rate_caps() {
        let c = MachineConfig::xy_plotter();
        // 10 mm of X: a feed of 0, negative, infinite or NaN sets no speed, so X's 150 mm/s is the nominal.
        for feed in [0.0, -5.0, f32::INFINITY, f32::NAN] {
            let b = PlanBlock::line(&c, [800, 0, 0, 0], feed).unwrap();
            assert_eq!(b.nominal_speed, 150.0, "feed {feed}");
        }
        // With 3000 steps/mm on X, 30 000 steps (10 mm) asked at 100 mm/s: 3000 step events per mm, and the
        // stepper's 250 000 events/s allow 83.333 mm/s.
        let mut fine = c;
        fine.axes[0].steps_per_mm = 3000.0;
        let b = PlanBlock::line(&fine, [30_000, 0, 0, 0], 100.0).unwrap();
        assert_eq!(b.events_per_mm, 3000.0);
        assert!(close(b.nominal_speed, 83.333_33, 1e-3), "{}", b.nominal_speed);
    }

    #[test]
    fn a_chord_of_a_curve_cruises_at_the_curve_speed_never_above_nominal() {
        let c = MachineConfig::xy_plotter();
        let mut b = PlanBlock::line(&c, [800, 0, 0, 0], 60.0).unwrap();
        assert_eq!(b.cruise_speed(), 60.0);
        // The curve allows 50 mm/s: the chord cruises at 50 (80 steps/mm: 4000 events/s); at 60.01 mm/s the
        // nominal 60 caps it.
        b.curve_speed_sqr = 2500.0;
        assert_eq!(b.cruise_speed(), 50.0);
        assert_eq!(to_step_block(&b, 0.0).cruise_rate, 4000);
        b.curve_speed_sqr = 3601.2;
        assert_eq!(b.cruise_speed(), 60.0);
        // A curve limit equal to the nominal speed² gives the nominal speed itself, not its square root taken
        // back (for 45.278 866 mm/s the root of its f32 square comes out one ulp above).
        let mut b = PlanBlock::line(&c, [800, 0, 0, 0], 45.278_866).unwrap();
        b.curve_speed_sqr = b.nominal_speed * b.nominal_speed;
        assert_eq!(b.cruise_speed(), b.nominal_speed);
    }

    #[test]
    fn junction_speed_by_deviation_alone_capped_by_both_chords() {
        let c = MachineConfig::xy_plotter();
        let x = PlanBlock::line(&c, [800, 0, 0, 0], 100.0).unwrap();
        let y = PlanBlock::line(&c, [0, 800, 0, 0], 100.0).unwrap();
        // A right angle: 1500·0.02·sin 45°/(1 − sin 45°) = 72.426 mm²/s²; straight on: the chords' 100².
        assert!(close(junction_speed_sqr(&x, &y, 0.02), 72.426, 0.01));
        assert_eq!(junction_speed_sqr(&x, &x, 0.02), 10_000.0);
        // A chord at 5 mm/s on either side caps the corner at 25 mm²/s².
        let slow = PlanBlock::line(&c, [0, 800, 0, 0], 5.0).unwrap();
        assert_eq!(junction_speed_sqr(&x, &slow, 0.02), 25.0);
        assert_eq!(junction_speed_sqr(&slow, &x, 0.02), 25.0);
        // A fixed block on either side: a stop, whatever geometry it carries.
        let held = PlanBlock { fixed: Some(StepBlock::dwell(10)), ..y };
        assert_eq!(junction_speed_sqr(&x, &held, 0.02), 0.0);
        assert_eq!(junction_speed_sqr(&held, &x, 0.02), 0.0);
    }

    #[test]
    fn a_stiff_machine_runs_its_blocks_at_the_planned_acceleration() {
        // The HP 7475A's figures: 40 steps/mm, 381 mm/s, 19 613 mm/s². A 100 mm line along X from rest to rest:
        // 4000 events, cruise 381·40 = 15 240 events/s, acceleration 19 613·40 = 784 520 events/s² (above the
        // 250 000 steps/s step-rate limit, which caps rates, not accelerations). By hand: 4000/15 240 s of
        // cruise plus one ramp's extra 15 240/784 520 s = 0.262 467 + 0.019 426 = 0.281 893 s. Capped at 250 000
        // events/s² it took 0.262 467 + 0.060 960 = 0.323 427 s.
        let mut c = MachineConfig::xy_plotter();
        for axis in &mut c.axes[..2] {
            (axis.steps_per_mm, axis.max_feed_mm_s, axis.max_accel_mm_s2) = (40.0, 381.0, 19_613.0);
        }
        let b = PlanBlock::line(&c, [4000, 0, 0, 0], 381.0).unwrap();
        let s = to_step_block(&b, 0.0);
        assert_eq!((s.cruise_rate, s.accel), (15_240, 784_520));
        assert!(s.duration_ticks().abs_diff(281_893) <= 1, "{}", s.duration_ticks());
        // Past what a frame carries, the frame's limit.
        let stiff = PlanBlock { acceleration: 1e6, ..b };
        assert_eq!(to_step_block(&stiff, 0.0).accel, crate::protocol::ACCEL_MAX);
    }

    #[test]
    fn deviation_switches_to_straight_on_above_the_threshold() {
        // Two equal vectors (s, 0, 0, 0) make |u_prev + u_next|/2 = s exactly (not unit vectors: this sets the
        // half-angle term directly). 1000 mm/s², 0.02 mm, chords at 10⁵ mm/s (cap 10¹⁰ mm²/s²).
        let seg = |s: f32| Seg { unit: [s, 0.0, 0.0, 0.0], len: 1.0, accel: 1000.0, nominal: 1e5, fixed: false };
        let dev = |s: f32| deviation_speed_sqr(&seg(s), &seg(s), 0.02);
        // At 0.999 999 (in f32 1 − 17·2⁻²⁴ = 1 − 1.013 279·10⁻⁶) still the formula: 20·0.999 999/1.013 279·10⁻⁶
        // = 1.973 79·10⁷; one step above (0.999 999 9) straight on: the cap.
        assert!((dev(0.999_999) / 1.973_79e7 - 1.0).abs() < 1e-4, "{}", dev(0.999_999));
        assert_eq!(dev(0.999_999_9), 1e10);
        // Below 10⁻⁴ a reversal: a stop; at 0.01 the formula, 20·0.01/0.99 = 0.202 02.
        assert_eq!(dev(5e-5), 0.0);
        assert!(close(dev(0.01), 0.202_02, 1e-5), "{}", dev(0.01));
    }
}
