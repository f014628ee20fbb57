//! Where a plot puts ink: strokes rendered at the pen's width onto a fine grid, opaque (an overlap is no darker
//! than one line). Used to check a style's tone against its target and by the tone measure bench.

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
}

impl InkGrid {
    /// An empty grid of `columns × rows` cells of size `cell`.
    pub fn new(columns: usize, rows: usize, cell: f64) -> Self {
        InkGrid { cell, columns, rows, ink: vec![false; columns * rows] }
    }

    /// Ink every cell whose centre lies within `width / 2` of a segment of one of the `strokes`.
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
        let c = self.cell;
        let (y0, y1) = (a.y.min(b.y) - r, a.y.max(b.y) + r);
        let row_of = |y: f64| y / c - 0.5;
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss, clippy::cast_precision_loss)]
        let (first, last) =
            (row_of(y0).ceil().max(0.0) as usize, (row_of(y1).floor().min(self.rows as f64 - 1.0)).max(-1.0) as isize);
        let d = b - a;
        let len2 = d.hypot2();
        for row in first..usize::try_from(last + 1).unwrap_or(0) {
            #[allow(clippy::cast_precision_loss)]
            let y = (row as f64 + 0.5) * c;
            // The part of the segment within r of this row's height, widened by r.
            let (mut xa, mut xb) = if d.y.abs() < 1e-12 {
                (a.x.min(b.x), a.x.max(b.x))
            } else {
                let t0 = ((y - r - a.y) / d.y).clamp(0.0, 1.0);
                let t1 = ((y + r - a.y) / d.y).clamp(0.0, 1.0);
                let (p, q) = (a.x + d.x * t0, a.x + d.x * t1);
                (p.min(q), p.max(q))
            };
            xa -= r;
            xb += r;
            #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss, clippy::cast_precision_loss)]
            let (c0, c1) =
                ((xa / c - 0.5).ceil().max(0.0) as usize, (xb / c - 0.5).floor().min(self.columns as f64 - 1.0));
            if c1 < 0.0 {
                continue;
            }
            #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
            let c1 = c1 as usize;
            for col in c0..=c1 {
                #[allow(clippy::cast_precision_loss)]
                let p = Point::new((col as f64 + 0.5) * c, y);
                let t = if len2 > 0.0 { ((p - a).dot(d) / len2).clamp(0.0, 1.0) } else { 0.0 };
                if (a + d * t).distance(p) <= r {
                    self.ink[row * self.columns + col] = true;
                }
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

/// For the styles' tests: the ink fraction of `strokes` (pixel coordinates, pen `pen` px) in a `w × h` picture,
/// `margin` px from its edges, rendered at 0.2 px.
#[cfg(test)]
pub(crate) fn ink_in_picture(strokes: &[Vec<Point>], pen: f64, w: usize, h: usize, margin: usize) -> f64 {
    let mut g = InkGrid::new(w * 5, h * 5, 0.2);
    g.draw(strokes, pen);
    g.fraction(margin * 5, (w - margin) * 5, margin * 5, (h - margin) * 5)
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
    fn a_diagonal_line_inks_its_area() {
        // A diagonal across a 10 × 10 square, width 0.5: inside the square that is the band |x − y| ≤ 0.25·√2, of
        // area 100 − (10 − 0.25·√2)² = 6.946 (the round caps lie outside).
        let mut g = InkGrid::new(1000, 1000, 0.01);
        g.draw(&[vec![Point::new(0.0, 0.0), Point::new(10.0, 10.0)]], 0.5);
        let area = g.fraction(0, 1000, 0, 1000) * 100.0;
        let want = 100.0 - (10.0 - 0.25 * 2f64.sqrt()).powi(2);
        assert!((area - want).abs() < 0.03, "{area} vs {want}");
    }
}
