//! Fuzzing every input kind on stable Rust (proptest, run by `cargo test`): random and mutated SVG, G-code, HP-GL,
//! trajectory files, images and generator specs go through the public importers and the size limits. Each must
//! give a drawing within [`crate::geometry::limits`] or an error — never a panic. The files under
//! `plotter-path/fuzz/regressions/` are the crashes and hangs found so far (the issue's reproducers among them);
//! [`regressions_stay_fixed`] replays every one. [`svg_resources_never_panic`] feeds `<image>` references of every
//! kind — `data:` URLs (raster, nested SVG, mutated nested SVG, nested again), relative names (a regular file, a
//! FIFO, a link to `/dev/zero`, a directory, a missing file, `..`), absolute paths and URLs — under both resource
//! policies: each import must end (an error or a drawing within the limits) without hanging or panicking.
//! [`gcode_numbers_read_as_rust_parses_them`] writes well-formed decimals, with and without an exponent, as an X
//! word and checks what each import makes of it against Rust's own `f64` parse: a plotter draws to that X (an
//! exponent is part of the number), a printer refuses a number run into an `e` as ambiguous (never an E word), and
//! beyond each import's range the error names the line.

use proptest::prelude::*;

use crate::MachineProfile;
use crate::geometry::limits::{MAX_COORD_MM, check_drawing};
use crate::geometry::steps::StepMapper;
use crate::input::svg::{ResourcePolicy, SvgOptions, import_svg};
use crate::input::{gcode_in, gcode_print, r#gen, hpgl_in, raster, trajectory};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

fn svg(bytes: &[u8]) {
    if let Ok(i) = import_svg(bytes, "fuzz.svg", &ResourcePolicy::DataUrlsOnly, &SvgOptions::default()) {
        let _ = check_drawing(&i.drawing, "fuzz.svg");
    }
}

/// A `data:` URL with every byte but letters and digits percent-encoded.
fn data_url(mime: &str, bytes: &[u8]) -> String {
    let mut s = format!("data:{mime},");
    for b in bytes {
        if b.is_ascii_alphanumeric() {
            s.push(char::from(*b));
        } else {
            s.push_str(&format!("%{b:02X}"));
        }
    }
    s
}

/// A folder shared by the resource fuzz cases: a PNG, a nested SVG, a FIFO, a link to /dev/zero, a directory.
fn resource_dir() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("plotter-fuzz-resources-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(dir.join("sub")).unwrap();
        std::fs::write(dir.join("a.png"), include_bytes!("../../../samples/line-art.png")).unwrap();
        std::fs::write(dir.join("sub/b.svg"), include_bytes!("../../../samples/transforms.svg")).unwrap();
        #[cfg(unix)]
        {
            let _ = std::process::Command::new("mkfifo").arg(dir.join("fifo.png")).status();
            let _ = std::os::unix::fs::symlink("/dev/zero", dir.join("zero.png"));
        }
        dir
    })
}

/// The hrefs the resource fuzz case picks from (index, nested-SVG bytes).
fn href(kind: u8, nested: &[u8]) -> String {
    let raster = include_bytes!("../../../samples/line-art.png");
    match kind % 16 {
        0 => data_url("image/png", raster),
        1 => data_url("image/svg+xml", nested),
        2 => data_url("text/plain", nested),
        3 => data_url("image/svg+xml", image_doc(&data_url("image/svg+xml", nested)).as_bytes()),
        4 => data_url("image/svg+xml", image_doc("a.png").as_bytes()),
        5 => "a.png".into(),
        6 => "sub/b.svg".into(),
        7 => "fifo.png".into(),
        8 => "zero.png".into(),
        9 => "sub".into(),
        10 => "missing.png".into(),
        11 => "sub/../a.png".into(),
        12 => resource_dir().join("a.png").display().to_string(),
        13 => "/dev/zero".into(),
        14 => "file:///etc/passwd".into(),
        _ => data_url("image/gif", nested),
    }
}

/// A small document showing one `<image>` (also inside a mask and through `<use>`), referencing `href`.
fn image_doc(href: &str) -> String {
    format!(
        r##"<svg xmlns="http://www.w3.org/2000/svg" width="100" height="100"><defs><image id="i" width="20" height="20" href="{href}"/></defs><mask id="m"><rect width="100" height="100" fill="white"/><use href="#i"/></mask><use href="#i" x="30"/><g mask="url(#m)"><line x1="0" y1="50" x2="100" y2="50" stroke="black"/></g></svg>"##
    )
}

fn gcode(text: &str) {
    if let Ok(i) = gcode_in::import(text, "fuzz.gcode", &MachineProfile::default_plotter()) {
        check_drawing(&i.drawing, "fuzz.gcode").expect("the G-code importer keeps its own limits");
    }
}

fn hpgl(bytes: &[u8]) {
    if let Ok(i) = hpgl_in::import(bytes, "fuzz.hpgl", None) {
        // Coordinates are bounded in plotter units; placed on a sheet they may still cross the page limit, which
        // the final gate then refuses.
        let _ = check_drawing(&i.drawing, "fuzz.hpgl");
    }
}

fn traj(text: &str) {
    if let Ok(steps) = trajectory::import(text, "fuzz.traj") {
        let d = steps.to_drawing(&StepMapper::new(&MachineProfile::default_plotter()), "t");
        let _ = check_drawing(&d, "fuzz.traj");
    }
}

fn image(bytes: &[u8]) {
    if let Ok(img) = raster::decode_image(bytes, std::path::Path::new("fuzz.png")) {
        let _ = raster::trace_named(&img, "fuzz.png", &raster::TraceOptions::default());
    }
}

/// Replay every committed regression input.
#[test]
fn regressions_stay_fixed() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/regressions");
    let mut n = 0;
    for e in std::fs::read_dir(&dir).unwrap() {
        let p = e.unwrap().path();
        let bytes = std::fs::read(&p).unwrap();
        match p.extension().and_then(|x| x.to_str()) {
            Some("svg") => {
                // Each SVG regression is absurd: it must be refused by the limits (or the importer), never panic.
                if let Ok(i) = import_svg(&bytes, "r.svg", &ResourcePolicy::DataUrlsOnly, &SvgOptions::default()) {
                    let checked = check_drawing(&i.drawing, "r.svg");
                    let preview = crate::output::preview::render(&i.drawing, &Default::default());
                    assert!(checked.is_err() || preview.is_ok(), "{}", p.display());
                }
            }
            Some("gcode") => gcode(std::str::from_utf8(&bytes).unwrap()),
            Some("traj") => traj(std::str::from_utf8(&bytes).unwrap()),
            Some("png" | "jpg") => image(&bytes),
            _ => continue,
        }
        n += 1;
    }
    assert!(n >= 7, "{n} regression inputs");
}

/// `PROPTEST_CASES` when set (for long fuzz runs), else `default`.
fn cases(default: u32) -> u32 {
    std::env::var("PROPTEST_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(default)
}

fn mutate(base: &[u8], edits: &[(usize, u8, u8)]) -> Vec<u8> {
    let mut v = base.to_vec();
    for &(pos, kind, byte) in edits {
        if v.is_empty() {
            v.push(byte);
            continue;
        }
        let i = pos % v.len();
        match kind % 4 {
            0 => v[i] = byte,
            1 => {
                v.remove(i);
            }
            2 => v.insert(i, byte),
            _ => {
                // Splice in a digit run: absurd numbers are where the trouble was.
                for d in b"9999999999" {
                    v.insert(i, *d);
                }
            }
        }
    }
    v
}

fn edits() -> impl Strategy<Value = Vec<(usize, u8, u8)>> {
    proptest::collection::vec((any::<usize>(), any::<u8>(), any::<u8>()), 0..12)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(cases(48)))]

    #[test]
    fn svg_never_panics(e in edits()) {
        let base = include_bytes!("../../../samples/transforms.svg");
        svg(&mutate(base, &e));
    }

    #[test]
    fn svg_resources_never_panic(kinds in proptest::collection::vec(any::<u8>(), 1..4), e in edits()) {
        let nested = mutate(include_bytes!("../../../samples/transforms.svg"), &e);
        let policies = [
            ResourcePolicy::DataUrlsOnly,
            ResourcePolicy::BesideFile { dir: resource_dir().to_path_buf(), max_bytes: 1 << 20 },
        ];
        for policy in &policies {
            for &k in &kinds {
                let doc = image_doc(&href(k, &nested));
                if let Ok(i) = import_svg(doc.as_bytes(), "fuzz.svg", policy, &SvgOptions::default()) {
                    let _ = check_drawing(&i.drawing, "fuzz.svg");
                }
            }
        }
    }

    #[test]
    fn gcode_never_panics(e in edits(), lines in proptest::collection::vec("[GMXYZIJRFN ]{0,3}[-+.0-9e]{0,24}( [XYZIJR][-.0-9]{0,42})*", 0..20)) {
        gcode(&String::from_utf8_lossy(&mutate(b"G21\nG90\nG0 X10 Y10\nG1 Z0\nG2 X20 Y10 I5 J0\nG1 X30\n", &e)));
        gcode(&lines.join("\n"));
    }

    #[test]
    fn hpgl_never_panics(e in edits(), cmds in proptest::collection::vec("[A-Z]{2}[-+.0-9, ]{0,30};?", 0..20)) {
        hpgl(&mutate(b"IN;IW0,0,11040,7721;SP1;PU800,6240;PD1200,6240;PR;PD0,-400;LBab\x03;PA;PU;SP0;", &e));
        hpgl(cmds.concat().as_bytes());
    }

    #[test]
    fn trajectory_never_panics(e in edits(), nums in proptest::collection::vec(any::<i64>(), 0..30)) {
        traj(&String::from_utf8_lossy(&mutate(b"4\n100\n0\n1\n0\n100\n0\n-100\n0\n", &e)));
        let text: Vec<String> = nums.iter().map(ToString::to_string).collect();
        traj(&text.join("\n"));
    }

    #[test]
    fn images_never_panic(e in edits()) {
        let base = include_bytes!("../../../samples/line-art.png");
        image(&mutate(base, &e));
    }

    #[test]
    fn gen_specs_never_panic(kind in "[a-z]{2,12}", params in proptest::collection::vec(("[a-z]{1,9}", "[-0-9.e/]{1,22}"), 0..4)) {
        let q: Vec<String> = params.iter().map(|(k, v)| format!("{k}={v}")).collect();
        for k in [kind.as_str(), "circle", "rose", "spiral", "lissajous", "epicycloid"] {
            if let Ok(d) = r#gen::from_spec(&format!("{k}?{}", q.join("&"))) {
                let _ = check_drawing(&d, "gen");
            }
        }
    }
}

/// A well-formed decimal as a script or a slicer writes it: sign, digits and a fraction (at least one digit in
/// all), and sometimes an exponent (`e`/`E`, sign, 1–3 digits). Returns the text and whether it has an exponent.
fn decimal() -> impl Strategy<Value = (String, bool)> {
    ("[-+]?", "[0-9]{0,8}", "(\\.[0-9]{0,8})?", "([eE][-+]?[0-9]{1,3})?")
        .prop_filter("a digit before any exponent", |(_, i, f, _)| {
            i.bytes().chain(f.bytes()).any(|b| b.is_ascii_digit())
        })
        .prop_map(|(s, i, f, e)| (format!("{s}{i}{f}{e}"), !e.is_empty()))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(cases(256)))]

    #[test]
    fn gcode_numbers_read_as_rust_parses_them((text, exponent) in decimal()) {
        let v: f64 = text.parse().expect("a well-formed decimal parses");
        // A plotter (no E axis): the number whole, exponent included, as Rust reads it.
        let plotter = MachineProfile::default_plotter();
        let drawing = format!("G0 Z1\nG0 X0 Y0\nG1 Z0\nG1 X{text} Y1\n");
        match gcode_in::import(&drawing, "t.gcode", &plotter) {
            Ok(i) => {
                prop_assert!(v.abs() <= MAX_COORD_MM, "X{} = {} accepted", text, v);
                let end = i.drawing.paths().last().and_then(|p| p.end()).expect("a line is drawn");
                let want = plotter.machine_to_page(kurbo::Point::new(v, 1.0));
                prop_assert!((end.x - want.x).abs() <= 1e-9 * (1.0 + v.abs()), "X{}: {:?} vs {:?}", text, end, want);
                prop_assert!((end.y - want.y).abs() <= 1e-9, "X{}: {:?} vs {:?}", text, end, want);
                prop_assert!(i.warnings.is_empty(), "X{}: {:?}", text, i.warnings);
            }
            Err(e) => {
                let e = e.to_string();
                prop_assert!(v.abs() > MAX_COORD_MM, "X{} = {} refused: {}", text, v, e);
                let range = if v.is_finite() { "mm is beyond ±1000000 mm (1 km)" } else { "number out of range" };
                prop_assert!(e.starts_with("t.gcode:4: X") && e.contains(range), "X{}: {}", text, e);
            }
        }
        // A printer (E is a word, as in Marlin): an exponent is ambiguous and refused, never extruded; otherwise
        // the move goes to X as Rust reads it, within the printer's ±10⁷ mm.
        let printer = MachineProfile::from_toml(include_str!("../../../samples/printer.toml"), "printer.toml")
            .expect("the sample printer profile");
        match gcode_print::import_print(&format!("G28\nG1 X{text} Y1 F600\n"), "t.gcode", &printer) {
            Ok(p) => {
                prop_assert!(!exponent && v.abs() < 1e7, "X{} accepted", text);
                let to = p.ops.iter().find_map(|o| match o {
                    gcode_print::PrintOp::Move { to, .. } => Some(*to),
                    _ => None,
                });
                prop_assert_eq!(to.map(|t| (t[0], t[1], t[3])), Some((v, 1.0, 0.0)), "X{}", text);
            }
            Err(e) => {
                let e = e.to_string();
                let why = if exponent { "ambiguous number: X" } else { "position out of range" };
                prop_assert!(e.starts_with("t.gcode:2: ") && e.contains(why), "X{}: {}", text, e);
                prop_assert!(exponent || v.abs() >= 1e7, "X{}: {}", text, e);
            }
        }
    }
}
