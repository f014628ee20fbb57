//! Framed mode through the simulator: numbered, CRC-checked replies; sequenced input only; four-byte real-time
//! commands that single damaged bytes cannot forge.

use std::string::String;
use std::vec::Vec;

use super::*;
use crate::framing::{parse_reply, rt_sequence};
use crate::gcode::xor_checksum;
use crate::protocol::{Encoder, MAX_FRAME, RT_FEED_HOLD, RT_RESET, RT_RESUME, RT_STATUS};
use crate::realtime::MachineState;
use crate::step_block::StepBlock;

fn numbered(n: u32, body: &str) -> String {
    let line = std::format!("N{n} {body}");
    std::format!("{line}*{}\n", xor_checksum(line.as_bytes()))
}

fn run(sim: &mut Sim, bytes: &[u8]) -> Vec<String> {
    sim.feed(bytes);
    sim.run_until_idle();
    sim.take_replies()
}

/// Every line must verify; returns (number, text) pairs.
fn framed(lines: &[String]) -> Vec<(u32, String)> {
    lines
        .iter()
        .map(|l| {
            let (n, t) = parse_reply(l).unwrap_or_else(|| panic!("not a valid framed reply: {l:?}"));
            (n, String::from(t))
        })
        .collect()
}

fn framed_sim() -> Sim {
    let mut sim = Sim::new(MachineConfig::xy_plotter());
    sim.take_replies();
    let r = run(&mut sim, numbered(0, "M990 S1").as_bytes());
    assert_eq!(framed(&r), [(0, String::from("ok"))]);
    assert!(sim.machine().is_framed());
    sim
}

fn block(dx: i32) -> StepBlock {
    StepBlock {
        steps: [dx, 0, 0, 0],
        entry_rate: 0,
        cruise_rate: 2000,
        exit_rate: 0,
        accel: 20_000,
        dwell_ticks: 0,
        servo: None,
    }
}

#[test]
fn replies_are_numbered_and_checked() {
    let mut sim = framed_sim();
    let mut enc = Encoder::new();
    let mut out = [0u8; MAX_FRAME];
    let mut bytes = Vec::new();
    for seq in 1..4 {
        let n = enc.encode(&block(400), seq, &mut out).unwrap();
        bytes.extend(&out[..n]);
    }
    // A frame out of order (number 9): rs with the expected number.
    let n = enc.encode(&block(400), 9, &mut out).unwrap();
    bytes.extend(&out[..n]);
    let r = framed(&run(&mut sim, &bytes));
    // Then, as the blocks complete (each 400 steps at ≤ 2000 steps/s: ≥ 200 ms apart, far more than the 5 ms
    // between reports), a completion report for each, numbered with the expected number 4.
    assert_eq!(
        r,
        [
            (1, "ok".into()),
            (2, "ok".into()),
            (3, "ok".into()),
            (4, "rs 4".into()),
            (4, "C:1".into()),
            (4, "C:2".into()),
            (4, "C:3".into())
        ]
    );
    let r = framed(&run(&mut sim, &rt_sequence(RT_STATUS)));
    assert_eq!(r, [(4, "<Idle|MPos:15.000,0.000,0.000,0.000|Steps:1200,0,0,0|Q:0/32|N:4|C:3>".into())]);
    // Plain G-code is not taken in framed mode: answered as a damaged frame.
    let r = framed(&run(&mut sim, b"G0 X0\n"));
    assert_eq!(r, [(4, "rs 4".into())]);
    assert_eq!(sim.physical_position()[0], 1200);
    // A soft-limit refusal names its frame.
    run(&mut sim, numbered(4, "G28").as_bytes());
    let n = enc.encode(&block(-400), 5, &mut out).unwrap();
    let r = framed(&run(&mut sim, &out[..n]));
    assert_eq!(r, [(5, "error:7 target outside the travel: X".into())]);
    // Every later frame is refused too (nothing after the hole runs), and the status names the refused block.
    let n = enc.encode(&block(400), 6, &mut out).unwrap();
    let r = framed(&run(&mut sim, &out[..n]));
    assert_eq!(r, [(6, "error:12 step block refused: block 5 was refused".into())]);
    let r = framed(&run(&mut sim, &rt_sequence(RT_STATUS)));
    // (Homed: X and Y at 0, the pen up at Z 4 mm; 3 blocks and 13 homing moves completed.)
    assert_eq!(r, [(7, "<Idle|MPos:0.000,0.000,4.000,0.000|Steps:0,0,1600,0|Q:0/32|N:7|C:16|R:5,7>".into())]);
    // Homing clears it.
    run(&mut sim, numbered(7, "G28").as_bytes());
    let n = enc.encode(&block(400), 8, &mut out).unwrap();
    let r = framed(&run(&mut sim, &out[..n]));
    assert_eq!(r[0], (8, "ok".into()));
    // Back to plain mode.
    let r = run(&mut sim, numbered(9, "M990 S0").as_bytes());
    assert_eq!(r, ["ok"]);
    assert!(!sim.machine().is_framed());
}

#[test]
fn lone_realtime_bytes_are_data_and_sequences_act() {
    let mut sim = framed_sim();
    let r = run(&mut sim, numbered(1, "G1 X100 F3000").as_bytes());
    assert_eq!(framed(&r), [(1, "ok".into()), (2, "C:1".into())]);
    // Nothing acts on `!`, `?`, `~` or one Ctrl-X alone: the bytes make a damaged line (answered rs).
    sim.feed(numbered(2, "G1 X200").as_bytes());
    sim.run_for(100_000);
    sim.take_replies();
    sim.feed(b"!?\x18~\n");
    sim.run_for(50_000);
    assert_eq!(sim.machine().state(), MachineState::Run);
    assert_eq!(framed(&sim.take_replies()), [(3, "rs 3".into())]);
    // The four-byte hold does act.
    sim.feed(&rt_sequence(RT_FEED_HOLD));
    sim.run_for(1_000_000);
    assert_eq!(sim.machine().state(), MachineState::Held);
    sim.feed(&rt_sequence(RT_RESUME));
    sim.run_until_idle();
    assert_eq!(sim.physical_position()[0], 16_000);
    assert_eq!(framed(&sim.take_replies()), [(3, "C:2".into())], "the second move's completion");
    // A framed reset leaves framed mode; its banner is plain.
    let r = run(&mut sim, &rt_sequence(RT_RESET));
    assert_eq!(r, ["plotter-fw 0.1.0 proto 3 rx 256 queue 32 line 96 seq 0"]);
    assert!(!sim.machine().is_framed());
    // The console's escape hatch: three plain Ctrl-X.
    let mut sim = framed_sim();
    let r = run(&mut sim, &[RT_RESET]);
    assert!(r.iter().all(|l| !l.starts_with("plotter-fw")), "{r:?}");
    let r = run(&mut sim, &[RT_RESET, RT_RESET]);
    assert!(r.iter().any(|l| l.starts_with("plotter-fw")), "{r:?}");
}

/// After a feed hold and its resume, the blocks the host planned for the uninterrupted run (here a straight line
/// at a constant 2000 events/s, eight 400-step blocks that enter and leave at that rate) start from the rate the
/// resumed ones end at, never with a jump: the stepper re-profiles them to accelerate (20 000 events/s²) from it.
/// Before, the first block pushed after the resume entered at its planned 2000 events/s right after a block the
/// resume had brought to rest: 0 → 1900 events/s from one step to the next.
#[test]
fn after_a_resume_the_host_s_blocks_accelerate_from_the_rate_the_resumed_ones_end_at() {
    let mut sim = framed_sim();
    let mut enc = Encoder::new();
    let mut out = [0u8; MAX_FRAME];
    let mut bytes = Vec::new();
    for seq in 1..9u32 {
        let b = StepBlock {
            entry_rate: if seq == 1 { 0 } else { 2000 },
            exit_rate: if seq == 8 { 0 } else { 2000 },
            ..block(400)
        };
        let n = enc.encode(&b, seq, &mut out).unwrap();
        bytes.extend(&out[..n]);
    }
    sim.feed(&bytes);
    // 150 ms in: the first block is done (its ramp to 2000/s takes 100 steps), the second runs.
    sim.run_for(150_000);
    sim.feed(&rt_sequence(RT_FEED_HOLD));
    sim.run_for(1_000_000);
    assert_eq!(sim.machine().state(), MachineState::Held);
    sim.feed(&rt_sequence(RT_RESUME));
    sim.run_until_idle();
    assert_eq!(sim.physical_position()[0], 3200);
    let xs: Vec<u64> = sim.hal().steps().iter().filter(|e| e.axis == crate::axis::Axis::X).map(|e| e.time).collect();
    assert_eq!(xs.len(), 3200);
    // The rate over four steps (the tick's rounding is ±1 µs on 2 ms there), and the acceleration between two
    // such windows: the blocks' 20 000 events/s², read up to 1.37× over four steps at the start of a ramp from
    // rest (the stepper's piecewise step times; the first block's own ramp reads 27 337), held at 1.5×. The jump
    // read 867 917 events/s² before.
    let rate = |k: usize| 4e6 / (xs[k + 4] - xs[k]) as f64;
    let acc = |k: usize| (rate(k + 4) - rate(k)) / ((xs[k + 6] - xs[k + 2]) as f64 / 1e6);
    let worst = (0..xs.len() - 8).map(acc).fold(0.0f64, f64::max);
    assert!(worst <= 30_000.0, "an acceleration of {worst:.0} events/s²");
}
