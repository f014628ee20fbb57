//! Speed of the tone styles: each traces a one-megapixel photo (samples/photo.png enlarged to 1155 × 866 pixels,
//! 180 mm wide, so 0.156 mm per pixel, with a 0.3 mm pen) on one core. Target: each at most 1 s.
//!
//! Run: `cargo bench -p plotter-path --bench styles_speed`. Prints the median of 3 runs per style in seconds, wall
//! clock and on the core (the latter is what counts on a machine busy with other work) (the
//! stipple's one line through its dots, `--tsp`, timed as the front end does it: the trace, then
//! `optimize::one_line`), with the paths and pen-down metres. `STYLES=stipple,flow` runs only the styles whose names
//! contain one of those words. `PICTURE=file.png` traces another photo, resized to about one megapixel (180 mm wide
//! still); `FIDELITY=1` adds the tone measure of each style's plot against that picture (L* error and SSIM, see
//! `plotter_path::input::raster::fidelity`), which is not timed.

use std::time::Instant;

use image::DynamicImage;
use image::imageops::FilterType;
use plotter_path::input::raster::fidelity::{MeasureOptions, measure};
use plotter_path::input::raster::{self, Mode, TraceOptions};
use plotter_path::optimize::one_line::join_into_one_line;

/// The time this thread has run on a core so far, in seconds (Linux: /proc/thread-self/schedstat), so that other
/// work on a busy machine does not count.
fn cpu_seconds() -> Option<f64> {
    let text = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    let ns: u64 = text.split_whitespace().next()?.parse().ok()?;
    #[allow(clippy::cast_precision_loss)]
    Some(ns as f64 / 1e9)
}

fn main() {
    let photo = std::env::var("PICTURE")
        .unwrap_or_else(|_| concat!(env!("CARGO_MANIFEST_DIR"), "/../samples/photo.png").to_owned());
    let fidelity = std::env::var("FIDELITY").is_ok_and(|v| v == "1");
    let gray = match image::open(&photo) {
        Ok(i) => i.to_luma8(),
        Err(e) => {
            eprintln!("styles_speed: {photo}: {e}");
            std::process::exit(1);
        }
    };
    // About a megapixel at the picture's own shape (samples/photo.png: 1155 × 866).
    let aspect = f64::from(gray.height()) / f64::from(gray.width().max(1));
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let (w, h) = ((1e6 / aspect).sqrt().round() as u32, ((1e6 * aspect).sqrt().round() as u32).max(1));
    let big = image::imageops::resize(&gray, w, h, FilterType::CatmullRom);
    let measure_opts = MeasureOptions::default();
    let only: Vec<String> = std::env::var("STYLES")
        .map(|s| s.split(',').map(str::to_owned).filter(|w| !w.is_empty()).collect())
        .unwrap_or_default();
    let cases: [(&str, Mode, bool); 9] = [
        ("hatch", Mode::Hatch, false),
        ("hatch --levels 8", Mode::Hatch, false),
        ("squiggle", Mode::Squiggle, false),
        ("spiral", Mode::Spiral, false),
        ("stipple", Mode::Stipple, false),
        ("stipple --tsp", Mode::Stipple, true),
        ("flow", Mode::Flow, false),
        ("sketch", Mode::Sketch, false),
        ("mosaic", Mode::Mosaic, false),
    ];
    println!(
        "{:<20} {:>8} {:>8} {:>8} {:>9} {:>8} {:>6}",
        format!("style ({w}×{h})"),
        "s",
        "cpu s",
        "paths",
        "ink m",
        "L* err",
        "SSIM"
    );
    let big_image = DynamicImage::ImageLuma8(big.clone());
    for (name, mode, tsp) in cases {
        if !only.is_empty() && !only.iter().any(|w| name.contains(w.as_str())) {
            continue;
        }
        let mut opts = TraceOptions { mode, pitch_mm: Some(180.0 / f64::from(w)), ..TraceOptions::default() };
        if name.contains("levels 8") {
            opts.hatch.levels = 8;
        }
        opts.stipple.tsp = tsp;
        let mut times = Vec::new();
        let mut cpu = Vec::new();
        let mut last = None;
        for _ in 0..3 {
            let t = Instant::now();
            let c = cpu_seconds();
            let mut traced = match raster::trace(&big_image, &opts) {
                Ok(t) => t,
                Err(e) => {
                    eprintln!("styles_speed: {name}: {e}");
                    break;
                }
            };
            if tsp {
                join_into_one_line(&mut traced.drawing);
            }
            times.push(t.elapsed().as_secs_f64());
            if let (Some(a), Some(b)) = (c, cpu_seconds()) {
                cpu.push(b - a);
            }
            last = Some(traced);
        }
        let Some(traced) = last else { continue };
        times.sort_by(f64::total_cmp);
        cpu.sort_by(f64::total_cmp);
        let cpu = cpu.get(cpu.len() / 2).map_or_else(String::new, |c| format!("{c:.2}"));
        let ink: f64 = traced.drawing.paths().map(|p| p.length()).sum::<f64>() / 1000.0;
        let (err, ssim) = if fidelity {
            let strokes: Vec<_> = traced.drawing.paths().map(|p| p.points.clone()).collect();
            let f = measure(&strokes, &big, &measure_opts);
            (format!("{:.4}", f.lightness_error), format!("{:.3}", f.ssim))
        } else {
            (String::new(), String::new())
        };
        println!(
            "{name:<20} {:>8.2} {cpu:>8} {:>8} {:>9.1} {err:>8} {ssim:>6}",
            times[times.len() / 2],
            traced.drawing.path_count(),
            ink
        );
    }
}
