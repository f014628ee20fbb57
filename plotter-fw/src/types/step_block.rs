//! The step-block contract: what a [`StepBlock`] asks the stepper to do and exactly how long it takes.
//!
//! Shared by the firmware's executor ([`crate::stepper`]) and the host, which plans with the same code: the host
//! sums [`StepBlock::duration_ticks`] and gets the time the stepper takes, to the tick.
//!
//! # Timing (the formula the host reproduces)
//! The block's speed plan gives the major axis an entry rate `v0`, a cruise rate `vc`, an exit rate `v1` (step
//! events per second) and an acceleration `a` (events/s²). [`Profile::new`] turns it into a continuous trapezoid
//! over position `x ∈ [0, n]` (in events): accelerate from `v0` up to `x_a`, cruise at the peak `vp` up to
//! `x_d`, decelerate to `v1` at `x = n` (a triangle when `vc` is not reachable; `vp² = (2an + v0² + v1²)/2`).
//! Ideally, event `k` fires at the time the continuous motion passes position `k`:
//!
//! ```text
//! t(k) = (√(v0² + 2ak) − v0) / a                 k ≤ x_a   (accelerating)
//! t(k) = T_a + (k − x_a) / vp                     x_a < k ≤ x_d (cruising)
//! t(k) = T − (√(v1² + 2a(n − k)) − v1) / a       k > x_d   (decelerating, measured back from the end)
//! T    = (vp − v0)/a + (x_d − x_a)/vp + (vp − v1)/a
//! ```
//!
//! (the code avoids the cancellation of nearly equal numbers in these forms: `√(v² + 2ax) − v` is computed as
//! `2ax/(√(v² + 2ax) + v)`).
//!
//! # Step times: an integer recurrence (what the interrupt runs and the host sums)
//! The events are not timed by evaluating `t(k)` (a square root per event); when a block is pushed into the
//! stepper (main context), [`Profile::new`] cuts its events into at most [`MAX_SEGMENTS`] [`Segment`]s
//! `(count, interval, add)`, in the form Klipper's step queue uses: the segment's first event comes `interval`
//! after the previous one, and each following interval is `add` longer. Times are fixed point (`2^32` units per
//! tick, [`FRAC_BITS`]); the event fires at the high word of the running time, which starts half a tick in so
//! that the high word is the time rounded to a tick. The executor ([`Cursor::advance`]) keeps only the time's
//! fraction: per event one 32-bit add whose carry joins the interval's integer part (that is the difference of
//! the high words) and one 64-bit add of `add` to the interval; the stepper takes the events of a segment as
//! one run ([`Cursor::reserve`]), so it counts them with the count it keeps anyway.
//!
//! The segments: each ramp (acceleration, deceleration) is cut from its slow end on into segments as long as
//! their estimated interpolation error allows (at most [`RAMP_SEGMENTS`]; the bound of the error of a quadratic
//! through three points of `t ∝ √distance`, see `greedy_ramp`): single events near a standstill, where the
//! square root bends most, ever longer segments towards the fast end. A ramp that would need more (very long
//! ramps from rest) gets [`RAMP_SEGMENTS`] with boundaries spaced geometrically in the distance from the point
//! where its rate would be zero. The cruise is one segment with `add = 0` (exact), plus a one-event segment for
//! the event where the cruise begins. Each segment's `add` is fitted through `t(k)` at its start, middle and
//! end, and its `interval` so that its last event lands on `t(end)` (to `2^-32` tick). Measured against `t(k)`
//! in f64 (the proptest in this file, blocks up to 3000 events, rates up to 20 000/s): every event is within
//! 1 tick + 0.025 % of the block's ramp time + 2·10⁻⁶ of `t(k)` (f32 rounding) — on 20 000 random blocks the
//! worst event used 72 % of that —, and no interval is more than 2 % (plus one tick of rounding) shorter than
//! the cruise rate's.
//!
//! The contract: a block lasts exactly the sum of its recurrence's intervals, [`StepBlock::duration_ticks`],
//! computed in closed form from the segments (`count·interval + add·count(count−1)/2`, exact integers); the next
//! block starts at the previous block's last event. The segment computation is `f32` with the deterministic
//! [`crate::fmath::sqrt`] and integer arithmetic, so the host calling [`StepBlock::duration_ticks`] gets bit for
//! bit the time the firmware (or the simulator) takes: a sequence of blocks takes exactly the sum of their
//! durations. A feed hold computes its deceleration the same way ([`StepTimes::hold`]) when it is requested.
//!
//! A dwell (G4, pen settle) is a block with no steps that lasts its given number of ticks. A servo block is a dwell
//! that first drives the pen servo ([`crate::hal::StepPins::set_servo`]) to its angle: the settle time is its
//! dwell, so the pen moves exactly between the moves around it, in the stepper's own time line.

use crate::axis::{Axis, NUM_AXES};
use crate::fmath::{round_u32, sqrt};

/// Step timer frequency: one tick is one microsecond.
pub const TICK_HZ: u32 = 1_000_000;

/// Largest servo angle a block carries, tenths of a degree (180°).
pub const SERVO_TENTHS_MAX: u16 = 1800;

/// Highest step-event rate a block may ask for (events/s): at least 4 timer ticks between events.
pub const MAX_RATE: u32 = 250_000;

/// One straight move in steps with its speed plan, or a dwell (all steps zero, `dwell_ticks` > 0), or a servo-pen
/// block (a dwell with a servo angle).
///
/// Rates are step events of the major axis per second; `accel` is events/s². A block with `accel == 0` runs at
/// `cruise_rate` throughout.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct StepBlock {
    /// Signed steps per axis, indexed by [`Axis::index`].
    pub steps: [i32; NUM_AXES],
    /// Rate at the block start.
    pub entry_rate: u32,
    /// Cruise (nominal) rate; the peak of the trapezoid when reachable.
    pub cruise_rate: u32,
    /// Rate at the block end.
    pub exit_rate: u32,
    /// Acceleration.
    pub accel: u32,
    /// Duration of a dwell block (ignored when any axis moves).
    pub dwell_ticks: u32,
    /// A servo-pen block (no steps): the pen servo is driven to this angle, in tenths of a degree
    /// (0..=[`SERVO_TENTHS_MAX`]), when the block starts, and the block then lasts `dwell_ticks` (the settle time).
    pub servo: Option<u16>,
}

impl StepBlock {
    /// A dwell of `ticks` timer ticks.
    pub const fn dwell(ticks: u32) -> Self {
        StepBlock {
            steps: [0; NUM_AXES],
            entry_rate: 0,
            cruise_rate: 0,
            exit_rate: 0,
            accel: 0,
            dwell_ticks: ticks,
            servo: None,
        }
    }

    /// A servo-pen block: drive the pen servo to `tenths` of a degree, then wait `settle_ticks` timer ticks.
    pub const fn servo(tenths: u16, settle_ticks: u32) -> Self {
        StepBlock { servo: Some(tenths), ..StepBlock::dwell(settle_ticks) }
    }

    /// Number of step events (steps of the major axis).
    pub fn events(&self) -> u32 {
        self.steps.iter().map(|s| s.unsigned_abs()).max().unwrap_or(0)
    }

    /// Whether this block moves nothing and just waits.
    pub fn is_dwell(&self) -> bool {
        self.events() == 0
    }

    /// The speed profile the stepper executes.
    pub fn profile(&self) -> Profile {
        Profile::new(self.events(), self.entry_rate, self.cruise_rate, self.exit_rate, self.accel)
    }

    /// Exact execution time of this block, in timer ticks ([`TICK_HZ`]), as the stepper runs it (a dwell takes at
    /// least one tick).
    pub fn duration_ticks(&self) -> u32 {
        if self.is_dwell() { self.dwell_ticks.max(1) } else { self.profile().duration_ticks() }
    }

    /// Mask of axes that move.
    pub fn axis_mask(&self) -> u8 {
        Axis::ALL.iter().filter(|a| self.steps[a.index()] != 0).fold(0, |m, a| m | a.bit())
    }
}

/// Most segments an acceleration or deceleration ramp is cut into (a cruise is one more segment).
pub const RAMP_SEGMENTS: usize = 16;

/// Most segments a block's step times have: two ramps, a cruise, and the events where the cruise begins and where
/// the deceleration begins.
pub const MAX_SEGMENTS: usize = 2 * RAMP_SEGMENTS + 3;

/// Fixed-point time: one timer tick is `1 << FRAC_BITS` units.
pub const FRAC_BITS: u32 = 32;

/// Half a tick in fixed point: every time carries it, so the integer tick of a time (its high word) is the time
/// rounded to the nearest tick.
const HALF: u64 = 1 << (FRAC_BITS - 1);

/// How the stepper treats the axis switches during a block.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Switches {
    /// A normal move: a pressed switch of an axis in the stepper's limit mask is a hard-limit fault.
    #[default]
    Limits,
    /// A homing block: hard limits are not checked, and each axis in `axes` stops (the rest of the block runs
    /// without it) the moment its switch reads pressed; the block ends when all of them have.
    Homing {
        /// Mask of the axes stopped by their switch (0: none, e.g. a pull-off or a debounce dwell).
        axes: u8,
    },
}

/// One piece of a block's step-time recurrence: `count` events, the first `interval` after the previous event,
/// each following one `add` longer than the one before (fixed point, [`FRAC_BITS`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Segment {
    /// Events in the segment (≥ 1).
    pub count: u32,
    /// Interval before the segment's first event, fixed-point ticks.
    pub interval: u64,
    /// Change of the interval from one event to the next, fixed-point ticks.
    pub add: i64,
}

/// What a cursor steps by past a block's last segment (never reached by the stepper, which counts the events):
/// one tick, for ever. The unused entries of [`StepTimes`]' segment array hold it.
pub const PAST_THE_END: Segment = Segment { count: u32::MAX, interval: 1 << FRAC_BITS, add: 0 };

/// The integer recurrence that times a block's step events: a short list of [`Segment`]s (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StepTimes {
    segments: [Segment; MAX_SEGMENTS],
    len: u8,
    /// Fixed-point time the recurrence starts from (with [`HALF`]).
    start: u64,
    /// Fixed-point time from the start to the last event (not wrapped).
    span: u128,
    /// Number of events.
    events: u32,
}

/// The per-event state of a [`StepTimes`] being executed: a few 32-bit adds and a decrement per event.
///
/// It keeps the fraction of the running fixed-point time only: the interval to the next event is the integer part
/// of the current interval `d` plus the carry out of adding its fraction to the time's (the same tick as the
/// difference of the two times' high words, with no 64-bit time and no subtraction), then `d` grows by `add`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[repr(C)]
pub struct Cursor {
    /// Events left in the current segment.
    left: u32,
    /// Fraction of the time of the last event returned (of the start, before the first).
    frac: u32,
    /// The next interval, fixed point.
    d: u64,
    /// Its change per event, fixed point.
    e: i64,
    /// Index of the next segment to enter.
    seg: u8,
}

impl Cursor {
    /// Advance to the next event and return the ticks since the previous one (the block start for the first).
    /// Past the last event it returns 1 (never reached by the stepper, which counts the events).
    #[inline]
    pub fn next(&mut self, times: &StepTimes) -> u32 {
        if self.left == 0 {
            match times.segments().get(usize::from(self.seg)) {
                Some(s) => self.enter(s),
                None => return 1,
            }
        }
        self.step()
    }

    /// Whether the current segment is used up: the next event needs the next segment ([`Cursor::enter`]) before
    /// its [`Cursor::step`].
    #[inline(always)]
    pub fn segment_done(&self) -> bool {
        self.left == 0
    }

    /// Index of the next segment to [`Cursor::enter`] (into [`StepTimes::segments`]).
    #[inline(always)]
    pub fn next_segment(&self) -> usize {
        usize::from(self.seg)
    }

    /// Enter segment `s` (the next one of its [`StepTimes`]): its first event comes `s.interval` after the last.
    #[inline(always)]
    pub fn enter(&mut self, s: &Segment) {
        self.seg = self.seg.wrapping_add(1);
        self.left = s.count;
        self.d = s.interval;
        self.e = s.add;
    }

    /// Enter segment `s` (the next one) and take all its events at once for [`Cursor::advance`]: returns how many.
    /// Its events not taken are 0, as they were (the current segment is used up): nothing to store for them.
    #[inline(always)]
    pub fn enter_whole(&mut self, s: &Segment) -> u32 {
        debug_assert_eq!(self.left, 0, "the current segment is used up");
        self.seg = self.seg.wrapping_add(1);
        self.d = s.interval;
        self.e = s.add;
        s.count
    }

    /// One event of the current segment (which has one left): the interval to it, ticks.
    #[inline(always)]
    pub fn step(&mut self) -> u32 {
        self.left = self.left.wrapping_sub(1);
        self.advance()
    }

    /// Take up to `max` of the current segment's events for [`Cursor::advance`] (which does not count them):
    /// returns how many were taken.
    #[inline(always)]
    pub fn reserve(&mut self, max: u32) -> u32 {
        let taken = self.left.min(max);
        self.left -= taken;
        taken
    }

    /// Give `n` events taken by [`Cursor::reserve`] and not advanced through back to the segment.
    #[inline(always)]
    pub fn give_back(&mut self, n: u32) {
        self.left = self.left.wrapping_add(n);
    }

    /// One event taken by [`Cursor::reserve`]: the interval to it, ticks ([`Cursor::step`] without the count).
    #[inline(always)]
    pub fn advance(&mut self) -> u32 {
        #[allow(clippy::cast_possible_truncation, reason = "the low word of the interval")]
        let (frac, carry) = self.frac.overflowing_add(self.d as u32);
        self.frac = frac;
        let interval = high_word(self.d).wrapping_add(u32::from(carry));
        self.d = self.d.wrapping_add_signed(self.e);
        interval
    }

    /// Become `from`, field by field (a whole-struct copy can become a slow library call in the interrupt).
    #[inline(always)]
    pub fn set(&mut self, from: &Cursor) {
        self.left = from.left;
        self.frac = from.frac;
        self.d = from.d;
        self.e = from.e;
        self.seg = from.seg;
    }

    /// Fixed-point time of the last event returned (the start, before the first), modulo one tick: its fraction,
    /// all that the following intervals depend on.
    pub fn time(&self) -> u64 {
        u64::from(self.frac)
    }
}

/// The high word of a fixed-point time: its tick.
#[inline]
fn high_word(t: u64) -> u32 {
    #[allow(clippy::cast_possible_truncation, reason = "the shift leaves 32 bits")]
    let w = (t >> FRAC_BITS) as u32;
    w
}

/// `t` ticks (≥ 0) as fixed point, truncated; saturates.
fn to_fixed(t: f32) -> u64 {
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss, reason = "float→int `as` saturates")]
    let f = (t * 4_294_967_296.0) as u64;
    f
}

impl StepTimes {
    /// No events yet, starting at fixed-point time `start` (which includes the half tick).
    fn empty(start: u64) -> Self {
        StepTimes { segments: [PAST_THE_END; MAX_SEGMENTS], len: 0, start, span: 0, events: 0 }
    }

    /// The segments.
    #[inline(always)]
    pub fn segments(&self) -> &[Segment] {
        &self.segments[..usize::from(self.len)]
    }

    /// Number of events timed.
    pub fn events(&self) -> u32 {
        self.events
    }

    /// Segment `i` (of [`StepTimes::segments`]), if there is one.
    #[inline(always)]
    pub fn segment(&self, i: usize) -> Option<&Segment> {
        if i < usize::from(self.len) { self.segments.get(i) } else { None }
    }

    /// Segment `i`, which the caller knows exists (`i <` [`StepTimes::segments`]`.len()`): no fallback to load, the
    /// index is only clamped to the array (an `i` past it gives the last entry).
    #[inline(always)]
    pub fn segment_known(&self, i: usize) -> &Segment {
        &self.segments[i.min(MAX_SEGMENTS - 1)]
    }

    /// Ticks from the start to the last event, exactly as [`Cursor::next`] adds them up (saturated at `u32::MAX`).
    pub fn duration_ticks(&self) -> u32 {
        let end = (u128::from(self.start) + self.span) >> FRAC_BITS;
        let ticks = end - (u128::from(self.start) >> FRAC_BITS);
        u32::try_from(ticks).unwrap_or(u32::MAX)
    }

    /// A cursor at the start.
    pub fn cursor(&self) -> Cursor {
        #[allow(clippy::cast_possible_truncation, reason = "the fraction of the start: the low word")]
        let frac = self.start as u32;
        Cursor { left: 0, frac, d: 0, e: 0, seg: 0 }
    }

    /// Append a segment of `m` events ending at relative time `t_end` (ticks after `start`), whose event at
    /// `m/2` should be at `t_mid` and whose start is ideally at `t_from`; `linear` forces a constant interval.
    fn fit(&mut self, m: u32, t_from: f32, t_mid: f32, t_end: f32, linear: bool) {
        if m == 0 || usize::from(self.len) >= MAX_SEGMENTS {
            return;
        }
        let now = i128::try_from(self.span).unwrap_or(i128::MAX);
        let target = i128::from(to_fixed(t_end)).max(now);
        let span = target - now;
        let mm = i128::from(m);
        let tri = mm * (mm - 1) / 2;
        let mut e: i128 = if linear || m < 2 {
            0
        } else {
            // Through the ideal start, middle and end: t(j) = t_from + j·D + j(j−1)/2·E gives E = 4(A − 2B)/m².
            let mf = m as f32;
            let curve = 4.0 * ((t_end - t_from) - 2.0 * (t_mid - t_from)) / (mf * mf);
            let c = curve * 4_294_967_296.0;
            #[allow(clippy::cast_possible_truncation, reason = "float→int `as` saturates")]
            let c = c as i64;
            i128::from(c)
        };
        let mut d = (span - e * tri).div_euclid(mm);
        if d < 0 || d + e * (mm - 1) < 0 {
            e = 0;
            d = span / mm;
        }
        let total = d * mm + e * tri;
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss, reason = "d ≥ 0 and below 2^64 by the fit")]
        let seg = Segment { count: m, interval: d as u64, add: e as i64 };
        self.segments[usize::from(self.len)] = seg;
        self.len += 1;
        self.events += m;
        self.span = self.span.saturating_add(u128::try_from(total).unwrap_or(0));
    }

    /// Cut the events `from..to` of a ramp into at most [`RAMP_SEGMENTS`] segments fitted to `time` (relative
    /// ticks of a real event position). The ramp is slowest at `to` when `slow_end`, else at `from`, where the
    /// motion is `c = v²/2a` events past the point where its rate would be zero (`two_a = 2a`, events/s²).
    ///
    /// The segments are as long as their estimated interpolation error allows ([`greedy_ramp`]), from the slow
    /// end on; when that takes more than [`RAMP_SEGMENTS`], their boundaries are spaced geometrically in the
    /// distance from the zero-rate point instead (each segment the same ratio `q` longer than the distance before
    /// it): `t ∝ √distance` there, so every segment then has the same relative interpolation error.
    fn ramp(&mut self, from: u32, to: u32, slow_end: bool, c: f32, two_a: f32, time: impl Fn(f32) -> f32) {
        if to <= from {
            return;
        }
        let len = to - from;
        let mut dist = [0u32; RAMP_SEGMENTS + 1];
        let segs = match greedy_ramp(len, c, two_a, &mut dist) {
            Some(segs) => segs,
            None => {
                let base = c.max(1.0);
                // q = ((len + c)/base)^(1/16), the 16th root as four square roots.
                let q = sqrt(sqrt(sqrt(sqrt((len as f32 + c) / base))));
                let mut g = base;
                for i in 1..=RAMP_SEGMENTS {
                    g *= q;
                    dist[i] = if i == RAMP_SEGMENTS { len } else { round_u32(g - c).clamp(dist[i - 1], len) };
                }
                RAMP_SEGMENTS
            }
        };
        let mut prev = from;
        for i in 1..=segs {
            let b = if slow_end { to - dist[segs - i] } else { from + dist[i] };
            if b > prev {
                let m = b - prev;
                let mid = prev as f32 + m as f32 * 0.5;
                self.fit(m, time(prev as f32), time(mid), time(b as f32), false);
                prev = b;
            }
        }
    }

    /// The constant-rate events `from..to` (one segment).
    fn cruise(&mut self, from: u32, to: u32, time: impl Fn(f32) -> f32) {
        if to > from {
            self.fit(to - from, time(from as f32), 0.0, time(to as f32), true);
        }
    }

    /// A feed-hold stop: from an event at fixed-point time `start` and rate `v` (events/s), decelerate at `accel`
    /// (events/s², > 0) over at most `avail` more events. Event `j` is at `(v − √(v² − 2aj))/a` after the start
    /// while `v² − 2aj > 0`. Returns the times, and the rate² left at the end when `avail` events do not stop it
    /// (`None`: it stops after [`StepTimes::events`] events).
    pub fn hold(start: u64, avail: u32, v: f32, accel: u32) -> (StepTimes, Option<f32>) {
        let a = accel.max(1) as f32;
        let two_a = 2.0 * a;
        let vsq = v * v;
        let q = vsq / two_a;
        // Events j ≥ 1 with v² − 2aj > 0.
        let fl = crate::fmath::floor_u32(q);
        let stop = if fl as f32 == q { fl.saturating_sub(1) } else { fl };
        let f = TICK_HZ as f32;
        let time = |x: f32| ramp_time(x, v, vsq, -two_a) * f;
        let mut times = StepTimes::empty(start);
        let count = stop.min(avail);
        times.ramp(0, count, true, q - count as f32, two_a, time);
        let left = if stop < avail { None } else { Some(vsq - two_a * avail as f32) };
        (times, left)
    }
}

/// Seconds to cover `x` events accelerating at `two_a / 2` from rate `v` (`v_sq = v²`): `(√(v² + 2ax) − v)/a`,
/// computed as `2x/(√(v² + 2ax) + v)`, which does not cancel nearly equal numbers (0 at `x ≤ 0`). With a negative
/// `two_a` it is the time to cover `x` events decelerating.
fn ramp_time(x: f32, v: f32, v_sq: f32, two_a: f32) -> f32 {
    if x <= 0.0 {
        return 0.0;
    }
    let den = sqrt(v_sq + two_a * x) + v;
    if den > 0.0 { 2.0 * x / den } else { 0.0 }
}

/// Interpolation error a ramp's segment may have: a fixed part, ticks, …
const RAMP_TOL_TICKS: f32 = 1.0;
/// … and a part of the ramp's duration (the stated accuracy, in the module docs, is 1 tick + 0.025 % of the
/// block's ramps).
const RAMP_TOL_REL: f32 = 4.0e-4;

/// Cut a ramp of `len` events, from `c` events past its zero-rate point (`two_a = 2a`), into segments from its
/// slow end on, each as long as its estimated interpolation error stays within [`RAMP_TOL_TICKS`] +
/// [`RAMP_TOL_REL`] of the ramp's duration: `dist[1..=segs]` are the boundaries' distances from the slow end
/// (the last one `len`). `None` when that needs more than [`RAMP_SEGMENTS`].
///
/// The estimate: near the slow end the ideal time is `t = K√u` (`u` events from the zero-rate point,
/// `K = 2·10⁶/√(2a)` ticks); a segment of `m` events from `u` on, fitted through its start, middle and end, errs
/// between them by at most `max|t‴|·m³·√3/108 = (3/8)·K·u^(−5/2)·m³·√3/108 < 0.0061·K·m³/u^(5/2)` (the
/// remainder of the interpolation through three equally spaced points; `|t‴|` is largest at the slow end `u`).
/// A one-event segment is exact; one starting at the zero-rate point is never longer.
fn greedy_ramp(len: u32, c: f32, two_a: f32, dist: &mut [u32; RAMP_SEGMENTS + 1]) -> Option<usize> {
    if two_a <= 0.0 {
        return None;
    }
    let k = 2.0 * TICK_HZ as f32 / sqrt(two_a);
    let c = if c > 0.0 { c } else { 0.0 };
    let tol = RAMP_TOL_TICKS + RAMP_TOL_REL * k * (sqrt(c + len as f32) - sqrt(c));
    let mut done = 0;
    for (segs, boundary) in dist.iter_mut().enumerate().skip(1) {
        let u = c + done as f32;
        // m³ ≤ tol·u^(5/2)/(0.0061·K).
        let room = tol * u * u * sqrt(u) / (0.0061 * k);
        done += cube_floor(room, len - done);
        *boundary = done;
        if done == len {
            return Some(segs);
        }
    }
    None
}

/// The largest `m` in `1..=cap` with `m³ ≤ x` (1 when none).
fn cube_floor(x: f32, cap: u32) -> u32 {
    let fits = |m: u32| {
        let f = m as f32;
        f * f * f <= x
    };
    // Double while it fits, then halve the gap.
    let (mut lo, mut hi) = (1u32, 2u32);
    while hi <= cap && fits(hi) {
        lo = hi;
        hi = hi.saturating_mul(2);
    }
    let mut hi = hi.min(cap.saturating_add(1));
    while hi - lo > 1 {
        let mid = lo + (hi - lo) / 2;
        if fits(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo.min(cap.max(1))
}

/// The trapezoid of one block (see the module docs for the formulas), and its step times.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Profile {
    n: u32,
    v0: f32,
    v1: f32,
    vp: f32,
    v0sq: f32,
    v1sq: f32,
    two_a: f32,
    /// `TICK_HZ / vp`.
    f_over_vp: f32,
    xa: f32,
    xd: f32,
    nf: f32,
    /// End of acceleration, ticks (unrounded).
    ta: f32,
    /// Total, ticks (unrounded).
    total: f32,
    times: StepTimes,
}

impl Profile {
    /// Profile of `n` events from the plan; rates are clamped so that `v0, v1 ≤ vc`, `vc ≥ 1`, and an exit rate
    /// that cannot be reached within `n` events is replaced by the reachable one (a well-formed plan never needs it).
    pub fn new(n: u32, entry: u32, cruise: u32, exit: u32, accel: u32) -> Self {
        let f = TICK_HZ as f32;
        let vc = cruise.clamp(1, MAX_RATE) as f32;
        let mut v0 = (entry.min(MAX_RATE) as f32).min(vc);
        let mut v1 = (exit.min(MAX_RATE) as f32).min(vc);
        let nf = n as f32;
        let (vp, xa, xd, a) = if accel == 0 || n == 0 {
            v0 = vc;
            v1 = vc;
            (vc, 0.0, nf, 0.0)
        } else {
            let a = accel as f32;
            let two_a = 2.0 * a;
            let xa_full = (vc - v0) * (vc + v0) / two_a;
            let xd_full = (vc - v1) * (vc + v1) / two_a;
            if xa_full + xd_full <= nf {
                (vc, xa_full, nf - xd_full, a)
            } else {
                let peak_sq = (two_a * nf + v0 * v0 + v1 * v1) * 0.5;
                if peak_sq <= v0 * v0 {
                    // Too short to slow down to v1: decelerate over the whole block.
                    v1 = sqrt(v0 * v0 - two_a * nf);
                    (v0, 0.0, 0.0, a)
                } else if peak_sq <= v1 * v1 {
                    // Too short to speed up to v1: accelerate over the whole block.
                    v1 = sqrt(v0 * v0 + two_a * nf);
                    (v1, nf, nf, a)
                } else {
                    let vp = sqrt(peak_sq);
                    let xa = (two_a * nf + (v1 - v0) * (v1 + v0)) / (2.0 * two_a);
                    (vp, xa, xa, a)
                }
            }
        };
        let f_over_vp = f / vp;
        // (vp − v0)/a written as 2·x_a/(vp + v0): no cancellation of nearly equal rates.
        let ta = 2.0 * xa * f / (vp + v0);
        let total = ta + (xd - xa) * f_over_vp + 2.0 * (nf - xd) * f / (vp + v1);
        let mut p = Profile {
            n,
            v0,
            v1,
            vp,
            v0sq: v0 * v0,
            v1sq: v1 * v1,
            two_a: 2.0 * a,
            f_over_vp,
            xa,
            xd,
            nf,
            ta,
            total,
            times: StepTimes::empty(HALF),
        };
        let ka = crate::fmath::floor_u32(xa).min(n);
        let kd = crate::fmath::floor_u32(xd).clamp(ka, n);
        let mut times = StepTimes::empty(HALF);
        let at = |x: f32| p.time_at(x);
        let two_a = 2.0 * a;
        let c0 = if a > 0.0 { v0 * v0 / two_a } else { 0.0 };
        let c1 = if a > 0.0 { v1 * v1 / two_a } else { 0.0 };
        times.ramp(0, ka, false, c0, two_a, at);
        // The event after x_a is the first of the cruise, but the interval before it still partly accelerates.
        let kc = if (ka as f32) < xa && ka < kd { ka + 1 } else { ka };
        if kc > ka {
            times.fit(1, at(ka as f32), 0.0, at(kc as f32), true);
        }
        times.cruise(kc, kd, at);
        // The interval that holds x_d (from the cruise or the peak into the deceleration) is not on the
        // deceleration's square root: a segment of its own, so that no fitted segment spans the bend.
        let ke = if (kd as f32) < xd && kd < n { kd + 1 } else { kd };
        if ke > kd {
            times.fit(1, at(kd as f32), 0.0, at(ke as f32), true);
        }
        times.ramp(ke, n, true, c1, two_a, at);
        p.times = times;
        p
    }

    /// Number of step events.
    pub fn events(&self) -> u32 {
        self.n
    }

    /// Ideal time of the continuous motion at position `x` (0..=n events) after the block start, ticks
    /// (the formulas of the module docs).
    pub fn time_at(&self, x: f32) -> f32 {
        let f = TICK_HZ as f32;
        if x <= self.xa && self.two_a > 0.0 {
            ramp_time(x, self.v0, self.v0sq, self.two_a) * f
        } else if x <= self.xd || self.two_a == 0.0 {
            self.ta + (x - self.xa) * self.f_over_vp
        } else {
            self.total - ramp_time(self.nf - x, self.v1, self.v1sq, self.two_a) * f
        }
    }

    /// The step times the stepper executes.
    pub fn times(&self) -> &StepTimes {
        &self.times
    }

    /// Replace the step times (a feed hold re-times the rest of a block).
    pub fn set_times(&mut self, times: StepTimes) {
        self.times = times;
    }

    /// Duration of the block, ticks: the sum of the recurrence's intervals.
    pub fn duration_ticks(&self) -> u32 {
        self.times.duration_ticks()
    }

    /// Peak rate reached (events/s).
    pub fn peak_rate(&self) -> f32 {
        self.vp
    }

    /// Exit rate actually reached (events/s): the plan's, unless it was unreachable.
    pub fn exit_rate(&self) -> f32 {
        self.v1
    }

    /// Instantaneous rate at position `k` (events/s), from the continuous profile.
    pub fn rate_at(&self, k: u32) -> f32 {
        let kf = k.min(self.n) as f32;
        if kf <= self.xa && self.two_a > 0.0 {
            sqrt(self.v0sq + self.two_a * kf)
        } else if kf <= self.xd || self.two_a == 0.0 {
            self.vp
        } else {
            sqrt(self.v1sq + self.two_a * (self.nf - kf))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use std::vec::Vec;

    /// The trapezoid of the module docs in f64, written out independently of [`Profile`]:
    /// `(v0, vp, v1, a, x_a, x_d, T)` in events, events/s, events/s² and seconds.
    fn ideal(n: u32, entry: u32, cruise: u32, exit: u32, accel: u32) -> (f64, f64, f64, f64, f64, f64, f64) {
        let nf = f64::from(n);
        let vc = f64::from(cruise.clamp(1, MAX_RATE));
        let v0 = f64::from(entry.min(MAX_RATE)).min(vc);
        let v1 = f64::from(exit.min(MAX_RATE)).min(vc);
        if accel == 0 {
            return (vc, vc, vc, 0.0, 0.0, nf, nf / vc);
        }
        let a = f64::from(accel);
        let (xa, xd) = ((vc * vc - v0 * v0) / (2.0 * a), (vc * vc - v1 * v1) / (2.0 * a));
        let (v0, vp, v1, xa, xd) = if xa + xd <= nf {
            (v0, vc, v1, xa, nf - xd)
        } else {
            let peak_sq = (2.0 * a * nf + v0 * v0 + v1 * v1) / 2.0;
            if peak_sq <= v0 * v0 {
                (v0, v0, (v0 * v0 - 2.0 * a * nf).max(0.0).sqrt(), 0.0, 0.0)
            } else if peak_sq <= v1 * v1 {
                let v1 = (v0 * v0 + 2.0 * a * nf).sqrt();
                (v0, v1, v1, nf, nf)
            } else {
                let xa = (peak_sq - v0 * v0) / (2.0 * a);
                (v0, peak_sq.sqrt(), v1, xa, xa)
            }
        };
        let total = (vp - v0) / a + (xd - xa) / vp + (vp - v1) / a;
        (v0, vp, v1, a, xa, xd, total)
    }

    /// Ideal time of event `k`, seconds.
    fn ideal_t(k: f64, p: (f64, f64, f64, f64, f64, f64, f64), n: f64) -> f64 {
        let (v0, vp, v1, a, xa, xd, total) = p;
        if a == 0.0 {
            k / vp
        } else if k <= xa {
            ((v0 * v0 + 2.0 * a * k).sqrt() - v0) / a
        } else if k <= xd {
            (vp - v0) / a + (k - xa) / vp
        } else {
            total - ((v1 * v1 + 2.0 * a * (n - k)).max(0.0).sqrt() - v1) / a
        }
    }

    /// All intervals of a block's recurrence.
    fn intervals(p: &Profile) -> Vec<u32> {
        let mut c = p.times().cursor();
        (0..p.events()).map(|_| c.next(p.times())).collect()
    }

    #[test]
    fn hand_computed_pure_acceleration() {
        // a = 2·10⁶ events/s² from rest: t(k) = √(2k/a) = 1000·√k µs; four events fit 12 segments exactly.
        let p = Profile::new(4, 0, MAX_RATE, MAX_RATE, 2_000_000);
        // round(1000·√k): 1000, 1414, 1732, 2000.
        assert_eq!(intervals(&p), [1000, 414, 318, 268]);
        assert_eq!(p.duration_ticks(), 2000);
    }

    #[test]
    fn hand_computed_cruise_is_one_constant_segment() {
        let p = Profile::new(5, 0, 400, 0, 0);
        assert_eq!(intervals(&p), [2500; 5]);
        assert_eq!(p.times().segments(), [Segment { count: 5, interval: 2500 << 32, add: 0 }]);
        assert_eq!(p.duration_ticks(), 12_500);
    }

    #[test]
    fn hand_computed_trapezoid() {
        // 0 → 1000 events/s at 10⁴ events/s²: 50 events and 0.1 s each way, 900 events cruise (0.9 s).
        let p = Profile::new(1000, 0, 1000, 0, 10_000);
        let iv = intervals(&p);
        assert_eq!(iv.iter().map(|&i| u64::from(i)).sum::<u64>(), 1_100_000);
        assert_eq!(p.duration_ticks(), 1_100_000);
        // Event 50 ends the ramp at 0.1 s; the cruise then ticks every millisecond; event 950 is at 1.0 s.
        let at = |k: usize| iv[..k].iter().map(|&i| u64::from(i)).sum::<u64>();
        assert_eq!(at(50), 100_000);
        assert!(iv[50..950].iter().all(|&i| i == 1000), "cruise intervals");
        assert_eq!(at(950), 1_000_000);
        // First event √(2/a) = 14 142.1 µs, second √(4/a) = 20 000 µs.
        assert_eq!(&iv[..2], [14_142, 5858]);
        // At most 12 + 1 + 12 segments.
        assert!(p.times().segments().len() <= MAX_SEGMENTS);
    }

    #[test]
    fn a_ramp_too_long_for_the_greedy_cut_fills_every_segment() {
        // 0 → 20 000 → 0 events/s at 200 events/s²: each ramp is 10⁶ events from rest, more than 16 greedy
        // segments cover; the geometric cut then has q = (10⁶)^(1/16) = 2.37 > 1.5, so its 16 boundaries round to
        // distinct events: 16 segments per ramp, no cruise (x_a = x_d is a whole event).
        let p = Profile::new(2_000_000, 0, 20_000, 0, 200);
        assert_eq!(p.times().segments().len(), 2 * RAMP_SEGMENTS);
        assert_eq!(p.times().segments().iter().map(|s| s.count).sum::<u32>(), 2_000_000);
        let mut dist = [0; RAMP_SEGMENTS + 1];
        assert_eq!(greedy_ramp(1_000_000, 0.0, 400.0, &mut dist), None);
    }

    #[test]
    fn a_hold_too_long_for_the_greedy_cut_falls_back_measured_from_its_stop() {
        // From 20 000 events/s at 300 events/s²: v²/2a = 4·10⁸/600 = 666 666.67, so the stop comes after 666 666
        // events, c = 0.67 events before the zero-rate point (too long for the greedy cut: 16 segments reach
        // ~242 000 events). The geometric cut from its slow end: base 1 (c < 1), q = 666 666.67^(1/16) = 2.3120,
        // boundaries round(qⁱ − 0.67) = 2, 5, 12, 28, 65 (measured from q/count ≈ 1.0 instead they would be 1, 4,
        // 11, 28, 65): its last segments hold 37, 16, 7, 3 and 2 events.
        let (times, left) = StepTimes::hold(HALF, 1_000_000, 20_000.0, 300);
        assert_eq!((times.events(), left), (666_666, None));
        let counts: Vec<u32> = times.segments().iter().rev().take(5).map(|s| s.count).collect();
        assert_eq!(counts, [2, 3, 7, 16, 37]);
        assert_eq!(times.segments().len(), RAMP_SEGMENTS);
    }

    #[test]
    fn a_fit_whose_first_interval_would_be_negative_is_linear() {
        // 3 events over 10 ticks, the middle one at the start: the curve through them, E = 4·(10 − 0)/9 = 4.44
        // ticks, would need a first interval of (10 − 3E)/3 = −1.11 ticks. The fit falls back to a constant
        // interval of 10/3 tick: ⌊10·2³²/3⌋ = 14 316 557 653 units, no add.
        let mut times = StepTimes::empty(HALF);
        times.fit(3, 0.0, 0.0, 10.0, false);
        assert_eq!(times.segments(), [Segment { count: 3, interval: 14_316_557_653, add: 0 }]);
        let mut cursor = times.cursor();
        let intervals: Vec<u32> = (0..3).map(|_| cursor.next(&times)).collect();
        // Events at 3.33, 6.67 and 10 ticks after a start at half a tick: ticks 3, 7 and 10.
        assert_eq!(intervals, [3, 4, 3]);
        // Only a negative interval is refused: 3 events over 3 ticks with the middle one at 0.375 give
        // E = 4·(3 − 0.75)/9 = 1 tick exactly and a first interval of (3 − 3E)/3 = 0, which the curve keeps.
        let mut times = StepTimes::empty(HALF);
        times.fit(3, 0.0, 0.375, 3.0, false);
        assert_eq!(times.segments(), [Segment { count: 3, interval: 0, add: 1 << FRAC_BITS }]);
    }

    #[test]
    fn the_fallback_cut_of_a_ramp_from_a_moving_start_measures_from_the_zero_rate_point() {
        // 100 → 20 000 → 0 events/s at 200 events/s²: the acceleration starts c = 100²/400 = 25 events past the
        // point where its rate would be zero and runs ~999 975 events, too long for the greedy cut. The geometric
        // cut grows from base c: q = ((999 975 + 25)/25)^(1/16) = 1.939 23, boundaries round(25·qⁱ − 25) = 23, 69,
        // 157, 329: segments of 23, 46, 88 and 172 events (from base 1 the first ones would be empty).
        let p = Profile::new(2_000_000, 100, 20_000, 0, 200);
        let counts: std::vec::Vec<u32> = p.times().segments()[..4].iter().map(|s| s.count).collect();
        assert_eq!(counts, [23, 46, 88, 172]);
        assert_eq!(p.times().segments().iter().map(|s| s.count).sum::<u32>(), 2_000_000);
    }

    #[test]
    fn every_segment_fits_when_both_ramps_fall_back_and_both_bends_are_between_events() {
        // 0 → 20 000 → 0 events/s at 201 events/s²: x_a = 4·10⁸/402 = 995 024.9 and x_d = n − x_a = 1 504 976.1,
        // both between events; each ramp ~995 000 events from rest (geometric fallback, q = 2.37: 16 distinct
        // segments), the event after x_a, the cruise, the event after x_d: 35 segments, every event timed.
        let p = Profile::new(2_500_001, 0, 20_000, 0, 201);
        assert_eq!(p.times().segments().len(), 2 * RAMP_SEGMENTS + 3);
        assert_eq!(MAX_SEGMENTS, 35);
        assert_eq!(p.times().segments().iter().map(|s| s.count).sum::<u32>(), 2_500_001);
        assert_eq!(p.times().events(), 2_500_001);
        // The acceleration's geometric boundaries from base 1: q = 995 024^(1/16) = 2.3707, round(q^i) = 2, 6, 13,
        // 32, 75: segments of 2, 4, 7, 19 and 43 events.
        let counts: std::vec::Vec<u32> = p.times().segments()[..5].iter().map(|s| s.count).collect();
        assert_eq!(counts, [2, 4, 7, 19, 43]);
    }

    #[test]
    fn fit_ignores_an_empty_segment_and_a_full_list() {
        let mut t = StepTimes::empty(HALF);
        t.fit(0, 0.0, 0.0, 5.0, false);
        assert_eq!((t.segments().len(), t.events(), t.duration_ticks()), (0, 0, 0));
        for i in 1..=MAX_SEGMENTS {
            t.fit(1, 0.0, 0.0, i as f32, true);
        }
        assert_eq!((t.segments().len(), t.duration_ticks()), (MAX_SEGMENTS, 35));
        // No room left: ignored.
        t.fit(1, 0.0, 0.0, 100.0, true);
        assert_eq!((t.segments().len(), t.events(), t.duration_ticks()), (MAX_SEGMENTS, 35, 35));
    }

    #[test]
    fn greedy_ramp_segments_by_hand() {
        // K = 2·10⁶/√(2a) = 1000 ticks at 2a = 4·10⁶. From c = 100 over 1000 events: tol = 1 + 4·10⁻⁴·1000·(√1100
        // − 10) = 10.27 ticks; the first segment m³ ≤ 10.27·100^2.5/6.1 = 168 300: 55 (55³ = 166 375, 56³ = 175 616);
        // the second from u = 155: 10.27·155^2.5/6.1 = 503 600: 79 (79³ = 493 039, 80³ = 512 000).
        let mut dist = [0; RAMP_SEGMENTS + 1];
        let segs = greedy_ramp(1000, 100.0, 4e6, &mut dist).unwrap();
        assert_eq!(&dist[..3], [0, 55, 134]);
        assert_eq!(dist[segs], 1000);
        assert!(segs < RAMP_SEGMENTS, "{segs}");
        // From rest: the first events each alone (a segment from the zero-rate point is one event; at u = 1..3 the
        // room 1.8·u^2.5/6.1 = 0.30, 1.67, 4.60 is below 2³).
        let segs = greedy_ramp(4, 0.0, 4e6, &mut dist).unwrap();
        assert_eq!((segs, &dist[..5]), (4, &[0, 1, 2, 3, 4][..]));
        // No acceleration: no greedy cut.
        assert_eq!(greedy_ramp(4, 0.0, 0.0, &mut dist), None);
    }

    #[test]
    fn cube_floor_is_the_integer_cube_root_capped() {
        assert_eq!([cube_floor(27.0, 100), cube_floor(26.9, 100), cube_floor(0.0, 5)], [3, 2, 1]);
        assert_eq!([cube_floor(1e9, 2000), cube_floor(1e9, 7), cube_floor(999_000_000.0, 2000)], [1000, 7, 999]);
        assert_eq!(cube_floor(8.0, 0), 1, "never below one event");
    }

    #[test]
    fn cursor_past_the_last_event_and_saturated_durations() {
        let p = Profile::new(2, 0, 1000, 0, 0);
        let mut c = p.times().cursor();
        assert_eq!([c.next(p.times()), c.next(p.times())], [1000, 1000]);
        // Never asked by the stepper, which counts the events: a harmless 1.
        assert_eq!(c.next(p.times()), 1);
        // 5000 events at 1 event/s: 5·10⁹ µs do not fit the u32 duration, which saturates.
        assert_eq!(Profile::new(5000, 0, 1, 0, 0).duration_ticks(), u32::MAX);
        assert_eq!(Profile::new(4000, 0, 1, 0, 0).duration_ticks(), 4_000_000_000);
    }

    #[test]
    fn cursor_intervals_and_times_are_exact_fixed_point() {
        // From half a tick: 3 events 1.5 ticks apart growing by 0.25, then 2 events 4 ticks apart.
        let mut times = StepTimes::empty(HALF);
        times.segments[0] = Segment { count: 3, interval: 3 << 31, add: 1 << 30 };
        times.segments[1] = Segment { count: 2, interval: 4 << 32, add: 0 };
        times.len = 2;
        times.events = 5;
        times.span = (13 << 32) + (1 << 31) - u128::from(HALF);
        // Event times 2.0, 3.75, 5.75, 9.75, 13.75 ticks: ticks 2, 3, 5, 9, 13, fractions 0 and then 0.75.
        let quarter = 1u64 << 30;
        let expect_frac = [0, 3 * quarter, 3 * quarter, 3 * quarter, 3 * quarter];
        let mut c = times.cursor();
        assert_eq!(c.time(), HALF);
        let mut intervals = Vec::new();
        for frac in expect_frac {
            intervals.push(c.next(&times));
            assert_eq!(c.time(), frac);
        }
        assert_eq!(intervals, [2, 1, 2, 4, 4]);
        assert_eq!(times.duration_ticks(), 13);
        assert_eq!(times.segments().len(), 2);
        // Within a segment `step` is `next`; at a segment's end the caller enters the next one.
        let mut c = times.cursor();
        assert!(c.segment_done(), "no segment entered yet");
        assert_eq!(c.next_segment(), 0);
        c.enter(&times.segments()[0]);
        assert_eq!((c.segment_done(), c.next_segment()), (false, 1));
        assert_eq!([c.step(), c.step(), c.step()], [2, 1, 2]);
        assert!(c.segment_done());
        assert_eq!(c.time(), 3 * quarter);
        assert_eq!([c.next(&times), c.next(&times), c.next(&times)], [4, 4, 1]);
        assert_eq!(c.next_segment(), 2);
        // A whole segment at once: entered, all its events taken (none left for `next`), the same intervals.
        let mut c = times.cursor();
        assert_eq!(c.enter_whole(&times.segments()[0]), 3);
        assert_eq!((c.segment_done(), c.next_segment()), (true, 1));
        assert_eq!([c.advance(), c.advance(), c.advance()], [2, 1, 2]);
        assert_eq!(c.enter_whole(&times.segments()[1]), 2);
        assert_eq!([c.advance(), c.advance()], [4, 4]);
        assert_eq!((c.time(), c.next_segment()), (3 * quarter, 2));
        // Segments by index: the two in use, then none (the unused rest of the array is not a segment).
        assert_eq!(times.segment(1), Some(&Segment { count: 2, interval: 4 << 32, add: 0 }));
        assert_eq!((times.segment(2), times.segment(MAX_SEGMENTS)), (None, None));
        // A segment known to exist, by index with no fallback; past the two in use the array's unused entries hold
        // the sentinel of one tick for ever, and an index beyond the array gets its last entry (the sentinel here).
        assert_eq!(times.segment_known(0), &Segment { count: 3, interval: 3 << 31, add: 1 << 30 });
        assert_eq!(times.segment_known(1), &Segment { count: 2, interval: 4 << 32, add: 0 });
        assert_eq!((times.segment_known(2), times.segment_known(MAX_SEGMENTS + 7)), (&PAST_THE_END, &PAST_THE_END));
        assert_eq!(PAST_THE_END, Segment { count: u32::MAX, interval: 1 << 32, add: 0 });
        // A copy made with `set` goes on exactly as the original: 4, 4 after the first three events.
        let mut c = times.cursor();
        for _ in 0..3 {
            c.next(&times);
        }
        let mut copy = Cursor::default();
        copy.set(&c);
        assert_eq!(copy, c);
        assert_eq!([copy.next(&times), copy.next(&times)], [4, 4]);
    }

    #[test]
    fn hold_ramp_stops_where_the_speed_runs_out() {
        // From 1000 events/s at 10⁵ events/s²: v² − 2aj > 0 for j < 5, so 4 more events, event j at
        // (v − √(v² − 2aj))/a = 10·(1000 − √(10⁶ − 2·10⁵·j)) µs: 1055.7, 2254.0, 3675.4, 5527.9.
        let (t, left) = StepTimes::hold(HALF, 1000, 1000.0, 100_000);
        assert_eq!(left, None);
        assert_eq!(t.events(), 4);
        let mut c = t.cursor();
        let iv: Vec<u32> = (0..4).map(|_| c.next(&t)).collect();
        assert_eq!(iv, [1056, 1198, 1421, 1853]);
        assert_eq!(t.duration_ticks(), 5528);
        // The same stop from an event 7 whole ticks later lasts as long: the start's whole ticks are not counted.
        let (t, _) = StepTimes::hold((7 << FRAC_BITS) + HALF, 1000, 1000.0, 100_000);
        assert_eq!(t.duration_ticks(), 5528);
        // From 1000 events/s at 10⁴ events/s²: 49 events, the last at 0.1·(1 − √0.02) s = 85 857.9 µs.
        let (t, left) = StepTimes::hold(HALF, 1000, 1000.0, 10_000);
        assert_eq!((t.events(), left), (49, None));
        assert_eq!(t.duration_ticks(), 85_858);
        // Fewer events available than the stop needs: the rate² left is carried on.
        let (t, left) = StepTimes::hold(HALF, 10, 1000.0, 10_000);
        assert_eq!(t.events(), 10);
        assert_eq!(left, Some(1000.0 * 1000.0 - 2.0 * 10_000.0 * 10.0));
        // Exactly the 49 events the stop needs: the last one still has speed (v² − 2a·49 = 20 000), carried on;
        // one more available and the hold stops within.
        let (t, left) = StepTimes::hold(HALF, 49, 1000.0, 10_000);
        assert_eq!((t.events(), left), (49, Some(20_000.0)));
        let (t, left) = StepTimes::hold(HALF, 50, 1000.0, 10_000);
        assert_eq!((t.events(), left), (49, None));
    }

    #[test]
    fn rate_at_follows_the_trapezoid() {
        // 100 events, 0 → 1000 → 0 at 10⁴ events/s²: accelerate over 50, decelerate over 50.
        let p = Profile::new(100, 0, 1000, 0, 10_000);
        // √(2a·25) = √500 000 = 707.107 a quarter in and a quarter before the end; the peak in the middle.
        assert!((p.rate_at(25) - 707.107).abs() < 0.01, "{}", p.rate_at(25));
        assert!((p.rate_at(75) - 707.107).abs() < 0.01, "{}", p.rate_at(75));
        assert!((p.rate_at(90) - 447.214).abs() < 0.01, "{}", p.rate_at(90));
        assert_eq!(p.rate_at(50), 1000.0);
        assert_eq!(p.rate_at(500), 0.0, "past the end: the end");
        assert_eq!(Profile::new(10, 0, 300, 0, 0).rate_at(4), 300.0, "no acceleration: the cruise rate");
    }

    #[test]
    fn a_fit_whose_last_interval_would_be_negative_is_linear() {
        // 4 events over 4 ticks with the middle one at 3.9: E = 4·(4 − 7.8)/16 = −0.95 tick, D = (4 + 0.95·6)/4 =
        // 2.425, last interval D + 3E = −0.425 < 0: one tick each instead.
        let mut t = StepTimes::empty(HALF);
        t.fit(4, 0.0, 3.9, 4.0, false);
        assert_eq!(t.segments(), &[Segment { count: 4, interval: 1 << 32, add: 0 }]);
        assert_eq!((t.events(), t.duration_ticks()), (4, 4));
        // A last interval of exactly 0 is not negative: kept (2 events over 4 ticks, the middle one at 4: E = −4,
        // D = 4).
        let mut t = StepTimes::empty(HALF);
        t.fit(2, 0.0, 4.0, 4.0, false);
        assert_eq!(t.segments(), &[Segment { count: 2, interval: 4 << 32, add: -(4 << 32) }]);
        // Convex (middle at 1.0): E = 4·(4 − 2)/16 = 0.5 tick, D = (4 − 0.5·6)/4 = 0.25, intervals 0.25 … 1.75.
        let mut t = StepTimes::empty(HALF);
        t.fit(4, 0.0, 1.0, 4.0, false);
        assert_eq!(t.segments(), &[Segment { count: 4, interval: 1 << 30, add: 1 << 31 }]);
        assert_eq!((t.events(), t.duration_ticks()), (4, 4));
    }

    /// The stated bound: each event within 1 tick + 0.025 % of the time spent ramping (accelerating plus
    /// decelerating) + 2·10⁻⁶ of its own time (the f32 arithmetic) of the ideal trapezoid.
    fn bound(ramp_ticks: f64, t_ticks: f64) -> f64 {
        1.0 + 2.5e-4 * ramp_ticks + 2e-6 * t_ticks
    }

    fn rates() -> impl Strategy<Value = (u32, u32, u32, u32, u32)> {
        (1u32..3000, 0u32..20_000, 1u32..20_000, 0u32..20_000, prop_oneof![Just(0u32), 1u32..200_000])
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(2000))]
        /// Every event of the recurrence is within [`bound`] of the analytic t(k); the duration is the sum of the
        /// intervals exactly; no interval is shorter than the cruise rate's by more than 2 % and one tick (rounding).
        #[test]
        fn recurrence_tracks_the_ideal_trapezoid((n, e, c, x, a) in rates()) {
            let p = Profile::new(n, e, c, x, a);
            let ideal = ideal(n, e, c, x, a);
            let (v0, vp, v1, acc, ..) = ideal;
            let f = f64::from(TICK_HZ);
            let ramp = if acc > 0.0 { f * ((vp - v0) + (vp - v1)) / acc } else { 0.0 };
            let mut cur = p.times().cursor();
            let mut t = 0u64;
            let min_interval = f / f64::from(c.clamp(1, MAX_RATE)) * 0.98 - 1.0;
            for k in 1..=n {
                let iv = cur.next(p.times());
                prop_assert!(f64::from(iv) >= min_interval, "event {k}: interval {iv} < {min_interval}");
                t += u64::from(iv);
                let want = f * ideal_t(f64::from(k), ideal, f64::from(n));
                let err = (t as f64 - want).abs();
                prop_assert!(err <= bound(ramp, want), "event {k}: {t} vs {want:.2} (err {err:.2})");
            }
            prop_assert_eq!(t, u64::from(p.duration_ticks()));
            prop_assert_eq!(p.times().events(), n);
        }
    }
}
