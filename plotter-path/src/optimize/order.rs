//! Greedy nearest-neighbour ordering with reversal and seam choice.
//!
//! Every place where a path may be entered goes into a shrinking k-d tree: both ends of an open path (only its
//! start when reversal is off) and the seam candidates of a closed path. From the pen position the nearest
//! remaining entry is taken, and all entries of its path are deleted; each query and deletion is `O(log E)`, so the
//! whole order costs `O(E log E)` for `E` entries. (An R-tree with `pop_nearest_neighbor` did the same job at
//! several times the cost, because its removals rebalance nodes; the static tree with per-node live counts never
//! restructures.) Entering an open path at its end means drawing it
//! reversed; entering a closed path at a vertex makes that vertex the seam.

use kurbo::Point;

use super::Visit;
use super::kdtree::ShrinkingKdTree;
use super::seam::{SeamMode, seam_candidates};
use crate::Polyline;

/// Greedy nearest-neighbour order of the paths listed in `ids` (indices into `paths`, each with at least one
/// point), starting from `start`.
pub(crate) fn greedy_order(
    paths: &[Polyline],
    ids: &[u32],
    start: Point,
    seam: SeamMode,
    allow_reverse: bool,
) -> Vec<Visit> {
    // Entries of one path are contiguous: `first[i]..first[i + 1]` for the i-th listed path.
    let mut coords: Vec<[f64; 2]> = Vec::with_capacity(ids.len() * 2);
    let mut data: Vec<(u32, u32)> = Vec::with_capacity(ids.len() * 2);
    let mut first: Vec<u32> = Vec::with_capacity(ids.len() + 1);
    let mut seams = Vec::new();
    for (i, &id) in ids.iter().enumerate() {
        first.push(u32::try_from(coords.len()).unwrap_or(u32::MAX));
        let i32_ = u32::try_from(i).unwrap_or(u32::MAX);
        let path = &paths[id as usize];
        if path.is_closed() {
            seams.clear();
            seam_candidates(path, seam, &mut seams);
            for &v in &seams {
                let p = path.points[v as usize];
                coords.push([p.x, p.y]);
                data.push((i32_, v));
            }
        } else {
            let (Some(a), Some(b)) = (path.start(), path.end()) else { continue };
            coords.push([a.x, a.y]);
            data.push((i32_, 0));
            if allow_reverse && a != b {
                coords.push([b.x, b.y]);
                data.push((i32_, 1));
            }
        }
    }
    first.push(u32::try_from(coords.len()).unwrap_or(u32::MAX));
    let mut tree = ShrinkingKdTree::build(&coords);
    let mut order = Vec::with_capacity(ids.len());
    let mut at = start;
    while let Some((_, e)) = tree.nearest([at.x, at.y]) {
        let (i, k) = data[e as usize];
        for other in first[i as usize]..first[i as usize + 1] {
            tree.remove(other);
        }
        let id = ids[i as usize];
        let path = &paths[id as usize];
        let visit = if path.is_closed() {
            Visit { path: id, reversed: false, seam: k }
        } else {
            Visit { path: id, reversed: k == 1, seam: 0 }
        };
        at = visit.exit(paths);
        order.push(visit);
    }
    order
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pl(pts: &[(f64, f64)]) -> Polyline {
        Polyline::new(pts.iter().map(|&(x, y)| Point::new(x, y)).collect())
    }

    #[test]
    fn picks_nearest_end_reverses_and_rotates_seams() {
        let paths = vec![
            pl(&[(30.0, 0.0), (20.0, 0.0)]), // entered reversed from 20
            pl(&[(1.0, 0.0), (10.0, 0.0)]),  // first
            pl(&[(50.0, 5.0), (40.0, 5.0), (40.0, -5.0), (50.0, -5.0), (50.0, 5.0)]), // square, seam at (40,5)?
        ];
        let ids = [0, 1, 2];
        let order = greedy_order(&paths, &ids, Point::ZERO, SeamMode::Any, true);
        assert_eq!(order.len(), 3);
        assert_eq!(order[0], Visit { path: 1, reversed: false, seam: 0 });
        assert_eq!(order[1], Visit { path: 0, reversed: true, seam: 0 });
        // From (30,0) the nearest square vertex is (40,5) or (40,-5) (both √125); either is index 1 or 2.
        assert_eq!(order[2].path, 2);
        assert!(order[2].seam == 1 || order[2].seam == 2);
        // Without reversal and with fixed seams, path 0 must be entered at (30,0) and the square at (50,5).
        let order = greedy_order(&paths, &ids, Point::ZERO, SeamMode::Keep, false);
        assert_eq!(order[1], Visit { path: 0, reversed: false, seam: 0 });
        assert_eq!(order[2], Visit { path: 2, reversed: false, seam: 0 });
    }
}
