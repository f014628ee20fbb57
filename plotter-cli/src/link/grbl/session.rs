//! A session with a GRBL 1.1 controller: connect (banner or `$I`), read `$$`, home (`$H`) or unlock (`$X`),
//! declare the plot's coordinates (`G92`), status, and stream a plan with character counting.
//!
//! # Coordinates
//! The plot works in the profile's machine coordinates (the homed corner is 0, see
//! [`plotter_path::motion::plan::homed_position`]). After homing (`$H` when `$22=1`; otherwise the carriage is
//! taken to stand at the homed corner) the sender declares that position with `G92`, so every line is written in
//! the plot's own coordinates whatever GRBL's machine space is. Positions read back from status reports are
//! converted through the offset measured right after the declaration (or from `$#` when the plot did not home).
//!
//! # Flow control
//! Character counting, as GRBL's interface documentation describes: the host keeps the lengths of the lines it
//! sent and has not seen answered, and sends the next line only if the total stays within the receive buffer
//! (`[OPT:…,…,RX]` from `$I`, 128 bytes by default, less the ring's one empty slot). Every line is answered once
//! (`ok` or `error:`), in order, so each answer frees the oldest line's bytes.
//!
//! # Holds, alarms and resets: every way a plot ends leaves the pen up
//! GRBL can stop in ways the sender did not ask for: its Hold button (or a `!` from another program) holds the
//! plot, its Reset button (Ctrl-X) drops everything (`ALARM:3` when it came during motion), a limit switch raises
//! an alarm. A hold is told to the user at once ([`Control::notice`]) and, when nobody resumes it (Cycle Start,
//! `~`) within [`GrblSession::hold_timeout`] (30 s by default, the stall limit of our own firmware's
//! [`crate::link::session::WAIT_STALL`]), ends the plot with an error naming it; so does any other state in which
//! nothing moves for that long. A pause request (Ctrl-C) during such a hold, or a second one before a pause at the
//! next pen-up is reached, stops the plot at once. Whichever way the stream ends early, the job then calls
//! [`GrblSession::stop_and_lift`]: bring motion to rest with a feed hold (so that the reset keeps the position),
//! soft-reset to drop what is queued, unlock (`$X`) if GRBL is in alarm, and lift the pen with the plot's own
//! pen-up command (`M3 S<up angle>`, or a relative Z move, which holds whatever offsets the reset dropped).
//!
//! # Progress
//! `ok` means queued. What has been executed comes from the `?` status report (polled at 5 Hz, the rate GRBL's
//! documentation recommends as the upper limit): the reported position is located on the plan's blocks between
//! the last executed one and the last acknowledged one; an idle machine has executed everything acknowledged.

use std::collections::VecDeque;
use std::time::Duration;

use anyhow::{Context as _, bail};
use plotter_path::MachineProfile;
use plotter_path::motion::plan::{MachinePos, MotionPlan};

use super::messages::{
    GrblLine, GrblStatus, RT_CYCLE_START, RT_FEED_HOLD, RT_RESET, RT_STATUS, alarm_meaning, describe_alarm,
    describe_error,
};
use super::program::{declare_position, lift, program};
use super::settings::GrblSettings;
use crate::link::Transport;
use crate::link::session::WAIT_STALL;
use crate::link::stream::{Control, PauseChoice, Progress, StreamError, StreamStats, stop_at_once};
use crate::stop::{Stop, Stopped};

/// How long a plain command may take.
pub const COMMAND_TIMEOUT: Duration = Duration::from_secs(10);
/// How long a homing cycle may take.
pub const HOMING_TIMEOUT: Duration = Duration::from_secs(180);
/// Status polling period while streaming.
pub const STATUS_EVERY: Duration = Duration::from_millis(200);
/// No status answer for this long while streaming: the controller is gone.
pub const SILENCE: Duration = Duration::from_secs(5);

/// An open session with a GRBL controller.
pub struct GrblSession<T: Transport> {
    /// The byte pipe.
    pub transport: T,
    /// Where it is connected (for messages).
    pub name: String,
    /// GRBL version (`1.1h`).
    pub version: String,
    /// Receive buffer size, bytes.
    pub rx_bytes: usize,
    /// The `$$` settings.
    pub settings: GrblSettings,
    /// The machine profile the plot uses.
    pub profile: MachineProfile,
    /// Reported position (MPos or WPos, mm) of the plot's origin, once known.
    offset: Option<[f64; 3]>,
    /// `[MSG:…]` lines received, for display.
    pub messages: Vec<String>,
    /// Most bytes in flight during the last stream.
    pub peak_in_flight: usize,
    /// How long a feed hold nobody resumes (or any other standstill) may last before a stream or a wait for
    /// the machine ends with an error ([`WAIT_STALL`] unless set).
    pub hold_timeout: Duration,
    /// Whether the last status report gave the work position (`WPos`, `$10=0`), which a soft reset changes
    /// (it drops the `G92` offset), rather than the machine position, which it keeps.
    reports_wpos: bool,
}

fn transport_error(name: &str, e: std::io::Error) -> anyhow::Error {
    crate::Error::lost(name, &e, "was the device unplugged or the emulator stopped?").into()
}

/// Step position (XYZ) of millimetres.
fn to_steps(profile: &MachineProfile, mm: [f64; 3]) -> [i32; 3] {
    let spm = [profile.axes.x.steps_per_mm, profile.axes.y.steps_per_mm, profile.axes.z.steps_per_mm];
    core::array::from_fn(|i| plotter_path::geometry::steps::round_steps(mm[i] * spm[i]).unwrap_or(i32::MAX))
}

impl<T: Transport> GrblSession<T> {
    /// Connect: drain what the controller sends (a start-up banner), ask `$I` for the version and buffer size,
    /// read `$$`. A device that does not answer like GRBL is an error naming what it sent.
    pub fn connect(mut transport: T, name: &str, profile: &MachineProfile) -> anyhow::Result<Self> {
        let mut heard = Vec::new();
        let mut version = None;
        let mut messages = Vec::new();
        // The start-up banner and messages: until a quiet 300 ms, for at most a second (a controller that reports
        // on its own, or a wrong port that babbles, must not hold the handshake).
        let end = transport.now() + Duration::from_secs(1);
        while transport.now() < end {
            if let Some(cause) = Stop::process().stop_cause_or_interrupt() {
                return Err(Stopped { cause, doing: format!("connecting to {name}") }.into());
            }
            let Some(l) = transport.recv_line(Duration::from_millis(300)).map_err(|e| transport_error(name, e))? else {
                break;
            };
            match GrblLine::parse(&l) {
                GrblLine::Banner(v) => version = Some(v),
                GrblLine::Msg(m) => messages.push(m),
                _ if !l.is_empty() && heard.len() < 5 => heard.push(l),
                _ => {}
            }
        }
        let mut s = GrblSession {
            transport,
            name: name.to_string(),
            version: version.unwrap_or_default(),
            rx_bytes: 128,
            settings: GrblSettings::default(),
            profile: profile.clone(),
            offset: None,
            messages,
            peak_in_flight: 0,
            hold_timeout: WAIT_STALL,
            reports_wpos: false,
        };
        let info = match s.command("$I", COMMAND_TIMEOUT) {
            Ok(info) => info,
            Err(e) => {
                let shown: Vec<String> = heard.iter().take(3).map(|l| format!("{l:?}")).collect();
                bail!("{name} does not answer like GRBL ($I: {e:#}); it sent: {}", shown.join(", "));
            }
        };
        for l in &info {
            if let Some(v) = l.strip_prefix("VER:") {
                s.version = v.split(':').next().unwrap_or(v).split('.').take(2).collect::<Vec<_>>().join(".");
            }
            if let Some(o) = l.strip_prefix("OPT:")
                && let Some(rx) = o.split(',').nth(2).and_then(|x| x.trim().parse::<usize>().ok())
                && rx >= 32
            {
                s.rx_bytes = rx;
            }
        }
        s.settings = s.read_settings()?;
        Ok(s)
    }

    /// Read `$$`.
    pub fn read_settings(&mut self) -> anyhow::Result<GrblSettings> {
        let mut settings = GrblSettings::default();
        self.transport.send(b"$$\n").map_err(|e| transport_error(&self.name, e))?;
        let deadline = self.transport.now() + COMMAND_TIMEOUT;
        loop {
            if self.transport.now() >= deadline {
                bail!("{}: no complete answer to $$ within {:.0} s", self.name, COMMAND_TIMEOUT.as_secs_f64());
            }
            let Some(l) = self.recv(deadline)? else { bail!("{}: no answer to $$", self.name) };
            match GrblLine::parse(&l) {
                GrblLine::Setting(k, v) => {
                    settings.values.insert(k, v);
                }
                GrblLine::Ok => return Ok(settings),
                GrblLine::Error(c) => bail!("{}: $$ refused: {}", self.name, describe_error(c)),
                GrblLine::Alarm(c) => bail!("{}: {}", self.name, describe_alarm(c)),
                GrblLine::Msg(m) => self.messages.push(m),
                _ => {}
            }
        }
    }

    fn recv(&mut self, deadline: Duration) -> anyhow::Result<Option<String>> {
        let left = deadline.saturating_sub(self.transport.now()).max(Duration::from_millis(1));
        self.transport.recv_line(left).map_err(|e| transport_error(&self.name, e))
    }

    /// Send one line and wait for its `ok`; returns the feedback lines (`[…]` without brackets) before it.
    pub fn command(&mut self, line: &str, timeout: Duration) -> anyhow::Result<Vec<String>> {
        self.command_within(line, timeout, false)
    }

    /// [`GrblSession::command`]; when `interruptible`, a stop (any signal) ends the wait with
    /// [`crate::stop::Stopped`].
    fn command_within(&mut self, line: &str, timeout: Duration, interruptible: bool) -> anyhow::Result<Vec<String>> {
        self.transport.send(format!("{line}\n").as_bytes()).map_err(|e| transport_error(&self.name, e))?;
        let deadline = self.transport.now() + timeout;
        let mut out = Vec::new();
        loop {
            if interruptible && let Some(cause) = Stop::process().stop_cause_or_interrupt() {
                return Err(
                    Stopped { cause, doing: format!("waiting for the answer to {line} from {}", self.name) }.into()
                );
            }
            // Checked before every read, not only after a quiet one: a line that babbles must not hold us.
            if self.transport.now() >= deadline {
                bail!("{}: no answer to {line:?} within {:.0} s", self.name, timeout.as_secs_f64());
            }
            let Some(l) = self.recv(deadline.min(self.transport.now() + Duration::from_millis(200)))? else {
                continue;
            };
            match GrblLine::parse(&l) {
                GrblLine::Ok => return Ok(out),
                GrblLine::Error(c) => bail!("{}: {line:?} refused: {}", self.name, describe_error(c)),
                GrblLine::Alarm(c) => bail!("{}: {} during {line:?}", self.name, describe_alarm(c)),
                GrblLine::Banner(_) => bail!("{}: the controller restarted during {line:?}", self.name),
                GrblLine::Msg(m) => {
                    out.push(format!("MSG:{m}"));
                    self.messages.push(m);
                }
                GrblLine::Feedback(f) => out.push(f),
                GrblLine::Setting(..) => out.push(l),
                GrblLine::Status(_) | GrblLine::Other(_) => {}
            }
        }
    }

    /// Ask for a status report and wait for it.
    pub fn status(&mut self) -> anyhow::Result<GrblStatus> {
        for _ in 0..3 {
            self.transport.send(&[RT_STATUS]).map_err(|e| transport_error(&self.name, e))?;
            let deadline = self.transport.now() + Duration::from_millis(1000);
            while let Some(l) = self.recv(deadline)? {
                match GrblLine::parse(&l) {
                    GrblLine::Status(s) => return Ok(s),
                    GrblLine::Alarm(c) => bail!("{}: {}", self.name, describe_alarm(c)),
                    GrblLine::Msg(m) => self.messages.push(m),
                    _ => {}
                }
                if self.transport.now() >= deadline {
                    break;
                }
            }
        }
        bail!("{}: no status report", self.name)
    }

    /// Whether the controller is in an alarm state.
    pub fn in_alarm(&mut self) -> anyhow::Result<bool> {
        Ok(self.status()?.state == "Alarm")
    }

    /// Unlock an alarm with `$X` (only after the user agreed: the position may be wrong).
    pub fn unlock(&mut self) -> anyhow::Result<()> {
        self.command("$X", COMMAND_TIMEOUT).map(|_| ())
    }

    /// Home with `$H` when homing is enabled (`$22=1`); without it, say that the current position is taken as
    /// the homed corner. Then declare the homed position as the plot's coordinates.
    pub fn home(&mut self) -> anyhow::Result<()> {
        if self.settings.homing_enabled() {
            if let Err(e) = self.command_within("$H", HOMING_TIMEOUT, true) {
                if e.downcast_ref::<Stopped>().is_some() {
                    // Stopped while homing: a soft reset ends the cycle where it is (GRBL then asks for `$H` again).
                    let reset = self.reset().map_or_else(|r| format!("; the reset failed: {r:#}"), |()| String::new());
                    return Err(e.context(format!("homing stopped (soft reset){reset}")));
                }
                return Err(e.context("homing ($H) failed"));
            }
        } else {
            eprintln!(
                "{}: homing is disabled on the controller ($22=0); the current position is taken as the home corner",
                self.name
            );
        }
        let home = plotter_path::motion::plan::homed_position(&self.profile)?;
        self.declare(home)
    }

    /// Declare that the machine stands at `pos` (steps of the plot's coordinates), with `G92`.
    pub fn declare(&mut self, pos: MachinePos) -> anyhow::Result<()> {
        self.command("G21", COMMAND_TIMEOUT)?;
        self.command("G90", COMMAND_TIMEOUT)?;
        self.command(&declare_position(&self.profile, pos), COMMAND_TIMEOUT)?;
        let s = self.wait_idle()?;
        let reported = s.mpos.or(s.wpos).context("status without a position")?;
        let spm =
            [self.profile.axes.x.steps_per_mm, self.profile.axes.y.steps_per_mm, self.profile.axes.z.steps_per_mm];
        self.offset = Some(core::array::from_fn(|i| reported[i] - f64::from(pos[i]) / spm[i]));
        Ok(())
    }

    /// The reported position's offset from the plot's coordinates, from `$#` when not declared in this session
    /// (`G54` + `G92`, plus the tool length offset on Z, for an `MPos` report; none for `WPos`).
    fn offset(&mut self, s: &GrblStatus) -> anyhow::Result<[f64; 3]> {
        if let Some(o) = self.offset {
            return Ok(o);
        }
        if s.mpos.is_none() {
            self.offset = Some([0.0; 3]);
            return Ok([0.0; 3]);
        }
        let lines = self.command("$#", COMMAND_TIMEOUT)?;
        let get = |key: &str| -> [f64; 3] {
            lines
                .iter()
                .find_map(|l| l.strip_prefix(key))
                .and_then(|v| {
                    let v: Vec<f64> = v.split([',', ':']).take(3).filter_map(|x| x.parse().ok()).collect();
                    <[f64; 3]>::try_from(v).ok()
                })
                .unwrap_or([0.0; 3])
        };
        let (g54, g92) = (get("G54:"), get("G92:"));
        let tlo: f64 = lines.iter().find_map(|l| l.strip_prefix("TLO:")).and_then(|v| v.parse().ok()).unwrap_or(0.0);
        let o = [g54[0] + g92[0], g54[1] + g92[1], g54[2] + g92[2] + tlo];
        self.offset = Some(o);
        Ok(o)
    }

    /// The position of a status report in steps of the plot's coordinates (E = 0).
    pub fn position_of(&mut self, s: &GrblStatus) -> anyhow::Result<MachinePos> {
        let r = s.mpos.or(s.wpos).context("status without a position")?;
        self.reports_wpos = s.mpos.is_none();
        let o = self.offset(s)?;
        let p = to_steps(&self.profile, core::array::from_fn(|i| r[i] - o[i]));
        Ok([p[0], p[1], p[2], 0])
    }

    /// Current position in steps of the plot's coordinates.
    pub fn position(&mut self) -> anyhow::Result<MachinePos> {
        let s = self.status()?;
        self.position_of(&s)
    }

    /// Poll the status until the machine is idle. A machine whose state and position stay the same for
    /// [`Self::hold_timeout`] (a feed hold nobody resumes) is an error naming its state, not an endless wait.
    pub fn wait_idle(&mut self) -> anyhow::Result<GrblStatus> {
        let mut last: Option<(String, Option<[f64; 3]>)> = None;
        let mut since = self.transport.now();
        loop {
            let s = self.status()?;
            if s.is_idle() {
                return Ok(s);
            }
            if s.state == "Alarm" {
                bail!("{}: the machine is in alarm", self.name);
            }
            let key = (s.state.clone(), s.mpos.or(s.wpos));
            if last.as_ref() == Some(&key) {
                let still = self.transport.now().saturating_sub(since);
                if still >= self.hold_timeout {
                    bail!("{} while waiting for the machine to finish", self.standstill(&s.state, still));
                }
            } else {
                last = Some(key);
                since = self.transport.now();
            }
            let _ = self.transport.recv_line(Duration::from_millis(50)).map_err(|e| transport_error(&self.name, e))?;
        }
    }

    /// What a standstill of `still` in `state` means, for an error message.
    fn standstill(&self, state: &str, still: Duration) -> String {
        if state.starts_with("Hold") {
            format!(
                "{}: the controller has been in a feed hold ({state}) for {:.0} s and nobody resumed it (its Hold \
                 button, or a `!` from another program; Cycle Start `~` resumes)",
                self.name,
                still.as_secs_f64()
            )
        } else {
            format!(
                "{}: nothing moved for {:.0} s while the controller reports {state}",
                self.name,
                still.as_secs_f64()
            )
        }
    }

    /// Whether two positions are the same for the plot (Z ignored for a servo pen).
    fn same(&self, a: &MachinePos, b: &MachinePos) -> bool {
        let axes = if self.profile.pen.uses_servo() { 2 } else { 3 };
        a[..axes] == b[..axes]
    }

    /// After the host lost a session: the first block of `full` not certainly executed. GRBL runs whatever it
    /// had accepted (and what was still in its buffer), so when the idle machine stands exactly where block k
    /// ends, for the last such k from the journal's executed count up to a buffer's worth past the accepted
    /// one, blocks before k are done; otherwise only the journal's executed count is certain.
    pub fn resume_point(&mut self, executed: usize, accepted: usize, full: &MotionPlan) -> anyhow::Result<usize> {
        if self.in_alarm()? {
            // Stopped by an alarm: where it stopped is not known, only the journal's executed count is certain.
            return Ok(executed);
        }
        let s = self.wait_idle()?;
        if self.offset.is_none() && s.mpos.is_some() {
            // The plot's G92 offset survives as long as the controller was not reset.
            let _ = self.offset(&s)?;
        }
        let pos = self.position_of(&s)?;
        let hi = (accepted + self.rx_bytes / 4).min(full.blocks.len());
        let mut p = full.start;
        let mut best = None;
        for (k, b) in full.blocks.iter().enumerate().take(hi) {
            for (x, d) in p.iter_mut().zip(b.block.steps) {
                *x += d;
            }
            if k + 1 >= executed && self.same(&p, &pos) {
                best = Some(k + 1);
            }
        }
        Ok(best.unwrap_or(executed).max(executed))
    }

    /// Stream `plan` (whose start is where the machine stands) line by line with character counting. Returns
    /// when every line has been executed (a status report asked for after the last `ok` says Idle); the same
    /// loop watches the tail, so a hold there is told and timed like one mid-plot.
    pub fn stream(&mut self, plan: &MotionPlan, control: &mut dyn Control) -> Result<StreamStats, StreamError> {
        // GRBL stops the motion for `M3` (its spindle sync): a drop planned on the way would land early.
        if let Some(i) = plan.servo_in_motion() {
            return Err(StreamError::Link(anyhow::anyhow!(
                "block {i}: the plan commands the pen servo while the carriage moves, which GRBL cannot do (it stops \
                 for M3); it was planned for another firmware"
            )));
        }
        let prog = program(&self.profile, plan);
        let n = prog.lines.len();
        let bytes: Vec<Vec<u8>> = prog.lines.iter().map(|l| format!("{l}\n").into_bytes()).collect();
        let limit = self.rx_bytes.saturating_sub(1);
        if let Some((i, b)) = bytes.iter().enumerate().find(|(_, b)| b.len() > limit.min(80)) {
            return Err(StreamError::Link(anyhow::anyhow!("line {i} is {} bytes, too long for GRBL", b.len())));
        }
        // Position after each block (steps).
        let mut ends = Vec::with_capacity(n);
        let mut p = plan.start;
        for b in &plan.blocks {
            for (x, d) in p.iter_mut().zip(b.block.steps) {
                *x += d;
            }
            ends.push(p);
        }
        let t0 = self.transport.now();
        let mut st = GrblStream {
            next: 0,
            acked: 0,
            executed: 0,
            in_flight: VecDeque::new(),
            in_bytes: 0,
            bytes_sent: 0,
            last_status_at: t0,
            last_heard: t0,
            status_pending: false,
            last_change: t0,
            report: None,
            hold_told: false,
            acked_at: t0,
            finished: n == 0,
        };
        self.peak_in_flight = 0;
        let mut pause_at: Option<usize> = None;
        let mut last_reported = None;
        let mut accept_elapsed = Duration::ZERO;
        self.transport.set_streaming(true);
        let result: Result<(), StreamError> = loop {
            let progress = Progress {
                accepted: st.acked,
                executed: st.executed,
                seq_after_accepted: u32::try_from(st.acked).unwrap_or(u32::MAX),
                resends: 0,
            };
            if last_reported != Some(progress) {
                control.progress(&progress);
                last_reported = Some(progress);
            }
            if st.acked == n && accept_elapsed.is_zero() {
                accept_elapsed = self.transport.now() - t0;
            }
            if st.finished {
                break Ok(());
            }
            let still = self.transport.now().saturating_sub(st.last_change);
            if still > self.hold_timeout {
                let state = st.report.as_ref().map_or("no state", |r| r.0.as_str());
                break Err(StreamError::Link(anyhow::anyhow!(
                    "{}; the plot stopped after {} executed block(s) ({} of {n} lines acknowledged)",
                    self.standstill(state, still),
                    st.executed,
                    st.acked
                )));
            }
            if let Some(cause) = control.stop_requested() {
                let why = cause.to_string();
                break Err(StreamError::StoppedAtOnce { name: self.name.clone(), why, executed: st.executed });
            }
            if let Some(now) = control.pause_requested() {
                let held = st.report.as_ref().map(|r| r.0.as_str()).filter(|s| s.starts_with("Hold"));
                if let Some(why) = stop_at_once(held, pause_at.is_some()) {
                    break Err(StreamError::StoppedAtOnce { name: self.name.clone(), why, executed: st.executed });
                }
                if now {
                    match self.hold(&mut st, plan, &ends, control) {
                        Ok(true) => st.last_change = self.transport.now(),
                        Ok(false) => break Err(StreamError::Aborted { executed: st.executed }),
                        Err(e) => break Err(e),
                    }
                } else {
                    let from = st.next.saturating_sub(1);
                    pause_at = Some((from..n).find(|&i| prog.safe_after[i]).unwrap_or(n - 1));
                }
            }
            if let Some(p) = pause_at
                && st.acked > p
            {
                if let Err(e) = self.wait_idle() {
                    break Err(StreamError::Link(e));
                }
                st.executed = st.acked;
                control.progress(&Progress { executed: st.executed, ..progress });
                pause_at = None;
                if control.paused(false) == PauseChoice::Abort {
                    break Err(StreamError::Aborted { executed: st.executed });
                }
                st.last_change = self.transport.now();
                continue;
            }
            let upto = pause_at.map_or(n, |p| p + 1);
            let mut send_error = None;
            while st.next < upto && st.in_bytes + bytes[st.next].len() <= limit {
                let b = &bytes[st.next];
                if let Err(e) = self.transport.send(b) {
                    send_error = Some(e);
                    break;
                }
                st.in_flight.push_back(b.len());
                st.in_bytes += b.len();
                st.bytes_sent += u64::try_from(b.len()).unwrap_or(u64::MAX);
                st.next += 1;
                self.peak_in_flight = self.peak_in_flight.max(st.in_bytes);
            }
            if let Some(e) = send_error {
                break Err(StreamError::Link(transport_error(&self.name, e)));
            }
            self.transport.set_streaming(st.next < n);
            let now = self.transport.now();
            if !st.status_pending && now.saturating_sub(st.last_status_at) >= STATUS_EVERY {
                if let Err(e) = self.transport.send(&[RT_STATUS]) {
                    break Err(StreamError::Link(transport_error(&self.name, e)));
                }
                st.status_pending = true;
                st.last_status_at = now;
            }
            let line = match self.transport.recv_line(STATUS_EVERY) {
                Ok(l) => l,
                Err(e) => break Err(StreamError::Link(transport_error(&self.name, e))),
            };
            let now = self.transport.now();
            let Some(line) = line else {
                if now.saturating_sub(st.last_heard) > SILENCE {
                    break Err(StreamError::Link(anyhow::anyhow!(
                        "{}: the controller stopped answering ({} of {n} lines acknowledged)",
                        self.name,
                        st.acked
                    )));
                }
                if now.saturating_sub(st.last_status_at) > SILENCE / 2 {
                    // A status request lost on the way: ask again.
                    st.status_pending = false;
                }
                continue;
            };
            st.last_heard = now;
            match GrblLine::parse(&line) {
                GrblLine::Ok => {
                    if let Some(len) = st.in_flight.pop_front() {
                        st.in_bytes -= len;
                        st.acked += 1;
                        st.last_change = now;
                        st.acked_at = now;
                    }
                }
                GrblLine::Error(code) => {
                    let bad = st.acked;
                    let stopped = self.stop_after_error(&mut st, plan.start, &ends);
                    let mut msg = format!(
                        "{}: GRBL refused line {} of {n} ({:?}): {}; the plot stopped after {} executed block(s)",
                        self.name,
                        bad + 1,
                        prog.lines[bad],
                        describe_error(code),
                        st.executed
                    );
                    if let Err(e) = stopped {
                        msg += &format!(" ({e:#})");
                    }
                    break Err(StreamError::Link(anyhow::anyhow!(msg)));
                }
                GrblLine::Alarm(code) => {
                    let (text, kept) = alarm_meaning(code);
                    let mut text = text.to_string();
                    if !kept {
                        text += "; a resume homes again";
                    }
                    break Err(StreamError::Alarm { code, text, executed: st.executed });
                }
                GrblLine::Banner(_) => break Err(StreamError::Restarted { executed: st.executed }),
                GrblLine::Status(s) => {
                    st.status_pending = false;
                    let pos = self.position_of(&s).ok();
                    if let Some(pos) = pos {
                        st.executed = st.executed.max(self.executed_at(&pos, &s, &st, plan, &ends));
                    }
                    let report = (s.state.clone(), pos);
                    if st.report.as_ref() != Some(&report) {
                        st.last_change = now;
                        st.report = Some(report);
                    }
                    let held = s.state.starts_with("Hold");
                    if held && !st.hold_told {
                        control.notice(&format!(
                            "{}: the controller reports a feed hold ({}), from its Hold button or a `!` sent by \
                             another program: Cycle Start (`~`) resumes; a pause request (Ctrl-C) stops the plot and \
                             lifts the pen; the plot stops by itself after {:.0} s on hold",
                            self.name,
                            s.state,
                            self.hold_timeout.as_secs_f64()
                        ));
                    }
                    st.hold_told = held;
                    // Asked for after the last line was acknowledged: everything has run.
                    if s.is_idle() && st.acked == n && st.last_status_at >= st.acked_at {
                        st.finished = true;
                    }
                }
                GrblLine::Msg(m) => self.messages.push(m),
                GrblLine::Feedback(_) | GrblLine::Setting(..) | GrblLine::Other(_) => {}
            }
        };
        self.transport.set_streaming(false);
        result?;
        st.executed = n;
        control.progress(&Progress {
            accepted: n,
            executed: n,
            seq_after_accepted: u32::try_from(n).unwrap_or(u32::MAX),
            resends: 0,
        });
        Ok(StreamStats {
            frames: n,
            frame_bytes: bytes.iter().map(Vec::len).sum(),
            bytes_sent: st.bytes_sent,
            resends: 0,
            resyncs: 0,
            noise_errors: 0,
            damaged_replies: 0,
            elapsed: self.transport.now() - t0,
            accept_elapsed,
            underruns: self.transport.underruns(),
        })
    }

    /// Blocks certainly executed given a status report at `pos`: an idle machine with nothing in flight has done
    /// everything acknowledged; otherwise the first block between the last executed and the last acknowledged
    /// one whose segment holds the position is the one running (or, if the position is its end, done).
    fn executed_at(
        &self,
        pos: &MachinePos,
        s: &GrblStatus,
        st: &GrblStream,
        plan: &MotionPlan,
        ends: &[MachinePos],
    ) -> usize {
        if s.is_idle() && st.in_flight.is_empty() {
            return st.acked;
        }
        for i in st.executed..st.acked {
            let a = if i == 0 { plan.start } else { ends[i - 1] };
            let b = ends[i];
            if self.same(&a, &b) {
                // A dwell (or a pen move for a servo): not certainly over.
                if self.same(pos, &a) {
                    return i;
                }
                continue;
            }
            if self.same(pos, &b) {
                return i + 1;
            }
            if on_segment(pos, &a, &b) {
                return i;
            }
        }
        st.executed
    }

    /// Feed hold now: wait for the stop, ask the user; resume with `~` (true) or abort with a soft reset, which
    /// keeps the position of a stopped machine (false).
    fn hold(
        &mut self,
        st: &mut GrblStream,
        plan: &MotionPlan,
        ends: &[MachinePos],
        control: &mut dyn Control,
    ) -> Result<bool, StreamError> {
        self.transport.send(&[RT_FEED_HOLD]).map_err(|e| StreamError::Link(transport_error(&self.name, e)))?;
        let deadline = self.transport.now() + COMMAND_TIMEOUT;
        loop {
            let s = self.status().map_err(StreamError::Link)?;
            if let Ok(pos) = self.position_of(&s) {
                st.executed = st.executed.max(self.executed_at(&pos, &s, st, plan, ends));
            }
            if s.is_held() || s.is_idle() {
                break;
            }
            if s.state == "Alarm" || self.transport.now() >= deadline {
                return Err(StreamError::Link(anyhow::anyhow!(
                    "{}: the feed hold did not come to a stop within {:.0} s (the controller reports {})",
                    self.name,
                    COMMAND_TIMEOUT.as_secs_f64(),
                    s.state
                )));
            }
            let _ = self.transport.recv_line(Duration::from_millis(20));
        }
        if control.paused(true) == PauseChoice::Abort {
            self.reset().map_err(StreamError::Link)?;
            return Ok(false);
        }
        self.transport.send(&[RT_CYCLE_START]).map_err(|e| StreamError::Link(transport_error(&self.name, e)))?;
        Ok(true)
    }

    /// After an `error:`: GRBL skips the refused line and would run the following ones, so hold, note where the
    /// machine stopped, and soft-reset to drop the rest.
    fn stop_after_error(&mut self, st: &mut GrblStream, start: MachinePos, ends: &[MachinePos]) -> anyhow::Result<()> {
        self.transport.send(&[RT_FEED_HOLD]).map_err(|e| transport_error(&self.name, e))?;
        let deadline = self.transport.now() + COMMAND_TIMEOUT;
        loop {
            let s = self.status()?;
            if s.is_held() || s.is_idle() {
                let pos = self.position_of(&s)?;
                // Only the lines before the refused one are the plan; find where it stopped among them.
                let bad = st.acked;
                let mut done = st.executed;
                for i in st.executed..bad {
                    let a = if i == 0 { start } else { ends[i - 1] };
                    if self.same(&ends[i], &pos) {
                        done = i + 1;
                    } else if on_segment(&pos, &a, &ends[i]) {
                        // Held in the middle of block i.
                        done = i;
                        break;
                    }
                }
                st.executed = done;
                break;
            }
            if self.transport.now() >= deadline {
                bail!("the machine did not stop");
            }
            let _ = self.transport.recv_line(Duration::from_millis(20));
        }
        self.reset()
    }

    /// Soft reset (Ctrl-X) and wait for the banner; GRBL drops its buffers (and G92 offsets: with work-position
    /// reports the offset is re-measured from `$#` afterwards).
    pub fn reset(&mut self) -> anyhow::Result<()> {
        self.transport.send(&[RT_RESET]).map_err(|e| transport_error(&self.name, e))?;
        let deadline = self.transport.now() + COMMAND_TIMEOUT;
        while let Some(l) = self.recv(deadline)? {
            if let GrblLine::Banner(_) = GrblLine::parse(&l) {
                // The reset drops the `G92` offset: a work position changes with it, a machine position does not
                // (and still converts to the plot's coordinates with the offset measured before).
                if self.reports_wpos {
                    self.offset = None;
                }
                // Let the banner's follow-up messages arrive (a quiet 100 ms, at most a second of talk).
                let end = self.transport.now() + Duration::from_secs(1);
                while self.transport.now() < end
                    && let Some(l) = self
                        .transport
                        .recv_line(Duration::from_millis(100))
                        .map_err(|e| transport_error(&self.name, e))?
                {
                    if let GrblLine::Msg(m) = GrblLine::parse(&l) {
                        self.messages.push(m);
                    }
                }
                return Ok(());
            }
            if self.transport.now() >= deadline {
                break;
            }
        }
        bail!("{}: no banner after the soft reset", self.name)
    }

    /// End a plot that stopped early with the pen up, whatever state the controller is in: bring motion to rest
    /// with a feed hold (a reset at `Hold:0` keeps the position, during motion it raises `ALARM:3`), soft-reset
    /// to drop what is still queued, unlock with `$X` when GRBL is in alarm, and lift the pen with the plot's own
    /// pen-up command ([`lift`]). Returns what was done, for the user. When the controller cannot be commanded
    /// the error says what to do by hand.
    pub fn stop_and_lift(&mut self) -> anyhow::Result<String> {
        self.try_stop_and_lift().map_err(|e| {
            let lift = if self.profile.pen.uses_servo() {
                format!("send `M3 S{}` (the pen-up angle)", self.profile.pen.servo_up_deg)
            } else {
                format!("raise Z to the pen-up height ({} mm)", self.profile.pen.up_z_mm)
            };
            e.context(format!(
                "could not lift the pen, which may still be on the paper: press the controller's Reset (or \
                 power it off), lift the pen by hand, or unlock it with `$X` and {lift}; home before plotting again"
            ))
        })
    }

    fn try_stop_and_lift(&mut self) -> anyhow::Result<String> {
        let mut done = Vec::new();
        // A controller stopped by a limit switch answers nothing but a reset (and perhaps status reports), so a
        // missing report is no reason to stop here.
        let mut before = self.status().ok();
        if let Some(s) = &before
            && matches!(s.state.as_str(), "Run" | "Jog" | "Hold:1")
        {
            if s.state != "Hold:1" {
                self.transport.send(&[RT_FEED_HOLD]).map_err(|e| transport_error(&self.name, e))?;
            }
            let deadline = self.transport.now() + COMMAND_TIMEOUT;
            loop {
                let s = self.status()?;
                let rest = s.is_held() || s.is_idle() || s.state == "Alarm";
                before = Some(s);
                if rest || self.transport.now() >= deadline {
                    break;
                }
                let _ =
                    self.transport.recv_line(Duration::from_millis(20)).map_err(|e| transport_error(&self.name, e))?;
            }
            done.push("feed hold");
        }
        // Where the pen is, while the offsets of the plot still hold.
        let z_before = match &before {
            Some(s) if s.mpos.is_some() || s.wpos.is_some() => self.position_of(s).ok().map(|p| p[2]),
            _ => None,
        };
        self.reset()?;
        done.push("soft reset");
        let s = self.status()?;
        if s.state == "Alarm" {
            self.unlock()?;
            done.push("unlocked with $X (home before the next plot: the position may be lost)");
        }
        let s = self.status()?;
        if !s.is_idle() {
            bail!("{}: the controller reports {} after the reset and will not take the lift", self.name, s.state);
        }
        let z = match z_before {
            Some(z) => z,
            None => self.position_of(&s)?[2],
        };
        let lines = lift(&self.profile, z)?;
        for l in &lines {
            self.command(l, COMMAND_TIMEOUT)?;
        }
        let after = self.wait_idle()?;
        if !self.profile.pen.uses_servo() && !lines.is_empty() {
            // Check the move by what it changed in the reported Z (whichever frame the reports use).
            let raw_z = |s: &GrblStatus| s.mpos.or(s.wpos).map_or(0.0, |p| p[2]);
            let moved = to_steps(&self.profile, [0.0, 0.0, raw_z(&after) - raw_z(&s)])[2];
            let up = plotter_path::motion::plan::homed_position(&self.profile)?[2];
            if z + moved != up {
                bail!(
                    "{}: after the lift Z stands at {:.3} mm, not at the pen-up height {} mm",
                    self.name,
                    f64::from(z + moved) / self.profile.axes.z.steps_per_mm,
                    self.profile.pen.up_z_mm
                );
            }
        }
        let what = if lines.is_empty() {
            "the pen was already up".to_string()
        } else {
            format!("the pen is up ({})", lines.join(", "))
        };
        Ok(format!("{}: stopped ({}); {what}", self.name, done.join(", ")))
    }
}

/// Streaming state.
struct GrblStream {
    next: usize,
    acked: usize,
    executed: usize,
    in_flight: VecDeque<usize>,
    in_bytes: usize,
    bytes_sent: u64,
    last_status_at: Duration,
    last_heard: Duration,
    status_pending: bool,
    /// When a line was last acknowledged or a status report last differed from the one before.
    last_change: Duration,
    /// The last status report's state and position (steps of the plot's coordinates, if readable).
    report: Option<(String, Option<MachinePos>)>,
    /// Whether the user has been told about the feed hold the controller is in.
    hold_told: bool,
    /// When the last line was acknowledged.
    acked_at: Duration,
    /// Whether a status report asked for after the last acknowledgement said Idle: the plan has run.
    finished: bool,
}

/// Whether `p` lies on the segment `a`–`b` (within one step of it, between its ends).
fn on_segment(p: &MachinePos, a: &MachinePos, b: &MachinePos) -> bool {
    let d: [f64; 3] = core::array::from_fn(|i| f64::from(b[i] - a[i]));
    let q: [f64; 3] = core::array::from_fn(|i| f64::from(p[i] - a[i]));
    let len2: f64 = d.iter().map(|x| x * x).sum();
    if len2 == 0.0 {
        return q.iter().all(|x| *x == 0.0);
    }
    let t = d.iter().zip(&q).map(|(x, y)| x * y).sum::<f64>() / len2;
    if !(0.0..=1.0).contains(&t) {
        return false;
    }
    let dist2: f64 = d.iter().zip(&q).map(|(x, y)| (y - t * x).powi(2)).sum();
    dist2 <= 1.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::grbl::emulator::{Faults, GrblEmulator, RX_USABLE};
    use crate::link::grbl::emulator_transport::EmulatorTransport;
    use crate::link::grbl::settings::GrblSettings;
    use crate::link::stream::tests::Record;
    use plotter_path::geometry::steps::{StepDrawing, drawing_to_steps};
    use plotter_path::kurbo::Point;
    use plotter_path::motion::plan::{Lookahead, homed_position, plan as make_plan};
    use plotter_path::{Drawing, Polyline};

    /// Ten 10 mm squares and a circle of 2 mm chords: every segment takes far longer to draw (≥ 2 mm at 60 mm/s
    /// = 33 ms) than its line takes on a 115200-baud wire (< 2 ms), so a fast-enough link never starves.
    fn drawing() -> StepDrawing {
        let square = |x: f64| {
            Polyline::new(vec![
                Point::new(x, 10.0),
                Point::new(x + 10.0, 10.0),
                Point::new(x + 10.0, 20.0),
                Point::new(x, 20.0),
                Point::new(x, 10.0),
            ])
        };
        let mut paths: Vec<Polyline> = (0..10).map(|i| square(10.0 + 15.0 * f64::from(i))).collect();
        let circle: Vec<Point> = (0..=94)
            .map(|i| {
                let a = f64::from(i) * std::f64::consts::TAU / 94.0;
                Point::new(100.0 + 30.0 * a.cos(), 80.0 + 30.0 * a.sin())
            })
            .collect();
        paths.push(Polyline::new(circle));
        drawing_to_steps(&MachineProfile::default_plotter(), &Drawing::single_layer("d", paths)).unwrap()
    }

    fn session(faults: Faults) -> GrblSession<EmulatorTransport> {
        let profile = MachineProfile::default_plotter();
        let cfg = plotter_path::motion::plan::machine_config(&profile).unwrap();
        let emu = GrblEmulator::with_settings(cfg, GrblSettings::for_profile(&profile), Some(115_200), faults);
        GrblSession::connect(EmulatorTransport::new(emu), "emulator", &profile).unwrap()
    }

    #[test]
    fn connect_reads_version_buffer_and_settings() {
        let s = session(Faults::default());
        assert_eq!((s.version.as_str(), s.rx_bytes), ("1.1h", 128));
        assert_eq!(s.settings.get(100), Some(80.0));
        assert!(s.settings.homing_enabled());
        assert!(s.messages.iter().any(|m| m.contains("to unlock")), "{:?}", s.messages);
    }

    #[test]
    fn streams_within_the_buffer_without_starving_and_ends_exactly() {
        let mut s = session(Faults::default());
        s.home().unwrap();
        let profile = MachineProfile::default_plotter();
        let home = homed_position(&profile).unwrap();
        assert_eq!(s.position().unwrap(), home);
        let steps = drawing();
        let plan = make_plan(&profile, &steps, home, Lookahead::Whole).unwrap();
        let mut rec = Record::default();
        let stats = s.stream(&plan, &mut rec).unwrap();
        let emu = s.transport.emulator();
        assert_eq!(emu.stats().overflow_bytes, 0);
        assert!(emu.stats().peak_rx <= RX_USABLE && s.peak_in_flight <= RX_USABLE, "{}", s.peak_in_flight);
        assert!(s.peak_in_flight > 100, "the buffer is used: {}", s.peak_in_flight);
        assert_eq!(stats.underruns, Some(0), "the planner never starved");
        assert_eq!(stats.frames, plan.blocks.len());
        // The last stroke is the circle: it ends where it began, at (130, 80) mm = (10400, 6400) steps, pen up
        // (4 mm × 400 steps/mm).
        let end = steps.strokes.last().unwrap().end();
        assert_eq!((end.x, end.y), (10_400, 6_400));
        let p = emu.backend().machine().stepper().position();
        assert_eq!([p[0], p[1], p[2]], [10_400, 6_400, 1_600]);
        assert_eq!(emu.backend().physical_position()[..3], [10_400, 6_400, 1_600]);
        // Executed progress comes from the reported position: it runs behind the acknowledged lines and is
        // exact at the end.
        assert!(rec.0.windows(2).all(|w| w[0].executed <= w[1].executed && w[1].executed <= w[1].accepted));
        assert!(rec.0.iter().any(|p| p.executed > 0 && p.executed < p.accepted), "position-based progress");
        assert_eq!(rec.0.last().map(|p| (p.accepted, p.executed)), Some((plan.blocks.len(), plan.blocks.len())));
    }

    fn plan_for(s: &mut GrblSession<EmulatorTransport>) -> MotionPlan {
        s.home().unwrap();
        let profile = MachineProfile::default_plotter();
        make_plan(&profile, &drawing(), s.position().unwrap(), Lookahead::Whole).unwrap()
    }

    #[test]
    fn an_alarm_stops_the_stream_with_its_meaning() {
        let mut s = session(Faults { hard_limit_after_lines: Some(60), ..Faults::default() });
        let plan = plan_for(&mut s);
        let mut rec = Record::default();
        match s.stream(&plan, &mut rec) {
            Err(StreamError::Alarm { code: 1, text, executed }) => {
                assert!(text.contains("hard limit") && text.contains("homes again"), "{text}");
                // 3 set-up lines, so 57 plan lines were acknowledged; fewer were certainly executed.
                assert!(executed <= 57, "{executed}");
            }
            other => panic!("{:?}", other.map(|s| s.frames)),
        }
    }

    #[test]
    fn a_refused_line_stops_the_plot_and_names_the_error() {
        // Line 3 (G21, G90, G92) + 40 = plan line 40.
        let mut s = session(Faults { error_on_line: Some((43, 33)), ..Faults::default() });
        let plan = plan_for(&mut s);
        let e = s.stream(&plan, &mut Record::default()).unwrap_err().to_string();
        assert!(e.contains("refused line 40 of") && e.contains("error:33 (invalid motion target)"), "{e}");
        // The machine was held and reset: nothing after the refused line ran.
        let p = s.transport.emulator().backend().machine().stepper().position();
        assert!(e.contains("stopped after"), "{e}");
        assert!(s.transport.emulator().motion_idle());
        let executed: usize = e.split("stopped after ").nth(1).unwrap().split(' ').next().unwrap().parse().unwrap();
        assert!(executed <= 39 && executed > 20, "{executed}");
        // The hold stopped inside block `executed` (or at its end): blocks before it are done, it is not.
        let (a, b) = (plan.position_after(executed - 1), plan.position_after(executed));
        let q = [p[0], p[1], p[2], 0];
        assert!(on_segment(&q, &a, &b) && q != b, "{q:?} on {a:?}..{b:?}");
    }

    /// A user at the terminal: sees notices, presses Ctrl-C (a pause request at the next pen-up) after a notice
    /// or once `at` blocks have been executed, `presses` times in a row; aborts at a pause.
    #[derive(Default)]
    struct User {
        notices: Vec<String>,
        after_notice: bool,
        at: Option<usize>,
        presses: u32,
        executed: usize,
    }

    impl Control for User {
        fn progress(&mut self, p: &Progress) {
            self.executed = p.executed;
        }
        fn pause_requested(&mut self) -> Option<bool> {
            let due = (self.after_notice && !self.notices.is_empty()) || self.at.is_some_and(|a| self.executed >= a);
            if due && self.presses > 0 {
                self.presses -= 1;
                return Some(false);
            }
            None
        }
        fn paused(&mut self, _: bool) -> PauseChoice {
            PauseChoice::Abort
        }
        fn notice(&mut self, text: &str) {
            self.notices.push(text.to_string());
        }
    }

    /// The emulator's pen Z (steps) and X, Y (steps).
    fn pen_and_xy(s: &GrblSession<EmulatorTransport>) -> (i64, [i64; 2]) {
        let p = s.transport.emulator().backend().physical_position();
        (s.transport.emulator().pen().z_steps, [p[0], p[1]])
    }

    /// G-code line 60 (the plan's 58th, after G21 and G90) is acknowledged while a square is being drawn, pen
    /// down (each test checks the pen before lifting it).
    const PRESS_AT: u64 = 60;

    #[test]
    fn a_hold_nobody_resumes_ends_with_a_message_and_the_pen_up() {
        let mut s = session(Faults { realtime_after_lines: Some((PRESS_AT, RT_FEED_HOLD)), ..Faults::default() });
        s.hold_timeout = Duration::from_secs(3);
        let plan = plan_for(&mut s);
        let mut user = User::default();
        let t0 = s.transport.now();
        let e = s.stream(&plan, &mut user).unwrap_err().to_string();
        let waited = s.transport.now() - t0;
        assert!(
            e.contains("emulator: the controller has been in a feed hold (Hold:0) for 3 s and nobody resumed it"),
            "{e}"
        );
        assert!(e.contains("the plot stopped after"), "{e}");
        assert!(waited < Duration::from_secs(12), "{waited:?}");
        assert_eq!(user.notices.len(), 1, "told once: {:?}", user.notices);
        assert!(user.notices[0].contains("reports a feed hold (Hold:0)") && user.notices[0].contains("after 3 s"));
        // Held with the pen on the paper.
        let (z, xy) = pen_and_xy(&s);
        assert_eq!(z, 0);
        let done = s.stop_and_lift().unwrap();
        assert_eq!(done, "emulator: stopped (soft reset); the pen is up (G91 G0 Z4, G90)");
        // A reset at Hold:0 raises no alarm and keeps the position: only Z moved, up to 4 mm.
        assert_eq!(pen_and_xy(&s), (1600, xy));
        assert!(s.status().unwrap().is_idle());
    }

    #[test]
    fn a_soft_reset_mid_plot_ends_with_alarm_3_and_the_pen_up() {
        let mut s = session(Faults { realtime_after_lines: Some((PRESS_AT, RT_RESET)), ..Faults::default() });
        let plan = plan_for(&mut s);
        match s.stream(&plan, &mut User::default()) {
            Err(e @ StreamError::Alarm { code: 3, .. }) => {
                let e = e.to_string();
                assert!(e.contains("alarm 3 (reset while moving; the position is probably lost"), "{e}");
            }
            other => panic!("{:?}", other.map(|s| s.frames)),
        }
        let (z, xy) = pen_and_xy(&s);
        assert_eq!(z, 0, "the reset does not move Z: the pen stays on the paper");
        let done = s.stop_and_lift().unwrap();
        assert_eq!(
            done,
            "emulator: stopped (soft reset, unlocked with $X (home before the next plot: the position may be lost)); \
             the pen is up (G91 G0 Z4, G90)"
        );
        assert_eq!(pen_and_xy(&s), (1600, xy));
    }

    #[test]
    fn an_alarm_mid_plot_ends_with_the_pen_up() {
        let mut s = session(Faults { hard_limit_after_lines: Some(PRESS_AT), ..Faults::default() });
        let plan = plan_for(&mut s);
        let e = s.stream(&plan, &mut User::default()).unwrap_err().to_string();
        assert!(e.contains("alarm 1 (hard limit switch triggered"), "{e}");
        let (z, xy) = pen_and_xy(&s);
        assert_eq!(z, 0);
        // GRBL waits for a reset after a hard limit; then `$X`, then the lift.
        let done = s.stop_and_lift().unwrap();
        assert!(done.contains("soft reset, unlocked with $X") && done.ends_with("the pen is up (G91 G0 Z4, G90)"));
        assert_eq!(pen_and_xy(&s), (1600, xy));
    }

    #[test]
    fn ctrl_c_while_held_stops_at_once_and_lifts_the_pen() {
        let mut s = session(Faults { realtime_after_lines: Some((PRESS_AT, RT_FEED_HOLD)), ..Faults::default() });
        let plan = plan_for(&mut s);
        let mut user = User { after_notice: true, presses: 1, ..User::default() };
        let t0 = s.transport.now();
        let e = s.stream(&plan, &mut user).unwrap_err().to_string();
        assert!(e.contains("emulator: stopped at once on a pause request (Ctrl-C) during a feed hold (Hold:"), "{e}");
        // At once: well within the 30 s a hold may last.
        assert!(s.transport.now() - t0 < Duration::from_secs(10));
        assert_eq!(pen_and_xy(&s).0, 0);
        let done = s.stop_and_lift().unwrap();
        assert!(done.ends_with("the pen is up (G91 G0 Z4, G90)"), "{done}");
        assert_eq!(pen_and_xy(&s).0, 1600);
    }

    #[test]
    fn a_second_ctrl_c_stops_at_once_without_an_alarm() {
        let mut s = session(Faults::default());
        let plan = plan_for(&mut s);
        // Two presses while the second square's pen-down stroke runs.
        let mut user = User { at: Some(13), presses: 2, ..User::default() };
        let e = s.stream(&plan, &mut user).unwrap_err().to_string();
        assert!(
            e.contains("stopped at once on a second pause request (Ctrl-C) before the pause at the next pen-up"),
            "{e}"
        );
        assert!(pen_and_xy(&s).0 < 1600, "stopped with the pen down");
        // Running: held first, so the reset keeps the position (no alarm, no `$X`); the lift goes from wherever
        // the hold stopped Z (it may have been on its way up).
        let done = s.stop_and_lift().unwrap();
        assert!(done.starts_with("emulator: stopped (feed hold, soft reset); the pen is up (G91 G0 Z"), "{done}");
        assert_eq!(pen_and_xy(&s).0, 1600);
    }

    #[test]
    fn a_servo_pen_is_lifted_with_m3_at_its_up_angle_after_a_reset() {
        let mut profile = MachineProfile::default_plotter();
        profile.pen.command = plotter_path::config::profile::PenCommand::Servo;
        (profile.pen.servo_up_deg, profile.pen.servo_down_deg) = (90.0, 25.0);
        // Planned for GRBL, which stops the motion for `M3`.
        profile.servo_sync = plotter_path::motion::servo::ServoSync::AtRest;
        let cfg = plotter_path::motion::plan::machine_config(&profile).unwrap();
        // Plan lines: `M3 S90 G4 …`, then per square travel, `M3 S25 G4 …`, four strokes, `M3 S90 G4 …`. The servo acts
        // once the queue has run empty, so the `ok` of G-code line 20 (G21, G90, then the third square's first
        // stroke) comes with the pen down.
        let faults = Faults { realtime_after_lines: Some((20, RT_RESET)), ..Faults::default() };
        let emu = GrblEmulator::with_settings(cfg, GrblSettings::for_profile(&profile), Some(115_200), faults);
        let mut s = GrblSession::connect(EmulatorTransport::new(emu), "emulator", &profile).unwrap();
        s.home().unwrap();
        let plan = make_plan(&profile, &drawing(), s.position().unwrap(), Lookahead::Whole).unwrap();
        let e = s.stream(&plan, &mut User::default()).unwrap_err().to_string();
        assert!(e.contains("alarm 3"), "{e}");
        // The reset switched the spindle output off: the servo got no new pulse and holds the pen down.
        assert_eq!(s.transport.emulator().pen().servo_deg, Some(25.0));
        let done = s.stop_and_lift().unwrap();
        assert!(done.ends_with(
            "unlocked with $X (home before the next plot: the position may be lost)); the pen is up (M3 S90)"
        ));
        assert_eq!(s.transport.emulator().pen().servo_deg, Some(90.0));
    }

    /// A session on `/dev/ttyUSB0` whose port goes away after 1500 bytes.
    fn vanishing_session() -> GrblSession<EmulatorTransport> {
        let profile = MachineProfile::default_plotter();
        let cfg = plotter_path::motion::plan::machine_config(&profile).unwrap();
        let emu =
            GrblEmulator::with_settings(cfg, GrblSettings::for_profile(&profile), Some(115_200), Faults::default());
        GrblSession::connect(EmulatorTransport::new(emu).vanish_after(1500), "/dev/ttyUSB0", &profile).unwrap()
    }

    #[test]
    fn a_silent_controller_is_reported_with_what_to_do() {
        let mut s = vanishing_session();
        let plan = plan_for(&mut s);
        let _ = s.stream(&plan, &mut User::default()).unwrap_err();
        let e = format!("{:#}", s.stop_and_lift().unwrap_err());
        assert!(e.starts_with("could not lift the pen, which may still be on the paper: press the controller's Reset"));
        assert!(e.contains("raise Z to the pen-up height (4 mm)") && e.contains("lost the connection"), "{e}");
    }

    #[test]
    fn a_vanished_port_is_a_clear_error() {
        let mut s = vanishing_session();
        let plan = plan_for(&mut s);
        let e = s.stream(&plan, &mut Record::default()).unwrap_err().to_string();
        assert!(e.contains("lost the connection to /dev/ttyUSB0") && e.contains("unplugged"), "{e}");
    }

    /// A GRBL controller behind a line that babbles as `kind` from the start.
    fn babbling(kind: crate::link::babble::BabbleKind) -> crate::link::babble::Babbling<EmulatorTransport> {
        let profile = MachineProfile::default_plotter();
        let cfg = plotter_path::motion::plan::machine_config(&profile).unwrap();
        let emu =
            GrblEmulator::with_settings(cfg, GrblSettings::for_profile(&profile), Some(115_200), Faults::default());
        crate::link::babble::Babbling::new(EmulatorTransport::new(emu), crate::link::babble::Babble::new(kind, 0))
    }

    #[test]
    fn a_controller_behind_chatter_connects_homes_and_plots_and_a_mute_one_is_given_up_in_seconds() {
        use crate::link::babble::BabbleKind;
        let profile = MachineProfile::default_plotter();
        // A line of noise every 20 ms (a controller set to report on its own): the start-up listen ends after a
        // second however much it says, and the answers are found between the noise.
        let mut s = GrblSession::connect(babbling(BabbleKind::Chatter), "emulator", &profile).unwrap();
        assert_eq!(s.rx_bytes, 128);
        s.home().unwrap();
        let plan = plan_for_babbling(&mut s);
        s.stream(&plan, &mut User::default()).unwrap();
        assert!(s.transport.babble().babbled > 50, "{}", s.transport.babble().babbled);
        // Mute but for a blank line every millisecond: no answer to `$I`, given up within its timeout.
        let t = babbling(BabbleKind::Blank);
        let e = GrblSession::connect(t, "/dev/ttyUSB1", &profile).err().unwrap().to_string();
        assert!(e.contains("/dev/ttyUSB1 does not answer like GRBL") && e.contains("$I"), "{e}");
        // And the firmware detection gives up listening too (it finds nothing: our firmware is the default).
        let mut t = babbling(BabbleKind::Blank);
        assert_eq!(crate::link::machine::detect(&mut t).unwrap(), crate::link::machine::Firmware::Ours);
        assert!(t.now() <= Duration::from_secs(5), "{:?}", t.now());
    }

    fn plan_for_babbling(s: &mut GrblSession<crate::link::babble::Babbling<EmulatorTransport>>) -> MotionPlan {
        make_plan(&MachineProfile::default_plotter(), &drawing(), s.position().unwrap(), Lookahead::Whole).unwrap()
    }
}
