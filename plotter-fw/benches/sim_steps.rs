//! Simulated steps per second: the firmware on the simulator, executing a long diagonal move and a stream of
//! host-planned step-block frames (a 2000-segment spiral), with and without the per-step trace.
//!
//! Run: `cargo bench -p plotter-fw --bench sim_steps` (prints a table; target ≥ 20 M steps/s).

use std::time::Instant;

use plotter_fw::fmath::round_i32;
use plotter_fw::planner::{PlanBlock, link_all, plan, step_blocks};
use plotter_fw::protocol::{Encoder, MAX_FRAME, quantize};
use plotter_fw::sim::{Sim, SimOptions};
use plotter_fw::{MachineConfig, NUM_AXES};

fn config() -> MachineConfig {
    let mut c = MachineConfig::xy_plotter();
    // A big, fast machine so one move has many steps.
    c.axes[0].travel_mm = 100_000.0;
    c.axes[1].travel_mm = 100_000.0;
    c.axes[0].steps_per_mm = 200.0;
    c.axes[1].steps_per_mm = 200.0;
    c.axes[0].max_feed_mm_s = 1000.0;
    c.axes[1].max_feed_mm_s = 1000.0;
    c.hard_limits = false;
    c
}

fn spiral_frames(c: &MachineConfig) -> (Vec<u8>, u64) {
    let mut blocks = Vec::new();
    let mut cur = [0i32; NUM_AXES];
    for i in 0..2000 {
        let a = f64::from(i) * 0.05;
        let r = 5.0 + f64::from(i) * 0.05;
        let t = [round_i32(r * a.cos() * 200.0), round_i32(r * a.sin() * 200.0), 0, 0];
        let steps = [t[0] - cur[0], t[1] - cur[1], 0, 0];
        cur = t;
        if let Some(b) = PlanBlock::line(c, steps, 800.0) {
            blocks.push(b);
        }
    }
    link_all(&mut blocks, c);
    plan(&mut blocks, 0.0);
    let mut enc = Encoder::new();
    let mut wire = Vec::new();
    let mut steps = 0u64;
    for (i, b) in step_blocks(&blocks).enumerate() {
        let q = quantize(&b);
        steps += q.steps.iter().map(|s| u64::from(s.unsigned_abs())).sum::<u64>();
        let mut out = [0u8; MAX_FRAME];
        let n = enc.encode(&q, u32::try_from(i).unwrap(), &mut out).unwrap();
        wire.extend_from_slice(&out[..n]);
    }
    (wire, steps)
}

fn measure(name: &str, record: bool, input: &[u8]) {
    let c = config();
    let mut best = f64::MAX;
    let mut steps = 0;
    for _ in 0..3 {
        let mut opts = SimOptions::for_config(&c);
        opts.record_steps = record;
        opts.switches = [None; NUM_AXES];
        let mut sim = Sim::with_options(c, opts);
        sim.feed(input);
        let t0 = Instant::now();
        sim.run_until_idle();
        best = best.min(t0.elapsed().as_secs_f64());
        steps = sim.hal().step_counts().iter().sum::<u64>();
    }
    println!(
        "{name:<40} {:>6} trace  {steps:>10} steps  {:>8.3} s  {:>8.1} M steps/s",
        if record { "with" } else { "no" },
        best,
        steps as f64 / best / 1e6
    );
}

fn main() {
    println!("simulated steps per second (best of 3)");
    let line = b"G1 X20000 Y15000 F60000\n";
    measure("one diagonal move (4M + 3M steps)", false, line);
    measure("one diagonal move (4M + 3M steps)", true, line);
    let (frames, expect) = spiral_frames(&config());
    println!(
        "(spiral: {} bytes of frames, {expect} steps, {:.1} bytes/block)",
        frames.len(),
        frames.len() as f64 / 2000.0
    );
    measure("2000 step-block frames (spiral)", false, &frames);
    measure("2000 step-block frames (spiral)", true, &frames);
}
