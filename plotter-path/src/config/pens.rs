//! Pens: the [`Pen`] a layer is drawn with, which pen of the profile's table draws which layer, and where the plot
//! stops for a pen change.
//!
//! A layer carries its pen (colour and width from the input, its name from the Inkscape layer or colour). The
//! profile's pen table (`[[pens]]`, [`crate::config::profile::PenSpec`]) names the physical pens: a layer is drawn
//! with the table pen whose name equals the layer's name (case-insensitive), else the one whose colour equals the
//! layer's colour. Without a match (or without a table) the layer's colour is its pen, with the profile's `[pen]`
//! values. Two consecutive layers need a pen change exactly when they resolve to different pens.

use crate::config::color::{Rgb, parse_hex_color};
use crate::config::profile::{MachineProfile, PenSpec};

/// The pen a layer is drawn with.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pen {
    /// Ink colour, used by previews and by colour-based layer selection.
    pub color: Rgb,
    /// Nib width in millimetres (previews draw strokes this wide).
    pub width_mm: f64,
}

impl Default for Pen {
    fn default() -> Self {
        Pen { color: Rgb::BLACK, width_mm: 0.3 }
    }
}

/// The pen a layer is drawn with, resolved against the profile.
#[derive(Debug, Clone, PartialEq)]
pub struct LayerPen {
    /// Index in the profile's pen table, `None` when the layer matched no table pen.
    pub table: Option<usize>,
    /// What the user is asked to load: the table pen's name, else the layer's name and colour.
    pub name: String,
    /// Ink colour.
    pub color: Rgb,
    /// Nib width, mm.
    pub width_mm: f64,
    /// Pen-down Z, mm (Z pens).
    pub down_z_mm: f64,
    /// Pen-down servo angle, degrees (servo pens).
    pub servo_down_deg: f64,
    /// Drawing feed, mm/s.
    pub draw_feed_mm_s: f64,
}

impl LayerPen {
    /// Whether `other` is the same physical pen (same table entry, or the same colour when neither is in the
    /// table).
    pub fn same_pen(&self, other: &LayerPen) -> bool {
        match (self.table, other.table) {
            (Some(a), Some(b)) => a == b,
            (None, None) => self.color == other.color,
            _ => false,
        }
    }

    /// `name (#rrggbb)`, as shown to the user.
    pub fn label(&self) -> String {
        format!("{} ({})", self.name, self.color.to_hex())
    }
}

/// The pen-table entry for a layer named `name` whose colour is `color`: the pen of that name
/// (case-insensitive), else the pen of that colour.
pub fn table_index(pens: &[PenSpec], name: &str, color: Rgb) -> Option<usize> {
    let by_name = pens.iter().position(|p| p.name.trim().eq_ignore_ascii_case(name.trim()));
    by_name.or_else(|| pens.iter().position(|p| p.color.as_deref().and_then(parse_hex_color) == Some(color)))
}

/// Resolve the pen of a layer named `name` drawn with `pen`; the name's `+H` and `+S` codes
/// ([`crate::config::layer_codes`]) then set its pen-down height and drawing speed for this layer.
pub fn resolve(profile: &MachineProfile, name: &str, pen: &Pen) -> LayerPen {
    let mut resolved = resolve_table(profile, name, pen);
    let codes = crate::config::layer_codes::LayerCodes::parse(name);
    if let Some(f) = codes.down_fraction() {
        let p = &profile.pen;
        resolved.down_z_mm += f * (p.up_z_mm - resolved.down_z_mm);
        resolved.servo_down_deg += f * (p.servo_up_deg - resolved.servo_down_deg);
    }
    if let Some(f) = codes.speed_factor() {
        resolved.draw_feed_mm_s *= f;
    }
    resolved
}

/// The pen of a layer named `name` drawn with `pen`, from the pen table or the profile's `[pen]`.
fn resolve_table(profile: &MachineProfile, name: &str, pen: &Pen) -> LayerPen {
    let defaults = &profile.pen;
    match table_index(&profile.pens, name, pen.color) {
        Some(i) => {
            let t = &profile.pens[i];
            LayerPen {
                table: Some(i),
                name: t.name.clone(),
                color: t.color.as_deref().and_then(parse_hex_color).unwrap_or(pen.color),
                width_mm: t.width_mm.unwrap_or(pen.width_mm),
                down_z_mm: t.down_z_mm.unwrap_or(defaults.down_z_mm),
                servo_down_deg: t.servo_down_deg.unwrap_or(defaults.servo_down_deg),
                draw_feed_mm_s: t.draw_feed_mm_s.unwrap_or(defaults.draw_feed_mm_s),
            }
        }
        None => LayerPen {
            table: None,
            name: if name.is_empty() { pen.color.to_hex() } else { name.to_string() },
            color: pen.color,
            width_mm: pen.width_mm,
            down_z_mm: defaults.down_z_mm,
            servo_down_deg: defaults.servo_down_deg,
            draw_feed_mm_s: defaults.draw_feed_mm_s,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn profile_with_pens() -> MachineProfile {
        let mut p = MachineProfile::default_plotter();
        p.pens = vec![
            PenSpec {
                name: "Fine black".into(),
                color: Some("#000000".into()),
                width_mm: Some(0.1),
                down_z_mm: Some(0.5),
                servo_down_deg: None,
                draw_feed_mm_s: Some(20.0),
                hatch: None,
            },
            PenSpec {
                name: "red".into(),
                color: Some("#ff0000".into()),
                width_mm: None,
                down_z_mm: None,
                servo_down_deg: Some(10.0),
                draw_feed_mm_s: None,
                hatch: None,
            },
        ];
        p
    }

    #[test]
    fn layers_match_by_name_then_colour() {
        let p = profile_with_pens();
        let red = Pen { color: Rgb(255, 0, 0), width_mm: 0.4 };
        // The name wins over the colour.
        let l = resolve(&p, "FINE BLACK", &red);
        assert_eq!((l.table, l.down_z_mm, l.draw_feed_mm_s, l.width_mm), (Some(0), 0.5, 20.0, 0.1));
        let l = resolve(&p, "outline", &red);
        assert_eq!((l.table, l.name.as_str(), l.servo_down_deg), (Some(1), "red", 10.0));
        assert_eq!((l.down_z_mm, l.draw_feed_mm_s, l.width_mm), (0.0, 60.0, 0.4), "profile defaults, layer width");
        let l = resolve(&p, "sky", &Pen { color: Rgb(0, 0, 255), width_mm: 0.3 });
        assert_eq!((l.table, l.name.as_str()), (None, "sky"));
        assert_eq!(l.label(), "sky (#0000ff)");
    }

    #[test]
    fn same_pen_compares_table_entries_or_colours() {
        let p = MachineProfile::default_plotter();
        let a = resolve(&p, "a", &Pen { color: Rgb(1, 2, 3), width_mm: 0.3 });
        let b = resolve(&p, "b", &Pen { color: Rgb(1, 2, 3), width_mm: 0.5 });
        let c = resolve(&p, "a", &Pen { color: Rgb(1, 2, 4), width_mm: 0.3 });
        assert!(a.same_pen(&b) && !a.same_pen(&c));
        let q = profile_with_pens();
        let x = resolve(&q, "red", &Pen::default());
        let y = resolve(&q, "z", &Pen { color: Rgb(255, 0, 0), width_mm: 0.3 });
        assert!(x.same_pen(&y));
        assert!(!x.same_pen(&resolve(&q, "z", &Pen::default())), "table pen 0 (black) differs from red");
    }

    #[test]
    fn hex_colours() {
        assert_eq!(parse_hex_color("#FF8000"), Some(Rgb(255, 128, 0)));
        assert_eq!(parse_hex_color("00ff00"), Some(Rgb(0, 255, 0)));
        assert_eq!(parse_hex_color("#fff"), None);
        assert_eq!(parse_hex_color("#gg0000"), None);
    }
}
