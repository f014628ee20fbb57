//! A uniform grid over bounding boxes, to find the boxes a query box meets without looking at every box: hidden-line
//! removal ([`super::occlude`]) asks for the fills painted over a shape, the edge rule ([`super::edges`]) for the
//! paint beneath it. The cell size is the mean box size, but at most 256 × 256 cells cover the boxes' extent, so
//! the grid's memory is bounded by the number of boxes times the cells each covers.

use kurbo::Rect;

use super::walk::Item;

const MAX_CELLS: f64 = 256.0;

/// The grid: for each cell, the indices of the boxes reaching into it.
pub(super) struct BoxGrid {
    boxes: Vec<Rect>,
    area: Rect,
    cell: f64,
    nx: usize,
    ny: usize,
    cells: Vec<Vec<u32>>,
}

/// Whether two closed boxes meet.
pub(super) fn meet(a: Rect, b: Rect) -> bool {
    a.x0 <= b.x1 && b.x0 <= a.x1 && a.y0 <= b.y1 && b.y0 <= a.y1
}

/// Every paint (fill, wide stroke) of every item with a bounding box, as (item, paint index), and a grid over their
/// boxes (`None` when nothing paints): what hidden-line removal and the edge rule both query.
pub(super) fn paint_grid(items: &[Item]) -> (Vec<(usize, usize)>, Option<BoxGrid>) {
    let mut paints = Vec::new();
    let mut boxes = Vec::new();
    for (i, it) in items.iter().enumerate() {
        for (p, paint) in it.paints.iter().enumerate() {
            if let Some(b) = paint.area.bbox() {
                paints.push((i, p));
                boxes.push(b);
            }
        }
    }
    (paints, BoxGrid::new(boxes))
}

impl BoxGrid {
    /// A grid over `boxes` (queries answer with indices into it); `None` when there are none.
    pub(super) fn new(boxes: Vec<Rect>) -> Option<BoxGrid> {
        let area = boxes.iter().copied().reduce(|a, b| a.union(b))?;
        let mean = boxes.iter().map(|b| b.width().max(b.height())).sum::<f64>() / boxes.len() as f64;
        let cell = mean.max(area.width() / MAX_CELLS).max(area.height() / MAX_CELLS).max(1e-6);
        // Both counts are at most MAX_CELLS + 1.
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let (nx, ny) = ((area.width() / cell).floor() as usize + 1, (area.height() / cell).floor() as usize + 1);
        let mut grid = BoxGrid { boxes: Vec::new(), area, cell, nx, ny, cells: vec![Vec::new(); nx * ny] };
        for (k, b) in boxes.iter().enumerate() {
            let (x0, x1, y0, y1) = grid.cell_range(*b);
            for y in y0..=y1 {
                for x in x0..=x1 {
                    grid.cells[y * nx + x].push(u32::try_from(k).expect("fewer than 2³² shapes"));
                }
            }
        }
        grid.boxes = boxes;
        Some(grid)
    }

    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    fn cell_range(&self, r: Rect) -> (usize, usize, usize, usize) {
        // Negative (and NaN) become 0 before the cast, which truncates like `floor` at or above 0.
        let cx = |x: f64| (((x - self.area.x0) / self.cell).max(0.0) as usize).min(self.nx - 1);
        let cy = |y: f64| (((y - self.area.y0) / self.cell).max(0.0) as usize).min(self.ny - 1);
        (cx(r.x0), cx(r.x1), cy(r.y0), cy(r.y1))
    }

    /// Put into `hits` (cleared first) the indices of the boxes meeting `query`, ascending, each once.
    pub(super) fn query_into(&self, query: Rect, hits: &mut Vec<usize>) {
        hits.clear();
        if !meet(query, self.area) {
            return;
        }
        let (x0, x1, y0, y1) = self.cell_range(query);
        for y in y0..=y1 {
            for x in x0..=x1 {
                hits.extend(
                    self.cells[y * self.nx + x].iter().map(|&k| k as usize).filter(|&k| meet(self.boxes[k], query)),
                );
            }
        }
        // One cell lists its boxes ascending, each once; several may share boxes.
        if x0 != x1 || y0 != y1 {
            hits.sort_unstable();
            hits.dedup();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_exactly_the_boxes_that_meet() {
        // A 10 × 10 lattice of unit boxes at even coordinates, and one long box along the bottom.
        let mut boxes: Vec<Rect> = (0..100)
            .map(|i| {
                let (x, y) = (f64::from(i % 10) * 2.0, f64::from(i / 10) * 2.0);
                Rect::new(x, y, x + 1.0, y + 1.0)
            })
            .collect();
        boxes.push(Rect::new(0.0, 30.0, 19.0, 31.0));
        let grid = BoxGrid::new(boxes.clone()).unwrap();
        let query = |q: Rect| {
            let mut hits = vec![7];
            grid.query_into(q, &mut hits);
            hits
        };
        for q in [Rect::new(1.5, 1.5, 4.5, 2.5), Rect::new(-5.0, -5.0, 0.0, 0.0), Rect::new(10.0, 25.0, 11.0, 40.0)] {
            let brute: Vec<usize> = (0..boxes.len()).filter(|&k| meet(boxes[k], q)).collect();
            assert_eq!(query(q), brute, "{q:?}");
        }
        // (1.5..4.5) × (1.5..2.5) meets the boxes at x 2..3 and 4..5 on row y 2..3: indices 11 and 12.
        assert_eq!(query(Rect::new(1.5, 1.5, 4.5, 2.5)), [11, 12]);
        assert_eq!(query(Rect::new(10.0, 25.0, 11.0, 40.0)), [100]);
        assert!(query(Rect::new(50.0, 50.0, 60.0, 60.0)).is_empty());
        assert!(BoxGrid::new(Vec::new()).is_none());
    }
}
