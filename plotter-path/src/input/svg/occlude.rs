//! Hidden-line removal: the parts of an item's pen lines that lie under an opaque fill painted after it are
//! removed, as a browser's painter's algorithm would hide them.
//!
//! For item `i` the occluders are the paints that hide (fills more than half opaque, wide opaque strokes; fainter
//! fills only tint, see [`super::walk::Paint`]) of items `j > i`
//! whose bounding boxes meet the item's lines; they are found through a [`super::grid::BoxGrid`] over the paints'
//! bounding boxes, and the lines are cut against them one by one, skipping those the remaining lines no longer
//! reach. Cost: per item, one cut per overlapping later fill, each linear in the vertices involved up to a log
//! factor.

use super::grid::paint_grid;
use super::walk::Item;
use crate::geometry::cancel::Cancel;
use crate::geometry::parallel::for_each_mut;
use crate::geometry::region::{Keep, Region, cut, polyline_bbox};

/// Remove hidden parts in place; returns how many items lost some of their lines. Stops between items once
/// `cancel` is set (the items are then only partly processed, for a caller that discards them).
///
/// Items are independent (each reads only the paints of later items), so they are cut on all cores; the result is
/// the same as one item after the other.
pub(super) fn occlude(items: &mut [Item], cancel: &Cancel) -> usize {
    let (paints, grid) = paint_grid(items);
    let Some(grid) = grid else { return 0 };
    let mut work: Vec<(Vec<Vec<kurbo::Point>>, bool)> =
        items.iter_mut().map(|it| (std::mem::take(&mut it.lines), false)).collect();
    let shared: &[Item] = items;
    for_each_mut(&mut work, |i, (lines, changed)| {
        if cancel.is_cancelled() {
            return;
        }
        let Some(bbox) = lines.iter().filter_map(|l| polyline_bbox(l)).reduce(|a, b| a.union(b)) else {
            return;
        };
        let hits: Vec<(usize, usize)> = grid
            .query(bbox)
            .into_iter()
            .map(|k| paints[k])
            .filter(|h| h.0 > i && items[h.0].paints[h.1].hides)
            .collect();
        if hits.is_empty() {
            return;
        }
        let mut kept = std::mem::take(lines);
        let before: f64 = total_length(&kept);
        // One occluder at a time: cutting against all at once makes i_overlay intersect the occluders' edges with
        // each other too, which is quadratic where many shapes are stacked (seconds on some clip art); one by one,
        // each cut only meets the lines that are still visible.
        for (j, p) in hits {
            let region: &Region = &shared[j].paints[p].area;
            let Some(bbox) = kept.iter().filter_map(|l| polyline_bbox(l)).reduce(|a, b| a.union(b)) else { break };
            let r = region.bbox().expect("paints with a box only");
            if super::grid::meet(r, bbox) {
                kept = cut(kept, &[region], Keep::Outside);
            }
        }
        *changed = total_length(&kept) < before - 1e-9;
        *lines = kept;
    });
    let mut count = 0;
    for (item, (lines, changed)) in items.iter_mut().zip(work) {
        item.lines = lines;
        count += usize::from(changed);
    }
    count
}

fn total_length(lines: &[Vec<kurbo::Point>]) -> f64 {
    lines.iter().flat_map(|l| l.windows(2)).map(|w| w[0].distance(w[1])).sum()
}
