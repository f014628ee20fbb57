//! Reaching a plotter on a serial port, whatever its firmware (ours, GRBL, an EiBotBoard): the `clap` flags that
//! name it and the connection they open (shared by `plotter home`, `jog`, `console` and `plot --port`).

use plotter_path::MachineProfile;

use super::machine::{Connected, Firmware};
use super::serial::SerialTransport;
use crate::options::machine::MachineArgs;

/// How to reach a plotter.
#[derive(clap::Args, Debug, Clone)]
pub struct LinkArgs {
    /// Serial device of the plotter (or the path printed by `plotter sim --pty`).
    #[arg(long)]
    pub port: String,
    /// The machine: its model or profile.
    #[command(flatten)]
    pub machine: MachineArgs,
    /// Baud rate [default: the profile's].
    #[arg(long)]
    pub baud: Option<u32>,
    /// The plotter's firmware: ours, GRBL 1.1 (grblHAL, FluidNC), ebb (AxiDraw-class EiBotBoard), or auto (told
    /// by its start-up banner or its answers).
    #[arg(long, value_enum, default_value_t = Firmware::Auto)]
    pub firmware: Firmware,
}

/// Open the serial device `port` at `baud` and connect to `firmware` on it (detected when [`Firmware::Auto`]).
pub fn open_port(
    port: &str,
    baud: u32,
    firmware: Firmware,
    profile: &MachineProfile,
) -> crate::Result<Connected<SerialTransport>> {
    let transport = SerialTransport::open(port, baud).map_err(crate::Error::PortUnavailable)?;
    Connected::connect(transport, port, firmware, profile)
}

impl LinkArgs {
    /// The profile and the open connection (at the profile's baud rate unless `--baud` says otherwise).
    pub fn connect(&self) -> crate::Result<(MachineProfile, Connected<SerialTransport>)> {
        let profile = self.machine.load()?;
        let c = open_port(&self.port, self.baud.unwrap_or(profile.link.baud), self.firmware, &profile)?;
        Ok((profile, c))
    }
}
