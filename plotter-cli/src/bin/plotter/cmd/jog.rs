//! `plotter jog`: move one axis by a distance, or lift/lower the pen, on a connected plotter.

use plotter_host::link::connect::LinkArgs;
use plotter_host::link::jog::{Jog, run_jog};

/// Arguments of `plotter jog`.
#[derive(clap::Args, Debug, Clone)]
pub(crate) struct JogArgs {
    #[command(flatten)]
    pub(crate) link: LinkArgs,
    #[command(flatten)]
    pub(crate) jog: Jog,
}

/// Run `plotter jog`.
pub(crate) fn run(args: &JogArgs) -> anyhow::Result<()> {
    let (profile, mut c) = crate::cmd::home::connect(&args.link)?;
    println!("{}", run_jog(&mut c, &args.jog, &profile, &mut |_| {})?);
    Ok(())
}
