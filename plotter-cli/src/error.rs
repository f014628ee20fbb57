//! The library's error: the causes a front end acts on, as variants it can match — a block the firmware refused
//! (with its number), an alarm (with its code), a firmware that restarted or is not the one expected, a plot the
//! user stopped, a lost port, a bad input file — and, for everything else, the message with its chain of causes.
//!
//! Every variant displays the same text the front ends print; the `after` fields carry what the job did once the
//! plot stopped (the pen lifted, the machine reset) and how to continue (`plotter plot --resume …`), empty when
//! there is nothing to add.

use std::fmt;
use std::path::PathBuf;

/// What went wrong, for a front end to act on.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The firmware refused a block (`error:`); nothing after it was executed.
    #[error("the firmware refused block {block}: error {code}: {text}{after}")]
    Refused {
        /// The block's number in the plan (the original plan's, when the plot was resumed or split at pen changes).
        block: usize,
        /// Error code.
        code: u8,
        /// Error text (and, from the plot job, where the block ends).
        text: String,
        /// What happened next.
        after: String,
    },
    /// The firmware raised an alarm.
    #[error("alarm {code} ({text}) after {executed} executed block(s){after}")]
    Alarm {
        /// Alarm code.
        code: u8,
        /// Alarm text.
        text: String,
        /// Blocks certainly executed.
        executed: usize,
        /// What happened next, and how to continue.
        after: String,
    },
    /// The machine ended a job that is not a block stream (a print, played line by line) with an alarm or a
    /// restart; the text says which and what the machine did.
    #[error("{0}")]
    Halted(String),
    /// A job ended early after the machine was made safe: the text says why and what was done; `trouble` is the
    /// kind of the cause (so that a stop stays a stop and an alarm an alarm under the added words).
    #[error("{text}")]
    Ended {
        /// Why the job ended and what was done about it.
        text: String,
        /// The kind of trouble that ended it.
        trouble: Trouble,
    },
    /// The firmware restarted during a plot (its banner appeared).
    #[error("the firmware restarted during the plot after {executed} executed block(s){after}")]
    Restarted {
        /// Blocks certainly executed.
        executed: usize,
        /// What happened next, and how to continue.
        after: String,
    },
    /// The user stopped the plot at a pause.
    #[error("plot aborted by the user after {executed} executed block(s){after}")]
    Aborted {
        /// Blocks executed.
        executed: usize,
        /// What happened next, and how to continue.
        after: String,
    },
    /// A pause request that could not wait for the next pen-up stopped the plot where it stood.
    #[error("{name}: stopped at once on {why}, after {executed} executed block(s){after}")]
    StoppedAtOnce {
        /// Where the machine is connected.
        name: String,
        /// What made the stop immediate.
        why: String,
        /// Blocks certainly executed.
        executed: usize,
        /// What happened next, and how to continue.
        after: String,
    },
    /// The user chose to stop at a pen change.
    #[error("stopped at the pen change before layer {layer:?} (pen {pen}){after}")]
    StoppedAtPenChange {
        /// The layer the plot would have continued with.
        layer: String,
        /// Its pen.
        pen: String,
        /// How to continue.
        after: String,
    },
    /// The user chose to stop at a pause the plot made on its own: before a layer whose name starts with `!`, or
    /// to refill the pen (`--split-distance`).
    #[error("stopped at the pause ({asked}){after}")]
    StoppedAtPause {
        /// What the pause asked for, as a sentence.
        asked: String,
        /// How to continue.
        after: String,
    },
    /// The link to the machine failed: the port went away or could not be read or written.
    #[error("{cause}{after}")]
    PortLost {
        /// What the operating system said.
        cause: std::io::Error,
        /// What happened next, and how to continue.
        after: String,
    },
    /// The device on the port does not answer like the firmware expected.
    #[error("{name} does not answer like plotter-fw (M115 got no firmware info); it sent: {heard}")]
    FirmwareMismatch {
        /// Where the device is connected.
        name: String,
        /// Its first few lines, quoted.
        heard: String,
    },
    /// The serial port could not be opened: it does not exist, is busy or is not permitted (the message says which).
    #[error(transparent)]
    PortUnavailable(anyhow::Error),
    /// Nothing answered on the port.
    #[error("no answer from {name}: is it a plotter running plotter-fw (or `plotter sim --pty`)?")]
    NoAnswer {
        /// Where the device is connected.
        name: String,
    },
    /// The motion plan cannot be made (a move outside the machine's travel, a block beyond its limits).
    #[error(transparent)]
    Plan(#[from] plotter_path::motion::plan::PlanError),
    /// An input file (a drawing, a profile) could not be read or is not valid; the message names the place.
    #[error(transparent)]
    BadInput(#[from] BadInput),
    /// Anything else, as a message with its causes.
    #[error(transparent)]
    Other(anyhow::Error),
}

/// What kind of trouble an [`Error`] is: what a front end decides on (an exit status, whether the link is still
/// worth using, whether the drawing or the machine needs attention).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Trouble {
    /// The machine said no: a refused block, an alarm, a restart during the plot.
    Machine,
    /// The link is gone or was never what it should be: a lost port, no answer, not the expected firmware.
    Link,
    /// The user stopped the plot (at a pause, at once, or at a pen change).
    Stopped,
    /// A bad input file, a plan that cannot be made, or anything else.
    Other,
}

impl Trouble {
    /// The first trouble other than [`Trouble::Other`] among the typed [`Error`]s in `e`'s chain of causes (a lost
    /// port stays a lost port under "homing failed"); [`Trouble::Other`] when there is none.
    pub fn of(e: &anyhow::Error) -> Trouble {
        e.chain()
            .filter_map(|cause| {
                // A wait the user stopped (see `crate::stop`) is a stop, under whatever context.
                let waited = cause.downcast_ref::<crate::stop::WaitError>();
                if cause.downcast_ref::<crate::stop::Stopped>().is_some()
                    || matches!(waited, Some(crate::stop::WaitError::Stopped(_)))
                {
                    return Some(Trouble::Stopped);
                }
                cause.downcast_ref::<Error>().map(Error::trouble)
            })
            .find(|t| *t != Trouble::Other)
            .unwrap_or(Trouble::Other)
    }

    /// A short lowercase name (`machine`, `link`, `stopped`, `other`), as the web app sends it.
    pub fn name(self) -> &'static str {
        match self {
            Trouble::Machine => "machine",
            Trouble::Link => "link",
            Trouble::Stopped => "stopped",
            Trouble::Other => "other",
        }
    }
}

impl Error {
    /// The port to `name` failed with `cause` in the middle of a conversation; `hint` says what to check (e.g.
    /// "was the board unplugged?"). A [`Error::PortLost`] whose message names the port, the cause and the hint.
    pub fn lost(name: &str, cause: &std::io::Error, hint: &str) -> Error {
        let cause = std::io::Error::new(cause.kind(), format!("lost the connection to {name}: {cause} ({hint})"));
        Error::PortLost { cause, after: String::new() }
    }

    /// What kind of trouble this is.
    pub fn trouble(&self) -> Trouble {
        match self {
            Error::Ended { trouble, .. } => *trouble,
            Error::Refused { .. } | Error::Alarm { .. } | Error::Restarted { .. } | Error::Halted(_) => {
                Trouble::Machine
            }
            Error::PortLost { .. }
            | Error::PortUnavailable(_)
            | Error::FirmwareMismatch { .. }
            | Error::NoAnswer { .. } => Trouble::Link,
            Error::Aborted { .. }
            | Error::StoppedAtOnce { .. }
            | Error::StoppedAtPenChange { .. }
            | Error::StoppedAtPause { .. } => Trouble::Stopped,
            Error::Plan(_) | Error::BadInput(_) => Trouble::Other,
            Error::Other(e) => Trouble::of(e),
        }
    }
}

/// A result of this library.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// A bad input file, and what is wrong with it (with the line, element or key where the reader knows it).
#[derive(Debug)]
pub struct BadInput {
    /// The file (`-` for standard input).
    pub input: PathBuf,
    error: anyhow::Error,
}

impl BadInput {
    /// `input` is bad as `error` says.
    pub fn new(input: impl Into<PathBuf>, error: anyhow::Error) -> Self {
        BadInput { input: input.into(), error }
    }
}

impl fmt::Display for BadInput {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Display::fmt(&self.error, f)
    }
}

impl std::error::Error for BadInput {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        self.error.source()
    }
}

/// How many errors `e`'s chain holds (`e` itself and its sources).
fn chain_len(e: &(dyn std::error::Error + 'static)) -> usize {
    std::iter::successors(Some(e), |e| e.source()).count()
}

impl From<anyhow::Error> for Error {
    /// The typed error inside `e` when nothing was added to it on the way ([`Error`] itself, or an I/O error of
    /// the link: [`Error::PortLost`]); otherwise [`Error::Other`] with the whole message.
    fn from(e: anyhow::Error) -> Self {
        if let Some(inner) = e.downcast_ref::<Error>()
            && chain_len(inner) == e.chain().count()
        {
            return e.downcast::<Error>().unwrap_or_else(Error::Other);
        }
        if let Some(inner) = e.downcast_ref::<std::io::Error>()
            && chain_len(inner) == e.chain().count()
        {
            return e.downcast::<std::io::Error>().map_or_else(Error::Other, Error::from);
        }
        Error::Other(e)
    }
}

impl From<std::io::Error> for Error {
    fn from(cause: std::io::Error) -> Self {
        Error::PortLost { cause, after: String::new() }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use anyhow::Context as _;

    fn lost() -> std::io::Error {
        std::io::Error::new(std::io::ErrorKind::BrokenPipe, "the device went away")
    }

    #[test]
    fn a_bare_io_error_is_a_lost_port_and_one_with_context_keeps_its_message() {
        let e = Error::from(anyhow::Error::from(lost()));
        assert!(matches!(&e, Error::PortLost { cause, after } if cause.kind() == std::io::ErrorKind::BrokenPipe
            && after.is_empty()));
        assert_eq!(e.to_string(), "the device went away");
        let e = Error::from(anyhow::Error::from(lost()).context("cannot write to /dev/ttyUSB0"));
        assert!(matches!(e, Error::Other(_)));
        assert_eq!(format!("{:#}", anyhow::Error::from(e)), "cannot write to /dev/ttyUSB0: the device went away");
    }

    #[test]
    fn a_typed_error_comes_back_out_of_anyhow_unless_context_was_added() {
        let refused = || Error::Refused { block: 4, code: 7, text: "soft limit".into(), after: String::new() };
        let back = Error::from(anyhow::Error::from(refused()));
        assert!(matches!(back, Error::Refused { block: 4, code: 7, .. }), "{back:?}");
        let wrapped: anyhow::Result<()> = Err(refused()).context("plotting duck.svg");
        let e = Error::from(wrapped.unwrap_err());
        assert!(matches!(e, Error::Other(_)), "{e:?}");
        assert_eq!(
            format!("{:#}", anyhow::Error::from(e)),
            "plotting duck.svg: the firmware refused block 4: error 7: soft limit"
        );
    }

    #[test]
    fn the_trouble_is_found_under_added_context_and_is_other_without_a_typed_error() {
        let alarm = Error::Alarm { code: 1, text: "hard limit".into(), executed: 3, after: String::new() };
        assert_eq!(alarm.trouble(), Trouble::Machine);
        let wrapped: anyhow::Result<()> = Err(alarm).context("plotting duck.svg");
        assert_eq!(Trouble::of(&wrapped.unwrap_err()), Trouble::Machine);
        let gone = anyhow::Error::from(Error::from(lost())).context("plotting");
        assert_eq!(Trouble::of(&gone), Trouble::Link);
        assert_eq!(Error::NoAnswer { name: "p".into() }.trouble(), Trouble::Link);
        assert_eq!(Error::PortUnavailable(anyhow::anyhow!("busy")).trouble(), Trouble::Link);
        assert_eq!(Error::FirmwareMismatch { name: "p".into(), heard: "x".into() }.trouble(), Trouble::Link);
        let stop = Error::StoppedAtPenChange { layer: "2".into(), pen: "red".into(), after: String::new() };
        assert_eq!(Trouble::of(&anyhow::Error::from(stop)), Trouble::Stopped);
        assert_eq!(Error::Aborted { executed: 0, after: String::new() }.trouble(), Trouble::Stopped);
        let refused = Error::Refused { block: 1, code: 2, text: "x".into(), after: String::new() };
        assert_eq!(refused.trouble(), Trouble::Machine);
        assert_eq!(Error::Restarted { executed: 0, after: String::new() }.trouble(), Trouble::Machine);
        let e = Error::lost("/dev/ttyACM0", &lost(), "was the board unplugged?");
        assert_eq!(
            e.to_string(),
            "lost the connection to /dev/ttyACM0: the device went away (was the board unplugged?)"
        );
        assert!(matches!(&e, Error::PortLost { cause, .. } if cause.kind() == std::io::ErrorKind::BrokenPipe));
        assert_eq!(Trouble::of(&anyhow::Error::from(e)), Trouble::Link);
        // Under added context the error is Other, and its trouble still the lost port's.
        let homing = anyhow::Error::from(Error::lost("p", &lost(), "h")).context("homing ($H) failed");
        let e = Error::from(homing);
        assert!(matches!(e, Error::Other(_)), "{e:?}");
        assert_eq!(e.trouble(), Trouble::Link);
        assert_eq!(Trouble::of(&anyhow::Error::from(e).context("plot")), Trouble::Link);
        assert_eq!(Error::Other(anyhow::anyhow!("stalled")).trouble(), Trouble::Other);
        // A wait ended by a stop is a stop, bare or under context (the wait's error shows the stop through, so the
        // stop itself is not in the chain); a wait that timed out is not.
        let stopped = crate::stop::Stopped { cause: crate::stop::StopCause::Terminate, doing: "homing".into() };
        let waited = anyhow::Error::from(crate::stop::WaitError::Stopped(stopped.clone()));
        assert_eq!(Trouble::of(&waited), Trouble::Stopped);
        assert_eq!(Trouble::of(&waited.context("homing failed")), Trouble::Stopped);
        assert_eq!(Trouble::of(&anyhow::Error::from(stopped)), Trouble::Stopped);
        let timed_out = crate::stop::WaitError::TimedOut {
            name: "p".into(),
            what: "QG".into(),
            limit: std::time::Duration::from_secs(3),
        };
        assert_eq!(Trouble::of(&anyhow::Error::from(timed_out)), Trouble::Other);
        // A bare I/O error from a file is not taken for a lost port: only a typed error says so.
        assert_eq!(Trouble::of(&anyhow::Error::from(lost())), Trouble::Other);
        let bad = Error::from(BadInput::new("a.svg", anyhow::anyhow!("not a valid SVG")));
        assert_eq!(Trouble::of(&anyhow::Error::from(bad)), Trouble::Other);
        assert_eq!(
            [Trouble::Machine, Trouble::Link, Trouble::Stopped, Trouble::Other].map(Trouble::name),
            ["machine", "link", "stopped", "other"]
        );
    }

    #[test]
    fn bad_input_reads_as_its_cause_and_names_the_file() {
        let cause = anyhow::anyhow!("line 3: unknown key").context("a.toml: not a machine profile");
        let e = Error::from(BadInput::new("a.toml", cause));
        let Error::BadInput(b) = &e else { panic!("{e:?}") };
        assert_eq!(b.input, PathBuf::from("a.toml"));
        assert_eq!(format!("{:#}", anyhow::Error::from(e)), "a.toml: not a machine profile: line 3: unknown key");
    }
}
