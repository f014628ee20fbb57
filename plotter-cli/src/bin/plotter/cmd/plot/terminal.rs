//! The terminal's side of a plot: the progress line (a bar that fits the terminal, or a plain line every 5 % when
//! stderr is a log), Ctrl-C pause requests and the prompts (resume or abort, pen changes, alarms), which take one
//! key at a terminal.

use std::io::{BufRead as _, IsTerminal as _, Write as _};
use std::os::fd::AsFd as _;

use anyhow::Context as _;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use plotter_host::job::progress::{
    JobProgress, LogCadence, PenChangeChoice, PenChangeMode, PenChangeRequest, PlotEvents,
};
use plotter_host::job::stops::PauseRequest;
use plotter_host::link::stream::PauseChoice;
use plotter_host::stop::Stop;
use plotter_path::config::pens::LayerPen;

/// `--pen-change`: what happens between layers drawn with different pens.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum PenChange {
    /// Prompt when stdin is a terminal; otherwise (a script, a pipe) plot straight through, with a warning.
    Auto,
    /// Park with the pen up and ask for the next pen: Enter continues, s skips the layer, q stops (one key at a
    /// terminal; otherwise one answer a line from stdin).
    Prompt,
    /// Park with the pen up and end the plot there (exit status 5); on a port `plotter resume` continues with the
    /// next pen.
    Pause,
    /// Plot straight through (one pen, or a machine that changes pens itself).
    None,
}

/// The terminal's side of a plot: progress, Ctrl-C pause requests (SIGTERM, SIGHUP, SIGQUIT and a second Ctrl-C
/// stop the plot: see plotter_host::stop), and the prompts.
pub(super) struct Terminal {
    pub(super) bar: ProgressBar,
    /// Plain progress lines for a log (stderr is not a terminal).
    log: Option<LogCadence>,
    stop: &'static Stop,
    immediately: bool,
    /// `--pen-change` with `auto` decided.
    pen_change: PenChange,
    /// `auto` chose to plot straight through (stdin is not a terminal): warn when the plot has pen changes.
    auto_straight: bool,
}

/// Puts a terminal in character mode (no line editing, no echo; Ctrl-C still signals) and restores its settings
/// when dropped — on every way out of a prompt, a stop signal and a panic included.
struct CharMode<'a> {
    fd: std::os::fd::BorrowedFd<'a>,
    saved: nix::sys::termios::Termios,
}

impl<'a> CharMode<'a> {
    fn enter(fd: std::os::fd::BorrowedFd<'a>) -> Option<Self> {
        use nix::sys::termios::{LocalFlags, SetArg, SpecialCharacterIndices, tcgetattr, tcsetattr};
        let saved = tcgetattr(fd).ok()?;
        let mut t = saved.clone();
        t.local_flags.remove(LocalFlags::ICANON | LocalFlags::ECHO);
        t.control_chars[SpecialCharacterIndices::VMIN as usize] = 1;
        t.control_chars[SpecialCharacterIndices::VTIME as usize] = 0;
        tcsetattr(fd, SetArg::TCSANOW, &t).ok()?;
        // Keys typed before the question (an Enter after an earlier answer's key) are not its answer.
        let _ = nix::sys::termios::tcflush(fd, nix::sys::termios::FlushArg::TCIFLUSH);
        Some(CharMode { fd, saved })
    }
}

impl Drop for CharMode<'_> {
    fn drop(&mut self) {
        let _ = nix::sys::termios::tcsetattr(self.fd, nix::sys::termios::SetArg::TCSANOW, &self.saved);
    }
}

/// Wait until stdin has input; `false` when a stop arrives first (any signal, a Ctrl-C included: nobody resumes
/// a prompt they interrupted) or stdin fails.
fn wait_for_input(stop: &Stop) -> bool {
    let stdin = std::io::stdin();
    loop {
        if stop.stop_cause_or_interrupt().is_some() {
            eprintln!();
            return false;
        }
        let mut fds = [nix::poll::PollFd::new(stdin.as_fd(), nix::poll::PollFlags::POLLIN)];
        match nix::poll::poll(&mut fds, nix::poll::PollTimeout::from(100u8)) {
            Ok(0) | Err(nix::errno::Errno::EINTR) => {}
            Ok(_) => return true,
            Err(_) => return false,
        }
    }
}

/// One answer from the user: at a terminal one key, taken as it is pressed (Enter is `'\n'`); otherwise the first
/// character of a line (`'\n'` for an empty line). `None` at the end of input, or when a stop arrives while
/// waiting for it.
fn ask(stop: &Stop, prompt: &str) -> Option<char> {
    let show = || {
        eprint!("{prompt}");
        let _ = std::io::stderr().flush();
    };
    let stdin = std::io::stdin();
    if stdin.is_terminal() {
        let fd = stdin.as_fd();
        // Character mode before the question shows: a key pressed once it is on the screen is its answer.
        if let Some(_mode) = CharMode::enter(fd) {
            show();
            if !wait_for_input(stop) {
                return None;
            }
            let mut byte = [0u8; 1];
            let key = match nix::unistd::read(fd, &mut byte) {
                Ok(1) => char::from(byte[0]),
                _ => return None,
            };
            // The echo is ours (the terminal's is off): the key, then the line ends.
            match key {
                '\n' | '\r' => eprintln!(),
                c if c.is_ascii_graphic() => eprintln!("{c}"),
                _ => eprintln!(),
            }
            return Some(if key == '\r' { '\n' } else { key });
        }
    }
    show();
    if !wait_for_input(stop) {
        return None;
    }
    let mut line = String::new();
    match stdin.lock().read_line(&mut line) {
        Ok(n) if n > 0 => Some(line.trim().chars().next().unwrap_or('\n')),
        _ => None,
    }
}

/// The terminal's width in columns, when stderr is one.
fn width() -> Option<usize> {
    console::Term::stderr().size_checked().map(|(_, cols)| usize::from(cols))
}

impl Terminal {
    /// The terminal of a plot about to stream: from now on one Ctrl-C pauses the plot (before, it ends the command).
    pub(super) fn new(immediately: bool, pen_change: PenChange) -> anyhow::Result<Self> {
        let stop = Stop::install_signals().context("cannot take the termination signals")?;
        // A signal while the drawing was loaded, ordered or planned (work that does not stop midway) ends the
        // command before anything moves, rather than pausing the plot it was meant to prevent.
        if let Some(cause) = stop.stop_cause() {
            let doing = "the plot was prepared (nothing moved)".to_string();
            return Err(plotter_host::stop::Stopped { cause, doing }.into());
        }
        stop.set_pausable(true);
        let on_terminal = std::io::stderr().is_terminal();
        let target = if on_terminal { ProgressDrawTarget::stderr_with_hz(5) } else { ProgressDrawTarget::hidden() };
        let bar = ProgressBar::with_draw_target(None, target);
        if let Ok(style) = ProgressStyle::with_template("{msg}") {
            bar.set_style(style);
        }
        let (pen_change, auto_straight) = match pen_change {
            PenChange::Auto if std::io::stdin().is_terminal() => (PenChange::Prompt, false),
            PenChange::Auto => (PenChange::None, true),
            other => (other, false),
        };
        let log = (!on_terminal).then(LogCadence::default);
        Ok(Terminal { bar, log, stop, immediately, pen_change, auto_straight })
    }
}

impl PlotEvents for Terminal {
    fn progress(&mut self, p: &JobProgress) {
        match self.log.as_mut() {
            Some(cadence) => {
                if cadence.due(p) {
                    eprintln!("progress {}", p.line(None));
                }
            }
            None => self.bar.set_message(p.line(Some(width().unwrap_or(80)))),
        }
    }

    fn pause_requested(&mut self) -> Option<bool> {
        self.stop.take_pause().then_some(self.immediately)
    }

    fn paused(&mut self, held: bool) -> PauseChoice {
        let what = if held { "feed hold (pen where it stopped)" } else { "paused with the pen up" };
        self.bar.suspend(|| {
            let mut prompt = format!("\n{what}: [r]esume or [a]bort? ");
            loop {
                match ask(self.stop, &prompt) {
                    Some('r' | 'R') => return PauseChoice::Resume,
                    Some('a' | 'A' | 'q' | 'Q') | None => return PauseChoice::Abort,
                    Some(_) => prompt = "press r to resume or a to abort: ".to_string(),
                }
            }
        })
    }

    fn pen_change_mode(&self) -> PenChangeMode {
        match self.pen_change {
            PenChange::Prompt | PenChange::Pause => PenChangeMode::Pause,
            PenChange::None | PenChange::Auto => PenChangeMode::None,
        }
    }

    fn plot_started(&mut self, first_pen: &LayerPen, pen_changes: usize) {
        if pen_changes == 0 {
            return;
        }
        self.bar.suspend(|| match self.pen_change {
            PenChange::Prompt | PenChange::Pause => {
                eprintln!("this plot uses {} pens: start with {}", pen_changes + 1, first_pen.label());
            }
            PenChange::None if self.auto_straight => eprintln!(
                "warning: this plot uses {} pens, and stdin is not a terminal to ask for them: plotting every \
                 layer with {} (--pen-change prompt asks on stdin, pause stops at each change for `plotter \
                 resume`, none plots straight through without this warning)",
                pen_changes + 1,
                first_pen.label()
            ),
            PenChange::None | PenChange::Auto => {}
        });
    }

    fn plot_pause(&mut self, p: &PauseRequest) -> PenChangeChoice {
        self.bar.set_message("");
        self.bar.suspend(|| {
            eprintln!("\n{}; parked at X{:.1} Y{:.1} with the pen up", p.ask(), p.park_mm.0, p.park_mm.1);
            match self.pen_change {
                PenChange::Pause => {
                    eprintln!("--pen-change pause: the plot stops here");
                    return PenChangeChoice::Stop;
                }
                PenChange::None | PenChange::Auto => {
                    eprintln!("nobody to ask (stdin is not a terminal, or --pen-change none): the plot goes on");
                    return PenChangeChoice::Continue;
                }
                PenChange::Prompt => {}
            }
            let mut prompt = "[Enter] continue, [q] stop (the journal keeps the plot): ";
            loop {
                match ask(self.stop, prompt) {
                    Some('\n') => return PenChangeChoice::Continue,
                    Some('q' | 'Q') => return PenChangeChoice::Stop,
                    Some(_) => prompt = "press Enter or q: ",
                    None => {
                        eprintln!("no answer (input closed or stopped): stopping");
                        return PenChangeChoice::Stop;
                    }
                }
            }
        })
    }

    fn pen_change(&mut self, c: &PenChangeRequest) -> PenChangeChoice {
        // The figures before the prompt were the last layer's: the next layer's line starts afresh.
        self.bar.set_message("");
        self.bar.suspend(|| {
            let resumed = c.previous.is_none() && !c.park_mm.0.is_finite();
            if self.pen_change == PenChange::Pause && resumed {
                eprintln!("continuing with layer {:?}: pen {} must be loaded", c.layer_name, c.pen.label());
                return PenChangeChoice::Continue;
            }
            let whence = if c.park_mm.0.is_finite() {
                format!("parked at X{:.1} Y{:.1} with the pen up", c.park_mm.0, c.park_mm.1)
            } else {
                "before the plot continues".to_string()
            };
            let from = c.previous.as_ref().map(|p| format!(" (replacing {})", p.label())).unwrap_or_default();
            eprintln!(
                "\npen change {}/{}: {whence}; load pen {}{from} for layer {:?}",
                c.number,
                c.total,
                c.pen.label(),
                c.layer_name
            );
            if self.pen_change == PenChange::Pause {
                eprintln!("--pen-change pause: the plot stops here");
                return PenChangeChoice::Stop;
            }
            let mut prompt = "[Enter] continue, [s] skip this layer, [q] stop (the journal keeps the plot): ";
            loop {
                match ask(self.stop, prompt) {
                    Some('\n') => return PenChangeChoice::Continue,
                    Some('s' | 'S') => return PenChangeChoice::SkipLayer,
                    Some('q' | 'Q') => return PenChangeChoice::Stop,
                    Some(_) => prompt = "press Enter, s or q: ",
                    None => {
                        eprintln!("no answer (input closed or stopped): stopping");
                        return PenChangeChoice::Stop;
                    }
                }
            }
        })
    }

    fn notice(&mut self, text: &str) {
        self.bar.suspend(|| eprintln!("\n{text}"));
    }

    fn unlock_alarm(&mut self, what: &str) -> bool {
        self.bar.suspend(|| {
            eprintln!("{what}");
            let answer = ask(self.stop, "unlock it ($X)? The position may be wrong after some alarms. [y/N] ");
            matches!(answer, Some('y' | 'Y'))
        })
    }
}
