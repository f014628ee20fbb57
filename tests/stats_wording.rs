//! Every figure `plot` and `stats` print is true as worded (issue 38, item 9): no part of the plot time is shown
//! below its own lower bound, no percentage reads `+-`, the pen-up saving says it is a saving, and the default
//! output speaks to the person at the plotter while the plan's and the link's figures wait for `--verbose`.

use std::fmt::Write as _;

use plotter_e2e::{plotter, scratch};

/// 150 short strokes of one to three tiny segments scattered over 150 mm, as traced clip art has: their lifts
/// are where the planner's curve rule takes the pen's rise faster than a 90° corner.
fn dashes() -> String {
    let mut svg = String::from(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"200mm\" height=\"200mm\" viewBox=\"0 0 200 200\">\n",
    );
    let mut seed = 11u64;
    let mut next = || {
        seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        f64::from(u32::try_from(seed >> 40).unwrap()) / f64::from(1u32 << 24)
    };
    for i in 0..150 {
        let (mut x, mut y) = (20.0 + 150.0 * next(), 20.0 + 150.0 * next());
        let mut d = format!("M {x:.3} {y:.3}");
        for _ in 0..=(i % 3) {
            (x, y) = (x + 0.1 + 0.4 * next(), y + 0.3 * next());
            let _ = write!(d, " L {x:.3} {y:.3}");
        }
        let _ = writeln!(svg, "<path d=\"{d}\" fill=\"none\" stroke=\"black\" stroke-width=\"0.3\"/>");
    }
    svg + "</svg>\n"
}

fn stdout(dir: &std::path::Path, args: &[&str]) -> String {
    let out = plotter(dir, args);
    assert!(out.status.success(), "{args:?}: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8_lossy(&out.stdout).into_owned()
}

#[test]
fn no_part_of_the_plot_time_reads_below_its_bound_and_no_sign_is_doubled() {
    let dir = scratch("stats-wording");
    std::fs::write(dir.join("dashes.svg"), dashes()).unwrap();
    let shown = stdout(&dir, &["stats", "dashes.svg", "--verbose"]);
    let parts: Vec<&str> = shown.lines().filter(|l| l.contains("time parts, planned (lower bound):")).collect();
    assert_eq!(parts.len(), 2, "before and after ordering: {shown}");
    for line in parts {
        // Each of pen down, lifts, and travel with lifts: `NAME T s (bound B s, P % above)`.
        assert_eq!(line.matches("% above)").count(), 3, "{line}");
        assert!(!line.contains("below") && !line.contains("+-") && !line.contains("-"), "{line}");
    }
    // The pen-up line says what its percentage is.
    let optimized = shown.lines().find(|l| l.starts_with("optimized")).unwrap();
    assert!(optimized.contains("% of ") && optimized.contains("(saves "), "{optimized}");
}

#[test]
fn the_default_output_speaks_to_the_plotter_owner() {
    let dir = scratch("plot-wording");
    std::fs::write(dir.join("dashes.svg"), dashes()).unwrap();
    // plot: one line of what the plot did; the plan's and the link's figures only with --verbose.
    let plain = stdout(&dir, &["plot", "dashes.svg", "--preview", "p.png"]);
    let first = plain.lines().next().unwrap();
    assert!(first.starts_with("plot time ") && first.ends_with(" pen lifts"), "{plain}");
    assert!(first.contains(" mm pen-down, ") && first.contains(" mm pen-up, "), "{plain}");
    // The simulated plot ran its planned time (counted from the end of homing): one time, no "(planned …)".
    assert!(!first.contains("planned"), "{plain}");
    for developer in ["blocks", "bytes/block", "resends", "underruns", "lower bound", "time parts"] {
        assert!(!plain.contains(developer), "{developer} in the default output:\n{plain}");
    }
    let verbose = stdout(&dir, &["plot", "dashes.svg", "--preview", "p.png", "--verbose"]);
    assert!(verbose.starts_with(first), "{verbose}");
    for developer in ["blocks", "bytes/block", "0 resends", "lower bound", "time parts, planned (lower bound)"] {
        assert!(verbose.contains(developer), "{developer} missing with --verbose:\n{verbose}");
    }
    // stats: the plot time and what ordering saves; the bounds with --verbose.
    let plain = stdout(&dir, &["stats", "dashes.svg"]);
    assert!(plain.contains("plot time ") && plain.contains("(saves "), "{plain}");
    assert!(!plain.contains("lower bound") && !plain.contains("time parts"), "{plain}");
}
