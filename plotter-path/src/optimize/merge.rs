//! Merging: open paths whose ends meet (within a tolerance, in either direction) become one longer path, so the
//! pen stays down across the joint instead of lifting and dropping on the same spot.
//!
//! All open-path ends go into an R-tree (rstar). Paths are taken in input order; each one seeds a chain that is
//! extended at its tail, then at its head, by the nearest unused end within the tolerance — the matched path is
//! reversed when its far end is the one that meets (only when reversal is allowed). Used paths leave the tree, so
//! every lookup is `O(log n)` and the whole merge `O(n log n)`. A chain whose two ends finally meet is closed.
//!
//! Geometry: when two ends coincide exactly, the duplicate vertex is dropped; when they are only within the
//! tolerance, the gap becomes a short pen-down bridge of at most the tolerance (that is what merging within a
//! tolerance means). Closed paths and paths with fewer than two points are left as they are.

use std::collections::VecDeque;

use kurbo::Point;
use rstar::RTree;
use rstar::primitives::GeomWithData;

use crate::Polyline;

type End = GeomWithData<[f64; 2], u32>;

/// What merging did to one layer.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct MergeStats {
    /// Number of joints made (each joint removes one path).
    pub(crate) joins: usize,
    /// Number of chains closed because their ends met.
    pub(crate) closed: usize,
}

fn end_entry(paths: &[Polyline], i: usize, which: u32) -> End {
    let p = if which == 0 { paths[i].points[0] } else { paths[i].points[paths[i].points.len() - 1] };
    let tag = u32::try_from(i).unwrap_or(u32::MAX) * 2 + which;
    GeomWithData::new([p.x, p.y], tag)
}

/// Join the open paths of `paths` whose ends lie within `tolerance` mm. Returns the new path list (chains in the
/// order of their first member; untouched paths keep their relative order) and what was done.
pub(crate) fn merge_paths(paths: Vec<Polyline>, tolerance: f64, allow_reverse: bool) -> (Vec<Polyline>, MergeStats) {
    let mut stats = MergeStats::default();
    let n = paths.len();
    if u32::try_from(n.saturating_mul(2)).is_err() {
        return (paths, stats);
    }
    let mergeable: Vec<bool> = paths.iter().map(|p| p.points.len() >= 2 && !p.is_closed()).collect();
    let mut entries = Vec::new();
    for (i, _) in mergeable.iter().enumerate().filter(|(_, m)| **m) {
        entries.push(end_entry(&paths, i, 0));
        entries.push(end_entry(&paths, i, 1));
    }
    let mut tree = RTree::bulk_load(entries);
    let tol2 = tolerance * tolerance;
    let mut used = vec![false; n];
    let mut out = Vec::with_capacity(n);

    // Remove both ends of path `i` from the tree and mark it used.
    let take = |tree: &mut RTree<End>, used: &mut [bool], i: usize| {
        used[i] = true;
        tree.remove(&end_entry(&paths, i, 0));
        tree.remove(&end_entry(&paths, i, 1));
    };
    // Nearest unused end within the tolerance of `at` whose kind is accepted.
    let find = |tree: &RTree<End>, at: Point, accept: &dyn Fn(u32) -> bool| -> Option<u32> {
        tree.nearest_neighbor_iter_with_distance_2([at.x, at.y])
            .take_while(|(_, d2)| *d2 <= tol2)
            .find(|(e, _)| accept(e.data & 1))
            .map(|(e, _)| e.data)
    };

    for i in 0..n {
        if used[i] {
            continue;
        }
        if !mergeable[i] {
            used[i] = true;
            out.push(paths[i].clone());
            continue;
        }
        take(&mut tree, &mut used, i);
        let mut chain: VecDeque<Point> = paths[i].points.iter().copied().collect();
        // Tail: the next path must start here (or, reversed, end here).
        while let Some(&tail) = chain.back() {
            let Some(tag) = find(&tree, tail, &|k| k == 0 || allow_reverse) else { break };
            let j = (tag / 2) as usize;
            take(&mut tree, &mut used, j);
            let pts = &paths[j].points;
            let forward = tag & 1 == 0;
            let mut seq: Box<dyn Iterator<Item = Point>> =
                if forward { Box::new(pts.iter().copied()) } else { Box::new(pts.iter().rev().copied()) };
            if let Some(first) = seq.next()
                && first != tail
            {
                chain.push_back(first);
            }
            chain.extend(seq);
            stats.joins += 1;
        }
        // Head: the previous path must end here (or, reversed, start here).
        while let Some(&head) = chain.front() {
            let Some(tag) = find(&tree, head, &|k| k == 1 || allow_reverse) else { break };
            let j = (tag / 2) as usize;
            take(&mut tree, &mut used, j);
            let pts = &paths[j].points;
            let ends_here = tag & 1 == 1;
            // Walk the path backwards from the meeting end and push each vertex in front.
            let mut seq: Box<dyn Iterator<Item = Point>> =
                if ends_here { Box::new(pts.iter().rev().copied()) } else { Box::new(pts.iter().copied()) };
            if let Some(first) = seq.next()
                && first != head
            {
                chain.push_front(first);
            }
            for p in seq {
                chain.push_front(p);
            }
            stats.joins += 1;
        }
        let mut pts: Vec<Point> = chain.into();
        if pts.len() > 2 {
            let (a, b) = (pts[0], pts[pts.len() - 1]);
            if a != b && a.distance_squared(b) <= tol2 {
                pts.push(a);
                stats.closed += 1;
            }
        }
        out.push(Polyline::new(pts));
    }
    (out, stats)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pl(pts: &[(f64, f64)]) -> Polyline {
        Polyline::new(pts.iter().map(|&(x, y)| Point::new(x, y)).collect())
    }

    #[test]
    fn joins_exact_ends_in_both_directions_and_closes_the_square() {
        // Four sides of a square, two of them pointing the wrong way, shuffled.
        let paths = vec![
            pl(&[(0.0, 0.0), (10.0, 0.0)]),
            pl(&[(10.0, 10.0), (0.0, 10.0)]),
            pl(&[(10.0, 10.0), (10.0, 0.0)]),
            pl(&[(0.0, 0.0), (0.0, 10.0)]),
        ];
        let (out, stats) = merge_paths(paths, 0.0, true);
        assert_eq!(out.len(), 1);
        assert_eq!(stats.joins, 3);
        assert!(out[0].is_closed());
        assert_eq!(out[0].points.len(), 5);
        assert!((out[0].length() - 40.0).abs() < 1e-12);
    }

    #[test]
    fn tolerance_bridges_gaps_and_respects_no_reverse() {
        let paths = vec![pl(&[(0.0, 0.0), (5.0, 0.0)]), pl(&[(5.05, 0.0), (9.0, 0.0)]), pl(&[(20.0, 0.0), (9.0, 0.0)])];
        // Tolerance too small for the 0.05 mm gap: only the exactly meeting ends at x = 9 join (one reversed).
        let (out, stats) = merge_paths(paths.clone(), 0.01, true);
        assert_eq!((out.len(), stats.joins), (2, 1));
        // 0.1 mm: all three join, the third reversed; one 0.05 mm bridge segment.
        let (out, stats) = merge_paths(paths.clone(), 0.1, true);
        assert_eq!((out.len(), stats.joins, stats.closed), (1, 2, 0));
        assert_eq!(out[0].points.first(), Some(&Point::new(0.0, 0.0)));
        assert_eq!(out[0].points.last(), Some(&Point::new(20.0, 0.0)));
        assert_eq!(out[0].points.len(), 5);
        // Without reversal the third path cannot be attached.
        let (out, stats) = merge_paths(paths, 0.1, false);
        assert_eq!((out.len(), stats.joins), (2, 1));
    }

    #[test]
    fn closed_and_degenerate_paths_are_kept_in_place() {
        let paths = vec![
            pl(&[(0.0, 0.0)]),
            pl(&[(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 0.0)]),
            pl(&[(1.0, 1.0), (2.0, 2.0)]),
            Polyline::default(),
        ];
        let (out, stats) = merge_paths(paths.clone(), 0.5, true);
        assert_eq!(stats.joins, 0);
        assert_eq!(out, paths);
    }

    #[test]
    fn head_extension_keeps_direction() {
        // Seed path in the middle; one path ends at its head, one starts at its tail.
        let paths = vec![pl(&[(5.0, 0.0), (6.0, 0.0)]), pl(&[(6.0, 0.0), (7.0, 0.0)]), pl(&[(4.0, 0.0), (5.0, 0.0)])];
        let (out, _) = merge_paths(paths, 0.0, false);
        assert_eq!(out, vec![pl(&[(4.0, 0.0), (5.0, 0.0), (6.0, 0.0), (7.0, 0.0)])]);
    }
}
