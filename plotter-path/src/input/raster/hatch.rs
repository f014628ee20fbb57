//! Hatch mode: gray tones as parallel hatch lines clipped exactly to gray-level regions.
//!
//! The default scheme, [`HatchScheme::Tone`], reads the tone model ([`super::tone`]): the darkness range is cut
//! into `levels` bands, even in CIE lightness (band `j` holds the pixels whose L* rounds to `100 · (1 − j / levels)`;
//! band 0 is paper and gets
//! nothing), and each band's region is hatched with the ladder rung for the band's mean darkness: one family at the
//! spacing whose coverage `pen / spacing` equals it, then a second family crossing at 90°, then a third at 45°, each
//! spacing computed so the crossed coverage `1 − (1 − c)^n` is the band's darkness. The bands do not nest; each
//! region's lines are joined into zig-zags ([`zigzag`]) where the connector stays inside the band, which sets the
//! band's spacing (its ink counts the connectors). The plot then takes every band's spans and joins them again as
//! one set ([`join`]): a row that stops at a band's edge goes straight on into the next band's nearest row, so the
//! pen lifts where the ink ends rather than at every band edge (a photo's bands are small and many: the astronaut
//! at the defaults lifts 533 times instead of 2156).
//!
//! The two older schemes split the gray range into `levels` cuts instead. The tone range is split into `levels` bands. Level `i` (0 = lightest) covers every pixel darker than
//! `255 · (N − i) / (N + 1)`, so the regions nest: each darker level lies inside the lighter ones and adds hatching
//! on top of them. Per level a family of parallel lines is added:
//!
//! - [`HatchScheme::Directions`]: level 0 hatches at the base angle, level 1 adds the perpendicular direction
//!   (cross-hatch), levels 2 and 3 the two diagonals; levels beyond four repeat the directions shifted by half the
//!   spacing (halving it).
//! - [`HatchScheme::Density`]: every level uses the base angle; each level fills in between the previous lines, so
//!   level `i` is drawn at spacing `s / 2^i`.
//!
//! Each region's boundary comes from [`trace_contours`] (no simplification, so the region is the bitmap's own
//! shape). Clipping is exact for polygons with the even-odd rule: in a frame rotated so the lines are horizontal,
//! every boundary edge is intersected with the lines whose offset falls in its half-open span `[v_min, v_max)`
//! (so a vertex on a line is counted once), the crossings on each line are sorted, and consecutive pairs are the
//! inside spans. Lines alternate direction (boustrophedon) so the pen travels little between them.

use super::bitmap::Bitmap;
use super::contour::trace_contours;
use super::error::RasterError;
use super::join;
use super::tone::{DarknessMap, Ladder, Rung, lightness_cie, line_coverage, luminance_from_cie};
use super::zigzag;
use image::GrayImage;
use kurbo::Point;
use std::fmt;
use std::str::FromStr;

use super::lines::pen_span;
pub use super::lines::{LineFamily, LineSpans, clip_lines, line_spans};

/// How darker levels add hatching.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum HatchScheme {
    /// Spacing and crossings from the tone model: each tone band gets the families and spacing whose ink matches
    /// its mean darkness ([`tone_hatch`]); lines are joined into zig-zags.
    #[default]
    Tone,
    /// Each level adds a new direction (then repeats them, offset by half the spacing).
    Directions,
    /// Each level halves the spacing of a single direction.
    Density,
}

impl FromStr for HatchScheme {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.to_ascii_lowercase().as_str() {
            "tone" => Ok(HatchScheme::Tone),
            "directions" | "cross" => Ok(HatchScheme::Directions),
            "density" => Ok(HatchScheme::Density),
            _ => Err(format!("unknown hatch scheme `{s}` (expected tone, directions or density)")),
        }
    }
}

impl fmt::Display for HatchScheme {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            HatchScheme::Tone => "tone",
            HatchScheme::Directions => "directions",
            HatchScheme::Density => "density",
        })
    }
}

/// Hatch settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HatchOptions {
    /// Number of gray levels that get hatching (1–16 with the tone scheme, 1–8 with the others).
    pub levels: u8,
    /// Line spacing of one level's family, in mm.
    pub spacing_mm: f64,
    /// Base direction in degrees, counter-clockwise from the +X axis as seen on the page.
    pub angle_deg: f64,
    /// How darker levels add lines.
    pub scheme: HatchScheme,
}

impl Default for HatchOptions {
    fn default() -> Self {
        HatchOptions { levels: 4, spacing_mm: 1.0, angle_deg: 45.0, scheme: HatchScheme::Tone }
    }
}

impl HatchOptions {
    /// Range checks.
    pub fn validate(&self) -> Result<(), RasterError> {
        // The tone scheme's bands are tones; the older schemes add a family (or halve the spacing) per level.
        let (most, reason) = if self.scheme == HatchScheme::Tone {
            (16, "must be 1 to 16")
        } else {
            (8, "must be 1 to 8 with the directions and density schemes")
        };
        if !(1..=most).contains(&self.levels) {
            return Err(RasterError::InvalidOption { name: "--levels", value: self.levels.to_string(), reason });
        }
        if !(self.spacing_mm.is_finite() && self.spacing_mm > 0.0) {
            return Err(RasterError::InvalidOption {
                name: "--spacing",
                value: self.spacing_mm.to_string(),
                reason: "must be a positive number of mm",
            });
        }
        if !self.angle_deg.is_finite() {
            return Err(RasterError::InvalidOption {
                name: "--angle",
                value: self.angle_deg.to_string(),
                reason: "must be a finite number of degrees",
            });
        }
        Ok(())
    }
}

/// One hatch level: its region, its line families and the clipped segments.
#[derive(Debug, Clone, PartialEq)]
pub struct HatchLevel {
    /// Pixels with luma below this value (after the optional inversion) belong to the level.
    pub cut: u8,
    /// The region's boundary loops (pixel coordinates, closed, even-odd).
    pub region: Vec<Vec<Point>>,
    /// The line families this level adds.
    pub families: Vec<LineFamily>,
    /// The hatch segments, in drawing order.
    pub segments: Vec<(Point, Point)>,
    /// Region loops smaller than the minimum area that were dropped.
    pub specks_dropped: usize,
}

/// The families level `i` adds.
pub fn level_families(i: usize, opts: &HatchOptions, spacing_px: f64) -> Vec<LineFamily> {
    let base = opts.angle_deg.to_radians();
    match opts.scheme {
        HatchScheme::Directions | HatchScheme::Tone => {
            let turn = [0.0, 90.0, -45.0, 45.0][i % 4];
            let phase = if (i / 4) % 2 == 1 { spacing_px / 2.0 } else { 0.0 };
            vec![LineFamily { angle: base + f64::to_radians(turn), period: spacing_px, phase }]
        }
        HatchScheme::Density => {
            if i == 0 {
                return vec![LineFamily { angle: base, period: spacing_px, phase: 0.0 }];
            }
            // Level i adds the odd multiples of s / 2^i.
            let parts = 1u32 << i.min(16);
            (0..parts / 2)
                .map(|j| LineFamily {
                    angle: base,
                    period: spacing_px,
                    phase: spacing_px * f64::from(2 * j + 1) / f64::from(parts),
                })
                .collect()
        }
    }
}

/// Hatch `gray` (luma; with `invert` the light tones are hatched instead). `spacing_px` is the family spacing in
/// pixels; region loops under `min_area_px` are dropped.
pub fn hatch(
    gray: &GrayImage,
    opts: &HatchOptions,
    spacing_px: f64,
    invert: bool,
    min_area_px: f64,
) -> Vec<HatchLevel> {
    let (w, h) = (gray.width() as usize, gray.height() as usize);
    let raw = gray.as_raw();
    let n = usize::from(opts.levels.max(1));
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        let cut = u8::try_from((255 * (n - i)) / (n + 1)).unwrap_or(255);
        let mask = Bitmap::from_fn(w, h, |x, y| {
            let v = raw[y * w + x];
            let v = if invert { 255 - v } else { v };
            v < cut
        });
        let (region, specks_dropped) = region_of(&mask, min_area_px);
        let families = level_families(i, opts, spacing_px);
        let mut segments = Vec::new();
        for f in &families {
            segments.extend(clip_lines(&region, f));
        }
        out.push(HatchLevel { cut, region, families, segments, specks_dropped });
    }
    out
}

/// One tone band of [`tone_hatch`]: its region, its rung of the ladder and its strokes.
#[derive(Debug, Clone, PartialEq)]
pub struct ToneBand {
    /// Band number, 1 = lightest.
    pub band: usize,
    /// Target darkness of the band: that of its pixels' mean L*.
    pub darkness: f64,
    /// The ladder rung drawn for it.
    pub rung: Rung,
    /// The region's boundary loops (pixel coordinates, closed, even-odd).
    pub region: Vec<Vec<Point>>,
    /// The line families drawn (pixel periods).
    pub families: Vec<LineFamily>,
    /// Zig-zag strokes, pixel coordinates: the band hatched alone (the plot joins all bands' spans again,
    /// [`ToneHatch::strokes`]).
    pub strokes: Vec<Vec<Point>>,
    /// Region loops smaller than the minimum area that were dropped.
    pub specks_dropped: usize,
}

/// Turns between the ladder's families, degrees from the base angle.
const FAMILY_TURNS: [f64; 3] = [0.0, 90.0, 45.0];

/// The band (0 = paper … `levels`) of a darkness. Bands split CIE lightness evenly (band `j` holds the tones whose
/// L* rounds to `100 · (1 − j / levels)`), as the eye tells tones apart: split evenly in darkness instead, the
/// darkest band would span L* 0 to 22 at four levels, and a near-black plotted at its mean looks dark gray.
fn band_of(d: f32, levels: usize) -> usize {
    let l = lightness_cie(1.0 - f64::from(d).clamp(0.0, 1.0));
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss, clippy::cast_precision_loss)]
    let b = ((100.0 - l) / 100.0 * levels as f64 + 0.5).floor().max(0.0) as usize;
    b.min(levels)
}

/// Hatch the darkness map with the tone ladder: `levels` bands, each region hatched at the rung of its mean
/// darkness, lines at `angle_deg` (then +90°, +45°), spacing converted to pixels with `pixel_mm`. Region loops under
/// `min_area_px` are dropped. The bands' spans are joined across the bands into the plot's strokes by
/// [`join::join`], with links up to three closest spacings long that run over inked pixels.
pub fn tone_hatch(
    map: &DarknessMap,
    levels: u8,
    ladder: &Ladder,
    angle_deg: f64,
    pixel_mm: f64,
    min_area_px: f64,
) -> ToneHatch {
    let n = usize::from(levels.max(1));
    let (w, h) = (map.width, map.height);
    let smooth = smoothed(map, ladder.min_spacing_mm / pixel_mm);
    // Paper stays paper: the smoothing picks the band of pixels that have some tone, but never spreads ink onto
    // white (a black square on white would otherwise get a ring of light hatching around it).
    let bands: Vec<u8> = smooth
        .iter()
        .zip(&map.data)
        .map(|(&s, &d)| if d <= 0.0 { 0 } else { u8::try_from(band_of(s, n)).unwrap_or(u8::MAX) })
        .collect();
    // Each band is drawn at the darkness of its pixels' mean lightness (the mean L*, which the eye averages).
    let mut sums = vec![(0.0f64, 0usize); n + 1];
    for (&b, &d) in bands.iter().zip(&map.data) {
        let s = &mut sums[usize::from(b)];
        s.0 += lightness_cie(1.0 - f64::from(d));
        s.1 += 1;
    }
    let inked = Bitmap::from_fn(w, h, |x, y| bands[y * w + x] > 0);
    let mut out = Vec::new();
    for (band, &(sum, count)) in sums.iter().enumerate().skip(1) {
        if count == 0 {
            continue;
        }
        #[allow(clippy::cast_precision_loss)] // pixel counts are far below 2^53
        let darkness = 1.0 - luminance_from_cie(sum / count as f64);
        let rung = ladder.rung_to_black(darkness);
        if rung.families == 0 {
            continue;
        }
        let mask = Bitmap::from_fn(w, h, |x, y| usize::from(bands[y * w + x]) == band);
        let (region, specks_dropped) = region_of(&mask, min_area_px);
        let period = rung.spacing_mm / pixel_mm;
        let pen_px = ladder.pen_mm / pixel_mm;
        #[allow(clippy::cast_precision_loss)] // pixel counts are far below 2^53
        let area = count as f64;
        let target = line_coverage(pen_px, period) * area;
        let inside = |a: Point, b: Point| connector_inside(&inked, a, b);
        #[allow(clippy::cast_possible_truncation)] // a band number ≤ 16
        let this = band as u8;
        // Whether the band at `p` (a point just past a span's end) is paper or darker than this one.
        let yields = |p: Point| {
            #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
            let (x, y) = (p.x.floor(), p.y.floor());
            #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
            let b = if x < 0.0 || y < 0.0 || x >= w as f64 || y >= h as f64 {
                0
            } else {
                bands[y as usize * w + x as usize]
            };
            b == 0 || b > this
        };
        let mut families = Vec::new();
        let mut strokes = Vec::new();
        for t in &FAMILY_TURNS[..usize::from(rung.families)] {
            let mut f = LineFamily { angle: (angle_deg + t).to_radians(), period, phase: 0.0 };
            let mut s = family_strokes(&region, &f, pen_px, inside, yields);
            // The zig-zags' connectors and short spans add ink the spacing did not count: respace once so the
            // family's ink matches its share of the band (never closer than the pen's width).
            let ink = stroke_ink(&s, pen_px, period);
            if ink > 0.0 && target > 0.0 {
                let respaced = (period * ink / target).clamp(period / 2.0, period * 2.0).max(pen_px);
                if (respaced - period).abs() > 1e-3 * period {
                    let (g, gs) =
                        best_phase(respaced, target, pen_px, f, |g| family_strokes(&region, g, pen_px, inside, yields));
                    (f, s) = (g, gs);
                }
            }
            families.push(f);
            strokes.extend(s);
        }
        out.push(ToneBand { band, darkness, rung, region, families, strokes, specks_dropped });
    }
    let zigzags: Vec<Vec<Point>> = out.iter().flat_map(|b| b.strokes.iter().cloned()).collect();
    let max_link = link_reach(ladder, pixel_mm);
    let strokes = join::join(&zigzags, max_link, |a, b| connector_inside(&inked, a, b));
    ToneHatch { bands: out, strokes }
}

/// Closest spacings in the longest link [`join::join`] draws between two spans of a tone hatch.
///
/// Three (1.35 mm with a 0.3 mm pen) is about the longest connector a band's own zig-zag draws (two periods along
/// the band's edge and one across, √5 · 0.58 mm at the lightest band's spacing). Measured on the astronaut at the
/// defaults (pen lifts after ordering at 0.3 mm pixels, and the tone bench's L* error at 180 mm), with the bands'
/// own turns kept where nothing better offers (the links of two, four and six spacings measured before those
/// were kept): two spacings 935 lifts, L* 0.0323; three 533, 0.0336; four 404, 0.0354; six 229, 0.0386 (the bands
/// hatched alone: 2156 lifts, 0.0364). Longer links join more, but their ink lands on tones that did not ask for it.
const LINK_REACH_SPACINGS: f64 = 3.0;

/// The longest link [`join::join`] draws between two spans of a tone hatch, pixels.
fn link_reach(ladder: &Ladder, pixel_mm: f64) -> f64 {
    LINK_REACH_SPACINGS * ladder.min_spacing_mm / pixel_mm
}

/// A tone hatch: its bands, each hatched on its own, and the strokes the plot draws (every band's spans joined
/// across the bands by [`join::join`]).
#[derive(Debug, Clone, PartialEq)]
pub struct ToneHatch {
    /// The bands, lightest first, with their own zig-zags.
    pub bands: Vec<ToneBand>,
    /// The plot's strokes, pixel coordinates.
    pub strokes: Vec<Vec<Point>>,
}

/// A respaced family misses its ink by more than this share when its lines fall badly across a narrow region.
const PHASE_MISS: f64 = 0.02;

/// The family `before` (its angle kept) at the `respaced` period, its strokes drawn by `draw`: at phase 0, and while
/// the closest so far misses the `target` ink by more than [`PHASE_MISS`], at a half, a third, two thirds, a sixth
/// and five sixths of the period, keeping whichever phase inks closest to the target.
///
/// A band's lines come in whole lines: a strip 3.75 mm wide (one of sixteen bands on a 60 mm ramp) holds 7 or 8
/// vertical lines 0.46 mm apart as their phase falls, not the 7.76 the spacing asks for. Respaced from the 7 it
/// drew, the family closed up 10 % and drew 9 at phase 0 (the band's ink 0.969 for its 0.956: L* 22.5 plotted
/// 18.9); other phases draw 8.
fn best_phase(
    respaced: f64,
    target: f64,
    pen: f64,
    before: LineFamily,
    draw: impl Fn(&LineFamily) -> Vec<Vec<Point>>,
) -> (LineFamily, Vec<Vec<Point>>) {
    let miss = |ink: f64| (ink - target).abs();
    let mut best = (before, Vec::new(), f64::INFINITY);
    for sixths in [0.0, 3.0, 2.0, 4.0, 1.0, 5.0] {
        if best.2 <= PHASE_MISS * target {
            break;
        }
        let g = LineFamily { period: respaced, phase: respaced * sixths / 6.0, ..before };
        let s = draw(&g);
        let m = miss(stroke_ink(&s, pen, respaced));
        if m < best.2 {
            best = (g, s, m);
        }
    }
    (best.0, best.1)
}

/// One family's strokes over a region, as the pen draws them: each span end that meets paper or a darker band
/// (`yields` at a point just past the end) pulled in by the pen's radius, so its round cap ends on the region's
/// boundary instead of inking the paper or darkening the next band; an end that meets a lighter band is drawn to the
/// boundary, its cap spilling over (pulled in on both sides, a seam between two near-black bands would keep a strip
/// of paper along it: with 16 bands the darkest ones plotted L* 22 instead of 6). Spans too short for their
/// pull-ins (a pen's width) are kept as a dot at their middle when the dot's ink (`π r²`) is no more than twice the span's
/// (`w · length`); the spans are joined into zig-zags.
fn family_strokes(
    region: &[Vec<Point>],
    f: &LineFamily,
    pen_px: f64,
    inside: impl Fn(Point, Point) -> bool,
    yields: impl Fn(Point) -> bool,
) -> Vec<Vec<Point>> {
    let r = pen_px / 2.0;
    let (d, n) = f.frame();
    let mut lines = line_spans(region, f);
    for line in &mut lines {
        let v = line.v;
        let at = |u: f64| Point::new(u * d.0 + v * n.0, u * d.1 + v * n.1);
        line.spans = line
            .spans
            .iter()
            .filter_map(|&(a, b)| {
                // Half a pixel past each end: the neighbour across the boundary. A hair further, so that an end on
                // a pixel's centre (where a line along the region's edge meets its cut corner) does not probe a
                // point on the pixel grid, which rounds down into the region itself on the lower side only.
                let past = 0.5 + 1e-6;
                let ra = if yields(at(a - past)) { r } else { 0.0 };
                let rb = if yields(at(b + past)) { r } else { 0.0 };
                pen_span((a, b), pen_px, (ra, rb))
            })
            .collect();
    }
    zigzag::join(&lines, f, 2.0 * f.period.max(1.0), inside)
}

/// The paper zig-zag strokes `pen` wide cover when their spans lie `period` apart: every span (a stroke's even
/// segments) at `pen` times its length, plus each stroke's two round caps; a connector (the odd segments, run along
/// the region's edge from one span's end to the next) only for the part of its path the spans' ends leave bare,
/// `1 − pen / period` of it: where the lines touch (a solid fill) a connector adds no ink at all, and counting it
/// whole made the respacing widen a near-black fill by the connectors' length (a 3.75 mm band of 45° lines: 8 %,
/// L* 7 plotted as 25).
fn stroke_ink(strokes: &[Vec<Point>], pen: f64, period: f64) -> f64 {
    let caps = std::f64::consts::PI * pen * pen / 4.0;
    let bare = 1.0 - line_coverage(pen, period);
    strokes
        .iter()
        .map(|s| {
            let ink: f64 = s
                .windows(2)
                .enumerate()
                .map(|(i, e)| e[0].distance(e[1]) * if i % 2 == 0 { pen } else { pen * bare })
                .sum();
            ink + caps
        })
        .sum()
}

/// The darkness map blurred with a Gaussian of `sigma_px` (skipped below half a pixel), so that bands follow the
/// tone at the scale of the hatch spacing rather than single noisy pixels.
fn smoothed(map: &DarknessMap, sigma_px: f64) -> Vec<f32> {
    if sigma_px.is_nan() || sigma_px < 0.5 || map.width == 0 || map.height == 0 {
        return map.data.clone();
    }
    let (Ok(w), Ok(h)) = (u32::try_from(map.width), u32::try_from(map.height)) else {
        return map.data.clone();
    };
    let Some(img) = image::ImageBuffer::<image::Luma<f32>, Vec<f32>>::from_raw(w, h, map.data.clone()) else {
        return map.data.clone();
    };
    #[allow(clippy::cast_possible_truncation)] // a blur radius of a few pixels
    let sigma = sigma_px as f32;
    imageproc::filter::gaussian_blur_f32(&img, sigma).into_raw()
}

/// Whether the straight stroke from `a` to `b` (both on a region's boundary) runs through the mask's pixels: its
/// points are sampled every half pixel, ends excluded.
fn connector_inside(mask: &Bitmap, a: Point, b: Point) -> bool {
    let len = a.distance(b);
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)] // a short connector: a few samples
    let steps = (len * 2.0).ceil().max(2.0) as u32;
    // A sample on a pixel edge (a connector along the region's boundary) counts when a pixel on either side is set.
    let e = 1e-9;
    #[allow(clippy::cast_possible_truncation)] // inside the image
    let px = |v: f64| v.floor() as isize;
    (1..steps).all(|i| {
        let p = a.lerp(b, f64::from(i) / f64::from(steps));
        [(-e, -e), (-e, e), (e, -e), (e, e)].iter().any(|&(dx, dy)| mask.get(px(p.x + dx), px(p.y + dy)))
    })
}

/// The closed boundary loops of `mask`'s set pixels (even-odd), leaving out specks smaller than `min_area_px`, and
/// how many were left out.
fn region_of(mask: &Bitmap, min_area_px: f64) -> (Vec<Vec<Point>>, usize) {
    let mut specks_dropped = 0;
    let mut region = Vec::new();
    for c in trace_contours(mask) {
        if c.signed_area.abs() < min_area_px {
            specks_dropped += 1;
        } else {
            region.push(c.closed_points());
        }
    }
    (region, specks_dropped)
}

/// Even-odd point-in-polygon test over closed loops (used by tests and available to callers that need it).
pub fn inside_even_odd(loops: &[Vec<Point>], p: Point) -> bool {
    let mut inside = false;
    for pl in loops {
        for e in pl.windows(2) {
            let (a, b) = (e[0], e[1]);
            if (a.y > p.y) != (b.y > p.y) {
                let x = a.x + (p.y - a.y) / (b.y - a.y) * (b.x - a.x);
                if p.x < x {
                    inside = !inside;
                }
            }
        }
    }
    inside
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::raster::ink::InkGrid;
    use crate::input::raster::simplify::point_segment_distance;
    use image::Luma;
    use proptest::prelude::*;

    fn boundary_distance(loops: &[Vec<Point>], p: Point) -> f64 {
        loops
            .iter()
            .flat_map(|l| l.windows(2).map(move |e| point_segment_distance(p, e[0], e[1])))
            .fold(f64::INFINITY, f64::min)
    }

    #[test]
    fn black_square_gets_every_level_with_exact_counts() {
        // A 40×40 black square from (10,10) to (50,50); lines at spacing 4 px, horizontal.
        let g = GrayImage::from_fn(60, 60, |x, y| {
            Luma([if (10..50).contains(&x) && (10..50).contains(&y) { 0 } else { 255 }])
        });
        let opts = HatchOptions { levels: 2, spacing_mm: 4.0, angle_deg: 0.0, scheme: HatchScheme::Directions };
        let levels = hatch(&g, &opts, 4.0, false, 0.0);
        assert_eq!(levels.len(), 2);
        // Horizontal lines y = 12, 16, ..., 48 cross the square (boundary at y = 10 and 50): 10 lines.
        assert_eq!(levels[0].segments.len(), 10);
        for (a, b) in &levels[0].segments {
            assert_eq!(a.y, b.y);
            assert!((a.x - b.x).abs() == 40.0, "{a:?} {b:?}");
        }
        // Level 1 is vertical at the same spacing.
        assert_eq!(levels[1].segments.len(), 10);
        assert!(levels[1].segments.iter().all(|(a, b)| (a.x - b.x).abs() < 1e-9));
        // Boustrophedon: consecutive lines run in opposite directions.
        let s = &levels[0].segments;
        assert!((s[0].1.x - s[0].0.x) * (s[1].1.x - s[1].0.x) < 0.0);
    }

    #[test]
    fn density_scheme_halves_the_spacing() {
        let g = GrayImage::from_pixel(64, 64, Luma([0]));
        let opts = HatchOptions { levels: 3, spacing_mm: 8.0, angle_deg: 0.0, scheme: HatchScheme::Density };
        let levels = hatch(&g, &opts, 8.0, false, 0.0);
        let mut ys: Vec<f64> = levels.iter().flat_map(|l| l.segments.iter().map(|s| s.0.y)).collect();
        ys.sort_by(f64::total_cmp);
        ys.dedup();
        // The union of three levels is spaced 2 px apart.
        for w in ys.windows(2) {
            assert!((w[1] - w[0] - 2.0).abs() < 1e-9, "{ys:?}");
        }
    }

    #[test]
    fn gray_levels_nest() {
        // A horizontal gradient: darker levels cover less.
        let g = GrayImage::from_fn(100, 20, |x, _| Luma([u8::try_from(x * 255 / 99).unwrap()]));
        let opts = HatchOptions { levels: 4, spacing_mm: 2.0, angle_deg: 90.0, scheme: HatchScheme::Directions };
        let levels = hatch(&g, &opts, 2.0, false, 0.0);
        let widths: Vec<f64> =
            levels.iter().map(|l| crate::input::raster::signed_area(&l.region[0][1..]).abs()).collect();
        assert!(widths.windows(2).all(|w| w[0] > w[1]), "{widths:?}");
        // Inverting shades the light end instead.
        let inv = hatch(&g, &opts, 2.0, true, 0.0);
        let x_of = |l: &HatchLevel| l.region[0].iter().map(|p| p.x).sum::<f64>() / l.region[0].len() as f64;
        assert!(x_of(&inv[0]) > x_of(&levels[0]));
    }

    fn tone_strokes_mm(g: &GrayImage, levels: u8, pixel_mm: f64) -> (Vec<ToneBand>, Vec<Vec<Point>>) {
        let map = crate::input::raster::tone::ToneCurve::default().darkness_map(g, false);
        let ladder = Ladder { pen_mm: 0.3, min_spacing_mm: 0.45 };
        let hatched = tone_hatch(&map, levels, &ladder, 45.0, pixel_mm, 4.0);
        let mm = hatched
            .strokes
            .iter()
            .map(|s| s.iter().map(|p| Point::new(p.x * pixel_mm, p.y * pixel_mm)).collect())
            .collect();
        (hatched.bands, mm)
    }

    #[test]
    fn tone_hatch_inks_a_flat_gray_as_dark_as_its_linear_light() {
        // Gray 128 asks for 1 − 0.21586 = 0.784 ink. Pen 0.3 mm, closest spacing 0.45 mm: one family covers at
        // most 2/3, two 0.889, so two families at coverage 1 − √0.216 = 0.535 each, 0.561 mm apart.
        let g = GrayImage::from_pixel(100, 100, Luma([128]));
        let (bands, strokes) = tone_strokes_mm(&g, 4, 0.3);
        assert_eq!(bands.len(), 1);
        // L* 53.6: (100 − 53.6) / 100 · 4 = 1.86 rounds to band 2 of 4.
        assert_eq!(bands[0].band, 2);
        assert_eq!(bands[0].rung.families, 2);
        assert!((bands[0].rung.spacing_mm - 0.3 / (1.0 - 0.216f64.sqrt())).abs() < 1e-3, "{:?}", bands[0].rung);
        // Rendered at 0.3 mm on a 0.02 mm grid, away from the 30 mm square's edges: the ink fraction.
        let mut grid = InkGrid::new(1500, 1500, 0.02);
        grid.draw(&strokes, 0.3);
        let f = grid.fraction(250, 1250, 250, 1250);
        assert!((f - 0.784).abs() < 0.02, "ink fraction {f}");
        // Joined: each family's lines are one zig-zag (two strokes for the square).
        assert_eq!(strokes.len(), 2, "{} strokes", strokes.len());
    }

    #[test]
    fn tone_hatch_leaves_white_empty_and_gives_black_the_darkest_rung() {
        let white = GrayImage::from_pixel(50, 50, Luma([255]));
        assert!(tone_strokes_mm(&white, 4, 0.3).0.is_empty());
        // A light gray (250: darkness 0.04) rounds to paper with 4 bands and with 8 (0.04 · 8 < 0.5).
        let light = GrayImage::from_pixel(50, 50, Luma([250]));
        assert!(tone_strokes_mm(&light, 4, 0.3).0.is_empty());
        assert_eq!(tone_strokes_mm(&light, 8, 0.3).0.len(), 0);
        let g = GrayImage::from_fn(60, 60, |x, y| {
            Luma([if (10..50).contains(&x) && (10..50).contains(&y) { 0 } else { 255 }])
        });
        let (bands, strokes) = tone_strokes_mm(&g, 4, 0.3);
        // The square's edge, smoothed at the closest spacing (1.5 px), rings it with lighter bands.
        let darkest = bands.last().unwrap();
        // Black is past three crossed families (26/27 = 0.963): filled solid, lines one pen width apart.
        assert_eq!((darkest.band, darkest.rung.families, darkest.rung.spacing_mm), (4, 1, 0.3));
        let mut grid = InkGrid::new(900, 900, 0.02);
        grid.draw(&strokes, 0.3);
        let f = grid.fraction(200, 700, 200, 700);
        // More than three crossed families give (26/27 = 0.963); the rest is the grid's cells on the lines' edges.
        assert!(f > 0.975, "ink fraction {f}");
        assert_eq!(grid.fraction(0, 900, 0, 120), 0.0);
    }

    #[test]
    fn rows_run_on_across_a_band_edge() {
        // A 12 mm field at L* 87.5 around a 4 mm square (pixels 40..80) at L* 75: pixels 0.1 mm, pen 0.3 mm, eight
        // bands, so bands 1 and 2 with one horizontal family each.
        #[allow(clippy::cast_possible_truncation)]
        let (lf, ls) = ((1.0 - luminance_from_cie(87.5)) as f32, (1.0 - luminance_from_cie(75.0)) as f32);
        let square = |i: usize| (40..80).contains(&(i % 120)) && (40..80).contains(&(i / 120));
        let data = (0..120 * 120).map(|i| if square(i) { ls } else { lf }).collect();
        let map = DarknessMap { width: 120, height: 120, data };
        let ladder = Ladder { pen_mm: 0.3, min_spacing_mm: 0.45 };
        let hatched = tone_hatch(&map, 8, &ladder, 0.0, 0.1, 0.0);
        assert_eq!(hatched.bands.iter().map(|b| (b.band, b.families.len())).collect::<Vec<_>>(), [(1, 1), (2, 1)]);
        // Hatched alone, the field zig-zags in two strokes (its rows split around the square) and the square in one.
        let alone: usize = hatched.bands.iter().map(|b| b.strokes.len()).sum();
        let spans: usize = hatched.bands.iter().flat_map(|b| &b.strokes).map(|s| s.len() / 2).sum();
        assert_eq!((alone, spans), (3, 21));
        // Joined, the field's rows that meet the square go on into its rows (links cross its left edge, x 40, three
        // times) and all 21 spans make one stroke.
        let joined: usize = hatched.strokes.iter().map(|s| s.len() / 2).sum();
        assert_eq!((hatched.strokes.len(), joined), (1, 21));
        let links: Vec<(Point, Point)> =
            hatched.strokes.iter().flat_map(|s| s.windows(2).skip(1).step_by(2).map(|w| (w[0], w[1]))).collect();
        let into = links.iter().filter(|(a, b)| (a.x < 40.0) != (b.x < 40.0)).count();
        assert_eq!(into, 3, "{links:?}");
    }

    #[test]
    fn bands_split_lightness_evenly() {
        // L* 30 is luminance ((30 + 16) / 116)³ = 0.06236, darkness 0.93764: with 4 bands (100 − 30) / 100 · 4 =
        // 2.8 rounds to band 3 (split evenly in darkness it would be 0.93764 · 4 = 3.75, band 4 with black).
        let d30 = 1.0 - ((30.0f64 + 16.0) / 116.0).powi(3);
        #[allow(clippy::cast_possible_truncation)]
        let d30 = d30 as f32;
        assert_eq!(band_of(d30, 4), 3);
        // L* 10 (luminance 0.01126) with 8 bands: 90 / 100 · 8 = 7.2 → band 7; black is band 8, white band 0.
        #[allow(clippy::cast_possible_truncation)]
        let d10 = (1.0 - ((10.0f64 + 16.0) / 116.0).powi(3)) as f32;
        assert_eq!(band_of(d10, 8), 7);
        assert_eq!((band_of(1.0, 8), band_of(0.0, 8)), (8, 0));
    }

    #[test]
    fn spans_end_a_pen_radius_inside_the_region_and_the_ink_matches_the_band() {
        // A flat 200 × 200 px picture (0.1 mm px) of darkness 0.25 with a 0.3 mm (3 px) pen: horizontal lines 12 px
        // apart. Every span is pulled in by 1.5 px at both ends, so with its round caps it ends on the picture's edge.
        let map = DarknessMap { width: 200, height: 200, data: vec![0.25; 40_000] };
        let ladder = Ladder { pen_mm: 0.3, min_spacing_mm: 0.45 };
        let bands = tone_hatch(&map, 16, &ladder, 0.0, 0.1, 0.0).bands;
        assert_eq!(bands.len(), 1);
        let xs: Vec<f64> = bands[0].strokes.iter().flatten().map(|p| p.x).collect();
        let (lo, hi) = xs.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| (a.min(x), b.max(x)));
        assert!((lo - 1.5).abs() < 1e-9 && (hi - 198.5).abs() < 1e-9, "{lo} {hi}");
        // The ink (strokes 3 px wide, caps and connectors included) is the band's darkness times its area, 10⁴ px²,
        // within a twentieth: the spacing was corrected for the connectors.
        let ink = stroke_ink(&bands[0].strokes, 3.0, bands[0].families[0].period);
        let want = bands[0].darkness * 40_000.0;
        assert!((ink - want).abs() < want / 20.0, "ink {ink} vs {want}");
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]
        #[test]
        fn segments_lie_inside_their_region_at_the_requested_spacing(
            cells in prop::collection::vec(0u8..=255, 64),
            angle in -180.0f64..180.0,
            spacing in 1.5f64..9.0,
            levels in 1u8..=5,
            density in any::<bool>(),
        ) {
            // An 8×8 random tone grid blown up to 48×48 pixels gives blocky regions with holes and corners.
            let g = GrayImage::from_fn(48, 48, |x, y| Luma([cells[(y / 6 * 8 + x / 6) as usize]]));
            let scheme = if density { HatchScheme::Density } else { HatchScheme::Directions };
            let opts = HatchOptions { levels, spacing_mm: spacing, angle_deg: angle, scheme };
            for level in hatch(&g, &opts, spacing, false, 0.0) {
                for &(a, b) in &level.segments {
                    // Ends on the region's boundary.
                    prop_assert!(boundary_distance(&level.region, a) < 1e-6);
                    prop_assert!(boundary_distance(&level.region, b) < 1e-6);
                    // Inside (or on the boundary) all along.
                    for t in 1..16 {
                        let p = a.lerp(b, f64::from(t) / 16.0);
                        prop_assert!(
                            inside_even_odd(&level.region, p) || boundary_distance(&level.region, p) < 1e-6,
                            "{:?} outside its region", p
                        );
                    }
                    // On one of the level's lines: same offset at both ends, a whole number of periods from a phase.
                    let fam = level.families.iter().find(|f| {
                        let (va, vb) = (f.offset(a), f.offset(b));
                        let k = (va - f.phase) / f.period;
                        (va - vb).abs() < 1e-6 && (k - k.round()).abs() < 1e-6
                            && ((b - a).normalize().dot(kurbo::Vec2::new(f.frame().0.0, f.frame().0.1)).abs() - 1.0).abs() < 1e-6
                    });
                    prop_assert!(fam.is_some(), "segment {:?}-{:?} is on none of the level's lines", a, b);
                }
                // Spacing: every family's period is the requested spacing.
                for f in &level.families {
                    prop_assert!((f.period - spacing).abs() < 1e-12);
                }
            }
        }
    }
}
