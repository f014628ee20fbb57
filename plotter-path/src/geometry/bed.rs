//! The machine as the page layout sees it: where a sheet of paper lies on it, and which part of the sheet its pen
//! reaches.
//!
//! Everything here is in page millimetres: the origin at the sheet's top-left corner, X right, Y down. The sheet
//! lies with its top-left corner at the page origin.
//! - A machine profile's bed is its work area, mapped onto the page through the profile's page→machine mapping
//!   ([`MachineProfile::page_to_machine`]). A sheet of any size may lie there; the part of it inside the work area
//!   is what can be drawn (an A3 sheet under an A4 plotter is drawn on where the pen reaches).
//! - An HP-GL plotter takes the sheets of its table ([`crate::geometry::hpgl_devices`]) in their fixed
//!   orientation; its pen reaches the sheet's plotting area. A paper no sheet of the device holds cannot be
//!   loaded. The generic HP-GL device plots on the drawing's own page, whole.

use kurbo::{Point, Rect};

use crate::config::profile::MachineProfile;
use crate::geometry::hpgl_devices::{HpglDevice, HpglPaper};

/// Rounding noise allowed when comparing sizes and positions, mm (far below a step or a plotter unit).
pub const EPS_MM: f64 = 1e-6;

/// A machine as the layout sees it.
#[derive(Debug, Clone, PartialEq)]
pub enum Bed {
    /// A machine profile's work area.
    WorkArea {
        /// The profile's name, for messages.
        machine: String,
        /// The work area on the page, mm.
        area: Rect,
    },
    /// An HP-GL plotter and, when one was chosen (`--hpgl-paper`), the sheet loaded in it.
    Hpgl {
        /// The plotter.
        device: &'static HpglDevice,
        /// The sheet chosen, or `None` for the one that suits the paper ([`sheet_for_page`]).
        sheet: Option<&'static HpglPaper>,
    },
}

/// How a sheet of paper lies on a bed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum SheetFit {
    /// The sheet overhangs the work area, or no sheet of the HP-GL plotter holds it.
    No,
    /// The sheet lies within the work area, or on a larger sheet of the HP-GL plotter.
    Holds,
    /// The sheet is one the HP-GL plotter takes, as it takes it.
    Exact,
}

/// Where a sheet of a given size goes on a bed.
#[derive(Debug, Clone, PartialEq)]
pub struct Placement {
    /// How well the bed takes the sheet.
    pub fit: SheetFit,
    /// The part of the page the pen reaches, mm.
    pub reach: Rect,
    /// Where the sheet lies, for messages: "the AxiDraw V3's 300 × 218 mm work area", "the HP 7475A's a4 sheet
    /// (297 × 210 mm)".
    pub place: String,
    /// What the pen reaches, for messages: the work area, or "the plotting area of the HP 7475A's a4 sheet …".
    pub reach_name: String,
}

impl Bed {
    /// The bed of a machine profile: its work area, mapped to the page.
    pub fn work_area(profile: &MachineProfile) -> Bed {
        let w = profile.work_area();
        let corners = [Point::new(w.x0, w.y0), Point::new(w.x1, w.y1)].map(|p| profile.machine_to_page(p));
        Bed::WorkArea { machine: profile.name.clone(), area: Rect::from_points(corners[0], corners[1]) }
    }

    /// The bed of an HP-GL plotter, with `sheet` loaded, or the sheet that suits each paper.
    pub fn hpgl(device: &'static HpglDevice, sheet: Option<&'static HpglPaper>) -> Bed {
        Bed::Hpgl { device, sheet }
    }

    /// Whether a paper must lie on the bed to be plotted at all (an HP-GL plotter loads only its sheets; a
    /// plotter with a work area draws on any paper where the pen reaches).
    pub fn paper_must_fit(&self) -> bool {
        matches!(self, Bed::Hpgl { device, .. } if !device.papers.is_empty())
    }

    /// The bed, named for messages: "the AxiDraw V3 (A4)'s 300 × 218 mm work area", "the HP 7475A's sheets (a4,
    /// letter, a3, tabloid)".
    pub fn name(&self) -> String {
        match self {
            Bed::WorkArea { machine, area } => {
                format!("the {machine}'s {} × {} mm work area", mm(area.width()), mm(area.height()))
            }
            Bed::Hpgl { device, sheet: Some(s) } => sheet_name(device, s),
            Bed::Hpgl { device, sheet: None } if device.papers.is_empty() => format!("the {}", device.name),
            Bed::Hpgl { device, sheet: None } => format!("the {}'s sheets ({})", device.name, device.paper_names()),
        }
    }

    /// Where a sheet of `width_mm` × `height_mm` (as it lies on the page) goes on this bed.
    pub fn place(&self, width_mm: f64, height_mm: f64) -> Placement {
        let sheet = Rect::new(0.0, 0.0, width_mm, height_mm);
        match self {
            Bed::WorkArea { area, .. } => {
                let fit = if contains(*area, sheet) { SheetFit::Holds } else { SheetFit::No };
                Placement { fit, reach: *area, place: self.name(), reach_name: self.name() }
            }
            Bed::Hpgl { device, sheet: _ } if device.papers.is_empty() => {
                let place = format!("the {}'s page", device.name);
                Placement { fit: SheetFit::Exact, reach: sheet, reach_name: place.clone(), place }
            }
            Bed::Hpgl { device, sheet: Some(s) } => on_sheet(device, s, width_mm, height_mm),
            Bed::Hpgl { device, sheet: None } => match sheet_for_page(device, width_mm, height_mm) {
                Some(s) => on_sheet(device, s, width_mm, height_mm),
                None => Placement {
                    fit: SheetFit::No,
                    // Such a paper cannot be loaded (see `paper_must_fit`); the sheets' areas together.
                    reach: device.papers.iter().map(plotting_area).fold(Rect::ZERO, |a, b| a.union(b)),
                    place: self.name(),
                    reach_name: format!("the plotting areas of {}", self.name()),
                },
            },
        }
    }
}

/// The sheet of `device` a page of `width_mm` × `height_mm` is plotted on: the sheet of exactly that size, as the
/// plotter takes it, else the first (smallest) sheet that holds the page at its top-left corner.
pub fn sheet_for_page(device: &'static HpglDevice, width_mm: f64, height_mm: f64) -> Option<&'static HpglPaper> {
    let on = |fit| device.papers.iter().find(|s| sheet_fit(s, width_mm, height_mm) == fit);
    on(SheetFit::Exact).or_else(|| on(SheetFit::Holds))
}

/// The part of `sheet` its plotter's pen reaches, page mm (the hard-clip rectangle placed at the sheet's origin).
pub fn plotting_area(sheet: &HpglPaper) -> Rect {
    let (w, h) = sheet.area_mm();
    let (x0, y0) = sheet.origin_mm;
    Rect::new(x0, y0 - h, x0 + w, y0)
}

fn on_sheet(device: &HpglDevice, sheet: &HpglPaper, width_mm: f64, height_mm: f64) -> Placement {
    let place = sheet_name(device, sheet);
    Placement {
        fit: sheet_fit(sheet, width_mm, height_mm),
        reach: plotting_area(sheet),
        reach_name: format!("the plotting area of {place}"),
        place,
    }
}

/// Whether a page of `width_mm` × `height_mm` is `sheet` as its plotter takes it (to 0.05 mm: a size given in
/// inches rounds).
pub fn is_sheet(sheet: &HpglPaper, width_mm: f64, height_mm: f64) -> bool {
    (sheet.size_mm.0 - width_mm).abs() <= 0.05 && (sheet.size_mm.1 - height_mm).abs() <= 0.05
}

fn sheet_fit(sheet: &HpglPaper, width_mm: f64, height_mm: f64) -> SheetFit {
    let (sw, sh) = sheet.size_mm;
    if is_sheet(sheet, width_mm, height_mm) {
        SheetFit::Exact
    } else if width_mm <= sw + EPS_MM && height_mm <= sh + EPS_MM {
        SheetFit::Holds
    } else {
        SheetFit::No
    }
}

fn sheet_name(device: &HpglDevice, sheet: &HpglPaper) -> String {
    format!("the {}'s {} sheet ({} × {} mm)", device.name, sheet.name, mm(sheet.size_mm.0), mm(sheet.size_mm.1))
}

/// Whether `outer` contains `inner`, give or take [`EPS_MM`].
pub fn contains(outer: Rect, inner: Rect) -> bool {
    inner.x0 >= outer.x0 - EPS_MM
        && inner.y0 >= outer.y0 - EPS_MM
        && inner.x1 <= outer.x1 + EPS_MM
        && inner.y1 <= outer.y1 + EPS_MM
}

/// Millimetres for messages: at most two decimals, no trailing zeros (300, 215.9, 193.03).
pub fn mm(v: f64) -> String {
    let s = format!("{v:.2}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" { "0".to_string() } else { s.to_string() }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::hpgl_devices::device;

    #[test]
    fn a_profile_bed_is_its_work_area_on_the_page() {
        let profile = MachineProfile::default_plotter();
        let (w, h) = (profile.axes.x.travel_mm, profile.axes.y.travel_mm);
        let bed = Bed::work_area(&profile);
        let a4 = bed.place(210.0, 297.0);
        assert_eq!(a4.reach, Rect::new(0.0, 0.0, w, h));
        assert_eq!(a4.fit, if w >= 210.0 && h >= 297.0 { SheetFit::Holds } else { SheetFit::No });
        assert_eq!(bed.place(w + 0.5, 10.0).fit, SheetFit::No);
        assert!(!bed.paper_must_fit());
    }

    /// The 7475A's A4 sheet is 297 × 210 mm with plu (0, 0) 10 mm from its left edge and 206 mm down, and an
    /// 11040 × 7721 plu (276 × 193.025 mm) range: on the page x 10..286, y 12.975..206.
    #[test]
    fn an_hpgl_sheet_is_chosen_by_size_and_reaches_its_plotting_area() {
        let hp = device("7475a").unwrap();
        let bed = Bed::hpgl(hp, None);
        let a4 = bed.place(297.0, 210.0);
        assert_eq!(a4.fit, SheetFit::Exact);
        let r = a4.reach;
        assert!((r.x0 - 10.0).abs() < 1e-9 && (r.x1 - 286.0).abs() < 1e-9, "{r:?}");
        assert!((r.y0 - 12.975).abs() < 1e-9 && (r.y1 - 206.0).abs() < 1e-9, "{r:?}");
        assert_eq!(a4.place, "the HP 7475A's a4 sheet (297 × 210 mm)");
        // A4 portrait lies only on the A3 sheet (420 × 297); A2 on none.
        let portrait = bed.place(210.0, 297.0);
        assert_eq!((portrait.fit, portrait.place.contains("a3 sheet")), (SheetFit::Holds, true));
        assert_eq!(bed.place(420.0, 594.0).fit, SheetFit::No);
        assert!(bed.paper_must_fit());
        assert_eq!(bed.name(), "the HP 7475A's sheets (a4, letter, a3, tabloid)");
        // The generic plotter's page is its sheet.
        let g = Bed::hpgl(device("generic").unwrap(), None).place(100.0, 50.0);
        assert_eq!((g.fit, g.reach), (SheetFit::Exact, Rect::new(0.0, 0.0, 100.0, 50.0)));
    }

    #[test]
    fn millimetres_read_plainly() {
        assert_eq!(mm(300.0), "300");
        assert_eq!(mm(215.9), "215.9");
        assert_eq!(mm(279.4), "279.4");
        assert_eq!(mm(-0.001), "0");
    }
}
