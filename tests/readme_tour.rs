//! The README as a test: every command of its tour runs, as pasted, in a clean temporary folder holding only
//! `samples/` (and the sliced cube the printer lines name), with `plotter` the built binary — the way a newcomer
//! pastes them. Exit 0 is expected unless the README says, on the command's own line or the comment above it, that
//! it ends otherwise (the thermal fault). Where the README says to start an emulator in a second terminal
//! (`plotter sim --pty …  # prints e.g. /dev/pts/7`), the test starts it (as fast as it can run, `--fast`) and
//! puts its real device where the README's example path stands; `plotter serve` is started, asked for its page,
//! and stopped with SIGTERM. The user's home and state directories point into the folder, so nothing is left
//! outside it.
//!
//! Runs every command even when one fails, then lists every failure with the command's output.

use std::collections::HashMap;
use std::io::{BufRead as _, BufReader, Read as _, Write as _};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use plotter_e2e::{plotter_bin, qemu_available, scratch, workspace_root};

/// The most one pasted command may take (the slowest, a plot on the emulated board in real time, takes ~20 s).
const COMMAND_LIMIT: Duration = Duration::from_secs(240);

/// One command of the tour, with the comment lines just above it and its own trailing comment.
#[derive(Debug, Clone)]
struct Pasted {
    line: usize,
    command: String,
    trailing: String,
    above: String,
}

/// The shell block that follows the `## Tour` heading.
fn tour_block(readme: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    let mut in_tour = false;
    let mut in_block = false;
    for (i, l) in readme.lines().enumerate() {
        if l.starts_with("## ") {
            in_tour = l.trim() == "## Tour";
            continue;
        }
        if !in_tour {
            continue;
        }
        if l.starts_with("```") {
            if in_block {
                break;
            }
            in_block = true;
            continue;
        }
        if in_block {
            out.push((i + 1, l.to_string()));
        }
    }
    out
}

/// Where an unquoted `#` starts a comment in a shell line (at the start or after white space), if anywhere.
fn comment_start(line: &str) -> Option<usize> {
    let (mut single, mut double) = (false, false);
    let mut previous = ' ';
    for (i, c) in line.char_indices() {
        match c {
            '\'' if !double => single = !single,
            '"' if !single => double = !double,
            '#' if !single && !double && previous.is_whitespace() => return Some(i),
            _ => {}
        }
        previous = c;
    }
    None
}

/// The commands of the tour block, comments set apart.
fn commands(block: &[(usize, String)]) -> Vec<Pasted> {
    let mut out = Vec::new();
    let mut above = String::new();
    for (n, l) in block {
        let t = l.trim();
        if t.is_empty() {
            above.clear();
            continue;
        }
        if t.starts_with('#') {
            above.push_str(t);
            above.push('\n');
            continue;
        }
        let (command, trailing) = match comment_start(l) {
            Some(i) => (l[..i].trim().to_string(), l[i..].to_string()),
            None => (t.to_string(), String::new()),
        };
        out.push(Pasted { line: *n, command, trailing, above: std::mem::take(&mut above) });
    }
    out
}

/// The example device a README line says an emulator prints (`# prints e.g. /dev/pts/7`).
fn example_device(trailing: &str) -> Option<String> {
    let at = trailing.find("/dev/")?;
    Some(trailing[at..].split(|c: char| c.is_whitespace() || c == ')' || c == ',').next()?.to_string())
}

/// A clean folder: `samples/` and the sliced cube, nothing else.
fn clean_folder() -> PathBuf {
    let dir = scratch("readme-tour");
    copy_tree(&workspace_root().join("samples"), &dir.join("samples"));
    let fixtures = dir.join("tests").join("fixtures");
    std::fs::create_dir_all(&fixtures).expect("fixtures folder");
    std::fs::copy(workspace_root().join("tests/fixtures/cube-20mm.gcode"), fixtures.join("cube-20mm.gcode"))
        .expect("copy the cube's G-code");
    std::fs::create_dir_all(dir.join("home")).expect("home folder");
    dir
}

fn copy_tree(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).expect("create a folder");
    for entry in std::fs::read_dir(from).expect("read samples") {
        let entry = entry.expect("folder entry");
        let target = to.join(entry.file_name());
        if entry.file_type().expect("file type").is_dir() {
            copy_tree(&entry.path(), &target);
        } else {
            std::fs::copy(entry.path(), &target).expect("copy a sample");
        }
    }
}

/// A background program (an emulator or the web app), killed when dropped; an emulated board holds
/// [`plotter_e2e::QEMU_BOARD`] until then.
struct Background(
    Child,
    #[allow(dead_code, reason = "held, never read: released when the emulator is gone")]
    Option<std::sync::MutexGuard<'static, ()>>,
);

impl Drop for Background {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// The environment every pasted command runs in: `plotter` is the built binary; home and state inside `dir`.
fn shell(dir: &Path, script: &str) -> Command {
    let bin = plotter_bin().display().to_string();
    let mut c = Command::new("bash");
    c.arg("-c")
        .arg(format!("set -o pipefail\nplotter() {{ '{bin}' \"$@\"; }}\n{script}"))
        .current_dir(dir)
        .env("HOME", dir.join("home"))
        .env("XDG_STATE_HOME", dir.join("home/.local/state"))
        .env("XDG_DATA_HOME", dir.join("home/.local/share"))
        .env("XDG_CONFIG_HOME", dir.join("home/.config"))
        .env_remove("DISPLAY")
        .env_remove("BROWSER");
    c
}

/// `command` with its leading `plotter` as the binary's path, for `exec` (which runs programs, not functions).
fn exec_line(command: &str) -> String {
    let rest = command.strip_prefix("plotter").unwrap_or(command);
    format!("exec '{}'{rest}", plotter_bin().display())
}

/// Start an emulator line (`plotter sim --pty …`, `plotter sim --qemu …`) and return it with the device it
/// printed.
fn start_emulator(dir: &Path, command: &str) -> Result<(Background, String), String> {
    let fast = if command.contains("--qemu") { "" } else { " --fast" };
    // One emulated board at a time, as tests/plot_qemu.rs's (the image is built by the first).
    let board = command.contains("--qemu").then(plotter_e2e::qemu_board);
    let mut child = shell(dir, &format!("{}{fast}", exec_line(command)))
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .map_err(|e| format!("cannot start: {e}"))?;
    let mut line = String::new();
    let stdout = child.stdout.take().ok_or("no stdout")?;
    BufReader::new(stdout).read_line(&mut line).map_err(|e| format!("no device printed: {e}"))?;
    let device = line.trim().to_string();
    if !device.starts_with("/dev/") {
        return Err(format!("printed {device:?} instead of a device"));
    }
    Ok((Background(child, board), device))
}

/// Start `plotter serve …`, fetch its page, stop it with SIGTERM; the exit status and what it printed.
fn run_server(dir: &Path, command: &str) -> Result<String, String> {
    let mut child = shell(dir, &exec_line(command))
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| format!("cannot start: {e}"))?;
    let stdout = child.stdout.take().ok_or("no stdout")?;
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for l in BufReader::new(stdout).lines().map_while(Result::ok) {
            let _ = tx.send(l);
        }
    });
    let mut printed = Vec::new();
    let deadline = Instant::now() + Duration::from_secs(30);
    let url = loop {
        match rx.recv_timeout(Duration::from_millis(100)) {
            Ok(l) => {
                let url = l.split_whitespace().find(|w| w.starts_with("http://")).map(str::to_string);
                printed.push(l);
                if let Some(u) = url {
                    break Some(u);
                }
            }
            Err(_) if Instant::now() > deadline => break None,
            Err(_) => {}
        }
    };
    let page = url.as_deref().map(fetch_page);
    let _ = nix::sys::signal::kill(
        nix::unistd::Pid::from_raw(i32::try_from(child.id()).unwrap_or(0)),
        nix::sys::signal::Signal::SIGTERM,
    );
    let status = wait_limited(&mut child, Duration::from_secs(40));
    let mut err = String::new();
    if let Some(mut e) = child.stderr.take() {
        let _ = e.read_to_string(&mut err);
    }
    let said = format!("stdout: {}\nstderr: {err}", printed.join("\n"));
    match (url, page, status) {
        (None, _, _) => Err(format!("never printed its address\n{said}")),
        (_, Some(Err(e)), _) => Err(format!("its page did not load: {e}\n{said}")),
        (_, _, Some(s)) if s.success() => Ok(said),
        (_, _, s) => Err(format!("after SIGTERM it ended {s:?}\n{said}")),
    }
}

/// GET `url` (plain HTTP on loopback); the page must be the app's HTML.
fn fetch_page(url: &str) -> Result<(), String> {
    let rest = url.strip_prefix("http://").ok_or("not http")?;
    let host = rest.split('/').next().unwrap_or(rest);
    let mut s = std::net::TcpStream::connect(host).map_err(|e| e.to_string())?;
    s.set_read_timeout(Some(Duration::from_secs(10))).map_err(|e| e.to_string())?;
    write!(s, "GET / HTTP/1.1\r\nHost: {host}\r\nConnection: close\r\n\r\n").map_err(|e| e.to_string())?;
    let mut body = String::new();
    let _ = s.read_to_string(&mut body);
    if body.starts_with("HTTP/1.1 200") && body.contains("<html") {
        Ok(())
    } else {
        Err(body.chars().take(300).collect())
    }
}

fn wait_limited(child: &mut Child, limit: Duration) -> Option<std::process::ExitStatus> {
    let deadline = Instant::now() + limit;
    loop {
        if let Ok(Some(s)) = child.try_wait() {
            return Some(s);
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            let _ = child.wait();
            return None;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// The exit status the README announces for a command: the thermal fault ends the print with an alarm (3).
fn expected_status(p: &Pasted) -> i32 {
    if p.command.contains("--fault ") { 3 } else { 0 }
}

/// Run one ordinary command; `Err` with what it printed when it did not end as expected.
fn run_command(dir: &Path, p: &Pasted, command: &str) -> Result<(), String> {
    let mut child = shell(dir, command)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| format!("cannot start: {e}"))?;
    let (mut out, mut err) = (child.stdout.take().ok_or("stdout")?, child.stderr.take().ok_or("stderr")?);
    let out_reader = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = out.read_to_string(&mut s);
        s
    });
    let err_reader = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = err.read_to_string(&mut s);
        s
    });
    let status = wait_limited(&mut child, COMMAND_LIMIT);
    let (out, err) = (out_reader.join().unwrap_or_default(), err_reader.join().unwrap_or_default());
    let tail = |s: &str| s.lines().rev().take(12).collect::<Vec<_>>().into_iter().rev().collect::<Vec<_>>().join("\n");
    let said = format!("stdout:\n{}\nstderr:\n{}", tail(&out), tail(&err));
    match status {
        None => Err(format!("still running after {COMMAND_LIMIT:?}\n{said}")),
        Some(s) if s.code() == Some(expected_status(p)) => Ok(()),
        Some(s) => Err(format!("exit {s:?}, expected {}\n{said}", expected_status(p))),
    }
}

#[test]
fn every_tour_command_runs_as_pasted() {
    let readme = std::fs::read_to_string(workspace_root().join("README.md")).expect("README.md");
    let tour = commands(&tour_block(&readme));
    assert!(tour.len() > 40, "the tour lost its commands: {} found", tour.len());
    let dir = clean_folder();
    let qemu = qemu_available("readme_tour (the QEMU lines)");
    let mut devices: HashMap<String, String> = HashMap::new();
    let mut emulators: HashMap<String, Background> = HashMap::new();
    let mut failures = Vec::new();
    let mut ran = 0;
    for p in &tour {
        if p.command.starts_with("alias ") {
            continue;
        }
        // The example device paths this line names, replaced by the emulators started for them, in one pass: a real
        // device may look like another line's example (`/dev/pts/9`), so a replacement must not be replaced again.
        let mut command = p.command.clone();
        let named: Vec<(&String, &String)> = devices.iter().filter(|(ex, _)| p.command.contains(ex.as_str())).collect();
        for (i, (example, _)) in named.iter().enumerate() {
            command = command.replace(example.as_str(), &format!("\u{0}{i}\u{0}"));
        }
        for (i, (_, real)) in named.iter().enumerate() {
            command = command.replace(&format!("\u{0}{i}\u{0}"), real);
        }
        let started = Instant::now();
        let result = if p.command.starts_with("plotter sim --pty") || p.command.starts_with("plotter sim --qemu") {
            if p.command.contains("--qemu") && !qemu {
                continue;
            }
            let Some(example) = example_device(&p.trailing) else {
                failures.push(format!("line {}: `{}` names no device it prints", p.line, p.command));
                continue;
            };
            match start_emulator(&dir, &p.command) {
                Ok((child, device)) => {
                    devices.insert(example.clone(), device);
                    emulators.insert(example, child);
                    Ok(())
                }
                Err(e) => Err(e),
            }
        } else if p.command.starts_with("plotter serve") {
            run_server(&dir, &command).map(|_| ())
        } else {
            if command.contains("/dev/") && !devices.keys().any(|d| p.command.contains(d.as_str())) {
                failures.push(format!(
                    "line {}: `{}` names a device no emulator line before it starts ({})",
                    p.line, p.command, "say which `plotter sim --pty …  # prints e.g. /dev/…` to run first"
                ));
                continue;
            }
            if p.command.contains("/dev/pts/8") && p.above.contains("QEMU") && !qemu {
                continue;
            }
            run_command(&dir, p, &command)
        };
        ran += 1;
        eprintln!("line {:>3} {:>6.1} s  {}", p.line, started.elapsed().as_secs_f64(), p.command);
        if let Err(e) = result {
            failures.push(format!("line {}: `{}`\n{e}", p.line, p.command));
        }
    }
    drop(emulators);
    let leftovers: Vec<String> = std::fs::read_dir(dir.join("samples"))
        .expect("samples")
        .filter_map(Result::ok)
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".journal"))
        .collect();
    assert!(leftovers.is_empty(), "journals were left beside the samples: {leftovers:?}");
    assert!(
        failures.is_empty(),
        "{} of {ran} README tour commands failed:\n\n{}",
        failures.len(),
        failures.join("\n\n")
    );
}

#[test]
fn comments_and_quotes_are_read_as_a_shell_would() {
    assert_eq!(comment_start("plotter sim --pty   # prints e.g. /dev/pts/7"), Some(20));
    assert_eq!(comment_start("plotter plot 'gen:a?b=#1' --fit"), None);
    assert_eq!(comment_start("echo a#b"), None);
    assert_eq!(example_device("# prints e.g. /dev/pts/7"), Some("/dev/pts/7".to_string()));
    assert_eq!(example_device("# or 2.8.1; prints e.g. /dev/pts/9"), Some("/dev/pts/9".to_string()));
    let block = vec![
        (1, "# a comment".to_string()),
        (2, "plotter stats x.svg".to_string()),
        (3, String::new()),
        (4, "plotter sim --pty  # prints e.g. /dev/pts/7".to_string()),
    ];
    let c = commands(&block);
    assert_eq!(c.len(), 2);
    assert_eq!((c[0].line, c[0].command.as_str(), c[0].above.as_str()), (2, "plotter stats x.svg", "# a comment\n"));
    assert_eq!((c[1].command.as_str(), c[1].above.as_str()), ("plotter sim --pty", ""));
}
