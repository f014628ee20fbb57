//! The tone of an SVG fill, for hatching fills by their lightness (`--hatch tone`): how dark the fill looks on
//! the paper at each point, as the image styles' tone model reads a picture.
//!
//! A colour is painted at its opacity (the fill's, the enclosing groups', and a gradient stop's own) over the
//! paper, blended in sRGB as renderers do; the result is decoded to linear light per channel
//! ([`srgb_to_linear`]), its luminance taken with the sRGB (Rec. 709) weights, and its darkness is `1 − Y` relative
//! to the paper's luminance. A gradient's darkness is sampled at [`SAMPLES`] evenly spaced points of its parameter,
//! its stops interpolated in sRGB between their offsets and padded beyond the first and last, and handed to
//! [`crate::geometry::tone_hatch`] with its geometry mapped to page millimetres (usvg has already turned
//! `objectBoundingBox` units into user space and `gradientTransform`).

use kurbo::{Affine, Point};

use super::{affine, rgb};
use crate::geometry::drawing::Rgb;
use crate::geometry::region::Region;
use crate::geometry::tone_hatch::{GradientField, GradientShape, Spread, ToneField};
use crate::input::raster::tone::{Ladder, srgb_to_linear};
use crate::input::svg::MM_PER_PX;

/// Samples of a gradient's darkness along its parameter.
pub(super) const SAMPLES: usize = 257;

/// Linear luminance of an sRGB colour given as 0–1 channels.
fn luminance(c: [f64; 3]) -> f64 {
    0.2126 * srgb_to_linear(c[0]) + 0.7152 * srgb_to_linear(c[1]) + 0.0722 * srgb_to_linear(c[2])
}

fn channels(c: Rgb) -> [f64; 3] {
    [c.0, c.1, c.2].map(|v| f64::from(v) / 255.0)
}

/// Darkness (0 = the paper, 1 = black) of colour `c` (0–1 channels) painted at opacity `alpha` over `paper`.
fn darkness_of(c: [f64; 3], alpha: f64, paper: Rgb) -> f64 {
    let a = alpha.clamp(0.0, 1.0);
    let p = channels(paper);
    let seen = [0, 1, 2].map(|i| c[i] * a + p[i] * (1.0 - a));
    let paper_y = luminance(p).max(1e-6);
    (1.0 - luminance(seen) / paper_y).clamp(0.0, 1.0)
}

/// Darkness of a plain colour at `alpha` over `paper`.
pub(super) fn darkness(c: Rgb, alpha: f32, paper: Rgb) -> f64 {
    darkness_of(channels(c), f64::from(alpha), paper)
}

/// The colour (0–1 channels) and opacity of gradient `stops` at offset `s` (0–1).
fn stop_at(stops: &[usvg::Stop], s: f32) -> ([f64; 3], f64) {
    let one = |st: &usvg::Stop| (channels(rgb(st.color())), f64::from(st.opacity().get()));
    let Some(first) = stops.first() else { return ([0.0; 3], 0.0) };
    if s <= first.offset().get() {
        return one(first);
    }
    for w in stops.windows(2) {
        let (a, b) = (w[0].offset().get(), w[1].offset().get());
        if s <= b {
            let f = if b > a { f64::from((s - a) / (b - a)) } else { 1.0 };
            let ((ca, oa), (cb, ob)) = (one(&w[0]), one(&w[1]));
            return ([0, 1, 2].map(|i| ca[i] + (cb[i] - ca[i]) * f), oa + (ob - oa) * f);
        }
    }
    one(stops.last().expect("not empty"))
}

fn samples(stops: &[usvg::Stop], alpha: f32, paper: Rgb) -> Vec<f64> {
    (0..SAMPLES)
        .map(|i| {
            #[allow(clippy::cast_precision_loss, clippy::cast_possible_truncation)]
            let s = (i as f64 / (SAMPLES - 1) as f64) as f32;
            let (c, o) = stop_at(stops, s);
            darkness_of(c, o * f64::from(alpha), paper)
        })
        .collect()
}

fn spread(s: usvg::SpreadMethod) -> Spread {
    match s {
        usvg::SpreadMethod::Pad => Spread::Pad,
        usvg::SpreadMethod::Reflect => Spread::Reflect,
        usvg::SpreadMethod::Repeat => Spread::Repeat,
    }
}

/// How dark the fill `paint` at opacity `alpha` (fill opacity × the groups') looks over `paper`, with `t` the
/// shape's transform to CSS px; `None` for a pattern (its tiles are shapes of their own).
pub(super) fn tone_field(paint: &usvg::Paint, alpha: f32, t: Affine, paper: Rgb) -> Option<ToneField> {
    let to_page = |g: &usvg::Transform| Affine::scale(MM_PER_PX) * t * affine(g);
    let p = |x: f32, y: f32| Point::new(f64::from(x), f64::from(y));
    match paint {
        usvg::Paint::Color(c) => Some(ToneField::Flat(darkness(rgb(*c), alpha, paper))),
        usvg::Paint::LinearGradient(g) => Some(ToneField::Gradient(GradientField {
            shape: GradientShape::Linear { from: p(g.x1(), g.y1()), to: p(g.x2(), g.y2()) },
            to_page: to_page(&g.transform()),
            spread: spread(g.spread_method()),
            darkness: samples(g.stops(), alpha, paper),
        })),
        usvg::Paint::RadialGradient(g) => Some(ToneField::Gradient(GradientField {
            shape: GradientShape::Radial {
                center: p(g.cx(), g.cy()),
                radius: f64::from(g.r().get()),
                focus: p(g.fx(), g.fy()),
                focal_radius: f64::from(g.fr().get()),
            },
            to_page: to_page(&g.transform()),
            spread: spread(g.spread_method()),
            darkness: samples(g.stops(), alpha, paper),
        })),
        usvg::Paint::Pattern(_) => None,
    }
}

/// The ladder's rung for a darkness, as the tone hatch asks for it: (families, spacing mm). Past the ladder's
/// darkest rung the families close in down to solid black ([`Ladder::rung_to_black`]), as the image styles'
/// do: a black fill plots black, not L* 22.
///
/// `edge` is the share of the fill the line along its edge already inks ([`edge_ink`]): the hatch lays down
/// the rest, coverage `c` with `edge + c · (1 − edge) = darkness`, so a fill's outline (or stroke) and its hatch
/// together ink the fill's darkness, and a fill lighter than its own outline gets no hatch.
pub(super) fn rung_of(ladder: Ladder, edge: f64) -> impl Fn(f64) -> (u8, f64) {
    move |d| {
        let d = if edge <= 0.0 {
            d
        } else if edge < 1.0 {
            ((d - edge) / (1.0 - edge)).max(0.0)
        } else {
            0.0
        };
        let r = ladder.rung_to_black(d);
        (r.families, r.spacing_mm)
    }
}

/// The share of `region` (mm) a pen `pen_mm` wide inks inside it when drawn along its edge: half a pen width
/// along the perimeter, over the area (at most 1).
pub(super) fn edge_ink(region: &Region, pen_mm: f64) -> f64 {
    let a = area(region);
    if a <= 0.0 { 1.0 } else { (perimeter(region) * pen_mm / 2.0 / a).min(1.0) }
}

/// The length of a region's contours, mm.
pub(super) fn perimeter(r: &Region) -> f64 {
    r.contours().map(|c| c.iter().zip(c.iter().cycle().skip(1)).map(|(a, b)| a.distance(*b)).sum::<f64>()).sum()
}

/// The area of a region, mm² (its contours' signed areas: holes run the other way round).
pub(super) fn area(r: &Region) -> f64 {
    let signed: f64 = r
        .contours()
        .map(|c| c.iter().zip(c.iter().cycle().skip(1)).map(|(a, b)| a.x * b.y - b.x * a.y).sum::<f64>() / 2.0)
        .sum();
    signed.abs()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::tone_hatch::ToneHatch;
    use crate::input::raster::ink::InkGrid;
    use crate::input::svg::{ResourcePolicy, SvgOptions, import_svg};

    /// Pen 0.3 mm, closest spacing 0.45 mm (1.5 pens, the image styles' default), lines at 0°.
    const TONE: ToneHatch = ToneHatch { pen_mm: 0.3, min_spacing_mm: 0.45, angle_deg: 0.0 };

    /// The lines `--hatch tone` plots for `body` in a 40 × 40 mm document (mm user units).
    fn plotted(body: &str) -> Vec<Vec<Point>> {
        let svg = format!(
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="40mm" height="40mm" viewBox="0 0 40 40">{body}</svg>"#
        );
        let options = SvgOptions { tone_hatch: Some(TONE), ..SvgOptions::default() };
        let d = import_svg(svg.as_bytes(), "t.svg", &ResourcePolicy::DataUrlsOnly, &options).unwrap().drawing;
        d.paths().map(|p| p.points.clone()).collect()
    }

    /// The fraction of `x0..x1 × y0..y1` (mm) the lines ink at the pen's width, on a 0.02 mm grid.
    fn ink(lines: &[Vec<Point>], x0: f64, x1: f64, y0: f64, y1: f64) -> f64 {
        let mut g = InkGrid::new(2000, 2000, 0.02);
        g.draw(lines, TONE.pen_mm);
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let cell = |v: f64| (v / 0.02).round() as usize;
        g.fraction(cell(x0), cell(x1), cell(y0), cell(y1))
    }

    #[test]
    fn a_white_fill_plots_nothing_and_a_black_one_the_darkest_rung() {
        // (A short black line keeps the drawing from being empty, which the import refuses.)
        let white = plotted(
            r#"<rect x="10" y="10" width="20" height="20" fill="white"/>
               <path d="M1 1 H2" stroke="black" stroke-width="0.3"/>"#,
        );
        assert_eq!(white.len(), 1);
        assert!(white[0].len() == 2 && (white[0][1] - white[0][0] - kurbo::Vec2::new(1.0, 0.0)).hypot() < 1e-9);
        // Black: past the ladder's darkest rung (three families 0.45 mm apart ink 1 − (1 − 0.3/0.45)³ = 0.963, L*
        // 22) one family of touching lines, 0.3 mm apart: the paper inked all over (inside, away from the outline;
        // the 0.02 mm grid leaves a hair between touching lines), with 20 · 20 / 0.3 = 1333 mm of lines plus the
        // 80 mm outline and the joins (67 × 0.3 mm), where the three families took twice that.
        let lines = plotted(r#"<rect x="10" y="10" width="20" height="20" fill="black"/>"#);
        let f = ink(&lines, 12.0, 28.0, 12.0, 28.0);
        assert!(f > 0.97, "{f}");
        let length: f64 = lines.iter().flat_map(|l| l.windows(2)).map(|w| w[0].distance(w[1])).sum();
        assert!(length > 1333.0 && length < 1333.0 + 80.0 + 21.0, "{length} mm");
        // Joined into zig-zags: the outline plus about one stroke per family.
        assert!(lines.len() <= 6, "{} strokes", lines.len());
    }

    #[test]
    fn a_mid_grey_fill_inks_its_darkness() {
        // #808080 is linear 0.2159: darkness 0.784 — more than two families can give at 0.45 mm (0.889 is two at
        // most; one family is 0.667): two families at 0.3 / (1 − √0.2159) = 0.559 mm.
        let lines = plotted(r##"<rect x="10" y="10" width="20" height="20" fill="#808080"/>"##);
        let f = ink(&lines, 12.0, 28.0, 12.0, 28.0);
        assert!((f - 0.7841).abs() < 0.03, "{f}");
        // Black at a quarter opacity over white is sRGB 0.75 → linear 0.5225: darkness 0.4775, one family.
        let lines = plotted(r#"<rect x="10" y="10" width="20" height="20" fill="black" fill-opacity="0.25"/>"#);
        let f = ink(&lines, 12.0, 28.0, 12.0, 28.0);
        assert!((f - 0.4775).abs() < 0.03, "{f}");
    }

    #[test]
    fn a_blend_of_thin_steps_inks_its_darkness() {
        // A blend: 40 rectangles x 10..30, each from y = 10 down to y = 30 − 0.5 i, grey 128 + i painted in that
        // order, so the band y = 29.5 − 0.5 i .. 30 − 0.5 i shows grey 128 + i: strips 0.5 mm tall, thinner than the
        // line spacing. Over y 14..28 the ink must be the mean darkness 1 − linear(grey) of the strips there (the
        // outline's share, 80 mm × 0.15 mm over 400 mm², is taken from the hatch: −0.03 · (1 − darkness)).
        // Hatched strip by strip, each piece of line inked a pen dot and each strip's joins ran along its edge.
        let body: String = (0..40)
            .map(|i| {
                let h = 20.0 - 0.5 * f64::from(i);
                format!(r#"<rect x="10" y="10" width="20" height="{h}" fill="rgb({g},{g},{g})"/>"#, g = 128 + i)
            })
            .collect();
        let lines = plotted(&body);
        let darkness = |y: f64| {
            // The strip at y shows grey 128 + i with i = ⌊(30 − y) / 0.5⌋ (y 10..10.5 is the top rectangle's).
            #[allow(clippy::cast_possible_truncation)]
            let i = (((30.0 - y) / 0.5).floor() as i32).min(39);
            1.0 - srgb_to_linear(f64::from(128 + i) / 255.0)
        };
        let want = (0..1400).map(|k| darkness(14.0 + 14.0 * (f64::from(k) + 0.5) / 1400.0)).sum::<f64>() / 1400.0;
        let want = want - 0.03 * (1.0 - want);
        let got = ink(&lines, 12.0, 28.0, 14.0, 28.0);
        assert!((got - want).abs() < 0.03, "ink {got}, darkness {want}");
    }

    #[test]
    fn an_even_odd_hole_stays_empty() {
        let lines =
            plotted(r#"<path fill-rule="evenodd" fill="black" d="M10 10 h20 v20 h-20 Z M15 15 h10 v10 h-10 Z"/>"#);
        // Nothing inside the hole beyond the outline's half pen width; the ring around it is dark.
        assert_eq!(ink(&lines, 15.2, 24.8, 15.2, 24.8), 0.0);
        assert!(ink(&lines, 11.0, 14.0, 16.0, 24.0) > 0.9);
    }

    #[test]
    fn a_linear_gradient_shades_along_its_length() {
        // Black at x = 10 to white at x = 30: at x the colour is sRGB (x − 10) / 20, darkness 1 − linear of it.
        let lines = plotted(
            r#"<defs><linearGradient id="g" gradientUnits="userSpaceOnUse" x1="10" y1="0" x2="30" y2="0">
                 <stop offset="0" stop-color="black"/><stop offset="1" stop-color="white"/></linearGradient></defs>
               <rect x="10" y="10" width="20" height="20" fill="url(#g)"/>"#,
        );
        for (x0, x1) in [(12.0, 16.0), (18.0, 22.0), (24.0, 28.0)] {
            // The mean darkness over the window, by the midpoint rule over 400 steps.
            let want = (0..400)
                .map(|i| {
                    let x = x0 + (x1 - x0) * (f64::from(i) + 0.5) / 400.0;
                    1.0 - srgb_to_linear((x - 10.0) / 20.0)
                })
                .sum::<f64>()
                / 400.0;
            let got = ink(&lines, x0, x1, 12.0, 28.0);
            assert!((got - want).abs() < 0.04, "x {x0}..{x1}: ink {got}, darkness {want}");
        }
    }

    #[test]
    fn darkness_is_one_minus_linear_luminance_over_the_paper() {
        let white = Rgb(255, 255, 255);
        assert_eq!(darkness(white, 1.0, white), 0.0);
        assert!((darkness(Rgb(0, 0, 0), 1.0, white) - 1.0).abs() < 1e-12);
        // Grey 128: linear 0.21586 → darkness 0.78414.
        assert!((darkness(Rgb(128, 128, 128), 1.0, white) - 0.78414).abs() < 1e-4);
        // Black at 50 % opacity over white is sRGB 0.5 → linear 0.21404 → 0.78596.
        assert!((darkness(Rgb(0, 0, 0), 0.5, white) - 0.78596).abs() < 1e-4);
        // Pure red: luminance 0.2126.
        assert!((darkness(Rgb(255, 0, 0), 1.0, white) - 0.7874).abs() < 1e-9);
    }
}
