//! Homing on the simulator's step trace: which axes a reset loses (only those stepping), and a full `G28` that
//! never lowers the pen onto the paper (a known Z kept, a lost one refused); see [`crate::homing`].

use std::string::String;
use std::vec::Vec;

use super::*;
use crate::protocol::{RT_FEED_HOLD, RT_RESET};

fn run(sim: &mut Sim, text: &str) -> Vec<String> {
    sim.feed(text.as_bytes());
    sim.run_until_idle();
    sim.take_replies()
}

/// The XY kit homed from physical (100, 100, 10) mm (switches one pull-off beyond the travel, so machine and
/// physical steps agree after homing).
fn homed_kit() -> Sim {
    let c = MachineConfig::xy_plotter();
    let mut o = SimOptions::for_config(&c);
    o.start = [8000, 8000, 4000, 0];
    let mut sim = Sim::with_options(c, o);
    sim.take_replies();
    assert_eq!(run(&mut sim, "G28\n"), ["ok"]);
    assert_eq!(sim.machine().homed(), 0b111);
    sim
}

/// Z steps in the trace from step `from` on.
fn z_steps(sim: &Sim, from: usize) -> usize {
    sim.hal().steps()[from..].iter().filter(|e| e.axis == Axis::Z).count()
}

/// A plot stopped mid-stroke the way the host stops it (a reset while X draws, then the pen lifted) keeps Z:
/// the resume's G28 lifts nothing further and never steps Z down (it used to seek the switch, 2 mm below the
/// paper, where the carriage stood); X and Y home again from where the stroke stopped.
#[test]
fn a_reset_mid_stroke_keeps_z_and_homing_never_lowers_the_pen() {
    let mut sim = homed_kit();
    // Pen down, then a 100 mm stroke at 50 mm/s: stopped by the reset 0.5 s in, X still stepping.
    assert_eq!(run(&mut sim, "G1 Z0 F600\n"), ["ok"]);
    sim.feed(b"G1 X100 F3000\n");
    sim.run_for(500_000);
    assert!(sim.physical_position()[0] > 0 && sim.physical_position()[0] < 8000);
    sim.feed(&[RT_RESET]);
    sim.run_until_idle();
    sim.take_replies();
    // X lost its steps; Y and Z did not step.
    assert_eq!(sim.machine().homed(), Axis::Y.bit() | Axis::Z.bit());
    assert_eq!(run(&mut sim, "G0 Z4\n"), ["ok"]);
    let (from, x) = (sim.hal().steps().len(), sim.physical_position()[0]);
    assert_eq!(run(&mut sim, "G28\n"), ["ok"]);
    assert_eq!(z_steps(&sim, from), 0, "Z stays at the pen-up height");
    assert_eq!(sim.physical_position(), [0, 0, 1600, 0]);
    assert!(sim.hal().steps()[from..].iter().filter(|e| e.axis == Axis::X).count() >= usize::try_from(x).unwrap());
    assert_eq!(sim.machine().homed(), 0b111);
}

/// A reset while Z moves loses Z: the kit's pen touches before its switch, so a full G28 is refused and
/// nothing moves; `G28 Z` (the operator's word that the paper is clear) homes it, and G28 then keeps it. A
/// reset once a feed hold has stopped loses nothing.
#[test]
fn a_lost_z_is_not_homed_onto_the_paper() {
    let mut sim = homed_kit();
    // Z down at 1 mm/s from 4 mm: reset 0.5 s in, while Z steps.
    sim.feed(b"G1 Z0 F60\n");
    sim.run_for(500_000);
    sim.feed(&[RT_RESET]);
    sim.run_until_idle();
    sim.take_replies();
    assert_eq!(sim.machine().homed(), Axis::X.bit() | Axis::Y.bit());
    let from = sim.hal().steps().len();
    let r = run(&mut sim, "G28\n");
    assert_eq!(r.len(), 1);
    assert!(r[0].starts_with("error:16 homing refused: the pen's height is lost"), "{r:?}");
    assert!(r[0].ends_with("then G28 Z"), "{r:?}");
    assert_eq!(sim.hal().steps().len(), from, "nothing moved");
    assert_eq!(run(&mut sim, "G28 Z\n"), ["ok"]);
    assert_eq!(sim.machine().homed(), 0b111);
    assert_eq!(run(&mut sim, "G28\n"), ["ok"]);
    // A stroke held to a stop, then reset: nothing was stepping.
    sim.feed(b"G1 X100 F3000\n");
    sim.run_for(300_000);
    sim.feed(&[RT_FEED_HOLD]);
    sim.run_for(500_000);
    sim.feed(&[RT_RESET]);
    sim.run_until_idle();
    assert_eq!(sim.machine().homed(), 0b111);
}
