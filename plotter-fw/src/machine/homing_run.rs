//! The machine's homing: the running cycle ([`crate::homing`]'s state machine), the result the `G28` line waits
//! for, and which axes are homed. The cycle's moves run on the motion queue's stepper; its position updates go to
//! the stepper and the program's target.

use crate::config::MachineConfig;
use crate::errors::{AlarmCode, ErrorCode};
use crate::hal::{Endstops, StepPins, StepTimer};
use crate::homing::{HomingCycle, HomingStep};

use super::motion::MotionQueue;
use super::program::Program;

/// How a homing cycle ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Ended {
    /// All axes found and set.
    Done,
    /// A switch was never found or never released: the machine latches this alarm.
    Alarm(AlarmCode),
}

/// The homing state (see the module docs).
pub(crate) struct Homing {
    cycle: Option<HomingCycle>,
    /// The outcome of the last cycle, until the `G28` line takes it.
    result: Option<Result<(), AlarmCode>>,
    /// Mask of homed axes.
    homed: u8,
    /// Axes that were homed and then lost their position (a reset or an alarm while they stepped).
    lost: u8,
}

impl Homing {
    /// Nothing homed.
    pub(crate) const fn new() -> Self {
        Homing { cycle: None, result: None, homed: 0, lost: 0 }
    }

    /// Mask of homed axes.
    pub(crate) fn homed(&self) -> u8 {
        self.homed
    }

    /// A cycle is running.
    pub(crate) fn is_running(&self) -> bool {
        self.cycle.is_some()
    }

    /// A result waits for its `G28` line.
    pub(crate) fn has_result(&self) -> bool {
        self.result.is_some()
    }

    /// The result for the `G28` line.
    pub(crate) fn take_result(&mut self) -> Option<Result<(), AlarmCode>> {
        self.result.take()
    }

    /// Start a cycle for the axes of `mask` (0: all), in the order [`HomingCycle::plan`] gives (a known Z is kept);
    /// refused, with nothing started, when it would lower the pen onto the paper (`over_drawing`: `G28 P1`, a Z
    /// never homed counts as lost).
    pub(crate) fn start(&mut self, cfg: &MachineConfig, mask: u8, over_drawing: bool) -> Result<(), ErrorCode> {
        self.cycle = Some(HomingCycle::plan(cfg, mask, self.homed, self.lost, over_drawing)?);
        Ok(())
    }

    /// An alarm stopped everything: the cycle ends (a homing alarm becomes its result) and nothing is homed.
    pub(crate) fn abort(&mut self, code: AlarmCode) {
        self.cycle = None;
        if self.result.is_none() && matches!(code, AlarmCode::HomingNotFound | AlarmCode::HomingNotReleased) {
            self.result = Some(Err(code));
        }
        self.lose(self.homed);
    }

    /// The axes of `mask` may have lost steps (they were stepping when the motion stopped without deceleration):
    /// their positions are no longer known.
    pub(crate) fn lose(&mut self, mask: u8) {
        self.lost |= self.homed & mask;
        self.homed &= !mask;
    }

    /// A reset: no cycle, no result. What was homed stays homed but for the axes [`Homing::lose`] was told of
    /// (those stepping when the reset stopped them); a feed hold that had stopped loses nothing.
    pub(crate) fn reset(&mut self) {
        self.cycle = None;
        self.result = None;
    }

    /// Advance the running cycle while the stepper is idle: start its next move, or set positions; `Some` once
    /// it has ended.
    pub(crate) fn run<H: StepPins + Endstops + StepTimer, const Q: usize>(
        &mut self,
        cfg: &MachineConfig,
        motion: &mut MotionQueue<Q>,
        program: &mut Program,
        hal: &mut H,
    ) -> Option<Ended> {
        while let Some(cycle) = self.cycle.as_mut() {
            if !motion.stepper().is_idle() {
                return None;
            }
            let pressed = hal.pressed();
            let stepper = motion.stepper();
            match cycle.next(cfg, stepper.homing_hits(), pressed, &stepper.position()) {
                HomingStep::Move(b, switches) => {
                    motion.push_homing(b, switches, hal);
                    return None;
                }
                HomingStep::SetPosition(_, pos) => {
                    motion.stepper_mut().set_position(pos);
                    program.set_target_steps(pos, cfg);
                }
                HomingStep::Alarm(code) => {
                    self.result = Some(Err(code));
                    return Some(Ended::Alarm(code));
                }
                HomingStep::Done(mask) => {
                    self.homed |= mask;
                    self.lost &= !mask;
                    self.cycle = None;
                    self.result = Some(Ok(()));
                    program.set_target_steps(motion.stepper().position(), cfg);
                    return Some(Ended::Done);
                }
            }
        }
        None
    }
}
