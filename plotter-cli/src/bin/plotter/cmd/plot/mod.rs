//! `plotter plot`: load a drawing (SVG, G-code or trajectory file), plan it with the firmware's planner, and run it
//! on the built-in simulated plotter (default, writes the as-stepped preview) or stream it to a serial device
//! running our firmware or GRBL. Between layers drawn with different pens the plot parks and asks for the pen
//! (Enter continue, `s` skip the layer, `q` stop and keep the journal), or as `--pen-change` says. On a port the
//! journal goes to the user's state directory (`plotter resume` lists and continues interrupted plots).

mod hpgl;
mod summary;
mod terminal;

use hpgl::{export_hpgl, plot_hpgl};
use summary::{copies_line, print_lower_bound, summary};
use terminal::{PenChange, Terminal};

use std::path::{Path, PathBuf};

use anyhow::{Context as _, bail};
use plotter_host::input::InputArgs;
use plotter_host::job::load::{load_page, load_steps, order_steps, page_of, pen_on_page};
use plotter_host::job::stepped::stepped_drawing;
use plotter_host::job::{self, JournalSpec};
use plotter_host::link::hpgl::handshake::Handshake;
use plotter_host::link::journal;
use plotter_host::link::machine::{Connected, Firmware};
use plotter_host::link::paced::PacedSim;
use plotter_host::link::serial::SerialTransport;
use plotter_host::link::session::Session;
use plotter_host::link::sim::SimTransport;
use plotter_host::options::layout::{LayoutArgs, journal_args, refuse_quarter_turns};
use plotter_host::options::machine::MachineArgs;
use plotter_host::options::optimize::OptimizeArgs;
use plotter_host::options::workflow::WorkflowArgs;
use plotter_host::stop::Stop;
use plotter_path::MachineProfile;
use plotter_path::input::trajectory;
use plotter_path::motion::plan;
use plotter_path::output::preview;
use serde::{Deserialize, Serialize};

/// Arguments of `plotter plot`.
#[derive(clap::Args, Debug, Clone)]
pub(crate) struct PlotArgs {
    /// Drawing to plot: an SVG, a G-code file (.gcode/.nc/.ngc/.g), an HP-GL file (.hpgl/.plt/.hgl) or a trajectory
    /// file (.traj/.txt).
    #[arg(required_unless_present = "resume")]
    pub(crate) input: Option<PathBuf>,
    /// Serial device of the plotter (e.g. /dev/ttyUSB0, or the path printed by `plotter sim --pty`). Without it
    /// the plot runs on the built-in simulated plotter.
    #[arg(long)]
    pub(crate) port: Option<String>,
    #[command(flatten)]
    pub(crate) machine: MachineArgs,
    /// Do not home before plotting (the machine must already know where it is).
    #[arg(long)]
    pub(crate) no_home: bool,
    /// Where to write the as-stepped preview PNG of a simulated plot [default: <input>.stepped.png].
    #[arg(long)]
    pub(crate) preview: Option<PathBuf>,
    /// Show pen-up travel in the as-stepped preview.
    #[arg(long)]
    pub(crate) travel: bool,
    /// Where to write the plot's resume journal [default with --port: in the state directory,
    /// ~/.local/state/plotter/journals, named after the drawing and the machine; `plotter resume --list` shows
    /// them].
    #[arg(long)]
    pub(crate) journal: Option<PathBuf>,
    /// Resume the plot recorded in this journal (as `plotter resume JOURNAL` does).
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
    /// GRBL: how long a feed hold nobody resumes (the controller's Hold button) may last, seconds, before the
    /// plot stops and lifts the pen.
    #[arg(long, default_value_t = 30.0, value_parser = hold_seconds)]
    pub(crate) hold_timeout: f64,
    /// The plotter's firmware: ours, GRBL 1.1 (grblHAL, FluidNC), ebb (AxiDraw-class EiBotBoard), hpgl (a
    /// vintage HP-GL plotter, sent the HP-GL export for --hpgl-device), or auto (told by its start-up banner or
    /// its answers).
    #[arg(long, value_enum, default_value_t = Firmware::Auto)]
    pub(crate) firmware: Firmware,
    /// What happens between layers drawn with different pens. The default asks at a terminal and, in a script or
    /// a pipe, plots straight through with a warning, so that nothing waits for an answer nobody can give.
    #[arg(long, value_enum, default_value_t = PenChange::Auto)]
    pub(crate) pen_change: PenChange,
    /// GRBL: take steps/mm, maximum rates, accelerations and travel from the machine's `$$` settings instead of
    /// the profile (the pen settings still come from the profile).
    #[arg(long)]
    pub(crate) profile_from_machine: bool,
    /// Do not plot: write the drawing, as it would be stepped, to this file — G-code (.gcode/.nc/.ngc/.g, GRBL
    /// style, pen per the profile), HP-GL (.hpgl/.plt/.hgl, for --hpgl-device) or the seed plotter's trajectory
    /// format (.traj/.txt).
    #[arg(long)]
    pub(crate) export: Option<PathBuf>,
    /// HP-GL export: the plotter (7475a, 7550a, dxy-1300, generic).
    #[arg(long, default_value = "7475a")]
    pub(crate) hpgl_device: String,
    /// HP-GL plotter (--firmware hpgl): how the sender keeps the plotter's buffer from overflowing — `ESC . B`
    /// buffer-space queries (escb, any cable), Xon/Xoff, or the RTS/CTS lines (hardware). The baud rate is 9600
    /// unless --baud says otherwise.
    #[arg(long, value_enum, default_value_t = Handshake::Escb)]
    pub(crate) handshake: Handshake,
    /// HP-GL export: the sheet loaded in the plotter (7475a: a4, letter, a3, tabloid) [default: the first of
    /// the device's sheets whose plotting area holds the drawing].
    #[arg(long)]
    pub(crate) hpgl_paper: Option<String>,
    /// Play a G-code file exactly as written — its order, its moves at their feeds, its pen lifts as Z moves, its
    /// dwells — instead of reading it as a drawing to order and plan (the simulator or our firmware; Z-lift pens).
    #[arg(long, conflicts_with_all = ["resume", "export"])]
    pub(crate) as_written: bool,
    /// Also print the figures of the plan and the link once the plot has finished: blocks, bytes per block,
    /// resends, queue underruns, the plot time's lower bound and its parts, GRBL's bytes in flight, the EBB's
    /// moves too short for the board.
    #[arg(long, short = 'v')]
    pub(crate) verbose: bool,
    /// Start a plan that stands still for over an hour in dwells (G4 with --as-written, or pen settles) even
    /// without a terminal on stdin; at a terminal such a plan starts after a loud warning.
    #[arg(long)]
    pub(crate) allow_long_dwell: bool,
    /// Simulated plot only: corrupt this fraction of the bytes on the simulated link (flip a bit or drop), to
    /// watch the resends at work.
    #[arg(long, default_value_t = 0.0)]
    pub(crate) sim_noise: f64,
    /// Simulated plot only: run at this many times the real machine's speed (e.g. 1 to watch it as it would
    /// plot, 10 for ten times faster) [default: as fast as the computer can].
    #[arg(long, value_parser = sim_speed)]
    pub(crate) sim_speed: Option<f64>,
    #[command(flatten)]
    pub(crate) workflow: Box<WorkflowArgs>,
    #[command(flatten)]
    pub(crate) input_args: Box<InputArgs>,
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
pub(super) struct PlotSource {
    cwd: PathBuf,
    args: Vec<String>,
    start: [i32; 4],
    /// The drawing and the machine, as `plotter resume --list` shows them.
    #[serde(default)]
    drawing: String,
    #[serde(default)]
    machine: String,
}

impl PlotSource {
    /// This command's plot: its arguments after `plot`, the current directory, where the plan starts.
    pub(super) fn here(input: &Path, machine: &str, start: [i32; 4]) -> anyhow::Result<PlotSource> {
        Ok(PlotSource {
            cwd: std::env::current_dir().context("no current directory")?,
            args: journal_args(std::env::args().skip_while(|a| a != "plot").skip(1)),
            start,
            drawing: drawing_name(input),
            machine: machine.to_string(),
        })
    }
}

/// The drawing as a journal names it: a `gen:` figure as written, a file by its absolute path.
fn drawing_name(input: &Path) -> String {
    match input.to_str().filter(|p| p.starts_with(plotter_host::input::GEN_PREFIX)) {
        Some(generated) => generated.to_string(),
        None => std::path::absolute(input).unwrap_or_else(|_| input.to_path_buf()).display().to_string(),
    }
}

/// Where a plot on a port keeps its journal: `--journal`, else the state directory's file for this drawing and
/// machine (finished plots' old journals there are pruned on the way).
pub(super) fn journal_path(args: &PlotArgs, input: &Path, machine: &str) -> anyhow::Result<PathBuf> {
    if let Some(j) = &args.journal {
        return Ok(j.clone());
    }
    let path = plotter_host::state_dir::journal_for(&drawing_name(input), machine)?;
    if let Some(dir) = path.parent() {
        let _ = plotter_host::state_dir::prune_finished(dir, plotter_host::state_dir::KEEP_FINISHED);
    }
    Ok(path)
}

/// `--sim-speed`: a positive factor of the machine's speed.
fn sim_speed(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v > 0.0 && v.is_finite() => Ok(v),
        _ => Err(format!("{s:?} is not a positive speed factor (1 = the machine's own speed)")),
    }
}

/// `--hold-timeout`: a positive number of seconds, at most a day.
pub(crate) fn hold_seconds(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v > 0.0 && v <= 86_400.0 => Ok(v),
        _ => Err(format!("{s:?} is not a number of seconds between 0 and 86400")),
    }
}
/// Connect to the port, check GRBL's settings against `profile` (or build the profile from them).
fn connect(args: &PlotArgs, port: &str, profile: &mut MachineProfile) -> anyhow::Result<Connected<SerialTransport>> {
    let baud = args.baud.unwrap_or(profile.link.baud);
    let mut c = crate::cmd::home::open(port, baud, args.firmware, profile)?;
    match &mut c {
        Connected::Grbl(g) => {
            if args.profile_from_machine {
                *profile = g.settings.to_profile(profile)?;
                eprintln!("profile from the machine's settings: {}", profile.name);
            } else {
                for m in g.settings.compare(profile) {
                    eprintln!("warning: GRBL setting {m} (or plot with --profile-from-machine)");
                }
            }
            g.profile = profile.clone();
            g.hold_timeout = std::time::Duration::from_secs_f64(args.hold_timeout);
        }
        Connected::Ours(_) | Connected::Ebb(_) if args.profile_from_machine => {
            bail!(
                "--profile-from-machine needs a GRBL controller (plotter-fw and the EBB take their settings from the profile)"
            )
        }
        Connected::Ours(_) | Connected::Ebb(_) => {}
    }
    Ok(c)
}

pub(super) fn default_beside(input: &Path, suffix: &str) -> PathBuf {
    // A generated figure `gen:KIND?params` is named after its kind.
    let generated = input.to_str().and_then(|p| p.strip_prefix(plotter_host::input::GEN_PREFIX));
    let stem = match generated {
        Some(spec) => spec.split('?').next().filter(|k| !k.is_empty() && !k.contains('/')).unwrap_or("figure"),
        None => input.file_stem().and_then(|s| s.to_str()).unwrap_or("plot"),
    };
    PathBuf::from(format!("{stem}{suffix}"))
}
/// Run `plotter plot`.
pub(crate) fn run(args: &PlotArgs) -> anyhow::Result<()> {
    // From the start: a signal while loading or connecting ends the command (imports stop early), one during the
    // plot pauses it or stops it with the pen up (see `Terminal`).
    Stop::install_signals().context("cannot take the termination signals")?;
    if let Some(j) = &args.resume {
        let link = ResumeLink {
            port: args.port.as_deref(),
            baud: args.baud,
            hold_timeout: args.hold_timeout,
            pause_immediately: args.pause_immediately,
            trust_position: args.trust_position,
        };
        return resume(&link, j);
    }
    let input = args.input.as_deref().context("an input file is required")?;
    let mut profile = args.machine.load()?;
    if args.as_written {
        if !matches!(args.firmware, Firmware::Ours | Firmware::Auto) {
            bail!(
                "--as-written streams G-code to our firmware (the simulator or --firmware ours); a GRBL controller \
                 takes the file from any G-code sender"
            );
        }
        return crate::cmd::plot_as_written::run(
            input,
            &profile,
            args.port.as_deref(),
            args.baud,
            args.allow_long_dwell,
        );
    }
    if args.firmware == Firmware::Hpgl && args.export.is_none() {
        let port = args.port.as_deref().context(
            "--firmware hpgl needs --port (a plotter, or the model `plotter sim --pty --hpgl` serves on a pty)",
        )?;
        let layout = hpgl::layout_for(args)?;
        let (steps, drawing) = load_steps(input, &profile, &args.input_args, &layout, &args.optimize, None)?;
        return plot_hpgl(args, input, port, &profile, &steps, drawing, None);
    }
    if args.export.is_none() && args.port.is_none() && args.profile_from_machine {
        bail!("--profile-from-machine needs --port (a GRBL controller to read the settings from)");
    }
    if args.export.is_none() && args.port.is_none() && args.pen_change == PenChange::Pause {
        bail!(
            "--pen-change pause ends the plot at the first pen change for `plotter resume`, which needs --port \
             (the simulated plotter keeps no journal); use --pen-change prompt or none"
        );
    }
    if args.sim_speed.is_some() && (args.port.is_some() || args.export.is_some()) {
        bail!("--sim-speed paces the simulated plotter: it has no effect with --port or --export");
    }
    // The page meets the machine before anything connects: loaded and laid out on the profile's work area (or
    // an HP-GL export's sheets), refused with the fix when it cannot be drawn. A GRBL controller may supply the
    // profile (--profile-from-machine), so that plot is laid out and checked once connected.
    let layout = hpgl::layout_for(args)?;
    let early = match args.profile_from_machine {
        false => Some(load_page(input, &profile, &args.input_args, &layout)?),
        true => None,
    };
    let mut connected = match (&args.port, &args.export) {
        (Some(port), None) => Some(connect(args, port, &mut profile)?),
        _ => None,
    };
    let cfg = plan::machine_config(&profile)?;
    let baud = args.baud.unwrap_or(profile.link.baud);
    // The simulated plotter is connected before the drawing is ordered too, like a real one.
    let mut simulated = match (&connected, &args.export) {
        (None, None) => {
            let mut transport = SimTransport::new(cfg, Some(baud));
            if args.sim_noise > 0.0 {
                transport = transport.with_noise(plotter_host::link::faults::Noise::new(args.sim_noise, 1));
            }
            let paced = PacedSim::new(transport, args.sim_speed.unwrap_or(f64::INFINITY));
            Some(Session::connect(paced, "simulated plotter")?)
        }
        _ => None,
    };
    // Without homing, the order starts where the machine reports the pen, not at home.
    let pen_at = match (args.no_home, connected.as_mut(), simulated.as_mut()) {
        (true, Some(c), _) => Some(pen_on_page(c.machine(), &profile)?),
        (true, None, Some(s)) => Some(pen_on_page(s, &profile)?),
        _ => None,
    };
    let page = match early {
        Some(page) => page,
        None => load_page(input, &profile, &args.input_args, &layout)?,
    };
    let (steps, drawing) = order_steps(page, input, &profile, &args.optimize, pen_at)?;
    let export_ext = args
        .export
        .as_ref()
        .map(|out| out.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).unwrap_or_default());
    if let (Some(out), Some("hpgl" | "plt" | "hgl")) = (&args.export, export_ext.as_deref()) {
        // An HP-GL plotter has its own plotting area, checked by the export instead of the profile's.
        return export_hpgl(args, &profile, &steps, drawing, out);
    }
    plan::check_work_area(&profile, &steps)?;
    if let (Some(out), Some(ext)) = (&args.export, export_ext) {
        let text = match ext.as_str() {
            "gcode" | "nc" | "ngc" | "g" | "gco" => plotter_path::output::gcode_out::export(&profile, &steps),
            "traj" | "trj" | "txt" => trajectory::export(&steps),
            _ => bail!("--export {}: use a .gcode/.nc/.ngc/.g, .hpgl/.plt/.hgl or .traj/.txt file name", out.display()),
        };
        std::fs::write(out, text).with_context(|| format!("cannot write {}", out.display()))?;
        println!("{} strokes, {} moves written to {}", steps.strokes.len(), steps.move_count(), out.display());
        return Ok(());
    }
    // The plan's time and its dwell before anything moves (planned from home here; the job plans again from the
    // position the machine reports, which differs by the first travel at most).
    let firmware = connected.as_mut().map_or(Firmware::Ours, |c| c.machine().firmware());
    let ahead = plan::plan_returning(
        &plotter_host::link::machine::profile_for(&profile, firmware),
        &steps,
        plan::homed_position(&profile)?,
        plan::Lookahead::Whole,
        args.optimize.return_home,
    )?;
    let what = format!("{} ({} blocks)", input.display(), ahead.blocks.len());
    crate::time_parts::announce(&what, ahead.seconds(), crate::time_parts::dwell_s(&ahead), args.allow_long_dwell)?;
    drop(ahead);
    let mut terminal = Terminal::new(args.pause_immediately, args.pen_change)?;
    match connected.as_mut() {
        None => {
            let mut session = simulated.context("the simulated plotter is not connected")?;
            let outcome = with_workflow(args, &mut session, input, &profile, &steps, None, &mut terminal);
            terminal.bar.finish_and_clear();
            let (outcome, busy_before, copies) = outcome?;
            let sim = session.transport.inner().sim();
            // The last copy's own run against its plan; all copies' run on the next line.
            let executed = sim.hal().busy_ticks() - outcome.busy_before;
            println!("{}", summary(&outcome, Some(executed), args.verbose));
            if let Some(line) = copies_line(copies, &outcome.plan, Some(sim.hal().busy_ticks() - busy_before)) {
                println!("{line}");
            }
            // The plot is done: the figures and the preview that follow are side outputs, which warn rather than
            // turn a finished plot into a failure.
            if let Some(d) = &drawing {
                let bound = args
                    .optimize
                    .start_from(Some(&profile), pen_at)
                    .and_then(|start| print_lower_bound(&profile, &steps, d, &outcome.plan, args, start));
                if let Err(e) = bound {
                    eprintln!("warning: no lower bound for the plot time: {e:#}");
                }
            }
            let out = args.preview.clone().unwrap_or_else(|| default_beside(input, ".stepped.png"));
            let written = (|| -> anyhow::Result<()> {
                let (mut stepped, travel) = stepped_drawing(sim, &profile);
                stepped.page_mm = drawing.as_ref().and_then(|d| d.page_mm);
                let opts = preview::PreviewOptions { travel: args.travel, ..preview::PreviewOptions::default() };
                let pixmap = preview::render_with_travel(&stepped, &travel, &opts)?;
                preview::save_pixmap(&pixmap, &out)?;
                Ok(())
            })();
            match written {
                Ok(()) => println!("as-stepped preview: {}", out.display()),
                Err(e) => eprintln!("warning: the plot finished, but its as-stepped preview was not written: {e:#}"),
            }
            Ok(())
        }
        Some(c) => {
            let journal_path = journal_path(args, input, &profile.name)?;
            let source = |start: [i32; 4]| -> anyhow::Result<String> {
                Ok(serde_json::to_string(&PlotSource::here(input, &profile.name, start)?)?)
            };
            let spec = JournalSpec { path: &journal_path, source: &source };
            let outcome = with_workflow(args, c.machine(), input, &profile, &steps, Some(spec), &mut terminal);
            terminal.bar.finish_and_clear();
            let (outcome, _, copies) = outcome?;
            println!("{}", summary(&outcome, None, args.verbose));
            if let Some(line) = copies_line(copies, &outcome.plan, None) {
                println!("{line}");
            }
            if let (Connected::Grbl(g), true) = (&c, args.verbose) {
                println!("GRBL: at most {} bytes in flight (receive buffer {} bytes)", g.peak_in_flight, g.rx_bytes);
            }
            if let (Connected::Ebb(e), true) = (&c, args.verbose) {
                println!(
                    "EBB: board time {:.3} s; {} move(s) shorter than the board sustains",
                    e.program_seconds, e.short_moves
                );
            }
            Ok(())
        }
    }
}

/// The plot with its workflow (`--copies`, `--split-distance`, `--webhook`): the last copy's outcome, the
/// simulator's busy time before the first (see [`job::JobOutcome::busy_before`]) and how many copies were plotted. The webhook hears of pen
/// changes and pauses as they come, and of the end; its deliveries are waited for once the plot is over.
fn with_workflow<M: plotter_host::link::machine::PlotMachine + ?Sized>(
    args: &PlotArgs,
    machine: &mut M,
    input: &Path,
    profile: &MachineProfile,
    steps: &plotter_path::geometry::steps::StepDrawing,
    journal: Option<JournalSpec<'_>>,
    terminal: &mut Terminal,
) -> anyhow::Result<(job::JobOutcome, u64, usize)> {
    let copies = args.workflow.copies()?;
    let stops = job::stops::StopOptions { split_mm: args.workflow.split_mm()? };
    let (home, back) = (!args.no_home, args.optimize.return_home);
    let result = job::webhook::hooked(
        args.workflow.webhook.as_deref(),
        &profile.name,
        &drawing_name(input),
        true,
        terminal,
        |events| job::copies::plot_copies(machine, profile, steps, home, back, journal, &stops, &copies, events),
        job::copies::CopiesOutcome::summary,
    )?;
    let mut out = result?;
    if let Some(why) = &out.ended_early {
        eprintln!("{why}");
    }
    let busy_before = out.copies.first().map_or(0, |c| c.busy_before);
    let plotted = out.copies.len();
    let last = out.copies.pop().context("no copy was plotted")?;
    Ok((last, busy_before, plotted))
}

/// How a resumed plot reaches the machine: the options of `plot --resume` and `plotter resume` (everything else
/// comes from the journal).
pub(crate) struct ResumeLink<'a> {
    /// `--port`.
    pub(crate) port: Option<&'a str>,
    /// `--baud`, when given.
    pub(crate) baud: Option<u32>,
    /// `--hold-timeout`, seconds.
    pub(crate) hold_timeout: f64,
    /// `--pause-immediately`.
    pub(crate) pause_immediately: bool,
    /// `--trust-position`.
    pub(crate) trust_position: bool,
}

/// `plotter plot --resume JOURNAL` and `plotter resume`: continue the plot recorded in the journal on
/// `args.port` (a finished plot is said to be finished, and that is a success).
pub(crate) fn resume(args: &ResumeLink<'_>, journal_path: &Path) -> anyhow::Result<()> {
    let state = journal::load(journal_path)?;
    // A plot stopped or killed at a paper change finished its copy but still owes the copies left.
    if state.complete && plotter_host::state_dir::copies_left(&state.source).is_none() {
        println!("{}: that plot already finished; nothing to resume", journal_path.display());
        return Ok(());
    }
    // A plot started from another front end (the web app's journals record who wrote them) is resumed there.
    let written_by = serde_json::from_str::<serde_json::Value>(&state.source)
        .ok()
        .and_then(|v| v.get("front_end").and_then(serde_json::Value::as_str).map(str::to_string));
    if let Some(front_end) = written_by {
        bail!(
            "{}: that plot was started by {front_end}; resume it there (load the same drawing on the same machine and \
             press Resume)",
            journal_path.display()
        );
    }
    let source: PlotSource = serde_json::from_str(&state.source)
        .with_context(|| format!("{}: unreadable source line", journal_path.display()))?;
    refuse_quarter_turns(&source.args).with_context(|| format!("{}: cannot resume", journal_path.display()))?;
    let original = <PlotOnly as clap::Parser>::try_parse_from(std::iter::once("plot".to_string()).chain(source.args))
        .with_context(|| format!("{}: the recorded plot arguments no longer parse", journal_path.display()))?
        .args;
    let journal_path = std::path::absolute(journal_path)?;
    let journal_path = journal_path.as_path();
    std::env::set_current_dir(&source.cwd)
        .with_context(|| format!("cannot enter {}, where the plot was started", source.cwd.display()))?;
    let input = original.input.as_deref().context("the recorded plot has no input")?;
    let mut profile = original.machine.load()?;
    let port = args.port.context("resuming needs --port (the simulated plotter keeps no state)")?;
    if original.firmware == Firmware::Hpgl {
        let layout = hpgl::layout_for(&original)?;
        let (steps, drawing) = load_steps(input, &profile, &original.input_args, &layout, &original.optimize, None)?;
        let link = PlotArgs { baud: args.baud.or(original.baud), ..original.clone() };
        return plot_hpgl(&link, input, port, &profile, &steps, drawing, Some((&state, journal_path)));
    }
    let link = PlotArgs {
        baud: args.baud.or(original.baud),
        firmware: original.firmware,
        hold_timeout: args.hold_timeout,
        ..original.clone()
    };
    // Laid out and checked before connecting, as `run` does (with --profile-from-machine, once connected).
    let early = match original.profile_from_machine {
        false => Some(load_page(input, &profile, &original.input_args, &original.layout)?),
        true => None,
    };
    let mut c = connect(&link, port, &mut profile)?;
    // The order started where the original plot's plan did when that plot did not home.
    let pen_at = original.no_home.then(|| page_of(&profile, source.start));
    let page = match early {
        Some(page) => page,
        None => load_page(input, &profile, &original.input_args, &original.layout)?,
    };
    let (steps, _) = order_steps(page, input, &profile, &original.optimize, pen_at)?;
    // As the plot planned it: several copies each end back where they started; the refills in the same places.
    let copies = original.workflow.copies()?;
    let stops = job::stops::StopOptions { split_mm: original.workflow.split_mm()? };
    let back = job::copies::returns(original.optimize.return_home, &copies);
    let planned = plotter_host::link::machine::profile_for(&profile, c.machine().firmware());
    let full = plan::plan_returning(&planned, &steps, source.start, plan::Lookahead::Whole, back)?;
    if full.geometry_hash() != state.plan_hash || full.blocks.len() != state.blocks {
        bail!(
            "{} no longer gives the plan recorded in {} (the input or the profile changed)",
            input.display(),
            journal_path.display()
        );
    }
    let mut terminal = Terminal::new(args.pause_immediately, original.pen_change)?;
    // The copy the journal was drawing, then the copies left; the plot's webhook hears the resume's events.
    let outcome = job::webhook::hooked(
        original.workflow.webhook.as_deref(),
        &profile.name,
        &drawing_name(input),
        true,
        &mut terminal,
        |events| {
            job::copies::resume_copies(
                c.machine(),
                &profile,
                &steps,
                source.start,
                &state,
                journal_path,
                args.trust_position,
                original.optimize.return_home,
                &stops,
                &copies,
                events,
            )
        },
        job::copies::CopiesOutcome::summary,
    );
    terminal.bar.finish_and_clear();
    let outcome = outcome?;
    let mut outcome = outcome?;
    if let Some(why) = &outcome.ended_early {
        eprintln!("{why}");
    }
    let plotted = outcome.copies.len();
    let last = outcome.copies.pop().context("no copy was plotted")?;
    if last.drawn_before && plotted == 1 {
        println!("{}: the drawing had been finished; nothing was left to plot", journal_path.display());
        return Ok(());
    }
    // As verbose as the plot it resumes.
    println!("{}", summary(&last, None, original.verbose));
    if plotted > 1 {
        println!("{plotted} copies plotted on resume (the one under way and the {} left)", plotted - 1);
    }
    Ok(())
}
