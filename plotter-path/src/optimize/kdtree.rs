//! A static 2-d tree over points, built once by median splits on the wider side (Bentley's k-d tree), stored as a
//! flat preorder array with point ranges per node. It serves two queries the optimizer runs millions of times and
//! that a general R-tree answers more slowly: the `k` nearest points with a caller's filter (neighbour lists), and
//! the nearest point whose label differs from a given one, pruning every subtree that carries only that label
//! (Borůvka's minimum spanning tree in the lower bound).

const LEAF_SIZE: usize = 8;
const NONE: u32 = u32::MAX;
/// Label of a subtree that holds more than one label.
pub(crate) const MIXED: u32 = u32::MAX;

#[derive(Debug, Clone, Copy)]
struct KdNode {
    min: [f64; 2],
    max: [f64; 2],
    lo: u32,
    hi: u32,
    left: u32,
    right: u32,
}

impl KdNode {
    /// How far `q` lies from the box along X and along Y (0 inside it on that axis).
    #[inline]
    fn box_gaps(&self, q: [f64; 2]) -> (f64, f64) {
        let dx = (self.min[0] - q[0]).max(q[0] - self.max[0]).max(0.0);
        let dy = (self.min[1] - q[1]).max(q[1] - self.max[1]).max(0.0);
        (dx, dy)
    }

    #[inline]
    fn box_dist2(&self, q: [f64; 2]) -> f64 {
        let dx = (self.min[0] - q[0]).max(q[0] - self.max[0]).max(0.0);
        let dy = (self.min[1] - q[1]).max(q[1] - self.max[1]).max(0.0);
        dx * dx + dy * dy
    }
}

/// The tree. Points are addressed by their index in the slice given to [`KdTree::build`] ("id"); internally they
/// are stored in tree order ("slot").
#[derive(Debug, Clone)]
pub(crate) struct KdTree {
    pts: Vec<[f64; 2]>,
    ids: Vec<u32>,
    nodes: Vec<KdNode>,
}

impl KdTree {
    /// Build over `points` (fewer than `u32::MAX`).
    pub(crate) fn build(points: &[[f64; 2]]) -> Self {
        let mut items: Vec<([f64; 2], u32)> =
            points.iter().enumerate().map(|(i, p)| (*p, u32::try_from(i).unwrap_or(NONE))).collect();
        let mut nodes = Vec::with_capacity(2 * points.len() / LEAF_SIZE + 1);
        if !items.is_empty() {
            build_node(&mut items, 0, &mut nodes);
        }
        KdTree { pts: items.iter().map(|x| x.0).collect(), ids: items.iter().map(|x| x.1).collect(), nodes }
    }

    /// Number of points.
    pub(crate) fn len(&self) -> usize {
        self.pts.len()
    }

    /// Id of the point stored in `slot`.
    pub(crate) fn id_at(&self, slot: usize) -> u32 {
        self.ids[slot]
    }

    /// Point stored in `slot`.
    pub(crate) fn point_at(&self, slot: usize) -> [f64; 2] {
        self.pts[slot]
    }

    /// The up to `k` nearest points to `q` whose id passes `keep`, as `(squared distance, id)` ascending, into `out`.
    pub(crate) fn knn(&self, q: [f64; 2], k: usize, keep: &impl Fn(u32) -> bool, out: &mut Vec<(f64, u32)>) {
        out.clear();
        if self.nodes.is_empty() || k == 0 {
            return;
        }
        self.knn_rec(0, q, k, keep, out);
    }

    fn knn_rec(&self, n: usize, q: [f64; 2], k: usize, keep: &impl Fn(u32) -> bool, out: &mut Vec<(f64, u32)>) {
        let node = &self.nodes[n];
        if node.left == NONE {
            for slot in node.lo as usize..node.hi as usize {
                let id = self.ids[slot];
                let p = self.pts[slot];
                let d2 = (p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]);
                if (out.len() < k || d2 < out[out.len() - 1].0) && keep(id) {
                    let at = out.partition_point(|e| e.0 <= d2);
                    if out.len() == k {
                        out.pop();
                    }
                    out.insert(at, (d2, id));
                }
            }
            return;
        }
        let (l, r) = (node.left as usize, node.right as usize);
        let (dl, dr) = (self.nodes[l].box_dist2(q), self.nodes[r].box_dist2(q));
        let order = if dl <= dr { [(l, dl), (r, dr)] } else { [(r, dr), (l, dl)] };
        for (child, d) in order {
            if out.len() < k || d < out[out.len() - 1].0 {
                self.knn_rec(child, q, k, keep, out);
            }
        }
    }

    /// For every node, the single label all its points carry, or [`MIXED`]. `labels` is indexed by slot.
    pub(crate) fn node_labels(&self, labels: &[u32], out: &mut Vec<u32>) {
        out.clear();
        out.resize(self.nodes.len(), MIXED);
        // Preorder: children come after their parent, so a reverse sweep sees children first.
        for n in (0..self.nodes.len()).rev() {
            let node = &self.nodes[n];
            out[n] = if node.left == NONE {
                let first = labels[node.lo as usize];
                if labels[node.lo as usize..node.hi as usize].iter().all(|&l| l == first) { first } else { MIXED }
            } else {
                let (a, b) = (out[node.left as usize], out[node.right as usize]);
                if a == b { a } else { MIXED }
            };
        }
    }
}

impl KdTree {
    /// For every node, the least of `weights` (indexed by slot) over its points.
    pub(crate) fn node_min(&self, weights: &[f64], out: &mut Vec<f64>) {
        out.clear();
        out.resize(self.nodes.len(), f64::INFINITY);
        // Preorder: children come after their parent, so a reverse sweep sees children first.
        for n in (0..self.nodes.len()).rev() {
            let node = &self.nodes[n];
            out[n] = if node.left == NONE {
                weights[node.lo as usize..node.hi as usize].iter().copied().fold(f64::INFINITY, f64::min)
            } else {
                out[node.left as usize].min(out[node.right as usize])
            };
        }
    }

    /// The point whose slot label differs from `label` with the least cost `f(|dx|, |dy|) + (w_self + its
    /// weight)` for its offset from `q` (`weights` by slot, `node_min` from [`node_min`](Self::node_min), `f`
    /// non-decreasing in each distance), improving `best = (cost, id)` under the lexicographic order (ties go to
    /// the smaller id). A subtree is skipped when `f` of its box's distances along X and Y plus its least weight
    /// already exceeds the best cost: no point in it can beat it.
    #[allow(clippy::too_many_arguments, reason = "one query's inputs, each read in the inner loop")]
    pub(crate) fn nearest_other_weighted(
        &self,
        q: [f64; 2],
        label: u32,
        (labels, node_labels): (&[u32], &[u32]),
        (weights, node_min): (&[f64], &[f64]),
        w_self: f64,
        f: &dyn Fn(f64, f64) -> f64,
        best: &mut (f64, u32),
    ) {
        if !self.nodes.is_empty() {
            self.weighted_rec(0, q, label, (labels, node_labels), (weights, node_min), w_self, f, best);
        }
    }

    #[allow(clippy::too_many_arguments, reason = "the recursion of the query above")]
    fn weighted_rec(
        &self,
        n: usize,
        q: [f64; 2],
        label: u32,
        (labels, nl): (&[u32], &[u32]),
        (weights, wmin): (&[f64], &[f64]),
        w_self: f64,
        f: &dyn Fn(f64, f64) -> f64,
        best: &mut (f64, u32),
    ) {
        if nl[n] == label {
            return;
        }
        let node = &self.nodes[n];
        if node.left == NONE {
            for slot in node.lo as usize..node.hi as usize {
                if labels[slot] == label {
                    continue;
                }
                let p = self.pts[slot];
                let c = f((p[0] - q[0]).abs(), (p[1] - q[1]).abs()) + (w_self + weights[slot]);
                let id = self.ids[slot];
                if c < best.0 || (c == best.0 && id < best.1) {
                    *best = (c, id);
                }
            }
            return;
        }
        let (l, r) = (node.left as usize, node.right as usize);
        let lb = |c: usize| {
            let (gx, gy) = self.nodes[c].box_gaps(q);
            f(gx, gy) + (w_self + wmin[c])
        };
        let (dl, dr) = (lb(l), lb(r));
        let order = if dl <= dr { [(l, dl), (r, dr)] } else { [(r, dr), (l, dl)] };
        for (child, d) in order {
            if d <= best.0 {
                self.weighted_rec(child, q, label, (labels, nl), (weights, wmin), w_self, f, best);
            }
        }
    }
}

/// A [`KdTree`] whose points can be deleted, answering nearest-remaining-point queries. Every node counts its
/// remaining points and keeps the bounding box of just those; a deletion updates counts and boxes on the way to the
/// root (`O(depth)`), and a query skips empty subtrees and prunes on the shrunken boxes, so queries stay fast even
/// after most points are gone (the greedy ordering deletes all of them, leaving scattered stragglers whose
/// original boxes would otherwise look deceptively close).
#[derive(Debug, Clone)]
pub(crate) struct ShrinkingKdTree {
    tree: KdTree,
    alive: Vec<u32>,
    boxes: Vec<([f64; 2], [f64; 2])>,
    parent: Vec<u32>,
    leaf_of_slot: Vec<u32>,
    slot_of_id: Vec<u32>,
    dead: Vec<bool>,
}

impl ShrinkingKdTree {
    /// Build over `points`; all are present.
    pub(crate) fn build(points: &[[f64; 2]]) -> Self {
        let tree = KdTree::build(points);
        let nn = tree.nodes.len();
        let mut parent = vec![NONE; nn];
        let mut leaf_of_slot = vec![0u32; tree.len()];
        let mut alive = vec![0u32; nn];
        for (n, node) in tree.nodes.iter().enumerate() {
            let n32 = u32::try_from(n).unwrap_or(NONE);
            alive[n] = node.hi - node.lo;
            if node.left == NONE {
                for slot in node.lo..node.hi {
                    leaf_of_slot[slot as usize] = n32;
                }
            } else {
                parent[node.left as usize] = n32;
                parent[node.right as usize] = n32;
            }
        }
        let mut slot_of_id = vec![0u32; tree.len()];
        for (slot, &id) in tree.ids.iter().enumerate() {
            slot_of_id[id as usize] = u32::try_from(slot).unwrap_or(NONE);
        }
        let dead = vec![false; tree.len()];
        let boxes = tree.nodes.iter().map(|n| (n.min, n.max)).collect();
        ShrinkingKdTree { tree, alive, boxes, parent, leaf_of_slot, slot_of_id, dead }
    }

    /// Point ids in tree order: neighbours in space are mostly neighbours in this list.
    pub(crate) fn ids_in_tree_order(&self) -> &[u32] {
        &self.tree.ids
    }

    /// Delete the point `id` (no effect if already deleted).
    pub(crate) fn remove(&mut self, id: u32) {
        let slot = self.slot_of_id[id as usize] as usize;
        if self.dead[slot] {
            return;
        }
        self.dead[slot] = true;
        let empty = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        let leaf = self.leaf_of_slot[slot] as usize;
        let node = self.tree.nodes[leaf];
        let mut b = empty;
        for s in node.lo as usize..node.hi as usize {
            if !self.dead[s] {
                let p = self.tree.pts[s];
                b = ([b.0[0].min(p[0]), b.0[1].min(p[1])], [b.1[0].max(p[0]), b.1[1].max(p[1])]);
            }
        }
        self.boxes[leaf] = b;
        self.alive[leaf] -= 1;
        let mut n = self.parent[leaf];
        while n != NONE {
            let ni = n as usize;
            self.alive[ni] -= 1;
            let (l, r) = (self.tree.nodes[ni].left as usize, self.tree.nodes[ni].right as usize);
            let (bl, br) = (self.boxes[l], self.boxes[r]);
            self.boxes[ni] =
                ([bl.0[0].min(br.0[0]), bl.0[1].min(br.0[1])], [bl.1[0].max(br.1[0]), bl.1[1].max(br.1[1])]);
            n = self.parent[ni];
        }
    }

    #[inline]
    fn box_dist2(&self, n: usize, q: [f64; 2]) -> f64 {
        let (min, max) = self.boxes[n];
        let dx = (min[0] - q[0]).max(q[0] - max[0]).max(0.0);
        let dy = (min[1] - q[1]).max(q[1] - max[1]).max(0.0);
        dx * dx + dy * dy
    }

    /// The remaining point nearest to `q`, as `(squared distance, id)`.
    pub(crate) fn nearest(&self, q: [f64; 2]) -> Option<(f64, u32)> {
        self.nearest_within(q, f64::INFINITY)
    }

    /// The remaining point nearest to `q` no farther than `sqrt(max_d2)`; the radius prunes the search, so a
    /// small one makes the query nearly free.
    pub(crate) fn nearest_within(&self, q: [f64; 2], max_d2: f64) -> Option<(f64, u32)> {
        let mut best = (max_d2.next_up(), NONE);
        if !self.alive.is_empty() && self.alive[0] > 0 {
            self.nearest_rec(0, q, &mut best);
        }
        (best.1 != NONE).then_some(best)
    }

    fn nearest_rec(&self, n: usize, q: [f64; 2], best: &mut (f64, u32)) {
        let node = &self.tree.nodes[n];
        if node.left == NONE {
            for slot in node.lo as usize..node.hi as usize {
                if self.dead[slot] {
                    continue;
                }
                let p = self.tree.pts[slot];
                let d2 = (p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]);
                if d2 < best.0 {
                    *best = (d2, self.tree.ids[slot]);
                }
            }
            return;
        }
        let (l, r) = (node.left as usize, node.right as usize);
        let (dl, dr) = (self.box_dist2(l, q), self.box_dist2(r, q));
        let order = if dl <= dr { [(l, dl), (r, dr)] } else { [(r, dr), (l, dl)] };
        for (child, d) in order {
            if self.alive[child] > 0 && d < best.0 {
                self.nearest_rec(child, q, best);
            }
        }
    }
}

fn build_node(items: &mut [([f64; 2], u32)], offset: usize, nodes: &mut Vec<KdNode>) -> u32 {
    let mut min = [f64::INFINITY; 2];
    let mut max = [f64::NEG_INFINITY; 2];
    for (p, _) in items.iter() {
        for a in 0..2 {
            min[a] = min[a].min(p[a]);
            max[a] = max[a].max(p[a]);
        }
    }
    let me = nodes.len();
    let lo = u32::try_from(offset).unwrap_or(NONE);
    let hi = u32::try_from(offset + items.len()).unwrap_or(NONE);
    nodes.push(KdNode { min, max, lo, hi, left: NONE, right: NONE });
    if items.len() > LEAF_SIZE {
        let axis = usize::from(max[1] - min[1] > max[0] - min[0]);
        let mid = items.len() / 2;
        items.select_nth_unstable_by(mid, |a, b| a.0[axis].total_cmp(&b.0[axis]));
        let (left, right) = items.split_at_mut(mid);
        let l = build_node(left, offset, nodes);
        let r = build_node(right, offset + mid, nodes);
        nodes[me].left = l;
        nodes[me].right = r;
    }
    u32::try_from(me).unwrap_or(NONE)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optimize::rng::SplitMix64;

    fn cloud(n: usize, seed: u64) -> Vec<[f64; 2]> {
        let mut r = SplitMix64::new(seed);
        (0..n).map(|_| [(r.unit() * 100.0).round() / 4.0, r.unit() * 50.0]).collect()
    }

    #[test]
    fn knn_matches_brute_force() {
        let pts = cloud(700, 3);
        let tree = KdTree::build(&pts);
        assert_eq!(tree.len(), 700);
        let mut out = Vec::new();
        for (qi, q) in cloud(60, 9).into_iter().enumerate() {
            let keep = |id: u32| id % 3 != u32::try_from(qi % 3).unwrap_or(0);
            tree.knn(q, 7, &keep, &mut out);
            let mut brute: Vec<(f64, u32)> = pts
                .iter()
                .enumerate()
                .map(|(i, p)| ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2), u32::try_from(i).unwrap_or(0)))
                .filter(|&(_, id)| keep(id))
                .collect();
            brute.sort_by(|a, b| a.0.total_cmp(&b.0));
            let d_tree: Vec<f64> = out.iter().map(|e| e.0).collect();
            let d_brute: Vec<f64> = brute[..7].iter().map(|e| e.0).collect();
            assert_eq!(d_tree, d_brute);
        }
    }

    #[test]
    fn shrinking_tree_finds_the_nearest_remaining_point() {
        let pts = cloud(400, 8);
        let mut tree = ShrinkingKdTree::build(&pts);
        let mut alive = vec![true; pts.len()];
        let mut r = SplitMix64::new(2);
        for step in 0..pts.len() {
            let q = [r.unit() * 100.0, r.unit() * 50.0];
            let got = tree.nearest(q).unwrap();
            let want = (0..pts.len())
                .filter(|&i| alive[i])
                .map(|i| (pts[i][0] - q[0]).powi(2) + (pts[i][1] - q[1]).powi(2))
                .fold(f64::INFINITY, f64::min);
            assert_eq!(got.0, want, "step {step}");
            alive[got.1 as usize] = false;
            tree.remove(got.1);
            tree.remove(got.1);
        }
        assert!(tree.nearest([0.0, 0.0]).is_none());
        let tree = ShrinkingKdTree::build(&pts);
        let q = pts[17];
        assert_eq!(tree.nearest_within(q, 0.0).map(|x| x.0), Some(0.0));
        let far = [q[0] + 1000.0, q[1]];
        assert!(tree.nearest_within(far, 100.0).is_none());
        assert!(tree.nearest_within(far, f64::INFINITY).is_some());
    }

    #[test]
    fn nearest_other_label_matches_brute_force() {
        let pts = cloud(500, 5);
        let tree = KdTree::build(&pts);
        // Label = id / 10 (groups of ten consecutive ids, scattered in space).
        let labels: Vec<u32> = (0..tree.len()).map(|s| tree.id_at(s) / 10).collect();
        let mut nl = Vec::new();
        tree.node_labels(&labels, &mut nl);
        let zero = vec![0.0; tree.len()];
        let mut wmin = Vec::new();
        tree.node_min(&zero, &mut wmin);
        // The squared distance, and a cost that weighs Y twice as much as X and takes the larger.
        let costs: [&dyn Fn(f64, f64) -> f64; 2] = [&|dx, dy| dx * dx + dy * dy, &|dx, dy| dx.max(2.0 * dy)];
        for f in costs {
            for slot in 0..tree.len() {
                let q = tree.point_at(slot);
                let mut best = (f64::INFINITY, u32::MAX);
                tree.nearest_other_weighted(q, labels[slot], (&labels, &nl), (&zero, &wmin), 0.0, f, &mut best);
                let brute = (0..tree.len())
                    .filter(|&s| labels[s] != labels[slot])
                    .map(|s| {
                        let p = tree.point_at(s);
                        (f((p[0] - q[0]).abs(), (p[1] - q[1]).abs()), tree.id_at(s))
                    })
                    .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)))
                    .unwrap();
                assert_eq!(best, brute);
            }
        }
        // A single label everywhere: the root is uniform and nothing is found.
        let same = vec![4; tree.len()];
        tree.node_labels(&same, &mut nl);
        assert_eq!(nl[0], 4);
        let mut best = (f64::INFINITY, u32::MAX);
        tree.nearest_other_weighted([0.0, 0.0], 4, (&same, &nl), (&zero, &wmin), 0.0, costs[0], &mut best);
        assert_eq!(best.1, u32::MAX);
    }
}
