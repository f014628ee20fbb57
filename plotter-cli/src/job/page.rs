//! A drawing as a front end draws it: layers of polylines with their pens, each path's place along the pen-down
//! length (so a page can ink the drawing up to the millimetres the machine reports as drawn), and the pen-up travel
//! between paths — serialisable as JSON for the web app.
//!
//! Coordinates are page millimetres rounded to a micrometre: far below a pen's width, and it keeps the JSON small.

use plotter_path::Drawing;
use plotter_path::geometry::travel::pen_up_moves;
use plotter_path::kurbo::{Line, Point};
use serde::Serialize;

/// A drawing for display.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PageView {
    /// Page size `[width, height]` in mm, when the drawing has one.
    pub page_mm: Option<[f64; 2]>,
    /// Bounding box `[x0, y0, x1, y1]` in mm, absent for an empty drawing.
    pub bbox_mm: Option<[f64; 4]>,
    /// Layers in plotting order.
    pub layers: Vec<LayerView>,
    /// Pen-up moves `[[x0, y0], [x1, y1]]` between consecutive paths, in plotting order.
    pub travel: Vec<[[f64; 2]; 2]>,
    /// Total pen-down length, mm.
    pub draw_mm: f64,
}

/// One layer for display.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LayerView {
    /// Layer name.
    pub name: String,
    /// Pen colour, `#rrggbb`.
    pub color: String,
    /// Pen width, mm.
    pub width_mm: f64,
    /// Its paths in plotting order.
    pub paths: Vec<PathView>,
}

/// One pen-down path for display.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PathView {
    /// Points `[x, y]` in page mm.
    pub points: Vec<[f64; 2]>,
    /// Pen-down length drawn before this path starts (over the whole drawing), mm.
    pub start_mm: f64,
    /// This path's length, mm.
    pub length_mm: f64,
}

fn round(v: f64) -> f64 {
    (v * 1000.0).round() / 1000.0
}

fn pt(p: Point) -> [f64; 2] {
    [round(p.x), round(p.y)]
}

/// The view of `drawing`, with the travel between its paths in drawing order.
pub fn view(drawing: &Drawing) -> PageView {
    view_with_travel(drawing, &pen_up_moves(drawing))
}

/// The view of `drawing` with the given pen-up moves (e.g. the ones a simulated machine made).
pub fn view_with_travel(drawing: &Drawing, travel: &[Line]) -> PageView {
    let mut done = 0.0;
    let layers = drawing
        .layers
        .iter()
        .map(|layer| LayerView {
            name: layer.name.clone(),
            color: layer.pen.color.to_hex(),
            width_mm: layer.pen.width_mm,
            paths: layer
                .paths
                .iter()
                .filter(|p| p.points.len() >= 2)
                .map(|p| {
                    let length_mm = p.length();
                    let view =
                        PathView { points: p.points.iter().map(|&q| pt(q)).collect(), start_mm: done, length_mm };
                    done += length_mm;
                    view
                })
                .collect(),
        })
        .collect();
    PageView {
        page_mm: drawing.page_mm.map(|(w, h)| [w, h]),
        bbox_mm: drawing.bbox().map(|r| [r.x0, r.y0, r.x1, r.y1]),
        layers,
        travel: travel.iter().map(|l| [pt(l.p0), pt(l.p1)]).collect(),
        draw_mm: done,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use plotter_path::{Layer, Pen, Polyline, Rgb};

    fn poly(points: &[(f64, f64)]) -> Polyline {
        Polyline::new(points.iter().map(|&(x, y)| Point::new(x, y)).collect())
    }

    #[test]
    fn paths_know_where_they_start_along_the_pen_down_length() {
        let mut a = Layer::new("a");
        a.pen = Pen { color: Rgb(255, 0, 16), width_mm: 0.5 };
        // A closed 10 mm square (40 mm), then a dot (skipped: nothing to draw).
        a.paths = vec![poly(&[(0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0), (0.0, 0.0)]), poly(&[(5.0, 5.0)])];
        let mut b = Layer::new("b");
        // A 3-4-5 triangle's hypotenuse, 5 mm, starting 20 mm right of the square's end.
        b.paths = vec![poly(&[(20.0, 0.0), (23.0, 4.0)])];
        let d = Drawing { layers: vec![a, b], page_mm: Some((210.0, 297.0)) };
        let v = view(&d);
        assert_eq!(v.page_mm, Some([210.0, 297.0]));
        assert_eq!(v.bbox_mm, Some([0.0, 0.0, 23.0, 10.0]));
        assert_eq!(v.layers[0].color, "#ff0010");
        assert_eq!(v.layers[0].width_mm, 0.5);
        assert_eq!(v.layers[0].paths.len(), 1);
        assert_eq!((v.layers[0].paths[0].start_mm, v.layers[0].paths[0].length_mm), (0.0, 40.0));
        assert_eq!((v.layers[1].paths[0].start_mm, v.layers[1].paths[0].length_mm), (40.0, 5.0));
        assert_eq!(v.draw_mm, 45.0);
        assert_eq!(v.travel, vec![[[0.0, 0.0], [20.0, 0.0]]]);
    }

    #[test]
    fn coordinates_are_rounded_to_a_micrometre_and_serialise() {
        let d = Drawing::single_layer("t", vec![poly(&[(1.0 / 3.0, 2.0 / 3.0), (1.0, 1.0)])]);
        let v = view(&d);
        assert_eq!(v.layers[0].paths[0].points, vec![[0.333, 0.667], [1.0, 1.0]]);
        let json = serde_json::to_value(&v).unwrap();
        assert_eq!(json["layers"][0]["paths"][0]["points"][0][0], 0.333);
        assert_eq!(json["page_mm"], serde_json::Value::Null);
    }
}
