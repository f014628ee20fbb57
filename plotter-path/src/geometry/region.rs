//! Filled areas in millimetres and the cuts the SVG importer makes with them: clip paths, masks, hidden-line
//! removal (occlusion) and hatching all reduce to "keep the parts of these polylines inside (or outside) that area".
//!
//! A [`Region`] is a set of *normalised* shapes: i_overlay's `simplify_shape` resolves the source fill rule
//! (non-zero or even-odd), self-intersections and holes into outer contours and holes of consistent orientation,
//! so every point has winding number 0 (outside) or 1 (inside) for one region. Two consequences used below:
//! the non-zero fill of the contours of several normalised regions is exactly their union, so clipping against a
//! list of regions needs no union computed first; and region booleans (intersection for nested clips, difference
//! for black parts of a mask) are i_overlay overlays under the non-zero rule.
//!
//! Polylines are cut with i_overlay's string clipping. It works on an integer grid fitted to the input's
//! bounding box (i32, a power-of-two scale), so a cut point lies within about 1e-8 of the page size of the exact
//! intersection (a few nanometres on a 300 mm page); a polyline that does not reach any region's bounding box is
//! passed through untouched, bit for bit. Cut pieces may come back reversed; the plot order is chosen later anyway.

use i_overlay::core::fill_rule::FillRule as OverlayFill;
use i_overlay::core::overlay_rule::OverlayRule;
use i_overlay::float::clip::FloatClip;
use i_overlay::float::simplify::SimplifyShape;
use i_overlay::float::single::SingleFloatOverlay;
use i_overlay::string::clip::ClipRule;
use kurbo::{Point, Rect};

/// How the inside of a set of contours is decided (SVG `fill-rule` / `clip-rule`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FillRule {
    /// Inside where the winding number is not zero (SVG's default).
    #[default]
    NonZero,
    /// Inside where a ray crosses the contours an odd number of times.
    EvenOdd,
}

impl FillRule {
    fn overlay(self) -> OverlayFill {
        match self {
            FillRule::NonZero => OverlayFill::NonZero,
            FillRule::EvenOdd => OverlayFill::EvenOdd,
        }
    }
}

type Contour = Vec<[f64; 2]>;
type Shape = Vec<Contour>;

/// A filled area: normalised shapes (outer contours with their holes), in millimetres.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Region {
    shapes: Vec<Shape>,
    bbox: Option<Rect>,
    /// For each horizontal band of the bounding box, the contour edges reaching into it, band after band (band `b`
    /// holds `band_edges[band_start[b]..band_start[b + 1]]`; an edge spanning several bands is in each): lets
    /// [`Region::classify`] and the point tests look at the edges near a place only, read in one sweep of memory.
    band_start: Vec<u32>,
    band_edges: Vec<[f64; 4]>,
    bands: Bands,
}

/// Where a polyline lies relative to a region.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Class {
    Outside,
    Inside,
    /// Crosses or touches the boundary: only a real cut can tell.
    Crosses,
}

fn bbox_of(shapes: &[Shape]) -> Option<Rect> {
    shapes.iter().flatten().flatten().map(|p| Rect::from_points((p[0], p[1]), (p[0], p[1]))).reduce(|a, b| a.union(b))
}

impl Region {
    /// The area filled by `contours` (each implicitly closed) under `rule`.
    pub fn from_contours<'a>(contours: impl IntoIterator<Item = &'a [Point]>, rule: FillRule) -> Region {
        let raw: Vec<Contour> = contours
            .into_iter()
            .filter(|c| c.len() >= 3)
            .map(|c| c.iter().filter(|p| p.x.is_finite() && p.y.is_finite()).map(|p| [p.x, p.y]).collect::<Contour>())
            .filter(|c| c.len() >= 3)
            .collect();
        if raw.is_empty() {
            return Region::default();
        }
        Region::from_shapes(raw.simplify_shape(rule.overlay()))
    }

    /// The union of many regions in one pass (their normalised contours filled non-zero).
    pub fn union_all(regions: impl IntoIterator<Item = Region>) -> Region {
        let mut shapes: Vec<Shape> = Vec::new();
        let mut count = 0;
        for r in regions {
            count += 1;
            shapes.extend(r.shapes);
        }
        if count <= 1 || shapes.is_empty() {
            return Region::from_shapes(shapes);
        }
        let contours: Vec<Contour> = shapes.into_iter().flatten().collect();
        Region::from_shapes(contours.simplify_shape(OverlayFill::NonZero))
    }

    /// An axis-aligned rectangle.
    pub fn rect(r: Rect) -> Region {
        if !(r.width() > 0.0 && r.height() > 0.0) {
            return Region::default();
        }
        let c = vec![[r.x0, r.y0], [r.x1, r.y0], [r.x1, r.y1], [r.x0, r.y1]];
        Region::from_shapes(vec![c].simplify_shape(OverlayFill::NonZero))
    }

    fn from_shapes(shapes: Vec<Shape>) -> Region {
        let shapes: Vec<Shape> = shapes.into_iter().filter(|s| s.first().is_some_and(|c| c.len() >= 3)).collect();
        let bbox = bbox_of(&shapes);
        let edges: Vec<[f64; 4]> = shapes
            .iter()
            .flatten()
            .flat_map(|c| {
                (0..c.len()).map(move |i| {
                    let (a, b) = (c[i], c[(i + 1) % c.len()]);
                    [a[0], a[1], b[0], b[1]]
                })
            })
            .collect();
        let mut region =
            Region { shapes, bbox, band_start: Vec::new(), band_edges: Vec::new(), bands: Bands::default() };
        if let Some(b) = bbox {
            // About √E bands (at most 1024): each holds few edges, and a band lookup is one division.
            #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
            let n = ((edges.len() as f64).sqrt().ceil() as usize).clamp(1, 1024);
            // Counted first, then placed: band b's edges end up in their contour order.
            region.bands = Bands::new(n, b);
            region.band_start = vec![0; n + 1];
            let ranges: Vec<(usize, usize)> =
                edges.iter().map(|e| region.band_range(e[1].min(e[3]), e[1].max(e[3]))).collect();
            for &(lo, hi) in &ranges {
                for count in &mut region.band_start[lo + 1..=hi + 1] {
                    *count += 1;
                }
            }
            for i in 0..n {
                region.band_start[i + 1] += region.band_start[i];
            }
            let mut fill: Vec<u32> = region.band_start[..n].to_vec();
            region.band_edges = vec![[0.0; 4]; region.band_start[n] as usize];
            for (e, &(lo, hi)) in edges.iter().zip(&ranges) {
                for at in &mut fill[lo..=hi] {
                    region.band_edges[*at as usize] = *e;
                    *at += 1;
                }
            }
        }
        region
    }

    /// The edges of bands `lo..=hi`.
    #[inline]
    fn edges_of_bands(&self, lo: usize, hi: usize) -> &[[f64; 4]] {
        &self.band_edges[self.band_start[lo] as usize..self.band_start[hi + 1] as usize]
    }

    fn band_range(&self, y0: f64, y1: f64) -> (usize, usize) {
        (self.bands.at(y0), self.bands.at(y1))
    }

    /// Whether `line` lies wholly outside, wholly inside, or meets the boundary (touching counts as meeting).
    fn classify(&self, line: &[Point]) -> Class {
        let Some(b) = self.bbox else { return Class::Outside };
        let lb = polyline_bbox(line).expect("lines have points");
        if lb.x1 < b.x0 || lb.x0 > b.x1 || lb.y1 < b.y0 || lb.y0 > b.y1 {
            return Class::Outside;
        }
        for w in line.windows(2) {
            let (p, q) = (w[0], w[1]);
            if p.y.max(q.y) < b.y0 || p.y.min(q.y) > b.y1 {
                continue;
            }
            let (lo, hi) = self.band_range(p.y.min(q.y), p.y.max(q.y));
            for e in self.edges_of_bands(lo, hi) {
                if segments_meet(p, q, Point::new(e[0], e[1]), Point::new(e[2], e[3])) {
                    return Class::Crosses;
                }
            }
        }
        // No contact with the boundary: the whole line is on the side of its first point.
        if self.winding_banded(line[0]) != 0 { Class::Inside } else { Class::Outside }
    }

    /// Whether all of `line` lies inside, not touching the boundary (a line along it is not covered).
    pub fn covers(&self, line: &[Point]) -> bool {
        !line.is_empty() && self.classify(line) == Class::Inside
    }

    /// [`Region::winding`] using only the edges of `p`'s band.
    fn winding_banded(&self, p: Point) -> i32 {
        let Some(b) = self.bbox else { return 0 };
        if p.y < b.y0 || p.y > b.y1 || p.x < b.x0 || p.x > b.x1 {
            return 0;
        }
        let band = self.bands.at(p.y);
        let mut w = 0;
        for e in self.edges_of_bands(band, band) {
            let (a, c) = ([e[0], e[1]], [e[2], e[3]]);
            let cross = (c[0] - a[0]) * (p.y - a[1]) - (p.x - a[0]) * (c[1] - a[1]);
            if a[1] <= p.y {
                if c[1] > p.y && cross > 0.0 {
                    w += 1;
                }
            } else if c[1] <= p.y && cross < 0.0 {
                w -= 1;
            }
        }
        w
    }

    /// Whether `p` lies inside (winding number not zero; a point exactly on the boundary may go either way). Looks
    /// only at the edges of `p`'s band, so it is cheap enough to ask for many points.
    pub fn contains(&self, p: Point) -> bool {
        self.winding_banded(p) != 0
    }

    /// Push to `out` the parameters `t ∈ [0, 1]` along `p`–`q` where it meets the boundary (both ends of an edge
    /// running along it); an edge reaching into several bands may be reported more than once.
    pub fn crossings(&self, p: Point, q: Point, out: &mut Vec<f64>) {
        let Some(b) = self.bbox else { return };
        if p.x.max(q.x) < b.x0 || p.x.min(q.x) > b.x1 || p.y.max(q.y) < b.y0 || p.y.min(q.y) > b.y1 {
            return;
        }
        let d = q - p;
        let (lo, hi) = self.band_range(p.y.min(q.y), p.y.max(q.y));
        for e in self.edges_of_bands(lo, hi) {
            let (a, c) = (Point::new(e[0], e[1]), Point::new(e[2], e[3]));
            if !segments_meet(p, q, a, c) {
                continue;
            }
            let f = c - a;
            let den = d.cross(f);
            if den == 0.0 {
                // Collinear: where the edge's ends project onto p–q.
                let dd = d.dot(d);
                if dd > 0.0 {
                    out.extend([a, c].map(|v| ((v - p).dot(d) / dd).clamp(0.0, 1.0)));
                }
            } else {
                out.push(((a - p).cross(f) / den).clamp(0.0, 1.0));
            }
        }
    }

    /// True when the region covers no area.
    pub fn is_empty(&self) -> bool {
        self.shapes.is_empty()
    }

    /// Bounding box, `None` when empty.
    pub fn bbox(&self) -> Option<Rect> {
        self.bbox
    }

    /// Every contour (outer boundaries and holes) as points.
    pub fn contours(&self) -> impl Iterator<Item = Vec<Point>> + '_ {
        self.shapes.iter().flatten().map(|c| c.iter().map(|p| Point::new(p[0], p[1])).collect())
    }

    /// Number of contour vertices (a measure of the work a cut against this region costs).
    pub fn vertex_count(&self) -> usize {
        self.shapes.iter().flatten().map(Vec::len).sum()
    }

    fn op(&self, other: &Region, rule: OverlayRule) -> Region {
        Region::from_shapes(self.shapes.overlay(&other.shapes, rule, OverlayFill::NonZero))
    }

    /// The area inside both.
    pub fn intersect(&self, other: &Region) -> Region {
        if self.is_empty() || other.is_empty() || !overlaps(self.bbox, other.bbox) {
            return Region::default();
        }
        self.op(other, OverlayRule::Intersect)
    }

    /// The area inside either.
    pub fn union(&self, other: &Region) -> Region {
        if self.is_empty() {
            return other.clone();
        }
        if other.is_empty() {
            return self.clone();
        }
        self.op(other, OverlayRule::Union)
    }

    /// The area inside `self` and outside `other`.
    pub fn difference(&self, other: &Region) -> Region {
        if self.is_empty() || other.is_empty() || !overlaps(self.bbox, other.bbox) {
            return self.clone();
        }
        self.op(other, OverlayRule::Difference)
    }

    /// Winding number of `p` against the normalised contours: 1 inside, 0 outside (on the boundary either).
    /// Used by tests and property checks as an independent inside test.
    pub fn winding(&self, p: Point) -> i32 {
        let mut w = 0;
        for c in self.shapes.iter().flatten() {
            for i in 0..c.len() {
                let (a, b) = (c[i], c[(i + 1) % c.len()]);
                let cross = (b[0] - a[0]) * (p.y - a[1]) - (p.x - a[0]) * (b[1] - a[1]);
                if a[1] <= p.y {
                    if b[1] > p.y && cross > 0.0 {
                        w += 1;
                    }
                } else if b[1] <= p.y && cross < 0.0 {
                    w -= 1;
                }
            }
        }
        w
    }

    /// Distance from `p` to the nearest contour edge.
    pub fn boundary_distance(&self, p: Point) -> f64 {
        let mut best = f64::INFINITY;
        for c in self.shapes.iter().flatten() {
            for i in 0..c.len() {
                let (a, b) = (c[i], c[(i + 1) % c.len()]);
                let seg = kurbo::Line::new((a[0], a[1]), (b[0], b[1]));
                best = best.min(kurbo::ParamCurveNearest::nearest(&seg, p, 1e-12).distance_sq.sqrt());
            }
        }
        best
    }

    /// True when `p` lies inside by more than `margin` (used by property tests).
    pub fn strictly_contains(&self, p: Point, margin: f64) -> bool {
        self.winding(p) != 0 && self.boundary_distance(p) > margin
    }
}

/// How a height maps to one of `n` equal horizontal bands of a bounding box: band `⌊(y − y0)·scale⌋`, clamped.
/// One multiplication and a truncating cast (no division, no call to `floor`), the same map for placing edges and
/// for looking points up — so an edge reaching from `y0` to `y1` is in every band a height between them maps to.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct Bands {
    y0: f64,
    scale: f64,
    last: usize,
}

impl Bands {
    fn new(n: usize, b: Rect) -> Bands {
        Bands { y0: b.y0, scale: n as f64 / b.height().max(1e-12), last: n - 1 }
    }

    /// The band of height `y` (the first or the last outside the box).
    #[inline]
    fn at(&self, y: f64) -> usize {
        // Negative (and NaN) become 0 before the cast, which truncates like `floor` at or above 0.
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let band = ((y - self.y0) * self.scale).max(0.0) as usize;
        band.min(self.last)
    }
}

/// True when segments `p`–`q` and `a`–`b` intersect or touch (collinear overlaps included).
fn segments_meet(p: Point, q: Point, a: Point, b: Point) -> bool {
    if p.x.max(q.x) < a.x.min(b.x)
        || a.x.max(b.x) < p.x.min(q.x)
        || p.y.max(q.y) < a.y.min(b.y)
        || a.y.max(b.y) < p.y.min(q.y)
    {
        return false;
    }
    let orient = |u: Point, v: Point, w: Point| (v - u).cross(w - u);
    let (d1, d2) = (orient(a, b, p), orient(a, b, q));
    let (d3, d4) = (orient(p, q, a), orient(p, q, b));
    // The bounding boxes overlap, so a zero orientation means contact or collinear overlap: report it.
    (d1 * d2 <= 0.0) && (d3 * d4 <= 0.0)
}

fn overlaps(a: Option<Rect>, b: Option<Rect>) -> bool {
    match (a, b) {
        (Some(a), Some(b)) => a.x0 <= b.x1 && b.x0 <= a.x1 && a.y0 <= b.y1 && b.y0 <= a.y1,
        _ => false,
    }
}

/// Bounding box of a polyline (`None` when empty).
pub fn polyline_bbox(points: &[Point]) -> Option<Rect> {
    let first = points.first()?;
    Some(points[1..].iter().fold(Rect::from_points(*first, *first), |r, p| r.union_pt(*p)))
}

/// Which part of the polylines a cut keeps.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Keep {
    /// The parts inside the region (clip paths, masks, hatching); parts running along the boundary are kept.
    Inside,
    /// The parts outside every region (e.g. what lies off the page); parts running along a boundary are kept.
    Outside,
}

/// Cut `lines` by the union of `regions`, keeping the parts `keep` says. Lines whose bounding box misses every
/// region come back unchanged (for [`Keep::Outside`]) or are dropped (for [`Keep::Inside`]).
pub fn cut(lines: Vec<Vec<Point>>, regions: &[&Region], keep: Keep) -> Vec<Vec<Point>> {
    let regions: Vec<&Region> = regions.iter().copied().filter(|r| !r.is_empty()).collect();
    if regions.is_empty() {
        return if keep == Keep::Inside { Vec::new() } else { lines };
    }
    let mut out = Vec::new();
    let mut todo: Vec<Vec<[f64; 2]>> = Vec::new();
    for line in lines {
        if line.len() < 2 {
            continue;
        }
        // Lines that do not meet any boundary are decided without a cut (and stay bit for bit as they were).
        let mut inside_any = false;
        let mut crosses = false;
        for r in &regions {
            match r.classify(&line) {
                Class::Inside => inside_any = true,
                Class::Crosses => crosses = true,
                Class::Outside => {}
            }
        }
        if inside_any {
            if keep == Keep::Inside {
                out.push(line);
            }
        } else if crosses {
            todo.push(line.iter().map(|p| [p.x, p.y]).collect());
        } else if keep == Keep::Outside {
            out.push(line);
        }
    }
    if todo.is_empty() {
        return out;
    }
    let shapes: Vec<&Shape> = regions.iter().flat_map(|r| r.shapes.iter()).collect();
    let shapes: Vec<Shape> = shapes.into_iter().cloned().collect();
    let rule = ClipRule { invert: keep == Keep::Outside, boundary_included: keep == Keep::Inside };
    let pieces = todo.clip_by(&shapes, OverlayFill::NonZero, rule);
    out.extend(
        pieces
            .into_iter()
            .filter(|p| p.len() >= 2)
            .map(|p| p.into_iter().map(|q| Point::new(q[0], q[1])).collect::<Vec<Point>>())
            .filter(|p| p.windows(2).any(|w| w[0] != w[1])),
    );
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn len(lines: &[Vec<Point>]) -> f64 {
        lines.iter().flat_map(|l| l.windows(2)).map(|w| w[0].distance(w[1])).sum()
    }

    fn square(x: f64, y: f64, s: f64) -> Vec<Point> {
        vec![Point::new(x, y), Point::new(x + s, y), Point::new(x + s, y + s), Point::new(x, y + s)]
    }

    #[test]
    fn cut_a_line_by_a_square_inside_and_outside() {
        let r = Region::rect(Rect::new(0.0, 0.0, 10.0, 10.0));
        let line = vec![vec![Point::new(-5.0, 5.0), Point::new(15.0, 5.0)]];
        // 20 mm line, 10 mm of it inside.
        assert!((len(&cut(line.clone(), &[&r], Keep::Inside)) - 10.0).abs() < 1e-6);
        assert!((len(&cut(line, &[&r], Keep::Outside)) - 10.0).abs() < 1e-6);
    }

    #[test]
    fn even_odd_makes_a_hole_and_non_zero_does_not() {
        // Two concentric squares drawn the same way round: even-odd has a hole, non-zero does not.
        let (outer, inner) = (square(0.0, 0.0, 10.0), square(3.0, 3.0, 4.0));
        let eo = Region::from_contours([outer.as_slice(), inner.as_slice()], FillRule::EvenOdd);
        let nz = Region::from_contours([outer.as_slice(), inner.as_slice()], FillRule::NonZero);
        let line = vec![vec![Point::new(-1.0, 5.0), Point::new(11.0, 5.0)]];
        // Even-odd: 10 − 4 = 6 mm inside; non-zero: the full 10 mm.
        assert!((len(&cut(line.clone(), &[&eo], Keep::Inside)) - 6.0).abs() < 1e-6);
        assert!((len(&cut(line, &[&nz], Keep::Inside)) - 10.0).abs() < 1e-6);
        assert_eq!(eo.winding(Point::new(5.0, 5.0)), 0);
        assert_ne!(eo.winding(Point::new(1.0, 5.0)), 0);
    }

    #[test]
    fn several_regions_cut_as_their_union() {
        // Two overlapping squares drawn in opposite directions: their union, not a cancelling winding sum.
        let a = Region::from_contours([square(0.0, 0.0, 10.0).as_slice()], FillRule::NonZero);
        let mut b_pts = square(5.0, 0.0, 10.0);
        b_pts.reverse();
        let b = Region::from_contours([b_pts.as_slice()], FillRule::NonZero);
        let line = vec![vec![Point::new(-5.0, 5.0), Point::new(20.0, 5.0)]];
        // Union spans x 0..15: 15 mm inside, 10 mm outside.
        assert!((len(&cut(line.clone(), &[&a, &b], Keep::Inside)) - 15.0).abs() < 1e-6);
        assert!((len(&cut(line, &[&a, &b], Keep::Outside)) - 10.0).abs() < 1e-6);
        // Booleans: intersection 5×10, difference 5×10 (area via a probe line at y = 5).
        let probe = || vec![vec![Point::new(-5.0, 5.0), Point::new(20.0, 5.0)]];
        assert!((len(&cut(probe(), &[&a.intersect(&b)], Keep::Inside)) - 5.0).abs() < 1e-6);
        assert!((len(&cut(probe(), &[&a.difference(&b)], Keep::Inside)) - 5.0).abs() < 1e-6);
        assert!((len(&cut(probe(), &[&a.union(&b)], Keep::Inside)) - 15.0).abs() < 1e-6);
    }

    #[test]
    fn far_lines_pass_untouched() {
        let r = Region::rect(Rect::new(0.0, 0.0, 1.0, 1.0));
        let line = vec![Point::new(5.1, 5.3), Point::new(7.7, 9.9), Point::new(5.1, 5.3)];
        assert_eq!(cut(vec![line.clone()], &[&r], Keep::Outside), vec![line.clone()]);
        assert!(cut(vec![line], &[&r], Keep::Inside).is_empty());
    }

    #[test]
    fn a_height_maps_to_its_band_by_hand() {
        // Four bands over y 10..30, 5 mm each.
        let b = Bands::new(4, Rect::new(0.0, 10.0, 1.0, 30.0));
        let at = |y: f64| b.at(y);
        assert_eq!(
            [at(-3.0), at(9.9), at(10.0), at(14.99), at(15.0), at(24.0), at(25.0), at(30.0)],
            [0, 0, 0, 0, 1, 2, 3, 3]
        );
        assert_eq!((at(1e300), at(f64::NAN), at(f64::NEG_INFINITY)), (3, 0, 0));
    }

    proptest::proptest! {
        /// The banded point test sees every edge the full winding count sees: the same answer at random points and
        /// at every vertex height (where edges start and end, the places a band map could drop one).
        #[test]
        fn banded_contains_agrees_with_the_full_winding_count(
            pts in proptest::collection::vec((0.0..100.0f64, 0.0..100.0f64), 3..80),
            probes in proptest::collection::vec((-5.0..105.0f64, -5.0..105.0f64), 1..40),
            even_odd in proptest::bool::ANY,
        ) {
            let contour: Vec<Point> = pts.iter().map(|&(x, y)| Point::new(x, y)).collect();
            let rule = if even_odd { FillRule::EvenOdd } else { FillRule::NonZero };
            let r = Region::from_contours([contour.as_slice()], rule);
            let vertices: Vec<Point> = r.contours().flatten().collect();
            let mut at = probes.iter().map(|&(x, y)| Point::new(x, y)).collect::<Vec<_>>();
            // Each vertex height, probed left of, at and right of the vertex.
            for v in &vertices {
                at.extend([Point::new(v.x - 0.5, v.y), *v, Point::new(v.x + 0.5, v.y)]);
            }
            for p in at {
                proptest::prop_assert_eq!(r.contains(p), r.winding(p) != 0, "at {:?}", p);
            }
        }
    }
}
