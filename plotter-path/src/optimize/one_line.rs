//! One continuous line through every point of a drawing — the "TSP art" of a stipple: the points (zero-length
//! paths, one touch of the pen each) are ordered by the path optimizer (nearest neighbour, then 2-opt/Or-opt) and
//! joined into a single polyline per layer, so the pen never lifts.

use crate::optimize::{OptimizeOptions, optimize};
use crate::{Drawing, Polyline};

/// Order the paths of every layer of `drawing` by the optimizer and replace them with one polyline through their
/// first points, in that order. A layer of fewer than two paths is left as it is. Should the optimizer refuse (it
/// does not on finite points), the points are joined in their given order.
pub fn join_into_one_line(drawing: &mut Drawing) {
    let opts =
        OptimizeOptions { merge: false, lower_bound: false, work_per_path: Some(200.0), ..OptimizeOptions::default() };
    let ordered = {
        let mut d = drawing.clone();
        optimize(&mut d, &opts).is_ok().then_some(d)
    };
    if let Some(d) = ordered {
        *drawing = d;
    }
    for layer in &mut drawing.layers {
        if layer.paths.len() < 2 {
            continue;
        }
        let line: Vec<_> = layer.paths.iter().filter_map(|p| p.points.first().copied()).collect();
        layer.paths = vec![Polyline::new(line)];
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use kurbo::Point;

    #[test]
    fn the_line_visits_every_point_once_and_is_routed() {
        // A 30 × 30 grid of dots 2 apart, given in a shuffled order.
        let mut dots: Vec<Point> =
            (0..900).map(|i| Point::new(f64::from(i % 30) * 2.0, f64::from(i / 30) * 2.0)).collect();
        let mut state = 12_345_u64;
        for i in (1..dots.len()).rev() {
            state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            #[allow(clippy::cast_possible_truncation)]
            let j = (state >> 33) as usize % (i + 1);
            dots.swap(i, j);
        }
        let paths = dots.iter().map(|&p| Polyline::new(vec![p, p])).collect();
        let mut drawing = Drawing::single_layer("stipple", paths);
        join_into_one_line(&mut drawing);
        let line = &drawing.layers[0].paths;
        assert_eq!(line.len(), 1);
        assert_eq!(line[0].points.len(), dots.len());
        let key = |p: &Point| (p.x.to_bits(), p.y.to_bits());
        let mut a: Vec<_> = dots.iter().map(key).collect();
        let mut b: Vec<_> = line[0].points.iter().map(key).collect();
        a.sort_unstable();
        b.sort_unstable();
        assert_eq!(a, b, "every dot once");
        // Routed: a grid tour needs 899 hops of 2 (1798); the shuffled order averages ~40 per hop.
        let len: f64 = line[0].points.windows(2).map(|w| w[0].distance(w[1])).sum();
        assert!(len < 1798.0 * 1.15, "tour length {len}");
    }
}
