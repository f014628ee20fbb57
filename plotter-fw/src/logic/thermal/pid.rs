//! The heater PID loop, run at the fixed thermal rate ([`super::ThermalConfig::period_ms`]).
//!
//! Output is a PWM duty on the 0–255 scale (the units printer firmwares give their gains in, so published and
//! autotuned gains carry over): `u = Kp·e + I + D`, with `e = setpoint − temperature`, the integral
//! `I = Σ Ki·e·dt` (Ki per second) and the derivative taken on the *measurement*, `D = −Kd·dT/dt` (Kd in seconds),
//! so a setpoint change gives no derivative kick. The derivative is smoothed by a first-order filter (half the new
//! value each period) because thermistor readings are noisy.
//!
//! Anti-windup by conditional integration: the integral only moves when the output is not saturated, or when the
//! error would bring it out of saturation, and it stays within `[0, max]`. During a long heat-up at full power the
//! integral therefore stays where it was instead of winding up and overshooting the target.

/// PID gains, output in duty units (0–255) per °C.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PidGains {
    /// Proportional gain, duty/°C.
    pub kp: f32,
    /// Integral gain, duty/(°C·s).
    pub ki: f32,
    /// Derivative gain, duty·s/°C.
    pub kd: f32,
}

impl PidGains {
    /// Whether all gains are finite and non-negative, with a positive Kp.
    pub fn is_valid(&self) -> bool {
        self.kp.is_finite()
            && self.kp > 0.0
            && self.ki.is_finite()
            && self.ki >= 0.0
            && self.kd.is_finite()
            && self.kd >= 0.0
    }
}

/// The PID state of one heater.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Pid {
    integral: f32,
    prev: Option<f32>,
    d_filtered: f32,
}

impl Pid {
    /// A fresh controller.
    pub const fn new() -> Self {
        Pid { integral: 0.0, prev: None, d_filtered: 0.0 }
    }

    /// Forget the history (heater switched off or the target changed from off).
    pub fn reset(&mut self) {
        *self = Pid::new();
    }

    /// The integral term, duty.
    pub fn integral(&self) -> f32 {
        self.integral
    }

    /// One control step `dt_s` seconds after the previous one: the duty in `[0, max]`.
    pub fn update(&mut self, g: &PidGains, setpoint: f32, measured: f32, dt_s: f32, max: f32) -> f32 {
        let e = setpoint - measured;
        let d_raw = match self.prev {
            Some(p) if dt_s > 0.0 => -g.kd * (measured - p) / dt_s,
            _ => 0.0,
        };
        self.prev = Some(measured);
        self.d_filtered += 0.5 * (d_raw - self.d_filtered);
        let p = g.kp * e;
        let unsat = p + self.integral + self.d_filtered;
        let pushing_up = unsat >= max && e > 0.0;
        let pushing_down = unsat <= 0.0 && e < 0.0;
        if !pushing_up && !pushing_down {
            self.integral = crate::fmath::clamp(self.integral + g.ki * e * dt_s, 0.0, max);
        }
        crate::fmath::clamp(p + self.integral + self.d_filtered, 0.0, max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integral_grows_linearly_below_saturation() {
        // Ki only: constant error 2 °C for 10 steps of 0.1 s at Ki = 1 → integral 2·1·0.1·10 = 2.
        let g = PidGains { kp: 1e-6, ki: 1.0, kd: 0.0 };
        let mut pid = Pid::new();
        let mut out = 0.0;
        for _ in 0..10 {
            out = pid.update(&g, 100.0, 98.0, 0.1, 255.0);
        }
        assert!((pid.integral() - 2.0).abs() < 1e-4, "{}", pid.integral());
        assert!((out - 2.0).abs() < 1e-3);
    }

    #[test]
    fn no_windup_while_saturated() {
        // 100 °C below target with Kp = 10: P alone saturates, so 1000 s of heat-up leave the integral untouched.
        let g = PidGains { kp: 10.0, ki: 1.0, kd: 0.0 };
        let mut pid = Pid::new();
        for _ in 0..10_000 {
            assert_eq!(pid.update(&g, 200.0, 100.0, 0.1, 255.0), 255.0);
        }
        assert_eq!(pid.integral(), 0.0);
        // Above the target, the output is zero and the integral cannot go negative.
        for _ in 0..100 {
            assert_eq!(pid.update(&g, 200.0, 250.0, 0.1, 255.0), 0.0);
        }
        assert_eq!(pid.integral(), 0.0);
    }

    #[test]
    fn derivative_acts_on_the_measurement() {
        let g = PidGains { kp: 0.0, ki: 0.0, kd: 10.0 };
        let mut pid = Pid::new();
        assert_eq!(pid.update(&g, 50.0, 20.0, 0.1, 255.0), 0.0);
        // A setpoint jump alone gives no kick.
        assert_eq!(pid.update(&g, 200.0, 20.0, 0.1, 255.0), 0.0);
        // Falling 1 °C in 0.1 s: raw D = 10·10 = 100, half of it after the filter.
        assert!((pid.update(&g, 200.0, 19.0, 0.1, 255.0) - 50.0).abs() < 1e-3);
    }
}
