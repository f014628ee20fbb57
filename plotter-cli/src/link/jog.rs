//! Jogging: move one axis by a distance, or lift/lower the pen — the lines each firmware dialect takes for it
//! (shared by `plotter jog` and the web app's jog buttons).

use std::time::Duration;

use super::Transport;
use super::machine::{Connected, Firmware};

/// What to move.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum JogTarget {
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

/// One jog: what to move, how far, how fast (`clap` arguments of `plotter jog`, filled in directly by the web app).
#[derive(clap::Args, Debug, Clone, Copy, PartialEq)]
pub struct Jog {
    /// Axis to move (x, y, z) or pen action (up, down).
    pub target: JogTarget,
    /// Distance in mm (signed) for an axis move.
    #[arg(allow_negative_numbers = true)]
    pub distance: Option<f64>,
    /// Feed rate, mm/s [default: the profile's travel feed].
    #[arg(long)]
    pub feed: Option<f64>,
}

/// The G-code lines of a jog for `firmware`. GRBL jogs axes with `$J=` (its jog command, refused outside the
/// travel instead of raising an alarm) and moves a servo pen with `M3 S<angle>`, up and down (never `M5`, which on
/// stock GRBL stops the servo's pulses and lets the pen fall); an EiBotBoard gets EBB
/// commands (`XM` for X/Y, `SP` for the pen).
pub fn jog_lines(
    args: &Jog,
    profile: &plotter_path::MachineProfile,
    firmware: Firmware,
) -> anyhow::Result<Vec<String>> {
    let feed_min = args.feed.unwrap_or(profile.pen.travel_feed_mm_s) * 60.0;
    if !(feed_min.is_finite() && feed_min > 0.0) {
        anyhow::bail!("--feed must be a positive number");
    }
    if firmware == Firmware::Ebb {
        return ebb_jog(args, profile, feed_min / 60.0);
    }
    let z_feed = profile.axes.z.max_feed_mm_s * 60.0;
    let servo = profile.pen.uses_servo();
    if servo && matches!(args.target, JogTarget::Up | JogTarget::Down) {
        return Ok(vec![match args.target {
            JogTarget::Up => format!("M3 S{}", profile.pen.servo_up_deg),
            _ => format!("M3 S{}", profile.pen.servo_down_deg),
        }]);
    }
    if firmware == Firmware::Grbl
        && let Some(letter) = match args.target {
            JogTarget::X => Some('X'),
            JogTarget::Y => Some('Y'),
            JogTarget::Z => Some('Z'),
            _ => None,
        }
    {
        let d = args.distance.ok_or_else(|| anyhow::anyhow!("jog {:?} needs a distance in mm", args.target))?;
        if !d.is_finite() {
            anyhow::bail!("the distance must be a number");
        }
        return Ok(vec![format!("$J=G91 {letter}{d:.4} F{feed_min:.1}")]);
    }
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

/// Run `jog` on the connected machine: its lines for the machine's dialect ([`jog_lines`]), each handed to `sent`
/// before it goes out (for a log), then back to absolute mode (even after a refused move) and wait until the move
/// is done. An EiBotBoard has no soft limits, so its jog is checked against the profile's travel first. Returns
/// where the machine then stands.
pub fn run_jog<T: Transport + 'static>(
    c: &mut Connected<T>,
    jog: &Jog,
    profile: &plotter_path::MachineProfile,
    sent: &mut dyn FnMut(&str),
) -> anyhow::Result<super::standing::Standing> {
    let firmware = c.machine().firmware();
    let lines = jog_lines(jog, profile, firmware)?;
    if let Connected::Ebb(e) = c {
        let at = e.position()?;
        let (axis, travel, spm) = match jog.target {
            JogTarget::X => (0, profile.axes.x.travel_mm, profile.axes.x.steps_per_mm),
            JogTarget::Y => (1, profile.axes.y.travel_mm, profile.axes.y.steps_per_mm),
            _ => (2, 0.0, 1.0),
        };
        if axis < 2 {
            let to = f64::from(at[axis]) / spm + jog.distance.unwrap_or(0.0);
            if !(0.0..=travel).contains(&to) {
                anyhow::bail!("the jog would end at {to:.2} mm, outside the travel 0..{travel} mm");
            }
        }
    }
    let mut result = Ok(());
    for l in &lines {
        sent(l);
        if let Err(e) = c.command(l) {
            result = Err(e);
            break;
        }
    }
    if firmware != Firmware::Ebb {
        let _ = c.command("G90");
    }
    result?;
    match c {
        Connected::Ours(s) => {
            s.wait_idle(Duration::from_millis(50))?;
        }
        Connected::Grbl(g) => {
            g.wait_idle()?;
        }
        Connected::Ebb(e) => e.drain(Duration::from_secs(600))?,
    }
    super::standing::standing(c, profile)
}

/// A jog as EBB commands: `XM,<ms>,<x steps>,<y steps>` (the board mixes them onto its two motors) or `SP`.
fn ebb_jog(args: &Jog, profile: &plotter_path::MachineProfile, feed: f64) -> anyhow::Result<Vec<String>> {
    let e = profile.ebb.ok_or_else(|| anyhow::anyhow!("the profile has no [ebb] section"))?;
    let settle = profile.pen.settle_ms.round();
    let (spm, steps_of) = match args.target {
        JogTarget::Up => return Ok(vec![format!("SP,1,{settle},{}", e.pen_pin)]),
        JogTarget::Down => return Ok(vec![format!("SP,0,{settle},{}", e.pen_pin)]),
        JogTarget::Z => anyhow::bail!("an EiBotBoard has no Z axis: jog up or down"),
        JogTarget::X => (profile.axes.x.steps_per_mm, (1, 0)),
        JogTarget::Y => (profile.axes.y.steps_per_mm, (0, 1)),
    };
    let d = args.distance.ok_or_else(|| anyhow::anyhow!("jog {:?} needs a distance in mm", args.target))?;
    if !d.is_finite() || d.abs() > 10_000.0 {
        anyhow::bail!("the distance must be a number of millimetres within the machine");
    }
    let steps =
        plotter_path::geometry::steps::round_steps(d * spm).ok_or_else(|| anyhow::anyhow!("distance out of range"))?;
    let ms = (d.abs() / feed * 1000.0).round().max(1.0);
    Ok(vec![format!("XM,{ms},{},{}", steps * steps_of.0, steps * steps_of.1)])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(target: JogTarget, distance: Option<f64>) -> Jog {
        Jog { target, distance, feed: Some(10.0) }
    }

    #[test]
    fn jog_gcode() {
        let p = plotter_path::MachineProfile::default_plotter();
        let ours = Firmware::Ours;
        assert_eq!(jog_lines(&args(JogTarget::X, Some(-2.5)), &p, ours).unwrap(), ["G91", "G1 X-2.5000 F600.0", "G90"]);
        assert_eq!(jog_lines(&args(JogTarget::Up, None), &p, ours).unwrap(), ["G90", "G1 Z4.0000 F1500.0"]);
        assert!(jog_lines(&args(JogTarget::Y, None), &p, ours).unwrap_err().to_string().contains("needs a distance"));
        let grbl = Firmware::Grbl;
        assert_eq!(jog_lines(&args(JogTarget::Y, Some(3.0)), &p, grbl).unwrap(), ["$J=G91 Y3.0000 F600.0"]);
        let mut servo = p.clone();
        servo.pen.command = plotter_path::config::profile::PenCommand::Servo;
        assert_eq!(jog_lines(&args(JogTarget::Down, None), &servo, grbl).unwrap(), ["M3 S30"]);
        // Up: `M3` at the up angle (90°; `M5` would let a stock GRBL's servo go limp and the pen fall).
        assert_eq!(jog_lines(&args(JogTarget::Up, None), &servo, ours).unwrap(), ["M3 S90"]);
        assert_eq!(jog_lines(&args(JogTarget::Up, None), &servo, grbl).unwrap(), ["M3 S90"]);
    }

    #[test]
    fn jog_ebb() {
        let text = include_str!("../../../samples/axidraw-v3.toml");
        let p = plotter_path::MachineProfile::from_toml(text, "axidraw-v3.toml").unwrap();
        let ebb = Firmware::Ebb;
        // 10 mm at 80 steps/mm and 10 mm/s: 800 steps in 1000 ms, mixed by the board (XM: A = X, B = Y).
        assert_eq!(jog_lines(&args(JogTarget::X, Some(10.0)), &p, ebb).unwrap(), ["XM,1000,800,0"]);
        assert_eq!(jog_lines(&args(JogTarget::Y, Some(-2.5)), &p, ebb).unwrap(), ["XM,250,0,-200"]);
        assert_eq!(jog_lines(&args(JogTarget::Down, None), &p, ebb).unwrap(), ["SP,0,126,1"]);
        assert_eq!(jog_lines(&args(JogTarget::Up, None), &p, ebb).unwrap(), ["SP,1,126,1"]);
        assert!(jog_lines(&args(JogTarget::Z, Some(1.0)), &p, ebb).unwrap_err().to_string().contains("no Z axis"));
    }
}
