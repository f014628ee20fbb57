//! The EBB's motion arithmetic, shared by the sender (which must predict it to the interrupt) and the emulator
//! (which runs it): the mixed-axis kinematics, the 25 kHz step accumulator, and fitting an `LM` move to a
//! phase of our trapezoid.
//!
//! # Kinematics
//! AxiDraw-class machines drive the carriage with two motors on one belt: motor 1 moves along X+Y, motor 2
//! along X−Y (as the EBB command reference's `XM` describes: steps 1 = A + B, steps 2 = A − B). With the profile's
//! X and Y step units equal to one motor step along the axis, an XY move of (x, y) steps is exactly
//! (x + y, x − y) motor steps, and a motor position maps back when both sums are even (always, for positions
//! made of XY moves).
//!
//! # The step accumulator (EBB firmware 3.0; `LM`, `LT`, `T3`, `SM`)
//! Each motor has an unsigned 32-bit accumulator and a signed 32-bit rate. Every 40 µs interval (a 25 kHz
//! interrupt) the acceleration is added to the rate (after the jerk was added to the acceleration), the rate to
//! the accumulator, and when bit 31 of the accumulator is set it is cleared and the motor steps once, in the
//! direction of the rate's sign. So a rate of 2³¹ is one step per interval and the position after k intervals,
//! with the move starting at accumulator C₀, is ⌊(C₀ + Σ rateᵢ) / 2³¹⌋. When loaded, a move's rate is lowered by
//! half its acceleration (and raised by a sixth of its jerk, the acceleration lowered by the jerk), which makes the
//! sums come out as the constant-acceleration formulas of the command reference. A move may clear an
//! accumulator: to 0, or to 2³¹ − 1 when the move starts backwards (the mirror image of 0). These are the
//! semantics the EBB documentation gives and its published regression data confirm (see the emulator's tests).
//!
//! # Fitting a move
//! [`fit_axis`] chooses, for one motor, the rate and acceleration of an `LM` that makes exactly `s` steps with the
//! last one in interval `T` — starting from a cleared accumulator — while following the planned start and end rates
//! as closely as integers allow. The sender sends every `LM` with both accumulators cleared, so each move's timing
//! depends on its own parameters only: the host knows the board's time to the interrupt.

/// The step interrupt's rate, Hz.
pub const ISR_HZ: u32 = 25_000;
/// One interrupt interval, µs.
pub const INTERVAL_US: u32 = 40;
/// The accumulator value of one step (bit 31).
pub const ONE_STEP: u64 = 1 << 31;
/// The highest step rate a motor can take (one step per interval), steps/s.
pub const MAX_STEP_RATE: f64 = 25_000.0;

/// Motor steps (motor 1, motor 2) of an XY move in steps.
pub fn mix(x: i64, y: i64) -> [i64; 2] {
    [x + y, x - y]
}

/// XY steps of a motor move or position, when it is one (both sums even). The sums are taken in 128 bits, so any
/// pair of counters a board may report maps without wrapping (half of an even sum of two `i64` fits an `i64`).
pub fn unmix(m: [i64; 2]) -> Option<(i64, i64)> {
    let (a, b) = (i128::from(m[0]), i128::from(m[1]));
    let (s, d) = (a + b, a - b);
    if s % 2 != 0 {
        // The sum and the difference differ by 2·b: both odd.
        return None;
    }
    Some((i64::try_from(s / 2).ok()?, i64::try_from(d / 2).ok()?))
}

/// A step frequency (steps/s) as accumulator units per interval (`Rate ≈ 85 899.35 s × F`).
pub fn rate_units(steps_per_s: f64) -> f64 {
    steps_per_s * ONE_STEP as f64 / f64::from(ISR_HZ)
}

/// How a move ends for one axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AxisLimit {
    /// After this many steps (`LM`, `SM`).
    Steps(u32),
    /// After this many intervals (`LT`, `T3`).
    Intervals(u32),
}

/// One motor's share of a running move, advanced one interval at a time exactly as the firmware's interrupt does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AxisMotion {
    /// Current rate (signed: the sign is the direction).
    pub rate: i32,
    /// Added to the rate every interval.
    pub accel: i32,
    /// Added to the acceleration every interval.
    pub jerk: i32,
    /// When this axis is done.
    pub limit: AxisLimit,
    /// Steps taken so far in this move.
    pub steps: u32,
    /// Net position change so far (steps, signed).
    pub net: i64,
    /// Intervals run so far.
    pub intervals: u32,
    /// Direction taken from the rate's sign (firmware 3) or fixed by the command (firmware 2, `SM`).
    pub fixed_dir: Option<i8>,
    /// Firmware 2's rule: a rate that turns negative rolls over by 2³¹.
    pub v2_rollover: bool,
}

impl AxisMotion {
    /// A move for `limit` starting at `rate` (already adjusted for the acceleration as the firmware does on load).
    pub fn new(rate: i32, accel: i32, jerk: i32, limit: AxisLimit) -> Self {
        AxisMotion { rate, accel, jerk, limit, steps: 0, net: 0, intervals: 0, fixed_dir: None, v2_rollover: false }
    }

    /// Whether this axis still has work to do.
    pub fn active(&self) -> bool {
        match self.limit {
            AxisLimit::Steps(n) => self.steps < n,
            AxisLimit::Intervals(n) => self.intervals < n,
        }
    }

    /// One interrupt: returns the step taken (+1 / −1), if any.
    pub fn tick(&mut self, acc: &mut u32) -> Option<i8> {
        if !self.active() {
            return None;
        }
        self.intervals += 1;
        self.accel = self.accel.wrapping_add(self.jerk);
        self.rate = self.rate.wrapping_add(self.accel);
        if self.v2_rollover && self.rate < 0 {
            // 2³¹ added to a negative i32 is its value with bit 31 cleared.
            self.rate &= i32::MAX;
        }
        *acc = acc.wrapping_add(self.rate.cast_unsigned());
        if *acc & 0x8000_0000 == 0 {
            return None;
        }
        *acc &= 0x7FFF_FFFF;
        let dir = self.fixed_dir.unwrap_or(if self.rate < 0 { -1 } else { 1 });
        self.steps += 1;
        self.net += i64::from(dir);
        Some(dir)
    }
}

/// The rate a move starts from once loaded: `rate − accel/2 + jerk/6` (C integer division, towards zero).
pub fn loaded_rate(rate: i32, accel: i32, jerk: i32) -> i32 {
    rate.wrapping_sub(accel / 2).wrapping_add(jerk / 6)
}

/// The accumulator a clearing move starts from: 0, or 2³¹ − 1 when its first interval's rate is negative (or
/// zero with a negative acceleration, or both zero with a negative jerk).
pub fn cleared_accumulator(loaded_rate: i32, accel: i32, jerk: i32) -> u32 {
    let first = i64::from(loaded_rate) + i64::from(accel);
    let negative = first < 0 || (first == 0 && (accel + jerk < 0 || (accel + jerk == 0 && jerk < 0)));
    if negative { 0x7FFF_FFFF } else { 0 }
}

/// `Σ rateᵢ` after `k` intervals of a move loaded at `r` with acceleration `a` (no jerk), from a cleared
/// accumulator: `k·r + a·k(k+1)/2`.
fn accumulated(r: i64, a: i64, k: i64) -> i128 {
    i128::from(k) * i128::from(r) + i128::from(a) * i128::from(k) * i128::from(k + 1) / 2
}

/// The interval of the last of `s` steps of a forward `LM` axis with parameters `rate`, `accel` (as sent) from
/// a cleared accumulator, when every interval's rate up to it stays within 0..=2³¹ (one step at most per
/// interval, never backwards); `None` otherwise or when it would take more than `max` intervals.
pub fn last_step_interval(rate: i32, s: u32, accel: i32, max: u64) -> Option<u64> {
    if s == 0 {
        return Some(0);
    }
    let r = i64::from(loaded_rate(rate, accel, 0));
    let a = i64::from(accel);
    let target = i128::from(s) * i128::from(ONE_STEP);
    // Solve a/2·k² + (r + a/2)·k = target for k, then settle on the exact integer.
    let (af, bf) = (a as f64 / 2.0, r as f64 + a as f64 / 2.0);
    let tf = target as f64;
    let guess = if af.abs() < 1e-12 {
        if bf <= 0.0 {
            return None;
        }
        tf / bf
    } else {
        let disc = bf * bf + 4.0 * af * tf;
        if disc < 0.0 {
            return None;
        }
        (-bf + disc.sqrt()) / (2.0 * af)
    };
    if !guess.is_finite() || guess > max as f64 + 2.0 {
        return None;
    }
    // `guess` is finite and at most `max + 2` (checked above); a negative one starts the search at 1.
    #[allow(clippy::cast_possible_truncation)]
    let mut k = (guess.floor() as i64).max(1);
    while k > 1 && accumulated(r, a, k - 1) >= target {
        k -= 1;
    }
    while accumulated(r, a, k) < target {
        k += 1;
        if k.cast_unsigned() > max {
            return None;
        }
    }
    let rate_at = |k: i64| r + a * k;
    let ok = |x: i64| (0..=1i64 << 31).contains(&x);
    // k ≥ 1 here.
    let k = k.cast_unsigned();
    (ok(rate_at(1)) && ok(rate_at(k.cast_signed())) && k <= max).then_some(k)
}

/// `LM` parameters (rate as sent, acceleration) for one motor making `s` steps with the last in interval `t`,
/// from a cleared accumulator, starting near `r0` and ending near `r1` (accumulator units per interval). The
/// acceleration is reduced when the exact fit needs it (rounded step counts and times leave the planned rates
/// slightly off); a constant rate is the last resort. `None` when no rate makes the last step land in `t`
/// (a move slower than one step per ~46 000 intervals) or a rate above one step per interval would be needed.
pub fn fit_axis(s: u32, t: u32, r0: f64, r1: f64) -> Option<(i32, i32)> {
    if s == 0 {
        return Some((0, 0));
    }
    if t == 0 || u64::from(s) > u64::from(t) {
        return None;
    }
    let target = f64::from(s) * ONE_STEP as f64;
    let tf = f64::from(t);
    let mean = target / tf;
    let mut delta = if r0.is_finite() && r1.is_finite() { r1 - r0 } else { 0.0 };
    // Keep both ends clear of zero by a margin that absorbs the rounding of the acceleration.
    let margin = 2.0 * tf + 8.0;
    let room = (mean - margin).max(0.0);
    delta = delta.clamp(-2.0 * room, 2.0 * room);
    for attempt in 0..3 {
        let d = match attempt {
            0 => delta,
            1 => delta / 2.0,
            _ => 0.0,
        };
        let accel = (d / tf).round();
        if accel.abs() > f64::from(i32::MAX) {
            continue;
        }
        // Within ±i32::MAX (checked above).
        #[allow(clippy::cast_possible_truncation)]
        let a = accel as i64;
        // The loaded rate r' making Σ over t intervals reach the target at t, not before.
        let need = i128::from(s) * i128::from(ONE_STEP) - i128::from(a) * i128::from(t) * i128::from(t + 1) / 2;
        let tt = i128::from(t);
        let r_loaded = (need + tt - 1).div_euclid(tt);
        let Ok(r_loaded) = i64::try_from(r_loaded) else { continue };
        let sent = r_loaded + a / 2;
        let (Ok(sent), Ok(a32)) = (i32::try_from(sent), i32::try_from(a)) else { continue };
        if last_step_interval(sent, s, a32, u64::from(t)) == Some(u64::from(t)) {
            return Some((sent, a32));
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run_lm(rate: i32, steps: u32, accel: i32) -> (u32, i64, u32) {
        let r = loaded_rate(rate, accel, 0);
        let mut acc = cleared_accumulator(r, accel, 0);
        let mut m = AxisMotion::new(r, accel, 0, AxisLimit::Steps(steps));
        while m.active() {
            m.tick(&mut acc);
            assert!(m.intervals < 10_000_000);
        }
        (m.intervals, m.net, acc)
    }

    #[test]
    fn mixing_is_the_corexy_sum_and_difference() {
        assert_eq!(mix(3, 1), [4, 2]);
        assert_eq!(unmix([4, 2]), Some((3, 1)));
        assert_eq!(unmix([3, 2]), None, "odd sums are no XY position");
        // Counters at the ends of their range do not wrap (i64::MAX + i64::MAX once read as (-1, 0): near home).
        assert_eq!(unmix([i64::MAX, i64::MAX]), Some((i64::MAX, 0)));
        assert_eq!(unmix([i64::MIN, i64::MIN]), Some((i64::MIN, 0)));
        assert_eq!(unmix([i64::MAX, i64::MIN + 1]), Some((0, i64::MAX)));
        assert_eq!(unmix([i64::MAX, i64::MIN]), None, "an odd sum");
        for (x, y) in [(0, 0), (-7, 12), (1000, -3)] {
            assert_eq!(unmix(mix(x, y)), Some((x, y)));
        }
    }

    #[test]
    fn the_reference_examples_take_their_documented_times() {
        // EBB command reference, LM example 3: axis 1 one step per ms for 10 steps = 250 intervals (10 ms).
        assert_eq!(run_lm(85_899_346, 10, 0).0, 250);
        // Example 6: 500 → 800 steps/s over 50 steps "takes 77 ms" (the reference rounds): 1923 intervals.
        let (t, net, _) = run_lm(42_950_000, 50, 13_400);
        assert_eq!(net, 50);
        assert!((1900..1950).contains(&t), "{t}");
        // A rate of 2^28 steps every 8 intervals: 5 steps in 40 (the first row of the LM regression data).
        assert_eq!(run_lm(268_435_456, 5, 0), (40, 5, 0));
    }

    #[test]
    fn the_closed_form_agrees_with_the_interrupt() {
        for (rate, s, accel) in
            [(8_589_934, 29, 17_353_403), (1_800_095_000, 29, -26_012_345), (42_950_000, 50, 13_400)]
        {
            let (t, _, _) = run_lm(rate, s, accel);
            assert_eq!(last_step_interval(rate, s, accel, 1_000_000), Some(u64::from(t)), "{rate} {s} {accel}");
        }
    }

    #[test]
    fn fitted_moves_end_on_their_interval() {
        // 1000 steps in 4000 intervals accelerating from 0.1 to 0.4 steps/interval; and a decelerating one to rest.
        let u = |steps_per_interval: f64| steps_per_interval * ONE_STEP as f64;
        for (s, t, r0, r1) in
            [(1000, 4000, u(0.1), u(0.4)), (300, 1200, u(0.5), 0.0), (1, 40_000, 0.0, 0.0), (7, 8, u(0.9), u(0.9))]
        {
            let (rate, accel) = fit_axis(s, t, r0, r1).unwrap_or_else(|| panic!("{s} {t}"));
            let (ran, net, _) = run_lm(rate, s, accel);
            assert_eq!((ran, net), (t, i64::from(s)), "{s} steps in {t}: LM,{rate},{s},{accel}");
        }
        // The ramp is kept where it fits: 0.1 → 0.4 steps/interval stays a ramp, not a constant rate.
        let (rate, accel) = fit_axis(1000, 4000, u(0.1), u(0.4)).unwrap();
        assert!(accel > 0 && (f64::from(rate) - u(0.1)).abs() < u(0.01), "{rate} {accel}");
        // One step in every interval needs a rate of 2^31, one more than an LM rate can be: s steps take s + 1.
        assert_eq!(fit_axis(7, 7, u(1.0), u(1.0)), None);
        assert_eq!(fit_axis(11, 10, 0.0, 0.0), None);
    }
}
