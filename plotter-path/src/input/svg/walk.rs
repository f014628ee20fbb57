//! The walk over usvg's tree in paint order: every visible shape becomes an [`Item`] — the pen lines it puts on
//! paper (stroke centre lines, dashed where the stroke is dashed; outlines of fills; hatching), cut to the clip
//! paths, masks and nested viewports above it, and the opaque area it covers (for hidden-line removal).
//!
//! **Clips.** usvg resolves `clipPathUnits`, `clip-rule` (as the clip children's fill rule) and turns nested
//! `<svg>` viewports and sliced images into rectangular clip paths on groups. A clip path's area is the union of
//! its children (each a [`Region`] under its own rule, intersected with the child's own clip path), intersected
//! with the clip path's own `clip-path`, all mapped to page millimetres with the group's transform, as resvg draws
//! them. **Masks** become the area where the mask is at least half opaque: mask children are painted in order,
//! each adding its area when its luminance (or alpha, for `mask-type="alpha"`) times its opacity is ≥ 0.5 and
//! removing it otherwise; the result is cut to the mask's rectangle and its own nested mask. A mask with values
//! strictly between 0 and 1 (grey, gradients, partial opacity) is reported, since a pen has no half tones.
//!
//! **Opacity.** The opacity of the enclosing groups multiplies each paint's own. A shape whose fill and stroke are
//! both fully transparent is skipped (counted for a warning); a fill hides what lies under it when it is more
//! than half opaque (its opacity times its least gradient stop opacity): a fainter one lets the eye see the lines
//! through it. A fill-only shape's outline is drawn where its colour differs from what lies beneath
//! ([`super::edges`]): a white shape draws nothing on the paper and its outline on black. Paper-coloured fills
//! are never hatched. An opaque stroke wider than four pen widths on the plotted page (its width in the document
//! times [`SvgOptions::hatch_scale`]) hides what lies under its outline too (a thick border over text); thinner
//! strokes do not: every crossing would cut a gap into the line beneath that is hardly wider than the pen's own blot
//! there, costing two lifts for nothing visible (a mm-unit drawing's default 1 mm stroke is such a line). Each such
//! choice is recorded in [`Walker::scales`], so that a layout by another factor can have the drawing decoded again.

use std::collections::HashMap;

use kurbo::{Affine, PathEl, Point};
use usvg::tiny_skia_path;

use super::hershey::{self, HersheyFont};
use super::page_scale::ScaleRange;
use super::{LayerBy, MM_PER_PX, SvgOptions, TextMode};
use crate::geometry::drawing::{Pen, Rgb};
use crate::geometry::flatten::flatten_path;
use crate::geometry::hatch::{FillHatch, hatch};
use crate::geometry::limits::MAX_COORD_MM;
use crate::geometry::region::{FillRule, Keep, Region, cut};
use crate::geometry::tone_hatch::{MIN_BAND_PENS, ToneField, ToneHatch, tone_hatch};
use crate::input::raster;

mod blend;
mod fill_paint;
mod pattern;

/// A fill hides what lies under it when its opacity is more than this.
const HIDING_ALPHA: f32 = 0.5;

/// Opaque strokes wider than this many pen widths hide what lies under them.
const WIDE_STROKE_PENS: f64 = 4.0;

/// Whether the outline of a stroke `width_mm` wide along `data` (under `t`, to px) stays within
/// ±[`MAX_COORD_MM`]. tiny-skia's stroker subdivides curves by the resolution asked of it, so outlining a shape
/// scaled far beyond any page costs memory without bound (a circle scaled to 10¹⁰ mm took 900 MB); beyond 1 km
/// the lines are cut away anyway ([`super::bounds`]).
fn within_reach(data: &tiny_skia_path::Path, t: Affine, width_mm: f64) -> bool {
    let b = data.bounds();
    let r = kurbo::Rect::new(f64::from(b.left()), f64::from(b.top()), f64::from(b.right()), f64::from(b.bottom()));
    let mm = t.transform_rect_bbox(r).scale_from_origin(MM_PER_PX).inflate(width_mm, width_mm);
    [mm.x0, mm.y0, mm.x1, mm.y1].iter().all(|v| v.abs() <= MAX_COORD_MM) && width_mm <= MAX_COORD_MM
}

/// One painted shape, in paint order.
#[derive(Debug, Clone)]
pub(super) struct Item {
    /// Index into [`Walker::layer_names`].
    pub(super) layer: usize,
    /// Colour and stroke width, for previews.
    pub(super) pen: Pen,
    /// Pen-down lines in page millimetres, already cut to the clips above the shape.
    pub(super) lines: Vec<Vec<Point>>,
    /// The outline of a fill-only shape, cut to its clips: its hidden parts are removed with the lines'
    /// ([`super::occlude`]), then it is drawn only where the fill's colour differs from what lies beneath
    /// ([`super::edges`]), after which it joins `lines`.
    pub(super) outline: Option<Outline>,
    /// The areas the shape paints over what lies beneath, in paint order (fill, then a wide stroke), cut to its
    /// clips: each hides the lines under it and has a colour for the edge rule.
    pub(super) paints: Vec<Paint>,
    /// The element, for messages: `<path id="x">` or `<path>`.
    pub(super) element: String,
}

/// The outline of a fill-only shape, waiting for the edge rule.
#[derive(Debug, Clone)]
pub(super) struct Outline {
    /// The outline's lines, mm.
    pub(super) lines: Vec<Vec<Point>>,
    /// The fill's colour; `None` when it is not one colour (a gradient of several), which matches nothing.
    pub(super) color: Option<Rgb>,
}

/// An area painted over what lies beneath, in mm.
#[derive(Debug, Clone)]
pub(super) struct Paint {
    /// The area.
    pub(super) area: Region,
    /// Its colour as seen; `None` when it is not one colour. A translucent fill's colour is its blend with the
    /// paper at its opacity (a 25 % black shadow is light grey): what lies beneath it besides the paper is not
    /// known here, so this is exact on the paper and an approximation over other paint.
    pub(super) color: Option<Rgb>,
    /// More than half opaque: it hides the lines under it ([`super::occlude`]). A fainter fill hides nothing but
    /// still tints what lies beneath, which the edge rule ([`super::edges`]) sees as a colour of its own.
    pub(super) hides: bool,
}

/// Counts of what was skipped, for warnings.
#[derive(Debug, Default)]
pub(super) struct Skipped {
    pub(super) hidden: usize,
    pub(super) transparent: usize,
    pub(super) dropped_subpaths: usize,
    pub(super) partial_masks: usize,
    pub(super) clip_text: usize,
    pub(super) hatch_refused: usize,
    /// Wide strokes whose outline would reach beyond ±1 km: not outlined (neither hiding nor filled).
    pub(super) far_outlines: usize,
    /// Pattern fills not drawn because their tiles are narrower than the pen.
    pub(super) fine_patterns: usize,
    /// Pattern fills not drawn because they would paint too many shapes.
    pub(super) huge_patterns: usize,
    /// Raster images of a kind the tracer does not take (e.g. nested SVG, GIF).
    pub(super) images_not_traced: usize,
    /// Raster images that cannot be decoded.
    pub(super) images_undecodable: usize,
}

/// Where the walk is: the transform to CSS px, the clip areas to cut by, the opacity, the layer.
#[derive(Clone)]
struct Ctx {
    t: Affine,
    clips: Vec<std::rc::Rc<Region>>,
    opacity: f32,
    layer: Option<usize>,
}

pub(super) struct Walker<'a> {
    pub(super) options: &'a SvgOptions,
    /// Inkscape layer (or top-level group) ids → layer names.
    pub(super) layer_groups: &'a HashMap<String, String>,
    pub(super) layer_names: Vec<String>,
    index: HashMap<String, usize>,
    pub(super) items: Vec<Item>,
    pub(super) skipped: Skipped,
    pub(super) warnings: Vec<String>,
    font: Option<Result<HersheyFont, String>>,
    name: &'a str,
    /// Shapes painted by pattern fills so far (bounded by [`pattern::MAX_PATTERN_SHAPES`]).
    pattern_shapes: usize,
    /// Opaque plain fills `--hatch tone` shades, hatched run by run once the walk is done ([`blend`]).
    tone_fills: Vec<blend::ToneFill>,
    /// Opaque plain fill-only shapes hatched at one spacing (`--hatch SPACING`, a pen's hatch): the steps of blends
    /// among them are not outlined inside their blend once the walk is done ([`blend`]).
    blend_steps: Vec<blend::Step>,
    /// The layout factors the walk's page-size choices hold for.
    pub(super) scales: ScaleRange,
}

fn affine(t: &usvg::Transform) -> Affine {
    Affine::new([t.sx, t.ky, t.kx, t.sy, t.tx, t.ty].map(f64::from))
}

fn rgb(c: usvg::Color) -> Rgb {
    Rgb(c.red, c.green, c.blue)
}

/// Whether the paint is `color` all over (a plain colour, or a gradient whose every stop is that colour).
fn paint_is(p: &usvg::Paint, color: Rgb) -> bool {
    let stops = |s: &[usvg::Stop]| !s.is_empty() && s.iter().all(|s| rgb(s.color()) == color);
    match p {
        usvg::Paint::Color(c) => rgb(*c) == color,
        usvg::Paint::LinearGradient(g) => stops(g.stops()),
        usvg::Paint::RadialGradient(g) => stops(g.stops()),
        usvg::Paint::Pattern(_) => false,
    }
}

/// The paint's one colour (a plain colour, or a gradient whose every stop has it); `None` otherwise.
fn uniform_color(p: &usvg::Paint) -> Option<Rgb> {
    let stops = |s: &[usvg::Stop]| {
        let first = rgb(s.first()?.color());
        s.iter().all(|s| rgb(s.color()) == first).then_some(first)
    };
    match p {
        usvg::Paint::Color(c) => Some(rgb(*c)),
        usvg::Paint::LinearGradient(g) => stops(g.stops()),
        usvg::Paint::RadialGradient(g) => stops(g.stops()),
        usvg::Paint::Pattern(_) => None,
    }
}

/// The paint's own opacity: 1 for a colour, the least stop opacity of a gradient, 0 for a pattern (whose tiles
/// paint on their own).
fn paint_alpha(p: &usvg::Paint) -> f32 {
    let stops = |s: &[usvg::Stop]| s.iter().map(|s| s.opacity().get()).reduce(f32::min).unwrap_or(0.0);
    match p {
        usvg::Paint::Color(_) => 1.0,
        usvg::Paint::LinearGradient(g) => stops(g.stops()),
        usvg::Paint::RadialGradient(g) => stops(g.stops()),
        usvg::Paint::Pattern(_) => 0.0,
    }
}

/// The paint's colour (a gradient's first stop; black for patterns) and whether it is fully opaque.
fn paint_color(p: &usvg::Paint) -> (Rgb, bool) {
    let stops = |s: &[usvg::Stop]| {
        let first = s.first().map_or(Rgb::BLACK, |s| rgb(s.color()));
        (first, !s.is_empty() && s.iter().all(|s| s.opacity().get() >= 1.0))
    };
    match p {
        usvg::Paint::Color(c) => (rgb(*c), true),
        usvg::Paint::LinearGradient(g) => stops(g.stops()),
        usvg::Paint::RadialGradient(g) => stops(g.stops()),
        usvg::Paint::Pattern(_) => (Rgb::BLACK, false),
    }
}

/// `top` painted at opacity `alpha` over `under`, per channel (source-over compositing, rounded).
fn blend(top: Rgb, under: Rgb, alpha: f32) -> Rgb {
    let a = alpha.clamp(0.0, 1.0);
    // The result lies between the two channel values, so it is within 0..=255.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let mix = |t: u8, u: u8| (f32::from(t) * a + f32::from(u) * (1.0 - a)).round() as u8;
    Rgb(mix(top.0, under.0), mix(top.1, under.1), mix(top.2, under.2))
}

/// Luminance of an sRGB colour, 0..1 (the coefficients of the SVG mask luminance).
fn luminance(c: Rgb) -> f32 {
    (0.2125 * f32::from(c.0) + 0.7154 * f32::from(c.1) + 0.0721 * f32::from(c.2)) / 255.0
}

fn describe(tag: &str, id: &str) -> String {
    if id.is_empty() { format!("<{tag}>") } else { format!("<{tag} id=\"{id}\">") }
}

impl<'a> Walker<'a> {
    pub(super) fn new(options: &'a SvgOptions, layer_groups: &'a HashMap<String, String>, name: &'a str) -> Self {
        Walker {
            options,
            layer_groups,
            layer_names: Vec::new(),
            index: HashMap::new(),
            items: Vec::new(),
            skipped: Skipped::default(),
            warnings: Vec::new(),
            font: None,
            name,
            pattern_shapes: 0,
            tone_fills: Vec::new(),
            blend_steps: Vec::new(),
            scales: ScaleRange::default(),
        }
    }

    fn layer_index(&mut self, key: &str) -> usize {
        if let Some(i) = self.index.get(key) {
            return *i;
        }
        self.layer_names.push(key.to_owned());
        self.index.insert(key.to_owned(), self.layer_names.len() - 1);
        self.layer_names.len() - 1
    }

    /// Walk the root's children with `t` (user units → px).
    pub(super) fn walk_root(&mut self, root: &usvg::Group, t: Affine) {
        let ctx = Ctx { t, clips: Vec::new(), opacity: 1.0, layer: None };
        for node in root.children() {
            self.walk(node, &ctx);
        }
        let fills = std::mem::take(&mut self.tone_fills);
        self.skipped.hatch_refused += blend::hatch_runs(fills, &mut self.items);
        blend::drop_step_edges(std::mem::take(&mut self.blend_steps), &mut self.items);
    }

    /// One element (and what it contains); nothing once the import is cancelled (the caller then reports it).
    fn walk(&mut self, node: &usvg::Node, ctx: &Ctx) {
        if self.options.cancel.is_cancelled() {
            return;
        }
        match node {
            usvg::Node::Group(g) => self.walk_group(g, ctx),
            usvg::Node::Path(p) => self.add_path(p, ctx, "path"),
            usvg::Node::Text(text) => match self.options.text {
                TextMode::Outlines => self.walk_group(text.flattened(), ctx),
                TextMode::SingleStroke => self.single_stroke(text, ctx),
            },
            usvg::Node::Image(image) => self.add_image(image, ctx),
        }
    }

    fn walk_group(&mut self, g: &usvg::Group, ctx: &Ctx) {
        let mut ctx = ctx.clone();
        if ctx.layer.is_none()
            && let Some(name) = self.layer_groups.get(g.id())
        {
            let name = name.clone();
            ctx.layer = Some(self.layer_index(&name));
        }
        ctx.opacity *= g.opacity().get();
        if ctx.opacity <= 0.0 {
            self.skipped.transparent += count_shapes(g);
            return;
        }
        ctx.t *= affine(&g.transform());
        if let Some(cp) = g.clip_path() {
            let r = self.clip_region(cp, ctx.t);
            ctx.clips.push(std::rc::Rc::new(r));
        }
        if let Some(mask) = g.mask() {
            let r = self.mask_region(mask, ctx.t);
            ctx.clips.push(std::rc::Rc::new(r));
        }
        for child in g.children() {
            self.walk(child, &ctx);
        }
    }

    /// The layer an item goes to.
    fn item_layer(&mut self, ctx: &Ctx, color: Rgb) -> usize {
        match self.options.layer_by {
            LayerBy::Color => self.layer_index(&color.to_hex()),
            LayerBy::None => self.layer_index("drawing"),
            LayerBy::Auto | LayerBy::Group => match ctx.layer {
                Some(i) => i,
                None if self.options.layer_by == LayerBy::Auto && self.layer_groups.is_empty() => {
                    self.layer_index("drawing")
                }
                None => self.layer_index("root"),
            },
        }
    }

    /// How the fills of an item in `layer` drawn in `color` are hatched: `--hatch` for all, else the hatch of the
    /// layer's pen in the profile's pen table (its spacing a page size, see [`SvgOptions::hatch_scale`]).
    fn fill_hatch(&self, layer: usize, color: Rgb) -> Option<FillHatch> {
        self.options.hatch.or_else(|| {
            let h = self.table_hatch(layer, color)?.1.filter(|h| !h.tone)?;
            Some(FillHatch { spacing_mm: h.spacing_mm / self.options.hatch_scale, ..FillHatch::from(h) })
        })
    }

    /// The tone hatch of an item in `layer` drawn in `color`: `--hatch tone` for all, else the layer's pen's when
    /// its hatch says `tone` (and no `--hatch` spacing is set for all), at the pen's width.
    fn tone_hatch(&self, layer: usize, color: Rgb) -> Option<ToneHatch> {
        if self.options.tone_hatch.is_some() || self.options.hatch.is_some() {
            return self.options.tone_hatch;
        }
        let (width, h) = self.table_hatch(layer, color)?;
        let h = h.filter(|h| h.tone)?;
        let pen = width / self.options.hatch_scale;
        Some(ToneHatch { pen_mm: pen, min_spacing_mm: 1.5 * pen, angle_deg: h.angle_deg })
    }

    /// The width (mm on the page) and hatch of the pen-table pen of `layer` / `color`.
    fn table_hatch(&self, layer: usize, color: Rgb) -> Option<(f64, Option<crate::config::profile::PenHatch>)> {
        let name = &self.layer_names[layer];
        let pen = &self.options.pens[crate::config::pens::table_index(&self.options.pens, name, color)?];
        Some((pen.width_mm.unwrap_or(self.options.pen_width_mm), pen.hatch))
    }

    /// Flatten usvg path data under `t` (px) into mm polylines.
    fn flatten(&mut self, data: &tiny_skia_path::Path, t: Affine) -> Vec<Vec<Point>> {
        let to_mm = Affine::scale(MM_PER_PX) * t;
        let map = move |q: tiny_skia_path::Point| -> Point { to_mm * Point::new(f64::from(q.x), f64::from(q.y)) };
        let elements = data.segments().map(|seg| match seg {
            tiny_skia_path::PathSegment::MoveTo(a) => PathEl::MoveTo(map(a)),
            tiny_skia_path::PathSegment::LineTo(a) => PathEl::LineTo(map(a)),
            tiny_skia_path::PathSegment::QuadTo(a, b) => PathEl::QuadTo(map(a), map(b)),
            tiny_skia_path::PathSegment::CubicTo(a, b, c) => PathEl::CurveTo(map(a), map(b), map(c)),
            tiny_skia_path::PathSegment::Close => PathEl::ClosePath,
        });
        let (polys, dropped) = flatten_path(elements, self.options.tolerance_mm);
        self.skipped.dropped_subpaths += dropped;
        polys
    }

    /// Flatten for an area: every subpath counts, implicitly closed.
    fn area(&mut self, data: &tiny_skia_path::Path, t: Affine, rule: FillRule) -> Region {
        let before = self.skipped.dropped_subpaths;
        let polys = self.flatten(data, t);
        self.skipped.dropped_subpaths = before;
        Region::from_contours(polys.iter().map(Vec::as_slice), rule)
    }

    fn cut_to_clips(lines: Vec<Vec<Point>>, clips: &[std::rc::Rc<Region>]) -> Vec<Vec<Point>> {
        clips.iter().fold(lines, |lines, c| if lines.is_empty() { lines } else { cut(lines, &[c], Keep::Inside) })
    }

    fn add_path(&mut self, p: &usvg::Path, ctx: &Ctx, tag: &str) {
        if !p.is_visible() {
            self.skipped.hidden += 1;
            return;
        }
        let fill = p.fill().map(|f| {
            let (color, _) = paint_color(f.paint());
            let alpha = f.opacity().get() * ctx.opacity;
            let paper = paint_is(f.paint(), self.options.paper_color);
            // More than half opaque: it hides what lies under it (a fainter fill lets the eye see through).
            let hides = alpha * paint_alpha(f.paint()) > HIDING_ALPHA;
            (color, hides, alpha > 0.0, f.rule(), paper, alpha)
        });
        let stroke = p.stroke().filter(|s| s.opacity().get() * ctx.opacity > 0.0);
        let fill_visible = fill.is_some_and(|f| f.2);
        if stroke.is_none() && !fill_visible {
            self.skipped.transparent += 1;
            return;
        }
        let rule = |r: usvg::FillRule| if r == usvg::FillRule::EvenOdd { FillRule::EvenOdd } else { FillRule::NonZero };
        let mut lines = Vec::new();
        let scale_mm = MM_PER_PX * ctx.t.determinant().abs().sqrt();
        let color;
        let mut width_mm = Pen::default().width_mm;
        let mut stroke_area = None;
        if let Some(s) = stroke {
            let (stroke_color, stroke_paint_opaque) = paint_color(s.paint());
            color = stroke_color;
            width_mm = f64::from(s.width().get()) * scale_mm;
            let dashed = s.dasharray().map(|da| {
                // tiny-skia flattens curves while measuring to 0.5 / res_scale path units: ask for tolerance/4 mm.
                let res = narrow(0.5 * scale_mm / (self.options.tolerance_mm / 4.0));
                tiny_skia_path::StrokeDash::new(da.to_vec(), s.dashoffset())
                    .map(|dash| p.data().dash(&dash, res.max(1.0)))
            });
            lines = match dashed {
                // An invalid dash array (all zero, negative) draws solid, as in browsers.
                None | Some(None) => self.flatten(p.data(), ctx.t),
                Some(Some(Some(d))) => self.flatten(&d, ctx.t),
                Some(Some(None)) => Vec::new(),
            };
            // A wide opaque stroke hides what lies under it, as a fill does: wide on the page, where the pen draws.
            let opaque = stroke_paint_opaque && s.opacity().get() * ctx.opacity >= 1.0;
            let hiding_limit = WIDE_STROKE_PENS * self.options.pen_width_mm;
            let hides = width_mm * self.options.hatch_scale > hiding_limit;
            if self.options.occlusion && opaque {
                self.scales.wider_than(width_mm, hiding_limit, self.options.hatch_scale);
            }
            let wide = self.options.fill_strokes.is_some_and(|f| width_mm > f.pen_mm * 1.5)
                || (self.options.occlusion && hides);
            let outline_ok = !wide || within_reach(p.data(), ctx.t, width_mm);
            if !outline_ok {
                self.skipped.far_outlines += 1;
            }
            if let Some(fs) = self.options.fill_strokes
                && outline_ok
                && width_mm > fs.pen_mm * 1.5
                && let Some(outline) = p.data().stroke(&s.to_tiny_skia(), narrow(scale_mm / fs.pen_mm * 4.0))
            {
                let area = self.area(&outline, ctx.t, FillRule::NonZero);
                let passes = FillHatch { spacing_mm: fs.pen_mm, angle_deg: fs.angle_deg, cross: false, link: true };
                match hatch(&area, &passes) {
                    Some(h) => lines.extend(h),
                    None => self.skipped.hatch_refused += 1,
                }
            }
            if self.options.occlusion
                && opaque
                && outline_ok
                && hides
                && let Some(outline) = p.data().stroke(&s.to_tiny_skia(), narrow(scale_mm / self.options.tolerance_mm))
            {
                stroke_area = Some(self.area(&outline, ctx.t, FillRule::NonZero));
            }
        } else {
            color = fill.map_or(Rgb::BLACK, |f| f.0);
        }
        let layer = self.item_layer(ctx, color);
        let mut paints = Vec::new();
        let mut outline = None;
        // An opaque plain fill's darkness and tone hatch, when it is shaded after the walk.
        let mut deferred_tone = None;
        // An opaque plain fill-only shape's colour: it may be a step of a blend ([`blend`]).
        let mut step_color = None;
        if let Some((_, hides, visible, r, paper, alpha)) = fill
            && visible
            && let Some(f) = p.fill()
        {
            // Paper-coloured fills are not hatched: no ink belongs inside them.
            let fill_hatch = if paper { None } else { self.fill_hatch(layer, color) };
            // `--hatch tone`: the fill's lightness decides its hatch (white and paper fills get none).
            let tone = if paper { None } else { self.tone_hatch(layer, color) };
            let is_pattern = matches!(f.paint(), usvg::Paint::Pattern(_));
            // A translucent plain fill tints what lies beneath: the edge rule needs its area too.
            let tints = !hides && !is_pattern;
            let needs_area = hides || tints || fill_hatch.is_some() || tone.is_some();
            let area = needs_area.then(|| self.area(p.data(), ctx.t, rule(r)));
            let uniform = uniform_color(f.paint());
            // Only where the fill is hatched: the hatch shades the blend, and an outline per step would draw
            // contours the picture does not have. With outlines alone they are the only shading there is.
            if hides && stroke.is_none() && !is_pattern && fill_hatch.is_some() {
                step_color = uniform;
            }
            if let usvg::Paint::Pattern(pattern) = f.paint() {
                // The tiles are the fill: painted now, before the shape's stroke; the shape itself has no edge.
                let area = self.area(p.data(), ctx.t, rule(r));
                self.add_pattern(pattern, area, ctx, f.opacity().get(), &describe(tag, p.id()));
            } else if stroke.is_none() {
                let own = self.flatten(p.data(), ctx.t);
                outline = Some(Outline { lines: Self::cut_to_clips(own, &ctx.clips), color: uniform });
            }
            if let (Some(th), Some(a)) = (&tone, &area) {
                match fill_paint::tone_field(f.paint(), alpha, ctx.t, self.options.paper_color) {
                    // An opaque plain fill-only shape is shaded with the run of fills it belongs to, after the walk.
                    Some(ToneField::Flat(d)) if hides && stroke.is_none() && uniform.is_some() => {
                        deferred_tone = Some((d, *th));
                    }
                    Some(field) => {
                        let ladder = raster::Ladder { pen_mm: th.pen_mm, min_spacing_mm: th.min_spacing_mm };
                        let rung = fill_paint::rung_of(ladder, fill_paint::edge_ink(a, th.pen_mm));
                        let min_band = MIN_BAND_PENS * th.pen_mm;
                        match tone_hatch(a, &field, th.angle_deg, self.options.tolerance_mm, min_band, &rung) {
                            Some(l) => lines.extend(l),
                            None => self.skipped.hatch_refused += 1,
                        }
                    }
                    None => {}
                }
            } else if let (Some(h), Some(a)) = (&fill_hatch, &area) {
                match hatch(a, h) {
                    Some(l) => lines.extend(l),
                    None => self.skipped.hatch_refused += 1,
                }
            }
            if let Some(a) = area {
                if hides {
                    paints.push(Paint { area: a, color: uniform, hides: true });
                } else if tints {
                    let seen = uniform.map(|c| blend(c, self.options.paper_color, alpha * paint_alpha(f.paint())));
                    paints.push(Paint { area: a, color: seen, hides: false });
                }
            }
        }
        if let Some(s) = stroke_area {
            let color = stroke.and_then(|s| uniform_color(s.paint()));
            paints.push(Paint { area: s, color, hides: true });
        }
        for paint in &mut paints {
            for c in &ctx.clips {
                paint.area = paint.area.intersect(c);
            }
        }
        paints.retain(|p| !p.area.is_empty());
        if let (Some((darkness, hatch)), Some(fill_paint)) = (deferred_tone, paints.first()) {
            self.tone_fills.push(blend::ToneFill {
                item: self.items.len(),
                layer,
                area: fill_paint.area.clone(),
                color: fill.map_or(color, |f| f.0),
                darkness,
                hatch,
            });
        } else if let (Some(color), false) = (step_color, paints.is_empty()) {
            self.blend_steps.push(blend::Step { item: self.items.len(), layer, color });
        }
        let lines = Self::cut_to_clips(lines, &ctx.clips);
        let pen = Pen { color, width_mm };
        self.items.push(Item { layer, pen, lines, outline, paints, element: describe(tag, p.id()) });
    }

    /// The area a clip path lets through, in mm, for content under `t` (px).
    fn clip_region(&mut self, cp: &usvg::ClipPath, t: Affine) -> Region {
        let mut region = self.clip_children(cp.root(), t * affine(&cp.transform()));
        if let Some(inner) = cp.clip_path() {
            region = region.intersect(&self.clip_region(inner, t));
        }
        region
    }

    fn clip_children(&mut self, g: &usvg::Group, t: Affine) -> Region {
        let mut parts = Vec::new();
        for child in g.children() {
            match child {
                usvg::Node::Path(p) if p.is_visible() => {
                    let rule = p.fill().map_or(usvg::FillRule::NonZero, usvg::Fill::rule);
                    let rule = if rule == usvg::FillRule::EvenOdd { FillRule::EvenOdd } else { FillRule::NonZero };
                    parts.push(self.area(p.data(), t, rule));
                }
                usvg::Node::Path(_) => {}
                usvg::Node::Group(cg) => {
                    let ct = t * affine(&cg.transform());
                    let mut r = self.clip_children(cg, ct);
                    if let Some(cp) = cg.clip_path() {
                        r = r.intersect(&self.clip_region(cp, ct));
                    }
                    parts.push(r);
                }
                usvg::Node::Text(text) => {
                    let r = self.clip_children(text.flattened(), t);
                    if r.is_empty() {
                        self.skipped.clip_text += 1;
                    }
                    parts.push(r);
                }
                usvg::Node::Image(_) => {}
            }
        }
        Region::union_all(parts)
    }

    /// The area where a mask is at least half opaque, in mm.
    fn mask_region(&mut self, mask: &usvg::Mask, t: Affine) -> Region {
        let r = mask.rect();
        let to_mm = Affine::scale(MM_PER_PX) * t;
        let corners = [(r.left(), r.top()), (r.right(), r.top()), (r.right(), r.bottom()), (r.left(), r.bottom())]
            .map(|(x, y)| to_mm * Point::new(f64::from(x), f64::from(y)));
        let rect = Region::from_contours([corners.as_slice()], FillRule::NonZero);
        let mut content = Region::default();
        let mut partial = false;
        self.mask_paint(mask.root(), t, mask.kind(), 1.0, &mut content, &mut partial);
        if partial {
            self.skipped.partial_masks += 1;
        }
        let mut region = rect.intersect(&content);
        if let Some(inner) = mask.mask() {
            region = region.intersect(&self.mask_region(inner, t));
        }
        region
    }

    fn mask_paint(
        &mut self,
        g: &usvg::Group,
        t: Affine,
        kind: usvg::MaskType,
        opacity: f32,
        content: &mut Region,
        partial: &mut bool,
    ) {
        for child in g.children() {
            match child {
                usvg::Node::Group(cg) => {
                    let o = opacity * cg.opacity().get();
                    let ct = t * affine(&cg.transform());
                    if let Some(cp) = cg.clip_path() {
                        // A clipped group inside a mask: paint it into its own area, then keep what the clip allows.
                        let mut inner = Region::default();
                        self.mask_paint(cg, ct, kind, o, &mut inner, partial);
                        let clip = self.clip_region(cp, ct);
                        *content = content.union(&inner.intersect(&clip));
                    } else {
                        self.mask_paint(cg, ct, kind, o, content, partial);
                    }
                }
                usvg::Node::Path(p) if p.is_visible() => {
                    let Some(f) = p.fill() else { continue };
                    let (c, opaque) = paint_color(f.paint());
                    let alpha = f.opacity().get() * opacity;
                    let value = match kind {
                        usvg::MaskType::Luminance => luminance(c) * alpha,
                        usvg::MaskType::Alpha => alpha,
                    };
                    if !opaque || (value > 0.0 && value < 1.0) {
                        *partial = true;
                    }
                    let rule = if f.rule() == usvg::FillRule::EvenOdd { FillRule::EvenOdd } else { FillRule::NonZero };
                    let area = self.area(p.data(), t, rule);
                    if value >= 0.5 {
                        *content = content.union(&area);
                    } else if alpha >= 0.5 {
                        // A dark, opaque shape paints the mask transparent where it lies.
                        *content = content.difference(&area);
                    }
                }
                usvg::Node::Path(_) => {}
                usvg::Node::Text(text) => self.mask_paint(text.flattened(), t, kind, opacity, content, partial),
                usvg::Node::Image(_) => *partial = true,
            }
        }
    }

    /// `--text single-stroke`: each glyph usvg laid out is replaced by the Hershey glyph of its character, placed
    /// at the glyph's origin, scaled to the span's font size and turned with the glyph's transform.
    fn single_stroke(&mut self, text: &usvg::Text, ctx: &Ctx) {
        if self.font.is_none() {
            self.font = Some(HersheyFont::load_default());
        }
        let font = match self.font.as_ref().expect("loaded above") {
            Ok(f) => f.clone(),
            Err(e) => {
                let msg = format!("{}: {e}; text drawn as glyph outlines", self.name);
                if !self.warnings.contains(&msg) {
                    self.warnings.push(msg);
                }
                self.walk_group(text.flattened(), ctx);
                return;
            }
        };
        let to_mm = Affine::scale(MM_PER_PX) * ctx.t;
        for span in text.layouted() {
            if !span.visible {
                continue;
            }
            let paint = span.stroke.as_ref().map(usvg::Stroke::paint).or(span.fill.as_ref().map(usvg::Fill::paint));
            let color = paint.map_or(Rgb::BLACK, |p| paint_color(p).0);
            let size = f64::from(span.font_size.get());
            let mut lines = Vec::new();
            for glyph in &span.positioned_glyphs {
                let m = affine(&glyph.transform());
                // The glyph transform scales font units to the font size; undo that scale, keep position and turn.
                let s = m.determinant().abs().sqrt();
                if s <= 0.0 || !s.is_finite() {
                    continue;
                }
                let place = to_mm * m * Affine::scale(size / (hershey::UNITS_PER_EM * s));
                for c in glyph.text.chars().filter(|c| !c.is_whitespace()).take(1) {
                    let g = font.glyph(c);
                    for stroke in &g.strokes {
                        lines.push(
                            stroke
                                .iter()
                                .map(|q| place * Point::new(q.x - g.left, q.y - hershey::BASELINE))
                                .collect::<Vec<Point>>(),
                        );
                    }
                }
            }
            let lines = Self::cut_to_clips(lines, &ctx.clips);
            let layer = self.item_layer(ctx, color);
            let pen = Pen { color, width_mm: Pen::default().width_mm };
            self.items.push(Item {
                layer,
                pen,
                lines,
                outline: None,
                paints: Vec::new(),
                element: describe("text", text.id()),
            });
        }
    }

    /// `--images MODE`: trace an embedded PNG/JPEG through the raster pipeline, placed by the image's transform.
    fn add_image(&mut self, image: &usvg::Image, ctx: &Ctx) {
        let element = describe("image", image.id());
        let Some(mode) = self.options.images.as_ref() else { return };
        if !image.is_visible() {
            self.skipped.hidden += 1;
            return;
        }
        let bytes = match image.kind() {
            usvg::ImageKind::PNG(d) | usvg::ImageKind::JPEG(d) => d.clone(),
            other => {
                self.skipped.images_not_traced += 1;
                self.warnings.push(format!("{}: {element}: {other:?} images are not traced", self.name));
                return;
            }
        };
        let decoded = match image::load_from_memory(&bytes) {
            Ok(i) => i,
            Err(e) => {
                self.skipped.images_undecodable += 1;
                self.warnings.push(format!("{}: {element}: cannot decode the image ({e})", self.name));
                return;
            }
        };
        // The image's own transform maps its pixels to the canvas (aspect ratio applied by usvg); usvg's
        // abs_transform already contains the root viewBox in f32, which is accurate to 1e-7 here.
        let m = affine(&image.abs_transform());
        let to_mm = Affine::scale(MM_PER_PX) * m;
        let pixel_mm = to_mm.determinant().abs().sqrt();
        let opts = raster::TraceOptions {
            pitch_mm: Some(pixel_mm),
            width_mm: None,
            cancel: self.options.cancel.clone(),
            ..mode.trace.clone()
        };
        let traced = match raster::trace_named(&decoded, &element, &opts) {
            Ok(t) => t,
            Err(e) => {
                self.warnings.push(format!("{}: {element}: {e}", self.name));
                return;
            }
        };
        for w in &traced.warnings {
            self.warnings.push(format!("{}: {element}: {w}", self.name));
        }
        // Working pixels (possibly downscaled) back to the image's pixels.
        let back = f64::from(decoded.width()) / (f64::from(traced.size_px.0) * traced.pixel_mm);
        let lines: Vec<Vec<Point>> = traced
            .drawing
            .paths()
            .map(|p| p.points.iter().map(|q| to_mm * Point::new(q.x * back, q.y * back)).collect())
            .collect();
        let lines = Self::cut_to_clips(lines, &ctx.clips);
        let pen = raster::TraceOptions::default().pen;
        let layer = self.item_layer(ctx, pen.color);
        self.items.push(Item { layer, pen, lines, outline: None, paints: Vec::new(), element });
    }
}

/// f64 → f32 for tiny-skia's resolution scales (any precision loss only changes how finely curves are measured).
#[allow(clippy::cast_possible_truncation)]
fn narrow(v: f64) -> f32 {
    v as f32
}

/// Shapes in a subtree (for the count of skipped transparent shapes).
fn count_shapes(g: &usvg::Group) -> usize {
    g.children()
        .iter()
        .map(|c| match c {
            usvg::Node::Group(g) => count_shapes(g),
            _ => 1,
        })
        .sum()
}
