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
//! ±[`MAX_COORD_MM`] and the file may produce at most [`MAX_POINTS`] points — counted wherever a point is made: a
//! coordinate, the start of a stroke at the pen's position, and the second point of a dot (`PD;PU;` in place), so
//! 16 MB of `PDPU` is refused at the limit rather than becoming eight million points. The strokes are kept in one
//! flat list of points while reading (16 bytes a point, no allocation per stroke), and warnings are counted by
//! kind with a bounded list of distinct messages ([`super::warn_tally`]). A termination signal
//! ([`crate::config::interrupt`]) or a [`Cancel`] ends a long import, looked at every few thousand commands.
//!
//! Y is flipped back to our page (Y down) on a sheet: the one given, else the first known sheet
//! ([`crate::geometry::hpgl_devices::DEVICES`]) whose hard-clip rectangle equals the file's `IW` window (this
//! project's export writes one), else the first 7475A sheet that holds every point, else a generic page just
//! holding the drawing (with a warning).

use kurbo::Point;

use super::gcode_in::CHECK_EVERY;
use super::gcode_in::short;
use super::warn_tally::Tally;
use crate::config::interrupt;
use crate::geometry::cancel::Cancel;
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
    /// The import was stopped before the end: the process was asked to end, or the result was no longer wanted.
    #[error("{origin}: stopped at command {command} (byte {offset}): {why}")]
    Stopped {
        /// File name.
        origin: String,
        /// 1-based index of the command reached.
        command: usize,
        /// Its byte offset.
        offset: usize,
        /// Why ("interrupted while reading …", "cancelled …").
        why: String,
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
    /// The points of every stroke, one after another, in plotter units; the stroke being drawn is the tail from
    /// `path_start`.
    pts: Vec<(f64, f64)>,
    path_start: usize,
    /// Finished strokes: (index into `pens`, start in `pts`); each ends where the next starts.
    strokes: Vec<(usize, usize)>,
    /// Pens in order of first use.
    pens: Vec<u32>,
    /// The last clip window and the index of its command.
    iw: Option<([f64; 4], usize)>,
    warnings: Tally,
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

    /// Record a warning of `kind` for the current mnemonic, counted with the earlier ones of the same message.
    fn warn(&mut self, kind: &'static str, message: String) {
        self.warnings.note(self.command, kind, &self.mnemonic, message);
    }

    /// Whether a stroke is being drawn.
    fn in_path(&self) -> bool {
        self.pts.len() > self.path_start
    }

    fn finish_path(&mut self) -> Result<(), HpglError> {
        let len = self.pts.len() - self.path_start;
        if len == 0 {
            return Ok(());
        }
        if len == 1 {
            // The pen went down and up again in place: a dot, drawn as two equal points (both count).
            self.push(self.pts[self.path_start])?;
        }
        let pen = self.pen.unwrap_or(1);
        let layer = match self.pens.iter().position(|&p| p == pen) {
            Some(i) => i,
            None => {
                self.pens.push(pen);
                self.pens.len() - 1
            }
        };
        self.strokes.push((layer, self.path_start));
        self.path_start = self.pts.len();
        Ok(())
    }

    fn pen_down(&mut self) -> Result<(), HpglError> {
        self.down = true;
        if self.pen == Some(0) {
            self.warn("pen-down without a pen", "pen-down moves with no pen selected (after SP0) are not drawn".into());
            return Ok(());
        }
        if !self.in_path()
            && let Some(p) = self.pos
        {
            self.push(p)?;
        }
        Ok(())
    }

    fn pen_up(&mut self) -> Result<(), HpglError> {
        self.down = false;
        self.finish_path()
    }

    /// Add a point to the stroke: the one place points are made, so the limit holds for all of them.
    fn push(&mut self, p: (f64, f64)) -> Result<(), HpglError> {
        if self.pts.len() >= MAX_POINTS {
            return Err(self
                .error(format!("more than {MAX_POINTS} points in the drawing (the limit that keeps memory bounded)")));
        }
        self.pts.push(p);
        Ok(())
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
                short(target.0),
                short(target.1)
            )));
        }
        if self.down && self.pen != Some(0) {
            if !self.in_path() {
                // Pen down at an unknown position (after a label): the stroke starts at its first known point.
                if let Some(p) = self.pos {
                    self.push(p)?;
                }
            }
            self.push(target)?;
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
                self.pen_up()?;
                self.absolute = true;
                if self.mnemonic == "IN" {
                    self.iw = None;
                }
            }
            "SP" => {
                self.pen_up()?;
                let n = params.first().copied().unwrap_or(0.0);
                if !(0.0..=255.0).contains(&n) || n.fract() != 0.0 {
                    return Err(self.error(format!("pen number {} is not a whole number from 0 to 255", short(n))));
                }
                // A whole number from 0 to 255, checked just above.
                #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
                let n = n as u32;
                self.pen = Some(n);
            }
            "PU" => {
                self.pen_up()?;
                self.moves(params)?;
            }
            "PD" => {
                self.pen_down()?;
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
                    self.pen_up()?;
                    self.pos = None;
                }
                let message = "circles, arcs, wedges and rectangles are not supported: not drawn";
                self.warn(message, message.into());
            }
            // Speeds come from the profile; the pen draws the same lines at any speed. `PS` (the 7550A's paper
            // size) does not move a line either.
            "VS" | "FS" | "VA" | "VN" | "PS" => {}
            "LT" => self.warn("line types", "line type (LT) ignored: drawn solid".into()),
            m => {
                let message = format!("{m} is not supported: ignored");
                self.warn("unsupported commands", message);
            }
        }
        Ok(())
    }
}

/// Import HP-GL `data` (named `origin` in messages). `paper` places the plotter units on the page; `None` picks
/// one as the module docs say.
pub fn import(data: &[u8], origin: &str, paper: Option<&HpglPaper>) -> Result<ImportedHpgl, HpglError> {
    import_cancellable(data, origin, paper, &Cancel::never())
}

/// [`import`] that ends early with [`HpglError::Stopped`] once `cancel` is set or the process is asked to stop
/// ([`interrupt`]), looked at every [`CHECK_EVERY`] commands.
pub fn import_cancellable(
    data: &[u8],
    origin: &str,
    paper: Option<&HpglPaper>,
    cancel: &Cancel,
) -> Result<ImportedHpgl, HpglError> {
    let mut st = State {
        origin,
        command: 0,
        offset: 0,
        mnemonic: String::new(),
        absolute: true,
        down: false,
        pen: None,
        pos: Some((0.0, 0.0)),
        pts: Vec::new(),
        path_start: 0,
        strokes: Vec::new(),
        pens: Vec::new(),
        iw: None,
        warnings: Tally::default(),
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
        if st.command.is_multiple_of(CHECK_EVERY) {
            let why = if cancel.is_cancelled() {
                Some("cancelled: the import was no longer wanted".to_string())
            } else {
                interrupt::check(|| format!("reading command {} of {origin}", st.command)).err().map(|e| e.to_string())
            };
            if let Some(why) = why {
                return Err(HpglError::Stopped { origin: origin.into(), command: st.command, offset: i, why });
            }
        }
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
            st.warn("device control", "device-control sequence ignored".into());
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
            st.pen_up()?;
            st.pos = None;
            st.warn("labels", "labels (LB) are not supported: text not drawn".into());
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
    st.pen_up()?;
    let mut warnings: Vec<HpglWarning> = std::mem::take(&mut st.warnings)
        .finish()
        .into_iter()
        .map(|n| HpglWarning { command: n.at, mnemonic: n.tag, count: n.count, message: n.message })
        .collect();
    if let Some(([x0, y0, x1, y1], command)) = st.iw {
        let outside = |&&(x, y): &&(f64, f64)| x < x0.min(x1) || x > x0.max(x1) || y < y0.min(y1) || y > y0.max(y1);
        let n = st.pts.iter().filter(outside).count();
        if n > 0 {
            warnings.push(HpglWarning {
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
    for pen in &st.pens {
        let mut layer = Layer::new(format!("pen {pen}"));
        layer.pen.color = pen_color(*pen);
        drawing.layers.push(layer);
    }
    let ends = st.strokes.iter().skip(1).map(|s| s.1).chain(std::iter::once(st.pts.len()));
    for (&(layer, start), end) in st.strokes.iter().zip(ends) {
        let points = st.pts[start..end]
            .iter()
            .map(|&(x, y)| {
                let (px, py) = paper.to_page(x, y);
                Point::new(px, py)
            })
            .collect();
        drawing.layers[layer].paths.push(Polyline::new(points));
    }
    drawing.page_mm = Some(paper.size_mm);
    if paper.name == "page" {
        warnings.push(HpglWarning {
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
    Ok(ImportedHpgl { drawing, paper, warnings })
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
    let (mut lo, mut hi) = ((0.0f64, 0.0f64), (0.0f64, 0.0f64));
    for &(x, y) in &st.pts {
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

    #[test]
    fn every_point_counts_toward_the_limit_dots_included() {
        // PD;PU in place makes a dot of two points: 2,097,152 of them reach the limit, the next PD is refused.
        let pairs = MAX_POINTS / 2 + 1;
        let text = format!("PA10,10;{}", "PDPU".repeat(pairs));
        let e = import(text.as_bytes(), "t.hpgl", Some(&a4())).unwrap_err().to_string();
        let command = 1 + 2 * pairs - 1;
        let byte = 8 + 4 * (pairs - 1);
        assert_eq!(
            e,
            format!(
                "t.hpgl: command {command} (byte {byte}): more than 4194304 points in the drawing (the limit that \
                 keeps memory bounded)"
            )
        );
        // Just under the limit, the dots are all there.
        let text = format!("PA10,10;{}", "PDPU".repeat(1000));
        let r = import(text.as_bytes(), "t.hpgl", Some(&a4())).unwrap();
        assert_eq!((r.drawing.path_count(), r.drawing.paths().map(|p| p.points.len()).sum::<usize>()), (1000, 2000));
    }

    #[test]
    fn many_different_unsupported_commands_are_capped_and_counted() {
        let mut text = String::new();
        for a in b'Q'..=b'Z' {
            for b in b'A'..=b'Z' {
                text.push_str(&format!("{}{};", char::from(a), char::from(b)));
            }
        }
        let r = import_a4(&text);
        let shown: Vec<String> = r.warnings.iter().map(ToString::to_string).collect();
        // QA..ZZ: 260 mnemonics. RA, RR and WG are shapes (a kind of their own), SC, SP, VA, VN and VS are read;
        // the other 252 are unsupported, each with its own message: 20 listed, 232 counted.
        assert_eq!(shown.len(), 24, "{shown:?}");
        assert_eq!(shown[0], "command 1 (QA): QA is not supported: ignored");
        assert_eq!(shown[19], "command 20 (QT): QT is not supported: ignored");
        assert!(shown[20..23].iter().all(|w| w.contains("circles, arcs")), "{shown:?}");
        assert_eq!(
            shown[23],
            "command 21 (QU): and 232 more like it (unsupported commands; only the first 20 different ones are listed)"
        );
    }

    #[test]
    fn huge_numbers_are_shown_short_and_a_cancel_stops_the_import() {
        let e = err(&format!("PA1{},0;", "0".repeat(39)));
        assert_eq!(
            e,
            "t.hpgl: command 1 (byte 0): target (1e39, 0) plotter units is beyond ±1000000 mm (1 km); no plotter draws that"
        );
        assert_eq!(
            err(&format!("SP{};", "9".repeat(30))),
            format!("t.hpgl: command 1 (byte 0): pen number 1e30 is not a whole number from 0 to 255")
        );
        let cancel = Cancel::new();
        cancel.cancel();
        let text = "PA1,1;".repeat(2 * CHECK_EVERY);
        let e = import_cancellable(text.as_bytes(), "t.hpgl", Some(&a4()), &cancel).unwrap_err();
        assert_eq!(
            e.to_string(),
            format!(
                "t.hpgl: stopped at command {CHECK_EVERY} (byte {}): cancelled: the import was no longer wanted",
                6 * (CHECK_EVERY - 1)
            )
        );
    }
}
