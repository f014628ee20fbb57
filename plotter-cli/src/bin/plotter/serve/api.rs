//! The HTTP API and the page's assets. Every request passes [`guard`] (Host/Origin, and the controller's token
//! for anything that changes state); handlers answer JSON, errors as `{ "error": "..." }` with a status that says
//! what kind of problem it is.
//!
//! Bodies are bounded in size — a declared size over the limit is refused before any of the body is read
//! ([`declared_size`]) — and in time ([`super::deadline`]). Decoding and preparing a drawing run on the blocking
//! pool in a limited number of slots ([`super::heavy`]), so no number of uploads can occupy every thread, and each first
//! reserves its estimated memory in the server's budget ([`super::budget`]), so that concurrent uploads cannot
//! together exhaust the machine's memory.

use std::path::Path;
use std::sync::Arc;

use axum::Json;
use axum::Router;
use axum::body::Bytes;
use axum::extract::rejection::{BytesRejection, JsonRejection};
use axum::extract::{DefaultBodyLimit, Query, Request, State};
use axum::http::{HeaderMap, HeaderValue, Method, StatusCode, header};
use axum::middleware::{self, Next};
use axum::response::sse::{KeepAlive, Sse};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use futures_util::stream::{self, Stream};
use plotter_host::input::InputArgs;
use plotter_host::job::page::view;
use plotter_host::job::prepare::{LayerChoice, prepare};
use plotter_host::link::jog::JogTarget;
use plotter_host::link::machine::Firmware;
use plotter_host::options::layout::{LayoutArgs, OrientationArg};
use plotter_host::options::optimize::OptimizeArgs;
use plotter_host::options::trace::{ColorsArg, ModeArg};

use plotter_path::input::r#gen;
use plotter_path::output::preview::plotting_pen;
use plotter_path::{MachineProfile, Pen, Rgb};
use serde::Deserialize;
use serde_json::json;
use tokio::sync::broadcast::error::RecvError;

use super::budget;
use super::command::{Command, PlotJob, firmware_choice, hpgl_choice, hpgl_refusal, hpgl_table};
use super::control;
use super::deadline::body_deadline;
use super::error::ApiError;
use super::events::Event;
use super::heavy::heavy;
use super::pen_speed::PenSpeed;
use super::safety::{self, TOKEN_HEADER};
use super::state::{Loaded, Settings, Shared, Source};

/// The page.
const INDEX_HTML: &str = include_str!("../../../../assets/index.html");
/// Its script.
const APP_JS: &str = include_str!("../../../../assets/app.js");
/// Its style sheet.
const STYLE_CSS: &str = include_str!("../../../../assets/style.css");

fn bad(message: impl Into<String>) -> ApiError {
    ApiError(StatusCode::BAD_REQUEST, message.into())
}

fn conflict(message: impl Into<String>) -> ApiError {
    ApiError(StatusCode::CONFLICT, message.into())
}

type ApiResult = Result<Response, ApiError>;

fn ok() -> ApiResult {
    Ok(Json(json!({ "ok": true })).into_response())
}

/// Largest body of a request other than an upload (JSON settings and commands), bytes.
const JSON_LIMIT: usize = 64 * 1024;

/// The router for `shared`.
pub(crate) fn router(shared: Arc<Shared>) -> Router {
    // Bodies of uploads may be as large as the limit; other JSON bodies are small.
    let max_upload = shared.config.max_upload;
    let uploads = Router::new()
        .route("/api/drawing", post(upload))
        .route("/api/profile/upload", post(upload_profile))
        .layer(DefaultBodyLimit::max(max_upload))
        .layer(middleware::from_fn_with_state((max_upload, true), declared_size));
    Router::new()
        .route("/", get(|| async { ([(header::CONTENT_TYPE, "text/html; charset=utf-8")], INDEX_HTML) }))
        .route("/app.js", get(|| async { ([(header::CONTENT_TYPE, "text/javascript; charset=utf-8")], APP_JS) }))
        .route("/style.css", get(|| async { ([(header::CONTENT_TYPE, "text/css; charset=utf-8")], STYLE_CSS) }))
        .route("/api/state", get(state))
        .route("/api/events", get(events))
        .route("/api/view", get(drawing_view))
        .route("/api/stepped", get(stepped_view))
        .route("/api/ports", get(ports))
        .route("/api/hpgl", get(|| async { Json(hpgl_table()) }))
        .route("/api/control/claim", post(claim))
        .route("/api/control/release", post(release))
        .route("/api/gen", post(generate))
        .route("/api/settings", post(settings))
        .route("/api/profile", post(choose_profile))
        .route("/api/connect", post(connect))
        .route("/api/disconnect", post(disconnect))
        .route("/api/plot", post(plot))
        .route("/api/pause", post(pause))
        .route("/api/resume", post(resume))
        .route("/api/cancel", post(cancel))
        .route("/api/prompt", post(answer))
        .route("/api/home", post(home))
        .route("/api/jog", post(jog))
        .route("/api/pen", post(pen))
        .route("/api/console", post(console))
        .route("/api/pen-speed", post(pen_speed))
        .route("/api/resume-plot", post(resume_plot))
        .route("/api/test-pen", post(test_pen))
        .route("/api/motors-off", post(motors_off))
        .route("/api/export", get(super::export::download))
        .layer(DefaultBodyLimit::max(JSON_LIMIT))
        .layer(middleware::from_fn_with_state((JSON_LIMIT, false), declared_size))
        .merge(uploads)
        .layer(middleware::from_fn_with_state(Arc::clone(&shared), body_deadline))
        .layer(middleware::from_fn_with_state(Arc::clone(&shared), guard))
        .with_state(shared)
}

/// Refuse foreign Host/Origin, and changes from anyone but the controller.
async fn guard(State(shared): State<Arc<Shared>>, req: Request, next: Next) -> Response {
    if let Err(refusal) = safety::check_request(req.headers(), shared.config.local) {
        return ApiError(StatusCode::FORBIDDEN, refusal.to_string()).into_response();
    }
    let reads = matches!(*req.method(), Method::GET | Method::HEAD);
    if !reads && req.uri().path() != "/api/control/claim" {
        let token = req.headers().get(TOKEN_HEADER).and_then(|t| t.to_str().ok());
        let controller = shared.lock().controller.as_ref().map(|c| c.token.clone());
        if controller.is_none() || token != controller.as_deref() {
            let message = if controller.is_none() {
                "take control first (nobody controls the plotter)"
            } else {
                "another page controls the plotter; this one is read-only"
            };
            return ApiError(StatusCode::FORBIDDEN, message.into()).into_response();
        }
    }
    next.run(req).await
}

async fn state(State(shared): State<Arc<Shared>>) -> Response {
    Json(shared.snapshot()).into_response()
}

#[derive(Deserialize)]
struct EventsQuery {
    token: Option<String>,
}

/// Server-sent events: the state first, then everything the hub sends. With the controller's token the stream
/// holds control ([`control::attach`]).
async fn events(
    State(shared): State<Arc<Shared>>,
    Query(q): Query<EventsQuery>,
) -> Sse<impl Stream<Item = Result<axum::response::sse::Event, std::convert::Infallible>>> {
    let lease = q.token.and_then(|token| control::attach(&shared, &token));
    let rx = shared.hub.subscribe();
    let first = Event::new("state", &shared.snapshot());
    let s = stream::unfold((Some(first), rx, shared, lease), |(first, mut rx, shared, lease)| async move {
        let event = match first {
            Some(e) => e,
            None => match rx.recv().await {
                Ok(e) => e,
                Err(RecvError::Lagged(_)) => Event::new("state", &shared.snapshot()),
                Err(RecvError::Closed) => return None,
            },
        };
        let sse = axum::response::sse::Event::default().event(event.name).data(event.data);
        Some((Ok(sse), (None, rx, shared, lease)))
    });
    Sse::new(s).keep_alive(KeepAlive::default())
}

/// The prepared drawing for the page's preview, every layer drawn with the pen that plots it: the width and colour
/// the page's layer table chose, else the profile's pen table, else its `[pen]` width — never the file's stroke
/// width (see [`plotting_pen`]).
async fn drawing_view(State(shared): State<Arc<Shared>>) -> ApiResult {
    let (prepared, profile, chosen) = {
        let i = shared.lock();
        (i.prepared.clone(), i.profile.clone(), i.settings.layers.clone())
    };
    let p = prepared.ok_or_else(|| ApiError(StatusCode::NOT_FOUND, "no drawing loaded".into()))?;
    let mut v = view(&p.drawing);
    for (shown, layer) in v.layers.iter_mut().zip(&p.drawing.layers) {
        let pen = plotting_pen(&profile, &layer.name, &layer.pen);
        let choice = chosen.iter().find(|c| c.name == layer.name);
        shown.width_mm = choice.map(|c| c.width_mm).filter(|w| *w > 0.0).unwrap_or(pen.width_mm);
        // A colour chosen on the page is the layer's pen colour by now (see `layer_choices`).
        let color = if choice.is_some_and(|c| !c.color.is_empty()) { layer.pen.color } else { pen.color };
        shown.color = color.to_hex();
    }
    Ok(Json(v).into_response())
}

async fn stepped_view(State(shared): State<Arc<Shared>>) -> ApiResult {
    let stepped = shared.lock().stepped.clone();
    let s = stepped.ok_or_else(|| ApiError(StatusCode::NOT_FOUND, "no simulated plot yet".into()))?;
    Ok(Json(&*s).into_response())
}

/// The serial ports a page may connect to: those the system lists and those named on the command line.
pub(crate) fn port_names(shared: &Shared) -> Vec<String> {
    let mut names: Vec<String> =
        serialport::available_ports().unwrap_or_default().into_iter().map(|p| p.port_name).collect();
    for p in &shared.config.extra_ports {
        if !names.contains(p) {
            names.push(p.clone());
        }
    }
    names
}

async fn ports(State(shared): State<Arc<Shared>>) -> Response {
    let names = tokio::task::spawn_blocking(move || port_names(&shared)).await.unwrap_or_default();
    Json(json!({ "ports": names })).into_response()
}

async fn claim(State(shared): State<Arc<Shared>>, headers: HeaderMap) -> ApiResult {
    let held = headers.get(TOKEN_HEADER).and_then(|t| t.to_str().ok());
    let token = control::claim(&shared, held).map_err(|taken| conflict(taken.to_string()))?;
    Ok(Json(json!({ "token": token })).into_response())
}

async fn release(State(shared): State<Arc<Shared>>) -> ApiResult {
    control::release(&shared);
    ok()
}

#[derive(Deserialize)]
struct UploadQuery {
    name: String,
}

/// The answer to a body over `limit` bytes (`upload`: a drawing or profile; else a JSON request).
fn too_large(what: &str, size: Option<u64>, limit: usize, upload: bool) -> ApiError {
    let mb = |b: u64| {
        // Display only.
        #[allow(clippy::cast_precision_loss)]
        let v = b as f64 / 1_048_576.0;
        v
    };
    let size = size.map_or_else(String::new, |s| format!(" ({:.1} MB)", mb(s)));
    let limit = u64::try_from(limit).unwrap_or(u64::MAX);
    let message = if upload {
        format!(
            "{what} is too large{size}: uploads are limited to {:.1} MB (start the server with --max-upload-mb to \
             change it)",
            mb(limit)
        )
    } else {
        format!("{what} is too large{size}: requests other than uploads are limited to {} KB", limit / 1024)
    };
    ApiError(StatusCode::PAYLOAD_TOO_LARGE, message)
}

/// Middleware: refuse a request whose declared size (`Content-Length`) is over `limit` before reading any of its
/// body (and before telling a client that sent `Expect: 100-continue` to go on), closing the connection so the
/// body is never read. A body without a declared size is cut at the limit as it is read ([`upload_body`]).
/// The state is the limit, bytes, and whether it is an upload's.
async fn declared_size(State((limit, upload)): State<(usize, bool)>, req: Request, next: Next) -> Response {
    let declared = req.headers().get(header::CONTENT_LENGTH).and_then(|v| v.to_str().ok()?.parse::<u64>().ok());
    if declared.is_none_or(|n| n <= u64::try_from(limit).unwrap_or(u64::MAX)) {
        return next.run(req).await;
    }
    let what = Query::<UploadQuery>::try_from_uri(req.uri())
        .ok()
        .and_then(|q| clean_name(&q.0.name).ok())
        .unwrap_or_else(|| "the request body".into());
    let mut refused = too_large(&what, declared, limit, upload).into_response();
    refused.headers_mut().insert(header::CONNECTION, HeaderValue::from_static("close"));
    refused
}

/// The body of an upload, a body cut at the limit mapped to the same message as a declared oversize one.
fn upload_body(what: &str, body: Result<Bytes, BytesRejection>, limit: usize) -> Result<Bytes, ApiError> {
    match body {
        Ok(b) => Ok(b),
        Err(e) if e.status() == StatusCode::PAYLOAD_TOO_LARGE => Err(too_large(what, None, limit, true)),
        Err(e) => Err(bad(format!("cannot read {what}: {}", e.body_text()))),
    }
}

/// A file name from the client, used only to tell the kind and in messages: its last component, printable.
fn clean_name(name: &str) -> Result<String, ApiError> {
    let base = name.rsplit(['/', '\\']).next().unwrap_or("").trim();
    if base.is_empty() || base.len() > 200 || base.chars().any(char::is_control) {
        return Err(bad(format!("unusable file name {name:?}")));
    }
    Ok(base.to_string())
}

/// What the page offers when "machine's pens" meets a machine profile without a coloured pen.
const PENS_FROM_PAGE: &str = "choose a machine profile whose pens have colours under Machine (or upload one with \
                              Upload profile), or set Picture colours to cmyk";

fn input_args(settings: &Settings) -> Result<InputArgs, ApiError> {
    #[derive(clap::Parser)]
    struct W {
        #[command(flatten)]
        input: InputArgs,
    }
    let mut args = <W as clap::Parser>::try_parse_from(["serve"]).map_err(|e| bad(e.to_string()))?.input;
    args.trace.mode = match settings.trace.as_str() {
        "" => ModeArg::default(),
        name => <ModeArg as clap::ValueEnum>::from_str(name, false).map_err(|_| {
            let names: Vec<String> = <ModeArg as clap::ValueEnum>::value_variants()
                .iter()
                .filter_map(|m| clap::ValueEnum::to_possible_value(m).map(|v| v.get_name().to_owned()))
                .collect();
            bad(format!("unknown tracing mode {name:?} ({})", names.join(", ")))
        })?,
    };
    args.trace.colors = match settings.colors.as_str() {
        "" => ColorsArg::default(),
        name => <ColorsArg as clap::ValueEnum>::from_str(name, false)
            .map_err(|_| bad(format!("unknown colour separation {name:?} (gray, cmyk, pens)")))?,
    };
    let h = settings.hatch_mm;
    if !(h == 0.0 || (h.is_finite() && (MIN_HATCH_MM..=MAX_HATCH_MM).contains(&h))) {
        return Err(bad(format!(
            "hatch spacing {h} mm is not in {MIN_HATCH_MM}..{MAX_HATCH_MM} mm (0 turns hatching off)"
        )));
    }
    args.hatch = if settings.hatch_tone {
        Some(plotter_host::input::HatchArg::Tone)
    } else {
        (h > 0.0).then_some(plotter_host::input::HatchArg::Spacing(h))
    };
    args.cross_hatch = args.hatch.is_some() && settings.cross_hatch;
    args.no_occlusion = !settings.hidden_lines;
    args.pens_hint = PENS_FROM_PAGE;
    Ok(args)
}

/// Closest hatch spacing the page may ask for, mm (finer multiplies the lines beyond use and bounds the work).
const MIN_HATCH_MM: f64 = 0.1;
/// Widest hatch spacing, mm.
const MAX_HATCH_MM: f64 = 50.0;

/// Smallest side of a custom paper, mm.
const MIN_PAPER_MM: f64 = 10.0;
/// Largest side of a custom paper, mm (an A0 roll and more).
const MAX_PAPER_MM: f64 = 5000.0;

/// The paper the settings name, as the layout flag takes it: a named size, or a custom `W × H` converted from its
/// unit (mm, cm, in) to millimetres and checked against [`MIN_PAPER_MM`]..[`MAX_PAPER_MM`].
fn paper_arg(s: &Settings) -> Result<Option<String>, ApiError> {
    let paper = s.paper.trim();
    if paper != "custom" {
        return Ok(Some(paper.to_string()).filter(|p| !p.is_empty()));
    }
    let unit = s.paper_unit.trim();
    let mm_per_unit = match unit {
        "mm" => 1.0,
        "cm" => 10.0,
        "in" => 25.4,
        other => return Err(bad(format!("custom paper unit {other:?} is not mm, cm or in"))),
    };
    for (side, v) in [("width", s.paper_width), ("height", s.paper_height)] {
        let mm = v * mm_per_unit;
        if !(mm.is_finite() && (MIN_PAPER_MM..=MAX_PAPER_MM).contains(&mm)) {
            return Err(bad(format!("custom paper {side} {v} {unit} is not in {MIN_PAPER_MM}..{MAX_PAPER_MM} mm")));
        }
    }
    let (w, h) = (s.paper_width * mm_per_unit, s.paper_height * mm_per_unit);
    Ok(Some(format!("{}x{}", (w * 1000.0).round() / 1000.0, (h * 1000.0).round() / 1000.0)))
}

fn layout_args(s: &Settings) -> Result<LayoutArgs, ApiError> {
    Ok(LayoutArgs {
        paper: paper_arg(s)?,
        orientation: match s.orientation.as_str() {
            "" => None,
            "portrait" => Some(OrientationArg::Portrait),
            "landscape" => Some(OrientationArg::Landscape),
            other => return Err(bad(format!("unknown orientation {other:?} (portrait, landscape)"))),
        },
        margin: s.margin,
        fit: s.fit,
        center: s.center,
        rotate: f64::from(s.rotate) * 90.0,
        ..LayoutArgs::default()
    })
}

fn optimize_args(s: &Settings) -> Result<OptimizeArgs, ApiError> {
    #[derive(clap::Parser)]
    struct W {
        #[command(flatten)]
        o: OptimizeArgs,
    }
    let mut args = <W as clap::Parser>::try_parse_from(["serve"]).map_err(|e| bad(e.to_string()))?.o;
    args.no_optimize = !s.optimize;
    Ok(args)
}

fn parse_color(c: &str) -> Result<Option<Rgb>, ApiError> {
    if c.is_empty() {
        return Ok(None);
    }
    let hex = c.strip_prefix('#').filter(|h| h.len() == 6 && h.chars().all(|ch| ch.is_ascii_hexdigit()));
    let hex = hex.ok_or_else(|| bad(format!("pen colour {c:?} is not #rrggbb")))?;
    let byte = |i: usize| u8::from_str_radix(&hex[i..i + 2], 16).unwrap_or(0);
    Ok(Some(Rgb(byte(0), byte(2), byte(4))))
}

fn layer_choices(s: &Settings, decoded: &plotter_path::Drawing) -> Result<Vec<LayerChoice>, ApiError> {
    s.layers
        .iter()
        .map(|l| {
            let own = decoded.layers.iter().find(|d| d.name == l.name).map(|d| d.pen).unwrap_or_default();
            let color = parse_color(&l.color)?;
            if !(l.width_mm.is_finite() && l.width_mm >= 0.0 && l.width_mm <= 20.0) {
                return Err(bad(format!("pen width {} mm of layer '{}' is not in 0..20", l.width_mm, l.name)));
            }
            let pen = (color.is_some() || l.width_mm > 0.0).then(|| Pen {
                color: color.unwrap_or(own.color),
                width_mm: if l.width_mm > 0.0 { l.width_mm } else { own.width_mm },
            });
            Ok(LayerChoice { name: l.name.clone(), visible: l.visible, pen })
        })
        .collect()
}

/// Decode `source` with `settings`, off the async threads.
async fn decode(
    shared: &Shared,
    source: Source,
    settings: &Settings,
    profile: MachineProfile,
) -> Result<Loaded, ApiError> {
    let mut input = input_args(settings)?;
    let layout = layout_args(settings)?;
    let memory = match &source {
        Source::Upload { name, bytes } => (budget::decode_estimate(name, bytes), name.clone()),
        Source::Gen(spec) => (budget::decode_estimate("gen.svg", b""), format!("gen:{spec}")),
    };
    heavy(shared, (memory.0, &memory.1), move |cancel| {
        let (name, decoded) = match &source {
            Source::Upload { name, bytes } => {
                // An upload may use only data: URLs inside it: no path on this machine is opened or looked up.
                let only_data = plotter_path::input::svg::ResourcePolicy::DataUrlsOnly;
                // Hatch sizes, pen widths and how wide a stroke is are page sizes: measured at the layout's factor
                // (as `plotter plot` does).
                let path = Path::new(name);
                let decoded = plotter_host::input::decode_for_layout(
                    bytes, path, name, &only_data, &input, &profile, &layout, cancel,
                );
                let (decoded, factor) = decoded.map_err(|e| bad(format!("{e:#}")))?;
                input.hatch_scale = factor;
                (name.clone(), decoded)
            }
            Source::Gen(spec) => {
                let drawing = r#gen::from_spec(spec).map_err(|e| bad(format!("cannot generate {spec}: {e}")))?;
                let decoded = plotter_host::input::Decoded::plain(drawing, Vec::new());
                (format!("gen:{spec}"), decoded)
            }
        };
        Ok(Loaded { source, name, decoded, input })
    })
    .await?
}

/// Re-prepare the loaded drawing with the current settings and profile; publish.
async fn reprepare(shared: &Arc<Shared>) -> ApiResult {
    let (drawing, settings, profile) = {
        let i = shared.lock();
        let Some(l) = &i.loaded else { return ok() };
        (l.decoded.drawing.clone(), i.settings.clone(), i.machine_profile())
    };
    let layers = layer_choices(&settings, &drawing)?;
    let layout = layout_args(&settings)?;
    let optimize = optimize_args(&settings)?;
    let memory = (budget::prepare_estimate(&drawing), "preparing the drawing");
    let result =
        heavy(shared, memory, move |cancel| prepare(drawing, &profile, &layers, &layout, &optimize, cancel)).await;
    let answer = {
        let mut i = shared.lock();
        i.view_version += 1;
        match result {
            // Busy: the drawing or settings have changed but could not be prepared, so the old plot must go.
            Err(busy) => {
                i.prepared = None;
                i.prepare_error = Some(busy.1.clone());
                Err(busy)
            }
            Ok(Ok(p)) => {
                let warnings = p.warnings.clone();
                i.prepared = Some(Arc::new(p));
                i.prepare_error = None;
                Ok(Json(json!({ "ok": true, "warnings": warnings })).into_response())
            }
            Ok(Err(e)) => {
                let message = format!("{e:#}");
                i.prepared = None;
                i.prepare_error = Some(message.clone());
                Err(bad(message))
            }
        }
    };
    shared.publish();
    answer
}

fn refuse_while_plotting(shared: &Shared) -> Result<(), ApiError> {
    match shared.lock().machine.activity {
        "plotting" | "paused" => Err(conflict("a plot is running: cancel it first")),
        _ => Ok(()),
    }
}

async fn load(shared: &Arc<Shared>, source: Source) -> ApiResult {
    refuse_while_plotting(shared)?;
    let (mut settings, profile) = {
        let i = shared.lock();
        (i.settings.clone(), i.machine_profile())
    };
    let loaded = decode(shared, source, &settings, profile).await?;
    let warnings = loaded.decoded.warnings.clone();
    // A new drawing starts with its own layers and pens.
    settings.layers.clear();
    {
        let mut i = shared.lock();
        i.loaded = Some(loaded);
        i.settings = settings;
    }
    for w in &warnings {
        shared.hub.log("info", format!("warning: {w}"));
    }
    reprepare(shared).await
}

async fn upload(
    State(shared): State<Arc<Shared>>,
    Query(q): Query<UploadQuery>,
    body: Result<Bytes, BytesRejection>,
) -> ApiResult {
    let name = clean_name(&q.name)?;
    let bytes = upload_body(&name, body, shared.config.max_upload)?;
    if bytes.is_empty() {
        return Err(bad(format!("{name} is empty")));
    }
    load(&shared, Source::Upload { name, bytes: Arc::new(bytes.to_vec()) }).await
}

#[derive(Deserialize)]
struct GenBody {
    spec: String,
}

async fn generate(State(shared): State<Arc<Shared>>, Json(b): Json<GenBody>) -> ApiResult {
    let spec = b.spec.trim();
    let spec = spec.strip_prefix(plotter_host::input::GEN_PREFIX).unwrap_or(spec);
    load(&shared, Source::Gen(spec.to_string())).await
}

async fn settings(State(shared): State<Arc<Shared>>, Json(s): Json<Settings>) -> ApiResult {
    refuse_while_plotting(&shared)?;
    // Check before storing, so a bad value never sticks.
    input_args(&s)?;
    layout_args(&s)?.options().map_err(|e| bad(format!("{e:#}")))?;
    let wanted = input_args(&s)?;
    let retrace = {
        let mut i = shared.lock();
        // Tracing, hatching and hidden lines are decided when the drawing is read: read it again when they change,
        // and when the layout changes under hatching (its spacings are page sizes, divided by the layout's factor).
        let decoded_as = |a: &InputArgs| (a.trace.mode, a.trace.colors, a.hatch, a.cross_hatch, a.no_occlusion);
        let laid_out = |s: &Settings| layout_args(s).ok().and_then(|l| l.options().ok());
        let hatched = wanted.hatch.is_some() || i.machine_profile().pens.iter().any(|p| p.hatch.is_some());
        let retrace = i.loaded.as_ref().is_some_and(|l| {
            // Strokes hide what lies under them by their width on the page too, pattern tiles are drawn by theirs,
            // and an SVG's curves are flattened for the page (an enlarged circle flattened again, finer).
            let page_sized = hatched || !l.decoded.scales.is_everything();
            decoded_as(&l.input) != decoded_as(&wanted) || (page_sized && laid_out(&i.settings) != laid_out(&s))
        });
        let before = std::mem::replace(&mut i.settings, s.clone());
        retrace.then(|| i.loaded.as_ref().map(|l| (l.source.clone(), i.machine_profile(), before))).flatten()
    };
    if let Some((source, profile, before)) = retrace {
        // A drawing the new settings cannot read (say `pens` with no coloured pen) keeps the settings it was read with.
        let loaded = match decode(&shared, source, &s, profile).await {
            Ok(loaded) => loaded,
            Err(e) => {
                shared.lock().settings = before;
                return Err(e);
            }
        };
        shared.lock().loaded = Some(loaded);
    }
    reprepare(&shared).await
}

#[derive(Deserialize)]
struct ProfileBody {
    name: String,
}

async fn choose_profile(State(shared): State<Arc<Shared>>, Json(b): Json<ProfileBody>) -> ApiResult {
    refuse_while_plotting(&shared)?;
    let profile = shared
        .profiles()
        .into_iter()
        .find(|p| p.name == b.name)
        .ok_or_else(|| bad(format!("no machine profile named {:?}", b.name)))?;
    let before = {
        let mut i = shared.lock();
        let before = i.machine_profile();
        i.profile = profile;
        before
    };
    reread_for_pens(&shared, &before).await?;
    reprepare(&shared).await
}

/// Reads the loaded drawing again after the machine profile changed from `before`, when what was read depends on
/// the profile's pens: `--colors pens` separates a picture into them, and a pen with a hatch shades fills as the
/// drawing is read. A drawing read otherwise is kept as it is.
async fn reread_for_pens(shared: &Shared, before: &MachineProfile) -> Result<(), ApiError> {
    let again = {
        let i = shared.lock();
        let now = i.machine_profile();
        let hatching = |p: &MachineProfile| p.pens.iter().any(|pen| pen.hatch.is_some());
        let pens_matter = i.settings.colors == "pens" || hatching(before) || hatching(&now);
        // An opaque stroke hides what lies under it when it is four pen widths wide on the page.
        let width_matters = |l: &&Loaded| !l.decoded.scales.is_everything() && before.pen.width_mm != now.pen.width_mm;
        let loaded = i.loaded.as_ref().filter(|l| (pens_matter && before.pens != now.pens) || width_matters(l));
        loaded.map(|l| (l.source.clone(), i.settings.clone(), now))
    };
    if let Some((source, settings, profile)) = again {
        let loaded = decode(shared, source, &settings, profile).await?;
        shared.lock().loaded = Some(loaded);
    }
    Ok(())
}

async fn upload_profile(
    State(shared): State<Arc<Shared>>,
    Query(q): Query<UploadQuery>,
    body: Result<Bytes, BytesRejection>,
) -> ApiResult {
    refuse_while_plotting(&shared)?;
    let name = clean_name(&q.name)?;
    let bytes = upload_body(&name, body, shared.config.max_upload)?;
    let text = std::str::from_utf8(&bytes).map_err(|_| bad(format!("{name}: a machine profile is UTF-8 TOML text")))?;
    let profile = MachineProfile::from_toml(text, &name).map_err(|e| bad(e.to_string()))?;
    plotter_path::motion::plan::machine_config(&profile).map_err(|e| bad(format!("{name}: {e}")))?;
    let before = {
        let mut i = shared.lock();
        let before = i.machine_profile();
        i.uploaded_profile = Some(profile.clone());
        i.profile = profile;
        before
    };
    reread_for_pens(&shared, &before).await?;
    reprepare(&shared).await
}

#[derive(Deserialize)]
struct ConnectBody {
    /// `sim`, or one of the listed serial ports.
    target: String,
    /// The port's firmware: `auto` (default), `ours`, `grbl`, `ebb` or `hpgl` ([`firmware_choice`]).
    #[serde(default)]
    firmware: Option<String>,
    /// HP-GL: the plotter model (default `7475a`) ([`hpgl_choice`]).
    #[serde(default)]
    hpgl_device: Option<String>,
    /// HP-GL: the sheet loaded (default: the first that holds the drawing).
    #[serde(default)]
    hpgl_paper: Option<String>,
    /// HP-GL: `escb` (default), `xonxoff` or `hardware`.
    #[serde(default)]
    handshake: Option<String>,
    /// HP-GL: the line's baud rate (default 9600).
    #[serde(default)]
    baud: Option<u32>,
}

async fn connect(State(shared): State<Arc<Shared>>, body: Result<Json<ConnectBody>, JsonRejection>) -> ApiResult {
    // A body of the wrong shape (say a number for `hpgl_device`) is a bad request, said in the page's JSON.
    let Json(b) = body.map_err(|e| bad(format!("connect: {}", e.body_text())))?;
    refuse_while_plotting(&shared)?;
    let firmware = firmware_choice(b.target == "sim", b.firmware.as_deref()).map_err(bad)?;
    let hpgl = if firmware == Firmware::Hpgl {
        Some(
            hpgl_choice(b.hpgl_device.as_deref(), b.hpgl_paper.as_deref(), b.handshake.as_deref(), b.baud)
                .map_err(bad)?,
        )
    } else {
        None
    };
    let port = if b.target == "sim" {
        None
    } else {
        // Only a port the server itself lists: never a path of the client's choosing.
        let s = Arc::clone(&shared);
        let names = tokio::task::spawn_blocking(move || port_names(&s)).await.unwrap_or_default();
        if !names.contains(&b.target) {
            return Err(bad(format!("{:?} is not a listed serial port (see GET /api/ports)", b.target)));
        }
        Some(b.target)
    };
    let profile = Box::new(shared.lock().machine_profile());
    shared.command(Command::Connect(port, firmware, profile, hpgl)).map_err(conflict)?;
    ok()
}

async fn disconnect(State(shared): State<Arc<Shared>>) -> ApiResult {
    refuse_while_plotting(&shared)?;
    shared.command(Command::Disconnect).map_err(conflict)?;
    ok()
}

/// Machine commands need a connection and no running plot.
fn ready(shared: &Shared) -> Result<(), ApiError> {
    refuse_while_plotting(shared)?;
    if shared.lock().machine.connected.is_none() {
        return Err(conflict("not connected: connect to the simulator or a serial port first"));
    }
    Ok(())
}

async fn plot(State(shared): State<Arc<Shared>>) -> ApiResult {
    ready(&shared)?;
    let prepared = {
        let i = shared.lock();
        i.prepared
            .clone()
            .ok_or_else(|| conflict(i.prepare_error.clone().unwrap_or_else(|| "load a drawing first".into())))?
    };
    if prepared.estimate_s.is_none() {
        return Err(conflict(prepared.warnings.join("; ")));
    }
    // Mark it at once, so a second press is refused before the worker picks it up.
    let job = plot_job(&shared, prepared);
    shared.command(Command::Plot(job)).map_err(conflict)?;
    ok()
}

#[derive(Deserialize, Default)]
#[serde(default)]
struct PauseBody {
    /// Feed hold at once (else at the next pen-up).
    now: bool,
}

async fn pause(State(shared): State<Arc<Shared>>, body: Option<Json<PauseBody>>) -> ApiResult {
    if shared.lock().machine.activity != "plotting" {
        return Err(conflict("no plot is running"));
    }
    let now = body.map(|b| b.0.now).unwrap_or_default();
    shared.control.update(|s| s.pause = Some(now));
    ok()
}

/// Answer the pending prompt of `kind` with `answer`.
fn answer_prompt(shared: &Shared, id: Option<u64>, answer: &str) -> ApiResult {
    let prompt = shared.lock().prompt.clone().ok_or_else(|| conflict("nothing is waiting for an answer"))?;
    if id.is_some_and(|i| i != prompt.id) {
        return Err(conflict(format!("prompt {} is no longer open", id.unwrap_or_default())));
    }
    if !prompt.choices.contains(&answer) {
        return Err(bad(format!("{answer:?} is not an answer to this prompt ({})", prompt.choices.join(", "))));
    }
    shared.control.update(|s| s.answer = Some((prompt.id, answer.to_string())));
    ok()
}

async fn resume(State(shared): State<Arc<Shared>>) -> ApiResult {
    answer_prompt(&shared, None, "resume")
}

async fn cancel(State(shared): State<Arc<Shared>>) -> ApiResult {
    if !matches!(shared.lock().machine.activity, "plotting" | "paused") {
        return Err(conflict("no plot is running"));
    }
    shared.control.update(|s| s.cancel = true);
    ok()
}

#[derive(Deserialize)]
struct AnswerBody {
    id: u64,
    answer: String,
}

async fn answer(State(shared): State<Arc<Shared>>, Json(b): Json<AnswerBody>) -> ApiResult {
    answer_prompt(&shared, Some(b.id), &b.answer)
}

/// Home and jog move the machine by steps: an HP-GL plotter has neither (see [`hpgl_refusal`]).
fn refuse_on_hpgl(shared: &Shared, what: &str) -> Result<(), ApiError> {
    if shared.lock().machine.hpgl { Err(conflict(hpgl_refusal(what))) } else { Ok(()) }
}

async fn home(State(shared): State<Arc<Shared>>) -> ApiResult {
    ready(&shared)?;
    refuse_on_hpgl(&shared, "home")?;
    shared.command(Command::Home).map_err(conflict)?;
    ok()
}

#[derive(Deserialize)]
struct JogBody {
    axis: String,
    mm: f64,
}

async fn jog(State(shared): State<Arc<Shared>>, Json(b): Json<JogBody>) -> ApiResult {
    ready(&shared)?;
    refuse_on_hpgl(&shared, "jog")?;
    let target = match b.axis.as_str() {
        "x" => JogTarget::X,
        "y" => JogTarget::Y,
        "z" => JogTarget::Z,
        other => return Err(bad(format!("unknown axis {other:?} (x, y, z)"))),
    };
    if !(b.mm.is_finite() && b.mm.abs() <= 1000.0) {
        return Err(bad(format!("jog distance {} mm is not in -1000..1000", b.mm)));
    }
    shared.command(Command::Jog(target, Some(b.mm))).map_err(conflict)?;
    ok()
}

#[derive(Deserialize)]
struct PenBody {
    down: bool,
}

async fn pen(State(shared): State<Arc<Shared>>, Json(b): Json<PenBody>) -> ApiResult {
    ready(&shared)?;
    shared.command(Command::Jog(if b.down { JogTarget::Down } else { JogTarget::Up }, None)).map_err(conflict)?;
    ok()
}

#[derive(Deserialize)]
struct ConsoleBody {
    line: String,
}

async fn console(State(shared): State<Arc<Shared>>, Json(b): Json<ConsoleBody>) -> ApiResult {
    ready(&shared)?;
    let line = b.line.trim();
    if line.is_empty() || line.len() > 256 || line.chars().any(char::is_control) {
        return Err(bad("a console line is 1-256 printable characters"));
    }
    shared.command(Command::Console(line.to_string())).map_err(conflict)?;
    ok()
}

/// The pen-height and speed sliders: checked, stored for the next plot (and the pen test), and the drawing planned
/// again (its time estimate depends on the speeds).
async fn pen_speed(State(shared): State<Arc<Shared>>, body: Result<Json<PenSpeed>, JsonRejection>) -> ApiResult {
    let Json(b) = body.map_err(|e| bad(format!("pen and speed settings: {}", e.body_text())))?;
    refuse_while_plotting(&shared)?;
    b.check().map_err(bad)?;
    let applied = b.apply(&shared.lock().profile).map_err(bad)?;
    plotter_path::motion::plan::machine_config(&applied).map_err(|e| bad(format!("with these settings: {e}")))?;
    shared.lock().pen_speed = b;
    reprepare(&shared).await
}

/// Lower the pen, wait, raise it, with the sliders' pen positions.
async fn test_pen(State(shared): State<Arc<Shared>>) -> ApiResult {
    ready(&shared)?;
    let profile = Box::new(shared.lock().machine_profile());
    shared.command(Command::TestPen(profile)).map_err(conflict)?;
    ok()
}

/// Switch the motors off so the carriage can be pushed by hand (never during a plot).
async fn motors_off(State(shared): State<Arc<Shared>>) -> ApiResult {
    ready(&shared)?;
    if shared.lock().machine.hpgl {
        return Err(conflict(
            "an HP-GL plotter has no command that turns its motors off; switch it off and on instead",
        ));
    }
    shared.command(Command::MotorsOff).map_err(conflict)?;
    ok()
}

/// The plot of `prepared` with the current profile and sliders; the machine is marked as plotting at once, so a
/// second press is refused before the worker picks it up.
fn plot_job(shared: &Shared, prepared: Arc<plotter_host::job::prepare::Prepared>) -> PlotJob {
    let mut i = shared.lock();
    i.machine.activity = "plotting";
    let drawing = i.loaded.as_ref().map_or_else(String::new, |l| l.name.clone());
    PlotJob { prepared, profile: Box::new(i.machine_profile()), drawing }
}

/// Continue the interrupted plot of the loaded drawing on the chosen machine (its journal in the state directory),
/// on the connected serial port.
async fn resume_plot(State(shared): State<Arc<Shared>>) -> ApiResult {
    ready(&shared)?;
    if !shared.lock().machine.journaled {
        return Err(conflict(
            "only a plot on a serial port (our firmware, GRBL or an EiBotBoard) keeps a journal to resume from; \
             connect to the plotter it ran on",
        ));
    }
    let Some(interrupted) = shared.resumable() else {
        let i = shared.lock();
        let drawing = i.loaded.as_ref().map_or("no drawing loaded", |l| l.name.as_str()).to_string();
        return Err(conflict(format!("no interrupted plot of {drawing} on the {} to resume", i.profile.name)));
    };
    let prepared = {
        let i = shared.lock();
        i.prepared
            .clone()
            .ok_or_else(|| conflict(i.prepare_error.clone().unwrap_or_else(|| "load a drawing first".into())))?
    };
    let job = plot_job(&shared, prepared);
    shared.command(Command::ResumePlot(job, interrupted.path)).map_err(conflict)?;
    ok()
}
