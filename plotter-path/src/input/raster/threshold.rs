//! Gray → binary: a fixed level or Otsu's automatic level, optionally inverted.

use super::bitmap::Bitmap;
use image::GrayImage;
use std::fmt;
use std::str::FromStr;

/// How gray pixels are split into ink (foreground) and paper (background).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Threshold {
    /// Pixels strictly darker than this luma (0–255) are ink.
    Fixed(u8),
    /// Otsu's method (1979): choose the level that maximises the between-class variance of the gray histogram, then
    /// pixels at or below it are ink. A uniform image has no two classes and yields no ink.
    #[default]
    Otsu,
}

impl fmt::Display for Threshold {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Threshold::Fixed(v) => write!(f, "{v}"),
            Threshold::Otsu => f.write_str("otsu"),
        }
    }
}

impl FromStr for Threshold {
    type Err = String;

    /// `otsu` or an integer 0–255.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        if s.eq_ignore_ascii_case("otsu") {
            return Ok(Threshold::Otsu);
        }
        s.parse::<u8>()
            .map(Threshold::Fixed)
            .map_err(|_| format!("threshold must be `otsu` or an integer 0-255, got `{s}`"))
    }
}

/// The luma cut actually used: pixels with luma `< cut` are ink (before inversion). `None` when the image is
/// uniform and the threshold is Otsu (no ink).
pub fn cut_level(gray: &GrayImage, threshold: Threshold) -> Option<u16> {
    match threshold {
        Threshold::Fixed(v) => Some(u16::from(v)),
        Threshold::Otsu => {
            let mut seen = [false; 256];
            for p in gray.pixels() {
                seen[usize::from(p.0[0])] = true;
            }
            if seen.iter().filter(|&&s| s).count() < 2 {
                return None;
            }
            Some(u16::from(imageproc::contrast::otsu_level(gray)) + 1)
        }
    }
}

/// Binarise `gray`: ink where luma is below the cut (or, with `invert`, at or above it).
pub fn binarize(gray: &GrayImage, threshold: Threshold, invert: bool) -> Bitmap {
    let (w, h) = (gray.width() as usize, gray.height() as usize);
    let Some(cut) = cut_level(gray, threshold) else {
        return Bitmap::new(w, h);
    };
    let raw = gray.as_raw();
    Bitmap::from_fn(w, h, |x, y| (u16::from(raw[y * w + x]) < cut) != invert)
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::Luma;

    #[test]
    fn fixed_and_inverted() {
        let g = GrayImage::from_fn(4, 1, |x, _| Luma([[0u8, 100, 128, 255][x as usize]]));
        let b = binarize(&g, Threshold::Fixed(128), false);
        assert_eq!(b.as_bytes(), &[1, 1, 0, 0]);
        let b = binarize(&g, Threshold::Fixed(128), true);
        assert_eq!(b.as_bytes(), &[0, 0, 1, 1]);
    }

    #[test]
    fn otsu_splits_two_tones() {
        let g = GrayImage::from_fn(10, 10, |x, _| Luma([if x < 3 { 40 } else { 200 }]));
        let b = binarize(&g, Threshold::Otsu, false);
        assert_eq!(b.count(), 30);
        assert!(b.get(0, 0) && !b.get(5, 5));
    }

    #[test]
    fn uniform_images_have_no_ink_under_otsu() {
        for v in [0u8, 128, 255] {
            let g = GrayImage::from_pixel(8, 8, Luma([v]));
            assert!(binarize(&g, Threshold::Otsu, false).is_empty(), "luma {v}");
        }
        // A fixed level on white finds nothing either.
        let g = GrayImage::from_pixel(8, 8, Luma([255]));
        assert!(binarize(&g, Threshold::Fixed(255), false).is_empty());
    }

    #[test]
    fn parse() {
        assert_eq!("otsu".parse::<Threshold>(), Ok(Threshold::Otsu));
        assert_eq!("OTSU".parse::<Threshold>(), Ok(Threshold::Otsu));
        assert_eq!("17".parse::<Threshold>(), Ok(Threshold::Fixed(17)));
        assert!("300".parse::<Threshold>().is_err());
        assert!("dark".parse::<Threshold>().unwrap_err().contains("dark"));
    }
}
