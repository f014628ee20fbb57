//! Machine profiles (TOML): what the plotter is — steps per mm, travel, speed and acceleration limits, pen lift,
//! homing, link settings — and the one place where page coordinates map to machine coordinates.
//!
//! Page coordinates are millimetres with the origin at the top-left of the page and Y pointing down (as in SVG).
//! Machine coordinates are millimetres from the homed origin. [`MachineProfile::page_to_machine`] is the only
//! conversion between the two; nothing else in the pipeline flips or offsets axes.

use std::path::Path;

use kurbo::{Point, Rect};
use plotter_fw::thermal::ThermalConfig;
use serde::{Deserialize, Serialize};

use crate::config::heaters::HeatersProfile;

/// Errors loading a machine profile.
#[derive(Debug, thiserror::Error)]
pub enum ProfileError {
    /// The file could not be read.
    #[error("cannot read machine profile {path}: {source}")]
    Read {
        /// The file.
        path: String,
        /// The OS error.
        source: std::io::Error,
    },
    /// The TOML did not parse or did not match the schema.
    #[error("invalid machine profile {path}: {message}")]
    Parse {
        /// The file.
        path: String,
        /// Parser message, with line and column.
        message: String,
    },
    /// A value is out of range.
    #[error("invalid machine profile {path}: {field}: {problem}")]
    Invalid {
        /// The file.
        path: String,
        /// Dotted field name.
        field: String,
        /// What is wrong.
        problem: String,
    },
}

/// Limits and scaling of one axis.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AxisProfile {
    /// Full steps × microsteps per millimetre of travel.
    pub steps_per_mm: f64,
    /// Usable travel from the homed origin, millimetres.
    pub travel_mm: f64,
    /// Maximum feed, mm/s.
    pub max_feed_mm_s: f64,
    /// Maximum acceleration, mm/s².
    pub max_accel_mm_s2: f64,
    /// Invert the direction pin.
    #[serde(default)]
    pub invert_dir: bool,
    /// Which end of the axis holds the homing switch.
    #[serde(default)]
    pub home: HomeEnd,
}

/// The end of an axis where its homing switch sits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum HomeEnd {
    /// The switch is at position 0; homing moves towards negative.
    #[default]
    Min,
    /// The switch is at `travel_mm`; homing moves towards positive.
    Max,
}

/// The machine's axes. X and Y draw; Z lifts the pen; E exists for the 3D-printer profile.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Axes {
    /// Horizontal axis.
    pub x: AxisProfile,
    /// Vertical (page) axis.
    pub y: AxisProfile,
    /// Pen lift axis.
    pub z: AxisProfile,
    /// Extruder, printers only.
    #[serde(default)]
    pub e: Option<AxisProfile>,
}

/// How the pen is lifted and lowered.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PenCommand {
    /// Pen as Z moves (`G0 Z<up>` / `G1 Z<down>`).
    #[default]
    Z,
    /// Servo pen: `M3 S<down>` / `M5` as on GRBL-based servo plotters.
    Servo,
}

/// Pen lift and drawing speeds.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PenProfile {
    /// Z position (mm) with the pen up.
    pub up_z_mm: f64,
    /// Z position (mm) with the pen on the paper.
    pub down_z_mm: f64,
    /// Dwell after each lift or drop, milliseconds.
    pub settle_ms: f64,
    /// Feed while drawing, mm/s.
    pub draw_feed_mm_s: f64,
    /// Feed of pen-up travel, mm/s.
    pub travel_feed_mm_s: f64,
    /// Lift mechanism: a Z axis, or a hobby servo (`M3 S<angle>` / `M5`) that needs `settle_ms` to reach its angle.
    #[serde(default)]
    pub command: PenCommand,
    /// Width of the line the pen draws, mm: path ends closer than half of it are joined, and pen-up gaps shorter
    /// than it are drawn through with the pen down (see `plotter optimize`). Default 0.3 mm (a fineliner).
    #[serde(default = "default_pen_width")]
    pub width_mm: f64,
    /// Servo pens: the angle (degrees, 0..=180) holding the pen up.
    #[serde(default = "default_servo_up")]
    pub servo_up_deg: f64,
    /// Servo pens: the angle (degrees, 0..=180) putting the pen on the paper.
    #[serde(default = "default_servo_down")]
    pub servo_down_deg: f64,
    /// Z pens: how far above the pen-down height the tip is clear of the paper, mm (default 1 mm). Pen-up travel
    /// starts as soon as a lift has reached this height and ends at it, the rest of the lift and drop happening
    /// during the travel (see [`crate::motion::hop`]). Capped at the pen-up height.
    #[serde(default = "default_clearance")]
    pub clearance_mm: f64,
    /// Servo pens: how long after a lift command the tip is clear of the paper, milliseconds (0..=`settle_ms`;
    /// default a third of `settle_ms`). Travel starts after it; a drop is taken to pass the same height this long
    /// before its settle ends, so it is commanded while the carriage is still travelling.
    #[serde(default)]
    pub clear_ms: Option<f64>,
    /// Acceleration along the path while drawing, mm/s² (default: only the axes' limits). A cap below what the
    /// axes allow, for a pen that skips or a machine that shakes when it draws (saxi, for one, draws at 200 and
    /// travels at 400 mm/s²).
    #[serde(default)]
    pub draw_accel_mm_s2: Option<f64>,
    /// Acceleration along the path of pen-up travel, mm/s² (default: only the axes' limits).
    #[serde(default)]
    pub travel_accel_mm_s2: Option<f64>,
}

impl PenProfile {
    /// Whether the pen is lifted by a hobby servo (no Z axis moves for it).
    pub fn uses_servo(&self) -> bool {
        self.command == PenCommand::Servo
    }

    /// Servo pens: milliseconds from a lift command until the tip is clear ([`Self::clear_ms`], by default a
    /// third of the settle time).
    pub fn servo_clear_ms(&self) -> f64 {
        self.clear_ms.unwrap_or(self.settle_ms / 3.0)
    }
}

/// Height above the pen-down Z at which the tip is clear of the paper when a profile does not say, mm.
pub const DEFAULT_CLEARANCE_MM: f64 = 1.0;

fn default_clearance() -> f64 {
    DEFAULT_CLEARANCE_MM
}

/// Pen width assumed when a profile does not give one, mm.
pub const DEFAULT_PEN_WIDTH_MM: f64 = 0.3;

fn default_pen_width() -> f64 {
    DEFAULT_PEN_WIDTH_MM
}

fn default_servo_up() -> f64 {
    90.0
}

fn default_servo_down() -> f64 {
    30.0
}

/// One pen of the profile's pen table (`[[pens]]`). A layer is drawn with the pen whose `name` equals the layer's
/// name (case-insensitive) or, failing that, whose `color` equals the layer's stroke colour; the optional values
/// override the profile's `[pen]` defaults while that pen is loaded.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PenSpec {
    /// What the user is asked to load ("fine black", "red 0.5").
    pub name: String,
    /// Ink colour as `#rrggbb`.
    #[serde(default)]
    pub color: Option<String>,
    /// Nib width, mm.
    #[serde(default)]
    pub width_mm: Option<f64>,
    /// Pen-down Z for this pen, mm (Z pens).
    #[serde(default)]
    pub down_z_mm: Option<f64>,
    /// Pen-down servo angle for this pen, degrees (servo pens).
    #[serde(default)]
    pub servo_down_deg: Option<f64>,
    /// Drawing feed with this pen, mm/s.
    #[serde(default)]
    pub draw_feed_mm_s: Option<f64>,
    /// Shade the filled areas of SVG layers drawn with this pen (`hatch = { spacing_mm = 0.8 }`); `--hatch`
    /// overrides it for every layer.
    #[serde(default)]
    pub hatch: Option<PenHatch>,
}

/// Hatching of a pen's filled areas, from the pen table.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PenHatch {
    /// Distance between neighbouring lines, mm.
    pub spacing_mm: f64,
    /// Line direction, degrees counter-clockwise from +X on the page.
    #[serde(default = "PenHatch::default_angle")]
    pub angle_deg: f64,
    /// Add a second family of lines at right angles.
    #[serde(default)]
    pub cross: bool,
}

impl PenHatch {
    fn default_angle() -> f64 {
        45.0
    }
}

/// Where the carriage waits during a pen change (machine millimetres).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ParkProfile {
    /// Machine X, mm.
    pub x_mm: f64,
    /// Machine Y, mm.
    pub y_mm: f64,
}

/// Cornering and planning settings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MotionProfile {
    /// Junction deviation, mm (grbl's cornering model, used at corners).
    pub junction_deviation_mm: f64,
    /// Largest chord deviation, mm, at which a polyline still counts as one smooth curve, planned from its radius
    /// (`v² = a·r`) instead of corner by corner; 0 treats every vertex as a corner. Default 0.1 mm, twice the
    /// default flattening tolerance.
    #[serde(default = "default_curve_deviation")]
    pub curve_deviation_mm: f64,
}

fn default_curve_deviation() -> f64 {
    0.1
}

/// Homing cycle settings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HomingProfile {
    /// Fast seek rate, mm/s.
    pub seek_mm_s: f64,
    /// Slow locate rate, mm/s.
    pub locate_mm_s: f64,
    /// Pull-off distance after each switch contact, mm.
    pub pull_off_mm: f64,
    /// Switch debounce, milliseconds.
    pub debounce_ms: f64,
}

/// Serial link and firmware buffer sizes.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinkProfile {
    /// Baud rate.
    pub baud: u32,
    /// Firmware receive buffer, bytes (the host never has more in flight).
    pub rx_buffer_bytes: u32,
    /// Firmware planner queue length, blocks.
    pub queue_blocks: u32,
}

/// The corner of the machine's work area that page (0, 0) — the page's top-left — maps to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum PageOrigin {
    /// Machine Y grows in the page's down direction (most XY plotter kits homing at the far-left corner).
    #[default]
    TopLeft,
    /// Machine Y grows upwards (3D printers, AxiDraw-like frames seen from the other side).
    BottomLeft,
}

/// A complete machine description, loaded from TOML.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MachineProfile {
    /// Human name, shown by the CLI.
    pub name: String,
    /// Where the page's top-left lands on the machine.
    #[serde(default)]
    pub page_origin: PageOrigin,
    /// Axis limits.
    pub axes: Axes,
    /// Pen lift and speeds.
    pub pen: PenProfile,
    /// Planner settings.
    pub motion: MotionProfile,
    /// Homing cycle.
    pub homing: HomingProfile,
    /// Serial link.
    pub link: LinkProfile,
    /// Pen table (`[[pens]]`), empty when the profile names no pens: each layer colour is then its own pen.
    #[serde(default)]
    pub pens: Vec<PenSpec>,
    /// Pen-change park position; the homed corner when absent.
    #[serde(default)]
    pub park: Option<ParkProfile>,
    /// Heaters and fan (printers only; see [`crate::config::heaters`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub heaters: Option<HeatersProfile>,
    /// EiBotBoard settings (AxiDraw-class machines driven with `--firmware ebb`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ebb: Option<EbbProfile>,
}

/// The settings of an EiBotBoard machine (AxiDraw, NextDraw, iDraw): its pen servo in the board's own units
/// (pulse widths of 1/12 MHz ≈ 83.3 ns, slew rates per 24 ms servo cycle) and its motion limits. The X and Y
/// `steps_per_mm` are motor steps along one axis (motor 1 moves X+Y, motor 2 X−Y).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EbbProfile {
    /// Servo pulse with the pen up (`SC,4`), 1/12 µs units.
    pub pen_up_position: u16,
    /// Servo pulse with the pen down (`SC,5`), 1/12 µs units; a pen's `servo_down_deg` between the `[pen]` angles
    /// is interpolated between the two positions.
    pub pen_down_position: u16,
    /// Servo slew when raising (`SC,11`), pulse units per 24 ms; 0 = at once.
    pub pen_rate_up: u16,
    /// Servo slew when lowering (`SC,12`), pulse units per 24 ms; 0 = at once.
    pub pen_rate_down: u16,
    /// The PortB pin of the pen servo (`SP`'s third argument): 1 for the standard servo (B1), 2 for the
    /// narrow-band brushless lift (B2) of newer machines.
    #[serde(default = "default_pen_pin")]
    pub pen_pin: u8,
    /// Servo power timeout (`SR`), ms; 0 keeps it powered.
    #[serde(default = "default_servo_timeout")]
    pub servo_timeout_ms: u32,
    /// Step mode for `EM` (1 = 1/16 microsteps, … 5 = full steps); the steps per mm above must match it.
    #[serde(default = "default_step_mode")]
    pub step_mode: u8,
    /// Shortest move the board sustains without gaps, ms (the reference measures 4 ms for `LM` on firmware 3):
    /// plan phases shorter than this are joined.
    #[serde(default = "default_min_move_ms")]
    pub min_move_ms: f64,
}

fn default_pen_pin() -> u8 {
    1
}

fn default_servo_timeout() -> u32 {
    60_000
}

fn default_step_mode() -> u8 {
    1
}

fn default_min_move_ms() -> f64 {
    4.0
}

/// The XY plotter kit profile shipped as `samples/xy-plotter.toml`, compiled in as the default.
pub const DEFAULT_PROFILE_TOML: &str = include_str!("../../../samples/xy-plotter.toml");

impl MachineProfile {
    /// Parse a profile from TOML text; `origin` names the source in errors.
    pub fn from_toml(text: &str, origin: &str) -> Result<Self, ProfileError> {
        let profile: MachineProfile = toml::from_str(text)
            .map_err(|e| ProfileError::Parse { path: origin.to_string(), message: e.to_string() })?;
        profile.validate(origin)?;
        Ok(profile)
    }

    /// Load a profile from a TOML file.
    pub fn load(path: &Path) -> Result<Self, ProfileError> {
        let shown = path.display().to_string();
        let text =
            std::fs::read_to_string(path).map_err(|source| ProfileError::Read { path: shown.clone(), source })?;
        Self::from_toml(&text, &shown)
    }

    /// The built-in XY plotter kit profile.
    pub fn default_plotter() -> Self {
        // The embedded sample is checked by a unit test, so this cannot fail at run time.
        Self::from_toml(DEFAULT_PROFILE_TOML, "built-in xy-plotter profile").unwrap_or_else(|e| unreachable!("{e}"))
    }

    /// The drawable area in page coordinates (mm): the X and Y travel from the page origin.
    pub fn work_area(&self) -> Rect {
        Rect::new(0.0, 0.0, self.axes.x.travel_mm, self.axes.y.travel_mm)
    }

    /// Map a page point (mm, origin top-left, Y down) to machine coordinates (mm from the homed origin).
    pub fn page_to_machine(&self, p: Point) -> Point {
        match self.page_origin {
            PageOrigin::TopLeft => p,
            PageOrigin::BottomLeft => Point::new(p.x, self.axes.y.travel_mm - p.y),
        }
    }

    /// Inverse of [`page_to_machine`](Self::page_to_machine).
    pub fn machine_to_page(&self, p: Point) -> Point {
        // The mapping is an involution for both origins.
        self.page_to_machine(p)
    }

    fn validate(&self, origin: &str) -> Result<(), ProfileError> {
        let bad = |field: &str, problem: &str| ProfileError::Invalid {
            path: origin.to_string(),
            field: field.to_string(),
            problem: problem.to_string(),
        };
        let axes = [("x", Some(self.axes.x)), ("y", Some(self.axes.y)), ("z", Some(self.axes.z)), ("e", self.axes.e)];
        for (name, axis) in axes {
            let Some(a) = axis else { continue };
            for (field, v) in [
                ("steps_per_mm", a.steps_per_mm),
                ("max_feed_mm_s", a.max_feed_mm_s),
                ("max_accel_mm_s2", a.max_accel_mm_s2),
            ] {
                if !(v.is_finite() && v > 0.0) {
                    return Err(bad(&format!("axes.{name}.{field}"), "must be a positive number"));
                }
            }
            if !(a.travel_mm.is_finite() && a.travel_mm >= 0.0) {
                return Err(bad(&format!("axes.{name}.travel_mm"), "must be zero or positive"));
            }
        }
        let positive = [
            ("pen.draw_feed_mm_s", self.pen.draw_feed_mm_s),
            ("pen.travel_feed_mm_s", self.pen.travel_feed_mm_s),
            ("motion.junction_deviation_mm", self.motion.junction_deviation_mm),
            ("homing.seek_mm_s", self.homing.seek_mm_s),
            ("homing.locate_mm_s", self.homing.locate_mm_s),
        ];
        for (field, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(bad(field, "must be a positive number"));
            }
        }
        for (field, v) in [
            ("pen.draw_accel_mm_s2", self.pen.draw_accel_mm_s2),
            ("pen.travel_accel_mm_s2", self.pen.travel_accel_mm_s2),
        ] {
            if v.is_some_and(|v| !(v.is_finite() && v > 0.0)) {
                return Err(bad(field, "must be a positive number"));
            }
        }
        for (field, v) in [
            ("pen.settle_ms", self.pen.settle_ms),
            ("homing.pull_off_mm", self.homing.pull_off_mm),
            ("homing.debounce_ms", self.homing.debounce_ms),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(bad(field, "must be zero or positive"));
            }
        }
        for (field, v, max) in [
            ("motion.curve_deviation_mm", self.motion.curve_deviation_mm, 10.0),
            ("pen.width_mm", self.pen.width_mm, 10.0),
        ] {
            if !(v.is_finite() && (0.0..=max).contains(&v)) {
                return Err(bad(field, "must lie in 0..=10 mm"));
            }
        }
        for (field, z) in [("pen.up_z_mm", self.pen.up_z_mm), ("pen.down_z_mm", self.pen.down_z_mm)] {
            if !(z.is_finite() && (0.0..=self.axes.z.travel_mm).contains(&z)) {
                return Err(bad(field, "must lie within the Z travel"));
            }
        }
        if !(self.pen.clearance_mm.is_finite() && self.pen.clearance_mm > 0.0) {
            return Err(bad("pen.clearance_mm", "must be a positive number"));
        }
        if let Some(c) = self.pen.clear_ms
            && !(c.is_finite() && (0.0..=self.pen.settle_ms).contains(&c))
        {
            return Err(bad("pen.clear_ms", "must lie in 0..=pen.settle_ms"));
        }
        for (field, a) in [("pen.servo_up_deg", self.pen.servo_up_deg), ("pen.servo_down_deg", self.pen.servo_down_deg)]
        {
            if !(a.is_finite() && (0.0..=180.0).contains(&a)) {
                return Err(bad(field, "must be an angle from 0 to 180 degrees"));
            }
        }
        for (i, pen) in self.pens.iter().enumerate() {
            let f = |name: &str| format!("pens[{i}] ({}).{name}", pen.name);
            if pen.name.trim().is_empty() {
                return Err(bad(&format!("pens[{i}].name"), "must not be empty"));
            }
            if let Some(c) = &pen.color
                && crate::config::color::parse_hex_color(c).is_none()
            {
                return Err(bad(&f("color"), "must be #rrggbb"));
            }
            for (name, v) in [("width_mm", pen.width_mm), ("draw_feed_mm_s", pen.draw_feed_mm_s)] {
                if v.is_some_and(|v| !(v.is_finite() && v > 0.0)) {
                    return Err(bad(&f(name), "must be a positive number"));
                }
            }
            if pen.down_z_mm.is_some_and(|z| !(z.is_finite() && (0.0..=self.axes.z.travel_mm).contains(&z))) {
                return Err(bad(&f("down_z_mm"), "must lie within the Z travel"));
            }
            if pen.servo_down_deg.is_some_and(|a| !(a.is_finite() && (0.0..=180.0).contains(&a))) {
                return Err(bad(&f("servo_down_deg"), "must be an angle from 0 to 180 degrees"));
            }
            if let Some(h) = pen.hatch {
                if !(h.spacing_mm.is_finite() && (0.01..=100.0).contains(&h.spacing_mm)) {
                    return Err(bad(&f("hatch.spacing_mm"), "must lie in 0.01..=100 mm"));
                }
                if !h.angle_deg.is_finite() {
                    return Err(bad(&f("hatch.angle_deg"), "must be a finite number of degrees"));
                }
            }
        }
        if let Some(park) = self.park
            && !(park.x_mm.is_finite()
                && park.y_mm.is_finite()
                && (0.0..=self.axes.x.travel_mm).contains(&park.x_mm)
                && (0.0..=self.axes.y.travel_mm).contains(&park.y_mm))
        {
            return Err(bad("park", "must lie within the X and Y travel"));
        }
        if self.link.baud == 0 || self.link.rx_buffer_bytes < 64 || self.link.queue_blocks == 0 {
            return Err(bad("link", "baud and queue_blocks must be positive, rx_buffer_bytes at least 64"));
        }
        if let Some(e) = &self.ebb {
            if e.pen_up_position == 0 || e.pen_down_position == 0 {
                return Err(bad("ebb.pen_up_position", "servo positions must lie in 1..=65535"));
            }
            if !(0..=7).contains(&e.pen_pin) {
                return Err(bad("ebb.pen_pin", "must be a PortB pin, 0..=7"));
            }
            if !(1..=5).contains(&e.step_mode) {
                return Err(bad("ebb.step_mode", "must be 1 (1/16 step) ..= 5 (full step)"));
            }
            if !(e.min_move_ms.is_finite() && (0.0..=100.0).contains(&e.min_move_ms)) {
                return Err(bad("ebb.min_move_ms", "must lie in 0..=100 ms"));
            }
            if !self.pen.uses_servo() {
                return Err(bad("pen.command", "an EBB machine lifts its pen with a servo: set it to \"servo\""));
            }
        }
        if let Some(h) = &self.heaters {
            if self.axes.e.is_none() {
                return Err(bad("heaters", "heaters need an extruder axis (axes.e)"));
            }
            if let Err(e) = h.to_config() {
                let (field, problem) = e.split_once(": ").unwrap_or(("heaters", e.as_str()));
                return Err(bad(field, problem));
            }
        }
        Ok(())
    }
}

/// The heaters of `profile` for the firmware ([`ThermalConfig::NONE`] without a `[heaters]` section).
pub fn thermal_config(profile: &MachineProfile) -> Result<ThermalConfig, String> {
    profile.heaters.as_ref().map_or(Ok(ThermalConfig::NONE), HeatersProfile::to_config)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pen_hatch_parses_with_defaults_and_is_checked() {
        let text = format!("{DEFAULT_PROFILE_TOML}\n[[pens]]\nname = \"gel\"\nhatch = {{ spacing_mm = 0.5 }}\n");
        let p = MachineProfile::from_toml(&text, "h.toml").unwrap();
        let h = p.pens.last().unwrap().hatch.unwrap();
        assert_eq!((h.spacing_mm, h.angle_deg, h.cross), (0.5, 45.0, false));
        assert_eq!(
            crate::geometry::hatch::FillHatch::from(h),
            crate::geometry::hatch::FillHatch { spacing_mm: 0.5, angle_deg: 45.0, cross: false, link: true }
        );
        let bad = text.replace("spacing_mm = 0.5", "spacing_mm = 0");
        let err = MachineProfile::from_toml(&bad, "h.toml").unwrap_err().to_string();
        assert!(err.contains("pens[3] (gel).hatch.spacing_mm") && err.contains("0.01..=100 mm"), "{err}");
    }

    #[test]
    fn built_in_profile_parses() {
        let p = MachineProfile::default_plotter();
        assert!(p.work_area().width() > 100.0);
        assert!(p.pen.up_z_mm > p.pen.down_z_mm);
    }

    #[test]
    fn printer_sample_parses_and_flips_y() {
        let text = include_str!("../../../samples/printer.toml");
        let p = MachineProfile::from_toml(text, "printer.toml").unwrap();
        assert_eq!(p.page_origin, PageOrigin::BottomLeft);
        let m = p.page_to_machine(Point::new(10.0, 20.0));
        assert_eq!(m, Point::new(10.0, p.axes.y.travel_mm - 20.0));
        assert_eq!(p.machine_to_page(m), Point::new(10.0, 20.0));
        assert!(p.axes.e.is_some());
    }

    #[test]
    fn pen_table_and_park_parse_and_are_checked() {
        let text = format!(
            "{DEFAULT_PROFILE_TOML}\n[park]\nx_mm = 5.0\ny_mm = 280.0\n\n[[pens]]\nname = \"red\"\ncolor = \"#ff0000\"\n\
             draw_feed_mm_s = 30.0\n"
        );
        let p = MachineProfile::from_toml(&text, "pens.toml").unwrap();
        // The kit's three pens, then this one.
        assert_eq!(p.pens.len(), 4);
        assert_eq!(p.pens[2].draw_feed_mm_s, Some(30.0), "the blue brush pen draws slower");
        assert_eq!((p.pens[3].name.as_str(), p.pens[3].draw_feed_mm_s), ("red", Some(30.0)));
        assert_eq!(p.park, Some(ParkProfile { x_mm: 5.0, y_mm: 280.0 }));
        let bad = text.replace("color = \"#ff0000\"\ndraw", "color = \"red\"\ndraw");
        let err = MachineProfile::from_toml(&bad, "pens.toml").unwrap_err().to_string();
        assert!(err.contains("pens[3] (red).color") && err.contains("#rrggbb"), "{err}");
        let err = MachineProfile::from_toml(&text.replace("y_mm = 280.0", "y_mm = 300.0"), "p.toml").unwrap_err();
        assert!(err.to_string().contains("park"), "{err}");
    }

    #[test]
    fn pen_clearance_defaults_and_is_checked() {
        let p = MachineProfile::default_plotter();
        assert_eq!((p.pen.clearance_mm, p.pen.clear_ms), (1.0, None));
        // The kit's 50 ms settle: clear after a third of it.
        assert!((p.pen.servo_clear_ms() - 50.0 / 3.0).abs() < 1e-12);
        let with = |line: &str| DEFAULT_PROFILE_TOML.replace("clearance_mm = 1.0", line);
        let p = MachineProfile::from_toml(&with("clearance_mm = 0.5\nclear_ms = 20"), "c.toml").unwrap();
        assert_eq!((p.pen.clearance_mm, p.pen.servo_clear_ms()), (0.5, 20.0));
        for (line, field) in [("clearance_mm = 0", "pen.clearance_mm"), ("clear_ms = 60", "pen.clear_ms")] {
            let err = MachineProfile::from_toml(&with(line), "c.toml").unwrap_err().to_string();
            assert!(err.contains(field) && err.contains("c.toml"), "{err}");
        }
    }

    #[test]
    fn errors_name_the_field_and_file() {
        let text = DEFAULT_PROFILE_TOML.replace("junction_deviation_mm = 0.02", "junction_deviation_mm = -1.0");
        let err = MachineProfile::from_toml(&text, "mine.toml").unwrap_err().to_string();
        assert!(err.contains("mine.toml") && err.contains("motion.junction_deviation_mm"), "{err}");
        let err = MachineProfile::from_toml("name = 3", "x.toml").unwrap_err().to_string();
        assert!(err.contains("x.toml"), "{err}");
    }
}
