//! `plotter trace`: turn a PNG/JPEG into plottable paths (outline, centerline, edges or hatch) and write them as a
//! plain SVG in mm.
//!
//! [`TraceArgs`] holds every tracing flag as a `clap::Args` struct so that `preview`, `plot` and friends can
//! `#[command(flatten)]` it and load images with [`load_image_drawing`].

use std::path::{Path, PathBuf};

use anyhow::Result;
use clap::{Args, ValueEnum};
use plotter_path::Pen;
use plotter_path::input::raster::{self, HatchOptions, HatchScheme, Mode, Threshold, TraceOptions};
use plotter_path::output::svg_out::to_svg_string;

use crate::input::write_output;
use crate::layout_args::LayoutArgs;

/// Tracing mode as a command-line value.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum, Default)]
pub(crate) enum ModeArg {
    /// Closed outlines of the ink regions (with holes)
    #[default]
    Outline,
    /// One stroke along the middle of each line (line art)
    Centerline,
    /// Canny edges chained into polylines (photos)
    Edges,
    /// Hatch shading of the gray tones
    Hatch,
}

/// How darker hatch levels add lines.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum, Default)]
pub(crate) enum SchemeArg {
    /// Each level adds a direction (cross-hatching)
    #[default]
    Directions,
    /// Each level halves the spacing
    Density,
}

/// Image tracing flags (used by `trace`, and by any command that accepts PNG/JPEG input).
#[derive(Debug, Clone, Args)]
pub(crate) struct TraceArgs {
    /// What to extract from the image
    #[arg(long, value_enum, default_value_t = ModeArg::Outline, help_heading = "Image tracing")]
    pub(crate) mode: ModeArg,
    /// Drawing width in mm (the image is resampled to width / pitch pixels); default: one pitch per image pixel
    #[arg(long, help_heading = "Image tracing")]
    pub(crate) width: Option<f64>,
    /// Pixel pitch in mm (default: the pen width)
    #[arg(long, help_heading = "Image tracing")]
    pub(crate) pitch: Option<f64>,
    /// Pen width in mm
    #[arg(long, default_value_t = Pen::default().width_mm, help_heading = "Image tracing")]
    pub(crate) pen_width: f64,
    /// Ink threshold: `otsu` or a luma 0-255 (pixels darker than it are ink)
    #[arg(long, default_value = "otsu", help_heading = "Image tracing")]
    pub(crate) threshold: Threshold,
    /// Swap ink and paper (light drawing on dark background; hatch shades light tones)
    #[arg(long, help_heading = "Image tracing")]
    pub(crate) invert: bool,
    /// Gaussian blur sigma in pixels before thresholding (0 = off)
    #[arg(long, default_value_t = 0.0, help_heading = "Image tracing")]
    pub(crate) blur: f32,
    /// Path simplification tolerance in pixels (Ramer-Douglas-Peucker; 0 = off)
    #[arg(long, default_value_t = TraceOptions::default().simplify_px, help_heading = "Image tracing")]
    pub(crate) simplify: f64,
    /// Drop regions and holes smaller than this, square pixels
    #[arg(long, default_value_t = TraceOptions::default().min_area_px, help_heading = "Image tracing")]
    pub(crate) min_area: f64,
    /// Drop strokes and edge chains shorter than this, pixels
    #[arg(long, default_value_t = TraceOptions::default().min_length_px, help_heading = "Image tracing")]
    pub(crate) min_length: f64,
    /// Canny low hysteresis threshold (edges mode)
    #[arg(long, default_value_t = TraceOptions::default().canny_low, help_heading = "Image tracing")]
    pub(crate) canny_low: f32,
    /// Canny high hysteresis threshold (edges mode)
    #[arg(long, default_value_t = TraceOptions::default().canny_high, help_heading = "Image tracing")]
    pub(crate) canny_high: f32,
    /// Number of hatched gray levels, 1-8 (hatch mode)
    #[arg(long, default_value_t = HatchOptions::default().levels, help_heading = "Image tracing")]
    pub(crate) levels: u8,
    /// Hatch line spacing in mm (hatch mode)
    #[arg(long, default_value_t = HatchOptions::default().spacing_mm, help_heading = "Image tracing")]
    pub(crate) spacing: f64,
    /// Hatch base angle in degrees, counter-clockwise (hatch mode)
    #[arg(long, default_value_t = HatchOptions::default().angle_deg, allow_negative_numbers = true, help_heading = "Image tracing")]
    pub(crate) angle: f64,
    /// How darker hatch levels add lines (hatch mode)
    #[arg(long, value_enum, default_value_t = SchemeArg::Directions, help_heading = "Image tracing")]
    pub(crate) hatch_scheme: SchemeArg,
}

impl TraceArgs {
    /// The library options these flags mean.
    pub(crate) fn options(&self) -> TraceOptions {
        TraceOptions {
            mode: match self.mode {
                ModeArg::Outline => Mode::Outline,
                ModeArg::Centerline => Mode::Centerline,
                ModeArg::Edges => Mode::Edges,
                ModeArg::Hatch => Mode::Hatch,
            },
            width_mm: self.width,
            pitch_mm: self.pitch,
            pen: Pen { width_mm: self.pen_width, ..Pen::default() },
            blur_px: self.blur,
            threshold: self.threshold,
            invert: self.invert,
            simplify_px: self.simplify,
            min_area_px: self.min_area,
            min_length_px: self.min_length,
            canny_low: self.canny_low,
            canny_high: self.canny_high,
            hatch: HatchOptions {
                levels: self.levels,
                spacing_mm: self.spacing,
                angle_deg: self.angle,
                scheme: match self.hatch_scheme {
                    SchemeArg::Directions => HatchScheme::Directions,
                    SchemeArg::Density => HatchScheme::Density,
                },
            },
        }
    }
}

/// Trace the image at `path` with `args`, printing the tracer's warnings to stderr. `traced.drawing` is the result
/// in mm (origin at the image's top-left corner, `page_mm` = the image size), ready for layout.
pub(crate) fn trace_image(path: &Path, args: &TraceArgs) -> Result<raster::Traced> {
    let traced = raster::trace_file(path, &args.options())?;
    for w in &traced.warnings {
        eprintln!("warning: {}: {w}", path.display());
    }
    Ok(traced)
}

/// Trace a raster image into paths and write them as a plain SVG.
#[derive(Debug, Args)]
pub(crate) struct TraceCmdArgs {
    /// Input image (PNG or JPEG)
    pub(crate) input: PathBuf,
    /// Output SVG (`-` writes stdout)
    #[arg(short, long)]
    pub(crate) output: PathBuf,
    #[command(flatten)]
    pub(crate) trace: TraceArgs,
    #[command(flatten)]
    pub(crate) layout: LayoutArgs,
}

/// Run `plotter trace`.
pub(crate) fn run(args: &TraceCmdArgs) -> Result<()> {
    let traced = trace_image(&args.input, &args.trace)?;
    let mut drawing = traced.drawing;
    let (paths, length) = (drawing.path_count(), drawing.paths().map(|p| p.length()).sum::<f64>());
    args.layout.apply(&mut drawing)?;
    write_output(&args.output, to_svg_string(&drawing).as_bytes())?;
    eprintln!(
        "traced {} ({}×{} px at {:.3} mm/px, {}): {paths} paths, {length:.0} mm pen-down",
        args.input.display(),
        traced.size_px.0,
        traced.size_px.1,
        traced.pixel_mm,
        args.trace.options().mode
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Wrap {
        #[command(flatten)]
        cmd: TraceCmdArgs,
    }

    fn sample(name: &str) -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../samples").join(name)
    }

    #[test]
    fn flags_map_to_options() {
        let w = Wrap::try_parse_from([
            "trace",
            "in.png",
            "-o",
            "out.svg",
            "--mode",
            "hatch",
            "--width",
            "120",
            "--threshold",
            "100",
            "--invert",
            "--levels",
            "3",
            "--spacing",
            "0.8",
            "--angle",
            "-30",
            "--hatch-scheme",
            "density",
            "--paper",
            "a4",
        ])
        .unwrap();
        let o = w.cmd.trace.options();
        assert_eq!(o.mode, Mode::Hatch);
        assert_eq!(o.width_mm, Some(120.0));
        assert_eq!(o.threshold, Threshold::Fixed(100));
        assert!(o.invert);
        assert_eq!(
            o.hatch,
            HatchOptions { levels: 3, spacing_mm: 0.8, angle_deg: -30.0, scheme: HatchScheme::Density }
        );
        assert_eq!(w.cmd.layout.paper.as_deref(), Some("a4"));
        assert!(Wrap::try_parse_from(["trace", "in.png", "-o", "x.svg", "--threshold", "dark"]).is_err());
        assert!(Wrap::try_parse_from(["trace", "in.png", "-o", "x.svg", "--mode", "sketch"]).is_err());
    }

    #[test]
    fn traces_the_line_art_sample_to_svg() {
        let out = std::env::temp_dir().join(format!("plotter-trace-test-{}.svg", std::process::id()));
        let w = Wrap::try_parse_from([
            "trace",
            sample("line-art.png").to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--mode",
            "centerline",
            "--width",
            "160",
        ])
        .unwrap();
        run(&w.cmd).unwrap();
        let svg = std::fs::read_to_string(&out).unwrap();
        std::fs::remove_file(&out).ok();
        assert!(
            svg.contains("<svg") && svg.matches("<polyline").count() + svg.matches("<polygon").count() >= 20,
            "{svg}"
        );
    }

    #[test]
    fn non_image_input_is_a_clear_error() {
        let w = Wrap::try_parse_from(["trace", sample("xy-plotter.toml").to_str().unwrap(), "-o", "-"]).unwrap();
        let e = run(&w.cmd).unwrap_err().to_string();
        assert!(e.contains("xy-plotter.toml") && e.contains("not a PNG or JPEG"), "{e}");
    }
}
