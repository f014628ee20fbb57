//! Writes the raster samples used by README, tests and benchmarks:
//!
//! - `samples/line-art.png`: 640 × 400 anti-aliased black strokes (stroke-font word, circle, spiral, wave, star);
//! - `samples/photo.png`: 480 × 360 photo-like gray scene (lit sphere, shadow, box, graded floor and wall).
//!
//! Both are computed from geometry in `plotter_path::input::raster::synth`; nothing is copied from elsewhere.
//! Run: `cargo run -p plotter-path --example make_raster_samples [OUT_DIR]` (default `samples/`).

use plotter_path::input::raster::synth;
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = std::env::args().nth(1).map_or_else(|| PathBuf::from("samples"), PathBuf::from);
    std::fs::create_dir_all(&dir)?;
    for (name, img) in [("line-art.png", synth::line_art_sample()), ("photo.png", synth::photo_sample())] {
        let path = dir.join(name);
        img.save(&path)?;
        println!("wrote {} ({}×{})", path.display(), img.width(), img.height());
    }
    Ok(())
}
