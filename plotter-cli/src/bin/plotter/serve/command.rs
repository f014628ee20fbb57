//! What the HTTP side asks the machine worker to do (sent over a channel the shared state holds).

use std::sync::Arc;

use plotter_host::job::prepare::Prepared;
use plotter_host::link::hpgl::handshake::Handshake;
use plotter_host::link::jog::JogTarget;
use plotter_host::link::machine::Firmware;
use plotter_path::MachineProfile;
use plotter_path::geometry::hpgl_devices::{self, HpglDevice, HpglPaper};

/// What the worker is asked to do.
pub(crate) enum Command {
    /// Connect to the simulator (`None`, our firmware) or a serial device speaking the firmware (detected when
    /// [`Firmware::Auto`]), with a profile; an HP-GL plotter (firmware `hpgl`) with its device and handshake.
    Connect(Option<String>, Firmware, Box<MachineProfile>, Option<HpglChoice>),
    /// Close the link.
    Disconnect,
    /// Home.
    Home,
    /// Move an axis (x, y, z) by mm, or lift/lower the pen.
    Jog(JogTarget, Option<f64>),
    /// Send a console line.
    Console(String),
    /// Lower the pen, wait a moment, raise it, with this profile's pen settings (the sliders').
    TestPen(Box<MachineProfile>),
    /// Switch the motors off, so the carriage can be pushed by hand.
    MotorsOff,
    /// Plot.
    Plot(PlotJob),
    /// Continue the interrupted plot whose journal is at this path.
    ResumePlot(PlotJob, std::path::PathBuf),
}

/// A plot the worker is asked to run.
pub(crate) struct PlotJob {
    /// The drawing, laid out and planned.
    pub(crate) prepared: Arc<Prepared>,
    /// The profile to plot with (the sliders applied).
    pub(crate) profile: Box<MachineProfile>,
    /// The drawing's name, as the page shows it (and its journal is named by).
    pub(crate) drawing: String,
}

/// How to drive an HP-GL plotter: the device the program is written for (as the CLI's `--hpgl-device`), the
/// sheet loaded (`None`: the first of the device's sheets that holds the drawing) and the buffer handshake.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct HpglChoice {
    /// The plotter model.
    pub(crate) device: &'static HpglDevice,
    /// The sheet loaded.
    pub(crate) paper: Option<HpglPaper>,
    /// How the sender keeps its buffer from overflowing.
    pub(crate) handshake: Handshake,
    /// The line's baud rate (9600 unless asked, as `plotter plot --firmware hpgl`).
    pub(crate) baud: u32,
}

/// What a connect request for an HP-GL plotter names: `hpgl_device` (default `7475a`, as the CLI),
/// `hpgl_paper` (default: the first sheet that holds the drawing), `handshake` (default `escb`) and `baud`
/// (default 9600). The error names the field and the choices, for the page.
pub(crate) fn hpgl_choice(
    device: Option<&str>,
    paper: Option<&str>,
    handshake: Option<&str>,
    baud: Option<u32>,
) -> Result<HpglChoice, String> {
    use clap::ValueEnum as _;
    let name = device.map_or("7475a", str::trim);
    let device = hpgl_devices::device(name).ok_or_else(|| {
        format!("hpgl_device {name:?}: not a known plotter (known: {})", hpgl_devices::device_names())
    })?;
    let paper = match paper.map(str::trim) {
        None => None,
        Some(_) if device.papers.is_empty() => {
            return Err(format!("hpgl_paper: the {} plots on the drawing's own page", device.name));
        }
        Some(p) => Some(
            *device
                .paper(p)
                .ok_or_else(|| format!("hpgl_paper {p:?}: the {} takes {}", device.name, device.paper_names()))?,
        ),
    };
    let handshake = match handshake.map(str::trim) {
        None => Handshake::default(),
        Some(h) => {
            Handshake::from_str(h, true).map_err(|_| format!("handshake {h:?}: use escb, xonxoff or hardware"))?
        }
    };
    let baud = baud.unwrap_or(9600);
    if !(300..=1_000_000).contains(&baud) {
        return Err(format!("baud {baud}: give 300 to 1000000"));
    }
    Ok(HpglChoice { device, paper, handshake, baud })
}

/// The HP-GL choices the page offers (`GET /api/hpgl`), from the device table the server validates against: each
/// device with its pens, buffer and sheets (each sheet's size and plotting area, mm), the default device, and the
/// handshakes. The page's selectors are filled from this, so they cannot offer what [`hpgl_choice`] refuses.
pub(crate) fn hpgl_table() -> serde_json::Value {
    use clap::ValueEnum as _;
    let devices: Vec<serde_json::Value> = hpgl_devices::DEVICES
        .iter()
        .map(|d| {
            let papers: Vec<serde_json::Value> = d
                .papers
                .iter()
                .map(|p| serde_json::json!({ "name": p.name, "size_mm": [p.size_mm.0, p.size_mm.1], "area_mm": p.area_mm() }))
                .collect();
            serde_json::json!({
                "id": d.id, "name": d.name, "pens": d.pens, "buffer_bytes": d.buffer_bytes, "papers": papers,
            })
        })
        .collect();
    let handshakes: Vec<&str> = Handshake::value_variants().iter().map(|h| h.name()).collect();
    serde_json::json!({
        "devices": devices,
        "default_device": hpgl_devices::DEVICES[0].id,
        "handshakes": handshakes,
        "default_handshake": Handshake::default().name(),
    })
}

/// Why `what` (home, jog) is refused on an HP-GL plotter.
pub(crate) fn hpgl_refusal(what: &str) -> String {
    format!(
        "{what} is not available on an HP-GL plotter: it has no homing cycle and moves only by HP-GL (the pen \
         buttons send PU; and PD;); type PU x,y; in the console to move it"
    )
}

/// The firmware a connect request asks for: `auto` (the default, as the CLI's `--firmware`), `ours`, `grbl`,
/// `ebb` or `hpgl`. The built-in simulator runs our firmware only. The error says why, for the page.
pub(crate) fn firmware_choice(simulator: bool, name: Option<&str>) -> Result<Firmware, String> {
    use clap::ValueEnum as _;
    let name = name.map_or("auto", str::trim);
    let firmware = Firmware::from_str(name, true)
        .map_err(|_| format!("unknown firmware {name:?} (auto, ours, grbl, ebb, hpgl)"))?;
    match firmware {
        Firmware::Hpgl if simulator => Err("the built-in simulator runs plotter-fw, not an HP-GL plotter: serve the \
                                            model with `plotter sim --pty --hpgl` and pass its port to `plotter \
                                            serve --port`"
            .into()),
        Firmware::Grbl | Firmware::Ebb if simulator => Err(format!(
            "the built-in simulator runs plotter-fw, not {name}: serve an emulator with `plotter sim --pty --{name}` \
             and pass its port to `plotter serve --port`"
        )),
        f => Ok(f),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn firmware_choices() {
        assert_eq!(firmware_choice(false, None), Ok(Firmware::Auto));
        assert_eq!(firmware_choice(false, Some("GRBL")), Ok(Firmware::Grbl));
        assert_eq!(firmware_choice(false, Some("ebb")), Ok(Firmware::Ebb));
        assert_eq!(firmware_choice(true, Some("ours")), Ok(Firmware::Ours));
        assert_eq!(firmware_choice(true, None), Ok(Firmware::Auto));
        assert_eq!(firmware_choice(false, Some("hpgl")), Ok(Firmware::Hpgl));
        let hpgl = firmware_choice(true, Some("hpgl")).unwrap_err();
        assert!(hpgl.contains("plotter sim --pty --hpgl"), "{hpgl}");
        let sim = firmware_choice(true, Some("ebb")).unwrap_err();
        assert!(sim.contains("plotter sim --pty --ebb"), "{sim}");
        assert_eq!(
            firmware_choice(false, Some("marlin")).unwrap_err(),
            "unknown firmware \"marlin\" (auto, ours, grbl, ebb, hpgl)"
        );
    }

    #[test]
    fn hpgl_choices() {
        let c = hpgl_choice(None, None, None, None).unwrap();
        assert_eq!((c.device.name, c.paper, c.handshake, c.baud), ("HP 7475A", None, Handshake::Escb, 9600));
        let c = hpgl_choice(Some("7550a"), Some("a3"), Some("XonXoff"), Some(19200)).unwrap();
        assert_eq!(c.baud, 19200);
        assert_eq!((c.device.name, c.paper.map(|p| p.name), c.handshake), ("HP 7550A", Some("a3"), Handshake::Xonxoff));
        let e = hpgl_choice(Some("7470b"), None, None, None).unwrap_err();
        assert!(e.starts_with("hpgl_device \"7470b\": not a known plotter (known: "), "{e}");
        let e = hpgl_choice(None, Some("a0"), None, None).unwrap_err();
        assert!(e.starts_with("hpgl_paper \"a0\": the HP 7475A takes "), "{e}");
        assert_eq!(
            hpgl_choice(None, None, Some("rts"), None).unwrap_err(),
            "handshake \"rts\": use escb, xonxoff or hardware"
        );
        assert_eq!(hpgl_choice(None, None, None, Some(0)).unwrap_err(), "baud 0: give 300 to 1000000");
    }

    /// Everything the page is offered is accepted by [`hpgl_choice`]: every device with each of its sheets and
    /// every handshake; the 7475A (the default) lists its four sheets with the plotting areas of the manual.
    #[test]
    fn the_page_is_offered_only_what_connect_accepts() {
        let t = hpgl_table();
        assert_eq!(t["default_device"], "7475a");
        assert_eq!(t["handshakes"], serde_json::json!(["escb", "xonxoff", "hardware"]));
        assert_eq!(t["default_handshake"], "escb");
        let devices = t["devices"].as_array().unwrap();
        assert_eq!(devices.len(), hpgl_devices::DEVICES.len());
        let mut offered = 0;
        for d in devices {
            let id = d["id"].as_str().unwrap();
            for h in t["handshakes"].as_array().unwrap() {
                assert!(hpgl_choice(Some(id), None, h.as_str(), None).is_ok(), "{id} {h}");
            }
            for p in d["papers"].as_array().unwrap() {
                let c = hpgl_choice(Some(id), p["name"].as_str(), None, None).unwrap();
                assert_eq!(c.paper.map(|p| p.name), p["name"].as_str());
                offered += 1;
            }
        }
        // 7475A: 4 sheets, 7550A: 2, DXY-1300: 1, generic: the drawing's page.
        assert_eq!(offered, 7);
        let hp = &devices[0];
        assert_eq!(
            hp["papers"][0],
            serde_json::json!({ "name": "a4", "size_mm": [297.0, 210.0], "area_mm": [276.0, 193.025] })
        );
        assert_eq!((hp["pens"].as_u64(), hp["buffer_bytes"].as_u64()), (Some(6), Some(1024)));
    }
}
