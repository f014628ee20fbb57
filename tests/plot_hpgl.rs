//! HP-GL end to end: `plotter plot --export FILE.hpgl` for a vintage pen plotter, and HP-GL files (ours, and one
//! vpype wrote for the HP 7475A) read back and plotted on the simulated plotter.

use plotter_e2e::{fixture, plotter, sample, scratch};
use plotter_path::input::hpgl_in;

fn stdout_of(out: &std::process::Output) -> String {
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// The "N mm pen-down" figure of a plot summary.
fn pen_down_mm(summary: &str) -> f64 {
    summary.split(" mm pen-down").next().and_then(|s| s.rsplit(' ').next()).unwrap().parse().unwrap()
}

fn length(d: &plotter_path::Drawing) -> f64 {
    d.paths().map(plotter_path::Polyline::length).sum()
}

/// Length of the quadratic Bézier from (0, 0) over (7.5, −4) to (15, 0) — one wave of `samples/three-pens.svg` —
/// summed over a million chords (the chord sum converges from below, error ~1e-11 mm here).
fn wave_length() -> f64 {
    let n = 1_000_000;
    let at = |t: f64| (2.0 * t * (1.0 - t) * 7.5 + t * t * 15.0, 2.0 * t * (1.0 - t) * -4.0);
    let mut prev = at(0.0);
    let mut sum = 0.0;
    for i in 1..=n {
        let p = at(f64::from(i) / f64::from(n));
        sum += (p.0 - prev.0).hypot(p.1 - prev.1);
        prev = p;
    }
    sum
}

/// `samples/three-pens.svg` drawn: a 80 × 50 mm frame and an 80 mm line (340 mm), a circle of radius 9 mm and
/// three 2 mm ticks (18π + 6 mm), and five quadratic waves.
fn three_pens_length() -> f64 {
    340.0 + 18.0 * std::f64::consts::PI + 6.0 + 5.0 * wave_length()
}

/// A 10 mm square with its corner at page (30, 50) mm on a landscape A4 page, exported for the 7475A: its A4 plotter
/// unit (0, 0) lies at page (10, 206) mm, so x = (30 − 10)·40 = 800, (40 − 10)·40 = 1200 and y = (206 − 50)·40 =
/// 6240, (206 − 60)·40 = 5840.
#[test]
fn a_square_becomes_exact_plotter_units() {
    let dir = scratch("hpgl-square");
    let svg = r#"<svg xmlns="http://www.w3.org/2000/svg" width="297mm" height="210mm" viewBox="0 0 297 210">
<path d="M30 50 H40 V60 H30 Z" fill="none" stroke="black"/></svg>"#;
    std::fs::write(dir.join("sq.svg"), svg).unwrap();
    let out = stdout_of(&plotter(&dir, &["plot", "sq.svg", "--no-optimize", "--export", "sq.hpgl"]));
    assert!(out.contains("for the HP 7475A on a4 written to sq.hpgl"), "{out}");
    let text = std::fs::read_to_string(dir.join("sq.hpgl")).unwrap();
    assert_eq!(
        text.lines().collect::<Vec<_>>(),
        [
            "IN;",
            "IW0,0,11040,7721;",
            "PU;SP1;",
            "VS6;",
            "PU800,6240;",
            "PD1200,6240,1200,5840,800,5840,800,6240;",
            "PU;SP0;"
        ]
    );
    // The DXY-1300's A3 origin is page (2, 286.5) mm: x = 28·40 = 1120, y = 236.5·40 = 9460.
    stdout_of(&plotter(&dir, &["plot", "sq.svg", "--no-optimize", "--export", "d.plt", "--hpgl-device", "dxy-1300"]));
    let text = std::fs::read_to_string(dir.join("d.plt")).unwrap();
    assert!(text.contains("\nPU1120,9460;\nPD1520,9460,1520,9060,1120,9060,1120,9460;\n"), "{text}");
    // An unknown device or paper is an error naming the choices.
    let bad = plotter(&dir, &["plot", "sq.svg", "--export", "x.hpgl", "--hpgl-device", "7470b"]);
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(!bad.status.success() && err.contains("known: 7475a, 7550a, dxy-1300, generic"), "{err}");
    let bad = plotter(&dir, &["plot", "sq.svg", "--export", "x.hpgl", "--hpgl-paper", "a0"]);
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(!bad.status.success() && err.contains("the HP 7475A takes a4, letter, a3, tabloid"), "{err}");
}

/// Our HP-GL, read back, draws the drawing: the pen-down length of the re-imported file (to the micrometre, and as
/// the simulated plot reports it) is that of the SVG's true curves within 0.1 %, each pen comes back as its own
/// layer, and exporting the re-imported file again writes the same program.
#[test]
fn export_round_trip_keeps_the_pen_down_length() {
    let dir = scratch("hpgl-round-trip");
    let svg = sample("three-pens.svg");
    let svg = svg.to_str().unwrap();
    stdout_of(&plotter(&dir, &["plot", svg, "--paper", "a4", "--landscape", "--center", "--export", "t.hpgl"]));
    let text = std::fs::read(dir.join("t.hpgl")).unwrap();
    let expect = three_pens_length();
    let back = hpgl_in::import(&text, "t.hpgl", None).unwrap();
    assert!(back.warnings.is_empty(), "{:?}", back.warnings);
    assert_eq!(back.paper.name, "a4");
    let names: Vec<&str> = back.drawing.layers.iter().map(|l| l.name.as_str()).collect();
    assert_eq!(names, ["pen 1", "pen 2", "pen 3"]);
    let got = length(&back.drawing);
    assert!((got - expect).abs() < expect * 1e-3, "re-imported {got} mm vs {expect} mm");

    let summary = stdout_of(&plotter(&dir, &["plot", "t.hpgl", "--no-optimize", "--pen-change", "none"]));
    let plotted = pen_down_mm(&summary);
    assert!((plotted - expect).abs() < expect * 1e-3, "plotted {plotted} mm vs {expect} mm");

    // Exported again, the same program — but for the speeds: the layers are now called "pen 1" … "pen 3", which
    // match other entries of the profile's pen table than "black", "red" and "blue" did.
    stdout_of(&plotter(&dir, &["plot", "t.hpgl", "--no-optimize", "--export", "again.hpgl"]));
    let without_speeds = |t: &str| t.lines().filter(|l| !l.starts_with("VS")).collect::<Vec<_>>().join("\n");
    let again = std::fs::read_to_string(dir.join("again.hpgl")).unwrap();
    assert_eq!(without_speeds(&again), without_speeds(&String::from_utf8(text).unwrap()));
}

/// `tests/fixtures/three-pens-7475a.hpgl` was written by vpype 1.15.0:
/// `vpype read samples/three-pens.svg write --device hp7475a --page-size a4 --landscape --center
/// three-pens-7475a.hpgl`. vpype takes the plotter unit as 0.02488 mm, so the 80 × 50 mm frame is 3215 × 2009
/// units and the 80 mm line 3215: the black pen draws 2·(3215 + 2009) + 3215 = 13663 units, 341.575 mm at our
/// 0.025 mm. The frame starts at unit (3959, 5064), page (10 + 3959/40, 206 − 5064/40) = (108.975, 79.4) mm on
/// the 7475A's A4 sheet. The file draws in relative coordinates (`PR`) and selects pens 1–3.
#[test]
fn a_file_vpype_wrote_for_the_7475a_imports_and_plots() {
    let path = fixture("three-pens-7475a.hpgl");
    let data = std::fs::read(&path).unwrap();
    let r = hpgl_in::import(&data, "vpype.hpgl", None).unwrap();
    assert!(r.warnings.is_empty(), "{:?}", r.warnings);
    assert_eq!(r.paper.name, "a4");
    let names: Vec<&str> = r.drawing.layers.iter().map(|l| l.name.as_str()).collect();
    assert_eq!(names, ["pen 1", "pen 2", "pen 3"]);
    let black = &r.drawing.layers[0];
    let first = black.paths[0].points[0];
    assert!((first.x - 108.975).abs() < 1e-9 && (first.y - 79.4).abs() < 1e-9, "{first:?}");
    let black_mm: f64 = black.paths.iter().map(plotter_path::Polyline::length).sum();
    assert!((black_mm - 341.575).abs() < 1e-9, "{black_mm}");
    // All of it: the SVG's length scaled by 0.025 / 0.02488, within 0.5 %. (Not closer: vpype writes the curves
    // as steps of about 4 units, each rounded to whole units, and such a staircase is longer than the curve —
    // here by 0.13 %.)
    let expect = three_pens_length() * 0.025 / 0.02488;
    let got = length(&r.drawing);
    assert!((got - expect).abs() < expect * 5e-3, "{got} vs {expect}");

    let dir = scratch("hpgl-vpype");
    let summary =
        stdout_of(&plotter(&dir, &["plot", path.to_str().unwrap(), "--no-optimize", "--pen-change", "none", "-v"]));
    assert!(summary.contains("0 resends"), "{summary}");
    assert!((pen_down_mm(&summary) - got).abs() < 0.1, "{summary}");
}
