//! Power loss mid-plot: host and firmware are cut together at many points of a sample plot (the journal keeps what
//! the host had written at that instant), both restart (the carriage stays where it stopped), and the plot resumes
//! from the journal. The pen-down steps drawn twice must not exceed the steps of the one block that was running at
//! the cut: the journal follows the firmware's completion reports to the very last block.

use std::cell::Cell;
use std::collections::HashMap;
use std::path::PathBuf;
use std::time::Duration;

use plotter_e2e::{SAMPLE_SVG, scratch};
use plotter_fw::sim::{Sim, SimOptions, StepEvent};
use plotter_fw::{Axis, NUM_AXES};
use plotter_host::job::{self, JournalSpec, progress::JobProgress, progress::PlotEvents};
use plotter_host::link::Transport;
use plotter_host::link::journal;
use plotter_host::link::session::Session;
use plotter_host::link::sim::SimTransport;
use plotter_path::MachineProfile;
use plotter_path::geometry::steps::{StepDrawing, drawing_to_steps};
use plotter_path::input::svg::{ResourcePolicy, SvgOptions, import_svg};
use plotter_path::motion::plan::{self, Lookahead, machine_config};

struct Quiet;
impl PlotEvents for Quiet {
    fn progress(&mut self, _: &JobProgress) {}
}

/// The simulator, cut off (host and firmware both stop) at the first call at or after virtual time `at`; at that instant the journal file is
/// copied to `saved`: what survives the power loss.
struct Cut {
    inner: SimTransport,
    at: Duration,
    journal: PathBuf,
    saved: PathBuf,
    cut: bool,
}

impl Cut {
    fn check(&mut self) -> std::io::Result<()> {
        if !self.cut && self.inner.now() >= self.at {
            self.cut = true;
            std::fs::copy(&self.journal, &self.saved)?;
        }
        if self.cut { Err(std::io::Error::other("power lost")) } else { Ok(()) }
    }
}

impl Transport for Cut {
    fn send(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        self.check()?;
        self.inner.send(bytes)
    }
    fn recv_line(&mut self, timeout: Duration) -> std::io::Result<Option<String>> {
        self.check()?;
        // The cut falls at the host's first call at or after `at`: host and firmware stop at that same instant, the
        // host having handled every line that arrived before it.
        self.inner.recv_line(timeout)
    }
    fn now(&self) -> Duration {
        self.inner.now()
    }
}

fn drawing() -> (MachineProfile, StepDrawing) {
    let mut profile = MachineProfile::default_plotter();
    // The restarted firmware knows nothing of Z, whose switch lies below the paper: the resume homes Z at this spot
    // off the drawing (pen lifted, X and Y homed first) instead of refusing.
    profile.homing.z_home_xy_mm = Some([400.0, 280.0]);
    let imported =
        import_svg(SAMPLE_SVG.as_bytes(), "sample.svg", &ResourcePolicy::DataUrlsOnly, &SvgOptions::default()).unwrap();
    let steps = drawing_to_steps(&profile, &imported.drawing).unwrap();
    (profile, steps)
}

fn sim_at(profile: &MachineProfile, start: [i64; NUM_AXES]) -> SimTransport {
    let cfg = machine_config(profile).unwrap();
    let mut opts = SimOptions::for_config(&cfg);
    opts.baud = Some(profile.link.baud);
    opts.start = start;
    SimTransport::from_sim(Sim::with_options(cfg, opts), Some(profile.link.baud))
}

/// An XY step taken with the pen down: where it started, which axis, which way.
type DrawStep = ([i64; 2], Axis, bool);

/// The pen-down XY steps of a trace that starts at physical position `start`, with how often each occurs. The pen
/// is down below `z_down` (physical Z steps).
fn draw_steps(start: [i64; NUM_AXES], trace: &[StepEvent], z_down: i64, into: &mut HashMap<DrawStep, i64>) -> i64 {
    let mut p = start;
    let mut n = 0;
    for e in trace {
        let i = e.axis.index();
        if e.axis != Axis::Z && e.axis != Axis::E && p[2] < z_down {
            *into.entry(([p[0], p[1]], e.axis, e.forward)).or_default() += 1;
            n += 1;
        }
        p[i] += if e.forward { 1 } else { -1 };
    }
    n
}

#[test]
fn power_loss_resume_redraws_at_most_the_running_block() {
    let (profile, steps) = drawing();
    let dir = scratch("power-loss");
    // Half-way between pen up (4 mm) and down (0 mm): 800 steps, far inside i64.
    #[allow(clippy::cast_possible_truncation)]
    let z_down = ((profile.pen.up_z_mm + profile.pen.down_z_mm) / 2.0 * profile.axes.z.steps_per_mm).round() as i64;

    // The clean run: every pen-down step once (or as often as the drawing itself retraces it).
    let mut s = Session::connect(sim_at(&profile, [0; NUM_AXES]), "sim").unwrap();
    let start = Cell::new([0; 4]);
    let source = |p: [i32; 4]| {
        start.set(p);
        Ok("power-loss test".to_string())
    };
    let jp = dir.join("clean.journal");
    let clean_out =
        job::plot(&mut s, &profile, &steps, true, false, Some(JournalSpec { path: &jp, source: &source }), &mut Quiet)
            .unwrap();
    let clean_trace = s.transport.sim().hal().steps().to_vec();
    let mut clean = HashMap::new();
    let clean_total = draw_steps([0; NUM_AXES], &clean_trace, z_down, &mut clean);
    let full = plan::plan_returning(&profile, &steps, start.get(), Lookahead::Whole, false).unwrap();
    let events = |b: &plan::PlannedBlock| b.block.steps.iter().map(|s| i64::from(s.unsigned_abs())).sum::<i64>();
    let plan_events: i64 = full.blocks.iter().map(events).sum();
    let homing_events = i64::try_from(clean_trace.len()).unwrap() - plan_events;
    let stream_start = clean_out.stats.elapsed;
    let t_end = s.transport.now();
    let t_begin = t_end - stream_start;

    let cuts = 50u32;
    let (mut worst, mut worst_block, mut worst_ratio) = (0i64, 0i64, 0.0f64);
    let mut total_redrawn = 0i64;
    for c in 0..cuts {
        let at = t_begin + stream_start * (2 * c + 1) / (2 * cuts);
        let jp = dir.join(format!("cut{c}.journal"));
        let saved = dir.join(format!("cut{c}.saved"));
        let mut s = Session::connect(
            Cut { inner: sim_at(&profile, [0; NUM_AXES]), at, journal: jp.clone(), saved: saved.clone(), cut: false },
            "sim",
        )
        .unwrap();
        let r = job::plot(
            &mut s,
            &profile,
            &steps,
            true,
            false,
            Some(JournalSpec { path: &jp, source: &source }),
            &mut Quiet,
        );
        assert!(r.is_err(), "cut {c}: the plot finished before the cut");
        assert!(s.transport.cut, "cut {c}");
        let trace1 = s.transport.inner.sim().hal().steps().to_vec();
        let stopped_at = s.transport.inner.sim().physical_position();
        // The block running at the cut: where the steps done so far fall in the plan. A cut right at a block's
        // last step counts as within that block (its completion cannot have been reported yet).
        let done = i64::try_from(trace1.len()).unwrap() - homing_events;
        let (mut acc, mut running) = (0i64, full.blocks.len());
        for (i, b) in full.blocks.iter().enumerate() {
            acc += events(b);
            if acc >= done && events(b) > 0 {
                running = i;
                break;
            }
        }
        let running_xy = full
            .blocks
            .get(running)
            .map_or(0, |b| i64::from(b.block.steps[0].unsigned_abs() + b.block.steps[1].unsigned_abs()));

        // Restart both; resume from what the journal held at the cut.
        let state = journal::load(&saved).unwrap();
        let mut s = Session::connect(sim_at(&profile, stopped_at), "sim").unwrap();
        job::resume(&mut s, &profile, &steps, start.get(), &state, &saved, false, false, &mut Quiet).unwrap();
        let trace2 = s.transport.sim().hal().steps().to_vec();

        let mut first = HashMap::new();
        draw_steps([0; NUM_AXES], &trace1, z_down, &mut first);
        let mut second = HashMap::new();
        draw_steps(stopped_at, &trace2, z_down, &mut second);
        let mut redrawn = 0;
        for (k, &n2) in &second {
            let n1 = first.get(k).copied().unwrap_or(0);
            let n0 = clean.get(k).copied().unwrap_or(0);
            redrawn += (n1 + n2 - n0).max(0).min(n2);
        }
        for (k, &n0) in &clean {
            let got = first.get(k).copied().unwrap_or(0) + second.get(k).copied().unwrap_or(0);
            assert!(got >= n0, "cut {c}: the resumed plot misses the pen-down step {k:?}");
        }
        assert!(
            redrawn <= running_xy,
            "cut {c} at {:.3} s: {redrawn} pen-down steps redrawn, more than the running block {running} ({running_xy} \
             XY steps); journal executed {} of {}",
            (at - t_begin).as_secs_f64(),
            state.executed,
            full.blocks.len()
        );
        total_redrawn += redrawn;
        if redrawn > worst {
            (worst, worst_block) = (redrawn, running_xy);
        }
        if running_xy > 0 {
            worst_ratio = worst_ratio.max(redrawn as f64 / running_xy as f64);
        }
    }
    println!(
        "{cuts} power cuts through the sample drawing ({clean_total} pen-down steps, {} blocks): max {worst} pen-down steps \
         redrawn (running block {worst_block} steps), max redrawn/running block {:.2}, total {total_redrawn}",
        full.blocks.len(),
        worst_ratio
    );
    let _ = std::fs::remove_dir_all(&dir);
}
