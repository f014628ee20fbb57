//! `plotter home`: run the homing cycle on a connected plotter (our firmware, GRBL or an EiBotBoard) and say where
//! it stands, in millimetres (`--json`: with the raw steps, for scripts). `--x`, `--y`, `--z` home only those
//! axes (our firmware): `--z` is how the user homes the pen lift off the paper when a resume refused to home it
//! over the drawing (see `plotter_host::link::home_axes`).

use anyhow::Context as _;
use plotter_host::link::connect::{LinkArgs, open_port};
use plotter_host::link::home_axes::HomeAxes;
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
    /// Home only X (with --y, --z as named; without any of them every axis homes). This project's firmware only
    #[arg(long)]
    pub(crate) x: bool,
    /// Home only Y (with --x, --z as named). This project's firmware only
    #[arg(long)]
    pub(crate) y: bool,
    /// Home only Z, the pen lift, where the carriage stands. Needed when a resume refused because the pen's height
    /// is unknown (after a power cycle, a reset while the pen moved, or new firmware) on a machine whose Z switch
    /// lies below the paper: raise the pen and move the carriage off the paper first (plotter jog), since homing Z
    /// presses the pen down where it stands; then resume again. This project's firmware only
    #[arg(long)]
    pub(crate) z: bool,
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
    let axes = HomeAxes { x: args.x, y: args.y, z: args.z };
    if axes.is_all() {
        home_machine(c.machine())?;
    } else {
        c.machine().home_axes(axes)?;
    }
    let at = standing(&mut c, &profile)?;
    if args.json {
        println!("{}", at.json());
    } else {
        println!("homed: {at}");
    }
    Ok(())
}
