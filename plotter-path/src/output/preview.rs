//! Preview PNGs rendered with tiny-skia: the paper outline, pen-down strokes in each path's own colour and width
//! (or its layer's pen), and
//! optionally the pen-up travel as a thin dashed overlay.
//!
//! The same renderer serves every stage: the ideal paths of a drawing, a generated figure, and the "as-stepped"
//! preview that the plot command builds from the simulator's step trace (pass those polylines as a drawing and
//! the recorded pen-up moves as `travel`).

use std::path::Path;

use kurbo::{Line, Rect};
use tiny_skia::{Color, FillRule, LineCap, LineJoin, Paint, PathBuilder, Pixmap, Stroke, StrokeDash, Transform};

use crate::geometry::drawing::{Drawing, Rgb};
use crate::geometry::travel::pen_up_moves;

/// Largest accepted image side in pixels (a 20000² RGBA image is 1.6 GB; beyond that is a mistake).
pub const MAX_SIDE_PX: u32 = 20_000;

/// Errors rendering or saving a preview.
#[derive(Debug, thiserror::Error)]
pub enum PreviewError {
    /// The requested image is empty or too large.
    #[error("preview size {width}×{height} px is outside 1..={MAX_SIDE_PX} px per side; lower --dpi or --width-px")]
    Size {
        /// Requested width, px.
        width: f64,
        /// Requested height, px.
        height: f64,
    },
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
    let view = view_rect(drawing);
    let scale = match options.width_px {
        Some(w) => f64::from(w) / view.width(),
        None => options.dpi / 25.4,
    };
    let (w, h) = ((view.width() * scale).round(), (view.height() * scale).round());
    let max = f64::from(MAX_SIDE_PX);
    if !(w >= 1.0 && h >= 1.0 && w <= max && h <= max) {
        return Err(PreviewError::Size { width: w, height: h });
    }
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

    for layer in &drawing.layers {
        // Consecutive paths with the same pen are stroked together.
        let mut start = 0;
        while start < layer.paths.len() {
            let pen = layer.paths[start].pen.unwrap_or(layer.pen);
            let mut end = start + 1;
            while end < layer.paths.len() && layer.paths[end].pen.unwrap_or(layer.pen) == pen {
                end += 1;
            }
            stroke_paths(&mut pixmap, &layer.paths[start..end], pen, options, px_per_mm, transform);
            start = end;
        }
    }

    if options.travel && !travel.is_empty() {
        let mut pb = PathBuilder::new();
        for l in travel {
            pb.move_to(narrow(l.p0.x), narrow(l.p0.y));
            pb.line_to(narrow(l.p1.x), narrow(l.p1.y));
        }
        if let Some(shape) = pb.finish() {
            let mut paint = Paint::default();
            paint.set_color(color(options.travel_color, 200));
            paint.anti_alias = true;
            let unit = 1.0 / px_per_mm;
            let stroke = Stroke {
                width: narrow(unit * 0.8),
                dash: StrokeDash::new(vec![narrow(unit * 5.0), narrow(unit * 3.0)], 0.0),
                ..Stroke::default()
            };
            pixmap.stroke_path(&shape, &paint, &stroke, transform, None);
        }
    }
    Ok(pixmap)
}

/// Draw `paths` with `pen`: its colour (darkened to grey when it would vanish on white paper) and its width
/// clamped to `min_stroke_px` .. `max_stroke_mm`, so hairlines show and wide SVG strokes do not turn text into blobs.
fn stroke_paths(
    pixmap: &mut Pixmap,
    paths: &[crate::geometry::drawing::Polyline],
    pen: crate::geometry::drawing::Pen,
    options: &PreviewOptions,
    px_per_mm: f64,
    transform: Transform,
) {
    let mut pb = PathBuilder::new();
    for path in paths {
        let mut pts = path.points.iter();
        let Some(first) = pts.next() else { continue };
        pb.move_to(narrow(first.x), narrow(first.y));
        if path.points.len() == 1 {
            // A dot: a zero-length segment still shows with round caps.
            pb.line_to(narrow(first.x), narrow(first.y));
        }
        for p in pts {
            pb.line_to(narrow(p.x), narrow(p.y));
        }
        if path.is_closed() {
            pb.close();
        }
    }
    let Some(shape) = pb.finish() else { return };
    let mut paint = Paint::default();
    paint.set_color(color(visible_on_paper(pen.color), 255));
    paint.anti_alias = true;
    let width_mm = pen.width_mm.min(options.max_stroke_mm).max(options.min_stroke_px / px_per_mm);
    let stroke =
        Stroke { width: narrow(width_mm), line_cap: LineCap::Round, line_join: LineJoin::Round, ..Stroke::default() };
    pixmap.stroke_path(&shape, &paint, &stroke, transform, None);
}

/// Colours too light to see on the paper (luminance above 0.85: white, pale yellow) are shown as grey.
fn visible_on_paper(c: Rgb) -> Rgb {
    let lum = 0.2126 * f64::from(c.0) + 0.7152 * f64::from(c.1) + 0.0722 * f64::from(c.2);
    if lum > 0.85 * 255.0 { Rgb(170, 170, 170) } else { c }
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
    use crate::geometry::drawing::{Pen, Polyline};
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

    #[test]
    fn absurd_sizes_are_errors() {
        let d = Drawing { page_mm: Some((10_000.0, 10.0)), ..Drawing::default() };
        let err = render(&d, &PreviewOptions { dpi: 600.0, ..PreviewOptions::default() }).unwrap_err();
        assert!(err.to_string().contains("--dpi"));
    }
}
