//! Every tone style of the image tracer against pictures whose answer is known by hand (issue 40):
//!
//! - a white picture plots nothing;
//! - a black square plots at the ladder's darkest coverage inside, and puts no ink outside it beyond the pen's
//!   half width;
//! - a linear lightness ramp (L* 100 at the left edge to 0 at the right) plots, as the eye sees it (the strokes
//!   rendered at the pen's width, blurred with σ = 1 mm, in CIE L*: the bench's tone measure), within 3 L* of the
//!   ramp along it, averaged over columns 3 mm wide;
//! - random pictures of random sizes get no stroke point outside the picture (plus the pen's half width).
//!
//! The pictures are 60 × 40 mm at 0.3 mm pixels and a 0.3 mm pen, as `plotter trace --mode STYLE` draws them.

use image::{DynamicImage, GrayImage, Luma};
use kurbo::Point;
use plotter_path::input::raster::fidelity::{MeasureOptions, Reflectance, plot_reflectance, seen_lightness};
use plotter_path::input::raster::tone::luminance_from_cie;
use plotter_path::input::raster::{Mode, RasterError, TraceOptions, trace};
use plotter_path::optimize::one_line::join_into_one_line;
use proptest::prelude::*;

/// Pen width and pixel pitch, mm.
const PEN_MM: f64 = 0.3;
/// Picture size in pixels: 60 × 40.2 mm.
const W: u32 = 200;
const H: u32 = 134;
/// Measure cells, mm (the bench's), and fine cells per cell where the ink is rendered.
const CELL_MM: f64 = 0.25;

/// Every tone style (the line-art modes outline, centerline and edges do not shade).
const STYLES: [Mode; 7] =
    [Mode::Hatch, Mode::Stipple, Mode::Squiggle, Mode::Spiral, Mode::Flow, Mode::Sketch, Mode::Mosaic];

fn options(mode: Mode) -> TraceOptions {
    TraceOptions { mode, pitch_mm: Some(PEN_MM), ..TraceOptions::default() }
}

/// What each style is held to: the ramp's worst |ΔL*|, the black square's least ink fraction, and how far past the
/// square (beyond the pen's half width) a stroke point may lie, mm. Where a style misses the marks (ΔL* 3,
/// ink 26/27 − 0.03, nothing outside) the figure is today's measure with a little room, and the reason is given.
struct Bounds {
    ramp: f64,
    ink: f64,
    outside_mm: f64,
}

fn bounds(mode: Mode, levels: u8) -> Bounds {
    let met = Bounds { ramp: 3.0, ink: DARKEST - 0.03, outside_mm: 0.0 };
    match (mode, levels) {
        // Four bands each span 25 L*, drawn at their mean: the staircase is ±12.5 by construction (measured 8.3).
        (Mode::Hatch, 4) => Bounds { ramp: 12.5, ..met },
        _ => met,
    }
}

fn width_mm() -> f64 {
    f64::from(W) * PEN_MM
}

fn measure_options() -> MeasureOptions {
    MeasureOptions { width_mm: width_mm(), pen_mm: PEN_MM, sigma_mm: 1.0, cell_mm: CELL_MM, fine: 5 }
}

/// Every style at its defaults, and hatch also at 16 levels (its finest): a label and the options.
fn cases() -> Vec<(String, TraceOptions)> {
    let mut out: Vec<(String, TraceOptions)> = STYLES.iter().map(|&m| (m.to_string(), options(m))).collect();
    let mut fine = options(Mode::Hatch);
    fine.hatch.levels = 16;
    out.insert(1, ("hatch --levels 16".to_owned(), fine));
    let mut tsp = options(Mode::Stipple);
    tsp.stipple.tsp = true;
    out.insert(3, ("stipple --tsp".to_owned(), tsp));
    out
}

/// The traced strokes in mm (the picture's frame, origin at its top-left corner), stipple's `--tsp` dots joined into
/// one line as the front end joins them; no strokes when there is nothing to draw.
fn strokes_mm(picture: &GrayImage, opts: &TraceOptions) -> Vec<Vec<Point>> {
    match trace(&DynamicImage::ImageLuma8(picture.clone()), opts) {
        Ok(mut t) => {
            if opts.stipple.tsp {
                join_into_one_line(&mut t.drawing);
            }
            t.drawing.paths().map(|p| p.points.clone()).collect()
        }
        Err(RasterError::NothingToDraw { .. }) => Vec::new(),
        Err(e) => panic!("{}: {e}", opts.mode),
    }
}

/// sRGB encoding of a linear value, rounded to 8 bits.
fn encode(linear: f64) -> u8 {
    let v = if linear <= 0.003_130_8 { 12.92 * linear } else { 1.055 * linear.powf(1.0 / 2.4) - 0.055 };
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)] // in 0..=255
    let v = (v * 255.0).round().clamp(0.0, 255.0) as u8;
    v
}

/// The ramp's L* at `x` mm from its left edge: 100 there, 0 at the right edge.
fn ramp_lightness(x_mm: f64) -> f64 {
    100.0 * (1.0 - x_mm / width_mm())
}

/// The ramp picture: each column at the L* of its middle.
fn ramp() -> GrayImage {
    GrayImage::from_fn(W, H, |x, _| Luma([encode(luminance_from_cie(ramp_lightness((f64::from(x) + 0.5) * PEN_MM)))]))
}

/// Black square, pixels 60..140 × 27..107 (18..42 × 8.1..32.1 mm), on white.
const SQUARE_PX: (u32, u32, u32, u32) = (60, 140, 27, 107);

fn black_square() -> GrayImage {
    let (x0, x1, y0, y1) = SQUARE_PX;
    GrayImage::from_fn(W, H, |x, y| Luma([if (x0..x1).contains(&x) && (y0..y1).contains(&y) { 0 } else { 255 }]))
}

/// Mean of the cells of a lightness image in columns `c0..c1` and rows `r0..r1`.
fn mean(img: &[f32], columns: usize, (c0, c1): (usize, usize), (r0, r1): (usize, usize)) -> f64 {
    let mut sum = 0.0;
    for r in r0..r1 {
        sum += img[r * columns + c0..r * columns + c1].iter().map(|&v| f64::from(v)).sum::<f64>();
    }
    #[allow(clippy::cast_precision_loss)]
    let n = ((c1 - c0) * (r1 - r0)) as f64;
    sum / n
}

fn cells(mm: f64) -> usize {
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let c = (mm / CELL_MM).round() as usize;
    c
}

#[test]
fn a_white_picture_plots_nothing_in_every_style() {
    let white = GrayImage::from_pixel(W, H, Luma([255]));
    for mode in STYLES {
        let e = trace(&DynamicImage::ImageLuma8(white.clone()), &options(mode)).unwrap_err();
        assert!(matches!(e, RasterError::NothingToDraw { .. }), "{mode}: {e:?}");
    }
}

/// The ladder's darkest coverage at the 0.3 mm pen and its default closest spacing, 0.45 mm: three crossed families
/// of lines covering 2/3 each, `1 − (1/3)³ = 26/27`.
const DARKEST: f64 = 26.0 / 27.0;

#[test]
fn a_black_square_plots_at_the_darkest_rung_and_nowhere_else() {
    assert!((options(Mode::Hatch).ladder().darkest() - DARKEST).abs() < 1e-12);
    let picture = black_square();
    let (x0, x1, y0, y1) = SQUARE_PX;
    let mm = |px: u32| f64::from(px) * PEN_MM;
    let (sx0, sx1, sy0, sy1) = (mm(x0), mm(x1), mm(y0), mm(y1));
    let mut failures = Vec::new();
    for (mode, opts) in cases() {
        let b = bounds(opts.mode, opts.hatch.levels);
        let half = PEN_MM / 2.0 + b.outside_mm + 1e-9;
        let strokes = strokes_mm(&picture, &opts);
        let outside = strokes
            .iter()
            .flatten()
            .filter(|p| p.x < sx0 - half || p.x > sx1 + half || p.y < sy0 - half || p.y > sy1 + half)
            .count();
        let worst_out = strokes
            .iter()
            .flatten()
            .map(|p| (sx0 - p.x).max(p.x - sx1).max(sy0 - p.y).max(p.y - sy1))
            .fold(f64::NEG_INFINITY, f64::max);
        // The ink fraction inside, 1 mm in from the square's edges, rendered on 0.05 mm cells.
        let plot = plot_reflectance(&strokes, &picture, &measure_options());
        let ink = 1.0
            - mean(
                &plot.data,
                plot.columns,
                (cells(sx0 + 1.0), cells(sx1 - 1.0)),
                (cells(sy0 + 1.0), cells(sy1 - 1.0)),
            );
        println!("{mode}: black square ink {ink:.3}, {outside} stroke points outside, farthest {worst_out:.2} mm out");
        if ink < b.ink {
            failures.push(format!("{mode}: ink {ink:.3} below {:.3}", b.ink));
        }
        if outside > 0 {
            failures.push(format!("{mode}: {outside} stroke points outside the square, up to {worst_out:.2} mm"));
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

#[test]
fn a_lightness_ramp_plots_within_3_lstar_along_it() {
    let picture = ramp();
    let opts = measure_options();
    let bin = cells(3.0);
    let margin = cells(3.0);
    let mut failures = Vec::new();
    for (mode, o) in cases() {
        let tolerance = bounds(o.mode, o.hatch.levels).ramp;
        let strokes = strokes_mm(&picture, &o);
        let plot: Reflectance = plot_reflectance(&strokes, &picture, &opts);
        let seen = seen_lightness(&plot, &opts);
        let rows = (margin, plot.rows - margin);
        let mut worst = (0.0f64, 0.0f64, 0.0f64);
        let mut c = margin;
        let mut line = String::new();
        while c + bin <= plot.columns - margin {
            let l = 100.0 * mean(&seen, plot.columns, (c, c + bin), rows);
            #[allow(clippy::cast_precision_loss)]
            let want = ramp_lightness((c as f64 + bin as f64 / 2.0) * CELL_MM);
            line.push_str(&format!(" {:+.1}", l - want));
            if (l - want).abs() > worst.0.abs() {
                worst = (l - want, want, l);
            }
            c += bin;
        }
        println!(
            "{mode}: ramp worst ΔL* {:+.2} (L* {:.1} plotted {:.1}); Δ per 3 mm:{line}",
            worst.0, worst.1, worst.2
        );
        if worst.0.abs() > tolerance {
            failures.push(format!("{mode}: L* {:.1} plotted {:.1}", worst.1, worst.2));
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, failure_persistence: None, ..ProptestConfig::default() })]
    /// No style draws outside the picture: every stroke point lies within its rectangle grown by the pen's half
    /// width (where a line along the edge puts its ink on the picture's side).
    #[test]
    fn no_style_puts_ink_outside_the_picture(
        style in 0..STYLES.len(),
        w in 6u32..70,
        h in 6u32..70,
        pitch in 0.15f64..0.8,
        cells in prop::collection::vec(0u8..=255, 16),
    ) {
        let mode = STYLES[style];
        // A 4 × 4 grid of random tones blown up to the picture's size: blocks with edges and corners.
        let picture = GrayImage::from_fn(w, h, |x, y| Luma([cells[((y * 4 / h) * 4 + x * 4 / w) as usize]]));
        let opts = TraceOptions { mode, pitch_mm: Some(pitch), ..TraceOptions::default() };
        let strokes: Vec<Vec<Point>> = match trace(&DynamicImage::ImageLuma8(picture), &opts) {
            Ok(t) => t.drawing.paths().map(|p| p.points.clone()).collect(),
            Err(RasterError::NothingToDraw { .. }) => Vec::new(),
            Err(e) => panic!("{mode}: {e}"),
        };
        let (wm, hm) = (f64::from(w) * pitch, f64::from(h) * pitch);
        let r = PEN_MM / 2.0 + 1e-9;
        for p in strokes.iter().flatten() {
            prop_assert!(
                p.x >= -r && p.x <= wm + r && p.y >= -r && p.y <= hm + r,
                "{mode}: stroke point {p:?} outside the {wm:.2} × {hm:.2} mm picture"
            );
        }
    }
}
