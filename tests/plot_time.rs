//! Host-planned time against the simulator's executed time, and the executed geometry against the plan, with the
//! frames fed straight into the simulated firmware (plotter-path's plan, plotter-fw's protocol and simulator).

use plotter_e2e::{SAMPLE_SVG, ink_off_drawing, machine_paths, sim_positions};
use plotter_fw::sim::Sim;
use plotter_path::geometry::steps::drawing_to_steps;
use plotter_path::motion::plan::{self, Lookahead, MotionPlan};
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
    plotter_e2e::play_framed(&mut sim, &plan);
    let executed = sim.hal().busy_ticks() - busy0;
    (plan, sim, executed)
}

#[test]
fn host_time_equals_executed_time() {
    for profile_text in [include_str!("../samples/xy-plotter.toml"), include_str!("../samples/printer.toml")] {
        let profile = MachineProfile::from_toml(profile_text, "sample").unwrap();
        let opts = svg::SvgOptions::default();
        let drawing = svg::import_svg(SAMPLE_SVG.as_bytes(), "sample.svg", &svg::ResourcePolicy::DataUrlsOnly, &opts)
            .unwrap()
            .drawing;
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
            if profile.heaters.is_none() {
                assert!(inks_off(&profile, &drawing, &sim).is_empty(), "{}", profile.name);
            }
        }
    }
}

/// The positions the simulator stepped with the pen below `judge`'s clearance off `drawing` (see
/// [`ink_off_drawing`]).
fn inks_off(judge: &MachineProfile, drawing: &plotter_path::Drawing, sim: &Sim) -> Vec<[i64; 2]> {
    let clear = (judge.pen.down_z_mm + judge.pen.clearance_mm) * judge.axes.z.steps_per_mm;
    let below = |z: i64| f64::from(i32::try_from(z).expect("Z steps fit i32")) < clear;
    let samples = sim_positions(sim).into_iter().map(|(_, p)| (below(p[2]), [p[0], p[1]]));
    ink_off_drawing(samples, &machine_paths(judge, drawing), judge.axes.x.steps_per_mm, svg::DEFAULT_TOLERANCE_MM)
}

/// The ink check can fail: a plan made for a pen that clears the paper at 0.5 mm travels between 0.5 and 1 mm
/// right after each rise and right before each drop, which on the kit (clearance 1 mm) is below the clearance
/// while XY moves off the strokes. The same plan with the kit's own clearance passes.
#[test]
fn the_ink_check_catches_travel_below_the_clearance() {
    let kit = MachineProfile::default_plotter();
    let mut low = kit.clone();
    low.pen.clearance_mm = 0.5;
    let drawing = svg::import_svg(
        SAMPLE_SVG.as_bytes(),
        "sample.svg",
        &svg::ResourcePolicy::DataUrlsOnly,
        &svg::SvgOptions::default(),
    )
    .unwrap()
    .drawing;
    let steps = drawing_to_steps(&kit, &drawing).unwrap();
    let (_, sim, _) = run_on_sim(&kit, |start| plan::plan(&low, &steps, start, Lookahead::Whole).unwrap());
    let off = inks_off(&kit, &drawing, &sim);
    // Every hop but the first (from the pen-up height) starts and ends below 1 mm: 5 strokes, 4 such hops, each
    // with XY steps off the drawing at both ends.
    assert!(off.len() >= 8, "{} positions off the drawing", off.len());
    assert!(inks_off(&low, &drawing, &sim).is_empty(), "judged with the clearance it was planned for");
    let (_, sim, _) = run_on_sim(&kit, |start| plan::plan(&kit, &steps, start, Lookahead::Whole).unwrap());
    assert!(inks_off(&kit, &drawing, &sim).is_empty());
}

/// Planned time of `drawing` on `profile` from home (no path optimization: the drawing's own order).
fn planned_seconds(profile: &MachineProfile, drawing: &plotter_path::Drawing) -> f64 {
    let steps = drawing_to_steps(profile, drawing).unwrap();
    plan::plan(profile, &steps, plan::homed_position(profile).unwrap(), Lookahead::Whole).unwrap().seconds()
}

/// The plan follows the curves, not the chords they were cut into: flattening at 0.05 mm or at 0.002 mm (25× finer,
/// 5× more vertices) plans within 1 %, on the samples and on small parametric figures (radii of a few mm, where
/// the curve speed √(a·r) is below the draw feed). With every vertex planned as a corner (junction deviation
/// alone, `curve_deviation_mm = 0`) the figures differ by far more — which is what this test guards against.
#[test]
fn plan_time_is_independent_of_flattening_tolerance() {
    let profile = MachineProfile::default_plotter();
    let mut corners_only = profile.clone();
    corners_only.motion.curve_deviation_mm = 0.0;
    let svg_at = |text: &str, name: &str, tol: f64| {
        let opts = svg::SvgOptions { tolerance_mm: tol, ..svg::SvgOptions::default() };
        svg::import_svg(text.as_bytes(), name, &svg::ResourcePolicy::DataUrlsOnly, &opts).unwrap().drawing
    };
    let samples = [
        ("sample.svg", SAMPLE_SVG.to_string()),
        ("duck.svg", std::fs::read_to_string(plotter_e2e::sample("duck.svg")).unwrap()),
        ("transforms.svg", std::fs::read_to_string(plotter_e2e::sample("transforms.svg")).unwrap()),
        ("layers.svg", std::fs::read_to_string(plotter_e2e::sample("layers.svg")).unwrap()),
    ];
    for (name, text) in &samples {
        let coarse = planned_seconds(&profile, &svg_at(text, name, 0.05));
        let fine = planned_seconds(&profile, &svg_at(text, name, 0.002));
        assert!((coarse / fine - 1.0).abs() < 0.01, "{name}: {coarse} s at 0.05 mm vs {fine} s at 0.002 mm");
    }
    let gen_at = |spec: &str, tol: f64| plotter_path::input::r#gen::from_spec(&format!("{spec}&tol={tol}")).unwrap();
    let mut corner_gap: f64 = 0.0;
    for spec in [
        "gen:epicycloid?q=3&r=1.5&cx=100&cy=100",
        "gen:spirograph?r=6&q=105/36&d=5&cx=100&cy=100",
        "gen:spirograph?r=3&q=105/36&d=2.5&cx=100&cy=100",
    ] {
        let (c, f) = (gen_at(spec, 0.05), gen_at(spec, 0.002));
        assert!(
            f.paths().map(|p| p.points.len()).sum::<usize>() > 4 * c.paths().map(|p| p.points.len()).sum::<usize>()
        );
        let (coarse, fine) = (planned_seconds(&profile, &c), planned_seconds(&profile, &f));
        assert!((coarse / fine - 1.0).abs() < 0.01, "{spec}: {coarse} s at 0.05 mm vs {fine} s at 0.002 mm");
        let (jc, jf) = (planned_seconds(&corners_only, &c), planned_seconds(&corners_only, &f));
        corner_gap = corner_gap.max((jc / jf - 1.0).abs());
        eprintln!("{spec}: curves {coarse:.3}/{fine:.3} s, corners only {jc:.3}/{jf:.3} s");
    }
    assert!(corner_gap > 0.025, "junction deviation alone differs by only {corner_gap}");
}
