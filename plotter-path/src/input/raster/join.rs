//! Joining a tone hatch's spans across its bands: the pen stays down from the end of one span to a nearby end of
//! another, whichever band or family it belongs to, wherever the short connector runs over ink.
//!
//! Each band of [`super::hatch::tone_hatch`] zig-zags its own lines, but a photo's bands are small and many, so a
//! band's zig-zags are short and the plot lifts the pen at every band edge. Here the zig-zags of all bands are taken
//! apart into their spans and joined again as one set: the zig-zags' own links, and every pair of span ends closer
//! than the longest link, are candidates, granted best first, each end once, never closing a loop (a union–find of
//! the chains, [`crate::geometry::union_find`]), and a new link only where the caller's `inside` test accepts the straight connector. The best links
//! are a **row going on** (two parallel spans whose ends face each other along the line, as where a row of one band
//! stops at the next band's edge and a row of the same direction starts across it) and the zig-zags' own turns,
//! shorter first; then the rest (other turns, links to a dot or to another family), shorter first. Every span is
//! drawn exactly once, so the ink is the spans' plus the granted connectors.
//!
//! Greedy matching is not the fewest strokes in every case (that is a path cover of the link graph), but it takes
//! rows straight through band edges first, keeps the zig-zags where nothing better offers, and is `O(n log n)` in
//! the spans.

use kurbo::Point;

use crate::geometry::union_find::UnionFind;

/// A span's two ends are `2 · span` and `2 · span + 1` (its start and its end).
type End = usize;

/// Whether the link from end `e` (of the span running `from → e`) to end `f` (of the span running `f → to`)
/// carries a row straight on: the spans are parallel, and the link leaves the first span forwards and enters the
/// second one forwards, running more along the rows than across them. A dot (a span of no length) goes with any
/// direction, so a row runs on through a dot in its way rather than past it.
fn straight_on(from: Point, e: Point, f: Point, to: Point) -> bool {
    let (s, t, w) = (e - from, to - f, f - e);
    let forward = |d: kurbo::Vec2| d.hypot2() == 0.0 || (w.dot(d) >= 0.0 && w.dot(d) >= w.cross(d).abs());
    let parallel = s.hypot2() == 0.0 || t.hypot2() == 0.0 || s.dot(t) > 0.999 * s.hypot() * t.hypot();
    parallel && forward(s) && forward(t)
}

/// Join the spans of `strokes` (polylines whose even segments are spans and odd ones links, as [`super::zigzag`]
/// draws them; a dot is a span whose two points are the same) into polylines of the same kind: every span once, in
/// some order and direction, consecutive spans linked by a straight connector. A link is one of the strokes' own or
/// at most `max_link` long with `inside(a, b)` accepting it.
pub fn join(strokes: &[Vec<Point>], max_link: f64, inside: impl Fn(Point, Point) -> bool) -> Vec<Vec<Point>> {
    let spans: Vec<(Point, Point)> = strokes.iter().flat_map(|s| s.chunks_exact(2).map(|p| (p[0], p[1]))).collect();
    let spans = &spans[..];
    let n = spans.len();
    let end = |e: End| if e.is_multiple_of(2) { spans[e / 2].0 } else { spans[e / 2].1 };
    // The far end of the span an end belongs to.
    let other = |e: End| e ^ 1;
    // Each candidate as one sort key (a row going on first, then shorter, then by its ends) and whether it is a
    // new link to test. The key packs `(not best, length, end, end)` into 128 bits in that order (a length is
    // non-negative, so its bits order as its value), so the sort compares integers, not tuples of floats: the
    // candidates of a dark photo's dense hatching number in the hundreds of thousands. Two entries share a key
    // only for the same pair of ends offered both as a stroke's own link and as a new one; whichever comes first,
    // the pair ends up linked when either may be.
    let key = |worse: bool, e: End, f: End| {
        let length = end(e).distance(end(f)).to_bits();
        let ends = |x: End| u128::from(u32::try_from(x).unwrap_or(u32::MAX));
        (u128::from(worse) << 127) | (u128::from(length) << 64) | (ends(e) << 32) | ends(f)
    };
    let mut ranked: Vec<(u128, bool)> = candidates(spans, max_link, &end)
        .into_iter()
        .map(|(e, f)| (key(!straight_on(end(other(e)), end(e), end(f), end(other(f))), e, f), true))
        .collect();
    // The strokes' own links: from each span's end to the next span's start.
    let mut first = 0;
    for s in strokes {
        let m = s.len() / 2;
        ranked.extend((first + 1..first + m).map(|i| (key(false, 2 * i - 1, 2 * i), false)));
        first += m;
    }
    ranked.sort_unstable();
    let mut link: Vec<Option<End>> = vec![None; 2 * n];
    // The chains built so far, as disjoint sets of spans (the key's ends are below 2^32, so are the spans).
    let mut chains = UnionFind((0..u32::try_from(n).unwrap_or(u32::MAX)).collect());
    for (k, new) in ranked {
        #[allow(clippy::cast_possible_truncation)] // the key's low words are the two ends, each below 2^32
        let (ei, fi) = ((k >> 32) as u32, k as u32);
        let (e, f) = (ei as End, fi as End);
        if link[e].is_some() || link[f].is_some() {
            continue;
        }
        let (ce, cf) = (chains.find(ei / 2), chains.find(fi / 2));
        if ce == cf || (new && !inside(end(e), end(f))) {
            continue;
        }
        chains.0[ce as usize] = cf;
        link[e] = Some(f);
        link[f] = Some(e);
    }
    // Walk each chain from a span end nobody links to (every chain has two: no loops were closed).
    let mut drawn = vec![false; n];
    let mut out = Vec::new();
    for (start, linked) in link.iter().enumerate() {
        if drawn[start / 2] || linked.is_some() {
            continue;
        }
        let mut line = Vec::new();
        let mut e = start;
        loop {
            drawn[e / 2] = true;
            line.push(end(e));
            line.push(end(other(e)));
            match link[other(e)] {
                Some(f) => e = f,
                None => break,
            }
        }
        out.push(line);
    }
    out
}

/// Every pair of ends of different spans at most `max_link` apart, each pair once (the lower end first), found in a
/// grid of `max_link` cells.
fn candidates(spans: &[(Point, Point)], max_link: f64, end: &impl Fn(End) -> Point) -> Vec<(End, End)> {
    let ends = 2 * spans.len();
    if ends == 0 || max_link.is_nan() || max_link <= 0.0 {
        return Vec::new();
    }
    let cell = |p: Point| {
        #[allow(clippy::cast_possible_truncation)] // pixel coordinates over a link's length: small
        let c = ((p.x / max_link).floor() as i64, (p.y / max_link).floor() as i64);
        c
    };
    let mut keyed: Vec<((i64, i64), End)> = (0..ends).map(|e| (cell(end(e)), e)).collect();
    keyed.sort_unstable();
    let find = |c: (i64, i64)| {
        let lo = keyed.partition_point(|k| k.0 < c);
        let hi = keyed.partition_point(|k| k.0 <= c);
        &keyed[lo..hi]
    };
    let mut out = Vec::new();
    for &(c, e) in &keyed {
        let p = end(e);
        for dy in -1..=1 {
            for dx in -1..=1 {
                for &(_, f) in find((c.0 + dx, c.1 + dy)) {
                    if f > e && f / 2 != e / 2 && p.distance(end(f)) <= max_link {
                        out.push((e, f));
                    }
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(x: f64, y: f64) -> Point {
        Point::new(x, y)
    }

    /// Spans as `(x0, x1, y)` rows, drawn left to right, each a stroke of its own.
    fn rows(r: &[(f64, f64, f64)]) -> Vec<Vec<Point>> {
        r.iter().map(|&(a, b, y)| vec![p(a, y), p(b, y)]).collect()
    }

    /// The ink a polyline's links add: the length of its odd segments (the spans are its even ones).
    fn link_length(strokes: &[Vec<Point>]) -> f64 {
        strokes.iter().flat_map(|s| s.windows(2).skip(1).step_by(2).map(|w| (w[1] - w[0]).hypot())).sum()
    }

    fn spans_of(strokes: &[Vec<Point>]) -> usize {
        strokes.iter().map(|s| s.len() / 2).sum()
    }

    #[test]
    fn a_row_goes_straight_on_across_a_band_edge_before_it_turns() {
        // Band A (x 0..10, rows 1 apart at y 0 and 1) meets band B (x 12..20, rows at y 0.25 and 1.25). A's rows end
        // 1 from each other (a turn) and 2.02 from B's (straight on). Shortest first, A and B would each turn at
        // their shared edge and make two strokes; rows going on first make one: A's rows into B's, A's rows turned
        // at x 0 (as long as B's turn at x 20 and found first), and B's turn left out (it would close a loop).
        let spans = rows(&[(0.0, 10.0, 0.0), (0.0, 10.0, 1.0), (12.0, 20.0, 0.25), (12.0, 20.0, 1.25)]);
        let out = join(&spans, 2.5, |_, _| true);
        assert_eq!(out.len(), 1, "{out:?}");
        assert_eq!(spans_of(&out), 4);
        let s = &out[0];
        assert_eq!(s.first().map(|q| q.x), Some(20.0));
        assert_eq!(s.last().map(|q| q.x), Some(20.0));
        // Links: 2 × √(2² + 0.25²) straight on and 1 turn at x 0.
        assert!((link_length(&out) - (2.0 * 4.0625f64.sqrt() + 1.0)).abs() < 1e-9, "{}", link_length(&out));
    }

    #[test]
    fn links_are_refused_outside_too_far_or_into_a_loop() {
        let spans = rows(&[(0.0, 4.0, 0.0), (0.0, 4.0, 1.0), (10.0, 14.0, 0.0)]);
        // The third span is 6 from the nearest end: beyond the reach.
        assert_eq!(join(&spans, 3.0, |_, _| true).len(), 2);
        // Refused by the caller: every span alone.
        assert_eq!(join(&spans, 3.0, |_, _| false).len(), 3);
        // Two spans whose ends both meet form one stroke, not a loop: one of the two links is left out.
        let two = rows(&[(0.0, 4.0, 0.0), (0.0, 4.0, 1.0)]);
        let out = join(&two, 3.0, |_, _| true);
        assert_eq!((out.len(), out[0].len()), (1, 4), "{out:?}");
        // The ink: spans 4 + 4 and one link of 1.
        assert!((link_length(&out) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn a_dot_is_linked_through() {
        let spans =
            vec![vec![p(0.0, 0.0), p(4.0, 0.0)], vec![p(5.0, 0.0), p(5.0, 0.0)], vec![p(6.0, 0.0), p(9.0, 0.0)]];
        let out = join(&spans, 1.5, |_, _| true);
        assert_eq!(out.len(), 1);
        assert_eq!(out[0].len(), 6);
        assert!((link_length(&out) - 2.0).abs() < 1e-12);
    }

    #[test]
    fn a_zig_zag_keeps_its_own_links_past_the_reach() {
        // One stroke of two rows linked by a 3 long turn, and a reach of 1: the turn stays, the ink is unchanged.
        let zig = vec![vec![p(0.0, 0.0), p(4.0, 0.0), p(4.0, 3.0), p(0.0, 3.0)]];
        let out = join(&zig, 1.0, |_, _| false);
        assert_eq!(out, zig);
    }
}
