//! Hatching a filled [`Region`] with parallel lines, linked into zig-zags where the link stays inside the area.
//!
//! The lines lie on a page-wide grid: direction `angle` (degrees counter-clockwise from +X as seen on the page,
//! the raster hatch mode's convention), offsets at whole multiples of the spacing from the page origin, so the
//! hatching of neighbouring shapes lines up. Each line is cut to the region by [`cut`], which honours the fill rule
//! the region was built with and its holes. Linking: the pieces are visited line by line; a piece joins the chain
//! that ended on the previous line when the connecting segment is at most three spacings long and lies inside the
//! region (its midpoint is inside or on the boundary and it crosses no contour edge; running along an edge is
//! allowed), which turns a convex area into one pen-down
//! zig-zag and leaves separate strokes where a hole or a concave edge is in the way.

use kurbo::{Line, Point, Rect, Vec2};

use super::region::{Keep, Region, cut};
use crate::config::profile::PenHatch;

/// Hatch settings for filled areas.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FillHatch {
    /// Distance between neighbouring lines, mm.
    pub spacing_mm: f64,
    /// Line direction, degrees counter-clockwise from +X as seen on the page.
    pub angle_deg: f64,
    /// Add a second family at right angles.
    pub cross: bool,
    /// Link neighbouring lines into zig-zags where the link stays inside the area.
    pub link: bool,
}

impl From<PenHatch> for FillHatch {
    /// The hatch settings of a pen-table pen (lines linked into zig-zags where that saves lifts).
    fn from(h: PenHatch) -> Self {
        FillHatch { spacing_mm: h.spacing_mm, angle_deg: h.angle_deg, cross: h.cross, link: true }
    }
}

impl Default for FillHatch {
    fn default() -> Self {
        FillHatch { spacing_mm: 1.0, angle_deg: 45.0, cross: false, link: true }
    }
}

/// Most hatch lines one region may get (a 1 m shape at 0.01 mm would otherwise ask for 10⁵ lines per family).
pub const MAX_LINES: usize = 200_000;

/// The hatch lines of `region`, or `None` when it would take more than [`MAX_LINES`] lines.
pub fn hatch(region: &Region, options: &FillHatch) -> Option<Vec<Vec<Point>>> {
    let Some(bbox) = region.bbox() else { return Some(Vec::new()) };
    let mut out = Vec::new();
    let angles: &[f64] = if options.cross { &[0.0, 90.0] } else { &[0.0] };
    for extra in angles {
        out.extend(family(region, bbox, options.spacing_mm, options.angle_deg + extra, options.link, None)?);
    }
    Some(out)
}

/// The hatch lines of `part`, a piece cut from a larger filled area `whole` (a band of a gradient), linked into
/// zig-zags only where both ends of the link lie on `whole`'s boundary: a link along a cut between two pieces
/// would ink a line the fill does not have (and one from each side of the cut). `None` as for [`hatch`].
pub fn hatch_part(part: &Region, whole: &Region, options: &FillHatch) -> Option<Vec<Vec<Point>>> {
    let Some(bbox) = part.bbox() else { return Some(Vec::new()) };
    let mut out = Vec::new();
    let angles: &[f64] = if options.cross { &[0.0, 90.0] } else { &[0.0] };
    for extra in angles {
        out.extend(family(part, bbox, options.spacing_mm, options.angle_deg + extra, options.link, Some(whole))?);
    }
    Some(out)
}

/// How far from `whole`'s boundary a link's end may lie and still count as on it, mm.
const ON_BOUNDARY_MM: f64 = 1e-6;

fn family(
    region: &Region,
    bbox: Rect,
    spacing: f64,
    angle_deg: f64,
    link: bool,
    whole: Option<&Region>,
) -> Option<Vec<Vec<Point>>> {
    let a = angle_deg.to_radians();
    // Page Y points down, so "counter-clockwise as seen" has a negative y component.
    let d = Vec2::new(a.cos(), -a.sin());
    let n = Vec2::new(a.sin(), a.cos());
    let corners = [(bbox.x0, bbox.y0), (bbox.x1, bbox.y0), (bbox.x1, bbox.y1), (bbox.x0, bbox.y1)].map(Vec2::from);
    let (mut vmin, mut vmax, mut umin, mut umax) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for c in corners {
        vmin = vmin.min(c.dot(n));
        vmax = vmax.max(c.dot(n));
        umin = umin.min(c.dot(d));
        umax = umax.max(c.dot(d));
    }
    let (k0, k1) = ((vmin / spacing).ceil(), (vmax / spacing).floor());
    if k1 < k0 {
        return Some(Vec::new());
    }
    if k1 - k0 > MAX_LINES as f64 {
        return None;
    }
    let (u0, u1) = (umin - 1.0, umax + 1.0);
    let mut lines = Vec::new();
    let mut k = k0;
    while k <= k1 {
        let v = k * spacing;
        lines.push(vec![(n * v + d * u0).to_point(), (n * v + d * u1).to_point()]);
        k += 1.0;
    }
    let pieces = cut(lines, &[region], Keep::Inside);
    // Orient every piece along d and group by line index.
    let mut keyed: Vec<(i64, f64, Point, Point)> = pieces
        .into_iter()
        .map(|p| {
            let (mut s, mut e) = (p[0], p[p.len() - 1]);
            if (e - s).dot(d) < 0.0 {
                std::mem::swap(&mut s, &mut e);
            }
            // Hatch pieces are straight: any index round-off is far below a line spacing.
            #[allow(clippy::cast_possible_truncation)]
            let line = (s.to_vec2().dot(n) / spacing).round() as i64;
            (line, s.to_vec2().dot(d), s, e)
        })
        .collect();
    keyed.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
    if !link {
        return Some(keyed.into_iter().map(|(_, _, s, e)| vec![s, e]).collect());
    }
    let edges = region_edges(region);
    let mut chains: Vec<Vec<Point>> = Vec::new();
    // Chains that ended on the previous line: (chain index, line index).
    let mut open: Vec<usize> = Vec::new();
    let mut next_open: Vec<usize> = Vec::new();
    let mut current_line = i64::MIN;
    for (line, _, s, e) in keyed {
        if line != current_line {
            // Chains ending two lines back can no longer be extended.
            if line == current_line + 1 {
                open = std::mem::take(&mut next_open);
            } else {
                open.clear();
                next_open.clear();
            }
            current_line = line;
        }
        let mut joined = None;
        let on_edge = |p: Point| whole.is_none_or(|w| w.boundary_distance(p) <= ON_BOUNDARY_MM);
        'chains: for (slot, &ci) in open.iter().enumerate() {
            let chain = &chains[ci];
            let end = *chain.last().expect("chains are never empty");
            // A chain of one piece may still be turned round: worth it when only its start is on the whole's edge.
            let turnable = whole.is_some() && chain.len() == 2 && !on_edge(end) && on_edge(chain[0]);
            let ends: &[(Point, bool)] = if turnable { &[(end, false), (chain[0], true)] } else { &[(end, false)] };
            for &(end, turn) in ends {
                // Enter the piece at whichever end is nearer the chain's end.
                let (entry, exit) = if end.distance(s) <= end.distance(e) { (s, e) } else { (e, s) };
                if end.distance(entry) <= 3.0 * spacing
                    && on_edge(end)
                    && on_edge(entry)
                    && inside_link(region, &edges, end, entry)
                {
                    if turn {
                        chains[ci].reverse();
                    }
                    chains[ci].push(entry);
                    chains[ci].push(exit);
                    joined = Some((slot, ci));
                    break 'chains;
                }
            }
        }
        match joined {
            Some((slot, ci)) => {
                open.remove(slot);
                next_open.push(ci);
            }
            None => {
                chains.push(vec![s, e]);
                next_open.push(chains.len() - 1);
            }
        }
    }
    Some(chains)
}

fn region_edges(region: &Region) -> Vec<Line> {
    region.contours().flat_map(|c| (0..c.len()).map(move |i| Line::new(c[i], c[(i + 1) % c.len()]))).collect()
}

/// True when the segment `a`–`b` (both on the boundary) runs inside the region.
fn inside_link(region: &Region, edges: &[Line], a: Point, b: Point) -> bool {
    let len = a.distance(b);
    if len == 0.0 {
        return true;
    }
    let mid = a.midpoint(b);
    if region.winding(mid) == 0 && region.boundary_distance(mid) > 1e-6 {
        return false;
    }
    // Shrink by a hair so touching the boundary at the ends does not count as a crossing.
    let eps = 1e-6_f64.min(len / 4.0);
    let dir = (b - a) / len;
    let link = Line::new(a + dir * eps, b - dir * eps);
    let bb = Rect::from_points(link.p0, link.p1);
    edges.iter().all(|e| {
        let eb = Rect::from_points(e.p0, e.p1);
        if eb.x1 < bb.x0 || eb.x0 > bb.x1 || eb.y1 < bb.y0 || eb.y0 > bb.y1 {
            return true;
        }
        !segments_cross(link, *e)
    })
}

fn segments_cross(p: Line, q: Line) -> bool {
    let orient = |a: Point, b: Point, c: Point| (b - a).cross(c - a);
    let (d1, d2) = (orient(q.p0, q.p1, p.p0), orient(q.p0, q.p1, p.p1));
    let (d3, d4) = (orient(p.p0, p.p1, q.p0), orient(p.p0, p.p1, q.p1));
    (d1 * d2 <= 0.0) && (d3 * d4 <= 0.0) && !(d1 == 0.0 && d2 == 0.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::region::FillRule;

    fn total(lines: &[Vec<Point>]) -> f64 {
        lines.iter().flat_map(|l| l.windows(2)).map(|w| w[0].distance(w[1])).sum()
    }

    fn square(x: f64, y: f64, s: f64) -> Vec<Point> {
        vec![Point::new(x, y), Point::new(x + s, y), Point::new(x + s, y + s), Point::new(x, y + s)]
    }

    #[test]
    fn horizontal_hatch_of_a_square_is_one_zig_zag() {
        // 10 × 10 mm square from (0.5, 0.5), spacing 1, angle 0: lines at y = 1, 2, …, 10 → 10 lines of 10 mm.
        // Linked: 9 vertical connectors of 1 mm each. Pen-down length 100 + 9 = 109 mm in one stroke.
        let r = Region::from_contours([square(0.5, 0.5, 10.0).as_slice()], FillRule::NonZero);
        let opts = FillHatch { spacing_mm: 1.0, angle_deg: 0.0, cross: false, link: true };
        let lines = hatch(&r, &opts).unwrap();
        assert_eq!(lines.len(), 1);
        assert!((total(&lines) - 109.0).abs() < 1e-5, "{}", total(&lines));
        let unlinked = hatch(&r, &FillHatch { link: false, ..opts }).unwrap();
        assert_eq!(unlinked.len(), 10);
        assert!((total(&unlinked) - 100.0).abs() < 1e-5);
        // Cross-hatch adds the same at 90°: 10 vertical lines of 10 mm.
        let cross = hatch(&r, &FillHatch { cross: true, link: false, ..opts }).unwrap();
        assert!((total(&cross) - 200.0).abs() < 1e-5);
    }

    #[test]
    fn holes_are_left_empty_and_split_the_zig_zag() {
        // Square 0..10 with an even-odd hole 3..7 (offset so no line runs along an edge): lines at y = 0.5 … 9.5.
        let outer = square(0.0, 0.0, 10.0);
        let inner = square(3.0, 3.0, 4.0);
        let r = Region::from_contours([outer.as_slice(), inner.as_slice()], FillRule::EvenOdd);
        let opts = FillHatch { spacing_mm: 1.0, angle_deg: 0.0, cross: false, link: false };
        let shifted = Region::from_contours(
            [square(0.0, 0.5, 10.0).as_slice(), square(3.0, 3.5, 4.0).as_slice()],
            FillRule::EvenOdd,
        );
        // Lines at y = 1..10 (10 lines). y = 4, 5, 6, 7 cross the hole (3.5..7.5): 6 mm each; others 10 mm.
        let lines = hatch(&shifted, &opts).unwrap();
        assert!((total(&lines) - (6.0 * 10.0 + 4.0 * 6.0)).abs() < 1e-5, "{}", total(&lines));
        // No hatch point strictly inside the hole.
        for p in lines.iter().flatten() {
            assert!(!(p.x > 3.0 + 1e-6 && p.x < 7.0 - 1e-6 && p.y > 3.5 + 1e-6 && p.y < 7.5 - 1e-6), "{p:?}");
        }
        // Linked: no connector crosses the hole.
        let linked = hatch(&r, &FillHatch { link: true, ..opts }).unwrap();
        for w in linked.iter().flat_map(|l| l.windows(2)) {
            let m = w[0].midpoint(w[1]);
            assert!(r.winding(m) != 0 || r.boundary_distance(m) < 1e-6, "link through the hole at {m:?}");
        }
    }

    #[test]
    fn a_part_links_only_along_the_whole_areas_edge() {
        // The square 0..10 cut at x = 5 into two parts (as two gradient bands would be), horizontal lines at
        // y = 1 … 9 (0.5 offset from the edges would be y = 0.5 …; here the square starts at 0.5). Each part
        // hatched alone links its rows along the cut too; as a part of the square it links only along the
        // square's own left (or right) edge: no 1 mm link on x = 5.
        let whole = Region::from_contours([square(0.5, 0.5, 10.0).as_slice()], FillRule::NonZero);
        let left = Region::rect(Rect::new(0.5, 0.5, 5.5, 10.5));
        let opts = FillHatch { spacing_mm: 1.0, angle_deg: 0.0, cross: false, link: true };
        let links_on_cut = |lines: &[Vec<Point>]| {
            lines
                .iter()
                .flat_map(|l| l.windows(2))
                .filter(|w| (w[0].x - 5.5).abs() < 1e-9 && (w[1].x - 5.5).abs() < 1e-9)
                .count()
        };
        let alone = hatch(&left, &opts).unwrap();
        assert!(links_on_cut(&alone) >= 4, "{alone:?}");
        let part = hatch_part(&left, &whole, &opts).unwrap();
        assert_eq!(links_on_cut(&part), 0, "{part:?}");
        // 10 rows of 5 mm, joined in pairs along the left edge: 5 strokes, 50 + 5 × 1 mm.
        assert_eq!(part.len(), 5);
        assert!((total(&part) - 55.0).abs() < 1e-6, "{}", total(&part));
    }

    #[test]
    fn too_many_lines_is_refused() {
        let r = Region::rect(Rect::new(0.0, 0.0, 1000.0, 1000.0));
        assert!(hatch(&r, &FillHatch { spacing_mm: 0.001, ..FillHatch::default() }).is_none());
    }
}
