//! The homing cycle: a small state machine that queues ordinary step blocks (run by the same Bresenham stepper,
//! with an axis lock mask that stops each axis at its switch) and checks the outcome of each.
//!
//! Order: Z first (then Z moves to the pen-up height), then X and Y together. Per group:
//! 1. **seek** towards the switches at the seek rate, at most 1.5 × travel — an axis stops (is locked) the moment
//!    its switch reads pressed; an axis that reaches the distance without it raises
//!    [`AlarmCode::HomingNotFound`];
//! 2. debounce dwell, **pull off** by the pull-off distance — a switch still pressed raises
//!    [`AlarmCode::HomingNotReleased`];
//! 3. **locate** towards the switches at the slow rate, at most 2 × pull-off + 1 step;
//! 4. debounce dwell, **pull off** again, check the release, and set the position: this pulled-off point is
//!    machine 0 (or the travel, for a switch at the maximum end). The switch thus trips exactly one pull-off
//!    beyond the travel, so no move within the travel ever touches it (it would be a hard-limit alarm).
//!
//! # Z first, and never onto the paper
//! X and Y may only move with the pen up, so Z comes first. Where Z's switch sits decides how:
//! - **at the maximum end**, homing Z lifts the pen: Z is homed first, always;
//! - **at the minimum end** (the XY kit: the switch below the pen's touch), seeking it lowers the pen wherever
//!   the carriage stands — a dot on the drawing. So a full cycle ([`HomingCycle::plan`]) homes Z there only when
//!   it must and may:
//!   - Z's position is **known** (homed since start, and not lost since): it is kept; Z goes up to the pen-up
//!     height, then X and Y home ([`HomingCycle::keeping_z`]). A plot stopped mid-stroke (the host resets the
//!     firmware while X and Y move, then lifts the pen) keeps Z: only the axes stepping at a reset lose their
//!     steps, and a stroke does not step Z;
//!   - Z's position was **lost** (a reset or an alarm while Z was stepping: its true height may differ from the
//!     count by the steps the halt lost): it is homed where the carriage stands only when the profile says the
//!     pen is still clear of the paper at the switch (`homing.pen_clear_at_z_switch`); otherwise the cycle is
//!     refused ([`ErrorCode::HomingWouldMark`](crate::errors::ErrorCode::HomingWouldMark)) and nothing moves —
//!     moving X and Y first could drag a lowered pen. The operator lifts the pen clear or moves the carriage off
//!     the paper and asks for Z alone (`G28 Z`), which always homes it;
//!   - Z was **never homed** since the firmware started: a plain `G28` homes it where the carriage stands (a
//!     machine is switched on with its carriage at the home corner, and every G-code sender starts with `G28`).
//!     But a power cycle, a board swapped or flashed mid-plot also leave Z never homed, with the carriage over
//!     the drawing and the pen perhaps on it. The firmware cannot tell the two apart; the host can, so it says
//!     which: **`G28 P1`** ("the carriage may stand over a drawing", what the host's resume sends) treats a Z
//!     never homed like a lost one — refused, nothing moves. The host then lifts the pen, homes X and Y alone
//!     (`G28 X Y`: Z untouched), travels to the spot its profile names for homing Z off the paper, and homes Z
//!     there (`G28 Z`); without such a spot it asks the user to move the carriage off the paper and home Z.
//!     Refusing every first `G28` instead would make each power-up need that spot or the user's hands, on the
//!     machine whose carriage is usually where the last plot left it at home.
use crate::axis::{Axis, NUM_AXES};
use crate::config::MachineConfig;
use crate::errors::{AlarmCode, ErrorCode};
use crate::fmath::{round_i32, round_u32};
use crate::planner::{PlanBlock, to_step_block};
use crate::step_block::{StepBlock, Switches, TICK_HZ};

/// A homing block that stops no axis at its switch (a debounce dwell, a pull-off): hard limits are not checked.
const NO_STOP: Switches = Switches::Homing { axes: 0 };

/// What the machine should do next for the cycle.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HomingStep {
    /// Queue this block, treating the switches as given (always [`Switches::Homing`]).
    Move(StepBlock, Switches),
    /// Set these axes' positions (steps), for the axes in the mask.
    SetPosition(u8, [i32; NUM_AXES]),
    /// The cycle failed.
    Alarm(AlarmCode),
    /// The cycle is complete; the mask names the homed axes.
    Done(u8),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Phase {
    Seek,
    Debounce1,
    PullOff1,
    Locate,
    Debounce2,
    PullOff2,
    SetPosition,
    PenUp,
    NextGroup,
}

/// One homing cycle in progress.
#[derive(Debug, Clone, Copy)]
pub struct HomingCycle {
    groups: [u8; 2],
    group: usize,
    phase: Phase,
    homed: u8,
}

impl HomingCycle {
    /// A cycle for the axes in `mask` (limited axes only; 0 = all of them).
    pub fn new(config: &MachineConfig, mask: u8) -> Self {
        let limited = Axis::ALL.iter().filter(|a| config.axis(**a).is_limited()).fold(0, |m, a| m | a.bit());
        let mask = if mask == 0 { limited } else { mask & limited };
        let z = mask & Axis::Z.bit();
        let xy = mask & (Axis::X.bit() | Axis::Y.bit() | Axis::E.bit());
        HomingCycle { groups: [z, xy], group: 0, phase: Phase::Seek, homed: 0 }
    }

    /// The cycle `G28` runs for the axes in `mask` (0 = all), given the axes whose position is known (`homed`) and
    /// those whose position was known and then lost (`lost`); see the module docs for the order and its reason. A
    /// full cycle keeps a known Z whose switch is at the minimum end, and is refused when such a Z was lost and the
    /// pen touches the paper before its switch — or was never homed, when `over_drawing` (`G28 P1`: the carriage
    /// may stand over a drawing, as after a power cycle mid-plot). Naming Z (`G28 Z`) always homes it.
    pub fn plan(config: &MachineConfig, mask: u8, homed: u8, lost: u8, over_drawing: bool) -> Result<Self, ErrorCode> {
        let z = config.axis(Axis::Z);
        let z_seeks_down = z.is_limited() && !z.home_at_max;
        if mask != 0 || !z_seeks_down {
            return Ok(Self::new(config, mask));
        }
        let zb = Axis::Z.bit();
        let unknown = if over_drawing { zb } else { lost & zb };
        if homed & zb != 0 {
            Ok(Self::keeping_z(config))
        } else if unknown != 0 && !config.homing.pen_clear_at_z_switch {
            Err(ErrorCode::HomingWouldMark)
        } else {
            Ok(Self::new(config, 0))
        }
    }

    /// A cycle of every limited axis that keeps Z's known position: Z goes straight to the pen-up height (no seek
    /// towards its switch, which would lower the pen), then X and Y home as usual.
    pub fn keeping_z(config: &MachineConfig) -> Self {
        let mut cycle = Self::new(config, 0);
        if cycle.groups[0] != 0 {
            cycle.phase = Phase::PenUp;
            cycle.homed = cycle.groups[0];
        }
        cycle
    }

    /// Axes homed so far.
    pub fn homed(&self) -> u8 {
        self.homed
    }

    /// Advance once the previous step is done. `hits` = axes stopped by their switch in the last block,
    /// `pressed` = switches pressed now, `position` = the current position in steps.
    pub fn next(&mut self, config: &MachineConfig, hits: u8, pressed: u8, position: &[i32; NUM_AXES]) -> HomingStep {
        loop {
            let group = match self.groups.get(self.group) {
                Some(&g) => g,
                None => return HomingStep::Done(self.homed),
            };
            if group == 0 {
                self.group += 1;
                continue;
            }
            let h = &config.homing;
            let debounce = StepBlock::dwell(round_u32(h.debounce_ms * (TICK_HZ as f32 / 1000.0)).max(1));
            match self.phase {
                Phase::Seek => {
                    self.phase = Phase::Debounce1;
                    return self.towards(config, group, |a| 1.5 * config.axis(a).travel_mm, h.seek_mm_s);
                }
                Phase::Debounce1 | Phase::Debounce2 => {
                    if hits & group != group {
                        return HomingStep::Alarm(AlarmCode::HomingNotFound);
                    }
                    self.phase = if self.phase == Phase::Debounce1 { Phase::PullOff1 } else { Phase::PullOff2 };
                    return HomingStep::Move(debounce, NO_STOP);
                }
                Phase::PullOff1 | Phase::PullOff2 => {
                    self.phase = if self.phase == Phase::PullOff1 { Phase::Locate } else { Phase::SetPosition };
                    let rate = if self.phase == Phase::Locate { h.seek_mm_s } else { h.locate_mm_s };
                    return self.away(config, group, h.pull_off_mm, rate);
                }
                Phase::Locate => {
                    if pressed & group != 0 {
                        return HomingStep::Alarm(AlarmCode::HomingNotReleased);
                    }
                    self.phase = Phase::Debounce2;
                    let dist = |a: Axis| 2.0 * h.pull_off_mm + 1.0 / config.axis(a).steps_per_mm;
                    return self.towards(config, group, dist, h.locate_mm_s);
                }
                Phase::SetPosition => {
                    if pressed & group != 0 {
                        return HomingStep::Alarm(AlarmCode::HomingNotReleased);
                    }
                    let mut pos = *position;
                    for axis in Axis::ALL.into_iter().filter(|a| group & a.bit() != 0) {
                        let a = config.axis(axis);
                        pos[axis.index()] = if a.home_at_max { a.travel_steps() } else { 0 };
                    }
                    self.homed |= group;
                    self.phase = if group & Axis::Z.bit() != 0 { Phase::PenUp } else { Phase::NextGroup };
                    return HomingStep::SetPosition(group, pos);
                }
                Phase::PenUp => {
                    self.phase = Phase::NextGroup;
                    let z = config.axis(Axis::Z);
                    let target = round_i32(f64::from(config.pen.up_z_mm) * f64::from(z.steps_per_mm));
                    let mut steps = [0; NUM_AXES];
                    steps[Axis::Z.index()] = target - position[Axis::Z.index()];
                    if let Some(b) = PlanBlock::line(config, steps, z.max_feed_mm_s) {
                        // Part of the cycle: switches of axes not homed yet may legitimately be pressed.
                        return HomingStep::Move(to_step_block(&b, 0.0), NO_STOP);
                    }
                }
                Phase::NextGroup => {
                    self.group += 1;
                    self.phase = Phase::Seek;
                }
            }
        }
    }

    fn towards(&self, config: &MachineConfig, group: u8, dist_mm: impl Fn(Axis) -> f32, rate: f32) -> HomingStep {
        self.block(config, group, dist_mm, rate, true)
    }

    fn away(&self, config: &MachineConfig, group: u8, dist_mm: f32, rate: f32) -> HomingStep {
        self.block(config, group, |_| dist_mm, rate, false)
    }

    fn block(
        &self,
        config: &MachineConfig,
        group: u8,
        dist_mm: impl Fn(Axis) -> f32,
        rate: f32,
        towards: bool,
    ) -> HomingStep {
        let mut steps = [0i32; NUM_AXES];
        for axis in Axis::ALL.into_iter().filter(|a| group & a.bit() != 0) {
            let a = config.axis(axis);
            let s = round_i32(f64::from(dist_mm(axis)) * f64::from(a.steps_per_mm)).max(1);
            // Towards the switch is negative for a switch at 0, positive at the maximum end.
            steps[axis.index()] = if a.home_at_max == towards { s } else { -s };
        }
        let plan = PlanBlock::line(config, steps, rate);
        let block = plan.map_or(StepBlock::dwell(1), |p| to_step_block(&p, 0.0));
        HomingStep::Move(block, Switches::Homing { axes: if towards { group } else { 0 } })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sequence_for_z_then_xy() {
        let c = MachineConfig::xy_plotter();
        let mut h = HomingCycle::new(&c, 0);
        let pos = [0; NUM_AXES];
        // Z seek: 1.5 × 10 mm × 400 = 6000 steps towards 0, watching Z.
        let HomingStep::Move(b, m) = h.next(&c, 0, 0, &pos) else { panic!() };
        assert_eq!((b.steps, m), ([0, 0, -6000, 0], Switches::Homing { axes: Axis::Z.bit() }));
        // Switch found → debounce dwell of 5 ms.
        assert_eq!(h.next(&c, Axis::Z.bit(), Axis::Z.bit(), &pos), HomingStep::Move(StepBlock::dwell(5000), NO_STOP));
        let HomingStep::Move(b, m) = h.next(&c, Axis::Z.bit(), Axis::Z.bit(), &pos) else { panic!() };
        assert_eq!((b.steps, m), ([0, 0, 800, 0], NO_STOP));
        // Still pressed after the pull-off → alarm.
        assert_eq!(h.next(&c, 0, Axis::Z.bit(), &pos), HomingStep::Alarm(AlarmCode::HomingNotReleased));
    }

    /// The XY kit's Z switch is at the minimum end, below the pen's touch. A full cycle with Z known starts with
    /// the lift to the pen-up height (4 mm = 1600 steps from Z 0.5 mm = 200 steps: +1400), not a seek downwards,
    /// then seeks X and Y (1.5 × 420 mm and 1.5 × 297 mm at 80 steps/mm); a lost Z is refused unless the profile
    /// says the pen is clear at the switch; a Z never homed, or named on its own, is sought (−1.5 × 10 mm × 400).
    #[test]
    fn a_full_cycle_keeps_a_known_z_and_refuses_a_lost_one() {
        let mut c = MachineConfig::xy_plotter();
        let (z, all) = (Axis::Z.bit(), 0b111);
        let pos = [5000, 4000, 200, 0];
        let z_seek = [0, 0, -6000, 0];
        let first = |h: &mut HomingCycle, c: &MachineConfig| match h.next(c, 0, 0, &pos) {
            HomingStep::Move(b, m) => (b.steps, m),
            other => panic!("{other:?}"),
        };
        let mut kept = HomingCycle::plan(&c, 0, all, 0, false).unwrap();
        assert_eq!(first(&mut kept, &c), ([0, 0, 1400, 0], NO_STOP));
        assert_eq!(kept.homed(), z, "Z counts as homed: its position is known");
        let xy = Switches::Homing { axes: Axis::X.bit() | Axis::Y.bit() };
        assert_eq!(first(&mut kept, &c), ([-50_400, -35_640, 0, 0], xy));
        assert_eq!(HomingCycle::plan(&c, 0, 0, z, false).unwrap_err(), ErrorCode::HomingWouldMark);
        let mut named = HomingCycle::plan(&c, z, 0, z, false).unwrap();
        assert_eq!(first(&mut named, &c), (z_seek, Switches::Homing { axes: z }));
        let mut fresh = HomingCycle::plan(&c, 0, 0, 0, false).unwrap();
        assert_eq!(first(&mut fresh, &c), (z_seek, Switches::Homing { axes: z }));
        c.homing.pen_clear_at_z_switch = true;
        let mut clear = HomingCycle::plan(&c, 0, 0, z, false).unwrap();
        assert_eq!(first(&mut clear, &c), (z_seek, Switches::Homing { axes: z }));
        // A switch at the maximum end lifts the pen: Z is sought upwards, known or not.
        let mut up = MachineConfig::xy_plotter();
        up.axes[Axis::Z.index()].home_at_max = true;
        let mut h = HomingCycle::plan(&up, 0, all, z, false).unwrap();
        assert_eq!(first(&mut h, &up), ([0, 0, 6000, 0], Switches::Homing { axes: z }));
    }

    /// `G28 P1` (the carriage may stand over a drawing: the host's resume after a power cycle) refuses a Z never
    /// homed on the kit, whose pen touches 2 mm before its switch, where a plain `G28` seeks it (−6000 steps);
    /// a known Z is still kept (+1400 to the pen-up height), `G28 Z` still homes it, and a profile whose pen
    /// clears the paper at the switch homes it where the carriage stands.
    #[test]
    fn over_a_drawing_a_z_never_homed_is_refused_like_a_lost_one() {
        let mut c = MachineConfig::xy_plotter();
        let (z, all) = (Axis::Z.bit(), 0b111);
        let pos = [5000, 4000, 200, 0];
        let first = |h: &mut HomingCycle, c: &MachineConfig| match h.next(c, 0, 0, &pos) {
            HomingStep::Move(b, m) => (b.steps, m),
            other => panic!("{other:?}"),
        };
        let z_seek = ([0, 0, -6000, 0], Switches::Homing { axes: z });
        assert_eq!(HomingCycle::plan(&c, 0, 0, 0, true).unwrap_err(), ErrorCode::HomingWouldMark);
        assert_eq!(
            HomingCycle::plan(&c, 0, Axis::X.bit() | Axis::Y.bit(), 0, true).unwrap_err(),
            ErrorCode::HomingWouldMark
        );
        assert_eq!(first(&mut HomingCycle::plan(&c, 0, 0, 0, false).unwrap(), &c), z_seek);
        assert_eq!(first(&mut HomingCycle::plan(&c, 0, all, 0, true).unwrap(), &c), ([0, 0, 1400, 0], NO_STOP));
        assert_eq!(first(&mut HomingCycle::plan(&c, z, 0, 0, true).unwrap(), &c), z_seek);
        c.homing.pen_clear_at_z_switch = true;
        assert_eq!(first(&mut HomingCycle::plan(&c, 0, 0, 0, true).unwrap(), &c), z_seek);
    }

    #[test]
    fn not_found_alarm() {
        let c = MachineConfig::xy_plotter();
        let mut h = HomingCycle::new(&c, Axis::X.bit());
        let HomingStep::Move(b, _) = h.next(&c, 0, 0, &[0; NUM_AXES]) else { panic!() };
        assert_eq!(b.steps, [-50_400, 0, 0, 0]);
        assert_eq!(h.next(&c, 0, 0, &[0; NUM_AXES]), HomingStep::Alarm(AlarmCode::HomingNotFound));
    }
}
