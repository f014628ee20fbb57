//! The HAL of the Nucleo-L476RG: [`plotter_fw::hal`] on its GPIO, TIM2, USART2 + DMA and TIM3.
//!
//! - **Clock**: TIM2 runs free at 1 MHz ([`plotter_fw::TICK_HZ`]; 80 MHz ÷ 80), 32 bits, its overflow
//!   interrupt extends it to 64 ([`now`]).
//! - **Step timer**: TIM2 compare channel 1 at the absolute deadline ([`plotter_board::deadline`]): output-compare
//!   timing is exact, the interrupt's latency never shifts the steps.
//! - **Steps** ([`plotter_board::stm32_step`]): the tick sets the step pins (one BSRR store per port) and TIM2's
//!   compare channels 2 (port A) and 3 (port B) end the pulse [`PULSE_TICKS`] later through DMA1 channels 7 and 1,
//!   which store the port's "step pins low" word into its BSRR — no pulse-end interrupt. High ≥ 2 µs, low ≥ 2 µs
//!   (DRV8825: 1.9 µs each; A4988: 1 µs).
//! - **Serial**: USART2 receives by DMA into a 256-byte circular buffer (no byte is ever lost to interrupt
//!   latency); the half/complete and line-idle interrupts hand the new bytes to `Machine::receive`. Replies go
//!   through a 512-byte ring drained by the transmit-empty interrupt.
//! - **Endstops**: pull-up inputs, filtered by [`plotter_board::debounce`], sampled at 1 kHz by SysTick, which
//!   hands them to `Machine::check_limits` (hard limits during normal moves: within 2 ms, the debounce's two
//!   readings), and at every read (the step interrupt reads them at each event of a homing move only). X's PC7 and
//!   Z's PA7 share EXTI line 7, so a pin-change interrupt cannot serve all three.
//! - **Pen servo** (feature `servo-pen`): TIM3 CH3 PWM at 50 Hz, driven to the angle of each `M3`/`M5` and servo
//!   step block (protocol 3), and following the Z steps of a Z-lift profile ([`plotter_board::servo`]) between the
//!   configured `pen.servo_down_deg` and `pen.servo_up_deg` pulses.

use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m::peripheral::NVIC;
use stm32l4xx_hal::pac::Interrupt;

use plotter_board::deadline::Deadline;
use plotter_board::debounce::Debouncer;
use plotter_board::note::ResetCause;
use plotter_board::servo::{ServoConfig, ServoPen};
use plotter_board::stm32_step::StepOutputs;
use plotter_fw::hal::{Clock, Endstops, SerialOut, StepPins, StepTimer, servo_pulse_us};
use plotter_fw::{Axis, MachineConfig};

use crate::pins::{self, Pin};
use crate::regs::{self, dma1, gpio, iwdg, rcc, tim, usart2};

/// Core and APB clock, Hz.
pub(crate) const SYSCLK_HZ: u32 = 80_000_000;
/// Step pulse length, µs.
const PULSE_TICKS: u32 = 3;
/// Shortest step pulse low time, µs (the step timer's lead: a late event comes at least this after a pulse end).
const LOW_TICKS: u32 = 2;
/// The step pins (X PA10, Y PB3, Z PB5, E PA6: ports A = 0 and B = 1) and TIM2.
const STEP_OUT: StepOutputs = StepOutputs::new(
    [pins::GPIOA, pins::GPIOB],
    [step_pin(0), step_pin(1), step_pin(2), step_pin(3)],
    tim::TIM2,
    PULSE_TICKS,
    tim::TIM3 + tim::CCR3,
);
/// Axis `a`'s step pin as (port 0 = A or 1 = B, pin); the step pins must be on those two ports.
const fn step_pin(a: usize) -> (u8, u8) {
    let p = pins::STEP[a];
    assert!(p.port == pins::GPIOA || p.port == pins::GPIOB, "step pins on ports A and B only");
    (if p.port == pins::GPIOA { 0 } else { 1 }, p.n)
}

/// The words the pulse-end DMA stores (memory to peripheral).
static PULSE_END: [u32; 2] = [STEP_OUT.pulse_end_transfers()[0].0, STEP_OUT.pulse_end_transfers()[1].0];
/// Endstop release window, µs.
const DEBOUNCE_TICKS: u64 = 1_000;
/// Receive ring size (DMA, circular).
const RX_RING: usize = 256;

/// TIM2 overflows since start.
static TIM2_WRAPS: AtomicU32 = AtomicU32::new(0);
/// The pen-up servo pulse, µs, from the configuration's `pen.servo_up_deg` (the fault path lifts the pen to it).
static SERVO_UP_PULSE: AtomicU32 = AtomicU32::new(0);

/// The DMA's receive ring. Written by the DMA controller, read by [`drain_rx`].
static mut RX_DMA: [u8; RX_RING] = [0; RX_RING];
/// Next ring index to read (only [`drain_rx`] touches it, from interrupts at one priority).
static RX_READ: AtomicU32 = AtomicU32::new(0);

fn set(p: Pin) {
    regs::write(p.port + gpio::BSRR, 1 << p.n);
}

/// Switch `I` as a mask bit: set when it is fitted and its pin reads low (pressed).
#[inline(always)]
fn endstop_low<const I: usize>() -> u8 {
    match pins::ENDSTOP[I] {
        Some(p) if regs::read(p.port + gpio::IDR) & (1 << p.n) == 0 => 1 << I,
        _ => 0,
    }
}

fn reset(p: Pin) {
    regs::write(p.port + gpio::BSRR, 1 << (u32::from(p.n) + 16));
}

/// Pin mode: 0 input, 1 output, 2 alternate.
fn mode(p: Pin, m: u32) {
    let shift = 2 * u32::from(p.n);
    regs::modify(p.port + gpio::MODER, 0b11 << shift, m << shift);
}

fn pull_up(p: Pin) {
    let shift = 2 * u32::from(p.n);
    regs::modify(p.port + gpio::PUPDR, 0b11 << shift, 0b01 << shift);
}

/// µs since start. Correct inside critical sections too: an overflow SysTick has not counted yet
/// ([`count_tim2_overflow`]) is counted from the flag.
pub(crate) fn now() -> u64 {
    let wraps = TIM2_WRAPS.load(Ordering::Relaxed);
    let cnt = regs::read(tim::TIM2 + tim::CNT);
    let pending = regs::read(tim::TIM2 + tim::SR) & tim::UIF != 0;
    let wraps = u64::from(wraps) + u64::from(pending && cnt < u32::MAX / 2);
    (wraps << 32) | u64::from(cnt)
}

/// Reset cause from RCC_CSR (then cleared). A software reset also pulls the reset pin, so it is checked first.
pub(crate) fn reset_cause() -> ResetCause {
    let csr = regs::read(rcc::CSR);
    regs::modify(rcc::CSR, 0, rcc::CSR_RMVF);
    if csr & (rcc::CSR_IWDGRSTF | rcc::CSR_WWDGRSTF) != 0 {
        ResetCause::Watchdog
    } else if csr & rcc::CSR_SFTRSTF != 0 {
        ResetCause::Software
    } else if csr & rcc::CSR_BORRSTF != 0 {
        ResetCause::PowerOn
    } else if csr & rcc::CSR_PINRSTF != 0 {
        ResetCause::Pin
    } else {
        ResetCause::Unknown
    }
}

/// Pins, TIM2, TIM3, USART2 + DMA and the watchdog (after the HAL set the clocks to 80 MHz).
pub(crate) fn init() {
    // Clock gates: GPIOA..C; DMA1; TIM2, TIM3, USART2.
    regs::modify(rcc::AHB2ENR, 0, 0b111);
    regs::modify(rcc::AHB1ENR, 0, 1);
    regs::modify(rcc::APB1ENR1, 0, (1 << 0) | (1 << 1) | (1 << 17));
    let _ = regs::read(rcc::APB1ENR1);

    // Drivers disabled until start-up is done; step and direction low.
    set(pins::ENABLE);
    mode(pins::ENABLE, 1);
    for p in pins::STEP.iter().chain(&pins::DIR) {
        reset(*p);
        mode(*p, 1);
    }
    for p in pins::ENDSTOP.iter().flatten() {
        pull_up(*p);
        mode(*p, 0);
    }

    // TIM2: 1 MHz, free-running over 32 bits; its overflows (the clock's upper half) are counted by SysTick
    // (`count_tim2_overflow`), so its only interrupt is the step event's compare 1 (enabled while stepping).
    let t = tim::TIM2;
    regs::write(t + tim::PSC, SYSCLK_HZ / plotter_fw::TICK_HZ - 1);
    regs::write(t + tim::ARR, u32::MAX);
    regs::write(t + tim::EGR, 1);
    regs::write(t + tim::SR, 0);
    regs::write(t + tim::DIER, plotter_board::stm32_step::tim::CC2DE_CC3DE);
    regs::write(t + tim::CR1, 1);
    // Pulse ends: TIM2 compare 2 → DMA1 channel 7 → port A's BSRR, compare 3 → channel 1 → port B's (request 4).
    regs::modify(dma1::CSELR, (0xF << 24) | 0xF, (4 << 24) | 4);
    let [(_, bsrr_a), (_, bsrr_b)] = STEP_OUT.pulse_end_transfers();
    for (ch, (cpar, cmar, cndtr, ccr), bsrr) in [
        (0usize, (dma1::CPAR7, dma1::CMAR7, dma1::CNDTR7, dma1::CCR7), bsrr_a),
        (1, (dma1::CPAR1, dma1::CMAR1, dma1::CNDTR1, dma1::CCR1), bsrr_b),
    ] {
        regs::write(cpar, u32::try_from(bsrr).unwrap_or(0));
        #[allow(clippy::cast_possible_truncation, reason = "a Cortex-M address fits u32")]
        regs::write(cmar, core::ptr::addr_of!(PULSE_END[ch]) as usize as u32);
        regs::write(cndtr, 1);
        regs::write(ccr, dma1::CCR_PULSE_END);
    }

    // USART2 on PA2 (TX) / PA3 (RX), alternate function 7; 8N1; DMA reception into the ring.
    for n in [2u8, 3] {
        let p = Pin { port: pins::GPIOA, n };
        regs::modify(pins::GPIOA + gpio::AFRL, 0xF << (4 * n), 7 << (4 * n));
        mode(p, 2);
    }
    regs::write(usart2::CR1, 0);
    regs::write(usart2::BRR, (SYSCLK_HZ + pins::BAUD / 2) / pins::BAUD);
    regs::write(usart2::CR3, usart2::CR3_DMAR);
    regs::modify(dma1::CSELR, 0xF << 20, 2 << 20);
    regs::write(dma1::CPAR6, u32::try_from(usart2::RDR).unwrap_or(0));
    // Addresses are 32-bit on this chip.
    #[allow(clippy::cast_possible_truncation, reason = "a Cortex-M address fits u32")]
    regs::write(dma1::CMAR6, core::ptr::addr_of!(RX_DMA) as usize as u32);
    regs::write(dma1::CNDTR6, u32::try_from(RX_RING).unwrap_or(0));
    regs::write(dma1::CCR6, dma1::CCR_RX_CIRC);
    regs::write(usart2::ICR, usart2::ICR_ERRORS_IDLE);
    regs::write(usart2::CR1, usart2::CR1_UE | usart2::CR1_RE | usart2::CR1_TE | usart2::CR1_IDLEIE);

    #[cfg(feature = "servo-pen")]
    {
        // TIM3 CH3 on PB0 (AF2): 1 MHz, 20 ms period, PWM mode 1 with preload; no pulse until `NucleoHal::new`
        // sets the configured pen-up angle's.
        regs::modify(pins::GPIOB + gpio::AFRL, 0xF << (4 * pins::SERVO.n), 2 << (4 * pins::SERVO.n));
        mode(pins::SERVO, 2);
        let t = tim::TIM3;
        regs::write(t + tim::PSC, SYSCLK_HZ / 1_000_000 - 1);
        regs::write(t + tim::ARR, 19_999);
        regs::write(t + tim::CCMR2, (0b110 << 4) | (1 << 3));
        regs::write(t + tim::CCER, 1 << 8);
        regs::write(t + tim::EGR, 1);
        regs::write(t + tim::CR1, 1);
    }

    // Independent watchdog: 32 kHz ÷ 64, 1000 counts: 2 s without a feed resets the chip.
    regs::write(iwdg::KR, iwdg::KEY_START);
    regs::write(iwdg::KR, iwdg::KEY_UNLOCK);
    regs::write(iwdg::PR, 4);
    regs::write(iwdg::RLR, 1_000);
    regs::write(iwdg::KR, iwdg::KEY_FEED);
}

/// Restart the watchdog count (main loop).
pub(crate) fn feed_watchdog() {
    regs::write(iwdg::KR, iwdg::KEY_FEED);
}

/// Energise the drivers.
pub(crate) fn enable_drivers() {
    reset(pins::ENABLE);
}

/// Fault path: no more timer interrupts, drivers released, step pins low, the servo pen up.
pub(crate) fn emergency_stop() {
    regs::write(tim::TIM2 + tim::DIER, 0);
    // No flag left for an interrupt already pending (the step interrupt does not mask the flags with DIER).
    regs::write(tim::TIM2 + tim::SR, 0);
    set(pins::ENABLE);
    STEP_OUT.lower_all();
    if cfg!(feature = "servo-pen") {
        regs::write(tim::TIM3 + tim::CCR3, SERVO_UP_PULSE.load(Ordering::Relaxed));
    }
}

/// TIM2 interrupt: the step event (compare 1, its only interrupt) is due; acknowledge it.
#[inline(always)]
pub(crate) fn tim2_step_event() {
    STEP_OUT.step_interrupt();
}

/// SysTick (1 kHz): count a TIM2 overflow (every 71 minutes) for [`now`].
pub(crate) fn count_tim2_overflow() {
    STEP_OUT.count_overflow(&TIM2_WRAPS);
}

/// Hand the bytes the DMA has written since the last call to `f` (USART2 idle and DMA half/complete
/// interrupts).
pub(crate) fn drain_rx(mut f: impl FnMut(u8)) {
    regs::write(usart2::ICR, usart2::ICR_ERRORS_IDLE);
    regs::write(dma1::IFCR, dma1::CH6_FLAGS);
    // CNDTR counts the bytes left before the ring wraps (RX_RING..=1).
    let written = (RX_RING - (regs::read(dma1::CNDTR6) as usize).min(RX_RING)) % RX_RING;
    let mut read = RX_READ.load(Ordering::Relaxed) as usize;
    while read != written {
        // SAFETY: a byte of the DMA ring the controller has finished writing (behind its write index).
        let b = unsafe { core::ptr::addr_of!(RX_DMA).cast::<u8>().add(read).read_volatile() };
        f(b);
        read = (read + 1) % RX_RING;
    }
    RX_READ.store(u32::try_from(read).unwrap_or(0), Ordering::Relaxed);
}

/// Whether USART2 wants transmit service.
pub(crate) fn usart2_tx_ready() -> bool {
    regs::read(usart2::ISR) & usart2::ISR_TXE != 0 && regs::read(usart2::CR1) & usart2::CR1_TXEIE != 0
}

/// Whether USART2 saw the line go idle (then the ring is drained).
pub(crate) fn usart2_idle() -> bool {
    regs::read(usart2::ISR) & usart2::ISR_IDLE != 0
}

/// The board as the core sees it.
pub(crate) struct NucleoHal {
    deadline: Deadline<{ PULSE_TICKS + LOW_TICKS }>,
    debounce: Debouncer,
    tx: heapless::Deque<u8, 512>,
    servo: Option<ServoPen>,
}

impl NucleoHal {
    /// After [`init`]. With the `servo-pen` feature the pen servo follows Z between the configured heights.
    pub(crate) fn new(cfg: &MachineConfig) -> Self {
        let servo = cfg!(feature = "servo-pen").then(|| {
            let up_us = servo_pulse_us(cfg.pen.servo_up_deg);
            SERVO_UP_PULSE.store(u32::from(up_us), Ordering::Relaxed);
            regs::write(tim::TIM3 + tim::CCR3, u32::from(up_us));
            let spm = cfg.axis(Axis::Z).steps_per_mm;
            let steps = |mm: f32| plotter_fw::fmath::round_i32(f64::from(mm) * f64::from(spm));
            ServoPen::new(
                ServoConfig {
                    down_z: steps(cfg.pen.down_z_mm),
                    up_z: steps(cfg.pen.up_z_mm),
                    down_us: servo_pulse_us(cfg.pen.servo_down_deg),
                    up_us,
                    forward_level: cfg.axis(Axis::Z).invert_dir,
                },
                steps(cfg.pen.up_z_mm),
            )
        });
        NucleoHal {
            deadline: Deadline::new(),
            debounce: Debouncer::new(DEBOUNCE_TICKS),
            tx: heapless::Deque::new(),
            servo,
        }
    }

    /// Feed the debounce filter a reading of the switches (every read: SysTick's at 1 kHz, homing).
    pub(crate) fn sample_endstops(&mut self) -> u8 {
        let raw = endstop_low::<0>() | endstop_low::<1>() | endstop_low::<2>() | endstop_low::<3>();
        if raw == 0 && self.debounce.is_quiet() {
            return 0;
        }
        self.debounce.update(raw, now())
    }

    /// USART2 transmit-empty: send the next queued byte, or stop asking.
    pub(crate) fn pump_tx(&mut self) {
        match self.tx.pop_front() {
            Some(b) => regs::write(usart2::TDR, u32::from(b)),
            None => regs::modify(usart2::CR1, usart2::CR1_TXEIE, 0),
        }
    }
}

impl StepPins for NucleoHal {
    #[inline]
    fn set_dir(&mut self, axis: Axis, level: bool) {
        let p = pins::DIR[axis.index()];
        if level {
            set(p)
        } else {
            reset(p)
        }
        if axis == Axis::Z
            && let Some(s) = self.servo.as_mut()
        {
            s.set_dir(level);
        }
    }

    #[inline]
    fn step(&mut self, axis: Axis) {
        self.step_axes(axis.bit());
    }

    /// All the event's step pins at once; the timer and DMA end the pulse.
    #[inline(always)]
    fn step_axes(&mut self, mask: u8) {
        self.step_axes_read(mask);
    }

    /// [`StepPins::step_axes`], handing on the counter read for the pulse end.
    #[inline(always)]
    fn step_axes_read(&mut self, mask: u8) -> u32 {
        // Without the `servo-pen` feature there is no servo: the check folds away.
        STEP_OUT.step_event(mask, self.servo.as_mut().filter(|_| cfg!(feature = "servo-pen")))
    }

    fn enable_motors(&mut self, on: bool) {
        if on { reset(pins::ENABLE) } else { set(pins::ENABLE) }
    }

    /// `M3`/`M5` and servo step blocks: the pulse of the angle sent.
    fn set_servo(&mut self, angle_deg: f32) {
        if self.servo.is_some() {
            regs::write(tim::TIM3 + tim::CCR3, u32::from(servo_pulse_us(angle_deg)));
        }
    }
}

impl Endstops for NucleoHal {
    #[inline]
    fn pressed(&mut self) -> u8 {
        self.sample_endstops()
    }
}

impl StepTimer for NucleoHal {
    #[inline(always)]
    fn schedule(&mut self, ticks: u32) {
        STEP_OUT.schedule(&mut self.deadline, ticks);
    }

    #[inline(always)]
    fn schedule_next(&mut self, ticks: u32) {
        STEP_OUT.schedule_next(&self.deadline, ticks);
    }

    /// The counter read by this event's pulse end, not read again.
    #[inline(always)]
    fn schedule_next_from(&mut self, read: u32, ticks: u32) {
        STEP_OUT.schedule_next_from(&self.deadline, read, ticks);
    }
    fn cancel(&mut self) {
        STEP_OUT.cancel(&mut self.deadline);
        // An event that came due while interrupts were masked is stale now: drop it.
        NVIC::unpend(Interrupt::TIM2);
    }
}

impl SerialOut for NucleoHal {
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            if self.tx.push_back(b).is_err() {
                // Ring full (a burst of long reports): send one byte by hand to make room.
                while regs::read(usart2::ISR) & usart2::ISR_TXE == 0 {}
                if let Some(first) = self.tx.pop_front() {
                    regs::write(usart2::TDR, u32::from(first));
                }
                let _ = self.tx.push_back(b);
            }
        }
        regs::modify(usart2::CR1, 0, usart2::CR1_TXEIE);
    }
}

impl Clock for NucleoHal {
    fn now(&self) -> u64 {
        now()
    }
}
