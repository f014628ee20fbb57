//! The plot workflow flags AxiDraw users know, shared by `plot` and the studio's queue: copies with a delay and a
//! paper change between them, a webhook told of the plot's events, and refills after a drawn length.

use anyhow::{Result, bail};
use clap::Args;

/// Copies of one plot.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Copies {
    /// How many (0: until stopped).
    pub count: u64,
    /// Seconds to wait between copies.
    pub page_delay_s: f64,
    /// Pause for fresh paper between copies.
    pub paper_pause: bool,
}

/// Workflow flags.
#[derive(Debug, Clone, Args, Default)]
pub struct WorkflowArgs {
    /// Plot the drawing this many times, one after another (0 = until stopped with Ctrl-C or at a paper change)
    #[arg(long, default_value_t = 1, value_name = "N", help_heading = "Workflow")]
    pub copies: u64,
    /// Wait this many seconds between copies (after the pen is back home, before the paper change)
    #[arg(long, default_value_t = 0.0, value_name = "SECONDS", help_heading = "Workflow")]
    pub page_delay: f64,
    /// Between copies, go straight on without pausing for fresh paper (for a roll, or a drawing that layers
    /// copies on one sheet)
    #[arg(long, help_heading = "Workflow")]
    pub no_paper_pause: bool,
    /// Send a JSON POST to this http:// address when the plot finishes, fails, or waits for a pen change or a
    /// pause (machine, job, event, times); a failed delivery is tried three more times and then only warned
    /// about: it never holds the plot up
    #[arg(long, value_name = "URL", help_heading = "Workflow")]
    pub webhook: Option<String>,
    /// End each part of a layer after at most this many millimetres drawn (at the end of a stroke), and pause to
    /// refill the pen as at a pen change: for fountain pens, dip pens and brushes
    #[arg(long, value_name = "MM", help_heading = "Workflow")]
    pub split_distance: Option<f64>,
}

impl WorkflowArgs {
    /// The copies these flags ask for, checked.
    pub fn copies(&self) -> Result<Copies> {
        if !(self.page_delay.is_finite() && (0.0..=86_400.0).contains(&self.page_delay)) {
            bail!("--page-delay {}: give a number of seconds from 0 to 86400 (a day)", self.page_delay);
        }
        Ok(Copies { count: self.copies, page_delay_s: self.page_delay, paper_pause: !self.no_paper_pause })
    }

    /// The drawn length per refill (`--split-distance`), checked.
    pub fn split_mm(&self) -> Result<Option<f64>> {
        if let Some(d) = self.split_distance
            && !(d.is_finite() && d > 0.0)
        {
            bail!("--split-distance {d}: give the drawn length per refill in mm, above 0");
        }
        Ok(self.split_distance)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Wrap {
        #[command(flatten)]
        w: WorkflowArgs,
    }

    fn parse(args: &[&str]) -> WorkflowArgs {
        Wrap::try_parse_from(std::iter::once("t").chain(args.iter().copied())).unwrap().w
    }

    #[test]
    fn flags_become_copies_and_stops_and_bad_values_are_named() {
        let w = parse(&["--copies", "0", "--page-delay", "2.5", "--no-paper-pause", "--split-distance", "400"]);
        assert_eq!(w.copies().unwrap(), Copies { count: 0, page_delay_s: 2.5, paper_pause: false });
        assert_eq!(w.split_mm().unwrap(), Some(400.0));
        let d = parse(&[]);
        assert_eq!(d.copies().unwrap(), Copies { count: 1, page_delay_s: 0.0, paper_pause: true });
        assert_eq!(d.split_mm().unwrap(), None);
        let e = parse(&["--page-delay=-1"]).copies().unwrap_err().to_string();
        assert!(e.starts_with("--page-delay -1: give a number of seconds"), "{e}");
        let e = parse(&["--split-distance", "0"]).split_mm().unwrap_err().to_string();
        assert!(e.starts_with("--split-distance 0: give the drawn length"), "{e}");
    }
}
