//! Homing chosen axes, and homing where the carriage may stand over a drawing (our firmware).
//!
//! On a machine whose Z switch lies below the paper (the XY kit: the pen touches 2 mm before the switch trips),
//! homing Z presses the pen onto whatever lies under the carriage. Our firmware keeps a Z it knows and refuses to
//! home a lost one (see `plotter_fw::homing`); but after a power cycle, a board swapped or new firmware flashed
//! mid-plot, Z was simply never homed, and a plain `G28` seeks it where the carriage stands: on the drawing. A
//! resume therefore homes with `G28 P1` ("the carriage may stand over a drawing"), which the firmware refuses,
//! moving nothing, when Z's height is unknown. Then, when the profile names a spot off the paper
//! (`[homing] z_home_xy_mm`), [`Session::home_over_drawing`]:
//! 1. lifts the pen by its stroke (pen-up height minus pen-down height, relative: its height is unknown, and from
//!    anywhere between down and up this ends at or above the pen-up height) — a power cut mid-stroke leaves the
//!    pen on the paper, and X and Y must not drag it;
//! 2. homes X and Y alone (`G28 X Y`: Z untouched);
//! 3. travels to the spot and homes Z there (`G28 Z`: the pen touches the bed, not the drawing; the cycle ends
//!    with the pen at its up height);
//! 4. travels back to where X and Y homed, as a full `G28` would leave the machine.
//!
//! A new plot homes this way too when the profile names a spot: a machine just switched on may stand over the
//! fresh sheet (see `crate::job`'s homing before a plot).
//!
//! Without a spot a resume refuses, moving nothing, and says how to go on: raise the pen and move the carriage off the
//! paper, then `plotter home --z`. Why not the spot by default, or at the home corner: the kit's A3 frame has no
//! place a sheet cannot cover, and only the user knows where the paper lies.

use std::time::Duration;

use plotter_fw::errors::ErrorCode;
use plotter_path::MachineProfile;

use super::Transport;
use super::refused::Refused;
use super::session::{COMMAND_TIMEOUT, Session};

/// The axes `plotter home --x/--y/--z` names; none named is the full cycle.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct HomeAxes {
    /// Home X.
    pub x: bool,
    /// Home Y.
    pub y: bool,
    /// Home Z (the pen lift).
    pub z: bool,
}

impl HomeAxes {
    /// Every axis: the full cycle.
    pub const ALL: HomeAxes = HomeAxes { x: false, y: false, z: false };

    /// Whether no axis is named (the full cycle).
    pub fn is_all(self) -> bool {
        !(self.x || self.y || self.z)
    }

    /// The `G28` line homing these axes: `G28` for all, else `G28` with the axis letters (`G28 Z`, `G28 X Y`).
    pub fn line(self) -> String {
        let mut line = String::from("G28");
        for (named, letter) in [(self.x, " X"), (self.y, " Y"), (self.z, " Z")] {
            if named {
                line.push_str(letter);
            }
        }
        line
    }
}

/// Whether `e` is our firmware refusing a homing that would press the pen onto the paper (error 16).
fn refused_as_marking(e: &anyhow::Error) -> bool {
    Refused::has_code(e, ErrorCode::HomingWouldMark.code())
}

/// What `plotter resume` says when Z's height is unknown and the profile names no spot off the paper to home it.
pub fn no_spot_message(name: &str) -> String {
    format!(
        "{name}: the pen's height is unknown (the firmware restarted since the plot stopped: a power cycle, a reset \
         while Z moved, new firmware), and homing Z where the carriage stands would press the pen onto the drawing \
         (this machine's Z switch lies below the paper), so nothing was moved. Raise the pen clear of the paper \
         (`plotter jog z 4`), move the carriage off the paper (`plotter jog x ...`, or by hand with the motors off), \
         run `plotter home --z` there, then resume again. To have the resume do this itself, name a spot off the \
         paper where the pen may touch the bed in the profile: [homing] z_home_xy_mm = [X, Y] (mm)"
    )
}

impl<T: Transport> Session<T> {
    /// Home only `axes` (`G28 X`, `G28 Z`, ...; all of them, as [`Session::home`], when none is named). Homing Z
    /// on its own always seeks its switch where the carriage stands.
    pub fn home_axes(&mut self, axes: HomeAxes) -> anyhow::Result<()> {
        self.home_with(&axes.line())
    }

    /// Home where the carriage may stand over a drawing (a resume; see the module docs): `G28 P1`, and when the
    /// firmware refuses it because Z's height is unknown, home Z at the profile's `z_home_xy_mm` (pen lifted,
    /// X and Y homed first) or refuse, moving nothing, with what to do. Returns what was done beyond a plain
    /// homing, for the user.
    pub fn home_over_drawing(&mut self, profile: &MachineProfile) -> anyhow::Result<Option<String>> {
        let refused = match self.home_with("G28 P1") {
            Ok(()) => return Ok(None),
            Err(e) if refused_as_marking(&e) => e,
            Err(e) => return Err(e),
        };
        let Some([x, y]) = profile.homing.z_home_xy_mm else {
            return Err(refused.context(no_spot_message(&self.name)));
        };
        let lift = profile.pen.up_z_mm - profile.pen.down_z_mm;
        self.command_checked(&format!("G91 G0 Z{lift:.6}"), COMMAND_TIMEOUT)?;
        self.command_checked("G90", COMMAND_TIMEOUT)?;
        self.home_with("G28 X Y")?;
        let homed = self.status()?.steps;
        let mm = |axis: usize, spm: f64| f64::from(homed[axis]) / spm;
        let (hx, hy) = (mm(0, profile.axes.x.steps_per_mm), mm(1, profile.axes.y.steps_per_mm));
        self.command_checked(&format!("G0 X{x:.6} Y{y:.6}"), COMMAND_TIMEOUT)?;
        self.home_with("G28 Z")?;
        self.command_checked(&format!("G0 X{hx:.6} Y{hy:.6}"), COMMAND_TIMEOUT)?;
        self.wait_idle(Duration::from_millis(50))?;
        Ok(Some(format!(
            "the pen's height was unknown (the firmware restarted since Z was last homed): lifted the pen {lift} mm, \
             homed X and Y, then homed Z off the paper at X{x} Y{y} mm ([homing] z_home_xy_mm)"
        )))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::sim::SimTransport;
    use plotter_fw::sim::{Sim, SimOptions};
    use plotter_fw::{Axis, MachineConfig};

    /// The kit switched on with its carriage at `start` (physical steps).
    fn kit_at(start: [i64; 4]) -> Session<SimTransport> {
        let cfg = MachineConfig::xy_plotter();
        let mut o = SimOptions::for_config(&cfg);
        o.start = start;
        Session::connect(SimTransport::from_sim(Sim::with_options(cfg, o), None), "sim").unwrap()
    }

    /// Steps per axis (X, Y, Z) in the trace from `from` on.
    fn moved(s: &Session<SimTransport>, from: usize) -> [usize; 3] {
        let trace = &s.transport.sim().hal().steps()[from..];
        [Axis::X, Axis::Y, Axis::Z].map(|a| trace.iter().filter(|e| e.axis == a).count())
    }

    /// The spot is read from the profile's [homing] table and must lie within the X and Y travel (420 × 297 mm).
    #[test]
    fn the_spot_is_read_and_checked_against_the_travel() {
        let with = |spot: &str| {
            let text = plotter_path::config::profile::DEFAULT_PROFILE_TOML.replace(
                "pen_clear_at_z_switch = false",
                &format!("pen_clear_at_z_switch = false\nz_home_xy_mm = {spot}"),
            );
            MachineProfile::from_toml(&text, "kit.toml")
        };
        assert_eq!(MachineProfile::default_plotter().homing.z_home_xy_mm, None);
        assert_eq!(with("[400.0, 280.0]").unwrap().homing.z_home_xy_mm, Some([400.0, 280.0]));
        let e = with("[430.0, 10.0]").unwrap_err().to_string();
        assert!(e.contains("homing.z_home_xy_mm") && e.contains("within the X and Y travel"), "{e}");
    }

    /// `plotter home --z` sends `G28 Z`: only Z moves, 6000 steps at 400 steps/mm — its seek from 3 mm down to
    /// the switch, which trips one pull-off (2 mm) below the touch (1200 + 800), the pull-off (800), the locate
    /// back onto the switch (800) and the second pull-off (800), then up to the pen-up height (1600) — and the
    /// carriage stays at (100, 50) mm; `--x --y` sends `G28 X Y` and Z does not step.
    #[test]
    fn home_z_alone_moves_only_z_and_x_y_alone_only_x_and_y() {
        assert_eq!(HomeAxes { z: true, ..HomeAxes::ALL }.line(), "G28 Z");
        assert_eq!(HomeAxes { x: true, y: true, z: false }.line(), "G28 X Y");
        assert_eq!(HomeAxes::ALL.line(), "G28");
        let mut s = kit_at([8000, 4000, 1200, 0]);
        s.home_axes(HomeAxes { z: true, ..HomeAxes::ALL }).unwrap();
        let [x, y, z] = moved(&s, 0);
        assert_eq!((x, y), (0, 0), "X and Y stand still");
        assert_eq!(z, 2000 + 800 + 800 + 800 + 1600);
        assert_eq!(s.transport.sim().physical_position(), [8000, 4000, 1600, 0]);
        let counted = s.status().unwrap().steps;
        assert_eq!(counted, [0, 0, 1600, 0], "Z homed; X and Y counted from where they stood at power-up");
        let from = s.transport.sim().hal().steps().len();
        s.home_axes(HomeAxes { x: true, y: true, z: false }).unwrap();
        assert_eq!(moved(&s, from)[2], 0, "Z does not step");
        assert_eq!(s.transport.sim().physical_position(), [0, 0, 1600, 0]);
    }
}
