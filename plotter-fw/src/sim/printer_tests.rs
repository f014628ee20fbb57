//! The printer profile through the simulator: extrusion in G-code, heaters on the thermal model, PID hold,
//! autotune, and every thermal safety trip within its documented time with the heaters off afterwards.

use std::string::String;
use std::vec::Vec;

use super::thermal::SimFault;
use super::*;
use crate::config::AxisConfig;
use crate::errors::AlarmCode;
use crate::errors::{Fault, ThermalAlarm};
use crate::heater::Heater;

const S: u64 = 1_000_000;

fn printer_cfg() -> MachineConfig {
    let mut c = MachineConfig::xy_plotter();
    c.axes[3] = AxisConfig {
        enabled: true,
        steps_per_mm: 93.0,
        travel_mm: 0.0,
        max_feed_mm_s: 120.0,
        max_accel_mm_s2: 5000.0,
        invert_dir: false,
        home_at_max: false,
    };
    c
}

fn printer() -> Sim {
    let cfg = printer_cfg();
    let opts = SimOptions { thermal: ThermalConfig::printer(), ..SimOptions::for_config(&cfg) };
    Sim::with_options(cfg, opts)
}

/// Run in 100 ms slices until `done` (or `limit_s` of virtual time passed); the time it became true.
fn run_until(sim: &mut Sim, limit_s: u64, mut done: impl FnMut(&mut Sim) -> bool) -> Option<u64> {
    let end = sim.now() + limit_s * S;
    while sim.now() < end {
        sim.run_for(S / 10);
        if done(sim) {
            return Some(sim.now());
        }
    }
    None
}

fn replies_contain(sim: &mut Sim, log: &mut Vec<String>, what: &str) -> bool {
    log.extend(sim.take_replies());
    log.iter().any(|l| l.contains(what))
}

/// Heat the hot end to 210 °C with M109 and return when the `ok` arrived.
fn heat_to_210(sim: &mut Sim) -> u64 {
    let mut log = Vec::new();
    sim.feed(b"M109 S210\n");
    run_until(sim, 300, |s| replies_contain(s, &mut log, "ok")).expect("M109 finished")
}

fn alarm_of(sim: &Sim) -> Option<ThermalAlarm> {
    match sim.machine().alarm() {
        Some(AlarmCode::Thermal(a)) => Some(a),
        _ => None,
    }
}

/// After a trip: every heater at 0 duty, and still 0 (and the block cooling) 20 s later.
fn assert_heaters_stay_off(sim: &mut Sim, heater: Heater) {
    assert_eq!(sim.heaters().duty(Heater::HotEnd), 0);
    assert_eq!(sim.heaters().duty(Heater::Bed), 0);
    assert!(!sim.hal().motors_on());
    let t0 = sim.heaters().temperature(heater);
    sim.run_for(20 * S);
    assert_eq!(sim.heaters().duty(heater), 0);
    assert!(sim.heaters().temperature(heater) <= t0 + 1e-9);
}

/// Largest deviation of the true block temperature from `target` over `secs` seconds, sampled every 100 ms.
fn hold_deviation(sim: &mut Sim, target: f64, secs: u64) -> f64 {
    let mut worst = 0.0f64;
    for _ in 0..secs * 10 {
        sim.run_for(S / 10);
        worst = worst.max((sim.heaters().temperature(Heater::HotEnd) - target).abs());
        let measured = f64::from(sim.machine().thermal().temperature(Heater::HotEnd));
        worst = worst.max((measured - target).abs() - 0.5);
    }
    worst
}

#[test]
fn extrusion_modes_retractions_and_g92() {
    let mut sim = printer();
    sim.take_replies();
    // Cold, so cold extrusion is allowed first (`cold_extrusion_is_refused_until_allowed_or_hot` tests the guard).
    assert_eq!(run(&mut sim, "M302 P1\n"), ["ok"]);
    // Relative E (M83): 1 mm with 10 mm of X, a 0.8 mm retraction and its prime as E-only moves.
    // Absolute E (M82) after G92 E0: E2 is 2 mm more.
    let g = "G21\nM83\nG1 X10 E1 F600\nG1 E-0.8 F2100\nG1 E0.8\nG92 E0\nM82\nG1 X20 E2 F600\nG1 E1.5 F2100\n\
             G91\nG1 E0.25\nG90\nM114\n";
    sim.feed(g.as_bytes());
    sim.run_until_idle();
    let r = sim.take_replies();
    assert_eq!(r.iter().filter(|l| *l == "ok").count(), 13, "{r:?}");
    // Net E: 1 − 0.8 + 0.8 + 2 − 0.5 + 0.25 = 2.75 mm = 255.75 → 256 steps (drift-free rounding of the absolute
    // position: 0.75 + 2 = 2.75 mm of machine E).
    assert_eq!(sim.physical_position()[3], 256);
    // Absolute targets 1.0, 0.2, 1.0, 3.0, 2.5, 2.75 mm → 93, 19 (18.6), 93, 279, 233 (232.5), 256 (255.75) steps.
    let e_steps = sim.hal().step_counts()[3];
    assert_eq!(e_steps, 93 + 74 + 74 + 186 + 46 + 23, "{e_steps}");
    // M114 reports E in work coordinates: G92 E0 at 1.0 mm machine E, now 2.75 → 1.75.
    assert!(r.iter().any(|l| l.starts_with("X:20.000 Y:0.000 Z:0.000 E:1.750")), "{r:?}");
}

fn run(sim: &mut Sim, text: &str) -> Vec<String> {
    sim.feed(text.as_bytes());
    sim.run_until_idle();
    sim.take_replies()
}

/// The hot-end temperature an `error:15` reply states (`hot end 20.0 C, below ...`).
fn stated_temperature(reply: &str) -> f64 {
    let t = reply.split("hot end ").nth(1).and_then(|r| r.split(" C,").next()).expect(reply);
    t.parse().expect(reply)
}

#[test]
fn cold_extrusion_is_refused_until_allowed_or_hot() {
    let mut sim = printer();
    sim.take_replies();
    let e_steps = |sim: &Sim| sim.hal().step_counts()[3];
    // At room temperature: an E-only move and a move with E are refused whole (X does not move either).
    let r = run(&mut sim, "G1 E5 F300\nG1 X10 E5\nM114\n");
    assert_eq!(r.len(), 4, "{r:?}");
    for reply in &r[..2] {
        assert!(
            reply.starts_with("error:15 cold extrusion prevented: hot end ")
                && reply.ends_with(", below the minimum of 170.0 C (M302 P1 allows cold extrusion)"),
            "{reply}"
        );
        let t = stated_temperature(reply);
        assert!((19.0..=21.0).contains(&t), "{reply}");
    }
    assert!(r[2].starts_with("X:0.000 Y:0.000 Z:0.000 E:0.000"), "{r:?}");
    assert_eq!((sim.hal().step_counts(), sim.machine().target_steps()), ([0; 4], [0; 4]));
    // Moves without extrusion run; M302 reports the guard.
    assert_eq!(run(&mut sim, "G1 X10 F600\n"), ["ok"]);
    assert_eq!(sim.physical_position()[0], 800);
    let r = run(&mut sim, "M302\n");
    assert!(r[0].starts_with("cold extrusion prevented (minimum 170.0 C, hot end "), "{r:?}");
    // M302 P1: allowed; 5 mm at 93 steps/mm is exactly 465 steps.
    assert_eq!(run(&mut sim, "M302 P1\nG1 E5 F300\n"), ["ok", "ok"]);
    assert_eq!(e_steps(&sim), 465);
    assert_eq!(sim.physical_position()[3], 465);
    // M302 P0: prevented again.
    let r = run(&mut sim, "M302 P0\nG1 E6\n");
    assert!(r[0] == "ok" && r[1].starts_with("error:15 "), "{r:?}");
    assert_eq!(e_steps(&sim), 465);
    // M302 S15: the minimum is 15 C, the hot end at about 20 C is warm enough; S0 allows everything.
    assert_eq!(run(&mut sim, "M302 S15\nG1 E6\n"), ["ok", "ok"]);
    assert_eq!(sim.physical_position()[3], 558);
    let r = run(&mut sim, "M302 S170\nG1 E7\nM302 S300\nM302 P2\n");
    assert!(r[0] == "ok" && r[1].starts_with("error:15 "), "{r:?}");
    assert!(r[2].starts_with("error:9 value out of range: M302 S") && r[3].starts_with("error:9"), "{r:?}");
    // A reset restores the profile's guard after M302 P1.
    assert_eq!(run(&mut sim, "M302 P1\n"), ["ok"]);
    sim.feed(&[crate::protocol::RT_RESET]);
    sim.run_until_idle();
    sim.take_replies();
    let r = run(&mut sim, "G1 E7 F300\n");
    assert!(r[0].starts_with("error:15 "), "{r:?}");
    // Hot: extrusion runs. E7 absolute from 6 mm of work E: +1 mm = 93 steps.
    heat_to_210(&mut sim);
    sim.take_replies();
    assert_eq!(run(&mut sim, "G1 E7 F300\n"), ["ok"]);
    assert_eq!(e_steps(&sim), 465 + 93 + 93);
}

#[test]
fn a_number_run_into_e_is_refused_and_nothing_moves() {
    let mut sim = printer();
    sim.take_replies();
    // Cold extrusion allowed, so only the parser stands between `X1E5` and 5 mm of extrusion (Marlin's reading).
    let r = run(&mut sim, "M302 P1\nG1 X1E5 F600\nG1 X1e40\nN0 G1 X1e-05*44\nG1 X2 E0.5\nG1 X2 E0.5 F600\n");
    let ambiguous = "error:14 ambiguous number: a number runs into an E word (put a space before E) at column 5";
    assert_eq!(
        r,
        [
            "ok",
            ambiguous,
            ambiguous,
            "error:14 ambiguous number: a number runs into an E word (put a space before E) at column 6",
            "error:9 value out of range: no feed rate (F) set for G1",
            "ok"
        ]
    );
    // Not even the refused lines' F600 took effect (the first `G1 X2 E0.5` has no feed). Only the last line moved:
    // X2 = 160 steps, E0.5 = 46.5 → 47 steps (rounded once).
    assert_eq!(sim.hal().step_counts(), [160, 0, 0, 47]);
}

#[test]
fn cold_step_blocks_with_extrusion_are_refused_and_latch() {
    use crate::protocol::{Encoder, MAX_FRAME};
    let mut sim = printer();
    sim.take_replies();
    let block = |steps| crate::step_block::StepBlock {
        steps,
        entry_rate: 0,
        cruise_rate: 1000,
        exit_rate: 0,
        accel: 1000,
        dwell_ticks: 0,
        servo: None,
    };
    let mut enc = Encoder::new();
    let mut out = [0u8; MAX_FRAME];
    // X only (accepted), X with E (refused: cold), then X only (refused too: nothing after a hole in the print).
    for (seq, steps) in [[80, 0, 0, 0], [80, 0, 0, 93], [80, 0, 0, 0]].into_iter().enumerate() {
        let n = enc.encode(&block(steps), u32::try_from(seq).unwrap(), &mut out).unwrap();
        sim.feed(&out[..n]);
    }
    sim.run_until_idle();
    let r = sim.take_replies();
    assert_eq!(r.len(), 3, "{r:?}");
    assert_eq!(r[0], "ok");
    assert!(r[1].starts_with("error:15 cold extrusion prevented: hot end "), "{r:?}");
    assert_eq!(r[2], "error:12 step block refused: block 1 was refused");
    assert_eq!(sim.hal().step_counts(), [80, 0, 0, 0]);
    sim.feed(&[crate::protocol::RT_STATUS]);
    sim.run_for(1000);
    let status = sim.take_replies();
    assert!(status.iter().any(|l| l.ends_with("|R:1,15>")), "{status:?}");
}

#[test]
fn pid_holds_210_within_one_degree() {
    let mut sim = printer();
    let reached = heat_to_210(&mut sim);
    // 20 → 210 °C with a 40 W heater: at least the full-power time 120·ln(400/210) = 77 s.
    assert!(reached > 77 * S && reached < 150 * S, "{reached}");
    sim.run_for(60 * S);
    let dev = hold_deviation(&mut sim, 210.0, 120);
    eprintln!(
        "profile gains: 210 °C reached (M109 ok) at {:.1} s, worst deviation over 120 s: {dev:.3} °C",
        reached as f64 / 1e6
    );
    assert!(dev <= 1.0, "deviation {dev}");
    // With the part-cooling fan switched on (a load step), the loop recovers to within 1 °C.
    sim.feed(b"M106 S255\n");
    sim.run_for(60 * S);
    let dev = hold_deviation(&mut sim, 210.0, 60);
    eprintln!("with the fan at full: worst deviation {dev:.3} °C");
    assert!(dev <= 1.0, "deviation with fan {dev}");
}

#[test]
fn autotune_finds_gains_that_hold() {
    let mut sim = printer();
    // Spoil the gains first: autotune must find working ones by itself.
    sim.feed(b"M301 P2 I0.01 D1\nM303 E0 S210 C6 U1\n");
    let mut log = Vec::new();
    run_until(&mut sim, 1200, |s| replies_contain(s, &mut log, "PID autotune E0")).expect("autotune result");
    let line = log.iter().find(|l| l.starts_with("PID autotune E0")).unwrap().clone();
    let g = sim.machine().thermal().gains(Heater::HotEnd);
    assert!(g.kp > 2.0 && g.ki > 0.01 && g.kd > 1.0, "{line} {g:?}");
    // Heater off after the autotune.
    sim.run_for(S);
    assert_eq!(sim.heaters().duty(Heater::HotEnd), 0);
    heat_to_210(&mut sim);
    sim.run_for(60 * S);
    let dev = hold_deviation(&mut sim, 210.0, 120);
    eprintln!("{line}: worst deviation over 120 s {dev:.3} °C");
    assert!(dev <= 1.0, "autotuned {line}: deviation {dev}");
}

#[test]
fn broken_thermistor_trips_within_one_period() {
    for (fault, expect) in [(SimFault::ThermistorOpen, Fault::MinTemp), (SimFault::ThermistorShort, Fault::MaxTemp)] {
        let mut sim = printer();
        heat_to_210(&mut sim);
        sim.run_for(5 * S);
        let at = sim.now();
        sim.heaters_mut().inject(Heater::HotEnd, Some(fault));
        let mut log = Vec::new();
        let t = run_until(&mut sim, 5, |s| alarm_of(s).is_some()).expect("trip");
        // One thermal period (100 ms) plus the 100 ms slice of this loop.
        eprintln!("{fault:?}: tripped after {} ms", (t - at) / 1000);
        assert!(t - at <= 200_000, "{fault:?} took {}", t - at);
        assert_eq!(alarm_of(&sim), Some(ThermalAlarm { heater: Heater::HotEnd, fault: expect }));
        assert!(replies_contain(&mut sim, &mut log, "hot end sensor T0"), "{log:?}");
        assert_heaters_stay_off(&mut sim, Heater::HotEnd);
    }
}

#[test]
fn cartridge_out_while_heating_trips_the_heating_check() {
    let mut sim = printer();
    sim.feed(b"M104 S210\n");
    sim.run_for(30 * S);
    let at = sim.now();
    assert!(sim.heaters().temperature(Heater::HotEnd) < 150.0);
    sim.heaters_mut().inject(Heater::HotEnd, Some(SimFault::CartridgeOut));
    let t = run_until(&mut sim, 60, |s| alarm_of(s).is_some()).expect("trip");
    // Documented: within two heating periods (2 × 20 s) and one thermal period.
    eprintln!("cartridge out while heating: heating check tripped after {:.1} s", (t - at) as f64 / 1e6);
    assert!(t - at <= 40 * S + 200_000, "took {}", t - at);
    assert_eq!(alarm_of(&sim).unwrap().fault, Fault::HeatingFailed);
    assert_heaters_stay_off(&mut sim, Heater::HotEnd);
}

#[test]
fn cartridge_out_while_holding_trips_the_runaway_check() {
    let mut sim = printer();
    heat_to_210(&mut sim);
    sim.run_for(30 * S);
    let at = sim.now();
    sim.heaters_mut().inject(Heater::HotEnd, Some(SimFault::CartridgeOut));
    // Find when the reading left the 4 °C band, and when the alarm came.
    let mut left = None;
    let t = run_until(&mut sim, 120, |s| {
        // The check counts continuous time below the band (noise may carry a reading back once or twice).
        if s.machine().thermal().temperature(Heater::HotEnd) >= 206.0 {
            left = None;
        } else if left.is_none() {
            left = Some(s.now());
        }
        alarm_of(s).is_some()
    })
    .expect("trip");
    let left = left.expect("left the band");
    // Documented: hold_period_s (40 s) after leaving the band, within one thermal period (+ this loop's slice).
    eprintln!(
        "cartridge out while holding: left the band after {:.1} s, runaway {:.1} s later",
        (left - at) as f64 / 1e6,
        (t - left) as f64 / 1e6
    );
    assert!(t - left >= 40 * S - 200_000 && t - left <= 40 * S + 200_000, "left at {}, trip {}", left - at, t - at);
    assert_eq!(alarm_of(&sim).unwrap().fault, Fault::Runaway);
    assert_heaters_stay_off(&mut sim, Heater::HotEnd);
}

#[test]
fn stalled_adc_trips_the_watchdog() {
    let mut sim = printer();
    sim.feed(b"M140 S60\n");
    sim.run_for(10 * S);
    let at = sim.now();
    sim.heaters_mut().inject(Heater::Bed, Some(SimFault::AdcStalled));
    let t = run_until(&mut sim, 10, |s| alarm_of(s).is_some()).expect("trip");
    // watchdog_s = 2 s, plus one period and the slice.
    eprintln!("stalled ADC: watchdog tripped after {:.1} s", (t - at) as f64 / 1e6);
    assert!(t - at <= 2 * S + 200_000 && t - at >= 2 * S, "took {}", t - at);
    assert_eq!(alarm_of(&sim), Some(ThermalAlarm { heater: Heater::Bed, fault: Fault::SensorTimeout }));
    assert_heaters_stay_off(&mut sim, Heater::Bed);
}

#[test]
fn bed_heats_with_m190_and_reports() {
    let mut sim = printer();
    let mut log = Vec::new();
    sim.feed(b"M190 S60\nM105\n");
    let t = run_until(&mut sim, 400, |s| replies_contain(s, &mut log, "ok")).expect("M190 done");
    // 60 °C at full power: 250·ln(137.5/97.5) = 86 s of the 220 W bed, plus the approach under PID.
    assert!(t > 86 * S && t < 300 * S, "{t}");
    assert!((sim.heaters().temperature(Heater::Bed) - 60.0).abs() < 1.5);
    // While waiting, the temperatures were reported every second.
    let reports = log.iter().filter(|l| l.starts_with("T:") && l.contains(" B:")).count();
    assert!(reports as u64 >= t / S - 2, "{reports} reports in {t}");
    sim.run_for(S / 10);
    assert!(replies_contain(&mut sim, &mut log, "/60.00"));
}

#[test]
fn emergency_stop_acts_while_a_wait_holds_the_queue() {
    let mut sim = printer();
    sim.feed(b"M109 S210\nG1 X10 F600\n");
    sim.run_for(10 * S);
    assert!(sim.heaters().duty(Heater::HotEnd) > 0);
    sim.feed(b"M112\n");
    sim.run_for(1000);
    assert_eq!(sim.machine().alarm(), Some(AlarmCode::EmergencyStop));
    assert_heaters_stay_off(&mut sim, Heater::HotEnd);
    // Nothing moved, heating is refused until a reset.
    assert_eq!(sim.physical_position()[0], 0);
    let mut log = Vec::new();
    sim.feed(b"M104 S200\n");
    sim.run_for(S);
    assert!(replies_contain(&mut sim, &mut log, "error:8"), "{log:?}");
}

#[test]
fn plotter_has_no_heaters_and_no_thermal_schedule() {
    let mut sim = Sim::new(MachineConfig::xy_plotter());
    assert_eq!(sim.machine().thermal().next_deadline(), None);
    sim.feed(b"M104 S200\nM105\nG1 X1 F600\n");
    sim.run_until_idle();
    let r = sim.take_replies();
    assert_eq!(r.iter().filter(|l| l.starts_with("error:3")).count(), 2, "{r:?}");
    assert_eq!(r.last().map(String::as_str), Some("ok"));
}
