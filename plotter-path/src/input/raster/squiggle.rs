//! Squiggle style: the picture as rows of zig-zag waves whose amplitude, then frequency, grow with darkness; each
//! row is one stroke, broken only where the picture is paper.
//!
//! Rows are `row` apart. A zig-zag of peak amplitude `A` and wavelength `λ` is `√(1 + (4A/λ)²)` times as long as
//! the row, so with pen width `w` it covers `w · √(1 + (4A/λ)²) / row` of the row's band, as long as its legs do
//! not overlap. For a target darkness `d` the length factor is `L = d · row / w`; lighter tones keep the longest
//! wave (`λ = 2·row`) and grow the amplitude `A = λ/4 · √(L² − 1)`.
//!
//! Darker tones ([`wave_for`] past [`full_band_coverage`] of the longest wave) fill the band (`A = row/2`) and
//! shorten the wavelength. There the legs overlap near every peak, and the length factor would overstate the ink
//! (at mid-gray it asked for 0.82 and drew 0.65, L* 10 too light). Counted exactly instead: at a height in the band
//! the two legs around a peak cross it `s` apart, `s` running evenly from 0 at the peak to `λ` at the opposite
//! peak, and each leg inks a width `h·λ` of the line (`h·λ = w · √((λ/2)² + row²) / row`, the pen's width seen
//! along a leg of that slope); the two legs together ink `min(h·λ, s) + min(h·λ, λ − s)` of each wavelength, which
//! averages to `1 − (1 − h)²` over the band ([`full_band_coverage`]). That leaves out the round peaks reaching a
//! pen's radius into the neighbour rows and the joins (at mid-gray still 0.03 short, L* 4 too dark), so [`Waves`]
//! measures the coverage instead: one wavelength of three neighbouring rows sampled on a 64 × 64 grid, for 48
//! wavelengths from legs touching (`h = 1`, `λ = w / √(1 − (w / 2row)²)`, black) to the longest, and reads the
//! wavelength for a darkness off that table.
//!
//! A tone lighter than half a flat line's coverage is paper. Waves never reach onto paper: a half wave stops at the
//! first paper column it meets, and each peak stays on the inked pixels of its column (so a shape's edge is drawn
//! to within the pen's half width).

use super::tone::DarknessMap;
use kurbo::Point;

/// The coverage `1 − (1 − h)²` of a zig-zag filling its row's band (`A = row/2`) with wavelength `lambda`, pen
/// `pen`, rows `row` apart (any unit), counting its legs only: `h = pen · √((λ/2)² + row²) / (row · λ)`, at most 1.
pub fn full_band_coverage(lambda: f64, pen: f64, row: f64) -> f64 {
    let h = (pen * ((lambda / 2.0).powi(2) + row * row).sqrt() / (row * lambda)).min(1.0);
    1.0 - (1.0 - h) * (1.0 - h)
}

/// The ink of a band-filling zig-zag (rows `row` apart, all in phase, pen `pen`) with wavelength `lambda`, as
/// rendered: the fraction of one wavelength × row tile within the pen's radius of its own row's or a neighbour
/// row's wave, sampled at 64 × 64 points.
pub fn measured_coverage(lambda: f64, pen: f64, row: f64) -> f64 {
    const N: u32 = 64;
    let segments = zigzag_segments(lambda, row, &[-1.0, 0.0, 1.0]);
    let r2 = pen * pen / 4.0;
    let mut inked = 0u32;
    for i in 0..N {
        for j in 0..N {
            let p = Point::new((f64::from(i) + 0.5) / f64::from(N) * lambda, (f64::from(j) + 0.5) / f64::from(N) * row);
            inked += u32::from(within(&segments, p, r2));
        }
    }
    f64::from(inked) / f64::from(N * N)
}

/// The legs of band-filling zig-zags of wavelength `lambda` (amplitude half the row pitch `row`), three
/// wavelengths of each row whose band is `k` rows below the first band, for each `k` of `rows`: each leg as its
/// start and its vector.
fn zigzag_segments(lambda: f64, row: f64, rows: &[f64]) -> Vec<(Point, kurbo::Vec2)> {
    let a = row / 2.0;
    let mut segments = Vec::new();
    for k in rows {
        let yc = row / 2.0 + k * row;
        for m in [-1.0, 0.0, 1.0] {
            let x0 = m * lambda;
            let pts = [
                Point::new(x0, yc),
                Point::new(x0 + lambda / 4.0, yc - a),
                Point::new(x0 + lambda / 2.0, yc),
                Point::new(x0 + 3.0 * lambda / 4.0, yc + a),
                Point::new(x0 + lambda, yc),
            ];
            segments.extend(pts.windows(2).map(|w| (w[0], w[1] - w[0])));
        }
    }
    segments
}

/// Whether `p` lies within the squared distance `r2` of one of `segments` (a pen of radius √r2 drawing them).
fn within(segments: &[(Point, kurbo::Vec2)], p: Point, r2: f64) -> bool {
    segments.iter().any(|&(o, d)| {
        let t = ((p - o).dot(d) / d.hypot2()).clamp(0.0, 1.0);
        (o + d * t - p).hypot2() <= r2
    })
}

/// The ink of band-filling zig-zags as [`measured_coverage`] counts it, except that each neighbour row's wave has a
/// phase of its own, evenly spread over the wavelength (as the spiral's turns do: each turn's length is no whole
/// number of wavelengths). Averaged over those phases a neighbour covers a point at height `y` of the band with the
/// probability `f(y)`: the fraction of its own wavelength its ink covers at that height. The two neighbours are
/// independent, so the paper left at a point is `(1 − own) · (1 − f_above(y)) · (1 − f_below(y))`, averaged over
/// one wavelength × row tile sampled at 64 × 64 points. In phase, the peaks of neighbouring rows nest beside each
/// other; out of phase they land on each other's legs half the time, so the same wave inks less (at mid-gray,
/// pen 1 on rows 3, 0.02 less) and a darkness needs a shorter wave.
pub fn measured_coverage_unphased(lambda: f64, pen: f64, row: f64) -> f64 {
    const N: u32 = 64;
    let segments = zigzag_segments(lambda, row, &[0.0]);
    let r2 = pen * pen / 4.0;
    let hit = |p: Point| within(&segments, p, r2);
    let mut paper = 0.0;
    for j in 0..N {
        let y = (f64::from(j) + 0.5) / f64::from(N) * row;
        // The row's own ink along this height, and its neighbours' share of it (a row above sees this height as
        // `y + row` of its own band, a row below as `y − row`).
        let (mut bare, mut above, mut below) = (0u32, 0u32, 0u32);
        for i in 0..N {
            let x = (f64::from(i) + 0.5) / f64::from(N) * lambda;
            bare += u32::from(!hit(Point::new(x, y)));
            above += u32::from(hit(Point::new(x, y + row)));
            below += u32::from(hit(Point::new(x, y - row)));
        }
        let n = f64::from(N);
        let open = (1.0 - f64::from(above) / n) * (1.0 - f64::from(below) / n);
        paper += f64::from(bare) * open;
    }
    1.0 - paper / f64::from(N * N)
}

/// The waves for one pen and row pitch: which amplitude and wavelength draw a darkness.
#[derive(Debug, Clone, PartialEq)]
pub struct Waves {
    pen: f64,
    row: f64,
    /// Measured `(wavelength, coverage)` of band-filling waves, from the shortest wavelength (darkest) up.
    table: Vec<(f64, f64)>,
}

impl Waves {
    /// Measure the band-filling waves of pen `pen` and rows `row` apart (pixels).
    pub fn new(pen: f64, row: f64) -> Waves {
        Waves::measured(pen, row, measured_coverage)
    }

    /// Measure the band-filling waves of pen `pen` and rows `row` apart (pixels) whose neighbouring rows are not in
    /// phase ([`measured_coverage_unphased`]): the spiral's turns.
    pub fn unphased(pen: f64, row: f64) -> Waves {
        Waves::measured(pen, row, measured_coverage_unphased)
    }

    fn measured(pen: f64, row: f64, measure: fn(f64, f64, f64) -> f64) -> Waves {
        let longest = 2.0 * row;
        let q = pen / (2.0 * row);
        let shortest = (pen / (1.0 - q * q).max(f64::MIN_POSITIVE).sqrt()).min(longest);
        let steps = 48;
        let table = (0..=steps)
            .map(|i| {
                let lambda = shortest * (longest / shortest).powf(f64::from(i) / f64::from(steps));
                (lambda, measure(lambda, pen, row))
            })
            .collect();
        Waves { pen, row, table }
    }

    /// The amplitude and wavelength (pixels) for a darkness; `None` for paper.
    pub fn wave(&self, darkness: f64) -> Option<(f64, f64)> {
        let (pen, row) = (self.pen, self.row);
        if darkness.is_nan() || !(row > 0.0 && pen > 0.0) || darkness < pen / row / 2.0 {
            return None;
        }
        let d = darkness.min(1.0);
        let longest = 2.0 * row;
        let &(_, lightest) = self.table.last()?;
        if d <= lightest {
            // The length rule: the legs rarely overlap yet (where the wave fills the band it asks 0.354 of a
            // 1 px pen on 4 px rows, the table measures 0.347).
            let l = (d * row / pen).max(1.0);
            let a = longest / 4.0 * (l * l - 1.0).sqrt();
            return Some((a.min(row / 2.0), longest));
        }
        // Coverage falls as the wavelength grows: the first entry no darker than `d`, interpolated.
        let i = self.table.partition_point(|&(_, c)| c > d);
        if i == 0 {
            return Some((row / 2.0, self.table[0].0));
        }
        let ((l0, c0), (l1, c1)) = (self.table[i - 1], self.table[i]);
        let t = if c0 > c1 { (c0 - d) / (c0 - c1) } else { 0.0 };
        Some((row / 2.0, l0 + (l1 - l0) * t))
    }
}

/// The amplitude and wavelength (pixels) for a darkness, with pen width `pen` and row pitch `row` (pixels);
/// `None` for paper. Measures the waves each call: tracing builds one [`Waves`] instead.
pub fn wave_for(darkness: f64, pen: f64, row: f64) -> Option<(f64, f64)> {
    Waves::new(pen, row).wave(darkness)
}

/// The squiggle strokes of a darkness map, pixel coordinates: rows `row` pixels apart, pen `pen` pixels wide.
pub fn squiggle(map: &DarknessMap, pen: f64, row: f64) -> Vec<Vec<Point>> {
    let mut out = Vec::new();
    if !(row.is_finite() && row > 0.0 && pen > 0.0) || map.width == 0 || map.height == 0 {
        return out;
    }
    let waves = Waves::new(pen, row);
    let wave_for = |d: f64, _: f64, _: f64| waves.wave(d);
    #[allow(clippy::cast_precision_loss)]
    let (w, h) = (map.width as f64, map.height as f64);
    // The mean darkness across the row's band at column x.
    let band = |x: f64, y: f64| -> f64 {
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let (xi, y0, y1) =
            (x.floor().max(0.0) as usize, (y - row / 2.0).floor().max(0.0) as usize, (y + row / 2.0).ceil() as usize);
        let y1 = y1.clamp(y0 + 1, map.height);
        let sum: f64 = (y0..y1).map(|yy| f64::from(map.at(xi.min(map.width - 1), yy))).sum();
        #[allow(clippy::cast_precision_loss)]
        let n = (y1 - y0) as f64;
        sum / n
    };
    let paper = |x: f64, y: f64| -> bool {
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let (xi, yi) = (x.floor().max(0.0) as usize, y.floor().max(0.0) as usize);
        map.at(xi.min(map.width - 1), yi.min(map.height - 1)) <= 0.0
    };
    // The first paper column's left edge in `(x, nx)`, where a half wave must stop.
    let paper_from = |x: f64, nx: f64, y: f64| -> Option<f64> {
        let mut c = x.floor() + 1.0;
        while c < nx {
            if wave_for(band(c, y), pen, row).is_none() {
                return Some(c);
            }
            c += 1.0;
        }
        None
    };
    // How far from the row's line (at `y`) towards `dir` (±1) a peak at column `x` may reach: up to `a`, but not
    // past the last inked pixel.
    let reach = |x: f64, y: f64, a: f64, dir: f64| -> f64 {
        let mut t = 0.0;
        while t < a {
            let next = (t + 0.5).min(a);
            if paper(x, y + dir * next) {
                return t;
            }
            t = next;
        }
        a
    };
    let mut y = row / 2.0;
    while y + row / 2.0 <= h + 1e-9 {
        let mut stroke: Vec<Point> = Vec::new();
        let mut x = 0.0;
        let mut up = true;
        while x < w {
            match wave_for(band(x, y), pen, row) {
                None => {
                    if stroke.len() >= 2 {
                        out.push(std::mem::take(&mut stroke));
                    }
                    stroke.clear();
                    x += 0.5;
                }
                Some((a, lambda)) => {
                    if stroke.is_empty() {
                        stroke.push(Point::new(x, y));
                    }
                    let nx = (x + lambda / 2.0).min(w);
                    // A peak in the middle of each half wave, back on the row's line at its end.
                    let mid = (x + nx) / 2.0;
                    let dir = if up { -1.0 } else { 1.0 };
                    let peak = Point::new(mid, y + dir * reach(mid, y, a, dir));
                    let end = Point::new(nx, y);
                    up = !up;
                    match paper_from(x, nx, y) {
                        // Paper ahead: the half wave is cut where it begins.
                        Some(xp) => {
                            let from = *stroke.last().unwrap_or(&Point::new(x, y));
                            if xp > mid {
                                stroke.push(peak);
                                stroke.push(peak.lerp(end, (xp - mid) / (nx - mid)));
                            } else if xp > from.x {
                                stroke.push(from.lerp(peak, (xp - from.x) / (mid - from.x)));
                            }
                            if stroke.len() >= 2 {
                                out.push(std::mem::take(&mut stroke));
                            }
                            stroke.clear();
                            x = xp;
                        }
                        None => {
                            stroke.push(peak);
                            stroke.push(end);
                            x = nx;
                        }
                    }
                }
            }
        }
        if stroke.len() >= 2 {
            out.push(stroke);
        }
        y += row;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::raster::ink::InkGrid;

    fn length(s: &[Point]) -> f64 {
        s.windows(2).map(|w| w[0].distance(w[1])).sum()
    }

    #[test]
    fn waves_grow_then_tighten() {
        // Pen 1, rows 4: a flat line covers 0.25, paper below 0.125.
        assert_eq!(wave_for(0.1, 1.0, 4.0), None);
        assert_eq!(wave_for(0.25, 1.0, 4.0), Some((0.0, 8.0)));
        // The longest wave filling the band, legs only: h = √(4² + 4²) / (4 · 8) = 0.17678, 1 − 0.82322² = 0.32230;
        // at λ = 4, h = √(4 + 16) / 16 = 0.27951, 1 − 0.72049² = 0.48090.
        assert!((full_band_coverage(8.0, 1.0, 4.0) - 0.322_30).abs() < 1e-5);
        assert!((full_band_coverage(4.0, 1.0, 4.0) - 0.480_90).abs() < 1e-5);
        // Measured, the peaks' round ends and the joins add to that: 0.347 and 0.534 (a 160 × 160 sampling);
        // legs touching (λ = 1 / √(1 − 1/64) = 1.00791) ink everything.
        // (64 × 64 samples are within 0.01 of those.)
        assert!((measured_coverage(8.0, 1.0, 4.0) - 0.347).abs() < 0.01);
        assert!((measured_coverage(4.0, 1.0, 4.0) - 0.534).abs() < 0.01);
        assert!(measured_coverage(1.007_905, 1.0, 4.0) > 0.995);
        // Darkness 0.3 is lighter than the band-filling wave: L = 1.2, √0.44 → A = 2·0.6633 = 1.327, λ = 8.
        let (a, l) = wave_for(0.3, 1.0, 4.0).unwrap();
        assert!((a - 2.0 * 0.44f64.sqrt()).abs() < 1e-12 && l == 8.0);
        // Darkness 0.534 fills the band at λ = 4 (within the table's interpolation).
        let (a, l) = wave_for(0.534, 1.0, 4.0).unwrap();
        assert!(a == 2.0 && (l - 4.0).abs() < 0.1, "{l}");
        // Black: legs touching.
        let (a, l) = wave_for(1.0, 1.0, 4.0).unwrap();
        assert!(a == 2.0 && (l - 1.007_905).abs() < 0.05, "{l}");
    }

    #[test]
    fn white_is_empty_and_a_flat_gray_gets_its_ink() {
        let white = DarknessMap { width: 40, height: 40, data: vec![0.0; 1600] };
        assert!(squiggle(&white, 1.0, 4.0).is_empty());
        // Darkness 0.3 over 200 × 200 px, pen 1, rows 4: 50 rows, each one stroke whose length is
        // 200 · 0.3 · 4 / 1 = 240 px (the length factor times the row).
        let gray = DarknessMap { width: 200, height: 200, data: vec![0.3; 40_000] };
        let s = squiggle(&gray, 1.0, 4.0);
        assert_eq!(s.len(), 50);
        for st in &s {
            assert!((length(st) - 240.0).abs() < 4.0, "{}", length(st));
            assert!(st.iter().all(|p| (0.0..=200.0).contains(&p.x) && (0.0..=200.0).contains(&p.y)));
        }
        // Rendered, from light to black: the ink fraction is the darkness (caps and the neighbour rows' peaks add
        // a little ink the band count leaves out).
        for d in [0.3f32, 0.6, 0.8, 0.95, 1.0] {
            let s = squiggle(&DarknessMap { width: 200, height: 200, data: vec![d; 40_000] }, 1.0, 4.0);
            let mut grid = InkGrid::new(1000, 1000, 0.2);
            grid.draw(&s, 1.0);
            let f = grid.fraction(100, 900, 100, 900);
            println!("darkness {d}: ink {f:.3}");
            assert!((f - f64::from(d)).abs() < 0.03, "darkness {d}: ink fraction {f}");
        }
    }

    #[test]
    fn waves_stop_at_the_paper() {
        // A dark square, columns and rows 20..60 of an 80 × 80 picture, rows 4 apart, pen 1: no stroke point
        // outside it, and rows 22, 26, …, 58 each cross it once.
        let map = DarknessMap {
            width: 80,
            height: 80,
            data: (0..6400)
                .map(|i| if (20..60).contains(&(i % 80)) && (20..60).contains(&(i / 80)) { 0.7 } else { 0.0 })
                .collect(),
        };
        let s = squiggle(&map, 1.0, 4.0);
        assert_eq!(s.len(), 10);
        for p in s.iter().flatten() {
            assert!((20.0..=60.0).contains(&p.x) && (20.0..=60.0).contains(&p.y), "{p:?}");
        }
    }
}
