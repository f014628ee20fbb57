//! Stipple style: the picture as pen dots, denser where it is darker (weighted Voronoi stippling, after Secord's
//! "Weighted Voronoi Stippling", 2002), optionally joined into one continuous line (TSP art).
//!
//! **How many dots.** Each dot is one touch of the pen, a disc of the pen's width, so `N = Σ darkness · pixel area /
//! dot area` dots cover as much paper as the tone model asks for (dots are spread so they rarely overlap until the
//! tone is near black). White gets no dots.
//!
//! **Where.** The dots start at evenly spaced quantiles of the darkness, taken in reading order, and are then moved
//! by Lloyd relaxation on the density: every pixel belongs to its nearest dot (its Voronoi cell, found by a
//! nearest-vertex query on a Delaunay triangulation of the dots, from the `spade` crate), and each dot moves to the
//! darkness-weighted centroid of its cell. A few rounds spread the dots evenly within each tone.
//!
//! **TSP line.** With `tsp`, the dots are visited in the order found by the path optimizer (nearest neighbour then
//! 2-opt/Or-opt) and drawn as one polyline through them; the optimizer comes after the inputs, so the front end
//! does that join on the traced drawing (`optimize::one_line`).

use super::tone::DarknessMap;
use kurbo::Point;
use spade::{DelaunayTriangulation, HasPosition, HierarchyHintGenerator, Point2, Triangulation};

/// Most dots a picture gets; darker or larger pictures are stippled with this many (each dot then covers more).
pub const MAX_DOTS: usize = 200_000;

/// Stipple settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StippleOptions {
    /// Join every dot into one continuous line, routed by the path optimizer.
    pub tsp: bool,
    /// Rounds of Lloyd relaxation.
    pub iterations: u32,
}

impl Default for StippleOptions {
    fn default() -> Self {
        StippleOptions { tsp: false, iterations: 8 }
    }
}

struct Site {
    at: Point2<f64>,
    index: usize,
}

impl HasPosition for Site {
    type Scalar = f64;
    fn position(&self) -> Point2<f64> {
        self.at
    }
}

/// The number of pen dots of diameter `pen_px` (pixels) that cover as much as the map's darkness.
pub fn dot_count(map: &DarknessMap, pen_px: f64) -> usize {
    let total: f64 = map.data.iter().map(|&d| f64::from(d)).sum();
    let dot_area = std::f64::consts::PI * pen_px * pen_px / 4.0;
    if dot_area.is_nan() || dot_area <= 0.0 {
        return 0;
    }
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)] // capped at MAX_DOTS
    let n = (total / dot_area).round().min(MAX_DOTS as f64) as usize;
    n
}

/// Initial dots: the pixel centres where the running sum of darkness (in reading order) passes `(k + ½) · total / n`,
/// shifted within the pixel by how far past the quantile it lies, so no two start at the same place.
fn seed(map: &DarknessMap, n: usize) -> Vec<Point> {
    let total: f64 = map.data.iter().map(|&d| f64::from(d)).sum();
    if n == 0 || total <= 0.0 {
        return Vec::new();
    }
    #[allow(clippy::cast_precision_loss)]
    let step = total / n as f64;
    let mut out = Vec::with_capacity(n);
    let mut acc = 0.0;
    let mut next = step / 2.0;
    for (i, &d) in map.data.iter().enumerate() {
        let d = f64::from(d);
        if d <= 0.0 {
            continue;
        }
        let (x, y) = (i % map.width, i / map.width);
        while next < acc + d && out.len() < n {
            let frac = (next - acc) / d;
            #[allow(clippy::cast_precision_loss)]
            out.push(Point::new(x as f64 + 0.1 + 0.8 * frac, y as f64 + 0.5));
            next += step;
        }
        acc += d;
    }
    out
}

/// One round of Lloyd relaxation: every dot moves to the darkness-weighted centroid of its Voronoi cell.
fn relax(map: &DarknessMap, dots: &mut [Point]) {
    // A dot on top of another is merged into it by the triangulation: it gets no pixels and keeps its place.
    let sites = dots.iter().enumerate().map(|(index, p)| Site { at: Point2::new(p.x, p.y), index }).collect();
    let Ok(tri) = DelaunayTriangulation::<Site, (), (), (), HierarchyHintGenerator<f64>>::bulk_load(sites) else {
        return;
    };
    let mut sums = vec![(0.0f64, 0.0f64, 0.0f64); dots.len()];
    for y in 0..map.height {
        for x in 0..map.width {
            let d = f64::from(map.data[y * map.width + x]);
            if d <= 0.0 {
                continue;
            }
            #[allow(clippy::cast_precision_loss)]
            let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
            if let Some(v) = tri.nearest_neighbor(Point2::new(px, py)) {
                let s = &mut sums[v.data().index];
                s.0 += d * px;
                s.1 += d * py;
                s.2 += d;
            }
        }
    }
    for (p, s) in dots.iter_mut().zip(&sums) {
        if s.2 > 0.0 {
            *p = Point::new(s.0 / s.2, s.1 / s.2);
        }
    }
}

/// Stipple the darkness map: dot centres in pixel coordinates, `pen_px` being the pen's width in pixels.
pub fn stipple_dots(map: &DarknessMap, pen_px: f64, iterations: u32) -> Vec<Point> {
    let n = dot_count(map, pen_px);
    let mut dots = seed(map, n);
    for _ in 0..iterations {
        relax(map, &mut dots);
    }
    dots
}

/// The dots as strokes: each a zero-length two-point path (one touch of the pen). With `tsp` the caller joins them
/// into one line afterwards through the path optimizer ([`crate::optimize`] comes after the inputs:
/// `optimize::one_line::join_into_one_line`).
pub fn strokes(dots: &[Point]) -> Vec<Vec<Point>> {
    dots.iter().map(|&p| vec![p, p]).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::raster::ink::InkGrid;
    use crate::input::raster::tone::ToneCurve;
    use image::{GrayImage, Luma};

    fn map_of(g: &GrayImage) -> DarknessMap {
        ToneCurve::default().darkness_map(g, false)
    }

    #[test]
    fn white_gets_no_dots_and_counts_follow_darkness() {
        assert!(stipple_dots(&map_of(&GrayImage::from_pixel(40, 40, Luma([255]))), 1.0, 4).is_empty());
        // Darkness 0.5 over 100 × 100 px with a 1.5 px pen: 5000 / (π · 1.5² / 4) = 2829.4 → 2829 dots;
        // a constant map at darkness 0.25 gets half as much ink: 1414.7 → 1415.
        let half = DarknessMap { width: 100, height: 100, data: vec![0.5; 10_000] };
        let quarter = DarknessMap { width: 100, height: 100, data: vec![0.25; 10_000] };
        assert_eq!(dot_count(&half, 1.5), 2829);
        assert_eq!(dot_count(&quarter, 1.5), 1415);
        assert_eq!(stipple_dots(&quarter, 1.5, 2).len(), 1415);
    }

    #[test]
    fn a_flat_gray_stipples_to_its_darkness() {
        // Darkness 0.3 over 80 × 80 px of 0.25 mm, pen 0.5 mm (2 px): dots spread by relaxation, rendered as discs.
        let map = DarknessMap { width: 80, height: 80, data: vec![0.3; 6400] };
        let dots = stipple_dots(&map, 2.0, 10);
        assert!(dots.iter().all(|p| (0.0..=80.0).contains(&p.x) && (0.0..=80.0).contains(&p.y)));
        let mm: Vec<Vec<Point>> = strokes(&dots)
            .into_iter()
            .map(|s| s.into_iter().map(|p| Point::new(p.x * 0.25, p.y * 0.25)).collect())
            .collect();
        let mut grid = InkGrid::new(1000, 1000, 0.02);
        grid.draw(&mm, 0.5);
        let f = grid.fraction(100, 900, 100, 900);
        assert!((f - 0.3).abs() < 0.03, "ink fraction {f}");
    }
}
