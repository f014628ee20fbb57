//! The machine worker: one thread owns the link to the plotter (a serial port speaking our firmware, GRBL or an
//! EiBotBoard's EBB commands, or the simulator of our firmware paced to the wall clock) and runs what the HTTP side asks — connect, home, jog, console lines, and plots through
//! [`plotter_host::job::plot`] — reporting to every page through the event hub. An HP-GL plotter is a session of
//! its own ([`HpglSession`]): its plots are the HP-GL export streamed by [`plotter_host::job::hpgl::plot`] with the
//! same progress, pause and cancel; it has no homing and no jogging. A plot's pause, resume and cancel
//! requests and prompt answers reach it through [`super::state::PlotControl`], which [`WebEvents`] reads.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::mpsc::Receiver;
use std::time::{Duration, Instant};

use plotter_host::Trouble;
use plotter_host::job::page::view_with_travel;
use plotter_host::job::prepare::Prepared;
use plotter_host::job::progress::{JobProgress, PlotEvents};
use plotter_host::job::stepped::stepped_drawing;
use plotter_host::job::{self, JournalSpec};
use plotter_host::link::Transport;
use plotter_host::link::connect::open_port;
use plotter_host::link::console::{console_bytes, shown_reply};
use plotter_host::link::hpgl::commands::Commands;
use plotter_host::link::hpgl::port::HpglPort;
use plotter_host::link::hpgl::sender::HpglSession;
use plotter_host::link::jog::{Jog, JogTarget, run_jog};
use plotter_host::link::machine::{Connected, Firmware, PlotMachine, home_machine};
use plotter_host::link::manual::motors;
use plotter_host::link::serial::SerialTransport;
use plotter_host::link::sim::SimTransport;
use plotter_host::link::standing::{Pen as StandingPen, standing};
use plotter_host::link::stream::PauseChoice;
use plotter_path::MachineProfile;
use plotter_path::motion::plan;
use serde::Serialize;

use super::command::{Command, HpglChoice, PlotJob, hpgl_refusal};
use super::events::{Event, Hub, ProgressEvent, Prompt};
use super::state::Shared;
use super::web_journal::{WEB_FRONT_END, WebJournal, journal_path};
use plotter_host::link::paced::PacedSim;

/// The open link (boxed: the simulator is large, and the link moves only when it opens): the simulator runs our
/// firmware; a serial port any dialect [`Connected`] speaks, or an HP-GL plotter's session.
enum Link {
    Sim(Box<Connected<PacedSim>>),
    Serial(Box<Connected<SerialTransport>>),
    Hpgl(Box<Hpgl>),
}

/// An HP-GL plotter: the session and how its programs are written.
struct Hpgl {
    session: HpglSession<HpglPort>,
    choice: HpglChoice,
}

/// Run `$body` with `$c` bound to the connection, whichever the transport; `$hpgl` for an HP-GL plotter.
macro_rules! on_link {
    ($link:expr, $c:ident => $body:expr, $h:ident => $hpgl:expr) => {
        match $link {
            Link::Sim($c) => $body,
            Link::Serial($c) => $body,
            Link::Hpgl($h) => $hpgl,
        }
    };
}

/// The worker's own state.
struct Worker {
    shared: Arc<Shared>,
    link: Option<Link>,
    profile: MachineProfile,
}

/// The machine connected runs `firmware`: plots and estimates are planned for it from now on
/// ([`super::state::Inner::machine_profile`]), and the prepared drawing's estimate, when it was planned for
/// another servo timing, is planned again (unless the drawing was prepared again meanwhile).
pub(crate) fn firmware_known(shared: &Shared, firmware: Firmware) {
    let (prepared, profile) = {
        let mut i = shared.lock();
        i.machine.firmware = Some(firmware);
        (i.prepared.clone(), i.machine_profile())
    };
    let Some(old) = prepared else { return };
    let Some(new) = old.estimated_for(&profile) else { return };
    let mut i = shared.lock();
    if i.prepared.as_ref().is_some_and(|p| Arc::ptr_eq(p, &old)) {
        i.prepared = Some(Arc::new(new));
    }
}

/// Run the worker until every sender is gone.
pub(crate) fn run(shared: Arc<Shared>, commands: Receiver<Command>) {
    let mut w = Worker { shared, link: None, profile: MachineProfile::default_plotter() };
    while let Ok(c) = commands.recv() {
        w.handle(c);
    }
}

impl Worker {
    fn set_activity(&self, activity: &'static str) {
        self.shared.lock().machine.activity = activity;
        self.shared.publish();
    }

    fn fail(&self, what: &str, e: &anyhow::Error) {
        let message = format!("{what}: {e:#}");
        self.shared.hub.log("error", message.clone());
        self.shared.lock().machine.error = Some(message);
    }

    fn handle(&mut self, c: Command) {
        self.shared.lock().machine.error = None;
        match c {
            Command::Connect(port, firmware, profile, hpgl) => {
                self.link = None;
                {
                    let mut i = self.shared.lock();
                    i.machine.connected = None;
                    i.machine.hpgl = false;
                }
                self.set_activity("connecting");
                self.profile = *profile;
                match self.connect(port.as_deref(), firmware, hpgl) {
                    Ok((mut link, name)) => {
                        self.shared.hub.log("info", format!("connected to {name}"));
                        let (is_hpgl, on_port) = (matches!(link, Link::Hpgl(_)), matches!(link, Link::Serial(_)));
                        firmware_known(
                            &self.shared,
                            on_link!(&mut link, c => c.machine().firmware(), _h => Firmware::Hpgl),
                        );
                        self.link = Some(link);
                        let mut i = self.shared.lock();
                        i.machine.connected = Some(name);
                        i.machine.hpgl = is_hpgl;
                        i.machine.journaled = on_port && self.shared.config.journals.is_some();
                    }
                    Err(e) => self.fail("cannot connect", &e),
                }
            }
            Command::Disconnect => {
                self.link = None;
                {
                    let mut i = self.shared.lock();
                    i.machine.connected = None;
                    i.machine.hpgl = false;
                    i.machine.journaled = false;
                }
                self.shared.hub.log("info", "disconnected");
            }
            Command::Plot(job) => self.run_plot(job, None),
            Command::ResumePlot(job, journal) => self.run_plot(job, Some(journal)),
            Command::TestPen(profile) => {
                self.set_activity("busy");
                if let Err(e) = self.use_profile(*profile).and_then(|()| self.test_pen()) {
                    self.fail("pen test failed", &e);
                }
            }
            other => {
                self.set_activity("busy");
                if let Err(e) = self.machine_command(other) {
                    self.fail("command failed", &e);
                }
            }
        }
        self.refresh_position();
        self.set_activity("idle");
    }

    fn connect(
        &self,
        port: Option<&str>,
        firmware: Firmware,
        hpgl: Option<HpglChoice>,
    ) -> anyhow::Result<(Link, String)> {
        if let (Some(p), Some(choice)) = (port, hpgl) {
            let session = HpglSession::connect(HpglPort::open(p, choice.baud)?, p, choice.device, choice.handshake)?;
            for w in &session.warnings {
                self.shared.hub.log("error", format!("warning: {w}"));
            }
            let name = format!(
                "{} on {p} (HP-GL, buffer {} bytes, handshake {}; programs for the {})",
                session.identity,
                session.buffer_bytes,
                choice.handshake.name(),
                choice.device.name
            );
            return Ok((Link::Hpgl(Box::new(Hpgl { session, choice })), name));
        }
        let cfg = plan::machine_config(&self.profile)?;
        Ok(match port {
            None => {
                let name = format!("simulated plotter ({} x real time)", self.shared.config.sim_speed);
                let transport =
                    PacedSim::new(SimTransport::new(cfg, Some(self.profile.link.baud)), self.shared.config.sim_speed);
                let c = Connected::connect(transport, "simulated plotter", Firmware::Ours, &self.profile)?;
                (Link::Sim(Box::new(c)), name)
            }
            Some(p) => {
                let c = open_port(p, self.profile.link.baud, firmware, &self.profile)?;
                if let Connected::Grbl(g) = &c {
                    // The plot is written for the profile; say where the controller's settings disagree.
                    for m in g.settings.compare(&self.profile) {
                        self.shared.hub.log("error", format!("warning: GRBL setting {m}"));
                    }
                }
                let name = c.describe();
                (Link::Serial(Box::new(c)), name)
            }
        })
    }

    /// Plot and move the pen with `profile` from now on (the sliders may have changed it since the connect). An
    /// EiBotBoard holds its pen positions and rates itself (`SC,4/5/11/12`, sent at the connect): they are sent
    /// again when they changed.
    fn use_profile(&mut self, profile: MachineProfile) -> anyhow::Result<()> {
        if let (Some(new), Some(old)) = (profile.ebb, self.profile.ebb)
            && new != old
            && let Some(Link::Serial(c)) = self.link.as_mut()
            && c.machine().firmware() == Firmware::Ebb
        {
            for line in [
                format!("SC,4,{}", new.pen_up_position),
                format!("SC,5,{}", new.pen_down_position),
                format!("SC,11,{}", new.pen_rate_up),
                format!("SC,12,{}", new.pen_rate_down),
            ] {
                self.shared.hub.log("out", line.clone());
                c.command(&line)?;
            }
        }
        self.profile = profile;
        Ok(())
    }

    /// Read where the machine stands: steps for scripts, millimetres and the pen for people.
    fn refresh_position(&mut self) {
        let Some(link) = self.link.as_mut() else { return };
        let profile = &self.profile;
        if let Ok(at) = on_link!(link, c => standing(c, profile), _h => return) {
            let mut i = self.shared.lock();
            i.machine.position = Some(at.steps);
            i.machine.position_mm = Some([at.x_mm, at.y_mm]);
            if let Some(pen) = at.pen {
                i.machine.pen_down = Some(pen == StandingPen::Down);
            }
        }
    }

    /// Lower the pen, wait for it to settle and a moment more, raise it.
    fn test_pen(&mut self) -> anyhow::Result<()> {
        let wait = Duration::from_secs_f64((self.profile.pen.settle_ms.max(0.0) / 1000.0).min(2.0) + 0.5);
        self.machine_command(Command::Jog(JogTarget::Down, None))?;
        std::thread::sleep(wait);
        self.machine_command(Command::Jog(JogTarget::Up, None))
    }

    fn machine_command(&mut self, c: Command) -> anyhow::Result<()> {
        let profile = self.profile.clone();
        let hub = self.shared.hub.clone();
        let link = self.link.as_mut().ok_or_else(|| anyhow::anyhow!("not connected: connect to a plotter first"))?;
        match c {
            Command::Home => {
                hub.log("out", "home");
                let at = on_link!(
                    link,
                    c => home_machine(c.machine()).and_then(|_| plotter_host::link::standing::standing(c, &profile)),
                    _h => anyhow::bail!(hpgl_refusal("home"))
                )?;
                hub.log("info", format!("homed: {at}"));
                self.shared.lock().machine.motors_off = false;
            }
            Command::Jog(target, distance) => {
                let jog = Jog { target, distance, feed: None };
                let at = on_link!(
                    link,
                    c => run_jog(c, &jog, &profile, &mut |l| hub.log("out", l.to_string())).map(|at| format!("at {at}")),
                    h => {
                        // The pen lifts and lowers by HP-GL where it stands; moving it is no jog of steps.
                        let pu_pd = match target {
                            JogTarget::Up => "PU;",
                            JogTarget::Down => "PD;",
                            JogTarget::X | JogTarget::Y | JogTarget::Z => anyhow::bail!(hpgl_refusal("jog")),
                        };
                        hub.log("out", pu_pd);
                        h.session.exchange(pu_pd.as_bytes(), Duration::from_millis(100))?;
                        Ok(format!("pen {}", if target == JogTarget::Up { "up" } else { "down" }))
                    }
                )?;
                hub.log("info", at);
                if matches!(target, JogTarget::Up | JogTarget::Down) {
                    self.shared.lock().machine.pen_down = Some(target == JogTarget::Down);
                }
            }
            Command::MotorsOff => {
                let done = on_link!(link, c => motors(c, false, &profile), _h => anyhow::bail!(
                    "an HP-GL plotter has no command that turns its motors off; switch it off and on instead"
                ))?;
                self.shared.lock().machine.motors_off = true;
                hub.log("info", format!("{done}; home before the next plot"));
            }
            Command::Console(line) => {
                hub.log("out", line.clone());
                on_link!(link, c => console_line(c, &line, &hub), h => {
                    // HP-GL as typed, under the buffer handshake; the answers (OI, OE, …) as they come.
                    for a in h.session.exchange(line.as_bytes(), Duration::from_millis(300))? {
                        hub.log("in", a);
                    }
                    Ok(())
                })?;
            }
            Command::Connect(..)
            | Command::Disconnect
            | Command::Plot(_)
            | Command::ResumePlot(..)
            | Command::TestPen(_) => {}
        }
        Ok(())
    }

    /// Plot `job` (or continue the interrupted plot of its drawing whose journal is `resume`) with its profile.
    fn run_plot(&mut self, job: PlotJob, resume: Option<PathBuf>) {
        self.set_activity("plotting");
        match self.use_profile(*job.profile) {
            Ok(()) => self.plot(&job.prepared, &job.drawing, resume.as_deref()),
            Err(e) => self.done(false, format!("plot not started: {e:#}"), false),
        }
    }

    fn plot(&mut self, prepared: &Prepared, drawing: &str, resume: Option<&Path>) {
        let shared = Arc::clone(&self.shared);
        // A plot on a serial port keeps a journal in the state directory, so that it can be resumed if it stops.
        let journal = match (&self.link, &shared.config.journals) {
            (Some(Link::Serial(_)), Some(dir)) => Some(journal_path(dir, drawing, &self.profile.name)),
            _ => None,
        };
        shared.control.reset();
        {
            let mut i = shared.lock();
            i.progress = None;
            i.prompt = None;
        }
        let Some(link) = self.link.as_mut() else {
            self.done(false, "not connected: connect to a plotter first".into(), false);
            return;
        };
        let mut events =
            WebEvents { shared: Arc::clone(&shared), profile: self.profile.clone(), last_sent: None, prompt_id: 0 };
        let profile = &self.profile;
        let machine: &mut dyn PlotMachine = match &mut *link {
            Link::Hpgl(h) => {
                let result = plot_hpgl(h, profile, prepared, &mut events, &shared.hub);
                events.flush();
                match result {
                    Ok(message) => self.done(true, message, false),
                    Err(e) => self.stopped(&e),
                }
                return;
            }
            Link::Sim(c) => c.machine(),
            Link::Serial(c) => c.machine(),
        };
        let steps = &prepared.steps;
        let result = match resume {
            Some(path) => resume_plot(machine, profile, steps, path, &mut events),
            None => {
                let source = |start: [i32; 4]| {
                    let record = WebJournal {
                        front_end: WEB_FRONT_END.into(),
                        drawing: drawing.into(),
                        machine: profile.name.clone(),
                        start,
                    };
                    Ok(serde_json::to_string(&record)?)
                };
                let spec = journal.as_deref().map(|path| JournalSpec { path, source: &source });
                plan::check_work_area(profile, steps)
                    .map_err(plotter_host::Error::from)
                    .and_then(|()| job::plot(machine, profile, steps, true, false, spec, &mut events))
                    .map_err(anyhow::Error::from)
            }
        };
        events.flush();
        match result {
            Ok(outcome) => {
                let mut stepped = false;
                if let Link::Sim(c) = link
                    && let Connected::Ours(s) = &**c
                {
                    let (mut drawing, travel) = stepped_drawing(s.transport.inner().sim(), profile);
                    drawing.page_mm = prepared.drawing.page_mm;
                    let mut i = shared.lock();
                    i.stepped = Some(Arc::new(view_with_travel(&drawing, &travel)));
                    i.stepped_version += 1;
                    stepped = true;
                }
                let message = format!(
                    "done: {} blocks, {:.1} mm pen-down, {:.1} mm travel, planned {:.1} s, {} resends",
                    outcome.plan.blocks.len(),
                    outcome.plan.draw_mm,
                    outcome.plan.travel_mm,
                    outcome.plan.seconds(),
                    outcome.stats.resends
                );
                self.done(true, message, stepped);
            }
            Err(e) => self.stopped(&e),
        }
    }

    /// A plot ended by `e`: told to the page with its kind of trouble; a lost link is dropped, so the page offers
    /// to connect again instead of sending commands to a port that is gone.
    fn stopped(&mut self, e: &anyhow::Error) {
        let trouble = Trouble::of(e);
        let mut message = format!("plot stopped: {e:#}");
        if trouble == Trouble::Link {
            self.link = None;
            let mut i = self.shared.lock();
            i.machine.connected = None;
            i.machine.hpgl = false;
            message.push_str(" (disconnected: connect again once the plotter is back)");
        }
        self.done_as(false, message, false, Some(trouble));
    }

    fn done(&self, ok: bool, message: String, stepped: bool) {
        self.done_as(ok, message, stepped, None);
    }

    /// The `done` event; `trouble` names what kind of trouble ended a failed plot (`machine`, `link`, `stopped`,
    /// `other`).
    fn done_as(&self, ok: bool, message: String, stepped: bool, trouble: Option<Trouble>) {
        #[derive(Serialize)]
        struct Done {
            ok: bool,
            message: String,
            stepped: bool,
            #[serde(skip_serializing_if = "Option::is_none")]
            trouble: Option<&'static str>,
        }
        self.shared.lock().prompt = None;
        self.shared.hub.log(if ok { "info" } else { "error" }, message.clone());
        let trouble = trouble.map(Trouble::name);
        self.shared.hub.send(Event::new("done", &Done { ok, message, stepped, trouble }));
    }
}

/// Continue the plot whose journal is at `path`, once the drawing prepared now is known to be the one plotted: the
/// same plan from the same start, to the bit (a changed layout, pen or speed would put the rest elsewhere).
fn resume_plot(
    machine: &mut dyn PlotMachine,
    profile: &MachineProfile,
    steps: &plotter_path::geometry::steps::StepDrawing,
    path: &Path,
    events: &mut WebEvents,
) -> anyhow::Result<job::JobOutcome> {
    let state = plotter_host::link::journal::load(path)?;
    let record: WebJournal = serde_json::from_str(&state.source)
        .map_err(|e| anyhow::anyhow!("{}: not a journal of this web app ({e})", path.display()))?;
    let planned = plotter_host::link::machine::profile_for(profile, machine.firmware());
    let full = plan::plan_returning(&planned, steps, record.start, plan::Lookahead::Whole, false)?;
    if full.geometry_hash() != state.plan_hash || full.blocks.len() != state.blocks {
        anyhow::bail!(
            "{} is no longer the plot that was interrupted: its layout, pens, speeds or machine changed since; set \
             them back as they were, or plot it anew",
            record.drawing
        );
    }
    Ok(job::resume(machine, profile, steps, record.start, &state, path, false, false, events)?)
}

/// Plot `prepared` on an HP-GL plotter: its page drawing exported for the chosen device and sheet, streamed
/// command by command with the page's progress, pause and cancel (no journal, as the other dialects here). The
/// message for the page.
fn plot_hpgl(
    h: &mut Hpgl,
    profile: &MachineProfile,
    prepared: &Prepared,
    events: &mut WebEvents,
    hub: &Hub,
) -> anyhow::Result<String> {
    let device = h.choice.device;
    let (program, paper) = job::hpgl::program_for(profile, &prepared.drawing, device, h.choice.paper.as_ref())?;
    for w in &program.warnings {
        hub.log("error", format!("warning: {w}"));
    }
    let cmds = Commands::split(&program.text, device);
    let o = job::hpgl::plot(&mut h.session, &cmds, &paper, 0, None, None, events)?;
    Ok(format!(
        "done: {} HP-GL commands for the {} on {}, {:.1} mm pen-down; {} bytes in {:.1} s ({} ESC . B queries, {} \
         Xoffs, {} waits for room; the program's estimated plotter time {:.1} s)",
        o.commands,
        device.name,
        paper.name,
        o.draw_mm,
        o.stats.bytes,
        o.seconds,
        o.stats.space_queries,
        o.stats.xoffs,
        o.stats.waits,
        o.estimated_s
    ))
}

/// Send a console line to a machine of the line-based dialects and show its answers until it has been quiet for a
/// moment.
fn console_line<T: Transport + 'static>(c: &mut Connected<T>, line: &str, hub: &Hub) -> anyhow::Result<()> {
    let firmware = c.machine().firmware();
    c.transport().send(&console_bytes(line))?;
    let deadline = Instant::now() + Duration::from_secs(5);
    while Instant::now() < deadline {
        match c.transport().recv_line(Duration::from_millis(300))? {
            Some(l) => hub.log("in", shown_reply(&l, firmware)),
            None => break,
        }
    }
    Ok(())
}

/// The page's side of a plot: progress to every page, pause and cancel from the controlling one.
struct WebEvents {
    shared: Arc<Shared>,
    /// The plot's profile (maps the page to the machine).
    profile: MachineProfile,
    last_sent: Option<(Instant, ProgressEvent)>,
    prompt_id: u64,
}

/// At most this many progress events a second (the last one is always sent).
const PROGRESS_INTERVAL: Duration = Duration::from_millis(100);

impl WebEvents {
    fn send(&mut self, p: ProgressEvent) {
        {
            let mut i = self.shared.lock();
            i.progress = Some(p);
            // The machine's position follows the plot, so a page or a script reading the state sees it live.
            i.machine.position_mm = Some(p.machine_mm);
            i.machine.pen_down = Some(p.pen_down);
        }
        self.shared.hub.send(Event::new("progress", &p));
        self.last_sent = Some((Instant::now(), p));
    }

    /// Send the latest progress if throttling held it back.
    fn flush(&mut self) {
        let latest = self.shared.lock().progress;
        if let (Some(p), Some((_, sent))) = (latest, self.last_sent)
            && p != sent
        {
            self.send(p);
        }
    }

    fn ask(&mut self, kind: &'static str, message: String, choices: Vec<&'static str>) -> String {
        self.prompt_id += 1;
        let id = self.prompt_id;
        let prompt = Prompt { id, kind, message, choices: choices.clone() };
        self.shared.lock().prompt = Some(prompt.clone());
        self.shared.publish();
        self.shared.hub.send(Event::new("prompt", &prompt));
        let answer = self.shared.control.wait_for(|s| {
            if s.cancel {
                return Some("cancel".to_string());
            }
            match s.answer.take() {
                Some((i, a)) if i == id => Some(a),
                _ => None,
            }
        });
        self.shared.lock().prompt = None;
        answer
    }
}

impl PlotEvents for WebEvents {
    fn progress(&mut self, p: &JobProgress) {
        // Counts far below 2^53: exact in f64.
        #[allow(clippy::cast_precision_loss)]
        let percent = if p.total == 0 { 100.0 } else { 100.0 * p.executed as f64 / p.total as f64 };
        let event = ProgressEvent {
            executed: p.executed,
            total: p.total,
            draw_done_mm: p.draw_done_mm,
            draw_total_mm: p.draw_total_mm,
            eta_s: p.eta_s,
            percent,
            resends: p.resends,
            pen_mm: [p.pen_mm.x, p.pen_mm.y],
            pen_down: p.pen_down,
            machine_mm: {
                let m = self.profile.page_to_machine(p.pen_mm);
                [m.x, m.y]
            },
        };
        let due = self.last_sent.is_none_or(|(t, _)| t.elapsed() >= PROGRESS_INTERVAL) || p.executed == p.total;
        if due {
            self.send(event);
        } else {
            self.shared.lock().progress = Some(event);
        }
    }

    fn pause_requested(&mut self) -> Option<bool> {
        let mut request = None;
        self.shared.control.update(|s| request = if s.cancel { Some(true) } else { s.pause.take() });
        request
    }

    fn paused(&mut self, held: bool) -> PauseChoice {
        self.flush();
        self.shared.lock().machine.activity = "paused";
        let what = if held { "feed hold (the pen stays where it stopped)" } else { "paused with the pen up" };
        let answer = self.ask("pause", format!("{what}: resume or cancel?"), vec!["resume", "cancel"]);
        self.shared.lock().machine.activity = "plotting";
        self.shared.publish();
        if answer == "resume" { PauseChoice::Resume } else { PauseChoice::Abort }
    }
}
