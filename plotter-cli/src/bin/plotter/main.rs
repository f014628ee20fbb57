//! `plotter`: drive an XY pen plotter (or its built-in simulator) from SVGs, images and parametric curves.
//!
//! Each subcommand lives in its own file under `cmd/`; flags shared by several commands (input, layout) are
//! `clap::Args` structs flattened into them.

mod cmd;
mod serve;
mod sim_qemu;
mod time_parts;

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
    Preview(cmd::preview::PreviewArgs),
    /// Print figures about a drawing (paths, segments, pen-down/up length, lifts, bounding box)
    Stats(cmd::stats::StatsArgs),
    /// Write the flattened, laid-out drawing as a plain SVG of polylines in mm
    Convert(cmd::convert::ConvertArgs),
    /// Plot a drawing on the simulated plotter (default) or a serial plotter (--port)
    Plot(cmd::plot::PlotArgs),
    /// List the plots interrupted on a port (--list), or continue one where it stopped
    Resume(cmd::resume::ResumeArgs),
    /// Print slicer G-code (PrusaSlicer/Cura, Marlin flavour) on the simulated printer (default) or a serial one
    Print(cmd::print::PrintArgs),
    /// Run the simulated firmware (`--pty`) or the firmware image under QEMU (`--qemu`) on a pseudo-terminal and
    /// print its device path
    Sim(cmd::sim::SimArgs),
    /// Home a connected plotter
    Home(cmd::home::HomeArgs),
    /// Move an axis by a distance, or lift/lower the pen
    Jog(cmd::jog::JogArgs),
    /// Type G-code to a connected plotter and see its replies
    Console(plotter_host::link::connect::LinkArgs),
    /// Raise, lower or cycle the pen of a connected plotter
    Pen(cmd::manual::PenArgs),
    /// Turn a connected plotter's motors off (to push the carriage by hand) or on
    Motors(cmd::manual::MotorsArgs),
    /// Raise the pen and move back to the home corner, without a homing cycle
    WalkHome(plotter_host::link::connect::LinkArgs),
    /// Print the firmware's version of a connected plotter
    Version(plotter_host::link::connect::LinkArgs),
    /// List the machine models built in (for --model), with their work areas and speeds
    Models(cmd::models::ModelsArgs),
    /// Benchmark the serial link on a dense drawing (simulated 115200-baud link)
    #[command(hide = true)]
    BenchLink(cmd::bench::BenchArgs),
    /// Generate a parametric figure (roulettes, roses, Lissajous, spirals, Fourier outlines) as SVG or PNG
    Gen(cmd::generate::GenArgs),
    /// Trace a PNG/JPEG image into paths (outline, centerline, edges, hatch) and write a plain SVG
    Trace(cmd::trace::TraceCmdArgs),
    /// Merge, reorder and reverse paths to cut pen-up travel; write plain SVG
    Optimize(cmd::optimize::OptimizeCmdArgs),
    /// Run the local web app: drop a drawing on the page, plot it, watch it (http://127.0.0.1:8040/)
    Serve(cmd::serve::ServeArgs),
    /// Queue a drawing on a running studio (`plotter serve --machine ...`), list, cancel or wait for its jobs
    Queue(cmd::queue::QueueArgs),
}

fn main() {
    let cli = Cli::parse();
    if cli.command.only_prints() {
        quiet_on_closed_stdout();
    }
    let result = match &cli.command {
        Command::Preview(args) => cmd::preview::run(args),
        Command::Stats(args) => cmd::stats::run(args),
        Command::Convert(args) => cmd::convert::run(args),
        Command::Plot(args) => cmd::plot::run(args),
        Command::Resume(args) => cmd::resume::run(args),
        Command::Print(args) => cmd::print::run(args),
        Command::Sim(args) => cmd::sim::run(args),
        Command::Home(args) => cmd::home::run(args),
        Command::Jog(args) => cmd::jog::run(args),
        Command::Console(args) => cmd::console::run(args),
        Command::Pen(args) => cmd::manual::run_pen(args),
        Command::Motors(args) => cmd::manual::run_motors(args),
        Command::WalkHome(args) => cmd::manual::run_walk_home(args),
        Command::Version(args) => cmd::manual::run_version(args),
        Command::Models(args) => cmd::models::run(args),
        Command::BenchLink(args) => cmd::bench::run(args),
        Command::Gen(args) => cmd::generate::run(args),
        Command::Trace(args) => cmd::trace::run(args),
        Command::Optimize(args) => cmd::optimize::run(args),
        Command::Serve(args) => cmd::serve::run(args),
        Command::Queue(args) => cmd::queue::run(args),
    };
    if let Err(e) = result {
        eprintln!("error: {e:#}");
        std::process::exit(exit_status(&e));
    }
}

/// The exit status for an error, by what kind of trouble it is, so that a script can tell them apart:
/// 1 a bad input or anything else, 3 the machine refused a block, raised an alarm or restarted, 4 the link was lost,
/// nothing answered or the firmware is not the expected one, 5 the user stopped the plot. (0 is success and 2 a
/// command line clap refused.)
fn exit_status(e: &anyhow::Error) -> i32 {
    match plotter_host::Trouble::of(e) {
        plotter_host::Trouble::Other => 1,
        plotter_host::Trouble::Machine => 3,
        plotter_host::Trouble::Link => 4,
        plotter_host::Trouble::Stopped => 5,
    }
}

impl Command {
    /// Whether the command only reads files and prints (no machine, no server): such a command may simply end when
    /// its reader goes away, as `plotter stats FILE | head` expects.
    fn only_prints(&self) -> bool {
        matches!(
            self,
            Command::Preview(_)
                | Command::Stats(_)
                | Command::Convert(_)
                | Command::Gen(_)
                | Command::Trace(_)
                | Command::Optimize(_)
                | Command::Models(_)
        )
    }
}

/// End the process quietly, as Unix tools do, when standard output is a pipe whose reader has gone (`println!`
/// panics then). Only for commands that drive no machine: a plot must never stop half-way because its summary
/// could not be printed.
fn quiet_on_closed_stdout() {
    let default = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let message = info
            .payload()
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| info.payload().downcast_ref::<&str>().copied())
            .unwrap_or_default();
        if message.starts_with("failed printing to stdout") && message.contains("Broken pipe") {
            std::process::exit(0);
        }
        default(info);
    }));
}

#[cfg(test)]
mod tests {
    use clap::CommandFactory as _;

    /// Every option and argument of every subcommand, with the subcommand's name.
    fn every_arg() -> Vec<(String, clap::Arg)> {
        fn walk(cmd: &clap::Command, path: &str, out: &mut Vec<(String, clap::Arg)>) {
            for a in cmd.get_arguments() {
                out.push((path.to_string(), a.clone()));
            }
            for sub in cmd.get_subcommands() {
                walk(sub, &format!("{path} {}", sub.get_name()), out);
            }
        }
        let mut out = Vec::new();
        walk(&super::Cli::command(), "plotter", &mut out);
        out
    }

    /// The help a user reads: every option of every command is described, in words for people — no rustdoc links
    /// (`[`Connected`]`, `[`super::hpgl`]`) or code paths leaking from the source's doc comments.
    #[test]
    fn every_option_is_described_for_people() {
        let mut missing = Vec::new();
        let mut leaks = Vec::new();
        let args = every_arg();
        assert!(args.len() > 150, "the command line lost its options: {}", args.len());
        for (cmd, a) in &args {
            if a.is_hide_set() || matches!(a.get_id().as_str(), "help" | "version") {
                continue;
            }
            let name = a.get_long().map_or_else(|| a.get_id().to_string(), |l| format!("--{l}"));
            let help = a.get_long_help().or(a.get_help()).map(ToString::to_string).unwrap_or_default();
            if help.trim().is_empty() {
                missing.push(format!("{cmd} {name}"));
            }
            let values: Vec<String> = a
                .get_possible_values()
                .iter()
                .filter(|v| !v.is_hide_set())
                .map(|v| v.get_help().map(ToString::to_string).unwrap_or_default())
                .collect();
            for text in std::iter::once(&help).chain(&values) {
                if text.contains("[`") || text.contains("super::") || text.contains("crate::") {
                    leaks.push(format!("{cmd} {name}: {text}"));
                }
            }
        }
        assert!(missing.is_empty(), "options without a description:\n{}", missing.join("\n"));
        assert!(leaks.is_empty(), "help text that speaks code:\n{}", leaks.join("\n"));
    }

    /// Every subcommand says what it does in one line.
    #[test]
    fn every_command_is_described() {
        let cli = super::Cli::command();
        let bare: Vec<&str> = cli
            .get_subcommands()
            .filter(|s| !s.is_hide_set() && s.get_about().is_none_or(|a| a.to_string().trim().is_empty()))
            .map(clap::Command::get_name)
            .collect();
        assert!(bare.is_empty(), "subcommands without a description: {bare:?}");
    }
}
