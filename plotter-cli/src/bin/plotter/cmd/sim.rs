//! `plotter sim --pty`: the simulated firmware on a pseudo-terminal, so that `plotter plot --port /dev/pts/N` (or
//! any serial terminal) exercises the real serial code path end to end.
//!
//! The pty is opened with nix's safe `openpty`; the simulator owns the master side. Bytes read from the master
//! feed the simulator's serial line (optionally through line noise), its replies are written back. Time runs at
//! wall-clock speed by default (a plot takes as long as on the machine), `--pace N` times as fast, or as fast as
//! possible with `--fast`. On
//! Ctrl-C (SIGINT), SIGTERM or SIGHUP, the step trace is written to `--trace` (one line per step: its time in µs and the position
//! after it, `t x y z` in steps), followed by a summary line `# busy_ticks <motion time in µs> steps <count>`
//! and whether the motors are powered (`# motors on <0|1>`: `M18` releases them).
//!
//! With `--grbl` the pty serves the project's GRBL 1.1 emulator ([`plotter_host::link::grbl::emulator`])
//! instead, set up from the profile; its trace adds `# grbl peak_rx <bytes> overflow <bytes> lines <n> errors
//! <n>`, `# position x y z` (steps) and a line `# servo <time µs> <angle °>` per servo command. `--grbl-fault`
//! injects `hard-limit@N` (an `ALARM:1` after N lines), `error@N:CODE` (line N answered `error:CODE`), or a press
//! of the controller's Hold (`hold@N`) or Reset (`reset@N`) button once N lines have been answered.
//!
//! With `--ebb` the pty serves the project's EiBotBoard emulator ([`plotter_host::link::ebb::emulator`]) running
//! firmware `--ebb-version` (2.8.1 or 3.0.2); its trace lists the motor positions instead (`t m1 m2 pen`, time in
//! µs, pen 1 = up), then `# busy_ticks <µs> steps <n>`, `# ebb commands <n> errors <n> estops <n> peak_fifo <n>
//! pen_up <0|1>` and `# position <m1> <m2>`. `--ebb-lie` makes the board misbehave for tests: `es-garbage`,
//! `blank@N`, `chatter`, `busy` or `qs=X,Y` ([`plotter_host::link::ebb::emulator::Lie`]).
//!
//! With `--hpgl` the pty serves the project's HP-GL plotter model ([`plotter_host::link::hpgl::model`]) of
//! `--hpgl-device` with a `--hpgl-buffer`-byte input buffer behind a 9600-baud line (`--baud`); its trace lists
//! the pen-down polylines (`pd x,y x,y …` in plotter units), then `# hpgl buffered <n> overflow <n> peak <n>
//! instructions <n> errors <n> xoffs <n> aborts <n> pen_up <0|1> pen <n> busy_s <s>`. `--hpgl-lie MODE[@BYTES]`
//! makes the model misbehave ([`plotter_host::link::hpgl::model::Lie`]).

use std::fs::File;
use std::io::{Read as _, Write as _};
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use anyhow::{Context as _, bail};
use nix::pty::openpty;
use nix::sys::termios::{SetArg, cfmakeraw, tcgetattr, tcsetattr};
use plotter_fw::sim::{Sim, SimOptions};

use plotter_host::link::babble::Babble;
use plotter_host::link::ebb::emulator::{EbbEmulator, Lie};
use plotter_host::link::ebb::messages::EbbVersion;
use plotter_host::link::faults::Noise;
use plotter_host::link::grbl::emulator::{Faults, GrblEmulator};
use plotter_host::link::grbl::messages::{RT_FEED_HOLD, RT_RESET};
use plotter_host::link::grbl::settings::GrblSettings;
use plotter_host::link::hpgl::handshake::Handshake;
use plotter_host::link::hpgl::model::{HpglModel, ModelConfig};
use plotter_host::link::hpgl::model_link::Wire;
use plotter_host::options::machine::MachineArgs;
use plotter_path::motion::plan;

/// Arguments of `plotter sim`.
#[derive(clap::Args, Debug, Clone)]
pub(crate) struct SimArgs {
    /// Expose the simulator on a pseudo-terminal and print its device path.
    #[arg(long, conflicts_with = "qemu")]
    pub(crate) pty: bool,
    /// Run the real firmware image on an emulated microcontroller (qemu-system-arm, the `qemu-lm3s6965` board)
    /// with its UART on a pseudo-terminal, and print the device path; steps are counted from QEMU's GPIO trace
    /// and the endstops are driven from outside the firmware.
    #[arg(long, conflicts_with_all = ["fast", "noise"])]
    pub(crate) qemu: bool,
    /// With --qemu: the firmware image to run [default: built with `cargo xtask firmware`].
    #[arg(long, requires = "qemu")]
    pub(crate) image: Option<PathBuf>,
    #[command(flatten)]
    pub(crate) machine: MachineArgs,
    /// Run as fast as possible instead of in real time.
    #[arg(long)]
    pub(crate) fast: bool,
    /// Run the machine's clock this many times as fast as the wall clock (1, the default, is real time): a plot
    /// that takes a minute on the machine takes 15 s at --pace 4, still streamed over the port as the host sends
    /// it. For tests and rehearsals; --fast drops the pacing altogether.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=1000), conflicts_with_all = ["fast", "qemu"])]
    pub(crate) pace: u32,
    /// Corrupt this fraction of the received bytes (flip a bit or drop the byte), to test recovery.
    #[arg(long, default_value_t = 0.0)]
    pub(crate) noise: f64,
    /// Seed of the noise.
    #[arg(long, default_value_t = 1)]
    pub(crate) seed: u64,
    /// Make the device babble, to test the host's deadlines: `blank[@N]` (after N lines from the host it stops
    /// answering and sends a blank line every millisecond, like a crashed board) or `chatter[@N]` (it adds a line
    /// of noise every 20 ms, like a wrong port or a controller that reports on its own).
    #[arg(long, conflicts_with = "qemu")]
    pub(crate) babble: Option<String>,
    /// Write the step trace here on exit.
    #[arg(long)]
    pub(crate) trace: Option<PathBuf>,
    /// Append a line `<ms since start> up|down` here each time the pen goes up or down (flushed at once), so that
    /// a test can read the pen's state after each host it ran against the device.
    #[arg(long, conflicts_with = "qemu")]
    pub(crate) pen_log: Option<PathBuf>,
    /// Emulate a GRBL 1.1 controller instead of our firmware.
    #[arg(long)]
    pub(crate) grbl: bool,
    /// GRBL emulator fault for tests: `hard-limit@N`, `error@N:CODE`, `hold@N` or `reset@N`.
    #[arg(long, requires = "grbl")]
    pub(crate) grbl_fault: Option<String>,
    /// Emulate an EiBotBoard (AxiDraw-class) instead of our firmware.
    #[arg(long, conflicts_with_all = ["grbl", "qemu", "noise"])]
    pub(crate) ebb: bool,
    /// The EBB firmware version to emulate: 2.8.1 or 3.0.2.
    #[arg(long, requires = "ebb", default_value = "3.0.2")]
    pub(crate) ebb_version: String,
    /// Model the EBB pen lift's geometry: the pen touches the paper while its servo is below this position (AxiDraw:
    /// a longer pulse lifts the pen), for hosts that move the pen with raw `S2` positions (saxi). Without it the pen
    /// is where `SP`/`TP` last put it.
    #[arg(long, requires = "ebb")]
    pub(crate) ebb_pen_contact: Option<u16>,
    /// Make the EBB misbehave, for tests: es-garbage (ES answered with an unreadable line), blank@N (after N
    /// commands no more answers, a blank line every ms), chatter (a junk line every 20 ms), busy (QG always
    /// busy) or qs=X,Y (QS reports X,Y).
    #[arg(long, requires = "ebb")]
    pub(crate) ebb_lie: Option<String>,
    /// Emulate a vintage HP-GL plotter instead of our firmware.
    #[arg(long, conflicts_with_all = ["grbl", "qemu", "noise", "ebb"])]
    pub(crate) hpgl: bool,
    /// The HP-GL plotter to emulate (7475a, 7550a, dxy-1300, generic).
    #[arg(long, requires = "hpgl", default_value = "7475a")]
    pub(crate) hpgl_device: String,
    /// Its input buffer, bytes [default: the device's].
    #[arg(long, requires = "hpgl")]
    pub(crate) hpgl_buffer: Option<usize>,
    /// The handshakes the HP-GL plotter offers beyond `ESC . B`: xonxoff (Xon/Xoff when asked for, the default)
    /// or escb (no Xon/Xoff, like a plotter whose Xon/Xoff is not set up). A pty carries no CTS line, so
    /// hardware is refused.
    #[arg(long, requires = "hpgl", value_enum)]
    pub(crate) handshake: Option<Handshake>,
    /// HP-GL: the line's baud rate.
    #[arg(long, requires = "hpgl", default_value_t = 9600)]
    pub(crate) baud: u32,
    /// HP-GL: make the model lie, for tests of the host's waits and stops: `MODE` or `MODE@BYTES` (from the
    /// moment BYTES HP-GL bytes have entered its buffer). MODE: no-room (ESC . B answers 0), xoff-forever (an
    /// Xoff, never an Xon), chatter (a junk line every 20 ms), escb-garbage (ESC . B and ESC . K answered with
    /// garbage), escb-silent (ESC . B never answered).
    #[arg(long, requires = "hpgl")]
    pub(crate) hpgl_lie: Option<String>,
}

/// Parse `--grbl-fault`.
fn parse_fault(spec: &str) -> anyhow::Result<Faults> {
    let bad = || anyhow::anyhow!("--grbl-fault {spec:?}: use hard-limit@N, error@N:CODE, hold@N or reset@N");
    let (kind, at) = spec.split_once('@').ok_or_else(bad)?;
    match kind {
        "hard-limit" => {
            Ok(Faults { hard_limit_after_lines: Some(at.parse().map_err(|_| bad())?), ..Faults::default() })
        }
        "hold" | "reset" => {
            let byte = if kind == "hold" { RT_FEED_HOLD } else { RT_RESET };
            Ok(Faults { realtime_after_lines: Some((at.parse().map_err(|_| bad())?, byte)), ..Faults::default() })
        }
        "error" => {
            let (n, code) = at.split_once(':').ok_or_else(bad)?;
            let n = n.parse().map_err(|_| bad())?;
            let code = code.parse().map_err(|_| bad())?;
            Ok(Faults { error_on_line: Some((n, code)), ..Faults::default() })
        }
        _ => Err(bad()),
    }
}

/// The simulated machine behind the pty: our firmware or the GRBL emulator.
enum Backend {
    Ours(Box<Sim>),
    Grbl(Box<GrblEmulator>),
    /// The EBB emulator, with the µs not yet run (it runs in 40 µs intervals).
    Ebb(Box<EbbEmulator>, u64),
    /// The HP-GL plotter model behind its serial line, with its clock (µs).
    Hpgl(Box<Wire>, u64),
}

impl Backend {
    fn feed(&mut self, bytes: &[u8]) {
        match self {
            Backend::Ours(s) => s.feed(bytes),
            Backend::Grbl(g) => g.feed(bytes),
            Backend::Ebb(e, _) => e.feed(bytes),
            Backend::Hpgl(w, us) => {
                w.send(secs(*us), bytes);
            }
        }
    }
    /// What the machine sent: reply lines (each ended with `\n`), or the EBB's bytes as it wrote them.
    fn take_output(&mut self) -> Vec<u8> {
        let lines = match self {
            Backend::Ours(s) => s.take_replies(),
            Backend::Grbl(g) => g.take_replies(),
            Backend::Ebb(e, _) => return e.take_output(),
            Backend::Hpgl(w, us) => return w.received(secs(*us)),
        };
        lines.iter().flat_map(|l| format!("{l}\n").into_bytes()).collect()
    }
    fn busy(&self) -> bool {
        match self {
            Backend::Ours(s) => s.wire_len() > 0 || !s.machine().is_idle() || s.machine().has_input(),
            Backend::Grbl(g) => !g.is_idle(),
            Backend::Ebb(e, _) => !e.is_idle(),
            Backend::Hpgl(w, _) => !w.model().idle(),
        }
    }
    fn run_for(&mut self, ticks: u64) {
        match self {
            Backend::Ours(s) => {
                s.run_for(ticks);
            }
            Backend::Grbl(g) => g.run_for(ticks),
            Backend::Ebb(e, carry) => {
                let us = *carry + ticks;
                e.run_for(us / 40);
                *carry = us % 40;
            }
            Backend::Hpgl(w, us) => {
                *us += ticks;
                w.run_until(secs(*us));
            }
        }
    }
    /// Whether the pen is up (our firmware and GRBL: Z at or above the middle of the profile's pen-up and
    /// pen-down heights).
    fn pen_up(&self, profile: &plotter_path::MachineProfile) -> bool {
        let z_up = |z_steps: i32| {
            let middle = (profile.pen.up_z_mm + profile.pen.down_z_mm) / 2.0;
            f64::from(z_steps) / profile.axes.z.steps_per_mm >= middle
        };
        match self {
            Backend::Ours(s) => z_up(s.machine().stepper().position()[2]),
            Backend::Grbl(g) => z_up(g.backend().machine().stepper().position()[2]),
            Backend::Ebb(e, _) => e.pen_up(),
            Backend::Hpgl(w, _) => w.model().pen_up(),
        }
    }
    fn sim(&self) -> Option<&Sim> {
        match self {
            Backend::Ours(s) => Some(s),
            Backend::Grbl(g) => Some(g.backend()),
            Backend::Ebb(..) | Backend::Hpgl(..) => None,
        }
    }
}

/// Microseconds as seconds.
fn secs(us: u64) -> f64 {
    // Display and model time: µs counts stay far below 2^52.
    #[allow(clippy::cast_precision_loss)]
    let s = us as f64 * 1e-6;
    s
}

/// Write the HP-GL model's trace (see the module docs).
fn write_hpgl_trace(m: &HpglModel, path: &Path) -> anyhow::Result<()> {
    let mut out =
        std::io::BufWriter::new(File::create(path).with_context(|| format!("cannot create {}", path.display()))?);
    for line in m.trace() {
        let pts: Vec<String> = line.iter().map(|(x, y)| format!("{x},{y}")).collect();
        writeln!(out, "pd {}", pts.join(" "))?;
    }
    let st = m.stats();
    writeln!(
        out,
        "# hpgl buffered {} overflow {} peak {} instructions {} errors {} xoffs {} aborts {} pen_up {} pen {} busy_s {:.6}",
        st.buffered,
        st.overflow,
        st.peak,
        st.instructions,
        st.errors,
        st.xoffs,
        st.aborts,
        u8::from(m.pen_up()),
        m.pen(),
        m.busy_seconds()
    )?;
    out.flush()?;
    Ok(())
}

/// Write the EBB emulator's step trace (see the module docs).
fn write_ebb_trace(e: &EbbEmulator, path: &Path) -> anyhow::Result<()> {
    let mut out =
        std::io::BufWriter::new(File::create(path).with_context(|| format!("cannot create {}", path.display()))?);
    for s in e.trace() {
        writeln!(out, "{} {} {} {}", s.t * 40, s.motors[0], s.motors[1], u8::from(!s.pen_down))?;
    }
    let st = e.stats();
    let p = e.position();
    writeln!(out, "# busy_ticks {} steps {}", e.busy_intervals() * 40, e.trace().len())?;
    writeln!(
        out,
        "# ebb commands {} errors {} estops {} peak_fifo {} pen_up {}\n# position {} {}",
        st.commands,
        st.errors,
        st.estops,
        st.peak_fifo,
        u8::from(e.pen_up()),
        p[0],
        p[1]
    )?;
    out.flush()?;
    Ok(())
}

/// Write the simulator's step trace (see the module docs).
pub(crate) fn write_trace(sim: &Sim, path: &Path) -> anyhow::Result<()> {
    let mut out =
        std::io::BufWriter::new(File::create(path).with_context(|| format!("cannot create {}", path.display()))?);
    let mut pos = [0i64; 4];
    for e in sim.hal().steps() {
        pos[e.axis.index()] += if e.forward { 1 } else { -1 };
        writeln!(out, "{} {} {} {}", e.time, pos[0], pos[1], pos[2])?;
    }
    writeln!(out, "# busy_ticks {} steps {}", sim.hal().busy_ticks(), sim.hal().steps().len())?;
    writeln!(out, "# motors on {}", u8::from(sim.hal().motors_on()))?;
    out.flush()?;
    Ok(())
}

/// Run `plotter sim`.
pub(crate) fn run(args: &SimArgs) -> anyhow::Result<()> {
    // Before any thread starts: SIGTERM and SIGHUP end the simulator as Ctrl-C does.
    let stop = plotter_host::stop::Stop::install_signals().context("cannot take the termination signals")?;
    if args.qemu {
        if args.machine.chosen() {
            bail!(
                "the QEMU image carries the built-in XY plotter kit's configuration, compiled in: drop --model, \
                 --profile and the speed and pen settings"
            );
        }
        let cfg = plotter_fw::MachineConfig::xy_plotter();
        return crate::sim_qemu::run(&cfg, args.image.as_deref(), args.trace.as_deref(), stop);
    }
    if !args.pty {
        bail!(
            "nothing to do: use `plotter sim --pty` or `plotter sim --qemu` (a simulated plot without a pty is \
             `plotter plot` without --port)"
        );
    }
    let profile = args.machine.load()?;
    let cfg = plan::machine_config(&profile)?;
    let mut sim = if args.hpgl {
        let device = plotter_path::geometry::hpgl_devices::device(&args.hpgl_device).with_context(|| {
            format!(
                "--hpgl-device {}: not a known plotter (known: {})",
                args.hpgl_device,
                plotter_path::geometry::hpgl_devices::device_names()
            )
        })?;
        let buffer = args.hpgl_buffer.unwrap_or(device.buffer_bytes);
        if !(16..=1 << 20).contains(&buffer) {
            bail!("--hpgl-buffer {buffer}: give 16 to 1048576 bytes");
        }
        let xon_xoff = match args.handshake {
            Some(Handshake::Hardware) => bail!(
                "--handshake hardware: a pseudo-terminal has no RTS/CTS lines; the model offers escb (always) and \
                 xonxoff"
            ),
            Some(Handshake::Escb) => false,
            Some(Handshake::Xonxoff) | None => true,
        };
        let mut model = HpglModel::new(ModelConfig { device, buffer, xon_xoff });
        if let Some(spec) = &args.hpgl_lie {
            let (lie, from) =
                plotter_host::link::hpgl::model::Lie::parse(spec).map_err(|e| anyhow::anyhow!("--hpgl-lie {e}"))?;
            model.set_lie(lie, from);
        }
        Backend::Hpgl(Box::new(Wire::new(model, args.baud)), 0)
    } else if args.ebb {
        let version = EbbVersion::parse(&format!("EB Firmware Version {}", args.ebb_version))
            .filter(|v| [EbbVersion(2, 8, 1), EbbVersion(3, 0, 2)].contains(v))
            .with_context(|| format!("--ebb-version {}: emulated are 2.8.1 and 3.0.2", args.ebb_version))?;
        let mut board = EbbEmulator::new(version);
        board.set_pen_contact(args.ebb_pen_contact);
        board.set_lie(args.ebb_lie.as_deref().map(Lie::parse).transpose().map_err(anyhow::Error::msg)?);
        Backend::Ebb(Box::new(board), 0)
    } else if args.grbl {
        let faults = args.grbl_fault.as_deref().map(parse_fault).transpose()?.unwrap_or_default();
        // The pty delivers bytes at the speed the client writes them; the emulator's buffer counts them.
        Backend::Grbl(Box::new(GrblEmulator::with_settings(cfg, GrblSettings::for_profile(&profile), None, faults)))
    } else {
        let mut opts = SimOptions::for_config(&cfg);
        opts.baud = if args.fast { None } else { Some(profile.link.baud) };
        // A printer profile's heaters run on the thermal model (plotters have none).
        opts.thermal = plotter_path::config::profile::thermal_config(&profile).map_err(anyhow::Error::msg)?;
        Backend::Ours(Box::new(Sim::with_options(cfg, opts)))
    };
    let mut noise = (args.noise > 0.0).then(|| Noise::new(args.noise, args.seed));
    let mut babble =
        args.babble.as_deref().map(Babble::parse).transpose().map_err(|e| anyhow::anyhow!("--babble {e}"))?;

    let pty = openpty(None, None).context("cannot open a pseudo-terminal")?;
    let mut tio = tcgetattr(&pty.slave).context("cannot read the pty settings")?;
    cfmakeraw(&mut tio);
    tcsetattr(&pty.slave, SetArg::TCSANOW, &tio).context("cannot set the pty to raw mode")?;
    let path = nix::unistd::ttyname(&pty.slave).context("cannot name the pty")?;
    // The client opens the slave by name; keeping our own descriptor would keep its exclusive-open flag alive
    // after a client dies, so that a resumed client could not reopen it.
    drop(pty.slave);
    let mut writer = File::from(pty.master.try_clone().context("cannot duplicate the pty")?);
    let mut reader = File::from(pty.master);
    println!("{}", path.display());
    std::io::stdout().flush()?;

    let (tx, rx) = mpsc::channel::<Vec<u8>>();
    std::thread::spawn(move || {
        let mut buf = [0u8; 4096];
        loop {
            match reader.read(&mut buf) {
                Ok(0) | Err(_) => {
                    // No client has the slave open (EIO): wait for one.
                    std::thread::sleep(Duration::from_millis(10));
                }
                Ok(n) => {
                    if tx.send(buf[..n].to_vec()).is_err() {
                        return;
                    }
                }
            }
        }
    });

    let mut last = Instant::now();
    let started = last;
    let mut pen_log = match &args.pen_log {
        Some(p) => Some((File::create(p).with_context(|| format!("cannot create {}", p.display()))?, None)),
        None => None,
    };
    let mut pending_out = sim.take_output();
    while !stop.any() {
        if !pending_out.is_empty() {
            // A client that is not there yet loses the line, as on a real port.
            let _ = writer.write_all(&std::mem::take(&mut pending_out));
        }
        let busy = sim.busy();
        let wait = if busy { Duration::from_micros(200) } else { Duration::from_millis(5) };
        match rx.recv_timeout(wait) {
            Ok(bytes) => {
                if let Some(b) = babble.as_mut() {
                    b.host_sent(&bytes);
                }
                match noise.as_mut() {
                    Some(n) => sim.feed(&n.apply(&bytes)),
                    None => sim.feed(&bytes),
                }
            }
            Err(mpsc::RecvTimeoutError::Timeout) => {}
            Err(mpsc::RecvTimeoutError::Disconnected) => break,
        }
        let now = Instant::now();
        let elapsed = now.duration_since(last);
        last = now;
        if args.fast {
            sim.run_for(if args.grbl || args.ebb || args.hpgl { 5_000 } else { 50_000 });
        } else {
            let us = u64::try_from(elapsed.as_micros()).unwrap_or(u64::MAX);
            sim.run_for(us.saturating_mul(u64::from(args.pace)));
        }
        pending_out = sim.take_output();
        if let Some(b) = babble.as_mut() {
            pending_out = b.filter(pending_out, started.elapsed());
        }
        if let Some((file, was)) = pen_log.as_mut() {
            let up = sim.pen_up(&profile);
            if *was != Some(up) {
                *was = Some(up);
                writeln!(file, "{} {}", started.elapsed().as_millis(), if up { "up" } else { "down" })?;
            }
        }
    }
    if let (Some(t), Backend::Hpgl(w, _)) = (&args.trace, &sim) {
        write_hpgl_trace(w.model(), t)?;
    } else if let (Some(t), Backend::Ebb(e, _)) = (&args.trace, &sim) {
        write_ebb_trace(e, t)?;
    } else if let (Some(t), Some(s)) = (&args.trace, sim.sim()) {
        write_trace(s, t)?;
        if let Backend::Grbl(g) = &sim {
            let st = g.stats();
            let p = g.backend().machine().stepper().position();
            let mut f = std::fs::OpenOptions::new().append(true).open(t)?;
            writeln!(
                f,
                "# grbl peak_rx {} overflow {} lines {} errors {}\n# position {} {} {}",
                st.peak_rx, st.overflow_bytes, st.lines, st.errors, p[0], p[1], p[2]
            )?;
            for (t, angle, _) in g.backend().hal().servo_trace() {
                writeln!(f, "# servo {t} {angle}")?;
            }
        }
    }
    if let Some(n) = &noise {
        eprintln!("noise: {} bytes flipped, {} dropped", n.flipped, n.dropped);
    }
    Ok(())
}
