//! `plotter plot`: load a drawing (SVG, G-code or trajectory file), plan it with the firmware's planner, and run it
//! on the built-in simulated plotter (default, writes the as-stepped preview) or stream it to a serial device
//! running our firmware or GRBL. Between layers drawn with different pens the plot parks and asks for the pen
//! (Enter continue, `s` skip the layer, `q` stop and keep the journal).

use std::io::{BufRead as _, IsTerminal as _, Write as _};
use std::path::{Path, PathBuf};

use anyhow::{Context as _, bail};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use plotter_fw::TICK_HZ;
use plotter_host::input::InputArgs;
use plotter_host::job::load::{load_steps, page_of, pen_on_page};
use plotter_host::job::progress::{JobProgress, PenChangeChoice, PenChangeMode, PenChangeRequest, PlotEvents};
use plotter_host::job::stepped::stepped_drawing;
use plotter_host::job::{self, JobOutcome, JournalSpec};
use plotter_host::link::hpgl::handshake::Handshake;
use plotter_host::link::journal;
use plotter_host::link::machine::{Connected, Firmware};
use plotter_host::link::serial::SerialTransport;
use plotter_host::link::session::Session;
use plotter_host::link::sim::SimTransport;
use plotter_host::link::stream::PauseChoice;
use plotter_host::options::layout::LayoutArgs;
use plotter_host::options::machine::MachineArgs;
use plotter_host::options::optimize::OptimizeArgs;
use plotter_host::stop::Stop;
use plotter_path::MachineProfile;
use plotter_path::config::pens::LayerPen;
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
    /// GRBL: how long a feed hold nobody resumes (the controller's Hold button) may last, seconds, before the
    /// plot stops and lifts the pen.
    #[arg(long, default_value_t = 30.0, value_parser = hold_seconds)]
    pub(crate) hold_timeout: f64,
    /// The plotter's firmware: ours, GRBL 1.1 (grblHAL, FluidNC), ebb (AxiDraw-class EiBotBoard), hpgl (a
    /// vintage HP-GL plotter, sent the HP-GL export for --hpgl-device), or auto (told by its start-up banner or
    /// its answers).
    #[arg(long, value_enum, default_value_t = Firmware::Auto)]
    pub(crate) firmware: Firmware,
    /// Between layers drawn with different pens: park with the pen up and wait for the new pen (pause), or plot
    /// straight through (none).
    #[arg(long, value_enum, default_value_t = PenChangeMode::Pause)]
    pub(crate) pen_change: PenChangeMode,
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
    /// Start a plan that stands still for over an hour in dwells (G4 with --as-written, or pen settles) even
    /// without a terminal on stdin; at a terminal such a plan starts after a loud warning.
    #[arg(long)]
    pub(crate) allow_long_dwell: bool,
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

/// `--hold-timeout`: a positive number of seconds, at most a day.
fn hold_seconds(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v > 0.0 && v <= 86_400.0 => Ok(v),
        _ => Err(format!("{s:?} is not a number of seconds between 0 and 86400")),
    }
}

/// The terminal's side of a plot: progress bar, Ctrl-C pause requests (SIGTERM, SIGHUP, SIGQUIT and a second
/// Ctrl-C stop the plot: [`plotter_host::stop`]), and the resume-or-abort prompt.
struct Terminal {
    bar: ProgressBar,
    stop: &'static Stop,
    immediately: bool,
    pen_change: PenChangeMode,
}

/// One answer line from the user: `None` at the end of input, or when a stop arrives while waiting for it (any
/// signal, a Ctrl-C included: nobody resumes a prompt they interrupted).
fn ask(stop: &Stop, prompt: &str) -> Option<String> {
    use std::os::fd::AsFd as _;
    eprint!("{prompt}");
    let _ = std::io::stderr().flush();
    let stdin = std::io::stdin();
    loop {
        if stop.stop_cause_or_interrupt().is_some() {
            eprintln!();
            return None;
        }
        let mut fds = [nix::poll::PollFd::new(stdin.as_fd(), nix::poll::PollFlags::POLLIN)];
        match nix::poll::poll(&mut fds, nix::poll::PollTimeout::from(100u8)) {
            Ok(0) | Err(nix::errno::Errno::EINTR) => {}
            Ok(_) => break,
            Err(_) => return None,
        }
    }
    let mut line = String::new();
    match stdin.lock().read_line(&mut line) {
        Ok(n) if n > 0 => Some(line.trim().to_string()),
        _ => None,
    }
}

impl Terminal {
    /// The terminal of a plot about to stream: from now on one Ctrl-C pauses the plot (before, it ends the command).
    fn new(immediately: bool, pen_change: PenChangeMode) -> anyhow::Result<Self> {
        let stop = Stop::install_signals().context("cannot take the termination signals")?;
        // A signal while the drawing was loaded, ordered or planned (work that does not stop midway) ends the
        // command before anything moves, rather than pausing the plot it was meant to prevent.
        if let Some(cause) = stop.stop_cause() {
            let doing = "the plot was prepared (nothing moved)".to_string();
            return Err(plotter_host::stop::Stopped { cause, doing }.into());
        }
        stop.set_pausable(true);
        let target = if std::io::stderr().is_terminal() {
            ProgressDrawTarget::stderr_with_hz(5)
        } else {
            ProgressDrawTarget::hidden()
        };
        let bar = ProgressBar::with_draw_target(None, target);
        if let Ok(style) = ProgressStyle::with_template("{bar:30} {percent:>3}% {pos}/{len} blocks  {msg}")
            .map(|s| s.progress_chars("█▉ "))
        {
            bar.set_style(style);
        }
        Ok(Terminal { bar, stop, immediately, pen_change })
    }
}

impl PlotEvents for Terminal {
    fn progress(&mut self, p: &JobProgress) {
        self.bar.set_length(u64::try_from(p.total).unwrap_or(u64::MAX));
        self.bar.set_position(u64::try_from(p.executed).unwrap_or(u64::MAX));
        self.bar.set_message(format!(
            "pen-down {:.0}/{:.0} mm  ETA {:.0} s  resends {}  pen {} at X {:.1}, Y {:.1} mm",
            p.draw_done_mm,
            p.draw_total_mm,
            p.eta_s,
            p.resends,
            if p.pen_down { "down" } else { "up" },
            p.pen_mm.x,
            p.pen_mm.y
        ));
    }

    fn pause_requested(&mut self) -> Option<bool> {
        self.stop.take_pause().then_some(self.immediately)
    }

    fn paused(&mut self, held: bool) -> PauseChoice {
        let what = if held { "feed hold (pen where it stopped)" } else { "paused with the pen up" };
        self.bar.suspend(|| match ask(self.stop, &format!("\n{what}: [r]esume or [a]bort? ")) {
            Some(l) if l.starts_with(['r', 'R']) => PauseChoice::Resume,
            _ => PauseChoice::Abort,
        })
    }

    fn pen_change_mode(&self) -> PenChangeMode {
        self.pen_change
    }

    fn plot_started(&mut self, first_pen: &LayerPen, pen_changes: usize) {
        if pen_changes > 0 && self.pen_change == PenChangeMode::Pause {
            self.bar.suspend(|| {
                eprintln!("this plot uses {} pens: start with {}", pen_changes + 1, first_pen.label());
            });
        }
    }

    fn pen_change(&mut self, c: &PenChangeRequest) -> PenChangeChoice {
        self.bar.suspend(|| {
            let whence = if c.park_mm.0.is_finite() {
                format!("parked at X{:.1} Y{:.1} with the pen up", c.park_mm.0, c.park_mm.1)
            } else {
                "before the plot continues".to_string()
            };
            let from = c.previous.as_ref().map(|p| format!(" (replacing {})", p.label())).unwrap_or_default();
            eprintln!(
                "\npen change {}/{}: {whence}; load pen {}{from} for layer {:?}",
                c.number,
                c.total,
                c.pen.label(),
                c.layer_name
            );
            loop {
                match ask(self.stop, "[Enter] continue, [s] skip this layer, [q] stop (the journal keeps the plot): ") {
                    Some(l) if l.is_empty() => return PenChangeChoice::Continue,
                    Some(l) if l.eq_ignore_ascii_case("s") => return PenChangeChoice::SkipLayer,
                    Some(l) if l.eq_ignore_ascii_case("q") => return PenChangeChoice::Stop,
                    Some(l) => eprintln!("{l:?}: answer with Enter, s or q"),
                    None => {
                        eprintln!("no answer (input closed): stopping");
                        return PenChangeChoice::Stop;
                    }
                }
            }
        })
    }

    fn notice(&mut self, text: &str) {
        self.bar.suspend(|| eprintln!("\n{text}"));
    }

    fn unlock_alarm(&mut self, what: &str) -> bool {
        self.bar.suspend(|| {
            eprintln!("{what}");
            matches!(ask(self.stop, "unlock it ($X)? The position may be wrong after some alarms. [y/N] "), Some(l) if l.eq_ignore_ascii_case("y"))
        })
    }
}

/// Human summary of a finished plot.
fn summary(outcome: &JobOutcome, executed_ticks: Option<u64>) -> String {
    let stops = if outcome.pen_stops > 0 {
        let skipped = if outcome.skipped.is_empty() {
            String::new()
        } else {
            format!(", skipped {}", outcome.skipped.iter().map(|l| format!("{l:?}")).collect::<Vec<_>>().join(", "))
        };
        format!("\npen changes: {}{skipped}", outcome.pen_stops)
    } else {
        String::new()
    };
    let (plan, stats) = (&outcome.plan, &outcome.stats);
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
    s + &stops
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

fn default_beside(input: &Path, suffix: &str) -> PathBuf {
    // A generated figure `gen:KIND?params` is named after its kind.
    let generated = input.to_str().and_then(|p| p.strip_prefix(plotter_host::input::GEN_PREFIX));
    let stem = match generated {
        Some(spec) => spec.split('?').next().filter(|k| !k.is_empty() && !k.contains('/')).unwrap_or("figure"),
        None => input.file_stem().and_then(|s| s.to_str()).unwrap_or("plot"),
    };
    PathBuf::from(format!("{stem}{suffix}"))
}

/// Print the plot-time lower bound next to the planned time, and both split into drawing, travel and lifts (see
/// [`plotter_path::motion::bound`]); the order's travel bound is taken from `start`, where the order started.
fn print_lower_bound(
    profile: &plotter_path::MachineProfile,
    steps: &plotter_path::geometry::steps::StepDrawing,
    drawing: &plotter_path::Drawing,
    plan: &plotter_path::motion::plan::MotionPlan,
    args: &PlotArgs,
    start: Option<plotter_path::kurbo::Point>,
) -> anyhow::Result<()> {
    use plotter_path::output::stats::{fixed, percent_above};
    let seam = args.optimize.options(Some(profile))?.seam;
    let b = plotter_path::motion::bound::drawing_time_lower_bound(profile, steps, drawing, seam, start)?;
    // Nothing to compare with when the bound is zero (nothing to draw).
    let above = percent_above(plan.seconds(), b.total_s())
        .map_or(String::new(), |p| format!(": planned time is {} % above it", fixed(p, 1)));
    println!(
        "lower bound {} s (pen down {} s, {} lifts {} s, travel {} s){above}",
        fixed(b.total_s(), 3),
        fixed(b.draw_s, 1),
        steps.strokes.len(),
        fixed(b.lifts_s, 1),
        fixed(b.travel_s, 1),
    );
    println!("{}", crate::time_parts::line(&plan.breakdown(), &b));
    Ok(())
}

/// The page drawing as HP-GL for `--hpgl-device` on `--hpgl-paper` (or the first of its sheets that holds the
/// drawing), with the device and the sheet.
fn hpgl_program(
    args: &PlotArgs,
    profile: &MachineProfile,
    steps: &plotter_path::geometry::steps::StepDrawing,
    drawing: Option<plotter_path::Drawing>,
) -> anyhow::Result<(
    plotter_path::output::hpgl_out::HpglProgram,
    &'static plotter_path::geometry::hpgl_devices::HpglDevice,
    plotter_path::geometry::hpgl_devices::HpglPaper,
    usize,
)> {
    use plotter_path::geometry::hpgl_devices;
    let device = hpgl_devices::device(&args.hpgl_device).with_context(|| {
        format!("--hpgl-device {}: not a known plotter (known: {})", args.hpgl_device, hpgl_devices::device_names())
    })?;
    let drawing = drawing
        .unwrap_or_else(|| steps.to_drawing(&plotter_path::geometry::steps::StepMapper::new(profile), "trajectory"));
    let paper = match (&args.hpgl_paper, device.papers.is_empty()) {
        (Some(name), false) => Some(
            device
                .paper(name)
                .with_context(|| format!("--hpgl-paper {name}: the {} takes {}", device.name, device.paper_names()))?,
        ),
        (Some(_), true) => bail!("--hpgl-paper: the {} plots on the drawing's own page", device.name),
        (None, _) => None,
    };
    let (program, paper) = plotter_host::job::hpgl::program_for(profile, &drawing, device, paper)?;
    plotter_host::input::warn_all(&program.warnings);
    Ok((program, device, paper, drawing.path_count()))
}

/// `--export FILE.hpgl`: write the HP-GL program.
fn export_hpgl(
    args: &PlotArgs,
    profile: &MachineProfile,
    steps: &plotter_path::geometry::steps::StepDrawing,
    drawing: Option<plotter_path::Drawing>,
    out: &Path,
) -> anyhow::Result<()> {
    let (program, device, paper, strokes) = hpgl_program(args, profile, steps, drawing)?;
    std::fs::write(out, &program.text).with_context(|| format!("cannot write {}", out.display()))?;
    println!("{strokes} strokes for the {} on {} written to {}", device.name, paper.name, out.display());
    Ok(())
}

/// `--firmware hpgl --port DEV`: stream the HP-GL program to the plotter (or, with `resume`, continue the plot a
/// journal recorded).
fn plot_hpgl(
    args: &PlotArgs,
    input: &Path,
    port: &str,
    profile: &MachineProfile,
    steps: &plotter_path::geometry::steps::StepDrawing,
    drawing: Option<plotter_path::Drawing>,
    resume: Option<(&journal::JournalState, &Path)>,
) -> anyhow::Result<()> {
    use plotter_host::job::hpgl as hplot;
    use plotter_host::link::hpgl::{commands::Commands, port::HpglPort, sender::HpglSession};
    let (program, device, paper, _) = hpgl_program(args, profile, steps, drawing)?;
    let cmds = Commands::split(&program.text, device);
    let hash = hplot::program_hash(&program.text);
    if let Some((state, path)) = resume
        && (state.plan_hash != hash || state.blocks != cmds.list.len())
    {
        bail!("{} no longer gives the HP-GL program recorded in {}", input.display(), path.display());
    }
    let mut s = HpglSession::connect(HpglPort::open(port, args.baud.unwrap_or(9600))?, port, device, args.handshake)?;
    eprintln!("{} on {port} (buffer {} bytes, handshake {})", s.identity, s.buffer_bytes, args.handshake.name());
    for w in &s.warnings {
        eprintln!("warning: {w}");
    }
    let (journal, from, path) = match resume {
        Some((state, path)) => {
            (journal::Journal::append(path, state)?, hplot::resume_point(state.executed, &cmds), path.to_path_buf())
        }
        None => {
            let path = args.journal.clone().unwrap_or_else(|| default_beside(input, ".journal"));
            let source = PlotSource {
                cwd: std::env::current_dir().context("no current directory")?,
                args: std::env::args().skip_while(|a| a != "plot").skip(1).collect(),
                start: [0; 4],
            };
            (journal::Journal::create(&path, &serde_json::to_string(&source)?, hash, cmds.list.len())?, 0, path)
        }
    };
    let mut terminal = Terminal::new(args.pause_immediately, PenChangeMode::None)?;
    let outcome = hplot::plot(&mut s, &cmds, &paper, from, Some(journal), Some(&path), &mut terminal);
    terminal.bar.finish_and_clear();
    let o = outcome?;
    // Display only.
    #[allow(clippy::cast_precision_loss)]
    let (bytes, cmds_sent) = (o.stats.bytes as f64, (o.commands - o.from) as f64);
    println!(
        "{} commands (from command {}), {:.1} mm pen-down; {} bytes in {:.1} s: {:.0} bytes/s, {:.1} commands/s \
         (the program's estimated plotter time {:.1} s)",
        o.commands,
        o.from + 1,
        o.draw_mm,
        o.stats.bytes,
        o.seconds,
        bytes / o.seconds.max(1e-9),
        cmds_sent / o.seconds.max(1e-9),
        o.estimated_s
    );
    println!(
        "handshake {}: {} ESC . B queries, {} Xoffs, {} waits for room",
        args.handshake.name(),
        o.stats.space_queries,
        o.stats.xoffs,
        o.stats.waits
    );
    Ok(())
}

/// Run `plotter plot`.
pub(crate) fn run(args: &PlotArgs) -> anyhow::Result<()> {
    // From the start: a signal while loading or connecting ends the command (imports stop early), one during the
    // plot pauses it or stops it with the pen up (see `Terminal`).
    Stop::install_signals().context("cannot take the termination signals")?;
    if let Some(j) = &args.resume {
        return resume(args, j);
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
        let (steps, drawing) = load_steps(input, &profile, &args.input_args, &args.layout, &args.optimize, None)?;
        return plot_hpgl(args, input, port, &profile, &steps, drawing, None);
    }
    if args.export.is_none() && args.port.is_none() && args.profile_from_machine {
        bail!("--profile-from-machine needs --port (a GRBL controller to read the settings from)");
    }
    // A GRBL controller may supply the profile, so connect before converting the drawing.
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
            Some(Session::connect(transport, "simulated plotter")?)
        }
        _ => None,
    };
    // Without homing, the order starts where the machine reports the pen, not at home.
    let pen_at = match (args.no_home, connected.as_mut(), simulated.as_mut()) {
        (true, Some(c), _) => Some(pen_on_page(c.machine(), &profile)?),
        (true, None, Some(s)) => Some(pen_on_page(s, &profile)?),
        _ => None,
    };
    let (steps, drawing) = load_steps(input, &profile, &args.input_args, &args.layout, &args.optimize, pen_at)?;
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
    let ahead = plan::plan_returning(
        &profile,
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
            let outcome = job::plot(
                &mut session,
                &profile,
                &steps,
                !args.no_home,
                args.optimize.return_home,
                None,
                &mut terminal,
            );
            terminal.bar.finish_and_clear();
            let outcome = outcome?;
            let sim = session.transport.sim();
            let executed = sim.hal().busy_ticks() - outcome.busy_before;
            println!("{}", summary(&outcome, Some(executed)));
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
            let journal_path = args.journal.clone().unwrap_or_else(|| default_beside(input, ".journal"));
            let source = |start: [i32; 4]| -> anyhow::Result<String> {
                let source = PlotSource {
                    cwd: std::env::current_dir().context("no current directory")?,
                    args: std::env::args().skip_while(|a| a != "plot").skip(1).collect(),
                    start,
                };
                Ok(serde_json::to_string(&source)?)
            };
            let spec = JournalSpec { path: &journal_path, source: &source };
            let back = args.optimize.return_home;
            let outcome = job::plot(c.machine(), &profile, &steps, !args.no_home, back, Some(spec), &mut terminal);
            terminal.bar.finish_and_clear();
            let outcome = outcome?;
            println!("{}", summary(&outcome, None));
            if let Connected::Grbl(g) = c {
                println!("GRBL: at most {} bytes in flight (receive buffer {} bytes)", g.peak_in_flight, g.rx_bytes);
            }
            if let Connected::Ebb(e) = c {
                println!(
                    "EBB: board time {:.3} s; {} move(s) shorter than the board sustains",
                    e.program_seconds, e.short_moves
                );
            }
            Ok(())
        }
    }
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
    let mut profile = original.machine.load()?;
    let port = args.port.as_deref().context("--resume needs --port (the simulated plotter keeps no state)")?;
    if original.firmware == Firmware::Hpgl {
        let (steps, drawing) =
            load_steps(input, &profile, &original.input_args, &original.layout, &original.optimize, None)?;
        let link = PlotArgs { baud: args.baud.or(original.baud), ..original.clone() };
        return plot_hpgl(&link, input, port, &profile, &steps, drawing, Some((&state, journal_path)));
    }
    let link = PlotArgs {
        baud: args.baud.or(original.baud),
        firmware: original.firmware,
        hold_timeout: args.hold_timeout,
        ..original.clone()
    };
    let mut c = connect(&link, port, &mut profile)?;
    // The order started where the original plot's plan did when that plot did not home.
    let pen_at = original.no_home.then(|| page_of(&profile, source.start));
    let (steps, _) = load_steps(input, &profile, &original.input_args, &original.layout, &original.optimize, pen_at)?;
    let back = original.optimize.return_home;
    let full = plan::plan_returning(&profile, &steps, source.start, plan::Lookahead::Whole, back)?;
    if full.geometry_hash() != state.plan_hash || full.blocks.len() != state.blocks {
        bail!(
            "{} no longer gives the plan recorded in {} (the input or the profile changed)",
            input.display(),
            journal_path.display()
        );
    }
    let mut terminal = Terminal::new(args.pause_immediately, original.pen_change)?;
    let outcome = job::resume(
        c.machine(),
        &profile,
        &steps,
        source.start,
        &state,
        journal_path,
        args.trust_position,
        back,
        &mut terminal,
    );
    terminal.bar.finish_and_clear();
    println!("{}", summary(&outcome?, None));
    Ok(())
}
