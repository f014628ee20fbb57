//! Region boundaries of a [`Bitmap`] as closed polygons (marching squares).
//!
//! Each boundary is traced through the *midpoints between neighbouring pixel centres* whose pixels differ, i.e. the
//! classic marching-squares iso-line at level ½ over the grid of pixel centres. Along a straight run of pixels this
//! lies exactly on the shared pixel edge, and across a one-pixel staircase it cuts the step diagonally. The polygons
//! therefore enclose exactly the foreground pixel centres, so re-filling them (even-odd) reproduces the bitmap, and
//! they look smoother than the pixel-edge ("crack") boundary.
//!
//! Why not the pixel-centre contours of `imageproc::contours` (Suzuki–Abe border following)? Those run *through*
//! the centres of the outermost foreground pixels, which shrinks every region by half a pixel on each side: a
//! one-pixel-wide line encloses no area at all, and thin letters lose a large share of their ink. The tracer here
//! costs the same single pass over the image.
//!
//! Saddle cells (two diagonal foreground pixels) are resolved so that diagonal foreground pixels are connected, the
//! same 8-connectivity the centreline walk uses. Loops are oriented with the foreground on their right in page
//! coordinates (Y down), so outer boundaries have negative and hole boundaries positive shoelace area.

use super::bitmap::Bitmap;
use kurbo::Point;

/// One closed boundary, in pixel coordinates; the last point is not repeated.
#[derive(Debug, Clone, PartialEq)]
pub struct Contour {
    /// The vertices, one per crossing of a pixel pair, in tracing order.
    pub points: Vec<Point>,
    /// Shoelace area: negative for an outer boundary of a foreground region, positive for a hole.
    pub signed_area: f64,
}

impl Contour {
    /// True when this loop bounds a hole (background enclosed by foreground).
    pub fn is_hole(&self) -> bool {
        self.signed_area > 0.0
    }

    /// The loop as a closed point list (first point repeated at the end).
    pub fn closed_points(&self) -> Vec<Point> {
        let mut v = self.points.clone();
        if let Some(&f) = self.points.first() {
            v.push(f);
        }
        v
    }
}

/// Shoelace signed area of a polygon given without its closing point.
pub fn signed_area(points: &[Point]) -> f64 {
    let n = points.len();
    let mut s = 0.0;
    for i in 0..n {
        let (a, b) = (points[i], points[(i + 1) % n]);
        s += a.x * b.y - b.x * a.y;
    }
    s / 2.0
}

// Cell sides, clockwise on screen: top, right, bottom, left.
const TOP: u8 = 0;
const RIGHT: u8 = 1;
const BOTTOM: u8 = 2;
const LEFT: u8 = 3;

/// Trace every region boundary of `bitmap`. Pixels outside the grid count as background, so regions touching the
/// border are closed along the image edge.
pub fn trace_contours(bitmap: &Bitmap) -> Vec<Contour> {
    let (w, h) = (bitmap.width(), bitmap.height());
    // A crossing between horizontally adjacent pixels (a, b)-(a+1, b), a in -1..w, is visited at most once; every
    // loop crosses at least one such pair, so scanning them finds every loop.
    let stride = w + 1;
    let mut visited = vec![false; stride * h];
    let mut out = Vec::new();
    let bytes = bitmap.as_bytes();
    for b in 0..h {
        let row = &bytes[b * w..(b + 1) * w];
        let mut left = false;
        for a1 in 0..=w {
            // a1 = a + 1 is the index of the right pixel of the pair.
            let right = a1 < w && row[a1] != 0;
            if left != right && !visited[b * stride + a1] {
                out.push(follow(bitmap, a1, b, right, &mut visited));
            }
            left = right;
        }
    }
    out
}

fn to_isize(v: usize) -> isize {
    // Bitmap dimensions come from image sizes capped far below isize::MAX by the loader's limits.
    isize::try_from(v).unwrap_or(isize::MAX)
}

/// Follow one loop starting at the crossing between pixels (a1-1, b) and (a1, b).
fn follow(bitmap: &Bitmap, a1: usize, b: usize, right_is_fg: bool, visited: &mut [bool]) -> Contour {
    let stride = bitmap.width() + 1;
    let (a1i, bi) = (to_isize(a1), to_isize(b));
    // The pair is the top side of cell (a1-1, b) and the bottom side of cell (a1-1, b-1). The top side is an entry
    // (clockwise background → foreground) when its right pixel is foreground; otherwise enter the upper cell.
    let (mut cx, mut cy, mut entry) = if right_is_fg { (a1i - 1, bi, TOP) } else { (a1i - 1, bi - 1, BOTTOM) };
    let (start_x, start_y, start_entry) = (cx, cy, entry);
    let mut points = Vec::new();
    loop {
        // Mark and record the crossing we enter through.
        let (px, py) = side_midpoint(cx, cy, entry);
        points.push(Point::new(px, py));
        if let Some(idx) = horizontal_pair_index(cx, cy, entry, stride) {
            visited[idx] = true;
        }
        let corners = [bitmap.get(cx, cy), bitmap.get(cx + 1, cy), bitmap.get(cx + 1, cy + 1), bitmap.get(cx, cy + 1)];
        let exit = exit_side(corners, entry);
        match exit {
            TOP => {
                cy -= 1;
                entry = BOTTOM;
            }
            RIGHT => {
                cx += 1;
                entry = LEFT;
            }
            BOTTOM => {
                cy += 1;
                entry = TOP;
            }
            _ => {
                cx -= 1;
                entry = RIGHT;
            }
        }
        if (cx, cy, entry) == (start_x, start_y, start_entry) {
            break;
        }
    }
    let signed_area = signed_area(&points);
    Contour { points, signed_area }
}

/// Corners of side `s` in clockwise order, as indices into `[TL, TR, BR, BL]`.
fn side_corners(s: u8) -> (usize, usize) {
    match s {
        TOP => (0, 1),
        RIGHT => (1, 2),
        BOTTOM => (2, 3),
        _ => (3, 0),
    }
}

/// The side through which the boundary leaves a cell entered through `entry`.
fn exit_side(corners: [bool; 4], entry: u8) -> u8 {
    let saddle = corners[0] == corners[2] && corners[1] == corners[3] && corners[0] != corners[1];
    if saddle {
        // Keep diagonal foreground connected: turn around the background corner the entry side starts at.
        return (entry + 3) % 4;
    }
    // The unique exit: the side whose clockwise corner pair goes foreground → background.
    (0..4u8)
        .find(|&s| {
            let (p, q) = side_corners(s);
            corners[p] && !corners[q]
        })
        .unwrap_or(entry)
}

/// Midpoint of side `s` of cell (cx, cy) (the cell spans pixel centres (cx, cy)..(cx+1, cy+1)).
fn side_midpoint(cx: isize, cy: isize, s: u8) -> (f64, f64) {
    // Pixel coordinates are far below 2^52, so the conversion is exact.
    #[allow(clippy::cast_precision_loss)] // |cx|, |cy| < 2^31
    let (x, y) = (cx as f64, cy as f64);
    match s {
        TOP => (x + 1.0, y + 0.5),
        RIGHT => (x + 1.5, y + 1.0),
        BOTTOM => (x + 1.0, y + 1.5),
        _ => (x + 0.5, y + 1.0),
    }
}

/// Index of the horizontal pixel pair a top/bottom side lies on (None for left/right sides).
fn horizontal_pair_index(cx: isize, cy: isize, s: u8, stride: usize) -> Option<usize> {
    let row = match s {
        TOP => cy,
        BOTTOM => cy + 1,
        _ => return None,
    };
    let row = usize::try_from(row).ok()?;
    let a1 = usize::try_from(cx + 1).ok()?;
    Some(row * stride + a1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn single_pixel_is_a_diamond() {
        let mut b = Bitmap::new(3, 3);
        b.set(1, 1, true);
        let c = trace_contours(&b);
        assert_eq!(c.len(), 1);
        assert_eq!(c[0].points.len(), 4);
        assert!((c[0].signed_area + 0.5).abs() < 1e-12, "{:?}", c[0]);
        assert!(!c[0].is_hole());
    }

    #[test]
    fn square_with_hole_gives_outer_and_hole() {
        // 5×5 block with the centre pixel cleared.
        let b = Bitmap::from_fn(7, 7, |x, y| (1..6).contains(&x) && (1..6).contains(&y) && !(x == 3 && y == 3));
        let c = trace_contours(&b);
        assert_eq!(c.len(), 2);
        let outer = c.iter().find(|c| !c.is_hole()).unwrap();
        let hole = c.iter().find(|c| c.is_hole()).unwrap();
        // Outer: 5×5 square with its four corners cut by half-pixel triangles (4 × 1/8).
        assert!((outer.signed_area + 24.5).abs() < 1e-12, "{}", outer.signed_area);
        assert!((hole.signed_area - 0.5).abs() < 1e-12, "{}", hole.signed_area);
    }

    #[test]
    fn diagonal_pixels_are_one_region() {
        let b = Bitmap::from_fn(4, 4, |x, y| x == y);
        let c = trace_contours(&b);
        assert_eq!(c.len(), 1);
    }

    #[test]
    fn regions_on_the_border_are_closed() {
        let b = Bitmap::from_fn(4, 3, |_, _| true);
        let c = trace_contours(&b);
        assert_eq!(c.len(), 1);
        // 4×3 rectangle from (0.5,0.5)..., corners cut: 4×3 - 4/8.
        assert!((c[0].signed_area + 11.5).abs() < 1e-12, "{}", c[0].signed_area);
        for p in &c[0].points {
            assert!(p.x >= 0.0 && p.x <= 4.0 && p.y >= 0.0 && p.y <= 3.0);
        }
    }

    #[test]
    fn checkerboard_counts() {
        // Diagonal-connected checkerboard: one foreground region; its enclosed background pixels are holes.
        let b = Bitmap::from_fn(5, 5, |x, y| (x + y) % 2 == 0);
        let c = trace_contours(&b);
        let outers = c.iter().filter(|c| !c.is_hole()).count();
        assert_eq!(outers, 1);
        // The four interior background pixels (1,2),(2,1),(2,3),(3,2) are each enclosed.
        assert_eq!(c.len() - outers, 4);
    }
}
