//! `plotter`: drive an XY pen plotter (or its built-in simulator) from SVGs, images and parametric curves.

mod cmd_bench;
mod cmd_console;
mod cmd_home;
mod cmd_jog;
mod cmd_plot;
mod cmd_sim;
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
    /// Run the simulated firmware on a pseudo-terminal (`--pty`) and print its device path.
    Sim(cmd_sim::SimArgs),
    /// Home a connected plotter.
    Home(cmd_home::LinkArgs),
    /// Move an axis by a distance, or lift/lower the pen.
    Jog(cmd_jog::JogArgs),
    /// Type G-code to a connected plotter and see its replies.
    Console(cmd_home::LinkArgs),
    /// Benchmark the serial link on a dense drawing (simulated 115200-baud link).
    #[command(hide = true)]
    BenchLink(cmd_bench::BenchArgs),
}

fn main() -> anyhow::Result<()> {
    let cli = Cli::parse();
    match cli.command {
        Command::Plot(a) => cmd_plot::run(&a),
        Command::Sim(a) => cmd_sim::run(&a),
        Command::Home(a) => cmd_home::run(&a),
        Command::Jog(a) => cmd_jog::run(&a),
        Command::Console(a) => cmd_console::run(&a),
        Command::BenchLink(a) => cmd_bench::run(&a),
    }
}
