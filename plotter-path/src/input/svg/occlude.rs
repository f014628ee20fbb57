//! Hidden-line removal: the parts of an item's pen lines that lie under an opaque fill painted after it are
//! removed, as a browser's painter's algorithm would hide them.
//!
//! For item `i` the occluders are the opaque fills of items `j > i` whose bounding boxes meet the item's lines;
//! they are found through a uniform grid over the occluders' bounding boxes (cell size from the mean occluder
//! size, at most 256 × 256 cells), and the lines are cut against them one by one, skipping those the remaining
//! lines no longer reach. Cost: per item, one cut per overlapping later fill, each linear in the vertices involved
//! up to a log factor.

use kurbo::Rect;

use super::walk::Item;
use crate::geometry::cancel::Cancel;
use crate::geometry::region::{Keep, Region, cut, polyline_bbox};

const MAX_CELLS: f64 = 256.0;

/// Remove hidden parts in place; returns how many items lost some of their lines. Stops between items once
/// `cancel` is set (the items are then only partly processed, for a caller that discards them).
pub(super) fn occlude(items: &mut [Item], cancel: &Cancel) -> usize {
    let occluders: Vec<(usize, Rect)> = items
        .iter()
        .enumerate()
        .filter_map(|(i, it)| it.occluder.as_ref().and_then(Region::bbox).map(|b| (i, b)))
        .collect();
    if occluders.is_empty() {
        return 0;
    }
    let area = occluders.iter().map(|o| o.1).reduce(|a, b| a.union(b)).expect("not empty");
    let mean = occluders.iter().map(|o| o.1.width().max(o.1.height())).sum::<f64>() / occluders.len() as f64;
    let cell = mean.max(area.width() / MAX_CELLS).max(area.height() / MAX_CELLS).max(1e-6);
    // Both counts are at most MAX_CELLS + 1.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let (nx, ny) = ((area.width() / cell).floor() as usize + 1, (area.height() / cell).floor() as usize + 1);
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let cell_range = |r: Rect| {
        let cx = |x: f64| (((x - area.x0) / cell).floor().max(0.0) as usize).min(nx - 1);
        let cy = |y: f64| (((y - area.y0) / cell).floor().max(0.0) as usize).min(ny - 1);
        (cx(r.x0), cx(r.x1), cy(r.y0), cy(r.y1))
    };
    let mut grid: Vec<Vec<u32>> = vec![Vec::new(); nx * ny];
    for (k, (_, b)) in occluders.iter().enumerate() {
        let (x0, x1, y0, y1) = cell_range(*b);
        for y in y0..=y1 {
            for x in x0..=x1 {
                grid[y * nx + x].push(u32::try_from(k).expect("fewer than 2³² shapes"));
            }
        }
    }
    let mut seen = vec![usize::MAX; occluders.len()];
    let mut changed = 0;
    for i in 0..items.len() {
        if cancel.is_cancelled() {
            break;
        }
        if items[i].lines.is_empty() {
            continue;
        }
        let Some(bbox) = items[i].lines.iter().filter_map(|l| polyline_bbox(l)).reduce(|a, b| a.union(b)) else {
            continue;
        };
        if bbox.x1 < area.x0 || bbox.x0 > area.x1 || bbox.y1 < area.y0 || bbox.y0 > area.y1 {
            continue;
        }
        let mut hits: Vec<usize> = Vec::new();
        let (x0, x1, y0, y1) = cell_range(bbox);
        for y in y0..=y1 {
            for x in x0..=x1 {
                for &k in &grid[y * nx + x] {
                    let k = k as usize;
                    let (j, b) = occluders[k];
                    if j > i && seen[k] != i && b.x0 <= bbox.x1 && bbox.x0 <= b.x1 && b.y0 <= bbox.y1 && bbox.y0 <= b.y1
                    {
                        seen[k] = i;
                        hits.push(j);
                    }
                }
            }
        }
        if hits.is_empty() {
            continue;
        }
        let mut lines = std::mem::take(&mut items[i].lines);
        let before: f64 = total_length(&lines);
        // One occluder at a time: cutting against all at once makes i_overlay intersect the occluders' edges with
        // each other too, which is quadratic where many shapes are stacked (seconds on some clip art); one by one,
        // each cut only meets the lines that are still visible.
        hits.sort_unstable();
        for &j in &hits {
            let Some(region) = items[j].occluder.as_ref() else { continue };
            let Some(bbox) = lines.iter().filter_map(|l| polyline_bbox(l)).reduce(|a, b| a.union(b)) else { break };
            let r = region.bbox().expect("occluders are not empty");
            if r.x0 <= bbox.x1 && bbox.x0 <= r.x1 && r.y0 <= bbox.y1 && bbox.y0 <= r.y1 {
                lines = cut(lines, &[region], Keep::Outside);
            }
        }
        let kept = lines;
        if total_length(&kept) < before - 1e-9 {
            changed += 1;
        }
        items[i].lines = kept;
    }
    changed
}

fn total_length(lines: &[Vec<kurbo::Point>]) -> f64 {
    lines.iter().flat_map(|l| l.windows(2)).map(|w| w[0].distance(w[1])).sum()
}
