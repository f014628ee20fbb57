//! The HAL of the emulated board: [`plotter_fw::hal`] on the LM3S6965's GPIO, timer 0, UART0 and SysTick.
//!
//! - **Clock**: SysTick counts the 50 MHz core clock down from 2²⁴; its wrap exception extends it to 64 bits
//!   ([`now_cycles`]), read as µs ([`plotter_fw::TICK_HZ`]).
//! - **Step timer**: timer 0A in 32-bit one-shot mode, re-armed at every event for the remaining time to the
//!   absolute deadline ([`plotter_board::deadline`]).
//! - **Steps**: a pulse is the step pin set and cleared by two GPIO writes (the emulated pins have no minimum
//!   pulse width; the Nucleo board times its pulses).
//! - **Serial out**: written straight into the UART (QEMU's PL011 transmits at once; it never reports a full
//!   FIFO, but the loop honours the flag).

use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m::peripheral::SCB;
use plotter_board::deadline::Deadline;
use plotter_board::debounce::Debouncer;
use plotter_board::note::ResetCause;
use plotter_fw::hal::{Clock, Endstops, SerialOut, StepPins, StepTimer};
use plotter_fw::{Axis, TICK_HZ};

use crate::pins;
use crate::regs::{self, gpio, sysctl, timer0, timer1, uart, wdt};

/// Core clock, Hz (RCC: 200 MHz PLL ÷ 4).
pub(crate) const SYSCLK_HZ: u32 = 50_000_000;
/// Core clock cycles per [`TICK_HZ`] tick.
const CYCLES_PER_TICK: u64 = (SYSCLK_HZ / TICK_HZ) as u64;
/// SysTick reload (24 bits).
const SYSTICK_RELOAD: u32 = 0x00FF_FFFF;
/// Endstop release window, ticks (1 ms).
const DEBOUNCE_TICKS: u64 = 1_000;
/// Watchdog: interrupt after 4 s without a feed, reset after 8 s. Longer than a real board needs: QEMU's virtual
/// clock keeps running with the host's while the emulator is descheduled on a loaded machine, so a short period
/// would fire without any stall in the firmware.
const WATCHDOG_CYCLES: u32 = 4 * SYSCLK_HZ;
/// Host serial speed (QEMU ignores it; set for a real LM3S6965).
const BAUD: u32 = 115_200;

/// SysTick wraps since start (incremented by the SysTick exception).
pub(crate) static SYSTICK_WRAPS: AtomicU32 = AtomicU32::new(0);

/// Core clock cycles since start. Works inside critical sections too: a wrap whose exception is still pending
/// is counted from the pending flag.
pub(crate) fn now_cycles() -> u64 {
    let wraps = SYSTICK_WRAPS.load(Ordering::Relaxed);
    // SAFETY: read-only access to SysTick's current value and the SCB's pending flag.
    let (val, pending) = unsafe {
        let syst = &*cortex_m::peripheral::SYST::PTR;
        let scb = &*SCB::PTR;
        (syst.cvr.read() & SYSTICK_RELOAD, scb.icsr.read() & (1 << 26) != 0)
    };
    // A pending wrap with the counter in the upper half has just happened and is not counted yet.
    let wraps = u64::from(wraps) + u64::from(pending && val > SYSTICK_RELOAD / 2);
    wraps * (u64::from(SYSTICK_RELOAD) + 1) + u64::from(SYSTICK_RELOAD - val)
}

/// Clock, pins, timer and UART set-up; returns the reset cause (and clears it).
pub(crate) fn init(syst: &mut cortex_m::peripheral::SYST) -> ResetCause {
    let resc = regs::read(sysctl::RESC);
    regs::write(sysctl::RESC, 0);
    let cause = if resc & sysctl::RESC_WDT != 0 {
        ResetCause::Watchdog
    } else if resc & sysctl::RESC_SW != 0 {
        ResetCause::Software
    } else if resc & sysctl::RESC_BOR != 0 {
        ResetCause::Brownout
    } else if resc & sysctl::RESC_POR != 0 {
        ResetCause::PowerOn
    } else if resc & sysctl::RESC_EXT != 0 {
        ResetCause::Pin
    } else {
        ResetCause::Unknown
    };
    // 8 MHz crystal, PLL on (400 MHz / 2), SYSDIV = 3 → 50 MHz. QEMU derives the clock from SYSDIV alone.
    regs::write(sysctl::RCC, (3 << 23) | (1 << 22) | (0xE << 6));
    // Clock gates: watchdog; UART0, timers 0 and 1; GPIO B, D, E.
    regs::write(sysctl::RCGC0, 1 << 3);
    regs::write(sysctl::RCGC1, (1 << 0) | (1 << 16) | (1 << 17));
    regs::write(sysctl::RCGC2, (1 << 1) | (1 << 3) | (1 << 4));

    // Step/dir outputs low; drivers disabled until start-up is done ([`enable_drivers`]). (GPIODATA only
    // latches bits of output pins, so the direction register comes first.)
    regs::write(pins::STEP_PORT + gpio::DIR, u32::from(pins::ALL_STEP | pins::ALL_DIR));
    regs::write(pins::STEP_PORT + gpio::DEN, u32::from(pins::ALL_STEP | pins::ALL_DIR));
    regs::gpio_write(pins::STEP_PORT, pins::ALL_STEP | pins::ALL_DIR, 0);
    regs::write(pins::ENABLE_PORT + gpio::DIR, u32::from(pins::ENABLE));
    regs::write(pins::ENABLE_PORT + gpio::DEN, u32::from(pins::ENABLE));
    regs::gpio_write(pins::ENABLE_PORT, pins::ENABLE, pins::ENABLE);
    // Endstops: inputs with pull-ups (normally open switches to ground).
    regs::write(pins::ENDSTOP_PORT + gpio::DIR, 0);
    regs::write(pins::ENDSTOP_PORT + gpio::AFSEL, 0);
    regs::write(pins::ENDSTOP_PORT + gpio::PUR, u32::from(pins::ALL_ENDSTOP));
    regs::write(pins::ENDSTOP_PORT + gpio::DEN, u32::from(pins::ALL_ENDSTOP));

    // UART0: 115200 8N1 from the 50 MHz clock (divisor 27 + 8/64), no FIFO: an interrupt per byte, and QEMU
    // holds the rest in its character device, so nothing is lost.
    regs::write(uart::CTL, 0);
    let div64 = (SYSCLK_HZ * 4 + BAUD / 2) / BAUD;
    regs::write(uart::IBRD, div64 / 64);
    regs::write(uart::FBRD, div64 % 64);
    regs::write(uart::LCRH, uart::LCRH_8N1);
    regs::write(uart::IM, uart::IM_RX);
    regs::write(uart::CTL, uart::CTL_ON);

    // Timer 0A: 32-bit one-shot, time-out interrupt.
    regs::write(timer0::CTL, 0);
    regs::write(timer0::CFG, 0);
    regs::write(timer0::TAMR, timer0::TAMR_ONE_SHOT);
    regs::write(timer0::IMR, timer0::TIMEOUT);

    // Timer 1A: 1 kHz periodic endstop sampling, so the debounce filter sees the switches between step events
    // too (moves that do not watch them, idle time).
    regs::write(timer1::CTL, 0);
    regs::write(timer1::CFG, 0);
    regs::write(timer1::TAMR, timer1::TAMR_PERIODIC);
    regs::write(timer1::TAILR, SYSCLK_HZ / 1_000);
    regs::write(timer1::IMR, timer0::TIMEOUT);
    regs::write(timer1::CTL, timer0::CTL_TAEN);

    // SysTick: free-running on the core clock, an exception per wrap.
    syst.set_clock_source(cortex_m::peripheral::syst::SystClkSource::Core);
    syst.set_reload(SYSTICK_RELOAD);
    syst.clear_current();
    syst.enable_interrupt();
    syst.enable_counter();

    // Watchdog: interrupt at the first time-out, reset at the second.
    regs::write(wdt::LOAD, WATCHDOG_CYCLES);
    regs::write(wdt::CTL, wdt::CTL_INTEN | wdt::CTL_RESEN);
    cause
}

/// Energise the drivers (the core releases them with M18 and energises them again with M17).
pub(crate) fn enable_drivers() {
    regs::gpio_write(pins::ENABLE_PORT, pins::ENABLE, 0);
}

/// Restart the watchdog count (main loop).
pub(crate) fn feed_watchdog() {
    regs::write(wdt::LOAD, WATCHDOG_CYCLES);
}

/// Fault path: stop the step timer and release the motors. (The pen is a Z stepper here; lifting it would take
/// a planned move, which is not safe in a fault handler.)
pub(crate) fn emergency_stop() {
    regs::write(timer0::CTL, 0);
    regs::gpio_write(pins::ENABLE_PORT, pins::ENABLE, pins::ENABLE);
    regs::gpio_write(pins::STEP_PORT, pins::ALL_STEP, 0);
}

/// Acknowledge the sampling timer's interrupt.
pub(crate) fn ack_sample_timer() {
    regs::write(timer1::ICR, timer0::TIMEOUT);
}

/// Acknowledge the step timer's interrupt.
pub(crate) fn ack_step_timer() {
    regs::write(timer0::ICR, timer0::TIMEOUT);
}

/// Drain the UART's receive side into `f`.
pub(crate) fn drain_uart(mut f: impl FnMut(u8)) {
    while regs::read(uart::FR) & uart::FR_RXFE == 0 {
        // Bits 8..11 are error flags; the byte is passed on either way (the core rejects damaged lines).
        f((regs::read(uart::DR) & 0xFF) as u8);
    }
    regs::write(uart::ICR, uart::IM_RX);
}

/// Write bytes to the UART, waiting while its FIFO is full.
pub(crate) fn uart_write(bytes: &[u8]) {
    for &b in bytes {
        while regs::read(uart::FR) & uart::FR_TXFF != 0 {}
        regs::write(uart::DR, u32::from(b));
    }
}

/// The board as the core sees it.
pub(crate) struct QemuHal {
    deadline: Deadline<1>,
    debounce: Debouncer,
}

impl QemuHal {
    /// After [`init`].
    pub(crate) fn new() -> Self {
        QemuHal { deadline: Deadline::new(), debounce: Debouncer::new(DEBOUNCE_TICKS) }
    }
}

impl StepPins for QemuHal {
    #[inline]
    fn set_dir(&mut self, axis: Axis, level: bool) {
        let pin = pins::DIR[axis.index()];
        regs::gpio_write(pins::STEP_PORT, pin, if level { pin } else { 0 });
    }

    #[inline]
    fn step(&mut self, axis: Axis) {
        let pin = pins::STEP[axis.index()];
        regs::gpio_write(pins::STEP_PORT, pin, pin);
        regs::gpio_write(pins::STEP_PORT, pin, 0);
    }

    fn enable_motors(&mut self, on: bool) {
        regs::gpio_write(pins::ENABLE_PORT, pins::ENABLE, if on { 0 } else { pins::ENABLE });
    }
}

impl QemuHal {
    /// Feed the debounce filter a reading of the endstop pins (every read: the 1 kHz sampling tick's, homing).
    pub(crate) fn sample_endstops(&mut self) -> u8 {
        let raw = pins::endstops_pressed(regs::gpio_read(pins::ENDSTOP_PORT));
        let now = self.now();
        self.debounce.update(raw, now)
    }
}

impl Endstops for QemuHal {
    #[inline]
    fn pressed(&mut self) -> u8 {
        self.sample_endstops()
    }
}

impl StepTimer for QemuHal {
    fn schedule(&mut self, ticks: u32) {
        // The deadline runs on the clock's low 32 bits (wrapping).
        #[allow(clippy::cast_possible_truncation, reason = "the low 32 bits of the clock")]
        let now = self.now() as u32;
        let at = self.deadline.schedule(now, ticks);
        let cycles = u64::from(at.wrapping_sub(now)) * CYCLES_PER_TICK;
        regs::write(timer0::CTL, 0);
        regs::write(timer0::TAILR, u32::try_from(cycles).unwrap_or(u32::MAX));
        regs::write(timer0::ICR, timer0::TIMEOUT);
        regs::write(timer0::CTL, timer0::CTL_TAEN);
    }

    fn cancel(&mut self) {
        regs::write(timer0::CTL, 0);
        regs::write(timer0::ICR, timer0::TIMEOUT);
        self.deadline.cancel();
    }
}

impl SerialOut for QemuHal {
    fn write(&mut self, bytes: &[u8]) {
        uart_write(bytes);
    }
}

impl Clock for QemuHal {
    fn now(&self) -> u64 {
        now_cycles() / CYCLES_PER_TICK
    }
}
