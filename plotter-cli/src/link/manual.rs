//! The small manual commands of a connected plotter, as the AxiDraw software has them (shared by `plotter pen`,
//! `plotter motors`, `plotter walk-home`, `plotter version` and, later, the web app): raise, lower or cycle the
//! pen, turn the motors off so the carriage can be pushed by hand (and on again), walk back to the home corner
//! without a homing cycle, and ask the firmware who it is — each in the dialect the machine speaks.
//!
//! Motors per firmware: an EiBotBoard takes `EM,0,0` (off) and `EM,<step mode>,<step mode>` (on, which zeroes its
//! step counters: where the carriage then stands is the new home); this project's firmware `M18` / `M17`; GRBL 1.1
//! has no command that only releases the motors: `$SLP` puts it to sleep (motors, spindle and coolant off, every
//! command refused) until a soft reset, after which it wants homing or `$X`, and it powers its motors itself for
//! each move (`$1=255` keeps them on between moves); an HP-GL plotter has no such command at all.

use std::time::Duration;

use plotter_path::geometry::steps::StepPos;
use plotter_path::motion::plan;

use super::Transport;
use super::jog::{Jog, JogTarget, run_jog};
use super::machine::{Connected, Firmware};
use super::stream::Quiet;

/// What to do with the pen.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum PenAction {
    /// Raise the pen.
    Up,
    /// Lower the pen.
    Down,
    /// Lower the pen, wait, raise it again (to check the pen's height).
    Cycle,
}

/// Raise, lower or cycle the pen of `c` (the lines `plotter jog up|down` sends, for every dialect); `hold` is how
/// long a cycle leaves the pen down. Returns what was done, for the user.
pub fn pen<T: Transport + 'static>(
    c: &mut Connected<T>,
    profile: &plotter_path::MachineProfile,
    action: PenAction,
    hold: Duration,
) -> anyhow::Result<String> {
    let jog = |target| Jog { target, distance: None, feed: None };
    match action {
        PenAction::Up => {
            run_jog(c, &jog(JogTarget::Up), profile, &mut |_| {})?;
            Ok("pen up".into())
        }
        PenAction::Down => {
            run_jog(c, &jog(JogTarget::Down), profile, &mut |_| {})?;
            Ok("pen down".into())
        }
        PenAction::Cycle => {
            run_jog(c, &jog(JogTarget::Down), profile, &mut |_| {})?;
            std::thread::sleep(hold);
            run_jog(c, &jog(JogTarget::Up), profile, &mut |_| {})?;
            Ok(format!("pen lowered for {} ms, then raised", hold.as_millis()))
        }
    }
}

/// The command that turns the motors of a `firmware` machine off (`on = false`) or on, or why there is none.
pub fn motors_line(firmware: Firmware, on: bool, profile: &plotter_path::MachineProfile) -> anyhow::Result<String> {
    Ok(match (firmware, on) {
        (Firmware::Ebb, false) => "EM,0,0".into(),
        (Firmware::Ebb, true) => {
            let mode = profile.ebb.map_or(1, |e| e.step_mode);
            format!("EM,{mode},{mode}")
        }
        (Firmware::Grbl, false) => "$SLP".into(),
        (Firmware::Grbl, true) => anyhow::bail!(
            "GRBL powers its motors itself for each move (set $1=255 to keep them on between moves); after \
             `plotter motors off` it sleeps until a reset: press Ctrl-X in `plotter console`, then home it"
        ),
        (Firmware::Hpgl, _) => anyhow::bail!(
            "an HP-GL plotter has no command that turns its motors {}; switch it off and on instead",
            if on { "on" } else { "off" }
        ),
        (_, false) => "M18".into(),
        (_, true) => "M17".into(),
    })
}

/// Turn the motors of `c` off (`on = false`: the carriage can be pushed by hand) or on; returns what was done.
pub fn motors<T: Transport + 'static>(
    c: &mut Connected<T>,
    on: bool,
    profile: &plotter_path::MachineProfile,
) -> anyhow::Result<String> {
    let line = motors_line(c.machine().firmware(), on, profile)?;
    c.command(&line)?;
    if let Connected::Ebb(e) = c {
        // EM waits in the board's queue behind anything still running.
        e.drain(Duration::from_secs(60))?;
    }
    Ok(match (c.machine().firmware(), on) {
        (Firmware::Grbl, _) => format!("motors off ({line}: GRBL sleeps until a reset)"),
        (Firmware::Ebb, true) => format!("motors on ({line}): the carriage's position is now home"),
        (_, true) => format!("motors on ({line})"),
        (_, false) => format!("motors off ({line}): the carriage can be moved by hand"),
    })
}

/// Raise the pen and travel back to the home corner (the homed position, or on an EiBotBoard where its motors
/// were enabled) at the travel feed, without a homing cycle; returns where it then stands, for the user.
pub fn walk_home<T: Transport + 'static>(
    c: &mut Connected<T>,
    profile: &plotter_path::MachineProfile,
) -> anyhow::Result<String> {
    let m = c.machine();
    let from = super::machine::position_within_travel(m, profile)?;
    let home = plan::homed_position(profile)?;
    // The travel lifts the pen first (a servo's angle is not part of the position: always).
    let travel = plan::plan_travel(profile, from, StepPos::new(home[0], home[1]))?;
    m.begin()?;
    if !travel.blocks.is_empty() {
        m.stream(&travel, &mut Quiet).map_err(|e| anyhow::anyhow!("cannot walk home: {e}"))?;
    }
    m.end()?;
    let at = m.position()?;
    let x = f64::from(at[0]) / profile.axes.x.steps_per_mm;
    let y = f64::from(at[1]) / profile.axes.y.steps_per_mm;
    Ok(format!("home: X {x:.2} mm, Y {y:.2} mm, pen up"))
}

/// The firmware's own identity line(s): `M115` on this project's firmware, `$I` on GRBL, `V` on an EiBotBoard.
pub fn version<T: Transport + 'static>(c: &mut Connected<T>) -> anyhow::Result<String> {
    let lines = match c {
        Connected::Ours(s) => s.command("M115", super::session::COMMAND_TIMEOUT)?,
        Connected::Grbl(g) => g.command("$I", super::grbl::session::COMMAND_TIMEOUT)?,
        Connected::Ebb(e) => e.console("V")?,
    };
    let said: Vec<String> =
        lines.into_iter().map(|l| l.trim().to_string()).filter(|l| !l.is_empty() && l != "OK" && l != "ok").collect();
    if said.is_empty() {
        anyhow::bail!("{}: the firmware did not say its version", c.machine().name());
    }
    Ok(said.join("\n"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn motors_off_and_on_in_each_dialect() {
        let v3 = plotter_path::config::models::find("axidraw-v3").unwrap().profile();
        let kit = plotter_path::MachineProfile::default_plotter();
        assert_eq!(motors_line(Firmware::Ebb, false, &v3).unwrap(), "EM,0,0");
        assert_eq!(motors_line(Firmware::Ebb, true, &v3).unwrap(), "EM,1,1");
        assert_eq!(motors_line(Firmware::Ours, false, &kit).unwrap(), "M18");
        assert_eq!(motors_line(Firmware::Ours, true, &kit).unwrap(), "M17");
        assert_eq!(motors_line(Firmware::Grbl, false, &kit).unwrap(), "$SLP");
        let err = motors_line(Firmware::Grbl, true, &kit).unwrap_err().to_string();
        assert!(err.contains("$1=255") && err.contains("Ctrl-X"), "{err}");
        let err = motors_line(Firmware::Hpgl, false, &kit).unwrap_err().to_string();
        assert_eq!(err, "an HP-GL plotter has no command that turns its motors off; switch it off and on instead");
    }
}
