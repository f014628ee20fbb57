//! # nucleo-l476rg — plotter-fw on the ST Nucleo-L476RG (Cortex-M4F, 80 MHz)
//!
//! The seed plotter's board with a CNC-shield style wiring ([`pins`]). Build with
//! `cargo xtask firmware --board nucleo-l476rg` (add `--features servo-pen` in the board crate for a servo pen
//! lift); flash `target/firmware/nucleo-l476rg.bin` by copying it to the ST-LINK's USB drive, or with probe-rs /
//! st-flash (see the README).
//!
//! **Stack.** stm32l4xx-hal sets up the clock tree (HSI16 → PLL → 80 MHz, flash wait states); cortex-m-rt
//! provides the vector table and start-up. The HAL's blocking, interrupt-friendly style matches the core's three
//! entry points exactly (receive, timer, poll): the core owns all timing and scheduling, so an async executor
//! (embassy) would add code and a second scheduler without doing anything the core needs, and the image has to
//! fit the project's flash budget (76 KiB). The hot paths (step pins, the TIM2 compare channels, the USART2 DMA ring) are register writes in
//! [`regs`].
//!
//! **Wiring of the core**: USART2's idle-line and DMA1 channel 6's half/complete interrupts hand received bytes
//! to `Machine::receive`; TIM2's compare-1 interrupt calls `Machine::on_timer`; the main loop feeds the
//! independent watchdog, calls `Machine::poll` and sleeps (WFI) when nothing is waiting; SysTick (1 kHz) counts TIM2's
//! overflows (the clock's upper half) and samples the switches into `Machine::check_limits`.
//!
//! **Faults**: a panic or hard fault stops the step timer, releases the drivers, lifts a servo pen, stores the
//! reason in no-init RAM and resets; the start-up note before the next banner reports it with the reset cause.
#![no_std]
#![no_main]

mod board;
mod pins;
mod regs;

use core::mem::MaybeUninit;
use core::ptr::addr_of_mut;

use cortex_m::peripheral::NVIC;
use cortex_m_rt::{ExceptionFrame, entry, exception};
use plotter_board::fault::FaultRecord;
use plotter_board::note::write_note;
use plotter_board::shared::Shared;
use plotter_fw::MachineConfig;
use plotter_fw::machine::Machine;
use stm32l4xx_hal::pac::{self, Interrupt, interrupt};
use stm32l4xx_hal::prelude::*;

use board::NucleoHal;

const BOARD: &str = "nucleo-l476rg";

static MACHINE: Shared<NucleoHal> = Shared::new();

/// The previous run's fault reason; in `.uninit`, which start-up leaves alone.
#[unsafe(link_section = ".uninit.plotter_fault")]
static mut FAULT: MaybeUninit<FaultRecord> = MaybeUninit::uninit();

fn fault_record() -> *mut FaultRecord {
    addr_of_mut!(FAULT).cast()
}

/// The start-up note goes out byte by byte (before the interrupt-driven output is running).
struct Blocking;

impl core::fmt::Write for Blocking {
    fn write_str(&mut self, s: &str) -> core::fmt::Result {
        for &b in s.as_bytes() {
            while regs::read(regs::usart2::ISR) & regs::usart2::ISR_TXE == 0 {}
            regs::write(regs::usart2::TDR, u32::from(b));
        }
        Ok(())
    }
}

#[entry]
fn main() -> ! {
    let cause = board::reset_cause();
    let mut cp = cortex_m::Peripherals::take().unwrap_or_else(|| panic!("core peripherals taken twice"));
    let dp = pac::Peripherals::take().unwrap_or_else(|| panic!("device peripherals taken twice"));
    let mut flash = dp.FLASH.constrain();
    let mut rcc = dp.RCC.constrain();
    let mut pwr = dp.PWR.constrain(&mut rcc.apb1r1);
    let clocks = rcc
        .cfgr
        .sysclk(board::SYSCLK_HZ.Hz())
        .pclk1(board::SYSCLK_HZ.Hz())
        .pclk2(board::SYSCLK_HZ.Hz())
        .freeze(&mut flash.acr, &mut pwr);
    if clocks.sysclk().raw() != board::SYSCLK_HZ {
        panic!("clock tree: {} Hz instead of {}", clocks.sysclk().raw(), board::SYSCLK_HZ);
    }
    board::init();
    // SysTick at 1 kHz samples the endstops (hard limits).
    cp.SYST.set_clock_source(cortex_m::peripheral::syst::SystClkSource::Core);
    cp.SYST.set_reload(board::SYSCLK_HZ / 1_000 - 1);
    cp.SYST.clear_current();
    cp.SYST.enable_interrupt();
    cp.SYST.enable_counter();

    // SAFETY: the record is only touched here and in the fault handlers, which reset the chip.
    let fault = unsafe { FaultRecord::take(fault_record()) };
    let _ = write_note(&mut Blocking, BOARD, cause, fault.as_deref());
    let cfg = MachineConfig::xy_plotter();
    if let Err(e) = cfg.validate() {
        panic!("machine configuration: {e}");
    }
    MACHINE.install(Machine::new(NucleoHal::new(&cfg), cfg));
    board::enable_drivers();
    // SAFETY: the handlers only touch the machine through the critical section (TIM2: see its handler).
    unsafe {
        NVIC::unmask(Interrupt::USART2);
        NVIC::unmask(Interrupt::DMA1_CH6);
        NVIC::unmask(Interrupt::TIM2);
    }
    loop {
        board::feed_watchdog();
        if MACHINE.poll() {
            continue;
        }
        cortex_m::interrupt::free(|_| {
            if !MACHINE.with(|m| m.has_input() || m.needs_poll()).unwrap_or(false) {
                cortex_m::asm::wfi();
            }
        });
    }
}

#[interrupt]
fn TIM2() {
    board::tim2_step_event();
    // SAFETY: the only caller is this handler (TIM2 never preempts itself), and every other access to the
    // machine — the USART2, DMA1 and SysTick handlers, the main loop — goes through `with`, which masks it;
    // `main` installs the machine before it unmasks TIM2 in the NVIC.
    unsafe { MACHINE.on_timer_installed() };
}

#[interrupt]
fn USART2() {
    if board::usart2_idle() {
        board::drain_rx(|b| MACHINE.receive(b));
    }
    if board::usart2_tx_ready() {
        MACHINE.with(|m| m.hal_mut().pump_tx());
    }
}

#[interrupt]
fn DMA1_CH6() {
    board::drain_rx(|b| MACHINE.receive(b));
}

/// The switches at 1 kHz: debounced, then the hard-limit check (the step interrupt reads them only when homing).
#[exception]
fn SysTick() {
    board::count_tim2_overflow();
    MACHINE.with(|m| m.check_limits());
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
    cortex_m::peripheral::SCB::sys_reset()
}
