//! The first half of a plot job: a machine profile and any supported input, laid out and ordered, as steps.

use std::path::Path;

use anyhow::Context as _;
use plotter_path::geometry::bed::Bed;
use plotter_path::geometry::steps::{StepDrawing, StepMapper, StepPos, drawing_to_steps};
use plotter_path::input::trajectory;
use plotter_path::kurbo::Point;
use plotter_path::motion::plan::{self, MachinePos};
use plotter_path::optimize::{self, OptimizeOptions};
use plotter_path::{Drawing, MachineProfile};

use crate::error::BadInput;
pub use crate::input::load_profile;
use crate::input::{InputArgs, InputKind, input_kind, load_laid_out};
use crate::link::machine::PlotMachine;
use crate::options::layout::LayoutArgs;
use crate::options::optimize::OptimizeArgs;

/// Where `machine` reports its pen, page mm (the firmware's status, mapped through the profile).
pub fn pen_on_page(machine: &mut dyn PlotMachine, profile: &MachineProfile) -> anyhow::Result<Point> {
    let at = super::position_within_travel(machine, profile).context("cannot use the machine's position")?;
    Ok(page_of(profile, at))
}

/// The page point (mm) of a machine position in steps (its X and Y).
pub fn page_of(profile: &MachineProfile, at: MachinePos) -> Point {
    StepMapper::new(profile).steps_to_page(StepPos::new(at[0], at[1]))
}

/// A drawing loaded and laid out on the machine's page, not yet ordered ([`load_page`]).
#[derive(Debug, Clone)]
pub enum Page {
    /// A trajectory file used exactly as stored (no layout flags): already in steps.
    Steps(StepDrawing),
    /// Any other input, laid out, in page millimetres.
    Drawing(Drawing),
}

/// Load any supported input and lay it out for the machine (`layout.bed` when the command set one, e.g. an HP-GL
/// plotter's sheets; else the profile's work area) as the options say, printing warnings and the layout's note (a paper turned to lie on the machine). The page meets
/// the machine here, before anything is ordered, connected or moved: a drawing laid out beyond what the pen
/// reaches is an error naming the fix. A trajectory file is already in steps and is used exactly as stored unless
/// the layout options ask for a change (checked against the work area as stored).
pub fn load_page(
    input: &Path,
    profile: &MachineProfile,
    input_args: &InputArgs,
    layout: &LayoutArgs,
) -> crate::Result<Page> {
    let bed = layout.bed.clone().unwrap_or_else(|| Bed::work_area(profile));
    let shown = input.display().to_string();
    let bad = |e: anyhow::Error| crate::Error::from(BadInput::new(input, e));
    if input != Path::new("-") && layout.options()?.is_identity() {
        let head = std::fs::read(input).map(|b| b[..b.len().min(512)].to_vec()).unwrap_or_default();
        if input_kind(input, &head) == InputKind::Trajectory {
            let text = std::fs::read_to_string(input).with_context(|| format!("{shown}: cannot read")).map_err(bad)?;
            let steps = trajectory::import(&text, &shown).map_err(|e| bad(e.into()))?;
            if matches!(bed, Bed::WorkArea { .. })
                && let Err(e) = plan::check_work_area(profile, &steps)
            {
                return Err(bad(anyhow::anyhow!("{e}; lay it out within it with --fit and a --paper")));
            }
            return Ok(Page::Steps(steps));
        }
    }
    let (layout, note) = layout.on_bed(bed).map_err(bad)?;
    if let Some(note) = note {
        eprintln!("{note}");
    }
    Ok(Page::Drawing(load_laid_out(input, input_args, profile, &layout).map_err(bad)?.drawing))
}

/// Order a loaded page's paths and convert them to steps (and keep the millimetre drawing for previews). The
/// optimizer runs to convergence (no time budget), so that a resumed plot rebuilds exactly the same order. The
/// order starts at `pen_at` (page mm) when given — where a machine that is not homed before the plot reports the
/// pen ([`pen_on_page`]) — else at home (or `--start-at`).
pub fn order_steps(
    page: Page,
    input: &Path,
    profile: &MachineProfile,
    optimize: &OptimizeArgs,
    pen_at: Option<Point>,
) -> crate::Result<(StepDrawing, Option<Drawing>)> {
    let mut drawing = match page {
        Page::Steps(steps) => return Ok((steps, None)),
        Page::Drawing(d) => d,
    };
    let shown = input.display().to_string();
    let bad = |e: anyhow::Error| crate::Error::from(BadInput::new(input, e));
    if optimize.enabled() {
        let options = OptimizeOptions { work_per_path: None, ..optimize.options_from(Some(profile), pen_at)? };
        let report = optimize::optimize(&mut drawing, &options).with_context(|| format!("cannot optimize {shown}"))?;
        eprintln!(
            "path order: pen-up travel {:.1} mm -> {:.1} mm (lower bound {})",
            report.pen_up_before_mm,
            report.pen_up_after_mm,
            report.pen_up_lower_bound_mm.map_or_else(|| "not computed".to_string(), |b| format!("{b:.1} mm"))
        );
    }
    let steps =
        drawing_to_steps(profile, &drawing).with_context(|| format!("cannot convert {shown} to steps")).map_err(bad)?;
    Ok((steps, Some(drawing)))
}

/// [`load_page`] then [`order_steps`]: any supported input as steps, laid out for the machine and ordered.
pub fn load_steps(
    input: &Path,
    profile: &MachineProfile,
    input_args: &InputArgs,
    layout: &LayoutArgs,
    optimize: &OptimizeArgs,
    pen_at: Option<Point>,
) -> crate::Result<(StepDrawing, Option<Drawing>)> {
    order_steps(load_page(input, profile, input_args, layout)?, input, profile, optimize, pen_at)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::session::Session;
    use crate::link::sim::SimTransport;
    use clap::Parser;
    use plotter_path::motion::plan;
    use plotter_path::optimize::{CostModel, drawing_travel};
    use std::time::Duration;

    #[derive(Parser)]
    struct Wrap {
        #[command(flatten)]
        input: InputArgs,
        #[command(flatten)]
        layout: LayoutArgs,
        #[command(flatten)]
        optimize: OptimizeArgs,
    }

    /// Worst chord error (mm) of the circle of `radius` about `center` drawn by `drawing`: the largest
    /// r − (distance of a chord's midpoint from the centre).
    fn worst_chord_error(drawing: &Drawing, center: Point, radius: f64) -> (usize, f64) {
        let points: Vec<Point> = drawing.paths().flat_map(|p| p.points.iter().copied()).collect();
        let mut worst: f64 = 0.0;
        for pair in points.windows(2) {
            // SVG's circle is four cubic Béziers, off the true circle by up to 0.027 % of r.
            assert!((pair[0].distance(center) - radius).abs() < 3e-4 * radius, "{:?} off the circle", pair[0]);
            worst = worst.max(radius - pair[0].midpoint(pair[1]).distance(center));
        }
        (points.len(), worst)
    }

    /// A 2 mm circle fitted onto A4 with 10 mm margins is magnified 95× (the 190 × 277 mm area over its 2 × 2 mm
    /// box: min(190/2, 277/2) = 95) to a 95 mm radius about the page's centre (105, 148.5). Flattened at the
    /// default 0.05 mm before the layout, its chords would miss the circle by up to ~95 · 0.05 = 4.75 mm; decoded
    /// again at 0.05/95 mm it is drawn as finely as the same circle drawn 95 mm large in the first place.
    #[test]
    fn a_magnifying_layout_flattens_curves_at_the_page_tolerance() {
        let dir = std::env::temp_dir().join(format!("plotter-load-fit-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let svg = |name: &str, size: f64, r: f64| {
            let path = dir.join(name);
            let c = size / 2.0;
            std::fs::write(
                &path,
                format!(
                    r#"<svg xmlns="http://www.w3.org/2000/svg" width="{size}mm" height="{size}mm" viewBox="0 0 {size} {size}">
<circle cx="{c}" cy="{c}" r="{r}" fill="none" stroke="black"/></svg>"#
                ),
            )
            .unwrap();
            path
        };
        let profile = MachineProfile::default_plotter();
        let fit = Wrap::try_parse_from(["t", "--paper", "a4", "--fit", "--margin", "10"]).unwrap();
        let small = crate::input::load_laid_out(&svg("dot.svg", 4.0, 1.0), &fit.input, &profile, &fit.layout).unwrap();
        let (n, worst) = worst_chord_error(&small.drawing, Point::new(105.0, 148.5), 95.0);
        // Drawn 95 mm large to begin with, no layout.
        let plain = Wrap::try_parse_from(["t"]).unwrap();
        let big =
            crate::input::load_laid_out(&svg("big.svg", 200.0, 95.0), &plain.input, &profile, &plain.layout).unwrap();
        let (n_big, worst_big) = worst_chord_error(&big.drawing, Point::new(100.0, 100.0), 95.0);
        // Unmagnified flattening of the 1 mm circle would give about 2π/(2·√(2·0.05/1)) ≈ 10 chords.
        assert!(n > 50 && n.abs_diff(n_big) <= n_big / 20, "{n} vs {n_big} points");
        assert!(
            worst > 0.0 && worst <= worst_big * 1.05 && worst < 0.15,
            "worst chord error {worst} vs {worst_big} mm"
        );
        std::fs::remove_dir_all(&dir).ok();
    }

    /// Two 20 mm lines, A from (10, 10) to (30, 10) and B from (80, 50) to (100, 50) (page mm). From home (0, 0)
    /// the best order is A then B: 10·√2 + √(50² + 40²) = 14.142 + 64.031 = 78.173 mm of pen-up travel. From
    /// (100, 50) it is B backwards (no hop), then A from (30, 10): 64.031 mm; starting with A would cost
    /// √(70² + 40²) = 80.623 mm before anything is drawn.
    #[test]
    fn without_homing_the_order_starts_where_the_machine_reports_the_pen() {
        let profile = MachineProfile::default_plotter();
        let dir = std::env::temp_dir().join(format!("plotter-load-pen-at-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let svg = dir.join("two.svg");
        std::fs::write(
            &svg,
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="210mm" height="297mm" viewBox="0 0 210 297">
<path d="M10 10 H30" stroke="black" fill="none"/><path d="M80 50 H100" stroke="black" fill="none"/></svg>"#,
        )
        .unwrap();
        let w = Wrap::try_parse_from(["t"]).unwrap();
        // The simulated plotter, homed, then moved to (100, 50) mm as a previous plot might have left it.
        let cfg = plan::machine_config(&profile).unwrap();
        let mut session = Session::connect(SimTransport::new(cfg, None), "sim").unwrap();
        session.home().unwrap();
        session.command_checked("G0 X100 Y50", Duration::from_secs(5)).unwrap();
        session.wait_idle(Duration::from_millis(1)).unwrap();
        let pen = pen_on_page(&mut session, &profile).unwrap();
        assert_eq!(pen, Point::new(100.0, 50.0));

        let (steps, drawing) = load_steps(&svg, &profile, &w.input, &w.layout, &w.optimize, Some(pen)).unwrap();
        let d = drawing.unwrap();
        assert_eq!(steps.strokes[0].start, StepPos::new(8000, 4000), "B first, entered at (100, 50)");
        let travel = drawing_travel(&d, Some(pen), &CostModel::Distance);
        assert!((travel - 4100f64.sqrt()).abs() < 1e-4, "{travel}");

        let (steps, drawing) = load_steps(&svg, &profile, &w.input, &w.layout, &w.optimize, None).unwrap();
        assert_eq!(steps.strokes[0].start, StepPos::new(800, 800), "A first, entered at (10, 10)");
        let travel = drawing_travel(&drawing.unwrap(), Some(Point::ZERO), &CostModel::Distance);
        assert!((travel - (200f64.sqrt() + 4100f64.sqrt())).abs() < 1e-4, "{travel}");
        std::fs::remove_dir_all(&dir).ok();
    }

    /// A trajectory file is used as stored, checked against the work area before anything connects: 40000 steps
    /// at the default profile's 80 steps/mm reach X 500 mm, past its 420 mm; the error names the fix.
    #[test]
    fn a_trajectory_beyond_the_work_area_is_refused_naming_the_fix() {
        let profile = MachineProfile::default_plotter();
        assert_eq!((profile.axes.x.steps_per_mm, profile.axes.x.travel_mm), (80.0, 420.0));
        let dir = std::env::temp_dir().join(format!("plotter-load-traj-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let far = dir.join("far.traj");
        std::fs::write(&far, "1\n2\n0 40000\n0 0\n").unwrap();
        let w = Wrap::try_parse_from(["t"]).unwrap();
        let e = load_page(&far, &profile, &w.input, &w.layout).unwrap_err().to_string();
        assert!(e.contains("(500.000, 0.000) mm (machine) is outside the work area 0..420 × 0..297 mm"), "{e}");
        assert!(e.ends_with("; lay it out within it with --fit and a --paper"), "{e}");
        let near = dir.join("near.traj");
        std::fs::write(&near, "1\n2\n0 4000\n0 0\n").unwrap();
        assert!(matches!(load_page(&near, &profile, &w.input, &w.layout).unwrap(), Page::Steps(_)));
        std::fs::remove_dir_all(&dir).ok();
    }
}
