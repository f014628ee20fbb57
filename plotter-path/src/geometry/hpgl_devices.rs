//! The HP-GL plotters this project knows: their papers, plotting areas, pen carousels and top speeds.
//!
//! HP-GL addresses the paper in *plotter units* (plu) of 0.025 mm, [`PLU_PER_MM`] = 40 per millimetre (the HP
//! 7470A/7475A Interfacing and Programming Manuals give 0.025 mm, "approximately 0.001 in"). The pen can reach a
//! rectangle of the sheet, the *hard-clip limits*; its lower-left corner is plotter-unit (0, 0), X runs along the
//! sheet's long side to the right and Y runs **up** (our page runs Y down, so every export and import flips Y).
//!
//! Each [`HpglPaper`] says where that rectangle lies on the sheet: `origin_mm` is the position of plu (0, 0)
//! measured from the sheet's top-left corner (X right, Y down, like our page), and `clip_plu` is the far corner of
//! the reachable rectangle.
//!
//! # Where every figure comes from
//!
//! Each figure below is either taken from a named document or marked *estimated*, with why. Sources:
//! - **[7475A-IPM]** HP 7475A Interfacing and Programming Manual (07475-90002): the plotter unit (0.025 mm) and
//!   its table "Plotting Areas and Default P1, P2 Locations" (the range of each paper size in plotter units). Its
//!   full text could not be searched here; the ranges were checked as [vpype] records them.
//! - **[HP-GL-coords]** the HP-GL coordinate-system page that quotes HP's manuals (pic.hallikainen.org techref,
//!   "language/hpgl/coordinates"): "the plotter unit is 0.025 mm (approximately 0.001 in.)", X along the long
//!   side, Y up, origin at the lower left of the hard-clip limits.
//! - **[vpype]** vpype's device configuration `vpype/hpgl_devices.toml`: records the 7475A ranges above (the same
//!   numbers as [7475A-IPM]) and the placement of those ranges on the sheet (`origin_location`), measured by its
//!   users — the manual gives the ranges, not the margins.
//! - **[DXY-CRM]** Roland DXY-1300/1200/1100 Command Reference Manual: §5.4.1 (the `ESC.N` example) gives the
//!   plotter's answer to `ESC.L` (buffer size) as "1024"; the Xon/Xoff and ENQ/ACK thresholds default to 80 bytes
//!   (`ESC.H`/`ESC.I`, same section). RD-GL I (its HP-GL) at 0.025 mm units is as a public table of DXY models
//!   records it; the manual's own unit section was not readable here.
//! - **[7550A-notes]** J. Stepanian, "Operating the HP 7550A Pen Plotter" (jamie.stepanian.ca/docs/hp7550a): up
//!   to 8 pens, an automatic sheet feeder, "6g of acceleration". The 7550A's own interfacing manual
//!   (07550-90001) could not be searched for its buffer size, see below.
//! - **[KC-GL]** Kyocera's HP 7550A emulation (KC-GL) reference: `OI` answers `7550A` in that mode — the model
//!   number is the identity, as on the 7475A.
//!
//! Per device:
//! - **HP 7475A**: 6 pens; 38.1 cm/s top speed (15 in/s, as recorded before; an overview of the HP 7470, the same
//!   grit-wheel mechanism, gives "up to 38 cm/s"); papers and ranges A4 0–11040 × 0–7721, A3 0–16158 × 0–11040, ANSI A
//!   0–10365 × 0–7962, ANSI B 0–16640 × 0–10365 [7475A-IPM, vpype]; origins on the sheet [vpype] except ANSI B's
//!   (*estimated*: vpype's would put the range off the sheet, see the table); buffer 1024
//!   bytes (the size the manual's `ESC.L` reports by default, as recorded before); acceleration 2 g (*estimated*:
//!   the figure recorded for the 7470A mechanism, not found in the sources searched).
//! - **HP 7550A**: 8 pens and 6 g [7550A-notes]; 80 cm/s (HP's figure as recorded before, not re-checked); the A4
//!   and A3 ranges and origins are *estimated* as the 7475A's (the 7550A manual's table was not available); the
//!   buffer of 1024 bytes is *estimated* (the 7550A's manual was not searchable; the sender asks the plotter with
//!   `ESC.L` at connect and uses the answer, so this figure only sizes the model of `plotter sim --hpgl`).
//! - **Roland DXY-1300**: 8 pens (as recorded before, not re-checked); 0.025 mm units and a 1024-byte buffer
//!   [DXY-CRM]; 42 cm/s and 1 g are *estimated* (not in the command reference, which covers commands only; a
//!   gentle acceleration only makes the time estimate longer); the 416 × 276 mm range (0–16640 × 0–11040) and
//!   its centring on A3 are *estimated* likewise.
//! - **generic**: any HP-GL plotter; the plotting area is the drawing's own page with plu (0, 0) at its lower-left
//!   corner, 8 pens, 38.1 cm/s (HP-GL's customary top `VS`), all *estimated* on purpose: a small 256-byte buffer
//!   and 1 g, which only make the sender more careful and the time estimate longer.
//!
//! Pen lift and pen-change times live with the timing model (`plotter-cli`'s `link::hpgl::timing`), estimated
//! there with the reason.

/// Plotter units per millimetre (1 plu = 0.025 mm).
pub const PLU_PER_MM: f64 = 40.0;

/// A sheet a device takes, with the reachable rectangle on it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HpglPaper {
    /// Name as given on the command line (`a4`, `a3`, `letter`, ...).
    pub name: &'static str,
    /// Sheet size as loaded, mm: width along the plotter's X, height along its Y.
    pub size_mm: (f64, f64),
    /// Far corner of the hard-clip rectangle, plotter units (the near corner is (0, 0)).
    pub clip_plu: (i32, i32),
    /// Where plu (0, 0) lies on the sheet, mm from its top-left corner (X right, Y down).
    pub origin_mm: (f64, f64),
}

/// One HP-GL plotter model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HpglDevice {
    /// Name as given to `--hpgl-device`.
    pub id: &'static str,
    /// Name shown to people.
    pub name: &'static str,
    /// Pens in the carousel (`SP 1` ..= `SP pens`).
    pub pens: u8,
    /// Highest pen speed `VS` accepts, cm/s.
    pub max_velocity_cm_s: f64,
    /// The sheets it takes, smallest first; empty for the generic device (the drawing's page is the sheet).
    pub papers: &'static [HpglPaper],
    /// What it answers to `OI` (output identification).
    pub identity: &'static str,
    /// Size of its input buffer, bytes (what `ESC . L` reports with the buffer empty).
    pub buffer_bytes: usize,
    /// Pen acceleration, g (9.80665 m/s²).
    pub accel_g: f64,
}

// Ranges: [7475A-IPM] (recorded in [vpype] with the same numbers); origins: [vpype] (measured by its users).
// vpype also records a measured plotter unit of 0.02488 mm; we keep the manual's 0.025 mm ([`PLU_PER_MM`]).
const HP7475A_PAPERS: &[HpglPaper] = &[
    HpglPaper { name: "a4", size_mm: (297.0, 210.0), clip_plu: (11040, 7721), origin_mm: (10.0, 206.0) },
    HpglPaper { name: "letter", size_mm: (279.4, 215.9), clip_plu: (10365, 7962), origin_mm: (10.0, 211.0) },
    HpglPaper { name: "a3", size_mm: (420.0, 297.0), clip_plu: (16158, 11040), origin_mm: (15.0, 287.0) },
    // Origin estimated: [vpype] gives the A3 sheet's 287 mm here too, which lies off a 279.4 mm sheet; taken
    // instead 10 mm above the bottom edge, as on A3, with A3's 15 mm left margin.
    HpglPaper { name: "tabloid", size_mm: (431.8, 279.4), clip_plu: (16640, 10365), origin_mm: (15.0, 269.4) },
];

// Estimated: the 7475A's A4 and A3 (the 7550A manual's table was not available; measure before relying on margins).
const HP7550A_PAPERS: &[HpglPaper] = &[HP7475A_PAPERS[0], HP7475A_PAPERS[2]];

// Units: [DXY-CRM] (0.025 mm in RD-GL I). Range 416 × 276 mm and its centring on A3: estimated.
const DXY1300_PAPERS: &[HpglPaper] =
    &[HpglPaper { name: "a3", size_mm: (420.0, 297.0), clip_plu: (16640, 11040), origin_mm: (2.0, 286.5) }];

/// Every known device, the 7475A first (the default).
pub const DEVICES: &[HpglDevice] = &[
    HpglDevice {
        id: "7475a",
        name: "HP 7475A",
        pens: 6,                 // the six-pen carousel (Wikipedia, "HP 7470": the 7475 has six pens)
        max_velocity_cm_s: 38.1, // 15 in/s, HP's figure, as recorded before (not re-checked)
        papers: HP7475A_PAPERS,
        identity: "7475A", // the model number, as `OI` answers on HP's plotters ([KC-GL] for the 7550A)
        buffer_bytes: 1024, // what `ESC.L` reports by default, as recorded before (not re-checked)
        accel_g: 2.0,      // estimated: the figure recorded for the 7470A mechanism
    },
    HpglDevice {
        id: "7550a",
        name: "HP 7550A",
        pens: 8,                 // [7550A-notes]
        max_velocity_cm_s: 80.0, // HP's figure, as recorded before (not re-checked)
        papers: HP7550A_PAPERS,
        identity: "7550A",  // [KC-GL]
        buffer_bytes: 1024, // estimated: not found; the sender uses what `ESC.L` answers
        accel_g: 6.0,       // [7550A-notes]: "6g of acceleration" (was 4, unsourced)
    },
    HpglDevice {
        id: "dxy-1300",
        name: "Roland DXY-1300",
        pens: 8,                 // as recorded before (not re-checked)
        max_velocity_cm_s: 42.0, // estimated (not in the command reference)
        papers: DXY1300_PAPERS,
        identity: "DXY-1300", // estimated: the model name (the command reference's `OI` answer was not found)
        buffer_bytes: 1024,   // [DXY-CRM] §5.4.1: `ESC.L` answers 1024
        accel_g: 1.0,         // estimated: gentle, so the time estimate errs long
    },
    HpglDevice {
        id: "generic",
        name: "generic HP-GL plotter",
        pens: 8,                 // estimated: the common carousel size
        max_velocity_cm_s: 38.1, // estimated: HP-GL's customary top `VS`
        papers: &[],
        identity: "HP-GL", // estimated: what the model answers to `OI`
        buffer_bytes: 256, // estimated: small on purpose, so the sender stays careful
        accel_g: 1.0,      // estimated: gentle, so the time estimate errs long
    },
];

/// The device called `id` (case-insensitive; `hp7475a` and `7475a` both name the 7475A).
pub fn device(id: &str) -> Option<&'static HpglDevice> {
    let id = id.trim().to_ascii_lowercase();
    let id = id.strip_prefix("hp").unwrap_or(&id);
    DEVICES.iter().find(|d| d.id == id || d.id.replace('-', "") == id)
}

/// The names `--hpgl-device` accepts, for messages.
pub fn device_names() -> String {
    DEVICES.iter().map(|d| d.id).collect::<Vec<_>>().join(", ")
}

impl HpglPaper {
    /// The sheet of the generic device: a page of `width_mm` × `height_mm` whose lower-left corner is plu (0, 0).
    pub fn generic(width_mm: f64, height_mm: f64) -> HpglPaper {
        let plu = |mm: f64| mm_to_plu(mm.max(0.0)).unwrap_or(i32::MAX);
        HpglPaper {
            name: "page",
            size_mm: (width_mm, height_mm),
            clip_plu: (plu(width_mm), plu(height_mm)),
            origin_mm: (0.0, height_mm),
        }
    }

    /// Page millimetres (Y down, from the sheet's top-left) to plotter units, each coordinate rounded once from
    /// the absolute position (so equal page points give equal plotter points and nothing drifts); `None` when a
    /// coordinate does not fit an `i32`.
    pub fn to_plu(&self, x_mm: f64, y_mm: f64) -> Option<(i32, i32)> {
        Some((mm_to_plu(x_mm - self.origin_mm.0)?, mm_to_plu(self.origin_mm.1 - y_mm)?))
    }

    /// Plotter units back to page millimetres (the inverse of [`HpglPaper::to_plu`] before rounding).
    pub fn to_page(&self, x_plu: f64, y_plu: f64) -> (f64, f64) {
        (self.origin_mm.0 + x_plu / PLU_PER_MM, self.origin_mm.1 - y_plu / PLU_PER_MM)
    }

    /// Whether the plotter point lies inside the hard-clip rectangle.
    pub fn holds(&self, (x, y): (i32, i32)) -> bool {
        (0..=self.clip_plu.0).contains(&x) && (0..=self.clip_plu.1).contains(&y)
    }

    /// The hard-clip rectangle's size, mm.
    pub fn area_mm(&self) -> (f64, f64) {
        (f64::from(self.clip_plu.0) / PLU_PER_MM, f64::from(self.clip_plu.1) / PLU_PER_MM)
    }
}

impl HpglDevice {
    /// The paper called `name` (case-insensitive; `ansi_a`/`a` mean letter, `ansi_b`/`b` tabloid).
    pub fn paper(&self, name: &str) -> Option<&'static HpglPaper> {
        let name = match name.trim().to_ascii_lowercase().as_str() {
            "a" | "ansi_a" => "letter".to_string(),
            "b" | "ansi_b" => "tabloid".to_string(),
            other => other.to_string(),
        };
        self.papers.iter().find(|p| p.name == name)
    }

    /// The names of its papers, for messages.
    pub fn paper_names(&self) -> String {
        self.papers.iter().map(|p| p.name).collect::<Vec<_>>().join(", ")
    }
}

fn mm_to_plu(mm: f64) -> Option<i32> {
    let v = (mm * PLU_PER_MM).round();
    if v.is_finite() && v.abs() <= f64::from(i32::MAX) {
        // In range and integral, checked just above.
        #[allow(clippy::cast_possible_truncation)]
        Some(v as i32)
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn devices_and_papers_by_name() {
        assert_eq!(device("7475A").map(|d| d.pens), Some(6));
        assert_eq!(device("hp7475a").map(|d| d.id), Some("7475a"));
        assert_eq!(device("7550a").map(|d| d.pens), Some(8));
        assert_eq!(device("dxy1300").map(|d| d.id), Some("dxy-1300"));
        assert_eq!(device("DXY-1300").map(|d| d.pens), Some(8));
        assert!(device("7470b").is_none());
        let hp = device("7475a").unwrap();
        assert_eq!(hp.paper("A4").map(|p| p.clip_plu), Some((11040, 7721)));
        assert_eq!(hp.paper("ansi_b").map(|p| p.name), Some("tabloid"));
        assert_eq!(hp.paper_names(), "a4, letter, a3, tabloid");
    }

    /// On the 7475A's A4 sheet plu (0, 0) lies 10 mm from the left edge and 206 mm down: page point (10, 206)
    /// is (0, 0), (20, 196) is (400, 400), and 0.0124 mm (0.496 units) rounds to 0 while 0.02 mm (0.8 units) rounds to 1.
    #[test]
    fn page_to_plotter_units_flips_y_and_rounds_once() {
        let a4 = device("7475a").unwrap().paper("a4").unwrap();
        assert_eq!(a4.to_plu(10.0, 206.0), Some((0, 0)));
        assert_eq!(a4.to_plu(20.0, 196.0), Some((400, 400)));
        assert_eq!(a4.to_plu(10.0124, 206.02), Some((0, -1)));
        assert_eq!(a4.to_page(400.0, 400.0), (20.0, 196.0));
        assert!(a4.holds((11040, 7721)) && !a4.holds((11041, 0)) && !a4.holds((0, -1)));
        assert_eq!(a4.area_mm(), (276.0, 193.025));
        assert_eq!(a4.to_plu(1e300, 0.0), None);
        let g = HpglPaper::generic(100.0, 50.0);
        assert_eq!(g.clip_plu, (4000, 2000));
        assert_eq!(g.to_plu(0.0, 50.0), Some((0, 0)));
        assert_eq!(g.to_plu(100.0, 0.0), Some((4000, 2000)));
    }

    /// The figures the sources give, pinned: 0.025 mm units; the 7475A's plotting ranges per paper as its
    /// Interfacing and Programming Manual lists them; the DXY-1300's 1024-byte buffer (its command reference's
    /// `ESC.L` answer); the 7550A's 8 pens and 6 g.
    #[test]
    fn documented_figures() {
        assert_eq!(PLU_PER_MM, 40.0);
        assert_eq!(1.0 / PLU_PER_MM, 0.025);
        let hp = device("7475a").unwrap();
        let ranges: Vec<(&str, (i32, i32))> = hp.papers.iter().map(|p| (p.name, p.clip_plu)).collect();
        assert_eq!(
            ranges,
            [("a4", (11040, 7721)), ("letter", (10365, 7962)), ("a3", (16158, 11040)), ("tabloid", (16640, 10365))]
        );
        // 16158 units = 403.95 mm, 11040 = 276 mm: the A3 range by hand.
        assert_eq!(hp.paper("a3").unwrap().area_mm(), (403.95, 276.0));
        assert_eq!((hp.pens, hp.buffer_bytes, hp.identity), (6, 1024, "7475A"));
        let dxy = device("dxy-1300").unwrap();
        assert_eq!((dxy.buffer_bytes, dxy.pens), (1024, 8));
        let hp7550 = device("7550a").unwrap();
        assert_eq!((hp7550.pens, hp7550.accel_g, hp7550.identity), (8, 6.0, "7550A"));
    }

    /// Every hard-clip rectangle, placed at its origin, lies on its sheet: a range or an origin copied wrong
    /// (say the A3 range on an A4 sheet) would reach past the paper's edge.
    #[test]
    fn every_plotting_range_lies_on_its_sheet() {
        for d in DEVICES {
            for p in d.papers {
                let (w, h) = p.area_mm();
                let (x0, y0) = p.origin_mm;
                assert!(x0 >= 0.0 && x0 + w <= p.size_mm.0, "{} {}: x {x0} + {w} past {}", d.id, p.name, p.size_mm.0);
                assert!(y0 <= p.size_mm.1 && y0 - h >= 0.0, "{} {}: y {y0} - {h} off the sheet", d.id, p.name);
            }
        }
    }
}
