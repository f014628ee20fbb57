//! Outline mode: the boundaries of the ink regions, holes included, simplified, specks dropped.
//!
//! Boundaries come from [`trace_contours`] (marching squares through the midpoints between differing pixel
//! centres), so an even-odd fill of the result reproduces the thresholded bitmap up to the simplification
//! tolerance. Loops enclosing less than the minimum area are dropped and counted: a small outer loop is a speck of
//! ink, a small hole loop a speck of paper inside ink (dropping it fills the pinhole). A hole is always smaller than
//! the loop around it, so dropping a speck never leaves its holes behind.

use super::bitmap::Bitmap;
use super::contour::trace_contours;
use super::error::RasterWarning;
use super::simplify::simplify;
use kurbo::Point;

/// Closed boundary polylines (pixel coordinates, first point repeated at the end) and the warnings.
pub fn outline(bitmap: &Bitmap, simplify_px: f64, min_area_px: f64) -> (Vec<Vec<Point>>, Vec<RasterWarning>) {
    let mut dropped = 0;
    let mut paths = Vec::new();
    for c in trace_contours(bitmap) {
        if c.signed_area.abs() < min_area_px {
            dropped += 1;
            continue;
        }
        paths.push(simplify(&c.closed_points(), simplify_px));
    }
    let warnings =
        if dropped > 0 { vec![RasterWarning::SpecksDropped { count: dropped, min_area_px }] } else { vec![] };
    (paths, warnings)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::raster::{TraceOptions, synth};

    #[test]
    fn ring_gives_two_loops_and_specks_are_counted() {
        let mut b = synth::ring(80, 80, (40.0, 40.0), 15.0, 30.0);
        b.set(2, 2, true);
        b.set(40, 40, true); // a speck inside the hole
        let (paths, warnings) = outline(&b, 0.5, 4.0);
        assert_eq!(paths.len(), 2);
        assert!(paths.iter().all(|p| p.first() == p.last() && p.len() >= 4));
        assert_eq!(warnings, vec![RasterWarning::SpecksDropped { count: 2, min_area_px: 4.0 }]);
        // Simplification keeps far fewer vertices than boundary crossings.
        let n: usize = paths.iter().map(Vec::len).sum();
        assert!(n < 200, "{n} vertices");
    }

    #[test]
    fn fidelity_iou_on_generated_shapes() {
        for (name, b) in synth::fidelity_shapes() {
            let (paths, _) = outline(&b, TraceOptions::default().simplify_px, 0.0);
            let iou = synth::iou_even_odd(&b, &paths);
            assert!(iou >= 0.98, "{name}: IoU {iou}");
            // Without simplification the fill reproduces the bitmap exactly.
            let (exact, _) = outline(&b, 0.0, 0.0);
            assert_eq!(synth::iou_even_odd(&b, &exact), 1.0, "{name}");
        }
    }
}
