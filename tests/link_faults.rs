//! The link under line noise in both directions, with stray real-time bytes, on the in-process simulator: the
//! sample plot finishes with exactly the clean run's step trace; a flipped digit in a status reply changes
//! nothing. (Power loss and resume: `power_loss.rs`.)

use std::time::Duration;

use plotter_e2e::sample;
use plotter_fw::Axis;
use plotter_host::job::{self, progress::JobProgress, progress::PlotEvents};
use plotter_host::link::Transport;
use plotter_host::link::faults::Noise;
use plotter_host::link::session::Session;
use plotter_host::link::sim::SimTransport;
use plotter_path::MachineProfile;
use plotter_path::geometry::steps::{StepDrawing, drawing_to_steps};
use plotter_path::input::svg::{ResourcePolicy, SvgOptions, import_svg};
use plotter_path::motion::plan::machine_config;

struct Quiet;
impl PlotEvents for Quiet {
    fn progress(&mut self, _: &JobProgress) {}
}

fn duck_steps(profile: &MachineProfile) -> StepDrawing {
    let data = std::fs::read(sample("duck.svg")).unwrap();
    let imported = import_svg(&data, "duck.svg", &ResourcePolicy::DataUrlsOnly, &SvgOptions::default()).unwrap();
    drawing_to_steps(profile, &imported.drawing).unwrap()
}

struct Run {
    trace: Vec<(Axis, bool)>,
    elapsed: Duration,
    resends: u64,
    damaged: u64,
    injected: u64,
}

fn plot(transport: SimTransport) -> Run {
    let profile = MachineProfile::default_plotter();
    let steps = duck_steps(&profile);
    let mut s = Session::connect(transport, "sim").unwrap();
    let out = job::plot(&mut s, &profile, &steps, true, false, None, &mut Quiet).unwrap();
    assert!(!s.framed, "framed mode is left at the end");
    let sim = s.transport.sim();
    Run {
        trace: sim.hal().steps().iter().map(|e| (e.axis, e.forward)).collect(),
        elapsed: out.stats.elapsed,
        resends: out.stats.resends,
        damaged: out.stats.damaged_replies,
        injected: s.transport.noise().0.map_or(0, |n| n.injected),
    }
}

fn transport() -> SimTransport {
    let profile = MachineProfile::default_plotter();
    SimTransport::new(machine_config(&profile).unwrap(), Some(profile.link.baud))
}

#[test]
fn noise_both_ways_and_stray_realtime_bytes_never_change_the_drawing() {
    let clean = plot(transport());
    assert!(clean.trace.len() > 10_000);
    let (mut worst, mut total) = (0.0f64, 0.0f64);
    let (mut resends, mut damaged, mut injected) = (0, 0, 0);
    for seed in 1..=20u64 {
        // 1 % of the bytes each way damaged (half flipped in one bit, half dropped) and 0.1 % stray real-time bytes
        // (`?`, `!`, `~`, Ctrl-X) towards the firmware.
        let t = transport()
            .with_noise(Noise::new(0.01, seed).with_realtime(0.001))
            .with_reply_noise(Noise::new(0.01, seed + 1000));
        let noisy = plot(t);
        assert!(noisy.trace == clean.trace, "seed {seed}: the step trace differs from the clean run");
        let overhead = noisy.elapsed.as_secs_f64() / clean.elapsed.as_secs_f64() - 1.0;
        worst = worst.max(overhead);
        total += overhead;
        resends += noisy.resends;
        damaged += noisy.damaged;
        injected += noisy.injected;
    }
    assert!(
        resends > 20 && damaged > 20 && injected > 20,
        "the noise did reach both ways: {resends} {damaged} {injected}"
    );
    println!(
        "20 noisy runs: time overhead mean {:.1} %, worst {:.1} % (clean {:.1} s); {resends} resends, {damaged} damaged \
         replies ignored, {injected} stray real-time bytes",
        total / 20.0 * 100.0,
        worst * 100.0,
        clean.elapsed.as_secs_f64()
    );
}

/// A transport that flips one digit of the position in every other status report (`Steps:0,` → `Steps:8,`).
struct FlipStatus {
    inner: SimTransport,
    count: u64,
}

impl Transport for FlipStatus {
    fn send(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        self.inner.send(bytes)
    }
    fn recv_line(&mut self, timeout: Duration) -> std::io::Result<Option<String>> {
        let Some(l) = self.inner.recv_line(timeout)? else { return Ok(None) };
        if let Some(i) = l.find("|Steps:").map(|i| i + "|Steps:".len()) {
            self.count += 1;
            if self.count % 2 == 1 {
                let mut b = l.into_bytes();
                b[i] = b'0' + (b[i] - b'0' + 8) % 10;
                return Ok(Some(String::from_utf8(b).unwrap()));
            }
        }
        Ok(Some(l))
    }
    fn now(&self) -> Duration {
        self.inner.now()
    }
}

#[test]
fn a_flipped_digit_in_a_status_reply_never_changes_the_drawing() {
    let clean = plot(transport());
    let profile = MachineProfile::default_plotter();
    let steps = duck_steps(&profile);
    let mut s = Session::connect(FlipStatus { inner: transport(), count: 0 }, "sim").unwrap();
    job::plot(&mut s, &profile, &steps, true, false, None, &mut Quiet).unwrap();
    assert!(s.transport.count > 10, "{} status reports", s.transport.count);
    let trace: Vec<(Axis, bool)> = s.transport.inner.sim().hal().steps().iter().map(|e| (e.axis, e.forward)).collect();
    assert!(trace == clean.trace, "the drawing changed");
}
