//! Stipple style: the picture as pen dots, denser where it is darker (weighted Voronoi stippling, after Secord's
//! "Weighted Voronoi Stippling", 2002), optionally joined into one continuous line (TSP art).
//!
//! **How many dots.** Each dot is one touch of the pen, a disc of the pen's width, so `N = Σ darkness · pixel area /
//! dot area` dots cover as much paper as the tone model asks for (dots are spread so they rarely overlap until the
//! tone is near black). White gets no dots.
//!
//! **Where.** The dots start at evenly spaced quantiles of the darkness, taken in reading order, and are then moved
//! by Lloyd relaxation on the density: every pixel belongs to its nearest dot (its Voronoi cell, found by a
//! nearest-vertex query on a Delaunay triangulation of the dots, from the `spade` crate), and each dot moves to the
//! darkness-weighted centroid of its cell. A few rounds spread the dots evenly within each tone.
//!
//! **TSP line.** With `tsp`, the dots are visited in the order found by the path optimizer (nearest neighbour then
//! 2-opt/Or-opt) and drawn as one polyline through them; the optimizer comes after the inputs, so the front end
//! does that join on the traced drawing (`optimize::one_line`).

use super::tone::DarknessMap;
use kurbo::Point;

/// Most dots a picture gets; darker or larger pictures are stippled with this many (each dot then covers more).
pub const MAX_DOTS: usize = 200_000;

/// Stipple settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StippleOptions {
    /// Join every dot into one continuous line, routed by the path optimizer.
    pub tsp: bool,
    /// Rounds of Lloyd relaxation.
    pub iterations: u32,
}

impl Default for StippleOptions {
    fn default() -> Self {
        StippleOptions { tsp: false, iterations: 8 }
    }
}

/// The number of pen dots of diameter `pen_px` (pixels) that cover as much as the map's darkness.
pub fn dot_count(map: &DarknessMap, pen_px: f64) -> usize {
    let total: f64 = map.data.iter().map(|&d| f64::from(d)).sum();
    let dot_area = std::f64::consts::PI * pen_px * pen_px / 4.0;
    if dot_area.is_nan() || dot_area <= 0.0 {
        return 0;
    }
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)] // capped at MAX_DOTS
    let n = (total / dot_area).round().min(MAX_DOTS as f64) as usize;
    n
}

/// Visit every pixel of a `width` × `height` picture once, in the order of a Hilbert curve over the smallest
/// power-of-two square holding it (the parts of the square outside the picture skipped). Consecutive pixels of the
/// curve are side by side, and every run of it fills a compact patch, so quantiles taken along it are spread evenly in
/// both directions (a reading-order walk would line them up in rows).
fn hilbert_pixels(width: usize, height: usize, visit: &mut impl FnMut(usize, usize)) {
    /// The block `origin + s·a + t·b` (s, t in [0, 1]), `a` and `b` axis vectors of equal power-of-two length,
    /// walked as a Hilbert curve entering at its `origin` corner and leaving at its `origin + b` corner.
    fn block(
        origin: (i64, i64),
        a: (i64, i64),
        b: (i64, i64),
        limit: (i64, i64),
        visit: &mut impl FnMut(usize, usize),
    ) {
        let x0 = origin.0 + a.0.min(0) + b.0.min(0);
        let y0 = origin.1 + a.1.min(0) + b.1.min(0);
        let (x1, y1) = (x0 + a.0.abs() + b.0.abs(), y0 + a.1.abs() + b.1.abs());
        if x0 >= limit.0 || y0 >= limit.1 || x1 <= 0 || y1 <= 0 {
            return;
        }
        if x1 - x0 == 1 && y1 - y0 == 1 {
            #[allow(clippy::cast_sign_loss, clippy::cast_possible_truncation)] // inside the picture
            visit(x0 as usize, y0 as usize);
            return;
        }
        let (ha, hb) = ((a.0 / 2, a.1 / 2), (b.0 / 2, b.1 / 2));
        let at = |p: (i64, i64), q: (i64, i64)| (origin.0 + p.0 + q.0, origin.1 + p.1 + q.1);
        // The four quarters: the first turned (its axes swapped), two as the whole, the last turned back the other
        // way, so each leaves where the next begins.
        block(origin, hb, ha, limit, visit);
        block(at(ha, (0, 0)), ha, hb, limit, visit);
        block(at(ha, hb), ha, hb, limit, visit);
        block(at(ha, b), (-hb.0, -hb.1), (-ha.0, -ha.1), limit, visit);
    }
    if width == 0 || height == 0 {
        return;
    }
    let side = width.max(height).next_power_of_two();
    #[allow(clippy::cast_possible_wrap)] // picture sides are far below 2⁶³
    let (s, limit) = (side as i64, (width as i64, height as i64));
    block((0, 0), (s, 0), (0, s), limit, visit);
}

/// Initial dots: walking the pixels along a Hilbert curve, a dot wherever the running sum of darkness passes
/// `(k + ½) · total / n`, shifted within its pixel by how far past the quantile it lies, so no two start at the same
/// place. Exactly `n` dots (for a picture with any darkness), spread evenly within each tone before any relaxation.
fn seed(map: &DarknessMap, n: usize) -> Vec<Point> {
    let total: f64 = map.data.iter().map(|&d| f64::from(d)).sum();
    if n == 0 || total <= 0.0 {
        return Vec::new();
    }
    #[allow(clippy::cast_precision_loss)]
    let step = total / n as f64;
    let mut out = Vec::with_capacity(n);
    let mut acc = 0.0;
    let mut next = step / 2.0;
    hilbert_pixels(map.width, map.height, &mut |x, y| {
        let d = f64::from(map.data[y * map.width + x]);
        if d <= 0.0 {
            return;
        }
        while next < acc + d && out.len() < n {
            let frac = (next - acc) / d;
            #[allow(clippy::cast_precision_loss)]
            out.push(Point::new(x as f64 + 0.1 + 0.8 * frac, y as f64 + 0.5));
            next += step;
        }
        acc += d;
    });
    out
}

/// No dot: a pixel not reached yet.
const NONE: u32 = u32::MAX;

/// The nearest dot of every pixel centre (its Voronoi cell), kept from round to round as dots move a little.
struct Cells {
    width: usize,
    height: usize,
    /// The dot of each pixel, row by row ([`NONE`] before any reaches it).
    label: Vec<u32>,
    /// The squared distance from each pixel centre to its dot.
    near: Vec<f32>,
}

impl Cells {
    fn new(width: usize, height: usize) -> Self {
        Cells { width, height, label: vec![NONE; width * height], near: vec![f32::INFINITY; width * height] }
    }

    /// Bring every pixel's dot up to date with the dots' places `xs`, `ys`: each dot claims the pixel it lies in
    /// (when nearer than the pixel's dot), then four sweeps (down the rows left to right and back, up the rows right
    /// to left and back) let every pixel take a neighbour's dot when that is nearer, as in Danielsson's vector
    /// distance transform. The result is the nearest dot of almost every pixel; the rare miss lies on a cell's
    /// border, where it moves a centroid by a fraction of a pixel.
    fn update(&mut self, xs: &[f32], ys: &[f32]) {
        let w = self.width;
        let dist = |l: u32, px: f32, py: f32| {
            if l == NONE {
                f32::INFINITY
            } else {
                let (dx, dy) = (xs[l as usize] - px, ys[l as usize] - py);
                dx * dx + dy * dy
            }
        };
        // The distance from each pixel centre to its dot where it is now.
        let near = &mut self.near;
        for (y, (row, near_row)) in self.label.chunks(w).zip(near.chunks_mut(w)).enumerate() {
            #[allow(clippy::cast_precision_loss)]
            let py = y as f32 + 0.5;
            for (x, (&l, d)) in row.iter().zip(near_row.iter_mut()).enumerate() {
                #[allow(clippy::cast_precision_loss)]
                let px = x as f32 + 0.5;
                *d = dist(l, px, py);
            }
        }
        for (k, (&x, &y)) in xs.iter().zip(ys).enumerate() {
            #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)] // clamped into the picture
            let (cx, cy) = ((x.max(0.0) as usize).min(w - 1), (y.max(0.0) as usize).min(self.height - 1));
            let i = cy * w + cx;
            #[allow(clippy::cast_precision_loss)]
            let (px, py) = (cx as f32 + 0.5, cy as f32 + 0.5);
            #[allow(clippy::cast_possible_truncation)] // at most MAX_DOTS dots
            let k = k as u32;
            let d = dist(k, px, py);
            if d < near[i] {
                self.label[i] = k;
                near[i] = d;
            }
        }
        let label = &mut self.label;
        // Take pixel j's dot for pixel i when it is nearer.
        let mut take = |i: usize, j: usize, px: f32, py: f32| {
            let b = label[j];
            if label[i] != b {
                let d = dist(b, px, py);
                if d < near[i] {
                    label[i] = b;
                    near[i] = d;
                }
            }
        };
        for y in 0..self.height {
            #[allow(clippy::cast_precision_loss)]
            let py = y as f32 + 0.5;
            for x in 0..w {
                #[allow(clippy::cast_precision_loss)]
                let px = x as f32 + 0.5;
                let i = y * w + x;
                if y > 0 {
                    take(i, i - w, px, py);
                    if x > 0 {
                        take(i, i - w - 1, px, py);
                    }
                    if x + 1 < w {
                        take(i, i - w + 1, px, py);
                    }
                }
                if x > 0 {
                    take(i, i - 1, px, py);
                }
            }
            for x in (0..w.saturating_sub(1)).rev() {
                #[allow(clippy::cast_precision_loss)]
                take(y * w + x, y * w + x + 1, x as f32 + 0.5, py);
            }
        }
        for y in (0..self.height).rev() {
            #[allow(clippy::cast_precision_loss)]
            let py = y as f32 + 0.5;
            for x in (0..w).rev() {
                #[allow(clippy::cast_precision_loss)]
                let px = x as f32 + 0.5;
                let i = y * w + x;
                if y + 1 < self.height {
                    take(i, i + w, px, py);
                    if x > 0 {
                        take(i, i + w - 1, px, py);
                    }
                    if x + 1 < w {
                        take(i, i + w + 1, px, py);
                    }
                }
                if x + 1 < w {
                    take(i, i + 1, px, py);
                }
            }
            for x in 1..w {
                #[allow(clippy::cast_precision_loss)]
                take(y * w + x, y * w + x - 1, x as f32 + 0.5, py);
            }
        }
    }
}

/// One round of Lloyd relaxation: every dot moves to the darkness-weighted centroid of its Voronoi cell (the pixel
/// centres nearest to it, from [`Cells::update`]). A dot that owns no pixel (one on top of another) stays.
fn relax(map: &DarknessMap, dots: &mut [Point], cells: &mut Cells) {
    #[allow(clippy::cast_possible_truncation)] // pixel coordinates, well within f32
    let xs: Vec<f32> = dots.iter().map(|p| p.x as f32).collect();
    #[allow(clippy::cast_possible_truncation)]
    let ys: Vec<f32> = dots.iter().map(|p| p.y as f32).collect();
    cells.update(&xs, &ys);
    let mut sums = vec![(0.0f64, 0.0f64, 0.0f64); dots.len()];
    for (y, (row, labels)) in map.data.chunks(map.width).zip(cells.label.chunks(map.width)).enumerate() {
        #[allow(clippy::cast_precision_loss)]
        let py = y as f64 + 0.5;
        for (x, (&d, &l)) in row.iter().zip(labels).enumerate() {
            if d <= 0.0 || l == NONE {
                continue;
            }
            let d = f64::from(d);
            #[allow(clippy::cast_precision_loss)]
            let px = x as f64 + 0.5;
            let s = &mut sums[l as usize];
            s.0 += d * px;
            s.1 += d * py;
            s.2 += d;
        }
    }
    for (p, s) in dots.iter_mut().zip(&sums) {
        if s.2 > 0.0 {
            *p = Point::new(s.0 / s.2, s.1 / s.2);
        }
    }
}

/// Stipple the darkness map: dot centres in pixel coordinates, `pen_px` being the pen's width in pixels.
pub fn stipple_dots(map: &DarknessMap, pen_px: f64, iterations: u32) -> Vec<Point> {
    let n = dot_count(map, pen_px);
    let mut dots = seed(map, n);
    if dots.is_empty() {
        return dots;
    }
    let mut cells = Cells::new(map.width, map.height);
    for _ in 0..iterations {
        relax(map, &mut dots, &mut cells);
    }
    dots
}

/// The dots as strokes: each a zero-length two-point path (one touch of the pen). With `tsp` the caller joins them
/// into one line afterwards through the path optimizer ([`crate::optimize`] comes after the inputs:
/// `optimize::one_line::join_into_one_line`).
pub fn strokes(dots: &[Point]) -> Vec<Vec<Point>> {
    dots.iter().map(|&p| vec![p, p]).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::raster::ink::InkGrid;
    use crate::input::raster::tone::ToneCurve;
    use image::{GrayImage, Luma};

    fn map_of(g: &GrayImage) -> DarknessMap {
        ToneCurve::default().darkness_map(g, false)
    }

    #[test]
    fn the_hilbert_walk_visits_every_pixel_once_stepping_to_a_neighbour() {
        // A full 16 × 16 square: 256 pixels, each step to a side neighbour, from (0, 0) to (0, 15).
        let mut seen = Vec::new();
        hilbert_pixels(16, 16, &mut |x, y| seen.push((x, y)));
        assert_eq!(seen.len(), 256);
        assert_eq!((seen[0], seen[255]), ((0, 0), (0, 15)));
        assert!(seen.windows(2).all(|w| w[0].0.abs_diff(w[1].0) + w[0].1.abs_diff(w[1].1) == 1));
        let mut sorted = seen.clone();
        sorted.sort_unstable();
        sorted.dedup();
        assert_eq!(sorted.len(), 256);
        // A 5 × 3 picture inside its 8 × 8 square: each of its 15 pixels once, nothing outside.
        let mut seen = Vec::new();
        hilbert_pixels(5, 3, &mut |x, y| seen.push((x, y)));
        seen.sort_unstable();
        let all: Vec<_> = (0..5).flat_map(|x| (0..3).map(move |y| (x, y))).collect();
        assert_eq!(seen, all);
    }

    #[test]
    fn seeds_of_a_flat_gray_are_spread_in_both_directions() {
        // Darkness 0.25 over 64 × 64 px is 1024; 256 dots take one per 4 of darkness, 16 pixels. The Hilbert curve
        // runs through each aligned 4 × 4 block in 16 steps, so every block gets exactly one dot (at its 8th pixel);
        // reading order would put one every 16 pixels of each row, four dots in every fourth block and none between.
        let map = DarknessMap { width: 64, height: 64, data: vec![0.25; 64 * 64] };
        let dots = seed(&map, 256);
        assert_eq!(dots.len(), 256);
        let mut per_block = vec![0; 256];
        for p in &dots {
            #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
            let (bx, by) = ((p.x / 4.0) as usize, (p.y / 4.0) as usize);
            per_block[by * 16 + bx] += 1;
        }
        assert!(per_block.iter().all(|&c| c == 1), "{per_block:?}");
    }

    #[test]
    fn cells_are_the_nearest_dot_of_every_pixel() {
        // Three dots on a 40 × 30 picture: every pixel centre's label is its nearest dot (ties aside).
        let (xs, ys) = (vec![5.2f32, 30.7, 18.0], vec![4.9f32, 8.3, 25.5]);
        let mut cells = Cells::new(40, 30);
        cells.update(&xs, &ys);
        for y in 0..30 {
            for x in 0..40 {
                #[allow(clippy::cast_precision_loss)]
                let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
                let d: Vec<f32> = (0..3).map(|k| (xs[k] - px).powi(2) + (ys[k] - py).powi(2)).collect();
                let nearest = (0..3).min_by(|&a, &b| d[a].total_cmp(&d[b])).unwrap();
                assert_eq!(cells.label[y * 40 + x] as usize, nearest, "pixel ({x}, {y})");
            }
        }
        // One relaxation round on a flat map: each dot moves to the centre of its cell; a lone dot in the middle
        // of a 10 × 10 flat map goes to (5, 5).
        let map = DarknessMap { width: 10, height: 10, data: vec![0.5; 100] };
        let mut dots = vec![Point::new(2.3, 7.9)];
        relax(&map, &mut dots, &mut Cells::new(10, 10));
        assert!((dots[0].x - 5.0).abs() < 1e-9 && (dots[0].y - 5.0).abs() < 1e-9, "{:?}", dots[0]);
    }

    #[test]
    fn white_gets_no_dots_and_counts_follow_darkness() {
        assert!(stipple_dots(&map_of(&GrayImage::from_pixel(40, 40, Luma([255]))), 1.0, 4).is_empty());
        // Darkness 0.5 over 100 × 100 px with a 1.5 px pen: 5000 / (π · 1.5² / 4) = 2829.4 → 2829 dots;
        // a constant map at darkness 0.25 gets half as much ink: 1414.7 → 1415.
        let half = DarknessMap { width: 100, height: 100, data: vec![0.5; 10_000] };
        let quarter = DarknessMap { width: 100, height: 100, data: vec![0.25; 10_000] };
        assert_eq!(dot_count(&half, 1.5), 2829);
        assert_eq!(dot_count(&quarter, 1.5), 1415);
        assert_eq!(stipple_dots(&quarter, 1.5, 2).len(), 1415);
    }

    #[test]
    fn a_flat_gray_stipples_to_its_darkness() {
        // Darkness 0.3 over 80 × 80 px of 0.25 mm, pen 0.5 mm (2 px): dots spread by relaxation, rendered as discs.
        let map = DarknessMap { width: 80, height: 80, data: vec![0.3; 6400] };
        let dots = stipple_dots(&map, 2.0, 10);
        assert!(dots.iter().all(|p| (0.0..=80.0).contains(&p.x) && (0.0..=80.0).contains(&p.y)));
        let mm: Vec<Vec<Point>> = strokes(&dots)
            .into_iter()
            .map(|s| s.into_iter().map(|p| Point::new(p.x * 0.25, p.y * 0.25)).collect())
            .collect();
        let mut grid = InkGrid::new(1000, 1000, 0.02);
        grid.draw(&mm, 0.5);
        let f = grid.fraction(100, 900, 100, 900);
        assert!((f - 0.3).abs() < 0.03, "ink fraction {f}");
    }
}
