//! Profiles and plans that would mislead the user, end to end through the `plotter` binary (issue 37, classes 11,
//! 12 and 14): a profile whose numbers collapse or stall a drawing is refused where it is read, naming the file,
//! the key, the value and the accepted range; every sample profile still loads; the figures of a drawing without
//! travel show no NaN and no negative zero; and a plan's time with its dwell is printed before anything moves,
//! with a plan of hours of dwell refused without a terminal unless `--allow-long-dwell`.

use std::path::Path;
use std::process::{Command, Stdio};

use plotter_e2e::{plotter, plotter_bin, sample, scratch};

/// A one-line drawing (40 mm, no pen-up travel between paths).
const ONE_LINE: &str = r#"<svg xmlns="http://www.w3.org/2000/svg" width="100mm" height="100mm" viewBox="0 0 100 100">
  <path d="M10 10 L50 10" stroke="black" fill="none"/></svg>"#;

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// Run `plotter` in `dir` with stdout and stderr into one file, so the order of their lines shows; returns the
/// exit success and the interleaved output.
fn plotter_merged(dir: &Path, args: &[&str]) -> (bool, String) {
    let log = dir.join("merged.log");
    let file = std::fs::File::create(&log).unwrap();
    let status = Command::new(plotter_bin())
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(file.try_clone().unwrap())
        .stderr(file)
        .status()
        .unwrap();
    (status.success(), std::fs::read_to_string(&log).unwrap())
}

#[test]
fn a_collapsing_profile_is_refused_naming_key_value_and_range() {
    let dir = scratch("profile-limits");
    std::fs::write(dir.join("line.svg"), ONE_LINE).unwrap();
    let kit = std::fs::read_to_string(sample("xy-plotter.toml")).unwrap();
    for (from, to, expect) in [
        (
            "steps_per_mm = 80.0",
            "steps_per_mm = 1e-9",
            "tiny.toml: axes.x.steps_per_mm: 1e-9 is outside the accepted range 1..=100000 steps/mm",
        ),
        (
            "draw_feed_mm_s = 60.0",
            "draw_feed_mm_s = 1e-300",
            "tiny.toml: pen.draw_feed_mm_s: 1e-300 is outside the accepted range 0.1..=5000 mm/s",
        ),
    ] {
        std::fs::write(dir.join("tiny.toml"), kit.replacen(from, to, 1)).unwrap();
        for cmd in
            [&["plot", "line.svg", "--profile", "tiny.toml"][..], &["stats", "line.svg", "--profile", "tiny.toml"]]
        {
            let out = plotter(&dir, cmd);
            let err = text(&out.stderr);
            assert!(!out.status.success(), "{cmd:?} {to}: {err}");
            assert!(err.contains(expect), "{cmd:?}: {err}");
            // Short numbers only: no run of zeros from printing 1e-300 in full.
            assert!(!err.contains("0000000000"), "{err}");
            assert!(!text(&out.stdout).contains("plot time"), "nothing was plotted: {}", text(&out.stdout));
        }
    }
}

#[test]
fn every_sample_profile_still_loads_and_plots() {
    let dir = scratch("profile-samples");
    std::fs::write(dir.join("line.svg"), ONE_LINE).unwrap();
    let mut seen = 0;
    for entry in std::fs::read_dir(plotter_e2e::workspace_root().join("samples")).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|e| e != "toml") {
            continue;
        }
        seen += 1;
        let out = plotter(&dir, &["stats", "line.svg", "--profile", path.to_str().unwrap()]);
        assert!(out.status.success(), "{}: {}", path.display(), text(&out.stderr));
        assert!(text(&out.stdout).contains("plot time"), "{}: {}", path.display(), text(&out.stdout));
    }
    assert!(seen >= 8, "{seen} sample profiles");
}

#[test]
fn stats_of_a_drawing_without_travel_show_no_nan_and_no_negative_zero() {
    let dir = scratch("stats-no-travel");
    std::fs::write(dir.join("line.svg"), ONE_LINE).unwrap();
    // Travel only, nothing drawn: every time is zero, and so is every bound.
    std::fs::write(dir.join("travel.gcode"), "G0 X10 Y10\n").unwrap();
    for input in ["line.svg", "travel.gcode"] {
        for json in [false, true] {
            let args: Vec<&str> = if json { vec!["stats", input, "--json"] } else { vec!["stats", input] };
            let out = plotter(&dir, &args);
            assert!(out.status.success(), "{input}: {}", text(&out.stderr));
            let shown = text(&out.stdout);
            for bad in ["NaN", "nan", "inf", "-0.0", "-0:", "-0 "] {
                assert!(!shown.contains(bad), "{input} (json {json}) shows {bad}:\n{shown}");
            }
            if json {
                let v: serde_json::Value = serde_json::from_str(&shown).unwrap();
                assert_eq!(v["pen_up_mm"].as_f64().map(f64::is_sign_positive), Some(true), "{shown}");
            } else {
                assert!(shown.contains("pen up        0.00 mm"), "{shown}");
            }
        }
    }
    // The plot's lower-bound lines of the travel-only file: no percentage against a zero bound.
    let out = plotter(&dir, &["plot", "travel.gcode", "--verbose"]);
    let shown = text(&out.stdout);
    assert!(out.status.success() && shown.contains("lower bound 0.000 s"), "{shown}{}", text(&out.stderr));
    assert!(!shown.contains("NaN") && !shown.contains("-0.0"), "{shown}");
}

#[test]
fn the_plan_time_with_its_dwell_is_printed_before_anything_moves() {
    let dir = scratch("dwell-ahead");
    std::fs::write(dir.join("dwell.gcode"), "G0 Z4\nG0 X10 Y10\nG1 Z0 F1500\nG1 X20 F600\nG4 P2\nG0 Z4\n").unwrap();
    let (ok, log) = plotter_merged(&dir, &["plot", "dwell.gcode", "--as-written"]);
    assert!(ok, "{log}");
    let ahead = log.find("dwell.gcode as written (5 blocks): planned time 0:03.6, of which dwell 0:02.0");
    let first_sent = log.find("% sent");
    let done = log.find("5 blocks as written; planned time 3.568 s");
    assert!(ahead.is_some() && first_sent.is_some() && done.is_some(), "{log}");
    assert!(ahead < first_sent && first_sent < done, "announced after streaming began:\n{log}");

    // The ordinary plot announces its plan (with the pen settles as its dwell) before the plot's summary.
    std::fs::write(dir.join("line.svg"), ONE_LINE).unwrap();
    let (ok, log) = plotter_merged(&dir, &["plot", "line.svg", "--verbose"]);
    assert!(ok, "{log}");
    let ahead = log.find("line.svg (6 blocks): planned time 0:01.3, of which dwell 0:00.1");
    let summary = log.find("6 blocks, 40.0 mm pen-down");
    assert!(ahead.is_some() && summary.is_some() && ahead < summary, "{log}");
}

#[test]
fn hours_of_dwell_without_a_terminal_need_allow_long_dwell() {
    let dir = scratch("dwell-long");
    // 48 hours of G4, an hour at a time (the import's per-command limit).
    let g = format!("G0 Z4\nG0 X10 Y10\nG1 Z0 F1500\nG1 X20 F600\n{}G0 Z4\n", "G4 P3600\n".repeat(48));
    std::fs::write(dir.join("long.gcode"), g).unwrap();
    let started = std::time::Instant::now();
    let out = plotter(&dir, &["plot", "long.gcode", "--as-written"]);
    let err = text(&out.stderr);
    assert!(!out.status.success(), "{err}");
    assert!(err.contains("planned time 48:00:01.6, of which dwell 48:00:00.0"), "{err}");
    assert!(err.contains("warning: ***** this plan stands still for 48:00:00.0"), "{err}");
    assert!(err.contains("--allow-long-dwell"), "{err}");
    assert!(!err.contains("% sent") && out.stdout.is_empty(), "nothing may be streamed: {err}");
    assert!(started.elapsed() < std::time::Duration::from_secs(30), "{:?}", started.elapsed());
}
