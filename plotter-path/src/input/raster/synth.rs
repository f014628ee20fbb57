//! Synthetic test images: discs, rings, strokes of known centre line, stroke-font letters, and the two sample
//! pictures of `samples/` (line art and a photo-like gray scene).
//!
//! Everything is computed from geometry (distances to segments and arcs), so the true shapes are known exactly:
//! tests compare traced results against them, the benchmark feeds them to each mode, and
//! `examples/make_raster_samples.rs` writes the sample PNGs from them. No font file or image is copied from
//! anywhere; the letters come from a tiny stroke font defined below.

use super::bitmap::Bitmap;
use image::{GrayImage, Luma};
use kurbo::Point;
use std::f64::consts::PI;

/// Pixel centre of pixel `(x, y)`.
fn centre(x: usize, y: usize) -> Point {
    #[allow(clippy::cast_precision_loss)] // image coordinates < 2^31
    Point::new(x as f64 + 0.5, y as f64 + 0.5)
}

/// A filled disc: pixels whose centre lies within `r` of `c`.
pub fn disc(width: usize, height: usize, c: (f64, f64), r: f64) -> Bitmap {
    Bitmap::from_fn(width, height, |x, y| centre(x, y).distance(Point::new(c.0, c.1)) <= r)
}

/// An annulus: pixel centres at distance in `[r_in, r_out]` from `c`.
pub fn ring(width: usize, height: usize, c: (f64, f64), r_in: f64, r_out: f64) -> Bitmap {
    Bitmap::from_fn(width, height, |x, y| {
        let d = centre(x, y).distance(Point::new(c.0, c.1));
        (r_in..=r_out).contains(&d)
    })
}

/// A stroke's centre line as a fine polyline (arcs are flattened to 0.01 px chord error).
#[derive(Debug, Clone, PartialEq)]
pub struct Stroke {
    /// Centre-line vertices in pixel coordinates.
    pub points: Vec<Point>,
}

impl Stroke {
    /// A straight stroke.
    pub fn line(a: (f64, f64), b: (f64, f64)) -> Self {
        Stroke { points: vec![Point::new(a.0, a.1), Point::new(b.0, b.1)] }
    }

    /// An elliptic arc around `c` with radii `r`, from angle `start` sweeping `sweep` (radians, Y down).
    pub fn arc(c: (f64, f64), r: (f64, f64), start: f64, sweep: f64) -> Self {
        let rmax = r.0.max(r.1).max(1e-9);
        // Chord error of a step dθ on radius R is R(1 − cos(dθ/2)) ≈ R dθ²/8 ≤ 0.01.
        let step = (0.08 / rmax).sqrt();
        let n = (sweep.abs() / step).ceil().max(1.0);
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)] // n ≥ 1 and small
        let count = n as usize;
        let points = (0..=count)
            .map(|i| {
                #[allow(clippy::cast_precision_loss)] // small counts
                let t = start + sweep * (i as f64) / n;
                Point::new(c.0 + r.0 * t.cos(), c.1 + r.1 * t.sin())
            })
            .collect();
        Stroke { points }
    }

    /// Centre-line length.
    pub fn length(&self) -> f64 {
        self.points.windows(2).map(|w| w[0].distance(w[1])).sum()
    }

    /// Distance from `p` to the centre line.
    pub fn distance(&self, p: Point) -> f64 {
        self.points
            .windows(2)
            .map(|w| super::simplify::point_segment_distance(p, w[0], w[1]))
            .fold(f64::INFINITY, f64::min)
    }

    /// Points along the centre line about `step` apart (for coverage checks).
    pub fn samples(&self, step: f64) -> Vec<Point> {
        let mut out = vec![self.points[0]];
        for w in self.points.windows(2) {
            let len = w[0].distance(w[1]);
            let n = (len / step).ceil().max(1.0);
            #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)] // n ≥ 1 and small
            for i in 1..=(n as usize) {
                #[allow(clippy::cast_precision_loss)] // small counts
                out.push(w[0].lerp(w[1], i as f64 / n));
            }
        }
        out
    }
}

/// Distance from every pixel centre to the nearest stroke centre line, computed only within `reach` of a stroke
/// (farther pixels get `f64::INFINITY`).
pub fn distance_field(width: usize, height: usize, strokes: &[Stroke], reach: f64) -> Vec<f64> {
    let mut d = vec![f64::INFINITY; width * height];
    for s in strokes {
        for w in s.points.windows(2) {
            let (a, b) = (w[0], w[1]);
            let clampi = |v: f64, hi: usize| -> usize {
                #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)] // clamped to [0, hi]
                let r = v.floor().clamp(0.0, hi as f64) as usize;
                r
            };
            let (x0, x1) = (clampi(a.x.min(b.x) - reach - 1.0, width), clampi(a.x.max(b.x) + reach + 1.0, width));
            let (y0, y1) = (clampi(a.y.min(b.y) - reach - 1.0, height), clampi(a.y.max(b.y) + reach + 1.0, height));
            for y in y0..y1 {
                for x in x0..x1 {
                    let dist = super::simplify::point_segment_distance(centre(x, y), a, b);
                    let cell = &mut d[y * width + x];
                    if dist < *cell && dist <= reach {
                        *cell = dist;
                    }
                }
            }
        }
    }
    d
}

/// Strokes of width `stroke_px` with round caps: pixel centres within half the width of a centre line.
pub fn stroke_bitmap(width: usize, height: usize, strokes: &[Stroke], stroke_px: f64) -> Bitmap {
    let d = distance_field(width, height, strokes, stroke_px / 2.0);
    Bitmap::from_fn(width, height, |x, y| d[y * width + x] <= stroke_px / 2.0)
}

/// Anti-aliased black strokes on white: ink coverage falls from 1 to 0 over one pixel at the stroke edge.
pub fn stroke_gray(width: usize, height: usize, strokes: &[Stroke], stroke_px: f64) -> GrayImage {
    let d = distance_field(width, height, strokes, stroke_px / 2.0 + 1.0);
    gray_from_fn(width, height, |x, y| {
        let coverage = (stroke_px / 2.0 - d[y * width + x] + 0.5).clamp(0.0, 1.0);
        255.0 * (1.0 - coverage)
    })
}

/// Build a gray image from a luma function (values clamped to 0–255 and rounded).
fn gray_from_fn(width: usize, height: usize, f: impl Fn(usize, usize) -> f64) -> GrayImage {
    let w = u32::try_from(width).unwrap_or(u32::MAX);
    let h = u32::try_from(height).unwrap_or(u32::MAX);
    GrayImage::from_fn(w, h, |x, y| {
        let v = f(x as usize, y as usize).round().clamp(0.0, 255.0);
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)] // clamped to 0..=255
        Luma([v as u8])
    })
}

/// The stroke font: each glyph is a list of polylines in a box 0.6 wide and 1 tall (Y down, baseline at 1).
/// Arcs are listed as `None` markers resolved in [`glyph`].
fn glyph_lines(ch: char) -> Option<Vec<Vec<(f64, f64)>>> {
    let g = match ch.to_ascii_uppercase() {
        'A' => vec![vec![(0.0, 1.0), (0.3, 0.0), (0.6, 1.0)], vec![(0.12, 0.6), (0.48, 0.6)]],
        'E' => vec![vec![(0.6, 0.0), (0.0, 0.0), (0.0, 1.0), (0.6, 1.0)], vec![(0.0, 0.5), (0.45, 0.5)]],
        'F' => vec![vec![(0.6, 0.0), (0.0, 0.0), (0.0, 1.0)], vec![(0.0, 0.5), (0.45, 0.5)]],
        'H' => vec![vec![(0.0, 0.0), (0.0, 1.0)], vec![(0.6, 0.0), (0.6, 1.0)], vec![(0.0, 0.5), (0.6, 0.5)]],
        'I' => vec![vec![(0.3, 0.0), (0.3, 1.0)]],
        'K' => vec![vec![(0.0, 0.0), (0.0, 1.0)], vec![(0.6, 0.0), (0.0, 0.6)], vec![(0.2, 0.45), (0.6, 1.0)]],
        'L' => vec![vec![(0.0, 0.0), (0.0, 1.0), (0.6, 1.0)]],
        'M' => vec![vec![(0.0, 1.0), (0.0, 0.0), (0.3, 0.6), (0.6, 0.0), (0.6, 1.0)]],
        'N' => vec![vec![(0.0, 1.0), (0.0, 0.0), (0.6, 1.0), (0.6, 0.0)]],
        'T' => vec![vec![(0.0, 0.0), (0.6, 0.0)], vec![(0.3, 0.0), (0.3, 1.0)]],
        'V' => vec![vec![(0.0, 0.0), (0.3, 1.0), (0.6, 0.0)]],
        'W' => vec![vec![(0.0, 0.0), (0.15, 1.0), (0.3, 0.4), (0.45, 1.0), (0.6, 0.0)]],
        'X' => vec![vec![(0.0, 0.0), (0.6, 1.0)], vec![(0.6, 0.0), (0.0, 1.0)]],
        'Y' => vec![vec![(0.0, 0.0), (0.3, 0.5), (0.6, 0.0)], vec![(0.3, 0.5), (0.3, 1.0)]],
        'Z' => vec![vec![(0.0, 0.0), (0.6, 0.0), (0.0, 1.0), (0.6, 1.0)]],
        'P' | 'R' | 'B' | 'D' | 'O' | 'C' | 'S' | 'U' | 'J' | 'G' => vec![],
        _ => return None,
    };
    Some(g)
}

/// The strokes of one glyph scaled to `height` pixels with its top-left corner at `origin`, or `None` when the
/// stroke font has no such letter.
pub fn glyph(ch: char, origin: (f64, f64), height: f64) -> Option<Vec<Stroke>> {
    let map = |p: (f64, f64)| (origin.0 + p.0 * height, origin.1 + p.1 * height);
    let mut strokes: Vec<Stroke> = glyph_lines(ch)?
        .into_iter()
        .map(|pl| Stroke { points: pl.into_iter().map(&map).map(|(x, y)| Point::new(x, y)).collect() })
        .collect();
    let arc = |c: (f64, f64), r: (f64, f64), a0: f64, sweep: f64| {
        let c = map(c);
        Stroke::arc(c, (r.0 * height, r.1 * height), a0, sweep)
    };
    let line = |a: (f64, f64), b: (f64, f64)| Stroke::line(map(a), map(b));
    match ch.to_ascii_uppercase() {
        'O' => strokes.push(arc((0.3, 0.5), (0.3, 0.5), 0.0, 2.0 * PI)),
        'C' => strokes.push(arc((0.32, 0.5), (0.3, 0.5), -0.25 * PI, -1.5 * PI)),
        'G' => {
            strokes.push(arc((0.32, 0.5), (0.3, 0.5), -0.25 * PI, -1.75 * PI));
            strokes.push(line((0.62, 0.5), (0.35, 0.5)));
        }
        'U' => {
            strokes.push(line((0.0, 0.0), (0.0, 0.7)));
            strokes.push(arc((0.3, 0.7), (0.3, 0.3), PI, -PI));
            strokes.push(line((0.6, 0.7), (0.6, 0.0)));
        }
        'J' => {
            strokes.push(line((0.6, 0.0), (0.6, 0.7)));
            strokes.push(arc((0.3, 0.7), (0.3, 0.3), 0.0, PI));
        }
        'D' => {
            strokes.push(line((0.0, 0.0), (0.0, 1.0)));
            strokes.push(arc((0.1, 0.5), (0.5, 0.5), -0.5 * PI, PI));
        }
        'P' | 'R' | 'B' => {
            strokes.push(Stroke { points: vec![Point::from(map((0.0, 1.0))), Point::from(map((0.0, 0.0)))] });
            strokes.push(line((0.0, 0.0), (0.35, 0.0)));
            strokes.push(arc((0.35, 0.25), (0.25, 0.25), -0.5 * PI, PI));
            strokes.push(line((0.35, 0.5), (0.0, 0.5)));
            if ch.eq_ignore_ascii_case(&'R') {
                strokes.push(line((0.3, 0.5), (0.6, 1.0)));
            }
            if ch.eq_ignore_ascii_case(&'B') {
                strokes.push(arc((0.35, 0.75), (0.25, 0.25), -0.5 * PI, PI));
                strokes.push(line((0.35, 1.0), (0.0, 1.0)));
            }
        }
        'S' => {
            strokes.push(arc((0.3, 0.25), (0.3, 0.25), -PI / 6.0, -4.0 * PI / 3.0 - PI / 6.0));
            strokes.push(arc((0.3, 0.75), (0.3, 0.25), -0.5 * PI, 4.0 * PI / 3.0 + PI / 6.0));
        }
        _ => {}
    }
    Some(strokes)
}

/// The strokes of a line of text (letters the stroke font lacks are skipped), `height` pixels tall.
pub fn text(s: &str, origin: (f64, f64), height: f64) -> Vec<Stroke> {
    let mut out = Vec::new();
    let mut x = origin.0;
    for ch in s.chars() {
        if let Some(g) = glyph(ch, (x, origin.1), height) {
            out.extend(g);
        }
        x += 0.9 * height;
    }
    out
}

/// The shapes the outline fidelity test runs on: discs, rings and letters of several sizes.
pub fn fidelity_shapes() -> Vec<(String, Bitmap)> {
    let mut v = vec![
        ("disc r=6".to_owned(), disc(20, 20, (10.0, 10.0), 6.0)),
        ("disc r=40.3".to_owned(), disc(100, 100, (50.2, 49.7), 40.3)),
        ("ring 10-16".to_owned(), ring(40, 40, (20.0, 20.0), 10.0, 16.0)),
        ("ring 60-80".to_owned(), ring(180, 180, (90.3, 89.6), 60.0, 80.0)),
        ("thin ring 30-34".to_owned(), ring(80, 80, (40.0, 40.0), 30.0, 34.0)),
    ];
    for (word, h, w) in [("PLOTTER", 40.0, 5.0), ("ABDEGJKS", 60.0, 7.0), ("MNUVWXYZ", 32.0, 4.0)] {
        let strokes = text(word, (8.0, 8.0), h);
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)] // small positive sizes
        let (iw, ih) = ((word.len() as f64 * 0.9 * h + 16.0) as usize, (h + 16.0) as usize);
        v.push((format!("letters {word} {h}px/{w}px"), stroke_bitmap(iw, ih, &strokes, w)));
    }
    v
}

/// Intersection over union between `bitmap` and the even-odd fill of the closed `paths` (pixel coordinates),
/// rasterised independently with tiny-skia (no anti-aliasing: a pixel is inside when its centre is).
pub fn iou_even_odd(bitmap: &Bitmap, paths: &[Vec<Point>]) -> f64 {
    let filled = fill_even_odd(bitmap.width(), bitmap.height(), paths);
    let (mut inter, mut union) = (0usize, 0usize);
    for (a, b) in bitmap.as_bytes().iter().zip(filled.as_bytes()) {
        let (a, b) = (*a != 0, *b != 0);
        inter += usize::from(a && b);
        union += usize::from(a || b);
    }
    #[allow(clippy::cast_precision_loss)] // pixel counts < 2^52
    let iou = if union == 0 { 1.0 } else { inter as f64 / union as f64 };
    iou
}

/// Even-odd fill of closed paths into a bitmap with tiny-skia.
pub fn fill_even_odd(width: usize, height: usize, paths: &[Vec<Point>]) -> Bitmap {
    let (w, h) = (u32::try_from(width).unwrap_or(1).max(1), u32::try_from(height).unwrap_or(1).max(1));
    let Some(mut pixmap) = tiny_skia::Pixmap::new(w, h) else {
        return Bitmap::new(width, height);
    };
    let mut pb = tiny_skia::PathBuilder::new();
    for p in paths {
        let Some((first, rest)) = p.split_first() else { continue };
        #[allow(clippy::cast_possible_truncation)] // pixel coordinates fit f32
        pb.move_to(first.x as f32, first.y as f32);
        for q in rest {
            #[allow(clippy::cast_possible_truncation)] // pixel coordinates fit f32
            pb.line_to(q.x as f32, q.y as f32);
        }
        pb.close();
    }
    if let Some(path) = pb.finish() {
        let mut paint = tiny_skia::Paint::default();
        paint.set_color_rgba8(0, 0, 0, 255);
        paint.anti_alias = false;
        pixmap.fill_path(&path, &paint, tiny_skia::FillRule::EvenOdd, tiny_skia::Transform::identity(), None);
    }
    let data = pixmap.data();
    Bitmap::from_fn(width, height, |x, y| data[(y * width + x) * 4 + 3] > 127)
}

/// The strokes of the line-art sample (640 × 400 px): a word, a circle, a spiral, a wave and a star.
pub fn line_art_strokes() -> Vec<Stroke> {
    let mut s = text("PLOTTER", (30.0, 30.0), 90.0);
    s.push(Stroke::arc((110.0, 270.0), (70.0, 70.0), 0.0, 2.0 * PI));
    // Archimedean spiral r = 6 + 7θ/π around (300, 275).
    let spiral: Vec<Point> = (0..=600)
        .map(|i| {
            let t = f64::from(i) / 600.0 * 6.0 * PI;
            let r = 6.0 + 7.0 * t / PI;
            Point::new(300.0 + r * t.cos(), 275.0 + r * t.sin())
        })
        .collect();
    s.push(Stroke { points: spiral });
    let wave: Vec<Point> = (0..=400)
        .map(|i| f64::from(i) / 400.0)
        .map(|t| Point::new(420.0 + 190.0 * t, 200.0 + 18.0 * (t * 4.0 * PI).sin()))
        .collect();
    s.push(Stroke { points: wave });
    // A five-pointed star drawn as one closed stroke (self-crossing: five junctions).
    let star: Vec<Point> = (0..=5)
        .map(|i| {
            let a = -PI / 2.0 + f64::from(i) * 4.0 * PI / 5.0;
            Point::new(515.0 + 75.0 * a.cos(), 310.0 + 75.0 * a.sin())
        })
        .collect();
    s.push(Stroke { points: star });
    s
}

/// The line-art sample: [`line_art_strokes`] 5 px wide, anti-aliased black on white, 640 × 400.
pub fn line_art_sample() -> GrayImage {
    stroke_gray(640, 400, &line_art_strokes(), 5.0)
}

/// Smooth value noise in [−1, 1] from an integer hash (deterministic, no RNG state).
fn value_noise(x: f64, y: f64) -> f64 {
    fn hash(ix: i64, iy: i64) -> f64 {
        let mut h = (ix.wrapping_mul(374_761_393) ^ iy.wrapping_mul(668_265_263)).cast_unsigned();
        h = (h ^ (h >> 13)).wrapping_mul(1_274_126_177);
        h ^= h >> 16;
        #[allow(clippy::cast_precision_loss)] // 16-bit value
        let v = (h & 0xffff) as f64 / 65535.0;
        v * 2.0 - 1.0
    }
    let (fx, fy) = (x.floor(), y.floor());
    #[allow(clippy::cast_possible_truncation)] // sample coordinates are small
    let (ix, iy) = (fx as i64, fy as i64);
    let (tx, ty) = (x - fx, y - fy);
    let (sx, sy) = (tx * tx * (3.0 - 2.0 * tx), ty * ty * (3.0 - 2.0 * ty));
    let top = hash(ix, iy) * (1.0 - sx) + hash(ix + 1, iy) * sx;
    let bottom = hash(ix, iy + 1) * (1.0 - sx) + hash(ix + 1, iy + 1) * sx;
    top * (1.0 - sy) + bottom * sy
}

/// The photo-like sample (480 × 360): a lit sphere with a soft cast shadow and a shaded box on a graded floor and
/// wall, with a little texture noise — smooth tones for hatching and clear edges for Canny.
pub fn photo_sample() -> GrayImage {
    photo_scene(480, 360)
}

/// The photo-like scene at any size (the geometry scales with the width).
pub fn photo_scene(width: usize, height: usize) -> GrayImage {
    #[allow(clippy::cast_precision_loss)] // image sizes < 2^31
    let (wf, hf) = (width as f64, height as f64);
    let k = wf / 480.0;
    let horizon = 0.55 * hf;
    let (sc, sr) = (Point::new(170.0 * k, 210.0 * k), 85.0 * k);
    let light = (-0.55f64, -0.65f64, 0.52f64);
    let ln = (light.0 * light.0 + light.1 * light.1 + light.2 * light.2).sqrt();
    gray_from_fn(width, height, |x, y| {
        let p = centre(x, y);
        // Wall above the horizon (lighter, graded), floor below (darker towards the viewer).
        let mut v =
            if p.y < horizon { 225.0 - 40.0 * p.y / horizon } else { 175.0 - 60.0 * (p.y - horizon) / (hf - horizon) };
        // Soft elliptic shadow of the sphere on the floor.
        let (dx, dy) = ((p.x - (sc.x + 55.0 * k)) / (1.15 * sr), (p.y - (sc.y + 0.9 * sr)) / (0.28 * sr));
        let sd = (dx * dx + dy * dy).sqrt();
        v *= 1.0 - 0.45 * (1.0 - ((sd - 0.8) / 0.4).clamp(0.0, 1.0));
        // The box: front face and lit top face.
        let (bx0, bx1, by0, by1, top) = (320.0 * k, 430.0 * k, 170.0 * k, 300.0 * k, 30.0 * k);
        if (bx0..bx1).contains(&p.x) && (by0..by1).contains(&p.y) {
            v = 95.0 + 25.0 * (p.x - bx0) / (bx1 - bx0);
        } else if p.y >= by0 - top && p.y < by0 && p.x >= bx0 + (by0 - p.y) && p.x < bx1 + (by0 - p.y) {
            v = 242.0;
        }
        // The sphere, Lambert-shaded, anti-aliased edge.
        let d = p.distance(sc);
        if d < sr + 1.0 {
            let (nx, ny) = ((p.x - sc.x) / sr, (p.y - sc.y) / sr);
            let nz = (1.0 - nx * nx - ny * ny).max(0.0).sqrt();
            let lambert = ((nx * light.0 + ny * light.1 + nz * light.2) / ln).max(0.0);
            let shade = 30.0 + 210.0 * lambert;
            let cover = (sr - d + 0.5).clamp(0.0, 1.0);
            v = v * (1.0 - cover) + shade * cover;
        }
        v + 6.0 * value_noise(p.x / (9.0 * k), p.y / (9.0 * k)) + 3.0 * value_noise(p.x / (3.0 * k), p.y / (3.0 * k))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn disc_area_is_close_to_pi_r2() {
        let b = disc(100, 100, (50.0, 50.0), 30.0);
        #[allow(clippy::cast_precision_loss)] // small counts
        let area = b.count() as f64;
        assert!((area - PI * 900.0).abs() < 20.0, "{area}");
    }

    #[test]
    fn stroke_font_covers_the_words_used() {
        for ch in "PLOTTERABDEGJKSMNUVWXYZCFHI".chars() {
            assert!(glyph(ch, (0.0, 0.0), 10.0).is_some_and(|g| !g.is_empty()), "{ch}");
        }
        assert!(glyph('?', (0.0, 0.0), 10.0).is_none());
    }

    #[test]
    fn arc_is_accurate_and_long_enough() {
        let a = Stroke::arc((0.0, 0.0), (50.0, 50.0), 0.0, PI);
        assert!((a.length() - 50.0 * PI).abs() < 0.05, "{}", a.length());
        assert!(a.points.iter().all(|p| (p.to_vec2().hypot() - 50.0).abs() < 1e-9));
        assert!((a.distance(Point::new(0.0, 60.0)) - 10.0).abs() < 0.02);
    }

    #[test]
    fn iou_of_a_square() {
        let b = Bitmap::from_fn(10, 10, |x, y| (2..6).contains(&x) && (2..6).contains(&y));
        let sq = vec![
            Point::new(2.0, 2.0),
            Point::new(6.0, 2.0),
            Point::new(6.0, 6.0),
            Point::new(2.0, 6.0),
            Point::new(2.0, 2.0),
        ];
        assert_eq!(iou_even_odd(&b, std::slice::from_ref(&sq)), 1.0);
        let half: Vec<Point> = sq.iter().map(|p| Point::new(p.x.min(4.0), p.y)).collect();
        assert!((iou_even_odd(&b, &[half]) - 0.5).abs() < 1e-12);
        // Even-odd: the same square twice cancels out.
        assert_eq!(iou_even_odd(&b, &[sq.clone(), sq]), 0.0);
    }

    #[test]
    fn samples_have_ink_and_tones() {
        let l = line_art_sample();
        assert_eq!(l.dimensions(), (640, 400));
        let dark = l.pixels().filter(|p| p.0[0] < 128).count();
        assert!((10_000..60_000).contains(&dark), "{dark}");
        let p = photo_sample();
        let mut hist = [0usize; 8];
        for px in p.pixels() {
            hist[usize::from(px.0[0] / 32)] += 1;
        }
        // At least five of the eight tone bands are well populated.
        assert!(hist.iter().filter(|&&n| n > 2000).count() >= 5, "{hist:?}");
    }
}
