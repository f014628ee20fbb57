//! Blends under `--hatch tone`: drawings shade with stacks of shapes painted one over the other, each a step of
//! colour lighter than the one beneath and a little smaller (openclipart's pink cake: 104 reds from `#990000` to
//! `#FF0000` in a band 5 mm tall on a 180 mm page, rings 0.05 mm wide). Hatched one by one, each shape's lines are
//! cut to the thin ring the next one leaves visible, every line piece inks a whole pen dot however short it is,
//! and each shape's zig-zag joins run along its own edge, inside the ring below: the band plotted solid black
//! where the drawing shows L* 31–53.
//!
//! So an opaque plain fill that `--hatch tone` shades is hatched after the walk, together with the fills painted
//! right before and after it (no other shape between them) in the same layer, with the same hatch, whose colours
//! differ by at most [`BLEND_STEP`] step after step. The steps' edges inside such a run are not outlined (they
//! are its shading, which the hatch draws; where a step reaches past the steps beneath it, its edge is the
//! run's own and the edge rule decides as for any fill). The run is one area, the union of its shapes, whose part where shape `i` shows (shape `i` less those
//! painted above it in the run) has shape `i`'s darkness. Consecutive parts are gathered into bands, as a
//! gradient's are ([`crate::geometry::tone_hatch`]): a band closes once its darkness would spread over more than
//! [`BAND_STEP`] and it is at least [`MIN_BAND_PENS`] pen widths wide (its area over half its perimeter: a ring's
//! width, a disc's radius); it is hatched at its parts' darkness averaged by area, so the ink it lays down is
//! the ink its parts ask for. Its lines are joined only along the run's outer edge, and they go to the run's top
//! shape, so hidden-line removal cuts them by what is painted later.

use super::Item;
use super::fill_paint::{area, edge_ink, perimeter, rung_of};
use crate::geometry::drawing::Rgb;
use crate::geometry::region::{Keep, Region, cut};
use crate::geometry::tone_hatch::{BAND_STEP, MIN_BAND_PENS, ToneHatch, tone_hatch_parts};
use crate::input::raster::Ladder;

/// An opaque plain fill waiting to be shaded by its tone with the fills of its run.
#[derive(Debug, Clone)]
pub(super) struct ToneFill {
    /// The shape's index among the walk's items.
    pub(super) item: usize,
    /// The shape's layer.
    pub(super) layer: usize,
    /// The area it paints, cut to its clips, mm.
    pub(super) area: Region,
    /// Its colour.
    pub(super) color: Rgb,
    /// Its darkness over the paper (0 = paper, 1 = black).
    pub(super) darkness: f64,
    /// How it is hatched.
    pub(super) hatch: ToneHatch,
}

/// Most difference per channel (of 255) between a fill and the one painted right before it for both to be steps
/// of one blend: the blends of the fills bench step by 1 to 6 (about 2 L* in mid tones).
pub(super) const BLEND_STEP: u8 = 8;

/// Whether `b`, painted right after `a`, continues `a`'s run.
fn continues(a: &ToneFill, b: &ToneFill) -> bool {
    b.hatch == a.hatch && steps_on((a.item, a.layer, a.color), (b.item, b.layer, b.color))
}

/// Whether shape `b` (its item, layer and colour) is the next step of a blend after shape `a`: painted right after
/// it in the same layer, its colour at most [`BLEND_STEP`] away in every channel.
fn steps_on(a: (usize, usize, Rgb), b: (usize, usize, Rgb)) -> bool {
    let near = |x: u8, y: u8| x.abs_diff(y) <= BLEND_STEP;
    let ((ai, al, ac), (bi, bl, bc)) = (a, b);
    bi == ai + 1 && bl == al && near(ac.0, bc.0) && near(ac.1, bc.1) && near(ac.2, bc.2)
}

/// An opaque plain fill-only shape hatched at one spacing (`--hatch SPACING`), a possible step of a blend. Its
/// outline is drawn where it reaches past the steps beneath it in its run (the blend's own edge), not inside the
/// run: the hatch shades the blend, and a plotted line there would draw a contour at each step of what the picture
/// shows as a smooth shading (openclipart's gull steps its greys by 6 of 255, beyond the edge rule's
/// [`super::super::edges`] tolerance of 4). Without hatching the steps' outlines are kept: they are the only
/// shading the plot has (the fills bench's outlines-only error grows from 0.3906 to 0.3961 without them).
#[derive(Debug, Clone, Copy)]
pub(super) struct Step {
    /// The shape's index among the walk's items; its first paint is its fill's area.
    pub(super) item: usize,
    /// The shape's layer.
    pub(super) layer: usize,
    /// Its colour.
    pub(super) color: Rgb,
}

/// Cut the outlines of `steps` (in paint order) to the blend runs' edges, as `--hatch tone` does for its runs.
pub(super) fn drop_step_edges(steps: Vec<Step>, items: &mut [Item]) {
    let mut start = 0;
    for end in 1..=steps.len() {
        let (a, b) = (steps[end - 1], steps.get(end));
        if b.is_none_or(|b| !steps_on((a.item, a.layer, a.color), (b.item, b.layer, b.color))) {
            let run: Vec<usize> = steps[start..end].iter().map(|s| s.item).collect();
            if run.len() > 1 {
                cut_inner_edges(&run, items, |items, k| items[run[k]].paints.first().map(|p| p.area.clone()));
            }
            start = end;
        }
    }
}

/// Cut the outline of each shape of a run (item indices, bottom to top) to where it reaches past the shapes beneath
/// it in the run; `area` gives the area of the run's `k`-th shape.
fn cut_inner_edges(run: &[usize], items: &mut [Item], area: impl Fn(&[Item], usize) -> Option<Region>) {
    let mut below = Region::default();
    for (k, &i) in run.iter().enumerate() {
        if let Some(outline) = items[i].outline.as_mut()
            && !below.is_empty()
        {
            outline.lines = cut(std::mem::take(&mut outline.lines), &[&below], Keep::Outside);
        }
        if let Some(a) = area(items, k) {
            below = below.union(&a);
        }
    }
}

/// Hatch `fills` (in paint order) run by run, their lines added to `items`; returns how many runs were not
/// hatched because a band would take too many lines.
pub(super) fn hatch_runs(fills: Vec<ToneFill>, items: &mut [Item]) -> usize {
    let mut refused = 0;
    let mut run: Vec<ToneFill> = Vec::new();
    for f in fills {
        if run.last().is_some_and(|last| !continues(last, &f)) {
            refused += usize::from(!hatch_run(&run, items));
            run.clear();
        }
        run.push(f);
    }
    if !run.is_empty() {
        refused += usize::from(!hatch_run(&run, items));
    }
    refused
}

/// One run's hatch, added to its top shape's lines; false when it was refused.
fn hatch_run(run: &[ToneFill], items: &mut [Item]) -> bool {
    let Some(top) = run.last() else { return true };
    let th = top.hatch;
    let ladder = Ladder { pen_mm: th.pen_mm, min_spacing_mm: th.min_spacing_mm };
    let lines = if let [one] = run {
        let rung = rung_of(ladder, edge_ink(&one.area, th.pen_mm));
        tone_hatch_parts(&one.area, &[(one.area.clone(), one.darkness)], th.angle_deg, &rung)
    } else {
        // The steps' own edges inside the run are its shading, which the bands draw: an outline there would be
        // ink the picture does not have. Where a step reaches past the steps beneath, its edge is the run's.
        let indices: Vec<usize> = run.iter().map(|f| f.item).collect();
        cut_inner_edges(&indices, items, |_, k| Some(run[k].area.clone()));
        let (whole, bands) = bands(run, MIN_BAND_PENS * th.pen_mm);
        let rung = rung_of(ladder, edge_ink(&whole, th.pen_mm));
        tone_hatch_parts(&whole, &bands, th.angle_deg, &rung)
    };
    match lines {
        Some(lines) => {
            items[top.item].lines.extend(lines);
            true
        }
        None => false,
    }
}

/// A run's whole area and its bands: (area, darkness), bottom to top.
fn bands(run: &[ToneFill], min_width: f64) -> (Region, Vec<(Region, f64)>) {
    // Where each shape shows: itself less the shapes above it in the run.
    let mut cover = Region::default();
    let mut shown: Vec<(Region, f64, f64)> = Vec::with_capacity(run.len());
    for f in run.iter().rev() {
        let part = f.area.difference(&cover);
        cover = cover.union(&f.area);
        let a = area(&part);
        if a > 0.0 {
            shown.push((part, a, f.darkness));
        }
    }
    shown.reverse();
    let mut out: Vec<(Region, f64)> = Vec::new();
    // The band being gathered: its area, its parts' total area, their area-weighted darkness, the darkness range.
    let mut band = Region::default();
    let (mut total, mut ink, mut lo, mut hi) = (0.0, 0.0, f64::MAX, f64::MIN);
    for (part, a, d) in shown {
        if !band.is_empty() && d.max(hi) - d.min(lo) > BAND_STEP && width(&band, total) >= min_width {
            out.push((std::mem::take(&mut band), ink / total));
            (total, ink, lo, hi) = (0.0, 0.0, f64::MAX, f64::MIN);
        }
        band = band.union(&part);
        total += a;
        ink += a * d;
        lo = lo.min(d);
        hi = hi.max(d);
    }
    if !band.is_empty() {
        // A last band narrower than the least width joins the band below it.
        match out.last_mut() {
            Some((below, below_d)) if width(&band, total) < min_width => {
                let below_area = area(below);
                *below_d = (*below_d * below_area + ink) / (below_area + total);
                *below = below.union(&band);
            }
            _ => out.push((band, ink / total)),
        }
    }
    (cover, out)
}

/// How wide a region is, about: its area over half its perimeter (a ring's width, a disc's radius).
fn width(r: &Region, area: f64) -> f64 {
    let perimeter = perimeter(r);
    if perimeter > 0.0 { 2.0 * area / perimeter } else { 0.0 }
}
