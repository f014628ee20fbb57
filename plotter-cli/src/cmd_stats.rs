//! `plotter stats`: path/segment counts, pen-down and pen-up length, pen lifts, bounding box (text or JSON).

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use plotter_path::stats::Stats;

use plotter_path::MachineProfile;

use crate::input::{InputArgs, load_drawing};
use crate::layout_args::LayoutArgs;

/// Print figures about a drawing.
#[derive(Debug, Args)]
pub(crate) struct StatsArgs {
    /// Input drawing (SVG; `-` reads stdin)
    pub(crate) input: PathBuf,
    /// Print JSON (keys: layers, paths, segments, pen_down_mm, pen_up_mm, pen_lifts, bbox_mm, layer_names)
    #[arg(long)]
    pub(crate) json: bool,
    #[command(flatten)]
    pub(crate) input_args: InputArgs,
    #[command(flatten)]
    pub(crate) layout: LayoutArgs,
}

/// Run `plotter stats`.
pub(crate) fn run(args: &StatsArgs) -> Result<()> {
    let mut drawing = load_drawing(&args.input, &args.input_args, &MachineProfile::default_plotter())?;
    args.layout.apply(&mut drawing)?;
    let stats = Stats::of(&drawing);
    let names: Vec<&str> = drawing.layers.iter().map(|l| l.name.as_str()).collect();
    if args.json {
        let mut value = serde_json::to_value(&stats)?;
        value["layer_names"] = serde_json::json!(names);
        println!("{}", serde_json::to_string_pretty(&value)?);
    } else {
        println!("{stats}");
        println!("layer names   {}", names.join(", "));
    }
    Ok(())
}
