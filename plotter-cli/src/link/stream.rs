//! Streaming planned step blocks to the firmware: flow control, go-back-N resends, progress and pause.
//!
//! # Flow control
//! Every frame is answered exactly once by the firmware (`ok`, `error:` or `rs <n>`), and a frame leaves the
//! firmware's receive buffer before it is answered. The host keeps a FIFO of the frames sent and not yet answered
//! and never lets their total size exceed the buffer the firmware announced, so the firmware never has to drop a
//! byte. Within that limit it sends as soon as it can, so the queue only runs dry when the link itself is too slow.
//!
//! # Resends
//! Frames carry an implicit sequence number (it is part of their CRC, see `plotter_fw::protocol`). On `rs <E>` the
//! firmware has accepted every frame before `E` and discards everything else until frame `E` arrives intact; the
//! host rewinds to `E` and resends the stored bytes from there (go-back-N). The answers to frames that were already
//! in flight when the rewind happened are `rs <E>` too; they are recognised by a generation counter on each FIFO
//! entry and do not trigger another rewind.
//!
//! Line noise can also merge two frames (a lost `\n`) or split one, so the answer count can drift from the frame
//! count. The FIFO then over- or under-estimates the bytes in flight; both are safe (an overflow is reported by the
//! firmware and resent) and a stall is resolved: after a quiet period the host asks for the status report, and if
//! the firmware is not simply waiting for queue space, everything it has not accepted (its `N:`) is resent.
//!
//! # Progress and the journal
//! `ok` means *accepted* (queued). What has been *executed* follows the firmware's completed-block count: in framed
//! mode the firmware sends a verified completion report `C:<count>` as blocks complete (at most every 5 ms, the
//! last one at once, see `plotter_fw::report`), and the periodic status report carries the same count as a backup.
//! When the machine was idle as the stream began, the count since then is exactly the number of frames executed
//! (each accepted frame is one block), up to the very last block, so after a power loss the journal is behind by
//! at most the block that was running (and what completed in the last report's few milliseconds). Without the
//! count (older firmwares) the status gives a lower bound: of the accepted frames, at most the planner queue
//! (`Q:`) plus the stepper's own queue and the running block are still waiting, so `accepted − Q − 3` blocks are
//! certainly done; when the machine is idle, all accepted blocks are.
//!
//! # Pauses
//! A pause request ([`Control::pause_requested`], Ctrl-C) pauses at the next pen-up: the host stops sending after
//! the first frame that leaves the pen up and waits for the machine to finish; or, when asked for, it holds at once
//! (feed hold). A second request before that pen-up, or one while the firmware reports a feed hold, stops the plot
//! at once ([`stop_at_once`], the same rule as the GRBL dialect's): the stream ends with
//! [`StreamError::StoppedAtOnce`] and the job resets the firmware (which drops its queue and stops where it is)
//! and lifts the pen. Once every frame is queued, a pause at the next pen-up would come only at the end, so a first
//! request there is answered with a notice and a second one stops at once.

use std::collections::VecDeque;
use std::time::Duration;

use anyhow::Context as _;
use plotter_fw::errors::ErrorCode;
use plotter_fw::protocol::{self, Encoder, MAX_FRAME, RT_STATUS, Reply};
use plotter_fw::stepper::STEPPER_QUEUE;
use plotter_path::motion::plan::{MotionPlan, MoveKind};

use super::Transport;
use super::session::{FirmwareInfo, Incoming, Session, Status};

/// The plan's blocks as wire frames, numbered from `base`.
pub struct Frames {
    /// Encoded frames, `\n` included.
    pub bytes: Vec<Vec<u8>>,
    /// Sequence number of the first frame.
    pub base: u32,
    /// Whether the pen is up (and settled) after each frame: where a pause may stop.
    pub safe_after: Vec<bool>,
}

impl Frames {
    /// Encode `plan` starting at sequence number `base`.
    pub fn encode(plan: &MotionPlan, base: u32) -> anyhow::Result<Frames> {
        let mut enc = Encoder::new();
        let mut buf = [0u8; MAX_FRAME];
        let mut bytes = Vec::with_capacity(plan.blocks.len());
        let mut safe_after = Vec::with_capacity(plan.blocks.len());
        let mut pen_up = true;
        for (i, b) in plan.blocks.iter().enumerate() {
            let seq = base.wrapping_add(u32::try_from(i).context("too many blocks")?);
            let n =
                enc.encode(&b.block, seq, &mut buf).map_err(|e| anyhow::anyhow!("block {i}: cannot encode: {e:?}"))?;
            bytes.push(buf[..n].to_vec());
            match b.kind {
                MoveKind::PenUp => pen_up = true,
                MoveKind::PenDown => pen_up = false,
                _ => {}
            }
            let next_is_settle = plan.blocks.get(i + 1).is_some_and(|n| n.kind == MoveKind::Settle);
            safe_after.push(pen_up && !next_is_settle);
        }
        Ok(Frames { bytes, base, safe_after })
    }

    /// Number of frames.
    pub fn len(&self) -> usize {
        self.bytes.len()
    }

    /// Whether there are no frames.
    pub fn is_empty(&self) -> bool {
        self.bytes.is_empty()
    }

    /// Total encoded size.
    pub fn total_bytes(&self) -> usize {
        self.bytes.iter().map(Vec::len).sum()
    }
}

/// Progress of a stream.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Progress {
    /// Frames accepted by the firmware.
    pub accepted: usize,
    /// Frames certainly executed.
    pub executed: usize,
    /// The firmware's expected sequence number after the accepted frames.
    pub seq_after_accepted: u32,
    /// Resend requests acted on.
    pub resends: u64,
}

/// What the user decided at a pause.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PauseChoice {
    /// Carry on.
    Resume,
    /// Stop here (the journal allows a later `--resume`).
    Abort,
}

/// The caller's side of a stream: progress display, journal, pause requests.
pub trait Control {
    /// Called whenever the accepted or executed count changes.
    fn progress(&mut self, p: &Progress);
    /// Whether a pause was requested since the last call; `Some(true)` = immediately (feed hold), `Some(false)` = at
    /// the next pen-up.
    fn pause_requested(&mut self) -> Option<bool>;
    /// The machine is paused (pen up, or held); ask what to do.
    fn paused(&mut self, held: bool) -> PauseChoice;
    /// Something the user should know now (a feed hold the controller reports, and how to get out of it).
    fn notice(&mut self, _text: &str) {}
    /// Whether the plot must stop now (the dialect's stop, the pen up): by default, whether the process was asked
    /// to ([`crate::stop`]: SIGTERM, SIGHUP, SIGQUIT, a second Ctrl-C). Every dialect's stream loop asks it as
    /// often as it asks [`Control::pause_requested`], and ends with [`StreamError::StoppedAtOnce`].
    fn stop_requested(&mut self) -> Option<crate::stop::StopCause> {
        crate::stop::Stop::process().stop_cause()
    }
}

/// Statistics of a finished stream.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StreamStats {
    /// Frames in the plan.
    pub frames: usize,
    /// Bytes of the frames (first transmission).
    pub frame_bytes: usize,
    /// Bytes actually written (with resends).
    pub bytes_sent: u64,
    /// Resend requests acted on.
    pub resends: u64,
    /// Times the host resynchronised from a status report after a stall.
    pub resyncs: u64,
    /// Frames that arrived so damaged that the firmware took them for (bad) G-code.
    pub noise_errors: u64,
    /// Reply lines that failed their check (framed mode) and were ignored.
    pub damaged_replies: u64,
    /// Transport time from the first frame to the last block executed.
    pub elapsed: Duration,
    /// Transport time from the first frame to the last frame accepted.
    pub accept_elapsed: Duration,
    /// Queue underruns, when the transport can see them.
    pub underruns: Option<u64>,
}

/// Why a stream stopped early.
#[derive(Debug, thiserror::Error)]
pub enum StreamError {
    /// The firmware refused a block (`error:`); nothing after it was executed.
    #[error("the firmware refused block {block}: error {code}: {text}")]
    Refused {
        /// Frame index.
        block: usize,
        /// Error code.
        code: u8,
        /// Error text.
        text: String,
    },
    /// The firmware raised an alarm.
    #[error("alarm {code} ({text}) after {executed} executed block(s)")]
    Alarm {
        /// Alarm code.
        code: u8,
        /// Alarm text.
        text: String,
        /// Blocks certainly executed.
        executed: usize,
    },
    /// The firmware restarted (its banner appeared).
    #[error("the firmware restarted during the plot after {executed} executed block(s)")]
    Restarted {
        /// Blocks certainly executed.
        executed: usize,
    },
    /// The user stopped the plot at a pause.
    #[error("plot aborted by the user after {executed} executed block(s)")]
    Aborted {
        /// Blocks executed.
        executed: usize,
    },
    /// A pause request that could not wait for the next pen-up (see [`stop_at_once`]) stopped the plot where it
    /// stood; the job then stops the machine and lifts the pen.
    #[error("{name}: stopped at once on {why}, after {executed} executed block(s)")]
    StoppedAtOnce {
        /// Where the machine is connected.
        name: String,
        /// What made the stop immediate, from [`stop_at_once`].
        why: String,
        /// Blocks certainly executed.
        executed: usize,
    },
    /// The link failed.
    #[error(transparent)]
    Link(#[from] anyhow::Error),
}

/// Whether a pause request (Ctrl-C) must stop the plot at once instead of pausing, and why: when the machine
/// already stands in a feed hold (`held`, the state it reports: a pause at the next pen-up would never come) or
/// when a pause at the next pen-up is already scheduled (`pause_scheduled`: the user asked twice). Every firmware
/// dialect's stream loop asks this on each request, so a second Ctrl-C means the same everywhere.
pub fn stop_at_once(held: Option<&str>, pause_scheduled: bool) -> Option<String> {
    match held {
        Some(state) => Some(format!("a pause request (Ctrl-C) during a feed hold ({state})")),
        None if pause_scheduled => {
            Some("a second pause request (Ctrl-C) before the pause at the next pen-up".to_string())
        }
        None => None,
    }
}

impl From<std::io::Error> for StreamError {
    fn from(e: std::io::Error) -> Self {
        StreamError::Link(e.into())
    }
}

/// Tuning of a stream.
#[derive(Debug, Clone, Copy)]
pub struct StreamOptions {
    /// How long without any reply before the host checks the firmware's status.
    pub quiet: Duration,
    /// How often to ask for a status report (executed progress).
    pub status_every: Duration,
    /// Consecutive stalls without progress before giving up.
    pub max_stalls: u32,
    /// The overall watchdog: no frame accepted and no block executed for this long, in any state, stops the
    /// stream with a message naming the state ([`stream_plan`] raises it to twice the plan's longest block).
    pub watchdog: Duration,
}

impl Default for StreamOptions {
    fn default() -> Self {
        StreamOptions {
            quiet: Duration::from_millis(500),
            status_every: Duration::from_millis(250),
            max_stalls: 20,
            watchdog: Duration::from_secs(30),
        }
    }
}

/// Error codes that refuse a step block for what it is (rather than because it was damaged on the way).
const REFUSALS: [u8; 3] = [ErrorCode::SoftLimit.code(), ErrorCode::Alarm.code(), ErrorCode::BadFrame.code()];

struct InFlight {
    len: usize,
    generation: u64,
    /// Frame index.
    index: usize,
}

struct State {
    next: usize,
    accepted: usize,
    executed: usize,
    in_flight: VecDeque<InFlight>,
    in_bytes: usize,
    generation: u64,
    resends: u64,
    resyncs: u64,
    noise_errors: u64,
    damaged_replies: u64,
    bytes_sent: u64,
    status_pending: bool,
    resync_pending: bool,
    resync_candidate: Option<u32>,
    last_status_at: Duration,
    /// The firmware's completed-block count when the stream began (machine idle), if it reports one.
    completed_base: Option<u32>,
}

impl State {
    /// Nothing sent yet, at link time `now`; `completed_base` is the firmware's completed-block count at the start
    /// (when it reports one and was idle).
    fn new(now: Duration, completed_base: Option<u32>) -> State {
        State {
            next: 0,
            accepted: 0,
            executed: 0,
            in_flight: VecDeque::new(),
            in_bytes: 0,
            generation: 0,
            resends: 0,
            resyncs: 0,
            noise_errors: 0,
            damaged_replies: 0,
            bytes_sent: 0,
            status_pending: false,
            resync_pending: false,
            resync_candidate: None,
            last_status_at: now,
            completed_base,
        }
    }

    fn answered(&mut self) -> Option<InFlight> {
        let e = self.in_flight.pop_front()?;
        self.in_bytes -= e.len;
        Some(e)
    }

    /// A framed `ok` names its frame: every frame sent before it has been answered too (answers come in order),
    /// whether or not their own answers arrived intact.
    fn answered_through(&mut self, index: usize) {
        if self.in_flight.iter().any(|e| e.index == index) {
            while let Some(e) = self.answered() {
                if e.index == index {
                    break;
                }
            }
        } else {
            self.answered();
        }
    }

    /// Ask the firmware for its status report now.
    fn ask_status<T: Transport>(&mut self, session: &mut Session<T>) -> std::io::Result<()> {
        session.send_realtime(RT_STATUS)?;
        self.status_pending = true;
        self.last_status_at = session.transport.now();
        Ok(())
    }

    /// Ask for the status when the polling period has passed since the last request, unless a report is still
    /// pending (then again after the quiet period, as a report lost to noise never comes).
    fn ask_status_if_due<T: Transport>(
        &mut self,
        session: &mut Session<T>,
        now: Duration,
        opts: &StreamOptions,
    ) -> std::io::Result<()> {
        let since = now.saturating_sub(self.last_status_at);
        if since >= opts.status_every && (!self.status_pending || since >= opts.quiet) {
            self.ask_status(session)?;
        }
        Ok(())
    }

    /// What the stream is doing, for the watchdog's message.
    fn phase(&self, n: usize, rx: usize, frames: &Frames, fw_state: Option<&str>) -> String {
        let host = if self.accepted == n {
            "waiting for the last blocks to execute".to_string()
        } else if self.next < n && self.in_bytes + frames.bytes[self.next].len() > rx {
            format!("waiting for the firmware to take frames ({} bytes in flight)", self.in_bytes)
        } else if self.accepted < self.next {
            format!("waiting for acknowledgements of frames {}..{}", self.accepted, self.next)
        } else {
            "sending".to_string()
        };
        let fw = match fw_state {
            Some("Hold:0" | "Hold:1") => "; the firmware reports a feed hold",
            Some("Alarm") => "; the firmware reports an alarm",
            Some("Idle") => "; the firmware reports Idle",
            Some(_) => "; the firmware reports Run",
            None => "; no readable status report",
        };
        format!("{host}{fw}")
    }

    fn on_status(&mut self, s: &Status, base: u32, n: usize) {
        let accepted_fw = usize::try_from(s.seq.wrapping_sub(base)).unwrap_or(usize::MAX);
        if accepted_fw <= n {
            let done = match (s.completed, self.completed_base) {
                (Some(c), Some(b)) => usize::try_from(c.wrapping_sub(b)).unwrap_or(usize::MAX).min(accepted_fw),
                _ => {
                    let waiting = if s.is_idle() { 0 } else { s.queued + STEPPER_QUEUE + 1 };
                    accepted_fw.saturating_sub(waiting)
                }
            };
            self.executed = self.executed.max(done);
        }
    }

    /// A verified completion report: `completed` blocks done since the firmware started, `seq` its expected
    /// number at the time. A count beyond the frames it had accepted cannot be about this stream and is ignored.
    fn on_completed(&mut self, seq: u32, completed: u32, base: u32, n: usize) {
        let Some(b) = self.completed_base else { return };
        let accepted_fw = usize::try_from(seq.wrapping_sub(base)).unwrap_or(usize::MAX);
        let done = usize::try_from(completed.wrapping_sub(b)).unwrap_or(usize::MAX);
        if accepted_fw <= n && done <= accepted_fw {
            self.executed = self.executed.max(done);
        }
    }
}

/// Stream `frames` over `session`. Returns when every frame has been executed. `before` is a status report taken
/// just before the stream (its completed-block count, if the machine was idle, makes the executed count exact).
pub fn stream<T: Transport>(
    session: &mut Session<T>,
    frames: &Frames,
    before: &Status,
    opts: StreamOptions,
    control: &mut dyn Control,
) -> Result<StreamStats, StreamError> {
    let n = frames.len();
    let rx = session.info.rx_bytes;
    if let Some(big) = frames.bytes.iter().find(|f| f.len() > rx) {
        return Err(StreamError::Link(anyhow::anyhow!(
            "a {}-byte frame does not fit the firmware's {rx}-byte receive buffer",
            big.len()
        )));
    }
    let t0 = session.transport.now();
    let mut st = State::new(t0, before.completed.filter(|_| before.is_idle()));
    let mut stalls = 0u32;
    let mut pause_at: Option<usize> = None;
    let mut garbage = 0usize;
    let mut accept_elapsed = Duration::ZERO;
    let mut last_reported = Progress::default();
    let mut last_progress_at = t0;
    let mut fw_state: Option<String> = Some(before.state.clone());
    session.transport.set_streaming(true);
    let result = loop {
        let progress = Progress {
            accepted: st.accepted,
            executed: st.executed,
            seq_after_accepted: frames.base.wrapping_add(u32::try_from(st.accepted).unwrap_or(u32::MAX)),
            resends: st.resends,
        };
        if progress != last_reported {
            if (progress.accepted, progress.executed) != (last_reported.accepted, last_reported.executed) {
                last_progress_at = session.transport.now();
            }
            control.progress(&progress);
            last_reported = progress;
        }
        if session.transport.now().saturating_sub(last_progress_at) > opts.watchdog {
            break Err(StreamError::Link(anyhow::anyhow!(
                "{}: no progress for {:.0} s while {} ({} of {n} blocks accepted, {} executed)",
                session.name,
                opts.watchdog.as_secs_f64(),
                st.phase(n, rx, frames, fw_state.as_deref()),
                st.accepted,
                st.executed
            )));
        }
        if st.accepted == n {
            accept_elapsed = session.transport.now() - t0;
            break Ok(());
        }
        // A stop (SIGTERM, SIGHUP, a second Ctrl-C): at once, whatever the firmware is doing.
        if let Some(cause) = control.stop_requested() {
            let why = cause.to_string();
            break Err(StreamError::StoppedAtOnce { name: session.name.clone(), why, executed: st.executed });
        }
        // Pause requests: a pause at the next pen-up, a feed hold, or (a second request, or one while the
        // firmware is held) a stop at once.
        if let Some(now) = control.pause_requested() {
            if let Some(why) = stop_at_once(held_state(fw_state.as_deref()), pause_at.is_some()) {
                break Err(StreamError::StoppedAtOnce { name: session.name.clone(), why, executed: st.executed });
            }
            if now {
                if hold_and_ask(session, &mut st, frames, control)? == PauseChoice::Abort {
                    break Err(StreamError::Aborted { executed: st.executed });
                }
                // (A report asked for before the hold may still say Hold; the next one tells.)
                fw_state = None;
            } else {
                let from = st.next.saturating_sub(1);
                pause_at = Some((from..n).find(|&i| frames.safe_after[i]).unwrap_or(n - 1));
            }
        }
        if let Some(p) = pause_at
            && st.accepted > p
        {
            let s = session.wait_idle(Duration::from_millis(100))?;
            st.on_status(&s, frames.base, n);
            st.executed = st.executed.max(st.accepted);
            control.progress(&Progress { executed: st.executed, ..last_reported });
            pause_at = None;
            if control.paused(false) == PauseChoice::Abort {
                break Err(StreamError::Aborted { executed: st.executed });
            }
            continue;
        }
        // Send what fits.
        let limit = pause_at.map_or(n, |p| p + 1);
        while st.next < limit && st.in_bytes + frames.bytes[st.next].len() <= rx {
            let f = &frames.bytes[st.next];
            session.transport.send(f)?;
            st.in_flight.push_back(InFlight { len: f.len(), generation: st.generation, index: st.next });
            st.in_bytes += f.len();
            st.bytes_sent += u64::try_from(f.len()).unwrap_or(u64::MAX);
            st.next += 1;
        }
        session.transport.set_streaming(st.next < n);
        // Periodic status for the executed count.
        let now = session.transport.now();
        // (A report lost to noise is asked for again after the quiet period.)
        st.ask_status_if_due(session, now, &opts)?;
        let Some(incoming) = session.recv(opts.quiet)? else {
            // Quiet: ask for the status and decide whether the firmware is just busy.
            stalls += 1;
            if stalls > opts.max_stalls {
                break Err(StreamError::Link(anyhow::anyhow!(
                    "{}: the firmware stopped answering ({} of {n} blocks accepted)",
                    session.name,
                    st.accepted
                )));
            }
            st.ask_status(session)?;
            st.resync_pending = true;
            continue;
        };
        let (number, line) = match incoming {
            Incoming::Reply(number, line) => (number, line),
            Incoming::Damaged(_) => {
                // Never acted on: a lost `ok` is made good by the next one, a lost `rs` by the next `rs`, a lost
                // status by asking again.
                st.damaged_replies += 1;
                continue;
            }
        };
        // A framed `ok`/`error:` names its frame.
        let frame = number.and_then(|x| usize::try_from(x.wrapping_sub(frames.base)).ok()).filter(|&i| i < n);
        match Reply::parse(&line) {
            Reply::Ok => {
                stalls = 0;
                st.resync_candidate = None;
                match frame {
                    Some(i) => {
                        st.answered_through(i);
                        st.accepted = st.accepted.max(i + 1).min(st.next);
                    }
                    None => {
                        st.answered();
                        st.accepted = (st.accepted + 1).min(st.next);
                    }
                }
            }
            Reply::Error { code, text } if REFUSALS.contains(&code) => {
                break Err(StreamError::Refused { block: frame.unwrap_or(st.accepted), code, text: text.to_string() });
            }
            Reply::Error { .. } => {
                // Only frames are sent while streaming, so a G-code error means line noise turned a frame into
                // something else. The firmware answers `rs` for a damaged frame that still holds a byte ≥ 0x80,
                // but a frame whose marker was cleared or dropped and whose other bytes are all below 0x80 looks
                // like (bad) G-code: that frame is lost, and the next frame's resend request (or the stall check)
                // brings it back.
                st.answered();
                st.noise_errors += 1;
            }
            Reply::Resend(e) => {
                let entry = st.answered();
                let idx = usize::try_from(e.wrapping_sub(frames.base)).unwrap_or(usize::MAX);
                if idx > n || idx > st.next {
                    break Err(StreamError::Link(anyhow::anyhow!(
                        "{}: the firmware asks for frame {e}, which was never sent",
                        session.name
                    )));
                }
                st.accepted = idx;
                if entry.is_none_or(|x| x.generation == st.generation) {
                    st.next = idx;
                    st.generation += 1;
                    st.resends += 1;
                }
            }
            Reply::Alarm { code, text } => {
                break Err(StreamError::Alarm { code, text: text.to_string(), executed: st.executed });
            }
            Reply::Banner(_) => break Err(StreamError::Restarted { executed: st.executed }),
            Reply::Completed(c) => {
                if let Some(seq) = number {
                    st.on_completed(seq, c, frames.base, n);
                }
            }
            Reply::Status(s) => {
                st.status_pending = false;
                let Some(s) = Status::parse(s) else { continue };
                fw_state = Some(s.state.clone());
                st.on_status(&s, frames.base, n);
                if st.resync_pending {
                    st.resync_pending = false;
                    let waiting_for_room = s.queued >= s.queue_size && s.state == "Run";
                    let accepted_fw = usize::try_from(s.seq.wrapping_sub(frames.base)).unwrap_or(usize::MAX);
                    // A status taken just before the firmware accepts a waiting frame can show a free slot, so
                    // only a second quiet report with the same number proves that nothing is held back.
                    let confirmed = st.resync_candidate == Some(s.seq);
                    st.resync_candidate = (!waiting_for_room).then_some(s.seq);
                    if !waiting_for_room && confirmed && accepted_fw <= st.next {
                        // Nothing is held back by the firmware: whatever is unanswered is lost.
                        st.resync_candidate = None;
                        st.in_flight.clear();
                        st.in_bytes = 0;
                        st.accepted = accepted_fw;
                        st.next = accepted_fw;
                        st.generation += 1;
                        st.resyncs += 1;
                    } else {
                        stalls = 0;
                    }
                }
            }
            Reply::Info(_) => {
                garbage += 1;
                if garbage > 1000 && st.accepted == 0 {
                    break Err(StreamError::Link(anyhow::anyhow!(
                        "{}: the device answers with unrecognised lines",
                        session.name
                    )));
                }
            }
        }
    };
    session.transport.set_streaming(false);
    result?;
    // Everything accepted: follow the execution to the very last block (the completion reports, with the status
    // as a backup), so the journal does too.
    let seq_after = frames.base.wrapping_add(u32::try_from(n).unwrap_or(u32::MAX));
    st.status_pending = false;
    let mut reported = st.executed;
    // Every block is queued: a pause at the next pen-up can no longer stop before the end, so a first request
    // only says so (a pause the main loop had scheduled at the last block counts as one), and a second one stops
    // at once; a feed hold works as before.
    let mut pause_scheduled = pause_at.is_some();
    loop {
        if let Some(cause) = control.stop_requested() {
            let why = cause.to_string();
            return Err(StreamError::StoppedAtOnce { name: session.name.clone(), why, executed: st.executed });
        }
        if let Some(now) = control.pause_requested() {
            if let Some(why) = stop_at_once(held_state(fw_state.as_deref()), pause_scheduled) {
                return Err(StreamError::StoppedAtOnce { name: session.name.clone(), why, executed: st.executed });
            }
            if now {
                if hold_and_ask(session, &mut st, frames, control)? == PauseChoice::Abort {
                    return Err(StreamError::Aborted { executed: st.executed });
                }
                fw_state = None;
            } else {
                pause_scheduled = true;
                control.notice(&format!(
                    "{}: every block is queued, so the plot ends with the pen up in a moment ({} of {n} blocks \
                     executed); a second pause request (Ctrl-C) stops it at once",
                    session.name, st.executed
                ));
            }
        }
        let now = session.transport.now();
        if st.executed != reported {
            reported = st.executed;
            last_progress_at = now;
            control.progress(&Progress {
                accepted: n,
                executed: st.executed,
                seq_after_accepted: seq_after,
                resends: st.resends,
            });
        }
        if st.executed == n {
            break;
        }
        if now.saturating_sub(last_progress_at) > opts.watchdog {
            return Err(StreamError::Link(anyhow::anyhow!(
                "{}: no progress for {:.0} s while {} ({} of {n} blocks executed)",
                session.name,
                opts.watchdog.as_secs_f64(),
                st.phase(n, rx, frames, fw_state.as_deref()),
                st.executed
            )));
        }
        st.ask_status_if_due(session, now, &opts)?;
        // (Virtual time passes for the simulator while receiving, unless it has nothing left to do.)
        let Some(incoming) = session.recv(opts.status_every)? else {
            // Quiet: ask now (a firmware without completion reports says it is idle only when asked).
            st.ask_status(session)?;
            continue;
        };
        let Incoming::Reply(number, line) = incoming else { continue };
        match Reply::parse(&line) {
            Reply::Completed(c) => {
                if let Some(seq) = number {
                    st.on_completed(seq, c, frames.base, n);
                }
            }
            Reply::Status(s) => {
                st.status_pending = false;
                let Some(s) = Status::parse(s) else { continue };
                if s.state == "Alarm" {
                    return Err(StreamError::Alarm {
                        code: 0,
                        text: "reported in the status".into(),
                        executed: st.executed,
                    });
                }
                st.on_status(&s, frames.base, n);
                if s.is_idle() {
                    st.executed = n;
                }
                fw_state = Some(s.state);
            }
            Reply::Alarm { code, text } => {
                return Err(StreamError::Alarm { code, text: text.to_string(), executed: st.executed });
            }
            Reply::Banner(_) => return Err(StreamError::Restarted { executed: st.executed }),
            _ => {}
        }
    }
    Ok(StreamStats {
        frames: n,
        frame_bytes: frames.total_bytes(),
        bytes_sent: st.bytes_sent,
        resends: st.resends,
        resyncs: st.resyncs,
        noise_errors: st.noise_errors,
        damaged_replies: st.damaged_replies,
        elapsed: session.transport.now() - t0,
        accept_elapsed,
        underruns: session.transport.underruns(),
    })
}

/// The firmware's reported state if it is a feed hold.
fn held_state(state: Option<&str>) -> Option<&str> {
    state.filter(|s| s.starts_with("Hold"))
}

/// A feed hold at once: hold, wait until the machine has come to a stop (the firmware only resumes from there),
/// ask the user, and resume when they say so. Returns their choice.
fn hold_and_ask<T: Transport>(
    session: &mut Session<T>,
    st: &mut State,
    frames: &Frames,
    control: &mut dyn Control,
) -> Result<PauseChoice, StreamError> {
    session.send_realtime(protocol::RT_FEED_HOLD)?;
    loop {
        let s = session.status()?;
        st.on_status(&s, frames.base, frames.len());
        if s.state == "Hold:0" || s.is_idle() {
            break;
        }
        let _ = session.transport.recv_line(Duration::from_millis(20))?;
    }
    let choice = control.paused(true);
    if choice == PauseChoice::Resume {
        session.send_realtime(protocol::RT_RESUME)?;
    }
    Ok(choice)
}

/// Stream a plan after checking where the firmware's sequence counter stands.
pub fn stream_plan<T: Transport>(
    session: &mut Session<T>,
    plan: &MotionPlan,
    opts: StreamOptions,
    control: &mut dyn Control,
) -> Result<(Frames, StreamStats), StreamError> {
    check_servo_support(&session.info, plan, &session.name)?;
    let s = session.status()?;
    if s.state == "Alarm" {
        return Err(StreamError::Link(anyhow::anyhow!("{}: the machine is in alarm; reset it first", session.name)));
    }
    let frames = Frames::encode(plan, s.seq)?;
    if frames.is_empty() {
        return Ok((frames, StreamStats::default()));
    }
    // The watchdog must outlast the longest block.
    let longest = plan.blocks.iter().map(|b| u64::from(b.block.duration_ticks())).max().unwrap_or(0);
    let longest = Duration::from_micros(longest * 1_000_000 / u64::from(plotter_fw::TICK_HZ));
    let opts = StreamOptions { watchdog: opts.watchdog.max(2 * longest), ..opts };
    let stats = stream(session, &frames, &s, opts, control)?;
    Ok((frames, stats))
}

/// First protocol version whose step blocks can drive a servo pen.
pub const SERVO_PROTOCOL: u32 = 3;

/// Refuse a plan with servo-pen blocks for a firmware older than [`SERVO_PROTOCOL`] (it would take them for plain
/// dwells and draw with the pen never lowered).
pub fn check_servo_support(info: &FirmwareInfo, plan: &MotionPlan, name: &str) -> Result<(), StreamError> {
    if info.protocol < SERVO_PROTOCOL && plan.blocks.iter().any(|b| b.block.servo.is_some()) {
        return Err(StreamError::Link(anyhow::anyhow!(
            "{name}: the profile lifts the pen with a servo, which needs step-block protocol {SERVO_PROTOCOL}, but the \
             firmware speaks protocol {} (version {}); update the firmware or plot with a Z-axis pen profile",
            info.protocol,
            info.version
        )));
    }
    Ok(())
}

/// Ignore-everything control (tests, benchmarks).
pub struct Quiet;

impl Control for Quiet {
    fn progress(&mut self, _: &Progress) {}
    fn pause_requested(&mut self) -> Option<bool> {
        None
    }
    fn paused(&mut self, _: bool) -> PauseChoice {
        PauseChoice::Resume
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::link::faults::Noise;
    use crate::link::sim::SimTransport;
    use plotter_fw::Axis;
    use plotter_path::geometry::steps::drawing_to_steps;
    use plotter_path::kurbo::Point;
    use plotter_path::motion::plan::{self, Lookahead};
    use plotter_path::{Drawing, MachineProfile, Polyline};

    fn spiral_plan(profile: &MachineProfile, start: [i32; 4]) -> MotionPlan {
        let pts: Vec<Point> = (0..1500)
            .map(|i| {
                let t = f64::from(i) * 0.05;
                Point::new(100.0 + (5.0 + t) * t.cos(), 100.0 + (5.0 + t) * t.sin())
            })
            .collect();
        let square = |x: f64| {
            Polyline::new(vec![
                Point::new(x, 10.0),
                Point::new(x + 10.0, 10.0),
                Point::new(x + 10.0, 20.0),
                Point::new(x, 20.0),
                Point::new(x, 10.0),
            ])
        };
        let mut paths: Vec<Polyline> = (0..40).map(|i| square(10.0 + 8.0 * f64::from(i))).collect();
        paths.push(Polyline::new(pts));
        let d = Drawing::single_layer("s", paths);
        let steps = drawing_to_steps(profile, &d).unwrap();
        plan::plan(profile, &steps, start, Lookahead::Whole).unwrap()
    }

    struct Run {
        trace: Vec<(Axis, bool)>,
        stats: StreamStats,
        busy: u64,
        plan_ticks: u64,
        end: [i64; 4],
        plan_end: [i32; 4],
    }

    fn run(noise: Option<Noise>, control: &mut dyn Control) -> Result<Run, StreamError> {
        let profile = MachineProfile::default_plotter();
        let cfg = plan::machine_config(&profile).unwrap();
        let mut t = SimTransport::new(cfg, Some(115_200));
        if let Some(n) = noise {
            t = t.with_noise(n);
        }
        let mut s = Session::connect(t, "sim").unwrap();
        s.home().unwrap();
        let start = s.status().unwrap().steps;
        let plan = spiral_plan(&profile, start);
        let busy0 = s.transport.sim().hal().busy_ticks();
        let steps0 = s.transport.sim().hal().steps().len();
        let (_, stats) = stream_plan(&mut s, &plan, StreamOptions::default(), control)?;
        let sim = s.transport.sim();
        Ok(Run {
            trace: sim.hal().steps()[steps0..].iter().map(|e| (e.axis, e.forward)).collect(),
            stats,
            busy: sim.hal().busy_ticks() - busy0,
            plan_ticks: plan.total_ticks,
            end: sim.physical_position(),
            plan_end: plan.end,
        })
    }

    fn state(completed_base: Option<u32>) -> State {
        State::new(Duration::ZERO, completed_base)
    }

    #[test]
    fn servo_plans_need_protocol_3() {
        let mut servo = MachineProfile::default_plotter();
        servo.pen.command = plotter_path::config::profile::PenCommand::Servo;
        let d = Drawing::single_layer("s", vec![Polyline::new(vec![Point::new(10.0, 10.0), Point::new(20.0, 10.0)])]);
        let steps = drawing_to_steps(&servo, &d).unwrap();
        let p = plan::plan(&servo, &steps, plan::homed_position(&servo).unwrap(), Lookahead::Whole).unwrap();
        let info = |protocol| FirmwareInfo { version: "0.1.0".into(), rx_bytes: 256, queue_blocks: 32, protocol };
        let e = check_servo_support(&info(2), &p, "/dev/ttyACM0").unwrap_err().to_string();
        assert!(e.contains("/dev/ttyACM0") && e.contains("protocol 3") && e.contains("protocol 2"), "{e}");
        assert!(check_servo_support(&info(3), &p, "sim").is_ok());
        // A Z-pen plan streams to the older firmware.
        let z = MachineProfile::default_plotter();
        let zp =
            plan::plan(&z, &drawing_to_steps(&z, &d).unwrap(), plan::homed_position(&z).unwrap(), Lookahead::Whole);
        assert!(check_servo_support(&info(2), &zp.unwrap(), "sim").is_ok());
    }

    #[test]
    fn executed_count_is_exact_with_the_completed_field_and_a_lower_bound_without() {
        // 30 of 100 frames (numbered from 1000) accepted, 10 in the planner queue; the firmware has completed 19 of
        // them since the stream began at its count 4294967290 (the count wraps).
        let run = "Run|MPos:0,0,0,0|Steps:0,0,0,0|Q:10/32|N:1030";
        let with_c = Status::parse(&format!("{run}|C:13")).unwrap();
        let without_c = Status::parse(run).unwrap();
        let mut st = state(Some(4_294_967_290));
        st.on_status(&with_c, 1000, 100);
        assert_eq!(st.executed, 19);
        let mut st = state(None);
        st.on_status(&with_c, 1000, 100);
        assert_eq!(st.executed, 30 - 10 - STEPPER_QUEUE - 1, "no base: lower bound");
        let mut st = state(Some(4_294_967_290));
        st.on_status(&without_c, 1000, 100);
        assert_eq!(st.executed, 30 - 10 - STEPPER_QUEUE - 1, "old firmware: lower bound");
        // Never more than the firmware has accepted, never backwards.
        let mut st = state(Some(0));
        st.on_status(&Status::parse(&format!("{run}|C:90")).unwrap(), 1000, 100);
        assert_eq!(st.executed, 30);
        st.on_status(&Status::parse(&format!("{run}|C:5")).unwrap(), 1000, 100);
        assert_eq!(st.executed, 30);
    }

    /// Records every progress report (the GRBL session's tests use it too).
    #[derive(Default)]
    pub(crate) struct Record(pub(crate) Vec<Progress>);

    impl Control for Record {
        fn progress(&mut self, p: &Progress) {
            self.0.push(*p);
        }
        fn pause_requested(&mut self) -> Option<bool> {
            None
        }
        fn paused(&mut self, _: bool) -> PauseChoice {
            PauseChoice::Resume
        }
    }

    #[test]
    fn executed_progress_follows_the_firmware_count_during_the_stream() {
        let mut rec = Record::default();
        run(None, &mut rec).unwrap();
        // With `C:` the executed figure is exact, so while frames are still being accepted it can exceed the old
        // lower bound (accepted − queue − stepper queue − 1) — which it never could before.
        let profile = MachineProfile::default_plotter();
        let q = plan::machine_config(&profile).unwrap().queue_blocks;
        let q = usize::try_from(q).unwrap();
        assert!(
            rec.0.iter().any(|p| p.executed > 0
                && p.accepted < rec.0.last().unwrap().accepted
                && p.executed > p.accepted.saturating_sub(q + STEPPER_QUEUE + 1)),
            "{:?}",
            &rec.0[..rec.0.len().min(20)]
        );
        assert!(rec.0.windows(2).all(|w| w[0].executed <= w[1].executed && w[1].executed <= w[1].accepted));
    }

    #[test]
    fn clean_run_executes_the_plan_exactly() {
        let r = run(None, &mut Quiet).unwrap();
        assert_eq!(r.busy, r.plan_ticks, "host-planned time is the executed time");
        assert_eq!(r.end, r.plan_end.map(i64::from));
        assert_eq!((r.stats.resends, r.stats.resyncs), (0, 0));
        assert_eq!(r.stats.underruns, Some(0));
        assert_eq!(r.stats.bytes_sent, u64::try_from(r.stats.frame_bytes).unwrap());
    }

    #[test]
    fn noisy_link_gives_the_same_trace_with_resends() {
        let clean = run(None, &mut Quiet).unwrap();
        for seed in [1, 2] {
            let noisy = run(Some(Noise::new(0.01, seed)), &mut Quiet).unwrap();
            assert!(noisy.stats.resends > 10, "seed {seed}: {:?}", noisy.stats);
            assert!(noisy.stats.bytes_sent > clean.stats.bytes_sent);
            assert_eq!(noisy.trace, clean.trace, "seed {seed}");
            assert_eq!(noisy.end, clean.end);
            // Stalls for resends add idle time, never motion time.
            assert_eq!(noisy.busy, clean.busy);
        }
    }

    /// Pauses once after `at` accepted frames, then answers `choice`.
    struct PauseOnce {
        at: usize,
        seen: usize,
        asked: bool,
        held: Option<bool>,
        choice: PauseChoice,
        immediately: bool,
    }

    impl Control for PauseOnce {
        fn progress(&mut self, p: &Progress) {
            self.seen = p.accepted;
        }
        fn pause_requested(&mut self) -> Option<bool> {
            if !self.asked && self.seen >= self.at {
                self.asked = true;
                return Some(self.immediately);
            }
            None
        }
        fn paused(&mut self, held: bool) -> PauseChoice {
            self.held = Some(held);
            self.choice
        }
    }

    #[test]
    fn pause_at_pen_up_then_resume_or_abort() {
        let clean = run(None, &mut Quiet).unwrap();
        let mut c =
            PauseOnce { at: 3, seen: 0, asked: false, held: None, choice: PauseChoice::Resume, immediately: false };
        let r = run(None, &mut c).unwrap();
        assert_eq!(c.held, Some(false));
        assert_eq!(r.trace, clean.trace);
        let mut c =
            PauseOnce { at: 3, seen: 0, asked: false, held: None, choice: PauseChoice::Abort, immediately: false };
        let profile = MachineProfile::default_plotter();
        let plan = spiral_plan(&profile, [0, 0, 1600, 0]);
        match run(None, &mut c) {
            // The pause waits for a stroke to end: the last executed block lifted the pen (between strokes of one
            // pen only to the clearance, with no settle; the hop's travel goes on up from there).
            Err(StreamError::Aborted { executed }) => {
                assert!(executed > 3 && executed < plan.blocks.len() / 2, "{executed}");
                let last = &plan.blocks[executed - 1];
                let before = &plan.blocks[executed - 2];
                assert!(
                    last.kind == MoveKind::PenUp && before.kind == MoveKind::Draw,
                    "{:?} {:?}",
                    before.kind,
                    last.kind
                );
            }
            other => panic!("{:?}", other.map(|r| r.stats)),
        }
        let mut c =
            PauseOnce { at: 100, seen: 0, asked: false, held: None, choice: PauseChoice::Resume, immediately: true };
        let r = run(None, &mut c).unwrap();
        assert_eq!(c.held, Some(true));
        assert_eq!(r.trace, clean.trace);
    }
}
