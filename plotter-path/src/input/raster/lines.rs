//! Families of parallel lines and where they lie inside a region: the geometry the hatch styles and the zig-zag
//! joiner share.

use kurbo::Point;

/// One family of parallel lines: direction and offsets `v = phase + k · period` across it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LineFamily {
    /// Direction of the lines in radians (page angle: counter-clockwise as seen, i.e. Y up).
    pub angle: f64,
    /// Distance between neighbouring lines, in pixels.
    pub period: f64,
    /// Offset of line 0 across the lines, in pixels.
    pub phase: f64,
}

impl LineFamily {
    /// Unit direction along the lines and unit normal across them, in pixel coordinates (Y down).
    pub fn frame(&self) -> ((f64, f64), (f64, f64)) {
        let (s, c) = self.angle.sin_cos();
        // Page angle is counter-clockwise as seen, so Y (down) flips the sine.
        ((c, -s), (s, c))
    }

    /// Offset across the lines of `p`.
    pub fn offset(&self, p: Point) -> f64 {
        let (_, n) = self.frame();
        p.x * n.0 + p.y * n.1
    }
}

/// The inside spans of one line of a family: the line's slot (consecutive lines have consecutive slots), its
/// offset `v` across the family, and the `(u_start, u_end)` intervals along it, sorted.
#[derive(Debug, Clone, PartialEq)]
pub struct LineSpans {
    /// The line's number counted from the region's first line.
    pub slot: usize,
    /// Offset across the family, pixels.
    pub v: f64,
    /// Inside intervals along the line, increasing.
    pub spans: Vec<(f64, f64)>,
}

/// The inside spans of every line of `family` that crosses the even-odd region bounded by the closed `loops`, in
/// line order.
pub fn line_spans(loops: &[Vec<Point>], family: &LineFamily) -> Vec<LineSpans> {
    let (d, n) = family.frame();
    let to_uv = |p: Point| (p.x * d.0 + p.y * d.1, p.x * n.0 + p.y * n.1);
    let (mut vmin, mut vmax) = (f64::INFINITY, f64::NEG_INFINITY);
    for p in loops.iter().flatten() {
        let v = to_uv(*p).1;
        vmin = vmin.min(v);
        vmax = vmax.max(v);
    }
    if vmin > vmax || family.period <= 0.0 {
        return Vec::new();
    }
    let k0 = ((vmin - family.phase) / family.period).floor();
    let lines = ((vmax - family.phase) / family.period).floor() - k0 + 1.0;
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)] // lines ≥ 1, bounded by image size / period
    let mut crossings: Vec<Vec<f64>> = vec![Vec::new(); lines.max(1.0) as usize];
    for pl in loops {
        for e in pl.windows(2) {
            let ((ua, va), (ub, vb)) = (to_uv(e[0]), to_uv(e[1]));
            if va == vb {
                continue;
            }
            let (lo, hi) = (va.min(vb), va.max(vb));
            let mut k = ((lo - family.phase) / family.period).ceil();
            loop {
                let v = family.phase + k * family.period;
                if v >= hi {
                    break;
                }
                if v >= lo {
                    let u = ua + (v - va) / (vb - va) * (ub - ua);
                    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)] // k ≥ k0 by construction
                    let slot = (k - k0) as usize;
                    if let Some(c) = crossings.get_mut(slot) {
                        c.push(u);
                    }
                }
                k += 1.0;
            }
        }
    }
    let mut out = Vec::new();
    for (slot, mut us) in crossings.into_iter().enumerate() {
        if us.len() < 2 {
            continue;
        }
        us.sort_by(f64::total_cmp);
        #[allow(clippy::cast_precision_loss)] // line counts are small
        let v = family.phase + (k0 + slot as f64) * family.period;
        let spans: Vec<(f64, f64)> = us.chunks_exact(2).filter(|c| c[1] > c[0]).map(|c| (c[0], c[1])).collect();
        if !spans.is_empty() {
            out.push(LineSpans { slot, v, spans });
        }
    }
    out
}

/// The span `(a, b)` of a line as a round-capped pen `pen_px` wide draws it, each end pulled in by `pull.0` and
/// `pull.1` (the pen's radius where its cap must stay inside the region, else 0): the pulled span when the span is
/// longer than the pen's width; else a dot at its middle when the dot's ink (`π r²`) is no more than twice the span's
/// (`pen · length`); else nothing.
pub fn pen_span((a, b): (f64, f64), pen_px: f64, pull: (f64, f64)) -> Option<(f64, f64)> {
    let r = pen_px / 2.0;
    if b - a > 2.0 * r {
        Some((a + pull.0, b - pull.1))
    } else if 2.0 * pen_px * (b - a) >= std::f64::consts::PI * r * r {
        let m = (a + b) / 2.0;
        Some((m, m))
    } else {
        None
    }
}

/// The parts of the lines of `family` inside the even-odd region bounded by the closed `loops`, every other line
/// reversed (boustrophedon).
pub fn clip_lines(loops: &[Vec<Point>], family: &LineFamily) -> Vec<(Point, Point)> {
    let (d, n) = family.frame();
    let mut out = Vec::new();
    for line in line_spans(loops, family) {
        let v = line.v;
        let at = |u: f64| Point::new(u * d.0 + v * n.0, u * d.1 + v * n.1);
        let mut spans: Vec<(Point, Point)> = line.spans.iter().map(|&(a, b)| (at(a), at(b))).collect();
        if line.slot % 2 == 1 {
            spans.reverse();
            for s in &mut spans {
                *s = (s.1, s.0);
            }
        }
        out.extend(spans);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 3 px pen (radius 1.5): a 10 px span pulled in at one end only keeps its other end; a 2 px span is shorter
    /// than the pen's width and becomes a dot at its middle, since the dot's ink (π · 1.5² ≈ 7.07 px²) is at most
    /// twice the span's (2 · 3 · 2 = 12 px²); a 1 px span (2 · 3 · 1 = 6 px² < 7.07 px²) is dropped.
    #[test]
    fn a_pen_span_is_pulled_in_kept_as_a_dot_or_dropped() {
        assert_eq!(pen_span((0.0, 10.0), 3.0, (1.5, 0.0)), Some((1.5, 10.0)));
        assert_eq!(pen_span((0.0, 10.0), 3.0, (1.5, 1.5)), Some((1.5, 8.5)));
        assert_eq!(pen_span((4.0, 6.0), 3.0, (1.5, 1.5)), Some((5.0, 5.0)));
        assert_eq!(pen_span((4.0, 5.0), 3.0, (1.5, 1.5)), None);
    }
}
