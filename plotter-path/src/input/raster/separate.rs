//! Colour separation: a colour picture split into one darkness map per ink, each then shaded by a tone style and
//! plotted with its own pen.
//!
//! Everything happens in linear light with a subtractive model: a pixel's darkness in each channel is
//! `1 − linear(R, G, B)` (after the tone curve, per channel), and an ink of colour `P` covering a fraction `a` of
//! the paper darkens channel `c` by `a · (1 − P_c)`, what it absorbs there.
//!
//! - [`Colors::Cmyk`]: cyan, magenta and yellow absorb red, green and blue; black takes the part all three share
//!   (gray component replacement): `k = min(c', m', y')`, then each colour ink covers what is left, `(c' − k) / (1 − k)`,
//!   so that its lines and the black lines crossing at random give `1 − (1 − c)(1 − k) = c'`. A gray is black ink
//!   only.
//! - [`Colors::Pens`]: the pixel's darkness is unmixed into the given pens' absorptions: the coverages `a_i` in
//!   `[0, 1]` that make `Σ a_i (1 − P_i)` closest to it (least squares, by coordinate descent, with a slight
//!   preference for less ink where pens can stand in for each other). With a red and a blue pen a red patch is the
//!   red pen's only.
//!
//! Each ink also gets its own line angle ([`Separation::angle_deg`]) so the families of different pens do not beat
//! against each other (moiré), as printers turn their screens.

use super::tone::{DarknessMap, ToneCurve, srgb_to_linear};
use crate::Rgb;
use image::RgbImage;
use std::collections::HashMap;

/// One ink of a separation: its layer name and colour.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Ink {
    /// The layer's name (a pen table name matches its pen by name).
    pub name: String,
    /// The ink's colour.
    pub color: Rgb,
}

/// How a picture's colours become pens.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub enum Colors {
    /// One black pen shading the picture's gray.
    #[default]
    Gray,
    /// Cyan, magenta, yellow and black, black taking the gray they share.
    Cmyk,
    /// The given pens, each pixel unmixed into their colours.
    Pens(Vec<Ink>),
}

/// One ink's share of the picture.
#[derive(Debug, Clone, PartialEq)]
pub struct Separation {
    /// The ink.
    pub ink: Ink,
    /// The coverage it should lay down at every pixel.
    pub map: DarknessMap,
    /// Turn of its lines from the base angle, degrees.
    pub angle_deg: f64,
}

/// The four process inks, black first.
pub fn cmyk_inks() -> Vec<Ink> {
    [("black", Rgb(0, 0, 0)), ("cyan", Rgb(0, 255, 255)), ("magenta", Rgb(255, 0, 255)), ("yellow", Rgb(255, 255, 0))]
        .into_iter()
        .map(|(name, color)| Ink { name: name.to_owned(), color })
        .collect()
}

/// Turns given to the inks in order, degrees: 30° between the strongest, the fourth (yellow in CMYK, the lightest)
/// 15° from black.
const ANGLES: [f64; 8] = [0.0, -30.0, 30.0, 15.0, -15.0, 60.0, -60.0, 45.0];

/// Split `rgb` into one darkness map per ink (`Gray` gives none: the caller shades the gray picture). The tone
/// curve and `invert` apply to each channel.
pub fn separate(rgb: &RgbImage, tone: &ToneCurve, invert: bool, colors: &Colors) -> Vec<Separation> {
    let inks = match colors {
        Colors::Gray => return Vec::new(),
        Colors::Cmyk => cmyk_inks(),
        Colors::Pens(p) => p.clone(),
    };
    let mut table = [0.0f64; 256];
    for (v, d) in (0u8..=255).zip(table.iter_mut()) {
        *d = 1.0 - srgb_to_linear(tone.lightness(v, invert));
    }
    let absorb: Vec<[f64; 3]> = inks.iter().map(absorption).collect();
    let (w, h) = (rgb.width() as usize, rgb.height() as usize);
    let mut maps = vec![vec![0.0f32; w * h]; inks.len()];
    let mut cache: HashMap<[u8; 3], Vec<f64>> = HashMap::new();
    for (i, px) in rgb.pixels().enumerate() {
        let cover = cache.entry(px.0).or_insert_with(|| {
            let d = px.0.map(|v| table[usize::from(v)]);
            match colors {
                Colors::Cmyk => cmyk(d).to_vec(),
                _ => unmix(d, &absorb),
            }
        });
        for (m, &a) in maps.iter_mut().zip(cover.iter()) {
            #[allow(clippy::cast_possible_truncation)] // a coverage in [0, 1]
            let a = a as f32;
            m[i] = a;
        }
    }
    inks.into_iter()
        .zip(maps)
        .enumerate()
        .map(|(k, (ink, data))| Separation {
            ink,
            map: DarknessMap { width: w, height: h, data },
            angle_deg: ANGLES[k % ANGLES.len()],
        })
        .collect()
}

/// The picture in colour at the working size of `prepared` (its gray twin): alpha composited over white, resized
/// with the same filter, blurred alike.
pub fn working_rgb(image: &image::DynamicImage, prepared: &super::Prepared, blur_px: f32) -> RgbImage {
    let rgba = image.to_rgba8();
    let mut rgb = RgbImage::from_fn(rgba.width(), rgba.height(), |x, y| {
        let [r, g, b, a] = rgba.get_pixel(x, y).0;
        let over = |v: u8| {
            let v = (u32::from(v) * u32::from(a) + 255 * (255 - u32::from(a)) + 127) / 255;
            u8::try_from(v).unwrap_or(255)
        };
        image::Rgb([over(r), over(g), over(b)])
    });
    let (tw, th) = prepared.gray.dimensions();
    if (tw, th) != rgb.dimensions() {
        rgb = image::imageops::resize(&rgb, tw, th, image::imageops::FilterType::Triangle);
    }
    if blur_px > 0.0 {
        rgb = imageproc::filter::gaussian_blur_f32(&rgb, blur_px);
    }
    rgb
}

/// What an ink absorbs in each channel, linear light: `1 − linear(P)`.
fn absorption(ink: &Ink) -> [f64; 3] {
    let Rgb(r, g, b) = ink.color;
    [r, g, b].map(|v| 1.0 - srgb_to_linear(f64::from(v) / 255.0))
}

/// Black, cyan, magenta, yellow coverages of a pixel whose channel darknesses are `d` (red, green, blue).
pub fn cmyk(d: [f64; 3]) -> [f64; 4] {
    let k = d[0].min(d[1]).min(d[2]).clamp(0.0, 1.0);
    if k >= 1.0 {
        return [1.0, 0.0, 0.0, 0.0];
    }
    let rest = |x: f64| ((x - k) / (1.0 - k)).clamp(0.0, 1.0);
    [k, rest(d[0]), rest(d[1]), rest(d[2])]
}

/// Coverages in `[0, 1]` of inks absorbing `absorb` that best give the channel darknesses `d`: least squares with
/// a small penalty on ink, solved by cyclic coordinate descent (convex, so it settles on the minimum).
pub fn unmix(d: [f64; 3], absorb: &[[f64; 3]]) -> Vec<f64> {
    const PENALTY: f64 = 1e-4;
    let n = absorb.len();
    let mut a = vec![0.0; n];
    if d.iter().all(|&x| x <= 0.0) {
        return a;
    }
    // The residual d − Σ a_i A_i, kept up to date.
    let mut r = d;
    for _ in 0..200 {
        let mut moved = 0.0f64;
        for i in 0..n {
            let ai = absorb[i];
            let norm = ai[0] * ai[0] + ai[1] * ai[1] + ai[2] * ai[2];
            if norm <= 0.0 {
                continue;
            }
            let dot = (0..3).map(|c| ai[c] * (r[c] + a[i] * ai[c])).sum::<f64>();
            let new = ((dot - PENALTY) / norm).clamp(0.0, 1.0);
            let step = new - a[i];
            if step != 0.0 {
                for c in 0..3 {
                    r[c] -= step * ai[c];
                }
                a[i] = new;
                moved = moved.max(step.abs());
            }
        }
        if moved < 1e-7 {
            break;
        }
    }
    a
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::Rgb as Px;

    fn linear_dark(v: u8) -> f64 {
        1.0 - srgb_to_linear(f64::from(v) / 255.0)
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-6
    }

    #[test]
    fn cmyk_takes_the_shared_gray_as_black() {
        // Mid-gray 128 in every channel: 0.784 darkness each, all black.
        let g = linear_dark(128);
        let [k, c, m, y] = cmyk([g, g, g]);
        assert!(close(k, g) && c == 0.0 && m == 0.0 && y == 0.0);
        // Orange (255, 128, 0): red absorbs nothing, so no black; magenta 0.784, yellow 1.
        let [k, c, m, y] = cmyk([0.0, g, 1.0]);
        assert!(k == 0.0 && c == 0.0 && close(m, g) && close(y, 1.0));
        // Dark teal (0, 128, 128): black 0.784, cyan covers the rest of the red, (1 − 0.784) / (1 − 0.784) = 1.
        let [k, c, m, y] = cmyk([1.0, g, g]);
        assert!(close(k, g) && close(c, 1.0) && m == 0.0 && y == 0.0);
        // Black and white.
        assert_eq!(cmyk([1.0; 3]), [1.0, 0.0, 0.0, 0.0]);
        assert_eq!(cmyk([0.0; 3]), [0.0; 4]);
    }

    #[test]
    fn pens_unmix_a_colour_into_the_pens_that_make_it() {
        let red = absorption(&Ink { name: "red".into(), color: Rgb(255, 0, 0) });
        let blue = absorption(&Ink { name: "blue".into(), color: Rgb(0, 0, 255) });
        assert_eq!((red, blue), ([0.0, 1.0, 1.0], [1.0, 1.0, 0.0]));
        // A red patch: green and blue absorbed, red not: the red pen alone, fully.
        let a = unmix([0.0, 1.0, 1.0], &[red, blue]);
        assert!((a[0] - 1.0).abs() < 1e-3 && a[1] == 0.0, "{a:?}");
        // Light red (255, 180, 180): green and blue darkness 1 − linear(180/255) = 0.5437, the red pen at that.
        let d = linear_dark(180);
        let a = unmix([0.0, d, d], &[red, blue]);
        assert!((a[0] - d).abs() < 1e-3 && a[1] == 0.0, "{a:?}");
        // Magenta (255, 0, 255) lies between: least squares of a(0,1,1) + b(1,1,0) ≈ (0,1,0) gives a = b = 1/3.
        let a = unmix([0.0, 1.0, 0.0], &[red, blue]);
        assert!((a[0] - 1.0 / 3.0).abs() < 1e-3 && (a[1] - 1.0 / 3.0).abs() < 1e-3, "{a:?}");
        // White: nothing.
        assert_eq!(unmix([0.0; 3], &[red, blue]), vec![0.0, 0.0]);
    }

    #[test]
    fn separate_makes_one_map_per_ink_with_its_own_angle() {
        // Left half pure cyan (0, 255, 255), right half white.
        let img = RgbImage::from_fn(10, 4, |x, _| if x < 5 { Px([0, 255, 255]) } else { Px([255, 255, 255]) });
        let seps = separate(&img, &ToneCurve::default(), false, &Colors::Cmyk);
        let names: Vec<&str> = seps.iter().map(|s| s.ink.name.as_str()).collect();
        assert_eq!(names, ["black", "cyan", "magenta", "yellow"]);
        assert_eq!(seps[1].map.at(0, 0), 1.0);
        assert_eq!(seps[1].map.at(7, 0), 0.0);
        for s in [&seps[0], &seps[2], &seps[3]] {
            assert!(s.map.data.iter().all(|&v| v == 0.0), "{}", s.ink.name);
        }
        let angles: Vec<f64> = seps.iter().map(|s| s.angle_deg).collect();
        assert_eq!(angles, [0.0, -30.0, 30.0, 15.0]);
        assert!(separate(&img, &ToneCurve::default(), false, &Colors::Gray).is_empty());
    }

    /// A 30 × 30 mm picture of one colour (100 px at 0.3 mm) traced with the tone hatch and `colors`: each layer's
    /// name and ink fraction 3 mm away from the edges, or the error.
    fn plotted(color: [u8; 3], colors: Colors) -> Result<Vec<(String, Rgb, f64)>, crate::input::raster::RasterError> {
        use crate::input::raster::ink::InkGrid;
        use crate::input::raster::{Mode, TraceOptions, trace};
        let img = image::DynamicImage::ImageRgb8(RgbImage::from_pixel(100, 100, Px(color)));
        let opts = TraceOptions { mode: Mode::Hatch, pitch_mm: Some(0.3), colors, ..TraceOptions::default() };
        let t = trace(&img, &opts)?;
        Ok(t.drawing
            .layers
            .iter()
            .map(|l| {
                let strokes: Vec<Vec<kurbo::Point>> = l.paths.iter().map(|p| p.points.clone()).collect();
                let mut g = InkGrid::new(1500, 1500, 0.02);
                g.draw(&strokes, l.pen.width_mm);
                (l.name.clone(), l.pen.color, g.fraction(150, 1350, 150, 1350))
            })
            .collect())
    }

    #[test]
    fn a_cyan_picture_plots_with_the_cyan_pen_only() {
        let layers = plotted([0, 255, 255], Colors::Cmyk).unwrap();
        assert_eq!(layers.len(), 1, "{layers:?}");
        let (name, color, ink) = &layers[0];
        assert_eq!((name.as_str(), *color), ("cyan", Rgb(0, 255, 255)));
        // Full cyan is past three crossed families: filled solid.
        assert!(*ink > 0.95, "cyan ink {ink}");
    }

    #[test]
    fn white_plots_nothing_and_gray_is_black_ink() {
        let e = plotted([255, 255, 255], Colors::Cmyk).unwrap_err();
        assert!(e.to_string().contains("nothing to draw"), "{e}");
        // Gray 128: black alone, 1 − linear(128/255) = 0.784 of the paper.
        let layers = plotted([128, 128, 128], Colors::Cmyk).unwrap();
        assert_eq!(layers.len(), 1, "{layers:?}");
        assert_eq!(layers[0].0, "black");
        assert!((layers[0].2 - 0.784).abs() <= 0.05, "black ink {}", layers[0].2);
    }

    #[test]
    fn each_separation_inks_its_hand_computed_darkness() {
        // Orange (255, 128, 0): no black, magenta 1 − linear(128/255) = 0.784, yellow 1 (solid), no cyan.
        let layers = plotted([255, 128, 0], Colors::Cmyk).unwrap();
        let names: Vec<&str> = layers.iter().map(|l| l.0.as_str()).collect();
        assert_eq!(names, ["magenta", "yellow"]);
        assert!((layers[0].2 - 0.784).abs() <= 0.05, "magenta ink {}", layers[0].2);
        assert!(layers[1].2 >= 0.95, "yellow ink {}", layers[1].2);
        // Dark teal (0, 128, 128): black 0.784 and cyan filling the rest of the red, (1 − 0.784) / (1 − 0.784) = 1.
        let layers = plotted([0, 128, 128], Colors::Cmyk).unwrap();
        let names: Vec<&str> = layers.iter().map(|l| l.0.as_str()).collect();
        assert_eq!(names, ["black", "cyan"]);
        assert!((layers[0].2 - 0.784).abs() <= 0.05, "black ink {}", layers[0].2);
        assert!(layers[1].2 >= 0.95, "cyan ink {}", layers[1].2);
    }

    #[test]
    fn with_red_and_blue_pens_a_red_patch_goes_to_the_red_pen() {
        let pens =
            vec![Ink { name: "red".into(), color: Rgb(255, 0, 0) }, Ink { name: "blue".into(), color: Rgb(0, 0, 255) }];
        // Light red (255, 180, 180): the red pen at 1 − linear(180/255) = 0.544.
        let layers = plotted([255, 180, 180], Colors::Pens(pens.clone())).unwrap();
        assert_eq!(layers.len(), 1, "{layers:?}");
        assert_eq!((layers[0].0.as_str(), layers[0].1), ("red", Rgb(255, 0, 0)));
        let want = 1.0 - srgb_to_linear(180.0 / 255.0);
        assert!((layers[0].2 - want).abs() <= 0.05, "red ink {} vs {want}", layers[0].2);
        let layers = plotted([0, 0, 255], Colors::Pens(pens)).unwrap();
        assert_eq!(layers.iter().map(|l| l.0.as_str()).collect::<Vec<_>>(), ["blue"]);
    }

    #[test]
    fn colours_need_a_tone_style_and_pens_with_colours() {
        use crate::input::raster::{Mode, TraceOptions};
        let opts = TraceOptions { mode: Mode::Outline, colors: Colors::Cmyk, ..TraceOptions::default() };
        let e = opts.validate().unwrap_err().to_string();
        assert!(e.contains("--colors") && e.contains("tone styles"), "{e}");
        let opts = TraceOptions { mode: Mode::Mosaic, colors: Colors::Pens(Vec::new()), ..TraceOptions::default() };
        let e = opts.validate().unwrap_err().to_string();
        assert!(e.contains("--colors") && e.contains("pen table"), "{e}");
    }
}
