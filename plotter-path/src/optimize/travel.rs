//! Pen-up travel of a drawing in its current order under a [`CostModel`]: one hop into every drawn path (at least
//! one segment) from the previous path's end, across layer boundaries too. As in [`crate::geometry::travel`] (what `plotter
//! stats` reports), the hop to the first path is only counted when a start position is given, and the return to
//! home never is.

use kurbo::Point;

use super::cost::CostModel;
use crate::{Drawing, Polyline};

/// Total hop cost of drawing `paths` in order from `start` (if known), and the position the pen ends at.
pub fn paths_travel(paths: &[Polyline], start: Option<Point>, cost: &CostModel) -> (f64, Option<Point>) {
    let mut at = start;
    let mut total = 0.0;
    for path in paths.iter().filter(|p| p.points.len() >= 2) {
        let (Some(first), Some(last)) = (path.start(), path.end()) else { continue };
        if let Some(from) = at {
            total += cost.cost(from, first);
        }
        at = Some(last);
    }
    (total, at)
}

/// Total hop cost of the whole drawing, layer after layer, from `start` (if known).
pub fn drawing_travel(drawing: &Drawing, start: Option<Point>, cost: &CostModel) -> f64 {
    let mut at = start;
    let mut total = 0.0;
    for layer in &drawing.layers {
        let (t, end) = paths_travel(&layer.paths, at, cost);
        total += t;
        at = end;
    }
    total
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Layer;

    fn seg(a: (f64, f64), b: (f64, f64)) -> Polyline {
        Polyline::new(vec![Point::new(a.0, a.1), Point::new(b.0, b.1)])
    }

    #[test]
    fn hops_span_layers_and_skip_undrawn_paths() {
        let mut d = Drawing::single_layer("a", vec![seg((3.0, 4.0), (10.0, 4.0)), Polyline::default()]);
        let mut b = Layer::new("b");
        b.paths.push(seg((10.0, 7.0), (0.0, 0.0)));
        b.paths.push(Polyline::new(vec![Point::new(0.0, 1.0)]));
        b.paths.push(seg((0.0, 1.0), (0.0, 2.0)));
        d.layers.push(b);
        // 5 (home → (3,4)) + 3 ((10,4) → (10,7)) + 1 ((0,0) → (0,1)); the single point is not drawn.
        let from_home = drawing_travel(&d, Some(Point::ZERO), &CostModel::Distance);
        assert!((from_home - 9.0).abs() < 1e-12, "{from_home}");
        // Without a start, the same figure as `plotter stats`.
        let free = drawing_travel(&d, None, &CostModel::Distance);
        assert!((free - 4.0).abs() < 1e-12, "{free}");
        assert!((free - crate::geometry::travel::pen_up_length(&d)).abs() < 1e-12);
        let (t, end) = paths_travel(&d.layers[0].paths, Some(Point::new(3.0, 4.0)), &CostModel::Distance);
        assert_eq!((t, end), (0.0, Some(Point::new(10.0, 4.0))));
    }
}
