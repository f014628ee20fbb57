//! Mosaic style: the picture cut into Voronoi cells, small where it is dark or detailed and large where it is light
//! and flat, each cell hatched at its own mean darkness with the tone model's ladder ([`super::tone::Ladder`]).
//!
//! **Cells.** The picture is tiled with squares of the largest cell size; a square is split into four while its
//! darkness (mean, or three times its spread for detail) asks for smaller cells, down to the smallest size. Each
//! square left gets one seed, jittered about its middle, and the seeds' Voronoi cells (from a Delaunay triangulation
//! by the `spade` crate, with a ring of seeds outside the picture so every cell is bounded) are clipped to the
//! picture. The smallest cell is four closest spacings across, so even the darkest cell holds a few lines; the
//! largest is sixteen by default.
//!
//! **Shading.** A cell's tone is the mean darkness of the pixel centres inside it (mean darkness, not mean
//! lightness: the eye averages light). The ladder's rung for it gives the families and their spacing; each cell's
//! lines run at an angle of its own (the mosaic's look, and neighbouring cells' lines do not line up into stripes),
//! each span ends a pen radius inside the cell so the ink stays in it, and a family's spans are joined into one
//! zig-zag (a cell is convex, so every connector stays inside). The connectors add ink the spacing did not count,
//! so each family is respaced once to match its share. Cell outlines are optional: they add ink the tone did not
//! ask for.

use super::ink::{InkGrid, unit};
use super::lines::{LineFamily, line_spans, pen_span};
use super::tone::{DarknessMap, Ladder, line_coverage};
use super::zigzag;
use kurbo::Point;
use spade::{DelaunayTriangulation, HasPosition, Point2, Triangulation};

/// Mosaic settings.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct MosaicOptions {
    /// Draw every shaded cell's outline as well (darker than the tone asks for, but shows the mosaic).
    pub outline: bool,
    /// Largest cell size in mm; `None` means sixteen times the closest line spacing.
    pub cell_mm: Option<f64>,
}

/// The mosaic's strokes: the hatch of every cell, and the cell outlines if asked for.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Mosaic {
    /// The cells' zig-zag hatching, pixel coordinates.
    pub strokes: Vec<Vec<Point>>,
    /// Closed outlines of the shaded cells (empty unless outlines were asked for), pixel coordinates.
    pub outlines: Vec<Vec<Point>>,
    /// Number of cells the picture was cut into.
    pub cells: usize,
}

/// Turns between the ladder's families, degrees from the cell's own angle.
const FAMILY_TURNS: [f64; 3] = [0.0, 90.0, 45.0];

/// Cut `map` into cells and hatch each at its mean darkness. `ladder` gives the pen and closest spacing (mm),
/// `pixel_mm` converts them to pixels, `angle_deg` is the base angle every cell's own angle is turned from.
pub fn mosaic(map: &DarknessMap, ladder: &Ladder, pixel_mm: f64, angle_deg: f64, options: &MosaicOptions) -> Mosaic {
    let (w, h) = (map.width, map.height);
    if w == 0 || h == 0 || pixel_mm.is_nan() || pixel_mm <= 0.0 {
        return Mosaic::default();
    }
    let min_px = (4.0 * ladder.min_spacing_mm / pixel_mm).max(2.0);
    let max_px = (options.cell_mm.unwrap_or(16.0 * ladder.min_spacing_mm) / pixel_mm).max(min_px);
    let sums = Sums::new(map);
    let seeds = seeds(&sums, min_px, max_px);
    let cells = cells(&seeds, w, h, max_px);
    let pen_px = ladder.pen_mm / pixel_mm;
    let mut out = Mosaic { cells: cells.len(), ..Mosaic::default() };
    for (i, cell) in cells.iter().enumerate() {
        let Some((mean, area, whole)) = sums.mean_in(cell) else { continue };
        let rung = ladder.rung_to_black(mean);
        if rung.families == 0 {
            continue;
        }
        let mut loop_ = cell.clone();
        loop_.push(cell[0]);
        let period = rung.spacing_mm / pixel_mm;
        let c = line_coverage(pen_px, period);
        let target = c * area;
        let turn = 180.0 * unit(i as u64, 1);
        let turns = &FAMILY_TURNS[..usize::from(rung.families)];
        let family = |t: f64, scale: f64| {
            let angle = (angle_deg + turn + t).to_radians();
            let phase = period * unit(i as u64, 2 + t.to_bits()) * scale;
            LineFamily { angle, period: period * scale, phase }
        };
        let mut scales = Vec::with_capacity(turns.len());
        let mut strokes = Vec::new();
        for &t in turns {
            let mut s = family_strokes(&loop_, &family(t, 1.0), pen_px, map);
            let ink = stroke_ink(&s, pen_px);
            let mut scale = 1.0;
            // Lines already touching cannot be closed up further: respaced, they could only lighten the cell.
            if ink > 0.0 && target > 0.0 && period > pen_px {
                scale = (ink / target).clamp(0.5, 2.0).max(pen_px / period);
                s = family_strokes(&loop_, &family(t, scale), pen_px, map);
            }
            scales.push(scale);
            strokes.push(s);
        }
        // The families together, as drawn, against the rung's coverage: closed up (or opened) once more where
        // they miss it.
        if period > pen_px && c < 1.0 {
            let seen = cell_ink(cell, strokes.iter().flatten(), pen_px, (!whole).then_some(map));
            if let Some(k) = seen.and_then(|seen| closer(c, rung.coverage, seen, turns.len())) {
                for ((s, scale), &t) in strokes.iter_mut().zip(&scales).zip(turns) {
                    let respaced = (scale / k).max(pen_px / period);
                    *s = family_strokes(&loop_, &family(t, respaced), pen_px, map);
                }
            }
        }
        out.strokes.extend(strokes.into_iter().flatten());
        // A cell filled solid (lines a pen width apart) and holding no paper also gets its edge traced a pen
        // radius inside: the lines' round ends leave slivers of paper along it.
        if rung.spacing_mm <= ladder.pen_mm && whole {
            let mut edge = inset(cell, pen_px / 2.0);
            if let Some(&first) = edge.first() {
                edge.push(first);
                out.strokes.push(edge);
            }
        }
        if options.outline {
            out.outlines.push(loop_);
        }
    }
    out
}

/// Summed-area tables of the darkness and its square, for the mean and spread of any square, and a running sum
/// along every row, for the mean over a cell's pixel centres.
struct Sums {
    width: usize,
    height: usize,
    /// `(width + 1) × (height + 1)`: sum of darkness over `[0, x) × [0, y)`.
    area: Vec<f64>,
    /// The same for darkness squared.
    area2: Vec<f64>,
    /// `(width + 1)` per row: sum of darkness over `[0, x)` of that row.
    rows: Vec<f64>,
    /// `(width + 1)` per row: how many pixels of `[0, x)` of that row are not paper.
    inked: Vec<u32>,
}

impl Sums {
    fn new(map: &DarknessMap) -> Self {
        let (w, h) = (map.width, map.height);
        let mut area = vec![0.0; (w + 1) * (h + 1)];
        let mut area2 = vec![0.0; (w + 1) * (h + 1)];
        let mut rows = vec![0.0; (w + 1) * h];
        let mut inked = vec![0u32; (w + 1) * h];
        for y in 0..h {
            let (mut run, mut run2, mut count) = (0.0, 0.0, 0u32);
            for x in 0..w {
                let d = f64::from(map.data[y * w + x]);
                run += d;
                run2 += d * d;
                count += u32::from(d > 0.0);
                rows[y * (w + 1) + x + 1] = run;
                inked[y * (w + 1) + x + 1] = count;
                area[(y + 1) * (w + 1) + x + 1] = area[y * (w + 1) + x + 1] + run;
                area2[(y + 1) * (w + 1) + x + 1] = area2[y * (w + 1) + x + 1] + run2;
            }
        }
        Sums { width: w, height: h, area, area2, rows, inked }
    }

    /// Mean and standard deviation of the darkness over pixels `[x0, x1) × [y0, y1)`.
    fn stats(&self, x0: usize, x1: usize, y0: usize, y1: usize) -> (f64, f64) {
        let s = self.width + 1;
        let box_sum = |t: &[f64]| t[y1 * s + x1] - t[y0 * s + x1] - t[y1 * s + x0] + t[y0 * s + x0];
        #[allow(clippy::cast_precision_loss)] // pixel counts are far below 2^53
        let n = ((x1 - x0) * (y1 - y0)).max(1) as f64;
        let mean = box_sum(&self.area) / n;
        let var = (box_sum(&self.area2) / n - mean * mean).max(0.0);
        (mean, var.sqrt())
    }

    /// Mean darkness of the pixel centres inside the convex polygon `cell` that are not paper, their number (the
    /// area the cell shades, in pixels), and whether that is all of the cell's pixels; `None` when no such centre
    /// lies inside. Paper stays paper: a cell across a shape's edge shades only the shape's side, at the shape's
    /// tone (averaged with the paper, a black square's edge cells plotted half dark and spilled 4 mm past it).
    fn mean_in(&self, cell: &[Point]) -> Option<(f64, f64, bool)> {
        let (lo, hi) = cell.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| (a.min(p.y), b.max(p.y)));
        let last = (hi - 0.5).floor();
        if last < 0.0 || self.height == 0 {
            return None;
        }
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)] // both clamped to the picture's rows
        let (r0, r1) = ((lo - 0.5).ceil().max(0.0) as usize, (last as usize).min(self.height - 1));
        let (mut sum, mut count, mut all) = (0.0, 0u64, 0usize);
        for row in r0..=r1 {
            #[allow(clippy::cast_precision_loss)]
            let y = row as f64 + 0.5;
            let Some((xa, xb)) = span_at(cell, y) else { continue };
            #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss, clippy::cast_precision_loss)]
            let (c0, c1) = ((xa - 0.5).ceil().max(0.0) as usize, ((xb - 0.5).floor() + 1.0).min(self.width as f64));
            if c1 <= 0.0 {
                continue;
            }
            #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
            let c1 = c1 as usize;
            if c1 <= c0 {
                continue;
            }
            let r = &self.rows[row * (self.width + 1)..];
            let k = &self.inked[row * (self.width + 1)..];
            sum += r[c1] - r[c0];
            count += u64::from(k[c1] - k[c0]);
            all += c1 - c0;
        }
        #[allow(clippy::cast_precision_loss)]
        (count > 0).then(|| (sum / count as f64, count as f64, count == all as u64))
    }
}

/// Where the horizontal line at `y` crosses the convex polygon `cell`: its leftmost and rightmost points.
fn span_at(cell: &[Point], y: f64) -> Option<(f64, f64)> {
    let (mut a, mut b) = (f64::INFINITY, f64::NEG_INFINITY);
    for i in 0..cell.len() {
        let (p, q) = (cell[i], cell[(i + 1) % cell.len()]);
        if (p.y <= y) != (q.y <= y) {
            let x = p.x + (y - p.y) / (q.y - p.y) * (q.x - p.x);
            a = a.min(x);
            b = b.max(x);
        }
    }
    (a <= b).then_some((a, b))
}

/// The cell size the darkness of a square asks for: the largest for flat paper, the smallest for black or for a
/// square whose tone spreads widely (an edge), in between by the square root so mid-tones already get small cells.
fn wanted(mean: f64, spread: f64, min_px: f64, max_px: f64) -> f64 {
    let t = mean.max(3.0 * spread).clamp(0.0, 1.0).sqrt();
    max_px + (min_px - max_px) * t
}

/// One seed per square of the quadtree, jittered within the square's middle half.
fn seeds(sums: &Sums, min_px: f64, max_px: f64) -> Vec<Point> {
    let (w, h) = (sums.width, sums.height);
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let top = max_px.round().max(1.0) as usize;
    let mut out = Vec::new();
    let mut stack = Vec::new();
    for y in (0..h).step_by(top) {
        for x in (0..w).step_by(top) {
            stack.push((x, y, top));
        }
    }
    while let Some((x, y, side)) = stack.pop() {
        let (x1, y1) = ((x + side).min(w), (y + side).min(h));
        let (mean, spread) = sums.stats(x, x1, y, y1);
        #[allow(clippy::cast_precision_loss)]
        let s = side as f64;
        if s / 2.0 >= min_px && s > 1.4 * wanted(mean, spread, min_px, max_px) {
            let half = side.div_ceil(2);
            for (dx, dy) in [(0, 0), (half, 0), (0, half), (half, half)] {
                if x + dx < w && y + dy < h {
                    stack.push((x + dx, y + dy, half));
                }
            }
            continue;
        }
        let n = out.len() as u64;
        #[allow(clippy::cast_precision_loss)]
        let (cx, cy, sx, sy) = (x as f64, y as f64, (x1 - x) as f64, (y1 - y) as f64);
        out.push(Point::new(cx + sx * (0.25 + 0.5 * unit(n, 11)), cy + sy * (0.25 + 0.5 * unit(n, 12))));
    }
    out
}

struct Site {
    at: Point2<f64>,
    real: bool,
}

impl HasPosition for Site {
    type Scalar = f64;
    fn position(&self) -> Point2<f64> {
        self.at
    }
}

/// The Voronoi cells of `seeds` clipped to `[0, w] × [0, h]`, in the seeds' order (a cell clipped away entirely
/// is left out). A ring of seeds `2 · ring_px` outside the picture bounds every real seed's cell.
fn cells(seeds: &[Point], w: usize, h: usize, ring_px: f64) -> Vec<Vec<Point>> {
    #[allow(clippy::cast_precision_loss)]
    let (wf, hf) = (w as f64, h as f64);
    let mut sites: Vec<Site> = seeds.iter().map(|p| Site { at: Point2::new(p.x, p.y), real: true }).collect();
    let m = 2.0 * ring_px.max(1.0);
    let step = ring_px.max(1.0);
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let (nx, ny) = (((wf + 2.0 * m) / step).ceil() as usize, ((hf + 2.0 * m) / step).ceil() as usize);
    for i in 0..=nx {
        #[allow(clippy::cast_precision_loss)]
        let x = -m + (wf + 2.0 * m) * i as f64 / nx as f64;
        sites.push(Site { at: Point2::new(x, -m), real: false });
        sites.push(Site { at: Point2::new(x, hf + m), real: false });
    }
    for j in 1..ny {
        #[allow(clippy::cast_precision_loss)]
        let y = -m + (hf + 2.0 * m) * j as f64 / ny as f64;
        sites.push(Site { at: Point2::new(-m, y), real: false });
        sites.push(Site { at: Point2::new(wf + m, y), real: false });
    }
    let Ok(dt) = DelaunayTriangulation::<Site>::bulk_load_stable(sites) else {
        return Vec::new();
    };
    let mut out = Vec::with_capacity(seeds.len());
    for v in dt.vertices() {
        if !v.data().real {
            continue;
        }
        let mut poly = Vec::new();
        let mut bounded = true;
        for e in v.out_edges() {
            match e.face().as_inner() {
                Some(f) => {
                    let c = f.circumcenter();
                    poly.push(Point::new(c.x, c.y));
                }
                None => bounded = false,
            }
        }
        if !bounded || poly.len() < 3 {
            continue;
        }
        let clipped = clip_to_box(&poly, wf, hf);
        if clipped.len() >= 3 {
            out.push(clipped);
        }
    }
    out
}

/// The convex polygon `poly` clipped to `[0, w] × [0, h]`.
fn clip_to_box(poly: &[Point], w: f64, h: f64) -> Vec<Point> {
    let mut cur = poly.to_vec();
    for (n, c) in [((1.0, 0.0), 0.0), ((-1.0, 0.0), -w), ((0.0, 1.0), 0.0), ((0.0, -1.0), -h)] {
        cur = clip_half_plane(&cur, n, c);
    }
    cur
}

/// The part of the convex polygon `poly` where `n · p ≥ c` (Sutherland–Hodgman, one side).
fn clip_half_plane(poly: &[Point], n: (f64, f64), c: f64) -> Vec<Point> {
    let side = |p: Point| p.x * n.0 + p.y * n.1 - c;
    let mut next = Vec::with_capacity(poly.len() + 2);
    for i in 0..poly.len() {
        let (p, q) = (poly[i], poly[(i + 1) % poly.len()]);
        let (sp, sq) = (side(p), side(q));
        if sp >= 0.0 {
            next.push(p);
        }
        if (sp >= 0.0) != (sq >= 0.0) {
            next.push(p.lerp(q, sp / (sp - sq)));
        }
    }
    next
}

/// The convex polygon `cell` shrunk by `r` on every side (empty when it is narrower than `2r`).
fn inset(cell: &[Point], r: f64) -> Vec<Point> {
    let twice_area: f64 = (0..cell.len())
        .map(|i| {
            let (p, q) = (cell[i], cell[(i + 1) % cell.len()]);
            p.x * q.y - q.x * p.y
        })
        .sum();
    let turn = twice_area.signum();
    let mut cur = cell.to_vec();
    for i in 0..cell.len() {
        let (p, q) = (cell[i], cell[(i + 1) % cell.len()]);
        let d = q - p;
        let len = d.hypot();
        if len <= 0.0 || cur.len() < 3 {
            continue;
        }
        // The inward normal: left of the edge for a counter-clockwise polygon.
        let n = (-d.y * turn / len, d.x * turn / len);
        cur = clip_half_plane(&cur, n, p.x * n.0 + p.y * n.1 + r);
    }
    if cur.len() >= 3 { cur } else { Vec::new() }
}

/// One family's strokes in a convex cell (closed `loop_`): each span cut where it crosses paper pixels of `map`,
/// each piece pulled in by the pen's radius at both ends so its round caps stay in the cell and off the paper, a
/// piece too short for that kept as a dot when the dot's ink is at most twice the span's, and the pieces joined into
/// one zig-zag by connectors that cross no paper (the cell is convex, so they stay inside it).
fn family_strokes(loop_: &[Point], f: &LineFamily, pen_px: f64, map: &DarknessMap) -> Vec<Vec<Point>> {
    let r = pen_px / 2.0;
    let (d, n) = f.frame();
    let mut lines = line_spans(std::slice::from_ref(&loop_.to_vec()), f);
    for line in &mut lines {
        let v = line.v;
        let at = |u: f64| Point::new(u * d.0 + v * n.0, u * d.1 + v * n.1);
        line.spans = line
            .spans
            .iter()
            .flat_map(|&span| off_paper(span, &at, map))
            .filter_map(|span| pen_span(span, pen_px, (r, r)))
            .collect();
    }
    lines.retain(|l| !l.spans.is_empty());
    zigzag::join(&lines, f, f64::INFINITY, |a, b| crosses_no_paper(a, b, map))
}

/// Paper within this much of a span is found (pixels): a quarter pixel.
const PAPER_STEP: f64 = 0.25;

/// Whether the pixel under `p` is paper.
fn paper_at(map: &DarknessMap, p: Point) -> bool {
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let (x, y) = (p.x.floor().max(0.0) as usize, p.y.floor().max(0.0) as usize);
    map.at(x.min(map.width.saturating_sub(1)), y.min(map.height.saturating_sub(1))) <= 0.0
}

/// The pieces of the span `(a, b)` (along the line `at`) that lie off the paper of `map`, found at quarter-pixel
/// steps.
fn off_paper((a, b): (f64, f64), at: &impl Fn(f64) -> Point, map: &DarknessMap) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let n = ((b - a) / PAPER_STEP).ceil().max(1.0) as usize;
    let mut start: Option<f64> = None;
    for i in 0..=n {
        #[allow(clippy::cast_precision_loss)]
        let u = a + (b - a) * i as f64 / n as f64;
        match (paper_at(map, at(u)), start) {
            (false, None) => start = Some(u),
            (true, Some(s)) => {
                #[allow(clippy::cast_precision_loss)]
                out.push((s, (u - (b - a) / n as f64 / 2.0).max(s)));
                start = None;
            }
            _ => {}
        }
    }
    if let Some(s) = start {
        out.push((s, b));
    }
    out
}

/// Whether the segment `a`→`b` crosses no paper pixel of `map` (checked every quarter pixel).
fn crosses_no_paper(a: Point, b: Point, map: &DarknessMap) -> bool {
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let n = (a.distance(b) / PAPER_STEP).ceil().max(1.0) as usize;
    #[allow(clippy::cast_precision_loss)]
    (0..=n).all(|i| !paper_at(map, a.lerp(b, i as f64 / n as f64)))
}

/// Samples across the smallest cell side [`cell_ink`] looks at, per pen width: finer than the measure's sixth, so a
/// small dark cell's few specks of paper are counted within a few percent.
const SAMPLES_PER_PEN: f64 = 8.0;

/// Most samples [`cell_ink`] looks at in one cell: the large light cells are sampled more coarsely.
const MOST_SAMPLES: f64 = 4096.0;

/// The fraction of the convex `cell` (pixels) the `strokes`, a pen `pen` px wide, ink: looked at on a grid of
/// [`SAMPLES_PER_PEN`] points per pen width (coarser in a large cell, at most [`MOST_SAMPLES`]), counting only the
/// points inside the cell and, given a `map`, off its paper. `None` when no point is.
fn cell_ink<'a>(
    cell: &[Point],
    strokes: impl Iterator<Item = &'a Vec<Point>>,
    pen: f64,
    map: Option<&DarknessMap>,
) -> Option<f64> {
    let (lo, hi) = cell.iter().fold(
        (Point::new(f64::INFINITY, f64::INFINITY), Point::new(f64::NEG_INFINITY, f64::NEG_INFINITY)),
        |(a, b), p| (Point::new(a.x.min(p.x), a.y.min(p.y)), Point::new(b.x.max(p.x), b.y.max(p.y))),
    );
    let (w, h) = (hi.x - lo.x, hi.y - lo.y);
    if !(w > 0.0 && h > 0.0 && pen > 0.0) {
        return None;
    }
    let step = (pen / SAMPLES_PER_PEN).max((w * h / MOST_SAMPLES).sqrt());
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)] // at most a few thousand samples
    let (columns, rows) = ((w / step).ceil() as usize, (h / step).ceil() as usize);
    let shifted: Vec<Vec<Point>> =
        strokes.map(|s| s.iter().map(|p| Point::new(p.x - lo.x, p.y - lo.y)).collect()).collect();
    let mut grid = InkGrid::new(columns, rows, step);
    grid.draw(&shifted, pen);
    let (mut inked, mut all) = (0usize, 0usize);
    for row in 0..rows {
        #[allow(clippy::cast_precision_loss)]
        let y = lo.y + (row as f64 + 0.5) * step;
        let Some((xa, xb)) = span_at(cell, y) else { continue };
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let (c0, c1) = (((xa - lo.x) / step - 0.5).ceil().max(0.0) as usize, ((xb - lo.x) / step - 0.5).floor());
        if c1 < 0.0 {
            continue;
        }
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let c1 = (c1 as usize).min(columns - 1);
        for col in c0..=c1 {
            #[allow(clippy::cast_precision_loss)]
            let p = Point::new(lo.x + (col as f64 + 0.5) * step, y);
            if map.is_some_and(|m| paper_at(m, p)) {
                continue;
            }
            all += 1;
            inked += usize::from(grid.ink[row * columns + col]);
        }
    }
    #[allow(clippy::cast_precision_loss)]
    (all > 0).then(|| inked as f64 / all as f64)
}

/// The factor by which `n` crossed families, each meant to cover `c`, must close up so that the `coverage` their
/// rung asks for is met when, as drawn, they cover `seen`; `None` when they meet it already (within a thousandth of
/// the spacing) or cannot be measured (no paper left between them).
///
/// Crossed families leave `Π(1 − cₖ)` of the paper bare, so closing every family up by `k` (coverage `k c`) leaves
/// `(1 − k c)ⁿ / (1 − c)ⁿ` of the bare paper seen: `k = (1 − (1 − c) · ((1 − coverage) / (1 − seen))^(1/n)) / c`,
/// held to 0.8–1.25.
///
/// Why it is needed: each family is spaced from its own ink, and the families are drawn as if they crossed at
/// random, but in a small cell they do not. Their zig-zags' connectors all run along the cell's edge a pen radius
/// inside, inking the band along it far more than the middle, and crossed families cover less of unevenly spread
/// ink than of the same ink spread evenly; and the ink each family counts (spans, caps, connectors less their
/// turns' overlap) runs a few percent over what it inks once its lines nearly touch. On a flat L* 7.5 (three
/// families 0.376 mm apart in 1.8 mm cells, pen 0.3 mm) each family inked 0.784 for its 0.798 and together 0.9865
/// (0.9896 had they crossed at random) for 0.9917: L* 11.3 for 7.5.
fn closer(c: f64, coverage: f64, seen: f64, n: usize) -> Option<f64> {
    let (bare, want) = (1.0 - seen, 1.0 - coverage);
    if !(bare > 0.0 && c > 0.0 && c < 1.0 && n > 0) {
        return None;
    }
    #[allow(clippy::cast_precision_loss)]
    let q = (1.0 - c) * (want / bare).powf(1.0 / n as f64);
    let k = ((1.0 - q) / c).clamp(0.8, 1.25);
    ((k - 1.0).abs() > 1e-3).then_some(k)
}

/// The paper strokes `pen` wide cover: each segment's rectangle, the two round caps of each stroke, and at each
/// turn by `φ` the round join's wedge outside (`r² φ / 2`) less the overlap of the two rectangles inside
/// (`r² tan(φ / 2)`, at most the shorter segment's rectangle beside the turn). At black the lines touch, and a
/// zig-zag's connectors lie mostly over the ends of the lines they join: counted whole they would make the cell
/// look darker than it is.
fn stroke_ink(strokes: &[Vec<Point>], pen: f64) -> f64 {
    let r = pen / 2.0;
    let caps = std::f64::consts::PI * r * r;
    let mut ink = 0.0;
    for s in strokes {
        ink += caps + s.windows(2).map(|e| e[0].distance(e[1])).sum::<f64>() * pen;
        for j in s.windows(3) {
            let (a, b) = (j[1] - j[0], j[2] - j[1]);
            let (la, lb) = (a.hypot(), b.hypot());
            if la <= 0.0 || lb <= 0.0 {
                continue;
            }
            let phi = (a.dot(b) / (la * lb)).clamp(-1.0, 1.0).acos();
            let overlap = (r * r * (phi / 2.0).tan()).min(r * la.min(lb) * 2.0);
            ink += r * r * phi / 2.0 - overlap;
        }
    }
    ink
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::raster::ink::{InkGrid, ink_in_picture};
    use crate::input::raster::tone::flat;

    const LADDER: Ladder = Ladder { pen_mm: 0.3, min_spacing_mm: 0.45 };

    #[test]
    fn a_white_picture_gets_nothing() {
        let m = mosaic(&flat(120, 80, 0.0), &LADDER, 0.1, 45.0, &MosaicOptions { outline: true, cell_mm: None });
        assert!(m.cells > 0);
        assert!(m.strokes.is_empty() && m.outlines.is_empty(), "{} strokes", m.strokes.len());
    }

    #[test]
    fn flat_greys_ink_their_darkness() {
        // 0.1 mm pixels, pen 3 px: the ink over the whole 30 × 30 mm picture (no margin: spans end a pen radius
        // inside every cell, the picture's edge included) matches the darkness.
        for d in [0.15f32, 0.4, 0.7, 0.9] {
            let m = mosaic(&flat(300, 300, d), &LADDER, 0.1, 45.0, &MosaicOptions::default());
            let f = ink_in_picture(&m.strokes, 3.0, 300, 300, 0);
            assert!((f - f64::from(d)).abs() <= 0.03, "darkness {d}: ink {f:.3} in {} cells", m.cells);
        }
    }

    #[test]
    fn a_flat_near_black_plots_at_its_darkness() {
        // L* 7.5 is luminance 7.5 · 27 / 24389 = 0.008303, darkness 0.991697: three families 0.376 mm apart in
        // 1.8 mm cells (pen 0.3 mm, 0.3 mm pixels, so a pen is a pixel). As the tone measure sees it (a jittered
        // grid of tenths of a pixel), 6 px in from the edges, the ink is that darkness within 0.002 (each family
        // spaced from its own ink alone, it inked 0.987: L* 11.3).
        let d = 1.0 - 7.5 * 27.0 / 24389.0;
        #[allow(clippy::cast_possible_truncation)]
        let m = mosaic(&flat(120, 120, d as f32), &LADDER, 0.3, 45.0, &MosaicOptions::default());
        let mut grid = InkGrid::jittered(1200, 1200, 0.1);
        grid.draw(&m.strokes, 1.0);
        let ink = grid.fraction(60, 1140, 60, 1140);
        assert!((ink - d).abs() < 0.002, "ink {ink:.4} for {d:.4}");
    }

    #[test]
    fn crossed_families_close_up_by_the_bare_paper_they_leave() {
        // Three families meant to cover 0.8 each leave 0.016 bare where the rung asks 0.008: each must cover
        // 1 − 0.2 · ∛0.5 = 0.841260, closer by 0.841260 / 0.8 = 1.051575.
        let k = closer(0.8, 0.992, 0.984, 3).unwrap();
        assert!((k - 1.051_575).abs() < 1e-6, "{k}");
        // One family of 0.5 that inks 0.45: it leaves 0.55 for 0.5, so it covers 1 − 0.5 · 0.5 / 0.55 = 6/11,
        // closer by 12/11.
        let k = closer(0.5, 0.5, 0.45, 1).unwrap();
        assert!((k - 12.0 / 11.0).abs() < 1e-12, "{k}");
        // On target, or no paper left to measure by: nothing to do; far off: held to 1.25.
        assert_eq!(closer(0.8, 0.992, 0.992, 3), None);
        assert_eq!(closer(0.8, 0.992, 1.0, 3), None);
        assert_eq!(closer(0.5, 0.9, 0.1, 1), Some(1.25));
    }

    #[test]
    fn a_cell_s_ink_is_counted_inside_it_and_off_its_paper() {
        // A 10 × 10 px square cell with one horizontal line 2 px wide across it at y = 5: 0.2 of it.
        let cell = [Point::new(0.0, 0.0), Point::new(10.0, 0.0), Point::new(10.0, 10.0), Point::new(0.0, 10.0)];
        let line = [vec![Point::new(-1.0, 5.0), Point::new(11.0, 5.0)]];
        let ink = cell_ink(&cell, line.iter(), 2.0, None).unwrap();
        assert!((ink - 0.2).abs() < 1e-9, "{ink}");
        // The left half paper: the line covers 0.2 of the right half still.
        let mut map = flat(10, 10, 1.0);
        for y in 0..10 {
            for x in 0..5 {
                map.data[y * 10 + x] = 0.0;
            }
        }
        let ink = cell_ink(&cell, line.iter(), 2.0, Some(&map)).unwrap();
        assert!((ink - 0.2).abs() < 1e-9, "{ink}");
    }

    #[test]
    fn flat_cells_are_larger_where_lighter() {
        let light = mosaic(&flat(300, 300, 0.1), &LADDER, 0.1, 45.0, &MosaicOptions::default()).cells;
        let dark = mosaic(&flat(300, 300, 0.9), &LADDER, 0.1, 45.0, &MosaicOptions::default()).cells;
        // Largest cells 16 × 0.45 = 7.2 mm: 30 mm is 5 squares across (the last one cut short), 25 cells; at 0.9 the
        // squares split twice, to 1.8 mm (the short ones less).
        assert_eq!(light, 25);
        assert!(dark >= 10 * light, "{dark} cells vs {light}");
    }

    #[test]
    fn a_black_square_gets_the_darkest_rung_inside_and_nothing_outside() {
        // A 20 × 20 mm black square in the middle of a 40 × 40 mm white picture, 0.1 mm pixels.
        let mut map = flat(400, 400, 0.0);
        for y in 100..300 {
            for x in 100..300 {
                map.data[y * 400 + x] = 1.0;
            }
        }
        let m = mosaic(&map, &LADDER, 0.1, 0.0, &MosaicOptions::default());
        let mut grid = InkGrid::new(2000, 2000, 0.2);
        grid.draw(&m.strokes, 3.0);
        // Inside, away from the edge by the smallest cell (1.8 mm = 18 px): solid, as black's rung (lines one pen
        // width apart) gives.
        let inner = grid.fraction(5 * 118, 5 * 282, 5 * 118, 5 * 282);
        assert!(inner > 0.97, "inside {inner:.3}");
        // Outside, beyond the pen's radius (1.5 px, a dot kept for a piece shorter than the pen) and the quarter
        // pixel paper is found within, nothing: cells across the edge shade only the square's side (they once
        // shaded the whole cell at its mean, up to a smallest cell, 18 px, past the edge).
        assert_eq!(grid.fraction(0, 2000, 0, 5 * 98), 0.0);
        assert_eq!(grid.fraction(0, 2000, 5 * 302, 2000), 0.0);
        assert_eq!(grid.fraction(0, 5 * 98, 0, 2000), 0.0);
        assert_eq!(grid.fraction(5 * 302, 2000, 0, 2000), 0.0);
    }

    #[test]
    fn cells_tile_the_picture_and_outlines_are_optional() {
        let map = flat(200, 150, 0.5);
        let m = mosaic(&map, &LADDER, 0.1, 45.0, &MosaicOptions { outline: true, cell_mm: Some(3.0) });
        assert_eq!(m.outlines.len(), m.cells);
        // The cells' areas (shoelace) add up to the picture's.
        let area: f64 = m
            .outlines
            .iter()
            .map(|l| l.windows(2).map(|e| e[0].x * e[1].y - e[1].x * e[0].y).sum::<f64>().abs() / 2.0)
            .sum();
        assert!((area - 200.0 * 150.0).abs() < 1e-6, "{area}");
        // Every stroke point lies in the picture.
        assert!(m.strokes.iter().flatten().all(|p| (0.0..=200.0).contains(&p.x) && (0.0..=150.0).contains(&p.y)));
        assert!(mosaic(&map, &LADDER, 0.1, 45.0, &MosaicOptions::default()).outlines.is_empty());
    }
}
