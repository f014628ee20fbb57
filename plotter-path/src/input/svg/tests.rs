//! Golden and behaviour tests of the SVG importer.

use super::*;

fn import(svg: &str) -> Imported {
    import_svg(svg.as_bytes(), "test.svg", None, &SvgOptions::default()).unwrap()
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
    let imported = import_svg(svg.as_bytes(), "c.svg", None, &opts).unwrap();
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
    let warned = import_svg(svg.as_bytes(), "c.svg", None, &opts).unwrap();
    assert!(warned.warnings.iter().any(|w| w.contains("arcs/circles are approximated")), "{:?}", warned.warnings);
}

#[test]
fn text_becomes_glyph_outlines_or_warns_without_fonts() {
    let svg = r##"<svg xmlns="http://www.w3.org/2000/svg" width="100" height="40">
        <text x="5" y="30" font-family="sans-serif" font-size="24">Hi</text></svg>"##;
    let mut db = usvg::fontdb::Database::new();
    db.load_system_fonts();
    let result = import_svg(svg.as_bytes(), "t.svg", None, &SvgOptions::default());
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
    let by_group = import_svg(svg.as_bytes(), "l.svg", None, &opts).unwrap().drawing;
    let names: Vec<&str> = by_group.layers.iter().map(|l| l.name.as_str()).collect();
    assert_eq!(names, ["Outline", "detail", "root"]);
    assert_eq!(by_group.layers[0].paths.len(), 2);

    let opts = SvgOptions { layer_by: LayerBy::Color, ..SvgOptions::default() };
    let by_color = import_svg(svg.as_bytes(), "l.svg", None, &opts).unwrap().drawing;
    let names: Vec<&str> = by_color.layers.iter().map(|l| l.name.as_str()).collect();
    assert_eq!(names, ["#ff0000", "#0000ff"]);
    assert_eq!(by_color.layers[0].paths.len(), 2);
    assert_eq!(by_color.layers[1].pen.color, Rgb(0, 0, 255));

    let opts = SvgOptions { layers: vec!["detail".into()], layer_by: LayerBy::Group, ..SvgOptions::default() };
    let only = import_svg(svg.as_bytes(), "l.svg", None, &opts).unwrap().drawing;
    assert_eq!(only.layers.len(), 1);
    assert_eq!(only.layers[0].name, "detail");
    let opts = SvgOptions { layers: vec!["nope".into()], layer_by: LayerBy::Group, ..SvgOptions::default() };
    let err = import_svg(svg.as_bytes(), "l.svg", None, &opts).unwrap_err().to_string();
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
        let err = import_svg(data, "bad.svg", None, &SvgOptions::default()).unwrap_err().to_string();
        assert!(err.starts_with("bad.svg") && err.contains(want), "{err}");
    }
    let err = load_svg(Path::new("/definitely/missing.svg"), &SvgOptions::default()).unwrap_err().to_string();
    assert!(err.contains("/definitely/missing.svg") && err.contains("cannot read"), "{err}");
    let html = b"<html><body/></html>";
    let err = import_svg(html, "page.html", None, &SvgOptions::default()).unwrap_err().to_string();
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
