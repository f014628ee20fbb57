//! Seam choice for closed paths: a closed path can be drawn starting at any of its vertices (the "seam", where the
//! pen drops and lifts again), and that choice changes the travel to and from it.

use crate::Polyline;

/// Where a closed path may start.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SeamMode {
    /// Keep the path's own first vertex.
    Keep,
    /// Any vertex.
    Any,
    /// Only vertices where the outline turns by at least `min_turn_deg` degrees, where the small blot of ink a pen
    /// leaves on dropping is least visible. A path without such a corner may start anywhere.
    Corners {
        /// Minimum direction change at the vertex, degrees (0–180).
        min_turn_deg: f64,
    },
}

/// Append to `out` the vertex indices where the closed path `path` may start under `mode` (its duplicate closing
/// vertex is never listed). For open paths nothing is appended.
pub(crate) fn seam_candidates(path: &Polyline, mode: SeamMode, out: &mut Vec<u32>) {
    if !path.is_closed() {
        return;
    }
    let m = path.points.len() - 1;
    let Ok(m32) = u32::try_from(m) else { return };
    match mode {
        SeamMode::Keep => out.push(0),
        SeamMode::Any => out.extend(0..m32),
        SeamMode::Corners { min_turn_deg } => {
            let cos_limit = min_turn_deg.clamp(0.0, 180.0).to_radians().cos();
            let before = out.len();
            let pts = &path.points[..m];
            for i in 0..m {
                let prev = pts[(i + m - 1) % m];
                let next = pts[(i + 1) % m];
                let a = pts[i] - prev;
                let b = next - pts[i];
                let (la, lb) = (a.hypot(), b.hypot());
                if la > 0.0 && lb > 0.0 && a.dot(b) / (la * lb) <= cos_limit {
                    out.push(u32::try_from(i).unwrap_or(0));
                }
            }
            if out.len() == before {
                out.extend(0..m32);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use kurbo::Point;

    fn square_with_midpoints() -> Polyline {
        let p = |x: f64, y: f64| Point::new(x, y);
        Polyline::new(vec![
            p(0.0, 0.0),
            p(5.0, 0.0),
            p(10.0, 0.0),
            p(10.0, 10.0),
            p(5.0, 10.0),
            p(0.0, 10.0),
            p(0.0, 0.0),
        ])
    }

    #[test]
    fn candidates_per_mode() {
        let sq = square_with_midpoints();
        let mut v = Vec::new();
        seam_candidates(&sq, SeamMode::Keep, &mut v);
        assert_eq!(v, [0]);
        v.clear();
        seam_candidates(&sq, SeamMode::Any, &mut v);
        assert_eq!(v, [0, 1, 2, 3, 4, 5]);
        v.clear();
        seam_candidates(&sq, SeamMode::Corners { min_turn_deg: 60.0 }, &mut v);
        assert_eq!(v, [0, 2, 3, 5]);
        // No vertex turns by 120°: every vertex qualifies.
        v.clear();
        seam_candidates(&sq, SeamMode::Corners { min_turn_deg: 120.0 }, &mut v);
        assert_eq!(v.len(), 6);
        v.clear();
        seam_candidates(&Polyline::new(vec![Point::ZERO, Point::new(1.0, 0.0)]), SeamMode::Any, &mut v);
        assert!(v.is_empty());
    }
}
