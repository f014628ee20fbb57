//! Page layout: paper size and orientation, margins, fit-to-page, centring, rotation by any angle, scale and
//! translation, and the page meeting the machine: the paper against the machine's bed (turned when it lies there
//! only turned), the fit into what the pen reaches, and the check that the laid-out drawing lies within reach.
//!
//! Operations apply in a fixed order, so a command line means the same thing whatever order its flags come in:
//! 1. **rotate** by any angle in degrees, clockwise on the page as seen (the page runs Y down, so a positive angle
//!    in the usual rotation formula turns clockwise), about the drawing's bounding-box centre or `origin`; the page
//!    stays as it is (as vpype's `rotate` does);
//! 2. **paper**: the page becomes the chosen paper (oriented), geometry stays where it is;
//! 3. **scale** by an explicit factor about the drawing's bounding-box centre or `origin`, or **fit**: the largest
//!    uniform scale that puts the bounding box inside the drawable area (fit implies centring);
//! 4. **centre** the bounding box on the drawable area;
//! 5. **translate** by a fixed offset.
//!
//! The drawable area is the page minus the margins; with a machine's [`Bed`] it is that area within the part of
//! the page the pen reaches (an HP-GL sheet's plotting area, or a work area smaller than the paper). Before any
//! of this, [`settle_on_bed`] turns a paper whose orientation was not given when the bed takes it only turned.

use std::fmt;
use std::str::FromStr;

use kurbo::{Affine, Point, Rect, Vec2};

use crate::config::profile::MachineProfile;
use crate::geometry::bed::{self, Bed, Placement, SheetFit, mm};
use crate::geometry::drawing::Drawing;
use crate::geometry::limits::MAX_COORD_MM;

/// The paper names `--paper` accepts, for messages.
const PAPER_NAMES: &str = "a0-a6, b0-b6, letter, legal, tabloid, ledger";

/// Layout errors.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LayoutError {
    /// A paper name that is neither known nor `WxH` with a unit.
    #[error(
        "unknown paper size '{0}': use {PAPER_NAMES}, or WIDTHxHEIGHT with a unit: mm (the default), cm, in or px \
         at 96 px/in (e.g. 210x297mm, 11x8.5in, 30x20cm)"
    )]
    Paper(String),
    /// The margins leave no room.
    #[error("margin {margin_mm} mm leaves no drawable area on a {width_mm} × {height_mm} mm page")]
    Margin {
        /// The margin.
        margin_mm: f64,
        /// Page width.
        width_mm: f64,
        /// Page height.
        height_mm: f64,
    },
    /// A scale that is zero, negative or not a number.
    #[error("scale must be a positive number, got {0}")]
    Scale(f64),
    /// A rotation that is not a number.
    #[error("rotation must be a number of degrees, got {0}")]
    Rotate(f64),
    /// Fit or centre needs a page, and the drawing has none.
    #[error("--fit and --center need a page size: give --paper")]
    NoPage,
    /// The drawing is empty; there is nothing to lay out.
    #[error("the drawing has no paths to lay out")]
    Empty,
    /// A paper larger than any plotter's reach.
    #[error("paper {width_mm:.3e} × {height_mm:.3e} mm is beyond the {max} mm (1 km) limit; give the size in mm", max = MAX_COORD_MM)]
    PaperTooLarge {
        /// Width, mm.
        width_mm: f64,
        /// Height, mm.
        height_mm: f64,
    },
    /// The layout (fit, scale, translate, rotate) moved the drawing beyond ±1 km: nothing of it could be drawn.
    #[error(
        "{step} puts the drawing at x {x0:.3e}..{x1:.3e} mm, y {y0:.3e}..{y1:.3e} mm, beyond ±{max} mm (1 km): \
         nothing of it could be drawn; check --paper, --scale and --translate", max = MAX_COORD_MM
    )]
    BeyondReach {
        /// The layout step that did it.
        step: &'static str,
        /// Extent, mm.
        x0: f64,
        /// Extent, mm.
        x1: f64,
        /// Extent, mm.
        y0: f64,
        /// Extent, mm.
        y1: f64,
    },
    /// The laid-out drawing leaves the machine's reach.
    #[error(
        "drawing spans x {x0:.2}..{x1:.2} mm, y {y0:.2}..{y1:.2} mm on the machine, outside the work area \
         0..{w:.2} × 0..{h:.2} mm of profile '{profile}'; use --fit, a smaller --scale or --translate"
    )]
    OutsideWorkArea {
        /// Machine-space extent.
        x0: f64,
        /// Machine-space extent.
        x1: f64,
        /// Machine-space extent.
        y0: f64,
        /// Machine-space extent.
        y1: f64,
        /// Work-area width.
        w: f64,
        /// Work-area height.
        h: f64,
        /// Profile name.
        profile: String,
    },
    /// The machine cannot take the paper (an HP-GL plotter loads only its own sheets).
    #[error("{paper} does not fit {bed}; use {fix}")]
    PaperOffBed {
        /// The paper, described ("A2 portrait (420 × 594 mm)").
        paper: String,
        /// The machine's bed, described.
        bed: String,
        /// What to do instead.
        fix: String,
    },
    /// The laid-out drawing reaches beyond what the machine's pen reaches.
    #[error("{paper_note}the drawing (x {x0}..{x1}, y {y0}..{y1} mm on the page) reaches beyond {reach}; use {fix}",
        x0 = mm(*x0), x1 = mm(*x1), y0 = mm(*y0), y1 = mm(*y1))]
    OutsideReach {
        /// "A4 portrait (210 × 297 mm) does not fit …, and " when the paper is part of the trouble, else empty.
        paper_note: String,
        /// Page extent of the drawing, mm.
        x0: f64,
        /// Page extent of the drawing, mm.
        x1: f64,
        /// Page extent of the drawing, mm.
        y0: f64,
        /// Page extent of the drawing, mm.
        y1: f64,
        /// What the pen reaches, described.
        reach: String,
        /// What to do instead.
        fix: String,
    },
    /// With the margins, nothing of the paper lies where the pen reaches.
    #[error("with a {margin} mm margin, nothing of {paper} lies within {reach}; use {fix}", margin = mm(*margin_mm))]
    NoRoom {
        /// The margin, mm.
        margin_mm: f64,
        /// The paper, described.
        paper: String,
        /// What the pen reaches, described.
        reach: String,
        /// What to do instead.
        fix: String,
    },
}

/// A paper size in millimetres. The named sizes are portrait (width ≤ height), except ledger (tabloid turned).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Paper {
    /// Width, mm.
    pub width_mm: f64,
    /// Height, mm.
    pub height_mm: f64,
}

const fn paper(width_mm: f64, height_mm: f64) -> Paper {
    Paper { width_mm, height_mm }
}

/// The named papers: ISO 216 A and B series (mm), and the US sizes (inches × 25.4).
const NAMED: &[(&str, Paper)] = &[
    ("a0", paper(841.0, 1189.0)),
    ("a1", paper(594.0, 841.0)),
    ("a2", paper(420.0, 594.0)),
    ("a3", paper(297.0, 420.0)),
    ("a4", paper(210.0, 297.0)),
    ("a5", paper(148.0, 210.0)),
    ("a6", paper(105.0, 148.0)),
    ("b0", paper(1000.0, 1414.0)),
    ("b1", paper(707.0, 1000.0)),
    ("b2", paper(500.0, 707.0)),
    ("b3", paper(353.0, 500.0)),
    ("b4", paper(250.0, 353.0)),
    ("b5", paper(176.0, 250.0)),
    ("b6", paper(125.0, 176.0)),
    ("letter", paper(215.9, 279.4)),  // 8.5 × 11 in
    ("legal", paper(215.9, 355.6)),   // 8.5 × 14 in
    ("tabloid", paper(279.4, 431.8)), // 11 × 17 in
    ("ledger", paper(431.8, 279.4)),  // 17 × 11 in: tabloid, landscape by name
];

/// Millimetres per unit a paper size may be given in (`px` at 96 per inch, as in CSS and SVG).
const UNITS: &[(&str, f64)] = &[("mm", 1.0), ("cm", 10.0), ("in", 25.4), ("px", 25.4 / 96.0)];

impl Paper {
    /// ISO A3.
    pub const A3: Paper = paper(297.0, 420.0);
    /// ISO A4.
    pub const A4: Paper = paper(210.0, 297.0);
    /// ISO A5.
    pub const A5: Paper = paper(148.0, 210.0);
    /// US Letter.
    pub const LETTER: Paper = paper(215.9, 279.4);

    /// This paper turned to `orientation` (named sizes are portrait; a custom size keeps its given shape unless an
    /// orientation is requested).
    pub fn oriented(self, orientation: Orientation) -> Paper {
        let (short, long) = (self.width_mm.min(self.height_mm), self.width_mm.max(self.height_mm));
        match orientation {
            Orientation::Portrait => Paper { width_mm: short, height_mm: long },
            Orientation::Landscape => Paper { width_mm: long, height_mm: short },
        }
    }

    /// This paper turned a quarter (width and height swapped).
    pub fn turned(self) -> Paper {
        Paper { width_mm: self.height_mm, height_mm: self.width_mm }
    }

    /// The paper for messages: "A4 portrait (210 × 297 mm)", "Letter landscape (279.4 × 215.9 mm)",
    /// "paper 300 × 200 mm".
    pub fn describe(self) -> String {
        let size = format!("{} × {} mm", mm(self.width_mm), mm(self.height_mm));
        let same = |p: &Paper| (p.width_mm - self.width_mm).abs() < 0.05 && (p.height_mm - self.height_mm).abs() < 0.05;
        let name = NAMED.iter().find(|(_, p)| same(p)).or_else(|| NAMED.iter().find(|(_, p)| same(&p.turned())));
        let Some((name, _)) = name else { return format!("paper {size}") };
        let shown = if name.len() == 2 {
            name.to_ascii_uppercase()
        } else {
            format!("{}{}", &name[..1].to_ascii_uppercase(), &name[1..])
        };
        let shape = if self.width_mm < self.height_mm {
            " portrait"
        } else if self.width_mm > self.height_mm {
            " landscape"
        } else {
            ""
        };
        format!("{shown}{shape} ({size})")
    }

    /// The name of the largest named paper (by area) for which `fits` holds, if any.
    pub fn largest_named(mut fits: impl FnMut(Paper) -> bool) -> Option<&'static str> {
        NAMED
            .iter()
            .filter(|(_, p)| fits(*p))
            .max_by(|(_, a), (_, b)| (a.width_mm * a.height_mm).total_cmp(&(b.width_mm * b.height_mm)))
            .map(|(n, _)| *n)
    }
}

/// A size like `11x8.5in`, `210x297mm`, `30x20cm`, `1123x794px`, `300x200` (mm), `5inx20cm` (each side its own
/// unit); the unit written once at the end applies to both sides.
fn parse_size(s: &str) -> Option<(f64, f64)> {
    // The separator is an `x` (or `×`) followed by a digit or a decimal point (spaces allowed): `10pxx20px` splits
    // after `10px`.
    let (i, sep) = s.char_indices().find(|&(i, c)| {
        (c == 'x' || c == '×')
            && i > 0
            && s[i + c.len_utf8()..].trim_start().starts_with(|d: char| d.is_ascii_digit() || d == '.')
    })?;
    let (a, b) = (&s[..i], &s[i + sep.len_utf8()..]);
    let number_unit = |v: &str| -> Option<(f64, Option<f64>)> {
        let v = v.trim();
        let (num, unit) = UNITS.iter().find_map(|(u, f)| v.strip_suffix(u).map(|n| (n, Some(*f)))).unwrap_or((v, None));
        let n = num.trim().parse::<f64>().ok().filter(|n| n.is_finite() && *n > 0.0)?;
        Some((n, unit))
    };
    let (bv, bu) = number_unit(b)?;
    let (av, au) = number_unit(a)?;
    Some((av * au.or(bu).unwrap_or(1.0), bv * bu.unwrap_or(1.0)))
}

impl FromStr for Paper {
    type Err = LayoutError;
    fn from_str(s: &str) -> Result<Self, LayoutError> {
        let lower = s.trim().to_ascii_lowercase();
        if let Some((_, p)) = NAMED.iter().find(|(n, _)| *n == lower) {
            return Ok(*p);
        }
        match parse_size(&lower) {
            Some((width_mm, height_mm)) if width_mm > MAX_COORD_MM || height_mm > MAX_COORD_MM => {
                Err(LayoutError::PaperTooLarge { width_mm, height_mm })
            }
            Some((width_mm, height_mm)) => Ok(Paper { width_mm, height_mm }),
            None => Err(LayoutError::Paper(s.to_string())),
        }
    }
}

/// Page orientation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Orientation {
    /// Taller than wide.
    Portrait,
    /// Wider than tall.
    Landscape,
}

impl Orientation {
    /// The flag that asks for this orientation.
    pub fn flag(self) -> &'static str {
        match self {
            Orientation::Portrait => "--orientation portrait",
            Orientation::Landscape => "--landscape",
        }
    }

    /// The orientation of a `width` × `height` page (a square one counts as portrait).
    pub fn of(width: f64, height: f64) -> Orientation {
        if width > height { Orientation::Landscape } else { Orientation::Portrait }
    }
}

impl fmt::Display for Orientation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Orientation::Portrait => "portrait",
            Orientation::Landscape => "landscape",
        })
    }
}

/// Everything the layout step can do; the default changes nothing.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LayoutOptions {
    /// Paper to lay out on (replaces the drawing's own page size).
    pub paper: Option<Paper>,
    /// Orientation of the paper (named sizes default to portrait; custom sizes keep their shape).
    pub orientation: Option<Orientation>,
    /// Margin on every side, mm (used by fit and centre).
    pub margin_mm: f64,
    /// Scale to the largest size that fits inside the drawable area, keeping the aspect ratio; implies centring.
    pub fit: bool,
    /// Centre the drawing on the drawable area.
    pub center: bool,
    /// Rotation in degrees, clockwise on the page as seen, about the drawing's centre (or `origin`).
    pub rotate_deg: f64,
    /// Explicit scale factor about the drawing's centre (or `origin`; ignored with `fit`).
    pub scale: Option<f64>,
    /// The page point (mm) to rotate and scale about instead of the drawing's bounding-box centre.
    pub origin: Option<Point>,
    /// Final offset, mm.
    pub translate: Vec2,
    /// The machine the page is laid out for: fit within what its pen reaches, and check the drawing lies there.
    pub bed: Option<Bed>,
}

impl LayoutOptions {
    /// True when applying these options changes nothing (the machine check aside; the margin only matters to fit
    /// and centre, so the command line's default 10 mm alone changes nothing either).
    pub fn is_identity(&self) -> bool {
        LayoutOptions { bed: None, margin_mm: 0.0, ..self.clone() } == LayoutOptions::default()
    }

    /// Whether the layout places the page on the machine's bed: a paper is given, or the drawing is fitted or
    /// centred on its page (else the drawing keeps its own coordinates and an HP-GL export picks the sheet).
    pub fn places_page(&self) -> bool {
        self.paper.is_some() || self.fit || self.center
    }
}

/// How [`settle_on_bed`] placed the paper.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Settled {
    /// The orientation the paper was turned to, when the bed takes it only turned.
    pub turned: Option<Orientation>,
    /// A line for the user: the turn, or that the fit uses only the part of the paper the pen reaches.
    pub note: Option<String>,
}

/// Settle the paper on the machine's bed before the layout: when no orientation was given and the paper lies on
/// the bed only turned (or, on an HP-GL plotter, is one of its sheets only turned), turn it and say so. An HP-GL
/// plotter that takes the paper neither way is an error naming the papers it takes; a work area the paper
/// overhangs is not (the pen draws on the part it reaches), but a fit or centring there says so.
pub fn settle_on_bed(options: &LayoutOptions) -> Result<Settled, LayoutError> {
    let (Some(bed), Some(given)) = (&options.bed, options.paper) else { return Ok(Settled::default()) };
    let as_is = options.orientation.map_or(given, |o| given.oriented(o));
    let here = bed.place(as_is.width_mm, as_is.height_mm);
    let turned = as_is.turned();
    let there = bed.place(turned.width_mm, turned.height_mm);
    if options.orientation.is_none() && there.fit > here.fit {
        let to = Orientation::of(turned.width_mm, turned.height_mm);
        let note = if here.fit == SheetFit::No {
            format!("{} does not fit {}; turned to {to}", as_is.describe(), here.place)
        } else {
            format!("{} goes on {} only turned; turned to {to}", as_is.describe(), there.place)
        };
        return Ok(Settled { turned: Some(to), note: Some(note) });
    }
    if here.fit == SheetFit::No {
        if bed.paper_must_fit() {
            return Err(LayoutError::PaperOffBed {
                paper: as_is.describe(),
                bed: bed.name(),
                fix: match paper_fixes(options, as_is, bed, false) {
                    f if f.is_empty() => "a smaller --paper".into(),
                    f => join_or(&f),
                },
            });
        }
        if options.fit || options.center {
            let r = here.reach.intersect(Rect::new(0.0, 0.0, as_is.width_mm, as_is.height_mm));
            let better = match paper_fixes(options, as_is, bed, false) {
                f if f.is_empty() => String::new(),
                f => format!(" (or use {})", join_or(&f)),
            };
            return Ok(Settled {
                turned: None,
                note: Some(format!(
                    "only {} × {} mm of {} lies in {}: the drawing is {} there{better}",
                    mm(r.width().max(0.0)),
                    mm(r.height().max(0.0)),
                    as_is.describe(),
                    here.place,
                    if options.fit { "fitted" } else { "centred" }
                )),
            });
        }
    }
    Ok(Settled::default())
}

/// What to use instead of a paper the bed does not take (as it lies): the other orientation when one was given
/// and the bed takes the paper turned, and the largest named paper the bed takes (in the given orientation, or
/// either way when none was given), each with `--fit` in front when `with_fit` (the drawing must move too).
fn paper_fixes(options: &LayoutOptions, paper: Paper, bed: &Bed, with_fit: bool) -> Vec<String> {
    let takes = |p: Paper| bed.place(p.width_mm, p.height_mm).fit > SheetFit::No;
    let mut fixes = Vec::new();
    let turned = paper.turned();
    if options.orientation.is_some() && takes(turned) {
        fixes.push(Orientation::of(turned.width_mm, turned.height_mm).flag().to_string());
    }
    let smaller = Paper::largest_named(|p| match options.orientation {
        Some(o) => takes(p.oriented(o)),
        None => takes(p) || takes(p.turned()),
    });
    if let Some(name) = smaller {
        fixes.push(format!("--paper {name}"));
    }
    if with_fit {
        fixes = fixes.into_iter().map(|f| format!("--fit {f}")).collect();
    }
    fixes
}

/// "a", "a or b", "a, b, or c".
fn join_or(items: &[String]) -> String {
    match items {
        [] => String::new(),
        [one] => one.clone(),
        [a, b] => format!("{a}, or {b}"),
        [rest @ .., last] => format!("{}, or {last}", rest.join(", ")),
    }
}

/// The sine and cosine of `deg` degrees, exact for whole quarter turns (so 90° maps equal points to equal points
/// without a 6e-17 residue).
fn sin_cos_deg(deg: f64) -> (f64, f64) {
    let d = deg.rem_euclid(360.0);
    match d {
        0.0 => (0.0, 1.0),
        90.0 => (1.0, 0.0),
        180.0 => (0.0, -1.0),
        270.0 => (-1.0, 0.0),
        _ => d.to_radians().sin_cos(),
    }
}

/// Lay out `drawing` in place according to `options`. Returns the scale factor applied (`--scale`, or the one
/// `--fit` chose; 1 when neither), so that an importer can flatten curves finer when the layout magnifies them.
/// With a machine's bed in the options, the drawable area is the page minus the margins within what the pen
/// reaches, and a drawing laid out beyond that reach is an error naming the fix.
pub fn apply(drawing: &mut Drawing, options: &LayoutOptions) -> Result<f64, LayoutError> {
    if let Some(s) = options.scale
        && !(s.is_finite() && s > 0.0)
    {
        return Err(LayoutError::Scale(s));
    }
    if !options.rotate_deg.is_finite() {
        return Err(LayoutError::Rotate(options.rotate_deg));
    }
    // 1. rotate about the drawing's centre (or the origin), clockwise as seen on the Y-down page
    if options.rotate_deg.rem_euclid(360.0) != 0.0
        && let Some(b) = drawing.bbox()
    {
        let about = options.origin.unwrap_or_else(|| b.center()).to_vec2();
        let (s, c) = sin_cos_deg(options.rotate_deg);
        let turn = Affine::translate(about) * Affine::new([c, s, -s, c, 0.0, 0.0]) * Affine::translate(-about);
        drawing.map_points(|p| turn * p);
        within_reach(drawing, "--rotate")?;
    }
    // 2. paper
    if let Some(paper) = options.paper {
        if !(paper.width_mm <= MAX_COORD_MM && paper.height_mm <= MAX_COORD_MM) {
            return Err(LayoutError::PaperTooLarge { width_mm: paper.width_mm, height_mm: paper.height_mm });
        }
        let paper = match options.orientation {
            Some(o) => paper.oriented(o),
            None => paper,
        };
        drawing.page_mm = Some((paper.width_mm, paper.height_mm));
    } else if let (Some(o), Some((w, h))) = (options.orientation, drawing.page_mm) {
        let p = Paper { width_mm: w, height_mm: h }.oriented(o);
        drawing.page_mm = Some((p.width_mm, p.height_mm));
    }
    // The page on the machine: what its pen reaches there.
    let placement = placement(drawing, options);
    if let (Some(p), Some(bed), Some((w, h))) = (&placement, &options.bed, drawing.page_mm)
        && p.fit == SheetFit::No
        && bed.paper_must_fit()
    {
        let paper = Paper { width_mm: w, height_mm: h };
        let fix = paper_fixes(options, paper, bed, false);
        return Err(LayoutError::PaperOffBed {
            paper: paper.describe(),
            bed: bed.name(),
            fix: if fix.is_empty() { "a smaller --paper".into() } else { join_or(&fix) },
        });
    }
    let needs_page = options.fit || options.center;
    if !needs_page && options.scale.is_none() && options.translate == Vec2::ZERO {
        check_reach(drawing, options, placement.as_ref())?;
        return Ok(1.0);
    }
    let bbox = drawing.bbox().ok_or(LayoutError::Empty)?;
    let area = if needs_page { Some(drawable(drawing, options, placement.as_ref())?) } else { None };
    // 3. scale about the drawing's centre (or the origin), or fit
    let factor = match area {
        Some(area) if options.fit => {
            let sx = if bbox.width() > 0.0 { area.width() / bbox.width() } else { f64::INFINITY };
            let sy = if bbox.height() > 0.0 { area.height() / bbox.height() } else { f64::INFINITY };
            Some(sx.min(sy)).filter(|s| s.is_finite())
        }
        _ => options.scale,
    };
    if let Some(s) = factor {
        // A fit is centred next, so where it scales about does not matter.
        let about = options.origin.filter(|_| !options.fit).unwrap_or_else(|| bbox.center());
        drawing.map_points(|p| about + (p - about) * s);
        if !needs_page {
            within_reach(drawing, "--scale")?;
        }
    }
    // 4. centre
    if let Some(area) = area {
        let bbox = drawing.bbox().ok_or(LayoutError::Empty)?;
        let shift = area.center() - bbox.center();
        drawing.map_points(|p| p + shift);
        let step = match (options.fit, options.scale) {
            (true, _) => "--fit",
            (false, Some(_)) => "--scale",
            (false, None) => "--center",
        };
        within_reach(drawing, step)?;
    }
    // 5. translate
    if options.translate != Vec2::ZERO {
        let t = options.translate;
        drawing.map_points(|p| p + t);
        within_reach(drawing, "--translate")?;
    }
    check_reach(drawing, options, placement.as_ref())?;
    Ok(factor.unwrap_or(1.0))
}

/// Where the page lies on the machine, when the options name one: a work area always (a drawing without a page
/// is checked against it as it stands), an HP-GL sheet when the layout places the page (else the export picks
/// the sheet that holds the drawing).
fn placement(drawing: &Drawing, options: &LayoutOptions) -> Option<Placement> {
    let bed = options.bed.as_ref()?;
    match (bed, drawing.page_mm) {
        (Bed::WorkArea { .. }, page) => {
            let (w, h) = page.unwrap_or((0.0, 0.0));
            Some(bed.place(w, h))
        }
        (Bed::Hpgl { .. }, Some((w, h))) if options.places_page() => Some(bed.place(w, h)),
        _ => None,
    }
}

/// The area fit and centre use: the page minus the margins, within what the pen reaches.
fn drawable(drawing: &Drawing, options: &LayoutOptions, placement: Option<&Placement>) -> Result<Rect, LayoutError> {
    let area = drawable_area(drawing, options.margin_mm)?;
    let Some(p) = placement else { return Ok(area) };
    let r = area.intersect(p.reach);
    if r.width() > 0.0 && r.height() > 0.0 {
        return Ok(r);
    }
    let (w, h) = drawing.page_mm.unwrap_or((0.0, 0.0));
    let paper = Paper { width_mm: w, height_mm: h };
    let mut fix = vec!["a smaller --margin".to_string()];
    if let Some(bed) = &options.bed {
        fix.extend(paper_fixes(options, paper, bed, false));
    }
    Err(LayoutError::NoRoom {
        margin_mm: options.margin_mm,
        paper: paper.describe(),
        reach: p.reach_name.clone(),
        fix: join_or(&fix),
    })
}

/// Refuse a drawing laid out beyond what the machine's pen reaches, naming the fix.
fn check_reach(drawing: &Drawing, options: &LayoutOptions, placement: Option<&Placement>) -> Result<(), LayoutError> {
    let (Some(p), Some(bed), Some(b)) = (placement, &options.bed, drawing.bbox()) else { return Ok(()) };
    if bed::contains(p.reach, b) {
        return Ok(());
    }
    let off_bed = drawing.page_mm.map(|(w, h)| Paper { width_mm: w, height_mm: h }).filter(|_| p.fit == SheetFit::No);
    let r = p.reach;
    let extent = format!("(x {}..{}, y {}..{} mm)", mm(r.x0), mm(r.x1), mm(r.y0), mm(r.y1));
    let (paper_note, reach) = match off_bed {
        Some(paper) => (format!("{} does not fit {}, and ", paper.describe(), p.place), format!("it {extent}")),
        None => (String::new(), format!("{} {extent}", p.reach_name)),
    };
    let mut fix = Vec::new();
    if let Some(paper) = off_bed {
        fix.extend(paper_fixes(options, paper, bed, !options.fit));
    }
    if !options.fit {
        fix.push(if drawing.page_mm.is_some() { "--fit" } else { "--fit with a --paper" }.to_string());
        if options.scale.is_some() {
            fix.push("a smaller --scale".into());
        }
    }
    if options.translate != Vec2::ZERO {
        fix.push("another --translate".into());
    }
    Err(LayoutError::OutsideReach { paper_note, x0: b.x0, x1: b.x1, y0: b.y0, y1: b.y1, reach, fix: join_or(&fix) })
}

/// Refuse a drawing that `step` moved beyond ±[`MAX_COORD_MM`]: every later stage would drop or refuse it, so
/// the layout says so, naming the step (a `--paper 1e300x1e300 --fit` used to end as "0 strokes", exit 0).
fn within_reach(drawing: &Drawing, step: &'static str) -> Result<(), LayoutError> {
    let Some(b) = drawing.bbox() else { return Ok(()) };
    if [b.x0, b.x1, b.y0, b.y1].iter().all(|v| v.abs() <= MAX_COORD_MM) {
        return Ok(());
    }
    Err(LayoutError::BeyondReach { step, x0: b.x0, x1: b.x1, y0: b.y0, y1: b.y1 })
}

fn drawable_area(drawing: &Drawing, margin: f64) -> Result<Rect, LayoutError> {
    let (w, h) = drawing.page_mm.ok_or(LayoutError::NoPage)?;
    let area = Rect::new(margin, margin, w - margin, h - margin);
    if !(margin >= 0.0 && area.width() > 0.0 && area.height() > 0.0) {
        return Err(LayoutError::Margin { margin_mm: margin, width_mm: w, height_mm: h });
    }
    Ok(area)
}

/// Check that every point of `drawing`, mapped to machine coordinates, lies inside the profile's work area.
pub fn check_work_area(drawing: &Drawing, profile: &MachineProfile) -> Result<(), LayoutError> {
    let Some(b) = drawing.bbox() else { return Ok(()) };
    let corners = [Point::new(b.x0, b.y0), Point::new(b.x1, b.y1)].map(|p| profile.page_to_machine(p));
    let m = Rect::from_points(corners[0], corners[1]);
    let area = profile.work_area();
    // Allow rounding noise well below one step.
    let eps = 1e-9;
    if m.x0 < area.x0 - eps || m.y0 < area.y0 - eps || m.x1 > area.x1 + eps || m.y1 > area.y1 + eps {
        return Err(LayoutError::OutsideWorkArea {
            x0: m.x0,
            x1: m.x1,
            y0: m.y0,
            y1: m.y1,
            w: area.width(),
            h: area.height(),
            profile: profile.name.clone(),
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::drawing::Polyline;

    fn rect_drawing(x0: f64, y0: f64, x1: f64, y1: f64, page: Option<(f64, f64)>) -> Drawing {
        let mut d = Drawing::single_layer(
            "r",
            vec![Polyline::new(vec![
                Point::new(x0, y0),
                Point::new(x1, y0),
                Point::new(x1, y1),
                Point::new(x0, y1),
                Point::new(x0, y0),
            ])],
        );
        d.page_mm = page;
        d
    }

    fn close(a: Rect, b: Rect) -> bool {
        (a.x0 - b.x0).abs() < 1e-9
            && (a.y0 - b.y0).abs() < 1e-9
            && (a.x1 - b.x1).abs() < 1e-9
            && (a.y1 - b.y1).abs() < 1e-9
    }

    /// Each named paper's millimetres: ISO 216 A and B series, and the US sizes at 25.4 mm per inch (letter 8.5 × 11,
    /// legal 8.5 × 14, tabloid 11 × 17, ledger 17 × 11).
    #[test]
    fn paper_names_and_custom_sizes() {
        let named = [
            ("a0", 841.0, 1189.0),
            ("a1", 594.0, 841.0),
            ("a2", 420.0, 594.0),
            ("A3", 297.0, 420.0),
            ("a4", 210.0, 297.0),
            ("a5", 148.0, 210.0),
            ("a6", 105.0, 148.0),
            ("b0", 1000.0, 1414.0),
            ("b1", 707.0, 1000.0),
            ("b2", 500.0, 707.0),
            ("b3", 353.0, 500.0),
            ("b4", 250.0, 353.0),
            ("B5", 176.0, 250.0),
            ("b6", 125.0, 176.0),
            ("letter", 215.9, 279.4),
            ("Legal", 215.9, 355.6),
            ("tabloid", 279.4, 431.8),
            ("ledger", 431.8, 279.4),
        ];
        for (name, w, h) in named {
            assert_eq!(name.parse::<Paper>().unwrap(), Paper { width_mm: w, height_mm: h }, "{name}");
        }
        let size = |s: &str| s.parse::<Paper>().map(|p| (p.width_mm, p.height_mm));
        let near = |s: &str, w: f64, h: f64| {
            let (pw, ph) = size(s).unwrap();
            assert!((pw - w).abs() < 1e-9 && (ph - h).abs() < 1e-9, "{s}: {pw} × {ph}, not {w} × {h}");
        };
        // 11 × 25.4 = 279.4, 8.5 × 25.4 = 215.9.
        near("11x8.5in", 279.4, 215.9);
        near("210x297mm", 210.0, 297.0);
        near("30x20cm", 300.0, 200.0);
        near("300x200", 300.0, 200.0);
        // 960 px at 96 px/in = 10 in = 254 mm; 480 px = 127 mm.
        near("960x480px", 254.0, 127.0);
        near("5inx20cm", 127.0, 200.0);
        near("8.5 × 11 in", 215.9, 279.4);
        assert_eq!(Paper::A4.oriented(Orientation::Landscape), Paper { width_mm: 297.0, height_mm: 210.0 });
        let err = "b7".parse::<Paper>().unwrap_err().to_string();
        assert!(err.contains("'b7'") && err.contains("11x8.5in"), "{err}");
        assert!("0x10".parse::<Paper>().is_err());
        assert!("10x20ft".parse::<Paper>().is_err());
        assert!("x20".parse::<Paper>().is_err());
        assert_eq!(Paper::A4.describe(), "A4 portrait (210 × 297 mm)");
        assert_eq!(Paper::LETTER.turned().describe(), "Letter landscape (279.4 × 215.9 mm)");
        assert_eq!(size("300x200").unwrap(), (300.0, 200.0));
        assert_eq!("300x200".parse::<Paper>().unwrap().describe(), "paper 300 × 200 mm");
    }

    #[test]
    fn fit_centres_inside_margins_keeping_aspect() {
        let mut d = rect_drawing(0.0, 0.0, 20.0, 10.0, None);
        let opts = LayoutOptions { paper: Some(Paper::A4), margin_mm: 10.0, fit: true, ..Default::default() };
        apply(&mut d, &opts).unwrap();
        // A4 portrait minus 10 mm margins: 190 × 277; 20×10 scales by 9.5 to 190 × 95, centred vertically.
        let b = d.bbox().unwrap();
        assert!(close(b, Rect::new(10.0, 148.5 - 47.5, 200.0, 148.5 + 47.5)), "{b:?}");
        assert_eq!(d.page_mm, Some((210.0, 297.0)));
    }

    /// A 40 × 20 mm box about its centre (20, 10), turned 30° clockwise: its half-extents become
    /// (40·cos 30° + 20·sin 30°)/2 = 17.3205 + 5 = 22.3205 and (40·sin 30° + 20·cos 30°)/2 = 10 + 8.6603 = 18.6603;
    /// its top-right corner (40, 0), 20 right of and 10 above the centre, goes to
    /// (20 + 20·cos 30° + 10·sin 30°, 10 + 20·sin 30° − 10·cos 30°) = (42.3205, 11.3397): down the page, clockwise.
    #[test]
    fn rotation_by_any_angle_turns_clockwise_about_the_centre() {
        let mut d = rect_drawing(0.0, 0.0, 40.0, 20.0, Some((100.0, 50.0)));
        apply(&mut d, &LayoutOptions { rotate_deg: 30.0, ..Default::default() }).unwrap();
        let (hw, hh) = (17.320_508_075_688_77 + 5.0, 10.0 + 8.660_254_037_844_386);
        assert!(close(d.bbox().unwrap(), Rect::new(20.0 - hw, 10.0 - hh, 20.0 + hw, 10.0 + hh)), "{:?}", d.bbox());
        let corner = d.layers[0].paths[0].points[1];
        assert!(corner.distance(Point::new(42.320_508_075_688_77, 11.339_745_962_155_614)) < 1e-9, "{corner:?}");
        assert_eq!(d.page_mm, Some((100.0, 50.0)), "the page stays");
        assert!(d.layers[0].paths[0].is_closed());
        // A quarter turn is exact: (10, 20)..(30, 25) about (20, 22.5) becomes (17.5, 12.5)..(22.5, 32.5).
        let mut q = rect_drawing(10.0, 20.0, 30.0, 25.0, None);
        apply(&mut q, &LayoutOptions { rotate_deg: 90.0, ..Default::default() }).unwrap();
        assert_eq!(q.bbox().unwrap(), Rect::new(17.5, 12.5, 22.5, 32.5));
        // −90° about the origin (0, 0): (x, y) → (y, −x).
        let mut o = rect_drawing(10.0, 20.0, 30.0, 25.0, None);
        let about = LayoutOptions { rotate_deg: -90.0, origin: Some(Point::ZERO), ..Default::default() };
        apply(&mut o, &about).unwrap();
        assert_eq!(o.bbox().unwrap(), Rect::new(20.0, -30.0, 25.0, -10.0));
        let nan = LayoutOptions { rotate_deg: f64::NAN, ..Default::default() };
        assert!(matches!(apply(&mut o, &nan), Err(LayoutError::Rotate(_))));
    }

    /// A 10 mm square at (10, 10) scaled 2× about its centre (15, 15) spans 5..25; about the origin (0, 0) it spans
    /// 20..40.
    #[test]
    fn scale_keeps_the_centre_or_the_origin() {
        let mut d = rect_drawing(10.0, 10.0, 20.0, 20.0, None);
        apply(&mut d, &LayoutOptions { scale: Some(2.0), ..Default::default() }).unwrap();
        assert_eq!(d.bbox().unwrap(), Rect::new(5.0, 5.0, 25.0, 25.0));
        assert_eq!(d.bbox().unwrap().center(), Point::new(15.0, 15.0));
        let mut o = rect_drawing(10.0, 10.0, 20.0, 20.0, None);
        apply(&mut o, &LayoutOptions { scale: Some(2.0), origin: Some(Point::ZERO), ..Default::default() }).unwrap();
        assert_eq!(o.bbox().unwrap(), Rect::new(20.0, 20.0, 40.0, 40.0));
    }

    #[test]
    fn scale_then_translate() {
        let mut d = rect_drawing(10.0, 10.0, 20.0, 20.0, None);
        let opts = LayoutOptions { scale: Some(2.0), translate: Vec2::new(5.0, -1.0), ..Default::default() };
        apply(&mut d, &opts).unwrap();
        // 5..25 about the centre, then moved by (5, −1).
        assert!(close(d.bbox().unwrap(), Rect::new(10.0, 4.0, 30.0, 24.0)));
        assert_eq!(
            apply(&mut d, &LayoutOptions { scale: Some(0.0), ..Default::default() }),
            Err(LayoutError::Scale(0.0))
        );
        assert_eq!(apply(&mut d, &LayoutOptions { center: true, ..Default::default() }), Err(LayoutError::NoPage));
    }

    /// Issue 22, item 11: a layout that throws the drawing beyond any machine's reach is an error naming the
    /// step, never a silently empty result.
    #[test]
    fn absurd_layouts_are_errors_naming_the_step() {
        let err = "1e300x1e300".parse::<Paper>().unwrap_err();
        assert_eq!(err, LayoutError::PaperTooLarge { width_mm: 1e300, height_mm: 1e300 });
        assert_eq!(
            err.to_string(),
            "paper 1.000e300 × 1.000e300 mm is beyond the 1000000 mm (1 km) limit; give the size in mm"
        );
        // The paper given directly (the web app builds LayoutOptions itself).
        let huge = Paper { width_mm: 1e300, height_mm: 1e300 };
        let mut d = rect_drawing(0.0, 0.0, 20.0, 10.0, None);
        let opts = LayoutOptions { paper: Some(huge), fit: true, ..Default::default() };
        assert!(matches!(apply(&mut d, &opts), Err(LayoutError::PaperTooLarge { .. })));
        // A 1 km paper is allowed, but fitting a 20 × 10 mm drawing on it (scale 5·10⁴) reaches 10⁶ mm: allowed
        // exactly at the edge; a 1e12 scale is not.
        let mut d = rect_drawing(0.0, 0.0, 20.0, 10.0, None);
        let err = apply(&mut d, &LayoutOptions { scale: Some(1e12), ..Default::default() }).unwrap_err();
        assert!(matches!(err, LayoutError::BeyondReach { step: "--scale", .. }), "{err}");
        // About its centre (10, 5): x 10 ∓ 10·10¹².
        assert!(err.to_string().contains("x -1.000e13..1.000e13 mm"), "{err}");
        let mut d = rect_drawing(0.0, 0.0, 20.0, 10.0, None);
        let far = LayoutOptions { translate: Vec2::new(2e6, 0.0), ..Default::default() };
        assert!(matches!(apply(&mut d, &far), Err(LayoutError::BeyondReach { step: "--translate", .. })));
        let mut d = rect_drawing(0.0, 0.0, 20.0, 10.0, None);
        let fit =
            LayoutOptions { paper: Some(Paper { width_mm: 1e6, height_mm: 1e6 }), fit: true, ..Default::default() };
        apply(&mut d, &fit).unwrap();
        let b = d.bbox().unwrap();
        assert!((b.width() - 1e6).abs() < 1e-6 && b.x0.abs() < 1e-6, "{b:?}");
    }

    fn machine(name: &str, w: f64, h: f64) -> Bed {
        let mut p = MachineProfile::default_plotter();
        p.name = name.into();
        p.axes.x.travel_mm = w;
        p.axes.y.travel_mm = h;
        Bed::work_area(&p)
    }

    /// A4 portrait (210 × 297) overhangs a 300 × 218 mm work area; landscape (297 × 210) lies on it, so the paper
    /// is turned, with a line saying so. A 20 × 10 drawing is then fitted into 297 × 210 minus 10 mm margins,
    /// 277 × 190: scale min(277/20, 190/10) = 13.85, 277 × 138.5 about the page's centre (148.5, 105).
    #[test]
    fn a_paper_the_machine_takes_only_turned_is_turned() {
        let v3 = machine("AxiDraw V3", 300.0, 218.0);
        let mut opts = LayoutOptions {
            paper: Some(Paper::A4),
            fit: true,
            margin_mm: 10.0,
            bed: Some(v3.clone()),
            ..Default::default()
        };
        assert!(!opts.is_identity() && LayoutOptions { bed: Some(v3), ..Default::default() }.is_identity());
        assert!(LayoutOptions { margin_mm: 10.0, ..Default::default() }.is_identity());
        let settled = settle_on_bed(&opts).unwrap();
        assert_eq!(settled.turned, Some(Orientation::Landscape));
        assert_eq!(
            settled.note.as_deref(),
            Some(
                "A4 portrait (210 × 297 mm) does not fit the AxiDraw V3's 300 × 218 mm work area; turned to landscape"
            )
        );
        opts.orientation = settled.turned;
        let mut d = rect_drawing(0.0, 0.0, 20.0, 10.0, None);
        apply(&mut d, &opts).unwrap();
        assert_eq!(d.page_mm, Some((297.0, 210.0)));
        assert!(close(d.bbox().unwrap(), Rect::new(10.0, 35.75, 287.0, 174.25)), "{:?}", d.bbox());
        // Landscape asked for: nothing to turn, nothing to say.
        let landscape = LayoutOptions { orientation: Some(Orientation::Landscape), ..opts.clone() };
        assert_eq!(settle_on_bed(&landscape).unwrap(), Settled::default());
    }

    /// Portrait asked for on the same machine: the fit uses what the pen reaches, A4 minus 10 mm margins
    /// (10..200 × 10..287) within 0..300 × 0..218, i.e. 10..200 × 10..218 (190 × 208): the 20 × 10 drawing scales by
    /// min(190/20, 208/10) = 9.5 to 190 × 95 about (105, 114). Without --fit, a drawing reaching y 280 is an error
    /// naming the fixes.
    #[test]
    fn portrait_asked_for_fits_what_the_pen_reaches_or_names_the_fix() {
        let opts = LayoutOptions {
            paper: Some(Paper::A4),
            orientation: Some(Orientation::Portrait),
            fit: true,
            margin_mm: 10.0,
            bed: Some(machine("AxiDraw V3", 300.0, 218.0)),
            ..Default::default()
        };
        let settled = settle_on_bed(&opts).unwrap();
        assert_eq!(settled.turned, None);
        assert_eq!(
            settled.note.as_deref(),
            Some(
                "only 210 × 218 mm of A4 portrait (210 × 297 mm) lies in the AxiDraw V3's 300 × 218 mm work area: \
                 the drawing is fitted there (or use --landscape, or --paper a5)"
            )
        );
        let mut d = rect_drawing(0.0, 0.0, 20.0, 10.0, None);
        apply(&mut d, &opts).unwrap();
        assert!(close(d.bbox().unwrap(), Rect::new(10.0, 66.5, 200.0, 161.5)), "{:?}", d.bbox());

        let placed = LayoutOptions { fit: false, ..opts };
        let mut tall = rect_drawing(15.0, 20.0, 195.0, 280.0, None);
        let err = apply(&mut tall, &placed).unwrap_err().to_string();
        assert_eq!(
            err,
            "A4 portrait (210 × 297 mm) does not fit the AxiDraw V3's 300 × 218 mm work area, and the drawing \
             (x 15..195, y 20..280 mm on the page) reaches beyond it (x 0..300, y 0..218 mm); use --fit --landscape, \
             --fit --paper a5, or --fit"
        );
        // Without a page, as it stands: the work area alone.
        let bare = LayoutOptions { bed: Some(machine("XY", 100.0, 100.0)), ..Default::default() };
        let err = apply(&mut rect_drawing(0.0, 0.0, 120.0, 50.0, None), &bare).unwrap_err().to_string();
        assert_eq!(
            err,
            "the drawing (x 0..120, y 0..50 mm on the page) reaches beyond the XY's 100 × 100 mm work area \
             (x 0..100, y 0..100 mm); use --fit with a --paper"
        );
        apply(&mut rect_drawing(0.0, 0.0, 100.0, 50.0, None), &bare).unwrap();
    }

    /// On the HP 7475A, A4 goes on its A4 sheet turned (297 × 210), whose plotting area on the page is
    /// x 10..286, y 12.975..206. A4 minus 10 mm margins (10..287 × 10..200) within it: 10..286 × 12.975..200,
    /// 276 × 187.025; a 20 × 10 drawing scales by min(276/20, 187.025/10) = 13.8 to 276 × 138 about
    /// (148, 106.4875). A2 goes on none of its sheets either way.
    #[test]
    fn an_hpgl_sheet_turns_the_paper_and_bounds_the_fit() {
        let hp = Bed::hpgl(crate::geometry::hpgl_devices::device("7475a").unwrap(), None);
        let mut opts =
            LayoutOptions { paper: Some(Paper::A4), fit: true, margin_mm: 10.0, bed: Some(hp), ..Default::default() };
        let settled = settle_on_bed(&opts).unwrap();
        assert_eq!(settled.turned, Some(Orientation::Landscape));
        assert_eq!(
            settled.note.as_deref(),
            Some(
                "A4 portrait (210 × 297 mm) goes on the HP 7475A's a4 sheet (297 × 210 mm) only turned; turned to landscape"
            )
        );
        opts.orientation = settled.turned;
        let mut d = rect_drawing(0.0, 0.0, 20.0, 10.0, None);
        apply(&mut d, &opts).unwrap();
        assert!(close(d.bbox().unwrap(), Rect::new(10.0, 37.4875, 286.0, 175.4875)), "{:?}", d.bbox());
        let a2 = LayoutOptions { paper: "a2".parse().ok(), orientation: None, ..opts };
        assert_eq!(
            settle_on_bed(&a2).unwrap_err().to_string(),
            "A2 portrait (420 × 594 mm) does not fit the HP 7475A's sheets (a4, letter, a3, tabloid); use --paper a3"
        );
    }

    #[test]
    fn work_area_check_names_the_extent() {
        let profile = MachineProfile::default_plotter();
        let inside = rect_drawing(0.0, 0.0, 100.0, 100.0, None);
        check_work_area(&inside, &profile).unwrap();
        let outside = rect_drawing(0.0, 0.0, 500.0, 100.0, None);
        let msg = check_work_area(&outside, &profile).unwrap_err().to_string();
        assert!(msg.contains("x 0.00..500.00") && msg.contains("0..420.00"), "{msg}");
    }
}
