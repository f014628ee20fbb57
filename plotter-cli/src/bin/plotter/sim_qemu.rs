//! `plotter sim --qemu`: the real firmware image on an emulated microcontroller, on a pseudo-terminal.
//!
//! Builds the `qemu-lm3s6965` board image if needed (`cargo xtask firmware --board qemu-lm3s6965`), starts
//! `qemu-system-arm -M lm3s6965evb` with the board's UART on a pty and prints the pty's path, exactly like
//! `plotter sim --pty`. Around the emulated chip it plays the machine:
//!
//! - **steps** are counted from QEMU's GPIO trace (`-d trace:pl061_set_output`, one line per pin change, read
//!   from QEMU's stderr): a rising edge on a step pin is one step, in the direction the direction pin shows.
//!   Nothing here asks the firmware; the count is what the pins did.
//! - **endstops** sit where the simulator puts them (one pull-off beyond the travel, carriage starting at 0):
//!   when the counted position reaches a switch, the switch is pressed through QEMU's input events (QMP
//!   `input-send-event`: the board's gamepad keys drive the endstop pins PE0..PE3, active low), and released when
//!   the carriage leaves it. Homing thus runs against switches the firmware cannot see through.
//!
//! `--trace FILE` receives one line per step as it happens (`t x y z`: µs since start and the position after
//! the step, as `plotter sim --pty` writes) and, on Ctrl-C (SIGINT), SIGTERM or SIGHUP, a summary line
//! `# busy_ticks <µs from first to last step> steps <count>`.
//!
//! The pin map mirrors `plotter-fw/boards/qemu-lm3s6965/src/pins.rs`: steps PD0..PD3, directions PD4..PD7 (high =
//! negative), endstops PE0..PE3.

use std::fs::File;
use std::io::{BufRead as _, BufReader, BufWriter, Write as _};
use std::os::unix::net::UnixStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use anyhow::{Context as _, bail};
use plotter_fw::sim::{SimOptions, Switch};
use plotter_fw::{MachineConfig, NUM_AXES};

/// The board crate and image name.
pub(crate) const BOARD: &str = "qemu-lm3s6965";
/// GPIO port of the step and direction pins (A = 0, so D = 3).
const STEP_PORT: usize = 3;
/// QEMU key (QMP `qcode`) pressing each axis's endstop: the lm3s6965evb gamepad's keys drive PE0..PE3.
const ENDSTOP_KEYS: [&str; NUM_AXES] = ["up", "down", "left", "right"];

/// The workspace root (the image is built from its sources).
fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().map(Path::to_path_buf).unwrap_or_default()
}

/// The board image: `explicit`, or built (if needed) with the xtask.
pub(crate) fn image(explicit: Option<&Path>) -> anyhow::Result<PathBuf> {
    if let Some(p) = explicit {
        if !p.exists() {
            bail!("--image {}: no such file", p.display());
        }
        return Ok(p.to_path_buf());
    }
    let root = workspace_root();
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    // Build output goes to stderr: stdout carries only the pty path.
    let status = Command::new(&cargo)
        .args(["xtask", "firmware", "--board", BOARD])
        .current_dir(&root)
        .stdout(Stdio::from(std::io::stderr()))
        .status()
        .with_context(|| format!("cannot run `{cargo} xtask` in {} to build the QEMU image", root.display()))?;
    if !status.success() {
        bail!("building the {BOARD} image failed (`cargo xtask firmware --board {BOARD}` in {})", root.display());
    }
    let target = std::env::var_os("CARGO_TARGET_DIR").map_or_else(|| root.join("target"), PathBuf::from);
    Ok(target.join("firmware").join(format!("{BOARD}.elf")))
}

/// One parsed `pl061_set_output` trace line: port path, pin, level.
fn parse_output(line: &str) -> Option<(&str, u8, bool)> {
    // "pl061_set_output /machine/unattached/device[11] setting output 3 to 1" (maybe after a "pid@time:" prefix).
    let rest = &line[line.find("pl061_set_output ")? + "pl061_set_output ".len()..];
    let mut t = rest.split_whitespace();
    let dev = t.next()?;
    if t.next()? != "setting" || t.next()? != "output" {
        return None;
    }
    let pin = t.next()?.parse().ok()?;
    if t.next()? != "to" {
        return None;
    }
    let level = t.next()?.parse::<u8>().ok()? != 0;
    Some((dev, pin, level))
}

/// What a pin change did to the machine.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Effect {
    /// A step on `axis`; `press` = switch changes it caused (axis, pressed).
    Step { axis: usize, switch: Option<(usize, bool)> },
    /// Nothing countable (a direction change, a falling edge, another pin).
    None,
}

/// The machine outside the chip: positions from the step/dir pins, switches from the positions.
#[derive(Debug, Clone)]
struct Machine {
    pos: [i64; NUM_AXES],
    negative: [bool; NUM_AXES],
    step_level: [bool; NUM_AXES],
    switches: [Option<Switch>; NUM_AXES],
    pressed: [bool; NUM_AXES],
    counts: [u64; NUM_AXES],
}

impl Machine {
    fn new(opts: &SimOptions) -> Self {
        Machine {
            pos: opts.start,
            negative: [false; NUM_AXES],
            step_level: [false; NUM_AXES],
            switches: opts.switches,
            pressed: [false; NUM_AXES],
            counts: [0; NUM_AXES],
        }
    }

    /// A step-port pin changed.
    fn on_pin(&mut self, pin: u8, level: bool) -> Effect {
        let pin = usize::from(pin);
        if (4..4 + NUM_AXES).contains(&pin) {
            self.negative[pin - 4] = level;
            return Effect::None;
        }
        if pin >= NUM_AXES {
            return Effect::None;
        }
        let rising = level && !self.step_level[pin];
        self.step_level[pin] = level;
        if !rising {
            return Effect::None;
        }
        self.pos[pin] += if self.negative[pin] { -1 } else { 1 };
        self.counts[pin] += 1;
        let switch = self.switches[pin].and_then(|s| {
            let now = if s.at_max { self.pos[pin] >= s.position } else { self.pos[pin] <= s.position };
            (now != self.pressed[pin]).then(|| {
                self.pressed[pin] = now;
                (pin, now)
            })
        });
        Effect::Step { axis: pin, switch }
    }
}

/// A QMP connection (QEMU's JSON control protocol).
struct Qmp {
    stream: UnixStream,
    reader: BufReader<UnixStream>,
}

impl Qmp {
    fn connect(path: &Path, qemu: &mut Child) -> anyhow::Result<Qmp> {
        let deadline = Instant::now() + Duration::from_secs(10);
        let stream = loop {
            match UnixStream::connect(path) {
                Ok(s) => break s,
                Err(e) => {
                    if let Some(status) = qemu.try_wait()? {
                        bail!("qemu-system-arm exited ({status}) before its control socket opened");
                    }
                    if Instant::now() > deadline {
                        return Err(e)
                            .with_context(|| format!("cannot reach QEMU's control socket {}", path.display()));
                    }
                    std::thread::sleep(Duration::from_millis(20));
                }
            }
        };
        stream.set_read_timeout(Some(Duration::from_secs(10)))?;
        let reader = BufReader::new(stream.try_clone()?);
        let mut q = Qmp { stream, reader };
        q.read_reply()?; // greeting
        q.execute(r#"{"execute":"qmp_capabilities"}"#)?;
        Ok(q)
    }

    fn read_reply(&mut self) -> anyhow::Result<serde_json::Value> {
        loop {
            let mut line = String::new();
            if self.reader.read_line(&mut line)? == 0 {
                bail!("QEMU closed its control socket");
            }
            let v: serde_json::Value = serde_json::from_str(&line).context("QEMU sent malformed QMP")?;
            if v.get("event").is_none() {
                return Ok(v);
            }
        }
    }

    fn execute(&mut self, cmd: &str) -> anyhow::Result<serde_json::Value> {
        self.stream.write_all(cmd.as_bytes())?;
        self.stream.write_all(b"\n")?;
        let v = self.read_reply()?;
        if let Some(e) = v.get("error") {
            bail!("QEMU refused {cmd}: {e}");
        }
        Ok(v.get("return").cloned().unwrap_or(serde_json::Value::Null))
    }
}

/// QMP command pressing (`down`) or releasing a key.
fn key_event(key: &str, down: bool) -> String {
    format!(
        r#"{{"execute":"input-send-event","arguments":{{"events":[{{"type":"key","data":{{"down":{down},"key":{{"type":"qcode","data":"{key}"}}}}}}]}}}}"#
    )
}

/// The canonical QOM paths of the GPIO ports A..G: the machine creates its `pl061_luminary` devices in port
/// order, so sorting them by their `device[N]` index gives the ports.
fn gpio_ports(qmp: &mut Qmp) -> anyhow::Result<Vec<String>> {
    let list = qmp.execute(r#"{"execute":"qom-list","arguments":{"path":"/machine/unattached"}}"#)?;
    let mut ports: Vec<(u32, String)> = list
        .as_array()
        .context("qom-list returned no list")?
        .iter()
        .filter(|e| e.get("type").and_then(|t| t.as_str()) == Some("child<pl061_luminary>"))
        .filter_map(|e| {
            let name = e.get("name")?.as_str()?;
            let n = name.strip_prefix("device[")?.strip_suffix(']')?.parse().ok()?;
            Some((n, format!("/machine/unattached/{name}")))
        })
        .collect();
    ports.sort();
    if ports.len() <= STEP_PORT {
        bail!("QEMU's lm3s6965evb shows {} GPIO ports; the board needs port D", ports.len());
    }
    Ok(ports.into_iter().map(|(_, p)| p).collect())
}

/// Run `plotter sim --qemu`.
/// Runs until `stop` is set (a termination signal, see [`plotter_host::stop`]) or QEMU ends; QEMU is killed on
/// every way out.
pub(crate) fn run(
    cfg: &MachineConfig,
    image_arg: Option<&Path>,
    trace: Option<&Path>,
    stop: &plotter_host::stop::Stop,
) -> anyhow::Result<()> {
    let elf = image(image_arg)?;
    let dir = std::env::temp_dir().join(format!("plotter-qemu-{}", std::process::id()));
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let qmp_path = dir.join("qmp.sock");
    let _ = std::fs::remove_file(&qmp_path);
    let mut qemu = Command::new("qemu-system-arm")
        .args(["-M", "lm3s6965evb", "-display", "none", "-monitor", "none", "-serial", "pty"])
        .arg("-qmp")
        .arg(format!("unix:{},server=on,wait=off", qmp_path.display()))
        .args(["-d", "trace:pl061_set_output", "-kernel"])
        .arg(&elf)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .context("cannot start qemu-system-arm (install it: apt-get install qemu-system-arm)")?;
    let result = serve(&mut qemu, cfg, &qmp_path, trace, stop);
    let _ = qemu.kill();
    let _ = qemu.wait();
    let _ = std::fs::remove_dir_all(&dir);
    result
}

fn serve(
    qemu: &mut Child,
    cfg: &MachineConfig,
    qmp_path: &Path,
    trace: Option<&Path>,
    stop: &plotter_host::stop::Stop,
) -> anyhow::Result<()> {
    let stdout = qemu.stdout.take().context("QEMU's stdout")?;
    let stderr = qemu.stderr.take().context("QEMU's stderr")?;
    // QEMU announces the pty on stdout: "char device redirected to /dev/pts/N (label serial0)".
    let mut out = BufReader::new(stdout);
    let pty = loop {
        let mut line = String::new();
        if out.read_line(&mut line)? == 0 {
            bail!("qemu-system-arm exited without opening a pty");
        }
        if let Some(p) = line.split_whitespace().find(|w| w.starts_with("/dev/")) {
            break p.to_string();
        }
    };
    std::thread::spawn(move || std::io::copy(&mut out, &mut std::io::sink()));

    let mut qmp = Qmp::connect(qmp_path, qemu)?;
    let ports = gpio_ports(&mut qmp)?;
    let step_port = ports[STEP_PORT].clone();
    // The emulated pins read low (pressed) until a key event drives them: press and release every key once.
    for key in ENDSTOP_KEYS {
        qmp.execute(&key_event(key, true))?;
        qmp.execute(&key_event(key, false))?;
    }
    // From here on key events are fire-and-forget; a thread drains QEMU's answers.
    let mut keys = qmp.stream.try_clone()?;
    let mut answers = qmp.reader;
    std::thread::spawn(move || {
        let mut line = String::new();
        while answers.read_line(&mut line).is_ok_and(|n| n > 0) {
            line.clear();
        }
    });

    let mut writer = match trace {
        Some(p) => Some(BufWriter::new(File::create(p).with_context(|| format!("cannot create {}", p.display()))?)),
        None => None,
    };
    let machine = Arc::new(Mutex::new(Machine::new(&SimOptions::for_config(cfg))));
    let span = Arc::new(Mutex::new((None::<u64>, 0u64)));
    let start = Instant::now();
    let (m, s) = (Arc::clone(&machine), Arc::clone(&span));
    let reader = std::thread::spawn(move || -> Option<BufWriter<File>> {
        let mut err = BufReader::new(stderr);
        let mut line = String::new();
        loop {
            line.clear();
            match err.read_line(&mut line) {
                Ok(0) | Err(_) => return writer,
                Ok(_) => {}
            }
            let Some((dev, pin, level)) = parse_output(&line) else {
                if !line.contains("pl061_") && !line.trim().is_empty() {
                    eprint!("qemu: {line}");
                }
                continue;
            };
            if dev != step_port {
                continue;
            }
            let mut mach = m.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
            if let Effect::Step { switch, .. } = mach.on_pin(pin, level) {
                if let Some((axis, down)) = switch {
                    // A failed write means QEMU is gone; the main loop notices.
                    let _ = keys.write_all(format!("{}\n", key_event(ENDSTOP_KEYS[axis], down)).as_bytes());
                }
                let t = u64::try_from(start.elapsed().as_micros()).unwrap_or(u64::MAX);
                let mut sp = s.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
                sp.0.get_or_insert(t);
                sp.1 = t;
                if let Some(w) = writer.as_mut() {
                    let _ = writeln!(w, "{t} {} {} {}", mach.pos[0], mach.pos[1], mach.pos[2]);
                }
            }
            if let Some(w) = writer.as_mut()
                && err.buffer().is_empty()
            {
                let _ = w.flush();
            }
        }
    });

    println!("{pty}");
    std::io::stdout().flush()?;
    let mut died = None;
    while !stop.any() {
        if let Some(status) = qemu.try_wait()? {
            died = Some(status);
            break;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let _ = qemu.kill();
    let _ = qemu.wait();
    let writer = reader.join().ok().flatten();
    let mach = machine.lock().unwrap_or_else(std::sync::PoisonError::into_inner).clone();
    let (first, last) = *span.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let total: u64 = mach.counts.iter().sum();
    if let Some(mut w) = writer {
        writeln!(w, "# busy_ticks {} steps {total}", last - first.unwrap_or(last))?;
        w.flush()?;
    }
    let c = mach.counts;
    eprintln!("qemu: step pulses X {} Y {} Z {} E {}; position {:?}", c[0], c[1], c[2], c[3], mach.pos);
    if let Some(status) = died {
        bail!("qemu-system-arm exited unexpectedly ({status})");
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn trace_lines_parse() {
        assert_eq!(
            parse_output("pl061_set_output /machine/unattached/device[11] setting output 3 to 1\n"),
            Some(("/machine/unattached/device[11]", 3, true))
        );
        assert_eq!(
            parse_output("1234@1700000000.000001:pl061_set_output /m/d[2] setting output 7 to 0"),
            Some(("/m/d[2]", 7, false))
        );
        assert_eq!(parse_output("pl061_update /m/d[2] GPIODIR 0xff GPIODATA 0x1"), None);
        assert_eq!(parse_output("pl061_set_output /m/d[2] setting output x to 1"), None);
        assert_eq!(parse_output("Timer with period zero, disabling"), None);
    }

    fn opts() -> SimOptions {
        SimOptions::for_config(&MachineConfig::xy_plotter())
    }

    #[test]
    fn rising_edges_count_in_the_direction_shown() {
        let mut m = Machine::new(&opts());
        // Three X steps forward, then direction high and two back; falling edges and repeats count nothing.
        for _ in 0..3 {
            assert!(matches!(m.on_pin(0, true), Effect::Step { axis: 0, switch: None }));
            assert_eq!(m.on_pin(0, true), Effect::None);
            assert_eq!(m.on_pin(0, false), Effect::None);
        }
        assert_eq!(m.on_pin(4, true), Effect::None);
        m.on_pin(0, true);
        m.on_pin(0, false);
        m.on_pin(0, true);
        assert_eq!(m.pos, [1, 0, 0, 0]);
        assert_eq!(m.counts, [5, 0, 0, 0]);
        // Z (pin 2, dir pin 6) counts on its own.
        m.on_pin(6, true);
        m.on_pin(2, true);
        assert_eq!(m.pos[2], -1);
        // Pins beyond the axes are ignored.
        assert_eq!(m.on_pin(9, true), Effect::None);
    }

    #[test]
    fn the_switch_presses_at_the_trip_point_and_releases_after() {
        let mut m = Machine::new(&opts());
        // X trips one pull-off (2 mm × 80 steps/mm) below 0.
        assert_eq!(m.switches[0].map(|s| s.position), Some(-160));
        m.on_pin(4, true);
        let mut presses = Vec::new();
        for _ in 0..165 {
            m.on_pin(0, false);
            if let Effect::Step { switch: Some(s), .. } = m.on_pin(0, true) {
                presses.push((m.pos[0], s));
            }
        }
        assert_eq!(presses, [(-160, (0, true))]);
        m.on_pin(4, false);
        for _ in 0..10 {
            m.on_pin(0, false);
            if let Effect::Step { switch: Some(s), .. } = m.on_pin(0, true) {
                presses.push((m.pos[0], s));
            }
        }
        assert_eq!(presses[1], (-159, (0, false)));
        assert_eq!(presses.len(), 2);
    }

    #[test]
    fn key_events_are_qmp_json() {
        let v: serde_json::Value = serde_json::from_str(&key_event("up", true)).unwrap();
        assert_eq!(v["execute"], "input-send-event");
        assert_eq!(v["arguments"]["events"][0]["data"]["down"], true);
        assert_eq!(v["arguments"]["events"][0]["data"]["key"]["data"], "up");
    }
}
