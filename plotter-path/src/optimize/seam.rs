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
    /// One vertex per path, picked at random from `seed` and the path's own shape (so the same drawing and seed
    /// give the same starts): long or repeated plots then do not wear one spot of the paper with every drop.
    Random {
        /// Seed of the choice.
        seed: u64,
    },
}

/// The vertex (below `m`) [`SeamMode::Random`] starts the closed path `pts` at: SplitMix64 of the seed mixed with
/// the bits of the path's vertices.
fn random_vertex(pts: &[kurbo::Point], m: usize, seed: u64) -> usize {
    let mut h = seed;
    for p in pts {
        h = (h ^ p.x.to_bits()).rotate_left(17) ^ p.y.to_bits();
        h = h.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    }
    super::rng::SplitMix64::new(h).below(m)
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
        SeamMode::Random { seed } => out.push(u32::try_from(random_vertex(&path.points[..m], m, seed)).unwrap_or(0)),
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

    /// The same seed gives the same start on the same path, another seed (mostly) another; every start is one
    /// of the path's own vertices, so the geometry drawn is the same loop.
    #[test]
    fn random_starts_are_seeded() {
        let sq = square_with_midpoints();
        let pick = |seed: u64| {
            let mut v = Vec::new();
            seam_candidates(&sq, SeamMode::Random { seed }, &mut v);
            assert_eq!(v.len(), 1);
            assert!(v[0] < 6);
            v[0]
        };
        assert_eq!(pick(7), pick(7));
        let starts: std::collections::BTreeSet<u32> = (0..40).map(pick).collect();
        assert!(starts.len() >= 4, "40 seeds reach most of the 6 vertices: {starts:?}");
        let mut open = Vec::new();
        seam_candidates(
            &Polyline::new(vec![Point::ZERO, Point::new(1.0, 0.0)]),
            SeamMode::Random { seed: 1 },
            &mut open,
        );
        assert!(open.is_empty(), "open paths keep their ends");
    }

    /// Through the optimizer: with the same seed the drawn squares start at the same vertices; every square is the
    /// same closed loop as before (its vertices a rotation of the original's, possibly reversed).
    #[test]
    fn the_optimizer_gives_way_to_random_starts() {
        use crate::optimize::{OptimizeOptions, optimize};
        use crate::{Drawing, Polyline};
        let squares: Vec<Polyline> = (0..5)
            .map(|i| {
                let x = 20.0 * f64::from(i);
                let p = |dx: f64, dy: f64| Point::new(x + dx, dy);
                Polyline::new(vec![p(0.0, 0.0), p(10.0, 0.0), p(10.0, 10.0), p(0.0, 10.0), p(0.0, 0.0)])
            })
            .collect();
        let run = |seed: u64| {
            let mut d = Drawing::single_layer("l", squares.clone());
            let opts = OptimizeOptions { seam: SeamMode::Random { seed }, ..OptimizeOptions::default() };
            optimize(&mut d, &opts).unwrap();
            d.layers[0].paths.clone()
        };
        let (a, b) = (run(3), run(3));
        let starts = |v: &[Polyline]| v.iter().map(|p| p.points[0]).collect::<Vec<_>>();
        assert_eq!(starts(&a), starts(&b));
        let corners = |p: &Polyline| {
            let mut v = p.points[..4].to_vec();
            v.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
            v
        };
        for p in &a {
            assert!(p.is_closed() && p.points.len() == 5);
            assert!(squares.iter().any(|s| corners(s) == corners(p)), "{p:?} is one of the squares");
        }
        // Some other seed moves at least one start.
        assert!((4..40).any(|seed| starts(&run(seed)) != starts(&a)));
    }
}
