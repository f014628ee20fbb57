//! Geometry far beyond any page: the parts of pen lines outside ±[`MAX_COORD_MM`] (1 km) on either axis are cut
//! off at import, with a warning naming the elements, instead of rejecting the whole file. Clip art sometimes
//! carries a stray point at 10¹² user units (a broken export) next to a perfectly good drawing; a browser shows the
//! drawing, so the importer keeps it. Lines are clipped segment by segment to the square (Liang–Barsky), so a
//! segment from the page to a far point keeps its part inside the square, exactly.

use kurbo::Point;

use super::walk::Item;
use crate::geometry::limits::MAX_COORD_MM;

/// The part of segment `a`–`b` inside the square |x|, |y| ≤ `m`, as parameters `(t0, t1)` along it, if any.
fn clip_segment(a: Point, b: Point, m: f64) -> Option<(f64, f64)> {
    let (dx, dy) = (b.x - a.x, b.y - a.y);
    let (mut t0, mut t1) = (0.0_f64, 1.0_f64);
    // Each edge as p·t ≤ q.
    for (p, q) in [(-dx, a.x + m), (dx, m - a.x), (-dy, a.y + m), (dy, m - a.y)] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else {
            let r = q / p;
            if p < 0.0 {
                t0 = t0.max(r);
            } else {
                t1 = t1.min(r);
            }
        }
    }
    (t0 <= t1).then_some((t0, t1))
}

/// The point at `t` along `a`–`b`: the ends exactly, and points of the edge on it (rounding aside).
fn at(a: Point, b: Point, t: f64, m: f64) -> Point {
    if t <= 0.0 {
        return a;
    }
    if t >= 1.0 {
        return b;
    }
    let snap = |v: f64| if (v.abs() - m).abs() <= m * 1e-12 { m.copysign(v) } else { v };
    let p = a.lerp(b, t);
    Point::new(snap(p.x), snap(p.y))
}

/// Clip one polyline to the square |x|, |y| ≤ `m`; `None` when it lies inside already.
fn clip_polyline(line: &[Point], m: f64) -> Option<Vec<Vec<Point>>> {
    let inside = |p: &Point| p.x.abs() <= m && p.y.abs() <= m;
    if line.iter().all(inside) {
        return None;
    }
    let mut out: Vec<Vec<Point>> = Vec::new();
    let mut current: Vec<Point> = Vec::new();
    for w in line.windows(2) {
        let (a, b) = (w[0], w[1]);
        let Some((t0, t1)) = clip_segment(a, b, m) else {
            if current.len() >= 2 {
                out.push(std::mem::take(&mut current));
            }
            current.clear();
            continue;
        };
        let (p, q) = (at(a, b, t0, m), at(a, b, t1, m));
        if current.last() != Some(&p) {
            if current.len() >= 2 {
                out.push(std::mem::take(&mut current));
            }
            current = vec![p];
        }
        current.push(q);
        if t1 < 1.0 {
            out.push(std::mem::take(&mut current));
        }
    }
    if current.len() >= 2 {
        out.push(current);
    }
    out.retain(|l| l.windows(2).any(|w| w[0] != w[1]));
    Some(out)
}

/// Cut `lines` to ±1 km in place; whether any was cut.
fn cut_lines_far(lines: &mut Vec<Vec<Point>>) -> bool {
    let mut changed = false;
    let mut kept = Vec::with_capacity(lines.len());
    for line in std::mem::take(lines) {
        match clip_polyline(&line, MAX_COORD_MM) {
            None => kept.push(line),
            Some(parts) => {
                changed = true;
                kept.extend(parts);
            }
        }
    }
    *lines = kept;
    changed
}

/// Cut every item's lines (and the outline waiting for the edge rule) to ±1 km; returns a warning naming the
/// elements that lost lines, if any did.
pub(super) fn cut_far(items: &mut [Item]) -> Option<String> {
    let mut elements: Vec<String> = Vec::new();
    for item in items.iter_mut() {
        let mut changed = cut_lines_far(&mut item.lines);
        if let Some(outline) = item.outline.as_mut() {
            changed |= cut_lines_far(&mut outline.lines);
        }
        if changed && !elements.contains(&item.element) {
            elements.push(item.element.clone());
        }
    }
    if elements.is_empty() {
        return None;
    }
    let n = elements.len();
    let mut shown: Vec<String> = elements.into_iter().take(5).collect();
    if n > 5 {
        shown.push("…".into());
    }
    Some(format!(
        "{n} element(s) ({}) reach beyond ±{MAX_COORD_MM} mm (1 km): cut there, the rest is kept — check the units \
         or the scale",
        shown.join(", ")
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(x: f64, y: f64) -> Point {
        Point::new(x, y)
    }

    #[test]
    fn a_segment_to_a_far_point_keeps_its_part_inside() {
        // From (0, 0) to (4, 2) against the square of half-side 1: leaves through x = 1 at t = 1/4, y = 0.5.
        assert_eq!(clip_segment(p(0.0, 0.0), p(4.0, 2.0), 1.0), Some((0.0, 0.25)));
        // Crossing the whole square along y = 0.5: enters at x = -1 (t = 1/4 of -3..5), leaves at x = 1 (t = 1/2).
        assert_eq!(clip_segment(p(-3.0, 0.5), p(5.0, 0.5), 1.0), Some((0.25, 0.5)));
        // Entirely outside, parallel to an edge.
        assert_eq!(clip_segment(p(2.0, -5.0), p(2.0, 5.0), 1.0), None);
        // Missing the corner.
        assert_eq!(clip_segment(p(0.0, 3.0), p(3.0, 0.0), 1.0), None);
    }

    #[test]
    fn polylines_split_where_they_leave_and_come_back() {
        let m = 10.0;
        assert_eq!(clip_polyline(&[p(0.0, 0.0), p(5.0, 5.0)], m), None);
        // In, out to x = 30, back in: two pieces, each ending on the edge x = 10.
        let parts = clip_polyline(&[p(0.0, 0.0), p(30.0, 0.0), p(0.0, 5.0)], m).unwrap();
        assert_eq!(parts.len(), 2);
        assert_eq!(parts[0], vec![p(0.0, 0.0), p(10.0, 0.0)]);
        assert_eq!(parts[1].len(), 2);
        assert!((parts[1][0].x - 10.0).abs() < 1e-12 && (parts[1][0].y - 10.0 / 3.0).abs() < 1e-12);
        assert_eq!(parts[1][1], p(0.0, 5.0));
        // Wholly outside: nothing left.
        assert_eq!(clip_polyline(&[p(20.0, 0.0), p(30.0, 0.0)], m), Some(vec![]));
        // A huge coordinate next to a good one keeps the good segment through the first point whole.
        let parts = clip_polyline(&[p(1.0, 1.0), p(2.0, 1.0), p(1e12, 1.0)], m).unwrap();
        assert_eq!(parts, vec![vec![p(1.0, 1.0), p(2.0, 1.0), p(10.0, 1.0)]]);
    }

    #[test]
    fn each_edge_clips_with_its_own_coordinate() {
        // Upwards along x = 0.5 against half-side 2: enters y = -2 at t = 4/16, leaves y = 2 at t = 8/16.
        assert_eq!(clip_segment(p(0.5, -6.0), p(0.5, 10.0), 2.0), Some((0.25, 0.5)));
        // Lying on the edge x = 2 itself, within the square: kept whole.
        assert_eq!(clip_segment(p(2.0, -1.0), p(2.0, 1.0), 2.0), Some((0.0, 1.0)));
    }

    #[test]
    fn a_spike_out_and_back_comes_back_exactly_on_the_edge() {
        // Out along y = 0 to x = 23 and back: leaves at x = 10 and re-enters there; the re-entry point, 23 − 13
        // by interpolation (off by an ulp), lands exactly on the edge.
        let parts = clip_polyline(&[p(0.0, 0.0), p(23.0, 0.0), p(0.0, 0.0)], 10.0).unwrap();
        assert_eq!(parts, vec![vec![p(0.0, 0.0), p(10.0, 0.0)], vec![p(10.0, 0.0), p(0.0, 0.0)]]);
    }

    fn item(element: &str, lines: Vec<Vec<Point>>) -> Item {
        Item {
            layer: 0,
            pen: crate::geometry::drawing::Pen::default(),
            lines,
            outline: None,
            paints: Vec::new(),
            element: element.into(),
        }
    }

    #[test]
    fn the_warning_names_up_to_five_elements_once_each() {
        let far = || vec![p(0.0, 0.0), p(2.0e6, 0.0)];
        let mut items = vec![item("<a>", vec![far()]), item("<ok>", vec![vec![p(0.0, 0.0), p(1.0, 1.0)]])];
        items.extend(["<b>", "<c>", "<a>", "<d>", "<e>"].map(|e| item(e, vec![far()])));
        let w = cut_far(&mut items).unwrap();
        assert_eq!(
            w,
            "5 element(s) (<a>, <b>, <c>, <d>, <e>) reach beyond ±1000000 mm (1 km): cut there, the rest is kept — \
             check the units or the scale"
        );
        assert_eq!(items[0].lines, vec![vec![p(0.0, 0.0), p(1.0e6, 0.0)]]);
        assert_eq!(items[1].lines, vec![vec![p(0.0, 0.0), p(1.0, 1.0)]]);
        items.push(item("<f>", vec![far()]));
        let w = cut_far(&mut items).unwrap();
        assert!(w.starts_with("1 element(s) (<f>)"), "{w}");
        let mut six: Vec<Item> = ["<1>", "<2>", "<3>", "<4>", "<5>", "<6>"].map(|e| item(e, vec![far()])).into();
        let w = cut_far(&mut six).unwrap();
        assert!(w.starts_with("6 element(s) (<1>, <2>, <3>, <4>, <5>, …) reach"), "{w}");
        assert_eq!(cut_far(&mut six), None, "already cut");
        // A fill-only shape's outline, still waiting for the edge rule, is cut the same way and named.
        let mut outlined = item("<g>", Vec::new());
        outlined.outline = Some(super::super::walk::Outline { lines: vec![far()], color: None });
        let mut items = vec![outlined];
        let w = cut_far(&mut items).unwrap();
        assert!(w.starts_with("1 element(s) (<g>)"), "{w}");
        assert_eq!(items[0].outline.as_ref().map(|o| o.lines.clone()), Some(vec![vec![p(0.0, 0.0), p(1.0e6, 0.0)]]));
    }
}
