//! Greedy nearest-neighbour ordering with reversal and seam choice.
//!
//! Every place where a path may be entered goes into an R-tree (rstar): both ends of an open path (only its start
//! when reversal is off) and the seam candidates of a closed path. From the pen position the nearest entry is popped
//! repeatedly; an entry whose path was already drawn is discarded (lazy deletion), so each entry is popped at most
//! once and the whole order costs `O(E log E)` for `E` entries. Entering an open path at its end means drawing it
//! reversed; entering a closed path at a vertex makes that vertex the seam.

use kurbo::Point;
use rstar::RTree;
use rstar::primitives::GeomWithData;

use super::Visit;
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
    let mut entries: Vec<GeomWithData<[f64; 2], (u32, u32)>> = Vec::with_capacity(ids.len() * 2);
    let mut seams = Vec::new();
    for &id in ids {
        let path = &paths[id as usize];
        if path.is_closed() {
            seams.clear();
            seam_candidates(path, seam, &mut seams);
            for &v in &seams {
                let p = path.points[v as usize];
                entries.push(GeomWithData::new([p.x, p.y], (id, v)));
            }
        } else {
            let (Some(a), Some(b)) = (path.start(), path.end()) else { continue };
            entries.push(GeomWithData::new([a.x, a.y], (id, 0)));
            if allow_reverse && a != b {
                entries.push(GeomWithData::new([b.x, b.y], (id, 1)));
            }
        }
    }
    let mut tree = RTree::bulk_load(entries);
    let mut done = vec![false; paths.len()];
    let mut order = Vec::with_capacity(ids.len());
    let mut at = start;
    while order.len() < ids.len() {
        let Some(e) = tree.pop_nearest_neighbor([at.x, at.y]) else { break };
        let (id, k) = e.data;
        if done[id as usize] {
            continue;
        }
        done[id as usize] = true;
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
