//! `plotter`: drive an XY pen plotter (or its built-in simulator) from SVGs, images and parametric curves.
//!
//! Each subcommand lives in its own `cmd_*.rs` file; flags shared by several commands (input, layout) are
//! `clap::Args` structs flattened into them.

mod cmd_convert;
mod cmd_optimize;
mod cmd_preview;
mod cmd_stats;
mod input;
mod layout_args;

use clap::{Parser, Subcommand};

/// Pen-plotter controller: preview, measure, convert and plot drawings.
///
/// SVG rule: every visible shape is plotted along its outline — stroked paths as their centre line, fill-only
/// shapes as the outline of the filled area. Shapes with neither fill nor stroke, and hidden elements, are skipped
/// with a warning. Text is drawn as glyph outlines.
#[derive(Parser)]
#[command(name = "plotter", version, about, long_about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a drawing as a preview PNG
    Preview(cmd_preview::PreviewArgs),
    /// Print figures about a drawing (paths, segments, pen-down/up length, lifts, bounding box)
    Stats(cmd_stats::StatsArgs),
    /// Write the flattened, laid-out drawing as a plain SVG of polylines in mm
    Convert(cmd_convert::ConvertArgs),
    /// Merge, reorder and reverse paths to cut pen-up travel; write plain SVG
    Optimize(cmd_optimize::OptimizeCmdArgs),
}

fn main() {
    let cli = Cli::parse();
    let result = match &cli.command {
        Command::Preview(args) => cmd_preview::run(args),
        Command::Stats(args) => cmd_stats::run(args),
        Command::Convert(args) => cmd_convert::run(args),
        Command::Optimize(args) => cmd_optimize::run(args),
    };
    if let Err(e) = result {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}
