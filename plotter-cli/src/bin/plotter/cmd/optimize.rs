//! `plotter optimize`: reorder, reverse, merge and re-seam paths to cut pen-up travel, then write plain SVG (or, for
//! an output named .png, the preview's image; .svgz gzipped).
//!
//! [`report_text`] formats the outcome of an optimization for the terminal.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use plotter_host::options::machine::MachineArgs;
use plotter_host::options::optimize::{OptimizeArgs, optimize_quietly};
use plotter_path::MachineProfile;
use plotter_path::optimize::OptimizeReport;
use plotter_path::output::stats::fixed;

use plotter_host::input::Source;

/// Human-readable summary of an optimization: pen-up before / greedy / after, the bound and the gap, times.
pub(crate) fn report_text(r: &OptimizeReport) -> String {
    let paths_in: usize = r.layers.iter().map(|l| l.paths_in).sum();
    let paths_out: usize = r.layers.iter().map(|l| l.paths_out).sum();
    let mut s = format!("paths         {paths_in} -> {paths_out}");
    if r.bridges > 0 {
        s += &format!(" -> {} ({} gaps drawn through with the pen down)", r.paths_out, r.bridges);
    }
    s += "\n";
    s += &format!("pen up        {:.2} mm -> {:.2} mm", r.pen_up_before_mm, r.pen_up_after_mm);
    // What ordering saved, said as such: `saves 62.5 %` (of the distance before), not the share that is left.
    if r.pen_up_before_mm > 0.0 {
        let saved = 100.0 * (1.0 - r.pen_up_after_mm / r.pen_up_before_mm);
        let verb = if fixed(saved, 1).starts_with('-') { "adds" } else { "saves" };
        s += &format!(" ({verb} {} %)", fixed(saved.abs(), 1));
    }
    s += "\n";
    if let Some(g) = r.pen_up_greedy_mm {
        s += &format!("greedy        {g:.2} mm\n");
    }
    if let Some(lb) = r.pen_up_lower_bound_mm {
        s += &format!("lower bound   {lb:.2} mm");
        if let Some(gap) = r.gap() {
            s += &format!(" (result at most {:.1} % above optimal)", 100.0 * (gap - 1.0));
        }
        s += "\n";
    }
    if let (Some(b), Some(a)) = (r.travel_time_before_s, r.travel_time_after_s) {
        s += &format!("pen-up time   {b:.1} s -> {a:.1} s\n");
    }
    let i = &r.improve;
    s += &format!(
        "moves         2-opt {}, or-opt {}, seam {}, kicks kept {}/{}, {} candidates evaluated{}\n",
        i.two_opt_moves,
        i.or_opt_moves,
        i.seam_moves,
        i.kicks_kept,
        i.kicks_tried,
        i.work,
        if i.budget_exhausted { " (work budget reached)" } else { "" }
    );
    s += &format!("time          {:.3} s", r.elapsed.as_secs_f64());
    s
}

/// Optimize a drawing's path order and write it as plain SVG (or a PNG image).
#[derive(Debug, Args)]
pub(crate) struct OptimizeCmdArgs {
    #[command(flatten)]
    pub(crate) source: Source,
    /// Output file: .svg (or .svgz, gzipped) for plain SVG polylines in mm, .png for a preview image; `-`
    /// writes SVG to stdout
    #[arg(short, long)]
    pub(crate) output: PathBuf,
    /// The machine for pen-up time figures and --opt-cost time.
    #[command(flatten)]
    pub(crate) machine: MachineArgs,
    #[command(flatten)]
    pub(crate) optimize: OptimizeArgs,
}

/// Run `plotter optimize`; the report goes to stderr.
pub(crate) fn run(args: &OptimizeCmdArgs) -> Result<()> {
    let format = crate::cmd::preview::Written::of(&args.output, "optimize", crate::cmd::preview::Written::Svg)?;
    // The machine (the given profile, else the built-in one) says where the pen starts and how wide it draws.
    let profile = Some(args.machine.load()?);
    let mut drawing = args.source.load(profile.as_ref().unwrap_or(&MachineProfile::default_plotter()))?;
    if let Some(report) = optimize_quietly(&mut drawing, &args.optimize, profile.as_ref())? {
        eprintln!("{}", report_text(&report));
    }
    crate::cmd::preview::write_drawing(&drawing, &args.output, format)
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;
    use plotter_path::optimize::{self, Objective, OptimizeOptions, SeamMode};

    #[derive(Parser)]
    struct Wrap {
        #[command(flatten)]
        opt: OptimizeArgs,
    }

    fn parse(args: &[&str]) -> OptimizeArgs {
        Wrap::try_parse_from(std::iter::once("t").chain(args.iter().copied())).unwrap().opt
    }

    #[test]
    fn flags_map_to_options() {
        let o = parse(&[]).options(None).unwrap();
        // Without a machine: default pen width (merge within half of it, bridge gaps below it), no known start.
        assert_eq!(o, OptimizeOptions { merge_tolerance_mm: 0.15, bridge_mm: 0.3, ..OptimizeOptions::default() });
        let p = MachineProfile::default_plotter();
        let o = parse(&["--return-home"]).options(Some(&p)).unwrap();
        assert_eq!(o.start, Some(plotter_path::kurbo::Point::new(0.0, 0.0)));
        assert!(o.return_home);
        let o = parse(&["--start-at", "10,20.5", "--no-bridge", "--merge-tolerance", "0.05"]).options(None).unwrap();
        let at = Some(plotter_path::kurbo::Point::new(10.0, 20.5));
        assert_eq!((o.start, o.bridge_mm, o.merge_tolerance_mm), (at, 0.0, 0.05));
        assert!(parse(&["--start-at", "10"]).options(None).unwrap_err().to_string().contains("X,Y"));
        assert!(parse(&["--return-home"]).options(None).is_err());
        let o = parse(&[
            "--no-merge",
            "--no-reverse",
            "--seam",
            "corners",
            "--seam-angle",
            "90",
            "--opt-work",
            "0",
            "--opt-seed",
            "7",
            "--opt-cost",
            "time",
        ])
        .options(Some(&MachineProfile::default_plotter()))
        .unwrap();
        assert!(!o.merge && !o.reverse && o.reorder && o.improve);
        assert_eq!(o.seam, SeamMode::Corners { min_turn_deg: 90.0 });
        assert_eq!((o.work_per_path, o.seed, o.objective), (None, 7, Objective::Time));
        assert!(o.time_model.is_some());
        let err = parse(&["--opt-cost", "time"]).options(None).unwrap_err().to_string();
        assert!(err.contains("profile"), "{err}");
        // auto: time with a machine profile, distance without; distance on request.
        assert_eq!(parse(&[]).options(Some(&p)).unwrap().objective, Objective::Time);
        assert_eq!(parse(&[]).options(None).unwrap().objective, Objective::Distance);
        assert_eq!(parse(&["--opt-cost", "distance"]).options(Some(&p)).unwrap().objective, Objective::Distance);
        assert!(parse(&["--opt-work=-1"]).options(None).is_err());
        assert!(!parse(&["--no-optimize"]).enabled());
    }

    #[test]
    fn report_text_names_the_figures() {
        let mut d = plotter_path::optimize::synth::maze(1);
        let r =
            optimize::optimize(&mut d, &OptimizeOptions { work_per_path: None, ..OptimizeOptions::default() }).unwrap();
        let t = report_text(&r);
        for key in ["pen up", "greedy", "lower bound", "moves", "2-opt"] {
            assert!(t.contains(key), "{key} missing in {t}");
        }
        // The percentage says what it is: the share of the pen-up distance that ordering saved.
        let saved = 100.0 * (1.0 - r.pen_up_after_mm / r.pen_up_before_mm);
        assert!(saved > 0.0, "{t}");
        let line =
            format!("pen up        {:.2} mm -> {:.2} mm (saves {saved:.1} %)", r.pen_up_before_mm, r.pen_up_after_mm);
        assert!(t.contains(&line), "{line} missing in {t}");
    }
}
