//! The servo pen's modelled angle (issue 39): a drop delayed by a feed hold while the lift before it still swings.
//!
//! A servo pen's hop on our firmware is a lift `L` (a servo block), the travel's first part `A`, the drop `S`
//! commanded on the way, the rest `B`, a settle dwell and the stroke (`landing.rs`). For a short hop the plan
//! commands `S` before `L`'s swing has ended: it knows the servo is only part way up, so the tip touches soon after
//! `S`. A feed hold between `L` and `S` stops the carriage while the servo goes on rising; the drop, deferred behind
//! `B` by the landing logic, then starts higher than the plan assumed and the tip touches later than the time
//! the drop was given, after the stroke has begun.
//!
//! So the stepper models the servo as the pushed blocks command it, on the plan's timeline (main context, at each
//! push; the interrupt reads none of it): the last servo command's target, the angle it started from, the planned
//! ticks since it, and the configured rate ([`ServoModel::new`]: the full up↔down swing in
//! `PenConfig::servo_swing_ms`). A servo block pushed while the previous command's swing is still under way at
//! its planned command time is commanded *in the swing*: any delay of it lets the servo move on. Such a drop gets
//! a wait ([`Queued::swing_wait`]): the swing from the previous command's target (where the servo may have got to
//! during the hold) to its own, at the rate. When the drop is deferred behind its landing move
//! ([`Stepper::defer_drop`]) it waits the longer of that swing and the plan's own time to the move's end, so the
//! carriage stands at the stroke's start until the modelled servo is down (the firmware does not know where the
//! tip meets the paper: the whole swing is the cautious choice); the planned settle and the stroke follow. The
//! servo's angle when the deferred drop is commanded depends on how long the hold stood, which is not known when
//! the drop is deferred (the hold is still decelerating); the previous target is the farthest it can be, so the
//! wait is never short, and it is at most one swing longer than needed, only after a hold.
//!
//! A drop whose lift's swing ended before its planned command has no wait: the hold finds the servo where the plan
//! has it, and the landing logic re-times the drop as before. Without a hold nothing here changes any timing.
//!
//! [`Queued::swing_wait`]: super::Queued::swing_wait
//! [`Stepper::defer_drop`]: super::Stepper::defer_drop

use crate::step_block::StepBlock;

/// The servo's modelled angle on the plan's timeline, in tenths of a degree as the blocks carry it.
#[derive(Debug, Clone, Copy)]
pub(super) struct ServoModel {
    /// Ticks the servo takes per tenth of a degree of swing.
    ticks_per_tenth: f32,
    /// The last servo command pushed: the angle it started from and its target; `None` before the first.
    last: Option<(f32, f32)>,
    /// Planned ticks from that command to the end of the last block pushed.
    since: u64,
}

impl ServoModel {
    /// A servo that swings between `up_deg` and `down_deg` in `swing_ms`; `None` when that gives no rate (equal
    /// angles, or a time that is not a positive number).
    pub(super) fn new(up_deg: f32, down_deg: f32, swing_ms: f32) -> Option<Self> {
        let tenths = (up_deg - down_deg).abs() * 10.0;
        #[allow(clippy::cast_precision_loss, reason = "TICK_HZ / 1000 = 1000, exact in f32")]
        let ticks = swing_ms * (crate::step_block::TICK_HZ / 1000) as f32;
        let ticks_per_tenth = ticks / tenths;
        (ticks_per_tenth.is_finite() && ticks_per_tenth > 0.0).then_some(ServoModel {
            ticks_per_tenth,
            last: None,
            since: 0,
        })
    }

    /// Forget the servo's state (the queue was dropped: what was commanded last is no longer known).
    pub(super) fn forget(&mut self) {
        self.last = None;
        self.since = 0;
    }

    /// Ticks the servo takes to turn from `a` to `b` (tenths of a degree), rounded.
    fn swing_ticks(&self, a: f32, b: f32) -> u32 {
        crate::fmath::round_u32((a - b).abs() * self.ticks_per_tenth)
    }

    /// `block` is pushed (main context), planned to take `ticks`: follow its servo command, if any. Returns the
    /// wait of a servo block commanded while the previous command's swing is still under way at its planned time
    /// (the swing from that command's target to this one's; see the module doc), else 0.
    pub(super) fn pushed(&mut self, block: &StepBlock, ticks: u32) -> u32 {
        let mut wait = 0;
        if let Some(tenths) = block.servo {
            let target = f32::from(tenths);
            let at = match self.last {
                None => target,
                Some((from, to)) => {
                    let swing = self.swing_ticks(from, to);
                    if u64::from(swing) > self.since {
                        // Still swinging at this command: part way from `from` to `to`.
                        wait = self.swing_ticks(to, target);
                        #[allow(clippy::cast_precision_loss, reason = "since < swing < 2^32: f32 is close enough")]
                        let moved = self.since as f32 / self.ticks_per_tenth;
                        if to > from { from + moved } else { from - moved }
                    } else {
                        to
                    }
                }
            };
            self.last = Some((at, target));
            self.since = 0;
        }
        self.since = self.since.saturating_add(u64::from(ticks));
        wait
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 90° ↔ 30° in 150 ms: 600 tenths in 150 000 ticks, 250 ticks per tenth.
    fn kit() -> ServoModel {
        ServoModel::new(90.0, 30.0, 150.0).unwrap()
    }

    #[test]
    fn a_drop_commanded_before_the_lift_has_swung_up_waits_the_whole_swing_down() {
        let mut s = kit();
        // The first command: its starting angle is unknown, taken as reached.
        assert_eq!(s.pushed(&StepBlock::servo(300, 1), 1), 0);
        // The lift from 30° to 90° (150 000 ticks), then 115 000 ticks of clear dwell and travel: the drop finds
        // the servo at 30 + 115 000 / 250 / 10 = 76°, still rising; its wait is the swing from 90° to 30°.
        assert_eq!(s.pushed(&StepBlock::servo(900, 45_000), 45_000), 0);
        let travel = StepBlock { steps: [60, 0, 0, 0], ..StepBlock::dwell(0) };
        assert_eq!(s.pushed(&travel, 70_000), 0);
        assert_eq!(s.pushed(&StepBlock::servo(300, 1), 1), 150_000);
        assert!((s.last.unwrap().0 - 760.0).abs() < 1e-3, "{:?}", s.last);
        // To a brush pen's 25°: 650 tenths, 162 500 ticks.
        let mut s = kit();
        s.pushed(&StepBlock::servo(300, 1), 1);
        s.pushed(&StepBlock::servo(900, 149_999), 149_999);
        assert_eq!(s.pushed(&StepBlock::servo(250, 1), 1), 162_500);
    }

    #[test]
    fn a_drop_after_the_lift_has_swung_up_has_no_wait() {
        let mut s = kit();
        s.pushed(&StepBlock::servo(300, 1), 1);
        // Exactly one swing after the lift: up.
        s.pushed(&StepBlock::servo(900, 150_000), 150_000);
        assert_eq!(s.pushed(&StepBlock::servo(300, 1), 1), 0);
        // A drop before any command is known: no wait.
        assert_eq!(kit().pushed(&StepBlock::servo(300, 1), 1), 0);
    }

    #[test]
    fn no_rate_no_model() {
        assert!(ServoModel::new(90.0, 90.0, 150.0).is_none());
        assert!(ServoModel::new(90.0, 30.0, 0.0).is_none());
        assert!(ServoModel::new(90.0, 30.0, f32::NAN).is_none());
    }
}
