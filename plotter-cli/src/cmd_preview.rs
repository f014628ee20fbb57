//! `plotter preview`: render a drawing as a PNG (paper, strokes per layer colour, optional travel overlay).

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use plotter_path::preview::{PreviewOptions, render_png};

use plotter_path::MachineProfile;

use crate::input::{InputArgs, load_drawing, write_output};
use crate::layout_args::LayoutArgs;

/// Render a drawing as a preview PNG.
#[derive(Debug, Args)]
pub(crate) struct PreviewArgs {
    /// Input drawing (SVG; `-` reads stdin)
    pub(crate) input: PathBuf,
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
    pub(crate) input_args: InputArgs,
    #[command(flatten)]
    pub(crate) layout: LayoutArgs,
}

/// Run `plotter preview`.
pub(crate) fn run(args: &PreviewArgs) -> Result<()> {
    let mut drawing = load_drawing(&args.input, &args.input_args, &MachineProfile::default_plotter())?;
    args.layout.apply(&mut drawing)?;
    let options = PreviewOptions { dpi: args.dpi, width_px: args.width_px, travel: args.travel, ..Default::default() };
    let png = render_png(&drawing, &options)?;
    write_output(&args.output, &png)
}
