//! Parametric art: circles, ellipses, epi/hypocycloids, epi/hypotrochoids (spirographs), roses, Lissajous figures,
//! spirals, Fourier-series outlines (the built-in Mickey) and their epicycles, as [`Drawing`]s in millimetres.
//!
//! A figure is named by a spec `KIND?param=value&param=value…` (the `gen:` prefix is accepted, so
//! `gen:epicycloid?q=3&r=10` works wherever a drawing can be loaded); [`from_spec`] turns it into a drawing and
//! [`KINDS`] lists the kinds with their parameters. Sampling is adaptive to a chord tolerance (`tol`, default
//! [`sampler::DEFAULT_TOLERANCE_MM`]) unless a fixed point count (`points`) is given; Fourier figures default to
//! the seed's 1000 fixed points.
//!
//! ## Placement
//! Curves are computed around their own origin with Y up, as in the textbooks; the drawing flips them to page
//! coordinates (Y down), so a Mickey's ears are on top. With `cx`/`cy` the figure's origin is put at that page
//! position (mm) and the drawing's page size is left unknown; without them the figure is moved so its bounding box
//! starts at ([`PAGE_MARGIN_MM`], [`PAGE_MARGIN_MM`]) and the page is the bounding box plus that margin all round —
//! like an SVG whose view box hugs its content, ready for the layout stage (`--paper a4 --fit`) to place on paper.
//!
//! ```
//! use plotter_path::kurbo::Point;
//!
//! let d = plotter_path::input::r#gen::from_spec("gen:epicycloid?q=3&r=10&cx=100&cy=100").unwrap();
//! let path = d.paths().next().unwrap();
//! assert!(path.is_closed());
//! // Every point lies between the fixed circle (R = q·r = 30 mm) and R + 2r = 50 mm from the centre.
//! let centre = Point::new(100.0, 100.0);
//! assert!(path.points.iter().all(|p| (30.0 - 1e-9..=50.0 + 1e-9).contains(&p.distance(centre))));
//! ```

pub mod circle;
mod error;
pub mod fourier;
pub mod hausdorff;
pub mod lissajous;
pub mod mickey;
pub mod outline;
pub mod rational;
pub mod rose;
pub mod roulette;
pub mod sampler;
mod spec;
pub mod spiral;

use kurbo::{Point, Vec2};

pub use circle::Ellipse;
pub use error::GenError;
pub use fourier::{Epicycle, FourierSeries};
pub use lissajous::Lissajous;
pub use mickey::MickeyOutline;
pub use outline::Outline;
pub use rational::Ratio;
pub use rose::Rose;
pub use roulette::{Rolling, Roulette};
pub use sampler::{Curve, Sampling, sample};
pub use spiral::Spiral;

use crate::{Drawing, Layer, Pen, Polyline, Rgb};
use spec::Params;

/// Chord tolerance (mm) used to sample an outline before a Fourier fit: fine enough that the polyline's own error
/// is negligible next to any truncation error worth measuring.
pub const FIT_TOLERANCE_MM: f64 = 1e-4;

/// Margin (mm) around the figure on the page of a drawing generated without `cx`/`cy`.
pub const PAGE_MARGIN_MM: f64 = 5.0;

/// Default turn limit for ratios (`max_turns`).
pub const DEFAULT_MAX_TURNS: u64 = 100;

/// Epicycle circles smaller than this (mm) are left out of the epicycles drawing: they are single dots.
pub const MIN_EPICYCLE_RADIUS_MM: f64 = 1e-6;

/// The figure kinds and their parameters (defaults in brackets), for help texts.
pub const KINDS: &[(&str, &str)] = &[
    ("circle", "r [50]"),
    ("ellipse", "rx [60], ry [40]"),
    ("epicycloid", "r rolling radius [10], q fixed/rolling radius ratio, a/b or decimal [3], max_turns [100]"),
    ("hypocycloid", "r [10], q [4], max_turns [100]"),
    ("epitrochoid", "r [10], q [3], d pen offset [5], max_turns [100]"),
    ("hypotrochoid", "r [15], q [8/3], d [12], max_turns [100]; alias: spirograph"),
    ("rose", "a petal length [50], k = n/d [5], max_turns [100]"),
    ("lissajous", "ax [50], ay [50] half-sizes, fx [3], fy [2] whole frequencies, phase degrees [90]"),
    ("spiral", "r0 [0], r1 [50], turns [10] (Archimedean)"),
    ("mickey-outline", "size head radius [40] (the exact circle outline)"),
    ("mickey", "size [40], harmonics [32], samples [1000] (Fourier fit of mickey-outline, 1000 points)"),
    ("fourier", "of closed kind [mickey-outline] and its parameters, harmonics [32], samples [1000]"),
    ("svg", "file, path: 1-based index [the longest closed path] — an SVG outline, for of=svg"),
    ("epicycles", "as fourier, plus at: instant 0..1 [0]; layers curve, circles, arms"),
];

/// Common parameters of every kind: `tol` (chord tolerance, mm), `points` (fixed count), `cx`, `cy` (placement).
pub const COMMON_PARAMS: &str = "tol, points, cx, cy";

/// A figure with its parameters, math orientation (Y up), centred on its own origin.
#[derive(Debug, Clone, PartialEq)]
pub enum Figure {
    /// A circle or ellipse.
    Ellipse(Ellipse),
    /// An epi/hypo cycloid or trochoid.
    Roulette(Roulette),
    /// A rose curve.
    Rose(Rose),
    /// A Lissajous figure.
    Lissajous(Lissajous),
    /// An Archimedean spiral (open).
    Spiral(Spiral),
    /// The exact Mickey outline.
    MickeyOutline(MickeyOutline),
    /// A closed outline read from a file (math orientation).
    Outline(Outline),
    /// A Fourier fit of another (closed) figure's outline.
    Fourier {
        /// The outline fitted.
        of: Box<Figure>,
        /// Harmonics N (terms −N … N).
        harmonics: usize,
        /// Arc-length samples of the outline the transform uses.
        samples: usize,
    },
    /// A Fourier fit drawn with its epicycles at one instant.
    Epicycles {
        /// The outline fitted.
        of: Box<Figure>,
        /// Harmonics N.
        harmonics: usize,
        /// Arc-length samples.
        samples: usize,
        /// The instant `s ∈ [0, 1)` at which the circles are drawn.
        at: f64,
    },
}

/// A parsed spec: the figure, how to sample it and where to put it.
#[derive(Debug, Clone, PartialEq)]
pub struct Spec {
    /// The figure kind as named in the spec (lower-cased; `spirograph` for the alias).
    pub kind: String,
    /// The figure.
    pub figure: Figure,
    /// How curves are turned into points.
    pub sampling: Sampling,
    /// Where the figure's origin goes on the page (mm); `None` moves the bounding box to (0, 0).
    pub centre: Option<Point>,
}

/// Parse a spec and generate its drawing.
///
/// # Errors
/// Any [`GenError`]: malformed spec, unknown kind or parameter, out-of-range value, non-closing ratio, too many
/// harmonics for the samples.
pub fn from_spec(spec: &str) -> Result<Drawing, GenError> {
    Spec::parse(spec)?.to_drawing()
}

/// `value` if positive and finite, else [`GenError::BadValue`] naming `kind` and `param`.
pub(crate) fn positive(kind: &str, param: &str, value: f64) -> Result<f64, GenError> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(GenError::BadValue {
            kind: kind.to_string(),
            param: param.to_string(),
            value: value.to_string(),
            problem: "must be a positive number of millimetres".to_string(),
        })
    }
}

impl Spec {
    /// Parse `KIND?param=value&…` (optionally prefixed `gen:`).
    ///
    /// # Errors
    /// See [`from_spec`].
    pub fn parse(text: &str) -> Result<Spec, GenError> {
        let mut params = Params::parse(text)?;
        let kind = params.kind().to_string();
        let fourier_default = matches!(kind.as_str(), "mickey" | "fourier" | "epicycles");
        let figure = figure(&kind, &mut params)?;
        let tol = params.opt_f64("tol")?;
        let points = params.opt_count("points", 3, u64::try_from(sampler::MAX_POINTS).unwrap_or(u64::MAX))?;
        let sampling = match (tol, points) {
            (Some(_), Some(_)) => {
                return Err(GenError::Syntax {
                    spec: text.to_string(),
                    problem: "give either tol (adaptive sampling) or points (fixed count), not both".to_string(),
                });
            }
            (Some(t), None) => Sampling::Adaptive(t),
            (None, Some(n)) => Sampling::Fixed(usize::try_from(n).unwrap_or(usize::MAX)),
            (None, None) if fourier_default => Sampling::Fixed(1000),
            (None, None) => Sampling::default(),
        };
        let cx = params.opt_f64("cx")?;
        let cy = params.opt_f64("cy")?;
        let centre = match (cx, cy) {
            (None, None) => None,
            (x, y) => Some(Point::new(x.unwrap_or(0.0), y.unwrap_or(0.0))),
        };
        params.finish()?;
        Ok(Spec { kind, figure, sampling, centre })
    }

    /// Generate the drawing (see the module docs for placement).
    ///
    /// # Errors
    /// Sampling errors ([`GenError::BadValue`] for a bad `tol`/`points`, [`GenError::TooManyPoints`]) and fit
    /// errors ([`GenError::TooManyHarmonics`], [`GenError::BadOutline`]).
    pub fn to_drawing(&self) -> Result<Drawing, GenError> {
        let layers = self.figure.layers(&self.kind, self.sampling)?;
        let mut drawing = Drawing { layers, page_mm: None };
        let offset = match self.centre {
            Some(c) => c.to_vec2(),
            None => Vec2::ZERO,
        };
        drawing.map_points(|p| Point::new(p.x, -p.y) + offset);
        if self.centre.is_none()
            && let Some(b) = drawing.bbox()
        {
            let shift = Vec2::new(PAGE_MARGIN_MM - b.x0, PAGE_MARGIN_MM - b.y0);
            drawing.map_points(|p| p + shift);
            drawing.page_mm = Some((b.width() + 2.0 * PAGE_MARGIN_MM, b.height() + 2.0 * PAGE_MARGIN_MM));
        }
        Ok(drawing)
    }
}

/// Build the figure `kind` from `params`.
fn figure(kind: &str, p: &mut Params) -> Result<Figure, GenError> {
    let epi = Rolling::Epi;
    let hypo = Rolling::Hypo;
    let whole = |n: u64| Ratio { num: n, den: 1 };
    Ok(match kind {
        "circle" => Figure::Ellipse(Ellipse::circle(p.f64("r", 50.0)?)?),
        "ellipse" => Figure::Ellipse(Ellipse::new(p.f64("rx", 60.0)?, p.f64("ry", 40.0)?)?),
        "epicycloid" | "hypocycloid" => {
            let (rolling, q0) = if kind == "epicycloid" { (epi, whole(3)) } else { (hypo, whole(4)) };
            let r = p.f64("r", 10.0)?;
            let max_turns = p.count("max_turns", DEFAULT_MAX_TURNS, 1, 1_000_000)?;
            Figure::Roulette(Roulette::cycloid(rolling, r, p.ratio("q", q0, max_turns)?)?)
        }
        "epitrochoid" | "hypotrochoid" | "spirograph" => {
            let (rolling, r0, q0, d0) = if kind == "epitrochoid" {
                (epi, 10.0, whole(3), 5.0)
            } else {
                (hypo, 15.0, Ratio { num: 8, den: 3 }, 12.0)
            };
            let r = p.f64("r", r0)?;
            let d = p.f64("d", d0)?;
            let max_turns = p.count("max_turns", DEFAULT_MAX_TURNS, 1, 1_000_000)?;
            Figure::Roulette(Roulette::trochoid(rolling, r, p.ratio("q", q0, max_turns)?, d)?)
        }
        "rose" => {
            let a = p.f64("a", 50.0)?;
            let max_turns = p.count("max_turns", DEFAULT_MAX_TURNS, 1, 1_000_000)?;
            Figure::Rose(Rose::new(a, p.ratio("k", whole(5), max_turns)?)?)
        }
        "lissajous" => {
            let max = u64::from(lissajous::MAX_FREQUENCY);
            let ax = p.f64("ax", 50.0)?;
            let ay = p.f64("ay", 50.0)?;
            let fx = u32::try_from(p.count("fx", 3, 1, max)?).unwrap_or(1);
            let fy = u32::try_from(p.count("fy", 2, 1, max)?).unwrap_or(1);
            let phase = p.f64("phase", 90.0)?.to_radians();
            Figure::Lissajous(Lissajous::new(ax, ay, fx, fy, phase)?)
        }
        "spiral" => Figure::Spiral(Spiral::new(p.f64("r0", 0.0)?, p.f64("r1", 50.0)?, p.f64("turns", 10.0)?)?),
        "mickey-outline" => Figure::MickeyOutline(MickeyOutline::new(p.f64("size", 40.0)?)?),
        "svg" => {
            let Some(file) = p.text("file") else {
                return Err(GenError::BadValue {
                    kind: kind.to_string(),
                    param: "file".to_string(),
                    value: String::new(),
                    problem: "the SVG file to take the outline from is required".to_string(),
                });
            };
            let index = p.opt_count("path", 1, u64::MAX)?;
            Figure::Outline(svg_outline(&file, index)?)
        }
        "mickey" | "fourier" | "epicycles" => {
            let of_kind = if kind == "mickey" {
                "mickey-outline".to_string()
            } else {
                p.text("of").unwrap_or_else(|| "mickey-outline".to_string()).to_ascii_lowercase()
            };
            if matches!(of_kind.as_str(), "mickey" | "fourier" | "epicycles") {
                return Err(GenError::BadValue {
                    kind: kind.to_string(),
                    param: "of".to_string(),
                    value: of_kind,
                    problem: "must be a plain closed curve kind (e.g. mickey-outline, epicycloid, rose)".to_string(),
                });
            }
            let harmonics = usize::try_from(p.count("harmonics", 32, 1, 100_000)?).unwrap_or(usize::MAX);
            let samples = usize::try_from(p.count("samples", 1000, 3, 10_000_000)?).unwrap_or(usize::MAX);
            if 2 * harmonics + 1 > samples {
                return Err(GenError::TooManyHarmonics { harmonics, samples });
            }
            let at = if kind == "epicycles" { p.f64("at", 0.0)? } else { 0.0 };
            p.set_kind(&of_kind);
            let of = Box::new(figure(&of_kind, p)?);
            p.set_kind(kind);
            if kind == "epicycles" {
                Figure::Epicycles { of, harmonics, samples, at }
            } else {
                Figure::Fourier { of, harmonics, samples }
            }
        }
        other => {
            return Err(GenError::UnknownKind {
                kind: other.to_string(),
                known: KINDS.iter().map(|k| k.0).collect::<Vec<_>>().join(", ") + ", spirograph",
            });
        }
    })
}

impl Figure {
    /// The figure as a single curve, when it is one (everything but epicycles).
    fn curve(&self) -> Result<Option<Box<dyn Curve + '_>>, GenError> {
        Ok(Some(match self {
            Figure::Ellipse(c) => Box::new(*c),
            Figure::Roulette(c) => Box::new(*c),
            Figure::Rose(c) => Box::new(*c),
            Figure::Lissajous(c) => Box::new(*c),
            Figure::Spiral(c) => Box::new(*c),
            Figure::MickeyOutline(c) => Box::new(c.clone()),
            Figure::Outline(c) => Box::new(c.clone()),
            Figure::Fourier { of, harmonics, samples } => Box::new(of.fit(*harmonics, *samples)?),
            Figure::Epicycles { .. } => return Ok(None),
        }))
    }

    /// Fit a Fourier series to this figure's outline.
    ///
    /// # Errors
    /// [`GenError::BadOutline`] when the figure is not one closed curve; [`GenError::TooManyHarmonics`].
    pub fn fit(&self, harmonics: usize, samples: usize) -> Result<FourierSeries, GenError> {
        let curve = self.curve()?.ok_or_else(|| GenError::BadOutline {
            what: "epicycles".to_string(),
            problem: "it is several curves, not one outline".to_string(),
        })?;
        if !curve.is_closed() {
            return Err(GenError::BadOutline {
                what: format!("a {}", curve.name()),
                problem: "it is an open curve".to_string(),
            });
        }
        let outline = sample(curve.as_ref(), Sampling::Adaptive(FIT_TOLERANCE_MM))?;
        FourierSeries::fit_outline(&outline, harmonics, samples)
    }

    /// The figure's layers in math orientation, each curve sampled with `sampling`.
    ///
    /// # Errors
    /// As [`Spec::to_drawing`].
    pub fn layers(&self, name: &str, sampling: Sampling) -> Result<Vec<Layer>, GenError> {
        if let Figure::Epicycles { of, harmonics, samples, at } = self {
            return epicycle_layers(&of.fit(*harmonics, *samples)?, *at, sampling);
        }
        let curve = self.curve()?.ok_or_else(|| GenError::BadOutline {
            what: name.to_string(),
            problem: "not a single curve".to_string(),
        })?;
        let mut layer = Layer::new(name);
        layer.paths.push(sample(curve.as_ref(), sampling)?);
        Ok(vec![layer])
    }
}

/// The closed path number `index` (1-based, in plotting order) of the SVG `file`, or its longest closed path, in
/// math orientation (Y flipped, so the generated drawing shows it the right way up). The file's other paths, and
/// the importer's warnings about elements it skipped, are not used: only the one outline matters here.
fn svg_outline(file: &str, index: Option<u64>) -> Result<Outline, GenError> {
    let options = crate::input::svg::SvgOptions { tolerance_mm: FIT_TOLERANCE_MM * 10.0, ..Default::default() };
    let imported = crate::input::svg::load_svg(std::path::Path::new(file), &options)
        .map_err(|e| GenError::OutlineFile { file: file.to_string(), problem: e.to_string() })?;
    let paths: Vec<&Polyline> = imported.drawing.paths().collect();
    let (number, path) = match index {
        Some(i) => {
            let n = usize::try_from(i).unwrap_or(usize::MAX);
            let path = paths.get(n - 1).ok_or_else(|| GenError::OutlineFile {
                file: file.to_string(),
                problem: format!("there is no path {i}; it has {} paths", paths.len()),
            })?;
            (n, *path)
        }
        None => paths
            .iter()
            .enumerate()
            .filter(|(_, p)| p.is_closed())
            .max_by(|a, b| a.1.length().total_cmp(&b.1.length()))
            .map(|(i, p)| (i + 1, *p))
            .ok_or_else(|| GenError::OutlineFile {
                file: file.to_string(),
                problem: format!("none of its {} paths is closed", paths.len()),
            })?,
    };
    let flipped = Polyline::new(path.points.iter().map(|p| Point::new(p.x, -p.y)).collect());
    Outline::new(flipped, &format!("path {number} of {file}"))
}

/// Layers `curve`, `circles` and `arms` of the epicycle view of `series` at instant `at`.
fn epicycle_layers(series: &FourierSeries, at: f64, sampling: Sampling) -> Result<Vec<Layer>, GenError> {
    if !(0.0..=1.0).contains(&at) {
        return Err(GenError::BadValue {
            kind: "epicycles".to_string(),
            param: "at".to_string(),
            value: at.to_string(),
            problem: "instant must be between 0 and 1 (fraction of one traversal)".to_string(),
        });
    }
    let circle_sampling = match sampling {
        Sampling::Adaptive(t) => Sampling::Adaptive(t),
        Sampling::Fixed(_) => Sampling::default(),
    };
    let mut curve = Layer::new("curve");
    curve.paths.push(sample(series, sampling)?);
    let chain = series.epicycles(at);
    let mut circles = Layer::new("circles");
    circles.pen = Pen { color: Rgb(0x4a, 0x78, 0xb0), width_mm: 0.2 };
    for e in chain.iter().filter(|e| e.radius >= MIN_EPICYCLE_RADIUS_MM) {
        let mut path = sample(&Ellipse { rx: e.radius, ry: e.radius }, circle_sampling)?;
        let c = e.centre.to_vec2();
        path.points.iter_mut().for_each(|p| *p += c);
        circles.paths.push(path);
    }
    let mut arms = Layer::new("arms");
    arms.pen = Pen { color: Rgb(0xc0, 0x30, 0x30), width_mm: 0.2 };
    if let Some(first) = chain.first() {
        let mut pts = vec![first.centre];
        pts.extend(chain.iter().map(|e| e.tip));
        arms.paths.push(Polyline::new(pts));
    }
    Ok(vec![curve, circles, arms])
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn ratio(a: u64, b: u64) -> Ratio {
        let g = (1..=a.min(b)).rev().find(|g| a.is_multiple_of(*g) && b.is_multiple_of(*g)).unwrap_or(1);
        Ratio { num: a / g, den: b / g }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(512))]
        /// Every generator, with random parameters, meets the chord tolerance when sampled adaptively.
        #[test]
        fn generators_meet_chord_tolerance(
            which in 0usize..8,
            r in 1.0f64..40.0,
            a in 1u64..9,
            b in 1u64..5,
            d in 0.5f64..60.0,
            tol in 0.005f64..0.3,
        ) {
            let q = ratio(a, b);
            let curve: Box<dyn Curve> = match which {
                0 => Box::new(Roulette::cycloid(Rolling::Epi, r, q).unwrap()),
                1 if q.num != q.den => Box::new(Roulette::cycloid(Rolling::Hypo, r, q).unwrap()),
                2 => Box::new(Roulette::trochoid(Rolling::Epi, r, q, d).unwrap()),
                3 if q.num != q.den => Box::new(Roulette::trochoid(Rolling::Hypo, r, q, d).unwrap()),
                4 => Box::new(Rose::new(d, q).unwrap()),
                5 => Box::new(Spiral::new(r, r + d, d / 2.0).unwrap()),
                6 => Box::new(Figure::MickeyOutline(MickeyOutline::new(r).unwrap()).fit(usize::try_from(a * 4).unwrap(), 512).unwrap()),
                _ => Box::new(Lissajous::new(r, d, u32::try_from(a).unwrap(), u32::try_from(b).unwrap(), r).unwrap()),
            };
            let worst = sampler::worst_chord_error(curve.as_ref(), tol);
            prop_assert!(worst <= tol, "{}: worst chord error {} > {}", curve.name(), worst, tol);
        }
    }

    #[test]
    fn every_kind_generates_with_defaults() {
        for (kind, _) in KINDS.iter().chain(&[("spirograph", "")]).filter(|k| k.0 != "svg") {
            let d = from_spec(kind).unwrap_or_else(|e| panic!("{kind}: {e}"));
            assert!(!d.is_empty(), "{kind}");
            let b = d.bbox().unwrap();
            let m = PAGE_MARGIN_MM;
            assert!((b.x0 - m).abs() < 1e-9 && (b.y0 - m).abs() < 1e-9, "{kind}: {b:?}");
            let (w, h) = d.page_mm.unwrap();
            assert!((w - b.width() - 2.0 * m).abs() < 1e-9 && (h - b.height() - 2.0 * m).abs() < 1e-9, "{kind}");
            for p in d.paths() {
                assert!(p.points.len() > 8, "{kind}");
            }
        }
    }

    #[test]
    fn epicycloid_spec_in_page_coordinates() {
        // Centre at (100, 80): the cusp at θ = 0 is at (30, 0) math → (130, 80) page; the point at θ = π/3 is
        // (25, 25√3) math → Y flips to below the centre line... on the page, above: y = 80 − 25√3.
        let d = from_spec("gen:epicycloid?q=3&r=10&cx=100&cy=80&points=600").unwrap();
        assert_eq!(d.page_mm, None);
        let path = d.paths().next().unwrap();
        assert_eq!(path.points.len(), 601);
        assert!(path.is_closed());
        assert!(path.points[0].distance(Point::new(130.0, 80.0)) < 1e-9);
        assert!(path.points[100].distance(Point::new(125.0, 80.0 - 25.0 * 3f64.sqrt())) < 1e-9);
        assert_eq!(d.layers[0].name, "epicycloid");
    }

    #[test]
    fn mickey_default_is_32_harmonics_on_1000_points() {
        let spec = Spec::parse("mickey").unwrap();
        assert_eq!(spec.sampling, Sampling::Fixed(1000));
        let Figure::Fourier { harmonics, samples, .. } = &spec.figure else { panic!("{spec:?}") };
        assert_eq!((*harmonics, *samples), (32, 1000));
        let d = spec.to_drawing().unwrap();
        let p = d.paths().next().unwrap();
        assert_eq!(p.points.len(), 1001);
        assert!(p.is_closed());
        // Ears on top: in page coordinates the top of the bounding box is ear, about 3.1 × 2.65 head radii.
        let b = d.bbox().unwrap();
        assert!((b.width() - 124.0).abs() < 3.0 && (b.height() - 106.0).abs() < 3.0, "{b:?}");
    }

    #[test]
    fn epicycles_end_on_the_curve() {
        let d = from_spec("epicycles?harmonics=8&at=0.3&tol=0.01").unwrap();
        assert_eq!(d.layers.iter().map(|l| l.name.as_str()).collect::<Vec<_>>(), ["curve", "circles", "arms"]);
        assert_eq!(d.layers[1].paths.len(), 16);
        let arm = &d.layers[2].paths[0];
        assert_eq!(arm.points.len(), 17);
        // The arm's tip lies on the fitted curve (within the curve's sampling tolerance).
        let tip = *arm.points.last().unwrap();
        let curve = &d.layers[0].paths[0].points;
        assert!(hausdorff::directed(&[tip], curve) < 0.01);
    }

    fn fit_error(kind: &str, params: &str, harmonics: usize) -> f64 {
        let fit = format!("fourier?of={kind}&{params}&harmonics={harmonics}&samples=4096&tol=0.001");
        let fit = from_spec(&fit).unwrap();
        let exact = from_spec(&format!("{kind}?{params}&tol=0.001")).unwrap();
        hausdorff::hausdorff(&fit.paths().next().unwrap().points, &exact.paths().next().unwrap().points)
    }

    #[test]
    fn fourier_of_any_closed_kind() {
        // A smooth epitrochoid converges fast under the arc-length fit (about 11× per doubling of N: 0.16, 0.012,
        // 0.0011 mm at N = 16, 32, 64); the epicycloid's cusps (corners in arc length) slow it to about 1/N (2.1,
        // 1.0, 0.51 mm), but its error still falls as harmonics are added.
        let smooth: Vec<f64> = [16, 32, 64].iter().map(|&n| fit_error("epitrochoid", "q=3&r=10&d=5", n)).collect();
        assert!(smooth[0] > 8.0 * smooth[1] && smooth[1] > 8.0 * smooth[2] && smooth[2] < 0.002, "{smooth:?}");
        let cusped: Vec<f64> = [16, 32, 64].iter().map(|&n| fit_error("epicycloid", "q=3&r=10", n)).collect();
        assert!(cusped[0] > 1.8 * cusped[1] && cusped[1] > 1.8 * cusped[2] && cusped[2] < 1.0, "{cusped:?}");
        let e = from_spec("fourier?of=spiral").unwrap_err();
        assert!(e.to_string().contains("open curve"), "{e}");
        let e = from_spec("fourier?of=fourier").unwrap_err();
        assert!(e.to_string().contains("plain closed curve"), "{e}");
    }

    #[test]
    fn fourier_of_an_svg_outline() {
        let dir = std::env::temp_dir().join(format!("plotter-gen-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("shapes.svg");
        // An open line, a small square and a big circle (r = 30 mm): the circle is the longest closed path.
        std::fs::write(
            &file,
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="200mm" height="200mm" viewBox="0 0 200 200">
            <path d="M0 0 L50 50" stroke="black" fill="none"/>
            <rect x="10" y="10" width="20" height="20" stroke="black" fill="none"/>
            <circle cx="100" cy="100" r="30" stroke="black" fill="none"/></svg>"#,
        )
        .unwrap();
        let f = file.display();
        // A circle needs one harmonic: the fit is a circle of radius 30 (to the flattening tolerance).
        let d = from_spec(&format!("fourier?of=svg&file={f}&harmonics=1&samples=64&cx=0&cy=0")).unwrap();
        let path = d.paths().next().unwrap();
        let centre = Point::new(100.0, 100.0);
        for p in &path.points {
            assert!((p.distance(centre) - 30.0).abs() < 0.01, "{p:?}");
        }
        // The square by number: its bounding box is the square's.
        let d = from_spec(&format!("svg?file={f}&path=2&cx=0&cy=0")).unwrap();
        let b = d.bbox().unwrap();
        assert!((b.x0 - 10.0).abs() < 1e-9 && (b.y1 - 30.0).abs() < 1e-9, "{b:?}");
        let e = from_spec(&format!("fourier?of=svg&file={f}&path=1")).unwrap_err().to_string();
        assert!(e.contains("path 1 of") && e.contains("not a closed path"), "{e}");
        let e = from_spec(&format!("fourier?of=svg&file={f}&path=9")).unwrap_err().to_string();
        assert!(e.contains("there is no path 9; it has 3 paths"), "{e}");
        let e = from_spec("fourier?of=svg").unwrap_err().to_string();
        assert!(e.contains("file") && e.contains("required"), "{e}");
        let e = from_spec("fourier?of=svg&file=/definitely/missing.svg").unwrap_err().to_string();
        assert!(e.contains("cannot take an outline from /definitely/missing.svg"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn bad_specs_are_clear_errors() {
        let cases = [
            ("epicycloid?q=1.41421356237", "does not close within 100 turns; give it as a fraction"),
            ("epicycloid?q=1.41421356237&max_turns=5", "does not close within 5 turns"),
            ("hypocycloid?q=1000/999", "does not close within 100 turns (it needs 999)"),
            ("rose?k=3.14159265359", "rose: k=3.14159265359 does not close"),
            ("circle?r=0", "circle: parameter r=\"0\": must be a positive number"),
            ("epitrochoid?r=-5", "epitrochoid: parameter r=\"-5\": must be a positive"),
            ("spirograph?d=0", "hypotrochoid: parameter d=\"0\""),
            ("ellipse?rx=10&ry=-1", "ellipse: parameter ry="),
            ("mickey?harmonics=600", "600 harmonics need at least 1201 samples of the outline, but only 1000"),
            ("mickey?harmonics=10&samples=20", "10 harmonics need at least 21 samples"),
            ("mickey?size=0", "mickey: parameter size=\"0\""),
            ("triangle", "unknown figure kind \"triangle\" (known: circle, ellipse,"),
            ("circle?radius=3", "circle: unknown parameter \"radius\" (accepted: r, tol, points, cx, cy)"),
            ("circle?tol=0.1&points=100", "either tol (adaptive sampling) or points"),
            ("circle?points=2", "parameter points=\"2\": must be a whole number from 3"),
            ("circle?tol=0", "tol"),
            ("epicycles?at=2", "instant must be between 0 and 1"),
            ("lissajous?fx=0", "lissajous: parameter fx=\"0\""),
            ("spiral?turns=-1", "spiral: parameter turns="),
        ];
        for (spec, want) in cases {
            let e = from_spec(spec).expect_err(spec).to_string();
            assert!(e.contains(want), "{spec}: got {e:?}, want {want:?}");
        }
    }
}
