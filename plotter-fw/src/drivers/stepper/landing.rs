//! A feed hold near a servo pen's drop commanded on the way (issue 39): the tip lands on the stroke's start, never
//! short of it.
//!
//! # The drop on the way
//! On our firmware the host plan commands a servo pen's drop while the carriage still travels: the travel to the
//! stroke is cut into a first part `A` that ends moving, the drop `S` (a 1-tick servo block) and the rest `B`,
//! which ends at rest on the stroke's first point no later than the tip can first touch the paper; a settle dwell
//! and the stroke `C` follow. Pushed after a move planned to end moving, `S` is *flying* ([`Queued::flying`]); the
//! move pushed right after it *lands* ([`Queued::lands`]). Both are flags computed when the blocks are pushed (main
//! context): the interrupt reads none of this.
//!
//! # A hold near the drop
//! A hold that slowed down across `S` into `B` (as a hold runs through a servo block the carriage enters moving)
//! would command the drop and stop inside `B`, short of the stroke: the tip would touch the paper there and, after
//! the resume, ink the rest of `B`. So:
//! - **The pen is landing** (the hold is requested while `S` or `B` runs, i.e. the drop has been commanded): `B` is
//!   not re-timed. It runs as planned — it already ends at rest on the stroke's start, within the time the tip
//!   takes to touch — and the hold stops at its end, before the settle dwell ([`Stepper::lands_now`]). When `B` does
//!   not end at rest (no plan of ours makes one), the hold runs through `S` into `B` as before.
//! - **The drop is still queued** when the hold's deceleration reaches it: the drop is deferred. `S` and `B` swap
//!   places in the ring ([`Stepper::defer_drop`]), `B` is re-timed as the hold's continuation (it stops within `B`:
//!   its planned profile already reaches rest at the same acceleration) and `S` waits `1 +` `B`'s planned
//!   duration, what it had from its command to the end of `B`, so that with the settle dwell the pen still has the
//!   plan's whole time from the command to the stroke's first step. After the resume the rest of `B` runs from rest
//!   to rest, the drop with its full settle, then `C`: the tip lands on the stroke's start. The same swap is made
//!   when `B` is pushed while the hold decelerates through a queued `S` ([`Stepper::hold_pushed`]), and by a
//!   resume that finds `S` and `B` queued behind a stop ([`Stepper::defer_queued_drops`]: everything queued then
//!   restarts from rest, so `B` would take longer than planned after the drop), and when `S` and `B` are pushed
//!   after a resume that made the move before `S` end at rest (a hold during the lift: `B` then starts slower than
//!   planned, [`Stepper::slowed_landing_pushed`]).
//! - A drop the hold delays while the lift before it still swings (a short hop) waits for the modelled servo
//!   when deferred (`servo.rs`).
//! - `B` is never missing when it matters: the motion queue hands `B` to the stepper together with `S`
//!   ([`Stepper::awaits_landing_move`]), which the 1-tick `S` needs anyway (it ends one tick after it starts). Only
//!   when the host has not sent `B` yet does a hold through `S` keep the old run-through: once `S` has started,
//!   its command is out, and `B`, pushed then, is re-timed from the rate the hold carries.
//!
//! A hold anywhere else behaves exactly as before.

use super::{Carry, Queued, SLOT_MASK, STEPPER_QUEUE, Stepper, continue_hold, nth_after};
use crate::step_block::StepBlock;

impl Stepper {
    /// The ring slot of the `i`th queued block.
    fn queued_slot(&self, i: usize) -> usize {
        nth_after(self.first, i) & SLOT_MASK
    }

    /// Whether the last queued block is a pen drop commanded on the way whose landing move is not queued yet, with
    /// room for it: the motion queue hands that move over at once (main context), so that the 1-tick drop never
    /// ends the stepper's queue and a feed hold that reaches the drop can defer it past the move.
    pub fn awaits_landing_move(&self) -> bool {
        self.queued > 0 && self.queued < STEPPER_QUEUE && self.ring[self.queued_slot(self.queued - 1)].flying
    }

    /// The landing flags of `block`, pushed now: whether it is a flying servo block (after a move planned to end
    /// moving) and whether it is the move that lands after one ([`Queued::flying`], [`Queued::lands`]).
    pub(super) fn pushed_after(&self, block: &StepBlock) -> (bool, bool) {
        let prev = if self.queued > 0 {
            Some(&self.ring[self.queued_slot(self.queued - 1)])
        } else if self.act.live {
            Some(&self.ring[self.act.slot & SLOT_MASK])
        } else {
            None
        };
        let flying = block.servo.is_some() && block.is_dwell() && prev.is_some_and(|p| p.exits_moving);
        let lands = !block.is_dwell() && prev.is_some_and(|p| p.flying);
        (flying, lands)
    }

    /// A hold requested while the pen is landing (the executing block is a flying drop followed by its landing
    /// move, or that move): the move runs as planned and the hold stops at its end. Returns whether it was so.
    pub(super) fn lands_now(&mut self) -> bool {
        let act = &self.ring[self.act.slot & SLOT_MASK];
        if as_planned(act) {
            // Its end is the hold's stop: the block after it is no hold continuation.
            return true;
        }
        if act.flying && self.queued > 0 {
            let first = self.queued_slot(0);
            if as_planned(&self.ring[first]) {
                self.ring[first].hold = true;
                return true;
            }
        }
        false
    }

    /// The block just pushed (the last queued) while the hold decelerates: continue the hold into it, deferring a
    /// drop the hold runs through to after it, or let it land as planned behind a drop already commanded.
    pub(super) fn hold_pushed(&mut self) {
        let i = self.queued - 1;
        let new = &self.ring[self.queued_slot(i)];
        if i == 0 {
            let drop_commanded = self.act.live && self.ring[self.act.slot & SLOT_MASK].flying;
            if self.carry.is_none() && drop_commanded && as_planned(new) {
                // The hold came during the drop, before this move was there.
                self.ring[self.queued_slot(0)].hold = true;
                return;
            }
            self.carry = self.hold_through(0, self.carry);
            return;
        }
        let prev = &self.ring[self.queued_slot(i - 1)];
        // The hold ran through a queued drop (its carry is the one into the drop): take it up again there.
        let from = if prev.flying && prev.hold && new.lands { i - 1 } else { i };
        self.carry = self.hold_through(from, self.carry);
    }

    /// Carry a decelerating hold through the queued blocks from the `from`th on ([`continue_hold`]); a flying drop
    /// it would run through is deferred past its landing move first. Returns the rate carried out of the last.
    pub(super) fn hold_through(&mut self, from: usize, mut carry: Option<Carry>) -> Option<Carry> {
        for i in from..self.queued {
            let c = carry?;
            let q = &self.ring[self.queued_slot(i)];
            if q.flying && runs_through(&c, q) && i + 1 < self.queued && self.ring[self.queued_slot(i + 1)].lands {
                self.defer_drop(i);
            }
            carry = continue_hold(c, &mut self.ring[self.queued_slot(i)]);
        }
        carry
    }

    /// Swap the `i`th queued block (a flying drop) with its landing move after it: the drop waits `1 +` the move's
    /// planned duration, what it had from its command to the move's end, or the servo's swing when it was
    /// commanded in the lift's swing ([`Queued::swing_wait`], `servo.rs`), whichever is longer.
    pub(super) fn defer_drop(&mut self, i: usize) {
        let (s_slot, b_slot) = (self.queued_slot(i), self.queued_slot(i + 1));
        let mut s = self.ring[s_slot];
        let mut b = self.ring[b_slot];
        let planned = s.duration_ticks().saturating_add(b.duration_ticks());
        s.block.dwell_ticks = planned.max(s.swing_wait);
        // Commanded at rest now, at the end of the move.
        s.flying = false;
        s.hold = false;
        s.prepare();
        b.lands = false;
        self.ring[s_slot] = b;
        self.ring[b_slot] = s;
    }

    /// The landing move just pushed (the last queued, no hold under way) starts slower than planned (a resume's
    /// shortfall, `catch_up.rs`: the move before the drop was made to end at rest): with the drop still queued, it
    /// is deferred behind the move, which would take longer than planned after the command.
    pub(super) fn slowed_landing_pushed(&mut self) {
        if self.queued >= 2 && self.ring[self.queued_slot(self.queued - 2)].flying {
            self.defer_drop(self.queued - 2);
        }
    }

    /// At a resume, before everything queued is re-profiled from rest: defer each queued drop whose landing move is
    /// queued after it (that move now runs from rest, longer than the drop's planned time to the touch).
    pub(super) fn defer_queued_drops(&mut self) {
        for i in 0..self.queued.saturating_sub(1) {
            if self.ring[self.queued_slot(i)].flying && self.ring[self.queued_slot(i + 1)].lands {
                self.defer_drop(i);
            }
        }
    }
}

/// A landing move that ends at rest, not re-timed by a hold: it runs as planned and a hold stops at its end.
fn as_planned(q: &Queued) -> bool {
    q.lands && q.block.exit_rate == 0 && !q.hold
}

/// Whether a hold carrying `carry` runs through the queued `q` without re-timing it: a servo block the carriage
/// enters moving (a drop commanded on the way), which keeps the rate.
pub(super) fn runs_through(carry: &Carry, q: &Queued) -> bool {
    q.block.servo.is_some() && q.block.is_dwell() && carry.v_sq > 0.0 && carry.planned_exit > 0
}

#[cfg(test)]
mod tests {
    use super::super::{Stepper, test_move};
    use crate::axis::Axis;
    use crate::config::{MachineConfig, PenConfig};
    use crate::hal::{Endstops, StepPins};
    use crate::step_block::{StepBlock, Switches};
    use std::vec::Vec;

    /// The carriage's XY position after each step event and at each servo command, with their times.
    #[derive(Default)]
    struct Trace {
        now: u64,
        pos: [i64; 2],
        dir: [bool; 2],
        steps: Vec<(u64, [i64; 2])>,
        servo: Vec<(u64, [i64; 2])>,
        counts: [u64; 2],
    }
    impl StepPins for Trace {
        fn set_dir(&mut self, axis: Axis, level: bool) {
            if let Some(d) = self.dir.get_mut(axis.index()) {
                *d = level;
            }
        }
        fn step(&mut self, axis: Axis) {
            let i = axis.index();
            if i < 2 {
                self.pos[i] += if self.dir[i] { -1 } else { 1 };
                self.counts[i] += 1;
            }
        }
        fn step_axes(&mut self, mask: u8) {
            for axis in Axis::ALL {
                if mask & axis.bit() != 0 {
                    self.step(axis);
                }
            }
            self.steps.push((self.now, self.pos));
        }
        fn enable_motors(&mut self, _on: bool) {}
        fn set_servo(&mut self, _angle_deg: f32) {
            self.servo.push((self.now, self.pos));
        }
    }
    impl Endstops for Trace {
        fn pressed(&mut self) -> u8 {
            0
        }
    }

    /// A servo pen's hop cut for a drop on the way, then its stroke, in events of 1000/s at 5000/s²: the travel
    /// [700, 175] from rest to rest (100 events up to 1000/s in 0.2 s, 500 cruising in 0.5 s, 100 down in 0.2 s)
    /// cut after 600 events into A (0.7 s, ending at 1000/s) and B (100 events from 1000/s to rest: 0.2 s), the
    /// drop S (1 tick) between them, a 0.1 s settle dwell and the stroke C, [0, 300] from rest to rest (0.5 s). The
    /// stroke starts at [700, 175]; a step with y > 175 is the stroke's.
    fn blocks() -> [StepBlock; 5] {
        let mv = |steps, entry, exit| test_move(steps, entry, 1000, exit, 5000);
        [
            mv([600, 150], 0, 1000),
            StepBlock::servo(300, 1),
            mv([100, 25], 1000, 0),
            StepBlock::dwell(100_000),
            mv([0, 300], 0, 0),
        ]
    }

    const A_END: [i64; 2] = [600, 150];
    const B_END: [i64; 2] = [700, 175];
    const SETTLE: u64 = 100_000;
    /// How long the hold stays stopped before the resume.
    const PAUSE: u64 = 300_000;

    /// Plays [`blocks`] as the machine's motion queue does (a block handed over whenever fewer than two are held or
    /// the last is a drop awaiting its landing move; B `late` by one step event after the hold when given), a feed
    /// hold requested after `hold_after` timer events, resumed [`PAUSE`] after it stopped.
    fn play(hold_after: Option<u32>, late: bool) -> Trace {
        play_blocks(&blocks(), None, hold_after, late.then_some(2))
    }

    /// [`play`] for `blocks` on a stepper modelling `pen`'s servo (when given), the block at index `late` (when
    /// given) handed over only one step event after the hold.
    fn play_blocks(
        blocks: &[StepBlock],
        pen: Option<PenConfig>,
        hold_after: Option<u32>,
        late: Option<usize>,
    ) -> Trace {
        let mut s = Stepper::new(0, 0);
        if let Some(pen) = pen {
            s.model_servo(&pen);
        }
        let mut hal = Trace::default();
        let mut next = 0;
        let mut events = 0u32;
        let mut due: Option<u64> = None;
        loop {
            let b_arrived = late.is_none() || hold_after.is_some_and(|h| events > h);
            while next < blocks.len()
                && (s.pending() < 2 || s.awaits_landing_move())
                && (Some(next) != late || b_arrived)
                && s.has_room()
            {
                s.push(blocks[next], Switches::Limits).unwrap();
                next += 1;
            }
            if let Some(at) = due {
                hal.now = at;
                due = s.tick(&mut hal).map(|iv| at + u64::from(iv));
                events += 1;
                if Some(events) == hold_after {
                    s.feed_hold();
                }
                continue;
            }
            if s.is_held() {
                hal.now += PAUSE;
                due = s.resume(&mut hal).map(|iv| hal.now + u64::from(iv));
            } else if s.is_idle() && next == blocks.len() {
                return hal;
            } else {
                due = s.start(&mut hal).map(|iv| hal.now + u64::from(iv));
                assert!(due.is_some() || next < blocks.len(), "stuck after {events} events");
            }
        }
    }

    /// Checks a played trace; returns the drop command's time and place.
    fn check(hal: &Trace, what: &str) -> (u64, [i64; 2]) {
        let [_, _, b, ..] = blocks();
        // B as planned: from 1000/s to rest at 5000/s², 0.2 s (to the ramp's accuracy, 1 tick + 0.025 %).
        let dur_b = u64::from(b.duration_ticks());
        assert!(dur_b.abs_diff(200_000) <= 51, "{dur_b}");
        assert_eq!(hal.servo.len(), 1, "{what}: one drop command");
        let (t_cmd, at) = hal.servo[0];
        // (a) The drop is commanded where planned (the end of A) or, deferred, on the stroke's start.
        assert!(at == A_END || at == B_END, "{what}: the drop was commanded at {at:?}");
        // (b) After the command, only B's rest towards the stroke's start, done by the planned contact time; the
        // stroke no sooner than the whole planned wait.
        let contact = t_cmd + 1 + dur_b;
        for &(t, p) in hal.steps.iter().filter(|s| s.0 > t_cmd) {
            if p[1] <= B_END[1] {
                assert!(p[0] >= A_END[0] && p[0] <= B_END[0] && p[1] >= A_END[1], "{what}: off B's path at {p:?}");
                assert!(t <= contact, "{what}: B's step to {p:?} at {t}, after the contact time {contact}");
            } else {
                assert!(t >= contact + SETTLE, "{what}: the stroke started at {t}, before {}", contact + SETTLE);
            }
        }
        // (c) Every step made, once: 700 + 0 along X, 175 + 300 along Y.
        assert_eq!((hal.pos, hal.counts), ([700, 475], [700, 475]), "{what}");
        (t_cmd, at)
    }

    #[test]
    fn without_a_hold_the_drop_is_commanded_on_the_way() {
        // A takes 0.7 s: the drop at 700 000 ticks, at A's end, moving; the stroke's first step after the drop's
        // tick, B (0.2 s), the settle (0.1 s) and C's first step from rest, √(2/5000) s = 20 000 ticks.
        let hal = play(None, false);
        let (t_cmd, at) = check(&hal, "no hold");
        let [a, _, b, ..] = blocks();
        assert_eq!((t_cmd, at), (u64::from(a.duration_ticks()), A_END));
        assert!(t_cmd.abs_diff(700_000) <= 1 + 100, "{t_cmd}");
        let first_c = hal.steps.iter().find(|s| s.1[1] > B_END[1]).unwrap().0;
        assert_eq!(first_c, t_cmd + 1 + u64::from(b.duration_ticks()) + SETTLE + 20_000);
    }

    #[test]
    fn a_hold_near_a_drop_on_the_way_lands_the_pen_on_the_stroke() {
        // A hold after each event from 300 ms before the drop (A's events 300..=600 at 1000/s; after event 600 the
        // drop runs) through B (events 601..=701; 601 ends the 1-tick drop). From 1000/s a hold needs 99 more
        // events (v² − 2aj > 0 for j < 100): one after event 500 or earlier stops within A; a later one would run
        // through the drop into B and stop inside it, short of the stroke (the drop commanded: the tip touching
        // there, the rest of B inked after the resume). Now the drop waits behind B, and a hold once the drop is
        // out lets B land as planned.
        let (mut deferred, mut landed) = (0, 0);
        for k in 300..=701 {
            let hal = play(Some(k), false);
            let (_, at) = check(&hal, &std::format!("hold after event {k}"));
            if at == B_END {
                deferred += 1;
            } else {
                landed += 1;
            }
            // A hold the drop's command has gone out before lets B land as planned: it stops at B's end.
            if k >= 600 {
                assert_eq!(at, A_END, "hold after event {k}");
            }
        }
        // Holds after events 300..=599 defer the drop (a stop within A restarts B from rest: longer than planned),
        // 600..=701 leave it where planned.
        assert_eq!((deferred, landed), (300, 102));
    }

    #[test]
    fn a_landing_move_pushed_while_the_hold_decelerates_defers_the_drop() {
        // B arrives one event after the hold was requested, with the drop still queued: the hold reaches the drop
        // (hold after event 501 and later), B takes its place and the drop is commanded on the stroke's start.
        for k in 501..=598 {
            let hal = play(Some(k), true);
            let (_, at) = check(&hal, &std::format!("B late, hold after event {k}"));
            assert_eq!(at, B_END, "hold after event {k}");
        }
    }

    /// A short hop after a stroke, in events of 1000/s at 50 000/s², on a servo that swings 90° ↔ 30° in 150 ms
    /// (0.4°/ms): the pen down (a 1-tick servo block, the stroke before), the lift `L` to 90° with `lift` ticks for
    /// the tip to clear, the travel's first part A, [60, 15] from rest to 1000/s (10 events in 20 ms, then 50 at
    /// 1000/s: 70 ms), the drop S to 30° (1 tick), the rest B, [20, 5] from 1000/s to rest (10 events at 1000/s, 10
    /// down in 20 ms: 30 ms), a [`HOP_SETTLE`] dwell and the stroke C, [0, 30] from rest to rest. C starts at
    /// [`HOP_END`]; a step with y > 20 is the stroke's.
    fn hop(lift: u32) -> [StepBlock; 7] {
        let mv = |steps, entry, exit| test_move(steps, entry, 1000, exit, 50_000);
        [
            StepBlock::servo(300, 1),
            StepBlock::servo(900, lift),
            mv([60, 15], 0, 1000),
            StepBlock::servo(300, 1),
            mv([20, 5], 1000, 0),
            StepBlock::dwell(HOP_SETTLE_TICKS),
            mv([0, 30], 0, 0),
        ]
    }

    /// Where [`hop`]'s A ends and the drop is planned.
    const HOP_A_END: [i64; 2] = [60, 15];
    /// Where B ends: the stroke's start.
    const HOP_END: [i64; 2] = [80, 20];
    /// The settle dwell after B, ticks.
    const HOP_SETTLE_TICKS: u32 = 40_000;
    const HOP_SETTLE: u64 = HOP_SETTLE_TICKS as u64;

    /// The kit's servo: 90° up, 30° down, the swing in 150 ms.
    fn kit_pen() -> PenConfig {
        PenConfig { servo_swing_ms: 150.0, ..MachineConfig::xy_plotter().pen }
    }

    /// Checks a played [`hop`]: every step once, B's path before the drop's command, the stroke after it. Returns
    /// the drop command's time and place (the pen-down and the lift commands before it at 0 and 1), and the time of
    /// C's first step.
    fn check_hop(hal: &Trace, what: &str) -> (u64, [i64; 2], u64) {
        assert_eq!(hal.servo.len(), 3, "{what}: three servo commands");
        assert_eq!(hal.servo[..2], [(0, [0, 0]), (1, [0, 0])], "{what}: the pen down, then the lift");
        let (t_cmd, at) = hal.servo[2];
        assert!(at == HOP_A_END || at == HOP_END, "{what}: the drop was commanded at {at:?}");
        let first_c = hal.steps.iter().find(|s| s.1[1] > HOP_END[1]).unwrap().0;
        // Nothing but B's path to the stroke's start before C.
        for &(t, p) in hal.steps.iter().filter(|s| s.1[1] <= HOP_END[1]) {
            assert!(t < first_c && p[0] <= HOP_END[0], "{what}: a step to {p:?} at {t}");
        }
        // Every step made, once: 80 along X, 20 + 30 along Y.
        assert_eq!((hal.pos, hal.counts), ([80, 50], [80, 50]), "{what}");
        (t_cmd, at, first_c)
    }

    /// C's first step from rest at 50 000/s²: √(2 / 50 000) s = 6325 ticks (6324.6 rounded up by the step times).
    fn c_first_interval() -> u64 {
        let [.., c] = hop(1);
        let mut s = Stepper::new(0, 0);
        s.push(c, Switches::Limits).unwrap();
        let first = u64::from(s.start(&mut Trace::default()).unwrap());
        assert!(first.abs_diff(6325) <= 1, "{first}");
        first
    }

    #[test]
    fn without_a_hold_the_servo_model_changes_no_timing() {
        // The lift at tick 1, A's 70 ms after the 45 ms clear: the drop at 1 + 45 000 + A's duration, where A ends;
        // the stroke after B, the settle and C's first interval; the same trace with the servo modelled or not.
        let blocks = hop(45_000);
        let hal = play_blocks(&blocks, Some(kit_pen()), None, None);
        let (t_cmd, at, first_c) = check_hop(&hal, "no hold");
        let (a, b) = (u64::from(blocks[2].duration_ticks()), u64::from(blocks[4].duration_ticks()));
        assert!(a.abs_diff(70_000) <= 20 && b.abs_diff(30_000) <= 20, "{a} {b}");
        assert_eq!((t_cmd, at), (1 + 45_000 + a, HOP_A_END));
        assert_eq!(first_c, t_cmd + 1 + b + HOP_SETTLE + c_first_interval());
        let plain = play_blocks(&blocks, None, None, None);
        assert_eq!((hal.steps, hal.servo), (plain.steps, plain.servo));
    }

    #[test]
    fn a_hold_between_a_lift_and_a_drop_in_its_swing_keeps_the_carriage_at_the_stroke_until_the_servo_is_down() {
        // The drop is planned 45 000 + 70 000 = 115 000 ticks after the lift, with the servo at 30° + 0.4°/ms ×
        // 115 ms = 76°, still rising: its contact comes soon. A hold after event k (1: the pen-down's end, the lift
        // running; 2..=61: A's events 0..=59 out; 62: A done, the drop out) before the drop stops the carriage and
        // the servo goes on up: after the [`PAUSE`] (300 ms, longer than the 150 ms swing) it is at 90°. The drop,
        // deferred behind B, is commanded on the stroke's start and C's first step comes only when the modelled
        // servo is back down, the whole swing (150 000 ticks) later, then the settle and C's first interval. A hold
        // once the drop is out (k = 62) lets B land as planned: the servo is where the plan has it.
        let blocks = hop(45_000);
        let b = u64::from(blocks[4].duration_ticks());
        let c_first = c_first_interval();
        let mut deferred = 0;
        for k in 1..=62 {
            let what = std::format!("hold after event {k}");
            let hal = play_blocks(&blocks, Some(kit_pen()), Some(k), None);
            let (t_cmd, at, first_c) = check_hop(&hal, &what);
            if k == 62 {
                assert_eq!(at, HOP_A_END, "{what}");
                assert_eq!(first_c, t_cmd + 1 + b + PAUSE + HOP_SETTLE + c_first, "{what}");
                continue;
            }
            assert_eq!(at, HOP_END, "{what}: the drop deferred to the stroke's start");
            // The modelled servo: from 30° at the lift's command (tick 1), up at 90° by 150 001; still there at the
            // command, which follows the pause.
            assert!(t_cmd >= 1 + 150_000 + PAUSE, "{what}: the drop at {t_cmd}");
            assert_eq!(first_c, t_cmd + 150_000 + HOP_SETTLE + c_first, "{what}: C at {first_c}, drop at {t_cmd}");
            deferred += 1;
        }
        assert_eq!(deferred, 61);
        // The landing move handed over late (after the hold, while it decelerates) defers the drop the same way.
        for k in 45..=60 {
            let what = std::format!("B late, hold after event {k}");
            let (t_cmd, at, first_c) = check_hop(&play_blocks(&blocks, Some(kit_pen()), Some(k), Some(4)), &what);
            assert_eq!(at, HOP_END, "{what}");
            assert_eq!(first_c, t_cmd + 150_000 + HOP_SETTLE + c_first, "{what}");
        }
    }

    #[test]
    fn a_hold_after_the_lift_has_swung_up_keeps_the_plans_wait() {
        // The lift given 80 000 ticks to clear: the drop planned 80 000 + 70 000 = 150 000 ticks after it, with the
        // servo up. A hold in A (after events 2..=61) defers the drop as without the model, waiting 1 + B's planned
        // time, what it had from its command to B's end; a hold during the lift too (after event 1), which stops at
        // the lift's end, A then ending at rest: B, pushed after the resume, starts from rest (10 events up, 10
        // down: 40 ms) and would end after the planned contact behind a drop commanded on the way, so the drop
        // waits behind it, 1 + B's time as pushed.
        let blocks = hop(80_000);
        let b = u64::from(blocks[4].duration_ticks());
        let b_from_rest = u64::from(StepBlock { entry_rate: 0, ..blocks[4] }.duration_ticks());
        assert!(b_from_rest.abs_diff(40_000) <= 20, "{b_from_rest}");
        let c_first = c_first_interval();
        for k in 1..=61 {
            let what = std::format!("hold after event {k}");
            let hal = play_blocks(&blocks, Some(kit_pen()), Some(k), None);
            let (t_cmd, at, first_c) = check_hop(&hal, &what);
            assert_eq!(at, HOP_END, "{what}: the drop deferred to the stroke's start");
            let b = if k == 1 { b_from_rest } else { b };
            assert_eq!(first_c, t_cmd + 1 + b + HOP_SETTLE + c_first, "{what}: C at {first_c}, drop at {t_cmd}");
            if k > 1 {
                let plain = play_blocks(&blocks, None, Some(k), None);
                assert_eq!((&hal.steps, &hal.servo), (&plain.steps, &plain.servo), "{what}: as without the model");
            }
        }
    }
}
