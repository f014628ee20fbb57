//! `plotter home`: run the homing cycle on a connected plotter and report where it is.

use std::path::PathBuf;

use plotter_host::job::load::load_profile;
use plotter_host::link::serial::SerialTransport;
use plotter_host::link::session::Session;

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
}

impl LinkArgs {
    /// Open the port and handshake.
    pub(crate) fn connect(&self) -> anyhow::Result<Session<SerialTransport>> {
        let profile = load_profile(self.profile.as_deref())?;
        let transport = SerialTransport::open(&self.port, self.baud.unwrap_or(profile.link.baud))?;
        let session = Session::connect(transport, &self.port)?;
        eprintln!(
            "connected to plotter-fw {} on {} (rx {} bytes, queue {} blocks)",
            session.info.version, self.port, session.info.rx_bytes, session.info.queue_blocks
        );
        Ok(session)
    }
}

/// Run `plotter home`.
pub(crate) fn run(args: &LinkArgs) -> anyhow::Result<()> {
    let mut session = args.connect()?;
    session.home()?;
    let s = session.status()?;
    println!("homed; position {:?} steps ({})", s.steps, s.state);
    Ok(())
}
