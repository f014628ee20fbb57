//! GRBL's `$$` settings against the machine profile: read them, compare the ones a plot depends on (steps/mm
//! `$100-102`, maximum rates `$110-112` in mm/min, accelerations `$120-122` in mm/s², travel `$130-132` in mm),
//! and build a profile from them (`--profile-from-machine`).

use std::collections::BTreeMap;

use plotter_path::MachineProfile;
use plotter_path::config::profile::AxisProfile;

/// Setting numbers of GRBL 1.1 used here.
pub mod key {
    /// Junction deviation, mm.
    pub const JUNCTION_DEVIATION: u16 = 11;
    /// Soft limits enable.
    pub const SOFT_LIMITS: u16 = 20;
    /// Hard limits enable.
    pub const HARD_LIMITS: u16 = 21;
    /// Homing cycle enable.
    pub const HOMING: u16 = 22;
    /// Homing locate feed, mm/min.
    pub const HOMING_FEED: u16 = 24;
    /// Homing seek rate, mm/min.
    pub const HOMING_SEEK: u16 = 25;
    /// Homing switch debounce, ms.
    pub const HOMING_DEBOUNCE: u16 = 26;
    /// Homing pull-off, mm.
    pub const HOMING_PULL_OFF: u16 = 27;
    /// Maximum spindle speed (servo pens: the largest `S`).
    pub const SPINDLE_MAX: u16 = 30;
    /// X steps/mm (+1 Y, +2 Z).
    pub const STEPS_PER_MM: u16 = 100;
    /// X maximum rate, mm/min (+1 Y, +2 Z).
    pub const MAX_RATE: u16 = 110;
    /// X acceleration, mm/s² (+1 Y, +2 Z).
    pub const ACCEL: u16 = 120;
    /// X maximum travel, mm (+1 Y, +2 Z).
    pub const MAX_TRAVEL: u16 = 130;
}

/// The controller's settings, by number.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct GrblSettings {
    /// `$n` → value.
    pub values: BTreeMap<u16, f64>,
}

/// One setting that disagrees with the profile.
#[derive(Debug, Clone, PartialEq)]
pub struct Mismatch {
    /// Setting number.
    pub key: u16,
    /// What the machine has.
    pub machine: f64,
    /// What the profile says (in the setting's unit).
    pub profile: f64,
    /// What the difference does to a plot.
    pub consequence: String,
}

impl std::fmt::Display for Mismatch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "${}={} on the machine, the profile says {}: {}",
            self.key, self.machine, self.profile, self.consequence
        )
    }
}

const AXES: [char; 3] = ['X', 'Y', 'Z'];

fn axis(profile: &MachineProfile, i: usize) -> &AxisProfile {
    match i {
        0 => &profile.axes.x,
        1 => &profile.axes.y,
        _ => &profile.axes.z,
    }
}

fn axis_mut(profile: &mut MachineProfile, i: usize) -> &mut AxisProfile {
    match i {
        0 => &mut profile.axes.x,
        1 => &mut profile.axes.y,
        _ => &mut profile.axes.z,
    }
}

fn differs(a: f64, b: f64) -> bool {
    (a - b).abs() > 1e-3 * a.abs().max(b.abs()).max(1e-9)
}

fn key_for(base: u16, i: usize) -> u16 {
    // i < 3.
    base + u16::try_from(i).unwrap_or(0)
}

impl GrblSettings {
    /// A setting's value.
    pub fn get(&self, key: u16) -> Option<f64> {
        self.values.get(&key).copied()
    }

    /// Whether the homing cycle is enabled (`$22`).
    pub fn homing_enabled(&self) -> bool {
        self.get(key::HOMING).is_some_and(|v| v != 0.0)
    }

    /// The `$$` listing (`$n=value` lines), as GRBL prints it.
    pub fn listing(&self) -> Vec<String> {
        self.values
            .iter()
            .map(|(k, v)| if v.fract() == 0.0 && *k < 100 { format!("${k}={v:.0}") } else { format!("${k}={v:.3}") })
            .collect()
    }

    /// Settings a controller set up for `profile` would hold (what the emulator starts with).
    pub fn for_profile(profile: &MachineProfile) -> GrblSettings {
        let mut v = BTreeMap::new();
        let h = &profile.homing;
        for (k, val) in [
            (0, 10.0),
            (1, 25.0),
            (2, 0.0),
            (3, 0.0),
            (4, 0.0),
            (5, 0.0),
            (6, 0.0),
            (10, 1.0),
            (key::JUNCTION_DEVIATION, profile.motion.junction_deviation_mm),
            (12, 0.002),
            (13, 0.0),
            (key::SOFT_LIMITS, 1.0),
            (key::HARD_LIMITS, 1.0),
            (key::HOMING, 1.0),
            (23, 0.0),
            (key::HOMING_FEED, h.locate_mm_s * 60.0),
            (key::HOMING_SEEK, h.seek_mm_s * 60.0),
            (key::HOMING_DEBOUNCE, h.debounce_ms),
            (key::HOMING_PULL_OFF, h.pull_off_mm),
            (key::SPINDLE_MAX, 1000.0),
            (31, 0.0),
            (32, 0.0),
        ] {
            v.insert(k, val);
        }
        for i in 0..3 {
            let a = axis(profile, i);
            v.insert(key_for(key::STEPS_PER_MM, i), a.steps_per_mm);
            v.insert(key_for(key::MAX_RATE, i), a.max_feed_mm_s * 60.0);
            v.insert(key_for(key::ACCEL, i), a.max_accel_mm_s2);
            v.insert(key_for(key::MAX_TRAVEL, i), a.travel_mm);
        }
        GrblSettings { values: v }
    }

    /// The settings that disagree with `profile`, with what each does to a plot. The Z axis is left out for a
    /// servo pen (it does not move).
    pub fn compare(&self, profile: &MachineProfile) -> Vec<Mismatch> {
        let mut out = Vec::new();
        let axes = if profile.pen.uses_servo() { 2 } else { 3 };
        for (i, &name) in AXES.iter().enumerate().take(axes) {
            let a = axis(profile, i);
            let k = key_for(key::STEPS_PER_MM, i);
            if let Some(m) = self.get(k)
                && differs(m, a.steps_per_mm)
            {
                let pct = (a.steps_per_mm / m - 1.0) * 100.0;
                out.push(Mismatch {
                    key: k,
                    machine: m,
                    profile: a.steps_per_mm,
                    consequence: format!("{name} would come out {pct:+.2} % the size the profile expects"),
                });
            }
            let k = key_for(key::MAX_RATE, i);
            if let Some(m) = self.get(k)
                && m < a.max_feed_mm_s * 60.0 * (1.0 - 1e-3)
            {
                out.push(Mismatch {
                    key: k,
                    machine: m,
                    profile: a.max_feed_mm_s * 60.0,
                    consequence: format!(
                        "the machine limits {name} to a lower rate, so the plot takes longer than estimated"
                    ),
                });
            }
            let k = key_for(key::ACCEL, i);
            if let Some(m) = self.get(k)
                && m < a.max_accel_mm_s2 * (1.0 - 1e-3)
            {
                out.push(Mismatch {
                    key: k,
                    machine: m,
                    profile: a.max_accel_mm_s2,
                    consequence: format!(
                        "{name} accelerates more slowly than planned, so the plot takes longer than estimated"
                    ),
                });
            }
            let k = key_for(key::MAX_TRAVEL, i);
            if let Some(m) = self.get(k)
                && m < a.travel_mm * (1.0 - 1e-3)
            {
                out.push(Mismatch {
                    key: k,
                    machine: m,
                    profile: a.travel_mm,
                    consequence: format!(
                        "{name} travel is shorter than the profile's: a drawing near the edge raises a soft-limit alarm"
                    ),
                });
            }
        }
        out
    }

    /// `base` with the axes taken from the machine (steps/mm, rates, accelerations, travel, junction deviation),
    /// for `--profile-from-machine`. Missing settings are an error naming them.
    pub fn to_profile(&self, base: &MachineProfile) -> anyhow::Result<MachineProfile> {
        let mut p = base.clone();
        let need = |k: u16| -> anyhow::Result<f64> {
            let v = self.get(k).ok_or_else(|| anyhow::anyhow!("the machine did not report ${k}"))?;
            if !(v.is_finite() && v >= 0.0) {
                anyhow::bail!("the machine reports ${k}={v}, which cannot drive a plot");
            }
            Ok(v)
        };
        for i in 0..3 {
            let spm = need(key_for(key::STEPS_PER_MM, i))?;
            let rate = need(key_for(key::MAX_RATE, i))? / 60.0;
            let accel = need(key_for(key::ACCEL, i))?;
            let travel = need(key_for(key::MAX_TRAVEL, i))?;
            let a = axis_mut(&mut p, i);
            (a.steps_per_mm, a.max_feed_mm_s, a.max_accel_mm_s2, a.travel_mm) = (spm, rate, accel, travel);
        }
        if let Some(j) = self.get(key::JUNCTION_DEVIATION).filter(|j| *j > 0.0) {
            p.motion.junction_deviation_mm = j;
        }
        // The profile's feeds must stay within the machine's rates.
        let max_xy = p.axes.x.max_feed_mm_s.min(p.axes.y.max_feed_mm_s);
        p.pen.travel_feed_mm_s = p.pen.travel_feed_mm_s.min(max_xy);
        p.pen.draw_feed_mm_s = p.pen.draw_feed_mm_s.min(max_xy);
        p.name = format!("{} (axes from the machine's settings)", base.name);
        let text = toml::to_string(&p)?;
        Ok(MachineProfile::from_toml(&text, "the machine's settings")?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_made_for_a_profile_match_it() {
        let p = MachineProfile::default_plotter();
        let s = GrblSettings::for_profile(&p);
        assert!(s.compare(&p).is_empty());
        assert_eq!(s.get(110), Some(9000.0), "150 mm/s = 9000 mm/min");
        assert!(s.listing().contains(&"$100=80.000".to_string()));
        assert!(s.listing().contains(&"$22=1".to_string()));
    }

    #[test]
    fn mismatches_say_what_they_do() {
        let p = MachineProfile::default_plotter();
        let mut s = GrblSettings::for_profile(&p);
        s.values.insert(100, 79.0);
        s.values.insert(111, 6000.0); // 100 mm/s < 150
        s.values.insert(112, 6000.0); // more than the profile's Z: fine
        s.values.insert(131, 250.0);
        let m = s.compare(&p);
        let keys: Vec<u16> = m.iter().map(|x| x.key).collect();
        assert_eq!(keys, [100, 111, 131]);
        // 80 / 79 = 1.01266: 1.27 % larger.
        assert!(m[0].to_string().contains("X would come out +1.27 %"), "{}", m[0]);
        assert!(m[2].consequence.contains("soft-limit"));
        let mut servo = p.clone();
        servo.pen.command = plotter_path::config::profile::PenCommand::Servo;
        s.values.insert(102, 1.0);
        assert!(!s.compare(&servo).iter().any(|x| x.key == 102), "no Z for a servo pen");
    }

    #[test]
    fn profile_from_machine_takes_the_axes() {
        let p = MachineProfile::default_plotter();
        let mut s = GrblSettings::for_profile(&p);
        s.values.insert(100, 40.0);
        s.values.insert(110, 3000.0);
        s.values.insert(121, 250.0);
        s.values.insert(130, 300.0);
        let q = s.to_profile(&p).unwrap();
        assert_eq!((q.axes.x.steps_per_mm, q.axes.x.max_feed_mm_s, q.axes.x.travel_mm), (40.0, 50.0, 300.0));
        assert_eq!(q.axes.y.max_accel_mm_s2, 250.0);
        assert_eq!(q.pen.travel_feed_mm_s, 50.0, "travel clamped to the slowest XY rate");
        assert!(s.compare(&q).is_empty());
        s.values.remove(&102);
        assert!(s.to_profile(&p).unwrap_err().to_string().contains("$102"));
    }
}
