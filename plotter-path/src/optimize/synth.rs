//! Synthetic drawings for benchmarks and tests: uniform random segments at any size, and "real-world-like"
//! drawings of a few hundred to a few thousand paths (handwriting-like text, hatch-filled shapes, a maze drawn as
//! wall segments, contour lines of a smooth field, scattered glyphs, traced-image-like outlines). They stand in for
//! real SVGs, which this project does not ship; every generator is deterministic in its seed.

use std::collections::HashMap;

use kurbo::{Point, Vec2};

use super::rng::SplitMix64;
use crate::{Drawing, Polyline};

const PAGE_W: f64 = 400.0;
const PAGE_H: f64 = 280.0;

fn drawing(name: &str, paths: Vec<Polyline>) -> Drawing {
    let mut d = Drawing::single_layer(name, paths);
    d.page_mm = Some((PAGE_W, PAGE_H));
    d
}

/// `n` random straight segments in a 400 × 280 mm page, lengths up to about twice the mean spacing.
pub fn random_segments(n: usize, seed: u64) -> Drawing {
    let mut r = SplitMix64::new(seed);
    #[allow(clippy::cast_precision_loss, reason = "counts far below 2^52")]
    let spacing = (PAGE_W * PAGE_H / n.max(1) as f64).sqrt();
    let paths = (0..n)
        .map(|_| {
            let a = Point::new(r.unit() * PAGE_W, r.unit() * PAGE_H);
            let ang = r.unit() * std::f64::consts::TAU;
            let len = r.unit() * 2.0 * spacing;
            Polyline::new(vec![a, a + Vec2::new(ang.cos() * len, ang.sin() * len)])
        })
        .collect();
    drawing("random-segments", paths)
}

/// Handwriting-like text: lines of words of 2–9 glyphs, each glyph 1–4 short wiggly strokes in a 3 × 5 mm cell.
pub fn text_like(seed: u64) -> Drawing {
    let mut r = SplitMix64::new(seed);
    let mut paths = Vec::new();
    let mut y = 15.0;
    while y < PAGE_H - 10.0 {
        let mut x = 15.0 + r.unit() * 5.0;
        while x < PAGE_W - 40.0 {
            let letters = 2 + r.below(8);
            for _ in 0..letters {
                for _ in 0..1 + r.below(4) {
                    let mut p = Point::new(x + r.unit() * 3.0, y - r.unit() * 5.0);
                    let mut stroke = vec![p];
                    for _ in 0..2 + r.below(5) {
                        p += Vec2::new(r.unit() * 2.0 - 1.0, r.unit() * 3.0 - 1.5);
                        stroke.push(p);
                    }
                    paths.push(Polyline::new(stroke));
                }
                x += 3.5;
            }
            x += 4.0 + r.unit() * 2.0;
        }
        y += 9.0;
    }
    drawing("text", paths)
}

/// Clip the infinite line `p + t·dir` to the convex polygon `poly` (counter-clockwise or clockwise).
fn clip_line(poly: &[Point], p: Point, dir: Vec2) -> Option<(Point, Point)> {
    let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
    let m = poly.len();
    let area: f64 = (0..m).map(|i| poly[i].to_vec2().cross(poly[(i + 1) % m].to_vec2())).sum();
    for i in 0..m {
        let (a, b) = (poly[i], poly[(i + 1) % m]);
        let e = b - a;
        // Inside is to the left for counter-clockwise polygons (positive area in Y-down space as computed).
        let n = if area > 0.0 { Vec2::new(-e.y, e.x) } else { Vec2::new(e.y, -e.x) };
        let denom = n.dot(dir);
        let num = n.dot(p - a);
        if denom.abs() < 1e-12 {
            if num < 0.0 {
                return None;
            }
        } else {
            let t = -num / denom;
            if denom > 0.0 {
                t0 = t0.max(t);
            } else {
                t1 = t1.min(t);
            }
        }
    }
    (t1 > t0).then(|| (p + dir * t0, p + dir * t1))
}

/// Convex shapes (regular polygons and ellipses) with their outlines, each filled with parallel hatching at its
/// own angle, drawn in the order a naive exporter would emit them (shape by shape, lines in scan order).
pub fn hatch_fill(seed: u64) -> Drawing {
    let mut r = SplitMix64::new(seed);
    let mut paths = Vec::new();
    for _ in 0..24 {
        let c = Point::new(30.0 + r.unit() * (PAGE_W - 60.0), 30.0 + r.unit() * (PAGE_H - 60.0));
        let rad = 8.0 + r.unit() * 28.0;
        let sides = if r.below(2) == 0 { 3 + r.below(5) } else { 48 };
        let squash = 0.5 + r.unit() * 0.5;
        let rot = r.unit() * std::f64::consts::TAU;
        let poly: Vec<Point> = (0..sides)
            .map(|i| {
                #[allow(clippy::cast_precision_loss, reason = "small counts")]
                let a = rot + std::f64::consts::TAU * i as f64 / sides as f64;
                c + Vec2::new(a.cos() * rad, a.sin() * rad * squash)
            })
            .collect();
        let mut outline = poly.clone();
        outline.push(poly[0]);
        paths.push(Polyline::new(outline));
        let ang = r.unit() * std::f64::consts::PI;
        let dir = Vec2::new(ang.cos(), ang.sin());
        let normal = Vec2::new(-dir.y, dir.x);
        let spacing = 0.8 + r.unit() * 0.8;
        let mut off = -rad;
        while off <= rad {
            if let Some((a, b)) = clip_line(&poly, c + normal * off, dir) {
                paths.push(Polyline::new(vec![a, b]));
            }
            off += spacing;
        }
    }
    drawing("hatch", paths)
}

/// A 60 × 40 maze (randomized depth-first search) drawn as one segment per wall piece, in grid order.
pub fn maze(seed: u64) -> Drawing {
    const W: usize = 60;
    const H: usize = 40;
    let cell = 6.0;
    let mut r = SplitMix64::new(seed);
    // Walls: right[x][y] between (x,y) and (x+1,y); down[x][y] between (x,y) and (x,y+1).
    let mut right = vec![true; W * H];
    let mut down = vec![true; W * H];
    let mut seen = vec![false; W * H];
    let mut stack = vec![(0usize, 0usize)];
    seen[0] = true;
    while let Some(&(x, y)) = stack.last() {
        let mut next = Vec::with_capacity(4);
        if x > 0 && !seen[(x - 1) * H + y] {
            next.push((x - 1, y));
        }
        if x + 1 < W && !seen[(x + 1) * H + y] {
            next.push((x + 1, y));
        }
        if y > 0 && !seen[x * H + y - 1] {
            next.push((x, y - 1));
        }
        if y + 1 < H && !seen[x * H + y + 1] {
            next.push((x, y + 1));
        }
        if next.is_empty() {
            stack.pop();
            continue;
        }
        let (nx, ny) = next[r.below(next.len())];
        match (nx.cmp(&x), ny.cmp(&y)) {
            (std::cmp::Ordering::Greater, _) => right[x * H + y] = false,
            (std::cmp::Ordering::Less, _) => right[nx * H + ny] = false,
            (_, std::cmp::Ordering::Greater) => down[x * H + y] = false,
            _ => down[nx * H + ny] = false,
        }
        seen[nx * H + ny] = true;
        stack.push((nx, ny));
    }
    let p = |x: usize, y: usize| {
        #[allow(clippy::cast_precision_loss, reason = "small counts")]
        let q = Point::new(20.0 + x as f64 * cell, 20.0 + y as f64 * cell);
        q
    };
    let mut paths = vec![
        Polyline::new(vec![p(0, 0), p(W, 0)]),
        Polyline::new(vec![p(0, 0), p(0, H)]),
        Polyline::new(vec![p(W, 0), p(W, H)]),
        Polyline::new(vec![p(0, H), p(W, H)]),
    ];
    for y in 0..H {
        for x in 0..W {
            if x + 1 < W && right[x * H + y] {
                paths.push(Polyline::new(vec![p(x + 1, y), p(x + 1, y + 1)]));
            }
            if y + 1 < H && down[x * H + y] {
                paths.push(Polyline::new(vec![p(x, y + 1), p(x + 1, y + 1)]));
            }
        }
    }
    drawing("maze", paths)
}

/// A smooth random field: a sum of Gaussian bumps.
struct Field {
    bumps: Vec<(Point, f64, f64)>,
}

impl Field {
    fn new(r: &mut SplitMix64, count: usize, min_r: f64, max_r: f64) -> Self {
        let bumps = (0..count)
            .map(|_| {
                let c = Point::new(r.unit() * PAGE_W, r.unit() * PAGE_H);
                let rad = min_r + r.unit() * (max_r - min_r);
                (c, rad, r.unit() * 2.0 - 1.0)
            })
            .collect();
        Field { bumps }
    }

    fn at(&self, p: Point) -> f64 {
        self.bumps.iter().map(|&(c, rad, h)| h * (-(p - c).hypot2() / (rad * rad)).exp()).sum()
    }
}

/// Iso-lines of `field` at `levels` by marching squares on a grid of `step` mm, chained into polylines (closed
/// where the line closes).
fn iso_lines(field: &Field, levels: &[f64], step: f64) -> Vec<Polyline> {
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss, reason = "page size / positive step")]
    let (nx, ny) = ((PAGE_W / step) as usize, (PAGE_H / step) as usize);
    #[allow(clippy::cast_precision_loss, reason = "small counts")]
    let gp = |i: usize, j: usize| Point::new(i as f64 * step, j as f64 * step);
    let mut values = vec![0.0; (nx + 1) * (ny + 1)];
    for i in 0..=nx {
        for j in 0..=ny {
            values[i * (ny + 1) + j] = field.at(gp(i, j));
        }
    }
    let v = |i: usize, j: usize| values[i * (ny + 1) + j];
    let mut out = Vec::new();
    for &level in levels {
        // Edge key: (i, j, 0) horizontal from (i,j) to (i+1,j); (i, j, 1) vertical from (i,j) to (i,j+1).
        let crossing = |(i, j, k): (usize, usize, usize)| {
            let (a, b) = if k == 0 { (gp(i, j), gp(i + 1, j)) } else { (gp(i, j), gp(i, j + 1)) };
            let (va, vb) = if k == 0 { (v(i, j), v(i + 1, j)) } else { (v(i, j), v(i, j + 1)) };
            a.lerp(b, ((level - va) / (vb - va)).clamp(0.0, 1.0))
        };
        let mut segs: Vec<[(usize, usize, usize); 2]> = Vec::new();
        for i in 0..nx {
            for j in 0..ny {
                let corners = [v(i, j), v(i + 1, j), v(i + 1, j + 1), v(i, j + 1)];
                let case = corners.iter().enumerate().fold(0, |acc, (b, &c)| acc | (usize::from(c > level) << b));
                let (top, right, bottom, left) = ((i, j, 0), (i + 1, j, 1), (i, j + 1, 0), (i, j, 1));
                let pairs: &[[(usize, usize, usize); 2]] = match case {
                    1 | 14 => &[[left, top]],
                    2 | 13 => &[[top, right]],
                    3 | 12 => &[[left, right]],
                    4 | 11 => &[[right, bottom]],
                    6 | 9 => &[[top, bottom]],
                    7 | 8 => &[[left, bottom]],
                    5 => &[[left, top], [right, bottom]],
                    10 => &[[top, right], [left, bottom]],
                    _ => &[],
                };
                segs.extend_from_slice(pairs);
            }
        }
        let mut at_edge: HashMap<(usize, usize, usize), Vec<usize>> = HashMap::new();
        for (s, pair) in segs.iter().enumerate() {
            for e in pair {
                at_edge.entry(*e).or_default().push(s);
            }
        }
        let mut used = vec![false; segs.len()];
        // Open lines first (from edges with one segment), then loops.
        let mut starts: Vec<(usize, usize, usize)> =
            at_edge.iter().filter(|(_, v)| v.len() == 1).map(|(k, _)| *k).collect();
        starts.sort_unstable();
        let loop_starts: Vec<(usize, usize, usize)> = segs.iter().map(|p| p[0]).collect();
        for start in starts.into_iter().chain(loop_starts) {
            let mut edge = start;
            let mut line = vec![crossing(edge)];
            while let Some(&s) = at_edge.get(&edge).and_then(|l| l.iter().find(|&&s| !used[s])) {
                used[s] = true;
                edge = if segs[s][0] == edge { segs[s][1] } else { segs[s][0] };
                line.push(crossing(edge));
            }
            if line.len() >= 2 {
                out.push(Polyline::new(line));
            }
        }
    }
    out
}

/// A topographic map: contour lines of a smooth random field at twenty-six levels.
pub fn contours(seed: u64) -> Drawing {
    let mut r = SplitMix64::new(seed);
    let field = Field::new(&mut r, 140, 8.0, 40.0);
    let levels: Vec<f64> = (-13..=13).filter(|&k| k != 0).map(|k| f64::from(k) * 0.062).collect();
    drawing("contours", iso_lines(&field, &levels, 2.0))
}

/// Scattered small closed glyphs: circles, squares and stars of 1–4 mm, in random order.
pub fn glyphs(seed: u64) -> Drawing {
    let mut r = SplitMix64::new(seed);
    let paths = (0..1500)
        .map(|_| {
            let c = Point::new(10.0 + r.unit() * (PAGE_W - 20.0), 10.0 + r.unit() * (PAGE_H - 20.0));
            let rad = 0.5 + r.unit() * 1.5;
            let (sides, star) = match r.below(3) {
                0 => (16, false),
                1 => (4, false),
                _ => (10, true),
            };
            let rot = r.unit() * std::f64::consts::TAU;
            let mut pts: Vec<Point> = (0..sides)
                .map(|i| {
                    #[allow(clippy::cast_precision_loss, reason = "small counts")]
                    let a = rot + std::f64::consts::TAU * i as f64 / sides as f64;
                    let k = if star && i % 2 == 1 { 0.45 } else { 1.0 };
                    c + Vec2::new(a.cos(), a.sin()) * rad * k
                })
                .collect();
            pts.push(pts[0]);
            Polyline::new(pts)
        })
        .collect();
    drawing("glyphs", paths)
}

/// A traced-image-like set of outlines: iso-lines of a busy field (many small bumps) at two thresholds, as an
/// image tracer would emit them for a posterized photo.
pub fn traced(seed: u64) -> Drawing {
    let mut r = SplitMix64::new(seed);
    let field = Field::new(&mut r, 700, 2.5, 10.0);
    drawing("traced", iso_lines(&field, &[0.3, -0.3], 1.0))
}

/// The realistic set used for the "≤ 0.80 × greedy" check: name and drawing.
pub fn realistic_set(seed: u64) -> Vec<(&'static str, Drawing)> {
    vec![
        ("text", text_like(seed)),
        ("hatch", hatch_fill(seed)),
        ("maze", maze(seed)),
        ("contours", contours(seed)),
        ("glyphs", glyphs(seed)),
        ("traced", traced(seed)),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn generators_are_deterministic_and_sized() {
        for (name, d) in realistic_set(1) {
            let n = d.path_count();
            assert!((200..=6000).contains(&n), "{name}: {n} paths");
            assert!(d.paths().all(|p| p.points.len() >= 2), "{name}");
            assert!(d.paths().flat_map(|p| &p.points).all(|p| p.x.is_finite() && p.y.is_finite()));
        }
        assert_eq!(maze(3), maze(3));
        assert_ne!(text_like(3), text_like(4));
        assert_eq!(random_segments(1000, 2).path_count(), 1000);
        // Contours come out as chained polylines, some of them closed loops.
        let c = contours(1);
        assert!(c.paths().any(|p| p.is_closed()) && c.paths().any(|p| p.points.len() > 20));
    }

    #[test]
    fn clip_line_cuts_a_square() {
        let sq = [Point::new(0.0, 0.0), Point::new(10.0, 0.0), Point::new(10.0, 10.0), Point::new(0.0, 10.0)];
        let (a, b) = clip_line(&sq, Point::new(-5.0, 5.0), Vec2::new(1.0, 0.0)).unwrap();
        assert!((a - Point::new(0.0, 5.0)).hypot() < 1e-12 && (b - Point::new(10.0, 5.0)).hypot() < 1e-12);
        assert!(clip_line(&sq, Point::new(-5.0, 15.0), Vec2::new(1.0, 0.0)).is_none());
    }
}
