//! The tone measure: how true plots are to their picture, as a person sees them (see
//! `plotter_path::input::raster::fidelity`).
//!
//! Run by `plotter-path/benches/tone_bench/run.sh`, which makes the pictures and the plots (ours and the peers'),
//! or by hand:
//!
//! ```text
//! cargo bench -p plotter-path --bench tone -- --picture gray.png [--width 180] [--pen 0.3] [--sigma 1]
//!     [--out DIR] LABEL=plot.svg ...
//! ```
//!
//! Each plot's page is scaled to `--width` mm (the page is the picture), its lines rendered at `--pen` mm in black
//! on white, and compared with the picture after a Gaussian blur of `--sigma` mm in CIE L*. One tab-separated line
//! per plot: label, L* error, SSIM, ink in metres, paths. With `--out`, each plot is also written there scaled
//! (`LABEL.svg`), ready for `plotter stats`; with `--png DIR`, the plot as the measure renders it (`LABEL.png`, one
//! pixel per analysis cell, before the blur).

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use plotter_path::input::raster::fidelity::{MeasureOptions, measure, plot_reflectance};
use plotter_path::input::svg::{SvgOptions, load_svg};
use plotter_path::kurbo::{Affine, Point};

struct Args {
    picture: PathBuf,
    opts: MeasureOptions,
    out: Option<PathBuf>,
    png: Option<PathBuf>,
    plots: Vec<(String, PathBuf)>,
}

fn parse() -> Result<Args, String> {
    let mut picture = None;
    let mut opts = MeasureOptions::default();
    let mut out = None;
    let mut png = None;
    let mut plots = Vec::new();
    let mut it = std::env::args().skip(1);
    let number = |flag: &str, v: Option<String>| -> Result<f64, String> {
        let v = v.ok_or_else(|| format!("{flag} needs a value"))?;
        v.parse::<f64>()
            .ok()
            .filter(|x| x.is_finite() && *x > 0.0)
            .ok_or_else(|| format!("{flag} {v}: expected a positive number of mm"))
    };
    while let Some(a) = it.next() {
        match a.as_str() {
            "--bench" => {}
            "--picture" => picture = it.next().map(PathBuf::from),
            "--width" => opts.width_mm = number("--width", it.next())?,
            "--pen" => opts.pen_mm = number("--pen", it.next())?,
            "--sigma" => opts.sigma_mm = number("--sigma", it.next())?,
            "--out" => out = it.next().map(PathBuf::from),
            "--png" => png = it.next().map(PathBuf::from),
            _ => {
                let (label, file) =
                    a.split_once('=').ok_or_else(|| format!("`{a}`: expected LABEL=plot.svg or a flag"))?;
                plots.push((label.to_owned(), PathBuf::from(file)));
            }
        }
    }
    let picture = picture.ok_or("--picture gray.png is required")?;
    Ok(Args { picture, opts, out, png, plots })
}

fn run(args: &Args) -> Result<(), String> {
    let picture = image::open(&args.picture).map_err(|e| format!("{}: {e}", args.picture.display()))?.to_luma8();
    let svg_opts = SvgOptions::default();
    println!("label\tlightness_error\tssim\tink_m\tpaths");
    for (label, file) in &args.plots {
        let shown = file.display();
        let imported = match load_svg(file, &svg_opts) {
            Ok(i) => i,
            Err(e) => {
                eprintln!("{label}: {shown}: {e}");
                continue;
            }
        };
        let mut drawing = imported.drawing;
        let Some((page_w, _)) = drawing.page_mm.filter(|p| p.0 > 0.0) else {
            eprintln!("{label}: {shown}: no page size, cannot align it with the picture");
            continue;
        };
        let k = args.opts.width_mm / page_w;
        let scale = Affine::scale(k);
        for p in drawing.paths_mut() {
            for q in &mut p.points {
                *q = scale * *q;
            }
        }
        let height = args.opts.width_mm * f64::from(picture.height()) / f64::from(picture.width());
        drawing.page_mm = Some((args.opts.width_mm, height));
        let strokes: Vec<Vec<Point>> = drawing.paths().map(|p| p.points.clone()).collect();
        let f = measure(&strokes, &picture, &args.opts);
        println!("{label}\t{:.4}\t{:.4}\t{:.2}\t{}", f.lightness_error, f.ssim, f.ink_m, strokes.len());
        if let Some(dir) = &args.png {
            let r = plot_reflectance(&strokes, &picture, &args.opts);
            let path = Path::new(dir).join(format!("{label}.png"));
            #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)] // reflectance in [0, 1]
            let bytes: Vec<u8> = r.data.iter().map(|&v| (v.clamp(0.0, 1.0) * 255.0).round() as u8).collect();
            let (Ok(w), Ok(h)) = (u32::try_from(r.columns), u32::try_from(r.rows)) else { continue };
            image::GrayImage::from_raw(w, h, bytes)
                .ok_or("bad preview size")?
                .save(&path)
                .map_err(|e| format!("{}: {e}", path.display()))?;
        }
        if let Some(dir) = &args.out {
            let path = Path::new(dir).join(format!("{label}.svg"));
            let text = plotter_path::output::svg_out::to_svg_string(&drawing);
            std::fs::write(&path, text).map_err(|e| format!("{}: {e}", path.display()))?;
        }
    }
    Ok(())
}

fn main() -> ExitCode {
    match parse().and_then(|a| run(&a)) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("tone bench: {e}");
            ExitCode::FAILURE
        }
    }
}
