//! The machine shared between the interrupts and the main loop.
//!
//! A single-core microcontroller runs [`Machine::receive`] in the UART receive interrupt, [`Machine::on_timer`] in
//! the step-timer interrupt and [`Machine::poll`] in the main loop. Everything but the step interrupt takes the
//! machine through one critical section (interrupts masked), as the core's docs prescribe: the interrupts can
//! never see a half-done `poll`, and `poll` is short (one line, one re-plan) so the step timer is delayed by at
//! most that long; the [`crate::deadline`] scheme keeps a late event from shifting the ones after it. The step
//! interrupt itself ([`Shared::on_timer_unmasked`], or [`Shared::on_timer_installed`] once a machine is installed)
//! needs no critical section of its own: since every other access masks it, it never finds the machine in use.

use core::cell::RefCell;

use critical_section::Mutex;
use plotter_fw::hal::Hal;
use plotter_fw::machine::Machine;

/// The board's one machine, installed at start-up.
pub struct Shared<H: Hal> {
    cell: Mutex<RefCell<Slot<Machine<H>>>>,
}

/// `Option` with a forced tag layout: the empty state is a zero tag and nothing else, so a `static` of it goes
/// to `.bss` (zeroed at start-up) instead of storing the whole machine's initial bytes in flash as `.data`.
#[repr(u8)]
enum Slot<T> {
    Empty = 0,
    Full(T),
}

impl<H: Hal> Shared<H> {
    /// Empty (a `static` initialiser).
    pub const fn new() -> Self {
        Shared { cell: Mutex::new(RefCell::new(Slot::Empty)) }
    }

    /// Install the machine (after the banner was written by [`Machine::new`]).
    pub fn install(&self, m: Machine<H>) {
        critical_section::with(|cs| *self.cell.borrow_ref_mut(cs) = Slot::Full(m));
    }

    /// Run `f` on the machine, if installed.
    pub fn with<R>(&self, f: impl FnOnce(&mut Machine<H>) -> R) -> Option<R> {
        critical_section::with(|cs| match &mut *self.cell.borrow_ref_mut(cs) {
            Slot::Full(m) => Some(f(m)),
            Slot::Empty => None,
        })
    }

    /// UART receive interrupt: one byte.
    pub fn receive(&self, b: u8) {
        self.with(|m| m.receive(b));
    }

    /// Step-timer interrupt, through the critical section.
    pub fn on_timer(&self) {
        self.with(|m| m.on_timer());
    }

    /// Step-timer interrupt without a critical section of its own: every other access ([`Shared::with`] and the
    /// calls built on it) runs with interrupts masked, so while the step interrupt runs nothing else holds the
    /// machine, and the step interrupt cannot preempt one that does.
    ///
    /// # Safety
    /// Call only from one interrupt handler that does not preempt itself (the step timer's), while every other
    /// user of this `Shared` goes through [`Shared::with`] (nothing else touches it from an interrupt of higher
    /// priority without masking).
    #[inline(always)]
    pub unsafe fn on_timer_unmasked(&self) {
        // SAFETY: no other context can hold the machine while this runs (see the contract above), which is what
        // the token stands for here.
        let cs = unsafe { critical_section::CriticalSection::new() };
        // SAFETY: no borrow of the cell exists while this runs (see the contract), so this is the only reference.
        if let Slot::Full(m) = unsafe { &mut *self.cell.borrow(cs).as_ptr() } {
            m.on_timer();
        }
    }

    /// [`Shared::on_timer_unmasked`] without asking whether a machine is installed (a test and a branch less per
    /// step event): the board installs its machine before it unmasks the step interrupt, and an installed machine
    /// is never taken out again ([`Shared::install`] only replaces it).
    ///
    /// # Safety
    /// As for [`Shared::on_timer_unmasked`], and [`Shared::install`] has been called before (this reads the
    /// machine without looking whether there is one).
    #[inline(always)]
    pub unsafe fn on_timer_installed(&self) {
        // SAFETY: as in `on_timer_unmasked`.
        let cs = unsafe { critical_section::CriticalSection::new() };
        // SAFETY: as in `on_timer_unmasked`.
        match unsafe { &mut *self.cell.borrow(cs).as_ptr() } {
            Slot::Full(m) => m.on_timer(),
            // SAFETY: a machine was installed (the contract), and nothing empties the slot again.
            Slot::Empty => unsafe { core::hint::unreachable_unchecked() },
        }
    }

    /// Main-loop pass; returns whether more work is already waiting (input, a finished block, a real-time
    /// command), i.e. whether the loop should poll again before sleeping.
    pub fn poll(&self) -> bool {
        self.with(|m| {
            m.poll();
            m.has_input() || m.needs_poll()
        })
        .unwrap_or(false)
    }
}

impl<H: Hal> Default for Shared<H> {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use plotter_fw::MachineConfig;
    use plotter_fw::hal::{Clock, Endstops, SerialOut, StepPins, StepTimer};
    use plotter_fw::{Axis, NUM_AXES};
    use std::vec::Vec;

    /// Pins and a timer that the test fires by hand.
    #[derive(Default)]
    struct Bench {
        steps: [i64; NUM_AXES],
        dir: [bool; NUM_AXES],
        armed: Option<u32>,
        out: Vec<u8>,
    }

    impl StepPins for Bench {
        fn set_dir(&mut self, axis: Axis, level: bool) {
            self.dir[axis.index()] = level;
        }
        fn step(&mut self, axis: Axis) {
            self.steps[axis.index()] += if self.dir[axis.index()] { -1 } else { 1 };
        }
        fn enable_motors(&mut self, _on: bool) {}
    }
    impl Endstops for Bench {
        fn pressed(&mut self) -> u8 {
            0
        }
    }
    impl StepTimer for Bench {
        fn schedule(&mut self, ticks: u32) {
            self.armed = Some(ticks);
        }
        fn cancel(&mut self) {
            self.armed = None;
        }
    }
    impl SerialOut for Bench {
        fn write(&mut self, bytes: &[u8]) {
            self.out.extend_from_slice(bytes);
        }
    }
    impl Clock for Bench {
        fn now(&self) -> u64 {
            0
        }
    }

    #[test]
    fn interrupts_and_main_loop_drive_one_machine() {
        static M: Shared<Bench> = Shared::new();
        assert!(!M.poll(), "nothing installed: nothing to do");
        // SAFETY: single-threaded test.
        unsafe { M.on_timer_unmasked() };
        let mut cfg = MachineConfig::xy_plotter();
        cfg.soft_limits = false;
        M.install(Machine::new(Bench::default(), cfg));
        for b in b"G91\nG1 X1 Y-0.5 F600\n" {
            M.receive(*b);
        }
        assert!(M.with(|m| m.has_input()).unwrap());
        while M.poll() {}
        // Fire the step timer as the interrupt would, until the stepper stops it.
        let mut events = 0;
        while M.with(|m| m.hal().armed.is_some()).unwrap() {
            // In turn as the boards' step interrupt does (no critical section, with and without the look whether
            // a machine is installed) and through one.
            match events % 3 {
                // SAFETY: single-threaded test; nothing else holds the machine.
                0 => unsafe { M.on_timer_unmasked() },
                // SAFETY: as above, and the machine is installed.
                1 => unsafe { M.on_timer_installed() },
                _ => M.on_timer(),
            }
            events += 1;
            while M.poll() {}
            assert!(events < 1_000);
        }
        // 1 mm and 0.5 mm at 80 steps/mm: 80 events (X is the major axis), 40 Y steps backwards.
        assert_eq!(events, 80);
        let (steps, out) = M.with(|m| (m.hal().steps, m.hal().out.clone())).unwrap();
        assert_eq!(steps, [80, -40, 0, 0]);
        let text = std::string::String::from_utf8(out).unwrap();
        assert!(text.starts_with("plotter-fw "), "{text}");
        assert_eq!(text.matches("ok\n").count(), 2, "{text}");
    }
}
