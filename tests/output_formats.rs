//! The output file's name says what `preview`, `convert` and `optimize` write (issue 38, item 8): `.png` a PNG,
//! `.svg` an SVG, `.svgz` a gzipped SVG, `-` each command's own default on stdout, and any other name a clear
//! error listing the extensions, with nothing written.

use std::path::Path;

use plotter_e2e::{plotter, sample, scratch};

/// The first bytes of a written file: what format it is, from its content alone.
fn kind(path: &Path) -> &'static str {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    if bytes.starts_with(b"\x89PNG\r\n\x1a\n") {
        "png"
    } else if bytes.starts_with(&[0x1f, 0x8b]) {
        "gzip"
    } else if bytes.starts_with(b"<?xml") && String::from_utf8_lossy(&bytes).contains("<svg ") {
        "svg"
    } else {
        "other"
    }
}

fn run(dir: &Path, args: &[&str]) -> (bool, String, Vec<u8>) {
    let out = plotter(dir, args);
    (out.status.success(), String::from_utf8_lossy(&out.stderr).into_owned(), out.stdout)
}

#[test]
fn each_command_writes_what_the_extension_says() {
    let dir = scratch("output-formats");
    let duck = sample("duck.svg");
    let duck = duck.to_str().unwrap();
    for command in ["preview", "convert", "optimize"] {
        for (name, expect) in [("out.svg", "svg"), ("OUT.PNG", "png"), ("out.svgz", "gzip")] {
            let file = format!("{command}-{name}");
            let (ok, err, _) = run(&dir, &[command, duck, "-o", &file]);
            assert!(ok, "{command} -o {file}: {err}");
            assert_eq!(kind(&dir.join(&file)), expect, "{command} -o {file}");
        }
        // `-`: a PNG from preview, the SVG from the others.
        let (ok, err, stdout) = run(&dir, &[command, duck, "-o", "-"]);
        assert!(ok, "{command}: {err}");
        let png = stdout.starts_with(b"\x89PNG");
        assert_eq!(png, command == "preview", "{command} -o -: {:?}", &stdout[..8.min(stdout.len())]);
        // Any other name: refused, naming the command, the name and what it writes; nothing written.
        let (ok, err, _) = run(&dir, &[command, duck, "-o", "out.pdf"]);
        assert!(!ok);
        assert_eq!(
            err,
            format!(
                "error: {command}: cannot tell what to write from the name out.pdf: {command} writes .svg, .svgz or \
                 .png files (chosen by the extension), or `-` for {} on stdout\n",
                if command == "preview" { "a PNG" } else { "an SVG" }
            )
        );
        assert!(!dir.join("out.pdf").exists());
    }
}

#[test]
fn the_svg_preview_draws_the_strokes_and_the_travel() {
    let dir = scratch("output-preview-svg");
    let layers = sample("layers.svg");
    let (ok, err, _) = run(&dir, &["preview", layers.to_str().unwrap(), "-o", "p.svg", "--travel"]);
    assert!(ok, "{err}");
    let svg = std::fs::read_to_string(dir.join("p.svg")).unwrap();
    // One layer group per layer with its pen's colour and width, and the dashed travel layer last.
    let groups = svg.matches("inkscape:groupmode=\"layer\"").count();
    assert!(groups >= 3, "{svg}");
    let travel = svg.find("inkscape:label=\"travel (pen up)\"").expect("a travel layer");
    assert!(svg[travel..].contains("stroke-dasharray=\"1 1\""), "{svg}");
    assert!(svg.rfind("inkscape:label=").unwrap() == travel, "the travel is drawn over the strokes");
    // Without --travel, no travel layer.
    let (ok, err, _) = run(&dir, &["preview", layers.to_str().unwrap(), "-o", "q.svg"]);
    assert!(ok, "{err}");
    assert!(!std::fs::read_to_string(dir.join("q.svg")).unwrap().contains("travel (pen up)"));
}
