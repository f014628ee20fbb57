//! `plotter plot` on an HP-GL plotter: the export for `--hpgl-device`, written to a file or streamed under a buffer
//! handshake with a journal.

use std::path::Path;

use anyhow::{Context as _, bail};
use plotter_host::link::journal;
use plotter_host::link::machine::Firmware;
use plotter_host::options::layout::LayoutArgs;
use plotter_path::MachineProfile;
use plotter_path::geometry::bed::Bed;
use plotter_path::geometry::hpgl_devices::HpglDevice;

use super::terminal::{PenChange, Terminal};
use super::{PlotArgs, PlotSource, journal_path};

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
    let (device, paper) = device_and_sheet(args)?;
    let drawing = drawing
        .unwrap_or_else(|| steps.to_drawing(&plotter_path::geometry::steps::StepMapper::new(profile), "trajectory"));
    let (program, paper) = plotter_host::job::hpgl::program_for(profile, &drawing, device, paper)?;
    plotter_host::input::warn_all(&program.warnings);
    Ok((program, device, paper, drawing.path_count()))
}

/// The plotter `--hpgl-device` names and the sheet `--hpgl-paper` names (none: the one that suits the page).
fn device_and_sheet(
    args: &PlotArgs,
) -> anyhow::Result<(&'static HpglDevice, Option<&'static plotter_path::geometry::hpgl_devices::HpglPaper>)> {
    use plotter_path::geometry::hpgl_devices;
    let device = hpgl_devices::device(&args.hpgl_device).with_context(|| {
        format!("--hpgl-device {}: not a known plotter (known: {})", args.hpgl_device, hpgl_devices::device_names())
    })?;
    let paper = match (&args.hpgl_paper, device.papers.is_empty()) {
        (Some(name), false) => Some(
            device
                .paper(name)
                .with_context(|| format!("--hpgl-paper {name}: the {} takes {}", device.name, device.paper_names()))?,
        ),
        (Some(_), true) => bail!("--hpgl-paper: the {} plots on the drawing's own page", device.name),
        (None, _) => None,
    };
    Ok((device, paper))
}

/// The layout flags with the machine the page is laid out for: for a plot that goes to an HP-GL plotter (an
/// `.hpgl`/`.plt`/`.hgl` export, or `--firmware hpgl`) its sheets, or the one `--hpgl-paper` names; otherwise as
/// given (the profile's work area).
pub(super) fn layout_for(args: &PlotArgs) -> anyhow::Result<LayoutArgs> {
    let ext = args.export.as_ref().and_then(|o| o.extension()).and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    let to_hpgl = match ext {
        Some(e) => matches!(e.as_str(), "hpgl" | "plt" | "hgl"),
        None => args.firmware == Firmware::Hpgl,
    };
    if !to_hpgl {
        return Ok(args.layout.clone());
    }
    let (device, sheet) = device_and_sheet(args)?;
    Ok(LayoutArgs { bed: Some(Bed::hpgl(device, sheet)), ..args.layout.clone() })
}

/// `--export FILE.hpgl`: write the HP-GL program.
pub(super) fn export_hpgl(
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
pub(super) fn plot_hpgl(
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
            let machine = device.name;
            let path = journal_path(args, input, machine)?;
            let source = PlotSource::here(input, machine, [0; 4])?;
            (journal::Journal::create(&path, &serde_json::to_string(&source)?, hash, cmds.list.len())?, 0, path)
        }
    };
    let mut terminal = Terminal::new(args.pause_immediately, PenChange::None)?;
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
