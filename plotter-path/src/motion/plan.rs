//! The host motion plan: a [`StepDrawing`] becomes the exact sequence of step blocks the firmware will run.
//!
//! Sequence per stroke: pen-up travel (XY at the travel feed) to the stroke start, pen drop (a Z move to the
//! pen-down height) and its settle dwell, the pen-down moves at the drawing feed, pen lift (Z to the pen-up height)
//! and its settle dwell. A servo pen (`pen.command = "servo"`) moves no axis: each drop and lift is one servo block
//! ([`StepBlock::servo`]: the angle, then the settle time as its dwell) and Z never steps. Every move becomes a [`PlanBlock`] of the firmware's own planner
//! ([`plotter_fw::planner`]: per-axis limits, junction deviation, reverse/forward passes), planned here over the
//! **whole drawing** at once — the host has unlimited look-ahead, the firmware only its queue. Dwells are fixed
//! blocks and therefore stop points, so the pen never moves sideways while it is settling.
//!
//! Every planned block is then rounded down to what a wire frame carries ([`protocol::quantize`]) *before* its
//! duration is taken with the stepper's own timing ([`StepBlock::duration_ticks`]), so [`MotionPlan::total_ticks`]
//! is the time the firmware executes, to the tick.
//!
//! The plan can also be computed with a bounded look-ahead window ([`Lookahead::Window`]) — each block planned with
//! only the blocks that follow it within the window, as a firmware with that queue length would when fed G-code —
//! to measure what the whole-drawing look-ahead gains.

use plotter_fw::config::{AxisConfig, HomingConfig, PenConfig};
use plotter_fw::planner::{self, PlanBlock};
use plotter_fw::protocol;
use plotter_fw::{Axis, MachineConfig, NUM_AXES, StepBlock, TICK_HZ};

use crate::MachineProfile;
use crate::motion::pens::{self, LayerPen};
use crate::motion::profile::{AxisProfile, HomeEnd};
use crate::motion::steps::{StepDrawing, StepMapper, StepPos};

/// Errors planning a drawing.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PlanError {
    /// A stroke point lies outside the machine's work area.
    #[error(
        "stroke {stroke}, point {point}: ({x_mm:.3}, {y_mm:.3}) mm (machine) is outside the work area \
         0..{w_mm} × 0..{h_mm} mm"
    )]
    OutsideWorkArea {
        /// Stroke index (0-based, plotting order).
        stroke: usize,
        /// Point index in the stroke (0 = its start).
        point: usize,
        /// Machine X, mm.
        x_mm: f64,
        /// Machine Y, mm.
        y_mm: f64,
        /// X travel, mm.
        w_mm: f64,
        /// Y travel, mm.
        h_mm: f64,
    },
    /// The profile cannot drive the firmware core.
    #[error("machine profile: {0}")]
    Config(String),
    /// The pen Z heights do not round to different steps.
    #[error("machine profile: pen.up_z_mm and pen.down_z_mm round to the same Z step")]
    PenHeights,
}

/// Convert a plotter-path profile (f64, TOML) to the firmware's configuration (f32, plain struct).
pub fn machine_config(profile: &MachineProfile) -> Result<MachineConfig, PlanError> {
    // The firmware works in f32; every profile value is a physical quantity far inside the f32 range.
    #[allow(clippy::cast_possible_truncation)]
    fn f(v: f64) -> f32 {
        v as f32
    }
    let axis = |a: &AxisProfile| AxisConfig {
        enabled: true,
        steps_per_mm: f(a.steps_per_mm),
        travel_mm: f(a.travel_mm),
        max_feed_mm_s: f(a.max_feed_mm_s),
        max_accel_mm_s2: f(a.max_accel_mm_s2),
        invert_dir: a.invert_dir,
        home_at_max: a.home == HomeEnd::Max,
    };
    let ax = &profile.axes;
    let cfg = MachineConfig {
        axes: [axis(&ax.x), axis(&ax.y), axis(&ax.z), ax.e.as_ref().map_or(AxisConfig::DISABLED, axis)],
        junction_deviation_mm: f(profile.motion.junction_deviation_mm),
        curve_deviation_mm: f(profile.motion.curve_deviation_mm),
        homing: HomingConfig {
            seek_mm_s: f(profile.homing.seek_mm_s),
            locate_mm_s: f(profile.homing.locate_mm_s),
            pull_off_mm: f(profile.homing.pull_off_mm),
            debounce_ms: f(profile.homing.debounce_ms),
        },
        pen: PenConfig {
            up_z_mm: f(profile.pen.up_z_mm),
            down_z_mm: f(profile.pen.down_z_mm),
            servo_up_deg: f(profile.pen.servo_up_deg),
            servo_down_deg: f(profile.pen.servo_down_deg),
        },
        rx_buffer_bytes: profile.link.rx_buffer_bytes,
        queue_blocks: profile.link.queue_blocks,
        soft_limits: true,
        hard_limits: true,
    };
    cfg.validate().map_err(|e| PlanError::Config(e.to_string()))?;
    Ok(cfg)
}

/// What a planned block does.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum MoveKind {
    /// Z move lifting the pen.
    PenUp,
    /// Z move lowering the pen.
    PenDown,
    /// Settle dwell after a pen move.
    Settle,
    /// Pen-up XY travel.
    Travel,
    /// Pen-down XY move.
    Draw,
}

/// One block of the plan: the exact step block sent to the firmware and what it is for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PlannedBlock {
    /// The quantized step block, as encoded on the wire.
    pub block: StepBlock,
    /// Its role.
    pub kind: MoveKind,
    /// The stroke it belongs to (the travel to a stroke belongs to that stroke).
    pub stroke: usize,
}

/// A pen change between two layers: the plot stops with the pen up before block `block` (the travel to the new
/// layer's first stroke) so that the user can load `pen`.
#[derive(Debug, Clone, PartialEq)]
pub struct PenChange {
    /// Index (in the original plan's numbering) of the first block drawn with the new pen: the travel to the
    /// layer's first stroke (or its pen drop when no travel is needed).
    pub block: usize,
    /// Index of the new layer in [`StepDrawing::layers`].
    pub layer: usize,
    /// The layer's name.
    pub layer_name: String,
    /// The pen to load.
    pub pen: LayerPen,
    /// The pen loaded before.
    pub previous: LayerPen,
}

/// A machine position in steps, all axes.
pub type MachinePos = [i32; NUM_AXES];

/// How far ahead the planner looks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Lookahead {
    /// Over the whole drawing (the host's plan).
    Whole,
    /// Each block planned with at most this many blocks (itself included), like a firmware queue of that length.
    Window(usize),
}

/// Where a plan's time goes, in ticks ([`TICK_HZ`]): the parts add up to [`MotionPlan::total_ticks`] exactly.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct PlanBreakdown {
    /// Pen-down drawing moves.
    pub draw_ticks: u64,
    /// Pen-up XY travel moves.
    pub travel_ticks: u64,
    /// Pen lifts and drops (Z moves) with their settle dwells.
    pub lift_ticks: u64,
}

impl PlanBreakdown {
    fn secs(ticks: u64) -> f64 {
        // u64 ticks of a plot fit f64's 53-bit mantissa for any realistic duration.
        #[allow(clippy::cast_precision_loss)]
        let t = ticks as f64;
        t / f64::from(TICK_HZ)
    }

    /// Pen-down drawing time, seconds.
    pub fn draw_s(&self) -> f64 {
        Self::secs(self.draw_ticks)
    }

    /// Pen-up travel time, seconds.
    pub fn travel_s(&self) -> f64 {
        Self::secs(self.travel_ticks)
    }

    /// Lift, drop and settle time, seconds.
    pub fn lift_s(&self) -> f64 {
        Self::secs(self.lift_ticks)
    }

    /// The whole, ticks.
    pub fn total_ticks(&self) -> u64 {
        self.draw_ticks + self.travel_ticks + self.lift_ticks
    }
}

/// The result of planning: blocks, exact time, positions.
#[derive(Debug, Clone, PartialEq)]
pub struct MotionPlan {
    /// Blocks in execution order.
    pub blocks: Vec<PlannedBlock>,
    /// Where the plan starts (steps, all axes).
    pub start: MachinePos,
    /// Where it ends.
    pub end: MachinePos,
    /// Exact execution time, timer ticks ([`TICK_HZ`]).
    pub total_ticks: u64,
    /// Pen-down path length, mm.
    pub draw_mm: f64,
    /// Pen-up travel length, mm.
    pub travel_mm: f64,
    /// For a resumed plan ([`plan_resume`]): how many blocks of the original plan were already done.
    pub resumed_from: usize,
    /// For a resumed plan: the number of leading blocks that bring the pen back (not part of the original plan).
    /// `blocks[preamble + i]` is block `resumed_from + i` of the original plan.
    pub preamble: usize,
    /// The pen the first layer is drawn with.
    pub first_pen: LayerPen,
    /// Pen changes between layers with different pens, numbered in the original plan (also in a resumed plan).
    pub pen_changes: Vec<PenChange>,
}

impl MotionPlan {
    /// Execution time in seconds.
    pub fn seconds(&self) -> f64 {
        // u64 ticks of a plot fit f64's 53-bit mantissa for any realistic duration.
        #[allow(clippy::cast_precision_loss)]
        let t = self.total_ticks as f64;
        t / f64::from(TICK_HZ)
    }

    /// Exact execution time of the blocks from `from` on (ticks).
    pub fn ticks_from(&self, from: usize) -> u64 {
        self.blocks.iter().skip(from).map(|b| u64::from(b.block.duration_ticks())).sum()
    }

    /// Where the time goes: drawing, travel, and lifts with their settles (see [`PlanBreakdown`]).
    pub fn breakdown(&self) -> PlanBreakdown {
        let mut b = PlanBreakdown::default();
        for p in &self.blocks {
            let t = u64::from(p.block.duration_ticks());
            match p.kind {
                MoveKind::Draw => b.draw_ticks += t,
                MoveKind::Travel => b.travel_ticks += t,
                MoveKind::PenUp | MoveKind::PenDown | MoveKind::Settle => b.lift_ticks += t,
            }
        }
        b
    }

    /// Index in the original plan of `blocks[i]`, `None` for a resume preamble block.
    pub fn original_index(&self, i: usize) -> Option<usize> {
        i.checked_sub(self.preamble).map(|k| k + self.resumed_from)
    }

    /// A hash of the plan's geometry and block kinds (FNV-1a), to check that a resumed plot re-plans the same
    /// drawing.
    pub fn geometry_hash(&self) -> u64 {
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        let mut eat = |v: i32| {
            for b in v.to_le_bytes() {
                h ^= u64::from(b);
                h = h.wrapping_mul(0x0100_0000_01b3);
            }
        };
        for b in &self.blocks {
            b.block.steps.iter().for_each(|s| eat(*s));
            eat(i32::from(b.kind as u8));
        }
        h
    }

    /// Position after block `i` (steps), by summing from the start.
    pub fn position_after(&self, i: usize) -> MachinePos {
        self.positions().take(i + 1).last().unwrap_or(self.start)
    }

    /// The position after each block in turn (steps, all axes): one pass over the plan, where calling
    /// [`position_after`](Self::position_after) for every block would sum from the start each time.
    pub fn positions(&self) -> impl Iterator<Item = MachinePos> + '_ {
        self.blocks.iter().scan(self.start, |p, b| {
            for (k, s) in b.block.steps.iter().enumerate() {
                p[k] += s;
            }
            Some(*p)
        })
    }
}

/// Where a pen block puts the pen: a Z height (steps) or a servo angle (tenths of a degree).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum PenAt {
    /// Z axis at this step position.
    Z(i32),
    /// Servo at this angle, tenths of a degree.
    Servo(u16),
}

/// A servo angle (degrees, validated 0..=180 by the profile) in tenths of a degree.
fn servo_tenths(deg: f64) -> u16 {
    // Clamped to 0..=1800 first.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let t = (deg * 10.0).round().clamp(0.0, f64::from(plotter_fw::SERVO_TENTHS_MAX)) as u16;
    t
}

/// The pen-up position and the pen-down position of every layer pen.
fn pen_targets(profile: &MachineProfile, pens: &[LayerPen]) -> Result<(PenAt, Vec<PenAt>), PlanError> {
    if profile.pen.uses_servo() {
        let downs = pens.iter().map(|p| PenAt::Servo(servo_tenths(p.servo_down_deg))).collect();
        return Ok((PenAt::Servo(servo_tenths(profile.pen.servo_up_deg)), downs));
    }
    let (up, _) = pen_steps(profile)?;
    let downs =
        pens.iter().map(|p| pen_steps_at(profile, p.down_z_mm).map(|s| PenAt::Z(s.1))).collect::<Result<_, _>>()?;
    Ok((PenAt::Z(up), downs))
}

/// The machine's pen Z positions in steps.
fn pen_steps(profile: &MachineProfile) -> Result<(i32, i32), PlanError> {
    pen_steps_at(profile, profile.pen.down_z_mm)
}

/// The pen-up Z and the pen-down Z `down_mm` in steps.
fn pen_steps_at(profile: &MachineProfile, down_mm: f64) -> Result<(i32, i32), PlanError> {
    let m = StepMapper::new(profile);
    let up = m.z_steps(profile.pen.up_z_mm).ok_or(PlanError::PenHeights)?;
    let down = m.z_steps(down_mm).ok_or(PlanError::PenHeights)?;
    if up == down {
        return Err(PlanError::PenHeights);
    }
    Ok((up, down))
}

/// The resolved pen of every layer of `steps` (one default layer when it has none).
pub fn layer_pens(profile: &MachineProfile, steps: &StepDrawing) -> Vec<LayerPen> {
    if steps.layers.is_empty() {
        return vec![pens::resolve(profile, "", &crate::Pen::default())];
    }
    steps.layers.iter().map(|l| pens::resolve(profile, &l.name, &l.pen)).collect()
}

/// The park position for pen changes (steps, X and Y): the profile's `[park]`, else the homed corner.
pub fn park_position(profile: &MachineProfile) -> Result<StepPos, PlanError> {
    match profile.park {
        Some(p) => {
            let m = StepMapper::new(profile);
            let (sx, sy) = m.steps_per_mm();
            let r = |v: f64| crate::motion::steps::round_steps(v).ok_or(PlanError::Config("park: out of range".into()));
            Ok(StepPos::new(r(p.x_mm * sx)?, r(p.y_mm * sy)?))
        }
        None => {
            let h = homed_position(profile)?;
            Ok(StepPos::new(h[0], h[1]))
        }
    }
}

/// A plan of one pen-up travel from `from` to `to` (XY) at the travel feed, lifting the pen first when it is not
/// at the pen-up height: what parks the carriage for a pen change.
pub fn plan_travel(profile: &MachineProfile, from: MachinePos, to: StepPos) -> Result<MotionPlan, PlanError> {
    let cfg = machine_config(profile)?;
    let (up, _) = pen_targets(profile, &[])?;
    #[allow(clippy::cast_possible_truncation)]
    let travel = profile.pen.travel_feed_mm_s as f32;
    let mut raw = RawPlan {
        cfg: &cfg,
        blocks: Vec::new(),
        meta: Vec::new(),
        pos: from,
        settle: settle_ticks(profile),
        changes: Vec::new(),
    };
    // A servo's angle is not part of the position: lift it to be sure.
    if !raw.at(up) {
        raw.pen(up, MoveKind::PenUp, 0);
    }
    raw.line_to(to, travel, MoveKind::Travel, 0);
    let first = pens::resolve(profile, "", &crate::Pen::default());
    Ok(finish(profile, &cfg, raw.blocks, raw.meta, from, Lookahead::Whole, (0, 0), first, Vec::new()))
}

/// The position after homing: X and Y at their switch end, Z at the pen-up height.
pub fn homed_position(profile: &MachineProfile) -> Result<MachinePos, PlanError> {
    let (up, _) = pen_steps(profile)?;
    let end = |a: &AxisProfile| {
        if a.home == HomeEnd::Max {
            crate::motion::steps::round_steps(a.travel_mm * a.steps_per_mm).unwrap_or(0)
        } else {
            0
        }
    };
    Ok([end(&profile.axes.x), end(&profile.axes.y), up, 0])
}

/// Where the pen is after homing, in page millimetres (where a plot's first travel starts).
pub fn home_on_page(profile: &MachineProfile) -> Result<kurbo::Point, PlanError> {
    let h = homed_position(profile)?;
    Ok(StepMapper::new(profile).steps_to_page(StepPos::new(h[0], h[1])))
}

/// Check that every stroke point is inside the work area (0..=travel on X and Y, in steps).
pub fn check_work_area(profile: &MachineProfile, steps: &StepDrawing) -> Result<(), PlanError> {
    let mapper = StepMapper::new(profile);
    let lim = |a: &AxisProfile| crate::motion::steps::round_steps(a.travel_mm * a.steps_per_mm).unwrap_or(i32::MAX);
    let (wx, wy) = (lim(&profile.axes.x), lim(&profile.axes.y));
    for (si, s) in steps.strokes.iter().enumerate() {
        for (pi, p) in s.positions().into_iter().enumerate() {
            if !(0..=wx).contains(&p.x) || !(0..=wy).contains(&p.y) {
                let m = mapper.steps_to_machine(p);
                return Err(PlanError::OutsideWorkArea {
                    stroke: si,
                    point: pi,
                    x_mm: m.x,
                    y_mm: m.y,
                    w_mm: profile.axes.x.travel_mm,
                    h_mm: profile.axes.y.travel_mm,
                });
            }
        }
    }
    Ok(())
}

/// Settle dwell in ticks.
pub(crate) fn settle_ticks(profile: &MachineProfile) -> u32 {
    let t = (profile.pen.settle_ms * 1000.0).round();
    // Clamped into the u32 range first.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let ticks = t.clamp(0.0, f64::from(protocol::DWELL_MAX)) as u32;
    ticks
}

/// The raw (unplanned) block sequence with each block's kind and stroke, built move by move.
struct RawPlan<'c> {
    cfg: &'c MachineConfig,
    blocks: Vec<PlanBlock>,
    meta: Vec<(MoveKind, usize)>,
    pos: MachinePos,
    settle: u32,
    changes: Vec<PenChange>,
}

impl RawPlan<'_> {
    fn push(&mut self, delta: MachinePos, feed: f32, kind: MoveKind, stroke: usize) -> bool {
        let Some(b) = PlanBlock::line(self.cfg, delta, feed) else { return false };
        self.blocks.push(b);
        self.meta.push((kind, stroke));
        for (p, d) in self.pos.iter_mut().zip(delta) {
            *p += d;
        }
        true
    }

    /// Z to `z` at the Z axis's maximum feed, then the settle dwell; or one servo block (angle and settle).
    fn pen(&mut self, to: PenAt, kind: MoveKind, stroke: usize) {
        match to {
            PenAt::Z(z) => {
                let feed = self.cfg.axis(Axis::Z).max_feed_mm_s;
                if self.push([0, 0, z - self.pos[2], 0], feed, kind, stroke) && self.settle > 0 {
                    self.blocks.push(PlanBlock::fixed(StepBlock::dwell(self.settle)));
                    self.meta.push((MoveKind::Settle, stroke));
                }
            }
            PenAt::Servo(tenths) => {
                self.blocks.push(PlanBlock::fixed(StepBlock::servo(tenths, self.settle)));
                self.meta.push((kind, stroke));
            }
        }
    }

    /// Whether the pen is known to be at `to` (a Z height reached; never for a servo, whose angle is not tracked).
    fn at(&self, to: PenAt) -> bool {
        to == PenAt::Z(self.pos[2])
    }

    fn line_to(&mut self, to: StepPos, feed: f32, kind: MoveKind, stroke: usize) {
        self.push([to.x - self.pos[0], to.y - self.pos[1], 0, 0], feed, kind, stroke);
    }
}

fn build_blocks<'c>(
    profile: &MachineProfile,
    cfg: &'c MachineConfig,
    steps: &StepDrawing,
    start: MachinePos,
    return_home: bool,
) -> Result<RawPlan<'c>, PlanError> {
    // Feeds are f32 in the firmware; values are physical speeds.
    #[allow(clippy::cast_possible_truncation)]
    let f32_of = |v: f64| v as f32;
    let travel = f32_of(profile.pen.travel_feed_mm_s);
    let pens = layer_pens(profile, steps);
    let (up, downs) = pen_targets(profile, &pens)?;
    let capacity = steps.move_count() + 6 * steps.strokes.len() + 2;
    let mut raw = RawPlan {
        cfg,
        blocks: Vec::with_capacity(capacity),
        meta: Vec::with_capacity(capacity),
        pos: start,
        settle: settle_ticks(profile),
        changes: Vec::new(),
    };
    raw.pen(up, MoveKind::PenUp, 0);
    let mut layer = 0;
    for (si, stroke) in steps.strokes.iter().enumerate() {
        let l = steps.layer_of(si);
        if l != layer {
            if !pens[l].same_pen(&pens[layer]) {
                raw.changes.push(PenChange {
                    block: raw.blocks.len(),
                    layer: l,
                    layer_name: steps.layers.get(l).map(|x| x.name.clone()).unwrap_or_default(),
                    pen: pens[l].clone(),
                    previous: pens[layer].clone(),
                });
            }
            layer = l;
        }
        let (down, draw) = (downs[l], f32_of(pens[l].draw_feed_mm_s));
        raw.line_to(stroke.start, travel, MoveKind::Travel, si);
        raw.pen(down, MoveKind::PenDown, si);
        let mut at = stroke.start;
        for d in &stroke.moves {
            at = at.offset(*d);
            raw.line_to(at, draw, MoveKind::Draw, si);
        }
        raw.pen(up, MoveKind::PenUp, si);
    }
    if return_home {
        let last = steps.strokes.len().saturating_sub(1);
        raw.line_to(StepPos::new(start[0], start[1]), travel, MoveKind::Travel, last);
    }
    Ok(raw)
}

/// Plan `steps` starting from machine position `start` (steps; see [`homed_position`]) with the given look-ahead.
/// The work area is checked first; nothing is planned for a drawing that does not fit.
pub fn plan(
    profile: &MachineProfile,
    steps: &StepDrawing,
    start: MachinePos,
    lookahead: Lookahead,
) -> Result<MotionPlan, PlanError> {
    plan_returning(profile, steps, start, lookahead, false)
}

/// [`plan`], and with `return_home` a last pen-up travel back to `start`'s X and Y.
pub fn plan_returning(
    profile: &MachineProfile,
    steps: &StepDrawing,
    start: MachinePos,
    lookahead: Lookahead,
    return_home: bool,
) -> Result<MotionPlan, PlanError> {
    let cfg = machine_config(profile)?;
    check_work_area(profile, steps)?;
    let raw = build_blocks(profile, &cfg, steps, start, return_home)?;
    let first = layer_pens(profile, steps).swap_remove(0);
    Ok(finish(profile, &cfg, raw.blocks, raw.meta, start, lookahead, (0, 0), first, raw.changes))
}

/// Plan the rest of a drawing after its first `done` blocks (as numbered by [`plan`] from `original_start`) were
/// executed, starting from machine position `now`: the pen is lifted if it is down, travels to where block `done`
/// starts, is set to the height it had there, and blocks `done..` follow with their original geometry (so the
/// pen-down steps are exactly those an uninterrupted plot makes), re-planned from rest.
pub fn plan_resume(
    profile: &MachineProfile,
    steps: &StepDrawing,
    original_start: MachinePos,
    done: usize,
    now: MachinePos,
    return_home: bool,
) -> Result<MotionPlan, PlanError> {
    let cfg = machine_config(profile)?;
    check_work_area(profile, steps)?;
    let full = build_blocks(profile, &cfg, steps, original_start, return_home)?;
    let done = done.min(full.blocks.len());
    let mut target = original_start;
    for b in &full.blocks[..done] {
        for (t, s) in target.iter_mut().zip(b.steps) {
            *t += s;
        }
    }
    let pens = layer_pens(profile, steps);
    let (up, downs) = pen_targets(profile, &pens)?;
    let stroke = full.meta.get(done).map_or(0, |m| m.1);
    // The pen at block `done`: as the last pen block before it left it.
    let pen_down = full.meta[..done].iter().rev().find(|m| matches!(m.0, MoveKind::PenUp | MoveKind::PenDown));
    let resume_pen = match (up, pen_down) {
        (PenAt::Z(_), _) => PenAt::Z(target[2]),
        (PenAt::Servo(_), Some((MoveKind::PenDown, s))) => downs[steps.layer_of(*s)],
        (PenAt::Servo(_), _) => up,
    };
    #[allow(clippy::cast_possible_truncation)]
    let travel = profile.pen.travel_feed_mm_s as f32;
    let mut pre = RawPlan {
        cfg: &cfg,
        blocks: Vec::new(),
        meta: Vec::new(),
        pos: now,
        settle: settle_ticks(profile),
        changes: Vec::new(),
    };
    if !pre.at(up) {
        pre.pen(up, MoveKind::PenUp, stroke);
    }
    pre.line_to(StepPos::new(target[0], target[1]), travel, MoveKind::Travel, stroke);
    if resume_pen != up {
        pre.pen(resume_pen, MoveKind::PenDown, stroke);
    }
    let preamble = pre.blocks.len();
    let mut blocks = pre.blocks;
    let mut meta = pre.meta;
    blocks.extend_from_slice(&full.blocks[done..]);
    meta.extend_from_slice(&full.meta[done..]);
    let first = layer_pens(profile, steps).swap_remove(0);
    Ok(finish(profile, &cfg, blocks, meta, now, Lookahead::Whole, (done, preamble), first, full.changes))
}

/// Link, plan and quantize a raw block sequence.
#[allow(clippy::too_many_arguments)]
fn finish(
    profile: &MachineProfile,
    cfg: &MachineConfig,
    mut raw: Vec<PlanBlock>,
    meta: Vec<(MoveKind, usize)>,
    start: MachinePos,
    lookahead: Lookahead,
    (resumed_from, preamble): (usize, usize),
    first_pen: LayerPen,
    pen_changes: Vec<PenChange>,
) -> MotionPlan {
    planner::link_all(&mut raw, cfg);
    let step_blocks: Vec<StepBlock> = match lookahead {
        Lookahead::Whole => {
            planner::plan(&mut raw, 0.0);
            planner::step_blocks(&raw).collect()
        }
        Lookahead::Window(w) => windowed(&raw, w.max(1)),
    };
    let mut blocks = Vec::with_capacity(step_blocks.len());
    let mut total = 0u64;
    let mut end = start;
    for (b, (kind, stroke)) in step_blocks.iter().zip(meta) {
        let q = protocol::quantize(b);
        total += u64::from(q.duration_ticks());
        for (e, s) in end.iter_mut().zip(q.steps) {
            *e += s;
        }
        blocks.push(PlannedBlock { block: q, kind, stroke });
    }
    let mapper = StepMapper::new(profile);
    let mut draw_mm = 0.0;
    let mut travel_mm = 0.0;
    for b in &blocks {
        let d = mapper.steps_to_machine(StepPos::new(b.block.steps[0], b.block.steps[1]));
        let len = d.to_vec2().hypot();
        match b.kind {
            MoveKind::Draw => draw_mm += len,
            MoveKind::Travel => travel_mm += len,
            _ => {}
        }
    }
    MotionPlan {
        blocks,
        start,
        end,
        total_ticks: total,
        draw_mm,
        travel_mm,
        resumed_from,
        preamble,
        first_pen,
        pen_changes,
    }
}

/// Plan each block seeing at most `w` blocks (itself included): the block's speed plan is taken from planning the
/// window that starts with it, entered at the speed the previous block actually exited with.
fn windowed(raw: &[PlanBlock], w: usize) -> Vec<StepBlock> {
    let mut out = Vec::with_capacity(raw.len());
    let mut entry_sqr = 0.0f32;
    for i in 0..raw.len() {
        let end = (i + w).min(raw.len());
        let mut win: Vec<PlanBlock> = raw[i..end].to_vec();
        planner::plan(&mut win, entry_sqr);
        let exit = planner::exit_speed_sqr(&win, 0);
        out.push(planner::to_step_block(&win[0], exit));
        entry_sqr = exit;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::steps::{StepDelta, StepStroke, drawing_to_steps};
    use crate::{Drawing, Polyline};
    use kurbo::Point;

    fn profile() -> MachineProfile {
        MachineProfile::default_plotter()
    }

    fn square(x: f64, y: f64, s: f64) -> Polyline {
        Polyline::new(vec![
            Point::new(x, y),
            Point::new(x + s, y),
            Point::new(x + s, y + s),
            Point::new(x, y + s),
            Point::new(x, y),
        ])
    }

    #[test]
    fn sequence_kinds_and_end_position() {
        let p = profile();
        let steps = drawing_to_steps(&p, &Drawing::single_layer("a", vec![square(10.0, 10.0, 5.0)])).unwrap();
        let start = homed_position(&p).unwrap();
        let plan = plan(&p, &steps, start, Lookahead::Whole).unwrap();
        let kinds: Vec<MoveKind> = plan.blocks.iter().map(|b| b.kind).collect();
        use MoveKind::*;
        assert_eq!(kinds, [Travel, PenDown, Settle, Draw, Draw, Draw, Draw, PenUp, Settle]);
        assert_eq!(plan.end, [800, 800, 1600, 0]);
        assert_eq!(plan.position_after(plan.blocks.len() - 1), plan.end);
        assert!((plan.draw_mm - 20.0).abs() < 1e-9 && (plan.travel_mm - 200f64.sqrt()).abs() < 1e-9);
        // Pen moves are pure Z, dwells last the settle time (50 ms = 50 000 ticks).
        assert_eq!(plan.blocks[1].block.steps, [0, 0, -1600, 0]);
        assert_eq!(plan.blocks[2].block, StepBlock::dwell(50_000));
        // Total time is the sum of the quantized blocks' durations.
        let sum: u64 = plan.blocks.iter().map(|b| u64::from(b.block.duration_ticks())).sum();
        assert_eq!(plan.total_ticks, sum);
        assert_eq!(plan.ticks_from(0), sum);
        // Every block is representable on the wire.
        let mut enc = protocol::Encoder::new();
        let mut buf = [0u8; protocol::MAX_FRAME];
        for (i, b) in plan.blocks.iter().enumerate() {
            enc.encode(&b.block, u32::try_from(i).unwrap(), &mut buf).unwrap();
        }
    }

    #[test]
    fn breakdown_of_two_lines_by_hand() {
        // A near-zero junction deviation makes every XY/Z junction a stop, so each move is a rest-to-rest
        // trapezoid t = d/v + v/a (long enough to reach v: d ≥ v²/a).
        let mut p = profile();
        p.motion.junction_deviation_mm = 1e-6;
        let line = |a: (f64, f64), b: (f64, f64)| Polyline::new(vec![Point::new(a.0, a.1), Point::new(b.0, b.1)]);
        let d = Drawing::single_layer("a", vec![line((0.0, 10.0), (30.0, 10.0)), line((30.0, 20.0), (0.0, 20.0))]);
        let steps = drawing_to_steps(&p, &d).unwrap();
        let plan = plan(&p, &steps, homed_position(&p).unwrap(), Lookahead::Whole).unwrap();
        let b = plan.breakdown();
        assert_eq!(b.total_ticks(), plan.total_ticks);
        // Travel: two 10 mm hops along Y at 120 mm/s, 1500 mm/s²: 2 · (10/120 + 120/1500) = 0.326667 s.
        assert!((b.travel_s() - 2.0 * (10.0 / 120.0 + 0.08)).abs() < 1e-3, "{b:?}");
        // Drawing: two 30 mm lines along X at 60 mm/s: 2 · (30/60 + 60/1500) = 1.08 s.
        assert!((b.draw_s() - 2.0 * (0.5 + 0.04)).abs() < 1e-3, "{b:?}");
        // Lifts: two drops and two lifts, each 4 mm of Z at 25 mm/s, 500 mm/s² (4/25 + 25/500 = 0.21 s) and a
        // 50 ms settle: 4 · 0.26 = 1.04 s.
        assert!((b.lift_s() - 4.0 * 0.26).abs() < 1e-3, "{b:?}");
    }

    #[test]
    fn starting_with_the_pen_down_lifts_it_first() {
        let p = profile();
        let steps = StepDrawing::from_strokes(vec![StepStroke { start: StepPos::new(8, 8), moves: vec![] }]);
        let plan = plan(&p, &steps, [0, 0, 0, 0], Lookahead::Whole).unwrap();
        assert_eq!(plan.blocks[0].kind, MoveKind::PenUp);
        assert_eq!(plan.blocks[0].block.steps, [0, 0, 1600, 0]);
    }

    #[test]
    fn outside_the_work_area_is_refused() {
        let p = profile();
        let steps = StepDrawing::from_strokes(vec![StepStroke {
            start: StepPos::new(8, 8),
            moves: vec![StepDelta { dx: -9, dy: 0 }],
        }]);
        let e = plan(&p, &steps, homed_position(&p).unwrap(), Lookahead::Whole).unwrap_err();
        assert!(matches!(e, PlanError::OutsideWorkArea { stroke: 0, point: 1, .. }), "{e}");
        assert!(e.to_string().contains("(-0.013, 0.100) mm"), "{e}");
    }

    #[test]
    fn whole_lookahead_is_never_slower_than_a_window() {
        let p = profile();
        // A circle of 720 short chords: the window cannot see far enough to keep speed, the whole plan can.
        let pts: Vec<Point> = (0..=720)
            .map(|i| {
                let a = f64::from(i) * std::f64::consts::TAU / 720.0;
                Point::new(100.0 + 40.0 * a.cos(), 100.0 + 40.0 * a.sin())
            })
            .collect();
        let steps = drawing_to_steps(&p, &Drawing::single_layer("c", vec![Polyline::new(pts)])).unwrap();
        let start = homed_position(&p).unwrap();
        let whole = plan(&p, &steps, start, Lookahead::Whole).unwrap();
        let win = plan(&p, &steps, start, Lookahead::Window(16)).unwrap();
        let one = plan(&p, &steps, start, Lookahead::Window(1)).unwrap();
        assert!(whole.total_ticks <= win.total_ticks && win.total_ticks < one.total_ticks);
        // Same geometry whatever the look-ahead.
        let geo = |m: &MotionPlan| m.blocks.iter().map(|b| b.block.steps).collect::<Vec<_>>();
        assert_eq!(geo(&whole), geo(&win));
        // A window as long as the drawing is the whole plan.
        let all = plan(&p, &steps, start, Lookahead::Window(whole.blocks.len())).unwrap();
        assert_eq!(all.total_ticks, whole.total_ticks);
    }

    #[test]
    fn resume_keeps_the_remaining_geometry() {
        let p = profile();
        let d = Drawing::single_layer("a", vec![square(10.0, 10.0, 5.0), square(30.0, 10.0, 5.0)]);
        let steps = drawing_to_steps(&p, &d).unwrap();
        let start = homed_position(&p).unwrap();
        let full = plan(&p, &steps, start, Lookahead::Whole).unwrap();
        assert_eq!((full.resumed_from, full.preamble), (0, 0));
        // Resume in the middle of the first square's drawing (block 4 is its second Draw), pen found down at 0,0.
        let r = plan_resume(&p, &steps, start, 4, [0, 0, 0, 0], false).unwrap();
        use MoveKind::*;
        let kinds: Vec<MoveKind> = r.blocks[..r.preamble].iter().map(|b| b.kind).collect();
        assert_eq!(kinds, [PenUp, Settle, Travel, PenDown, Settle]);
        assert_eq!(r.position_after(r.preamble - 1), full.position_after(3));
        let rest: Vec<_> = r.blocks[r.preamble..].iter().map(|b| (b.block.steps, b.kind)).collect();
        let orig: Vec<_> = full.blocks[4..].iter().map(|b| (b.block.steps, b.kind)).collect();
        assert_eq!(rest, orig);
        assert_eq!(r.end, full.end);
        assert_eq!(r.original_index(r.preamble), Some(4));
        assert_eq!(r.original_index(0), None);
        // Resuming at a pen-up point from the pen-up height needs no pen moves.
        let r = plan_resume(&p, &steps, start, 9, start, false).unwrap();
        assert_eq!(r.blocks[..r.preamble].iter().map(|b| b.kind).collect::<Vec<_>>(), [Travel]);
        assert_ne!(full.geometry_hash(), r.geometry_hash());
        assert_eq!(full.geometry_hash(), plan(&p, &steps, start, Lookahead::Window(4)).unwrap().geometry_hash());
    }

    #[test]
    fn servo_pens_plan_servo_blocks_and_resume_with_them() {
        let mut p = profile();
        p.pen.command = crate::motion::profile::PenCommand::Servo;
        p.pen.settle_ms = 120.0;
        let d = Drawing::single_layer("a", vec![square(10.0, 10.0, 5.0), square(30.0, 10.0, 5.0)]);
        let steps = drawing_to_steps(&p, &d).unwrap();
        let start = homed_position(&p).unwrap();
        let full = plan(&p, &steps, start, Lookahead::Whole).unwrap();
        use MoveKind::*;
        let up = Some(StepBlock::servo(900, 120_000));
        let down = Some(StepBlock::servo(300, 120_000));
        let shape: Vec<(MoveKind, Option<StepBlock>)> =
            full.blocks.iter().map(|b| (b.kind, b.block.servo.map(|_| b.block))).collect();
        let square_blocks = [(Travel, None), (PenDown, down), (Draw, None), (Draw, None), (Draw, None), (Draw, None)];
        let mut expected = vec![(PenUp, up)];
        for _ in 0..2 {
            expected.extend(square_blocks);
            expected.push((PenUp, up));
        }
        assert_eq!(shape, expected);
        assert!(full.blocks.iter().all(|b| b.block.steps[2] == 0), "no Z steps");
        // Resumed on the first square's second side (block 4): lift, travel back, lower to the pen's angle.
        let r = plan_resume(&p, &steps, start, 4, [0, 0, start[2], 0], false).unwrap();
        let pre: Vec<(MoveKind, Option<u16>)> =
            r.blocks[..r.preamble].iter().map(|b| (b.kind, b.block.servo)).collect();
        assert_eq!(pre, [(PenUp, Some(900)), (Travel, None), (PenDown, Some(300))]);
        assert_eq!(r.position_after(r.preamble - 1), full.position_after(3));
        // Resumed at the travel to the second square (pen up): the servo is lifted anyway, its angle being unknown.
        let r = plan_resume(&p, &steps, start, 8, start, false).unwrap();
        let pre: Vec<MoveKind> = r.blocks[..r.preamble].iter().map(|b| b.kind).collect();
        assert_eq!(pre, [PenUp, Travel]);
    }

    #[test]
    fn pen_changes_sit_before_the_travel_to_a_layer_with_another_pen() {
        use crate::motion::profile::PenSpec;
        let mut p = profile();
        p.pens = vec![PenSpec {
            name: "red".into(),
            color: Some("#ff0000".into()),
            width_mm: None,
            down_z_mm: Some(1.0),
            servo_down_deg: None,
            draw_feed_mm_s: Some(30.0),
            hatch: None,
        }];
        let mut d = Drawing::single_layer("black", vec![square(10.0, 10.0, 5.0)]);
        let layers = [
            ("red", crate::Rgb(255, 0, 0), 30.0),
            ("red2", crate::Rgb(255, 0, 0), 50.0),
            ("k", crate::Rgb::BLACK, 70.0),
        ];
        for (name, color, x) in layers {
            let mut l = crate::Layer::new(name);
            l.pen.color = color;
            l.paths = vec![square(x, 10.0, 5.0)];
            d.layers.push(l);
        }
        let steps = drawing_to_steps(&p, &d).unwrap();
        let start = homed_position(&p).unwrap();
        let plan = plan(&p, &steps, start, Lookahead::Whole).unwrap();
        // Layers of 9 blocks each (travel, drop, settle, 4 draws, lift, settle): black, red, red (same pen), black.
        let blocks: Vec<usize> = plan.pen_changes.iter().map(|c| c.block).collect();
        assert_eq!(blocks, [9, 27]);
        assert!(plan.pen_changes.iter().all(|c| plan.blocks[c.block].kind == MoveKind::Travel));
        assert_eq!(plan.pen_changes[0].pen.name, "red");
        assert_eq!(plan.pen_changes[1].previous.name, "red");
        assert_eq!(plan.pen_changes[1].layer_name, "k");
        assert_eq!(plan.first_pen.name, "black");
        // The red pen drops to 1 mm (400 steps/mm: 1200 steps below the 4 mm pen-up) and draws at 30 mm/s: a 5 mm
        // side takes longer than the black pen's at 60 mm/s.
        assert_eq!(plan.blocks[10].block.steps, [0, 0, -1200, 0]);
        assert_eq!(plan.blocks[1].block.steps, [0, 0, -1600, 0]);
        let side = |i: usize| plan.blocks[i].block.duration_ticks();
        assert!(side(12) > side(3), "{} vs {}", side(12), side(3));
        // A resumed plan keeps the original numbering of the pen changes.
        let r = plan_resume(&p, &steps, start, 12, start, false).unwrap();
        assert_eq!(r.pen_changes, plan.pen_changes);
    }

    #[test]
    fn profile_converts_to_a_valid_config() {
        let c = machine_config(&profile()).unwrap();
        assert_eq!(c, MachineConfig::xy_plotter());
        let printer = MachineProfile::from_toml(include_str!("../../../samples/printer.toml"), "printer.toml").unwrap();
        let c = machine_config(&printer).unwrap();
        assert!(c.axis(Axis::E).enabled);
    }
}
