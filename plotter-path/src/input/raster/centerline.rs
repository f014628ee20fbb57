//! Centreline mode: line art to one stroke along the middle of each line.
//!
//! The ink is thinned to a one-pixel skeleton ([`skeleton`](super::skeleton)), walked into polylines split at
//! junctions, and each run is simplified. Each stroke is therefore drawn once, instead of the out-and-back outline
//! that outline mode would draw around a thin line.
//!
//! Thinning leaves short *spurs* where a thick stroke's boundary has a bump or a corner: a branch from a junction to
//! a free end that never leaves the stroke's own body. A branch is removed as a spur when its length is at most
//! 1.5 × the ink's half-width at its junction, plus one pixel; the half-width is the distance from the junction to
//! the nearest paper pixel of the original bitmap (the radius of the largest disc of ink centred there). After
//! pruning the skeleton is walked again, so the remaining strokes join through the former junction.

use super::bitmap::Bitmap;
use super::error::RasterWarning;
use super::simplify::simplify;
use super::skeleton::{Node, SkeletonPath, skeletonize, walk};
use kurbo::Point;

/// Distance from pixel `(x, y)` to the nearest background pixel centre (searching up to 64 pixels away).
fn half_width(b: &Bitmap, x: usize, y: usize) -> f64 {
    let (xi, yi) = (isize::try_from(x).unwrap_or(0), isize::try_from(y).unwrap_or(0));
    let mut best = f64::INFINITY;
    for r in 1..=64isize {
        #[allow(clippy::cast_precision_loss)] // r ≤ 64
        if (r as f64) > best {
            break;
        }
        for d in -r..=r {
            for (dx, dy) in [(d, -r), (d, r), (-r, d), (r, d)] {
                if !b.get(xi + dx, yi + dy) {
                    #[allow(clippy::cast_precision_loss)] // small offsets
                    let dist = ((dx * dx + dy * dy) as f64).sqrt();
                    best = best.min(dist);
                }
            }
        }
    }
    best.min(64.0)
}

fn pixel_length(p: &SkeletonPath) -> f64 {
    p.points.windows(2).map(|w| w[0].distance(w[1])).sum()
}

/// Open or closed centre-line polylines in pixel coordinates, plus warnings (short strokes dropped).
pub fn centerline(bitmap: &Bitmap, simplify_px: f64, min_length_px: f64) -> (Vec<Vec<Point>>, Vec<RasterWarning>) {
    let mut thin = bitmap.clone();
    skeletonize(&mut thin);
    let mut paths = walk(&thin);
    // Prune spurs once, then walk the cleaned skeleton again.
    let mut pruned = false;
    for p in &paths {
        let junction_end = match (p.start, p.end) {
            (Node::End, Node::Junction(_)) => p.pixels.last(),
            (Node::Junction(_), Node::End) => p.pixels.first(),
            _ => None,
        };
        let Some(&(jx, jy)) = junction_end else { continue };
        if pixel_length(p) <= 1.5 * half_width(bitmap, jx, jy) + 1.0 {
            for &(x, y) in &p.pixels {
                if (x, y) != (jx, jy) {
                    thin.set(x, y, false);
                }
            }
            pruned = true;
        }
    }
    if pruned {
        super::skeleton::remove_staircase(&mut thin);
        paths = walk(&thin);
    }
    simplify_long_paths(paths, simplify_px, min_length_px)
}

/// Simplify every walked path at least `min_length_px` long; the shorter ones are dropped and counted in a warning.
pub(crate) fn simplify_long_paths(
    paths: Vec<SkeletonPath>,
    simplify_px: f64,
    min_length_px: f64,
) -> (Vec<Vec<Point>>, Vec<RasterWarning>) {
    let mut dropped = 0;
    let mut out = Vec::new();
    for p in paths {
        if pixel_length(&p) < min_length_px {
            dropped += 1;
            continue;
        }
        out.push(simplify(&p.points, simplify_px));
    }
    let warnings =
        if dropped > 0 { vec![RasterWarning::ShortPathsDropped { count: dropped, min_length_px }] } else { vec![] };
    (out, warnings)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::raster::simplify::point_segment_distance;
    use crate::input::raster::synth::{self, Stroke};
    use std::f64::consts::PI;

    fn dist_to_paths(p: Point, paths: &[Vec<Point>]) -> f64 {
        paths
            .iter()
            .flat_map(|pl| pl.windows(2).map(move |w| point_segment_distance(p, w[0], w[1])))
            .fold(f64::INFINITY, f64::min)
    }

    fn check_strokes(strokes: &[Stroke], width: usize, height: usize, expect_paths: usize) {
        let b = synth::stroke_bitmap(width, height, strokes, 5.0);
        let (paths, _) = centerline(&b, 0.5, 3.0);
        assert_eq!(paths.len(), expect_paths, "each stroke once: {paths:?}");
        // Every point of the result (densely sampled) lies within 1.5 px of a true centre line...
        for pl in &paths {
            for s in (Stroke { points: pl.clone() }).samples(0.5) {
                let d = strokes.iter().map(|st| st.distance(s)).fold(f64::INFINITY, f64::min);
                assert!(d <= 1.5, "result point {s:?} is {d:.2} px from every true centre line");
            }
        }
        // ...and every true centre-line point away from the free ends within 1.5 px of the result.
        for st in strokes {
            for s in st.samples(1.0) {
                let d = dist_to_paths(s, &paths);
                let near_end = s.distance(st.points[0]).min(s.distance(*st.points.last().unwrap())) < 3.0;
                assert!(d <= 1.5 || near_end, "true point {s:?} is {d:.2} px from the result");
            }
        }
        let traced: f64 = paths.iter().map(|pl| pl.windows(2).map(|w| w[0].distance(w[1])).sum::<f64>()).sum();
        let truth: f64 = strokes.iter().map(Stroke::length).sum();
        assert!((traced - truth).abs() <= 0.05 * truth, "length {traced:.1} vs true {truth:.1}");
    }

    #[test]
    fn lines_and_arcs_are_traced_once_along_their_centres() {
        let strokes = vec![
            Stroke::line((20.0, 20.0), (280.0, 45.0)),
            Stroke::line((30.0, 80.0), (110.0, 260.0)),
            Stroke::line((150.0, 280.0), (290.0, 280.0)),
            Stroke::line((160.0, 100.0), (160.0, 200.0)),
            Stroke::arc((230.0, 160.0), (50.0, 50.0), -0.4 * PI, 1.3 * PI),
            Stroke::arc((100.0, 120.0), (25.0, 40.0), 0.3, 2.2),
        ];
        check_strokes(&strokes, 310, 300, strokes.len());
    }

    #[test]
    fn full_circle_is_one_closed_stroke() {
        let strokes = vec![Stroke::arc((60.0, 60.0), (40.0, 40.0), 0.0, 2.0 * PI)];
        let b = synth::stroke_bitmap(120, 120, &strokes, 5.0);
        let (paths, _) = centerline(&b, 0.5, 3.0);
        assert_eq!(paths.len(), 1);
        assert_eq!(paths[0].first(), paths[0].last());
        check_strokes(&strokes, 120, 120, 1);
    }

    #[test]
    fn crossing_lines_meet_at_one_junction() {
        let strokes = vec![Stroke::line((10.0, 10.0), (110.0, 110.0)), Stroke::line((10.0, 110.0), (110.0, 10.0))];
        // Four arms from the crossing.
        check_strokes(&strokes, 120, 120, 4);
    }

    #[test]
    fn tiny_blobs_are_dropped_and_reported() {
        let mut b = synth::stroke_bitmap(100, 40, &[Stroke::line((10.0, 20.0), (90.0, 20.0))], 5.0);
        b.set(2, 2, true);
        let (paths, warnings) = centerline(&b, 0.5, 3.0);
        assert_eq!(paths.len(), 1);
        assert_eq!(warnings, vec![RasterWarning::ShortPathsDropped { count: 1, min_length_px: 3.0 }]);
    }
}
