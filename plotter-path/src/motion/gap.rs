//! Where a plan's time above its lower bound goes: the gap between the plan ([`crate::motion::plan`]) and the
//! bound ([`crate::motion::bound`]) split into its causes, each computed from the plan's own blocks, never guessed.
//!
//! **Pen down** is taken apart as a ladder. Each stroke's drawing blocks are timed at their fastest (forward and
//! backward passes over the speed caps at their vertices, each block a trapezoid) under constraints that are
//! added one kind at a time, from what the bound assumed to what the plan obeyed; each rung can only be slower than
//! the one before, and the difference is what that kind of constraint costs:
//!
//! 1. the bound itself: every block at the acceleration and top speed its own direction allows on the machine's
//!    axes (and the profile's drawing acceleration and the pen's feed), every vertex capped at the profile's
//!    vertex limit as the bound takes it (the more permissive of junction deviation's and the curve's speed, at
//!    the largest acceleration any direction allows), the stroke ending at the bound's speed into the lift;
//! 2. *axis limits*: each block at the limits the planner gave it: the same physical limits as the bound's (in
//!    the planner's single precision), and the stepper's highest step rate;
//! 3. *corners*: the vertices the planner takes as corners, at their junction-deviation speed with the lower
//!    acceleration of their two blocks (what remains is that acceleration against the bound's largest);
//! 4. *curves*: the vertices the planner takes as points of a curve, at the curve's centripetal limit where
//!    junction deviation would allow more (finely flattened curves), and the chords of curves cruising no faster
//!    than their ends;
//! 5. *stroke ends*: each stroke entered and left at the speeds the plan has there (the pen's drop before it and
//!    the lift after it);
//! 6. the plan as the firmware runs it: the rest is *step timing* (speeds rounded down to whole steps per second,
//!    durations to ticks).
//!
//! **Pen moves**: the plan's lift, drop and settle blocks against the bound's parts for them (a servo's drop and
//! the dwell that completes it count together as the drop).
//!
//! **Travel**: *travel order* is what the plan's hops, each at the least time a hop of its X and Y distances
//! takes ([`crate::motion::hop_time::HopTime`], the same cost the bound's travel charges, with what its length
//! adds to the pen's moves), cost above the bound's travel (a bound on the hops of any order: the best order's
//! hops lie between the two, so this part is what order could win at most); *hops* is what the plan's travel
//! takes above that (climbing over the paper with a Z pen, stopping for a servo's drop command). What a hop's
//! length adds to the pen's moves (a Z pen's corners at a long hop's joins; a servo's drop window after a lift,
//! taken at the plan's own travel time of the hop) is charged to the hop, so it is taken off the lifts and drops.

use plotter_fw::TICK_HZ;
use plotter_fw::planner::{self, PlanBlock};

use crate::MachineProfile;
use crate::geometry::steps::StepDrawing;
use crate::motion::bound::{self, TimeBound};
use crate::motion::piece_time;
use crate::motion::plan::{MotionPlan, MoveKind, PlanError, layer_pens, planner_blocks};

/// A plan's time above its lower bound, by cause, seconds. The parts add up to the plan's time less the bound's.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct TimeGap {
    /// Drawing slower because of the limits the planner gives each line beyond the bound's own per-direction
    /// axis limits (the stepper's highest step rate; the planner's single-precision arithmetic).
    pub axis_limits_s: f64,
    /// Drawing slowed at corners (junction deviation).
    pub corners_s: f64,
    /// Drawing slowed on curves (their centripetal acceleration).
    pub curves_s: f64,
    /// Drawing slowed where strokes start and end, by the pen's drop before and lift after them.
    pub stroke_ends_s: f64,
    /// Drawing slower as the firmware runs it: speeds rounded down to whole steps per second, times to ticks.
    pub step_timing_s: f64,
    /// Pen lifts above the bound's.
    pub lifts_s: f64,
    /// Pen drops above the bound's (a servo's drop with the wait that completes it).
    pub drops_s: f64,
    /// Settle dwells above the bound's.
    pub settles_s: f64,
    /// Travel above the least time its hops take (climbs, stops, the hops' corners).
    pub hops_s: f64,
    /// The plan's hops (their order and lengths) above the travel bound.
    pub travel_order_s: f64,
}

impl TimeGap {
    /// The causes with their names, in the order `plotter stats --verbose` prints them.
    pub fn parts(&self) -> [(&'static str, f64); 10] {
        [
            ("axis limits", self.axis_limits_s),
            ("corners", self.corners_s),
            ("curves", self.curves_s),
            ("stroke ends", self.stroke_ends_s),
            ("step timing", self.step_timing_s),
            ("lifts", self.lifts_s),
            ("drops", self.drops_s),
            ("settles", self.settles_s),
            ("hops", self.hops_s),
            ("travel order", self.travel_order_s),
        ]
    }

    /// The whole gap, seconds.
    pub fn total_s(&self) -> f64 {
        self.parts().iter().map(|p| p.1).sum()
    }
}

/// One drawing block as a rung of the ladder sees it: length, acceleration, top speed.
#[derive(Debug, Clone, Copy)]
struct Piece {
    len: f64,
    accel: f64,
    top: f64,
}

/// Least time over `pieces` with speed caps `caps` at their ends (`caps.len() == pieces.len() + 1`; the first is
/// the entry, the last the exit), each piece within its top speed and acceleration: the speeds the caps allow
/// (forward and backward passes), each piece a trapezoid between them.
fn fastest(pieces: &[Piece], caps: &[f64]) -> f64 {
    let n = pieces.len();
    let mut v: Vec<f64> = (0..=n)
        .map(|j| {
            let before = j.checked_sub(1).map_or(f64::INFINITY, |i| pieces[i].top);
            let after = pieces.get(j).map_or(f64::INFINITY, |p| p.top);
            caps[j].min(before).min(after)
        })
        .collect();
    for (i, p) in pieces.iter().enumerate() {
        v[i + 1] = v[i + 1].min((v[i] * v[i] + 2.0 * p.accel * p.len).sqrt());
    }
    for (i, p) in pieces.iter().enumerate().rev() {
        v[i] = v[i].min((v[i + 1] * v[i + 1] + 2.0 * p.accel * p.len).sqrt());
    }
    pieces.iter().enumerate().map(|(i, p)| piece_time::fastest_piece(p.len, v[i], v[i + 1], p.top, p.accel)).sum()
}

/// Seconds of `ticks` of the step timer (any plot's tick count fits f64's mantissa).
#[allow(clippy::cast_precision_loss)]
fn secs(ticks: u64) -> f64 {
    ticks as f64 / f64::from(TICK_HZ)
}

/// Where `plan` (the whole-drawing plan of `steps` on `profile`, back home at its end with `return_home`) spends
/// its time above `bound` (that drawing's lower bound): see the module docs.
pub fn time_gap(
    profile: &MachineProfile,
    steps: &StepDrawing,
    plan: &MotionPlan,
    bound: &TimeBound,
    return_home: bool,
) -> Result<TimeGap, PlanError> {
    let (cfg, blocks) = planner_blocks(profile, steps, plan.start, return_home)?;
    let kinds: Vec<(MoveKind, usize)> = blocks.iter().map(|b| (b.1, b.2)).collect();
    let blocks: Vec<PlanBlock> = blocks.into_iter().map(|b| b.0).collect();
    let verdicts: Vec<planner::Junction> = planner::junctions(&blocks, &cfg).collect();
    let feeds: Vec<f64> = layer_pens(profile, steps).iter().map(|p| p.draw_feed_mm_s).collect();
    let accel = bound::draw_accel(profile);
    let (sx, sy) = (profile.axes.x.steps_per_mm, profile.axes.y.steps_per_mm);
    // Rungs 2 to 5 summed over the strokes.
    let mut rung = [0.0f64; 4];
    let (mut drawn_strokes, mut cornered) = (0u32, 0u32);
    let mut i = 0;
    while i < blocks.len() {
        if kinds[i].0 != MoveKind::Draw {
            i += 1;
            continue;
        }
        let (k0, stroke) = (i, kinds[i].1);
        while i < blocks.len() && kinds[i] == (MoveKind::Draw, stroke) {
            i += 1;
        }
        drawn_strokes += 1;
        let run = &blocks[k0..i];
        // The bound's speed into the lift, from the stroke's last chord (as the bound measures it).
        let last = run[run.len() - 1].steps;
        let last_mm = (f64::from(last[0]) / sx).hypot(f64::from(last[1]) / sy);
        let v_lift = bound::stroke_exit_speed(profile, accel, last_mm);
        if !bound::stroke_end_may_curve(profile, last_mm) {
            cornered += 1;
        }
        let feed = feeds.get(steps.layer_of(stroke)).copied().unwrap_or(profile.pen.draw_feed_mm_s);
        // The bound's caps: rest at the start, its corners inside, its speed into the lift at the end.
        let mut caps = vec![f64::INFINITY; run.len() + 1];
        caps[0] = 0.0;
        caps[run.len()] = v_lift;
        let segs = bound::vertex_segs(run.iter().copied(), accel);
        for (j, cap) in caps.iter_mut().enumerate().take(run.len()).skip(1) {
            *cap = bound::vertex_cap(&cfg, &segs, j);
        }
        // Rung 2: each block's own limits.
        let mut pieces: Vec<Piece> = run
            .iter()
            .map(|b| Piece {
                len: f64::from(b.millimeters),
                accel: f64::from(b.acceleration),
                top: f64::from(b.nominal_speed).min(feed),
            })
            .collect();
        rung[0] += fastest(&pieces, &caps);
        // Rung 3: the planner's corners.
        for j in 1..run.len() {
            let v = &verdicts[k0 + j];
            if v.curve.is_none() {
                caps[j] = caps[j].min(f64::from(v.speed_sqr).sqrt());
            }
        }
        rung[1] += fastest(&pieces, &caps);
        // Rung 4: the curves (every limit the planner set inside the stroke).
        for j in 1..run.len() {
            caps[j] = caps[j].min(f64::from(run[j].max_entry_speed_sqr).sqrt());
        }
        for (p, b) in pieces.iter_mut().zip(run) {
            p.top = p.top.min(f64::from(b.cruise_speed()));
        }
        rung[2] += fastest(&pieces, &caps);
        // Rung 5: entered and left at the plan's speeds.
        caps[0] = f64::from(run[0].entry_speed_sqr).sqrt();
        caps[run.len()] = f64::from(blocks.get(i).map_or(0.0, |b| b.entry_speed_sqr)).sqrt();
        rung[3] += fastest(&pieces, &caps);
    }
    let parts = plan.breakdown();
    let mut gap = TimeGap {
        axis_limits_s: rung[0] - bound.draw_s,
        corners_s: rung[1] - rung[0],
        curves_s: rung[2] - rung[1],
        stroke_ends_s: rung[3] - rung[2],
        step_timing_s: parts.draw_s() - rung[3],
        ..TimeGap::default()
    };
    // Pen moves: the plan's blocks of each kind against the bound's share.
    let mut ticks = [0u64; 3];
    for b in &plan.blocks {
        let k = match b.kind {
            MoveKind::PenUp => 0,
            MoveKind::PenDown => 1,
            MoveKind::Settle if profile.pen.uses_servo() => 1,
            MoveKind::Settle => 2,
            _ => continue,
        };
        ticks[k] += u64::from(b.ticks);
    }
    let share = bound::lift_parts(profile).split(f64::from(drawn_strokes), f64::from(cornered));
    // The bound's lifts part is the sum of its shares; what rounding leaves between them goes to the settles.
    let rest = bound.lifts_s - share.iter().sum::<f64>();
    gap.lifts_s = secs(ticks[0]) - share[0];
    gap.drops_s = secs(ticks[1]) - share[1];
    gap.settles_s = secs(ticks[2]) - share[2] - rest;
    // Travel: each hop of the plan at the least time its X and Y distances allow, and what its length adds to
    // the pen's moves (taken off the pen's causes and charged here, as the bound's travel charges it).
    let hop = crate::motion::hop_time::HopTime::of(profile);
    let lifted = bound::lifted_hops(profile, steps);
    // The plan's travel into each stroke (the travel after the plot's final lift is the way home).
    let final_lift = plan.blocks.iter().rposition(|b| b.kind == MoveKind::PenUp).unwrap_or(plan.blocks.len());
    let mut travel_ticks = vec![0u64; steps.strokes.len()];
    for b in plan.blocks[..final_lift].iter().filter(|b| b.kind == MoveKind::Travel) {
        if let Some(t) = travel_ticks.get_mut(b.stroke) {
            *t += u64::from(b.ticks);
        }
    }
    let (mut x, mut y) = (plan.start[0], plan.start[1]);
    // The hops' charges, what of them the bound leaves out (a lift the hop does not have) and what goes to the
    // pen's causes.
    let (mut charged, mut unlifted, mut pen) = (0.0, 0.0, [0.0f64; 2]);
    for (si, s) in steps.strokes.iter().enumerate() {
        let (dx, dy) = (f64::from(s.start.x - x) / sx, f64::from(s.start.y - y) / sy);
        let least = hop.travel_seconds(dx, dy);
        charged += hop.seconds(dx, dy);
        if lifted[si] {
            let e = hop.pen_extra(dx, dy, secs(travel_ticks[si]));
            pen[0] += e.lift_s;
            pen[1] += e.drop_s + e.drop_after_lift_s;
        } else {
            let e = hop.pen_extra(dx, dy, least);
            unlifted += e.after_lift_s();
            pen[1] += e.drop_s;
        }
        let end = s.moves.iter().fold(s.start, |p, d| p.offset(*d));
        (x, y) = (end.x, end.y);
    }
    if plan.end[0] != x || plan.end[1] != y {
        // The way home: travel alone, from the final lift to rest.
        charged += hop.travel_seconds(f64::from(plan.end[0] - x) / sx, f64::from(plan.end[1] - y) / sy);
    }
    gap.lifts_s -= pen[0];
    gap.drops_s -= pen[1];
    gap.travel_order_s = charged - unlifted - bound.travel_s;
    gap.hops_s = parts.travel_s() - (charged - unlifted - pen[0] - pen[1]);
    Ok(gap)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::steps::{StepDelta, StepPos, StepStroke};
    use crate::motion::bound::plot_time_lower_bound;
    use crate::motion::hop_time::HopTime;
    use crate::motion::plan::{Lookahead, homed_position, plan};

    fn piece(len: f64, accel: f64, top: f64) -> Piece {
        Piece { len, accel, top }
    }

    #[test]
    fn fastest_is_a_trapezoid_between_the_caps() {
        // 100 mm at 60 mm/s and 500 mm/s² from rest to rest: 100/60 + 60/500 s.
        let t = fastest(&[piece(100.0, 500.0, 60.0)], &[0.0, 0.0]);
        assert!((t - (100.0 / 60.0 + 0.12)).abs() < 1e-12, "{t}");
        // Cut in two with no cap between: the same.
        let t2 = fastest(&[piece(40.0, 500.0, 60.0), piece(60.0, 500.0, 60.0)], &[0.0, f64::INFINITY, 0.0]);
        assert!((t2 - t).abs() < 1e-12, "{t2}");
        // A stop in the middle: two 50 mm rest-to-rest moves.
        let t3 = fastest(&[piece(50.0, 500.0, 60.0), piece(50.0, 500.0, 60.0)], &[0.0, 0.0, 0.0]);
        assert!((t3 - 2.0 * (50.0 / 60.0 + 0.12)).abs() < 1e-12, "{t3}");
        // A slower block caps the vertices at its ends: 10 mm at 10 mm/s between two 60 mm/s blocks of 45 mm.
        let t4 = fastest(
            &[piece(45.0, 500.0, 60.0), piece(10.0, 500.0, 10.0), piece(45.0, 500.0, 60.0)],
            &[0.0, f64::INFINITY, f64::INFINITY, 0.0],
        );
        // Each 45 mm block: from rest to 60 (3.6 mm, 0.12 s), down to 10 ((3600 − 100)/1000 = 3.5 mm, 0.1 s),
        // cruise 37.9 mm; the middle 1 s.
        let side = 0.12 + 0.1 + 37.9 / 60.0;
        assert!((t4 - (2.0 * side + 1.0)).abs() < 1e-12, "{t4}");
    }

    /// The parts add up to the plan less the bound, and each is what the hand-made drawing costs.
    #[test]
    fn a_square_and_a_line_by_hand() {
        // The built-in profile (80 steps/mm, 1500 mm/s² per axis, draw 60 mm/s, junction deviation 0.02 mm), with
        // a servo pen so that every stroke runs rest to rest and the pen's moves are plain waits.
        let mut p = MachineProfile::default_plotter();
        p.pen.command = crate::config::profile::PenCommand::Servo;
        // A 40 mm square, then a 40 mm line 40 mm to its right.
        let steps = StepDrawing::from_strokes(vec![
            StepStroke {
                start: StepPos::new(800, 800),
                moves: vec![
                    StepDelta { dx: 3200, dy: 0 },
                    StepDelta { dx: 0, dy: 3200 },
                    StepDelta { dx: -3200, dy: 0 },
                    StepDelta { dx: 0, dy: -3200 },
                ],
            },
            StepStroke { start: StepPos::new(7200, 800), moves: vec![StepDelta { dx: 3200, dy: 0 }] },
        ]);
        let home = homed_position(&p).unwrap();
        let planned = plan(&p, &steps, home, Lookahead::Whole).unwrap();
        let b = plot_time_lower_bound(&p, &steps, 0.0).unwrap();
        let gap = time_gap(&p, &steps, &planned, &b, false).unwrap();
        let above = planned.seconds() - b.total_s();
        assert!((gap.total_s() - above).abs() < 1e-9, "{gap:?} vs {above}");
        // The bound caps each of the square's 90° vertices at the profile's vertex limit, junction deviation's
        // speed with the largest acceleration any direction allows: √(1500·√2·0.02·√½/(1 − √½)) = 10.12 mm/s;
        // each side at the 1500 mm/s² its axis allows (as the planner does: nothing for axis limits), less a
        // microsecond of the stepper's rounding per side. The planner corners with the lower acceleration of its
        // two blocks, 1500 mm/s²: √(1500·0.02·√½/(1 − √½)) = 8.51 mm/s; the difference is the corners' part. No
        // curves, no stroke ends (a servo pen: strokes run rest to rest on both sides).
        let s = std::f64::consts::FRAC_1_SQRT_2;
        let vp = (1500.0 * 0.02 * s / (1.0 - s)).sqrt();
        let vb = (1500f64.hypot(1500.0) * 0.02 * s / (1.0 - s)).sqrt();
        assert!((vp - 8.51).abs() < 0.01 && (vb - 10.12).abs() < 0.01, "{vp} {vb}");
        // A run of `len` mm at 60 mm/s and acceleration a from rest to rest.
        let run = |len: f64, a: f64| len / 60.0 + 60.0 / a;
        // A 40 mm side from u to w at 60 mm/s and acceleration a.
        let side = |u: f64, w: f64, a: f64| {
            let (du, dw) = ((3600.0 - u * u) / (2.0 * a), (3600.0 - w * w) / (2.0 * a));
            (60.0 - u) / a + (60.0 - w) / a + (40.0 - du - dw) / 60.0
        };
        // The square's sides go rest→v, v→v, v→v, v→rest.
        let square = |v: f64| side(0.0, v, 1500.0) + 2.0 * side(v, v, 1500.0) + side(v, 0.0, 1500.0);
        let bound_draw = square(vb) + run(40.0, 1500.0) - 5e-6;
        assert!((b.draw_s - bound_draw).abs() < 1e-5, "{b:?} vs {bound_draw}");
        let corners = square(vp) - square(vb);
        assert!(gap.axis_limits_s.abs() < 1e-5, "{gap:?}");
        assert!((gap.corners_s - corners).abs() < 1e-5, "{gap:?} vs {corners}");
        assert!(gap.corners_s > 0.005, "{gap:?}");
        assert!(gap.curves_s.abs() < 1e-9 && gap.stroke_ends_s.abs() < 1e-9, "{gap:?}");
        // Step timing: what rounding rates down to whole steps per second costs, a few ticks per block.
        assert!((0.0..1e-3).contains(&gap.step_timing_s), "{gap:?}");
        // Travel: from home (0, 0) to (10, 10) mm, then 80 mm along X from the square's start back at (10, 10) to
        // the line at (90, 10): the bound was handed 0 s, so all of the hops' least time is travel order. Each hop
        // from rest to rest (a servo pen) at the travel feed, 120 mm/s. The diagonal: 14.142 mm less two step
        // diagonals at the diagonal's 2121.3 mm/s² (its X or Y alone, 9.975 mm at 1500 mm/s², take less, 0.163 s):
        // 0.113 14 s of ramps over 6.788 mm and 7.318 mm cruising, 0.174 13 s. Along X, 79.975 mm at X's own
        // 1500 mm/s²: 0.16 s of ramps over 9.6 mm, 70.375 mm cruising, 0.746 46 s (at the diagonal's acceleration,
        // all the bound allowed before, 0.723 s).
        let order = 0.174_13 + 0.746_46;
        let hop = HopTime::of(&p);
        assert!((hop.seconds(10.0, 10.0) + hop.seconds(80.0, 0.0) - order).abs() < 2e-5);
        assert!((gap.travel_order_s - order).abs() < 2e-5, "{gap:?} vs {order}");
        assert!(gap.hops_s >= 0.0, "{gap:?}");
        // The servo's waits: two strokes, so the bound counts the first lift's and the last lift's settle and
        // one clear time for the hop's lift. The plan waits just that: its hop of 80 mm takes longer than the
        // settle, so the hop's lift waits only the clear time. Nothing above the bound.
        assert!(gap.lifts_s.abs() < 1e-9, "{gap:?}");
        assert_eq!(gap.settles_s, 0.0);
    }

    #[test]
    fn a_curve_costs_curves_not_corners() {
        // A quarter circle of radius 20 mm cut into 64 chords: the planner takes its vertices as curve points at
        // √(a·r) (with the axes' acceleration along the normal), so the gap shows curves and no corners.
        let p = MachineProfile::default_plotter();
        let mut moves = Vec::new();
        let mut at = (0i32, 0i32);
        for k in 1..=64 {
            let t = std::f64::consts::FRAC_PI_2 * f64::from(k) / 64.0;
            #[allow(clippy::cast_possible_truncation)]
            let q = ((20.0 * t.sin() * 80.0).round() as i32, ((20.0 - 20.0 * t.cos()) * 80.0).round() as i32);
            moves.push(StepDelta { dx: q.0 - at.0, dy: q.1 - at.1 });
            at = q;
        }
        let steps = StepDrawing::from_strokes(vec![StepStroke { start: StepPos::new(800, 800), moves }]);
        let planned = plan(&p, &steps, homed_position(&p).unwrap(), Lookahead::Whole).unwrap();
        let b = plot_time_lower_bound(&p, &steps, 0.0).unwrap();
        let gap = time_gap(&p, &steps, &planned, &b, false).unwrap();
        // √(1500·20) = 173 mm/s is above the 60 mm/s feed: a radius of 20 mm costs nothing at this acceleration.
        // The bound and the plan differ by the axes' limits along the arc and the rounding only.
        assert!(gap.corners_s.abs() < 1e-6, "{gap:?}");
        assert!(gap.curves_s.abs() < 1e-6, "{gap:?}");
        // At 100 mm/s² the curve's limit √(a_n·20) = 44.7 mm/s falls below the feed: the bound holds the
        // vertices whose verdict reads only the stroke's chords (16 to 48) at that speed as the planner does, so
        // what is left above the bound on the curve is its ends' and chords' share, still no corners.
        let mut slow = p.clone();
        slow.pen.draw_accel_mm_s2 = Some(100.0);
        (slow.axes.x.max_accel_mm_s2, slow.axes.y.max_accel_mm_s2) = (100.0, 100.0);
        let planned = plan(&slow, &steps, homed_position(&slow).unwrap(), Lookahead::Whole).unwrap();
        let b = plot_time_lower_bound(&slow, &steps, 0.0).unwrap();
        let gap = time_gap(&slow, &steps, &planned, &b, false).unwrap();
        assert!(gap.corners_s.abs() < 1e-6, "{gap:?}");
        assert!(gap.curves_s.abs() < 0.005, "{gap:?}");
        assert!((gap.total_s() - (planned.seconds() - b.total_s())).abs() < 1e-9);
    }
}
