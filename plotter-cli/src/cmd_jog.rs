//! `plotter jog`: move one axis by a distance, or lift/lower the pen, on a connected plotter.

use crate::cmd_home::LinkArgs;
use plotter_host::job::load::load_profile;
use plotter_host::link::session::COMMAND_TIMEOUT;

/// What to move.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum JogTarget {
    /// X axis by DISTANCE mm.
    X,
    /// Y axis by DISTANCE mm.
    Y,
    /// Z axis by DISTANCE mm.
    Z,
    /// Pen up.
    Up,
    /// Pen down.
    Down,
}

/// Arguments of `plotter jog`.
#[derive(clap::Args, Debug, Clone)]
pub(crate) struct JogArgs {
    #[command(flatten)]
    pub(crate) link: LinkArgs,
    /// Axis to move (x, y, z) or pen action (up, down).
    pub(crate) target: JogTarget,
    /// Distance in mm (signed) for an axis move.
    #[arg(allow_negative_numbers = true)]
    pub(crate) distance: Option<f64>,
    /// Feed rate, mm/s [default: the profile's travel feed].
    #[arg(long)]
    pub(crate) feed: Option<f64>,
}

/// The G-code lines of a jog.
pub(crate) fn jog_lines(args: &JogArgs, profile: &plotter_path::MachineProfile) -> anyhow::Result<Vec<String>> {
    let feed_min = args.feed.unwrap_or(profile.pen.travel_feed_mm_s) * 60.0;
    if !(feed_min.is_finite() && feed_min > 0.0) {
        anyhow::bail!("--feed must be a positive number");
    }
    let z_feed = profile.axes.z.max_feed_mm_s * 60.0;
    Ok(match args.target {
        JogTarget::Up => vec!["G90".into(), format!("G1 Z{:.4} F{z_feed:.1}", profile.pen.up_z_mm)],
        JogTarget::Down => vec!["G90".into(), format!("G1 Z{:.4} F{z_feed:.1}", profile.pen.down_z_mm)],
        axis => {
            let d = args.distance.ok_or_else(|| anyhow::anyhow!("jog {axis:?} needs a distance in mm"))?;
            if !d.is_finite() {
                anyhow::bail!("the distance must be a number");
            }
            let letter = match axis {
                JogTarget::X => 'X',
                JogTarget::Y => 'Y',
                _ => 'Z',
            };
            vec!["G91".into(), format!("G1 {letter}{d:.4} F{feed_min:.1}"), "G90".into()]
        }
    })
}

/// Run `plotter jog`.
pub(crate) fn run(args: &JogArgs) -> anyhow::Result<()> {
    let profile = load_profile(args.link.profile.as_deref())?;
    let lines = jog_lines(args, &profile)?;
    let mut session = args.link.connect()?;
    let mut result = Ok(());
    for l in &lines {
        if let Err(e) = session.command(l, COMMAND_TIMEOUT) {
            result = Err(e);
            break;
        }
    }
    // Always return to absolute mode, even after a refused move.
    let _ = session.command("G90", COMMAND_TIMEOUT);
    result?;
    let s = session.wait_idle(std::time::Duration::from_millis(50))?;
    println!("position {:?} steps", s.steps);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(target: JogTarget, distance: Option<f64>) -> JogArgs {
        JogArgs { link: LinkArgs { port: "p".into(), profile: None, baud: None }, target, distance, feed: Some(10.0) }
    }

    #[test]
    fn jog_gcode() {
        let p = plotter_path::MachineProfile::default_plotter();
        assert_eq!(jog_lines(&args(JogTarget::X, Some(-2.5)), &p).unwrap(), ["G91", "G1 X-2.5000 F600.0", "G90"]);
        assert_eq!(jog_lines(&args(JogTarget::Up, None), &p).unwrap(), ["G90", "G1 Z4.0000 F1500.0"]);
        assert!(jog_lines(&args(JogTarget::Y, None), &p).unwrap_err().to_string().contains("needs a distance"));
    }
}
