//! Where a plot puts ink: strokes rendered at the pen's width onto a fine grid, opaque (an overlap is no darker
//! than one line). Used to check a style's tone against its target and by the tone measure bench.
//!
//! **Where a cell looks.** A grid made by [`InkGrid::new`] inks a cell when the cell's centre is under ink. A grid
//! made by [`InkGrid::jittered`] looks at one fixed point placed at random within each cell (stratified jitter, the
//! same point every time): a mark then inks, on average, exactly its area wherever it lies. Centres are biased for
//! marks that sit on a lattice of their own: a pen touch one pixel wide on a sixth-of-a-pixel grid, centred on a
//! cell's corner, covers 32 centres against its true 28.3 cells, and stipple dots that settle on quarter pixels
//! would read 13 % too dark. The eye sees no such lattice, so the tone measure uses the jittered grid.

use kurbo::Point;

/// A grid of cells `cell` wide over `[0, columns·cell] × [0, rows·cell]`, each inked or not.
#[derive(Debug, Clone, PartialEq)]
pub struct InkGrid {
    /// Cell size, in the strokes' unit.
    pub cell: f64,
    /// Cells across.
    pub columns: usize,
    /// Cells down.
    pub rows: usize,
    /// Inked cells, row by row.
    pub ink: Vec<bool>,
    /// Whether each cell looks at a fixed random point within it (see the module's notes) instead of its centre.
    pub jittered: bool,
}

impl InkGrid {
    /// An empty grid of `columns × rows` cells of size `cell`, each inked when its centre is.
    pub fn new(columns: usize, rows: usize, cell: f64) -> Self {
        InkGrid { cell, columns, rows, ink: vec![false; columns * rows], jittered: false }
    }

    /// An empty grid of `columns × rows` cells of size `cell`, each inked when a fixed random point within it is:
    /// a mark's ink is its true area on average, wherever the mark lies.
    pub fn jittered(columns: usize, rows: usize, cell: f64) -> Self {
        InkGrid { jittered: true, ..InkGrid::new(columns, rows, cell) }
    }

    /// Where cell `(col, row)` looks, as a fraction of a cell from its top-left corner along each side.
    fn sample(&self, col: usize, row: usize) -> (f64, f64) {
        if !self.jittered {
            return (0.5, 0.5);
        }
        let key = ((row as u64) << 32) | col as u64;
        (unit(key, 1), unit(key, 2))
    }

    /// Ink every cell whose sample point (its centre, or its jittered point) lies within `width / 2` of a segment of
    /// one of the `strokes`.
    pub fn draw(&mut self, strokes: &[Vec<Point>], width: f64) {
        let r = width / 2.0;
        for s in strokes {
            if s.len() == 1 {
                self.segment(s[0], s[0], r);
            }
            for e in s.windows(2) {
                self.segment(e[0], e[1], r);
            }
        }
    }

    fn segment(&mut self, a: Point, b: Point, r: f64) {
        if !self.jittered {
            self.segment_centres(a, b, r);
            return;
        }
        let c = self.cell;
        // The part of each cell its sample point may lie in, in cells from the cell's top-left corner.
        let (lo, hi) = if self.jittered { (0.0, 1.0) } else { (0.5, 0.5) };
        let (y0, y1) = (a.y.min(b.y) - r, a.y.max(b.y) + r);
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss, clippy::cast_precision_loss)]
        let (first, last) = (
            (y0 / c - hi).ceil().max(0.0) as usize,
            ((y1 / c - lo).floor().min(self.rows as f64 - 1.0)).max(-1.0) as isize,
        );
        let d = b - a;
        let len2 = d.hypot2();
        for row in first..usize::try_from(last + 1).unwrap_or(0) {
            #[allow(clippy::cast_precision_loss)]
            let (ya, yb) = ((row as f64 + lo) * c, (row as f64 + hi) * c);
            // The part of the segment within r of this row's sample heights, widened by r.
            let (mut xa, mut xb) = if d.y.abs() < 1e-12 {
                (a.x.min(b.x), a.x.max(b.x))
            } else {
                let t0 = ((ya - r - a.y) / d.y).clamp(0.0, 1.0);
                let t1 = ((yb + r - a.y) / d.y).clamp(0.0, 1.0);
                let (p, q) = (a.x + d.x * t0, a.x + d.x * t1);
                (p.min(q), p.max(q))
            };
            xa -= r;
            xb += r;
            #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss, clippy::cast_precision_loss)]
            let (c0, c1) =
                ((xa / c - hi).ceil().max(0.0) as usize, (xb / c - lo).floor().min(self.columns as f64 - 1.0));
            if c1 < 0.0 {
                continue;
            }
            #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
            let c1 = c1 as usize;
            for col in c0..=c1 {
                let (u, v) = self.sample(col, row);
                #[allow(clippy::cast_precision_loss)]
                let p = Point::new((col as f64 + u) * c, (row as f64 + v) * c);
                let t = if len2 > 0.0 { ((p - a).dot(d) / len2).clamp(0.0, 1.0) } else { 0.0 };
                if (a + d * t).distance(p) <= r {
                    self.ink[row * self.columns + col] = true;
                }
            }
        }
    }

    /// Ink every cell whose centre lies within `r` of the segment `ab`. The centres of a row lie on one horizontal
    /// line, which crosses the segment's round-capped band (convex) in one interval: the union of where it crosses
    /// the two end discs and the straight part between them. Every cell centred in that interval is inked, a row at
    /// a time (the same cells as testing each centre's distance, which cost a square root per cell).
    fn segment_centres(&mut self, a: Point, b: Point, r: f64) {
        let per_cell = 1.0 / self.cell;
        let d = b - a;
        let len = d.hypot();
        // The straight part: along the segment `0 ≤ (p − a)·u ≤ len`, across it `|(p − a)·n| ≤ r`, with u the unit
        // direction and n = (−u.y, u.x); along a row each is `slope · (x − a.x) + offset` within bounds.
        let (ux, uy) = if len > 0.0 { (d.x / len, d.y / len) } else { (0.0, 0.0) };
        let (per_ux, per_uy) = (1.0 / ux, -1.0 / uy);
        let (y0, y1) = (a.y.min(b.y) - r, a.y.max(b.y) + r);
        let Some(last) = floor_index(y1 * per_cell - 0.5) else { return };
        for row in ceil_index(y0 * per_cell - 0.5)..=last.min(self.rows.saturating_sub(1)) {
            #[allow(clippy::cast_precision_loss)]
            let y = (row as f64 + 0.5) * self.cell;
            let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
            for end in [a, b] {
                let h2 = r * r - (y - end.y) * (y - end.y);
                if h2 >= 0.0 {
                    let h = h2.sqrt();
                    lo = lo.min(end.x - h);
                    hi = hi.max(end.x + h);
                }
            }
            if len > 0.0 {
                let (mut xa, mut xb) = (f64::NEG_INFINITY, f64::INFINITY);
                let mut clip = |slope: f64, per_slope: f64, offset: f64, lo_v: f64, hi_v: f64| {
                    if slope == 0.0 {
                        if offset < lo_v || offset > hi_v {
                            (xa, xb) = (f64::INFINITY, f64::NEG_INFINITY);
                        }
                    } else {
                        let (p, q) = ((lo_v - offset) * per_slope + a.x, (hi_v - offset) * per_slope + a.x);
                        xa = xa.max(p.min(q));
                        xb = xb.min(p.max(q));
                    }
                };
                clip(ux, per_ux, (y - a.y) * uy, 0.0, len);
                clip(-uy, per_uy, (y - a.y) * ux, -r, r);
                if xa <= xb {
                    lo = lo.min(xa);
                    hi = hi.max(xb);
                }
            }
            if lo > hi {
                continue;
            }
            let c0 = ceil_index(lo * per_cell - 0.5);
            let Some(c1) = floor_index(hi * per_cell - 0.5) else { continue };
            let c1 = c1.min(self.columns.saturating_sub(1));
            if c0 <= c1 {
                self.ink[row * self.columns + c0..=row * self.columns + c1].fill(true);
            }
        }
    }

    /// Fraction of inked cells among columns `x0..x1` and rows `y0..y1` (clamped to the grid).
    pub fn fraction(&self, x0: usize, x1: usize, y0: usize, y1: usize) -> f64 {
        let (x1, y1) = (x1.min(self.columns), y1.min(self.rows));
        let mut inked = 0usize;
        let mut all = 0usize;
        for row in y0..y1 {
            for col in x0..x1 {
                all += 1;
                inked += usize::from(self.ink[row * self.columns + col]);
            }
        }
        #[allow(clippy::cast_precision_loss)]
        if all == 0 { 0.0 } else { inked as f64 / all as f64 }
    }
}

/// The least whole number at least `v`, and 0 for anything below 1 (or NaN). Written out rather than `f64::ceil`,
/// which without SSE4.1 is a call into the C library, a fifth of the ink grid's time.
fn ceil_index(v: f64) -> usize {
    if v > 0.0 {
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss, clippy::cast_precision_loss)]
        let t = v as usize;
        #[allow(clippy::cast_precision_loss)]
        if (t as f64) < v { t + 1 } else { t }
    } else {
        0
    }
}

/// The greatest whole number at most `v`, or `None` below 0 (or NaN); see [`ceil_index`].
fn floor_index(v: f64) -> Option<usize> {
    // A cast truncates toward zero: floor for `v ≥ 0`.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    (v >= 0.0).then_some(v as usize)
}

/// A number in `[0, 1)` from `key` and a salt (SplitMix64's mixer), the same for the same pair: the same cell
/// always looks at the same point, the same picture always gives the same mosaic.
pub(super) fn unit(key: u64, salt: u64) -> f64 {
    let mut z = key.wrapping_mul(0x9E37_79B9_7F4A_7C15).wrapping_add(salt.wrapping_mul(0xD1B5_4A32_D192_ED03));
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    #[allow(clippy::cast_precision_loss)] // 53 bits of the hash
    let u = (z >> 11) as f64 / (1u64 << 53) as f64;
    u
}

/// For the styles' tests: the ink fraction of `strokes` (pixel coordinates, pen `pen` px) in a `w × h` picture,
/// `margin` px from its edges, rendered at 0.2 px.
#[cfg(test)]
pub(crate) fn ink_in_picture(strokes: &[Vec<Point>], pen: f64, w: usize, h: usize, margin: usize) -> f64 {
    let mut g = InkGrid::new(w * 5, h * 5, 0.2);
    g.draw(strokes, pen);
    g.fraction(margin * 5, (w - margin) * 5, margin * 5, (h - margin) * 5)
}

/// For the styles' tests: the linear lightness ramp the tone tests plot (`tests/raster_tone.rs`) as a `w × h` px
/// darkness map: L* 100 at the left edge to 0 at the right, each column at the L* of its middle, stored as an 8-bit
/// sRGB gray as a picture file holds it and read back through the default tone curve.
#[cfg(test)]
pub(crate) fn lightness_ramp(w: usize, h: usize) -> super::tone::DarknessMap {
    use super::tone::{luminance_from_cie, srgb_to_linear};
    let column = |x: usize| {
        #[allow(clippy::cast_precision_loss)]
        let y = luminance_from_cie(100.0 * (1.0 - (x as f64 + 0.5) / w as f64));
        let v = if y <= 0.003_130_8 { 12.92 * y } else { 1.055 * y.powf(1.0 / 2.4) - 0.055 };
        #[allow(clippy::cast_possible_truncation)] // a value in [0, 1]
        let d = (1.0 - srgb_to_linear((v * 255.0).round() / 255.0)) as f32;
        d
    };
    let row: Vec<f32> = (0..w).map(column).collect();
    super::tone::DarknessMap { width: w, height: h, data: row.repeat(h) }
}

/// For the styles' tests: the L* `map` asks for and the L* `strokes` plot (pixel coordinates, pen `pen` px, rendered
/// on a jittered grid of a fifth of a pixel, as the tone measure sees them) in bands `band` px wide across the map,
/// `margin` px in from its edges: `(asked, plotted)` per band, each from the band's mean reflectance.
#[cfg(test)]
pub(crate) fn band_lightness(
    strokes: &[Vec<Point>],
    pen: f64,
    map: &super::tone::DarknessMap,
    band: usize,
    margin: usize,
) -> Vec<(f64, f64)> {
    use super::tone::lightness_cie;
    let (w, h) = (map.width, map.height);
    let mut g = InkGrid::jittered(w * 5, h * 5, 0.2);
    g.draw(strokes, pen);
    (margin..w.saturating_sub(margin + band - 1))
        .step_by(band)
        .map(|x0| {
            let asked: f64 = (margin..h - margin)
                .flat_map(|y| (x0..x0 + band).map(move |x| f64::from(map.data[y * w + x])))
                .sum::<f64>();
            #[allow(clippy::cast_precision_loss)]
            let asked = asked / (band * (h - 2 * margin)) as f64;
            let ink = g.fraction(x0 * 5, (x0 + band) * 5, margin * 5, (h - margin) * 5);
            (lightness_cie(1.0 - asked), lightness_cie(1.0 - ink))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_line_inks_its_width_and_overlaps_count_once() {
        // 100 × 100 cells of 0.1: a horizontal line at y = 5 of width 1 inks the rows whose centres are within 0.5,
        // 4.55 … 5.45: ten rows of 100.
        let mut g = InkGrid::new(100, 100, 0.1);
        g.draw(&[vec![Point::new(-1.0, 5.0), Point::new(11.0, 5.0)]], 1.0);
        assert!((g.fraction(0, 100, 0, 100) - 0.10).abs() < 1e-12);
        // Drawing it again, and a vertical line crossing it: 10 + 10 columns − the 10 × 10 overlap.
        g.draw(
            &[vec![Point::new(-1.0, 5.0), Point::new(11.0, 5.0)], vec![Point::new(5.0, -1.0), Point::new(5.0, 11.0)]],
            1.0,
        );
        assert!((g.fraction(0, 100, 0, 100) - 0.19).abs() < 1e-12);
    }

    #[test]
    fn a_centre_grid_inks_the_cells_whose_centres_are_within_the_pen() {
        // Segments of every slope (flat, upright, a dot, steep and shallow diagonals, some running off the grid),
        // pen 0.9 on cells of 0.3: each inks exactly the cells whose centre lies within 0.45 of the segment.
        let segments = [
            ((1.0, 2.0), (7.0, 2.0)),
            ((3.31, 0.5), (3.31, 8.0)),
            ((4.0, 4.0), (4.0, 4.0)),
            ((0.7, 0.2), (8.9, 6.1)),
            ((2.0, 8.7), (2.6, 0.4)),
            ((-1.0, 5.0), (12.0, 5.3)),
            ((8.2, 8.6), (9.9, 9.9)),
        ];
        for ((ax, ay), (bx, by)) in segments {
            let (a, b) = (Point::new(ax, ay), Point::new(bx, by));
            let mut g = InkGrid::new(30, 30, 0.3);
            g.draw(&[vec![a, b]], 0.9);
            let mut inked = 0;
            for row in 0..30 {
                for col in 0..30 {
                    let p = Point::new((f64::from(col) + 0.5) * 0.3, (f64::from(row) + 0.5) * 0.3);
                    let d = b - a;
                    let t = if d.hypot2() > 0.0 { ((p - a).dot(d) / d.hypot2()).clamp(0.0, 1.0) } else { 0.0 };
                    let want = (a + d * t).distance(p) <= 0.45;
                    assert_eq!(g.ink[usize::try_from(row * 30 + col).unwrap()], want, "{a:?}-{b:?} at {p:?}");
                    inked += usize::from(want);
                }
            }
            assert!(inked > 0);
        }
        // By hand: a dot of radius 0.45 (1.5 cells) at (4, 4) = (13.33, 13.33) cells. The centres of columns and rows
        // 12, 13, 14 lie 0.83, 0.17, 1.17 cells from it (11 and 15: 1.83 and 2.17, past the radius alone), so the
        // 3 × 3 centres are 0.69 … 2.06 cells² away, within 1.5² = 2.25, but for the corner at (1.17, 1.17), 2.72:
        // 8 cells.
        let mut g = InkGrid::new(30, 30, 0.3);
        g.draw(&[vec![Point::new(4.0, 4.0)]], 0.9);
        assert_eq!(g.ink.iter().filter(|&&i| i).count(), 8);
    }

    #[test]
    fn a_diagonal_line_inks_its_area() {
        // A diagonal across a 10 × 10 square, width 0.5: inside the square that is the band |x − y| ≤ 0.25·√2, of
        // area 100 − (10 − 0.25·√2)² = 6.946 (the round caps lie outside).
        let mut g = InkGrid::new(1000, 1000, 0.01);
        g.draw(&[vec![Point::new(0.0, 0.0), Point::new(10.0, 10.0)]], 0.5);
        let area = g.fraction(0, 1000, 0, 1000) * 100.0;
        let want = 100.0 - (10.0 - 0.25 * 2f64.sqrt()).powi(2);
        assert!((area - want).abs() < 0.03, "{area} vs {want}");
    }

    /// 400 touches of a pen one unit wide on a 20 × 20 lattice 2 units apart, each centred on a corner of the
    /// grid's cells (a sixth of a unit): their true ink is 400 · π / 4 = 314.16 of the 1600 square units.
    fn corner_touches(mut g: InkGrid) -> f64 {
        let touches: Vec<Vec<Point>> = (0..400)
            .map(|i| {
                let p = Point::new(f64::from(i % 20) * 2.0 + 1.0, f64::from(i / 20) * 2.0 + 1.0);
                vec![p, p]
            })
            .collect();
        g.draw(&touches, 1.0);
        g.fraction(0, 240, 0, 240) * 1600.0
    }

    #[test]
    fn a_jittered_grid_inks_a_touch_by_its_area_wherever_it_lies() {
        // Centres: each touch covers 32 cell centres of 1/36 (its radius is 3 cells, centred on a corner), 0.889
        // against π / 4 = 0.785, 13 % too dark.
        let centred = corner_touches(InkGrid::new(240, 240, 1.0 / 6.0));
        assert!((centred - 400.0 * 32.0 / 36.0).abs() < 1e-9, "{centred}");
        // Jittered: 314.16 within 1 %.
        let jittered = corner_touches(InkGrid::jittered(240, 240, 1.0 / 6.0));
        let want = 100.0 * std::f64::consts::PI;
        assert!((jittered / want - 1.0).abs() < 0.01, "{jittered} vs {want}");
        // A line's edges on the cells' edges ink the same either way: 10 rows of 100.
        let mut g = InkGrid::jittered(100, 100, 0.1);
        g.draw(&[vec![Point::new(-1.0, 5.0), Point::new(11.0, 5.0)]], 1.0);
        assert!((g.fraction(0, 100, 0, 100) - 0.10).abs() < 1e-12);
    }
}
