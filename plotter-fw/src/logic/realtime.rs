//! Real-time commands and the status report.
//!
//! The bytes [`crate::protocol::RT_STATUS`] (`?`), [`crate::protocol::RT_FEED_HOLD`] (`!`),
//! [`crate::protocol::RT_RESUME`] (`~`) and [`crate::protocol::RT_RESET`] (0x18) are taken out of the byte stream
//! in the receive path ([`crate::machine::Machine::receive`]) and never reach the line buffer. Feed hold and reset
//! act on the stepper at once; the report and the rest of the reset run in the next main-loop pass.
//!
//! A resume (`~`) that arrives while a feed hold is still decelerating (`Hold:1`) is remembered, and motion resumes
//! by itself as soon as the hold has come to rest (as grbl does); a further `!` before that cancels it. A `~`
//! while running is ignored.
//!
//! Status report, one line:
//! `<State|MPos:x,y,z,e|Steps:x,y,z,e|Q:used/size|N:expected|C:completed>` — state as below, machine position in
//! mm (3 decimals) and in steps, the planner queue fill, the next expected sequence number, and the number of
//! blocks the stepper has completed since start or the last reset (moves, dwells, step-block frames and homing
//! moves alike; a zero-length move queues no block and counts nothing; wraps at 2³²). Since every accepted
//! step-block frame becomes exactly one block, a host that reads `C` before and during a stream knows exactly how
//! many of its frames have been executed.

use core::fmt;

/// The machine state shown in the status report.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MachineState {
    /// Nothing queued or moving.
    Idle,
    /// Executing or holding queued motion.
    Run,
    /// Feed hold decelerating.
    Holding,
    /// Feed hold complete, queue kept; `~` resumes.
    Held,
    /// Homing cycle running.
    Homing,
    /// Alarm latched; reset required.
    Alarm,
}

impl MachineState {
    /// The word used in the status report.
    pub const fn name(self) -> &'static str {
        match self {
            MachineState::Idle => "Idle",
            MachineState::Run => "Run",
            MachineState::Holding => "Hold:1",
            MachineState::Held => "Hold:0",
            MachineState::Homing => "Home",
            MachineState::Alarm => "Alarm",
        }
    }
}

impl fmt::Display for MachineState {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn report_words_are_grbls() {
        // The words of grbl's status report (its `Hold:0`/`Hold:1` sub-states included).
        let all = [
            (MachineState::Idle, "Idle"),
            (MachineState::Run, "Run"),
            (MachineState::Holding, "Hold:1"),
            (MachineState::Held, "Hold:0"),
            (MachineState::Homing, "Home"),
            (MachineState::Alarm, "Alarm"),
        ];
        for (state, word) in all {
            assert_eq!((state.name(), std::format!("<{state}|")), (word, std::format!("<{word}|")));
        }
    }
}
