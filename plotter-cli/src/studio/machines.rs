//! The studio's machines as the user names them: `NAME=DEVICE[,firmware=ours|grbl|ebb|auto][,profile=FILE][,paper=P]`
//! on the command line (`plotter serve --machine`, repeatable), or a studio file (TOML) of `[[machines]]` tables
//! with `name`, `device`, `firmware`, `profile` and `paper`.
//!
//! `device` is a serial port (or the path `plotter sim --pty` prints), or `sim` for a simulated plotter of our
//! firmware inside the server. `profile` is a machine profile file, or the name of a built-in model
//! (`plotter models`). `paper` is the paper that lies on the machine: a job for "any machine" goes only to a
//! machine whose paper is the job's.

use std::path::Path;

use plotter_path::MachineProfile;
use plotter_path::geometry::layout::Paper;
use serde::Deserialize;

use super::error::{Result, StudioError};
use crate::link::machine::Firmware;
use crate::options::machine::MachineArgs;

/// The device name of the simulated plotter inside the server.
pub const SIM_DEVICE: &str = "sim";

/// One machine of the studio.
#[derive(Debug, Clone)]
pub struct MachineSpec {
    /// Its name (unique in the studio).
    pub name: String,
    /// Its serial device, or [`SIM_DEVICE`].
    pub device: String,
    /// Its firmware.
    pub firmware: Firmware,
    /// The profile file or model name given, if any.
    pub profile_name: Option<String>,
    /// Its machine profile (the built-in kit when none is given).
    pub profile: MachineProfile,
    /// The paper on it, if given.
    pub paper: Option<Paper>,
}

/// A studio file.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct StudioFile {
    machines: Vec<FileMachine>,
}

/// A `[[machines]]` table.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct FileMachine {
    name: String,
    device: String,
    firmware: Option<String>,
    profile: Option<String>,
    paper: Option<String>,
}

fn firmware_named(word: &str, whose: &str) -> Result<Firmware> {
    match word.trim().to_ascii_lowercase().as_str() {
        "ours" => Ok(Firmware::Ours),
        "grbl" => Ok(Firmware::Grbl),
        "ebb" => Ok(Firmware::Ebb),
        "auto" => Ok(Firmware::Auto),
        "hpgl" => Err(StudioError::Invalid(format!(
            "{whose}: the studio does not drive HP-GL plotters yet; plot to one with `plotter plot --firmware hpgl`"
        ))),
        other => Err(StudioError::Invalid(format!("{whose}: unknown firmware \"{other}\" (ours, grbl, ebb or auto)"))),
    }
}

/// The profile a file or a model name gives (relative files from `base`).
fn profile_named(given: Option<&str>, base: &Path, whose: &str) -> Result<MachineProfile> {
    let args = match given {
        None => MachineArgs::default(),
        Some(p) if plotter_path::config::models::find(p).is_some() && !base.join(p).exists() => {
            MachineArgs { model: Some(p.to_string()), ..MachineArgs::default() }
        }
        Some(p) => MachineArgs { profile: Some(base.join(p)), ..MachineArgs::default() },
    };
    args.load().map_err(|e| StudioError::Invalid(format!("{whose}: {e}")))
}

fn spec(
    name: &str,
    device: &str,
    firmware: Option<&str>,
    profile: Option<&str>,
    paper: Option<&str>,
    base: &Path,
    whose: &str,
) -> Result<MachineSpec> {
    let name = name.trim();
    if name.is_empty() || name.len() > 64 || !name.chars().all(|c| c.is_alphanumeric() || "-_.".contains(c)) {
        return Err(StudioError::Invalid(format!(
            "{whose}: a machine's name is 1 to 64 letters, digits, '-', '_' or '.', not \"{name}\""
        )));
    }
    if device.trim().is_empty() {
        return Err(StudioError::Invalid(format!("{whose}: machine \"{name}\" has no device")));
    }
    let paper = paper
        .map(|p| p.parse::<Paper>().map_err(|e| StudioError::Invalid(format!("{whose}: paper: {e}"))))
        .transpose()?;
    Ok(MachineSpec {
        name: name.to_string(),
        device: device.trim().to_string(),
        firmware: firmware.map_or(Ok(Firmware::Auto), |f| firmware_named(f, whose))?,
        profile_name: profile.map(str::to_string),
        profile: profile_named(profile, base, whose)?,
        paper,
    })
}

/// A machine from `--machine NAME=DEVICE[,firmware=…][,profile=…][,paper=…]` (profile files relative to the
/// current directory).
pub fn parse_machine(text: &str) -> Result<MachineSpec> {
    let whose = format!("--machine {text}");
    let mut parts = text.split(',');
    let head = parts.next().unwrap_or("");
    let (name, device) = head
        .split_once('=')
        .ok_or_else(|| StudioError::Invalid(format!("{whose}: expected NAME=DEVICE first, e.g. left=/dev/ttyACM0")))?;
    let (mut firmware, mut profile, mut paper) = (None, None, None);
    for part in parts {
        let (key, value) = part
            .split_once('=')
            .ok_or_else(|| StudioError::Invalid(format!("{whose}: \"{part}\" is not KEY=VALUE")))?;
        let slot = match key.trim() {
            "firmware" => &mut firmware,
            "profile" => &mut profile,
            "paper" => &mut paper,
            other => {
                return Err(StudioError::Invalid(format!(
                    "{whose}: unknown key \"{other}\" (firmware, profile or paper)"
                )));
            }
        };
        *slot = Some(value.trim());
    }
    spec(name, device, firmware, profile, paper, Path::new(""), &whose)
}

/// The machines of a studio file (profile files relative to the studio file's folder).
pub fn read_studio_file(path: &Path) -> Result<Vec<MachineSpec>> {
    let shown = path.display().to_string();
    let text = std::fs::read_to_string(path)
        .map_err(|e| StudioError::Invalid(format!("{shown}: cannot read the studio file: {e}")))?;
    let file: StudioFile = toml::from_str(&text).map_err(|e| StudioError::Invalid(format!("{shown}: {e}")))?;
    let base = path.parent().unwrap_or(Path::new(""));
    file.machines
        .iter()
        .enumerate()
        .map(|(i, m)| {
            let whose = format!("{shown}: machine {} (\"{}\")", i + 1, m.name);
            spec(&m.name, &m.device, m.firmware.as_deref(), m.profile.as_deref(), m.paper.as_deref(), base, &whose)
        })
        .collect()
}

/// Every machine named once, or an error naming the name used twice; none at all is an error too.
pub fn check_unique(machines: &[MachineSpec]) -> Result<()> {
    if machines.is_empty() {
        return Err(StudioError::Invalid("a studio needs at least one machine".into()));
    }
    for (i, m) in machines.iter().enumerate() {
        if machines[..i].iter().any(|o| o.name == m.name) {
            return Err(StudioError::Invalid(format!("two machines are named \"{}\"", m.name)));
        }
        if m.device != SIM_DEVICE
            && let Some(o) = machines[..i].iter().find(|o| o.device == m.device)
        {
            return Err(StudioError::Invalid(format!(
                "machines \"{}\" and \"{}\" are both on {}",
                o.name, m.name, m.device
            )));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_machine_flag_reads_its_keys_and_refuses_bad_ones_by_name() {
        let m = parse_machine("left=/dev/ttyACM0,firmware=grbl,paper=a5").unwrap();
        assert_eq!((m.name.as_str(), m.device.as_str(), m.firmware), ("left", "/dev/ttyACM0", Firmware::Grbl));
        assert_eq!(m.paper, Some(Paper { width_mm: 148.0, height_mm: 210.0 }));
        assert_eq!(m.profile.name, MachineProfile::default_plotter().name);
        let ax = parse_machine("ax=/dev/ttyACM1,firmware=ebb,profile=axidraw-v3").unwrap();
        assert_eq!(ax.firmware, Firmware::Ebb);
        assert!(ax.profile.ebb.is_some(), "the built-in AxiDraw model");
        assert_eq!(parse_machine("s=sim").unwrap().firmware, Firmware::Auto);
        for (bad, says) in [
            ("left", "expected NAME=DEVICE"),
            ("left=/dev/x,speed=3", "unknown key \"speed\""),
            ("left=/dev/x,firmware=marlin", "unknown firmware \"marlin\""),
            ("left=/dev/x,firmware=hpgl", "does not drive HP-GL"),
            ("a b=/dev/x", "a machine's name"),
            ("left=", "has no device"),
            ("left=/dev/x,profile=/no/such.toml", "/no/such.toml"),
            ("left=/dev/x,paper=huge", "paper"),
        ] {
            let e = parse_machine(bad).unwrap_err().to_string();
            assert!(e.contains(says) && e.starts_with(&format!("--machine {bad}")), "{bad}: {e}");
        }
    }

    #[test]
    fn a_studio_file_lists_machines_and_names_the_bad_one() {
        let dir = std::env::temp_dir().join(format!("studio-file-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("studio.toml");
        std::fs::write(
            &file,
            "[[machines]]\nname = \"a\"\ndevice = \"sim\"\n\n[[machines]]\nname = \"b\"\ndevice = \"/dev/ttyUSB0\"\n\
             firmware = \"grbl\"\npaper = \"a4\"\n",
        )
        .unwrap();
        let ms = read_studio_file(&file).unwrap();
        assert_eq!(ms.iter().map(|m| m.name.as_str()).collect::<Vec<_>>(), ["a", "b"]);
        check_unique(&ms).unwrap();
        std::fs::write(&file, "[[machines]]\nname = \"a\"\ndevice = \"sim\"\nfirmware = \"zz\"\n").unwrap();
        let e = read_studio_file(&file).unwrap_err().to_string();
        assert!(e.contains("machine 1 (\"a\")") && e.contains("\"zz\""), "{e}");
        std::fs::write(&file, "[[machines]]\nname = \"a\"\n").unwrap();
        let e = read_studio_file(&file).unwrap_err().to_string();
        assert!(e.contains("device"), "{e}");
        let twice = [parse_machine("a=/dev/x").unwrap(), parse_machine("a=/dev/y").unwrap()];
        assert!(check_unique(&twice).unwrap_err().to_string().contains("two machines are named \"a\""));
        let shared = [parse_machine("a=/dev/x").unwrap(), parse_machine("b=/dev/x").unwrap()];
        assert!(check_unique(&shared).unwrap_err().to_string().contains("both on /dev/x"));
        assert!(check_unique(&[]).is_err());
        std::fs::remove_dir_all(&dir).ok();
    }
}
