//! LM3S6965 registers this board touches (addresses and bits from the LM3S6965 data sheet), accessed volatile.
//!
//! The device crate (`lm3s6965`) only names the interrupts, so the few registers the glue needs are written
//! out here; every access goes through [`read`]/[`write`].

/// System control: reset cause (RESC), clock configuration (RCC), clock gating (RCGC0..2).
pub(crate) mod sysctl {
    pub(crate) const RESC: usize = 0x400F_E05C;
    pub(crate) const RCC: usize = 0x400F_E060;
    pub(crate) const RCGC0: usize = 0x400F_E100;
    pub(crate) const RCGC1: usize = 0x400F_E104;
    pub(crate) const RCGC2: usize = 0x400F_E108;
    /// RESC bits.
    pub(crate) const RESC_EXT: u32 = 1 << 0;
    pub(crate) const RESC_POR: u32 = 1 << 1;
    pub(crate) const RESC_BOR: u32 = 1 << 2;
    pub(crate) const RESC_WDT: u32 = 1 << 3;
    pub(crate) const RESC_SW: u32 = 1 << 4;
}

/// GPIO port base addresses (the APB aperture) and register offsets.
pub(crate) mod gpio {
    pub(crate) const PORT_B: usize = 0x4000_5000;
    pub(crate) const PORT_D: usize = 0x4000_7000;
    pub(crate) const PORT_E: usize = 0x4002_4000;
    /// GPIODATA: the address bits [9:2] mask the bits a read or write touches.
    pub(crate) const DATA: usize = 0x000;
    pub(crate) const DIR: usize = 0x400;
    pub(crate) const AFSEL: usize = 0x420;
    pub(crate) const PUR: usize = 0x510;
    pub(crate) const DEN: usize = 0x51C;
}

/// UART0 (PL011 variant).
pub(crate) mod uart {
    pub(crate) const BASE: usize = 0x4000_C000;
    pub(crate) const DR: usize = BASE;
    pub(crate) const FR: usize = BASE + 0x018;
    pub(crate) const IBRD: usize = BASE + 0x024;
    pub(crate) const FBRD: usize = BASE + 0x028;
    pub(crate) const LCRH: usize = BASE + 0x02C;
    pub(crate) const CTL: usize = BASE + 0x030;
    pub(crate) const IM: usize = BASE + 0x038;
    pub(crate) const ICR: usize = BASE + 0x044;
    pub(crate) const FR_RXFE: u32 = 1 << 4;
    pub(crate) const FR_TXFF: u32 = 1 << 5;
    /// Receive and receive-timeout interrupts.
    pub(crate) const IM_RX: u32 = (1 << 4) | (1 << 6);
    pub(crate) const LCRH_8N1: u32 = 0b11 << 5;
    pub(crate) const CTL_ON: u32 = (1 << 0) | (1 << 8) | (1 << 9);
}

/// General-purpose timer 0, used as one 32-bit one-shot timer (timer A).
pub(crate) mod timer0 {
    pub(crate) const BASE: usize = 0x4003_0000;
    pub(crate) const CFG: usize = BASE;
    pub(crate) const TAMR: usize = BASE + 0x04;
    pub(crate) const CTL: usize = BASE + 0x0C;
    pub(crate) const IMR: usize = BASE + 0x18;
    pub(crate) const ICR: usize = BASE + 0x24;
    pub(crate) const TAILR: usize = BASE + 0x28;
    pub(crate) const TAMR_ONE_SHOT: u32 = 1;
    pub(crate) const TIMEOUT: u32 = 1;
    pub(crate) const CTL_TAEN: u32 = 1;
}

/// General-purpose timer 1, a 1 kHz periodic tick that samples the endstops (timer A).
pub(crate) mod timer1 {
    pub(crate) const BASE: usize = 0x4003_1000;
    pub(crate) const CFG: usize = BASE;
    pub(crate) const TAMR: usize = BASE + 0x04;
    pub(crate) const CTL: usize = BASE + 0x0C;
    pub(crate) const IMR: usize = BASE + 0x18;
    pub(crate) const ICR: usize = BASE + 0x24;
    pub(crate) const TAILR: usize = BASE + 0x28;
    pub(crate) const TAMR_PERIODIC: u32 = 2;
}

/// Watchdog timer 0: interrupt at the first time-out, reset at the second.
pub(crate) mod wdt {
    pub(crate) const BASE: usize = 0x4000_0000;
    pub(crate) const LOAD: usize = BASE;
    pub(crate) const CTL: usize = BASE + 0x008;
    pub(crate) const CTL_INTEN: u32 = 1 << 0;
    pub(crate) const CTL_RESEN: u32 = 1 << 1;
}

/// Read a register.
#[inline(always)]
pub(crate) fn read(addr: usize) -> u32 {
    // SAFETY: `addr` is one of the memory-mapped register addresses above (aligned, always mapped).
    unsafe { (addr as *const u32).read_volatile() }
}

/// Write a register.
#[inline(always)]
pub(crate) fn write(addr: usize, value: u32) {
    // SAFETY: as for `read`; writes to these registers have no memory-safety effects.
    unsafe { (addr as *mut u32).write_volatile(value) }
}

/// Set the masked pins of a GPIO port (`mask`) to `value` without touching the others (GPIODATA masking).
#[inline(always)]
pub(crate) fn gpio_write(port: usize, mask: u8, value: u8) {
    write(port + gpio::DATA + (usize::from(mask) << 2), u32::from(value));
}

/// Read all pins of a GPIO port.
#[inline(always)]
pub(crate) fn gpio_read(port: usize) -> u8 {
    (read(port + gpio::DATA + (0xFF << 2)) & 0xFF) as u8
}
