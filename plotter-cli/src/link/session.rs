//! A session with the firmware over a [`Transport`]: handshake (firmware info and buffer sizes from `M115`),
//! plain G-code commands answered by `ok`/`error:`, the real-time status report, homing.

use std::time::Duration;

use anyhow::{Context as _, bail};
use plotter_fw::protocol::{RT_STATUS, Reply};

use super::Transport;

/// What the firmware says about itself.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FirmwareInfo {
    /// Firmware version.
    pub version: String,
    /// Receive buffer, bytes: the most the host may have in flight.
    pub rx_bytes: usize,
    /// Planner queue length, blocks.
    pub queue_blocks: usize,
}

/// A parsed status report `<State|MPos:..|Steps:x,y,z,e|Q:used/size|N:seq|C:completed>` (`C:` is optional:
/// firmwares before it report no completed-block count).
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
}

/// How long to wait for the answer to a plain command (the homing cycle can take a while on a large machine).
pub const COMMAND_TIMEOUT: Duration = Duration::from_secs(5);
/// How long a homing cycle may take.
pub const HOMING_TIMEOUT: Duration = Duration::from_secs(180);

fn parse_m115(line: &str) -> Option<FirmwareInfo> {
    if !line.starts_with("FIRMWARE_NAME:plotter-fw") {
        return None;
    }
    let field = |key: &str| line.split_whitespace().find_map(|w| w.strip_prefix(key)).map(str::to_string);
    Some(FirmwareInfo {
        version: field("FIRMWARE_VERSION:")?,
        rx_bytes: field("RX_BUFFER:")?.parse().ok()?,
        queue_blocks: field("QUEUE_BLOCKS:")?.parse().ok()?,
    })
}

impl<T: Transport> Session<T> {
    /// Handshake: flush any half-received line, ask `M115` (up to three times, for boards that reset when the port
    /// opens), read the buffer sizes. A device that never answers like plotter-fw is an error naming what it sent.
    pub fn connect(mut transport: T, name: &str) -> anyhow::Result<Self> {
        let mut heard: Vec<String> = Vec::new();
        transport.send(b"\n").with_context(|| format!("cannot write to {name}"))?;
        for _attempt in 0..3 {
            // Drain whatever answers the flush (or a banner) produced.
            while let Some(l) = transport.recv_line(Duration::from_millis(150))? {
                if heard.len() < 8 && !l.is_empty() && !l.starts_with("plotter-fw ") && Reply::parse(&l) != Reply::Ok {
                    heard.push(l);
                }
            }
            transport.send(b"M115\n")?;
            let mut info = None;
            while let Some(l) = transport.recv_line(Duration::from_secs(1))? {
                if let Some(i) = parse_m115(&l) {
                    info = Some(i);
                } else if l == "ok" {
                    if let Some(info) = info.take() {
                        return Ok(Session { transport, info, name: name.to_string() });
                    }
                } else if heard.len() < 8 && !l.starts_with("plotter-fw ") {
                    heard.push(l);
                }
            }
        }
        if heard.is_empty() {
            bail!("no answer from {name}: is it a plotter running plotter-fw (or `plotter sim --pty`)?");
        }
        let shown: Vec<String> = heard.iter().take(3).map(|l| format!("{l:?}")).collect();
        bail!("{name} does not answer like plotter-fw (M115 got no firmware info); it sent: {}", shown.join(", "))
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
                Reply::Error { code, text } => bail!("{}: {line:?} refused: error {code}: {text}", self.name),
                Reply::Alarm { code, text } => bail!("{}: alarm {code} ({text}) during {line:?}", self.name),
                Reply::Banner(_) => bail!("{}: the firmware restarted during {line:?}", self.name),
                Reply::Status(_) | Reply::Resend(_) => {}
                Reply::Info(i) => out.push(i.to_string()),
            }
        }
    }

    /// Ask for a status report and wait for it.
    pub fn status(&mut self) -> anyhow::Result<Status> {
        for _ in 0..3 {
            self.transport.send(&[RT_STATUS])?;
            while let Some(l) = self.transport.recv_line(Duration::from_millis(500))? {
                if let Reply::Status(s) = Reply::parse(&l) {
                    return Status::parse(s).with_context(|| format!("{}: unreadable status report <{s}>", self.name));
                }
            }
        }
        bail!("{}: no status report", self.name)
    }

    /// Send one G-code line numbered and checksummed (`N<n> line*<cs>`, with `n` the firmware's expected sequence
    /// number), so that a line damaged on the way is detected and resent instead of being misread; wait for its
    /// `ok`. Returns the report lines before it.
    pub fn command_checked(&mut self, line: &str, timeout: Duration) -> anyhow::Result<Vec<String>> {
        let mut out = Vec::new();
        let mut seq = self.status()?.seq;
        for _attempt in 0..10 {
            let body = format!("N{seq} {line}");
            let cs = plotter_fw::protocol::xor_checksum(body.as_bytes());
            self.transport.send(format!("{body}*{cs}\n").as_bytes())?;
            let deadline = self.transport.now() + timeout;
            loop {
                let left = deadline.saturating_sub(self.transport.now());
                let Some(l) = self.transport.recv_line(left.max(Duration::from_millis(1)))? else {
                    // Lost without an answer (e.g. its line end was dropped): ask where the firmware stands.
                    seq = self.status()?.seq;
                    break;
                };
                match Reply::parse(&l) {
                    Reply::Ok => return Ok(out),
                    Reply::Error { code, text } => bail!("{}: {line:?} refused: error {code}: {text}", self.name),
                    Reply::Alarm { code, text } => bail!("{}: alarm {code} ({text}) during {line:?}", self.name),
                    Reply::Banner(_) => bail!("{}: the firmware restarted during {line:?}", self.name),
                    Reply::Resend(n) => {
                        seq = n;
                        break;
                    }
                    Reply::Status(_) => {}
                    Reply::Info(i) => out.push(i.to_string()),
                }
            }
        }
        bail!("{}: {line:?} could not be delivered intact after 10 attempts", self.name)
    }

    /// Run the homing cycle (`G28`, sent checked).
    pub fn home(&mut self) -> anyhow::Result<()> {
        self.command_checked("G28", HOMING_TIMEOUT).map(|_| ()).context("homing failed")
    }

    /// Wait until the machine is idle (everything queued executed), polling the status every `every`.
    pub fn wait_idle(&mut self, every: Duration) -> anyhow::Result<Status> {
        loop {
            let s = self.status()?;
            if s.is_idle() {
                return Ok(s);
            }
            if s.state == "Alarm" {
                bail!("{}: the machine is in alarm", self.name);
            }
            // Let time pass (virtual for the simulator: receiving advances it).
            let _ = self.transport.recv_line(every)?;
        }
    }
}

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
}
