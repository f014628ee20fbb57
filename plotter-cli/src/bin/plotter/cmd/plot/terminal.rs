//! The terminal's side of a plot: the progress bar, Ctrl-C pause requests and the prompts (resume or abort, pen
//! changes, alarms).

use std::io::{BufRead as _, IsTerminal as _, Write as _};

use anyhow::Context as _;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use plotter_host::job::progress::{JobProgress, PenChangeChoice, PenChangeMode, PenChangeRequest, PlotEvents};
use plotter_host::link::stream::PauseChoice;
use plotter_host::stop::Stop;
use plotter_path::config::pens::LayerPen;

/// The terminal's side of a plot: progress bar, Ctrl-C pause requests (SIGTERM, SIGHUP, SIGQUIT and a second
/// Ctrl-C stop the plot: [`plotter_host::stop`]), and the resume-or-abort prompt.
pub(super) struct Terminal {
    pub(super) bar: ProgressBar,
    stop: &'static Stop,
    immediately: bool,
    pen_change: PenChangeMode,
}

/// One answer line from the user: `None` at the end of input, or when a stop arrives while waiting for it (any
/// signal, a Ctrl-C included: nobody resumes a prompt they interrupted).
fn ask(stop: &Stop, prompt: &str) -> Option<String> {
    use std::os::fd::AsFd as _;
    eprint!("{prompt}");
    let _ = std::io::stderr().flush();
    let stdin = std::io::stdin();
    loop {
        if stop.stop_cause_or_interrupt().is_some() {
            eprintln!();
            return None;
        }
        let mut fds = [nix::poll::PollFd::new(stdin.as_fd(), nix::poll::PollFlags::POLLIN)];
        match nix::poll::poll(&mut fds, nix::poll::PollTimeout::from(100u8)) {
            Ok(0) | Err(nix::errno::Errno::EINTR) => {}
            Ok(_) => break,
            Err(_) => return None,
        }
    }
    let mut line = String::new();
    match stdin.lock().read_line(&mut line) {
        Ok(n) if n > 0 => Some(line.trim().to_string()),
        _ => None,
    }
}

impl Terminal {
    /// The terminal of a plot about to stream: from now on one Ctrl-C pauses the plot (before, it ends the command).
    pub(super) fn new(immediately: bool, pen_change: PenChangeMode) -> anyhow::Result<Self> {
        let stop = Stop::install_signals().context("cannot take the termination signals")?;
        // A signal while the drawing was loaded, ordered or planned (work that does not stop midway) ends the
        // command before anything moves, rather than pausing the plot it was meant to prevent.
        if let Some(cause) = stop.stop_cause() {
            let doing = "the plot was prepared (nothing moved)".to_string();
            return Err(plotter_host::stop::Stopped { cause, doing }.into());
        }
        stop.set_pausable(true);
        let target = if std::io::stderr().is_terminal() {
            ProgressDrawTarget::stderr_with_hz(5)
        } else {
            ProgressDrawTarget::hidden()
        };
        let bar = ProgressBar::with_draw_target(None, target);
        if let Ok(style) = ProgressStyle::with_template("{bar:30} {percent:>3}% {pos}/{len} blocks  {msg}")
            .map(|s| s.progress_chars("█▉ "))
        {
            bar.set_style(style);
        }
        Ok(Terminal { bar, stop, immediately, pen_change })
    }
}

impl PlotEvents for Terminal {
    fn progress(&mut self, p: &JobProgress) {
        self.bar.set_length(u64::try_from(p.total).unwrap_or(u64::MAX));
        self.bar.set_position(u64::try_from(p.executed).unwrap_or(u64::MAX));
        self.bar.set_message(format!(
            "pen-down {:.0}/{:.0} mm  ETA {:.0} s  resends {}  pen {} at X {:.1}, Y {:.1} mm",
            p.draw_done_mm,
            p.draw_total_mm,
            p.eta_s,
            p.resends,
            if p.pen_down { "down" } else { "up" },
            p.pen_mm.x,
            p.pen_mm.y
        ));
    }

    fn pause_requested(&mut self) -> Option<bool> {
        self.stop.take_pause().then_some(self.immediately)
    }

    fn paused(&mut self, held: bool) -> PauseChoice {
        let what = if held { "feed hold (pen where it stopped)" } else { "paused with the pen up" };
        self.bar.suspend(|| match ask(self.stop, &format!("\n{what}: [r]esume or [a]bort? ")) {
            Some(l) if l.starts_with(['r', 'R']) => PauseChoice::Resume,
            _ => PauseChoice::Abort,
        })
    }

    fn pen_change_mode(&self) -> PenChangeMode {
        self.pen_change
    }

    fn plot_started(&mut self, first_pen: &LayerPen, pen_changes: usize) {
        if pen_changes > 0 && self.pen_change == PenChangeMode::Pause {
            self.bar.suspend(|| {
                eprintln!("this plot uses {} pens: start with {}", pen_changes + 1, first_pen.label());
            });
        }
    }

    fn pen_change(&mut self, c: &PenChangeRequest) -> PenChangeChoice {
        self.bar.suspend(|| {
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
            loop {
                match ask(self.stop, "[Enter] continue, [s] skip this layer, [q] stop (the journal keeps the plot): ") {
                    Some(l) if l.is_empty() => return PenChangeChoice::Continue,
                    Some(l) if l.eq_ignore_ascii_case("s") => return PenChangeChoice::SkipLayer,
                    Some(l) if l.eq_ignore_ascii_case("q") => return PenChangeChoice::Stop,
                    Some(l) => eprintln!("{l:?}: answer with Enter, s or q"),
                    None => {
                        eprintln!("no answer (input closed): stopping");
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
            matches!(ask(self.stop, "unlock it ($X)? The position may be wrong after some alarms. [y/N] "), Some(l) if l.eq_ignore_ascii_case("y"))
        })
    }
}
