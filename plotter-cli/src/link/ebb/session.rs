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
//! # Waits
//! Every wait on the board ([`crate::link::wait::Wait`]) has an overall deadline derived from the work it waits
//! for, not only a quiet gap, so a board that babbles (blank lines, a wrong device's reports) cannot hold the host:
//! connecting reads what the board still sends for at most a second and asks `V` three times for half a second
//! each; an answer waits for its command's timeout, which for a queued move includes the time of the moves queued
//! ahead of it; a drain waits for the queued work's board time plus a margin (homing: the pen move and the
//! return). Data lines of another shape than the answer's (noise, a wrong device's reports) are skipped and named
//! in the error when the answer never comes. The waits of a plot end on a stop (a termination signal, a second
//! Ctrl-C); those that cannot pause (connecting, homing, a resume's drain) on a single Ctrl-C too; the stop's own
//! waits (`ES`, the pen-up) only at their deadline.
//!
//! # Coordinates
//! The EBB has no endstops: its step counters are zero where the motors were enabled (`EM`) or cleared (`CS`).
//! Homing enables the motors where the carriage stands (the user has put it in the home corner) — or, when they
//! are enabled already, returns there with `HM` — so motor position (0, 0) is the profile's homed position, and
//! a position read with `QS` maps back to the plot's steps (`x = (m1 + m2)/2`, `y = (m1 − m2)/2`). A position
//! outside the machine's travel (plus [`TRAVEL_MARGIN_MM`]) is refused before anything moves: the counters are
//! wrong, and trusting them would send the carriage a kilometre away.
//!
//! # Stopping
//! There is no feed hold: a pause asked for "now" (Ctrl-C) stops with `ES` (which flushes the queue) and raises
//! the pen at once; to continue, the carriage returns with `HM` to the start of the interrupted move, the pen is
//! lowered again if it was down, and the program continues from that move. A pause at the next pen-up just stops
//! sending there and waits for the queue to drain. A stop (a termination signal, a second Ctrl-C) ends the stream
//! with [`StreamError::StoppedAtOnce`]; the job then calls [`EbbSession::stop_and_lift`], which sends the pen-up
//! whatever `ES` answered.

use std::time::Duration;

use anyhow::{Context as _, bail};
use plotter_path::MachineProfile;
use plotter_path::geometry::steps::round_steps;
use plotter_path::motion::plan::{MachinePos, MotionPlan, homed_position};

use super::kinematics::{INTERVAL_US, mix, unmix};
use super::messages::{EbbLine, EbbVersion, GeneralStatus, describe_error};
use super::program::{MotionStyle, Program, ProgramError, program};
use crate::link::Transport;
use crate::link::stream::{Control, PauseChoice, Progress, StreamError, StreamStats};
use crate::link::wait::{Wait, WaitError};
use crate::stop::Stop;

/// How long a plain command may take to be answered (a queued one waits for its FIFO slot on top of this).
pub const COMMAND_TIMEOUT: Duration = Duration::from_secs(3);

/// How long the stop's own commands (`ES`, the pen-up) may take to be answered, on top of the time a command
/// still stuck in the board's parser may wait for its FIFO slot (the parser reads nothing else meanwhile): the
/// board answers them at once.
pub const STOP_TIMEOUT: Duration = Duration::from_secs(1);

/// At connect, what the board still sends from before is read for at most this long.
const CONNECT_QUIET_LIMIT: Duration = Duration::from_secs(1);

/// How long each of the three `V` at connect waits for the version.
const VERSION_WAIT: Duration = Duration::from_millis(500);

/// How long `CU,4` may take: the board drains its queue first (what another host left running).
const FIFO_SETUP_LIMIT: Duration = Duration::from_secs(120);

/// How far outside the work area a reported position may lie (a carriage pushed past the home corner by hand,
/// a belt that slipped), mm.
pub const TRAVEL_MARGIN_MM: f64 = 10.0;

/// How long each read of a wait lasts at most (how often the deadline and the stop flag are looked at).
const SLICE: Duration = Duration::from_millis(100);

/// How often `QG` is asked while draining.
const POLL: Duration = Duration::from_millis(20);

/// The FIFO depth asked for on firmware 3 (the host keeps about a second of short moves queued).
const FIFO_WANTED: usize = 16;

/// Step rate of `HM` returns, steps/s (about 60 mm/s at 80 steps/mm).
const HM_RATE: u32 = 5_000;

/// Data lines of the answers, by shape: numbers after an optional prefix (the future syntax's command name).
fn numbers(l: &str, prefix: &str, n: usize) -> bool {
    let l = l.trim();
    let l = l.strip_prefix(prefix).unwrap_or(l);
    let v: Vec<&str> = l.split(',').collect();
    v.len() == n && v.iter().all(|x| x.trim().parse::<i64>().is_ok())
}

fn es_shape(l: &str) -> bool {
    numbers(l, "ES,", 1)
}

fn qs_shape(l: &str) -> bool {
    numbers(l, "QS,", 2)
}

fn qp_shape(l: &str) -> bool {
    numbers(l, "QP,", 1)
}

fn qe_shape(l: &str) -> bool {
    numbers(l, "QE,", 2)
}

fn qu_shape(l: &str) -> bool {
    numbers(l, "QU,", 1)
}

fn qg_shape(l: &str) -> bool {
    GeneralStatus::parse(l).is_some()
}

fn qm_shape(l: &str) -> bool {
    l.trim().starts_with("QM,") && numbers(l, "QM,", 4)
}

/// What a command's answer ends with. Data lines of another shape than the answer's are noise and skipped.
#[derive(Debug, Clone, Copy)]
enum Expect {
    /// `OK`.
    Ok,
    /// One data line of this shape.
    Line(fn(&str) -> bool),
    /// A data line of this shape, then `OK`.
    LineOk(fn(&str) -> bool),
}

/// How the waits of a session react to the stop flag.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Interrupt {
    /// A stop (a termination signal, a second Ctrl-C) ends them: the waits of a plot, which one Ctrl-C pauses.
    Stop,
    /// A single Ctrl-C ends them too: waits that cannot pause (connecting, homing, a resume's drain).
    Any,
    /// Only their deadline ends them: the stop's own waits (`ES`, the pen-up).
    Never,
}

/// Lines a wait heard that were not what it waited for: the first few, and how many others and blank ones.
#[derive(Debug, Default)]
struct Heard {
    lines: Vec<String>,
    others: usize,
    blank: usize,
}

impl Heard {
    fn push(&mut self, l: &str) {
        if l.trim().is_empty() {
            self.blank += 1;
        } else if self.lines.len() < 3 {
            self.lines.push(l.chars().take(80).collect());
        } else {
            self.others += 1;
        }
    }

    /// `"; it sent instead: "a", "b" and 3 other line(s), 2980 blank line(s)"`, or nothing.
    fn describe(&self, how: &str) -> String {
        let mut parts: Vec<String> = self.lines.iter().map(|l| format!("{l:?}")).collect();
        if self.others > 0 {
            parts.push(format!("{} other line(s)", self.others));
        }
        if self.blank > 0 {
            parts.push(format!("{} blank line(s)", self.blank));
        }
        if parts.is_empty() { String::new() } else { format!("; it sent {how}: {}", parts.join(", ")) }
    }
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
    /// The stop flag the waits obey (the process's by default).
    stop: Stop,
    /// How the waits obey it now.
    interrupt: Interrupt,
    /// The outcome of the last [`EbbSession::stop_and_lift`], while nothing was sent since.
    stopped: Option<Result<String, String>>,
    /// How long a command the board has not answered yet may still wait in its parser for a FIFO slot (the
    /// longest queued command ahead of it): the stop's commands are read only after it.
    parser_wait: Duration,
}

fn lost(name: &str, e: std::io::Error) -> anyhow::Error {
    crate::Error::lost(name, &e, "was the board unplugged or the emulator stopped?").into()
}

/// Board time of `intervals`.
fn board_time(intervals: u64) -> Duration {
    Duration::from_micros(intervals.saturating_mul(u64::from(INTERVAL_US)))
}

/// The deadline of a wait for `work` of board time: the work, a tenth more, and a command's timeout.
fn work_limit(work: Duration) -> Duration {
    COMMAND_TIMEOUT + work + work / 10
}

impl<T: Transport> EbbSession<T> {
    /// Connect: ask `V` (three times, for a board still booting), leave future syntax if another host left it on,
    /// deepen the FIFO on firmware 3, and set up the pen servo from the profile's `[ebb]` section. A single
    /// Ctrl-C ends it; a device that never falls quiet or never answers `V` is given up within a few seconds.
    pub fn connect(transport: T, name: &str, profile: &MachineProfile) -> anyhow::Result<Self> {
        Self::connect_with(transport, name, profile, Stop::process().clone())
    }

    /// [`EbbSession::connect`] with the waits obeying `stop` (a web worker's own flag, a test's).
    pub fn connect_with(transport: T, name: &str, profile: &MachineProfile, stop: Stop) -> anyhow::Result<Self> {
        let pen = profile.ebb.ok_or(ProgramError::NoEbbSection)?;
        let mut s = EbbSession {
            transport,
            name: name.to_string(),
            version: EbbVersion(0, 0, 0),
            fifo: 1,
            profile: profile.clone(),
            style: MotionStyle::Lm,
            short_moves: 0,
            program_seconds: 0.0,
            stop,
            interrupt: Interrupt::Any,
            stopped: None,
            parser_wait: Duration::ZERO,
        };
        let mut heard = Heard::default();
        // What the board still sends from before (a boot message, the end of another host's session) is read
        // while it comes, within a deadline: a device that never falls quiet is not waited out.
        let mut quiet = s.wait("the line to fall quiet", CONNECT_QUIET_LIMIT);
        while let Some(l) = s.recv_within(&mut quiet, Some(SLICE))? {
            heard.push(&l);
        }
        let mut version = None;
        let mut future = false;
        for _ in 0..3 {
            s.send_cmd("V")?;
            let mut w = s.wait("the version (V)", VERSION_WAIT);
            while let Some(l) = s.recv_within(&mut w, None)? {
                if let Some(v) = EbbVersion::parse(&l) {
                    future = l.starts_with("V,");
                    version = Some(v);
                    break;
                }
                heard.push(&l);
            }
            if version.is_some() {
                break;
            }
        }
        let Some(version) = version else {
            let sent = heard.describe("instead");
            let sent = if sent.is_empty() { "; it sent nothing".to_string() } else { sent };
            bail!("{name} does not answer like an EiBotBoard (no version to V){sent}");
        };
        s.version = version;
        s.style = if version.has_lm() { MotionStyle::Lm } else { MotionStyle::Sm };
        if future {
            // Left in future syntax by another program: back to the default replies (answered `CUOK`).
            s.send_cmd("CU,10,0")?;
            let mut w = s.wait("the answer to CU,10,0", COMMAND_TIMEOUT);
            while let Some(l) = s.recv_within(&mut w, None)? {
                if l.trim().ends_with("OK") {
                    break;
                }
            }
        }
        if version.has_deep_fifo() {
            let max = s.exchange("QU,2", Expect::LineOk(qu_shape), COMMAND_TIMEOUT)?;
            let max: usize = max.trim().trim_start_matches("QU,").trim().parse().unwrap_or(1);
            let want = max.clamp(1, FIFO_WANTED);
            if want > 1 {
                // Waits for the queue to drain, so give it time.
                s.exchange(&format!("CU,4,{want}"), Expect::Ok, FIFO_SETUP_LIMIT)?;
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
        s.interrupt = Interrupt::Stop;
        Ok(s)
    }

    /// The stop flag the session's waits obey.
    pub fn stop_flag(&self) -> &Stop {
        &self.stop
    }

    /// A wait on the board for `what`, of at most `limit`, obeying the stop flag as the session does now.
    fn wait(&self, what: impl Into<String>, limit: Duration) -> Wait {
        let w = Wait::new(&self.name, what, self.transport.now(), limit);
        match self.interrupt {
            Interrupt::Stop => w.interruptible_by(&self.stop),
            Interrupt::Any => w.interruptible_by(&self.stop).on_any_interrupt(),
            Interrupt::Never => w,
        }
    }

    /// Run `f` with the waits obeying the stop flag as `how` says, then as before.
    fn with_interrupt<R>(&mut self, how: Interrupt, f: impl FnOnce(&mut Self) -> R) -> R {
        let before = std::mem::replace(&mut self.interrupt, how);
        let r = f(self);
        self.interrupt = before;
        r
    }

    /// The next line within `wait` (for waits whose end is no failure: a line falling quiet, the version tries):
    /// `None` once the deadline passed, or `quiet` passed without a line; a stop is an error.
    fn recv_within(&mut self, wait: &mut Wait, quiet: Option<Duration>) -> anyhow::Result<Option<String>> {
        let since = self.transport.now();
        loop {
            let slice = match wait.next(self.transport.now(), quiet.unwrap_or(SLICE).min(SLICE)) {
                Ok(t) => t,
                Err(WaitError::TimedOut { .. }) => return Ok(None),
                Err(e) => return Err(e.into()),
            };
            if let Some(l) = self.transport.recv_line(slice).map_err(|e| lost(&self.name, e))? {
                return Ok(Some(l));
            }
            if quiet.is_some_and(|q| self.transport.now().saturating_sub(since) >= q) {
                return Ok(None);
            }
        }
    }

    /// Send one command line (CR added).
    fn send_cmd(&mut self, cmd: &str) -> anyhow::Result<()> {
        self.stopped = None;
        self.transport.send(format!("{cmd}\r").as_bytes()).map_err(|e| lost(&self.name, e))
    }

    /// Send `cmd` and read its answer; an error line is an error naming its meaning.
    fn exchange(&mut self, cmd: &str, expect: Expect, timeout: Duration) -> anyhow::Result<String> {
        self.send_cmd(cmd)?;
        self.answer(cmd, expect, timeout)
    }

    fn answer(&mut self, cmd: &str, expect: Expect, timeout: Duration) -> anyhow::Result<String> {
        self.read_answer(cmd, expect, timeout)?
            .map_err(|(code, text)| anyhow::anyhow!("{}: {cmd:?} refused: {}", self.name, describe_error(code, &text)))
    }

    /// The answer to `cmd`: its data, or the board's refusal `(error number, text)`; the link failing, the board
    /// not answering within `timeout` (whatever else it sends meanwhile), or a stop is the outer error.
    fn read_answer(
        &mut self,
        cmd: &str,
        expect: Expect,
        timeout: Duration,
    ) -> anyhow::Result<Result<String, (u8, String)>> {
        let mut wait = self.wait(format!("the answer to {cmd}"), timeout);
        let mut heard = Heard::default();
        let mut data = None;
        loop {
            let slice = match wait.next(self.transport.now(), SLICE) {
                Ok(t) => t,
                Err(e @ WaitError::TimedOut { .. }) => bail!("{e}{}", heard.describe("instead")),
                Err(e) => return Err(e.into()),
            };
            let Some(l) = self.transport.recv_line(slice).map_err(|e| lost(&self.name, e))? else {
                continue;
            };
            if l.trim().is_empty() {
                heard.push(&l);
                continue;
            }
            match (EbbLine::parse(&l), expect) {
                (EbbLine::Error { code, text }, _) => return Ok(Err((code, text))),
                (EbbLine::Ok, Expect::Ok) => return Ok(Ok(String::new())),
                (EbbLine::Ok, Expect::LineOk(_)) if data.is_some() => return Ok(Ok(data.unwrap_or_default())),
                (EbbLine::Data(d), Expect::Line(shape)) if shape(&d) => return Ok(Ok(d)),
                (EbbLine::Data(d), Expect::LineOk(shape)) if shape(&d) => data = Some(d),
                _ => heard.push(&l),
            }
        }
    }

    /// Send a console line and return the board's answer lines (until `OK`, an error, a quiet 0.3 s, or
    /// [`COMMAND_TIMEOUT`] in all: a board that keeps talking is not listened to for ever). A single Ctrl-C ends it.
    pub fn console(&mut self, line: &str) -> anyhow::Result<Vec<String>> {
        self.send_cmd(line)?;
        let mut out = Vec::new();
        let mut w = self.wait(format!("the answer to {line}"), COMMAND_TIMEOUT).on_any_interrupt();
        let mut blank = 0usize;
        loop {
            let slice = match w.next(self.transport.now(), Duration::from_millis(300)) {
                Ok(t) => t,
                Err(WaitError::TimedOut { .. }) => {
                    out.push(format!(
                        "(still talking after {:.0} s: stopped listening)",
                        COMMAND_TIMEOUT.as_secs_f64()
                    ));
                    break;
                }
                Err(e) => return Err(e.into()),
            };
            let Some(l) = self.transport.recv_line(slice).map_err(|e| lost(&self.name, e))? else { break };
            if l.trim().is_empty() {
                blank += 1;
                continue;
            }
            let parsed = EbbLine::parse(&l);
            let done = matches!(parsed, EbbLine::Ok | EbbLine::Error { .. });
            out.push(match parsed {
                EbbLine::Error { code, text } => describe_error(code, &text),
                _ => l,
            });
            if done {
                break;
            }
        }
        if blank > 0 {
            out.push(format!("({blank} blank line(s))"));
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
            let l = self.exchange("QM", Expect::Line(qm_shape), COMMAND_TIMEOUT)?;
            let v: Vec<u8> = l.split(',').skip(1).filter_map(|x| x.trim().parse().ok()).collect();
            let bits = v.iter().take(4).fold(0u8, |b, x| (b << 1) | u8::from(*x != 0));
            return Ok(GeneralStatus(bits));
        }
        let l = self.exchange("QG", Expect::Line(qg_shape), COMMAND_TIMEOUT)?;
        GeneralStatus::parse(&l).with_context(|| format!("{}: unreadable QG answer {l:?}", self.name))
    }

    /// Wait until every queued command has run (`QG` polled every 20 ms); `limit` bounds the wait (derive it from
    /// the work queued: `work_limit`). Says what it waits for once it takes long; obeys the stop flag as the
    /// session's waits do now.
    pub fn drain(&mut self, limit: Duration) -> anyhow::Result<()> {
        let what = if self.version.has_qg() { "QG" } else { "QM" };
        let mut wait = self.wait(format!("the board to finish its queued moves ({what} reports them running)"), limit);
        loop {
            wait.next(self.transport.now(), SLICE)?;
            if !self.general()?.busy() {
                return Ok(());
            }
            // A pause between polls, whatever the board sends meanwhile.
            let until = self.transport.now() + POLL;
            loop {
                let left = until.saturating_sub(self.transport.now());
                if left.is_zero() {
                    break;
                }
                let slice = wait.next(self.transport.now(), left)?;
                if self.transport.recv_line(slice).map_err(|e| lost(&self.name, e))?.is_none() {
                    break;
                }
            }
        }
    }

    /// Motor positions (`QS`), refused when they lie outside the machine's travel (see [`Self::check_motors`]).
    pub fn motors(&mut self) -> anyhow::Result<[i64; 2]> {
        let l = self.exchange("QS", Expect::LineOk(qs_shape), COMMAND_TIMEOUT)?;
        let l = l.trim().trim_start_matches("QS,");
        let v: Vec<i64> = l.split(',').filter_map(|x| x.trim().parse().ok()).collect();
        let m = <[i64; 2]>::try_from(v).map_err(|_| anyhow::anyhow!("{}: unreadable QS answer {l:?}", self.name))?;
        self.check_motors(m)?;
        Ok(m)
    }

    /// Whether the pen is up, as the board last commanded its servo (`QP`: 1 up, 0 down).
    pub fn pen_is_up(&mut self) -> anyhow::Result<bool> {
        let l = self.exchange("QP", Expect::LineOk(qp_shape), COMMAND_TIMEOUT)?;
        Ok(l.trim().trim_start_matches("QP,").trim() == "1")
    }

    /// Refuse motor positions whose XY position lies outside the work area by more than [`TRAVEL_MARGIN_MM`] on
    /// any side (computed in 128 bits: no counter the board may report wraps).
    pub fn check_motors(&self, m: [i64; 2]) -> anyhow::Result<()> {
        let home = homed_position(&self.profile)?;
        let axes = [&self.profile.axes.x, &self.profile.axes.y];
        // Doubled XY steps from home (motor 1 = X+Y, motor 2 = X−Y): integral even between two motors' steps.
        let (a, b) = (i128::from(m[0]), i128::from(m[1]));
        let doubled = [a + b, a - b];
        let mut travel = [0i64; 2];
        let mut inside = true;
        for k in 0..2 {
            let steps = |mm: f64| round_steps(mm * axes[k].steps_per_mm).map_or(i64::from(i32::MAX), i64::from);
            travel[k] = steps(axes[k].travel_mm);
            let margin = i128::from(steps(TRAVEL_MARGIN_MM));
            let at = 2 * i128::from(home[k]) + doubled[k];
            inside &= (-2 * margin..=2 * (i128::from(travel[k]) + margin)).contains(&at);
        }
        if inside {
            return Ok(());
        }
        bail!(
            "{}: the board reports its motors at {},{} (QS), outside the machine's travel (X 0..{} and Y 0..{} steps: \
             {} × {} mm, {TRAVEL_MARGIN_MM} mm to spare): its step counters cannot be trusted, so nothing was \
             moved. Power-cycle the board (or send EM,0 from the console), move the carriage to the home corner \
             by hand, and plot again with homing (not --no-home, not --resume --trust-position)",
            self.name,
            m[0],
            m[1],
            travel[0],
            travel[1],
            self.profile.axes.x.travel_mm,
            self.profile.axes.y.travel_mm
        )
    }

    /// The plot position of motor positions. A stop between the two motors' steps of a move leaves them half an
    /// XY step apart (an odd sum): that position is rounded (towards motor 1's side); [`Self::stop_and_lift`]
    /// steps motor 2 once to make it whole again.
    fn xy_of(&self, m: [i64; 2]) -> anyhow::Result<MachinePos> {
        let home = homed_position(&self.profile)?;
        let (x, y) = unmix(m)
            .or_else(|| unmix([m[0], m[1].checked_add(1)?]))
            .with_context(|| format!("{}: motor position {},{} out of range", self.name, m[0], m[1]))?;
        let to = |h: i32, d: i64| {
            i64::from(h).checked_add(d).and_then(|v| i32::try_from(v).ok()).context("position out of range")
        };
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

    /// The time of the pen's settle (the `SP` delay at homing), ms.
    fn settle_ms(&self) -> f64 {
        self.profile.pen.settle_ms.round().clamp(0.0, 65_535.0)
    }

    /// Raise the pen, then make the current carriage position (or, with the motors enabled already, motor
    /// position 0, reached with `HM`) the home corner. Every wait is bounded by the work it waits for (the pen
    /// move, the return) and ends on a single Ctrl-C (homing cannot pause), which stops the board
    /// ([`Self::stop_and_lift`]).
    pub fn home(&mut self) -> anyhow::Result<()> {
        let r = self.with_interrupt(Interrupt::Any, Self::home_now);
        self.stop_if_stopped(r)
    }

    /// A wait outside a stream ended by a stop: the board is stopped and the pen lifted before the error returns
    /// (with what the stop did).
    fn stop_if_stopped<R>(&mut self, r: anyhow::Result<R>) -> anyhow::Result<R> {
        match r {
            Err(e) if stopped_by(&e).is_some() => {
                let done = match self.stop_and_lift() {
                    Ok(done) => done,
                    Err(s) => format!("{s:#}"),
                };
                Err(anyhow::anyhow!("{e:#}; {done}"))
            }
            r => r,
        }
    }

    fn home_now(&mut self) -> anyhow::Result<()> {
        let e = self.profile.ebb.context("no [ebb] section")?;
        let settle = self.settle_ms();
        let pen_move = Duration::from_secs_f64(settle / 1000.0);
        // The board may still finish what another host queued: as long as CU,4 may have waited at connect.
        self.command(&format!("SP,1,{settle},{}", e.pen_pin), FIFO_SETUP_LIMIT)?;
        let enabled = if self.version.has_qe() {
            let l = self.exchange("QE", Expect::LineOk(qe_shape), COMMAND_TIMEOUT)?;
            l.trim().trim_start_matches("QE,").split(',').any(|x| x.trim() != "0")
        } else {
            false
        };
        let mut work = pen_move;
        if enabled {
            let at = self.motors()?;
            if at != [0, 0] {
                work += self.return_to(at, [0, 0], pen_move)?;
            }
        } else {
            eprintln!("{}: the EBB has no endstops; the carriage is taken to stand in the home corner", self.name);
            self.command(&format!("EM,{},{}", e.step_mode, e.step_mode), COMMAND_TIMEOUT + pen_move)?;
        }
        self.drain(work_limit(work))
    }

    /// Stop now and raise the pen: `ES` flushes the queue, then the pen goes up at once (`SP,2` on firmware
    /// 3.0.1 and later, else a plain `SP,1` into the empty queue) — sent whatever `ES` answered. Returns what was
    /// done, for the user; an error names each step that failed and whether the pen is up. Its waits end only at
    /// their deadlines (a second signal must not cut the lift short). Called again with nothing sent since, it
    /// returns the same outcome without asking the board again.
    pub fn stop_and_lift(&mut self) -> anyhow::Result<String> {
        if let Some(done) = &self.stopped {
            return done.clone().map_err(anyhow::Error::msg);
        }
        let r = self.with_interrupt(Interrupt::Never, Self::stop_and_lift_now);
        self.stopped = Some(r.as_ref().map(Clone::clone).map_err(|e| format!("{e:#}")));
        r
    }

    fn stop_and_lift_now(&mut self) -> anyhow::Result<String> {
        let e = self.profile.ebb.context("no [ebb] section")?;
        let limit = STOP_TIMEOUT + self.parser_wait;
        let es = self.exchange("ES", Expect::LineOk(es_shape), limit);
        if es.is_err() {
            // A late answer to ES must not pass for the lift's: what the board still sends is read first (briefly).
            let mut w = self.wait("the line to fall quiet", Duration::from_millis(300));
            while self.recv_within(&mut w, Some(SLICE))?.is_some() {}
        }
        let lift = if self.version.has_immediate_pen_up() {
            format!("SP,2,0,{}", e.pen_pin)
        } else {
            format!("SP,1,0,{}", e.pen_pin)
        };
        let lifted = self.command(&lift, limit);
        self.parser_wait = Duration::ZERO;
        let stopped = match &es {
            Ok(d) if d.trim().trim_start_matches("ES,") == "1" => "motion stopped (ES)".to_string(),
            Ok(_) => "nothing was moving (ES)".to_string(),
            Err(err) => format!("ES unanswered ({err:#})"),
        };
        let lifted = match lifted {
            Ok(()) => format!("the pen is up ({lift})"),
            Err(err) => bail!(
                "{stopped}; the pen-up {lift} failed too ({err:#}): the pen may still be on the paper. Switch the \
                 board off (or unplug its USB) and lift the pen by hand"
            ),
        };
        if es.is_err() {
            bail!("{stopped}; {lifted}");
        }
        // The motion has ended within a short bound (the queue is empty; the pen moves on its own).
        self.drain(Duration::from_secs(2)).with_context(|| format!("{stopped}; {lifted}"))?;
        // Stopped between the two motors' steps of a move: one step of motor 2 makes the position an XY one.
        let m = self.motors().with_context(|| format!("{stopped}; {lifted}"))?;
        if unmix(m).is_none() {
            self.command("SM,2,0,1", COMMAND_TIMEOUT)?;
            self.drain(Duration::from_secs(2))?;
        }
        Ok(format!("{stopped}; {lifted}"))
    }

    /// Stream `plan` (which starts where the machine stands). Returns when it has been executed.
    pub fn stream(&mut self, plan: &MotionPlan, control: &mut dyn Control) -> Result<StreamStats, StreamError> {
        let start = self.motors_of(&plan.start).map_err(StreamError::Link)?;
        let prog = program(&self.profile, plan, start, self.style).map_err(|e| StreamError::Link(e.into()))?;
        self.short_moves += prog.short_moves;
        self.program_seconds += prog.seconds();
        let t0 = self.transport.now();
        let result = self.with_interrupt(Interrupt::Stop, |s| s.send_program(&prog, plan, start, control));
        self.transport.set_streaming(false);
        let (bytes, frames, queued, executed) = result?;
        self.with_interrupt(Interrupt::Stop, |s| s.drain(work_limit(queued)))
            .map_err(|e| self.stream_failure(e, executed))?;
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

    /// Send the program; returns the bytes and commands sent, the board time still queued at the end and the
    /// blocks certainly executed then.
    fn send_program(
        &mut self,
        prog: &Program,
        plan: &MotionPlan,
        start: [i64; 2],
        control: &mut dyn Control,
    ) -> Result<(u64, usize, Duration, usize), StreamError> {
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
        let ahead = |from: usize, to: usize| board_time(cmds[from..to].iter().map(|c| c.intervals).sum());
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
            // A stop (SIGTERM, SIGHUP, a second Ctrl-C): at once; the job sends ES and lifts the pen.
            if let Some(cause) = control.stop_requested() {
                return Err(StreamError::StoppedAtOnce {
                    name: self.name.clone(),
                    why: cause.to_string(),
                    executed: Self::blocks_done(prog, done_cmds),
                });
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
                let executed = Self::blocks_done(prog, done_cmds);
                self.drain(work_limit(ahead(done_cmds, next))).map_err(|e| self.stream_failure(e, executed))?;
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
            self.stopped = None;
            self.transport.send(line.as_bytes()).map_err(|e| StreamError::Link(lost(&self.name, e)))?;
            bytes += u64::try_from(line.len()).unwrap_or(u64::MAX);
            // A queued command waits for its slot: at most the FIFO's and the executing command's time; meanwhile
            // it blocks the board's parser for at most the longest command ahead of it.
            let wait = COMMAND_TIMEOUT + ahead(done_cmds, next);
            self.parser_wait = board_time(cmds[done_cmds..next].iter().map(|c| c.intervals).max().unwrap_or(0));
            let answer = self.read_answer(&c.line, Expect::Ok, wait);
            if !matches!(answer, Ok(Ok(_))) {
                let executed = Self::blocks_done(prog, done_cmds);
                if let Err(e) = &answer
                    && let Some(why) = stopped_by(e)
                {
                    return Err(StreamError::StoppedAtOnce { name: self.name.clone(), why, executed });
                }
                let stopped = self.stop_and_lift();
                let after = match stopped {
                    Ok(_) => format!("the plot stopped (pen up) after {executed} executed block(s)"),
                    Err(s) => format!("the plot stopped after {executed} executed block(s); stopping: {s:#}"),
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
            self.parser_wait = Duration::ZERO;
            if c.queued {
                // Everything queued more than a FIFO's length before this one has finished.
                let finished = ordinal[next].saturating_sub(self.fifo);
                while done_cmds < next && ordinal[done_cmds] < finished {
                    done_cmds += 1;
                }
            }
            next += 1;
        }
        Ok((bytes, cmds.len(), ahead(done_cmds, cmds.len()), Self::blocks_done(prog, done_cmds)))
    }

    /// A wait of the stream that failed: a stop is [`StreamError::StoppedAtOnce`] (the job stops the board and
    /// lifts the pen), anything else a link error.
    fn stream_failure(&self, e: anyhow::Error, executed: usize) -> StreamError {
        match stopped_by(&e) {
            Some(why) => StreamError::StoppedAtOnce { name: self.name.clone(), why, executed },
            None => StreamError::Link(e),
        }
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
        let executed = Self::blocks_done(prog, *done_cmds);
        let at = self.motors().map_err(|e| self.stream_failure(e, executed))?;
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
        let executed = Self::blocks_done(prog, resume);
        let e = self.profile.ebb.context("no [ebb] section").map_err(StreamError::Link)?;
        let target = before(resume);
        let mut work = Duration::ZERO;
        if at != target {
            work += self.return_to(at, target, Duration::ZERO).map_err(|e| self.stream_failure(e, executed))?;
        }
        if resume > 0 && cmds[resume - 1].pen_down {
            let settle = self.settle_ms();
            self.command(&format!("SP,0,{settle},{}", e.pen_pin), COMMAND_TIMEOUT + work)
                .map_err(|e| self.stream_failure(e, executed))?;
            work += Duration::from_secs_f64(settle / 1000.0);
        }
        self.drain(work_limit(work)).map_err(|e| self.stream_failure(e, executed))?;
        Ok(Some(resume))
    }

    /// Move the carriage (pen up) from motor position `at` to `target`, behind `ahead` of queued board time:
    /// `HM` to the absolute position where the firmware has it (2.7.0 and later), else one slow `SM`. Returns the
    /// move's board time.
    fn return_to(&mut self, at: [i64; 2], target: [i64; 2], ahead: Duration) -> anyhow::Result<Duration> {
        let d = [target[0].saturating_sub(at[0]), target[1].saturating_sub(at[1])];
        let ms =
            (d[0].unsigned_abs().max(d[1].unsigned_abs()).saturating_mul(1000)).div_ceil(u64::from(HM_RATE)).max(1);
        let time = Duration::from_millis(ms);
        // HM waits for the queue to drain before it is answered.
        let timeout = COMMAND_TIMEOUT + ahead;
        if self.version.has_hm() {
            self.command(&format!("HM,{HM_RATE},{},{}", target[0], target[1]), timeout)?;
        } else {
            self.command(&format!("SM,{ms},{},{}", d[0], d[1]), timeout)?;
        }
        Ok(time)
    }

    /// After the host lost a plot: the first block of `full` not certainly executed, from where the idle board
    /// stands: the last block end at that position from the journal's executed count on (within what the FIFO can
    /// have held past the accepted count); otherwise the journal's executed count. The wait for the board to
    /// finish is bounded by the board time of what it can still hold, and ends on a single Ctrl-C.
    pub fn resume_point(&mut self, executed: usize, accepted: usize, full: &MotionPlan) -> anyhow::Result<usize> {
        let hi = (accepted + 3 * self.fifo + 3).min(full.blocks.len());
        // Plan ticks are µs (TICK_HZ = 1 MHz).
        let queued = Duration::from_micros(
            full.blocks.get(executed.min(hi)..hi).unwrap_or(&[]).iter().map(|b| u64::from(b.ticks)).sum(),
        );
        let pos = self.with_interrupt(Interrupt::Any, |s| {
            s.drain(work_limit(queued))?;
            s.position()
        });
        let pos = self.stop_if_stopped(pos)?;
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

/// The cause, when `e` is a wait ended by a stop ([`WaitError::Stopped`]).
fn stopped_by(e: &anyhow::Error) -> Option<String> {
    match e.downcast_ref::<WaitError>() {
        Some(WaitError::Stopped(s)) => Some(s.cause.to_string()),
        _ => None,
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
    use crate::link::ebb::emulator::{ES_GARBAGE, EbbEmulator, Lie};
    use crate::link::ebb::emulator_transport::EbbTransport;
    use crate::link::stream::tests::Record;
    use crate::stop::StopCause;
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

    /// The emulated board behind a clock that ends: past `cap` of virtual time every read fails (so a wait that
    /// never ends fails its test instead of hanging it). Notes when the first blank line arrived, and raises
    /// `stop` (as SIGTERM) once `stop_after` has passed since then (a signal arriving in the middle of a wait);
    /// presses Ctrl-C once on `interrupt_at`'s flag at that virtual time.
    struct Clocked {
        inner: EbbTransport,
        cap: Duration,
        first_blank: Option<Duration>,
        stop_after: Option<(Duration, Stop)>,
        interrupt_at: Option<(Duration, Stop)>,
    }

    impl Clocked {
        fn new(emu: EbbEmulator) -> Clocked {
            Clocked {
                inner: EbbTransport::new(emu),
                cap: Duration::from_secs(60),
                first_blank: None,
                stop_after: None,
                interrupt_at: None,
            }
        }

        fn emu(&mut self) -> &mut EbbEmulator {
            self.inner.emulator_mut()
        }
    }

    impl Transport for Clocked {
        fn send(&mut self, bytes: &[u8]) -> std::io::Result<()> {
            self.inner.send(bytes)
        }
        fn recv_line(&mut self, timeout: Duration) -> std::io::Result<Option<String>> {
            let now = self.inner.now();
            if now > self.cap {
                return Err(std::io::Error::other("the test's virtual clock ran out"));
            }
            if let (Some(t), Some((after, stop))) = (self.first_blank, &self.stop_after)
                && now >= t + *after
            {
                stop.request(StopCause::Terminate);
            }
            if let Some((t, stop)) = &self.interrupt_at
                && now >= *t
            {
                stop.interrupt();
                self.interrupt_at = None;
            }
            let l = self.inner.recv_line(timeout)?;
            if l.as_deref() == Some("") && self.first_blank.is_none() {
                self.first_blank = Some(self.inner.now());
            }
            Ok(l)
        }
        fn now(&self) -> Duration {
            self.inner.now()
        }
    }

    fn clocked(v: EbbVersion, lie: Option<Lie>) -> anyhow::Result<EbbSession<Clocked>> {
        let mut emu = EbbEmulator::new(v);
        emu.set_lie(lie);
        EbbSession::connect_with(Clocked::new(emu), "lying EBB", &profile(), Stop::new())
    }

    fn ms(d: Duration) -> u128 {
        d.as_millis()
    }

    #[test]
    fn a_failed_es_still_lifts_the_pen_and_names_both_outcomes() {
        for (v, lift) in [(EbbVersion(3, 0, 2), "SP,2,0,1"), (EbbVersion(2, 8, 1), "SP,1,0,1")] {
            let mut s = clocked(v, None).unwrap();
            s.home().unwrap();
            // The pen down and a 2 s move running when the stop comes.
            s.command("SP,0,0,1", COMMAND_TIMEOUT).unwrap();
            s.command("SM,2000,800,800", COMMAND_TIMEOUT).unwrap();
            s.transport.emu().run_for(2_500);
            assert!(!s.transport.emu().pen_up());
            s.transport.emu().set_lie(Some(Lie::EsGarbage));
            let t0 = s.transport.now();
            let e = format!("{:#}", s.stop_and_lift().unwrap_err());
            let took = s.transport.now() - t0;
            assert!(
                e.contains("ES unanswered (lying EBB: gave up waiting for the answer to ES after 1.0 s")
                    && e.contains(&format!("{ES_GARBAGE:?}"))
                    && e.ends_with(&format!("; the pen is up ({lift})")),
                "{v}: {e}"
            );
            // The ES deadline, then at most the 0.3 s spent reading what else comes.
            assert!(took >= STOP_TIMEOUT && took <= STOP_TIMEOUT + Duration::from_millis(400), "{v}: {took:?}");
            // The board takes a queued SP,1 on its next interval.
            s.transport.emu().run_for(2);
            let emu = s.transport.emu();
            assert!(emu.pen_up(), "{v}: the pen is up although ES answered garbage");
            assert_eq!(emu.stats().estops, 1, "{v}");
            let log = emu.log().to_vec();
            let es = log.iter().position(|l| l == "ES").unwrap();
            assert_eq!(log[es + 1..], [lift.to_string()], "{v}: the lift right after ES, nothing else");
            // Asked again with nothing sent since (the job does, after the stream's own stop): the same outcome,
            // the board not asked again.
            assert_eq!(format!("{:#}", s.stop_and_lift().unwrap_err()), e);
            assert_eq!(s.transport.emu().log().len(), log.len());
        }
    }

    #[test]
    fn a_board_that_falls_into_blank_lines_mid_plot_is_given_up_within_the_deadline_with_the_pen_up() {
        let mut s = clocked(EbbVersion(3, 0, 2), None).unwrap();
        s.home().unwrap();
        let n = s.transport.emu().stats().commands;
        s.transport.emu().set_lie(Some(Lie::Blank { after: n + 40 }));
        let plan = squares();
        let e = s.stream(&plan, &mut Record::default()).unwrap_err().to_string();
        let since = s.transport.now() - s.transport.first_blank.expect("blank lines came");
        // The command's own deadline: its timeout and at most the 16 queued commands ahead of it (the plan's moves
        // take well under 2 s in all); then ES and the lift, 1 s each plus the longest command ahead, and 0.3 s.
        assert!(
            since < COMMAND_TIMEOUT + Duration::from_secs(2) + 2 * STOP_TIMEOUT + Duration::from_secs(3),
            "{since:?}"
        );
        assert!(
            e.contains("lying EBB: gave up waiting for the answer to ")
                && e.contains("blank line(s)")
                && e.contains("ES unanswered")
                && e.contains("the pen-up SP,2,0,1 failed too"),
            "{e}"
        );
        // The board still obeyed: the pen went up.
        assert!(s.transport.emu().pen_up());
        let log = s.transport.emu().log().to_vec();
        assert_eq!(log[log.len() - 2..], ["ES".to_string(), "SP,2,0,1".to_string()]);
        // The job's stop afterwards: the same outcome at once, nothing sent.
        let t = s.transport.now();
        assert!(format!("{:#}", s.stop_and_lift().unwrap_err()).contains("ES unanswered"));
        assert_eq!((s.transport.now(), s.transport.emu().log().len()), (t, log.len()));
    }

    #[test]
    fn connecting_to_a_babbling_device_ends_within_seconds() {
        // A board that chatters (a junk line every 20 ms) besides its answers: the junk is skipped, the connect
        // ends within its one second of listening, and a plot runs to its planned end.
        let mut s = clocked(EbbVersion(3, 0, 2), Some(Lie::Chatter)).unwrap();
        assert!(s.transport.now() <= CONNECT_QUIET_LIMIT + Duration::from_millis(50), "{:?}", s.transport.now());
        assert_eq!(s.fifo, FIFO_WANTED);
        s.home().unwrap();
        let plan = squares();
        s.stream(&plan, &mut Record::default()).unwrap();
        assert_eq!(s.position().unwrap()[..2], plan.position_after(plan.blocks.len() - 1)[..2]);
        // A device that answers nothing but blank lines: refused after the listening and three V tries.
        let e = format!("{:#}", clocked(EbbVersion(3, 0, 2), Some(Lie::Blank { after: 0 })).err().unwrap());
        assert!(
            e.starts_with("lying EBB does not answer like an EiBotBoard (no version to V); it sent instead: ")
                && e.ends_with(" blank line(s)"),
            "{e}"
        );
    }

    #[test]
    fn a_board_busy_for_ever_is_given_up_after_the_work_it_was_given() {
        let mut s = clocked(EbbVersion(3, 0, 2), None).unwrap();
        s.home().unwrap();
        s.transport.emu().set_lie(Some(Lie::Busy));
        // Homing again raises the pen (126 ms) with the motors at home: the wait is that work, a tenth more, and
        // a command's timeout — not ten minutes.
        let t0 = s.transport.now();
        let e = format!("{:#}", s.home().unwrap_err());
        let took = s.transport.now() - t0;
        let limit = work_limit(Duration::from_millis(126));
        assert_eq!(
            e,
            "lying EBB: gave up waiting for the board to finish its queued moves (QG reports them running) after 3.1 s"
        );
        assert!(took >= limit && took <= limit + Duration::from_millis(150), "{took:?}");
        // A stream's final drain: the program's board time and a margin.
        let plan = squares();
        let t0 = s.transport.now();
        let e = s.stream(&plan, &mut Record::default()).unwrap_err().to_string();
        let took = s.transport.now() - t0;
        assert!(e.contains("gave up waiting for the board to finish its queued moves"), "{e}");
        assert!(took <= Duration::from_secs_f64(plan.seconds() * 1.1) + COMMAND_TIMEOUT * 2, "{took:?}");
    }

    #[test]
    fn an_absurd_qs_is_refused_before_anything_moves() {
        for at in [[100_000_000, 100_000_000], [i64::MAX, i64::MAX], [i64::MIN, i64::MAX], [-802, -802]] {
            let mut s = clocked(EbbVersion(3, 0, 2), None).unwrap();
            s.home().unwrap();
            s.transport.emu().set_lie(Some(Lie::Qs(at)));
            let e = format!("{:#}", s.home().unwrap_err());
            assert!(
                e.starts_with(&format!("lying EBB: the board reports its motors at {},{} (QS), outside", at[0], at[1]))
                    && e.contains("(X 0..24000 and Y 0..17440 steps: 300 × 218 mm, 10 mm to spare)")
                    && e.contains("Power-cycle the board"),
                "{e}"
            );
            assert!(s.position().is_err(), "{at:?}");
            assert!(s.resume_point(0, 0, &squares()).is_err(), "{at:?}: a resume reads it too");
            assert_eq!(s.transport.emu().stats().moves, 0, "{at:?}: nothing moved");
        }
        // Within the margin (10 mm = 800 steps past the home corner): read as it is.
        let mut s = clocked(EbbVersion(3, 0, 2), Some(Lie::Qs([-800, -800]))).unwrap();
        let home = homed_position(&profile()).unwrap();
        assert_eq!(s.position().unwrap()[..2], [home[0] - 800, home[1]]);
    }

    /// Asks for a stop (as SIGTERM) once `after` blocks are reported executed.
    struct StopAfter {
        after: usize,
        seen: usize,
    }

    impl Control for StopAfter {
        fn progress(&mut self, p: &Progress) {
            self.seen = self.seen.max(p.executed);
        }
        fn pause_requested(&mut self) -> Option<bool> {
            None
        }
        fn paused(&mut self, _held: bool) -> PauseChoice {
            PauseChoice::Resume
        }
        fn stop_requested(&mut self) -> Option<StopCause> {
            (self.seen >= self.after).then_some(StopCause::Terminate)
        }
    }

    #[test]
    fn a_stop_during_a_stream_ends_it_at_once_and_the_stop_leaves_the_pen_up() {
        let mut s = session(EbbVersion(3, 0, 2));
        s.home().unwrap();
        let plan = squares();
        let e = s.stream(&plan, &mut StopAfter { after: 10, seen: 0 }).unwrap_err();
        match e {
            StreamError::StoppedAtOnce { why, executed, .. } => {
                assert_eq!(why, "SIGTERM");
                assert!((10..plan.blocks.len()).contains(&executed), "{executed}");
            }
            other => panic!("{other}"),
        }
        assert!(!s.transport.emulator().is_idle(), "the board still had moves queued");
        let done = s.stop_and_lift().unwrap();
        assert_eq!(done, "motion stopped (ES); the pen is up (SP,2,0,1)");
        let emu = s.transport.emulator();
        assert!(emu.pen_up() && emu.is_idle());
        assert_eq!(emu.stats().estops, 1);
    }

    #[test]
    fn a_stop_ends_a_wait_for_an_answer_but_not_the_stops_own_waits() {
        let mut s = clocked(EbbVersion(3, 0, 2), None).unwrap();
        s.home().unwrap();
        let n = s.transport.emu().stats().commands;
        s.transport.emu().set_lie(Some(Lie::Blank { after: n + 40 }));
        s.transport.stop_after = Some((Duration::from_millis(500), s.stop_flag().clone()));
        let plan = squares();
        let e = s.stream(&plan, &mut Record::default()).unwrap_err();
        let since = s.transport.now() - s.transport.first_blank.expect("blank lines came");
        assert!(matches!(&e, StreamError::StoppedAtOnce { why, .. } if why == "SIGTERM"), "{e}");
        // Within a read slice of the signal, not at the answer's deadline.
        assert!(since <= Duration::from_millis(500) + SLICE * 2, "{} ms", ms(since));
        // The stop itself runs to its deadlines whatever the flag says, and sends the lift.
        let t0 = s.transport.now();
        let e = format!("{:#}", s.stop_and_lift().unwrap_err());
        assert!(s.transport.now() - t0 >= 2 * STOP_TIMEOUT, "{e}");
        assert!(e.contains("ES unanswered") && e.contains("SP,2,0,1"), "{e}");
        assert!(s.transport.emu().pen_up());
    }

    #[test]
    fn one_ctrl_c_ends_homing_on_a_busy_board_and_stops_it_with_the_pen_up() {
        let mut s = clocked(EbbVersion(3, 0, 2), None).unwrap();
        s.home().unwrap();
        s.transport.emu().set_lie(Some(Lie::Busy));
        // As during a plot, where one Ctrl-C asks for a pause: homing cannot pause, so it ends.
        s.stop_flag().set_pausable(true);
        let t0 = s.transport.now();
        s.transport.interrupt_at = Some((t0 + Duration::from_secs(1), s.stop_flag().clone()));
        let e = format!("{:#}", s.home().unwrap_err());
        assert!(
            e.starts_with(
                "stopped by Ctrl-C (SIGINT) while waiting for the board to finish its queued moves (QG reports \
                 them running) from lying EBB; "
            ) && e.contains("the pen is up (SP,2,0,1)"),
            "{e}"
        );
        let log = s.transport.emu().log();
        assert_eq!(log.iter().filter(|l| *l == "ES").count(), 1, "the board was stopped: {log:?}");
        assert!(s.transport.emu().pen_up());
    }
}
