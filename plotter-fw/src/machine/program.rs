//! The G-code program state the interpreter keeps between lines: the modal words (units, absolute or relative,
//! the last motion command and feed) and the coordinates — the target the queue ends at and the `G92` offsets.
//! It checks a line's words against the machine ([`check`]) and turns a move into a planner block
//! ([`Program::line_move`]); the machine decides when a line may run and performs it.
//!
//! # Coordinates
//! Positions are kept exactly, in millionths of a millimetre (machine coordinates: 0 at the homing switch). A
//! target is converted to whole steps once (rounded), and a move is the difference to the previous target in
//! steps, so relative moves never drift. `G92` offsets work coordinates from machine coordinates.

use core::fmt::{self, Write};

use crate::axis::{Axis, NUM_AXES};
use crate::config::MachineConfig;
use crate::decimal::Decimal;
use crate::errors::ErrorCode;
use crate::framing::M_FRAMED;
use crate::gcode::Words;
use crate::heater_driver::TooCold;
use crate::planner::PlanBlock;
use crate::range::MoveRange;
use crate::step_block::StepBlock;

/// The detail after an error's text.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Detail {
    /// A fixed text (starting with `: `).
    Text(&'static str),
    /// `: <letter>`: the word, axis or value concerned.
    Letter(u8),
    /// `: G<n>` or `: M<n>`.
    Code(u8, u16),
    /// `: <what>`: a value out of range.
    OutOfRange(&'static str),
    /// `: <axis> <range>`: a target position out of range.
    Position(Axis),
    /// The hot end is too cold to extrude.
    Cold(TooCold),
}

impl fmt::Display for Detail {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Detail::Text(t) => f.write_str(t),
            Detail::OutOfRange(t) => write!(f, ": {t}"),
            Detail::Letter(l) => write!(f, ": {}", char::from(l)),
            Detail::Code(c, n) => write!(f, ": {}{n}", char::from(c)),
            Detail::Position(a) => write!(f, ": {} {}", a.letter(), MoveRange::Position.text()),
            Detail::Cold(c) => write!(f, "{c}"),
        }
    }
}

/// A refused line: its error code and detail.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Refusal {
    /// The error code.
    pub(crate) code: ErrorCode,
    /// The detail after its text.
    pub(crate) detail: Detail,
}

const fn refuse<T>(code: ErrorCode, detail: Detail) -> Result<T, Refusal> {
    Err(Refusal { code, detail })
}

/// What a checked line does, as far as the words tell.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Line {
    /// `G4`, `G28` or `G92`.
    pub(crate) other_g: Option<u16>,
    /// An axis word is present.
    pub(crate) has_axis: bool,
    /// It queues a block (a move or a dwell).
    pub(crate) needs_slot: bool,
    /// It waits for the queue to run empty (homing, `G92`, motors off, the servo pen, program pauses).
    pub(crate) needs_idle: bool,
    /// It moves the machine (refused in alarm).
    pub(crate) moves: bool,
    /// `S` as an angle, degrees (the servo pen).
    pub(crate) servo_deg: Option<f64>,
    /// `G0` or `G1`.
    motion: Option<u16>,
}

impl Line {
    /// A `G0`/`G1` move (axis words without `G4`, `G28` or `G92`).
    pub(crate) fn is_move(&self) -> bool {
        self.has_axis && self.other_g.is_none()
    }
}

/// Check a line's words, codes and numbers against `cfg`, before anything runs or changes (`inches`: the modal
/// unit before this line).
pub(crate) fn check(w: &Words, cfg: &MachineConfig, inches: bool) -> Result<Line, Refusal> {
    for axis in Axis::ALL {
        if w.has(axis.letter() as u8) && !cfg.axis(axis).enabled {
            return refuse(ErrorCode::AxisDisabled, Detail::Letter(axis.letter() as u8));
        }
    }
    const KNOWN: &[u8] = b"XYZEFPSN";
    for bit in 0..26u8 {
        let letter = b'A' + bit;
        if w.letters() & (1 << bit) != 0 && !KNOWN.contains(&letter) {
            return refuse(ErrorCode::UnsupportedWord, Detail::Letter(letter));
        }
    }
    let mut motion = None;
    let mut other_g = None;
    for &g in &w.g {
        match g {
            0 | 1 => motion = Some(g),
            4 | 28 | 92 => other_g = Some(g),
            20 | 21 | 90 | 91 => {}
            _ => return refuse(ErrorCode::UnknownCommand, Detail::Code(b'G', g)),
        }
    }
    for &m in &w.m {
        if !matches!(m, 0 | 1 | 2 | 3 | 4 | 5 | 17 | 18 | 30 | 82 | 83 | 84 | 110 | 114 | 115 | M_FRAMED) {
            return refuse(ErrorCode::UnknownCommand, Detail::Code(b'M', m));
        }
    }
    let has_axis = Axis::ALL.iter().any(|a| w.has(a.letter() as u8));
    if w.get(b'F').is_some_and(|f| f <= 0) {
        return refuse(ErrorCode::InvalidValue, Detail::Text(": F must be positive"));
    }
    // Values that cannot be represented in the unit this line asks for.
    let inches =
        w.g.iter()
            .rev()
            .find_map(|g| match g {
                20 => Some(true),
                21 => Some(false),
                _ => None,
            })
            .unwrap_or(inches);
    for letter in *b"XYZEF" {
        if inches && w.get(letter).is_some_and(|v| crate::range::inches_to_um(v).is_none()) {
            return refuse(ErrorCode::OutOfRange, Detail::Letter(letter));
        }
    }
    let needs_slot = motion.is_some() || other_g == Some(4) || (has_axis && other_g.is_none());
    // The servo pen and program pauses act between moves, so they wait for the queue to empty.
    let pen_or_pause = w.m.iter().any(|m| matches!(m, 0 | 1 | 3 | 4 | 5));
    let needs_idle = matches!(other_g, Some(28 | 92)) || w.m.contains(&18) || w.m.contains(&84) || pen_or_pause;
    let servo_deg = w.get(b'S').map(|s| s as f64 / 1e6);
    if w.m.iter().any(|m| matches!(m, 3 | 4)) && servo_deg.is_none_or(|a| !(0.0..=180.0).contains(&a)) {
        return refuse(ErrorCode::InvalidValue, Detail::Text(": M3 needs S<angle> from 0 to 180"));
    }
    if w.m.contains(&5) && servo_deg.is_some_and(|a| !(0.0..=180.0).contains(&a)) {
        return refuse(ErrorCode::InvalidValue, Detail::Text(": S must be an angle from 0 to 180"));
    }
    let moves = needs_slot || other_g == Some(28);
    Ok(Line { other_g, has_axis, needs_slot, needs_idle, moves, servo_deg, motion })
}

/// G-code modal state.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Modal {
    absolute: bool,
    inches: bool,
    /// Last motion command: 0 or 1.
    motion: u16,
    /// Feed for G1, mm/s (0 = not set yet).
    feed_mm_s: f32,
    /// E words are relative (M83, or G91 until M82).
    e_relative: bool,
}

impl Modal {
    const DEFAULT: Modal = Modal { absolute: true, inches: false, motion: 0, feed_mm_s: 0.0, e_relative: false };
}

/// The program state (see the module docs).
pub(crate) struct Program {
    modal: Modal,
    /// Machine position of the last queued target, millionths of a mm.
    target_um: [i64; NUM_AXES],
    /// The same in steps (what the queue ends at).
    target_steps: [i32; NUM_AXES],
    offset_um: [i64; NUM_AXES],
    /// Servo pen: the angle `M5` lifts to (set with `M5 S<angle>`).
    servo_up_deg: f32,
}

impl Program {
    /// At the origin, default modes; `M5` lifts the servo pen to `servo_up_deg`.
    pub(crate) const fn new(servo_up_deg: f32) -> Self {
        Program {
            modal: Modal::DEFAULT,
            target_um: [0; NUM_AXES],
            target_steps: [0; NUM_AXES],
            offset_um: [0; NUM_AXES],
            servo_up_deg,
        }
    }

    /// Default modes (a reset).
    pub(crate) fn reset_modes(&mut self) {
        self.modal = Modal::DEFAULT;
    }

    /// `M2`/`M30`: default modes, the feed kept.
    pub(crate) fn end(&mut self) {
        self.modal = Modal { feed_mm_s: self.modal.feed_mm_s, ..Modal::DEFAULT };
    }

    /// The servo angle of `M3`/`M4` (down to `S`) or `M5` (up; `S` sets the up angle), `servo_deg` checked to
    /// lie in 0..=180 by [`check`].
    pub(crate) fn pen_angle(&mut self, m: u16, servo_deg: Option<f64>) -> f32 {
        // Angles are 0..=180: exact enough in f32.
        #[allow(clippy::cast_possible_truncation)]
        let s = servo_deg.map(|a| a as f32);
        if m == 5 {
            self.servo_up_deg = s.unwrap_or(self.servo_up_deg);
            self.servo_up_deg
        } else {
            s.unwrap_or(0.0)
        }
    }

    /// `M82` (false) / `M83` (true).
    pub(crate) fn set_e_relative(&mut self, relative: bool) {
        self.modal.e_relative = relative;
    }

    /// The unit is inches (`G20`).
    pub(crate) fn inches(&self) -> bool {
        self.modal.inches
    }

    /// Exact commanded (queued) target in steps.
    pub(crate) fn target_steps(&self) -> [i32; NUM_AXES] {
        self.target_steps
    }

    /// The queue now ends at `target` steps.
    pub(crate) fn set_target_steps(&mut self, target: [i32; NUM_AXES], cfg: &MachineConfig) {
        self.target_steps = target;
        for axis in Axis::ALL {
            let i = axis.index();
            let spm = f64::from(cfg.axis(axis).steps_per_mm);
            self.target_um[i] = round_i64(f64::from(target[i]) / spm * 1e6);
        }
    }

    /// A G-code length in millionths of the current unit → millionths of a mm; `None` on overflow.
    fn to_um(&self, value: i64) -> Option<i64> {
        if self.modal.inches { crate::range::inches_to_um(value) } else { Some(value) }
    }

    /// Take the line's modal words, then run its G words (`homed`: soft limits, `cold`: extrusion refused): the
    /// block to queue (a dwell or a move), if any.
    pub(crate) fn run_g(
        &mut self,
        w: &Words,
        line: &Line,
        cfg: &MachineConfig,
        homed: u8,
        cold: Option<TooCold>,
    ) -> Result<Option<PlanBlock>, Refusal> {
        self.apply_modes(w, line);
        match line.other_g {
            Some(4) => {
                Ok(Some(Self::dwell_ticks(w)?).filter(|&t| t > 0).map(|t| PlanBlock::fixed(StepBlock::dwell(t))))
            }
            Some(92) => self.set_offsets(w, line.has_axis).map(|()| None),
            _ if line.has_axis => self.line_move(w, cfg, homed, cold),
            _ => Ok(None),
        }
    }

    /// Take the line's modal words (checked by [`check`]).
    fn apply_modes(&mut self, w: &Words, line: &Line) {
        for &g in &w.g {
            match g {
                20 => self.modal.inches = true,
                21 => self.modal.inches = false,
                90 => (self.modal.absolute, self.modal.e_relative) = (true, false),
                91 => (self.modal.absolute, self.modal.e_relative) = (false, true),
                _ => {}
            }
        }
        if let Some(f) = w.get(b'F') {
            // Checked for the line's unit.
            let f_um_min = self.to_um(f).unwrap_or(i64::MAX);
            self.modal.feed_mm_s = f_um_min as f32 / 1e6 / 60.0;
        }
        if let Some(m) = line.motion {
            self.modal.motion = m;
        }
    }

    /// `G4 P<ms>` / `G4 S<s>`: the dwell in ticks (µs).
    fn dwell_ticks(w: &Words) -> Result<u32, Refusal> {
        let ms = w.get(b'P').map(|p| p / 1000).or_else(|| w.get(b'S').map(|s| s / 1000 * 1000)).unwrap_or(0);
        if !(0..=3_600_000_000).contains(&ms) {
            return refuse(ErrorCode::InvalidValue, Detail::Text(": dwell"));
        }
        // ms is in thousandths of a millisecond = microseconds = ticks.
        Ok(u32::try_from(ms).unwrap_or(u32::MAX))
    }

    /// `G92`: the given axes (all, without axis words) read the given positions (0) from now on.
    fn set_offsets(&mut self, w: &Words, has_axis: bool) -> Result<(), Refusal> {
        let mut offset = self.offset_um;
        for axis in Axis::ALL {
            let i = axis.index();
            // Checked for the line's unit.
            let given = w.get(axis.letter() as u8).map(|v| self.to_um(v).unwrap_or(0));
            if let Some(v) = given.or(if has_axis { None } else { Some(0) }) {
                let Some(o) = self.target_um[i].checked_sub(v) else {
                    return refuse(ErrorCode::OutOfRange, Detail::OutOfRange("G92 offset"));
                };
                offset[i] = o;
            }
        }
        self.offset_um = offset;
        Ok(())
    }

    /// `G0`/`G1`: the block from the current target to the line's (`None` when nothing moves), and the target
    /// taken; `cold` refuses extrusion, `homed` is the mask of homed axes (soft limits).
    fn line_move(
        &mut self,
        w: &Words,
        cfg: &MachineConfig,
        homed: u8,
        cold: Option<TooCold>,
    ) -> Result<Option<PlanBlock>, Refusal> {
        // Every step is checked (see `crate::range`): an unrepresentable target is refused, never wrapped or
        // saturated, so a move's direction is always the commanded one.
        let mut target_um = self.target_um;
        let mut target = self.target_steps;
        for axis in Axis::ALL {
            let i = axis.index();
            if let Some(v) = w.get(axis.letter() as u8) {
                let um = self.to_um(v).and_then(|v| {
                    let absolute = if axis == Axis::E { !self.modal.e_relative } else { self.modal.absolute };
                    if absolute { v.checked_add(self.offset_um[i]) } else { target_um[i].checked_add(v) }
                });
                let steps = um.and_then(|um| crate::range::um_to_steps(um, cfg.axis(axis).steps_per_mm));
                let (Some(um), Some(steps)) = (um, steps) else {
                    return refuse(ErrorCode::OutOfRange, Detail::Position(axis));
                };
                target_um[i] = um;
                target[i] = steps;
            }
        }
        if let Some(axis) = crate::limits::violation(cfg, homed, &target) {
            return refuse(ErrorCode::SoftLimit, Detail::Letter(axis.letter() as u8));
        }
        let feed = if self.modal.motion == 0 {
            f32::INFINITY
        } else if self.modal.feed_mm_s > 0.0 {
            self.modal.feed_mm_s
        } else {
            return refuse(ErrorCode::InvalidValue, Detail::Text(": no feed rate (F) set for G1"));
        };
        // Both targets lie within ±2^30 steps, so the difference fits.
        let steps: [i32; NUM_AXES] = core::array::from_fn(|i| target[i] - self.target_steps[i]);
        if steps[Axis::E.index()] != 0
            && let Some(cold) = cold
        {
            return refuse(ErrorCode::ColdExtrusion, Detail::Cold(cold));
        }
        let block = PlanBlock::line(cfg, steps, feed);
        if let Some(b) = &block {
            let rate = crate::fmath::floor_u32(b.nominal_speed * b.events_per_mm);
            if let Err(e) = crate::range::check_move(&steps, rate) {
                return refuse(ErrorCode::OutOfRange, Detail::OutOfRange(e.text()));
            }
        }
        self.target_um = target_um;
        self.target_steps = target;
        Ok(block)
    }

    /// A host-planned step block of `steps`: the target it ends at, checked like a move (`homed`: soft limits,
    /// `cold`: extrusion refused).
    pub(crate) fn frame_target(
        &self,
        steps: &[i32; NUM_AXES],
        cfg: &MachineConfig,
        homed: u8,
        cold: Option<TooCold>,
    ) -> Result<[i32; NUM_AXES], Refusal> {
        let mut target = self.target_steps;
        for (t, s) in target.iter_mut().zip(steps) {
            *t = t.saturating_add(*s);
        }
        if !crate::range::position_ok(&target) {
            return refuse(ErrorCode::OutOfRange, Detail::OutOfRange(MoveRange::Position.text()));
        }
        if let Some(axis) = crate::limits::violation(cfg, homed, &target) {
            return refuse(ErrorCode::SoftLimit, Detail::Letter(axis.letter() as u8));
        }
        if steps[Axis::E.index()] != 0
            && let Some(cold) = cold
        {
            return refuse(ErrorCode::ColdExtrusion, Detail::Cold(cold));
        }
        Ok(target)
    }

    /// `M114`: the work position of the target and the stepper's position `steps`.
    pub(crate) fn write_position<W: Write>(&self, out: &mut W, steps: &[i32; NUM_AXES]) {
        let work: [f64; NUM_AXES] = core::array::from_fn(|i| (self.target_um[i] - self.offset_um[i]) as f64 / 1e6);
        let p = steps;
        let _ = writeln!(
            out,
            "X:{} Y:{} Z:{} E:{} Count X:{} Y:{} Z:{} E:{}",
            Decimal::new(work[0], 3),
            Decimal::new(work[1], 3),
            Decimal::new(work[2], 3),
            Decimal::new(work[3], 3),
            p[0],
            p[1],
            p[2],
            p[3]
        );
    }
}

fn round_i64(x: f64) -> i64 {
    let r = if x >= 0.0 { x + 0.5 } else { x - 0.5 };
    #[allow(clippy::cast_possible_truncation, reason = "float→int `as` saturates; positions are far below 2^63")]
    let r = r as i64;
    r
}
