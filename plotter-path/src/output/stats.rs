//! Drawing statistics: path and segment counts, pen-down and pen-up length (in drawing order), pen lifts and the
//! bounding box — the figures `plotter stats` prints and other tools (vpype's `stat`) can be compared against —
//! and the formatting every figure shown to people goes through ([`fixed`], [`percent_above`]): no `NaN`, no
//! `inf`, no `-0.0`.

use kurbo::Rect;
use serde::Serialize;

use crate::geometry::drawing::Drawing;
use crate::geometry::travel::pen_up_length;

/// Measured figures of a drawing.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Stats {
    /// Number of layers.
    pub layers: usize,
    /// Number of polylines with at least one segment.
    pub paths: usize,
    /// Number of straight segments.
    pub segments: usize,
    /// Total pen-down length, mm.
    pub pen_down_mm: f64,
    /// Total pen-up travel between consecutive paths in drawing order, mm.
    pub pen_up_mm: f64,
    /// Times the pen is lifted: once after every path.
    pub pen_lifts: usize,
    /// Bounding box `[x0, y0, x1, y1]` in mm, absent for an empty drawing.
    pub bbox_mm: Option<[f64; 4]>,
}

impl Stats {
    /// Measure `drawing`.
    pub fn of(drawing: &Drawing) -> Stats {
        let drawn = drawing.paths().filter(|p| p.points.len() >= 2);
        let (mut paths, mut segments, mut pen_down_mm) = (0, 0, 0.0);
        for p in drawn {
            paths += 1;
            segments += p.segment_count();
            pen_down_mm += p.length();
        }
        // Sums over nothing are -0.0 (an empty f64 sum starts there); figures are shown and exported as +0.
        Stats {
            layers: drawing.layers.len(),
            paths,
            segments,
            pen_down_mm: unsigned_zero(pen_down_mm),
            pen_up_mm: unsigned_zero(pen_up_length(drawing)),
            pen_lifts: paths,
            bbox_mm: drawing.bbox().map(|Rect { x0, y0, x1, y1 }| [x0, y0, x1, y1].map(unsigned_zero)),
        }
    }
}

impl std::fmt::Display for Stats {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "layers        {}", self.layers)?;
        writeln!(f, "paths         {}", self.paths)?;
        writeln!(f, "segments      {}", self.segments)?;
        writeln!(f, "pen down      {} mm", fixed(self.pen_down_mm, 2))?;
        writeln!(f, "pen up        {} mm", fixed(self.pen_up_mm, 2))?;
        writeln!(f, "pen lifts     {}", self.pen_lifts)?;
        match self.bbox_mm {
            Some([x0, y0, x1, y1]) => write!(
                f,
                "bounding box  x {}..{} mm, y {}..{} mm ({} × {} mm)",
                fixed(x0, 2),
                fixed(x1, 2),
                fixed(y0, 2),
                fixed(y1, 2),
                fixed(x1 - x0, 2),
                fixed(y1 - y0, 2)
            ),
            None => write!(f, "bounding box  (empty)"),
        }
    }
}

/// `v` with `decimals` decimals for people: a value that rounds to zero is shown unsigned (`0.0`, never `-0.0`),
/// and a value that is not a number (NaN, an infinity) as `n/a` — a figure that cannot be computed is said so
/// instead of printed as `NaN`.
pub fn fixed(v: f64, decimals: usize) -> String {
    if !v.is_finite() {
        return "n/a".to_string();
    }
    let s = format!("{v:.decimals$}");
    match s.strip_prefix('-') {
        // Rounded to zero: only zeros and the point remain after the sign.
        Some(rest) if rest.bytes().all(|b| b == b'0' || b == b'.') => rest.to_string(),
        _ => s,
    }
}

/// How far `value` lies above `bound`, in percent, when that is a number: `None` when the bound is not positive
/// (nothing to compare with: an empty drawing, a part that takes no time) or either is not finite.
pub fn percent_above(value: f64, bound: f64) -> Option<f64> {
    (value.is_finite() && bound.is_finite() && bound > 0.0).then(|| 100.0 * (value / bound - 1.0))
}

/// `v`, with -0.0 made +0.0 (other values unchanged).
pub fn unsigned_zero(v: f64) -> f64 {
    if v == 0.0 { 0.0 } else { v }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::drawing::Polyline;
    use kurbo::Point;

    #[test]
    fn counts_lengths_and_box() {
        let d = Drawing::single_layer(
            "s",
            vec![
                Polyline::new(vec![Point::new(0.0, 0.0), Point::new(3.0, 4.0), Point::new(3.0, 10.0)]),
                Polyline::new(vec![Point::new(6.0, 14.0), Point::new(0.0, 14.0)]),
                Polyline::new(vec![Point::new(50.0, 50.0)]),
            ],
        );
        let s = Stats::of(&d);
        assert_eq!((s.paths, s.segments, s.pen_lifts, s.layers), (2, 3, 2, 1));
        assert_eq!(s.pen_down_mm, 5.0 + 6.0 + 6.0);
        assert_eq!(s.pen_up_mm, 5.0);
        assert_eq!(s.bbox_mm, Some([0.0, 0.0, 50.0, 50.0]));
        let text = s.to_string();
        assert!(text.contains("pen up        5.00 mm"), "{text}");
    }

    #[test]
    fn a_drawing_without_travel_shows_no_negative_zero() {
        // One line: no pen-up travel between paths, and an empty sum of f64 is -0.0.
        let one = Drawing::single_layer("l", vec![Polyline::new(vec![Point::new(10.0, 10.0), Point::new(50.0, 10.0)])]);
        let empty = Drawing::single_layer("e", vec![]);
        for d in [one, empty] {
            let s = Stats::of(&d);
            assert!(s.pen_up_mm.is_sign_positive() && s.pen_down_mm.is_sign_positive(), "{s:?}");
            let text = s.to_string();
            assert!(text.contains("pen up        0.00 mm") && !text.contains("-0") && !text.contains("NaN"), "{text}");
        }
    }

    #[test]
    fn figures_are_never_nan_inf_or_negative_zero() {
        assert_eq!(fixed(-0.0, 1), "0.0");
        assert_eq!(fixed(-0.04, 1), "0.0");
        assert_eq!(fixed(-0.05001, 1), "-0.1");
        assert_eq!(fixed(-12.5, 2), "-12.50");
        assert_eq!(fixed(2.4, 0), "2");
        assert_eq!(fixed(-0.3, 0), "0");
        assert_eq!(fixed(f64::NAN, 1), "n/a");
        assert_eq!(fixed(f64::INFINITY, 1), "n/a");
        assert_eq!(percent_above(0.0, 0.0), None);
        assert_eq!(percent_above(1.0, 0.0), None);
        assert_eq!(percent_above(f64::INFINITY, 2.0), None);
        assert_eq!(percent_above(3.0, 2.0), Some(50.0));
        assert_eq!(unsigned_zero(-0.0).to_bits(), 0.0f64.to_bits());
        assert_eq!(unsigned_zero(-2.0), -2.0);
    }
}
