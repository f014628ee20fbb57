//! `plotter preview`: render a drawing as a PNG (paper, strokes per layer colour, optional travel overlay), in
//! the order it would be plotted (optimised unless `--no-optimize`).

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use plotter_path::MachineProfile;
use plotter_path::output::preview::{PreviewOptions, render_png};

use plotter_host::input::{Source, write_output};
use plotter_host::options::optimize::{OptimizeArgs, optimize_quietly};

/// Render a drawing as a preview PNG.
#[derive(Debug, Args)]
pub(crate) struct PreviewArgs {
    #[command(flatten)]
    pub(crate) source: Source,
    /// Output PNG (`-` writes stdout)
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
    let profile = MachineProfile::default_plotter();
    let mut drawing = args.source.load(&profile)?;
    optimize_quietly(&mut drawing, &args.optimize, None)?;
    // Every line at the width of the pen that plots it, not the file's stroke width.
    plotter_path::output::preview::use_plotting_pens(&mut drawing, &profile);
    let options = PreviewOptions { dpi: args.dpi, width_px: args.width_px, travel: args.travel, ..Default::default() };
    if let Some(note) = plotter_path::output::preview::reduction_note(&drawing, &options) {
        eprintln!("note: {note}");
    }
    let png = render_png(&drawing, &options)?;
    write_output(&args.output, &png)
}
