//! A queued job's layout and plot options: the flags `plotter plot` takes for the drawing (input, layout, path
//! order), stored in the job's options as the list of words the user gave (`{"args": ["--paper", "a5", "--fit"]}`)
//! and read back with the same flag definitions `plot` uses, so that a machine of the studio plots a job exactly
//! as `plotter plot FILE <the same flags>` would.
//!
//! The machine's own settings (its port, firmware, profile) belong to the machine, not to the job: a job names
//! only what is drawn and where it goes on the paper.

use plotter_path::MachineProfile;
use plotter_path::geometry::layout::Paper;

use super::error::{Result, StudioError};
use crate::input::InputArgs;
use crate::options::layout::LayoutArgs;
use crate::options::optimize::OptimizeArgs;
use crate::options::workflow::{Copies, WorkflowArgs};

/// The key of the flag list in a job's options.
pub const ARGS_KEY: &str = "args";

/// What a queued job's `--colors pens` says when the machine's profile has no pen with a colour: a job chooses its
/// machine, not the machine's profile (the studio's operator gives each machine its profile).
pub const PENS_FROM_STUDIO: &str = "queue the job for a machine whose profile has coloured pens (plotter queue add \
                                    --machine NAME; a machine's profile is the profile= of plotter serve --machine), \
                                    or with --colors cmyk";

/// The flags of a queued job.
#[derive(clap::Args, Debug, Clone)]
pub struct JobArgs {
    /// Input flags (tolerance, layers, hatching, text, images).
    #[command(flatten)]
    pub input: InputArgs,
    /// Layout flags (paper, orientation, margin, fit, centre, rotate, scale, translate).
    #[command(flatten)]
    pub layout: LayoutArgs,
    /// Path-order flags.
    #[command(flatten)]
    pub optimize: OptimizeArgs,
    /// Workflow flags, as `plotter plot` takes them: copies with a page delay and a paper change between them,
    /// refills after a drawn length, a webhook.
    #[command(flatten)]
    pub workflow: WorkflowArgs,
}

/// The flag words stored in `options` (none when it has no `args`); an error naming what is wrong otherwise.
pub fn words(options: &serde_json::Value) -> Result<Vec<String>> {
    let Some(args) = options.get(ARGS_KEY) else { return Ok(Vec::new()) };
    let list = args
        .as_array()
        .ok_or_else(|| StudioError::Invalid(format!("the job's \"{ARGS_KEY}\" must be a list of flag words")))?;
    list.iter()
        .map(|w| {
            w.as_str()
                .map(str::to_string)
                .ok_or_else(|| StudioError::Invalid(format!("the job's \"{ARGS_KEY}\" holds {w}, which is not a word")))
        })
        .collect()
}

impl JobArgs {
    /// The flags of a job's `options`, checked as `plotter plot` checks them.
    pub fn from_options(options: &serde_json::Value) -> Result<JobArgs> {
        let words = words(options)?;
        let refused = |e: clap::Error| {
            let text = e.render().to_string();
            let first = text.lines().next().unwrap_or("").trim_start_matches("error: ").to_string();
            StudioError::Invalid(format!("the job's flags {}: {first}", words.join(" ")))
        };
        let matches = JobArgs::command().try_get_matches_from(&words).map_err(refused)?;
        let mut args = <JobArgs as clap::FromArgMatches>::from_arg_matches(&matches).map_err(refused)?;
        args.input.pens_hint = PENS_FROM_STUDIO;
        args.split_mm()?;
        args.copies()?;
        if let Some(url) = &args.workflow.webhook {
            crate::job::webhook::check_url(url).map_err(|e| StudioError::Invalid(format!("the job's {e}")))?;
        }
        Ok(args)
    }

    /// The drawn length between refills (`--split-distance`), checked.
    pub fn split_mm(&self) -> Result<Option<f64>> {
        self.workflow.split_mm().map_err(|e| StudioError::Invalid(format!("the job's {e}")))
    }

    /// The copies (`--copies`, `--page-delay`, `--no-paper-pause`), checked.
    pub fn copies(&self) -> Result<Copies> {
        self.workflow.copies().map_err(|e| StudioError::Invalid(format!("the job's {e}")))
    }

    /// The flags' definitions, as a command of their own (no program name first, no help flag).
    pub fn command() -> clap::Command {
        <JobArgs as clap::Args>::augment_args(
            clap::Command::new("job").no_binary_name(true).disable_help_flag(true).disable_version_flag(true),
        )
    }

    /// The paper the job asks for, if any.
    pub fn paper(&self) -> Result<Option<Paper>> {
        self.layout
            .paper
            .as_deref()
            .map(|p| p.parse::<Paper>().map_err(|e| StudioError::Invalid(format!("the job's --paper: {e}"))))
            .transpose()
    }
}

/// Whether a job asking for `paper` (none: any) fits a machine with `profile` on which `loaded` (its `paper` in the
/// studio file, none: any) lies: the paper the machine holds must be the job's (same size, either way round), and
/// without one named the job's paper must lie within the machine's work area, turned if need be (0.5 mm spare).
pub fn paper_fits(paper: Option<Paper>, profile: &MachineProfile, loaded: Option<Paper>) -> bool {
    let Some(p) = paper else { return true };
    let same = |a: f64, b: f64| (a - b).abs() <= 0.5;
    if let Some(l) = loaded {
        return (same(p.width_mm, l.width_mm) && same(p.height_mm, l.height_mm))
            || (same(p.width_mm, l.height_mm) && same(p.height_mm, l.width_mm));
    }
    let area = profile.work_area();
    let (w, h) = (area.width() + 0.5, area.height() + 0.5);
    (p.width_mm <= w && p.height_mm <= h) || (p.height_mm <= w && p.width_mm <= h)
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    /// A job's `--colors pens` on a machine whose profile has no coloured pen is refused naming what the job can
    /// choose: its machine (`--machine`), or `--colors cmyk`; not `--model` or `--profile`, which `plotter queue
    /// add` does not take.
    #[test]
    fn colors_pens_on_a_machine_without_coloured_pens_names_the_jobs_choices() {
        let toml = plotter_path::config::profile::DEFAULT_PROFILE_TOML;
        let plain: Vec<&str> = toml.lines().filter(|l| !l.trim_start().starts_with("color =")).collect();
        let profile = MachineProfile::from_toml(&plain.join("\n"), "plain.toml").unwrap();
        let a = JobArgs::from_options(&json!({"args": ["--mode", "mosaic", "--colors", "pens"]})).unwrap();
        let photo = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../samples/photo.png");
        let e = crate::input::load_laid_out(&photo, &a.input, &profile, &a.layout).unwrap_err();
        let e = format!("{e:#}");
        assert!(e.contains("has no pen with a colour") && e.contains("queue add --machine"), "{e}");
        assert!(e.contains("--colors cmyk") && !e.contains("--model") && !e.contains("--profile"), "{e}");
    }

    #[test]
    fn stored_words_read_back_as_plot_reads_them() {
        let a = JobArgs::from_options(&json!({"args": ["--paper", "a5", "--fit", "--margin", "12", "--no-optimize"]}))
            .unwrap();
        assert_eq!(a.layout.paper.as_deref(), Some("a5"));
        assert!(a.layout.fit && a.optimize.no_optimize);
        assert!((a.layout.margin - 12.0).abs() < 1e-12);
        let none = JobArgs::from_options(&json!({})).unwrap();
        assert!(!none.layout.fit && none.layout.paper.is_none());
        let e = JobArgs::from_options(&json!({"args": ["--fit", "--bogus"]})).unwrap_err().to_string();
        assert!(e.contains("--bogus") && e.contains("the job's flags --fit --bogus"), "{e}");
        let e = JobArgs::from_options(&json!({"args": "--fit"})).unwrap_err().to_string();
        assert!(e.contains("must be a list"), "{e}");
        let e = JobArgs::from_options(&json!({"args": [3]})).unwrap_err().to_string();
        assert!(e.contains("holds 3"), "{e}");
        // The workflow flags, as `plotter plot` reads them: 0 copies is until stopped.
        let w = JobArgs::from_options(&json!({"args": ["--copies", "0", "--page-delay", "2.5", "--no-paper-pause"]}))
            .unwrap();
        assert_eq!(w.copies().unwrap(), Copies { count: 0, page_delay_s: 2.5, paper_pause: false });
        assert_eq!(none.copies().unwrap(), Copies { count: 1, page_delay_s: 0.0, paper_pause: true });
        let e = JobArgs::from_options(&json!({"args": ["--page-delay", "90000"]})).unwrap_err().to_string();
        assert!(e.starts_with("the job's --page-delay 90000: give a number of seconds from 0 to 86400"), "{e}");
        let e = JobArgs::from_options(&json!({"args": ["--copies", "-1"]})).unwrap_err().to_string();
        assert!(e.contains("the job's flags --copies -1") && e.contains("'-1'"), "{e}");
    }

    #[test]
    fn a_paper_fits_the_work_area_either_way_round_or_must_be_the_loaded_one() {
        // The default kit's work area, read from the profile.
        let profile = MachineProfile::default_plotter();
        let area = profile.work_area();
        let exact = Paper { width_mm: area.width(), height_mm: area.height() };
        let turned = Paper { width_mm: area.height(), height_mm: area.width() };
        let wider = Paper { width_mm: area.width() + 1.0, height_mm: 10.0 };
        assert!(paper_fits(None, &profile, None));
        assert!(paper_fits(Some(exact), &profile, None));
        assert!(paper_fits(Some(turned), &profile, None));
        assert!(!paper_fits(Some(wider), &profile, None));
        let a5: Paper = "a5".parse().unwrap();
        let a4: Paper = "a4".parse().unwrap();
        let a5_landscape = Paper { width_mm: 210.0, height_mm: 148.0 };
        assert!(paper_fits(Some(a5), &profile, Some(a5)));
        assert!(paper_fits(Some(a5_landscape), &profile, Some(a5)));
        assert!(!paper_fits(Some(a4), &profile, Some(a5)));
        assert!(paper_fits(None, &profile, Some(a5)));
    }
}
