//! Raster images (PNG, JPEG) to plottable paths.
//!
//! The pipeline: [`load_image`] (format by magic bytes, size limits) → [`prepare`] (alpha over white, gray, resize
//! to the requested width at the pixel pitch, optional Gaussian blur) → one of four [`Mode`]s:
//!
//! - [`Mode::Outline`]: boundaries of the thresholded regions, holes included ([`outline`]).
//! - [`Mode::Centerline`]: line art thinned to a skeleton and walked into strokes drawn once ([`centerline`]).
//! - [`Mode::Edges`]: Canny edges chained into polylines ([`edges`]).
//! - [`Mode::Hatch`]: tone shading with hatch lines clipped exactly to tone regions ([`hatch`]).
//! - [`Mode::Stipple`]: pen dots spread by weighted Voronoi stippling, or one line through them ([`stipple`]).
//! - [`Mode::Squiggle`]: rows of zig-zag waves growing with darkness, one stroke per row ([`squiggle`]).
//! - [`Mode::Spiral`]: one spiral from the centre carrying the same waves ([`spiral`]).
//! - [`Mode::Flow`]: evenly spaced streamlines along the picture's edges, spaced by tone ([`flow`]).
//! - [`Mode::Sketch`]: long scribbled strokes that keep heading for the darkest place nearby ([`sketch`]).
//! - [`Mode::Mosaic`]: Voronoi cells, smaller where darker or detailed, each hatched at its mean tone ([`mosaic`]).
//!
//! With [`TraceOptions::colors`] set to CMYK or a set of pens, a tone style shades each ink's separation
//! ([`separate`]) instead of the gray, one layer per ink in that ink's colour, each at its own line angle.
//!
//! The tone styles (hatch, stipple) read one tone model ([`tone`]): the target darkness of every pixel after the
//! tone curve, and the ink a pen of the given width lays down.
//!
//! All tracing happens in pixel coordinates (pixel `(x, y)` covers `[x, x+1] × [y, y+1]`); the result is scaled to
//! millimetres once at the end, so the [`Drawing`] is `columns × pixel_mm` wide with its origin at the image's
//! top-left corner.
//!
//! ```
//! use plotter_path::input::raster::{trace, Mode, TraceOptions};
//! use image::{DynamicImage, GrayImage, Luma};
//!
//! // A black square on white, traced at 0.5 mm per pixel.
//! let img = GrayImage::from_fn(20, 20, |x, y| Luma([if (5..15).contains(&x) && (5..15).contains(&y) { 0 } else { 255 }]));
//! let opts = TraceOptions { mode: Mode::Outline, pitch_mm: Some(0.5), ..TraceOptions::default() };
//! let traced = trace(&DynamicImage::ImageLuma8(img), &opts).unwrap();
//! assert_eq!(traced.drawing.path_count(), 1);
//! let bbox = traced.drawing.bbox().unwrap();
//! assert!((bbox.width() - 5.0).abs() < 1e-9);
//! ```

mod bitmap;
pub mod centerline;
mod contour;
pub mod edges;
mod error;
pub mod fidelity;
pub mod flow;
pub mod hatch;
pub mod ink;
pub mod join;
pub mod lines;
mod load;
pub mod mosaic;
pub mod outline;
pub mod separate;
pub mod simplify;
pub mod skeleton;
pub mod sketch;
pub mod spiral;
pub mod squiggle;
pub mod stipple;
pub mod synth;
mod threshold;
pub mod tone;
pub mod zigzag;

pub use bitmap::Bitmap;
pub use contour::{Contour, signed_area, trace_contours};
pub use error::{RasterError, RasterWarning};
pub use hatch::{HatchOptions, HatchScheme};
pub use load::{Prepared, decode_image, load_image, prepare};
pub use threshold::{Threshold, binarize, cut_level};
pub use tone::{Ladder, ToneCurve};

use crate::geometry::cancel::Cancel;
use crate::{Drawing, Layer, Pen, Polyline};
use image::DynamicImage;
use kurbo::Point;
use std::fmt;
use std::path::Path;
use std::str::FromStr;

/// Largest accepted image side in pixels; larger files are refused with [`RasterError::TooLarge`].
pub const MAX_IMAGE_SIDE: u32 = 30_000;
/// Largest accepted image in pixels (100 megapixels); larger files are refused with [`RasterError::TooLarge`].
pub const MAX_IMAGE_PIXELS: u64 = 100_000_000;
/// Largest working image (after resizing) in pixels, 4096²; a larger request is scaled down with a
/// [`RasterWarning::Downscaled`].
pub const MAX_WORK_PIXELS: u64 = 4096 * 4096;

/// What to extract from the image.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Mode {
    /// Closed boundaries of the ink regions (with holes).
    #[default]
    Outline,
    /// One stroke along the middle of each line of line art.
    Centerline,
    /// Canny edges of a photo.
    Edges,
    /// Hatch shading of the gray tones.
    Hatch,
    /// Pen dots, denser where darker.
    Stipple,
    /// Rows of waves whose amplitude and frequency follow darkness.
    Squiggle,
    /// One spiral from the centre whose waves follow darkness.
    Spiral,
    /// Evenly spaced streamlines along the picture's edges, closer where darker.
    Flow,
    /// Long scribbled strokes heading for the darkest place nearby until the tone is met.
    Sketch,
    /// Voronoi cells, smaller where darker or detailed, each hatched at its mean tone.
    Mosaic,
}

impl Mode {
    /// The CLI spelling.
    pub fn name(self) -> &'static str {
        match self {
            Mode::Outline => "outline",
            Mode::Centerline => "centerline",
            Mode::Edges => "edges",
            Mode::Hatch => "hatch",
            Mode::Stipple => "stipple",
            Mode::Squiggle => "squiggle",
            Mode::Spiral => "spiral",
            Mode::Flow => "flow",
            Mode::Sketch => "sketch",
            Mode::Mosaic => "mosaic",
        }
    }

    /// What the mode draws, in a user's words (the help text of `--mode` and `--images`).
    pub fn summary(self) -> &'static str {
        match self {
            Mode::Outline => "Closed outlines of the ink regions (with holes)",
            Mode::Centerline => "One stroke along the middle of each line (line art)",
            Mode::Edges => "Canny edges chained into polylines (photos)",
            Mode::Hatch => "Hatch shading of the gray tones",
            Mode::Stipple => "Pen dots, denser where the picture is darker (add --tsp for one continuous line)",
            Mode::Squiggle => {
                "Rows of zig-zag waves growing with darkness, one stroke per row (rows twice --min-spacing apart)"
            }
            Mode::Spiral => {
                "One spiral from the centre whose waves grow with darkness (turns twice --min-spacing apart)"
            }
            Mode::Flow => {
                "Evenly spaced streamlines along the picture's edges, closer where darker (crossed in the dark tones)"
            }
            Mode::Sketch => {
                "Long scribbled strokes that keep heading for the darkest place nearby until the tone is met"
            }
            Mode::Mosaic => {
                "Cells, smaller where the picture is darker or busier, each hatched as dark as its mean tone"
            }
        }
    }

    /// Every mode, in documentation order.
    pub const ALL: [Mode; 10] = [
        Mode::Outline,
        Mode::Centerline,
        Mode::Edges,
        Mode::Hatch,
        Mode::Stipple,
        Mode::Squiggle,
        Mode::Spiral,
        Mode::Flow,
        Mode::Sketch,
        Mode::Mosaic,
    ];
}

impl fmt::Display for Mode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Mode {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Mode::ALL.into_iter().find(|m| m.name().eq_ignore_ascii_case(s)).ok_or_else(|| {
            let names: Vec<&str> = Mode::ALL.iter().map(|m| m.name()).collect();
            format!("unknown mode `{s}` (expected one of: {})", names.join(", "))
        })
    }
}

/// Every knob of the tracer. Pixel-valued options refer to the working image (after resizing).
#[derive(Debug, Clone, PartialEq)]
pub struct TraceOptions {
    /// The tracing mode.
    pub mode: Mode,
    /// Target drawing width in mm; the image is resampled to `width_mm / pitch` pixels across. `None` keeps the
    /// image's own pixels, each `pitch` mm wide.
    pub width_mm: Option<f64>,
    /// Pixel pitch in mm; `None` means the pen width.
    pub pitch_mm: Option<f64>,
    /// The pen the result is drawn with (its width is the default pitch).
    pub pen: Pen,
    /// Gaussian blur sigma in pixels before thresholding; 0 = off.
    pub blur_px: f32,
    /// Ink/paper split for outline and centerline.
    pub threshold: Threshold,
    /// Swap ink and paper (light drawing on a dark background). For hatch, shade light tones instead of dark ones.
    pub invert: bool,
    /// Ramer–Douglas–Peucker tolerance in pixels for every traced path; 0 = keep every vertex. The default 0.4 keeps
    /// outline fidelity (IoU of the re-filled polygons vs the bitmap) ≥ 0.998 on discs, rings and letters; at 0.5
    /// the simplified chords start to cut whole pixel centres off small round shapes.
    pub simplify_px: f64,
    /// Regions and holes smaller than this many square pixels are dropped (outline, hatch regions).
    pub min_area_px: f64,
    /// Strokes and edge chains shorter than this many pixels are dropped (centerline, edges).
    pub min_length_px: f64,
    /// Canny hysteresis thresholds on the Sobel gradient magnitude (0 to about 1140).
    pub canny_low: f32,
    /// See [`TraceOptions::canny_low`].
    pub canny_high: f32,
    /// Hatch levels, spacing and angle.
    pub hatch: HatchOptions,
    /// The tone curve (levels, contrast, gamma) applied before darkness is read by the tone styles.
    pub tone: ToneCurve,
    /// Closest spacing of one family of lines in mm for the tone styles; `None` means 1.5 × the pen width.
    pub min_spacing_mm: Option<f64>,
    /// Stipple settings (one line through the dots, relaxation rounds).
    pub stipple: stipple::StippleOptions,
    /// Mosaic settings (cell outlines, largest cell).
    pub mosaic: mosaic::MosaicOptions,
    /// One black pen for the gray picture, or the picture separated into CMYK or into pens, one layer per ink.
    pub colors: separate::Colors,
    /// Stops the tracing early with [`RasterError::Cancelled`] when set: checked between its stages (resizing,
    /// thresholding, tracing, scaling to millimetres).
    pub cancel: Cancel,
}

impl Default for TraceOptions {
    fn default() -> Self {
        TraceOptions {
            mode: Mode::Outline,
            width_mm: None,
            pitch_mm: None,
            pen: Pen::default(),
            blur_px: 0.0,
            threshold: Threshold::Otsu,
            invert: false,
            simplify_px: 0.4,
            min_area_px: 4.0,
            min_length_px: 3.0,
            canny_low: 40.0,
            canny_high: 100.0,
            hatch: HatchOptions::default(),
            tone: ToneCurve::default(),
            min_spacing_mm: None,
            stipple: stipple::StippleOptions::default(),
            mosaic: mosaic::MosaicOptions::default(),
            colors: separate::Colors::Gray,
            cancel: Cancel::never(),
        }
    }
}

impl TraceOptions {
    /// The pixel pitch in effect (explicit pitch or the pen width).
    pub fn pitch(&self) -> f64 {
        self.pitch_mm.unwrap_or(self.pen.width_mm)
    }

    /// The tone ladder for these options' pen and minimum spacing.
    pub fn ladder(&self) -> Ladder {
        Ladder { pen_mm: self.pen.width_mm, min_spacing_mm: self.min_spacing_mm.unwrap_or(1.5 * self.pen.width_mm) }
    }

    /// Check every option's range.
    pub fn validate(&self) -> Result<(), RasterError> {
        fn bad(name: &'static str, value: impl ToString, reason: &'static str) -> Result<(), RasterError> {
            Err(RasterError::InvalidOption { name, value: value.to_string(), reason })
        }
        let pitch = self.pitch();
        if !(pitch.is_finite() && pitch > 0.0) {
            return bad("--pitch", pitch, "must be a positive number of mm (the pen width is used by default)");
        }
        if let Some(w) = self.width_mm
            && !(w.is_finite() && w > 0.0)
        {
            return bad("--width", w, "must be a positive number of mm");
        }
        if !(self.blur_px.is_finite() && self.blur_px >= 0.0) {
            return bad("--blur", self.blur_px, "must be ≥ 0 pixels");
        }
        if !(self.simplify_px.is_finite() && self.simplify_px >= 0.0) {
            return bad("--simplify", self.simplify_px, "must be ≥ 0 pixels");
        }
        if !(self.min_area_px.is_finite() && self.min_area_px >= 0.0) {
            return bad("--min-area", self.min_area_px, "must be ≥ 0 square pixels");
        }
        if !(self.min_length_px.is_finite() && self.min_length_px >= 0.0) {
            return bad("--min-length", self.min_length_px, "must be ≥ 0 pixels");
        }
        if !(self.canny_low.is_finite() && self.canny_low >= 0.0) {
            return bad("--canny-low", self.canny_low, "must be ≥ 0");
        }
        if !(self.canny_high.is_finite() && self.canny_high >= self.canny_low) {
            return bad("--canny-high", self.canny_high, "must be ≥ --canny-low");
        }
        if !(self.pen.width_mm.is_finite() && self.pen.width_mm > 0.0) {
            return bad("--pen-width", self.pen.width_mm, "must be a positive number of mm");
        }
        if let Some(s) = self.min_spacing_mm
            && !(s.is_finite() && s > 0.0)
        {
            return bad("--min-spacing", s, "must be a positive number of mm");
        }
        if let Some(c) = self.mosaic.cell_mm
            && !(c.is_finite() && c > 0.0)
        {
            return bad("--cell-size", c, "must be a positive number of mm");
        }
        if self.colors != separate::Colors::Gray {
            let value = if self.colors == separate::Colors::Cmyk { "cmyk" } else { "pens" };
            let tone_style = match self.mode {
                Mode::Outline | Mode::Centerline | Mode::Edges => false,
                Mode::Hatch => self.hatch.scheme == HatchScheme::Tone,
                _ => true,
            };
            if !tone_style {
                return bad(
                    "--colors",
                    value,
                    "shades colours with the tone styles only: hatch (tone scheme), stipple, squiggle, spiral, flow, \
                     sketch or mosaic",
                );
            }
            if self.colors == separate::Colors::Pens(Vec::new()) {
                return bad(
                    "--colors",
                    value,
                    "found no pen with a colour in the pen table given to separate into (the front end passes the \
                     machine profile's coloured pens)",
                );
            }
        }
        self.tone.validate()?;
        self.hatch.validate()
    }
}

/// The result of tracing: the drawing plus everything that was dropped or changed.
#[derive(Debug, Clone)]
pub struct Traced {
    /// The paths in millimetres, origin at the image's top-left corner; `page_mm` is the image's size.
    pub drawing: Drawing,
    /// Dropped specks, short paths, downscaling.
    pub warnings: Vec<RasterWarning>,
    /// Size of one working pixel in mm.
    pub pixel_mm: f64,
    /// Working image size in pixels.
    pub size_px: (u32, u32),
}

/// Read `path` (PNG or JPEG) and trace it. This is the entry point for every image input of the CLI.
pub fn trace_file(path: &Path, options: &TraceOptions) -> Result<Traced, RasterError> {
    options.validate()?;
    let image = load_image(path)?;
    trace_named(&image, &path.display().to_string(), options)
}

/// Trace an already decoded image (errors name it "image").
pub fn trace(image: &DynamicImage, options: &TraceOptions) -> Result<Traced, RasterError> {
    trace_named(image, "image", options)
}

/// Trace an already decoded image; `input` names it in errors.
pub fn trace_named(image: &DynamicImage, input: &str, options: &TraceOptions) -> Result<Traced, RasterError> {
    options.validate()?;
    load::check_size(input, image.width(), image.height())?;
    let cancelled = |_| RasterError::Cancelled { input: input.to_owned() };
    options.cancel.check().map_err(cancelled)?;
    let prepared = prepare(image, options)?;
    options.cancel.check().map_err(cancelled)?;
    let mut warnings = prepared.warnings.clone();
    let nothing = |reason: String| RasterError::NothingToDraw { input: input.to_owned(), reason };
    let layers: Vec<(String, Vec<Vec<Point>>)> = match options.mode {
        _ if options.colors != separate::Colors::Gray => Vec::new(),
        Mode::Outline | Mode::Centerline => {
            let bitmap = binarize(&prepared.gray, options.threshold, options.invert);
            if bitmap.is_empty() {
                let inv = if options.invert { ", inverted" } else { "" };
                return Err(nothing(format!("no ink: no pixel passes the threshold ({}{inv})", options.threshold)));
            }
            options.cancel.check().map_err(cancelled)?;
            let (paths, w) = if options.mode == Mode::Outline {
                outline::outline(&bitmap, options.simplify_px, options.min_area_px)
            } else {
                centerline::centerline(&bitmap, options.simplify_px, options.min_length_px)
            };
            warnings.extend(w);
            vec![(options.mode.name().to_owned(), paths)]
        }
        Mode::Edges => {
            let (paths, w) = edges::edges(
                &prepared.gray,
                options.canny_low,
                options.canny_high,
                options.simplify_px,
                options.min_length_px,
            );
            warnings.extend(w);
            vec![("edges".to_owned(), paths)]
        }
        Mode::Hatch if options.hatch.scheme != HatchScheme::Tone => {
            let spacing_px = options.hatch.spacing_mm / prepared.pixel_mm;
            let levels = hatch::hatch(&prepared.gray, &options.hatch, spacing_px, options.invert, options.min_area_px);
            let mut dropped = 0;
            let mut out = Vec::new();
            for (i, level) in levels.into_iter().enumerate() {
                dropped += level.specks_dropped;
                let paths = level.segments.iter().map(|&(a, b)| vec![a, b]).collect();
                out.push((format!("hatch {}", i + 1), paths));
            }
            if dropped > 0 {
                warnings.push(RasterWarning::SpecksDropped { count: dropped, min_area_px: options.min_area_px });
            }
            out
        }
        _ => {
            shade(&options.tone.darkness_map(&prepared.gray, options.invert), options, prepared.pixel_mm, &mut warnings)
        }
    };
    let mut layers: Vec<(String, Pen, Vec<Vec<Point>>)> =
        layers.into_iter().map(|(name, paths)| (name, options.pen, paths)).collect();
    if options.colors != separate::Colors::Gray {
        let rgb = separate::working_rgb(image, &prepared, options.blur_px);
        for sep in separate::separate(&rgb, &options.tone, options.invert, &options.colors) {
            options.cancel.check().map_err(cancelled)?;
            let mut turned = options.clone();
            turned.hatch.angle_deg += sep.angle_deg;
            let paths = shade(&sep.map, &turned, prepared.pixel_mm, &mut warnings).into_iter().flat_map(|l| l.1);
            let pen = Pen { color: sep.ink.color, ..options.pen };
            layers.push((sep.ink.name, pen, paths.collect()));
        }
    }
    options.cancel.check().map_err(cancelled)?;
    let (w, h) = prepared.gray.dimensions();
    let s = prepared.pixel_mm;
    let mut drawing = Drawing { layers: Vec::new(), page_mm: Some((f64::from(w) * s, f64::from(h) * s)) };
    for (name, pen, paths) in layers {
        let mut layer = Layer::new(name);
        layer.pen = pen;
        layer.paths = paths
            .into_iter()
            .filter(|p| p.len() >= 2)
            .map(|p| Polyline::new(p.into_iter().map(|q| Point::new(q.x * s, q.y * s)).collect()))
            .collect();
        if !layer.paths.is_empty() {
            drawing.layers.push(layer);
        }
    }
    if drawing.is_empty() {
        let dropped: Vec<String> = warnings.iter().map(ToString::to_string).collect();
        let reason = match options.mode {
            Mode::Edges => format!("no edges found with Canny thresholds {}/{}", options.canny_low, options.canny_high),
            Mode::Hatch => "no pixel is dark enough for the lightest hatch level".to_owned(),
            Mode::Stipple => "the picture is too light for a single pen dot".to_owned(),
            Mode::Squiggle | Mode::Spiral | Mode::Flow | Mode::Sketch | Mode::Mosaic => {
                format!("the picture is too light for a {} line", options.mode)
            }
            _ => "every region was too small to keep".to_owned(),
        };
        let reason = if dropped.is_empty() { reason } else { format!("{reason}; {}", dropped.join("; ")) };
        return Err(nothing(reason));
    }
    Ok(Traced { drawing, warnings, pixel_mm: s, size_px: (w, h) })
}

/// The tone styles: `map` shaded by `options.mode` (hatch with the tone scheme, stipple, squiggle, spiral, flow,
/// sketch, mosaic), one or more named layers of strokes in pixel coordinates.
fn shade(
    map: &tone::DarknessMap,
    options: &TraceOptions,
    pixel_mm: f64,
    warnings: &mut Vec<RasterWarning>,
) -> Vec<(String, Vec<Vec<Point>>)> {
    match options.mode {
        Mode::Hatch => {
            let hatched = hatch::tone_hatch(
                map,
                options.hatch.levels,
                &options.ladder(),
                options.hatch.angle_deg,
                pixel_mm,
                options.min_area_px,
            );
            let dropped: usize = hatched.bands.iter().map(|b| b.specks_dropped).sum();
            if dropped > 0 {
                warnings.push(RasterWarning::SpecksDropped { count: dropped, min_area_px: options.min_area_px });
            }
            vec![("hatch".to_owned(), hatched.strokes)]
        }
        Mode::Stipple => {
            vec![("stipple".to_owned(), stipple::stipple(map, options.pen.width_mm / pixel_mm, &options.stipple))]
        }
        Mode::Squiggle => {
            let row = 2.0 * options.ladder().min_spacing_mm / pixel_mm;
            vec![("squiggle".to_owned(), squiggle::squiggle(map, options.pen.width_mm / pixel_mm, row))]
        }
        Mode::Spiral => {
            let row = 2.0 * options.ladder().min_spacing_mm / pixel_mm;
            vec![("spiral".to_owned(), spiral::spiral(map, options.pen.width_mm / pixel_mm, row))]
        }
        Mode::Flow => {
            let lines = flow::flow(map, &options.ladder(), pixel_mm, options.hatch.angle_deg);
            let lines = lines.iter().map(|l| simplify::simplify(l, options.simplify_px)).collect();
            vec![("flow".to_owned(), lines)]
        }
        Mode::Sketch => {
            vec![("sketch".to_owned(), sketch::sketch(map, &options.ladder(), pixel_mm))]
        }
        Mode::Mosaic => {
            let m = mosaic::mosaic(map, &options.ladder(), pixel_mm, options.hatch.angle_deg, &options.mosaic);
            vec![("mosaic".to_owned(), m.strokes), ("mosaic cells".to_owned(), m.outlines)]
        }
        Mode::Outline | Mode::Centerline | Mode::Edges => Vec::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::{GrayImage, Luma};

    fn white(w: u32, h: u32) -> DynamicImage {
        DynamicImage::ImageLuma8(GrayImage::from_pixel(w, h, Luma([255])))
    }

    #[test]
    fn a_cancelled_trace_ends_with_its_typed_error() {
        let img = GrayImage::from_fn(20, 20, |x, y| {
            Luma([if (5..15).contains(&x) && (5..15).contains(&y) { 0 } else { 255 }])
        });
        let cancel = Cancel::new();
        let opts = TraceOptions { pitch_mm: Some(0.5), cancel: cancel.clone(), ..TraceOptions::default() };
        let img = DynamicImage::ImageLuma8(img);
        assert_eq!(trace_named(&img, "square.png", &opts).unwrap().drawing.path_count(), 1);
        cancel.cancel();
        let e = trace_named(&img, "square.png", &opts).unwrap_err();
        assert!(matches!(e, RasterError::Cancelled { .. }), "{e:?}");
        assert_eq!(e.to_string(), "square.png: tracing cancelled (the drawing was no longer wanted)");
    }

    #[test]
    fn white_image_has_nothing_to_draw_in_every_mode() {
        for mode in Mode::ALL {
            for threshold in [Threshold::Otsu, Threshold::Fixed(128)] {
                let opts = TraceOptions { mode, threshold, ..TraceOptions::default() };
                let e = trace(&white(50, 40), &opts).unwrap_err();
                assert!(matches!(e, RasterError::NothingToDraw { .. }), "{mode}: {e:?}");
                assert!(e.to_string().contains("nothing to draw"), "{e}");
            }
        }
    }

    #[test]
    fn only_specks_is_nothing_to_draw_and_says_why() {
        let img = GrayImage::from_fn(30, 30, |x, y| Luma([if x == 10 && y == 10 { 0 } else { 255 }]));
        let opts = TraceOptions { threshold: Threshold::Fixed(128), ..TraceOptions::default() };
        let e = trace(&DynamicImage::ImageLuma8(img), &opts).unwrap_err();
        assert!(e.to_string().contains("dropped 1 speck"), "{e}");
    }

    #[test]
    fn bad_options_are_named() {
        let opts = TraceOptions { pitch_mm: Some(0.0), ..TraceOptions::default() };
        let e = trace(&white(4, 4), &opts).unwrap_err();
        assert!(e.to_string().contains("--pitch"), "{e}");
        let opts = TraceOptions { canny_low: 50.0, canny_high: 10.0, ..TraceOptions::default() };
        assert!(trace(&white(4, 4), &opts).unwrap_err().to_string().contains("--canny-high"));
    }

    #[test]
    fn missing_file_names_the_path() {
        let e = trace_file(Path::new("/nonexistent/dir/pic.png"), &TraceOptions::default()).unwrap_err();
        assert!(matches!(e, RasterError::Io { .. }));
        assert!(e.to_string().contains("/nonexistent/dir/pic.png"), "{e}");
    }

    #[test]
    fn mode_parse() {
        assert_eq!("Hatch".parse::<Mode>(), Ok(Mode::Hatch));
        assert_eq!("Sketch".parse::<Mode>(), Ok(Mode::Sketch));
        let e = "scribble".parse::<Mode>().unwrap_err();
        assert!(e.contains("scribble") && Mode::ALL.iter().all(|m| e.contains(m.name())), "{e}");
    }

    #[test]
    fn drawing_is_in_mm_with_page_size() {
        let img = GrayImage::from_fn(40, 20, |x, y| {
            Luma([if (10..30).contains(&x) && (5..15).contains(&y) { 0 } else { 255 }])
        });
        let opts = TraceOptions { width_mm: Some(100.0), pitch_mm: Some(1.0), ..TraceOptions::default() };
        let t = trace(&DynamicImage::ImageLuma8(img), &opts).unwrap();
        assert_eq!(t.size_px, (100, 50));
        assert_eq!(t.drawing.page_mm, Some((100.0, 50.0)));
        let b = t.drawing.bbox().unwrap();
        // The square spans pixels 25..75 × 12.5..37.5 after resampling by 2.5; allow the resampling blur.
        assert!((b.x0 - 25.0).abs() <= 1.5 && (b.x1 - 75.0).abs() <= 1.5, "{b:?}");
        assert!((b.y0 - 12.5).abs() <= 1.5 && (b.y1 - 37.5).abs() <= 1.5, "{b:?}");
        assert!(t.drawing.paths().all(Polyline::is_closed));
    }
}

#[cfg(test)]
mod sample_tests {
    use super::*;
    use crate::input::raster::simplify::point_segment_distance;
    use std::path::PathBuf;

    fn sample(name: &str) -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../samples").join(name)
    }

    /// Paths back in pixel coordinates.
    fn pixel_paths(t: &Traced) -> Vec<Vec<Point>> {
        t.drawing
            .paths()
            .map(|p| p.points.iter().map(|q| Point::new(q.x / t.pixel_mm, q.y / t.pixel_mm)).collect())
            .collect()
    }

    #[test]
    fn committed_samples_match_the_generator() {
        let line = load_image(&sample("line-art.png")).unwrap().to_luma8();
        assert!(line == synth::line_art_sample(), "samples/line-art.png is stale: run the make_raster_samples example");
        let photo = load_image(&sample("photo.png")).unwrap().to_luma8();
        assert!(photo == synth::photo_sample(), "samples/photo.png is stale: run the make_raster_samples example");
    }

    #[test]
    fn outline_fidelity_on_the_samples() {
        for name in ["line-art.png", "photo.png"] {
            let opts = TraceOptions::default();
            let t = trace_file(&sample(name), &opts).unwrap();
            let gray = load_image(&sample(name)).unwrap().to_luma8();
            let bitmap = binarize(&gray, opts.threshold, false);
            let iou = synth::iou_even_odd(&bitmap, &pixel_paths(&t));
            assert!(iou >= 0.98, "{name}: IoU {iou}");
            assert!(t.drawing.paths().all(crate::Polyline::is_closed));
        }
    }

    #[test]
    fn centerline_on_the_line_art_sample_follows_the_true_strokes() {
        let opts = TraceOptions { mode: Mode::Centerline, ..TraceOptions::default() };
        let t = trace_file(&sample("line-art.png"), &opts).unwrap();
        let strokes = synth::line_art_strokes();
        let paths = pixel_paths(&t);
        // Where two strokes meet at 90° or less (the star's 36° tips, square corners) their ink merges into one wedge and the
        // skeleton runs down its bisector until they separate, up to 2 px off either true line, and stops short of
        // the tip. Those wedges (8 px around each acute corner) are checked separately with a looser bound.
        let mut acute = Vec::new();
        for st in &strokes {
            let closed = st.points.first() == st.points.last();
            let n = st.points.len();
            for i in 0..n {
                let (prev, next) = match (i, closed) {
                    (0, true) | (_, true) if i == 0 || i == n - 1 => (st.points[n - 2], st.points[1]),
                    (0, false) => continue,
                    _ if i == n - 1 => continue,
                    _ => (st.points[i - 1], st.points[i + 1]),
                };
                let (u, v) = (prev - st.points[i], next - st.points[i]);
                if u.dot(v) >= -1e-9 {
                    acute.push(st.points[i]);
                }
            }
        }
        let in_wedge = |p: Point| acute.iter().any(|c| c.distance(p) <= 8.0);
        let (mut worst, mut worst_at, mut worst_wedge) = (0.0, Point::ZERO, 0.0f64);
        for pl in &paths {
            for s in (synth::Stroke { points: pl.clone() }).samples(0.5) {
                let d = strokes.iter().map(|st| st.distance(s)).fold(f64::INFINITY, f64::min);
                if in_wedge(s) {
                    worst_wedge = worst_wedge.max(d);
                } else if d > worst {
                    (worst, worst_at) = (d, s);
                }
            }
        }
        let traced: f64 = paths.iter().map(|pl| pl.windows(2).map(|w| w[0].distance(w[1])).sum::<f64>()).sum();
        let truth: f64 = strokes.iter().map(synth::Stroke::length).sum();
        println!(
            "centerline sample: {} paths, {} acute corners, worst {worst:.2} px (in wedges {worst_wedge:.2} px), \
             length {traced:.0} vs {truth:.0}",
            paths.len(),
            acute.len()
        );
        // Junction positions are the centroid of the junction pixels, which sits up to ~1.5 px off where two strokes
        // cross at a shallow angle (the star's inner crossings): allow 2 px there, 1.5 px for the strokes themselves
        // (checked by the coverage loop below).
        assert!(worst <= 2.0, "worst deviation {worst:.2} px at {worst_at:?}");
        assert!(worst_wedge <= 2.5, "worst deviation in acute wedges {worst_wedge:.2} px");
        assert!((traced - truth).abs() <= 0.05 * truth, "length {traced:.0} vs {truth:.0}");
        // Every true stroke point is covered, except the last 3 px of free ends (thinning shortens them by up to a
        // half-width) and the acute wedges.
        for st in &strokes {
            let ends = [st.points[0], st.points[st.points.len() - 1]];
            for s in st.samples(2.0).into_iter().filter(|s| ends.iter().all(|e| e.distance(*s) > 3.0) && !in_wedge(*s))
            {
                let d = paths
                    .iter()
                    .flat_map(|pl| pl.windows(2).map(move |w| point_segment_distance(s, w[0], w[1])))
                    .fold(f64::INFINITY, f64::min);
                assert!(d <= 1.5, "true point {s:?} is {d:.2} px from the result");
            }
        }
    }

    #[test]
    fn edges_and_hatch_on_the_photo_sample() {
        let opts = TraceOptions { mode: Mode::Edges, ..TraceOptions::default() };
        let t = trace_file(&sample("photo.png"), &opts).unwrap();
        let paths = pixel_paths(&t);
        // The sphere's silhouette (centre (170, 210), radius 85) is found where it has contrast: its shaded right half
        // (the lit left half is about as light as the wall behind it).
        let mut found = 0;
        for i in 0..36 {
            let a = f64::from(i) * std::f64::consts::PI / 36.0 - std::f64::consts::FRAC_PI_2;
            let p = Point::new(170.0 + 85.0 * a.cos(), 210.0 + 85.0 * a.sin());
            let d = paths
                .iter()
                .flat_map(|pl| pl.windows(2).map(move |w| point_segment_distance(p, w[0], w[1])))
                .fold(f64::INFINITY, f64::min);
            found += usize::from(d <= 2.0);
        }
        assert!(found >= 30, "{found}/36 silhouette points near an edge");
        // The cut-level scheme: darker levels nest inside lighter ones.
        let hatch = HatchOptions { scheme: HatchScheme::Directions, ..HatchOptions::default() };
        let opts = TraceOptions { mode: Mode::Hatch, hatch, ..TraceOptions::default() };
        let t = trace_file(&sample("photo.png"), &opts).unwrap();
        assert_eq!(t.drawing.layers.len(), 4);
        // Darker levels cover less, so they have less line length.
        let lengths: Vec<f64> =
            t.drawing.layers.iter().map(|l| l.paths.iter().map(crate::Polyline::length).sum()).collect();
        assert!(lengths.windows(2).all(|w| w[0] > w[1]), "{lengths:?}");
    }
}
