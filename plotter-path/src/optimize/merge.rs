//! Merging: open paths whose ends meet (within a tolerance, in either direction) become one longer path, so the
//! pen stays down across the joint instead of lifting and dropping on the same spot.
//!
//! All open-path starts and ends go into two shrinking k-d trees. Paths are taken in the trees' spatial order
//! (for cache locality; each chain is put back at its seed's input position); each one seeds a chain that is
//! extended at its tail, then at its head, by the nearest unused end within the tolerance — the matched path is
//! reversed when its far end is the one that meets (only when reversal is allowed). Used paths leave the trees, so
//! every lookup is `O(log n)` and the whole merge `O(n log n)`, even when many ends meet at one
//! point. A chain whose two ends finally meet is closed. (An rstar R-tree did the same with removals several times
//! slower; see the benchmark notes.)
//!
//! Geometry: when two ends coincide exactly, the duplicate vertex is dropped; when they are only within the
//! tolerance, the gap becomes a short pen-down bridge of at most the tolerance (that is what merging within a
//! tolerance means). A closed path joins through its seam vertex (both its ends); paths with fewer than two points
//! are left as they are.

use std::collections::VecDeque;

use kurbo::Point;

use super::kdtree::ShrinkingKdTree;
use crate::Polyline;

/// What merging did to one layer.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct MergeStats {
    /// Number of joints made (each joint removes one path).
    pub(crate) joins: usize,
    /// Number of chains closed because their ends met.
    pub(crate) closed: usize,
}

/// Start points and end points of the mergeable paths, each in a shrinking k-d tree (id = rank among mergeable).
struct Ends {
    trees: [ShrinkingKdTree; 2],
    tol2: f64,
}

impl Ends {
    /// Nearest remaining end of kind `kinds` (0 = start, 1 = end) within the tolerance of `at`: (rank, kind).
    fn find(&self, at: Point, kinds: &[usize]) -> Option<(u32, usize)> {
        kinds
            .iter()
            .filter_map(|&k| self.trees[k].nearest_within([at.x, at.y], self.tol2).map(|(d2, id)| (d2, id, k)))
            .min_by(|a, b| a.0.total_cmp(&b.0).then(a.2.cmp(&b.2)))
            .map(|(_, id, k)| (id, k))
    }

    fn take(&mut self, rank: u32) {
        self.trees[0].remove(rank);
        self.trees[1].remove(rank);
    }
}

/// Join the open paths of `paths` whose ends lie within `tolerance` mm. Returns the new path list (each chain at the
/// input position of the path it grew from; untouched paths keep their relative order) and what was done.
pub(crate) fn merge_paths(paths: Vec<Polyline>, tolerance: f64, allow_reverse: bool) -> (Vec<Polyline>, MergeStats) {
    let mut stats = MergeStats::default();
    let n = paths.len();
    if u32::try_from(n).is_err() {
        return (paths, stats);
    }
    // A closed path takes part through its seam (its first and last point), as vpype's `linemerge` does: a path
    // ending where a loop starts is drawn on around the loop without a lift.
    let mergeable: Vec<bool> = paths.iter().map(|p| p.points.len() >= 2).collect();
    let members: Vec<usize> = (0..n).filter(|&i| mergeable[i]).collect();
    let mut rank = vec![u32::MAX; n];
    for (r, &i) in members.iter().enumerate() {
        rank[i] = u32::try_from(r).unwrap_or(u32::MAX);
    }
    let point_of = |i: usize, k: usize| {
        let pts = &paths[i].points;
        let p = if k == 0 { pts[0] } else { pts[pts.len() - 1] };
        [p.x, p.y]
    };
    let starts: Vec<[f64; 2]> = members.iter().map(|&i| point_of(i, 0)).collect();
    let ends: Vec<[f64; 2]> = members.iter().map(|&i| point_of(i, 1)).collect();
    let mut index =
        Ends { trees: [ShrinkingKdTree::build(&starts), ShrinkingKdTree::build(&ends)], tol2: tolerance * tolerance };
    // At the tail the next path must start there (or, reversed, end there); at the head the previous one must end
    // there (or, reversed, start there).
    let (tail_kinds, head_kinds): (&[usize], &[usize]) = if allow_reverse { (&[0, 1], &[1, 0]) } else { (&[0], &[1]) };
    let mut used = vec![false; n];
    let mut out: Vec<(usize, Polyline)> = Vec::with_capacity(n);
    // Seeds in space-filling (tree) order, so consecutive lookups hit warm memory; the output is put back into
    // input order afterwards (each chain at its seed's position).
    let seeds: Vec<usize> = index.trees[0]
        .ids_in_tree_order()
        .iter()
        .map(|&r| members[r as usize])
        .chain((0..n).filter(|&i| !mergeable[i]))
        .collect();
    for i in seeds {
        if used[i] {
            continue;
        }
        used[i] = true;
        if !mergeable[i] {
            out.push((i, paths[i].clone()));
            continue;
        }
        index.take(rank[i]);
        let mut chain: VecDeque<Point> = paths[i].points.iter().copied().collect();
        while let Some(&tail) = chain.back() {
            let Some((r, kind)) = index.find(tail, tail_kinds) else { break };
            index.take(r);
            let j = members[r as usize];
            used[j] = true;
            let pts = &paths[j].points;
            let seq: Box<dyn Iterator<Item = &Point>> =
                if kind == 0 { Box::new(pts.iter()) } else { Box::new(pts.iter().rev()) };
            let mut seq = seq.copied().peekable();
            if seq.peek() == Some(&tail) {
                seq.next();
            }
            chain.extend(seq);
            stats.joins += 1;
        }
        while let Some(&head) = chain.front() {
            let Some((r, kind)) = index.find(head, head_kinds) else { break };
            index.take(r);
            let j = members[r as usize];
            used[j] = true;
            let pts = &paths[j].points;
            // Walk the path away from the meeting end and push each vertex in front.
            let seq: Box<dyn Iterator<Item = &Point>> =
                if kind == 1 { Box::new(pts.iter().rev()) } else { Box::new(pts.iter()) };
            let mut seq = seq.copied().peekable();
            if seq.peek() == Some(&head) {
                seq.next();
            }
            for p in seq {
                chain.push_front(p);
            }
            stats.joins += 1;
        }
        let mut pts: Vec<Point> = chain.into();
        if pts.len() > 2 {
            let (a, b) = (pts[0], pts[pts.len() - 1]);
            if a != b && a.distance_squared(b) <= index.tol2 {
                pts.push(a);
                stats.closed += 1;
            }
        }
        out.push((i, Polyline { points: pts, pen: paths[i].pen }));
    }
    out.sort_unstable_by_key(|e| e.0);
    (out.into_iter().map(|e| e.1).collect(), stats)
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
    fn degenerate_paths_are_kept_in_place_and_loops_join_at_their_seam() {
        let paths = vec![
            pl(&[(0.0, 0.0)]),
            pl(&[(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 0.0)]),
            pl(&[(1.0, 1.0), (2.0, 2.0)]),
            Polyline::default(),
        ];
        // Nothing meets the loop's seam (0, 0) but the single point, which is not a path to draw.
        let (out, stats) = merge_paths(paths.clone(), 0.5, true);
        assert_eq!(stats.joins, 0);
        assert_eq!(out, paths);
        // A stroke ending at the seam is drawn on around the loop: one path of 5 points, 3 + 1 + 1 + √2 mm long.
        let paths = vec![pl(&[(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 0.0)]), pl(&[(-3.0, 0.0), (0.0, 0.0)])];
        let (out, stats) = merge_paths(paths, 0.0, true);
        assert_eq!((out.len(), stats.joins), (1, 1));
        assert_eq!(out[0].points.len(), 5);
        assert!((out[0].length() - (3.0 + 2.0 + 2f64.sqrt())).abs() < 1e-12);
    }

    #[test]
    fn head_extension_keeps_direction() {
        // Seed path in the middle; one path ends at its head, one starts at its tail.
        let paths = vec![pl(&[(5.0, 0.0), (6.0, 0.0)]), pl(&[(6.0, 0.0), (7.0, 0.0)]), pl(&[(4.0, 0.0), (5.0, 0.0)])];
        let (out, _) = merge_paths(paths, 0.0, false);
        assert_eq!(out, vec![pl(&[(4.0, 0.0), (5.0, 0.0), (6.0, 0.0), (7.0, 0.0)])]);
    }
}
