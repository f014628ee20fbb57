//! The fill tone bench: how true an SVG's filled shapes plot to their colours, as a person sees them — outlines
//! only, one hatch spacing for every fill (`--hatch 0.8`), and each fill hatched by its lightness (`--hatch tone`).
//!
//! Run by `plotter-path/benches/fills.sh` over openclipart drawings, or by hand:
//!
//! ```text
//! cargo bench -p plotter-path --bench fills -- [--width 180] [--pen 0.3] [--sigma 1] [--cell 0.1] DRAWING.svg ...
//! ```
//!
//! Each drawing is laid out `--width` mm wide (hatch spacings and the pen are page sizes, so the import is given
//! them divided by the layout's factor, as the `plotter` loader does). The reference is `rsvg-convert`'s rendering
//! of the drawing on white at `--cell` mm per pixel, in linear luminance (its grey); the plot is its lines drawn at
//! the pen's width in black on white (opaque ink: overlaps do not darken further). Both are blurred with the same
//! Gaussian (`--sigma` mm: the eye at reading distance) and compared in CIE L*: the mean |ΔL*| / 100 over the
//! page, and over the drawn part of it (pixels where either side is darker than L* 99.5), with the ink length.
//! The drawn part's error is also split by sign: `too_dark` is the mean of (L* wanted − L* plotted) where the plot
//! is darker than the picture, `too_light` where it is lighter (both / 100, over all drawn pixels, so they add up
//! to `error_drawn`). One tab-separated line per drawing and method. `--dump DIR` writes, per drawing and method,
//! the blurred picture and plot as PNGs, the plot's ink unblurred, and a map of the signed error (red: plot too dark, blue: too light).

// Pixel counts and indices of a page-sized picture: far inside every integer type.
#![allow(
    clippy::cast_possible_truncation,
    clippy::cast_precision_loss,
    clippy::cast_sign_loss,
    clippy::cast_possible_wrap
)]

use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};

use plotter_path::geometry::hatch::FillHatch;
use plotter_path::geometry::tone_hatch::ToneHatch;
use plotter_path::input::raster::ink::InkGrid;
use plotter_path::input::raster::tone::{lightness_cie, srgb_to_linear};
use plotter_path::input::svg::{SvgOptions, load_svg};
use plotter_path::kurbo::Point;

struct Args {
    width_mm: f64,
    pen_mm: f64,
    sigma_mm: f64,
    cell_mm: f64,
    spacing_mm: f64,
    dump: Option<PathBuf>,
    files: Vec<PathBuf>,
}

fn parse() -> Result<Args, String> {
    let mut a = Args {
        width_mm: 180.0,
        pen_mm: 0.3,
        sigma_mm: 1.0,
        cell_mm: 0.1,
        spacing_mm: 0.8,
        dump: None,
        files: Vec::new(),
    };
    let mut it = std::env::args().skip(1);
    let number = |flag: &str, v: Option<String>| -> Result<f64, String> {
        let v = v.ok_or_else(|| format!("{flag} needs a value"))?;
        v.parse::<f64>()
            .ok()
            .filter(|x| x.is_finite() && *x > 0.0)
            .ok_or_else(|| format!("{flag} {v}: expected a positive number of mm"))
    };
    while let Some(arg) = it.next() {
        match arg.as_str() {
            "--bench" => {}
            "--width" => a.width_mm = number("--width", it.next())?,
            "--pen" => a.pen_mm = number("--pen", it.next())?,
            "--sigma" => a.sigma_mm = number("--sigma", it.next())?,
            "--cell" => a.cell_mm = number("--cell", it.next())?,
            "--spacing" => a.spacing_mm = number("--spacing", it.next())?,
            "--dump" => a.dump = Some(PathBuf::from(it.next().ok_or("--dump needs a folder")?)),
            f if f.starts_with("--") => return Err(format!("unknown flag {f}")),
            f => a.files.push(PathBuf::from(f)),
        }
    }
    if a.files.is_empty() {
        return Err("name at least one SVG drawing".into());
    }
    Ok(a)
}

/// A grey picture in linear luminance (0 = black, 1 = white), row by row.
struct Grey {
    w: usize,
    h: usize,
    y: Vec<f64>,
}

/// `rsvg-convert`'s rendering of `file` on white at `w × h` pixels, as linear luminance.
fn reference(file: &Path, w: usize, h: usize) -> Result<Grey, String> {
    let out = Command::new("rsvg-convert")
        .args(["-b", "white", "-w", &w.to_string(), "-h", &h.to_string(), "-f", "png"])
        .arg(file)
        .output()
        .map_err(|e| format!("rsvg-convert: {e} (install librsvg2-bin)"))?;
    if !out.status.success() {
        return Err(format!("rsvg-convert: {}", String::from_utf8_lossy(&out.stderr).trim()));
    }
    let img = image::load_from_memory(&out.stdout).map_err(|e| format!("rsvg-convert's PNG: {e}"))?.to_rgb8();
    let (iw, ih) = (img.width() as usize, img.height() as usize);
    let mut y = vec![1.0; w * h];
    for (x, yy, p) in img.enumerate_pixels() {
        let (x, yy) = (x as usize, yy as usize);
        if x < w && yy < h && x < iw && yy < ih {
            let c = p.0.map(|v| srgb_to_linear(f64::from(v) / 255.0));
            y[yy * w + x] = 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
        }
    }
    Ok(Grey { w, h, y })
}

/// Separable Gaussian blur of standard deviation `sigma` pixels, edges extended.
fn blur(g: &Grey, sigma: f64) -> Vec<f64> {
    let r = (3.0 * sigma).ceil() as isize;
    let k: Vec<f64> = (-r..=r).map(|i| (-(i * i) as f64 / (2.0 * sigma * sigma)).exp()).collect();
    let sum: f64 = k.iter().sum();
    let k: Vec<f64> = k.iter().map(|v| v / sum).collect();
    let (w, h) = (g.w as isize, g.h as isize);
    let mut tmp = vec![0.0; g.y.len()];
    for y in 0..h {
        for x in 0..w {
            let mut s = 0.0;
            for (j, kv) in k.iter().enumerate() {
                let xx = (x + j as isize - r).clamp(0, w - 1);
                s += kv * g.y[(y * w + xx) as usize];
            }
            tmp[(y * w + x) as usize] = s;
        }
    }
    let mut out = vec![0.0; g.y.len()];
    for y in 0..h {
        for x in 0..w {
            let mut s = 0.0;
            for (j, kv) in k.iter().enumerate() {
                let yy = (y + j as isize - r).clamp(0, h - 1);
                s += kv * tmp[(yy * w + x) as usize];
            }
            out[(y * w + x) as usize] = s;
        }
    }
    out
}

/// How far a plot's lightness is from its picture's, each / 100.
struct Errors {
    /// Mean |ΔL*| over the page.
    page: f64,
    /// Mean |ΔL*| over the drawn pixels.
    drawn: f64,
    /// The part of `drawn` where the plot is darker.
    too_dark: f64,
    /// The part of `drawn` where the plot is lighter.
    too_light: f64,
}

/// The error of plot `a` against picture `b` (both linear luminance).
fn lightness_error(a: &[f64], b: &[f64]) -> Errors {
    let (mut page, mut dark, mut light, mut n_drawn) = (0.0, 0.0, 0.0, 0usize);
    for (&x, &y) in a.iter().zip(b) {
        let (la, lb) = (lightness_cie(x.clamp(0.0, 1.0)), lightness_cie(y.clamp(0.0, 1.0)));
        let d = (la - lb) / 100.0;
        page += d.abs();
        if la < 99.5 || lb < 99.5 {
            if d < 0.0 {
                dark -= d;
            } else {
                light += d;
            }
            n_drawn += 1;
        }
    }
    let n = n_drawn.max(1) as f64;
    Errors { page: page / a.len() as f64, drawn: (dark + light) / n, too_dark: dark / n, too_light: light / n }
}

/// Writes `y` (linear luminance) as a grey PNG.
fn write_grey(path: &Path, w: usize, h: usize, y: &[f64]) -> Result<(), String> {
    let img = image::GrayImage::from_fn(w as u32, h as u32, |x, yy| {
        let v = y[yy as usize * w + x as usize].clamp(0.0, 1.0);
        let s = if v <= 0.003_130_8 { 12.92 * v } else { 1.055 * v.powf(1.0 / 2.4) - 0.055 };
        image::Luma([(s * 255.0).round() as u8])
    });
    img.save(path).map_err(|e| format!("{}: {e}", path.display()))
}

/// Writes the signed lightness error of `plot` against `picture` as a PNG: red where the plot is darker, blue
/// where it is lighter, full colour at 25 L*.
fn write_error(path: &Path, w: usize, h: usize, plot: &[f64], picture: &[f64]) -> Result<(), String> {
    let img = image::RgbImage::from_fn(w as u32, h as u32, |x, yy| {
        let i = yy as usize * w + x as usize;
        let d = (lightness_cie(plot[i].clamp(0.0, 1.0)) - lightness_cie(picture[i].clamp(0.0, 1.0))) / 25.0;
        let k = (d.abs().min(1.0) * 255.0).round() as u8;
        if d < 0.0 { image::Rgb([255, 255 - k, 255 - k]) } else { image::Rgb([255 - k, 255 - k, 255]) }
    });
    img.save(path).map_err(|e| format!("{}: {e}", path.display()))
}

fn run(args: &Args) -> Result<(), String> {
    println!("drawing\tmethod\terror_page\terror_drawn\ttoo_dark\ttoo_light\tink_m\tstrokes\tseconds");
    if let Some(dir) = &args.dump {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    }
    for file in &args.files {
        let name = file.file_stem().map_or_else(|| file.display().to_string(), |s| s.to_string_lossy().into_owned());
        let plain = match load_svg(file, &SvgOptions::default()) {
            Ok(i) => i.drawing,
            Err(e) => {
                eprintln!("{name}: {e}");
                continue;
            }
        };
        let Some((page_w, page_h)) = plain.page_mm.filter(|p| p.0 > 0.0 && p.1 > 0.0) else {
            eprintln!("{name}: no page size");
            continue;
        };
        let k = args.width_mm / page_w;
        let (w, h) = ((args.width_mm / args.cell_mm).round() as usize, (page_h * k / args.cell_mm).round() as usize);
        let refr = match reference(file, w, h) {
            Ok(r) => r,
            Err(e) => {
                eprintln!("{name}: {e}");
                continue;
            }
        };
        let sigma_px = args.sigma_mm / args.cell_mm;
        let ref_blur = blur(&refr, sigma_px);
        if let Some(dir) = &args.dump {
            write_grey(&dir.join(format!("{name}.picture.png")), w, h, &ref_blur)?;
        }
        let methods: [(&str, SvgOptions); 3] = [
            ("outlines", SvgOptions::default()),
            (
                "hatch-0.8",
                SvgOptions {
                    hatch: Some(FillHatch { spacing_mm: args.spacing_mm / k, ..FillHatch::default() }),
                    ..SvgOptions::default()
                },
            ),
            (
                "hatch-tone",
                SvgOptions {
                    tone_hatch: Some(ToneHatch {
                        pen_mm: args.pen_mm / k,
                        min_spacing_mm: 1.5 * args.pen_mm / k,
                        angle_deg: 45.0,
                    }),
                    ..SvgOptions::default()
                },
            ),
        ];
        for (label, opts) in methods {
            let started = std::time::Instant::now();
            let d = match load_svg(file, &opts) {
                Ok(i) => i.drawing,
                Err(e) => {
                    eprintln!("{name} {label}: {e}");
                    continue;
                }
            };
            let secs = started.elapsed().as_secs_f64();
            let strokes: Vec<Vec<Point>> =
                d.paths().map(|p| p.points.iter().map(|q| Point::new(q.x * k, q.y * k)).collect()).collect();
            let ink_m: f64 =
                strokes.iter().flat_map(|s| s.windows(2)).map(|s| s[0].distance(s[1])).sum::<f64>() / 1000.0;
            let mut grid = InkGrid::new(w, h, args.cell_mm);
            grid.draw(&strokes, args.pen_mm);
            let plot = Grey { w, h, y: grid.ink.iter().map(|&i| if i { 0.0 } else { 1.0 }).collect() };
            let plot_blur = blur(&plot, sigma_px);
            let e = lightness_error(&plot_blur, &ref_blur);
            if let Some(dir) = &args.dump {
                write_grey(&dir.join(format!("{name}.{label}.png")), w, h, &plot_blur)?;
                write_grey(&dir.join(format!("{name}.{label}.ink.png")), w, h, &plot.y)?;
                write_error(&dir.join(format!("{name}.{label}.error.png")), w, h, &plot_blur, &ref_blur)?;
            }
            println!(
                "{name}\t{label}\t{:.4}\t{:.4}\t{:.4}\t{:.4}\t{ink_m:.1}\t{}\t{secs:.2}",
                e.page,
                e.drawn,
                e.too_dark,
                e.too_light,
                strokes.len()
            );
        }
    }
    Ok(())
}

fn main() -> ExitCode {
    match parse().and_then(|a| run(&a)) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("fills bench: {e}");
            ExitCode::FAILURE
        }
    }
}
