//! Step-timer deadlines.
//!
//! [`plotter_fw::hal::StepTimer::schedule`] asks for an interrupt `ticks` after the *previous timer event* (or after
//! now, when the stepper was idle). Boards keep the absolute deadline of the last event and aim every new one at
//! `previous + ticks`, so interrupt latency never accumulates into the plot's timing: the step times are the
//! core's rounded absolute times exactly, as in the simulator.
//!
//! A deadline that has already passed (the interrupt ran late, e.g. behind a long critical section) fires at the
//! next tick, and the following events are measured from that late one: the machine falls behind by the delay but
//! never emits a burst of catch-up steps (a stepper motor may stall on those).

/// The deadline of the last scheduled step event, in [`plotter_fw::TICK_HZ`] ticks of the board's clock.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Deadline {
    at: u64,
    running: bool,
}

impl Deadline {
    /// Idle: the next [`Deadline::schedule`] counts from now.
    pub const fn new() -> Self {
        Deadline { at: 0, running: false }
    }

    /// The next event: `ticks` after the previous one (or after `now` when idle), never earlier than `now + 1`.
    /// Returns its absolute time.
    pub fn schedule(&mut self, now: u64, ticks: u32) -> u64 {
        let base = if self.running { self.at } else { now };
        let mut at = base + u64::from(ticks);
        if at <= now {
            at = now + 1;
        }
        self.at = at;
        self.running = true;
        at
    }

    /// The stepper went idle.
    pub fn cancel(&mut self) {
        self.running = false;
    }

    /// Whether an event is scheduled.
    pub fn is_running(&self) -> bool {
        self.running
    }

    /// Absolute time of the scheduled (or last) event.
    pub fn at(&self) -> u64 {
        self.at
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn events_follow_the_previous_deadline_not_the_interrupt_time() {
        let mut d = Deadline::new();
        // Idle: from now.
        assert_eq!(d.schedule(1_000, 40), 1_040);
        // The interrupt ran at 1_043 (3 ticks of latency): the next event still lands at 1_040 + 25.
        assert_eq!(d.schedule(1_043, 25), 1_065);
        assert_eq!(d.schedule(1_066, 30), 1_095);
        d.cancel();
        assert!(!d.is_running());
        // Idle again: counts from now.
        assert_eq!(d.schedule(5_000, 10), 5_010);
    }

    #[test]
    fn a_late_deadline_fires_next_tick_without_a_burst() {
        let mut d = Deadline::new();
        assert_eq!(d.schedule(0, 10), 10);
        // Interrupt 100 ticks late: 10 + 10 = 20 is past; fire at once, then measure from there.
        assert_eq!(d.schedule(110, 10), 111);
        assert_eq!(d.schedule(111, 10), 121);
        // Exactly now is also past: an interrupt cannot be scheduled at the current tick.
        assert_eq!(d.schedule(131, 10), 132);
    }
}
