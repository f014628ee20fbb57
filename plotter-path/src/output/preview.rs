//! Preview PNGs rendered with tiny-skia: the paper outline, pen-down strokes in each path's own colour and width
//! (or its layer's pen), and
//! optionally the pen-up travel as a thin dashed overlay.
//!
//! A preview of what a machine will draw first passes the drawing through [`use_plotting_pens`]: every line is then
//! drawn at the width of the pen that plots it (the profile's pen table, else its `[pen]` width) in the layer's pen
//! colour, not at the stroke width the source file gave it (a 0.01 mm hairline, a 1.69 mm drop shadow).
//!
//! The same renderer serves every stage: the ideal paths of a drawing, a generated figure, and the "as-stepped"
//! preview that the plot command builds from the simulator's step trace (pass those polylines as a drawing and
//! the recorded pen-up moves as `travel`).
//!
//! # Bounded memory and time
//! The image is at most [`MAX_SIDE_PX`] per side and [`MAX_PIXELS`] in all (256 MB of RGBA): a larger request
//! (a big drawing at a high DPI, or absurd coordinates) is rendered at the largest resolution that fits, and
//! [`reduction_note`] says so for the caller to show. Polylines are thinned to a quarter pixel before they reach
//! the rasteriser (invisible on the image) and stroked in chunks, so a trace with millions of points — an
//! as-stepped preview has one per motor step — costs memory in proportion to the image, not to the point count.
//! Stroke widths are clamped to the view (a pen wider than the whole image paints it all anyway; tiny-skia panics
//! on some huge widths), and drawings beyond [`crate::geometry::limits`] are refused.

use std::path::Path;

use kurbo::{Line, Rect};
use tiny_skia::{Color, FillRule, LineCap, LineJoin, Paint, PathBuilder, Pixmap, Stroke, StrokeDash, Transform};

use crate::config::pens::{self, Pen};
use crate::config::profile::MachineProfile;
use crate::geometry::drawing::{Drawing, Rgb};
use crate::geometry::limits::{self, LimitError};
use crate::geometry::travel::pen_up_moves;

/// Largest image side in pixels.
pub const MAX_SIDE_PX: u32 = 20_000;

/// Most pixels in one image (4 bytes each: 256 MB).
pub const MAX_PIXELS: f64 = 64.0 * 1024.0 * 1024.0;

/// Most points in one rasterised path (tiny-skia's stroker needs several hundred bytes per point).
const CHUNK_POINTS: usize = 16_384;

/// Thinning distance, pixels: a point closer than this to the last kept one is skipped.
const THIN_PX: f64 = 0.25;

/// Errors rendering or saving a preview.
#[derive(Debug, thiserror::Error)]
pub enum PreviewError {
    /// The requested image is empty (or its size is not a number).
    #[error("preview size {width}×{height} px is empty; raise --dpi or --width-px")]
    Size {
        /// Requested width, px.
        width: f64,
        /// Requested height, px.
        height: f64,
    },
    /// The drawing exceeds the size limits.
    #[error(transparent)]
    Limit(#[from] LimitError),
    /// PNG encoding or writing failed.
    #[error("cannot write preview {path}: {message}")]
    Write {
        /// Output file.
        path: String,
        /// What went wrong.
        message: String,
    },
}

/// How a preview is drawn.
#[derive(Debug, Clone, PartialEq)]
pub struct PreviewOptions {
    /// Resolution in pixels per inch (ignored when `width_px` is set).
    pub dpi: f64,
    /// Fixed output width in pixels; the height follows the aspect ratio.
    pub width_px: Option<u32>,
    /// Draw the pen-up travel as a dashed overlay.
    pub travel: bool,
    /// Colour of the travel overlay.
    pub travel_color: Rgb,
    /// Draw the paper outline.
    pub paper: bool,
    /// Minimum stroke width on the image, pixels (so fine pens stay visible at low DPI).
    pub min_stroke_px: f64,
    /// Maximum stroke width, mm (an SVG's wide strokes would otherwise hide the lines the pen draws).
    pub max_stroke_mm: f64,
}

impl Default for PreviewOptions {
    fn default() -> Self {
        PreviewOptions {
            dpi: 96.0,
            width_px: None,
            travel: false,
            travel_color: Rgb(230, 40, 90),
            paper: true,
            min_stroke_px: 1.0,
            max_stroke_mm: 1.0,
        }
    }
}

/// The pen that plots a layer named `name` whose own pen is `own`, as a preview draws it: the profile's pen table
/// pen for that layer (by name, else by colour; see [`pens::resolve`]) with its width when the table gives one,
/// else the profile's `[pen]` width; the colour is the table pen's, else the layer's. The source's stroke width
/// never counts: the pen draws the line, not the file.
pub fn plotting_pen(profile: &MachineProfile, name: &str, own: &Pen) -> Pen {
    let resolved = pens::resolve(profile, name, own);
    let table_width = resolved.table.and_then(|i| profile.pens.get(i)).and_then(|t| t.width_mm);
    Pen { color: resolved.color, width_mm: table_width.unwrap_or(profile.pen.width_mm) }
}

/// Make `drawing` look as `profile` plots it: every layer gets its [`plotting_pen`], and paths lose the colour
/// and width their source gave each of them (one pen draws the whole layer).
pub fn use_plotting_pens(drawing: &mut Drawing, profile: &MachineProfile) {
    for layer in &mut drawing.layers {
        layer.pen = plotting_pen(profile, &layer.name, &layer.pen);
        for path in &mut layer.paths {
            path.pen = None;
        }
    }
}

/// The region shown: the paper (if known) united with the drawing, with a small border.
fn view_rect(drawing: &Drawing) -> Rect {
    let paper = drawing.page_mm.map(|(w, h)| Rect::new(0.0, 0.0, w, h));
    let r = match (paper, drawing.bbox()) {
        (Some(p), Some(b)) => p.union(b),
        (Some(p), None) => p,
        (None, Some(b)) => b,
        (None, None) => Rect::new(0.0, 0.0, 10.0, 10.0),
    };
    let border = (r.width().max(r.height()) * 0.02).max(1.0);
    r.inflate(border, border)
}

fn color(c: Rgb, alpha: u8) -> Color {
    Color::from_rgba8(c.0, c.1, c.2, alpha)
}

/// Requested size (px) and scale (px per mm) of the preview of `view`, before any reduction.
fn requested(view: Rect, options: &PreviewOptions) -> (f64, f64, f64) {
    let scale = match options.width_px {
        Some(w) => f64::from(w) / view.width(),
        None => options.dpi / 25.4,
    };
    ((view.width() * scale).round(), (view.height() * scale).round(), scale)
}

/// The factor (≤ 1) by which a requested `w`×`h` image must shrink to fit [`MAX_SIDE_PX`] and [`MAX_PIXELS`].
fn reduction(w: f64, h: f64) -> f64 {
    let side = f64::from(MAX_SIDE_PX) / w.max(h);
    let area = (MAX_PIXELS / (w * h)).sqrt();
    side.min(area).min(1.0)
}

/// When the preview of `drawing` is rendered below the requested resolution (to cap its memory), a note saying
/// so, for the caller to show.
pub fn reduction_note(drawing: &Drawing, options: &PreviewOptions) -> Option<String> {
    let (w, h, _) = requested(view_rect(drawing), options);
    let f = reduction(w, h);
    (f < 1.0 && f.is_finite()).then(|| {
        format!(
            "the {w:.0}×{h:.0} px preview asked for exceeds {MAX_SIDE_PX} px per side or {:.0} Mpx; rendered at {:.0}×{:.0} px",
            MAX_PIXELS / 1e6,
            (w * f).round().max(1.0),
            (h * f).round().max(1.0)
        )
    })
}

/// Render `drawing` with the travel implied by its order (when `options.travel` is set).
pub fn render(drawing: &Drawing, options: &PreviewOptions) -> Result<Pixmap, PreviewError> {
    let travel = if options.travel { pen_up_moves(drawing) } else { Vec::new() };
    render_with_travel(drawing, &travel, options)
}

/// Render `drawing` with an explicit list of pen-up moves (drawn when `options.travel` is set).
pub fn render_with_travel(
    drawing: &Drawing,
    travel: &[Line],
    options: &PreviewOptions,
) -> Result<Pixmap, PreviewError> {
    limits::check_drawing(drawing, "preview")?;
    if let Some(l) = travel.iter().find(|l| !(limits::point_ok(l.p0) && limits::point_ok(l.p1))) {
        let p = if limits::point_ok(l.p0) { l.p1 } else { l.p0 };
        return Err(LimitError::Coordinate {
            origin: "preview".into(),
            layer: "travel".into(),
            path: 0,
            point: 0,
            x: p.x,
            y: p.y,
        }
        .into());
    }
    let view = view_rect(drawing);
    let (w, h, scale) = requested(view, options);
    if !(w >= 1.0 && h >= 1.0) {
        return Err(PreviewError::Size { width: w, height: h });
    }
    let f = reduction(w, h);
    let (w, h, scale) = ((w * f).round().max(1.0), (h * f).round().max(1.0), scale * f);
    // Both sides were checked to lie in 1..=MAX_SIDE_PX.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let mut pixmap = Pixmap::new(w as u32, h as u32).ok_or(PreviewError::Size { width: w, height: h })?;
    pixmap.fill(Color::WHITE);
    #[allow(clippy::cast_possible_truncation)]
    let transform =
        Transform::from_row(scale as f32, 0.0, 0.0, scale as f32, (-view.x0 * scale) as f32, (-view.y0 * scale) as f32);
    let px_per_mm = scale;

    if options.paper
        && let Some((pw, ph)) = drawing.page_mm
        && let Some(rect) = tiny_skia::Rect::from_xywh(0.0, 0.0, narrow(pw), narrow(ph))
    {
        let paper = PathBuilder::from_rect(rect);
        let mut paint = Paint::default();
        paint.set_color(Color::from_rgba8(246, 246, 240, 255));
        pixmap.fill_path(&paper, &paint, FillRule::Winding, transform, None);
        paint.set_color(Color::from_rgba8(150, 150, 150, 255));
        let stroke = Stroke { width: narrow(1.0 / px_per_mm), ..Stroke::default() };
        pixmap.stroke_path(&paper, &paint, &stroke, transform, None);
    }

    // A pen wider than the view's diagonal covers it all: clamp (tiny-skia panics on some huge widths).
    let widest = view.width().hypot(view.height());
    let thin = THIN_PX / px_per_mm;
    for layer in &drawing.layers {
        // Consecutive paths with the same pen are stroked together, each group with its own colour and width.
        let mut start = 0;
        while start < layer.paths.len() {
            let pen = layer.paths[start].pen.unwrap_or(layer.pen);
            let mut end = start + 1;
            while end < layer.paths.len() && layer.paths[end].pen.unwrap_or(layer.pen) == pen {
                end += 1;
            }
            let mut paint = Paint::default();
            paint.set_color(color(visible_on_paper(pen.color), 255));
            paint.anti_alias = true;
            let width_mm = pen.width_mm.min(options.max_stroke_mm).max(options.min_stroke_px / px_per_mm);
            let width_mm = if width_mm.is_finite() { width_mm.min(widest) } else { widest };
            let stroke = Stroke {
                width: narrow(width_mm),
                line_cap: LineCap::Round,
                line_join: LineJoin::Round,
                ..Stroke::default()
            };
            stroke_group(&mut pixmap, &layer.paths[start..end], &paint, &stroke, transform, thin);
            start = end;
        }
    }

    if options.travel && !travel.is_empty() {
        let mut paint = Paint::default();
        paint.set_color(color(options.travel_color, 200));
        paint.anti_alias = true;
        let unit = 1.0 / px_per_mm;
        let stroke = Stroke {
            width: narrow(unit * 0.8),
            dash: StrokeDash::new(vec![narrow(unit * 5.0), narrow(unit * 3.0)], 0.0),
            ..Stroke::default()
        };
        let mut chunk = Chunk::default();
        for l in travel {
            chunk.pb.move_to(narrow(l.p0.x), narrow(l.p0.y));
            chunk.pb.line_to(narrow(l.p1.x), narrow(l.p1.y));
            chunk.points += 2;
            if chunk.points >= CHUNK_POINTS {
                chunk.flush(&mut pixmap, &paint, &stroke, transform);
            }
        }
        chunk.flush(&mut pixmap, &paint, &stroke, transform);
    }
    Ok(pixmap)
}

/// Stroke `paths` with one paint and stroke, in chunks of at most [`CHUNK_POINTS`] points, thinning vertices
/// closer than `thin` mm (a fraction of a pixel).
fn stroke_group(
    pixmap: &mut Pixmap,
    paths: &[crate::geometry::drawing::Polyline],
    paint: &Paint<'_>,
    stroke: &Stroke,
    transform: Transform,
    thin: f64,
) {
    let mut chunk = Chunk::default();
    for path in paths {
        let mut pts = path.points.iter();
        let Some(&first) = pts.next() else { continue };
        chunk.pb.move_to(narrow(first.x), narrow(first.y));
        chunk.points += 1;
        let mut last = first;
        if path.points.len() == 1 {
            // A dot: a zero-length segment still shows with round caps.
            chunk.pb.line_to(narrow(first.x), narrow(first.y));
        }
        let n = path.points.len();
        let mut split = false;
        for (i, &p) in pts.enumerate() {
            // Thin to a fraction of a pixel; the last point is always kept.
            if i + 2 < n && p.distance(last) < thin {
                continue;
            }
            chunk.pb.line_to(narrow(p.x), narrow(p.y));
            chunk.points += 1;
            last = p;
            if chunk.points >= CHUNK_POINTS && i + 2 < n {
                // Continue the same polyline in a new path from this point.
                chunk.flush(pixmap, paint, stroke, transform);
                chunk.pb.move_to(narrow(p.x), narrow(p.y));
                split = true;
            }
        }
        // (A split closed path ends on its first point anyway; with round joins and caps it looks the same.)
        if path.is_closed() && !split {
            chunk.pb.close();
        }
        if chunk.points >= CHUNK_POINTS {
            chunk.flush(pixmap, paint, stroke, transform);
        }
    }
    chunk.flush(pixmap, paint, stroke, transform);
}

/// Colours too light to see on the paper (luminance above 0.85: white, pale yellow) are shown as grey.
fn visible_on_paper(c: Rgb) -> Rgb {
    let lum = 0.2126 * f64::from(c.0) + 0.7152 * f64::from(c.1) + 0.0722 * f64::from(c.2);
    if lum > 0.85 * 255.0 { Rgb(170, 170, 170) } else { c }
}

/// A path being built for the rasteriser, flushed every [`CHUNK_POINTS`] points.
#[derive(Default)]
struct Chunk {
    pb: PathBuilder,
    points: usize,
}

impl Chunk {
    fn flush(&mut self, pixmap: &mut Pixmap, paint: &Paint<'_>, stroke: &Stroke, transform: Transform) {
        if let Some(shape) = std::mem::take(&mut self.pb).finish() {
            pixmap.stroke_path(&shape, paint, stroke, transform, None);
        }
        self.points = 0;
    }
}

/// f64 → f32 for drawing coordinates (precision loss is far below a pixel).
#[allow(clippy::cast_possible_truncation)]
fn narrow(v: f64) -> f32 {
    v as f32
}

/// Render and encode as PNG bytes.
pub fn render_png(drawing: &Drawing, options: &PreviewOptions) -> Result<Vec<u8>, PreviewError> {
    encode(&render(drawing, options)?, "<memory>")
}

fn encode(pixmap: &Pixmap, shown: &str) -> Result<Vec<u8>, PreviewError> {
    pixmap.encode_png().map_err(|e| PreviewError::Write { path: shown.to_string(), message: e.to_string() })
}

/// Render and write a PNG file.
pub fn save_png(drawing: &Drawing, options: &PreviewOptions, path: &Path) -> Result<(), PreviewError> {
    save_pixmap(&render(drawing, options)?, path)
}

/// Write an already rendered preview to a PNG file.
pub fn save_pixmap(pixmap: &Pixmap, path: &Path) -> Result<(), PreviewError> {
    let shown = path.display().to_string();
    let bytes = encode(pixmap, &shown)?;
    std::fs::write(path, bytes).map_err(|e| PreviewError::Write { path: shown, message: e.to_string() })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::drawing::{Layer, Polyline};
    use kurbo::Point;

    fn pixel(p: &Pixmap, x: u32, y: u32) -> (u8, u8, u8) {
        let c = p.pixel(x, y).unwrap();
        (c.red(), c.green(), c.blue())
    }

    #[test]
    fn strokes_land_where_the_geometry_is() {
        let mut d = Drawing::single_layer(
            "l",
            vec![
                Polyline::new(vec![Point::new(10.0, 10.0), Point::new(90.0, 10.0)]),
                Polyline::new(vec![Point::new(10.0, 50.0), Point::new(90.0, 50.0)]),
            ],
        );
        d.page_mm = Some((100.0, 100.0));
        d.layers[0].pen.color = Rgb(0, 0, 255);
        // 25.4 dpi → 1 px per mm; view = page inflated by 2 mm border.
        let opts = PreviewOptions { dpi: 25.4, travel: true, min_stroke_px: 2.0, ..PreviewOptions::default() };
        let p = render(&d, &opts).unwrap();
        assert_eq!((p.width(), p.height()), (104, 104));
        assert_eq!(pixel(&p, 2 + 50, 2 + 10), (0, 0, 255));
        assert_eq!(pixel(&p, 2 + 50, 2 + 80), (246, 246, 240), "paper below the strokes");
        assert_eq!(pixel(&p, 0, 0), (255, 255, 255), "outside the paper");
        // The travel from (90,10) to (10,50) crosses x=50 at y=30: somewhere near it is tinted.
        let tinted = (26..35).any(|y| {
            let (r, g, _) = pixel(&p, 52, 2 + y);
            u16::from(r) > u16::from(g) + 40
        });
        assert!(tinted, "travel overlay drawn");
    }

    #[test]
    fn each_path_has_its_own_colour_and_a_clamped_width() {
        let red = Pen { color: Rgb(255, 0, 0), width_mm: 4.4 };
        let green = Pen { color: Rgb(0, 160, 0), width_mm: 0.3 };
        let mut d = Drawing::single_layer(
            "l",
            vec![
                Polyline::with_pen(vec![Point::new(10.0, 20.0), Point::new(90.0, 20.0)], red),
                Polyline::with_pen(vec![Point::new(10.0, 60.0), Point::new(90.0, 60.0)], green),
                Polyline::with_pen(
                    vec![Point::new(10.0, 80.0), Point::new(90.0, 80.0)],
                    Pen { color: Rgb(255, 255, 255), width_mm: 1.0 },
                ),
            ],
        );
        d.page_mm = Some((100.0, 100.0));
        // 254 dpi → 10 px per mm; the view starts 2 mm before the page.
        let opts = PreviewOptions { dpi: 254.0, ..PreviewOptions::default() };
        let p = render(&d, &opts).unwrap();
        // Page positions well inside the image: small positive values.
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let at = |x: f64, y: f64| pixel(&p, ((x + 2.0) * 10.0) as u32, ((y + 2.0) * 10.0) as u32);
        assert_eq!(at(50.0, 20.0), (255, 0, 0));
        assert_eq!(at(50.0, 60.0), (0, 160, 0));
        // 4.4 mm is clamped to 1 mm: 0.8 mm off the line is paper, not red.
        assert_eq!(at(50.0, 20.8), (246, 246, 240));
        assert_eq!(at(50.0, 20.3), (255, 0, 0));
        // White ink is shown grey so it does not vanish.
        assert_eq!(at(50.0, 80.0), (170, 170, 170));
    }

    /// Rows of column `x` painted in `ink`.
    fn rows_of(p: &Pixmap, x: u32, ink: (u8, u8, u8)) -> Vec<u32> {
        (0..p.height()).filter(|&y| pixel(p, x, y) == ink).collect()
    }

    /// The pen table decides the width: a 0.01 mm hairline and a 1.69 mm grey drop shadow are both drawn at the
    /// profile's 0.5 mm pen in the layer's colour. At 254 dpi (10 px/mm) with the view starting 1 mm before a
    /// 20 × 10 mm page, a line at y = 5.05 mm is centred on pixel row edge 60.5 px, so a 0.5 mm (5 px) pen covers
    /// rows 58..=62 exactly: five rows, fully inked.
    #[test]
    fn lines_are_drawn_at_the_pen_tables_width_not_the_files() {
        let mut profile = MachineProfile::default_plotter();
        profile.pen.width_mm = 0.5;
        // No pen table at first: the `[pen]` width draws every layer.
        profile.pens.clear();
        let line = |y: f64, pen: Pen| Polyline::with_pen(vec![Point::new(2.0, y), Point::new(18.0, y)], pen);
        let hairline = Pen { color: Rgb(0, 0, 0), width_mm: 0.01 };
        let shadow = Pen { color: Rgb(128, 128, 128), width_mm: 1.69 };
        let mut d = Drawing::single_layer("ink", vec![line(5.05, hairline)]);
        d.layers.push(Layer {
            name: "shadow".into(),
            pen: Pen { color: Rgb(0, 0, 255), width_mm: 1.69 },
            paths: vec![line(8.05, shadow)],
        });
        d.page_mm = Some((20.0, 10.0));
        let opts = PreviewOptions { dpi: 254.0, ..PreviewOptions::default() };
        // As the file says: a one-pixel hairline and a grey stroke clamped to 1 mm.
        let as_filed = render(&d, &opts).unwrap();
        assert_eq!(rows_of(&as_filed, 100, (0, 0, 0)).len(), 1, "the hairline is one pixel");
        assert_eq!(rows_of(&as_filed, 100, (0, 0, 255)), Vec::<u32>::new(), "the shadow is grey");
        use_plotting_pens(&mut d, &profile);
        let p = render(&d, &opts).unwrap();
        assert_eq!(rows_of(&p, 100, (0, 0, 0)), vec![58, 59, 60, 61, 62]);
        // The shadow's layer pen is blue: at y = 8.05 mm, rows 88..=92.
        assert_eq!(rows_of(&p, 100, (0, 0, 255)), vec![88, 89, 90, 91, 92]);
        // A table pen of that layer's name brings its own width: 0.3 mm = 3 px, rows 89..=91.
        profile.pens = vec![crate::config::profile::PenSpec {
            name: "shadow".into(),
            color: None,
            width_mm: Some(0.3),
            down_z_mm: None,
            servo_down_deg: None,
            draw_feed_mm_s: None,
            hatch: None,
        }];
        use_plotting_pens(&mut d, &profile);
        let p = render(&d, &opts).unwrap();
        assert_eq!(rows_of(&p, 100, (0, 0, 255)), vec![89, 90, 91]);
    }

    #[test]
    fn large_requests_render_at_reduced_resolution_with_a_note() {
        // 10 m × 1 cm at 600 dpi is 236 225 × 236 px: reduced to 20 000 px wide.
        let d = Drawing { page_mm: Some((10_000.0, 10.0)), ..Drawing::default() };
        let opts = PreviewOptions { dpi: 600.0, ..PreviewOptions::default() };
        let p = render(&d, &opts).unwrap();
        assert_eq!(p.width(), MAX_SIDE_PX);
        let note = reduction_note(&d, &opts).unwrap();
        assert!(note.contains("rendered at 20000×"), "{note}");
        // A square page at a high DPI: the pixel budget, not the side, limits it (√(64 Mi) = 8192 px).
        let d = Drawing { page_mm: Some((1000.0, 1000.0)), ..Drawing::default() };
        let p = render(&d, &opts).unwrap();
        assert_eq!((p.width(), p.height()), (8192, 8192));
        assert_eq!(reduction_note(&d, &PreviewOptions::default()), None, "96 dpi fits");
        let err = render(&d, &PreviewOptions { dpi: 0.0, ..PreviewOptions::default() }).unwrap_err();
        assert!(err.to_string().contains("--dpi"), "{err}");
    }

    #[test]
    fn huge_stroke_widths_and_coordinates_do_not_panic() {
        // tiny-skia 0.12 panicked (scan/path.rs, alpha_runs.rs) for widths from about 1e9 mm.
        for w in [1e5, 1e9, 1e12, 1e15, 3e38, f64::INFINITY, f64::NAN] {
            let mut d =
                Drawing::single_layer("l", vec![Polyline::new(vec![Point::new(10.0, 10.0), Point::new(90.0, 90.0)])]);
            d.page_mm = Some((100.0, 100.0));
            d.layers[0].pen.width_mm = w;
            let p = render(&d, &PreviewOptions::default()).unwrap();
            assert_eq!(pixel(&p, 200, 200), (0, 0, 0), "width {w}: all ink");
        }
        let d = Drawing::single_layer("l", vec![Polyline::new(vec![Point::ZERO, Point::new(3.4e38, 10.0)])]);
        assert!(matches!(render(&d, &PreviewOptions::default()), Err(PreviewError::Limit(_))));
    }

    #[test]
    fn a_million_point_trace_renders_in_bounded_memory_like_the_plain_one() {
        // A staircase of 0.0125 mm steps (one point per motor step) along a 200 mm diagonal, twice: once as it is,
        // once with every point — the images agree, and the thinned one never builds a 300k-point path.
        let n = 16_000usize;
        let mut stairs = Vec::with_capacity(2 * n + 1);
        let s = 0.0125;
        for i in 0..n {
            let v = i as f64 * s;
            stairs.push(Point::new(10.0 + v, 10.0 + v));
            stairs.push(Point::new(10.0 + v + s, 10.0 + v));
        }
        stairs.push(Point::new(10.0 + n as f64 * s, 10.0 + n as f64 * s));
        let mut d = Drawing::single_layer("l", vec![Polyline::new(stairs)]);
        d.page_mm = Some((220.0, 220.0));
        let mut straight =
            Drawing::single_layer("l", vec![Polyline::new(vec![Point::new(10.0, 10.0), Point::new(210.0, 210.0)])]);
        straight.page_mm = d.page_mm;
        let (a, b) =
            (render(&d, &PreviewOptions::default()).unwrap(), render(&straight, &PreviewOptions::default()).unwrap());
        let differ = a.pixels().iter().zip(b.pixels()).filter(|(x, y)| x.red().abs_diff(y.red()) > 64).count();
        assert!(differ < 50, "{differ} pixels differ");
        // Chunking keeps a long polyline continuous: a 100 000-point circle has no gap on the image.
        let circle: Vec<Point> = (0..=100_000)
            .map(|i| {
                let t = std::f64::consts::TAU * i as f64 / 100_000.0;
                Point::new(110.0 + 100.0 * t.cos(), 110.0 + 100.0 * t.sin())
            })
            .collect();
        let mut c = Drawing::single_layer("l", vec![Polyline::new(circle)]);
        c.page_mm = d.page_mm;
        // 10 px/mm: thinned to 0.025 mm, about 25 000 points remain, more than one chunk.
        let p = render(&c, &PreviewOptions { dpi: 254.0, min_stroke_px: 2.0, ..PreviewOptions::default() }).unwrap();
        // 4.4 mm border: every column the circle spans has ink near the circle, above and below.
        for x in (200..=2000).step_by(7) {
            let cx = f64::from(x) / 10.0 - 110.0;
            for sign in [-1.0, 1.0] {
                let y = 110.0 + sign * (100.0f64 * 100.0 - cx * cx).sqrt();
                #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss, reason = "test pixel coordinates")]
                let py = ((y + 4.4) * 10.0).round() as u32;
                let inked = (py.saturating_sub(3)..=py + 3).any(|yy| pixel(&p, x + 44, yy).0 < 160);
                assert!(inked, "gap at x = {x} px, y = {py} px");
            }
        }
    }
}
