//! Reading drawings from the command line: the input flags, input-kind detection, and the one loader that turns
//! any supported input — SVG, PNG/JPEG (traced), G-code, the seed plotter's trajectory file, or a generated
//! figure `gen:KIND?param=value&...` — into a [`Drawing`] in page millimetres, printing every warning to stderr.

use std::io::Read;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::{Args, ValueEnum};
use plotter_path::geometry::cancel::Cancel;
use plotter_path::geometry::hatch::FillHatch;
use plotter_path::geometry::steps::StepMapper;
use plotter_path::geometry::tone_hatch::ToneHatch;
use plotter_path::input::raster::Mode;
use plotter_path::input::skipped::Skipped;
use plotter_path::input::svg::{
    self, FillStrokes, ImageTrace, LayerBy, ResourcePolicy, ScaleRange, SvgOptions, TextMode,
};
use plotter_path::input::{gcode_in, r#gen, hpgl_in, raster, trajectory};
use plotter_path::{Drawing, MachineProfile};

use crate::options::layout::LayoutArgs;
use crate::options::trace::{PENS_FROM_FLAGS, TraceArgs};

/// How SVG shapes are grouped into layers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum, Default)]
pub enum LayerByArg {
    /// Inkscape layers when the document has any, else one layer
    #[default]
    Auto,
    /// One layer per top-level group (Inkscape label, else group id)
    Group,
    /// One layer per stroke colour
    Color,
    /// Everything in one layer
    None,
}

/// How SVG text is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum, Default)]
pub enum TextArg {
    /// The font's glyph outlines
    #[default]
    Outlines,
    /// One line per stroke (Hershey font)
    SingleStroke,
}

/// What happens to embedded SVG images: skipped (the default, with a warning) or traced in one of the library's
/// modes, spelled and described as `--mode` spells them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ImagesArg(pub Option<Mode>);

/// `skip`, then every mode, in the library's documentation order.
const IMAGES_ARGS: [ImagesArg; Mode::ALL.len() + 1] = {
    let mut out = [ImagesArg(None); Mode::ALL.len() + 1];
    let mut i = 0;
    while i < Mode::ALL.len() {
        out[i + 1] = ImagesArg(Some(Mode::ALL[i]));
        i += 1;
    }
    out
};

impl ValueEnum for ImagesArg {
    fn value_variants<'a>() -> &'a [Self] {
        &IMAGES_ARGS
    }

    fn to_possible_value(&self) -> Option<clap::builder::PossibleValue> {
        Some(match self.0 {
            None => clap::builder::PossibleValue::new("skip").help("Not drawn (with a warning)"),
            Some(mode) => clap::builder::PossibleValue::new(mode.name()).help(mode.summary()),
        })
    }
}

/// What `--hatch` asks for: one spacing for every fill, or each fill shaded by its lightness.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum HatchArg {
    /// Parallel lines this far apart in every fill, mm on the plotted page.
    Spacing(f64),
    /// Each fill gets lines as dense as its colour is dark (`tone`): white stays empty, light fills get sparse
    /// lines, dark ones denser and then crossing lines; gradients vary along the shape.
    Tone,
}

impl std::str::FromStr for HatchArg {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        if s.trim().eq_ignore_ascii_case("tone") {
            return Ok(HatchArg::Tone);
        }
        match s.trim().parse::<f64>() {
            Ok(v) if v.is_finite() && v > 0.0 => Ok(HatchArg::Spacing(v)),
            Ok(v) => Err(format!("the hatch spacing must be a positive number of mm, got {v}")),
            Err(_) => Err(format!("expected a spacing in mm (such as 0.8) or `tone`, got {s:?}")),
        }
    }
}

/// Input flags shared by every command that reads a drawing.
#[derive(Debug, Clone, Args)]
pub struct InputArgs {
    /// Maximum chord error when flattening SVG curves, mm on the plotted page
    #[arg(long, default_value_t = svg::DEFAULT_TOLERANCE_MM, help_heading = "Input")]
    pub tolerance: f64,
    /// How SVG shapes are grouped into layers (pens)
    #[arg(long, value_enum, default_value_t = LayerByArg::Auto, help_heading = "Input")]
    pub layer_by: LayerByArg,
    /// Keep only these layers (names as listed by `plotter stats`), comma-separated
    #[arg(long, value_delimiter = ',', help_heading = "Input")]
    pub layers: Vec<String>,
    /// Plot SVG outlines in full, also where an opaque fill painted later hides them
    #[arg(long, help_heading = "Input")]
    pub no_occlusion: bool,
    /// Shade every filled SVG area with parallel lines: a spacing in mm on the plotted page, or `tone` to space
    /// each fill's lines by how dark its colour is, crossing them for dark fills (pen: --pen-width, closest
    /// spacing: --min-spacing, direction: --angle)
    #[arg(long, value_name = "SPACING_MM|tone", help_heading = "Input")]
    pub hatch: Option<HatchArg>,
    /// With --hatch SPACING_MM: add a second family of lines at right angles
    #[arg(long, requires = "hatch", help_heading = "Input")]
    pub cross_hatch: bool,
    /// How much the layout magnifies the drawing (set by the loader, 1 from the command line): hatch spacings, the
    /// tone hatch's pen width and the pen width --fill-strokes passes are spaced by are divided by it at import, so
    /// that they come out as asked on the page, and so is --tolerance when it magnifies.
    #[arg(skip = 1.0)]
    pub hatch_scale: f64,
    /// What the user of this front end can do when `--colors pens` finds no pen with a colour in the machine
    /// profile (set by the front end: the command line's flags, [`PENS_FROM_FLAGS`], unless it says otherwise).
    #[arg(skip = PENS_FROM_FLAGS)]
    pub pens_hint: &'static str,
    /// Fill SVG strokes wider than the pen (--pen-width) with parallel passes a pen width apart, both measured on
    /// the plotted page, in the direction --angle gives
    #[arg(long, help_heading = "Input")]
    pub fill_strokes: bool,
    /// How SVG text is drawn
    #[arg(long, value_enum, default_value_t = TextArg::Outlines, help_heading = "Input")]
    pub text: TextArg,
    /// Trace the images embedded in an SVG with this tracing mode (the image tracing flags apply)
    #[arg(long, value_enum, default_value_t = ImagesArg(None), help_heading = "Input")]
    pub images: ImagesArg,
    /// Cut SVG geometry at the page edge (it is reported either way)
    #[arg(long, help_heading = "Input")]
    pub crop: bool,
    /// How raster images (PNG/JPEG) are traced into paths
    #[command(flatten)]
    pub trace: TraceArgs,
}

impl InputArgs {
    /// The chord error an SVG's curves are flattened to on the plotted page, mm: `--tolerance`, but no finer than
    /// half a motor step of `profile` (of its finer axis). Every point of a plot is placed on the machine's step
    /// grid, so a chord closer to its curve than that is lost to the grid, and the extra points only make the path's
    /// direction jitter from step to step: a planner that reads each vertex (an HP 7475A's own, at 0.025 mm per
    /// step) took them as corners, and the same drawing planned 1.1 % slower at 0.002 mm than at 0.05.
    pub fn page_tolerance(&self, profile: &MachineProfile) -> f64 {
        let finest_step = 1.0 / profile.axes.x.steps_per_mm.max(profile.axes.y.steps_per_mm);
        self.tolerance.max(finest_step / 2.0)
    }

    fn svg_options(&self, profile: &MachineProfile) -> Result<SvgOptions> {
        if !(self.tolerance.is_finite() && self.tolerance > 0.0) {
            bail!("--tolerance must be a positive number of mm, got {}", self.tolerance);
        }
        let scale = self.hatch_scale;
        if !(scale.is_finite() && scale > 0.0) {
            bail!("the layout's scale factor must be a positive number, got {scale}");
        }
        if (self.fill_strokes || self.hatch.is_some()) && !self.trace.angle.is_finite() {
            bail!("--angle must be a finite number of degrees, got {}", self.trace.angle);
        }
        Ok(SvgOptions {
            tolerance_mm: document_tolerance(self.page_tolerance(profile), scale),
            layer_by: match self.layer_by {
                LayerByArg::Auto => LayerBy::Auto,
                LayerByArg::Group => LayerBy::Group,
                LayerByArg::Color => LayerBy::Color,
                LayerByArg::None => LayerBy::None,
            },
            layers: self.layers.clone(),
            occlusion: !self.no_occlusion,
            hatch: match self.hatch {
                Some(HatchArg::Spacing(s)) if !(s.is_finite() && s > 0.0) => {
                    bail!("--hatch must be a positive spacing in mm, got {s}")
                }
                Some(HatchArg::Spacing(s)) => Some(FillHatch {
                    spacing_mm: s / scale,
                    angle_deg: self.trace.angle,
                    cross: self.cross_hatch,
                    link: true,
                }),
                Some(HatchArg::Tone) | None => None,
            },
            tone_hatch: match self.hatch {
                Some(HatchArg::Tone) => Some(self.tone_hatch(scale)?),
                Some(HatchArg::Spacing(_)) | None => None,
            },
            fill_strokes: self
                .fill_strokes
                .then_some(FillStrokes { pen_mm: self.trace.pen_width / scale, angle_deg: self.trace.angle }),
            text: match self.text {
                TextArg::Outlines => TextMode::Outlines,
                TextArg::SingleStroke => TextMode::SingleStroke,
            },
            images: match self.images.0 {
                Some(mode) => Some(ImageTrace { trace: raster::TraceOptions { mode, ..self.trace_options(profile)? } }),
                None => None,
            },
            crop: self.crop,
            pen_width_mm: profile.pen.width_mm,
            pens: profile.pens.clone(),
            hatch_scale: scale,
            ..SvgOptions::default()
        })
    }
}

impl InputArgs {
    /// The tracing options for pictures, `--colors pens` separating into the coloured pens of `profile` and
    /// refused, saying what to do ([`InputArgs::pens_hint`]), when it has none.
    fn trace_options(&self, profile: &MachineProfile) -> Result<raster::TraceOptions> {
        self.trace.options_for_profile(&profile.name, &profile.pens, self.pens_hint)
    }

    /// `--hatch tone`'s settings in document millimetres: the pen width and closest spacing asked for on the page,
    /// divided by the layout's magnification `scale`.
    fn tone_hatch(&self, scale: f64) -> Result<ToneHatch> {
        if self.cross_hatch {
            bail!(
                "--cross-hatch goes with a --hatch spacing; with --hatch tone each fill's darkness decides its crossings"
            );
        }
        let pen = self.trace.pen_width;
        if !(pen.is_finite() && pen > 0.0) {
            bail!("--pen-width must be a positive number of mm, got {pen}");
        }
        let min = self.trace.min_spacing.unwrap_or(1.5 * pen);
        if !(min.is_finite() && min > 0.0) {
            bail!("--min-spacing must be a positive number of mm, got {min}");
        }
        if !self.trace.angle.is_finite() {
            bail!("--angle must be a finite number of degrees, got {}", self.trace.angle);
        }
        Ok(ToneHatch { pen_mm: pen / scale, min_spacing_mm: min / scale, angle_deg: self.trace.angle })
    }
}

/// The kinds of input file the loader understands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InputKind {
    /// SVG drawing.
    Svg,
    /// PNG or JPEG image, traced into paths.
    Image,
    /// G-code (ours or another plotter tool's).
    Gcode,
    /// The seed plotter's trajectory file (relative motor steps).
    Trajectory,
    /// HP-GL plot file.
    Hpgl,
    /// A file format recognised by its signature but not read (GIF, TIFF, WebP, BMP, PDF, …): named, so that it
    /// is refused as what it is rather than as broken G-code.
    Unread(&'static str),
}

/// The formats the loader reads, as messages list them.
pub const READ_FORMATS: &str = "SVG (also .svgz), PNG and JPEG images (traced), G-code, HP-GL, the seed plotter's \
                                trajectory files, and generated figures (gen:KIND?...)";

/// File signatures of formats that are recognised but not read: (leading bytes, the format's name).
const UNREAD_SIGNATURES: &[(&[u8], &str)] = &[
    (b"GIF87a", "a GIF image"),
    (b"GIF89a", "a GIF image"),
    (b"II*\0", "a TIFF image"),
    (b"MM\0*", "a TIFF image"),
    (b"BM", "a BMP image"),
    (b"%PDF", "a PDF document"),
    (b"%!PS", "a PostScript document"),
    (b"\0\0\x01\0", "an ICO icon"),
    (b"8BPS", "a Photoshop image"),
    (b"PK\x03\x04", "a ZIP archive (or a file in one, such as DOCX or ODG)"),
    (b"\xd0\xcf\x11\xe0", "an old Microsoft Office file"),
    (b"AC10", "a DWG drawing"),
    (b"\x7fELF", "a program (ELF)"),
];

/// The name of a recognised format that is not read, from the first bytes; `None` when nothing matches.
fn unread_format(head: &[u8]) -> Option<&'static str> {
    if head.len() >= 12 && head.starts_with(b"RIFF") && &head[8..12] == b"WEBP" {
        return Some("a WebP image");
    }
    if head.len() >= 12
        && &head[4..8] == b"ftyp"
        && matches!(&head[8..12], b"avif" | b"avis" | b"heic" | b"heix" | b"mif1")
    {
        return Some("an AVIF/HEIF image");
    }
    if head.starts_with(b"BM") {
        // "BM" is also how a text file may start; a BMP has its file size and a known header size after it.
        let header = head.get(14..18).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]));
        return header.filter(|h| matches!(h, 12 | 40 | 52 | 56 | 64 | 108 | 124)).map(|_| "a BMP image");
    }
    UNREAD_SIGNATURES.iter().find(|(sig, _)| head.starts_with(sig)).map(|(_, name)| *name)
}

/// Prefix of generated-figure inputs.
pub const GEN_PREFIX: &str = "gen:";

/// Decide what the file `path` holds: by its first bytes where they say it for sure (gzip → compressed SVG,
/// PNG/JPEG signatures, an XML start in UTF-8 or UTF-16, and the signatures of formats that are not read: GIF,
/// TIFF, WebP, BMP, PDF, …), else by its extension, else by its text. (Generated figures are not files:
/// [`load_drawing`] recognises their `gen:` prefix before reading anything.)
pub fn input_kind(path: &Path, head: &[u8]) -> InputKind {
    if head.starts_with(&[0x1f, 0x8b]) {
        return InputKind::Svg;
    }
    if head.starts_with(b"\x89PNG\r\n\x1a\n") || head.starts_with(&[0xff, 0xd8, 0xff]) {
        return InputKind::Image;
    }
    if let Some(name) = unread_format(head) {
        return InputKind::Unread(name);
    }
    if head.starts_with(&[0xff, 0xfe]) || head.starts_with(&[0xfe, 0xff]) {
        return InputKind::Svg;
    }
    let text = String::from_utf8_lossy(head);
    let t = text.trim_start_matches('\u{feff}').trim_start();
    if t.starts_with("<?xml") || t.starts_with("<svg") || t.starts_with("<!DOCTYPE") || t.starts_with("<!--") {
        return InputKind::Svg;
    }
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).unwrap_or_default();
    match ext.as_str() {
        "svg" | "svgz" => return InputKind::Svg,
        "png" | "jpg" | "jpeg" => return InputKind::Image,
        "gcode" | "nc" | "ngc" | "g" | "gco" | "tap" => return InputKind::Gcode,
        "traj" | "trj" => return InputKind::Trajectory,
        "hpgl" | "plt" | "hgl" => return InputKind::Hpgl,
        "gif" => return InputKind::Unread("a GIF image"),
        "tif" | "tiff" => return InputKind::Unread("a TIFF image"),
        "webp" => return InputKind::Unread("a WebP image"),
        "bmp" => return InputKind::Unread("a BMP image"),
        "pdf" => return InputKind::Unread("a PDF document"),
        "eps" | "ps" => return InputKind::Unread("a PostScript document"),
        "dxf" => return InputKind::Unread("a DXF drawing"),
        "dwg" => return InputKind::Unread("a DWG drawing"),
        _ => {}
    }
    if t.starts_with('<') {
        InputKind::Svg
    } else if t.get(..3).is_some_and(|s| s.eq_ignore_ascii_case("IN;")) {
        InputKind::Hpgl
    } else if t.split_whitespace().next().is_some_and(|w| w.parse::<u64>().is_ok()) {
        InputKind::Trajectory
    } else {
        InputKind::Gcode
    }
}

/// Print warnings to stderr, prefixed so they stand out from results.
pub fn warn_all(warnings: &[String]) {
    for w in warnings {
        eprintln!("warning: {w}");
    }
}

/// The bytes of `path` (`-` reads stdin).
pub fn read_input(path: &Path) -> Result<Vec<u8>> {
    if path == Path::new("-") {
        let mut data = Vec::new();
        std::io::stdin().read_to_end(&mut data).context("cannot read the drawing from stdin")?;
        Ok(data)
    } else {
        std::fs::read(path).with_context(|| format!("{}: cannot read", path.display()))
    }
}

pub use crate::options::machine::load_profile;

/// Load any supported input as a drawing in page millimetres (before layout). `profile` maps machine coordinates
/// of G-code and trajectory files back to the page.
pub fn load_drawing(path: &Path, args: &InputArgs, profile: &MachineProfile) -> Result<Drawing> {
    Ok(load_decoded(path, args, profile)?.drawing)
}

/// [`load_drawing`] with what the import left out ([`Decoded::skipped`]); the warnings are printed.
pub fn load_decoded(path: &Path, args: &InputArgs, profile: &MachineProfile) -> Result<Decoded> {
    let shown = shown_name(path);
    let decoded = load_unchecked(path, &shown, args, profile)?;
    // Every input passes the size limits before any later stage works on it.
    plotter_path::geometry::limits::check_drawing(&decoded.drawing, &shown)?;
    Ok(decoded)
}

/// The finest flattening tolerance a magnifying layout asks the SVG import for, mm: bounds the work an absurd
/// `--scale` could cause (at most √(0.05/0.0001) ≈ 22 times the points of the default tolerance).
pub const FINEST_TOLERANCE_MM: f64 = 0.0001;

/// Whether decoding `data` (read from `path`) hatches filled areas: an SVG with `--hatch`, with a pen table whose
/// pens hatch, or with `--fill-strokes`. Their hatch sizes (and the passes' pen width) are page sizes, so such a
/// drawing is decoded knowing the layout's factor ([`InputArgs::hatch_scale`], [`decode_for_layout`]).
pub fn hatches_fills(path: &Path, data: &[u8], args: &InputArgs, profile: &MachineProfile) -> bool {
    input_kind(path, &data[..data.len().min(512)]) == InputKind::Svg
        && (args.hatch.is_some() || args.fill_strokes || profile.pens.iter().any(|p| p.hatch.is_some()))
}

/// `args` and `profile` without any hatching (`--hatch` off, the pen table's hatches left out). `--fill-strokes`
/// stays on: its passes fill each wide stroke's outline, which reaches half the stroke's width past its middle
/// line, so the layout (`--fit`) must see them to give the factor the hatched drawing is laid out with.
fn unhatched(args: &InputArgs, profile: &MachineProfile) -> (InputArgs, MachineProfile) {
    let mut bare = profile.clone();
    bare.pens.iter_mut().for_each(|p| p.hatch = None);
    (InputArgs { hatch: None, cross_hatch: false, ..args.clone() }, bare)
}

/// Decode `data` for a layout by `layout`, as every front end does: `plot`, `preview` and the other commands
/// ([`load_laid_out`]) and the web app, which keeps the decoded drawing and lays it out later. Returns the decoded
/// drawing (not laid out) and the factor its page sizes were measured at ([`InputArgs::hatch_scale`]).
///
/// Some of an SVG's import is measured on the plotted page: hatch spacings, `--hatch tone`'s and `--fill-strokes`'
/// pen width, whether an opaque stroke is wide enough to hide what lies under it or a pattern's tiles are wider than
/// the pen, and the chords its curves are flattened into, which must stay within `--tolerance` of the curve on the
/// page: when the layout magnifies the drawing (`--fit` of a small icon onto a page, `--scale 4`) their error grows
/// by the same factor ([`Decoded::scales`]). Such an SVG is decoded once (without hatching) to learn the layout's
/// factor, then again at that factor when the first decode does not hold for it (curves then flattened at the
/// tolerance divided by the factor, at least [`FINEST_TOLERANCE_MM`]); a 37 mm card fitted to 180 mm and hatched at
/// 0.8 gets 0.8 mm between its lines on the page, not 3.9 mm. When that second decode fails (it breaks the size
/// limits, say), the first one is kept with a warning, unless it lacks the hatching asked for.
#[allow(clippy::too_many_arguments)]
pub fn decode_for_layout(
    data: &[u8],
    name: &Path,
    shown: &str,
    resources: &ResourcePolicy,
    args: &InputArgs,
    profile: &MachineProfile,
    layout: &LayoutArgs,
    cancel: &Cancel,
) -> Result<(Decoded, f64)> {
    let hatched = hatches_fills(name, data, args, profile);
    let (first_args, bare) = if hatched { unhatched(args, profile) } else { (args.clone(), profile.clone()) };
    let mut first = decode_drawing(data, name, shown, resources, &first_args, &bare, cancel)?;
    if !hatched && first.scales.is_everything() {
        return Ok((first, args.hatch_scale));
    }
    let mut laid_out = first.drawing.clone();
    let factor = match layout.apply(&mut laid_out) {
        Ok(f) => f,
        // Without hatching the first decode stands; the layout's complaint comes when the drawing is laid out.
        Err(_) if !hatched => return Ok((first, args.hatch_scale)),
        Err(e) => return Err(e),
    };
    if !hatched && first.scales.holds_for(factor) {
        return Ok((first, args.hatch_scale));
    }
    let again = InputArgs { hatch_scale: factor, ..args.clone() };
    match decode_drawing(data, name, shown, resources, &again, profile, cancel) {
        Ok(decoded) => Ok((decoded, factor)),
        // The first decode has no hatching: it cannot stand in for the one asked for.
        Err(e) if hatched => Err(e),
        Err(e) => {
            first.warnings.push(format!(
                "{shown}: laid out {factor:.2}× by the layout, but decoding it again for that size fails ({e:#}): \
                 kept as decoded at its own size, so curves may show chords up to {:.3} mm and wide strokes and \
                 pattern tiles are judged by their size in the document",
                args.page_tolerance(profile) * factor.max(1.0)
            ));
            Ok((first, args.hatch_scale))
        }
    }
}

/// [`load_decoded`], then laid out by `layout`, the page sizes of an SVG measured on the laid-out page
/// ([`decode_for_layout`]). Warnings are printed once, for the decode that is kept.
pub fn load_laid_out(path: &Path, args: &InputArgs, profile: &MachineProfile, layout: &LayoutArgs) -> Result<Decoded> {
    if path.to_str().is_some_and(|p| p.starts_with(GEN_PREFIX)) {
        let mut decoded = load_decoded(path, args, profile)?;
        layout.apply(&mut decoded.drawing)?;
        return Ok(decoded);
    }
    let data = read_input(path)?;
    let shown = shown_name(path);
    let resources = resources_beside(path);
    let (mut decoded, _) = decode_for_layout(&data, path, &shown, &resources, args, profile, layout, &Cancel::never())?;
    layout.apply(&mut decoded.drawing)?;
    warn_all(&decoded.warnings);
    Ok(decoded)
}

/// The flattening tolerance an SVG's curves are decoded at, mm in the document, for chords within `tolerance` of
/// the curve on the page once the layout magnifies the drawing `scale` times: divided by the magnification, at least
/// [`FINEST_TOLERANCE_MM`] (unless `tolerance` asks for finer); a shrinking layout keeps it (its chords shrink with
/// the drawing).
fn document_tolerance(tolerance: f64, scale: f64) -> f64 {
    (tolerance / scale.max(1.0)).max(FINEST_TOLERANCE_MM.min(tolerance))
}

/// The layout factors for which an SVG flattened at `used` mm in the document keeps its chords within `tolerance`
/// on the page: up to `tolerance / used`, or every factor when `used` is as fine as [`document_tolerance`] goes.
fn flattening_scales(tolerance: f64, used: f64) -> ScaleRange {
    let finest = used <= FINEST_TOLERANCE_MM.min(tolerance);
    ScaleRange { up_to: if finest { f64::INFINITY } else { tolerance / used }, ..ScaleRange::default() }
}

/// How an input is named in messages: its path, or `<stdin>` for `-`.
fn shown_name(path: &Path) -> String {
    if path == Path::new("-") { "<stdin>".to_string() } else { path.display().to_string() }
}

/// What an SVG read from `path` may reference: images beside it; stdin has no folder, so only data: URLs.
fn resources_beside(path: &Path) -> ResourcePolicy {
    if path == Path::new("-") { ResourcePolicy::DataUrlsOnly } else { ResourcePolicy::beside(path) }
}

/// Decode `data` read from `path` (warnings returned, not printed), with the resources [`resources_beside`] allows.
fn decode_bytes(data: &[u8], path: &Path, shown: &str, args: &InputArgs, profile: &MachineProfile) -> Result<Decoded> {
    decode_drawing(data, path, shown, &resources_beside(path), args, profile, &Cancel::never())
}

fn load_unchecked(path: &Path, shown: &str, args: &InputArgs, profile: &MachineProfile) -> Result<Decoded> {
    if let Some(spec) = path.to_str().and_then(|p| p.strip_prefix(GEN_PREFIX)) {
        let drawing = r#gen::from_spec(spec).with_context(|| format!("cannot generate {spec}"))?;
        return Ok(Decoded::plain(drawing, Vec::new()));
    }
    let decoded = decode_bytes(&read_input(path)?, path, shown, args, profile)?;
    warn_all(&decoded.warnings);
    Ok(decoded)
}

/// A drawing decoded from bytes, with the warnings met on the way (each names the input).
#[derive(Debug, Clone)]
pub struct Decoded {
    /// The drawing in page millimetres (before layout).
    pub drawing: Drawing,
    /// Warnings, ready to show.
    pub warnings: Vec<String>,
    /// What the import left out, per reason (SVG imports count it; other inputs warn only).
    pub skipped: Skipped,
    /// The layout factors the decode holds for as it is (an SVG's opaque strokes hide what lies under them by
    /// their width on the page, its pattern tiles are drawn by theirs, its curves are flattened for chords within
    /// `--tolerance` on the page: see [`decode_for_layout`]); every factor for other inputs.
    pub scales: ScaleRange,
}

impl Decoded {
    /// A drawing whose import counts nothing as skipped.
    pub fn plain(drawing: Drawing, warnings: Vec<String>) -> Self {
        Decoded { drawing, warnings, skipped: Skipped::default(), scales: ScaleRange::default() }
    }
}

/// Decode the bytes of an input file: `name` (its file name) decides the kind together with the first bytes,
/// `shown` names it in messages, and `resources` decides what an SVG may reference — a front end that receives
/// bytes from elsewhere passes [`ResourcePolicy::DataUrlsOnly`], so no path of the sender's choosing is opened.
/// `cancel` stops an SVG import or an image tracing early (with their `Cancelled` error) once it is set — a front
/// end whose requester went away sets it; [`Cancel::never`] otherwise.
pub fn decode_drawing(
    data: &[u8],
    name: &Path,
    shown: &str,
    resources: &ResourcePolicy,
    args: &InputArgs,
    profile: &MachineProfile,
    cancel: &Cancel,
) -> Result<Decoded> {
    let decoded = decode_kind(data, name, shown, resources, args, profile, cancel)?;
    // Every decoded drawing passes the size limits here, whoever asked (a file, an upload), before any later
    // stage works on it.
    plotter_path::geometry::limits::check_drawing(&decoded.drawing, shown)?;
    Ok(decoded)
}

fn decode_kind(
    data: &[u8],
    name: &Path,
    shown: &str,
    resources: &ResourcePolicy,
    args: &InputArgs,
    profile: &MachineProfile,
    cancel: &Cancel,
) -> Result<Decoded> {
    match input_kind(name, &data[..data.len().min(512)]) {
        InputKind::Unread(format) => {
            bail!("{shown} is {format}, which is not read here; the formats read are {READ_FORMATS}")
        }
        InputKind::Svg => {
            let options = SvgOptions { cancel: cancel.clone(), ..args.svg_options(profile)? };
            let imported = svg::import_svg(data, shown, resources, &options)?;
            let page_tolerance = args.page_tolerance(profile);
            let flattened = flattening_scales(page_tolerance, options.tolerance_mm);
            let ScaleRange { above, up_to } = imported.scales;
            let mut warnings = imported.warnings;
            if page_tolerance > args.tolerance {
                warnings.push(format!(
                    "{shown}: --tolerance {} mm is finer than half a motor step of {} ({page_tolerance} mm), which \
                     the machine cannot place: curves are flattened to within {page_tolerance} mm",
                    args.tolerance, profile.name
                ));
            }
            Ok(Decoded {
                drawing: imported.drawing,
                warnings,
                skipped: imported.skipped,
                scales: ScaleRange { above, up_to: up_to.min(flattened.up_to) },
            })
        }
        InputKind::Image => {
            let image = raster::decode_image(data, name)?;
            let options = args.trace_options(profile).with_context(|| shown.to_owned())?;
            let options = raster::TraceOptions { cancel: cancel.clone(), ..options };
            let mut traced = raster::trace_named(&image, shown, &options)?;
            crate::options::trace::join_stipples(&mut traced.drawing, &options);
            let warnings = traced.warnings.iter().map(|w| format!("{shown}: {w}")).collect();
            Ok(Decoded::plain(traced.drawing, warnings))
        }
        InputKind::Gcode => {
            let text = std::str::from_utf8(data).with_context(|| format!("{shown}: G-code is not UTF-8 text"))?;
            let imported = gcode_in::import_cancellable(text, shown, profile, cancel)?;
            let warnings = imported.warnings.iter().map(|w| format!("{shown}: {w}")).collect();
            Ok(Decoded::plain(imported.drawing, warnings))
        }
        InputKind::Hpgl => {
            let imported = hpgl_in::import_cancellable(data, shown, None, cancel)?;
            let warnings = imported.warnings.iter().map(|w| format!("{shown}: {w}")).collect();
            Ok(Decoded::plain(imported.drawing, warnings))
        }
        InputKind::Trajectory => {
            let text = std::str::from_utf8(data).with_context(|| format!("{shown}: not a text file"))?;
            let steps = trajectory::import(text, shown)?;
            Ok(Decoded::plain(steps.to_drawing(&StepMapper::new(profile), "trajectory"), Vec::new()))
        }
    }
}

/// What a drawing command reads: the input, how to read it, and how to lay it out on the page.
#[derive(Debug, Clone, Args)]
pub struct Source {
    /// Input: SVG, PNG/JPEG (traced), G-code, HP-GL, trajectory file, `gen:KIND?param=value&...`, or `-` for stdin
    /// (GIF, TIFF, WebP, BMP and PDF are recognised and refused by name)
    pub input: PathBuf,
    /// Input flags.
    #[command(flatten)]
    pub read: InputArgs,
    /// Layout flags.
    #[command(flatten)]
    pub layout: LayoutArgs,
}

impl Source {
    /// Load the input and lay it out; `profile` maps G-code and trajectory files back to the page.
    pub fn load(&self, profile: &MachineProfile) -> Result<Drawing> {
        Ok(self.load_decoded(profile)?.drawing)
    }

    /// [`Source::load`] with what the import left out ([`Decoded::skipped`]).
    pub fn load_decoded(&self, profile: &MachineProfile) -> Result<Decoded> {
        load_laid_out(&self.input, &self.read, profile, &self.layout)
    }
}

/// Write `bytes` to `out` (`-` is stdout).
pub fn write_output(out: &Path, bytes: &[u8]) -> Result<()> {
    if out.as_os_str() == "-" {
        use std::io::Write;
        let mut stdout = std::io::stdout().lock();
        stdout.write_all(bytes).context("cannot write to stdout")?;
        stdout.flush().context("cannot write to stdout")?;
    } else {
        std::fs::write(out, bytes).with_context(|| format!("cannot write {}", out.display()))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kinds_by_name_extension_and_content() {
        assert_eq!(input_kind(Path::new("a.svg"), b""), InputKind::Svg);
        assert_eq!(input_kind(Path::new("a.JPG"), b""), InputKind::Image);
        assert_eq!(input_kind(Path::new("a.NGC"), b""), InputKind::Gcode);
        assert_eq!(input_kind(Path::new("a.traj"), b""), InputKind::Trajectory);
        assert_eq!(input_kind(Path::new("a.PLT"), b""), InputKind::Hpgl);
        assert_eq!(input_kind(Path::new("a.hpgl"), b""), InputKind::Hpgl);
        assert_eq!(input_kind(Path::new("out"), b"IN;SP1;PU0,0;"), InputKind::Hpgl);
        assert_eq!(input_kind(Path::new("a.txt"), b"3\n1\n0\n0\n"), InputKind::Trajectory);
        assert_eq!(input_kind(Path::new("a.txt"), b"G1 X1\n"), InputKind::Gcode);
        assert_eq!(input_kind(Path::new("a"), b"  <svg/>"), InputKind::Svg);
        assert_eq!(input_kind(Path::new(""), b"\x89PNG\r\n\x1a\n...."), InputKind::Image);
        assert_eq!(input_kind(Path::new("scan"), &[0xff, 0xd8, 0xff, 0xe0]), InputKind::Image);
        // Content wins over a misleading name: gzip bytes are a compressed SVG, an XML start is SVG.
        assert_eq!(input_kind(Path::new("a.gcode"), &[0x1f, 0x8b, 8, 0]), InputKind::Svg);
        assert_eq!(input_kind(Path::new("a.svgz"), b""), InputKind::Svg);
        assert_eq!(input_kind(Path::new("a.txt"), b"<?xml version=\"1.0\"?><svg/>"), InputKind::Svg);
        assert_eq!(input_kind(Path::new("a.png"), b"\xef\xbb\xbf<svg/>"), InputKind::Svg);
        assert_eq!(input_kind(Path::new("a.svg"), b"\x89PNG\r\n\x1a\n"), InputKind::Image);
        assert_eq!(input_kind(Path::new("x"), &[0xff, 0xfe, b'<', 0]), InputKind::Svg);
    }

    #[test]
    fn images_and_documents_that_are_not_read_are_named_by_their_signature() {
        let gif = b"GIF89a\x01\x00\x01\x00\x80\x00\x00";
        let webp = b"RIFF\x24\x00\x00\x00WEBPVP8 ";
        let mut bmp = b"BM\x3a\x00\x00\x00\x00\x00\x00\x00\x36\x00\x00\x00".to_vec();
        bmp.extend_from_slice(&40u32.to_le_bytes());
        let cases: [(&str, &[u8], &str); 9] = [
            ("up.gcode", gif, "a GIF image"),
            ("a", b"GIF87a....", "a GIF image"),
            ("scan.nc", b"II*\x00\x08\x00\x00\x00", "a TIFF image"),
            ("scan", b"MM\x00*\x00\x00\x00\x08", "a TIFF image"),
            ("photo.hpgl", webp, "a WebP image"),
            ("x", &bmp, "a BMP image"),
            ("doc", b"%PDF-1.7\n", "a PDF document"),
            ("pic.gif", b"", "a GIF image"),
            ("pic.TIFF", b"", "a TIFF image"),
        ];
        for (name, head, format) in cases {
            assert_eq!(input_kind(Path::new(name), head), InputKind::Unread(format), "{name}");
        }
        // G-code that happens to start with B or M is still G-code; so is an HP-GL file called .plt.
        assert_eq!(input_kind(Path::new("a.gcode"), b"BM? no: M3 S90\n"), InputKind::Gcode);
        assert_eq!(input_kind(Path::new("a.txt"), b"MM\n"), InputKind::Gcode);
        // Decoding one says what it is and what is read.
        let e = decode_drawing(
            gif,
            Path::new("up.gcode"),
            "up.gcode",
            &ResourcePolicy::DataUrlsOnly,
            &test_args(),
            &MachineProfile::default_plotter(),
            &Cancel::never(),
        )
        .unwrap_err();
        let e = format!("{e:#}");
        assert!(e.starts_with("up.gcode is a GIF image, which is not read here; the formats read are SVG"), "{e}");
        assert!(e.contains("PNG and JPEG") && e.contains("G-code") && e.contains("HP-GL"), "{e}");
    }

    /// A circle of 2 mm radius decoded at `--tolerance 0.002` for `profile`: (the farthest any chord's middle
    /// lies inside the circle, mm, the warnings). (The SVG library turns the circle into four cubics, within
    /// 0.0006 mm of it at this radius.)
    fn circle_at_fine_tolerance(profile: &MachineProfile) -> (f64, Vec<String>) {
        let svg = br#"<svg xmlns="http://www.w3.org/2000/svg" width="40mm" height="40mm" viewBox="0 0 40 40">
            <circle cx="20" cy="20" r="2" fill="none" stroke="black"/></svg>"#;
        let args = InputArgs { tolerance: 0.002, ..test_args() };
        let decoded = decode_drawing(
            svg,
            Path::new("c.svg"),
            "c.svg",
            &ResourcePolicy::DataUrlsOnly,
            &args,
            profile,
            &Cancel::never(),
        )
        .unwrap();
        let centre = plotter_path::kurbo::Point::new(20.0, 20.0);
        let sagitta = decoded
            .drawing
            .paths()
            .flat_map(|p| p.points.windows(2).map(|w| 2.0 - w[0].midpoint(w[1]).distance(centre)))
            .fold(0.0, f64::max);
        (sagitta, decoded.warnings)
    }

    #[test]
    fn curves_are_flattened_no_finer_than_half_a_motor_step() {
        // The HP 7475A steps 0.025 mm (40 steps/mm): half a step is 0.0125 mm, coarser than the 0.002 asked.
        let hp = plotter_path::config::models::find("hp7475a").unwrap().profile();
        assert_eq!(test_args().page_tolerance(&hp), svg::DEFAULT_TOLERANCE_MM);
        assert_eq!(InputArgs { tolerance: 0.002, ..test_args() }.page_tolerance(&hp), 0.0125);
        let (sagitta, warnings) = circle_at_fine_tolerance(&hp);
        assert!(sagitta > 0.002 * 2.0 && sagitta <= 0.0125 + 1e-9, "{sagitta}");
        assert_eq!(warnings.len(), 1, "{warnings:?}");
        let w = &warnings[0];
        assert!(w.starts_with("c.svg: --tolerance 0.002 mm") && w.contains("HP 7475A") && w.contains("0.0125"), "{w}");
        // At 400 steps/mm half a step is 0.00125 mm: the 0.002 asked stands, without a word.
        let mut fine = hp.clone();
        fine.axes.x.steps_per_mm = 400.0;
        let (sagitta, warnings) = circle_at_fine_tolerance(&fine);
        assert!(sagitta <= 0.002 + 1e-9, "{sagitta}");
        assert_eq!(warnings, Vec::<String>::new());
    }

    /// The input and layout flags of a plot, parsed on their own.
    #[derive(clap::Parser)]
    struct PageFlags {
        #[command(flatten)]
        input: InputArgs,
        #[command(flatten)]
        layout: LayoutArgs,
    }

    /// A 37 × 20 mm card whose SVG holds `body`, written to a fresh folder: (the folder, the file).
    fn card_svg(name: &str, body: &str) -> (std::path::PathBuf, std::path::PathBuf) {
        let dir = std::env::temp_dir().join(format!("plotter-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let card = dir.join("card.svg");
        let svg = format!(
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="37mm" height="20mm" viewBox="0 0 37 20">{body}</svg>"#
        );
        std::fs::write(&card, svg).unwrap();
        (dir, card)
    }

    /// A 37 × 20 mm card (a grey rectangle) fitted to a 200 mm square page with 10 mm margins is magnified
    /// 180 / 37 = 4.865×. Hatched at 0.8 mm, its horizontal lines must lie 0.8 mm apart on the page (hatched before
    /// the layout they were 0.8 · 4.865 = 3.89 mm apart); with `--hatch tone` its mid grey (#808080: darkness
    /// 0.784, less its outline's share) gets two crossing families 0.5615 mm apart on the page, the pen being 0.3 mm.
    #[test]
    fn hatch_spacing_is_measured_on_the_laid_out_page() {
        let (dir, card) = card_svg("hatch-fit", r##"<rect x="0" y="0" width="37" height="20" fill="#808080"/>"##);
        let profile = MachineProfile::default_plotter();
        let load = |flags: &[&str]| {
            let base = ["t", "--paper", "200x200", "--margin", "10", "--fit", "--pen-width", "0.3"];
            let w = <PageFlags as clap::Parser>::try_parse_from(base.iter().chain(flags)).unwrap();
            load_laid_out(&card, &w.input, &profile, &w.layout).unwrap().drawing
        };
        // The gaps between neighbouring horizontal line heights, away from the card's edges.
        let gaps = |d: &Drawing| {
            let mut ys: Vec<f64> = d
                .paths()
                .flat_map(|p| p.points.windows(2).map(|w| (w[0], w[1])).collect::<Vec<_>>())
                .filter(|(a, b)| (a.y - b.y).abs() < 1e-9 && (a.x - b.x).abs() > 100.0)
                .map(|(a, _)| a.y)
                .collect();
            ys.sort_by(f64::total_cmp);
            ys.dedup_by(|a, b| (*a - *b).abs() < 1e-6);
            // The card's top and bottom edges are no hatch lines.
            ys.pop();
            ys.remove(0);
            ys.windows(2).map(|w| w[1] - w[0]).collect::<Vec<_>>()
        };
        let spaced = gaps(&load(&["--hatch", "0.8", "--angle", "0"]));
        assert!(spaced.len() > 100, "{} gaps", spaced.len());
        assert!(spaced.iter().all(|g| (g - 0.8).abs() < 1e-5), "{spaced:?}");
        let toned = gaps(&load(&["--hatch", "tone", "--angle", "0"]));
        // The card's outline inks half a pen width along its 554.6 mm edge of its 17,513 mm² on the page: a share
        // f = 0.00475 the hatch leaves out, (0.78414 − f) / (1 − f) = 0.78311.
        let (w, h) = (180.0f64, 180.0 * 20.0 / 37.0);
        let f = 2.0 * (w + h) * 0.15 / (w * h);
        let want = 0.3 / (1.0 - (1.0 - (0.78414 - f) / (1.0 - f)).sqrt());
        assert!(toned.len() > 100 && toned.iter().all(|g| (g - want).abs() < 1e-3), "{want}: {toned:?}");
        // The pen table's hatches are page sizes too: a grey pen hatching at 0.8 mm, then one hatching by tone.
        let with_pen = |hatch: &str| {
            let toml = format!(
                "{}\n[[pens]]\nname = \"grey\"\ncolor = \"#808080\"\nwidth_mm = 0.3\nhatch = {{ {hatch}, angle_deg = 0 }}\n",
                plotter_path::config::profile::DEFAULT_PROFILE_TOML
            );
            let profile = MachineProfile::from_toml(&toml, "t.toml").unwrap();
            let base = ["t", "--paper", "200x200", "--margin", "10", "--fit", "--layer-by", "color"];
            let w = <PageFlags as clap::Parser>::try_parse_from(base).unwrap();
            load_laid_out(&card, &w.input, &profile, &w.layout).unwrap().drawing
        };
        let spaced = gaps(&with_pen("spacing_mm = 0.8"));
        assert!(spaced.len() > 100 && spaced.iter().all(|g| (g - 0.8).abs() < 1e-5), "{spaced:?}");
        let toned = gaps(&with_pen("tone = true"));
        assert!(toned.len() > 100 && toned.iter().all(|g| (g - want).abs() < 1e-3), "{want}: {toned:?}");
        std::fs::remove_dir_all(&dir).ok();
    }

    /// `--fill-strokes` passes are a pen width apart on the page too. A 37 × 20 mm card framed by a 2 mm wide stroke
    /// (its outline exactly the card) fitted to a 200 mm page with 10 mm margins is magnified 180 / 37 = 4.865×:
    /// the frame, 9.73 mm wide on the page, is filled with passes at 45° 0.3 mm apart, the pen's width (filled
    /// before the layout they were 0.3 · 4.865 = 1.46 mm apart). The layout must see the passes when it learns its
    /// factor: without them the card is the stroke's middle line, 35 mm wide, and the passes come out
    /// 0.3 · 35 / 37 = 0.284 mm apart.
    #[test]
    fn fill_strokes_passes_are_a_pen_width_apart_on_the_laid_out_page() {
        let frame = r#"<rect x="1" y="1" width="35" height="18" fill="none" stroke="black" stroke-width="2"/>"#;
        let (dir, card) = card_svg("fill-strokes-fit", frame);
        let flags = ["t", "--paper", "200x200", "--margin", "10", "--fit", "--pen-width", "0.3", "--fill-strokes"];
        let w = <PageFlags as clap::Parser>::try_parse_from(flags).unwrap();
        let d = load_laid_out(&card, &w.input, &MachineProfile::default_plotter(), &w.layout).unwrap().drawing;
        std::fs::remove_dir_all(&dir).ok();
        let bounds = d.bbox().unwrap();
        assert!((bounds.width() - 180.0).abs() < 1e-6, "{bounds:?}");
        // The passes' places across their direction (x + y constant along a line at 45° on the page, y down), each
        // once; every line across the frame meets it, so they follow one another at the spacing.
        let mut vs: Vec<f64> = d
            .paths()
            .flat_map(|p| p.points.windows(2).map(|w| (w[0], w[1])).collect::<Vec<_>>())
            .filter(|(a, b)| a.distance(*b) > 1e-6 && ((a.x + a.y) - (b.x + b.y)).abs() < 1e-9)
            .map(|(a, _)| (a.x + a.y) / std::f64::consts::SQRT_2)
            .collect();
        vs.sort_by(f64::total_cmp);
        vs.dedup_by(|a, b| (*a - *b).abs() < 1e-6);
        let gaps: Vec<f64> = vs.windows(2).map(|w| w[1] - w[0]).collect();
        // (180 + 97.3) / √2 = 196 mm across: 650 passes.
        assert!(gaps.len() > 600, "{} passes", vs.len());
        assert!(gaps.iter().all(|g| (g - 0.3).abs() < 1e-6), "{gaps:?}");
    }

    /// `--fill-strokes` passes run the way `--angle` says, with or without `--hatch`. The 2 mm frame of the
    /// 37 × 20 mm card, fitted to 180 mm, is filled with passes at 30° counter-clockwise from +X as seen: direction
    /// (cos 30°, −sin 30°) = (0.8660, −0.5) on the page (y down), so along a pass x·sin 30° + y·cos 30° stays put,
    /// and neighbouring passes lie 0.3 mm apart across that direction. (They ran at 45° whatever --angle said.)
    #[test]
    fn fill_strokes_passes_follow_the_angle_given() {
        use plotter_path::kurbo::Point;
        let frame = r#"<rect x="1" y="1" width="35" height="18" fill="none" stroke="black" stroke-width="2"/>"#;
        let (dir, card) = card_svg("fill-strokes-angle", frame);
        let (sin, cos) = 30f64.to_radians().sin_cos();
        for extra in [&[][..], &["--hatch", "tone"], &["--hatch", "0.8"]] {
            let base = ["t", "--paper", "200x200", "--margin", "10", "--fit", "--pen-width", "0.3", "--fill-strokes"];
            let flags: Vec<&str> = base.iter().chain(extra).copied().chain(["--angle", "30"]).collect();
            let w = <PageFlags as clap::Parser>::try_parse_from(flags).unwrap();
            let d = load_laid_out(&card, &w.input, &MachineProfile::default_plotter(), &w.layout).unwrap().drawing;
            // Every long segment that is not the frame's middle line (along x or y) is a pass.
            let passes: Vec<(Point, Point)> = d
                .paths()
                .flat_map(|p| p.points.windows(2).map(|w| (w[0], w[1])).collect::<Vec<_>>())
                .filter(|(a, b)| a.distance(*b) > 2.0 && (a.x - b.x).abs() > 1e-6 && (a.y - b.y).abs() > 1e-6)
                .collect();
            assert!(passes.len() > 300, "{extra:?}: {} passes", passes.len());
            for (a, b) in &passes {
                let u = (*b - *a) / a.distance(*b);
                assert!((u.x.abs() - cos).abs() < 1e-6 && (u.y.abs() - sin).abs() < 1e-6, "{extra:?}: {u:?}");
                assert!(u.x * u.y < 0.0, "{extra:?}: {u:?} runs down to the right");
            }
            let mut vs: Vec<f64> = passes.iter().map(|(a, _)| a.x * sin + a.y * cos).collect();
            vs.sort_by(f64::total_cmp);
            vs.dedup_by(|a, b| (*a - *b).abs() < 1e-6);
            assert!(vs.windows(2).all(|w| (w[1] - w[0] - 0.3).abs() < 1e-6), "{extra:?}: {vs:?}");
        }
        std::fs::remove_dir_all(&dir).ok();
    }

    /// The lengths of the drawing's horizontal paths (y constant), longest first.
    fn horizontal_lengths(d: &Drawing) -> Vec<f64> {
        let mut out: Vec<f64> = d
            .paths()
            .filter(|p| p.points.len() >= 2 && p.points.iter().all(|q| (q.y - p.points[0].y).abs() < 1e-9))
            .map(|p| p.points.windows(2).map(|w| w[0].distance(w[1])).sum())
            .collect();
        out.sort_by(|a, b| b.total_cmp(a));
        out
    }

    /// An opaque stroke hides what lies under it by its width on the page, the pen being 0.3 mm (four pens:
    /// 1.2 mm). On the 37 × 20 mm card, a thin line across its middle lies under a 0.5 mm black stroke down its
    /// middle; fitted to 180 mm (4.865×) the stroke is 0.5 · 180 / 37 = 2.432 mm wide on the page, so the line
    /// splits into two pieces of (180 − 2.432) / 2 = 88.784 mm. (Judged in the document's 0.5 mm it stayed whole.)
    /// The other way: a card ten times that size (370 mm, its stroke 5 mm) shrunk to 180 mm has a 2.432 mm stroke
    /// too, and with a 0.7 mm pen (2.8 mm) that no longer hides: the line stays whole at 180 mm.
    #[test]
    fn a_stroke_hides_what_lies_under_it_by_its_width_on_the_page() {
        let body = r#"<path d="M0 10H37" stroke="black" stroke-width="0.1" fill="none"/>
            <path d="M18.5 0V20" stroke="black" stroke-width="0.5" fill="none"/>"#;
        let (dir, card) = card_svg("wide-stroke-fit", body);
        let flags = ["t", "--paper", "200x200", "--margin", "10", "--fit"];
        let w = <PageFlags as clap::Parser>::try_parse_from(flags).unwrap();
        let d = load_laid_out(&card, &w.input, &MachineProfile::default_plotter(), &w.layout).unwrap().drawing;
        let pieces = horizontal_lengths(&d);
        let want = (180.0 - 0.5 * 180.0 / 37.0) / 2.0;
        assert_eq!(pieces.len(), 2, "{pieces:?}");
        assert!(pieces.iter().all(|l| (l - want).abs() < 0.01), "{want}: {pieces:?}");
        // Shrunk: ten times the card, a 0.7 mm pen.
        let big = dir.join("big.svg");
        let svg = std::fs::read_to_string(&card).unwrap().replace("37mm", "370mm").replace("20mm", "200mm");
        std::fs::write(&big, svg).unwrap();
        let toml = plotter_path::config::profile::DEFAULT_PROFILE_TOML.replacen("width_mm = 0.3", "width_mm = 0.7", 1);
        let profile = MachineProfile::from_toml(&toml, "t.toml").unwrap();
        assert_eq!(profile.pen.width_mm, 0.7);
        let d = load_laid_out(&big, &w.input, &profile, &w.layout).unwrap().drawing;
        let whole = horizontal_lengths(&d);
        assert!(whole.len() == 1 && (whole[0] - 180.0).abs() < 1e-6, "{whole:?}");
        std::fs::remove_dir_all(&dir).ok();
    }

    /// Total pen-down length, mm.
    fn ink(d: &Drawing) -> f64 {
        d.paths().map(plotter_path::Polyline::length).sum()
    }

    /// A pattern fill is drawn when its tiles are wider than the 0.3 mm pen on the page. The 37 × 20 mm card is
    /// framed by a thin line (114 mm) and holds a 5 × 2.5 mm rect filled with 0.25 mm tiles, each with a line across
    /// its middle: 10 rows of 5 mm, 50 mm. As it is the tiles are 0.25 mm, not drawn: 114 mm of ink. Fitted to
    /// 180 mm (4.865×) they are 1.216 mm: (114 + 50) · 180 / 37 = 797.84 mm (judged in the document they were left
    /// out: 554.59 mm). The other way: a 370 × 200 mm poster (a 1140 mm frame) with 0.5 mm tiles over a 10 × 5 mm
    /// rect (10 rows of 10 mm) draws them as it is, 1240 mm, and not once shrunk to 180 mm (0.243 mm tiles):
    /// 1140 · 180 / 370 = 554.59 mm (drawn, they made it 603.24 mm).
    #[test]
    fn pattern_tiles_are_drawn_by_their_width_on_the_page() {
        let tiles = |size: f64, x: f64, w: f64| {
            format!(
                r#"<defs><pattern id="p" patternUnits="userSpaceOnUse" width="{size}" height="{size}">
                  <path d="M0 {}H{size}" stroke="black" stroke-width="0.05"/></pattern></defs>
                <rect x="{x}" y="{x}" width="{w}" height="{}" fill="url(#p)"/>"#,
                size / 2.0,
                w / 2.0
            )
        };
        let frame = r#"<rect x="0" y="0" width="37" height="20" fill="none" stroke="black" stroke-width="0.1"/>"#;
        let (dir, card) = card_svg("pattern-fit", &format!("{frame}{}", tiles(0.25, 5.0, 5.0)));
        let poster = dir.join("poster.svg");
        let body = format!("{}{}", frame.replace("37", "370").replace("20", "200"), tiles(0.5, 50.0, 10.0));
        let svg = format!(
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="370mm" height="200mm" viewBox="0 0 370 200">{body}</svg>"#
        );
        std::fs::write(&poster, svg).unwrap();
        let profile = MachineProfile::default_plotter();
        assert_eq!(profile.pen.width_mm, 0.3);
        let ink_of = |file: &Path, fit: bool| {
            let flags = ["t", "--paper", "200x200", "--margin", "10", "--fit"];
            let w = <PageFlags as clap::Parser>::try_parse_from(if fit { &flags[..] } else { &flags[..1] }).unwrap();
            ink(&load_laid_out(file, &w.input, &profile, &w.layout).unwrap().drawing)
        };
        let cases = [
            (&card, false, 114.0),
            (&card, true, 164.0 * 180.0 / 37.0),
            (&poster, false, 1240.0),
            (&poster, true, 1140.0 * 180.0 / 370.0),
        ];
        for (file, fit, want) in cases {
            let got = ink_of(file, fit);
            assert!((got - want).abs() < 1e-3, "{} fit {fit}: {got} mm of ink, want {want}", file.display());
        }
        std::fs::remove_dir_all(&dir).ok();
    }

    /// `--colors pens` with a machine profile whose pens have no colour is refused naming what the command line
    /// offers: `--model`, `--profile`, `--colors cmyk` (it pointed at preview and plot, which read the picture
    /// with that very profile), for a picture and for an SVG whose images are traced.
    #[test]
    fn colors_pens_without_coloured_pens_names_the_machine_flags() {
        let toml = plotter_path::config::profile::DEFAULT_PROFILE_TOML;
        let plain: Vec<&str> = toml.lines().filter(|l| !l.trim_start().starts_with("color =")).collect();
        let mut profile = MachineProfile::from_toml(&plain.join("\n"), "plain.toml").unwrap();
        profile.name = "plain pens".into();
        let photo = Path::new(env!("CARGO_MANIFEST_DIR")).join("../samples/photo.png");
        let (dir, card) = card_svg("pens-hint", r#"<path d="M0 10H37" stroke="black"/>"#);
        for (file, extra) in [(&photo, &[][..]), (&card, &["--images", "mosaic"][..])] {
            let flags = ["t", "--mode", "mosaic", "--colors", "pens"];
            let w = <PageFlags as clap::Parser>::try_parse_from(flags.iter().chain(extra)).unwrap();
            let e = format!("{:#}", load_laid_out(file, &w.input, &profile, &w.layout).unwrap_err());
            assert!(e.contains("machine profile \"plain pens\" has no pen with a colour"), "{e}");
            assert!(e.contains("(--model)") && e.contains("(--profile)") && e.contains("--colors cmyk"), "{e}");
            assert!(!e.contains("preview"), "{e}");
        }
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn hatch_takes_a_spacing_or_tone_and_refuses_anything_else() {
        assert_eq!("tone".parse::<HatchArg>(), Ok(HatchArg::Tone));
        assert_eq!("0.8".parse::<HatchArg>(), Ok(HatchArg::Spacing(0.8)));
        let e = "0".parse::<HatchArg>().unwrap_err();
        assert!(e.contains("positive") && e.contains('0'), "{e}");
        let e = "dense".parse::<HatchArg>().unwrap_err();
        assert!(e.contains("\"dense\"") && e.contains("tone"), "{e}");
        // Crossings are the tone's to decide.
        let mut a = test_args();
        a.hatch = Some(HatchArg::Tone);
        a.cross_hatch = true;
        let e = a.svg_options(&MachineProfile::default_plotter()).unwrap_err().to_string();
        assert!(e.contains("--cross-hatch") && e.contains("--hatch tone"), "{e}");
    }

    fn test_args() -> InputArgs {
        #[derive(clap::Parser)]
        struct W {
            #[command(flatten)]
            input: InputArgs,
        }
        <PageFlags as clap::Parser>::parse_from(["t"]).input
    }
}
