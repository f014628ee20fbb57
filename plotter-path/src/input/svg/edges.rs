//! The edge rule for fill-only shapes: a browser shows a filled shape's boundary only where the colour on its two
//! sides differs, so its outline is drawn exactly there. Inside, the colour is the shape's fill; outside, it is
//! what was painted before it at that place — the topmost earlier paint ([`super::walk::Paint`]: fills, wide
//! strokes; a fill at most half opaque counts with its colour blended with the paper's, so a white shape on a
//! 25 % black shadow is outlined), or the paper where there is none. (What is painted later is
//! hidden-line removal's business, [`super::occlude`].) So a white shape on white paper draws nothing, on a black
//! square its whole outline, half over each exactly the half over black; a red shape on a red one draws no edge.
//! A fill that is not one colour (a gradient of several) matches nothing, so its outline is drawn wherever it is
//! visible. Translucent fills are compared by their colour, as if opaque: a faint red on red shows no edge either.
//!
//! For a shape of colour `c`, the earlier paints meeting its outline's bounding box are visited from the top down,
//! each contributing the part not covered by those above it: to `same` when its colour is `c`, else to `other`.
//! When `c` is the paper's colour the outline is kept inside `other` (everything uncovered is paper, the same);
//! otherwise it is cut away inside `same` (uncovered paper differs). Shortcuts: with nothing of colour `c` beneath
//! and `c` not the paper's, the outline stays whole without any area operation; with nothing at all beneath a
//! paper-coloured shape, it goes.

use super::grid::paint_grid;
use super::walk::{Item, Outline};
use crate::geometry::drawing::Rgb;
use crate::geometry::parallel::for_each_mut;
use crate::geometry::region::{Keep, Region, cut, polyline_bbox};
use kurbo::Point;

/// Apply the edge rule to every item's outline and move what remains into its lines. Returns how many shapes lost
/// their whole outline to it (they match what lies beneath everywhere, e.g. white on the paper).
pub(super) fn draw_edges(items: &mut [Item], paper: Rgb) -> usize {
    let (paints, grid) = paint_grid(items);
    // Each item reads only the paints of earlier items, which this does not change: the outlines are cut on all
    // cores, with the same result as one after the other.
    let mut work: Vec<(Option<Outline>, Vec<Vec<Point>>, bool)> =
        items.iter_mut().map(|it| (it.outline.take(), Vec::new(), false)).collect();
    let shared: &[Item] = items;
    for_each_mut(&mut work, |i, (outline, kept_out, vanished)| {
        let Some(outline) = outline.take() else { return };
        let Some(bbox) = outline.lines.iter().filter_map(|l| polyline_bbox(l)).reduce(|a, b| a.union(b)) else {
            return;
        };
        // Earlier paints under the outline, from the top down (later items and, within one, the stroke first).
        let mut beneath: Vec<(usize, usize)> = grid
            .as_ref()
            .map(|g| g.query(bbox).into_iter().map(|k| paints[k]).filter(|h| h.0 < i).collect())
            .unwrap_or_default();
        beneath.reverse();
        let color = outline.color;
        let on_paper = color == Some(paper);
        let kept = if on_paper {
            if beneath.is_empty() {
                Vec::new()
            } else {
                let other = visible_where(shared, &beneath, true, |c| c != color);
                cut(outline.lines, &[&other], Keep::Inside)
            }
        } else if color.is_none() || !beneath.iter().any(|&(k, p)| shared[k].paints[p].color == color) {
            outline.lines
        } else {
            let same = visible_where(shared, &beneath, false, |c| c == color);
            cut(outline.lines, &[&same], Keep::Outside)
        };
        *vanished = kept.iter().all(|l| l.len() < 2);
        *kept_out = kept;
    });
    let mut vanished = 0;
    for (item, (_, kept, gone)) in items.iter_mut().zip(work) {
        vanished += usize::from(gone);
        item.lines.extend(kept);
    }
    vanished
}

/// The union of the visible parts of the paints `beneath` (listed from the top down) whose colour `wanted` accepts.
/// Tints (fills at most half opaque) cover nothing, since what lies under them still shows; they count only when
/// `tints` is set — when looking for a different colour, so a tint can add an edge but never take one away (its
/// colour is a blend with the paper, which is only an estimate over other paint).
fn visible_where(
    items: &[Item],
    beneath: &[(usize, usize)],
    tints: bool,
    wanted: impl Fn(Option<Rgb>) -> bool,
) -> Region {
    // Paints below the last one that can count cannot add to the result: the cover is not built under it.
    let Some(last) = beneath.iter().rposition(|&(k, p)| {
        let paint = &items[k].paints[p];
        wanted(paint.color) && (paint.hides || tints)
    }) else {
        return Region::default();
    };
    let mut covered = Region::default();
    let mut found = Region::default();
    for &(k, p) in &beneath[..=last] {
        let paint = &items[k].paints[p];
        if !paint.hides {
            if tints && wanted(paint.color) {
                let visible = if covered.is_empty() { paint.area.clone() } else { paint.area.difference(&covered) };
                found = found.union(&visible);
            }
            continue;
        }
        if wanted(paint.color) {
            let visible = if covered.is_empty() { paint.area.clone() } else { paint.area.difference(&covered) };
            found = found.union(&visible);
        }
        covered = covered.union(&paint.area);
    }
    found
}
