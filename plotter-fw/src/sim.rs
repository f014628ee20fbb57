//! The host simulator (`std` feature): the firmware on virtual pins and a virtual clock.
//!
//! [`Sim`] runs a [`Machine`] on [`SimHal`]: a clock in [`TICK_HZ`] ticks, a one-shot step timer, step/dir pins
//! that move a *physical* position, endstops at configurable physical positions, and a serial line (bytes fed by
//! the host arrive at the baud rate, or as fast as the receive buffer takes them with hardware flow control).
//! Every step is recorded with its time, axis and direction, and the pen state (from the physical Z position) with
//! its time — the as-stepped trace for previews and tests.
//!
//! Physical positions are true machine coordinates in steps: by default each switch trips one pull-off beyond the
//! travel (at `-pull_off`, or `travel + pull_off` at the maximum end), which is where homing puts it, so after
//! homing the firmware's and the physical coordinates agree. The firmware starts believing it is at 0 wherever the simulated carriage really is
//! ([`SimOptions::start`]), exactly like a machine switched on at an unknown position.
//!
//! ```
//! use plotter_fw::{MachineConfig, sim::Sim};
//! let mut sim = Sim::new(MachineConfig::xy_plotter());
//! sim.feed(b"G1 X10 F600\n");
//! sim.run_until_idle();
//! assert_eq!(sim.physical_position()[0], 800);
//! assert!(sim.take_replies().iter().any(|l| l == "ok"));
//! ```

use std::collections::VecDeque;
use std::string::String;
use std::vec::Vec;

use crate::axis::{Axis, NUM_AXES};
use crate::config::MachineConfig;
use crate::fmath::round_i32;
use crate::hal::{Clock, Endstops, SerialOut, StepPins, StepTimer};
use crate::machine::Machine;
use crate::step_block::TICK_HZ;
use crate::thermal::ThermalConfig;

pub mod thermal;

use thermal::SimHeaters;

/// The firmware as the simulator runs it.
pub type SimMachine = Machine<SimHal, 1024, 64, SimHeaters>;

/// One recorded step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StepEvent {
    /// Time, ticks.
    pub time: u64,
    /// Axis.
    pub axis: Axis,
    /// `true` for a step towards positive physical coordinates.
    pub forward: bool,
}

/// A homing/limit switch: pressed when the physical position is at or beyond `position` (below it for a switch at
/// the minimum end, above it for one at the maximum end).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Switch {
    /// Physical trip position, steps.
    pub position: i64,
    /// Whether the switch sits at the maximum end.
    pub at_max: bool,
}

/// Simulator set-up.
#[derive(Debug, Clone, PartialEq)]
pub struct SimOptions {
    /// Serial speed; `None` = bytes arrive as fast as the receive buffer accepts them (hardware flow control).
    pub baud: Option<u32>,
    /// Physical start position, steps.
    pub start: [i64; NUM_AXES],
    /// Switch per axis (`None` = no switch).
    pub switches: [Option<Switch>; NUM_AXES],
    /// Record every step (off: only counts and the pen trace are kept).
    pub record_steps: bool,
    /// The printer's heaters, simulated by [`thermal`] ([`ThermalConfig::NONE`] for a plotter).
    pub thermal: ThermalConfig,
}

impl SimOptions {
    /// Switches one pull-off outside the travel (where homing expects them), carriage at 0, flow-controlled
    /// serial, full trace.
    pub fn for_config(cfg: &MachineConfig) -> Self {
        let mut switches = [None; NUM_AXES];
        for axis in Axis::ALL {
            let a = cfg.axis(axis);
            if a.is_limited() {
                let pull = i64::from(round_i32(f64::from(cfg.homing.pull_off_mm) * f64::from(a.steps_per_mm)));
                let position = if a.home_at_max { i64::from(a.travel_steps()) + pull } else { -pull };
                switches[axis.index()] = Some(Switch { position, at_max: a.home_at_max });
            }
        }
        SimOptions { baud: None, start: [0; NUM_AXES], switches, record_steps: true, thermal: ThermalConfig::NONE }
    }
}

/// The simulated board.
#[derive(Debug)]
pub struct SimHal {
    now: u64,
    timer_at: Option<u64>,
    busy: u64,
    dir: [bool; NUM_AXES],
    invert: u8,
    phys: [i64; NUM_AXES],
    phys_max: [i64; NUM_AXES],
    switches: [Option<Switch>; NUM_AXES],
    record: bool,
    steps: Vec<StepEvent>,
    step_counts: [u64; NUM_AXES],
    pen_threshold: i64,
    pen_down: bool,
    pen: Vec<(u64, bool)>,
    motors_on: bool,
    /// Servo commands: time, angle, pulse width (µs).
    servo: Vec<(u64, f32, u16)>,
    out: Vec<u8>,
}

impl SimHal {
    fn new(cfg: &MachineConfig, opts: &SimOptions) -> Self {
        let invert = Axis::ALL.iter().filter(|a| cfg.axis(**a).invert_dir).fold(0, |m, a| m | a.bit());
        let z = cfg.axis(Axis::Z);
        let mid = f64::from(cfg.pen.up_z_mm + cfg.pen.down_z_mm) / 2.0 * f64::from(z.steps_per_mm);
        let pen_threshold = i64::from(round_i32(mid));
        let pen_down = opts.start[Axis::Z.index()] < pen_threshold;
        SimHal {
            now: 0,
            timer_at: None,
            busy: 0,
            dir: [false; NUM_AXES],
            invert,
            phys: opts.start,
            phys_max: opts.start,
            switches: opts.switches,
            record: opts.record_steps,
            steps: Vec::new(),
            step_counts: [0; NUM_AXES],
            pen_threshold,
            pen_down,
            pen: std::vec![(0, pen_down)],
            motors_on: true,
            servo: Vec::new(),
            out: Vec::new(),
        }
    }

    /// Physical position, steps.
    pub fn physical_position(&self) -> [i64; NUM_AXES] {
        self.phys
    }

    /// Highest physical position reached per axis, steps (for the extruder: the filament pushed out, since
    /// retracted filament is pushed out again before any more leaves the nozzle).
    pub fn max_position(&self) -> [i64; NUM_AXES] {
        self.phys_max
    }

    /// Every step so far (empty when recording is off).
    pub fn steps(&self) -> &[StepEvent] {
        &self.steps
    }

    /// Steps per axis so far.
    pub fn step_counts(&self) -> [u64; NUM_AXES] {
        self.step_counts
    }

    /// Pen state changes `(time, down)`, starting with the initial state at time 0. The pen is down while the
    /// physical Z is below the midpoint of the configured pen-up and pen-down heights.
    pub fn pen_trace(&self) -> &[(u64, bool)] {
        &self.pen
    }

    /// Total time the step timer ran (the executed motion time), ticks.
    pub fn busy_ticks(&self) -> u64 {
        self.busy
    }

    /// Whether the drivers are energised.
    pub fn motors_on(&self) -> bool {
        self.motors_on
    }

    /// Every servo command with its time (ticks), angle (degrees) and the pulse width (µs) of its 50 Hz signal.
    pub fn servo_trace(&self) -> &[(u64, f32, u16)] {
        &self.servo
    }
}

impl StepPins for SimHal {
    #[inline]
    fn set_dir(&mut self, axis: Axis, level: bool) {
        self.dir[axis.index()] = level ^ (self.invert & axis.bit() != 0);
    }

    #[inline]
    fn step(&mut self, axis: Axis) {
        let i = axis.index();
        let forward = !self.dir[i];
        self.phys[i] += if forward { 1 } else { -1 };
        self.phys_max[i] = self.phys_max[i].max(self.phys[i]);
        self.step_counts[i] += 1;
        if self.record {
            self.steps.push(StepEvent { time: self.now, axis, forward });
        }
        if axis == Axis::Z {
            let down = self.phys[i] < self.pen_threshold;
            if down != self.pen_down {
                self.pen_down = down;
                self.pen.push((self.now, down));
            }
        }
    }

    fn set_servo(&mut self, angle_deg: f32) {
        self.servo.push((self.now, angle_deg, crate::hal::servo_pulse_us(angle_deg)));
    }

    fn enable_motors(&mut self, on: bool) {
        self.motors_on = on;
    }
}

impl Endstops for SimHal {
    #[inline]
    fn pressed(&mut self) -> u8 {
        let mut m = 0;
        for (i, s) in self.switches.iter().enumerate() {
            if let Some(s) = s {
                let p = self.phys[i];
                if (s.at_max && p >= s.position) || (!s.at_max && p <= s.position) {
                    m |= 1 << i;
                }
            }
        }
        m
    }
}

impl StepTimer for SimHal {
    #[inline]
    fn schedule(&mut self, ticks: u32) {
        self.timer_at = Some(self.now + u64::from(ticks));
        self.busy += u64::from(ticks);
    }

    fn cancel(&mut self) {
        self.timer_at = None;
    }
}

impl SerialOut for SimHal {
    fn write(&mut self, bytes: &[u8]) {
        self.out.extend_from_slice(bytes);
    }
}

impl Clock for SimHal {
    fn now(&self) -> u64 {
        self.now
    }
}

/// The firmware on a simulated board. See the module docs.
pub struct Sim {
    machine: SimMachine,
    wire: VecDeque<u8>,
    byte_ticks: Option<u64>,
    next_byte_at: u64,
    replies: Vec<u8>,
}

impl Sim {
    /// Simulator with [`SimOptions::for_config`].
    pub fn new(cfg: MachineConfig) -> Self {
        let opts = SimOptions::for_config(&cfg);
        Self::with_options(cfg, opts)
    }

    /// Simulator with explicit options.
    pub fn with_options(cfg: MachineConfig, opts: SimOptions) -> Self {
        let hal = SimHal::new(&cfg, &opts);
        let byte_ticks = opts.baud.map(|b| (u64::from(TICK_HZ) * 10).div_ceil(u64::from(b.max(1))));
        let heaters = SimHeaters::new(&opts.thermal);
        let machine = Machine::with_heaters(hal, cfg, heaters, opts.thermal);
        Sim { machine, wire: VecDeque::new(), byte_ticks, next_byte_at: 0, replies: Vec::new() }
    }

    /// Queue bytes on the serial line towards the firmware.
    pub fn feed(&mut self, bytes: &[u8]) {
        if self.wire.is_empty() {
            self.next_byte_at = self.next_byte_at.max(self.machine.hal().now);
        }
        self.wire.extend(bytes);
    }

    /// Bytes still on the wire (not yet received by the firmware).
    pub fn wire_len(&self) -> usize {
        self.wire.len()
    }

    /// Complete reply lines received since the last call (without line ends).
    pub fn take_replies(&mut self) -> Vec<String> {
        let out = &mut self.machine.hal_mut().out;
        self.replies.append(out);
        let Some(end) = self.replies.iter().rposition(|&b| b == b'\n') else { return Vec::new() };
        let text: Vec<u8> = self.replies.drain(..=end).collect();
        String::from_utf8_lossy(&text).lines().map(String::from).collect()
    }

    /// Virtual time, ticks.
    pub fn now(&self) -> u64 {
        self.machine.hal().now
    }

    /// The firmware.
    pub fn machine(&self) -> &SimMachine {
        &self.machine
    }

    /// The simulated heaters (temperatures, duties, fault injection).
    pub fn heaters(&self) -> &SimHeaters {
        self.machine.heaters()
    }

    /// The simulated heaters, mutably (inject faults, change models).
    pub fn heaters_mut(&mut self) -> &mut SimHeaters {
        self.machine.heaters_mut()
    }

    /// The main loop, with the heater models brought up to now first.
    fn poll(&mut self) {
        let now = self.now();
        self.machine.heaters_mut().advance_to(now);
        self.machine.poll();
    }

    /// The board (trace, physical position).
    pub fn hal(&self) -> &SimHal {
        self.machine.hal()
    }

    /// Physical position, steps.
    pub fn physical_position(&self) -> [i64; NUM_AXES] {
        self.machine.hal().phys
    }

    /// Run until nothing is left to do (wire empty, queue empty, stepper idle); returns the virtual time.
    pub fn run_until_idle(&mut self) -> u64 {
        self.run_until(u64::MAX);
        self.now()
    }

    /// Advance virtual time by `ticks` (or less, if everything goes idle first).
    pub fn run_for(&mut self, ticks: u64) -> u64 {
        let end = self.now().saturating_add(ticks);
        self.run_until(end);
        self.now()
    }

    fn deliver(&mut self) -> bool {
        let mut any = false;
        match self.byte_ticks {
            None => {
                while self.machine.rx_free() > 0 {
                    let Some(b) = self.wire.pop_front() else { break };
                    self.machine.receive(b);
                    any = true;
                }
            }
            Some(bt) => {
                while self.next_byte_at <= self.now() {
                    let Some(b) = self.wire.pop_front() else { break };
                    self.machine.receive(b);
                    self.next_byte_at += bt;
                    any = true;
                }
            }
        }
        any
    }

    fn run_until(&mut self, end: u64) {
        loop {
            let delivered = self.deliver();
            if delivered || self.machine.needs_poll() {
                self.poll();
                // Polling may free receive space (flow-controlled wire) or queue work.
                if self.byte_ticks.is_none() && !self.wire.is_empty() && self.machine.rx_free() > 0 {
                    continue;
                }
            }
            let byte_at = match self.byte_ticks {
                Some(_) if !self.wire.is_empty() => Some(self.next_byte_at),
                _ => None,
            };
            let timer_at = self.machine.hal().timer_at;
            // The heaters' period wakes the main loop while something is under way (motion, a line waiting, e.g.
            // for a temperature) or for a bounded run; an idle machine holding its temperature does not keep
            // `run_until_idle` going for ever.
            let busy = end != u64::MAX || self.machine.has_input() || !self.machine.stepper().is_idle();
            let thermal_at = self.machine.thermal().next_deadline().filter(|_| busy).map(|t| t.max(self.now()));
            let next = match [timer_at, byte_at, thermal_at].into_iter().flatten().min() {
                Some(t) => t,
                None => {
                    if self.machine.has_input() && !self.machine.needs_poll() {
                        // Input waiting but nothing to wake the machine: poll once more, then give up.
                        let before = self.machine.rx_free();
                        self.poll();
                        if self.machine.hal().timer_at.is_some() || self.machine.rx_free() != before {
                            continue;
                        }
                    }
                    return;
                }
            };
            if next > end {
                self.machine.hal_mut().now = end.max(self.now());
                return;
            }
            self.machine.hal_mut().now = next;
            if timer_at == Some(next) {
                // Hot loop: timer events until something needs the main loop or a byte is due.
                let limit = byte_at.unwrap_or(u64::MAX).min(end).min(thermal_at.unwrap_or(u64::MAX));
                loop {
                    // The switches as a board's switch interrupt sees them: between two step events.
                    self.machine.check_limits();
                    self.machine.on_timer();
                    if self.machine.needs_poll() {
                        break;
                    }
                    match self.machine.hal().timer_at {
                        Some(t) if t <= limit => self.machine.hal_mut().now = t,
                        _ => break,
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod framed;
#[cfg(test)]
mod homing_tests;
#[cfg(test)]
mod numbers;
#[cfg(test)]
mod printer_tests;
#[cfg(test)]
mod tests;
