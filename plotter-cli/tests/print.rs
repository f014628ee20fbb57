//! `plotter print`: slicer G-code on the simulated printer, thermal faults, and plotter profiles refused.

use std::path::PathBuf;
use std::process::{Command, Output};

fn plotter() -> Command {
    Command::new(env!("CARGO_BIN_EXE_plotter"))
}

fn root(rel: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..").join(rel)
}

fn print(extra: &[&str], profile: &str) -> Output {
    plotter()
        .arg("print")
        .arg(root("tests/fixtures/cube-20mm.gcode"))
        .arg("--profile")
        .arg(root(profile))
        .args(extra)
        .output()
        .expect("run plotter")
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

#[test]
fn prusaslicer_cube_prints_with_both_estimates() {
    let o = print(&[], "samples/printer.toml");
    let (out, err) = (text(&o.stdout), text(&o.stderr));
    assert!(o.status.success(), "{out}\n{err}");
    // 99 layers (the file's ;LAYER_CHANGE count), PrusaSlicer's own estimate from its comment next to ours.
    assert!(out.contains("99 layers") && out.contains("slicer's estimate: 17m 42s"), "{out}");
    // (16m 37s once the planner took curves at their centripetal limit rather than chord by chord; 16m 35s since
    // blocks run at their planned acceleration where it exceeds 250,000 steps/s², the retractions among them.)
    assert!(out.contains("print time (motion, exact): 16m 35s"), "{out}");
    // Filament pushed out = the file's "filament used [mm] = 1392.74" (to the 93 steps/mm resolution).
    assert!(out.contains("extruded 1392.742 mm") && out.contains("slicer: 1392.74 mm"), "{out}");
    // The Marlin extras are warnings with their line, never failures.
    for m in ["M73", "M201", "M203", "M204", "M205", "M900"] {
        assert!(err.lines().any(|l| l.starts_with("warning:") && l.contains(m)), "{m}: {err}");
    }
}

#[test]
fn a_broken_thermistor_stops_the_print_naming_the_sensor() {
    let o = print(&["--fault", "hotend-open@300"], "samples/printer.toml");
    let err = text(&o.stderr);
    // A machine alarm: exit status 3, as the README's list of statuses says (it was 1, "anything else").
    assert_eq!(o.status.code(), Some(3), "{err}");
    assert!(err.contains("printer alarm 5: MINTEMP") && err.contains("hot end sensor T0"), "{err}");
    let o = print(&["--fault", "bed-cartridge@100"], "samples/printer.toml");
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(3), "{err}");
    assert!(err.contains("bed sensor B") && err.contains("thermal runaway"), "{err}");
}

#[test]
fn plotter_profiles_cannot_print() {
    let o = print(&[], "samples/xy-plotter.toml");
    assert!(!o.status.success());
    assert!(text(&o.stderr).contains("not a printer profile"), "{}", text(&o.stderr));
    let o = print(&["--fault", "nozzle-open@1"], "samples/printer.toml");
    assert!(text(&o.stderr).contains("unknown heater"), "{}", text(&o.stderr));
}
