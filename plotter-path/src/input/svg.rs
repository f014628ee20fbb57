//! SVG import through usvg: every shape, nested transforms, viewBox and preserveAspectRatio, physical units,
//! `<use>`, hidden elements, and text as glyph outlines — flattened to millimetre polylines with a proven chord
//! bound (see [`crate::geometry::flatten`]) — and cut so the plot shows what a browser shows.
//!
//! **Reading.** Anything a browser opens: gzip-compressed files (`.svgz`, or gzip bytes under any name), any
//! declared encoding or byte order mark, and DOCTYPEs with internal entities, with bounded entity expansion and
//! node count (see [`decode`]).
//!
//! **What is plotted** (the reference is the SVG rendered by a browser or resvg; see [`walk`] for the details):
//! a stroked path along its centre line (dashes as separate pen-down dashes); a fill-only path along the outline
//! of its filled area where the colour on its two sides differs as painted (a white shape on black is outlined,
//! on the paper it only hides what lies under it; see [`edges`]);
//! a `<pattern>` fill as its tiles' content, cut to the shape (see [`walk`]'s pattern module; patterns finer than
//! the pen are skipped with a warning); with [`SvgOptions::hatch`], every filled area is also shaded with
//! parallel lines. Everything is cut to its
//! clip paths, masks (their opaque area) and nested viewports; with [`SvgOptions::occlusion`] (on by default) the
//! parts of lines under a fill more than half opaque painted later are removed ([`occlude`]). Skipped with a warning: paths
//! with neither fill nor stroke, `display:none`/`visibility:hidden`, fully transparent shapes. Geometry outside
//! the page is reported, and cut at the page edge with [`SvgOptions::crop`]; lines reaching beyond ±1 km are cut
//! there with a warning ([`bounds`]). Embedded raster `<image>`s are
//! traced through the raster pipeline when [`SvgOptions::images`] asks for it, else skipped with a warning.
//!
//! **Units.** usvg resolves units at 96 px per inch (1 px = 1/96 in, 1 mm = 96/25.4 px) and folds the root
//! viewBox/preserveAspectRatio into the transforms, so this importer only converts px to mm. usvg keeps geometry
//! in `f32`: coordinates are exact for dyadic values and otherwise carry a relative error of about 1e-7
//! (0.03 µm on a 300 mm page), far below any plotter's resolution.
//!
//! **Arcs.** usvg turns elliptical arcs (and circles, ellipses, rounded rects) into cubic Béziers within 0.1 user
//! units and at most 2.7e-4 of the radius (cubics spanning ≤ 90°). Only for very large arcs can that exceed the
//! flattening tolerance; the importer then warns with the bound in millimetres. The chord error of a
//! curve given as an arc is therefore at most the tolerance plus usvg's 0.1 user unit.
//!
//! **Layers are pens.** [`LayerBy::Auto`] (the default): one layer per Inkscape layer
//! (`inkscape:groupmode="layer"`, named by its label, with or without an `id`: see [`layers`]) when the
//! document has any — shapes outside every layer go
//! to a layer named `root` — otherwise the whole drawing is one layer. [`LayerBy::Group`] makes a layer of each
//! top-level `<g>` (vpype's convention; other top-level content goes to `root`). [`LayerBy::Color`] makes one
//! layer per stroke colour as usvg normalises it (`red` and `#ff0000` are one pen; fill colour for fill-only
//! paths). [`LayerBy::None`] puts everything in one layer. Nothing but a layer element makes a layer.

pub mod attributes;
mod bounds;
pub mod decode;
pub mod dtd;
mod edges;
mod grid;
pub mod hershey;
mod layers;
mod occlude;
mod page_scale;
pub mod resources;
mod walk;

pub use page_scale::ScaleRange;
pub use resources::ResourcePolicy;

use std::collections::HashMap;
use std::path::Path;

use kurbo::{Affine, Point, Rect};
use usvg::roxmltree;

use crate::geometry::cancel::Cancel;
use crate::geometry::drawing::{Drawing, Layer, Polyline, Rgb};
use crate::geometry::hatch::FillHatch;
use crate::geometry::region::{Keep, Region, cut};
use crate::input::raster::TraceOptions;
use crate::input::skipped::{SkipReason, Skipped};

/// Millimetres per CSS pixel (1/96 in).
pub const MM_PER_PX: f64 = 25.4 / 96.0;

/// Default flattening tolerance, mm.
pub const DEFAULT_TOLERANCE_MM: f64 = 0.05;

/// Fonts tried, in order, for the generic families (serif, sans-serif, monospace, cursive, fantasy).
const FALLBACK_FAMILIES: [&str; 4] = ["DejaVu Sans", "Liberation Sans", "Noto Sans", "FreeSans"];

/// Errors that stop an SVG import.
#[derive(Debug, thiserror::Error)]
pub enum SvgError {
    /// The file could not be read.
    #[error("{path}: cannot read: {source}")]
    Read {
        /// The file.
        path: String,
        /// The OS error.
        source: std::io::Error,
    },
    /// Not an SVG document, or malformed XML.
    #[error("{path}: not a valid SVG document: {message}")]
    Parse {
        /// The file.
        path: String,
        /// What the parser said, with line and column where known.
        message: String,
    },
    /// Parsed, but nothing drawable remains.
    #[error("{path}: nothing to draw: no visible shapes{detail}")]
    Empty {
        /// The file.
        path: String,
        /// Why, when it is more than "no shapes".
        detail: String,
    },
    /// The import was cancelled ([`SvgOptions::cancel`]) before it ended.
    #[error("{path}: import cancelled (the drawing was no longer wanted)")]
    Cancelled {
        /// The file.
        path: String,
    },
    /// A requested layer does not exist.
    #[error("{path}: no layer named '{name}'; layers are: {available}")]
    NoSuchLayer {
        /// The file.
        path: String,
        /// The requested name.
        name: String,
        /// The names that exist.
        available: String,
    },
}

/// How paths are grouped into layers (pens).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LayerBy {
    /// Inkscape layers when the document has any, else one layer.
    #[default]
    Auto,
    /// One layer per top-level `<g>` (Inkscape label, else id).
    Group,
    /// One layer per normalised stroke colour.
    Color,
    /// Everything in one layer.
    None,
}

/// How `<text>` is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum TextMode {
    /// The outlines of the font's glyphs (needs a system font, e.g. Debian's fonts-dejavu-core).
    #[default]
    Outlines,
    /// One line per stroke with a Hershey font (needs Debian's hershey-fonts-data).
    SingleStroke,
}

/// How embedded raster images are traced (`--images`).
#[derive(Debug, Clone, PartialEq)]
pub struct ImageTrace {
    /// The raster tracer's settings; the pixel pitch is set from the image's size on the page.
    pub trace: TraceOptions,
}

/// How strokes wider than the pen are filled (`--fill-strokes`): with parallel passes a pen width apart.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FillStrokes {
    /// The pen's width, mm in the document (a page width divided by [`SvgOptions::hatch_scale`]): the passes'
    /// spacing; strokes wider than 1.5 of it are filled.
    pub pen_mm: f64,
    /// Direction of the passes, degrees counter-clockwise from +X as seen on the page.
    pub angle_deg: f64,
}

/// Import settings.
#[derive(Debug, Clone, PartialEq)]
pub struct SvgOptions {
    /// Maximum chord error of flattened curves, mm.
    pub tolerance_mm: f64,
    /// Layer grouping rule.
    pub layer_by: LayerBy,
    /// Keep only these layers (by name); empty keeps all.
    pub layers: Vec<String>,
    /// Remove the parts of lines hidden under opaque fills painted later.
    pub occlusion: bool,
    /// Shade filled areas with parallel lines.
    pub hatch: Option<FillHatch>,
    /// Shade every filled area by its lightness (`--hatch tone`, see [`crate::geometry::tone_hatch`]): sparser
    /// lines for light fills, denser and then crossing ones for dark fills, following gradients; wins over
    /// [`SvgOptions::hatch`] and the pens' hatches.
    pub tone_hatch: Option<crate::geometry::tone_hatch::ToneHatch>,
    /// How much the layout magnifies the drawing: the pen table's hatch spacings and tone pen widths are page
    /// sizes, divided by this at import so that they come out as asked on the page, and a stroke's width times
    /// this is its width on the page, which decides whether it hides what lies under it (1: no layout).
    pub hatch_scale: f64,
    /// Fill strokes wider than the pen with parallel passes a pen width apart.
    pub fill_strokes: Option<FillStrokes>,
    /// How text is drawn.
    pub text: TextMode,
    /// Trace embedded raster images; `None` skips them with a warning.
    pub images: Option<ImageTrace>,
    /// Cut everything at the page edge.
    pub crop: bool,
    /// The paper's colour: fill-only shapes of this colour draw an outline only where they lie on another colour.
    pub paper_color: Rgb,
    /// The pen's width, mm on the page: opaque strokes wider than four times this on the page hide what lies under
    /// them, as fills do (thinner ones would only nick the lines they cross).
    pub pen_width_mm: f64,
    /// The profile's pen table: a layer whose pen (matched by name, then colour, see
    /// [`crate::config::pens::table_index`]) has a `hatch` gets its fills shaded, unless [`SvgOptions::hatch`]
    /// sets one hatch for all.
    pub pens: Vec<crate::config::profile::PenSpec>,
    /// Stops the import early with [`SvgError::Cancelled`] when set: checked after parsing, at every element of
    /// the walk and every item of hidden-line removal, and passed on to the tracer of embedded images.
    pub cancel: Cancel,
}

impl Default for SvgOptions {
    fn default() -> Self {
        SvgOptions {
            tolerance_mm: DEFAULT_TOLERANCE_MM,
            layer_by: LayerBy::Auto,
            layers: Vec::new(),
            occlusion: true,
            hatch: None,
            tone_hatch: None,
            hatch_scale: 1.0,
            fill_strokes: None,
            text: TextMode::Outlines,
            images: None,
            crop: false,
            paper_color: Rgb(255, 255, 255),
            pen_width_mm: crate::geometry::drawing::Pen::default().width_mm,
            pens: Vec::new(),
            cancel: Cancel::never(),
        }
    }
}

/// A successful import: the drawing and everything the user should be told about.
#[derive(Debug, Clone, PartialEq)]
pub struct Imported {
    /// The drawing, in mm, page coordinates.
    pub drawing: Drawing,
    /// Elements that were skipped or approximated, each naming the element and its line.
    pub warnings: Vec<String>,
    /// How many elements were left out (wholly or in part), per reason: the summary beside the warnings.
    pub skipped: Skipped,
    /// The layout factors this import holds for as it is ([`SvgOptions::hatch_scale`] among them): laid out by
    /// another factor, some opaque stroke would hide what lies under it on the page where it now does not, or the
    /// other way round, and the drawing should be decoded again at that factor.
    pub scales: ScaleRange,
}

/// Load and import an SVG file; it may reference image files beside it ([`ResourcePolicy::beside`]).
pub fn load_svg(path: &Path, options: &SvgOptions) -> Result<Imported, SvgError> {
    let shown = path.display().to_string();
    let data = std::fs::read(path).map_err(|source| SvgError::Read { path: shown.clone(), source })?;
    import_svg(&data, &shown, &ResourcePolicy::beside(path), options)
}

/// Import SVG bytes (plain or gzip-compressed); `name` is used in messages, `resources` decides what the
/// document may reference beyond its own bytes (a front end receiving bytes from elsewhere passes
/// [`ResourcePolicy::DataUrlsOnly`]).
pub fn import_svg(
    data: &[u8],
    name: &str,
    resources: &ResourcePolicy,
    options: &SvgOptions,
) -> Result<Imported, SvgError> {
    let parse_err = |message: String| SvgError::Parse { path: name.to_string(), message };
    let cancelled = |_| SvgError::Cancelled { path: name.to_string() };
    let text = decode::checked_text(data, decode::MAX_INFLATED_BYTES).map_err(parse_err)?;
    let xml = decode::parse_xml(&text).map_err(parse_err)?;
    if xml.root_element().tag_name().name() != "svg" {
        return Err(parse_err(format!("root element is <{}>, expected <svg>", xml.root_element().tag_name().name())));
    }
    check_page_size(xml.root_element()).map_err(parse_err)?;
    // Layer groups without an id get one, so that they can be found in usvg's tree (see [`layers`]).
    let prefix = layers::synthetic_prefix(&text);
    let named = layers::name_layer_groups(&text, &xml, &prefix);
    let xml = match &named {
        Some(t) => decode::parse_xml(t).map_err(parse_err)?,
        None => xml,
    };
    let survey = survey(&xml, options.images.is_none(), &prefix);
    let mut warnings = survey.warnings.clone();

    let resolver = resources::Resolver::new(resources);
    let mut opt = usvg::Options { image_href_resolver: resolver.href_resolver(0), ..usvg::Options::default() };
    if survey.has_text {
        let db = opt.fontdb_mut();
        db.load_system_fonts();
        let family = FALLBACK_FAMILIES
            .iter()
            .find(|f| db.faces().any(|face| face.families.iter().any(|(n, _)| n == *f)))
            .map(|f| (*f).to_string())
            .or_else(|| db.faces().next().and_then(|face| face.families.first().map(|(n, _)| n.clone())));
        match family {
            Some(f) => {
                db.set_serif_family(f.clone());
                db.set_sans_serif_family(f.clone());
                db.set_monospace_family(f.clone());
                db.set_cursive_family(f.clone());
                db.set_fantasy_family(f.clone());
                opt.font_family = f;
            }
            None => warnings.push(format!(
                "{name}: no font found on this system: {} text element(s) cannot be drawn (install fonts-dejavu-core)",
                survey.text_elements
            )),
        }
    }
    options.cancel.check().map_err(cancelled)?;
    let tree = usvg::Tree::from_xmltree(&xml, &opt).map_err(|e| parse_err(e.to_string()))?;
    options.cancel.check().map_err(cancelled)?;
    warnings.extend(resolver.warnings(name));

    let empty = HashMap::new();
    let layer_groups = match options.layer_by {
        LayerBy::Auto => &survey.inkscape_layers,
        LayerBy::Group => &survey.top_groups,
        LayerBy::Color | LayerBy::None => &empty,
    };
    let mut walker = walk::Walker::new(options, layer_groups, name);
    let (root, t) = content_root(tree.root(), root_viewbox_transform(xml.root_element()));
    walker.walk_root(root, t);
    options.cancel.check().map_err(cancelled)?;
    warnings.append(&mut walker.warnings);
    let skipped = &walker.skipped;
    let mut summary = Skipped::default();
    summary.add(SkipReason::Invisible, skipped.hidden);
    summary.add(SkipReason::Transparent, skipped.transparent);
    summary.add(SkipReason::SinglePoint, skipped.dropped_subpaths);
    summary.add(SkipReason::HatchRefused, skipped.hatch_refused);
    summary.add(SkipReason::PatternTooFine, skipped.fine_patterns);
    summary.add(SkipReason::PatternTooLarge, skipped.huge_patterns);
    summary.add(SkipReason::ImageNotTraced, skipped.images_not_traced + survey.images_not_traced);
    summary.add(SkipReason::ImageUndecodable, skipped.images_undecodable);
    summary.add(SkipReason::UnsupportedElement, survey.unsupported);
    summary.add(SkipReason::DegenerateShape, survey.degenerate);
    if skipped.hidden > 0 {
        warnings
            .push(format!("{name}: {} invisible shape(s) skipped (no fill and no stroke, or hidden)", skipped.hidden));
    }
    if skipped.transparent > 0 {
        warnings.push(format!("{name}: {} fully transparent shape(s) skipped (opacity 0)", skipped.transparent));
    }
    if skipped.dropped_subpaths > 0 {
        warnings
            .push(format!("{name}: {} single-point subpath(s) skipped (nothing to draw)", skipped.dropped_subpaths));
    }
    if skipped.partial_masks > 0 {
        warnings.push(format!(
            "{name}: {} mask(s) are partly transparent (grey, gradient or translucent): cut where they are at least half opaque",
            skipped.partial_masks
        ));
    }
    if skipped.far_outlines > 0 {
        warnings.push(format!(
            "{name}: {} wide stroke(s) reach beyond ±{} mm (1 km): drawn as centre lines only (they neither hide \
             what lies under them nor are filled)",
            skipped.far_outlines,
            crate::geometry::limits::MAX_COORD_MM
        ));
    }
    if skipped.hatch_refused > 0 {
        warnings.push(format!(
            "{name}: {} area(s) not hatched: more than {} lines at this spacing",
            skipped.hatch_refused,
            crate::geometry::hatch::MAX_LINES
        ));
    }
    let arc_error_mm = arc_approximation_bound(survey.max_arc_radius) * survey.max_user_unit_px * MM_PER_PX;
    if arc_error_mm > options.tolerance_mm {
        warnings.push(format!(
            "{name}: arcs/circles are approximated by the SVG library within {arc_error_mm:.4} mm, more than the \
             tolerance {:.4} mm",
            options.tolerance_mm
        ));
    }
    let layer_names = std::mem::take(&mut walker.layer_names);
    let scales = walker.scales;
    let mut items = std::mem::take(&mut walker.items);
    if let Some(w) = bounds::cut_far(&mut items) {
        warnings.push(format!("{name}: {w}"));
    }
    // Hidden parts go first, outlines included: the edge rule then only looks at what can be seen.
    if options.occlusion {
        occlude::occlude(&mut items, &options.cancel);
        options.cancel.check().map_err(cancelled)?;
    }
    let unseen = edges::draw_edges(&mut items, options.paper_color);
    summary.add(SkipReason::SameColourFill, unseen);
    if unseen > 0 {
        warnings.push(format!(
            "{name}: {unseen} fill-only shape(s) not outlined: their colour is that of what lies beneath (e.g. white \
             on the paper); they only hide what lies under them"
        ));
    }
    // The page in f64 from the document's absolute width and height when it has them, else usvg's (f32) size.
    let size = tree.size();
    let (w, h) = absolute_size_px(xml.root_element()).unwrap_or((f64::from(size.width()), f64::from(size.height())));
    let page_mm = (w * MM_PER_PX, h * MM_PER_PX);
    if let Some((w, elements)) = off_page(&mut items, page_mm, options.crop) {
        warnings.push(format!("{name}: {w}"));
        if options.crop {
            summary.add(SkipReason::CroppedAtPage, elements);
        }
    }
    let mut layers: Vec<Layer> = layer_names.into_iter().map(Layer::new).collect();
    let mut has_pen = vec![false; layers.len()];
    for item in items {
        let layer = &mut layers[item.layer];
        if !has_pen[item.layer] {
            layer.pen = item.pen;
            has_pen[item.layer] = true;
        }
        layer.paths.extend(item.lines.into_iter().map(|l| Polyline::with_pen(l, item.pen)));
    }
    layers.retain(|l| !l.paths.is_empty());
    warnings.extend(layers::read_codes(&mut layers, name));
    if !options.layers.is_empty() {
        let available: Vec<String> = layers.iter().map(|l| l.name.clone()).collect();
        for want in &options.layers {
            if !available.iter().any(|a| a == want || layers::by_number(a, want)) {
                return Err(SvgError::NoSuchLayer {
                    path: name.to_string(),
                    name: want.clone(),
                    available: available.join(", "),
                });
            }
        }
        layers.retain(|l| options.layers.iter().any(|w| *w == l.name || layers::by_number(&l.name, w)));
    }
    let drawing = Drawing { layers, page_mm: Some(page_mm) };
    if drawing.is_empty() {
        let detail = if warnings.is_empty() { String::new() } else { format!(" ({})", warnings.join("; ")) };
        return Err(SvgError::Empty { path: name.to_string(), detail });
    }
    Ok(Imported { drawing, warnings, skipped: summary, scales })
}

/// Refuse a root `width` or `height` beyond ±[`crate::geometry::limits::MAX_COORD_MM`] (1 km) before usvg works
/// on it: no plotter draws such a page, and everything on it would be absurdly large (and usvg panics on sizes
/// near the f32 limit, e.g. an SVG image 3e38 px wide).
pub(super) fn check_page_size(root: roxmltree::Node<'_, '_>) -> Result<(), String> {
    use crate::geometry::limits::MAX_COORD_MM;
    for attr in ["width", "height"] {
        let Some(v) = root.attribute(attr) else { continue };
        if v.trim_end().ends_with('%') {
            continue;
        }
        let Some(px) = length_px(v) else { continue };
        let mm = px * MM_PER_PX;
        if mm.is_nan() || mm.abs() > MAX_COORD_MM {
            return Err(format!(
                "<svg> {attr}=\"{v}\" at line {} is {mm:.3e} mm, beyond the {MAX_COORD_MM} mm (1 km) limit; check \
                 the units",
                root.document().text_pos_at(root.range().start).row
            ));
        }
    }
    Ok(())
}

/// The content below usvg's anonymous wrapper groups (viewBox transform and the like), with the transform to px.
/// `viewbox` (exact, f64) replaces usvg's f32 root transform when they agree.
fn content_root(mut root: &usvg::Group, viewbox: Option<Affine>) -> (&usvg::Group, Affine) {
    let affine = |t: &usvg::Transform| Affine::new([t.sx, t.ky, t.kx, t.sy, t.tx, t.ty].map(f64::from));
    let mut t = affine(&root.transform());
    while let [usvg::Node::Group(only)] = root.children()
        && only.id().is_empty()
        && only.clip_path().is_none()
        && only.mask().is_none()
        && only.opacity().get() >= 1.0
    {
        root = only;
        t = match viewbox {
            Some(exact) if t == Affine::IDENTITY && rounds_to(&root.transform(), exact) => exact,
            _ => t * affine(&root.transform()),
        };
    }
    (root, t)
}

/// Report (and with `crop`, cut) the lines outside the page: the warning and the number of elements concerned.
fn off_page(items: &mut [walk::Item], (w, h): (f64, f64), crop: bool) -> Option<(String, usize)> {
    let page = Rect::new(0.0, 0.0, w, h);
    let region = Region::rect(page);
    let (mut length, mut elements) = (0.0, Vec::new());
    for item in items.iter_mut() {
        let outside = item.lines.iter().flatten().any(|p| p.x < 0.0 || p.y < 0.0 || p.x > w || p.y > h);
        if !outside {
            continue;
        }
        let len = |lines: &[Vec<Point>]| -> f64 {
            lines.iter().flat_map(|l| l.windows(2)).map(|s| s[0].distance(s[1])).sum()
        };
        let out_len = len(&cut(item.lines.clone(), &[&region], Keep::Outside));
        if out_len <= 1e-3 {
            continue;
        }
        length += out_len;
        elements.push(item.element.clone());
        if crop {
            item.lines = cut(std::mem::take(&mut item.lines), &[&region], Keep::Inside);
        }
    }
    if elements.is_empty() {
        return None;
    }
    let n = elements.len();
    elements.dedup();
    let mut shown: Vec<String> = elements.iter().take(5).cloned().collect();
    if elements.len() > 5 {
        shown.push("…".into());
    }
    let what = if crop { "were cut at the page edge (--crop)" } else { "lie outside the page; --crop cuts them there" };
    let warning = format!(
        "{length:.1} mm of pen-down lines in {n} element(s) ({}) {what} ({w:.1} × {h:.1} mm)",
        shown.join(", ")
    );
    Some((warning, n))
}

/// What a pass over the XML learns before usvg runs: layer labels, text, arcs, and elements usvg would drop.
#[derive(Clone)]
struct Survey {
    /// Inkscape layers (`inkscape:groupmode="layer"`): id → label (else id).
    inkscape_layers: HashMap<String, String>,
    /// Top-level `<g>` elements: id → Inkscape label (else id).
    top_groups: HashMap<String, String>,
    has_text: bool,
    text_elements: usize,
    /// Largest radius (user units) of any arc, circle, ellipse or rounded corner; 0 when there are none.
    max_arc_radius: f64,
    /// Largest scale from a user unit to px over the document (an upper bound from viewBox and width).
    max_user_unit_px: f64,
    /// Raster `<image>`s left untraced because tracing is off.
    images_not_traced: usize,
    /// Elements no plotter draws (`foreignObject`, `video`…).
    unsupported: usize,
    /// Shapes of zero or negative size.
    degenerate: usize,
    warnings: Vec<String>,
}

/// `prefix` marks the synthetic ids of [`layers::name_layer_groups`]: a group named so is called by its label, else
/// by its line.
fn survey(xml: &roxmltree::Document<'_>, skip_images: bool, prefix: &str) -> Survey {
    use layers::INKSCAPE;
    let mut s = Survey {
        inkscape_layers: HashMap::new(),
        top_groups: HashMap::new(),
        has_text: false,
        text_elements: 0,
        max_arc_radius: 0.0,
        max_user_unit_px: 1.0,
        images_not_traced: 0,
        unsupported: 0,
        degenerate: 0,
        warnings: Vec::new(),
    };
    let root = xml.root_element();
    if let (Some(vb), Some(w)) = (root.attribute("viewBox"), root.attribute("width")) {
        let vb_w = vb.split(|c: char| c == ',' || c.is_whitespace()).filter(|t| !t.is_empty()).nth(2);
        if let (Some(vb_w), Some(len)) = (vb_w.and_then(|t| t.parse::<f64>().ok()), length_px(w))
            && vb_w > 0.0
        {
            s.max_user_unit_px = (len / vb_w).max(1.0);
        }
    }
    // Where each line starts, built the first time a line number is asked for (then one binary search each, where
    // `roxmltree`'s own lookup scans the text from its start every time: quadratic over a large file).
    let line_starts: std::cell::OnceCell<Vec<usize>> = std::cell::OnceCell::new();
    let line_at = |pos: usize| {
        let starts = line_starts.get_or_init(|| {
            std::iter::once(0).chain(xml.input_text().match_indices('\n').map(|(i, _)| i + 1)).collect()
        });
        starts.partition_point(|&s| s <= pos)
    };
    for node in xml.descendants().filter(roxmltree::Node::is_element) {
        let tag = node.tag_name().name();
        // Where the element is, for warnings only.
        let at = || {
            let id = node.attribute("id").map(|i| format!(" id=\"{i}\"")).unwrap_or_default();
            format!("<{tag}{id}> at line {}", line_at(node.range().start))
        };
        if tag == "g"
            && let Some(id) = node.attribute("id")
        {
            let label = match node.attribute((INKSCAPE, "label")) {
                Some(l) => l.to_string(),
                None if id.starts_with(prefix) => {
                    format!("group at line {}", line_at(node.range().start))
                }
                None => id.to_string(),
            };
            if node.attribute((INKSCAPE, "groupmode")) == Some("layer") {
                s.inkscape_layers.insert(id.to_string(), label.clone());
            }
            if node.parent_element() == Some(root) {
                s.top_groups.insert(id.to_string(), label);
            }
        }
        let number =
            |attr: &str| node.attribute(attr).and_then(|v| v.parse::<svgtypes::Length>().ok()).map(|l| l.number);
        let mut radius = |r: Option<f64>| s.max_arc_radius = s.max_arc_radius.max(r.unwrap_or(0.0).abs());
        match tag {
            "text" => {
                s.has_text = true;
                s.text_elements += 1;
            }
            "circle" => radius(number("r")),
            "ellipse" | "rect" => {
                radius(number("rx"));
                radius(number("ry"));
            }
            "path" => match node.attribute("d") {
                None => s.warnings.push(format!("{}: no 'd' attribute, not drawn", at())),
                Some(d) => {
                    for (i, seg) in svgtypes::PathParser::from(d).enumerate() {
                        match seg {
                            Ok(svgtypes::PathSegment::EllipticalArc { rx, ry, .. }) => radius(Some(rx.max(ry))),
                            Ok(_) => {}
                            Err(e) => {
                                s.warnings.push(format!(
                                    "{}: invalid path data after {i} segment(s) ({e}); drawn up to the error",
                                    at()
                                ));
                                break;
                            }
                        }
                    }
                }
            },
            "image" if skip_images => {
                s.images_not_traced += 1;
                s.warnings.push(format!("{}: embedded raster image not traced (use --images MODE)", at()));
            }
            "foreignObject" | "video" | "audio" | "iframe" | "canvas" => {
                s.unsupported += 1;
                s.warnings.push(format!("{}: element not supported, skipped", at()));
            }
            _ => {}
        }
        let non_positive = |attr: &str| {
            node.attribute(attr).and_then(|v| v.parse::<svgtypes::Length>().ok()).is_some_and(|l| l.number <= 0.0)
        };
        let degenerate = match tag {
            "rect" => non_positive("width") || non_positive("height"),
            "circle" => non_positive("r"),
            "ellipse" => non_positive("rx") || non_positive("ry"),
            _ => false,
        };
        if degenerate {
            s.degenerate += 1;
            s.warnings.push(format!("{}: zero or negative size, not drawn", at()));
        }
    }
    s
}

/// The root viewBox transform (user units → px) computed in f64 from `width`, `height`, `viewBox` and
/// `preserveAspectRatio`, when all are given in absolute units. usvg computes the same transform in f32; using this
/// one keeps millimetre-based documents exact (116 mm stays 116 mm, not 115.999996).
fn root_viewbox_transform(root: roxmltree::Node<'_, '_>) -> Option<Affine> {
    let vb: svgtypes::ViewBox = root.attribute("viewBox")?.parse().ok()?;
    let (w, h) = absolute_size_px(root)?;
    if !(vb.w > 0.0 && vb.h > 0.0) {
        return None;
    }
    let par: svgtypes::AspectRatio =
        root.attribute("preserveAspectRatio").and_then(|v| v.parse().ok()).unwrap_or_default();
    let (sx, sy) = (w / vb.w, h / vb.h);
    use svgtypes::Align;
    let (fx, fy) = match par.align {
        Align::None => return Some(Affine::new([sx, 0.0, 0.0, sy, -vb.x * sx, -vb.y * sy])),
        Align::XMinYMin => (0.0, 0.0),
        Align::XMidYMin => (0.5, 0.0),
        Align::XMaxYMin => (1.0, 0.0),
        Align::XMinYMid => (0.0, 0.5),
        Align::XMidYMid => (0.5, 0.5),
        Align::XMaxYMid => (1.0, 0.5),
        Align::XMinYMax => (0.0, 1.0),
        Align::XMidYMax => (0.5, 1.0),
        Align::XMaxYMax => (1.0, 1.0),
    };
    let s = if par.slice { sx.max(sy) } else { sx.min(sy) };
    let (dx, dy) = ((w - vb.w * s) * fx, (h - vb.h * s) * fy);
    Some(Affine::new([s, 0.0, 0.0, s, dx - vb.x * s, dy - vb.y * s]))
}

/// The root `width` and `height` in px when both are given as positive absolute lengths (not percentages).
fn absolute_size_px(root: roxmltree::Node<'_, '_>) -> Option<(f64, f64)> {
    let get = |a: &str| {
        let v = root.attribute(a)?;
        if v.trim_end().ends_with('%') {
            return None;
        }
        length_px(v).filter(|l| *l > 0.0)
    };
    Some((get("width")?, get("height")?))
}

/// usvg's f32 transform as an f64 affine map.
fn affine(t: &usvg::Transform) -> Affine {
    Affine::new([t.sx, t.ky, t.kx, t.sy, t.tx, t.ty].map(f64::from))
}

/// True when the f32 transform `t` is `exact` rounded to f32 (so `exact` may replace it).
fn rounds_to(t: &usvg::Transform, exact: Affine) -> bool {
    affine(t).as_coeffs().iter().zip(exact.as_coeffs()).all(|(a, e)| (a - e).abs() <= 1e-6 * e.abs().max(1.0))
}

/// Upper bound (user units) of usvg's arc-to-cubic error for arcs up to `radius`: it cuts arcs into cubics of at
/// most 90° (kurbo's `Arc::to_cubic_beziers`, at least four per turn), whose radial error is 2.7e-4 of the radius
/// for a circle and of the larger radius for an ellipse; it never lets the error exceed 0.1 user unit.
fn arc_approximation_bound(radius: f64) -> f64 {
    (3e-4 * radius).min(0.1)
}

/// Length in px of an SVG length string with an absolute unit (relative units count as their bare number).
fn length_px(text: &str) -> Option<f64> {
    let l: svgtypes::Length = text.parse().ok()?;
    let per_unit = match l.unit {
        svgtypes::LengthUnit::Mm => 1.0 / MM_PER_PX,
        svgtypes::LengthUnit::Cm => 10.0 / MM_PER_PX,
        svgtypes::LengthUnit::In => 96.0,
        svgtypes::LengthUnit::Pt => 96.0 / 72.0,
        svgtypes::LengthUnit::Pc => 16.0,
        _ => 1.0,
    };
    Some(l.number * per_unit)
}

#[cfg(test)]
mod tests;
