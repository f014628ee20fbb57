//! `<pattern>` fills: the pattern's content is painted once per tile, as resvg does — tile `(i, j)` is the
//! pattern rectangle moved by `i` widths and `j` heights, its content placed at the tile's corner, mapped to the
//! shape's user space by `patternTransform` (usvg has already resolved `patternUnits`, `patternContentUnits` and
//! the pattern's `viewBox` into the rectangle, the transform and the content) — and cut to the shape's filled area
//! and, when the content reaches beyond it, to the tile. The tiles' shapes are walked like any other, so they are
//! outlined, hide what lies under them and are hidden by what comes later by the same rules.
//!
//! Only the tiles whose rectangle meets the shape's bounding box are painted. A pattern whose tiles are narrower
//! than the pen is not drawn (a pen cannot draw detail finer than itself; the lines would merge into a blot), nor
//! one that would bring the shapes painted by the document's patterns beyond [`MAX_PATTERN_SHAPES`] (patterns
//! inside patterns multiply); both are reported.

use kurbo::{Affine, Point, Rect, Vec2};

use super::{Ctx, Walker, affine};
use crate::geometry::region::{FillRule, Region};
use crate::input::svg::MM_PER_PX;

/// The most shapes the pattern fills of one document may paint (tiles × shapes per tile, summed).
pub(crate) const MAX_PATTERN_SHAPES: usize = 100_000;

impl Walker<'_> {
    /// Paint `pattern` over `area` (the shape's filled area, mm) for a shape under `ctx`, at `opacity` (the fill's).
    pub(super) fn add_pattern(
        &mut self,
        pattern: &usvg::Pattern,
        area: Region,
        ctx: &Ctx,
        opacity: f32,
        element: &str,
    ) {
        let Some(bbox) = area.bbox() else { return };
        let to_mm = Affine::scale(MM_PER_PX) * ctx.t * affine(&pattern.transform());
        let r = pattern.rect();
        let (x, y, w, h) = (f64::from(r.x()), f64::from(r.y()), f64::from(r.width()), f64::from(r.height()));
        let origin = to_mm * Point::ZERO;
        let (w_mm, h_mm) =
            ((to_mm * Point::new(w, 0.0) - origin).hypot(), (to_mm * Point::new(0.0, h) - origin).hypot());
        if to_mm.determinant().abs() < 1e-12 || !w_mm.is_finite() || !h_mm.is_finite() {
            return;
        }
        // The tiles meeting the shape's bounding box, in pattern space.
        let pb = to_mm.inverse().transform_rect_bbox(bbox);
        let range = |lo: f64, hi: f64, at: f64, size: f64| {
            let (a, b) = (((lo - at) / size).floor(), ((hi - at) / size).floor());
            (a, b, (b - a + 1.0).max(0.0))
        };
        let (i0, i1, ni) = range(pb.x0, pb.x1, x, w);
        let (j0, j1, nj) = range(pb.y0, pb.y1, y, h);
        let tiles = ni * nj;
        let shapes_per_tile = super::count_shapes(pattern.root()).max(1);
        let shown = format!("{element} filled with pattern \"{}\"", pattern.id());
        if w_mm.min(h_mm) < self.options.pen_width_mm {
            self.skipped.fine_patterns += 1;
            self.warnings.push(format!(
                "{}: {shown}: not drawn, its {tiles:.0} tile(s) of {w_mm:.3} × {h_mm:.3} mm are finer than the \
                 {} mm pen",
                self.name, self.options.pen_width_mm
            ));
            return;
        }
        #[allow(clippy::cast_precision_loss)]
        let needed = tiles * shapes_per_tile as f64;
        #[allow(clippy::cast_precision_loss)]
        if needed + self.pattern_shapes as f64 > MAX_PATTERN_SHAPES as f64 {
            self.skipped.huge_patterns += 1;
            self.warnings.push(format!(
                "{}: {shown}: not drawn, its {tiles:.0} tile(s) of {w_mm:.3} × {h_mm:.3} mm would paint more than \
                 {MAX_PATTERN_SHAPES} shapes (with the document's other patterns)",
                self.name
            ));
            return;
        }
        // At most MAX_PATTERN_SHAPES, checked above.
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        {
            self.pattern_shapes += needed as usize;
        }
        // The content needs the tile's clip only when it reaches beyond the tile.
        let content = pattern.root().stroke_bounding_box();
        let overflows = f64::from(content.left()) < 0.0
            || f64::from(content.top()) < 0.0
            || f64::from(content.right()) > w
            || f64::from(content.bottom()) > h;
        let mut inner = ctx.clone();
        inner.opacity *= opacity;
        inner.clips.push(std::rc::Rc::new(area));
        let base = ctx.t * affine(&pattern.transform());
        // Both ranges are bounded by MAX_PATTERN_SHAPES above, far inside i64.
        #[allow(clippy::cast_possible_truncation)]
        let (i0, i1, j0, j1) = (i0 as i64, i1 as i64, j0 as i64, j1 as i64);
        for j in j0..=j1 {
            for i in i0..=i1 {
                #[allow(clippy::cast_precision_loss)]
                let corner = Vec2::new(x + i as f64 * w, y + j as f64 * h);
                let mut tile = inner.clone();
                tile.t = base * Affine::translate(corner);
                if overflows {
                    let rect = Rect::new(0.0, 0.0, w, h);
                    let to_mm = Affine::scale(MM_PER_PX) * tile.t;
                    let corners = [(rect.x0, rect.y0), (rect.x1, rect.y0), (rect.x1, rect.y1), (rect.x0, rect.y1)]
                        .map(|(a, b)| to_mm * Point::new(a, b));
                    tile.clips.push(std::rc::Rc::new(Region::from_contours([corners.as_slice()], FillRule::NonZero)));
                }
                for child in pattern.root().children() {
                    self.walk(child, &tile);
                }
            }
        }
    }
}
