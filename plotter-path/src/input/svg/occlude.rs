//! Hidden-line removal: the parts of an item's pen lines that lie under an opaque fill painted after it are
//! removed, as a browser's painter's algorithm would hide them.
//!
//! For item `i` the occluders are the paints that hide (fills more than half opaque, wide opaque strokes; fainter
//! fills only tint, see [`super::walk::Paint`]) of items `j > i`. Each segment of the item's lines is split where it
//! crosses the boundary of an occluder near it (found through a [`super::grid::BoxGrid`] over the paints' bounding
//! boxes), and each piece is kept when a point just beside its middle, on either side, lies under none of them
//! ([`crate::geometry::split`]): no area operation is computed, so the cost is that of the boundary edges near each
//! segment, whatever the number of occluders stacked there. A piece running along an occluder's edge stays (one of
//! its sides is open).
//!
//! A fill-only shape's outline is hidden the same way before the edge rule ([`super::edges`]) looks at it: the two
//! rules keep a piece only when both do, so the order does not change what is drawn, and on a deep stack of shapes
//! most of each outline is buried and never needs the edge rule's look at the paints beneath.

use super::grid::{BoxGrid, paint_grid};
use super::walk::Item;
use crate::geometry::cancel::Cancel;
use crate::geometry::parallel::for_each_mut;
use crate::geometry::region::{Region, polyline_bbox};
use crate::geometry::split::{Near, split_where};
use kurbo::{Point, Rect};

/// Remove hidden parts in place; returns how many items lost some of their lines. Stops between items once
/// `cancel` is set (the items are then only partly processed, for a caller that discards them).
///
/// Items are independent (each reads only the paints of later items), so they are cut on all cores; the result is
/// the same as one item after the other.
pub(super) fn occlude(items: &mut [Item], cancel: &Cancel) -> usize {
    let (paints, grid) = paint_grid(items);
    let Some(grid) = grid else { return 0 };
    // Each item's pen lines and the outline still waiting for the edge rule: both are hidden alike.
    let mut work: Vec<([Vec<Vec<Point>>; 2], bool)> = items
        .iter_mut()
        .map(|it| {
            let outline = it.outline.as_mut().map(|o| std::mem::take(&mut o.lines)).unwrap_or_default();
            ([std::mem::take(&mut it.lines), outline], false)
        })
        .collect();
    let shared: &[Item] = items;
    for_each_mut(&mut work, |i, (sets, changed)| {
        if cancel.is_cancelled() {
            return;
        }
        let Some(bbox) = sets.iter().flatten().filter_map(|l| polyline_bbox(l)).reduce(|a, b| a.union(b)) else {
            return;
        };
        let above = Above { items: shared, paints: &paints, grid: &grid, over: i };
        let mut hits = Vec::new();
        above.near(bbox, &mut hits);
        if hits.is_empty() {
            return;
        }
        for lines in sets.iter_mut().filter(|s| !s.is_empty()) {
            let before: f64 = total_length(lines);
            // A line wholly inside one occluder goes without splitting (deep stacks bury most lines that way): only
            // the occluders whose box holds the line's box are asked.
            lines.retain(|l| {
                let Some(lb) = polyline_bbox(l) else { return true };
                !hits.iter().any(|&k| {
                    let r = above.region(k);
                    r.bbox().is_some_and(|b| b.contains_rect(lb)) && r.covers(l)
                })
            });
            let kept = split_where(std::mem::take(lines), &above, |near, l, r| {
                let covered = |p: Point| near.iter().any(|&k| above.region(k).contains(p));
                !covered(l) || !covered(r)
            });
            *changed |= total_length(&kept) < before - 1e-9;
            *lines = kept;
        }
    });
    let mut count = 0;
    for (item, ([lines, outline], changed)) in items.iter_mut().zip(work) {
        item.lines = lines;
        if let Some(o) = item.outline.as_mut() {
            o.lines = outline;
        }
        count += usize::from(changed);
    }
    count
}

/// The hiding paints of the items after item `over`, found through the paint grid.
struct Above<'a> {
    items: &'a [Item],
    paints: &'a [(usize, usize)],
    grid: &'a BoxGrid,
    over: usize,
}

impl Near for Above<'_> {
    /// An index into the paint list.
    type Item = usize;

    fn near(&self, bbox: Rect, out: &mut Vec<usize>) {
        self.grid.query_into(bbox, out);
        // Ascending paint indices are in item order: the later items' paints come last.
        let later = out.partition_point(|&k| self.paints[k].0 <= self.over);
        out.drain(..later);
        out.retain(|&k| {
            let (j, p) = self.paints[k];
            self.items[j].paints[p].hides
        });
    }

    fn region(&self, k: usize) -> &Region {
        let (j, p) = self.paints[k];
        &self.items[j].paints[p].area
    }
}

fn total_length(lines: &[Vec<Point>]) -> f64 {
    lines.iter().flat_map(|l| l.windows(2)).map(|w| w[0].distance(w[1])).sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::drawing::{Pen, Rgb};
    use crate::geometry::region::{FillRule, Keep, cut};
    use proptest::prelude::*;

    fn rect(x: f64, y: f64, w: f64, h: f64) -> Vec<Point> {
        vec![Point::new(x, y), Point::new(x + w, y), Point::new(x + w, y + h), Point::new(x, y + h), Point::new(x, y)]
    }

    /// A rectangle drawn as its outline and filled: the fill hides when `hides`.
    fn item(r: Vec<Point>, hides: bool) -> Item {
        let area = Region::from_contours([&r[..4]], FillRule::NonZero);
        Item {
            layer: 0,
            pen: Pen { color: Rgb(0, 0, 0), width_mm: 0.3 },
            lines: vec![r],
            outline: None,
            paints: vec![super::super::walk::Paint { area, color: Some(Rgb(0, 0, 0)), hides }],
            element: "<rect>".into(),
        }
    }

    /// Lines only, painting nothing.
    fn lines(lines: Vec<Vec<Point>>) -> Item {
        Item { lines, paints: Vec::new(), ..item(rect(0.0, 0.0, 1.0, 1.0), false) }
    }

    #[test]
    fn a_square_over_half_a_line_hides_that_half_and_an_edge_along_it_stays() {
        // A line y = 5 from x = 0 to 20 under a square x 10..20, y 0..10 painted later: 10 mm remain. A line along
        // the square's top edge (y = 10) is not under it (one side is open) and stays whole.
        let line = lines(vec![vec![Point::new(0.0, 5.0), Point::new(20.0, 5.0)]]);
        let edge = lines(vec![vec![Point::new(12.0, 10.0), Point::new(18.0, 10.0)]]);
        let mut items = vec![line, edge, item(rect(10.0, 0.0, 10.0, 10.0), true)];
        assert_eq!(occlude(&mut items, &Cancel::never()), 1);
        assert_eq!(items[0].lines, vec![vec![Point::new(0.0, 5.0), Point::new(10.0, 5.0)]]);
        assert_eq!(items[1].lines, vec![vec![Point::new(12.0, 10.0), Point::new(18.0, 10.0)]]);
        // The square's own outline is painted last: nothing hides it.
        assert_eq!(total_length(&items[2].lines), 40.0);

        // Lines wholly under a later fill go, whole, without a cut.
        let inside = lines(vec![vec![Point::new(2.0, 2.0), Point::new(8.0, 8.0)], rect(3.0, 3.0, 2.0, 2.0)]);
        let square =
            Item { paints: vec![item(rect(0.0, 0.0, 10.0, 10.0), true).paints.remove(0)], ..lines(Vec::new()) };
        let mut items = vec![inside, square];
        assert_eq!(occlude(&mut items, &Cancel::never()), 1);
        assert!(items[0].lines.is_empty());

        // An element's own fill is painted before its lines: a line of it inside its fill (a subpath) stays.
        let mut own = item(rect(0.0, 0.0, 10.0, 10.0), true);
        own.lines.push(vec![Point::new(2.0, 5.0), Point::new(8.0, 5.0)]);
        let mut items = vec![own];
        assert_eq!(occlude(&mut items, &Cancel::never()), 0);
        assert_eq!(total_length(&items[0].lines), 46.0);
    }

    #[test]
    fn an_outline_under_a_later_copy_of_its_shape_stays_whole_and_two_fills_side_by_side_hide_their_seam() {
        // A square's outline under a later fill of the same square: every side runs along the fill's edge, with the
        // outside open, so all 40 mm stay, in one piece.
        let mut items = vec![lines(vec![rect(0.0, 0.0, 10.0, 10.0)]), item(rect(0.0, 0.0, 10.0, 10.0), true)];
        assert_eq!(occlude(&mut items, &Cancel::never()), 0);
        assert_eq!(items[0].lines, vec![rect(0.0, 0.0, 10.0, 10.0)]);
        // A line along x = 10 where two later squares meet (x 0..10 and 10..20): covered on both sides, gone; its
        // ends beyond the squares (y −5..0 and 10..15) stay.
        let seam = lines(vec![vec![Point::new(10.0, -5.0), Point::new(10.0, 15.0)]]);
        let mut items = vec![seam, item(rect(0.0, 0.0, 10.0, 10.0), true), item(rect(10.0, 0.0, 10.0, 10.0), true)];
        assert_eq!(occlude(&mut items, &Cancel::never()), 1);
        assert_eq!(
            items[0].lines,
            vec![
                vec![Point::new(10.0, -5.0), Point::new(10.0, 0.0)],
                vec![Point::new(10.0, 10.0), Point::new(10.0, 15.0)]
            ]
        );
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 200, ..ProptestConfig::default() })]
        /// On stacks of rectangles in general position, what stays of each outline is what an area operation keeps:
        /// the outline cut (by i_overlay) outside the union of the later hiding fills.
        #[test]
        fn the_point_rule_agrees_with_cutting_by_the_later_fills(
            shapes in prop::collection::vec(
                (0.0..40.0f64, 0.0..40.0f64, 1.0..30.0f64, 1.0..30.0f64, prop::bool::weighted(0.8)),
                2..8,
            )
        ) {
            let mut items: Vec<Item> = shapes.iter().map(|&(x, y, w, h, hides)| item(rect(x, y, w, h), hides)).collect();
            let expected: Vec<f64> = (0..items.len())
                .map(|i| {
                    let later: Vec<&Region> =
                        items[i + 1..].iter().flat_map(|it| &it.paints).filter(|p| p.hides).map(|p| &p.area).collect();
                    total_length(&cut(items[i].lines.clone(), &later, Keep::Outside))
                })
                .collect();
            occlude(&mut items, &Cancel::never());
            for (i, it) in items.iter().enumerate() {
                let got = total_length(&it.lines);
                prop_assert!((got - expected[i]).abs() < 1e-6, "shape {i}: {got} mm, area operation {} mm", expected[i]);
            }
        }
    }
}
