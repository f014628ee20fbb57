//! The servo-pen profile (`samples/servo-plotter.toml`) on the simulated firmware: the pen moves by protocol-3
//! servo step blocks, never by Z steps, and the plot takes exactly the host's planned time. The three-pen sample,
//! counted by hand from `samples/three-pens.svg`: black frame + black line (2 strokes), red circle + three red rays
//! (4), blue wave (1) = 7 strokes, so 7 drops + 7 lifts + the lift that starts every servo plot (a servo's angle is
//! not known before it is commanded) = 15 servo commands.

use plotter_fw::sim::Sim;
use plotter_host::link::grbl::emulator::GrblEmulator;
use plotter_host::link::grbl::program::{declare_position, program};
use plotter_path::geometry::steps::drawing_to_steps;
use plotter_path::motion::plan::{self, Lookahead, MotionPlan};
use plotter_path::motion::servo::ServoSync;
use plotter_path::{MachineProfile, input::svg};

const STROKES: usize = 7;

fn profile(name: &str) -> MachineProfile {
    let path = plotter_e2e::sample(name);
    MachineProfile::from_toml(&std::fs::read_to_string(&path).unwrap(), name).unwrap()
}

fn three_pens() -> plotter_path::Drawing {
    let data = std::fs::read(plotter_e2e::sample("three-pens.svg")).unwrap();
    svg::import_svg(&data, "three-pens.svg", &svg::ResourcePolicy::DataUrlsOnly, &svg::SvgOptions::default())
        .unwrap()
        .drawing
}

fn three_pens_plan(profile: &MachineProfile, start: [i32; 4]) -> MotionPlan {
    let drawing = three_pens();
    let steps = drawing_to_steps(profile, &drawing).unwrap();
    assert_eq!(steps.strokes.len(), STROKES);
    plan::plan(profile, &steps, start, Lookahead::Whole).unwrap()
}

/// The positions the simulated servo plotter stepped while the pen was below its clearance off the drawing: the
/// ink check of [`plotter_e2e::ink_off_drawing`] with the servo's timing ([`plotter_e2e::servo_low_intervals`],
/// judged with `judge`'s settle and clear times).
fn servo_inks_off(judge: &MachineProfile, sim: &Sim) -> Vec<[i64; 2]> {
    let ms = |v: f64| {
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let t = (v * 1000.0).round() as u64;
        t
    };
    #[allow(clippy::cast_possible_truncation)]
    let up = judge.pen.servo_up_deg as f32;
    let low = plotter_e2e::servo_low_intervals(
        sim.hal().servo_trace(),
        up,
        ms(judge.pen.settle_ms),
        ms(judge.pen.servo_clear_ms()),
    );
    let samples = plotter_e2e::sim_positions(sim)
        .into_iter()
        .map(|(t, p)| (low.iter().any(|&(a, b)| (a..b).contains(&t)), [p[0], p[1]]));
    let paths = plotter_e2e::machine_paths(judge, &three_pens());
    plotter_e2e::ink_off_drawing(samples, &paths, judge.axes.x.steps_per_mm, svg::DEFAULT_TOLERANCE_MM)
}

/// Home the simulator, stream the plan's frames, run it: the plan, the servo commands (time, angle), the step
/// counts of the plot alone and its executed time (ticks).
fn plot_on_sim(profile: &MachineProfile) -> (MotionPlan, Vec<(u64, f32)>, [u64; 4], u64) {
    let (plan, sim, steps, ticks) = plot_on_sim_with(profile, profile);
    let servo = sim.hal().servo_trace().iter().map(|s| (s.0, s.1)).collect();
    (plan, servo, steps, ticks)
}

/// [`plot_on_sim`] of a plan made with `planned_with`, returning the simulator.
fn plot_on_sim_with(profile: &MachineProfile, planned_with: &MachineProfile) -> (MotionPlan, Sim, [u64; 4], u64) {
    let mut sim = Sim::new(plan::machine_config(profile).unwrap());
    sim.feed(b"G28\n");
    sim.run_until_idle();
    assert!(sim.take_replies().iter().any(|l| l == "ok"), "homing");
    let plan = three_pens_plan(planned_with, sim.machine().stepper().position());
    let (busy0, steps0) = (sim.hal().busy_ticks(), sim.hal().step_counts());
    plotter_e2e::play_framed(&mut sim, &plan);
    let steps = sim.hal().step_counts();
    let plotted = core::array::from_fn(|i| steps[i] - steps0[i]);
    let ticks = sim.hal().busy_ticks() - busy0;
    (plan, sim, plotted, ticks)
}

#[test]
fn servo_pen_plots_with_servo_blocks_and_no_z_steps() {
    let servo = profile("servo-plotter.toml");
    let (plan, commands, steps, ticks) = plot_on_sim(&servo);
    assert_eq!(commands.len(), 2 * STROKES + 1, "{commands:?}");
    assert_eq!(steps[2], 0, "no Z steps");
    assert_eq!(ticks, plan.total_ticks, "executed time = planned time, to the tick");
    // Up at 90°, then down/up per stroke: black and red pens at the profile's 30°, the blue brush at its 25°.
    let angles: Vec<f32> = commands.iter().map(|c| c.1).collect();
    let mut expected = vec![90.0];
    for down in [30.0, 30.0, 30.0, 30.0, 30.0, 30.0, 25.0] {
        expected.extend([down, 90.0]);
    }
    assert_eq!(angles, expected);
    // A drop is never commanded before the lift before it has the tip clear (0.3 of the 150 ms swing: 45 ms; the
    // drop then reverses the servo where the lift has taken it), and a lift comes no sooner than the tip touched
    // after the drop (70 % of the swing from the top: 105 ms; the strokes here are longer than that to draw).
    let short: Vec<(u64, u64)> = commands
        .windows(2)
        .skip(1)
        .map(|w| (w[0].0, w[1].0 - w[0].0))
        .enumerate()
        .filter(|&(i, (_, gap))| gap < if i % 2 == 0 { 105_000 } else { 45_000 })
        .map(|(_, g)| g)
        .collect();
    assert!(short.is_empty(), "{short:?} in {commands:?}");
    // The hops overlap the servo with the travel, yet the pen is never below its clearance off the drawing.
    let (_, sim, _, _) = plot_on_sim_with(&servo, &servo);
    let off = servo_inks_off(&servo, &sim);
    assert!(off.is_empty(), "{} positions off the drawing: {:?}", off.len(), off.first());

    // The same drawing on the Z-lift kit: the same XY steps, and the Z steps the plan holds.
    let (z_plan, _, z_steps, z_ticks) = plot_on_sim(&profile("xy-plotter.toml"));
    assert_eq!(z_ticks, z_plan.total_ticks);
    let planned_z: u64 = z_plan.blocks.iter().map(|b| u64::from(b.block.steps[2].unsigned_abs())).sum();
    assert_eq!(z_steps[2], planned_z);
    assert_eq!([steps[0], steps[1]], [z_steps[0], z_steps[1]]);
    #[allow(clippy::cast_precision_loss)]
    let (s, z) = (ticks as f64 / 1e6, z_ticks as f64 / 1e6);
    eprintln!("three-pens.svg, drawing order: servo pen {s:.3} s, Z-lift kit {z:.3} s");
}

/// The servo ink check can fail: a plan that believes the tip clears the paper after 10 ms (and so starts
/// travelling then, and commands drops 140 ms before it needs the pen down) moves the carriage while the real
/// servo (clear only after 50 ms) is still below the clearance.
#[test]
fn the_servo_ink_check_catches_travel_before_the_tip_is_clear() {
    let servo = profile("servo-plotter.toml");
    let mut hasty = servo.clone();
    hasty.pen.clear_ms = Some(10.0);
    let (_, sim, _, _) = plot_on_sim_with(&servo, &hasty);
    let off = servo_inks_off(&servo, &sim);
    assert!(!off.is_empty(), "the early travel went unnoticed");
    assert!(servo_inks_off(&hasty, &sim).is_empty(), "judged with the timing it was planned for");
}

#[test]
fn grbl_program_of_a_servo_plan_runs_on_the_emulator() {
    // Planned for GRBL, which stops the motion for `M3`.
    let servo = MachineProfile { servo_sync: ServoSync::AtRest, ..profile("servo-plotter.toml") };
    let start = plan::homed_position(&servo).unwrap();
    let plan = three_pens_plan(&servo, start);
    let prog = program(&servo, &plan);
    // The pen is lifted with `M3` at its up angle (90°), never let go with `M5` (stock GRBL's servo would go limp).
    let lifts = prog.lines.iter().filter(|l| l.starts_with("M3 S90 G4 P")).count();
    let m3 = prog.lines.iter().filter(|l| l.starts_with("M3 S") && l.contains(" G4 P")).count();
    assert_eq!((lifts, m3 - lifts), (STROKES + 1, STROKES), "{:?}", prog.lines);
    assert!(!prog.lines.iter().any(|l| l.contains("M5")), "{:?}", prog.lines);
    // The first lift, the lifts before the two pen changes and the last keep their whole 150 ms; the four lifts
    // between strokes of one pen (black frame to horizon, red circle to rays) wait the 50 ms clear time only
    // (each written a millisecond short of its whole 50 ms steps, which GRBL dwells in).
    let whole = prog.lines.iter().filter(|l| l.as_str() == "M3 S90 G4 P0.149").count();
    assert_eq!(whole, 4, "{:?}", prog.lines);
    let mut emu = GrblEmulator::new(&servo, None).unwrap();
    emu.take_replies();
    // Home (GRBL starts locked in alarm when homing is on), then declare the plan's start as the sender does.
    let lines = ["$H".to_string(), declare_position(&servo, start)].into_iter().chain(prog.lines.iter().cloned());
    let mut z_after_homing = 0;
    for (i, line) in lines.enumerate() {
        if i == 2 {
            z_after_homing = emu.backend().hal().step_counts()[2];
        }
        emu.feed(format!("{line}\n").as_bytes());
        let mut replies = Vec::new();
        for _ in 0..100_000 {
            emu.run_for(10_000);
            replies.extend(emu.take_replies());
            if replies.iter().any(|r| r == "ok" || r.starts_with("error:")) {
                break;
            }
        }
        assert!(replies.iter().any(|r| r == "ok"), "{line}: {replies:?}");
    }
    let servo_cmds = emu.backend().hal().servo_trace().len();
    assert_eq!(servo_cmds, 2 * STROKES + 1);
    assert_eq!(emu.backend().hal().step_counts()[2], z_after_homing, "no Z steps after homing");
}
