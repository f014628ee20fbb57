//! Step-timer deadlines.
//!
//! [`plotter_fw::hal::StepTimer::schedule`] asks for an interrupt `ticks` after the *previous timer event* (or after
//! now, when the stepper was idle). Boards keep the absolute deadline of the last event and aim every new one at
//! `previous + ticks`, so interrupt latency never accumulates into the plot's timing: the step times are the
//! core's rounded absolute times exactly, as in the simulator.
//!
//! Times are the low 32 bits of the board's [`plotter_fw::TICK_HZ`] clock (a free-running 32-bit compare timer
//! counts exactly that), compared by wrapping differences: one subtraction, one add and one compare per event,
//! no 64-bit arithmetic in the step interrupt.
//!
//! A deadline that has already passed, or is closer than the board's *lead* (the interrupt ran late, e.g. behind
//! a long critical section), fires `lead` ticks after now, and the following events are measured from that late
//! one: the machine falls behind by the delay but never emits a burst of catch-up steps (a stepper motor may stall
//! on those), and the lead keeps a step pulse's low time (see the board's pulse timing) even then.

/// The deadline of the last scheduled step event, in [`plotter_fw::TICK_HZ`] ticks of the board's clock (low 32
/// bits). A late event fires `LEAD` ticks after now (a lead of 0 is 1); the lead is a constant of the board, an
/// immediate operand in the step interrupt.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Deadline<const LEAD: u32> {
    at: u32,
    running: bool,
}

impl<const LEAD: u32> Deadline<LEAD> {
    /// The lead, ticks (≥ 1).
    const LEAD: u32 = if LEAD == 0 { 1 } else { LEAD };

    /// Idle: the next [`Deadline::schedule`] counts from now.
    pub const fn new() -> Self {
        Deadline { at: 0, running: false }
    }

    /// The next event: `ticks` after the previous one (or after `now` when idle), never earlier than
    /// `now + lead`. Returns its absolute time (wrapping).
    #[inline(always)]
    pub fn schedule(&mut self, now: u32, ticks: u32) -> u32 {
        // From the previous event (the interrupt runs at or after it); from now when idle.
        if !self.running {
            self.at = now;
            self.running = true;
        }
        self.next(now, ticks)
    }

    /// [`Deadline::schedule`] while running (from the timer's interrupt): `ticks` after the previous event, never
    /// earlier than `now + lead` ([`Deadline::after`] the deadline kept here).
    #[inline(always)]
    pub fn next(&mut self, now: u32, ticks: u32) -> u32 {
        self.at = Self::after(self.at, now, ticks);
        self.at
    }

    /// The event `ticks` after the previous one at `prev`, never earlier than `now + lead`, for a board that keeps
    /// the previous deadline elsewhere (its compare register). `now` is at most `2³² − lead` ticks after `prev`
    /// (the interrupt runs at most 71 minutes late), so `elapsed + lead` does not wrap: a plain add, no saturation.
    #[inline(always)]
    pub fn after(prev: u32, now: u32, ticks: u32) -> u32 {
        let elapsed = now.wrapping_sub(prev);
        if ticks >= elapsed.wrapping_add(Self::LEAD) { prev.wrapping_add(ticks) } else { now.wrapping_add(Self::LEAD) }
    }

    /// The stepper went idle.
    pub fn cancel(&mut self) {
        self.running = false;
    }

    /// Whether an event is scheduled.
    pub fn is_running(&self) -> bool {
        self.running
    }

    /// Absolute time of the event last scheduled through this value ([`Deadline::schedule`], [`Deadline::next`]).
    pub fn at(&self) -> u32 {
        self.at
    }
}

impl<const LEAD: u32> Default for Deadline<LEAD> {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn events_follow_the_previous_deadline_not_the_interrupt_time() {
        let mut d = Deadline::<1>::new();
        // Idle: from now.
        assert_eq!(d.schedule(1_000, 40), 1_040);
        // The interrupt ran at 1_043 (3 ticks of latency): the next event still lands at 1_040 + 25.
        assert_eq!(d.schedule(1_043, 25), 1_065);
        assert_eq!(d.schedule(1_066, 30), 1_095);
        d.cancel();
        assert!(!d.is_running());
        // Idle again: counts from now.
        assert_eq!(d.schedule(5_000, 10), 5_010);
        assert_eq!(d.at(), 5_010);
    }

    #[test]
    fn a_late_deadline_fires_after_the_lead_without_a_burst() {
        let mut d = Deadline::<1>::new();
        assert_eq!(d.schedule(0, 10), 10);
        // Interrupt 100 ticks late: 10 + 10 = 20 is past; fire at once, then measure from there.
        assert_eq!(d.schedule(110, 10), 111);
        assert_eq!(d.schedule(111, 10), 121);
        // Exactly now is also past: an interrupt cannot be scheduled at the current tick.
        assert_eq!(d.schedule(131, 10), 132);
        // A lead of 5: 140 + 3 = 143 is closer than 141 + 5.
        let mut d = Deadline::<5>::new();
        assert_eq!(d.schedule(135, 5), 140);
        assert_eq!(d.schedule(141, 3), 146);
        // Exactly the lead away is in time.
        assert_eq!(d.schedule(147, 6), 152);
        // From idle, a delay below the lead is stretched to it.
        d.cancel();
        assert_eq!(d.schedule(200, 2), 205);
        assert_eq!(Deadline::<0>::new().schedule(7, 0), 8, "a lead of 0 is 1");
    }

    #[test]
    fn next_is_schedule_while_running() {
        let mut d = Deadline::<5>::new();
        assert_eq!(d.schedule(1_000, 40), 1_040);
        // From the interrupt (running): the previous deadline plus the interval, as `schedule` gives.
        assert_eq!(d.next(1_043, 25), 1_065);
        assert_eq!(d.next(1_066, 10), 1_075);
        // Late: 1_075 + 6 = 1_081 is closer than 1_077 + 5 = 1_082; an interval just the lead away is in time.
        assert_eq!(d.next(1_077, 6), 1_082);
        assert_eq!(d.next(1_082, 5), 1_087);
        assert!(d.is_running());
        // Across the clock's wrap.
        let mut d = Deadline::<1>::new();
        assert_eq!(d.schedule(u32::MAX - 2, 2), u32::MAX);
        assert_eq!(d.next(u32::MAX, 4), 3);
    }

    #[test]
    fn after_is_next_from_a_deadline_kept_elsewhere() {
        // As in `next_is_schedule_while_running`, with the previous deadline passed in.
        assert_eq!(Deadline::<5>::after(1_040, 1_043, 25), 1_065);
        assert_eq!(Deadline::<5>::after(1_075, 1_077, 6), 1_082);
        assert_eq!(Deadline::<5>::after(1_082, 1_082, 5), 1_087);
        assert_eq!(Deadline::<1>::after(u32::MAX, u32::MAX, 4), 3);
        assert_eq!(Deadline::<0>::after(7, 7, 0), 8, "a lead of 0 is 1");
    }

    #[test]
    fn the_32_bit_clock_wraps_between_events() {
        let mut d = Deadline::<1>::new();
        assert_eq!(d.schedule(u32::MAX - 5, 4), u32::MAX - 1);
        // The interrupt ran 2 ticks late, after the counter wrapped: 9 ticks after the deadline is 7.
        assert_eq!(d.schedule(0, 9), 7);
        // Late across the wrap: fires at now + 1.
        let mut d = Deadline::<1>::new();
        d.schedule(u32::MAX - 1, 1);
        assert_eq!(d.schedule(3, 2), 4);
        // A delay longer than half the counter is not mistaken for a late one.
        let mut d = Deadline::<1>::new();
        d.schedule(0, 10);
        assert_eq!(d.schedule(12, 3_000_000_000), 3_000_000_010);
    }
}
