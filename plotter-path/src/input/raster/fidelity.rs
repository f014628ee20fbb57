//! How true a plot is to its picture, as a person sees it from reading distance: the tone measure of the bench.
//!
//! The plot's strokes are rendered in black at the pen's width on white paper, with opaque ink (an overlap is no
//! darker than one line: [`InkGrid`]), on a fine grid that is then averaged into analysis cells, giving the paper's
//! reflectance `1 − ink fraction` per cell. Each fine cell looks at a fixed random point within it
//! ([`InkGrid::jittered`]), so a mark counts its true area wherever it lies: looking at the cells' centres, pen
//! touches that sat on a lattice of their own (stipple dots on quarter pixels) read up to 13 % too dark. The picture's gray values are decoded from sRGB to linear light and
//! averaged into the same cells. Both are blurred with the same Gaussian (σ = 1 mm by default: what the eye
//! resolves at reading distance on a plot 180 mm wide) and converted to CIE L*. The figures:
//!
//! - **L\* error**: the mean of `|L*(plot) − L*(picture)|` over the picture, divided by 100 (0 = the same tone
//!   everywhere; a plot at 50 % ink of a mid-gray 128 picture scores (76.07 − 53.59) / 100 = 0.225).
//! - **SSIM** (Wang, Bovik, Sheikh and Simoncelli, 2004) of the two blurred L*/100 images, with a Gaussian window
//!   of 1.5 σ and the usual constants `(0.01)²` and `(0.03)²`: 1 for identical structure.
//! - **Ink length**: the pen-down length of the strokes, in metres.

use super::ink::InkGrid;
use super::tone::{lightness_cie, srgb_to_linear};
use image::{GrayImage, ImageBuffer, Luma};
use kurbo::Point;

/// Where and how finely the measure looks.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeasureOptions {
    /// The plot's width in mm; the picture spans `[0, width] × [0, width · rows / columns]`.
    pub width_mm: f64,
    /// Pen width in mm (every stroke is rendered at it).
    pub pen_mm: f64,
    /// The eye's blur, a Gaussian σ in mm.
    pub sigma_mm: f64,
    /// Analysis cell size in mm.
    pub cell_mm: f64,
    /// Fine cells per analysis cell along each side, where the ink is rendered.
    pub fine: usize,
}

impl Default for MeasureOptions {
    fn default() -> Self {
        MeasureOptions { width_mm: 180.0, pen_mm: 0.3, sigma_mm: 1.0, cell_mm: 0.25, fine: 5 }
    }
}

/// The figures of one plot against its picture.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fidelity {
    /// Mean |L*(plot) − L*(picture)| / 100 after the eye's blur.
    pub lightness_error: f64,
    /// Structural similarity of the blurred lightness images.
    pub ssim: f64,
    /// Pen-down length in metres.
    pub ink_m: f64,
}

/// A reflectance image (0 = black, 1 = paper) in analysis cells, row by row.
#[derive(Debug, Clone, PartialEq)]
pub struct Reflectance {
    /// Cells across.
    pub columns: usize,
    /// Cells down.
    pub rows: usize,
    /// Linear reflectance per cell.
    pub data: Vec<f32>,
}

/// The grid of analysis cells covering the picture at `opts`: `(columns, rows)`.
fn grid_size(picture: &GrayImage, opts: &MeasureOptions) -> (usize, usize) {
    let height_mm = opts.width_mm * f64::from(picture.height()) / f64::from(picture.width().max(1));
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)] // a few thousand cells
    let size = |mm: f64| (mm / opts.cell_mm).round().max(1.0) as usize;
    (size(opts.width_mm), size(height_mm))
}

/// The picture's linear-light reflectance averaged into analysis cells.
pub fn picture_reflectance(picture: &GrayImage, opts: &MeasureOptions) -> Reflectance {
    let (columns, rows) = grid_size(picture, opts);
    let mut table = [0.0f32; 256];
    for (v, t) in (0u8..=255).zip(table.iter_mut()) {
        #[allow(clippy::cast_possible_truncation)] // a value in [0, 1]
        let x = srgb_to_linear(f64::from(v) / 255.0) as f32;
        *t = x;
    }
    let linear: ImageBuffer<Luma<f32>, Vec<f32>> = ImageBuffer::from_fn(picture.width(), picture.height(), |x, y| {
        Luma([table[usize::from(picture.get_pixel(x, y).0[0])]])
    });
    let (Ok(c), Ok(r)) = (u32::try_from(columns), u32::try_from(rows)) else {
        return Reflectance { columns, rows, data: vec![1.0; columns * rows] };
    };
    let resized = image::imageops::resize(&linear, c, r, image::imageops::FilterType::Triangle);
    Reflectance { columns, rows, data: resized.into_raw() }
}

/// The plot's reflectance: `strokes` (mm, the picture's frame) rendered at the pen's width on the fine grid,
/// averaged into analysis cells.
pub fn plot_reflectance(strokes: &[Vec<Point>], picture: &GrayImage, opts: &MeasureOptions) -> Reflectance {
    let (columns, rows) = grid_size(picture, opts);
    let k = opts.fine.max(1);
    #[allow(clippy::cast_precision_loss)]
    let fine_cell = opts.cell_mm / k as f64;
    let mut grid = InkGrid::jittered(columns * k, rows * k, fine_cell);
    grid.draw(strokes, opts.pen_mm);
    let mut counts = vec![0u32; columns * rows];
    for (i, &inked) in grid.ink.iter().enumerate() {
        if inked {
            let (fx, fy) = (i % grid.columns, i / grid.columns);
            counts[(fy / k) * columns + fx / k] += 1;
        }
    }
    #[allow(clippy::cast_precision_loss)]
    let per = (k * k) as f32;
    #[allow(clippy::cast_precision_loss)]
    let data = counts.iter().map(|&n| 1.0 - n as f32 / per).collect();
    Reflectance { columns, rows, data }
}

/// A Gaussian blur of `sigma` cells (none below a tenth of a cell).
fn blur(img: &Reflectance, sigma: f64) -> Vec<f32> {
    let (Ok(w), Ok(h)) = (u32::try_from(img.columns), u32::try_from(img.rows)) else {
        return img.data.clone();
    };
    if sigma.is_nan() || sigma < 0.1 {
        return img.data.clone();
    }
    let Some(buf) = ImageBuffer::<Luma<f32>, Vec<f32>>::from_raw(w, h, img.data.clone()) else {
        return img.data.clone();
    };
    #[allow(clippy::cast_possible_truncation)] // a blur of a few cells
    let s = sigma as f32;
    imageproc::filter::gaussian_blur_f32(&buf, s).into_raw()
}

/// The lightness the eye sees in each cell of `img`: blurred by `opts.sigma_mm`, then CIE L* / 100 (0 = black,
/// 1 = paper), row by row.
pub fn seen_lightness(img: &Reflectance, opts: &MeasureOptions) -> Vec<f32> {
    #[allow(clippy::cast_possible_truncation)] // L*/100 in [0, 1]
    blur(img, opts.sigma_mm / opts.cell_mm)
        .into_iter()
        .map(|y| (lightness_cie(f64::from(y).clamp(0.0, 1.0)) / 100.0) as f32)
        .collect()
}

/// Compare two reflectance images of the same size as the eye sees them: blurred by `sigma_mm`, in CIE L*.
/// Returns `(lightness error, SSIM)`.
///
/// # Panics
/// When the two images differ in size (the caller builds both on one grid).
pub fn compare(plot: &Reflectance, picture: &Reflectance, opts: &MeasureOptions) -> (f64, f64) {
    assert_eq!((plot.columns, plot.rows), (picture.columns, picture.rows), "the images must share one grid");
    let sigma = opts.sigma_mm / opts.cell_mm;
    let a = seen_lightness(plot, opts);
    let b = seen_lightness(picture, opts);
    if a.is_empty() {
        return (0.0, 1.0);
    }
    let sum: f64 = a.iter().zip(&b).map(|(x, y)| f64::from((x - y).abs())).sum();
    #[allow(clippy::cast_precision_loss)]
    let error = sum / a.len() as f64;
    (error, ssim(&a, &b, plot.columns, plot.rows, 1.5 * sigma))
}

/// Mean SSIM of two images (values 0–1) with a Gaussian window of `window` cells.
fn ssim(a: &[f32], b: &[f32], columns: usize, rows: usize, window: f64) -> f64 {
    let img = |data: Vec<f32>| Reflectance { columns, rows, data };
    let mean = |v: &[f32]| blur(&img(v.to_vec()), window);
    let ma = mean(a);
    let mb = mean(b);
    let aa = mean(&a.iter().map(|x| x * x).collect::<Vec<_>>());
    let bb = mean(&b.iter().map(|x| x * x).collect::<Vec<_>>());
    let ab = mean(&a.iter().zip(b).map(|(x, y)| x * y).collect::<Vec<_>>());
    let (c1, c2) = (0.01f64 * 0.01, 0.03f64 * 0.03);
    let mut total = 0.0;
    for i in 0..a.len() {
        let (mx, my) = (f64::from(ma[i]), f64::from(mb[i]));
        let vx = (f64::from(aa[i]) - mx * mx).max(0.0);
        let vy = (f64::from(bb[i]) - my * my).max(0.0);
        let cxy = f64::from(ab[i]) - mx * my;
        total += ((2.0 * mx * my + c1) * (2.0 * cxy + c2)) / ((mx * mx + my * my + c1) * (vx + vy + c2));
    }
    #[allow(clippy::cast_precision_loss)]
    let n = a.len() as f64;
    total / n
}

/// Measure a plot: `strokes` in mm in the picture's frame (the picture `opts.width_mm` wide, its top-left corner at
/// the origin) against the gray `picture` (sRGB-encoded).
pub fn measure(strokes: &[Vec<Point>], picture: &GrayImage, opts: &MeasureOptions) -> Fidelity {
    let plot = plot_reflectance(strokes, picture, opts);
    let pic = picture_reflectance(picture, opts);
    let (lightness_error, ssim) = compare(&plot, &pic, opts);
    let ink_mm: f64 = strokes.iter().map(|s| s.windows(2).map(|w| w[0].distance(w[1])).sum::<f64>()).sum();
    Fidelity { lightness_error, ssim, ink_m: ink_mm / 1000.0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn opts(width_mm: f64) -> MeasureOptions {
        MeasureOptions { width_mm, ..MeasureOptions::default() }
    }

    #[test]
    fn a_picture_against_itself_scores_zero_error_and_full_similarity() {
        // A ramp with structure: identical images give error 0 and SSIM 1.
        let pic = GrayImage::from_fn(120, 80, |x, y| Luma([u8::try_from((x * 2 + y) % 256).unwrap()]));
        let o = opts(30.0);
        let r = picture_reflectance(&pic, &o);
        let (e, s) = compare(&r, &r, &o);
        assert_eq!(e, 0.0);
        assert!((s - 1.0).abs() < 1e-9, "{s}");
        // Paper against a blank picture: nothing drawn on white is perfect too.
        let white = GrayImage::from_pixel(40, 40, Luma([255]));
        let f = measure(&[], &white, &opts(20.0));
        assert!(f.lightness_error < 1e-6 && (f.ssim - 1.0).abs() < 1e-6 && f.ink_m == 0.0, "{f:?}");
    }

    #[test]
    fn half_ink_lines_on_a_mid_gray_are_22_points_too_light() {
        // Gray 128 is linear 0.21586, L* 53.59; horizontal lines 0.3 mm wide every 0.6 mm cover half the paper,
        // reflectance 0.5, L* 76.07: the error is (76.07 − 53.59) / 100 = 0.2248.
        let pic = GrayImage::from_pixel(100, 100, Luma([128]));
        let o = opts(30.0);
        let lines: Vec<Vec<Point>> = (0..50)
            .map(|i| {
                let y = 0.3 + 0.6 * f64::from(i);
                vec![Point::new(-1.0, y), Point::new(31.0, y)]
            })
            .collect();
        let f = measure(&lines, &pic, &o);
        assert!((f.lightness_error - 0.2248).abs() < 0.002, "{f:?}");
        assert!((f.ink_m - 50.0 * 32.0 / 1000.0).abs() < 1e-9);
        // Solid ink (lines every 0.25 mm at 0.3 mm) on a black picture: no error.
        let black = GrayImage::from_pixel(100, 100, Luma([0]));
        let solid: Vec<Vec<Point>> = (0..=120)
            .map(|i| {
                let y = 0.25 * f64::from(i);
                vec![Point::new(-1.0, y), Point::new(31.0, y)]
            })
            .collect();
        let f = measure(&solid, &black, &o);
        assert!(f.lightness_error < 1e-6, "{f:?}");
    }

    #[test]
    fn touches_on_the_fine_cells_corners_count_their_true_area() {
        // Pen touches 0.3 mm wide every 0.6 mm, each centred on a corner of the 0.05 mm fine cells: they ink
        // π · 0.15² / 0.36 = 0.19635 of the paper. Seen at the cells' centres each covered 32 cells of 0.0025 mm²,
        // 0.2222 of the paper.
        let pic = GrayImage::from_pixel(100, 100, Luma([255]));
        let o = opts(30.0);
        let touches: Vec<Vec<Point>> = (0..2500)
            .map(|i| {
                let p = Point::new(0.3 + 0.6 * f64::from(i % 50), 0.3 + 0.6 * f64::from(i / 50));
                vec![p, p]
            })
            .collect();
        let r = plot_reflectance(&touches, &pic, &o);
        #[allow(clippy::cast_precision_loss)]
        let ink = 1.0 - r.data.iter().map(|&v| f64::from(v)).sum::<f64>() / r.data.len() as f64;
        let want = std::f64::consts::PI * 0.15 * 0.15 / 0.36;
        assert!((ink - want).abs() < 0.002, "{ink} vs {want}");
    }

    #[test]
    fn a_dark_half_plotted_on_the_wrong_side_loses_similarity() {
        // Left half black in the picture; the plot inks the right half instead: L* differs by 100 on both halves
        // away from the middle (blurred across 1 mm at it), so the error is near 1 and SSIM far below 1.
        let pic = GrayImage::from_fn(80, 80, |x, _| Luma([if x < 40 { 0 } else { 255 }]));
        let o = opts(20.0);
        let right: Vec<Vec<Point>> = (0..=80)
            .map(|i| {
                let y = 0.25 * f64::from(i);
                vec![Point::new(10.0, y), Point::new(21.0, y)]
            })
            .collect();
        let f = measure(&right, &pic, &o);
        assert!(f.lightness_error > 0.85, "{f:?}");
        assert!(f.ssim < 0.5, "{f:?}");
    }
}
