//! Slicer G-code on the simulated printer: a 20 mm cube, written as STL by this project ([`cube_stl`]) and sliced
//! by Debian's `prusa-slicer` (CLI) into `tests/fixtures/cube-20mm.gcode`, plays to the end on the firmware
//! simulator with its heaters: the extruded filament equals the file's total, the final position is exact, and
//! the stepper's time equals our plan's estimate to the tick. Our estimate is printed next to PrusaSlicer's.
//!
//! The G-code is committed (prusa-slicer and its libraries are too heavy to install in CI); regenerate it with
//! `cargo test -p plotter-e2e --test e2e print_slicer::regenerate -- --ignored` on a machine with
//! `apt-get install prusa-slicer`.

use std::process::Command;

use plotter_e2e::{cube_stl, fixture, sample};
use plotter_fw::sim::{Sim, SimOptions};
use plotter_fw::{Axis, MachineConfig};
use plotter_path::MachineProfile;
use plotter_path::config::profile::thermal_config;
use plotter_path::input::gcode_print::import_print;
use plotter_path::motion::plan::{homed_position, machine_config};
use plotter_path::motion::print_plan::{PrintItem, plan_print, wire_items};

const GCODE: &str = "cube-20mm.gcode";

/// The exact slicing command (the bed and placement of samples/printer.toml; Marlin 2 flavour; machine limits,
/// remaining-time M73 and a linear-advance M900 emitted so the file carries the Marlin extras a print must
/// tolerate).
fn slice_command(stl: &std::path::Path, out: &std::path::Path) -> Command {
    let mut c = Command::new("prusa-slicer");
    c.args([
        "--export-gcode",
        "--gcode-flavor",
        "marlin2",
        "--bed-shape",
        "0x0,235x0,235x235,0x235",
        "--center",
        "117.5,117.5",
        "--temperature",
        "210",
        "--first-layer-temperature",
        "210",
        "--bed-temperature",
        "60",
        "--first-layer-bed-temperature",
        "60",
        "--layer-height",
        "0.2",
        "--fill-density",
        "15%",
        "--machine-limits-usage",
        "emit_to_gcode",
        "--remaining-times",
        "--start-gcode",
        "M900 K0 ; linear advance off\nG28 ; home all axes\nG1 Z5 F5000 ; lift nozzle",
        "--output",
    ]);
    c.arg(out).arg(stl);
    c
}

#[test]
#[ignore = "needs Debian's prusa-slicer; rewrites tests/fixtures/cube-20mm.{stl,gcode}"]
fn regenerate_cube_fixture() {
    let stl = fixture("cube-20mm.stl");
    std::fs::create_dir_all(stl.parent().unwrap()).unwrap();
    std::fs::write(&stl, cube_stl(20.0)).unwrap();
    let status = slice_command(&stl, &fixture(GCODE)).status().expect("prusa-slicer runs");
    assert!(status.success());
}

#[test]
fn cube_stl_is_a_closed_20mm_cube() {
    let text = cube_stl(20.0);
    let v: Vec<[f64; 3]> = text
        .lines()
        .filter_map(|l| l.trim().strip_prefix("vertex "))
        .map(|l| {
            let c: Vec<f64> = l.split_whitespace().map(|x| x.parse().unwrap()).collect();
            [c[0], c[1], c[2]]
        })
        .collect();
    let normals: Vec<[f64; 3]> = text
        .lines()
        .filter_map(|l| l.trim().strip_prefix("facet normal "))
        .map(|l| {
            let c: Vec<f64> = l.split_whitespace().map(|x| x.parse().unwrap()).collect();
            [c[0], c[1], c[2]]
        })
        .collect();
    assert_eq!((v.len(), normals.len()), (36, 12));
    let (mut area, mut volume) = (0.0, 0.0);
    for (t, n) in v.chunks(3).zip(&normals) {
        let e1 = [t[1][0] - t[0][0], t[1][1] - t[0][1], t[1][2] - t[0][2]];
        let e2 = [t[2][0] - t[0][0], t[2][1] - t[0][1], t[2][2] - t[0][2]];
        let c = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
        let len = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
        // The winding agrees with the stated outward normal.
        assert!((0..3).all(|k| (c[k] / len - n[k]).abs() < 1e-12), "{t:?} {n:?}");
        area += len / 2.0;
        // Divergence theorem: V = Σ (p0 · (p1 × p2)) / 6.
        let p = t;
        volume += (p[0][0] * (p[1][1] * p[2][2] - p[1][2] * p[2][1])
            - p[0][1] * (p[1][0] * p[2][2] - p[1][2] * p[2][0])
            + p[0][2] * (p[1][0] * p[2][1] - p[1][1] * p[2][0]))
            / 6.0;
    }
    assert!((area - 6.0 * 400.0).abs() < 1e-9 && (volume - 8000.0).abs() < 1e-9, "{area} {volume}");
}

/// A number after `key` in a comment line of the file (PrusaSlicer writes `; key = value`).
fn comment_value(text: &str, key: &str) -> String {
    text.lines().find_map(|l| l.strip_prefix(key)).map(|v| v.trim().to_string()).expect(key)
}

fn printer() -> (MachineProfile, MachineConfig) {
    let p = MachineProfile::load(&sample("printer.toml")).unwrap();
    let c = machine_config(&p).unwrap();
    (p, c)
}

fn printer_sim(profile: &MachineProfile, cfg: MachineConfig, start: [i64; 4]) -> Sim {
    let opts = SimOptions {
        thermal: thermal_config(profile).unwrap(),
        record_steps: false,
        start,
        ..SimOptions::for_config(&cfg)
    };
    Sim::with_options(cfg, opts)
}

/// Stepper time of homing `line` from the physical position `start` on a fresh printer.
fn homing_ticks(profile: &MachineProfile, cfg: MachineConfig, start: [i64; 4], line: &str) -> u64 {
    let mut sim = printer_sim(profile, cfg, start);
    sim.feed(format!("{line}\n").as_bytes());
    sim.run_until_idle();
    assert!(sim.take_replies().iter().any(|l| l == "ok"));
    sim.hal().busy_ticks()
}

#[test]
fn prusaslicer_cube_plays_to_the_end() {
    let path = fixture(GCODE);
    let text = std::fs::read_to_string(&path).unwrap();
    let (profile, cfg) = printer();
    let program = import_print(&text, "cube-20mm.gcode", &profile).unwrap();
    // The Marlin extras are accepted with warnings, never failures.
    let warned: Vec<String> = program.warnings.iter().map(|w| w.message.clone()).collect();
    for m in ["M73", "M201", "M203", "M204", "M205", "M900"] {
        assert!(warned.iter().any(|w| w.starts_with(m)), "{m} not in {warned:?}");
    }
    let plan = plan_print(&profile, &program).unwrap();
    assert_eq!(plan.layers, text.lines().filter(|l| *l == ";LAYER_CHANGE").count());

    // Stream everything over a flow-controlled line (the wire holds it, the firmware takes what fits).
    let mut sim = printer_sim(&profile, cfg, [0; 4]);
    let wire = wire_items(&plan, 0).unwrap();
    for w in &wire {
        sim.feed(w);
    }
    sim.run_until_idle();
    let replies = sim.take_replies();
    let oks = replies.iter().filter(|l| *l == "ok").count();
    let bad: Vec<&String> = replies.iter().filter(|l| l.starts_with("error") || l.starts_with("ALARM")).collect();
    assert!(bad.is_empty(), "{bad:?}");
    assert_eq!(oks, wire.len(), "every item answered");
    assert!(sim.machine().stepper().is_idle() && sim.wire_len() == 0);

    // Extrusion: the filament pushed out equals PrusaSlicer's "filament used" within 0.1 %.
    let slicer_mm: f64 = comment_value(&text, "; filament used [mm] =").parse().unwrap();
    let spm_e = f64::from(cfg.axis(Axis::E).steps_per_mm);
    let extruded = sim.hal().max_position()[3] as f64 / spm_e;
    assert!((extruded - slicer_mm).abs() <= 0.001 * slicer_mm, "{extruded} vs {slicer_mm}");
    // ...and the net E position is exactly the planned one (drift-free steps).
    assert_eq!(sim.physical_position()[3], plan.e_steps);

    // Final position: the last X/Y/Z words of the file (absolute mode throughout), with X homed by `G28 X0`.
    assert!(!text.lines().any(|l| l.starts_with("G91")));
    let mut last = [f64::NAN; 3];
    for l in text.lines().filter(|l| l.starts_with("G1 ") || l.starts_with("G0 ")) {
        for w in l.split(';').next().unwrap().split_whitespace() {
            let (k, v) = w.split_at(1);
            if let Some(i) = "XYZ".find(k) {
                last[i] = v.parse().unwrap();
            }
        }
    }
    // Positions on a 235 mm bed: far inside i64.
    #[allow(clippy::cast_possible_truncation)]
    let steps = |mm: f64, spm: f64| (mm * spm).round() as i64;
    let x_homed = text.lines().any(|l| l.starts_with("G28 X0"));
    let phys = sim.physical_position();
    let expect_x = if x_homed { 0 } else { steps(last[0], 80.0) };
    assert_eq!(phys[0], expect_x);
    assert_eq!(phys[1], steps(last[1], 80.0));
    assert_eq!(phys[2], steps(last[2], 400.0));

    // Time: the stepper ran exactly the planned motion plus the two homing cycles (measured on their own from the
    // same physical positions).
    let homed = homed_position(&profile).unwrap();
    let mut pos = [0i64; 4];
    let mut before_end_home = None;
    for item in &plan.items {
        match item {
            PrintItem::Line { text, .. } if text == "G28" => {
                pos[..3].copy_from_slice(&[i64::from(homed[0]), i64::from(homed[1]), i64::from(homed[2])]);
            }
            PrintItem::Line { text, .. } if text.starts_with("G28 ") => before_end_home = Some((pos, text.clone())),
            PrintItem::Block { block, .. } => (0..4).for_each(|k| pos[k] += i64::from(block.steps[k])),
            PrintItem::Line { .. } => {}
        }
    }
    let first = homing_ticks(&profile, cfg, [0; 4], "G28");
    let (at, line) = before_end_home.expect("G28 X0 at the end");
    let end = homing_ticks(&profile, cfg, [at[0], at[1], at[2], 0], &line);
    let busy = sim.hal().busy_ticks();
    assert_eq!(busy - first - end, plan.total_ticks, "executed vs planned, ticks");

    let theirs = comment_value(&text, "; estimated printing time (normal mode) =");
    eprintln!(
        "cube-20mm: {} layers, {} blocks; our estimate {:.1} s (motion, exact), PrusaSlicer's {theirs}; executed \
         {:.1} s of stepper time + {:.1} s of homing; extruded {extruded:.3} mm vs PrusaSlicer's {slicer_mm} mm; \
         virtual time with heating {:.1} s",
        plan.layers,
        plan.block_count(),
        plan.seconds(),
        (busy - first - end) as f64 / 1e6,
        (first + end) as f64 / 1e6,
        sim.now() as f64 / 1e6
    );
}

// ---- `plotter print` ends with the reason, never printing cold (issue 22, findings 9 and 10) ----

/// Notes the print streamer writes.
#[derive(Default)]
struct Notes(Vec<String>);

impl plotter_host::link::print::PrintControl for Notes {
    fn progress(&mut self, _: &plotter_host::link::print::PrintProgress) {}
    fn note(&mut self, message: &str) {
        self.0.push(message.to_string());
    }
}

/// `gcode` printed by the library's print path on the simulated printer; `check` sees the simulator afterwards.
/// Returns the streamer's result (the error with its causes).
fn print_on_sim(gcode: &str, check: impl FnOnce(&Sim)) -> Result<plotter_host::link::print::PrintStats, String> {
    use plotter_host::link::print::{Played, PrinterSim, stream_print};
    use plotter_host::link::session::Session;
    let (profile, cfg) = printer();
    let program = import_print(gcode, "t.gcode", &profile).unwrap();
    let plan = plan_print(&profile, &program).unwrap();
    let transport = PrinterSim::new(cfg, thermal_config(&profile).unwrap(), Vec::new());
    let mut session = Session::connect(transport, "simulated printer").unwrap();
    let result = stream_print(&mut session, &plan, Played::Printer, &mut Notes::default());
    check(session.transport.sim());
    result.map_err(|e| format!("{e:#}"))
}

/// The start of a print without any heating: homing, the first layer's height, then extrusion (5 + 5 mm).
const COLD_PRINT: &str = "G28\nG1 Z0.3 F600\nG1 X10 Y10 F3000\nG1 X30 Y10 E5 F1200\nG1 X30 Y30 E10\n";

fn assert_stopped_cold(sim: &Sim) {
    use plotter_fw::heater::Heater;
    // Not a step of filament, heaters off (targets and duties), the machine idle.
    assert_eq!(sim.physical_position()[Axis::E.index()], 0);
    assert_eq!(sim.hal().step_counts()[Axis::E.index()], 0);
    let t = sim.machine().thermal();
    assert_eq!((t.target(Heater::HotEnd), t.target(Heater::Bed), t.fan()), (0.0, 0.0, 0));
    assert_eq!((sim.heaters().duty(Heater::HotEnd), sim.heaters().duty(Heater::Bed)), (0, 0));
    assert!(sim.machine().stepper().is_idle());
}

#[test]
fn cold_extrusion_stops_the_print_with_the_reason() {
    let e = print_on_sim(COLD_PRINT, assert_stopped_cold).unwrap_err();
    assert!(e.contains("refused by the printer: error 15: cold extrusion prevented: hot end 2"), "{e}");
    assert!(
        e.contains("below the minimum of 170.0 C") && e.ends_with("print stopped: motion stopped, heaters and fan off"),
        "{e}"
    );
}

#[test]
fn a_refused_heater_command_stops_the_print_instead_of_printing_cold() {
    // The file: targets above the hot end's maximum (260 °C), refused; the bed heats meanwhile.
    let gcode = format!("M140 S60\nM104 S300\nM109 S300\n{COLD_PRINT}");
    // The bed's target (60 °C, accepted) is switched off again.
    let e = print_on_sim(&gcode, assert_stopped_cold).unwrap_err();
    assert!(
        e.starts_with(
            "line 2 (M104 S300) refused by the printer: error 9: value out of range: target above the heater's maximum"
        ),
        "{e}"
    );
    assert!(e.ends_with("heaters and fan off"), "{e}");
}

#[test]
fn heated_print_extrudes_exactly() {
    // The same moves after M109 S210 print to the end: 10 mm of filament at 93 steps/mm.
    let stats = print_on_sim(&format!("M109 S210\n{COLD_PRINT}"), |sim| {
        assert_eq!(sim.physical_position()[Axis::E.index()], 930);
        assert!(sim.heaters().temperature(plotter_fw::heater::Heater::HotEnd) > 205.0);
    })
    .unwrap();
    assert_eq!(stats.refused, 0);
}

#[test]
fn plotter_print_exits_with_the_reason() {
    use plotter_e2e::{plotter, scratch};
    let dir = scratch("print-cold");
    let profile = sample("printer.toml");
    let profile = profile.to_str().unwrap();
    for (name, gcode, reason) in [
        ("cold.gcode", COLD_PRINT.to_string(), "error 15: cold extrusion prevented"),
        (
            "hot300.gcode",
            format!("M104 S300\nM109 S300\n{COLD_PRINT}"),
            "line 1 (M104 S300) refused by the printer: error 9",
        ),
        ("exponent.gcode", "G28\nG1 X1e40 F600\n".to_string(), "exponent.gcode:2: ambiguous number: X1 runs into e40"),
    ] {
        std::fs::write(dir.join(name), gcode).unwrap();
        let out = plotter(&dir, &["print", name, "--profile", profile]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{name}: {stderr}");
        assert!(stderr.contains(reason), "{name}: {stderr}");
    }
}
