//! Slicer G-code for a printer profile, played back: the moves with their extrusion (X, Y, Z, E in machine
//! millimetres), and the heater, fan and homing commands in order. This is what `plotter print` plans and streams
//! ([`crate::motion::print_plan`]).
//!
//! The flavour is Marlin's, as PrusaSlicer and Cura write it:
//! - moves: `G0`/`G1` (both at the modal feed, as Marlin does), `G2`/`G3` arcs in the XY plane (I/J or R, the
//!   extrusion spread evenly over the chords), `G4` dwell, `G20`/`G21`, `G90`/`G91`, `M82`/`M83` (E absolute /
//!   relative; `G90`/`G91` set E too, as in Marlin), `G92` (any axis, E included);
//! - sent to the firmware: `G28` (homing), `M104`/`M109`/`M140`/`M190` (targets and waits, `S` or `R`), `M106`/`M107`
//!   (fan), `M105`, `M155`, `M84`/`M18`/`M17` (motors), `M301`/`M303`/`M304` (PID), `M112`;
//! - accepted and ignored with a warning (counted per command, never a failure): progress and messages (`M73`,
//!   `M117`, `M486`), linear advance (`M900`), machine limits (`M201`, `M203`, `M204`, `M205` — the profile's limits
//!   apply), feed/flow overrides (`M220`, `M221`), firmware checks (`M115`, `M862.x`), bed levelling (`G29`, `G80`),
//!   firmware retraction (`G10`/`G11`), pauses, tool changes, beeps, and any other M code;
//! - `M400` (wait for moves) becomes a stop in the plan.
//!
//! Unknown G codes and malformed words are errors naming the line: they could change the geometry. So is a number
//! run straight into an `E` word (`G1 X1e40`): Marlin reads X1 and extrudes 40 mm, a script printing floats meant
//! 10⁴⁰; which one is not guessed. Commands for the firmware are sent in canonical form and at most [`COMMAND_MAX`]
//! characters long.
//!
//! Layers: a layer starts at the first extruding move at a Z above the previous layer's. The slicer's own figures
//! are read from its comments when present: `; estimated printing time (normal mode) = 1h 2m 3s` (PrusaSlicer),
//! `;TIME:3723` (Cura), `; filament used [mm] = 1234.56` (PrusaSlicer), `;Filament used: 1.23456m` (Cura).
//!
//! With a plotter profile (no extruder, `axes.e` absent) the same playback plays plotter G-code exactly as written
//! (`plotter plot FILE.gcode --as-written`): every move, pen lift and dwell as the file states it, nothing re-planned.
//! There an `E` word, a heater or fan command and a spindle/servo command (`M3`/`M4`/`M5`, which only the drawing
//! import reads as pen down/up) are errors naming the line, numbers may use exponents (`X1e-05`) as in the
//! drawing import, `G4 P` is in seconds and `G0` runs at the machine's top speed, as GRBL reads them (Marlin, for
//! printers: milliseconds, and the modal feed).

use kurbo::Point;

use super::gcode_in::{CHECK_EVERY, check_arc_centre, r_arc_centre};
use super::gcode_words::{Exponents, GcodeError, GcodeWarning, Word, code10, echo, num, strip_comments, words};
use super::warn_tally::Tally;
use crate::MachineProfile;
use crate::config::interrupt;
use crate::geometry::steps::StepMapper;

/// Maximum chord error when flattening arcs, millimetres.
const ARC_TOLERANCE_MM: f64 = 0.005;
/// Most chords one arc may become.
const MAX_ARC_CHORDS: f64 = 100_000.0;
/// Most operations one file may produce (bounds memory: about 100 bytes each).
pub const MAX_OPS: usize = 20_000_000;
/// Longest command sent to the firmware as written: its line buffer less room for `N<seq> ` and `*<checksum>`.
pub const COMMAND_MAX: usize = plotter_fw::line_buffer::LINE_MAX - 16;

/// One step of the print.
#[derive(Debug, Clone, PartialEq)]
pub enum PrintOp {
    /// A straight move to `to` (machine mm: X, Y, Z, E) at `feed_mm_s` along the X/Y/Z path (E-only moves: along
    /// E); infinite = the machine's maximum.
    Move {
        /// Target, machine millimetres.
        to: [f64; 4],
        /// Feed, mm/s.
        feed_mm_s: f64,
        /// Layer (0 before the first layer starts).
        layer: usize,
        /// Source line.
        line: usize,
    },
    /// Dwell, milliseconds.
    Dwell {
        /// Duration, ms.
        ms: f64,
        /// Source line.
        line: usize,
    },
    /// Wait until all moves are done (`M400`).
    Sync {
        /// Source line.
        line: usize,
    },
    /// Home (`G28`): the axes in `axes` (bits X=1, Y=2, Z=4; 0 = all).
    Home {
        /// Axis mask.
        axes: u8,
        /// Source line.
        line: usize,
    },
    /// A firmware command sent as written (canonical form, e.g. `M109 S210`).
    Command {
        /// The command.
        text: String,
        /// The firmware holds the stream until it is done (a heating wait, autotune, motors off).
        wait: bool,
        /// Source line.
        line: usize,
    },
}

/// What the slicer says about its file.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SlicerFigures {
    /// Estimated print time, s.
    pub estimate_s: Option<f64>,
    /// Filament used, mm.
    pub filament_mm: Option<f64>,
}

/// A print, ready to plan.
#[derive(Debug, Clone, PartialEq)]
pub struct PrintProgram {
    /// The operations in order.
    pub ops: Vec<PrintOp>,
    /// Everything ignored or assumed, with first line and count.
    pub warnings: Vec<GcodeWarning>,
    /// Number of layers.
    pub layers: usize,
    /// Filament pushed out of the nozzle, mm: the highest net E position reached (a retraction pulls filament
    /// back into the nozzle, its prime pushes the same filament out again), which is what slicers report as
    /// "filament used".
    pub extruded_mm: f64,
    /// Net E at the end (sum of all E moves, retractions negative), mm.
    pub net_e_mm: f64,
    /// The slicer's own figures from the comments.
    pub slicer: SlicerFigures,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Motion {
    /// `G0`: at the modal feed for a printer (Marlin), at the machine's top speed for a plotter (GRBL).
    Rapid,
    Linear,
    Cw,
    Ccw,
}

struct Player<'a> {
    origin: &'a str,
    mm_per_unit: f64,
    absolute: bool,
    e_relative: bool,
    motion: Option<Motion>,
    feed_mm_s: f64,
    pos: [f64; 4],
    offset: [f64; 4],
    homed_pos: [f64; 4],
    layer: usize,
    layer_z: f64,
    ended: bool,
    ops: Vec<PrintOp>,
    warnings: Tally,
    net_e: f64,
    high_e: f64,
    /// The machine has an extruder (a printer profile); without one, E words and heater commands are errors.
    extruder: bool,
}

/// Parse `; estimated printing time (normal mode) = 1d 2h 3m 4s` style durations.
fn parse_duration(s: &str) -> Option<f64> {
    let mut total = 0.0;
    let mut any = false;
    for part in s.split_whitespace() {
        let (num, unit) = part.split_at(part.find(|c: char| c.is_ascii_alphabetic())?);
        let v: f64 = num.parse().ok()?;
        total += v * match unit {
            "d" => 86_400.0,
            "h" => 3600.0,
            "m" => 60.0,
            "s" => 1.0,
            _ => return None,
        };
        any = true;
    }
    any.then_some(total)
}

fn slicer_comment(raw: &str, figures: &mut SlicerFigures) {
    let Some(c) = raw.trim_start().strip_prefix(';') else { return };
    let c = c.trim();
    if let Some(v) = c.strip_prefix("estimated printing time (normal mode) =") {
        figures.estimate_s = figures.estimate_s.or(parse_duration(v.trim()));
    } else if let Some(v) = c.strip_prefix("TIME:") {
        figures.estimate_s = figures.estimate_s.or(v.trim().parse().ok());
    } else if let Some(v) = c.strip_prefix("filament used [mm] =") {
        // Several extruders are comma-separated; sum them.
        let sum: Option<f64> = v.split(',').map(|x| x.trim().parse::<f64>().ok()).sum();
        figures.filament_mm = figures.filament_mm.or(sum);
    } else if let Some(v) = c.strip_prefix("Filament used:") {
        let m: Option<f64> = v.split(',').map(|x| x.trim().trim_end_matches('m').parse::<f64>().ok()).sum();
        figures.filament_mm = figures.filament_mm.or(m.map(|m| m * 1000.0));
    }
}

impl Player<'_> {
    /// A warning whose text is also its kind.
    fn warn(&mut self, line: usize, message: &'static str) {
        self.warnings.note(line, message, "", message.to_string());
    }

    /// A warning of `kind` whose text varies (it quotes the input).
    fn warn_as(&mut self, line: usize, kind: &'static str, message: String) {
        self.warnings.note(line, kind, "", message);
    }

    fn malformed(&self, line: usize, message: impl Into<String>) -> GcodeError {
        GcodeError::Malformed { origin: self.origin.into(), line, message: message.into() }
    }

    fn push(&mut self, line: usize, op: PrintOp) -> Result<(), GcodeError> {
        if self.ops.len() >= MAX_OPS {
            return Err(self.malformed(line, format!("more than {MAX_OPS} moves and commands")));
        }
        self.ops.push(op);
        Ok(())
    }

    fn run_line(&mut self, line: usize, raw: &str) -> Result<(), GcodeError> {
        let code = strip_comments(raw);
        let code = code.trim();
        if code.is_empty() || code == "%" {
            return Ok(());
        }
        let exponents = if self.extruder { Exponents::EWords } else { Exponents::Numbers };
        let ws = match words(code, self.origin, line, exponents) {
            Ok(ws) => ws,
            Err(e) => {
                // Printer-specific M codes carry free text (`M117 Hello`, `M862.3 P "MK3S"`): ignore those lines
                // with a warning; anything else that does not parse is an error.
                let upper = code.to_ascii_uppercase();
                let body = upper.trim_start_matches(|c: char| c == 'N' || c.is_ascii_digit() || c == ' ');
                let head: String = body.chars().take_while(|c| *c == 'M' || c.is_ascii_digit() || *c == '.').collect();
                let sent = ["M104", "M109", "M140", "M190", "M106", "M107", "M105", "M155", "M301", "M303", "M304"];
                if head.starts_with('M') && head.len() > 1 && !sent.contains(&head.as_str()) {
                    self.warn_as(
                        line,
                        "unsupported M codes, ignored",
                        format!("{}: not supported, ignored", echo(&head)),
                    );
                    return Ok(());
                }
                return Err(e);
            }
        };
        if self.ended {
            self.warn(line, "commands after the program end (M2/M30) ignored");
            return Ok(());
        }
        if let Some(k) = ws.iter().position(|w| w.runs_into_e) {
            // `G1 X1e40`: Marlin would move to X1 and extrude 40 mm; a script printing floats meant 10⁴⁰. Neither is
            // guessed on a machine that pushes filament.
            let next = ws.get(k + 1).map_or("E", |w| w.text);
            return Err(self.malformed(
                line,
                format!(
                    "ambiguous number: {} runs into {} (an extrusion as Marlin reads it, or an exponent); put a space \
                     before E, or write the number without an exponent",
                    echo(ws[k].text),
                    echo(next)
                ),
            ));
        }
        let mut axes: [Option<f64>; 4] = [None; 4];
        let (mut i, mut j, mut r) = (None, None, None);
        let (mut s, mut p) = (None, None);
        let mut g: Option<(f64, &str)> = None;
        let mut m: Option<(f64, &str)> = None;
        for w in &ws {
            match w.letter {
                'G' if g.is_none() => g = Some((w.value, w.text)),
                'M' if m.is_none() && g.is_none() => m = Some((w.value, w.text)),
                'G' | 'M' => return Err(self.malformed(line, "one G or M command per line, please")),
                'X' => axes[0] = Some(w.value),
                'Y' => axes[1] = Some(w.value),
                'Z' => axes[2] = Some(w.value),
                'E' if !self.extruder => {
                    return Err(GcodeError::Unsupported {
                        origin: self.origin.into(),
                        line,
                        word: echo(&w.text.to_uppercase()),
                        why: "this machine has no extruder",
                    });
                }
                'E' => axes[3] = Some(w.value),
                'F' => {
                    if w.value <= 0.0 {
                        return Err(self.malformed(line, "F must be positive"));
                    }
                    self.feed_mm_s = w.value * self.mm_per_unit / 60.0;
                }
                'I' => i = Some(w.value),
                'J' => j = Some(w.value),
                'R' => r = Some(w.value),
                'S' => s = Some(w.value),
                'P' => p = Some(w.value),
                'N' => {}
                'T' if m.is_some() => {}
                'T' => {
                    if w.value != 0.0 {
                        self.warn(line, "tool change ignored: one extruder");
                    }
                    return Ok(());
                }
                _ if m.is_some() => {}
                _ => {
                    return Err(GcodeError::Unsupported {
                        origin: self.origin.into(),
                        line,
                        word: echo(&w.text.to_uppercase()),
                        why: "unknown word",
                    });
                }
            }
        }
        if let Some((v, text)) = m {
            return self.m_code(line, v, text, code, &ws);
        }
        let any_axis = axes.iter().any(Option::is_some);
        if let Some((v, text)) = g {
            match code10(v) {
                0 => self.motion = Some(Motion::Rapid),
                10 => self.motion = Some(Motion::Linear),
                20 => self.motion = Some(Motion::Cw),
                30 => self.motion = Some(Motion::Ccw),
                40 => {
                    // `G4 P`: milliseconds in Marlin (printers); seconds in GRBL, which plotter G-code follows
                    // (vpype-gcode's profiles, our own export). `S` is seconds in both.
                    let p_ms = if self.extruder { p } else { p.map(|p| p * 1000.0) };
                    let ms = p_ms.or(s.map(|s| s * 1000.0)).unwrap_or(0.0);
                    if !(0.0..=3_600_000.0).contains(&ms) {
                        return Err(self.malformed(line, "G4 dwell out of range (0..=3600 s)"));
                    }
                    if ms > 0.0 {
                        self.push(line, PrintOp::Dwell { ms, line })?;
                    }
                    return Ok(());
                }
                200 => self.mm_per_unit = 25.4,
                210 => self.mm_per_unit = 1.0,
                900 => (self.absolute, self.e_relative) = (true, false),
                910 => (self.absolute, self.e_relative) = (false, true),
                170 | 940 | 400 | 490 | 540 => {}
                280 => {
                    if axes[3].is_some() {
                        self.warn(line, "G28 E: the extruder has no home, ignored");
                    }
                    if ws.iter().any(|w| matches!(w.letter, 'W' | 'O' | 'R')) {
                        self.warn(line, "G28 options ignored");
                    }
                    let mask = (0..3).filter(|k| axes[*k].is_some()).fold(0u8, |m, k| m | 1 << k);
                    self.push(line, PrintOp::Home { axes: mask, line })?;
                    for k in (0..3).filter(|k| mask == 0 || mask & 1 << k != 0) {
                        self.pos[k] = self.homed_pos[k];
                        self.offset[k] = 0.0;
                    }
                    return Ok(());
                }
                920 => {
                    if !any_axis {
                        self.warn(line, "G92 without axes ignored");
                    }
                    for (k, v) in axes.iter().enumerate() {
                        if let Some(v) = v {
                            self.offset[k] = self.pos[k] - v * self.unit(k);
                        }
                    }
                    return Ok(());
                }
                100 | 110 => {
                    let message = format!("{}: firmware retraction not supported, ignored", echo(&text.to_uppercase()));
                    self.warn_as(line, "firmware retraction, ignored", message);
                    return Ok(());
                }
                290 | 800 => {
                    self.warn_as(
                        line,
                        "bed levelling, ignored",
                        format!("{}: bed levelling ignored", echo(&text.to_uppercase())),
                    );
                    return Ok(());
                }
                180 | 190 => {
                    return Err(GcodeError::Unsupported {
                        origin: self.origin.into(),
                        line,
                        word: echo(&text.to_uppercase()),
                        why: "only the XY plane (G17) is supported",
                    });
                }
                _ => {
                    return Err(GcodeError::Unsupported {
                        origin: self.origin.into(),
                        line,
                        word: echo(&text.to_uppercase()),
                        why: "unknown G code",
                    });
                }
            }
        }
        let has_arc = i.is_some() || j.is_some() || r.is_some();
        if !any_axis && !has_arc {
            return Ok(());
        }
        let Some(motion) = self.motion else {
            return Err(self.malformed(line, "axis words without a motion command (G0/G1/G2/G3)"));
        };
        let mut target = self.pos;
        for (k, v) in axes.iter().enumerate() {
            if let Some(v) = v {
                let absolute = if k == 3 { !self.e_relative } else { self.absolute };
                target[k] = if absolute { v * self.unit(k) + self.offset[k] } else { target[k] + v * self.unit(k) };
            }
        }
        if !target.iter().all(|v| v.is_finite() && v.abs() < 1e7) {
            return Err(self.malformed(line, "position out of range"));
        }
        let rapid = motion == Motion::Rapid && !self.extruder;
        let feed = if self.feed_mm_s > 0.0 && !rapid { self.feed_mm_s } else { f64::INFINITY };
        match motion {
            Motion::Rapid | Motion::Linear => self.move_to(line, target, feed)?,
            Motion::Cw | Motion::Ccw => self.arc(line, motion == Motion::Cw, target, feed, (i, j, r))?,
        }
        Ok(())
    }

    fn unit(&self, axis: usize) -> f64 {
        // E is in the same units as the axes (G20 makes it inches too, as in Marlin).
        let _ = axis;
        self.mm_per_unit
    }

    fn move_to(&mut self, line: usize, to: [f64; 4], feed: f64) -> Result<(), GcodeError> {
        let de = to[3] - self.pos[3];
        let xy_moves = to[0] != self.pos[0] || to[1] != self.pos[1];
        if de > 0.0 && xy_moves && to[2] > self.layer_z + 1e-6 {
            self.layer += 1;
            self.layer_z = to[2];
        }
        self.net_e += de;
        self.high_e = self.high_e.max(self.net_e);
        if to != self.pos {
            self.push(line, PrintOp::Move { to, feed_mm_s: feed, layer: self.layer, line })?;
        }
        self.pos = to;
        Ok(())
    }

    fn arc(
        &mut self,
        line: usize,
        cw: bool,
        to: [f64; 4],
        feed: f64,
        (i, j, r): (Option<f64>, Option<f64>, Option<f64>),
    ) -> Result<(), GcodeError> {
        let u = self.mm_per_unit;
        let (fx, fy) = (self.pos[0], self.pos[1]);
        // The drawing import's checks ([`r_arc_centre`], [`check_arc_centre`]): an overflowing radius or offset is an
        // error naming the line, never a NaN centre whose arc has no chords (and vanishes).
        let centre = if let Some(r) = r {
            if i.is_some() || j.is_some() {
                return Err(self.malformed(line, "an arc takes either R or I/J, not both"));
            }
            r_arc_centre(Point::new(fx, fy), Point::new(to[0], to[1]), r, u, cw)
        } else {
            let c = Point::new(fx + i.unwrap_or(0.0) * u, fy + j.unwrap_or(0.0) * u);
            check_arc_centre(c).map(|()| c)
        };
        let Point { x: center_x, y: center_y } = centre.map_err(|m| self.malformed(line, m))?;
        let r0 = (fx - center_x).hypot(fy - center_y);
        let r1 = (to[0] - center_x).hypot(to[1] - center_y);
        if r0 == 0.0 || (r0 - r1).abs() > 0.005f64.max(0.001 * r0) {
            return Err(self.malformed(line, "arc end is not on the circle"));
        }
        let a0 = (fy - center_y).atan2(fx - center_x);
        let a1 = (to[1] - center_y).atan2(to[0] - center_x);
        let tau = std::f64::consts::TAU;
        let mut sweep = a1 - a0;
        if cw {
            while sweep >= 0.0 {
                sweep -= tau;
            }
        } else {
            while sweep <= 0.0 {
                sweep += tau;
            }
        }
        let max_step = if r0 > ARC_TOLERANCE_MM { 2.0 * (1.0 - ARC_TOLERANCE_MM / r0).acos() } else { tau };
        let n = (sweep.abs() / max_step).ceil().clamp(1.0, MAX_ARC_CHORDS);
        // n is in [1, MAX_ARC_CHORDS].
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let n_chords = n as u32;
        let from = self.pos;
        for k in 1..=n_chords {
            let f = f64::from(k) / n;
            let p = if k == n_chords {
                to
            } else {
                let a = a0 + sweep * f;
                [
                    center_x + r0 * a.cos(),
                    center_y + r0 * a.sin(),
                    from[2] + (to[2] - from[2]) * f,
                    from[3] + (to[3] - from[3]) * f,
                ]
            };
            self.move_to(line, p, feed)?;
        }
        Ok(())
    }

    fn m_code(&mut self, line: usize, v: f64, text: &str, code: &str, ws: &[Word<'_>]) -> Result<(), GcodeError> {
        let upper = echo(&text.to_uppercase());
        // Sent in canonical form (`M0104` → `M104`); the number is whole here (checked below before any send).
        let name = format!("M{}", code10(v) / 10);
        let send = |wait: bool, keep: &[char]| {
            let mut t = name.clone();
            for w in ws.iter().filter(|w| keep.contains(&w.letter)) {
                t.push(' ');
                t.push_str(&w.text.to_uppercase().replace(' ', ""));
            }
            PrintOp::Command { text: t, wait, line }
        };
        if !self.extruder {
            let why = match code10(v) / 10 {
                104 | 109 | 140 | 190 | 106 | 107 | 105 | 155 | 301 | 303 | 304 => {
                    Some("this machine has no heaters or fan")
                }
                3..=5 => Some(
                    "a spindle/servo pen command is not played as written (plot the file without --as-written: the \
                     drawing import reads M3/M5 as pen down/up)",
                ),
                _ => None,
            };
            if let Some(why) = why {
                return Err(GcodeError::Unsupported { origin: self.origin.into(), line, word: upper, why });
            }
        }
        if v.fract() != 0.0 {
            // M862.1 and friends (Prusa printer checks).
            self.warn_as(line, "printer checks, ignored", format!("{upper}: printer check ignored"));
            return Ok(());
        }
        let op = match code10(v) / 10 {
            82 => {
                self.e_relative = false;
                return Ok(());
            }
            83 => {
                self.e_relative = true;
                return Ok(());
            }
            400 => PrintOp::Sync { line },
            104 | 140 | 106 | 155 | 301 | 304 => send(false, &['S', 'R', 'P', 'I', 'D']),
            105 => send(false, &[]),
            107 => send(false, &[]),
            109 | 190 => send(true, &['S', 'R']),
            303 => send(true, &['E', 'S', 'C', 'U']),
            17 => send(false, &[]),
            18 | 84 => {
                if ws.iter().any(|w| matches!(w.letter, 'S' | 'X' | 'Y' | 'Z' | 'E')) {
                    let message = format!("{upper} arguments ignored: all motors are switched off");
                    self.warn_as(line, "motor-off arguments, ignored", message);
                }
                send(true, &[])
            }
            112 => send(false, &[]),
            2 | 30 => {
                self.ended = true;
                return Ok(());
            }
            0 | 1 => {
                self.warn(line, "program pause (M0/M1) ignored");
                return Ok(());
            }
            73 | 117 | 486 => {
                self.warn_as(line, "progress and messages, ignored", format!("{upper}: progress/message ignored"));
                return Ok(());
            }
            900 => {
                self.warn(line, "M900: linear advance ignored");
                return Ok(());
            }
            201 | 203 | 204 | 205 | 566 => {
                let message = format!("{upper}: machine limits ignored, the profile's limits apply");
                self.warn_as(line, "machine limits, ignored", message);
                return Ok(());
            }
            220 | 221 => {
                let pct = ws.iter().find(|w| w.letter == 'S').map_or(100.0, |w| w.value);
                if pct != 100.0 {
                    let message = format!("{upper} S{}: feed/flow override ignored, printing at 100 %", num(pct));
                    self.warn_as(line, "feed/flow overrides, ignored", message);
                } else {
                    self.warn_as(line, "feed/flow overrides, ignored", format!("{upper}: override at 100 % ignored"));
                }
                return Ok(());
            }
            _ => {
                self.warn_as(
                    line,
                    "unsupported M codes, ignored",
                    format!("{upper}: not supported, ignored ({})", echo(code)),
                );
                return Ok(());
            }
        };
        if let PrintOp::Command { text, .. } = &op
            && text.len() > COMMAND_MAX
        {
            return Err(self.malformed(
                line,
                format!("{}: longer than the {COMMAND_MAX} characters a firmware line has room for", echo(text)),
            ));
        }
        self.push(line, op)
    }
}

/// Interpret slicer G-code for `profile` — or, for a plotter profile (no `axes.e`), plotter G-code as written (see
/// the module docs). `origin` names the text in errors.
pub fn import_print(text: &str, origin: &str, profile: &MachineProfile) -> Result<PrintProgram, GcodeError> {
    let homed = StepMapper::new(profile).homed().map_err(|e| GcodeError::Malformed {
        origin: origin.into(),
        line: 0,
        message: e.to_string(),
    })?;
    let spm = [profile.axes.x.steps_per_mm, profile.axes.y.steps_per_mm, profile.axes.z.steps_per_mm];
    let homed_pos = [f64::from(homed[0]) / spm[0], f64::from(homed[1]) / spm[1], f64::from(homed[2]) / spm[2], 0.0];
    let mut p = Player {
        origin,
        mm_per_unit: 1.0,
        absolute: true,
        e_relative: false,
        motion: None,
        feed_mm_s: 0.0,
        pos: homed_pos,
        offset: [0.0; 4],
        homed_pos,
        layer: 0,
        layer_z: f64::NEG_INFINITY,
        ended: false,
        ops: Vec::new(),
        warnings: Tally::default(),
        net_e: 0.0,
        high_e: 0.0,
        extruder: profile.axes.e.is_some(),
    };
    let mut slicer = SlicerFigures::default();
    for (idx, raw) in text.lines().enumerate() {
        if idx.is_multiple_of(CHECK_EVERY) {
            // A termination signal ends a long import (the host raises the flag; see `config::interrupt`).
            interrupt::check(|| format!("reading line {} of {origin}", idx + 1))
                .map_err(|e| GcodeError::Malformed { origin: origin.into(), line: idx + 1, message: e.to_string() })?;
        }
        slicer_comment(raw, &mut slicer);
        p.run_line(idx + 1, raw)?;
    }
    let warnings = p
        .warnings
        .finish()
        .into_iter()
        .map(|n| GcodeWarning { line: n.at, count: n.count, message: n.message })
        .collect();
    Ok(PrintProgram { ops: p.ops, warnings, layers: p.layer, extruded_mm: p.high_e, net_e_mm: p.net_e, slicer })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn printer() -> MachineProfile {
        MachineProfile::from_toml(include_str!("../../../samples/printer.toml"), "printer.toml").unwrap()
    }

    fn moves(p: &PrintProgram) -> Vec<[f64; 4]> {
        p.ops.iter().filter_map(|o| if let PrintOp::Move { to, .. } = o { Some(*to) } else { None }).collect()
    }

    #[test]
    fn extrusion_modes_and_layers() {
        let g = "G28\nG90\nM83\nG1 Z0.2 F600\nG1 X10 Y10 E1.5 F1200\nG1 E-0.8 F2100\nG1 Z0.4\nG1 E0.8\n\
                 G1 X20 E1\nG92 E0\nM82\nG1 X30 E2\nG1 E1.2\nG91\nG1 X-5 E0.5\n";
        let p = import_print(g, "t.gcode", &printer()).unwrap();
        let m = moves(&p);
        assert_eq!(m[0], [0.0, 0.0, 0.2, 0.0]);
        assert_eq!(m[1], [10.0, 10.0, 0.2, 1.5]);
        assert!((m[2][3] - 0.7).abs() < 1e-12);
        assert_eq!(m[5], [20.0, 10.0, 0.4, 2.5]);
        // G92 E0 at 2.5: absolute E2 is machine 4.5; then E1.2 → 3.7 (a retraction); G91 makes E relative.
        assert_eq!(m[6][3], 4.5);
        assert!((m[7][3] - 3.7).abs() < 1e-12);
        assert!((m[8][3] - 4.2).abs() < 1e-12 && m[8][0] == 25.0);
        // Net 4.2 mm; the highest point was 4.5 mm (before the 0.8 mm retraction at the end of line 13).
        assert!((p.net_e_mm - 4.2).abs() < 1e-12);
        assert!((p.extruded_mm - 4.5).abs() < 1e-12);
        assert_eq!(p.layers, 2);
        assert!(p.warnings.is_empty(), "{:?}", p.warnings);
        // Homing comes first, then Z at pen-up height (3 mm) is the start of the Z0.2 move.
        assert_eq!(p.ops[0], PrintOp::Home { axes: 0, line: 1 });
        // End-of-print "G28 X0": X only, Z stays where it is.
        let p = import_print("G28\nG1 Z20 F600\nG28 X0\nG1 Y5\n", "t.gcode", &printer()).unwrap();
        assert_eq!(p.ops[2], PrintOp::Home { axes: 1, line: 3 });
        assert_eq!(moves(&p)[1], [0.0, 5.0, 20.0, 0.0]);
    }

    #[test]
    fn heater_commands_and_slicer_noise() {
        let g = "; estimated printing time (normal mode) = 1h 2m 3s\n; filament used [mm] = 1234.56\n\
                 M73 P0 R10\nM201 X1000 Y1000\nM203 X200\nM204 P1000\nM205 X8\nM900 K0\nM104 S210 T0\n\
                 M140 S60\nM190 S60\nM109 S210\nM106 S255\nM107\nM221 S95\nT0\nM862.3 P \"MK3S\"\nM117 Printing...\nM84\n";
        let p = import_print(g, "t.gcode", &printer()).unwrap();
        let cmds: Vec<(&str, bool)> = p
            .ops
            .iter()
            .filter_map(
                |o| if let PrintOp::Command { text, wait, .. } = o { Some((text.as_str(), *wait)) } else { None },
            )
            .collect();
        assert_eq!(
            cmds,
            [
                ("M104 S210", false),
                ("M140 S60", false),
                ("M190 S60", true),
                ("M109 S210", true),
                ("M106 S255", false),
                ("M107", false),
                ("M84", true)
            ]
        );
        assert_eq!(p.slicer.estimate_s, Some(3723.0));
        assert_eq!(p.slicer.filament_mm, Some(1234.56));
        let w: Vec<String> = p.warnings.iter().map(ToString::to_string).collect();
        for needle in ["M73", "M201", "M203", "M204", "M205", "M900", "M221 S95", "M862.3", "M117"] {
            assert!(w.iter().any(|x| x.contains(needle)), "{needle} in {w:?}");
        }
    }

    #[test]
    fn a_number_run_into_e_is_refused_not_extruded() {
        // Marlin would extrude 40 mm here; a script meant X = 10⁴⁰. The file is refused, naming the line.
        for (g, word) in [
            ("G1 X1e40", "X1 runs into e40"),
            ("G1 Y2 X1E5 F600", "X1 runs into E5"),
            ("G1 X1e-05", "X1 runs into e-05"),
        ] {
            let e = import_print(&format!("G28\n{g}\n"), "t.gcode", &printer()).unwrap_err().to_string();
            assert!(e.starts_with(&format!("t.gcode:2: ambiguous number: {word} (an extrusion")), "{e}");
        }
        // A space makes E a word; a command letter never takes an exponent.
        let p = import_print("G28\nG1 X1 E40 F600\nG1E41\n", "t.gcode", &printer()).unwrap();
        assert_eq!(moves(&p), [[1.0, 0.0, 3.0, 40.0], [1.0, 0.0, 3.0, 41.0]]);
        // Absurd values are range errors.
        let e = import_print("G1 X1\nG1 X99999999999\n", "t.gcode", &printer()).unwrap_err().to_string();
        assert_eq!(e, "t.gcode:2: position out of range");
    }

    #[test]
    fn commands_are_canonical_bounded_and_echoes_short() {
        let p = import_print("M0104 S200\nm140 s60\n", "t.gcode", &printer()).unwrap();
        let cmds: Vec<&PrintOp> = p.ops.iter().collect();
        assert_eq!(cmds[0], &PrintOp::Command { text: "M104 S200".into(), wait: false, line: 1 });
        assert_eq!(cmds[1], &PrintOp::Command { text: "M140 S60".into(), wait: false, line: 2 });
        // A 1 MB number: refused with a short message, never sent (the firmware's line could not hold it).
        let big = format!("M104 S{}210\n", "0".repeat(1 << 20));
        let e = import_print(&big, "t.gcode", &printer()).unwrap_err().to_string();
        assert!(e.starts_with("t.gcode:1: M104 S0000") && e.contains("…: longer than the 80 characters"), "{e}");
        assert!(e.len() < 200, "{}", e.len());
        let long_g = format!("G{}\n", "1".repeat(1 << 20));
        let e = import_print(&long_g, "t.gcode", &printer()).unwrap_err().to_string();
        assert!(e.len() < 200 && e.contains('…'), "{}", &e[..e.len().min(300)]);
        let p = import_print(&format!("M{}\n", "7".repeat(1 << 20)), "t.gcode", &printer()).unwrap();
        assert!(p.warnings[0].message.len() < 200, "{}", p.warnings[0].message.len());
    }

    #[test]
    fn arcs_spread_extrusion_and_errors_name_lines() {
        let p = import_print("G28\nG1 X10 Y0 Z1 F600\nG2 X0 Y10 I-10 J0 E3\n", "a.gcode", &printer()).unwrap();
        let m = moves(&p);
        let last = m.last().unwrap();
        assert_eq!(*last, [0.0, 10.0, 1.0, 3.0]);
        // A quarter circle (clockwise the long way: 270°): E rises evenly with the angle.
        let n = m.len() - 1;
        assert!(n > 10);
        // m[k] is chord k (m[0] is the G1).
        let mid = m[n / 2];
        assert!((mid[3] - 3.0 * (n / 2) as f64 / n as f64).abs() < 1e-9);
        for q in &m[1..] {
            assert!(((q[0] - 0.0).hypot(q[1]) - 10.0).abs() < 1e-9);
        }
        let e = import_print("G1 X1\nG18\n", "b.gcode", &printer()).unwrap_err().to_string();
        assert!(e.contains("b.gcode:2") && e.contains("G18"), "{e}");
        let e = import_print("G1 X1 Q2\n", "b.gcode", &printer()).unwrap_err().to_string();
        assert!(e.contains("b.gcode:1"), "{e}");
        // A plotter profile plays plotter G-code as written; what only a printer has is refused with its line.
        let plotter = MachineProfile::default_plotter();
        let e = import_print("G1 X1\nG1 X2 E2\n", "c.gcode", &plotter).unwrap_err().to_string();
        assert!(e.contains("c.gcode:2") && e.contains("E2") && e.contains("no extruder"), "{e}");
        let e = import_print("G1 X1\nM104 S200\n", "c.gcode", &plotter).unwrap_err().to_string();
        assert!(e.contains("c.gcode:2") && e.contains("M104") && e.contains("no heaters"), "{e}");
        let e = import_print("M3 S1000\n", "c.gcode", &plotter).unwrap_err().to_string();
        assert!(e.contains("c.gcode:1") && e.contains("M3") && e.contains("--as-written"), "{e}");
    }

    #[test]
    fn plotter_gcode_as_written() {
        // vpype-gcode style: lift, dwell, travel, drop, dwell, draw; exponents are numbers without an extruder.
        let g = "G21\nG90\nG0 Z4\nG4 P0.05\nG0 X10 Y5 F7200\nG1 Z0 F1500\nG4 P0.05\nG1 X2e1 Y5 F3600\nG0 Z4\nM2\n";
        let p = import_print(g, "v.gcode", &MachineProfile::default_plotter()).unwrap();
        let ops: Vec<String> = p
            .ops
            .iter()
            .map(|o| match o {
                PrintOp::Move { to, feed_mm_s, .. } => format!("move {:?} at {feed_mm_s}", &to[..3]),
                PrintOp::Dwell { ms, .. } => format!("dwell {ms}"),
                other => format!("{other:?}"),
            })
            .collect();
        // Without an extruder `G4 P` is in seconds, as GRBL and plotter tools write it: P0.05 = 50 ms.
        // The plotter starts homed with the pen up (Z 4), so the first `G0 Z4` moves nothing; `G0` is a rapid
        // (infinite feed: the machine's limits), `G1` keeps its feed (F1500 = 25 mm/s, F3600 = 60 mm/s).
        assert_eq!(MachineProfile::default_plotter().pen.up_z_mm, 4.0);
        assert_eq!(
            ops,
            [
                "dwell 50",
                "move [10.0, 5.0, 4.0] at inf",
                "move [10.0, 5.0, 0.0] at 25",
                "dwell 50",
                "move [20.0, 5.0, 0.0] at 60",
                "move [20.0, 5.0, 4.0] at inf"
            ]
        );
        assert_eq!((p.extruded_mm, p.layers), (0.0, 0));
    }

    #[test]
    fn an_overflowing_arc_is_an_error_naming_the_line_not_a_vanished_move() {
        // R1e200 squares to infinity: the centre became NaN, the arc got no chords and the 50 mm move vanished.
        let plotter = MachineProfile::default_plotter();
        for (arc, shown) in [("G2 X50 Y0 R1e200", "radius 1e200"), ("G2 X50 Y0 I1e200 J0", "(1e200, 0)")] {
            let g = format!("G1 Z0 F1500\nG1 X0 Y0\n{arc}\nG0 Z4\n");
            let e = import_print(&g, "a.gcode", &plotter).unwrap_err().to_string();
            assert!(e.starts_with("a.gcode:3: arc centre") && e.contains(shown) && e.len() < 120, "{e}");
        }
        // A large but sane radius still draws its arc, ending exactly at the target.
        let p = import_print("G1 Z0 F1500\nG1 X0 Y0\nG2 X50 Y0 R1000\n", "a.gcode", &plotter).unwrap();
        assert_eq!(moves(&p).last().map(|m| [m[0], m[1]]), Some([50.0, 0.0]));
    }

    #[test]
    fn distinct_warnings_of_one_kind_are_capped_and_counted() {
        // Each line warns with its own text (the echo of the line): kept are the first 20, then one summary line.
        let g: String = (0..5000).map(|n| format!("M5000 P{n}\n")).collect();
        let p = import_print(&g, "m.gcode", &MachineProfile::default_plotter()).unwrap();
        let w: Vec<String> = p.warnings.iter().map(ToString::to_string).collect();
        assert_eq!(w.len(), 21, "{w:?}");
        assert_eq!(w[0], "line 1: M5000: not supported, ignored (M5000 P0)");
        assert_eq!(w[19], "line 20: M5000: not supported, ignored (M5000 P19)");
        assert_eq!(
            w[20],
            "line 21: and 4980 more like it (unsupported M codes, ignored; only the first 20 different ones are listed)"
        );
    }
}
