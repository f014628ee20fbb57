//! Import of plotter G-code (ours or from third-party tools) into a [`Drawing`].
//!
//! The program is interpreted in two passes. The first runs the modal state machine — units (`G20`/`G21`),
//! distance mode (`G90`/`G91`), arc centre mode (`G90.1`/`G91.1`), coordinate offsets (`G92`, `G92.1`), motion mode
//! (`G0`/`G1`/`G2`/`G3`) — and records every XY segment in machine millimetres together with the Z height, the
//! spindle/servo state (`M3`/`M4` on, `M5` off) and whether it was a rapid. Arcs (`G2` clockwise, `G3`
//! counter-clockwise, by `I`/`J` centre or `R` radius, helical Z allowed) are flattened into chords whose sagitta
//! stays within [`ARC_TOLERANCE_MM`] (the chord of angle θ on radius r deviates by r·(1 − cos θ/2)).
//!
//! The second pass decides how the file lifts its pen, because plotter tools disagree:
//! 1. if the XY moves happen at two or more Z heights, the pen is down below the midpoint of the lowest and highest
//!    of them (`Z` lift, the usual GRBL plotter convention and our own export);
//! 2. otherwise, if the file uses `M3`/`M4`/`M5`, the pen is down while the spindle output is on (servo lift) —
//!    except that in a file that never says `M5`, `M3 S<angle>` at an angle nearer the profile's pen-up angle than
//!    its pen-down angles holds the pen up (a hobby servo on stock GRBL is lifted so, as our export does);
//! 3. otherwise feed moves (`G1`/`G2`/`G3`) draw and rapids (`G0`) travel, with a warning saying so.
//!
//! Consecutive pen-down segments become one polyline; machine coordinates go back to page coordinates through the
//! profile. Commands that do not change the drawing (feeds, dwells, motor enables, temperatures, fan, messages) are
//! accepted; anything that would change the geometry and is not understood (another plane, other axes, unknown G or
//! M codes) is an error naming the line; things dropped on purpose (tool changes, extrusion, program pauses) are
//! warnings with their first line and repeat count.
//!
//! This import makes a *drawing*. Extrusion has no place in one: with a plotter profile E words are dropped with a
//! warning; with a printer profile (one with an E axis) the warning says that `plotter print` keeps them — the
//! printing playback is [`super::gcode_print`], which interprets the same G-code with E planned alongside X/Y/Z.
//!
//! Numbers: with a plotter profile (no extruder) `1e-05`, `3.5e1` and `2E1` are numbers in exponent notation —
//! what a script printing floats writes — so `X1e-05` lands at 0.00001 mm. With a printer profile `E` starts the
//! extruder word as in Marlin, and a number run straight into one (`X1E5`) is read as Marlin reads it with a warning
//! naming the line (for `plotter print` it is an error). A number beyond `f64` is a range error, and no message
//! echoes more than 40 characters of the input.
//!
//! Bounded work: every target and arc centre must lie within ±[`MAX_COORD_MM`] and the file may produce at most
//! [`MAX_POINTS`] segments (see [`crate::geometry::limits`]); beyond either, the import stops with an error naming
//! the line.

use kurbo::Point;

use super::gcode_words::{Exponents, code10, echo, num, record_warning, strip_comments, words};
pub use super::gcode_words::{GcodeError, GcodeWarning};
use crate::config::color::parse_hex_color;
use crate::config::interrupt;
use crate::geometry::cancel::Cancel;
use crate::geometry::limits::{MAX_COORD_MM, MAX_POINTS};
use crate::{Drawing, Layer, MachineProfile, Polyline};

/// Maximum chord error when flattening arcs, millimetres.
pub const ARC_TOLERANCE_MM: f64 = 0.005;

/// Most chords one arc may become (guards against absurd radii).
const MAX_ARC_CHORDS: f64 = 200_000.0;

/// Lines read between two looks at the stop flags ([`interrupt`], [`Cancel`]).
pub(crate) const CHECK_EVERY: usize = 4096;

use super::warn_tally::Tally;

/// How the imported file lifts its pen (decided by the second pass).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PenDetection {
    /// Pen down while Z is below this height (machine mm).
    ZBelow(f64),
    /// Pen down while the spindle (servo) output is on.
    Spindle,
    /// Feed moves draw, rapids travel.
    FeedMoves,
}

/// The result of an import.
#[derive(Debug, Clone, PartialEq)]
pub struct ImportedGcode {
    /// The pen-down strokes in page coordinates: one layer, plus one more after each `M0`/`M1` pause (a pen change),
    /// named from that line's comment.
    pub drawing: Drawing,
    /// How the pen was detected.
    pub pen: PenDetection,
    /// Everything skipped or assumed.
    pub warnings: Vec<GcodeWarning>,
}

#[derive(Debug, Clone, Copy)]
struct Segment {
    from: Point,
    to: Point,
    z: f64,
    /// Source line (saturating), for the point limit of pass 2.
    line: u32,
    spindle: bool,
    rapid: bool,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Motion {
    Rapid,
    Linear,
    Cw,
    Ccw,
}

struct Machine<'a> {
    origin: &'a str,
    /// The profile's servo angles, degrees: pen up, and every pen's down angle (`M3 S<angle>` lifts or drops in a
    /// file that never lifts with `M5`); `NaN` for the up angle in a file that does (every `M3` drops).
    servo_up_deg: f64,
    servo_down_deg: Vec<f64>,
    /// The profile has an extruder: E is kept for `plotter print` ([`super::gcode_print`]).
    printer: bool,
    mm_per_unit: f64,
    absolute: bool,
    arc_center_absolute: bool,
    motion: Option<Motion>,
    /// Machine position (mm).
    pos: [f64; 3],
    /// Work = machine − offset (G92).
    offset: [f64; 3],
    spindle: bool,
    used_spindle: bool,
    ended: bool,
    segments: Vec<Segment>,
    /// Layer breaks from `M0`/`M1` pauses: the layer starts with segment `.0`.
    layer_starts: Vec<(usize, Layer)>,
    warnings: Tally,
}

/// The comment of a G-code line (the text in parentheses, or after `;`), trimmed; `None` when it has none.
fn comment_of(line: &str) -> Option<&str> {
    let c = match (line.find('('), line.find(';')) {
        (Some(p), s) if s.is_none_or(|s| p < s) => {
            let rest = &line[p + 1..];
            &rest[..rest.find(')').unwrap_or(rest.len())]
        }
        (_, Some(s)) => &line[s + 1..],
        _ => return None,
    };
    Some(c.trim()).filter(|c| !c.is_empty())
}

/// The layer that an `M0`/`M1` pause (a pen change) starts, named from the line's comment: our own export's
/// `M0 ; pen change: load red fineliner 0.5 (#ff0000) for layer "red"` gives layer `red` with that colour, and
/// other tools' `M0 (pen: red)` gives layer `red`; without a comment the layer is called `pen <n>`.
fn pause_layer(raw: &str, n: usize) -> Layer {
    let comment = comment_of(raw).unwrap_or("");
    let name = if let Some((_, quoted)) = comment.split_once("for layer \"") {
        quoted.split('"').next().unwrap_or(quoted).to_string()
    } else {
        let lower = comment.to_ascii_lowercase();
        let prefix = ["pen change:", "pen:", "change pen:", "tool:"].iter().find(|p| lower.starts_with(*p));
        prefix.map_or(comment, |p| &comment[p.len()..]).trim().to_string()
    };
    let mut layer = Layer::new(if name.is_empty() { format!("pen {n}") } else { name });
    if let Some(color) = comment.match_indices('#').find_map(|(i, _)| comment.get(i..i + 7).and_then(parse_hex_color)) {
        layer.pen.color = color;
    }
    layer
}

impl Machine<'_> {
    /// A warning whose text is also its kind.
    fn warn(&mut self, line: usize, message: &'static str) {
        self.warnings.note(line, message, "", message.to_string());
    }

    /// A warning of `kind` whose text varies (it quotes the input).
    fn warn_as(&mut self, line: usize, kind: &'static str, message: String) {
        self.warnings.note(line, kind, "", message);
    }

    /// Push a segment made on `line`.
    fn segment(&mut self, line: usize, from: Point, to: Point, z: f64, spindle: bool, rapid: bool) {
        let line = u32::try_from(line).unwrap_or(u32::MAX);
        self.segments.push(Segment { from, to, z, line, spindle, rapid });
    }

    fn malformed(&self, line: usize, message: impl Into<String>) -> GcodeError {
        GcodeError::Malformed { origin: self.origin.into(), line, message: message.into() }
    }

    fn unsupported(&self, line: usize, word: &str, why: &'static str) -> GcodeError {
        GcodeError::Unsupported { origin: self.origin.into(), line, word: echo(&word.to_uppercase()), why }
    }

    fn run_line(&mut self, line: usize, raw: &str) -> Result<(), GcodeError> {
        let code = strip_comments(raw);
        let code = code.trim();
        if code.is_empty() || code == "%" {
            return Ok(());
        }
        let exponents = if self.printer { Exponents::EWords } else { Exponents::Numbers };
        let ws = words(code, self.origin, line, exponents)?;
        for pair in ws.windows(2).filter(|p| p[0].runs_into_e) {
            self.warn_as(
                line,
                "ambiguous number run into E",
                format!(
                    "ambiguous number: {} runs into {}, read as two words as Marlin does (a script may have meant an \
                     exponent); put a space before E",
                    echo(pair[0].text),
                    echo(pair[1].text)
                ),
            );
        }
        if self.ended {
            if ws.iter().any(|w| !matches!(w.letter, 'N')) {
                self.warn(line, "commands after the program end (M2/M30) ignored");
            }
            return Ok(());
        }
        let mut axes: [Option<f64>; 3] = [None; 3];
        let (mut i, mut j, mut r) = (None, None, None);
        let mut g92 = false;
        let mut g28 = false;
        let spindle_before = self.spindle;
        for w in &ws {
            match w.letter {
                'G' => {
                    match code10(w.value) {
                        0 => self.motion = Some(Motion::Rapid),
                        10 => self.motion = Some(Motion::Linear),
                        20 => self.motion = Some(Motion::Cw),
                        30 => self.motion = Some(Motion::Ccw),
                        200 => self.mm_per_unit = 25.4,
                        210 => self.mm_per_unit = 1.0,
                        900 => self.absolute = true,
                        910 => self.absolute = false,
                        901 => self.arc_center_absolute = true,
                        911 => self.arc_center_absolute = false,
                        920 => g92 = true,
                        921 => self.offset = [0.0; 3],
                        280 => g28 = true,
                        // Dwell, XY plane, feed per minute, path modes, cancel offsets/cycles, first work system.
                        40 | 170 | 940 | 610 | 640 | 400 | 490 | 800 | 540 => {}
                        180 | 190 => {
                            return Err(self.unsupported(line, w.text, "only the XY plane (G17) is drawn"));
                        }
                        _ => return Err(self.unsupported(line, w.text, "unknown G code")),
                    }
                }
                'M' => match code10(w.value) {
                    30 | 40 => {
                        // With an angle: down when it is nearer a pen's down angle than the pen-up angle.
                        let near = |a: f64, b: f64| (a - b).abs();
                        let s = ws.iter().find(|w| w.letter == 'S').map(|w| w.value);
                        let up = self.servo_up_deg;
                        self.spindle = s.is_none_or(|a| {
                            up.is_nan() || self.servo_down_deg.iter().any(|&d| near(a, d) < near(a, up))
                        });
                        self.used_spindle = true;
                    }
                    50 => {
                        self.spindle = false;
                        self.used_spindle = true;
                    }
                    20 | 300 => self.ended = true,
                    0 | 10 => {
                        let layer = pause_layer(raw, self.layer_starts.len() + 2);
                        self.layer_starts.push((self.segments.len(), layer));
                    }
                    60 => self.warn(line, "tool change ignored: the drawing is one layer"),
                    // Motors, extrusion modes, temperatures, fans, messages, feed/flow overrides, sync, reports.
                    v if [170, 180, 840, 820, 830, 1040, 1090, 1400, 1900, 1060, 1070, 1170].contains(&v)
                        || [2200, 2210, 4000, 1140, 1150, 70, 80, 90].contains(&v) => {}
                    _ => return Err(self.unsupported(line, w.text, "unknown M code")),
                },
                'X' => axes[0] = Some(w.value),
                'Y' => axes[1] = Some(w.value),
                'Z' => axes[2] = Some(w.value),
                'I' => i = Some(w.value),
                'J' => j = Some(w.value),
                'R' => r = Some(w.value),
                'K' => return Err(self.unsupported(line, w.text, "arcs outside the XY plane are not drawn")),
                'E' if self.printer => {
                    self.warn(line, "extruder (E) values are not part of a drawing (`plotter print` plays them)");
                }
                'E' => self.warn(line, "extruder (E) values ignored"),
                'T' => self.warn(line, "tool selection ignored: the drawing is one layer"),
                'F' | 'S' | 'P' | 'N' => {}
                'A' | 'B' | 'C' | 'U' | 'V' | 'W' => {
                    return Err(self.unsupported(line, w.text, "only the X, Y and Z axes exist"));
                }
                _ => return Err(self.unsupported(line, w.text, "unknown word")),
            }
        }
        if self.spindle != spindle_before {
            let at = Point::new(self.pos[0], self.pos[1]);
            self.segment(line, at, at, self.pos[2], self.spindle, true);
        }
        let any_axis = axes.iter().any(Option::is_some);
        if g92 {
            if !any_axis {
                return Err(self.malformed(line, "G92 needs at least one axis value"));
            }
            for (k, v) in axes.iter().enumerate() {
                if let Some(v) = v {
                    self.offset[k] = self.pos[k] - v * self.mm_per_unit;
                }
            }
            return Ok(());
        }
        if g28 {
            // Homing: the pen travels (lifted) to the machine origin.
            self.warn(line, "G28 taken as a pen-up move to the machine origin");
            let from = Point::new(self.pos[0], self.pos[1]);
            self.segment(line, from, Point::ZERO, f64::NAN, false, true);
            self.pos[0] = 0.0;
            self.pos[1] = 0.0;
            return Ok(());
        }
        let has_arc_words = i.is_some() || j.is_some() || r.is_some();
        if !any_axis && !has_arc_words {
            return Ok(());
        }
        let Some(motion) = self.motion else {
            return Err(self.malformed(line, "axis words without a motion command (G0/G1/G2/G3)"));
        };
        if has_arc_words && !matches!(motion, Motion::Cw | Motion::Ccw) {
            return Err(self.malformed(line, "I/J/R given without an arc motion (G2/G3)"));
        }
        let mut target = self.pos;
        for (k, v) in axes.iter().enumerate() {
            if let Some(v) = v {
                target[k] = if self.absolute {
                    v * self.mm_per_unit + self.offset[k]
                } else {
                    target[k] + v * self.mm_per_unit
                };
            }
        }
        if let Some(k) = target.iter().position(|v| v.is_nan() || v.abs() > MAX_COORD_MM) {
            return Err(self.malformed(
                line,
                format!(
                    "{} target {} mm is beyond ±{MAX_COORD_MM} mm (1 km); check the units",
                    ['X', 'Y', 'Z'][k],
                    num(target[k])
                ),
            ));
        }
        if self.segments.len() >= MAX_POINTS {
            return Err(self.malformed(line, format!("more than {MAX_POINTS} moves: the limit that bounds memory")));
        }
        let from = Point::new(self.pos[0], self.pos[1]);
        let to = Point::new(target[0], target[1]);
        match motion {
            Motion::Rapid | Motion::Linear => {
                // Z-only moves are kept as zero-length segments: they mark pen lifts between touching strokes.
                if from != to || target[2] != self.pos[2] {
                    self.segment(line, from, to, target[2], self.spindle, motion == Motion::Rapid);
                }
            }
            Motion::Cw | Motion::Ccw => self.arc(line, motion == Motion::Cw, from, to, target[2], (i, j, r))?,
        }
        self.pos = target;
        Ok(())
    }

    fn arc(
        &mut self,
        line: usize,
        cw: bool,
        from: Point,
        to: Point,
        z: f64,
        (i, j, r): (Option<f64>, Option<f64>, Option<f64>),
    ) -> Result<(), GcodeError> {
        let u = self.mm_per_unit;
        let center = if let Some(r) = r {
            if i.is_some() || j.is_some() {
                return Err(self.malformed(line, "an arc takes either R or I/J, not both"));
            }
            r_arc_centre(from, to, r, u, cw).map_err(|m| self.malformed(line, m))?
        } else {
            let (ci, cj) = (i.unwrap_or(0.0) * u, j.unwrap_or(0.0) * u);
            if self.arc_center_absolute {
                Point::new(ci + self.offset[0], cj + self.offset[1])
            } else {
                Point::new(from.x + ci, from.y + cj)
            }
        };
        check_arc_centre(center).map_err(|m| self.malformed(line, m))?;
        let r0 = (from - center).hypot();
        let r1 = (to - center).hypot();
        if r0 == 0.0 {
            return Err(self.malformed(line, "arc centre is on its start point"));
        }
        if (r0 - r1).abs() > (0.005f64).max(0.001 * r0) {
            return Err(self.malformed(
                line,
                format!("arc end is not on the circle (radius {r0:.4} mm at the start, {r1:.4} mm at the end)"),
            ));
        }
        let a0 = (from.y - center.y).atan2(from.x - center.x);
        let a1 = (to.y - center.y).atan2(to.x - center.x);
        let tau = std::f64::consts::TAU;
        let mut sweep = a1 - a0;
        if cw {
            while sweep >= 0.0 {
                sweep -= tau;
            }
            // Same start and end: a full turn (sweep is -2π), a tiny negative sweep stays as is.
        } else {
            while sweep <= 0.0 {
                sweep += tau;
            }
        }
        if sweep.abs() > tau {
            sweep = sweep.signum() * tau;
        }
        let max_step = if r0 > ARC_TOLERANCE_MM { 2.0 * (1.0 - ARC_TOLERANCE_MM / r0).acos() } else { tau };
        let n = (sweep.abs() / max_step).ceil().clamp(1.0, MAX_ARC_CHORDS);
        // n ≤ MAX_ARC_CHORDS: exact in f64.
        #[allow(clippy::cast_precision_loss)]
        if self.segments.len() as f64 + n > MAX_POINTS as f64 {
            return Err(self.malformed(line, format!("more than {MAX_POINTS} moves: the limit that bounds memory")));
        }
        // n is in [1, MAX_ARC_CHORDS], so the conversion is exact.
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let n_chords = n as u32;
        let mut prev = from;
        for k in 1..=n_chords {
            let p = if k == n_chords {
                to
            } else {
                let a = a0 + sweep * f64::from(k) / n;
                Point::new(center.x + r0 * a.cos(), center.y + r0 * a.sin())
            };
            if p != prev {
                self.segment(line, prev, p, z, self.spindle, false);
            }
            prev = p;
        }
        Ok(())
    }
}

/// The centre of an `R`-form arc from `from` to `to` (machine mm), `r` in file units of `mm_per_unit` mm, clockwise
/// when `cw` (a negative `R` asks for the major arc). Shared by the drawing and the print import. An error text
/// (without the line) when the chord is empty, the radius is shorter than half the chord, or the centre would lie
/// beyond ±[`MAX_COORD_MM`] — which is where an overflowing radius (`R1e200`) ends up, instead of at a NaN centre
/// that draws nothing.
pub(crate) fn r_arc_centre(from: Point, to: Point, r: f64, mm_per_unit: f64, cw: bool) -> Result<Point, String> {
    let r_mm = r * mm_per_unit;
    let chord = to - from;
    let d = chord.hypot();
    if d == 0.0 {
        return Err("an R-form arc cannot start and end at the same point".into());
    }
    let half = d / 2.0;
    // (|r| − d/2)(|r| + d/2) rather than r² − d²/4: the same height, without overflowing for radii up to 1e300.
    let h2 = (r_mm.abs() - half) * (r_mm.abs() + half);
    if h2 < -(ARC_TOLERANCE_MM * r_mm.abs()).max(1e-9) {
        return Err(format!("arc radius {} is smaller than half the chord", short(r)));
    }
    let h = h2.max(0.0).sqrt();
    // Centre to the right of the chord for a clockwise minor arc (Y up); G3 or a negative R flips it.
    let right = kurbo::Vec2::new(chord.y, -chord.x) / d;
    let sign = if cw == (r_mm >= 0.0) { 1.0 } else { -1.0 };
    let centre = from.midpoint(to) + right * (h * sign);
    if check_arc_centre(centre).is_err() {
        // An overflowing radius (`R1e200`) gets here too, with an infinite height, instead of a NaN centre.
        return Err(format!("arc centre for radius {} lies beyond ±{MAX_COORD_MM} mm (1 km)", short(r)));
    }
    Ok(centre)
}

/// An arc's centre must be a number within ±[`MAX_COORD_MM`] (an `I`/`J` of `1e200` is not), else an error text.
pub(crate) fn check_arc_centre(centre: Point) -> Result<(), String> {
    if centre.x.abs() <= MAX_COORD_MM && centre.y.abs() <= MAX_COORD_MM {
        Ok(())
    } else {
        Err(format!("arc centre ({}, {}) mm is beyond ±{MAX_COORD_MM} mm (1 km)", short(centre.x), short(centre.y)))
    }
}

/// A number as an importer's message shows it: as written when that is short (`12.5`, `2539999974.6`), else with
/// four significant digits and an exponent (`1.000e200`), never hundreds of digits.
pub(crate) fn short(v: f64) -> String {
    let plain = num(v);
    if plain.len() <= 16 { plain } else { format!("{v:.3e}") }
}

/// The error a stop (a termination signal, or the requester gone) ends an import with, naming the line.
fn stopped(origin: &str, line: usize, cancel: &Cancel) -> Result<(), GcodeError> {
    let why = if cancel.is_cancelled() {
        Some("cancelled: the import was no longer wanted".to_string())
    } else {
        interrupt::check(|| format!("reading line {line} of {origin}")).err().map(|e| e.to_string())
    };
    match why {
        Some(message) => Err(GcodeError::Malformed { origin: origin.into(), line, message }),
        None => Ok(()),
    }
}

/// Import G-code text (`origin` names it in errors); machine coordinates are mapped to page coordinates through
/// `profile`.
pub fn import(text: &str, origin: &str, profile: &MachineProfile) -> Result<ImportedGcode, GcodeError> {
    import_cancellable(text, origin, profile, &Cancel::never())
}

/// Whether `text` has an `M5` (or `M05`) word outside comments: a file that lifts its servo pen so.
fn lifts_with_m5(text: &str) -> bool {
    text.lines().any(|raw| {
        let code = raw.split([';', '(']).next().unwrap_or("").as_bytes();
        code.windows(2).enumerate().any(|(i, w)| {
            let zeros = code[i + 1..].iter().take_while(|&&b| b == b'0').count();
            let after = code.get(i + 1 + zeros);
            w[0].eq_ignore_ascii_case(&b'm')
                && after == Some(&b'5')
                && !code.get(i + 2 + zeros).is_some_and(u8::is_ascii_digit)
                && !(i > 0 && code[i - 1].is_ascii_alphanumeric())
        })
    })
}

/// [`import`] that ends early with an error naming the line once `cancel` is set or the process is asked to stop
/// ([`interrupt`]), looked at every [`CHECK_EVERY`] lines.
pub fn import_cancellable(
    text: &str,
    origin: &str,
    profile: &MachineProfile,
    cancel: &Cancel,
) -> Result<ImportedGcode, GcodeError> {
    let mut m = Machine {
        origin,
        servo_up_deg: if lifts_with_m5(text) { f64::NAN } else { profile.pen.servo_up_deg },
        servo_down_deg: std::iter::once(profile.pen.servo_down_deg)
            .chain(profile.pens.iter().filter_map(|p| p.servo_down_deg))
            .collect(),
        printer: profile.axes.e.is_some(),
        mm_per_unit: 1.0,
        absolute: true,
        arc_center_absolute: false,
        motion: None,
        pos: [0.0; 3],
        offset: [0.0; 3],
        spindle: false,
        used_spindle: false,
        ended: false,
        segments: Vec::new(),
        layer_starts: Vec::new(),
        warnings: Tally::default(),
    };
    for (idx, raw) in text.lines().enumerate() {
        if idx.is_multiple_of(CHECK_EVERY) {
            stopped(origin, idx + 1, cancel)?;
        }
        m.run_line(idx + 1, raw)?;
    }
    // Pass 2: how is the pen lifted?
    let zs = m.segments.iter().map(|s| s.z).filter(|z| z.is_finite());
    let (zmin, zmax) = zs.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), z| (lo.min(z), hi.max(z)));
    let mut warnings: Vec<GcodeWarning> = std::mem::take(&mut m.warnings)
        .finish()
        .into_iter()
        .map(|n| GcodeWarning { line: n.at, count: n.count, message: n.message })
        .collect();
    let pen = if zmax - zmin > 1e-6 {
        PenDetection::ZBelow((zmin + zmax) / 2.0)
    } else if m.used_spindle {
        PenDetection::Spindle
    } else {
        if !m.segments.is_empty() {
            let message = "no pen lift found (no Z changes, no M3/M5): G1/G2/G3 moves draw, G0 moves travel";
            record_warning(&mut warnings, 0, message.into());
        }
        PenDetection::FeedMoves
    };
    let down = |s: &Segment| match pen {
        PenDetection::ZBelow(t) => s.z < t,
        PenDetection::Spindle => s.spindle,
        PenDetection::FeedMoves => !s.rapid,
    };
    let name = std::path::Path::new(origin).file_stem().and_then(|s| s.to_str()).unwrap_or("gcode").to_string();
    let mut layers = vec![Layer::new(name.clone())];
    let mut breaks = std::mem::take(&mut m.layer_starts).into_iter().peekable();
    let mut paths: Vec<Polyline> = Vec::new();
    let mut current: Vec<Point> = Vec::new();
    // Points made so far (each segment adds one or two): the drawing's limit, checked where a point is made.
    let mut points = 0usize;
    for (k, s) in m.segments.iter().enumerate() {
        if points > MAX_POINTS {
            return Err(GcodeError::Malformed {
                origin: origin.into(),
                line: usize::try_from(s.line).unwrap_or(usize::MAX),
                message: format!("more than {MAX_POINTS} points in the drawing (the limit that keeps memory bounded)"),
            });
        }
        while let Some((_, layer)) = breaks.next_if(|b| b.0 <= k) {
            // A pause (pen change) ends the stroke and the layer.
            if current.len() > 1 {
                paths.push(Polyline::new(std::mem::take(&mut current)));
            }
            current.clear();
            if let Some(l) = layers.last_mut() {
                l.paths.append(&mut paths);
            }
            layers.push(layer);
        }
        if s.from == s.to {
            // A pen event without XY motion: a lift ends the stroke, anything else changes nothing.
            if !down(s) && pen != PenDetection::FeedMoves && current.len() > 1 {
                paths.push(Polyline::new(std::mem::take(&mut current)));
            }
            if !down(s) && pen != PenDetection::FeedMoves {
                current.clear();
            }
            continue;
        }
        if !down(s) {
            if current.len() > 1 {
                paths.push(Polyline::new(std::mem::take(&mut current)));
            }
            current.clear();
            continue;
        }
        let (a, b) = (profile.machine_to_page(s.from), profile.machine_to_page(s.to));
        if current.last() != Some(&a) {
            if current.len() > 1 {
                paths.push(Polyline::new(std::mem::take(&mut current)));
            }
            current.clear();
            current.push(a);
            points += 1;
        }
        current.push(b);
        points += 1;
    }
    if points > MAX_POINTS {
        let line = m.segments.last().map_or(0, |s| usize::try_from(s.line).unwrap_or(usize::MAX));
        return Err(GcodeError::Malformed {
            origin: origin.into(),
            line,
            message: format!("more than {MAX_POINTS} points in the drawing (the limit that keeps memory bounded)"),
        });
    }
    if current.len() > 1 {
        paths.push(Polyline::new(current));
    }
    if let Some(l) = layers.last_mut() {
        l.paths.append(&mut paths);
    }
    // Pauses after the last stroke, or before the first, leave empty layers behind.
    layers.retain(|l| !l.paths.is_empty());
    if layers.is_empty() {
        layers.push(Layer::new(name));
    }
    Ok(ImportedGcode { drawing: Drawing { layers, page_mm: None }, pen, warnings })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::profile::PenCommand;
    use crate::geometry::steps::drawing_to_steps;
    use crate::output::gcode_out;
    use proptest::prelude::*;

    fn profile() -> MachineProfile {
        MachineProfile::default_plotter()
    }

    fn imp(text: &str) -> ImportedGcode {
        import(text, "t.gcode", &profile()).unwrap()
    }

    fn err(text: &str) -> String {
        import(text, "t.gcode", &profile()).unwrap_err().to_string()
    }

    #[test]
    fn z_lift_with_units_relative_and_g92() {
        let g = "G21 G90\nG0 Z5\nG0 X10 Y10\nG1 Z-1 F100\nG91\nG1 X10\nG1 Y10 ; comment\nG90\nG0 Z5\n\
                 G20\nG0 X1 Y1\nG1 Z0\nG1 X2 (inch)\nG21\nG0 Z5\nG92 X0 Y0\nG1 Z-1\nG1 X5 Y0\n";
        let r = imp(g);
        assert_eq!(r.pen, PenDetection::ZBelow(2.0));
        let paths: Vec<Vec<Point>> = r.drawing.paths().map(|p| p.points.clone()).collect();
        assert_eq!(paths.len(), 3);
        assert_eq!(paths[0], vec![Point::new(10.0, 10.0), Point::new(20.0, 10.0), Point::new(20.0, 20.0)]);
        assert_eq!(paths[1], vec![Point::new(25.4, 25.4), Point::new(50.8, 25.4)]);
        // G92 X0 Y0 at (50.8, 25.4): X5 in work coordinates is 55.8 on the machine.
        assert_eq!(paths[2], vec![Point::new(50.8, 25.4), Point::new(55.8, 25.4)]);
        assert!(r.warnings.is_empty(), "{:?}", r.warnings);
    }

    #[test]
    fn m0_and_m1_start_layers_named_by_their_comments() {
        let g = "G0 X1 Y1\nM3\nG1 X2 Y1\nM5\nM0 (pen: red)\nG0 X5 Y5\nM3\nG1 X6 Y5\nG1 X6 Y6\nM5\n\
                 M1 ; second pen\nM0\nG0 X1 Y9\nM3\nG1 X2 Y9\nM5\nM0 (pen: green)\n";
        let r = imp(g);
        let layers: Vec<(&str, Vec<Vec<Point>>)> = r
            .drawing
            .layers
            .iter()
            .map(|l| (l.name.as_str(), l.paths.iter().map(|p| p.points.clone()).collect()))
            .collect();
        // "second pen" (M1, nothing drawn before the next pause) and "green" (nothing after it) stay empty and go.
        let p = Point::new;
        assert_eq!(
            layers,
            [
                ("t", vec![vec![p(1.0, 1.0), p(2.0, 1.0)]]),
                ("red", vec![vec![p(5.0, 5.0), p(6.0, 5.0), p(6.0, 6.0)]]),
                ("pen 4", vec![vec![p(1.0, 9.0), p(2.0, 9.0)]]),
            ]
        );
        assert!(r.warnings.is_empty(), "{:?}", r.warnings);
    }

    #[test]
    fn our_multi_pen_export_reimports_with_its_pen_changes() {
        let mut p = profile();
        p.pens.clear();
        let line = |y: f64| Polyline::new(vec![Point::new(10.0, y), Point::new(30.0, y)]);
        let layer = |name: &str, color: crate::Rgb, ys: &[f64]| {
            let mut l = Layer::new(name);
            l.pen.color = color;
            l.paths = ys.iter().map(|y| line(*y)).collect();
            l
        };
        let red = crate::Rgb(255, 0, 0);
        let d = Drawing {
            layers: vec![
                layer("a", crate::Rgb::BLACK, &[10.0]),
                layer("b", red, &[20.0, 30.0]),
                layer("c", red, &[40.0]),
            ],
            page_mm: None,
        };
        let g = gcode_out::export(&p, &drawing_to_steps(&p, &d).unwrap());
        // b and c share a pen, so the export stops once, before b: the re-import has b's and c's lines in one layer.
        let r = import(&g, "three.gcode", &p).unwrap();
        let got: Vec<(&str, crate::Rgb, usize)> =
            r.drawing.layers.iter().map(|l| (l.name.as_str(), l.pen.color, l.paths.len())).collect();
        assert_eq!(got, [("three", crate::Rgb::BLACK, 1), ("b", red, 3)]);
    }

    #[test]
    fn servo_lift_and_checksums() {
        let g = "N1 G0 X1 Y1*57\nN2 M3 S90\nN3 G1 X2 Y1\nN4 M5\nN5 G0 X5\nM3\nG1 Y5\nM5\n";
        let r = imp(g);
        assert_eq!(r.pen, PenDetection::Spindle);
        let paths: Vec<Vec<Point>> = r.drawing.paths().map(|p| p.points.clone()).collect();
        assert_eq!(
            paths,
            vec![vec![Point::new(1.0, 1.0), Point::new(2.0, 1.0)], vec![Point::new(5.0, 1.0), Point::new(5.0, 5.0)]]
        );
    }

    #[test]
    fn laser_style_feed_moves_with_a_warning() {
        let r = imp("G0 X1 Y1\nG1 X3 Y1\nG0 X0 Y0\n");
        assert_eq!(r.pen, PenDetection::FeedMoves);
        assert_eq!(r.drawing.path_count(), 1);
        assert_eq!(r.warnings.len(), 1);
        assert!(r.warnings[0].message.contains("no pen lift"));
    }

    #[test]
    fn arcs_stay_within_tolerance_and_end_exactly() {
        // Full CCW circle of radius 10 around (20, 20) by I/J, then a CW half circle by R.
        let r = imp("G0 Z1\nG0 X30 Y20\nG1 Z0\nG3 X30 Y20 I-10 J0\nG2 X10 Y20 R10\nG0 Z1\n");
        let paths: Vec<&Polyline> = r.drawing.paths().collect();
        assert_eq!(paths.len(), 1);
        let pts = &paths[0].points;
        assert_eq!(*pts.last().unwrap(), Point::new(10.0, 20.0));
        for w in pts.windows(2) {
            let mid = w[0].midpoint(w[1]);
            let d = mid.distance(Point::new(20.0, 20.0));
            // Midpoints of chords sit inside the circle by at most the tolerance (the R arc uses the same circle).
            assert!((10.0 - d) <= ARC_TOLERANCE_MM + 1e-9 && d <= 10.0 + 1e-9, "{d}");
        }
        // The full circle passes through (20, 30) and the CW half circle from (30,20) to (10,20) through (20, 10).
        let near = |q: Point| pts.iter().any(|p| p.distance(q) < 0.2);
        assert!(near(Point::new(20.0, 30.0)) && near(Point::new(20.0, 10.0)));
        let turn: f64 = pts.windows(2).map(|w| w[0].distance(w[1])).sum();
        let expect = 2.0 * std::f64::consts::PI * 10.0 * 1.5;
        assert!(turn < expect && expect - turn < 0.03, "{turn} vs {expect}");
    }

    #[test]
    fn absurd_numbers_are_errors_not_hangs() {
        // The reproducer: X = 3.4e38, written out and in exponent notation (a number on a plotter).
        let huge = format!("G0 Z1\nG1 Z0\nG1 X{:.1} Y10 F1000\nG1 X10 Y10\n", 3.4e38);
        let e = err(&huge);
        assert_eq!(e, "t.gcode:3: X target 3.4e38 mm is beyond ±1000000 mm (1 km); check the units");
        let e = err("G0 Z1\nG1 Z0\nG1 X3.4e38 Y10 F1000\n");
        assert_eq!(e, "t.gcode:3: X target 3.4e38 mm is beyond ±1000000 mm (1 km); check the units");
        assert_eq!(num(1e-300), "1e-300");
        assert_eq!(num(-0.125), "-0.125");
        // Beyond f64 altogether: a range error naming the word.
        assert_eq!(err("G0 X1\nG1 Y1e400\n"), "t.gcode:2: Y1e400: number out of range");
        assert!(err(&format!("G1 X{}\n", "9".repeat(400))).starts_with("t.gcode:1: X999"));
        assert!(err("G20\nG1 Y99999999\n").starts_with("t.gcode:2: Y target 2539999974.6"));
        assert!(err("G92 X-999999999\nG90 G1 X1\n").starts_with("t.gcode:2: X target"));
        assert!(err("G0 X0 Y0\nG2 X1 Y0 R1000000000\n").contains(":2: arc centre"));
        // Full circles of 1 km radius need 31 416 chords each: the move limit stops the import, in bounded time.
        let mut many = String::from("G0 X0 Y0\nG1 Z0\n");
        for _ in 0..200 {
            many.push_str("G2 X0 Y0 I999999 J0\n");
        }
        let e = err(&many);
        assert!(e.contains(&format!("more than {MAX_POINTS} moves")), "{e}");
    }

    #[test]
    fn bad_input_is_named_by_line() {
        assert_eq!(err("G0 X1\nG1 Y2\nG18\n"), "t.gcode:3: unsupported command G18: only the XY plane (G17) is drawn");
        assert!(err("G1 X1\nM999\n").starts_with("t.gcode:2: unsupported command M999"));
        assert!(err("G1 X1\nG7\n").contains(":2: unsupported command G7: unknown G code"));
        assert!(err("X10\n").contains(":1: axis words without a motion command"));
        assert!(err("G1 X1 A5\n").contains("A5"));
        assert!(err("G1 X\n").contains(":1: X needs a number"));
        assert!(err("G1 X1 #\n").contains("unexpected character"));
        assert!(err("G2 X10 Y0 R2\n").contains("smaller than half the chord"));
        assert!(err("G2 X10 Y0 I3 J0\n").contains("not on the circle"));
        assert!(err("G92\n").contains("G92 needs"));
        assert!(err("G1 X1 I2\n").contains("without an arc motion"));
    }

    #[test]
    fn harmless_commands_pass_and_dropped_ones_warn() {
        let r = imp("M17\nM106 S255\nG4 P1\nT1\nM6\nG0 Z2\nG1 X1 Y0 E0.5\nG1 Z0\nG1 X2 E1\nG1 X3 E1.5\nM30\nG1 X9\n");
        let msgs: Vec<String> = r.warnings.iter().map(ToString::to_string).collect();
        assert!(msgs.iter().any(|m| m.starts_with("line 4: tool selection")), "{msgs:?}");
        assert!(msgs.iter().any(|m| m.starts_with("line 7: extruder (E) values ignored (3 times)")), "{msgs:?}");
        assert!(msgs.iter().any(|m| m.starts_with("line 12: commands after the program end")), "{msgs:?}");
        assert_eq!(r.drawing.path_count(), 1);
        assert_eq!(r.drawing.paths().next().unwrap().end(), Some(Point::new(3.0, 0.0)));
    }

    #[test]
    fn exponent_notation_is_a_number_on_a_plotter() {
        // What a script printing Python floats writes: `1e-05` lands at 0.00001 mm, not 1 mm off with an E word.
        let r = imp("G0 Z1\nG0 X0 Y0\nG1 Z0\nG1 X1e-05 Y3.5e1\nG1 X2E1 Y35\nG1 X+2.5E+1 Y.35e2\nG0 Z1\n");
        let paths: Vec<Vec<Point>> = r.drawing.paths().map(|p| p.points.clone()).collect();
        let p = Point::new;
        assert_eq!(paths, [vec![p(0.0, 0.0), p(0.000_01, 35.0), p(20.0, 35.0), p(25.0, 35.0)]]);
        assert!(r.warnings.is_empty(), "{:?}", r.warnings);
        // Command letters are never exponents: `G1E5` is G1 and an E word (dropped with its warning).
        let r = imp("G0 Z1\nG0 X0 Y0\nG1 Z0\nG1E5 X3\n");
        assert_eq!(r.drawing.paths().next().unwrap().end(), Some(p(3.0, 0.0)));
        assert_eq!(r.warnings[0].to_string(), "line 4: extruder (E) values ignored");
        // An E word after a space stays an E word; `1e.5` cannot be an exponent and is said to be ambiguous.
        let r = imp("G0 Z1\nG0 X0 Y0\nG1 Z0\nG1 X1 E5\nG1 X2e.5\n");
        assert_eq!(r.drawing.paths().next().unwrap().end(), Some(p(2.0, 0.0)));
        let w: Vec<String> = r.warnings.iter().map(ToString::to_string).collect();
        assert!(w[0].starts_with("line 4: extruder (E) values ignored (2 times)"), "{w:?}");
        assert!(w[1].starts_with("line 5: ambiguous number: X2 runs into e.5"), "{w:?}");
    }

    #[test]
    fn a_number_run_into_e_on_a_printer_is_read_as_marlin_does_with_a_warning() {
        let printer = MachineProfile::from_toml(include_str!("../../../samples/printer.toml"), "printer.toml").unwrap();
        let r = import("G0 Z1\nG0 X0 Y0\nG1 Z0\nG1 X1e40 Y2\nG1 X3 Y2 E7\n", "t.gcode", &printer).unwrap();
        let w: Vec<String> = r.warnings.iter().map(ToString::to_string).collect();
        assert!(w[0].starts_with("line 4: ambiguous number: X1 runs into e40, read as two words"), "{w:?}");
        // X1 (and E40, which a drawing drops), as Marlin reads it.
        let pts = &r.drawing.paths().next().unwrap().points;
        let page = |x, y| printer.machine_to_page(Point::new(x, y));
        assert_eq!(pts[..], [page(0.0, 0.0), page(1.0, 2.0), page(3.0, 2.0)]);
    }

    #[test]
    fn messages_echo_at_most_forty_characters() {
        // Issue 12a: a 1 MB number is not echoed whole.
        let big = "1".repeat(1 << 20);
        for text in [format!("G1 X{big}\n"), format!("G1 X1-{big}\n"), format!("G1 A{big}\n"), format!("G{big}\n")] {
            let e = err(&text);
            assert!(e.len() < 200 && e.contains('…') && e.starts_with("t.gcode:1: "), "{}", &e[..e.len().min(300)]);
        }
        assert_eq!(echo("short"), "short");
        assert_eq!(echo(&"x".repeat(41)), format!("{}…", "x".repeat(40)));
        assert_eq!(echo(&"é".repeat(40)), "é".repeat(40));
    }

    #[test]
    fn ambiguous_numbers_on_a_printer_are_counted_not_listed_one_by_one() {
        let printer = MachineProfile::from_toml(include_str!("../../../samples/printer.toml"), "printer.toml").unwrap();
        let g: String = (0..3000).map(|n| format!("G1 X{}e{n}\n", n % 100)).collect();
        let r = import(&g, "t.gcode", &printer).unwrap();
        let w: Vec<String> = r.warnings.iter().map(ToString::to_string).collect();
        let ambiguous: Vec<&String> = w.iter().filter(|w| w.contains("ambiguous number")).collect();
        // Besides: the E values dropped (one message, 3000 times) and the lack of a pen lift.
        assert_eq!((ambiguous.len(), w.len()), (21, 23), "{:?}", &w[..w.len().min(25)]);
        assert!(ambiguous[0].starts_with("line 1: ambiguous number: X0 runs into e0"), "{}", ambiguous[0]);
        assert_eq!(
            ambiguous[20],
            "line 21: and 2980 more like it (ambiguous number run into E; only the first 20 different ones are listed)"
        );
    }

    #[test]
    fn a_cancelled_import_stops_naming_the_line() {
        let cancel = Cancel::new();
        cancel.cancel();
        let g = "G1 X1\n".repeat(2 * CHECK_EVERY);
        let e = import_cancellable(&g, "t.gcode", &profile(), &cancel).unwrap_err().to_string();
        assert_eq!(e, "t.gcode:1: cancelled: the import was no longer wanted");
        assert!(import_cancellable(&g, "t.gcode", &profile(), &Cancel::new()).is_ok());
    }

    #[test]
    fn arc_numbers_are_shown_short() {
        assert_eq!(short(1e300), "1e300");
        assert_eq!(short(-0.125), "-0.125");
        assert_eq!(short(1.234_567_890_123_456_7e-7), "1.235e-7");
        // R1e200: the radius squared overflowed; the centre is said to be too far, with the radius short.
        let e = err("G0 X0 Y0\nG1 Z0\nG2 X50 Y0 R1e200\n");
        assert_eq!(e, "t.gcode:3: arc centre for radius 1e200 lies beyond ±1000000 mm (1 km)");
    }

    /// A number-like text: sign, digits (sometimes a huge run), point, fraction, exponent.
    fn number_like() -> impl Strategy<Value = String> {
        plotter_fw::testing::number_like(11..=20, 1..2000)
    }

    proptest! {
        /// Fuzz target of the G-code number grammar: random number-like words through the firmware's parser, the
        /// host's word splitter in both modes, the plotter import and the print import. Never a panic; a value or
        /// a clear, bounded error naming the line; the firmware and the host agree on every value both accept and
        /// on every number run into an E word.
        #[test]
        fn number_grammar_fuzz(letter in prop::sample::select(&['X', 'Y', 'Z', 'F', 'S']), num in number_like()) {
            let code = format!("G1 {letter}{num}");
            let fw = plotter_fw::gcode::parse_words(code.as_bytes());
            let marlin = words(&code, "t", 1, Exponents::EWords);
            let plotter = words(&code, "t", 1, Exponents::Numbers);
            for r in [&marlin, &plotter] {
                if let Err(e) = r {
                    let e = e.to_string();
                    prop_assert!(e.starts_with("t:1: ") && e.chars().count() < 150, "{}", e);
                }
            }
            match &fw {
                Ok(w) => {
                    // The firmware's exact decimal agrees with the host's f64 (the firmware rounds to 10⁻⁶).
                    let v = w.get(letter as u8).expect("the word is there");
                    let host = marlin.as_ref().expect("the host takes what the firmware takes");
                    prop_assert_eq!(host.len(), 2);
                    prop_assert!(!host[1].runs_into_e);
                    let diff = (host[1].value * 1e6 - v as f64).abs();
                    prop_assert!(diff <= 0.5 + 1e-15 * (v as f64).abs(), "{} vs {}", host[1].value, v);
                }
                Err(e) if e.code == plotter_fw::errors::ErrorCode::AmbiguousE => {
                    // Ambiguous for the firmware: flagged or refused by the host's Marlin reading too.
                    prop_assert!(marlin.as_ref().is_err() || marlin.as_ref().unwrap().iter().any(|w| w.runs_into_e));
                }
                Err(_) => {}
            }
            if let Ok(ws) = &plotter {
                // Read as one number (an exponent is never split off into an E word on a plotter), or, where `e` is
                // not followed by exponent digits (`1e.5`), split with the ambiguity flagged for a warning.
                if ws.len() == 2 {
                    prop_assert_eq!(Some(ws[1].value), num.parse::<f64>().ok());
                } else {
                    prop_assert!(ws[1].runs_into_e && ws[2].letter == 'E', "{:?}", ws);
                }
            }
            // The whole importers: a result or an error naming the line, never a panic, never a huge message.
            let drawing = format!("G0 Z1\nG1 Z0\nG1 {letter}{num} Y1 F600\n");
            if let Err(e) = import(&drawing, "t.gcode", &profile()) {
                let e = e.to_string();
                prop_assert!(e.starts_with("t.gcode:3: ") && e.chars().count() < 200, "{}", e);
            }
            let printer =
                MachineProfile::from_toml(include_str!("../../../samples/printer.toml"), "printer.toml").unwrap();
            let print = format!("G28\nG1 {letter}{num} Y1 F600\n");
            match crate::input::gcode_print::import_print(&print, "t.gcode", &printer) {
                Ok(p) => prop_assert!(p.warnings.is_empty() && marlin.is_ok_and(|ws| !ws.iter().any(|w| w.runs_into_e))),
                Err(e) => {
                    let e = e.to_string();
                    prop_assert!(e.starts_with("t.gcode:2: ") && e.chars().count() < 300, "{}", e);
                }
            }
        }
    }

    fn arb_paths() -> impl Strategy<Value = Vec<Polyline>> {
        let pt = (0.0f64..400.0, 0.0f64..290.0).prop_map(|(x, y)| Point::new(x, y));
        prop::collection::vec(prop::collection::vec(pt, 2..20).prop_map(Polyline::new), 1..10)
    }

    proptest! {
        #[test]
        fn export_then_import_gives_the_same_steps(paths in arb_paths(), servo in any::<bool>(), flip in any::<bool>()) {
            let mut p = profile();
            if servo { p.pen.command = PenCommand::Servo; }
            if flip { p.page_origin = crate::config::profile::PageOrigin::BottomLeft; }
            let steps = drawing_to_steps(&p, &Drawing::single_layer("a", paths)).unwrap();
            // Strokes whose every point rounds to the same step carry no motion and come back as nothing.
            let mut expected = steps.clone();
            expected.strokes.retain(|s| !s.moves.is_empty());
            let back = import(&gcode_out::export(&p, &steps), "rt", &p).unwrap();
            prop_assert!(back.warnings.is_empty());
            let again = drawing_to_steps(&p, &back.drawing).unwrap();
            prop_assert_eq!(again.strokes, expected.strokes);
        }
    }
}
