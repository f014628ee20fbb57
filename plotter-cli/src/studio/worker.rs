//! One machine's worker: a thread that owns the machine's link and plots the jobs the queue gives it.
//!
//! The worker opens the machine's port (or the simulated plotter) and greets its firmware; then, while the studio
//! runs, it claims the machine's next job ([`super::queue::Queue::claim_next`]: its own jobs first, then the first
//! job for any machine whose paper fits it), makes the job's drawing ready from its stored bytes and flags exactly
//! as `plotter plot` does ([`crate::job::load::load_steps`]), and plots it through the same job API
//! ([`crate::job::plot`]) with a journal in the studio's folder — or, for a job the operator confirmed after an
//! interruption, continues it from that journal ([`crate::job::resume`]).
//!
//! While it plots it reports progress (per cent of the plan, time left from the plan, the pen's position) and
//! honours the operator: pause (at the next pen-up) and resume, stop (at the next pen-up; the job ends
//! cancelled), emergency stop (at once, pen up; cancelled).
//!
//! How a job ends: finished → done; stopped by the operator → cancelled; the port lost, or the studio ending
//! under it → *interrupted*, held by the machine until the operator confirms the paper is still in place (then it
//! resumes from its journal) or cancels it; anything else → failed, with the reason. A port that cannot be opened
//! or is lost takes only its own machine off line: the worker reports it and tries again, waiting longer each time
//! (up to the studio's `max_retry`), and the machine comes back when its port does.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use plotter_path::motion::plan::{self, Lookahead};
use serde::{Deserialize, Serialize};

use super::job_args::JobArgs;
use super::machines::{MachineSpec, SIM_DEVICE};
use super::queue::{Job, Outcome};
use super::running::Studio;
use super::state::JobState;
use super::status::{Activity, Slot};
use crate::Trouble;
use crate::job::copies::CopiesOutcome;
use crate::job::progress::{JobProgress, PenChangeChoice, PenChangeMode, PenChangeRequest, PlotEvents};
use crate::job::{self, JobOutcome, JournalSpec};
use crate::link::journal;
use crate::link::machine::{Connected, Firmware, PlotMachine};
use crate::link::paced::PacedSim;
use crate::link::serial::SerialTransport;
use crate::link::sim::SimTransport;
use crate::link::stream::PauseChoice;
use crate::stop::{Stop, StopCause};

/// What the studio's journals record as their plot's source.
pub const STUDIO_FRONT_END: &str = "plotter studio";

/// The first wait before a failed port is tried again; it doubles up to the studio's `max_retry`.
const FIRST_RETRY: Duration = Duration::from_millis(500);
/// How often an idle worker looks at the queue even when nobody says there is work.
const IDLE_LOOK: Duration = Duration::from_secs(1);
/// At most this many progress updates a second reach the page.
const PROGRESS_INTERVAL: Duration = Duration::from_millis(100);

/// A studio journal's source record: enough to check that a resume continues the same job.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct JournalSource {
    front_end: String,
    job: i64,
    drawing: String,
    machine: String,
    start: [i32; 4],
}

/// The machine's link (boxed: the simulator is large).
enum Link {
    Sim(Box<Connected<PacedSim>>),
    Serial(Box<Connected<SerialTransport>>),
}

impl Link {
    fn machine(&mut self) -> &mut dyn PlotMachine {
        match self {
            Link::Sim(c) => c.machine(),
            Link::Serial(c) => c.machine(),
        }
    }

    fn describe(&self) -> String {
        match self {
            Link::Sim(c) => c.describe(),
            Link::Serial(c) => c.describe(),
        }
    }

    /// The simulator's executed motion time since `busy_before`, seconds (in-process simulators only).
    fn executed_s(&self, busy_before: u64) -> Option<f64> {
        match self {
            Link::Sim(c) => match &**c {
                // Ticks of a microsecond: far below 2^53.
                #[allow(clippy::cast_precision_loss)]
                Connected::Ours(s) => {
                    Some(s.transport.inner().sim().hal().busy_ticks().saturating_sub(busy_before) as f64 / 1e6)
                }
                _ => None,
            },
            Link::Serial(_) => None,
        }
    }
}

/// Start one worker thread per machine of `studio`.
pub fn start(studio: &Arc<Studio>) -> std::io::Result<Vec<JoinHandle<()>>> {
    studio
        .slots()
        .iter()
        .map(|slot| {
            let (studio, slot) = (Arc::clone(studio), Arc::clone(slot));
            std::thread::Builder::new().name(format!("machine {}", slot.spec.name)).spawn(move || run(&studio, &slot))
        })
        .collect()
}

fn connect(spec: &MachineSpec, sim_speed: f64) -> crate::Result<Link> {
    if spec.device == SIM_DEVICE {
        let cfg = plan::machine_config(&spec.profile)?;
        let transport = PacedSim::new(SimTransport::new(cfg, Some(spec.profile.link.baud)), sim_speed);
        let firmware = if spec.firmware == Firmware::Auto { Firmware::Ours } else { spec.firmware };
        let c = Connected::connect(transport, "simulated plotter", firmware, &spec.profile)?;
        return Ok(Link::Sim(Box::new(c)));
    }
    let c = crate::link::connect::open_port(&spec.device, spec.profile.link.baud, spec.firmware, &spec.profile)?;
    if let Connected::Grbl(g) = &c {
        for m in g.settings.compare(&spec.profile) {
            eprintln!("{}: warning: GRBL setting {m}", spec.name);
        }
    }
    Ok(Link::Serial(Box::new(c)))
}

/// Set the machine's status; the studio's version moves only when something changed.
fn set(studio: &Studio, slot: &Slot, change: impl FnOnce(&mut super::status::MachineStatus)) {
    let changed = {
        let mut s = slot.status();
        let before = s.clone();
        change(&mut s);
        *s != before
    };
    if changed {
        studio.touch();
    }
}

/// The worker's loop, until the studio ends.
fn run(studio: &Studio, slot: &Slot) {
    let name = slot.spec.name.clone();
    let mut link: Option<Link> = None;
    let mut retry = FIRST_RETRY;
    while !studio.ending() {
        if link.is_none() {
            set(studio, slot, |s| s.state = Activity::Connecting);
            match connect(&slot.spec, studio.options().sim_speed) {
                Ok(l) => {
                    let what = l.describe();
                    eprintln!("{name}: connected to {what}");
                    set(studio, slot, |s| {
                        s.state = Activity::Idle;
                        s.connected = Some(what);
                        s.error = None;
                    });
                    link = Some(l);
                    retry = FIRST_RETRY;
                }
                Err(e) => {
                    let message = format!("{e:#}; trying again in {:.1} s", retry.as_secs_f64());
                    set(studio, slot, |s| {
                        s.state = Activity::Offline;
                        s.connected = None;
                        s.error = Some(message);
                    });
                    let until = Instant::now() + retry;
                    while Instant::now() < until && !studio.ending() {
                        std::thread::sleep(Duration::from_millis(50));
                    }
                    retry = (retry * 2).min(studio.options().max_retry.max(FIRST_RETRY));
                    continue;
                }
            }
        }
        let held = studio.queue().held_by(&name);
        if let Ok(Some(j)) = &held
            && j.state == JobState::Interrupted
        {
            set(studio, slot, |s| {
                s.state = Activity::Waiting;
                s.job = Some(j.id);
                s.drawing = Some(j.drawing_name.clone());
            });
            studio.wait_for_work(IDLE_LOOK);
            continue;
        }
        let claimed = studio.queue().claim_next(&name, &mut |j| Studio::fits(slot, j));
        match claimed {
            Ok(Some(job)) => {
                if let Some(l) = link.as_mut() {
                    let lost = run_job(studio, slot, l, &job);
                    if lost {
                        link = None;
                    }
                }
                studio.wake_workers();
            }
            Ok(None) => {
                set(studio, slot, |s| {
                    s.state = Activity::Idle;
                    s.job = None;
                    s.drawing = None;
                    s.remaining_s = None;
                });
                studio.wait_for_work(IDLE_LOOK);
                // An idle machine's port that is unplugged is noticed now, not when a job next fails on it: the
                // worker drops the link and reconnects (the machine shows offline until the port is back).
                if matches!(link, Some(Link::Serial(_))) && !Path::new(&slot.spec.device).exists() {
                    eprintln!("{name}: {} is gone", slot.spec.device);
                    link = None;
                }
            }
            Err(e) => {
                set(studio, slot, |s| s.error = Some(format!("cannot take the next job: {e}")));
                studio.wait_for_work(IDLE_LOOK);
            }
        }
    }
    set(studio, slot, |s| s.state = Activity::Stopped);
}

/// Plot `job` on `link` and record how it ended; true when the link was lost.
fn run_job(studio: &Studio, slot: &Slot, link: &mut Link, job: &Job) -> bool {
    let id = job.summary.id;
    slot.clear();
    set(studio, slot, |s| {
        s.state = Activity::Plotting;
        s.job = Some(id);
        s.drawing = Some(job.summary.drawing_name.clone());
        s.percent = 0.0;
        s.remaining_s = None;
        s.error = None;
        s.copy = None;
    });
    let started = Instant::now();
    let mut events = StudioEvents {
        studio,
        slot,
        job: id,
        paused_for: Duration::ZERO,
        last_sent: None,
        stop_sent: false,
        operator_stop: false,
        copies: 1,
        next_copy: 1,
    };
    let result = plot_job(studio, slot, link, job, &mut events);
    let plot_time = started.elapsed().saturating_sub(events.paused_for);
    let operator_stop = events.operator_stop;
    let mut lost = false;
    let (recorded, last, error) = match result {
        Ok(Some(out)) => {
            let text = format!("job {id} done: {}", done_text(&out, link));
            // Copies stopped by the operator at a paper change: the end of "until stopped", else short of the count.
            let outcome = match (&out.ended_early, events.copies) {
                (Some(_), n) if n != 0 => Outcome::Cancelled,
                _ => Outcome::Done,
            };
            (studio.queue().finish(id, &outcome, plot_time), text, None)
        }
        Ok(None) => {
            let text = format!("job {id} done (its journal says it had finished)");
            (studio.queue().finish(id, &Outcome::Done, plot_time), text, None)
        }
        Err(e) => {
            let text = format!("{e:#}");
            let process_stop = Stop::process().stop_cause().is_some();
            match Trouble::of(&e) {
                Trouble::Link => {
                    lost = true;
                    let r = studio.queue().interrupt(id, &text);
                    (
                        r,
                        format!("job {id} interrupted: {text}"),
                        Some(format!("{text} (the machine reconnects when its port is back)")),
                    )
                }
                Trouble::Stopped if (studio.ending() || process_stop) && !operator_stop => {
                    let r = studio.queue().interrupt(id, "the studio was stopped");
                    (r, format!("job {id} interrupted: the studio was stopped"), None)
                }
                Trouble::Stopped => {
                    (studio.queue().finish(id, &Outcome::Cancelled, plot_time), format!("job {id} cancelled"), None)
                }
                Trouble::Machine | Trouble::Other => {
                    let r = studio.queue().finish(id, &Outcome::Failed(text.clone()), plot_time);
                    (r, format!("job {id} failed: {text}"), Some(text))
                }
            }
        }
    };
    if let Err(e) = recorded {
        eprintln!("{}: cannot record the end of job {id}: {e}", slot.spec.name);
    }
    eprintln!("{}: {last}", slot.spec.name);
    set(studio, slot, |s| {
        s.state = Activity::Idle;
        s.last = Some(last);
        s.error = error;
        s.remaining_s = None;
        s.copy = None;
        if lost {
            s.connected = None;
        }
    });
    lost
}

/// Where a job's drawing is written for the loader: `drawings/<id>-<its file name>` in the studio's folder (the
/// name keeps its extension, which tells the loader what kind of file it is).
fn drawing_file(dir: &Path, job: &Job) -> anyhow::Result<PathBuf> {
    let name = Path::new(&job.summary.drawing_name)
        .file_name()
        .and_then(|n| n.to_str())
        .map(|n| n.chars().map(|c| if c.is_alphanumeric() || ".-_".contains(c) { c } else { '_' }).collect::<String>())
        .filter(|n| !n.is_empty() && !n.starts_with('.'))
        .unwrap_or_else(|| "drawing.svg".to_string());
    let path = dir.join("drawings").join(format!("{}-{name}", job.summary.id));
    std::fs::write(&path, &job.drawing).map_err(|e| anyhow::anyhow!("cannot write {}: {e}", path.display()))?;
    Ok(path)
}

/// The journal of job `id`.
pub fn journal_of(dir: &Path, id: i64) -> PathBuf {
    dir.join("journals").join(format!("job-{id}.journal"))
}

/// How a job's copies went, for the machine's card and log: "2 copies, 612 blocks, 160.0 mm pen-down, planned
/// 20.100 s, executed 23.412 s" (the copies drawn here: one a resume found finished is not counted; executed, on
/// a simulator, from the first copy's start and with the page delays and paper changes between copies), and why
/// the copies ended early, if they did.
fn done_text(out: &CopiesOutcome, link: &Link) -> String {
    let drawn: Vec<&JobOutcome> = out.copies.iter().filter(|c| !c.drawn_before).collect();
    let blocks: usize = drawn.iter().map(|c| c.plan.blocks.len()).sum();
    let mm: f64 = drawn.iter().map(|c| c.plan.draw_mm).sum();
    let planned: f64 = drawn.iter().map(|c| c.plan.seconds()).sum();
    let executed = out
        .copies
        .first()
        .and_then(|c| link.executed_s(c.busy_before))
        .map_or_else(String::new, |s| format!(", executed {s:.3} s"));
    let copies = match drawn.len() {
        1 => String::new(),
        n => format!("{n} copies, "),
    };
    let early = out.ended_early.as_ref().map_or_else(String::new, |why| format!("; {why}"));
    format!("{copies}{blocks} blocks, {mm:.1} mm pen-down, planned {planned:.3} s{executed}{early}")
}

/// Make the job's drawing ready and plot its copies (or continue them from its journal), telling the job's
/// webhook (if it has one) of its pen changes, pauses and end — a resumed job's too. `None`: its journal says it
/// had finished (the studio stopped before recording that).
fn plot_job(
    studio: &Studio,
    slot: &Slot,
    link: &mut Link,
    job: &Job,
    events: &mut StudioEvents<'_>,
) -> anyhow::Result<Option<CopiesOutcome>> {
    let args = JobArgs::from_options(&job.summary.options)?;
    let copies = args.copies()?;
    events.copies = copies.count;
    // A resume goes on with the copy its journal was drawing.
    let journal_path = journal_of(studio.dir(), job.summary.id);
    if job.summary.resume
        && let Ok(state) = journal::load(&journal_path)
    {
        events.resuming_copy(crate::state_dir::copy_of(&state.source), state.complete);
    }
    let name = format!("{} (job {})", job.summary.drawing_name, job.summary.id);
    let finished = |o: &Option<CopiesOutcome>| match o {
        Some(o) => o.summary(),
        None => "its journal says it had finished".to_string(),
    };
    let url = args.workflow.webhook.as_deref();
    job::webhook::hooked(
        url,
        &slot.spec.name,
        &name,
        false,
        events,
        |events| plot_job_with(studio, slot, link, job, &args, events),
        finished,
    )?
}

/// [`plot_job`] with `events` (the studio's, or the studio's with the webhook told).
fn plot_job_with(
    studio: &Studio,
    slot: &Slot,
    link: &mut Link,
    job: &Job,
    args: &JobArgs,
    events: &mut dyn PlotEvents,
) -> anyhow::Result<Option<CopiesOutcome>> {
    let id = job.summary.id;
    let file = drawing_file(studio.dir(), job)?;
    let profile = &slot.spec.profile;
    let (steps, _) = crate::job::load::load_steps(&file, profile, &args.input, &args.layout, &args.optimize, None)?;
    plan::check_work_area(profile, &steps).map_err(crate::Error::from)?;
    let journal_path = journal_of(studio.dir(), id);
    let back = args.optimize.return_home;
    let copies = args.copies()?;
    let stops = job::stops::StopOptions { split_mm: args.split_mm()? };
    let machine = link.machine();
    let out = if job.summary.resume && journal_path.exists() {
        let state = journal::load(&journal_path)?;
        // A journal that finished its copy goes on with the copies left (it was stopped at a paper change).
        let copy = crate::state_dir::copy_of(&state.source);
        if state.complete && copies.count != 0 && copy >= copies.count {
            return Ok(None);
        }
        let source: JournalSource = serde_json::from_str(&state.source)
            .map_err(|e| anyhow::anyhow!("{}: not a journal of the studio ({e})", journal_path.display()))?;
        if source.job != id {
            anyhow::bail!("{}: the journal of job {}, not of job {id}", journal_path.display(), source.job);
        }
        // As the plot planned it: several copies each end back where they started.
        let p = crate::link::machine::profile_for(profile, machine.firmware());
        let full =
            plan::plan_returning(&p, &steps, source.start, Lookahead::Whole, job::copies::returns(back, &copies))?;
        if full.geometry_hash() != state.plan_hash || full.blocks.len() != state.blocks {
            anyhow::bail!(
                "job {id} no longer gives the plan its journal recorded (the machine's profile changed); cancel it \
                 and queue it again"
            );
        }
        job::copies::resume_copies(
            machine,
            profile,
            &steps,
            source.start,
            &state,
            &journal_path,
            false,
            back,
            &stops,
            &copies,
            events,
        )?
    } else {
        let record = |start: [i32; 4]| -> anyhow::Result<String> {
            Ok(serde_json::to_string(&JournalSource {
                front_end: STUDIO_FRONT_END.into(),
                job: id,
                drawing: job.summary.drawing_name.clone(),
                machine: slot.spec.name.clone(),
                start,
            })?)
        };
        let spec = JournalSpec { path: &journal_path, source: &record };
        job::copies::plot_copies(machine, profile, &steps, true, back, Some(spec), &stops, &copies, events)?
    };
    // Copies that ended at a paper change because the studio is ending (not because the operator stopped them) are
    // interrupted, to go on with the copies left when the studio is back.
    let asked = slot.peek();
    if let Some(why) = &out.ended_early
        && !(asked.stop || asked.estop)
    {
        let cause = Stop::process().stop_cause().unwrap_or(StopCause::Requested);
        // A shutdown is no job error: the webhook hears `stopped` with this, and the job keeps its copies owed.
        let doing = format!(
            "the studio was shutting down, parked between copies ({why}); the job goes on with the copies left once \
             the studio is back"
        );
        return Err(crate::stop::Stopped { cause, doing }.into());
    }
    if out.copies.iter().all(|c| c.drawn_before) && out.ended_early.is_none() {
        return Ok(None);
    }
    Ok(Some(out))
}

/// What the operator is asked to do at a pen change: "change to pen 2, red fineliner 0.5 (#ff0000), for layer
/// \"red\"" (pen 1 is the one the plot starts with); a resumed plot asks for the pen of the layer it goes on with.
fn pen_prompt(change: &PenChangeRequest) -> String {
    match change.previous {
        Some(_) => {
            format!("change to pen {}, {}, for layer {:?}", change.number + 1, change.pen.label(), change.layer_name)
        }
        None => format!("load pen {} for layer {:?}, where the plot goes on", change.pen.label(), change.layer_name),
    }
}

/// The studio's side of a plot: progress to the machine's status, the operator's requests to the job.
struct StudioEvents<'a> {
    studio: &'a Studio,
    slot: &'a Slot,
    job: i64,
    /// Time spent paused (left out of the plot time).
    paused_for: Duration,
    last_sent: Option<Instant>,
    /// A stop's pause was asked for already.
    stop_sent: bool,
    /// The operator stopped the job (not the studio ending).
    operator_stop: bool,
    /// How many copies the job asks for (0: until stopped).
    copies: u64,
    /// The copy the next plan of the job draws.
    next_copy: u64,
}

impl PlotEvents for StudioEvents<'_> {
    fn progress(&mut self, p: &JobProgress) {
        // Counts far below 2^53: exact in f64.
        #[allow(clippy::cast_precision_loss)]
        let percent = if p.total == 0 { 100.0 } else { 100.0 * p.executed as f64 / p.total as f64 };
        let due = self.last_sent.is_none_or(|t| t.elapsed() >= PROGRESS_INTERVAL) || p.executed == p.total;
        {
            let mut s = self.slot.status();
            s.percent = percent;
            s.remaining_s = Some(p.eta_s);
            s.pen_mm = Some([p.pen_mm.x, p.pen_mm.y]);
            s.pen_down = Some(p.pen_down);
        }
        if due {
            self.last_sent = Some(Instant::now());
            self.studio.touch();
        }
    }

    fn pause_requested(&mut self) -> Option<bool> {
        if self.slot.peek().stop && !self.stop_sent {
            self.stop_sent = true;
            return Some(false);
        }
        self.slot.take_pause().then_some(false)
    }

    fn paused(&mut self, _held: bool) -> PauseChoice {
        self.wait_for_operator(None)
    }

    fn pen_change_mode(&self) -> PenChangeMode {
        PenChangeMode::Pause
    }

    fn pen_change(&mut self, change: &PenChangeRequest) -> PenChangeChoice {
        // Parked with the pen up, like a refill, until the operator has loaded the pen and resumes (or stops).
        match self.wait_for_operator(Some(pen_prompt(change))) {
            PauseChoice::Resume => PenChangeChoice::Continue,
            PauseChoice::Abort => PenChangeChoice::Stop,
        }
    }

    fn plot_started(&mut self, _first_pen: &plotter_path::config::pens::LayerPen, _pen_changes: usize) {
        let copy = self.next_copy;
        self.show_copy(copy);
        self.next_copy = copy + 1;
    }

    fn plot_pause(&mut self, pause: &job::stops::PauseRequest) -> PenChangeChoice {
        // A layer's `!`, a refill or fresh paper for the next copy: parked with the pen up until the operator
        // resumes (or stops) the machine. The card counts the copy whose paper goes in.
        if let job::stops::PauseWhy::Paper { copy, .. } = pause.why {
            self.show_copy(copy);
            self.next_copy = copy;
        }
        match self.wait_for_operator(Some(pause.ask())) {
            PauseChoice::Resume => PenChangeChoice::Continue,
            PauseChoice::Abort => PenChangeChoice::Stop,
        }
    }

    fn stop_requested(&mut self) -> Option<StopCause> {
        if self.slot.peek().estop {
            self.operator_stop = true;
            return Some(StopCause::Requested);
        }
        if self.studio.ending() {
            return Some(StopCause::Requested);
        }
        Stop::process().stop_cause()
    }
}

impl StudioEvents<'_> {
    /// A resume goes on with copy `copy`, or after it when its journal says it was `complete`.
    fn resuming_copy(&mut self, copy: u64, complete: bool) {
        self.next_copy = copy + 1;
        if !complete {
            self.show_copy(copy);
        }
    }

    /// The card shows the machine at copy `copy` (for a job of several copies only).
    fn show_copy(&self, copy: u64) {
        let text = match self.copies {
            1 => None,
            0 => Some(format!("copy {copy} (until stopped)")),
            n => Some(format!("copy {copy} of {n}")),
        };
        set(self.studio, self.slot, |s| s.copy = text);
    }

    /// The job is paused (saying `prompt` to the operator, if any) until the operator resumes or stops it, or the
    /// studio ends.
    fn wait_for_operator(&mut self, prompt: Option<String>) -> PauseChoice {
        let since = Instant::now();
        let _ = self.studio.queue().set_paused(self.job, true);
        set(self.studio, self.slot, |s| {
            s.state = Activity::Paused;
            s.prompt = prompt;
        });
        let studio = self.studio;
        let choice = self.slot.wait_for(Duration::from_millis(100), |r| {
            if r.stop || r.estop || studio.ending() || Stop::process().stop_cause().is_some() {
                return Some(PauseChoice::Abort);
            }
            if std::mem::take(&mut r.resume) {
                return Some(PauseChoice::Resume);
            }
            None
        });
        self.paused_for += since.elapsed();
        if choice == PauseChoice::Resume {
            let _ = self.studio.queue().set_paused(self.job, false);
            set(self.studio, self.slot, |s| {
                s.state = Activity::Plotting;
                s.prompt = None;
            });
        } else {
            let r = self.slot.peek();
            self.operator_stop = r.stop || r.estop;
            set(self.studio, self.slot, |s| s.prompt = None);
        }
        choice
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::studio::machines::parse_machine;
    use crate::studio::queue::NewJob;
    use crate::studio::running::StudioOptions;
    use crate::studio::status::Activity;
    use serde_json::json;

    const SQUARES: &str = r#"<svg xmlns="http://www.w3.org/2000/svg" width="60mm" height="60mm" viewBox="0 0 60 60">
      <rect x="10" y="10" width="40" height="40" fill="none" stroke="black"/>
      <rect x="20" y="20" width="20" height="20" fill="none" stroke="black"/>
      <path d="M 5 5 L 55 5 M 5 55 L 55 55 M 5 30 L 55 30" fill="none" stroke="black"/>
    </svg>"#;

    /// Many short blocks (circles), so the plot is never all queued on the firmware at once.
    fn rings() -> String {
        let circles: String = (1..=12)
            .map(|r| format!(r#"<circle cx="30" cy="30" r="{}" fill="none" stroke="black"/>"#, 2 * r))
            .collect();
        format!(
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="60mm" height="60mm" viewBox="0 0 60 60">{circles}</svg>"#
        )
    }

    fn temp_dir(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("plotter-worker-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        dir
    }

    /// Wait (at most 60 s) until `done` holds.
    fn until(what: &str, mut done: impl FnMut() -> bool) {
        let start = Instant::now();
        while !done() {
            assert!(start.elapsed() < Duration::from_secs(60), "still waiting for {what}");
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// A studio of `machines` in `dir` with simulators at full speed and a 500 ms retry cap, its workers started.
    fn open(dir: &Path, machines: Vec<MachineSpec>) -> (Arc<Studio>, Vec<JoinHandle<()>>) {
        let options = StudioOptions { sim_speed: f64::INFINITY, max_retry: Duration::from_millis(500) };
        let studio = Studio::open(dir, machines, options).unwrap();
        let workers = start(&studio).unwrap();
        (studio, workers)
    }

    /// End the studio, wait for its workers and remove its folder.
    fn close(studio: Arc<Studio>, workers: Vec<JoinHandle<()>>, dir: &Path) {
        studio.end();
        for w in workers {
            w.join().unwrap();
        }
        drop(studio);
        std::fs::remove_dir_all(dir).ok();
    }

    fn state_of(studio: &Studio, id: i64) -> JobState {
        studio.queue().get(id).unwrap().state
    }

    /// The plan `plotter plot` would run for the squares with `flags` on the default kit: blocks and seconds.
    fn plan_alone(flags: &[&str]) -> (usize, f64) {
        let dir = temp_dir("alone");
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("squares.svg");
        std::fs::write(&file, SQUARES).unwrap();
        let args = JobArgs::from_options(&json!({ "args": flags })).unwrap();
        let profile = plotter_path::MachineProfile::default_plotter();
        let (steps, _) =
            crate::job::load::load_steps(&file, &profile, &args.input, &args.layout, &args.optimize, None).unwrap();
        let p = plan::plan(&profile, &steps, plan::homed_position(&profile).unwrap(), Lookahead::Whole).unwrap();
        std::fs::remove_dir_all(&dir).ok();
        (p.blocks.len(), p.seconds())
    }

    #[test]
    fn each_machine_plots_its_own_job_and_a_dead_port_takes_no_other_down() {
        let dir = temp_dir("two");
        let machines = vec![
            parse_machine("a=sim").unwrap(),
            parse_machine("b=sim").unwrap(),
            parse_machine("gone=/dev/no-such-plotter,firmware=ours").unwrap(),
        ];
        let (studio, workers) = open(&dir, machines);
        let flags = ["--paper", "a6", "--margin", "12"];
        let job = |name: &str| NewJob::new(name, SQUARES.as_bytes().to_vec()).with_options(json!({ "args": flags }));
        let for_b = studio.add(&job("b.svg").for_machine("b")).unwrap();
        let for_gone = studio.add(&job("gone.svg").for_machine("gone")).unwrap();
        until("b's job", || state_of(&studio, for_b) == JobState::Done);
        let any = studio.add(&job("any.svg")).unwrap();
        until("the any-machine job", || state_of(&studio, any) == JobState::Done);
        // b plotted its own job; the any-machine job went to a machine that is up, never to the dead one.
        assert_eq!(studio.queue().get(for_b).unwrap().claimed_by.as_deref(), Some("b"));
        assert_ne!(studio.queue().get(any).unwrap().claimed_by.as_deref(), Some("gone"));
        // Exactly the plan `plotter plot` makes of the same drawing and flags, executed in its planned time.
        let (blocks, seconds) = plan_alone(&flags);
        let last = studio.slot("b").unwrap().status().last.clone().unwrap();
        let expected = format!("{blocks} blocks");
        assert!(
            last.contains(&expected) && last.contains(&format!("planned {seconds:.3} s, executed {seconds:.3} s")),
            "{last}"
        );
        let h = studio.queue().history(for_b).unwrap();
        assert_eq!(h.len(), 1);
        assert_eq!(h[0].outcome.as_deref(), Some("done"));
        // The dead port: reported by name, retried, its job waiting.
        let gone = studio.slot("gone").unwrap().status().clone();
        assert_eq!(gone.state, Activity::Offline);
        let e = gone.error.unwrap();
        assert!(e.contains("/dev/no-such-plotter") && e.contains("trying again in"), "{e}");
        assert_eq!(state_of(&studio, for_gone), JobState::Queued);
        close(studio, workers, &dir);
    }

    #[test]
    fn a_refill_pause_parks_the_machine_until_the_operator_resumes_it() {
        let dir = temp_dir("refill");
        let (studio, workers) = open(&dir, vec![parse_machine("a=sim").unwrap()]);
        // The rings in the file's order draw 2π × (2 + 4 + … + 18) = 565.5 mm before the 20 mm ring (125.7 mm),
        // which would pass 600 mm: one refill there, and the last three rings (414.7 mm) fit in the second part.
        let flags = json!({ "args": ["--no-optimize", "--split-distance", "600"] });
        let id = studio.add(&NewJob::new("rings.svg", rings().into_bytes()).with_options(flags)).unwrap();
        let slot = Arc::clone(studio.slot("a").unwrap());
        until("the refill pause", || slot.status().state == Activity::Paused);
        assert_eq!(state_of(&studio, id), JobState::Paused);
        let prompt = slot.status().prompt.clone().unwrap();
        assert!(prompt.contains("refill") && prompt.contains("part 2"), "{prompt}");
        let held = slot.status().percent;
        assert!(held > 0.0 && held < 100.0, "{held}");
        std::thread::sleep(Duration::from_millis(300));
        assert!((slot.status().percent - held).abs() < 1e-9, "nothing moves while it waits");
        assert_eq!(slot.status().pen_down, Some(false), "waiting with the pen up");
        studio.resume("a").unwrap();
        until("the job's end", || state_of(&studio, id) == JobState::Done);
        assert_eq!(slot.status().prompt, None);
        let e = studio.add(
            &NewJob::new("r.svg", rings().into_bytes()).with_options(json!({ "args": ["--split-distance", "0"] })),
        );
        assert!(e.unwrap_err().to_string().contains("--split-distance 0: give the drawn length per refill in mm"));
        close(studio, workers, &dir);
    }

    /// Two Inkscape layers, a black 20 mm square and a red 20 mm line: one pen change, to the kit's red pen.
    const TWO_PENS: &str = r##"<svg xmlns="http://www.w3.org/2000/svg" xmlns:inkscape="http://www.inkscape.org/namespaces/inkscape"
      width="60mm" height="60mm" viewBox="0 0 60 60">
      <g inkscape:groupmode="layer" inkscape:label="black"><rect x="10" y="10" width="20" height="20" fill="none"
        stroke="#000000"/></g>
      <g inkscape:groupmode="layer" inkscape:label="red"><path d="M 10 40 L 30 40" fill="none" stroke="#ff0000"/></g>
    </svg>"##;

    #[test]
    fn a_pen_change_parks_the_machine_tells_the_webhook_and_goes_on_at_resume() {
        let dir = temp_dir("pens");
        let (studio, workers) = open(&dir, vec![parse_machine("a=sim").unwrap()]);
        let (url, seen) = crate::job::webhook::receiver::receiver(0);
        let flags = json!({ "args": ["--no-optimize", "--webhook", url] });
        let id = studio.add(&NewJob::new("pens.svg", TWO_PENS.as_bytes().to_vec()).with_options(flags)).unwrap();
        let slot = Arc::clone(studio.slot("a").unwrap());
        until("the pen change", || slot.status().state == Activity::Paused);
        assert_eq!(state_of(&studio, id), JobState::Paused);
        let prompt = slot.status().prompt.clone().unwrap();
        assert_eq!(prompt, "change to pen 2, red fineliner 0.5 (#ff0000), for layer \"red\"");
        // The page reads it from the studio's snapshot, beside the machine's state.
        let page: serde_json::Value = serde_json::from_str(&studio.snapshot_json().unwrap()).unwrap();
        assert_eq!(page["machines"][0]["state"], "paused");
        assert_eq!(page["machines"][0]["prompt"].as_str(), Some(prompt.as_str()));
        // The square is drawn (80 of the 100 mm), the line not yet; nothing moves, the pen is up.
        let held = slot.status().percent;
        assert!(held > 0.0 && held < 100.0, "{held}");
        std::thread::sleep(Duration::from_millis(300));
        assert!((slot.status().percent - held).abs() < 1e-9, "nothing moves while it waits");
        assert_eq!(slot.status().pen_down, Some(false), "waiting with the pen up");
        until("the webhook's pen-change event", || !seen.lock().unwrap().is_empty());
        studio.resume("a").unwrap();
        until("the job's end", || state_of(&studio, id) == JobState::Done);
        assert_eq!(slot.status().prompt, None);
        until("the webhook's end event", || seen.lock().unwrap().len() == 2);
        let events = crate::job::webhook::receiver::events(&seen);
        assert_eq!(events[0].0, "pen_change");
        assert_eq!(events[0].1, "pen change 1/1: load pen red fineliner 0.5 (#ff0000) for layer \"red\"");
        assert_eq!(events[1].0, "finished");
        // Both layers drawn: 80 mm of square and 20 mm of line.
        let last = slot.status().last.clone().unwrap();
        assert!(last.contains("100.0 mm pen-down"), "{last}");
        close(studio, workers, &dir);
    }

    /// A 20 mm square: 80 mm drawn per copy.
    const SQUARE: &str = r#"<svg xmlns="http://www.w3.org/2000/svg" width="60mm" height="60mm" viewBox="0 0 60 60">
      <rect x="10" y="10" width="20" height="20" fill="none" stroke="black"/></svg>"#;

    /// Wait for the machine to park with a prompt; (the prompt, the card's copy).
    fn parked(slot: &Slot) -> (String, Option<String>) {
        until("the machine parked", || slot.status().state == Activity::Paused);
        let s = slot.status();
        (s.prompt.clone().unwrap(), s.copy.clone())
    }

    /// Three copies of the square with a 0.5 s page delay: the machine parks for fresh paper before copy 2 and
    /// tells the webhook; the studio ends there (as a killed server would leave it, with copy 1's journal
    /// finished) and is started again: the confirmed job homes, asks again for the paper of copy 2, then for copy
    /// 3's, and draws exactly the two copies left: 2 × 80 = 160.0 mm pen-down, with at least the two page delays
    /// (1 s) executed beyond the two copies' plans; the webhook hears the resumed job too.
    #[test]
    fn copies_park_for_fresh_paper_and_go_on_with_the_copies_left_after_a_restart() {
        let dir = temp_dir("copies");
        let (url, seen) = crate::job::webhook::receiver::receiver(0);
        let (studio, workers) = open(&dir, vec![parse_machine("a=sim").unwrap()]);
        let flags = json!({ "args": ["--no-optimize", "--copies", "3", "--page-delay", "0.5", "--webhook", url] });
        let id = studio.add(&NewJob::new("square.svg", SQUARE.as_bytes().to_vec()).with_options(flags)).unwrap();
        let slot = Arc::clone(studio.slot("a").unwrap());
        let paper = |n: u32| format!("put in fresh paper for copy {n} of 3");
        assert_eq!(parked(&slot), (paper(2), Some("copy 2 of 3".to_string())));
        assert_eq!(state_of(&studio, id), JobState::Paused);
        let page: serde_json::Value = serde_json::from_str(&studio.snapshot_json().unwrap()).unwrap();
        assert_eq!(page["machines"][0]["copy"], "copy 2 of 3");
        until("the webhook's paper event", || !seen.lock().unwrap().is_empty());
        assert_eq!(crate::job::webhook::receiver::events(&seen), [("pause".to_string(), paper(2))]);
        // The studio ends while the machine waits for paper: the job is interrupted, not done.
        studio.end();
        for w in workers {
            w.join().unwrap();
        }
        drop(studio);
        until("the webhook's stopped event", || seen.lock().unwrap().len() == 2);
        assert_eq!(
            crate::job::webhook::receiver::events(&seen)[1],
            (
                "stopped".to_string(),
                "stopped by a stop request while the studio was shutting down, parked between copies (stopped at the \
                 paper change before copy 2); the job goes on with the copies left once the studio is back"
                    .to_string()
            )
        );
        let (studio, workers) = open(&dir, vec![parse_machine("a=sim").unwrap()]);
        assert_eq!(state_of(&studio, id), JobState::Interrupted);
        let slot = Arc::clone(studio.slot("a").unwrap());
        studio.confirm_resume(id).unwrap();
        assert_eq!(parked(&slot), (paper(2), Some("copy 2 of 3".to_string())));
        studio.resume("a").unwrap();
        until("copy 2 drawn", || slot.status().prompt.as_deref() == Some(paper(3).as_str()));
        assert_eq!(parked(&slot), (paper(3), Some("copy 3 of 3".to_string())));
        studio.resume("a").unwrap();
        until("the job's end", || state_of(&studio, id) == JobState::Done && slot.status().last.is_some());
        let last = slot.status().last.clone().unwrap();
        assert!(last.contains(": 2 copies, ") && last.contains(" 160.0 mm pen-down"), "{last}");
        let number = |after: &str| -> f64 {
            let rest = &last[last.find(after).unwrap() + after.len()..];
            rest.split(' ').next().unwrap().parse().unwrap()
        };
        let (planned, executed) = (number("planned "), number("executed "));
        assert!(executed - planned >= 1.0, "{last}");
        assert_eq!(slot.status().copy, None);
        until("the webhook's end", || seen.lock().unwrap().len() == 5);
        let events = crate::job::webhook::receiver::events(&seen);
        let names: Vec<&str> = events.iter().map(|e| e.0.as_str()).collect();
        assert_eq!(names, ["pause", "stopped", "pause", "pause", "finished"]);
        assert_eq!((events[2].1.clone(), events[3].1.clone()), (paper(2), paper(3)));
        assert!(events[4].1.starts_with("3 copies plotted"), "{}", events[4].1);
        close(studio, workers, &dir);
    }

    /// `--copies 0`: copies until the operator stops at a paper change. Three copies drawn (3 × 80 = 240.0 mm),
    /// the card counting "copy 4 (until stopped)" at the fourth paper; stopped there, the job is done.
    #[test]
    fn copies_until_stopped_end_done_at_the_paper_change_the_operator_stops() {
        let dir = temp_dir("until");
        let (studio, workers) = open(&dir, vec![parse_machine("a=sim").unwrap()]);
        let flags = json!({ "args": ["--no-optimize", "--copies", "0"] });
        let id = studio.add(&NewJob::new("square.svg", SQUARE.as_bytes().to_vec()).with_options(flags)).unwrap();
        let slot = Arc::clone(studio.slot("a").unwrap());
        for n in 2..=4 {
            let at = format!("put in fresh paper for copy {n}");
            until("the next paper", || slot.status().prompt.as_deref() == Some(at.as_str()));
            assert_eq!(parked(&slot), (at, Some(format!("copy {n} (until stopped)"))));
            if n < 4 {
                studio.resume("a").unwrap();
            }
        }
        studio.stop("a").unwrap();
        until("the job's end", || state_of(&studio, id) == JobState::Done && slot.status().last.is_some());
        let last = slot.status().last.clone().unwrap();
        assert!(last.contains(": 3 copies, ") && last.contains(" 240.0 mm pen-down"), "{last}");
        assert!(last.ends_with("; stopped at the paper change before copy 4"), "{last}");
        assert_eq!(studio.queue().history(id).unwrap()[0].outcome.as_deref(), Some("done"));
        close(studio, workers, &dir);
    }

    #[test]
    fn pause_resume_and_emergency_stop_reach_the_plot() {
        let dir = temp_dir("controls");
        let options = StudioOptions { sim_speed: 4.0, max_retry: Duration::from_millis(500) };
        let studio = Studio::open(&dir, vec![parse_machine("a=sim").unwrap()], options).unwrap();
        let workers = start(&studio).unwrap();
        let job = NewJob::new("rings.svg", rings().into_bytes()).with_options(json!({ "args": ["--no-optimize"] }));
        let first = studio.add(&job.clone().for_machine("a")).unwrap();
        let slot = Arc::clone(studio.slot("a").unwrap());
        until("the plot under way", || slot.status().percent > 5.0);
        studio.pause("a").unwrap();
        until("the pause", || slot.status().state == Activity::Paused);
        assert_eq!(state_of(&studio, first), JobState::Paused);
        let held = slot.status().percent;
        std::thread::sleep(Duration::from_millis(300));
        assert!((slot.status().percent - held).abs() < 1e-9, "nothing moves while paused");
        assert_eq!(slot.status().pen_down, Some(false), "paused with the pen up");
        studio.resume("a").unwrap();
        until("the first job's end", || state_of(&studio, first) == JobState::Done);
        // The plot time leaves the pause out.
        let plot = studio.queue().history(first).unwrap()[0].plot_time.unwrap();
        let second = studio.add(&job.for_machine("a")).unwrap();
        until("the second plot under way", || {
            let s = slot.status();
            s.job == Some(second) && s.percent > 5.0
        });
        studio.estop("a").unwrap();
        until("the stop", || state_of(&studio, second) == JobState::Cancelled);
        let h = studio.queue().history(second).unwrap();
        assert_eq!(h[0].outcome.as_deref(), Some("cancelled by the operator"));
        until("the machine idle", || slot.status().state == Activity::Idle);
        assert!(slot.status().percent < 100.0, "stopped before the end");
        close(studio, workers, &dir);
        assert!(plot > Duration::ZERO);
    }
}
