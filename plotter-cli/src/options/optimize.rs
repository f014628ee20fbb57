//! Path-optimization options shared by every front end: the flags `plot`, `preview`, `stats` and `optimize`
//! flatten into their own arguments, [`OptimizeArgs::options`] turns them into library options.

use anyhow::{Context, Result, bail};
use clap::{Args, ValueEnum};
use plotter_path::MachineProfile;
use plotter_path::kurbo::Point;
use plotter_path::motion::plan;
use plotter_path::optimize::{self, Objective, OptimizeOptions, OptimizeReport, SeamMode, TravelTimeModel};

/// Where closed paths may start.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum SeamArg {
    /// Keep each closed path's own start vertex
    Keep,
    /// Any vertex
    Any,
    /// Only sharp corners (see --seam-angle); smooth loops may start anywhere
    Corners,
}

/// What the optimizer minimizes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum CostArg {
    /// Pen-up time when a machine profile is known (as `time`), else pen-up distance
    Auto,
    /// Pen-up distance
    Distance,
    /// Pen-up time from the machine profile: each hop's stop-to-stop move at the travel feed and acceleration,
    /// plus the pen lift and drop with their settles
    Time,
}

/// Path-optimization flags shared by `optimize`, `plot`, `preview` and `stats`.
#[derive(Debug, Clone, Args)]
pub struct OptimizeArgs {
    /// Skip path optimization entirely (keep the drawing's order)
    #[arg(long, help_heading = "Optimization")]
    pub no_optimize: bool,
    /// Do not join paths whose ends meet
    #[arg(long, help_heading = "Optimization")]
    pub no_merge: bool,
    /// Join path ends closer than this, mm (gaps become short pen-down bridges; 0 = only exactly touching ends)
    /// [default: half the profile's pen width]
    #[arg(long, help_heading = "Optimization")]
    pub merge_tolerance: Option<f64>,
    /// Keep the pen up over every gap between consecutive paths (by default gaps shorter than the pen width are
    /// drawn through with the pen down)
    #[arg(long, help_heading = "Optimization")]
    pub no_bridge: bool,
    /// End the plot with the pen back home (the order is chosen with that last travel counted)
    #[arg(long, help_heading = "Optimization")]
    pub return_home: bool,
    /// Where the pen starts, page mm `X,Y` [default: the machine's home]
    #[arg(long, value_name = "X,Y", help_heading = "Optimization")]
    pub start_at: Option<String>,
    /// Do not reorder greedily (start the improvement from the drawing's order)
    #[arg(long, help_heading = "Optimization")]
    pub no_reorder: bool,
    /// Never draw a path backwards
    #[arg(long, help_heading = "Optimization")]
    pub no_reverse: bool,
    /// Where closed paths may start
    #[arg(long, value_enum, default_value_t = SeamArg::Any, help_heading = "Optimization")]
    pub seam: SeamArg,
    /// Start each closed path at a vertex picked at random (from --seed), so that long or repeated plots do not
    /// wear one spot of the paper with every pen drop (instead of --seam)
    #[arg(long, help_heading = "Optimization")]
    pub random_start: bool,
    /// Seed of --random-start: the same seed gives the same starts
    #[arg(long, default_value_t = 1, requires = "random_start", help_heading = "Optimization")]
    pub seed: u64,
    /// Minimum turn, degrees, of a vertex to count as a corner for --seam corners
    #[arg(long, default_value_t = 60.0, help_heading = "Optimization")]
    pub seam_angle: f64,
    /// Skip the 2-opt / Or-opt improvement (greedy order only)
    #[arg(long, help_heading = "Optimization")]
    pub no_improve: bool,
    /// Work budget of the improvement: candidate moves evaluated per path (0 = run until no move improves). A
    /// count, not a time: the order depends only on the drawing, the options and the seed, never on the machine
    #[arg(long, default_value_t = optimize::DEFAULT_WORK_PER_PATH, help_heading = "Optimization")]
    pub opt_work: f64,
    /// Seed of the improvement's random choices
    #[arg(long, default_value_t = 1, help_heading = "Optimization")]
    pub opt_seed: u64,
    /// Random kicks per path after the first local optimum (0 = none)
    #[arg(long, default_value_t = 2.0, help_heading = "Optimization")]
    pub opt_kicks: f64,
    /// What to minimize (time needs a machine profile; auto is time when one is known)
    #[arg(long, value_enum, default_value_t = CostArg::Auto, help_heading = "Optimization")]
    pub opt_cost: CostArg,
}

impl OptimizeArgs {
    /// Whether the optimization step runs at all.
    pub fn enabled(&self) -> bool {
        !self.no_optimize
    }

    /// Where the pen starts (page mm): `--start-at`, else the profile's home, else unknown.
    pub fn start(&self, profile: Option<&MachineProfile>) -> Result<Option<Point>> {
        self.start_from(profile, None)
    }

    /// Where the pen starts (page mm): `--start-at`, else `pen_at` (where a machine that is not homed reports
    /// the pen), else the profile's home, else unknown.
    pub fn start_from(&self, profile: Option<&MachineProfile>, pen_at: Option<Point>) -> Result<Option<Point>> {
        if let Some(text) = &self.start_at {
            let parse = |v: &str| v.trim().parse::<f64>().ok().filter(|x| x.is_finite());
            let (Some(x), Some(y)) = text.split_once(',').map_or((None, None), |(a, b)| (parse(a), parse(b))) else {
                bail!("--start-at {text}: expected two numbers X,Y in page millimetres, e.g. 0,0");
            };
            return Ok(Some(Point::new(x, y)));
        }
        if pen_at.is_some() {
            return Ok(pen_at);
        }
        match profile {
            Some(p) => Ok(Some(plan::home_on_page(p)?)),
            None => Ok(None),
        }
    }

    /// Library options from the flags; `profile` (if any) supplies the start (its home), the pen width (merge
    /// tolerance and bridges) and the travel-time model.
    pub fn options(&self, profile: Option<&MachineProfile>) -> Result<OptimizeOptions> {
        self.options_from(profile, None)
    }

    /// [`options`](Self::options) with the order starting at `pen_at` (page mm) instead of home, unless
    /// `--start-at` says otherwise: for a plot on a machine that is not homed first.
    pub fn options_from(&self, profile: Option<&MachineProfile>, pen_at: Option<Point>) -> Result<OptimizeOptions> {
        if !(self.opt_work.is_finite() && self.opt_work >= 0.0) {
            bail!("--opt-work must be a number ≥ 0 (candidate moves per path), got {}", self.opt_work);
        }
        let width = profile.map_or(plotter_path::config::profile::DEFAULT_PEN_WIDTH_MM, |p| p.pen.width_mm);
        let start = self.start_from(profile, pen_at)?;
        if self.return_home && start.is_none() {
            bail!("--return-home needs to know where home is: give --profile or --start-at");
        }
        let time_model = profile.map(TravelTimeModel::from_profile);
        let objective = match (self.opt_cost, time_model) {
            (CostArg::Time, None) => bail!("--opt-cost time needs a machine profile (--profile FILE)"),
            (CostArg::Time | CostArg::Auto, Some(_)) => Objective::Time,
            (CostArg::Distance, _) | (CostArg::Auto, None) => Objective::Distance,
        };
        Ok(OptimizeOptions {
            merge: !self.no_merge,
            merge_tolerance_mm: self.merge_tolerance.unwrap_or(width / 2.0),
            bridge_mm: if self.no_bridge { 0.0 } else { width },
            start,
            return_home: self.return_home,
            reorder: !self.no_reorder,
            reverse: !self.no_reverse,
            seam: match self.seam {
                _ if self.random_start => SeamMode::Random { seed: self.seed },
                SeamArg::Keep => SeamMode::Keep,
                SeamArg::Any => SeamMode::Any,
                SeamArg::Corners => SeamMode::Corners { min_turn_deg: self.seam_angle },
            },
            improve: !self.no_improve,
            work_per_path: (self.opt_work > 0.0).then_some(self.opt_work),
            seed: self.opt_seed,
            kicks_per_path: self.opt_kicks,
            objective,
            time_model,
            ..OptimizeOptions::default()
        })
    }
}

/// Optimise `drawing` in place when the flags allow (returns the report), with the flags' work budget.
pub fn optimize_quietly(
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
