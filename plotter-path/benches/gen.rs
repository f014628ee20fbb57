//! Parametric generators: adaptive sampling, Fourier fitting and whole specs.
//!
//! Run: `cargo bench -p plotter-path --bench gen`. Criterion reports time per figure; the table printed first gives
//! the point counts each figure produces and the derived points per second.

use std::hint::black_box;
use std::time::Instant;

use criterion::{Criterion, criterion_group, criterion_main};
use plotter_path::input::r#gen::{FourierSeries, MickeyOutline, Sampling, from_spec, sample};

const SPECS: &[&str] = &[
    "epicycloid?q=3&r=10",
    "spirograph?r=36&q=105/36&d=30",
    "rose?k=7/4&a=50",
    "lissajous?fx=13&fy=12",
    "spiral?turns=100&r1=100",
    "mickey",
    "mickey?harmonics=64&samples=4096&tol=0.01",
];

fn table() {
    println!("{:<45} {:>9} {:>11} {:>12}", "spec", "points", "time (ms)", "points/s");
    for spec in SPECS {
        let runs = 20;
        let start = Instant::now();
        let mut points = 0;
        for _ in 0..runs {
            let d = from_spec(black_box(spec)).unwrap();
            points = d.paths().map(|p| p.points.len()).sum::<usize>();
        }
        let per = start.elapsed().as_secs_f64() / f64::from(runs);
        #[allow(clippy::cast_precision_loss)]
        let rate = points as f64 / per;
        println!("{spec:<45} {points:>9} {:>11.3} {rate:>12.3e}", per * 1e3);
    }
}

fn bench(c: &mut Criterion) {
    table();
    for spec in ["spirograph?r=36&q=105/36&d=30", "mickey"] {
        c.bench_function(&format!("from_spec {spec}"), |b| b.iter(|| from_spec(black_box(spec)).unwrap()));
    }
    let outline = sample(&MickeyOutline::new(40.0).unwrap(), Sampling::Adaptive(1e-4)).unwrap();
    c.bench_function("fourier fit N=64 M=4096", |b| {
        b.iter(|| FourierSeries::fit_outline(black_box(&outline), 64, 4096).unwrap())
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
