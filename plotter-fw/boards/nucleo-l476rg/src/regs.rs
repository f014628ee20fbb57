//! STM32L476 registers this board drives directly (addresses and bits from ST's reference manual RM0351),
//! accessed volatile. The clock tree is set up by stm32l4xx-hal; the hot paths (GPIO set/reset, the TIM2
//! compare channels, the USART2/DMA receive ring) are plain register accesses, which is what they are anyway.

pub(crate) use plotter_board::stm32_step::{read, write};

/// Read-modify-write: clear `clear`, then set `set`.
#[inline(always)]
pub(crate) fn modify(addr: usize, clear: u32, set: u32) {
    write(addr, (read(addr) & !clear) | set);
}

/// Reset and clock control.
pub(crate) mod rcc {
    pub(crate) const AHB1ENR: usize = 0x4002_1048;
    pub(crate) const AHB2ENR: usize = 0x4002_104C;
    pub(crate) const APB1ENR1: usize = 0x4002_1058;
    pub(crate) const CSR: usize = 0x4002_1094;
    pub(crate) const CSR_RMVF: u32 = 1 << 23;
    pub(crate) const CSR_PINRSTF: u32 = 1 << 26;
    pub(crate) const CSR_BORRSTF: u32 = 1 << 27;
    pub(crate) const CSR_SFTRSTF: u32 = 1 << 28;
    pub(crate) const CSR_IWDGRSTF: u32 = 1 << 29;
    pub(crate) const CSR_WWDGRSTF: u32 = 1 << 30;
}

/// GPIO register offsets.
pub(crate) mod gpio {
    pub(crate) const MODER: usize = 0x00;
    pub(crate) const PUPDR: usize = 0x0C;
    pub(crate) const IDR: usize = 0x10;
    pub(crate) const BSRR: usize = 0x18;
    pub(crate) const AFRL: usize = 0x20;
}

/// General-purpose timers (TIM2: 32-bit step timer and clock; TIM3: servo PWM); the offsets and bits of the step
/// path are [`plotter_board::stm32_step::tim`]'s.
pub(crate) mod tim {
    pub(crate) use plotter_board::stm32_step::tim::{CNT, CR1, DIER, EGR, SR, UIF};
    pub(crate) const TIM2: usize = 0x4000_0000;
    pub(crate) const TIM3: usize = 0x4000_0400;
    #[cfg_attr(not(feature = "servo-pen"), allow(dead_code, reason = "servo PWM only"))]
    pub(crate) const CCMR2: usize = 0x1C;
    #[cfg_attr(not(feature = "servo-pen"), allow(dead_code, reason = "servo PWM only"))]
    pub(crate) const CCER: usize = 0x20;
    pub(crate) const PSC: usize = 0x28;
    pub(crate) const ARR: usize = 0x2C;
    #[cfg_attr(not(feature = "servo-pen"), allow(dead_code, reason = "servo PWM only"))]
    pub(crate) const CCR3: usize = 0x3C;
}

/// USART2 (the ST-LINK virtual COM port).
pub(crate) mod usart2 {
    pub(crate) const BASE: usize = 0x4000_4400;
    pub(crate) const CR1: usize = BASE;
    pub(crate) const CR3: usize = BASE + 0x08;
    pub(crate) const BRR: usize = BASE + 0x0C;
    pub(crate) const ISR: usize = BASE + 0x1C;
    pub(crate) const ICR: usize = BASE + 0x20;
    pub(crate) const RDR: usize = BASE + 0x24;
    pub(crate) const TDR: usize = BASE + 0x28;
    pub(crate) const CR1_UE: u32 = 1 << 0;
    pub(crate) const CR1_RE: u32 = 1 << 2;
    pub(crate) const CR1_TE: u32 = 1 << 3;
    pub(crate) const CR1_IDLEIE: u32 = 1 << 4;
    pub(crate) const CR1_TXEIE: u32 = 1 << 7;
    pub(crate) const CR3_DMAR: u32 = 1 << 6;
    pub(crate) const ISR_IDLE: u32 = 1 << 4;
    pub(crate) const ISR_TXE: u32 = 1 << 7;
    /// Clear idle, overrun, noise, framing and parity flags.
    pub(crate) const ICR_ERRORS_IDLE: u32 = 0b1_1111;
}

/// DMA1: channel 6 = USART2_RX (request 2); channel 1 = TIM2_CH3 and channel 7 = TIM2_CH2 (request 4), the
/// step pulses' ends.
pub(crate) mod dma1 {
    pub(crate) const BASE: usize = 0x4002_0000;
    pub(crate) const CCR1: usize = BASE + 0x08;
    pub(crate) const CNDTR1: usize = BASE + 0x0C;
    pub(crate) const CPAR1: usize = BASE + 0x10;
    pub(crate) const CMAR1: usize = BASE + 0x14;
    pub(crate) const CCR7: usize = BASE + 0x80;
    pub(crate) const CNDTR7: usize = BASE + 0x84;
    pub(crate) const CPAR7: usize = BASE + 0x88;
    pub(crate) const CMAR7: usize = BASE + 0x8C;
    /// CCR: enable, memory to peripheral, circular, 32-bit memory and peripheral, no increments.
    pub(crate) const CCR_PULSE_END: u32 = (1 << 0) | (1 << 4) | (1 << 5) | (0b10 << 8) | (0b10 << 10);
    pub(crate) const IFCR: usize = BASE + 0x04;
    pub(crate) const CCR6: usize = BASE + 0x6C;
    pub(crate) const CNDTR6: usize = BASE + 0x70;
    pub(crate) const CPAR6: usize = BASE + 0x74;
    pub(crate) const CMAR6: usize = BASE + 0x78;
    pub(crate) const CSELR: usize = BASE + 0xA8;
    /// Channel 6's flags in ISR/IFCR.
    pub(crate) const CH6_FLAGS: u32 = 0xF << 20;
    /// CCR: enable, transfer-complete and half-transfer interrupts, circular, memory increment (8-bit both).
    pub(crate) const CCR_RX_CIRC: u32 = (1 << 0) | (1 << 1) | (1 << 2) | (1 << 5) | (1 << 7);
}

/// Independent watchdog (LSI, 32 kHz).
pub(crate) mod iwdg {
    pub(crate) const KR: usize = 0x4000_3000;
    pub(crate) const PR: usize = 0x4000_3004;
    pub(crate) const RLR: usize = 0x4000_3008;
    pub(crate) const KEY_START: u32 = 0xCCCC;
    pub(crate) const KEY_UNLOCK: u32 = 0x5555;
    pub(crate) const KEY_FEED: u32 = 0xAAAA;
}
