//! After a resume: the moves pushed next start from the speed the resumed ones end at, never faster.
//!
//! A resume restarts the interrupted block and everything queued from rest to rest ([`Stepper::resume`]). The host
//! keeps sending blocks planned for the uninterrupted plot (our step blocks carry their own junction rates and are
//! run as they come), so the next one may be planned to *enter* at speed after a block that now ends at rest: run as
//! sent, the carriage would jump from rest to that rate in one step (measured before this: 0 → 1900 events/s
//! between two consecutive steps on a straight line of 400-step blocks at 2000 events/s), which a real stepper
//! answers by losing steps.
//!
//! So the stepper remembers the shortfall: the rate the last block handed to it ends at and the rate it was
//! planned to end at ([`Stepper::note_resumed`]). Each move pushed while a shortfall stands is re-profiled
//! ([`Stepper::catch_up`]): its entry is the rate reached, converted into its own units by the ratio of the planned
//! junction rates (as a decelerating hold converts, `continue_hold`), and its exit the lower of its planned exit and
//! what its acceleration reaches over its length from that entry. Its cruise and acceleration stay, so it is never
//! faster than planned anywhere. The shortfall ends at the first move that reaches its planned exit, at a rest
//! point (a move planned to start from rest, a dwell) or at a block without acceleration; a servo block between two
//! moves (a pen drop commanded on the way) passes it on, as the carriage passes the block.
//!
//! All of it runs in main context when blocks are pushed; the step interrupt reads none of it.

use super::{Carry, Queued, SLOT_MASK, Stepper, nth_after};
use crate::fmath::sqrt;
use crate::step_block::StepBlock;

impl Stepper {
    /// Before a resume zeroes the queued blocks' junction rates: note what the last of them (or the interrupted
    /// block, when none is queued) was planned to end at, as the shortfall the next pushed block starts from.
    pub(super) fn note_resumed(&mut self) {
        let mut short = if self.act.live { rest_after(&self.ring[self.act.slot & SLOT_MASK], None) } else { None };
        for i in 0..self.queued {
            short = rest_after(&self.ring[nth_after(self.first, i) & SLOT_MASK], short);
        }
        self.shortfall = short;
    }

    /// `block`, pushed now, re-profiled to start from the rate the last block ends at after a resume (see the
    /// module doc); the shortfall goes on or ends with it.
    pub(super) fn catch_up(&mut self, mut block: StepBlock) -> StepBlock {
        let Some(s) = self.shortfall else { return block };
        if block.is_dwell() {
            // A servo block between two moves is passed moving; any other dwell is a stop.
            if block.servo.is_none() {
                self.shortfall = None;
            }
            return block;
        }
        if block.entry_rate == 0 || block.accel == 0 {
            self.shortfall = None;
            return block;
        }
        #[allow(clippy::cast_precision_loss, reason = "rates and events are below 2^24, exact in f32")]
        let (entry, exit, accel, n) =
            (block.entry_rate as f32, block.exit_rate as f32, block.accel as f32, block.events() as f32);
        let reached = s.rate_into(&block);
        if reached >= entry {
            self.shortfall = None;
            return block;
        }
        let reach_sq = reached * reached + 2.0 * accel * n;
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss, reason = "0 ≤ rates < 2^24: rounded down")]
        let floor = |v: f32| v as u32;
        block.entry_rate = floor(reached);
        let planned_exit = block.exit_rate;
        if reach_sq < exit * exit {
            block.exit_rate = floor(sqrt(reach_sq));
            #[allow(clippy::cast_precision_loss, reason = "rates are below 2^24, exact in f32")]
            let v = block.exit_rate as f32;
            self.shortfall = Some(Carry { v_sq: v * v, planned_exit });
        } else {
            self.shortfall = None;
        }
        block
    }
}

/// The shortfall after `q` once a resume has made every block end at rest: a move ends at rest short of its
/// planned exit; a servo block between moves passes the one before it on; any other dwell is a stop.
fn rest_after(q: &Queued, before: Option<Carry>) -> Option<Carry> {
    if q.block.is_dwell() {
        return if q.block.servo.is_some() { before } else { None };
    }
    (q.block.exit_rate > 0).then_some(Carry { v_sq: 0.0, planned_exit: q.block.exit_rate })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 50-event move along X at `entry → cruise → exit` events/s, 20 000 events/s².
    fn mv(entry: u32, exit: u32) -> StepBlock {
        super::super::test_move([50, 0], entry, 2000, exit, 20_000)
    }

    fn resumed(planned_exit: u32) -> Stepper {
        let mut s = Stepper::new(0, 0);
        s.shortfall = Some(Carry { v_sq: 0.0, planned_exit });
        s
    }

    #[test]
    fn a_move_after_a_resume_starts_from_rest_and_reaches_what_its_length_allows() {
        let mut s = resumed(2000);
        // From rest over 50 events at 20 000/s²: √(2 · 20 000 · 50) = 1414.2 events/s, short of the planned 2000.
        let b = s.catch_up(mv(2000, 2000));
        assert_eq!((b.entry_rate, b.cruise_rate, b.exit_rate), (0, 2000, 1414));
        // The next move was planned to enter at 1000 where this one left at 2000: it enters at 1414 · ½ = 707, and
        // √(707² + 2 · 20 000 · 50) = 1581.1 reaches its planned exit of 1000, which ends the shortfall.
        let b = s.catch_up(mv(1000, 1000));
        assert_eq!((b.entry_rate, b.exit_rate), (707, 1000));
        assert!(s.shortfall.is_none());
        // From then on the host's blocks run as planned.
        assert_eq!(s.catch_up(mv(1000, 500)), mv(1000, 500));
    }

    #[test]
    fn a_servo_block_between_moves_passes_the_shortfall_on_and_any_other_dwell_ends_it() {
        let mut s = resumed(2000);
        assert_eq!(s.catch_up(StepBlock::servo(300, 1)), StepBlock::servo(300, 1));
        assert_eq!(s.catch_up(mv(2000, 0)).entry_rate, 0, "passed on through the servo block");
        let mut s = resumed(2000);
        assert_eq!(s.catch_up(StepBlock::dwell(1000)), StepBlock::dwell(1000));
        assert_eq!(s.catch_up(mv(2000, 0)), mv(2000, 0), "a dwell is a stop: the plan starts from rest there");
        // A move planned from rest ends it too.
        let mut s = resumed(2000);
        assert_eq!(s.catch_up(mv(0, 2000)), mv(0, 2000));
        assert!(s.shortfall.is_none());
    }
}
