//! Import + flatten throughput on a generated SVG with 60 000 paths (lines, quadratics, cubics, arcs, polygons).
//!
//! Run: `cargo bench -p plotter-path --bench import`. Prints paths/s and segments/s after criterion's timing.

use std::fmt::Write;
use std::hint::black_box;
use std::time::Instant;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use plotter_path::input::svg::{SvgOptions, import_svg};
use plotter_path::output::stats::Stats;

/// A deterministic large drawing: a 300 × 200 grid of cells, each with one shape.
fn large_svg(paths: usize) -> String {
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
            2 => writeln!(s, r#"<circle cx="{}" cy="{}" r="0.6" stroke="black" fill="none"/>"#, x + 0.6, y + 0.6),
            3 => writeln!(
                s,
                r#"<polygon points="{x},{y} {},{y} {},{}" stroke="black" fill="none"/>"#,
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
    let svg = large_svg(paths);
    let options = SvgOptions { tolerance_mm: 0.01, ..SvgOptions::default() };
    let first = import_svg(svg.as_bytes(), "bench.svg", None, &options).expect("bench SVG imports");
    let stats = Stats::of(&first.drawing);
    let mut group = c.benchmark_group("import");
    group.sample_size(10);
    group.throughput(Throughput::Elements(stats.segments as u64));
    group.bench_function("svg_60k_paths_tol_0.01mm", |b| {
        b.iter(|| import_svg(black_box(svg.as_bytes()), "bench.svg", None, &options).unwrap())
    });
    group.finish();

    let runs = 5;
    let start = Instant::now();
    for _ in 0..runs {
        black_box(import_svg(svg.as_bytes(), "bench.svg", None, &options).unwrap());
    }
    let per_run = start.elapsed().as_secs_f64() / f64::from(runs);
    println!(
        "import+flatten: {} paths, {} segments in {:.1} ms → {:.0} paths/s, {:.2} M segments/s",
        stats.paths,
        stats.segments,
        per_run * 1e3,
        stats.paths as f64 / per_run,
        stats.segments as f64 / per_run / 1e6
    );
}

criterion_group!(benches, bench);
criterion_main!(benches);
