//! `plotter plot FILE.gcode --as-written`: play plotter G-code exactly as the file states it — every move at its
//! feed (`G0` at the machine's top speed), every pen lift as a Z move, every dwell — on the simulated plotter or a
//! plotter running our firmware (`--port`). Nothing is re-ordered, merged or re-planned into our overlapped pen
//! hops: this is what a G-code sender does with the file, and what `plotter plot FILE.gcode` (which reads the file
//! as a drawing) improves on.
//!
//! The file is interpreted by the print playback ([`plotter_path::input::gcode_print`], GRBL's reading of `G0` and
//! `G4 P` when the profile has no extruder), planned with the shared planner
//! ([`plotter_path::motion::print_plan`]) — so the exact motion time is known before anything moves — and streamed
//! ([`plotter_host::link::print`]). The machine is homed first; every way the run ends leaves the pen up: Ctrl-C
//! (or SIGTERM, SIGHUP) and errors stop the machine and raise the pen, and a file that ends with the pen down gets it
//! raised.

use std::path::Path;

use anyhow::{Context as _, bail};
use plotter_fw::TICK_HZ;
use plotter_host::input::{InputKind, input_kind};
use plotter_host::link::Transport;
use plotter_host::link::print::{Played, PrintControl, PrintProgress, stream_print};
use plotter_host::link::serial::SerialTransport;
use plotter_host::link::session::Session;
use plotter_host::link::sim::SimTransport;
use plotter_path::MachineProfile;
use plotter_path::config::profile::PenCommand;
use plotter_path::input::gcode_print::{PrintOp, import_print};
use plotter_path::motion::plan;
use plotter_path::motion::print_plan::{PrintPlan, plan_print};

/// Progress on stderr (one line per 10 %), Ctrl-C as a stop request.
struct Console {
    interrupt: &'static plotter_host::stop::Stop,
    shown_tenths: usize,
}

impl PrintControl for Console {
    fn progress(&mut self, p: &PrintProgress) {
        let tenths = (p.accepted * 10).checked_div(p.items).unwrap_or(10);
        if tenths > self.shown_tenths {
            self.shown_tenths = tenths;
            eprintln!("{}% sent", tenths * 10);
        }
    }
    fn note(&mut self, message: &str) {
        eprintln!("{message}");
    }
    fn stop_requested(&mut self) -> bool {
        self.interrupt.any()
    }
}

/// Read, interpret and plan `input` for `profile`. The plan starts with the machine homed (the homing is done by
/// the session before the stream, so the plan carries none).
fn plan_file(input: &Path, profile: &MachineProfile) -> anyhow::Result<PrintPlan> {
    let shown = input.display().to_string();
    let bytes = std::fs::read(input).with_context(|| format!("cannot read {shown}"))?;
    if input_kind(input, &bytes) != InputKind::Gcode {
        bail!("{shown}: --as-written plays G-code files only");
    }
    let text = String::from_utf8(bytes).map_err(|e| anyhow::anyhow!("{shown}: not UTF-8 text ({e})"))?;
    let mut program = import_print(&text, &shown, profile)?;
    for w in &program.warnings {
        eprintln!("warning: {shown}: {w}");
    }
    // A homing at the head keeps the planner from adding its own; the session homes instead (see above).
    program.ops.insert(0, PrintOp::Home { axes: 0, line: 0 });
    let mut plan = plan_print(profile, &program).with_context(|| shown.clone())?;
    plan.items.remove(0);
    Ok(plan)
}

/// Home, stream `plan`, and say how long it took (`executed` counts the stepper's time after homing).
fn play<T: Transport>(
    mut session: Session<T>,
    plan: &PrintPlan,
    machine: Played,
    busy: impl Fn(&Session<T>) -> Option<u64>,
    interrupt: &'static plotter_host::stop::Stop,
) -> anyhow::Result<()> {
    session.home()?;
    let before = busy(&session);
    let mut console = Console { interrupt, shown_tenths: 0 };
    let stats = stream_print(&mut session, plan, machine, &mut console)?;
    // Display only: tick counts fit f64's mantissa.
    #[allow(clippy::cast_precision_loss)]
    let ticks_to_s = |t: u64| t as f64 / f64::from(TICK_HZ);
    let mut line = format!("{} blocks as written; planned time {:.3} s", plan.block_count(), plan.seconds());
    if let (Some(b), Some(a)) = (before, busy(&session)) {
        line += &format!(", executed {:.3} s", ticks_to_s(a - b));
    }
    println!("{line}");
    if stats.resent > 0 || stats.refused > 0 {
        println!("link: {} items resent, {} lines refused", stats.resent, stats.refused);
    }
    Ok(())
}

/// Run `plotter plot INPUT --as-written` on the simulated plotter, or on our firmware at `port` (the caller has
/// checked that the firmware is ours); `baud` overrides the profile's. The planned time and its dwell are printed
/// before the machine is even connected; a plan standing still for over an hour needs a terminal or
/// `allow_long_dwell` (see [`crate::time_parts::announce`]).
pub(crate) fn run(
    input: &Path,
    profile: &MachineProfile,
    port: Option<&str>,
    baud: Option<u32>,
    allow_long_dwell: bool,
) -> anyhow::Result<()> {
    if profile.pen.command != PenCommand::Z {
        bail!("--as-written needs a Z-lift pen (the profile's pen.command is servo): plot the file without it");
    }
    // Ctrl-C, SIGTERM and SIGHUP stop the run the safe way.
    let interrupt = plotter_host::stop::Stop::install_signals().context("cannot take the termination signals")?;
    let plan = plan_file(input, profile)?;
    let what = format!("{} as written ({} blocks)", input.display(), plan.block_count());
    crate::time_parts::announce(&what, plan.seconds(), plan.dwell_seconds(), allow_long_dwell)?;
    let machine = Played::Plotter { up_z_mm: profile.pen.up_z_mm, z_steps_per_mm: profile.axes.z.steps_per_mm };
    let cfg = plan::machine_config(profile)?;
    let baud = baud.unwrap_or(profile.link.baud);
    match port {
        None => {
            let session = Session::connect(SimTransport::new(cfg, Some(baud)), "simulated plotter")?;
            play(session, &plan, machine, |s| Some(s.transport.sim().hal().busy_ticks()), interrupt)
        }
        Some(port) => {
            let session = Session::connect(SerialTransport::open(port, baud)?, port)?;
            play(session, &plan, machine, |_| None, interrupt)
        }
    }
}
