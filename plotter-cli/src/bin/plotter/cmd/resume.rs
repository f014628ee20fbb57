//! `plotter resume`: list the plots that were interrupted on a port (their journals in the user's state directory)
//! and continue one of them where it stopped.

use std::path::PathBuf;
use std::time::{Duration, SystemTime};

use anyhow::{Context as _, bail};
use plotter_host::state_dir::{self, JournalEntry};

use super::plot::{ResumeLink, hold_seconds, resume};

/// Arguments of `plotter resume`.
#[derive(clap::Args, Debug)]
pub(crate) struct ResumeArgs {
    /// The plot to continue: a journal file, or its number in `plotter resume --list` [default: the only
    /// interrupted plot, when there is just one].
    pub(crate) journal: Option<String>,
    /// List the plots that can be resumed (drawing, machine, how far they got, when) instead of resuming one.
    #[arg(long, conflicts_with = "journal")]
    pub(crate) list: bool,
    /// Serial device of the plotter (e.g. /dev/ttyUSB0, or the path printed by `plotter sim --pty`).
    #[arg(long, required_unless_present = "list")]
    pub(crate) port: Option<String>,
    /// Serial baud rate [default: the one the plot was started with, else the profile's].
    #[arg(long)]
    pub(crate) baud: Option<u32>,
    /// Trust the position the firmware reports instead of homing again.
    #[arg(long)]
    pub(crate) trust_position: bool,
    /// On Ctrl-C, hold at once (pen stays where it is) instead of at the next pen-up.
    #[arg(long)]
    pub(crate) pause_immediately: bool,
    /// GRBL: how long a feed hold nobody resumes may last, seconds, before the plot stops and lifts the pen.
    #[arg(long, default_value_t = 30.0, value_parser = hold_seconds)]
    pub(crate) hold_timeout: f64,
}

/// How long ago `age` was, for a person: "just now", "12 min ago", "3 h ago", "2 days ago".
fn ago(age: Duration) -> String {
    let s = age.as_secs();
    match s {
        0..60 => "just now".to_string(),
        60..3600 => format!("{} min ago", s / 60),
        3600..86_400 => format!("{} h ago", s / 3600),
        86_400..172_800 => "1 day ago".to_string(),
        _ => format!("{} days ago", s / 86_400),
    }
}

/// One plot of the listing: its number, drawing, machine, progress and age, then its journal file.
fn listing_line(number: usize, e: &JournalEntry, now: SystemTime) -> String {
    let on = if e.machine.is_empty() { String::new() } else { format!(" on {}", e.machine) };
    let age = now.duration_since(e.modified).unwrap_or_default();
    format!(
        "{number:>3}  {}{on}: {:.0}% plotted, {}\n     {}",
        e.drawing,
        e.percent().floor(),
        ago(age),
        e.path.display()
    )
}

/// Run `plotter resume`.
pub(crate) fn run(args: &ResumeArgs) -> anyhow::Result<()> {
    plotter_host::stop::Stop::install_signals().context("cannot take the termination signals")?;
    let dir = state_dir::journals_dir()?;
    let list = state_dir::resumable(&dir)?;
    if args.list {
        if list.is_empty() {
            println!("no interrupted plots to resume (journals are kept in {})", dir.display());
            return Ok(());
        }
        println!("plots that can be resumed (plotter resume NUMBER --port DEVICE):");
        let now = SystemTime::now();
        for (i, e) in list.iter().enumerate() {
            println!("{}", listing_line(i + 1, e, now));
        }
        return Ok(());
    }
    let journal: PathBuf = match args.journal.as_deref() {
        Some(j) if PathBuf::from(j).exists() => PathBuf::from(j),
        Some(j) => match j.parse::<usize>() {
            Ok(n) if n >= 1 && n <= list.len() => list[n - 1].path.clone(),
            Ok(n) => bail!("there is no plot number {n} to resume ({} listed; see plotter resume --list)", list.len()),
            Err(_) => bail!("{j}: no such journal file (plotter resume --list shows the plots that can be resumed)"),
        },
        None => match list.as_slice() {
            [] => bail!("no interrupted plots to resume (journals are kept in {})", dir.display()),
            [only] => only.path.clone(),
            _ => bail!(
                "{} interrupted plots: say which (plotter resume NUMBER --port DEVICE; plotter resume --list)",
                list.len()
            ),
        },
    };
    let link = ResumeLink {
        port: args.port.as_deref(),
        baud: args.baud,
        hold_timeout: args.hold_timeout,
        pause_immediately: args.pause_immediately,
        trust_position: args.trust_position,
    };
    resume(&link, &journal)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ages_read_as_a_person_says_them() {
        let cases = [
            (0, "just now"),
            (59, "just now"),
            (60, "1 min ago"),
            (3599, "59 min ago"),
            (3600, "1 h ago"),
            (86_399, "23 h ago"),
            (86_400, "1 day ago"),
            (172_800, "2 days ago"),
            (10 * 86_400 + 5, "10 days ago"),
        ];
        for (s, text) in cases {
            assert_eq!(ago(Duration::from_secs(s)), text, "{s} s");
        }
    }

    #[test]
    fn a_listed_plot_says_what_where_how_far_and_when() {
        let now = SystemTime::UNIX_EPOCH + Duration::from_secs(1_000_000);
        let e = JournalEntry {
            path: PathBuf::from("/s/journals/duck-xy-1234abcd.journal"),
            drawing: "/home/me/duck.svg".into(),
            machine: "XY plotter kit".into(),
            executed: 333,
            blocks: 1000,
            modified: now - Duration::from_secs(300),
        };
        assert_eq!(
            listing_line(2, &e, now),
            "  2  /home/me/duck.svg on XY plotter kit: 33% plotted, 5 min ago\n     /s/journals/duck-xy-1234abcd.journal"
        );
        let bare = JournalEntry { machine: String::new(), ..e };
        assert!(listing_line(1, &bare, now).starts_with("  1  /home/me/duck.svg: 33% plotted"));
    }
}
