//! `plotter jog`: move one axis by a distance, or lift/lower the pen, on a connected plotter.

use plotter_host::link::connect::LinkArgs;
use plotter_host::link::jog::{Jog, JogTarget, jog_lines};
use plotter_host::link::machine::{Connected, Firmware};

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
    let firmware = match c {
        Connected::Grbl(_) => Firmware::Grbl,
        Connected::Ebb(_) => Firmware::Ebb,
        Connected::Ours(_) => Firmware::Ours,
    };
    let lines = jog_lines(&args.jog, &profile, firmware)?;
    if let Connected::Ebb(e) = &mut c {
        // No soft limits on the board: the jog is checked against the travel here.
        let at = e.position()?;
        let (axis, travel, spm) = match args.jog.target {
            JogTarget::X => (0, profile.axes.x.travel_mm, profile.axes.x.steps_per_mm),
            JogTarget::Y => (1, profile.axes.y.travel_mm, profile.axes.y.steps_per_mm),
            _ => (2, 0.0, 1.0),
        };
        if axis < 2 {
            let to = f64::from(at[axis]) / spm + args.jog.distance.unwrap_or(0.0);
            if !(0.0..=travel).contains(&to) {
                anyhow::bail!("the jog would end at {to:.2} mm, outside the travel 0..{travel} mm");
            }
        }
    }
    let mut result = Ok(());
    for l in &lines {
        if let Err(e) = c.command(l) {
            result = Err(e);
            break;
        }
    }
    // Always return to absolute mode, even after a refused move.
    if firmware != Firmware::Ebb {
        let _ = c.command("G90");
    }
    result?;
    match &mut c {
        Connected::Ours(s) => {
            let st = s.wait_idle(std::time::Duration::from_millis(50))?;
            println!("position {:?} steps", st.steps);
        }
        Connected::Grbl(g) => {
            let st = g.wait_idle()?;
            let pos = st.mpos.map(|p| format!("MPos {p:?}")).or(st.wpos.map(|p| format!("WPos {p:?}")));
            println!("position {} mm", pos.unwrap_or_default());
        }
        Connected::Ebb(e) => {
            e.drain(std::time::Duration::from_secs(600))?;
            println!("position {:?} steps (motors {:?})", e.position()?, e.motors()?);
        }
    }
    Ok(())
}
