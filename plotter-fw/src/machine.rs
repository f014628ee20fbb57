//! The firmware proper: receive path, line handling (sequencing, resends), the G-code interpreter, the planner
//! queue, the hand-off to the stepper, homing, alarms and real-time commands.
//!
//! # Entry points (how a board wires it)
//! - [`Machine::receive`] from the serial receive interrupt, one byte at a time;
//! - [`Machine::on_timer`] from the step timer interrupt;
//! - [`Machine::poll`] from the main loop, as often as possible.
//!
//! On hardware the two interrupt entry points and `poll` share the `Machine`; the board integration runs `poll`'s
//! body with the timer and UART interrupts masked (a critical section), as single-core firmwares do. The
//! simulator calls all three from one thread.
//!
//! # Look-ahead and the stepper hand-off
//! Moves parsed from G-code are planned in the bounded planner queue ([`crate::planner`], re-planned on every
//! new block). A planned block is handed to the stepper — and frozen — only when the stepper holds fewer than two
//! blocks, so the planner keeps as much look-ahead as the input gives it. Host-planned step blocks and dwells pass
//! through the same queue unchanged ([`PlanBlock::fixed`]).
//!
//! # Coordinates
//! Positions are kept exactly, in millionths of a millimetre (machine coordinates: 0 at the homing switch). A
//! target is converted to whole steps once (rounded), and a move is the difference to the previous target in
//! steps, so relative moves never drift. `G92` offsets work coordinates from machine coordinates.

use core::fmt::{self, Write as _};

use heapless::Deque;

use crate::axis::{Axis, NUM_AXES};
use crate::config::MachineConfig;
use crate::decimal::Decimal;
use crate::errors::{AlarmCode, ErrorCode};
use crate::framing::{self, M_FRAMED, RtMatcher};
use crate::gcode::{MICRO, Words, envelope, parse_words};
use crate::hal::{Hal, Heaters, NoHeaters};
use crate::homing::{HomingCycle, HomingStep};
use crate::line_buffer::{Frame, LINE_MAX, LineAssembler, RxBuffer};
use crate::planner::{Linker, PlanBlock, plan, to_step_block};
use crate::protocol::{Decoder, PROTOCOL_VERSION, RT_FEED_HOLD, RT_RESET, RT_RESUME, RT_STATUS, is_realtime};
use crate::realtime::MachineState;
use crate::report::CompletionReporter;
use crate::step_block::{StepBlock, Switches, TICK_HZ};
use crate::stepper::{Stepper, StepperFault};
use crate::thermal::{Cmd, EmergencyParser, Thermal, ThermalConfig};

/// Firmware version reported in the banner and M115.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");

const RT_FLAG_STATUS: u8 = 1;
const RT_FLAG_RESUME: u8 = 2;
const RT_FLAG_RESET: u8 = 4;

/// Result of handling one frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Outcome {
    /// Answered; take the next frame.
    Done,
    /// Cannot run yet (queue full, waiting for idle, homing): keep the frame and retry on the next poll.
    Blocked,
}

/// G-code modal state.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Modal {
    absolute: bool,
    inches: bool,
    /// Last motion command: 0 or 1.
    motion: u16,
    /// Feed for G1, mm/s (0 = not set yet).
    feed_mm_s: f32,
    /// E words are relative (M83, or G91 until M82).
    e_relative: bool,
}

impl Modal {
    const DEFAULT: Modal = Modal { absolute: true, inches: false, motion: 0, feed_mm_s: 0.0, e_relative: false };
}

/// Writes formatted text to the serial port.
struct Out<'a, H: Hal>(&'a mut H);

impl<H: Hal> fmt::Write for Out<'_, H> {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        self.0.write(s.as_bytes());
        Ok(())
    }
}

/// The firmware. `RX` is the receive buffer capacity (bytes), `Q` the planner queue capacity (blocks); the sizes
/// announced to the host are the configured ones, clamped to these. `T` is the printer's heater I/O
/// ([`NoHeaters`] on plotters).
pub struct Machine<H: Hal, const RX: usize = 256, const Q: usize = 32, T: Heaters = NoHeaters> {
    hal: H,
    heaters: T,
    thermal: Thermal,
    estop: EmergencyParser,
    /// `M112` was received; `poll` latches the alarm.
    estop_pending: bool,
    cfg: MachineConfig,
    rx: RxBuffer<RX>,
    asm: LineAssembler,
    pending: heapless::Vec<u8, LINE_MAX>,
    pending_kind: Option<PendingKind>,
    planner: Deque<PlanBlock, Q>,
    /// Cornering memory of the planner (the last blocks' geometry, for curve radii).
    linker: Linker,
    queue_limit: usize,
    first_entry_sqr: f32,
    hold_replanned: bool,
    stepper: Stepper,
    timer_running: bool,
    decoder: Decoder,
    seq: u32,
    resync: bool,
    alarm: Option<AlarmCode>,
    homed: u8,
    homing: Option<HomingCycle>,
    homing_result: Option<Result<(), AlarmCode>>,
    modal: Modal,
    /// Machine position of the last queued target, millionths of a mm.
    target_um: [i64; NUM_AXES],
    /// The same in steps (what the queue ends at).
    target_steps: [i32; NUM_AXES],
    offset_um: [i64; NUM_AXES],
    rt: u8,
    last_completed: u32,
    /// `~` arrived while a feed hold was still decelerating: resume as soon as it has stopped.
    resume_after_hold: bool,
    /// The stepper's completed-block count at start or the last reset (the status report's `C:` counts from it).
    completed_base: u32,
    /// A sequenced stream is active: a sequenced frame was accepted or a resend requested since the last reset or
    /// the last plain G-code line. Bytes ≥ 0x80 in a line then mean a damaged frame.
    streaming: bool,
    /// Servo pen: the angle `M5` lifts to (set with `M5 S<angle>`).
    servo_up_deg: f32,
    /// `M0`/`M1` program pause (a pen change in a raw G-code stream): nothing more runs until `~`.
    program_paused: bool,
    /// Framed mode ([`crate::framing`]): CRC-framed replies, four-byte real-time commands, sequenced input only.
    framed: bool,
    rt_matcher: RtMatcher,
    /// The sequence number of the frame or line being answered (framed `ok`/`error:` carry it).
    answering: u32,
    /// When to send the next completion report (framed mode, [`crate::report`]).
    reporter: CompletionReporter,
    /// A step block was refused (its sequence number and error code): every later frame is refused too, so nothing
    /// after a hole in the plot runs, until a reset, a homing cycle or framed mode switched on again. The status
    /// report carries it as `R:<n>,<code>`.
    refused: Option<(u32, u8)>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum PendingKind {
    Line,
    TooLong,
    Damaged,
}

impl<H: Hal, const RX: usize, const Q: usize> Machine<H, RX, Q, NoHeaters> {
    /// Start the firmware on `hal` with `cfg` (validate it first with [`MachineConfig::validate`]); sends the
    /// banner. No heaters (a plotter).
    pub fn new(hal: H, cfg: MachineConfig) -> Self {
        Self::with_heaters(hal, cfg, NoHeaters, ThermalConfig::NONE)
    }
}

impl<H: Hal, const RX: usize, const Q: usize, T: Heaters> Machine<H, RX, Q, T> {
    /// Start the firmware of a printer: `heaters` drives the heater outputs and reads the thermistors configured
    /// in `thermal` (validate both configurations first); sends the banner.
    pub fn with_heaters(hal: H, cfg: MachineConfig, heaters: T, thermal: ThermalConfig) -> Self {
        let invert = Axis::ALL.iter().filter(|a| cfg.axis(**a).invert_dir).fold(0, |m, a| m | a.bit());
        let limits = if cfg.hard_limits {
            Axis::ALL.iter().filter(|a| cfg.axis(**a).is_limited()).fold(0, |m, a| m | a.bit())
        } else {
            0
        };
        let queue_limit = usize::try_from(cfg.queue_blocks).unwrap_or(Q).clamp(1, Q);
        let thermal = Thermal::new(thermal, hal.now());
        let mut m = Machine {
            hal,
            heaters,
            thermal,
            estop: EmergencyParser::new(),
            estop_pending: false,
            cfg,
            rx: RxBuffer::new(),
            asm: LineAssembler::new(),
            pending: heapless::Vec::new(),
            pending_kind: None,
            planner: Deque::new(),
            linker: Linker::new(),
            queue_limit,
            first_entry_sqr: 0.0,
            hold_replanned: false,
            stepper: Stepper::new(invert, limits),
            timer_running: false,
            decoder: Decoder::new(),
            seq: 0,
            resync: false,
            alarm: None,
            homed: 0,
            homing: None,
            homing_result: None,
            modal: Modal::DEFAULT,
            target_um: [0; NUM_AXES],
            target_steps: [0; NUM_AXES],
            offset_um: [0; NUM_AXES],
            rt: 0,
            last_completed: 0,
            resume_after_hold: false,
            completed_base: 0,
            streaming: false,
            servo_up_deg: cfg.pen.servo_up_deg,
            program_paused: false,
            framed: false,
            rt_matcher: RtMatcher::new(),
            answering: 0,
            reporter: CompletionReporter::new(0),
            refused: None,
        };
        m.banner();
        m
    }

    /// The board.
    pub fn hal(&self) -> &H {
        &self.hal
    }

    /// The board, mutably (simulator access to pins and clock).
    pub fn hal_mut(&mut self) -> &mut H {
        &mut self.hal
    }

    /// The heater I/O.
    pub fn heaters(&self) -> &T {
        &self.heaters
    }

    /// The heater I/O, mutably (simulator access to the thermal model).
    pub fn heaters_mut(&mut self) -> &mut T {
        &mut self.heaters
    }

    /// The heater controller (temperatures, targets, duties).
    pub fn thermal(&self) -> &Thermal {
        &self.thermal
    }

    /// When the main loop must run next for the heaters (ticks); `None` without heaters.
    pub fn thermal_deadline(&self) -> Option<u64> {
        self.thermal.next_deadline()
    }

    /// The configuration.
    pub fn config(&self) -> &MachineConfig {
        &self.cfg
    }

    /// The stepper (position, queue state).
    pub fn stepper(&self) -> &Stepper {
        &self.stepper
    }

    /// Receive buffer size announced to the host.
    pub fn rx_size(&self) -> usize {
        usize::try_from(self.cfg.rx_buffer_bytes).unwrap_or(RX).min(RX)
    }

    /// Planner queue size announced to the host.
    pub fn queue_size(&self) -> usize {
        self.queue_limit
    }

    /// The latched alarm.
    pub fn alarm(&self) -> Option<AlarmCode> {
        self.alarm
    }

    /// Mask of homed axes.
    pub fn homed(&self) -> u8 {
        self.homed
    }

    /// Next expected sequence number.
    pub fn expected_seq(&self) -> u32 {
        self.seq
    }

    /// Whether the receive buffer holds bytes or a frame is waiting.
    pub fn has_input(&self) -> bool {
        !self.rx.is_empty() || self.pending_kind.is_some()
    }

    /// Free bytes in the receive buffer.
    pub fn rx_free(&self) -> usize {
        self.rx_size().saturating_sub(self.rx.len())
    }

    /// Current state.
    pub fn state(&self) -> MachineState {
        if self.alarm.is_some() {
            MachineState::Alarm
        } else if self.homing.is_some() {
            MachineState::Homing
        } else if self.stepper.is_held() || self.program_paused {
            MachineState::Held
        } else if self.stepper.is_holding() {
            MachineState::Holding
        } else if !self.stepper.is_idle() || !self.planner.is_empty() {
            MachineState::Run
        } else {
            MachineState::Idle
        }
    }

    /// Nothing left to do: no motion, no queued blocks, no pending input.
    pub fn is_idle(&self) -> bool {
        self.stepper.is_idle() && self.planner.is_empty() && self.homing.is_none() && !self.has_input() && self.rt == 0
    }

    /// Whether a block finished or something else happened that `poll` should see.
    pub fn needs_poll(&self) -> bool {
        self.stepper.completed() != self.last_completed
            || self.rt != 0
            || self.stepper.fault().is_some()
            || (self.resume_after_hold && self.stepper.is_held())
            || self.thermal.due(self.hal.now())
            || self.estop_pending
            || self.completion_due()
    }

    /// Nothing left to run: planner queue and stepper empty.
    fn drained(&self) -> bool {
        self.stepper.is_idle() && self.planner.is_empty()
    }

    /// Whether a completion report should go out now ([`crate::report`]; framed mode only).
    fn completion_due(&self) -> bool {
        self.framed && self.reporter.due(self.stepper.completed(), self.hal.now(), self.drained())
    }

    /// Send the completion report when one is due.
    fn report_completion(&mut self) {
        if self.completion_due() {
            let completed = self.stepper.completed();
            let (done, seq) = (completed.wrapping_sub(self.completed_base), self.seq);
            self.reply(seq, format_args!("C:{done}"));
            self.reporter.sent(completed, self.hal.now());
        }
    }

    /// Serial receive path (interrupt context): real-time bytes act at once, the rest goes to the ring buffer
    /// (a byte that does not fit is counted and reported, see [`RxBuffer`]). Counting against the announced size.
    pub fn receive(&mut self, b: u8) {
        if self.estop.feed(b) {
            // M112: act now, not when the line's turn comes.
            self.thermal.shutdown(&mut self.heaters);
            self.stepper.abort();
            self.hal.cancel();
            self.timer_running = false;
            self.estop_pending = true;
        }
        if self.framed {
            // Only a complete four-byte sequence is a command; everything else is data (see `crate::framing`).
            let mut matcher = core::mem::take(&mut self.rt_matcher);
            let cmd = matcher.feed(b, |d| self.receive_data(d));
            self.rt_matcher = matcher;
            if let Some(c) = cmd {
                self.realtime(c);
            }
            return;
        }
        if is_realtime(b) {
            self.realtime(b);
            return;
        }
        self.receive_data(b);
    }

    /// Whether framed mode is on ([`crate::framing`]).
    pub fn is_framed(&self) -> bool {
        self.framed
    }

    fn realtime(&mut self, b: u8) {
        {
            match b {
                RT_STATUS => self.rt |= RT_FLAG_STATUS,
                RT_FEED_HOLD => {
                    // The latest real-time command wins: a hold cancels a resume still waiting for the stop.
                    self.resume_after_hold = false;
                    self.stepper.feed_hold();
                }
                RT_RESUME => self.rt |= RT_FLAG_RESUME,
                RT_RESET => {
                    self.stepper.abort();
                    self.hal.cancel();
                    self.timer_running = false;
                    self.rt |= RT_FLAG_RESET;
                }
                _ => {}
            }
        }
    }

    fn receive_data(&mut self, b: u8) {
        if self.rx.len() >= self.rx_size() {
            // Over the announced size: recorded as a loss, exactly like a full ring.
            self.rx.mark_loss();
            return;
        }
        self.rx.push(b);
    }

    /// Step timer interrupt.
    pub fn on_timer(&mut self) {
        match self.stepper.tick(&mut self.hal) {
            Some(t) => self.hal.schedule(t),
            None => {
                self.timer_running = false;
                self.hal.cancel();
            }
        }
    }

    /// Main loop pass: real-time work, homing, line handling, planning, stepper hand-off.
    pub fn poll(&mut self) {
        self.last_completed = self.stepper.completed();
        self.service_realtime();
        if let Some(StepperFault::HardLimit(_)) = self.stepper.fault() {
            self.stepper.clear_fault();
            self.raise_alarm(AlarmCode::HardLimit);
        }
        if self.stepper.is_held() && !self.hold_replanned {
            // Everything after the hold restarts from rest.
            self.hold_replanned = true;
            self.first_entry_sqr = 0.0;
            plan(self.planner.make_contiguous(), 0.0);
        }
        if self.resume_after_hold && self.stepper.is_held() {
            // A `~` received while the hold was decelerating: the hold has now stopped (and was re-planned).
            self.resume_after_hold = false;
            self.resume();
        }
        self.service_thermal();
        self.run_homing();
        loop {
            if self.pending_kind.is_none() && !self.next_frame() {
                break;
            }
            if self.handle_pending() == Outcome::Blocked {
                break;
            }
            self.pending_kind = None;
            self.pending.clear();
            self.feed_stepper();
            self.run_homing();
        }
        self.feed_stepper();
        self.report_completion();
    }

    fn next_frame(&mut self) -> bool {
        while let Some((b, lost)) = self.rx.pop() {
            if let Some(frame) = self.asm.feed(b, lost) {
                let (kind, bytes) = match frame {
                    Frame::Line(l) => (PendingKind::Line, l),
                    Frame::TooLong(l) => (PendingKind::TooLong, l),
                    Frame::Damaged(l) => (PendingKind::Damaged, l),
                };
                self.pending.clear();
                // Cannot fail: frames are at most LINE_MAX bytes.
                let _ = self.pending.extend_from_slice(bytes);
                self.pending_kind = Some(kind);
                return true;
            }
        }
        false
    }

    fn banner(&mut self) {
        let (rx, q, seq) = (self.rx_size(), self.queue_limit, self.seq);
        let _ = writeln!(
            Out(&mut self.hal),
            "plotter-fw {VERSION} proto {PROTOCOL_VERSION} rx {rx} queue {q} line {LINE_MAX} seq {seq}"
        );
    }

    /// One reply line: plain, or framed with number `n` in framed mode.
    fn reply(&mut self, n: u32, text: fmt::Arguments<'_>) {
        if self.framed {
            let _ = framing::write_reply(Out(&mut self.hal), n, text);
        } else {
            let _ = writeln!(Out(&mut self.hal), "{text}");
        }
    }

    fn reply_ok(&mut self) {
        self.reply(self.answering, format_args!("ok"));
    }

    fn reply_error(&mut self, code: ErrorCode, detail: fmt::Arguments<'_>) {
        self.reply(self.answering, format_args!("error:{} {}{}", code.code(), code.text(), detail));
    }

    fn reply_resend(&mut self) {
        self.resync = true;
        self.streaming = true;
        let seq = self.seq;
        self.reply(seq, format_args!("rs {seq}"));
    }

    /// The heaters' period (PID, safety checks) and a pending emergency stop.
    fn service_thermal(&mut self) {
        if core::mem::take(&mut self.estop_pending) {
            self.raise_alarm(AlarmCode::EmergencyStop);
        }
        let now = self.hal.now();
        if let Some(alarm) = self.thermal.tick(&mut self.heaters, now, &mut Out(&mut self.hal)) {
            self.raise_alarm(AlarmCode::Thermal(alarm));
        }
    }

    /// A temperature, fan or emergency-stop command (see [`crate::thermal`]); `None` when `w` is none of these.
    fn thermal_command(&mut self, w: &Words) -> Option<Outcome> {
        if !w.m.iter().any(|&m| crate::thermal::handles(m)) {
            return None;
        }
        let now = self.hal.now();
        let alarm = self.alarm.is_some();
        match self.thermal.command(w, now, &mut self.heaters, &mut Out(&mut self.hal), alarm) {
            Cmd::Ok => self.reply_ok(),
            Cmd::Blocked => return Some(Outcome::Blocked),
            Cmd::Error(code, detail) => self.reply_error(code, format_args!("{detail}")),
            Cmd::EmergencyStop => {
                self.raise_alarm(AlarmCode::EmergencyStop);
                self.reply_ok();
            }
        }
        Some(Outcome::Done)
    }

    fn raise_alarm(&mut self, code: AlarmCode) {
        if code.is_shutdown() {
            self.thermal.shutdown(&mut self.heaters);
            self.hal.enable_motors(false);
        }
        self.stepper.abort();
        self.hal.cancel();
        self.timer_running = false;
        self.planner.clear();
        self.linker.clear();
        self.first_entry_sqr = 0.0;
        self.homing = None;
        if self.homing_result.is_none() && matches!(code, AlarmCode::HomingNotFound | AlarmCode::HomingNotReleased) {
            self.homing_result = Some(Err(code));
        }
        self.homed = 0;
        self.resume_after_hold = false;
        self.sync_target();
        if self.alarm.is_none() {
            self.alarm = Some(code);
            self.reply(self.seq, format_args!("{code}"));
        }
    }

    fn service_realtime(&mut self) {
        let rt = core::mem::take(&mut self.rt);
        if rt & RT_FLAG_RESET != 0 {
            let moving = !self.stepper.is_idle() || !self.planner.is_empty() || self.homing.is_some();
            self.stepper.abort();
            self.stepper.clear_fault();
            self.hal.cancel();
            self.timer_running = false;
            self.planner.clear();
            self.first_entry_sqr = 0.0;
            self.hold_replanned = false;
            self.rx.clear();
            self.asm.clear();
            self.pending.clear();
            self.pending_kind = None;
            self.decoder = Decoder::new();
            self.seq = 0;
            self.resync = false;
            self.alarm = None;
            self.homing = None;
            self.homing_result = None;
            self.modal = Modal::DEFAULT;
            self.resume_after_hold = false;
            self.streaming = false;
            self.program_paused = false;
            self.framed = false;
            self.rt_matcher.clear();
            self.completed_base = self.stepper.completed();
            self.refused = None;
            self.thermal.restore_cold_extrusion();
            if moving {
                // Stopped without deceleration: steps may have been lost.
                self.homed = 0;
            }
            self.sync_target();
            self.last_completed = self.stepper.completed();
            self.banner();
            return;
        }
        if rt & RT_FLAG_RESUME != 0 {
            if self.program_paused {
                self.program_paused = false;
            } else if self.stepper.is_held() {
                self.resume();
            } else if self.stepper.is_holding() {
                // Still decelerating: remember the resume and act once the hold has stopped (see `poll`).
                self.resume_after_hold = true;
            }
        }
        if rt & RT_FLAG_STATUS != 0 {
            self.status_report();
        }
    }

    fn resume(&mut self) {
        self.hold_replanned = false;
        if let Some(t) = self.stepper.resume(&mut self.hal) {
            self.timer_running = true;
            self.hal.schedule(t);
        }
        self.feed_stepper();
    }

    /// Write the status report line (also sent for `?`).
    pub fn status_report(&mut self) {
        let state = self.state();
        let pos = self.stepper.position();
        let used = self.planner.len();
        let (q, seq) = (self.queue_limit, self.seq);
        let done = self.stepper.completed().wrapping_sub(self.completed_base);
        let mut mm = [0.0f32; NUM_AXES];
        for axis in Axis::ALL {
            mm[axis.index()] = pos[axis.index()] as f32 / self.cfg.axis(axis).steps_per_mm;
        }
        let refused = Refused(self.refused);
        self.reply(
            seq,
            format_args!(
                "<{state}|MPos:{},{},{},{}|Steps:{},{},{},{}|Q:{used}/{q}|N:{seq}|C:{done}{refused}>",
                Decimal::new(mm[0], 3),
                Decimal::new(mm[1], 3),
                Decimal::new(mm[2], 3),
                Decimal::new(mm[3], 3),
                pos[0],
                pos[1],
                pos[2],
                pos[3]
            ),
        );
    }

    fn sync_target(&mut self) {
        let pos = self.stepper.position();
        self.target_steps = pos;
        for axis in Axis::ALL {
            let i = axis.index();
            let spm = f64::from(self.cfg.axis(axis).steps_per_mm);
            self.target_um[i] = round_i64(f64::from(pos[i]) / spm * 1e6);
        }
    }

    fn quiescent(&self) -> bool {
        self.stepper.is_idle() && self.planner.is_empty() && self.homing.is_none()
    }

    /// Move planned blocks to the stepper while it holds fewer than two, then make sure it runs.
    fn feed_stepper(&mut self) {
        while self.stepper.pending() < 2 && !self.stepper.is_held() {
            let Some(head) = self.planner.pop_front() else { break };
            let exit = self.planner.front().map_or(0.0, |b| b.entry_speed_sqr);
            self.first_entry_sqr = exit;
            let block = to_step_block(&head, exit);
            // Cannot fail: the stepper holds fewer than two blocks and its queue takes two.
            let _ = self.stepper.push(block, Switches::Limits);
        }
        self.start_stepper();
    }

    fn start_stepper(&mut self) {
        if !self.timer_running
            && let Some(t) = self.stepper.start(&mut self.hal)
        {
            self.timer_running = true;
            self.hal.schedule(t);
        }
    }

    fn run_homing(&mut self) {
        while let Some(cycle) = self.homing.as_mut() {
            if !self.stepper.is_idle() {
                return;
            }
            let pressed = self.hal.pressed();
            let step = cycle.next(&self.cfg, self.stepper.homing_hits(), pressed, &self.stepper.position());
            match step {
                HomingStep::Move(b, switches) => {
                    let _ = self.stepper.push(b, switches);
                    self.start_stepper();
                    return;
                }
                HomingStep::SetPosition(_, pos) => {
                    self.stepper.set_position(pos);
                    self.sync_target();
                }
                HomingStep::Alarm(code) => {
                    self.homing_result = Some(Err(code));
                    self.raise_alarm(code);
                    return;
                }
                HomingStep::Done(mask) => {
                    self.homed |= mask;
                    self.refused = None;
                    self.homing = None;
                    self.homing_result = Some(Ok(()));
                    self.sync_target();
                    return;
                }
            }
        }
    }

    fn handle_pending(&mut self) -> Outcome {
        let kind = self.pending_kind.unwrap_or(PendingKind::Line);
        let mut buf = [0u8; LINE_MAX];
        let len = self.pending.len();
        buf[..len].copy_from_slice(&self.pending);
        let line = &buf[..len];
        // G-code is ASCII: during a sequenced stream, a line with a byte ≥ 0x80 is a step-block frame whose marker
        // bit (or marker byte) was damaged on the wire, never a command to run.
        let damaged_frame = self.streaming && line.iter().any(|&c| c >= 0x80);
        let sequenced =
            self.framed || damaged_frame || line.first().is_some_and(|&c| c >= 0x80 || c == b'N' || c == b'n');
        self.answering = self.seq;
        if self.framed && kind == PendingKind::Line && line.first().is_none_or(|&c| c < 0x80) {
            // Framed mode takes sequenced input only: anything else is a damaged frame.
            match envelope(line) {
                Ok(e) if e.checked && e.number.is_some() => self.answering = e.number.unwrap_or(self.seq),
                _ => {
                    self.reply_resend();
                    return Outcome::Done;
                }
            }
        }
        match kind {
            PendingKind::TooLong | PendingKind::Damaged if sequenced => {
                self.reply_resend();
                return Outcome::Done;
            }
            PendingKind::TooLong => {
                self.reply_error(ErrorCode::LineTooLong, format_args!(""));
                return Outcome::Done;
            }
            PendingKind::Damaged => {
                let lost = self.rx.take_lost();
                self.reply_error(ErrorCode::RxOverflow, format_args!(": {lost} bytes"));
                return Outcome::Done;
            }
            PendingKind::Line => {}
        }
        if line.first().is_some_and(|&c| c >= 0x80) {
            return self.handle_step_frame(line);
        }
        if damaged_frame {
            self.reply_resend();
            return Outcome::Done;
        }
        let env = match envelope(line) {
            Ok(e) => e,
            Err(_) if sequenced => {
                self.reply_resend();
                return Outcome::Done;
            }
            Err(_) => {
                self.reply_error(ErrorCode::Checksum, format_args!(""));
                return Outcome::Done;
            }
        };
        let words = match parse_words(env.body) {
            Ok(w) => Some(w),
            Err(e) => {
                if env.number.is_some() && !env.checked {
                    self.reply_resend();
                    return Outcome::Done;
                }
                if let Some(n) = env.number
                    && n != self.seq
                {
                    self.reply_resend();
                    return Outcome::Done;
                }
                self.commit_seq(env.number);
                self.reply_error(e.code, format_args!(" at column {}", e.column));
                return Outcome::Done;
            }
        };
        let Some(words) = words else { return Outcome::Done };
        if env.number.is_none() && !env.checked {
            // A plain, well-formed G-code line: interactive use, not a sequenced stream.
            self.streaming = false;
        }
        if let Some(n) = env.number {
            let m110 = words.m.contains(&110);
            if !env.checked {
                self.reply_resend();
                return Outcome::Done;
            }
            if m110 {
                self.seq = n;
                self.resync = false;
            } else if n != self.seq {
                self.reply_resend();
                return Outcome::Done;
            }
        }
        let out = self.execute(&words);
        if out == Outcome::Done {
            self.commit_seq(env.number);
        }
        out
    }

    fn commit_seq(&mut self, number: Option<u32>) {
        if number.is_some() {
            self.seq = self.seq.wrapping_add(1);
            self.resync = false;
            self.streaming = true;
        }
    }

    fn handle_step_frame(&mut self, frame: &[u8]) -> Outcome {
        let mut trial = self.decoder.clone();
        let block = match trial.decode(frame, self.seq) {
            Ok(b) => b,
            Err(_) => {
                self.reply_resend();
                return Outcome::Done;
            }
        };
        if self.alarm.is_some() {
            self.decoder = trial;
            self.commit_seq(Some(0));
            self.reply_error(ErrorCode::Alarm, format_args!(""));
            return Outcome::Done;
        }
        if self.planner.len() >= self.queue_limit || self.homing.is_some() {
            return Outcome::Blocked;
        }
        self.decoder = trial;
        let number = self.seq;
        self.commit_seq(Some(0));
        if let Some((n, _)) = self.refused {
            self.reply_error(ErrorCode::BadFrame, format_args!(": block {n} was refused"));
            return Outcome::Done;
        }
        let mut target = self.target_steps;
        for (t, s) in target.iter_mut().zip(block.steps) {
            *t = t.saturating_add(s);
        }
        if !crate::range::position_ok(&target) {
            self.refused = Some((number, ErrorCode::OutOfRange.code()));
            self.reply_error(ErrorCode::OutOfRange, format_args!(": {}", crate::range::MoveRange::Position.text()));
            return Outcome::Done;
        }
        if let Some(axis) = crate::limits::violation(&self.cfg, self.homed, &target) {
            self.refused = Some((number, ErrorCode::SoftLimit.code()));
            self.reply_error(ErrorCode::SoftLimit, format_args!(": {}", axis.letter()));
            return Outcome::Done;
        }
        if block.steps[Axis::E.index()] != 0
            && let Some(cold) = self.thermal.cold_extrusion()
        {
            self.refused = Some((number, ErrorCode::ColdExtrusion.code()));
            self.reply_error(ErrorCode::ColdExtrusion, format_args!("{cold}"));
            return Outcome::Done;
        }
        self.set_target_steps(target);
        self.queue_block(PlanBlock::fixed(block));
        self.reply_ok();
        Outcome::Done
    }

    fn set_target_steps(&mut self, target: [i32; NUM_AXES]) {
        self.target_steps = target;
        for axis in Axis::ALL {
            let i = axis.index();
            let spm = f64::from(self.cfg.axis(axis).steps_per_mm);
            self.target_um[i] = round_i64(f64::from(target[i]) / spm * 1e6);
        }
    }

    fn queue_block(&mut self, block: PlanBlock) {
        // Cannot fail: callers check the fill against `queue_limit ≤ Q`.
        let _ = self.planner.push_back(block);
        self.linker.push(self.planner.make_contiguous(), &self.cfg);
        let first = if self.stepper.is_held() { 0.0 } else { self.first_entry_sqr };
        plan(self.planner.make_contiguous(), first);
    }

    /// A G-code length in millionths of the current unit → millionths of a mm; `None` on overflow.
    fn to_um(&self, value: i64) -> Option<i64> {
        if self.modal.inches { crate::range::inches_to_um(value) } else { Some(value) }
    }

    fn reply_out_of_range(&mut self, what: &str) {
        self.reply_error(ErrorCode::OutOfRange, format_args!(": {what}"));
    }

    fn execute(&mut self, w: &Words) -> Outcome {
        if self.program_paused {
            // `M0`/`M1`: wait for `~`.
            return Outcome::Blocked;
        }
        if let Some(out) = self.thermal_command(w) {
            return out;
        }
        // Validate axis words first.
        for axis in Axis::ALL {
            if w.has(axis.letter() as u8) && !self.cfg.axis(axis).enabled {
                self.reply_error(ErrorCode::AxisDisabled, format_args!(": {}", axis.letter()));
                return Outcome::Done;
            }
        }
        const KNOWN: &[u8] = b"XYZEFPSN";
        for bit in 0..26u8 {
            let letter = b'A' + bit;
            if w.letters() & (1 << bit) != 0 && !KNOWN.contains(&letter) {
                self.reply_error(ErrorCode::UnsupportedWord, format_args!(": {}", letter as char));
                return Outcome::Done;
            }
        }
        let mut motion = None;
        let mut other_g = None;
        for &g in &w.g {
            match g {
                0 | 1 => motion = Some(g),
                4 | 28 | 92 => other_g = Some(g),
                20 | 21 | 90 | 91 => {}
                _ => {
                    self.reply_error(ErrorCode::UnknownCommand, format_args!(": G{g}"));
                    return Outcome::Done;
                }
            }
        }
        for &m in &w.m {
            if !matches!(m, 0 | 1 | 2 | 3 | 4 | 5 | 17 | 18 | 30 | 82 | 83 | 84 | 110 | 114 | 115 | M_FRAMED) {
                self.reply_error(ErrorCode::UnknownCommand, format_args!(": M{m}"));
                return Outcome::Done;
            }
        }
        let has_axis = Axis::ALL.iter().any(|a| w.has(a.letter() as u8));
        if w.get(b'F').is_some_and(|f| f <= 0) {
            self.reply_error(ErrorCode::InvalidValue, format_args!(": F must be positive"));
            return Outcome::Done;
        }
        // Values that cannot be represented in the unit this line asks for, checked before any state changes.
        let inches = w.g.iter().rev().find_map(|g| match g {
            20 => Some(true),
            21 => Some(false),
            _ => None,
        });
        let inches = inches.unwrap_or(self.modal.inches);
        for letter in *b"XYZEF" {
            if inches && w.get(letter).is_some_and(|v| crate::range::inches_to_um(v).is_none()) {
                self.reply_out_of_range(core::str::from_utf8(&[letter]).unwrap_or("?"));
                return Outcome::Done;
            }
        }
        // Blocking conditions, checked before any state changes.
        let needs_slot = motion.is_some() || other_g == Some(4) || (has_axis && other_g.is_none());
        // The servo pen and program pauses act between moves, so they wait for the queue to empty.
        let pen_or_pause = w.m.iter().any(|m| matches!(m, 0 | 1 | 3 | 4 | 5));
        let needs_idle = matches!(other_g, Some(28 | 92)) || w.m.contains(&18) || w.m.contains(&84) || pen_or_pause;
        let servo_s = w.get(b'S').map(|s| s as f64 / 1e6);
        if w.m.iter().any(|m| matches!(m, 3 | 4)) && servo_s.is_none_or(|a| !(0.0..=180.0).contains(&a)) {
            self.reply_error(ErrorCode::InvalidValue, format_args!(": M3 needs S<angle> from 0 to 180"));
            return Outcome::Done;
        }
        if w.m.contains(&5) && servo_s.is_some_and(|a| !(0.0..=180.0).contains(&a)) {
            self.reply_error(ErrorCode::InvalidValue, format_args!(": S must be an angle from 0 to 180"));
            return Outcome::Done;
        }
        let moves = needs_slot || other_g == Some(28);
        if moves && self.alarm.is_some() && self.homing_result.is_none() {
            self.reply_error(ErrorCode::Alarm, format_args!(""));
            return Outcome::Done;
        }
        if other_g == Some(28) {
            return self.home(w);
        }
        if needs_idle && !self.quiescent() {
            return Outcome::Blocked;
        }
        if needs_slot && (self.planner.len() >= self.queue_limit || self.homing.is_some()) {
            return Outcome::Blocked;
        }
        // Modal words.
        for &g in &w.g {
            match g {
                20 => self.modal.inches = true,
                21 => self.modal.inches = false,
                90 => (self.modal.absolute, self.modal.e_relative) = (true, false),
                91 => (self.modal.absolute, self.modal.e_relative) = (false, true),
                _ => {}
            }
        }
        if let Some(f) = w.get(b'F') {
            // Checked above for the line's unit.
            let f_um_min = self.to_um(f).unwrap_or(i64::MAX);
            self.modal.feed_mm_s = f_um_min as f32 / 1e6 / 60.0;
        }
        if let Some(m) = motion {
            self.modal.motion = m;
        }
        match other_g {
            Some(4) => {
                let ms = w.get(b'P').map(|p| p / 1000).or_else(|| w.get(b'S').map(|s| s / 1000 * 1000)).unwrap_or(0);
                if !(0..=3_600_000_000).contains(&ms) {
                    self.reply_error(ErrorCode::InvalidValue, format_args!(": dwell"));
                    return Outcome::Done;
                }
                // ms is in thousandths of a millisecond = microseconds = ticks.
                let ticks = u32::try_from(ms).unwrap_or(u32::MAX);
                if ticks > 0 {
                    self.queue_block(PlanBlock::fixed(StepBlock::dwell(ticks)));
                }
            }
            Some(92) => {
                let mut offset = self.offset_um;
                for axis in Axis::ALL {
                    let i = axis.index();
                    // Checked above for the line's unit.
                    let given = w.get(axis.letter() as u8).map(|v| self.to_um(v).unwrap_or(0));
                    if let Some(v) = given.or(if has_axis { None } else { Some(0) }) {
                        let Some(o) = self.target_um[i].checked_sub(v) else {
                            self.reply_out_of_range("G92 offset");
                            return Outcome::Done;
                        };
                        offset[i] = o;
                    }
                }
                self.offset_um = offset;
            }
            _ => {
                if has_axis {
                    return self.linear_move(w);
                }
            }
        }
        for &m in &w.m {
            match m {
                2 | 30 => self.modal = Modal { feed_mm_s: self.modal.feed_mm_s, ..Modal::DEFAULT },
                0 | 1 => self.program_paused = true,
                // Angles are 0..=180 (checked above): exact enough in f32.
                #[allow(clippy::cast_possible_truncation)]
                3 | 4 => self.hal.set_servo(servo_s.unwrap_or(0.0) as f32),
                #[allow(clippy::cast_possible_truncation)]
                5 => {
                    if let Some(a) = servo_s {
                        self.servo_up_deg = a as f32;
                    }
                    self.hal.set_servo(self.servo_up_deg);
                }
                17 => self.hal.enable_motors(true),
                M_FRAMED => {
                    self.framed = w.get(b'S').is_some_and(|s| s != 0);
                    self.reporter.restart(self.stepper.completed());
                    self.refused = None;
                }
                18 | 84 => self.hal.enable_motors(false),
                82 => self.modal.e_relative = false,
                83 => self.modal.e_relative = true,
                114 => self.report_position(),
                115 => {
                    let (rx, q) = (self.rx_size(), self.queue_limit);
                    // Framed in framed mode: the host takes its buffer sizes from it.
                    self.reply(
                        self.answering,
                        format_args!(
                            "FIRMWARE_NAME:plotter-fw FIRMWARE_VERSION:{VERSION} PROTOCOL_VERSION:{PROTOCOL_VERSION} \
                             RX_BUFFER:{rx} QUEUE_BLOCKS:{q} LINE_MAX:{LINE_MAX} TICK_HZ:{TICK_HZ}"
                        ),
                    );
                }
                _ => {}
            }
        }
        self.reply_ok();
        Outcome::Done
    }

    fn linear_move(&mut self, w: &Words) -> Outcome {
        // Every step is checked (see `crate::range`): an unrepresentable target is refused, never wrapped or
        // saturated, so a move's direction is always the commanded one.
        let mut target_um = self.target_um;
        let mut target = self.target_steps;
        for axis in Axis::ALL {
            let i = axis.index();
            if let Some(v) = w.get(axis.letter() as u8) {
                let um = self.to_um(v).and_then(|v| {
                    let absolute = if axis == Axis::E { !self.modal.e_relative } else { self.modal.absolute };
                    if absolute { v.checked_add(self.offset_um[i]) } else { target_um[i].checked_add(v) }
                });
                let steps = um.and_then(|um| crate::range::um_to_steps(um, self.cfg.axis(axis).steps_per_mm));
                let (Some(um), Some(steps)) = (um, steps) else {
                    self.reply_error(
                        ErrorCode::OutOfRange,
                        format_args!(": {} {}", axis.letter(), crate::range::MoveRange::Position.text()),
                    );
                    return Outcome::Done;
                };
                target_um[i] = um;
                target[i] = steps;
            }
        }
        if let Some(axis) = crate::limits::violation(&self.cfg, self.homed, &target) {
            self.reply_error(ErrorCode::SoftLimit, format_args!(": {}", axis.letter()));
            return Outcome::Done;
        }
        let feed = if self.modal.motion == 0 {
            f32::INFINITY
        } else if self.modal.feed_mm_s > 0.0 {
            self.modal.feed_mm_s
        } else {
            self.reply_error(ErrorCode::InvalidValue, format_args!(": no feed rate (F) set for G1"));
            return Outcome::Done;
        };
        // Both targets lie within ±2^30 steps, so the difference fits.
        let steps: [i32; NUM_AXES] = core::array::from_fn(|i| target[i] - self.target_steps[i]);
        if steps[Axis::E.index()] != 0
            && let Some(cold) = self.thermal.cold_extrusion()
        {
            self.reply_error(ErrorCode::ColdExtrusion, format_args!("{cold}"));
            return Outcome::Done;
        }
        let block = PlanBlock::line(&self.cfg, steps, feed);
        if let Some(b) = &block {
            let rate = crate::fmath::floor_u32(b.nominal_speed * b.events_per_mm);
            if let Err(e) = crate::range::check_move(&steps, rate) {
                self.reply_out_of_range(e.text());
                return Outcome::Done;
            }
        }
        self.target_um = target_um;
        self.target_steps = target;
        if let Some(b) = block {
            self.queue_block(b);
        }
        self.reply_ok();
        Outcome::Done
    }

    fn home(&mut self, w: &Words) -> Outcome {
        if let Some(result) = self.homing_result.take() {
            match result {
                Ok(()) => self.reply_ok(),
                Err(code) => self.reply_error(ErrorCode::Alarm, format_args!(": {}", code.text())),
            }
            return Outcome::Done;
        }
        if self.homing.is_some() || !self.quiescent() {
            return Outcome::Blocked;
        }
        let mask = Axis::ALL.iter().filter(|a| w.has(a.letter() as u8)).fold(0, |m, a| m | a.bit());
        self.homing = Some(HomingCycle::new(&self.cfg, mask));
        self.linker.clear();
        self.run_homing();
        if self.homing_result.is_some() { self.home(w) } else { Outcome::Blocked }
    }

    fn report_position(&mut self) {
        let work: [f64; NUM_AXES] = core::array::from_fn(|i| (self.target_um[i] - self.offset_um[i]) as f64 / 1e6);
        let p = self.stepper.position();
        let _ = writeln!(
            Out(&mut self.hal),
            "X:{} Y:{} Z:{} E:{} Count X:{} Y:{} Z:{} E:{}",
            Decimal::new(work[0], 3),
            Decimal::new(work[1], 3),
            Decimal::new(work[2], 3),
            Decimal::new(work[3], 3),
            p[0],
            p[1],
            p[2],
            p[3]
        );
    }

    /// Exact commanded (queued) target in steps.
    pub fn target_steps(&self) -> [i32; NUM_AXES] {
        self.target_steps
    }

    /// Micrometre scale of the G-code parser, for callers converting positions.
    pub const MICRO: i64 = MICRO;
}

/// The status report's `|R:<n>,<code>` field (nothing when no block was refused).
struct Refused(Option<(u32, u8)>);

impl fmt::Display for Refused {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0 {
            Some((n, code)) => write!(f, "|R:{n},{code}"),
            None => Ok(()),
        }
    }
}

fn round_i64(x: f64) -> i64 {
    let r = if x >= 0.0 { x + 0.5 } else { x - 0.5 };
    #[allow(clippy::cast_possible_truncation, reason = "float→int `as` saturates; positions are far below 2^63")]
    let r = r as i64;
    r
}
