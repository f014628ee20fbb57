//! The first half of a plot job: a machine profile and any supported input, laid out and ordered, as steps.

use std::path::Path;

use anyhow::Context as _;
use plotter_path::input::trajectory;
use plotter_path::kurbo::Point;
use plotter_path::motion::steps::{StepDrawing, StepMapper, StepPos, drawing_to_steps};
use plotter_path::optimize::{self, OptimizeOptions};
use plotter_path::{Drawing, MachineProfile};

use crate::input::{InputArgs, InputKind, input_kind, load_drawing};
use crate::link::machine::PlotMachine;
use crate::options::layout::LayoutArgs;
use crate::options::optimize::OptimizeArgs;

/// Load the machine profile at `path`, or the built-in XY plotter kit profile.
pub fn load_profile(path: Option<&Path>) -> anyhow::Result<MachineProfile> {
    match path {
        Some(p) => Ok(MachineProfile::load(p)?),
        None => Ok(MachineProfile::default_plotter()),
    }
}

/// Where `machine` reports its pen, page mm (the firmware's status, mapped through the profile).
pub fn pen_on_page(machine: &mut dyn PlotMachine, profile: &MachineProfile) -> anyhow::Result<Point> {
    let at = machine.position().context("cannot read the machine's position")?;
    Ok(StepMapper::new(profile).steps_to_page(StepPos::new(at[0], at[1])))
}

/// Load any supported input as steps (and the millimetre drawing for previews), laid out as the options say,
/// printing warnings. A trajectory file is already in steps and is used exactly as stored unless the layout
/// options ask for a change. The optimizer runs to convergence (no time budget), so that a resumed plot rebuilds
/// exactly the same order. The order starts at `pen_at` (page mm) when given — where a machine that is not homed
/// before the plot reports the pen ([`pen_on_page`]) — else at home (or `--start-at`).
pub fn load_steps(
    input: &Path,
    profile: &MachineProfile,
    input_args: &InputArgs,
    layout: &LayoutArgs,
    optimize: &OptimizeArgs,
    pen_at: Option<Point>,
) -> anyhow::Result<(StepDrawing, Option<Drawing>)> {
    let shown = input.display().to_string();
    if input != Path::new("-") && layout.options()?.is_identity() {
        let head = std::fs::read(input).map(|b| b[..b.len().min(512)].to_vec()).unwrap_or_default();
        if input_kind(input, &head) == InputKind::Trajectory {
            let text = std::fs::read_to_string(input).with_context(|| format!("{shown}: cannot read"))?;
            return Ok((trajectory::import(&text, &shown)?, None));
        }
    }
    let mut drawing = load_drawing(input, input_args, profile)?;
    layout.apply(&mut drawing)?;
    if optimize.enabled() {
        let options = OptimizeOptions { time_budget: None, ..optimize.options_from(Some(profile), pen_at)? };
        let report = optimize::optimize(&mut drawing, &options).with_context(|| format!("cannot optimize {shown}"))?;
        eprintln!(
            "path order: pen-up travel {:.1} mm -> {:.1} mm (lower bound {})",
            report.pen_up_before_mm,
            report.pen_up_after_mm,
            report.pen_up_lower_bound_mm.map_or_else(|| "not computed".to_string(), |b| format!("{b:.1} mm"))
        );
    }
    let steps = drawing_to_steps(profile, &drawing).with_context(|| format!("cannot convert {shown} to steps"))?;
    Ok((steps, Some(drawing)))
}
