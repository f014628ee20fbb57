//! `plotter gen`: generate a parametric figure (roulettes, roses, Lissajous, spirals, Fourier outlines and their
//! epicycles) and write it as a plain SVG or a preview PNG, laid out with the usual layout flags.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::Args;
use plotter_path::input::r#gen::{COMMON_PARAMS, KINDS, Spec};
use plotter_path::output::preview::{PreviewOptions, render_png};
use plotter_path::output::svg_out::to_svg_string;

use plotter_host::input::write_output;
use plotter_host::options::layout::LayoutArgs;

/// Generate a parametric figure as SVG or PNG.
///
/// Examples: `plotter gen epicycloid q=3 r=10 -o e.svg`, `plotter gen spirograph q=7/3 d=12 -o s.png`,
/// `plotter gen 'mickey?harmonics=16' -o m.png --paper a4 --fit`. `plotter gen --list` shows every kind.
#[derive(Debug, Args)]
pub(crate) struct GenArgs {
    /// Figure kind, optionally with its parameters as `KIND?p=v&p=v`
    #[arg(required_unless_present = "list")]
    pub(crate) kind: Option<String>,
    /// Parameters as `name=value` (e.g. `q=5/2 r=12 tol=0.02`)
    pub(crate) params: Vec<String>,
    /// Output file: `.svg` (plain polylines in mm) or `.png` (preview)
    #[arg(short, long, required_unless_present = "list")]
    pub(crate) output: Option<PathBuf>,
    /// List the figure kinds and their parameters, then exit
    #[arg(long)]
    pub(crate) list: bool,
    /// PNG resolution, pixels per inch
    #[arg(long, default_value_t = 96.0)]
    pub(crate) dpi: f64,
    /// PNG width in pixels (overrides --dpi)
    #[arg(long)]
    pub(crate) width_px: Option<u32>,
    #[command(flatten)]
    pub(crate) layout: LayoutArgs,
}

/// The spec text for a kind and `name=value` parameters: `KIND?p=v&p=v`.
fn spec_text(kind: &str, params: &[String]) -> Result<String> {
    let mut spec = kind.to_string();
    for p in params {
        if !p.contains('=') {
            bail!("parameter '{p}' should be name=value");
        }
        spec.push(if spec.contains('?') { '&' } else { '?' });
        spec.push_str(p);
    }
    Ok(spec)
}

/// Run `plotter gen`.
pub(crate) fn run(args: &GenArgs) -> Result<()> {
    if args.list {
        println!("Figure kinds (parameters with defaults; every kind also takes {COMMON_PARAMS}):");
        for (kind, params) in KINDS {
            println!("  {kind:<15} {params}");
        }
        return Ok(());
    }
    let (Some(kind), Some(output)) = (&args.kind, &args.output) else {
        bail!("give a figure kind and -o OUTPUT (or --list)");
    };
    let spec = spec_text(kind, &args.params)?;
    let mut drawing = Spec::parse(&spec)?.to_drawing().with_context(|| format!("cannot generate {spec}"))?;
    args.layout.apply(&mut drawing)?;
    let ext = output.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    let bytes = match ext.as_deref() {
        Some("svg") => to_svg_string(&drawing).into_bytes(),
        Some("png") => {
            let options = PreviewOptions { dpi: args.dpi, width_px: args.width_px, ..Default::default() };
            render_png(&drawing, &options)?
        }
        _ => bail!("output {} should end in .svg or .png", output.display()),
    };
    write_output(output, &bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spec_text_joins_parameters() {
        assert_eq!(spec_text("rose", &[]).unwrap(), "rose");
        assert_eq!(spec_text("rose", &["k=3".into(), "a=20".into()]).unwrap(), "rose?k=3&a=20");
        assert_eq!(spec_text("rose?k=3", &["a=20".into()]).unwrap(), "rose?k=3&a=20");
        assert!(spec_text("rose", &["k".into()]).is_err());
    }

    fn args(kind: &str, params: &[&str], output: PathBuf) -> GenArgs {
        GenArgs {
            kind: Some(kind.to_string()),
            params: params.iter().map(|p| (*p).to_string()).collect(),
            output: Some(output),
            list: false,
            dpi: 96.0,
            width_px: Some(200),
            layout: LayoutArgs::default(),
        }
    }

    #[test]
    fn writes_svg_and_png() {
        let dir = std::env::temp_dir().join(format!("plotter-cmd-gen-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let svg = dir.join("c.svg");
        run(&args("circle", &["r=20", "tol=0.001"], svg.clone())).unwrap();
        // The SVG reads back as one closed path on a page 40 mm wide plus the 5 mm margins.
        let back = plotter_path::input::svg::load_svg(&svg, &plotter_path::input::svg::SvgOptions::default()).unwrap();
        assert_eq!(back.drawing.path_count(), 1);
        assert!(back.drawing.paths().next().unwrap().is_closed());
        let (w, _) = back.drawing.page_mm.unwrap();
        assert!((w - 50.0).abs() < 0.01, "{w}");
        let png = dir.join("m.png");
        run(&args("mickey?harmonics=8", &[], png.clone())).unwrap();
        assert!(std::fs::read(&png).unwrap().starts_with(b"\x89PNG"));
        let e = run(&args("rose", &["k=0"], dir.join("r.svg"))).unwrap_err().to_string();
        assert!(e.contains("rose: parameter k=\"0\""), "{e}");
        let e = run(&args("rose", &[], dir.join("r.pdf"))).unwrap_err().to_string();
        assert!(e.contains("should end in .svg or .png"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
