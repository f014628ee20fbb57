//! Speed of the tone styles: each traces a one-megapixel photo (samples/photo.png enlarged to 1155 × 866 pixels,
//! 180 mm wide, so 0.156 mm per pixel, with a 0.3 mm pen) on one core. Target: each at most 1 s.
//!
//! Run: `cargo bench -p plotter-path --bench styles_speed`. Prints the median of 3 runs per style in seconds (the
//! stipple's one line through its dots, `--tsp`, timed as the front end does it: the trace, then
//! `optimize::one_line`), with the paths and pen-down metres.

use std::time::Instant;

use image::DynamicImage;
use image::imageops::FilterType;
use plotter_path::input::raster::{self, Mode, TraceOptions};
use plotter_path::optimize::one_line::join_into_one_line;

fn main() {
    let photo = concat!(env!("CARGO_MANIFEST_DIR"), "/../samples/photo.png");
    let gray = match image::open(photo) {
        Ok(i) => i.to_luma8(),
        Err(e) => {
            eprintln!("styles_speed: {photo}: {e}");
            std::process::exit(1);
        }
    };
    let big = DynamicImage::ImageLuma8(image::imageops::resize(&gray, 1155, 866, FilterType::CatmullRom));
    let cases: [(&str, Mode, bool); 6] = [
        ("hatch", Mode::Hatch, false),
        ("hatch --levels 8", Mode::Hatch, false),
        ("squiggle", Mode::Squiggle, false),
        ("spiral", Mode::Spiral, false),
        ("stipple", Mode::Stipple, false),
        ("stipple --tsp", Mode::Stipple, true),
    ];
    println!("{:<20} {:>8} {:>8} {:>9}", "style (1155×866)", "s", "paths", "ink m");
    for (name, mode, tsp) in cases {
        let mut opts = TraceOptions { mode, pitch_mm: Some(180.0 / 1155.0), ..TraceOptions::default() };
        if name.contains("levels 8") {
            opts.hatch.levels = 8;
        }
        opts.stipple.tsp = tsp;
        let mut times = Vec::new();
        let mut last = None;
        for _ in 0..3 {
            let t = Instant::now();
            let mut traced = match raster::trace(&big, &opts) {
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
            last = Some(traced);
        }
        let Some(traced) = last else { continue };
        times.sort_by(f64::total_cmp);
        let ink: f64 = traced.drawing.paths().map(|p| p.length()).sum::<f64>() / 1000.0;
        println!("{name:<20} {:>8.2} {:>8} {:>9.1}", times[times.len() / 2], traced.drawing.path_count(), ink);
    }
}
