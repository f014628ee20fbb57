//! `<pattern>` fills: the pattern's content is painted once per tile, as resvg does — tile `(i, j)` is the
//! pattern rectangle moved by `i` widths and `j` heights, its content placed at the tile's corner, mapped to the
//! shape's user space by `patternTransform` (usvg has already resolved `patternUnits`, `patternContentUnits` and
//! the pattern's `viewBox` into the rectangle, the transform and the content) — and cut to the shape's filled area
//! and, when the content reaches beyond it, to the tile. The tiles' shapes are walked like any other, so they are
//! outlined, hide what lies under them and are hidden by what comes later by the same rules.
//!
//! Only the tiles whose rectangle meets the shape's bounding box are painted. A pattern whose tiles are no wider
//! than the pen on the plotted page (their size in the document times [`super::SvgOptions::hatch_scale`], the
//! layout's factor) is not drawn: a pen cannot draw detail finer than itself, the lines would merge into a blot.
//! That choice is recorded in the walk's [`super::Walker::scales`], so that a layout by a factor on the other side
//! of it has the drawing decoded again (a card of fine tiles enlarged onto a page draws them; a poster of tiles a
//! little wider than the pen, shrunk, does not). Nor is a pattern drawn that would bring the shapes painted by the
//! document's patterns beyond [`MAX_PATTERN_SHAPES`] (patterns inside patterns multiply); both are reported.

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
        // Judged on the page, where the pen draws them: drawn when wider than the pen there.
        let (page, pen) = (self.options.hatch_scale, self.options.pen_width_mm);
        self.scales.wider_than(w_mm.min(h_mm), pen, page);
        if w_mm.min(h_mm) * page <= pen {
            self.skipped.fine_patterns += 1;
            self.warnings.push(format!(
                "{}: {shown}: not drawn, its {tiles:.0} tile(s) of {:.3} × {:.3} mm on the page are no wider than \
                 the {pen} mm pen",
                self.name,
                w_mm * page,
                h_mm * page
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

#[cfg(test)]
mod tests {
    use crate::Drawing;
    use crate::input::svg::{Imported, ResourcePolicy, ScaleRange, SvgOptions, import_svg};

    /// A 100 mm document: a 7 mm line, and a 5 × 2.5 mm rect filled with 0.25 mm tiles, each holding a line across
    /// its middle: 10 rows of 20 tiles, 10 × 5 = 50 mm of lines when drawn.
    fn tiled(scale: f64) -> Imported {
        let svg = r#"<svg xmlns="http://www.w3.org/2000/svg" width="100mm" height="100mm" viewBox="0 0 100 100">
            <defs><pattern id="p" patternUnits="userSpaceOnUse" width="0.25" height="0.25">
              <path d="M0 0.125H0.25" stroke="black" stroke-width="0.05"/></pattern></defs>
            <line x1="0" y1="90" x2="7" y2="90" stroke="black"/>
            <rect x="5" y="5" width="5" height="2.5" fill="url(#p)"/></svg>"#;
        let options = SvgOptions { hatch_scale: scale, ..SvgOptions::default() };
        import_svg(svg.as_bytes(), "t.svg", &ResourcePolicy::DataUrlsOnly, &options).unwrap()
    }

    fn ink(d: &Drawing) -> f64 {
        d.paths().map(crate::geometry::drawing::Polyline::length).sum()
    }

    /// The 0.25 mm tiles against the 0.3 mm pen on the page: 0.25 mm at 1× and 0.275 mm at 1.1× (not drawn, the
    /// line alone: 7 mm), 0.325 mm at 1.3× and 0.5 mm at 2× (drawn: 57 mm in the document). The choice flips at
    /// 0.3 / 0.25 = 1.2×, which the import records: up to 1.2× when not drawn, above it when drawn (and then up to
    /// 24×, where the tiles' 0.05 mm lines would be four pens, 1.2 mm, wide and hide what lies under them).
    #[test]
    fn tiles_are_drawn_by_their_width_on_the_page() {
        assert_eq!(SvgOptions::default().pen_width_mm, 0.3);
        for (scale, want, drawn) in [(1.0, 7.0, false), (1.1, 7.0, false), (1.3, 57.0, true), (2.0, 57.0, true)] {
            let imported = tiled(scale);
            let got = ink(&imported.drawing);
            assert!((got - want).abs() < 1e-3, "{scale}×: {got} mm of ink, expected {want}");
            let warned = imported.warnings.iter().any(|w| w.contains("pattern \"p\"") && w.contains("no wider"));
            assert_eq!(warned, !drawn, "{scale}×: {:?}", imported.warnings);
            let ScaleRange { above, up_to } = imported.scales;
            if drawn {
                assert!((above - 1.2).abs() < 1e-5 && (up_to - 24.0).abs() < 1e-5, "{scale}×: {:?}", imported.scales);
            } else {
                assert!(above == 0.0 && (up_to - 1.2).abs() < 1e-5, "{scale}×: {:?}", imported.scales);
            }
        }
        // The warning gives the tiles' size on the page, and counts those meeting the rect's box, x 5..10 and
        // y 5..7.5: tiles 20 ..= 40 across (the last starts on the box's edge) and 20 ..= 30 down, 21 × 11 = 231.
        let w = tiled(1.1).warnings.join("; ");
        assert!(w.contains("231 tile(s) of 0.275 × 0.275 mm on the page"), "{w}");
    }
}
