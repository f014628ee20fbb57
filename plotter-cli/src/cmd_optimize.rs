//! `plotter optimize`: reorder, reverse, merge and re-seam paths to cut pen-up travel, then write plain SVG.
//!
//! [`OptimizeArgs`] holds the optimization flags so `plot`, `preview` and `stats` can flatten the same set into
//! their own arguments; [`OptimizeArgs::options`] turns them into library options and [`report_text`] formats
//! the outcome.

use std::path::PathBuf;
use std::time::Duration;

use anyhow::{Context, Result, bail};
use clap::{Args, ValueEnum};
use plotter_path::MachineProfile;
use plotter_path::kurbo::Point;
use plotter_path::motion::plan;
use plotter_path::optimize::{self, Objective, OptimizeOptions, OptimizeReport, SeamMode, TravelTimeModel};
use plotter_path::output::svg_out::to_svg_string;

use crate::input::{Source, write_output};

/// Where closed paths may start.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(crate) enum SeamArg {
    /// Keep each closed path's own start vertex
    Keep,
    /// Any vertex
    Any,
    /// Only sharp corners (see --seam-angle); smooth loops may start anywhere
    Corners,
}

/// What the optimizer minimizes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(crate) enum CostArg {
    /// Pen-up distance
    Distance,
    /// Pen-up time from the machine profile (acceleration-limited moves plus pen lift/drop)
    Time,
}

/// Path-optimization flags shared by `optimize`, `plot`, `preview` and `stats`.
#[derive(Debug, Clone, Args)]
pub(crate) struct OptimizeArgs {
    /// Skip path optimization entirely (keep the drawing's order)
    #[arg(long, help_heading = "Optimization")]
    pub(crate) no_optimize: bool,
    /// Do not join paths whose ends meet
    #[arg(long, help_heading = "Optimization")]
    pub(crate) no_merge: bool,
    /// Join path ends closer than this, mm (gaps become short pen-down bridges; 0 = only exactly touching ends)
    /// [default: half the profile's pen width]
    #[arg(long, help_heading = "Optimization")]
    pub(crate) merge_tolerance: Option<f64>,
    /// Keep the pen up over every gap between consecutive paths (by default gaps shorter than the pen width are
    /// drawn through with the pen down)
    #[arg(long, help_heading = "Optimization")]
    pub(crate) no_bridge: bool,
    /// End the plot with the pen back home (the order is chosen with that last travel counted)
    #[arg(long, help_heading = "Optimization")]
    pub(crate) return_home: bool,
    /// Where the pen starts, page mm `X,Y` [default: the machine's home]
    #[arg(long, value_name = "X,Y", help_heading = "Optimization")]
    pub(crate) start_at: Option<String>,
    /// Do not reorder greedily (start the improvement from the drawing's order)
    #[arg(long, help_heading = "Optimization")]
    pub(crate) no_reorder: bool,
    /// Never draw a path backwards
    #[arg(long, help_heading = "Optimization")]
    pub(crate) no_reverse: bool,
    /// Where closed paths may start
    #[arg(long, value_enum, default_value_t = SeamArg::Any, help_heading = "Optimization")]
    pub(crate) seam: SeamArg,
    /// Minimum turn, degrees, of a vertex to count as a corner for --seam corners
    #[arg(long, default_value_t = 60.0, help_heading = "Optimization")]
    pub(crate) seam_angle: f64,
    /// Skip the 2-opt / Or-opt improvement (greedy order only)
    #[arg(long, help_heading = "Optimization")]
    pub(crate) no_improve: bool,
    /// Time budget of the improvement, seconds (0 = run until no move improves; the result then depends only on
    /// the seed)
    #[arg(long, default_value_t = 1.5, help_heading = "Optimization")]
    pub(crate) opt_budget: f64,
    /// Seed of the improvement's random choices
    #[arg(long, default_value_t = 1, help_heading = "Optimization")]
    pub(crate) opt_seed: u64,
    /// Random kicks per path after the first local optimum (0 = none)
    #[arg(long, default_value_t = 2.0, help_heading = "Optimization")]
    pub(crate) opt_kicks: f64,
    /// What to minimize (time needs a machine profile)
    #[arg(long, value_enum, default_value_t = CostArg::Distance, help_heading = "Optimization")]
    pub(crate) opt_cost: CostArg,
}

impl OptimizeArgs {
    /// Whether the optimization step runs at all.
    pub(crate) fn enabled(&self) -> bool {
        !self.no_optimize
    }

    /// Where the pen starts (page mm): `--start-at`, else the profile's home, else unknown.
    pub(crate) fn start(&self, profile: Option<&MachineProfile>) -> Result<Option<Point>> {
        if let Some(text) = &self.start_at {
            let parse = |v: &str| v.trim().parse::<f64>().ok().filter(|x| x.is_finite());
            let (Some(x), Some(y)) = text.split_once(',').map_or((None, None), |(a, b)| (parse(a), parse(b))) else {
                bail!("--start-at {text}: expected two numbers X,Y in page millimetres, e.g. 0,0");
            };
            return Ok(Some(Point::new(x, y)));
        }
        match profile {
            Some(p) => Ok(Some(plan::home_on_page(p)?)),
            None => Ok(None),
        }
    }

    /// Library options from the flags; `profile` (if any) supplies the start (its home), the pen width (merge
    /// tolerance and bridges) and the travel-time model.
    pub(crate) fn options(&self, profile: Option<&MachineProfile>) -> Result<OptimizeOptions> {
        if !(self.opt_budget.is_finite() && self.opt_budget >= 0.0) {
            bail!("--opt-budget must be a number of seconds ≥ 0, got {}", self.opt_budget);
        }
        let width = profile.map_or(plotter_path::motion::profile::DEFAULT_PEN_WIDTH_MM, |p| p.pen.width_mm);
        let start = self.start(profile)?;
        if self.return_home && start.is_none() {
            bail!("--return-home needs to know where home is: give --profile or --start-at");
        }
        let time_model = profile.map(TravelTimeModel::from_profile);
        if self.opt_cost == CostArg::Time && time_model.is_none() {
            bail!("--opt-cost time needs a machine profile (--profile FILE)");
        }
        Ok(OptimizeOptions {
            merge: !self.no_merge,
            merge_tolerance_mm: self.merge_tolerance.unwrap_or(width / 2.0),
            bridge_mm: if self.no_bridge { 0.0 } else { width },
            start,
            return_home: self.return_home,
            reorder: !self.no_reorder,
            reverse: !self.no_reverse,
            seam: match self.seam {
                SeamArg::Keep => SeamMode::Keep,
                SeamArg::Any => SeamMode::Any,
                SeamArg::Corners => SeamMode::Corners { min_turn_deg: self.seam_angle },
            },
            improve: !self.no_improve,
            time_budget: (self.opt_budget > 0.0).then(|| Duration::from_secs_f64(self.opt_budget)),
            seed: self.opt_seed,
            kicks_per_path: self.opt_kicks,
            objective: match self.opt_cost {
                CostArg::Distance => Objective::Distance,
                CostArg::Time => Objective::Time,
            },
            time_model,
            ..OptimizeOptions::default()
        })
    }
}

/// Optimise `drawing` in place when the flags allow (returns the report), with the flags' time budget.
pub(crate) fn optimize_quietly(
    drawing: &mut plotter_path::Drawing,
    args: &OptimizeArgs,
    profile: Option<&MachineProfile>,
) -> Result<Option<OptimizeReport>> {
    if !args.enabled() {
        return Ok(None);
    }
    let report = optimize::optimize(drawing, &args.options(profile)?).context("cannot optimize the path order")?;
    Ok(Some(report))
}

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
    if r.pen_up_before_mm > 0.0 {
        s += &format!(" ({:.1} %)", 100.0 * r.pen_up_after_mm / r.pen_up_before_mm);
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
        "moves         2-opt {}, or-opt {}, seam {}, kicks kept {}/{}{}\n",
        i.two_opt_moves,
        i.or_opt_moves,
        i.seam_moves,
        i.kicks_kept,
        i.kicks_tried,
        if i.budget_exhausted { " (time budget reached)" } else { "" }
    );
    s += &format!("time          {:.3} s", r.elapsed.as_secs_f64());
    s
}

/// Optimize a drawing's path order and write it as plain SVG.
#[derive(Debug, Args)]
pub(crate) struct OptimizeCmdArgs {
    #[command(flatten)]
    pub(crate) source: Source,
    /// Output SVG (`-` writes stdout)
    #[arg(short, long)]
    pub(crate) output: PathBuf,
    /// Machine profile (TOML) for pen-up time figures and --opt-cost time
    #[arg(long)]
    pub(crate) profile: Option<PathBuf>,
    #[command(flatten)]
    pub(crate) optimize: OptimizeArgs,
}

/// Run `plotter optimize`; the report goes to stderr.
pub(crate) fn run(args: &OptimizeCmdArgs) -> Result<()> {
    let profile = match args.profile.as_deref() {
        Some(p) => MachineProfile::load(p)?,
        None => MachineProfile::default_plotter(),
    };
    let mut drawing = args.source.load(&profile)?;
    if let Some(report) = optimize_quietly(&mut drawing, &args.optimize, Some(&profile))? {
        eprintln!("{}", report_text(&report));
    }
    write_output(&args.output, to_svg_string(&drawing).as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

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
        assert_eq!(o.start, Some(Point::new(0.0, 0.0)));
        assert!(o.return_home);
        let o = parse(&["--start-at", "10,20.5", "--no-bridge", "--merge-tolerance", "0.05"]).options(None).unwrap();
        assert_eq!((o.start, o.bridge_mm, o.merge_tolerance_mm), (Some(Point::new(10.0, 20.5)), 0.0, 0.05));
        assert!(parse(&["--start-at", "10"]).options(None).unwrap_err().to_string().contains("X,Y"));
        assert!(parse(&["--return-home"]).options(None).is_err());
        let o = parse(&[
            "--no-merge",
            "--no-reverse",
            "--seam",
            "corners",
            "--seam-angle",
            "90",
            "--opt-budget",
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
        assert_eq!((o.time_budget, o.seed, o.objective), (None, 7, Objective::Time));
        assert!(o.time_model.is_some());
        let err = parse(&["--opt-cost", "time"]).options(None).unwrap_err().to_string();
        assert!(err.contains("profile"), "{err}");
        assert!(parse(&["--opt-budget=-1"]).options(None).is_err());
        assert!(!parse(&["--no-optimize"]).enabled());
    }

    #[test]
    fn report_text_names_the_figures() {
        let mut d = plotter_path::optimize::synth::maze(1);
        let r =
            optimize::optimize(&mut d, &OptimizeOptions { time_budget: None, ..OptimizeOptions::default() }).unwrap();
        let t = report_text(&r);
        for key in ["pen up", "greedy", "lower bound", "moves", "2-opt"] {
            assert!(t.contains(key), "{key} missing in {t}");
        }
    }
}
