//! `plotter preview`: render a drawing as a PNG (paper, strokes per layer colour, optional travel overlay), or as
//! an SVG of the same strokes (with the travel as a dashed layer), in the order it would be plotted (optimised
//! unless `--no-optimize`).
//!
//! The file name says what is written: [`Written::of`] reads the extension for `preview`, `convert` and
//! `optimize` alike, and refuses one a command does not write instead of writing another format under it.

use std::path::{Path, PathBuf};

use anyhow::Result;
use clap::Args;
use plotter_path::MachineProfile;
use plotter_path::geometry::travel::pen_up_moves;
use plotter_path::output::preview::{PreviewOptions, render_png};
use plotter_path::output::svg_out::{gzip, to_preview_svg};

use plotter_host::input::{Source, write_output};
use plotter_host::options::optimize::{OptimizeArgs, optimize_quietly};

/// The formats a drawing is written in, told by the output file's name.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Written {
    /// `.png`: the preview's raster image.
    Png,
    /// `.svg`: plain SVG polylines in millimetres.
    Svg,
    /// `.svgz`: the same SVG, gzip-compressed.
    Svgz,
}

impl Written {
    /// The format `out` names for `command` by its extension (any case): `.png`, `.svg` or `.svgz`; `on_stdout`
    /// for `-`. Any other name is refused with the extensions that are written.
    pub(crate) fn of(out: &Path, command: &str, on_stdout: Written) -> Result<Written> {
        if out.as_os_str() == "-" {
            return Ok(on_stdout);
        }
        let ext = out.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
        match ext.as_deref() {
            Some("png") => Ok(Written::Png),
            Some("svg") => Ok(Written::Svg),
            Some("svgz") => Ok(Written::Svgz),
            _ => {
                let stdout = match on_stdout {
                    Written::Png => "a PNG",
                    Written::Svg => "an SVG",
                    Written::Svgz => "a gzipped SVG",
                };
                anyhow::bail!(
                    "{command}: cannot tell what to write from the name {}: {command} writes .svg, .svgz or .png \
                     files (chosen by the extension), or `-` for {stdout} on stdout",
                    out.display()
                )
            }
        }
    }
}

/// Write `drawing` to `out` as `format` says: the SVG of [`to_svg_string`](plotter_path::output::svg_out), gzipped
/// for `.svgz`, or the preview's PNG at its default resolution.
pub(crate) fn write_drawing(drawing: &plotter_path::Drawing, out: &Path, format: Written) -> Result<()> {
    let svg = || plotter_path::output::svg_out::to_svg_string(drawing);
    match format {
        Written::Svg => write_output(out, svg().as_bytes()),
        Written::Svgz => write_output(out, &gzip(&svg())),
        Written::Png => write_output(out, &render_png(drawing, &PreviewOptions::default())?),
    }
}

/// Render a drawing as a preview PNG or SVG.
#[derive(Debug, Args)]
pub(crate) struct PreviewArgs {
    #[command(flatten)]
    pub(crate) source: Source,
    /// Output file: .png for an image, .svg (or .svgz) for the same strokes as SVG, the travel as a dashed layer;
    /// `-` writes a PNG to stdout
    #[arg(short, long)]
    pub(crate) output: PathBuf,
    /// Overlay the pen-up travel as thin dashed lines
    #[arg(long)]
    pub(crate) travel: bool,
    /// Resolution, pixels per inch
    #[arg(long, default_value_t = 96.0)]
    pub(crate) dpi: f64,
    /// Output width in pixels (overrides --dpi)
    #[arg(long)]
    pub(crate) width_px: Option<u32>,
    #[command(flatten)]
    pub(crate) optimize: OptimizeArgs,
}

/// Run `plotter preview`.
pub(crate) fn run(args: &PreviewArgs) -> Result<()> {
    // Refused before the drawing is loaded: a wrong name costs nothing.
    let format = Written::of(&args.output, "preview", Written::Png)?;
    let profile = MachineProfile::default_plotter();
    let mut drawing = args.source.load(&profile)?;
    optimize_quietly(&mut drawing, &args.optimize, None)?;
    // Every line at the width of the pen that plots it, not the file's stroke width.
    plotter_path::output::preview::use_plotting_pens(&mut drawing, &profile);
    let options = PreviewOptions { dpi: args.dpi, width_px: args.width_px, travel: args.travel, ..Default::default() };
    if format != Written::Png {
        let travel = if args.travel { pen_up_moves(&drawing) } else { Vec::new() };
        let svg = to_preview_svg(&drawing, &travel, options.travel_color);
        let bytes = if format == Written::Svgz { gzip(&svg) } else { svg.into_bytes() };
        return write_output(&args.output, &bytes);
    }
    if let Some(note) = plotter_path::output::preview::reduction_note(&drawing, &options) {
        eprintln!("note: {note}");
    }
    let png = render_png(&drawing, &options)?;
    write_output(&args.output, &png)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_name_says_the_format() {
        let of = |name: &str| Written::of(Path::new(name), "convert", Written::Svg);
        assert_eq!(of("flat.png").unwrap(), Written::Png);
        assert_eq!(of("FLAT.SVG").unwrap(), Written::Svg);
        assert_eq!(of("a.b/flat.svgz").unwrap(), Written::Svgz);
        assert_eq!(of("-").unwrap(), Written::Svg);
        assert_eq!(
            of("flat.pdf").unwrap_err().to_string(),
            "convert: cannot tell what to write from the name flat.pdf: convert writes .svg, .svgz or .png files \
             (chosen by the extension), or `-` for an SVG on stdout"
        );
        assert!(of("flat").is_err());
    }
}
