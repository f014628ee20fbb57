//! What the HTTP side asks the machine worker to do (sent over a channel the shared state holds).

use std::sync::Arc;

use plotter_host::job::prepare::Prepared;
use plotter_host::link::jog::JogTarget;
use plotter_path::MachineProfile;

/// What the worker is asked to do.
pub(crate) enum Command {
    /// Connect to the simulator (`None`) or a serial device, with a profile.
    Connect(Option<String>, Box<MachineProfile>),
    /// Close the link.
    Disconnect,
    /// Home.
    Home,
    /// Move an axis (x, y, z) by mm, or lift/lower the pen.
    Jog(JogTarget, Option<f64>),
    /// Send a console line.
    Console(String),
    /// Plot.
    Plot(Arc<Prepared>),
}
