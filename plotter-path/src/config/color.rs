//! Colours: an ink colour as the drawings and the pen table state it, and its `#rrggbb` form.

/// An RGB colour, 8 bits per channel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Rgb(pub u8, pub u8, pub u8);

impl Rgb {
    /// Black, the default pen colour.
    pub const BLACK: Rgb = Rgb(0, 0, 0);

    /// `#rrggbb` form, as used in SVG output.
    pub fn to_hex(self) -> String {
        format!("#{:02x}{:02x}{:02x}", self.0, self.1, self.2)
    }
}

/// Parse `#rrggbb` (or `rrggbb`).
pub fn parse_hex_color(s: &str) -> Option<Rgb> {
    let h = s.trim().strip_prefix('#').unwrap_or(s.trim());
    if h.len() != 6 || !h.is_ascii() {
        return None;
    }
    let byte = |i: usize| u8::from_str_radix(&h[i..i + 2], 16).ok();
    Some(Rgb(byte(0)?, byte(2)?, byte(4)?))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hex_colours_round_trip_and_bad_ones_are_refused() {
        assert_eq!(parse_hex_color("#ff8000"), Some(Rgb(255, 128, 0)));
        assert_eq!(parse_hex_color(" 0a0B0c "), Some(Rgb(10, 11, 12)));
        assert_eq!(Rgb(10, 11, 12).to_hex(), "#0a0b0c");
        for bad in ["#fff", "#gg0000", "#ff00000", "", "#ffé00"] {
            assert_eq!(parse_hex_color(bad), None, "{bad}");
        }
    }
}
