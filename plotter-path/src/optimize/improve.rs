//! Local improvement of a path order: 2-opt and Or-opt moves with path reversal, seam re-choice for closed paths,
//! and optional random segment-swap kicks, all driven by neighbour lists.
//!
//! **Model.** Each path is a node with two ends, its entry and its exit (for a closed path both are its seam
//! vertex). The order is a cycle through all nodes plus one depot node whose "out" end is the start position and
//! whose "in" end is a wildcard reachable from anywhere at zero cost — so the cycle is exactly an open route from the
//! start that may end anywhere. A node carries an orientation flag; reversing a stretch of the cycle reverses the
//! order of its nodes *and* flips each one, which is how paths get reversed.
//!
//! **Moves** (the classic local-search neighbourhoods of Croes' 2-opt and Or's segment insertion, applied here to
//! the "fixed edge" variant where each path is an edge the tour must contain):
//! * 2-opt: drop two hops, reconnect by reversing everything between them;
//! * Or-opt: move a run of one to three paths elsewhere, as it is or reversed;
//! * seam: move a closed path's seam to the vertex cheapest between its neighbours (searched again only once a
//!   neighbouring hop has changed).
//!
//! Candidate moves come from the `k` nearest other ends of each end (a static k-d tree query), and a move is only
//! tried when its first new hop is cheaper than the hop it replaces — the standard neighbour-list pruning of Johnson
//! and McGeoch's TSP experiments. Nodes wait in a queue ("don't-look bits"): a node leaves the queue when no move
//! around it improves, and comes back when a move touches one of its hops, so the search stops by itself at a local
//! optimum.
//!
//! **Representation.** The cycle is an array plus each node's position. A reversal flips whichever side of the
//! cycle is shorter (flipping the other side gives the same cycle read backwards), so it costs at most `n/2`; in
//! addition moves whose reversal would exceed a length cap are skipped, which keeps huge inputs near `n log n`.
//! Or-opt moves are applied as two or three reversals, so one primitive does all edits and every edit can be undone.
//!
//! **Kicks.** Once at a local optimum, the remaining budget goes to a simple iterated local search: swap two short
//! adjacent stretches of the cycle (a segment-insertion "double bridge" no sequence of improving 2-opt moves finds),
//! re-optimize around the cut points, and keep the result only if the total cost went down; otherwise undo it.
//! On large drawings the kicks are tried in two lanes at once ([`kicks`]). All randomness comes from the seed.
//!
//! **Budget.** The work is measured, not timed: every candidate a move looks at (a neighbour of an end, a seam
//! vertex) counts one unit, and the search stops once the units reach the limit. So the result is fixed by the
//! input, the seed and the limit — never by the machine's speed or load.

use std::collections::VecDeque;

use kurbo::Point;

use super::Visit;
use super::cost::{CostModel, HopCost};
use super::kdtree::KdTree;
use super::rng::SplitMix64;
use super::seam::{SeamMode, seam_candidates};
use crate::Polyline;

mod kicks;

const EPS: f64 = 1e-9;

/// Knobs of the improvement step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct ImproveParams {
    /// Neighbour-list length per end.
    pub(crate) neighbours: usize,
    /// Stop once this many candidates have been evaluated, even if not converged; `None`: run to the end.
    pub(crate) work_limit: Option<u64>,
    /// Seed of the queue order and of the kicks.
    pub(crate) seed: u64,
    /// Number of kicks after the first local optimum.
    pub(crate) kicks: usize,
    /// Longest reversal (in nodes) a move may need.
    pub(crate) max_reversal: usize,
    /// Open paths may be drawn backwards (enables 2-opt and reversed Or-opt insertions).
    pub(crate) allow_reverse: bool,
    /// Allowed seams of closed paths.
    pub(crate) seam: SeamMode,
    /// Check the cost after every move against the claimed gain (tests only; `O(n)` per move).
    pub(crate) verify: bool,
    /// The start position is unknown: the hop to the first path costs nothing.
    pub(crate) free_start: bool,
    /// The route must end here (the hop from the last path to it counts); `None`: it may end anywhere.
    pub(crate) end: Option<Point>,
}

/// What the improvement step did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ImproveStats {
    /// 2-opt moves applied.
    pub two_opt_moves: usize,
    /// Or-opt moves applied.
    pub or_opt_moves: usize,
    /// Seam changes applied.
    pub seam_moves: usize,
    /// Kicks tried.
    pub kicks_tried: usize,
    /// Kicks that lowered the cost and were kept.
    pub kicks_kept: usize,
    /// Kicks tried in the second of two lanes and dropped because the first lane kept one of its own at the same
    /// meeting (see the kicks module); they come on top of the kicks asked for.
    pub kicks_dropped: usize,
    /// The work budget ran out before the search finished.
    pub budget_exhausted: bool,
    /// Candidates evaluated (neighbours of ends, seam vertices): the work the budget counts.
    pub work: u64,
}

impl ImproveStats {
    /// Add another layer's counts.
    pub fn add(&mut self, o: &ImproveStats) {
        self.two_opt_moves += o.two_opt_moves;
        self.or_opt_moves += o.or_opt_moves;
        self.seam_moves += o.seam_moves;
        self.kicks_tried += o.kicks_tried;
        self.kicks_kept += o.kicks_kept;
        self.kicks_dropped += o.kicks_dropped;
        self.budget_exhausted |= o.budget_exhausted;
        self.work += o.work;
    }
}

#[derive(Debug, Clone, Copy)]
enum Op {
    Exchange(u32, u32, u32, u32),
    /// A closed path's seam changed: the path, the old seam, the new one.
    Seam(u32, u32, u32),
}

#[derive(Clone)]
struct Tour<'a> {
    n: usize,
    depot: u32,
    wild: u32,
    wild_start: u32,
    tour: Vec<u32>,
    pos: Vec<u32>,
    rev: Vec<bool>,
    pts: Vec<Point>,
    closed: Vec<bool>,
    seam: Vec<u32>,
    seam_off: Vec<u32>,
    seam_list: Vec<u32>,
    /// For each closed path, the points its neighbouring hops meet and its seam when the seam was last found best
    /// between them ([`Tour::try_seam`] skips asking again).
    seam_settled: Vec<Option<([f64; 4], u32)>>,
    nbr_off: Vec<u32>,
    nbrs: Vec<u32>,
    cost: HopCost,
    params: ImproveParams,
    queue: VecDeque<u32>,
    queued: Vec<bool>,
    log: Option<Vec<Op>>,
    gained: f64,
    stats: ImproveStats,
    paths: &'a [Polyline],
    visits: &'a [Visit],
}

/// Improve `visits` (an order of paths drawn from `start`) in place. Returns what was done.
pub(crate) fn improve(
    paths: &[Polyline],
    visits: &mut Vec<Visit>,
    start: Point,
    cost: &CostModel,
    params: ImproveParams,
) -> ImproveStats {
    // With fewer than four paths there is nothing a neighbourhood move can do that the greedy missed often enough
    // to matter; the cycle primitives also assume at least five nodes.
    if visits.len() < 4 || u32::try_from(2 * visits.len() + 2).is_err() {
        return ImproveStats::default();
    }
    let original = visits.clone();
    let mut t = Tour::new(paths, &original, start, cost, params);
    t.local_search();
    t.kick_phase();
    *visits = t.extract();
    t.stats
}

impl<'a> Tour<'a> {
    fn new(
        paths: &'a [Polyline],
        visits: &'a [Visit],
        start: Point,
        cost: &'a CostModel,
        params: ImproveParams,
    ) -> Self {
        let n = visits.len() + 1;
        let depot = u32::try_from(visits.len()).unwrap_or(0);
        let wild = if params.end.is_some() { u32::MAX - 1 } else { 2 * depot };
        let wild_start = if params.free_start { wild + 1 } else { u32::MAX };
        let mut pts = Vec::with_capacity(2 * n);
        let mut closed = Vec::with_capacity(n);
        let mut seam = Vec::with_capacity(n);
        let mut seam_off = Vec::with_capacity(n + 1);
        let mut seam_list = Vec::new();
        for v in visits {
            let path = &paths[v.path as usize];
            pts.push(v.entry(paths));
            pts.push(v.exit(paths));
            let c = path.is_closed();
            closed.push(c);
            seam.push(v.seam);
            seam_off.push(u32::try_from(seam_list.len()).unwrap_or(u32::MAX));
            if c {
                seam_candidates(path, params.seam, &mut seam_list);
            }
        }
        // Depot: side 0 (in) is the wildcard (or the required end), side 1 (out) the start position.
        pts.push(params.end.unwrap_or(start));
        pts.push(start);
        closed.push(false);
        seam.push(0);
        seam_off.push(u32::try_from(seam_list.len()).unwrap_or(u32::MAX));
        seam_off.push(u32::try_from(seam_list.len()).unwrap_or(u32::MAX));

        // Neighbour lists: one k-d tree over every distinct end point (closed paths and the depot contribute one).
        let mut coords = Vec::with_capacity(2 * n);
        let mut ids = Vec::with_capacity(2 * n);
        for k in 0..n {
            let k32 = u32::try_from(k).unwrap_or(0);
            if k32 == depot {
                if !params.free_start {
                    coords.push([start.x, start.y]);
                    ids.push(2 * k32 + 1);
                }
                if let Some(e) = params.end {
                    coords.push([e.x, e.y]);
                    ids.push(2 * k32);
                }
            } else {
                coords.push([pts[2 * k].x, pts[2 * k].y]);
                ids.push(2 * k32);
                if !closed[k] {
                    coords.push([pts[2 * k + 1].x, pts[2 * k + 1].y]);
                    ids.push(2 * k32 + 1);
                }
            }
        }
        let tree = KdTree::build(&coords);
        let kn = params.neighbours.max(1);
        let mut nbr_off = vec![0u32; 2 * n + 1];
        let mut lists: Vec<Vec<u32>> = vec![Vec::new(); 2 * n];
        let mut found = Vec::new();
        for (i, c) in coords.iter().enumerate() {
            let end = ids[i];
            let me = end / 2;
            tree.knn(*c, kn, &|id| ids[id as usize] / 2 != me, &mut found);
            lists[end as usize] = found.iter().map(|&(_, id)| ids[id as usize]).collect();
        }
        for k in 0..n {
            if closed[k] {
                lists[2 * k + 1] = lists[2 * k].clone();
            }
        }
        let mut nbrs = Vec::with_capacity(2 * n * kn);
        for (e, l) in lists.iter().enumerate() {
            nbr_off[e] = u32::try_from(nbrs.len()).unwrap_or(u32::MAX);
            nbrs.extend_from_slice(l);
        }
        nbr_off[2 * n] = u32::try_from(nbrs.len()).unwrap_or(u32::MAX);

        // Initial cycle: depot, then the visits in order.
        let mut tour = Vec::with_capacity(n);
        tour.push(depot);
        tour.extend(0..depot);
        let mut pos = vec![0u32; n];
        for (i, &k) in tour.iter().enumerate() {
            pos[k as usize] = u32::try_from(i).unwrap_or(0);
        }
        let mut order: Vec<u32> = (0..=depot).collect();
        SplitMix64::new(params.seed).shuffle(&mut order);
        Tour {
            n,
            depot,
            wild,
            wild_start,
            tour,
            pos,
            rev: vec![false; n],
            pts,
            closed,
            seam,
            seam_off,
            seam_list,
            seam_settled: vec![None; n],
            nbr_off,
            nbrs,
            cost: HopCost::new(*cost),
            params,
            queue: order.into(),
            queued: vec![true; n],
            log: None,
            gained: 0.0,
            stats: ImproveStats::default(),
            paths,
            visits,
        }
    }

    // ---- cycle primitives ------------------------------------------------------------------------------------

    #[inline]
    fn next(&self, k: u32) -> u32 {
        let p = self.pos[k as usize] as usize + 1;
        self.tour[if p == self.n { 0 } else { p }]
    }

    #[inline]
    fn prev(&self, k: u32) -> u32 {
        let p = self.pos[k as usize] as usize;
        self.tour[if p == 0 { self.n - 1 } else { p - 1 }]
    }

    #[inline]
    fn in_end(&self, k: u32) -> u32 {
        2 * k + u32::from(self.rev[k as usize])
    }

    #[inline]
    fn out_end(&self, k: u32) -> u32 {
        2 * k + 1 - u32::from(self.rev[k as usize])
    }

    /// The depot's wildcard ends: its "in" end always, its "out" end when the start is free.
    #[inline]
    fn is_wild(&self, e: u32) -> bool {
        e == self.wild || e == self.wild_start
    }

    /// Hop cost between two ends (zero to or from a wildcard).
    #[inline]
    fn c(&self, a: u32, b: u32) -> f64 {
        if self.is_wild(a) || self.is_wild(b) {
            0.0
        } else {
            self.cost.cost(self.pts[a as usize], self.pts[b as usize])
        }
    }

    /// Steps forward along the cycle from position `i` to position `j` (both below `n`); no division, as this runs
    /// for every candidate.
    #[inline]
    fn forward(&self, i: usize, j: usize) -> usize {
        if j >= i { j - i } else { j + self.n - i }
    }

    /// Nodes a reversal of cycle positions `i..=j` (forward) really touches (the shorter side).
    fn rev_len(&self, i: u32, j: u32) -> usize {
        let len = self.forward(i as usize, j as usize) + 1;
        len.min(self.n - len)
    }

    fn reverse(&mut self, i: usize, j: usize) {
        let n = self.n;
        let len = (j + n - i) % n + 1;
        let (mut a, mut b, len) = if 2 * len > n { ((j + 1) % n, (i + n - 1) % n, n - len) } else { (i, j, len) };
        for _ in 0..len / 2 {
            let (ka, kb) = (self.tour[a], self.tour[b]);
            self.tour[a] = kb;
            self.tour[b] = ka;
            self.pos[kb as usize] = u32::try_from(a).unwrap_or(0);
            self.pos[ka as usize] = u32::try_from(b).unwrap_or(0);
            self.rev[ka as usize] ^= true;
            self.rev[kb as usize] ^= true;
            a = if a + 1 == n { 0 } else { a + 1 };
            b = if b == 0 { n - 1 } else { b - 1 };
        }
        if len % 2 == 1 {
            let k = self.tour[a] as usize;
            self.rev[k] ^= true;
        }
    }

    /// Replace the cycle's hops {a,b} and {c,d} by {a,c} and {b,d} (b next to a, d next to c, same direction).
    fn exchange(&mut self, a: u32, b: u32, c: u32, d: u32) {
        if self.next(a) == b {
            debug_assert_eq!(self.next(c), d);
            self.reverse(self.pos[b as usize] as usize, self.pos[c as usize] as usize);
        } else {
            debug_assert_eq!(self.prev(a), b);
            debug_assert_eq!(self.prev(c), d);
            self.reverse(self.pos[a as usize] as usize, self.pos[d as usize] as usize);
        }
        if let Some(log) = &mut self.log {
            log.push(Op::Exchange(a, b, c, d));
        }
        for k in [a, b, c, d] {
            self.push(k);
        }
    }

    fn push(&mut self, k: u32) {
        if !self.queued[k as usize] {
            self.queued[k as usize] = true;
            self.queue.push_back(k);
        }
    }

    fn total_cost(&self) -> f64 {
        (0..self.n).map(|i| self.c(self.out_end(self.tour[i]), self.in_end(self.tour[(i + 1) % self.n]))).sum()
    }

    fn applied(&mut self, gain: f64, before: Option<f64>) {
        self.gained += gain;
        if let Some(b) = before {
            let after = self.total_cost();
            assert!((b - gain - after).abs() < 1e-6 * (1.0 + b.abs()), "claimed gain {gain}, cost {b} -> {after}");
        }
    }

    /// Where the neighbour list of `end` sits in `nbrs` (indices, so a move can be applied mid-scan).
    #[inline]
    fn nbr_range(&self, end: u32) -> (usize, usize) {
        let e = end as usize;
        (self.nbr_off[e] as usize, self.nbr_off[e + 1] as usize)
    }

    fn out_of_work(&mut self) -> bool {
        if let Some(limit) = self.params.work_limit
            && self.stats.work >= limit
        {
            self.stats.budget_exhausted = true;
            return true;
        }
        false
    }

    // ---- moves -----------------------------------------------------------------------------------------------

    fn try_two_opt(&mut self, a: u32) -> bool {
        if !self.params.allow_reverse {
            return false;
        }
        let cap = self.params.max_reversal;
        // Forward: hop out(a) → in(b); new hop out(a) – out(c).
        let b = self.next(a);
        let x1 = self.out_end(a);
        let x2 = self.in_end(b);
        let g1 = self.c(x1, x2);
        if g1 > EPS && !self.is_wild(x1) {
            let depot_out = self.out_end(self.depot);
            let (lo, hi) = self.nbr_range(x1);
            let extra = usize::from(self.is_wild(depot_out));
            for i in lo..hi + extra {
                self.stats.work += 1;
                let y = if i < hi { self.nbrs[i] } else { depot_out };
                let cn = y / 2;
                if cn == a || (!self.closed[cn as usize] && y != self.out_end(cn)) {
                    continue;
                }
                let y1 = self.out_end(cn);
                let d1 = self.c(x1, y1);
                if d1 >= g1 {
                    if self.is_wild(y) {
                        continue;
                    }
                    break;
                }
                let dn = self.next(cn);
                let gain = g1 + self.c(y1, self.in_end(dn)) - d1 - self.c(x2, self.in_end(dn));
                if gain > EPS && self.rev_len(self.pos[b as usize], self.pos[cn as usize]) <= cap {
                    let before = self.params.verify.then(|| self.total_cost());
                    self.exchange(a, b, cn, dn);
                    self.applied(gain, before);
                    self.stats.two_opt_moves += 1;
                    return true;
                }
            }
        }
        // Backward: hop out(p) → in(a); new hop in(a) – in(c).
        let p = self.prev(a);
        let x1 = self.in_end(a);
        let x2 = self.out_end(p);
        let g1 = self.c(x2, x1);
        if g1 > EPS && !self.is_wild(x1) {
            let depot_in = self.in_end(self.depot);
            let (lo, hi) = self.nbr_range(x1);
            let extra = usize::from(self.is_wild(depot_in));
            for i in lo..hi + extra {
                self.stats.work += 1;
                let y = if i < hi { self.nbrs[i] } else { depot_in };
                let cn = y / 2;
                if cn == a || (!self.closed[cn as usize] && y != self.in_end(cn)) {
                    continue;
                }
                let y1 = self.in_end(cn);
                let d1 = self.c(x1, y1);
                if d1 >= g1 {
                    if self.is_wild(y) {
                        continue;
                    }
                    break;
                }
                let cp = self.prev(cn);
                let gain = g1 + self.c(self.out_end(cp), y1) - d1 - self.c(x2, self.out_end(cp));
                if gain > EPS && self.rev_len(self.pos[a as usize], self.pos[cp as usize]) <= cap {
                    let before = self.params.verify.then(|| self.total_cost());
                    self.exchange(p, a, cp, cn);
                    self.applied(gain, before);
                    self.stats.two_opt_moves += 1;
                    return true;
                }
            }
        }
        false
    }

    /// Move the run `s1..=s2` (forward, `len` nodes) between `cc` and `dn = next(cc)`, reversed or not.
    fn apply_or(&mut self, s1: u32, s2: u32, cc: u32, dn: u32, reversed: bool) {
        let p = self.prev(s1);
        let nn = self.next(s2);
        self.exchange(p, s1, cc, dn);
        self.exchange(p, cc, nn, s2);
        if !reversed {
            self.exchange(cc, s2, s1, dn);
        }
    }

    fn try_or_opt(&mut self, a: u32) -> bool {
        let cap = self.params.max_reversal;
        for len in 1..=3usize {
            if self.n < len + 4 {
                break;
            }
            let dirs: &[bool] = if len == 1 { &[true] } else { &[true, false] };
            for &fwd in dirs {
                let (mut s1, mut s2) = (a, a);
                for _ in 1..len {
                    if fwd {
                        s2 = self.next(s2);
                    } else {
                        s1 = self.prev(s1);
                    }
                }
                let p = self.prev(s1);
                let nn = self.next(s2);
                let removed = self.c(self.out_end(p), self.in_end(s1)) + self.c(self.out_end(s2), self.in_end(nn))
                    - self.c(self.out_end(p), self.in_end(nn));
                if removed <= EPS {
                    continue;
                }
                let seg_start = self.pos[s1 as usize] as usize;
                let in_seg = |t: &Self, k: u32| t.forward(seg_start, t.pos[k as usize] as usize) < len;
                for head in [true, false] {
                    let x = if head { self.in_end(s1) } else { self.out_end(s2) };
                    if self.is_wild(x) {
                        continue;
                    }
                    let (lo, hi) = self.nbr_range(x);
                    for i in lo..hi {
                        self.stats.work += 1;
                        let y = self.nbrs[i];
                        let cn = y / 2;
                        if in_seg(self, cn) {
                            continue;
                        }
                        let d1 = self.c(x, y);
                        if d1 >= removed {
                            break;
                        }
                        let closed = self.closed[cn as usize];
                        let is_out = closed || y == self.out_end(cn);
                        let is_in = closed || y == self.in_end(cn);
                        // (target hop start, reversed insertion)
                        let mut options: [Option<(u32, bool)>; 2] = [None, None];
                        if is_out {
                            // Target hop cn → next(cn): head meets out(cn) forward, tail meets it reversed.
                            options[0] = Some((cn, !head));
                        }
                        if is_in {
                            // Target hop prev(cn) → cn: tail meets in(cn) forward, head meets it reversed.
                            options[1] = Some((self.prev(cn), head));
                        }
                        for (cc, reversed) in options.into_iter().flatten() {
                            if reversed && !self.params.allow_reverse {
                                continue;
                            }
                            let dn = self.next(cc);
                            if cc == s2 || dn == s1 {
                                continue;
                            }
                            let (oc, idn) = (self.out_end(cc), self.in_end(dn));
                            let add = if reversed {
                                self.c(oc, self.out_end(s2)) + self.c(self.in_end(s1), idn)
                            } else {
                                self.c(oc, self.in_end(s1)) + self.c(self.out_end(s2), idn)
                            } - self.c(oc, idn);
                            let gain = removed - add;
                            if gain > EPS && self.rev_len(self.pos[s1 as usize], self.pos[cc as usize]) <= cap {
                                let before = self.params.verify.then(|| self.total_cost());
                                self.apply_or(s1, s2, cc, dn, reversed);
                                self.applied(gain, before);
                                self.stats.or_opt_moves += 1;
                                return true;
                            }
                        }
                    }
                }
            }
        }
        false
    }

    fn set_seam(&mut self, a: u32, v: u32) {
        let p = self.paths[self.visits[a as usize].path as usize].points[v as usize];
        self.pts[2 * a as usize] = p;
        self.pts[2 * a as usize + 1] = p;
        let old = std::mem::replace(&mut self.seam[a as usize], v);
        if let Some(log) = &mut self.log {
            log.push(Op::Seam(a, old, v));
        }
    }

    /// The points of ends `a` and `b` (a wildcard as infinity), in a fixed order whichever comes first.
    fn hop_ends(&self, a: u32, b: u32) -> [f64; 4] {
        let at = |e: u32| {
            if self.is_wild(e) { [f64::INFINITY; 2] } else { [self.pts[e as usize].x, self.pts[e as usize].y] }
        };
        let (p, q) = (at(a), at(b));
        if p <= q { [p[0], p[1], q[0], q[1]] } else { [q[0], q[1], p[0], p[1]] }
    }

    fn try_seam(&mut self, a: u32) -> bool {
        let ai = a as usize;
        if !self.closed[ai] {
            return false;
        }
        if self.seam_off[ai + 1] - self.seam_off[ai] < 2 {
            return false;
        }
        let (pe, ne) = (self.out_end(self.prev(a)), self.in_end(self.next(a)));
        // The answer depends only on where the two neighbouring hops come from and go to, and on the seam.
        let ends = self.hop_ends(pe, ne);
        if self.seam_settled[ai] == Some((ends, self.seam[ai])) {
            return false;
        }
        self.stats.work += u64::from(self.seam_off[ai + 1] - self.seam_off[ai]);
        let cands = &self.seam_list[self.seam_off[ai] as usize..self.seam_off[ai + 1] as usize];
        let hop = |t: &Self, e: u32, q: Point| if t.is_wild(e) { 0.0 } else { t.cost.cost(t.pts[e as usize], q) };
        let now = self.pts[2 * ai];
        let current = hop(self, pe, now) + hop(self, ne, now);
        let verts = &self.paths[self.visits[ai].path as usize].points;
        let mut best = (current, self.seam[ai]);
        for &v in cands {
            let q = verts[v as usize];
            let c = hop(self, pe, q) + hop(self, ne, q);
            if c < best.0 {
                best = (c, v);
            }
        }
        let gain = current - best.0;
        // The best seam between these neighbours: asked again, the same search finds no gain.
        self.seam_settled[ai] = Some((ends, if gain > EPS { best.1 } else { self.seam[ai] }));
        if gain > EPS {
            let before = self.params.verify.then(|| self.total_cost());
            self.set_seam(a, best.1);
            self.applied(gain, before);
            let (p, n) = (self.prev(a), self.next(a));
            self.push(p);
            self.push(n);
            self.stats.seam_moves += 1;
            return true;
        }
        false
    }

    // ---- drivers ---------------------------------------------------------------------------------------------

    /// Run until the queue is empty (local optimum) or the budget is gone. Returns false when out of work.
    fn local_search(&mut self) -> bool {
        while let Some(a) = self.queue.pop_front() {
            self.queued[a as usize] = false;
            self.stats.work += 1;
            if self.out_of_work() {
                return false;
            }
            while self.try_two_opt(a) || self.try_or_opt(a) || self.try_seam(a) {}
        }
        true
    }

    /// Read the cycle from the depot in the direction that leaves it through the start position.
    fn extract(&self) -> Vec<Visit> {
        let d = self.depot;
        let forward = !self.rev[d as usize];
        let mut out = Vec::with_capacity(self.n - 1);
        let mut k = d;
        for _ in 1..self.n {
            k = if forward { self.next(k) } else { self.prev(k) };
            let flip = self.rev[k as usize] == forward;
            let v = self.visits[k as usize];
            out.push(Visit { path: v.path, reversed: v.reversed ^ flip, seam: self.seam[k as usize] });
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optimize::order::greedy_order;

    pub(super) fn params(verify: bool, kicks: usize) -> ImproveParams {
        ImproveParams {
            neighbours: 6,
            work_limit: None,
            seed: 1,
            kicks,
            max_reversal: usize::MAX,
            allow_reverse: true,
            seam: SeamMode::Any,
            verify,
            free_start: false,
            end: None,
        }
    }

    pub(super) fn random_paths(n: usize, seed: u64) -> Vec<Polyline> {
        let mut r = SplitMix64::new(seed);
        (0..n)
            .map(|i| {
                let a = Point::new(r.unit() * 200.0, r.unit() * 200.0);
                if i % 4 == 0 {
                    // A small closed triangle.
                    let b = a + kurbo::Vec2::new(3.0, 0.0);
                    let c = a + kurbo::Vec2::new(1.0, 4.0);
                    Polyline::new(vec![a, b, c, a])
                } else {
                    Polyline::new(vec![a, a + kurbo::Vec2::new(r.unit() * 20.0 - 10.0, r.unit() * 20.0 - 10.0)])
                }
            })
            .collect()
    }

    pub(super) fn cost_of(paths: &[Polyline], visits: &[Visit], start: Point, cost: &CostModel) -> f64 {
        let mut at = start;
        let mut total = 0.0;
        for v in visits {
            total += cost.cost(at, v.entry(paths));
            at = v.exit(paths);
        }
        total
    }

    #[test]
    fn every_move_changes_the_cost_by_its_claimed_gain() {
        for (seed, cost) in [
            (1u64, CostModel::Distance),
            (
                2,
                CostModel::Time(crate::optimize::cost::TravelTimeModel::from_profile(
                    &crate::MachineProfile::default_plotter(),
                )),
            ),
        ] {
            let paths = random_paths(120, seed);
            let ids: Vec<u32> = (0..120).collect();
            let mut visits = greedy_order(&paths, &ids, Point::ZERO, SeamMode::Any, true);
            let greedy = cost_of(&paths, &visits, Point::ZERO, &cost);
            let stats = improve(&paths, &mut visits, Point::ZERO, &cost, params(true, 200));
            let after = cost_of(&paths, &visits, Point::ZERO, &cost);
            assert!(stats.two_opt_moves > 0 && stats.or_opt_moves > 0 && stats.kicks_tried == 200, "{stats:?}");
            assert!(after < greedy, "{after} !< {greedy}");
            let mut seen: Vec<u32> = visits.iter().map(|v| v.path).collect();
            seen.sort_unstable();
            assert_eq!(seen, ids);
        }
    }

    #[test]
    fn a_seam_settled_between_the_same_neighbours_is_not_searched_again() {
        // Between a line ending at (−1, 0) and one starting at (5, 5), the square's corner (4, 4) is cheapest:
        // 6.40 + 1.41 mm, against 1 + 7.07 at (0, 0), 5 + 5.10 at (4, 0), 4.12 + 5.10 at (0, 4).
        let square = vec![Point::ZERO, Point::new(4.0, 0.0), Point::new(4.0, 4.0), Point::new(0.0, 4.0), Point::ZERO];
        let paths = vec![
            Polyline::new(vec![Point::new(-10.0, 0.0), Point::new(-1.0, 0.0)]),
            Polyline::new(square),
            Polyline::new(vec![Point::new(5.0, 5.0), Point::new(10.0, 5.0)]),
        ];
        let visits: Vec<Visit> = (0..3).map(|path| Visit { path, reversed: false, seam: 0 }).collect();
        let start = Point::new(-10.0, 0.0);
        let mut t = Tour::new(&paths, &visits, start, &CostModel::Distance, params(true, 0));
        assert!(t.try_seam(1));
        assert_eq!(t.seam[1], 2);
        // Asked again with nothing changed: no candidate is looked at.
        let work = t.stats.work;
        assert!(!t.try_seam(1));
        assert_eq!(t.stats.work, work);
        // The next line now starts at (0, 5): the search runs again and moves the seam to (0, 4) (4.12 + 1 mm).
        t.pts[4] = Point::new(0.0, 5.0);
        assert!(t.try_seam(1));
        assert_eq!(t.seam[1], 3);
        assert!(t.stats.work > work);
    }

    #[test]
    fn cycle_distances_by_hand() {
        // Five paths and the depot: a cycle of six positions.
        let paths: Vec<Polyline> =
            (0..5).map(|i| Polyline::new(vec![Point::new(f64::from(i), 0.0), Point::new(f64::from(i), 1.0)])).collect();
        let visits: Vec<Visit> = (0..5).map(|path| Visit { path, reversed: false, seam: 0 }).collect();
        let t = Tour::new(&paths, &visits, Point::ZERO, &CostModel::Distance, params(false, 0));
        let steps = [(1, 3), (0, 5), (4, 1), (5, 0), (2, 2)].map(|(i, j)| t.forward(i, j));
        assert_eq!(steps, [2, 5, 3, 1, 0]);
        // Reversing positions 1..=5 touches five nodes, or one going the other way round: one.
        assert_eq!([t.rev_len(1, 5), t.rev_len(1, 3), t.rev_len(1, 2)], [1, 3, 2]);
    }

    #[test]
    fn same_seed_same_result_and_no_reverse_is_respected() {
        let paths = random_paths(300, 5);
        let ids: Vec<u32> = (0..300).collect();
        let greedy = greedy_order(&paths, &ids, Point::ZERO, SeamMode::Any, true);
        let mut a = greedy.clone();
        let mut b = greedy.clone();
        improve(&paths, &mut a, Point::ZERO, &CostModel::Distance, params(false, 500));
        improve(&paths, &mut b, Point::ZERO, &CostModel::Distance, params(false, 500));
        assert_eq!(a, b);
        let mut p = params(true, 100);
        p.allow_reverse = false;
        let mut c = greedy_order(&paths, &ids, Point::ZERO, SeamMode::Any, false);
        let before = cost_of(&paths, &c, Point::ZERO, &CostModel::Distance);
        let stats = improve(&paths, &mut c, Point::ZERO, &CostModel::Distance, p);
        assert!(c.iter().all(|v| !v.reversed));
        assert_eq!(stats.two_opt_moves, 0);
        assert!(cost_of(&paths, &c, Point::ZERO, &CostModel::Distance) < before);
    }

    #[test]
    fn collinear_segments_reach_the_optimum() {
        // Unit segments along a line, shuffled and randomly flipped: the optimum walks the line once.
        let mut r = SplitMix64::new(3);
        let mut paths: Vec<Polyline> = (0..200)
            .map(|i| {
                let x = f64::from(2 * i + 1);
                let (a, b) = (Point::new(x, 0.0), Point::new(x + 1.0, 0.0));
                Polyline::new(if r.below(2) == 0 { vec![a, b] } else { vec![b, a] })
            })
            .collect();
        r.shuffle(&mut paths);
        let ids: Vec<u32> = (0..200).collect();
        // Start in the middle so the greedy must come back.
        let start = Point::new(150.0, 0.0);
        let mut visits = greedy_order(&paths, &ids, start, SeamMode::Any, true);
        improve(&paths, &mut visits, start, &CostModel::Distance, params(true, 0));
        let after = cost_of(&paths, &visits, start, &CostModel::Distance);
        // Optimum: the start sits on the end x=150 of segment [149,150]; sweep left (74 unit hops), jump from 1 to
        // 151 (150), sweep right (124 unit hops): 348. Going right first costs 449.
        let optimum = 348.0;
        assert!(after <= optimum + 1e-9, "{after} > {optimum}");
    }
}
