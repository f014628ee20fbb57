//! A plot run by a script — stdin and stderr not terminals — on the built-in simulator: its progress comes as a
//! plain line every 5 % (ending at 100 %), and a drawing with pen changes plots through to the end with a warning
//! naming `--pen-change` instead of stopping (exit 5) at a question nobody can answer; `--pen-change prompt` still
//! asks (and stops when stdin has no answer), and `--pen-change pause` is refused before anything moves.

use std::process::{Command, Output, Stdio};

use plotter_e2e::{plotter_bin, sample, scratch};

/// `plotter plot` with `args` in a fresh folder, stdin empty, stdout and stderr piped.
fn plot(name: &str, args: &[&str]) -> Output {
    let dir = scratch(name);
    Command::new(plotter_bin())
        .arg("plot")
        .args(args)
        .current_dir(&dir)
        .env("PLOTTER_STATE_DIR", dir.join("state"))
        .stdin(Stdio::null())
        .output()
        .expect("plotter runs")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn a_log_gets_a_progress_line_every_five_per_cent() {
    let out = plot("piped-progress", &[sample("duck.svg").to_str().unwrap()]);
    let err = stderr(&out);
    assert!(out.status.success(), "{err}");
    let percents: Vec<u32> = err
        .lines()
        .filter_map(|l| l.strip_prefix("progress "))
        .map(|l| l.trim_start().split('%').next().unwrap().parse().unwrap())
        .collect();
    assert_eq!(percents, (1..=20).map(|k| k * 5).collect::<Vec<u32>>(), "{err}");
    let last = err.lines().rfind(|l| l.starts_with("progress ")).unwrap();
    assert!(last.starts_with("progress 100%  0:00:00 left  pen-down 566/566 mm  pen up at X "), "{last}");
}

#[test]
fn pen_changes_plot_straight_through_with_a_warning_when_nobody_can_answer() {
    let out = plot("piped-three-pens", &[sample("three-pens.svg").to_str().unwrap(), "--travel"]);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(0), "{err}");
    assert!(
        err.contains("warning: this plot uses 3 pens, and stdin is not a terminal to ask for them")
            && err.contains("--pen-change prompt"),
        "{err}"
    );
    assert!(!err.contains("[Enter] continue"), "{err}");
    // Asked for on purpose, the prompt still comes, and an empty stdin stops the plot at the first change.
    let out = plot("piped-prompt", &[sample("three-pens.svg").to_str().unwrap(), "--pen-change", "prompt"]);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(5), "{err}");
    assert!(err.contains("pen change 1/2") && err.contains("no answer (input closed or stopped): stopping"), "{err}");
}

#[test]
fn pause_at_pen_changes_needs_a_port() {
    let out = plot("piped-pause", &[sample("three-pens.svg").to_str().unwrap(), "--pen-change", "pause"]);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("--pen-change pause ends the plot at the first pen change"), "{err}");
    // Refused before anything was planned or moved.
    assert!(!err.contains("planned time") && !err.contains("progress"), "{err}");
}
