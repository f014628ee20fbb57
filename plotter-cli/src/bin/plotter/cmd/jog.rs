//! `plotter jog`: move one axis by a distance, or lift/lower the pen, on a connected plotter, and say where it
//! then stands in millimetres (`--json`: with the raw steps, for scripts).

use anyhow::Context as _;
use plotter_host::link::connect::LinkArgs;
use plotter_host::link::jog::{Jog, run_jog};

/// Arguments of `plotter jog`.
#[derive(clap::Args, Debug, Clone)]
pub(crate) struct JogArgs {
    #[command(flatten)]
    pub(crate) link: LinkArgs,
    #[command(flatten)]
    pub(crate) jog: Jog,
    /// Print where the machine stands as JSON (x_mm, y_mm, pen, steps) instead of a sentence.
    #[arg(long)]
    pub(crate) json: bool,
}

/// Run `plotter jog`.
pub(crate) fn run(args: &JogArgs) -> anyhow::Result<()> {
    // A signal ends the handshake; a jog already sent runs to its end (it is short and pen-up).
    plotter_host::stop::Stop::install_signals().context("cannot take the termination signals")?;
    let (profile, mut c) = crate::cmd::home::connect(&args.link)?;
    let at = run_jog(&mut c, &args.jog, &profile, &mut |_| {})?;
    if args.json {
        println!("{}", at.json());
    } else {
        println!("at {at}");
    }
    Ok(())
}
