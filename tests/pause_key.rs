//! The pause prompt takes one key, without Enter, when stdin is a terminal: `plotter plot`, with stdin and stderr
//! on a pseudo-terminal, is sent SIGINT (a Ctrl-C) while it plots, shows `[r]esume or [a]bort?`, and is typed a
//! single `r` (the plot finishes, exit 0) or a single `a` (the plot stops, exit 5, and the emulator's pen log ends
//! with the pen up) — no newline in either case. The first plot runs on the built-in simulator paced with
//! `--sim-speed` (so that it is still plotting when asked), the second on `plotter sim --pty --pen-log`, whose own
//! record of the pen is the witness. The terminal is back in line mode with echo after either, and after a stop
//! signal (SIGTERM) that ends the plot while the prompt waits. A pen change takes one key too (Enter), and the bar
//! goes on from where it was after each prompt: it counts the whole plot, with no stale copy of the last layer's line.

use std::fs::File;
use std::io::{Read as _, Write as _};
use std::process::{Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use nix::sys::signal::{Signal, kill};
use nix::sys::termios::{LocalFlags, tcgetattr};
use nix::unistd::Pid;
use plotter_e2e::{SimPty, plotter_bin, sample, scratch};

const PROMPT: &str = "[r]esume or [a]bort? ";

/// A plot on a pseudo-terminal: the child, the master side to type on, and everything it wrote to stderr so far.
struct OnPty {
    child: std::process::Child,
    master: File,
    seen: Arc<Mutex<String>>,
    slave: std::os::fd::OwnedFd,
}

impl OnPty {
    /// `plotter plot duck.svg` with `extra` arguments in `dir`, its stdin and stderr on a new pseudo-terminal.
    fn start(dir: &std::path::Path, extra: &[&str]) -> OnPty {
        OnPty::plot(dir, "duck.svg", extra)
    }

    /// `plotter plot SAMPLE` with `extra` arguments in `dir`, its stdin and stderr on a new pseudo-terminal.
    fn plot(dir: &std::path::Path, drawing: &str, extra: &[&str]) -> OnPty {
        let pty = nix::pty::openpty(None, None).expect("openpty");
        let slave = pty.slave;
        let child = Command::new(plotter_bin())
            .args(["plot", sample(drawing).to_str().unwrap()])
            .args(extra)
            .env("PLOTTER_STATE_DIR", dir.join("state"))
            .current_dir(dir)
            .stdin(Stdio::from(slave.try_clone().expect("dup")))
            .stderr(Stdio::from(slave.try_clone().expect("dup")))
            .stdout(Stdio::piped())
            .spawn()
            .expect("plotter runs");
        let master = File::from(pty.master);
        let seen = Arc::new(Mutex::new(String::new()));
        let (mut reader, theirs) = (master.try_clone().expect("dup master"), Arc::clone(&seen));
        std::thread::spawn(move || {
            let mut buf = [0u8; 4096];
            // Ends with EIO once every slave copy is closed.
            while let Ok(n) = reader.read(&mut buf) {
                if n == 0 {
                    break;
                }
                theirs.lock().unwrap().push_str(&String::from_utf8_lossy(&buf[..n]));
            }
        });
        OnPty { child, master, seen, slave }
    }

    /// Wait (at most `limit`) until the output contains `what`.
    fn wait_for(&self, what: &str, limit: Duration) {
        let start = Instant::now();
        while !self.seen.lock().unwrap().contains(what) {
            assert!(start.elapsed() < limit, "no {what:?} after {limit:?}; the terminal shows:\n{}", self.seen());
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    fn seen(&self) -> String {
        self.seen.lock().unwrap().clone()
    }

    /// Ctrl-C once the plot runs, then the prompt; returns the terminal's local flags while the prompt waits.
    fn pause(&mut self) -> LocalFlags {
        // The progress line shows once the plot streams.
        self.wait_for(" left", Duration::from_secs(8));
        kill(Pid::from_raw(i32::try_from(self.child.id()).unwrap()), Signal::SIGINT).expect("SIGINT");
        self.wait_for(PROMPT, Duration::from_secs(8));
        tcgetattr(&self.slave).expect("tcgetattr").local_flags
    }

    /// Type `key` (no newline) and wait for the exit; returns the exit code, stdout and the terminal's text.
    fn answer(mut self, key: &[u8]) -> (Option<i32>, String, String) {
        self.master.write_all(key).expect("type");
        self.end()
    }

    /// Wait for the exit; returns the exit code, stdout and the terminal's text.
    fn end(mut self) -> (Option<i32>, String, String) {
        let start = Instant::now();
        let status = loop {
            if let Some(s) = self.child.try_wait().expect("wait") {
                break s;
            }
            if start.elapsed() > Duration::from_secs(10) {
                let _ = self.child.kill();
                panic!("the plot did not end; the terminal shows:\n{}", self.seen());
            }
            std::thread::sleep(Duration::from_millis(20));
        };
        let mut out = String::new();
        self.child.stdout.take().expect("stdout").read_to_string(&mut out).expect("stdout");
        // The terminal is back in line mode with echo.
        let flags = tcgetattr(&self.slave).expect("tcgetattr").local_flags;
        assert!(flags.contains(LocalFlags::ICANON | LocalFlags::ECHO), "{flags:?}");
        std::thread::sleep(Duration::from_millis(50));
        (status.code(), out, self.seen())
    }
}

#[test]
fn one_r_resumes_the_plot_without_enter() {
    let dir = scratch("pause-key-r");
    let mut plot = OnPty::start(&dir, &["--sim-speed", "4"]);
    let before = tcgetattr(&plot.slave).expect("tcgetattr").local_flags;
    assert!(before.contains(LocalFlags::ICANON | LocalFlags::ECHO));
    let waiting = plot.pause();
    assert!(!waiting.contains(LocalFlags::ICANON) && !waiting.contains(LocalFlags::ECHO), "{waiting:?}");
    // Ctrl-C still signals while the prompt waits.
    assert!(waiting.contains(LocalFlags::ISIG));
    let (code, stdout, terminal) = plot.answer(b"r");
    assert_eq!(code, Some(0), "{terminal}\n{stdout}");
    assert!(terminal.contains("paused with the pen up: [r]esume or [a]bort? r"), "{terminal}");
    assert!(stdout.contains("as-stepped preview"), "{stdout}");
}

#[test]
fn one_a_aborts_with_the_pen_up() {
    let dir = scratch("pause-key-a");
    let log = dir.join("pen.log");
    // The emulator runs at four times real time: the 13 s duck (3.3 s here) is still plotting when the Ctrl-C comes.
    let sim = SimPty::start(&dir, &["--pace", "4", "--pen-log", log.to_str().unwrap()]);
    let mut plot = OnPty::start(&dir, &["--port", &sim.port]);
    plot.pause();
    let (code, stdout, terminal) = plot.answer(b"a");
    assert_eq!(code, Some(5), "{terminal}\n{stdout}");
    assert!(terminal.contains("paused with the pen up: [r]esume or [a]bort? a"), "{terminal}");
    assert!(terminal.contains("aborted by the user"), "{terminal}");
    // The emulator's record: the pen went down while plotting, and its last move was up.
    let pen = std::fs::read_to_string(&log).expect("pen log");
    assert!(pen.lines().any(|l| l.ends_with(" down")), "{pen}");
    assert!(pen.lines().last().is_some_and(|l| l.ends_with(" up")), "{pen}");
    drop(sim);
}

#[test]
fn a_stop_signal_at_the_prompt_gives_the_terminal_back() {
    let dir = scratch("pause-key-term");
    let mut plot = OnPty::start(&dir, &["--sim-speed", "2"]);
    let waiting = plot.pause();
    assert!(!waiting.contains(LocalFlags::ICANON), "{waiting:?}");
    kill(Pid::from_raw(i32::try_from(plot.child.id()).unwrap()), Signal::SIGTERM).expect("SIGTERM");
    // `end` checks that the terminal is back in line mode with echo.
    let (code, stdout, terminal) = plot.end();
    assert_eq!(code, Some(5), "{terminal}\n{stdout}");
}

/// The per cents of the progress bars drawn on the terminal, in order.
fn bar_percents(terminal: &str) -> Vec<u32> {
    terminal
        .split(['\r', '\n'])
        .map(|l| l.replace("\u{1b}[2K", ""))
        .filter(|l| l.starts_with('['))
        .filter_map(|l| l.split_once("]")?.1.trim_start().split('%').next()?.parse().ok())
        .collect()
}

#[test]
fn a_pen_change_takes_one_key_and_the_bar_goes_on_from_where_it_was() {
    let dir = scratch("pen-change-key");
    let plot = OnPty::plot(&dir, "three-pens.svg", &["--sim-speed", "10", "--pen-change", "prompt"]);
    const ASK: &str = "[q] stop (the journal keeps the plot): ";
    for n in 1..=2 {
        let start = Instant::now();
        while plot.seen().matches(ASK).count() < n {
            assert!(start.elapsed() < Duration::from_secs(10), "no pen change {n}:\n{}", plot.seen());
            std::thread::sleep(Duration::from_millis(20));
        }
        // One key, the Enter key, no line editing.
        (&plot.master).write_all(b"\r").expect("type");
    }
    let (code, stdout, terminal) = plot.end();
    assert_eq!(code, Some(0), "{terminal}\n{stdout}");
    assert!(stdout.contains("pen changes: 2"), "{stdout}");
    // The bar counts the whole plot: after each pen change it goes on from where it was, never back to a part's
    // start nor to a stale copy of the last layer's figures.
    let percents = bar_percents(&terminal);
    assert!(percents.windows(2).all(|w| w[0] <= w[1]), "{percents:?}\n{terminal}");
    assert!(percents.len() > 3 && percents.iter().any(|&p| p > 50), "{percents:?}\n{terminal}");
}
