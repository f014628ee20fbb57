//! Pen-up travel implied by a drawing's order: the jumps from the end of each path to the start of the next.
//!
//! Travel is measured between consecutive paths in plotting order, across layer boundaries, and excludes the
//! move from the machine origin to the first path and back — the convention other plotter tools use, so that
//! figures compare.

use kurbo::{Line, Point};

use crate::geometry::drawing::Drawing;

/// The pen-up moves of `drawing` in plotting order (zero-length moves included).
pub fn pen_up_moves(drawing: &Drawing) -> Vec<Line> {
    let mut moves = Vec::new();
    let mut last: Option<Point> = None;
    for path in drawing.paths().filter(|p| p.points.len() >= 2) {
        let (Some(start), Some(end)) = (path.start(), path.end()) else { continue };
        if let Some(prev) = last {
            moves.push(Line::new(prev, start));
        }
        last = Some(end);
    }
    moves
}

/// Total pen-up travel in millimetres, in plotting order.
pub fn pen_up_length(drawing: &Drawing) -> f64 {
    pen_up_moves(drawing).iter().map(|l| l.p0.distance(l.p1)).sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::drawing::Polyline;

    #[test]
    fn travel_between_paths_only() {
        let d = Drawing::single_layer(
            "t",
            vec![
                Polyline::new(vec![Point::new(10.0, 0.0), Point::new(20.0, 0.0)]),
                Polyline::new(vec![Point::new(23.0, 4.0), Point::new(30.0, 4.0)]),
                Polyline::new(vec![Point::new(99.0, 99.0)]),
                Polyline::new(vec![Point::new(30.0, 4.0), Point::new(0.0, 0.0)]),
            ],
        );
        let moves = pen_up_moves(&d);
        assert_eq!(moves.len(), 2);
        assert_eq!(pen_up_length(&d), 5.0);
    }
}
