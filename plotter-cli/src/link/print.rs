//! Streaming a planned print ([`PrintPlan`]) to the firmware: step-block frames and G-code lines in one numbered
//! sequence, with the same flow control as plots (never more unanswered bytes than the firmware's receive buffer).
//!
//! - Every item is answered once (`ok`, `error:` or `rs <n>`). Heating waits (`M109`, `M190`) and autotune
//!   (`M303`) are answered when done, so the stream simply pauses behind them; the firmware reports temperatures
//!   every second meanwhile (and during the print, after the `M155 S1` sent first).
//! - `rs <n>` (a damaged item): the host stops sending, collects the answers of everything still in flight, and
//!   resends from item `n` (go-back-N).
//! - A refused step block (cold extrusion, a soft limit: the firmware refuses everything after a hole in the print)
//!   or a refused heater or homing command (`M104 S300` above the maximum would otherwise print cold) ends the print
//!   with the firmware's reason; any other refused line (a fan the printer lacks) is reported and the print goes on.
//!   An alarm (a thermal trip, an emergency stop, a limit) ends the print with the firmware's alarm text, which names
//!   the sensor.
//! - However the print ends early, the host then stops the machine (a reset: motion stops, the queue is dropped) and
//!   switches the heaters and the fan off, and the error says so (or that it could not, so the user switches the
//!   printer off).
//! - Progress is the layer of the latest block the firmware accepted (its queue holds well under a second of
//!   motion); at the end the host waits until the machine is idle.

use std::collections::VecDeque;
use std::time::Duration;

use anyhow::{Context as _, bail};
use plotter_fw::MachineConfig;
use plotter_fw::heater::Heater;
use plotter_fw::protocol::{RT_STATUS, Reply};
use plotter_fw::sim::thermal::SimFault;
use plotter_fw::sim::{Sim, SimOptions};
use plotter_fw::thermal::ThermalConfig;
use plotter_path::motion::print_plan::{PrintItem, PrintPlan, wire_items};

use super::Transport;
use super::session::{COMMAND_TIMEOUT, Session, Status};
use super::sim::SimTransport;

/// A fault to inject into the simulated printer: `fault` on `heater` at `at_us` of virtual time (µs).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ScheduledFault {
    /// The heater.
    pub heater: Heater,
    /// What breaks.
    pub fault: SimFault,
    /// When, µs of virtual time.
    pub at_us: u64,
}

/// The simulated printer (firmware, steppers, heaters on their thermal model) behind the [`Transport`] trait, with
/// faults injected at their scheduled times.
pub struct PrinterSim {
    inner: SimTransport,
    faults: Vec<ScheduledFault>,
}

impl PrinterSim {
    /// A printer for `cfg` with the heaters of `thermal`; bytes arrive as fast as the firmware takes them.
    pub fn new(cfg: MachineConfig, thermal: ThermalConfig, faults: Vec<ScheduledFault>) -> Self {
        let opts = SimOptions { thermal, record_steps: false, ..SimOptions::for_config(&cfg) };
        PrinterSim { inner: SimTransport::from_sim(Sim::with_options(cfg, opts), None), faults }
    }

    /// The simulator (positions, stepper time, heaters).
    pub fn sim(&self) -> &Sim {
        self.inner.sim()
    }
}

impl Transport for PrinterSim {
    fn send(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        self.inner.send(bytes)
    }

    fn recv_line(&mut self, timeout: Duration) -> std::io::Result<Option<String>> {
        let now = self.inner.sim().now();
        let sim = self.inner.sim_mut();
        self.faults.retain(|f| {
            if f.at_us <= now {
                sim.heaters_mut().inject(f.heater, Some(f.fault));
                false
            } else {
                true
            }
        });
        // Never run past the next fault.
        let until = self.faults.iter().map(|f| f.at_us.saturating_sub(now)).min().unwrap_or(u64::MAX);
        self.inner.recv_line(timeout.min(Duration::from_micros(until.max(1))))
    }

    fn now(&self) -> Duration {
        self.inner.now()
    }
}

/// What the display shows.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PrintProgress {
    /// Items accepted by the firmware.
    pub accepted: usize,
    /// Items in the plan.
    pub items: usize,
    /// Layer of the latest accepted block.
    pub layer: usize,
    /// Planned motion time not yet accepted, ticks.
    pub remaining_ticks: u64,
    /// The latest temperature report (`T:… /… B:… /…`).
    pub temperatures: Option<String>,
    /// The command the firmware is waiting on, if any.
    pub waiting: Option<String>,
}

/// The caller's side: display and notes.
pub trait PrintControl {
    /// Progress changed (accepted count, temperatures or waiting state).
    fn progress(&mut self, p: &PrintProgress);
    /// Something to tell the user (a refused line, a firmware message).
    fn note(&mut self, message: &str);
    /// Whether the user asked to stop (Ctrl-C): the stream then ends early, as after an error (see
    /// [`stream_print`]). Asked between replies, at least every 200 ms.
    fn stop_requested(&mut self) -> bool {
        false
    }
}

/// The machine a [`PrintPlan`] is streamed to, which decides how it starts and how an early end makes it safe.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Played {
    /// A printer: temperature reports are switched on first; an early end switches the heaters and the fan off.
    Printer,
    /// A Z-lift pen plotter playing G-code as written (no heaters): an early end raises the pen to `up_z_mm`
    /// (machine coordinates), and so does a program that ends with the pen below it.
    Plotter {
        /// The pen-up height, mm.
        up_z_mm: f64,
        /// Z steps per mm (to read the plan's end position).
        z_steps_per_mm: f64,
    },
}

impl Played {
    /// The machine and its job, as messages name them.
    fn names(self) -> (&'static str, &'static str) {
        match self {
            Self::Printer => ("printer", "print"),
            Self::Plotter { .. } => ("plotter", "plot"),
        }
    }
}

/// Figures of a finished print.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PrintStats {
    /// Transport time from the first item to idle (heating and homing included).
    pub elapsed: Duration,
    /// Items resent after `rs`.
    pub resent: u64,
    /// Lines the firmware refused.
    pub refused: usize,
    /// The last temperature report.
    pub temperatures: Option<String>,
}

/// Quiet time after which the firmware is taken to be gone (it reports temperatures every second).
const SILENCE: Duration = Duration::from_secs(30);

/// Whether the firmware refusing this line must end the print: heater targets and waits (printing on without them
/// prints cold or at the wrong temperature), autotune and homing.
fn refusal_ends_print(text: &str) -> bool {
    let command = text.split_whitespace().next().unwrap_or("");
    matches!(command, "M104" | "M109" | "M140" | "M190" | "M303" | "G28")
}

/// Stream `plan` over `session` to `machine`; `control` gets the progress. When the stream ends early (see the
/// module docs; also when `control` asks to stop), the machine is stopped and made safe — a printer's heaters
/// switched off, a plotter's pen raised — before the error returns. A plotter program that ends with the pen down
/// gets its pen raised too (with a note).
pub fn stream_print<T: Transport>(
    session: &mut Session<T>,
    plan: &PrintPlan,
    machine: Played,
    control: &mut dyn PrintControl,
) -> anyhow::Result<PrintStats> {
    let stats = stream(session, plan, machine, control).map_err(|why| {
        let text = match (machine, shut_down(session, machine)) {
            (Played::Printer, Ok(())) => format!("{why:#}; print stopped: motion stopped, heaters and fan off"),
            (Played::Printer, Err(e)) => format!(
                "{why:#}; print stopped, but the heaters could not be switched off ({e:#}): switch the printer off"
            ),
            (Played::Plotter { .. }, Ok(())) => format!("{why:#}; plot stopped: motion stopped, pen up"),
            (Played::Plotter { .. }, Err(e)) => format!(
                "{why:#}; plot stopped, but the pen could not be raised ({e:#}): lift it by hand before moving the \
                 carriage"
            ),
        };
        crate::Error::Ended { text, trouble: crate::Trouble::of(&why) }
    })?;
    if let Played::Plotter { up_z_mm, z_steps_per_mm } = machine {
        // The plan's end is in steps; half a step of slack for the rounding of the height.
        if f64::from(plan.end[2]) < up_z_mm * z_steps_per_mm - 0.5 {
            control.note("the program ended with the pen below its up height: raising it");
            session.command_checked(&format!("G90 G0 Z{up_z_mm:.3}"), COMMAND_TIMEOUT)?;
            session.wait_idle(Duration::from_millis(50))?;
        }
    }
    Ok(stats)
}

/// After an early end: reset (motion stops, the queue is dropped), then make the machine safe — heaters and fan off
/// (a printer), the pen raised (a plotter) — each checked.
fn shut_down<T: Transport>(session: &mut Session<T>, machine: Played) -> anyhow::Result<()> {
    match machine {
        Played::Printer => {
            session.reset()?;
            for off in ["M104 S0", "M140 S0", "M107"] {
                session.command(off, COMMAND_TIMEOUT)?;
            }
            Ok(())
        }
        Played::Plotter { up_z_mm, .. } => session.stop_and_lift(up_z_mm),
    }
}

fn stream<T: Transport>(
    session: &mut Session<T>,
    plan: &PrintPlan,
    machine: Played,
    control: &mut dyn PrintControl,
) -> anyhow::Result<PrintStats> {
    if machine == Played::Printer {
        session.command_checked("M155 S1", COMMAND_TIMEOUT).context("cannot switch on the temperature reports")?;
    }
    let (noun, job) = machine.names();
    let base = session.status()?.seq;
    let wire = wire_items(plan, base).map_err(|e| anyhow::anyhow!(e))?;
    let rx = session.info.rx_bytes;
    let n = wire.len();
    if let Some(i) = (0..n).find(|&i| wire[i].len() > rx) {
        bail!("item {i} is {} bytes, more than the firmware's receive buffer ({rx} bytes) holds", wire[i].len());
    }
    // Planned time after each item.
    let mut remaining = vec![0u64; n + 1];
    for i in (0..n).rev() {
        let t = match &plan.items[i] {
            PrintItem::Block { block, .. } => u64::from(block.duration_ticks()),
            PrintItem::Line { .. } => 0,
        };
        remaining[i] = remaining[i + 1] + t;
    }
    let t = &mut session.transport;
    let start = t.now();
    let mut progress = PrintProgress { items: n, remaining_ticks: remaining[0], ..PrintProgress::default() };
    let mut stats = PrintStats::default();
    let mut inflight: VecDeque<usize> = VecDeque::new();
    let mut inflight_bytes = 0usize;
    let mut next = 0usize;
    let mut rewind: Option<usize> = None;
    let mut last_heard = t.now();
    let mut last_status = t.now();
    let mut done_sending = false;
    let mut stalled = false;
    loop {
        if rewind.is_none() {
            while next < n && inflight_bytes + wire[next].len() <= rx {
                t.send(&wire[next])?;
                inflight.push_back(next);
                inflight_bytes += wire[next].len();
                next += 1;
            }
        }
        if next == n && inflight.is_empty() && !done_sending {
            done_sending = true;
            t.send(&[RT_STATUS])?;
            last_status = t.now();
        }
        if t.now().saturating_sub(last_status) >= Duration::from_millis(500) {
            t.send(&[RT_STATUS])?;
            last_status = t.now();
        }
        if control.stop_requested() {
            bail!("stopped by the user at item {} of {n}", progress.accepted);
        }
        let waited_from = t.now();
        let Some(line) = t.recv_line(Duration::from_millis(200))? else {
            if t.now() == waited_from {
                // A simulator with nothing left to run (no heaters keep its time going): time stands still, so the
                // status is asked for at once — its answer ends the wait once the machine is idle. Silence twice
                // in a row with the clock stopped means nothing will ever answer.
                if stalled {
                    bail!("the firmware stopped answering (item {} of {n})", progress.accepted);
                }
                stalled = true;
                t.send(&[RT_STATUS])?;
                last_status = t.now();
                continue;
            }
            if t.now().saturating_sub(last_heard) > SILENCE {
                bail!("the firmware went quiet for {} s (item {} of {n})", SILENCE.as_secs(), progress.accepted);
            }
            continue;
        };
        last_heard = t.now();
        stalled = false;
        match Reply::parse(&line) {
            Reply::Ok | Reply::Error { .. } | Reply::Resend(_) => {
                let Some(item) = inflight.pop_front() else {
                    // An answer to something sent outside the stream (e.g. a stray line): nothing to account.
                    continue;
                };
                inflight_bytes -= wire[item].len();
                match Reply::parse(&line) {
                    Reply::Ok if rewind.is_none() => {
                        progress.accepted = item + 1;
                        progress.remaining_ticks = remaining[item + 1];
                        progress.waiting = None;
                        if let PrintItem::Block { layer, .. } = &plan.items[item] {
                            progress.layer = *layer;
                        }
                    }
                    Reply::Error { code, text } if rewind.is_none() => {
                        progress.accepted = item + 1;
                        stats.refused += 1;
                        let (what, fatal) = match &plan.items[item] {
                            PrintItem::Line { text, line, .. } => {
                                (format!("line {line} ({text})"), refusal_ends_print(text))
                            }
                            PrintItem::Block { layer, .. } => (format!("block {item} (layer {layer})"), true),
                        };
                        if fatal {
                            bail!("{what} refused by the {noun}: error {code}: {text}");
                        }
                        control.note(&format!("{what} refused: error {code}: {text}"));
                    }
                    Reply::Resend(seq) => {
                        let at = usize::try_from(seq.wrapping_sub(base)).unwrap_or(usize::MAX);
                        if at > n {
                            bail!("the firmware asked for item {seq}, outside this print");
                        }
                        rewind = Some(rewind.map_or(at, |r| r.min(at)));
                    }
                    _ => {}
                }
                if let Some(at) = rewind
                    && inflight.is_empty()
                {
                    stats.resent += u64::try_from(next - at).unwrap_or(0);
                    next = at;
                    rewind = None;
                    done_sending = false;
                }
                // The head of the stream is a wait: say so.
                if let Some(&head) = inflight.front()
                    && let PrintItem::Line { text, wait: true, .. } = &plan.items[head]
                {
                    progress.waiting = Some(text.clone());
                }
                control.progress(&progress);
            }
            Reply::Alarm { code, text } => {
                return Err(crate::Error::Halted(format!("{noun} alarm {code}: {text}")).into());
            }
            Reply::Banner(_) => {
                return Err(crate::Error::Halted(format!("the firmware restarted during the {job}")).into());
            }
            // Completion reports (framed mode) count blocks; the print follows its lines' answers instead.
            Reply::Completed(_) => {}
            Reply::Status(s) => {
                if let Some(st) = Status::parse(s) {
                    if st.state == "Alarm" {
                        return Err(crate::Error::Halted(format!("the {noun} is in alarm")).into());
                    }
                    if done_sending && st.is_idle() {
                        break;
                    }
                }
            }
            Reply::Info(i) => {
                if i.starts_with("T:") || i.starts_with("B:") {
                    progress.temperatures = Some(i.to_string());
                    stats.temperatures = Some(i.to_string());
                    control.progress(&progress);
                } else if !i.is_empty() {
                    control.note(i);
                }
            }
        }
    }
    stats.elapsed = t.now().saturating_sub(start);
    Ok(stats)
}
