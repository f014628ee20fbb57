//! A motion plan as EBB commands: each planned block becomes one `LM` per constant-acceleration phase of its
//! trapezoid (or `SM` constant-rate slices on firmware without `LM`), each pen block one `SP` with its settle as
//! the delay.
//!
//! # Exact time
//! The plan's block times are microseconds; the board counts 40 µs intervals. The program keeps the board's
//! running time `h` (intervals) and ends every block at `round(t / 40 µs)` of the plan's running time `t`, so the
//! rounding never accumulates: the board's total differs from the plan's by less than one interval. Inside a
//! block, each phase ends at its own rounded boundary, and each motor's step count at a boundary is its exact
//! share of the block rounded once (`round(e/n · Δmotor)` for `e` of the block's `n` events), so the steps of
//! the phases add up to the block's exactly (drift-free, like the plan's own steps). [`kinematics::fit_axis`]
//! then picks rates that put each phase's last step on its last interval.
//!
//! # Short moves
//! The board needs a few milliseconds to parse and queue a move; a stream of shorter ones leaves gaps (the
//! reference measures 4 ms for `LM` on firmware 3). Phases shorter than the profile's `min_move_ms` are joined
//! with a neighbour inside their block (one `LM` from the first's start rate to the last's end rate); blocks
//! that are shorter as a whole are counted in [`Program::short_moves`].

use plotter_fw::StepBlock;
use plotter_path::MachineProfile;
use plotter_path::motion::plan::{MotionPlan, MoveKind};

use super::kinematics::{self, INTERVAL_US, ONE_STEP, fit_axis, last_step_interval, mix, rate_units};

/// How the board is asked to move.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MotionStyle {
    /// `LM` with acceleration (firmware 2.7.0 and later).
    Lm,
    /// `SM` constant-rate slices (older firmware).
    Sm,
}

/// The pen servo as the program drives it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PenSetup {
    /// `SC,4` position (pen up).
    pub up_position: u16,
    /// `SC,5` position for the profile's `servo_down_deg`.
    pub down_position: u16,
    /// The profile's servo angles the two positions stand for.
    pub up_deg: f64,
    /// See `up_deg`.
    pub down_deg: f64,
    /// PortB pin of the servo.
    pub pin: u8,
}

impl PenSetup {
    /// From the profile's `[ebb]` and `[pen]` sections.
    pub fn of(profile: &MachineProfile) -> Result<PenSetup, ProgramError> {
        let e = profile.ebb.ok_or(ProgramError::NoEbbSection)?;
        Ok(PenSetup {
            up_position: e.pen_up_position,
            down_position: e.pen_down_position,
            up_deg: profile.pen.servo_up_deg,
            down_deg: profile.pen.servo_down_deg,
            pin: e.pen_pin,
        })
    }

    /// The pulse position of a servo angle (tenths of a degree), interpolated between the two positions.
    pub fn position(&self, tenths: u16) -> u16 {
        let deg = f64::from(tenths) / 10.0;
        if (self.down_deg - self.up_deg).abs() < 1e-9 {
            return self.down_position;
        }
        let f = (deg - self.up_deg) / (self.down_deg - self.up_deg);
        let p = f64::from(self.up_position) + f * (f64::from(self.down_position) - f64::from(self.up_position));
        // Clamped to the servo's range, so the cast cannot truncate.
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let p = p.round().clamp(1.0, 65535.0) as u16;
        p
    }
}

/// The built-in EiBotBoard models as `--model` options: `--model axidraw-v3 (AxiDraw V3 and SE/A4), …`.
fn ebb_models() -> String {
    let models = plotter_path::config::models::for_firmware(plotter_path::config::models::ModelFirmware::Ebb);
    models.map(|m| format!("--model {} ({})", m.name, m.description)).collect::<Vec<_>>().join(", ")
}

/// Why a plan cannot be sent to an EBB.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ProgramError {
    /// The profile has no `[ebb]` section.
    #[error(
        "the machine profile has no [ebb] section (pen servo positions and rates): choose the EiBotBoard machine \
         with {}, or add an [ebb] section to your profile",
        ebb_models()
    )]
    NoEbbSection,
    /// A pen block moves a Z axis.
    #[error("block {block}: the pen moves on a Z axis; an EBB lifts it with its servo (set pen.command = \"servo\")")]
    NotServo {
        /// Plan block index.
        block: usize,
    },
    /// A move asks a motor for more than 25 000 steps/s.
    #[error(
        "block {block}: motor {motor} would step at {rate:.0} steps/s, above the board's 25 000 (lower the feeds in \
         the profile)"
    )]
    TooFast {
        /// Plan block index.
        block: usize,
        /// Motor 1 or 2.
        motor: u8,
        /// Steps per second asked for.
        rate: f64,
    },
    /// No integer rates make a phase end on its interval (a motor slower than about one step per two seconds).
    #[error(
        "block {block}: no LM rates end the move on its planned interval ({steps:?} steps in {intervals} intervals)"
    )]
    Unfittable {
        /// Plan block index.
        block: usize,
        /// Motor steps of the phase.
        steps: [i64; 2],
        /// Its length, intervals.
        intervals: u64,
    },
}

/// One command of the program.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EbbCommand {
    /// The command, without its CR.
    pub line: String,
    /// The plan block it belongs to.
    pub block: usize,
    /// Board time it takes, intervals (0 for immediate commands such as `SC`).
    pub intervals: u64,
    /// Motor positions after it.
    pub motors: [i64; 2],
    /// Whether it is queued (and so takes a FIFO slot).
    pub queued: bool,
    /// The pen is down after it.
    pub pen_down: bool,
    /// Whether it is the last command of its block.
    pub ends_block: bool,
}

impl EbbCommand {
    /// A queued command of block `block`, taking `intervals`, with the motors at `motors` and the pen as `pen_down`
    /// after it (not yet marked as its block's last).
    fn queued(line: String, block: usize, intervals: u64, motors: [i64; 2], pen_down: bool) -> EbbCommand {
        EbbCommand { line, block, intervals, motors, queued: true, pen_down, ends_block: false }
    }
}

/// The program of a plan.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Program {
    /// In order.
    pub commands: Vec<EbbCommand>,
    /// Board time of the whole program, intervals.
    pub intervals: u64,
    /// Moves (blocks) shorter than the profile's `min_move_ms` that could not be joined.
    pub short_moves: usize,
}

impl Program {
    /// Board time, seconds.
    pub fn seconds(&self) -> f64 {
        self.intervals as f64 * f64::from(INTERVAL_US) / 1e6
    }
}

/// One constant-acceleration piece of a block, per motor.
#[derive(Debug, Clone, Copy)]
struct Phase {
    steps: [i64; 2],
    intervals: u64,
    r0: [f64; 2],
    r1: [f64; 2],
}

/// The trapezoid of a block as the stepper's [`plotter_fw::step_block::Profile`] builds it: `(events, start rate,
/// end rate, seconds)` per phase, in f64.
fn trapezoid(b: &StepBlock) -> Vec<(f64, f64, f64, f64)> {
    let n = f64::from(b.events());
    let max = f64::from(plotter_fw::step_block::MAX_RATE);
    let vc = f64::from(b.cruise_rate).clamp(1.0, max);
    let v0 = f64::from(b.entry_rate).min(max).min(vc);
    let v1 = f64::from(b.exit_rate).min(max).min(vc);
    if b.accel == 0 || n == 0.0 {
        return vec![(n, vc, vc, n / vc)];
    }
    let a = f64::from(b.accel);
    let xa_full = (vc * vc - v0 * v0) / (2.0 * a);
    let xd_full = (vc * vc - v1 * v1) / (2.0 * a);
    let (vp, xa, xd, v1) = if xa_full + xd_full <= n {
        (vc, xa_full, n - xd_full, v1)
    } else {
        let peak_sq = (2.0 * a * n + v0 * v0 + v1 * v1) / 2.0;
        if peak_sq <= v0 * v0 {
            (v0, 0.0, 0.0, (v0 * v0 - 2.0 * a * n).max(0.0).sqrt())
        } else if peak_sq <= v1 * v1 {
            let v1 = (v0 * v0 + 2.0 * a * n).sqrt();
            (v1, n, n, v1)
        } else {
            let xa = (peak_sq - v0 * v0) / (2.0 * a);
            (peak_sq.sqrt(), xa, xa, v1)
        }
    };
    let mut out = Vec::with_capacity(3);
    if xa > 1e-9 {
        out.push((xa, v0, vp, (vp - v0) / a));
    }
    if xd - xa > 1e-9 {
        out.push((xd - xa, vp, vp, (xd - xa) / vp));
    }
    if n - xd > 1e-9 {
        out.push((n - xd, vp, v1, (vp - v1) / a));
    }
    out
}

/// Round a non-negative interval count held in f64.
fn intervals_at(us: f64) -> u64 {
    // Times are non-negative and far below 2^53 µs.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let i = (us / f64::from(INTERVAL_US)).round().max(0.0) as u64;
    i
}

fn round_i64(x: f64) -> i64 {
    // Step counts of one block, far inside i64.
    #[allow(clippy::cast_possible_truncation)]
    let r = x.round() as i64;
    r
}

/// The `LM` line of a phase and its exact board time.
// The two motors' arrays are indexed in parallel.
#[allow(clippy::needless_range_loop)]
fn lm_line(block: usize, p: &Phase) -> Result<(String, u64), ProgramError> {
    let t = u32::try_from(p.intervals).map_err(|_| ProgramError::Unfittable {
        block,
        steps: p.steps,
        intervals: p.intervals,
    })?;
    let mut parts = [(0i32, 0i64, 0i32); 2];
    let mut end = 0u64;
    for m in 0..2 {
        let s = u32::try_from(p.steps[m].unsigned_abs()).unwrap_or(u32::MAX);
        let fitted = fit_axis(s, t, p.r0[m], p.r1[m]).or_else(|| {
            // A constant rate that ends no later than t (enough for the motor that does not set the time).
            let r = (u64::from(s) * ONE_STEP).div_ceil(u64::from(t.max(1)));
            i32::try_from(r).ok().filter(|_| s > 0).map(|r| (r, 0))
        });
        let (rate, accel) = fitted.ok_or(ProgramError::Unfittable { block, steps: p.steps, intervals: p.intervals })?;
        let last = last_step_interval(rate, s, accel, u64::from(t)).ok_or(ProgramError::Unfittable {
            block,
            steps: p.steps,
            intervals: p.intervals,
        })?;
        end = end.max(last);
        parts[m] = (rate, p.steps[m], accel);
    }
    if end != p.intervals && p.steps != [0, 0] {
        return Err(ProgramError::Unfittable { block, steps: p.steps, intervals: p.intervals });
    }
    let [(r1, s1, a1), (r2, s2, a2)] = parts;
    Ok((format!("LM,{r1},{s1},{a1},{r2},{s2},{a2},3"), end.max(1)))
}

/// A phase as constant-rate `SM` slices `(milliseconds, motor steps)`: one for a cruise, up to eight of at least
/// two shortest moves each for a ramp, each ending where the constant acceleration has carried the motors by then
/// (steps rounded once, cumulatively). Whole milliseconds, never faster than 25 steps per millisecond; the next
/// block's boundary absorbs the rounding.
fn sm_slices(p: &Phase, min_t: u64) -> Vec<(u32, [i64; 2])> {
    let m = usize::from(p.steps[1].abs() > p.steps[0].abs());
    let (r0, r1) = (p.r0[m], p.r1[m]);
    let ramp = (r1 - r0).abs() > 1e-6 * (r0 + r1).abs().max(1.0);
    let k = if ramp { (p.intervals / (2 * min_t)).clamp(1, 8) } else { 1 };
    let t = p.intervals.max(1) as f64;
    let frac = |u: f64| if r0 + r1 > 0.0 { (r0 * u + (r1 - r0) * u * u / 2.0) / ((r0 + r1) / 2.0) } else { u };
    let mut out = Vec::new();
    let (mut prev_b, mut prev) = (0u64, [0i64; 2]);
    for j in 1..=k {
        // Interval boundary of slice j (the last one exactly at the phase's end).
        let b = p.intervals * j / k;
        let f = if j == k { 1.0 } else { frac(b as f64 / t) };
        let cum: [i64; 2] =
            core::array::from_fn(|i| if j == k { p.steps[i] } else { round_i64(f * p.steps[i] as f64) });
        let st = [cum[0] - prev[0], cum[1] - prev[1]];
        let fastest = st[0].unsigned_abs().max(st[1].unsigned_abs());
        let ms = ((b - prev_b + 12) / 25).max(fastest.div_ceil(25)).max(1);
        out.push((u32::try_from(ms).unwrap_or(u32::MAX), st));
        (prev_b, prev) = (b, cum);
    }
    out
}

/// The intervals an `SM` of `ms` milliseconds and these motor steps takes on the board (its f32 rate arithmetic).
pub fn sm_intervals(ms: u32, steps: [i64; 2]) -> u64 {
    if steps == [0, 0] {
        return 25 * u64::from(ms.min(100_000)).max(1);
    }
    let per = 85_899_345.92_f32 / ms.max(1) as f32;
    let mut end = 1;
    for s in steps {
        let s = s.unsigned_abs();
        if s == 0 {
            continue;
        }
        // The board's own conversion: float product truncated to an integer rate.
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss, clippy::cast_precision_loss)]
        let rate = ((s as f32) * per) as u64;
        end = end.max((s * ONE_STEP).div_ceil(rate.clamp(1, ONE_STEP)));
    }
    end
}

/// Write `plan` as EBB commands, starting with the motors at `motors` and `SC,5` at the profile's pen-down
/// position.
pub fn program(
    profile: &MachineProfile,
    plan: &MotionPlan,
    motors: [i64; 2],
    style: MotionStyle,
) -> Result<Program, ProgramError> {
    let pen = PenSetup::of(profile)?;
    let e = profile.ebb.ok_or(ProgramError::NoEbbSection)?;
    let min_t = intervals_at(e.min_move_ms * 1000.0).max(1);
    let mut out = Vec::with_capacity(plan.blocks.len() * 2);
    let mut pos = motors;
    let mut h = 0u64; // board time so far, intervals
    let mut t_us = 0u64; // plan time so far, µs
    let mut down_position = pen.down_position;
    let mut pen_down = false;
    let mut short_moves = 0;
    for (bi, pb) in plan.blocks.iter().enumerate() {
        let b = &pb.block;
        let dur = u64::from(b.duration_ticks());
        let start_h = h;
        let first = out.len();
        match pb.kind {
            MoveKind::Travel | MoveKind::Draw if !b.is_dwell() => {
                let n = f64::from(b.events());
                let dm = mix(i64::from(b.steps[0]), i64::from(b.steps[1]));
                let pieces = trapezoid(b);
                let total_s: f64 = pieces.iter().map(|p| p.3).sum();
                let scale = if total_s > 0.0 { dur as f64 / (total_s * 1e6) } else { 0.0 };
                let mut phases: Vec<Phase> = Vec::with_capacity(3);
                let (mut e_cum, mut t_cum) = (0.0, t_us as f64);
                let mut prev_steps = [0i64; 2];
                let mut prev_h = h;
                for (k, &(de, va, vb, secs)) in pieces.iter().enumerate() {
                    e_cum += de;
                    t_cum += secs * 1e6 * scale;
                    let last = k + 1 == pieces.len();
                    let end_h = if last { intervals_at((t_us + dur) as f64) } else { intervals_at(t_cum) };
                    let cum: [i64; 2] =
                        core::array::from_fn(|m| if last { dm[m] } else { round_i64(e_cum / n * dm[m] as f64) });
                    let mut r0 = [0.0; 2];
                    let mut r1 = [0.0; 2];
                    for m in 0..2 {
                        let share = dm[m].unsigned_abs() as f64 / n;
                        let peak = va.max(vb) * share;
                        if peak > kinematics::MAX_STEP_RATE * 1.000_001 {
                            return Err(ProgramError::TooFast {
                                block: bi,
                                motor: if m == 0 { 1 } else { 2 },
                                rate: peak,
                            });
                        }
                        r0[m] = rate_units(va * share);
                        r1[m] = rate_units(vb * share);
                    }
                    phases.push(Phase {
                        steps: [cum[0] - prev_steps[0], cum[1] - prev_steps[1]],
                        intervals: end_h.saturating_sub(prev_h),
                        r0,
                        r1,
                    });
                    prev_steps = cum;
                    prev_h = end_h.max(prev_h);
                }
                // Join phases the board cannot sustain (or that round to nothing) with a neighbour.
                while phases.len() > 1 {
                    let Some(i) = phases.iter().position(|p| p.intervals < min_t) else { break };
                    let j = if i + 1 < phases.len() { i + 1 } else { i - 1 };
                    let (a, b) = (i.min(j), i.max(j));
                    let merged = Phase {
                        steps: [phases[a].steps[0] + phases[b].steps[0], phases[a].steps[1] + phases[b].steps[1]],
                        intervals: phases[a].intervals + phases[b].intervals,
                        r0: phases[a].r0,
                        r1: phases[b].r1,
                    };
                    phases[a] = merged;
                    phases.remove(b);
                }
                if phases.iter().map(|p| p.intervals).sum::<u64>() < min_t {
                    short_moves += 1;
                }
                for p in &mut phases {
                    // An LM rate is below 2^31 (one step per interval): s steps take at least s + 1 intervals.
                    let need = p.steps[0].unsigned_abs().max(p.steps[1].unsigned_abs());
                    if need > 0 {
                        p.intervals = p.intervals.max(need + 1);
                    }
                }
                for p in &phases {
                    let pieces = match style {
                        MotionStyle::Lm => {
                            let (line, t) = lm_line(bi, p)?;
                            vec![(line, t, p.steps)]
                        }
                        MotionStyle::Sm => sm_slices(p, min_t)
                            .into_iter()
                            .map(|(ms, st)| (format!("SM,{ms},{},{}", st[0], st[1]), sm_intervals(ms, st), st))
                            .collect(),
                    };
                    for (line, t, st) in pieces {
                        pos = [pos[0] + st[0], pos[1] + st[1]];
                        h += t;
                        out.push(EbbCommand::queued(line, bi, t, pos, pen_down));
                    }
                }
            }
            MoveKind::PenUp | MoveKind::PenDown if b.servo.is_some() => {
                // Whole milliseconds (25 intervals each), rounded to the plan's running time.
                let target = intervals_at((t_us + dur) as f64);
                let ms = ((target.saturating_sub(h) + 12) / 25).min(65_535);
                let up = pb.kind == MoveKind::PenUp;
                if !up {
                    let p = pen.position(b.servo.unwrap_or(0));
                    if p != down_position {
                        out.push(EbbCommand {
                            queued: false,
                            ..EbbCommand::queued(format!("SC,5,{p}"), bi, 0, pos, pen_down)
                        });
                        down_position = p;
                    }
                }
                pen_down = !up;
                let t = (25 * ms).max(1);
                h += t;
                out.push(EbbCommand::queued(format!("SP,{},{ms},{}", u8::from(up), pen.pin), bi, t, pos, pen_down));
            }
            MoveKind::PenUp | MoveKind::PenDown => return Err(ProgramError::NotServo { block: bi }),
            _ => {
                // A dwell: SM with no steps, whole milliseconds.
                let target = intervals_at((t_us + dur) as f64);
                let ms = u32::try_from((target.saturating_sub(h) + 12) / 25).unwrap_or(100_000).clamp(1, 100_000);
                let t = sm_intervals(ms, [0, 0]);
                h += t;
                out.push(EbbCommand::queued(format!("SM,{ms},0,0"), bi, t, pos, pen_down));
            }
        }
        t_us += dur;
        if out.len() == first {
            // A block with nothing to send (a zero move): keep the accounting with a 1 ms pause.
            h += 25;
            out.push(EbbCommand::queued("SM,1,0,0".into(), bi, 25, pos, pen_down));
        }
        if let Some(last) = out.last_mut() {
            last.ends_block = true;
        }
        debug_assert!(h >= start_h);
    }
    Ok(Program { commands: out, intervals: h, short_moves })
}

#[cfg(test)]
mod tests {
    use super::*;
    use plotter_path::geometry::steps::drawing_to_steps;
    use plotter_path::kurbo::Point;
    use plotter_path::motion::plan::{Lookahead, plan as make_plan};
    use plotter_path::{Drawing, Polyline};

    pub(crate) fn axidraw() -> MachineProfile {
        MachineProfile::from_toml(include_str!("../../../../samples/axidraw-v3.toml"), "axidraw-v3.toml").unwrap()
    }

    #[test]
    fn a_square_becomes_lm_moves_ending_where_the_plan_ends_in_its_time() {
        let profile = axidraw();
        let sq = Polyline::new(vec![
            Point::new(20.0, 20.0),
            Point::new(60.0, 20.0),
            Point::new(60.0, 60.0),
            Point::new(20.0, 60.0),
            Point::new(20.0, 20.0),
        ]);
        let steps = drawing_to_steps(&profile, &Drawing::single_layer("s", vec![sq])).unwrap();
        let plan = make_plan(&profile, &steps, [0; 4], Lookahead::Whole).unwrap();
        let prog = program(&profile, &plan, [0, 0], MotionStyle::Lm).unwrap();
        // The board's time is the plan's to within one 40 µs interval.
        let plan_us = plan.total_ticks;
        let board_us = prog.intervals * u64::from(INTERVAL_US);
        assert!(plan_us.abs_diff(board_us) <= 20, "{plan_us} µs planned, {board_us} µs on the board");
        // The last command leaves the motors at the plan's end: (20, 20) mm = 1600 steps on X and Y, so motor 1
        // (X+Y) at 3200 and motor 2 (X−Y) at 0.
        assert_eq!(prog.commands.last().unwrap().motors, [3200, 0]);
        // The 40 mm pen-down edges accelerate, cruise and decelerate: three LMs each; pen moves are SP commands.
        // The drop is commanded during the travel to the square (the pen hop overlaps it), so the rest of the
        // settle after arriving is the one dwell, an SM with no steps on the Settle block.
        for c in &prog.commands {
            let kind = plan.blocks[c.block].kind;
            match kind {
                MoveKind::Travel | MoveKind::Draw => assert!(c.line.starts_with("LM,"), "{kind:?}: {}", c.line),
                MoveKind::PenUp | MoveKind::PenDown => assert!(c.line.starts_with("SP,"), "{kind:?}: {}", c.line),
                MoveKind::Settle => assert!(c.line.starts_with("SM,") && c.line.ends_with(",0,0"), "{}", c.line),
            }
        }
        assert_eq!(prog.commands.iter().filter(|c| plan.blocks[c.block].kind == MoveKind::Draw).count(), 12);
        assert_eq!(prog.commands.iter().filter(|c| c.line.starts_with("SP,0,")).count(), 1);
        assert_eq!(prog.short_moves, 0);
    }

    #[test]
    fn every_command_takes_on_the_emulator_the_time_the_program_says() {
        use crate::link::ebb::emulator::EbbEmulator;
        use crate::link::ebb::messages::EbbVersion;
        let profile = axidraw();
        let circle: Vec<Point> = (0..=60)
            .map(|i| {
                let a = f64::from(i) * std::f64::consts::TAU / 60.0;
                Point::new(80.0 + 25.0 * a.cos(), 80.0 + 25.0 * a.sin())
            })
            .collect();
        let steps = drawing_to_steps(&profile, &Drawing::single_layer("c", vec![Polyline::new(circle)])).unwrap();
        let plan = make_plan(&profile, &steps, [0; 4], Lookahead::Whole).unwrap();
        let prog = program(&profile, &plan, [0, 0], MotionStyle::Lm).unwrap();
        let mut e = EbbEmulator::new(EbbVersion(3, 0, 2));
        let mut worst: f64 = 0.0;
        for c in &prog.commands {
            let (before, from, steps0) = (e.busy_intervals(), e.position(), e.trace().len());
            e.feed(format!("{}\r", c.line).as_bytes());
            while !e.is_idle() {
                e.run_for(1);
            }
            e.run_for(1);
            assert_eq!(e.busy_intervals() - before, c.intervals, "{}", c.line);
            assert_eq!(e.position(), c.motors, "{}", c.line);
            // The two motors keep to the straight line of their move: every step within 1.5 motor steps of it.
            let d = [(c.motors[0] - from[0]) as f64, (c.motors[1] - from[1]) as f64];
            let len = d[0].hypot(d[1]);
            if len > 0.0 {
                for st in &e.trace()[steps0..] {
                    let q = [(st.motors[0] - from[0]) as f64, (st.motors[1] - from[1]) as f64];
                    worst = worst.max((q[0] * d[1] - q[1] * d[0]).abs() / len);
                }
            }
        }
        assert!(worst <= 1.5, "a step {worst:.2} motor steps off its move's line");
    }

    #[test]
    fn the_pen_drop_is_commanded_between_two_lms_at_speed() {
        use crate::link::ebb::emulator::EbbEmulator;
        use crate::link::ebb::messages::EbbVersion;
        let text = include_str!("../../../../samples/axidraw-saxi.toml");
        let profile = MachineProfile::from_toml(text, "axidraw-saxi.toml").unwrap();
        let l = Polyline::new(vec![Point::new(20.0, 20.0), Point::new(30.0, 20.0), Point::new(30.0, 30.0)]);
        let steps = drawing_to_steps(&profile, &Drawing::single_layer("l", vec![l])).unwrap();
        let plan = make_plan(&profile, &steps, [0; 4], Lookahead::Whole).unwrap();
        let prog = program(&profile, &plan, [0, 0], MotionStyle::Lm).unwrap();
        let drop = prog.commands.iter().position(|c| c.line.starts_with("SP,0,")).unwrap();
        assert_eq!(prog.commands[drop].line, "SP,0,0,1", "commanded with no delay");
        // The LM before it ends moving: its start rate plus its acceleration over its intervals is well above
        // zero (motor 1 carries the whole 45° travel; the drop is commanded 21–23 ms before the carriage stops,
        // the earliest the tip may touch, when it still moves at about 400 mm/s² × 22 ms = 8.8 mm/s, some 1000
        // motor steps/s).
        let before: Vec<i64> = prog.commands[drop - 1].line.split(',').skip(1).map(|x| x.parse().unwrap()).collect();
        let end_rate = (before[0] + before[2] * i64::try_from(prog.commands[drop - 1].intervals).unwrap()) as f64;
        let steps_s = end_rate / 2f64.powi(31) * 25_000.0;
        assert!(steps_s > 800.0, "{steps_s} steps/s at the drop: {:?}", &prog.commands[drop - 1]);
        // On the emulator, from the first move to the first pen-down move: the 20·√2 mm travel from rest to rest at
        // 400 mm/s² (2·√(d/a)), less its last 21–23 ms after the drop command, and the 49 ms from the command to
        // the latest the tip touches (2 servo cycles of 24 ms from the top to 0.7 of the way down, and a 1 ms
        // margin), to within the 40 µs intervals.
        let mut e = EbbEmulator::new(EbbVersion(3, 0, 2));
        let first_draw = prog.commands.iter().position(|c| plan.blocks[c.block].kind == MoveKind::Draw).unwrap();
        let mut at = [0u64; 2];
        for (k, c) in prog.commands.iter().enumerate() {
            if k == 1 || k == first_draw {
                at[usize::from(k == first_draw)] = e.busy_intervals();
            }
            e.feed(format!("{}\r", c.line).as_bytes());
            while !e.is_idle() {
                e.run_for(1);
            }
            e.run_for(1);
        }
        let hop_s = (at[1] - at[0]) as f64 * 40e-6;
        let by_hand = 2.0 * (20.0 * std::f64::consts::SQRT_2 / 400.0f64).sqrt() + 0.049 - 0.023;
        assert!(hop_s >= by_hand - 0.001 && hop_s <= by_hand + 0.004, "{hop_s} s, by hand {by_hand} s");
        assert!(prog.intervals.abs_diff(e.busy_intervals()) <= prog.commands.len() as u64);
    }

    #[test]
    fn sm_slices_follow_the_ramp_and_keep_every_step() {
        // 1000 steps accelerating from rest over 2 s (50 000 intervals), slices of at least 2 × 4 ms: eight
        // slices of 250 ms, covering (j/8)² of the distance by the end of slice j.
        let p = Phase { steps: [1000, -500], intervals: 50_000, r0: [0.0; 2], r1: [1e9, 5e8] };
        let s = sm_slices(&p, 100);
        assert_eq!(s.len(), 8);
        assert!(s.iter().all(|(ms, _)| *ms == 250));
        let firsts: Vec<i64> = s.iter().map(|(_, st)| st[0]).collect();
        assert_eq!(firsts, [16, 47, 78, 109, 141, 172, 203, 234], "(j/8)² × 1000, rounded cumulatively");
        assert_eq!(s.iter().map(|(_, st)| st[1]).sum::<i64>(), -500);
        // A cruise is one slice.
        let c = Phase { steps: [40, 40], intervals: 1000, r0: [1e8; 2], r1: [1e8; 2] };
        assert_eq!(sm_slices(&c, 100), [(40, [40, 40])]);
    }

    #[test]
    fn the_ebb_samples_parse_with_their_machines_figures() {
        let load = |name: &str, text: &str| MachineProfile::from_toml(text, name).unwrap();
        let samples = [
            load("axidraw-v3.toml", include_str!("../../../../samples/axidraw-v3.toml")),
            load("axidraw-se-a3.toml", include_str!("../../../../samples/axidraw-se-a3.toml")),
            load("nextdraw.toml", include_str!("../../../../samples/nextdraw.toml")),
            load("idraw-h.toml", include_str!("../../../../samples/idraw-h.toml")),
        ];
        let figures: Vec<(f64, f64, u8, u16)> = samples
            .iter()
            .map(|p| {
                let e = p.ebb.unwrap();
                (p.axes.x.travel_mm, p.axes.y.travel_mm, e.pen_pin, e.pen_up_position)
            })
            .collect();
        assert_eq!(
            figures,
            [(300.0, 218.0, 1, 20_641), (430.0, 297.0, 1, 20_641), (300.0, 218.0, 2, 9_720), (420.0, 297.0, 1, 20_641)]
        );
        for p in &samples {
            // 2032 steps per inch; no diagonal asks a motor for more than 25 000 steps/s.
            assert_eq!((p.axes.x.steps_per_mm, p.axes.y.steps_per_mm), (80.0, 80.0));
            assert!(80.0 * (p.axes.x.max_feed_mm_s + p.axes.y.max_feed_mm_s) <= 25_000.0);
        }
        // saxi's limits (its defaultPlanOptions) along the path: 50 mm/s at 200 mm/s² drawing, 200 mm/s at
        // 400 mm/s² travelling, 0.12 s per pen move; at 200 mm/s in any direction a motor steps at most
        // 80 × 200 × √2 ≈ 22 627 steps/s.
        let saxi = load("axidraw-saxi.toml", include_str!("../../../../samples/axidraw-saxi.toml"));
        let pen = &saxi.pen;
        assert_eq!((pen.draw_feed_mm_s, pen.draw_accel_mm_s2), (50.0, Some(200.0)));
        assert_eq!((pen.travel_feed_mm_s, pen.travel_accel_mm_s2), (200.0, Some(400.0)));
        assert_eq!((pen.settle_ms, saxi.motion.junction_deviation_mm), (120.0, 0.127));
        assert!(80.0 * pen.travel_feed_mm_s * std::f64::consts::SQRT_2 <= 25_000.0);
        assert!(saxi.axes.x.max_accel_mm_s2.min(saxi.axes.y.max_accel_mm_s2) >= 400.0, "the caps bind, not the axes");
        // An EBB lifts its pen with the servo: a Z pen is refused with the field named.
        let z = include_str!("../../../../samples/axidraw-v3.toml").replace("command = \"servo\"", "command = \"z\"");
        let e = MachineProfile::from_toml(&z, "z.toml").unwrap_err().to_string();
        assert!(e.contains("pen.command") && e.contains("servo"), "{e}");
    }

    #[test]
    fn pen_positions_interpolate_between_the_profile_angles() {
        let pen = PenSetup { up_position: 20_000, down_position: 10_000, up_deg: 90.0, down_deg: 30.0, pin: 1 };
        assert_eq!(pen.position(300), 10_000);
        assert_eq!(pen.position(900), 20_000);
        assert_eq!(pen.position(250), 9_167, "5° beyond down: 1/12 of the span further");
    }

    #[test]
    fn sm_times_follow_the_boards_rate_arithmetic() {
        // 1000 steps in 1000 ms: the f32 product 1000 × 85 899.34 truncates to 85 899 343 (just under one step per
        // 25 intervals), so the last step lands on interval 25 001; 4 steps in 1 ms: 4 × 85 899 344 (the f32 of
        // 85 899 345.92) = 343 597 376, just under 4·2^31/25, so 26 intervals.
        assert_eq!(sm_intervals(1000, [1000, 0]), 25_001);
        assert_eq!(sm_intervals(1, [4, -4]), 26);
        assert_eq!(sm_intervals(10, [0, 0]), 250);
    }
}
