//! The page meets the machine before anything connects (issue 38, item 3): `--paper a4 --fit` on a machine that
//! takes A4 only landscape (the HP 7475A's A4 sheet, the AxiDraw V3's 300 × 218 mm work area) turns the paper,
//! says so in one line, and fits the drawing where the pen reaches; when the layout cannot be drawn, the error
//! names the fix before any port is opened. And `--rotate` in degrees: a journal recorded when it counted quarter
//! turns is refused rather than resumed with a 1° turn (item 11).

use plotter_e2e::{SimPty, plotter, sample, scratch};

fn run(dir: &std::path::Path, args: &[&str]) -> (Option<i32>, String, String) {
    let out = plotter(dir, args);
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn path(p: &std::path::Path) -> &str {
    p.to_str().expect("utf-8 path")
}

/// Every X,Y pair of the HP-GL program's PU/PD/PA commands, plotter units.
fn hpgl_points(text: &str) -> Vec<(i64, i64)> {
    let mut points = Vec::new();
    for cmd in text.split(';').map(str::trim) {
        let Some(args) = ["PU", "PD", "PA"].iter().find_map(|c| cmd.strip_prefix(c)) else { continue };
        let v: Vec<i64> = args.split(',').filter(|s| !s.is_empty()).map(|s| s.parse().expect("integer")).collect();
        points.extend(v.chunks(2).map(|c| (c[0], c[1])));
    }
    points
}

/// `plot samples/duck.svg --paper a4 --fit --export duck.hpgl` (failed: "lies outside the HP 7475A's a4
/// plotting area", with --landscape too). The 7475A takes A4 as a 297 × 210 mm sheet whose plotting area is
/// x 10..286, y 12.975..206 mm on the page (11040 × 7721 plu from (10, 206)): the paper turns to landscape, and the
/// duck (wider than the area's 276 : 187.025) is fitted into A4 minus 10 mm margins within that area, x 10..286 mm
/// = plu 0..11040 exactly, centred on y (12.975 + 200)/2 = 106.4875 mm = plu (206 − 106.4875)·40 = 3980.5.
#[test]
fn an_a4_fit_turns_to_the_hp_7475a_sheet_and_stays_in_its_plotting_area() {
    let dir = scratch("layout-hpgl");
    let duck = sample("duck.svg");
    let (code, stdout, stderr) = run(&dir, &["plot", path(&duck), "--paper", "a4", "--fit", "--export", "duck.hpgl"]);
    assert_eq!(code, Some(0), "{stderr}");
    assert!(
        stderr.contains(
            "A4 portrait (210 × 297 mm) goes on the HP 7475A's a4 sheet (297 × 210 mm) only turned; turned to landscape"
        ),
        "{stderr}"
    );
    assert!(stdout.contains("for the HP 7475A on a4 written to duck.hpgl"), "{stdout}");
    let text = std::fs::read_to_string(dir.join("duck.hpgl")).expect("export written");
    let points = hpgl_points(&text);
    assert!(points.len() > 50, "{} points", points.len());
    assert!(points.iter().all(|&(x, y)| (0..=11040).contains(&x) && (0..=7721).contains(&y)), "outside the area");
    let (x0, x1) = (points.iter().map(|p| p.0).min().unwrap(), points.iter().map(|p| p.0).max().unwrap());
    let (y0, y1) = (points.iter().map(|p| p.1).min().unwrap(), points.iter().map(|p| p.1).max().unwrap());
    assert_eq!((x0, x1), (0, 11040));
    let centre = (y0 + y1) as f64 / 2.0;
    assert!((centre - 3980.5).abs() <= 1.0, "y {y0}..{y1}");

    // Asked landscape: nothing to turn, the same program.
    let args = ["plot", path(&duck), "--paper", "a4", "--fit", "--landscape", "--export", "landscape.hpgl"];
    let (code, _, stderr) = run(&dir, &args);
    assert_eq!(code, Some(0), "{stderr}");
    assert!(!stderr.contains("turned"), "{stderr}");
    assert_eq!(std::fs::read_to_string(dir.join("landscape.hpgl")).unwrap(), text);
}

/// `plot … --paper a4 --fit --profile samples/axidraw-v3.toml`, simulated and on the EBB emulator: A4 portrait
/// overhangs the 300 × 218 mm work area, so it turns (said before the port is opened); the duck is then fitted
/// into A4 landscape minus 10 mm margins (277 × 190 mm; the duck is wider than that), x 10..287 mm, which the board
/// steps at 80 steps/mm (motor 1 = X + Y, motor 2 = X − Y): every pen-down step inside the work area.
#[test]
fn an_a4_fit_turns_on_the_axidraw_simulated_and_on_the_board() {
    let dir = scratch("layout-axidraw");
    let duck = sample("duck.svg");
    let profile = sample("axidraw-v3.toml");
    let turned = "A4 portrait (210 × 297 mm) does not fit the AxiDraw V3 (A4)'s 300 × 218 mm work area; turned to \
                  landscape";
    let base = ["plot", path(&duck), "--paper", "a4", "--fit", "--profile", path(&profile)];
    let (code, stdout, stderr) = run(&dir, &base);
    assert_eq!(code, Some(0), "{stderr}\n{stdout}");
    assert!(stderr.contains(turned), "{stderr}");

    let sim = SimPty::start(&dir, &["--ebb", "--fast", "--profile", path(&profile)]);
    let args: Vec<&str> = base.iter().copied().chain(["--firmware", "ebb", "--port", &sim.port]).collect();
    let (code, stdout, stderr) = run(&dir, &args);
    assert_eq!(code, Some(0), "{stderr}\n{stdout}");
    let said = stderr.find(turned).expect("the turn is said");
    let connected = stderr.find("connected to EiBotBoard").expect("connected");
    assert!(said < connected, "the page met the machine before connecting:\n{stderr}");
    let trace = sim.stop();
    assert_eq!(SimPty::figure(&trace, "ebb", "errors"), Some(0));
    // Pen-down positions in XY steps: ((m1 + m2)/2, (m1 − m2)/2).
    let down: Vec<(f64, f64)> = trace
        .positions
        .iter()
        .filter(|p| p[2] == 0)
        .map(|p| ((p[0] + p[1]) as f64 / 160.0, (p[0] - p[1]) as f64 / 160.0))
        .collect();
    assert!(down.len() > 100, "{} pen-down steps", down.len());
    assert!(down.iter().all(|&(x, y)| (0.0..=300.0).contains(&x) && (0.0..=218.0).contains(&y)), "off the area");
    let x0 = down.iter().map(|p| p.0).fold(f64::INFINITY, f64::min);
    let x1 = down.iter().map(|p| p.0).fold(f64::NEG_INFINITY, f64::max);
    assert!((x0 - 10.0).abs() < 0.1 && (x1 - 287.0).abs() < 0.1, "x {x0}..{x1} mm");
}

const TALL: &str = r#"<svg xmlns="http://www.w3.org/2000/svg" width="210mm" height="297mm" viewBox="0 0 210 297">
<rect x="15" y="20" width="180" height="260" fill="none" stroke="black"/></svg>"#;

/// When the layout cannot be drawn, the error names the fix, and comes before any port is opened (the port here
/// does not exist: the layout's error is the one reported).
#[test]
fn a_layout_the_machine_cannot_draw_is_refused_naming_the_fix_before_connecting() {
    let dir = scratch("layout-refused");
    std::fs::write(dir.join("tall.svg"), TALL).unwrap();
    let profile = sample("axidraw-v3.toml");
    let args = [
        "plot",
        "tall.svg",
        "--paper",
        "a4",
        "--orientation",
        "portrait",
        "--profile",
        path(&profile),
        "--firmware",
        "ebb",
        "--port",
        "/dev/plotter-layout-test-no-such-port",
    ];
    let (code, _, stderr) = run(&dir, &args);
    assert_eq!(code, Some(1), "{stderr}");
    assert!(
        stderr.contains(
            "A4 portrait (210 × 297 mm) does not fit the AxiDraw V3 (A4)'s 300 × 218 mm work area, and the drawing \
             (x 15..195, y 20..280 mm on the page) reaches beyond it (x 0..300, y 0..218 mm); use --fit --landscape, \
             --fit --paper a5, or --fit"
        ),
        "{stderr}"
    );
    assert!(!stderr.contains("no-such-port"), "{stderr}");

    // An HP-GL plotter takes none of its sheets as A2, either way.
    let (code, _, stderr) = run(&dir, &["plot", "tall.svg", "--paper", "a2", "--fit", "--export", "t.hpgl"]);
    assert_eq!(code, Some(1), "{stderr}");
    assert!(
        stderr.contains(
            "A2 portrait (420 × 594 mm) does not fit the HP 7475A's sheets (a4, letter, a3, tabloid); use --paper a3"
        ),
        "{stderr}"
    );
    assert!(!dir.join("t.hpgl").exists());
}

/// A journal whose plot was recorded with `--rotate 1` (a quarter turn, before --rotate took degrees) is refused,
/// saying why and what to type, instead of being rebuilt with a 1° turn.
#[test]
fn a_journal_recorded_in_quarter_turns_is_refused() {
    let dir = scratch("layout-journal");
    let source = serde_json::json!({
        "cwd": dir,
        "args": [path(&sample("duck.svg")), "--rotate", "1", "--port", "/dev/x"],
        "start": [0, 0, 0, 0],
    });
    std::fs::write(
        dir.join("old.journal"),
        format!("plotter-journal 1\nsource {source}\nplan 1f 10\nprogress 4 3 4\n"),
    )
    .unwrap();
    let (code, _, stderr) =
        run(&dir, &["plot", "--resume", "old.journal", "--port", "/dev/plotter-layout-test-no-such-port"]);
    assert_eq!(code, Some(1), "{stderr}");
    assert!(
        stderr.contains("recorded with --rotate 1, when --rotate counted quarter turns")
            && stderr.contains("--rotate 90 for the same turn"),
        "{stderr}"
    );
}
