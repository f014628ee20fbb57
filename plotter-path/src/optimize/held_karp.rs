//! A tighter lower bound on the pen-up travel of any order: Held and Karp's 1-tree bound with Lagrangian node
//! penalties (Held & Karp, "The traveling-salesman problem and minimum spanning trees", 1970/71), here on the ends
//! of the paths rather than on whole paths.
//!
//! **The graph.** Every open path gives two nodes, its two ends, joined by a *fixed edge* (the path itself, drawn
//! pen-down: it costs no travel). Every closed path gives one node whose position is the set of its allowed seams.
//! The start position, when known, is one more node. A hop between two nodes costs at least `c(a, b)`, the least
//! hop cost ([`HopCost`]) between a point `a` of one and a point `b` of the other. The cost may depend on the
//! hop's direction (a machine whose axes have their own limits, [`crate::motion::hop_time`]); all the argument
//! below needs is that it is symmetric (a hop from `a` to `b` costs what the hop back does, true of any cost of
//! `|dx|` and `|dy|`): then a route's hops, read as undirected edges, each cost at least their edge's cost, and
//! no triangle inequality or other geometry is used.
//!
//! **Why any order costs at least the bound.** Any drawing order is a route: start → hop → one end of a path →
//! its fixed edge → its other end → hop → … (a closed path is entered and left at its one node). Close the route
//! into a cycle through one extra node `D` joined to the start and to the route's last node at no cost. In that
//! cycle every node has exactly two edges. Give every node `x` a penalty `π_x` of any sign (D none) and add
//! `π_u + π_v` to every edge `uv`: the cycle's cost grows by exactly `2·Σπ`. Remove D's two edges: what is left is
//! a spanning tree of the other nodes that contains every fixed edge, so its penalized cost is at least `W(π)`,
//! the least penalized spanning tree containing the fixed edges (found exactly by [`super::boruvka`], from the
//! components the fixed edges make, each component asking the k-d tree for its cheapest penalized hop). D's two
//! edges cost `π_start` and `π_last ≥ min over x ≠ start of π_x`. So every route's hops cost at least
//!
//! `L(π) = W(π) + π_start + min_{x ≠ start} π_x − 2·Σπ`,
//!
//! and with an unknown start (both ends of the route free, the first hop costing at least `c(0)`, a hop of no
//! length): `L(π) = W(π) + (the two least π) − 2·Σπ + c(0)`. With `π = 0` this is the spanning-tree bound; the penalties
//! are then moved by subgradient steps (a node with more than two tree edges gets dearer, a leaf cheaper), which
//! pushes the tree towards a route, and the best `L` seen is the bound. Every `L(π)` is a bound, so stopping after
//! any number of steps is safe; a small margin for floating-point rounding is taken off.
//!
//! The penalties are searched on a sparse graph of candidate hops (each point's nearest points of other nodes), where
//! a step is one Kruskal tree; every few steps the best penalties so far are evaluated on the complete graph, and
//! only those exact values count. The number of steps is fixed (never a clock), so the bound depends only on the
//! input.

use super::boruvka::{EndGraph, Tree, spanning_tree};
use super::hop_cost::HopCost;
use super::kdtree::KdTree;
use crate::geometry::union_find::UnionFind;

/// The least spanning tree of the graph's nodes containing the fixed edges, each hop costing its hop cost plus
/// `π_u + π_v` ([`spanning_tree`]): its cost, every node's number of tree edges, and its hops.
fn penalized_tree(g: &EndGraph, tree: &KdTree, pi: &[f64], hop: &dyn HopCost) -> (f64, Vec<u32>, Vec<(u32, u32, f64)>) {
    let t = spanning_tree(g, tree, pi, hop);
    (t.cost, t.deg, t.edges)
}

/// Candidate hops for the cheap search of penalties: from every point its `K` nearest points of other nodes, and
/// the given tree edges; one entry per node pair, at its least hop cost, sorted by node pair.
fn candidates(g: &EndGraph, tree: &KdTree, hop: &dyn HopCost, extra: &[(u32, u32, f64)]) -> Vec<(u32, u32, f64)> {
    // Closed paths bring many points of one node each: more neighbours reach more nodes.
    let k = if g.points.len() <= 4000 { 24 } else { 10 };
    let mut out: Vec<(u32, u32, f64)> = extra.to_vec();
    let mut found = Vec::new();
    for (i, p) in g.points.iter().enumerate() {
        let me = g.node[i];
        tree.knn(*p, k, &|id| g.node[id as usize] != me, &mut found);
        for &(_, id) in &found {
            let other = g.node[id as usize];
            let q = g.points[id as usize];
            out.push((me.min(other), me.max(other), hop.cost((p[0] - q[0]).abs(), (p[1] - q[1]).abs())));
        }
    }
    out.sort_by(|a, b| (a.0, a.1).cmp(&(b.0, b.1)).then(a.2.total_cmp(&b.2)));
    out.dedup_by(|b, a| (a.0, a.1) == (b.0, b.1));
    out
}

/// The least spanning forest over the candidate hops containing the fixed edges, hops costing `c + π_u + π_v`
/// (Kruskal): its cost and the nodes' degrees. Only steers the search: the bound itself is evaluated exactly.
fn sparse_tree(g: &EndGraph, cands: &[(u32, u32, f64)], pi: &[f64], order: &mut Vec<(f64, u32)>) -> (f64, Vec<u32>) {
    let n = g.nodes;
    let Ok(n32) = u32::try_from(n) else { return (0.0, vec![0; n]) };
    let mut uf = UnionFind((0..n32).collect());
    let mut deg = vec![0u32; n];
    let mut cost = 0.0;
    for &(a, b) in &g.fixed {
        let (ra, rb) = (uf.find(a), uf.find(b));
        if ra != rb {
            uf.0[ra as usize] = rb;
        }
        cost += pi[a as usize] + pi[b as usize];
        deg[a as usize] += 1;
        deg[b as usize] += 1;
    }
    let mut components = n - g.fixed.len();
    order.clear();
    order.extend(
        cands
            .iter()
            .enumerate()
            .map(|(i, &(a, b, c))| (c + (pi[a as usize] + pi[b as usize]), u32::try_from(i).unwrap_or(u32::MAX))),
    );
    order.sort_unstable_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
    for &(c, i) in order.iter() {
        if components <= 1 {
            break;
        }
        let (a, b, _) = cands[i as usize];
        let (ra, rb) = (uf.find(a), uf.find(b));
        if ra != rb {
            uf.0[ra as usize] = rb;
            cost += c;
            deg[a as usize] += 1;
            deg[b as usize] += 1;
            components -= 1;
        }
    }
    (cost, deg)
}

/// `L(π)` from a tree's cost and degrees (see the module docs), with D's edges added to `deg`; a margin for
/// rounding taken off.
fn lagrangian(g: &EndGraph, pi: &[f64], w: f64, deg: &mut [u32], free_start: f64) -> f64 {
    let n = g.nodes;
    let cheapest = |skip: Option<usize>| {
        (0..n).filter(|&x| Some(x) != skip).min_by(|&a, &b| pi[a].total_cmp(&pi[b]).then(a.cmp(&b)))
    };
    let Some(first) = g.start.map_or_else(|| cheapest(None), |s| Some(s as usize)) else { return 0.0 };
    let Some(last) = cheapest(Some(first)) else { return 0.0 };
    deg[first] += 1;
    deg[last] += 1;
    let sum: f64 = pi.iter().sum();
    let l = w + pi[first] + pi[last] - 2.0 * sum + free_start;
    // Rounding: the sums above gather an error of a few units in the last place of their terms' magnitudes.
    l - 1e-9 * (w.abs() + pi.iter().map(|p| p.abs()).sum::<f64>() + free_start)
}

/// The best Held–Karp bound found on the hops of any route through `g` (see the module docs), each hop costing at
/// least its cost under `hop`.
#[cfg(test)]
fn held_karp(g: &EndGraph, hop: &dyn HopCost) -> f64 {
    held_karp_steps(g, hop, HELD_KARP_STEPS)
}

/// Subgradient steps per round of the search, at most.
pub(crate) const HELD_KARP_STEPS: usize = 150;

/// Candidate hops looked at over the whole search (each step sorts them all once): about a quarter of a second.
const WORK: usize = 3_000_000;

/// Rounds of the search (two on drawings of over 5000 points): each ends with one exact evaluation of its best penalties, whose tree's hops join the
/// candidates.
const ROUNDS: usize = 5;

/// [`held_karp`] with `steps` subgradient steps per round.
#[cfg(test)]
fn held_karp_steps(g: &EndGraph, hop: &dyn HopCost, steps: usize) -> f64 {
    if g.nodes < 2 || g.points.is_empty() {
        return 0.0;
    }
    let tree = KdTree::build(&g.points);
    let t0 = spanning_tree(g, &tree, &vec![0.0; g.nodes], hop);
    held_karp_from(g, &tree, t0, hop, steps)
}

/// The best Held–Karp bound found on the hops of any route through `g` (see the module docs), each hop costing at
/// least its cost under `hop`, with `steps` subgradient steps per round, from the k-d tree `tree` of `g.points`
/// and the least tree with no penalties `t0` ([`spanning_tree`]), which the caller has built for its own bounds.
/// The penalties are searched on a sparse graph of candidate hops (cheap, but its trees may cost more than the
/// complete graph's); each round's best penalties are then evaluated exactly on the complete graph (Borůvka with
/// the k-d tree), and only exact values are returned.
pub(crate) fn held_karp_from(g: &EndGraph, tree: &KdTree, t0: Tree, hop: &dyn HopCost, steps: usize) -> f64 {
    let n = g.nodes;
    if n < 2 || g.points.is_empty() {
        return 0.0;
    }
    let free_start = if g.start.is_none() { hop.cost(0.0, 0.0) } else { 0.0 };
    let mut pi = vec![0.0f64; n];
    let (w0, mut deg0, edges0) = (t0.cost, t0.deg, t0.edges);
    let mut best = lagrangian(g, &pi, w0, &mut deg0, free_start).max(0.0);
    if steps == 0 || deg0.iter().all(|&d| d == 2) {
        return best;
    }
    let mut cands = candidates(g, tree, hop, &edges0);
    // A large drawing gets fewer rounds, each exact evaluation costing a spanning tree of all its points.
    let rounds = if g.points.len() > 5000 { 2 } else { ROUNDS };
    let steps = steps.min(WORK / (rounds * cands.len().max(1))).max(5);
    #[allow(clippy::cast_precision_loss, reason = "node counts are far below 2^52")]
    let mut step = 0.05 * w0.abs() / n as f64;
    let mut dir = vec![0.0f64; n];
    let mut order = Vec::new();
    for _ in 0..rounds {
        let mut round_best = (f64::NEG_INFINITY, pi.clone());
        let mut since_better = 0usize;
        let patience = (steps / 10).max(2);
        for _ in 0..steps {
            let (w, mut deg) = sparse_tree(g, &cands, &pi, &mut order);
            let l = lagrangian(g, &pi, w, &mut deg, free_start);
            if l > round_best.0 {
                round_best = (l, pi.clone());
                since_better = 0;
            } else {
                since_better += 1;
                if since_better >= patience {
                    step *= 0.5;
                    since_better = 0;
                }
            }
            if deg.iter().all(|&d| d == 2) {
                break;
            }
            for (x, d) in deg.iter().enumerate() {
                dir[x] = 0.7 * (f64::from(*d) - 2.0) + 0.3 * dir[x];
                pi[x] += step * dir[x];
            }
        }
        pi = round_best.1;
        let (w, mut deg, edges) = penalized_tree(g, tree, &pi, hop);
        best = best.max(lagrangian(g, &pi, w, &mut deg, free_start));
        // Hops the exact tree took that the candidates lacked steer the next round.
        let before = cands.len();
        cands.extend(edges);
        cands.sort_by(|a, b| (a.0, a.1).cmp(&(b.0, b.1)).then(a.2.total_cmp(&b.2)));
        cands.dedup_by(|b, a| (a.0, a.1) == (b.0, b.1));
        if cands.len() == before && deg.iter().all(|&d| d == 2) {
            break;
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::optimize::hop_cost::ByLength;

    fn dist(l: f64) -> f64 {
        l
    }

    /// Open segments given by their ends, and a start.
    fn segments(segs: &[([f64; 2], [f64; 2])], start: Option<[f64; 2]>) -> EndGraph {
        let mut g = EndGraph::default();
        for (i, (a, b)) in segs.iter().enumerate() {
            let i = u32::try_from(i).unwrap();
            g.points.extend([*a, *b]);
            g.node.extend([2 * i, 2 * i + 1]);
            g.fixed.push((2 * i, 2 * i + 1));
        }
        g.nodes = 2 * segs.len();
        if let Some(s) = start {
            g.points.push(s);
            g.node.push(u32::try_from(g.nodes).unwrap());
            g.start = Some(u32::try_from(g.nodes).unwrap());
            g.nodes += 1;
        }
        g
    }

    #[test]
    fn two_opposite_segments_cost_the_hop_across() {
        // Two 10 mm segments pointing away from the start at the origin, north and south, their inner ends 1 mm
        // from it. The spanning tree joins the start to both inner ends: 2 mm. A route draws one segment and must
        // come back from its outer end, 11 mm out, to the other one: at best 1 + 12 = 13 mm (to the inner end).
        let g = segments(&[([0.0, 1.0], [0.0, 11.0]), ([0.0, -1.0], [0.0, -11.0])], Some([0.0, 0.0]));
        let tree = held_karp_steps(&g, &ByLength(&dist), 0);
        assert!((tree - 2.0).abs() < 1e-6, "{tree}");
        let hk = held_karp(&g, &ByLength(&dist));
        assert!(hk <= 13.0 && hk > 12.99, "{hk}");
    }

    #[test]
    fn a_star_of_segments_is_bounded_far_above_its_spanning_tree() {
        // Four segments as above, north, east, south and west. The spanning tree: 4 mm. The best route (found by
        // hand: start, north inner, north outer, east outer, east inner, south inner, south outer, west outer,
        // west inner) hops 1 + 15.556 + 1.414 + 15.556 = 33.527 mm; the bound stays below and well above the tree.
        let segs = [
            ([0.0, 1.0], [0.0, 11.0]),
            ([1.0, 0.0], [11.0, 0.0]),
            ([0.0, -1.0], [0.0, -11.0]),
            ([-1.0, 0.0], [-11.0, 0.0]),
        ];
        let g = segments(&segs, Some([0.0, 0.0]));
        assert!((held_karp_steps(&g, &ByLength(&dist), 0) - 4.0).abs() < 1e-6);
        let route = 1.0 + 2.0 * 242f64.sqrt() + 2f64.sqrt();
        let hk = held_karp(&g, &ByLength(&dist));
        assert!(hk <= route && hk > 25.0, "{hk}");
    }

    #[test]
    fn segments_on_a_line_are_tight() {
        // Ten 1 mm segments along a line, 1 mm apart, the start 1 mm before the first: the best route hops ten
        // times 1 mm, and so does the spanning tree: the bound is exact at once.
        let segs: Vec<_> = (0..10).map(|i| ([f64::from(2 * i + 1), 0.0], [f64::from(2 * i + 2), 0.0])).collect();
        let g = segments(&segs, Some([0.0, 0.0]));
        let hk = held_karp(&g, &ByLength(&dist));
        assert!((hk - 10.0).abs() < 1e-6, "{hk}");
    }
}
