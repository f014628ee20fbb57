//! A lower bound on the pen-up travel of any order of a layer's paths, so a report can say how far from optimal
//! its result is at most.
//!
//! Contract every path to one node whose "position" is the set of places where it can be entered or left (both
//! ends of an open path, every allowed seam vertex of a closed path), and add the start position as a node. The
//! distance between two nodes is the smallest distance between their point sets. Any drawing order makes one hop
//! into every path, and those hops link the nodes into a spanning path, each hop at least as long as the node
//! distance it spans. Hence two bounds, of which the larger is reported:
//!
//! * **Spanning tree**: the hops form a spanning tree, so they cost at least a minimum spanning tree (the classic
//!   MST bound of the travelling-salesman literature, here on contracted nodes);
//! * **Nearest predecessor**: each path's incoming hop costs at least the distance to its nearest other node (the
//!   assignment-style bound, relaxed to one nearest neighbour per path).
//!
//! A third, tighter bound works on the paths' ends rather than whole paths, where an open path's two ends are
//! entry and exit, one each: Held and Karp's penalized spanning trees, see [`super::held_karp`] (the plot-time bound
//! uses it; the optimizer's report keeps the two cheap ones).
//!
//! The MST is found exactly with Borůvka's algorithm ([`super::boruvka`], the one the Held–Karp bound's trees are
//! built with too), on the paths' ends with each open path's two ends joined from the start (a tree of those
//! points containing every path's own join is a tree of the contracted nodes); its first round's answers are the
//! nearest-predecessor costs.
//!
//! **Hop costs.** A hop costs at least its cost under a [`HopCost`]: its length (the optimizer's report), the
//! cheapest time of a hop of that length, or (the plot-time bound) the least time of a hop of its X and Y
//! distances on a machine whose axes each have their own limits ([`crate::motion::hop_time`]). Such a cost
//! depends on the hop's direction, so the trees are built under the cost itself, not under distance. They stay
//! bounds: every argument above charges each hop of an order at least the cost of the node pair it joins, and
//! compares the order's hops with the least tree (or nearest neighbour) under those same pair costs; that needs
//! only that a pair's cost is the least over its points and the same either way round (a cost of `|dx|` and
//! `|dy|` is), not that it is a distance or obeys the triangle inequality.
//!
//! On a layer of a dozen paths or so, the tightest bound of all is the best order itself, found by trying every
//! one (dynamic programming over subsets, see [`super::exact`]); the plot-time bound uses it where it is cheap.
//!
//! Where the layer starts: at the known start position for the first layer; a later layer starts where the
//! previous one ended, which is one of the places where the previous layer's paths can be left (its open paths'
//! ends, its closed paths' allowed seams), so the start node is that whole set of points.
//!
//! When the start position is not known (layers after the first, whose start depends on how earlier layers end),
//! the first hop is only known to cost at least a zero-length hop.

use kurbo::Point;

use super::boruvka::{EndGraph, Tree, spanning_tree};
use super::cost::CostModel;
use super::exact::ExactLayer;
use super::held_karp::{HELD_KARP_STEPS, held_karp_from};
use super::hop_cost::{ByLength, HopCost};
use super::kdtree::KdTree;

/// Both lower bounds on one layer's pen-up cost.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TravelBound {
    /// The spanning-tree bound.
    pub spanning_tree: f64,
    /// The nearest-predecessor bound.
    pub nearest: f64,
    /// The Held–Karp bound on the paths' ends (see [`super::held_karp`]), when computed (0 otherwise).
    pub held_karp: f64,
    /// The best order's own cost on a small layer (see [`super::exact`]), when computed (0 otherwise).
    pub exact: f64,
}

impl TravelBound {
    /// The best (largest) of the bounds.
    pub fn value(&self) -> f64 {
        self.spanning_tree.max(self.nearest).max(self.held_karp).max(self.exact)
    }
}

/// Raw material of the bounds, independent of the cost model: the layer's travel graph and, on a small layer, the
/// layer made ready for the exact solve.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct BoundParts {
    start_known: bool,
    /// The paths' ends as the spanning trees see them.
    graph: EndGraph,
    /// The layer made ready for the exact solve, when it is small enough.
    exact: Option<ExactLayer>,
}

impl BoundParts {
    /// Both bounds under `cost`.
    pub(crate) fn under(&self, cost: &CostModel) -> TravelBound {
        self.mapped(&|d| cost.min_cost_of_length(d))
    }

    /// Both bounds with every hop of length `d` costing `f(d)`, for any `f` that is non-decreasing and ≥ 0 (the
    /// cheapest any hop of length ≥ `d` can be).
    pub(crate) fn mapped(&self, f: &dyn Fn(f64) -> f64) -> TravelBound {
        self.cheap(&ByLength(f))
    }

    /// The spanning-tree and nearest-predecessor bounds under `hop` (see the module docs).
    pub(crate) fn cheap(&self, hop: &dyn HopCost) -> TravelBound {
        let g = &self.graph;
        if g.points.is_empty() {
            return TravelBound::default();
        }
        let tree = KdTree::build(&g.points);
        let t = spanning_tree(g, &tree, &vec![0.0; g.nodes], hop);
        self.cheap_from(&t, hop)
    }

    /// [`cheap`](Self::cheap) from the least tree `t` of the graph with no penalties.
    fn cheap_from(&self, t: &Tree, hop: &dyn HopCost) -> TravelBound {
        let g = &self.graph;
        // Each path's cheapest hop from another node (the start, on no fixed edge, is its own component's root;
        // its cheapest hop is no path's).
        let nn: Vec<f64> = t.first.iter().filter(|x| Some(x.0) != g.start).map(|x| x.1).collect();
        let nn_sum: f64 = nn.iter().sum();
        if self.start_known {
            TravelBound { spanning_tree: t.cost, nearest: nn_sum, ..TravelBound::default() }
        } else {
            let worst = nn.iter().copied().fold(0.0, f64::max);
            let free = hop.cost(0.0, 0.0);
            TravelBound { spanning_tree: t.cost + free, nearest: nn_sum - worst + free, ..TravelBound::default() }
        }
    }

    /// [`mapped`](Self::mapped) with the Held–Karp bound too ([`super::held_karp`]), and on a small layer the exact
    /// best order ([`super::exact`]): tighter, at some tens to a few hundred spanning trees' cost.
    pub(crate) fn mapped_tight(&self, f: &dyn Fn(f64) -> f64) -> TravelBound {
        self.tight(&ByLength(f))
    }

    /// [`cheap`](Self::cheap) with the Held–Karp bound too ([`super::held_karp`]), and on a small layer the exact best
    /// order ([`super::exact`]), each hop charged its cost under `hop`.
    pub(crate) fn tight(&self, hop: &dyn HopCost) -> TravelBound {
        let g = &self.graph;
        if g.points.is_empty() {
            return TravelBound::default();
        }
        // One least tree with no penalties serves both the cheap bounds and the Held–Karp search's first step.
        let tree = KdTree::build(&g.points);
        let t = spanning_tree(g, &tree, &vec![0.0; g.nodes], hop);
        let mut b = self.cheap_from(&t, hop);
        b.held_karp = held_karp_from(g, &tree, t, hop, HELD_KARP_STEPS);
        if let Some(e) = &self.exact {
            b.exact = e.least(hop);
        }
        b
    }
}

/// Bound material for visiting `groups` paths whose entry points are `points` (each tagged in `group` with its
/// path, `0..groups`; every path has at least one point), from one of the points `start` (empty: from anywhere).
/// A path whose `both_ends` is set is open: its two points are its two ends, one where the pen goes down and the
/// other where it comes up; the points of any other path are alternatives (a closed path's seams), any one of
/// them both entry and exit.
pub(crate) fn bound_parts(
    points: &[Point],
    group: &[u32],
    groups: usize,
    both_ends: &[bool],
    start: &[Point],
) -> BoundParts {
    let start_known = !start.is_empty();
    if groups == 0 || u32::try_from(groups + 1).is_err() {
        return BoundParts::default();
    }
    let graph = end_graph(points, group, groups, both_ends, start);
    let exact = (groups <= super::exact::MAX_PATHS)
        .then(|| exact_places(points, group, groups, both_ends))
        .and_then(|places| ExactLayer::new(&places, start_known.then_some(start)));
    BoundParts { start_known, graph, exact }
}

/// Each path's places (its points) and whether it is open, for [`ExactLayer::new`].
fn exact_places(points: &[Point], group: &[u32], groups: usize, both_ends: &[bool]) -> Vec<(Vec<Point>, bool)> {
    let mut places: Vec<(Vec<Point>, bool)> =
        (0..groups).map(|g| (Vec::new(), both_ends.get(g).copied().unwrap_or(false))).collect();
    for (p, &g) in points.iter().zip(group) {
        places[g as usize].0.push(*p);
    }
    places
}

/// The Held–Karp graph of the paths (see [`bound_parts`] and [`super::held_karp`]): an open path's two ends are two nodes
/// joined by a fixed edge, a closed path's seams one node, the start one more.
fn end_graph(points: &[Point], group: &[u32], groups: usize, both_ends: &[bool], start: &[Point]) -> EndGraph {
    let mut g = EndGraph::default();
    // The node of each group's first point, and (open paths) whether that point was seen.
    let mut first: Vec<Option<u32>> = vec![None; groups];
    let mut next = 0u32;
    for (p, &gi) in points.iter().zip(group) {
        let open = both_ends.get(gi as usize).copied().unwrap_or(false);
        let node = match first[gi as usize] {
            Some(a) if open => {
                g.fixed.push((a, next));
                next += 1;
                next - 1
            }
            Some(a) => a,
            None => {
                first[gi as usize] = Some(next);
                next += 1;
                next - 1
            }
        };
        g.points.push([p.x, p.y]);
        g.node.push(node);
    }
    if !start.is_empty() {
        for s in start {
            g.points.push([s.x, s.y]);
            g.node.push(next);
        }
        g.start = Some(next);
        next += 1;
    }
    g.nodes = next as usize;
    g
}

/// Lower bound on the hop cost of visiting `groups` paths (see [`bound_parts`]) under `cost`.
#[cfg(test)]
fn travel_lower_bound(
    points: &[Point],
    group: &[u32],
    groups: usize,
    start: Option<Point>,
    cost: &CostModel,
) -> TravelBound {
    bound_parts(points, group, groups, &vec![true; groups], start.as_slice()).under(cost)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optimize::rng::SplitMix64;

    /// Exact minimum pen-up distance by trying every order and orientation (tiny inputs only).
    fn brute_force(segs: &[(Point, Point)], start: Point) -> f64 {
        fn go(segs: &[(Point, Point)], used: &mut Vec<bool>, at: Point, acc: f64, best: &mut f64) {
            if acc >= *best {
                return;
            }
            if used.iter().all(|&u| u) {
                *best = acc;
                return;
            }
            for i in 0..segs.len() {
                if used[i] {
                    continue;
                }
                used[i] = true;
                let (a, b) = segs[i];
                go(segs, used, b, acc + at.distance(a), best);
                go(segs, used, a, acc + at.distance(b), best);
                used[i] = false;
            }
        }
        let mut best = f64::INFINITY;
        go(segs, &mut vec![false; segs.len()], start, 0.0, &mut best);
        best
    }

    #[test]
    fn bound_never_exceeds_the_optimum_and_is_tight_on_a_line() {
        // Collinear unit segments with unit gaps: the optimum and both bounds are 1 per hop.
        let segs: Vec<(Point, Point)> =
            (0..5).map(|i| (Point::new(f64::from(2 * i + 1), 0.0), Point::new(f64::from(2 * i + 2), 0.0))).collect();
        let (pts, grp) = flatten(&segs);
        let b = travel_lower_bound(&pts, &grp, segs.len(), Some(Point::ZERO), &CostModel::Distance);
        assert!((b.spanning_tree - 5.0).abs() < 1e-12 && (b.nearest - 5.0).abs() < 1e-12, "{b:?}");
        assert!((brute_force(&segs, Point::ZERO) - 5.0).abs() < 1e-12);

        let mut r = SplitMix64::new(11);
        for _ in 0..40 {
            let segs: Vec<(Point, Point)> = (0..6)
                .map(|_| {
                    let a = Point::new(r.unit() * 50.0, r.unit() * 50.0);
                    (a, a + kurbo::Vec2::new(r.unit() * 10.0 - 5.0, r.unit() * 10.0 - 5.0))
                })
                .collect();
            let (pts, grp) = flatten(&segs);
            let opt = brute_force(&segs, Point::ZERO);
            let b = travel_lower_bound(&pts, &grp, segs.len(), Some(Point::ZERO), &CostModel::Distance);
            assert!(b.value() <= opt + 1e-9, "{b:?} > {opt}");
            assert!(b.value() > 0.0);
            // Without a known start the bound can only drop.
            let free = travel_lower_bound(&pts, &grp, segs.len(), None, &CostModel::Distance);
            assert!(free.value() <= b.value() + 1e-9);
        }
    }

    #[test]
    fn mst_matches_prim_on_random_points() {
        let mut r = SplitMix64::new(4);
        let pts: Vec<Point> = (0..300).map(|_| Point::new(r.unit() * 100.0, r.unit() * 100.0)).collect();
        let grp: Vec<u32> = (0..300).collect();
        let b = travel_lower_bound(&pts, &grp, 300, None, &CostModel::Distance);
        let pts: Vec<[f64; 2]> = pts.iter().map(|p| [p.x, p.y]).collect();
        let total = super::super::boruvka::tests::prim(&pts, &|dx, dy| dx.hypot(dy));
        assert!((b.spanning_tree - total).abs() < 1e-9, "{} vs {total}", b.spanning_tree);
    }

    fn flatten(segs: &[(Point, Point)]) -> (Vec<Point>, Vec<u32>) {
        let mut pts = Vec::new();
        let mut grp = Vec::new();
        for (i, (a, b)) in segs.iter().enumerate() {
            pts.extend([*a, *b]);
            grp.extend([u32::try_from(i).unwrap(); 2]);
        }
        (pts, grp)
    }
}
