//! Checked numbers through the simulator: the reproducers of extreme G-code values (each an error or a bounded,
//! correct move), and a property test over random G-code with extreme values against an exact model of the
//! commanded targets — no panic (tests build with overflow checks), no step against the commanded direction, and
//! every completed move ends exactly on the commanded target.
#![allow(clippy::needless_range_loop, reason = "the model indexes several per-axis arrays by axis")]

use std::format;
use std::string::String;
use std::vec::Vec;

use proptest::prelude::*;

use super::*;
use crate::protocol::RT_RESET;
use crate::range::MAX_POSITION_STEPS;

fn cfg() -> MachineConfig {
    MachineConfig::xy_plotter()
}

fn run(sim: &mut Sim, text: &str) -> Vec<String> {
    sim.feed(text.as_bytes());
    sim.run_until_idle();
    sim.take_replies()
}

/// Every step since `from` on `axis` goes the way `forward` says.
fn all_steps(sim: &Sim, from: usize, axis: Axis, forward: bool) -> usize {
    let steps: Vec<_> = sim.hal().steps()[from..].iter().filter(|e| e.axis == axis).collect();
    assert!(steps.iter().all(|e| e.forward == forward), "{axis:?} stepped against the commanded direction");
    steps.len()
}

#[test]
fn inch_overflow_is_an_error() {
    let mut sim = Sim::new(cfg());
    sim.take_replies();
    let r = run(&mut sim, "G20\nG1 X999999999999 F10\nG92 Y-999999999999\nG1 F999999999999\n");
    assert_eq!(
        r,
        ["ok", "error:13 number out of range: X", "error:13 number out of range: Y", "error:13 number out of range: F"]
    );
    assert!(sim.hal().steps().is_empty());
    // 13 integer digits: beyond the parser.
    let r = run(&mut sim, "G21\nG1 X1234567890123\n");
    assert_eq!(r, ["ok", "error:13 number out of range at column 4"]);
}

#[test]
fn target_overflow_is_an_error_and_nothing_moves() {
    let mut sim = Sim::new(cfg());
    sim.take_replies();
    // Y-1 trips nothing (the switch is 2 mm below 0); then 99999999 mm is 8·10⁹ steps: beyond ±2^30.
    let r = run(&mut sim, "G0 Y-1\nG0 Y99999999\n");
    assert_eq!(r, ["ok", "error:13 number out of range: Y target beyond the machine's position range"]);
    assert_eq!(sim.machine().target_steps(), [0, -80, 0, 0], "the refused move left the target alone");
    assert_eq!(sim.physical_position(), [0, -80, 0, 0]);
    // A target within the position range but a single move longer than one block can step (2^24 events).
    let r = run(&mut sim, "G0 X9999999\n");
    assert_eq!(r, ["error:13 number out of range: move longer than one block can step"]);
    // G92 shifting work coordinates so far that an absolute move overflows the i64 micrometres.
    let r = run(&mut sim, "G92 X-999999999999\nG0 X999999999999\nG0 X-999999999999\n");
    assert_eq!(r[0], "ok");
    assert!(r[1].starts_with("error:13 number out of range: X"), "{r:?}");
    assert_eq!(r[2], "ok", "X-999999999999 in work coordinates is machine 0");
    assert_eq!(sim.physical_position()[0], 0);
}

#[test]
fn too_slow_to_time_is_an_error() {
    let mut sim = Sim::new(cfg());
    sim.take_replies();
    // 400 mm at 0.000001 mm/min: 32000 events at the minimum rate of 1 event/s = 8.9 h.
    let r = run(&mut sim, "G1 X400 F0.000001\n");
    assert_eq!(r, ["error:13 number out of range: move too slow to time (lasts over 35 minutes)"]);
    // 1 mm at 1 mm/min = 60 s: fine.
    let r = run(&mut sim, "G1 X1 F1\n");
    assert_eq!(r, ["ok"]);
    assert_eq!(sim.physical_position()[0], 80);
}

#[test]
fn huge_unhomed_move_goes_the_commanded_way() {
    // Before homing there are no soft limits: +X by 200 km (1.6·10⁷ steps, just under 2^24) is a valid move. It
    // must start in +X (the seed wrapped it into −X, into the endstop), and it is stopped here by a reset.
    for (line, forward) in [("G0 X200000\n", true), ("G91\nG0 Y-200000\n", false)] {
        let mut o = SimOptions::for_config(&cfg());
        o.start = [8000, 8000, 0, 0];
        let mut sim = Sim::with_options(cfg(), o);
        sim.take_replies();
        sim.feed(line.as_bytes());
        sim.run_for(200_000);
        let axis = if forward { Axis::X } else { Axis::Y };
        let n = all_steps(&sim, 0, axis, forward);
        assert!(n > 500, "{line:?}: it moves ({n} steps in 0.2 s)");
        assert!(sim.take_replies().iter().all(|l| l == "ok"));
        sim.feed(&[RT_RESET]);
        sim.run_until_idle();
    }
}

#[test]
fn g28_with_bare_axis_letters_homes_those_axes() {
    let c = cfg();
    let mut o = SimOptions::for_config(&c);
    o.start = [4000, 3000, 800, 0];
    let mut sim = Sim::with_options(c, o);
    sim.take_replies();
    let r = run(&mut sim, "G28 X\n");
    assert_eq!(r, ["ok"]);
    assert_eq!(sim.machine().homed(), Axis::X.bit());
    // X at machine 0 (one pull-off from its switch at −160), Y untouched.
    assert_eq!(sim.physical_position()[..2], [0, 3000]);
    let r = run(&mut sim, "G28 Y Z\n");
    assert_eq!(r, ["ok"]);
    assert_eq!(sim.machine().homed(), 0b111);
    // A bare letter means nothing outside G28.
    let r = run(&mut sim, "G0 X\n");
    assert_eq!(r, ["error:1 expected a letter followed by a number at column 4"]);
}

#[test]
fn step_frame_beyond_the_position_range_is_refused() {
    use crate::protocol::{Encoder, MAX_FRAME};
    use crate::step_block::StepBlock;
    // An X axis of 10^9 steps homing at its maximum end: after `G28 X` the machine stands at +10^9 steps, and
    // 2^30 − 10^9 = 73 741 824 steps further is the end of the position range: the 9th frame of 2^23 − 1 steps
    // (queued, not yet stepped: targets are checked when a block is queued) crosses it.
    let mut c = cfg();
    c.axes[0].travel_mm = 12_500_000.0;
    c.axes[0].home_at_max = true;
    c.soft_limits = false;
    assert_eq!(c.validate(), Ok(()));
    let mut o = SimOptions::for_config(&c);
    o.start = [1_000_000_100, 0, 0, 0];
    let mut sim = Sim::with_options(c, o);
    sim.take_replies();
    assert_eq!(run(&mut sim, "G28 X\n"), ["ok"]);
    assert_eq!(sim.machine().target_steps()[0], 1_000_000_000);
    let mut enc = Encoder::new();
    let mut out = [0u8; MAX_FRAME];
    let b = StepBlock {
        steps: [(1 << 23) - 1, 0, 0, 0],
        entry_rate: 0,
        cruise_rate: 1000,
        exit_rate: 0,
        accel: 1000,
        dwell_ticks: 0,
        servo: None,
    };
    for seq in 0..9 {
        let n = enc.encode(&b, seq, &mut out).unwrap();
        sim.feed(&out[..n]);
    }
    let steps_before = sim.hal().steps().len();
    sim.run_for(10_000);
    let r = sim.take_replies();
    let mut want = std::vec![String::from("ok"); 8];
    want.push(String::from("error:13 number out of range: target beyond the machine's position range"));
    assert_eq!(r, want);
    assert_eq!(sim.machine().target_steps()[0], 1_000_000_000 + 8 * ((1 << 23) - 1));
    // Whatever stepped so far went +X, as commanded.
    all_steps(&sim, steps_before, Axis::X, true);
}

// ---- Property test: random G-code with extreme values against an exact model ----

/// A value in millionths: zero, small, around the representable bounds, or huge (up to the parser's 12 digits).
fn value() -> impl Strategy<Value = i64> {
    prop_oneof![
        Just(0i64),
        -400_000_000i64..400_000_000,
        -2_000i64..2_000,
        // ±2^30 steps at 80 steps/mm = 13 421 772.8 mm, and 2^24 events = 209 715.2 mm, give or take.
        (13_421_772_700_000i64..13_421_772_900_000).prop_map(|v| if v % 2 == 0 { v } else { -v }),
        (209_715_100_000i64..209_715_300_000).prop_map(|v| if v % 2 == 0 { v } else { -v }),
        (1_000_000_000_000_000i64..999_999_999_999_999_999).prop_map(|v| if v % 2 == 0 { v } else { -v }),
        Just(999_999_999_999_999_999i64),
        Just(-999_999_999_999_999_999i64),
    ]
}

fn text(v: i64) -> String {
    let a = v.unsigned_abs();
    format!("{}{}.{:06}", if v < 0 { "-" } else { "" }, a / 1_000_000, a % 1_000_000)
}

#[derive(Debug, Clone)]
enum Line {
    Inches(bool),
    Absolute(bool),
    Offset(usize, i64),
    Move { rapid: bool, axes: Vec<(usize, i64)>, feed: Option<i64> },
    Home(u8),
    Dwell(i64),
}

fn line() -> impl Strategy<Value = Line> {
    let axes = proptest::collection::vec((0usize..3, value()), 1..3);
    let feed = proptest::option::of(prop_oneof![1i64..1_000_000, 1_000_000i64..10_000_000_000, value()]);
    prop_oneof![
        1 => any::<bool>().prop_map(Line::Inches),
        1 => any::<bool>().prop_map(Line::Absolute),
        1 => (0usize..3, value()).prop_map(|(a, v)| Line::Offset(a, v)),
        6 => (any::<bool>(), axes, feed).prop_map(|(rapid, axes, feed)| Line::Move { rapid, axes, feed }),
        1 => (0u8..8).prop_map(Line::Home),
        1 => value().prop_map(Line::Dwell),
    ]
}

const LETTERS: [char; 3] = ['X', 'Y', 'Z'];

impl Line {
    fn gcode(&self) -> String {
        match self {
            Line::Inches(i) => String::from(if *i { "G20" } else { "G21" }),
            Line::Absolute(a) => String::from(if *a { "G90" } else { "G91" }),
            Line::Offset(a, v) => format!("G92 {}{}", LETTERS[*a], text(*v)),
            Line::Move { rapid, axes, feed } => {
                let mut s = String::from(if *rapid { "G0" } else { "G1" });
                let mut seen = [false; 3];
                for (a, v) in axes {
                    if !core::mem::replace(&mut seen[*a], true) {
                        s.push_str(&format!(" {}{}", LETTERS[*a], text(*v)));
                    }
                }
                if let Some(f) = feed {
                    s.push_str(&format!(" F{}", text(*f)));
                }
                s
            }
            Line::Home(mask) => {
                let mut s = String::from("G28");
                for (i, l) in LETTERS.iter().enumerate() {
                    if mask & (1 << i) != 0 {
                        s.push_str(&format!(" {l}"));
                    }
                }
                s
            }
            Line::Dwell(p) => format!("G4 P{}", text(*p)),
        }
    }
}

/// The commanded state, in exact integers: micrometre-millionths (as the firmware's documented unit), i128.
struct Model {
    inches: bool,
    absolute: bool,
    offset: [i128; 3],
    target: [i128; 3],
}

impl Model {
    fn um(&self, v: i64) -> i128 {
        let v = i128::from(v);
        // ×25.4, rounded half away from zero (the parser's documented rounding to millionths of a mm).
        if self.inches { (v * 254 + v.signum() * 5) / 10 } else { v }
    }

    /// Resynchronise the target with where the firmware put it (after homing, an alarm or a reset).
    fn sync(&mut self, sim: &Sim, c: &MachineConfig) {
        let steps = sim.machine().target_steps();
        for i in 0..3 {
            let spm = i128::from(steps_per_mm(c, i));
            self.target[i] = i128::from(steps[i]) * 1_000_000 / spm;
        }
    }
}

fn steps_per_mm(c: &MachineConfig, i: usize) -> i64 {
    let spm = c.axis(Axis::from_index(i).unwrap()).steps_per_mm;
    assert_eq!(spm.fract(), 0.0);
    #[allow(clippy::cast_possible_truncation, reason = "an integral test configuration value")]
    let spm = spm as i64;
    spm
}

/// Steps of a micrometre-millionths position, rounded half away from zero, exactly.
fn exact_steps(um: i128, spm: i64) -> i128 {
    let num = um * i128::from(spm);
    let (q, r) = (num / 1_000_000, num % 1_000_000);
    if 2 * r.abs() >= 1_000_000 { q + num.signum() } else { q }
}

/// Feed one line; run until it is answered and done, or at most ~3000 steps or 2 s of virtual time (then stop it
/// with a reset). Returns the replies and whether it had to be stopped.
fn step_line(sim: &mut Sim, line: &str) -> (Vec<String>, bool) {
    let s0 = sim.hal().steps().len();
    let t0 = sim.now();
    sim.feed(line.as_bytes());
    sim.feed(b"\n");
    let mut replies = Vec::new();
    let stopped = loop {
        sim.run_for(2_000);
        replies.extend(sim.take_replies());
        if sim.machine().is_idle() && sim.wire_len() == 0 {
            break false;
        }
        if sim.hal().steps().len() - s0 > 3000 || sim.now() - t0 > 2_000_000 {
            break true;
        }
    };
    if stopped {
        sim.feed(&[RT_RESET]);
        sim.run_until_idle();
        replies.extend(sim.take_replies());
    }
    (replies, stopped)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    #[test]
    fn extreme_gcode_never_panics_nor_flips_a_direction(
        lines in proptest::collection::vec(line(), 1..24),
        start in (0i64..33_000, 0i64..23_000),
    ) {
        let c = cfg();
        let mut o = SimOptions::for_config(&c);
        o.start = [start.0, start.1, 0, 0];
        let mut sim = Sim::with_options(c, o);
        sim.take_replies();
        let mut m = Model { inches: false, absolute: true, offset: [0; 3], target: [0; 3] };
        for l in &lines {
            let g = l.gcode();
            let before = sim.hal().steps().len();
            let (r, stopped) = step_line(&mut sim, &g);
            let ok = r.first().is_some_and(|x| x == "ok");
            prop_assert!(
                r.iter().all(|x| x == "ok" || x.starts_with("error:") || x.starts_with("ALARM:") || x.starts_with("plotter-fw ")),
                "{g}: {r:?}"
            );
            let alarm = r.iter().any(|x| x.starts_with("ALARM:")) || sim.machine().alarm().is_some();
            match l {
                Line::Inches(i) if ok => m.inches = *i,
                Line::Absolute(a) if ok => m.absolute = *a,
                Line::Offset(a, v) if ok => m.offset[*a] = m.target[*a] - m.um(*v),
                Line::Move { axes, .. } if ok => {
                    let mut new = m.target;
                    let mut seen = [false; 3];
                    for (a, v) in axes {
                        if !core::mem::replace(&mut seen[*a], true) {
                            new[*a] = if m.absolute { m.um(*v) + m.offset[*a] } else { m.target[*a] + m.um(*v) };
                        }
                    }
                    for i in 0..3 {
                        let spm = steps_per_mm(&c, i);
                        let (from, to) = (exact_steps(m.target[i], spm), exact_steps(new[i], spm));
                        // An accepted target is representable.
                        prop_assert!(to.abs() <= i128::from(MAX_POSITION_STEPS), "{g}: accepted {to} steps");
                        let axis = Axis::from_index(i).unwrap();
                        let evs: Vec<bool> = sim.hal().steps()[before..].iter().filter(|e| e.axis == axis).map(|e| e.forward).collect();
                        prop_assert!(evs.iter().all(|&f| f == (to > from)), "{g}: {axis:?} from {from} to {to} stepped {:?}", &evs[..evs.len().min(5)]);
                        if !stopped && !alarm {
                            prop_assert_eq!(i128::from(sim.machine().stepper().position()[i]), to, "{}: {:?} ends on the target", g, axis);
                            prop_assert_eq!(i128::try_from(evs.len()).unwrap(), (to - from).abs());
                        }
                    }
                    m.target = new;
                }
                Line::Move { .. } => {
                    // Refused: nothing moved.
                    prop_assert_eq!(sim.hal().steps().len(), before, "{}: refused but stepped: {:?}", g, r);
                }
                _ => {}
            }
            if stopped || alarm || matches!(l, Line::Home(_)) {
                if alarm {
                    sim.feed(&[RT_RESET]);
                    sim.run_until_idle();
                    sim.take_replies();
                }
                if stopped || alarm {
                    // A reset restores the default modes.
                    m.inches = false;
                    m.absolute = true;
                }
                m.sync(&sim, &c);
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    /// Fuzz the receive path: random bytes, G-code-like lines and step-block frames (valid, then mutated), in plain
    /// and framed mode. Nothing panics (overflow checks on), every reply is a well-formed line, and the machine
    /// keeps answering.
    #[test]
    fn random_input_never_panics(
        chunks in proptest::collection::vec(prop_oneof![
            proptest::collection::vec(any::<u8>(), 0..40),
            "[GMNXYZEFPS0-9. *;()-]{0,40}\n".prop_map(String::into_bytes),
            (proptest::array::uniform4(-9_000_000i32..9_000_000), 1u32..70_000, any::<u32>(), any::<usize>(), any::<u8>())
                .prop_map(|(steps, rate, seq, pos, flip)| {
                    let b = crate::step_block::StepBlock { steps, entry_rate: 0, cruise_rate: rate, exit_rate: 0, accel: 5000, dwell_ticks: 0, servo: None };
                    let mut out = [0u8; crate::protocol::MAX_FRAME];
                    let mut enc = crate::protocol::Encoder::new();
                    let n = enc.encode(&crate::protocol::quantize(&b), seq % 4, &mut out).unwrap_or(0);
                    let mut v = out[..n].to_vec();
                    if !v.is_empty() && flip % 2 == 0 {
                        let i = pos % v.len();
                        v[i] ^= flip;
                    }
                    v
                }),
            Just(b"N0 M990 S1*".iter().copied().chain(std::format!("{}\n", crate::gcode::xor_checksum(b"N0 M990 S1")).into_bytes()).collect::<Vec<u8>>()),
        ], 1..16)
    ) {
        let mut sim = Sim::new(cfg());
        sim.take_replies();
        for c in &chunks {
            sim.feed(c);
            sim.run_for(20_000);
        }
        sim.feed(&[RT_RESET, RT_RESET, RT_RESET]);
        sim.run_for(20_000);
        let r = sim.take_replies();
        prop_assert!(r.last().is_some_and(|l| l.starts_with("plotter-fw ")), "still answers a reset: {:?}", r.last());
    }
}
