//! The manual commands on a connected plotter, as the AxiDraw software has them: `plotter pen up|down|cycle`,
//! `plotter motors off|on`, `plotter walk-home` and `plotter version` (the dialect logic is in
//! `plotter_host::link::manual`).

use std::time::Duration;

use anyhow::Context as _;
use plotter_host::link::connect::LinkArgs;
use plotter_host::link::machine::Firmware;
use plotter_host::link::manual::{self, PenAction};

/// Arguments of `plotter pen`.
#[derive(clap::Args, Debug, Clone)]
pub(crate) struct PenArgs {
    /// up, down, or cycle (lower, wait, raise: to check the pen's height).
    pub(crate) action: PenAction,
    /// How long `cycle` leaves the pen down, ms.
    #[arg(long, default_value_t = 1000, value_parser = clap::value_parser!(u64).range(0..=60_000))]
    pub(crate) hold_ms: u64,
    #[command(flatten)]
    pub(crate) link: LinkArgs,
}

/// Motors on or off.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum MotorState {
    /// Release the motors: the carriage can be pushed by hand.
    Off,
    /// Power the motors again.
    On,
}

/// Arguments of `plotter motors`.
#[derive(clap::Args, Debug, Clone)]
pub(crate) struct MotorsArgs {
    /// off (the carriage can be moved by hand) or on.
    pub(crate) state: MotorState,
    #[command(flatten)]
    pub(crate) link: LinkArgs,
}

/// Connect as `plotter jog` does: the signals end a handshake; what is sent is short and pen-up.
fn connect(
    link: &LinkArgs,
) -> anyhow::Result<(
    plotter_path::MachineProfile,
    plotter_host::link::machine::Connected<plotter_host::link::serial::SerialTransport>,
)> {
    plotter_host::stop::Stop::install_signals().context("cannot take the termination signals")?;
    crate::cmd::home::connect(link)
}

/// Run `plotter pen`.
pub(crate) fn run_pen(args: &PenArgs) -> anyhow::Result<()> {
    let (profile, mut c) = connect(&args.link)?;
    println!("{}", manual::pen(&mut c, &profile, args.action, Duration::from_millis(args.hold_ms))?);
    Ok(())
}

/// Run `plotter motors`.
pub(crate) fn run_motors(args: &MotorsArgs) -> anyhow::Result<()> {
    let on = args.state == MotorState::On;
    // Refused before the port is opened where the firmware has no such command.
    if matches!(args.link.firmware, Firmware::Hpgl | Firmware::Grbl) {
        manual::motors_line(args.link.firmware, on, &args.link.machine.load()?)?;
    }
    let (profile, mut c) = connect(&args.link)?;
    println!("{}", manual::motors(&mut c, on, &profile)?);
    Ok(())
}

/// Run `plotter walk-home`.
pub(crate) fn run_walk_home(args: &LinkArgs) -> anyhow::Result<()> {
    let (profile, mut c) = connect(args)?;
    println!("{}", manual::walk_home(&mut c, &profile)?);
    Ok(())
}

/// Run `plotter version`.
pub(crate) fn run_version(args: &LinkArgs) -> anyhow::Result<()> {
    let (_, mut c) = connect(args)?;
    println!("{}", manual::version(&mut c)?);
    Ok(())
}
