//! # tick-bench — what one stepper interrupt costs on a Cortex-M4F
//!
//! Runs the firmware core on QEMU's `mps2-an386` (a Cortex-M4 with FPU, like the STM32L476) with the Nucleo
//! board's step path — the same [`plotter_board::stm32_step`] code (step pins from the mask table, pulse end armed
//! on TIM2's compare channels 2 and 3, next compare from [`plotter_board::deadline`]), the same interrupt body
//! without a critical section — on register stand-ins in RAM at fixed addresses (the mps2 has no STM32
//! peripherals). `cargo xtask tick-cost` runs it with QEMU's execution trace and prices every instruction executed
//! between [`bench_tick`]'s entry and [`bench_tick_done`] with the Cortex-M4's documented cycle counts.
//!
//! [`bench_tick`] is the body of the Nucleo's TIM2 interrupt: acknowledge compare 1 (its only interrupt), then
//! `Machine::on_timer`.
//! On the board the step pulse ends by DMA (no instructions); here the main loop lowers the stand-in pins after
//! each measured tick. The workload is the worst this firmware sees: moves of three axes at once (every event steps
//! several axes), short blocks with acceleration and deceleration (every ramp segment change on the slow path), a
//! block change at every block end (loaded in the interrupt), hard limits armed (checked by the 1 kHz sampling
//! tick, not per event — as on the board), and a feed hold that decelerates across block boundaries.
#![no_std]
#![no_main]

use core::sync::atomic::AtomicU32;

use cortex_m_rt::entry;
use cortex_m_semihosting::{debug, hprintln};
use plotter_board::deadline::Deadline;
use plotter_board::debounce::Debouncer;
use plotter_board::shared::Shared;
use plotter_board::stm32_step::{StepOutputs, read, tim, write};
use plotter_fw::hal::{Clock, Endstops, SerialOut, StepPins, StepTimer};
use plotter_fw::machine::Machine;
use plotter_fw::{Axis, MachineConfig};

/// Stand-ins for the Nucleo's peripherals: RAM that `memory.x` keeps out of the program's, laid out like the
/// STM32's register blocks (TIM2, GPIOA..C, TIM3), so the step path runs the Nucleo's code with other base
/// addresses.
const PERIPH: usize = 0x203F_0000;
const TIM2: usize = PERIPH;
const GPIOA: usize = PERIPH + 0x400;
const GPIOB: usize = PERIPH + 0x800;
const GPIOC: usize = PERIPH + 0xC00;
const TIM3: usize = PERIPH + 0x1000;
const DIR_A: usize = PERIPH + 0x1400;
const DIR_B: usize = PERIPH + 0x1800;
/// GPIO input data register offset.
const IDR: usize = 0x10;

/// As the Nucleo's: step pins X PA10, Y PB3, Z PB5, E PA6; 3 µs pulses, 2 µs low; the servo's compare register.
const STEP_OUT: StepOutputs = StepOutputs::new([GPIOA, GPIOB], [(0, 10), (1, 3), (1, 5), (0, 6)], TIM2, 3, TIM3 + 0x3C);
const LEAD: u32 = 3 + 2;
/// The Nucleo's direction pins (PB4, PB10, PA8, PA5), on stand-in ports of their own here so that the step
/// ports' BSRR stand-ins show only the step pins (the store is the same).
const DIR: [(usize, u32); 4] = [(DIR_B, 4), (DIR_B, 10), (DIR_A, 8), (DIR_A, 5)];
/// Endstops X PC7, Y PB6, Z PA7.
const ENDSTOP: [(usize, u32); 3] = [(GPIOC, 7), (GPIOB, 6), (GPIOA, 7)];

/// TIM2 overflows (the Nucleo's clock extension, counted by its SysTick; none happen in the bench).
static TIM2_WRAPS: AtomicU32 = AtomicU32::new(0);

/// The NVIC's first interrupt clear-pending register, and the STM32L476's TIM2 interrupt line.
const NVIC_ICPR0: usize = 0xE000_E280;
const TIM2_IRQ: u32 = 28;

/// Switch `I` as a mask bit: set when its pin reads low (pressed).
#[inline(always)]
fn endstop_low<const I: usize>() -> u8 {
    let (port, n) = ENDSTOP[I];
    u8::from(read(port + IDR) & (1 << n) == 0) << I
}

struct BenchHal {
    deadline: Deadline<LEAD>,
    debounce: Debouncer,
}

impl StepPins for BenchHal {
    #[inline]
    fn set_dir(&mut self, axis: Axis, level: bool) {
        let (port, n) = DIR[axis.index()];
        write(port + plotter_board::stm32_step::BSRR, if level { 1 << n } else { 1 << (n + 16) });
    }
    #[inline]
    fn step(&mut self, axis: Axis) {
        self.step_axes(axis.bit());
    }
    /// As the Nucleo board (built without the `servo-pen` feature).
    #[inline(always)]
    fn step_axes(&mut self, mask: u8) {
        self.step_axes_read(mask);
    }
    #[inline(always)]
    fn step_axes_read(&mut self, mask: u8) -> u32 {
        STEP_OUT.step_event(mask, None)
    }
    fn enable_motors(&mut self, _on: bool) {}
}

impl Endstops for BenchHal {
    #[inline]
    fn pressed(&mut self) -> u8 {
        let raw = endstop_low::<0>() | endstop_low::<1>() | endstop_low::<2>();
        if raw == 0 && self.debounce.is_quiet() {
            return 0;
        }
        let now = self.now();
        self.debounce.update(raw, now)
    }
}

impl StepTimer for BenchHal {
    #[inline(always)]
    fn schedule(&mut self, ticks: u32) {
        STEP_OUT.schedule(&mut self.deadline, ticks);
    }
    #[inline(always)]
    fn schedule_next(&mut self, ticks: u32) {
        STEP_OUT.schedule_next(&self.deadline, ticks);
    }
    #[inline(always)]
    fn schedule_next_from(&mut self, read: u32, ticks: u32) {
        STEP_OUT.schedule_next_from(&self.deadline, read, ticks);
    }
    fn cancel(&mut self) {
        STEP_OUT.cancel(&mut self.deadline);
        // As the Nucleo's: drop a pending TIM2 interrupt (its NVIC line, 28, in the interrupt clear-pending
        // register; QEMU's NVIC has it too).
        write(NVIC_ICPR0, 1 << TIM2_IRQ);
    }
}

impl SerialOut for BenchHal {
    fn write(&mut self, _bytes: &[u8]) {}
}

impl Clock for BenchHal {
    #[inline]
    fn now(&self) -> u64 {
        let wraps = TIM2_WRAPS.load(core::sync::atomic::Ordering::Relaxed);
        (u64::from(wraps) << 32) | u64::from(read(TIM2 + tim::CNT))
    }
}

static MACHINE: Shared<BenchHal> = Shared::new();

/// The Nucleo's TIM2 interrupt body.
#[unsafe(no_mangle)]
#[inline(never)]
pub extern "C" fn bench_tick() {
    STEP_OUT.step_interrupt();
    // SAFETY: as on the Nucleo: only this function runs the step path, everything else goes through `with`;
    // `main` installs the machine before the first tick.
    unsafe { MACHINE.on_timer_installed() };
}

/// Marks the end of a measured tick in the execution trace.
#[unsafe(no_mangle)]
#[inline(never)]
pub extern "C" fn bench_tick_done() {
    cortex_m::asm::nop();
}

/// The workload, G-code.
const PROGRAM: &[&[u8]] = &[
    b"G91\n",
    // A long three-axis move: acceleration, cruise and deceleration.
    b"G1 X12 Y8 Z2 F9000\n",
    // Short zig-zag moves: sharp corners, so every block accelerates and decelerates; direction changes.
    b"G1 X0.6 Y0.5 Z0.2 F6000\n",
    b"G1 X-0.5 Y0.6 Z-0.2\n",
    b"G1 X0.6 Y-0.4 Z0.2\n",
    b"G1 X-0.6 Y-0.5 Z-0.2\n",
];

/// The step pins raised by the last event (the BSRR stand-ins hold the last word written: its low half is the
/// pins set; the pulse end's word has none).
fn step_pins() -> u32 {
    let a = read(GPIOA + plotter_board::stm32_step::BSRR) & 0xFFFF;
    let b = read(GPIOB + plotter_board::stm32_step::BSRR) & 0xFFFF;
    (a & ((1 << 10) | (1 << 6))) << 16 | (b & ((1 << 3) | (1 << 5)))
}

fn feed(line: &[u8]) {
    for &b in line {
        MACHINE.receive(b);
    }
}

#[entry]
fn main() -> ! {
    // Endstops released (pins high).
    for port in [GPIOA, GPIOB, GPIOC] {
        write(port + IDR, 0xFFFF);
    }
    let cfg = MachineConfig::xy_plotter();
    let hal = BenchHal { deadline: Deadline::new(), debounce: Debouncer::new(1_000) };
    MACHINE.install(Machine::new(hal, cfg));
    let mut ticks = 0u32;
    let mut steps = 0u32;
    let mut lines = 0usize;
    let mut held = false;
    loop {
        // The timer "fires": the counter jumps to the compare value.
        let due = MACHINE.with(|m| m.hal().deadline.is_running().then(|| STEP_OUT.deadline())).flatten();
        if let Some(at) = due {
            // The counter reaches the compare value: the flag goes up, the interrupt runs. (The flags of the real
            // register are cleared by writing 0 and kept by writing 1; in this RAM stand-in the interrupt's
            // clearing write leaves its complement, so the flags are set afresh here, compare 1's alone.)
            write(TIM2 + tim::CNT, at);
            write(TIM2 + tim::SR, tim::CC1);
            bench_tick();
            bench_tick_done();
            steps += step_pins().count_ones();
            // What the pulse-end DMA does on the board (no CPU instructions): the step pins go low.
            STEP_OUT.lower_all();
            ticks += 1;
            // A feed hold in the middle of the zig-zags, resumed once stopped.
            if ticks == 1_500 {
                MACHINE.receive(b'!');
                held = true;
            }
        }
        let (idle, held_now, room) = MACHINE
            .with(|m| {
                m.poll();
                (m.is_idle(), m.state() == plotter_fw::realtime::MachineState::Held, m.rx_free())
            })
            .unwrap_or((true, false, 0));
        if held && held_now {
            held = false;
            MACHINE.receive(b'~');
            continue;
        }
        // Keep the planner queue filled, so block changes happen inside the interrupt as in a real plot.
        if room > 64 {
            let next = match lines {
                0 | 1 => Some(PROGRAM[lines]),
                n if n < 2 + 4 * 12 => Some(PROGRAM[2 + (n - 2) % 4]),
                _ => None,
            };
            if let Some(next) = next {
                feed(next);
                lines += 1;
                continue;
            }
        }
        if idle && lines >= 2 + 4 * 12 {
            break;
        }
    }
    hprintln!("tick-bench: {} ticks {} steps", ticks, steps);
    debug::exit(debug::EXIT_SUCCESS);
    loop {
        cortex_m::asm::bkpt();
    }
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo<'_>) -> ! {
    hprintln!("tick-bench panicked: {}", info);
    debug::exit(debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::bkpt();
    }
}
