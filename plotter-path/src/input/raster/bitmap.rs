//! A binary image: which pixels belong to the foreground (the ink).
//!
//! Pixel `(x, y)` covers the unit square `[x, x+1] × [y, y+1]` in pixel coordinates, so its centre is at
//! `(x + 0.5, y + 0.5)`. Every tracing mode works in these pixel coordinates and scales to millimetres at the end.

/// A width × height grid of booleans stored one byte per pixel (0 = background, 1 = foreground), row-major.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Bitmap {
    width: usize,
    height: usize,
    data: Vec<u8>,
}

impl Bitmap {
    /// An all-background bitmap.
    pub fn new(width: usize, height: usize) -> Self {
        Bitmap { width, height, data: vec![0; width * height] }
    }

    /// A bitmap whose pixel `(x, y)` is `f(x, y)`.
    pub fn from_fn(width: usize, height: usize, mut f: impl FnMut(usize, usize) -> bool) -> Self {
        let mut data = Vec::with_capacity(width * height);
        for y in 0..height {
            for x in 0..width {
                data.push(u8::from(f(x, y)));
            }
        }
        Bitmap { width, height, data }
    }

    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.height
    }

    /// True when pixel `(x, y)` is foreground. Coordinates outside the grid are background, which lets the tracers
    /// treat the image as surrounded by a one-pixel white frame without padding it.
    #[inline]
    pub fn get(&self, x: isize, y: isize) -> bool {
        if x < 0 || y < 0 {
            return false;
        }
        let (x, y) = (x.unsigned_abs(), y.unsigned_abs());
        x < self.width && y < self.height && self.data[y * self.width + x] != 0
    }

    /// Set pixel `(x, y)`; panics when out of range (callers index from their own loops over the grid).
    #[inline]
    pub fn set(&mut self, x: usize, y: usize, on: bool) {
        self.data[y * self.width + x] = u8::from(on);
    }

    /// Number of foreground pixels.
    pub fn count(&self) -> usize {
        self.data.iter().filter(|&&v| v != 0).count()
    }

    /// True when no pixel is foreground.
    pub fn is_empty(&self) -> bool {
        self.data.iter().all(|&v| v == 0)
    }

    /// The raw row-major bytes (0 or 1).
    pub fn as_bytes(&self) -> &[u8] {
        &self.data
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn outside_is_background() {
        let b = Bitmap::from_fn(3, 2, |_, _| true);
        assert!(b.get(0, 0) && b.get(2, 1));
        assert!(!b.get(-1, 0) && !b.get(3, 0) && !b.get(0, 2) && !b.get(0, -1));
        assert_eq!(b.count(), 6);
        let mut e = Bitmap::new(4, 4);
        assert!(e.is_empty());
        e.set(3, 3, true);
        assert!(e.get(3, 3) && !e.is_empty() && e.count() == 1);
    }
}
