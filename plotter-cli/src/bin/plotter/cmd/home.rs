//! `plotter home`: run the homing cycle on a connected plotter (our firmware or GRBL) and report where it is.

use std::path::PathBuf;

use plotter_host::job::load::load_profile;
use plotter_host::link::machine::{Connected, Firmware};
use plotter_host::link::serial::SerialTransport;
use plotter_path::MachineProfile;

/// How to reach a plotter (shared by `home`, `jog` and `console`).
#[derive(clap::Args, Debug, Clone)]
pub(crate) struct LinkArgs {
    /// Serial device of the plotter (or the path printed by `plotter sim --pty`).
    #[arg(long)]
    pub(crate) port: String,
    /// Machine profile (TOML) [default: the built-in XY plotter kit].
    #[arg(long)]
    pub(crate) profile: Option<PathBuf>,
    /// Baud rate [default: the profile's].
    #[arg(long)]
    pub(crate) baud: Option<u32>,
    /// The plotter's firmware: ours, GRBL 1.1 (grblHAL, FluidNC), ebb (AxiDraw-class EiBotBoard), or auto (told
    /// by its start-up banner or its answers).
    #[arg(long, value_enum, default_value_t = Firmware::Auto)]
    pub(crate) firmware: Firmware,
}

/// Open `port` and connect to `firmware`; prints what answered.
pub(crate) fn open(
    port: &str,
    baud: u32,
    firmware: Firmware,
    profile: &MachineProfile,
) -> anyhow::Result<Connected<SerialTransport>> {
    let transport = SerialTransport::open(port, baud)?;
    let c = Connected::connect(transport, port, firmware, profile)?;
    eprintln!("connected to {}", c.describe());
    Ok(c)
}

impl LinkArgs {
    /// The profile and the open connection.
    pub(crate) fn connect(&self) -> anyhow::Result<(MachineProfile, Connected<SerialTransport>)> {
        let profile = load_profile(self.profile.as_deref())?;
        let c = open(&self.port, self.baud.unwrap_or(profile.link.baud), self.firmware, &profile)?;
        Ok((profile, c))
    }
}

/// Run `plotter home`.
pub(crate) fn run(args: &LinkArgs) -> anyhow::Result<()> {
    let (_, mut c) = args.connect()?;
    let m = c.machine();
    if let Some(what) = m.alarm_pending()?
        && !m.can_home()
    {
        anyhow::bail!("{what}; homing is disabled, unlock it with `plotter console` ($X) once it is safe");
    }
    m.home()?;
    let p = m.position()?;
    println!("homed; position {p:?} steps");
    Ok(())
}
