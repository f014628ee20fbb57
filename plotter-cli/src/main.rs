//! `plotter`: drive an XY pen plotter (or its built-in simulator) from SVGs, images and parametric curves.

use clap::{Parser, Subcommand};

/// Pen-plotter controller: preview, measure, convert and plot drawings.
#[derive(Parser)]
#[command(name = "plotter", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {}

fn main() -> anyhow::Result<()> {
    let cli = Cli::parse();
    match cli.command {}
}
