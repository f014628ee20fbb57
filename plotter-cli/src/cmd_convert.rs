//! `plotter convert`: write the flattened, laid-out drawing as a plain SVG of polylines in millimetres.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use plotter_path::svg_out::to_svg_string;

use plotter_path::MachineProfile;

use crate::input::{InputArgs, load_drawing, write_output};
use crate::layout_args::LayoutArgs;

/// Flatten and lay out a drawing, then write it as plain SVG polylines in mm.
#[derive(Debug, Args)]
pub(crate) struct ConvertArgs {
    /// Input drawing (SVG; `-` reads stdin)
    pub(crate) input: PathBuf,
    /// Output SVG (`-` writes stdout)
    #[arg(short, long)]
    pub(crate) output: PathBuf,
    #[command(flatten)]
    pub(crate) input_args: InputArgs,
    #[command(flatten)]
    pub(crate) layout: LayoutArgs,
}

/// Run `plotter convert`.
pub(crate) fn run(args: &ConvertArgs) -> Result<()> {
    let mut drawing = load_drawing(&args.input, &args.input_args, &MachineProfile::default_plotter())?;
    args.layout.apply(&mut drawing)?;
    write_output(&args.output, to_svg_string(&drawing).as_bytes())
}
