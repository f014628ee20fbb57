//! Size limits for any drawing, so that no input — however absurd its numbers — can make the pipeline run without
//! bound in time or memory.
//!
//! The limits derive from the machines this project drives: the largest sheet in common use is A0 (1189 mm on its
//! long side); a coordinate a thousand times beyond that ([`MAX_COORD_MM`], 1 km) is no drawing any plotter can
//! draw, even before `--fit` shrinks it onto a page, and keeps every computation on it far from f32/f64 trouble
//! (1 km at the default 0.05 mm tolerance needs at most a few thousand chords per curve). A drawing holds at most
//! [`MAX_POINTS`] points (2²², as many as a generated figure may have): four times the densest real inputs (a
//! hatched A3 photo is about a million points), and small enough that every later stage — ordering, the motion
//! plan with its step blocks and wire frames, about 150 bytes per point in all — stays well below a gigabyte.
//! Pen widths only matter to previews; they are clamped there.
//!
//! Importers check what they can where they read it (naming the line); [`check_drawing`] is the final gate every
//! loaded drawing passes, naming the layer, path and point.

use kurbo::Point;

use crate::Drawing;

/// Largest coordinate magnitude accepted anywhere, mm (see the module docs).
pub const MAX_COORD_MM: f64 = 1.0e6;

/// Most points one drawing may hold.
pub const MAX_POINTS: usize = 1 << 22;

/// Why a drawing is refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LimitError {
    /// A point is not a finite number or lies beyond ±[`MAX_COORD_MM`].
    #[error(
        "{origin}: layer {layer:?}, path {path}, point {point}: coordinate ({x}, {y}) mm is beyond ±{MAX_COORD_MM} mm \
         (1 km); no plotter draws that — check the units or the scale"
    )]
    Coordinate {
        /// The input's name.
        origin: String,
        /// Layer name.
        layer: String,
        /// Path index within the layer (0-based).
        path: usize,
        /// Point index within the path (0-based).
        point: usize,
        /// The offending x.
        x: f64,
        /// The offending y.
        y: f64,
    },
    /// Too many points in all.
    #[error("{origin}: more than {MAX_POINTS} points in the drawing (the limit that keeps memory bounded)")]
    TooManyPoints {
        /// The input's name.
        origin: String,
    },
}

/// Whether `p` is finite and within ±[`MAX_COORD_MM`] on both axes.
pub fn point_ok(p: Point) -> bool {
    p.x.abs() <= MAX_COORD_MM && p.y.abs() <= MAX_COORD_MM
}

/// Check every point of `drawing` (named `origin` in the error) against the limits.
pub fn check_drawing(drawing: &Drawing, origin: &str) -> Result<(), LimitError> {
    check_with(drawing, origin, MAX_POINTS)
}

fn check_with(drawing: &Drawing, origin: &str, max_points: usize) -> Result<(), LimitError> {
    let mut total = 0usize;
    for layer in &drawing.layers {
        for (pi, path) in layer.paths.iter().enumerate() {
            total = total.saturating_add(path.points.len());
            if total > max_points {
                return Err(LimitError::TooManyPoints { origin: origin.to_string() });
            }
            if let Some((i, p)) = path.points.iter().enumerate().find(|(_, p)| !point_ok(**p)) {
                return Err(LimitError::Coordinate {
                    origin: origin.to_string(),
                    layer: layer.name.clone(),
                    path: pi,
                    point: i,
                    x: p.x,
                    y: p.y,
                });
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Polyline;

    #[test]
    fn coordinates_and_counts_are_checked() {
        let ok = Drawing::single_layer("a", vec![Polyline::new(vec![Point::new(0.0, 0.0), Point::new(1e6, -1e6)])]);
        assert_eq!(check_drawing(&ok, "x.svg"), Ok(()));
        for bad in [1.000_001e6, f64::NAN, f64::INFINITY, -3.4e38] {
            let d = Drawing::single_layer(
                "ink",
                vec![
                    Polyline::new(vec![Point::ZERO, Point::ZERO]),
                    Polyline::new(vec![Point::ZERO, Point::new(5.0, bad)]),
                ],
            );
            let e = check_drawing(&d, "x.svg").unwrap_err();
            assert!(matches!(e, LimitError::Coordinate { path: 1, point: 1, .. }), "{e:?}");
            assert!(e.to_string().starts_with("x.svg: layer \"ink\", path 1, point 1: coordinate (5, "), "{e}");
        }
        let many = Drawing::single_layer("a", vec![Polyline::new(vec![Point::ZERO; 501]); 2]);
        assert_eq!(check_with(&many, "m", 1002), Ok(()));
        assert!(matches!(check_with(&many, "m", 1001), Err(LimitError::TooManyPoints { .. })));
    }
}
