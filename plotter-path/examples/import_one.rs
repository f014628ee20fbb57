//! Import one SVG and print how long it took (for profiling the importer on real files).
//!
//! Run: `cargo run --release -p plotter-path --example import_one -- FILE.svg [--no-occlusion]`.

use std::time::Instant;

use plotter_path::input::svg::{SvgOptions, load_svg};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let Some(path) = args.get(1) else {
        eprintln!("usage: import_one FILE.svg [--no-occlusion]");
        std::process::exit(2);
    };
    let options = SvgOptions { occlusion: !args.iter().any(|a| a == "--no-occlusion"), ..SvgOptions::default() };
    let t0 = Instant::now();
    match load_svg(std::path::Path::new(path), &options) {
        Ok(imported) => {
            let segments: usize = imported.drawing.paths().map(|p| p.segment_count()).sum();
            println!(
                "{path}: {} paths, {segments} segments, {:.3} s",
                imported.drawing.path_count(),
                t0.elapsed().as_secs_f64()
            );
        }
        Err(e) => println!("{path}: error after {:.3} s: {e}", t0.elapsed().as_secs_f64()),
    }
}
