//! Every sample SVG imports cleanly, previews, and survives the plain-SVG export round trip unchanged.

use plotter_e2e::sample;
use plotter_path::input::svg::{ResourcePolicy, SvgOptions, import_svg, load_svg};
use plotter_path::output::preview::{PreviewOptions, render};
use plotter_path::output::svg_out::to_svg_string;
use plotter_path::{MachineProfile, geometry::layout};

const SVG_SAMPLES: [&str; 4] = ["duck.svg", "transforms.svg", "layers.svg", "three-pens.svg"];

#[test]
fn samples_import_without_warnings_and_fit_the_plotter() {
    let profile = MachineProfile::default_plotter();
    for name in SVG_SAMPLES {
        let imported = load_svg(&sample(name), &SvgOptions::default()).unwrap();
        assert!(imported.warnings.is_empty(), "{name}: {:?}", imported.warnings);
        assert!(imported.drawing.path_count() > 3, "{name}");
        layout::check_work_area(&imported.drawing, &profile).unwrap();
        let png = render(&imported.drawing, &PreviewOptions { travel: true, ..Default::default() }).unwrap();
        assert!(png.width() > 100 && png.height() > 100);
    }
}

#[test]
fn export_round_trip_preserves_geometry() {
    for name in SVG_SAMPLES {
        let original = load_svg(&sample(name), &SvgOptions::default()).unwrap().drawing;
        let exported = to_svg_string(&original);
        let again =
            import_svg(exported.as_bytes(), name, &ResourcePolicy::DataUrlsOnly, &SvgOptions::default()).unwrap();
        assert!(again.warnings.is_empty(), "{name}: {:?}", again.warnings);
        let again = again.drawing;
        assert_eq!(
            again.page_mm.map(|(w, h)| (w.round(), h.round())),
            original.page_mm.map(|(w, h)| (w.round(), h.round()))
        );
        let names = |d: &plotter_path::Drawing| d.layers.iter().map(|l| l.name.clone()).collect::<Vec<_>>();
        assert_eq!(names(&again), names(&original), "{name}");
        for (a, b) in original.paths().zip(again.paths()) {
            assert_eq!(a.points.len(), b.points.len(), "{name}");
            assert_eq!(a.is_closed(), b.is_closed(), "{name}");
            for (p, q) in a.points.iter().zip(&b.points) {
                // 4 decimals in the file plus f32 inside the SVG library.
                assert!(p.distance(*q) < 1e-3, "{name}: {p:?} vs {q:?}");
            }
        }
        assert_eq!(original.path_count(), again.path_count(), "{name}");
    }
}

#[test]
fn three_pens_sample_changes_pen_twice() {
    use plotter_path::geometry::steps::drawing_to_steps;
    use plotter_path::motion::plan::{Lookahead, homed_position, plan};
    let profile = MachineProfile::default_plotter();
    let d = load_svg(&sample("three-pens.svg"), &SvgOptions::default()).unwrap().drawing;
    let layers: Vec<(&str, String)> = d.layers.iter().map(|l| (l.name.as_str(), l.pen.color.to_hex())).collect();
    assert_eq!(layers, [("black", "#000000".into()), ("red", "#ff0000".into()), ("blue", "#0000ff".into())]);
    let steps = drawing_to_steps(&profile, &d).unwrap();
    let p = plan(&profile, &steps, homed_position(&profile).unwrap(), Lookahead::Whole).unwrap();
    let pens: Vec<&str> = p.pen_changes.iter().map(|c| c.pen.name.as_str()).collect();
    assert_eq!(pens, ["red fineliner 0.5", "blue brush pen"]);
    assert_eq!(p.first_pen.name, "black fineliner 0.3");
    let g = plotter_path::output::gcode_out::export(&profile, &steps);
    assert_eq!(g.lines().filter(|l| l.starts_with("M0 ; pen change: load")).count(), 2);
}
