//! HP-GL export of a drawing, for vintage pen plotters (the HP 7475A and kin, see
//! [`crate::geometry::hpgl_devices`]).
//!
//! The program is plain HP-GL (the subset every HP-GL plotter since the 7470A understands):
//! - `IN;` resets the plotter, `IW0,0,X,Y;` sets the clip window to the sheet's hard-clip rectangle;
//! - each layer draws with a carousel pen: `SP n;` selects it and `VS v;` sets its speed in cm/s (the layer's
//!   drawing feed from the profile's pen table, capped at the device's top speed);
//! - each stroke is `PU x,y;` to its start, then `PD` with the rest of its points as a coordinate list, split so
//!   that no line is longer than [`MAX_LINE`] characters (small plotter buffers, line-based senders);
//! - the program ends with `PU;SP0;`: the pen lifted and put back in the carousel.
//!
//! Coordinates are absolute integers in plotter units: each page point is converted once, by rounding
//! ([`HpglPaper::to_plu`]), so the plot is drift-free and a closed path closes exactly. Y is flipped (HP-GL's Y
//! runs up the sheet). Pens: the distinct pens of the layers (as the profile's pen table tells them apart) take
//! carousel slots 1, 2, … in order of first use; when there are more pens than slots the numbering wraps (pen
//! 7 of a 6-pen 7475A goes in slot 1 again) and a warning names every layer that shares a slot, since the pens
//! must then be changed by hand between layers. A point outside the sheet's hard-clip rectangle is an error
//! naming it: the plotter would clip it silently.

use std::fmt::Write as _;

use super::gcode_out::fmt_mm;
use crate::config::pens::{self, LayerPen};
use crate::geometry::hpgl_devices::{HpglDevice, HpglPaper};
use crate::{Drawing, MachineProfile};

/// Longest line written, characters (without the newline).
pub const MAX_LINE: usize = 80;

/// Why a drawing cannot be written as HP-GL for a device.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum HpglExportError {
    /// A point lies outside the reachable area of the sheet.
    #[error(
        "layer {layer:?}, path {path}, point {point}: ({x_mm:.3}, {y_mm:.3}) mm lies outside the {device}'s {paper} \
         plotting area ({w} × {h} mm from {l} mm, {t} mm); move or shrink the drawing (--fit, --translate) or \
         pick a larger --hpgl-paper",
        w = fmt_mm(*.width_mm, 3),
        h = fmt_mm(*.height_mm, 3),
        l = fmt_mm(*.left_mm, 3),
        t = fmt_mm(*.top_mm, 3)
    )]
    OutsideArea {
        /// Layer name.
        layer: String,
        /// Path index within the layer (0-based).
        path: usize,
        /// Point index within the path (0-based).
        point: usize,
        /// Page x, mm.
        x_mm: f64,
        /// Page y, mm.
        y_mm: f64,
        /// Device name.
        device: &'static str,
        /// Paper name.
        paper: &'static str,
        /// Width of the plotting area, mm.
        width_mm: f64,
        /// Height of the plotting area, mm.
        height_mm: f64,
        /// Left edge of the plotting area on the page, mm.
        left_mm: f64,
        /// Top edge of the plotting area on the page, mm.
        top_mm: f64,
    },
}

/// An HP-GL program and what the export had to say about it.
#[derive(Debug, Clone, PartialEq)]
pub struct HpglProgram {
    /// The program text.
    pub text: String,
    /// The carousel slot (1-based) of each layer, in layer order.
    pub layer_slots: Vec<u8>,
    /// Things the user must know (shared carousel slots, capped speeds).
    pub warnings: Vec<String>,
}

/// Write `drawing` (page mm) as HP-GL for `device` with `paper` loaded; `profile` gives each layer's pen and speed.
pub fn export(
    profile: &MachineProfile,
    drawing: &Drawing,
    device: &HpglDevice,
    paper: &HpglPaper,
) -> Result<HpglProgram, HpglExportError> {
    let mut warnings = Vec::new();
    let (layer_slots, pens) = assign_slots(profile, drawing, device, &mut warnings);
    let mut out = String::new();
    let _ = writeln!(out, "IN;");
    let _ = writeln!(out, "IW0,0,{},{};", paper.clip_plu.0, paper.clip_plu.1);
    let mut current: Option<(u8, String)> = None;
    let mut capped = false;
    for (li, layer) in drawing.layers.iter().enumerate() {
        let velocity = pens[li].draw_feed_mm_s / 10.0;
        capped |= velocity > device.max_velocity_cm_s;
        let velocity = fmt_velocity(velocity.clamp(0.1, device.max_velocity_cm_s));
        let wanted = (layer_slots[li], velocity);
        for (pi, path) in layer.paths.iter().enumerate() {
            let mut points: Vec<(i32, i32)> = Vec::with_capacity(path.points.len());
            for (i, p) in path.points.iter().enumerate() {
                let q = paper.to_plu(p.x, p.y).filter(|q| paper.holds(*q)).ok_or_else(|| {
                    let (width_mm, height_mm) = paper.area_mm();
                    let (left_mm, bottom_mm) = paper.origin_mm;
                    HpglExportError::OutsideArea {
                        layer: layer.name.clone(),
                        path: pi,
                        point: i,
                        x_mm: p.x,
                        y_mm: p.y,
                        device: device.name,
                        paper: paper.name,
                        width_mm,
                        height_mm,
                        left_mm,
                        top_mm: bottom_mm - height_mm,
                    }
                })?;
                // Repeated plotter points draw nothing; one is enough.
                if points.last() != Some(&q) {
                    points.push(q);
                }
            }
            let Some(&first) = points.first() else { continue };
            if current.as_ref() != Some(&wanted) {
                if current.as_ref().map(|c| c.0) != Some(wanted.0) {
                    let _ = writeln!(out, "PU;SP{};", wanted.0);
                }
                let _ = writeln!(out, "VS{};", wanted.1);
                current = Some(wanted.clone());
            }
            let _ = writeln!(out, "PU{},{};", first.0, first.1);
            // A single point is a dot: the pen goes down where it is.
            let rest = if points.len() == 1 { &points[..] } else { &points[1..] };
            write_list(&mut out, "PD", rest);
        }
    }
    let _ = writeln!(out, "PU;SP0;");
    if capped {
        warnings
            .push(format!("pen speeds above the {}'s {} cm/s are capped at it", device.name, device.max_velocity_cm_s));
    }
    Ok(HpglProgram { text: out, layer_slots, warnings })
}

/// Carousel slots for the layers' pens (see the module docs), and each layer's resolved pen.
fn assign_slots(
    profile: &MachineProfile,
    drawing: &Drawing,
    device: &HpglDevice,
    warnings: &mut Vec<String>,
) -> (Vec<u8>, Vec<LayerPen>) {
    let pens: Vec<LayerPen> = drawing.layers.iter().map(|l| pens::resolve(profile, &l.name, &l.pen)).collect();
    let mut distinct: Vec<usize> = Vec::new(); // layer index of each distinct pen's first use
    let mut slots = Vec::with_capacity(pens.len());
    let carousel = usize::from(device.pens.max(1));
    for (li, pen) in pens.iter().enumerate() {
        let k = distinct.iter().position(|&f| pens[f].same_pen(pen)).unwrap_or_else(|| {
            distinct.push(li);
            distinct.len() - 1
        });
        // k % carousel < carousel ≤ 255.
        slots.push(u8::try_from(k % carousel + 1).unwrap_or(1));
    }
    if distinct.len() > carousel {
        let mut shared = Vec::new();
        for slot in 1..=device.pens {
            let users: Vec<String> = distinct
                .iter()
                .filter(|&&f| slots[f] == slot)
                .map(|&f| format!("{:?} ({})", drawing.layers[f].name, pens[f].label()))
                .collect();
            if users.len() > 1 {
                shared.push(format!("slot {slot}: {}", users.join(", then ")));
            }
        }
        warnings.push(format!(
            "{} pens but the {} holds {}: pens share carousel slots, change them by hand when the plot reaches \
             them — {}",
            distinct.len(),
            device.name,
            device.pens,
            shared.join("; ")
        ));
    }
    (slots, pens)
}

/// `VS` parameter: cm/s with at most one decimal.
fn fmt_velocity(v: f64) -> String {
    fmt_mm(v, 1)
}

/// Write `cmd` with the coordinate list `points`, as several instructions when one line would exceed
/// [`MAX_LINE`] characters.
fn write_list(out: &mut String, cmd: &str, points: &[(i32, i32)]) {
    let mut line = String::new();
    for (x, y) in points {
        let pair = format!("{x},{y}");
        if !line.is_empty() && line.len() + 1 + pair.len() + 1 > MAX_LINE {
            let _ = writeln!(out, "{line};");
            line.clear();
        }
        if line.is_empty() {
            line.push_str(cmd);
        } else {
            line.push(',');
        }
        line.push_str(&pair);
    }
    if !line.is_empty() {
        let _ = writeln!(out, "{line};");
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::hpgl_devices::device;
    use crate::{Layer, Pen, Polyline, Rgb};
    use kurbo::Point;

    fn hp7475a_a4() -> (&'static HpglDevice, &'static HpglPaper) {
        let d = device("7475a").unwrap();
        (d, d.paper("a4").unwrap())
    }

    fn layer(name: &str, color: Rgb, paths: Vec<Polyline>) -> Layer {
        Layer { name: name.into(), pen: Pen { color, width_mm: 0.3 }, paths }
    }

    fn square(x: f64, y: f64, side: f64) -> Polyline {
        let p = |dx: f64, dy: f64| Point::new(x + dx, y + dy);
        Polyline::new(vec![p(0.0, 0.0), p(side, 0.0), p(side, side), p(0.0, side), p(0.0, 0.0)])
    }

    /// A 10 mm square with its top-left corner at page (30, 50) mm on A4 in a 7475A: plu (0, 0) sits at page
    /// (10, 206), so x = (30 − 10)·40 = 800 and (40 − 10)·40 = 1200; y = (206 − 50)·40 = 6240 at the top edge and
    /// (206 − 60)·40 = 5840 at the bottom. The default profile draws at 60 mm/s = 6 cm/s.
    #[test]
    fn square_on_a4_gives_exact_plotter_units() {
        let (d, a4) = hp7475a_a4();
        let p = MachineProfile::default_plotter();
        let drawing = Drawing::single_layer("ink", vec![square(30.0, 50.0, 10.0)]);
        let prog = export(&p, &drawing, d, a4).unwrap();
        assert_eq!(
            prog.text.lines().collect::<Vec<_>>(),
            [
                "IN;",
                "IW0,0,11040,7721;",
                "PU;SP1;",
                "VS6;",
                "PU800,6240;",
                "PD1200,6240,1200,5840,800,5840,800,6240;",
                "PU;SP0;"
            ]
        );
        assert_eq!(prog.layer_slots, [1]);
        assert!(prog.warnings.is_empty());
    }

    /// Eight layers in eight colours on a 6-pen 7475A: slots 1–6, then 1 and 2 again, with a warning naming the
    /// shared slots. Two layers in the same colour share a pen and a slot without a warning.
    #[test]
    fn layers_map_to_carousel_slots_and_wrap() {
        let (d, a4) = hp7475a_a4();
        let mut p = MachineProfile::default_plotter();
        p.pens.clear();
        let line = Polyline::new(vec![Point::new(20.0, 20.0), Point::new(30.0, 20.0)]);
        let layers: Vec<Layer> =
            (0u8..8).map(|i| layer(&format!("l{i}"), Rgb(i * 30, 0, 0), vec![line.clone()])).collect();
        let prog = export(&p, &Drawing { layers, page_mm: None }, d, a4).unwrap();
        assert_eq!(prog.layer_slots, [1, 2, 3, 4, 5, 6, 1, 2]);
        let selects: Vec<&str> = prog.text.lines().filter(|l| l.contains("SP")).collect();
        assert_eq!(
            selects,
            ["PU;SP1;", "PU;SP2;", "PU;SP3;", "PU;SP4;", "PU;SP5;", "PU;SP6;", "PU;SP1;", "PU;SP2;", "PU;SP0;"]
        );
        assert_eq!(prog.warnings.len(), 1, "{:?}", prog.warnings);
        let w = &prog.warnings[0];
        assert!(w.starts_with("8 pens but the HP 7475A holds 6"), "{w}");
        assert!(w.contains("slot 1: \"l0\" (l0 (#000000)), then \"l6\" (l6 (#b40000))"), "{w}");
        assert!(w.contains("slot 2: \"l1\"") && !w.contains("slot 3:"), "{w}");

        let same = vec![
            layer("a", Rgb::BLACK, vec![line.clone()]),
            layer("b", Rgb(255, 0, 0), vec![line.clone()]),
            layer("c", Rgb::BLACK, vec![line.clone()]),
        ];
        let prog = export(&p, &Drawing { layers: same, page_mm: None }, d, a4).unwrap();
        assert_eq!(prog.layer_slots, [1, 2, 1]);
        assert!(prog.warnings.is_empty());
    }

    #[test]
    fn speed_is_capped_at_the_device_maximum() {
        let (d, a4) = hp7475a_a4();
        let mut p = MachineProfile::default_plotter();
        p.pens.clear();
        p.pen.draw_feed_mm_s = 500.0;
        let drawing = Drawing::single_layer("ink", vec![square(30.0, 50.0, 1.0)]);
        let prog = export(&p, &drawing, d, a4).unwrap();
        assert!(prog.text.contains("\nVS38.1;\n"), "{}", prog.text);
        assert_eq!(prog.warnings, ["pen speeds above the HP 7475A's 38.1 cm/s are capped at it"]);
    }

    /// 30 points at x = 1000 + 10·i plu: each pair is `x,6240` (9–10 characters); lines stay ≤ 80 characters and
    /// together list every point once, in order.
    #[test]
    fn long_strokes_are_split_into_bounded_lines() {
        let (d, a4) = hp7475a_a4();
        let p = MachineProfile::default_plotter();
        let pts: Vec<Point> = (0..30).map(|i| Point::new(35.0 + f64::from(i) * 0.25, 50.0)).collect();
        let drawing = Drawing::single_layer("ink", vec![Polyline::new(pts.clone())]);
        let prog = export(&p, &drawing, d, a4).unwrap();
        let pd: Vec<&str> = prog.text.lines().filter(|l| l.starts_with("PD")).collect();
        assert!(pd.len() > 1, "{}", prog.text);
        assert!(pd.iter().all(|l| l.len() <= MAX_LINE && l.ends_with(';')));
        let listed: Vec<String> = pd
            .iter()
            .flat_map(|l| l[2..l.len() - 1].split(','))
            .collect::<Vec<_>>()
            .chunks(2)
            .map(|c| c.join(","))
            .collect();
        let want: Vec<String> = (1..30).map(|i| format!("{},6240", 1000 + i * 10)).collect();
        assert_eq!(listed, want);
    }

    #[test]
    fn a_point_off_the_sheet_is_an_error_naming_it() {
        let (d, a4) = hp7475a_a4();
        let p = MachineProfile::default_plotter();
        let off = Polyline::new(vec![Point::new(20.0, 20.0), Point::new(290.0, 20.0)]);
        let drawing = Drawing::single_layer("ink", vec![square(30.0, 50.0, 1.0), off]);
        let e = export(&p, &drawing, d, a4).unwrap_err().to_string();
        assert!(e.starts_with("layer \"ink\", path 1, point 1: (290.000, 20.000) mm lies outside"), "{e}");
        assert!(e.contains("HP 7475A's a4 plotting area (276 × 193.025 mm from 10 mm, 12.975 mm)"), "{e}");
    }
}
