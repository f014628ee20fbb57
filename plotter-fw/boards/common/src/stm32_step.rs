//! The step-event path of an STM32 board: GPIO step pins, a free-running 32-bit compare timer, and the step
//! pulse ended by the timer and DMA, not by an interrupt.
//!
//! Per step event the interrupt does, and nothing else:
//! 1. [`StepOutputs::step_interrupt`]: clear compare 1's flag, the timer's only interrupt (the board counts the
//!    overflows for its 64-bit clock from its periodic tick: [`StepOutputs::count_overflow`]);
//! 2. the stepper's event ([`plotter_fw::stepper::Stepper::tick`]) and [`StepOutputs::raise`]: one BSRR store per
//!    port from a table indexed by the axis mask, then the pulse end: the counter read once, plus the pulse
//!    length, stored into the two compare channels that end the pulse (channel 2 for the first port, channel 3
//!    for the second);
//! 3. [`StepOutputs::schedule_next_from`]: the next event's compare value, the previous deadline (read back from
//!    compare 1) plus the interval ([`crate::deadline`]), one add and one compare against the counter as step 2
//!    read it (not read again; [`StepOutputs::schedule_next`], off the plain event's path, reads it anew).
//!
//! **Pulse end in hardware.** Each of the two pulse compare channels raises a DMA request when the counter
//! matches it; its DMA channel (circular, one word, memory to peripheral) stores the port's "all step pins low"
//! word into that port's BSRR. No second interrupt, no busy wait: the pulse lasts from the pin write to the match.
//!
//! **Pulse timing** (proved by the tests below over every latency and interval): with the pins raised before the
//! counter is read, a pulse of `pulse` ticks is high for at least `pulse − 1` ticks (the read falls anywhere in a
//! tick) and at most `pulse` plus the few cycles between the pin store and the counter read; the next event is never
//! earlier than `lead = pulse + low` ticks after the counter read of the one before (the [`crate::deadline`]
//! lead), so the pins are low for at least `low` ticks. The Nucleo uses `pulse = 3`, `low = 2` at 1 MHz: high
//! ≥ 2 µs, low ≥ 2 µs — the DRV8825's 1.9 µs minimum high and low times (the A4988's 1 µs and the TMC2209's
//! 100 ns are shorter). The price: events closer than 5 µs (above 200 k events/s) come late by the difference.
//!
//! The same code runs on the Nucleo-L476RG and in the `tick-bench` image that `cargo xtask tick-cost` prices;
//! only the register base addresses differ (the bench's "registers" are RAM on QEMU's mps2-an386).

use core::sync::atomic::{AtomicU32, Ordering};

use plotter_fw::{Axis, NUM_AXES};

use crate::deadline::Deadline;
use crate::servo::ServoPen;

/// Register offsets and bits of an STM32 general-purpose timer (RM0351 §31.4).
pub mod tim {
    /// Control 1.
    pub const CR1: usize = 0x00;
    /// DMA/interrupt enable.
    pub const DIER: usize = 0x0C;
    /// Status.
    pub const SR: usize = 0x10;
    /// Event generation.
    pub const EGR: usize = 0x14;
    /// Counter.
    pub const CNT: usize = 0x24;
    /// Compare 1: the next step event.
    pub const CCR1: usize = 0x34;
    /// Compare 2: end of the pulse on the first step port.
    pub const CCR2: usize = 0x38;
    /// Compare 3: end of the pulse on the second step port.
    pub const CCR3: usize = 0x3C;
    /// Update (overflow) flag / interrupt enable.
    pub const UIF: u32 = 1 << 0;
    /// Compare 1 flag / interrupt enable.
    pub const CC1: u32 = 1 << 1;
    /// Compare 2 and 3 DMA request enables.
    pub const CC2DE_CC3DE: u32 = (1 << 10) | (1 << 11);
}

/// GPIO bit set/reset register offset.
pub const BSRR: usize = 0x18;

/// Read a memory-mapped register.
#[inline(always)]
pub fn read(addr: usize) -> u32 {
    // SAFETY: the addresses used are a board's peripheral registers or the bench's RAM stand-ins (aligned, mapped).
    unsafe { (addr as *const u32).read_volatile() }
}

/// Write a memory-mapped register.
#[inline(always)]
pub fn write(addr: usize, value: u32) {
    // SAFETY: as for `read`; these registers have no memory-safety effects.
    unsafe { (addr as *mut u32).write_volatile(value) }
}

/// A board's step pins (on at most two GPIO ports) and its step timer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StepOutputs {
    /// BSRR of the two ports.
    bsrr: [usize; 2],
    /// Per axis mask: the BSRR words that raise its axes' step pins, per port.
    raise: [[u32; 2]; 1 << NUM_AXES],
    /// Per port: the BSRR word that lowers all its step pins (what the pulse-end DMA stores).
    lower: [u32; 2],
    /// Timer base address.
    tim: usize,
    /// Pulse length, ticks.
    pulse: u32,
    /// The compare register of a servo pen's PWM.
    servo_ccr: usize,
}

impl StepOutputs {
    /// Step pins `steps[axis] = (port, pin)` with `port` 0 or 1 of `ports` (GPIO base addresses), the timer at
    /// `tim`, pulses of `pulse` ticks; a servo pen's PWM compare register at `servo_ccr`.
    ///
    /// # Panics
    /// If `tim` is not 8-byte aligned (a timer's register block is; [`StepOutputs::raise`] stores compare 2 and 3
    /// at once) — at compile time for a `const`.
    pub const fn new(ports: [usize; 2], steps: [(u8, u8); NUM_AXES], tim: usize, pulse: u32, servo_ccr: usize) -> Self {
        assert!(tim.is_multiple_of(8), "the timer's register block is 8-byte aligned");
        let mut raise = [[0u32; 2]; 1 << NUM_AXES];
        let mut lower = [0u32; 2];
        let mut a = 0;
        while a < NUM_AXES {
            let (port, pin) = steps[a];
            lower[port as usize] |= 1 << (pin as u32 + 16);
            let mut mask = 0;
            while mask < 1 << NUM_AXES {
                if mask & (1 << a) != 0 {
                    raise[mask][port as usize] |= 1 << pin;
                }
                mask += 1;
            }
            a += 1;
        }
        StepOutputs { bsrr: [ports[0] + BSRR, ports[1] + BSRR], raise, lower, tim, pulse, servo_ccr }
    }

    /// The pulse-end DMA's source word and destination (BSRR) for port 0 and 1.
    pub const fn pulse_end_transfers(&self) -> [(u32, usize); 2] {
        [(self.lower[0], self.bsrr[0]), (self.lower[1], self.bsrr[1])]
    }

    /// Raise the step pins of the axes in `mask` and arm the pulse end (the hardware lowers them `pulse` ticks
    /// later).
    /// Returns the counter as read for the pulse end ([`StepOutputs::schedule_next_from`] takes it).
    #[inline(always)]
    pub fn raise(&self, mask: u8) -> u32 {
        let words = &self.raise[usize::from(mask) & ((1 << NUM_AXES) - 1)];
        write(self.bsrr[0], words[0]);
        write(self.bsrr[1], words[1]);
        let now = read(self.tim + tim::CNT);
        let end = now.wrapping_add(self.pulse);
        // Compare 2 and 3 are adjacent: one store of both (two word transfers on the bus).
        // SAFETY: as for `write`; CCR2 is 8-byte aligned (0x38) in the timer's aligned register block.
        unsafe { ((self.tim + tim::CCR2) as *mut u64).write_volatile(u64::from(end) << 32 | u64::from(end)) };
        now
    }

    /// A step event's outputs ([`plotter_fw::hal::StepPins::step_axes`]): [`StepOutputs::raise`], then a servo pen
    /// (if fitted) follows the Z step.
    /// Returns the counter as read for the pulse end ([`StepOutputs::raise`]).
    #[inline(always)]
    pub fn step_event(&self, mask: u8, servo: Option<&mut ServoPen>) -> u32 {
        let now = self.raise(mask);
        if mask & Axis::Z.bit() != 0
            && let Some(s) = servo
        {
            write(self.servo_ccr, u32::from(s.step()));
        }
        now
    }

    /// Lower every step pin now (fault path).
    pub fn lower_all(&self) {
        write(self.bsrr[0], self.lower[0]);
        write(self.bsrr[1], self.lower[1]);
    }

    /// The timer's interrupt: compare 1 reached the next event; acknowledge it (one constant store, no read).
    ///
    /// Compare 1 is the only interrupt the timer raises: its overflow is counted from the board's periodic tick
    /// ([`StepOutputs::count_overflow`]) and the pulse ends are DMA requests, so the handler runs only when compare
    /// 1's flag rose with its interrupt enabled: a step event is due. [`StepOutputs::cancel`] disables it, and the
    /// board's cancel also drops an interrupt left pending then (an event stale by then reaches a stepper that is
    /// not running and emits nothing: [`plotter_fw::stepper::Stepper::tick`]).
    #[inline(always)]
    pub fn step_interrupt(&self) {
        write(self.tim + tim::SR, !tim::CC1);
    }

    /// The timer's overflow, from the board's periodic tick (far more often than every 2³² ticks, at the step
    /// interrupt's priority): if its flag is up, clear it and count it in `wraps`. Writing 0 clears a flag and
    /// writing 1 leaves it, so this never clears compare 1's flag.
    pub fn count_overflow(&self, wraps: &AtomicU32) {
        if read(self.tim + tim::SR) & tim::UIF != 0 {
            write(self.tim + tim::SR, !tim::UIF);
            wraps.fetch_add(1, Ordering::Relaxed);
        }
    }

    /// Aim compare 1 at the next event, `ticks` after the previous one ([`Deadline`]); from idle, also enable its
    /// interrupt. While the timer runs, the previous deadline is the one compare 1 holds (see
    /// [`StepOutputs::schedule_next`]).
    #[inline(always)]
    pub fn schedule<const LEAD: u32>(&self, deadline: &mut Deadline<LEAD>, ticks: u32) {
        let idle = !deadline.is_running();
        let now = read(self.tim + tim::CNT);
        let at =
            if idle { deadline.schedule(now, ticks) } else { Deadline::<LEAD>::after(self.deadline(), now, ticks) };
        write(self.tim + tim::CCR1, at);
        if idle {
            write(self.tim + tim::SR, !tim::CC1);
            let dier = read(self.tim + tim::DIER);
            write(self.tim + tim::DIER, dier | tim::CC1);
        }
    }

    /// [`StepOutputs::schedule`] from the timer's interrupt (the timer runs): the next event's compare value only,
    /// from the previous one read back from compare 1 (written without preload, it reads back as written), so the
    /// deadline is not also kept in RAM: one register load instead of a load and a store. `deadline` is the
    /// board's [`Deadline`] (its lead; it stays running).
    #[inline(always)]
    pub fn schedule_next<const LEAD: u32>(&self, deadline: &Deadline<LEAD>, ticks: u32) {
        self.schedule_next_from(deadline, read(self.tim + tim::CNT), ticks);
    }

    /// [`StepOutputs::schedule_next`] with the counter read `now` by this event's [`StepOutputs::raise`] (the
    /// event in the middle of a block: [`plotter_fw::hal::StepTimer::schedule_next_from`]), not read again. Safe
    /// because only the next interval's adds (and a servo step) run between that read and this compare store —
    /// tens of cycles, under one tick at 80 MHz, while a deadline is at least the lead (5 ticks) after `now` — and
    /// nothing preempts the step interrupt (the board's interrupts share one priority). It is also exactly the
    /// pulse timing's reference: the next event is at least `lead` after the counter read of the pulse before.
    #[inline(always)]
    pub fn schedule_next_from<const LEAD: u32>(&self, _deadline: &Deadline<LEAD>, now: u32, ticks: u32) {
        let at = Deadline::<LEAD>::after(self.deadline(), now, ticks);
        write(self.tim + tim::CCR1, at);
    }

    /// The deadline compare 1 holds: the scheduled step event (or the last one, when stopped).
    #[inline(always)]
    pub fn deadline(&self) -> u32 {
        read(self.tim + tim::CCR1)
    }

    /// Stop the step events.
    pub fn cancel<const LEAD: u32>(&self, deadline: &mut Deadline<LEAD>) {
        let dier = read(self.tim + tim::DIER);
        write(self.tim + tim::DIER, dier & !tim::CC1);
        write(self.tim + tim::SR, !tim::CC1);
        deadline.cancel();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn raise_words_per_mask_and_the_pulse_end_words() {
        // X on port 0 pin 10, Y port 1 pin 3, Z port 1 pin 5, E port 0 pin 6 (the Nucleo's wiring).
        let o = StepOutputs::new([0x100, 0x200], [(0, 10), (1, 3), (1, 5), (0, 6)], 0x300, 3, 0x400);
        assert_eq!(o.raise[0b0001], [1 << 10, 0]);
        assert_eq!(o.raise[0b0110], [0, (1 << 3) | (1 << 5)]);
        assert_eq!(o.raise[0b1111], [(1 << 10) | (1 << 6), (1 << 3) | (1 << 5)]);
        assert_eq!(o.raise[0], [0, 0]);
        assert_eq!(o.pulse_end_transfers(), [((1 << 26) | (1 << 22), 0x118), ((1 << 19) | (1 << 21), 0x218)]);
    }

    /// The flag writes, on a RAM stand-in for the timer (a write shows as written: on the chip a 0 bit clears its flag
    /// and a 1 bit leaves it).
    #[test]
    fn the_step_interrupt_clears_compare_1_alone_and_the_overflow_is_counted_once() {
        #[repr(align(8))]
        struct Timer([u32; 16]);
        let mut timer = Timer([0; 16]);
        let base = timer.0.as_mut_ptr() as usize;
        let o = StepOutputs::new([0x100, 0x200], [(0, 10), (1, 3), (1, 5), (0, 6)], base, 3, 0x400);
        let sr = |t: &Timer| t.0[tim::SR / 4];
        let wraps = AtomicU32::new(7);
        // No overflow flag: nothing written, nothing counted.
        timer.0[tim::SR / 4] = tim::CC1;
        o.count_overflow(&wraps);
        assert_eq!((sr(&timer), wraps.load(Ordering::Relaxed)), (tim::CC1, 7));
        // The overflow flag up (and compare 1's): cleared by a write whose other bits keep every other flag.
        timer.0[tim::SR / 4] = tim::UIF | tim::CC1;
        o.count_overflow(&wraps);
        assert_eq!((sr(&timer), wraps.load(Ordering::Relaxed)), (!tim::UIF, 8));
        // The step interrupt: compare 1's flag cleared, every other flag kept.
        o.step_interrupt();
        assert_eq!(sr(&timer), !tim::CC1);
    }

    /// The pulse end: both compare channels get the counter plus the pulse, in one store (RAM stand-ins again:
    /// the step ports' BSRR and the timer).
    #[test]
    fn raising_the_pins_arms_both_pulse_ends_from_one_counter_read() {
        #[repr(align(8))]
        struct Block([u32; 256]);
        let mut ports = Block([0; 256]);
        let mut timer = Block([0; 256]);
        let (a, b) = (ports.0.as_mut_ptr() as usize, ports.0.as_mut_ptr() as usize + 0x200);
        let o = StepOutputs::new([a, b], [(0, 10), (1, 3), (1, 5), (0, 6)], timer.0.as_mut_ptr() as usize, 3, 0x400);
        timer.0[tim::CNT / 4] = 0xFFFF_FFFE;
        assert_eq!(o.raise(0b0101), 0xFFFF_FFFE);
        // X on port 0 (pin 10), Z on port 1 (pin 5); the pulse ends wrap past 0.
        assert_eq!((ports.0[BSRR / 4], ports.0[(0x200 + BSRR) / 4]), (1 << 10, 1 << 5));
        assert_eq!((timer.0[tim::CCR2 / 4], timer.0[tim::CCR3 / 4], timer.0[tim::CCR1 / 4]), (1, 1, 0));
    }

    /// Pulse and gap at the ticks' resolution (times in hundredths of a tick): the pins go up at `set`, the counter
    /// reads `⌊set⌋`, the DMA lowers them when the counter reaches that plus `pulse`; the next event is scheduled
    /// from the counter read then and fires at its deadline (plus the interrupt's latency).
    #[test]
    fn pulses_stay_high_and_low_long_enough_at_every_latency_and_rate() {
        let (pulse, low) = (3u32, 2u32);
        assert_eq!(pulse + low, 5, "the deadline's lead");
        for interval in 1..12u32 {
            for latency in [0u32, 30, 90, 100, 170, 250, 400, 470, 600, 990, 1500] {
                let mut d = Deadline::<5>::new();
                let mut deadline = d.schedule(0, interval);
                let mut last_end: Option<u32> = None;
                for _ in 0..20 {
                    // The interrupt runs `latency` after the deadline; the pin store comes 0.05 tick later.
                    let set = deadline * 100 + latency + 5;
                    let cnt = set / 100;
                    let end = (cnt + pulse) * 100;
                    assert!(end - set >= (pulse - 1) * 100, "high {} at {interval}/{latency}", end - set);
                    if let Some(prev_end) = last_end {
                        assert!(set - prev_end >= low * 100, "low {} at {interval}/{latency}", set - prev_end);
                    }
                    last_end = Some(end);
                    deadline = d.schedule(cnt, interval);
                }
            }
        }
    }
}
