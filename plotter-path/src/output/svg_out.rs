//! Plain-SVG export: the flattened, laid-out drawing as polylines in millimetres.
//!
//! The output is deliberately simple so that other plotter tools (vpype, Inkscape, AxiDraw software) read it
//! unchanged: `width`/`height` in `mm`, a `viewBox` in millimetres (1 user unit = 1 mm), one Inkscape layer group
//! per layer (stroke colour and width from the layer's pen, no fill), open paths as `<polyline>` and closed paths
//! as `<polygon>` (without the repeated last point, which the polygon closes again on import). A path whose own
//! colour or width (from its source) differs from its layer's pen carries them as its own `stroke` attributes, so
//! the file looks like its source.
//!
//! [`to_preview_svg`] writes the same document with the pen-up travel as a dashed overlay layer (`plotter preview
//! -o out.svg --travel`), and [`gzip`] makes an `.svgz` of either.

use std::fmt::Write as _;
use std::io::{self, Write};

use kurbo::{Line, Point};

use crate::geometry::drawing::{Drawing, Pen, Polyline, Rgb};

/// Number of decimals written for coordinates (0.1 µm: far below any plotter's resolution).
pub const DECIMALS: usize = 4;

/// Write `value` with at most [`DECIMALS`] decimals and no trailing zeros.
pub(crate) fn push_number(out: &mut String, value: f64) {
    if let Some(units) = ten_thousandths(value) {
        push_units(out, units);
        return;
    }
    push_number_formatted(out, value);
}

/// `value` in ten-thousandths, rounded to the nearest as `{:.4}` rounds it, when that is certain without the exact
/// decimal expansion: below 10⁶ in size (the product's rounding error is under 2·10⁻⁶ of a unit) and not within
/// 10⁻⁴ of a unit of half-way. `None` otherwise (and for NaN and infinities): the caller formats it.
fn ten_thousandths(value: f64) -> Option<i64> {
    const _: () = assert!(DECIMALS == 4, "the fast path writes four decimals");
    if value.is_nan() || value.abs() >= 1e6 {
        return None;
    }
    let scaled = value * 1e4;
    let frac = scaled - scaled.floor();
    if (frac - 0.5).abs() < 1e-4 {
        return None;
    }
    // |scaled| < 10¹⁰: the cast is exact.
    #[allow(clippy::cast_possible_truncation)]
    Some(scaled.round() as i64)
}

/// Write `units` ten-thousandths as a decimal number without trailing zeros (`0` for zero).
fn push_units(out: &mut String, units: i64) {
    if units < 0 {
        out.push('-');
    }
    let magnitude = units.unsigned_abs();
    let _ = write!(out, "{}", magnitude / 10_000);
    let mut frac = magnitude % 10_000;
    if frac > 0 {
        let mut digits = 4;
        while frac.is_multiple_of(10) {
            frac /= 10;
            digits -= 1;
        }
        let _ = write!(out, ".{frac:0digits$}");
    }
}

/// [`push_number`] through the standard library's exact formatting.
fn push_number_formatted(out: &mut String, value: f64) {
    let start = out.len();
    // Writing into a String cannot fail.
    let _ = write!(out, "{value:.DECIMALS$}");
    if out[start..].contains('.') {
        let trimmed = out.trim_end_matches('0').trim_end_matches('.').len();
        out.truncate(trimmed);
    }
    if &out[start..] == "-0" {
        out.truncate(start);
        out.push('0');
    }
}

fn push_points(out: &mut String, points: &[Point]) {
    for (i, p) in points.iter().enumerate() {
        if i > 0 {
            out.push(' ');
        }
        push_number(out, p.x);
        out.push(',');
        push_number(out, p.y);
    }
}

fn escape(text: &str) -> String {
    text.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

/// The page size written: the drawing's page if known, else the bounding box's far corner (origin kept at 0,0).
fn page_size(drawing: &Drawing) -> (f64, f64) {
    if let Some(page) = drawing.page_mm {
        return page;
    }
    match drawing.bbox() {
        Some(b) => (b.x1.max(1.0), b.y1.max(1.0)),
        None => (1.0, 1.0),
    }
}

fn push_path(out: &mut String, path: &Polyline, layer_pen: &Pen) {
    if path.points.len() < 2 {
        return;
    }
    if path.is_closed() {
        out.push_str("    <polygon points=\"");
        push_points(out, &path.points[..path.points.len() - 1]);
    } else {
        out.push_str("    <polyline points=\"");
        push_points(out, &path.points);
    }
    out.push('"');
    if let Some(pen) = path.pen {
        if pen.color != layer_pen.color {
            let _ = write!(out, " stroke=\"{}\"", pen.color.to_hex());
        }
        if (pen.width_mm - layer_pen.width_mm).abs() > 0.5e-4 {
            out.push_str(" stroke-width=\"");
            push_number(out, pen.width_mm);
            out.push('"');
        }
    }
    out.push_str("/>\n");
}

/// Render `drawing` as a plain SVG document.
pub fn to_svg_string(drawing: &Drawing) -> String {
    document(drawing, &[], Rgb::BLACK)
}

/// Width of the travel overlay's dashed lines, mm.
const TRAVEL_WIDTH_MM: f64 = 0.2;

/// Render `drawing` as [`to_svg_string`] does, with `travel` (the pen-up moves, e.g.
/// [`crate::geometry::travel::pen_up_moves`]) drawn over it as a last layer of thin dashed lines in
/// `travel_color`, labelled `travel (pen up)`.
pub fn to_preview_svg(drawing: &Drawing, travel: &[Line], travel_color: Rgb) -> String {
    document(drawing, travel, travel_color)
}

/// `svg` compressed with gzip, as an `.svgz` file holds it.
pub fn gzip(svg: &str) -> Vec<u8> {
    let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    // Writing into a Vec cannot fail.
    let _ = enc.write_all(svg.as_bytes());
    enc.finish().unwrap_or_default()
}

/// The document of `drawing`, with a travel overlay layer when `travel` is not empty.
fn document(drawing: &Drawing, travel: &[Line], travel_color: Rgb) -> String {
    let (w, h) = page_size(drawing);
    let mut out = String::with_capacity(256 + drawing.paths().map(|p| p.points.len() * 20).sum::<usize>());
    out.push_str("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    out.push_str("<svg xmlns=\"http://www.w3.org/2000/svg\" ");
    out.push_str("xmlns:inkscape=\"http://www.inkscape.org/namespaces/inkscape\" width=\"");
    push_number(&mut out, w);
    out.push_str("mm\" height=\"");
    push_number(&mut out, h);
    out.push_str("mm\" viewBox=\"0 0 ");
    push_number(&mut out, w);
    out.push(' ');
    push_number(&mut out, h);
    out.push_str("\">\n");
    for (i, layer) in drawing.layers.iter().enumerate() {
        let _ = write!(
            out,
            "  <g id=\"layer{}\" inkscape:groupmode=\"layer\" inkscape:label=\"{}\" fill=\"none\" stroke=\"{}\" \
             stroke-width=\"",
            i + 1,
            escape(&layer.name),
            layer.pen.color.to_hex()
        );
        push_number(&mut out, layer.pen.width_mm);
        out.push_str("\" stroke-linecap=\"round\" stroke-linejoin=\"round\">\n");
        for path in &layer.paths {
            push_path(&mut out, path, &layer.pen);
        }
        out.push_str("  </g>\n");
    }
    if !travel.is_empty() {
        let _ = writeln!(
            out,
            "  <g id=\"travel\" inkscape:groupmode=\"layer\" inkscape:label=\"travel (pen up)\" fill=\"none\" \
             stroke=\"{}\" stroke-width=\"{TRAVEL_WIDTH_MM}\" stroke-dasharray=\"1 1\">",
            travel_color.to_hex()
        );
        for l in travel {
            out.push_str("    <polyline points=\"");
            push_points(&mut out, &[l.p0, l.p1]);
            out.push_str("\"/>\n");
        }
        out.push_str("  </g>\n");
    }
    out.push_str("</svg>\n");
    out
}

/// Write `drawing` as a plain SVG document to `w`.
pub fn write_svg(drawing: &Drawing, mut w: impl Write) -> io::Result<()> {
    w.write_all(to_svg_string(drawing).as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::drawing::Layer;

    #[test]
    fn the_preview_document_adds_the_travel_as_a_dashed_layer() {
        let line = |a: (f64, f64), b: (f64, f64)| Polyline::new(vec![Point::new(a.0, a.1), Point::new(b.0, b.1)]);
        let mut d = Drawing::single_layer("ink", vec![line((1.0, 2.0), (11.0, 2.0)), line((11.0, 12.0), (1.0, 12.0))]);
        d.page_mm = Some((20.0, 20.0));
        let travel = [Line::new((11.0, 2.0), (11.0, 12.0))];
        let svg = to_preview_svg(&d, &travel, Rgb(230, 40, 90));
        let plain = to_svg_string(&d);
        // The plain document, then the overlay before the end.
        let overlay = "  <g id=\"travel\" inkscape:groupmode=\"layer\" inkscape:label=\"travel (pen up)\" fill=\"none\" \
                       stroke=\"#e6285a\" stroke-width=\"0.2\" stroke-dasharray=\"1 1\">\n    <polyline points=\"11,2 \
                       11,12\"/>\n  </g>\n</svg>\n";
        assert_eq!(svg, format!("{}{overlay}", plain.strip_suffix("</svg>\n").unwrap()));
        assert_eq!(to_preview_svg(&d, &[], Rgb::BLACK), plain);
        // Gzip: the magic bytes, and the document back.
        let z = gzip(&plain);
        assert_eq!(&z[..2], &[0x1f, 0x8b]);
        let mut back = String::new();
        std::io::Read::read_to_string(&mut flate2::read::GzDecoder::new(&z[..]), &mut back).unwrap();
        assert_eq!(back, plain);
    }

    #[test]
    fn the_fast_path_writes_what_exact_formatting_writes() {
        let check = |v: f64| {
            let (mut fast, mut exact) = (String::new(), String::new());
            push_number(&mut fast, v);
            push_number_formatted(&mut exact, v);
            assert_eq!(fast, exact, "{v:e}");
        };
        // Half-way cases, signs, zeros, carries into the integer part, the size limit and beyond.
        for v in [
            0.0,
            -0.0,
            0.00005,
            -0.00005,
            0.00015,
            1.23455,
            2.5,
            9.99995,
            9.99994,
            -9.99996,
            0.1,
            0.2,
            0.3,
            1234.5678,
            999_999.999_94,
            999_999.999_96,
            1e6,
            -1e6,
            3e9,
            1e-9,
            -1e-9,
            0.00049999,
            12.0001,
            f64::MAX,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ] {
            check(v);
        }
        use rand::{RngExt, SeedableRng};
        let mut r = rand::rngs::StdRng::seed_from_u64(3);
        for _ in 0..200_000 {
            let scale = [1e-3, 1.0, 1e3, 1e6][r.random_range(0..4)];
            check(r.random_range(-1.0..1.0) * scale);
            // Values on the grid of ten-thousandths and half-way between, as coordinates typed in a file are.
            let k = f64::from(r.random_range(-10_000_000..10_000_000));
            check(k / 1e4);
            check((k + 0.5) / 1e4);
        }
    }

    #[test]
    fn numbers_are_short_and_exact_enough() {
        let mut s = String::new();
        for v in [1.0, 0.5, -0.00001, 12.345678, -3.1] {
            push_number(&mut s, v);
            s.push(' ');
        }
        assert_eq!(s, "1 0.5 0 12.3457 -3.1 ");
    }

    #[test]
    fn writes_layers_polylines_and_polygons() {
        let mut layer = Layer::new("outline & fill");
        layer.pen.color = Rgb(255, 0, 0);
        layer.paths.push(Polyline::new(vec![Point::new(0.0, 0.0), Point::new(10.0, 0.5)]));
        layer.paths.push(Polyline::new(vec![
            Point::new(1.0, 1.0),
            Point::new(2.0, 1.0),
            Point::new(2.0, 2.0),
            Point::new(1.0, 1.0),
        ]));
        let d = Drawing { layers: vec![layer], page_mm: Some((210.0, 297.0)) };
        let svg = to_svg_string(&d);
        assert!(svg.contains("width=\"210mm\" height=\"297mm\" viewBox=\"0 0 210 297\""), "{svg}");
        assert!(svg.contains("inkscape:label=\"outline &amp; fill\""));
        assert!(svg.contains("stroke=\"#ff0000\""));
        assert!(svg.contains("<polyline points=\"0,0 10,0.5\"/>"));
        assert!(svg.contains("<polygon points=\"1,1 2,1 2,2\"/>"));
    }

    #[test]
    fn paths_keep_their_own_stroke_where_it_differs_from_the_layer() {
        let mut layer = Layer::new("mixed");
        layer.pen = Pen { color: Rgb(0, 0, 0), width_mm: 0.3 };
        let line = vec![Point::new(0.0, 0.0), Point::new(1.0, 0.0)];
        let pens = [
            Pen { color: Rgb(0, 0, 0), width_mm: 0.3 },
            Pen { color: Rgb(0, 128, 255), width_mm: 0.3 },
            Pen { color: Rgb(0, 0, 0), width_mm: 1.25 },
        ];
        for pen in pens {
            layer.paths.push(Polyline::with_pen(line.clone(), pen));
        }
        let svg = to_svg_string(&Drawing { layers: vec![layer], page_mm: None });
        let lines: Vec<&str> = svg.lines().filter(|l| l.contains("<polyline")).collect();
        assert_eq!(
            lines,
            [
                "    <polyline points=\"0,0 1,0\"/>",
                "    <polyline points=\"0,0 1,0\" stroke=\"#0080ff\"/>",
                "    <polyline points=\"0,0 1,0\" stroke-width=\"1.25\"/>",
            ]
        );
    }

    #[test]
    fn without_a_page_the_size_is_the_far_corner_of_the_drawing() {
        let mut first = Layer::new("a");
        first.paths.push(Polyline::new(vec![Point::new(-5.0, 2.0), Point::new(30.5, 12.25)]));
        let mut second = Layer::new("b");
        // One point: nothing to draw.
        second.paths.push(Polyline::new(vec![Point::new(3.0, 3.0)]));
        second.paths.push(Polyline::new(vec![Point::new(0.1, 0.1), Point::new(0.2, 0.3)]));
        let svg = to_svg_string(&Drawing { layers: vec![first, second], page_mm: None });
        assert!(svg.contains("width=\"30.5mm\" height=\"12.25mm\" viewBox=\"0 0 30.5 12.25\""), "{svg}");
        assert!(svg.contains("<g id=\"layer1\" inkscape:groupmode=\"layer\" inkscape:label=\"a\""), "{svg}");
        assert!(svg.contains("<g id=\"layer2\" inkscape:groupmode=\"layer\" inkscape:label=\"b\""), "{svg}");
        assert_eq!(svg.matches("<polyline").count(), 2, "the one-point path is left out: {svg}");
        // A drawing within a millimetre of the origin, or none at all, gets a 1 mm page.
        let mut tiny = Layer::new("t");
        tiny.paths.push(Polyline::new(vec![Point::new(0.1, 0.1), Point::new(0.2, 0.3)]));
        for layers in [vec![tiny], vec![]] {
            let svg = to_svg_string(&Drawing { layers, page_mm: None });
            assert!(svg.contains("width=\"1mm\" height=\"1mm\" viewBox=\"0 0 1 1\""), "{svg}");
        }
    }

    #[test]
    fn a_width_within_the_written_precision_of_the_layer_s_is_not_repeated() {
        let mut layer = Layer::new("w");
        layer.pen = Pen { color: Rgb(0, 0, 0), width_mm: 0.0 };
        let line = vec![Point::new(0.0, 0.0), Point::new(1.0, 0.0)];
        for width_mm in [0.5e-4, 2.0e-4] {
            layer.paths.push(Polyline::with_pen(line.clone(), Pen { color: Rgb(0, 0, 0), width_mm }));
        }
        let svg = to_svg_string(&Drawing { layers: vec![layer], page_mm: None });
        let lines: Vec<&str> = svg.lines().filter(|l| l.contains("<polyline")).collect();
        assert_eq!(
            lines,
            ["    <polyline points=\"0,0 1,0\"/>", "    <polyline points=\"0,0 1,0\" stroke-width=\"0.0002\"/>"]
        );
    }

    #[test]
    fn write_svg_writes_the_whole_document() {
        let mut out = Vec::new();
        write_svg(&Drawing { layers: vec![], page_mm: Some((10.0, 20.0)) }, &mut out).unwrap();
        let text = String::from_utf8(out).unwrap();
        assert!(text.starts_with("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<svg "), "{text}");
        assert!(text.ends_with("viewBox=\"0 0 10 20\">\n</svg>\n"), "{text}");
    }
}
