//! The `plotter` binary: preview, stats, convert, stdin/stdout, and clear errors for bad input.

use std::io::Write;
use std::path::PathBuf;
use std::process::{Command, Output, Stdio};

fn plotter() -> Command {
    Command::new(env!("CARGO_BIN_EXE_plotter"))
}

fn sample(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../samples").join(name)
}

fn out_dir(test: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(test);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn run(cmd: &mut Command) -> Output {
    cmd.output().expect("run plotter")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn preview_writes_a_png() {
    let out = out_dir("preview").join("duck.png");
    let o = run(plotter().args(["preview"]).arg(sample("duck.svg")).arg("-o").arg(&out).arg("--travel"));
    assert!(o.status.success(), "{}", stderr(&o));
    let bytes = std::fs::read(&out).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
}

#[test]
fn a_preview_that_cannot_be_written_warns_and_the_finished_plot_succeeds() {
    // A side output (issue 38): the plot on the simulator finishes; its as-stepped preview has nowhere to go.
    let dir = out_dir("preview-unwritable");
    let blocked = dir.join("not-a-directory");
    std::fs::write(&blocked, "a file where the preview's folder should be").unwrap();
    let o = run(plotter()
        .current_dir(&dir)
        .args(["plot", "gen:circle?r=5&cx=20&cy=20", "--preview"])
        .arg(blocked.join("circle.png")));
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(String::from_utf8_lossy(&o.stdout).starts_with("plot time "), "the plot ran");
    assert!(err.contains("warning: the plot finished, but its as-stepped preview was not written"), "{err}");
}

/// Seconds of an `m:ss.s` clock.
fn clock_s(text: &str) -> f64 {
    let (m, s) = text.split_once(':').unwrap_or_else(|| panic!("not a clock: {text}"));
    m.parse::<f64>().unwrap() * 60.0 + s.parse::<f64>().unwrap()
}

#[test]
fn copies_report_the_last_copy_against_its_plan_and_all_of_them_in_all() {
    // Three copies with 0.5 s between them on the simulator: the summary's plot time is one copy's, equal to its
    // plan (no "(planned ...)" beside it, which would mean the two differ); the copies line counts three and
    // their time in all is 3 × one copy + 2 × 0.5 s, to the display's rounding (each clock to the tenth).
    let dir = out_dir("copies-summary");
    let o = run(plotter().current_dir(&dir).args([
        "plot",
        "gen:circle?r=5&cx=20&cy=20",
        "--copies",
        "3",
        "--page-delay",
        "0.5",
        "--no-paper-pause",
    ]));
    let out = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(o.status.success(), "{}", stderr(&o));
    let first = out.lines().find(|l| l.starts_with("plot time ")).expect("a summary");
    assert!(!first.contains("planned"), "one copy ran as planned: {first}");
    let copies = out.lines().find(|l| l.starts_with("3 copies in ")).unwrap_or_else(|| panic!("{out}"));
    let total = clock_s(copies["3 copies in ".len()..].split_whitespace().next().unwrap());
    let each = clock_s(copies.split("each planned ").nth(1).unwrap().split(';').next().unwrap());
    let one = clock_s(first["plot time ".len()..].split(':').take(2).collect::<Vec<_>>().join(":").as_str());
    assert!((each - one).abs() < 1e-9, "{copies} vs {first}");
    assert!((total - (3.0 * each + 1.0)).abs() <= 0.2 + 1e-9, "{copies}");
}

#[test]
fn stats_json_has_the_documented_keys() {
    let o = run(plotter().args(["stats", "--json"]).arg(sample("duck.svg")));
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    for key in ["paths", "segments", "pen_down_mm", "pen_up_mm", "pen_lifts", "bbox_mm"] {
        assert!(v.get(key).is_some(), "missing {key} in {v}");
    }
    assert_eq!(v["paths"], 6);
    assert_eq!(v["segments"], 71);
    // The duck's page is 120 × 90 mm and its geometry keeps the SVG's own size.
    assert_eq!(v["bbox_mm"], serde_json::json!([8.0, 9.0, 116.0, 82.0]));
}

#[test]
fn convert_through_stdin_and_stdout_with_layout() {
    let svg = std::fs::read(sample("duck.svg")).unwrap();
    let mut child = plotter()
        .args(["convert", "-", "-o", "-", "--paper", "a4", "--landscape", "--fit", "--margin", "20"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    child.stdin.take().unwrap().write_all(&svg).unwrap();
    let o = child.wait_with_output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8(o.stdout).unwrap();
    assert!(text.contains("width=\"297mm\" height=\"210mm\""), "{text}");
    assert_eq!(text.matches("<polygon").count() + text.matches("<polyline").count(), 6);
}

#[test]
fn bad_inputs_fail_cleanly_naming_the_file() {
    let dir = out_dir("bad");
    let not_svg = dir.join("notes.svg");
    std::fs::write(&not_svg, "just some text").unwrap();
    let truncated = dir.join("truncated.svg");
    std::fs::write(&truncated, "<svg xmlns=\"http://www.w3.org/2000/svg\"><line x1=\"0\" y1=\"0\"").unwrap();
    let empty = dir.join("empty.svg");
    std::fs::write(&empty, "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"10\" height=\"10\"><g/></svg>").unwrap();
    let missing = dir.join("missing.svg");
    for (file, want) in [
        (&not_svg, "not a valid SVG"),
        (&truncated, "not a valid SVG"),
        (&empty, "nothing to draw"),
        (&missing, "cannot read"),
    ] {
        let o = run(plotter().arg("stats").arg(file));
        assert_eq!(o.status.code(), Some(1), "{}", file.display());
        let err = stderr(&o);
        assert!(err.contains(&file.display().to_string()) && err.contains(want), "{err}");
        assert!(!err.contains("panicked"), "{err}");
    }
}

#[test]
fn layout_errors_are_reported() {
    let o = run(plotter().args(["stats", "--paper", "b9"]).arg(sample("duck.svg")));
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("unknown paper size 'b9'"), "{}", stderr(&o));
}

#[test]
fn stats_json_reports_optimisation_and_time() {
    let o = run(plotter().args(["stats", "--json"]).arg(sample("layers.svg")));
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let f = |k: &str| v[k].as_f64().unwrap_or_else(|| panic!("{k} missing in {v}"));
    assert!(f("pen_up_lower_bound_mm") <= f("pen_up_mm_optimized"));
    assert!(f("pen_up_mm_optimized") <= f("pen_up_mm"));
    assert!(f("est_time_s_optimized") > 0.0 && f("est_time_s_optimized") <= f("est_time_s"));
    // Without optimisation the optimised figures are absent, the plain estimate stays.
    let o = run(plotter().args(["stats", "--json", "--no-optimize"]).arg(sample("layers.svg")));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(v["pen_up_mm_optimized"].is_null() && v["est_time_s"].as_f64().is_some(), "{v}");
}

#[test]
fn every_input_kind_previews() {
    let dir = out_dir("kinds");
    let image = sample("line-art.png");
    for (input, extra) in [
        (image.to_str().unwrap(), &["--mode", "centerline", "--width", "120"][..]),
        ("gen:rose?k=5&a=30", &[][..]),
        ("gen:mickey?harmonics=8", &["--paper", "a5", "--fit"][..]),
    ] {
        let out = dir.join("out.png");
        let o = run(plotter().args(["preview", input, "-o"]).arg(&out).args(extra));
        assert!(o.status.success(), "{input}: {}", stderr(&o));
        assert!(std::fs::read(&out).unwrap().starts_with(b"\x89PNG"));
    }
    let o = run(plotter().args(["stats", "gen:rose?k=0"]));
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("rose"), "{}", stderr(&o));
}

#[test]
fn stats_says_what_the_import_left_out_and_why() {
    // A line, a white square on the blank page (no visible edge), an untraced image and a pattern finer than the pen.
    let file = out_dir("stats-skipped").join("skips.svg");
    std::fs::write(
        &file,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="100mm" height="100mm" viewBox="0 0 100 100">
             <defs><pattern id="fine" patternUnits="userSpaceOnUse" width="0.1" height="0.1">
               <circle cx="0.05" cy="0.05" r="0.04" fill="black"/></pattern></defs>
             <line x1="0" y1="90" x2="7" y2="90" stroke="black"/>
             <rect x="10" y="10" width="20" height="20" fill="white"/>
             <image x="0" y="40" width="4" height="4" href="data:image/png;base64,iVBORw0KGgo="/>
             <circle cx="50" cy="60" r="5" fill="url(#fine)"/>
           </svg>"#,
    )
    .unwrap();
    let o = run(plotter().args(["stats", "--json"]).arg(&file));
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(
        v["skipped"],
        serde_json::json!({"same_colour_fill": 1, "image_not_traced": 1, "pattern_too_fine": 1}),
        "{v}"
    );
    let o = run(plotter().arg("stats").arg(&file));
    let text = String::from_utf8_lossy(&o.stdout);
    let line = text.lines().find(|l| l.starts_with("skipped")).unwrap_or_default();
    assert!(
        line.contains("1 fill-only shape(s) not outlined: the colour of what lies beneath")
            && line.contains("1 raster image(s) not traced")
            && line.contains("1 pattern fill(s) finer than the pen"),
        "{text}"
    );
    // Nothing left out: said so.
    let o = run(plotter().arg("stats").arg(sample("duck.svg")));
    assert!(String::from_utf8_lossy(&o.stdout).lines().any(|l| l == "skipped       nothing"));
}

#[test]
fn a_printing_command_ends_quietly_when_its_reader_goes_away() {
    // `plotter stats FILE | head -0`: the reader closes before anything is printed.
    let mut child = plotter()
        .arg("stats")
        .arg(sample("duck.svg"))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run plotter");
    drop(child.stdout.take());
    let o = child.wait_with_output().expect("plotter ends");
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("panicked"), "{}", stderr(&o));
}

#[test]
fn the_qemu_board_refuses_another_machine_naming_every_flag_that_chose_it() {
    // The image's machine is compiled in: a model or a speed setting would be silently ignored.
    for extra in [&["--model", "axidraw-v3"][..], &["--speed-pendown", "50"][..]] {
        let o = run(plotter().args(["sim", "--qemu"]).args(extra));
        assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
        assert!(stderr(&o).contains("drop --model, --profile and the speed and pen settings"), "{}", stderr(&o));
    }
}
