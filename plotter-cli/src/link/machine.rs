//! The machine a plot job drives, whatever its firmware: ours (step blocks in CRC frames,
//! [`crate::link::session::Session`]), GRBL (G-code with character counting,
//! [`crate::link::grbl::session::GrblSession`]) or an EiBotBoard (`LM` moves,
//! [`crate::link::ebb::session::EbbSession`]). The job ([`crate::job`]) only talks to [`PlotMachine`], so pen
//! changes, pauses, the journal and resume work the same on all of them.

use std::time::Duration;

use anyhow::Context as _;

use plotter_path::MachineProfile;
use plotter_path::motion::plan::{MachinePos, MotionPlan};
use plotter_path::motion::servo::ServoSync;

use super::Transport;
use super::ebb::session::EbbSession;
use super::grbl::session::GrblSession;
use super::session::Session;
use super::sim::SimTransport;
use super::stream::{self, Control, StreamError, StreamOptions, StreamStats};
use crate::link::journal::JournalState;

/// Which firmware a port speaks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum Firmware {
    /// Tell by the start-up banner (or `$I`, when the banner was missed).
    #[default]
    Auto,
    /// This project's firmware (plotter-fw).
    Ours,
    /// GRBL 1.1, grblHAL, FluidNC.
    Grbl,
    /// The EiBotBoard (AxiDraw, NextDraw, iDraw): `LM`/`SM` moves, servo pen.
    Ebb,
    /// A vintage HP-GL plotter (HP 7475A and kin), sent the HP-GL export under a buffer handshake (by `plotter plot`
    /// and `plotter serve`, which drive it through an HP-GL session of their own).
    Hpgl,
}

impl Firmware {
    /// How this firmware runs a servo pen's command among the moves, which the plan is made for: GRBL stops the
    /// motion for `M3` (its spindle sync); ours and the EiBotBoard queue it between two moves without stopping the
    /// motors; `auto` plans as for the simulated plotter (ours).
    pub fn servo_sync(self) -> ServoSync {
        match self {
            Firmware::Grbl => ServoSync::AtRest,
            Firmware::Auto | Firmware::Ours | Firmware::Ebb | Firmware::Hpgl => ServoSync::InMotion,
        }
    }
}

/// `profile` for a plot on `firmware`: with the servo timing the plan must be made for
/// ([`MachineProfile::servo_sync`]).
pub fn profile_for(profile: &MachineProfile, firmware: Firmware) -> std::borrow::Cow<'_, MachineProfile> {
    let sync = firmware.servo_sync();
    if profile.servo_sync == sync {
        return std::borrow::Cow::Borrowed(profile);
    }
    std::borrow::Cow::Owned(MachineProfile { servo_sync: sync, ..profile.clone() })
}

/// What a plot job needs from a machine.
pub trait PlotMachine {
    /// Where it is connected (for messages).
    fn name(&self) -> &str;
    /// Which firmware it runs.
    fn firmware(&self) -> Firmware;
    /// Run the homing cycle; afterwards the machine stands at the profile's homed position.
    fn home(&mut self) -> anyhow::Result<()>;
    /// Home where the carriage may stand over a drawing (a resume): the firmware keeps a known pen height and
    /// never homes Z onto the paper (see [`super::home_axes`]); returns what was done beyond a plain homing, for
    /// the user. Others: [`PlotMachine::home`].
    fn home_over_drawing(&mut self, _profile: &MachineProfile) -> anyhow::Result<Option<String>> {
        self.home().map(|()| None)
    }
    /// Home only the named axes (`plotter home --z`); none named: [`PlotMachine::home`]. Only our firmware homes
    /// axes one by one.
    fn home_axes(&mut self, axes: super::home_axes::HomeAxes) -> anyhow::Result<()> {
        if axes.is_all() {
            return self.home();
        }
        anyhow::bail!(
            "{} ({:?} firmware) homes all its axes at once: run `plotter home` without --x, --y or --z",
            self.name(),
            self.firmware()
        )
    }
    /// The current position, steps of the plot's coordinates.
    fn position(&mut self) -> anyhow::Result<MachinePos>;
    /// Stream `plan` (which starts where the machine stands); returns when it has been executed.
    fn stream(&mut self, plan: &MotionPlan, control: &mut dyn Control) -> Result<StreamStats, StreamError>;
    /// After the host lost a plot: the first block of `full` (the original plan) not certainly executed, given
    /// the journal's `state`. Waits until the machine has finished what it still holds.
    fn resume_point(&mut self, state: &JournalState, full: &MotionPlan) -> anyhow::Result<usize>;
    /// The in-process simulator's executed motion time so far, ticks (0 on a port).
    fn busy_ticks(&self) -> u64 {
        0
    }
    /// Whether the machine is in an alarm that needs the user's decision (`$X` on GRBL).
    fn alarm_pending(&mut self) -> anyhow::Result<Option<String>> {
        Ok(None)
    }
    /// Clear the alarm after the user agreed.
    fn unlock(&mut self) -> anyhow::Result<()> {
        Ok(())
    }
    /// Whether `home` runs a real homing cycle (else it only declares the current position as home).
    fn can_home(&self) -> bool {
        true
    }
    /// Prepare for a plot (our firmware: enter framed mode).
    fn begin(&mut self) -> anyhow::Result<()> {
        Ok(())
    }
    /// A plot finished (our firmware: leave framed mode).
    fn end(&mut self) -> anyhow::Result<()> {
        Ok(())
    }
    /// After a failed or aborted stream: stop what is queued and lift the pen, if the machine still answers;
    /// returns what was done, for the user (empty when there was nothing to do).
    fn stop_and_lift(&mut self, _profile: &plotter_path::MachineProfile) -> anyhow::Result<String> {
        Ok(String::new())
    }
}

impl<T: Transport + 'static> PlotMachine for Session<T> {
    fn name(&self) -> &str {
        &self.name
    }

    fn firmware(&self) -> Firmware {
        Firmware::Ours
    }

    fn home(&mut self) -> anyhow::Result<()> {
        Session::home(self)
    }

    fn home_over_drawing(&mut self, profile: &MachineProfile) -> anyhow::Result<Option<String>> {
        Session::home_over_drawing(self, profile)
    }

    fn home_axes(&mut self, axes: super::home_axes::HomeAxes) -> anyhow::Result<()> {
        Session::home_axes(self, axes)
    }

    fn position(&mut self) -> anyhow::Result<MachinePos> {
        Ok(self.status()?.steps)
    }

    fn stream(&mut self, plan: &MotionPlan, control: &mut dyn Control) -> Result<StreamStats, StreamError> {
        stream::stream_plan(self, plan, StreamOptions::default(), control).map(|(_, s)| s)
    }

    fn resume_point(&mut self, state: &JournalState, full: &MotionPlan) -> anyhow::Result<usize> {
        // If the firmware is still running the session the host lost, let it finish what it accepted. Frames that
        // were in flight when the host died may have been accepted after the journal's last line: the firmware's
        // sequence number tells how many (one per block). If it then stands exactly where that many blocks end,
        // they were all executed; otherwise (restarted, moved) only the journal's executed count is certain.
        self.enter_framed()?;
        let status = self.wait_idle(Duration::from_millis(50))?;
        // (Numbered lines this session sent itself took sequence numbers too: they are no blocks.)
        let extra = status.seq.wrapping_sub(state.seq_after_accepted).wrapping_sub(self.own_lines);
        let accepted = usize::try_from(extra).ok().map(|x| state.accepted + x).filter(|&a| a <= full.blocks.len());
        Ok(match accepted {
            Some(a) if a > 0 && status.steps == full.position_after(a - 1) => a,
            _ => state.executed,
        })
    }

    fn busy_ticks(&self) -> u64 {
        // The simulator, or the simulator paced to the wall clock (`plot --sim-speed`, and `plot` at full speed).
        let t = &self.transport as &dyn std::any::Any;
        let paced = || t.downcast_ref::<super::paced::PacedSim>().map(super::paced::PacedSim::inner);
        let sim = t.downcast_ref::<SimTransport>().or_else(paced);
        sim.map_or(0, |s| s.sim().hal().busy_ticks())
    }

    fn begin(&mut self) -> anyhow::Result<()> {
        self.enter_framed()
    }

    fn end(&mut self) -> anyhow::Result<()> {
        self.leave_framed()
    }

    fn stop_and_lift(&mut self, profile: &plotter_path::MachineProfile) -> anyhow::Result<String> {
        Session::stop_and_lift(self, profile.pen.up_z_mm).context("could not lift the pen")?;
        Ok(String::new())
    }
}

impl<T: Transport + 'static> PlotMachine for GrblSession<T> {
    fn name(&self) -> &str {
        &self.name
    }

    fn firmware(&self) -> Firmware {
        Firmware::Grbl
    }

    fn home(&mut self) -> anyhow::Result<()> {
        GrblSession::home(self)
    }

    fn position(&mut self) -> anyhow::Result<MachinePos> {
        GrblSession::position(self)
    }

    fn stream(&mut self, plan: &MotionPlan, control: &mut dyn Control) -> Result<StreamStats, StreamError> {
        GrblSession::stream(self, plan, control)
    }

    fn resume_point(&mut self, state: &JournalState, full: &MotionPlan) -> anyhow::Result<usize> {
        GrblSession::resume_point(self, state.executed, state.accepted, full)
    }

    fn busy_ticks(&self) -> u64 {
        (&self.transport as &dyn std::any::Any)
            .downcast_ref::<crate::link::grbl::emulator_transport::EmulatorTransport>()
            .map_or(0, |t| t.emulator().backend().hal().busy_ticks())
    }

    fn alarm_pending(&mut self) -> anyhow::Result<Option<String>> {
        if !self.in_alarm()? {
            return Ok(None);
        }
        let why = self.messages.last().cloned().unwrap_or_else(|| "alarm".into());
        Ok(Some(format!("{} is in alarm ({why})", self.name)))
    }

    fn unlock(&mut self) -> anyhow::Result<()> {
        GrblSession::unlock(self)
    }

    fn can_home(&self) -> bool {
        self.settings.homing_enabled()
    }

    fn stop_and_lift(&mut self, _profile: &plotter_path::MachineProfile) -> anyhow::Result<String> {
        // The session lifts with the profile it writes the plot for.
        GrblSession::stop_and_lift(self)
    }
}

impl<T: Transport + 'static> PlotMachine for EbbSession<T> {
    fn name(&self) -> &str {
        &self.name
    }

    fn firmware(&self) -> Firmware {
        Firmware::Ebb
    }

    fn home(&mut self) -> anyhow::Result<()> {
        EbbSession::home(self)
    }

    fn position(&mut self) -> anyhow::Result<MachinePos> {
        EbbSession::position(self)
    }

    fn stream(&mut self, plan: &MotionPlan, control: &mut dyn Control) -> Result<StreamStats, StreamError> {
        EbbSession::stream(self, plan, control)
    }

    fn resume_point(&mut self, state: &JournalState, full: &MotionPlan) -> anyhow::Result<usize> {
        EbbSession::resume_point(self, state.executed, state.accepted, full)
    }

    fn busy_ticks(&self) -> u64 {
        (&self.transport as &dyn std::any::Any)
            .downcast_ref::<crate::link::ebb::emulator_transport::EbbTransport>()
            .map_or(0, |t| t.emulator().busy_intervals() * u64::from(crate::link::ebb::kinematics::INTERVAL_US))
    }

    fn can_home(&self) -> bool {
        false
    }

    fn stop_and_lift(&mut self, _profile: &plotter_path::MachineProfile) -> anyhow::Result<String> {
        EbbSession::stop_and_lift(self)
    }
}

/// How far outside its travel a machine may report its pen before the report is taken for a lie, mm (a carriage
/// pushed against a frame beyond its endstop; a board's counters that went wild are kilometres out).
pub const POSITION_MARGIN_MM: f64 = 10.0;

/// Where `machine` reports its pen, checked against the profile's travel (X and Y within 0..travel, give or take
/// [`POSITION_MARGIN_MM`]): a position outside is refused before any move is planned from it (a board answering
/// kilometres away would get a move of that length), naming the position and the travel.
pub fn position_within_travel<M: PlotMachine + ?Sized>(
    machine: &mut M,
    profile: &MachineProfile,
) -> anyhow::Result<MachinePos> {
    let at = machine.position()?;
    let axes = [&profile.axes.x, &profile.axes.y];
    for (i, (&p, axis)) in at.iter().zip(axes).enumerate() {
        let mm = f64::from(p) / axis.steps_per_mm;
        if !(-POSITION_MARGIN_MM..=axis.travel_mm + POSITION_MARGIN_MM).contains(&mm) {
            anyhow::bail!(
                "{} reports the pen at {} = {} steps ({} mm), outside its travel 0..{} mm (± {POSITION_MARGIN_MM} mm): \
                 refusing to move from there. Home the machine (or power-cycle it and move the carriage home by \
                 hand) before plotting; do not use --no-home or --trust-position",
                machine.name(),
                ["X", "Y"][i],
                p,
                plotter_path::output::stats::fixed(mm, 1),
                axis.travel_mm
            );
        }
    }
    Ok(at)
}

/// Home `m` (shared by `plotter home` and the web app): refused while the machine is in an alarm that homing
/// cannot clear (GRBL with homing disabled, `$22=0`); returns where it then stands, steps.
pub fn home_machine(m: &mut dyn PlotMachine) -> anyhow::Result<MachinePos> {
    if let Some(what) = m.alarm_pending()?
        && !m.can_home()
    {
        anyhow::bail!("{what}; homing is disabled, unlock it with `$X` on the console once it is safe");
    }
    m.home()?;
    m.position()
}

/// Which firmware answers on `transport`: a start-up banner (`Grbl 1.1x ['$' for help]` or `plotter-fw …`)
/// decides; when none arrives (the port did not reset the board), `$I` does — GRBL answers `[VER:…]`, our
/// firmware an error, an EiBotBoard `!8 Err: Unknown command` (it is then asked `V`). Nothing is reset or moved.
pub fn detect<T: Transport>(transport: &mut T) -> anyhow::Result<Firmware> {
    let name_of = |l: &str| {
        if l.starts_with("Grbl ") || l.starts_with("[VER:") {
            Some(Firmware::Grbl)
        } else if l.starts_with("plotter-fw ") || l.starts_with("FIRMWARE_NAME:plotter-fw") {
            Some(Firmware::Ours)
        } else {
            None
        }
    };
    // Each listen lasts until a quiet gap, and at most a second and a half however much the device says (a wrong
    // port that babbles); a stop (any signal) ends it.
    let listen = |transport: &mut T, quiet: Duration, each: &mut dyn FnMut(&str) -> bool| -> anyhow::Result<()> {
        let mut wait = super::wait::Wait::new("the port", "its answers", transport.now(), Duration::from_millis(1500))
            .interruptible()
            .on_any_interrupt();
        loop {
            let slice = match wait.next(transport.now(), quiet) {
                Ok(slice) => slice,
                Err(super::wait::WaitError::TimedOut { .. }) => return Ok(()),
                Err(e) => return Err(e.into()),
            };
            match transport.recv_line(slice)? {
                Some(l) if each(&l) => return Ok(()),
                Some(_) => {}
                None => return Ok(()),
            }
        }
    };
    let mut found = None;
    listen(transport, Duration::from_millis(300), &mut |l| {
        found = name_of(l);
        found.is_some()
    })?;
    if let Some(f) = found {
        return Ok(f);
    }
    transport.send(b"$I\n")?;
    let mut found = Firmware::Ours;
    let mut ebb_error = false;
    listen(transport, Duration::from_millis(500), &mut |l| {
        if let Some(f) = name_of(l) {
            found = f;
        }
        ebb_error |= l.starts_with("!8 Err:");
        false
    })?;
    if ebb_error {
        transport.send(b"V\r")?;
        listen(transport, Duration::from_millis(500), &mut |l| {
            if super::ebb::messages::EbbVersion::parse(l).is_some() {
                found = Firmware::Ebb;
            }
            false
        })?;
    }
    Ok(found)
}

/// A connected machine of either firmware.
// One per connection: the size difference between the variants does not matter.
#[allow(clippy::large_enum_variant)]
pub enum Connected<T: Transport> {
    /// This project's firmware.
    Ours(Session<T>),
    /// A GRBL controller.
    Grbl(GrblSession<T>),
    /// An EiBotBoard.
    Ebb(EbbSession<T>),
}

impl<T: Transport + 'static> Connected<T> {
    /// Connect over `transport` (named `name`) to `firmware` (detected when [`Firmware::Auto`]); the profile
    /// is what GRBL's settings are checked against and what its program is written for.
    pub fn connect(
        mut transport: T,
        name: &str,
        firmware: Firmware,
        profile: &plotter_path::MachineProfile,
    ) -> crate::Result<Self> {
        let firmware = match firmware {
            Firmware::Auto => detect(&mut transport)?,
            f => f,
        };
        Ok(match firmware {
            Firmware::Grbl => Connected::Grbl(GrblSession::connect(transport, name, profile)?),
            Firmware::Ebb => Connected::Ebb(EbbSession::connect(transport, name, profile)?),
            Firmware::Hpgl => {
                return Err(crate::Error::Other(anyhow::anyhow!(
                    "{name}: an HP-GL plotter is driven by `plotter plot FILE --port {name} --firmware hpgl` only \
                     (it plans its own moves: no homing, jogging or console here)"
                )));
            }
            _ => Connected::Ours(Session::connect(transport, name)?),
        })
    }

    /// The machine, for the plot job.
    pub fn machine(&mut self) -> &mut dyn PlotMachine {
        match self {
            Connected::Ours(s) => s,
            Connected::Grbl(g) => g,
            Connected::Ebb(e) => e,
        }
    }

    /// The byte pipe (console).
    pub fn transport(&mut self) -> &mut T {
        match self {
            Connected::Ours(s) => &mut s.transport,
            Connected::Grbl(g) => &mut g.transport,
            Connected::Ebb(e) => &mut e.transport,
        }
    }

    /// One line saying what is connected.
    pub fn describe(&self) -> String {
        match self {
            Connected::Ours(s) => format!(
                "plotter-fw {} on {} (rx {} bytes, queue {} blocks)",
                s.info.version, s.name, s.info.rx_bytes, s.info.queue_blocks
            ),
            Connected::Grbl(g) => format!(
                "GRBL {} on {} (rx {} bytes, homing {})",
                g.version,
                g.name,
                g.rx_bytes,
                if g.settings.homing_enabled() { "on" } else { "off ($22=0)" }
            ),
            Connected::Ebb(e) => format!(
                "EiBotBoard firmware {} on {} (FIFO {} command(s), {} moves)",
                e.version,
                e.name,
                e.fifo,
                if e.style == super::ebb::program::MotionStyle::Lm { "LM" } else { "SM" }
            ),
        }
    }

    /// Send one G-code line (an EBB command for an EiBotBoard) and wait for its `ok`; returns the report lines.
    pub fn command(&mut self, line: &str) -> anyhow::Result<Vec<String>> {
        match self {
            Connected::Ours(s) => s.command(line, super::session::COMMAND_TIMEOUT),
            Connected::Grbl(g) => g.command(line, super::grbl::session::COMMAND_TIMEOUT),
            Connected::Ebb(e) => e.command(line, Duration::from_secs(120)).map(|()| Vec::new()),
        }
    }
}
