//! What the HTTP side asks the machine worker to do (sent over a channel the shared state holds).

use std::sync::Arc;

use plotter_host::job::prepare::Prepared;
use plotter_host::link::jog::JogTarget;
use plotter_host::link::machine::Firmware;
use plotter_path::MachineProfile;

/// What the worker is asked to do.
pub(crate) enum Command {
    /// Connect to the simulator (`None`, our firmware) or a serial device speaking the firmware (detected when
    /// [`Firmware::Auto`]), with a profile.
    Connect(Option<String>, Firmware, Box<MachineProfile>),
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

/// The firmware a connect request asks for: `auto` (the default, as the CLI's `--firmware`), `ours`, `grbl` or
/// `ebb`. The built-in simulator runs our firmware only; an HP-GL plotter is refused here (only `plotter plot`
/// drives one). The error says why, for the page.
pub(crate) fn firmware_choice(simulator: bool, name: Option<&str>) -> Result<Firmware, String> {
    use clap::ValueEnum as _;
    let name = name.map_or("auto", str::trim);
    let firmware =
        Firmware::from_str(name, true).map_err(|_| format!("unknown firmware {name:?} (auto, ours, grbl, ebb)"))?;
    match firmware {
        Firmware::Hpgl => Err("an HP-GL plotter is not driven from the web app: plot it with \
                               `plotter plot FILE --port PORT --firmware hpgl`"
            .into()),
        Firmware::Grbl | Firmware::Ebb if simulator => Err(format!(
            "the built-in simulator runs plotter-fw, not {name}: serve an emulator with `plotter sim --pty --{name}` \
             and pass its port to `plotter serve --port`"
        )),
        f => Ok(f),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn firmware_choices() {
        assert_eq!(firmware_choice(false, None), Ok(Firmware::Auto));
        assert_eq!(firmware_choice(false, Some("GRBL")), Ok(Firmware::Grbl));
        assert_eq!(firmware_choice(false, Some("ebb")), Ok(Firmware::Ebb));
        assert_eq!(firmware_choice(true, Some("ours")), Ok(Firmware::Ours));
        assert_eq!(firmware_choice(true, None), Ok(Firmware::Auto));
        let hpgl = firmware_choice(false, Some("hpgl")).unwrap_err();
        assert!(hpgl.contains("plotter plot FILE --port PORT --firmware hpgl"), "{hpgl}");
        let sim = firmware_choice(true, Some("ebb")).unwrap_err();
        assert!(sim.contains("plotter sim --pty --ebb"), "{sim}");
        assert_eq!(
            firmware_choice(false, Some("marlin")).unwrap_err(),
            "unknown firmware \"marlin\" (auto, ours, grbl, ebb)"
        );
    }
}
