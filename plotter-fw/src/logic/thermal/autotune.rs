//! PID autotune (`M303`) by the relay method (Åström–Hägglund).
//!
//! The heater is driven by a relay around the target: full output `bias + d` while the temperature is below
//! `target − h`, `bias − d` once it is above `target + h`. The loop settles into a limit cycle whose period `Tu` and
//! temperature amplitude `a` give the ultimate gain by the describing function of a relay with hysteresis,
//! `Ku = 4d / (π·√(a² − h²))`. The Ziegler–Nichols rules for a PID then give `Kp = 0.6·Ku`, `Ki = 2·Kp/Tu`,
//! `Kd = Kp·Tu/8` (Ki per second, Kd in seconds, output in duty units 0–255).
//!
//! After each full cycle the bias is moved so that the on and off times become equal (a heater loses heat faster
//! when hot, so a 50 % relay gives a lopsided cycle and a worse estimate): `bias += d·(t_on − t_off)/(t_on + t_off)`,
//! with `d = min(bias, max − bias)`. The first cycle (heating up from cold) is not used; the gains are the mean over
//! the remaining ones.

use super::pid::PidGains;
use super::safety::ticks;

/// Most cycles `M303 C` may ask for.
pub const MAX_CYCLES: u8 = 20;
/// Relay hysteresis, °C (above the sensor noise, so the relay does not chatter).
pub const HYSTERESIS_C: f32 = 0.5;
/// Autotune gives up when the temperature overshoots the target by this much, °C.
pub const ABORT_OVERSHOOT_C: f32 = 30.0;
/// Autotune gives up after this long, s.
pub const TIMEOUT_S: f32 = 1800.0;

/// What the autotune wants this period.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Step {
    /// Drive the heater at this duty.
    Drive(f32),
    /// Finished: the gains.
    Done(PidGains),
    /// Gave up.
    Failed(&'static str),
}

/// A running autotune.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Autotune {
    target: f32,
    max: f32,
    cycles: u8,
    started: u64,
    on: bool,
    bias: f32,
    d: f32,
    t_on: u64,
    t_off: u64,
    high_ticks: Option<u64>,
    low_ticks: Option<u64>,
    peak: f32,
    trough: f32,
    last_peak: Option<f32>,
    offs: u8,
    results: u8,
    sum: [f32; 3],
}

impl Autotune {
    /// Start at `now` towards `target` with at most `max` duty, for `cycles` cycles (3..=[`MAX_CYCLES`]).
    pub fn new(now: u64, target: f32, max: f32, cycles: u8) -> Self {
        Autotune {
            target,
            max,
            cycles: cycles.clamp(3, MAX_CYCLES),
            started: now,
            on: true,
            bias: max / 2.0,
            d: max / 2.0,
            t_on: now,
            t_off: now,
            high_ticks: None,
            low_ticks: None,
            peak: f32::MIN,
            trough: f32::MAX,
            last_peak: None,
            offs: 0,
            results: 0,
            sum: [0.0; 3],
        }
    }

    /// The target, °C.
    pub fn target(&self) -> f32 {
        self.target
    }

    /// One period at `now` with the heater at `temp`.
    pub fn tick(&mut self, now: u64, temp: f32) -> Step {
        if temp > self.target + ABORT_OVERSHOOT_C {
            return Step::Failed("temperature far above the target");
        }
        if now - self.started > ticks(TIMEOUT_S) {
            return Step::Failed("no stable oscillation within 30 minutes");
        }
        self.peak = self.peak.max(temp);
        self.trough = self.trough.min(temp);
        if self.on && temp > self.target + HYSTERESIS_C {
            // Switch off: one on-phase is complete (its trough is known now).
            self.on = false;
            self.t_off = now;
            let high = now - self.t_on;
            self.high_ticks = Some(high);
            self.offs = self.offs.saturating_add(1);
            if let (Some(peak), Some(low), true) = (self.last_peak, self.low_ticks, self.offs >= 3) {
                let a = (peak - self.trough) / 2.0;
                let tu = (high + low) as f32 / 1e6;
                if a > HYSTERESIS_C && tu > 0.0 {
                    let ku = 4.0 * self.d
                        / (core::f32::consts::PI * crate::fmath::sqrt(a * a - HYSTERESIS_C * HYSTERESIS_C));
                    let kp = 0.6 * ku;
                    self.sum[0] += kp;
                    self.sum[1] += 2.0 * kp / tu;
                    self.sum[2] += kp * tu / 8.0;
                    self.results += 1;
                }
            }
            self.peak = temp;
            if self.results >= self.cycles - 1 {
                let n = f32::from(self.results);
                return Step::Done(PidGains { kp: self.sum[0] / n, ki: self.sum[1] / n, kd: self.sum[2] / n });
            }
        } else if !self.on && temp < self.target - HYSTERESIS_C {
            // Switch on: one off-phase is complete (its peak is known now).
            self.on = true;
            self.t_on = now;
            let low = now - self.t_off;
            self.low_ticks = Some(low);
            self.last_peak = Some(self.peak);
            if let (Some(high), true) = (self.high_ticks, self.offs >= 2) {
                let (h, l) = (high as f32, low as f32);
                self.bias = crate::fmath::clamp(self.bias + self.d * (h - l) / (h + l), 0.1 * self.max, 0.9 * self.max);
                self.d = self.bias.min(self.max - self.bias);
            }
            self.trough = temp;
        }
        Step::Drive(if self.on { self.bias + self.d } else { self.bias - self.d })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A first-order heater with dead time, integrated here with explicit Euler at 10 ms (independent of the
    /// simulator's model): gains come out positive and the cycle count is honoured.
    #[test]
    fn relay_on_a_dead_time_plant_gives_positive_gains() {
        let (c, k, p, amb) = (12.0f32, 0.1f32, 40.0f32, 20.0f32);
        let mut t = amb;
        let mut delay = std::collections::VecDeque::from(std::vec![amb; 200]); // 2 s dead time
        let mut at = Autotune::new(0, 200.0, 255.0, 5);
        let mut duty = 0.0;
        let mut done = None;
        for step in 0..2_000_000u64 {
            let now = step * 10_000;
            t += 0.01 * (p * duty / 255.0 - k * (t - amb)) / c;
            delay.push_back(t);
            let seen = delay.pop_front().unwrap();
            if step % 10 == 0 {
                match at.tick(now, seen) {
                    Step::Drive(d) => duty = d,
                    Step::Done(g) => {
                        done = Some((g, now));
                        break;
                    }
                    Step::Failed(why) => panic!("{why}"),
                }
            }
        }
        let (g, _) = done.expect("autotune finished");
        assert!(g.is_valid() && g.ki > 0.0 && g.kd > 0.0, "{g:?}");
        assert_eq!(at.results, 4);
    }

    #[test]
    fn overshoot_aborts() {
        let mut at = Autotune::new(0, 200.0, 255.0, 5);
        assert_eq!(at.tick(100, 150.0), Step::Drive(255.0));
        assert!(matches!(at.tick(200, 231.0), Step::Failed(_)));
    }
}
