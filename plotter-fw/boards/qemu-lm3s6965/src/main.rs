//! # qemu-lm3s6965 — plotter-fw on the emulated Stellaris LM3S6965 (Cortex-M3)
//!
//! The CI board: `qemu-system-arm -M lm3s6965evb` (QEMU 7.2 models its PL011 UART, PL061 GPIO, general-purpose
//! timers, SysTick and watchdog). Build with `cargo xtask firmware --board qemu-lm3s6965`; run with
//! `plotter sim --qemu`, which counts the steps from QEMU's GPIO trace and drives the endstops.
//!
//! Wiring of the core (see [`plotter_fw::hal`]): UART0's receive interrupt calls `Machine::receive`, timer 0A's
//! time-out calls `Machine::on_timer`, the main loop calls `Machine::poll` and sleeps (WFI) when nothing is
//! waiting. A panic or hard fault stops the timer, disables the drivers, stores the reason in no-init RAM and
//! resets; the next start-up note reports it with the reset cause.
#![no_std]
#![no_main]

mod board;
mod pins;
mod regs;

use core::fmt::Write as _;
use core::mem::MaybeUninit;
use core::ptr::addr_of_mut;
use core::sync::atomic::Ordering;

use cortex_m::peripheral::NVIC;
use cortex_m_rt::{ExceptionFrame, entry, exception};
use lm3s6965::{Interrupt, interrupt};
use plotter_board::fault::FaultRecord;
use plotter_board::note::write_note;
use plotter_board::shared::Shared;
use plotter_fw::MachineConfig;
use plotter_fw::machine::Machine;

use board::QemuHal;

const BOARD: &str = "qemu-lm3s6965";

static MACHINE: Shared<QemuHal> = Shared::new();

/// The previous run's fault reason; in `.uninit`, which start-up leaves alone.
#[unsafe(link_section = ".uninit.plotter_fault")]
static mut FAULT: MaybeUninit<FaultRecord> = MaybeUninit::uninit();

fn fault_record() -> *mut FaultRecord {
    addr_of_mut!(FAULT).cast()
}

/// `fmt::Write` onto the UART, for the start-up note.
struct Uart;

impl core::fmt::Write for Uart {
    fn write_str(&mut self, s: &str) -> core::fmt::Result {
        board::uart_write(s.as_bytes());
        Ok(())
    }
}

#[entry]
fn main() -> ! {
    let mut cp = cortex_m::Peripherals::take().unwrap_or_else(|| panic!("core peripherals taken twice"));
    let cause = board::init(&mut cp.SYST);
    // SAFETY: the record is only touched here and in the fault handlers, which reset the chip.
    let fault = unsafe { FaultRecord::take(fault_record()) };
    let _ = write_note(&mut Uart, BOARD, cause, fault.as_deref());
    let cfg = MachineConfig::xy_plotter();
    if let Err(e) = cfg.validate() {
        panic!("machine configuration: {e}");
    }
    MACHINE.install(Machine::new(QemuHal::new(), cfg));
    board::enable_drivers();
    // SAFETY: the handlers only touch the machine through the critical section.
    unsafe {
        NVIC::unmask(Interrupt::UART0);
        NVIC::unmask(Interrupt::TIMER_0A);
        NVIC::unmask(Interrupt::TIMER_1A);
        NVIC::unmask(Interrupt::WATCHDOG_TIMER_0);
    }
    loop {
        board::feed_watchdog();
        if MACHINE.poll() {
            continue;
        }
        // Sleep until an interrupt, unless one arrived since the check (WFI wakes on a pending interrupt even
        // with interrupts masked, so nothing slips between the check and the sleep).
        cortex_m::interrupt::free(|_| {
            if !MACHINE.with(|m| m.has_input() || m.needs_poll()).unwrap_or(false) {
                cortex_m::asm::wfi();
            }
        });
    }
}

#[interrupt]
fn UART0() {
    board::drain_uart(|b| MACHINE.receive(b));
}

#[interrupt]
fn TIMER_0A() {
    board::ack_step_timer();
    MACHINE.on_timer();
}

#[interrupt]
fn TIMER_1A() {
    board::ack_sample_timer();
    // The switches at 1 kHz: debounced, then the hard-limit check (the step interrupt reads them only when homing).
    MACHINE.with(|m| m.check_limits());
}

#[interrupt]
fn WATCHDOG_TIMER_0() {
    // First time-out: the main loop has not run for a second. Stop the motors and record why; the watchdog's
    // second time-out resets the chip.
    board::emergency_stop();
    // SAFETY: see `fault_record`; nothing else writes the record while this runs.
    unsafe { FaultRecord::store(fault_record(), format_args!("watchdog: main loop stalled")) };
    loop {
        cortex_m::asm::nop();
    }
}

#[exception]
fn SysTick() {
    board::SYSTICK_WRAPS.fetch_add(1, Ordering::Relaxed);
}

#[exception]
unsafe fn HardFault(ef: &ExceptionFrame) -> ! {
    board::emergency_stop();
    // SAFETY: see `fault_record`.
    unsafe { FaultRecord::store(fault_record(), format_args!("hard fault at pc {:#010x}", ef.pc())) };
    cortex_m::peripheral::SCB::sys_reset()
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo<'_>) -> ! {
    cortex_m::interrupt::disable();
    board::emergency_stop();
    // SAFETY: see `fault_record`; interrupts are off.
    unsafe { FaultRecord::store_panic(fault_record(), info) };
    let _ = writeln!(Uart, "[MSG:{BOARD} panic, resetting]");
    cortex_m::peripheral::SCB::sys_reset()
}
