//! An HP-GL program as a list of commands (one mnemonic with its parameters and its `;`), each with the plotter's
//! state before it: the pen in the holder, the `VS` speed, where the pen is and whether it is down. The sender
//! streams command by command, so a pause ends after a whole command, the journal counts commands, and a
//! resumed plot starts at a command with a preamble that puts the plotter back in that state
//! ([`Commands::resume_preamble`]).
//!
//! Only what this project's export writes needs to be understood (`IN`, `IW`, `SP`, `VS`, `PU`/`PD`/`PA` with
//! absolute coordinate lists); other mnemonics are passed on untouched and assumed not to move the pen.

use plotter_path::geometry::hpgl_devices::{HpglDevice, PLU_PER_MM};

use super::timing::{PEN_CHANGE_S, PEN_LIFT_S, accel_plu, cm_s_to_plu, move_seconds};

/// The plotter's state between two commands.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PenState {
    /// The pen in the holder (0: none).
    pub pen: u32,
    /// The `VS` speed, cm/s (`None`: the device's default, its top speed).
    pub velocity: Option<f64>,
    /// Where the pen is, plotter units.
    pub pos: (i32, i32),
    /// Whether it is down.
    pub down: bool,
}

/// One command of the program.
#[derive(Debug, Clone, PartialEq)]
pub struct Command {
    /// Its text, `;` included.
    pub text: String,
    /// The state before it.
    pub before: PenState,
    /// Pen-down millimetres drawn by the program up to and including it.
    pub draw_mm_after: f64,
    /// Estimated plotter seconds of the program up to and including it.
    pub seconds_after: f64,
}

/// A program split into commands.
#[derive(Debug, Clone, PartialEq)]
pub struct Commands {
    /// The commands, in order.
    pub list: Vec<Command>,
    /// The set-up commands (`IN`, `IW`) a resumed plot sends again first.
    pub setup: Vec<String>,
}

/// The numbers of a command's parameters (`None` when one is not a number).
fn numbers(params: &str) -> Option<Vec<f64>> {
    params.split([',', ' ']).filter(|p| !p.is_empty()).map(|p| p.trim().parse().ok()).collect()
}

/// A plotter-unit coordinate (saturating; the export writes `i32`s).
fn plu(v: f64) -> i32 {
    // Clamped to the i32 range first.
    #[allow(clippy::cast_possible_truncation)]
    let r = v.round().clamp(f64::from(i32::MIN), f64::from(i32::MAX)) as i32;
    r
}

impl Commands {
    /// Split `program` (HP-GL text, commands ended by `;`, white space between them ignored) for `device`.
    pub fn split(program: &str, device: &HpglDevice) -> Commands {
        let mut st = PenState { pen: 0, velocity: None, pos: (0, 0), down: false };
        let (mut draw, mut secs) = (0.0, 0.0);
        let accel = accel_plu(device);
        let mut list = Vec::new();
        let mut setup = Vec::new();
        for raw in program.split(';') {
            let text: String = raw.chars().filter(|c| !c.is_whitespace() || *c == ' ').collect();
            let text = text.trim();
            if text.is_empty() {
                continue;
            }
            let before = st;
            let (mn, params) = text.split_at(text.len().min(2));
            let mn = mn.to_ascii_uppercase();
            let nums = numbers(params).unwrap_or_default();
            match mn.as_str() {
                "IN" => {
                    st = PenState { pen: 0, velocity: None, pos: (0, 0), down: false };
                    setup.push(format!("{text};"));
                }
                "IW" => setup.push(format!("{text};")),
                "SP" => {
                    st.pen = nums.first().map_or(0, |&n| u32::try_from(plu(n)).unwrap_or(0));
                    st.down = false;
                    secs += PEN_CHANGE_S;
                }
                "VS" => st.velocity = nums.first().copied(),
                "PU" | "PD" | "PA" => {
                    let down = match mn.as_str() {
                        "PU" => false,
                        "PD" => true,
                        _ => st.down,
                    };
                    if down != st.down {
                        secs += PEN_LIFT_S;
                    }
                    st.down = down;
                    let v = if down {
                        cm_s_to_plu(st.velocity.unwrap_or(device.max_velocity_cm_s).min(device.max_velocity_cm_s))
                    } else {
                        cm_s_to_plu(device.max_velocity_cm_s)
                    };
                    for pair in nums.chunks_exact(2) {
                        let to = (plu(pair[0]), plu(pair[1]));
                        let d = f64::from(to.0 - st.pos.0).hypot(f64::from(to.1 - st.pos.1));
                        if down {
                            draw += d / PLU_PER_MM;
                        }
                        secs += move_seconds(d, v, accel);
                        st.pos = to;
                    }
                }
                _ => {}
            }
            list.push(Command { text: format!("{text};"), before, draw_mm_after: draw, seconds_after: secs });
        }
        Commands { list, setup }
    }

    /// Pen-down millimetres of the whole program.
    pub fn draw_mm(&self) -> f64 {
        self.list.last().map_or(0.0, |c| c.draw_mm_after)
    }

    /// Estimated plotter seconds of the whole program.
    pub fn seconds(&self) -> f64 {
        self.list.last().map_or(0.0, |c| c.seconds_after)
    }

    /// What to send before command `k` so that the plotter is as it was there: the set-up, the pen, its speed,
    /// a pen-up move to where the pen was (and the pen lowered if it was down).
    pub fn resume_preamble(&self, k: usize) -> Vec<String> {
        let mut out = self.setup.clone();
        let Some(c) = self.list.get(k) else { return out };
        let b = c.before;
        if b.pen > 0 {
            out.push(format!("SP{};", b.pen));
        }
        if let Some(v) = b.velocity {
            out.push(format!("VS{};", plotter_path::output::gcode_out::fmt_mm(v, 1)));
        }
        out.push(format!("PU{},{};", b.pos.0, b.pos.1));
        if b.down {
            out.push("PD;".into());
        }
        out
    }

    /// Byte offset just past each command when the commands are sent back to back.
    pub fn ends(&self) -> Vec<usize> {
        self.list
            .iter()
            .scan(0, |at, c| {
                *at += c.text.len();
                Some(*at)
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use plotter_path::geometry::hpgl_devices::device;

    #[test]
    fn states_lengths_and_the_resume_preamble() {
        let d = device("7475a").unwrap();
        let p = "IN;\nIW0,0,11040,7721;\nPU;SP2;\nVS6;\nPU800,6240;\nPD1200,6240,1200,5840;\nPU;SP0;\n";
        let c = Commands::split(p, d);
        let texts: Vec<&str> = c.list.iter().map(|c| c.text.as_str()).collect();
        assert_eq!(
            texts,
            ["IN;", "IW0,0,11040,7721;", "PU;", "SP2;", "VS6;", "PU800,6240;", "PD1200,6240,1200,5840;", "PU;", "SP0;"]
        );
        assert_eq!(c.setup, ["IN;", "IW0,0,11040,7721;"]);
        // Two 400-unit sides = 800 plu = 20 mm.
        assert!((c.draw_mm() - 20.0).abs() < 1e-12);
        let pd = &c.list[6];
        assert_eq!(pd.before, PenState { pen: 2, velocity: Some(6.0), pos: (800, 6240), down: false });
        assert_eq!(c.list[7].before.pos, (1200, 5840));
        assert!(c.list[7].before.down);
        assert_eq!(c.resume_preamble(7), ["IN;", "IW0,0,11040,7721;", "SP2;", "VS6;", "PU1200,5840;", "PD;"]);
        // 6 cm/s = 2400 plu/s at 784 532 plu/s²: each 400-unit side takes 400/2400 + 2400/784532 s.
        let side = 400.0 / 2400.0 + 2400.0 / 784_532.0;
        let travel = (800f64.powi(2) + 6240f64.powi(2)).sqrt();
        let want = PEN_CHANGE_S * 2.0 + move_seconds(travel, 15_240.0, 784_532.0) + 2.0 * PEN_LIFT_S + 2.0 * side;
        assert!((c.seconds() - want).abs() < 1e-9, "{} {want}", c.seconds());
        assert_eq!(c.ends()[..3], [3, 20, 23]);
    }
}
