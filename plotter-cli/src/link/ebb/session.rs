//! A session with an EiBotBoard: connect (`V` for the version, firmware 3's FIFO deepened with `CU,4` after
//! `QU,2`), set up the pen servo (`SC,4/5/11/12`, `SR`), home, position (`QS`), and stream a plan's program with
//! the board's own flow control.
//!
//! # Flow control
//! The board answers a queued command only once it has a FIFO slot: while the FIFO is full, the command waits in
//! its parser unanswered. So the host sends one command, waits for its `OK`, sends the next; the board's queue
//! stays full and never starves as long as each move lasts longer than the command takes to cross and parse
//! (the program joins moves shorter than the profile's `min_move_ms`).
//!
//! # Progress
//! When queued command `q` is answered it is the newest of the at most `F` commands in the FIFO, behind the one
//! executing: every queued command before `q − F` has finished. At the end, `QG` is polled until motion has
//! stopped (bits 0..=3 clear).
//!
//! # Coordinates
//! The EBB has no endstops: its step counters are zero where the motors were enabled (`EM`) or cleared (`CS`).
//! Homing enables the motors where the carriage stands (the user has put it in the home corner) — or, when they
//! are enabled already, returns there with `HM` — so motor position (0, 0) is the profile's homed position, and
//! a position read with `QS` maps back to the plot's steps (`x = (m1 + m2)/2`, `y = (m1 − m2)/2`).
//!
//! # Stopping
//! There is no feed hold: a pause asked for "now" (Ctrl-C) stops with `ES` (which flushes the queue) and raises
//! the pen at once; to continue, the carriage returns with `HM` to the start of the interrupted move, the pen is
//! lowered again if it was down, and the program continues from that move. A pause at the next pen-up just stops
//! sending there and waits for the queue to drain.

use std::time::Duration;

use anyhow::{Context as _, bail};
use plotter_path::MachineProfile;
use plotter_path::motion::plan::{MachinePos, MotionPlan, homed_position};

use super::kinematics::{INTERVAL_US, mix, unmix};
use super::messages::{EbbLine, EbbVersion, GeneralStatus, describe_error};
use super::program::{MotionStyle, Program, ProgramError, program};
use crate::link::Transport;
use crate::link::stream::{Control, PauseChoice, Progress, StreamError, StreamStats};

/// How long a plain command may take to be answered (a queued one waits for its FIFO slot on top of this).
pub const COMMAND_TIMEOUT: Duration = Duration::from_secs(3);

/// The FIFO depth asked for on firmware 3 (the host keeps about a second of short moves queued).
const FIFO_WANTED: usize = 16;

/// Step rate of `HM` returns, steps/s (about 60 mm/s at 80 steps/mm).
const HM_RATE: u32 = 5_000;

/// What a command's answer ends with.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Expect {
    /// `OK`.
    Ok,
    /// One data line.
    Line,
    /// A data line, then `OK`.
    LineOk,
}

/// An open session with an EBB.
pub struct EbbSession<T: Transport> {
    /// The byte pipe.
    pub transport: T,
    /// Where it is connected.
    pub name: String,
    /// Firmware version.
    pub version: EbbVersion,
    /// FIFO depth in use.
    pub fifo: usize,
    /// The machine profile.
    pub profile: MachineProfile,
    /// How moves are sent.
    pub style: MotionStyle,
    /// Moves streamed in this session that are shorter than the board sustains.
    pub short_moves: usize,
    /// Board time of the programs streamed in this session, seconds.
    pub program_seconds: f64,
}

fn lost(name: &str, e: std::io::Error) -> anyhow::Error {
    crate::Error::lost(name, &e, "was the board unplugged or the emulator stopped?").into()
}

impl<T: Transport> EbbSession<T> {
    /// Connect: ask `V` (three times, for a board still booting), leave future syntax if another host left it on,
    /// deepen the FIFO on firmware 3, and set up the pen servo from the profile's `[ebb]` section.
    pub fn connect(mut transport: T, name: &str, profile: &MachineProfile) -> anyhow::Result<Self> {
        let pen = profile.ebb.ok_or(ProgramError::NoEbbSection)?;
        let mut heard = Vec::new();
        while let Some(l) = transport.recv_line(Duration::from_millis(100)).map_err(|e| lost(name, e))? {
            if heard.len() < 5 && !l.trim().is_empty() {
                heard.push(l);
            }
        }
        let mut version = None;
        let mut future = false;
        for _ in 0..3 {
            transport.send(b"V\r").map_err(|e| lost(name, e))?;
            while let Some(l) = transport.recv_line(Duration::from_millis(500)).map_err(|e| lost(name, e))? {
                if let Some(v) = EbbVersion::parse(&l) {
                    future = l.starts_with("V,");
                    version = Some(v);
                    break;
                }
                if heard.len() < 5 && !l.trim().is_empty() {
                    heard.push(l);
                }
            }
            if version.is_some() {
                break;
            }
        }
        let Some(version) = version else {
            let shown: Vec<String> = heard.iter().take(3).map(|l| format!("{l:?}")).collect();
            bail!("{name} does not answer like an EiBotBoard (no version to V); it sent: {}", shown.join(", "));
        };
        let style = if version.has_lm() { MotionStyle::Lm } else { MotionStyle::Sm };
        let mut s = EbbSession {
            transport,
            name: name.to_string(),
            version,
            fifo: 1,
            profile: profile.clone(),
            style,
            short_moves: 0,
            program_seconds: 0.0,
        };
        if future {
            // Left in future syntax by another program: back to the default replies (answered `CUOK`).
            s.transport.send(b"CU,10,0\r").map_err(|e| lost(name, e))?;
            let _ = s.transport.recv_line(COMMAND_TIMEOUT).map_err(|e| lost(name, e))?;
        }
        if version.has_deep_fifo() {
            let max = s.exchange("QU,2", Expect::LineOk, COMMAND_TIMEOUT)?;
            let max: usize = max.trim_start_matches("QU,").trim().parse().unwrap_or(1);
            let want = max.clamp(1, FIFO_WANTED);
            if want > 1 {
                // Waits for the queue to drain, so give it time.
                s.exchange(&format!("CU,4,{want}"), Expect::Ok, Duration::from_secs(120))?;
                s.fifo = want;
            }
        }
        for cmd in [
            format!("SC,4,{}", pen.pen_up_position),
            format!("SC,5,{}", pen.pen_down_position),
            format!("SC,11,{}", pen.pen_rate_up),
            format!("SC,12,{}", pen.pen_rate_down),
            format!("SR,{}", pen.servo_timeout_ms),
        ] {
            s.exchange(&cmd, Expect::Ok, COMMAND_TIMEOUT)?;
        }
        Ok(s)
    }

    /// Send `cmd` and read its answer; an error line is an error naming its meaning.
    fn exchange(&mut self, cmd: &str, expect: Expect, timeout: Duration) -> anyhow::Result<String> {
        self.transport.send(format!("{cmd}\r").as_bytes()).map_err(|e| lost(&self.name, e))?;
        self.answer(cmd, expect, timeout)
    }

    fn answer(&mut self, cmd: &str, expect: Expect, timeout: Duration) -> anyhow::Result<String> {
        self.read_answer(cmd, expect, timeout)?
            .map_err(|(code, text)| anyhow::anyhow!("{}: {cmd:?} refused: {}", self.name, describe_error(code, &text)))
    }

    /// The answer to `cmd`: its data, or the board's refusal `(error number, text)`; the link failing or staying
    /// silent past `timeout` is the outer error.
    fn read_answer(
        &mut self,
        cmd: &str,
        expect: Expect,
        timeout: Duration,
    ) -> anyhow::Result<Result<String, (u8, String)>> {
        let deadline = self.transport.now() + timeout;
        let mut data = None;
        loop {
            let left = deadline.saturating_sub(self.transport.now()).max(Duration::from_millis(1));
            let Some(l) = self.transport.recv_line(left).map_err(|e| lost(&self.name, e))? else {
                if self.transport.now() >= deadline {
                    bail!("{}: no answer to {cmd:?} within {:.1} s", self.name, timeout.as_secs_f64());
                }
                continue;
            };
            if l.trim().is_empty() {
                continue;
            }
            match EbbLine::parse(&l) {
                EbbLine::Error { code, text } => return Ok(Err((code, text))),
                EbbLine::Ok if expect == Expect::Line => {}
                EbbLine::Ok => return Ok(Ok(data.unwrap_or_default())),
                EbbLine::Data(d) => {
                    if expect == Expect::Line {
                        return Ok(Ok(d));
                    }
                    data = Some(d);
                }
            }
        }
    }

    /// Send a console line and return the board's answer lines (until `OK`, an error, or a quiet 0.3 s).
    pub fn console(&mut self, line: &str) -> anyhow::Result<Vec<String>> {
        self.transport.send(format!("{line}\r").as_bytes()).map_err(|e| lost(&self.name, e))?;
        let mut out = Vec::new();
        while let Some(l) = self.transport.recv_line(Duration::from_millis(300)).map_err(|e| lost(&self.name, e))? {
            let done = matches!(EbbLine::parse(&l), EbbLine::Ok | EbbLine::Error { .. });
            out.push(match EbbLine::parse(&l) {
                EbbLine::Error { code, text } => describe_error(code, &text),
                _ => l,
            });
            if done {
                break;
            }
        }
        Ok(out)
    }

    /// Send one command answered by `OK` (queued ones may wait for a FIFO slot up to `timeout`).
    pub fn command(&mut self, cmd: &str, timeout: Duration) -> anyhow::Result<()> {
        self.exchange(cmd, Expect::Ok, timeout).map(|_| ())
    }

    /// The `QG` status.
    pub fn general(&mut self) -> anyhow::Result<GeneralStatus> {
        if !self.version.has_qg() {
            // QM: CommandStatus,Motor1,Motor2,FIFO → the same four bits.
            let l = self.exchange("QM", Expect::Line, COMMAND_TIMEOUT)?;
            let v: Vec<u8> = l.split(',').skip(1).filter_map(|x| x.trim().parse().ok()).collect();
            let bits = v.iter().take(4).fold(0u8, |b, x| (b << 1) | u8::from(*x != 0));
            return Ok(GeneralStatus(bits));
        }
        let l = self.exchange("QG", Expect::Line, COMMAND_TIMEOUT)?;
        GeneralStatus::parse(&l).with_context(|| format!("{}: unreadable QG answer {l:?}", self.name))
    }

    /// Wait until every queued command has run (`QG` polled every 20 ms); `limit` bounds the wait.
    pub fn drain(&mut self, limit: Duration) -> anyhow::Result<()> {
        let deadline = self.transport.now() + limit;
        loop {
            if !self.general()?.busy() {
                return Ok(());
            }
            if self.transport.now() >= deadline {
                bail!("{}: still moving after {:.0} s", self.name, limit.as_secs_f64());
            }
            let _ = self.transport.recv_line(Duration::from_millis(20)).map_err(|e| lost(&self.name, e))?;
        }
    }

    /// Motor positions (`QS`).
    pub fn motors(&mut self) -> anyhow::Result<[i64; 2]> {
        let l = self.exchange("QS", Expect::LineOk, COMMAND_TIMEOUT)?;
        let l = l.trim_start_matches("QS,");
        let v: Vec<i64> = l.split(',').filter_map(|x| x.trim().parse().ok()).collect();
        <[i64; 2]>::try_from(v).map_err(|_| anyhow::anyhow!("{}: unreadable QS answer {l:?}", self.name))
    }

    /// The plot position of motor positions. A stop between the two motors' steps of a move leaves them half an
    /// XY step apart (an odd sum): that position is rounded (towards motor 1's side); [`Self::stop_and_lift`]
    /// steps motor 2 once to make it whole again.
    fn xy_of(&self, m: [i64; 2]) -> anyhow::Result<MachinePos> {
        let home = homed_position(&self.profile)?;
        let (x, y) = unmix(m).or_else(|| unmix([m[0], m[1] + 1])).context("unreachable: one of two sums is even")?;
        let to = |h: i32, d: i64| i32::try_from(i64::from(h) + d).context("position out of range");
        Ok([to(home[0], x)?, to(home[1], y)?, home[2], 0])
    }

    /// Motor positions of a plot position.
    fn motors_of(&self, p: &MachinePos) -> anyhow::Result<[i64; 2]> {
        let home = homed_position(&self.profile)?;
        Ok(mix(i64::from(p[0] - home[0]), i64::from(p[1] - home[1])))
    }

    /// The current position, steps of the plot's coordinates.
    pub fn position(&mut self) -> anyhow::Result<MachinePos> {
        let m = self.motors()?;
        self.xy_of(m)
    }

    /// Raise the pen, then make the current carriage position (or, with the motors enabled already, motor
    /// position 0, reached with `HM`) the home corner.
    pub fn home(&mut self) -> anyhow::Result<()> {
        let e = self.profile.ebb.context("no [ebb] section")?;
        let settle = self.profile.pen.settle_ms.round().clamp(0.0, 65_535.0);
        self.command(&format!("SP,1,{settle},{}", e.pen_pin), Duration::from_secs(120))?;
        let enabled = if self.version.has_qe() {
            let l = self.exchange("QE", Expect::LineOk, COMMAND_TIMEOUT)?;
            l.trim_start_matches("QE,").split(',').any(|x| x.trim() != "0")
        } else {
            false
        };
        if enabled {
            let at = self.motors()?;
            if at != [0, 0] {
                self.return_to(at, [0, 0])?;
            }
        } else {
            eprintln!("{}: the EBB has no endstops; the carriage is taken to stand in the home corner", self.name);
            self.command(&format!("EM,{},{}", e.step_mode, e.step_mode), Duration::from_secs(120))?;
        }
        self.drain(Duration::from_secs(600))
    }

    /// Stop now and raise the pen: `ES` flushes the queue, then the pen goes up at once (`SP,2` on firmware
    /// 3.0.1 and later, else a plain `SP,1` into the empty queue). Returns what was done, for the user.
    pub fn stop_and_lift(&mut self) -> anyhow::Result<String> {
        let e = self.profile.ebb.context("no [ebb] section")?;
        self.exchange("ES", Expect::LineOk, COMMAND_TIMEOUT)?;
        let lift = if self.version.has_immediate_pen_up() {
            format!("SP,2,0,{}", e.pen_pin)
        } else {
            format!("SP,1,0,{}", e.pen_pin)
        };
        self.command(&lift, COMMAND_TIMEOUT)?;
        self.drain(Duration::from_secs(10))?;
        // Stopped between the two motors' steps of a move: one step of motor 2 makes the position an XY one.
        let m = self.motors()?;
        if unmix(m).is_none() {
            self.command("SM,2,0,1", COMMAND_TIMEOUT)?;
            self.drain(Duration::from_secs(10))?;
        }
        Ok(format!("motion stopped (ES); the pen is up ({lift})"))
    }

    /// Stream `plan` (which starts where the machine stands). Returns when it has been executed.
    pub fn stream(&mut self, plan: &MotionPlan, control: &mut dyn Control) -> Result<StreamStats, StreamError> {
        let start = self.motors_of(&plan.start).map_err(StreamError::Link)?;
        let prog = program(&self.profile, plan, start, self.style).map_err(|e| StreamError::Link(e.into()))?;
        self.short_moves += prog.short_moves;
        self.program_seconds += prog.seconds();
        let t0 = self.transport.now();
        let result = self.send_program(&prog, plan, start, control);
        self.transport.set_streaming(false);
        let (bytes, frames) = result?;
        self.drain(Duration::from_secs(600)).map_err(StreamError::Link)?;
        let n = plan.blocks.len();
        control.progress(&Progress {
            accepted: n,
            executed: n,
            seq_after_accepted: u32::try_from(n).unwrap_or(u32::MAX),
            resends: 0,
        });
        let elapsed = self.transport.now() - t0;
        Ok(StreamStats {
            frames,
            frame_bytes: usize::try_from(bytes).unwrap_or(usize::MAX),
            bytes_sent: bytes,
            elapsed,
            accept_elapsed: elapsed,
            underruns: self.transport.underruns(),
            ..StreamStats::default()
        })
    }

    /// Blocks whose every command is among the first `done` commands.
    fn blocks_done(prog: &Program, done: usize) -> usize {
        if done == 0 {
            return 0;
        }
        let c = &prog.commands[done - 1];
        if c.ends_block { c.block + 1 } else { c.block }
    }

    fn send_program(
        &mut self,
        prog: &Program,
        plan: &MotionPlan,
        start: [i64; 2],
        control: &mut dyn Control,
    ) -> Result<(u64, usize), StreamError> {
        let cmds = &prog.commands;
        // Queued-command ordinal of each command, for the FIFO bound.
        let mut ordinal = Vec::with_capacity(cmds.len());
        let mut q = 0usize;
        for c in cmds {
            ordinal.push(q);
            q += usize::from(c.queued);
        }
        let safe: Vec<bool> = (0..cmds.len())
            .map(|i| {
                cmds[i].ends_block
                    && !cmds[i].pen_down
                    && plan
                        .blocks
                        .get(cmds[i].block + 1)
                        .is_none_or(|b| b.kind != plotter_path::motion::plan::MoveKind::Settle)
            })
            .collect();
        let (mut next, mut bytes) = (0usize, 0u64);
        let mut done_cmds = 0usize;
        let mut pause_at: Option<usize> = None;
        let mut last = None;
        self.transport.set_streaming(true);
        while next < cmds.len() {
            let progress = Progress {
                accepted: Self::blocks_done(prog, next),
                executed: Self::blocks_done(prog, done_cmds),
                seq_after_accepted: u32::try_from(Self::blocks_done(prog, next)).unwrap_or(u32::MAX),
                resends: 0,
            };
            if last != Some(progress) {
                control.progress(&progress);
                last = Some(progress);
            }
            if pause_at.is_none()
                && let Some(now) = control.pause_requested()
            {
                if now {
                    match self.stop_now(prog, start, next, &mut done_cmds, control)? {
                        Some(resume) => {
                            next = resume;
                            continue;
                        }
                        None => {
                            return Err(StreamError::Aborted { executed: Self::blocks_done(prog, done_cmds) });
                        }
                    }
                }
                pause_at = Some((next.saturating_sub(1)..cmds.len()).find(|&i| safe[i]).unwrap_or(cmds.len() - 1));
            }
            if let Some(p) = pause_at
                && next > p
            {
                self.drain(Duration::from_secs(600)).map_err(StreamError::Link)?;
                done_cmds = next;
                pause_at = None;
                control.progress(&Progress { executed: Self::blocks_done(prog, done_cmds), ..progress });
                if control.paused(false) == PauseChoice::Abort {
                    return Err(StreamError::Aborted { executed: Self::blocks_done(prog, done_cmds) });
                }
                continue;
            }
            let c = &cmds[next];
            let line = format!("{}\r", c.line);
            self.transport.send(line.as_bytes()).map_err(|e| StreamError::Link(lost(&self.name, e)))?;
            bytes += u64::try_from(line.len()).unwrap_or(u64::MAX);
            // A queued command waits for its slot: at most the FIFO's and the executing command's time.
            let ahead: u64 = cmds[done_cmds..next].iter().map(|c| c.intervals).sum();
            let wait = COMMAND_TIMEOUT + Duration::from_micros(ahead * u64::from(INTERVAL_US));
            let answer = self.read_answer(&c.line, Expect::Ok, wait);
            if !matches!(answer, Ok(Ok(_))) {
                let executed = Self::blocks_done(prog, done_cmds);
                let stopped = self.stop_and_lift();
                let after = match stopped {
                    Ok(_) => format!("the plot stopped (pen up) after {executed} executed block(s)"),
                    Err(s) => format!("the plot stopped after {executed} executed block(s); stopping failed: {s:#}"),
                };
                return Err(match answer {
                    Ok(Err((code, text))) => StreamError::Refused {
                        block: c.block,
                        code,
                        text: format!("{:?} refused: {}; {after}", c.line, describe_error(code, &text)),
                    },
                    Err(e) => StreamError::Link(anyhow::anyhow!("{e:#}; {after}")),
                    Ok(Ok(_)) => unreachable!("handled above"),
                });
            }
            if c.queued {
                // Everything queued more than a FIFO's length before this one has finished.
                let finished = ordinal[next].saturating_sub(self.fifo);
                while done_cmds < next && ordinal[done_cmds] < finished {
                    done_cmds += 1;
                }
            }
            next += 1;
        }
        Ok((bytes, cmds.len()))
    }

    /// A pause asked for now: `ES`, pen up, ask; on "continue" return to the start of the first unfinished
    /// command (with the pen as it was there) and resume from it.
    fn stop_now(
        &mut self,
        prog: &Program,
        start: [i64; 2],
        sent: usize,
        done_cmds: &mut usize,
        control: &mut dyn Control,
    ) -> Result<Option<usize>, StreamError> {
        self.stop_and_lift().map_err(StreamError::Link)?;
        let at = self.motors().map_err(StreamError::Link)?;
        let cmds = &prog.commands;
        // The first move (among those possibly unfinished) whose segment holds the position: interrupted in it (or
        // about to start it) unless the position is its end, when the plot goes on after it. Pen commands between
        // are sent again (they only set the pen).
        let before = |i: usize| if i == 0 { start } else { cmds[i - 1].motors };
        let resume = (*done_cmds..sent)
            .find_map(|i| {
                let (a, b) = (before(i), cmds[i].motors);
                if a == b {
                    None
                } else if at == b {
                    Some(i + 1)
                } else {
                    on_segment(at, a, b).then_some(i)
                }
            })
            .unwrap_or(*done_cmds);
        *done_cmds = resume;
        if control.paused(true) == PauseChoice::Abort {
            return Ok(None);
        }
        let e = self.profile.ebb.context("no [ebb] section").map_err(StreamError::Link)?;
        let target = before(resume);
        if at != target {
            self.return_to(at, target).map_err(StreamError::Link)?;
        }
        if resume > 0 && cmds[resume - 1].pen_down {
            let settle = self.profile.pen.settle_ms.round().clamp(0.0, 65_535.0);
            self.command(&format!("SP,0,{settle},{}", e.pen_pin), Duration::from_secs(120))
                .map_err(StreamError::Link)?;
        }
        self.drain(Duration::from_secs(600)).map_err(StreamError::Link)?;
        Ok(Some(resume))
    }

    /// Move the carriage (pen up) from motor position `at` to `target`: `HM` to the absolute position where the
    /// firmware has it (2.7.0 and later), else one slow `SM`.
    fn return_to(&mut self, at: [i64; 2], target: [i64; 2]) -> anyhow::Result<()> {
        if self.version.has_hm() {
            return self.command(&format!("HM,{HM_RATE},{},{}", target[0], target[1]), Duration::from_secs(120));
        }
        let d = [target[0] - at[0], target[1] - at[1]];
        let ms = (d[0].unsigned_abs().max(d[1].unsigned_abs()) * 1000).div_ceil(u64::from(HM_RATE)).max(1);
        self.command(&format!("SM,{ms},{},{}", d[0], d[1]), Duration::from_secs(120))
    }

    /// After the host lost a plot: the first block of `full` not certainly executed, from where the idle board
    /// stands: the last block end at that position from the journal's executed count on (within what the FIFO can
    /// have held past the accepted count); otherwise the journal's executed count.
    pub fn resume_point(&mut self, executed: usize, accepted: usize, full: &MotionPlan) -> anyhow::Result<usize> {
        self.drain(Duration::from_secs(600))?;
        let pos = self.position()?;
        let hi = (accepted + 3 * self.fifo + 3).min(full.blocks.len());
        let mut p = full.start;
        let mut best = None;
        for (k, b) in full.blocks.iter().enumerate().take(hi) {
            for (x, d) in p.iter_mut().zip(b.block.steps) {
                *x += d;
            }
            if k + 1 >= executed && p[..2] == pos[..2] {
                best = Some(k + 1);
            }
        }
        Ok(best.unwrap_or(executed).max(executed))
    }
}

/// Whether motor position `p` lies on the move from `a` to `b` (within two steps of the line, between its ends):
/// the two motors of a move step in proportion, each rounded on its own.
fn on_segment(p: [i64; 2], a: [i64; 2], b: [i64; 2]) -> bool {
    let d = [(b[0] - a[0]) as f64, (b[1] - a[1]) as f64];
    let q = [(p[0] - a[0]) as f64, (p[1] - a[1]) as f64];
    let len2 = d[0] * d[0] + d[1] * d[1];
    if len2 == 0.0 {
        return q == [0.0, 0.0];
    }
    let t = (d[0] * q[0] + d[1] * q[1]) / len2;
    let dist2 = (q[0] - t * d[0]).powi(2) + (q[1] - t * d[1]).powi(2);
    (0.0..=1.0).contains(&t) && dist2 <= 4.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::ebb::emulator::EbbEmulator;
    use crate::link::ebb::emulator_transport::EbbTransport;
    use crate::link::stream::tests::Record;
    use plotter_path::geometry::steps::drawing_to_steps;
    use plotter_path::kurbo::Point;
    use plotter_path::motion::plan::{Lookahead, plan as make_plan};
    use plotter_path::{Drawing, Polyline};

    fn profile() -> MachineProfile {
        MachineProfile::from_toml(include_str!("../../../../samples/axidraw-v3.toml"), "axidraw-v3.toml").unwrap()
    }

    fn session(v: EbbVersion) -> EbbSession<EbbTransport> {
        EbbSession::connect(EbbTransport::new(EbbEmulator::new(v)), "emulated EBB", &profile()).unwrap()
    }

    fn squares() -> MotionPlan {
        let p = profile();
        let sq = |x: f64| {
            Polyline::new(vec![
                Point::new(x, 20.0),
                Point::new(x + 30.0, 20.0),
                Point::new(x + 30.0, 50.0),
                Point::new(x, 50.0),
                Point::new(x, 20.0),
            ])
        };
        let steps =
            drawing_to_steps(&p, &Drawing::single_layer("s", (0..4).map(|i| sq(20.0 + 40.0 * f64::from(i))).collect()))
                .unwrap();
        make_plan(&p, &steps, homed_position(&p).unwrap(), Lookahead::Whole).unwrap()
    }

    #[test]
    fn connect_reads_the_version_and_deepens_the_fifo_on_firmware_3() {
        let s = session(EbbVersion(3, 0, 2));
        assert_eq!((s.version, s.fifo, s.style), (EbbVersion(3, 0, 2), FIFO_WANTED, MotionStyle::Lm));
        let log = s.transport.emulator().log().join(" ");
        assert!(log.contains("QU,2 CU,4,16 SC,4,20641 SC,5,15248 SC,11,1618 SC,12,1079 SR,60000"), "{log}");
        let s = session(EbbVersion(2, 8, 1));
        assert_eq!((s.fifo, s.style), (1, MotionStyle::Lm));
    }

    #[test]
    fn a_board_left_in_future_syntax_is_switched_back() {
        let mut emu = EbbEmulator::new(EbbVersion(3, 0, 2));
        emu.feed(b"CU,10,1\r");
        let _ = emu.take_output();
        let mut s = EbbSession::connect(EbbTransport::new(emu), "emulated EBB", &profile()).unwrap();
        assert_eq!(s.version, EbbVersion(3, 0, 2));
        assert_eq!(s.motors().unwrap(), [0, 0], "QS answered in the default syntax again");
        assert!(s.transport.emulator().log().iter().any(|l| l == "CU,10,0"));
    }

    #[test]
    fn a_plot_runs_in_the_planned_time_and_ends_where_planned() {
        for v in [EbbVersion(3, 0, 2), EbbVersion(2, 8, 1)] {
            let mut s = session(v);
            s.home().unwrap();
            let plan = squares();
            let busy0 = s.transport.emulator().busy_intervals();
            let mut rec = Record::default();
            let stats = s.stream(&plan, &mut rec).unwrap();
            let emu = s.transport.emulator();
            let ran = (emu.busy_intervals() - busy0) as f64 * 40e-6;
            // Board time = program time exactly; program time = plan time within one interval.
            assert!((ran - s.program_seconds).abs() < 1e-9, "{v}: ran {ran} s, program {} s", s.program_seconds);
            assert!((ran - plan.seconds()).abs() <= 40e-6, "{v}: ran {ran} s, planned {} s", plan.seconds());
            assert_eq!(stats.underruns, Some(0), "{v}: the board never starved");
            let end = plan.position_after(plan.blocks.len() - 1);
            assert_eq!(s.position().unwrap()[..2], end[..2]);
            assert!(s.transport.emulator().pen_up());
            assert_eq!(rec.0.last().map(|p| (p.accepted, p.executed)), Some((plan.blocks.len(), plan.blocks.len())));
            assert!(rec.0.windows(2).all(|w| w[0].executed <= w[1].executed && w[1].executed <= w[1].accepted));
        }
    }

    /// Asks for one pause (now or at the next pen-up) once `after` blocks are reported executed, then resumes.
    struct PauseOnce {
        after: usize,
        now: bool,
        seen: usize,
        asked: bool,
        paused: Vec<bool>,
    }

    impl Control for PauseOnce {
        fn progress(&mut self, p: &Progress) {
            self.seen = self.seen.max(p.executed);
        }
        fn pause_requested(&mut self) -> Option<bool> {
            (!self.asked && self.seen >= self.after).then(|| {
                self.asked = true;
                self.now
            })
        }
        fn paused(&mut self, held: bool) -> PauseChoice {
            self.paused.push(held);
            PauseChoice::Resume
        }
    }

    /// The board behind a link that delivers `ES` only `delay` intervals after the host sent it (USB latency, and a
    /// user who pressed Ctrl-C at some moment of a move rather than right after a command was answered).
    struct LateStop {
        inner: EbbTransport,
        delay: u64,
    }

    impl Transport for LateStop {
        fn send(&mut self, bytes: &[u8]) -> std::io::Result<()> {
            if bytes.starts_with(b"ES") {
                self.inner.emulator_mut().run_for(self.delay);
            }
            self.inner.send(bytes)
        }
        fn recv_line(&mut self, timeout: Duration) -> std::io::Result<Option<String>> {
            self.inner.recv_line(timeout)
        }
        fn now(&self) -> Duration {
            self.inner.now()
        }
    }

    /// The motor positions the pen was down at, in order, consecutive repeats dropped.
    fn drawn(emu: &EbbEmulator) -> Vec<[i64; 2]> {
        let mut v: Vec<[i64; 2]> = emu.trace().iter().filter(|s| s.pen_down).map(|s| s.motors).collect();
        v.dedup();
        v
    }

    #[test]
    fn a_pause_now_stops_with_es_and_continues_from_the_interrupted_move() {
        let plan = squares();
        // The same plot without a pause, for comparison.
        let mut plain = session(EbbVersion(3, 0, 2));
        plain.home().unwrap();
        plain.stream(&plan, &mut Record::default()).unwrap();
        let want = drawn(plain.transport.emulator());
        let mut returned = 0;
        // Stops all through the plot: in moves (pen up or down) and in pen delays.
        let n = plan.blocks.len();
        for (k, after) in (1..n - 2).enumerate() {
            let t = LateStop {
                inner: EbbTransport::new(EbbEmulator::new(EbbVersion(3, 0, 2))),
                delay: 397 * (k as u64 % 5),
            };
            let mut s = EbbSession::connect(t, "late", &profile()).unwrap();
            s.home().unwrap();
            let mut c = PauseOnce { after, now: true, seen: 0, asked: false, paused: Vec::new() };
            s.stream(&plan, &mut c).unwrap();
            if c.paused.is_empty() {
                // Everything was sent before that many blocks had run: no pause is asked for any more.
                assert!(after > n / 2, "{after} of {n}");
                break;
            }
            assert_eq!(c.paused, [true]);
            let emu = s.transport.inner.emulator();
            assert_eq!(emu.stats().estops, 1, "ES interrupted a command");
            let log = emu.log();
            let es = log.iter().position(|l| l == "ES").unwrap();
            assert!(log[es + 1].starts_with("SP,2,"), "the pen goes up at once after ES: {:?}", &log[es..]);
            returned += usize::from(log[es..].iter().any(|l| l.starts_with("HM,")));
            let end = plan.position_after(plan.blocks.len() - 1);
            assert_eq!(s.position().unwrap()[..2], end[..2]);
            // Every pen-down position of the plain plot is drawn, in order (an interrupted move is drawn again
            // from its start, so some may be visited twice, none is missed).
            let got = drawn(s.transport.inner.emulator());
            let mut it = got.iter();
            assert!(want.iter().all(|w| it.any(|g| g == w)), "after {after}: the paused plot draws everything");
        }
        assert!(returned >= 5, "some stops were mid-move and returned with HM: {returned}");
    }

    #[test]
    fn a_pause_at_the_next_pen_up_drains_and_continues() {
        let plan = squares();
        let mut s = session(EbbVersion(3, 0, 2));
        s.home().unwrap();
        let mut c = PauseOnce { after: 10, now: false, seen: 0, asked: false, paused: Vec::new() };
        s.stream(&plan, &mut c).unwrap();
        assert_eq!(c.paused, [false]);
        assert_eq!(s.transport.emulator().stats().estops, 0);
        let end = plan.position_after(plan.blocks.len() - 1);
        assert_eq!(s.position().unwrap()[..2], end[..2]);
    }

    #[test]
    fn firmware_without_lm_gets_sm_slices_in_the_planned_time() {
        // 2.6.0: no LM (2.7.0), no QG (2.6.2: QM is asked), no QE.
        let mut s = session(EbbVersion(2, 6, 0));
        assert_eq!(s.style, MotionStyle::Sm);
        s.home().unwrap();
        let plan = squares();
        let busy0 = s.transport.emulator().busy_intervals();
        s.stream(&plan, &mut Record::default()).unwrap();
        let emu = s.transport.emulator();
        let ran = (emu.busy_intervals() - busy0) as f64 * 40e-6;
        // SM cannot clear the accumulators on this firmware: each slice may end one interval earlier than from a
        // cleared one (what the host assumes), never later.
        let slices = emu.log().iter().filter(|l| l.starts_with("SM,")).count() as f64;
        assert!(
            ran <= s.program_seconds + 1e-9 && ran >= s.program_seconds - slices * 40e-6,
            "{ran} {}",
            s.program_seconds
        );
        assert!((ran - plan.seconds()).abs() <= plan.seconds() * 1e-3, "ran {ran} s, planned {} s", plan.seconds());
        assert!(emu.log().iter().any(|l| l.starts_with("SM,")) && !emu.log().iter().any(|l| l.starts_with("LM,")));
        assert_eq!(emu.stats().errors, 0);
        let end = plan.position_after(plan.blocks.len() - 1);
        assert_eq!(s.position().unwrap()[..2], end[..2]);
    }

    #[test]
    fn a_refused_command_stops_with_its_meaning_and_the_pen_up() {
        let mut s = session(EbbVersion(3, 0, 2));
        s.home().unwrap();
        // Make the board's parser refuse LM by asking for a plan on a profile whose pen pin is out of range for
        // SP (pin 9): the first SP is answered !6.
        let mut p = profile();
        p.ebb.as_mut().unwrap().pen_pin = 9;
        s.profile = p;
        let e = s.stream(&squares(), &mut Record::default()).unwrap_err();
        match e {
            StreamError::Refused { code: 6, text, .. } => {
                assert!(text.contains("a parameter is out of its range") && text.contains("executed block"), "{text}")
            }
            other => panic!("{other}"),
        }
        assert!(s.transport.emulator().pen_up() && s.transport.emulator().is_idle());
    }
}
