//! Planning a print: a [`PrintProgram`] becomes the exact sequence the firmware runs — step blocks planned by the
//! firmware's own planner ([`plotter_fw::planner`], E following the X/Y/Z path with its own limits) interleaved
//! with the firmware commands (heaters, fan, homing) in file order.
//!
//! As for plots ([`crate::motion::plan`]), every target is converted to whole steps once (rounded) and each block
//! is the difference to the previous target, so positions — extrusion included — never drift; the blocks are
//! planned over whole runs (unlimited look-ahead), quantized to what a wire frame carries, and timed with the
//! stepper's own arithmetic, so [`PrintPlan::total_ticks`] is the motion time the firmware executes, to the tick.
//!
//! A run ends (the machine comes to rest) where the firmware stops consuming the stream: a heating wait (`M109`,
//! `M190`), an autotune, homing, a dwell, motors off, or `M400`. Commands that do not wait (`M104`, `M106`, ...)
//! stay inside a run and act when the firmware reads them, as in Marlin.
//!
//! The print starts homed: a program whose first move comes before any `G28` gets one in front.

use plotter_fw::planner::{self, PlanBlock};
use plotter_fw::protocol::{self, DWELL_MAX};
use plotter_fw::{MachineConfig, NUM_AXES, StepBlock, TICK_HZ};

use crate::MachineProfile;
use crate::geometry::steps::round_steps;
use crate::input::gcode_print::{PrintOp, PrintProgram};
use crate::motion::plan::{MachinePos, homed_position, machine_config};

/// Errors planning a print.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PrintPlanError {
    /// The profile cannot drive the firmware, or has no extruder.
    #[error("machine profile: {0}")]
    Profile(String),
    /// A move leaves the machine's travel.
    #[error("line {line}: {axis} = {value_mm:.3} mm is outside the travel 0..{travel_mm} mm")]
    OutsideTravel {
        /// Source line.
        line: usize,
        /// Axis letter.
        axis: char,
        /// Target, mm.
        value_mm: f64,
        /// Travel, mm.
        travel_mm: f64,
    },
    /// A position beyond what steps can count.
    #[error("line {line}: position out of range")]
    Range {
        /// Source line.
        line: usize,
    },
}

/// One thing to send.
#[derive(Debug, Clone, PartialEq)]
pub enum PrintItem {
    /// A step block (a move or a dwell), quantized as the frame carries it.
    Block {
        /// The block.
        block: StepBlock,
        /// Layer of the move (0 = before the first layer).
        layer: usize,
    },
    /// A G-code line for the firmware.
    Line {
        /// The command.
        text: String,
        /// The firmware holds the stream until it is done.
        wait: bool,
        /// Source line (0 = added by the planner).
        line: usize,
        /// Layer at that point.
        layer: usize,
    },
}

/// The planned print.
#[derive(Debug, Clone, PartialEq)]
pub struct PrintPlan {
    /// Items in order.
    pub items: Vec<PrintItem>,
    /// Exact motion and dwell time, ticks ([`TICK_HZ`]); heating waits and homing are not included.
    pub total_ticks: u64,
    /// Number of layers.
    pub layers: usize,
    /// Position after the last block (steps, from the last homing).
    pub end: MachinePos,
    /// Net E steps over the whole print.
    pub e_steps: i64,
}

impl PrintPlan {
    /// Motion time in seconds.
    pub fn seconds(&self) -> f64 {
        // Tick counts of a print fit f64's mantissa.
        #[allow(clippy::cast_precision_loss)]
        let t = self.total_ticks as f64;
        t / f64::from(TICK_HZ)
    }

    /// Time spent standing still in dwell blocks (`G4`, settles), ticks ([`TICK_HZ`]): part of
    /// [`Self::total_ticks`], known before anything moves.
    pub fn dwell_ticks(&self) -> u64 {
        self.items
            .iter()
            .filter_map(|i| match i {
                PrintItem::Block { block, .. } if block.is_dwell() => Some(u64::from(block.duration_ticks())),
                _ => None,
            })
            .sum()
    }

    /// Dwell time in seconds ([`Self::dwell_ticks`]).
    pub fn dwell_seconds(&self) -> f64 {
        // Tick counts of a print fit f64's mantissa.
        #[allow(clippy::cast_precision_loss)]
        let t = self.dwell_ticks() as f64;
        t / f64::from(TICK_HZ)
    }

    /// Number of step blocks.
    pub fn block_count(&self) -> usize {
        self.items.iter().filter(|i| matches!(i, PrintItem::Block { .. })).count()
    }
}

/// The plan's items as the bytes sent on the wire, numbered from sequence number `base`: step blocks as frames,
/// lines as `N<seq> <text>*<checksum>` (one sequence for both, so resends work the same for either).
pub fn wire_items(plan: &PrintPlan, base: u32) -> Result<Vec<Vec<u8>>, String> {
    let mut enc = protocol::Encoder::new();
    let mut buf = [0u8; protocol::MAX_FRAME];
    let mut out = Vec::with_capacity(plan.items.len());
    for (i, item) in plan.items.iter().enumerate() {
        let seq = base.wrapping_add(u32::try_from(i).map_err(|_| "too many items".to_string())?);
        match item {
            PrintItem::Block { block, .. } => {
                let n = enc.encode(block, seq, &mut buf).map_err(|e| format!("item {i}: cannot encode: {e:?}"))?;
                out.push(buf[..n].to_vec());
            }
            PrintItem::Line { text, .. } => {
                let body = format!("N{seq} {text}");
                let cs = plotter_fw::gcode::xor_checksum(body.as_bytes());
                out.push(format!("{body}*{cs}\n").into_bytes());
            }
        }
    }
    Ok(out)
}

struct Planner<'c> {
    cfg: &'c MachineConfig,
    items: Vec<PrintItem>,
    run: Vec<PlanBlock>,
    run_layers: Vec<usize>,
    /// Lines to emit after `n` blocks of the current run.
    run_lines: Vec<(usize, PrintItem)>,
    total: u64,
}

impl Planner<'_> {
    fn flush(&mut self) {
        planner::link_all(&mut self.run, self.cfg);
        planner::plan(&mut self.run, 0.0);
        let mut lines = std::mem::take(&mut self.run_lines).into_iter().peekable();
        for (i, sb) in planner::step_blocks(&self.run).enumerate() {
            while let Some((_, item)) = lines.next_if(|(n, _)| *n <= i) {
                self.items.push(item);
            }
            let q = protocol::quantize(&sb);
            self.total += u64::from(q.duration_ticks());
            self.items.push(PrintItem::Block { block: q, layer: self.run_layers[i] });
        }
        self.items.extend(lines.map(|(_, item)| item));
        self.run.clear();
        self.run_layers.clear();
    }

    fn line(&mut self, item: PrintItem, wait: bool) {
        if wait {
            self.flush();
            self.items.push(item);
        } else {
            self.run_lines.push((self.run.len(), item));
        }
    }
}

/// Plan `program` for `profile`: a printer, or a plotter playing its G-code as written (no extruder: the program
/// then never moves E, which [`crate::input::gcode_print::import_print`] guarantees).
pub fn plan_print(profile: &MachineProfile, program: &PrintProgram) -> Result<PrintPlan, PrintPlanError> {
    let cfg = machine_config(profile).map_err(|e| PrintPlanError::Profile(e.to_string()))?;
    let homed = homed_position(profile).map_err(|e| PrintPlanError::Profile(e.to_string()))?;
    let axes = [Some(profile.axes.x), Some(profile.axes.y), Some(profile.axes.z), profile.axes.e];
    let mut p = Planner {
        cfg: &cfg,
        items: Vec::new(),
        run: Vec::new(),
        run_layers: Vec::new(),
        run_lines: Vec::new(),
        total: 0,
    };
    let mut pos: MachinePos = homed;
    let mut e_steps: i64 = 0;
    let mut layer = 0;
    let first_move = program.ops.iter().position(|o| matches!(o, PrintOp::Move { .. }));
    let first_home = program.ops.iter().position(|o| matches!(o, PrintOp::Home { .. }));
    if first_move.is_some() && first_home.is_none_or(|h| Some(h) > first_move) {
        p.items.push(PrintItem::Line { text: "G28".into(), wait: true, line: 0, layer: 0 });
    }
    for op in &program.ops {
        match op {
            PrintOp::Move { to, feed_mm_s, layer: l, line } => {
                layer = *l;
                let mut target = pos;
                for k in 0..NUM_AXES {
                    let Some(a) = &axes[k] else {
                        if to[k] != 0.0 {
                            return Err(PrintPlanError::Profile(format!(
                                "line {line}: {:?} has no extruder (axes.e)",
                                profile.name
                            )));
                        }
                        continue;
                    };
                    if k < 3 && a.travel_mm > 0.0 && !(-1e-9..=a.travel_mm + 1e-9).contains(&to[k]) {
                        return Err(PrintPlanError::OutsideTravel {
                            line: *line,
                            axis: ['X', 'Y', 'Z'][k],
                            value_mm: to[k],
                            travel_mm: a.travel_mm,
                        });
                    }
                    target[k] = round_steps(to[k] * a.steps_per_mm).ok_or(PrintPlanError::Range { line: *line })?;
                }
                let steps: [i32; NUM_AXES] = std::array::from_fn(|k| target[k] - pos[k]);
                e_steps += i64::from(steps[3]);
                pos = target;
                // f32 is ample for a feed in mm/s.
                #[allow(clippy::cast_possible_truncation)]
                let feed = *feed_mm_s as f32;
                if let Some(b) = PlanBlock::line(&cfg, steps, feed) {
                    p.run.push(b);
                    p.run_layers.push(layer);
                }
            }
            PrintOp::Dwell { ms, .. } => {
                p.flush();
                let mut left = (ms * 1000.0).round();
                while left > 0.0 {
                    let chunk = left.min(f64::from(DWELL_MAX));
                    // Within 1..=DWELL_MAX.
                    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
                    let ticks = chunk as u32;
                    p.total += u64::from(ticks);
                    p.items.push(PrintItem::Block { block: StepBlock::dwell(ticks), layer });
                    left -= chunk;
                }
            }
            PrintOp::Sync { .. } => p.flush(),
            PrintOp::Home { axes, line } => {
                let mut text = String::from("G28");
                for (k, letter) in ['X', 'Y', 'Z'].iter().enumerate() {
                    if axes & 1 << k != 0 {
                        text.push(' ');
                        text.push(*letter);
                        text.push('0');
                    }
                }
                p.line(PrintItem::Line { text, wait: true, line: *line, layer }, true);
                // The homed axes at their homed position; E is not homed and keeps counting.
                for k in (0..3).filter(|k| *axes == 0 || axes & 1 << k != 0) {
                    pos[k] = homed[k];
                }
            }
            PrintOp::Command { text, wait, line } => {
                p.line(PrintItem::Line { text: text.clone(), wait: *wait, line: *line, layer }, *wait);
            }
        }
    }
    p.flush();
    Ok(PrintPlan { items: p.items, total_ticks: p.total, layers: program.layers, end: pos, e_steps })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::gcode_print::import_print;

    fn printer() -> MachineProfile {
        MachineProfile::from_toml(include_str!("../../../samples/printer.toml"), "printer.toml").unwrap()
    }

    fn plan(g: &str) -> PrintPlan {
        plan_print(&printer(), &import_print(g, "t.gcode", &printer()).unwrap()).unwrap()
    }

    #[test]
    fn retraction_time_and_steps_are_exact() {
        // From home: an E-only 2 mm retraction at 35 mm/s (E allows 120 mm/s, 5000 mm/s²). On the wire: cruise
        // 35·93 = 3255 → 3248 steps/s (frame rate quantization), acceleration 5000·93 = 465 000 steps/s² (a
        // frame carries up to 2²⁴ − 1). So: ramps 2·3248/465000 = 13.970 ms over 11.343 steps each, cruise
        // (186 − 22.686)/3248 = 50.282 ms: 64.252 ms.
        let p = plan("G28\nG1 E-2 F2100\n");
        assert_eq!(p.e_steps, -186);
        let t = p.total_ticks as f64;
        assert!((t - 64_252.0).abs() < 3.0, "{t} {:?}", p.items);
        assert!(matches!(&p.items[0], PrintItem::Line { text, wait: true, .. } if text == "G28"));
    }

    #[test]
    fn plotter_gcode_plays_as_written() {
        // The plotter kit (no extruder), pen up at Z 4 after homing: drop at F1500 (25 mm/s, Z's top speed, 500 mm/s²),
        // settle 50 ms (GRBL's `G4 P` in seconds), rapid back up, every move from rest to rest. 25 mm/s is 10 000
        // steps/s, sent as 9984 (the wire's rate quantum, 64 steps/s), at 500·400 = 200 000 steps/s²: ramps of
        // 9984/200000 = 49.92 ms over 249.2 steps each, cruise (1600 − 498.4)/9984 = 110.34 ms: 210.18 ms per move
        // (the ideal 25 mm/s gives 210 ms); in all 2·210.176 + 50 = 470.352 ms.
        let kit = MachineProfile::default_plotter();
        let g = "G1 Z0 F1500\nG4 P0.05\nG0 Z4\n";
        let p = plan_print(&kit, &import_print(g, "v.gcode", &kit).unwrap()).unwrap();
        let t = p.total_ticks as f64;
        assert!((t - 470_352.0).abs() < 3.0, "{t} {:?}", p.items);
        assert_eq!(p.dwell_ticks(), 50_000, "the G4 alone");
        assert_eq!((p.e_steps, p.end[2]), (0, 1600));
        let blocks: Vec<i32> = p
            .items
            .iter()
            .filter_map(|i| if let PrintItem::Block { block, .. } = i { Some(block.steps[2]) } else { None })
            .collect();
        assert_eq!(blocks, [-1600, 0, 1600]);
    }

    #[test]
    fn a_long_dwell_is_counted_whole() {
        // 48 hours of G4 (an hour each, split into blocks of at most DWELL_MAX ticks on the wire) between two
        // moves.
        let kit = MachineProfile::default_plotter();
        let g = format!("G1 Z0 F1500\n{}G0 Z4\n", "G4 P3600\n".repeat(48));
        let p = plan_print(&kit, &import_print(&g, "d.gcode", &kit).unwrap()).unwrap();
        assert_eq!(p.dwell_ticks(), 172_800 * u64::from(TICK_HZ));
        assert_eq!(p.dwell_seconds(), 172_800.0);
        assert!(p.total_ticks > p.dwell_ticks() && p.total_ticks - p.dwell_ticks() < 500_000, "{}", p.total_ticks);
    }

    #[test]
    fn waits_split_runs_and_non_waits_keep_their_place() {
        let p = plan("G28\nG1 X10 F3000\nM106 S255\nG1 X20\nM109 S200\nG1 X30\nG4 P250\n");
        let kinds: Vec<String> = p
            .items
            .iter()
            .map(|i| match i {
                PrintItem::Block { block, .. } if block.is_dwell() => format!("dwell{}", block.dwell_ticks),
                PrintItem::Block { block, .. } => format!("x{}e{}", block.steps[0], block.exit_rate),
                PrintItem::Line { text, .. } => text.clone(),
            })
            .collect();
        // The fan command sits between the two X moves, which run through without stopping (exit > 0); the heating
        // wait ends the run (exit 0); the dwell is 250 ms.
        assert_eq!(kinds[0], "G28");
        assert!(kinds[1].starts_with("x800e") && !kinds[1].ends_with("e0"), "{kinds:?}");
        assert_eq!(&kinds[2..4], ["M106 S255".to_string(), "x800e0".to_string()]);
        assert_eq!(kinds[4], "M109 S200");
        assert_eq!(kinds[5..], ["x800e0".to_string(), "dwell250000".to_string()]);
        assert_eq!(p.end[0], 2400);
    }

    #[test]
    fn a_print_without_homing_gets_one_and_travel_is_checked() {
        let p = plan("G1 X1 F600\n");
        assert!(matches!(&p.items[0], PrintItem::Line { text, line: 0, .. } if text == "G28"));
        let prog = import_print("G28\nG1 X300 F600\n", "t.gcode", &printer()).unwrap();
        let e = plan_print(&printer(), &prog).unwrap_err().to_string();
        assert_eq!(e, "line 2: X = 300.000 mm is outside the travel 0..235 mm");
    }
}
