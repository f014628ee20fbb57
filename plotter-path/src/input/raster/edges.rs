//! Edges mode: Canny edges (imageproc) chained into polylines.
//!
//! Canny (1986): Gaussian smoothing (σ = 1.4 in imageproc), Sobel gradients, non-maximum suppression along the
//! gradient direction, hysteresis between a low and a high magnitude threshold. The edge map is thinned and walked
//! exactly like a centreline skeleton ([`skeleton`](super::skeleton)), so chains split at junctions and each edge
//! pixel is drawn once. Chains shorter than the minimum length (texture noise) are dropped and counted.

use super::bitmap::Bitmap;
use super::centerline::simplify_long_paths;
use super::error::RasterWarning;
use super::skeleton::{skeletonize, walk};
use image::GrayImage;
use kurbo::Point;

/// The Canny edge map of `gray` as a bitmap (`canny_low ≤ canny_high`; images smaller than 3×3 have no edges).
pub fn edge_map(gray: &GrayImage, canny_low: f32, canny_high: f32) -> Bitmap {
    let (w, h) = (gray.width() as usize, gray.height() as usize);
    if w < 3 || h < 3 {
        return Bitmap::new(w, h);
    }
    let e = imageproc::edges::canny(gray, canny_low, canny_high.max(canny_low));
    let raw = e.as_raw();
    Bitmap::from_fn(w, h, |x, y| raw[y * w + x] != 0)
}

/// Edge chains in pixel coordinates, plus warnings.
pub fn edges(
    gray: &GrayImage,
    canny_low: f32,
    canny_high: f32,
    simplify_px: f64,
    min_length_px: f64,
) -> (Vec<Vec<Point>>, Vec<RasterWarning>) {
    let mut map = edge_map(gray, canny_low, canny_high);
    skeletonize(&mut map);
    simplify_long_paths(walk(&map), simplify_px, min_length_px)
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::Luma;

    #[test]
    fn square_edge_is_one_loop_on_the_boundary() {
        let g = GrayImage::from_fn(80, 80, |x, y| {
            Luma([if (20..60).contains(&x) && (20..60).contains(&y) { 30 } else { 220 }])
        });
        let (paths, _) = edges(&g, 40.0, 100.0, 0.5, 3.0);
        assert_eq!(paths.len(), 1, "{paths:?}");
        let p = &paths[0];
        assert_eq!(p.first(), p.last());
        // Every vertex within 1.5 px of the square's boundary (x or y = 20 or 60).
        for q in p {
            let d = [(q.x - 20.0).abs(), (q.x - 60.0).abs(), (q.y - 20.0).abs(), (q.y - 60.0).abs()]
                .into_iter()
                .fold(f64::INFINITY, f64::min);
            assert!(d <= 1.5, "{q:?}");
        }
        let len: f64 = p.windows(2).map(|w| w[0].distance(w[1])).sum();
        assert!((len - 160.0).abs() < 12.0, "{len}");
    }

    #[test]
    fn flat_image_has_no_edges_and_tiny_images_are_safe() {
        let g = GrayImage::from_pixel(50, 50, Luma([128]));
        assert!(edges(&g, 40.0, 100.0, 0.5, 3.0).0.is_empty());
        let g = GrayImage::from_pixel(2, 1, Luma([0]));
        assert!(edge_map(&g, 1.0, 2.0).is_empty());
    }
}
