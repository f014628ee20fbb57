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
//! Event `k` fires at the time the continuous motion passes position `k`:
//!
//! ```text
//! t(k) = (√(v0² + 2ak) − v0) / a                 k ≤ x_a   (accelerating)
//! t(k) = T_a + (k − x_a) / vp                     x_a < k ≤ x_d (cruising)
//! t(k) = T − (√(v1² + 2a(n − k)) − v1) / a       k > x_d   (decelerating, measured back from the end)
//! T    = (vp − v0)/a + (x_d − x_a)/vp + (vp − v1)/a
//! ```
//!
//! and is scheduled at `round(TICK_HZ · t(k))` timer ticks after the block start. Rounding the *absolute* time of
//! each event (not each interval) keeps the tick grid from drifting, so a block lasts exactly
//! `round(TICK_HZ · T)` ticks ([`StepBlock::duration_ticks`]); the next block starts at the previous block's last
//! event. All of this is `f32` arithmetic with the deterministic [`crate::fmath::sqrt`], so the host calling
//! [`StepBlock::duration_ticks`] gets bit-for-bit the time the firmware (or the simulator) takes: a sequence of
//! blocks takes exactly the sum of their durations.
//!
//! A dwell (G4, pen settle) is a block with no steps that lasts its given number of ticks. A servo block is a dwell
//! that first drives the pen servo ([`crate::hal::StepPins::set_servo`]) to its angle: the settle time is its dwell, so the
//! pen moves exactly between the moves around it, in the stepper's own time line.

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

/// Segments each acceleration or deceleration ramp is cut into (a cruise is one more segment).
pub const RAMP_SEGMENTS: usize = 12;

/// Most segments a block's step times have: two ramps and a cruise.
pub const MAX_SEGMENTS: usize = 2 * RAMP_SEGMENTS + 1;

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

/// The per-event state of a [`StepTimes`] being executed: integer adds and a compare per event.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Cursor {
    seg: u8,
    left: u32,
    t: u64,
    d: u64,
    e: i64,
    last: u32,
}

impl Cursor {
    /// Advance to the next event and return the ticks since the previous one (the block start for the first).
    /// Past the last event it returns 1 (never reached by the stepper, which counts the events).
    #[inline]
    pub fn next(&mut self, times: &StepTimes) -> u32 {
        if self.left == 0 {
            if self.seg >= times.len {
                return 1;
            }
            let Some(s) = times.segments.get(usize::from(self.seg)) else { return 1 };
            self.seg += 1;
            self.left = s.count;
            self.d = s.interval;
            self.e = s.add;
        }
        self.left -= 1;
        self.t = self.t.wrapping_add(self.d);
        self.d = self.d.wrapping_add_signed(self.e);
        let tick = high_word(self.t);
        let interval = tick.wrapping_sub(self.last);
        self.last = tick;
        interval
    }

    /// Fixed-point time of the last event returned (the start, before the first).
    pub fn time(&self) -> u64 {
        self.t
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

/// `x⁶`: where the ramp boundaries go (see [`StepTimes::ramp`]).
fn pow6(x: f32) -> f32 {
    let x2 = x * x;
    x2 * x2 * x2
}

impl StepTimes {
    /// No events yet, starting at fixed-point time `start` (which includes the half tick).
    fn empty(start: u64) -> Self {
        StepTimes {
            segments: [Segment::default(); MAX_SEGMENTS],
            len: 0,
            start,
            span: 0,
            events: 0,
        }
    }

    /// The segments.
    pub fn segments(&self) -> &[Segment] {
        &self.segments[..usize::from(self.len)]
    }

    /// Number of events timed.
    pub fn events(&self) -> u32 {
        self.events
    }

    /// Ticks from the start to the last event, exactly as [`Cursor::next`] adds them up (saturated at `u32::MAX`).
    pub fn duration_ticks(&self) -> u32 {
        let end = (u128::from(self.start) + self.span) >> FRAC_BITS;
        let ticks = end - (u128::from(self.start) >> FRAC_BITS);
        u32::try_from(ticks).unwrap_or(u32::MAX)
    }

    /// A cursor at the start.
    pub fn cursor(&self) -> Cursor {
        Cursor { seg: 0, left: 0, t: self.start, d: 0, e: 0, last: high_word(self.start) }
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

    /// Cut the events `from..to` into [`RAMP_SEGMENTS`] segments fitted to `time` (relative ticks of a real
    /// event position), denser towards the slow end (`slow_end`: the end; else the start). The boundaries sit
    /// at the sixth power of the fraction, which spreads the interpolation error of `√` evenly over the segments.
    fn ramp(&mut self, from: u32, to: u32, slow_end: bool, time: impl Fn(f32) -> f32) {
        let len = (to - from) as f32;
        let mut prev = from;
        let s = RAMP_SEGMENTS as f32;
        for i in 1..=RAMP_SEGMENTS {
            let b = if i == RAMP_SEGMENTS {
                to
            } else {
                let w = i as f32 / s;
                let frac = if slow_end { 1.0 - pow6(1.0 - w) } else { pow6(w) };
                (from + round_u32(len * frac)).clamp(prev, to)
            };
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
        let f_over_a = TICK_HZ as f32 / a;
        let time = |x: f32| (v - sqrt(vsq - two_a * x)) * f_over_a;
        let mut times = StepTimes::empty(start);
        let count = stop.min(avail);
        times.ramp(0, count, true, time);
        let left = if stop < avail { None } else { Some(vsq - two_a * avail as f32) };
        (times, left)
    }
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
    /// `TICK_HZ / a` (0 when `a == 0`).
    f_over_a: f32,
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
            let xa_full = (vc * vc - v0 * v0) / two_a;
            let xd_full = (vc * vc - v1 * v1) / two_a;
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
                    let xa = (peak_sq - v0 * v0) / two_a;
                    (vp, xa, xa, a)
                }
            }
        };
        let f_over_a = if a > 0.0 { f / a } else { 0.0 };
        let f_over_vp = f / vp;
        let ta = (vp - v0) * f_over_a;
        let total = ta + (xd - xa) * f_over_vp + (vp - v1) * f_over_a;
        let mut p = Profile {
            n,
            v0,
            v1,
            vp,
            v0sq: v0 * v0,
            v1sq: v1 * v1,
            two_a: 2.0 * a,
            f_over_a,
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
        times.ramp(0, ka, false, at);
        times.cruise(ka, kd, at);
        times.ramp(kd, n, true, at);
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
        if x <= self.xa && self.two_a > 0.0 {
            (sqrt(self.v0sq + self.two_a * x) - self.v0) * self.f_over_a
        } else if x <= self.xd || self.two_a == 0.0 {
            self.ta + (x - self.xa) * self.f_over_vp
        } else {
            self.total - (sqrt(self.v1sq + self.two_a * (self.nf - x)) - self.v1) * self.f_over_a
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
