//! The least spanning tree of a layer's travel graph under a hop cost, by Borůvka's algorithm: the one tree the
//! travel bound's spanning-tree and nearest-predecessor bounds ([`super::bound`]) and Held and Karp's penalized
//! trees ([`super::held_karp`]) are all built with.
//!
//! The graph ([`EndGraph`]) has nodes, each a set of points where a hop may start or end, and fixed edges (an open
//! path's two ends) that every tree contains. A hop between two points costs the hop cost of their offset
//! ([`HopCost::cost`] of `|dx|`, `|dy|`) plus both nodes' penalties `π`. Every round, each component (the nodes the
//! tree has joined so far) finds its cheapest hop to another component with a k-d tree, which skips a subtree
//! lying wholly inside the asking component, or whose box is already too far along X and Y to hold a cheaper
//! point (the hop cost never falls as either distance grows); all those cheapest hops are added. Ties are broken
//! by point index, so the hops added all belong to one least tree, and rounds at least halve the components:
//! `O(E log E · log n)` for `E` points.
//!
//! The first round's answers, each component's cheapest hop to any other before any hop is added, are kept too:
//! with no penalties and no start among the components, each is a path's nearest predecessor.

use super::hop_cost::HopCost;
use super::kdtree::KdTree;
use crate::geometry::union_find::UnionFind;

/// The travel graph of one layer (see the module docs), for the spanning trees here and the Held–Karp bound
/// ([`super::held_karp::held_karp_from`]).
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct EndGraph {
    /// Every place a hop may start or end (page mm).
    pub(crate) points: Vec<[f64; 2]>,
    /// The node of each point.
    pub(crate) node: Vec<u32>,
    /// Number of nodes.
    pub(crate) nodes: usize,
    /// The two ends of every open path (distinct nodes, each in at most one pair).
    pub(crate) fixed: Vec<(u32, u32)>,
    /// The start position's node, when the start is known.
    pub(crate) start: Option<u32>,
}

/// A least spanning tree (see the module docs).
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct Tree {
    /// Its cost: the hops' costs with both ends' penalties, and the fixed edges' penalties.
    pub(crate) cost: f64,
    /// Every node's number of tree edges (fixed ones included).
    pub(crate) deg: Vec<u32>,
    /// The hops it added: both nodes (lower first) and the hop's cost without penalties.
    pub(crate) edges: Vec<(u32, u32, f64)>,
    /// The first round: each component's node that asked (its root) and its cheapest hop's cost, penalties
    /// included; empty when the fixed edges already join everything.
    pub(crate) first: Vec<(u32, f64)>,
}

/// The least spanning tree of `g` containing its fixed edges, each hop costing its hop cost under `hop` plus its
/// nodes' penalties `pi`, over the k-d tree `tree` of `g.points`.
pub(crate) fn spanning_tree(g: &EndGraph, tree: &KdTree, pi: &[f64], hop: &dyn HopCost) -> Tree {
    let n = g.nodes;
    let Ok(n32) = u32::try_from(n) else { return Tree { deg: vec![0; n], ..Tree::default() } };
    let mut uf = UnionFind((0..n32).collect());
    let mut out = Tree { deg: vec![0u32; n], ..Tree::default() };
    let mut components = n;
    for &(a, b) in &g.fixed {
        let (ra, rb) = (uf.find(a), uf.find(b));
        if ra != rb {
            uf.0[ra as usize] = rb;
            components -= 1;
        }
        out.cost += pi[a as usize] + pi[b as usize];
        out.deg[a as usize] += 1;
        out.deg[b as usize] += 1;
    }
    let f = |dx: f64, dy: f64| hop.cost(dx, dy);
    let slot_node: Vec<u32> = (0..tree.len()).map(|s| g.node[tree.id_at(s) as usize]).collect();
    let weights: Vec<f64> = slot_node.iter().map(|&x| pi[x as usize]).collect();
    let mut wmin = Vec::new();
    tree.node_min(&weights, &mut wmin);
    let mut labels: Vec<u32> = slot_node.iter().map(|&x| uf.find(x)).collect();
    let mut node_labels = Vec::new();
    let none = (f64::INFINITY, u32::MAX, u32::MAX);
    let mut best = vec![none; n];
    let mut first_round = true;
    while components > 1 {
        tree.node_labels(&labels, &mut node_labels);
        best.fill(none);
        for slot in 0..tree.len() {
            let c = labels[slot] as usize;
            let id = tree.id_at(slot);
            let mut found = (best[c].0, u32::MAX);
            let q = tree.point_at(slot);
            let owned = (&labels[..], &node_labels[..]);
            tree.nearest_other_weighted(q, labels[slot], owned, (&weights, &wmin), weights[slot], &f, &mut found);
            if found.1 != u32::MAX {
                let key = (found.0, id.min(found.1), id.max(found.1));
                if key.0 < best[c].0 || (key.0 == best[c].0 && (key.1, key.2) < (best[c].1, best[c].2)) {
                    best[c] = key;
                }
            }
        }
        if first_round {
            first_round = false;
            out.first = (0..n32).filter(|&c| best[c as usize].1 != u32::MAX).map(|c| (c, best[c as usize].0)).collect();
        }
        let mut merged_any = false;
        for &(c, a, b) in &best {
            if a == u32::MAX {
                continue;
            }
            let (na, nb) = (g.node[a as usize], g.node[b as usize]);
            let (ra, rb) = (uf.find(na), uf.find(nb));
            if ra != rb {
                uf.0[ra as usize] = rb;
                out.cost += c;
                out.deg[na as usize] += 1;
                out.deg[nb as usize] += 1;
                out.edges.push((na.min(nb), na.max(nb), c - (pi[na as usize] + pi[nb as usize])));
                components -= 1;
                merged_any = true;
            }
        }
        if !merged_any {
            break;
        }
        for (slot, l) in labels.iter_mut().enumerate() {
            *l = uf.find(slot_node[slot]);
        }
    }
    out
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::optimize::hop_cost::ByLength;
    use crate::optimize::rng::SplitMix64;

    /// Every point its own node, no fixed edges.
    fn singletons(pts: &[[f64; 2]]) -> EndGraph {
        let n = u32::try_from(pts.len()).unwrap();
        EndGraph { points: pts.to_vec(), node: (0..n).collect(), nodes: pts.len(), fixed: Vec::new(), start: None }
    }

    /// Prim's algorithm over every pair, O(n²), under `cost` (of `|dx|`, `|dy|`): the least spanning tree's cost,
    /// the independent answer the trees here and in [`super::super::bound`] are checked against.
    pub(crate) fn prim(pts: &[[f64; 2]], cost: &dyn Fn(f64, f64) -> f64) -> f64 {
        let n = pts.len();
        let mut in_tree = vec![false; n];
        let mut dist = vec![f64::INFINITY; n];
        dist[0] = 0.0;
        let mut total = 0.0;
        for _ in 0..n {
            let u = (0..n).filter(|&i| !in_tree[i]).min_by(|&a, &b| dist[a].total_cmp(&dist[b])).unwrap();
            in_tree[u] = true;
            total += dist[u];
            for v in 0..n {
                if !in_tree[v] {
                    dist[v] = dist[v].min(cost((pts[u][0] - pts[v][0]).abs(), (pts[u][1] - pts[v][1]).abs()));
                }
            }
        }
        total
    }

    /// A cost by X and Y: X costs twice what Y does, and the larger counts (a machine whose X is twice as slow).
    struct Skewed;

    impl HopCost for Skewed {
        fn cost(&self, dx: f64, dy: f64) -> f64 {
            (2.0 * dx).max(dy)
        }

        fn along(&self, d: f64) -> f64 {
            // The cheapest direction: 2·dx = dy with dx² + dy² = d².
            2.0 * d / 5f64.sqrt()
        }
    }

    #[test]
    fn the_tree_is_prim_s_under_a_length_cost_and_a_direction_dependent_one() {
        let mut r = SplitMix64::new(4);
        let pts: Vec<[f64; 2]> = (0..300).map(|_| [r.unit() * 100.0, r.unit() * 100.0]).collect();
        let g = singletons(&pts);
        let kd = KdTree::build(&pts);
        let pi = vec![0.0; pts.len()];
        let length = |d: f64| d;
        let t = spanning_tree(&g, &kd, &pi, &ByLength(&length));
        let want = prim(&pts, &|dx, dy| dx.hypot(dy));
        assert!((t.cost - want).abs() < 1e-9, "{} vs {want}", t.cost);
        assert_eq!(t.edges.len(), 299);
        let t = spanning_tree(&g, &kd, &pi, &Skewed);
        let want = prim(&pts, &|dx, dy| (2.0 * dx).max(dy));
        assert!((t.cost - want).abs() < 1e-9, "{} vs {want}", t.cost);
        // A tree of the skewed cost joins points along X less readily than the length's tree does.
        let along_x: f64 = t.edges.iter().map(|e| (pts[e.0 as usize][0] - pts[e.1 as usize][0]).abs()).sum();
        let t_len = spanning_tree(&g, &kd, &pi, &ByLength(&length));
        let along_x_len: f64 = t_len.edges.iter().map(|e| (pts[e.0 as usize][0] - pts[e.1 as usize][0]).abs()).sum();
        assert!(along_x < along_x_len, "{along_x} vs {along_x_len}");
    }

    #[test]
    fn fixed_edges_are_in_the_tree_and_the_first_round_is_each_component_s_nearest() {
        // Two segments (fixed edges) and a lone point: (0, 0)–(10, 0), (0, 3)–(10, 3), the point (20, 0). Under
        // the skewed cost the segments' ends are 3 apart (along Y), the lone point 2·10 = 20 from (10, 0).
        let g = EndGraph {
            points: vec![[0.0, 0.0], [10.0, 0.0], [0.0, 3.0], [10.0, 3.0], [20.0, 0.0]],
            node: vec![0, 1, 2, 3, 4],
            nodes: 5,
            fixed: vec![(0, 1), (2, 3)],
            start: None,
        };
        let kd = KdTree::build(&g.points);
        let t = spanning_tree(&g, &kd, &[0.0; 5], &Skewed);
        assert!((t.cost - 23.0).abs() < 1e-12, "{t:?}");
        // Ties go to the lower point indices: the hops (0, 0)–(0, 3) and (10, 0)–(20, 0).
        assert_eq!(t.deg, vec![2, 2, 2, 1, 1]);
        // The first round: each segment's cheapest hop is 3 (to the other), the point's 20.
        let mut first: Vec<f64> = t.first.iter().map(|x| x.1).collect();
        first.sort_by(f64::total_cmp);
        assert_eq!(first, vec![3.0, 3.0, 20.0]);
    }
}
