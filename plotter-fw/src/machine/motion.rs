//! The motion queue: the bounded planner queue and the stepper it feeds, with the one path that stops them.
//!
//! # Look-ahead and the stepper hand-off
//! Moves are planned in the bounded planner queue ([`crate::planner`], re-planned on every new block). A planned
//! block is handed to the stepper — and frozen — only when the stepper holds fewer than two blocks, so the planner
//! keeps as much look-ahead as the input gives it. Host-planned step blocks and dwells pass through the same queue
//! unchanged ([`PlanBlock::fixed`]). After a feed hold has stopped, everything still queued is re-planned to start
//! from rest.
//!
//! # Stopping
//! [`MotionQueue::halt`] stops the stepper at once without deceleration (safe in interrupt context: an emergency
//! stop or a reset byte); [`MotionQueue::abort`] does that and also empties the queue and forgets the cornering
//! memory — the one stop-everything path of alarms and resets.

use heapless::Deque;

use crate::axis::Axis;
use crate::config::MachineConfig;
use crate::hal::{Endstops, StepPins, StepTimer};
use crate::planner::{Linker, PlanBlock, plan, to_step_block};
use crate::realtime::MachineState;
use crate::step_block::{StepBlock, Switches};
use crate::stepper::Stepper;

/// The planner queue (capacity `Q` blocks) and the stepper.
#[repr(C)]
pub(crate) struct MotionQueue<const Q: usize> {
    /// First: the step interrupt's state at the start of the machine (short load offsets, `ldrd`/`ldm` in reach).
    stepper: Stepper,
    planner: Deque<PlanBlock, Q>,
    /// Cornering memory of the planner (the last blocks' geometry, for curve radii).
    linker: Linker,
    /// The queue size announced to the host (≤ `Q`).
    limit: usize,
    /// Entry speed² of the queue's first block: the exit of the block last handed to the stepper.
    first_entry_sqr: f32,
    /// The queue was re-planned from rest after the current feed hold stopped.
    hold_replanned: bool,
    /// `~` arrived while a feed hold was still decelerating: resume as soon as it has stopped.
    resume_after_hold: bool,
    timer_running: bool,
}

impl<const Q: usize> MotionQueue<Q> {
    /// An empty queue for `cfg` (its direction inversions, hard limits and queue size).
    pub(crate) fn new(cfg: &MachineConfig) -> Self {
        let invert = Axis::ALL.iter().filter(|a| cfg.axis(**a).invert_dir).fold(0, |m, a| m | a.bit());
        let limits = if cfg.hard_limits {
            Axis::ALL.iter().filter(|a| cfg.axis(**a).is_limited()).fold(0, |m, a| m | a.bit())
        } else {
            0
        };
        let mut stepper = Stepper::new(invert, limits);
        stepper.model_servo(&cfg.pen);
        MotionQueue {
            planner: Deque::new(),
            linker: Linker::new(),
            limit: usize::try_from(cfg.queue_blocks).unwrap_or(Q).clamp(1, Q),
            first_entry_sqr: 0.0,
            hold_replanned: false,
            resume_after_hold: false,
            stepper,
            timer_running: false,
        }
    }

    /// The stepper.
    pub(crate) fn stepper(&self) -> &Stepper {
        &self.stepper
    }

    /// The stepper, mutably (faults, holds, position).
    pub(crate) fn stepper_mut(&mut self) -> &mut Stepper {
        &mut self.stepper
    }

    /// Queue size announced to the host.
    pub(crate) fn limit(&self) -> usize {
        self.limit
    }

    /// Blocks in the planner queue (not yet handed to the stepper).
    pub(crate) fn len(&self) -> usize {
        self.planner.len()
    }

    /// No room for another block.
    pub(crate) fn is_full(&self) -> bool {
        self.planner.len() >= self.limit
    }

    /// The motion part of the machine state: held, holding, running or idle.
    pub(crate) fn state(&self) -> MachineState {
        if self.stepper.is_held() {
            MachineState::Held
        } else if self.stepper.is_holding() {
            MachineState::Holding
        } else if !self.drained() {
            MachineState::Run
        } else {
            MachineState::Idle
        }
    }

    /// Nothing left to run: planner queue and stepper empty.
    pub(crate) fn drained(&self) -> bool {
        self.stepper.is_idle() && self.planner.is_empty()
    }

    /// Queue `block` (callers check [`MotionQueue::is_full`] first) and re-plan the queue.
    pub(crate) fn push_block(&mut self, block: PlanBlock, cfg: &MachineConfig) {
        // Cannot fail: callers check the fill against `limit ≤ Q`.
        let _ = self.planner.push_back(block);
        self.linker.push(self.planner.make_contiguous(), cfg);
        let first = if self.stepper.is_held() { 0.0 } else { self.first_entry_sqr };
        plan(self.planner.make_contiguous(), first);
    }

    /// Start a homing move of the cycle: `block` watches the `switches` the cycle names.
    pub(crate) fn push_homing<H: StepPins + Endstops + StepTimer>(
        &mut self,
        block: StepBlock,
        switches: Switches,
        hal: &mut H,
    ) {
        self.linker.clear();
        // Cannot fail: homing moves run one at a time on an idle stepper.
        let _ = self.stepper.push(block, switches);
        self.start(hal);
    }

    /// Move planned blocks to the stepper while it holds fewer than two (or its last is a pen drop commanded on the
    /// way, which takes the move it lands at with it: [`Stepper::awaits_landing_move`]), then make sure it runs.
    pub(crate) fn feed<H: StepPins + Endstops + StepTimer>(&mut self, hal: &mut H) {
        while (self.stepper.pending() < 2 || self.stepper.awaits_landing_move()) && !self.stepper.is_held() {
            let Some(head) = self.planner.pop_front() else { break };
            let exit = self.planner.front().map_or(0.0, |b| b.entry_speed_sqr);
            self.first_entry_sqr = exit;
            let block = to_step_block(&head, exit);
            // Cannot fail: the stepper has room (fewer than two held, or room after a drop).
            let _ = self.stepper.push(block, Switches::Limits);
        }
        self.start(hal);
    }

    fn start<H: StepPins + Endstops + StepTimer>(&mut self, hal: &mut H) {
        if !self.timer_running
            && let Some(t) = self.stepper.start(hal)
        {
            self.timer_running = true;
            hal.schedule(t);
        }
    }

    /// The step timer interrupt: the stepper's fast path inline, the rest out of line in a call that ends the
    /// handler (a tail call: the handler's straight path calls nothing).
    #[inline(always)]
    pub(crate) fn on_timer<H: StepPins + Endstops + StepTimer>(&mut self, hal: &mut H) {
        if !self.stepper.on_timer_fast(hal) {
            self.on_timer_slow(hal);
        }
    }

    /// [`MotionQueue::on_timer`] off the fast path.
    #[inline(never)]
    fn on_timer_slow<H: StepPins + Endstops + StepTimer>(&mut self, hal: &mut H) {
        if !self.stepper.on_timer_slow(hal) {
            self.timer_running = false;
        }
    }

    /// The switches may have changed (the board's switch interrupt or sampling tick): a switch pressed during a
    /// normal move stops the stepper with a hard-limit fault, latched as an alarm by the next poll.
    pub(crate) fn check_limits<H: Endstops + StepTimer>(&mut self, hal: &mut H) {
        let pressed = hal.pressed();
        if self.stepper.limit_switches(pressed) {
            self.timer_running = false;
            hal.cancel();
        }
    }

    /// Once a feed hold has stopped, re-plan what is queued to start from rest (once per hold).
    pub(crate) fn replan_after_hold(&mut self) {
        if self.stepper.is_held() && !self.hold_replanned {
            self.hold_replanned = true;
            self.first_entry_sqr = 0.0;
            plan(self.planner.make_contiguous(), 0.0);
        }
    }

    /// Feed hold (`!`): decelerate to a stop. The latest real-time command wins: a hold cancels a resume still
    /// waiting for the stop.
    pub(crate) fn feed_hold(&mut self) {
        self.resume_after_hold = false;
        self.stepper.feed_hold();
    }

    /// Resume (`~`): continue after a hold that has stopped, or, while it is still decelerating, as soon as it has
    /// stopped ([`MotionQueue::resume_when_stopped`]).
    pub(crate) fn resume<H: StepPins + Endstops + StepTimer>(&mut self, hal: &mut H) {
        if self.stepper.is_held() {
            self.restart(hal);
        } else if self.stepper.is_holding() {
            self.resume_after_hold = true;
        }
    }

    /// A resume waits for the hold to stop, and it has.
    pub(crate) fn resume_due(&self) -> bool {
        self.resume_after_hold && self.stepper.is_held()
    }

    /// Act on a resume that waited for the hold to stop.
    pub(crate) fn resume_when_stopped<H: StepPins + Endstops + StepTimer>(&mut self, hal: &mut H) {
        if self.resume_due() {
            self.resume_after_hold = false;
            self.restart(hal);
        }
    }

    fn restart<H: StepPins + Endstops + StepTimer>(&mut self, hal: &mut H) {
        self.hold_replanned = false;
        if let Some(t) = self.stepper.resume(hal) {
            self.timer_running = true;
            hal.schedule(t);
        }
        self.feed(hal);
    }

    /// Stop the stepper now, without deceleration (interrupt-safe; the queue is kept until [`MotionQueue::abort`]).
    pub(crate) fn halt<H: StepTimer>(&mut self, hal: &mut H) {
        self.stepper.abort();
        hal.cancel();
        self.timer_running = false;
    }

    /// Stop everything: the stepper at once, the queue emptied, the cornering memory forgotten.
    pub(crate) fn abort<H: StepTimer>(&mut self, hal: &mut H) {
        self.halt(hal);
        self.planner.clear();
        self.linker.clear();
        self.first_entry_sqr = 0.0;
        self.hold_replanned = false;
        self.resume_after_hold = false;
    }
}
