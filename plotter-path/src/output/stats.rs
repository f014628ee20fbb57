//! Drawing statistics: path and segment counts, pen-down and pen-up length (in drawing order), pen lifts and the
//! bounding box — the figures `plotter stats` prints and other tools (vpype's `stat`) can be compared against.

use kurbo::Rect;
use serde::Serialize;

use crate::geometry::drawing::Drawing;
use crate::geometry::travel::pen_up_length;

/// Measured figures of a drawing.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Stats {
    /// Number of layers.
    pub layers: usize,
    /// Number of polylines with at least one segment.
    pub paths: usize,
    /// Number of straight segments.
    pub segments: usize,
    /// Total pen-down length, mm.
    pub pen_down_mm: f64,
    /// Total pen-up travel between consecutive paths in drawing order, mm.
    pub pen_up_mm: f64,
    /// Times the pen is lifted: once after every path.
    pub pen_lifts: usize,
    /// Bounding box `[x0, y0, x1, y1]` in mm, absent for an empty drawing.
    pub bbox_mm: Option<[f64; 4]>,
}

impl Stats {
    /// Measure `drawing`.
    pub fn of(drawing: &Drawing) -> Stats {
        let drawn = drawing.paths().filter(|p| p.points.len() >= 2);
        let (mut paths, mut segments, mut pen_down_mm) = (0, 0, 0.0);
        for p in drawn {
            paths += 1;
            segments += p.segment_count();
            pen_down_mm += p.length();
        }
        Stats {
            layers: drawing.layers.len(),
            paths,
            segments,
            pen_down_mm,
            pen_up_mm: pen_up_length(drawing),
            pen_lifts: paths,
            bbox_mm: drawing.bbox().map(|Rect { x0, y0, x1, y1 }| [x0, y0, x1, y1]),
        }
    }
}

impl std::fmt::Display for Stats {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "layers        {}", self.layers)?;
        writeln!(f, "paths         {}", self.paths)?;
        writeln!(f, "segments      {}", self.segments)?;
        writeln!(f, "pen down      {:.2} mm", self.pen_down_mm)?;
        writeln!(f, "pen up        {:.2} mm", self.pen_up_mm)?;
        writeln!(f, "pen lifts     {}", self.pen_lifts)?;
        match self.bbox_mm {
            Some([x0, y0, x1, y1]) => write!(
                f,
                "bounding box  x {x0:.2}..{x1:.2} mm, y {y0:.2}..{y1:.2} mm ({:.2} × {:.2} mm)",
                x1 - x0,
                y1 - y0
            ),
            None => write!(f, "bounding box  (empty)"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::drawing::Polyline;
    use kurbo::Point;

    #[test]
    fn counts_lengths_and_box() {
        let d = Drawing::single_layer(
            "s",
            vec![
                Polyline::new(vec![Point::new(0.0, 0.0), Point::new(3.0, 4.0), Point::new(3.0, 10.0)]),
                Polyline::new(vec![Point::new(6.0, 14.0), Point::new(0.0, 14.0)]),
                Polyline::new(vec![Point::new(50.0, 50.0)]),
            ],
        );
        let s = Stats::of(&d);
        assert_eq!((s.paths, s.segments, s.pen_lifts, s.layers), (2, 3, 2, 1));
        assert_eq!(s.pen_down_mm, 5.0 + 6.0 + 6.0);
        assert_eq!(s.pen_up_mm, 5.0);
        assert_eq!(s.bbox_mm, Some([0.0, 0.0, 50.0, 50.0]));
        let text = s.to_string();
        assert!(text.contains("pen up        5.00 mm"), "{text}");
    }
}
