//! Firmware behaviour through the simulator: G-code streams, resends, step-block frames, homing, limits, alarms,
//! real-time commands.

use std::format;
use std::string::String;
use std::vec::Vec;

use rand::{RngExt, SeedableRng, rngs::StdRng};

use super::*;
use crate::gcode::xor_checksum;
use crate::planner::{PlanBlock, link_all, plan, step_blocks};
use crate::protocol::{Encoder, MAX_FRAME, RT_FEED_HOLD, RT_RESUME, RT_STATUS, quantize};
use crate::realtime::MachineState;
use crate::step_block::StepBlock;

fn cfg() -> MachineConfig {
    MachineConfig::xy_plotter()
}

fn run(sim: &mut Sim, text: &str) -> Vec<String> {
    sim.feed(text.as_bytes());
    sim.run_until_idle();
    sim.take_replies()
}

fn numbered(n: u32, body: &str) -> String {
    let line = format!("N{n} {body}");
    format!("{line}*{}\n", xor_checksum(line.as_bytes()))
}

fn count(replies: &[String], what: &str) -> usize {
    replies.iter().filter(|r| *r == what).count()
}

#[test]
fn banner_announces_buffers() {
    let mut sim = Sim::new(cfg());
    let r = sim.take_replies();
    assert_eq!(r, ["plotter-fw 0.1.0 proto 3 rx 256 queue 32 line 96 seq 0"]);
}

/// The seed's square, relative version: pen down, four sides, pen up.
const SQUARE_RELATIVE: &str = "G21\nG91\nG1 Z-4 F300\nG1 X30 F1200\nG1 Y30\nG1 X-30\nG1 Y-30\nG1 Z4 F300\n";
/// The seed's square, absolute version, starting at (20, 20).
const SQUARE_ABSOLUTE: &str =
    "G21\nG90\nG0 X20 Y20\nG1 Z0 F300\nG1 X50 Y20 F1200\nG1 X50 Y50\nG1 X20 Y50\nG1 X20 Y20\nG0 Z4\n";

#[test]
fn square_streams_end_at_exact_steps() {
    let mut opts = SimOptions::for_config(&cfg());
    opts.start = [0, 0, 1600, 0];
    let mut sim = Sim::with_options(cfg(), opts.clone());
    // Firmware believes it starts at Z=0; the relative square does not care.
    let r = run(&mut sim, SQUARE_RELATIVE);
    assert_eq!(count(&r, "ok"), 8, "{r:?}");
    assert_eq!(sim.machine().stepper().position(), [0, 0, 0, 0]);
    assert_eq!(sim.physical_position(), [0, 0, 1600, 0]);
    assert_eq!(sim.hal().step_counts(), [4800, 4800, 3200, 0]);
    // Pen went down once and up once.
    assert_eq!(sim.hal().pen_trace().iter().map(|p| p.1).collect::<Vec<_>>(), [false, true, false]);

    let mut sim = Sim::with_options(cfg(), SimOptions { start: [0; NUM_AXES], ..opts });
    let r = run(&mut sim, SQUARE_ABSOLUTE);
    assert_eq!(count(&r, "ok"), 9, "{r:?}");
    assert_eq!(sim.machine().stepper().position(), [1600, 1600, 1600, 0]);
    assert_eq!(sim.hal().step_counts(), [1600 + 4800, 1600 + 4800, 1600, 0]);
}

#[test]
fn relative_moves_do_not_drift() {
    let mut opts = SimOptions::for_config(&cfg());
    opts.start = [0, 8000, 0, 0];
    let mut sim = Sim::with_options(cfg(), opts);
    let mut text = String::from("G91 G1 F3000\n");
    for _ in 0..1000 {
        text.push_str("X0.0137 Y-0.0031\n");
    }
    sim.feed(text.as_bytes());
    sim.run_until_idle();
    let r = sim.take_replies();
    assert_eq!(count(&r, "ok"), 1001);
    // 13.7 mm · 80 = 1096 steps; −3.1 mm · 80 = −248 steps: exact, no accumulated rounding.
    assert_eq!(sim.physical_position(), [1096, 8000 - 248, 0, 0]);
}

#[test]
fn corrupted_line_is_resent_and_executed_once() {
    let mut sim = Sim::new(cfg());
    sim.take_replies();
    let lines: Vec<String> = ["G91", "G1 X10 F1200", "G1 Y10", "G1 X-5", "G1 Y-5"]
        .iter()
        .enumerate()
        .map(|(i, l)| numbered(u32::try_from(i).unwrap(), l))
        .collect();
    // Line 2 arrives with a flipped digit (checksum mismatch); 3 and 4 follow in flight.
    let mut wire = String::new();
    wire.push_str(&lines[0]);
    wire.push_str(&lines[1]);
    wire.push_str(&lines[2].replace("Y10", "Y19"));
    wire.push_str(&lines[3]);
    wire.push_str(&lines[4]);
    let r = run(&mut sim, &wire);
    assert_eq!(r, ["ok", "ok", "rs 2", "rs 2", "rs 2"]);
    // The host goes back to 2.
    let r = run(&mut sim, &(lines[2].clone() + &lines[3] + &lines[4]));
    assert_eq!(r, ["ok", "ok", "ok"]);
    assert_eq!(sim.physical_position(), [400, 400, 0, 0], "Y10 executed exactly once");
    // A duplicate of an executed line is not executed again.
    let r = run(&mut sim, &lines[4]);
    assert_eq!(r, ["rs 5"]);
    assert_eq!(sim.physical_position(), [400, 400, 0, 0]);
    // An unnumbered line with a bad checksum is an error, not a resend.
    let r = run(&mut sim, "G1 X1*0\n");
    assert_eq!(r, ["error:11 checksum mismatch"]);
}

/// Plan a path on the host with the shared planner, send it as step-block frames.
fn host_plan(c: &MachineConfig, pts: &[(f64, f64)]) -> Vec<StepBlock> {
    let mut cur = [0i32; NUM_AXES];
    let mut blocks = Vec::new();
    for &(x, y) in pts {
        let t = [round_i32(x * 80.0), round_i32(y * 80.0), 0, 0];
        let steps = [t[0] - cur[0], t[1] - cur[1], 0, 0];
        cur = t;
        if let Some(b) = PlanBlock::line(c, steps, 60.0) {
            blocks.push(b);
        }
    }
    link_all(&mut blocks, c);
    plan(&mut blocks, 0.0);
    step_blocks(&blocks).map(|b| quantize(&b)).collect()
}

fn circle(n: usize, r: f64) -> Vec<(f64, f64)> {
    (0..=n)
        .map(|i| {
            let a = std::f64::consts::TAU * i as f64 / n as f64;
            (50.0 + r * a.cos(), 50.0 + r * a.sin())
        })
        .collect()
}

#[test]
fn step_frames_execute_in_exactly_the_host_time() {
    let c = cfg();
    let mut pts = std::vec![(50.0 + 20.0, 50.0)];
    pts.extend(circle(200, 20.0));
    let blocks = host_plan(&c, &pts);
    let expected_ticks: u64 = blocks.iter().map(|b| u64::from(b.duration_ticks())).sum();
    let mut enc = Encoder::new();
    let mut wire = Vec::new();
    for (i, b) in blocks.iter().enumerate() {
        let mut out = [0u8; MAX_FRAME];
        let n = enc.encode(b, u32::try_from(i).unwrap(), &mut out).unwrap();
        wire.extend_from_slice(&out[..n]);
    }
    let mut sim = Sim::new(c);
    sim.take_replies();
    sim.feed(&wire);
    sim.run_until_idle();
    let r = sim.take_replies();
    assert_eq!(count(&r, "ok"), blocks.len(), "{r:?}");
    let total: [i64; NUM_AXES] = core::array::from_fn(|i| blocks.iter().map(|b| i64::from(b.steps[i])).sum());
    assert_eq!(sim.physical_position(), total);
    assert_eq!(sim.hal().busy_ticks(), expected_ticks, "executed time equals the host's sum of block durations");
    assert_eq!(sim.now(), expected_ticks, "the stepper never starved");
}

#[test]
fn corrupted_step_frame_resent_and_executed_once() {
    let c = cfg();
    let blocks = host_plan(&c, &[(10.0, 0.0), (10.0, 10.0), (0.0, 10.0), (0.0, 0.0)]);
    let mut enc = Encoder::new();
    let frames: Vec<Vec<u8>> = blocks
        .iter()
        .enumerate()
        .map(|(i, b)| {
            let mut out = [0u8; MAX_FRAME];
            let n = enc.encode(b, u32::try_from(i).unwrap(), &mut out).unwrap();
            out[..n].to_vec()
        })
        .collect();
    let mut sim = Sim::new(c);
    sim.take_replies();
    let mut wire = frames[0].clone();
    let mut bad = frames[1].clone();
    bad[2] ^= 0x04;
    wire.extend_from_slice(&bad);
    wire.extend_from_slice(&frames[2]);
    sim.feed(&wire);
    sim.run_until_idle();
    assert_eq!(sim.take_replies(), ["ok", "rs 1", "rs 1"]);
    sim.feed(&[frames[1].clone(), frames[2].clone(), frames[3].clone(), frames[3].clone()].concat());
    sim.run_until_idle();
    assert_eq!(sim.take_replies(), ["ok", "ok", "ok", "rs 4"], "the duplicate is refused");
    assert_eq!(sim.physical_position(), [0, 0, 0, 0]);
    assert_eq!(sim.hal().step_counts(), [1600, 1600, 0, 0], "each side stepped once");
}

fn encode_all(blocks: &[StepBlock]) -> Vec<Vec<u8>> {
    let mut enc = Encoder::new();
    blocks
        .iter()
        .enumerate()
        .map(|(i, b)| {
            let mut out = [0u8; MAX_FRAME];
            let n = enc.encode(b, u32::try_from(i).unwrap(), &mut out).unwrap();
            out[..n].to_vec()
        })
        .collect()
}

#[test]
fn frame_with_a_cleared_marker_bit_is_resent_not_parsed_as_gcode() {
    let c = cfg();
    let blocks = host_plan(&c, &circle(24, 20.0));
    let frames = encode_all(&blocks);
    // A frame whose body holds a byte ≥ 0x80 besides the marker (most do: CRC and rate bytes).
    let k = (1..frames.len()).find(|&i| frames[i][1..].iter().any(|&b| b >= 0x80)).unwrap();
    let mut sim = Sim::new(c);
    sim.take_replies();
    sim.feed(&frames[..k].concat());
    sim.run_until_idle();
    assert_eq!(sim.take_replies(), vec!["ok"; k]);
    let before = sim.hal().steps().len();
    for damage in [0x80u8, 0xFF] {
        // The marker's top bit cleared (an ASCII first byte), or the whole marker replaced by a letter.
        let mut bad = frames[k].clone();
        if damage == 0x80 {
            bad[0] ^= 0x80;
        } else {
            bad[0] = b'G';
        }
        sim.feed(&bad);
        sim.run_until_idle();
        assert_eq!(sim.take_replies(), [format!("rs {k}")], "damage {damage:#x}");
    }
    // A marker byte dropped altogether.
    sim.feed(&frames[k][1..]);
    sim.run_until_idle();
    assert_eq!(sim.take_replies(), [format!("rs {k}")]);
    assert_eq!(sim.hal().steps().len(), before, "nothing executed");
    sim.feed(&frames[k..].concat());
    sim.run_until_idle();
    assert_eq!(sim.take_replies(), vec!["ok"; frames.len() - k]);
    assert_eq!(sim.machine().expected_seq(), u32::try_from(frames.len()).unwrap());
    let total: [i32; NUM_AXES] = blocks.iter().fold([0; NUM_AXES], |t, b| core::array::from_fn(|i| t[i] + b.steps[i]));
    assert_eq!(sim.physical_position(), total.map(i64::from), "each frame executed exactly once");

    // Outside a sequenced stream (fresh, or after a plain G-code line) such a line is ordinary bad input.
    let mut sim = Sim::new(c);
    sim.take_replies();
    let mut bad = frames[k].clone();
    bad[0] ^= 0x80;
    sim.feed(&bad);
    sim.run_until_idle();
    let r = sim.take_replies();
    assert!(r.len() == 1 && r[0].starts_with("error:"), "{r:?}");
    assert_eq!(run(&mut sim, &numbered(0, "G4 P1")), ["ok"]);
    sim.feed(&bad);
    sim.run_until_idle();
    assert_eq!(sim.take_replies(), ["rs 1"], "numbered lines make a sequenced stream too");
    assert_eq!(run(&mut sim, "G4 P1 ; plain\n"), ["ok"]);
    sim.feed(&bad);
    sim.run_until_idle();
    let r = sim.take_replies();
    assert!(r.len() == 1 && r[0].starts_with("error:"), "a plain line ends the stream: {r:?}");
}

fn homing_sim(rng: &mut StdRng) -> (Sim, [i64; NUM_AXES]) {
    let c = cfg();
    let mut opts = SimOptions::for_config(&c);
    let mut sw = [0i64; NUM_AXES];
    for axis in [Axis::X, Axis::Y, Axis::Z] {
        let i = axis.index();
        let travel = i64::from(c.axis(axis).travel_steps());
        sw[i] = rng.random_range(-500..500);
        opts.switches[i] = Some(Switch { position: sw[i], at_max: false });
        // Carriage anywhere within the travel above the switch.
        opts.start[i] = sw[i] + rng.random_range(1..travel);
    }
    (Sim::with_options(c, opts), sw)
}

#[test]
fn homing_finds_origin_exactly_at_random_offsets() {
    let mut rng = StdRng::seed_from_u64(7);
    for _ in 0..12 {
        let (mut sim, sw) = homing_sim(&mut rng);
        sim.take_replies();
        let r = run(&mut sim, "G28\n");
        assert_eq!(r, ["ok"]);
        assert_eq!(sim.machine().homed(), 0b111);
        // Machine 0 is one pull-off (2 mm) from the switch; Z then went to the pen-up height (4 mm).
        let phys = sim.physical_position();
        assert_eq!(sim.machine().stepper().position(), [0, 0, 1600, 0]);
        assert_eq!([phys[0] - sw[0], phys[1] - sw[1], phys[2] - sw[2]], [160, 160, 800 + 1600]);
        // Exactly: a move to (12.5, 7.25) lands 12.5 mm + 2 mm from the X switch.
        let r = run(&mut sim, "G1 X12.5 Y7.25 F3000\nG0 X0 Y0\nG1 X12.5 Y7.25\n");
        assert_eq!(r, ["ok", "ok", "ok"]);
        assert_eq!(sim.physical_position()[..2], [sw[0] + 160 + 1000, sw[1] + 160 + 580]);
    }
}

#[test]
fn homing_alarms() {
    // No switch on Y: never found.
    let c = cfg();
    let mut opts = SimOptions::for_config(&c);
    opts.switches[Axis::Y.index()] = None;
    opts.start = [1000, 1000, 1000, 0];
    let mut sim = Sim::with_options(c, opts.clone());
    sim.take_replies();
    let r = run(&mut sim, "G28\nG1 X1 F600\n");
    assert_eq!(
        r,
        [
            "ALARM:2 homing failed: switch not found",
            "error:8 alarm active, reset required: homing failed: switch not found",
            "error:8 alarm active, reset required"
        ]
    );
    assert_eq!(sim.machine().state(), MachineState::Alarm);
    // Y moved at most 1.5 × travel.
    assert!(1000 - sim.physical_position()[1] <= 35_640);
    // Reset clears the alarm.
    let r = run(&mut sim, "\u{18}");
    assert_eq!(r, ["plotter-fw 0.1.0 proto 3 rx 256 queue 32 line 96 seq 0"]);
    assert_eq!(sim.machine().alarm(), None);

    // A switch that never releases (stuck far beyond the travel on X).
    opts.switches[Axis::Y.index()] = Some(Switch { position: 0, at_max: false });
    opts.switches[Axis::X.index()] = Some(Switch { position: 1_000_000, at_max: false });
    let mut sim = Sim::with_options(c, opts);
    sim.take_replies();
    let r = run(&mut sim, "G28\n");
    assert_eq!(r[0], "ALARM:3 homing failed: switch still pressed after pull-off");
}

#[test]
fn soft_limit_rejects_before_any_step() {
    let mut sim = Sim::new(cfg());
    run(&mut sim, "G28\n");
    let before = sim.hal().step_counts();
    let r = run(&mut sim, "G1 X421 F1200\nG1 Y-0.1\nG91 G1 Z7\n");
    assert_eq!(
        r,
        [
            "error:7 target outside the travel: X",
            "error:7 target outside the travel: Y",
            "error:7 target outside the travel: Z"
        ]
    );
    assert_eq!(sim.hal().step_counts(), before, "nothing moved");
    // Within the travel still works.
    let r = run(&mut sim, "G90 G1 X420 Y297 F6000\n");
    assert_eq!(r, ["ok"]);
    assert_eq!(sim.physical_position()[..2], [33_600, 23_760]);
}

#[test]
fn hard_limit_latches_alarm_until_reset() {
    let c = cfg();
    let mut opts = SimOptions::for_config(&c);
    opts.start = [800, 800, 1600, 0];
    let mut sim = Sim::with_options(c, opts);
    sim.take_replies();
    // Not homed: the firmware thinks it is at 0 and happily moves to X-20 — into the switch at 12 mm below.
    let r = run(&mut sim, "G1 X-20 F1200\nG1 X5\n");
    assert_eq!(r[0], "ok");
    assert!(r.contains(&String::from("ALARM:1 hard limit: switch pressed outside homing")), "{r:?}");
    assert_eq!(sim.physical_position()[0], -160, "stopped at the switch");
    let r = run(&mut sim, "G1 X5\n");
    assert_eq!(r, ["error:8 alarm active, reset required"]);
    run(&mut sim, "\u{18}");
    assert_eq!(sim.machine().state(), MachineState::Idle);
}

#[test]
fn feed_hold_and_resume_keep_the_queue() {
    let mut sim = Sim::new(cfg());
    sim.take_replies();
    sim.feed(b"G1 X100 F6000\nG1 Y50\n");
    sim.run_for(400_000);
    sim.feed(&[RT_FEED_HOLD]);
    sim.run_for(500_000);
    sim.feed(&[RT_STATUS]);
    sim.run_for(10);
    let held_at = sim.physical_position();
    let r = sim.take_replies();
    assert!(r.last().unwrap().starts_with("<Hold:0|MPos:"), "{r:?}");
    assert!(held_at[0] > 0 && held_at[0] < 8000);
    sim.run_for(1_000_000);
    assert_eq!(sim.physical_position(), held_at, "held");
    sim.feed(&[RT_RESUME]);
    sim.run_until_idle();
    assert_eq!(sim.physical_position(), [8000, 4000, 0, 0]);
    sim.feed(&[RT_STATUS]);
    sim.run_until_idle();
    let r = sim.take_replies();
    assert_eq!(r.last().unwrap(), "<Idle|MPos:100.000,50.000,0.000,0.000|Steps:8000,4000,0,0|Q:0/32|N:0|C:2>");
}

/// Run until the machine reports `state` (at most `limit` ticks in small slices).
fn run_until_state(sim: &mut Sim, state: MachineState, limit: u64) {
    let end = sim.now() + limit;
    while sim.machine().state() != state {
        let before = sim.now();
        sim.run_for(100);
        assert!(sim.now() < end && sim.now() > before, "still {:?}", sim.machine().state());
    }
}

#[test]
fn resume_sent_while_the_hold_decelerates_acts_once_it_has_stopped() {
    let mut sim = Sim::new(cfg());
    sim.take_replies();
    sim.feed(b"G1 X100 F6000\nG1 Y50\n");
    sim.run_for(400_000);
    sim.feed(&[RT_FEED_HOLD]);
    sim.run_for(1_000);
    assert_eq!(sim.machine().state(), MachineState::Holding, "still decelerating");
    sim.feed(&[RT_RESUME]);
    // The resume is not lost: the hold still comes to a full stop first (the step rate falls to the hold's stop),
    // then motion carries on by itself.
    let mut last = sim.hal().steps().len();
    let mut gap_ticks = 0u64;
    let mut quiet = 0u64;
    while sim.machine().state() == MachineState::Holding {
        sim.run_for(1_000);
        let now = sim.hal().steps().len();
        quiet = if now == last { quiet + 1_000 } else { 0 };
        gap_ticks = gap_ticks.max(quiet);
        last = now;
    }
    assert_eq!(sim.machine().state(), MachineState::Run, "resumed without a second `~`");
    assert!(gap_ticks < 50_000, "no long stop: {gap_ticks}");
    sim.run_until_idle();
    assert_eq!(sim.machine().state(), MachineState::Idle);
    assert_eq!(sim.physical_position(), [8000, 4000, 0, 0]);
    assert_eq!(sim.hal().step_counts(), [8000, 4000, 0, 0], "no step lost or repeated");

    // A second `!` after the early `~` cancels it: the latest real-time command wins.
    let mut sim = Sim::new(cfg());
    sim.take_replies();
    sim.feed(b"G1 X100 F6000\n");
    sim.run_for(400_000);
    sim.feed(&[RT_FEED_HOLD]);
    sim.run_for(1_000);
    sim.feed(&[RT_RESUME]);
    sim.run_for(1_000);
    sim.feed(&[RT_FEED_HOLD]);
    run_until_state(&mut sim, MachineState::Held, 2_000_000);
    let held_at = sim.physical_position();
    sim.run_for(2_000_000);
    assert_eq!(sim.physical_position(), held_at, "held");
    assert!(held_at[0] < 8000);
    sim.feed(&[RT_RESUME]);
    sim.run_until_idle();
    assert_eq!(sim.physical_position(), [8000, 0, 0, 0]);
}

fn status(sim: &mut Sim) -> String {
    sim.feed(&[RT_STATUS]);
    sim.run_for(10);
    sim.take_replies().pop().unwrap()
}

#[test]
fn status_counts_completed_blocks_since_start_and_reset() {
    let mut sim = Sim::new(cfg());
    sim.take_replies();
    assert!(status(&mut sim).ends_with("|Q:0/32|N:0|C:0>"));
    sim.feed(b"G1 X10 F6000\nG1 Y10\nG4 P50\nG1 X0\n");
    // Part way: the first block done, the others still queued or running.
    while sim.machine().stepper().position()[0] < 800 {
        sim.run_for(1_000);
    }
    sim.run_for(1_000);
    let mid = status(&mut sim);
    assert!(mid.starts_with("<Run|") && mid.ends_with("|C:1>"), "{mid}");
    sim.run_until_idle();
    sim.take_replies();
    assert_eq!(status(&mut sim), "<Idle|MPos:0.000,10.000,0.000,0.000|Steps:0,800,0,0|Q:0/32|N:0|C:4>");
    // Zero-length moves queue nothing and count nothing.
    run(&mut sim, "G1 X0\n");
    assert!(status(&mut sim).ends_with("|C:4>"));
    run(&mut sim, "\u{18}");
    assert!(status(&mut sim).ends_with("|Q:0/32|N:0|C:0>"), "counted from the reset");
    run(&mut sim, "G1 X1 F600\n");
    assert!(status(&mut sim).ends_with("|C:1>"));
}

#[test]
fn reports_and_errors() {
    let mut sim = Sim::new(cfg());
    sim.take_replies();
    let r = run(&mut sim, "M115\nG92 X10\nM114\nG5\nG1 Q3\nG1 X1\nG1 E5 F100\nG4 P250\nM18\n");
    assert_eq!(
        r,
        [
            "FIRMWARE_NAME:plotter-fw FIRMWARE_VERSION:0.1.0 PROTOCOL_VERSION:3 RX_BUFFER:256 QUEUE_BLOCKS:32 LINE_MAX:96 TICK_HZ:1000000",
            "ok",
            "ok",
            "X:10.000 Y:0.000 Z:0.000 E:0.000 Count X:0 Y:0 Z:0 E:0",
            "ok",
            "error:3 unsupported command: G5",
            "error:4 unsupported or repeated word: Q",
            "error:9 value out of range: no feed rate (F) set for G1",
            "error:10 axis not configured: E",
            "ok",
            "ok"
        ]
    );
    assert_eq!(sim.now(), 250_000, "the dwell took 250 ms");
    assert!(!sim.hal().motors_on());
}

#[test]
fn overflow_is_reported_not_silent() {
    let mut opts = SimOptions::for_config(&cfg());
    opts.baud = Some(115_200);
    let mut sim = Sim::with_options(cfg(), opts);
    sim.take_replies();
    // A long dwell blocks the queue at 32 blocks; a host ignoring flow control overruns the buffer.
    let mut text = String::new();
    for _ in 0..100 {
        text.push_str("G4 P1000\n");
    }
    sim.feed(text.as_bytes());
    sim.run_until_idle();
    // The line cut by the overflow is answered when its end (here: the next line's) arrives.
    sim.feed(b"M114\n");
    sim.run_until_idle();
    let r = sim.take_replies();
    assert_eq!(r.iter().filter(|l| l.starts_with("error:6 receive buffer overflow, bytes lost: ")).count(), 1, "{r:?}");
    // 32 blocks in the planner, 2 in the stepper, 1 line waiting for room, 28 whole lines in the 256-byte buffer.
    assert_eq!(count(&r, "ok"), 32 + 2 + 1 + 28);
}

#[test]
fn servo_pen_m3_m5_drive_the_servo_after_the_queue_empties() {
    let mut sim = Sim::new(cfg());
    let r = run(&mut sim, "G1 X10 F600\nM3 S30\nG4 P100\nM5\nM5 S120\nM3\nM3 S200\n");
    // Five ok, then the two M3 without a valid angle refused.
    assert_eq!(count(&r, "ok"), 5, "{r:?}");
    assert_eq!(r.iter().filter(|l| l.starts_with("error:9")).count(), 2, "{r:?}");
    let servo = sim.hal().servo_trace().to_vec();
    let angles: Vec<(f32, u16)> = servo.iter().map(|s| (s.1, s.2)).collect();
    assert_eq!(angles, [(30.0, 1167), (90.0, 1500), (120.0, 1667)]);
    // M3 waited for the 10 mm move (800 steps at 10 mm/s: at least 1 s), and M5 for the 100 ms dwell after it.
    assert!(servo[0].0 >= 1_000_000, "{}", servo[0].0);
    assert!(servo[1].0 >= servo[0].0 + 100_000);
    assert_eq!(sim.physical_position()[0], 800);
}

#[test]
fn servo_frames_drive_the_servo_in_the_stepper_time_line() {
    let move_x = StepBlock {
        steps: [400, 0, 0, 0],
        entry_rate: 2000,
        cruise_rate: 2000,
        exit_rate: 2000,
        accel: 0,
        dwell_ticks: 0,
        servo: None,
    };
    // Pen down to 30.0°, settle 150 ms, 400 steps at 2000/s (200 ms), pen up to 95.5°, settle 150 ms.
    let blocks = [StepBlock::servo(300, 150_000), move_x, StepBlock::servo(955, 150_000)];
    let wire: Vec<u8> = encode_all(&blocks).concat();
    let mut sim = Sim::new(cfg());
    sim.take_replies();
    sim.feed(&wire);
    sim.run_until_idle();
    assert_eq!(count(&sim.take_replies(), "ok"), 3);
    // 1000 µs + 30/180 · 1000 µs = 1166.7 → 1167; 1000 + 95.5/180 · 1000 = 1530.6 → 1531.
    let servo = sim.hal().servo_trace().to_vec();
    let start = servo[0].0;
    assert_eq!(servo, [(start, 30.0, 1167), (start + 350_000, 95.5, 1531)]);
    assert_eq!(sim.hal().step_counts(), [400, 0, 0, 0], "no Z steps");
    assert_eq!(sim.hal().busy_ticks(), 500_000);
}

#[test]
fn m0_pauses_a_gcode_stream_until_resume() {
    let mut sim = Sim::new(cfg());
    let r = run(&mut sim, "G1 X5 F600\nM0\nG1 X10\n");
    assert_eq!(count(&r, "ok"), 2, "the line after M0 waits: {r:?}");
    assert_eq!(sim.physical_position()[0], 400);
    sim.feed(b"?");
    sim.run_until_idle();
    assert!(sim.take_replies().iter().any(|l| l.starts_with("<Hold:0|")), "paused shows as a stopped hold");
    sim.feed(b"~");
    sim.run_until_idle();
    assert_eq!(count(&sim.take_replies(), "ok"), 1);
    assert_eq!(sim.physical_position()[0], 800);
}
