//! Instructions per stepper tick, counted with callgrind.
//!
//! The binary drives `Stepper::tick` (inlined into the board's interrupt handler, so here wrapped in the
//! `#[inline(never)]` function `stepper_tick`) through a long accelerating/cruising/
//! decelerating 3-axis block and a run of short blocks, on a HAL whose pins are plain memory writes, and prints
//! how many ticks it made. Count the instructions executed inside `tick` (inclusive of everything it calls) with
//!
//! ```text
//! cargo bench -p plotter-fw --bench tick_instructions --no-run
//! valgrind --tool=callgrind --toggle-collect='*stepper_tick*' --callgrind-out-file=/tmp/cg.out \
//!     target/release/deps/tick_instructions-<hash>
//! callgrind_annotate /tmp/cg.out | head      # "PROGRAM TOTALS" Ir / ticks printed = instructions per tick
//! ```
//! (`--toggle-collect` counts only while inside `stepper_tick`.) Target: ≤ 150 instructions per tick (x86-64).

use plotter_fw::hal::{Endstops, StepPins};
use plotter_fw::step_block::{StepBlock, Switches};
use plotter_fw::stepper::Stepper;
use plotter_fw::{Axis, NUM_AXES};

/// One step interrupt, as a function of its own for callgrind.
#[inline(never)]
fn stepper_tick(s: &mut Stepper, pins: &mut Pins) -> Option<u32> {
    s.tick(pins)
}

/// Pins as memory: what a board's GPIO writes amount to.
struct Pins {
    dir: [bool; NUM_AXES],
    steps: [u32; NUM_AXES],
}

impl StepPins for Pins {
    #[inline]
    fn set_dir(&mut self, axis: Axis, level: bool) {
        self.dir[axis.index()] = level;
    }
    #[inline]
    fn step(&mut self, axis: Axis) {
        self.steps[axis.index()] += 1;
    }
    fn enable_motors(&mut self, _on: bool) {}
}

impl Endstops for Pins {
    #[inline]
    fn pressed(&mut self) -> u8 {
        0
    }
}

fn main() {
    let mut pins = Pins { dir: [false; NUM_AXES], steps: [0; NUM_AXES] };
    // Hard limits on X, Y, Z are checked at every event, as in the firmware.
    let mut s = Stepper::new(0, 0b0111);
    let long = StepBlock {
        steps: [400_000, -250_000, 1_000, 0],
        entry_rate: 0,
        cruise_rate: 40_000,
        exit_rate: 0,
        accel: 400_000,
        dwell_ticks: 0,
        servo: None,
    };
    let short = StepBlock {
        steps: [37, 120, 0, 0],
        entry_rate: 3_000,
        cruise_rate: 4_800,
        exit_rate: 3_000,
        accel: 120_000,
        dwell_ticks: 0,
        servo: None,
    };
    let mut pending = vec![long];
    pending.extend(std::iter::repeat_n(short, 20_000));
    pending.reverse();
    let mut ticks = 0u64;
    let mut time = 0u64;
    let _ = s.push(pending.pop().unwrap(), Switches::Limits);
    time += u64::from(s.start(&mut pins).unwrap());
    loop {
        while s.has_room() {
            match pending.pop() {
                Some(b) => {
                    let _ = s.push(b, Switches::Limits);
                }
                None => break,
            }
        }
        ticks += 1;
        match stepper_tick(&mut s, &mut pins) {
            Some(t) => time += u64::from(t),
            None => break,
        }
    }
    println!("ticks {ticks} steps {:?} virtual time {:.3} s", pins.steps, time as f64 / 1e6);
}
