//! The exact least pen-up cost of a small layer over every order, by dynamic programming over subsets of its
//! paths (Bellman; Held and Karp, 1962), so that on layers of a dozen paths or so the travel bound is the best
//! order itself rather than a relaxation of it.
//!
//! **The ways of drawing a path.** An open path is drawn forwards or backwards: entered at one end, left at the
//! other. A closed path is entered and left at the same seam: one way per allowed seam. When that makes too many
//! states, each closed path gets one relaxed way instead, entered at any of its seams and left at any (possibly
//! another one). The layer starts at any of a set of points (where the pen may be when the layer begins: the
//! known start, or every place the previous layer can end), or anywhere when nothing is known, its first hop then
//! costing at least `f(0)`.
//!
//! **Why it is a bound.** Let `c(dx, dy)` be the least cost of a hop of `|dx|` × `|dy|` mm, non-decreasing in
//! each, and `f(d) ≤ c` the least cost of any hop at least `d` long ([`HopCost`]). Any order of the paths, with
//! its choice of direction and seam, is one sequence of ways; each of its hops, from where one way leaves to where
//! the next is entered, costs at least its `c`. Between two single points that is exact. Between point sets (a
//! relaxed closed path, a set of starts) the hop is one of the pairs, so it costs at least both
//! `c(least |dx|, least |dy|)` and `f(least distance)` over the pairs, each least taken on its own: the larger
//! of the two is the cost used. The recursion below computes the least such sum
//! over every sequence that draws each path once: `best[S][w]`, the least cost of drawing the paths of the set `S`
//! ending with way `w` (whose path is in `S`), is the cost of reaching `w` first when `S` is `w`'s path alone,
//! else the least `best[S − path(w)][v] + hop(v, w)` over the ways `v` of the other paths. The minimum over the
//! last way of the full set is therefore at most the hops of any order: only exact sums of exact hop costs, a
//! margin for the rounding of those sums taken off.
//!
//! The work is `2ⁿ · W²` for `n` paths with `W` ways in all, so it runs only where that is small (see
//! [`MAX_WORK`]).

use kurbo::Point;

use super::hop_cost::HopCost;

/// Most paths a layer may have for the exact solve.
pub(crate) const MAX_PATHS: usize = 16;

/// Most `2ⁿ · W²` steps of the recursion (some tens of milliseconds in a release build).
pub(crate) const MAX_WORK: usize = 20_000_000;

/// Most point pairs looked at to find the least distances between ways.
const MAX_PAIRS: usize = 40_000_000;

/// One way of drawing a path: where it may be entered and where it is then left (indices into the layer's points).
#[derive(Debug, Clone, PartialEq)]
struct Way {
    path: usize,
    entry: Vec<u32>,
    exit: Vec<u32>,
}

/// A small layer made ready for the exact solve: its paths' ways, and where the layer may start.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct ExactLayer {
    points: Vec<[f64; 2]>,
    ways: Vec<Way>,
    paths: usize,
    /// How far from where each way is left to where each other way is entered (`W × W`, row = from).
    between: Vec<Apart>,
    /// How far from the start to where each way is entered; `None`: the start is unknown.
    from_start: Option<Vec<Apart>>,
}

/// How far apart two point sets are: the least `|dx|`, the least `|dy|` and the least distance over their pairs,
/// each on its own (for single points, one pair's own).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Apart {
    dx: f64,
    dy: f64,
    d: f64,
}

impl Apart {
    /// Between no sets: never a hop.
    const NEVER: Apart = Apart { dx: f64::INFINITY, dy: f64::INFINITY, d: f64::INFINITY };

    /// The least cost of a hop between the two sets (see the module docs).
    fn cost(&self, hop: &dyn HopCost) -> f64 {
        if !self.d.is_finite() {
            return f64::INFINITY;
        }
        hop.cost(self.dx, self.dy).max(hop.along(self.d))
    }
}

/// How far apart two point sets are (indices into `pts`).
fn set_apart(pts: &[[f64; 2]], a: &[u32], b: &[u32]) -> Apart {
    let mut best = Apart::NEVER;
    for &i in a {
        let p = pts[i as usize];
        for &j in b {
            let q = pts[j as usize];
            let (dx, dy) = ((p[0] - q[0]).abs(), (p[1] - q[1]).abs());
            best.dx = best.dx.min(dx);
            best.dy = best.dy.min(dy);
            best.d = best.d.min(dx * dx + dy * dy);
        }
    }
    best.d = best.d.sqrt();
    best
}

impl ExactLayer {
    /// The layer whose path `k` may be entered and left at `places[k]`: `(points, open)`, an open path's two ends
    /// or a closed path's allowed seams; the layer starts at one of `start` (`None`: anywhere). `None` when the
    /// layer is too large for the exact solve.
    pub(crate) fn new(places: &[(Vec<Point>, bool)], start: Option<&[Point]>) -> Option<ExactLayer> {
        let n = places.len();
        if n == 0 || n > MAX_PATHS || places.iter().any(|(p, _)| p.is_empty()) {
            return None;
        }
        let mut points: Vec<[f64; 2]> = Vec::new();
        let mut ranges = Vec::with_capacity(n);
        for (pts, _) in places {
            let first = u32::try_from(points.len()).ok()?;
            points.extend(pts.iter().map(|p| [p.x, p.y]));
            ranges.push(first..u32::try_from(points.len()).ok()?);
        }
        let fits = |w: usize| (1usize << n).saturating_mul(w.saturating_mul(w)) <= MAX_WORK;
        let exact_ways: usize = places.iter().map(|(p, open)| if *open { 2 } else { p.len() }).sum();
        let relax = !fits(exact_ways);
        let mut ways = Vec::new();
        for (k, ((pts, open), r)) in places.iter().zip(&ranges).enumerate() {
            if *open {
                let (a, b) = (r.start, r.end - 1);
                ways.push(Way { path: k, entry: vec![a], exit: vec![b] });
                if pts.len() > 1 {
                    ways.push(Way { path: k, entry: vec![b], exit: vec![a] });
                }
            } else if relax {
                let all: Vec<u32> = r.clone().collect();
                ways.push(Way { path: k, entry: all.clone(), exit: all });
            } else {
                ways.extend(r.clone().map(|i| Way { path: k, entry: vec![i], exit: vec![i] }));
            }
        }
        let w = ways.len();
        if !fits(w) {
            return None;
        }
        let pairs: usize =
            ways.iter().map(|x| x.exit.len()).sum::<usize>() * ways.iter().map(|x| x.entry.len()).sum::<usize>();
        if pairs > MAX_PAIRS {
            return None;
        }
        let mut between = vec![Apart::NEVER; w * w];
        for (i, a) in ways.iter().enumerate() {
            for (j, b) in ways.iter().enumerate() {
                if a.path != b.path {
                    between[i * w + j] = set_apart(&points, &a.exit, &b.entry);
                }
            }
        }
        let from_start = start.map(|s| {
            let first = points.len();
            let mut all = points.clone();
            all.extend(s.iter().map(|p| [p.x, p.y]));
            let ids: Vec<u32> = (first..all.len()).filter_map(|i| u32::try_from(i).ok()).collect();
            ways.iter().map(|x| set_apart(&all, &ids, &x.entry)).collect()
        });
        Some(ExactLayer { points, ways, paths: n, between, from_start })
    }

    /// The least cost of drawing every path of the layer once, each hop costing at least its cost under `cost`;
    /// see the module docs.
    pub(crate) fn least(&self, cost: &dyn HopCost) -> f64 {
        let (n, w) = (self.paths, self.ways.len());
        if w == 0 {
            return 0.0;
        }
        let hop: Vec<f64> = self.between.iter().map(|a| a.cost(cost)).collect();
        let full = (1usize << n) - 1;
        let mut best = vec![f64::INFINITY; (full + 1) * w];
        for (k, way) in self.ways.iter().enumerate() {
            let first = self.from_start.as_ref().map_or_else(|| cost.cost(0.0, 0.0), |s| s[k].cost(cost));
            best[(1usize << way.path) * w + k] = first;
        }
        for set in 1..=full {
            for (k, way) in self.ways.iter().enumerate() {
                let here = best[set * w + k];
                if !here.is_finite() || set & (1 << way.path) == 0 {
                    continue;
                }
                let row = &hop[k * w..(k + 1) * w];
                for (m, next) in self.ways.iter().enumerate() {
                    if set & (1 << next.path) != 0 {
                        continue;
                    }
                    let to = (set | (1 << next.path)) * w + m;
                    let c = here + row[m];
                    if c < best[to] {
                        best[to] = c;
                    }
                }
            }
        }
        let least = best[full * w..].iter().copied().fold(f64::INFINITY, f64::min);
        if !least.is_finite() {
            return 0.0;
        }
        // Rounding: each of the at most n + 1 additions may be off by half a unit in the last place of the sum.
        #[allow(clippy::cast_precision_loss, reason = "path counts are tiny")]
        let margin = 1e-12 * (n as f64 + 1.0) * least.abs();
        (least - margin).max(0.0)
    }

    /// Number of ways of drawing the paths the solve looks at (for tests: exact seams or relaxed closed paths).
    #[cfg(test)]
    fn way_count(&self) -> usize {
        let _ = &self.points;
        self.ways.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optimize::hop_cost::ByLength;

    fn p(x: f64, y: f64) -> Point {
        Point::new(x, y)
    }

    #[test]
    fn two_segments_pointing_apart_from_a_known_start() {
        // From the origin, 10 mm north and 10 mm south, inner ends 1 mm away: 1 mm in, then 12 mm back across
        // from the outer end to the other inner end (counted by hand).
        let places = vec![(vec![p(0.0, 1.0), p(0.0, 11.0)], true), (vec![p(0.0, -1.0), p(0.0, -11.0)], true)];
        let e = ExactLayer::new(&places, Some(&[Point::ZERO])).unwrap();
        assert!((e.least(&ByLength(&|d| d)) - 13.0).abs() < 1e-9);
        // Unknown start, each hop costing 1 more than its length: the first hop is f(0) = 1, then one segment is
        // drawn inwards and the hop across the 2 mm between the inner ends costs f(2) = 3.
        let free = ExactLayer::new(&places, None).unwrap();
        assert!((free.least(&ByLength(&|d| d + 1.0)) - (1.0 + 3.0)).abs() < 1e-9);
    }

    #[test]
    fn a_closed_path_is_left_where_it_was_entered() {
        // A 10 mm square with corners (0, 0) .. (10, 10), the start at (-1, 0), a dot-like segment at (11, 10)
        // to (12, 10). Entered at (0, 0) (1 mm), the square is left there and the hop to (11, 10) is √221; entered
        // at (10, 10) instead, the first hop is √(121 + 100) and the second 1 mm: both √221 + 1 = 15.866 mm. With
        // seams taken as one set (entered at (0, 0), left at (10, 10)) it would be 2 mm.
        let sq = vec![p(0.0, 0.0), p(10.0, 0.0), p(10.0, 10.0), p(0.0, 10.0)];
        let places = vec![(sq, false), (vec![p(11.0, 10.0), p(12.0, 10.0)], true)];
        let e = ExactLayer::new(&places, Some(&[p(-1.0, 0.0)])).unwrap();
        assert_eq!(e.way_count(), 4 + 2);
        let want = 221f64.sqrt() + 1.0;
        assert!((e.least(&ByLength(&|d| d)) - want).abs() < 1e-9, "{}", e.least(&ByLength(&|d| d)));
    }

    #[test]
    fn a_set_of_starts_takes_the_nearest() {
        // The layer may start at (0, 0) or (100, 0): one segment from (98, 0) to (90, 0) costs the 2 mm from
        // (100, 0).
        let places = vec![(vec![p(98.0, 0.0), p(90.0, 0.0)], true)];
        let e = ExactLayer::new(&places, Some(&[p(0.0, 0.0), p(100.0, 0.0)])).unwrap();
        assert!((e.least(&ByLength(&|d| d)) - 2.0).abs() < 1e-9);
    }

    #[test]
    fn too_many_paths_are_left_to_the_other_bounds() {
        let places: Vec<_> =
            (0..=MAX_PATHS).map(|i| (vec![p(f64::from(u32::try_from(i).unwrap()), 0.0)], false)).collect();
        assert!(ExactLayer::new(&places, None).is_none());
    }
}
