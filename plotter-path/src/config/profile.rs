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
use crate::config::models::Model;
use crate::config::servo_sync::ServoSync;

/// Errors loading a machine profile.
#[derive(Debug, thiserror::Error)]
pub enum ProfileError {
    /// The file could not be read.
    // The OS error is part of the message, not a source: a chain printed with its sources said it twice.
    #[error("cannot read machine profile {path}: {error}")]
    Read {
        /// The file.
        path: String,
        /// The OS error.
        error: std::io::Error,
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
    /// Servo pens: how long after a lift command the tip is clear of the paper, milliseconds (0..=`settle_ms`).
    /// Travel starts after it. Without it (the default) the time follows from the servo's rate and
    /// `contact_fraction` (see [`crate::motion::servo`]); give it only for a lift slower than that.
    #[serde(default)]
    pub clear_ms: Option<f64>,
    /// Servo pens: the fraction (0.05..=1) of the servo's travel from the pen-up to the pen-down position at which
    /// the tip touches the paper. A drop is timed so that the carriage has arrived at the stroke's start when the
    /// servo reaches it and the line starts then, the rest of the servo's travel overlapping the drawing; a lift
    /// lets the carriage go once the servo is back past it. Default 0.7, cautiously early: a pen holder is set up
    /// with its down position somewhat below where the tip meets the paper (so that the pen rests on it), and a
    /// contact taken early errs towards a line whose first fraction of a millimetre the tip lands on a moment
    /// late (the carriage starts from rest: 0.1 mm takes 16 ms at 760 mm/s²), never towards a tip that lands
    /// while the carriage is still arriving and marks the paper before the line.
    #[serde(default = "default_contact_fraction")]
    pub contact_fraction: f64,
    /// Servo pens: an extra wait after the tip is clear of the paper before travel starts, milliseconds
    /// (0..=10000; default 0). The AxiDraw-style `--pen-delay-up`; the servo's own timing is unchanged.
    #[serde(default)]
    pub lift_delay_ms: f64,
    /// Servo pens: an extra wait after the tip touches the paper before the line starts, milliseconds
    /// (0..=10000; default 0). The AxiDraw-style `--pen-delay-down`, for an ink that needs a moment to flow; the
    /// servo's own timing is unchanged.
    #[serde(default)]
    pub drop_delay_ms: f64,
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

/// The fraction of a servo's down travel at which the tip touches the paper when a profile does not say (see
/// [`PenProfile::contact_fraction`] for the reason of the value).
pub const DEFAULT_CONTACT_FRACTION: f64 = 0.7;

fn default_contact_fraction() -> f64 {
    DEFAULT_CONTACT_FRACTION
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
    /// Shade the filled areas of SVG layers drawn with this pen (`hatch = { spacing_mm = 0.8 }`, or
    /// `hatch = { tone = true }` to space the lines by each fill's lightness at this pen's width); `--hatch`
    /// overrides it for every layer.
    #[serde(default)]
    pub hatch: Option<PenHatch>,
}

/// Hatching of a pen's filled areas, from the pen table.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PenHatch {
    /// Distance between neighbouring lines, mm (not read with `tone`).
    #[serde(default)]
    pub spacing_mm: f64,
    /// Line direction, degrees counter-clockwise from +X on the page.
    #[serde(default = "PenHatch::default_angle")]
    pub angle_deg: f64,
    /// Add a second family of lines at right angles.
    #[serde(default)]
    pub cross: bool,
    /// Space the lines by each fill's lightness instead (`--hatch tone` for this pen's layers, at its width).
    #[serde(default)]
    pub tone: bool,
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
    /// Whether the pen is still clear of the paper when Z reaches a switch at the minimum end. Default `false`
    /// (cautious: the pen touches first), and then a Z whose height was lost is not homed where the carriage
    /// stands, which would press the pen onto the drawing.
    #[serde(default)]
    pub pen_clear_at_z_switch: bool,
    /// Where Z may be homed when its height is unknown on a machine whose pen touches before its Z switch (a
    /// power cycle mid-plot): machine X and Y, mm, a spot off the paper where the pen may touch the bed. The
    /// resume then lifts the pen, homes X and Y, travels there and homes Z; so does a new plot's homing when the
    /// machine was switched on since Z was homed (its carriage may stand over the fresh sheet). Absent (the
    /// default): the resume refuses and asks the user to move the carriage off the paper and home Z (`plotter
    /// home --z`), and a new plot homes Z where the carriage stands.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub z_home_xy_mm: Option<[f64; 2]>,
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
    /// G-code export templates (`[gcode]`: header, footer, pen up and down, layer start and end, tool change).
    #[serde(default)]
    pub gcode: crate::config::gcode_template::GcodeTemplate,
    /// Whether the firmware plotted with runs a servo pen's drop while the carriage moves: never read from a
    /// profile file; the host sets it from the firmware it talks to (our firmware and the EiBotBoard do, GRBL
    /// stops). See [`ServoSync`].
    #[serde(skip)]
    pub servo_sync: ServoSync,
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
    /// A profile that says `model = "NAME"` extends that built-in model (see [`crate::config::models`]).
    pub fn from_toml(text: &str, origin: &str) -> Result<Self, ProfileError> {
        let parse = |e: toml::de::Error| ProfileError::Parse { path: origin.to_string(), message: e.to_string() };
        let table: toml::Table = toml::from_str(text).map_err(parse)?;
        if table.contains_key("model") {
            return Self::from_table(table, origin);
        }
        // Parsed from the text itself, so that a schema error names its line and column.
        let profile: MachineProfile = toml::from_str(text).map_err(parse)?;
        profile.validate(origin)?;
        Ok(profile)
    }

    /// A profile from parsed TOML (its `model = "NAME"` key expanded), validated; `origin` names it in errors.
    pub fn from_table(table: toml::Table, origin: &str) -> Result<Self, ProfileError> {
        let table = crate::config::models::expand(table, origin)
            .map_err(|e| ProfileError::Parse { path: e.path, message: e.message })?;
        let profile: MachineProfile = toml::Value::Table(table)
            .try_into()
            .map_err(|e: toml::de::Error| ProfileError::Parse { path: origin.to_string(), message: e.to_string() })?;
        profile.validate(origin)?;
        Ok(profile)
    }

    /// Load a profile from a TOML file.
    pub fn load(path: &Path) -> Result<Self, ProfileError> {
        let shown = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|error| ProfileError::Read { path: shown.clone(), error })?;
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

    /// Check every number against its physical range (and the sections against each other), as loading does;
    /// `origin` names the profile in errors. For a profile changed after loading (command-line overrides).
    pub fn validate(&self, origin: &str) -> Result<(), ProfileError> {
        let bad = |field: &str, problem: &str| ProfileError::Invalid {
            path: origin.to_string(),
            field: field.to_string(),
            problem: problem.to_string(),
        };
        // Every number against its physical range (see `limits`), named with its dotted key.
        let within = |field: &str, v: f64, r: &Range| -> Result<(), ProfileError> {
            if v.is_finite() && (r.lo..=r.hi).contains(&v) { Ok(()) } else { Err(bad(field, &r.refusal(v))) }
        };
        let axes = [("x", Some(self.axes.x)), ("y", Some(self.axes.y)), ("z", Some(self.axes.z)), ("e", self.axes.e)];
        for (name, axis) in axes {
            let Some(a) = axis else { continue };
            let key = |field: &str| format!("axes.{name}.{field}");
            within(&key("steps_per_mm"), a.steps_per_mm, &limits::STEPS_PER_MM)?;
            let travel = if matches!(name, "x" | "y") { &limits::XY_TRAVEL } else { &limits::ZE_TRAVEL };
            within(&key("travel_mm"), a.travel_mm, travel)?;
            within(&key("max_feed_mm_s"), a.max_feed_mm_s, &limits::FEED)?;
            within(&key("max_accel_mm_s2"), a.max_accel_mm_s2, &limits::ACCEL)?;
            let rate = a.max_feed_mm_s * a.steps_per_mm;
            if rate > limits::MAX_STEP_RATE {
                return Err(bad(
                    &key("max_feed_mm_s"),
                    &format!(
                        "{} mm/s at {} steps/mm is {} steps/s, above the {} steps/s a step generator runs",
                        short(a.max_feed_mm_s),
                        short(a.steps_per_mm),
                        short(rate),
                        short(limits::MAX_STEP_RATE)
                    ),
                ));
            }
        }
        // Feeds along the page: at least one step per second on the coarser of X and Y, the slowest rate a step
        // block carries (rates are whole steps per second); slower, the machine could not run what the plan says.
        let xy_spm = self.axes.x.steps_per_mm.min(self.axes.y.steps_per_mm);
        let slowest = |field: &str, feed: f64| -> Result<(), ProfileError> {
            if feed * xy_spm < 1.0 {
                return Err(bad(
                    field,
                    &format!(
                        "{} mm/s at {} steps/mm is below one step per second, the slowest rate a step block carries",
                        short(feed),
                        short(xy_spm)
                    ),
                ));
            }
            Ok(())
        };
        for (field, v) in [
            ("pen.draw_feed_mm_s", self.pen.draw_feed_mm_s),
            ("pen.travel_feed_mm_s", self.pen.travel_feed_mm_s),
            ("homing.seek_mm_s", self.homing.seek_mm_s),
            ("homing.locate_mm_s", self.homing.locate_mm_s),
        ] {
            within(field, v, &limits::FEED)?;
            slowest(field, v)?;
        }
        for (field, v) in [
            ("pen.draw_accel_mm_s2", self.pen.draw_accel_mm_s2),
            ("pen.travel_accel_mm_s2", self.pen.travel_accel_mm_s2),
        ] {
            if let Some(v) = v {
                within(field, v, &limits::ACCEL)?;
            }
        }
        within("motion.junction_deviation_mm", self.motion.junction_deviation_mm, &limits::JUNCTION_DEVIATION)?;
        within("motion.curve_deviation_mm", self.motion.curve_deviation_mm, &limits::CURVE_DEVIATION)?;
        within("pen.settle_ms", self.pen.settle_ms, &limits::SETTLE)?;
        within("pen.width_mm", self.pen.width_mm, &limits::PEN_WIDTH)?;
        within("pen.clearance_mm", self.pen.clearance_mm, &limits::CLEARANCE)?;
        within("pen.contact_fraction", self.pen.contact_fraction, &limits::CONTACT_FRACTION)?;
        within("pen.lift_delay_ms", self.pen.lift_delay_ms, &limits::SETTLE)?;
        within("pen.drop_delay_ms", self.pen.drop_delay_ms, &limits::SETTLE)?;
        within("homing.pull_off_mm", self.homing.pull_off_mm, &limits::PULL_OFF)?;
        within("homing.debounce_ms", self.homing.debounce_ms, &limits::DEBOUNCE)?;
        let z_travel = Range { hi: self.axes.z.travel_mm, why: "the Z travel (axes.z.travel_mm)", ..limits::Z_HEIGHT };
        for (field, z) in [("pen.up_z_mm", self.pen.up_z_mm), ("pen.down_z_mm", self.pen.down_z_mm)] {
            within(field, z, &z_travel)?;
        }
        if let Some(c) = self.pen.clear_ms {
            let r = Range { hi: self.pen.settle_ms, why: "up to pen.settle_ms", ..limits::SETTLE };
            within("pen.clear_ms", c, &r)?;
        }
        for (field, a) in [("pen.servo_up_deg", self.pen.servo_up_deg), ("pen.servo_down_deg", self.pen.servo_down_deg)]
        {
            within(field, a, &limits::SERVO_ANGLE)?;
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
            if let Some(w) = pen.width_mm {
                within(&f("width_mm"), w, &Range { lo: 0.01, ..limits::PEN_WIDTH })?;
            }
            if let Some(v) = pen.draw_feed_mm_s {
                within(&f("draw_feed_mm_s"), v, &limits::FEED)?;
                slowest(&f("draw_feed_mm_s"), v)?;
            }
            if let Some(z) = pen.down_z_mm {
                within(&f("down_z_mm"), z, &z_travel)?;
            }
            if let Some(a) = pen.servo_down_deg {
                within(&f("servo_down_deg"), a, &limits::SERVO_ANGLE)?;
            }
            if let Some(h) = pen.hatch {
                if !h.tone {
                    within(&f("hatch.spacing_mm"), h.spacing_mm, &limits::HATCH_SPACING)?;
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
        if let Some([x, y]) = self.homing.z_home_xy_mm
            && !(x.is_finite()
                && y.is_finite()
                && (0.0..=self.axes.x.travel_mm).contains(&x)
                && (0.0..=self.axes.y.travel_mm).contains(&y))
        {
            return Err(bad("homing.z_home_xy_mm", "must lie within the X and Y travel"));
        }
        within("link.baud", f64::from(self.link.baud), &limits::BAUD)?;
        within("link.rx_buffer_bytes", f64::from(self.link.rx_buffer_bytes), &limits::RX_BUFFER)?;
        within("link.queue_blocks", f64::from(self.link.queue_blocks), &limits::QUEUE_BLOCKS)?;
        if let Some(e) = &self.ebb {
            within("ebb.pen_up_position", f64::from(e.pen_up_position), &limits::SERVO_PULSE)?;
            within("ebb.pen_down_position", f64::from(e.pen_down_position), &limits::SERVO_PULSE)?;
            within("ebb.pen_pin", f64::from(e.pen_pin), &limits::EBB_PEN_PIN)?;
            within("ebb.servo_timeout_ms", f64::from(e.servo_timeout_ms), &limits::SERVO_TIMEOUT)?;
            within("ebb.step_mode", f64::from(e.step_mode), &limits::EBB_STEP_MODE)?;
            within("ebb.min_move_ms", e.min_move_ms, &limits::MIN_MOVE)?;
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

/// The range a profile number must lie in, its unit, and what it is (shown in the refusal).
#[derive(Debug, Clone, Copy)]
struct Range {
    lo: f64,
    hi: f64,
    unit: &'static str,
    /// What the range is, when it is not a plain physical range (e.g. "the Z travel").
    why: &'static str,
}

impl Range {
    const fn new(lo: f64, hi: f64, unit: &'static str) -> Self {
        Range { lo, hi, unit, why: "" }
    }

    /// `v is outside 1..=100000 steps/mm`, with the value printed short.
    fn refusal(&self, v: f64) -> String {
        let unit = if self.unit.is_empty() { String::new() } else { format!(" {}", self.unit) };
        let why = if self.why.is_empty() { String::new() } else { format!(" ({})", self.why) };
        format!("{} is outside the accepted range {}..={}{unit}{why}", short(v), short(self.lo), short(self.hi))
    }
}

/// A number as a person reads it: as written for ordinary magnitudes (`80`, `0.127`), in scientific notation
/// beyond them (`1e-9`, `1e300`), never as hundreds of digits.
fn short(v: f64) -> String {
    if v == 0.0 || !v.is_finite() || (1e-4..1e9).contains(&v.abs()) { format!("{v}") } else { format!("{v:e}") }
}

/// The accepted ranges of a profile's numbers. Each admits every real machine we know of — hobby servo kits and
/// AxiDraw-class EBB plotters (80 steps/mm, 300 × 218 mm), belt and lead-screw XY kits, big floor and wall
/// plotters (several metres), bed-slinger and fast CoreXY 3D printers (Z lead screws at 400 steps/mm and more,
/// 20 000 mm/s² and beyond), vintage HP-GL plotters (75 baud upwards) — with a wide margin, and refuses only
/// values no machine has, which collapse a drawing (a step every kilometre), stall it for ever (a feed of
/// 10⁻³⁰⁰ mm/s) or overflow the step counters.
mod limits {
    use super::Range;

    /// Microstepped belts give 40–160, AxiDraws 80, lead screws 400 (8 mm lead, 1/16) up to 25 600 (2 mm lead at
    /// 1/256), geared extruders several hundred; full-stepped large pulleys a few. Below one step per millimetre
    /// a plotter cannot draw millimetre detail.
    pub(super) const STEPS_PER_MM: Range = Range::new(1.0, 100_000.0, "steps/mm");
    /// From a postcard plotter (~100 mm) to a 10 m wall or floor plotter; with the largest steps/mm above the
    /// position still fits the step counters (10⁹ steps).
    pub(super) const XY_TRAVEL: Range = Range::new(1.0, 10_000.0, "mm");
    /// Z (a servo's nominal 10 mm, a printer's 250 mm) and E (0: an extruder has no travel limit).
    pub(super) const ZE_TRAVEL: Range = Range::new(0.0, 10_000.0, "mm");
    /// Feeds: slow Z lead screws run at 2–5 mm/s and brush pens draw at a few mm/s; the fastest printers travel
    /// at about 1 m/s. 0.1 mm/s to 5 m/s.
    pub(super) const FEED: Range = Range::new(0.1, 5_000.0, "mm/s");
    /// From a wobbly Z (tens of mm/s²) to CoreXY printers tuned to 20 000–50 000 mm/s².
    pub(super) const ACCEL: Range = Range::new(1.0, 100_000.0, "mm/s²");
    /// The firmware's step generator limit (`MachineConfig::validate`): an axis's top feed in steps per second.
    pub(super) const MAX_STEP_RATE: f64 = 1.0e6;
    /// grbl's default is 0.01 mm, Marlin's 0.013, saxi's cornering 0.127; 10 µm below the smallest and far above
    /// the largest still plan (every corner a stop, or none).
    pub(super) const JUNCTION_DEVIATION: Range = Range::new(0.0001, 10.0, "mm");
    /// As the firmware takes it: 0 plans corner by corner, 10 mm is far beyond any flattening tolerance.
    pub(super) const CURVE_DEVIATION: Range = Range::new(0.0, 10.0, "mm");
    /// Pen lift settle: 0 (a Z axis that is done when its move is) to seconds for a slow solenoid or pneumatic
    /// lift; 10 s each way is already an hour per 180 lifts.
    pub(super) const SETTLE: Range = Range::new(0.0, 10_000.0, "ms");
    /// Nib widths: 0 turns joining off; a 10 mm marker is the widest.
    pub(super) const PEN_WIDTH: Range = Range::new(0.0, 10.0, "mm");
    /// How far above the pen-down height the tip is clear (capped at the pen-up height when planned).
    pub(super) const CLEARANCE: Range = Range::new(0.01, 100.0, "mm");
    /// Where a servo pen's tip meets the paper, as a fraction of its down travel: a tip that touches in the first
    /// twentieth of the travel would drag on every hop.
    pub(super) const CONTACT_FRACTION: Range = Range::new(0.05, 1.0, "");
    /// Pen heights, within the Z travel (the upper end is the profile's own `axes.z.travel_mm`).
    pub(super) const Z_HEIGHT: Range = Range::new(0.0, 10_000.0, "mm");
    /// Servo angles, as `M3 S<angle>` takes them.
    pub(super) const SERVO_ANGLE: Range = Range::new(0.0, 180.0, "degrees");
    /// The switch has to release (the firmware needs a pull-off above 0); 100 mm is a tenth of a large frame.
    pub(super) const PULL_OFF: Range = Range::new(0.01, 100.0, "mm");
    /// Switch debounce: mechanical switches bounce for a few milliseconds; a second is far beyond any.
    pub(super) const DEBOUNCE: Range = Range::new(0.0, 1_000.0, "ms");
    /// Hatch spacing of a pen's filled areas.
    pub(super) const HATCH_SPACING: Range = Range::new(0.01, 100.0, "mm");
    /// Serial speeds: an HP 7475A can be switched down to 75 baud; USB-serial bridges reach 12 Mbaud.
    pub(super) const BAUD: Range = Range::new(75.0, 12_000_000.0, "baud");
    /// The firmware's receive buffer: 64 bytes (an EBB command) up to 1 MiB (grblHAL and FluidNC use a few KiB).
    pub(super) const RX_BUFFER: Range = Range::new(64.0, 1_048_576.0, "bytes");
    /// Planner queue: 4 on an EBB, 16 on grbl, 32 on ours, hundreds on grblHAL.
    pub(super) const QUEUE_BLOCKS: Range = Range::new(1.0, 10_000.0, "blocks");
    /// EBB servo pulse widths, 1/12 µs units (0 would switch the servo output off).
    pub(super) const SERVO_PULSE: Range = Range::new(1.0, 65_535.0, "");
    /// PortB pins 0..=7 (B1 the standard servo, B2 the brushless lift).
    pub(super) const EBB_PEN_PIN: Range = Range::new(0.0, 7.0, "");
    /// `SR`: 0 keeps the servo powered; a day is longer than any plot's pause.
    pub(super) const SERVO_TIMEOUT: Range = Range::new(0.0, 86_400_000.0, "ms");
    /// `EM` step modes: 1 = 1/16 step … 5 = full step.
    pub(super) const EBB_STEP_MODE: Range = Range::new(1.0, 5.0, "");
    /// Shortest move the EBB sustains (4 ms measured on firmware 3).
    pub(super) const MIN_MOVE: Range = Range::new(0.0, 100.0, "ms");
}

/// The heaters of `profile` for the firmware ([`ThermalConfig::NONE`] without a `[heaters]` section).
pub fn thermal_config(profile: &MachineProfile) -> Result<ThermalConfig, String> {
    profile.heaters.as_ref().map_or(Ok(ThermalConfig::NONE), HeatersProfile::to_config)
}

impl Model {
    /// The model's profile. The built-in TOML is checked by a unit test (every model loads), so this cannot fail
    /// at run time.
    pub fn profile(&self) -> MachineProfile {
        MachineProfile::from_toml(self.toml, &self.origin()).unwrap_or_else(|e| unreachable!("{e}"))
    }
}

/// The profile of `model` with the profile text `over` (named `origin` in errors) laid over it: what
/// `--model M --profile FILE` loads. A file that names another model itself is refused (which one was meant?).
pub fn extend_model(model: &Model, over: &str, origin: &str) -> Result<MachineProfile, ProfileError> {
    let mut table: toml::Table =
        toml::from_str(over).map_err(|e| ProfileError::Parse { path: origin.to_string(), message: e.to_string() })?;
    match table.get("model").map(|v| v.as_str()) {
        Some(Some(name)) if name != model.name => {
            return Err(ProfileError::Parse {
                path: origin.to_string(),
                message: format!(
                    "model: the file extends {name:?} but --model says {:?}; drop one of the two",
                    model.name
                ),
            });
        }
        _ => {}
    }
    table.insert("model".into(), toml::Value::String(model.name.into()));
    MachineProfile::from_table(table, origin)
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
        // A tone hatch needs no spacing.
        let tone = text.replace("spacing_mm = 0.5", "tone = true");
        let h = MachineProfile::from_toml(&tone, "h.toml").unwrap().pens.last().unwrap().hatch.unwrap();
        assert!(h.tone && h.angle_deg == 45.0);
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
    fn collapsing_numbers_are_refused_with_the_field_value_and_range() {
        let with = |from: &str, to: &str| {
            assert!(DEFAULT_PROFILE_TOML.contains(from), "{from}");
            let text = DEFAULT_PROFILE_TOML.replacen(from, to, 1);
            MachineProfile::from_toml(&text, "mine.toml").unwrap_err().to_string()
        };
        // A step every kilometre: the drawing collapsed to the home corner.
        let err = with("steps_per_mm = 80.0", "steps_per_mm = 1e-9");
        assert_eq!(
            err,
            "invalid machine profile mine.toml: axes.x.steps_per_mm: 1e-9 is outside the accepted range \
             1..=100000 steps/mm"
        );
        // A feed that never arrives: short numbers, never 300 digits.
        let err = with("draw_feed_mm_s = 60.0", "draw_feed_mm_s = 1e-300");
        assert_eq!(
            err,
            "invalid machine profile mine.toml: pen.draw_feed_mm_s: 1e-300 is outside the accepted range \
             0.1..=5000 mm/s"
        );
        let err = with("baud = 115200", "baud = 0");
        assert!(err.contains("link.baud: 0 is outside the accepted range 75..=12000000 baud"), "{err}");
        let err = with("up_z_mm = 4.0", "up_z_mm = 11.0");
        assert!(err.contains("pen.up_z_mm: 11 is outside the accepted range 0..=10 mm (the Z travel"), "{err}");
        // Each in range alone, but together half a step per second along the page.
        let text = DEFAULT_PROFILE_TOML.replacen("steps_per_mm = 80.0", "steps_per_mm = 1.0", 1).replacen(
            "draw_feed_mm_s = 60.0",
            "draw_feed_mm_s = 0.5",
            1,
        );
        let err = MachineProfile::from_toml(&text, "mine.toml").unwrap_err().to_string();
        assert!(err.contains("pen.draw_feed_mm_s: 0.5 mm/s at 1 steps/mm is below one step per second"), "{err}");
        let text = DEFAULT_PROFILE_TOML.replacen("steps_per_mm = 400.0", "steps_per_mm = 100000", 1);
        let err = MachineProfile::from_toml(&text, "mine.toml").unwrap_err().to_string();
        assert!(err.contains("axes.z.max_feed_mm_s: 25 mm/s at 100000 steps/mm is 2500000 steps/s"), "{err}");
    }

    #[test]
    fn every_number_of_the_profile_is_range_checked() {
        // Each key of the kit's profile set to a value no machine has, one at a time: refused, naming the key.
        let keys = [
            ("steps_per_mm = 80.0", "axes.x.steps_per_mm"),
            ("travel_mm = 420.0", "axes.x.travel_mm"),
            ("max_feed_mm_s = 150.0", "axes.x.max_feed_mm_s"),
            ("max_accel_mm_s2 = 1500.0", "axes.x.max_accel_mm_s2"),
            ("steps_per_mm = 400.0", "axes.z.steps_per_mm"),
            ("travel_mm = 10.0", "axes.z.travel_mm"),
            ("max_feed_mm_s = 25.0", "axes.z.max_feed_mm_s"),
            ("max_accel_mm_s2 = 500.0", "axes.z.max_accel_mm_s2"),
            ("settle_ms = 50.0", "pen.settle_ms"),
            ("clearance_mm = 1.0", "pen.clearance_mm"),
            ("draw_feed_mm_s = 60.0", "pen.draw_feed_mm_s"),
            ("travel_feed_mm_s = 120.0", "pen.travel_feed_mm_s"),
            ("width_mm = 0.3\n\n[motion]", "pen.width_mm"),
            ("junction_deviation_mm = 0.02", "motion.junction_deviation_mm"),
            ("curve_deviation_mm = 0.1", "motion.curve_deviation_mm"),
            ("seek_mm_s = 40.0", "homing.seek_mm_s"),
            ("locate_mm_s = 4.0", "homing.locate_mm_s"),
            ("pull_off_mm = 2.0", "homing.pull_off_mm"),
            ("debounce_ms = 5.0", "homing.debounce_ms"),
            ("baud = 115200", "link.baud"),
            ("rx_buffer_bytes = 256", "link.rx_buffer_bytes"),
            ("queue_blocks = 32", "link.queue_blocks"),
            ("draw_feed_mm_s = 30.0", "pens[2] (blue brush pen).draw_feed_mm_s"),
            ("width_mm = 0.8", "pens[2] (blue brush pen).width_mm"),
        ];
        for (line, key) in keys {
            assert!(DEFAULT_PROFILE_TOML.contains(line), "{line}");
            let (name, _) = line.split_once(" = ").unwrap();
            let rest = line.split_once('\n').map_or(String::new(), |(_, r)| format!("\n{r}"));
            let huge = if name == "baud" || name.ends_with("bytes") || name.ends_with("blocks") {
                "4000000000".to_string()
            } else {
                "1e300".to_string()
            };
            let text = DEFAULT_PROFILE_TOML.replacen(line, &format!("{name} = {huge}{rest}"), 1);
            let err = MachineProfile::from_toml(&text, "k.toml").unwrap_err().to_string();
            assert!(err.contains(&format!("k.toml: {key}: ")) && err.contains("accepted range"), "{line}: {err}");
        }
        // The EBB's own numbers.
        let v3 = include_str!("../../../samples/axidraw-v3.toml");
        for (line, to, key) in [
            ("pen_up_position = 20641", "pen_up_position = 0", "ebb.pen_up_position"),
            ("pen_pin = 1", "pen_pin = 9", "ebb.pen_pin"),
            ("step_mode = 1", "step_mode = 0", "ebb.step_mode"),
            ("min_move_ms = 4.0", "min_move_ms = 1e9", "ebb.min_move_ms"),
            ("servo_timeout_ms = 60000", "servo_timeout_ms = 4000000000", "ebb.servo_timeout_ms"),
        ] {
            let err = MachineProfile::from_toml(&v3.replacen(line, to, 1), "v3.toml").unwrap_err().to_string();
            assert!(err.contains(&format!("v3.toml: {key}: ")), "{line}: {err}");
        }
    }

    #[test]
    fn every_sample_profile_loads() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../samples");
        let mut loaded = 0;
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.extension().is_some_and(|e| e == "toml") {
                MachineProfile::load(&path).unwrap_or_else(|e| panic!("{e}"));
                loaded += 1;
            }
        }
        assert!(loaded >= 8, "{loaded} sample profiles");
    }

    #[test]
    fn a_missing_file_says_its_os_error_once() {
        let err = MachineProfile::load(Path::new("no-such-dir/axidraw-v3")).unwrap_err();
        // The OS error is in the message only: printed with its sources, the chain said it twice.
        assert!(std::error::Error::source(&err).is_none());
        let text = err.to_string();
        assert!(text.starts_with("cannot read machine profile no-such-dir/axidraw-v3: "), "{text}");
        assert_eq!(text.matches("os error 2").count(), 1, "{text}");
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
