//! Spiral style: one Archimedean spiral from the picture's centre, its turns `row` apart, carrying a triangle wave
//! whose amplitude and wavelength follow darkness exactly as the squiggle's rows do ([`super::squiggle::Waves`]).
//! The pen lifts only where the picture is paper and where the spiral leaves the picture (past its corners). A wave
//! point that would land on paper is pulled back onto the spiral's own line, so no wave reaches past a shape's edge
//! by more than the pen's half width.
//!
//! The spiral `r = row · θ / 2π` is walked in steps that end on every quarter of the local wavelength (each peak and
//! each crossing of the spiral's line, at most half a pixel apart); the wave's phase advances by step / wavelength,
//! and each point is pushed out along the radius by the amplitude times a triangle wave of the phase.
//!
//! **Tone.** The turns' waves are not in phase with their neighbours' (a turn is no whole number of wavelengths
//! long), so their wavelength for a darkness is read from the squiggle's table measured with neighbours at every
//! phase ([`super::squiggle::Waves::unphased`]): read off the in-phase table the ramp plotted up to L* 12 too light
//! in the middle.

use super::squiggle::Waves;
use super::tone::DarknessMap;
use kurbo::Point;
use std::f64::consts::TAU;

/// Triangle wave of period 1: 0 at 0, 1 at ¼, 0 at ½, −1 at ¾.
fn triangle(phase: f64) -> f64 {
    let p = phase.rem_euclid(1.0);
    if p < 0.25 {
        4.0 * p
    } else if p < 0.75 {
        2.0 - 4.0 * p
    } else {
        4.0 * p - 4.0
    }
}

/// The spiral strokes of a darkness map, pixel coordinates: turns `row` pixels apart, pen `pen` pixels wide.
pub fn spiral(map: &DarknessMap, pen: f64, row: f64) -> Vec<Vec<Point>> {
    let mut out = Vec::new();
    if !(row.is_finite() && row > 0.0 && pen > 0.0) || map.width == 0 || map.height == 0 {
        return out;
    }
    #[allow(clippy::cast_precision_loss)]
    let (w, h) = (map.width as f64, map.height as f64);
    let c = Point::new(w / 2.0, h / 2.0);
    let r_end = (w * w + h * h).sqrt() / 2.0 + row;
    let b = row / TAU;
    let waves = Waves::unphased(pen, row);
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let paper = |p: Point| p.x < 0.0 || p.y < 0.0 || map.at(p.x as usize, p.y as usize) <= 0.0;
    let (mut theta, mut phase) = (0.0f64, 0.0f64);
    let mut stroke: Vec<Point> = Vec::new();
    loop {
        let r = b * theta;
        if r > r_end {
            break;
        }
        let (s, co) = theta.sin_cos();
        let on = Point::new(c.x + r * co, c.y + r * s);
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let dark = if on.x >= 0.0 && on.y >= 0.0 { map.at(on.x as usize, on.y as usize) } else { 0.0 };
        let wave = waves.wave(f64::from(dark));
        // Steps land on every quarter of the wave (its peaks and its crossings of the spiral's line), at most half
        // a pixel apart: a step across a peak would cut it short, and the band-filling waves would leave paper
        // between the turns (at L* 7.5 the plot was L* 16).
        let step = wave.map_or(0.5, |(_, lambda)| {
            let to_quarter = ((4.0 * phase).floor() + 1.0) / 4.0 - phase;
            (to_quarter * lambda).clamp(1e-6, 0.5)
        });
        let inside_picture = |p: Point| (0.0..=w).contains(&p.x) && (0.0..=h).contains(&p.y);
        match wave {
            Some((a, lambda)) => {
                // Near the centre the radius is shorter than the amplitude: keep the wave off the other side.
                let off = a.min(r) * triangle(phase);
                let mut p = Point::new(c.x + (r + off) * co, c.y + (r + off) * s);
                if paper(p) {
                    p = on;
                }
                if inside_picture(p) {
                    stroke.push(p);
                } else if stroke.len() >= 2 {
                    out.push(std::mem::take(&mut stroke));
                } else {
                    stroke.clear();
                }
                phase += step / lambda;
            }
            None => {
                if stroke.len() >= 2 {
                    out.push(std::mem::take(&mut stroke));
                }
                stroke.clear();
            }
        }
        theta += step / (r * r + b * b).sqrt();
    }
    if stroke.len() >= 2 {
        out.push(stroke);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::raster::ink::InkGrid;

    #[test]
    fn the_triangle_wave() {
        assert_eq!(triangle(0.0), 0.0);
        assert_eq!(triangle(0.25), 1.0);
        assert_eq!(triangle(0.5), 0.0);
        assert_eq!(triangle(0.75), -1.0);
        assert_eq!(triangle(1.125), 0.5);
    }

    #[test]
    fn flat_grays_ink_their_darkness_though_the_turns_are_out_of_phase() {
        // Pen 1 px, turns 3 px apart (the 0.3 mm pen on 0.3 mm pixels, rows twice the 0.45 mm closest spacing), a
        // 240 × 240 picture of one darkness: the ink over the square 40..200 (whole turns, away from the centre's
        // first turns and the corners) is that darkness. Read off the squiggle's in-phase table, and with steps
        // that cut across the peaks, 0.5 plotted 0.474 and 0.8 plotted 0.744.
        for d in [0.5f32, 0.8, 0.95] {
            let s = spiral(&crate::input::raster::tone::flat(240, 240, d), 1.0, 3.0);
            let mut grid = InkGrid::new(1200, 1200, 0.2);
            grid.draw(&s, 1.0);
            let f = grid.fraction(200, 1000, 200, 1000);
            assert!((f - f64::from(d)).abs() < 0.03, "darkness {d}: ink fraction {f:.3}");
        }
    }

    #[test]
    fn a_white_picture_gets_nothing_and_a_gray_disc_one_spiral_of_its_tone() {
        let white = DarknessMap { width: 60, height: 60, data: vec![0.0; 3600] };
        assert!(spiral(&white, 1.0, 4.0).is_empty());
        // A flat darkness 0.4 disc of radius 90 inside a 200 × 200 picture, paper outside it: one stroke, inside
        // the picture, with 0.4 ink away from the centre and the rim.
        let gray = DarknessMap {
            width: 200,
            height: 200,
            data: (0..40_000)
                .map(|i| {
                    let (x, y) = (f64::from(i % 200) + 0.5 - 100.0, f64::from(i / 200) + 0.5 - 100.0);
                    if x.hypot(y) < 90.0 { 0.4 } else { 0.0 }
                })
                .collect(),
        };
        let s = spiral(&gray, 1.0, 4.0);
        // One stroke from the centre out to the rim; the last turn, grazing the pixelated rim, breaks into short
        // pieces there (between radius 86 and 94: the rim ± a turn's spacing and amplitude).
        let centre = Point::new(100.0, 100.0);
        assert!(s[0][0].distance(centre) < 1e-9 && s[0].last().unwrap().distance(centre) > 86.0);
        assert!(s[1..].iter().flatten().all(|p| (86.0..94.0).contains(&p.distance(centre))));
        assert!(s.iter().flatten().all(|p| p.distance(centre) < 94.0));
        let mut grid = InkGrid::new(1000, 1000, 0.2);
        grid.draw(&s, 1.0);
        // The square 60..140 (cells 300..700) is inside the disc.
        let f = grid.fraction(300, 700, 300, 700);
        assert!((f - 0.4).abs() < 0.05, "ink fraction {f}");
    }
}
