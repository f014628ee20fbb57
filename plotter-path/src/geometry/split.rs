//! Cutting polylines by a rule asked at points: each segment is split where it meets the boundary of any region
//! near it, and each piece between two such points is kept or dropped by asking the rule just beside its middle.
//! Between two consecutive boundary points no region's inside changes, so one question settles the whole piece,
//! whatever the rule does with the regions (the topmost of a stack of paints, a colour comparison, …): no union,
//! difference or other area operation is computed, and the cost is that of the boundary edges near each segment.
//!
//! The rule is given two points beside the piece's middle, a hair ([`SIDE_MM`]) off the line on either side: away
//! from any boundary both lie in the same regions, while on a piece running along a boundary they tell the two
//! sides apart, and the rule says which side matters.
//!
//! Kept pieces that meet are joined, so a line is only split where the rule's answer changes. A line kept whole
//! comes back bit for bit; the pieces of a closed line that meet at its first point are joined there.

use kurbo::{Point, Rect, Vec2};

use super::region::Region;

/// How far beside a piece the rule is asked, mm: far below anything a pen draws, far above rounding.
pub const SIDE_MM: f64 = 1e-6;

/// The regions near a segment, for [`split_where`].
pub trait Near {
    /// What the rule gets for a segment (e.g. indices of paints).
    type Item: Copy;
    /// Put into `out` (cleared first) the items whose regions may meet `bbox`.
    fn near(&self, bbox: Rect, out: &mut Vec<Self::Item>);
    /// The region of an item.
    fn region(&self, item: Self::Item) -> &Region;
}

/// Cut `lines` where they cross the boundaries of the regions `near` finds, keeping each piece for which `keep`
/// holds, given the items near its segment and the two points beside its middle: first the one toward the direction
/// turned a quarter from +x to +y, then the other.
pub fn split_where<N: Near>(
    lines: Vec<Vec<Point>>,
    near: &N,
    keep: impl Fn(&[N::Item], Point, Point) -> bool,
) -> Vec<Vec<Point>> {
    let mut out = Vec::new();
    let mut items = Vec::new();
    let mut ts: Vec<f64> = Vec::new();
    for line in lines {
        if line.len() < 2 {
            continue;
        }
        let mut pieces: Vec<Vec<Point>> = Vec::new();
        let mut cur: Vec<Point> = Vec::new();
        // Whether `cur`'s last point is a cut inside the current segment (replaced when the next piece is kept too).
        let mut inner = false;
        let mut dropped = false;
        for w in line.windows(2) {
            let (a, b) = (w[0], w[1]);
            if a == b {
                if !cur.is_empty() {
                    cur.push(b);
                    inner = false;
                }
                continue;
            }
            near.near(Rect::from_points(a, b), &mut items);
            ts.clear();
            ts.push(0.0);
            for &it in &items {
                near.region(it).crossings(a, b, &mut ts);
            }
            ts.push(1.0);
            ts.sort_unstable_by(f64::total_cmp);
            ts.dedup();
            let d = b - a;
            let side = Vec2::new(-d.y, d.x) * (SIDE_MM / d.hypot());
            for iv in ts.windows(2) {
                let (t0, t1) = (iv[0], iv[1]);
                if t1 <= t0 {
                    continue;
                }
                let m = a + d * (0.5 * (t0 + t1));
                if keep(&items, m + side, m - side) {
                    if inner {
                        cur.pop();
                    } else if cur.is_empty() {
                        cur.push(if t0 == 0.0 { a } else { a + d * t0 });
                    }
                    inner = t1 < 1.0;
                    cur.push(if inner { a + d * t1 } else { b });
                } else {
                    dropped = true;
                    inner = false;
                    if !cur.is_empty() {
                        pieces.push(std::mem::take(&mut cur));
                    }
                }
            }
            // The next segment starts at `b`: a cut there is a vertex of the line, never replaced.
            inner = false;
        }
        if !dropped {
            out.push(line);
            continue;
        }
        if !cur.is_empty() {
            pieces.push(cur);
        }
        // A closed line cut somewhere: its last and first pieces meet at its first point.
        let closed = line.len() > 2 && line.first() == line.last();
        if closed
            && pieces.len() >= 2
            && pieces[0].first() == line.first()
            && pieces.last().and_then(|p| p.last()) == line.last()
        {
            let first = pieces.remove(0);
            let last = pieces.last_mut().expect("two or more pieces");
            last.extend_from_slice(&first[1..]);
        }
        out.extend(pieces.into_iter().filter(|p| p.len() >= 2 && p.windows(2).any(|w| w[0] != w[1])));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::region::FillRule;

    struct All(Vec<Region>);

    impl Near for All {
        type Item = usize;
        fn near(&self, _bbox: Rect, out: &mut Vec<usize>) {
            out.clear();
            out.extend(0..self.0.len());
        }
        fn region(&self, item: usize) -> &Region {
            &self.0[item]
        }
    }

    fn len(lines: &[Vec<Point>]) -> f64 {
        lines.iter().flat_map(|l| l.windows(2)).map(|w| w[0].distance(w[1])).sum()
    }

    fn square(x: f64, y: f64, s: f64) -> Region {
        let c = [Point::new(x, y), Point::new(x + s, y), Point::new(x + s, y + s), Point::new(x, y + s)];
        Region::from_contours([c.as_slice()], FillRule::NonZero)
    }

    #[test]
    fn a_line_through_two_squares_is_cut_at_their_edges() {
        // Squares x 0..10 and 20..30 (y 0..10); a line y = 5 from x = −5 to 35 (one segment).
        let regions = All(vec![square(0.0, 0.0, 10.0), square(20.0, 0.0, 10.0)]);
        let line = vec![vec![Point::new(-5.0, 5.0), Point::new(35.0, 5.0)]];
        let inside = |items: &[usize], p: Point, _: Point| items.iter().any(|&k| regions.0[k].contains(p));
        let kept = split_where(line.clone(), &regions, |i, p, q| !inside(i, p, q));
        // Outside both: −5..0, 10..20, 30..35 — three pieces, 5 + 10 + 5 mm, ends exactly at the edges.
        assert_eq!(kept.len(), 3);
        assert!((len(&kept) - 20.0).abs() < 1e-9);
        assert_eq!(kept[1], vec![Point::new(10.0, 5.0), Point::new(20.0, 5.0)]);
        // The kept pieces of the inverse rule are the two 10 mm runs inside.
        let kept = split_where(line, &regions, inside);
        assert_eq!(
            kept,
            vec![vec![Point::new(0.0, 5.0), Point::new(10.0, 5.0)], vec![Point::new(20.0, 5.0), Point::new(30.0, 5.0)]]
        );
    }

    #[test]
    fn a_line_kept_whole_comes_back_bit_for_bit_and_no_cut_splits_a_kept_run() {
        // Two overlapping squares x 0..10 and 5..15: the line crosses four edges, but "outside the union" changes
        // only twice; the kept run in the middle has no vertex at x = 5 or 10.
        let regions = All(vec![square(0.0, 0.0, 10.0), square(5.0, 0.0, 10.0)]);
        let line = vec![Point::new(-5.0, 5.0), Point::new(0.1 + 0.2, 5.0), Point::new(20.0, 5.0)];
        let any = |items: &[usize], p: Point, _: Point| items.iter().any(|&k| regions.0[k].contains(p));
        assert_eq!(split_where(vec![line.clone()], &regions, |_, _, _| true), vec![line.clone()]);
        let kept = split_where(vec![line.clone()], &regions, any);
        assert_eq!(kept, vec![vec![Point::new(0.0, 5.0), Point::new(0.1 + 0.2, 5.0), Point::new(15.0, 5.0)]]);
        let none = split_where(vec![line], &regions, |_, _, _| false);
        assert!(none.is_empty());
    }

    #[test]
    fn a_piece_along_a_boundary_has_a_point_on_each_side_and_a_closed_line_joins_at_its_start() {
        // The square x, y 0..10's edge y = 0, run along toward +x: the first point (y = +10⁻⁶) is inside, the
        // second (y = −10⁻⁶) outside; a line along it is kept or dropped by the side the rule looks at.
        let regions = All(vec![square(0.0, 0.0, 10.0)]);
        let along = vec![vec![Point::new(2.0, 0.0), Point::new(8.0, 0.0)]];
        let sides = std::cell::RefCell::new(Vec::new());
        let kept = split_where(along.clone(), &regions, |_, l, r| {
            sides.borrow_mut().push((regions.0[0].contains(l), regions.0[0].contains(r)));
            true
        });
        assert_eq!((kept, sides.into_inner()), (along.clone(), vec![(true, false)]));
        let first_out = |items: &[usize], p: Point, _: Point| !items.iter().any(|&k| regions.0[k].contains(p));
        let second_out = |items: &[usize], _: Point, q: Point| !items.iter().any(|&k| regions.0[k].contains(q));
        assert!(split_where(along.clone(), &regions, first_out).is_empty());
        assert_eq!(split_where(along.clone(), &regions, second_out), along);
        // A closed ring x, y 5..15 starting at (5, 5), inside the square: what lies outside is one open piece,
        // (10, 5) → (15, 5) → (15, 15) → (5, 15) → (5, 10).
        let ring = vec![
            Point::new(5.0, 5.0),
            Point::new(15.0, 5.0),
            Point::new(15.0, 15.0),
            Point::new(5.0, 15.0),
            Point::new(5.0, 5.0),
        ];
        let outside = |items: &[usize], p: Point, _: Point| !items.iter().any(|&k| regions.0[k].contains(p));
        assert_eq!(
            split_where(vec![ring.clone()], &regions, outside),
            vec![vec![
                Point::new(10.0, 5.0),
                Point::new(15.0, 5.0),
                Point::new(15.0, 15.0),
                Point::new(5.0, 15.0),
                Point::new(5.0, 10.0)
            ]]
        );
        // Inside instead: the two pieces meeting at (5, 5) are joined into one corner (5,10) → (5,5) → (10,5).
        let inside = |items: &[usize], p: Point, _: Point| items.iter().any(|&k| regions.0[k].contains(p));
        assert_eq!(
            split_where(vec![ring], &regions, inside),
            vec![vec![Point::new(5.0, 10.0), Point::new(5.0, 5.0), Point::new(10.0, 5.0)]]
        );
    }
}
