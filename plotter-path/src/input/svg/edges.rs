//! The edge rule for fill-only shapes: a browser shows a filled shape's boundary only where the colour on its two
//! sides differs, so its outline is drawn exactly there. Inside, the colour is the shape's fill; outside, it is
//! what was painted before it at that place — the topmost earlier paint ([`super::walk::Paint`]: fills, wide
//! strokes; a fill at most half opaque counts with its colour blended with the paper's, so a white shape on a
//! 25 % black shadow is outlined), or the paper where there is none. (What is painted later is hidden-line
//! removal's business, [`super::occlude`], which has already taken the outline's hidden parts away.) So a white
//! shape on white paper draws nothing, on a black square its whole outline, half over each exactly the half over
//! black; a red shape on a red one draws no edge.
//! A fill that is not one colour (a gradient of several) matches nothing, so its outline is drawn wherever it is
//! visible. Colours count as the same when no channel differs by more than [`SAME_COLOR_STEP`]: an edge between
//! them is one no eye sees, and drawings shade with "blends", stacks of dozens of shapes each a step or two of 255
//! lighter than the one beneath (openclipart's pink cake draws 40 m of such outlines on a 180 mm page). Translucent fills are compared by their colour, as if opaque: a faint red on red shows no edge either.
//!
//! At a point beside the outline, the colour there is decided by the earlier paints, from the top down
//! ([`topmost_counts`]): tints (fills at most half opaque) cover nothing and count only when looking for a colour
//! different from the shape's, the first opaque paint decides, and with none the paper shows. The outline is cut
//! where it crosses the boundary of any earlier paint near it ([`crate::geometry::split`]) and each piece kept or
//! dropped by that verdict at two points beside its middle, one on each side; no union or difference of areas is
//! built, so a shape on a deep stack of paints costs the boundary edges near its outline, not the stack's area
//! operations.
//!
//! A piece running along an earlier paint's edge has a different verdict on each side. It is dropped when either
//! side shows the shape's own colour: that edge is already drawn as the earlier paint's outline (a red square laid
//! over the left half of a red rectangle draws nothing, and the rectangle's outline stays whole: one line where the
//! browser shows one). For a paper-coloured shape it is kept when either side shows another colour.
//!
//! Shortcuts: with nothing of colour `c` beneath and `c` not the paper's, the outline stays whole without any cut;
//! with nothing at all beneath a paper-coloured shape, it goes.

use super::grid::{BoxGrid, paint_grid};
use super::walk::{Item, Outline, Paint};
use crate::geometry::drawing::Rgb;
use crate::geometry::parallel::for_each_mut;
use crate::geometry::region::{Region, polyline_bbox};
use crate::geometry::split::{Near, split_where};
use kurbo::{Point, Rect};

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
        let Some(grid) = grid.as_ref() else {
            // Nothing painted anywhere: only the paper lies beneath.
            *kept_out = if alike(outline.color, Some(paper)) { Vec::new() } else { outline.lines };
            *vanished = kept_out.is_empty();
            return;
        };
        let beneath = Beneath { items: shared, paints: &paints, grid, below: i };
        let mut under = Vec::new();
        beneath.near(bbox, &mut under);
        let color = outline.color;
        let kept = if alike(color, Some(paper)) {
            if under.is_empty() {
                Vec::new()
            } else {
                split_where(outline.lines, &beneath, |near, l, r| {
                    let other = |p| topmost_counts(&beneath, near, p, true, |c| !alike(c, color));
                    other(l) || other(r)
                })
            }
        } else if color.is_none() || !under.iter().any(|&k| alike(beneath.paint(k).color, color)) {
            outline.lines
        } else {
            split_where(outline.lines, &beneath, |near, l, r| {
                let same = |p| topmost_counts(&beneath, near, p, false, |c| alike(c, color));
                !same(l) && !same(r)
            })
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

/// Most difference per channel (of 255) between two colours that count as the same for the edge rule: about 2 in
/// CIE ΔE, what an eye can just tell apart side by side, so an edge drawn between them would be ink the picture
/// does not show.
pub(crate) const SAME_COLOR_STEP: u8 = 4;

/// Whether two paint colours count as the same ([`SAME_COLOR_STEP`]); no colour (a gradient) matches only itself.
fn alike(a: Option<Rgb>, b: Option<Rgb>) -> bool {
    match (a, b) {
        (Some(a), Some(b)) => {
            a.0.abs_diff(b.0) <= SAME_COLOR_STEP
                && a.1.abs_diff(b.1) <= SAME_COLOR_STEP
                && a.2.abs_diff(b.2) <= SAME_COLOR_STEP
        }
        (None, None) => true,
        _ => false,
    }
}

/// The paints of the items before item `below`, found through the paint grid.
struct Beneath<'a> {
    items: &'a [Item],
    paints: &'a [(usize, usize)],
    grid: &'a BoxGrid,
    below: usize,
}

impl Beneath<'_> {
    fn paint(&self, k: usize) -> &Paint {
        let (i, p) = self.paints[k];
        &self.items[i].paints[p]
    }
}

impl Near for Beneath<'_> {
    /// An index into the paint list; ascending is the paint order, so the topmost comes last.
    type Item = usize;

    fn near(&self, bbox: Rect, out: &mut Vec<usize>) {
        self.grid.query_into(bbox, out);
        // Ascending paint indices are in item order: the earlier items' paints come first.
        let earlier = out.partition_point(|&k| self.paints[k].0 < self.below);
        out.truncate(earlier);
    }

    fn region(&self, k: usize) -> &Region {
        &self.paint(k).area
    }
}

/// Whether the paints `near` (ascending paint order), looked at from the top down at `p`, show a colour `wanted`
/// accepts: the first opaque paint containing `p` decides; a tint containing `p` above it counts when `tints` is
/// set (looking for a different colour: a tint can add an edge but never take one away, its colour being a blend
/// with the paper, only an estimate over other paint) and is looked through otherwise. With no paint, no.
fn topmost_counts(
    beneath: &Beneath,
    near: &[usize],
    p: Point,
    tints: bool,
    wanted: impl Fn(Option<Rgb>) -> bool,
) -> bool {
    for &k in near.iter().rev() {
        let paint = beneath.paint(k);
        if !paint.area.contains(p) {
            continue;
        }
        if paint.hides {
            return wanted(paint.color);
        }
        if tints && wanted(paint.color) {
            return true;
        }
    }
    false
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::drawing::Pen;
    use crate::geometry::region::{FillRule, Keep, cut};
    use proptest::prelude::*;

    const PAPER: Rgb = Rgb(255, 255, 255);
    const COLOURS: [Rgb; 3] = [Rgb(255, 0, 0), Rgb(0, 0, 255), PAPER];

    fn rect(x: f64, y: f64, w: f64, h: f64) -> Vec<Point> {
        vec![Point::new(x, y), Point::new(x + w, y), Point::new(x + w, y + h), Point::new(x, y + h), Point::new(x, y)]
    }

    /// A fill-only rectangle: its outline waiting for the rule, its fill a paint.
    fn item(r: Vec<Point>, color: Rgb, hides: bool) -> Item {
        let area = Region::from_contours([&r[..4]], FillRule::NonZero);
        Item {
            layer: 0,
            pen: Pen { color, width_mm: 0.3 },
            lines: Vec::new(),
            outline: Some(Outline { lines: vec![r], color: Some(color) }),
            paints: vec![Paint { area, color: Some(color), hides }],
            element: "<rect>".into(),
        }
    }

    fn length(lines: &[Vec<Point>]) -> f64 {
        lines.iter().flat_map(|l| l.windows(2)).map(|w| w[0].distance(w[1])).sum()
    }

    /// The rule computed with area operations (i_overlay's booleans and its polyline clipping), independently of
    /// the point tests: the union of the visible parts of the earlier paints of the wanted colours, then a cut.
    fn by_areas(items: &[Item], i: usize) -> Vec<Vec<Point>> {
        let outline = items[i].outline.clone().expect("an outline");
        let color = outline.color;
        let visible = |tints: bool, wanted: &dyn Fn(Option<Rgb>) -> bool| {
            let mut covered = Region::default();
            let mut found = Region::default();
            for paint in items[..i].iter().rev().flat_map(|it| it.paints.iter().rev()) {
                if (paint.hides || tints) && wanted(paint.color) {
                    found = found.union(&paint.area.difference(&covered));
                }
                if paint.hides {
                    covered = covered.union(&paint.area);
                }
            }
            found
        };
        if color == Some(PAPER) {
            cut(outline.lines, &[&visible(true, &|c| c != color)], Keep::Inside)
        } else {
            cut(outline.lines, &[&visible(false, &|c| c == color)], Keep::Outside)
        }
    }

    #[test]
    fn a_blend_step_a_few_units_lighter_draws_no_edge() {
        // A blend: 10 × 10 mm pink #FFC3D4 with a 6 × 6 mm #FFC4D6 (one and two units of 255 lighter) inside it,
        // and a 4 × 4 mm #FFCADC (seven and eight units) inside that. The first's outline lies on paper: all 40 mm.
        // The second matches the first all round: nothing. The third differs by more than 4 units: all 16 mm.
        let mut items = vec![
            item(rect(0.0, 0.0, 10.0, 10.0), Rgb(255, 195, 212), true),
            item(rect(2.0, 2.0, 6.0, 6.0), Rgb(255, 196, 214), true),
            item(rect(3.0, 3.0, 4.0, 4.0), Rgb(255, 202, 220), true),
        ];
        draw_edges(&mut items, PAPER);
        let drawn: Vec<f64> = items.iter().map(|it| length(&it.lines)).collect();
        assert!((drawn[0] - 40.0).abs() < 1e-9 && drawn[1] < 1e-9 && (drawn[2] - 16.0).abs() < 1e-9, "{drawn:?}");
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 200, ..ProptestConfig::default() })]
        /// On stacks of rectangles in general position (no shared edges), cutting by the topmost paint beside each
        /// piece keeps what the area operations keep, to rounding.
        #[test]
        fn the_point_rule_agrees_with_area_operations(
            shapes in prop::collection::vec(
                (0.0..40.0f64, 0.0..40.0f64, 1.0..30.0f64, 1.0..30.0f64, 0..3usize, prop::bool::weighted(0.8)),
                2..7,
            )
        ) {
            let mut items: Vec<Item> =
                shapes.iter().map(|&(x, y, w, h, c, hides)| item(rect(x, y, w, h), COLOURS[c], hides)).collect();
            let expected: Vec<f64> = (0..items.len()).map(|i| length(&by_areas(&items, i))).collect();
            draw_edges(&mut items, PAPER);
            for (i, it) in items.iter().enumerate() {
                let got = length(&it.lines);
                prop_assert!((got - expected[i]).abs() < 1e-6, "shape {i}: {got} mm, area operations {} mm", expected[i]);
            }
        }
    }
}
