//! Page-layout flags shared by every command that takes a drawing (`preview`, `stats`, `convert`, `plot`, ...).

use anyhow::{Result, bail};
use clap::{Args, ValueEnum};
use plotter_path::geometry::bed::Bed;
use plotter_path::geometry::layout::{self, LayoutOptions, Orientation, Paper};
use plotter_path::kurbo::{Point, Vec2};

/// Orientation as a command-line value.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum OrientationArg {
    /// Taller than wide.
    Portrait,
    /// Wider than tall.
    Landscape,
}

/// Layout flags. Applied in a fixed order: rotate, paper, scale or fit, centre, translate.
#[derive(Debug, Clone, Args, Default)]
pub struct LayoutArgs {
    /// Paper: a0-a6, b0-b6, letter, legal, tabloid, ledger, or WIDTHxHEIGHT with a unit: mm (the default), cm, in,
    /// or px at 96 per inch (e.g. 11x8.5in, 210x297mm, 30x20cm). Without --orientation, a plot turns the paper
    /// when the machine takes it only turned, and says so.
    #[arg(long, help_heading = "Layout")]
    pub paper: Option<String>,
    /// Paper orientation (named papers are portrait, ledger landscape)
    #[arg(long, value_enum, help_heading = "Layout")]
    pub orientation: Option<OrientationArg>,
    /// Shorthand for --orientation landscape
    #[arg(long, conflicts_with = "orientation", help_heading = "Layout")]
    pub landscape: bool,
    /// Margin on every side, mm (used by --fit and --center)
    #[arg(long, default_value_t = 10.0, help_heading = "Layout")]
    pub margin: f64,
    /// Scale to the largest size fitting inside the margins, keeping the aspect ratio (implies --center); a plot
    /// fits the drawing where the machine's pen reaches on the paper
    #[arg(long, help_heading = "Layout")]
    pub fit: bool,
    /// Centre the drawing on the page
    #[arg(long, help_heading = "Layout")]
    pub center: bool,
    /// Rotate by this many degrees, clockwise on the page as you see it, about the drawing's centre (or
    /// --origin); negative turns counter-clockwise (e.g. --rotate 90, --rotate -30). The page does not turn
    /// with the drawing.
    #[arg(
        long,
        default_value = "0",
        value_parser = parse_degrees,
        allow_negative_numbers = true,
        value_name = "DEGREES",
        help_heading = "Layout"
    )]
    pub rotate: f64,
    /// Scale by this factor about the drawing's centre (or --origin)
    #[arg(long, conflicts_with = "fit", help_heading = "Layout")]
    pub scale: Option<f64>,
    /// The point that --rotate and --scale turn and scale about, X,Y in mm from the page's top-left corner
    /// [default: the centre of the drawing]
    #[arg(long, value_parser = parse_origin, allow_hyphen_values = true, value_name = "X,Y", help_heading = "Layout")]
    pub origin: Option<Point>,
    /// Move by DX,DY mm after everything else (e.g. --translate 10,-5)
    #[arg(long, value_parser = parse_offset, allow_hyphen_values = true, help_heading = "Layout")]
    pub translate: Option<Vec2>,
    /// The machine the page is laid out for (the command sets it; not a flag).
    #[arg(skip)]
    pub bed: Option<Bed>,
}

/// Units `--rotate` may carry.
const DEGREE_UNITS: [&str; 2] = ["deg", "°"];

/// `--rotate`: degrees, optionally written with `deg` or `°`.
fn parse_degrees(s: &str) -> Result<f64, String> {
    let t = s.trim();
    let number = DEGREE_UNITS.iter().find_map(|u| t.strip_suffix(u)).unwrap_or(t);
    match number.trim().parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(format!("'{s}' is not a number of degrees (e.g. 90, -30 or 12.5)")),
    }
}

fn pair(s: &str, what: &str, flag: &str) -> Result<(f64, f64), String> {
    let (x, y) = s.split_once(',').ok_or_else(|| format!("expected {what} in mm, got '{s}'"))?;
    let num = |v: &str| {
        v.trim().parse::<f64>().ok().filter(|v| v.is_finite()).ok_or(format!("'{v}' is not a number in {flag} {s}"))
    };
    Ok((num(x)?, num(y)?))
}

fn parse_offset(s: &str) -> Result<Vec2, String> {
    pair(s, "DX,DY", "--translate").map(|(x, y)| Vec2::new(x, y))
}

fn parse_origin(s: &str) -> Result<Point, String> {
    pair(s, "X,Y", "--origin").map(|(x, y)| Point::new(x, y))
}

impl LayoutArgs {
    /// The library options these flags mean.
    pub fn options(&self) -> Result<LayoutOptions> {
        let paper = self.paper.as_deref().map(str::parse::<Paper>).transpose()?;
        let orientation = if self.landscape {
            Some(Orientation::Landscape)
        } else {
            self.orientation.map(|o| match o {
                OrientationArg::Portrait => Orientation::Portrait,
                OrientationArg::Landscape => Orientation::Landscape,
            })
        };
        Ok(LayoutOptions {
            paper,
            orientation,
            margin_mm: self.margin,
            fit: self.fit,
            center: self.center,
            rotate_deg: self.rotate,
            scale: self.scale,
            origin: self.origin,
            translate: self.translate.unwrap_or(Vec2::ZERO),
            bed: self.bed.clone(),
        })
    }

    /// These flags laid out for `bed`: the paper turned when the machine takes it only turned (see
    /// [`layout::settle_on_bed`]), and the line that says so (or that a fit uses only part of the paper).
    pub fn on_bed(&self, bed: Bed) -> Result<(LayoutArgs, Option<String>)> {
        let mut laid = LayoutArgs { bed: Some(bed), ..self.clone() };
        let settled = layout::settle_on_bed(&laid.options()?)?;
        if let Some(o) = settled.turned {
            laid.landscape = false;
            laid.orientation = Some(match o {
                Orientation::Portrait => OrientationArg::Portrait,
                Orientation::Landscape => OrientationArg::Landscape,
            });
        }
        Ok((laid, settled.note))
    }

    /// Lay `drawing` out in place; returns the scale factor applied (1 when none, see [`layout::apply`]).
    pub fn apply(&self, drawing: &mut plotter_path::Drawing) -> Result<f64> {
        Ok(layout::apply(drawing, &self.options()?)?)
    }
}

// `--rotate` counted quarter turns before it took degrees. A plot journal stores the `plot` arguments as typed and
// `plot --resume` parses them again, so an interrupted plot recorded with `--rotate 1` would now be rebuilt with a
// 1° turn. That old meaning is not kept reachable: the quarter turn also turned the page with the drawing, so
// rebuilding such a plot would mean keeping the old layout alive for resuming alone, and the journal's plan check
// would refuse the rebuilt plan anyway, blaming a changed input. Instead a journal records `--rotate` with its
// unit (`--rotate=90deg`), and a resume refuses a journal whose `--rotate` has none, saying why and what to type.

/// Where `args` gives `--rotate`: (index of the argument, its value).
fn rotate_values(args: &[String]) -> Vec<(usize, &str)> {
    let mut found = Vec::new();
    let mut i = 0;
    while i < args.len() {
        let a = args[i].as_str();
        if a == "--" {
            break;
        }
        if let Some(v) = a.strip_prefix("--rotate=") {
            found.push((i, v));
        } else if a == "--rotate"
            && let Some(v) = args.get(i + 1)
        {
            found.push((i, v.as_str()));
            i += 1;
        }
        i += 1;
    }
    found
}

/// The `plot` arguments as a journal records them: every `--rotate` written with its unit (`--rotate=30deg`),
/// so that a resume tells them from a journal written when `--rotate` counted quarter turns.
pub fn journal_args(args: impl IntoIterator<Item = String>) -> Vec<String> {
    let mut args: Vec<String> = args.into_iter().collect();
    let found: Vec<(usize, String)> = rotate_values(&args).into_iter().map(|(i, v)| (i, v.to_string())).collect();
    for (i, v) in found.into_iter().rev() {
        let degrees = parse_degrees(&v).map_or(v, |d| format!("{d}deg"));
        if args[i] == "--rotate" {
            args.remove(i + 1);
        }
        args[i] = format!("--rotate={degrees}");
    }
    args
}

/// Refuse `plot` arguments a journal recorded when `--rotate` counted quarter turns (a value without a unit,
/// other than 0, which meant no turn then and now).
pub fn refuse_quarter_turns(args: &[String]) -> Result<()> {
    for (_, v) in rotate_values(args) {
        let unit = DEGREE_UNITS.iter().any(|u| v.trim().ends_with(u));
        if !unit && parse_degrees(v).is_ok_and(|d| d != 0.0) {
            let turns = parse_degrees(v).unwrap_or(0.0);
            bail!(
                "this plot was recorded with --rotate {v}, when --rotate counted quarter turns; it now takes degrees, \
                 so the plot cannot be rebuilt as it was: start it again, with --rotate {} for the same turn",
                turns * 90.0
            );
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Wrap {
        #[command(flatten)]
        layout: LayoutArgs,
    }

    fn parse(args: &[&str]) -> Result<LayoutArgs, clap::Error> {
        Wrap::try_parse_from(std::iter::once("t").chain(args.iter().copied())).map(|w| w.layout)
    }

    #[test]
    fn rotate_takes_degrees_and_origin_a_point() {
        assert_eq!(parse(&["--rotate", "30"]).unwrap().rotate, 30.0);
        assert_eq!(parse(&["--rotate", "-12.5"]).unwrap().rotate, -12.5);
        assert_eq!(parse(&["--rotate=90deg"]).unwrap().rotate, 90.0);
        assert_eq!(parse(&["--rotate", "45°"]).unwrap().rotate, 45.0);
        assert_eq!(parse(&[]).unwrap().rotate, 0.0);
        let e = parse(&["--rotate", "1q"]).unwrap_err().to_string();
        assert!(e.contains("'1q' is not a number of degrees"), "{e}");
        let o = parse(&["--origin", "10,-5", "--scale", "2"]).unwrap();
        assert_eq!((o.origin, o.scale), (Some(Point::new(10.0, -5.0)), Some(2.0)));
        let opts = o.options().unwrap();
        assert_eq!((opts.origin, opts.scale, opts.rotate_deg), (Some(Point::new(10.0, -5.0)), Some(2.0), 0.0));
        assert!(parse(&["--origin", "10"]).unwrap_err().to_string().contains("expected X,Y in mm"));
    }

    /// A 300 × 218 mm work area takes A4 only as landscape: the flags come back with the orientation set, and
    /// the line saying so; with --landscape given there is nothing to say.
    #[test]
    fn on_a_bed_the_paper_turns_when_it_must() {
        let mut profile = plotter_path::MachineProfile::default_plotter();
        profile.name = "AxiDraw V3".into();
        (profile.axes.x.travel_mm, profile.axes.y.travel_mm) = (300.0, 218.0);
        let bed = Bed::work_area(&profile);
        let (laid, note) = parse(&["--paper", "a4", "--fit"]).unwrap().on_bed(bed.clone()).unwrap();
        assert_eq!(laid.orientation, Some(OrientationArg::Landscape));
        assert_eq!(laid.options().unwrap().bed, Some(bed.clone()));
        assert!(note.unwrap().ends_with("; turned to landscape"));
        let (laid, note) = parse(&["--paper", "a4", "--landscape"]).unwrap().on_bed(bed).unwrap();
        assert_eq!((laid.landscape, note), (true, None));
    }

    /// A journal records `--rotate` with its unit; one recorded when the value counted quarter turns (no unit)
    /// is refused naming the same turn in degrees, and 0 (no turn, then and now) passes.
    #[test]
    fn journals_tell_degrees_from_quarter_turns() {
        let owned = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        let recorded = journal_args(owned(&["in.svg", "--rotate", "-30", "--paper", "a4"]));
        assert_eq!(recorded, owned(&["in.svg", "--rotate=-30deg", "--paper", "a4"]));
        assert_eq!(journal_args(owned(&["--rotate=90", "--fit"])), owned(&["--rotate=90deg", "--fit"]));
        refuse_quarter_turns(&recorded).unwrap();
        let w = Wrap::try_parse_from(std::iter::once("t".to_string()).chain(recorded.into_iter().skip(1))).unwrap();
        assert_eq!(w.layout.rotate, -30.0);
        let old = owned(&["in.svg", "--rotate", "1", "--port", "/dev/x"]);
        let e = refuse_quarter_turns(&old).unwrap_err().to_string();
        assert!(e.contains("recorded with --rotate 1, when --rotate counted quarter turns"), "{e}");
        assert!(e.contains("--rotate 90 for the same turn"), "{e}");
        refuse_quarter_turns(&owned(&["in.svg", "--rotate", "0"])).unwrap();
        refuse_quarter_turns(&owned(&["in.svg", "--", "--rotate", "1"])).unwrap();
    }
}
