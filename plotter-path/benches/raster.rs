//! Raster tracing: a 1000 × 1000 image through each mode (decode excluded, gray conversion included).
//!
//! Run: `cargo bench -p plotter-path --bench raster`. After criterion's runs it prints a table of milliseconds per
//! mode (median of 15 runs). Inputs: the photo-like scene of `raster::synth` rendered at 1000 × 1000 (outline with
//! Otsu, edges, hatch) and the line-art strokes scaled to 1000 × 1000 (outline, centerline). Target: outline ≤ 150 ms.
//! Set `RASTER_BENCH_PBM=dir` to also write the thresholded bitmaps as PBM files for an external reference
//! (e.g. `potrace -b svg`).

use std::hint::black_box;
use std::time::Instant;

use criterion::{Criterion, criterion_group, criterion_main};
use image::DynamicImage;
use plotter_path::input::raster::{self, Mode, TraceOptions, synth};
use plotter_path::kurbo::Point;

fn photo() -> DynamicImage {
    DynamicImage::ImageLuma8(synth::photo_scene(1000, 1000))
}

fn line_art() -> DynamicImage {
    let strokes: Vec<synth::Stroke> = synth::line_art_strokes()
        .into_iter()
        .map(|s| synth::Stroke {
            points: s.points.iter().map(|p| Point::new(p.x * 1.5 + 20.0, p.y * 1.5 + 190.0)).collect(),
        })
        .collect();
    DynamicImage::ImageLuma8(synth::stroke_gray(1000, 1000, &strokes, 7.0))
}

fn cases() -> Vec<(&'static str, DynamicImage, Mode)> {
    let (p, l) = (photo(), line_art());
    vec![
        ("outline (photo, otsu)", p.clone(), Mode::Outline),
        ("outline (line art)", l.clone(), Mode::Outline),
        ("centerline (line art)", l, Mode::Centerline),
        ("edges (photo)", p.clone(), Mode::Edges),
        ("hatch (photo, 4 levels, 1 mm)", p, Mode::Hatch),
    ]
}

fn options(mode: Mode) -> TraceOptions {
    // 0.3 mm per pixel: the 1000-pixel image is 300 mm wide; hatch spacing 1 mm ≈ 3.3 px.
    TraceOptions { mode, pitch_mm: Some(0.3), ..TraceOptions::default() }
}

fn bench(c: &mut Criterion) {
    let cases = cases();
    let mut group = c.benchmark_group("raster 1000x1000");
    group.sample_size(10);
    for (name, img, mode) in &cases {
        let opts = options(*mode);
        group.bench_function(*name, |b| b.iter(|| raster::trace(black_box(img), &opts).unwrap()));
    }
    group.finish();

    println!("\n{:<32} {:>9} {:>8} {:>10}", "mode (1000×1000)", "ms", "paths", "vertices");
    for (name, img, mode) in &cases {
        let opts = options(*mode);
        let mut times: Vec<f64> = (0..15)
            .map(|_| {
                let t = Instant::now();
                black_box(raster::trace(img, &opts).unwrap());
                t.elapsed().as_secs_f64() * 1e3
            })
            .collect();
        times.sort_by(f64::total_cmp);
        let r = raster::trace(img, &opts).unwrap();
        let vertices: usize = r.drawing.paths().map(|p| p.points.len()).sum();
        println!("{name:<32} {:>9.1} {:>8} {:>10}", times[7], r.drawing.path_count(), vertices);
    }
    if let Ok(dir) = std::env::var("RASTER_BENCH_PBM") {
        for (name, (_, img, _)) in ["photo", "line-art"].iter().zip(&cases) {
            let bitmap = raster::binarize(&img.to_luma8(), raster::Threshold::Otsu, false);
            let file = std::path::Path::new(&dir).join(format!("{name}.pbm"));
            let mut out = format!("P1\n{} {}\n", bitmap.width(), bitmap.height()).into_bytes();
            for row in bitmap.as_bytes().chunks(bitmap.width()) {
                out.extend(row.iter().map(|&v| if v != 0 { b'1' } else { b'0' }));
                out.push(b'\n');
            }
            std::fs::write(&file, out).unwrap();
            println!("wrote {}", file.display());
        }
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
