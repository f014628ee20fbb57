//! `plotter plot`: load a drawing (SVG, G-code or trajectory file), plan it with the firmware's planner, and run it
//! on the built-in simulated plotter (default, writes the as-stepped preview) or stream it to a serial device.

use std::io::{BufRead as _, IsTerminal as _, Write as _};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use anyhow::{Context as _, bail};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use plotter_fw::sim::Sim;
use plotter_fw::{Axis, TICK_HZ};
use plotter_path::input::trajectory;
use plotter_path::kurbo::{Line, Point};
use plotter_path::motion::plan::{self, Lookahead, MotionPlan};
use plotter_path::motion::steps::{StepDrawing, StepMapper, drawing_to_steps};
use plotter_path::optimize::{self, OptimizeOptions};
use plotter_path::output::preview;
use plotter_path::{Drawing, MachineProfile, Polyline};

use crate::cmd_optimize::OptimizeArgs;
use crate::input::{InputArgs, InputKind, input_kind, load_drawing};
use crate::layout_args::LayoutArgs;
use serde::{Deserialize, Serialize};

use crate::link::Transport;
use crate::link::journal::{self, Journal};
use crate::link::serial::SerialTransport;
use crate::link::session::Session;
use crate::link::sim::SimTransport;
use crate::link::stream::{self, Control, PauseChoice, Progress, StreamError, StreamOptions, StreamStats};

/// Arguments of `plotter plot`.
#[derive(clap::Args, Debug, Clone)]
pub(crate) struct PlotArgs {
    /// Drawing to plot: an SVG, a G-code file (.gcode/.nc/.ngc/.g) or a trajectory file (.traj/.txt).
    #[arg(required_unless_present = "resume")]
    pub(crate) input: Option<PathBuf>,
    /// Serial device of the plotter (e.g. /dev/ttyUSB0, or the path printed by `plotter sim --pty`). Without it
    /// the plot runs on the built-in simulated plotter.
    #[arg(long)]
    pub(crate) port: Option<String>,
    /// Machine profile (TOML); the built-in XY plotter kit profile by default.
    #[arg(long)]
    pub(crate) profile: Option<PathBuf>,
    /// Do not home before plotting (the machine must already know where it is).
    #[arg(long)]
    pub(crate) no_home: bool,
    /// Where to write the as-stepped preview PNG of a simulated plot [default: <input>.stepped.png].
    #[arg(long)]
    pub(crate) preview: Option<PathBuf>,
    /// Show pen-up travel in the as-stepped preview.
    #[arg(long)]
    pub(crate) travel: bool,
    /// Resume journal [default with --port: <input>.journal].
    #[arg(long)]
    pub(crate) journal: Option<PathBuf>,
    /// Resume the plot recorded in this journal.
    #[arg(long, conflicts_with = "input")]
    pub(crate) resume: Option<PathBuf>,
    /// With --resume: trust the position the firmware reports instead of homing again.
    #[arg(long, requires = "resume")]
    pub(crate) trust_position: bool,
    /// On Ctrl-C, hold at once (pen stays where it is) instead of at the next pen-up.
    #[arg(long)]
    pub(crate) pause_immediately: bool,
    /// Serial baud rate [default: the profile's].
    #[arg(long)]
    pub(crate) baud: Option<u32>,
    /// Do not plot: write the drawing, as it would be stepped, to this file — G-code (.gcode/.nc/.ngc/.g, GRBL
    /// style, pen per the profile) or the seed plotter's trajectory format (.traj/.txt).
    #[arg(long)]
    pub(crate) export: Option<PathBuf>,
    /// Simulated plot only: corrupt this fraction of the bytes on the simulated link (flip a bit or drop), to
    /// watch the resends at work.
    #[arg(long, default_value_t = 0.0)]
    pub(crate) sim_noise: f64,
    #[command(flatten)]
    pub(crate) input_args: InputArgs,
    #[command(flatten)]
    pub(crate) layout: LayoutArgs,
    /// Path ordering. `plot` runs the optimizer to convergence (no time budget), so that a resumed plot rebuilds
    /// exactly the same order.
    #[command(flatten)]
    pub(crate) optimize: OptimizeArgs,
}

/// `plot`'s arguments on their own, to re-read the ones stored in a journal.
#[derive(clap::Parser, Debug)]
struct PlotOnly {
    #[command(flatten)]
    args: PlotArgs,
}

/// What a plot was made from: stored in the journal so that `--resume` rebuilds exactly the same plan (the
/// `plot` arguments as given, the directory they are relative to, and where the plan started).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct PlotSource {
    cwd: PathBuf,
    args: Vec<String>,
    start: [i32; 4],
}

/// Load the machine profile.
pub(crate) fn load_profile(path: Option<&Path>) -> anyhow::Result<MachineProfile> {
    match path {
        Some(p) => Ok(MachineProfile::load(p)?),
        None => Ok(MachineProfile::default_plotter()),
    }
}

/// Load any supported input as steps (and the millimetre drawing for previews), laid out as the flags say,
/// printing warnings. A trajectory file is already in steps and is used exactly as stored unless layout flags
/// ask for a change.
pub(crate) fn load_steps(
    input: &Path,
    profile: &MachineProfile,
    input_args: &InputArgs,
    layout: &LayoutArgs,
    optimize: &OptimizeArgs,
) -> anyhow::Result<(StepDrawing, Option<Drawing>)> {
    let shown = input.display().to_string();
    // A trajectory file is already in steps: keep it exactly as stored unless layout flags ask for a change.
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
        let options = OptimizeOptions { time_budget: None, ..optimize.options(Some(profile))? };
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

/// The as-stepped drawing: pen-down runs of the simulator's step trace as page-millimetre polylines, and the
/// pen-up moves between them.
pub(crate) fn stepped_drawing(sim: &Sim, profile: &MachineProfile) -> (Drawing, Vec<Line>) {
    let mapper = StepMapper::new(profile);
    let cfg = sim.machine().config();
    let z = cfg.axis(Axis::Z);
    let threshold = (f64::from(cfg.pen.up_z_mm) + f64::from(cfg.pen.down_z_mm)) / 2.0 * f64::from(z.steps_per_mm);
    let mut pos = [0i64; 4];
    let mut paths: Vec<Polyline> = Vec::new();
    let mut travel: Vec<Line> = Vec::new();
    let mut current: Vec<Point> = Vec::new();
    let mut last_down_end: Option<Point> = None;
    let to_page = |p: &[i64; 4]| {
        let x = i32::try_from(p[0]).unwrap_or(i32::MAX);
        let y = i32::try_from(p[1]).unwrap_or(i32::MAX);
        mapper.steps_to_page(plotter_path::motion::steps::StepPos::new(x, y))
    };
    // Step counts are far below 2^53, so the comparison in f64 is exact.
    #[allow(clippy::cast_precision_loss)]
    let down = |p: &[i64; 4]| (p[2] as f64) < threshold;
    for e in sim.hal().steps() {
        pos[e.axis.index()] += if e.forward { 1 } else { -1 };
        if down(&pos) {
            let pt = to_page(&pos);
            if current.is_empty() {
                if let Some(prev) = last_down_end {
                    travel.push(Line::new(prev, pt));
                }
                current.push(pt);
            } else if current.last() != Some(&pt) {
                current.push(pt);
            }
        } else if !current.is_empty() {
            last_down_end = current.last().copied();
            if current.len() > 1 {
                paths.push(Polyline::new(std::mem::take(&mut current)));
            }
            current.clear();
        }
    }
    if current.len() > 1 {
        paths.push(Polyline::new(current));
    }
    (Drawing::single_layer("as-stepped", paths), travel)
}

/// Ctrl-C handling shared by the plot loop: a flag set by the signal handler.
fn interrupt_flag() -> Arc<AtomicBool> {
    let flag = Arc::new(AtomicBool::new(false));
    let f = Arc::clone(&flag);
    // A second registration (tests, repeated calls) fails harmlessly: Ctrl-C then simply ends the process.
    let _ = ctrlc::set_handler(move || f.store(true, Ordering::SeqCst));
    flag
}

/// Progress bar, journal and pause prompts.
struct PlotControl {
    bar: ProgressBar,
    journal: Option<Journal>,
    /// Cumulative pen-down mm after each frame.
    draw_mm: Vec<f64>,
    /// Remaining planned time after each frame, ticks.
    remaining: Vec<u64>,
    total_draw: f64,
    resumed_from: usize,
    preamble: usize,
    interrupt: Arc<AtomicBool>,
    immediately: bool,
    error: Option<anyhow::Error>,
}

impl PlotControl {
    fn new(
        plan: &MotionPlan,
        profile: &MachineProfile,
        journal: Option<Journal>,
        interrupt: Arc<AtomicBool>,
        immediately: bool,
    ) -> Self {
        let n = plan.blocks.len();
        let target = if std::io::stderr().is_terminal() {
            ProgressDrawTarget::stderr_with_hz(5)
        } else {
            ProgressDrawTarget::hidden()
        };
        let bar = ProgressBar::with_draw_target(Some(u64::try_from(n).unwrap_or(u64::MAX)), target);
        if let Ok(style) = ProgressStyle::with_template("{bar:30} {percent:>3}% {pos}/{len} blocks  {msg}")
            .map(|s| s.progress_chars("█▉ "))
        {
            bar.set_style(style);
        }
        let mut draw_mm = Vec::with_capacity(n);
        let mut acc = 0.0;
        let mapper = StepMapper::new(profile);
        for b in &plan.blocks {
            if b.kind == plan::MoveKind::Draw {
                let d = mapper
                    .steps_to_machine(plotter_path::motion::steps::StepPos::new(b.block.steps[0], b.block.steps[1]));
                acc += d.to_vec2().hypot();
            }
            draw_mm.push(acc);
        }
        let mut remaining = vec![0u64; n];
        let mut r = 0u64;
        for (i, b) in plan.blocks.iter().enumerate().rev() {
            remaining[i] = r;
            r += u64::from(b.block.duration_ticks());
        }
        PlotControl {
            bar,
            journal,
            draw_mm,
            remaining,
            total_draw: acc,
            resumed_from: plan.resumed_from,
            preamble: plan.preamble,
            interrupt,
            immediately,
            error: None,
        }
    }

    fn original(&self, frames: usize) -> usize {
        self.resumed_from + frames.saturating_sub(self.preamble)
    }
}

impl Control for PlotControl {
    fn progress(&mut self, p: &Progress) {
        self.bar.set_position(u64::try_from(p.executed).unwrap_or(u64::MAX));
        let i = p.executed.saturating_sub(1);
        let done = self.draw_mm.get(i).copied().unwrap_or(0.0);
        let left = if p.executed == 0 { self.remaining.first().copied().unwrap_or(0) } else { self.remaining[i] };
        // Ratios of step counts for display only.
        #[allow(clippy::cast_precision_loss)]
        let secs = left as f64 / f64::from(TICK_HZ);
        self.bar.set_message(format!(
            "pen-down {done:.0}/{:.0} mm  ETA {secs:.0} s  resends {}",
            self.total_draw, p.resends
        ));
        let (a, e) = (self.original(p.accepted), self.original(p.executed));
        // The journal pairs a block number with the sequence number after it; during a resume preamble that is
        // the number the firmware will have once the preamble is through.
        let pending = u32::try_from(self.preamble.saturating_sub(p.accepted)).unwrap_or(u32::MAX);
        let seq = p.seq_after_accepted.wrapping_add(pending);
        if let Some(j) = self.journal.as_mut()
            && self.error.is_none()
            && let Err(err) = j.record(a, e, seq)
        {
            self.error = Some(err);
        }
    }

    fn pause_requested(&mut self) -> Option<bool> {
        self.interrupt.swap(false, Ordering::SeqCst).then_some(self.immediately)
    }

    fn paused(&mut self, held: bool) -> PauseChoice {
        let what = if held { "feed hold (pen where it stopped)" } else { "paused with the pen up" };
        self.bar.suspend(|| {
            eprint!("\n{what}: [r]esume or [a]bort? ");
            let _ = std::io::stderr().flush();
            let mut line = String::new();
            match std::io::stdin().lock().read_line(&mut line) {
                Ok(n) if n > 0 && line.trim_start().starts_with(['r', 'R']) => PauseChoice::Resume,
                _ => PauseChoice::Abort,
            }
        })
    }
}

/// Human summary of a finished plot.
fn summary(plan: &MotionPlan, stats: &StreamStats, executed_ticks: Option<u64>) -> String {
    // Display only.
    #[allow(clippy::cast_precision_loss)]
    let per_block = if stats.frames > 0 { stats.frame_bytes as f64 / stats.frames as f64 } else { 0.0 };
    let mut s = format!(
        "{} blocks, {:.1} mm pen-down, {:.1} mm travel; planned time {:.3} s",
        plan.blocks.len(),
        plan.draw_mm,
        plan.travel_mm,
        plan.seconds()
    );
    if let Some(t) = executed_ticks {
        // Display only.
        #[allow(clippy::cast_precision_loss)]
        let secs = t as f64 / f64::from(TICK_HZ);
        s += &format!(", executed {secs:.3} s");
    }
    s += &format!("\nlink: {per_block:.1} bytes/block, {} resends", stats.resends);
    if stats.resyncs > 0 {
        s += &format!(", {} resyncs", stats.resyncs);
    }
    if let Some(u) = stats.underruns {
        s += &format!(", {u} queue underruns");
    }
    s
}

fn default_beside(input: &Path, suffix: &str) -> PathBuf {
    // A generated figure `gen:KIND?params` is named after its kind.
    let generated = input.to_str().and_then(|p| p.strip_prefix(crate::input::GEN_PREFIX));
    let stem = match generated {
        Some(spec) => spec.split('?').next().filter(|k| !k.is_empty() && !k.contains('/')).unwrap_or("figure"),
        None => input.file_stem().and_then(|s| s.to_str()).unwrap_or("plot"),
    };
    PathBuf::from(format!("{stem}{suffix}"))
}

/// Run `plotter plot`.
pub(crate) fn run(args: &PlotArgs) -> anyhow::Result<()> {
    if let Some(j) = &args.resume {
        return resume(args, j);
    }
    let input = args.input.as_deref().context("an input file is required")?;
    let profile = load_profile(args.profile.as_deref())?;
    let cfg = plan::machine_config(&profile)?;
    let (steps, drawing) = load_steps(input, &profile, &args.input_args, &args.layout, &args.optimize)?;
    plan::check_work_area(&profile, &steps)?;
    if let Some(out) = &args.export {
        let ext = out.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).unwrap_or_default();
        let text = match ext.as_str() {
            "gcode" | "nc" | "ngc" | "g" | "gco" => plotter_path::output::gcode_out::export(&profile, &steps),
            "traj" | "trj" | "txt" => trajectory::export(&steps),
            _ => bail!("--export {}: use a .gcode/.nc/.ngc/.g or .traj/.txt file name", out.display()),
        };
        std::fs::write(out, text).with_context(|| format!("cannot write {}", out.display()))?;
        println!("{} strokes, {} moves written to {}", steps.strokes.len(), steps.move_count(), out.display());
        return Ok(());
    }
    let interrupt = interrupt_flag();
    let baud = args.baud.unwrap_or(profile.link.baud);
    match &args.port {
        None => {
            let mut transport = SimTransport::new(cfg, Some(baud));
            if args.sim_noise > 0.0 {
                transport = transport.with_noise(crate::link::faults::Noise::new(args.sim_noise, 1));
            }
            let mut session = Session::connect(transport, "simulated plotter")?;
            let (plan, stats, start_busy) = plot_on(&mut session, &profile, &steps, args, None, interrupt)?;
            let sim = session.transport.sim();
            let executed = sim.hal().busy_ticks() - start_busy;
            println!("{}", summary(&plan, &stats, Some(executed)));
            if let Some(d) = &drawing {
                print_lower_bound(&profile, &steps, d, &plan, args)?;
            }
            let (stepped, travel) = stepped_drawing(sim, &profile);
            let mut stepped = stepped;
            stepped.page_mm = drawing.as_ref().and_then(|d| d.page_mm);
            let out = args.preview.clone().unwrap_or_else(|| default_beside(input, ".stepped.png"));
            let opts = preview::PreviewOptions { travel: args.travel, ..preview::PreviewOptions::default() };
            let pixmap = preview::render_with_travel(&stepped, &travel, &opts)?;
            preview::save_pixmap(&pixmap, &out)?;
            println!("as-stepped preview: {}", out.display());
            Ok(())
        }
        Some(port) => {
            let transport = SerialTransport::open(port, baud)?;
            let mut session = Session::connect(transport, port)?;
            let journal_path = args.journal.clone().unwrap_or_else(|| default_beside(input, ".journal"));
            let (plan, stats, _) = plot_on(&mut session, &profile, &steps, args, Some(&journal_path), interrupt)?;
            println!("{}", summary(&plan, &stats, None));
            Ok(())
        }
    }
}

/// Print the plot-time lower bound next to the planned time (see [`plotter_path::motion::bound`]).
fn print_lower_bound(
    profile: &MachineProfile,
    steps: &StepDrawing,
    drawing: &Drawing,
    plan: &MotionPlan,
    args: &PlotArgs,
) -> anyhow::Result<()> {
    let start = args.optimize.start(Some(profile))?;
    let seam = args.optimize.options(Some(profile))?.seam;
    let (travel_lb, _) = optimize::travel_lower_bound(drawing, seam, start, None);
    let b = plotter_path::motion::bound::plot_time_lower_bound(profile, steps, travel_lb)?;
    println!(
        "lower bound {:.3} s (pen down {:.1} s, {} lifts {:.1} s, travel {:.1} s): planned time is {:.1} % above it",
        b.total_s(),
        b.draw_s,
        steps.strokes.len(),
        b.lifts_s,
        b.travel_s,
        100.0 * (plan.seconds() / b.total_s() - 1.0)
    );
    Ok(())
}

/// Home (unless told not to), plan from the reported position, stream. Returns the plan, the stream statistics
/// and the simulator's busy time before the plot (0 for a serial port).
fn plot_on<T: Transport + 'static>(
    session: &mut Session<T>,
    profile: &MachineProfile,
    steps: &StepDrawing,
    args: &PlotArgs,
    journal_path: Option<&Path>,
    interrupt: Arc<AtomicBool>,
) -> anyhow::Result<(MotionPlan, StreamStats, u64)> {
    if !args.no_home {
        session.home()?;
    }
    let status = session.status()?;
    let start = status.steps;
    let plan = plan::plan_returning(profile, steps, start, Lookahead::Whole, args.optimize.return_home)?;
    let journal = match journal_path {
        Some(p) => {
            let source = PlotSource {
                cwd: std::env::current_dir().context("no current directory")?,
                args: std::env::args().skip_while(|a| a != "plot").skip(1).collect(),
                start,
            };
            Some(Journal::create(p, &serde_json::to_string(&source)?, plan.geometry_hash(), plan.blocks.len())?)
        }
        None => None,
    };
    let busy_before = busy_ticks(session);
    let mut control = PlotControl::new(&plan, profile, journal, interrupt, args.pause_immediately);
    let result = stream::stream_plan(session, &plan, StreamOptions::default(), &mut control);
    control.bar.finish_and_clear();
    if let Some(e) = control.error.take() {
        return Err(e);
    }
    let (_, stats) = result.map_err(|e| explain(e, journal_path))?;
    if let Some(j) = control.journal.as_mut() {
        j.complete()?;
    }
    Ok((plan, stats, busy_before))
}

/// The simulator's executed motion time so far, when the transport is the in-process simulator.
fn busy_ticks<T: Transport + 'static>(session: &Session<T>) -> u64 {
    (&session.transport as &dyn std::any::Any).downcast_ref::<SimTransport>().map_or(0, |s| s.sim().hal().busy_ticks())
}

fn explain(e: StreamError, journal: Option<&Path>) -> anyhow::Error {
    let hint = match (&e, journal) {
        (StreamError::Refused { .. }, _) | (_, None) => String::new(),
        (_, Some(j)) => format!("\ncontinue with: plotter plot --resume {} --port <device>", j.display()),
    };
    anyhow::anyhow!("{e}{hint}")
}

/// `plotter plot --resume JOURNAL`.
fn resume(args: &PlotArgs, journal_path: &Path) -> anyhow::Result<()> {
    let state = journal::load(journal_path)?;
    if state.complete {
        bail!("{}: that plot already finished", journal_path.display());
    }
    let source: PlotSource = serde_json::from_str(&state.source)
        .with_context(|| format!("{}: unreadable source line", journal_path.display()))?;
    let original = <PlotOnly as clap::Parser>::try_parse_from(std::iter::once("plot".to_string()).chain(source.args))
        .with_context(|| format!("{}: the recorded plot arguments no longer parse", journal_path.display()))?
        .args;
    let journal_path = std::path::absolute(journal_path)?;
    let journal_path = journal_path.as_path();
    std::env::set_current_dir(&source.cwd)
        .with_context(|| format!("cannot enter {}, where the plot was started", source.cwd.display()))?;
    let input = original.input.as_deref().context("the recorded plot has no input")?;
    let profile = load_profile(original.profile.as_deref())?;
    let (steps, _) = load_steps(input, &profile, &original.input_args, &original.layout, &original.optimize)?;
    let back = original.optimize.return_home;
    let full = plan::plan_returning(&profile, &steps, source.start, Lookahead::Whole, back)?;
    if full.geometry_hash() != state.plan_hash || full.blocks.len() != state.blocks {
        bail!(
            "{} no longer gives the plan recorded in {} (the input or the profile changed)",
            input.display(),
            journal_path.display()
        );
    }
    let port = args.port.as_deref().context("--resume needs --port (the simulated plotter keeps no state)")?;
    let baud = args.baud.unwrap_or(profile.link.baud);
    let mut session = Session::connect(SerialTransport::open(port, baud)?, port)?;
    // If the firmware is still running the session the host lost, let it finish what it accepted. Frames that
    // were in flight when the host died may have been accepted after the journal's last line: the firmware's
    // sequence number tells how many (one per block). If it then stands exactly where that many blocks end,
    // they were all executed; otherwise (restarted, moved) only the journal's executed count is certain.
    let status = session.wait_idle(std::time::Duration::from_millis(50))?;
    let extra = status.seq.wrapping_sub(state.seq_after_accepted);
    let accepted = usize::try_from(extra).ok().map(|x| state.accepted + x).filter(|&a| a <= full.blocks.len());
    let done = match accepted {
        Some(a) if a > 0 && status.steps == full.position_after(a - 1) => a,
        _ => state.executed,
    };
    eprintln!("resuming at block {done} of {} ({} certainly executed)", full.blocks.len(), state.executed);
    if !args.trust_position {
        session.home()?;
    }
    let now = session.status()?.steps;
    let plan = plan::plan_resume(&profile, &steps, source.start, done, now, back)?;
    let journal = Journal::append(journal_path, &state)?;
    let mut control = PlotControl::new(&plan, &profile, Some(journal), interrupt_flag(), args.pause_immediately);
    let result = stream::stream_plan(&mut session, &plan, StreamOptions::default(), &mut control);
    control.bar.finish_and_clear();
    if let Some(e) = control.error.take() {
        return Err(e);
    }
    let (_, stats) = result.map_err(|e| explain(e, Some(journal_path)))?;
    if let Some(j) = control.journal.as_mut() {
        j.complete()?;
    }
    println!("{}", summary(&plan, &stats, None));
    Ok(())
}
