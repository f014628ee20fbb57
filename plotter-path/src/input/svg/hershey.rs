//! Single-stroke (Hershey) glyphs for `--text single-stroke`.
//!
//! No crate on crates.io ships the Hershey font data (the `hershey` crate only parses the format and leaves the
//! data to the caller), so the data comes from Debian's `hershey-fonts-data` package, installed by the README's
//! setup and by `.ci/run` (`/usr/share/hershey-fonts/*.jhf`; its licence lets anyone use the data with the
//! acknowledgement that the Hershey fonts were created by Dr. A. V. Hershey at the U.S. National Bureau of
//! Standards, in the format made by James Hurt, Cognition, Inc.). The parser below is written from the format's
//! description: each glyph is a 5-column number, a 3-column vertex-pair count, then that many pairs of
//! characters, each coordinate being its character's code minus `'R'`; the first pair is the glyph's left and right
//! bounds, `" R"` lifts the pen; long glyphs continue on the following lines. The standard files hold the printable
//! ASCII characters 32 to 126 in order. Coordinates have Y down, capitals span −12 to 9 with the baseline at 9.

use std::path::{Path, PathBuf};

use kurbo::Point;

/// Where the fonts are looked for, in order (Debian's `hershey-fonts-data`).
pub const FONT_DIRS: [&str; 2] = ["/usr/share/hershey-fonts", "/usr/local/share/hershey-fonts"];

/// The font used: "Roman Simplex" (`rowmans.jhf`), one stroke per line, legible at small sizes.
pub const DEFAULT_FONT: &str = "rowmans.jhf";

/// Hershey units per em: the baseline-to-cap distance is 21 units, about 0.66 em as in common fonts.
pub const UNITS_PER_EM: f64 = 32.0;

/// Y of the baseline in Hershey units.
pub const BASELINE: f64 = 9.0;

/// One glyph: left and right bounds and its strokes (Hershey units, Y down).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Glyph {
    /// Left bound (the glyph's origin side).
    pub left: f64,
    /// Right bound.
    pub right: f64,
    /// Pen-down strokes.
    pub strokes: Vec<Vec<Point>>,
}

/// A Hershey font: glyphs for ASCII 32..=126.
#[derive(Debug, Clone, PartialEq)]
pub struct HersheyFont {
    glyphs: Vec<Glyph>,
}

impl HersheyFont {
    /// Find and load the default font from [`FONT_DIRS`].
    pub fn load_default() -> Result<HersheyFont, String> {
        let path =
            FONT_DIRS.iter().map(|d| Path::new(d).join(DEFAULT_FONT)).find(|p| p.is_file()).ok_or_else(|| {
                format!(
                    "single-stroke text needs the Hershey fonts: {DEFAULT_FONT} was not found in {} (install Debian's \
                 hershey-fonts-data)",
                    FONT_DIRS.join(", ")
                )
            })?;
        HersheyFont::load(&path)
    }

    /// Load a `.jhf` file.
    pub fn load(path: &PathBuf) -> Result<HersheyFont, String> {
        let text = std::fs::read_to_string(path).map_err(|e| format!("{}: cannot read: {e}", path.display()))?;
        HersheyFont::parse(&text).map_err(|e| format!("{}: {e}", path.display()))
    }

    /// Parse `.jhf` text.
    pub fn parse(text: &str) -> Result<HersheyFont, String> {
        let mut glyphs = Vec::new();
        let mut pending: Option<(usize, String, usize)> = None; // (pairs, data, line)
        for (i, line) in text.lines().enumerate() {
            let line = line.trim_end_matches('\r');
            if let Some((pairs, data, at)) = pending.as_mut() {
                data.push_str(line);
                if data.len() >= 2 * *pairs {
                    glyphs.push(parse_glyph(data, *pairs, *at)?);
                    pending = None;
                }
                continue;
            }
            if line.trim().is_empty() {
                continue;
            }
            let count = line
                .get(5..8)
                .and_then(|c| c.trim().parse::<usize>().ok())
                .ok_or_else(|| format!("line {}: no vertex count in columns 6-8", i + 1))?;
            let data = line.get(8..).unwrap_or("").to_owned();
            if data.len() >= 2 * count {
                glyphs.push(parse_glyph(&data, count, i + 1)?);
            } else {
                pending = Some((count, data, i + 1));
            }
        }
        if let Some((_, _, at)) = pending {
            return Err(format!("line {at}: glyph data ends early"));
        }
        if glyphs.len() < 95 {
            return Err(format!("{} glyphs, expected the 95 printable ASCII characters", glyphs.len()));
        }
        Ok(HersheyFont { glyphs })
    }

    /// The glyph for `c`; accented Latin letters are drawn as their base letter (the fonts are ASCII only), other
    /// characters outside printable ASCII get `?`.
    pub fn glyph(&self, c: char) -> &Glyph {
        let code = u32::from(fold_latin(c));
        let index = if (32..=126).contains(&code) { code - 32 } else { u32::from('?') - 32 };
        &self.glyphs[usize::try_from(index).unwrap_or(0)]
    }
}

/// The base letter of a Latin-1 accented letter (`é` → `e`), else `c` itself.
fn fold_latin(c: char) -> char {
    const FROM: &str = "ÀÁÂÃÄÅÇÈÉÊËÌÍÎÏÑÒÓÔÕÖØÙÚÛÜÝàáâãäåçèéêëìíîïñòóôõöøùúûüýÿ";
    const TO: &str = "AAAAAACEEEEIIIINOOOOOOUUUUYaaaaaaceeeeiiiinoooooouuuuyy";
    FROM.chars().position(|f| f == c).and_then(|i| TO.chars().nth(i)).unwrap_or(c)
}

fn parse_glyph(data: &str, pairs: usize, line: usize) -> Result<Glyph, String> {
    let bytes = data.as_bytes();
    if pairs == 0 || bytes.len() < 2 * pairs {
        return Err(format!("line {line}: glyph data ends early"));
    }
    let coord = |b: u8| f64::from(b) - f64::from(b'R');
    let mut glyph = Glyph { left: coord(bytes[0]), right: coord(bytes[1]), strokes: Vec::new() };
    let mut current: Vec<Point> = Vec::new();
    for k in 1..pairs {
        let (x, y) = (bytes[2 * k], bytes[2 * k + 1]);
        if x == b' ' && y == b'R' {
            if current.len() >= 2 {
                glyph.strokes.push(std::mem::take(&mut current));
            }
            current.clear();
            continue;
        }
        current.push(Point::new(coord(x), coord(y)));
    }
    if current.len() >= 2 {
        glyph.strokes.push(current);
    }
    Ok(glyph)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A made-up font of 95 glyphs: every glyph is "-" (one stroke from (-5,0) to (5,0)); "I" is a vertical bar
    /// written across a line break, "!" is a stem and a dot.
    fn fake_font() -> String {
        let mut s = String::new();
        for code in 32..=126u8 {
            match code {
                b'I' => s.push_str("12345  3MWRFR[\n"),
                b'!' => s.push_str("12345  6MWRFRT RRZRZ\n"),
                _ => s.push_str("12345  3MWMRWR\n"),
            }
        }
        s.replace("12345  3MWRFR[", "12345  3MW\nRFR[")
    }

    #[test]
    fn parses_strokes_bounds_and_wrapped_lines() {
        let font = HersheyFont::parse(&fake_font()).unwrap();
        let i = font.glyph('I');
        assert_eq!((i.left, i.right), (-5.0, 5.0));
        // 'F' − 'R' = −12 (cap height), '[' − 'R' = 9 (baseline).
        assert_eq!(i.strokes, vec![vec![Point::new(0.0, -12.0), Point::new(0.0, 9.0)]]);
        let bang = font.glyph('!');
        // The stem, and the dot as a zero-length stroke (a pen dab).
        assert_eq!(
            bang.strokes,
            vec![vec![Point::new(0.0, -12.0), Point::new(0.0, 2.0)], vec![Point::new(0.0, 8.0); 2]]
        );
        assert_eq!(font.glyph('€'), font.glyph('?'));
        assert_eq!(font.glyph('Ì'), font.glyph('I'));
        assert!(HersheyFont::parse("12345  3MW").unwrap_err().contains("ends early"));
        assert!(HersheyFont::parse("12345 xxMWRR").unwrap_err().contains("vertex count"));
    }

    #[test]
    fn debian_font_when_installed() {
        // The real file is a system package (installed by .ci/run); check its shape when present.
        if let Ok(font) = HersheyFont::load_default() {
            let l = font.glyph('L');
            // Roman Simplex "L": a vertical stem and the foot, two strokes from the cap line to the baseline.
            assert_eq!(l.strokes.len(), 2);
            let ys: Vec<f64> = l.strokes.iter().flatten().map(|p| p.y).collect();
            assert_eq!(ys.iter().copied().fold(f64::MAX, f64::min), -12.0);
            assert_eq!(ys.iter().copied().fold(f64::MIN, f64::max), BASELINE);
        }
    }
}
