//! `plotter home`: run the homing cycle on a connected plotter (our firmware, GRBL or an EiBotBoard) and say where
//! it stands, in millimetres (`--json`: with the raw steps, for scripts).

use anyhow::Context as _;
use plotter_host::link::connect::{LinkArgs, open_port};
use plotter_host::link::machine::{Connected, Firmware, home_machine};
use plotter_host::link::serial::SerialTransport;
use plotter_host::link::standing::standing;
use plotter_path::MachineProfile;

/// Arguments of `plotter home`.
#[derive(clap::Args, Debug, Clone)]
pub(crate) struct HomeArgs {
    #[command(flatten)]
    pub(crate) link: LinkArgs,
    /// Print where the machine stands as JSON (x_mm, y_mm, pen, steps) instead of a sentence.
    #[arg(long)]
    pub(crate) json: bool,
}

/// Open `port` and connect to `firmware`; prints what answered.
pub(crate) fn open(
    port: &str,
    baud: u32,
    firmware: Firmware,
    profile: &MachineProfile,
) -> anyhow::Result<Connected<SerialTransport>> {
    let c = open_port(port, baud, firmware, profile)?;
    eprintln!("connected to {}", c.describe());
    Ok(c)
}

/// The profile and the connection `args` name; prints what answered.
pub(crate) fn connect(args: &LinkArgs) -> anyhow::Result<(MachineProfile, Connected<SerialTransport>)> {
    let (profile, c) = args.connect()?;
    eprintln!("connected to {}", c.describe());
    Ok((profile, c))
}

/// Run `plotter home`.
pub(crate) fn run(args: &HomeArgs) -> anyhow::Result<()> {
    // A signal ends the handshake or the homing cycle the firmware's way (a reset or ES), not the process mid-move.
    plotter_host::stop::Stop::install_signals().context("cannot take the termination signals")?;
    let (profile, mut c) = connect(&args.link)?;
    home_machine(c.machine())?;
    let at = standing(&mut c, &profile)?;
    if args.json {
        println!("{}", at.json());
    } else {
        println!("homed: {at}");
    }
    Ok(())
}
