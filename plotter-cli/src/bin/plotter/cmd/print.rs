//! `plotter print FILE.gcode --profile samples/printer.toml`: play slicer G-code (PrusaSlicer, Cura; Marlin
//! flavour) on the simulated printer, or on a printer running our firmware (`--port`).
//!
//! The file is interpreted ([`plotter_path::input::gcode_print`]), planned with the shared planner
//! ([`plotter_path::motion::print_plan`]) — which gives the exact motion time before anything moves — and streamed
//! ([`crate::link::print`]). The progress line shows the layer and the temperatures; the summary puts our time
//! estimate next to the slicer's own (from the file's comments).
//!
//! Simulator faults for trying the thermal protection: `--fault hotend-open@90` breaks the hot-end thermistor 90 s
//! (virtual time) into the print; kinds are `{hotend,bed}-{open,short,cartridge,adc}`.

use std::io::IsTerminal as _;
use std::path::PathBuf;

use anyhow::{Context as _, bail};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use plotter_fw::heater::Heater;
use plotter_fw::sim::thermal::SimFault;
use plotter_fw::{Axis, TICK_HZ};
use plotter_path::config::profile::thermal_config;
use plotter_path::input::gcode_print::import_print;
use plotter_path::motion::plan;
use plotter_path::motion::print_plan::plan_print;

use plotter_host::job::load::load_profile;
use plotter_host::link::print::{Played, PrintControl, PrintProgress, PrinterSim, ScheduledFault, stream_print};
use plotter_host::link::serial::SerialTransport;
use plotter_host::link::session::Session;

/// Arguments of `plotter print`.
#[derive(clap::Args, Debug, Clone)]
pub(crate) struct PrintArgs {
    /// Slicer G-code (Marlin flavour).
    pub(crate) input: PathBuf,
    /// Printer profile (TOML) with an extruder and heaters, e.g. samples/printer.toml.
    #[arg(long)]
    pub(crate) profile: PathBuf,
    /// Serial port of a printer running plotter-fw (default: the built-in simulator).
    #[arg(long)]
    pub(crate) port: Option<String>,
    /// Baud rate (default: the profile's).
    #[arg(long)]
    pub(crate) baud: Option<u32>,
    /// Simulator only: inject a fault, `KIND@SECONDS` (virtual time), KIND one of hotend-open, hotend-short,
    /// hotend-cartridge, hotend-adc, bed-open, bed-short, bed-cartridge, bed-adc. Repeatable.
    #[arg(long, value_parser = parse_fault)]
    pub(crate) fault: Vec<(Heater, SimFault, f64)>,
}

fn parse_fault(s: &str) -> Result<(Heater, SimFault, f64), String> {
    let (kind, at) = s.split_once('@').ok_or("expected KIND@SECONDS, e.g. hotend-open@90")?;
    let at: f64 = at.parse().ok().filter(|v: &f64| v.is_finite() && *v >= 0.0).ok_or("SECONDS must be a number ≥ 0")?;
    let (heater, fault) = kind.split_once('-').ok_or("KIND is HEATER-FAULT, e.g. hotend-open")?;
    let heater = match heater {
        "hotend" => Heater::HotEnd,
        "bed" => Heater::Bed,
        _ => return Err(format!("unknown heater {heater:?} (hotend, bed)")),
    };
    let fault = match fault {
        "open" => SimFault::ThermistorOpen,
        "short" => SimFault::ThermistorShort,
        "cartridge" => SimFault::CartridgeOut,
        "adc" => SimFault::AdcStalled,
        _ => return Err(format!("unknown fault {fault:?} (open, short, cartridge, adc)")),
    };
    Ok((heater, fault, at))
}

/// Human duration: `1h 02m 03s`.
fn hms(secs: f64) -> String {
    // Print times are far below u64::MAX seconds; negative or NaN shows as 0.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let s = secs.max(0.0).round() as u64;
    if s >= 3600 {
        format!("{}h {:02}m {:02}s", s / 3600, s / 60 % 60, s % 60)
    } else {
        format!("{}m {:02}s", s / 60, s % 60)
    }
}

struct Display {
    bar: ProgressBar,
    layers: usize,
    /// Set by Ctrl-C, SIGTERM or SIGHUP: the print stops, heaters off.
    stop: &'static plotter_host::stop::Stop,
}

impl PrintControl for Display {
    fn progress(&mut self, p: &PrintProgress) {
        self.bar.set_position(u64::try_from(p.accepted).unwrap_or(u64::MAX));
        // Ticks to seconds for display.
        #[allow(clippy::cast_precision_loss)]
        let left = p.remaining_ticks as f64 / f64::from(TICK_HZ);
        let temps = p.temperatures.as_deref().unwrap_or("");
        let state = p.waiting.as_ref().map(|w| format!("  waiting: {w}")).unwrap_or_default();
        self.bar.set_message(format!("layer {}/{}  {temps}  {} left{state}", p.layer, self.layers, hms(left)));
    }
    fn note(&mut self, message: &str) {
        self.bar.suspend(|| eprintln!("{message}"));
    }
    fn stop_requested(&mut self) -> bool {
        self.stop.any()
    }
}

/// Run `plotter print`.
pub(crate) fn run(args: &PrintArgs) -> anyhow::Result<()> {
    let stop = plotter_host::stop::Stop::install_signals().context("cannot take the termination signals")?;
    let profile = load_profile(Some(&args.profile))?;
    if profile.axes.e.is_none() {
        bail!("{}: not a printer profile (no axes.e)", args.profile.display());
    }
    let cfg = plan::machine_config(&profile)?;
    let thermal = thermal_config(&profile).map_err(|e| anyhow::anyhow!("{}: {e}", args.profile.display()))?;
    let shown = args.input.display().to_string();
    let text = std::fs::read_to_string(&args.input).with_context(|| format!("cannot read {shown}"))?;
    let program = import_print(&text, &shown, &profile)?;
    for w in &program.warnings {
        eprintln!("warning: {shown}: {w}");
    }
    let plan = plan_print(&profile, &program).with_context(|| shown.clone())?;
    let ours = plan.seconds();
    let theirs = program.slicer.estimate_s.map_or_else(|| "not in the file".to_string(), hms);
    println!(
        "{shown}: {} layers, {} blocks, {:.2} mm of filament; print time (motion, exact): {} — slicer's estimate: {theirs}",
        plan.layers,
        plan.block_count(),
        program.extruded_mm,
        hms(ours)
    );
    let target = if std::io::stderr().is_terminal() {
        ProgressDrawTarget::stderr_with_hz(5)
    } else {
        ProgressDrawTarget::hidden()
    };
    let bar = ProgressBar::with_draw_target(Some(u64::try_from(plan.items.len()).unwrap_or(u64::MAX)), target);
    if let Ok(style) = ProgressStyle::with_template("{bar:25} {percent:>3}%  {msg}") {
        bar.set_style(style.progress_chars("█▉ "));
    }
    let mut display = Display { bar, layers: plan.layers, stop };
    let baud = args.baud.unwrap_or(profile.link.baud);
    match &args.port {
        None => {
            let faults = args
                .fault
                .iter()
                .map(|(heater, fault, s)| {
                    // Seconds to µs, far inside u64.
                    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
                    let at_us = (s * 1e6).round() as u64;
                    ScheduledFault { heater: *heater, fault: *fault, at_us }
                })
                .collect();
            let transport = PrinterSim::new(cfg, thermal, faults);
            let mut session = Session::connect(transport, "simulated printer")?;
            let busy_before = session.transport.sim().hal().busy_ticks();
            let result = stream_print(&mut session, &plan, Played::Printer, &mut display);
            display.bar.finish_and_clear();
            let stats = result?;
            let sim = session.transport.sim();
            // Step counts of a print are far inside f64's mantissa.
            #[allow(clippy::cast_precision_loss)]
            let e_mm = sim.hal().max_position()[Axis::E.index()] as f64 / f64::from(cfg.axis(Axis::E).steps_per_mm);
            #[allow(clippy::cast_precision_loss)]
            let busy = (sim.hal().busy_ticks() - busy_before) as f64 / f64::from(TICK_HZ);
            println!(
                "printed on the simulator: {} elapsed (heating and homing included), {} of stepper time (homing \
                 included); extruded {e_mm:.3} mm (G-code: {:.3} mm{}); final temperatures {}",
                hms(stats.elapsed.as_secs_f64()),
                hms(busy),
                program.extruded_mm,
                program.slicer.filament_mm.map(|f| format!(", slicer: {f:.2} mm")).unwrap_or_default(),
                stats.temperatures.as_deref().unwrap_or("not reported"),
            );
            if stats.refused > 0 {
                println!("{} lines were refused by the firmware (see above)", stats.refused);
            }
            Ok(())
        }
        Some(port) => {
            if !args.fault.is_empty() {
                bail!("--fault only applies to the simulator");
            }
            let transport = SerialTransport::open(port, baud)?;
            let mut session = Session::connect(transport, port)?;
            let result = stream_print(&mut session, &plan, Played::Printer, &mut display);
            display.bar.finish_and_clear();
            let stats = result?;
            println!(
                "printed on {port}: {} elapsed; final temperatures {}",
                hms(stats.elapsed.as_secs_f64()),
                stats.temperatures.as_deref().unwrap_or("not reported")
            );
            Ok(())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fault_specs() {
        assert_eq!(parse_fault("hotend-open@90"), Ok((Heater::HotEnd, SimFault::ThermistorOpen, 90.0)));
        assert_eq!(parse_fault("bed-cartridge@1.5"), Ok((Heater::Bed, SimFault::CartridgeOut, 1.5)));
        assert!(parse_fault("nozzle-open@1").unwrap_err().contains("nozzle"));
        assert!(parse_fault("hotend-open").is_err());
        assert_eq!(hms(3723.0), "1h 02m 03s");
        assert_eq!(hms(62.4), "1m 02s");
    }
}
