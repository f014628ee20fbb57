//! Squiggle style: the picture as rows of zig-zag waves whose amplitude, then frequency, grow with darkness; each
//! row is one stroke, broken only where the picture is paper.
//!
//! Rows are `row` apart. A zig-zag of peak amplitude `A` and wavelength `λ` is `√(1 + (4A/λ)²)` times as long as
//! the row, so with pen width `w` it covers `w · √(1 + (4A/λ)²) / row` of the row's band. For a target darkness `d`
//! the length factor is `L = d · row / w`; lighter tones keep the longest wave (`λ = 2·row`) and grow the amplitude
//! `A = λ/4 · √(L² − 1)`; once the wave fills the band (`A = row/2`) darker tones shorten the wavelength
//! `λ = 2·row / √(L² − 1)`, down to twice the pen width. A tone lighter than half a flat line's coverage is paper.

use super::tone::DarknessMap;
use kurbo::Point;

/// The amplitude and wavelength (pixels) for a darkness, with pen width `pen` and row pitch `row` (pixels);
/// `None` for paper.
pub fn wave_for(darkness: f64, pen: f64, row: f64) -> Option<(f64, f64)> {
    let flat = pen / row;
    if darkness.is_nan() || darkness < flat / 2.0 {
        return None;
    }
    let l = (darkness * row / pen).max(1.0);
    let k = (l * l - 1.0).sqrt();
    let longest = 2.0 * row;
    let a = longest / 4.0 * k;
    if a <= row / 2.0 {
        return Some((a, longest));
    }
    let lambda = (longest / k).max(2.0 * pen);
    Some((row / 2.0, lambda))
}

/// The squiggle strokes of a darkness map, pixel coordinates: rows `row` pixels apart, pen `pen` pixels wide.
pub fn squiggle(map: &DarknessMap, pen: f64, row: f64) -> Vec<Vec<Point>> {
    let mut out = Vec::new();
    if !(row.is_finite() && row > 0.0 && pen > 0.0) {
        return out;
    }
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
                    stroke.push(Point::new(mid, if up { y - a } else { y + a }));
                    stroke.push(Point::new(nx, y));
                    up = !up;
                    x = nx;
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
        // Darkness 0.5: L = 2, √3 → A = 8/4·√3 = 3.46 > 2, so A = 2 and λ = 8/√3.
        let (a, l) = wave_for(0.5, 1.0, 4.0).unwrap();
        assert!((a - 2.0).abs() < 1e-12 && (l - 8.0 / 3f64.sqrt()).abs() < 1e-12);
        // Darkness 0.3: L = 1.2, √0.44 → A = 2·0.6633 = 1.327, λ = 8.
        let (a, l) = wave_for(0.3, 1.0, 4.0).unwrap();
        assert!((a - 2.0 * 0.44f64.sqrt()).abs() < 1e-12 && l == 8.0);
    }

    #[test]
    fn white_is_empty_and_a_flat_gray_gets_its_ink() {
        let white = DarknessMap { width: 40, height: 40, data: vec![0.0; 1600] };
        assert!(squiggle(&white, 1.0, 4.0).is_empty());
        // Darkness 0.4 over 200 × 200 px, pen 1, rows 4: 50 rows, each one stroke whose length is
        // 200 · 0.4 · 4 / 1 = 320 px (the length factor times the row).
        let gray = DarknessMap { width: 200, height: 200, data: vec![0.4; 40_000] };
        let s = squiggle(&gray, 1.0, 4.0);
        assert_eq!(s.len(), 50);
        for st in &s {
            assert!((length(st) - 320.0).abs() < 4.0, "{}", length(st));
            assert!(st.iter().all(|p| (0.0..=200.0).contains(&p.x) && (0.0..=200.0).contains(&p.y)));
        }
        // Rendered: the ink fraction is near 0.4 (legs overlap a little near the peaks).
        let mut grid = InkGrid::new(1000, 1000, 0.2);
        grid.draw(&s, 1.0);
        let f = grid.fraction(100, 900, 100, 900);
        assert!((f - 0.4).abs() < 0.05, "ink fraction {f}");
    }
}
