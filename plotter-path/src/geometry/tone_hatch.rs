//! Hatching a filled [`Region`] by its tone: the lighter the fill, the sparser its lines; past what one family of
//! lines can cover, a second family crosses the first, then a third.
//!
//! The fill's darkness comes as a [`ToneField`]: one darkness for a plain colour, or a gradient's darkness sampled
//! along its parameter `t` (0 at the start colour, 1 at the end). Which spacing and how many families a darkness
//! gets is the caller's tone model (the same ladder the image styles use), passed in as a function, since the tone
//! model belongs to the input stage and geometry comes before it.
//!
//! **Gradients.** The darkness along `t` is cut into bands, each at most [`BAND_STEP`] of darkness wide; each band
//! is the part of the shape where `t` lies between two values — a strip across a linear gradient, a ring of a
//! radial one (the circles of a radial gradient with a focus are not concentric: the circle at `t` has its centre
//! `t` of the way from the focus to the centre and its radius `t` of the way from the focal radius to the radius,
//! so a ring is the disc at the larger `t` less the disc at the smaller). The gradient's spread (pad, reflect,
//! repeat) decides `t` outside 0..1. Each band is hatched on its own at its mean darkness, with
//! [`super::hatch::hatch_part`]: lines on the page-wide grid of their spacing, cut to the band with the shape's fill
//! rule and holes, and joined into zig-zags where the connector stays inside and runs along the shape's own edge
//! (a connector along the cut between two bands would draw a line the fill does not have).

use kurbo::{Affine, Point, Rect, Vec2};

use super::hatch::{FillHatch, hatch, hatch_part};
use super::region::{FillRule, Region};

/// Tone hatch settings for SVG fills, in the plotted page's millimetres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ToneHatch {
    /// Pen width, mm: the width of every line, from which the ladder computes the spacing.
    pub pen_mm: f64,
    /// Closest spacing of one family of lines, mm.
    pub min_spacing_mm: f64,
    /// Direction of the first family, degrees counter-clockwise from +X on the page (the second turns 90°, the
    /// third 45° from it).
    pub angle_deg: f64,
}

/// Turns of the ladder's families from the base angle, degrees (the image hatch's order).
pub const FAMILY_TURNS: [f64; 3] = [0.0, 90.0, 45.0];

/// Widest darkness range one gradient band covers.
pub const BAND_STEP: f64 = 1.0 / 32.0;

/// Narrowest a band of one darkness is, in pen widths (2.1 mm for a 0.3 mm pen), along a gradient or across a
/// blend's band: lines cut at a band's edges put their pen's round ends into the neighbour band, which darkens
/// bands narrower than a few line spacings. A pen width, as the spacings are, so the bands are as wide on the
/// plotted page however much the layout magnifies the drawing.
pub const MIN_BAND_PENS: f64 = 7.0;

/// Most bands one gradient fill is cut into (a repeating gradient with many periods across a shape).
pub const MAX_BANDS: usize = 512;

/// Darkness below this is paper: nothing is drawn.
const PAPER: f64 = 1e-3;

/// How a gradient continues outside its 0..1 range.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Spread {
    /// The end colours continue.
    Pad,
    /// The gradient runs back and forth.
    Reflect,
    /// The gradient starts again.
    Repeat,
}

/// The geometry of a gradient, in its own coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum GradientShape {
    /// `t` runs from 0 at `from` to 1 at `to`, constant across.
    Linear {
        /// Where `t` is 0.
        from: Point,
        /// Where `t` is 1.
        to: Point,
    },
    /// `t` is 0 on the focal circle and 1 on the outer circle.
    Radial {
        /// Centre of the outer circle.
        center: Point,
        /// Radius of the outer circle.
        radius: f64,
        /// Centre of the focal circle.
        focus: Point,
        /// Radius of the focal circle.
        focal_radius: f64,
    },
}

/// A gradient's darkness over the page.
#[derive(Debug, Clone, PartialEq)]
pub struct GradientField {
    /// Its geometry, in gradient coordinates.
    pub shape: GradientShape,
    /// Gradient coordinates to page millimetres.
    pub to_page: Affine,
    /// Outside 0..1.
    pub spread: Spread,
    /// Darkness (0 = paper, 1 = solid ink) at evenly spaced `t` from 0 to 1 (at least one sample).
    pub darkness: Vec<f64>,
}

/// How dark a fill is over its area.
#[derive(Debug, Clone, PartialEq)]
pub enum ToneField {
    /// One darkness all over (0 = paper, 1 = solid ink).
    Flat(f64),
    /// A gradient.
    Gradient(GradientField),
}

/// A band of darkness: `t` from `lo` to `hi` (`None`: unbounded on that side) at `darkness`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Band {
    lo: Option<f64>,
    hi: Option<f64>,
    darkness: f64,
}

/// The tone hatch of `region` shaded as `field`: every part hatched at the rung `rung(darkness)` gives it —
/// (number of crossing families 0–3, spacing in mm) — lines at `angle_deg` and then [`FAMILY_TURNS`]. A
/// gradient's bands are at least `min_band_mm` wide along it (see [`MIN_BAND_PENS`]). Circles of radial gradients
/// are drawn as polygons within `tolerance_mm`. `None` when some band would take more than
/// [`super::hatch::MAX_LINES`] lines.
pub fn tone_hatch(
    region: &Region,
    field: &ToneField,
    angle_deg: f64,
    tolerance_mm: f64,
    min_band_mm: f64,
    rung: &dyn Fn(f64) -> (u8, f64),
) -> Option<Vec<Vec<Point>>> {
    let Some(bbox) = region.bbox() else { return Some(Vec::new()) };
    let mut out = Vec::new();
    match field {
        ToneField::Flat(d) => out.extend(hatch_at(region, region, *d, angle_deg, rung)?),
        ToneField::Gradient(g) => {
            let Some(geo) = Geometry::new(g, bbox, tolerance_mm) else {
                // A degenerate gradient (zero length or radius) paints its last colour.
                let d = g.darkness.last().copied().unwrap_or(0.0);
                return hatch_at(region, region, d, angle_deg, rung);
            };
            let min_dt = min_band_mm / geo.page_len;
            for band in bands(&g.darkness, g.spread, geo.t_min, geo.t_max, geo.t_floor, min_dt) {
                if band.darkness < PAPER {
                    continue;
                }
                let part = match (band.lo, band.hi) {
                    (None, None) => region.clone(),
                    (lo, hi) => region.intersect(&geo.band_region(lo, hi)),
                };
                if !part.is_empty() {
                    out.extend(hatch_at(&part, region, band.darkness, angle_deg, rung)?);
                }
            }
        }
    }
    Some(out)
}

/// The tone hatch of an area made of `parts` of their own flat darkness each (a blend's bands, see
/// `input::svg::walk::blend`): each hatched at its rung as [`tone_hatch`] hatches a gradient's band, its lines
/// joined only along `whole`'s edges, not along the cuts between parts. One part is hatched as the whole.
/// `None` when some part would take more than [`super::hatch::MAX_LINES`] lines.
pub fn tone_hatch_parts(
    whole: &Region,
    parts: &[(Region, f64)],
    angle_deg: f64,
    rung: &dyn Fn(f64) -> (u8, f64),
) -> Option<Vec<Vec<Point>>> {
    if let [(only, d)] = parts {
        return hatch_at(only, only, *d, angle_deg, rung);
    }
    let mut out = Vec::new();
    for (part, d) in parts {
        if !part.is_empty() {
            out.extend(hatch_at(part, whole, *d, angle_deg, rung)?);
        }
    }
    Some(out)
}

/// `part` of `region` hatched at the rung of one darkness, its lines joined only along `region`'s edges.
fn hatch_at(
    part: &Region,
    region: &Region,
    darkness: f64,
    angle_deg: f64,
    rung: &dyn Fn(f64) -> (u8, f64),
) -> Option<Vec<Vec<Point>>> {
    if darkness < PAPER {
        return Some(Vec::new());
    }
    let (families, spacing_mm) = rung(darkness);
    let mut out = Vec::new();
    if !(spacing_mm.is_finite() && spacing_mm > 0.0) {
        return Some(out);
    }
    for turn in FAMILY_TURNS.iter().take(usize::from(families)) {
        let h = FillHatch { spacing_mm, angle_deg: angle_deg + turn, cross: false, link: true };
        out.extend(if std::ptr::eq(part, region) { hatch(region, &h)? } else { hatch_part(part, region, &h)? });
    }
    Some(out)
}

/// The darkness samples cut into bands of at most [`BAND_STEP`] (but no narrower than `min_dt` of `t`), laid along
/// `t` over `t_min..t_max` by the spread; `t_floor` is the least `t` the gradient has (0 for a radial one, whose
/// inside of the focal circle pads the first colour).
fn bands(samples: &[f64], spread: Spread, t_min: f64, t_max: f64, t_floor: Option<f64>, min_dt: f64) -> Vec<Band> {
    // Runs of samples within one step of darkness: (s from, s to, mean darkness) over 0..1.
    let mut runs: Vec<(f64, f64, f64)> = Vec::new();
    let n = samples.len();
    if n <= 1 {
        runs.push((0.0, 1.0, samples.first().copied().unwrap_or(0.0)));
    } else {
        #[allow(clippy::cast_precision_loss)]
        let s_of = |i: usize| i as f64 / (n - 1) as f64;
        let mut start = 0;
        for i in 1..=n {
            let lo = samples[start..i.min(n)].iter().copied().fold(f64::MAX, f64::min);
            let hi = samples[start..i.min(n)].iter().copied().fold(f64::MIN, f64::max);
            let wide = s_of(i) - s_of(start) >= min_dt;
            let breaks = i == n || (wide && samples[i].max(hi) - samples[i].min(lo) > BAND_STEP);
            if breaks {
                let from = if start == 0 { 0.0 } else { (s_of(start - 1) + s_of(start)) / 2.0 };
                let to = if i == n { 1.0 } else { (s_of(i - 1) + s_of(i)) / 2.0 };
                #[allow(clippy::cast_precision_loss)]
                let mean = samples[start..i].iter().sum::<f64>() / (i - start) as f64;
                runs.push((from, to, mean));
                start = i;
            }
        }
    }
    let mut out: Vec<Band> = Vec::new();
    let mut push = |lo: Option<f64>, hi: Option<f64>, darkness: f64| {
        if let (Some(a), Some(b)) = (lo, hi)
            && b <= a
        {
            return;
        }
        // Neighbours of one darkness (across a period's edge) become one band.
        if let Some(last) = out.last_mut()
            && last.darkness == darkness
            && last.hi == lo
        {
            last.hi = hi;
            return;
        }
        out.push(Band { lo, hi, darkness });
    };
    let floor = |t: f64| t_floor.map_or(t, |f| t.max(f));
    match spread {
        Spread::Pad => {
            let last = runs.len() - 1;
            for (i, &(a, b, d)) in runs.iter().enumerate() {
                let lo = if i == 0 { None } else { Some(a) };
                let hi = if i == last { None } else { Some(b) };
                push(lo, hi, d);
            }
        }
        Spread::Reflect | Spread::Repeat => {
            let first = floor(t_min).floor();
            let mut k = first;
            let mut count = 0usize;
            while k <= t_max && count < MAX_BANDS {
                // Whole periods only: k is an integer-valued float.
                #[allow(clippy::cast_possible_truncation)]
                let odd = spread == Spread::Reflect && (k as i64).rem_euclid(2) == 1;
                let ordered: Vec<(f64, f64, f64)> = if odd {
                    runs.iter().rev().map(|&(a, b, d)| (k + 1.0 - b, k + 1.0 - a, d)).collect()
                } else {
                    runs.iter().map(|&(a, b, d)| (k + a, k + b, d)).collect()
                };
                for (a, b, d) in ordered {
                    if b < t_min || a > t_max {
                        continue;
                    }
                    push(Some(a), Some(b), d);
                    count += 1;
                }
                k += 1.0;
            }
            // The ends reach past the shape: open them so no sliver is left at the edge.
            if let Some(f) = out.first_mut() {
                f.lo = None;
            }
            if let Some(l) = out.last_mut() {
                l.hi = None;
            }
        }
    }
    out
}

/// A gradient's geometry set up for one shape: the `t` range over the shape and how to draw a band.
struct Geometry {
    shape: GradientShape,
    to_page: Affine,
    /// The shape's bounding box in gradient coordinates (grown a little).
    local_box: Rect,
    t_min: f64,
    t_max: f64,
    /// Radial gradients have no `t` below 0.
    t_floor: Option<f64>,
    /// Page millimetres per unit of `t`, about (along a linear gradient; a radial one's radius).
    page_len: f64,
    tolerance_mm: f64,
}

impl Geometry {
    /// `None` for a degenerate gradient (zero length, zero radius, or a transform that cannot be undone).
    fn new(g: &GradientField, page_box: Rect, tolerance_mm: f64) -> Option<Geometry> {
        if g.to_page.determinant().abs() < 1e-18 {
            return None;
        }
        let inv = g.to_page.inverse();
        let shape = match g.shape {
            GradientShape::Linear { from, to } if (to - from).hypot2() > 1e-18 => g.shape,
            GradientShape::Linear { .. } => return None,
            GradientShape::Radial { center, radius, focus, focal_radius } => {
                if radius.is_nan() || radius <= 0.0 || focal_radius >= radius {
                    return None;
                }
                // The focus must lie inside the outer circle for the rings to nest: pull it in, as SVG 1.1 does.
                let room = 0.99 * (radius - focal_radius);
                let off = focus - center;
                let focus = if off.hypot() > room { center + off * (room / off.hypot()) } else { focus };
                GradientShape::Radial { center, radius, focus, focal_radius }
            }
        };
        let local_box = inv.transform_rect_bbox(page_box);
        let pad = 0.01 * (local_box.width() + local_box.height()) + 1e-9;
        let local_box = local_box.inflate(pad, pad);
        let mut geo = Geometry {
            shape,
            to_page: g.to_page,
            local_box,
            t_min: f64::MAX,
            t_max: f64::MIN,
            t_floor: None,
            page_len: 1.0,
            tolerance_mm,
        };
        let [a, b, c, d, _, _] = g.to_page.as_coeffs();
        geo.page_len = match shape {
            GradientShape::Linear { from, to } => (g.to_page * to - g.to_page * from).hypot(),
            // The geometric mean of the ellipse's two radii.
            GradientShape::Radial { radius, focal_radius, .. } => {
                (radius - focal_radius) * (a * d - b * c).abs().sqrt()
            }
        }
        .max(1e-9);
        match shape {
            GradientShape::Linear { .. } => {
                for c in corners(local_box) {
                    let t = geo.t_at(c);
                    geo.t_min = geo.t_min.min(t);
                    geo.t_max = geo.t_max.max(t);
                }
            }
            GradientShape::Radial { .. } => {
                // t is not linear: sample the box (its largest value lies on the edge, its least may be inside).
                const N: u32 = 24;
                for i in 0..=N {
                    for j in 0..=N {
                        let (u, v) = (f64::from(i) / f64::from(N), f64::from(j) / f64::from(N));
                        let p = Point::new(local_box.x0 + u * local_box.width(), local_box.y0 + v * local_box.height());
                        let t = geo.t_at(p);
                        geo.t_min = geo.t_min.min(t);
                        geo.t_max = geo.t_max.max(t);
                    }
                }
                geo.t_min = (geo.t_min - 0.05 * (geo.t_max - geo.t_min)).max(0.0);
                geo.t_floor = Some(0.0);
            }
        }
        Some(geo)
    }

    /// The gradient parameter at a point in gradient coordinates.
    fn t_at(&self, p: Point) -> f64 {
        match self.shape {
            GradientShape::Linear { from, to } => {
                let v = to - from;
                (p - from).dot(v) / v.hypot2()
            }
            GradientShape::Radial { center, radius, focus, focal_radius } => {
                // |p − F − t·D| = fr + t·dr, D = C − F, dr = R − fr: a quadratic in t; the larger root.
                let d = center - focus;
                let dr = radius - focal_radius;
                let q = p - focus;
                let a = d.hypot2() - dr * dr;
                let b = q.dot(d) + focal_radius * dr;
                let c = q.hypot2() - focal_radius * focal_radius;
                // a < 0 since the focus lies inside the outer circle (see `new`).
                let disc = (b * b - a * c).max(0.0);
                (b - disc.sqrt()) / a
            }
        }
    }

    /// The part of the page where `t` lies between `lo` and `hi` (`None`: unbounded), in page mm.
    fn band_region(&self, lo: Option<f64>, hi: Option<f64>) -> Region {
        let contours: Vec<Vec<Point>> = match self.shape {
            GradientShape::Linear { from, to } => {
                let v = to - from;
                let n = Vec2::new(-v.y, v.x) / v.hypot();
                let (mut u0, mut u1) = (f64::MAX, f64::MIN);
                for c in corners(self.local_box) {
                    let u = (c - from).dot(n);
                    u0 = u0.min(u);
                    u1 = u1.max(u);
                }
                let t0 = lo.unwrap_or(self.t_min - 1.0);
                let t1 = hi.unwrap_or(self.t_max + 1.0);
                let at = |t: f64, u: f64| self.to_page * (from + v * t + n * u);
                vec![vec![at(t0, u0), at(t1, u0), at(t1, u1), at(t0, u1)]]
            }
            GradientShape::Radial { .. } => {
                let outer = match hi {
                    Some(t) => self.circle(t),
                    None => corners(self.local_box).iter().map(|&c| self.to_page * c).collect(),
                };
                let mut c = vec![outer];
                if let Some(t) = lo.filter(|&t| t > 0.0 || self.focal_radius() > 0.0) {
                    c.push(self.circle(t.max(0.0)));
                }
                c
            }
        };
        Region::from_contours(contours.iter().map(Vec::as_slice), FillRule::EvenOdd)
    }

    fn focal_radius(&self) -> f64 {
        match self.shape {
            GradientShape::Radial { focal_radius, .. } => focal_radius,
            GradientShape::Linear { .. } => 0.0,
        }
    }

    /// The circle of a radial gradient at `t`, as a polygon in page mm within the tolerance.
    fn circle(&self, t: f64) -> Vec<Point> {
        let GradientShape::Radial { center, radius, focus, focal_radius } = self.shape else { return Vec::new() };
        let c = focus + (center - focus) * t;
        let r = focal_radius + (radius - focal_radius) * t;
        // The longest a unit vector grows on the page bounds the ellipse's radius there.
        let [a, b, cc, d, _, _] = self.to_page.as_coeffs();
        let grow = ((a * a + b * b + cc * cc + d * d).sqrt()).max(1e-12);
        let r_page = r * grow;
        // A chord over an angle π/n strays r·π²/(2n²) from the arc.
        let n = (std::f64::consts::PI * (r_page / (2.0 * self.tolerance_mm.max(1e-6))).sqrt()).ceil();
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let n = (n as usize).clamp(16, 2048);
        (0..n)
            .map(|i| {
                #[allow(clippy::cast_precision_loss)]
                let a = std::f64::consts::TAU * i as f64 / n as f64;
                self.to_page * (c + Vec2::new(a.cos(), a.sin()) * r)
            })
            .collect()
    }
}

fn corners(r: Rect) -> [Point; 4] {
    [Point::new(r.x0, r.y0), Point::new(r.x1, r.y0), Point::new(r.x1, r.y1), Point::new(r.x0, r.y1)]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn total(lines: &[Vec<Point>]) -> f64 {
        lines.iter().flat_map(|l| l.windows(2)).map(|w| w[0].distance(w[1])).sum()
    }

    /// A made-up ladder: one family at 1/d mm up to 0.5, two at 1 mm above it.
    fn rung(d: f64) -> (u8, f64) {
        if d <= 0.0 {
            (0, f64::INFINITY)
        } else if d <= 0.5 {
            (1, 0.5 / d)
        } else {
            (2, 1.0)
        }
    }

    fn square(x: f64, y: f64, s: f64) -> Vec<Point> {
        vec![Point::new(x, y), Point::new(x + s, y), Point::new(x + s, y + s), Point::new(x, y + s)]
    }

    #[test]
    fn a_flat_tone_hatches_at_its_rung_and_paper_stays_empty() {
        // 10 × 10 square from (0.5, 0.5), angle 0: darkness 0.25 → one family at 2 mm: lines y = 2, 4, 6, 8, 10,
        // 5 × 10 mm plus 4 links of 2 mm = 58 mm in one zig-zag.
        let r = Region::from_contours([square(0.5, 0.5, 10.0).as_slice()], FillRule::NonZero);
        let lines = tone_hatch(&r, &ToneField::Flat(0.25), 0.0, 0.01, 2.0, &rung).unwrap();
        assert_eq!(lines.len(), 1);
        assert!((total(&lines) - 58.0).abs() < 1e-6, "{}", total(&lines));
        // Darkness 0.8 → two families at 1 mm: 10 + 10 lines of 10 mm and 9 + 9 links of 1 mm.
        let lines = tone_hatch(&r, &ToneField::Flat(0.8), 0.0, 0.01, 2.0, &rung).unwrap();
        assert!((total(&lines) - 218.0).abs() < 1e-6, "{}", total(&lines));
        assert!(tone_hatch(&r, &ToneField::Flat(0.0), 0.0, 0.01, 2.0, &rung).unwrap().is_empty());
    }

    #[test]
    fn a_linear_gradient_varies_the_spacing_along_it() {
        // 0..40 × 0..10 with a gradient along x from darkness 0 to 0.5, vertical lines (90°). Each band is at most
        // 1/32 of darkness: the band around x has lines 0.5/d(x) apart, so the left quarter gets far fewer lines
        // than the right quarter: count the lines' x positions.
        let r = Region::rect(Rect::new(0.0, 0.0, 40.0, 10.0));
        let darkness: Vec<f64> = (0..=64).map(|i| 0.5 * f64::from(i) / 64.0).collect();
        let field = ToneField::Gradient(GradientField {
            shape: GradientShape::Linear { from: Point::new(0.0, 0.0), to: Point::new(40.0, 0.0) },
            to_page: Affine::IDENTITY,
            spread: Spread::Pad,
            darkness,
        });
        let lines = tone_hatch(&r, &field, 90.0, 0.01, 2.0, &|d| rung(d)).unwrap();
        let mut xs: Vec<f64> = lines.iter().flatten().map(|p| p.x).collect();
        xs.sort_by(f64::total_cmp);
        xs.dedup_by(|a, b| (*a - *b).abs() < 1e-6);
        let count = |a: f64, b: f64| xs.iter().filter(|&&x| x > a && x < b).count();
        // Over 30..40 the darkness is 0.375..0.5: spacing 1.0..1.33 mm, about 8–10 lines; over 2..10 it is
        // 0.025..0.125, spacing 4..20 mm: at most 3.
        let (light, dark) = (count(2.0, 10.0), count(30.0, 40.0));
        assert!(dark >= 7 && light <= 3, "light {light}, dark {dark}");
        // Nothing at the paper end (x < 0.4 is darkness < 1/200 of the way, the first band's mean is tiny but
        // its spacing is wider than the shape).
        assert!(count(0.0, 0.3) == 0);
    }

    #[test]
    fn a_radial_gradient_is_hatched_in_rings() {
        // A disc gradient, dark (0.5) at the centre to paper at radius 10, over a 20 × 20 square: far corners
        // (t > 1, padded paper) stay empty, the centre is hatched densely.
        let r = Region::rect(Rect::new(-10.0, -10.0, 10.0, 10.0));
        let darkness: Vec<f64> = (0..=64).map(|i| 0.5 * (1.0 - f64::from(i) / 64.0)).collect();
        let field = ToneField::Gradient(GradientField {
            shape: GradientShape::Radial {
                center: Point::ORIGIN,
                radius: 5.0,
                focus: Point::ORIGIN,
                focal_radius: 0.0,
            },
            to_page: Affine::scale(2.0),
            spread: Spread::Pad,
            darkness,
        });
        let lines = tone_hatch(&r, &field, 0.0, 0.01, 2.0, &rung).unwrap();
        assert!(!lines.is_empty());
        for p in lines.iter().flatten() {
            assert!(p.to_vec2().hypot() <= 10.0 + 0.02, "ink at {p:?}, outside the gradient's circle");
        }
    }

    #[test]
    fn repeat_and_reflect_lay_periods_side_by_side() {
        // Samples 0.1 → 0.4 (two steps of more than 1/32: several runs); repeated over t = 0..3.
        let s: Vec<f64> = (0..=8).map(|i| 0.1 + 0.3 * f64::from(i) / 8.0).collect();
        let rep = bands(&s, Spread::Repeat, 0.0, 3.0, None, 0.0);
        let refl = bands(&s, Spread::Reflect, 0.0, 3.0, None, 0.0);
        // Repeat: every period starts light; reflect: the second period runs dark to light, so the darkest bands
        // of periods one and two meet and merge into one.
        assert!(refl.len() < rep.len(), "{} vs {}", refl.len(), rep.len());
        assert_eq!(rep.first().unwrap().lo, None);
        assert_eq!(rep.last().unwrap().hi, None);
        let pad = bands(&s, Spread::Pad, -5.0, 5.0, None, 0.0);
        assert_eq!((pad.first().unwrap().lo, pad.last().unwrap().hi), (None, None));
        for w in pad.windows(2) {
            assert_eq!(w[0].hi, w[1].lo);
            assert!((w[1].darkness - w[0].darkness) > 0.0);
        }
    }
}
