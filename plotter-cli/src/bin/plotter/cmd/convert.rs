//! `plotter convert`: write the flattened, laid-out drawing as a plain SVG of polylines in millimetres, in the
//! input's own order (`plotter optimize` writes it reordered).

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use plotter_path::MachineProfile;
use plotter_path::output::svg_out::to_svg_string;

use plotter_host::input::{Source, write_output};

/// Flatten and lay out a drawing, then write it as plain SVG polylines in mm.
#[derive(Debug, Args)]
pub(crate) struct ConvertArgs {
    #[command(flatten)]
    pub(crate) source: Source,
    /// Output SVG (`-` writes stdout)
    #[arg(short, long)]
    pub(crate) output: PathBuf,
}

/// Run `plotter convert`.
pub(crate) fn run(args: &ConvertArgs) -> Result<()> {
    let drawing = args.source.load(&MachineProfile::default_plotter())?;
    write_output(&args.output, to_svg_string(&drawing).as_bytes())
}
