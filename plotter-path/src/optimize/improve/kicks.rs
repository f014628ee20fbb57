//! The kick phase of the improvement (iterated local search): once at a local optimum, swap two short adjacent
//! stretches of the cycle at a random place, re-optimize around the cut points, and keep the result only if the
//! total cost went down; otherwise undo it.
//!
//! **Two lanes.** On a large drawing most kicks are undone (a few percent are kept), so they are tried two at a time
//! from the same state, on two copies of the cycle (on two cores where there are two): each lane tries a batch of
//! [`BATCH`] kicks of its own. Then the lanes meet: when the first lane kept any, its kept kicks stand and the
//! second lane's are dropped (it undoes them and replays the first lane's moves); when only the second lane kept
//! any, the first lane replays them. Both copies leave a meeting in the same state. Which kicks are tried, and what
//! stands, depends only on the drawing, the seed and the work budget — not on the cores or their timing — so the
//! order found is the same on any machine. A drawing below [`TWO_LANES_MIN_NODES`] paths uses one lane.

use std::sync::mpsc;

use super::{EPS, Op, Tour};
use crate::optimize::improve::ImproveStats;
use crate::optimize::rng::SplitMix64;

/// Longest stretch (in paths) a kick moves.
const MAX_RUN: usize = 30;

/// Kicks each lane tries between two meetings.
const BATCH: usize = 4;

/// Paths (plus the depot) from which the kicks run in two lanes.
pub(super) const TWO_LANES_MIN_NODES: usize = 500;

/// One kick: the stretches `tour[i+1 ..= i+l1]` and the `l2` paths after them swap places.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Kick {
    i: usize,
    l1: usize,
    l2: usize,
}

/// The kicks of a phase on a cycle of `n` nodes, drawn from `seed`.
fn draw_kicks(n: usize, count: usize, seed: u64) -> Vec<Kick> {
    let mut rng = SplitMix64::new(seed ^ 0x6b69_636b);
    let run = MAX_RUN.min((n - 4) / 2);
    (0..count)
        .map(|_| {
            let l1 = 1 + rng.below(run);
            let l2 = 1 + rng.below(run);
            Kick { i: rng.below(n), l1, l2 }
        })
        .collect()
}

/// The kicks (indices into the phase's list of `len`) that lane `l` (0 or 1) tries in batch `b`: the first lane
/// `2bB .. 2bB + B`, the second the next `B` (`B` = [`BATCH`]), cut at the list's end.
fn batch_range(len: usize, b: usize, l: usize) -> std::ops::Range<usize> {
    let lo = ((2 * b + l) * BATCH).min(len);
    lo..(lo + BATCH).min(len)
}

/// What a lane reports at a meeting.
struct Report {
    /// The moves of each kick it kept, in order.
    kept: Vec<Vec<Op>>,
    /// The lane's work so far.
    work: u64,
    /// Kicks it tried in the batch.
    tried: usize,
}

/// What the first lane tells the second at a meeting, before its next batch.
struct Meeting {
    /// Undo the kicks it kept in its last batch (the first lane's stand instead).
    undo_own: bool,
    /// Moves to replay (the first lane's kept kicks), in order.
    replay: Vec<Vec<Op>>,
    /// The batch to try next, and the work limit for it.
    batch: usize,
    limit: Option<u64>,
}

impl Tour<'_> {
    /// Run the kick phase (see the module docs).
    pub(super) fn kick_phase(&mut self) {
        if self.stats.budget_exhausted || self.n < 8 {
            return;
        }
        if self.n >= TWO_LANES_MIN_NODES {
            // Up to half as many again in reserve, for the second lane's kicks that are dropped.
            let kicks = draw_kicks(self.n, self.params.kicks.saturating_add(self.params.kicks / 2), self.params.seed);
            self.two_lanes(&kicks, self.params.kicks);
            return;
        }
        let mut log = Vec::new();
        for k in draw_kicks(self.n, self.params.kicks, self.params.seed) {
            if self.out_of_work() {
                return;
            }
            let (kept, finished) = self.try_kick(k, &mut log);
            self.stats.kicks_kept += usize::from(kept);
            if !finished {
                return;
            }
        }
    }

    /// Apply kick `k`, re-optimize and keep it when the cost went down, else undo it. Returns whether it was kept
    /// (its moves are then in `log`) and whether the work budget lasted.
    fn try_kick(&mut self, k: Kick, log: &mut Vec<Op>) -> (bool, bool) {
        let at = |t: &Self, j: usize| t.tour[(k.i + j) % t.n];
        let (l1, l2) = (k.l1, k.l2);
        let (p, s1, s2, nn, cc, dn) =
            (at(self, 0), at(self, 1), at(self, l1), at(self, l1 + 1), at(self, l1 + l2), at(self, l1 + l2 + 1));
        let old = self.c(self.out_end(p), self.in_end(s1))
            + self.c(self.out_end(s2), self.in_end(nn))
            + self.c(self.out_end(cc), self.in_end(dn));
        let new = self.c(self.out_end(p), self.in_end(nn))
            + self.c(self.out_end(cc), self.in_end(s1))
            + self.c(self.out_end(s2), self.in_end(dn));
        self.stats.kicks_tried += 1;
        let before = self.params.verify.then(|| self.total_cost());
        log.clear();
        self.log = Some(std::mem::take(log));
        self.gained = 0.0;
        self.apply_or(s1, s2, cc, dn, false);
        self.applied(old - new, before);
        let finished = self.local_search();
        *log = self.log.take().unwrap_or_default();
        let kept = self.gained > EPS;
        if !kept {
            let before = self.params.verify.then(|| self.total_cost());
            let undone = self.gained;
            self.undo(log);
            self.applied(-undone, before);
        }
        (kept, finished)
    }

    /// Take back the moves of `log` (newest first).
    pub(super) fn undo(&mut self, log: &[Op]) {
        for &op in log.iter().rev() {
            match op {
                Op::Exchange(a, b, c, d) => self.exchange(a, c, b, d),
                Op::Seam(k, old, _) => self.set_seam(k, old),
            }
        }
        self.clear_queue();
    }

    /// Make the moves of `log` again, on a cycle in the state they were first made from.
    fn replay(&mut self, log: &[Op]) {
        for &op in log {
            match op {
                Op::Exchange(a, b, c, d) => self.exchange(a, b, c, d),
                Op::Seam(k, _, new) => self.set_seam(k, new),
            }
        }
        self.clear_queue();
    }

    fn clear_queue(&mut self) {
        while let Some(k) = self.queue.pop_front() {
            self.queued[k as usize] = false;
        }
    }

    /// Try the kicks of `batch` (kept ones stay applied); see [`Report`].
    fn run_batch(&mut self, batch: &[Kick]) -> Report {
        let mut kept = Vec::new();
        let mut tried = 0;
        for &k in batch {
            if self.out_of_work() {
                break;
            }
            let mut log = Vec::new();
            tried += 1;
            let (keep, finished) = self.try_kick(k, &mut log);
            if keep {
                kept.push(log);
            }
            if !finished {
                break;
            }
        }
        Report { kept, work: self.stats.work, tried }
    }

    /// The kicks in two lanes (see the module docs): `self` is the first lane and ends in the phase's result.
    /// Kicks are taken from `kicks` in order until `count` of them have been tried with a result that could stand
    /// (the second lane's dropped at a meeting do not count), so the phase tries as many as one lane would.
    fn two_lanes(&mut self, kicks: &[Kick], count: usize) {
        let mut second = self.clone();
        second.stats = ImproveStats::default();
        let limit = self.params.work_limit;
        let lane = |b: usize, l: usize| &kicks[batch_range(kicks.len(), b, l)];
        let (to_second, orders) = mpsc::channel::<Meeting>();
        let (reports, from_second) = mpsc::channel::<Report>();
        let mut kept = 0;
        std::thread::scope(|s| {
            let second = &mut second;
            s.spawn(move || {
                let mut own: Vec<Vec<Op>> = Vec::new();
                for m in orders {
                    if m.undo_own {
                        for log in own.iter().rev() {
                            second.undo(log);
                        }
                    }
                    for log in &m.replay {
                        second.replay(log);
                    }
                    second.params.work_limit = m.limit;
                    let r = second.run_batch(lane(m.batch, 1));
                    own.clone_from(&r.kept);
                    if reports.send(r).is_err() {
                        break;
                    }
                }
            });
            let (mut undo_own, mut replay) = (false, Vec::new());
            let mut second_work = 0;
            let mut counted = 0;
            for b in 0.. {
                if counted >= count || lane(b, 0).is_empty() {
                    break;
                }
                // Each lane may use what the two have left of the budget: the limits follow from the work done so
                // far, so they are the same on any machine.
                let left = limit.map(|l| l.saturating_sub(self.stats.work + second_work));
                if left == Some(0) {
                    self.stats.budget_exhausted = true;
                    break;
                }
                let meeting = Meeting {
                    undo_own,
                    replay: std::mem::take(&mut replay),
                    batch: b,
                    limit: left.map(|l| second_work + l),
                };
                if to_second.send(meeting).is_err() {
                    break;
                }
                self.params.work_limit = left.map(|l| self.stats.work + l);
                let first = self.run_batch(lane(b, 0));
                let Ok(other) = from_second.recv() else { break };
                second_work = other.work;
                counted += first.tried;
                if first.kept.is_empty() {
                    counted += other.tried;
                    kept += other.kept.len();
                    for log in &other.kept {
                        self.replay(log);
                    }
                    undo_own = false;
                } else {
                    kept += first.kept.len();
                    self.stats.kicks_dropped += other.tried;
                    undo_own = true;
                    replay = first.kept;
                }
                // A lane that ran out of work leaves nothing for the next meeting, which then stops.
            }
            drop(to_second);
        });
        self.params.work_limit = limit;
        self.stats.add(&second.stats);
        self.stats.kicks_kept += kept;
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::{cost_of, params, random_paths};
    use super::super::{ImproveParams, Visit, improve};
    use super::*;
    use crate::optimize::cost::CostModel;
    use crate::optimize::order::greedy_order;
    use crate::optimize::seam::SeamMode;
    use kurbo::Point;

    /// The cycle's whole state: order, positions, orientations, seams, end points.
    type State = (Vec<u32>, Vec<u32>, Vec<bool>, Vec<u32>, Vec<Point>);

    /// The state of `t`, to compare two copies.
    fn state(t: &Tour) -> State {
        (t.tour.clone(), t.pos.clone(), t.rev.clone(), t.seam.clone(), t.pts.clone())
    }

    /// `n` random paths from `seed`, their ids, and the greedy route through them from the origin.
    fn greedy_route(n: usize, seed: u64) -> (Vec<crate::Polyline>, Vec<u32>, Vec<Visit>) {
        let paths = random_paths(n, seed);
        let ids: Vec<u32> = (0..u32::try_from(n).unwrap()).collect();
        let greedy = greedy_order(&paths, &ids, Point::ZERO, SeamMode::Any, true);
        (paths, ids, greedy)
    }

    /// `route` improved with `p` (distance cost, from the origin), and what the improvement did.
    fn improved(paths: &[crate::Polyline], route: &[Visit], p: ImproveParams) -> (Vec<Visit>, ImproveStats) {
        let mut v = route.to_vec();
        let stats = improve(paths, &mut v, Point::ZERO, &CostModel::Distance, p);
        (v, stats)
    }

    #[test]
    fn a_kept_kick_replayed_on_a_copy_gives_the_same_cycle_and_undo_restores_it() {
        // Closed squares among open lines, so kept kicks include seam moves.
        let mut paths = random_paths(200, 8);
        paths.extend((0..40).map(|i| {
            let (x, y) = (f64::from(i % 8) * 25.0, f64::from(i / 8) * 30.0);
            let c = [(0.0, 0.0), (3.0, 0.0), (3.0, 3.0), (0.0, 3.0), (0.0, 0.0)];
            crate::Polyline::new(c.iter().map(|&(a, b)| Point::new(x + a, y + b)).collect())
        }));
        let ids: Vec<u32> = (0..240).collect();
        let visits = greedy_order(&paths, &ids, Point::ZERO, SeamMode::Any, true);
        let mut t = Tour::new(&paths, &visits, Point::ZERO, &CostModel::Distance, params(true, 0));
        t.local_search();
        let (mut kept_any, mut seams) = (false, false);
        for k in draw_kicks(t.n, 300, 4) {
            let copy = t.clone();
            let mut log = Vec::new();
            let (kept, finished) = t.try_kick(k, &mut log);
            assert!(finished);
            if !kept {
                assert_eq!(state(&t), state(&copy), "an unkept kick leaves the cycle as it was");
                continue;
            }
            kept_any = true;
            seams |= log.iter().any(|op| matches!(op, Op::Seam(..)));
            let mut replayed = copy.clone();
            replayed.replay(&log);
            assert_eq!(state(&replayed), state(&t));
            assert!(replayed.queue.is_empty() && replayed.queued.iter().all(|q| !q));
            replayed.undo(&log);
            assert_eq!(state(&replayed), state(&copy));
        }
        assert!(kept_any && seams, "some kicks kept, some with seam moves");
    }

    #[test]
    fn two_lanes_give_one_answer_and_every_move_its_claimed_gain() {
        // 1,200 paths: above the two-lane threshold. With `verify` every move of both lanes is checked against the
        // whole cycle's cost; the result never costs more than the first local optimum (no kicks).
        let n = 1200;
        assert!(n + 1 >= TWO_LANES_MIN_NODES);
        let (paths, ids, greedy) = greedy_route(n, 21);
        let run = |kicks: usize, verify: bool| improved(&paths, &greedy, params(verify, kicks));
        let (settled, _) = run(0, false);
        let (a, sa) = run(600, true);
        let (b, sb) = run(600, false);
        assert_eq!(a, b, "the same order whatever the threads' timing");
        assert_eq!((sa.kicks_tried, sa.kicks_kept), (sb.kicks_tried, sb.kicks_kept));
        // 600 kicks count (the last meeting may go past by less than a batch per lane); the second lane's dropped
        // at a meeting come on top.
        let counted = sa.kicks_tried - sa.kicks_dropped;
        assert!((600..600 + 2 * BATCH).contains(&counted), "{sa:?}");
        assert!(sa.kicks_dropped > 0, "{sa:?}");
        assert!(sa.kicks_kept > 0, "{sa:?}");
        let mut seen: Vec<u32> = a.iter().map(|v: &Visit| v.path).collect();
        seen.sort_unstable();
        assert_eq!(seen, ids);
        let cost = |v: &[Visit]| cost_of(&paths, v, Point::ZERO, &CostModel::Distance);
        assert!(cost(&a) < cost(&settled), "{} !< {}", cost(&a), cost(&settled));
    }

    #[test]
    fn batches_take_the_kicks_in_turn_by_hand() {
        // B = 4: batch 0 is kicks 0..4 (first lane) and 4..8 (second), batch 1 8..12 and 12..16; a list of 10
        // ends inside batch 1's first half.
        assert_eq!(BATCH, 4);
        assert_eq!([batch_range(100, 0, 0), batch_range(100, 0, 1)], [0..4, 4..8]);
        assert_eq!([batch_range(100, 1, 0), batch_range(100, 1, 1)], [8..12, 12..16]);
        assert_eq!(batch_range(100, 12, 1), 100..100);
        assert_eq!([batch_range(10, 1, 0), batch_range(10, 1, 1)], [8..10, 10..10]);
    }

    #[test]
    fn a_budget_of_one_unit_past_the_local_optimum_lets_each_lane_start_one_kick() {
        let (paths, _, greedy) = greedy_route(1100, 9);
        let (_, settled) = improved(&paths, &greedy, params(false, 0));
        let mut p = params(false, 500);
        p.work_limit = Some(settled.work + 1);
        let (_, stats) = improved(&paths, &greedy, p);
        // Both lanes meet with one unit left: each may start one kick, whose re-optimization then runs out.
        assert!(stats.budget_exhausted);
        assert_eq!(stats.kicks_tried, 2, "{stats:?}");
    }

    #[test]
    fn two_lanes_share_the_work_budget() {
        let (paths, _, greedy) = greedy_route(1100, 5);
        let (_, free) = improved(&paths, &greedy, params(false, 2000));
        let (_, settled) = improved(&paths, &greedy, params(false, 0));
        // A limit a third of the way into the kicks stops them, both lanes counted: the work stays within one
        // batch's worth of the limit.
        let limit = free.work - (free.work - settled.work) * 2 / 3;
        let mut p = params(false, 2000);
        p.work_limit = Some(limit);
        let (_, capped) = improved(&paths, &greedy, p);
        assert!(capped.budget_exhausted && !free.budget_exhausted);
        assert!(capped.kicks_tried < free.kicks_tried, "{capped:?} vs {free:?}");
        assert!(capped.work >= limit && capped.work < limit + free.work / 20, "{} vs limit {limit}", capped.work);
    }
}
