//! `plotter trace`: turn a PNG/JPEG into plottable paths (outline, centerline, edges or hatch) and write them as a
//! plain SVG in mm.
//! The tracing flags themselves are [`TraceArgs`], shared with every command that loads images.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use clap::builder::PossibleValuesParser;
use plotter_host::options::machine::MachineArgs;
use plotter_host::options::trace::{ColorsArg, PENS_FROM_FLAGS, TraceArgs, trace_image};
use plotter_path::config::models;
use plotter_path::config::profile::PenSpec;
use plotter_path::output::svg_out::to_svg_string;

use plotter_host::input::write_output;
use plotter_host::options::layout::LayoutArgs;

/// Trace a raster image into paths and write them as a plain SVG.
#[derive(Debug, Args)]
pub(crate) struct TraceCmdArgs {
    /// Input image (PNG or JPEG)
    pub(crate) input: PathBuf,
    /// Output SVG (`-` writes stdout)
    #[arg(short, long)]
    pub(crate) output: PathBuf,
    #[command(flatten)]
    pub(crate) trace: TraceArgs,
    #[command(flatten)]
    pub(crate) layout: LayoutArgs,
    /// Built-in machine model whose pens (their colours from its pen table) --colors pens separates the picture
    /// into [default: xy-kit]
    #[arg(long, help_heading = "Image tracing", value_parser = PossibleValuesParser::new(models::names()))]
    pub(crate) model: Option<String>,
    /// Machine profile (TOML) whose pen table --colors pens separates the picture into; with --model, its keys
    /// replace the model's
    #[arg(long, help_heading = "Image tracing")]
    pub(crate) profile: Option<PathBuf>,
}

/// The pens `--colors pens` separates into: the pen table of `--model`/`--profile`, else the built-in default
/// machine's; refused by name when none of them has a colour.
fn separation_pens(args: &TraceCmdArgs) -> Result<Vec<PenSpec>> {
    if args.trace.colors != ColorsArg::Pens {
        return Ok(Vec::new());
    }
    let machine = MachineArgs { model: args.model.clone(), profile: args.profile.clone(), ..MachineArgs::default() };
    let profile = machine.load()?;
    args.trace.options_for_profile(&profile.name, &profile.pens, PENS_FROM_FLAGS)?;
    Ok(profile.pens)
}

/// Run `plotter trace`.
pub(crate) fn run(args: &TraceCmdArgs) -> Result<()> {
    let pens = separation_pens(args)?;
    let traced = trace_image(&args.input, &args.trace, &pens)?;
    let mut drawing = traced.drawing;
    let (paths, length) = (drawing.path_count(), drawing.paths().map(|p| p.length()).sum::<f64>());
    args.layout.apply(&mut drawing)?;
    write_output(&args.output, to_svg_string(&drawing).as_bytes())?;
    eprintln!(
        "traced {} ({}×{} px at {:.3} mm/px, {}): {paths} paths, {length:.0} mm pen-down",
        args.input.display(),
        traced.size_px.0,
        traced.size_px.1,
        traced.pixel_mm,
        args.trace.options().mode
    );
    if !pens.is_empty() {
        let names: Vec<&str> = pens.iter().filter(|p| p.color.is_some()).map(|p| p.name.as_str()).collect();
        eprintln!("separated into the pens {} (--model or --profile chooses others)", names.join(", "));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;
    use clap::ValueEnum;
    use plotter_host::options::trace::ModeArg;
    use plotter_path::input::raster::{HatchOptions, HatchScheme, Mode, Threshold};
    use std::path::Path;

    #[derive(Parser)]
    struct Wrap {
        #[command(flatten)]
        cmd: TraceCmdArgs,
    }

    fn sample(name: &str) -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../samples").join(name)
    }

    #[test]
    fn flags_map_to_options() {
        let w = Wrap::try_parse_from([
            "trace",
            "in.png",
            "-o",
            "out.svg",
            "--mode",
            "hatch",
            "--width",
            "120",
            "--threshold",
            "100",
            "--invert",
            "--levels",
            "3",
            "--spacing",
            "0.8",
            "--angle",
            "-30",
            "--hatch-scheme",
            "density",
            "--paper",
            "a4",
        ])
        .unwrap();
        let o = w.cmd.trace.options();
        assert_eq!(o.mode, Mode::Hatch);
        assert_eq!(o.width_mm, Some(120.0));
        assert_eq!(o.threshold, Threshold::Fixed(100));
        assert!(o.invert);
        assert_eq!(
            o.hatch,
            HatchOptions { levels: 3, spacing_mm: 0.8, angle_deg: -30.0, scheme: HatchScheme::Density }
        );
        assert_eq!(w.cmd.layout.paper.as_deref(), Some("a4"));
        assert!(Wrap::try_parse_from(["trace", "in.png", "-o", "x.svg", "--threshold", "dark"]).is_err());
        let e =
            Wrap::try_parse_from(["trace", "in.png", "-o", "x.svg", "--mode", "scribble"]).err().unwrap().to_string();
        for mode in ModeArg::value_variants() {
            let name = mode.to_possible_value().unwrap().get_name().to_owned();
            assert!(e.contains("scribble") && e.contains(&name), "{name} missing from: {e}");
        }
    }

    #[test]
    fn traces_the_line_art_sample_to_svg() {
        let out = std::env::temp_dir().join(format!("plotter-trace-test-{}.svg", std::process::id()));
        let w = Wrap::try_parse_from([
            "trace",
            sample("line-art.png").to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--mode",
            "centerline",
            "--width",
            "160",
        ])
        .unwrap();
        run(&w.cmd).unwrap();
        let svg = std::fs::read_to_string(&out).unwrap();
        std::fs::remove_file(&out).ok();
        assert!(
            svg.contains("<svg") && svg.matches("<polyline").count() + svg.matches("<polygon").count() >= 20,
            "{svg}"
        );
    }

    #[test]
    fn every_listed_mode_traces_a_small_picture() {
        // The photo sample (a sphere and a box on a wall), traced 40 mm wide at 0.5 mm pixels: 80 x 60 px.
        let dir = std::env::temp_dir().join(format!("plotter-trace-modes-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let input = sample("photo.png");
        let mut traced = Vec::new();
        for mode in ModeArg::value_variants() {
            let name = mode.to_possible_value().unwrap().get_name().to_owned();
            let out = dir.join(format!("{name}.svg"));
            let w = Wrap::try_parse_from([
                "trace",
                input.to_str().unwrap(),
                "-o",
                out.to_str().unwrap(),
                "--mode",
                &name,
                "--width",
                "40",
                "--pitch",
                "0.5",
            ])
            .unwrap();
            run(&w.cmd).unwrap_or_else(|e| panic!("--mode {name}: {e}"));
            let svg = std::fs::read_to_string(&out).unwrap();
            assert!(svg.contains("<polyline") || svg.contains("<polygon") || svg.contains("<path"), "{name}: {svg}");
            traced.push(name);
        }
        std::fs::remove_dir_all(&dir).ok();
        assert_eq!(traced.len(), ModeArg::value_variants().len());
        for name in ["flow", "sketch", "stipple", "squiggle", "spiral", "mosaic"] {
            assert!(traced.iter().any(|t| t == name), "{name} is not offered: {traced:?}");
        }
    }

    /// `--colors pens` with no machine given separates into the built-in default machine's coloured pens (the
    /// xy-kit's black, red and blue), one layer each named after its pen; a profile without coloured pens is refused
    /// naming --model and --profile. (It was refused, pointing at preview and plot, whatever the machine.)
    #[test]
    fn colors_pens_takes_the_default_machines_pens_or_the_one_given() {
        let out = std::env::temp_dir().join(format!("plotter-trace-pens-{}.svg", std::process::id()));
        let input = sample("photo.png");
        let flags = ["trace", input.to_str().unwrap(), "-o", out.to_str().unwrap(), "--mode", "mosaic"];
        let w = Wrap::try_parse_from(flags.iter().chain(&["--colors", "pens", "--width", "40"])).unwrap();
        run(&w.cmd).unwrap();
        let svg = std::fs::read_to_string(&out).unwrap();
        std::fs::remove_file(&out).ok();
        let layers: Vec<&str> = svg.split("inkscape:label=\"").skip(1).filter_map(|s| s.split('"').next()).collect();
        assert!(!layers.is_empty(), "{svg}");
        let pens = ["black fineliner 0.3", "red fineliner 0.5", "blue brush pen"];
        assert!(layers.iter().all(|l| pens.contains(l)), "{layers:?}");
        // A profile whose pens have no colour.
        let toml = std::env::temp_dir().join(format!("plotter-trace-pens-{}.toml", std::process::id()));
        let text = std::fs::read_to_string(sample("xy-plotter.toml")).unwrap();
        std::fs::write(&toml, text.lines().filter(|l| !l.starts_with("color =")).collect::<Vec<_>>().join("\n"))
            .unwrap();
        let w = Wrap::try_parse_from(flags.iter().chain(&["--colors", "pens", "--profile", toml.to_str().unwrap()]))
            .unwrap();
        let e = format!("{:#}", run(&w.cmd).unwrap_err());
        std::fs::remove_file(&toml).ok();
        assert!(e.contains("--colors pens") && e.contains("--model") && e.contains("--profile"), "{e}");
    }

    #[test]
    fn non_image_input_is_a_clear_error() {
        let w = Wrap::try_parse_from(["trace", sample("xy-plotter.toml").to_str().unwrap(), "-o", "-"]).unwrap();
        let e = run(&w.cmd).unwrap_err().to_string();
        assert!(e.contains("xy-plotter.toml") && e.contains("not a PNG or JPEG"), "{e}");
    }
}
