//! The boards `cargo xtask firmware` knows: crate, target, memory map and budget.

/// One board image.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Board {
    /// Name (`--board`), also the crate under `plotter-fw/boards/` and the image file name.
    pub(crate) name: &'static str,
    /// Rust target.
    pub(crate) target: &'static str,
    /// Flash start (where the `.bin` begins).
    pub(crate) flash_base: u32,
    /// RAM start.
    pub(crate) ram_base: u32,
    /// The chip's flash and RAM, bytes.
    pub(crate) flash_size: u64,
    /// RAM size.
    pub(crate) ram_size: u64,
    /// Budget the image must meet (flash, RAM), bytes; `None`: reported only.
    pub(crate) budget: Option<(u64, u64)>,
    /// What it is.
    pub(crate) about: &'static str,
}

/// The project's budget for the seed board: ≤ 76 KiB flash (of its 1024 KiB; 64 KiB until the integer step timing
/// and the heater G-code layer came in, 72 KiB until a servo pen's landing after a feed hold — the hold's drop
/// deferral, the resume's catch-up and the servo model, issue 39 — took the image to 72.9 KiB; the f64 soft-float
/// of `Decimal` (`__adddf3`, `__muldf3`, `__divdf3`: 2.6 KiB) and the range checks, ~3 KiB, are the first things to
/// cut to get back under a smaller one), ≤ 32 KiB static RAM.
pub(crate) const BUDGET: (u64, u64) = (76 * 1024, 32 * 1024);

/// Every board.
pub(crate) const BOARDS: [Board; 2] = [
    Board {
        name: "nucleo-l476rg",
        target: "thumbv7em-none-eabihf",
        flash_base: 0x0800_0000,
        ram_base: 0x2000_0000,
        flash_size: 1024 * 1024,
        ram_size: 96 * 1024,
        budget: Some(BUDGET),
        about: "ST Nucleo-L476RG (Cortex-M4F, 80 MHz)",
    },
    Board {
        name: "qemu-lm3s6965",
        target: "thumbv7m-none-eabi",
        flash_base: 0x0000_0000,
        ram_base: 0x2000_0000,
        flash_size: 256 * 1024,
        ram_size: 64 * 1024,
        // A Cortex-M3 without FPU: the float maths is software, so the image is larger; reported, not gated.
        budget: None,
        about: "Stellaris LM3S6965 as emulated by qemu-system-arm -M lm3s6965evb (Cortex-M3, CI)",
    },
];

/// The board named `name`.
pub(crate) fn find(name: &str) -> Option<Board> {
    BOARDS.iter().copied().find(|b| b.name == name)
}
