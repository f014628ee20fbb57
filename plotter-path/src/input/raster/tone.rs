//! The tone model every image style reads: how dark each point of the picture should plot, and how much ink a
//! family of pen lines lays down.
//!
//! **Target darkness.** A pixel's gray value is first passed through the tone curve ([`ToneCurve`]: levels, then
//! contrast around mid-gray, then gamma, then the optional inversion). The result is still an sRGB-encoded value, so
//! it is decoded to linear light (the IEC 61966-2-1 transfer function) and the darkness is `1 − linear`: the
//! fraction of the paper that opaque black ink must cover so that, seen from a distance, the plot reflects as much
//! light as the picture. Mid-gray 128 is therefore about 78 % ink, not 50 %.
//!
//! **Ink coverage.** Parallel lines of width `w` spaced `s` apart cover `min(1, w / s)` of the paper. Two families
//! crossing at an angle overlap in proportion to their coverage, so together they cover `1 − (1 − c₁)(1 − c₂)`.
//! [`Ladder`] turns a target darkness into one, two or three crossing families at a computed spacing, never closer
//! than the minimum spacing.

use super::error::RasterError;
use image::GrayImage;

/// The tone curve applied to the picture before its darkness is read.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ToneCurve {
    /// Gray value (0–255) that becomes full black: everything darker is clipped to it.
    pub black: u8,
    /// Gray value (0–255) that becomes paper white: everything lighter is clipped to it.
    pub white: u8,
    /// Mid-tone gamma: above 1 lightens the mid-tones, below 1 darkens them (`t^(1/gamma)`).
    pub gamma: f64,
    /// Contrast around mid-gray: 1 keeps it, 2 doubles the distance of every tone from mid-gray.
    pub contrast: f64,
}

impl Default for ToneCurve {
    fn default() -> Self {
        ToneCurve { black: 0, white: 255, gamma: 1.0, contrast: 1.0 }
    }
}

impl ToneCurve {
    /// Range checks, naming the option at fault.
    pub fn validate(&self) -> Result<(), RasterError> {
        let bad = |name: &'static str, value: String, reason: &'static str| {
            Err(RasterError::InvalidOption { name, value, reason })
        };
        if self.black >= self.white {
            return bad(
                "--black-point",
                format!("{} (white point {})", self.black, self.white),
                "must be below --white-point",
            );
        }
        if !(self.gamma.is_finite() && self.gamma > 0.0) {
            return bad("--gamma", self.gamma.to_string(), "must be a positive number");
        }
        if !(self.contrast.is_finite() && self.contrast >= 0.0) {
            return bad("--contrast", self.contrast.to_string(), "must be a number ≥ 0");
        }
        Ok(())
    }

    /// The encoded lightness (0 = black, 1 = white) of gray value `luma` after the curve; `invert` swaps black
    /// and white last.
    pub fn lightness(&self, luma: u8, invert: bool) -> f64 {
        let (b, w) = (f64::from(self.black), f64::from(self.white));
        let t = ((f64::from(luma) - b) / (w - b)).clamp(0.0, 1.0);
        let t = (0.5 + (t - 0.5) * self.contrast).clamp(0.0, 1.0);
        let t = t.powf(1.0 / self.gamma);
        if invert { 1.0 - t } else { t }
    }

    /// The target ink coverage (0 = paper, 1 = solid ink) of gray value `luma`.
    pub fn darkness(&self, luma: u8, invert: bool) -> f64 {
        1.0 - srgb_to_linear(self.lightness(luma, invert))
    }

    /// The darkness of every pixel of `gray`.
    pub fn darkness_map(&self, gray: &GrayImage, invert: bool) -> DarknessMap {
        let mut table = [0.0f32; 256];
        for (v, d) in (0u8..=255).zip(table.iter_mut()) {
            #[allow(clippy::cast_possible_truncation)] // a value in [0, 1]
            let x = self.darkness(v, invert) as f32;
            *d = x;
        }
        DarknessMap {
            width: gray.width() as usize,
            height: gray.height() as usize,
            data: gray.as_raw().iter().map(|&v| table[usize::from(v)]).collect(),
        }
    }
}

/// Target darkness per pixel, row by row (0 = paper, 1 = solid ink).
#[derive(Debug, Clone, PartialEq)]
pub struct DarknessMap {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// `width × height` values, row by row.
    pub data: Vec<f32>,
}

impl DarknessMap {
    /// The darkness at pixel `(x, y)`; outside the picture it is paper (0).
    pub fn at(&self, x: usize, y: usize) -> f32 {
        if x < self.width && y < self.height { self.data[y * self.width + x] } else { 0.0 }
    }
}

/// sRGB-encoded value (0–1) to linear light (0–1), the IEC 61966-2-1 curve.
pub fn srgb_to_linear(v: f64) -> f64 {
    if v <= 0.04045 { v / 12.92 } else { ((v + 0.055) / 1.055).powf(2.4) }
}

/// CIE 1976 lightness L* (0–100) of a linear luminance `y` (0–1, white = 1).
pub fn lightness_cie(y: f64) -> f64 {
    let e = 216.0 / 24389.0;
    if y > e { 116.0 * y.cbrt() - 16.0 } else { y * 24389.0 / 27.0 }
}

/// Linear luminance `y` (0–1, white = 1) of a CIE 1976 lightness L* (0–100): the inverse of [`lightness_cie`].
pub fn luminance_from_cie(l: f64) -> f64 {
    let l = l.clamp(0.0, 100.0);
    if l > 8.0 { ((l + 16.0) / 116.0).powi(3) } else { l * 27.0 / 24389.0 }
}

/// Fraction of the paper covered by parallel lines `pen_mm` wide spaced `spacing_mm` apart: `min(1, w / s)`.
pub fn line_coverage(pen_mm: f64, spacing_mm: f64) -> f64 {
    if spacing_mm <= 0.0 { 1.0 } else { (pen_mm / spacing_mm).min(1.0) }
}

/// Coverage of two line families crossing at an angle: `1 − (1 − c₁)(1 − c₂)`.
pub fn combine(c1: f64, c2: f64) -> f64 {
    1.0 - (1.0 - c1) * (1.0 - c2)
}

/// Spacing at which lines `pen_mm` wide cover `coverage` of the paper; `None` for no coverage.
pub fn spacing_for(coverage: f64, pen_mm: f64) -> Option<f64> {
    (coverage > 0.0).then(|| pen_mm / coverage.min(1.0))
}

/// Most line families a [`Ladder`] stacks (the base angle, the cross angle, a diagonal).
pub const MAX_FAMILIES: u8 = 3;

/// The hatch ladder: lighter tones get one family of lines, spaced from the pen width; when even the minimum
/// spacing is too light, a second family crosses the first, then a third.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ladder {
    /// Pen width in mm.
    pub pen_mm: f64,
    /// Closest spacing of one family in mm.
    pub min_spacing_mm: f64,
}

/// One rung of the ladder: how many families at which spacing, and the darkness they give.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rung {
    /// Number of crossing families (0 = paper).
    pub families: u8,
    /// Spacing of every family, mm (infinite for paper).
    pub spacing_mm: f64,
    /// The coverage these families give together.
    pub coverage: f64,
}

impl Ladder {
    /// The most one family covers, at the minimum spacing.
    pub fn max_family_coverage(&self) -> f64 {
        line_coverage(self.pen_mm, self.min_spacing_mm)
    }

    /// The darkest tone the ladder reaches (every family at the minimum spacing).
    pub fn darkest(&self) -> f64 {
        1.0 - (1.0 - self.max_family_coverage()).powi(i32::from(MAX_FAMILIES))
    }

    /// The rung for a target `darkness`: the fewest families that reach it, each family's coverage `c` solving
    /// `1 − (1 − c)^n = darkness`, its spacing `pen / c` (not below the minimum spacing).
    pub fn rung(&self, darkness: f64) -> Rung {
        if darkness.is_nan() || darkness <= 0.0 {
            return Rung { families: 0, spacing_mm: f64::INFINITY, coverage: 0.0 };
        }
        let cmax = self.max_family_coverage();
        let d = darkness.min(1.0);
        let mut n = 1;
        while n < MAX_FAMILIES && 1.0 - (1.0 - cmax).powi(i32::from(n)) < d {
            n += 1;
        }
        let c = (1.0 - (1.0 - d).powf(1.0 / f64::from(n))).min(cmax);
        let spacing_mm = (self.pen_mm / c).max(self.min_spacing_mm);
        let coverage = 1.0 - (1.0 - line_coverage(self.pen_mm, spacing_mm)).powi(i32::from(n));
        Rung { families: n, spacing_mm, coverage }
    }

    /// The rung for `darkness` as [`Ladder::rung`], except past the ladder's darkest tone (pen 0.3 mm, closest
    /// spacing 0.45 mm: 26/27 = 0.963 ink, L* 22 where black is 0): there the three families close in below the
    /// closest spacing, each at coverage `c = 1 − (1 − d)^⅓` (spacing `pen / c`), so the paper left between them
    /// is the `1 − d` the tone asks for, in holes the eye still averages. Once those holes would be narrower than a
    /// tenth of the pen (`c ≥ 10/11`, darkness 0.99925) a pen's ink fills them anyway, and one family of touching
    /// lines draws the black with a third of the ink.
    ///
    /// (One family `pen / d` apart, as this once was, leaves gaps of `pen · (1/d − 1)`: 0.006 mm at L* 17, which
    /// no pen keeps open, so every tone past the darkest rung plotted as solid black.)
    pub fn rung_to_black(&self, darkness: f64) -> Rung {
        let d = if darkness.is_nan() { 0.0 } else { darkness.min(1.0) };
        if d <= self.darkest() {
            return self.rung(d);
        }
        let c = 1.0 - (1.0 - d).cbrt();
        if c >= SOLID_FAMILY_COVERAGE {
            return Rung { families: 1, spacing_mm: self.pen_mm, coverage: 1.0 };
        }
        let spacing_mm = self.pen_mm / c;
        let coverage = 1.0 - (1.0 - line_coverage(self.pen_mm, spacing_mm)).powi(i32::from(MAX_FAMILIES));
        Rung { families: MAX_FAMILIES, spacing_mm, coverage }
    }
}

/// Past this coverage of one family (gaps a tenth of the pen wide), [`Ladder::rung_to_black`] draws solid.
const SOLID_FAMILY_COVERAGE: f64 = 10.0 / 11.0;

/// For the styles' tests: a `w × h` picture of darkness `d` everywhere.
#[cfg(test)]
pub(crate) fn flat(w: usize, h: usize, d: f32) -> DarknessMap {
    DarknessMap { width: w, height: h, data: vec![d; w * h] }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol
    }

    #[test]
    fn mid_gray_needs_78_percent_ink_not_half() {
        let c = ToneCurve::default();
        // 128/255 = 0.50196; ((0.50196 + 0.055) / 1.055)^2.4 = 0.21586.
        assert!(close(c.darkness(128, false), 1.0 - 0.21586, 1e-4), "{}", c.darkness(128, false));
        assert_eq!(c.darkness(255, false), 0.0);
        assert_eq!(c.darkness(0, false), 1.0);
        assert_eq!(c.darkness(0, true), 0.0);
        // Inverted 128 is 127/255 = 0.49804 → linear 0.21223.
        assert!(close(c.darkness(128, true), 1.0 - 0.21223, 1e-4));
        // The darkest sRGB step is on the linear segment: (1/255) / 12.92.
        assert!(close(c.darkness(1, false), 1.0 - 1.0 / 255.0 / 12.92, 1e-9));
    }

    #[test]
    fn levels_contrast_and_gamma_reshape_the_tones() {
        // Levels 50..200: 125 sits halfway, 40 is clipped to black, 210 to white.
        let lv = ToneCurve { black: 50, white: 200, ..ToneCurve::default() };
        assert!(close(lv.lightness(125, false), 0.5, 1e-12));
        assert_eq!(lv.lightness(40, false), 0.0);
        assert_eq!(lv.lightness(210, false), 1.0);
        // Contrast 2 around mid-gray: 0.25 → 0, 0.6 → 0.7.
        let ct = ToneCurve { contrast: 2.0, ..ToneCurve::default() };
        assert_eq!(ct.lightness(51, false), 0.0); // 51/255 = 0.2 → 0.5 − 0.6 < 0
        assert!(close(ct.lightness(153, false), 0.7, 1e-12)); // 153/255 = 0.6
        // Gamma 2 lightens: 0.25^(1/2) = 0.5.
        let gm = ToneCurve { gamma: 2.0, ..ToneCurve::default() };
        assert!(close(gm.lightness(51, false), 0.2f64.sqrt(), 1e-12));
        // Inversion comes last.
        assert!(close(gm.lightness(51, true), 1.0 - 0.2f64.sqrt(), 1e-12));
    }

    #[test]
    fn bad_curves_are_refused_by_name() {
        let e = ToneCurve { black: 200, white: 100, ..ToneCurve::default() }.validate().unwrap_err();
        assert!(e.to_string().contains("--black-point"), "{e}");
        let e = ToneCurve { gamma: 0.0, ..ToneCurve::default() }.validate().unwrap_err();
        assert!(e.to_string().contains("--gamma"), "{e}");
        let e = ToneCurve { contrast: f64::NAN, ..ToneCurve::default() }.validate().unwrap_err();
        assert!(e.to_string().contains("--contrast"), "{e}");
        assert!(ToneCurve::default().validate().is_ok());
    }

    #[test]
    fn coverage_of_lines_and_crossings() {
        assert!(close(line_coverage(0.3, 1.2), 0.25, 1e-12));
        assert_eq!(line_coverage(0.3, 0.2), 1.0);
        assert!(close(combine(0.5, 0.5), 0.75, 1e-12));
        assert!(close(combine(0.25, 0.4), 0.55, 1e-12));
        assert!(close(spacing_for(0.25, 0.3).unwrap(), 1.2, 1e-12));
        assert_eq!(spacing_for(0.0, 0.3), None);
    }

    #[test]
    fn cie_lightness_of_known_greys() {
        // Mid-gray 128 is L* 53.6; a 50 % ink plot reflects 0.5 → L* 76.07.
        assert!(close(lightness_cie(srgb_to_linear(128.0 / 255.0)), 53.585, 0.01));
        assert!(close(lightness_cie(0.5), 76.069, 0.01));
        assert_eq!(lightness_cie(1.0), 100.0);
        assert_eq!(lightness_cie(0.0), 0.0);
        // And back: L* 50 is ((50 + 16) / 116)³ = 0.18419; L* 4 is on the linear segment, 4 · 27 / 24389.
        assert!(close(luminance_from_cie(50.0), 0.184_19, 1e-5));
        assert!(close(luminance_from_cie(4.0), 108.0 / 24389.0, 1e-12));
        for y in [0.001, 0.05, 0.2159, 0.5, 0.9] {
            assert!(close(luminance_from_cie(lightness_cie(y)), y, 1e-12));
        }
    }

    #[test]
    fn the_ladder_adds_families_as_darkness_grows() {
        // Pen 0.3 mm, closest spacing 0.6 mm: one family covers at most 0.5.
        let l = Ladder { pen_mm: 0.3, min_spacing_mm: 0.6 };
        assert_eq!(l.rung(0.0).families, 0);
        // 0.25 → one family at 0.3 / 0.25 = 1.2 mm.
        let r = l.rung(0.25);
        assert_eq!(r.families, 1);
        assert!(close(r.spacing_mm, 1.2, 1e-12) && close(r.coverage, 0.25, 1e-12));
        // 0.64 → two families, each 1 − √0.36 = 0.4 → 0.75 mm.
        let r = l.rung(0.64);
        assert_eq!(r.families, 2);
        assert!(close(r.spacing_mm, 0.75, 1e-12) && close(r.coverage, 0.64, 1e-12));
        // 0.784 is past two families (0.75): three, each 1 − ∛0.216 = 0.4 → 0.75 mm.
        let r = l.rung(0.784);
        assert_eq!(r.families, 3);
        assert!(close(r.spacing_mm, 0.75, 1e-12) && close(r.coverage, 0.784, 1e-12));
        // Black: three families at the minimum spacing, 1 − 0.5³ = 0.875.
        let r = l.rung(1.0);
        assert_eq!((r.families, r.spacing_mm), (3, 0.6));
        assert!(close(r.coverage, 0.875, 1e-12) && close(l.darkest(), 0.875, 1e-12));
    }

    #[test]
    fn past_three_families_the_ladder_closes_in_to_black() {
        // Pen 0.3 mm, closest spacing 0.45 mm: three families reach 1 − (1/3)³ = 26/27 = 0.963 at most.
        let l = Ladder { pen_mm: 0.3, min_spacing_mm: 0.45 };
        assert_eq!(l.rung_to_black(0.5), l.rung(0.5));
        assert_eq!(l.rung_to_black(26.0 / 27.0), l.rung(26.0 / 27.0));
        // Darker, 0.992 (L* 7.2): three families each covering 1 − ∛0.008 = 0.8, 0.3 / 0.8 = 0.375 mm apart.
        let r = l.rung_to_black(0.992);
        assert_eq!(r.families, 3);
        assert!(close(r.spacing_mm, 0.375, 1e-9) && close(r.coverage, 0.992, 1e-12), "{r:?}");
        // 0.9995: each would cover 1 − ∛0.0005 = 0.9206 > 10/11, gaps under 0.03 mm: one family of touching lines.
        let r = l.rung_to_black(0.9995);
        assert_eq!((r.families, r.spacing_mm, r.coverage), (1, 0.3, 1.0));
        let r = l.rung_to_black(1.0);
        assert_eq!((r.families, r.spacing_mm, r.coverage), (1, 0.3, 1.0));
        assert_eq!(l.rung_to_black(0.0).families, 0);
    }
}
