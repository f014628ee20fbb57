//! The host motion plan: a [`StepDrawing`] becomes the exact sequence of step blocks the firmware will run.
//!
//! Sequence per stroke: the pen-up hop to the stroke start, the pen drop and its settle dwell, the pen-down moves
//! at the drawing feed. The hop overlaps the pen's motion with the travel (issue 25): with a Z pen it is a Z-only
//! rise from the paper to the clearance height (`pen.clearance_mm`), XY+Z travel blocks along which the pen goes
//! on up towards the pen-up height and comes back down to the clearance height ([`crate::motion::hop`]), and the
//! Z-only drop from there to the paper. Nothing waits for the pen to stop rising, so the lift has no settle. Before
//! a pen change, and after the last stroke, the pen goes fully up and settles, and the travel to the first stroke of
//! a new pen is flat at the pen-up height (where the job parks).
//!
//! A servo pen (`pen.command = "servo"`) moves no axis: each drop and lift is one servo block ([`StepBlock::servo`]:
//! the angle, then a dwell) and Z never steps. Its overlap is timing, from the servo's rate and travel
//! ([`crate::motion::servo`]): the travel starts once the lifting servo has passed the point where the tip meets
//! the paper (`pen.contact_fraction` of its travel), and the drop is commanded during the travel, the servo turning
//! back wherever the lift has taken it, so that the carriage has arrived at the stroke's start by the earliest time
//! the tip may touch; a dwell holds it there until the latest, and the line starts. How the drop meets the travel
//! depends on the firmware ([`MachineProfile::servo_sync`], see [`ServoSync`]):
//!
//! * where the servo command is a queue entry between two moves that does not stop the motors (our firmware's
//!   servo step block, the EBB's `SP`), the travel does not stop for the command: it is planned whole from rest to
//!   rest and cut where the rest of it arrives by the earliest contact, and the carriage passes the command (a
//!   1-tick servo block) at the speed it has there (`RawPlan::flying_servo_hop`);
//! * where the motion stops for it (GRBL's `M3`), the drop command splits the travel: the travel stops, the servo
//!   is commanded, the last part follows from rest; the split is only made where it pays. GRBL dwells in whole
//!   steps of 50 ms, so every dwell of a plan for it (the lift's wait, the landing's, the settle) is timed so
//!   ([`grbl_dwell_ticks`]), and the drop's timing follows from those.
//!
//! Every move becomes a [`PlanBlock`] of the firmware's own planner
//! ([`plotter_fw::planner`]: per-axis limits, junction deviation, reverse/forward passes), planned here over the
//! **whole drawing** at once — the host has unlimited look-ahead, the firmware only its queue. Dwells are fixed
//! blocks and therefore stop points, so the pen never moves sideways while it is settling. The raw blocks are kept
//! compact until they are planned (`RawBlock`, 32 bytes) and the whole-drawing plan is computed a window at a time
//! (`plan_whole`: the same plan to the bit, but a drawing at the pipeline's point limit no longer holds 104-byte
//! planner blocks for all of it), so the plan's peak memory is about its own blocks plus the compact raw ones.
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
use crate::config::pens::{self, LayerPen};
use crate::config::profile::{AxisProfile, HomeEnd};
use crate::geometry::parallel::for_each_mut;
use crate::geometry::steps::{PenHeightsError, StepDrawing, StepMapper, StepPos};
use crate::motion::hop::{self, HopHeights};
use crate::motion::servo::{self, ServoSync, ServoTiming};

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
    #[error("{}", PenHeightsError)]
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
            pen_clear_at_z_switch: profile.homing.pen_clear_at_z_switch,
        },
        pen: PenConfig {
            up_z_mm: f(profile.pen.up_z_mm),
            down_z_mm: f(profile.pen.down_z_mm),
            servo_up_deg: f(profile.pen.servo_up_deg),
            servo_down_deg: f(profile.pen.servo_down_deg),
            // The profile's servo turns its up-to-down swing in `settle_ms` (motion::servo's model).
            servo_swing_ms: f(profile.pen.settle_ms),
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
    /// How long the firmware takes to run `block` (ticks): its [`StepBlock::duration_ticks`], taken once when the
    /// plan is made, since the stepper's timing is not free to compute.
    pub ticks: u32,
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

    /// The first servo block the carriage runs into moving (the block before it ends above rest): a drop
    /// commanded on the way, which only a firmware that runs the servo between moves can execute as planned
    /// ([`ServoSync::InMotion`]). `None` when every servo block comes with the carriage at rest.
    pub fn servo_in_motion(&self) -> Option<usize> {
        self.blocks.windows(2).position(|w| w[1].block.servo.is_some() && w[0].block.exit_rate > 0).map(|i| i + 1)
    }

    /// Exact execution time of the blocks from `from` on (ticks).
    pub fn ticks_from(&self, from: usize) -> u64 {
        self.blocks.iter().skip(from).map(|b| u64::from(b.ticks)).sum()
    }

    /// Where the time goes: drawing, travel, and lifts with their settles (see [`PlanBreakdown`]).
    pub fn breakdown(&self) -> PlanBreakdown {
        let mut b = PlanBreakdown::default();
        for p in &self.blocks {
            let t = u64::from(p.ticks);
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
    StepMapper::new(profile).pen_z_steps(down_mm).map_err(|PenHeightsError| PlanError::PenHeights)
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
            let r =
                |v: f64| crate::geometry::steps::round_steps(v).ok_or(PlanError::Config("park: out of range".into()));
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
    let mut raw = RawPlan::new(profile, &cfg, from, 0);
    // A servo's angle is not part of the position: lift it to be sure.
    if !raw.at(up) {
        raw.pen(up, MoveKind::PenUp, 0);
    }
    raw.line_to(to, travel, MoveKind::Travel, 0);
    let first = pens::resolve(profile, "", &crate::Pen::default());
    Ok(finish(profile, &cfg, &raw.raw, from, Lookahead::Whole, (0, 0), first, Vec::new()))
}

/// The position after homing: X and Y at their switch end, Z at the pen-up height.
pub fn homed_position(profile: &MachineProfile) -> Result<MachinePos, PlanError> {
    StepMapper::new(profile).homed().map_err(|PenHeightsError| PlanError::PenHeights)
}

/// Where the pen is after homing, in page millimetres (where a plot's first travel starts).
pub fn home_on_page(profile: &MachineProfile) -> Result<kurbo::Point, PlanError> {
    let h = homed_position(profile)?;
    Ok(StepMapper::new(profile).steps_to_page(StepPos::new(h[0], h[1])))
}

/// Check that every stroke point is inside the work area (0..=travel on X and Y, in steps).
pub fn check_work_area(profile: &MachineProfile, steps: &StepDrawing) -> Result<(), PlanError> {
    let mapper = StepMapper::new(profile);
    let lim = |a: &AxisProfile| crate::geometry::steps::round_steps(a.travel_mm * a.steps_per_mm).unwrap_or(i32::MAX);
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

/// GRBL 1.1 dwells (`G4 P<seconds>`) in whole steps of 50 ms: its `delay_sec` (nuts_bolts.c) waits ⌈20·P⌉
/// steps of `DWELL_TIME_STEP` (config.h), so `G4 P0.045` takes 50 ms. A plan for GRBL ([`ServoSync::AtRest`])
/// times each dwell as [`grbl_dwell_ticks`] does.
pub const GRBL_DWELL_STEP_TICKS: u32 = TICK_HZ / 20;

/// What GRBL dwells for a dwell of `ticks` as the GRBL program writes it (in whole milliseconds, so that what is
/// under half a millisecond is `P0`, no dwell): the whole [`GRBL_DWELL_STEP_TICKS`] steps that cover it.
pub fn grbl_dwell_ticks(ticks: u32) -> u32 {
    if ticks < TICK_HZ / 2000 { 0 } else { ticks.div_ceil(GRBL_DWELL_STEP_TICKS).saturating_mul(GRBL_DWELL_STEP_TICKS) }
}

/// Settle dwell in ticks.
pub(crate) fn settle_ticks(profile: &MachineProfile) -> u32 {
    ms_ticks(profile.pen.settle_ms)
}

/// Ticks a servo lift waits before the travel, for a pen whose servo moves as `timing` says: the profile's
/// `pen.clear_ms` when it sets one ([`servo_clear_ticks`]), else until the tip is clear at the servo's rate
/// ([`ServoTiming::clear_ticks`]); the profile's lift delay included either way.
pub(crate) fn lift_clear_ticks(profile: &MachineProfile, timing: ServoTiming) -> u64 {
    profile.pen.clear_ms.map_or(timing.clear_ticks(), |_| u64::from(servo_clear_ticks(profile)))
}

/// A servo pen's clear time ([`crate::config::profile::PenProfile::servo_clear_ms`]) in ticks, at most the settle,
/// and the profile's extra wait after it (`pen.lift_delay_ms`).
pub(crate) fn servo_clear_ticks(profile: &MachineProfile) -> u32 {
    ms_ticks(profile.pen.servo_clear_ms())
        .min(settle_ticks(profile))
        .saturating_add(ms_ticks(profile.pen.lift_delay_ms))
}

/// Milliseconds as a dwell in ticks.
fn ms_ticks(ms: f64) -> u32 {
    let t = (ms * 1000.0).round();
    // Clamped into the u32 range first.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let ticks = t.clamp(0.0, f64::from(protocol::DWELL_MAX)) as u32;
    ticks
}

/// What a raw block is: a move at a feed (its [`PlanBlock`] is made again from the steps when it is planned), or
/// a fixed block (an index into [`RawBlocks::fixed`]).
#[derive(Debug, Clone, Copy, PartialEq)]
enum RawWhat {
    /// A straight move at this feed, mm/s.
    Line(f32),
    /// A fixed step block: index into [`RawBlocks::fixed`].
    Fixed(u32),
}

/// One raw (unplanned) block, compact: 32 bytes where its [`PlanBlock`] with the kind and stroke took 120. At the
/// pipeline's point limit (4 Mi points, one block each) the raw plan is 128 MB instead of 480 MB; the planning
/// data ([`PlanBlock::line`]: unit vector, length, limits) is made again from the steps and the feed when the
/// block is planned ([`RawBlocks::plan_block`]), which is the same pure function of the same inputs, so the plan
/// is the same to the bit.
#[derive(Debug, Clone, Copy, PartialEq)]
struct RawBlock {
    steps: MachinePos,
    what: RawWhat,
    kind: MoveKind,
    /// The stroke; a `u32` as the pipeline's point limit (4,194,304) keeps stroke numbers far below `u32::MAX`.
    stroke: u32,
}

/// A raw block sequence ([`RawBlock`]s and the fixed blocks they refer to).
#[derive(Debug, Clone, Default)]
struct RawBlocks {
    blocks: Vec<RawBlock>,
    fixed: Vec<StepBlock>,
}

impl RawBlocks {
    fn len(&self) -> usize {
        self.blocks.len()
    }

    fn kind(&self, i: usize) -> Option<MoveKind> {
        self.blocks.get(i).map(|b| b.kind)
    }

    fn push_fixed(&mut self, block: StepBlock, kind: MoveKind, stroke: usize) {
        let index = u32::try_from(self.fixed.len()).unwrap_or(u32::MAX);
        self.fixed.push(block);
        self.blocks.push(RawBlock {
            steps: block.steps,
            what: RawWhat::Fixed(index),
            kind,
            stroke: stroke_u32(stroke),
        });
    }

    /// Append `other`'s blocks from `from` on.
    fn extend_from(&mut self, other: &RawBlocks, from: usize) {
        for b in &other.blocks[from.min(other.len())..] {
            match b.what {
                RawWhat::Line(_) => self.blocks.push(*b),
                RawWhat::Fixed(k) => self.push_fixed(other.fixed[k as usize], b.kind, b.stroke as usize),
            }
        }
    }

    /// The planner block of block `i`, unlinked (as [`RawPlan::push`] or [`RawPlan::fixed`] made it).
    fn plan_block(&self, i: usize, cfg: &MachineConfig, caps: [f32; 2]) -> PlanBlock {
        let b = &self.blocks[i];
        match b.what {
            RawWhat::Fixed(k) => PlanBlock::fixed(self.fixed[k as usize]),
            // A stored line moves (`push` keeps only those), so `line` gives a block; rest for safety.
            RawWhat::Line(feed) => {
                line_block(cfg, caps, b.steps, feed, b.kind).unwrap_or_else(|| PlanBlock::fixed(StepBlock::dwell(0)))
            }
        }
    }

    /// Blocks `range` as planner blocks, linked ([`planner::link_all`]) exactly as over the whole sequence: the
    /// limits of a block depend on the [`planner::CURVE_SPAN_BLOCKS`] blocks on either side of the vertices at its
    /// ends (and on where the sequence starts and ends), so the range is linked with [`LINK_MARGIN`] blocks of
    /// context on each side and only the range is kept. `scratch` is reused between calls.
    fn linked(
        &self,
        range: std::ops::Range<usize>,
        cfg: &MachineConfig,
        caps: [f32; 2],
        scratch: &mut Vec<PlanBlock>,
        out: &mut Vec<PlanBlock>,
    ) {
        let lo = range.start.saturating_sub(LINK_MARGIN);
        let hi = (range.end + LINK_MARGIN).min(self.len());
        scratch.clear();
        scratch.extend((lo..hi).map(|i| self.plan_block(i, cfg, caps)));
        planner::link_all(scratch, cfg);
        out.extend_from_slice(&scratch[range.start - lo..range.end - lo]);
    }
}

/// Blocks of context on each side of a range linked on its own ([`RawBlocks::linked`]): a block's limits read the
/// junctions at its start, at its end and at the previous block's start, each of which reads up to
/// [`planner::CURVE_SPAN_BLOCKS`] blocks on either side (so 17 would do).
const LINK_MARGIN: usize = planner::CURVE_SPAN_BLOCKS + 8;

/// A stroke number as stored in a [`RawBlock`].
fn stroke_u32(stroke: usize) -> u32 {
    u32::try_from(stroke).unwrap_or(u32::MAX)
}

/// The block of an XY(Z) move of `kind`: the axes' limits, and the profile's acceleration cap (`caps`: drawing,
/// travel) for drawing or travel.
fn line_block(cfg: &MachineConfig, caps: [f32; 2], delta: MachinePos, feed: f32, kind: MoveKind) -> Option<PlanBlock> {
    let mut b = PlanBlock::line(cfg, delta, feed)?;
    let cap = match kind {
        MoveKind::Draw => caps[0],
        MoveKind::Travel => caps[1],
        _ => f32::MAX,
    };
    b.acceleration = b.acceleration.min(cap);
    Some(b)
}

/// The raw (unplanned) block sequence with each block's kind and stroke, built move by move.
struct RawPlan<'c> {
    cfg: &'c MachineConfig,
    raw: RawBlocks,
    pos: MachinePos,
    settle: u32,
    changes: Vec<PenChange>,
    /// The profile's path acceleration caps (drawing, travel), mm/s²; `f32::MAX` where it sets none.
    accel_caps: [f32; 2],
    /// A servo drop may be commanded while the carriage moves (see [`RawPlan::servo_hop`]): the firmware does not
    /// stop for it ([`ServoSync::InMotion`]).
    flying_drop: bool,
}

impl<'c> RawPlan<'c> {
    /// An empty plan at `pos`.
    fn new(profile: &MachineProfile, cfg: &'c MachineConfig, pos: MachinePos, capacity: usize) -> RawPlan<'c> {
        // Accelerations are physical values, far inside f32.
        #[allow(clippy::cast_possible_truncation)]
        let cap = |a: Option<f64>| a.map_or(f32::MAX, |a| a as f32);
        RawPlan {
            cfg,
            raw: RawBlocks { blocks: Vec::with_capacity(capacity), fixed: Vec::new() },
            pos,
            // GRBL dwells in steps of 50 ms.
            settle: if profile.servo_sync == ServoSync::AtRest {
                grbl_dwell_ticks(settle_ticks(profile))
            } else {
                settle_ticks(profile)
            },
            changes: Vec::new(),
            accel_caps: [cap(profile.pen.draw_accel_mm_s2), cap(profile.pen.travel_accel_mm_s2)],
            flying_drop: profile.servo_sync == ServoSync::InMotion,
        }
    }

    /// The block of an XY(Z) move of `kind`: the axes' limits, and the profile's acceleration cap for drawing or
    /// travel.
    fn line_block(&self, delta: MachinePos, feed: f32, kind: MoveKind) -> Option<PlanBlock> {
        line_block(self.cfg, self.accel_caps, delta, feed, kind)
    }

    fn push(&mut self, delta: MachinePos, feed: f32, kind: MoveKind, stroke: usize) -> bool {
        // Only whether it moves: the planner block is made again when the plan is made (`RawBlocks::plan_block`).
        // (`PlanBlock::line` makes a block exactly when some axis moves.)
        if delta.iter().all(|&d| d == 0) {
            return false;
        }
        let stroke = stroke_u32(stroke);
        self.raw.blocks.push(RawBlock { steps: delta, what: RawWhat::Line(feed), kind, stroke });
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
                    self.raw.push_fixed(StepBlock::dwell(self.settle), MoveKind::Settle, stroke);
                }
            }
            PenAt::Servo(tenths) => self.raw.push_fixed(StepBlock::servo(tenths, self.settle), kind, stroke),
        }
    }

    /// Whether the pen is known to be at `to` (a Z height reached; never for a servo, whose angle is not tracked).
    fn at(&self, to: PenAt) -> bool {
        to == PenAt::Z(self.pos[2])
    }

    fn line_to(&mut self, to: StepPos, feed: f32, kind: MoveKind, stroke: usize) {
        self.push([to.x - self.pos[0], to.y - self.pos[1], 0, 0], feed, kind, stroke);
    }

    /// Exact duration (ticks, quantized as on the wire) of an XY move by `delta` at `feed` from rest to rest: what
    /// a move between two fixed blocks takes. 0 when nothing moves.
    fn rest_to_rest_ticks(&self, delta: StepPos, feed: f32) -> u32 {
        self.rest_to_rest_block(delta, feed).map_or(0, |b| b.duration_ticks())
    }

    /// The step block of an XY travel by `delta` at `feed` from rest to rest, quantized as on the wire; `None`
    /// when nothing moves.
    fn rest_to_rest_block(&self, delta: StepPos, feed: f32) -> Option<StepBlock> {
        let b = self.line_block([delta.x, delta.y, 0, 0], feed, MoveKind::Travel)?;
        Some(protocol::quantize(&planner::to_step_block(&b, 0.0)))
    }

    fn fixed(&mut self, block: StepBlock, kind: MoveKind, stroke: usize) {
        self.raw.push_fixed(block, kind, stroke);
    }

    /// A servo pen's hop to `to` (see the module docs): the lift (when `lift` gives its angle) waits until the tip
    /// is clear (`servo.clear` ticks), the travel follows, and the drop is commanded so that the carriage has
    /// arrived by the earliest time the tip may touch ([`ServoTiming::contact_window`], the servo reversing
    /// where the lift has taken it; `servo.pressed` is how far down it surely was when lifted); a dwell holds it
    /// there until the latest, when the line starts. On a board that stops for a servo command the drop splits
    /// the travel into two parts from rest to rest, made only where it pays.
    fn servo_hop(&mut self, lift: Option<u16>, down: u16, to: StepPos, feed: f32, stroke: usize, servo: ServoHop) {
        let from = StepPos::new(self.pos[0], self.pos[1]);
        let delta = from.delta_to(to);
        let clear = if lift.is_some() { servo.clear.max(1) } else { 0 };
        let window = |d: u64| servo.timing.contact_window(lift.map(|_| (d, servo.pressed)));
        let whole = self.rest_to_rest_block(StepPos::new(delta.dx, delta.dy), feed);
        if self.flying_drop {
            self.flying_servo_hop(lift, down, whole, stroke, (clear, &window));
            return;
        }
        let at = |k: i64, n: i64| {
            // The point k/n of the way back from `to` towards `from` (`to` itself for a hop of no length).
            let back = |d: i32| i32::try_from((i64::from(d) * k).checked_div(n).unwrap_or(0)).unwrap_or(0);
            StepPos::new(to.x - back(delta.dx), to.y - back(delta.dy))
        };
        let n = i64::from(delta.dx.unsigned_abs().max(delta.dy.unsigned_abs()));
        let ticks =
            |a: StepPos, b: StepPos| u64::from(self.rest_to_rest_ticks(StepPos::new(b.x - a.x, b.y - a.y), feed));
        // GRBL's dwells, the lift's wait among them, come in whole steps of 50 ms ([`grbl_dwell_ticks`]).
        let dwell = |t: u64| u64::from(grbl_dwell_ticks(ticks_u32(t)));
        let clear = if lift.is_some() { dwell(u64::from(clear)).max(1) } else { 0 };
        let drop_at = |k: i64| clear + ticks(from, at(k, n));
        // The longest last part that arrives by the earliest contact (durations grow with the length).
        let fits = |k: i64| ticks(at(k, n), to) + u64::from(DROP_TICK) <= window(drop_at(k)).0;
        let (mut lo, mut hi) = (0i64, n);
        while lo < hi {
            let mid = (lo + hi + 1) / 2;
            if fits(mid) { lo = mid } else { hi = mid - 1 }
        }
        // The wait from the drop to the line: the drop's dwell up to the latest contact in place, or the last part
        // and a dwell for what is left of it.
        let after_drop = |k: i64| {
            let latest = window(drop_at(k)).1;
            if k == 0 {
                return dwell(latest);
            }
            let t2 = ticks(at(k, n), to) + u64::from(DROP_TICK);
            t2 + dwell(latest.saturating_sub(t2))
        };
        // The split pays when the line starts sooner than after the whole travel and a drop in place.
        let start = |k: i64| drop_at(k) + after_drop(k);
        let k = if lo > 0 && start(lo) < start(0) { lo } else { 0 };
        let split = at(k, n);
        let d = drop_at(k);
        let (_, latest) = window(d);
        let t2 = ticks(split, to);
        if let Some(u) = lift {
            self.fixed(StepBlock::servo(u, ticks_u32(clear)), MoveKind::PenUp, stroke - 1);
        }
        self.line_to(split, feed, MoveKind::Travel, stroke);
        if split == to {
            self.fixed(StepBlock::servo(down, ticks_u32(dwell(latest))), MoveKind::PenDown, stroke);
            return;
        }
        self.fixed(StepBlock::servo(down, DROP_TICK), MoveKind::PenDown, stroke);
        self.line_to(to, feed, MoveKind::Travel, stroke);
        // Always a dwell, a stop (GRBL's `G4` waits for the planner to empty, even `P0`): the line starts from rest,
        // not joined to the travel.
        let rest = dwell(latest.saturating_sub(u64::from(DROP_TICK) + t2)).max(1);
        self.fixed(StepBlock::dwell(ticks_u32(rest)), MoveKind::Settle, stroke);
    }

    /// [`RawPlan::servo_hop`] on a board that runs the servo command between two queued moves without stopping the
    /// motors (the EBB: its `SP` is a FIFO entry like a move): the travel is planned in one piece from rest to rest
    /// and cut at the first point from which the rest of it arrives by the earliest contact ([`split_block`]), the
    /// drop command (a 1-tick servo block) sits at the cut and the carriage passes it at the speed it has there,
    /// so the hop loses no time to stopping for the command. The parts are fixed blocks (the planner would plan
    /// the whole travel from rest to rest anyway, between the two servo blocks). `whole` is that travel
    /// ([`RawPlan::rest_to_rest_block`]), `timing` is the lift's clear time and the contact window of a drop
    /// commanded a number of ticks after the lift command.
    fn flying_servo_hop(
        &mut self,
        lift: Option<u16>,
        down: u16,
        whole: Option<StepBlock>,
        stroke: usize,
        (clear, window): (u32, &dyn Fn(u64) -> (u64, u64)),
    ) {
        let parts = |e: u32| match whole {
            None => (None, None),
            Some(b) if e == 0 => (None, Some(b)),
            Some(b) if e >= b.events() => (Some(b), None),
            Some(b) => {
                let (x, y) = split_block(&b, e);
                (Some(x), Some(y))
            }
        };
        let dur = |b: Option<StepBlock>| u64::from(b.map_or(0, |b| b.duration_ticks()));
        let fits = |e: u32| {
            let (first, last) = parts(e);
            last.is_none() || dur(last) + u64::from(DROP_TICK) <= window(u64::from(clear) + dur(first)).0
        };
        // The first cut whose rest arrives in time (a later cut leaves less to travel and starts the drop later).
        let n = whole.map_or(0, |b| b.events());
        let (mut lo, mut hi) = (0u32, n);
        while lo < hi {
            let mid = lo + (hi - lo) / 2;
            if fits(mid) { hi = mid } else { lo = mid + 1 }
        }
        let (first, last) = parts(lo);
        let (_, latest) = window(u64::from(clear) + dur(first));
        if let Some(u) = lift {
            self.fixed(StepBlock::servo(u, clear), MoveKind::PenUp, stroke - 1);
        }
        if let Some(b) = first {
            self.fixed_travel(b, stroke);
        }
        let Some(b) = last else {
            self.fixed(StepBlock::servo(down, ticks_u32(latest)), MoveKind::PenDown, stroke);
            return;
        };
        self.fixed(StepBlock::servo(down, DROP_TICK), MoveKind::PenDown, stroke);
        self.fixed_travel(b, stroke);
        let rest = latest.saturating_sub(u64::from(DROP_TICK) + dur(Some(b)));
        if rest > 0 {
            self.fixed(StepBlock::dwell(ticks_u32(rest)), MoveKind::Settle, stroke);
        }
    }

    /// A fixed travel block, the position moved on by its XY steps.
    fn fixed_travel(&mut self, b: StepBlock, stroke: usize) {
        self.fixed(b, MoveKind::Travel, stroke);
        self.pos[0] += b.steps[0];
        self.pos[1] += b.steps[1];
    }
}

/// The servo's drop command is a 1-tick block: the part of the travel after it follows at once.
const DROP_TICK: u32 = 1;

/// A servo pen's hop timing: the pen's servo, how far down it surely was when lifted (a fraction of its travel),
/// and the lift's clear time (ticks).
#[derive(Debug, Clone, Copy)]
struct ServoHop {
    timing: ServoTiming,
    pressed: f64,
    clear: u32,
}

/// Ticks as a block's dwell (at most the wire's longest).
fn ticks_u32(t: u64) -> u32 {
    u32::try_from(t).unwrap_or(u32::MAX).min(protocol::DWELL_MAX)
}

/// `block` cut after its first `e` step events (0 < `e` < its events) into two blocks that run one after the
/// other as the whole does: each axis's steps split in proportion, rounded once (so the parts add up exactly and
/// keep within half a step of the line), the first part ending and the second starting at the trapezoid's rate
/// at the cut (rounded down as a wire frame carries it, [`protocol::quantize`]).
fn split_block(block: &StepBlock, e: u32) -> (StepBlock, StepBlock) {
    let n = i64::from(block.events().max(1));
    let first: [i32; NUM_AXES] = core::array::from_fn(|i| {
        let s = i64::from(block.steps[i]) * i64::from(e);
        // |s / n| ≤ |steps[i]|, inside i32; rounded half away from zero.
        i32::try_from((s + s.signum() * n / 2) / n).unwrap_or(block.steps[i])
    });
    let second: [i32; NUM_AXES] = core::array::from_fn(|i| block.steps[i] - first[i]);
    // A rate in events/s, non-negative and far below u32::MAX.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let at = block.profile().rate_at(e).max(0.0) as u32;
    let a = StepBlock { steps: first, exit_rate: at, ..*block };
    let b = StepBlock { steps: second, entry_rate: at, ..*block };
    (protocol::quantize(&a), protocol::quantize(&b))
}

/// A rest-to-rest travel `block` cut so that its last part is the longest that takes at most `budget` ticks: the
/// first part (`None` when the whole travel fits) and the last (`None` when not even one event fits).
#[cfg(test)]
fn split_for_budget(block: &StepBlock, budget: u32) -> (Option<StepBlock>, Option<StepBlock>) {
    let n = block.events();
    if n == 0 {
        return (None, None);
    }
    if block.duration_ticks() <= budget {
        return (None, Some(*block));
    }
    // The smallest cut whose rest fits: the rest's duration falls as the cut moves on.
    let fits = |e: u32| split_block(block, e).1.duration_ticks() <= budget;
    let (mut lo, mut hi) = (1u32, n);
    while lo < hi {
        let mid = lo + (hi - lo) / 2;
        if fits(mid) { hi = mid } else { lo = mid + 1 }
    }
    if lo >= n || !fits(lo) {
        return (Some(*block), None);
    }
    let (a, b) = split_block(block, lo);
    (Some(a), Some(b))
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
    let capacity = steps.move_count() + 8 * steps.strokes.len() + 2;
    let mut raw = RawPlan::new(profile, cfg, start, capacity);
    raw.pen(up, MoveKind::PenUp, 0);
    let mut layer = 0;
    for (si, stroke) in steps.strokes.iter().enumerate() {
        let l = steps.layer_of(si);
        let change = l != layer && !pens[l].same_pen(&pens[layer]);
        // Leave the previous stroke: fully up before a pen change, else only as far as the hop needs.
        if si > 0 {
            if change {
                raw.pen(up, MoveKind::PenUp, si - 1);
            } else if let (PenAt::Z(u), PenAt::Z(d)) = (up, downs[layer]) {
                let clear = HopHeights::new(profile, d, u).clear;
                raw.push([0, 0, clear - raw.pos[2], 0], raw.cfg.axis(Axis::Z).max_feed_mm_s, MoveKind::PenUp, si - 1);
            }
        }
        if change {
            raw.changes.push(PenChange {
                block: raw.raw.len(),
                layer: l,
                layer_name: steps.layers.get(l).map(|x| x.name.clone()).unwrap_or_default(),
                pen: pens[l].clone(),
                previous: pens[layer].clone(),
            });
        }
        layer = l;
        let (down, draw) = (downs[l], f32_of(pens[l].draw_feed_mm_s));
        match (up, down) {
            // After a pen change the pen is fully up: the old sequence, a flat travel the job can park.
            _ if change => {
                raw.line_to(stroke.start, travel, MoveKind::Travel, si);
                raw.pen(down, MoveKind::PenDown, si);
            }
            (PenAt::Z(u), PenAt::Z(d)) => {
                let h = HopHeights::new(profile, d, u);
                let from = [raw.pos[0], raw.pos[1], raw.pos[2]];
                for w in hop::travel_waypoints(profile, from, stroke.start, h) {
                    raw.push(
                        [w[0] - raw.pos[0], w[1] - raw.pos[1], w[2] - raw.pos[2], 0],
                        travel,
                        MoveKind::Travel,
                        si,
                    );
                }
                raw.pen(down, MoveKind::PenDown, si);
            }
            (PenAt::Servo(u), PenAt::Servo(d)) => {
                let lift = (si > 0).then_some(u);
                let timing = ServoTiming::of(profile, pens[l].servo_down_deg);
                // The stroke before was drawn from its latest contact on, for at least its length at its feed.
                let drawn = si.checked_sub(1).map_or(0, |p| {
                    servo::min_draw_ticks(profile, &steps.strokes[p], pens[steps.layer_of(p)].draw_feed_mm_s)
                });
                let clear = lift_clear_ticks(profile, timing);
                let hop = ServoHop { timing, pressed: timing.pressed_after(drawn), clear: ticks_u32(clear) };
                raw.servo_hop(lift, d, stroke.start, travel, si, hop);
            }
            _ => unreachable!("pen_targets gives one kind of pen"),
        }
        let mut at = stroke.start;
        for d in &stroke.moves {
            at = at.offset(*d);
            raw.line_to(at, draw, MoveKind::Draw, si);
        }
    }
    if let Some(last) = steps.strokes.len().checked_sub(1) {
        raw.pen(up, MoveKind::PenUp, last);
    }
    if return_home {
        let last = steps.strokes.len().saturating_sub(1);
        raw.line_to(StepPos::new(start[0], start[1]), travel, MoveKind::Travel, last);
    }
    Ok(raw)
}

/// Planner blocks, each with its kind and stroke.
pub(crate) type KindedBlocks = Vec<(PlanBlock, MoveKind, usize)>;

/// The planner blocks of the whole-drawing plan of `steps` from `start` before they become step blocks: each
/// linked ([`planner::link_all`], its junction and curve limits set) and speed-planned ([`planner::plan`], from
/// rest), with its kind and stroke; and the machine configuration they were planned with. The same blocks
/// [`plan_returning`] turns into its step blocks, kept whole (a plan's diagnostics read their limits, see
/// [`crate::motion::gap`]).
pub(crate) fn planner_blocks(
    profile: &MachineProfile,
    steps: &StepDrawing,
    start: MachinePos,
    return_home: bool,
) -> Result<(MachineConfig, KindedBlocks), PlanError> {
    let cfg = machine_config(profile)?;
    check_work_area(profile, steps)?;
    let raw = build_blocks(profile, &cfg, steps, start, return_home)?;
    // Accelerations are physical values, far inside f32.
    #[allow(clippy::cast_possible_truncation)]
    let cap = |a: Option<f64>| a.map_or(f32::MAX, |a| a as f32);
    let caps = [cap(profile.pen.draw_accel_mm_s2), cap(profile.pen.travel_accel_mm_s2)];
    let mut all = Vec::with_capacity(raw.raw.len());
    raw.raw.linked(0..raw.raw.len(), &cfg, caps, &mut Vec::new(), &mut all);
    planner::plan(&mut all, 0.0);
    let out = all.into_iter().zip(&raw.raw.blocks).map(|(b, r)| (b, r.kind, r.stroke as usize)).collect();
    Ok((cfg, out))
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
    let mut raw = build_blocks(profile, &cfg, steps, start, return_home)?;
    let first = layer_pens(profile, steps).swap_remove(0);
    let changes = std::mem::take(&mut raw.changes);
    Ok(finish(profile, &cfg, &raw.raw, start, lookahead, (0, 0), first, changes))
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
    let (raw, changes) = (&full.raw, full.changes.clone());
    let mut done = done.min(raw.len());
    // A servo pen's drop is commanded before the last part of its travel, which the carriage enters moving:
    // resuming on the drop command or on that part goes on from the stroke's start instead (the preamble travels
    // there with the pen up and lowers it in full), skipping the part and the rest of the settle.
    let kind = |i: usize| raw.kind(i);
    let is_pen = |b: &&RawBlock| matches!(b.kind, MoveKind::PenUp | MoveKind::PenDown);
    let last_pen = raw.blocks[..done].iter().rev().find(is_pen).map(|b| b.kind);
    let after_drop = last_pen == Some(MoveKind::PenDown) && kind(done) == Some(MoveKind::Travel);
    if after_drop || (kind(done) == Some(MoveKind::PenDown) && kind(done + 1) == Some(MoveKind::Travel)) {
        if kind(done) == Some(MoveKind::PenDown) {
            done += 1;
        }
        while matches!(kind(done), Some(MoveKind::Travel | MoveKind::Settle)) {
            done += 1;
        }
    }
    let mut target = original_start;
    for b in &raw.blocks[..done] {
        for (t, s) in target.iter_mut().zip(b.steps) {
            *t += s;
        }
    }
    let pens = layer_pens(profile, steps);
    let (up, downs) = pen_targets(profile, &pens)?;
    let stroke = raw.blocks.get(done).map_or(0, |b| b.stroke as usize);
    // The pen at block `done`: as the last pen block before it left it.
    let pen_down = raw.blocks[..done].iter().rev().find(is_pen).map(|b| (b.kind, b.stroke as usize));
    let resume_pen = match (up, pen_down) {
        (PenAt::Z(_), _) => PenAt::Z(target[2]),
        (PenAt::Servo(_), Some((MoveKind::PenDown, s))) => downs[steps.layer_of(s)],
        (PenAt::Servo(_), _) => up,
    };
    #[allow(clippy::cast_possible_truncation)]
    let travel = profile.pen.travel_feed_mm_s as f32;
    let mut pre = RawPlan::new(profile, &cfg, now, 0);
    if !pre.at(up) {
        pre.pen(up, MoveKind::PenUp, stroke);
    }
    pre.line_to(StepPos::new(target[0], target[1]), travel, MoveKind::Travel, stroke);
    if resume_pen != up {
        pre.pen(resume_pen, MoveKind::PenDown, stroke);
    }
    let preamble = pre.raw.len();
    let mut blocks = pre.raw;
    blocks.blocks.reserve_exact(raw.len() - done);
    blocks.extend_from(raw, done);
    drop(full);
    let first = layer_pens(profile, steps).swap_remove(0);
    Ok(finish(profile, &cfg, &blocks, now, Lookahead::Whole, (done, preamble), first, changes))
}

/// Link, plan, quantize and time a raw block sequence.
///
/// Memory: the whole-drawing plan never holds the planner blocks of the whole drawing (104 bytes each; at the
/// pipeline's point limit 420 MB, and the step blocks and timed blocks made from them were 340 MB more). It plans
/// a window of blocks at a time ([`plan_whole`]) straight into the plan's own [`PlannedBlock`]s, which are then
/// quantized and timed in place on all cores. The result is the plan the planner makes over the whole drawing at
/// once, to the bit.
#[allow(clippy::too_many_arguments)]
fn finish(
    profile: &MachineProfile,
    cfg: &MachineConfig,
    raw: &RawBlocks,
    start: MachinePos,
    lookahead: Lookahead,
    (resumed_from, preamble): (usize, usize),
    first_pen: LayerPen,
    pen_changes: Vec<PenChange>,
) -> MotionPlan {
    // Accelerations are physical values, far inside f32.
    #[allow(clippy::cast_possible_truncation)]
    let cap = |a: Option<f64>| a.map_or(f32::MAX, |a| a as f32);
    let caps = [cap(profile.pen.draw_accel_mm_s2), cap(profile.pen.travel_accel_mm_s2)];
    let mut blocks = Vec::with_capacity(raw.len());
    let planned = |i: usize, block: StepBlock| {
        let r = &raw.blocks[i];
        PlannedBlock { block, kind: r.kind, stroke: r.stroke as usize, ticks: 0 }
    };
    match lookahead {
        Lookahead::Whole => plan_whole(raw, cfg, caps, WHOLE_WINDOW, |i, b| blocks.push(planned(i, b))),
        Lookahead::Window(w) => {
            let mut all = Vec::with_capacity(raw.len());
            raw.linked(0..raw.len(), cfg, caps, &mut Vec::new(), &mut all);
            let step_blocks = windowed(&all, w.max(1));
            drop(all);
            blocks.extend(step_blocks.into_iter().enumerate().map(|(i, b)| planned(i, b)));
        }
    }
    // Each block is quantized and timed on its own, so the (costly) timing runs on all cores.
    for_each_mut(&mut blocks, |_, p| {
        p.block = protocol::quantize(&p.block);
        p.ticks = p.block.duration_ticks();
    });
    let mut total = 0u64;
    let mut end = start;
    let mapper = StepMapper::new(profile);
    let mut draw_mm = 0.0;
    let mut travel_mm = 0.0;
    for b in &blocks {
        total += u64::from(b.ticks);
        for (e, s) in end.iter_mut().zip(b.block.steps) {
            *e += s;
        }
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

/// Blocks [`plan_whole`] plans at a time, at first (a window grows when it has to).
const WHOLE_WINDOW: usize = 8192;

/// The whole-drawing plan of `raw` ([`planner::link_all`] and [`planner::plan`] over all of it, then
/// [`planner::step_blocks`]), computed a window at a time: `emit(i, block)` gets the step block of every block in
/// order.
///
/// Why a window gives the same plan. The planner's reverse pass lowers each entry speed² to
/// `min(max_entry, next_entry + 2·a·L)` from the last block back; the forward pass then lowers it to what the
/// previous block reaches. Planning a window `[s, e)` on its own ends it at rest, so its reverse-pass values are at
/// most the whole drawing's (f32 `+` and `min` are monotone). Where the window's final entry speed² of block `k`
/// equals its `max_entry_speed_sqr` (or `k` is a fixed block, a stop either way), its reverse-pass value was the
/// cap in the window, so it is the cap over the whole drawing too, and from `k` back the two reverse passes are
/// the same computation; the forward pass from `s` (entered at the exact speed carried over) is then the same up
/// to `k`. So the blocks before the last such `k` are final: they are emitted, and the next window starts at `k`,
/// entered at its planned speed. A window with no such block grows (doubles) until it has one or reaches the end
/// of the drawing, where the window's end at rest is the drawing's. The windows' planner blocks are linked with
/// enough context to be exactly [`planner::link_all`]'s ([`RawBlocks::linked`]).
fn plan_whole(
    raw: &RawBlocks,
    cfg: &MachineConfig,
    caps: [f32; 2],
    window: usize,
    mut emit: impl FnMut(usize, StepBlock),
) {
    let n = raw.len();
    let mut win: Vec<PlanBlock> = Vec::new();
    let mut scratch = Vec::new();
    // `win[0]` is block `s`; blocks `s..linked` are in `win`; `entry` is block `s`'s planned entry speed².
    let (mut s, mut linked, mut entry) = (0usize, 0usize, 0.0f32);
    let mut want = window.max(2);
    while s < n {
        let upto = (s + want).min(n);
        if upto > linked {
            raw.linked(linked..upto, cfg, caps, &mut scratch, &mut win);
            linked = upto;
        }
        planner::plan(&mut win, entry);
        let last = win.len();
        let k = if linked == n {
            last
        } else {
            match (1..last).rev().find(|&k| {
                let b = &win[k];
                b.fixed.is_some() || b.entry_speed_sqr == b.max_entry_speed_sqr
            }) {
                Some(k) => k,
                None => {
                    want = want.saturating_mul(2);
                    continue;
                }
            }
        };
        for i in 0..k {
            emit(s + i, planner::to_step_block(&win[i], planner::exit_speed_sqr(&win, i)));
        }
        entry = win.get(k).map_or(0.0, |b| b.entry_speed_sqr);
        win.drain(..k);
        s += k;
        want = window.max(2);
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
    use crate::geometry::steps::{StepDelta, StepStroke, drawing_to_steps};
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
        // The travel from home starts at the pen-up height and comes down on the way (14.14 mm at the hop slope,
        // 0.73 mm), staying above the 1 mm clearance; the drop is pure Z and the rest of the way to the paper.
        let (travel, drop) = (plan.blocks[0].block.steps, plan.blocks[1].block.steps);
        let descent = 200f64.sqrt() * crate::motion::hop::rise_slope(&p) * 400.0;
        assert_eq!(f64::from(travel[2]), -descent.round());
        assert_eq!([travel[0], travel[1], drop[0], drop[1]], [800, 800, 0, 0]);
        assert_eq!(travel[2] + drop[2], -1600);
        // The dwell lasts the settle time (50 ms = 50 000 ticks).
        assert_eq!(plan.blocks[2].block, StepBlock::dwell(50_000));
        // The last lift is pure Z, all the way up.
        assert_eq!(plan.blocks[7].block.steps, [0, 0, 1600, 0]);
        // Total time is the sum of the quantized blocks' durations.
        let sum: u64 = plan.blocks.iter().map(|b| u64::from(b.block.duration_ticks())).sum();
        assert_eq!(plan.total_ticks, sum);
        assert_eq!(plan.ticks_from(0), sum);
        // From the last lift on: the lift and its settle.
        let last_two = [7, 8].map(|i| u64::from(plan.blocks[i].block.duration_ticks()));
        assert_eq!(plan.ticks_from(7), last_two[0] + last_two[1]);
        assert!(plan.blocks.iter().all(|b| b.ticks == b.block.duration_ticks()));
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
        // Lifts: a full Z move of 4 mm at 25 mm/s, 500 mm/s² takes 4/25 + 25/500 = 0.21 s, the 1 mm clearance
        // (too short for 25 mm/s) 2·√(1/500) = 0.0894 s. The first drop comes from the travel's end 1599 steps up
        // (the first hop from the pen-up height came down 10 mm · 0.000 37 = 1 step): 3.9975/25 + 0.05 s; then the
        // rise off the paper to the clearance, the drop from it, the final lift; three 50 ms settles (after the
        // drops and the final lift, none after the rise to the clearance).
        let clear = 2.0 * (1.0f64 / 500.0).sqrt();
        let expect = (3.9975 / 25.0 + 0.05) + clear + clear + 0.21 + 3.0 * 0.05;
        assert!((b.lift_s() - expect).abs() < 1e-3, "{b:?} vs {expect}");
    }

    #[test]
    fn one_overlapped_hop_by_hand_against_the_sequential_one() {
        // Junction deviation ~0 (1 nm) makes every junction a stop (a 90° corner at √(500·10⁻⁹·2.414) =
        // 0.001 mm/s), so each block is a rest-to-rest trapezoid (and the hop slope, 0.8·tan(acos(F²/(F² + aδ)))
        // ≈ 0.000 012, leaves a 10 mm hop flat). Two lines along X with a 10 mm gap: the hop between them is the rise off the paper to the 1 mm
        // clearance (Z, 25 mm/s, 500 mm/s²: too short for 25 mm/s, a triangle 2·√(1/500) = 0.089 443 s), the
        // travel at the clearance height (10/120 + 120/1500 = 0.163 333 s), the drop from the clearance
        // (0.089 443 s) and its 50 ms settle: 0.392 219 s. Sequential, as before issue 25: a 4 mm lift
        // (4/25 + 25/500 = 0.21 s) and its settle, the same travel, a 4 mm drop and its settle: 0.683 333 s.
        let mut p = profile();
        p.motion.junction_deviation_mm = 1e-9;
        let line = |x0: f64, x1: f64| Polyline::new(vec![Point::new(x0, 10.0), Point::new(x1, 10.0)]);
        let steps = drawing_to_steps(&p, &Drawing::single_layer("a", vec![line(0.0, 30.0), line(40.0, 70.0)])).unwrap();
        let plan = plan(&p, &steps, homed_position(&p).unwrap(), Lookahead::Whole).unwrap();
        use MoveKind::*;
        // The first line's only Draw block is block 3; the hop follows.
        let hop: Vec<_> = plan.blocks[4..8].iter().map(|b| (b.kind, b.block.steps)).collect();
        assert_eq!(
            hop,
            [(PenUp, [0, 0, 400, 0]), (Travel, [800, 0, 0, 0]), (PenDown, [0, 0, -400, 0]), (Settle, [0; 4])]
        );
        let secs = |r: std::ops::Range<usize>| {
            #[allow(clippy::cast_precision_loss)]
            let t = plan.blocks[r].iter().map(|b| u64::from(b.block.duration_ticks())).sum::<u64>() as f64;
            t / 1e6
        };
        let (clear, travel) = (2.0 * (1.0f64 / 500.0).sqrt(), 10.0 / 120.0 + 120.0 / 1500.0);
        let overlapped = clear + travel + clear + 0.05;
        let sequential = 2.0 * (4.0 / 25.0 + 25.0 / 500.0 + 0.05) + travel;
        assert!((overlapped - 0.392_219).abs() < 1e-6 && (sequential - 0.683_333).abs() < 1e-6);
        // The stepper's rates are rounded down to what a frame carries (9 significant bits, ≤ 0.2 % slower) and to
        // whole ticks, the corners are not quite stops (a few µs): the planned hop is within 0.2 % of the hand value.
        let planned = secs(4..8);
        assert!(planned >= overlapped - 1e-5 && planned <= overlapped * 1.002, "{planned} vs {overlapped}");
        assert!(planned < 0.6 * sequential);
        // Each part on its own.
        assert!((secs(4..5) - clear).abs() < clear * 0.002, "{}", secs(4..5));
        assert!((secs(6..7) - clear).abs() < clear * 0.002, "{}", secs(6..7));
        assert_eq!(secs(7..8), 0.05);
        assert!((secs(5..6) - travel).abs() < travel * 0.002, "{}", secs(5..6));
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
        // Resuming on the hop (block 8, the first travel block after the rise to the clearance) from the pen-up
        // height: travel there, and set the pen to the height it had there (the clearance, 400 steps).
        assert_eq!(full.blocks[7].kind, PenUp);
        assert_eq!(full.position_after(7)[2], 400);
        let r = plan_resume(&p, &steps, start, 8, start, false).unwrap();
        assert_eq!(r.blocks[..r.preamble].iter().map(|b| b.kind).collect::<Vec<_>>(), [Travel, PenDown, Settle]);
        assert_eq!(r.position_after(r.preamble - 1), full.position_after(7));
        // Resuming after the final lift, from the pen-up height, needs no pen moves.
        let last = full.blocks.len() - 1;
        let r = plan_resume(&p, &steps, start, last, start, false).unwrap();
        assert_eq!(r.blocks[..r.preamble].iter().map(|b| b.kind).collect::<Vec<_>>(), [Travel]);
        assert_ne!(full.geometry_hash(), r.geometry_hash());
        assert_eq!(full.geometry_hash(), plan(&p, &steps, start, Lookahead::Window(4)).unwrap().geometry_hash());
    }

    #[test]
    // Accelerations in steps/s², far inside u32.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    fn draw_and_travel_accelerations_are_capped_by_the_pen_profile() {
        let mut p = profile();
        // A servo pen: travel stays flat (no Z in the hop), so its per-event acceleration is the path's.
        p.pen.command = crate::config::profile::PenCommand::Servo;
        let (spm, axis_a) = (p.axes.x.steps_per_mm, p.axes.x.max_accel_mm_s2);
        assert_eq!((p.axes.y.steps_per_mm, p.axes.y.max_accel_mm_s2), (spm, axis_a));
        let d = Drawing::single_layer("a", vec![square(10.0, 10.0, 5.0), square(30.0, 10.0, 5.0)]);
        let accels = |p: &MachineProfile, kind: MoveKind| -> Vec<u32> {
            let steps = drawing_to_steps(p, &d).unwrap();
            let full = plan(p, &steps, homed_position(p).unwrap(), Lookahead::Whole).unwrap();
            // Axis-aligned moves only: one step per event, so the accel is the cap in steps/s².
            full.blocks
                .iter()
                .filter(|b| b.kind == kind && !b.block.is_dwell() && (b.block.steps[0] == 0) != (b.block.steps[1] == 0))
                .map(|b| b.block.accel)
                .collect()
        };
        // Without caps: the axes' acceleration (rounded down in f32: within one step/s² of the exact figure).
        let floor = |a: f64| (a * spm).floor() as u32;
        let near = |got: u32, a: f64| got <= floor(a) && got + 1 >= floor(a);
        assert!(accels(&p, MoveKind::Draw).iter().all(|&a| near(a, axis_a)));
        let (draw_a, travel_a) = (axis_a / 4.0, axis_a / 2.0);
        p.pen.draw_accel_mm_s2 = Some(draw_a);
        p.pen.travel_accel_mm_s2 = Some(travel_a);
        let draws = accels(&p, MoveKind::Draw);
        assert_eq!(draws.len(), 8, "the two squares' sides");
        assert!(draws.iter().all(|&a| near(a, draw_a)), "{draws:?}");
        let travels = accels(&p, MoveKind::Travel);
        assert!(!travels.is_empty() && travels.iter().all(|&a| near(a, travel_a)), "{travels:?}");
        // A cap above the axes' limits changes nothing; a zero cap is refused by the profile check.
        p.pen.draw_accel_mm_s2 = Some(axis_a * 2.0);
        assert!(accels(&p, MoveKind::Draw).iter().all(|&a| near(a, axis_a)));
        let err = MachineProfile::from_toml(
            &include_str!("../../../samples/xy-plotter.toml").replace("[pen]", "[pen]\ntravel_accel_mm_s2 = 0.0"),
            "t",
        )
        .unwrap_err();
        assert!(err.to_string().contains("pen.travel_accel_mm_s2"), "{err}");
    }

    #[test]
    fn a_servo_hop_of_no_length_lifts_and_drops_in_place() {
        // Two strokes meeting end to start (as `plan` gets them when nothing merged them): the hop between them
        // has no length (this divided by zero once).
        let mut p = profile();
        p.pen.command = crate::config::profile::PenCommand::Servo;
        p.pen.settle_ms = 120.0;
        let a = Polyline::new(vec![Point::new(10.0, 10.0), Point::new(20.0, 10.0)]);
        let b = Polyline::new(vec![Point::new(20.0, 10.0), Point::new(20.0, 20.0)]);
        let steps = drawing_to_steps(&p, &Drawing::single_layer("a", vec![a, b])).unwrap();
        let full = plan(&p, &steps, homed_position(&p).unwrap(), Lookahead::Whole).unwrap();
        use MoveKind::*;
        let kinds: Vec<MoveKind> = full.blocks.iter().map(|b| b.kind).collect();
        let i = kinds.iter().position(|&k| k == Draw).unwrap() + 1;
        // Lifted until the tip is clear (0.3 of the 120 ms swing: 36 ms), then dropped in place: the servo turns
        // back at the contact fraction and the tip touches again at once (within the ticks the rounding takes).
        assert_eq!(&kinds[i..i + 2], [PenUp, PenDown]);
        let t = full.blocks[i].block.duration_ticks() + full.blocks[i + 1].block.duration_ticks();
        assert!((36_000..=36_004).contains(&t), "{t}");
        assert_eq!(kinds[i + 2], Draw);
    }

    #[test]
    fn servo_pens_plan_servo_blocks_and_resume_with_them() {
        let mut p = profile();
        p.pen.command = crate::config::profile::PenCommand::Servo;
        p.pen.settle_ms = 120.0;
        let d = Drawing::single_layer("a", vec![square(10.0, 10.0, 5.0), square(30.0, 10.0, 5.0)]);
        let steps = drawing_to_steps(&p, &d).unwrap();
        let start = homed_position(&p).unwrap();
        let full = plan(&p, &steps, start, Lookahead::Whole).unwrap();
        use MoveKind::*;
        assert!(full.blocks.iter().all(|b| b.block.steps[2] == 0), "no Z steps");
        let servo: Vec<u16> = full.blocks.iter().filter_map(|b| b.block.servo).collect();
        assert_eq!(servo, [900, 300, 900, 300, 900]);
        assert_eq!(full.blocks[0].block, StepBlock::servo(900, 120_000), "the first lift settles in full");
        // Each hop by hand: the servo turns 60° in 120 ms (2 µs per 0.001 of its travel), the tip touching at 0.7
        // of the way down. A lift from the paper is clear after 0.3 × 120 ms = 36 ms; a drop commanded D after the
        // lift reverses the servo at x = 1 − D/120 ms (at the top, 0, after 120 ms) and touches after
        // (0.7 − x) × 120 ms. The carriage travels only after the clear time, has arrived by the contact and the
        // line starts then.
        let mut t = 0u64;
        let (mut lift, mut drop, mut arrived, mut first_travel) = (None, None, 0, None);
        let mut hops = 0;
        for b in &full.blocks {
            match (b.kind, b.block.servo) {
                (PenUp, Some(_)) if t > 0 => lift = Some(t),
                (PenDown, Some(_)) => drop = Some(t),
                (Travel, _) if first_travel.is_none() => first_travel = Some(t),
                (Draw, _) if drop.is_some() => {
                    let d = drop.take().unwrap();
                    #[allow(clippy::cast_precision_loss)]
                    let x = lift.map_or(0.0, |l| (1.0 - (d - l) as f64 / 120_000.0).max(0.0));
                    #[allow(clippy::cast_precision_loss)]
                    let contact = d as f64 + (0.7 - x) * 120_000.0;
                    #[allow(clippy::cast_precision_loss)]
                    let (a, s) = (arrived as f64, t as f64);
                    assert!(a <= contact && s >= contact && s - contact <= 2.0, "{a} {contact} {s}");
                    if let (Some(l), Some(f)) = (lift, first_travel) {
                        assert!(f >= l + 36_000, "the travel left before the tip was clear: {l} {f}");
                    }
                    (lift, first_travel) = (None, None);
                    hops += 1;
                }
                _ => {}
            }
            t += u64::from(b.block.duration_ticks());
            if b.kind == Travel {
                arrived = t;
            }
        }
        assert_eq!(hops, 2);
        let first = |k: MoveKind, from: usize| (from..full.blocks.len()).find(|&i| full.blocks[i].kind == k).unwrap();
        // Resumed on the first square's second side: lift, travel back, lower to the pen's angle.
        let side = first(Draw, 0) + 1;
        let r = plan_resume(&p, &steps, start, side, [0, 0, start[2], 0], false).unwrap();
        let pre: Vec<(MoveKind, Option<u16>)> =
            r.blocks[..r.preamble].iter().map(|b| (b.kind, b.block.servo)).collect();
        assert_eq!(pre, [(PenUp, Some(900)), (Travel, None), (PenDown, Some(300))]);
        assert_eq!(r.position_after(r.preamble - 1), full.position_after(side - 1));
        // Resumed at the travel to the second square (pen up): the servo is lifted anyway, its angle being unknown.
        let lift2 = first(PenUp, side);
        let r = plan_resume(&p, &steps, start, lift2 + 1, start, false).unwrap();
        let pre: Vec<MoveKind> = r.blocks[..r.preamble].iter().map(|b| b.kind).collect();
        assert_eq!(pre, [PenUp, Travel]);
        // Resumed on the drop command or the last part of that travel: it goes on from the second square's first
        // side after a travel there with the pen up and a full drop.
        let (drop2, side2) = (first(PenDown, lift2), first(Draw, lift2));
        assert_eq!(full.blocks[drop2 + 1].kind, Travel, "the drop was commanded during the travel");
        for at in [drop2, drop2 + 1] {
            let r = plan_resume(&p, &steps, start, at, start, false).unwrap();
            assert_eq!(r.resumed_from, side2);
            let pre: Vec<(MoveKind, Option<StepBlock>)> =
                r.blocks[..r.preamble].iter().map(|b| (b.kind, b.block.servo.map(|_| b.block))).collect();
            let up = Some(StepBlock::servo(900, 120_000));
            assert_eq!(pre, [(PenUp, up), (Travel, None), (PenDown, Some(StepBlock::servo(300, 120_000)))]);
            assert_eq!(r.position_after(r.preamble - 1), full.position_after(side2 - 1));
            assert_eq!(r.blocks[r.preamble].kind, Draw);
        }
    }

    /// Two 10 mm strokes along X on the servo kit (`samples/servo-plotter.toml`), the second 30 mm on from the
    /// first's end, planned for a firmware that runs the servo `sync`: the plan and its blocks from the lift after
    /// the first stroke up to the second stroke's first line (the hop).
    fn kit_hop(sync: ServoSync) -> (MotionPlan, std::ops::Range<usize>) {
        let mut p = MachineProfile::from_toml(include_str!("../../../samples/servo-plotter.toml"), "kit").unwrap();
        p.servo_sync = sync;
        let l = |x: f64| Polyline::new(vec![Point::new(x, 20.0), Point::new(x + 10.0, 20.0)]);
        let steps = drawing_to_steps(&p, &Drawing::single_layer("a", vec![l(20.0), l(60.0)])).unwrap();
        let plan = plan(&p, &steps, homed_position(&p).unwrap(), Lookahead::Whole).unwrap();
        let kind_at = |k: MoveKind, stroke: usize| plan.blocks.iter().position(|b| b.kind == k && b.stroke == stroke);
        let lift = kind_at(MoveKind::Draw, 0).unwrap() + 1;
        let line = kind_at(MoveKind::Draw, 1).unwrap();
        (plan, lift..line)
    }

    /// The servo kit's numbers, by hand: the travel is 30 mm along X (2400 steps at 80/mm) at 120 mm/s (9600
    /// steps/s) and 1500 mm/s² (120 000 steps/s²): 384 steps of ramp each way (80 ms each), 1632 of cruise
    /// (170 ms), 330 ms from rest to rest. The servo turns 60° in 150 ms, the tip touching at 0.7: a lift is clear
    /// after 45 ms, a drop from the top touches 105 ms after its command.
    const KIT_CLEAR: u64 = 45_000;
    const KIT_CONTACT: u64 = 105_000;

    #[test]
    fn the_servo_kit_runs_its_hop_through_the_drop_on_a_firmware_that_does_not_stop_for_it() {
        let (plan, hop) = kit_hop(ServoSync::InMotion);
        use MoveKind::*;
        let kinds: Vec<MoveKind> = plan.blocks[hop.clone()].iter().map(|b| b.kind).collect();
        assert_eq!(kinds, [PenUp, Travel, PenDown, Travel, Settle]);
        let b = |i: usize| plan.blocks[hop.start + i].block;
        // One rest-to-rest move, cut where the drop is commanded: the carriage passes the 1-tick servo block at
        // the rate the first part leaves off with and the second part starts with.
        assert_eq!((b(0).servo, b(2)), (Some(900), StepBlock::servo(300, 1)));
        assert!(b(1).entry_rate == 0 && b(3).exit_rate == 0, "{:?} {:?}", b(1), b(3));
        assert!(b(1).exit_rate > 0 && b(1).exit_rate == b(3).entry_rate, "{:?} {:?}", b(1), b(3));
        assert_eq!(b(1).steps[0] + b(3).steps[0], 2400);
        // The drop is commanded where the rest of the travel takes the 105 ms the tip needs to touch, to within
        // a step (104 µs at the cruise): the carriage arrives as the tip touches.
        let last = u64::from(b(2).duration_ticks() + b(3).duration_ticks());
        assert!((KIT_CONTACT - 105..=KIT_CONTACT).contains(&last), "{last}");
        // Lift command to line: the clear time, then the 330 ms move; the drop costs nothing (less than a step).
        let t: u64 = plan.blocks[hop].iter().map(|b| u64::from(b.ticks)).sum();
        assert!((KIT_CLEAR + 330_000..=KIT_CLEAR + 330_000 + 110).contains(&t), "{t}");
        assert_eq!(plan.servo_in_motion(), Some(hop_drop(&plan)));
    }

    /// The first drop commanded during a travel (the servo block between two travel blocks).
    fn hop_drop(plan: &MotionPlan) -> usize {
        (1..plan.blocks.len())
            .find(|&i| plan.blocks[i].kind == MoveKind::PenDown && plan.blocks[i + 1].kind == MoveKind::Travel)
            .unwrap()
    }

    #[test]
    fn on_a_firmware_that_stops_for_the_servo_the_kits_hop_stops_where_the_drop_is_commanded() {
        // GRBL: the travel stops, the drop is commanded, the rest follows from rest and must arrive within the
        // 105 ms to the touch: a triangle of 2·√(e / 120 000 steps/s²) ≤ 104 999 µs (the command takes a tick),
        // e = 330 steps (4.125 mm): 104 881 µs; the first 2070 steps take 80 + 135.625 + 80 ms from rest to rest.
        // GRBL dwells in whole 50 ms steps: the lift's 45 ms wait is 50 ms, and the 0.12 ms left between the
        // arrival and the touch is no dwell (`G4 P0`, a stop of a tick).
        let (plan, hop) = kit_hop(ServoSync::AtRest);
        use MoveKind::*;
        let kinds: Vec<MoveKind> = plan.blocks[hop.clone()].iter().map(|b| b.kind).collect();
        assert_eq!(kinds, [PenUp, Travel, PenDown, Travel, Settle]);
        let b = |i: usize| plan.blocks[hop.start + i].block;
        assert_eq!(b(1).exit_rate, 0, "the first part ends at rest");
        assert_eq!(b(3).entry_rate, 0, "the last part starts from rest");
        assert_eq!((b(1).steps[0], b(3).steps[0]), (2070, 330));
        assert_eq!((b(0).duration_ticks(), b(4).duration_ticks()), (50_000, 1));
        let t: u64 = plan.blocks[hop].iter().map(|b| u64::from(b.ticks)).sum();
        assert!((50_000 + 295_625 + 104_881..=50_000 + 295_625 + 104_881 + 100).contains(&t), "{t}");
        assert_eq!(plan.servo_in_motion(), None);
    }

    #[test]
    fn an_ebb_commands_the_drop_while_the_carriage_travels() {
        // saxi's limits: travel at 400 mm/s²; the servo from 17750 (up) to 15700 (down), 2050 units, raised 1618
        // and lowered 1079 units per 24 ms cycle; the tip touching at 0.7 of the way down.
        let p = MachineProfile::from_toml(include_str!("../../../samples/axidraw-saxi.toml"), "saxi.toml").unwrap();
        let l =
            |x: f64| Polyline::new(vec![Point::new(x, 20.0), Point::new(x + 10.0, 20.0), Point::new(x + 10.0, 30.0)]);
        let d = Drawing::single_layer("l", vec![l(20.0), l(60.0)]);
        let steps = drawing_to_steps(&p, &d).unwrap();
        let plan = plan(&p, &steps, [0; 4], Lookahead::Whole).unwrap();
        use MoveKind::*;
        let kinds: Vec<MoveKind> = plan.blocks.iter().map(|b| b.kind).collect();
        let hop = [Travel, PenDown, Travel, Settle];
        let mut expected = vec![PenUp];
        expected.extend(hop.iter().chain(&[Draw, Draw, PenUp]).chain(&hop).chain(&[Draw, Draw, PenUp]));
        assert_eq!(kinds, expected);
        let t = |i: usize| u64::from(plan.blocks[i].block.duration_ticks());
        // A lift is clear after one cycle (1618 of the 615 units to the contact point) and the board's 1 ms margin.
        assert_eq!(t(7), 25_000);
        for first in [1, 8] {
            let (a, drop, b) = (plan.blocks[first].block, plan.blocks[first + 1].block, plan.blocks[first + 2].block);
            // The carriage passes the drop command moving: the first part ends at the rate the second starts with.
            assert_eq!(drop, StepBlock::servo(300, 1));
            assert!(a.exit_rate > 0 && a.exit_rate == b.entry_rate, "{a:?} {b:?}");
            // From the top the tip is beyond 0.7 × 2050 = 1435 units after 2 moves of 1079, the first one tick to
            // one cycle after the command: between 24 ms + 1 tick and 48 ms (less and more the 1 ms margin). The
            // carriage has arrived by the earliest; the stroke starts at the latest.
            assert!(t(first + 1) + t(first + 2) <= 23_001);
            // The cut is at the last step that arrives in time: steps come about 1.4 ms apart at the 9 mm/s the
            // carriage has 23 ms before it stops (400 mm/s², 80 steps/mm), and the wire rounds the rates down.
            assert!(t(first + 1) + t(first + 2) >= 23_001 - 3000, "{}", t(first + 1) + t(first + 2));
            assert_eq!(t(first + 1) + t(first + 2) + t(first + 3), 49_000);
        }
        // The hop from home to (20, 20) mm is the rest-to-rest travel of 20·√2 mm at 400 mm/s² (2·√(d/a), the
        // feed of 200 mm/s never reached), its last 20–23 ms overlapping the drop, then the rest of the 49 ms.
        let hop_s = (t(1) + t(2) + t(3) + t(4)) as f64 / 1e6;
        let by_hand = 2.0 * (20.0 * std::f64::consts::SQRT_2 / 400.0f64).sqrt() + 0.049 - 0.023;
        assert!(hop_s >= by_hand - 0.0005 && hop_s <= by_hand + 0.0035, "{hop_s} s, by hand {by_hand} s");
        // The second hop, from (30, 30) to (60, 20) mm (√1000 mm) likewise, after the lift's 25 ms.
        let hop_s = (t(7) + t(8) + t(9) + t(10) + t(11)) as f64 / 1e6;
        let by_hand = 0.025 + 2.0 * (1000.0f64.sqrt() / 400.0).sqrt() + 0.049 - 0.023;
        assert!(hop_s >= by_hand - 0.0005 && hop_s <= by_hand + 0.0035, "{hop_s} s, by hand {by_hand} s");
    }

    #[test]
    fn a_split_block_runs_as_the_whole_did() {
        // 1000 × 400 steps from rest at 20 000 events/s² to a cruise of 8000/s and back to rest.
        let whole = StepBlock {
            steps: [1000, -400, 0, 0],
            entry_rate: 0,
            cruise_rate: 8000,
            exit_rate: 0,
            accel: 20_000,
            dwell_ticks: 0,
            servo: None,
        };
        for e in [1, 100, 500, 900, 999] {
            let (a, b) = split_block(&whole, e);
            assert_eq!(
                (a.steps[0], a.steps[0] + b.steps[0], a.steps[1] + b.steps[1]),
                (i32::try_from(e).unwrap(), 1000, -400)
            );
            // Axis Y keeps to the line: within half a step of 0.4 × e.
            assert!((f64::from(a.steps[1]) + 0.4 * f64::from(e)).abs() <= 0.5, "{e}: {a:?}");
            // The rate at the cut: √(2·a·x) on the ramps, the cruise between (quantized down by under 0.2 %).
            let ideal = (2.0 * 20_000.0 * f64::from(e.min(1000 - e))).sqrt().min(8000.0);
            assert!(f64::from(a.exit_rate) <= ideal && f64::from(a.exit_rate) > 0.998 * ideal, "{e}: {a:?}");
            assert_eq!(a.exit_rate, b.entry_rate);
            let parts = a.duration_ticks() + b.duration_ticks();
            assert!(parts.abs_diff(whole.duration_ticks()) <= 200, "{e}: {parts} vs {}", whole.duration_ticks());
        }
        // The longest last part within 50 ms: the end of the final ramp, ½·a·t² = 25 events.
        let (a, b) = split_for_budget(&whole, 50_000);
        let (a, b) = (a.unwrap(), b.unwrap());
        assert!(b.duration_ticks() <= 50_000 && b.duration_ticks() > 49_000, "{b:?}");
        assert_eq!(b.steps[0], 25);
        assert_eq!(a.steps[0], 975);
        // A travel that fits whole is not cut.
        assert_eq!(split_for_budget(&whole, whole.duration_ticks()), (None, Some(whole)));
    }

    #[test]
    fn pen_changes_sit_before_the_travel_to_a_layer_with_another_pen() {
        use crate::config::profile::PenSpec;
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
        // Black (travel, drop, settle, 4 draws), full lift and settle; red (travel, drop, settle, 4 draws); red,
        // the same pen (rise to the clearance, two travel blocks climbing and descending, drop, settle, 4 draws),
        // full lift and settle; black.
        let blocks: Vec<usize> = plan.pen_changes.iter().map(|c| c.block).collect();
        assert_eq!(blocks, [9, 27]);
        assert!(plan.pen_changes.iter().all(|c| plan.blocks[c.block].kind == MoveKind::Travel));
        assert_eq!(plan.pen_changes[0].pen.name, "red");
        assert_eq!(plan.pen_changes[1].previous.name, "red");
        assert_eq!(plan.pen_changes[1].layer_name, "k");
        assert_eq!(plan.first_pen.name, "black");
        // The red pen drops to 1 mm (400 steps/mm: 1200 steps below the 4 mm pen-up) and draws at 30 mm/s: a 5 mm
        // side takes longer than the black pen's at 60 mm/s.
        // After the pen change the travel is flat at the pen-up height.
        assert_eq!(plan.blocks[9].block.steps[2], 0);
        assert_eq!(plan.blocks[10].block.steps, [0, 0, -1200, 0]);
        assert_eq!(plan.blocks[0].block.steps[2] + plan.blocks[1].block.steps[2], -1600);
        // Before it the pen goes all the way up and settles; between the two red layers (one pen) it rises to
        // the clearance (1 mm above its 1 mm down height) only.
        assert_eq!(plan.blocks[7].block.steps, [0, 0, 1600, 0]);
        assert_eq!(plan.blocks[8].kind, MoveKind::Settle);
        assert_eq!((plan.blocks[16].kind, plan.blocks[16].block.steps), (MoveKind::PenUp, [0, 0, 400, 0]));
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

    /// The plan as made before windows: every planner block of the drawing at once, linked, planned, stepped.
    fn whole_at_once(raw: &RawBlocks, cfg: &MachineConfig, caps: [f32; 2]) -> Vec<StepBlock> {
        let mut all: Vec<PlanBlock> = (0..raw.len()).map(|i| raw.plan_block(i, cfg, caps)).collect();
        planner::link_all(&mut all, cfg);
        planner::plan(&mut all, 0.0);
        planner::step_blocks(&all).collect()
    }

    /// Curves (a spiral of fine chords, circles of coarse ones), corners (a zigzag), dots and long straight runs,
    /// in several strokes, with random wiggles.
    fn busy_drawing(seed: u64) -> Drawing {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
        let mut paths = Vec::new();
        let spiral = (0..3000)
            .map(|i| {
                let t = f64::from(i) * 0.02;
                let r = 60.0 - t * 0.9;
                Point::new(100.0 + r * t.cos(), 90.0 + r * t.sin())
            })
            .collect();
        paths.push(Polyline::new(spiral));
        let zig = (0..400).map(|i| Point::new(10.0 + f64::from(i) * 0.5, 20.0 + f64::from(i % 2) * 3.0)).collect();
        paths.push(Polyline::new(zig));
        for k in 0..6 {
            let n = [3, 8, 40, 200, 7, 1000][k];
            let r = rng.random_range(1.0..25.0);
            let (cx, cy) = (rng.random_range(30.0..170.0), rng.random_range(30.0..120.0));
            let pts = (0..=n)
                .map(|i| {
                    let a = std::f64::consts::TAU * f64::from(i) / f64::from(n);
                    let w = rng.random_range(-0.05..0.05);
                    Point::new(cx + (r + w) * a.cos(), cy + (r + w) * a.sin())
                })
                .collect();
            paths.push(Polyline::new(pts));
        }
        paths.push(Polyline::new(vec![Point::new(5.0, 5.0), Point::new(5.0, 5.0)]));
        paths.push(Polyline::new(vec![Point::new(5.0, 150.0), Point::new(200.0, 150.0), Point::new(200.0, 10.0)]));
        Drawing::single_layer("busy", paths)
    }

    #[test]
    fn planning_a_window_at_a_time_is_planning_the_whole_drawing() {
        for profile in [
            profile(),
            MachineProfile::from_toml(include_str!("../../../samples/servo-plotter.toml"), "servo.toml").unwrap(),
            MachineProfile::from_toml(include_str!("../../../samples/axidraw-saxi.toml"), "saxi.toml").unwrap(),
        ] {
            let cfg = machine_config(&profile).unwrap();
            #[allow(clippy::cast_possible_truncation)]
            let cap = |a: Option<f64>| a.map_or(f32::MAX, |a| a as f32);
            let caps = [cap(profile.pen.draw_accel_mm_s2), cap(profile.pen.travel_accel_mm_s2)];
            for seed in 0..3 {
                let steps = drawing_to_steps(&profile, &busy_drawing(seed)).unwrap();
                let start = homed_position(&profile).unwrap();
                let raw = build_blocks(&profile, &cfg, &steps, start, true).unwrap().raw;
                let want = whole_at_once(&raw, &cfg, caps);
                assert!(want.len() > 4000);
                for window in [2, 3, 5, 16, 100, 1000, WHOLE_WINDOW] {
                    let mut got = Vec::new();
                    plan_whole(&raw, &cfg, caps, window, |i, b| {
                        assert_eq!(i, got.len());
                        got.push(b);
                    });
                    assert!(got == want, "{}: window {window}, seed {seed}", profile.name);
                }
                // And the plan's blocks are those, quantized and timed.
                let plan = plan_returning(&profile, &steps, start, Lookahead::Whole, true).unwrap();
                let q: Vec<StepBlock> = want.iter().map(protocol::quantize).collect();
                assert!(plan.blocks.iter().map(|b| b.block).eq(q.iter().copied()));
                assert!(plan.blocks.iter().all(|b| b.ticks == b.block.duration_ticks()));
            }
        }
    }
}
