//! Where a machine stands, as people read it: X and Y in millimetres from the home corner and the pen up or down —
//! never raw steps, which stay available for scripts (`--json`) and debugging.
//!
//! Every dialect reports its position in steps of the plot's coordinates ([`super::machine::PlotMachine::position`]);
//! the profile's steps/mm turn them into millimetres. The pen: a Z-lift pen is up when Z stands at or above the
//! middle of its up and down heights; an EiBotBoard's servo pen is asked (`QP`); a servo pen on our firmware or
//! GRBL has no position to read back, so its state is not claimed.

use std::fmt;

use plotter_path::MachineProfile;
use plotter_path::config::profile::PenCommand;
use plotter_path::motion::plan::MachinePos;

use super::Transport;
use super::machine::Connected;

/// The pen, as the machine reports it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pen {
    /// Lifted off the paper.
    Up,
    /// On the paper.
    Down,
}

/// Where a machine stands.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Standing {
    /// The position as the machine reported it, steps (X, Y, Z, E) of the plot's coordinates.
    pub steps: MachinePos,
    /// X from the home corner, mm.
    pub x_mm: f64,
    /// Y from the home corner, mm.
    pub y_mm: f64,
    /// The pen, when the machine can tell.
    pub pen: Option<Pen>,
}

impl Standing {
    /// `steps` read through `profile`; `pen` as the machine answered, else (a Z-lift pen) from Z.
    pub fn of(steps: MachinePos, profile: &MachineProfile, pen: Option<Pen>) -> Standing {
        let mm = |s: i32, spm: f64| if spm > 0.0 { f64::from(s) / spm } else { 0.0 };
        let z_pen = (profile.pen.command == PenCommand::Z).then(|| {
            let middle = f64::midpoint(profile.pen.up_z_mm, profile.pen.down_z_mm);
            if mm(steps[2], profile.axes.z.steps_per_mm) >= middle { Pen::Up } else { Pen::Down }
        });
        Standing {
            steps,
            x_mm: mm(steps[0], profile.axes.x.steps_per_mm),
            y_mm: mm(steps[1], profile.axes.y.steps_per_mm),
            pen: pen.or(z_pen),
        }
    }

    /// The figures for a script: millimetres, the pen (`"up"`, `"down"` or null) and the raw steps.
    pub fn json(&self) -> serde_json::Value {
        serde_json::json!({
            "x_mm": round3(self.x_mm),
            "y_mm": round3(self.y_mm),
            "pen": self.pen.map(|p| match p { Pen::Up => "up", Pen::Down => "down" }),
            "steps": self.steps,
        })
    }
}

/// `v` to three decimals (a micrometre), so that JSON shows 10.0 rather than 9.999999999.
fn round3(v: f64) -> f64 {
    (v * 1000.0).round() / 1000.0
}

impl fmt::Display for Standing {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "X {:.2} Y {:.2} mm", self.x_mm + 0.0, self.y_mm + 0.0)?;
        match self.pen {
            Some(Pen::Up) => write!(f, ", pen up"),
            Some(Pen::Down) => write!(f, ", pen down"),
            None => Ok(()),
        }
    }
}

/// Ask `c` where it stands (an EiBotBoard is asked for its pen too).
pub fn standing<T: Transport + 'static>(c: &mut Connected<T>, profile: &MachineProfile) -> anyhow::Result<Standing> {
    let pen = match c {
        Connected::Ebb(e) => Some(if e.pen_is_up()? { Pen::Up } else { Pen::Down }),
        Connected::Ours(_) | Connected::Grbl(_) => None,
    };
    let steps = c.machine().position()?;
    Ok(Standing::of(steps, profile, pen))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steps_read_as_millimetres_and_the_z_pen_as_up_or_down() {
        // The built-in kit: 80 steps/mm on X and Y, 400 on Z; pen up at Z 4 mm, down at 0 (middle 2 mm = 800
        // steps).
        let p = MachineProfile::default_plotter();
        assert_eq!(
            (p.axes.x.steps_per_mm, p.axes.z.steps_per_mm, p.pen.up_z_mm, p.pen.down_z_mm),
            (80.0, 400.0, 4.0, 0.0)
        );
        let s = Standing::of([800, 0, 1600, 0], &p, None);
        assert_eq!((s.x_mm, s.y_mm, s.pen), (10.0, 0.0, Some(Pen::Up)));
        assert_eq!(s.to_string(), "X 10.00 Y 0.00 mm, pen up");
        let s = Standing::of([-40, 12_345, 799, 0], &p, None);
        assert_eq!(s.to_string(), "X -0.50 Y 154.31 mm, pen down");
        assert_eq!(Standing::of([0, 0, 800, 0], &p, None).pen, Some(Pen::Up));
        // What the machine answered wins over Z.
        assert_eq!(Standing::of([0, 0, 0, 0], &p, Some(Pen::Up)).pen, Some(Pen::Up));
        let j = Standing::of([800, 8, 1600, 0], &p, None).json();
        assert_eq!(j, serde_json::json!({"x_mm": 10.0, "y_mm": 0.1, "pen": "up", "steps": [800, 8, 1600, 0]}));
    }

    #[test]
    fn a_servo_pen_without_an_answer_is_not_claimed() {
        let mut p = MachineProfile::default_plotter();
        p.pen.command = PenCommand::Servo;
        let s = Standing::of([0, 0, 0, 0], &p, None);
        assert_eq!((s.pen, s.to_string()), (None, "X 0.00 Y 0.00 mm".to_string()));
        assert_eq!(s.json()["pen"], serde_json::Value::Null);
    }
}
