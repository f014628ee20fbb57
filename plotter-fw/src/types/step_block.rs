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

/// The trapezoid of one block, precomputed for per-event evaluation (see the module docs for the formulas).
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
    nf: f32,
    /// Last event index in the accelerating / cruising phase.
    ka: u32,
    kd: u32,
    /// End of acceleration, ticks (unrounded).
    ta: f32,
    /// Total, ticks (unrounded) and rounded.
    total: f32,
    total_ticks: u32,
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
        Profile {
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
            nf,
            ka: crate::fmath::floor_u32(xa),
            kd: crate::fmath::floor_u32(xd),
            ta,
            total,
            total_ticks: round_u32(total),
        }
    }

    /// Number of step events.
    pub fn events(&self) -> u32 {
        self.n
    }

    /// Rounded time of event `k` (1..=n) after the block start, ticks. `k ≥ n` gives the block duration.
    #[inline]
    pub fn tick_of(&self, k: u32) -> u32 {
        if k >= self.n {
            return self.total_ticks;
        }
        let kf = k as f32;
        let t = if k <= self.ka {
            (sqrt(self.v0sq + self.two_a * kf) - self.v0) * self.f_over_a
        } else if k <= self.kd {
            self.ta + (kf - self.xa) * self.f_over_vp
        } else {
            self.total - (sqrt(self.v1sq + self.two_a * (self.nf - kf)) - self.v1) * self.f_over_a
        };
        round_u32(t)
    }

    /// Duration of the block, ticks.
    pub fn duration_ticks(&self) -> u32 {
        self.total_ticks
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
        } else if k <= self.kd || self.two_a == 0.0 {
            self.vp
        } else {
            sqrt(self.v1sq + self.two_a * (self.nf - kf))
        }
    }
}
