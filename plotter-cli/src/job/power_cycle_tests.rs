//! A power cycle mid-plot on the XY kit (its Z switch 2 mm below the pen's touch), then `plotter resume`: the
//! firmware starts again knowing nothing of Z, and the resume must not home Z where the carriage stands, over the
//! drawing (see `crate::link::home_axes`). Checked on the simulator's step trace.

use std::collections::HashSet;
use std::io;
use std::time::Duration;

use plotter_fw::sim::{Sim, SimOptions};
use plotter_fw::{Axis, NUM_AXES};
use plotter_path::geometry::steps::{StepDrawing, drawing_to_steps};
use plotter_path::kurbo::Point;
use plotter_path::{Drawing, MachineProfile, Polyline};

use super::progress::{JobProgress, PlotEvents};
use super::{JournalSpec, plan, plot, resume};
use crate::link::Transport;
use crate::link::session::Session;
use crate::link::sim::SimTransport;

struct Quiet;
impl PlotEvents for Quiet {
    fn progress(&mut self, _: &JobProgress) {}
}

/// The simulator, its power cut (every later call fails) at the first host call where `when` holds for the
/// carriage's physical position.
struct Cut {
    inner: SimTransport,
    when: fn([i64; NUM_AXES]) -> bool,
    cut: bool,
}

impl Cut {
    fn check(&mut self) -> io::Result<()> {
        self.cut = self.cut || (self.when)(self.inner.sim().physical_position());
        if self.cut { Err(io::Error::other("power lost")) } else { Ok(()) }
    }
}

impl Transport for Cut {
    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.check()?;
        self.inner.send(bytes)
    }
    fn recv_line(&mut self, timeout: Duration) -> io::Result<Option<String>> {
        self.check()?;
        self.inner.recv_line(timeout)
    }
    fn now(&self) -> Duration {
        self.inner.now()
    }
}

/// Two 100 mm strokes: (20, 40) → (120, 40) mm, then a pen-up travel to (220, 140) → (320, 140) mm.
fn two_strokes(profile: &MachineProfile) -> StepDrawing {
    let line = |a: (f64, f64), b: (f64, f64)| Polyline::new(vec![Point::new(a.0, a.1), Point::new(b.0, b.1)]);
    let d = Drawing::single_layer("l", vec![line((20.0, 40.0), (120.0, 40.0)), line((220.0, 140.0), (320.0, 140.0))]);
    drawing_to_steps(profile, &d).unwrap()
}

fn sim_at(profile: &MachineProfile, start: [i64; NUM_AXES]) -> SimTransport {
    let cfg = plan::machine_config(profile).unwrap();
    let mut o = SimOptions::for_config(&cfg);
    o.start = start;
    SimTransport::from_sim(Sim::with_options(cfg, o), None)
}

/// Where the pen touches the paper (Z at or below its touch, physical Z 0) and where it presses past its touch
/// (Z below 0: the Z switch's seek), X and Y in steps, over `trace` from physical position `start`.
fn touches(start: [i64; NUM_AXES], trace: &[plotter_fw::sim::StepEvent]) -> (HashSet<[i64; 2]>, HashSet<[i64; 2]>) {
    let (mut p, mut touch, mut press) = (start, HashSet::new(), HashSet::new());
    for e in trace {
        p[e.axis.index()] += if e.forward { 1 } else { -1 };
        if p[Axis::Z.index()] <= 0 {
            touch.insert([p[0], p[1]]);
        }
        if p[Axis::Z.index()] < 0 {
            press.insert([p[0], p[1]]);
        }
    }
    (touch, press)
}

/// The kit (80 steps/mm, switches one pull-off beyond the travel: physical steps are machine steps once homed)
/// with its Z homing spot at (400, 280) mm, off the drawing: the pen there touches only the bed.
const SPOT: [i64; 2] = [400 * 80, 280 * 80];

/// Plot the two strokes and cut the power where `when` says; then restart the simulator where the carriage
/// stopped (a fresh firmware: nothing homed) and resume from the journal. Returns where the power was cut, the
/// clean plot's pen-down positions, and the resumed trace's touches and presses (or the resume's error).
#[allow(clippy::type_complexity)]
fn cut_and_resume(
    profile: &MachineProfile,
    when: fn([i64; NUM_AXES]) -> bool,
    name: &str,
) -> ([i64; NUM_AXES], HashSet<[i64; 2]>, Result<(HashSet<[i64; 2]>, HashSet<[i64; 2]>), String>) {
    let steps = two_strokes(profile);
    let dir = std::env::temp_dir().join(format!("plotter-power-cycle-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let source = |start: [i32; 4]| Ok(format!("{start:?}"));
    // The clean plot: where its pen touches (its homing at the start included, at the home corner).
    let mut s = Session::connect(sim_at(profile, [0; NUM_AXES]), "sim").unwrap();
    plot(&mut s, profile, &steps, true, false, None, &mut Quiet).unwrap();
    let (drawn, _) = touches([0; NUM_AXES], s.transport.sim().hal().steps());
    // The plot, its power cut.
    let jp = dir.join("cut.journal");
    let t = Cut { inner: sim_at(profile, [0; NUM_AXES]), when, cut: false };
    let mut s = Session::connect(t, "sim").unwrap();
    let spec = JournalSpec { path: &jp, source: &source };
    assert!(plot(&mut s, profile, &steps, true, false, Some(spec), &mut Quiet).is_err());
    let stopped_at = s.transport.inner.sim().physical_position();
    // Power back: a fresh firmware, the carriage where it stopped.
    let state = crate::link::journal::load(&jp).unwrap();
    let mut s = Session::connect(sim_at(profile, stopped_at), "sim").unwrap();
    let start = plan::homed_position(profile).unwrap();
    let resumed = match resume(&mut s, profile, &steps, start, &state, &jp, false, false, &mut Quiet) {
        Ok(_) => Ok(touches(stopped_at, s.transport.sim().hal().steps())),
        Err(e) => {
            assert!(s.transport.sim().hal().steps().is_empty(), "a refused resume moves nothing");
            Err(format!("{e:#}"))
        }
    };
    std::fs::remove_dir_all(&dir).ok();
    (stopped_at, drawn, resumed)
}

/// Cut while the pen travels up between the strokes (X past 150 mm), and cut mid-stroke with the pen on the
/// paper (X past 60 mm on the first stroke, Z at its touch): after the power cycle the resume touches the paper
/// only where the clean plot drew, and presses past the touch only at the homing spot. It used to home Z where
/// the carriage stood: a seek 2 mm past the touch there, a dot in the travel's middle. Without a spot in the
/// profile the resume is refused, moving nothing, naming `plotter home --z`.
#[test]
fn a_resume_after_a_power_cycle_never_lowers_the_pen_onto_the_drawing() {
    let mut profile = MachineProfile::default_plotter();
    assert!(!profile.homing.pen_clear_at_z_switch);
    profile.homing.z_home_xy_mm = Some([400.0, 280.0]);
    // (Off the homing trip to the spot and back, along y = 0.7 x: the travel between the strokes runs along y = x − 80.)
    let travelling: fn([i64; NUM_AXES]) -> bool = |p| p[2] >= 1500 && p[0] >= 150 * 80 && p[1] < 90 * 80;
    let drawing: fn([i64; NUM_AXES]) -> bool = |p| p[2] <= 0 && p[0] >= 60 * 80 && p[1] < 100 * 80;
    for (when, name) in [(travelling, "travel"), (drawing, "stroke")] {
        let (stopped_at, drawn, resumed) = cut_and_resume(&profile, when, name);
        let (touch, press) = resumed.unwrap();
        let astray: Vec<_> = touch.iter().filter(|p| !drawn.contains(*p) && **p != SPOT).collect();
        assert!(astray.is_empty(), "{name}: cut at {stopped_at:?}, the pen touched at {astray:?}");
        assert_eq!(press, HashSet::from([SPOT]), "{name}: cut at {stopped_at:?}, pressed past the touch");
        assert!(touch.len() > 1000, "{name}: the rest was drawn ({} positions)", touch.len());
    }
    profile.homing.z_home_xy_mm = None;
    let (_, _, resumed) = cut_and_resume(&profile, travelling, "no-spot");
    let e = resumed.unwrap_err();
    assert!(e.contains("the pen's height is unknown") && e.contains("`plotter home --z`"), "{e}");
}

/// A new plot (not a resume) on a kit just switched on, its carriage left over the sheet at (100, 80) mm with the
/// pen resting on it: with a homing spot in the profile, Z is homed there — the pen presses past its touch only at
/// the spot and touches the paper only where the plot draws. Without a spot the plain cycle seeks Z where the
/// carriage stands (the firmware cannot tell a switch-on from a power cycle), pressing there.
#[test]
fn a_new_plot_on_a_machine_just_switched_on_homes_z_at_the_spot() {
    let mut profile = MachineProfile::default_plotter();
    profile.homing.z_home_xy_mm = Some([400.0, 280.0]);
    let steps = two_strokes(&profile);
    let mut s = Session::connect(sim_at(&profile, [0; NUM_AXES]), "sim").unwrap();
    plot(&mut s, &profile, &steps, true, false, None, &mut Quiet).unwrap();
    let (drawn, _) = touches([0; NUM_AXES], s.transport.sim().hal().steps());
    let over_the_sheet = [100 * 80, 80 * 80, 0, 0];
    let run = |profile: &MachineProfile| {
        let mut s = Session::connect(sim_at(profile, over_the_sheet), "sim").unwrap();
        plot(&mut s, profile, &steps, true, false, None, &mut Quiet).unwrap();
        touches(over_the_sheet, s.transport.sim().hal().steps())
    };
    let (touch, press) = run(&profile);
    let astray: Vec<_> = touch.iter().filter(|p| !drawn.contains(*p) && **p != SPOT).collect();
    assert!(astray.is_empty(), "the pen touched at {astray:?}");
    assert_eq!(press, HashSet::from([SPOT]));
    assert!(touch.len() > 1000, "the strokes were drawn ({} positions)", touch.len());
    profile.homing.z_home_xy_mm = None;
    let (_, press) = run(&profile);
    assert_eq!(press, HashSet::from([[100 * 80, 80 * 80]]));
}
