//! Flow style: evenly spaced streamlines along the picture's structure, spaced by its tone (after Jobard and Lefer,
//! "Creating Evenly-Spaced Streamlines of Arbitrary Density", 1997).
//!
//! **Direction.** The lines follow the edge-tangent field: the structure tensor of the darkness gradient
//! (`gx², gx·gy, gy²`, each blurred with a Gaussian a few line spacings wide) has its strongest eigenvector across
//! the edges, so the lines run along them (along a face's contour, around a sphere). Where the picture is flat the
//! tensor is empty and a small bias turns the lines to the base angle.
//!
//! **Spacing.** Each point's (smoothed) darkness `d` asks for up to three families of lines: one along the field,
//! a second across it (+90°), a third at +45°, filled one after another ([`family_coverages`]): the first alone up
//! to the most one family covers at the closest spacing, then the second while the first stays there, then the
//! third, so that `1 − Π(1 − cₖ) = d` (the tone model's crossing rule) and every family's spacing `pen / cₖ` changes
//! smoothly with the tone. Past the three at the closest spacing (0.963 at the default spacing) they close in
//! together, up to 0.9 coverage each (0.999 together). Paper, and a family whose lines would be more than twenty
//! minimum spacings apart, stay white; no line enters a paper pixel of the picture itself (before smoothing).
//!
//! **Placement.** Each family is laid out on its own: a streamline is integrated both ways from a seed (midpoint
//! steps of at most 0.4 spacing) until it leaves the picture, reaches a lighter tone than its family draws, turns
//! sharply, or comes within 0.7 of the local spacing of a line already drawn; new seeds are tried one spacing to
//! either side of every finished line, and the picture is then scanned for places no line reached, and a seed
//! is taken where it is at least 0.7 spacings from every line. Where the field fans out or closes in, the spacing
//! between neighbouring lines thus stays between 0.7 and 1.7 local spacings, about evenly on either side of one.
//! (Lines stopping at 0.6 and seeds needing a whole spacing, 0.6 to 2 spacings, plotted a lightness ramp up to 7.7
//! L* off, too dark where lines closed in and too light where they fanned out; 0.7 and 0.7 plot it within 4.5 L*
//! but for its darkest end.)
//!
//! **Measured respacing.** The spacing the lines actually keep strays from the asked one (and is on average a little
//! wider), so the families after the first are not spaced from the tone alone: each is laid over the ink the ones
//! before it drew, measured on a fine grid and blurred over two closest spacings, and covers what turns that paper
//! into the paper the tone leaves through it (`Rungs::respace`). Two touch-up families (at 135° and 67.5°), where
//! the tone asks for all three, make up what the third left. A lightness ramp then plots within 1.3 L* along it
//! (was 4.5 too dark where the later families set in and 6.3 too light at the dark end, where the three families'
//! gaps met in holes).

use super::ink::InkGrid;
use super::tone::{DarknessMap, Ladder};
use kurbo::{Point, Vec2};

/// Turns between the families, degrees from the field's direction.
const FAMILY_TURNS: [f64; 5] = [0.0, 90.0, 45.0, 135.0, 67.5];
/// Tones whose line spacing would exceed this many minimum spacings are left as paper.
const MAX_SPACING_FACTOR: f64 = 20.0;
/// A streamline stops where it comes closer than this fraction of the local spacing to another line.
const TEST_FRACTION: f64 = 0.7;
/// A new streamline may start where it is at least this fraction of the local spacing from every line (it starts one
/// spacing from the line it grows from).
const SEED_CLEARANCE: f64 = 0.7;
/// The darkest tone flow draws: three families each covering 0.9 (`1 − 0.1³`), lines 1.11 pens apart.
const CLOSEST_DARKNESS: f64 = 0.999;
/// A streamline stops where its direction turns more than this in one step (a vortex or a saddle of the field).
const MAX_TURN_COS: f64 = 0.5;
/// The most a family respaced from the measured ink covers (lines 1.11 pens apart).
const CLOSEST_COVERAGE: f64 = 0.9;
/// The Gaussian over which the ink drawn so far is measured and compared with the tone, in closest spacings
/// (0.9 mm at the default 0.45 mm: about the eye's 1 mm at reading distance).
const MEASURE_SPACINGS: f64 = 2.0;

/// The structure tensor's three components (`xx`, `xy`, `yy`) per pixel, side by side so that one lookup reads all
/// three, read bilinearly between pixel centres.
struct TensorField {
    width: usize,
    height: usize,
    data: Vec<[f32; 3]>,
}

impl TensorField {
    /// Bilinear `[xx, xy, yy]` at `p` (pixel centres at half-integers), clamped at the borders.
    fn sample(&self, p: Point) -> [f64; 3] {
        #[allow(clippy::cast_precision_loss)]
        let (mx, my) = ((self.width - 1) as f64, (self.height - 1) as f64);
        let (x, y) = ((p.x - 0.5).clamp(0.0, mx), (p.y - 0.5).clamp(0.0, my));
        // Both are at least 0, where a cast truncates as floor does (and skips a call to the C library's floor).
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let (x0, y0) = (x as usize, y as usize);
        let (x1, y1) = ((x0 + 1).min(self.width - 1), (y0 + 1).min(self.height - 1));
        #[allow(clippy::cast_precision_loss)]
        let (fx, fy) = (x - x0 as f64, y - y0 as f64);
        let (a, b) = (self.data[y0 * self.width + x0], self.data[y0 * self.width + x1]);
        let (c, d) = (self.data[y1 * self.width + x0], self.data[y1 * self.width + x1]);
        std::array::from_fn(|j| {
            let top = f64::from(a[j]) * (1.0 - fx) + f64::from(b[j]) * fx;
            let bottom = f64::from(c[j]) * (1.0 - fx) + f64::from(d[j]) * fx;
            top * (1.0 - fy) + bottom * fy
        })
    }
}

/// `data` (`width × height`, row by row) blurred with a Gaussian of `sigma` pixels (unchanged below half a pixel).
///
/// The kernel and the order of the sums are imageproc's `gaussian_blur_f32` (taps out to `⌈2σ⌉`, normalised;
/// borders repeat the edge pixel; rows, then columns; each output the taps added left to right), so the result is
/// the same to the bit; but each pass adds one tap to a whole row at a time, which the compiler turns into vector
/// instructions: 10 blurs of a 1 MP picture took 0.28 s of flow's 1.7 s on the storm photo.
fn blur(width: usize, height: usize, data: Vec<f32>, sigma: f64) -> Vec<f32> {
    if sigma.is_nan() || sigma < 0.5 || width == 0 || height == 0 || data.len() != width * height {
        return data;
    }
    #[allow(clippy::cast_possible_truncation)] // a blur radius of a few pixels
    let sigma = sigma as f32;
    let kernel = gaussian_kernel(sigma);
    let r = kernel.len() / 2;
    // Rows: each padded with its edge pixels, then every tap added to the whole row.
    let mut rows = vec![0.0f32; width * height];
    let mut padded = vec![0.0f32; width + 2 * r];
    for (row, out) in data.chunks_exact(width).zip(rows.chunks_exact_mut(width)) {
        padded[..r].fill(row[0]);
        padded[r..r + width].copy_from_slice(row);
        padded[r + width..].fill(row[width - 1]);
        for (i, &k) in kernel.iter().enumerate() {
            for (o, &v) in out.iter_mut().zip(&padded[i..i + width]) {
                *o += v * k;
            }
        }
    }
    // Columns: every tap's row (the edge row past the borders) added to the whole output row.
    let mut out = vec![0.0f32; width * height];
    for (y, o) in out.chunks_exact_mut(width).enumerate() {
        for (i, &k) in kernel.iter().enumerate() {
            let src = (y + i).saturating_sub(r).min(height - 1);
            for (o, &v) in o.iter_mut().zip(&rows[src * width..(src + 1) * width]) {
                *o += v * k;
            }
        }
    }
    out
}

/// imageproc's Gaussian kernel for `sigma` pixels: taps out to `⌈2σ⌉` either side, normalised to sum 1.
fn gaussian_kernel(sigma: f32) -> Vec<f32> {
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)] // a few pixels
    let radius = (2.0 * sigma).ceil() as usize;
    let pdf =
        |x: f32| (sigma * (2.0 * std::f32::consts::PI).sqrt()).recip() * (-x.powi(2) / (2.0 * sigma.powi(2))).exp();
    let mut kernel = vec![0.0f32; 2 * radius + 1];
    for i in 0..=radius {
        #[allow(clippy::cast_precision_loss)]
        let v = pdf(i as f32);
        kernel[radius + i] = v;
        kernel[radius - i] = v;
    }
    let sum: f32 = kernel.iter().sum();
    kernel.iter_mut().for_each(|x| *x /= sum);
    kernel
}

/// The edge-tangent field: the structure tensor's components, blurred.
struct Tangents {
    tensor: TensorField,
}

impl Tangents {
    /// The tensor of `map`'s darkness gradient, blurred with `sigma` pixels, plus a bias across the lines of page
    /// angle `angle` (radians) three times as strong as the picture's median structure, so that flat and merely noisy parts
    /// follow that angle and only real edges turn the lines.
    fn new(map: &DarknessMap, sigma: f64, angle: f64) -> Self {
        let (w, h) = (map.width, map.height);
        let d = blur(w, h, map.data.clone(), 1.0);
        let at = |x: usize, y: usize| d[y * w + x];
        let (mut xx, mut xy, mut yy) = (vec![0.0f32; w * h], vec![0.0f32; w * h], vec![0.0f32; w * h]);
        for y in 0..h {
            for x in 0..w {
                let gx = (at((x + 1).min(w - 1), y) - at(x.saturating_sub(1), y)) / 2.0;
                let gy = (at(x, (y + 1).min(h - 1)) - at(x, y.saturating_sub(1))) / 2.0;
                let i = y * w + x;
                xx[i] = gx * gx;
                xy[i] = gx * gy;
                yy[i] = gy * gy;
            }
        }
        // The normal of a line at page angle a is (sin a, cos a) in pixel coordinates (Y down).
        #[allow(clippy::cast_possible_truncation)]
        let (s, c) = (angle.sin() as f32, angle.cos() as f32);
        let (xx, xy, yy) = (blur(w, h, xx, sigma), blur(w, h, xy, sigma), blur(w, h, yy, sigma));
        let mut traces: Vec<f32> = xx.iter().zip(&yy).step_by(7).map(|(a, b)| a + b).collect();
        let mid = traces.len() / 2;
        let bias = if traces.is_empty() { 0.0 } else { *traces.select_nth_unstable_by(mid, f32::total_cmp).1 };
        let bias = (3.0 * bias).max(1e-6);
        let (bxx, bxy, byy) = (bias * s * s, bias * s * c, bias * c * c);
        let data = xx.iter().zip(&xy).zip(&yy).map(|((a, b), c)| [a + bxx, b + bxy, c + byy]).collect();
        Tangents { tensor: TensorField { width: w, height: h, data } }
    }

    /// The unit direction along the edges at `p` (either sign).
    fn direction(&self, p: Point) -> Vec2 {
        let [a, b, c] = self.tensor.sample(p);
        // The gradient's direction is the tensor's major eigenvector, at θ = ½·atan2(2b, a − c); edges run across
        // it, along (−sin θ, cos θ). The half angle comes from cos 2θ without trigonometry.
        let (u, v) = (a - c, 2.0 * b);
        // Not `hypot` (a call into the C library, a tenth of the tracing): the tensor's components lie between
        // 1e-12 and a few units, far from where the squares would overflow or vanish.
        let r = (u * u + v * v).sqrt();
        if r <= 0.0 {
            return Vec2::new(0.0, 1.0);
        }
        let cos2 = u / r;
        let (cos, sin) = (((1.0 + cos2) / 2.0).max(0.0).sqrt(), ((1.0 - cos2) / 2.0).max(0.0).sqrt().copysign(v));
        Vec2::new(-sin, cos)
    }
}

/// Points of the finished streamlines of one family in a grid of buckets, for the distance tests.
struct Grid {
    /// Buckets per pixel (one over their side: a product, where a quotient took a tenth of the scan's time).
    per_pixel: f64,
    columns: usize,
    rows: usize,
    /// Per bucket, row by row: each point, its line, and its arc length along the line (kept in the bucket itself,
    /// so that a test reads one run of memory per bucket).
    buckets: Vec<Vec<(Point, u32, f64)>>,
}

impl Grid {
    fn new(width: f64, height: f64, cell: f64) -> Self {
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let (columns, rows) = ((width / cell).ceil().max(1.0) as usize, (height / cell).ceil().max(1.0) as usize);
        Grid { per_pixel: 1.0 / cell, columns, rows, buckets: vec![Vec::new(); columns * rows] }
    }

    fn index(&self, v: f64, n: usize) -> usize {
        // A cast truncates toward zero and saturates below at 0: floor for every `v` that matters here. The same
        // product for every point and every test, never decreasing in `v`, so a test's buckets hold every point
        // within its reach.
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let i = (v * self.per_pixel) as usize;
        i.min(n - 1)
    }

    fn add(&mut self, p: Point, line: u32, arc: f64) {
        let b = self.index(p.y, self.rows) * self.columns + self.index(p.x, self.columns);
        self.buckets[b].push((p, line, arc));
    }

    /// Whether a point lies within `r` of `p`, not counting the points of `own` line less than `window` along it
    /// from `arc`.
    fn near(&self, p: Point, r: f64, own: Option<(u32, f64, f64)>) -> bool {
        self.nearby(p, r, own).is_some()
    }

    /// A point within `r` of `p` (not counting the points of `own` line less than `window` along it from `arc`),
    /// if there is one.
    fn nearby(&self, p: Point, r: f64, own: Option<(u32, f64, f64)>) -> Option<Point> {
        let (c0, c1) = (self.index(p.x - r, self.columns), self.index(p.x + r, self.columns));
        let (r0, r1) = (self.index(p.y - r, self.rows), self.index(p.y + r, self.rows));
        let r2 = r * r;
        let hit = |bucket: &[(Point, u32, f64)]| {
            bucket.iter().find_map(|&(q, line, arc)| {
                let own_part = own.is_some_and(|(l, a, window)| l == line && (arc - a).abs() < window);
                ((q - p).hypot2() < r2 && !own_part).then_some(q)
            })
        };
        // `p`'s own bucket first: where a point is near, it most often lies there.
        let home = self.index(p.y, self.rows) * self.columns + self.index(p.x, self.columns);
        if let Some(q) = hit(&self.buckets[home]) {
            return Some(q);
        }
        (r0..=r1)
            .flat_map(|row| row * self.columns + c0..=row * self.columns + c1)
            .filter(|&b| b != home)
            .find_map(|b| hit(&self.buckets[b]))
    }
}

/// Per pixel: each family's spacing in pixels, infinite where the picture is too light for it.
struct Rungs {
    width: usize,
    height: usize,
    /// How many of the three regular families any pixel asks for.
    top: u8,
    /// Each family's spacing per pixel: the three regular families, then the two touch-up families.
    spacing: [Vec<f32>; 5],
    /// How many regular families the tone asks for at each pixel.
    asks: Vec<u8>,
    /// Whether each pixel is paper (darkness 0 before smoothing): no line enters one, so no ink lands past a
    /// shape's edge (the smoothed tone reaches a few pixels past it, and lines once ran on 0.82 mm beyond a black
    /// square).
    paper: Vec<bool>,
    /// The darkness blurred at the measuring scale ([`MEASURE_SPACINGS`]), which the measured respacing aims at.
    target: Vec<f32>,
    /// The most one family covers at the closest spacing, the pen and the widest spacing drawn, pixels.
    cmax: f64,
    pen_px: f64,
    max_spacing_px: f64,
}

/// The coverage of each of the three families for `darkness`, filled one after another: the first family alone
/// up to the most one family covers (`cmax`, lines at the closest spacing), then the second while the first stays
/// at `cmax`, then the third; past all three at `cmax` they close in together, each `1 − ∛(1 − d)`, up to
/// [`CLOSEST_DARKNESS`]. Together they cover `1 − Π(1 − cₖ) = d`.
///
/// Why not the ladder's rungs (every family at one spacing): there a family's spacing jumps where a family is
/// added (one family at 0.45 mm just lighter than 2/3 ink, two at 0.71 mm just darker), and a streamline that runs
/// across the tones carries its spacing over the jump, which the spacing tests let it keep: on a lightness ramp the
/// side lighter than each jump plotted up to 4 L* too light and the side darker up to 6 L* too dark. Filled one
/// after another, every family's spacing changes smoothly with the tone.
fn family_coverages(darkness: f64, cmax: f64) -> [f64; 3] {
    let d = if darkness.is_nan() { 0.0 } else { darkness.clamp(0.0, CLOSEST_DARKNESS) };
    let open = 1.0 - cmax;
    if d <= cmax {
        [d, 0.0, 0.0]
    } else if d <= 1.0 - open * open {
        [cmax, 1.0 - (1.0 - d) / open, 0.0]
    } else if d <= 1.0 - open * open * open {
        [cmax, cmax, 1.0 - (1.0 - d) / (open * open)]
    } else {
        let c = 1.0 - (1.0 - d).cbrt();
        [c, c, c]
    }
}

impl Rungs {
    fn new(map: &DarknessMap, ladder: &Ladder, pixel_mm: f64) -> Self {
        let min_px = ladder.min_spacing_mm / pixel_mm;
        let smooth = blur(map.width, map.height, map.data.clone(), min_px);
        let max_spacing_px = MAX_SPACING_FACTOR * min_px;
        let pen_px = ladder.pen_mm / pixel_mm;
        let cmax = ladder.max_family_coverage();
        let mut top = 0u8;
        let n = smooth.len();
        let mut spacing =
            [vec![f32::INFINITY; n], vec![f32::INFINITY; n], vec![f32::INFINITY; n], Vec::new(), Vec::new()];
        let mut asks = vec![0u8; n];
        for (i, &d) in smooth.iter().enumerate() {
            for (k, c) in family_coverages(f64::from(d), cmax).into_iter().enumerate() {
                let px = pen_px / c;
                if c > 0.0 && px <= max_spacing_px {
                    #[allow(clippy::cast_possible_truncation)] // a spacing of a few pixels
                    let px = px as f32;
                    spacing[k][i] = px;
                    #[allow(clippy::cast_possible_truncation)] // k < 3
                    let n = k as u8 + 1;
                    top = top.max(n);
                    asks[i] = n;
                }
            }
        }
        spacing[3] = vec![f32::INFINITY; n];
        spacing[4] = vec![f32::INFINITY; n];
        Rungs {
            width: map.width,
            height: map.height,
            top,
            spacing,
            asks,
            paper: map.data.iter().map(|&d| d <= 0.0).collect(),
            target: blur(map.width, map.height, map.data.clone(), MEASURE_SPACINGS * min_px),
            cmax,
            pen_px,
            max_spacing_px,
        }
    }

    /// Respace family `k` (1, 2, or 3 for the touch-up family) from the paper the families before it left,
    /// `paper_left` (per pixel, blurred at the measuring scale): where the family draws at all (family 3 where the
    /// third draws), its coverage is what turns that paper into the paper the tone leaves through this family,
    /// `c = 1 − (1 − D)/p` with `D = 1 − Π(1 − cⱼ)` the tone's coverages through family `k` (the whole darkness
    /// for the last two), up to [`CLOSEST_COVERAGE`]; none where the paper is already dark enough.
    ///
    /// Why measure: the streamlines' spacing strays from the tone's where the field turns or the tone changes along
    /// a line (0.7 … 1.7 spacings, and on average wider than asked), so the product rule over the asked coverages
    /// plotted a lightness ramp 4.5 L* too dark where the later families set in and, at the dark end where each
    /// family leaves a quarter pen between lines, 6.3 L* too light where all three missed. A family laid over the
    /// ink actually drawn corrects what the ones before it left; the touch-up family corrects the last.
    fn respace(&mut self, k: usize, paper_left: &[f32]) {
        #[allow(clippy::cast_possible_truncation)] // k ≤ 4
        let gate = k.min(2) as u8;
        let (cmax, pen, max_spacing) = (self.cmax, self.pen_px, self.max_spacing_px);
        let out: Vec<f32> = (0..self.target.len())
            .map(|i| {
                if self.asks[i] <= gate {
                    return f32::INFINITY;
                }
                let d = f64::from(self.target[i]);
                // The last two make up the whole darkness: no coverages to work out (a cube root per dark pixel).
                let through = if k >= 2 {
                    d.clamp(0.0, CLOSEST_DARKNESS)
                } else {
                    1.0 - family_coverages(d, cmax)[..=k].iter().map(|c| 1.0 - c).product::<f64>()
                };
                let p = f64::from(paper_left[i]);
                if p <= 1.0 - through {
                    return f32::INFINITY;
                }
                let c = (1.0 - (1.0 - through) / p).min(CLOSEST_COVERAGE);
                let px = pen / c;
                #[allow(clippy::cast_possible_truncation)] // a spacing of a few pixels
                if px <= max_spacing { px as f32 } else { f32::INFINITY }
            })
            .collect();
        self.spacing[k] = out;
    }

    /// The spacing of family `k` (0-based) at `p`, or `None` where the picture is too light for it.
    fn spacing(&self, p: Point, k: u8) -> Option<f64> {
        // A cast truncates toward zero and saturates below at 0: floor for every point that matters here.
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let (x, y) = (p.x as usize, p.y as usize);
        let i = y.min(self.height - 1) * self.width + x.min(self.width - 1);
        let s = self.spacing[usize::from(k)][i];
        (s.is_finite() && !self.paper[i]).then(|| f64::from(s))
    }
}

/// The paper left per pixel by the lines drawn so far (`grid` holds their ink), blurred with `sigma` pixels: each
/// fine cell counts toward the pixel its centre lies in.
fn paper_left(grid: &InkGrid, width: usize, height: usize, sigma: f64) -> Vec<f32> {
    // The pixel each column and each row of cells falls in, worked out once for the whole grid.
    #[allow(clippy::cast_precision_loss, clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let pixel = |i: usize, n: usize| (((i as f64 + 0.5) * grid.cell) as usize).min(n - 1);
    let xs: Vec<usize> = (0..grid.columns).map(|c| pixel(c, width)).collect();
    let (mut inked, mut all) = (vec![0u32; width * height], vec![0u32; width * height]);
    for (row, cells) in grid.ink.chunks_exact(grid.columns.max(1)).enumerate() {
        let base = pixel(row, height) * width;
        for (&x, &ink) in xs.iter().zip(cells) {
            all[base + x] += 1;
            inked[base + x] += u32::from(ink);
        }
    }
    #[allow(clippy::cast_precision_loss)]
    let paper = inked.into_iter().zip(all).map(|(n, a)| if a == 0 { 1.0 } else { 1.0 - n as f32 / a as f32 }).collect();
    blur(width, height, paper, sigma)
}

/// The ink grid flow measures its own lines on: cells about a third of the pen wide (2 … 4 per pixel side), their
/// size a little off every fraction of a pixel so that no lattice of the lines (seeds start at pixel centres, so
/// straight lines sit at fixed fractions of a pixel) lines up with the cells' centres: a line 1 px wide at a whole
/// pixel on cells of 1/3 px covers four centres, and measured 4/3 of its ink.
fn ink_grid(width: usize, height: usize, pen_px: f64) -> InkGrid {
    let per_side = (3.0 / pen_px).ceil().clamp(2.0, 4.0) + 0.137;
    let cell = 1.0 / per_side;
    #[allow(clippy::cast_precision_loss, clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let (columns, rows) = ((width as f64 / cell).ceil() as usize, (height as f64 / cell).ceil() as usize);
    InkGrid::new(columns, rows, cell)
}

/// One family's streamlines.
struct Family<'a> {
    tangents: &'a Tangents,
    rungs: &'a Rungs,
    k: u8,
    turn: Vec2,
    width: f64,
    height: f64,
    grid: Grid,
    lines: Vec<Vec<Point>>,
    /// Pixels between the places the scan for unreached gaps tries, across and down: half the closest spacing, in
    /// fractions of a pixel, at least one (a gap that takes a seed 0.7 spacings clear of its sides is 1.4 spacings
    /// wide, so a scan at half of one still finds it). On a 1 MP photo (closest spacing 2.88 px) it tries 1.44 px
    /// apart, half as many places as every pixel; rounded down to whole pixels it had tried every one.
    scan_step: f64,
}

impl Family<'_> {
    /// The family's direction at `p`, turned to agree with `prev`.
    fn direction(&self, p: Point, prev: Vec2) -> Vec2 {
        let t = self.tangents.direction(p);
        // Rotate the field's direction by the family's turn.
        let d = Vec2::new(t.x * self.turn.x - t.y * self.turn.y, t.x * self.turn.y + t.y * self.turn.x);
        if d.dot(prev) < 0.0 { -d } else { d }
    }

    fn inside(&self, p: Point) -> bool {
        (0.0..=self.width).contains(&p.x) && (0.0..=self.height).contains(&p.y)
    }

    /// A seed at `p` is usable: inside, dark enough for this family, and `clear` spacings from every line.
    fn seed_ok(&self, p: Point, clear: f64) -> bool {
        self.inside(p) && self.rungs.spacing(p, self.k).is_some_and(|s| !self.grid.near(p, clear * s, None))
    }

    /// Follow the field from `seed` in direction `sign`, adding the points to the grid as line `id`.
    fn trace(&mut self, seed: Point, start: Vec2, id: u32, sign: f64) -> Vec<Point> {
        let mut out = Vec::new();
        let (mut p, mut dir, mut arc) = (seed, start * sign, 0.0f64);
        let limit = 4.0 * (self.width + self.height) * MAX_SPACING_FACTOR;
        while arc.abs() < limit {
            let Some(sep) = self.rungs.spacing(p, self.k) else { break };
            let h = (0.4 * sep).clamp(0.5, 4.0);
            let v1 = self.direction(p, dir);
            let v2 = self.direction(p + v1 * (h / 2.0), v1);
            let q = p + v2 * h;
            if v2.dot(dir) < MAX_TURN_COS || !self.inside(q) {
                break;
            }
            let Some(sep_q) = self.rungs.spacing(q, self.k) else { break };
            let next_arc = arc + sign * h;
            let r = TEST_FRACTION * sep_q;
            if self.grid.near(q, r, Some((id, next_arc, 2.0 * r + 2.0 * h))) {
                break;
            }
            self.grid.add(q, id, next_arc);
            out.push(q);
            (p, dir, arc) = (q, v2, next_arc);
        }
        out
    }

    /// A whole streamline through `seed` (both ways), or `None` if it is a lone point.
    fn streamline(&mut self, seed: Point) -> Option<usize> {
        let id = u32::try_from(self.lines.len()).ok()?;
        self.grid.add(seed, id, 0.0);
        let start = self.direction(seed, Vec2::new(1.0, 0.0));
        let forward = self.trace(seed, start, id, 1.0);
        let backward = self.trace(seed, start, id, -1.0);
        let mut line: Vec<Point> = backward.into_iter().rev().collect();
        line.push(seed);
        line.extend(forward);
        self.lines.push(line);
        Some(self.lines.len() - 1)
    }

    /// Seeds `offset` spacings to either side of line `i`, every half spacing along it, each at least `offset`
    /// spacings from every line (a hair less, for rounding), and likewise from the lines they start.
    fn grow_from(&mut self, i: usize, offset: f64) {
        let mut queue = vec![i];
        while let Some(i) = queue.pop() {
            let line = self.lines[i].clone();
            let mut since = f64::INFINITY;
            for w in line.windows(2) {
                let (a, b) = (w[0], w[1]);
                let Some(sep) = self.rungs.spacing(a, self.k) else { continue };
                since += a.distance(b);
                if since < 0.5 * sep {
                    continue;
                }
                since = 0.0;
                let t = (b - a).normalize();
                let n = Vec2::new(-t.y, t.x);
                for side in [1.0, -1.0] {
                    let s = a + n * (side * offset * sep);
                    if self.seed_ok(s, SEED_CLEARANCE)
                        && let Some(j) = self.streamline(s)
                    {
                        queue.push(j);
                    }
                }
            }
        }
    }

    /// Lay the family out: grow from every usable place, scanning the picture in reading order.
    ///
    /// Most places the scan tries lie near a line already drawn. The line point that last turned a place down is
    /// kept and tried first at the next place along the row: points are never taken away, so where it is still
    /// within the clearance the place is turned down as the whole test would (exactly the same lines), for one
    /// distance instead of a search of the nearby buckets.
    fn run(mut self) -> Vec<Vec<Point>> {
        let step = self.scan_step.max(1.0);
        // The places along `n` pixels: from the first pixel's centre, every `step` pixels.
        #[allow(clippy::cast_precision_loss)]
        let places = move |n: usize| (0..).map(move |i| 0.5 + f64::from(i) * step).take_while(move |&v| v < n as f64);
        for y in places(self.rungs.height) {
            let mut last_near: Option<Point> = None;
            for x in places(self.rungs.width) {
                let p = Point::new(x, y);
                if !self.inside(p) {
                    continue;
                }
                let Some(s) = self.rungs.spacing(p, self.k) else { continue };
                let r = SEED_CLEARANCE * s;
                if last_near.is_some_and(|q| (q - p).hypot2() < r * r) {
                    continue;
                }
                if let Some(q) = self.grid.nearby(p, r, None) {
                    last_near = Some(q);
                    continue;
                }
                if let Some(i) = self.streamline(p) {
                    self.grow_from(i, 1.0);
                }
            }
        }

        self.lines.retain(|l| l.len() >= 2);
        self.lines
    }
}

/// The flow strokes of a darkness map, pixel coordinates: the ladder's families laid out as streamlines of the
/// edge-tangent field, the base direction `angle_deg` (page angle) where the picture is flat; `pixel_mm` converts
/// the ladder's spacings to pixels.
pub fn flow(map: &DarknessMap, ladder: &Ladder, pixel_mm: f64, angle_deg: f64) -> Vec<Vec<Point>> {
    if map.width == 0 || map.height == 0 || !(pixel_mm.is_finite() && pixel_mm > 0.0) {
        return Vec::new();
    }
    let min_px = ladder.min_spacing_mm / pixel_mm;
    let rungs = Rungs::new(map, ladder, pixel_mm);
    let top = rungs.top;
    if top == 0 {
        return Vec::new();
    }
    let tangents = Tangents::new(map, (2.0 * min_px).max(2.0), angle_deg.to_radians());
    #[allow(clippy::cast_precision_loss)]
    let (w, h) = (map.width as f64, map.height as f64);
    let scan_step = (min_px / 2.0).max(1.0);
    let mut rungs = rungs;
    let mut ink = ink_grid(map.width, map.height, rungs.pen_px);
    let mut out: Vec<Vec<Point>> = Vec::new();
    // The three regular families, then the touch-up families where all three draw.
    let families = if top >= 3 { 5 } else { top };
    for k in 0..families {
        if k > 0 {
            let paper = paper_left(&ink, map.width, map.height, MEASURE_SPACINGS * min_px);
            rungs.respace(usize::from(k), &paper);
        }
        let turn = FAMILY_TURNS[usize::from(k)].to_radians();
        let family = Family {
            tangents: &tangents,
            rungs: &rungs,
            k,
            turn: Vec2::new(turn.cos(), -turn.sin()),
            width: w,
            height: h,
            grid: Grid::new(w, h, (2.0 * min_px).max(2.0)),
            lines: Vec::new(),
            scan_step,
        };
        let lines = family.run();
        if k + 1 < families {
            ink.draw(&lines, rungs.pen_px);
        }
        out.extend(lines);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::raster::ink::ink_in_picture as ink;
    use crate::input::raster::tone::flat;
    use image::{ImageBuffer, Luma};

    #[test]
    fn the_blur_is_imageprocs_gaussian_to_the_bit() {
        // A 37 × 23 picture of uneven values, at σ under half a pixel (unchanged), 1, 2.9, 5.77 (flow's measuring
        // blur on a 1 MP photo: 25 taps) and 20 (a kernel wider than the picture, every tap past a border).
        let (w, h) = (37usize, 23usize);
        #[allow(clippy::cast_precision_loss)]
        let data: Vec<f32> = (0..w * h).map(|i| ((i * 7919) % 101) as f32 / 100.0).collect();
        assert_eq!(blur(w, h, data.clone(), 0.4), data);
        for sigma in [1.0f32, 2.9, 5.77, 20.0] {
            let img = ImageBuffer::<Luma<f32>, Vec<f32>>::from_raw(37, 23, data.clone()).unwrap();
            let want = imageproc::filter::gaussian_blur_f32(&img, sigma).into_raw();
            assert_eq!(blur(w, h, data.clone(), f64::from(sigma)), want, "σ {sigma}");
        }
        // A flat picture stays flat (the kernel sums to 1 and the borders repeat the edge).
        let flat = blur(w, h, vec![0.25; w * h], 5.77);
        assert!(flat.iter().all(|v| (v - 0.25).abs() < 1e-6), "{:?}", flat.first());
    }

    #[test]
    fn the_scan_turns_a_place_down_by_the_line_point_that_turned_down_the_one_before() {
        // Pen 0.3 mm on 0.3 mm pixels, closest spacing 0.45 mm: flat darkness 0.3 asks for lines 3.33 px apart,
        // horizontal (base angle 0). A line along y = 10.5 is drawn first: the scan's places at y = 10.5 lie on it
        // and are all turned down, the one that turned down x = 0.5 (clearance 0.7 · 3.33 = 2.33 px) doing for the
        // next ones; places at y = 12.5 (2 px off) are turned down too, and at y = 13.5 (3 px off) none is.
        let ladder = Ladder { pen_mm: 0.3, min_spacing_mm: 0.45 };
        let map = flat(40, 40, 0.3);
        let rungs = Rungs::new(&map, &ladder, 0.3);
        let tangents = Tangents::new(&map, 3.0, 0.0);
        let mut family = Family {
            tangents: &tangents,
            rungs: &rungs,
            k: 0,
            turn: Vec2::new(1.0, 0.0),
            width: 40.0,
            height: 40.0,
            grid: Grid::new(40.0, 40.0, 3.0),
            lines: Vec::new(),
            scan_step: 1.0,
        };
        family.streamline(Point::new(20.5, 10.5));
        let line = &family.lines[0];
        assert!(line.len() >= 29 && line.iter().all(|p| (p.y - 10.5).abs() < 1e-9), "{line:?}");
        let r = 0.7 / 0.3;
        let q = family.grid.nearby(Point::new(0.5, 10.5), r, None).unwrap();
        assert!((q.y - 10.5).abs() < 1e-9 && q.x < 0.5 + r);
        assert!(family.grid.near(Point::new(30.5, 12.5), r, None));
        assert!(!family.grid.near(Point::new(30.5, 13.5), r, None));
        // The whole run keeps the line drawn first and fills the rest 3.33 px apart: above it, lines grown from
        // y = 0.5 (3.83, 7.17, then 10.5 is taken); below, the scan's first clear row 13.5, then 16.83 … 36.83, and
        // 39.5 (2.67 px clear): 13 lines.
        let lines = family.run();
        let mut ys: Vec<f64> = lines.iter().map(|l| l[0].y).collect();
        ys.sort_by(f64::total_cmp);
        assert_eq!(ys.len(), 13, "{ys:?}");
        assert!((ys[4] - 13.5).abs() < 1e-9 && (ys[12] - 39.5).abs() < 1e-9, "{ys:?}");
    }

    #[test]
    fn the_scan_tries_places_half_the_closest_spacing_apart_in_fractions_of_a_pixel() {
        // Pen 0.3 mm on 0.3 mm pixels, closest spacing 0.9 mm (3 px): the scan tries rows 1.5 px apart from the
        // first pixel's centre, 0.5, 2, 3.5 … 12.5, 14. Darkness 0.3 (one family of horizontal lines) in rows 0–9
        // and 14–29, paper in rows 10–13, which no line enters or seeds across: the lower band's first line is the
        // scan's first seed there, on the first row it tries in pixel row 14, y = 14 (rounded down to whole pixels
        // the scan tried every row, and seeded it at 14.5).
        let ladder = Ladder { pen_mm: 0.3, min_spacing_mm: 0.9 };
        let (w, h) = (30usize, 30usize);
        let data = (0..w * h).map(|i| if (10..14).contains(&(i / w)) { 0.0 } else { 0.3 }).collect();
        let map = DarknessMap { width: w, height: h, data };
        let lines = flow(&map, &ladder, 0.3, 0.0);
        assert!(lines.iter().flatten().all(|p| !(10.0..14.0).contains(&p.y)), "{lines:?}");
        let below = lines.iter().flatten().map(|p| p.y).filter(|&y| y > 12.0).fold(f64::INFINITY, f64::min);
        assert!((below - 14.0).abs() < 1e-9, "{below}");
        assert!(lines.iter().any(|l| l.iter().all(|p| (p.y - 14.0).abs() < 1e-9) && l.len() >= 10), "{lines:?}");
    }

    #[test]
    fn white_is_empty_and_a_flat_gray_gets_parallel_lines_of_its_tone() {
        // Pen 0.3 mm on 0.3 mm pixels (1 px), closest spacing 0.45 mm (1.5 px).
        let ladder = Ladder { pen_mm: 0.3, min_spacing_mm: 0.45 };
        assert!(flow(&flat(60, 60, 0.0), &ladder, 0.3, 0.0).is_empty());
        // Darkness 0.3: one family at 0.3 / 0.3 = 1 mm = 3.33 px, straight at the base angle (0°: horizontal), so
        // a 150 px tall picture holds 45 lines across the whole width.
        let s = flow(&flat(150, 150, 0.3), &ladder, 0.3, 0.0);
        let long: Vec<&Vec<Point>> = s.iter().filter(|l| l.len() > 10).collect();
        assert!(long.len() >= 44 && long.len() <= 46, "{} lines", long.len());
        for l in &long {
            let (a, b) = (l[0], l[l.len() - 1]);
            assert!((a.y - b.y).abs() < 1e-6 && a.x.min(b.x) < 1.0 && a.x.max(b.x) > 149.0, "{a:?} {b:?}");
        }
        let f = ink(&s, 1.0, 150, 150, 20);
        assert!((f - 0.3).abs() < 0.02, "ink fraction {f}");
    }

    #[test]
    fn darker_grays_cross_and_black_reaches_the_darkest_rung() {
        let ladder = Ladder { pen_mm: 0.3, min_spacing_mm: 0.45 };
        // 0.8 is past one family (0.667): two families crossing, each 1 − √0.2 = 0.553 → 0.542 mm.
        let f = ink(&flow(&flat(150, 150, 0.8), &ladder, 0.3, 30.0), 1.0, 150, 150, 20);
        assert!((f - 0.8).abs() < 0.04, "ink fraction {f}");
        // Black: past the ladder's darkest rung (1 − (1/3)³ = 0.963, where flow once stopped) the three families
        // close in to 0.9 coverage each, 1 − 0.1³ = 0.999: within 0.03 of black.
        let f = ink(&flow(&flat(150, 150, 1.0), &ladder, 0.3, 0.0), 1.0, 150, 150, 20);
        assert!(f > 0.97, "ink fraction {f}");
    }

    #[test]
    fn families_fill_one_after_another_and_their_spacing_changes_smoothly() {
        // Pen 0.3 mm, closest spacing 0.45 mm: one family covers at most 2/3.
        let close = |a: [f64; 3], b: [f64; 3]| a.iter().zip(&b).all(|(x, y)| (x - y).abs() < 1e-9);
        let cmax = 2.0 / 3.0;
        assert!(close(family_coverages(0.5, cmax), [0.5, 0.0, 0.0]));
        // 0.8: the first at 2/3 leaves 1/3 paper, the second covers 1 − 0.2 / (1/3) = 0.4 of it.
        assert!(close(family_coverages(0.8, cmax), [cmax, 0.4, 0.0]));
        // 0.9: two at 2/3 leave 1/9, the third covers 1 − 0.1 / (1/9) = 0.1.
        assert!(close(family_coverages(0.9, cmax), [cmax, cmax, 0.1]));
        // 0.992: past 26/27, all three 1 − ∛0.008 = 0.8; black stops at 0.999, 0.9 each.
        assert!(close(family_coverages(0.992, cmax), [0.8, 0.8, 0.8]));
        assert!(close(family_coverages(1.0, cmax), [0.9, 0.9, 0.9]));
        // Across 2/3 the first family stays at 2/3 (the ladder's rungs jumped to 1 − √(1/3) = 0.42 there).
        let (below, above) = (family_coverages(cmax - 1e-6, cmax), family_coverages(cmax + 1e-6, cmax));
        assert!((below[0] - above[0]).abs() < 1e-5 && above[1] < 1e-5, "{below:?} {above:?}");
    }

    #[test]
    fn a_family_respaced_from_measured_ink_makes_up_what_the_ones_before_left() {
        // Pen 0.3 mm on 0.3 mm pixels, closest 0.45 mm: a flat darkness 0.9 asks for families covering 2/3, 2/3 and
        // 0.1, leaving 0.1 of the paper. If the first two left 0.2 (not the 1/9 asked), the third must cover
        // 1 − 0.1 / 0.2 = 0.5: lines 1 / 0.5 = 2 px apart; over 0.25 it covers 1 − 0.1 / 0.25 = 0.6 (1.67 px); over
        // 0.1 it draws nothing. The touch-up family likewise: 0.25 paper left → 0.6, 0.05 → nothing.
        let ladder = Ladder { pen_mm: 0.3, min_spacing_mm: 0.45 };
        let mut rungs = Rungs::new(&flat(40, 40, 0.9), &ladder, 0.3);
        let at = |r: &Rungs, k: u8| r.spacing(Point::new(20.5, 20.5), k);
        for (left, third, touch) in
            [(0.2f32, Some(2.0), Some(1.0 / 0.6)), (0.1, None, None), (0.25, Some(1.0 / 0.6), Some(1.0 / 0.6))]
        {
            let paper = vec![left; 40 * 40];
            rungs.respace(2, &paper);
            let touch_paper = vec![if left >= 0.2 { 0.25 } else { 0.05 }; 40 * 40];
            rungs.respace(3, &touch_paper);
            let close = |a: Option<f64>, b: Option<f64>| match (a, b) {
                (Some(a), Some(b)) => (a - b).abs() < 1e-4,
                (a, b) => a.is_none() && b.is_none(),
            };
            assert!(
                close(at(&rungs, 2), third) && close(at(&rungs, 3), touch),
                "paper {left}: {:?} {:?}",
                at(&rungs, 2),
                at(&rungs, 3)
            );
        }
    }

    #[test]
    fn no_line_runs_past_a_black_square() {
        // A black 60 × 60 px square in a white 120 × 120 picture: every stroke point lies on the square's pixels
        // (before, lines followed the smoothed tone and ran on 0.82 mm past it).
        let (w, h) = (120usize, 120usize);
        let data = (0..w * h)
            .map(|i| if (30..90).contains(&(i % w)) && (30..90).contains(&(i / w)) { 1.0 } else { 0.0 })
            .collect();
        let ladder = Ladder { pen_mm: 0.3, min_spacing_mm: 0.45 };
        let s = flow(&DarknessMap { width: w, height: h, data }, &ladder, 0.3, 45.0);
        let out: Vec<&Point> =
            s.iter().flatten().filter(|p| !(30.0..=90.0).contains(&p.x) || !(30.0..=90.0).contains(&p.y)).collect();
        assert!(out.is_empty(), "{} points outside, e.g. {:?}", out.len(), out.first());
        assert!(ink(&s, 1.0, w, h, 33) > 0.97);
    }

    #[test]
    fn lines_run_along_the_edges() {
        // A dark disc on white with a soft rim: around the rim the lines run round the disc (across the radius).
        let (w, h) = (160usize, 160usize);
        let data = (0..w * h)
            .map(|i| {
                #[allow(clippy::cast_precision_loss)]
                let r = ((i % w) as f64 + 0.5 - 80.0).hypot((i / w) as f64 + 0.5 - 80.0);
                #[allow(clippy::cast_possible_truncation)]
                let d = (0.6 - (r - 50.0) / 40.0).clamp(0.05, 0.6) as f32;
                d
            })
            .collect();
        let ladder = Ladder { pen_mm: 0.3, min_spacing_mm: 0.45 };
        let s = flow(&DarknessMap { width: w, height: h, data }, &ladder, 0.3, 0.0);
        let (mut along, mut all) = (0usize, 0usize);
        let c = Point::new(80.0, 80.0);
        for l in &s {
            for seg in l.windows(2) {
                let m = seg[0].midpoint(seg[1]);
                let r = m.distance(c);
                if (55.0..65.0).contains(&r) {
                    let t = (seg[1] - seg[0]).normalize();
                    let radial = (m - c) / r;
                    all += 1;
                    along += usize::from(t.dot(radial).abs() < 0.26); // within 15° of the tangent
                }
            }
        }
        assert!(all > 100 && along * 10 >= all * 9, "{along} of {all} steps run round the disc");
    }
}
