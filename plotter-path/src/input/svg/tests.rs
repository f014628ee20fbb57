//! Golden and behaviour tests of the SVG importer.

use super::*;
use crate::geometry::drawing::Pen;

fn import(svg: &str) -> Imported {
    import_svg(svg.as_bytes(), "test.svg", &ResourcePolicy::DataUrlsOnly, &SvgOptions::default()).unwrap()
}

/// A point given in CSS px, converted to mm.
fn px(x: f64, y: f64) -> Point {
    Point::new(x * MM_PER_PX, y * MM_PER_PX)
}

fn assert_points(actual: &[Point], expected: &[Point], tol: f64) {
    assert_eq!(actual.len(), expected.len(), "{actual:?} vs {expected:?}");
    for (a, e) in actual.iter().zip(expected) {
        assert!(a.distance(*e) <= tol, "{a:?} != {e:?} (tol {tol})\nall: {actual:?}");
    }
}

/// Hand-checked: nested transforms, a quarter-turn matrix, `<use>`, root size in inches with a 2× viewBox.
/// Every value involved is dyadic, so usvg's f32 arithmetic is exact and the result matches to 1e-6 mm.
#[test]
fn golden_nested_transforms_units_and_use() {
    let svg = r##"<svg xmlns="http://www.w3.org/2000/svg" xmlns:xlink="http://www.w3.org/1999/xlink"
        width="2in" height="1in" viewBox="0 0 96 48">
      <g transform="translate(10,4)">
        <g transform="scale(0.5)"><line x1="0" y1="0" x2="16" y2="8" stroke="black"/></g>
        <g transform="matrix(0,1,-1,0,20,0)"><polyline points="0,0 4,0 4,2" stroke="black" fill="none"/></g>
      </g>
      <defs><rect id="r" width="4" height="2" stroke="black" fill="none"/></defs>
      <use xlink:href="#r" x="40" y="20"/>
    </svg>"##;
    let imported = import(svg);
    assert!(imported.warnings.is_empty(), "{:?}", imported.warnings);
    let d = imported.drawing;
    // 2 in × 1 in page.
    let (w, h) = d.page_mm.unwrap();
    assert!((w - 50.8).abs() < 1e-9 && (h - 25.4).abs() < 1e-9);
    let paths: Vec<&Polyline> = d.paths().collect();
    assert_eq!(paths.len(), 3);
    // line: scale .5 → (0,0),(8,4); translate → (10,4),(18,8); viewBox ×2 → px (20,8),(36,16).
    assert_points(&paths[0].points, &[px(20.0, 8.0), px(36.0, 16.0)], 1e-6);
    // polyline: (x,y) → (20 − y, x), then translate(10,4), then ×2.
    assert_points(&paths[1].points, &[px(60.0, 8.0), px(60.0, 16.0), px(56.0, 16.0)], 1e-6);
    // use: rect 4×2 at (40,20), ×2 → closed (80,40)…(88,44).
    assert!(paths[2].is_closed());
    assert_points(
        &paths[2].points,
        &[px(80.0, 40.0), px(88.0, 40.0), px(88.0, 44.0), px(80.0, 44.0), px(80.0, 40.0)],
        1e-6,
    );
    // The same in plain millimetres, checked by hand: 20 px = 20 × 25.4 / 96 = 5.291666… mm.
    assert!((paths[0].points[0].x - 5.291_666_666_7).abs() < 1e-6);
    assert!((paths[2].points[2].y - 11.641_666_666_7).abs() < 1e-6);
}

#[test]
fn physical_units_resolve_at_96_dpi() {
    // No viewBox: one user unit is one px. Coordinates in in, cm, pt, mm; f32 inside usvg → 1e-4 mm.
    let svg = r##"<svg xmlns="http://www.w3.org/2000/svg" width="200mm" height="100mm">
      <line x1="1in" y1="2cm" x2="36pt" y2="10mm" stroke="black"/>
      <line x1="96px" y1="0" x2="6pc" y2="48" stroke="black"/>
    </svg>"##;
    let d = import(svg).drawing;
    let (w, h) = d.page_mm.unwrap();
    assert!((w - 200.0).abs() < 1e-4 && (h - 100.0).abs() < 1e-4);
    let paths: Vec<&Polyline> = d.paths().collect();
    assert_points(&paths[0].points, &[Point::new(25.4, 20.0), Point::new(12.7, 10.0)], 1e-4);
    assert_points(&paths[1].points, &[Point::new(25.4, 0.0), Point::new(25.4, 12.7)], 1e-4);
}

#[test]
fn viewbox_with_preserve_aspect_ratio() {
    let shape = r##"<line x1="0" y1="0" x2="50" y2="50" stroke="black"/>"##;
    let cases = [
        // meet: scale min(4, 2) = 2, centred horizontally: x offset (200 − 100) / 2 = 50.
        ("xMidYMid meet", [px(50.0, 0.0), px(150.0, 100.0)]),
        // slice: scale max(4, 2) = 4, aligned top-left.
        ("xMinYMin slice", [px(0.0, 0.0), px(200.0, 200.0)]),
        // none: independent scales 4 × 2.
        ("none", [px(0.0, 0.0), px(200.0, 100.0)]),
        // meet aligned right.
        ("xMaxYMax meet", [px(100.0, 0.0), px(200.0, 100.0)]),
    ];
    for (par, expected) in cases {
        let svg = format!(
            r##"<svg xmlns="http://www.w3.org/2000/svg" width="200" height="100" viewBox="0 0 50 50"
                preserveAspectRatio="{par}">{shape}</svg>"##
        );
        let d = import(&svg).drawing;
        let p = d.paths().next().unwrap();
        assert_points(&p.points, &expected, 1e-6);
    }
}

#[test]
fn curves_meet_the_tolerance_and_close() {
    // A circle of r = 100 px. usvg turns it into quarter-circle cubics (radial error ≤ 2.7e-4 r = 0.007 mm) before we
    // see it; our flattening adds at most `tol` on top.
    let svg = r##"<svg xmlns="http://www.w3.org/2000/svg" width="300" height="300">
        <circle cx="150" cy="150" r="100" stroke="black" fill="none"/></svg>"##;
    let tol = 0.01;
    let opts = SvgOptions { tolerance_mm: tol, ..SvgOptions::default() };
    let imported = import_svg(svg.as_bytes(), "c.svg", &ResourcePolicy::DataUrlsOnly, &opts).unwrap();
    assert!(imported.warnings.is_empty(), "{:?}", imported.warnings);
    let p = imported.drawing.paths().next().unwrap();
    assert!(p.is_closed());
    let (c, r) = (px(150.0, 150.0), 100.0 * MM_PER_PX);
    let library_bound = arc_approximation_bound(100.0) * MM_PER_PX;
    for w in p.points.windows(2) {
        // Sagitta of each chord: distance of its midpoint inside the circle.
        let sagitta = r - w[0].midpoint(w[1]).distance(c);
        assert!(sagitta <= tol + library_bound, "chord error {sagitta}");
        assert!((w[0].distance(c) - r).abs() <= library_bound);
    }
    // A tolerance below the library's bound is reported.
    let opts = SvgOptions { tolerance_mm: 0.005, ..SvgOptions::default() };
    let warned = import_svg(svg.as_bytes(), "c.svg", &ResourcePolicy::DataUrlsOnly, &opts).unwrap();
    assert!(warned.warnings.iter().any(|w| w.contains("arcs/circles are approximated")), "{:?}", warned.warnings);
}

#[test]
fn text_becomes_glyph_outlines_or_warns_without_fonts() {
    let svg = r##"<svg xmlns="http://www.w3.org/2000/svg" width="100" height="40">
        <text x="5" y="30" font-family="sans-serif" font-size="24">Hi</text></svg>"##;
    let mut db = usvg::fontdb::Database::new();
    db.load_system_fonts();
    let result = import_svg(svg.as_bytes(), "t.svg", &ResourcePolicy::DataUrlsOnly, &SvgOptions::default());
    if db.is_empty() {
        let err = result.unwrap_err().to_string();
        assert!(err.contains("no font found"), "{err}");
    } else {
        let d = result.unwrap().drawing;
        // "H" is three closed-or-open outlines' worth of points, "i" at least two (stem and dot).
        assert!(d.path_count() >= 2, "glyph outlines: {}", d.path_count());
        let b = d.bbox().unwrap();
        assert!(b.x0 >= 5.0 * MM_PER_PX - 1.0 && b.y1 <= 31.0 * MM_PER_PX, "{b:?}");
    }
}

#[test]
fn fill_only_shapes_plot_their_outline_and_invisible_ones_are_reported() {
    let svg = r##"<svg xmlns="http://www.w3.org/2000/svg" width="100" height="100">
        <rect x="10" y="10" width="20" height="20" fill="red"/>
        <rect x="40" y="10" width="20" height="20" fill="none"/>
        <rect x="70" y="10" width="20" height="20" stroke="black" visibility="hidden"/>
        <rect x="70" y="40" width="20" height="20" stroke="black" display="none"/>
        <path d="M 10 50 L 20 60 L oops" stroke="blue"/>
        <rect x="0" y="0" width="0" height="5" stroke="black"/>
        <image x="0" y="0" width="10" height="10" href="missing.png"/>
    </svg>"##;
    let imported = import(svg);
    let d = &imported.drawing;
    assert_eq!(d.path_count(), 2, "filled rect outline + valid part of the broken path");
    let red = d.paths().next().unwrap();
    assert!(red.is_closed());
    assert_eq!(d.layers[0].pen.color, Rgb(255, 0, 0));
    let w = imported.warnings.join("\n");
    assert!(w.contains("2 invisible shape(s)"), "{w}");
    assert!(w.contains("<path> at line 6") && w.contains("drawn up to the error"), "{w}");
    assert!(w.contains("<rect> at line 7: zero or negative size"), "{w}");
    assert!(w.contains("<image> at line 8"), "{w}");
}

#[test]
fn layers_from_inkscape_labels_and_colours() {
    let svg = r##"<svg xmlns="http://www.w3.org/2000/svg" xmlns:inkscape="http://www.inkscape.org/namespaces/inkscape"
        width="100" height="100">
      <g id="layer1" inkscape:groupmode="layer" inkscape:label="Outline">
        <line x1="0" y1="0" x2="10" y2="0" stroke="#ff0000"/>
        <line x1="0" y1="5" x2="10" y2="5" stroke="#0000ff"/>
      </g>
      <g id="detail"><line x1="0" y1="10" x2="10" y2="10" stroke="#0000ff"/></g>
      <line x1="0" y1="20" x2="10" y2="20" stroke="#ff0000"/>
    </svg>"##;
    // Auto: the one Inkscape layer, and everything outside it (a plain group and a line) in `root`.
    let auto = import(svg).drawing;
    let names: Vec<&str> = auto.layers.iter().map(|l| l.name.as_str()).collect();
    assert_eq!(names, ["Outline", "root"]);
    assert_eq!(auto.layers[0].paths.len(), 2);
    assert_eq!(auto.layers[1].paths.len(), 2);
    let opts = SvgOptions { layer_by: LayerBy::Group, ..SvgOptions::default() };
    let by_group = import_svg(svg.as_bytes(), "l.svg", &ResourcePolicy::DataUrlsOnly, &opts).unwrap().drawing;
    let names: Vec<&str> = by_group.layers.iter().map(|l| l.name.as_str()).collect();
    assert_eq!(names, ["Outline", "detail", "root"]);
    assert_eq!(by_group.layers[0].paths.len(), 2);

    let opts = SvgOptions { layer_by: LayerBy::Color, ..SvgOptions::default() };
    let by_color = import_svg(svg.as_bytes(), "l.svg", &ResourcePolicy::DataUrlsOnly, &opts).unwrap().drawing;
    let names: Vec<&str> = by_color.layers.iter().map(|l| l.name.as_str()).collect();
    assert_eq!(names, ["#ff0000", "#0000ff"]);
    assert_eq!(by_color.layers[0].paths.len(), 2);
    assert_eq!(by_color.layers[1].pen.color, Rgb(0, 0, 255));

    let opts = SvgOptions { layers: vec!["detail".into()], layer_by: LayerBy::Group, ..SvgOptions::default() };
    let only = import_svg(svg.as_bytes(), "l.svg", &ResourcePolicy::DataUrlsOnly, &opts).unwrap().drawing;
    assert_eq!(only.layers.len(), 1);
    assert_eq!(only.layers[0].name, "detail");
    let opts = SvgOptions { layers: vec!["nope".into()], layer_by: LayerBy::Group, ..SvgOptions::default() };
    let err = import_svg(svg.as_bytes(), "l.svg", &ResourcePolicy::DataUrlsOnly, &opts).unwrap_err().to_string();
    assert!(err.contains("no layer named 'nope'") && err.contains("Outline, detail, root"), "{err}");
}

#[test]
fn bad_input_is_a_clear_error_naming_the_file() {
    let png = b"\x89PNG\r\n\x1a\n\0\0\0\rIHDR";
    let cases: [(&[u8], &str); 4] = [
        (png, "not UTF-8"),
        (b"hello, plotter", "not a valid SVG"),
        (b"<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"10\" height=\"10\"><line x1=\"0\"", "not a valid SVG"),
        (b"<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"10\" height=\"10\"><g/></svg>", "nothing to draw"),
    ];
    for (data, want) in cases {
        let err =
            import_svg(data, "bad.svg", &ResourcePolicy::DataUrlsOnly, &SvgOptions::default()).unwrap_err().to_string();
        assert!(err.starts_with("bad.svg") && err.contains(want), "{err}");
    }
    let err = load_svg(Path::new("/definitely/missing.svg"), &SvgOptions::default()).unwrap_err().to_string();
    assert!(err.contains("/definitely/missing.svg") && err.contains("cannot read"), "{err}");
    let html = b"<html><body/></html>";
    let err =
        import_svg(html, "page.html", &ResourcePolicy::DataUrlsOnly, &SvgOptions::default()).unwrap_err().to_string();
    assert!(err.contains("expected <svg>"), "{err}");
}

#[test]
fn millimetre_documents_stay_exact() {
    // width in mm with a viewBox in mm, rotated content: the root transform is computed in f64.
    let svg = r##"<svg xmlns="http://www.w3.org/2000/svg" width="100mm" height="50mm" viewBox="0 0 100 50">
        <g transform="translate(10 5)"><line x1="0" y1="5" x2="80" y2="35" stroke="black"/></g></svg>"##;
    let d = import(svg).drawing;
    assert_eq!(d.page_mm, Some((100.0, 50.0)));
    assert_points(&d.paths().next().unwrap().points, &[Point::new(10.0, 10.0), Point::new(90.0, 40.0)], 1e-9);
}

// ---------------------------------------------------------------------------------------------------------------
// Real-world SVG: reading, layers, clips, masks, occlusion, dashes, opacity, page, hatch, text, images.
// Documents use width/height in mm with a matching viewBox, so one user unit is one millimetre and every expected
// length below is computed by hand in mm.

/// A 100 × 100 mm page around `body`.
fn mm_doc(body: &str) -> String {
    format!(
        r##"<svg xmlns="http://www.w3.org/2000/svg" xmlns:xlink="http://www.w3.org/1999/xlink"
            xmlns:inkscape="http://www.inkscape.org/namespaces/inkscape"
            width="100mm" height="100mm" viewBox="0 0 100 100">{body}</svg>"##
    )
}

fn import_with(svg: &str, options: &SvgOptions) -> Imported {
    import_svg(svg.as_bytes(), "t.svg", &ResourcePolicy::DataUrlsOnly, options).unwrap()
}

/// Total pen-down length, mm.
fn pen_down(d: &Drawing) -> f64 {
    d.paths().map(Polyline::length).sum()
}

fn assert_len(d: &Drawing, expected: f64) {
    let got = pen_down(d);
    assert!((got - expected).abs() < 1e-3, "pen-down {got} mm, expected {expected} mm");
}

#[test]
fn doctype_with_internal_entities() {
    let svg = r##"<?xml version="1.0"?>
<!DOCTYPE svg PUBLIC "-//W3C//DTD SVG 1.1//EN" "http://www.w3.org/Graphics/SVG/1.1/DTD/svg11.dtd" [
  <!ENTITY ns_svg "http://www.w3.org/2000/svg">
  <!ENTITY len "60">
]>
<svg xmlns="&ns_svg;" width="100mm" height="100mm" viewBox="0 0 100 100">
  <line x1="10" y1="10" x2="&len;" y2="10" stroke="black"/>
</svg>"##;
    // 60 − 10 = 50 mm.
    assert_len(&import(svg).drawing, 50.0);
    let mut laughs = String::from("<?xml version=\"1.0\"?><!DOCTYPE svg [<!ENTITY a \"aaaaaaaaaa\">");
    let mut prev = "a".to_string();
    for i in 0..9 {
        laughs.push_str(&format!("<!ENTITY a{i} \"{}\">", format!("&{prev};").repeat(10)));
        prev = format!("a{i}");
    }
    laughs.push_str(&format!("]><svg xmlns=\"http://www.w3.org/2000/svg\"><text>&{prev};</text></svg>"));
    let err = import_svg(laughs.as_bytes(), "laughs.svg", &ResourcePolicy::DataUrlsOnly, &SvgOptions::default())
        .unwrap_err()
        .to_string();
    assert!(err.starts_with("laughs.svg") && err.contains("billion laughs"), "{err}");
}

#[test]
fn each_encoding_reads() {
    // A 30 mm line with a non-ASCII id, written in each encoding.
    let body = |decl: &str| {
        format!(
            r##"<?xml version="1.0" encoding="{decl}"?><svg xmlns="http://www.w3.org/2000/svg" width="100mm"
            height="100mm" viewBox="0 0 100 100"><line id="café" x1="0" y1="5" x2="30" y2="5" stroke="black"/></svg>"##
        )
    };
    let latin1 = |s: &str| s.chars().map(|c| u8::try_from(u32::from(c)).unwrap()).collect::<Vec<u8>>();
    let utf16le: Vec<u8> =
        [0xff, 0xfe].into_iter().chain(body("UTF-16").encode_utf16().flat_map(u16::to_le_bytes)).collect();
    let utf16be: Vec<u8> =
        [0xfe, 0xff].into_iter().chain(body("UTF-16").encode_utf16().flat_map(u16::to_be_bytes)).collect();
    let cases: [(&str, Vec<u8>); 5] = [
        ("ISO-8859-1", latin1(&body("ISO-8859-1"))),
        ("ISO-8859-15", latin1(&body("ISO-8859-15"))),
        ("windows-1252", latin1(&body("windows-1252"))),
        ("UTF-16LE", utf16le),
        ("UTF-16BE", utf16be),
    ];
    for (what, bytes) in cases {
        let imported = import_svg(&bytes, "enc.svg", &ResourcePolicy::DataUrlsOnly, &SvgOptions::default())
            .unwrap_or_else(|e| panic!("{what}: {e}"));
        assert_len(&imported.drawing, 30.0);
    }
}

#[test]
fn gzip_compressed_svg() {
    use std::io::Write;
    let svg = mm_doc(r#"<line x1="0" y1="5" x2="40" y2="5" stroke="black"/>"#);
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    gz.write_all(svg.as_bytes()).unwrap();
    let bytes = gz.finish().unwrap();
    assert_len(
        &import_svg(&bytes, "a.svgz", &ResourcePolicy::DataUrlsOnly, &SvgOptions::default()).unwrap().drawing,
        40.0,
    );
    let err = import_svg(&bytes[..bytes.len() / 2], "b.svgz", &ResourcePolicy::DataUrlsOnly, &SvgOptions::default())
        .unwrap_err();
    assert!(err.to_string().contains("gzip"), "{err}");
}

#[test]
fn inkscape_layers_versus_plain_groups() {
    // Two Inkscape layers (20 + 10 mm, and 30 mm), each holding plain groups: two pens.
    let layered = mm_doc(
        r##"<g id="layer1" inkscape:groupmode="layer" inkscape:label="Ink">
              <g id="g1"><line x1="0" y1="0" x2="20" y2="0" stroke="red"/></g>
              <g id="g2"><line x1="0" y1="5" x2="10" y2="5" stroke="blue"/></g></g>
            <g id="layer2" inkscape:groupmode="layer" inkscape:label="Pencil">
              <line x1="0" y1="9" x2="30" y2="9" stroke="black"/></g>"##,
    );
    let d = import(&layered).drawing;
    let names: Vec<&str> = d.layers.iter().map(|l| l.name.as_str()).collect();
    assert_eq!(names, ["Ink", "Pencil"]);
    assert!((d.layers[0].paths.iter().map(Polyline::length).sum::<f64>() - 30.0).abs() < 1e-6);
    assert!((d.layers[1].paths.iter().map(Polyline::length).sum::<f64>() - 30.0).abs() < 1e-6);
    // The same without layer marks: 3 plain groups, a top-level <use> and a marker are one pen in auto mode.
    let plain = mm_doc(
        r##"<defs><marker id="m" markerWidth="4" markerHeight="4" refX="0" refY="0">
              <line x1="0" y1="0" x2="2" y2="0" stroke="black"/></marker>
              <line id="tick" x1="0" y1="0" x2="5" y2="0" stroke="black"/></defs>
            <g id="a"><line x1="0" y1="0" x2="20" y2="0" stroke="red"/></g>
            <g id="b"><line x1="0" y1="5" x2="10" y2="5" stroke="blue"/></g>
            <g id="c"><line x1="0" y1="9" x2="30" y2="9" stroke="black" marker-end="url(#m)"/></g>
            <use xlink:href="#tick" y="20"/>"##,
    );
    let d = import(&plain).drawing;
    assert_eq!(d.layers.len(), 1);
    // 20 + 10 + 30 + the marker's 2 mm (stroke width 1 scales markers by 1) + the 5 mm <use>.
    assert_len(&d, 67.0);
    let groups = import_with(&plain, &SvgOptions { layer_by: LayerBy::Group, ..SvgOptions::default() }).drawing;
    let names: Vec<&str> = groups.layers.iter().map(|l| l.name.as_str()).collect();
    assert_eq!(names, ["a", "b", "c", "root"], "the <use> is not a layer of its own");
}

#[test]
fn inkscape_layers_without_ids_are_layers() {
    // Two layers without ids (usvg keeps such groups but without a name to find them by): 20 + 10 mm in "Ink",
    // 30 mm in "Pencil"; a line outside both goes to "root".
    let svg = mm_doc(
        r##"<g inkscape:groupmode="layer" inkscape:label="Ink">
              <line x1="0" y1="0" x2="20" y2="0" stroke="red"/>
              <g><line x1="0" y1="5" x2="10" y2="5" stroke="blue"/></g></g>
            <g inkscape:label="Pencil" inkscape:groupmode="layer" transform="translate(0,10)">
              <line x1="0" y1="9" x2="30" y2="9" stroke="black"/></g>
            <line x1="0" y1="50" x2="7" y2="50" stroke="black"/>"##,
    );
    let d = import(&svg).drawing;
    let names: Vec<&str> = d.layers.iter().map(|l| l.name.as_str()).collect();
    assert_eq!(names, ["Ink", "Pencil", "root"]);
    let lengths: Vec<f64> = d.layers.iter().map(|l| l.paths.iter().map(Polyline::length).sum()).collect();
    assert_eq!(d.layers[0].paths.len(), 2);
    for (got, want) in lengths.iter().zip([30.0, 30.0, 7.0]) {
        assert!((got - want).abs() < 1e-6, "{lengths:?}");
    }
    // The Pencil line moved by its layer's transform: y = 19 mm.
    assert!((d.layers[1].paths[0].points[0].y - 19.0).abs() < 1e-6);
    // Top-level groups without ids are groups too (named by their label, else their line).
    let by_group = import_with(&svg, &SvgOptions { layer_by: LayerBy::Group, ..SvgOptions::default() }).drawing;
    let names: Vec<&str> = by_group.layers.iter().map(|l| l.name.as_str()).collect();
    assert_eq!(names, ["Ink", "Pencil", "root"]);
    let unlabelled = mm_doc("\n<g>\n<line x1=\"0\" y1=\"0\" x2=\"5\" y2=\"0\" stroke=\"black\"/></g>");
    let d = import_with(&unlabelled, &SvgOptions { layer_by: LayerBy::Group, ..SvgOptions::default() }).drawing;
    assert_eq!(d.layers[0].name, "group at line 4");
}

#[test]
fn colour_layers_normalise_colour_names() {
    let svg = mm_doc(
        r##"<line x1="0" y1="0" x2="10" y2="0" stroke="red"/>
            <line x1="0" y1="5" x2="10" y2="5" stroke="#ff0000"/>
            <line x1="0" y1="9" x2="10" y2="9" stroke="rgb(255,0,0)"/>
            <line x1="0" y1="12" x2="10" y2="12" stroke="#00f"/>"##,
    );
    let d = import_with(&svg, &SvgOptions { layer_by: LayerBy::Color, ..SvgOptions::default() }).drawing;
    let names: Vec<&str> = d.layers.iter().map(|l| l.name.as_str()).collect();
    assert_eq!(names, ["#ff0000", "#0000ff"]);
    assert_eq!(d.layers[0].paths.len(), 3);
}

#[test]
fn clip_paths_cut_exactly() {
    let line = r#"<line x1="-10" y1="50" x2="110" y2="50" stroke="black"/>"#;
    // A rectangle clip x 20..80: 60 mm of the line stay.
    let simple = mm_doc(&format!(
        r#"<clipPath id="c"><rect x="20" y="0" width="60" height="100"/></clipPath><g clip-path="url(#c)">{line}</g>"#
    ));
    assert_len(&import(&simple).drawing, 60.0);
    // Nested: the clip path itself clipped to x 50..100 → 50..80 = 30 mm.
    let nested = mm_doc(&format!(
        r#"<clipPath id="outer"><rect x="50" y="0" width="50" height="100"/></clipPath>
           <clipPath id="c" clip-path="url(#outer)"><rect x="20" y="0" width="60" height="100"/></clipPath>
           <g clip-path="url(#c)">{line}</g>"#
    ));
    assert_len(&import(&nested).drawing, 30.0);
    // clip-rule evenodd: two nested squares make a frame; x 10..90 minus 30..70 = 80 − 40 = 40 mm.
    let frame = |rule: &str| {
        mm_doc(&format!(
            r#"<clipPath id="c"><path clip-rule="{rule}" d="M10 10 H90 V90 H10 Z M30 30 H70 V70 H30 Z"/></clipPath>
               <g clip-path="url(#c)">{line}</g>"#
        ))
    };
    assert_len(&import(&frame("evenodd")).drawing, 40.0);
    assert_len(&import(&frame("nonzero")).drawing, 80.0);
    // objectBoundingBox units: the left half of a 100 × 100 square's outline = 100 (left) + 50 + 50 = 200 mm.
    let obb = mm_doc(
        r#"<clipPath id="c" clipPathUnits="objectBoundingBox"><rect x="0" y="0" width="0.5" height="1"/></clipPath>
           <rect x="0" y="0" width="100" height="100" fill="none" stroke="black" clip-path="url(#c)"/>"#,
    );
    assert_len(&import(&obb).drawing, 200.0);
}

#[test]
fn nested_svg_viewport_clips() {
    // Inner viewport at (10, 10), 50 × 50 mm: a 120 mm line across it keeps 50 mm.
    let svg = mm_doc(
        r#"<svg x="10" y="10" width="50" height="50" viewBox="0 0 50 50">
             <line x1="-20" y1="25" x2="100" y2="25" stroke="black"/></svg>"#,
    );
    let d = import(&svg).drawing;
    assert_len(&d, 50.0);
    let b = d.bbox().unwrap();
    assert!((b.x0 - 10.0).abs() < 1e-6 && (b.x1 - 60.0).abs() < 1e-6 && (b.y0 - 35.0).abs() < 1e-6, "{b:?}");
}

#[test]
fn masks_cut_to_their_opaque_area() {
    let line = r#"<line x1="0" y1="50" x2="100" y2="50" stroke="black"/>"#;
    // White rect x 20..80 with a black square x 40..50 painted over it: 60 − 10 = 50 mm.
    let svg = mm_doc(&format!(
        r#"<mask id="m" maskUnits="userSpaceOnUse" x="0" y="0" width="100" height="100">
             <rect x="20" y="0" width="60" height="100" fill="white"/>
             <rect x="40" y="40" width="10" height="20" fill="black"/></mask>
           <g mask="url(#m)">{line}</g>"#
    ));
    let imported = import(&svg);
    assert_len(&imported.drawing, 50.0);
    assert!(imported.warnings.is_empty(), "{:?}", imported.warnings);
    // A grey mask is cut at half opacity and reported.
    let grey = mm_doc(&format!(
        r##"<mask id="m" maskUnits="userSpaceOnUse" x="0" y="0" width="100" height="100">
             <rect x="20" y="0" width="60" height="100" fill="#c0c0c0"/></mask><g mask="url(#m)">{line}</g>"##
    ));
    let imported = import(&grey);
    assert_len(&imported.drawing, 60.0);
    assert!(imported.warnings.iter().any(|w| w.contains("partly transparent")), "{:?}", imported.warnings);
}

#[test]
fn occlusion_of_two_overlapping_rectangles() {
    // A: 0..40 outline (fill white), B: 20..60 filled red with an outline, painted after A.
    // A's perimeter 160 mm loses its right edge y 20..40 and bottom edge x 20..40 under B: 160 − 40 = 120.
    // B's perimeter 160 stays. Total 280 mm; without occlusion 320 mm.
    let svg = mm_doc(
        r#"<rect x="0" y="0" width="40" height="40" fill="none" stroke="black"/>
           <rect x="20" y="20" width="40" height="40" fill="red" stroke="black"/>"#,
    );
    assert_len(&import(&svg).drawing, 280.0);
    assert_len(&import_with(&svg, &SvgOptions { occlusion: false, ..SvgOptions::default() }).drawing, 320.0);
    // A translucent fill hides nothing.
    let translucent = svg.replace(r#"fill="red""#, r#"fill="red" fill-opacity="0.5""#);
    assert_len(&import(&translucent).drawing, 320.0);
}

#[test]
fn white_fill_only_shape_masks_a_line_and_is_not_drawn() {
    // A 100 mm line under a white 40 mm wide rectangle: 60 mm stay, the rectangle draws nothing.
    let svg = mm_doc(
        r#"<line x1="0" y1="50" x2="100" y2="50" stroke="black"/>
           <rect x="30" y="0" width="40" height="100" fill="white"/>"#,
    );
    let d = import(&svg).drawing;
    assert_len(&d, 60.0);
    assert_eq!(d.path_count(), 2);
}

/// Where a fill-only shape's outline runs along the edge of an earlier paint of its colour, that edge is drawn once,
/// by the earlier paint's outline (issue 25).
#[test]
fn an_outline_along_an_earlier_edge_of_its_colour_is_drawn_once() {
    // A red rectangle x 0..40, y 0..20, then a red square over its left half, sharing three of its edges: the
    // square draws nothing (its shared edges lie on the rectangle's, its right edge on red), and the rectangle's
    // outline stays whole (the square's fill hides nothing of it that lies on the square's edge): 120 mm.
    let doc = mm_doc(
        r#"<rect x="0" y="0" width="40" height="20" fill="red"/>
           <rect x="0" y="0" width="20" height="20" fill="red"/>"#,
    );
    let imported = import(&doc);
    assert_len(&imported.drawing, 120.0);
    assert!(
        imported.warnings.iter().any(|w| w.contains("1 fill-only shape(s) not outlined")),
        "{:?}",
        imported.warnings
    );
    // The same square on a blue rectangle: its whole outline (80 mm), and the rectangle's 120 mm.
    assert_len(&import(&doc.replacen("red", "blue", 1)).drawing, 200.0);
    // A red square beside the red rectangle, sharing its edge x = 40 from the outside: the square draws its other
    // three sides (60 mm), the rectangle all of its 120 mm.
    let beside = mm_doc(
        r#"<rect x="0" y="0" width="40" height="20" fill="red"/>
           <rect x="40" y="0" width="20" height="20" fill="red"/>"#,
    );
    assert_len(&import(&beside).drawing, 180.0);
    // A white square over the rectangle's left half, on white paper: its edges along the rectangle's outer edges
    // have red on one side (kept), its right edge red on both sides (kept): 80 mm, and the rectangle 120 mm.
    assert_len(&import(&doc.replacen("red", "white", 2).replacen("white", "red", 1)).drawing, 200.0);
}

/// Hidden-line removal takes a fill-only shape's outline before the edge rule does, so the edge rule is asked only
/// about what can be seen (issue 25): a shape buried under a later one is hidden, not "not outlined".
#[test]
fn a_buried_outline_is_hidden_before_the_edge_rule_looks_at_it() {
    let warned = |i: &Imported| i.warnings.iter().any(|w| w.contains("not outlined"));
    // A white 20 mm square on the paper under a black 40 mm square painted later: only the black outline, 160 mm,
    // and no shape reported as matching what lies beneath (nothing of the white one is visible).
    let buried = import(&mm_doc(
        r#"<rect x="10" y="10" width="20" height="20" fill="white"/>
           <rect x="0" y="0" width="40" height="40" fill="black"/>"#,
    ));
    assert_len(&buried.drawing, 160.0);
    assert!(!warned(&buried), "{:?}", buried.warnings);
    // Half buried (the black square x 20..60): the visible half of the white one lies on the paper, so it still
    // draws nothing and is reported; the black square draws its 160 mm.
    let half = import(&mm_doc(
        r#"<rect x="10" y="10" width="20" height="20" fill="white"/>
           <rect x="20" y="0" width="40" height="40" fill="black"/>"#,
    ));
    assert_len(&half.drawing, 160.0);
    assert!(half.warnings.iter().any(|w| w.contains("1 fill-only shape(s) not outlined")), "{:?}", half.warnings);
    // A red square half under a later blue one: the 40 mm of its outline that lie under blue go, the rest (two
    // 10 mm halves of its sides and its 20 mm left side) stays, with the blue square's 160 mm: 200 mm.
    let red = import(&mm_doc(
        r#"<rect x="10" y="10" width="20" height="20" fill="red"/>
           <rect x="20" y="0" width="40" height="40" fill="blue"/>"#,
    ));
    assert_len(&red.drawing, 200.0);
}

/// Fill-only shapes are outlined where their colour differs from what lies beneath (issue 24).
#[test]
fn a_fill_only_shape_draws_its_edge_where_the_colours_differ() {
    let warned = |i: &Imported| i.warnings.iter().any(|w| w.contains("1 fill-only shape(s) not outlined"));
    // A white 20 mm square on a black 60 mm square: both outlines, 240 + 80 mm.
    let on_black = import(&mm_doc(
        r#"<rect x="0" y="0" width="60" height="60" fill="black"/>
           <rect x="20" y="20" width="20" height="20" fill="white"/>"#,
    ));
    assert_len(&on_black.drawing, 320.0);
    assert!(!warned(&on_black), "{:?}", on_black.warnings);
    // On the page alone it draws nothing: with a 7 mm line beside it, only the line, and the shape is reported.
    let alone = import(&mm_doc(
        r#"<rect x="20" y="20" width="20" height="20" fill="white"/>
           <line x1="0" y1="90" x2="7" y2="90" stroke="black"/>"#,
    ));
    assert_len(&alone.drawing, 7.0);
    assert!(warned(&alone), "{:?}", alone.warnings);
    let err = import_svg(
        mm_doc(r##"<rect x="20" y="20" width="20" height="20" fill="#fff"/>"##).as_bytes(),
        "w.svg",
        &ResourcePolicy::DataUrlsOnly,
        &SvgOptions::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(err.contains("nothing to draw") && err.contains("not outlined"), "{err}");
    // Straddling the bottom edge of a black 40 × 20 rectangle: the white square x 10..30, y 10..30 draws its top
    // (20 mm) and its sides down to y = 20 (2 × 10 mm); the rectangle loses the 20 mm of its bottom edge under the
    // square (120 − 20). Total 140 mm.
    let straddle = mm_doc(
        r#"<rect x="0" y="0" width="40" height="20" fill="black"/>
           <rect x="10" y="10" width="20" height="20" fill="white"/>"#,
    );
    assert_len(&import(&straddle).drawing, 140.0);
    // The same with a red square on a red rectangle: the square's edge is drawn over the paper instead, its bottom
    // and lower sides (20 + 2 × 10 mm), again 140 mm; on a blue rectangle, its whole outline: 100 + 80 mm.
    let red = straddle.replace("black", "red").replace("white", "#f00");
    assert_len(&import(&red).drawing, 140.0);
    assert_len(&import(&straddle.replace("black", "blue").replace("white", "red")).drawing, 180.0);
    // Red inside red draws only the outer outline; a later black square between them separates the colours.
    let nested = mm_doc(
        r#"<rect x="0" y="0" width="60" height="60" fill="red"/>
           <rect x="20" y="20" width="20" height="20" fill="red"/>"#,
    );
    assert_len(&import(&nested).drawing, 240.0);
    let between = nested.replace(
        r#"<rect x="20" y="20""#,
        r#"<rect x="10" y="10" width="40" height="40" fill="black"/><rect x="20" y="20""#,
    );
    assert_len(&import(&between).drawing, 240.0 + 160.0 + 80.0);
    // The paper's colour is the option's: on yellow paper a yellow square draws nothing and a white one its edge.
    let yellow = SvgOptions { paper_color: Rgb(255, 255, 0), ..SvgOptions::default() };
    let doc = |fill: &str| {
        mm_doc(&format!(
            r#"<rect x="20" y="20" width="20" height="20" fill="{fill}"/>
               <line x1="0" y1="90" x2="7" y2="90" stroke="black"/>"#
        ))
    };
    assert_len(&import_with(&doc("yellow"), &yellow).drawing, 7.0);
    assert_len(&import_with(&doc("white"), &yellow).drawing, 87.0);
}

#[test]
fn a_fill_under_half_opacity_hides_nothing() {
    // A 100 mm line under a black 40 mm square at 30 % opacity: the line stays whole, plus the square's 160 mm.
    let doc = |opacity: &str| {
        mm_doc(&format!(
            r#"<line x1="0" y1="50" x2="100" y2="50" stroke="black"/>
               <rect x="30" y="30" width="40" height="40" fill="black" fill-opacity="{opacity}"/>"#
        ))
    };
    assert_len(&import(&doc("0.3")).drawing, 260.0);
    // At 60 % (here the element's opacity) or 75 % it hides the 40 mm under it.
    assert_len(&import(&doc("1").replace("<rect ", r#"<rect opacity="0.6" "#)).drawing, 220.0);
    assert_len(&import(&doc("0.75")).drawing, 220.0);
}

#[test]
fn a_white_shape_on_a_faint_shadow_is_outlined_where_it_lies_on_it() {
    // A 25 % black 40 × 20 rectangle (light grey on the paper; its outline, 120 mm, is drawn as any fill's) and a
    // white square x 10..30, y 10..30 straddling its bottom edge: the browser shows the square's edge over the
    // grey, so its top (20 mm) and its sides down to y = 20 (2 × 10 mm) are drawn; below, white on white, nothing.
    // The opaque square hides the 20 mm of the shadow's bottom edge under it: 120 − 20 + 40 = 140 mm (before the
    // shadow counted as a colour, the square drew nothing: 100 mm).
    let shadow = mm_doc(
        r#"<rect x="0" y="0" width="40" height="20" fill="black" fill-opacity="0.25"/>
           <rect x="10" y="10" width="20" height="20" fill="white"/>"#,
    );
    assert_len(&import(&shadow).drawing, 140.0);
    // A tint never takes an edge away: over a black 40 mm square (160 mm), a 25 % white tint x, y 5..35 (its 120 mm
    // outline shows, light grey on black) and a white square 10..30 on it (80 mm, white on dark grey): 360 mm.
    let over_black = mm_doc(
        r#"<rect x="0" y="0" width="40" height="40" fill="black"/>
           <rect x="5" y="5" width="30" height="30" fill="white" fill-opacity="0.25"/>
           <rect x="10" y="10" width="20" height="20" fill="white"/>"#,
    );
    assert_len(&import(&over_black).drawing, 360.0);
    // A white tint on the paper stays paper-coloured: the square over it draws nothing, nor does the tint.
    let tint = shadow.replace(r#"fill="black""#, r#"fill="white""#);
    let err = import_svg(tint.as_bytes(), "t.svg", &ResourcePolicy::DataUrlsOnly, &SvgOptions::default())
        .unwrap_err()
        .to_string();
    assert!(err.contains("nothing to draw"), "{err}");
}

/// Pen-down length of the part of a circle (centre at distance `d` from `c`, radius `r`) inside the circle of
/// radius `big` around `c`: the points at angle φ from the direction towards `c` lie within `big` when
/// d² + r² − 2dr·cos φ ≤ big², so the inside arc spans 2·acos((d² + r² − big²) / 2dr).
fn arc_inside(d: f64, r: f64, big: f64) -> f64 {
    if d + r <= big {
        return 2.0 * std::f64::consts::PI * r;
    }
    if d - r >= big {
        return 0.0;
    }
    2.0 * r * ((d * d + r * r - big * big) / (2.0 * d * r)).clamp(-1.0, 1.0).acos()
}

#[test]
fn pattern_dots_are_tiled_and_clipped_to_their_shape() {
    // 5 mm dots (r 2.5) centred in 6 mm tiles from the origin, filling a 20 mm circle (r 10) at (50, 50).
    let svg = mm_doc(
        r#"<defs><pattern id="dots" patternUnits="userSpaceOnUse" width="6" height="6">
              <circle cx="3" cy="3" r="2.5" fill="black"/></pattern></defs>
           <circle cx="50" cy="50" r="10" fill="url(#dots)"/>"#,
    );
    let fine = SvgOptions { tolerance_mm: 0.001, ..SvgOptions::default() };
    let imported = import_with(&svg, &fine);
    // (At this tolerance, only the note that usvg's arcs are within 0.003 mm.)
    assert!(imported.warnings.iter().all(|w| w.contains("arcs/circles")), "{:?}", imported.warnings);
    let d = imported.drawing;
    // From the geometry: every dot centre (3 + 6i, 3 + 6j), whole when within 7.5 mm of the centre, cut when
    // within 12.5 mm.
    let (mut whole, mut cut_dots, mut length) = (0, 0, 0.0);
    for i in 0..20 {
        for j in 0..20 {
            let c = Point::new(3.0 + 6.0 * f64::from(i), 3.0 + 6.0 * f64::from(j));
            let dist = c.distance(Point::new(50.0, 50.0));
            length += arc_inside(dist, 2.5, 10.0);
            if dist + 2.5 <= 10.0 {
                whole += 1;
            } else if dist - 2.5 < 10.0 {
                cut_dots += 1;
            }
        }
    }
    // By hand, centre offsets from (50, 50) on each axis are −11, −5, 1, 7, 13: whole (≤ 7.5 mm) are (1,1),
    // (−5,1), (1,−5), (7,1), (1,7), (−5,−5); cut (< 12.5 mm) are (−5,7), (7,−5), (7,7), (−11,1), (1,−11),
    // (−11,−5), (−5,−11).
    assert_eq!((whole, cut_dots), (6, 7));
    let closed = d.paths().filter(|p| p.is_closed()).count();
    assert_eq!(closed, whole, "every whole dot is one closed line");
    let got = pen_down(&d);
    // usvg's cubic circles lie up to 2.7e-4 of the radius outside the true circle, so lengths agree to that.
    assert!((got - length).abs() < 3e-4 * length, "pen-down {got} mm, expected {length} mm");
    // Nothing outside the circle.
    assert!(d.paths().flat_map(|p| &p.points).all(|q| q.distance(Point::new(50.0, 50.0)) <= 10.0 + 0.003));
    // Tiles finer than the pen (0.125 mm < 0.3 mm) are not drawn, with the count of tiles over the shape's box
    // (x and y 40.3 .. 60.3: tiles 322 ..= 482, 161 each way).
    let tiny = mm_doc(
        r#"<defs><pattern id="fine" patternUnits="userSpaceOnUse" width="0.125" height="0.125">
              <circle cx="0.0625" cy="0.0625" r="0.05" fill="black"/></pattern></defs>
           <circle cx="50.3" cy="50.3" r="10" fill="url(#fine)"/>
           <line x1="0" y1="90" x2="7" y2="90" stroke="black"/>"#,
    );
    let imported = import(&tiny);
    assert_len(&imported.drawing, 7.0);
    assert!(
        imported.warnings.iter().any(|w| w.contains("pattern \"fine\"") && w.contains("25921 tile(s)")),
        "{:?}",
        imported.warnings
    );
}

#[test]
fn wide_opaque_stroke_hides_what_lies_under_it() {
    // A 100 mm line at y = 50 under a vertical 10 mm wide black stroke x = 50, y 0..100 (butt caps: the outline
    // is the rectangle x 45..55): the line keeps 45 + 45 mm, the stroke's centre line 100 mm stays. Total 190 mm.
    let svg = mm_doc(
        r#"<line x1="0" y1="50" x2="100" y2="50" stroke="black" stroke-width="0.3"/>
           <line x1="50" y1="0" x2="50" y2="100" stroke="black" stroke-width="10"/>"#,
    );
    let d = import(&svg).drawing;
    assert_len(&d, 190.0);
    assert_eq!(d.path_count(), 3);
    assert_len(&import_with(&svg, &SvgOptions { occlusion: false, ..SvgOptions::default() }).drawing, 200.0);
    // Not wider than four pen widths (1.2 mm with the 0.3 mm pen), or translucent, it hides nothing.
    assert_len(&import(&svg.replace(r#"stroke-width="10""#, r#"stroke-width="1.1""#)).drawing, 200.0);
    assert_len(
        &import(&svg.replace(r#"stroke-width="10""#, r#"stroke-width="10" stroke-opacity="0.9""#)).drawing,
        200.0,
    );
    // A wider pen raises the bar: 10 mm is less than four 3 mm pens.
    assert_len(&import_with(&svg, &SvgOptions { pen_width_mm: 3.0, ..SvgOptions::default() }).drawing, 200.0);
}

#[test]
fn a_gradient_is_paper_only_when_every_stop_is_the_paper_colour() {
    // The 100 mm line under a 40 mm wide fill-only rectangle painted with a gradient.
    let doc = |stops: &str| {
        mm_doc(&format!(
            r#"<defs><linearGradient id="g">{stops}</linearGradient></defs>
               <line x1="0" y1="50" x2="100" y2="50" stroke="black"/>
               <rect x="30" y="0" width="40" height="100" fill="url(#g)"/>"#
        ))
    };
    // White to white: paper. It hides 40 mm of the line and draws nothing.
    let white = doc(r##"<stop offset="0" stop-color="white"/><stop offset="1" stop-color="#ffffff"/>"##);
    assert_len(&import(&white).drawing, 60.0);
    // White to black: visible ink. It hides the same 40 mm and is outlined (2 × 40 + 2 × 100 = 280 mm).
    let shaded = doc(r#"<stop offset="0" stop-color="white"/><stop offset="1" stop-color="black"/>"#);
    assert_len(&import(&shaded).drawing, 60.0 + 280.0);
}

#[test]
fn pens_with_a_hatch_shade_their_layers_fills() {
    // Two 20 × 20 squares: red at (10, 10.5), blue at (50, 10.5). Only the red pen has a hatch (1 mm, 0°):
    // 20 lines of 20 mm linked by 19 × 1 mm, as in `hatch_of_a_square`, plus both 80 mm outlines.
    let svg = mm_doc(
        r#"<rect x="10" y="10.5" width="20" height="20" fill="red"/>
           <rect x="50" y="10.5" width="20" height="20" fill="blue"/>"#,
    );
    let pen = |name: &str, color: &str, hatch| crate::config::profile::PenSpec {
        name: name.into(),
        color: Some(color.into()),
        width_mm: None,
        down_z_mm: None,
        servo_down_deg: None,
        draw_feed_mm_s: None,
        hatch,
    };
    let red_hatch = crate::config::profile::PenHatch { spacing_mm: 1.0, angle_deg: 0.0, cross: false, tone: false };
    let options = SvgOptions {
        layer_by: LayerBy::Color,
        pens: vec![pen("red gel", "#ff0000", Some(red_hatch)), pen("blue", "#0000ff", None)],
        ..SvgOptions::default()
    };
    let d = import_with(&svg, &options).drawing;
    let layer = |name: &str| d.layers.iter().find(|l| l.name == name).unwrap();
    assert_len(&Drawing { layers: vec![layer("#ff0000").clone()], page_mm: None }, 80.0 + 400.0 + 19.0);
    assert_len(&Drawing { layers: vec![layer("#0000ff").clone()], page_mm: None }, 80.0);
    // `--hatch` sets one hatch for every layer and wins over the table.
    let all = FillHatch { spacing_mm: 2.0, angle_deg: 0.0, cross: false, link: false };
    let d = import_with(&svg, &SvgOptions { hatch: Some(all), ..options }).drawing;
    // 2 mm spacing: lines y = 12, 14 … 30 (10 lines of 20 mm) per square, unlinked.
    assert_len(&d, 2.0 * (80.0 + 200.0));
}

#[test]
fn hatch_of_a_square() {
    // Square 20 × 20 at (10, 10.5): horizontal hatch at 1 mm spacing on lines y = 11 … 30 (20 lines of 20 mm),
    // linked into one zig-zag by 19 connectors of 1 mm along the sides, plus the 80 mm outline: 499 mm.
    let svg = mm_doc(r#"<rect x="10" y="10.5" width="20" height="20" fill="black"/>"#);
    let hatch = FillHatch { spacing_mm: 1.0, angle_deg: 0.0, cross: false, link: true };
    let d = import_with(&svg, &SvgOptions { hatch: Some(hatch), ..SvgOptions::default() }).drawing;
    assert_len(&d, 80.0 + 400.0 + 19.0);
    assert_eq!(d.path_count(), 2, "outline + one zig-zag");
    // A hole (even-odd) is left empty: 10 × 10 hole at (15, 15.5) removes 10 lines × 10 mm.
    let holed =
        mm_doc(r#"<path fill-rule="evenodd" fill="black" d="M10 10.5 h20 v20 h-20 Z M15 15.5 h10 v10 h-10 Z"/>"#);
    let d =
        import_with(&holed, &SvgOptions { hatch: Some(FillHatch { link: false, ..hatch }), ..SvgOptions::default() })
            .drawing;
    assert_len(&d, 80.0 + 40.0 + 400.0 - 100.0);
}

#[test]
fn dashes_are_separate_strokes() {
    // 100 mm, dasharray 10 5: dashes at 0, 15, …, 90 → 7 dashes, 70 mm.
    let svg = mm_doc(r#"<line x1="0" y1="5" x2="100" y2="5" stroke="black" stroke-dasharray="10 5"/>"#);
    let d = import(&svg).drawing;
    assert_eq!(d.path_count(), 7);
    assert_len(&d, 70.0);
    // Offset 5: dash 0..5, then 10..20, 25..35, 40..50, 55..65, 70..80, 85..95: 5 + 6 × 10 = 65 mm.
    let offset = svg.replace(r#"stroke-dasharray="10 5""#, r#"stroke-dasharray="10 5" stroke-dashoffset="5""#);
    let d = import(&offset).drawing;
    assert_eq!(d.path_count(), 7);
    assert_len(&d, 65.0);
}

#[test]
fn fully_transparent_shapes_are_skipped_with_a_warning() {
    let svg = mm_doc(
        r#"<line x1="0" y1="5" x2="10" y2="5" stroke="black" opacity="0"/>
           <rect x="0" y="10" width="10" height="10" fill="black" fill-opacity="0"/>
           <g opacity="0"><line x1="0" y1="30" x2="50" y2="30" stroke="black"/></g>
           <rect x="50" y="50" width="10" height="10" fill="black" stroke="black" stroke-opacity="0"/>
           <line x1="0" y1="90" x2="25" y2="90" stroke="black"/>"#,
    );
    let imported = import(&svg);
    // Only the last line (25) and the filled square's outline (40; its stroke is transparent) are drawn.
    assert_len(&imported.drawing, 65.0);
    assert!(imported.warnings.iter().any(|w| w.contains("3 fully transparent shape(s)")), "{:?}", imported.warnings);
}

#[test]
fn off_page_geometry_is_reported_and_cropped() {
    let svg = mm_doc(r#"<line id="long" x1="50" y1="50" x2="150" y2="50" stroke="black"/>"#);
    let imported = import(&svg);
    assert_len(&imported.drawing, 100.0);
    let w = imported.warnings.join("\n");
    assert!(w.contains("50.0 mm of pen-down lines in 1 element(s) (<path id=\"long\">)"), "{w}");
    let cropped = import_with(&svg, &SvgOptions { crop: true, ..SvgOptions::default() });
    assert_len(&cropped.drawing, 50.0);
}

/// Issue 22, item 11 (nothing dropped silently): a crop that removes every line is an error naming why — the
/// 30 mm line lies wholly beyond the 100 mm page — not an empty drawing; without the crop the line is kept.
#[test]
fn a_crop_that_removes_everything_is_an_error_naming_why() {
    let svg = mm_doc(r#"<line id="away" x1="120" y1="50" x2="150" y2="50" stroke="black"/>"#);
    assert_len(&import(&svg).drawing, 30.0);
    let crop = SvgOptions { crop: true, ..SvgOptions::default() };
    let err = import_svg(svg.as_bytes(), "t.svg", &ResourcePolicy::DataUrlsOnly, &crop).unwrap_err();
    assert!(matches!(err, SvgError::Empty { .. }), "{err:?}");
    assert_eq!(
        err.to_string(),
        "t.svg: nothing to draw: no visible shapes (t.svg: 30.0 mm of pen-down lines in 1 element(s) (<path \
         id=\"away\">) were cut at the page edge (--crop) (100.0 × 100.0 mm))"
    );
}

#[test]
fn single_stroke_text() {
    // Hershey Roman Simplex "L": stem from y −12 to 9 (21 units) and foot from x −6 to 6 (12 units), 33 units.
    // font-size 32 mm = 32 Hershey units per em, so one unit is 1 mm: 33 mm of pen-down lines in 2 strokes.
    let svg = mm_doc(r#"<text x="10" y="50" font-family="sans-serif" font-size="32">L</text>"#);
    let opts = SvgOptions { text: TextMode::SingleStroke, ..SvgOptions::default() };
    let result = import_svg(svg.as_bytes(), "t.svg", &ResourcePolicy::DataUrlsOnly, &opts);
    let mut db = usvg::fontdb::Database::new();
    db.load_system_fonts();
    if db.is_empty() {
        return; // no font to lay text out with: covered by text_becomes_glyph_outlines_or_warns_without_fonts
    }
    let imported = result.unwrap();
    if hershey::HersheyFont::load_default().is_err() {
        assert!(imported.warnings.iter().any(|w| w.contains("hershey-fonts-data")), "{:?}", imported.warnings);
        return;
    }
    assert_eq!(imported.drawing.path_count(), 2);
    assert_len(&imported.drawing, 33.0);
    // The baseline sits at y = 50, the cap line 21 mm above; the glyph's left bound (x = −10) is at the origin
    // x = 10, so the stem (x = −6) is at 14 mm and the foot ends at 14 + 12 = 26 mm.
    let b = imported.drawing.bbox().unwrap();
    assert!((b.y1 - 50.0).abs() < 1e-3 && (b.y0 - 29.0).abs() < 1e-3, "{b:?}");
    assert!((b.x0 - 14.0).abs() < 1e-3 && (b.x1 - 26.0).abs() < 1e-3, "{b:?}");
}

/// Standard base64 (for data URIs in tests).
fn base64(data: &[u8]) -> String {
    const T: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in data.chunks(3) {
        let b = [chunk[0], *chunk.get(1).unwrap_or(&0), *chunk.get(2).unwrap_or(&0)];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for i in 0..4 {
            if i <= chunk.len() {
                out.push(char::from(T[((n >> (18 - 6 * i)) & 63) as usize]));
            } else {
                out.push('=');
            }
        }
    }
    out
}

#[test]
fn embedded_png_is_traced_in_place() {
    // 20 × 20 px white PNG with a black 10 × 10 px square at (5, 5), shown 20 × 20 mm at (30, 40): one pixel is
    // 1 mm. The outline tracer runs between pixel centres, so the square's edges lie on its pixel edges (x 35..45,
    // y 45..55) and each corner is cut by the diagonal between the midpoints next to it: 40 mm of edges lose
    // 4 × 1 mm and gain 4 × √½ mm.
    let img = image::GrayImage::from_fn(20, 20, |x, y| {
        image::Luma([if (5..15).contains(&x) && (5..15).contains(&y) { 0 } else { 255 }])
    });
    let mut png = Vec::new();
    image::DynamicImage::ImageLuma8(img)
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .unwrap();
    let svg = mm_doc(&format!(
        r#"<image x="30" y="40" width="20" height="20" xlink:href="data:image/png;base64,{}"/>"#,
        base64(&png)
    ));
    let skipped = import_svg(svg.as_bytes(), "i.svg", &ResourcePolicy::DataUrlsOnly, &SvgOptions::default())
        .unwrap_err()
        .to_string();
    assert!(skipped.contains("embedded raster image not traced"), "{skipped}");
    let opts = SvgOptions {
        images: Some(ImageTrace { trace: crate::input::raster::TraceOptions::default() }),
        ..SvgOptions::default()
    };
    let d = import_with(&svg, &opts).drawing;
    assert_len(&d, 40.0 - 4.0 + 4.0 * 0.5f64.sqrt());
    let b = d.bbox().unwrap();
    // usvg's image transform is f32: a few µm of rounding.
    assert!((b.x0 - 35.0).abs() < 1e-5 && (b.y0 - 45.0).abs() < 1e-5 && (b.x1 - 45.0).abs() < 1e-5, "{b:?}");
}

#[test]
fn paths_carry_their_own_colour_and_width() {
    let svg = mm_doc(
        r#"<line x1="0" y1="5" x2="10" y2="5" stroke="red" stroke-width="2"/>
           <line x1="0" y1="9" x2="10" y2="9" stroke="blue" stroke-width="0.5"/>"#,
    );
    let d = import(&svg).drawing;
    let pens: Vec<Pen> = d.paths().map(|p| p.pen.unwrap()).collect();
    assert_eq!(pens[0], Pen { color: Rgb(255, 0, 0), width_mm: 2.0 });
    assert_eq!(pens[1], Pen { color: Rgb(0, 0, 255), width_mm: 0.5 });
}

mod properties {
    use super::*;
    use proptest::prelude::*;

    /// Even-odd point-in-polygon on the original polygon (independent of the region code).
    fn inside(poly: &[(f64, f64)], p: Point) -> bool {
        let mut c = false;
        for i in 0..poly.len() {
            let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
            if (a.1 > p.y) != (b.1 > p.y) && p.x < a.0 + (p.y - a.1) * (b.0 - a.0) / (b.1 - a.1) {
                c = !c;
            }
        }
        c
    }

    fn dist_to_polygon(poly: &[(f64, f64)], p: Point) -> f64 {
        (0..poly.len())
            .map(|i| {
                let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
                let seg = kurbo::Line::new(a, b);
                kurbo::ParamCurveNearest::nearest(&seg, p, 1e-12).distance_sq.sqrt()
            })
            .fold(f64::INFINITY, f64::min)
    }

    fn star() -> impl Strategy<Value = Vec<(f64, f64)>> {
        (prop::collection::vec(5.0..45.0f64, 5..12), 30.0..70.0f64, 30.0..70.0f64).prop_map(|(radii, cx, cy)| {
            let n = radii.len() as f64;
            radii
                .iter()
                .enumerate()
                .map(|(i, r)| {
                    let a = i as f64 / n * std::f64::consts::TAU;
                    (cx + r * a.cos(), cy + r * a.sin())
                })
                .collect()
        })
    }

    fn lines() -> impl Strategy<Value = Vec<[(f64, f64); 2]>> {
        prop::collection::vec(((0.0..100.0f64, 0.0..100.0f64), (0.0..100.0f64, 0.0..100.0f64)), 1..6)
            .prop_map(|v| v.into_iter().map(|(a, b)| [a, b]).collect())
    }

    fn poly_attr(poly: &[(f64, f64)]) -> String {
        poly.iter().map(|(x, y)| format!("{x},{y}")).collect::<Vec<_>>().join(" ")
    }

    fn line_elems(ls: &[[(f64, f64); 2]]) -> String {
        ls.iter()
            .map(|[a, b]| format!(r#"<line x1="{}" y1="{}" x2="{}" y2="{}" stroke="black"/>"#, a.0, a.1, b.0, b.1))
            .collect()
    }

    /// usvg keeps coordinates in f32: allow its rounding (1e-5 mm at 100 mm) plus the cut's grid.
    const EPS: f64 = 1e-4;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        #[test]
        fn no_clipped_point_lies_outside_its_clip(poly in star(), ls in lines()) {
            let svg = mm_doc(&format!(
                r#"<clipPath id="c"><polygon points="{}"/></clipPath><g clip-path="url(#c)">{}</g>"#,
                poly_attr(&poly), line_elems(&ls)
            ));
            let Ok(imported) = import_svg(svg.as_bytes(), "p.svg", &ResourcePolicy::DataUrlsOnly, &SvgOptions::default()) else {
                return Ok(()); // every line missed the clip: nothing to draw
            };
            for path in imported.drawing.paths() {
                for w in path.points.windows(2) {
                    for p in [w[0], w[1], w[0].midpoint(w[1])] {
                        prop_assert!(inside(&poly, p) || dist_to_polygon(&poly, p) < EPS, "{p:?} outside the clip");
                    }
                }
            }
        }

        #[test]
        fn no_pen_down_point_strictly_inside_a_later_opaque_fill(poly in star(), ls in lines()) {
            let svg = mm_doc(&format!(r#"{}<polygon points="{}" fill="green"/>"#, line_elems(&ls), poly_attr(&poly)));
            let imported = import_svg(svg.as_bytes(), "p.svg", &ResourcePolicy::DataUrlsOnly, &SvgOptions::default()).unwrap();
            // The polygon's own outline is the last path; every earlier one was a line under it.
            let paths: Vec<&Polyline> = imported.drawing.paths().collect();
            let polygon_len: f64 = (0..poly.len())
                .map(|i| Point::from(poly[i]).distance(Point::from(poly[(i + 1) % poly.len()])))
                .sum();
            let (lines_part, outline) = paths.split_at(paths.len() - 1);
            prop_assert!((outline[0].length() - polygon_len).abs() < 1e-3);
            for path in lines_part {
                for w in path.points.windows(2) {
                    for p in [w[0], w[1], w[0].midpoint(w[1])] {
                        prop_assert!(!inside(&poly, p) || dist_to_polygon(&poly, p) < EPS, "{p:?} is hidden");
                    }
                }
            }
        }
    }
}

#[test]
fn wide_strokes_filled_with_pen_wide_passes() {
    // A 10 mm line at y = 5.25, 2 mm wide (butt caps): its ink is the rectangle x 0..10, y 4.25..6.25. With a
    // 0.5 mm pen and passes at angle 0, the passes lie on y = 4.5, 5.0, 5.5, 6.0 (4 × 10 mm), linked by 3 × 0.5 mm,
    // plus the 10 mm centre line: 51.5 mm.
    let svg = mm_doc(r#"<line x1="0" y1="5.25" x2="10" y2="5.25" stroke="black" stroke-width="2"/>"#);
    let opts = SvgOptions { fill_strokes: Some(FillStrokes { pen_mm: 0.5, angle_deg: 0.0 }), ..SvgOptions::default() };
    assert_len(&import_with(&svg, &opts).drawing, 51.5);
    // Strokes no wider than 1.5 pens are left as their centre line.
    let thin = svg.replace(r#"stroke-width="2""#, r#"stroke-width="0.7""#);
    assert_len(&import_with(&thin, &opts).drawing, 10.0);
}

#[test]
fn far_geometry_is_cut_at_one_km_and_the_rest_kept() {
    // A stray segment from (10, 0) mm to 10¹² mm east beside a 40 mm line: the stray part keeps 10 → 10⁶ mm.
    let svg = mm_doc(
        r#"<path id="stray" d="M10 0 L1e12 0" stroke="black"/>
           <line x1="0" y1="50" x2="40" y2="50" stroke="black"/>"#,
    );
    let imported = import(&svg);
    assert_len(&imported.drawing, 40.0 + (1.0e6 - 10.0));
    let w = imported.warnings.iter().find(|w| w.contains("1 km")).expect("a warning");
    assert!(w.contains(r#"1 element(s) (<path id="stray">)"#), "{w}");
    // With --crop it is then cut at the page too: 90 mm of the stray line stay.
    let cropped = import_with(&svg, &SvgOptions { crop: true, ..SvgOptions::default() });
    assert_len(&cropped.drawing, 40.0 + 90.0);
}

#[test]
fn an_empty_file_says_so() {
    for (data, expected) in
        [("", "the file is empty (0 bytes)"), ("  \n\t", "the file is empty (4 bytes, all white space)")]
    {
        let e = import_svg(data.as_bytes(), "e.svg", &ResourcePolicy::DataUrlsOnly, &SvgOptions::default())
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("e.svg: ") && e.contains(expected), "{e}");
    }
}

/// Issue 22: hostile files, each built here, end in a clear error or a bounded result (the limits behind them are
/// tested in their own modules: dtd, attributes, resources).
mod hostile {
    use super::*;

    fn parse_error(data: &[u8]) -> String {
        match import_svg(data, "h.svg", &ResourcePolicy::DataUrlsOnly, &SvgOptions::default()) {
            Err(e @ SvgError::Parse { .. }) => e.to_string(),
            other => panic!("expected a parse error, got {other:?}"),
        }
    }

    /// Item 2: the three ways round the old entity guard, in a whole import (65 references to 1 MiB each).
    #[test]
    fn entity_guard_bypasses_are_refused() {
        let value = "x".repeat(1 << 20);
        let body = |name: &str| {
            format!("<svg xmlns=\"http://www.w3.org/2000/svg\"><text>{}</text></svg>", format!("&{name};").repeat(65))
        };
        for doc in [
            format!("<!DOCTYPE svg [<!-- ]> --><!ENTITY b \"{value}\">]>{}", body("b")),
            format!("<!-- <!DOCTYPE x []> --><!DOCTYPE svg [<!ENTITY b \"{value}\">]>{}", body("b")),
            format!("<!DOCTYPE svg [<!ENTITY b·c \"{value}\">]>{}", body("b·c")),
        ] {
            let err = parse_error(doc.as_bytes());
            assert!(
                err.starts_with("h.svg: not a valid SVG document: entity references expand to more than 64 MiB"),
                "{err}"
            );
        }
    }

    /// Item 4: 200 000 attributes on one element (2.3 MB) are refused before any parser sees them.
    #[test]
    fn an_element_with_200k_attributes_is_refused() {
        let attrs: String = (0..200_000).map(|i| format!(" a{i}=\"1\"")).collect();
        let doc = format!("<svg xmlns=\"http://www.w3.org/2000/svg\">\n<rect{attrs}/></svg>");
        let err = parse_error(doc.as_bytes());
        assert_eq!(err, "h.svg: not a valid SVG document: <rect> at line 2 has more than 256 attributes (200000)");
    }

    /// Item 12c: a page of 10²⁰ mm is refused before usvg works on it, and a stroke scaled to 10¹⁰ mm is drawn
    /// as its centre line (cut at 1 km) without outlining it (that took 900 MB).
    #[test]
    fn absurd_sizes_are_refused_or_bounded() {
        let page = r#"<svg xmlns="http://www.w3.org/2000/svg" width="1e20mm" height="1e20mm" viewBox="0 0 10 10"><circle cx="5" cy="5" r="4" fill="none" stroke="black"/></svg>"#;
        assert_eq!(
            parse_error(page.as_bytes()),
            "h.svg: not a valid SVG document: <svg> width=\"1e20mm\" at line 1 is 1.000e20 mm, beyond the 1000000 mm \
             (1 km) limit; check the units"
        );
        let scaled = r#"<svg xmlns="http://www.w3.org/2000/svg" width="1000mm" height="1000mm" viewBox="0 0 10 10"><g transform="scale(1e10)"><circle cx="5" cy="5" r="4" fill="none" stroke="black"/></g><line x1="1" y1="1" x2="2" y2="1" stroke="black" stroke-width="0.01"/></svg>"#;
        let imported =
            import_svg(scaled.as_bytes(), "h.svg", &ResourcePolicy::DataUrlsOnly, &SvgOptions::default()).unwrap();
        assert!(
            imported.warnings.iter().any(|w| w.contains("1 wide stroke(s) reach beyond ±1000000 mm (1 km)")),
            "{:?}",
            imported.warnings
        );
        // The small line survives, 1 user unit = 100 mm long.
        assert!(
            imported.drawing.paths().any(|p| (p.points[0].distance(p.points[p.points.len() - 1]) - 100.0).abs() < 1e-6)
        );
    }
}

/// Three overlapping white discs outlined in black: each later disc hides part of the outlines before it.
const DISCS: &str = r#"<svg xmlns="http://www.w3.org/2000/svg" width="100mm" height="100mm" viewBox="0 0 100 100">
  <circle cx="30" cy="50" r="15" fill="white" stroke="black"/>
  <circle cx="45" cy="50" r="15" fill="white" stroke="black"/>
  <circle cx="60" cy="50" r="15" fill="white" stroke="black"/>
</svg>"#;

#[test]
fn a_cancelled_import_ends_with_its_typed_error_and_each_check_stops_its_stage() {
    let cancel = crate::geometry::cancel::Cancel::new();
    let opts = SvgOptions { cancel: cancel.clone(), ..SvgOptions::default() };
    // Not cancelled: the same drawing as without a flag.
    assert_eq!(import_with(DISCS, &opts), import_with(DISCS, &SvgOptions::default()));
    cancel.cancel();
    match import_svg(DISCS.as_bytes(), "discs.svg", &ResourcePolicy::DataUrlsOnly, &opts) {
        Err(e @ SvgError::Cancelled { .. }) => {
            assert_eq!(e.to_string(), "discs.svg: import cancelled (the drawing was no longer wanted)");
        }
        other => panic!("{other:?}"),
    }
    // The checks inside the stages: a cancelled walk collects no element, and hidden-line removal cancelled
    // before its first item cuts none (uncancelled, it cuts the first two outlines).
    let tree = usvg::Tree::from_str(DISCS, &usvg::Options::default()).unwrap();
    let groups = HashMap::new();
    let mut walker = walk::Walker::new(&opts, &groups, "discs.svg");
    walker.walk_root(tree.root(), Affine::IDENTITY);
    assert!(walker.items.is_empty());
    let open = SvgOptions::default();
    let mut walker = walk::Walker::new(&open, &groups, "discs.svg");
    walker.walk_root(tree.root(), Affine::IDENTITY);
    assert_eq!(walker.items.len(), 3);
    let mut items = std::mem::take(&mut walker.items);
    assert_eq!(occlude::occlude(&mut items, &cancel), 0);
    assert_eq!(occlude::occlude(&mut items, &crate::geometry::cancel::Cancel::never()), 2);
}

#[test]
fn the_skipped_summary_counts_each_item_left_out_with_its_reason() {
    // One drawn line beside: a white square on the paper (no edge), two invisible rects (no paint; display:none),
    // a transparent circle, an image (not traced: images off by default), a foreignObject, a zero-width rect and a
    // pattern finer than the pen.
    let svg = mm_doc(
        r#"<defs><pattern id="fine" patternUnits="userSpaceOnUse" width="0.125" height="0.125">
              <circle cx="0.0625" cy="0.0625" r="0.05" fill="black"/></pattern></defs>
           <line x1="0" y1="90" x2="7" y2="90" stroke="black"/>
           <rect x="10" y="10" width="20" height="20" fill="white"/>
           <rect x="40" y="10" width="5" height="5" fill="none"/>
           <rect x="50" y="10" width="5" height="5" fill="black" style="display:none"/>
           <circle cx="70" cy="20" r="5" fill="black" opacity="0"/>
           <image x="0" y="40" width="4" height="4" href="data:image/png;base64,iVBORw0KGgo="/>
           <foreignObject x="0" y="50" width="10" height="10"/>
           <rect x="20" y="50" width="0" height="10" fill="black"/>
           <circle cx="50" cy="60" r="5" fill="url(#fine)"/>"#,
    );
    let imported = import(&svg);
    assert_len(&imported.drawing, 7.0);
    let s = &imported.skipped;
    assert_eq!(s.count(SkipReason::SameColourFill), 1, "{s}");
    assert_eq!(s.count(SkipReason::Transparent), 1, "{s}");
    assert_eq!(s.count(SkipReason::ImageNotTraced), 1, "{s}");
    assert_eq!(s.count(SkipReason::UnsupportedElement), 1, "{s}");
    assert_eq!(s.count(SkipReason::DegenerateShape), 1, "{s}");
    assert_eq!(s.count(SkipReason::PatternTooFine), 1, "{s}");
    // usvg drops display:none before the walk; the fill="none" rect is the one invisible shape it keeps.
    assert_eq!(s.count(SkipReason::Invisible), 1, "{s}");
    assert_eq!(s.total(), 7, "{s}");
    // A drawing with nothing left out says so.
    let plain = import(&mm_doc(r#"<line x1="0" y1="90" x2="7" y2="90" stroke="black"/>"#));
    assert!(plain.skipped.is_empty(), "{}", plain.skipped);
}

/// Hatched blends are outlined at their own edge only, with `--hatch SPACING` too. Three opaque greys, each 6 of
/// 255 lighter than the one painted right before it (a step the edge rule alone sees as an edge): A, a 30 mm square
/// (120 mm round), B inside it, and C reaching 10 mm past A's right side. Inside the blend nothing is outlined: A
/// shows 110 mm (C hides 10 mm of its right side), B none, C only the 30 mm that lies past A (top, right and bottom
/// of its 10 × 10 mm part outside). D, black, painted next, is no step of the blend: its 40 mm outline is whole.
/// 180 mm in all; every step's outline drawn, it was 280 mm (B 70, C 60), as it stays without hatching. The hatch
/// runs along y = 0, 1000, ... mm: no line of it meets the shapes.
#[test]
fn blend_steps_are_not_outlined_inside_their_blend() {
    let svg = mm_doc(
        r##"<rect x="10" y="10" width="30" height="30" fill="#808080"/>
            <rect x="15" y="15" width="20" height="20" fill="#868686"/>
            <rect x="30" y="20" width="20" height="10" fill="#8c8c8c"/>
            <rect x="60" y="10" width="10" height="10" fill="#000000"/>"##,
    );
    let hatched = SvgOptions {
        hatch: Some(FillHatch { spacing_mm: 1000.0, angle_deg: 0.0, ..FillHatch::default() }),
        ..SvgOptions::default()
    };
    assert_len(&import_with(&svg, &hatched).drawing, 180.0);
    assert_len(&import_with(&svg, &SvgOptions::default()).drawing, 280.0);
    // A step painted with another shape between it and the one before starts a run of its own: the same greys with
    // a black square between B and C outline C's part over A and B too (+ its 30 mm inside, + the square's 40 mm).
    let svg = mm_doc(
        r##"<rect x="10" y="10" width="30" height="30" fill="#808080"/>
            <rect x="15" y="15" width="20" height="20" fill="#868686"/>
            <rect x="80" y="80" width="10" height="10" fill="#000000"/>
            <rect x="30" y="20" width="20" height="10" fill="#8c8c8c"/>"##,
    );
    assert_len(&import_with(&svg, &hatched).drawing, 110.0 + 60.0 + 40.0);
}
