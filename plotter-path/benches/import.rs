//! Import + flatten throughput on a generated SVG with 60 000 paths (lines, quadratics, cubics, arcs, polygons).
//!
//! Run: `cargo bench -p plotter-path --bench import`. Prints paths/s and segments/s after criterion's timing, with
//! hidden-line removal off and on, and on a variant where every circle and triangle has an opaque fill (so
//! occlusion has work to do: 24 000 occluders, each overlapping its neighbours' outlines).

use std::fmt::Write;
use std::hint::black_box;
use std::time::Instant;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use plotter_path::input::svg::{ResourcePolicy, SvgOptions, import_svg};
use plotter_path::output::stats::Stats;

/// A deterministic large drawing: a 300 × 200 grid of cells, each with one shape; with `filled`, circles (grown to
/// overlap their neighbours) and triangles get an opaque fill.
fn large_svg(paths: usize, filled: bool) -> String {
    let (fill, r) = if filled { ("#88aacc", 0.9) } else { ("none", 0.6) };
    let mut s =
        String::from(r#"<svg xmlns="http://www.w3.org/2000/svg" width="400mm" height="300mm" viewBox="0 0 400 300">"#);
    s.push('\n');
    for i in 0..paths {
        let (x, y) = ((i % 300) as f64 * 1.3, (i / 300) as f64 * 1.4);
        let _ = match i % 5 {
            0 => writeln!(
                s,
                r#"<path d="M{x} {y} C{} {} {} {} {} {y}" stroke="black" fill="none"/>"#,
                x + 0.3,
                y + 1.0,
                x + 0.8,
                y - 0.6,
                x + 1.2
            ),
            1 => writeln!(
                s,
                r#"<path d="M{x} {y} Q{} {} {} {y} T{} {y}" stroke="black" fill="none"/>"#,
                x + 0.5,
                y + 1.2,
                x + 1.0,
                x + 1.2
            ),
            2 => writeln!(s, r#"<circle cx="{}" cy="{}" r="{r}" stroke="black" fill="{fill}"/>"#, x + 0.6, y + 0.6),
            3 => writeln!(
                s,
                r#"<polygon points="{x},{y} {},{y} {},{}" stroke="black" fill="{fill}"/>"#,
                x + 1.0,
                x + 0.5,
                y + 1.0
            ),
            _ => writeln!(s, r#"<path d="M{x} {y} a 0.6 0.4 30 1 1 1.1 0.2" stroke="black" fill="none"/>"#),
        };
    }
    s.push_str("</svg>\n");
    s
}

fn bench(c: &mut Criterion) {
    let paths = 60_000;
    let svg = large_svg(paths, false);
    let options = SvgOptions { tolerance_mm: 0.01, occlusion: false, ..SvgOptions::default() };
    let first =
        import_svg(svg.as_bytes(), "bench.svg", &ResourcePolicy::DataUrlsOnly, &options).expect("bench SVG imports");
    let stats = Stats::of(&first.drawing);
    let mut group = c.benchmark_group("import");
    group.sample_size(10);
    group.throughput(Throughput::Elements(stats.segments as u64));
    group.bench_function("svg_60k_paths_tol_0.01mm", |b| {
        b.iter(|| import_svg(black_box(svg.as_bytes()), "bench.svg", &ResourcePolicy::DataUrlsOnly, &options).unwrap())
    });
    group.finish();

    let filled = large_svg(paths, true);
    let on = SvgOptions { occlusion: true, ..options.clone() };
    for (what, doc, opts) in
        [("occlusion off", &svg, &options), ("occlusion on", &svg, &on), ("occlusion on, filled", &filled, &on)]
    {
        let runs = 3;
        let first =
            import_svg(doc.as_bytes(), "bench.svg", &ResourcePolicy::DataUrlsOnly, opts).expect("bench SVG imports");
        let stats = Stats::of(&first.drawing);
        let start = Instant::now();
        for _ in 0..runs {
            black_box(import_svg(doc.as_bytes(), "bench.svg", &ResourcePolicy::DataUrlsOnly, opts).unwrap());
        }
        let per_run = start.elapsed().as_secs_f64() / f64::from(runs);
        println!(
            "import+flatten ({what}): {} paths, {} segments in {:.1} ms → {:.0} paths/s, {:.2} M segments/s",
            stats.paths,
            stats.segments,
            per_run * 1e3,
            stats.paths as f64 / per_run,
            stats.segments as f64 / per_run / 1e6
        );
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
