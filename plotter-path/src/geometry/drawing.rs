//! The `Drawing` model: layers of polylines in millimetres, page coordinates (origin top-left, Y down, like SVG).
//!
//! Every input (SVG, raster image, parametric curve, G-code, trajectory file) becomes a [`Drawing`]; every later
//! stage (layout, ordering, motion planning, previews, export) reads one. A path is *closed* exactly when its first
//! point equals its last point (bit-for-bit), so closure survives every transform that maps equal points to equal
//! points and needs no separate flag to keep in sync.

use kurbo::{Point, Rect};

// A layer's pen and its colour are configuration too (the pen table matches them), defined in `config`; they are
// re-exported here, where drawings use them.
pub use crate::config::color::Rgb;
pub use crate::config::pens::Pen;

/// One pen-down stroke: a sequence of points in millimetres. Closed when first point == last point.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Polyline {
    /// The vertices, in drawing order.
    pub points: Vec<Point>,
    /// The colour and stroke width this path has in its source, when the source gives each path its own (an SVG
    /// layer holds paths of many colours). Previews draw with it; `None` means the layer's pen.
    pub pen: Option<Pen>,
}

impl Polyline {
    /// A polyline through `points`.
    pub fn new(points: Vec<Point>) -> Self {
        Polyline { points, pen: None }
    }

    /// A polyline through `points` drawn in its source with `pen`.
    pub fn with_pen(points: Vec<Point>, pen: Pen) -> Self {
        Polyline { points, pen: Some(pen) }
    }

    /// True when the path returns to its start (first point equals last point exactly) and has a body.
    pub fn is_closed(&self) -> bool {
        self.points.len() > 2 && self.points.first() == self.points.last()
    }

    /// Number of straight segments (vertices − 1, or 0 for an empty path).
    pub fn segment_count(&self) -> usize {
        self.points.len().saturating_sub(1)
    }

    /// Euclidean length in millimetres.
    pub fn length(&self) -> f64 {
        self.points.windows(2).map(|w| w[0].distance(w[1])).sum()
    }

    /// First vertex, if any.
    pub fn start(&self) -> Option<Point> {
        self.points.first().copied()
    }

    /// Last vertex, if any.
    pub fn end(&self) -> Option<Point> {
        self.points.last().copied()
    }

    /// Reverse the drawing direction in place.
    pub fn reverse(&mut self) {
        self.points.reverse();
    }

    /// Axis-aligned bounding box, or `None` for an empty path.
    pub fn bbox(&self) -> Option<Rect> {
        let first = self.points.first()?;
        let mut r = Rect::from_points(*first, *first);
        for p in &self.points[1..] {
            r = r.union_pt(*p);
        }
        Some(r)
    }
}

/// A named group of polylines drawn with one pen. Layers are plotted in order; a pen change may sit between them.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Layer {
    /// Display name (Inkscape layer label, group id, or colour).
    pub name: String,
    /// The pen this layer is drawn with.
    pub pen: Pen,
    /// The strokes, in drawing order.
    pub paths: Vec<Polyline>,
}

impl Layer {
    /// An empty layer with the default pen.
    pub fn new(name: impl Into<String>) -> Self {
        Layer { name: name.into(), pen: Pen::default(), paths: Vec::new() }
    }
}

/// A whole drawing: layers of polylines in millimetres, page coordinates (origin top-left, Y down).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Drawing {
    /// The layers, in plotting order.
    pub layers: Vec<Layer>,
    /// The page size in millimetres the geometry refers to (from the SVG's width/height, or the layout's paper),
    /// if known.
    pub page_mm: Option<(f64, f64)>,
}

impl Drawing {
    /// A drawing with a single layer holding `paths`.
    pub fn single_layer(name: impl Into<String>, paths: Vec<Polyline>) -> Self {
        let mut layer = Layer::new(name);
        layer.paths = paths;
        Drawing { layers: vec![layer], page_mm: None }
    }

    /// All polylines of all layers, in plotting order.
    pub fn paths(&self) -> impl Iterator<Item = &Polyline> {
        self.layers.iter().flat_map(|l| l.paths.iter())
    }

    /// All polylines, mutable.
    pub fn paths_mut(&mut self) -> impl Iterator<Item = &mut Polyline> {
        self.layers.iter_mut().flat_map(|l| l.paths.iter_mut())
    }

    /// Number of polylines over all layers.
    pub fn path_count(&self) -> usize {
        self.layers.iter().map(|l| l.paths.len()).sum()
    }

    /// True when no layer holds a path with at least one segment.
    pub fn is_empty(&self) -> bool {
        self.paths().all(|p| p.points.len() < 2)
    }

    /// Bounding box of every vertex, or `None` when there are none.
    pub fn bbox(&self) -> Option<Rect> {
        self.paths().filter_map(Polyline::bbox).reduce(|a, b| a.union(b))
    }

    /// Apply `f` to every vertex of every path.
    pub fn map_points(&mut self, mut f: impl FnMut(Point) -> Point) {
        for path in self.paths_mut() {
            for p in &mut path.points {
                *p = f(*p);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closed_means_first_equals_last() {
        let open = Polyline::new(vec![Point::new(0.0, 0.0), Point::new(1.0, 0.0), Point::new(1.0, 1.0)]);
        assert!(!open.is_closed());
        let mut closed = open.clone();
        closed.points.push(Point::new(0.0, 0.0));
        assert!(closed.is_closed());
        assert_eq!(closed.segment_count(), 3);
        assert!((closed.length() - (2.0 + 2f64.sqrt())).abs() < 1e-12);
        // A single back-and-forth segment is not a closed shape.
        let degenerate = Polyline::new(vec![Point::new(0.0, 0.0), Point::new(0.0, 0.0)]);
        assert!(!degenerate.is_closed());
    }

    #[test]
    fn bbox_spans_layers() {
        let mut d = Drawing::single_layer("a", vec![Polyline::new(vec![Point::new(1.0, 2.0), Point::new(3.0, -1.0)])]);
        let mut b = Layer::new("b");
        b.paths.push(Polyline::new(vec![Point::new(-5.0, 0.0), Point::new(0.0, 10.0)]));
        d.layers.push(b);
        assert_eq!(d.bbox(), Some(Rect::new(-5.0, -1.0, 3.0, 10.0)));
        assert_eq!(d.path_count(), 2);
        d.map_points(|p| Point::new(p.x * 2.0, p.y));
        assert_eq!(d.bbox(), Some(Rect::new(-10.0, -1.0, 6.0, 10.0)));
    }
}
