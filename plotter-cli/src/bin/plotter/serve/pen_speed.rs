//! The page's pen-height and speed sliders, as AxiDraw users know them: pen up and pen down positions as 0–100 %
//! of the servo's range, pen-down and pen-up speeds as % of the machine's maximum, applied to the profile of the
//! next plot (and of the "test pen" button).
//!
//! The % → profile mapping is the command line's (`--pen-pos-up`, `--speed-pendown`, …: [`MachineArgs::apply`]),
//! so both front ends map alike.

use plotter_host::options::machine::{MachineArgs, Speed, top_speed_mm_s};
use plotter_path::MachineProfile;
use plotter_path::config::profile::PenCommand;
use serde::{Deserialize, Serialize};

/// The sliders. `None` keeps the profile's own value.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub(crate) struct PenSpeed {
    /// Pen-up position, 0–100 % of the pen lift's range.
    pub(crate) pen_up_pct: Option<f64>,
    /// Pen-down position, 0–100 %.
    pub(crate) pen_down_pct: Option<f64>,
    /// Drawing speed, 1–100 % of the machine's top speed.
    pub(crate) speed_pendown_pct: Option<f64>,
    /// Pen-up travel speed, 1–100 % of the machine's top speed.
    pub(crate) speed_penup_pct: Option<f64>,
}

/// The pen lift's up and down settings in the profile's own units: an EiBotBoard's servo pulses, a servo's angles
/// or a Z pen's heights.
fn lift(p: &MachineProfile) -> (f64, f64) {
    match (p.ebb, p.pen.command) {
        (Some(e), _) => (f64::from(e.pen_up_position), f64::from(e.pen_down_position)),
        (None, PenCommand::Servo) => (p.pen.servo_up_deg, p.pen.servo_down_deg),
        (None, PenCommand::Z) => (p.pen.up_z_mm, p.pen.down_z_mm),
    }
}

impl PenSpeed {
    /// The command line's settings these sliders stand for.
    fn args(&self) -> MachineArgs {
        MachineArgs {
            speed_pendown: self.speed_pendown_pct.map(Speed::Percent),
            speed_penup: self.speed_penup_pct.map(Speed::Percent),
            pen_pos_up: self.pen_up_pct,
            pen_pos_down: self.pen_down_pct,
            ..MachineArgs::default()
        }
    }

    /// The values `profile` has on its own, as the sliders show them (to 0.1 %): the inverse of [`Self::apply`],
    /// read off the mapping itself at 0 % and 100 %.
    pub(crate) fn of(profile: &MachineProfile) -> PenSpeed {
        let at = |pct: f64| {
            let s = PenSpeed { pen_up_pct: Some(pct), pen_down_pct: Some(pct), ..PenSpeed::default() };
            s.apply(profile).map(|p| lift(&p).0).ok()
        };
        let round = |v: f64| (v * 10.0).round() / 10.0;
        let (up, down) = lift(profile);
        let (lift_up, lift_down) = match (at(0.0), at(100.0)) {
            (Some(lo), Some(hi)) if (hi - lo).abs() > 0.0 => {
                let pct = |v: f64| Some(round(100.0 * (v - lo) / (hi - lo)));
                (pct(up), pct(down))
            }
            _ => (None, None),
        };
        let top = top_speed_mm_s(profile);
        PenSpeed {
            pen_up_pct: lift_up,
            pen_down_pct: lift_down,
            speed_pendown_pct: Some(round(100.0 * profile.pen.draw_feed_mm_s / top)),
            speed_penup_pct: Some(round(100.0 * profile.pen.travel_feed_mm_s / top)),
        }
    }

    /// Check every value against its range; the message names the slider.
    pub(crate) fn check(&self) -> Result<(), String> {
        let fields = [
            ("pen up position", self.pen_up_pct, 0.0),
            ("pen down position", self.pen_down_pct, 0.0),
            ("pen-down speed", self.speed_pendown_pct, 1.0),
            ("pen-up speed", self.speed_penup_pct, 1.0),
        ];
        for (name, value, min) in fields {
            if let Some(v) = value
                && !(v.is_finite() && (min..=100.0).contains(&v))
            {
                return Err(format!("{name} {v} % is not in {min}..100 %"));
            }
        }
        if let (Some(up), Some(down)) = (self.pen_up_pct, self.pen_down_pct)
            && (up - down).abs() < 1.0
        {
            return Err(format!(
                "pen up position {up} % and pen down position {down} % are less than 1 % apart: the pen would not lift"
            ));
        }
        Ok(())
    }

    /// `profile` with the sliders applied, as the command line's flags would apply them.
    pub(crate) fn apply(&self, profile: &MachineProfile) -> Result<MachineProfile, String> {
        let mut p = profile.clone();
        self.args().apply(&mut p)?;
        Ok(p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn axidraw() -> MachineProfile {
        MachineProfile::from_toml(include_str!("../../../../../samples/axidraw-v3.toml"), "axidraw-v3.toml").unwrap()
    }

    /// The AxiDraw V3's sample says "up at 60 %, down at 30 %" of 9855..27831: 20641 and 15248 (as in its
    /// `[ebb]`); speeds are % of its top speed, 25 000 steps/s per motor on a diagonal at 80 steps/mm:
    /// 25000 / (80 × √2) = 220.97 mm/s.
    #[test]
    fn percentages_map_onto_the_axidraws_servo_and_feeds() {
        let s = PenSpeed {
            pen_up_pct: Some(60.0),
            pen_down_pct: Some(30.0),
            speed_pendown_pct: Some(25.0),
            speed_penup_pct: Some(100.0),
        };
        s.check().unwrap();
        let p = s.apply(&axidraw()).unwrap();
        let e = p.ebb.unwrap();
        assert_eq!((e.pen_up_position, e.pen_down_position), (20641, 15248));
        let top = 25_000.0 / (80.0 * std::f64::consts::SQRT_2);
        assert!((p.pen.draw_feed_mm_s - top / 4.0).abs() < 1e-9, "{}", p.pen.draw_feed_mm_s);
        assert!((p.pen.travel_feed_mm_s - top).abs() < 1e-9, "{}", p.pen.travel_feed_mm_s);
        // Nothing chosen: the profile as it was.
        assert_eq!(PenSpeed::default().apply(&axidraw()).unwrap(), axidraw());
        // What the sliders show for the profile itself: 60 % up, 30 % down, speeds as its feeds say.
        let own = PenSpeed::of(&axidraw());
        assert_eq!((own.pen_up_pct, own.pen_down_pct), (Some(60.0), Some(30.0)));
        assert_eq!(PenSpeed::of(&p), PenSpeed { pen_up_pct: Some(60.0), pen_down_pct: Some(30.0), ..s });
    }

    #[test]
    fn a_z_pen_moves_over_its_z_travel() {
        let base = MachineProfile::default_plotter();
        let s = PenSpeed { pen_up_pct: Some(50.0), pen_down_pct: Some(0.0), ..PenSpeed::default() };
        let p = s.apply(&base).unwrap();
        assert_eq!((p.pen.up_z_mm, p.pen.down_z_mm), (base.axes.z.travel_mm / 2.0, 0.0));
        let own = PenSpeed::of(&p);
        assert_eq!((own.pen_up_pct, own.pen_down_pct), (Some(50.0), Some(0.0)));
    }

    #[test]
    fn out_of_range_values_are_refused_by_name() {
        let e = PenSpeed { pen_up_pct: Some(101.0), ..PenSpeed::default() }.check().unwrap_err();
        assert_eq!(e, "pen up position 101 % is not in 0..100 %");
        let e = PenSpeed { speed_penup_pct: Some(0.0), ..PenSpeed::default() }.check().unwrap_err();
        assert_eq!(e, "pen-up speed 0 % is not in 1..100 %");
        let e = PenSpeed { speed_pendown_pct: Some(f64::NAN), ..PenSpeed::default() }.check().unwrap_err();
        assert_eq!(e, "pen-down speed NaN % is not in 1..100 %");
        let e =
            PenSpeed { pen_up_pct: Some(40.0), pen_down_pct: Some(40.5), ..PenSpeed::default() }.check().unwrap_err();
        assert!(e.ends_with("the pen would not lift"), "{e}");
    }
}
