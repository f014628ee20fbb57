//! The least time a pen-up hop can take on a machine, from how far it goes along each axis: the one hop cost the
//! time bound ([`crate::motion::bound`]), its breakdown ([`crate::motion::gap`]) and the travel bound's searches
//! ([`crate::optimize::bound`]) all read.
//!
//! A hop covers `|dx|` mm of X and `|dy|` mm of Y, whatever path it takes. Three things bound its time, each valid
//! for any path between its ends, so their largest is too:
//!
//! * **X alone**: the X carriage covers `|dx|` moving no faster than X's speed limit (and the travel feed: an
//!   axis's speed is a share of the path's), speeding up and slowing down no harder than X's acceleration (and
//!   the travel acceleration cap, `pen.travel_accel_mm_s2`, a limit along the path in any direction), starting and
//!   ending no faster than the hop itself may start and end. That is a one-dimensional motion, whose least time is
//!   a trapezoid (or a triangle): accelerate, cruise, decelerate.
//! * **Y alone**: the same with Y's limits over `|dy|`.
//! * **The path**: the path is at least `√(dx² + dy²)` long, the pen's speed along it is at most the travel feed
//!   and changes no faster than the largest acceleration any direction allows (`√(a_x² + a_y²)`, or the cap where
//!   lower).
//!
//! Along one axis the X term is the tightest of the three (a 30 mm hop along X on axes of 760 mm/s² each takes at
//! least X's 760 mm/s² trapezoid, not the diagonal's 1075 mm/s²); on a diagonal the path term may be.
//!
//! **Where the hop starts and ends.** A servo pen's hop runs from rest to rest (its servo blocks are stops); a Z
//! pen's hop starts and ends at the corner with the pen's Z moves ([`crate::motion::bound`]), or, with the curve
//! model on, at up to the slower of the Z and travel feeds. Each axis's share of that speed is no more than the
//! whole. The plan's hop runs between stroke ends rounded to steps, which may shorten a hop by up to a step
//! along each axis at each end: each axis's distance is taken two of its steps short, the path's two step
//! diagonals short.
//!
//! **A Z pen's hop bends.** It climbs over the paper at a slope `s` ([`crate::motion::hop`]): its blocks are tilted
//! by up to `atan(2s)` out of the paper's plane, and where the tilt changes, the pen's speed along the path is
//! kept but the share of it that X carries grows or shrinks by the cosine of the tilt. Measured against the
//! pen's speed along the path (continuous, and speeding up no harder than each block's limits, which are at most
//! X's limits divided by X's share of that block), X moves no faster than its limits times `1/cos(atan 2s)` =
//! `√(1 + 4s²)`: the X and Y terms of a Z pen take their limits that much higher (0.5 % at the XY kit's
//! 0.052). A servo pen's hop is one straight block (or collinear parts of it): no bend.
//!
//! **A drop the motion stops for.** Where the firmware runs a servo command only with the carriage at rest
//! ([`ServoSync::AtRest`], GRBL's `M3`), the drop cannot be commanded on the way: the hop's travel either arrives
//! whole and the drop is commanded there, or it stops part way (a split), the drop is commanded, and the rest
//! follows from rest, arriving by the tip's earliest contact ([`crate::motion::plan`]). Count time `t` from the end
//! of the lift's clear wait (`c` ticks after the lift command); a drop commanded then has its earliest and latest
//! contact `E(t)`, `L(t)` after the command ([`crate::motion::servo::ServoTiming::contact_window`], the servo
//! taken as fully down when lifted: the earliest latest), both never falling as `t` grows (the servo has risen
//! further). A hop whose first part takes `t₁` and whose second takes `t₂` (zero without a split) starts its
//! line at `t₁ + max(L(t₁), t₂ + 1 tick)` with `t₂ + 1 tick ≤ E(t₁)`: the line starts no sooner than
//! `t₁ + L(t₁)`, and the second part lasts under `E(t₁)`. Each part is a motion from rest to rest, which covers
//! along one axis (or the path) at most `ℓ(t) = a·t²/4` in `t ≤ 2v/a` and `v·t − v²/a` beyond, for the term's
//! top speed `v` and acceleration `a` (with a tick more for the rounding of a block's duration); the two parts
//! together cover the term's distance `d` (taken short as above). So a split at `t₁` needs
//! `ℓ(t₁) + ℓ(E(t₁)) ≥ d`, which holds from some least `t₁*` on (both sides grow with `t₁`), and the line starts
//! no sooner than `t₁* + L(t₁*)`: the best split can do no better. On a servo of one steady rate lifted from fully
//! down, `E(t) = L(t) = min(t, W)` with `W` the drop from fully up (the servo has risen `t` past the contact and
//! comes back as fast): while the halves of the hop take `T(d/2) ≤ W` the least is the even split, `2·T(d/2)`; a
//! longer hop is best cut where its last `ℓ(W)` mm start, `T(d − ℓ(W)) + W`, against the whole travel `T(d)` the
//! drop in motion needs (a 30 mm hop along X on the servo kit: 0.2956 + 0.105 s, 71 ms above its 0.3298 s of
//! travel). The time is tabled on the 0.1 ms grid of `t₁` (each cell charged the latest `E` and the least
//! `t + L` within it), the least over the profile's pens, each term (X, Y, the path) on its own and the largest
//! taken, less the drop's share of the lifts part.
//!
//! **One cost, symmetric.** The time depends on `|dx|` and `|dy|` only, so a hop from `a` to `b` costs what the
//! hop from `b` to `a` costs, and it never falls when either distance grows. That is all the travel bound's
//! spanning trees, penalized trees and exact search need ([`crate::optimize::bound`]): a tree of symmetric hop
//! costs is a bound on any route's hops whatever the costs' geometry, and a subtree of a k-d tree whose box lies
//! `bx`, `by` from a point holds no point cheaper than the cost of `(bx, by)`.

use plotter_fw::TICK_HZ;

use crate::MachineProfile;
use crate::config::servo_sync::ServoSync;
use crate::motion::piece_time::{
    clearance_mm, corner_speed, fastest_piece, hop_corner_speed, path_accel, servo_timings, servo_waits, z_join_speeds,
    z_joins_may_curve,
};

/// One axis's limits for a hop: top speed, acceleration, and the distance its steps' rounding may take off.
#[derive(Debug, Clone, Copy, PartialEq)]
struct AxisLimit {
    top: f64,
    accel: f64,
    slack: f64,
}

/// What a hop adds to the pen's moves beyond the lifts part's shares (see the module docs), seconds.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct PenExtra {
    /// The lift out of the paper into the hop (a Z pen's rise into a corner): only on a hop that starts with a
    /// lift from the paper.
    pub(crate) lift_s: f64,
    /// The drop (a Z pen's drop out of a corner): on every hop into a stroke.
    pub(crate) drop_s: f64,
    /// The drop's wait that only a lift just before it forces (a servo's wider contact window): only on a hop
    /// that starts with a lift from the paper.
    pub(crate) drop_after_lift_s: f64,
}

impl PenExtra {
    /// All of it.
    pub(crate) fn total_s(&self) -> f64 {
        self.lift_s + self.drop_s + self.drop_after_lift_s
    }

    /// The part a hop that does not start with a lift from the paper does not have.
    pub(crate) fn after_lift_s(&self) -> f64 {
        self.lift_s + self.drop_after_lift_s
    }
}

/// A Z pen's corners at the joins of a long hop (curve model on): see the module docs.
#[derive(Debug, Clone, Copy, PartialEq)]
struct ZCorners {
    /// Hops longer than this (mm, as the drawing gives them) have corners at both joins.
    from_mm: f64,
    /// The speed at those corners, mm/s.
    speed: f64,
    /// What the corner adds to the rise before the hop and to the drop after it, seconds.
    rise_s: f64,
    drop_s: f64,
}

/// A servo pen's least time from the end of the lift's clear wait to the line's start, as a function of the
/// travel between (see the module docs): `least[i]` is for a travel of at least `i · GRID` ticks, less the drop's
/// share of the lifts part; beyond the table it is the travel plus `tail`.
#[derive(Debug, Clone, PartialEq)]
struct ServoWindow {
    least: Vec<f64>,
    tail: f64,
}

/// The servo table's step, ticks (0.1 ms).
const GRID: u64 = 100;

impl ServoWindow {
    /// The table of `profile`'s servo (see [`ServoWindow`]).
    fn of(profile: &MachineProfile) -> ServoWindow {
        let (_, window) = servo_waits(profile);
        // The drop's share of the lifts part: the command's tick and the narrowest window.
        let share = 1 + window;
        #[allow(clippy::cast_precision_loss, reason = "tick counts are far below 2^52")]
        let secs = |t: u64, minus: u64| (t as f64 - minus as f64) / f64::from(TICK_HZ);
        let mut tables: Vec<(Vec<f64>, f64)> = Vec::new();
        for timing in servo_timings(profile) {
            let clear = crate::motion::plan::lift_clear_ticks(profile, timing).max(1);
            let window = |d: u64| timing.contact_window(Some((d, 1.0)));
            let up = timing.contact_window(None);
            // The least drop time D (from the lift command) whose earliest contact comes at or after the
            // carriage's arrival, clear + τ: D + earliest(D) never falls as D grows, so D only moves on, to the
            // least D that reaches (a search between the last D and one the deficit further on, which reaches).
            let reaches = |d: u64, tau: u64| d + window(d).0 >= clear + tau;
            let mut d = clear;
            let mut least = Vec::new();
            let mut tau = 0u64;
            loop {
                if !reaches(d, tau) {
                    let (mut lo, mut hi) = (d, clear + tau);
                    while hi - lo > 1 {
                        let mid = lo + (hi - lo) / 2;
                        if reaches(mid, tau) { hi = mid } else { lo = mid }
                    }
                    d = hi;
                }
                let w = window(d);
                // From lift command to line start D + latest(D), less the clear wait and the drop's share.
                least.push(secs(d + w.1, clear + share));
                if w == up && d + w.0 == clear + tau {
                    // The servo is all the way up and the drop waits for nothing else: every later drop sees the
                    // same window at D = clear + τ − earliest, and the line starts τ plus a constant after the
                    // clear wait.
                    let tail = secs(d + w.1, clear + share + tau);
                    tables.push((least, tail));
                    break;
                }
                tau += GRID;
            }
        }
        let n = tables.iter().map(|t| t.0.len()).max().unwrap_or(0);
        #[allow(clippy::cast_precision_loss, reason = "table indices are small")]
        let at = |t: &(Vec<f64>, f64), i: usize| {
            t.0.get(i).copied().unwrap_or((i as u64 * GRID) as f64 / f64::from(TICK_HZ) + t.1)
        };
        let least = (0..n).map(|i| tables.iter().map(|t| at(t, i)).fold(f64::INFINITY, f64::min)).collect();
        let tail = tables.iter().map(|t| t.1).fold(f64::INFINITY, f64::min);
        ServoWindow { least, tail }
    }

    /// The least time of the travel and the drop's wait beyond its share, for a travel of at least `travel_s`
    /// seconds: never below the travel, never falling as it grows.
    fn with_travel(&self, travel_s: f64) -> f64 {
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss, reason = "a hop's ticks, far in range")]
        let i = (travel_s.max(0.0) * f64::from(TICK_HZ) / GRID as f64).floor() as usize;
        #[allow(clippy::cast_precision_loss, reason = "table indices are small")]
        let least = self.least.get(i).copied().unwrap_or((i as u64 * GRID) as f64 / f64::from(TICK_HZ) + self.tail);
        travel_s.max(least)
    }
}

/// A servo pen's drop on a firmware that stops the motion for it (see the module docs): per pen, a table of the
/// drop's earliest and latest contact by when (after the lift's clear wait) it is commanded.
#[derive(Debug, Clone, PartialEq)]
struct RestDrop {
    /// One table per pen the profile names.
    pens: Vec<RestTable>,
    /// The drop's share of the lifts part (its command's tick and the narrowest window), seconds.
    share: f64,
}

/// One pen's drop at rest, seconds; cell `j` holds the drops commanded `j·GRID` to `(j + 1)·GRID` ticks after
/// the lift's clear wait.
#[derive(Debug, Clone, PartialEq)]
struct RestTable {
    /// The earliest contact of a drop commanded at the cell's end: the latest of any drop in the cell.
    earliest: Vec<f64>,
    /// The cell's start plus the latest contact of a drop commanded then: the least line start of any drop in the
    /// cell, counted from the clear wait's end.
    start: Vec<f64>,
    /// From the table's end on (the servo all the way up): the latest earliest contact and the least latest.
    up: (f64, f64),
    /// The latest contact of any drop (from fully up).
    most_latest: f64,
}

/// The most cells of a [`RestTable`]: 10 s.
const REST_CELLS: usize = 100_000;

/// The farthest a motion from rest to rest goes in `t` seconds at top speed `v` and acceleration `a`, mm.
fn rest_reach(t: f64, v: f64, a: f64) -> f64 {
    if t <= 2.0 * v / a { a * t * t / 4.0 } else { v * t - v * v / a }
}

impl RestDrop {
    /// The tables of `profile`'s servo pens.
    fn of(profile: &MachineProfile) -> RestDrop {
        let (_, window) = servo_waits(profile);
        let pens = servo_timings(profile)
            .map(|timing| {
                let clear = crate::motion::plan::lift_clear_ticks(profile, timing).max(1);
                let window = |t: u64| timing.contact_window(Some((clear + t, 1.0)));
                let up = timing.contact_window(None);
                let (mut earliest, mut start) = (Vec::new(), Vec::new());
                let mut t = 0;
                // Until the servo is all the way up; a servo that does not move (a down angle equal to the up
                // angle) never gets there: cut at REST_CELLS, the tail taking the earliest contact from fully up
                // (the latest there is) and the latest at the cut (the least after it).
                while window(t) != up && earliest.len() < REST_CELLS {
                    earliest.push(secs(window(t + GRID).0));
                    start.push(secs(t + window(t).1));
                    t += GRID;
                }
                RestTable { earliest, start, up: (secs(up.0), secs(window(t).1)), most_latest: secs(up.1) }
            })
            .collect();
        RestDrop { pens, share: secs(1 + window) }
    }

    /// The least time from the lift's clear wait to the line's start, less the drop's share, of a hop whose
    /// terms (X, Y, the path) are `(distance, top speed, acceleration)`: see the module docs.
    fn seconds(&self, terms: &[(f64, f64, f64)]) -> f64 {
        let tick = 1.0 / f64::from(TICK_HZ);
        let least = |t: &RestTable, (d, v, a): (f64, f64, f64)| {
            let reach = |s: f64| rest_reach(s + tick, v, a);
            #[allow(clippy::cast_precision_loss, reason = "table indices are small")]
            let end = |j: usize| ((j as u64 + 1) * GRID) as f64 * tick;
            let fits = |j: usize| reach(end(j)) + reach(t.earliest[j]) >= d;
            let (mut lo, mut hi) = (0, t.earliest.len());
            while lo < hi {
                let mid = lo + (hi - lo) / 2;
                if fits(mid) { hi = mid } else { lo = mid + 1 }
            }
            if let Some(s) = t.start.get(lo) {
                return *s;
            }
            // The servo all the way up: the first part covers what the last, under the earliest contact, cannot.
            #[allow(clippy::cast_precision_loss, reason = "table indices are small")]
            let sat = (t.start.len() as u64 * GRID) as f64 * tick;
            let first = fastest_piece((d - reach(t.up.0)).max(0.0), 0.0, 0.0, v, a) - tick;
            first.max(sat) + t.up.1
        };
        let most = |t: &RestTable| terms.iter().map(|&term| least(t, term)).fold(0.0, f64::max);
        self.pens.iter().map(most).fold(f64::INFINITY, f64::min) - self.share
    }

    /// The most [`RestDrop::seconds`] exceeds the hop's travel: the latest contact from fully up, less the share.
    fn excess(&self) -> f64 {
        self.pens.iter().map(|t| t.most_latest).fold(0.0, f64::max) - self.share
    }
}

/// `ticks` in seconds.
fn secs(ticks: u64) -> f64 {
    #[allow(clippy::cast_precision_loss, reason = "tick counts are far below 2^52")]
    let s = ticks as f64 / f64::from(TICK_HZ);
    s
}

/// The least time of a pen-up hop on one profile (see the module docs), seconds; build once with
/// [`HopTime::of`], then ask [`HopTime::seconds`] per hop.
#[derive(Debug, Clone, PartialEq)]
pub struct HopTime {
    /// The speed the hop may start and end at, mm/s (a Z pen's short hop, see [`ZCorners`] for a long one).
    v_end: f64,
    /// The travel feed, mm/s.
    feed: f64,
    /// The largest acceleration along the path, mm/s².
    accel: f64,
    /// What the steps' rounding may take off the path's length, mm.
    slack: f64,
    /// X's and Y's limits.
    axes: [AxisLimit; 2],
    /// A Z pen's corners at a long hop's joins, where its short hops' joins may be curve points.
    corners: Option<ZCorners>,
    /// A servo pen's drop window after the lift, where the drop is commanded on the way.
    servo: Option<ServoWindow>,
    /// A servo pen's drop where the motion stops for it ([`ServoSync::AtRest`]).
    rest: Option<RestDrop>,
}

impl HopTime {
    /// The hop time of `profile`.
    pub fn of(profile: &MachineProfile) -> HopTime {
        let cap = profile.pen.travel_accel_mm_s2;
        let accel = path_accel(profile, cap);
        let feed = profile.pen.travel_feed_mm_s;
        let servo = profile.pen.uses_servo();
        let z = &profile.axes.z;
        // The corner between a Z move and a travel, at Z's acceleration (the planner corners at the lower of its
        // two blocks', and a Z-only block has Z's), with a part in 10⁵ for the planner's single precision.
        let corner = hop_corner_speed(profile, z.max_accel_mm_s2.min(accel)) * (1.0 + 1e-5);
        // A servo's blocks are stops (its Z feed is bookkeeping only), whatever the curve model says of Z joins.
        let v_end = if servo {
            0.0
        } else if z_joins_may_curve(profile) {
            feed.min(z.max_feed_mm_s)
        } else {
            corner
        };
        let tilt = if servo { 1.0 } else { (2.0 * crate::motion::hop::rise_slope(profile)).hypot(1.0) };
        let axis = |a: &crate::config::profile::AxisProfile| AxisLimit {
            top: a.max_feed_mm_s.min(feed) * tilt,
            accel: cap.map_or(a.max_accel_mm_s2, |c| a.max_accel_mm_s2.min(c)) * tilt,
            slack: 2.0 / a.steps_per_mm,
        };
        let (x, y) = (&profile.axes.x, &profile.axes.y);
        let slack = 2.0 * (1.0 / x.steps_per_mm).hypot(1.0 / y.steps_per_mm);
        let corners =
            (!servo && z_joins_may_curve(profile)).then(|| z_corners(profile, corner.min(v_end), slack)).flatten();
        let at_rest = profile.servo_sync == ServoSync::AtRest;
        let rest = (servo && at_rest).then(|| RestDrop::of(profile));
        let servo = (servo && !at_rest).then(|| ServoWindow::of(profile));
        HopTime { v_end, feed, accel, slack, axes: [axis(x), axis(y)], corners, servo, rest }
    }

    /// The speed a hop of `len` mm may start and end at.
    fn v_end_of(&self, len: f64) -> f64 {
        match self.corners {
            Some(c) if len > c.from_mm => c.speed,
            _ => self.v_end,
        }
    }

    /// The least time of a hop of `dx` × `dy` mm (signs ignored): its travel ([`travel_seconds`]) and what it
    /// adds to the pen's moves ([`pen_extra`]).
    ///
    /// [`travel_seconds`]: Self::travel_seconds
    /// [`pen_extra`]: Self::pen_extra
    pub fn seconds(&self, dx: f64, dy: f64) -> f64 {
        let travel = self.travel_seconds(dx, dy);
        travel + self.pen_extra(dx, dy, travel).total_s()
    }

    /// The least time of the travel blocks alone of a hop of `dx` × `dy` mm: the largest of X's, Y's and the
    /// path's terms.
    pub fn travel_seconds(&self, dx: f64, dy: f64) -> f64 {
        let v = self.v_end_of(dx.hypot(dy));
        let along = |d: f64, a: &AxisLimit| fastest_piece((d.abs() - a.slack).max(0.0), v, v, a.top, a.accel);
        self.path_term(dx.hypot(dy)).max(along(dx, &self.axes[0])).max(along(dy, &self.axes[1]))
    }

    /// The path's term of the travel of a hop `d` mm long.
    fn path_term(&self, d: f64) -> f64 {
        let v = self.v_end_of(d);
        fastest_piece((d - self.slack).max(0.0), v, v, self.feed, self.accel)
    }

    /// What a hop of `dx` × `dy` mm whose travel takes `travel_s` seconds adds to the pen's moves beyond the
    /// lifts part's shares (see the module docs).
    pub(crate) fn pen_extra(&self, dx: f64, dy: f64, travel_s: f64) -> PenExtra {
        let len = dx.hypot(dy);
        if let Some(c) = self.corners.filter(|c| len > c.from_mm) {
            return PenExtra { lift_s: c.rise_s, drop_s: c.drop_s, drop_after_lift_s: 0.0 };
        }
        if let Some(r) = &self.rest {
            let [x, y] = self.axes;
            let term = |d: f64, a: &AxisLimit| ((d.abs() - a.slack).max(0.0), a.top, a.accel);
            let terms = [term(dx, &x), term(dy, &y), ((len - self.slack).max(0.0), self.feed, self.accel)];
            return PenExtra { drop_after_lift_s: (r.seconds(&terms) - travel_s).max(0.0), ..PenExtra::default() };
        }
        match &self.servo {
            Some(w) => PenExtra { drop_after_lift_s: w.with_travel(travel_s) - travel_s, ..PenExtra::default() },
            None => PenExtra::default(),
        }
    }

    /// The most [`seconds`](Self::seconds) charges any hop for a lift from the paper just before it: what the
    /// plot's first hop (from where the machine stands, the pen up) and a hop after a pen change (the pen fully
    /// up) are charged without having it.
    pub fn lift_excess(&self) -> f64 {
        let corner = self.corners.map_or(0.0, |c| c.rise_s);
        let window = self.servo.as_ref().map_or(0.0, |w| {
            #[allow(clippy::cast_precision_loss, reason = "table indices are small")]
            let grid = |i: usize| (i as u64 * GRID) as f64 / f64::from(TICK_HZ);
            w.least.iter().enumerate().map(|(i, l)| l - grid(i)).fold(w.tail, f64::max).max(0.0)
        });
        let rest = self.rest.as_ref().map_or(0.0, |r| r.excess().max(0.0));
        corner.max(window).max(rest)
    }

    /// The path's term alone: the least time of a hop at least `d` mm long in any direction (the least of
    /// [`seconds`](Self::seconds) over the hops of that length). Non-decreasing in `d`.
    pub fn along_path(&self, d: f64) -> f64 {
        let travel = self.path_term(d);
        let extra = match &self.rest {
            Some(r) => (r.seconds(&[((d - self.slack).max(0.0), self.feed, self.accel)]) - travel).max(0.0),
            None => self.pen_extra(d, 0.0, travel).total_s(),
        };
        travel + extra
    }
}

/// A Z pen's corners at a long hop's joins (see the module docs), with `speed` the corner's and `slack` what the
/// steps' rounding may take off a hop's length; `None` where every hop's joins may be curve points.
fn z_corners(profile: &MachineProfile, speed: f64, slack: f64) -> Option<ZCorners> {
    let (z, s) = (&profile.axes.z, crate::motion::hop::rise_slope(profile));
    // The shortest chord beside a join that makes it surely a corner: the planner's curve rule 1 takes a vertex
    // of turn φ as a curve point while half the shorter chord times tan(φ/4) is within the curve deviation; the
    // hop's blocks tilt by at most atan(2s), so φ ≥ 90° − atan(2s); a part in a thousand for single precision.
    let turn = std::f64::consts::FRAC_PI_2 - (2.0 * s).atan();
    let chord = 2.0 * profile.motion.curve_deviation_mm * 1.001 / (turn / 4.0).tan();
    // The rise (and the drop) is at least the clearance; the first (and last) travel block runs at least to the
    // hop's middle or to where it reaches the pen-up height (`top / s` along it), less half a step diagonal of
    // its bend's rounding.
    let c_mm = clearance_mm(profile);
    let sz = z.steps_per_mm;
    let c_steps = (profile.pen.clearance_mm * sz).round().max(1.0) / sz;
    let top = std::iter::once(profile.pen.down_z_mm)
        .chain(profile.pens.iter().filter_map(|p| p.down_z_mm))
        .map(|d| (profile.pen.up_z_mm - d).abs() - 1.0 / sz - c_steps)
        .fold(f64::INFINITY, f64::min)
        .max(0.0);
    let r = 0.5 * (1.0 / profile.axes.x.steps_per_mm).hypot(1.0 / profile.axes.y.steps_per_mm);
    if c_mm <= chord || top / s - r <= chord {
        return None;
    }
    let (v_in, v_hop) = z_join_speeds(profile);
    let speed = speed.min(v_hop);
    let (vz, az) = (z.max_feed_mm_s, z.max_accel_mm_s2);
    // The rise from a stroke's end at the most the lifts part allows there (a curve point's, or a corner's), into
    // the corner rather than at the lifts part's speed: the least of both differences.
    let rise = |v0: f64| fastest_piece(c_mm, v0, speed, vz, az) - fastest_piece(c_mm, v0, v_hop, vz, az);
    let rise_s = rise(v_in).min(rise(corner_speed(az, profile.motion.junction_deviation_mm))).max(0.0);
    let drop_s = (fastest_piece(c_mm, speed, 0.0, vz, az) - fastest_piece(c_mm, v_hop, 0.0, vz, az)).max(0.0);
    Some(ZCorners { from_mm: 2.0 * (chord + r) + slack, speed, rise_s, drop_s })
}

impl crate::optimize::hop_cost::HopCost for HopTime {
    fn cost(&self, dx: f64, dy: f64) -> f64 {
        self.seconds(dx, dy)
    }

    fn along(&self, d: f64) -> f64 {
        self.along_path(d)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The servo kit: samples/servo-plotter.toml (the XY kit's axes, 80 steps/mm, 150 mm/s and 1500 mm/s² each,
    /// travel at 120 mm/s, a servo pen).
    fn servo_kit() -> MachineProfile {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../samples/servo-plotter.toml");
        MachineProfile::from_toml(&std::fs::read_to_string(&dir).unwrap(), "servo-plotter.toml").unwrap()
    }

    #[test]
    fn a_hop_along_x_takes_x_s_own_acceleration() {
        let p = servo_kit();
        assert!(p.pen.uses_servo());
        assert_eq!((p.axes.x.max_accel_mm_s2, p.axes.x.max_feed_mm_s, p.pen.travel_feed_mm_s), (1500.0, 150.0, 120.0));
        assert_eq!(p.pen.travel_accel_mm_s2, None);
        let hop = HopTime::of(&p);
        // 30 mm along X from rest to rest, less two X steps (0.025 mm): 29.975 mm at X's 1500 mm/s² up to the
        // 120 mm/s travel feed: ramps of 120²/1500 = 9.6 mm in all, 0.16 s; cruise 20.375 mm at 120 mm/s,
        // 0.169 79 s: 0.329 79 s. The path's term alone (the diagonal's 2121.3 mm/s², 30 mm less two step
        // diagonals, 29.9646 mm): ramps of 6.788 mm, 0.113 14 s, cruise 0.193 14 s: 0.306 27 s, which is all the
        // bound took before.
        let t = hop.seconds(30.0, 0.0);
        assert!((t - 0.329_79).abs() < 1e-5, "{t}");
        assert!((hop.along_path(30.0) - 0.306_27).abs() < 1e-5, "{}", hop.along_path(30.0));
        // Direction does not matter, nor sign, nor which axis (Y has the same limits).
        assert_eq!(hop.seconds(-30.0, 0.0), t);
        assert_eq!(hop.seconds(0.0, 30.0), t);
    }

    #[test]
    fn on_grbl_a_hop_stops_for_the_drop_and_is_charged_the_best_split() {
        // The servo kit planned for GRBL, whose M3 waits for the moves before it: the drop is commanded with the
        // carriage at rest. The servo turns 1/150 000 of its swing per tick, so a drop commanded t after the
        // lift's clear wait (the servo 0.3 up, at the contact) touches t later (it rose t past the contact),
        // at most W = 0.7 × 150 ms = 105 ms (from fully up, 150 ms after the lift).
        let grbl = MachineProfile { servo_sync: ServoSync::AtRest, ..servo_kit() };
        let hop = HopTime::of(&grbl);
        // 30 mm along X (29.975 mm less the steps' rounding; X's 1500 mm/s² and the 120 mm/s feed): the halves,
        // 14.99 mm each, take 0.2049 s > W, so the best split leaves the last ℓ(W) = 1500·0.105²/4 = 4.1344 mm
        // to follow the drop: T(25.8406 mm) = 25.8406/120 + 120/1500 = 0.295 34 s, then W: 0.400 34 s (less the
        // drop's 1-tick share the lifts part counts), where the drop in motion needs the travel alone, 0.329 79 s.
        // (The plan's hop: 445.6 ms less the 45 ms clear wait, 400.6 ms.)
        let t = hop.seconds(30.0, 0.0);
        assert!((t - 0.400_34).abs() < 1e-5, "{t}");
        assert!((HopTime::of(&servo_kit()).seconds(30.0, 0.0) - 0.329_79).abs() < 1e-5);
        // 2 mm along X (1.975 mm): the halves take T(0.9875) = 2·√(0.9875/1500) = 51.32 ms ≤ W, so the even split,
        // 102.63 ms, against the travel's 72.57 ms; the table's 0.1 ms grid takes up to two cells off.
        let t = hop.seconds(2.0, 0.0);
        let even = 2.0 * 2.0 * (0.9875f64 / 1500.0).sqrt();
        assert!(t <= even && t > even - 3e-4, "{t} vs {even}");
        // A hop with no lift before it (the first, one after a pen change) is given back at most the drop from
        // fully up of the kit's slowest pen: its brush, down at 25°, swings 65° at the same rate, 0.7 × 162.5 ms.
        assert!((hop.lift_excess() - 0.113_75).abs() < 1e-5, "{}", hop.lift_excess());
        let mut last = 0.0;
        for i in 0..400 {
            let d = f64::from(i) * 0.1;
            let t = hop.seconds(d, 0.3 * d);
            assert!(t >= last && hop.along_path(d.hypot(0.3 * d)) <= t, "{d}: {t} < {last}");
            last = t;
        }
    }

    #[test]
    fn a_30_by_40_diagonal_is_bounded_by_its_path_at_the_travel_feed() {
        let hop = HopTime::of(&servo_kit());
        // Y covers 40 − 0.025 = 39.975 mm at 1500 mm/s² up to 120 mm/s: 0.16 s of ramps (9.6 mm), 30.375 mm at
        // 120 mm/s, 0.253 13 s: 0.413 13 s. X's 29.975 mm take 0.329 79 s (above). The path, 50 − 0.0354 =
        // 49.9646 mm at 2121.3 mm/s²: 0.113 14 s of ramps (6.788 mm) and 43.176 mm cruising, 0.359 80 s:
        // 0.472 94 s, the largest: a diagonal moves both axes at once and the path's feed limits it.
        let t = hop.seconds(30.0, 40.0);
        assert!((t - 0.472_94).abs() < 1e-5, "{t}");
        assert_eq!(t, hop.along_path(50.0));
        // A 30 × 4 mm hop: X's term 0.329 79 s is above the path's (30.27 mm at the diagonal's acceleration).
        let t = hop.seconds(30.0, 4.0);
        assert!((t - 0.329_79).abs() < 1e-5, "{t}");
        assert!(hop.along_path(30f64.hypot(4.0)) < t - 0.02);
    }

    #[test]
    fn short_hops_are_triangles_and_never_fall_as_either_distance_grows() {
        let hop = HopTime::of(&servo_kit());
        // 2 mm along X: 1.975 mm from rest to rest at 1500 mm/s², never reaching the feed: 2·√(1.975/1500) =
        // 0.072 572 s.
        assert!((hop.seconds(2.0, 0.0) - 0.072_572).abs() < 1e-6, "{}", hop.seconds(2.0, 0.0));
        // Within the rounding slack: nothing is certain of the travel (the servo's drop wait may add a tick or
        // two after a lift).
        assert_eq!(hop.travel_seconds(0.02, 0.02), 0.0);
        assert!(hop.seconds(0.02, 0.02) < 3e-6, "{}", hop.seconds(0.02, 0.02));
        let mut last = 0.0;
        for i in 0..200 {
            let x = f64::from(i) * 0.37;
            let t = hop.seconds(x, 7.0);
            assert!(t >= last, "{x}: {t} < {last}");
            last = t;
        }
    }

    #[test]
    fn a_z_pen_s_axes_allow_for_the_hop_s_tilt() {
        // The XY kit (a Z pen, the curve model on): its short hops start and end at up to Z's 25 mm/s, and X's
        // limits count √(1 + 4s²) higher for the slope s = 0.051 67 of its climb: 1.005 32.
        let p = MachineProfile::default_plotter();
        let s = crate::motion::hop::rise_slope(&p);
        assert!((s - 0.051_67).abs() < 1e-5, "{s}");
        let k = (1.0 + 4.0 * s * s).sqrt();
        let hop = HopTime::of(&p);
        let by_hand = fastest_piece(1.0 - 2.0 / 80.0, 25.0, 25.0, 120.0 * k, 1500.0 * k);
        assert_eq!(hop.seconds(1.0, 0.0), by_hand);
        // 0.975 mm from 25 mm/s and back at 1507.99 mm/s², never reaching the feed: a peak of
        // √(1507.99 · 0.975 + 625) = 45.774 mm/s, 2 · 20.774 / 1507.99 = 0.027 55 s.
        assert!((by_hand - 0.027_55).abs() < 1e-5, "{by_hand}");
    }

    #[test]
    fn a_long_hop_of_the_xy_kit_pays_its_z_corners_a_short_one_may_curve() {
        // The XY kit (samples/xy-plotter.toml): Z at 25 mm/s and 500 mm/s², a 1 mm clearance, junction deviation
        // 0.02 mm, curve deviation 0.1 mm, the hop climbing at s = 0.051 67.
        let p = MachineProfile::default_plotter();
        let hop = HopTime::of(&p);
        // A join between the rise and the hop is a curve point only while half its shorter chord times tan(φ/4)
        // is within 0.1 mm, with the turn φ ≥ 90° − atan(2s) = 84.10°: chords up to 2 · 0.1 · 1.001 / tan 21.03° =
        // 0.520 96 mm. The rise is 1 mm; the hop's first block runs to its middle (or far up to the pen-up
        // height), less half a step diagonal (0.008 84 mm) of rounding: a hop longer than 2 · (0.520 96 +
        // 0.008 84) mm plus two step diagonals of its ends' rounding (0.035 36 mm), 1.094 75 mm, has corners at
        // both joins.
        let k = (1.0 + 4.0 * 0.051_67f64.powi(2)).sqrt();
        let curve = fastest_piece(1.09 - 0.025, 25.0, 25.0, 120.0 * k, 1500.0 * k);
        assert!((hop.seconds(1.09, 0.0) - curve).abs() < 1e-6, "{}", hop.seconds(1.09, 0.0));
        // The corner: v² = 500 · 0.02 · sin h / (1 − sin h), sin h = √((1 + sin atan 2s) / 2) = 0.742 56: 5.3707
        // mm/s. A 30 mm hop along X: 29.975 mm at X's limits (× 1.005 32 for the climb's tilt) from 5.3707 to
        // 5.3707 mm/s: ramps 2 · (14 553.8 − 28.845) / 3015.98 = 9.632 mm, 0.152 88 s; cruise 20.343 mm at
        // 120.639 mm/s, 0.168 63 s: 0.321 50 s.
        assert!((hop.travel_seconds(30.0, 0.0) - 0.321_50).abs() < 1e-5, "{}", hop.travel_seconds(30.0, 0.0));
        // The rise's 1 mm into the corner rather than at 25 mm/s: from the 90° corner out of a stroke (4.9135
        // mm/s), a triangle peaking at 22.945 mm/s, 0.071 21 s, against 0.056 14 s into 25 mm/s: 0.015 07 s (from
        // a curve point at 25 mm/s, 0.055 41 − 0.04 = 0.015 41 s, the larger). The drop's 1 mm from the corner to
        // rest: a triangle peaking at 22.680 mm/s, 0.079 98 s, against 0.065 s from 25 mm/s: 0.014 98 s.
        let e = hop.pen_extra(30.0, 0.0, 0.0);
        assert!((e.lift_s - 0.015_07).abs() < 1e-5 && (e.drop_s - 0.014_98).abs() < 1e-5, "{e:?}");
        let t = hop.seconds(30.0, 0.0);
        assert!((t - (0.321_50 + 0.015_07 + 0.014_98)).abs() < 2e-5, "{t}");
        // Before, the joins ran at 25 mm/s whatever the hop's length: 0.298 75 s.
        assert!(t > 0.298_75 + 0.05);
        // The plot's first hop starts with no lift from the paper: it is charged the rise's part at most.
        assert!((hop.lift_excess() - e.lift_s).abs() < 1e-12);
        // Never falling with the length, across the step at 1.094 75 mm too.
        let mut last = 0.0;
        for i in 0..400 {
            let d = f64::from(i) * 0.005;
            let t = hop.seconds(d, 0.0);
            assert!(t >= last && hop.along_path(d) <= t, "{d}: {t} < {last}");
            last = t;
        }
    }

    #[test]
    fn a_short_hop_on_an_ebb_pays_the_drop_window_a_lift_leaves() {
        // AxiDraw V3 (its MiniKit shares the servo): the EBB's 24 ms servo cycle of unknown phase, 1 ms of margin
        // each side; the servo rises 1618/5393 = 0.300 02 and lowers 0.200 07 of its travel per cycle, the tip
        // touching at 0.7. The lifts part charges each hop's lift 25 ms (one move, at most a cycle after the
        // command, and the margin) and its drop 25 ms (the command's tick and the narrowest window).
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../samples/axidraw-v3.toml");
        let p = MachineProfile::from_toml(&std::fs::read_to_string(&path).unwrap(), "axidraw-v3.toml").unwrap();
        let hop = HopTime::of(&p);
        // A drop commanded D ms after the lift's command finds the servo after 1 to 2 lift moves while D is 25 to
        // 47 ms: 0.7 or 0.4 down, so the tip touches from the board's first move (earliest 0) to 2 cycles and
        // the margin on (latest 49 ms). The carriage leaves 25 ms after the lift and must arrive by the earliest
        // contact, so a hop of no length has D = 25 ms and the line starts at 25 + 49 = 74 ms: 24 ms beyond the
        // two shares.
        assert!((hop.seconds(0.0, 0.0) - 0.024).abs() < 1e-9, "{}", hop.seconds(0.0, 0.0));
        // 0.2 mm along X: 0.175 mm (less two steps) from rest to rest at 760 mm/s², 2·√(0.175/760) = 30.35 ms.
        // Arriving by the earliest contact needs D + earliest(D) ≥ 25 + 30.3 ms: with the earliest 0 until 2
        // lift moves surely came (D ≥ 49 ms, earliest 23.001 ms), D = 49 ms; up to 3 lift moves may have come
        // then (the servo 0.1 down), 3 cycles down and the margin: latest 73 ms. The line starts at 122 ms:
        // 72 ms after the two shares' 50, where the bound took the travel alone (30.35 ms) before.
        assert!((hop.travel_seconds(0.2, 0.0) - 0.030_35).abs() < 1e-5, "{}", hop.travel_seconds(0.2, 0.0));
        assert!((hop.seconds(0.2, 0.0) - 0.072).abs() < 1e-9, "{}", hop.seconds(0.2, 0.0));
        // 1 mm: 71.6 ms of travel; D = 73 ms (3 lift moves surely came, earliest 47.001 ms), latest 4 cycles and
        // the margin, 97 ms: 170 ms, 120 ms after the shares.
        assert!((hop.seconds(1.0, 0.0) - 0.12).abs() < 1e-9, "{}", hop.seconds(1.0, 0.0));
        // 30 mm: the servo is all the way up long before; the window is the one after a full lift, 97 − 71.001
        // ms, a millisecond above its share (on the 0.1 ms grid of the travel's time, floored).
        let t = hop.travel_seconds(30.0, 0.0);
        assert!(hop.seconds(30.0, 0.0) - t < 0.001 && hop.seconds(30.0, 0.0) - t > 0.000_9, "{t}");
        // The first hop has no lift before it: it is charged the most a lift adds to any hop, 49 ms at most.
        assert!((hop.lift_excess() - 0.048_999).abs() < 1e-9, "{}", hop.lift_excess());
        let mut last = 0.0;
        for i in 0..400 {
            let d = f64::from(i) * 0.05;
            let t = hop.seconds(d, 0.0);
            assert!(t >= last && hop.along_path(d) <= t, "{d}: {t} < {last}");
            last = t;
        }
    }
}
