//! Drift-free conversion of millimetre drawings to integer motor steps.
//!
//! Every absolute point (page mm) goes through the profile's page → machine mapping
//! ([`MachineProfile::page_to_machine`]) and is rounded to the nearest integer step **once**; the relative moves sent
//! to the machine are differences of consecutive rounded points. Summing the relative moves of a path therefore gives
//! exactly the rounded absolute end point, and a closed curve (first point == last point) returns to its first step
//! exactly. Rounding every *relative* move instead lets the rounding errors accumulate along the path (the seed
//! plotter's shrunken drawings came from that).
//!
//! The result, a [`StepDrawing`], is what the trajectory file, the G-code export and the motion plan are built from.

use kurbo::Point;

use crate::config::profile::{AxisProfile, HomeEnd};
use crate::{Drawing, MachineProfile, Pen, Polyline};

/// Largest step coordinate accepted: ±2³⁰ keeps every difference of two coordinates inside `i32`.
pub const MAX_STEP_COORD: i32 = 1 << 30;

/// Errors converting millimetres to steps.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StepError {
    /// A coordinate is NaN or infinite.
    #[error("layer {layer}, path {path}, point {point}: coordinate is not a finite number")]
    NonFinite {
        /// Layer index (0-based).
        layer: usize,
        /// Path index within the layer (0-based).
        path: usize,
        /// Point index within the path (0-based).
        point: usize,
    },
    /// A coordinate maps to a step count beyond [`MAX_STEP_COORD`].
    #[error("layer {layer}, path {path}, point {point}: ({x:.3}, {y:.3}) mm is too far from the origin to step")]
    OutOfRange {
        /// Layer index (0-based).
        layer: usize,
        /// Path index within the layer (0-based).
        path: usize,
        /// Point index within the path (0-based).
        point: usize,
        /// Page X, mm.
        x: f64,
        /// Page Y, mm.
        y: f64,
    },
    /// Rounding to whole steps lost the drawing: its pen-down length in steps is a small fraction of its length
    /// in millimetres (steps far too coarse for the drawing's size: a tiny layout, or a profile's steps/mm).
    #[error(
        "the drawing's {drawn_mm} mm of pen-down lines come out as {stepped_mm} mm in whole steps ({x_steps_per_mm} \
         × {y_steps_per_mm} steps/mm): the steps are too coarse for a drawing this small (check the profile's \
         steps_per_mm and the layout's scale)"
    )]
    Collapsed {
        /// Pen-down length of the drawing, mm (rounded to 0.001 for the message).
        drawn_mm: f64,
        /// Pen-down length after rounding every point to steps, mm.
        stepped_mm: f64,
        /// X steps per mm.
        x_steps_per_mm: f64,
        /// Y steps per mm.
        y_steps_per_mm: f64,
    },
}

/// A drawing whose pen-down length in whole steps is below this fraction of its length in millimetres has lost
/// its shape to rounding ([`StepError::Collapsed`]). Rounding each point moves it by at most half a step, so an
/// honest conversion keeps nearly all of the length; losing half of it means most strokes became dots.
pub const COLLAPSE_FRACTION: f64 = 0.5;

/// Below this many steps of pen-down length (on the coarser axis) a drawing is too short to judge: a few dots or
/// a tiny mark may legitimately round away.
pub const COLLAPSE_MIN_STEPS: f64 = 20.0;

/// An absolute machine position in integer steps (X, Y; Z is handled by the pen).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct StepPos {
    /// X steps from the homed origin.
    pub x: i32,
    /// Y steps from the homed origin.
    pub y: i32,
}

impl StepPos {
    /// A position.
    pub const fn new(x: i32, y: i32) -> Self {
        StepPos { x, y }
    }

    /// The relative move from `self` to `to`. Coordinates are within ±[`MAX_STEP_COORD`], so it cannot overflow.
    pub fn delta_to(self, to: StepPos) -> StepDelta {
        StepDelta { dx: to.x - self.x, dy: to.y - self.y }
    }

    /// `self` moved by `d`.
    pub fn offset(self, d: StepDelta) -> StepPos {
        StepPos { x: self.x.saturating_add(d.dx), y: self.y.saturating_add(d.dy) }
    }
}

/// A relative move in integer steps.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct StepDelta {
    /// X steps (signed).
    pub dx: i32,
    /// Y steps (signed).
    pub dy: i32,
}

impl StepDelta {
    /// True when neither axis moves.
    pub fn is_zero(self) -> bool {
        self.dx == 0 && self.dy == 0
    }
}

/// Page millimetres ⇄ machine steps for one profile: the page → machine mapping followed by steps/mm scaling.
#[derive(Debug, Clone)]
pub struct StepMapper {
    profile: MachineProfile,
}

impl StepMapper {
    /// The mapper of `profile`.
    pub fn new(profile: &MachineProfile) -> Self {
        StepMapper { profile: profile.clone() }
    }

    /// Steps per mm on X and Y.
    pub fn steps_per_mm(&self) -> (f64, f64) {
        (self.profile.axes.x.steps_per_mm, self.profile.axes.y.steps_per_mm)
    }

    /// Round a page point to the nearest machine step position, or `None` when it is not finite or out of range.
    pub fn try_page_to_steps(&self, p: Point) -> Option<StepPos> {
        let m = self.profile.page_to_machine(p);
        let (sx, sy) = self.steps_per_mm();
        Some(StepPos { x: round_steps(m.x * sx)?, y: round_steps(m.y * sy)? })
    }

    /// Machine millimetres of a step position (exact quantized position).
    pub fn steps_to_machine(&self, s: StepPos) -> Point {
        let (sx, sy) = self.steps_per_mm();
        Point::new(f64::from(s.x) / sx, f64::from(s.y) / sy)
    }

    /// Page millimetres of a step position.
    pub fn steps_to_page(&self, s: StepPos) -> Point {
        self.profile.machine_to_page(self.steps_to_machine(s))
    }

    /// Steps of a machine Z height (mm), rounded once.
    pub fn z_steps(&self, z_mm: f64) -> Option<i32> {
        round_steps(z_mm * self.profile.axes.z.steps_per_mm)
    }

    /// The pen-up Z and the pen-down Z `down_mm`, in steps.
    pub fn pen_z_steps(&self, down_mm: f64) -> Result<(i32, i32), PenHeightsError> {
        let up = self.z_steps(self.profile.pen.up_z_mm).ok_or(PenHeightsError)?;
        let down = self.z_steps(down_mm).ok_or(PenHeightsError)?;
        if up == down {
            return Err(PenHeightsError);
        }
        Ok((up, down))
    }

    /// The machine position after homing, in steps (X, Y, Z, E): X and Y at their switch end, Z at the pen-up
    /// height, E at 0.
    pub fn homed(&self) -> Result<[i32; 4], PenHeightsError> {
        let (up, _) = self.pen_z_steps(self.profile.pen.down_z_mm)?;
        let end = |a: &AxisProfile| {
            if a.home == HomeEnd::Max { round_steps(a.travel_mm * a.steps_per_mm).unwrap_or(0) } else { 0 }
        };
        Ok([end(&self.profile.axes.x), end(&self.profile.axes.y), up, 0])
    }
}

/// The profile's pen heights do not round to two different Z steps.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("machine profile: pen.up_z_mm and pen.down_z_mm round to the same Z step")]
pub struct PenHeightsError;

/// Round a step count to the nearest integer (ties away from zero), `None` when not finite or beyond the range.
pub fn round_steps(v: f64) -> Option<i32> {
    let r = v.round();
    if !r.is_finite() || r.abs() > f64::from(MAX_STEP_COORD) {
        return None;
    }
    // The range was checked just above, so the conversion is exact.
    #[allow(clippy::cast_possible_truncation)]
    Some(r as i32)
}

/// One pen-down stroke in steps: an absolute start and the relative moves that follow it.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct StepStroke {
    /// Where the pen goes down.
    pub start: StepPos,
    /// Relative moves drawn from `start`; moves that round to zero steps are dropped (they carry no motion).
    pub moves: Vec<StepDelta>,
}

impl StepStroke {
    /// The absolute end of the stroke (the start plus every move).
    pub fn end(&self) -> StepPos {
        self.moves.iter().fold(self.start, |p, d| p.offset(*d))
    }

    /// The absolute positions visited: the start, then after each move.
    pub fn positions(&self) -> Vec<StepPos> {
        let mut out = Vec::with_capacity(self.moves.len() + 1);
        let mut p = self.start;
        out.push(p);
        for d in &self.moves {
            p = p.offset(*d);
            out.push(p);
        }
        out
    }
}

/// Where a layer begins in a [`StepDrawing`], and its pen: layer boundaries survive into steps (and the plan) so
/// that the plot can stop for a pen change between layers.
#[derive(Debug, Clone, PartialEq)]
pub struct StepLayer {
    /// The layer's name.
    pub name: String,
    /// The layer's pen (colour, width) from the input.
    pub pen: Pen,
    /// Index of the layer's first stroke in [`StepDrawing::strokes`].
    pub first_stroke: usize,
}

/// A whole drawing in steps: strokes in plotting order (layer by layer).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct StepDrawing {
    /// The pen-down strokes.
    pub strokes: Vec<StepStroke>,
    /// The layers holding at least one stroke, in order, by their first stroke (ascending, the first at 0). Empty
    /// for inputs without layers (trajectory files): one layer with the default pen.
    pub layers: Vec<StepLayer>,
}

impl StepDrawing {
    /// A drawing of `strokes` in one unnamed layer.
    pub fn from_strokes(strokes: Vec<StepStroke>) -> Self {
        StepDrawing { strokes, layers: Vec::new() }
    }

    /// Index in [`Self::layers`] of the layer holding stroke `stroke` (0 when there are no layers).
    pub fn layer_of(&self, stroke: usize) -> usize {
        self.layers.partition_point(|l| l.first_stroke <= stroke).saturating_sub(1)
    }

    /// Total number of pen-down moves.
    pub fn move_count(&self) -> usize {
        self.strokes.iter().map(|s| s.moves.len()).sum()
    }

    /// Convert back to a single-layer millimetre drawing (page coordinates) through `mapper`.
    pub fn to_drawing(&self, mapper: &StepMapper, layer_name: &str) -> Drawing {
        let paths = self
            .strokes
            .iter()
            .map(|s| Polyline::new(s.positions().into_iter().map(|p| mapper.steps_to_page(p)).collect()))
            .collect();
        Drawing::single_layer(layer_name, paths)
    }
}

/// Convert one polyline: every point rounded once, zero moves dropped. `layer`/`path` only label errors.
/// Returns `None` for an empty polyline.
pub fn polyline_to_steps(
    mapper: &StepMapper,
    poly: &Polyline,
    layer: usize,
    path: usize,
) -> Result<Option<StepStroke>, StepError> {
    let mut abs = Vec::with_capacity(poly.points.len());
    for (i, p) in poly.points.iter().enumerate() {
        if !(p.x.is_finite() && p.y.is_finite()) {
            return Err(StepError::NonFinite { layer, path, point: i });
        }
        let s = mapper.try_page_to_steps(*p).ok_or(StepError::OutOfRange { layer, path, point: i, x: p.x, y: p.y })?;
        abs.push(s);
    }
    let Some(&start) = abs.first() else { return Ok(None) };
    let moves = abs.windows(2).map(|w| w[0].delta_to(w[1])).filter(|d| !d.is_zero()).collect();
    Ok(Some(StepStroke { start, moves }))
}

/// Convert a whole drawing (all layers, in order) to steps with `profile`'s mapping.
pub fn drawing_to_steps(profile: &MachineProfile, drawing: &Drawing) -> Result<StepDrawing, StepError> {
    let mapper = StepMapper::new(profile);
    let mut strokes = Vec::with_capacity(drawing.path_count());
    let mut layers = Vec::new();
    for (li, layer) in drawing.layers.iter().enumerate() {
        let first_stroke = strokes.len();
        for (pi, poly) in layer.paths.iter().enumerate() {
            if let Some(s) = polyline_to_steps(&mapper, poly, li, pi)? {
                strokes.push(s);
            }
        }
        if strokes.len() > first_stroke {
            layers.push(StepLayer { name: layer.name.clone(), pen: layer.pen, first_stroke });
        }
    }
    let out = StepDrawing { strokes, layers };
    check_not_collapsed(&mapper, drawing, &out)?;
    Ok(out)
}

/// Refuse a conversion that lost the drawing to rounding ([`StepError::Collapsed`]): pen-down length in whole
/// steps below [`COLLAPSE_FRACTION`] of the length in millimetres, for a drawing of at least
/// [`COLLAPSE_MIN_STEPS`] steps' length.
fn check_not_collapsed(mapper: &StepMapper, drawing: &Drawing, steps: &StepDrawing) -> Result<(), StepError> {
    let (sx, sy) = mapper.steps_per_mm();
    let drawn_mm: f64 = drawing.paths().map(Polyline::length).sum();
    let length_steps = drawn_mm * sx.min(sy);
    if length_steps.is_nan() || length_steps < COLLAPSE_MIN_STEPS {
        return Ok(());
    }
    let stepped_mm: f64 =
        steps.strokes.iter().flat_map(|s| &s.moves).map(|d| (f64::from(d.dx) / sx).hypot(f64::from(d.dy) / sy)).sum();
    if stepped_mm >= COLLAPSE_FRACTION * drawn_mm {
        return Ok(());
    }
    let short = |v: f64| (v * 1000.0).round() / 1000.0 + 0.0;
    Err(StepError::Collapsed {
        drawn_mm: short(drawn_mm),
        stepped_mm: short(stepped_mm),
        x_steps_per_mm: sx,
        y_steps_per_mm: sy,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::profile::PageOrigin;
    use proptest::prelude::*;

    fn profile() -> MachineProfile {
        MachineProfile::default_plotter()
    }

    #[test]
    fn a_drawing_lost_to_rounding_is_an_error() {
        // Forty small circles (r = 0.3 mm, 75 mm of ink in all) at 1 step/mm: every point rounds to its centre's
        // step, so every stroke collapses to a dot.
        let mut p = profile();
        p.axes.x.steps_per_mm = 1.0;
        p.axes.y.steps_per_mm = 1.0;
        let circle = |c: Point| {
            let pts = (0..=32).map(|k| c + kurbo::Vec2::from_angle(f64::from(k) * std::f64::consts::TAU / 32.0) * 0.3);
            Polyline::new(pts.collect())
        };
        let circles: Vec<Polyline> = (0..40).map(|i| circle(Point::new(f64::from(10 + 2 * i), 10.0))).collect();
        let d = Drawing::single_layer("c", circles);
        let err = drawing_to_steps(&p, &d).unwrap_err();
        let StepError::Collapsed { drawn_mm, stepped_mm, .. } = err else { panic!("{err}") };
        // 40 circles of 32 chords of 2 · 0.3 · sin(π/32) mm.
        let ink = 40.0 * 32.0 * 0.6 * (std::f64::consts::PI / 32.0).sin();
        assert!((drawn_mm - ink).abs() < 1e-3 && stepped_mm == 0.0, "{drawn_mm} {stepped_mm}");
        assert!(err.to_string().contains("75.277 mm of pen-down lines come out as 0 mm"), "{err}");
        // The same drawing at the kit's 80 steps/mm keeps its shape.
        assert!(drawing_to_steps(&profile(), &d).is_ok());
        // A few dots (too short to judge) and an ordinary line are fine at 1 step/mm.
        let dots =
            (0..5).map(|i| Polyline::new(vec![Point::new(f64::from(i), 0.0), Point::new(f64::from(i) + 0.1, 0.0)]));
        let line = Polyline::new(vec![Point::new(0.0, 5.0), Point::new(40.0, 5.0)]);
        assert!(drawing_to_steps(&p, &Drawing::single_layer("d", dots.collect())).is_ok());
        assert!(drawing_to_steps(&p, &Drawing::single_layer("l", vec![line])).is_ok());
    }

    #[test]
    fn rounds_once_not_per_move() {
        // 100 moves of 0.01 mm at 80 steps/mm: each is 0.8 steps. Rounding each relative move would give 1 step
        // per move (100 steps); rounding absolute points gives the true 80.
        let pts: Vec<Point> = (0..=100).map(|i| Point::new(f64::from(i) * 0.01, 0.0)).collect();
        let s = polyline_to_steps(&StepMapper::new(&profile()), &Polyline::new(pts), 0, 0).unwrap().unwrap();
        assert_eq!(s.end(), StepPos::new(80, 0));
        let total: i32 = s.moves.iter().map(|d| d.dx).sum();
        assert_eq!(total, 80);
        // Moves that round to nothing are dropped, none is zero.
        assert!(s.moves.iter().all(|d| !d.is_zero()));
        assert_eq!(s.moves.len(), 80);
    }

    #[test]
    fn bottom_left_origin_flips_y() {
        let mut p = profile();
        p.page_origin = PageOrigin::BottomLeft;
        let m = StepMapper::new(&p);
        let s = m.try_page_to_steps(Point::new(1.0, 0.0)).unwrap();
        assert_eq!(s, StepPos::new(80, round_steps(p.axes.y.travel_mm * 80.0).unwrap()));
        assert_eq!(m.steps_to_page(s), Point::new(1.0, 0.0));
    }

    #[test]
    fn bad_points_name_their_place() {
        let mut d = Drawing::single_layer("a", vec![Polyline::new(vec![Point::new(0.0, 0.0)])]);
        d.layers[0].paths.push(Polyline::new(vec![Point::new(0.0, 0.0), Point::new(f64::NAN, 1.0)]));
        assert_eq!(drawing_to_steps(&profile(), &d), Err(StepError::NonFinite { layer: 0, path: 1, point: 1 }));
        d.layers[0].paths[1].points[1] = Point::new(1e12, 0.0);
        let e = drawing_to_steps(&profile(), &d).unwrap_err();
        assert!(matches!(e, StepError::OutOfRange { layer: 0, path: 1, point: 1, .. }), "{e}");
        assert!(e.to_string().contains("path 1, point 1"));
    }

    #[test]
    fn empty_paths_are_skipped_dots_kept() {
        let d = Drawing::single_layer("a", vec![Polyline::new(vec![]), Polyline::new(vec![Point::new(2.0, 3.0)])]);
        let s = drawing_to_steps(&profile(), &d).unwrap();
        assert_eq!(s.strokes, vec![StepStroke { start: StepPos::new(160, 240), moves: vec![] }]);
    }

    #[test]
    fn layer_boundaries_survive_and_empty_layers_drop() {
        let dot = |x: f64| Polyline::new(vec![Point::new(x, 1.0), Point::new(x + 1.0, 1.0)]);
        let mut d = Drawing::single_layer("a", vec![dot(1.0), dot(3.0)]);
        d.layers.push(crate::Layer::new("empty"));
        let mut c = crate::Layer::new("c");
        c.pen.color = crate::Rgb(255, 0, 0);
        c.paths = vec![dot(5.0)];
        d.layers.push(c);
        let s = drawing_to_steps(&profile(), &d).unwrap();
        let names: Vec<(&str, usize)> = s.layers.iter().map(|l| (l.name.as_str(), l.first_stroke)).collect();
        assert_eq!(names, [("a", 0), ("c", 2)]);
        assert_eq!(s.layers[1].pen.color, crate::Rgb(255, 0, 0));
        assert_eq!([s.layer_of(0), s.layer_of(1), s.layer_of(2)], [0, 0, 1]);
        assert_eq!(StepDrawing::from_strokes(s.strokes.clone()).layer_of(2), 0);
    }

    fn arb_point() -> impl Strategy<Value = Point> {
        (-50.0f64..400.0, -50.0f64..300.0).prop_map(|(x, y)| Point::new(x, y))
    }

    proptest! {
        #[test]
        fn sums_equal_rounded_absolute_end(
            pts in prop::collection::vec(arb_point(), 1..200),
            spm in 3.0f64..250.0,
            flip in any::<bool>(),
        ) {
            let mut p = profile();
            p.axes.x.steps_per_mm = spm;
            p.axes.y.steps_per_mm = spm * 1.37;
            if flip { p.page_origin = PageOrigin::BottomLeft; }
            let m = StepMapper::new(&p);
            let s = polyline_to_steps(&m, &Polyline::new(pts.clone()), 0, 0).unwrap().unwrap();
            let expect_end = m.try_page_to_steps(*pts.last().unwrap()).unwrap();
            let sx: i64 = s.moves.iter().map(|d| i64::from(d.dx)).sum();
            let sy: i64 = s.moves.iter().map(|d| i64::from(d.dy)).sum();
            prop_assert_eq!(i64::from(s.start.x) + sx, i64::from(expect_end.x));
            prop_assert_eq!(i64::from(s.start.y) + sy, i64::from(expect_end.y));
            // Every visited position is within half a step of its ideal point.
            for pos in s.positions() {
                let ideal = pts.iter().map(|q| p.page_to_machine(*q)).map(|q| (q.x * spm, q.y * spm * 1.37));
                prop_assert!(ideal.clone().any(|(ix, iy)| (f64::from(pos.x) - ix).abs() <= 0.5
                    && (f64::from(pos.y) - iy).abs() <= 0.5));
            }
        }

        #[test]
        fn closed_curves_return_exactly(
            pts in prop::collection::vec(arb_point(), 2..300),
            spm in 3.0f64..250.0,
        ) {
            let mut pts = pts;
            pts.push(pts[0]);
            let mut p = profile();
            p.axes.x.steps_per_mm = spm;
            let s = polyline_to_steps(&StepMapper::new(&p), &Polyline::new(pts), 0, 0).unwrap().unwrap();
            prop_assert_eq!(s.end(), s.start);
        }
    }
}
