//! The travel part of the plot-time bound: tight where the best order is known by hand, and never above the best
//! order found by trying every one (order, direction, seam) on small random drawings — so a bound made too tight
//! fails here.

use kurbo::Point;
use plotter_path::motion::bound::min_hop_seconds;
use plotter_path::optimize::{SeamMode, travel_lower_bound_mapped};
use plotter_path::{Drawing, Layer, MachineProfile, Polyline};

fn seg(a: (f64, f64), b: (f64, f64)) -> Polyline {
    Polyline::new(vec![Point::new(a.0, a.1), Point::new(b.0, b.1)])
}

fn square(x: f64, y: f64, s: f64) -> Polyline {
    let p = |dx: f64, dy: f64| Point::new(x + dx, y + dy);
    Polyline::new(vec![p(0.0, 0.0), p(s, 0.0), p(s, s), p(0.0, s), p(0.0, 0.0)])
}

/// The least hop cost of drawing every path once from `start`, each hop of length `d` costing `f(d)`: every order,
/// both directions of open paths, every vertex of closed ones as the seam.
fn brute_force(paths: &[Polyline], start: Point, f: &dyn Fn(f64) -> f64) -> f64 {
    brute_force_layers(&[paths.to_vec()], start, f)
}

/// Each path's ways of being drawn, (entry, exit), and each path's layer.
type Ways<'a> = (&'a [Vec<(Point, Point)>], &'a [usize]);

/// [`brute_force`] over layers drawn one after the other, each in any order (the pen goes from the last path of
/// one layer to the first of the next).
fn brute_force_layers(layers: &[Vec<Polyline>], start: Point, f: &dyn Fn(f64) -> f64) -> f64 {
    let layer_of: Vec<usize> = layers.iter().enumerate().flat_map(|(l, p)| std::iter::repeat_n(l, p.len())).collect();
    let paths: Vec<Polyline> = layers.concat();
    // Each path's ways of being drawn: (entry, exit).
    let ways: Vec<Vec<(Point, Point)>> = paths
        .iter()
        .map(|p| {
            let pts = &p.points;
            if p.is_closed() {
                pts[..pts.len() - 1].iter().map(|&v| (v, v)).collect()
            } else {
                vec![(pts[0], pts[pts.len() - 1]), (pts[pts.len() - 1], pts[0])]
            }
        })
        .collect();
    fn go((ways, layer_of): Ways<'_>, used: &mut [bool], at: Point, acc: f64, f: &dyn Fn(f64) -> f64, best: &mut f64) {
        if acc >= *best {
            return;
        }
        // The layer being drawn: the first with a path left.
        let Some(layer) = (0..ways.len()).find(|&i| !used[i]).map(|i| layer_of[i]) else {
            *best = acc;
            return;
        };
        for i in 0..ways.len() {
            if used[i] || layer_of[i] != layer {
                continue;
            }
            used[i] = true;
            for &(entry, exit) in &ways[i] {
                go((ways, layer_of), used, exit, acc + f(at.distance(entry)), f, best);
            }
            used[i] = false;
        }
    }
    let mut best = f64::INFINITY;
    go((&ways, &layer_of), &mut vec![false; paths.len()], start, 0.0, f, &mut best);
    best
}

#[test]
fn two_segments_pointing_apart_cost_the_hop_back_across() {
    // From the origin, a 10 mm segment north and one south, inner ends 1 mm away. The best order hops 1 mm to an
    // inner end, draws out, and hops 12 mm back from the outer end to the other inner end: 13 mm. The spanning
    // tree of the paths sees only the two 1 mm hops (2 mm).
    let d = Drawing::single_layer("l", vec![seg((0.0, 1.0), (0.0, 11.0)), seg((0.0, -1.0), (0.0, -11.0))]);
    let b = travel_lower_bound_mapped(&d, SeamMode::Any, Some(Point::ZERO), &|l| l);
    assert!(b <= 13.0 && b > 12.99, "{b}");
    assert!((brute_force(&d.layers[0].paths, Point::ZERO, &|l| l) - 13.0).abs() < 1e-12);
}

#[test]
fn the_bound_never_exceeds_the_best_order() {
    // Small random drawings of open segments and closed squares, in millimetres and in the V3's hop seconds.
    let v3 = MachineProfile::from_toml(include_str!("../../samples/axidraw-v3.toml"), "axidraw-v3.toml").unwrap();
    let hop = min_hop_seconds(&v3);
    let mut seed = 99u64;
    let mut next = || {
        seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        f64::from(u32::try_from(seed >> 40).unwrap()) / f64::from(1u32 << 24)
    };
    let mut tighter = 0;
    for case in 0..60 {
        let mut paths = Vec::new();
        for k in 0..(3 + case % 4) {
            let (x, y) = (60.0 * next(), 40.0 * next());
            if k % 3 == 2 {
                paths.push(square(x, y, 1.0 + 8.0 * next()));
            } else {
                paths.push(seg((x, y), (x + 30.0 * next() - 15.0, y + 30.0 * next() - 15.0)));
            }
        }
        let start = Point::new(60.0 * next(), 40.0 * next());
        let d = Drawing::single_layer("l", paths);
        for (name, f) in [("mm", &(|l: f64| l) as &dyn Fn(f64) -> f64), ("s", &hop)] {
            let best = brute_force(&d.layers[0].paths, start, f);
            let b = travel_lower_bound_mapped(&d, SeamMode::Any, Some(start), f);
            assert!(b <= best + 1e-9, "case {case} ({name}): bound {b} above the best order {best}");
            // Without a start the bound can only be lower.
            let free = travel_lower_bound_mapped(&d, SeamMode::Any, None, f);
            assert!(free <= b + 1e-9, "case {case} ({name}): {free} > {b}");
            tighter += usize::from(b > 0.9 * best);
        }
    }
    // And it is close: within 10 % of the best order in most cases.
    assert!(tighter >= 80, "{tighter} of 120 within 10 %");
}

/// A small random drawing: open segments and closed squares.
fn random_paths(count: usize, next: &mut impl FnMut() -> f64) -> Vec<Polyline> {
    (0..count)
        .map(|k| {
            let (x, y) = (60.0 * next(), 40.0 * next());
            if k % 3 == 2 {
                square(x, y, 1.0 + 8.0 * next())
            } else {
                seg((x, y), (x + 30.0 * next() - 15.0, y + 30.0 * next() - 15.0))
            }
        })
        .collect()
}

fn lcg(mut seed: u64) -> impl FnMut() -> f64 {
    move || {
        seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        f64::from(u32::try_from(seed >> 40).unwrap()) / f64::from(1u32 << 24)
    }
}

#[test]
fn a_small_layer_is_bounded_at_its_best_order() {
    // Up to six paths: the bound is the best order found by trying every one (each square entered and left at
    // the same corner), in millimetres and in the V3's hop seconds.
    let v3 = MachineProfile::from_toml(include_str!("../../samples/axidraw-v3.toml"), "axidraw-v3.toml").unwrap();
    let hop = min_hop_seconds(&v3);
    let mut next = lcg(7);
    for case in 0..30 {
        let paths = random_paths(3 + case % 4, &mut next);
        let start = Point::new(60.0 * next(), 40.0 * next());
        let d = Drawing::single_layer("l", paths);
        for (name, f) in [("mm", &(|l: f64| l) as &dyn Fn(f64) -> f64), ("s", &hop)] {
            let best = brute_force(&d.layers[0].paths, start, f);
            let b = travel_lower_bound_mapped(&d, SeamMode::Any, Some(start), f);
            assert!(b <= best && b >= best * (1.0 - 1e-9), "case {case} ({name}): bound {b}, best order {best}");
        }
    }
}

#[test]
fn a_later_layer_starts_where_the_layer_before_can_end() {
    // Layer one: a 10 mm segment along X from the start at the origin. Layer two: a segment from (10, 5) to
    // (10, 20). The best plot draws the first from the origin (no hop), leaves it at (10, 0) and hops 5 mm to
    // (10, 5): 5 mm, as trying every order says. Taken as starting anywhere, the second layer was bounded at 0.
    let mut d = Drawing::single_layer("one", vec![seg((0.0, 0.0), (10.0, 0.0))]);
    let mut two = Layer::new("two");
    two.paths.push(seg((10.0, 5.0), (10.0, 20.0)));
    d.layers.push(two);
    let layers: Vec<Vec<Polyline>> = d.layers.iter().map(|l| l.paths.clone()).collect();
    assert!((brute_force_layers(&layers, Point::ZERO, &|l| l) - 5.0).abs() < 1e-12);
    let b = travel_lower_bound_mapped(&d, SeamMode::Any, Some(Point::ZERO), &|l| l);
    assert!((b - 5.0).abs() < 1e-9, "{b}");
}

#[test]
fn layers_are_never_bounded_above_their_best_order() {
    // Two or three small random layers (and an empty one between), from a known start and from anywhere: never
    // above the best plot found by trying every order within each layer.
    let v3 = MachineProfile::from_toml(include_str!("../../samples/axidraw-v3.toml"), "axidraw-v3.toml").unwrap();
    let hop = min_hop_seconds(&v3);
    let mut next = lcg(41);
    for case in 0..24 {
        let mut d = Drawing::single_layer("0", random_paths(2 + case % 2, &mut next));
        d.layers.push(Layer::new("empty"));
        for k in 0..(1 + case % 2) {
            let mut l = Layer::new(format!("{k}"));
            l.paths = random_paths(2 + (case + k) % 2, &mut next);
            d.layers.push(l);
        }
        let start = Point::new(60.0 * next(), 40.0 * next());
        let layers: Vec<Vec<Polyline>> = d.layers.iter().map(|l| l.paths.clone()).collect();
        for (name, f) in [("mm", &(|l: f64| l) as &dyn Fn(f64) -> f64), ("s", &hop)] {
            let best = brute_force_layers(&layers, start, f);
            let b = travel_lower_bound_mapped(&d, SeamMode::Any, Some(start), f);
            assert!(b <= best + 1e-9, "case {case} ({name}): bound {b} above the best plot {best}");
            // From anywhere, the first hop is free: still below the best plot from the start.
            let free = travel_lower_bound_mapped(&d, SeamMode::Any, None, f);
            assert!(free <= b + 1e-9, "case {case} ({name}): {free} > {b}");
        }
    }
}
