//! Layer-name codes, as the AxiDraw software reads Inkscape layer labels (its "layer control" syntax), so that a
//! drawing prepared for an AxiDraw plots the same way here.
//!
//! Leading spaces are ignored. Then:
//! - `%` first: a **documentation layer** (notes, registration marks, instructions), never plotted; nothing else is
//!   read from its name.
//! - `!` first: the plot **pauses before the layer** (pen up), as if the user had asked for a pause there.
//! - A whole number next: the layer's **number**, which `--layers 1,3` selects by (several layers may share one).
//! - After the number (or at the start), any run of codes, letters in either case, each followed by a whole
//!   number: `+H<n>` the pen-down height for this layer, in per cent of the pen's range (0..=100, see
//!   [`LayerCodes::down_fraction`]); `+S<n>` the pen-down speed, in per cent of the pen's drawing speed
//!   (1..=110); `+D<n>` an extra delay after each pen drop in the layer, milliseconds (above 0). When a code is
//!   given twice, the last one counts. A value outside its range is left out with a [`LayerCodes::problems`]
//!   entry.
//! - Whatever follows the codes is the layer's own text (`"1+S50 outline"` → `" outline"`).
//!
//! The AxiDraw's pen-down height is a position of its servo between its two ends; a profile here knows a pen-up and
//! a pen-down position, so `+H` counts from the pen-down position (0 %) up to the pen-up position (100 %): `+H0`
//! is the profile's own pen-down height and `+H25` a quarter of the way up, a lighter touch.

/// What a layer's name asks for.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct LayerCodes {
    /// `%`: a documentation layer, never plotted.
    pub documentation: bool,
    /// `!`: pause before the layer.
    pub pause: bool,
    /// The leading whole number, if any.
    pub number: Option<u64>,
    /// `+H`: the pen-down height, per cent of the pen's range from its down position (0) to its up position
    /// (100).
    pub height_pct: Option<u8>,
    /// `+S`: the pen-down speed, per cent of the pen's drawing speed.
    pub speed_pct: Option<u8>,
    /// `+D`: an extra delay after each pen drop in the layer, milliseconds.
    pub delay_ms: Option<u32>,
    /// The name after the codes.
    pub text: String,
    /// Codes whose value is out of range, each said as a person reads it (they are left out).
    pub problems: Vec<String>,
}

/// The whole number at the start of `s` (ASCII digits) and what follows it; `None` when `s` starts otherwise or
/// the number does not fit a `u64`.
fn leading_number(s: &str) -> Option<(u64, &str)> {
    let end = s.find(|c: char| !c.is_ascii_digit()).unwrap_or(s.len());
    if end == 0 {
        return None;
    }
    s[..end].parse().ok().map(|n| (n, &s[end..]))
}

impl LayerCodes {
    /// Read the codes of the layer named `name`.
    pub fn parse(name: &str) -> LayerCodes {
        let mut codes = LayerCodes::default();
        let mut rest = name.trim_start();
        if let Some(doc) = rest.strip_prefix('%') {
            codes.documentation = true;
            codes.text = doc.to_string();
            return codes;
        }
        if let Some(after) = rest.strip_prefix('!') {
            codes.pause = true;
            rest = after;
        }
        if let Some((n, after)) = leading_number(rest) {
            codes.number = Some(n);
            rest = after;
        }
        while let Some(key) = rest.get(..2).map(str::to_ascii_lowercase) {
            if !matches!(key.as_str(), "+h" | "+s" | "+d") {
                break;
            }
            let Some((n, after)) = leading_number(&rest[2..]) else { break };
            let written = &rest[..rest.len() - after.len()];
            rest = after;
            let out_of = |range: &str| format!("{written} is outside {range}, so it is left out");
            match key.as_str() {
                "+h" => match u8::try_from(n).ok().filter(|v| *v <= 100) {
                    Some(v) => codes.height_pct = Some(v),
                    None => codes.problems.push(out_of("0..100 (% of the pen's range)")),
                },
                "+s" => match u8::try_from(n).ok().filter(|v| (1..=110).contains(v)) {
                    Some(v) => codes.speed_pct = Some(v),
                    None => codes.problems.push(out_of("1..110 (% of the drawing speed)")),
                },
                _ => match u32::try_from(n).ok().filter(|v| *v > 0) {
                    Some(v) => codes.delay_ms = Some(v),
                    None => codes.problems.push(out_of("1..4294967295 ms")),
                },
            }
        }
        codes.text = rest.to_string();
        codes
    }

    /// With `+H`: where the pen goes down, as a fraction of the way from the pen-down position (0) to the pen-up
    /// position (1).
    pub fn down_fraction(&self) -> Option<f64> {
        self.height_pct.map(|p| f64::from(p) / 100.0)
    }

    /// With `+S`: the factor on the drawing speed.
    pub fn speed_factor(&self) -> Option<f64> {
        self.speed_pct.map(|p| f64::from(p) / 100.0)
    }

    /// Whether `wanted` (an entry of `--layers`) selects this layer by its number: `wanted` is a whole number
    /// equal to the layer's.
    pub fn selected_by_number(&self, wanted: &str) -> bool {
        let w = wanted.trim();
        !w.is_empty() && w.bytes().all(|b| b.is_ascii_digit()) && w.parse::<u64>().ok() == self.number
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_read_as_the_axidraw_software_reads_them() {
        let c = LayerCodes::parse("  !3+s50+H20+d1500 inks");
        assert!(c.pause && !c.documentation);
        assert_eq!((c.number, c.speed_pct, c.height_pct, c.delay_ms), (Some(3), Some(50), Some(20), Some(1500)));
        assert_eq!(c.text, " inks");
        assert_eq!((c.down_fraction(), c.speed_factor()), (Some(0.2), Some(0.5)));
        // A documentation layer: nothing else is read.
        let d = LayerCodes::parse("%1+S50 notes");
        assert!(d.documentation && d.number.is_none() && d.speed_pct.is_none());
        assert_eq!(d.text, "1+S50 notes");
        // The last of a repeated code counts; codes stop at the first thing that is not one.
        let r = LayerCodes::parse("12+S30+S40 x+H10");
        assert_eq!((r.number, r.speed_pct, r.height_pct), (Some(12), Some(40), None));
        assert_eq!(r.text, " x+H10");
        // Codes without a number; a plain name.
        assert_eq!(LayerCodes::parse("+H40 light").height_pct, Some(40));
        let plain = LayerCodes::parse("outline 2");
        assert_eq!(plain, LayerCodes { text: "outline 2".into(), ..LayerCodes::default() });
        // A "+S" without a number ends the codes.
        assert_eq!(LayerCodes::parse("5+Sx").text, "+Sx");
    }

    #[test]
    fn values_out_of_range_are_left_out_and_said() {
        let c = LayerCodes::parse("1+H101+S0+D0+S120");
        assert_eq!((c.height_pct, c.speed_pct, c.delay_ms), (None, None, None));
        assert_eq!(
            c.problems,
            [
                "+H101 is outside 0..100 (% of the pen's range), so it is left out",
                "+S0 is outside 1..110 (% of the drawing speed), so it is left out",
                "+D0 is outside 1..4294967295 ms, so it is left out",
                "+S120 is outside 1..110 (% of the drawing speed), so it is left out",
            ]
        );
    }

    #[test]
    fn layers_are_selected_by_their_number() {
        let c = LayerCodes::parse("3 trees");
        assert!(c.selected_by_number("3") && c.selected_by_number(" 03"));
        assert!(!c.selected_by_number("4") && !c.selected_by_number("3 trees") && !c.selected_by_number(""));
        assert!(!LayerCodes::parse("trees").selected_by_number("3"));
    }
}
