//! One-pixel skeletons: Zhang–Suen thinning, staircase clean-up, and the walk that turns a thin bitmap into
//! polylines split at junctions. Shared by the centreline and edge modes.
//!
//! - Thinning follows Zhang and Suen (CACM 1984): two alternating sub-passes each delete, all at once, the border
//!   pixels that have 2–6 foreground neighbours, exactly one background→foreground transition around them, and (in
//!   the first pass) no foreground on both the south-east side pairs, (in the second) the north-west ones. Only
//!   pixels next to a deletion can become deletable, so after the first pass only those are re-examined.
//! - The thinned result can still hold "staircase" pixels: a pixel whose two 4-neighbours touch each other
//!   diagonally. Removing such a pixel keeps the topology when it is a *simple point*, which Yokoi's 8-connectivity
//!   number decides (it counts the 8-connected groups of foreground around the pixel). After the clean-up every
//!   pixel of a curve has exactly two neighbours, so the walk is unambiguous.
//! - The walk treats pixels with one neighbour as ends and pixels with three or more as junctions; adjacent junction
//!   pixels form one junction whose position is their centroid. Each run of two-neighbour pixels between two nodes
//!   becomes one polyline, each used once; what is left afterwards are closed loops.

use super::bitmap::Bitmap;
use kurbo::Point;
use std::collections::HashSet;

// Neighbour offsets P2..P9 of Zhang–Suen: N, NE, E, SE, S, SW, W, NW (clockwise from north, Y down).
const OFFSETS: [(isize, isize); 8] = [(0, -1), (1, -1), (1, 0), (1, 1), (0, 1), (-1, 1), (-1, 0), (-1, -1)];

fn ix(v: usize) -> isize {
    isize::try_from(v).unwrap_or(isize::MAX)
}

/// The eight neighbours of `(x, y)` in the order N, NE, E, SE, S, SW, W, NW.
fn ring(b: &Bitmap, x: usize, y: usize) -> [bool; 8] {
    let (x, y) = (ix(x), ix(y));
    OFFSETS.map(|(dx, dy)| b.get(x + dx, y + dy))
}

/// Neighbour coordinates that lie inside the grid.
fn neighbour_coords(b: &Bitmap, x: usize, y: usize) -> impl Iterator<Item = (usize, usize)> + use<> {
    let (w, h) = (b.width(), b.height());
    OFFSETS.into_iter().filter_map(move |(dx, dy)| {
        let nx = x.checked_add_signed(dx)?;
        let ny = y.checked_add_signed(dy)?;
        (nx < w && ny < h).then_some((nx, ny))
    })
}

fn zs_deletable(n: [bool; 8], first: bool) -> bool {
    let count = n.iter().filter(|&&v| v).count();
    if !(2..=6).contains(&count) {
        return false;
    }
    let transitions = (0..8).filter(|&i| !n[i] && n[(i + 1) % 8]).count();
    if transitions != 1 {
        return false;
    }
    let (p2, p4, p6, p8) = (n[0], n[2], n[4], n[6]);
    // First pass: not (P2·P4·P6) and not (P4·P6·P8), i.e. P4 or P6 is background, or both P2 and P8 are.
    if first { !(p4 && p6) || (!p2 && !p8) } else { !(p2 && p8) || (!p4 && !p6) }
}

/// Zhang–Suen thinning in place.
pub fn zhang_suen(b: &mut Bitmap) {
    let (w, h) = (b.width(), b.height());
    let mut queued = vec![false; w * h];
    let mut cand: Vec<(usize, usize)> = Vec::new();
    for y in 0..h {
        for x in 0..w {
            if b.get(ix(x), ix(y)) && ring(b, x, y).iter().any(|&v| !v) {
                queued[y * w + x] = true;
                cand.push((x, y));
            }
        }
    }
    let (mut first, mut idle) = (true, 0);
    while idle < 2 {
        let del: Vec<(usize, usize)> =
            cand.iter().copied().filter(|&(x, y)| zs_deletable(ring(b, x, y), first)).collect();
        for &(x, y) in &del {
            b.set(x, y, false);
        }
        idle = if del.is_empty() { idle + 1 } else { 0 };
        cand.retain(|&(x, y)| b.get(ix(x), ix(y)));
        for &(x, y) in &del {
            for (nx, ny) in neighbour_coords(b, x, y) {
                if b.get(ix(nx), ix(ny)) && !queued[ny * w + nx] {
                    queued[ny * w + nx] = true;
                    cand.push((nx, ny));
                }
            }
        }
        first = !first;
    }
}

/// Yokoi's 8-connectivity number of a pixel with neighbours `n` (N, NE, E, SE, S, SW, W, NW): 1 for a simple point.
fn connectivity8(n: [bool; 8]) -> usize {
    // Yokoi's ring x1..x8 runs E, NE, N, NW, W, SW, S, SE.
    let x = [n[2], n[1], n[0], n[7], n[6], n[5], n[4], n[3]].map(|v| !v);
    [0usize, 2, 4, 6].iter().filter(|&&k| x[k] && !(x[(k + 1) % 8] && x[(k + 2) % 8])).count()
}

/// Remove staircase pixels: simple points with at least two 4-neighbours, in one raster-order pass.
pub fn remove_staircase(b: &mut Bitmap) {
    for y in 0..b.height() {
        for x in 0..b.width() {
            if !b.get(ix(x), ix(y)) {
                continue;
            }
            let n = ring(b, x, y);
            let four = [n[0], n[2], n[4], n[6]].iter().filter(|&&v| v).count();
            if four >= 2 && connectivity8(n) == 1 {
                b.set(x, y, false);
            }
        }
    }
}

/// What a walked path starts or ends at.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Node {
    /// A pixel with a single neighbour (a free end), or an isolated pixel.
    End,
    /// A junction, by cluster number.
    Junction(usize),
    /// The path is a closed loop without nodes.
    Loop,
}

/// One walked run of skeleton pixels.
#[derive(Debug, Clone, PartialEq)]
pub struct SkeletonPath {
    /// Pixel-centre positions (junction ends at the junction's centroid); closed loops repeat the first point.
    pub points: Vec<Point>,
    /// The skeleton pixels of the run, ends included, as `(x, y)`.
    pub pixels: Vec<(usize, usize)>,
    /// Node at the first point.
    pub start: Node,
    /// Node at the last point.
    pub end: Node,
}

fn pixel_centre(x: usize, y: usize) -> Point {
    #[allow(clippy::cast_precision_loss)] // image coordinates < 2^31
    Point::new(x as f64 + 0.5, y as f64 + 0.5)
}

/// Walk a thin (thinned and staircase-free) bitmap into paths split at junctions; each pixel-to-pixel step is used
/// by exactly one path, isolated pixels become zero-length two-point paths (dots).
pub fn walk(b: &Bitmap) -> Vec<SkeletonPath> {
    let (w, h) = (b.width(), b.height());
    let idx = |x: usize, y: usize| y * w + x;
    let mut degree = vec![0u8; w * h];
    for y in 0..h {
        for x in 0..w {
            if b.get(ix(x), ix(y)) {
                degree[idx(x, y)] = u8::try_from(ring(b, x, y).iter().filter(|&&v| v).count()).unwrap_or(8);
            }
        }
    }
    // Cluster adjacent junction pixels; centroid per cluster.
    let mut cluster = vec![usize::MAX; w * h];
    let mut centroids: Vec<Point> = Vec::new();
    for y in 0..h {
        for x in 0..w {
            if degree[idx(x, y)] >= 3 && cluster[idx(x, y)] == usize::MAX {
                let id = centroids.len();
                let (mut sum, mut n) = (Point::ZERO, 0.0);
                let mut stack = vec![(x, y)];
                cluster[idx(x, y)] = id;
                while let Some((cx, cy)) = stack.pop() {
                    let c = pixel_centre(cx, cy);
                    sum = Point::new(sum.x + c.x, sum.y + c.y);
                    n += 1.0;
                    for (nx, ny) in neighbour_coords(b, cx, cy) {
                        if degree[idx(nx, ny)] >= 3 && cluster[idx(nx, ny)] == usize::MAX {
                            cluster[idx(nx, ny)] = id;
                            stack.push((nx, ny));
                        }
                    }
                }
                centroids.push(Point::new(sum.x / n, sum.y / n));
            }
        }
    }
    let node_of = |x: usize, y: usize| -> Node {
        let c = cluster[idx(x, y)];
        if c == usize::MAX { Node::End } else { Node::Junction(c) }
    };
    let position = |x: usize, y: usize| -> Point {
        let c = cluster[idx(x, y)];
        if c == usize::MAX { pixel_centre(x, y) } else { centroids[c] }
    };
    let mut visited = vec![false; w * h];
    let mut direct: HashSet<(usize, usize)> = HashSet::new();
    let mut out = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let d = degree[idx(x, y)];
            if !b.get(ix(x), ix(y)) || d == 2 {
                continue;
            }
            if d == 0 {
                let p = pixel_centre(x, y);
                out.push(SkeletonPath { points: vec![p, p], pixels: vec![(x, y)], start: Node::End, end: Node::End });
                continue;
            }
            for (nx, ny) in neighbour_coords(b, x, y) {
                if !b.get(ix(nx), ix(ny)) {
                    continue;
                }
                let nd = degree[idx(nx, ny)];
                if nd != 2 {
                    // Two nodes side by side: one direct step, unless both belong to the same junction.
                    let same = cluster[idx(x, y)] != usize::MAX && cluster[idx(x, y)] == cluster[idx(nx, ny)];
                    let key = (idx(x, y).min(idx(nx, ny)), idx(x, y).max(idx(nx, ny)));
                    if !same && direct.insert(key) {
                        out.push(SkeletonPath {
                            points: vec![position(x, y), position(nx, ny)],
                            pixels: vec![(x, y), (nx, ny)],
                            start: node_of(x, y),
                            end: node_of(nx, ny),
                        });
                    }
                    continue;
                }
                if visited[idx(nx, ny)] {
                    continue;
                }
                let mut pixels = vec![(x, y)];
                let (mut prev, mut cur) = ((x, y), (nx, ny));
                loop {
                    pixels.push(cur);
                    if degree[idx(cur.0, cur.1)] != 2 {
                        break;
                    }
                    visited[idx(cur.0, cur.1)] = true;
                    let next =
                        neighbour_coords(b, cur.0, cur.1).find(|&(px, py)| b.get(ix(px), ix(py)) && (px, py) != prev);
                    match next {
                        Some(n) if degree[idx(n.0, n.1)] != 2 || !visited[idx(n.0, n.1)] => {
                            prev = cur;
                            cur = n;
                        }
                        _ => break,
                    }
                }
                let &(ex, ey) = pixels.last().unwrap_or(&(x, y));
                let end = if degree[idx(ex, ey)] == 2 { Node::End } else { node_of(ex, ey) };
                let mut points: Vec<Point> = pixels.iter().map(|&(px, py)| pixel_centre(px, py)).collect();
                points[0] = position(x, y);
                if let (Some(last), Node::Junction(c)) = (points.last_mut(), end) {
                    *last = centroids[c];
                }
                out.push(SkeletonPath { points, pixels, start: node_of(x, y), end });
            }
        }
    }
    // Whatever two-neighbour pixels remain form closed loops.
    for y in 0..h {
        for x in 0..w {
            if degree[idx(x, y)] != 2 || visited[idx(x, y)] || !b.get(ix(x), ix(y)) {
                continue;
            }
            let mut pixels = vec![(x, y)];
            visited[idx(x, y)] = true;
            let (mut prev, mut cur) = ((x, y), (x, y));
            loop {
                let next = neighbour_coords(b, cur.0, cur.1)
                    .find(|&(px, py)| b.get(ix(px), ix(py)) && (px, py) != prev && !visited[idx(px, py)]);
                match next {
                    Some(n) => {
                        visited[idx(n.0, n.1)] = true;
                        pixels.push(n);
                        prev = cur;
                        cur = n;
                    }
                    None => break,
                }
            }
            let closes = neighbour_coords(b, cur.0, cur.1).any(|p| p == (x, y)) && pixels.len() > 2;
            if closes {
                pixels.push((x, y));
            }
            let points = pixels.iter().map(|&(px, py)| pixel_centre(px, py)).collect();
            let kind = if closes { Node::Loop } else { Node::End };
            out.push(SkeletonPath { points, pixels, start: kind, end: kind });
        }
    }
    out
}

/// Thin `b` and clean its staircases: the input for [`walk`].
pub fn skeletonize(b: &mut Bitmap) {
    zhang_suen(b);
    remove_staircase(b);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn thin_of(b: &Bitmap) -> Bitmap {
        let mut t = b.clone();
        skeletonize(&mut t);
        t
    }

    #[test]
    fn thick_bar_thins_to_a_line() {
        let b = Bitmap::from_fn(60, 20, |x, y| (5..55).contains(&x) && (7..12).contains(&y));
        let t = thin_of(&b);
        // One pixel per column along the bar, all on the middle row.
        for x in 10..50 {
            let col: Vec<usize> = (0..20).filter(|&y| t.get(ix(x), ix(y))).collect();
            assert_eq!(col, vec![9], "column {x}");
        }
        let paths = walk(&t);
        assert_eq!(paths.len(), 1);
        assert_eq!((paths[0].start, paths[0].end), (Node::End, Node::End));
    }

    #[test]
    fn simple_point_test() {
        // Staircase corner: neighbours N and W only.
        let corner = [true, false, false, false, false, false, true, false];
        assert_eq!(connectivity8(corner), 1);
        // Middle of a horizontal line: E and W.
        let middle = [false, false, true, false, false, false, true, false];
        assert_eq!(connectivity8(middle), 2);
        // Centre of a plus: removing it would open a hole in the 4-connected background, so it is not simple.
        assert_eq!(connectivity8([true, false, true, false, true, false, true, false]), 0);
        // Isolated: no foreground groups at all.
        assert_eq!(connectivity8([false; 8]), 0);
    }

    #[test]
    fn staircase_is_cleaned_so_every_curve_pixel_has_two_neighbours() {
        // A 4-connected staircase line.
        let mut b = Bitmap::new(20, 20);
        for i in 0..8 {
            b.set(2 + i, 2 + i, true);
            b.set(3 + i, 2 + i, true);
        }
        remove_staircase(&mut b);
        let paths = walk(&b);
        assert_eq!(paths.len(), 1, "{paths:?}");
    }

    #[test]
    fn plus_sign_splits_at_the_junction() {
        let b = Bitmap::from_fn(41, 41, |x, y| {
            ((18..23).contains(&x) && (2..39).contains(&y)) || ((18..23).contains(&y) && (2..39).contains(&x))
        });
        let t = thin_of(&b);
        let paths = walk(&t);
        let arms: Vec<&SkeletonPath> = paths.iter().filter(|p| p.points.len() > 6).collect();
        assert_eq!(arms.len(), 4, "{paths:?}");
        for a in arms {
            assert!(matches!((a.start, a.end), (Node::End, Node::Junction(_)) | (Node::Junction(_), Node::End)));
        }
    }

    #[test]
    fn ring_is_one_closed_loop() {
        let b = super::super::synth::ring(60, 60, (30.0, 30.0), 15.0, 20.0);
        let t = thin_of(&b);
        let paths = walk(&t);
        assert_eq!(paths.len(), 1, "{paths:?}");
        assert_eq!(paths[0].start, Node::Loop);
        assert_eq!(paths[0].points.first(), paths[0].points.last());
        // Radius of the skeleton ≈ 17.5.
        for p in &paths[0].points {
            assert!((p.distance(Point::new(30.0, 30.0)) - 17.5).abs() < 1.5, "{p:?}");
        }
    }

    #[test]
    fn dots_and_direct_steps() {
        let mut b = Bitmap::new(10, 10);
        b.set(1, 1, true);
        b.set(5, 5, true);
        b.set(6, 5, true);
        let paths = walk(&b);
        assert_eq!(paths.len(), 2);
        assert!(paths.iter().any(|p| p.points.len() == 2 && p.points[0] == p.points[1]));
        assert!(paths.iter().any(|p| p.points[0] != p.points[1] && p.pixels.len() == 2));
    }
}
