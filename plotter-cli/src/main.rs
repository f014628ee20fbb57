//! `plotter`: drive an XY pen plotter (or its built-in simulator) from SVGs, images and parametric curves.

mod cmd_plot;
mod link;

use clap::{Parser, Subcommand};

/// Pen-plotter controller: preview, measure, convert and plot drawings.
#[derive(Parser)]
#[command(name = "plotter", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Plot a drawing on the simulated plotter (default) or a serial plotter (--port).
    Plot(cmd_plot::PlotArgs),
}

fn main() -> anyhow::Result<()> {
    let cli = Cli::parse();
    match cli.command {
        Command::Plot(a) => cmd_plot::run(&a),
    }
}
