//! SVG import through usvg: every shape, nested transforms, viewBox and preserveAspectRatio, physical units,
//! `<use>`, hidden elements, and text as glyph outlines — flattened to millimetre polylines with a proven chord
//! bound (see [`crate::geometry::flatten`]).
//!
//! **What is plotted.** Every visible path is plotted along its outline: a stroked path as its centre line, a
//! fill-only path as the outline of its filled area (the pen traces the boundary; filling with hatching is a
//! separate step). Paths with neither fill nor stroke are invisible in any viewer and are skipped with a warning,
//! as are `display:none`/`visibility:hidden` elements. Embedded raster `<image>`s are not traced (warned).
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
//! **Layers.** [`LayerBy::Group`] makes a layer of each top-level group (named by its Inkscape label, else its id);
//! shapes outside any top-level group form a layer named `root`. [`LayerBy::Color`] makes one layer per stroke
//! colour (fill colour for fill-only paths). [`LayerBy::None`] puts everything in one layer.

use std::collections::HashMap;
use std::path::Path;

use kurbo::{Affine, PathEl, Point};
use usvg::roxmltree;

use crate::geometry::drawing::{Drawing, Layer, Pen, Polyline, Rgb};
use crate::geometry::flatten::flatten_path;

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

/// How paths are grouped into layers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LayerBy {
    /// One layer per top-level group (Inkscape layers by label).
    #[default]
    Group,
    /// One layer per stroke colour.
    Color,
    /// Everything in one layer.
    None,
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
}

impl Default for SvgOptions {
    fn default() -> Self {
        SvgOptions { tolerance_mm: DEFAULT_TOLERANCE_MM, layer_by: LayerBy::Group, layers: Vec::new() }
    }
}

/// A successful import: the drawing and everything the user should be told about.
#[derive(Debug, Clone, PartialEq)]
pub struct Imported {
    /// The drawing, in mm, page coordinates.
    pub drawing: Drawing,
    /// Elements that were skipped or approximated, each naming the element and its line.
    pub warnings: Vec<String>,
}

/// Load and import an SVG file.
pub fn load_svg(path: &Path, options: &SvgOptions) -> Result<Imported, SvgError> {
    let shown = path.display().to_string();
    let data = std::fs::read(path).map_err(|source| SvgError::Read { path: shown.clone(), source })?;
    let dir = path.parent().map(Path::to_path_buf);
    import_svg(&data, &shown, dir, options)
}

/// Import SVG bytes; `name` is used in messages, `resources_dir` resolves relative references.
pub fn import_svg(
    data: &[u8],
    name: &str,
    resources_dir: Option<std::path::PathBuf>,
    options: &SvgOptions,
) -> Result<Imported, SvgError> {
    let parse_err = |message: String| SvgError::Parse { path: name.to_string(), message };
    let text = std::str::from_utf8(data).map_err(|e| parse_err(format!("not UTF-8 text ({e})")))?;
    let xml = roxmltree::Document::parse(text).map_err(|e| parse_err(e.to_string()))?;
    if xml.root_element().tag_name().name() != "svg" {
        return Err(parse_err(format!("root element is <{}>, expected <svg>", xml.root_element().tag_name().name())));
    }
    let survey = survey(&xml);
    let mut warnings = survey.warnings;

    let mut opt = usvg::Options { resources_dir, ..usvg::Options::default() };
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
    let tree = usvg::Tree::from_xmltree(&xml, &opt).map_err(|e| parse_err(e.to_string()))?;

    let mut walker = Walker {
        tolerance: options.tolerance_mm,
        layer_by: options.layer_by,
        labels: &survey.labels,
        layers: Vec::new(),
        index: HashMap::new(),
        hidden: 0,
        dropped_subpaths: 0,
    };
    walker.walk_root(tree.root(), root_viewbox_transform(xml.root_element()));
    if walker.hidden > 0 {
        warnings
            .push(format!("{name}: {} invisible shape(s) skipped (no fill and no stroke, or hidden)", walker.hidden));
    }
    if walker.dropped_subpaths > 0 {
        warnings.push(format!("{name}: {} single-point subpath(s) skipped (nothing to draw)", walker.dropped_subpaths));
    }
    let arc_error_mm = arc_approximation_bound(survey.max_arc_radius) * survey.max_user_unit_px * MM_PER_PX;
    if arc_error_mm > options.tolerance_mm {
        warnings.push(format!(
            "{name}: arcs/circles are approximated by the SVG library within {arc_error_mm:.4} mm, more than the \
             tolerance {:.4} mm",
            options.tolerance_mm
        ));
    }
    let mut layers = walker.layers;
    layers.retain(|l| !l.paths.is_empty());
    if !options.layers.is_empty() {
        let available: Vec<String> = layers.iter().map(|l| l.name.clone()).collect();
        for want in &options.layers {
            if !available.iter().any(|a| a == want) {
                return Err(SvgError::NoSuchLayer {
                    path: name.to_string(),
                    name: want.clone(),
                    available: available.join(", "),
                });
            }
        }
        layers.retain(|l| options.layers.contains(&l.name));
    }
    // The page in f64 from the document's absolute width and height when it has them, else usvg's (f32) size.
    let size = tree.size();
    let (w, h) = absolute_size_px(xml.root_element()).unwrap_or((f64::from(size.width()), f64::from(size.height())));
    let drawing = Drawing { layers, page_mm: Some((w * MM_PER_PX, h * MM_PER_PX)) };
    if drawing.is_empty() {
        let detail = if warnings.is_empty() { String::new() } else { format!(" ({})", warnings.join("; ")) };
        return Err(SvgError::Empty { path: name.to_string(), detail });
    }
    Ok(Imported { drawing, warnings })
}

/// What a pass over the XML learns before usvg runs: layer labels, text, arcs, and elements usvg would drop.
struct Survey {
    labels: HashMap<String, String>,
    has_text: bool,
    text_elements: usize,
    /// Largest radius (user units) of any arc, circle, ellipse or rounded corner; 0 when there are none.
    max_arc_radius: f64,
    /// Largest scale from a user unit to px over the document (an upper bound from viewBox and width).
    max_user_unit_px: f64,
    warnings: Vec<String>,
}

fn survey(xml: &roxmltree::Document<'_>) -> Survey {
    const INKSCAPE: &str = "http://www.inkscape.org/namespaces/inkscape";
    let mut s = Survey {
        labels: HashMap::new(),
        has_text: false,
        text_elements: 0,
        max_arc_radius: 0.0,
        max_user_unit_px: 1.0,
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
    for node in xml.descendants().filter(roxmltree::Node::is_element) {
        let tag = node.tag_name().name();
        // Where the element is, for warnings only: finding the line scans the text, so it is done on demand.
        let at = || {
            let id = node.attribute("id").map(|i| format!(" id=\"{i}\"")).unwrap_or_default();
            format!("<{tag}{id}> at line {}", xml.text_pos_at(node.range().start).row)
        };
        if tag == "g"
            && let Some(label) = node.attribute((INKSCAPE, "label"))
            && let Some(id) = node.attribute("id")
        {
            s.labels.insert(id.to_string(), label.to_string());
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
            "image" => s.warnings.push(format!("{}: embedded raster image not traced (use `plotter trace`)", at())),
            "foreignObject" | "video" | "audio" | "iframe" | "canvas" => {
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

struct Walker<'a> {
    tolerance: f64,
    layer_by: LayerBy,
    labels: &'a HashMap<String, String>,
    layers: Vec<Layer>,
    index: HashMap<String, usize>,
    hidden: usize,
    dropped_subpaths: usize,
}

impl Walker<'_> {
    /// Walk the tree composing group transforms in f64; `viewbox` (exact) replaces usvg's f32 root transform.
    fn walk_root(&mut self, mut root: &usvg::Group, viewbox: Option<Affine>) {
        let mut t = affine(&root.transform());
        // usvg wraps the content in anonymous groups (for the viewBox transform, for example): look through them.
        while let [usvg::Node::Group(only)] = root.children()
            && only.id().is_empty()
        {
            root = only;
            t = match viewbox {
                Some(exact) if t == Affine::IDENTITY && rounds_to(&root.transform(), exact) => exact,
                _ => t * affine(&root.transform()),
            };
        }
        for node in root.children() {
            let layer = match (self.layer_by, node) {
                (LayerBy::Group, usvg::Node::Group(g)) => self.group_layer_name(g),
                (LayerBy::Group, _) => "root".to_string(),
                _ => String::new(),
            };
            self.walk(node, &layer, t);
        }
    }

    fn group_layer_name(&self, g: &usvg::Group) -> String {
        let id = g.id();
        if let Some(label) = self.labels.get(id) {
            label.clone()
        } else if !id.is_empty() {
            id.to_string()
        } else {
            format!("layer {}", self.layers.len() + 1)
        }
    }

    /// `t` maps the node's user units to px (its parent's absolute transform).
    fn walk(&mut self, node: &usvg::Node, layer: &str, t: Affine) {
        match node {
            usvg::Node::Group(g) => {
                let t = t * affine(&g.transform());
                for child in g.children() {
                    self.walk(child, layer, t);
                }
            }
            usvg::Node::Path(p) => self.add_path(p, layer, t),
            usvg::Node::Text(text) => {
                // Glyph outlines come with usvg's own absolute transforms.
                for child in text.flattened().children() {
                    self.walk_text(child, layer);
                }
            }
            // Embedded images were reported by the survey.
            usvg::Node::Image(_) => {}
        }
    }

    fn walk_text(&mut self, node: &usvg::Node, layer: &str) {
        match node {
            usvg::Node::Group(g) => g.children().iter().for_each(|c| self.walk_text(c, layer)),
            usvg::Node::Path(p) => self.add_path(p, layer, affine(&p.abs_transform())),
            usvg::Node::Text(_) | usvg::Node::Image(_) => {}
        }
    }

    fn layer_mut(&mut self, key: String, pen: Pen) -> &mut Layer {
        let next = self.layers.len();
        let i = *self.index.entry(key.clone()).or_insert(next);
        if i == next {
            self.layers.push(Layer { name: key, pen, paths: Vec::new() });
        }
        &mut self.layers[i]
    }

    fn add_path(&mut self, p: &usvg::Path, layer: &str, t: Affine) {
        if !p.is_visible() {
            self.hidden += 1;
            return;
        }
        let paint = p.stroke().map(usvg::Stroke::paint).or_else(|| p.fill().map(usvg::Fill::paint));
        let color = match paint {
            Some(usvg::Paint::Color(c)) => Rgb(c.red, c.green, c.blue),
            _ => Rgb::BLACK,
        };
        let width_mm = p.stroke().map(|s| f64::from(s.width().get()) * MM_PER_PX * t.determinant().abs().sqrt());
        let key = match self.layer_by {
            LayerBy::Group => layer.to_string(),
            LayerBy::Color => color.to_hex(),
            LayerBy::None => "drawing".to_string(),
        };
        let mut pen = Pen { color, ..Pen::default() };
        if let Some(w) = width_mm.filter(|w| *w > 0.0) {
            pen.width_mm = w;
        }
        let to_mm = Affine::scale(MM_PER_PX) * t;
        let map = move |q: usvg::tiny_skia_path::Point| -> Point { to_mm * Point::new(f64::from(q.x), f64::from(q.y)) };
        let elements = p.data().segments().map(|seg| match seg {
            usvg::tiny_skia_path::PathSegment::MoveTo(a) => PathEl::MoveTo(map(a)),
            usvg::tiny_skia_path::PathSegment::LineTo(a) => PathEl::LineTo(map(a)),
            usvg::tiny_skia_path::PathSegment::QuadTo(a, b) => PathEl::QuadTo(map(a), map(b)),
            usvg::tiny_skia_path::PathSegment::CubicTo(a, b, c) => PathEl::CurveTo(map(a), map(b), map(c)),
            usvg::tiny_skia_path::PathSegment::Close => PathEl::ClosePath,
        });
        let (polys, dropped) = flatten_path(elements, self.tolerance);
        self.dropped_subpaths += dropped;
        let target = self.layer_mut(key, pen);
        target.paths.extend(polys.into_iter().map(Polyline::new));
    }
}

#[cfg(test)]
mod tests;
