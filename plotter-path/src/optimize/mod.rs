//! Path optimization: draw the same strokes with as little pen-up travel as possible.
//!
//! Per layer (layers keep their order; each layer starts where the previous one ended, the first at `start` when
//! one is given — otherwise the hop to the first path is free, the convention of [`crate::geometry::travel`] and `plotter
//! stats`):
//!
//! 1. **Merge** ([`merge`](self) step) — open paths whose ends meet within a tolerance are joined, in either
//!    direction, so the pen does not lift at the joint;
//! 2. **Order** — greedy nearest neighbour over every place a path can be entered: either end of an open path
//!    (entering at the end draws it reversed) and, for closed paths, any allowed seam vertex;
//! 3. **Improve** — 2-opt and Or-opt moves with reversal, seam re-choice and seeded kicks on neighbour lists,
//!    within a work budget (candidate moves evaluated, in proportion to the paths: never a clock, so the same
//!    input gives the same order however loaded the machine is);
//! 4. **Bound** — a lower bound on the travel of any order, so the report can state the worst-case gap.
//!
//! The cost minimized is pen-up distance or pen-up time ([`CostModel`]). Every step can be switched off. The
//! result draws each input path exactly once (possibly reversed, closed paths possibly starting at another vertex),
//! so the pen-down geometry is unchanged — except that merging within a tolerance bridges the joined gaps (each at
//! most the tolerance) with pen-down segments. Improvement never makes a layer worse than its greedy order, and a
//! layer is left in its input order if that is cheaper than anything found.
//!
//! ```
//! use plotter_path::optimize::{optimize, OptimizeOptions};
//! use plotter_path::{Drawing, Polyline};
//! use kurbo::Point;
//!
//! let seg = |a: f64, b: f64| Polyline::new(vec![Point::new(a, 0.0), Point::new(b, 0.0)]);
//! let mut d = Drawing::single_layer("l", vec![seg(30.0, 40.0), seg(10.0, 0.0), seg(20.0, 15.0)]);
//! let report = optimize(&mut d, &OptimizeOptions::default()).unwrap();
//! assert!(report.pen_up_after_mm < report.pen_up_before_mm);
//! assert!(report.pen_up_lower_bound_mm.unwrap() <= report.pen_up_after_mm);
//! ```

mod boruvka;
pub mod bound;
pub mod cost;
mod exact;
mod held_karp;
pub mod hop_cost;
mod improve;
mod kdtree;
mod merge;
pub mod one_line;
mod order;
mod rng;
pub mod seam;
pub mod synth;
pub mod travel;

use std::time::{Duration, Instant};

use kurbo::Point;

pub use bound::TravelBound;
pub use cost::{CostModel, TravelTimeModel};
pub use improve::ImproveStats;
pub use seam::SeamMode;
pub use travel::drawing_travel;

use crate::geometry::parallel;
use crate::{Drawing, Polyline};

/// Default improvement budget: candidate moves evaluated per path (see [`OptimizeOptions::work_per_path`]).
pub const DEFAULT_WORK_PER_PATH: f64 = 4000.0;

/// Layers with at least this many paths compute their lower bound on a second thread during the improvement.
const PARALLEL_BOUND_MIN_PATHS: usize = 500;

/// How one path is drawn: which path, in which direction, and (closed paths) from which vertex.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Visit {
    /// Index of the path in its layer.
    pub(crate) path: u32,
    /// Drawn backwards.
    pub(crate) reversed: bool,
    /// Start vertex of a closed path (0 for open paths).
    pub(crate) seam: u32,
}

impl Visit {
    /// Where the pen goes down.
    pub(crate) fn entry(&self, paths: &[Polyline]) -> Point {
        let pts = &paths[self.path as usize].points;
        if paths[self.path as usize].is_closed() {
            pts[self.seam as usize]
        } else if self.reversed {
            pts[pts.len() - 1]
        } else {
            pts[0]
        }
    }

    /// Where the pen comes up.
    pub(crate) fn exit(&self, paths: &[Polyline]) -> Point {
        let pts = &paths[self.path as usize].points;
        if paths[self.path as usize].is_closed() {
            pts[self.seam as usize]
        } else if self.reversed {
            pts[0]
        } else {
            pts[pts.len() - 1]
        }
    }

    /// The path as drawn: reversed and/or rotated to its seam.
    fn realize(&self, path: Polyline) -> Polyline {
        let mut pts = path.points;
        if path_is_closed(&pts) {
            pts.pop();
            pts.rotate_left(self.seam as usize);
            pts.push(pts[0]);
        }
        if self.reversed {
            pts.reverse();
        }
        Polyline { points: pts, pen: path.pen }
    }
}

fn path_is_closed(pts: &[Point]) -> bool {
    pts.len() > 2 && pts.first() == pts.last()
}

/// Which cost the improvement step minimizes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Objective {
    /// Pen-up distance.
    #[default]
    Distance,
    /// Pen-up time from [`OptimizeOptions::time_model`].
    Time,
}

/// Switches and knobs of [`optimize`].
#[derive(Debug, Clone, PartialEq)]
pub struct OptimizeOptions {
    /// Join open paths whose ends meet.
    pub merge: bool,
    /// Largest gap (mm) merging bridges with a pen-down segment; 0 joins only exactly coinciding ends.
    pub merge_tolerance_mm: f64,
    /// Reorder paths greedily (nearest neighbour). Off: keep the input order as the starting point.
    pub reorder: bool,
    /// Open and closed paths may be drawn backwards.
    pub reverse: bool,
    /// Where closed paths may start.
    pub seam: SeamMode,
    /// Run 2-opt / Or-opt improvement after ordering.
    pub improve: bool,
    /// Work budget of the improvement over the whole drawing, per path: the search stops once it has evaluated
    /// this many candidate moves per (merged, drawn) path in all, even if not converged. `None` runs to
    /// convergence. Either way the result depends only on the input, the options and the seed — not on time.
    pub work_per_path: Option<f64>,
    /// Seed of the improvement's randomness.
    pub seed: u64,
    /// Random kicks after the first local optimum, per path (iterated local search; 0 disables).
    pub kicks_per_path: f64,
    /// Neighbour-list length per path end.
    pub neighbours: usize,
    /// Longest cycle reversal (in paths) a move may use; `None` picks `max(1000, 50·√n)`.
    pub max_reversal: Option<usize>,
    /// What to minimize.
    pub objective: Objective,
    /// Travel timing, for the time objective and for time figures in the report.
    pub time_model: Option<TravelTimeModel>,
    /// Compute the lower bound.
    pub lower_bound: bool,
    /// Pen position before the first layer (page mm); `None`: unknown, the hop to the first path is not counted.
    pub start: Option<Point>,
    /// The plot ends with the pen back at `start` (needs `start`): the order is chosen with that last hop counted,
    /// and the report's pen-up figures include it.
    pub return_home: bool,
    /// After ordering, a pen-up hop shorter than this (mm) between consecutive paths of a layer is drawn with the
    /// pen down, joining the two paths (0 = never): a pen a little wider than the gap covers it anyway, and each
    /// saved lift is two Z moves and two settle dwells.
    pub bridge_mm: f64,
}

impl Default for OptimizeOptions {
    fn default() -> Self {
        OptimizeOptions {
            merge: true,
            merge_tolerance_mm: 0.01,
            reorder: true,
            reverse: true,
            seam: SeamMode::Any,
            improve: true,
            work_per_path: Some(DEFAULT_WORK_PER_PATH),
            seed: 1,
            kicks_per_path: 2.0,
            neighbours: 8,
            max_reversal: None,
            objective: Objective::Distance,
            time_model: None,
            lower_bound: true,
            start: None,
            return_home: false,
            bridge_mm: 0.0,
        }
    }
}

/// Invalid input to [`optimize`].
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum OptimizeError {
    /// A vertex has a NaN or infinite coordinate.
    #[error("layer {layer} (\"{name}\"), path {path}, point {point}: coordinate is not a finite number")]
    NonFinite {
        /// Layer index.
        layer: usize,
        /// Layer name.
        name: String,
        /// Path index within the layer.
        path: usize,
        /// Vertex index within the path.
        point: usize,
    },
    /// An option is out of range.
    #[error("optimize option {option}: {problem}")]
    InvalidOption {
        /// Option name.
        option: &'static str,
        /// What is wrong.
        problem: &'static str,
    },
}

/// What optimization did to one layer. Distances in mm, times in s.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LayerReport {
    /// Layer name.
    pub name: String,
    /// Paths before.
    pub paths_in: usize,
    /// Paths after (fewer when merged).
    pub paths_out: usize,
    /// Joints made by merging.
    pub joins: usize,
    /// Chains merging closed.
    pub closed_by_merge: usize,
    /// Pen-up distance in the input order.
    pub pen_up_before_mm: f64,
    /// Pen-up distance of the greedy order (when reordering).
    pub pen_up_greedy_mm: Option<f64>,
    /// Pen-up distance of the result.
    pub pen_up_after_mm: f64,
    /// Lower bound on the pen-up distance of any order of this layer's (merged) paths.
    pub pen_up_lower_bound_mm: Option<f64>,
    /// Pen-up time in the input order.
    pub travel_time_before_s: Option<f64>,
    /// Pen-up time of the result.
    pub travel_time_after_s: Option<f64>,
    /// Lower bound on the pen-up time.
    pub travel_time_lower_bound_s: Option<f64>,
    /// The input order was cheaper than the optimized one and was kept.
    pub kept_input_order: bool,
    /// Improvement counters.
    pub improve: ImproveStats,
    /// Pen-up hops drawn through with the pen down ([`OptimizeOptions::bridge_mm`]).
    pub bridges: usize,
}

/// What [`optimize`] did, per layer and in total. Distances in mm, times in s (travel only: hops plus lifts).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct OptimizeReport {
    /// Per-layer figures.
    pub layers: Vec<LayerReport>,
    /// Pen-up distance in the input order.
    pub pen_up_before_mm: f64,
    /// Pen-up distance of the greedy order (when reordering).
    pub pen_up_greedy_mm: Option<f64>,
    /// Pen-up distance of the result.
    pub pen_up_after_mm: f64,
    /// Lower bound on the pen-up distance (sum of the layer bounds).
    pub pen_up_lower_bound_mm: Option<f64>,
    /// Pen-up time in the input order (with a time model).
    pub travel_time_before_s: Option<f64>,
    /// Pen-up time of the result (with a time model).
    pub travel_time_after_s: Option<f64>,
    /// Lower bound on the pen-up time (with a time model and the bound on).
    pub travel_time_lower_bound_s: Option<f64>,
    /// Improvement counters over all layers.
    pub improve: ImproveStats,
    /// Over several layers the plain greedy chain came out cheaper than the improved one (improving a layer moved
    /// its end point to the next layer's disadvantage) and was used instead.
    pub fell_back_to_greedy: bool,
    /// Over the whole drawing the input order was cheaper than the optimized one and was kept.
    pub kept_input_order: bool,
    /// Pen-up hops drawn through with the pen down ([`OptimizeOptions::bridge_mm`]).
    pub bridges: usize,
    /// Paths (pen lifts) after optimization.
    pub paths_out: usize,
    /// Wall time spent.
    pub elapsed: Duration,
}

impl OptimizeReport {
    /// Result travel over the lower bound (≥ 1; how far from optimal the result is at most).
    pub fn gap(&self) -> Option<f64> {
        let lb = self.pen_up_lower_bound_mm?;
        (lb > 0.0).then(|| self.pen_up_after_mm / lb)
    }
}

fn check(drawing: &Drawing, opts: &OptimizeOptions) -> Result<(), OptimizeError> {
    let bad = |option, problem| Err(OptimizeError::InvalidOption { option, problem });
    if !(opts.merge_tolerance_mm.is_finite() && opts.merge_tolerance_mm >= 0.0) {
        return bad("merge_tolerance_mm", "must be a finite number ≥ 0");
    }
    if !(opts.bridge_mm.is_finite() && opts.bridge_mm >= 0.0) {
        return bad("bridge_mm", "must be a finite number ≥ 0");
    }
    if opts.return_home && opts.start.is_none() {
        return bad("return_home", "needs a start position");
    }
    if opts.work_per_path.is_some_and(|w| !(w.is_finite() && w >= 0.0)) {
        return bad("work_per_path", "must be a finite number ≥ 0");
    }
    if !(opts.kicks_per_path.is_finite() && opts.kicks_per_path >= 0.0) {
        return bad("kicks_per_path", "must be a finite number ≥ 0");
    }
    if opts.neighbours == 0 {
        return bad("neighbours", "must be at least 1");
    }
    if opts.objective == Objective::Time && opts.time_model.is_none() {
        return bad("objective", "the time objective needs a time model (a machine profile)");
    }
    if let SeamMode::Corners { min_turn_deg } = opts.seam
        && !(0.0..=180.0).contains(&min_turn_deg)
    {
        return bad("seam", "corner angle must be between 0 and 180 degrees");
    }
    if let Some(s) = opts.start
        && !(s.x.is_finite() && s.y.is_finite())
    {
        return bad("start", "must be a finite point");
    }
    for (li, layer) in drawing.layers.iter().enumerate() {
        for (pi, path) in layer.paths.iter().enumerate() {
            if let Some(k) = path.points.iter().position(|p| !(p.x.is_finite() && p.y.is_finite())) {
                return Err(OptimizeError::NonFinite { layer: li, name: layer.name.clone(), path: pi, point: k });
            }
        }
    }
    if drawing.layers.iter().any(|l| u32::try_from(l.paths.len().saturating_mul(2).saturating_add(4)).is_err()) {
        return bad("drawing", "a layer has too many paths (limit 2³¹)");
    }
    Ok(())
}

fn visits_cost(paths: &[Polyline], visits: &[Visit], start: Option<Point>, cost: &CostModel) -> f64 {
    visits_cost_to(paths, visits, start, None, cost)
}

/// [`visits_cost`] plus the hop from the last exit to `end` when given.
fn visits_cost_to(
    paths: &[Polyline],
    visits: &[Visit],
    start: Option<Point>,
    end: Option<Point>,
    cost: &CostModel,
) -> f64 {
    let mut at = start;
    let mut total = 0.0;
    for v in visits {
        if let Some(from) = at {
            total += cost.cost(from, v.entry(paths));
        }
        at = Some(v.exit(paths));
    }
    if let (Some(from), Some(to)) = (at, end) {
        total += cost.cost(from, to);
    }
    total
}

fn add_opt(acc: &mut Option<f64>, v: Option<f64>) {
    if let Some(v) = v {
        *acc = Some(acc.unwrap_or(0.0) + v);
    }
}

/// Where the paths `ids` of one layer can be entered and left (both ends of open paths, allowed seams of closed
/// ones), each point tagged with its path's place in `ids`, and whether each path is open.
fn layer_places(paths: &[Polyline], ids: &[u32], seam: SeamMode) -> (Vec<Point>, Vec<u32>, Vec<bool>) {
    let mut pts = Vec::with_capacity(2 * ids.len());
    let mut grp = Vec::with_capacity(2 * ids.len());
    let mut seams = Vec::new();
    let mut both_ends = Vec::with_capacity(ids.len());
    for (g, &id) in ids.iter().enumerate() {
        let path = &paths[id as usize];
        let g = u32::try_from(g).unwrap_or(u32::MAX);
        if path.is_closed() {
            seams.clear();
            seam::seam_candidates(path, seam, &mut seams);
            pts.extend(seams.iter().map(|&v| path.points[v as usize]));
            grp.extend(std::iter::repeat_n(g, seams.len()));
            both_ends.push(false);
        } else {
            both_ends.push(true);
            pts.extend([path.points[0], path.points[path.points.len() - 1]]);
            grp.extend([g, g]);
        }
    }
    (pts, grp, both_ends)
}

/// Bound material for the paths `ids` of one layer (see [`layer_places`]), starting at one of `start` (empty:
/// anywhere).
fn layer_bound_parts(paths: &[Polyline], ids: &[u32], seam: SeamMode, start: &[Point]) -> bound::BoundParts {
    let (pts, grp, both_ends) = layer_places(paths, ids, seam);
    bound::bound_parts(&pts, &grp, ids.len(), &both_ends, start)
}

/// Lower bound on the pen-up cost of drawing `drawing`'s paths as they stand (no merging) in any order, with
/// reversal and the given seam freedom, layer by layer from `start` (see [`bound`]). Returns `(distance mm,
/// time s)`, the time only with a model.
pub fn travel_lower_bound(
    drawing: &Drawing,
    seam: SeamMode,
    start: Option<Point>,
    time_model: Option<&TravelTimeModel>,
) -> (f64, Option<f64>) {
    let mut dist = 0.0;
    let mut time = time_model.map(|_| 0.0);
    for parts in drawing_bound_parts(drawing, seam, start) {
        dist += parts.under(&CostModel::Distance).value();
        if let (Some(t), Some(m)) = (time.as_mut(), time_model) {
            *t += parts.under(&CostModel::Time(*m)).value();
        }
    }
    (dist, time)
}

/// Lower bound on the pen-up cost of `drawing` (as [`travel_lower_bound`], and tightened by the Held–Karp bound on
/// the paths' ends, see [`bound`]) when a hop of length `d` costs at least `min_hop(d)`; `min_hop` must be
/// non-decreasing and ≥ 0. Lets the plot-time bound charge every hop its own acceleration-limited time instead of
/// dividing the summed length by the feed.
pub fn travel_lower_bound_mapped(
    drawing: &Drawing,
    seam: SeamMode,
    start: Option<Point>,
    min_hop: &dyn Fn(f64) -> f64,
) -> f64 {
    drawing_bound_parts(drawing, seam, start).map(|parts| parts.mapped_tight(min_hop).value()).sum()
}

/// Lower bound on the pen-up cost of `drawing` (as [`travel_lower_bound_mapped`]) when a hop costs at least its
/// cost under `hop`, which may depend on the hop's direction (see [`hop_cost::HopCost`]).
pub fn travel_lower_bound_hops(
    drawing: &Drawing,
    seam: SeamMode,
    start: Option<Point>,
    hop: &dyn hop_cost::HopCost,
) -> f64 {
    drawing_bound_parts(drawing, seam, start).map(|parts| parts.tight(hop).value()).sum()
}

/// Bound material of every layer of `drawing` as it stands, the first from `start`; each later layer from where
/// the layer before it (the last one with paths) can end: any place where one of its paths can be left. (The plan
/// travels from the last stroke of a layer straight to the first of the next, so the pen is at one of those
/// places when the layer begins; with no start the first drawn layer starts anywhere.)
fn drawing_bound_parts(
    drawing: &Drawing,
    seam: SeamMode,
    start: Option<Point>,
) -> impl Iterator<Item = bound::BoundParts> + '_ {
    let mut from: Vec<Point> = start.into_iter().collect();
    drawing.layers.iter().map(move |layer| {
        let ids: Vec<u32> = (0..u32::try_from(layer.paths.len()).unwrap_or(0))
            .filter(|&i| layer.paths[i as usize].points.len() >= 2)
            .collect();
        let (pts, grp, both_ends) = layer_places(&layer.paths, &ids, seam);
        let parts = bound::bound_parts(&pts, &grp, ids.len(), &both_ends, &from);
        if !ids.is_empty() {
            from = pts;
        }
        parts
    })
}

/// Optimize `drawing` in place; see the module docs. Fails only on invalid options or non-finite coordinates.
pub fn optimize(drawing: &mut Drawing, opts: &OptimizeOptions) -> Result<OptimizeReport, OptimizeError> {
    check(drawing, opts)?;
    let t0 = Instant::now();
    // The work left for the improvement of the remaining layers (shared by all layers, in drawing order).
    let mut work_left: Option<u64> = opts.work_per_path.map(|w| {
        let paths = drawing.layers.iter().map(|l| l.paths.len()).sum::<usize>();
        #[allow(clippy::cast_precision_loss, reason = "path counts are far below 2^52")]
        let total = w * paths as f64;
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss, reason = "finite, ≥ 0, clamped")]
        let units = total.min(1e18) as u64;
        units
    });
    let objective = match (opts.objective, opts.time_model) {
        (Objective::Time, Some(m)) => CostModel::Time(m),
        _ => CostModel::Distance,
    };
    let time_cost = opts.time_model.map(CostModel::Time);
    let mut report = OptimizeReport::default();
    let input_layers: Option<Vec<Vec<Polyline>>> =
        opts.improve.then(|| drawing.layers.iter().map(|l| l.paths.clone()).collect());
    let (mut at_before, mut at_after) = (opts.start, opts.start);
    // Improving a layer can move where it ends and so make the next layer dearer. To stay never worse than plain
    // greedy over the whole drawing, a greedy-only chain runs alongside when there are several layers.
    let track_greedy = drawing.layers.len() > 1 && opts.reorder && opts.improve;
    let mut at_greedy = opts.start;
    let mut greedy_layers: Vec<Vec<Polyline>> = Vec::new();
    let (mut greedy_total, mut improved_total) = (0.0, 0.0);
    let last_layer = drawing.layers.len().saturating_sub(1);
    let home = opts.start.filter(|_| opts.return_home);
    for (li, layer) in drawing.layers.iter_mut().enumerate() {
        let end = if li == last_layer { home } else { None };
        let mut lr = LayerReport { name: layer.name.clone(), paths_in: layer.paths.len(), ..LayerReport::default() };
        let (before, end_before) = travel::paths_travel(&layer.paths, at_before, &CostModel::Distance);
        lr.pen_up_before_mm = before;
        lr.travel_time_before_s = time_cost.map(|c| travel::paths_travel(&layer.paths, at_before, &c).0);
        at_before = end_before;

        let mut paths = std::mem::take(&mut layer.paths);
        if opts.merge {
            let (merged, stats) = merge::merge_paths(paths, opts.merge_tolerance_mm, opts.reverse);
            paths = merged;
            lr.joins = stats.joins;
            lr.closed_by_merge = stats.closed;
        }
        // Paths without a segment are not drawn (see `crate::geometry::travel`); they stay, unordered, at the layer's end.
        let (ids, empties): (Vec<u32>, Vec<u32>) =
            (0..u32::try_from(paths.len()).unwrap_or(0)).partition(|&i| paths[i as usize].points.len() >= 2);
        let input_visits: Vec<Visit> = ids.iter().map(|&id| Visit { path: id, reversed: false, seam: 0 }).collect();
        let mut visits = if opts.reorder {
            order::greedy_order(&paths, &ids, at_after.unwrap_or(Point::ZERO), opts.seam, opts.reverse)
        } else {
            input_visits.clone()
        };
        if opts.reorder {
            // The greedy chain's own figures (from where greedy's previous layer ended).
            let own;
            let greedy = if at_greedy == at_after {
                &visits
            } else {
                own = order::greedy_order(&paths, &ids, at_greedy.unwrap_or(Point::ZERO), opts.seam, opts.reverse);
                &own
            };
            lr.pen_up_greedy_mm = Some(visits_cost(&paths, greedy, at_greedy, &CostModel::Distance));
            greedy_total += visits_cost_to(&paths, greedy, at_greedy, end, &objective);
            if let Some(last) = greedy.last() {
                at_greedy = Some(last.exit(&paths));
            }
            if track_greedy {
                greedy_layers.push(greedy.iter().map(|v| v.realize(paths[v.path as usize].clone())).collect());
                if let Some(g) = greedy_layers.last_mut() {
                    g.extend(empties.iter().map(|&i| paths[i as usize].clone()));
                }
            }
        }
        let out_of_work = work_left == Some(0);
        if opts.improve && out_of_work {
            lr.improve.budget_exhausted = true;
        }
        let improve_step = |visits: &mut Vec<Visit>| {
            let n = visits.len();
            #[allow(clippy::cast_precision_loss, reason = "path counts are far below 2^52")]
            let nf = n as f64;
            #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss, reason = "finite, ≥ 0, clamped")]
            let kicks = (opts.kicks_per_path * nf).min(1e12) as usize;
            #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss, reason = "finite, ≥ 0")]
            let auto_cap = (50.0 * nf.sqrt()) as usize;
            let params = improve::ImproveParams {
                neighbours: opts.neighbours,
                work_limit: work_left,
                seed: opts.seed ^ (li as u64).wrapping_mul(0x9E37_79B9),
                kicks,
                max_reversal: opts.max_reversal.unwrap_or(auto_cap.max(1000)),
                allow_reverse: opts.reverse,
                seam: opts.seam,
                verify: false,
                free_start: at_after.is_none(),
                end,
            };
            improve::improve(&paths, visits, at_after.unwrap_or(Point::ZERO), &objective, params)
        };
        // The lower bound does not depend on the order: it runs beside the improvement (on another core when the
        // layer is big enough to pay for a thread), which leaves the result unchanged.
        let bound_start = if li == 0 { opts.start.as_slice() } else { &[] };
        let bound_step = || opts.lower_bound.then(|| layer_bound_parts(&paths, &ids, opts.seam, bound_start));
        let improving = opts.improve && !out_of_work;
        let (improved, bound_parts) = if improving && ids.len() >= PARALLEL_BOUND_MIN_PATHS {
            parallel::join(|| Some(improve_step(&mut visits)), bound_step)
        } else {
            (improving.then(|| improve_step(&mut visits)), bound_step())
        };
        if let Some(stats) = improved {
            if let Some(left) = work_left.as_mut() {
                *left = left.saturating_sub(stats.work);
            }
            lr.improve = stats;
        }
        // With improvement on, never worse than the input order under the objective (plain greedy stays plain).
        if opts.improve
            && visits_cost_to(&paths, &input_visits, at_after, end, &objective)
                < visits_cost_to(&paths, &visits, at_after, end, &objective)
        {
            visits = input_visits;
            lr.kept_input_order = true;
        }
        improved_total += visits_cost_to(&paths, &visits, at_after, end, &objective);
        if let Some(parts) = bound_parts {
            lr.pen_up_lower_bound_mm = Some(parts.under(&CostModel::Distance).value());
            lr.travel_time_lower_bound_s = time_cost.map(|c| parts.under(&c).value());
        }
        let mut slots: Vec<Option<Polyline>> = paths.into_iter().map(Some).collect();
        let mut out = Vec::with_capacity(slots.len());
        for v in &visits {
            if let Some(p) = slots[v.path as usize].take() {
                out.push(v.realize(p));
            }
        }
        out.extend(empties.iter().filter_map(|&i| slots[i as usize].take()));
        let (after, end_after) = travel::paths_travel(&out, at_after, &CostModel::Distance);
        lr.pen_up_after_mm = after;
        lr.travel_time_after_s = time_cost.map(|c| travel::paths_travel(&out, at_after, &c).0);
        at_after = end_after;
        lr.paths_out = out.len();
        layer.paths = out;

        report.pen_up_before_mm += lr.pen_up_before_mm;
        report.pen_up_after_mm += lr.pen_up_after_mm;
        add_opt(&mut report.pen_up_greedy_mm, lr.pen_up_greedy_mm);
        add_opt(&mut report.pen_up_lower_bound_mm, lr.pen_up_lower_bound_mm);
        add_opt(&mut report.travel_time_before_s, lr.travel_time_before_s);
        add_opt(&mut report.travel_time_after_s, lr.travel_time_after_s);
        add_opt(&mut report.travel_time_lower_bound_s, lr.travel_time_lower_bound_s);
        report.improve.add(&lr.improve);
        report.layers.push(lr);
    }
    if track_greedy && greedy_total < improved_total {
        // Rare: greedy's layer ends happened to suit the following layers better. Use the greedy chain.
        report.fell_back_to_greedy = true;
        adopt(drawing, &mut report, greedy_layers, opts.start, time_cost);
    }
    // With improvement on, never worse than the input order over the whole drawing: the per-layer guard above
    // compares from where the previous (reordered) layer ended, which can differ from where the input's ended.
    if let Some(input) = input_layers {
        let current: Vec<&[Polyline]> = drawing.layers.iter().map(|l| l.paths.as_slice()).collect();
        let original: Vec<&[Polyline]> = input.iter().map(Vec::as_slice).collect();
        if chain_cost(&original, opts.start, home, &objective) < chain_cost(&current, opts.start, home, &objective) {
            report.kept_input_order = true;
            adopt(drawing, &mut report, input, opts.start, time_cost);
        }
    }
    if opts.bridge_mm > 0.0 {
        let mut bridged = Vec::with_capacity(drawing.layers.len());
        for (layer, lr) in drawing.layers.iter_mut().zip(&mut report.layers) {
            let (paths, joins) = bridge_paths(std::mem::take(&mut layer.paths), opts.bridge_mm);
            lr.bridges = joins;
            report.bridges += joins;
            bridged.push(paths);
        }
        adopt(drawing, &mut report, bridged, opts.start, time_cost);
    }
    if let Some(h) = home {
        // The return hop belongs to the plot's pen-up travel.
        let last = drawing.paths().filter(|p| p.points.len() >= 2).last().and_then(Polyline::end);
        if let Some(e) = last {
            report.pen_up_after_mm += e.distance(h);
            if let (Some(t), Some(c)) = (report.travel_time_after_s.as_mut(), time_cost) {
                *t += c.cost(e, h);
            }
        }
    }
    report.paths_out = drawing.paths().filter(|p| p.points.len() >= 2).count();
    report.elapsed = t0.elapsed();
    Ok(report)
}

/// Pen-up cost of drawing `layers` one after the other from `start` (and back to `home` when given).
fn chain_cost(layers: &[&[Polyline]], start: Option<Point>, home: Option<Point>, cost: &CostModel) -> f64 {
    let mut at = start;
    let mut total = 0.0;
    for paths in layers {
        let (c, end) = travel::paths_travel(paths, at, cost);
        total += c;
        at = end;
    }
    if let (Some(a), Some(h)) = (at, home) {
        total += cost.cost(a, h);
    }
    total
}

/// Join consecutive drawn paths of `paths` whose gap (end of one to start of the next) is shorter than `max_gap`:
/// the gap is drawn with the pen down. Returns the paths and the number of joins.
fn bridge_paths(paths: Vec<Polyline>, max_gap: f64) -> (Vec<Polyline>, usize) {
    let mut out: Vec<Polyline> = Vec::with_capacity(paths.len());
    let mut undrawn = Vec::new();
    let mut joins = 0;
    for p in paths {
        if p.points.len() < 2 {
            undrawn.push(p);
            continue;
        }
        if let Some(prev) = out.last_mut()
            && let (Some(a), Some(b)) = (prev.end(), p.start())
            && a.distance(b) < max_gap
        {
            let skip = usize::from(a == b);
            prev.points.extend(p.points.into_iter().skip(skip));
            joins += 1;
            continue;
        }
        out.push(p);
    }
    out.extend(undrawn);
    (out, joins)
}

/// Replace every layer's paths by `layers` and recompute the report's "after" figures.
fn adopt(
    drawing: &mut Drawing,
    report: &mut OptimizeReport,
    layers: Vec<Vec<Polyline>>,
    start: Option<Point>,
    time_cost: Option<CostModel>,
) {
    let mut at = start;
    report.pen_up_after_mm = 0.0;
    report.travel_time_after_s = time_cost.map(|_| 0.0);
    for ((layer, lr), paths) in drawing.layers.iter_mut().zip(&mut report.layers).zip(layers) {
        layer.paths = paths;
        let (d, end) = travel::paths_travel(&layer.paths, at, &CostModel::Distance);
        lr.pen_up_after_mm = d;
        lr.travel_time_after_s = time_cost.map(|c| travel::paths_travel(&layer.paths, at, &c).0);
        lr.paths_out = layer.paths.len();
        at = end;
        report.pen_up_after_mm += d;
        if let (Some(t), Some(v)) = (report.travel_time_after_s.as_mut(), lr.travel_time_after_s) {
            *t += v;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Layer;
    use proptest::prelude::*;

    fn key(p: Point) -> (u64, u64) {
        (p.x.to_bits(), p.y.to_bits())
    }

    /// A path up to drawing direction (when `reverse`) and, for closed paths, seam rotation.
    fn canonical(path: &Polyline, reverse: bool, rotate: bool) -> Vec<(u64, u64)> {
        let pts: Vec<(u64, u64)> = path.points.iter().map(|&p| key(p)).collect();
        let mut forms = Vec::new();
        if path.is_closed() && rotate {
            let body = &pts[..pts.len() - 1];
            for r in 0..body.len() {
                let mut f: Vec<_> = body[r..].iter().chain(&body[..r]).copied().collect();
                f.push(f[0]);
                forms.push(f.clone());
                if reverse {
                    f.reverse();
                    forms.push(f);
                }
            }
        } else {
            forms.push(pts.clone());
            if reverse {
                forms.push(pts.iter().rev().copied().collect());
            }
        }
        forms.into_iter().min().unwrap_or_default()
    }

    fn segments(d: &Drawing) -> Vec<((u64, u64), (u64, u64))> {
        let mut v: Vec<_> = d
            .paths()
            .flat_map(|p| p.points.windows(2))
            .filter(|w| w[0] != w[1])
            .map(|w| {
                let (a, b) = (key(w[0]), key(w[1]));
                (a.min(b), a.max(b))
            })
            .collect();
        v.sort_unstable();
        v
    }

    fn arb_path() -> impl Strategy<Value = Polyline> {
        let pt = (0..40i32, 0..30i32).prop_map(|(x, y)| Point::new(f64::from(x) * 2.5, f64::from(y) * 2.5));
        prop_oneof![
            4 => prop::collection::vec(pt.clone(), 2..6).prop_map(Polyline::new),
            2 => prop::collection::vec(pt.clone(), 3..7).prop_map(|mut v| { v.push(v[0]); Polyline::new(v) }),
            1 => prop::collection::vec(pt, 0..2).prop_map(Polyline::new),
        ]
    }

    fn arb_drawing() -> impl Strategy<Value = Drawing> {
        prop::collection::vec(prop::collection::vec(arb_path(), 0..40), 1..4).prop_map(|layers| Drawing {
            layers: layers
                .into_iter()
                .enumerate()
                .map(|(i, paths)| Layer { paths, ..Layer::new(format!("l{i}")) })
                .collect(),
            page_mm: None,
        })
    }

    fn arb_seam() -> impl Strategy<Value = SeamMode> {
        prop_oneof![Just(SeamMode::Keep), Just(SeamMode::Any), Just(SeamMode::Corners { min_turn_deg: 45.0 })]
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 200, ..ProptestConfig::default() })]

        /// Without merging the result draws every input path once per layer, possibly reversed or with a rotated
        /// seam, never worse than greedy, and never below the lower bound.
        #[test]
        fn result_is_a_permutation_with_unchanged_geometry(
            d in arb_drawing(), reverse in any::<bool>(), seam in arb_seam(), start in any::<bool>(), seed in 0u64..4,
        ) {
            let opts = OptimizeOptions {
                merge: false, reverse, seam, seed, work_per_path: None,
                start: start.then_some(Point::new(3.0, 7.0)),
                ..OptimizeOptions::default()
            };
            let mut out = d.clone();
            let report = optimize(&mut out, &opts).unwrap();
            prop_assert_eq!(out.layers.len(), d.layers.len());
            let rotate = seam != SeamMode::Keep;
            for (a, b) in d.layers.iter().zip(&out.layers) {
                prop_assert_eq!(&a.name, &b.name);
                let mut ca: Vec<_> = a.paths.iter().map(|p| canonical(p, reverse, rotate)).collect();
                let mut cb: Vec<_> = b.paths.iter().map(|p| canonical(p, reverse, rotate)).collect();
                ca.sort();
                cb.sort();
                prop_assert_eq!(ca, cb);
            }
            let greedy = report.pen_up_greedy_mm.unwrap();
            prop_assert!(report.pen_up_after_mm <= greedy + 1e-9, "{} > greedy {}", report.pen_up_after_mm, greedy);
            prop_assert!(report.pen_up_after_mm <= report.pen_up_before_mm + 1e-9);
            let lb = report.pen_up_lower_bound_mm.unwrap();
            prop_assert!(lb <= report.pen_up_after_mm + 1e-9, "bound {} > result {}", lb, report.pen_up_after_mm);
            // The report agrees with measuring the output.
            let measured = drawing_travel(&out, opts.start, &CostModel::Distance);
            prop_assert!((measured - report.pen_up_after_mm).abs() < 1e-6);
            if opts.start.is_none() {
                prop_assert!((crate::geometry::travel::pen_up_length(&out) - report.pen_up_after_mm).abs() < 1e-6);
            }
        }

        /// With merging every input segment is still drawn exactly once; the only additions are bridges no longer
        /// than the tolerance.
        #[test]
        fn merging_keeps_every_segment_and_bridges_only_small_gaps(
            d in arb_drawing(), reverse in any::<bool>(), tol in prop_oneof![Just(0.0), Just(1.0), Just(3.0)],
        ) {
            let opts = OptimizeOptions { merge_tolerance_mm: tol, reverse, work_per_path: None, ..OptimizeOptions::default() };
            let mut out = d.clone();
            let report = optimize(&mut out, &opts).unwrap();
            let before = segments(&d);
            let after = segments(&out);
            // Multiset difference: after ⊇ before, the rest are short bridges.
            let (mut i, mut extra) = (0, Vec::new());
            for s in &after {
                if i < before.len() && before[i] == *s {
                    i += 1;
                } else {
                    extra.push(*s);
                }
            }
            prop_assert_eq!(i, before.len(), "an input segment is missing");
            for (a, b) in extra {
                let len = Point::new(f64::from_bits(a.0), f64::from_bits(a.1))
                    .distance(Point::new(f64::from_bits(b.0), f64::from_bits(b.1)));
                prop_assert!(len <= tol + 1e-12, "bridge of {} mm", len);
            }
            let joins: usize = report.layers.iter().map(|l| l.joins).sum();
            prop_assert_eq!(out.path_count() + joins, d.path_count());
        }
    }

    #[test]
    fn bad_input_names_the_place() {
        let mut d = Drawing::single_layer("ok", vec![Polyline::new(vec![Point::ZERO, Point::new(1.0, 1.0)])]);
        let mut bad = Layer::new("broken");
        bad.paths.push(Polyline::new(vec![Point::ZERO, Point::new(1.0, 0.0)]));
        bad.paths.push(Polyline::new(vec![Point::ZERO, Point::new(f64::NAN, 0.0)]));
        d.layers.push(bad);
        let err = optimize(&mut d.clone(), &OptimizeOptions::default()).unwrap_err();
        assert_eq!(err, OptimizeError::NonFinite { layer: 1, name: "broken".into(), path: 1, point: 1 });
        assert!(err.to_string().contains("(\"broken\"), path 1, point 1"), "{err}");
        let opts = OptimizeOptions { objective: Objective::Time, ..OptimizeOptions::default() };
        let err = optimize(&mut d, &opts).unwrap_err().to_string();
        assert!(err.contains("objective") && err.contains("profile"), "{err}");
        let opts = OptimizeOptions { merge_tolerance_mm: -1.0, ..OptimizeOptions::default() };
        assert!(matches!(
            optimize(&mut d, &opts),
            Err(OptimizeError::InvalidOption { option: "merge_tolerance_mm", .. })
        ));
    }

    #[test]
    fn switches_disable_each_step() {
        let d = synth::maze(2);
        let n = d.path_count();
        let none = OptimizeOptions {
            merge: false,
            reorder: false,
            improve: false,
            lower_bound: false,
            ..OptimizeOptions::default()
        };
        let mut same = d.clone();
        let r = optimize(&mut same, &none).unwrap();
        assert_eq!(same, d);
        assert_eq!((r.pen_up_before_mm, r.pen_up_greedy_mm, r.pen_up_lower_bound_mm), (r.pen_up_after_mm, None, None));
        // Merge only: fewer paths, same order otherwise.
        let mut merged = d.clone();
        let r = optimize(&mut merged, &OptimizeOptions { merge: true, ..none.clone() }).unwrap();
        assert!(merged.path_count() < n / 2 && r.layers[0].joins == n - merged.path_count());
        // Improvement on the input order (no greedy) still helps and never hurts.
        let mut improved = d.clone();
        let r = optimize(&mut improved, &OptimizeOptions { improve: true, work_per_path: None, ..none }).unwrap();
        assert!(r.pen_up_after_mm < 0.5 * r.pen_up_before_mm, "{r:?}");
        assert_eq!(improved.path_count(), n);
    }

    #[test]
    fn time_objective_reports_times_and_weighs_hops() {
        let model = TravelTimeModel::from_profile(&crate::MachineProfile::default_plotter());
        let d = synth::glyphs(5);
        let mut a = d.clone();
        let opts = OptimizeOptions {
            objective: Objective::Time,
            time_model: Some(model),
            work_per_path: None,
            ..OptimizeOptions::default()
        };
        let r = optimize(&mut a, &opts).unwrap();
        let (before, after, lb) =
            (r.travel_time_before_s.unwrap(), r.travel_time_after_s.unwrap(), r.travel_time_lower_bound_s.unwrap());
        assert!(lb <= after && after < 0.7 * before, "{lb} {after} {before}");
        // Every hop pays the lift: the bound is at least that for each path.
        #[allow(clippy::cast_precision_loss, reason = "small count")]
        let lifts = model.lift_drop_s * (d.path_count() - 1) as f64;
        assert!(lb >= lifts);
        let measured = drawing_travel(&a, None, &CostModel::Time(model));
        assert!((measured - after).abs() < 1e-6);
    }

    #[test]
    fn never_worse_than_greedy_across_layers_on_the_samples() {
        // transforms.svg once came out 4 % worse than greedy: improving layer 1 moved its end away from layer 2.
        for name in ["duck.svg", "layers.svg", "transforms.svg"] {
            let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../samples").join(name);
            let d = crate::input::svg::load_svg(&path, &crate::input::svg::SvgOptions::default()).unwrap().drawing;
            let mut out = d.clone();
            let r = optimize(&mut out, &OptimizeOptions { work_per_path: None, ..OptimizeOptions::default() }).unwrap();
            let greedy = r.pen_up_greedy_mm.unwrap();
            assert!(r.pen_up_after_mm <= greedy + 1e-9, "{name}: {} > {greedy}", r.pen_up_after_mm);
            assert!((crate::geometry::travel::pen_up_length(&out) - r.pen_up_after_mm).abs() < 1e-6, "{name}");
            assert_eq!(out.layers.len(), d.layers.len());
        }
    }

    /// The issue's quality bar: in total over the realistic drawings, improved travel ≤ 0.80 × plain greedy, and
    /// never above greedy on any of them. Deterministic (no time budget), so this is not a timing test.
    #[test]
    fn realistic_drawings_beat_greedy_by_a_fifth() {
        let (mut greedy, mut improved) = (0.0, 0.0);
        for (name, d) in synth::realistic_set(1) {
            let mut out = d.clone();
            let r = optimize(&mut out, &OptimizeOptions { work_per_path: None, ..OptimizeOptions::default() }).unwrap();
            let g = r.pen_up_greedy_mm.unwrap();
            assert!(r.pen_up_after_mm <= g, "{name}");
            greedy += g;
            improved += r.pen_up_after_mm;
        }
        assert!(improved <= 0.80 * greedy, "{improved} vs greedy {greedy}");
    }

    /// A layer big enough to compute its bound on a second thread gives the same drawing on every run and the
    /// same bound as computing it alone.
    #[test]
    fn threaded_bound_is_deterministic_and_equals_the_sequential_bound() {
        let d = synth::random_segments(3 * PARALLEL_BOUND_MIN_PATHS, 11);
        let opts =
            OptimizeOptions { merge: false, work_per_path: None, kicks_per_path: 0.5, ..OptimizeOptions::default() };
        let (mut a, mut b) = (d.clone(), d.clone());
        let ra = optimize(&mut a, &opts).unwrap();
        let rb = optimize(&mut b, &opts).unwrap();
        assert_eq!(a, b);
        assert_eq!(ra.pen_up_lower_bound_mm, rb.pen_up_lower_bound_mm);
        let alone = travel_lower_bound(&d, opts.seam, opts.start, None).0;
        assert_eq!(ra.pen_up_lower_bound_mm, Some(alone));
        assert!(alone > 0.0 && alone <= ra.pen_up_after_mm);
    }

    /// The improvement's budget counts work, not time: a budget that stops the search spends exactly what it was
    /// given (give or take one node's scan), repeats bit for bit, and more of it never gives a longer travel — the
    /// search only ever keeps improvements, so a shorter run is a prefix of a longer one.
    #[test]
    fn work_budget_is_deterministic_and_monotone() {
        let d = synth::random_segments(400, 3);
        let run = |work: Option<f64>| {
            let opts = OptimizeOptions { merge: false, work_per_path: work, ..OptimizeOptions::default() };
            let mut out = d.clone();
            let r = optimize(&mut out, &opts).unwrap();
            (out, r)
        };
        let (full, rf) = run(None);
        assert!(!rf.improve.budget_exhausted && rf.improve.work > 0);
        let mut last = f64::INFINITY;
        for per_path in [0.5, 5.0, 50.0] {
            let (a, ra) = run(Some(per_path));
            let (b, rb) = run(Some(per_path));
            assert_eq!(a, b, "{per_path}");
            assert_eq!(ra.improve, rb.improve);
            assert!(ra.improve.budget_exhausted, "{per_path}: {:?}", ra.improve);
            // 400 paths × per_path units; the budget is checked between nodes, so the last node's scans (until no
            // move around it applies) may run over by a few hundred candidates.
            #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss, reason = "small positive values")]
            let limit = (400.0 * per_path) as u64;
            assert!(ra.improve.work >= limit && ra.improve.work < limit + 2000, "{per_path}: {}", ra.improve.work);
            assert!(ra.pen_up_after_mm <= last + 1e-9, "{per_path}: {} > {last}", ra.pen_up_after_mm);
            last = ra.pen_up_after_mm;
        }
        assert!(rf.pen_up_after_mm <= last + 1e-9);
        // A budget above what convergence needs changes nothing.
        #[allow(clippy::cast_precision_loss, reason = "small count")]
        let ample = 2.0 * rf.improve.work as f64 / 400.0;
        let (c, rc) = run(Some(ample));
        assert_eq!((c, rc.improve), (full, rf.improve));
    }

    #[test]
    fn same_seed_same_drawing() {
        let d = synth::text_like(9);
        let opts = OptimizeOptions { work_per_path: None, seed: 5, ..OptimizeOptions::default() };
        let (mut a, mut b) = (d.clone(), d.clone());
        optimize(&mut a, &opts).unwrap();
        optimize(&mut b, &opts).unwrap();
        assert_eq!(a, b);
    }
}
