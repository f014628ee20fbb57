//! Import of HP-GL plot files (from this project's [`crate::output::hpgl_out`], vpype, CAD programs of the 1980s)
//! into a [`Drawing`].
//!
//! HP-GL is a stream of two-letter mnemonics, each followed by numbers separated by commas or spaces, ended by `;`
//! or by the next mnemonic. Drawn: `IN` and `DF` (reset: pen up, absolute), `SP n` (select pen n: each pen becomes
//! a layer `pen n`, in order of first use; `SP0` puts the pen away and what is "drawn" without a pen is dropped
//! with a warning; a file that never selects a pen draws with pen 1), `PU` / `PD` with or without coordinate
//! lists, `PA` / `PR` (absolute / relative). Coordinates are plotter units ([`PLU_PER_MM`] per mm).
//!
//! Not drawn, each with a warning naming the mnemonic, the index of its first use (commands are counted from 1)
//! and how often it appeared: labels (`LB`, its text skipped up to the terminator, `ETX` or the one `DT` sets),
//! circles, arcs, wedges and rectangles (`CI`, `AA`, `AR`, `EA`, `ER`, `EW`, `RA`, `RR`, `WG`), and any other
//! mnemonic, such as `LT` line types (drawn solid). Speeds (`VS`, `FS`, `VA`, `VN`) are accepted without a word:
//! the profile's speeds apply and the lines are the same; so is `PS` (paper size). A clip window (`IW`) is not applied; when points lie
//! outside the last one, a warning says how many. After a label or an arc the pen's position is not tracked,
//! so a relative move before the next absolute one is an error. `SC` with parameters (user-unit scaling) would
//! change every coordinate and is refused; device-control escapes (`ESC . x … :`) are skipped with a warning.
//!
//! Garbage (a byte that cannot start a mnemonic, a malformed number, an odd coordinate count) is an error naming
//! the file, the command index and its byte offset. Bounded work: every coordinate must lie within
//! ±[`MAX_COORD_MM`] and the file may produce at most [`MAX_POINTS`] points.
//!
//! Y is flipped back to our page (Y down) on a sheet: the one given, else the first known sheet
//! ([`crate::geometry::hpgl_devices::DEVICES`]) whose hard-clip rectangle equals the file's `IW` window (this
//! project's export writes one), else the first 7475A sheet that holds every point, else a generic page just
//! holding the drawing (with a warning).

use kurbo::Point;

use crate::geometry::hpgl_devices::{DEVICES, HpglPaper, PLU_PER_MM};
use crate::geometry::limits::{MAX_COORD_MM, MAX_POINTS};
use crate::{Drawing, Layer, Polyline, Rgb};

/// Longest number accepted, characters.
const MAX_NUMBER_LEN: usize = 40;

/// Errors importing HP-GL.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum HpglError {
    /// The file does not parse, or asks for something that cannot be drawn faithfully.
    #[error("{origin}: command {command} (byte {offset}): {message}")]
    Malformed {
        /// File name.
        origin: String,
        /// 1-based index of the command.
        command: usize,
        /// Byte offset of the command in the file.
        offset: usize,
        /// What is wrong.
        message: String,
    },
}

/// Something the importer skipped; the drawing is still usable.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct HpglWarning {
    /// 1-based index of the first command concerned, 0 when it concerns the whole file.
    pub command: usize,
    /// The mnemonic (`LB`), or empty.
    pub mnemonic: String,
    /// How many times it happened.
    pub count: usize,
    /// What was skipped.
    pub message: String,
}

impl std::fmt::Display for HpglWarning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.command > 0 {
            write!(f, "command {} ({}): ", self.command, self.mnemonic)?;
        }
        write!(f, "{}", self.message)?;
        if self.count > 1 { write!(f, " ({} times)", self.count) } else { Ok(()) }
    }
}

/// The result of an import.
#[derive(Debug, Clone, PartialEq)]
pub struct ImportedHpgl {
    /// The pen-down strokes in page millimetres, one layer per pen.
    pub drawing: Drawing,
    /// The sheet the plotter units were placed on.
    pub paper: HpglPaper,
    /// Everything skipped.
    pub warnings: Vec<HpglWarning>,
}

/// A stroke in plotter units.
type PluPath = Vec<(f64, f64)>;

/// Parser and plotter state, coordinates in plotter units.
struct State<'a> {
    origin: &'a str,
    command: usize,
    offset: usize,
    mnemonic: String,
    absolute: bool,
    down: bool,
    /// `None` until the first `SP`; `Some(0)` when the pen is put away.
    pen: Option<u32>,
    /// `None` after a command that moves the pen where this importer does not follow (labels, arcs).
    pos: Option<(f64, f64)>,
    path: Vec<(f64, f64)>,
    /// (pen, paths) in order of first use.
    layers: Vec<(u32, Vec<PluPath>)>,
    points: usize,
    /// The last clip window and the index of its command.
    iw: Option<([f64; 4], usize)>,
    warnings: Vec<HpglWarning>,
}

impl State<'_> {
    fn error(&self, message: impl Into<String>) -> HpglError {
        HpglError::Malformed {
            origin: self.origin.to_string(),
            command: self.command,
            offset: self.offset,
            message: message.into(),
        }
    }

    /// Record a warning for the current mnemonic, counted with the earlier ones of the same message.
    fn warn(&mut self, message: String) {
        if let Some(w) = self.warnings.iter_mut().find(|w| w.mnemonic == self.mnemonic && w.message == message) {
            w.count += 1;
        } else {
            self.warnings.push(HpglWarning {
                command: self.command,
                mnemonic: self.mnemonic.clone(),
                count: 1,
                message,
            });
        }
    }

    fn finish_path(&mut self) {
        let mut path = std::mem::take(&mut self.path);
        if path.is_empty() {
            return;
        }
        if path.len() == 1 {
            // The pen went down and up again in place: a dot.
            path.push(path[0]);
        }
        let pen = self.pen.unwrap_or(1);
        match self.layers.iter_mut().find(|(p, _)| *p == pen) {
            Some((_, paths)) => paths.push(path),
            None => self.layers.push((pen, vec![path])),
        }
    }

    fn pen_down(&mut self) {
        self.down = true;
        if self.pen == Some(0) {
            self.warn("pen-down moves with no pen selected (after SP0) are not drawn".into());
            return;
        }
        if self.path.is_empty()
            && let Some(p) = self.pos
        {
            self.push(p);
        }
    }

    fn pen_up(&mut self) {
        self.down = false;
        self.finish_path();
    }

    fn push(&mut self, p: (f64, f64)) {
        self.path.push(p);
        self.points += 1;
    }

    fn move_to(&mut self, x: f64, y: f64) -> Result<(), HpglError> {
        let target = if self.absolute {
            (x, y)
        } else {
            let (px, py) = self.pos.ok_or_else(|| {
                self.error(
                    "relative move after a label or arc, whose end this importer does not follow; use an absolute \
                     move (PA) first",
                )
            })?;
            (px + x, py + y)
        };
        let limit = MAX_COORD_MM * PLU_PER_MM;
        if !(target.0.abs() <= limit && target.1.abs() <= limit) {
            return Err(self.error(format!(
                "target ({}, {}) plotter units is beyond ±{MAX_COORD_MM} mm (1 km); no plotter draws that",
                target.0, target.1
            )));
        }
        if self.down && self.pen != Some(0) {
            if self.path.is_empty() {
                // Pen down at an unknown position (after a label): the stroke starts at its first known point.
                if let Some(p) = self.pos {
                    self.push(p);
                }
            }
            self.push(target);
            if self.points > MAX_POINTS {
                return Err(self.error(format!(
                    "more than {MAX_POINTS} points in the drawing (the limit that keeps memory bounded)"
                )));
            }
        }
        // Pen-down moves without a pen were warned about by the PD that lowered it.
        self.pos = Some(target);
        Ok(())
    }

    fn moves(&mut self, params: &[f64]) -> Result<(), HpglError> {
        if !params.len().is_multiple_of(2) {
            return Err(self.error(format!("{} numbers: coordinates come in x,y pairs", params.len())));
        }
        for pair in params.chunks_exact(2) {
            self.move_to(pair[0], pair[1])?;
        }
        Ok(())
    }

    fn command(&mut self, params: &[f64]) -> Result<(), HpglError> {
        match self.mnemonic.as_str() {
            "IN" | "DF" => {
                self.pen_up();
                self.absolute = true;
                if self.mnemonic == "IN" {
                    self.iw = None;
                }
            }
            "SP" => {
                self.pen_up();
                let n = params.first().copied().unwrap_or(0.0);
                if !(0.0..=255.0).contains(&n) || n.fract() != 0.0 {
                    return Err(self.error(format!("pen number {n} is not a whole number from 0 to 255")));
                }
                // A whole number from 0 to 255, checked just above.
                #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
                let n = n as u32;
                self.pen = Some(n);
            }
            "PU" => {
                self.pen_up();
                self.moves(params)?;
            }
            "PD" => {
                self.pen_down();
                self.moves(params)?;
            }
            "PA" | "PR" => {
                self.absolute = self.mnemonic == "PA";
                self.moves(params)?;
            }
            "SC" if !params.is_empty() => {
                return Err(self.error("user-unit scaling (SC with parameters) is not supported"));
            }
            "SC" => {}
            "IW" => {
                self.iw = match params {
                    [a, b, c, d] => Some(([*a, *b, *c, *d], self.command)),
                    [] => None,
                    _ => return Err(self.error(format!("IW takes 4 numbers, not {}", params.len()))),
                };
            }
            "CI" | "AA" | "AR" | "EA" | "ER" | "EW" | "RA" | "RR" | "WG" => {
                if matches!(self.mnemonic.as_str(), "AA" | "AR") {
                    self.pen_up();
                    self.pos = None;
                }
                self.warn("circles, arcs, wedges and rectangles are not supported: not drawn".into());
            }
            // Speeds come from the profile; the pen draws the same lines at any speed. `PS` (the 7550A's paper
            // size) does not move a line either.
            "VS" | "FS" | "VA" | "VN" | "PS" => {}
            "LT" => self.warn("line type (LT) ignored: drawn solid".into()),
            m => {
                let m = m.to_string();
                self.warn(format!("{m} is not supported: ignored"));
            }
        }
        Ok(())
    }
}

/// Import HP-GL `data` (named `origin` in messages). `paper` places the plotter units on the page; `None` picks
/// one as the module docs say.
pub fn import(data: &[u8], origin: &str, paper: Option<&HpglPaper>) -> Result<ImportedHpgl, HpglError> {
    let mut st = State {
        origin,
        command: 0,
        offset: 0,
        mnemonic: String::new(),
        absolute: true,
        down: false,
        pen: None,
        pos: Some((0.0, 0.0)),
        path: Vec::new(),
        layers: Vec::new(),
        points: 0,
        iw: None,
        warnings: Vec::new(),
    };
    let mut terminator = 0x03u8;
    let mut i = 0;
    let mut params = Vec::new();
    while i < data.len() {
        let b = data[i];
        if b.is_ascii_whitespace() || b == b';' || b == b',' || b == 0x03 {
            i += 1;
            continue;
        }
        st.command += 1;
        st.offset = i;
        if b == 0x1b {
            // Device control: ESC . letter [parameters] [:]
            st.mnemonic = format!("ESC.{}", data.get(i + 2).map_or('?', |&c| char::from(c)));
            i += 3;
            while i < data.len() && i - st.offset < 64 && !data[i].is_ascii_alphabetic() && data[i] != 0x1b {
                i += 1;
                if data[i - 1] == b':' {
                    break;
                }
            }
            st.warn("device-control sequence ignored".into());
            continue;
        }
        let (Some(&a), Some(&c)) = (data.get(i), data.get(i + 1)) else {
            return Err(st.error(format!("{:?} at the end of the file is not a command", char::from(b))));
        };
        if !(a.is_ascii_alphabetic() && c.is_ascii_alphabetic()) {
            let shown = String::from_utf8_lossy(&data[i..data.len().min(i + 8)]).into_owned();
            return Err(st.error(format!("expected a two-letter command, found {shown:?}")));
        }
        st.mnemonic = String::from_utf8_lossy(&[a.to_ascii_uppercase(), c.to_ascii_uppercase()]).into_owned();
        i += 2;
        if st.mnemonic == "LB" {
            let Some(len) = data[i..].iter().position(|&x| x == terminator) else {
                return Err(st.error("label (LB) without its terminator"));
            };
            i += len + 1;
            st.pen_up();
            st.pos = None;
            st.warn("labels (LB) are not supported: text not drawn".into());
            continue;
        }
        if st.mnemonic == "DT" {
            match data.get(i) {
                Some(&t) if t != b';' && !t.is_ascii_whitespace() => {
                    terminator = t;
                    i += 1;
                }
                _ => terminator = 0x03,
            }
            continue;
        }
        params.clear();
        i = read_params(data, i, &mut params).map_err(|m| st.error(m))?;
        st.command(&params)?;
    }
    st.pen_up();
    if let Some(([x0, y0, x1, y1], command)) = st.iw {
        let outside = |&&(x, y): &&(f64, f64)| x < x0.min(x1) || x > x0.max(x1) || y < y0.min(y1) || y > y0.max(y1);
        let n = st.layers.iter().flat_map(|(_, paths)| paths.iter().flatten()).filter(outside).count();
        if n > 0 {
            st.warnings.push(HpglWarning {
                command,
                mnemonic: "IW".into(),
                count: 1,
                message: format!(
                    "{n} point(s) lie outside the clip window, where a plotter would not draw; they are kept here"
                ),
            });
        }
    }
    let paper = match paper {
        Some(p) => *p,
        None => choose_paper(&st),
    };
    let mut drawing = Drawing::default();
    for (pen, paths) in &st.layers {
        let mut layer = Layer::new(format!("pen {pen}"));
        layer.pen.color = pen_color(*pen);
        layer.paths = paths
            .iter()
            .map(|path| {
                Polyline::new(
                    path.iter()
                        .map(|&(x, y)| {
                            let (px, py) = paper.to_page(x, y);
                            Point::new(px, py)
                        })
                        .collect(),
                )
            })
            .collect();
        drawing.layers.push(layer);
    }
    drawing.page_mm = Some(paper.size_mm);
    if paper.name == "page" {
        st.warnings.push(HpglWarning {
            command: 0,
            mnemonic: String::new(),
            count: 1,
            message: format!(
                "the coordinates fit no known sheet: placed on a {} × {} mm page with plotter unit (0, 0) at its \
                 lower-left corner",
                paper.size_mm.0, paper.size_mm.1
            ),
        });
    }
    Ok(ImportedHpgl { drawing, paper, warnings: st.warnings })
}

/// The colour a pen's layer gets, so that previews tell the pens apart and a re-export keeps them in their own
/// carousel slots: pens 1–8 black, red, green, blue, cyan, magenta, yellow, orange (the usual order of plotter
/// pen sets), higher numbers a colour spread from the number.
fn pen_color(pen: u32) -> Rgb {
    const SET: [Rgb; 8] = [
        Rgb(0, 0, 0),
        Rgb(255, 0, 0),
        Rgb(0, 160, 0),
        Rgb(0, 0, 255),
        Rgb(0, 190, 190),
        Rgb(200, 0, 200),
        Rgb(230, 200, 0),
        Rgb(255, 128, 0),
    ];
    let spread = |k: u32| u8::try_from(pen.wrapping_mul(k) % 200).unwrap_or(0);
    pen.checked_sub(1).and_then(|i| SET.get(usize::try_from(i).ok()?)).copied().unwrap_or(Rgb(
        spread(53),
        spread(97),
        spread(151),
    ))
}

/// Parse the numbers after a mnemonic, from `i` up to `;`, the next mnemonic or an escape; returns where they end.
fn read_params(data: &[u8], mut i: usize, params: &mut Vec<f64>) -> Result<usize, String> {
    while i < data.len() {
        let b = data[i];
        if b == b';' || b.is_ascii_alphabetic() || b == 0x1b {
            break;
        }
        if b.is_ascii_whitespace() || b == b',' {
            i += 1;
            continue;
        }
        let start = i;
        while i < data.len() && matches!(data[i], b'0'..=b'9' | b'.' | b'+' | b'-') {
            i += 1;
        }
        if i == start {
            return Err(format!("unexpected {:?} in the parameters", char::from(b)));
        }
        let token = std::str::from_utf8(&data[start..i]).unwrap_or("");
        if token.len() > MAX_NUMBER_LEN {
            return Err(format!("a number of {} characters is too long", token.len()));
        }
        match token.parse::<f64>() {
            Ok(v) if v.is_finite() => params.push(v),
            _ => return Err(format!("{token:?} is not a number")),
        }
    }
    Ok(i)
}

/// The sheet for the plotter units (see the module docs).
fn choose_paper(st: &State<'_>) -> HpglPaper {
    let all = || DEVICES.iter().flat_map(|d| d.papers.iter());
    if let Some(([0.0, 0.0, x, y], _)) = st.iw
        && let Some(p) = all().find(|p| f64::from(p.clip_plu.0) == x && f64::from(p.clip_plu.1) == y)
    {
        return *p;
    }
    let points = || st.layers.iter().flat_map(|(_, paths)| paths.iter().flatten());
    let (mut lo, mut hi) = ((0.0f64, 0.0f64), (0.0f64, 0.0f64));
    for &(x, y) in points() {
        lo = (lo.0.min(x), lo.1.min(y));
        hi = (hi.0.max(x), hi.1.max(y));
    }
    if lo.0 >= 0.0 && lo.1 >= 0.0 {
        let fits = |p: &&HpglPaper| hi.0 <= f64::from(p.clip_plu.0) && hi.1 <= f64::from(p.clip_plu.1);
        if let Some(p) = DEVICES[0].papers.iter().find(fits) {
            return *p;
        }
    }
    HpglPaper::generic(hi.0 / PLU_PER_MM, hi.1 / PLU_PER_MM)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::hpgl_devices::device;

    fn a4() -> HpglPaper {
        *device("7475a").unwrap().paper("a4").unwrap()
    }

    fn import_a4(text: &str) -> ImportedHpgl {
        import(text.as_bytes(), "t.hpgl", Some(&a4())).unwrap()
    }

    fn err(text: &str) -> String {
        import(text.as_bytes(), "t.hpgl", Some(&a4())).unwrap_err().to_string()
    }

    fn points(p: &Polyline) -> Vec<(f64, f64)> {
        p.points.iter().map(|q| (q.x, q.y)).collect()
    }

    /// The 7475A's A4 origin is page (10, 206) mm: plu (800, 6240) is (30, 50) mm, (1200, 5840) is (40, 60) mm.
    #[test]
    fn pens_strokes_and_modes() {
        let r = import_a4("IN;SP1;PU800,6240;PD1200,6240,1200,5840;PU;SP2;PA800,5840;PD;PR400,0,0,400;PU;SP0;");
        assert!(r.warnings.is_empty(), "{:?}", r.warnings);
        let names: Vec<&str> = r.drawing.layers.iter().map(|l| l.name.as_str()).collect();
        assert_eq!(names, ["pen 1", "pen 2"]);
        assert_eq!(r.drawing.layers[1].pen.color, Rgb(255, 0, 0));
        assert_eq!(points(&r.drawing.layers[0].paths[0]), [(30.0, 50.0), (40.0, 50.0), (40.0, 60.0)]);
        assert_eq!(points(&r.drawing.layers[1].paths[0]), [(30.0, 60.0), (40.0, 60.0), (40.0, 50.0)]);
        // Separators: spaces instead of commas, no semicolons, lower case; no SP means pen 1.
        let r = import_a4("pu 800 6240 pd 1200 6240\npu");
        assert_eq!(points(&r.drawing.layers[0].paths[0]), [(30.0, 50.0), (40.0, 50.0)]);
        assert_eq!(r.drawing.layers[0].name, "pen 1");
    }

    #[test]
    fn unsupported_commands_are_warned_with_their_position() {
        let r = import_a4(
            "IN;VS10;SP1;LBhello\x03;PA0,0;PD10,0;CI50;CI20;PU;DT@;LBx@PA0,0;SP0;PD5,5;PU;IW0,0,8,8;LT2;ZZ1;",
        );
        let shown: Vec<String> = r.warnings.iter().map(ToString::to_string).collect();
        assert_eq!(
            shown,
            [
                "command 4 (LB): labels (LB) are not supported: text not drawn (2 times)",
                "command 7 (CI): circles, arcs, wedges and rectangles are not supported: not drawn (2 times)",
                "command 14 (PD): pen-down moves with no pen selected (after SP0) are not drawn",
                "command 17 (LT): line type (LT) ignored: drawn solid",
                "command 18 (ZZ): ZZ is not supported: ignored",
                "command 16 (IW): 1 point(s) lie outside the clip window, where a plotter would not draw; they are \
                 kept here",
            ]
        );
        assert_eq!(r.drawing.path_count(), 1);
    }

    #[test]
    fn garbage_is_an_error_naming_the_command() {
        assert_eq!(err("IN;SP1;PD1,2,3;"), "t.hpgl: command 3 (byte 7): 3 numbers: coordinates come in x,y pairs");
        assert_eq!(err("IN;#$;"), "t.hpgl: command 2 (byte 3): expected a two-letter command, found \"#$;\"");
        assert_eq!(err("IN;PD1.2.3,4;"), "t.hpgl: command 2 (byte 3): \"1.2.3\" is not a number");
        assert_eq!(err("PA1,\"2;"), "t.hpgl: command 1 (byte 0): unexpected '\"' in the parameters");
        assert!(err("LBnever ends").starts_with("t.hpgl: command 1 (byte 0): label (LB) without its terminator"));
        assert!(err("SC0,100,0,100;").contains("SC with parameters"));
        assert!(err("SP1.5;").contains("pen number 1.5"));
        assert!(err("PA0,0;AA10,10,90;PR5,5;").starts_with("t.hpgl: command 3 (byte 17): relative move after"));
        assert!(err("PA99999999999,0;").contains("beyond ±1000000 mm"), "{}", err("PA99999999999,0;"));
        assert!(err(&format!("PA{};", "1".repeat(41))).contains("41 characters"));
    }

    /// Without a given sheet: the `IW` window names the 7475A's A3 (its clip is 16158 × 11040); without one, the
    /// first 7475A sheet holding the points (A4 for x ≤ 11040, y ≤ 7721; letter for x ≤ 10365, y ≤ 7962; A3 beyond); else a generic page.
    #[test]
    fn the_sheet_is_chosen_from_the_window_or_the_extent() {
        let pick = |t: &str| import(t.as_bytes(), "t", None).unwrap();
        assert_eq!(pick("IN;IW0,0,16158,11040;PD0,0;").paper.name, "a3");
        assert_eq!(pick("PD11040,7721;").paper.name, "a4");
        assert_eq!(pick("PD10000,7800;").paper.name, "letter");
        assert_eq!(pick("PD11041,7721;").paper.name, "a3");
        let g = pick("PD20000,4000;");
        assert_eq!((g.paper.name, g.paper.size_mm), ("page", (500.0, 100.0)));
        assert_eq!(points(&g.drawing.layers[0].paths[0]), [(0.0, 100.0), (500.0, 0.0)]);
        assert!(g.warnings[0].to_string().starts_with("the coordinates fit no known sheet: placed on a 500 × 100"));
    }
}
