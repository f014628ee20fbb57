//! The servo-pen profile (`samples/servo-plotter.toml`) on the simulated firmware: the pen moves by protocol-3
//! servo step blocks, never by Z steps, and the plot takes exactly the host's planned time. The three-pen sample,
//! counted by hand from `samples/three-pens.svg`: black frame + black line (2 strokes), red circle + three red rays
//! (4), blue wave (1) = 7 strokes, so 7 drops + 7 lifts + the lift that starts every servo plot (a servo's angle is
//! not known before it is commanded) = 15 servo commands.

use plotter_fw::sim::Sim;
use plotter_host::link::grbl::emulator::GrblEmulator;
use plotter_host::link::grbl::program::{declare_position, program};
use plotter_path::motion::plan::{self, Lookahead, MotionPlan};
use plotter_path::motion::steps::drawing_to_steps;
use plotter_path::{MachineProfile, input::svg};

const STROKES: usize = 7;

fn profile(name: &str) -> MachineProfile {
    let path = plotter_e2e::sample(name);
    MachineProfile::from_toml(&std::fs::read_to_string(&path).unwrap(), name).unwrap()
}

fn three_pens_plan(profile: &MachineProfile, start: [i32; 4]) -> MotionPlan {
    let data = std::fs::read(plotter_e2e::sample("three-pens.svg")).unwrap();
    let drawing =
        svg::import_svg(&data, "three-pens.svg", &svg::ResourcePolicy::DataUrlsOnly, &svg::SvgOptions::default())
            .unwrap()
            .drawing;
    let steps = drawing_to_steps(profile, &drawing).unwrap();
    assert_eq!(steps.strokes.len(), STROKES);
    plan::plan(profile, &steps, start, Lookahead::Whole).unwrap()
}

/// Home the simulator, stream the plan's frames, run it: the plan, the servo commands (time, angle), the step
/// counts of the plot alone and its executed time (ticks).
fn plot_on_sim(profile: &MachineProfile) -> (MotionPlan, Vec<(u64, f32)>, [u64; 4], u64) {
    let mut sim = Sim::new(plan::machine_config(profile).unwrap());
    sim.feed(b"G28\n");
    sim.run_until_idle();
    assert!(sim.take_replies().iter().any(|l| l == "ok"), "homing");
    let plan = three_pens_plan(profile, sim.machine().stepper().position());
    let (busy0, steps0) = (sim.hal().busy_ticks(), sim.hal().step_counts());
    plotter_e2e::play_framed(&mut sim, &plan);
    let steps = sim.hal().step_counts();
    let plotted = core::array::from_fn(|i| steps[i] - steps0[i]);
    let servo = sim.hal().servo_trace().iter().map(|s| (s.0, s.1)).collect();
    (plan, servo, plotted, sim.hal().busy_ticks() - busy0)
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
    // Each servo command is followed by its 150 ms settle before anything else moves.
    assert!(commands.windows(2).all(|w| w[1].0 - w[0].0 >= 150_000), "{commands:?}");

    // The same drawing on the Z-lift kit: the same XY steps, and Z steps 4 mm × 400 steps/mm down and up per stroke.
    let (z_plan, _, z_steps, z_ticks) = plot_on_sim(&profile("xy-plotter.toml"));
    assert_eq!(z_ticks, z_plan.total_ticks);
    assert_eq!(z_steps[2], u64::try_from(2 * STROKES * 1600).unwrap());
    assert_eq!([steps[0], steps[1]], [z_steps[0], z_steps[1]]);
    #[allow(clippy::cast_precision_loss)]
    let (s, z) = (ticks as f64 / 1e6, z_ticks as f64 / 1e6);
    eprintln!("three-pens.svg, drawing order: servo pen {s:.3} s, Z-lift kit {z:.3} s");
    assert!(ticks < z_ticks, "a 150 ms servo settle beats a 4 mm Z move plus 50 ms: {s} s vs {z} s");
}

#[test]
fn grbl_program_of_a_servo_plan_runs_on_the_emulator() {
    let servo = profile("servo-plotter.toml");
    let start = plan::homed_position(&servo).unwrap();
    let plan = three_pens_plan(&servo, start);
    let prog = program(&servo, &plan);
    let m5 = prog.lines.iter().filter(|l| l.as_str() == "M5 G4 P0.15").count();
    let m3 = prog.lines.iter().filter(|l| l.starts_with("M3 S") && l.ends_with(" G4 P0.15")).count();
    assert_eq!((m5, m3), (STROKES + 1, STROKES), "{:?}", prog.lines);
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
