//! `plotter convert`: write the flattened, laid-out drawing as a plain SVG of polylines in millimetres (or, for an
//! output named .png, the preview's image of it; .svgz gzipped), in the input's own order (`plotter optimize`
//! writes it reordered).

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use plotter_path::MachineProfile;

use plotter_host::input::Source;

/// Flatten and lay out a drawing, then write it as plain SVG polylines in mm (or a PNG image).
#[derive(Debug, Args)]
pub(crate) struct ConvertArgs {
    #[command(flatten)]
    pub(crate) source: Source,
    /// Output file: .svg (or .svgz, gzipped) for plain SVG polylines in mm, .png for a preview image; `-`
    /// writes SVG to stdout
    #[arg(short, long)]
    pub(crate) output: PathBuf,
}

/// Run `plotter convert`.
pub(crate) fn run(args: &ConvertArgs) -> Result<()> {
    let format = crate::cmd::preview::Written::of(&args.output, "convert", crate::cmd::preview::Written::Svg)?;
    let drawing = args.source.load(&MachineProfile::default_plotter())?;
    crate::cmd::preview::write_drawing(&drawing, &args.output, format)
}
