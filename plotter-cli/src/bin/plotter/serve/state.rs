//! The server's shared state: the drawing and its settings, the prepared plot, the machine's state as the worker
//! reports it, who controls, and the snapshot every page is sent.

use std::net::SocketAddr;
use std::sync::{Arc, Condvar, Mutex, MutexGuard, mpsc};
use std::time::Duration;

use plotter_host::input::{Decoded, InputArgs};
use plotter_host::job::page::PageView;
use plotter_host::job::prepare::Prepared;
use plotter_host::link::machine::{Firmware, profile_for};
use plotter_path::MachineProfile;
use plotter_path::motion::servo::ServoSync;
use plotter_path::output::preview::plotting_pen;
use serde::{Deserialize, Serialize};

use super::command::Command;
use super::events::{Event, Hub, ProgressEvent, Prompt};
use super::pen_speed::PenSpeed;

/// The page in control.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Controller {
    /// Its token, sent back in the `X-Plotter-Token` header of every change.
    pub(crate) token: String,
    /// Its open event streams.
    pub(crate) streams: usize,
}

/// Fixed at start-up by `plotter serve`'s flags.
#[derive(Clone)]
pub(crate) struct Config {
    /// The address the server listens on (Host checks use it).
    pub(crate) local: SocketAddr,
    /// Largest upload, bytes.
    pub(crate) max_upload: usize,
    /// Simulator pace, × real time.
    pub(crate) sim_speed: f64,
    /// Serial devices named on the command line (offered besides the detected ports).
    pub(crate) extra_ports: Vec<String>,
    /// Machine profiles on offer: the built-in kit first, the other built-in models, then those named on the
    /// command line.
    pub(crate) profiles: Vec<MachineProfile>,
    /// Time and count limits on clients.
    pub(crate) limits: Limits,
    /// Where plots on a serial port keep their resume journals (`None`: no journals).
    pub(crate) journals: Option<std::path::PathBuf>,
}

/// What one client may hold of the server, so that no client — a hostile page, a port scanner, a half-open
/// connection — can exhaust it:
/// - a connection must send its request head within `header_timeout` of the server waiting for one (also the
///   idle time of a kept-alive connection), and a request's body must arrive within `body_timeout`;
/// - at most `max_connections` connections are open; more are answered 503 and closed at once (a page needs one
///   for its event stream and a few for its requests);
/// - at most `max_imports` drawings are decoded or prepared at once; more are answered 503 (each holds a CPU-bound
///   thread until it ends, even if its client has gone);
/// - a claim of control lapses after `claim_grace` unless the claiming page opens its event stream (the stream
///   then holds control until it closes).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Limits {
    /// Time to send a request head.
    pub(crate) header_timeout: Duration,
    /// Time to send a request body.
    pub(crate) body_timeout: Duration,
    /// Open connections.
    pub(crate) max_connections: usize,
    /// Drawings decoded or prepared at once.
    pub(crate) max_imports: usize,
    /// Time for a claiming page to open its event stream.
    pub(crate) claim_grace: Duration,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            header_timeout: Duration::from_secs(10),
            body_timeout: Duration::from_secs(60),
            max_connections: 64,
            max_imports: 2,
            claim_grace: Duration::from_secs(15),
        }
    }
}

/// Layout, layer and ordering settings as the page sends them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub(crate) struct Settings {
    /// `a3`, `a4`, `a5`, `letter`, `WxH` (mm), `custom` (then `paper_width` × `paper_height` in `paper_unit`),
    /// or empty for the drawing's own page.
    pub(crate) paper: String,
    /// Custom paper width, in `paper_unit`.
    pub(crate) paper_width: f64,
    /// Custom paper height, in `paper_unit`.
    pub(crate) paper_height: f64,
    /// Unit of the custom paper size: `mm`, `cm` or `in`.
    pub(crate) paper_unit: String,
    /// `portrait`, `landscape`, or empty (named papers default to portrait).
    pub(crate) orientation: String,
    /// Margin, mm.
    pub(crate) margin: f64,
    /// Fit inside the margins.
    pub(crate) fit: bool,
    /// Centre on the page.
    pub(crate) center: bool,
    /// Quarter turns clockwise.
    pub(crate) rotate: i32,
    /// Path ordering on.
    pub(crate) optimize: bool,
    /// Raster tracing mode: one of `--mode`'s names (`outline`, `hatch`, `stipple`, `mosaic`, ...).
    pub(crate) trace: String,
    /// How a picture's colours become pens (`--colors`): `gray`, `cmyk` or `pens` (the machine profile's pens).
    pub(crate) colors: String,
    /// Shade filled SVG areas with lines this far apart, mm (0: no hatching).
    pub(crate) hatch_mm: f64,
    /// Shade each filled SVG area by its colour's lightness (`--hatch tone`) instead of one spacing for all.
    pub(crate) hatch_tone: bool,
    /// With hatching: a second family of lines at right angles.
    pub(crate) cross_hatch: bool,
    /// Remove the lines an opaque fill painted later hides (the command line's default; off is `--no-occlusion`).
    pub(crate) hidden_lines: bool,
    /// Per-layer choices.
    pub(crate) layers: Vec<LayerSetting>,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            paper: String::new(),
            paper_width: 210.0,
            paper_height: 297.0,
            paper_unit: "mm".into(),
            orientation: String::new(),
            margin: 10.0,
            fit: false,
            center: false,
            rotate: 0,
            optimize: true,
            trace: "outline".into(),
            colors: "gray".into(),
            hatch_mm: 0.0,
            hatch_tone: false,
            cross_hatch: false,
            hidden_lines: true,
            layers: Vec::new(),
        }
    }
}

/// One layer's setting.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct LayerSetting {
    /// Layer name.
    pub(crate) name: String,
    /// Plotted or not.
    pub(crate) visible: bool,
    /// Pen colour `#rrggbb` (empty: the drawing's own).
    #[serde(default)]
    pub(crate) color: String,
    /// Pen width, mm (0: the drawing's own).
    #[serde(default)]
    pub(crate) width_mm: f64,
}

/// Where the drawing came from.
#[derive(Clone)]
pub(crate) enum Source {
    /// An uploaded file: its name (for kind detection and messages only) and bytes.
    Upload { name: String, bytes: Arc<Vec<u8>> },
    /// A generated figure's spec (after `gen:`).
    Gen(String),
}

/// The decoded drawing and the input options it was decoded with.
pub(crate) struct Loaded {
    /// Where it came from.
    pub(crate) source: Source,
    /// Shown name.
    pub(crate) name: String,
    /// Decoded drawing and warnings.
    pub(crate) decoded: Decoded,
    /// Input options used (re-decoded when the tracing mode changes).
    pub(crate) input: InputArgs,
}

/// What the machine is doing, as the worker reports it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub(crate) struct MachineState {
    /// What it is connected to (`None`: not connected).
    pub(crate) connected: Option<String>,
    /// `idle`, `busy` (a command), `plotting`, `paused`, `connecting`.
    pub(crate) activity: &'static str,
    /// Position in steps, last known (for scripts; people are shown `position_mm`).
    pub(crate) position: Option<[i32; 4]>,
    /// Where the pen is, page mm (X, Y): during a plot the end of the last block the machine executed, else the
    /// position the machine last reported.
    pub(crate) position_mm: Option<[f64; 2]>,
    /// Whether the pen is down (`None`: not known).
    pub(crate) pen_down: Option<bool>,
    /// The motors were switched off (the carriage may have been pushed: home before plotting).
    pub(crate) motors_off: bool,
    /// The connected machine is an HP-GL plotter (no homing, no jogging; the console speaks HP-GL).
    pub(crate) hpgl: bool,
    /// Plots on the connected machine keep a resume journal (a serial port of our firmware, GRBL or an EBB).
    pub(crate) journaled: bool,
    /// The firmware of the machine last connected (`None` before any): estimates are planned for it
    /// ([`Inner::machine_profile`]).
    #[serde(skip)]
    pub(crate) firmware: Option<Firmware>,
    /// Last error.
    pub(crate) error: Option<String>,
}

/// Everything mutable.
pub(crate) struct Inner {
    /// The page in control.
    pub(crate) controller: Option<Controller>,
    /// The drawing.
    pub(crate) loaded: Option<Loaded>,
    /// Current settings.
    pub(crate) settings: Settings,
    /// The drawing ready to plot (and a counter the page watches to refetch the view).
    pub(crate) prepared: Option<Arc<Prepared>>,
    /// Why there is no prepared drawing.
    pub(crate) prepare_error: Option<String>,
    /// Bumped whenever `prepared` changes.
    pub(crate) view_version: u64,
    /// The chosen machine profile (index in the config's list, or an uploaded one), before the sliders.
    pub(crate) profile: MachineProfile,
    /// The pen-height and speed sliders, applied to `profile` for the next plot ([`Inner::machine_profile`]).
    pub(crate) pen_speed: PenSpeed,
    /// An uploaded profile, offered after the configured ones.
    pub(crate) uploaded_profile: Option<MachineProfile>,
    /// The machine.
    pub(crate) machine: MachineState,
    /// The last plot's progress.
    pub(crate) progress: Option<ProgressEvent>,
    /// The question the job waits on.
    pub(crate) prompt: Option<Prompt>,
    /// The as-stepped drawing of the last simulated plot.
    pub(crate) stepped: Option<Arc<PageView>>,
    /// Bumped whenever `stepped` changes.
    pub(crate) stepped_version: u64,
}

impl Inner {
    /// The profile plots are planned and run with: the chosen one with the sliders applied, timed for the firmware
    /// of the machine last connected ([`profile_for`]; before any, for our firmware's simulator, the one a
    /// connection without a port gets).
    pub(crate) fn machine_profile(&self) -> MachineProfile {
        // The sliders were applied to this profile when they were set; a later profile they do not fit keeps its own.
        let p = self.pen_speed.apply(&self.profile).unwrap_or_else(|_| self.profile.clone());
        profile_for(&p, self.machine.firmware.unwrap_or(Firmware::Ours)).into_owned()
    }
}

/// Requests from the HTTP side to a running plot, and answers to its prompts.
#[derive(Default)]
pub(crate) struct PlotControl {
    state: Mutex<ControlState>,
    changed: Condvar,
}

/// See [`PlotControl`].
#[derive(Default)]
pub(crate) struct ControlState {
    /// A pause was asked: `Some(true)` at once, `Some(false)` at the next pen-up.
    pub(crate) pause: Option<bool>,
    /// Cancel the plot.
    pub(crate) cancel: bool,
    /// An answer to prompt `id`.
    pub(crate) answer: Option<(u64, String)>,
}

impl PlotControl {
    /// Change the state and wake the worker.
    pub(crate) fn update(&self, f: impl FnOnce(&mut ControlState)) {
        f(&mut self.state.lock().unwrap_or_else(std::sync::PoisonError::into_inner));
        self.changed.notify_all();
    }

    /// Wait until `f` gives an answer.
    pub(crate) fn wait_for<R>(&self, mut f: impl FnMut(&mut ControlState) -> Option<R>) -> R {
        let mut state = self.state.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        loop {
            if let Some(r) = f(&mut state) {
                return r;
            }
            state = self.changed.wait(state).unwrap_or_else(std::sync::PoisonError::into_inner);
        }
    }

    /// Forget requests from a previous plot.
    pub(crate) fn reset(&self) {
        self.update(|s| *s = ControlState::default());
    }
}

/// Shared by every handler and the machine worker.
pub(crate) struct Shared {
    /// Start-up configuration.
    pub(crate) config: Config,
    /// Event channel to the pages.
    pub(crate) hub: Hub,
    /// Mutable state.
    inner: Mutex<Inner>,
    /// Commands to the machine worker.
    pub(crate) worker: Mutex<mpsc::Sender<Command>>,
    /// Requests to a running plot.
    pub(crate) control: PlotControl,
    /// Slots for decoding and preparing drawings ([`Limits::max_imports`]).
    pub(crate) imports: Arc<tokio::sync::Semaphore>,
}

impl Shared {
    /// New state; `worker` receives machine commands.
    pub(crate) fn new(config: Config, worker: mpsc::Sender<Command>) -> Shared {
        let profile = config.profiles.first().cloned().unwrap_or_else(MachineProfile::default_plotter);
        let imports = Arc::new(tokio::sync::Semaphore::new(config.limits.max_imports));
        Shared {
            config,
            hub: Hub::new(),
            inner: Mutex::new(Inner {
                controller: None,
                loaded: None,
                settings: Settings::default(),
                prepared: None,
                prepare_error: None,
                view_version: 0,
                profile,
                pen_speed: PenSpeed::default(),
                uploaded_profile: None,
                machine: MachineState {
                    connected: None,
                    activity: "idle",
                    position: None,
                    position_mm: None,
                    pen_down: None,
                    motors_off: false,
                    hpgl: false,
                    journaled: false,
                    firmware: None,
                    error: None,
                },
                progress: None,
                prompt: None,
                stepped: None,
                stepped_version: 0,
            }),
            worker: Mutex::new(worker),
            control: PlotControl::default(),
            imports,
        }
    }

    /// Lock the mutable state (a panicked holder leaves it usable: every update is a plain assignment).
    pub(crate) fn lock(&self) -> MutexGuard<'_, Inner> {
        self.inner.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// Send every page the current state.
    pub(crate) fn publish(&self) {
        let snapshot = self.snapshot();
        self.hub.send(Event::new("state", &snapshot));
    }

    /// Send a command to the machine worker.
    pub(crate) fn command(&self, c: Command) -> Result<(), String> {
        self.worker
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .send(c)
            .map_err(|_| "the machine worker has stopped".to_string())
    }

    /// The profiles on offer (configured, then an uploaded one).
    pub(crate) fn profiles(&self) -> Vec<MachineProfile> {
        let mut all = self.config.profiles.clone();
        all.extend(self.lock().uploaded_profile.clone());
        all
    }

    /// The interrupted plot of the loaded drawing on the chosen machine, when its journal says it did not finish.
    pub(crate) fn resumable(&self) -> Option<Resumable> {
        let dir = self.config.journals.as_ref()?;
        let (drawing, machine) = {
            let i = self.lock();
            (i.loaded.as_ref()?.name.clone(), i.profile.name.clone())
        };
        let path = super::web_journal::journal_path(dir, &drawing, &machine);
        let state = plotter_host::link::journal::load(&path).ok()?;
        // Block counts far below 2^53: exact in f64.
        #[allow(clippy::cast_precision_loss)]
        let percent = 100.0 * state.executed as f64 / state.blocks.max(1) as f64;
        (!state.complete).then_some(Resumable { path, executed: state.executed, blocks: state.blocks, percent })
    }

    /// The state every page sees.
    pub(crate) fn snapshot(&self) -> Snapshot {
        let profiles: Vec<String> = self.profiles().into_iter().map(|p| p.name).collect();
        let resumable = self.resumable();
        let i = self.lock();
        Snapshot {
            controlled: i.controller.is_some(),
            drawing: i.loaded.as_ref().map(|l| DrawingInfo {
                name: l.name.clone(),
                layers: l
                    .decoded
                    .drawing
                    .layers
                    .iter()
                    .map(|layer| (layer, plotting_pen(&i.profile, &layer.name, &layer.pen)))
                    .map(|(layer, pen)| LayerInfo {
                        name: layer.name.clone(),
                        color: pen.color.to_hex(),
                        width_mm: pen.width_mm,
                        paths: layer.paths.iter().filter(|p| p.points.len() >= 2).count(),
                    })
                    .collect(),
                warnings: l.decoded.warnings.clone(),
            }),
            settings: i.settings.clone(),
            prepared: i.prepared.as_ref().map(|p| PreparedInfo {
                stats: serde_json::to_value(&p.stats).unwrap_or_default(),
                estimate_s: p.estimate_s,
                estimate_for: estimate_for(&i.profile, p.estimate_sync),
                pen_up_before_mm: p.optimize.as_ref().map(|r| r.pen_up_before_mm),
                pen_up_after_mm: p.optimize.as_ref().map(|r| r.pen_up_after_mm),
                warnings: p.warnings.clone(),
            }),
            prepare_error: i.prepare_error.clone(),
            view_version: i.view_version,
            profile: i.profile.name.clone(),
            profiles,
            pen_speed: i.pen_speed,
            resumable,
            pen_speed_profile: PenSpeed::of(&i.profile),
            machine: i.machine.clone(),
            progress: i.progress,
            prompt: i.prompt.clone(),
            stepped_version: i.stepped.as_ref().map(|_| i.stepped_version),
            max_upload: self.config.max_upload,
        }
    }
}

/// The state a page is sent (`GET /api/state`, and the `state` event).
#[derive(Debug, Clone, Serialize)]
pub(crate) struct Snapshot {
    /// Whether some page controls the machine.
    pub(crate) controlled: bool,
    /// The loaded drawing.
    pub(crate) drawing: Option<DrawingInfo>,
    /// Current settings.
    pub(crate) settings: Settings,
    /// The prepared plot's figures.
    pub(crate) prepared: Option<PreparedInfo>,
    /// Why nothing is prepared.
    pub(crate) prepare_error: Option<String>,
    /// Refetch `GET /api/view` when this changes.
    pub(crate) view_version: u64,
    /// The chosen profile's name.
    pub(crate) profile: String,
    /// Profiles on offer.
    pub(crate) profiles: Vec<String>,
    /// The pen-height and speed sliders.
    pub(crate) pen_speed: PenSpeed,
    /// An interrupted plot of this drawing on this machine that can be resumed.
    pub(crate) resumable: Option<Resumable>,
    /// What the sliders stand at with nothing chosen: the profile's own values.
    pub(crate) pen_speed_profile: PenSpeed,
    /// The machine.
    pub(crate) machine: MachineState,
    /// The last plot's progress.
    pub(crate) progress: Option<ProgressEvent>,
    /// The question the job waits on.
    pub(crate) prompt: Option<Prompt>,
    /// `GET /api/stepped` has an as-stepped drawing of this version.
    pub(crate) stepped_version: Option<u64>,
    /// Upload limit, bytes.
    pub(crate) max_upload: usize,
}

/// An interrupted plot, as the page offers to resume it.
#[derive(Debug, Clone, Serialize)]
pub(crate) struct Resumable {
    /// Its journal (not sent: a page names no file).
    #[serde(skip)]
    pub(crate) path: std::path::PathBuf,
    /// Blocks certainly executed.
    pub(crate) executed: usize,
    /// Blocks in the plot.
    pub(crate) blocks: usize,
    /// How far it got, per cent.
    pub(crate) percent: f64,
}

/// The loaded drawing, for the layer list.
#[derive(Debug, Clone, Serialize)]
pub(crate) struct DrawingInfo {
    /// Shown name.
    pub(crate) name: String,
    /// Its layers as decoded.
    pub(crate) layers: Vec<LayerInfo>,
    /// Decoding warnings.
    pub(crate) warnings: Vec<String>,
}

/// One decoded layer.
#[derive(Debug, Clone, Serialize)]
pub(crate) struct LayerInfo {
    /// Name.
    pub(crate) name: String,
    /// The colour of the pen that plots it (the profile's pen table, else the layer's own).
    pub(crate) color: String,
    /// The width of the pen that plots it, mm (the pen table's, else the profile's `[pen]` width).
    pub(crate) width_mm: f64,
    /// Paths with something to draw.
    pub(crate) paths: usize,
}

/// Which firmware an estimate planned with `sync` is for, where it matters: a servo pen on `profile`.
fn estimate_for(profile: &MachineProfile, sync: ServoSync) -> Option<&'static str> {
    profile.pen.uses_servo().then_some(match sync {
        ServoSync::AtRest => "GRBL",
        ServoSync::InMotion => "our firmware or an EiBotBoard",
    })
}

/// Figures of the prepared plot.
#[derive(Debug, Clone, Serialize)]
pub(crate) struct PreparedInfo {
    /// `plotter stats` figures.
    pub(crate) stats: serde_json::Value,
    /// Planned time, seconds.
    pub(crate) estimate_s: Option<f64>,
    /// The firmware the planned time is for, where it matters (a servo pen: GRBL stops the carriage for the
    /// pen's drop, our firmware and the EBB drop it on the way); `None` for a Z pen.
    pub(crate) estimate_for: Option<&'static str>,
    /// Pen-up travel before ordering, mm.
    pub(crate) pen_up_before_mm: Option<f64>,
    /// Pen-up travel after ordering, mm.
    pub(crate) pen_up_after_mm: Option<f64>,
    /// Layer and work-area warnings.
    pub(crate) warnings: Vec<String>,
}
