//! The motion planner: trapezoidal velocity profiles with junction-deviation cornering, planned by a reverse and
//! a forward pass over a sequence of blocks.
//!
//! The planner is a plain library over `&mut [PlanBlock]`, so the look-ahead is whatever slice the caller passes:
//! the firmware passes its bounded (heapless) queue and re-plans each time a block arrives
//! ([`crate::machine`]); the host passes a whole drawing and gets the exact speed plan and execution time
//! ([`step_blocks`], [`total_ticks`]). One implementation, two callers.
//!
//! # Model
//! Each block is a straight move at constant acceleration `a` up to its nominal speed. Speeds are planned in mm/s
//! along the path, then converted to the major axis's step-event rates ([`to_step_block`]) for the stepper.
//! - Per-axis limits: a block's nominal speed and acceleration are the largest whose projection on every axis
//!   (`v·|u_i|`, `a·|u_i|` with `u` the unit direction) stays within that axis's maximum feed and acceleration.
//! - Cornering (junction deviation, the model grbl's planner uses): the path is imagined to round the corner on a
//!   circle that stays within the deviation `δ` of the sharp corner; the speed at the junction is the one whose
//!   centripetal acceleration on that circle equals `a`: `v² = a·δ·sin(θ/2)/(1 − sin(θ/2))` with θ the angle between
//!   the reversed incoming and the outgoing direction (θ = 180° straight on: unlimited; θ = 0 reversal: stop).
//!   Both blocks' nominal speeds cap it too.
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
use crate::stepper::{MAX_RATE, StepBlock};

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
    /// Highest entry speed² allowed by the junction with the previous block and both nominal speeds.
    pub max_entry_speed_sqr: f32,
    /// Planned entry speed², mm²/s² (the output of [`plan`]).
    pub entry_speed_sqr: f32,
    /// Step events (major-axis steps) per mm of path: converts mm/s to events/s.
    pub events_per_mm: f32,
}

impl PlanBlock {
    /// A straight move by `steps` at the requested `feed_mm_s`, limited per axis by `config`. `None` when no axis
    /// moves. The junction with the previous block is set by [`link`].
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
            let u = unit[i].abs();
            if u > 0.0 {
                let a = config.axis(axis);
                nominal = nominal.min(a.max_feed_mm_s / u);
                accel = accel.min(a.max_accel_mm_s2 / u);
            }
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
            entry_speed_sqr: 0.0,
            events_per_mm: 0.0,
        }
    }
}

/// Highest speed² at the junction from `prev` into `next` under junction deviation `deviation_mm` (also capped by
/// both nominal speeds). 0 when either block is fixed.
pub fn junction_speed_sqr(prev: &PlanBlock, next: &PlanBlock, deviation_mm: f32) -> f32 {
    if prev.fixed.is_some() || next.fixed.is_some() {
        return 0.0;
    }
    let cap = (prev.nominal_speed * prev.nominal_speed).min(next.nominal_speed * next.nominal_speed);
    // For unit vectors p, q at angle φ, |p − q| = 2·sin(φ/2); with p = −u_prev this is |u_prev + u_next|/2, which
    // (unlike going through cos θ) stays accurate for nearly reversing corners.
    let (p, q) = (path_direction(prev), path_direction(next));
    let sum_sq: f32 = p.iter().zip(q).map(|(a, b)| (a + b) * (a + b)).sum();
    let sin_half = 0.5 * sqrt(sum_sq);
    if sin_half < 1e-4 {
        // Reversal.
        return 0.0;
    }
    if sin_half > 0.999_999 {
        // Straight on.
        return cap;
    }
    let a = prev.acceleration.min(next.acceleration);
    (a * deviation_mm * sin_half / (1.0 - sin_half)).min(cap)
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

/// Set `block.max_entry_speed_sqr` from the junction with `prev` (the block before it; `None` = start from rest).
pub fn link(prev: Option<&PlanBlock>, block: &mut PlanBlock, deviation_mm: f32) {
    block.max_entry_speed_sqr = match prev {
        Some(p) => junction_speed_sqr(p, block, deviation_mm),
        None => 0.0,
    };
}

/// Set the `max_entry_speed_sqr` of every block of a sequence starting from rest (host use, whole drawing).
pub fn link_all(blocks: &mut [PlanBlock], deviation_mm: f32) {
    let mut prev: Option<PlanBlock> = None;
    for b in blocks.iter_mut() {
        link(prev.as_ref(), b, deviation_mm);
        prev = Some(*b);
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
/// speeds and acceleration never exceed the plan.
pub fn to_step_block(block: &PlanBlock, exit_speed_sqr: f32) -> StepBlock {
    if let Some(f) = block.fixed {
        return f;
    }
    let k = block.events_per_mm;
    let rate = |v: f32| floor_u32(v * k).min(MAX_RATE);
    let cruise = rate(block.nominal_speed).max(1);
    StepBlock {
        steps: block.steps,
        // `sqrt` of a squared speed may land an ulp above the nominal speed: cap at cruise.
        entry_rate: rate(sqrt(block.entry_speed_sqr)).min(cruise),
        cruise_rate: cruise,
        exit_rate: rate(sqrt(exit_speed_sqr)).min(cruise),
        accel: rate(block.acceleration).max(1),
        dwell_ticks: 0,
    }
}

/// The stepper blocks of a planned sequence, in order.
pub fn step_blocks(blocks: &[PlanBlock]) -> impl Iterator<Item = StepBlock> + '_ {
    (0..blocks.len()).map(|i| to_step_block(&blocks[i], exit_speed_sqr(blocks, i)))
}

/// Exact execution time of a planned sequence, timer ticks ([`crate::stepper::TICK_HZ`]): the sum of the
/// stepper's [`StepBlock::duration_ticks`].
pub fn total_ticks(blocks: &[PlanBlock]) -> u64 {
    step_blocks(blocks).map(|b| u64::from(b.duration_ticks())).sum()
}

#[cfg(test)]
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
        link_all(&mut v, c.junction_deviation_mm);
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
        link_all(&mut v, c.junction_deviation_mm);
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
        link_all(&mut v, c.junction_deviation_mm);
        plan(&mut v, 0.0);
        let t = total_ticks(&v);
        assert!((t as f64 - 120_000.0).abs() < 20.0, "{t}");
        // Collinear X moves with different E ratios corner as straight on (E ignored in the junction).
        let a = PlanBlock::line(&c, [800, 0, 0, 40], 50.0).unwrap();
        let mut b2 = PlanBlock::line(&c, [800, 0, 0, 80], 50.0).unwrap();
        link(Some(&a), &mut b2, c.junction_deviation_mm);
        assert_eq!(b2.max_entry_speed_sqr, 50.0 * 50.0);
        // Retraction after a nozzle move: a right angle.
        let mut r2 = PlanBlock::line(&c, [0, 0, 0, -200], 20.0).unwrap();
        link(Some(&a), &mut r2, c.junction_deviation_mm);
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
                let nominal_sq = b.nominal_speed * b.nominal_speed;
                prop_assert!(entry <= nominal_sq * tol && exit <= nominal_sq * tol);
                // Reachable within the block at the block's acceleration.
                let ramp = 2.0 * b.acceleration * b.millimeters;
                prop_assert!((exit - entry).abs() <= ramp * tol + 1e-3, "block {i}: {entry} → {exit} over {ramp}");
                // Junction within the deviation limit.
                prop_assert!(entry <= b.max_entry_speed_sqr * tol + 1e-6);
                if i > 0 {
                    let p = &v[i - 1];
                    let sum_sq: f64 = p.unit.iter().zip(b.unit).map(|(x, y)| f64::from(x + y).powi(2)).sum();
                    let sin_half = 0.5 * sum_sq.sqrt();
                    let a = f64::from(p.acceleration.min(b.acceleration));
                    if sin_half < 0.999 {
                        let limit = a * f64::from(c.junction_deviation_mm) * sin_half / (1.0 - sin_half);
                        prop_assert!(f64::from(entry) <= limit * 1.001 + 1e-6, "junction {i}: {entry} > {limit}");
                    }
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
            for (s, f) in &ms {
                if let Some(mut b) = PlanBlock::line(&c, *s, *f) {
                    link(inc.last(), &mut b, c.junction_deviation_mm);
                    inc.push(b);
                    plan(&mut inc, 0.0);
                }
            }
            prop_assert_eq!(inc, whole);
        }
    }
}
