//! Page layout: paper size and orientation, margins, fit-to-page, centring, quarter-turn rotation, explicit scale
//! and translation, and the check that the result fits the machine's work area.
//!
//! Operations apply in a fixed order, so a command line means the same thing whatever order its flags come in:
//! 1. **rotate** by quarter turns clockwise, carrying the page along (a portrait page becomes landscape);
//! 2. **paper**: the page becomes the chosen paper (oriented), geometry stays where it is;
//! 3. **scale** by an explicit factor about the drawing's top-left corner, or **fit**: the largest uniform scale that
//!    puts the bounding box inside the page minus the margins (fit implies centring);
//! 4. **centre** the bounding box on the page;
//! 5. **translate** by a fixed offset.

use std::fmt;
use std::str::FromStr;

use kurbo::{Affine, Point, Rect, Vec2};

use crate::config::profile::MachineProfile;
use crate::geometry::drawing::Drawing;
use crate::geometry::limits::MAX_COORD_MM;

/// Layout errors.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LayoutError {
    /// A paper name that is neither known nor `WxH` in millimetres.
    #[error("unknown paper size '{0}': use a3, a4, a5, letter or WIDTHxHEIGHT in mm (e.g. 300x200)")]
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
}

/// A paper size in millimetres, portrait (width ≤ height) for the named sizes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Paper {
    /// Width, mm.
    pub width_mm: f64,
    /// Height, mm.
    pub height_mm: f64,
}

impl Paper {
    /// ISO A3.
    pub const A3: Paper = Paper { width_mm: 297.0, height_mm: 420.0 };
    /// ISO A4.
    pub const A4: Paper = Paper { width_mm: 210.0, height_mm: 297.0 };
    /// ISO A5.
    pub const A5: Paper = Paper { width_mm: 148.0, height_mm: 210.0 };
    /// US Letter.
    pub const LETTER: Paper = Paper { width_mm: 215.9, height_mm: 279.4 };

    /// This paper turned to `orientation` (named sizes are portrait; a custom size keeps its given shape unless an
    /// orientation is requested).
    pub fn oriented(self, orientation: Orientation) -> Paper {
        let (short, long) = (self.width_mm.min(self.height_mm), self.width_mm.max(self.height_mm));
        match orientation {
            Orientation::Portrait => Paper { width_mm: short, height_mm: long },
            Orientation::Landscape => Paper { width_mm: long, height_mm: short },
        }
    }
}

impl FromStr for Paper {
    type Err = LayoutError;
    fn from_str(s: &str) -> Result<Self, LayoutError> {
        let lower = s.trim().to_ascii_lowercase();
        let named = match lower.as_str() {
            "a3" => Some(Paper::A3),
            "a4" => Some(Paper::A4),
            "a5" => Some(Paper::A5),
            "letter" => Some(Paper::LETTER),
            _ => None,
        };
        if let Some(p) = named {
            return Ok(p);
        }
        let body = lower.strip_suffix("mm").unwrap_or(&lower);
        let (w, h) = body.split_once('x').ok_or_else(|| LayoutError::Paper(s.to_string()))?;
        let parse = |v: &str| v.trim().parse::<f64>().ok().filter(|v| v.is_finite() && *v > 0.0);
        match (parse(w), parse(h)) {
            (Some(width_mm), Some(height_mm)) if width_mm > MAX_COORD_MM || height_mm > MAX_COORD_MM => {
                Err(LayoutError::PaperTooLarge { width_mm, height_mm })
            }
            (Some(width_mm), Some(height_mm)) => Ok(Paper { width_mm, height_mm }),
            _ => Err(LayoutError::Paper(s.to_string())),
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
    /// Scale to the largest size that fits inside the margins, keeping the aspect ratio; implies centring.
    pub fit: bool,
    /// Centre the drawing on the page.
    pub center: bool,
    /// Quarter turns clockwise (any integer; taken modulo 4).
    pub rotate_quarters: i32,
    /// Explicit scale factor about the drawing's top-left corner (ignored with `fit`).
    pub scale: Option<f64>,
    /// Final offset, mm.
    pub translate: Vec2,
}

impl LayoutOptions {
    /// True when applying these options changes nothing.
    pub fn is_identity(&self) -> bool {
        *self == LayoutOptions::default()
    }
}

/// Lay out `drawing` in place according to `options`. Returns the scale factor applied (`--scale`, or the one
/// `--fit` chose; 1 when neither), so that an importer can flatten curves finer when the layout magnifies them.
pub fn apply(drawing: &mut Drawing, options: &LayoutOptions) -> Result<f64, LayoutError> {
    if let Some(s) = options.scale
        && !(s.is_finite() && s > 0.0)
    {
        return Err(LayoutError::Scale(s));
    }
    // 1. rotate with the page
    let quarters = options.rotate_quarters.rem_euclid(4);
    if quarters != 0 {
        let (w, h) = drawing.page_mm.or_else(|| drawing.bbox().map(|b| (b.x1, b.y1))).unwrap_or((0.0, 0.0));
        // One clockwise quarter turn on a Y-down page: (x, y) → (h − y, x); the page becomes h × w.
        let (mut pw, mut ph) = (w, h);
        let mut m = Affine::IDENTITY;
        for _ in 0..quarters {
            m = Affine::new([0.0, 1.0, -1.0, 0.0, ph, 0.0]) * m;
            (pw, ph) = (ph, pw);
        }
        drawing.map_points(|p| m * p);
        if drawing.page_mm.is_some() {
            drawing.page_mm = Some((pw, ph));
        }
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
    let needs_page = options.fit || options.center;
    if !needs_page && options.scale.is_none() && options.translate == Vec2::ZERO {
        return Ok(1.0);
    }
    let bbox = drawing.bbox().ok_or(LayoutError::Empty)?;
    // 3. scale or fit, about the bounding box's top-left corner
    let factor = if options.fit {
        let area = drawable_area(drawing, options.margin_mm)?;
        let sx = if bbox.width() > 0.0 { area.width() / bbox.width() } else { f64::INFINITY };
        let sy = if bbox.height() > 0.0 { area.height() / bbox.height() } else { f64::INFINITY };
        Some(sx.min(sy)).filter(|s| s.is_finite())
    } else {
        options.scale
    };
    if let Some(s) = factor {
        let origin = bbox.origin();
        drawing.map_points(|p| origin + (p - origin) * s);
        if !needs_page {
            within_reach(drawing, "--scale")?;
        }
    }
    // 4. centre
    if needs_page {
        let area = drawable_area(drawing, options.margin_mm)?;
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
    Ok(factor.unwrap_or(1.0))
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

    #[test]
    fn paper_names_and_custom_sizes() {
        assert_eq!("A4".parse::<Paper>().unwrap(), Paper::A4);
        assert_eq!("300x200mm".parse::<Paper>().unwrap(), Paper { width_mm: 300.0, height_mm: 200.0 });
        assert_eq!(Paper::A4.oriented(Orientation::Landscape), Paper { width_mm: 297.0, height_mm: 210.0 });
        assert!("b7".parse::<Paper>().unwrap_err().to_string().contains("b7"));
        assert!("0x10".parse::<Paper>().is_err());
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

    #[test]
    fn rotation_carries_the_page() {
        let mut d = rect_drawing(10.0, 20.0, 30.0, 25.0, Some((100.0, 50.0)));
        apply(&mut d, &LayoutOptions { rotate_quarters: 1, ..Default::default() }).unwrap();
        assert_eq!(d.page_mm, Some((50.0, 100.0)));
        // (x, y) → (50 − y, x)
        assert!(close(d.bbox().unwrap(), Rect::new(25.0, 10.0, 30.0, 30.0)));
        apply(&mut d, &LayoutOptions { rotate_quarters: 3, ..Default::default() }).unwrap();
        assert!(close(d.bbox().unwrap(), Rect::new(10.0, 20.0, 30.0, 25.0)));
        assert_eq!(d.page_mm, Some((100.0, 50.0)));
    }

    #[test]
    fn scale_then_translate() {
        let mut d = rect_drawing(10.0, 10.0, 20.0, 20.0, None);
        let opts = LayoutOptions { scale: Some(2.0), translate: Vec2::new(5.0, -1.0), ..Default::default() };
        apply(&mut d, &opts).unwrap();
        assert!(close(d.bbox().unwrap(), Rect::new(15.0, 9.0, 35.0, 29.0)));
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
        assert!(err.to_string().contains("x 0.000e0..2.000e13 mm"), "{err}");
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
