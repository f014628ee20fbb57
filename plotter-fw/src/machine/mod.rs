//! Layer 3, orchestration: the firmware proper. [`Machine`] ties together parts that each own their state — the
//! host link (`link.rs`: receive ring, frames, sequence numbers, resends, replies, completion reports), the motion
//! queue (`motion.rs`: planner queue, stepper hand-off, re-planning after a hold, the one stop path), the program
//! state (`program.rs`: modal words, targets, offsets, line checks), homing (`homing_run.rs`) and the heaters
//! (`heaters.rs`: heater I/O, the heater driver, the `M112` spotter). The parts never call each other or the
//! machine; the machine, on top, interprets each line with them and latches alarms.
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

use core::fmt;

use crate::axis::{Axis, NUM_AXES};
use crate::config::MachineConfig;
use crate::errors::{AlarmCode, ErrorCode};
use crate::framing::M_FRAMED;
use crate::gcode::Words;
use crate::hal::{Hal, Heaters, NoHeaters};
use crate::heater_driver::{Cmd, Thermal};
use crate::planner::PlanBlock;
use crate::protocol::{Decoder, RT_FEED_HOLD, RT_RESET};
use crate::realtime::MachineState;
use crate::step_block::StepBlock;
use crate::stepper::{Stepper, StepperFault};
use crate::thermal::ThermalConfig;
use heaters::{HeaterUnit, Reply};
use homing_run::{Ended, Homing};
use link::{Input, Link, Out};
use motion::MotionQueue;
use program::{Program, Refusal};

mod heaters;
mod homing_run;
mod link;
mod motion;
mod program;

/// Firmware version reported in the banner and M115.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");

/// Result of handling one frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Outcome {
    /// Answered; take the next frame.
    Done,
    /// Cannot run yet (queue full, waiting for idle, homing): keep the frame and retry on the next poll.
    Blocked,
}

/// The firmware. `RX` is the receive buffer capacity (bytes), `Q` the planner queue capacity (blocks); the sizes
/// announced to the host are the configured ones, clamped to these. `T` is the printer's heater I/O
/// ([`NoHeaters`] on plotters).
#[repr(C)]
pub struct Machine<H: Hal, const RX: usize = 256, const Q: usize = 32, T: Heaters = NoHeaters> {
    /// First: the stepper's interrupt state (see [`MotionQueue`]), then the board's step timer.
    motion: MotionQueue<Q>,
    hal: H,
    heaters: HeaterUnit<T>,
    cfg: MachineConfig,
    link: Link<RX>,
    alarm: Option<AlarmCode>,
    homing: Homing,
    program: Program,
    last_completed: u32,
    /// `M0`/`M1` program pause (a pen change in a raw G-code stream): nothing more runs until `~`.
    program_paused: bool,
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
        let heaters = HeaterUnit::new(heaters, thermal, hal.now());
        let mut m = Machine {
            hal,
            heaters,
            cfg,
            link: Link::new(cfg.rx_buffer_bytes),
            motion: MotionQueue::new(&cfg),
            alarm: None,
            homing: Homing::new(),
            program: Program::new(cfg.pen.servo_up_deg),
            last_completed: 0,
            program_paused: false,
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
        self.heaters.io()
    }

    /// The heater I/O, mutably (simulator access to the thermal model).
    pub fn heaters_mut(&mut self) -> &mut T {
        self.heaters.io_mut()
    }

    /// The heater controller (temperatures, targets, duties).
    pub fn thermal(&self) -> &Thermal {
        self.heaters.thermal()
    }

    /// The configuration.
    pub fn config(&self) -> &MachineConfig {
        &self.cfg
    }

    /// The stepper (position, queue state).
    pub fn stepper(&self) -> &Stepper {
        self.motion.stepper()
    }

    /// The latched alarm.
    pub fn alarm(&self) -> Option<AlarmCode> {
        self.alarm
    }

    /// Mask of homed axes.
    pub fn homed(&self) -> u8 {
        self.homing.homed()
    }

    /// Next expected sequence number.
    pub fn expected_seq(&self) -> u32 {
        self.link.seq()
    }

    /// Whether the receive buffer holds bytes or a frame is waiting.
    pub fn has_input(&self) -> bool {
        self.link.has_input()
    }

    /// Free bytes in the receive buffer.
    pub fn rx_free(&self) -> usize {
        self.link.rx_free()
    }

    /// Current state.
    pub fn state(&self) -> MachineState {
        if self.alarm.is_some() {
            MachineState::Alarm
        } else if self.homing.is_running() {
            MachineState::Homing
        } else if self.program_paused {
            MachineState::Held
        } else {
            self.motion.state()
        }
    }

    /// Nothing left to do: no motion, no queued blocks, no pending input.
    pub fn is_idle(&self) -> bool {
        self.motion.drained() && !self.homing.is_running() && !self.has_input()
    }

    /// Whether a block finished or something else happened that `poll` should see.
    pub fn needs_poll(&self) -> bool {
        self.motion.stepper().completed() != self.last_completed
            || self.link.realtime_pending()
            || self.motion.stepper().fault().is_some()
            || self.motion.resume_due()
            || self.heaters.thermal().due(self.hal.now())
            || self.heaters.emergency_pending()
            || self.link.completion_due(self.motion.stepper().completed(), self.hal.now(), self.motion.drained())
    }

    /// Serial receive path (interrupt context): real-time bytes act at once, the rest goes to the ring buffer
    /// (a byte that does not fit is counted and reported, see [`crate::line_buffer::RxBuffer`]). Counting against the announced size.
    pub fn receive(&mut self, b: u8) {
        if self.heaters.spot_emergency_stop(b) {
            // M112: heaters off and motion stopped now, not when the line's turn comes; `poll` latches the alarm.
            self.motion.halt(&mut self.hal);
        }
        // Feed hold and reset act at once; status, resume and the rest of a reset wait for `poll`.
        match self.link.receive(b) {
            Some(RT_FEED_HOLD) => self.motion.feed_hold(),
            Some(RT_RESET) => {
                // Stopped without deceleration: the axes stepping now may lose steps (and only they).
                self.homing.lose(self.motion.stepper().moving_axes());
                self.motion.halt(&mut self.hal);
            }
            _ => {}
        }
    }

    /// Whether framed mode is on ([`crate::framing`]).
    pub fn is_framed(&self) -> bool {
        self.link.is_framed()
    }

    /// Step timer interrupt.
    #[inline(always)]
    pub fn on_timer(&mut self) {
        self.motion.on_timer(&mut self.hal);
    }

    /// The limit switches may have changed: a board calls this from its switch interrupt or its switch-sampling
    /// tick (the step interrupt reads the switches only during homing). During a normal move a pressed switch of
    /// an axis with hard limits stops the motion at once; the next [`Machine::poll`] raises the alarm (pen up,
    /// queue flushed).
    pub fn check_limits(&mut self) {
        self.motion.check_limits(&mut self.hal);
    }

    /// Main loop pass: real-time work, homing, line handling, planning, stepper hand-off.
    pub fn poll(&mut self) {
        self.last_completed = self.motion.stepper().completed();
        self.service_realtime();
        if let Some(StepperFault::HardLimit(_)) = self.motion.stepper().fault() {
            self.motion.stepper_mut().clear_fault();
            self.raise_alarm(AlarmCode::HardLimit);
        }
        // Everything after a hold restarts from rest.
        self.motion.replan_after_hold();
        // A `~` received while the hold was decelerating: the hold has now stopped (and was re-planned).
        self.motion.resume_when_stopped(&mut self.hal);
        self.service_thermal();
        self.run_homing();
        loop {
            if !self.link.next_frame() {
                break;
            }
            if self.handle_pending() == Outcome::Blocked {
                break;
            }
            self.link.finish_frame();
            self.motion.feed(&mut self.hal);
            self.run_homing();
        }
        self.motion.feed(&mut self.hal);
        let (completed, now, drained) = (self.motion.stepper().completed(), self.hal.now(), self.motion.drained());
        self.link.report_completion(&mut self.hal, completed, now, drained);
    }

    fn banner(&mut self) {
        self.link.banner(&mut self.hal, VERSION, self.motion.limit());
    }

    fn reply_ok(&mut self) {
        self.link.reply_ok(&mut self.hal);
    }

    fn reply_error(&mut self, code: ErrorCode, detail: fmt::Arguments<'_>) {
        self.link.reply_error(&mut self.hal, code, detail);
    }

    /// A pending emergency stop, and the heaters' period (PID, safety checks).
    fn service_thermal(&mut self) {
        let now = self.hal.now();
        if let Some(alarm) = self.heaters.service(now, &mut Out(&mut self.hal)) {
            self.raise_alarm(alarm);
        }
    }

    /// A temperature, fan or emergency-stop command (parsed by [`crate::thermal_gcode`], run by the heater
    /// driver); `None` when `w` is none of these.
    fn thermal_command(&mut self, w: &Words) -> Option<Outcome> {
        let (now, alarm) = (self.hal.now(), self.alarm.is_some());
        match self.heaters.command(w, now, &mut Out(&mut self.hal), alarm)? {
            Reply::Driver(Cmd::Ok) => self.reply_ok(),
            Reply::Driver(Cmd::Blocked) => return Some(Outcome::Blocked),
            Reply::Driver(Cmd::Error(code, detail)) => self.reply_error(code, format_args!("{detail}")),
            Reply::EmergencyStop => {
                // Spotted on receipt already, unless written in a form the byte spotter does not take (`M0112`).
                self.raise_alarm(AlarmCode::EmergencyStop);
                self.reply_ok();
            }
        }
        Some(Outcome::Done)
    }

    fn raise_alarm(&mut self, code: AlarmCode) {
        if code.is_shutdown() {
            self.heaters.shutdown();
            self.hal.enable_motors(false);
        }
        self.motion.abort(&mut self.hal);
        self.homing.abort(code);
        self.sync_target();
        if self.alarm.is_none() {
            self.alarm = Some(code);
            let seq = self.link.seq();
            self.link.reply(&mut self.hal, seq, format_args!("{code}"));
        }
    }

    fn service_realtime(&mut self) {
        let rt = self.link.take_realtime();
        if rt & link::RT_FLAG_RESET != 0 {
            self.motion.abort(&mut self.hal);
            self.motion.stepper_mut().clear_fault();
            self.link.reset(self.motion.stepper().completed());
            self.alarm = None;
            // (The axes that were stepping lost their home when the reset byte arrived, in `receive`.)
            self.homing.reset();
            self.program.reset_modes();
            self.program_paused = false;
            self.heaters.reset();
            self.sync_target();
            self.last_completed = self.motion.stepper().completed();
            self.banner();
            return;
        }
        if rt & link::RT_FLAG_RESUME != 0 {
            if self.program_paused {
                self.program_paused = false;
            } else {
                self.motion.resume(&mut self.hal);
            }
        }
        if rt & link::RT_FLAG_STATUS != 0 {
            self.status_report();
        }
    }

    /// Write the status report line (also sent for `?`).
    pub fn status_report(&mut self) {
        let state = self.state();
        let (queued, queue, completed) = (self.motion.len(), self.motion.limit(), self.motion.stepper().completed());
        let steps = self.motion.stepper().position();
        self.link.status_report(&mut self.hal, state, &steps, &self.cfg, [queued, queue], completed);
    }

    fn sync_target(&mut self) {
        self.program.set_target_steps(self.motion.stepper().position(), &self.cfg);
    }

    fn quiescent(&self) -> bool {
        self.motion.drained() && !self.homing.is_running()
    }

    fn run_homing(&mut self) {
        match self.homing.run(&self.cfg, &mut self.motion, &mut self.program, &mut self.hal) {
            Some(Ended::Alarm(code)) => self.raise_alarm(code),
            Some(Ended::Done) => self.link.clear_refused(),
            None => {}
        }
    }

    fn handle_pending(&mut self) -> Outcome {
        match self.link.input(&mut self.hal) {
            Input::Answered => Outcome::Done,
            Input::Line { words, number } => {
                let out = self.execute(&words);
                if out == Outcome::Done {
                    self.link.commit_seq(number);
                }
                out
            }
            Input::Frame { block, decoder } => self.step_frame(block, decoder),
        }
    }

    /// A host-planned step block: checked like a move, then queued unchanged.
    fn step_frame(&mut self, block: StepBlock, decoder: Decoder) -> Outcome {
        if self.alarm.is_none() && (self.motion.is_full() || self.homing.is_running()) {
            return Outcome::Blocked;
        }
        let number = self.link.accept_frame(decoder);
        if self.alarm.is_some() {
            self.reply_error(ErrorCode::Alarm, format_args!(""));
            return Outcome::Done;
        } else if let Some((n, _)) = self.link.refused() {
            self.reply_error(ErrorCode::BadFrame, format_args!(": block {n} was refused"));
            return Outcome::Done;
        }
        let cold = self.heaters.cold_extrusion();
        match self.program.frame_target(&block.steps, &self.cfg, self.homing.homed(), cold) {
            Ok(target) => {
                self.program.set_target_steps(target, &self.cfg);
                self.motion.push_block(PlanBlock::fixed(block), &self.cfg);
                self.reply_ok();
            }
            Err(r) => {
                self.link.refuse(number, r.code);
                self.refuse(r);
            }
        }
        Outcome::Done
    }

    fn refuse(&mut self, r: Refusal) -> Outcome {
        self.reply_error(r.code, format_args!("{}", r.detail));
        Outcome::Done
    }

    /// Run a G-code line (or keep it pending: [`Outcome::Blocked`]).
    fn execute(&mut self, w: &Words) -> Outcome {
        if self.program_paused {
            // `M0`/`M1`: wait for `~`.
            return Outcome::Blocked;
        }
        if let Some(out) = self.thermal_command(w) {
            return out;
        }
        let line = match program::check(w, &self.cfg, self.program.inches()) {
            Ok(line) => line,
            Err(r) => return self.refuse(r),
        };
        if line.moves && self.alarm.is_some() && !self.homing.has_result() {
            self.reply_error(ErrorCode::Alarm, format_args!(""));
            return Outcome::Done;
        }
        if line.other_g == Some(28) {
            return self.home(w);
        }
        // Blocking conditions, checked before any state changes.
        if line.needs_idle && !self.quiescent() {
            return Outcome::Blocked;
        }
        if line.needs_slot && (self.motion.is_full() || self.homing.is_running()) {
            return Outcome::Blocked;
        }
        let cold = self.heaters.cold_extrusion();
        match self.program.run_g(w, &line, &self.cfg, self.homing.homed(), cold) {
            Ok(block) => {
                if let Some(b) = block {
                    self.motion.push_block(b, &self.cfg);
                }
            }
            Err(r) => return self.refuse(r),
        }
        if line.is_move() {
            // A move line's M words are not run (as before the split).
            self.reply_ok();
            return Outcome::Done;
        }
        for &m in &w.m {
            match m {
                2 | 30 => self.program.end(),
                0 | 1 => self.program_paused = true,
                3..=5 => self.hal.set_servo(self.program.pen_angle(m, line.servo_deg)),
                17 => self.hal.enable_motors(true),
                M_FRAMED => {
                    self.link.set_framed(w.get(b'S').is_some_and(|s| s != 0), self.motion.stepper().completed())
                }
                18 | 84 => self.hal.enable_motors(false),
                82 | 83 => self.program.set_e_relative(m == 83),
                114 => self.program.write_position(&mut Out(&mut self.hal), &self.motion.stepper().position()),
                115 => self.link.identify(&mut self.hal, VERSION, self.motion.limit()),
                _ => {}
            }
        }
        self.reply_ok();
        Outcome::Done
    }

    fn home(&mut self, w: &Words) -> Outcome {
        if let Some(result) = self.homing.take_result() {
            match result {
                Ok(()) => self.reply_ok(),
                Err(code) => self.reply_error(ErrorCode::Alarm, format_args!(": {}", code.text())),
            }
            return Outcome::Done;
        }
        if self.homing.is_running() || !self.quiescent() {
            return Outcome::Blocked;
        }
        let mask = Axis::ALL.iter().filter(|a| w.has(a.letter() as u8)).fold(0, |m, a| m | a.bit());
        // `P1`: the carriage may stand over a drawing (the host's resume), see `crate::homing`.
        let over_drawing = w.get(b'P').is_some_and(|p| p != 0);
        if let Err(code) = self.homing.start(&self.cfg, mask, over_drawing) {
            self.reply_error(code, format_args!(": lift the pen clear or move the carriage off the paper, then G28 Z"));
            return Outcome::Done;
        }
        self.run_homing();
        if self.homing.has_result() { self.home(w) } else { Outcome::Blocked }
    }

    /// Exact commanded (queued) target in steps.
    pub fn target_steps(&self) -> [i32; NUM_AXES] {
        self.program.target_steps()
    }
}
