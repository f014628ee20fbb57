//! Which machine a command plans for or drives: the `clap` flags that choose its model or profile, and the
//! AxiDraw-style speed and pen settings laid over it, shared by every command that needs a machine (`plot`,
//! `stats`, `optimize`, `sim`, `home`, `jog`, `console`, the manual commands).
//!
//! # How the AxiDraw-style settings map onto a profile
//! - `--speed-pendown` / `--speed-penup`: a plain number is a percentage of the machine's top speed, as the AxiDraw
//!   software means it; with a unit (`120mm/s`) a speed. The top speed of an EiBotBoard machine is what its board
//!   steps on any diagonal, 25 000 steps/s per motor at the X axis's steps/mm (80 → 221 mm/s, the AxiDraw
//!   software's 8.6979 in/s); of any other machine its faster axis's `max_feed_mm_s`. They set `pen.draw_feed_mm_s`
//!   and `pen.travel_feed_mm_s` (pens of the pen table with a feed of their own keep it).
//! - `--accel`: a percentage of the profile's own acceleration (the X and Y axes' and the pen section's caps).
//! - `--pen-pos-up` / `--pen-pos-down`: 0–100 % of the pen lift's range. On an EiBotBoard, the servo pulse between
//!   the AxiDraw software's 9855 and 27831 (0.82–2.32 ms, in 1/12 µs) for the standard servo, or between 5400 and
//!   12600 (0.45–1.05 ms) for the narrow-band brushless lift (`pen_pin = 2`); on any other servo pen, the angle
//!   `M3 S<angle>` takes, 0–180°; on a Z pen, the height over the Z travel (`axes.z.travel_mm`).
//! - `--pen-rate-raise` / `--pen-rate-lower` (EiBotBoard only): the servo's slew as a percentage of a full sweep in
//!   200 ms (70 ms for the brushless lift), in the board's units per 24 ms servo cycle.
//! - With a new position or rate on an EiBotBoard, the pen's settle time is worked out again, the AxiDraw
//!   software's way: the longer of the sweep at the set rates and the servo's own travel time (45 ms + 2.69 ms per
//!   percent moved; the brushless lift's sweep + 8 ms).
//! - `--pen-delay-up` / `--pen-delay-down`: milliseconds added after a lift or a drop. The plan keeps one settle
//!   time for both, so the longer of the two is added to it; a servo pen's travel after a lift also starts the
//!   raise delay later.

use std::path::{Path, PathBuf};

use plotter_path::MachineProfile;
use plotter_path::config::models;

use crate::error::BadInput;

/// The machine-choosing flags and the speed and pen settings laid over the machine's profile.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct MachineArgs {
    /// Built-in machine model (`plotter models` lists them with their work areas) [default: xy-kit].
    #[arg(long, help_heading = "Machine", value_parser = clap::builder::PossibleValuesParser::new(models::names()))]
    pub model: Option<String>,
    /// Machine profile (TOML); with --model, its keys replace the model's [default: the built-in XY plotter kit].
    #[arg(long, help_heading = "Machine")]
    pub profile: Option<PathBuf>,
    /// Drawing speed: percent of the machine's top speed (1-100, as the AxiDraw software counts), or a speed with
    /// its unit, e.g. 120mm/s.
    #[arg(long, help_heading = "Machine", value_name = "SPEED", value_parser = parse_speed)]
    pub speed_pendown: Option<Speed>,
    /// Pen-up travel speed: percent of the machine's top speed (1-100), or a speed with its unit, e.g. 200mm/s.
    #[arg(long, help_heading = "Machine", value_name = "SPEED", value_parser = parse_speed)]
    pub speed_penup: Option<Speed>,
    /// Acceleration: percent of the machine's own (1-100).
    #[arg(long, help_heading = "Machine", value_name = "PERCENT", value_parser = percent_from(1.0))]
    pub accel: Option<f64>,
    /// Pen height when raised: percent of the pen lift's range (0-100).
    #[arg(long, help_heading = "Machine", value_name = "PERCENT", value_parser = percent_from(0.0))]
    pub pen_pos_up: Option<f64>,
    /// Pen height when lowered: percent of the pen lift's range (0-100).
    #[arg(long, help_heading = "Machine", value_name = "PERCENT", value_parser = percent_from(0.0))]
    pub pen_pos_down: Option<f64>,
    /// How fast the pen servo raises: percent of its full speed (1-100; EiBotBoard machines).
    #[arg(long, help_heading = "Machine", value_name = "PERCENT", value_parser = percent_from(1.0))]
    pub pen_rate_raise: Option<f64>,
    /// How fast the pen servo lowers: percent of its full speed (1-100; EiBotBoard machines).
    #[arg(long, help_heading = "Machine", value_name = "PERCENT", value_parser = percent_from(1.0))]
    pub pen_rate_lower: Option<f64>,
    /// Extra wait after the pen is raised, ms (0-10000).
    #[arg(long, help_heading = "Machine", value_name = "MS", value_parser = parse_delay)]
    pub pen_delay_up: Option<f64>,
    /// Extra wait after the pen is lowered, ms (0-10000).
    #[arg(long, help_heading = "Machine", value_name = "MS", value_parser = parse_delay)]
    pub pen_delay_down: Option<f64>,
}

/// A speed as `--speed-pendown` takes it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Speed {
    /// Percent of the machine's top speed.
    Percent(f64),
    /// Millimetres per second.
    MmPerS(f64),
}

impl Speed {
    /// The speed in mm/s on a machine whose top speed is `top` mm/s.
    pub fn mm_s(self, top: f64) -> f64 {
        match self {
            Speed::Percent(p) => p / 100.0 * top,
            Speed::MmPerS(v) => v,
        }
    }
}

/// `25` (percent), `25%`, `120mm/s` or `120 mm/s`.
fn parse_speed(s: &str) -> Result<Speed, String> {
    let t = s.trim();
    if let Some(v) = t.strip_suffix("mm/s") {
        let v: f64 =
            v.trim().parse().map_err(|_| format!("{s:?} is not a speed: write e.g. 120mm/s or 25 (percent)"))?;
        // The range every profile feed must lie in.
        if !(v.is_finite() && (0.1..=5000.0).contains(&v)) {
            return Err(format!("{v} mm/s is outside 0.1..=5000 mm/s"));
        }
        return Ok(Speed::MmPerS(v));
    }
    let number = t.strip_suffix('%').unwrap_or(t).trim();
    let v: f64 = number.parse().map_err(|_| {
        format!("{s:?} is not a speed: write a percentage of the machine's top speed (1-100) or e.g. 120mm/s")
    })?;
    if !(v.is_finite() && (1.0..=100.0).contains(&v)) {
        return Err(format!("{v} % is outside 1..=100 % of the machine's top speed (for a speed, add mm/s)"));
    }
    Ok(Speed::Percent(v))
}

/// A percentage from `lo` to 100.
fn percent_from(lo: f64) -> impl Fn(&str) -> Result<f64, String> + Clone + Send + Sync + 'static {
    move |s: &str| {
        let t = s.trim();
        let v: f64 = t.strip_suffix('%').unwrap_or(t).trim().parse().map_err(|_| format!("{s:?} is not a number"))?;
        if v.is_finite() && (lo..=100.0).contains(&v) { Ok(v) } else { Err(format!("{v} is outside {lo}..=100 %")) }
    }
}

/// Milliseconds, 0 to 10 000 (the longest settle a profile takes).
fn parse_delay(s: &str) -> Result<f64, String> {
    let t = s.trim();
    let v: f64 =
        t.strip_suffix("ms").unwrap_or(t).trim().parse().map_err(|_| format!("{s:?} is not a number of ms"))?;
    if v.is_finite() && (0.0..=10_000.0).contains(&v) { Ok(v) } else { Err(format!("{v} ms is outside 0..=10000 ms")) }
}

/// An EiBotBoard's top step rate per motor, steps/s (its command reference: 25 kHz).
const EBB_MAX_STEP_RATE: f64 = 25_000.0;

/// The pen servo of an EiBotBoard machine as the AxiDraw-style settings see it.
#[derive(Debug, Clone, Copy, PartialEq)]
struct EbbServo {
    /// Pulse at 0 %, 1/12 µs.
    min: f64,
    /// Pulse at 100 %, 1/12 µs.
    max: f64,
    /// A full sweep at 100 % rate, ms.
    sweep_ms: f64,
    /// The standard hobby servo (its travel time counts), not the brushless lift.
    hobby: bool,
}

impl EbbServo {
    /// The AxiDraw software's servo_min/servo_max and servo_sweep_time; the NextDraw's narrow-band lift on pin 2.
    fn of(pin: u8) -> Self {
        if pin == 2 {
            EbbServo { min: 5400.0, max: 12_600.0, sweep_ms: 70.0, hobby: false }
        } else {
            EbbServo { min: 9855.0, max: 27_831.0, sweep_ms: 200.0, hobby: true }
        }
    }

    fn span(&self) -> f64 {
        self.max - self.min
    }

    /// Board units per 24 ms servo cycle at 100 % rate.
    fn full_rate(&self) -> f64 {
        self.span() * 24.0 / self.sweep_ms
    }

    fn position(&self, percent: f64) -> u16 {
        // Within min..=max, far inside u16.
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let p = (self.min + percent / 100.0 * self.span()).round() as u16;
        p
    }

    fn percent(&self, position: u16) -> f64 {
        (f64::from(position) - self.min) / self.span() * 100.0
    }

    fn rate(&self, percent: f64) -> u16 {
        // At most full_rate (≤ 2500), far inside u16.
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let r = (percent / 100.0 * self.full_rate()).round() as u16;
        r.max(1)
    }

    fn rate_percent(&self, rate: u16) -> f64 {
        if rate == 0 { 100.0 } else { f64::from(rate) / self.full_rate() * 100.0 }
    }

    /// The settle for a move of `moved` percent at `rate` percent: the sweep, or the servo's own travel time when
    /// longer (the AxiDraw software's servo_move_min 45 ms + servo_move_slope 2.69 ms per percent).
    fn settle_ms(&self, moved: f64, raise_rate: f64, lower_rate: f64) -> f64 {
        let sweep = |rate: f64| self.sweep_ms * moved / rate;
        let swept = sweep(raise_rate).max(sweep(lower_rate));
        if self.hobby { swept.max(45.0 + 2.69 * moved).round() } else { (swept + 8.0).round() }
    }
}

impl MachineArgs {
    /// Whether any flag chose or changed the machine (other than the built-in default as it is).
    pub fn chosen(&self) -> bool {
        self.model.is_some() || self.profile.is_some() || self.changes_profile()
    }

    /// Whether a speed or pen setting changes the profile.
    fn changes_profile(&self) -> bool {
        self.speed_pendown.is_some()
            || self.speed_penup.is_some()
            || self.accel.is_some()
            || self.pen_pos_up.is_some()
            || self.pen_pos_down.is_some()
            || self.pen_rate_raise.is_some()
            || self.pen_rate_lower.is_some()
            || self.pen_delay_up.is_some()
            || self.pen_delay_down.is_some()
    }

    /// The machine profile these flags name, with the speed and pen settings applied (a bad file, or a setting
    /// the machine cannot take, is [`crate::Error::BadInput`]).
    pub fn load(&self) -> crate::Result<MachineProfile> {
        let model = match self.model.as_deref() {
            Some(name) => Some(models::find(name).ok_or_else(|| {
                crate::Error::BadInput(BadInput::new("--model", anyhow::anyhow!("--model: {}", models::unknown(name))))
            })?),
            None => None,
        };
        let mut profile = match (model, self.profile.as_deref()) {
            (Some(m), Some(path)) => {
                let text = std::fs::read_to_string(path).map_err(|e| {
                    BadInput::new(path, anyhow::anyhow!("cannot read machine profile {}: {e}", path.display()))
                })?;
                plotter_path::config::profile::extend_model(m, &text, &path.display().to_string())
                    .map_err(|e| BadInput::new(path, e.into()))?
            }
            (Some(m), None) => m.profile(),
            (None, path) => load_profile(path)?,
        };
        if self.changes_profile() {
            self.apply(&mut profile).map_err(|e| BadInput::new("the command line", anyhow::anyhow!("{e}")))?;
            profile
                .validate("with the command line's settings")
                .map_err(|e| BadInput::new("the command line", e.into()))?;
        }
        Ok(profile)
    }

    /// Lay the speed and pen settings over `p` (see the module docs for the mapping).
    pub fn apply(&self, p: &mut MachineProfile) -> Result<(), String> {
        let top = top_speed_mm_s(p);
        if let Some(s) = self.speed_pendown {
            p.pen.draw_feed_mm_s = s.mm_s(top);
        }
        if let Some(s) = self.speed_penup {
            p.pen.travel_feed_mm_s = s.mm_s(top);
        }
        if let Some(a) = self.accel {
            let f = a / 100.0;
            p.axes.x.max_accel_mm_s2 *= f;
            p.axes.y.max_accel_mm_s2 *= f;
            p.pen.draw_accel_mm_s2 = p.pen.draw_accel_mm_s2.map(|v| v * f);
            p.pen.travel_accel_mm_s2 = p.pen.travel_accel_mm_s2.map(|v| v * f);
        }
        let rates = self.pen_rate_raise.is_some() || self.pen_rate_lower.is_some();
        let positions = self.pen_pos_up.is_some() || self.pen_pos_down.is_some();
        if let Some(e) = p.ebb.as_mut() {
            let servo = EbbServo::of(e.pen_pin);
            if let Some(v) = self.pen_pos_up {
                e.pen_up_position = servo.position(v);
            }
            if let Some(v) = self.pen_pos_down {
                e.pen_down_position = servo.position(v);
            }
            if let Some(v) = self.pen_rate_raise {
                e.pen_rate_up = servo.rate(v);
            }
            if let Some(v) = self.pen_rate_lower {
                e.pen_rate_down = servo.rate(v);
            }
            if positions || rates {
                let up = self.pen_pos_up.unwrap_or_else(|| servo.percent(e.pen_up_position));
                let down = self.pen_pos_down.unwrap_or_else(|| servo.percent(e.pen_down_position));
                let raise = self.pen_rate_raise.unwrap_or_else(|| servo.rate_percent(e.pen_rate_up));
                let lower = self.pen_rate_lower.unwrap_or_else(|| servo.rate_percent(e.pen_rate_down));
                p.pen.settle_ms = servo.settle_ms((up - down).abs(), raise, lower);
                if p.pen.clear_ms.is_some() {
                    p.pen.clear_ms = Some(p.pen.servo_clear_ms().min(p.pen.settle_ms));
                }
            }
        } else {
            if rates {
                return Err(format!(
                    "--pen-rate-raise/--pen-rate-lower: the {} moves its pen at the lift's own speed; only an \
                     EiBotBoard machine (--model axidraw-v3 and the like) sets a servo slew rate",
                    p.name
                ));
            }
            let servo = p.pen.uses_servo();
            let z_travel = p.axes.z.travel_mm;
            let set = |percent: f64, deg: &mut f64, z: &mut f64| {
                if servo {
                    *deg = percent * 1.8;
                } else {
                    *z = percent / 100.0 * z_travel;
                }
            };
            if let Some(v) = self.pen_pos_up {
                set(v, &mut p.pen.servo_up_deg, &mut p.pen.up_z_mm);
            }
            if let Some(v) = self.pen_pos_down {
                set(v, &mut p.pen.servo_down_deg, &mut p.pen.down_z_mm);
            }
        }
        let (up, down) = (self.pen_delay_up.unwrap_or(0.0), self.pen_delay_down.unwrap_or(0.0));
        if p.pen.uses_servo() {
            // A servo's settle time is its swing, which the drops are timed from: the delays are waits of their
            // own, after the tip is clear and after it touches.
            p.pen.lift_delay_ms += up;
            p.pen.drop_delay_ms += down;
        } else if up > 0.0 || down > 0.0 {
            // A Z pen's one settle serves lifts and drops: the longer delay is added to it.
            p.pen.settle_ms += up.max(down);
        }
        Ok(())
    }
}

/// The speed 100 % means: an EiBotBoard machine's on any diagonal (25 000 steps/s per motor, each X or Y step a
/// step of both motors), any other machine's faster axis's `max_feed_mm_s`.
pub fn top_speed_mm_s(p: &MachineProfile) -> f64 {
    if p.ebb.is_some() {
        EBB_MAX_STEP_RATE / (p.axes.x.steps_per_mm * std::f64::consts::SQRT_2)
    } else {
        p.axes.x.max_feed_mm_s.max(p.axes.y.max_feed_mm_s)
    }
}

/// Load the machine profile at `path` (a TOML file, a bad one is [`crate::Error::BadInput`]), or the built-in XY
/// plotter kit profile.
pub fn load_profile(path: Option<&Path>) -> crate::Result<MachineProfile> {
    match path {
        // A model's name (or its sample file, which an installed program does not have) given as a file.
        Some(p) if !p.exists() && plotter_path::config::models::meant_by_path(p).is_some() => {
            let name = plotter_path::config::models::meant_by_path(p).map_or("", |m| m.name);
            let e = anyhow::anyhow!(
                "cannot read machine profile {}: no such file; did you mean --model {name} (built in)?",
                p.display()
            );
            Err(BadInput::new(p, e).into())
        }
        Some(p) => MachineProfile::load(p).map_err(|e| BadInput::new(p, e.into()).into()),
        None => Ok(MachineProfile::default_plotter()),
    }
}

#[cfg(test)]
mod tests {
    use clap::Parser as _;

    use super::*;

    #[derive(clap::Parser, Debug)]
    struct Cli {
        #[command(flatten)]
        machine: MachineArgs,
    }

    fn args(flags: &[&str]) -> MachineArgs {
        let mut argv = vec!["test"];
        argv.extend_from_slice(flags);
        Cli::try_parse_from(argv).unwrap_or_else(|e| panic!("{flags:?}: {e}")).machine
    }

    fn refused(flags: &[&str]) -> String {
        let mut argv = vec!["test"];
        argv.extend_from_slice(flags);
        Cli::try_parse_from(argv).unwrap_err().to_string()
    }

    fn model(flags: &[&str]) -> MachineProfile {
        args(flags).load().unwrap_or_else(|e| panic!("{flags:?}: {e}"))
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-9
    }

    #[test]
    fn a_model_is_chosen_by_name_and_unknown_names_are_refused_with_the_list() {
        let p = model(&["--model", "axidraw-se-a3"]);
        assert_eq!((p.name.as_str(), p.axes.x.travel_mm), ("AxiDraw SE/A3", 430.0));
        assert_eq!(model(&[]), MachineProfile::default_plotter());
        let err = refused(&["--model", "axidraw-v4"]);
        assert!(err.contains("invalid value 'axidraw-v4' for '--model <MODEL>'"), "{err}");
        assert!(err.contains("possible values: xy-kit, servo-grbl, axidraw-v3"), "{err}");
        assert!(err.contains("a similar value exists: 'axidraw-v3'"), "{err}");
    }

    #[test]
    fn speed_pendown_is_a_percentage_of_the_top_speed_or_a_speed() {
        // AxiDraw: 25 000 steps/s / (80 steps/mm × √2) = 220.971 mm/s; 25 % of it.
        let p = model(&["--model", "axidraw-v3", "--speed-pendown", "25"]);
        assert!(close(p.pen.draw_feed_mm_s, 25_000.0 / (80.0 * 2f64.sqrt()) * 0.25), "{}", p.pen.draw_feed_mm_s);
        assert!((p.pen.draw_feed_mm_s - 55.243).abs() < 1e-3);
        // The kit: 50 % of its 150 mm/s axes.
        assert_eq!(model(&["--speed-pendown", "50"]).pen.draw_feed_mm_s, 75.0);
        assert_eq!(model(&["--speed-pendown", "42mm/s"]).pen.draw_feed_mm_s, 42.0);
        assert_eq!(model(&["--speed-pendown", "42 mm/s"]).pen.draw_feed_mm_s, 42.0);
        let err = refused(&["--speed-pendown", "150"]);
        assert!(err.contains("150 % is outside 1..=100 %"), "{err}");
        assert!(refused(&["--speed-pendown", "fast"]).contains("is not a speed"));
        assert!(refused(&["--speed-pendown", "0mm/s"]).contains("0 mm/s is outside 0.1..=5000 mm/s"));
    }

    #[test]
    fn speed_penup_sets_the_travel_feed() {
        // 75 % of 220.971 mm/s.
        let p = model(&["--model", "axidraw-v3", "--speed-penup", "75"]);
        assert!((p.pen.travel_feed_mm_s - 165.728).abs() < 1e-3, "{}", p.pen.travel_feed_mm_s);
        assert_eq!(model(&["--speed-penup", "100"]).pen.travel_feed_mm_s, 150.0);
        assert!(refused(&["--speed-penup", "0"]).contains("0 % is outside 1..=100 %"));
    }

    #[test]
    fn accel_scales_the_axes_and_the_caps() {
        let p = model(&["--accel", "50"]);
        assert_eq!(
            (p.axes.x.max_accel_mm_s2, p.axes.y.max_accel_mm_s2, p.axes.z.max_accel_mm_s2),
            (750.0, 750.0, 500.0)
        );
        // saxi's caps 200 and 400 mm/s², axes 400: a quarter of each.
        let s = model(&["--model", "axidraw-saxi", "--accel", "25"]);
        assert_eq!(
            (s.pen.draw_accel_mm_s2, s.pen.travel_accel_mm_s2, s.axes.x.max_accel_mm_s2),
            (Some(50.0), Some(100.0), 100.0)
        );
        assert!(refused(&["--accel", "0"]).contains("0 is outside 1..=100 %"));
        assert!(refused(&["--accel", "101"]).contains("101 is outside 1..=100 %"));
    }

    #[test]
    fn pen_pos_up_maps_to_each_kind_of_pen_lift() {
        // EBB standard servo: 9855 + 0.70 × 17976 = 22438.2.
        let p = model(&["--model", "axidraw-v3", "--pen-pos-up", "70"]);
        assert_eq!(p.ebb.unwrap().pen_up_position, 22_438);
        // Brushless lift: 5400 + 0.80 × 7200 = 11160.
        assert_eq!(model(&["--model", "nextdraw-8511", "--pen-pos-up", "80"]).ebb.unwrap().pen_up_position, 11_160);
        // A GRBL servo: 1.8° per percent.
        assert_eq!(model(&["--model", "servo-grbl", "--pen-pos-up", "60"]).pen.servo_up_deg, 108.0);
        // A Z pen: of the 10 mm Z travel.
        assert_eq!(model(&["--pen-pos-up", "55"]).pen.up_z_mm, 5.5);
        assert!(refused(&["--pen-pos-up", "101"]).contains("101 is outside 0..=100 %"));
    }

    #[test]
    fn pen_pos_down_maps_to_each_kind_of_pen_lift() {
        // 9855 + 0.25 × 17976 = 14349.
        let p = model(&["--model", "axidraw-v3", "--pen-pos-down", "25"]);
        assert_eq!(p.ebb.unwrap().pen_down_position, 14_349);
        // Up stays at 60 %: 35 % moved, 45 + 2.69 × 35 = 139.15 → 139 ms (the sweep at 50 %: 140 ms).
        assert_eq!(p.pen.settle_ms, 140.0);
        assert_eq!(model(&["--model", "servo-grbl", "--pen-pos-down", "10"]).pen.servo_down_deg, 18.0);
        assert_eq!(model(&["--pen-pos-down", "5"]).pen.down_z_mm, 0.5);
        assert!(refused(&["--pen-pos-down=-1"]).contains("-1 is outside 0..=100 %"));
    }

    #[test]
    fn the_profile_positions_and_settle_are_the_axidraw_defaults() {
        // The defaults given as flags change nothing: 60 %, 30 %, 75 %, 50 % are the sample's figures.
        let v3 = model(&["--model", "axidraw-v3"]);
        let same = model(&[
            "--model",
            "axidraw-v3",
            "--pen-pos-up",
            "60",
            "--pen-pos-down",
            "30",
            "--pen-rate-raise",
            "75",
            "--pen-rate-lower",
            "50",
        ]);
        assert_eq!(same, v3);
        let nd = model(&["--model", "nextdraw-8511"]);
        assert_eq!(model(&["--model", "nextdraw-8511", "--pen-pos-up", "60", "--pen-rate-lower", "50"]), nd);
    }

    #[test]
    fn pen_rate_raise_is_a_share_of_a_full_sweep() {
        // 17976 units per 200 ms = 2157.12 per 24 ms; 40 % = 862.8.
        let p = model(&["--model", "axidraw-v3", "--pen-rate-raise", "40"]);
        assert_eq!(p.ebb.unwrap().pen_rate_up, 863);
        // Raising 30 % at 40 %: 200 × 0.30 / 0.40 = 150 ms, longer than the servo's 125.7 ms.
        assert_eq!(p.pen.settle_ms, 150.0);
        let err = args(&["--pen-rate-raise", "40"]).load().unwrap_err().to_string();
        assert!(err.contains("only an EiBotBoard machine") && err.contains("XY plotter kit"), "{err}");
    }

    #[test]
    fn pen_rate_lower_is_a_share_of_a_full_sweep() {
        // 2157.12 × 0.20 = 431.4; lowering 30 % at 20 %: 300 ms.
        let p = model(&["--model", "axidraw-v3", "--pen-rate-lower", "20"]);
        assert_eq!((p.ebb.unwrap().pen_rate_down, p.pen.settle_ms), (431, 300.0));
        // Brushless: 7200 × 24 / 70 = 2468.6 per cycle, 25 % = 617; 70 × 0.3 / 0.25 + 8 = 92 ms.
        let nd = model(&["--model", "nextdraw-8511", "--pen-rate-lower", "25"]);
        assert_eq!((nd.ebb.unwrap().pen_rate_down, nd.pen.settle_ms), (617, 92.0));
    }

    #[test]
    fn pen_delay_up_is_added_to_the_settle_or_waited_after_the_lift() {
        // The kit: 50 ms settle + 100; a Z pen's travel waits for the settle.
        assert_eq!(model(&["--pen-delay-up", "100"]).pen.settle_ms, 150.0);
        // A servo pen: the swing keeps its 150 ms (the drops are timed from it); travel waits 100 ms more.
        let s = model(&["--model", "servo-grbl", "--pen-delay-up", "100ms"]);
        assert_eq!(
            (s.pen.settle_ms, s.pen.clear_ms, s.pen.lift_delay_ms, s.pen.drop_delay_ms),
            (150.0, None, 100.0, 0.0)
        );
        // The AxiDraw: 126 ms settle unchanged, 40 ms after the lift.
        let v3 = model(&["--model", "axidraw-v3", "--pen-delay-up", "40"]);
        assert_eq!((v3.pen.settle_ms, v3.pen.lift_delay_ms), (126.0, 40.0));
        assert!(refused(&["--pen-delay-up", "10001"]).contains("10001 ms is outside 0..=10000 ms"));
    }

    #[test]
    fn pen_delay_down_is_added_to_the_settle_or_waited_after_the_touch() {
        let s = model(&["--model", "servo-grbl", "--pen-delay-down", "70"]);
        assert_eq!(
            (s.pen.settle_ms, s.pen.clear_ms, s.pen.lift_delay_ms, s.pen.drop_delay_ms),
            (150.0, None, 0.0, 70.0)
        );
        let v3 = model(&["--model", "axidraw-v3", "--pen-delay-down", "70"]);
        assert_eq!((v3.pen.settle_ms, v3.pen.drop_delay_ms), (126.0, 70.0));
        // A Z pen: the longer is added once to its one settle.
        assert_eq!(model(&["--pen-delay-down", "30", "--pen-delay-up", "20"]).pen.settle_ms, 80.0);
    }

    #[test]
    fn settings_the_profile_cannot_take_are_refused_after_applying() {
        // 100 % of the kit's 150 mm/s, then a 0.1 mm/s feed at 80 steps/mm is fine; Z at 100 % of 10 mm is the top.
        let p = model(&["--pen-pos-up", "100"]);
        assert_eq!(p.pen.up_z_mm, 10.0);
        // A profile file and a model: the file's keys over the model's.
        let dir = std::env::temp_dir().join(format!("machine-args-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("slow.toml");
        std::fs::write(&f, "[pen]\ndraw_feed_mm_s = 20.0\n").unwrap();
        let p = model(&["--model", "axidraw-v3", "--profile", f.to_str().unwrap()]);
        assert_eq!((p.pen.draw_feed_mm_s, p.axes.x.travel_mm), (20.0, 300.0));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
