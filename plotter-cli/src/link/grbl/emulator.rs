//! A GRBL 1.1 controller emulated from GRBL's documented serial interface, so that the sender (and any other
//! GRBL tool) can be tested without a machine: `plotter sim --pty --grbl` serves it on a pseudo-terminal, and
//! [`super::emulator_transport::EmulatorTransport`] runs it in-process on virtual time.
//!
//! # What it emulates
//! - the start-up banner `Grbl 1.1h ['$' for help]` (after a soft reset too), and with homing enabled (`$22=1`)
//!   the power-up alarm lock `[MSG:'$H'|'$X' to unlock]`;
//! - the 128-byte serial receive buffer, counted the way a character-counting host counts it: the bytes of a
//!   line occupy the buffer until the line is answered. The ring holds 127 bytes (one slot always empty, as in
//!   GRBL's ring buffer); a byte that does not fit is lost and counted ([`EmulatorStats::overflow_bytes`]), and
//!   the peak fill is recorded;
//! - `ok` / `error:N` for every line, with GRBL 1.1's codes for what it checks (letter without number 1/2,
//!   unsupported command or word 20, repeated word 25, no feed rate 22, G-code during an alarm 9, `$` commands
//!   3/5/8);
//! - real-time `?` (status report `<State|MPos:…|FS:…>`, or `WPos:` with `$10=0`; `WCO:` every tenth report),
//!   `!` feed hold (`Hold:1` decelerating, `Hold:0` stopped; on an idle machine `Hold:0` at once, and lines sent
//!   meanwhile are queued but wait for `~`), `~` cycle start, Ctrl-X soft reset (during a cycle, a decelerating
//!   hold or homing it stops the steppers dead and raises `ALARM:3`, position lost; idle or at `Hold:0` the
//!   position is kept and no alarm raised). A reset never moves Z and leaves a servo pen where it was (GRBL
//!   switches the spindle output off, so the servo gets no new pulse): [`GrblEmulator::pen`] reports both, for
//!   tests to check that a plot ended with the pen up;
//! - alarms: hard limit (`ALARM:1`, also injectable for tests), soft limit (`ALARM:2`: a target outside the travel
//!   once homed, `$20=1`) — both critical, as in GRBL: `[MSG:Reset to continue]`, then nothing but real-time
//!   bytes is handled until a soft reset —, homing failures (`ALARM:8`/`ALARM:9`); G-code stays locked until `$X`
//!   or `$H`. Tests can also press the Hold or Reset button mid-plot ([`Faults::realtime_after_lines`]);
//! - `$$` (settings listing), `$n=value`, `$I` (build info, `[OPT:V,15,128]`), `$#` (offsets), `$G`
//!   (parser state), `$X`, `$H`, `$J=` jogging; `M0`/`M1` program pause (`Hold:0` until `~`), `M2`/`M30`,
//!   `M3 S`/`M5` (a servo pen), `G4 P<seconds>`, `G92`.
//!
//! # How motion runs
//! Accepted G-code drives this project's own firmware core ([`plotter_fw::sim::Sim`]) configured from the `$`
//! settings, with a 16-block planner like GRBL's: it supplies exact step positions, timing and the step trace.
//! The GRBL side (buffer, replies, codes, states, settings) is this file's own, written from GRBL's interface
//! documentation. Coordinates: machine 0 is the homed (pulled-off) switch position, positive into the work area
//! (real GRBL uses negative machine space; the sender never relies on either, it works in `G92` coordinates).
//! The lines meet the motion as in GRBL's main loop: moves that arrive while the machine stands still are planned
//! together and start once no complete line is left to parse or a line must wait, and `G4` and `M3`/`M5` wait
//! for the planner to empty (see the emulator's `process`).
//!
//! - `$SLP` sleep: motors off, state `Sleep`, every line left unanswered until a soft reset, which wakes it in
//!   alarm (it cannot know where it is) whatever `$22` says.
//!
//! Not emulated: arcs (G2/G3: `error:20`), the `Bf:` buffer field, probing, overrides, coolant, check mode (`$C`), startup lines (`$N`).
//! Dwells run as GRBL 1.1 runs them, in whole steps of 50 ms (`DWELL_TIME_STEP`: ⌈20·P⌉ steps, so `G4 P0.045`
//! takes 50 ms), P read as the nearest single-precision number (GRBL's own reading may differ in the last bit,
//! which matters only at exact multiples of 0.05 s; the sender writes none).
//! Settings changed with `$n=` are listed at once but drive the motion only after a soft reset.

use std::collections::VecDeque;

use plotter_fw::config::MachineConfig;
use plotter_fw::realtime::MachineState;
use plotter_fw::sim::{Sim, SimOptions};
use plotter_fw::{Axis, TICK_HZ};
use plotter_path::MachineProfile;

use super::messages::{RT_CYCLE_START, RT_FEED_HOLD, RT_RESET, RT_STATUS};
use super::settings::{GrblSettings, key};

/// GRBL's serial receive buffer, bytes.
pub const RX_BUFFER_SIZE: usize = 128;
/// Bytes the receive ring can hold (one slot stays empty).
pub const RX_USABLE: usize = RX_BUFFER_SIZE - 1;
/// Planner blocks (GRBL 1.1 on an ATmega328p has 16, reports 15 free).
pub const PLANNER_BLOCKS: u32 = 16;
/// The emulated version.
pub const VERSION: &str = "1.1h";
/// Longest line accepted (GRBL's line buffer on an ATmega328p).
pub const LINE_MAX: usize = 80;

/// Faults to inject, for tests.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Faults {
    /// Trip a hard limit (`ALARM:1`) once this many G-code lines have been answered `ok`.
    pub hard_limit_after_lines: Option<u64>,
    /// Answer the G-code line with this number (1-based, counting G-code lines received) with this error code
    /// instead of executing it.
    pub error_on_line: Option<(u64, u8)>,
    /// Once this many G-code lines have been answered `ok`, act on this real-time byte as if it had arrived on
    /// the serial line or from the controller's own buttons: `!` (the Hold button), `~` (Cycle Start) or `0x18`
    /// (Reset / Abort). Pressed while the machine runs: when the moves answered wait for the cycle to start, once
    /// it has.
    pub realtime_after_lines: Option<(u64, u8)>,
}

/// Figures about a session.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct EmulatorStats {
    /// Most bytes ever held in the receive buffer.
    pub peak_rx: usize,
    /// Bytes lost because the receive buffer was full.
    pub overflow_bytes: u64,
    /// Lines answered (`ok` or `error`).
    pub lines: u64,
    /// `error:` answers.
    pub errors: u64,
    /// Status reports sent.
    pub reports: u64,
}

/// The pen as the machine physically holds it, for tests to tell whether a plot ended with the pen up.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PenState {
    /// Where the Z axis stands, steps (machine coordinates: the homed position is 0).
    pub z_steps: i64,
    /// The servo's angle, degrees, as its last pulse set it (`None` before the first servo command).
    pub servo_deg: Option<f32>,
}

/// What the line being executed waits for.
#[derive(Debug, Clone, PartialEq)]
enum Waiting {
    /// Backend lines still to send, then each one's `ok`; `flow` says when they may go.
    Backend { lines: VecDeque<String>, sent: bool, flow: Flow },
    /// The homing cycle (`$H`).
    Homing { sent: bool },
    /// `M0`/`M1`: the planner to empty, then the pause.
    Pause,
    /// `M2`/`M30`: the planner to empty.
    End,
    /// `G92`: the backend's answer, then the offset is recorded.
    Offset { line: String, given: [Option<f64>; 3], sent: bool },
}

/// How a G-code line meets the motion before it ([`GrblEmulator::process`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Flow {
    /// A move: planned at once, it waits for the cycle to start when the machine stands still.
    Queues,
    /// A dwell or a spindle (servo) word: GRBL runs it only once the planner has emptied (its
    /// `protocol_buffer_synchronize`, in `mc_dwell` and `spindle_sync`), whatever the dwell's length.
    Syncs,
    /// Anything else (modal words, a jog, which starts at once).
    Runs,
}

#[derive(Debug, Clone, PartialEq)]
struct Current {
    /// Bytes (line end included) it holds in the receive buffer.
    len: usize,
    waiting: Waiting,
}

/// The emulated controller.
pub struct GrblEmulator {
    backend: Sim,
    base: MachineConfig,
    settings: GrblSettings,
    faults: Faults,
    /// Bytes on the wire not yet received (delivered at the baud rate).
    wire: VecDeque<u8>,
    byte_ticks: Option<u64>,
    next_byte_at: u64,
    /// The emulator's clock, ticks.
    now: u64,
    /// How far the backend's clock is behind (it stands still while the backend has nothing to do).
    lag: u64,
    /// Receive buffer: bytes received and not yet answered.
    rx: VecDeque<u8>,
    current: Option<Current>,
    out: Vec<String>,
    alarm: Option<u8>,
    /// An alarm that needs a reset before `$X` (hard limit).
    needs_reset: bool,
    /// Asleep after `$SLP`: only a soft reset wakes it.
    sleeping: bool,
    /// Motion lines wait in the backend's planner (held there) for GRBL's cycle start: see
    /// [`GrblEmulator::process`].
    queued: bool,
    /// The last line sent to the backend waited for the planner to empty ([`Flow::Syncs`]).
    synced: bool,
    homed: bool,
    paused: bool,
    status_wanted: bool,
    feed_set: bool,
    g92: [f64; 3],
    gcode_lines: u64,
    ok_gcode_lines: u64,
    stats: EmulatorStats,
}

/// The firmware-core configuration the `$` settings describe, on top of `base` (pen heights, extruder).
fn backend_config(base: &MachineConfig, s: &GrblSettings) -> MachineConfig {
    let mut cfg = *base;
    // Settings are physical quantities far inside f32's range.
    #[allow(clippy::cast_possible_truncation)]
    let f = |k: u16, d: f32| s.get(k).map_or(d, |v| v as f32);
    for (i, axis) in [Axis::X, Axis::Y, Axis::Z].into_iter().enumerate() {
        let i = u16::try_from(i).unwrap_or(0);
        let a = &mut cfg.axes[axis.index()];
        a.steps_per_mm = f(key::STEPS_PER_MM + i, a.steps_per_mm);
        a.max_feed_mm_s = f(key::MAX_RATE + i, a.max_feed_mm_s * 60.0) / 60.0;
        a.max_accel_mm_s2 = f(key::ACCEL + i, a.max_accel_mm_s2);
        a.travel_mm = f(key::MAX_TRAVEL + i, a.travel_mm);
    }
    cfg.junction_deviation_mm = f(key::JUNCTION_DEVIATION, cfg.junction_deviation_mm);
    cfg.homing.seek_mm_s = f(key::HOMING_SEEK, cfg.homing.seek_mm_s * 60.0) / 60.0;
    cfg.homing.locate_mm_s = f(key::HOMING_FEED, cfg.homing.locate_mm_s * 60.0) / 60.0;
    cfg.homing.pull_off_mm = f(key::HOMING_PULL_OFF, cfg.homing.pull_off_mm);
    cfg.homing.debounce_ms = f(key::HOMING_DEBOUNCE, cfg.homing.debounce_ms);
    cfg.soft_limits = s.get(key::SOFT_LIMITS).is_some_and(|v| v != 0.0);
    cfg.hard_limits = s.get(key::HARD_LIMITS).is_some_and(|v| v != 0.0);
    cfg.queue_blocks = PLANNER_BLOCKS;
    cfg.rx_buffer_bytes = 1024;
    cfg
}

/// One G-code word.
struct Word {
    letter: u8,
    value: f64,
}

/// Split a line into words the way GRBL's parser does (spaces ignored, upper-cased, comments removed); `Err`
/// carries the GRBL error code.
fn words(line: &str) -> Result<Vec<Word>, u8> {
    let mut clean = String::new();
    let mut paren = false;
    for c in line.chars() {
        match c {
            '(' => paren = true,
            ')' => paren = false,
            ';' if !paren => break,
            c if paren || c.is_whitespace() => {}
            c => clean.push(c.to_ascii_uppercase()),
        }
    }
    let b = clean.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let letter = b[i];
        if !letter.is_ascii_uppercase() {
            return Err(1);
        }
        i += 1;
        let start = i;
        while i < b.len() && (b[i].is_ascii_digit() || b[i] == b'.' || b[i] == b'-' || b[i] == b'+') {
            i += 1;
        }
        let value: f64 = clean[start..i].parse().map_err(|_| 2u8)?;
        if !value.is_finite() {
            return Err(2);
        }
        out.push(Word { letter, value });
    }
    Ok(out)
}

fn fmt3(v: [f64; 3]) -> String {
    format!("{:.3},{:.3},{:.3}", v[0], v[1], v[2])
}

impl GrblEmulator {
    /// A controller set up for `profile` (its `$` settings say what the profile says; homing enabled), with
    /// `baud` = `None` delivering bytes at once.
    pub fn new(profile: &MachineProfile, baud: Option<u32>) -> anyhow::Result<Self> {
        let base = plotter_path::motion::plan::machine_config(profile)?;
        Ok(Self::with_settings(base, GrblSettings::for_profile(profile), baud, Faults::default()))
    }

    /// A controller on `base` (pen heights and the extruder come from it) with these settings and faults.
    pub fn with_settings(base: MachineConfig, settings: GrblSettings, baud: Option<u32>, faults: Faults) -> Self {
        let cfg = backend_config(&base, &settings);
        let mut backend = Sim::with_options(cfg, SimOptions::for_config(&cfg));
        let _ = backend.take_replies();
        let mut e = GrblEmulator {
            backend,
            base,
            settings,
            faults,
            wire: VecDeque::new(),
            byte_ticks: baud.map(|b| (u64::from(TICK_HZ) * 10).div_ceil(u64::from(b.max(1)))),
            next_byte_at: 0,
            now: 0,
            lag: 0,
            rx: VecDeque::new(),
            current: None,
            out: Vec::new(),
            alarm: None,
            needs_reset: false,
            sleeping: false,
            queued: false,
            synced: false,
            homed: false,
            paused: false,
            status_wanted: false,
            feed_set: false,
            g92: [0.0; 3],
            gcode_lines: 0,
            ok_gcode_lines: 0,
            stats: EmulatorStats::default(),
        };
        e.start_up(true);
        e
    }

    /// Set faults to inject from now on.
    pub fn set_faults(&mut self, faults: Faults) {
        self.faults = faults;
    }

    /// The motion backend (step trace, executed time).
    pub fn backend(&self) -> &Sim {
        &self.backend
    }

    /// The settings.
    pub fn settings(&self) -> &GrblSettings {
        &self.settings
    }

    /// Session figures.
    pub fn stats(&self) -> EmulatorStats {
        self.stats
    }

    /// The pen: the Z axis's physical position and the servo's angle.
    pub fn pen(&self) -> PenState {
        PenState {
            z_steps: self.backend.physical_position()[Axis::Z.index()],
            servo_deg: self.backend.hal().servo_trace().last().map(|s| s.1),
        }
    }

    /// Virtual time, ticks.
    pub fn now(&self) -> u64 {
        self.now
    }

    fn backend_idle(&self) -> bool {
        self.backend.wire_len() == 0 && self.backend.machine().is_idle()
    }

    /// Whether nothing is left to do: wire and buffer empty, backend idle.
    pub fn is_idle(&self) -> bool {
        self.wire.is_empty() && self.rx.is_empty() && self.current.is_none() && self.backend.machine().is_idle()
    }

    /// Whether motion is stopped (planner empty, stepper idle), whatever else waits.
    pub fn motion_idle(&self) -> bool {
        self.backend_motion_idle()
    }

    fn backend_motion_idle(&self) -> bool {
        self.backend.machine().stepper().is_idle() && self.backend.machine().state() == MachineState::Idle
    }

    fn start_up(&mut self, power_on: bool) {
        self.out.push(format!("Grbl {VERSION} ['$' for help]"));
        if power_on && self.settings.homing_enabled() && self.alarm.is_none() {
            // GRBL locks a machine with homing enabled until it is homed (or unlocked).
            self.alarm = Some(0);
        }
        if self.alarm.is_some() {
            self.out.push("[MSG:'$H'|'$X' to unlock]".into());
        }
    }

    /// Bytes arriving from the host (on the wire first when a baud rate is set).
    pub fn feed(&mut self, bytes: &[u8]) {
        if self.byte_ticks.is_some() {
            if self.wire.is_empty() {
                self.next_byte_at = self.next_byte_at.max(self.now);
            }
            self.wire.extend(bytes);
        } else {
            for &b in bytes {
                self.receive(b);
            }
        }
    }

    /// Bytes still on the wire.
    pub fn wire_len(&self) -> usize {
        self.wire.len()
    }

    /// Reply lines produced since the last call.
    pub fn take_replies(&mut self) -> Vec<String> {
        std::mem::take(&mut self.out)
    }

    /// The serial receive interrupt: real-time bytes act at once, the rest goes into the buffer.
    fn receive(&mut self, b: u8) {
        match b {
            RT_STATUS => self.status_wanted = true,
            RT_FEED_HOLD => {
                // A hold while moves wait for the cycle to start holds them (`Hold:0`) until `~`.
                self.queued = false;
                self.backend.feed(&[plotter_fw::protocol::RT_FEED_HOLD]);
            }
            RT_CYCLE_START => {
                self.queued = false;
                if self.paused {
                    self.paused = false;
                } else {
                    self.backend.feed(&[plotter_fw::protocol::RT_RESUME]);
                }
            }
            RT_RESET => self.soft_reset(),
            _ => {
                if self.rx.len() >= RX_USABLE {
                    self.stats.overflow_bytes += 1;
                } else {
                    self.rx.push_back(b);
                    self.stats.peak_rx = self.stats.peak_rx.max(self.rx.len());
                }
            }
        }
    }

    fn soft_reset(&mut self) {
        // As GRBL's `mc_reset`: a reset during a cycle, a hold still decelerating (`Hold:1`) or homing stops the
        // steppers dead and raises `ALARM:3`; at rest — idle, or a hold that has come to a stop (`Hold:0`) — the
        // position is kept and no alarm is raised. Z does not move either way; the spindle output is switched off
        // (GRBL's `spindle_stop`), which leaves a servo pen where its last pulse put it.
        let homing = matches!(self.current, Some(Current { waiting: Waiting::Homing { .. }, .. }));
        let moving = homing
            || matches!(
                self.backend.machine().state(),
                MachineState::Run | MachineState::Holding | MachineState::Homing
            );
        if moving {
            self.out.push("ALARM:3".into());
            self.alarm = Some(3);
            self.homed = false;
        }
        // Settings changed with `$n=` take effect now; the carriage stays where it physically is.
        let cfg = backend_config(&self.base, &self.settings);
        if cfg != *self.backend.machine().config() {
            let mut opts = SimOptions::for_config(&cfg);
            opts.start = self.backend.physical_position();
            self.backend = Sim::with_options(cfg, opts);
            self.homed = false;
        } else {
            self.backend.feed(&[plotter_fw::protocol::RT_RESET]);
            self.backend.run_for(1);
        }
        let _ = self.backend.take_replies();
        self.rx.clear();
        self.current = None;
        self.paused = false;
        self.queued = false;
        self.synced = false;
        self.feed_set = false;
        self.g92 = [0.0; 3];
        if self.needs_reset {
            self.needs_reset = false;
        }
        if std::mem::take(&mut self.sleeping) {
            // The motors were off: the position is lost.
            self.homed = false;
            self.alarm = Some(0);
        }
        self.start_up(false);
    }

    /// Advance virtual time by `ticks`, in slices of one byte time (or 100 µs) so that replies leave at their
    /// time.
    pub fn run_for(&mut self, ticks: u64) {
        let end = self.now.saturating_add(ticks);
        loop {
            self.deliver();
            self.process();
            if self.now >= end {
                break;
            }
            let mut step = (end - self.now).min(self.byte_ticks.unwrap_or(100));
            if self.byte_ticks.is_some() && !self.wire.is_empty() {
                step = step.min(self.next_byte_at.saturating_sub(self.now).max(1));
            }
            self.now += step;
            let target = self.now - self.lag;
            if target > self.backend.now() {
                self.backend.run_for(target - self.backend.now());
            }
            if self.backend_idle() {
                self.lag = self.now - self.backend.now().min(self.now);
            }
            self.collect_backend();
        }
    }

    fn deliver(&mut self) {
        match self.byte_ticks {
            None => {
                while let Some(b) = self.wire.pop_front() {
                    self.receive(b);
                }
            }
            Some(bt) => {
                while self.next_byte_at <= self.now {
                    let Some(b) = self.wire.pop_front() else { break };
                    self.receive(b);
                    self.next_byte_at += bt;
                }
            }
        }
    }

    /// The time the next wire byte arrives, if any is waiting.
    pub fn next_byte_at(&self) -> Option<u64> {
        (!self.wire.is_empty()).then_some(self.next_byte_at)
    }

    fn mpos(&self) -> [f64; 3] {
        let p = self.backend.machine().stepper().position();
        let cfg = self.backend.machine().config();
        core::array::from_fn(|i| f64::from(p[i]) / f64::from(cfg.axes[i].steps_per_mm))
    }

    fn state_name(&self) -> &'static str {
        if self.sleeping {
            return "Sleep";
        }
        if self.alarm.is_some() {
            return "Alarm";
        }
        if self.paused {
            return "Hold:0";
        }
        if self.queued {
            // GRBL is idle while its planned moves wait for the cycle to start.
            return "Idle";
        }
        match self.backend.machine().state() {
            MachineState::Homing => "Home",
            MachineState::Held => "Hold:0",
            MachineState::Holding => "Hold:1",
            MachineState::Run => "Run",
            MachineState::Alarm => "Alarm",
            MachineState::Idle => {
                if matches!(self.current, Some(Current { waiting: Waiting::Homing { .. }, .. })) {
                    "Home"
                } else {
                    "Idle"
                }
            }
        }
    }

    fn status_report(&mut self) {
        self.stats.reports += 1;
        let mask = self.settings.get(10).unwrap_or(1.0);
        // $10 is a small bit mask.
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let mask = mask as u32;
        let m = self.mpos();
        let mut s = format!("<{}|", self.state_name());
        if mask & 1 != 0 {
            s += &format!("MPos:{}", fmt3(m));
        } else {
            s += &format!("WPos:{}", fmt3(core::array::from_fn(|i| m[i] - self.g92[i])));
        }
        s += "|FS:0,0";
        if self.stats.reports % 10 == 1 {
            s += &format!("|WCO:{}", fmt3(self.g92));
        }
        s.push('>');
        self.out.push(s);
    }

    /// Answer the current line and free its bytes.
    fn answer(&mut self, reply: String) {
        if let Some(c) = self.current.take() {
            for _ in 0..c.len {
                self.rx.pop_front();
            }
        }
        if reply.starts_with("error:") {
            self.stats.errors += 1;
        }
        self.stats.lines += 1;
        self.out.push(reply);
    }

    fn raise_alarm(&mut self, code: u8, lost: bool) {
        self.out.push(format!("ALARM:{code}"));
        self.alarm = Some(code);
        if lost {
            self.homed = false;
        }
        // Everything queued is discarded; the rest of the buffer is dropped unanswered, as GRBL's reset does.
        self.backend.feed(&[plotter_fw::protocol::RT_RESET]);
        self.backend.run_for(1);
        let _ = self.backend.take_replies();
        self.current = None;
        self.rx.clear();
    }

    /// A hard or soft limit: GRBL says `[MSG:Reset to continue]` and then handles nothing but real-time bytes
    /// until a soft reset; the lines that arrive meanwhile wait in the receive buffer, unanswered, and the reset
    /// drops them.
    fn critical_event(&mut self) {
        self.needs_reset = true;
        self.out.push("[MSG:Reset to continue]".into());
    }

    fn collect_backend(&mut self) {
        for l in self.backend.take_replies() {
            if let Some(rest) = l.strip_prefix("ALARM:") {
                // The core's alarms: 1 hard limit, 2 homing switch not found, 3 switch not released.
                let code = match rest.split_whitespace().next() {
                    Some("2") => 9,
                    Some("3") => 8,
                    _ => 1,
                };
                self.raise_alarm(code, true);
                if code == 1 {
                    self.critical_event();
                }
                continue;
            }
            let is_ok = l == "ok";
            let err = l
                .strip_prefix("error:")
                .map(|r| r.split_whitespace().next().and_then(|c| c.parse::<u8>().ok()).unwrap_or(20));
            if !is_ok && err.is_none() {
                continue;
            }
            let Some(cur) = self.current.as_mut() else { continue };
            match &mut cur.waiting {
                Waiting::Backend { lines, sent, .. } => {
                    *sent = false;
                    let more = !lines.is_empty();
                    match err {
                        // Soft limits (the core's error 7) are an alarm on GRBL, and a critical one.
                        Some(7) => {
                            self.raise_alarm(2, false);
                            self.critical_event();
                        }
                        Some(code) => {
                            let grbl = match code {
                                1 | 2 => code,
                                5 => 11,
                                8 => 9,
                                9 => 33,
                                _ => 20,
                            };
                            self.answer(format!("error:{grbl}"));
                        }
                        None if more => {}
                        None => {
                            self.ok_gcode_lines += 1;
                            self.answer("ok".into());
                            if self.faults.hard_limit_after_lines.is_some_and(|n| self.ok_gcode_lines >= n) {
                                self.faults.hard_limit_after_lines = None;
                                self.raise_alarm(1, true);
                                self.critical_event();
                            }
                            self.press_due_button();
                        }
                    }
                }
                Waiting::Homing { .. } => {
                    if is_ok {
                        self.homed = true;
                        self.alarm = None;
                        self.answer("ok".into());
                    }
                }
                Waiting::Offset { given, .. } => {
                    let given = *given;
                    if is_ok {
                        let m = self.mpos();
                        for (i, g) in given.iter().enumerate() {
                            if let Some(v) = g {
                                self.g92[i] = m[i] - v;
                            }
                        }
                        self.answer("ok".into());
                    } else {
                        self.answer("error:20".into());
                    }
                }
                Waiting::Pause | Waiting::End => {}
            }
        }
    }

    /// The button press of [`Faults::realtime_after_lines`], once its lines have been answered and no move
    /// waits for the cycle to start (the press comes while the machine runs them).
    fn press_due_button(&mut self) {
        if let Some((n, byte)) = self.faults.realtime_after_lines
            && self.ok_gcode_lines >= n
            && !self.queued
        {
            self.faults.realtime_after_lines = None;
            self.receive(byte);
        }
    }

    /// Run the line handling: answer status requests, start the next lines, push backend lines; then start the
    /// cycle.
    ///
    /// As GRBL's main loop (`protocol_main_loop`, `protocol_auto_cycle_start`): a motion line that arrives while
    /// the machine stands still is planned but does not start it; the lines after it are parsed and planned
    /// too, and the cycle starts once no complete line is left to parse, or a line must wait (for the planner
    /// to empty: `M3`, `G4`, `M0`, `M2`; for room in the planner). So the moves after a stop are planned
    /// together: a corner between two of them is taken at its junction speed, not from rest. The backend's
    /// planner hands a block to its stepper (frozen) as soon as the stepper runs short, so the waiting moves are
    /// held there (a feed hold on a stepper at rest) until the cycle starts. Only after a line that waited for
    /// the planner to empty (`M3`, `G4`): there a sender has filled the receive buffer with the lines after it
    /// while it waited, whatever the pace of the link. Elsewhere (a plot's first move) what is received when
    /// hangs on the host's timing, and GRBL re-plans the block it runs as more arrive, which the backend cannot:
    /// the moves start at once, the first ones planned alone, whatever the timing.
    fn process(&mut self) {
        loop {
            self.process_lines();
            if !self.queued {
                return;
            }
            self.queued = false;
            self.backend.feed(&[plotter_fw::protocol::RT_RESUME]);
            self.backend.run_for(0);
            self.press_due_button();
        }
    }

    fn process_lines(&mut self) {
        loop {
            self.collect_backend();
            if self.status_wanted {
                self.status_wanted = false;
                self.status_report();
            }
            let motion_idle = self.backend_motion_idle();
            if let Some(cur) = self.current.as_mut() {
                match &mut cur.waiting {
                    Waiting::Backend { flow: Flow::Syncs, sent: false, .. } if !motion_idle => {}
                    Waiting::Backend { lines, sent, flow } if !*sent && !lines.is_empty() => {
                        if *flow == Flow::Queues && !self.queued && motion_idle && self.synced {
                            // Nothing moves: the move waits for the cycle to start.
                            self.queued = true;
                            self.backend.feed(&[plotter_fw::protocol::RT_FEED_HOLD]);
                        }
                        self.synced = *flow == Flow::Syncs;
                        if let Some(l) = lines.pop_front() {
                            self.backend.feed(format!("{l}\n").as_bytes());
                        }
                        *sent = true;
                        self.backend.run_for(0);
                        continue;
                    }
                    Waiting::Homing { sent } | Waiting::Offset { sent, .. } if !*sent => {
                        *sent = true;
                        let line = match &cur.waiting {
                            Waiting::Offset { line, .. } => line.clone(),
                            _ => "G28".to_string(),
                        };
                        self.backend.feed(format!("{line}\n").as_bytes());
                        self.backend.run_for(0);
                        continue;
                    }
                    Waiting::Pause if motion_idle => {
                        self.paused = true;
                        self.answer("ok".into());
                        continue;
                    }
                    Waiting::End if motion_idle => {
                        self.feed_set = false;
                        self.answer("ok".into());
                        self.out.push("[MSG:Pgm End]".into());
                        continue;
                    }
                    _ => {}
                }
                return;
            }
            if self.paused || self.needs_reset || self.sleeping {
                return;
            }
            let Some(end) = self.rx.iter().position(|&b| b == b'\n' || b == b'\r') else {
                if self.rx.len() >= RX_USABLE {
                    // A line longer than the buffer can never end: GRBL would report a line overflow.
                    self.rx.clear();
                    self.stats.lines += 1;
                    self.stats.errors += 1;
                    self.out.push("error:11".into());
                }
                return;
            };
            let bytes: Vec<u8> = self.rx.iter().take(end).copied().collect();
            let line = String::from_utf8_lossy(&bytes).trim().to_string();
            self.current = Some(Current { len: end + 1, waiting: Waiting::Pause });
            self.start_line(&line, end);
        }
    }

    fn start_line(&mut self, line: &str, len: usize) {
        let set = |this: &mut Self, w: Waiting| {
            if let Some(c) = this.current.as_mut() {
                c.waiting = w;
            }
        };
        if line.is_empty() {
            return self.answer("ok".into());
        }
        if len > LINE_MAX {
            return self.answer("error:11".into());
        }
        if let Some(cmd) = line.strip_prefix('$') {
            return self.system_command(cmd.trim());
        }
        self.gcode_lines += 1;
        if let Some((n, code)) = self.faults.error_on_line
            && n == self.gcode_lines
        {
            return self.answer(format!("error:{code}"));
        }
        if self.alarm.is_some() {
            return self.answer("error:9".into());
        }
        match self.translate(line) {
            Ok(w) => set(self, w),
            Err(code) => self.answer(format!("error:{code}")),
        }
    }

    /// Check a G-code line as GRBL's parser would and turn it into what the backend runs.
    fn translate(&mut self, line: &str) -> Result<Waiting, u8> {
        let ws = words(line)?;
        let mut seen = 0u32;
        let mut out = String::new();
        let mut motion = None;
        let (mut g92, mut pause, mut end) = (false, false, false);
        let mut given = [None; 3];
        let mut has_f = false;
        let mut dwell = false;
        for w in &ws {
            let bit = 1u32 << (w.letter - b'A');
            let repeatable = matches!(w.letter, b'G' | b'M');
            if !repeatable && seen & bit != 0 {
                return Err(25);
            }
            seen |= bit;
            match w.letter {
                b'G' => {
                    let g = (w.value * 10.0).round();
                    match g {
                        0.0 | 10.0 => motion = Some(g),
                        40.0 => dwell = true,
                        920.0 => g92 = true,
                        170.0 | 200.0 | 210.0 | 540.0 | 900.0 | 910.0 | 940.0 => {}
                        _ if w.value.fract() != 0.0 && g != 921.0 => return Err(23),
                        _ => return Err(20),
                    }
                    if g != 170.0 && g != 540.0 && g != 940.0 {
                        out += &format!("G{} ", w.value);
                    }
                }
                b'M' => match (w.value * 10.0).round() {
                    0.0 | 10.0 => pause = true,
                    20.0 | 300.0 => end = true,
                    30.0 | 40.0 => out += "M3 ",
                    50.0 => out += "M5 ",
                    80.0 | 90.0 => {}
                    _ => return Err(20),
                },
                b'X' | b'Y' | b'Z' => {
                    given[usize::from(w.letter - b'X')] = Some(w.value);
                    out += &format!("{}{} ", char::from(w.letter), w.value);
                }
                b'F' => {
                    if w.value <= 0.0 {
                        return Err(4);
                    }
                    has_f = true;
                    out += &format!("F{} ", w.value);
                }
                b'S' => {
                    if w.value < 0.0 {
                        return Err(4);
                    }
                    out += &format!("S{} ", w.value);
                }
                b'P' => {
                    if w.value < 0.0 {
                        return Err(4);
                    }
                    // GRBL's dwell is in seconds, the core's in milliseconds; GRBL dwells in whole steps of 50 ms,
                    // ⌈20·P⌉ of them, in single precision (`delay_sec`).
                    #[allow(clippy::cast_possible_truncation, reason = "a dwell's seconds, far inside f32")]
                    let steps = (20.0 * w.value as f32).ceil();
                    out += &format!("P{} ", f64::from(steps) * 50.0);
                }
                b'N' | b'T' => {}
                _ => return Err(20),
            }
        }
        if pause {
            return Ok(Waiting::Pause);
        }
        if end {
            return Ok(Waiting::End);
        }
        if dwell && seen & (1 << (b'P' - b'A')) == 0 {
            return Err(28);
        }
        let axes = given.iter().any(Option::is_some);
        if motion == Some(10.0) || (motion.is_none() && axes && !g92) {
            // A G1 (or a modal G1 continuation) needs a feed rate.
            if !has_f && !self.feed_set && motion == Some(10.0) {
                return Err(22);
            }
        }
        if has_f {
            self.feed_set = true;
        }
        if g92 {
            if !axes {
                return Err(26);
            }
            return Ok(Waiting::Offset { line: out.trim().to_string(), given, sent: false });
        }
        let flow = if dwell || seen & (1 << (b'M' - b'A')) != 0 {
            Flow::Syncs
        } else if motion.is_some() || axes {
            Flow::Queues
        } else {
            Flow::Runs
        };
        Ok(Waiting::Backend { lines: VecDeque::from([out.trim().to_string()]), sent: false, flow })
    }

    fn system_command(&mut self, cmd: &str) {
        let idle = self.motion_idle();
        match cmd {
            "" => {
                self.out.push("[HLP:$$ $# $G $I $N $x=val $Nx=line $J=line $SLP $C $X $H ~ ! ? ctrl-x]".into());
                self.answer("ok".into());
            }
            "$" => {
                let listing = self.settings.listing();
                self.out.extend(listing);
                self.answer("ok".into());
            }
            "I" => {
                self.out.push(format!("[VER:{VERSION}.20190830:plotter emulator]"));
                self.out.push(format!("[OPT:V,{},{RX_BUFFER_SIZE}]", PLANNER_BLOCKS - 1));
                self.answer("ok".into());
            }
            "#" => {
                let zero = fmt3([0.0; 3]);
                for g in ["G54", "G55", "G56", "G57", "G58", "G59", "G28", "G30"] {
                    self.out.push(format!("[{g}:{zero}]"));
                }
                self.out.push(format!("[G92:{}]", fmt3(self.g92)));
                self.out.push("[TLO:0.000]".into());
                self.out.push(format!("[PRB:{zero}:0]"));
                self.answer("ok".into());
            }
            "G" => {
                self.out.push("[GC:G0 G54 G17 G21 G90 G94 M5 M9 T0 F0 S0]".into());
                self.answer("ok".into());
            }
            "SLP" => {
                if !idle {
                    return self.answer("error:8".into());
                }
                self.answer("ok".into());
                self.out.push("[MSG:Sleeping]".into());
                self.sleeping = true;
            }
            "X" => {
                if self.needs_reset {
                    return self.answer("error:9".into());
                }
                if self.alarm.take().is_some() {
                    self.out.push("[MSG:Caution: Unlocked]".into());
                }
                self.answer("ok".into());
            }
            "H" => {
                if !self.settings.homing_enabled() {
                    return self.answer("error:5".into());
                }
                if self.needs_reset {
                    return self.answer("error:9".into());
                }
                if !idle {
                    return self.answer("error:8".into());
                }
                self.g92 = [0.0; 3];
                if let Some(c) = self.current.as_mut() {
                    c.waiting = Waiting::Homing { sent: false };
                }
            }
            _ => {
                if let Some(jog) = cmd.strip_prefix("J=") {
                    if self.alarm.is_some() {
                        return self.answer("error:9".into());
                    }
                    return self.jog(jog);
                }
                if let Some((k, v)) = cmd.split_once('=')
                    && let (Ok(k), Ok(v)) = (k.trim().parse::<u16>(), v.trim().parse::<f64>())
                {
                    if !idle {
                        return self.answer("error:8".into());
                    }
                    if !v.is_finite() || v < 0.0 {
                        return self.answer("error:4".into());
                    }
                    if !self.settings.values.contains_key(&k) {
                        return self.answer("error:3".into());
                    }
                    self.settings.values.insert(k, v);
                    return self.answer("ok".into());
                }
                self.answer("error:3".into());
            }
        }
    }

    /// `$J=`: a jog, relative (`G91`) or absolute, with its own feed; the parser state is left as it was.
    fn jog(&mut self, body: &str) {
        let Ok(ws) = words(body) else { return self.answer("error:16".into()) };
        let mut relative = false;
        let mut axes = String::new();
        let mut feed = None;
        for w in &ws {
            match w.letter {
                b'G' if w.value == 91.0 => relative = true,
                b'G' if w.value == 90.0 || w.value == 21.0 => {}
                b'X' | b'Y' | b'Z' => axes += &format!("{}{} ", char::from(w.letter), w.value),
                b'F' if w.value > 0.0 => feed = Some(w.value),
                _ => return self.answer("error:16".into()),
            }
        }
        let Some(f) = feed else { return self.answer("error:16".into()) };
        if axes.is_empty() {
            return self.answer("error:16".into());
        }
        let mode = if relative { "G91" } else { "G90" };
        let lines = VecDeque::from([format!("{mode} G1 {axes}F{f}"), "G90".to_string()]);
        if let Some(c) = self.current.as_mut() {
            // A jog starts at once (GRBL's `jog_execute`).
            c.waiting = Waiting::Backend { lines, sent: false, flow: Flow::Runs };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn emu() -> GrblEmulator {
        GrblEmulator::new(&MachineProfile::default_plotter(), None).unwrap()
    }

    /// Send `line`, run until idle, return the replies.
    fn say(e: &mut GrblEmulator, line: &str) -> Vec<String> {
        e.feed(format!("{line}\n").as_bytes());
        for _ in 0..10_000 {
            e.run_for(10_000);
            if e.is_idle() {
                break;
            }
        }
        e.take_replies()
    }

    /// The motion time of `lines` sent at once to an unlocked controller standing still, ticks.
    fn motion_ticks(lines: &str) -> u64 {
        let mut e = emu();
        assert_eq!(say(&mut e, "$X").last().map(String::as_str), Some("ok"));
        let before = e.backend().hal().busy_ticks();
        let replies = say(&mut e, lines);
        assert!(replies.iter().all(|r| r == "ok"), "{replies:?}");
        e.backend().hal().busy_ticks() - before
    }

    #[test]
    fn moves_sent_together_are_planned_together_and_a_dwell_stops_them() {
        // Two 10 mm moves at 60 mm/s (F3600) with a 90° corner, on the kit (1500 mm/s², $11 = 0.02 mm), after a
        // dwell (a sync, as a servo's drop is). GRBL starts the cycle only once no complete line is left to
        // parse, so the second move is planned before the first starts and the corner is taken at its junction
        // speed: v² = a·δ·s/(1 − s), s = sin 45° → v = 8.510 mm/s.
        // Each move: 0 → 60 mm/s in 40 ms (1.2 mm), 60 → 8.51 mm/s in 34.33 ms (1.176 mm), 7.624 mm at 60 mm/s in
        // 127.07 ms: 201.40 ms, 402.79 ms both; from rest to rest at the corner 2 × 206.67 = 413.33 ms.
        let cornered = motion_ticks("G4 P0\nG1 X10 F3600\nG1 X10 Y10");
        assert!(cornered.abs_diff(402_790) <= 50, "{cornered} ticks, 402 790 by hand");
        // A dwell, even of no length, waits for the planner to empty first (GRBL's `mc_dwell`), as a spindle word
        // does: the carriage stops at the corner.
        for between in ["G4 P0", "M3 S90"] {
            let stopped = motion_ticks(&format!("G1 X10 F3600\n{between}\nG1 X10 Y10"));
            assert!(stopped.abs_diff(413_333) <= 50, "{between}: {stopped} ticks, 413 333 by hand");
        }
    }

    #[test]
    fn dwells_come_in_whole_steps_of_50_ms() {
        // GRBL's `delay_sec`: ⌈20·P⌉ steps of 50 ms.
        for (p, ticks) in [("0", 0), ("0.0001", 50_000), ("0.045", 50_000), ("0.049", 50_000), ("0.051", 100_000)] {
            assert_eq!(motion_ticks(&format!("G4 P{p}")), ticks, "G4 P{p}");
        }
    }

    #[test]
    fn power_up_locks_until_homed_then_runs_gcode() {
        let mut e = emu();
        assert_eq!(e.take_replies(), ["Grbl 1.1h ['$' for help]", "[MSG:'$H'|'$X' to unlock]"]);
        assert_eq!(say(&mut e, "G1 X1 F600"), ["error:9"], "G-code is locked during the alarm");
        assert_eq!(say(&mut e, "$H"), ["ok"]);
        assert_eq!(say(&mut e, "G1 X10 Y5 F600"), ["ok"]);
        e.feed(b"?");
        e.run_for(1);
        let r = e.take_replies();
        assert!(r[0].starts_with("<Idle|MPos:10.000,5.000,4.000|FS:0,0"), "{r:?}");
        // 10 mm at 80 steps/mm.
        assert_eq!(e.backend().physical_position()[0], 800);
    }

    #[test]
    fn parser_errors_use_grbl_codes() {
        let mut e = emu();
        let _ = say(&mut e, "$X");
        assert_eq!(say(&mut e, "G1 X1"), ["error:22"], "no feed rate yet");
        assert_eq!(say(&mut e, "G2 X1 Y1 I1 F100"), ["error:20"]);
        assert_eq!(say(&mut e, "G1 X1 X2 F100"), ["error:25"]);
        assert_eq!(say(&mut e, "1 X"), ["error:1"]);
        assert_eq!(say(&mut e, "G1 Xa F100"), ["error:2"]);
        assert_eq!(say(&mut e, "$Q"), ["error:3"]);
        assert_eq!(say(&mut e, "G4"), ["error:28"]);
        assert_eq!(say(&mut e, "G1 X1 Y1 F600 ; comment (x)"), ["ok"]);
        assert_eq!(e.stats().errors, 7);
    }

    #[test]
    fn settings_info_and_offsets() {
        let mut e = emu();
        let _ = e.take_replies();
        let r = say(&mut e, "$$");
        assert!(r.contains(&"$100=80.000".to_string()) && r.contains(&"$22=1".to_string()), "{r:?}");
        assert_eq!(r.last().map(String::as_str), Some("ok"));
        assert_eq!(say(&mut e, "$I"), ["[VER:1.1h.20190830:plotter emulator]", "[OPT:V,15,128]", "ok"]);
        assert_eq!(say(&mut e, "$100=79.5"), ["ok"]);
        assert_eq!(e.settings().get(100), Some(79.5));
        assert_eq!(say(&mut e, "$H"), ["ok"]);
        assert_eq!(say(&mut e, "G92 X0 Y0 Z4"), ["ok"]);
        let r = say(&mut e, "$#");
        assert!(r.contains(&"[G92:0.000,0.000,0.000]".to_string()), "{r:?}");
        assert_eq!(say(&mut e, "G1 X2 F600"), ["ok"]);
        assert_eq!(say(&mut e, "G92 X10"), ["ok"]);
        let r = say(&mut e, "$#");
        assert!(r.contains(&"[G92:-8.000,0.000,0.000]".to_string()), "{r:?}");
    }

    #[test]
    fn soft_limit_is_an_alarm_and_x_unlocks() {
        let mut e = emu();
        let _ = say(&mut e, "$H");
        let r = say(&mut e, "G1 X500 F600");
        assert_eq!(r, ["ALARM:2", "[MSG:Reset to continue]"]);
        // A critical event: nothing is answered until a reset, which drops the waiting line.
        e.feed(b"$X\n");
        e.run_for(1_000_000);
        assert_eq!(e.take_replies(), Vec::<String>::new());
        e.feed(&[RT_RESET]);
        e.run_for(1);
        assert_eq!(e.take_replies(), ["Grbl 1.1h ['$' for help]", "[MSG:'$H'|'$X' to unlock]"]);
        assert_eq!(say(&mut e, "G1 X1 F600"), ["error:9"]);
        assert_eq!(say(&mut e, "$X"), ["[MSG:Caution: Unlocked]", "ok"]);
        assert_eq!(say(&mut e, "G1 X1 F600"), ["ok"]);
    }

    #[test]
    fn receive_buffer_overflow_is_counted() {
        let mut e = emu();
        let _ = say(&mut e, "$X");
        // 20 lines of 12 bytes at once: far more than 127 bytes before any answer.
        let burst: String = (0..20).map(|i| format!("G1 X{:>2} F600\n", i + 10)).collect();
        e.feed(burst.as_bytes());
        assert_eq!(e.stats().peak_rx, RX_USABLE);
        assert_eq!(e.stats().overflow_bytes, u64::try_from(burst.len() - RX_USABLE).unwrap());
    }

    #[test]
    fn m0_pauses_until_cycle_start_and_hold_resumes() {
        let mut e = emu();
        let _ = say(&mut e, "$H");
        e.feed(b"G1 X20 F600\nM0\nG1 X30\n");
        for _ in 0..100 {
            e.run_for(100_000);
        }
        e.feed(b"?");
        e.run_for(1);
        let r = e.take_replies();
        assert_eq!(&r[..2], ["ok", "ok"]);
        assert!(r[2].starts_with("<Hold:0|MPos:20.000,"), "{r:?}");
        e.feed(b"~");
        for _ in 0..100 {
            e.run_for(100_000);
        }
        assert_eq!(e.take_replies(), ["ok"]);
        assert_eq!(e.backend().physical_position()[0], 2400);
        // Feed hold in the middle of a move, then resume: the move completes.
        e.feed(b"G1 X100\n");
        e.run_for(200_000);
        e.feed(b"!");
        e.run_for(500_000);
        e.feed(b"?");
        e.run_for(1);
        assert!(e.take_replies().iter().any(|l| l.starts_with("<Hold:0")));
        e.feed(b"~");
        e.run_for(10_000_000);
        assert_eq!(e.backend().physical_position()[0], 8000);
    }

    #[test]
    fn reset_while_moving_raises_alarm_3() {
        let mut e = emu();
        let _ = say(&mut e, "$H");
        e.feed(b"G1 X100 F600\n");
        e.run_for(100_000);
        let _ = e.take_replies();
        e.feed(&[RT_RESET]);
        e.run_for(1);
        assert_eq!(e.take_replies(), ["ALARM:3", "Grbl 1.1h ['$' for help]", "[MSG:'$H'|'$X' to unlock]"]);
        assert_eq!(say(&mut e, "G1 X1"), ["error:9"]);
        // Z stays at the homed pen-up height (4 mm × 400 steps/mm); after `$X` a relative move is accepted.
        assert_eq!(e.pen().z_steps, 1600);
        assert_eq!(say(&mut e, "$X"), ["[MSG:Caution: Unlocked]", "ok"]);
        assert_eq!(say(&mut e, "G91 G0 Z-1"), ["ok"]);
        assert_eq!(e.pen().z_steps, 1200);
    }

    fn status(e: &mut GrblEmulator) -> String {
        e.feed(b"?");
        e.run_for(1);
        e.take_replies().into_iter().find(|l| l.starts_with('<')).unwrap()
    }

    #[test]
    fn sleep_refuses_everything_until_a_reset_wakes_it_in_alarm() {
        let mut e = emu();
        let _ = say(&mut e, "$H");
        assert_eq!(say(&mut e, "$SLP"), ["ok", "[MSG:Sleeping]"]);
        assert!(status(&mut e).starts_with("<Sleep|"));
        // A line waits unanswered.
        assert!(say(&mut e, "G1 X10 F600").is_empty());
        e.feed(&[RT_RESET]);
        e.run_for(1000);
        let r = e.take_replies();
        assert!(r.contains(&"[MSG:'$H'|'$X' to unlock]".to_string()), "{r:?}");
        assert!(status(&mut e).starts_with("<Alarm|"));
    }

    #[test]
    fn hold_decelerates_then_stops_and_a_reset_at_rest_keeps_position_and_pen() {
        let mut e = emu();
        let _ = say(&mut e, "$H");
        // Pen down (Z 0), then a long move at 100 mm/s.
        assert_eq!(say(&mut e, "G1 Z0 F1500"), ["ok"]);
        e.feed(b"G1 X200 F6000\n");
        e.run_for(300_000);
        e.feed(b"!");
        e.run_for(1);
        assert!(status(&mut e).starts_with("<Hold:1|"), "decelerating");
        e.run_for(1_000_000);
        let held = status(&mut e);
        assert!(held.starts_with("<Hold:0|MPos:"), "{held}");
        let x = e.backend().physical_position()[0];
        assert!(x > 0 && x < 16_000, "{x}");
        // A reset at Hold:0 is no alarm: banner only, position and pen kept, G-code accepted again.
        let _ = e.take_replies();
        e.feed(&[RT_RESET]);
        e.run_for(1);
        assert_eq!(e.take_replies(), ["Grbl 1.1h ['$' for help]"]);
        assert!(status(&mut e).starts_with("<Idle|"));
        assert_eq!(e.backend().physical_position()[0], x);
        assert_eq!(e.pen(), PenState { z_steps: 0, servo_deg: None }, "a reset does not move Z");
        assert_eq!(say(&mut e, "G0 Z4"), ["ok"]);
        assert_eq!(e.pen().z_steps, 1600);
    }

    #[test]
    fn hold_on_an_idle_machine_queues_lines_until_cycle_start() {
        let mut e = emu();
        let _ = say(&mut e, "$H");
        e.feed(b"!");
        e.run_for(1);
        assert!(status(&mut e).starts_with("<Hold:0|MPos:0.000,0.000,4.000"));
        e.feed(b"G1 X10 F600\n");
        e.run_for(2_000_000);
        assert_eq!(e.take_replies(), ["ok"], "queued");
        assert_eq!(e.backend().physical_position()[0], 0, "but not started");
        e.feed(b"~");
        e.run_for(2_000_000);
        assert_eq!(e.backend().physical_position()[0], 800);
        assert!(status(&mut e).starts_with("<Idle|"));
    }

    #[test]
    fn buttons_pressed_mid_program_act_as_real_time_bytes() {
        let cfg = plotter_path::motion::plan::machine_config(&MachineProfile::default_plotter()).unwrap();
        let settings = GrblSettings::for_profile(&MachineProfile::default_plotter());
        let faults = Faults { realtime_after_lines: Some((2, RT_FEED_HOLD)), ..Faults::default() };
        let mut e = GrblEmulator::with_settings(cfg, settings, None, faults);
        let _ = say(&mut e, "$H");
        e.feed(b"G1 X10 F600\nG1 X20\nG1 X30\n");
        e.run_for(5_000_000);
        // Held after the second line's `ok`: the third is queued too, nothing reaches X 30 mm.
        assert_eq!(e.take_replies(), ["ok", "ok", "ok"]);
        assert!(status(&mut e).starts_with("<Hold:0|"));
        assert!(e.backend().physical_position()[0] < 2400);
        e.feed(b"~");
        e.run_for(10_000_000);
        assert_eq!(e.backend().physical_position()[0], 2400);
    }

    #[test]
    fn a_hard_limit_waits_for_a_reset_before_anything_else() {
        let cfg = plotter_path::motion::plan::machine_config(&MachineProfile::default_plotter()).unwrap();
        let settings = GrblSettings::for_profile(&MachineProfile::default_plotter());
        let faults = Faults { hard_limit_after_lines: Some(1), ..Faults::default() };
        let mut e = GrblEmulator::with_settings(cfg, settings, None, faults);
        let _ = say(&mut e, "$H");
        e.feed(b"G1 X50 F600\n");
        e.run_for(100_000);
        assert_eq!(e.take_replies(), ["ok", "ALARM:1", "[MSG:Reset to continue]"]);
        e.feed(b"$X\n");
        e.run_for(1_000_000);
        assert_eq!(e.take_replies(), Vec::<String>::new(), "no answer before the reset");
        assert!(status(&mut e).starts_with("<Alarm|"));
        e.feed(&[RT_RESET]);
        e.run_for(1);
        assert_eq!(e.take_replies(), ["Grbl 1.1h ['$' for help]", "[MSG:'$H'|'$X' to unlock]"]);
        assert_eq!(say(&mut e, "$X"), ["[MSG:Caution: Unlocked]", "ok"]);
    }
}
