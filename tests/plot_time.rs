//! Host-planned time against the simulator's executed time, and the executed geometry against the plan, with the
//! frames fed straight into the simulated firmware (plotter-path's plan, plotter-fw's protocol and simulator).

use plotter_e2e::SAMPLE_SVG;
use plotter_fw::protocol::{Encoder, MAX_FRAME};
use plotter_fw::sim::Sim;
use plotter_path::motion::plan::{self, Lookahead, MotionPlan};
use plotter_path::motion::steps::drawing_to_steps;
use plotter_path::{MachineProfile, input::svg};

fn run_on_sim(profile: &MachineProfile, plan_for: impl Fn([i32; 4]) -> MotionPlan) -> (MotionPlan, Sim, u64) {
    let cfg = plan::machine_config(profile).unwrap();
    let mut sim = Sim::new(cfg);
    sim.feed(b"G28\n");
    sim.run_until_idle();
    assert!(sim.take_replies().iter().any(|l| l == "ok"), "homing");
    let start = sim.machine().stepper().position();
    let plan = plan_for(start);
    let busy0 = sim.hal().busy_ticks();
    let seq0 = sim.machine().expected_seq();
    let mut enc = Encoder::new();
    let mut buf = [0u8; MAX_FRAME];
    for (i, b) in plan.blocks.iter().enumerate() {
        let n = enc.encode(&b.block, seq0 + u32::try_from(i).unwrap(), &mut buf).unwrap();
        // The simulated wire is flow-controlled: bytes wait until the receive buffer has room.
        sim.feed(&buf[..n]);
    }
    sim.run_until_idle();
    let replies = sim.take_replies();
    assert_eq!(replies.iter().filter(|l| *l == "ok").count(), plan.blocks.len(), "{replies:?}");
    let executed = sim.hal().busy_ticks() - busy0;
    (plan, sim, executed)
}

#[test]
fn host_time_equals_executed_time() {
    for profile_text in [include_str!("../samples/xy-plotter.toml"), include_str!("../samples/printer.toml")] {
        let profile = MachineProfile::from_toml(profile_text, "sample").unwrap();
        let opts = svg::SvgOptions::default();
        let drawing = svg::import_svg(SAMPLE_SVG.as_bytes(), "sample.svg", None, &opts).unwrap().drawing;
        let steps = drawing_to_steps(&profile, &drawing).unwrap();
        for look in [Lookahead::Whole, Lookahead::Window(16)] {
            let (plan, sim, executed) =
                run_on_sim(&profile, |start| plan::plan(&profile, &steps, start, look).unwrap());
            // Required: within 0.1 %; by construction the two are the same arithmetic, so they agree to the tick.
            let host = plan.total_ticks;
            let diff = host.abs_diff(executed);
            assert!(diff * 1000 <= host, "{}: host {host} vs executed {executed}", profile.name);
            assert_eq!(host, executed, "{}", profile.name);
            let end = sim.physical_position();
            assert_eq!([end[0], end[1], end[2]], [plan.end[0], plan.end[1], plan.end[2]].map(i64::from));
        }
    }
}
