//! Pen-up travel of a drawing in its current order: one hop into every non-empty path, from the previous path's
//! end (or the start position), across layer boundaries too. The final return to home is not counted: it is not
//! part of plotting and no ordering step aims at it.

use kurbo::Point;

use super::cost::CostModel;
use crate::{Drawing, Polyline};

/// Total hop cost of drawing `paths` in order from `start`, and the position the pen ends at.
pub fn paths_travel(paths: &[Polyline], start: Point, cost: &CostModel) -> (f64, Point) {
    let mut at = start;
    let mut total = 0.0;
    for path in paths {
        let (Some(first), Some(last)) = (path.start(), path.end()) else { continue };
        total += cost.cost(at, first);
        at = last;
    }
    (total, at)
}

/// Total hop cost of the whole drawing, layer after layer, from `start`.
pub fn drawing_travel(drawing: &Drawing, start: Point, cost: &CostModel) -> f64 {
    let mut at = start;
    let mut total = 0.0;
    for layer in &drawing.layers {
        let (t, end) = paths_travel(&layer.paths, at, cost);
        total += t;
        at = end;
    }
    total
}

/// Pen-up distance of the whole drawing in millimetres, from `start`.
pub fn pen_up_length(drawing: &Drawing, start: Point) -> f64 {
    drawing_travel(drawing, start, &CostModel::Distance)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Layer;

    fn seg(a: (f64, f64), b: (f64, f64)) -> Polyline {
        Polyline::new(vec![Point::new(a.0, a.1), Point::new(b.0, b.1)])
    }

    #[test]
    fn hops_span_layers_and_skip_empty_paths() {
        let mut d = Drawing::single_layer("a", vec![seg((3.0, 4.0), (10.0, 4.0)), Polyline::default()]);
        let mut b = Layer::new("b");
        b.paths.push(seg((10.0, 7.0), (0.0, 0.0)));
        b.paths.push(Polyline::new(vec![Point::new(0.0, 1.0)]));
        d.layers.push(b);
        // 5 (home → (3,4)) + 3 ((10,4) → (10,7)) + 1 ((0,0) → (0,1)).
        assert!((pen_up_length(&d, Point::ZERO) - 9.0).abs() < 1e-12);
        let (t, end) = paths_travel(&d.layers[0].paths, Point::new(3.0, 4.0), &CostModel::Distance);
        assert_eq!((t, end), (0.0, Point::new(10.0, 4.0)));
    }
}
