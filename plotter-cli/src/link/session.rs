//! A session with the firmware over a [`Transport`]: handshake (firmware info and buffer sizes from `M115`),
//! plain G-code commands answered by `ok`/`error:`, the real-time status report, homing.

use std::time::Duration;

use anyhow::{Context as _, bail};
use plotter_fw::framing::{self, rt_sequence};
use plotter_fw::protocol::{RT_FEED_HOLD, RT_STATUS, Reply};

use super::Transport;
use super::refused::Refused;
use super::wait::{Wait, WaitError};

/// What the firmware says about itself.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FirmwareInfo {
    /// Firmware version.
    pub version: String,
    /// Receive buffer, bytes: the most the host may have in flight.
    pub rx_bytes: usize,
    /// Planner queue length, blocks.
    pub queue_blocks: usize,
    /// Protocol version (2 and later have framed mode, see `plotter_fw::framing`).
    pub protocol: u32,
}

/// One line received from the firmware.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Incoming {
    /// A reply to act on: a framed line whose CRC verified (with its number), or any line in plain mode (no
    /// number), or a plain start banner in framed mode (a reset ends framed mode).
    Reply(Option<u32>, String),
    /// In framed mode, a line that does not verify: damaged on the way, never acted on.
    Damaged(String),
}

/// A parsed status report `<State|MPos:..|Steps:x,y,z,e|Q:used/size|N:seq|C:completed>` (`C:` is optional:
/// firmwares before it report no completed-block count; a trailing `|R:<n>,<code>` after a refused step block is
/// not needed here: the refusal's own `error:` stops the stream).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Status {
    /// `Idle`, `Run`, `Hold:1`, `Hold:0`, `Home`, `Alarm`.
    pub state: String,
    /// Position in steps.
    pub steps: [i32; 4],
    /// Blocks in the planner queue.
    pub queued: usize,
    /// Planner queue size.
    pub queue_size: usize,
    /// Next expected sequence number.
    pub seq: u32,
    /// Blocks the stepper has completed since the firmware started or was reset (wrapping), when reported.
    pub completed: Option<u32>,
}

impl Status {
    /// Parse the inside of `<...>`.
    pub fn parse(s: &str) -> Option<Status> {
        let mut parts = s.split('|');
        let state = parts.next()?.to_string();
        let (mut steps, mut q, mut seq, mut completed) = (None, None, None, None);
        for p in parts {
            if let Some(v) = p.strip_prefix("Steps:") {
                let v: Vec<i32> = v.split(',').map(str::parse).collect::<Result<_, _>>().ok()?;
                steps = Some(<[i32; 4]>::try_from(v).ok()?);
            } else if let Some(v) = p.strip_prefix("Q:") {
                let (a, b) = v.split_once('/')?;
                q = Some((a.parse().ok()?, b.parse().ok()?));
            } else if let Some(v) = p.strip_prefix("N:") {
                seq = Some(v.parse().ok()?);
            } else if let Some(v) = p.strip_prefix("C:") {
                completed = Some(v.parse().ok()?);
            }
        }
        let (queued, queue_size) = q?;
        Some(Status { state, steps: steps?, queued, queue_size, seq: seq?, completed })
    }

    /// Whether nothing is queued or moving.
    pub fn is_idle(&self) -> bool {
        self.state == "Idle"
    }
}

/// An open session.
pub struct Session<T: Transport> {
    /// The byte pipe.
    pub transport: T,
    /// From the handshake.
    pub info: FirmwareInfo,
    /// Where the session is connected (for messages).
    pub name: String,
    /// Framed mode is on (see `plotter_fw::framing`): replies are verified, real-time commands are sequences.
    pub framed: bool,
    /// Numbered lines this session had accepted (each takes one of the firmware's sequence numbers; a resume must
    /// not count them as blocks of the interrupted plot).
    pub own_lines: u32,
}

/// How long to wait for the answer to a plain command (the homing cycle can take a while on a large machine).
pub const COMMAND_TIMEOUT: Duration = Duration::from_secs(5);
/// How long a homing cycle may take.
pub const HOMING_TIMEOUT: Duration = Duration::from_secs(180);
/// How long the handshake may take in all, however much the device says.
pub const CONNECT_TIMEOUT: Duration = Duration::from_secs(12);

fn parse_m115(line: &str) -> Option<FirmwareInfo> {
    if !line.starts_with("FIRMWARE_NAME:plotter-fw") {
        return None;
    }
    let field = |key: &str| line.split_whitespace().find_map(|w| w.strip_prefix(key)).map(str::to_string);
    Some(FirmwareInfo {
        version: field("FIRMWARE_VERSION:")?,
        rx_bytes: field("RX_BUFFER:")?.parse().ok()?,
        queue_blocks: field("QUEUE_BLOCKS:")?.parse().ok()?,
        protocol: field("PROTOCOL_VERSION:")?.parse().ok()?,
    })
}

impl<T: Transport> Session<T> {
    /// Handshake: flush any half-received line, ask `M115` (up to three times, for boards that reset when the port
    /// opens), read the buffer sizes. A device that never answers like plotter-fw is an error naming what it sent;
    /// the whole handshake takes at most [`CONNECT_TIMEOUT`] however much the device says (a wrong port that
    /// babbles), and ends on a stop (any signal, Ctrl-C included: nothing to pause yet).
    pub fn connect(mut transport: T, name: &str) -> crate::Result<Self> {
        let mut heard: Vec<String> = Vec::new();
        transport.send(b"\n").with_context(|| format!("cannot write to {name}"))?;
        let mut wait = Wait::new(name, "a firmware description (M115)", transport.now(), CONNECT_TIMEOUT)
            .interruptible()
            .on_any_interrupt();
        // No firmware description: nothing heard at all, or lines that are not plotter-fw's (the first three quoted).
        let not_found = |heard: &[String]| {
            if heard.is_empty() {
                return crate::Error::NoAnswer { name: name.to_string() };
            }
            let shown: Vec<String> = heard.iter().take(3).map(|l| format!("{l:?}")).collect();
            crate::Error::FirmwareMismatch { name: name.to_string(), heard: shown.join(", ") }
        };
        let gave_up = |e: WaitError, heard: &[String]| match e {
            WaitError::TimedOut { .. } => not_found(heard),
            e @ WaitError::Stopped(_) => crate::Error::Other(e.into()),
        };
        // Plain replies are unchecked, so the firmware's description only counts when two answers agree (line noise
        // could change a digit of a buffer size); framed mode later reads it again, verified.
        let mut previous: Option<FirmwareInfo> = None;
        let mut framed_seen = false;
        for attempt in 0..40 {
            if framed_seen {
                // A firmware left in framed mode by an earlier host (which may have died mid-plot): continue in
                // framed mode and read its description the verified way.
                let info = FirmwareInfo { version: String::new(), rx_bytes: 64, queue_blocks: 1, protocol: 2 };
                let mut s = Session { transport, info, name: name.to_string(), framed: true, own_lines: 0 };
                s.verify_info()?;
                return Ok(s);
            }
            if attempt >= 3 && heard.is_empty() && previous.is_none() {
                break;
            }
            // Drain whatever answers the flush (or a banner) produced: until a quiet 150 ms, for at most 300 ms.
            let drain_end = transport.now() + Duration::from_millis(300);
            while transport.now() < drain_end {
                let slice = wait.next(transport.now(), Duration::from_millis(150)).map_err(|e| gave_up(e, &heard))?;
                let Some(l) = transport.recv_line(slice)? else { break };
                framed_seen |= framing::parse_reply(&l).is_some();
                if heard.len() < 8 && !l.is_empty() && !l.starts_with("plotter-fw ") && Reply::parse(&l) != Reply::Ok {
                    heard.push(l);
                }
            }
            transport.send(b"M115\n")?;
            let mut info = None;
            // The answer: until its `ok`, a quiet second, or 2 s of other talk.
            let answer_end = transport.now() + Duration::from_secs(2);
            while transport.now() < answer_end {
                let slice = wait.next(transport.now(), Duration::from_secs(1)).map_err(|e| gave_up(e, &heard))?;
                let Some(l) = transport.recv_line(slice)? else { break };
                framed_seen |= framing::parse_reply(&l).is_some();
                if let Some(i) = parse_m115(&l) {
                    info = Some(i);
                } else if l == "ok" {
                    if let Some(info) = info.take() {
                        if previous.as_ref() == Some(&info) {
                            return Ok(Session {
                                transport,
                                info,
                                name: name.to_string(),
                                framed: false,
                                own_lines: 0,
                            });
                        }
                        previous = Some(info);
                        break;
                    }
                } else if heard.len() < 8 && !l.is_empty() && !l.starts_with("plotter-fw ") {
                    heard.push(l);
                }
            }
        }
        Err(not_found(&heard))
    }

    /// The next line from the firmware within `timeout` (see [`Incoming`]).
    pub fn recv(&mut self, timeout: Duration) -> std::io::Result<Option<Incoming>> {
        let Some(l) = self.transport.recv_line(timeout)? else { return Ok(None) };
        if !self.framed {
            return Ok(Some(Incoming::Reply(None, l)));
        }
        if let Some((n, text)) = framing::parse_reply(&l) {
            return Ok(Some(Incoming::Reply(Some(n), text.to_string())));
        }
        if matches!(Reply::parse(&l), Reply::Banner(b) if b.split_whitespace().count() >= 11) {
            // The firmware restarted (a reset ends framed mode): its banner is plain.
            self.framed = false;
            return Ok(Some(Incoming::Reply(None, l)));
        }
        Ok(Some(Incoming::Damaged(l)))
    }

    /// Send the real-time command `cmd`: one byte in plain mode, its four-byte sequence in framed mode.
    pub fn send_realtime(&mut self, cmd: u8) -> std::io::Result<()> {
        if self.framed { self.transport.send(&rt_sequence(cmd)) } else { self.transport.send(&[cmd]) }
    }

    /// Switch framed mode on (firmwares with protocol 2 and later; older ones stay plain). Sent checked.
    pub fn enter_framed(&mut self) -> anyhow::Result<()> {
        if self.framed || self.info.protocol < 2 {
            return Ok(());
        }
        // The answer to the switch is already framed; a damaged exchange is settled by asking for the status the
        // framed way (only a framed firmware answers it with a verified report).
        let mut seq = self.status()?.seq;
        'attempt: for _attempt in 0..10 {
            let body = format!("N{seq} M{} S1", framing::M_FRAMED);
            let cs = plotter_fw::gcode::xor_checksum(body.as_bytes());
            self.transport.send(format!("{body}*{cs}\n").as_bytes())?;
            let deadline = self.transport.now() + COMMAND_TIMEOUT;
            loop {
                let left = deadline.saturating_sub(self.transport.now());
                let Some(l) = self.transport.recv_line(left.max(Duration::from_millis(1)))? else { break };
                if let Some((n, text)) = framing::parse_reply(&l) {
                    if n == seq && text == "ok" {
                        self.framed = true;
                        self.own_lines += 1;
                        return self.verify_info();
                    }
                    continue;
                }
                // (Anything else, e.g. an unnumbered-checksum error when our `N` was damaged, is settled below.)
                if let Reply::Resend(n) = Reply::parse(&l) {
                    seq = n;
                    continue 'attempt;
                }
            }
            self.framed = true;
            if self.status().is_ok() {
                self.own_lines += 1;
                return self.verify_info();
            }
            self.framed = false;
            seq = self.status()?.seq;
        }
        bail!("{}: could not switch to framed mode", self.name)
    }

    /// In framed mode, read the firmware's description again, verified this time.
    fn verify_info(&mut self) -> anyhow::Result<()> {
        for _ in 0..30 {
            let lines = self.command_checked("M115", COMMAND_TIMEOUT)?;
            if let Some(info) = lines.iter().find_map(|l| parse_m115(l)) {
                self.info = info;
                return Ok(());
            }
        }
        bail!("{}: no intact firmware description in framed mode", self.name)
    }

    /// Switch framed mode off again (for consoles and other senders after us).
    pub fn leave_framed(&mut self) -> anyhow::Result<()> {
        if !self.framed {
            return Ok(());
        }
        // The answer to the switch is plain already; when it is lost, a plain status settles whether the switch
        // happened (a framed firmware does not answer a lone `?`).
        let mut seq = self.status()?.seq;
        for _attempt in 0..10 {
            let body = format!("N{seq} M{} S0", framing::M_FRAMED);
            let cs = plotter_fw::gcode::xor_checksum(body.as_bytes());
            self.transport.send(format!("{body}*{cs}\n").as_bytes())?;
            self.framed = false;
            let deadline = self.transport.now() + COMMAND_TIMEOUT;
            while let Some(l) =
                self.transport.recv_line(deadline.saturating_sub(self.transport.now()).max(Duration::from_millis(1)))?
            {
                if l == "ok" {
                    return Ok(());
                }
            }
            // Unclear: a framed firmware answers a framed status request (the line was lost: again), a plain one a
            // plain request.
            self.framed = true;
            if let Ok(st) = self.status() {
                seq = st.seq;
                continue;
            }
            self.framed = false;
            if self.status().is_ok() {
                // Flush the halves of the framed requests a plain firmware took for data.
                self.transport.send(b"\n")?;
                return Ok(());
            }
        }
        bail!("{}: could not leave framed mode", self.name)
    }

    /// The firmware's `error:<code> <text>` answer to `line`, as a typed error.
    fn refused(&self, line: &str, code: u8, text: &str) -> Refused {
        Refused { machine: self.name.clone(), line: line.to_string(), code, text: text.to_string() }
    }

    /// Send one G-code line (unsequenced) and wait for its `ok`; returns the report lines before it. `error:` and
    /// alarms are errors.
    pub fn command(&mut self, line: &str, timeout: Duration) -> anyhow::Result<Vec<String>> {
        self.transport.send(format!("{line}\n").as_bytes())?;
        let mut out = Vec::new();
        let deadline = self.transport.now() + timeout;
        loop {
            let left = deadline.saturating_sub(self.transport.now());
            let Some(l) = self.transport.recv_line(left.max(Duration::from_millis(1)))? else {
                if self.transport.now() >= deadline {
                    bail!("{}: no answer to {line:?} within {:.0} s", self.name, timeout.as_secs_f64());
                }
                bail!("{}: the firmware went quiet without answering {line:?}", self.name);
            };
            match Reply::parse(&l) {
                Reply::Ok => return Ok(out),
                Reply::Error { code, text } => return Err(self.refused(line, code, text).into()),
                Reply::Alarm { code, text } => bail!("{}: alarm {code} ({text}) during {line:?}", self.name),
                Reply::Banner(_) => bail!("{}: the firmware restarted during {line:?}", self.name),
                Reply::Status(_) | Reply::Resend(_) | Reply::Completed(_) => {}
                Reply::Info(i) => out.push(i.to_string()),
            }
        }
    }

    /// Ask for a status report and wait for it.
    /// In framed mode only a verified report counts: a damaged one is asked for again (up to 10 times).
    pub fn status(&mut self) -> anyhow::Result<Status> {
        let mut damaged = 0;
        for _ in 0..30 {
            self.send_realtime(RT_STATUS)?;
            // Until a quiet half second, or a second of other lines (a babbling device must not hold us).
            let end = self.transport.now() + Duration::from_secs(1);
            while self.transport.now() < end {
                let Some(l) = self.recv(Duration::from_millis(500))? else { break };
                let Incoming::Reply(_, l) = l else {
                    damaged += 1;
                    continue;
                };
                if let Reply::Status(s) = Reply::parse(&l) {
                    match Status::parse(s) {
                        Some(st) => return Ok(st),
                        None if self.framed => bail!("{}: unreadable status report <{s}>", self.name),
                        None => damaged += 1,
                    }
                }
                if matches!(Reply::parse(&l), Reply::Banner(_)) {
                    bail!("{}: the firmware restarted", self.name);
                }
            }
        }
        bail!("{}: no readable status report ({damaged} damaged lines)", self.name)
    }

    /// Send one G-code line numbered and checksummed (`N<n> line*<cs>`, with `n` the firmware's expected sequence
    /// number), so that a line damaged on the way is detected and resent instead of being misread; wait for its
    /// `ok`. Returns the report lines before it.
    pub fn command_checked(&mut self, line: &str, timeout: Duration) -> anyhow::Result<Vec<String>> {
        self.command_checked_within(line, timeout, false)
    }

    /// [`Session::command_checked`]; when `interruptible`, a stop (any signal) ends the wait for the answer.
    fn command_checked_within(
        &mut self,
        line: &str,
        timeout: Duration,
        interruptible: bool,
    ) -> anyhow::Result<Vec<String>> {
        let mut out = Vec::new();
        let mut seq = self.status()?.seq;
        for _attempt in 0..10 {
            let body = format!("N{seq} {line}");
            let cs = plotter_fw::gcode::xor_checksum(body.as_bytes());
            self.transport.send(format!("{body}*{cs}\n").as_bytes())?;
            let mut wait = Wait::new(&self.name, format!("the answer to {line}"), self.transport.now(), timeout);
            if interruptible {
                wait = wait.interruptible().on_any_interrupt();
            }
            // An interruptible wait reads in short slices, so that a stop is seen within one.
            let slice = if interruptible { Duration::from_millis(100) } else { timeout };
            loop {
                let left = match wait.next(self.transport.now(), slice) {
                    Ok(left) => left,
                    // Past the deadline: one last read of zero length settles it below, as before.
                    Err(WaitError::TimedOut { .. }) => Duration::from_millis(1),
                    Err(e) => return Err(e.into()),
                };
                let before = self.transport.now();
                let got = self.recv(left)?;
                let now = self.transport.now();
                if got.is_none() && interruptible && now > before && wait.elapsed(now) < timeout {
                    // Only a slice passed: the answer may still come.
                    continue;
                }
                let Some(Incoming::Reply(n, l)) = got else {
                    if got.is_some() {
                        // Damaged: perhaps our answer. Wait on; the status below settles it.
                        continue;
                    }
                    // No (readable) answer: ask where the firmware stands. If it has taken our number, the line
                    // was executed and only its `ok` was lost — never send it twice.
                    let now = self.status()?.seq;
                    if now == seq.wrapping_add(1) {
                        self.own_lines += 1;
                        return Ok(out);
                    }
                    seq = now;
                    break;
                };
                if n.is_some_and(|n| n != seq) {
                    // A framed answer about another line (a late reply): not ours.
                    continue;
                }
                match Reply::parse(&l) {
                    Reply::Ok => {
                        self.own_lines += 1;
                        return Ok(out);
                    }
                    Reply::Error { code, .. } if code == plotter_fw::errors::ErrorCode::Checksum.code() => {
                        // Our line lost its `N` on the way: ask where the firmware stands and send it again.
                        seq = self.status()?.seq;
                        break;
                    }
                    Reply::Error { code, text } => return Err(self.refused(line, code, text).into()),
                    Reply::Alarm { code, text } => bail!("{}: alarm {code} ({text}) during {line:?}", self.name),
                    Reply::Banner(_) => bail!("{}: the firmware restarted during {line:?}", self.name),
                    Reply::Resend(n) => {
                        seq = n;
                        break;
                    }
                    Reply::Status(_) | Reply::Completed(_) => {}
                    Reply::Info(i) => out.push(i.to_string()),
                }
            }
        }
        bail!("{}: {line:?} could not be delivered intact after 10 attempts", self.name)
    }

    /// Stop everything and raise the pen, for abort paths: a feed hold brings the axes to rest first (as GRBL
    /// senders do before a reset: the firmware forgets the position of every axis stepping when a reset arrives,
    /// and a Z forgotten on a machine whose Z switch lies below the paper cannot be homed without marking it), then
    /// a reset (the queue is dropped, the carriage stays where it came to rest; framed mode ends), then
    /// `G0 Z<up_z_mm>` in machine coordinates. Fails when the firmware does not answer.
    pub fn stop_and_lift(&mut self, up_z_mm: f64) -> anyhow::Result<()> {
        self.hold_to_rest();
        self.reset()?;
        self.command(&format!("G90 G0 Z{up_z_mm:.3}"), COMMAND_TIMEOUT)?;
        // Wait for the lift to finish.
        self.wait_idle(Duration::from_millis(50))?;
        Ok(())
    }

    /// A feed hold until the machine reports itself at rest (`Hold:0`, idle, in alarm), for at most
    /// [`COMMAND_TIMEOUT`] (a deceleration takes a fraction of a second); best effort: a machine that does not
    /// answer, or is not moving, is left as it is for the reset that follows.
    fn hold_to_rest(&mut self) {
        let moving = |s: &Status| matches!(s.state.as_str(), "Run" | "Hold:1");
        match self.status() {
            Ok(s) if moving(&s) => {}
            _ => return,
        }
        if self.send_realtime(RT_FEED_HOLD).is_err() {
            return;
        }
        let deadline = self.transport.now() + COMMAND_TIMEOUT;
        while self.transport.now() < deadline {
            match self.status() {
                Ok(s) if moving(&s) => {}
                _ => return,
            }
            // Let time pass (virtual for the simulator: receiving advances it).
            if self.transport.recv_line(Duration::from_millis(20)).is_err() {
                return;
            }
        }
    }

    /// Reset the firmware (0x18) and wait for its banner: motion stops where it is, the queue is dropped, framed mode
    /// ends. Fails when no banner comes within 3 s.
    pub fn reset(&mut self) -> anyhow::Result<()> {
        self.send_realtime(plotter_fw::protocol::RT_RESET)?;
        let deadline = self.transport.now() + Duration::from_secs(3);
        loop {
            let left = deadline.saturating_sub(self.transport.now());
            if left.is_zero() {
                bail!("{}: no banner after the reset", self.name);
            }
            let before = self.transport.now();
            match self.recv(left)? {
                Some(Incoming::Reply(_, l)) if matches!(Reply::parse(&l), Reply::Banner(_)) => break,
                // No reply, and no time passed: nothing will ever answer (a simulator with nothing left to run).
                None if self.transport.now() == before => bail!("{}: no banner after the reset (silent)", self.name),
                _ => {}
            }
        }
        self.framed = false;
        Ok(())
    }

    /// Run the homing cycle (`G28`, sent checked).
    pub fn home(&mut self) -> anyhow::Result<()> {
        self.home_with("G28")
    }

    /// Run a homing line (`G28` with its axis letters or `P1`, sent checked); see `plotter_fw::homing`.
    pub fn home_with(&mut self, line: &str) -> anyhow::Result<()> {
        match self.command_checked_within(line, HOMING_TIMEOUT, true) {
            Ok(_) => Ok(()),
            Err(e) if e.downcast_ref::<WaitError>().is_some_and(|w| matches!(w, WaitError::Stopped(_))) => {
                // Stopped while homing: the firmware stops the cycle where it is (the pen went up first).
                let reset = self.reset().map_or_else(|r| format!("; the reset failed: {r:#}"), |()| String::new());
                Err(e.context(format!("homing stopped (the firmware was reset){reset}")))
            }
            Err(e) => Err(e.context("homing failed")),
        }
    }

    /// Wait until the machine is idle (everything queued executed), polling the status every `every`. A machine
    /// whose state, position, queue and completed count stay the same for [`WAIT_STALL`] (a feed hold nobody
    /// resumes, a link whose time stands still) is an error naming its state, not an endless wait.
    pub fn wait_idle(&mut self, every: Duration) -> anyhow::Result<Status> {
        let mut last: Option<(String, [i32; 4], usize, Option<u32>)> = None;
        let (mut since, mut still_polls) = (self.transport.now(), 0u32);
        loop {
            let s = self.status()?;
            if s.is_idle() {
                return Ok(s);
            }
            if s.state == "Alarm" {
                bail!("{}: the machine is in alarm", self.name);
            }
            let key = (s.state.clone(), s.steps, s.queued, s.completed);
            if last.as_ref() == Some(&key) {
                still_polls += 1;
                let still = self.transport.now().saturating_sub(since);
                if still >= WAIT_STALL || still_polls >= WAIT_STALL_POLLS {
                    bail!(
                        "{}: no progress for {:.1} s ({still_polls} status reports) while waiting for the machine \
                         to finish: it stays in state {} at steps {:?} with {} block(s) queued",
                        self.name,
                        still.as_secs_f64(),
                        s.state,
                        s.steps,
                        s.queued
                    );
                }
            } else {
                last = Some(key);
                (since, still_polls) = (self.transport.now(), 0);
            }
            // Let time pass (virtual for the simulator: receiving advances it).
            let _ = self.transport.recv_line(every)?;
        }
    }
}

/// How long [`Session::wait_idle`] waits for a machine that shows no progress at all (no motion, no queue change).
/// Longer than any dwell or pen settle a plot asks for.
pub const WAIT_STALL: Duration = Duration::from_secs(30);

/// How many unchanged status reports [`Session::wait_idle`] accepts when the link's clock stands still.
const WAIT_STALL_POLLS: u32 = 10_000;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::sim::SimTransport;
    use plotter_fw::MachineConfig;

    #[test]
    fn status_and_m115_parse() {
        let s = Status::parse("Run|MPos:1.000,2.000,0.000,0.000|Steps:80,160,0,0|Q:3/32|N:17").unwrap();
        assert_eq!(s.steps, [80, 160, 0, 0]);
        assert_eq!((s.queued, s.queue_size, s.seq, s.completed), (3, 32, 17, None));
        assert!(!s.is_idle());
        let s = Status::parse("Run|MPos:1.000,2.000,0.000,0.000|Steps:80,160,0,0|Q:3/32|N:17|C:4294967295").unwrap();
        assert_eq!((s.seq, s.completed), (17, Some(u32::MAX)));
        assert_eq!(Status::parse("Run|Steps:80,160,0,0|Q:3/32|N:17|C:x"), None, "a garbled count is no report");
        assert_eq!(Status::parse("Idle|Steps:1,2"), None);
        let i = parse_m115(
            "FIRMWARE_NAME:plotter-fw FIRMWARE_VERSION:0.1.0 PROTOCOL_VERSION:1 RX_BUFFER:256 QUEUE_BLOCKS:32",
        )
        .unwrap();
        assert_eq!((i.rx_bytes, i.queue_blocks), (256, 32));
    }

    #[test]
    fn handshake_home_and_status_on_the_simulator() {
        let t = SimTransport::new(MachineConfig::xy_plotter(), None);
        let mut s = Session::connect(t, "sim").unwrap();
        assert_eq!((s.info.rx_bytes, s.info.queue_blocks), (256, 32));
        s.home().unwrap();
        let st = s.status().unwrap();
        assert_eq!(st.steps, [0, 0, 1600, 0]);
        assert!(st.is_idle());
        let e = s.command("G1 X-5 F600", COMMAND_TIMEOUT).unwrap_err().to_string();
        assert!(e.contains("refused"), "{e}");
    }

    /// A stop while the XY kit's pen is lowering (a slow Z move, 1 mm/s from 4 mm towards the paper) brings Z to
    /// rest with a feed hold before the reset, so Z keeps its position: the next `G28` keeps it (up to the pen-up
    /// height, 1600 steps, then X and Y home) instead of being refused (error 16: a Z lost by a reset mid-move on a
    /// machine whose Z switch lies below the paper cannot be homed without marking it).
    #[test]
    fn a_stop_while_z_moves_keeps_its_position_for_homing() {
        let t = SimTransport::new(MachineConfig::xy_plotter(), None);
        let mut s = Session::connect(t, "sim").unwrap();
        s.home().unwrap();
        s.command("G1 Z0 F60", COMMAND_TIMEOUT).unwrap();
        let _ = s.transport.recv_line(Duration::from_millis(500)).unwrap();
        assert_eq!(s.status().unwrap().state, "Run", "Z is moving");
        s.stop_and_lift(4.0).unwrap();
        let st = s.status().unwrap();
        assert!(st.is_idle() && st.steps[2] == 1600, "{st:?}");
        s.home().unwrap();
        assert_eq!(s.status().unwrap().steps, [0, 0, 1600, 0]);
    }

    #[test]
    fn waiting_for_a_machine_held_forever_ends_with_its_state() {
        let t = SimTransport::new(MachineConfig::xy_plotter(), None);
        let mut s = Session::connect(t, "sim").unwrap();
        s.home().unwrap();
        // A long move (200 mm), then a feed hold nobody resumes.
        s.command("G1 X200 F600", COMMAND_TIMEOUT).unwrap();
        let _ = s.transport.recv_line(Duration::from_millis(500)).unwrap();
        s.send_realtime(plotter_fw::protocol::RT_FEED_HOLD).unwrap();
        let t0 = s.transport.now();
        let e = s.wait_idle(Duration::from_millis(50)).unwrap_err().to_string();
        assert!(e.contains("no progress for") && e.contains("state Hold:0"), "{e}");
        // The simulator's clock stands still in a hold (nothing to simulate): the unchanged reports end the wait,
        // within the deceleration into the hold.
        let waited = s.transport.now() - t0;
        assert!(e.contains("(10000 status reports)") && waited < Duration::from_secs(2), "{waited:?}: {e}");
    }

    /// A machine stuck in a feed hold on a link whose clock runs: every `?` is answered with the same report,
    /// and waiting advances the clock by the timeout.
    struct StuckInHold {
        clock: Duration,
        pending: Vec<String>,
    }
    impl Transport for StuckInHold {
        fn send(&mut self, data: &[u8]) -> std::io::Result<()> {
            if data == [plotter_fw::protocol::RT_STATUS] {
                self.pending.push("<Hold:0|MPos:1.000,2.000,0.000,0.000|Steps:80,160,0,0|Q:3/32|N:17>".into());
            }
            Ok(())
        }
        fn recv_line(&mut self, timeout: Duration) -> std::io::Result<Option<String>> {
            match self.pending.pop() {
                Some(l) => Ok(Some(l)),
                None => {
                    self.clock += timeout;
                    Ok(None)
                }
            }
        }
        fn now(&self) -> Duration {
            self.clock
        }
    }

    #[test]
    fn a_hold_on_a_running_clock_ends_the_wait_after_the_stall_time() {
        let info = FirmwareInfo { version: "t".into(), rx_bytes: 256, queue_blocks: 32, protocol: 3 };
        let transport = StuckInHold { clock: Duration::ZERO, pending: Vec::new() };
        let mut s = Session { transport, info, name: "held".into(), framed: false, own_lines: 0 };
        let e = s.wait_idle(Duration::from_millis(50)).unwrap_err().to_string();
        // One report per 50 ms poll: the wait ends at the first poll 30 s after the first report, 600 polls later.
        assert_eq!(
            e,
            "held: no progress for 30.0 s (600 status reports) while waiting for the machine to finish: it stays in \
             state Hold:0 at steps [80, 160, 0, 0] with 3 block(s) queued"
        );
        assert_eq!(s.transport.clock, WAIT_STALL);
    }

    /// A transport that answers every line with noise.
    struct Garbage(Vec<String>);
    impl Transport for Garbage {
        fn send(&mut self, _: &[u8]) -> std::io::Result<()> {
            self.0.push("\u{7f}#garbage%".into());
            Ok(())
        }
        fn recv_line(&mut self, _: Duration) -> std::io::Result<Option<String>> {
            Ok(self.0.pop())
        }
        fn now(&self) -> Duration {
            Duration::ZERO
        }
    }

    #[test]
    fn a_port_answering_garbage_is_refused() {
        let e = Session::connect(Garbage(Vec::new()), "/dev/ttyX").err().unwrap().to_string();
        assert!(e.contains("/dev/ttyX does not answer like plotter-fw") && e.contains("garbage"), "{e}");
    }

    #[test]
    fn a_port_answering_garbage_is_a_firmware_mismatch() {
        match Session::connect(Garbage(Vec::new()), "/dev/ttyX").err().unwrap() {
            crate::Error::FirmwareMismatch { name, heard } => {
                assert_eq!(name, "/dev/ttyX");
                // The first three lines heard, quoted.
                assert_eq!(heard.matches("\"\\u{7f}#garbage%\"").count(), 3, "{heard}");
            }
            e => panic!("{e:?}"),
        }
    }

    /// A transport that never answers, or whose reads fail.
    struct Silent(bool);
    impl Transport for Silent {
        fn send(&mut self, _: &[u8]) -> std::io::Result<()> {
            Ok(())
        }
        fn recv_line(&mut self, _: Duration) -> std::io::Result<Option<String>> {
            if self.0 { Err(std::io::Error::new(std::io::ErrorKind::BrokenPipe, "device unplugged")) } else { Ok(None) }
        }
        fn now(&self) -> Duration {
            Duration::ZERO
        }
    }

    #[test]
    fn silence_is_no_answer_and_a_failing_read_a_lost_port() {
        let e = Session::connect(Silent(false), "/dev/ttyS9").err().unwrap();
        assert!(matches!(&e, crate::Error::NoAnswer { name } if name == "/dev/ttyS9"), "{e:?}");
        let e = Session::connect(Silent(true), "/dev/ttyS9").err().unwrap();
        assert!(
            matches!(&e, crate::Error::PortLost { cause, .. } if cause.kind() == std::io::ErrorKind::BrokenPipe),
            "{e:?}"
        );
        assert_eq!(e.to_string(), "device unplugged");
    }

    /// A port where nothing answers, on a clock that reading advances (virtual time).
    #[derive(Default)]
    struct Mute(Duration);
    impl Transport for Mute {
        fn send(&mut self, _: &[u8]) -> std::io::Result<()> {
            Ok(())
        }
        fn recv_line(&mut self, timeout: Duration) -> std::io::Result<Option<String>> {
            self.0 += timeout;
            Ok(None)
        }
        fn now(&self) -> Duration {
            self.0
        }
    }

    #[test]
    fn a_device_that_only_babbles_is_given_up_within_the_connect_deadline_naming_what_it_said() {
        use crate::link::babble::{Babble, BabbleKind, Babbling};
        // Blank lines every millisecond: heard as nothing at all.
        let t = Babbling::new(Mute::default(), Babble::new(BabbleKind::Blank, 0));
        let e = Session::connect(t, "/dev/ttyUSB3").err().unwrap();
        assert!(matches!(&e, crate::Error::NoAnswer { name } if name == "/dev/ttyUSB3"), "{e:?}");
        // A line every 20 ms (a wrong port): its lines are quoted, and the handshake gives up in time.
        let mut t = Babbling::new(Mute::default(), Babble::new(BabbleKind::Chatter, 0));
        t.send(b"").unwrap();
        let e = Session::connect(t, "/dev/ttyUSB3").err().unwrap();
        match e {
            crate::Error::FirmwareMismatch { heard, .. } => {
                assert_eq!(heard, r##""#%& line noise &%#", "#%& line noise &%#", "#%& line noise &%#""##)
            }
            e => panic!("{e:?}"),
        }
    }

    #[test]
    fn the_handshake_ends_by_its_deadline_on_a_babbling_port_and_goes_through_chatter() {
        use crate::link::babble::{Babble, BabbleKind, Babbling};
        // Our firmware behind a chattering line still connects, and reads its status through the noise.
        let sim = SimTransport::new(MachineConfig::xy_plotter(), None);
        let mut s = Session::connect(Babbling::new(sim, Babble::new(BabbleKind::Chatter, 0)), "sim").unwrap();
        assert_eq!((s.info.rx_bytes, s.info.queue_blocks), (256, 32));
        // Homing takes simulated seconds: many lines of noise come between its answers.
        s.home().unwrap();
        assert!(s.status().unwrap().is_idle());
        assert!(s.transport.babble().babbled > 100, "{}", s.transport.babble().babbled);
    }

    #[test]
    fn a_board_that_turns_to_blank_lines_mid_session_fails_its_status_in_bounded_time() {
        use crate::link::babble::{Babble, BabbleKind, Babbling};
        let sim = SimTransport::new(MachineConfig::xy_plotter(), None);
        // The handshake sends three lines (the flush and M115 twice); the board babbles from the next one on.
        let mut s = Session::connect(Babbling::new(sim, Babble::new(BabbleKind::Blank, 4)), "sim").unwrap();
        s.transport.send(b"\n").unwrap();
        let t0 = s.transport.now();
        let e = s.status().unwrap_err().to_string();
        let took = s.transport.now() - t0;
        assert!(e.contains("no readable status report"), "{e}");
        // 30 asks of at most a second each.
        assert!(took <= Duration::from_secs(31), "{took:?}");
    }
}
