//! The studio's HTTP API and page (`plotter serve --machine …`): the machines side by side and the job queue.
//!
//! - `GET /api/studio`: every machine (state, job, progress, time remaining, pen position) and the queue;
//! - `GET /api/events`: the same as server-sent `studio` events, one on connect and one after each change;
//! - `GET /api/queue`, `GET /api/queue/{id}`: the jobs with their history;
//! - `POST /api/queue?name=FILE[&machine=NAME][&args=JSON list of plot flags]` with the drawing's bytes as the
//!   body: queue a job (the queue's size limits apply); answers `{ "id": N }`;
//! - `POST /api/queue/{id}/cancel|retry|confirm`, `POST /api/queue/{id}/move` with `{ "before": N }` or
//!   `{ "after": N }`;
//! - `POST /api/machines/{name}/pause|resume|stop|estop`, `POST /api/stop-all`.
//!
//! Every request passes the Host/Origin checks of [`super::safety`], so no other site's page can drive the
//! machines. The queue's work (SQLite, with a disk sync per change) runs off the async threads.

use std::sync::Arc;
use std::time::Duration;

use axum::Json;
use axum::Router;
use axum::body::Bytes;
use axum::extract::{DefaultBodyLimit, Path, Query, Request, State};
use axum::http::{StatusCode, header};
use axum::middleware::{self, Next};
use axum::response::sse::{KeepAlive, Sse};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use futures_util::stream::{self, Stream};
use plotter_host::studio::error::StudioError;
use plotter_host::studio::queue::{MAX_DRAWING_BYTES, NewJob, Place};
use plotter_host::studio::running::Studio;
use serde::Deserialize;
use serde_json::json;

use super::error::ApiError;
use super::safety;

/// The studio's page.
const STUDIO_HTML: &str = include_str!("../../../../assets/studio.html");
/// Its script.
const STUDIO_JS: &str = include_str!("../../../../assets/studio.js");
/// The style sheet the single-machine page uses too.
const STYLE_CSS: &str = include_str!("../../../../assets/style.css");

/// How often an event stream looks for a change.
const EVENT_TICK: Duration = Duration::from_millis(100);

/// What the studio's handlers share.
#[derive(Clone)]
pub(crate) struct StudioState {
    /// The running studio.
    pub(crate) studio: Arc<Studio>,
    /// The address the server listens on (Host checks).
    pub(crate) local: std::net::SocketAddr,
}

type ApiResult = Result<Response, ApiError>;

/// The answer for a studio error: a missing job or machine is 404, a job or machine in the wrong state 409,
/// anything the caller sent wrong 400, the database 500.
fn studio_error(e: StudioError) -> ApiError {
    let status = match &e {
        StudioError::NoJob(_) | StudioError::NoMachine(_) => StatusCode::NOT_FOUND,
        StudioError::WrongState { .. } | StudioError::Busy { .. } => StatusCode::CONFLICT,
        StudioError::TooLarge { .. } => StatusCode::PAYLOAD_TOO_LARGE,
        StudioError::QueueFull(_) => StatusCode::SERVICE_UNAVAILABLE,
        StudioError::Invalid(_) => StatusCode::BAD_REQUEST,
        _ => StatusCode::INTERNAL_SERVER_ERROR,
    };
    ApiError::new(status, e.to_string())
}

/// Run `work` on the studio off the async threads.
async fn on_studio<T: Send + 'static>(
    s: &StudioState,
    work: impl FnOnce(&Studio) -> Result<T, StudioError> + Send + 'static,
) -> Result<T, ApiError> {
    let studio = Arc::clone(&s.studio);
    tokio::task::spawn_blocking(move || work(&studio))
        .await
        .map_err(|e| ApiError::new(StatusCode::INTERNAL_SERVER_ERROR, format!("the studio's task failed: {e}")))?
        .map_err(studio_error)
}

fn ok() -> ApiResult {
    Ok(Json(json!({ "ok": true })).into_response())
}

/// The studio's router.
pub(crate) fn router(state: StudioState) -> Router {
    let uploads =
        Router::new().route("/api/queue", post(add).get(list)).layer(DefaultBodyLimit::max(MAX_DRAWING_BYTES + 1024));
    Router::new()
        .route("/", get(|| async { ([(header::CONTENT_TYPE, "text/html; charset=utf-8")], STUDIO_HTML) }))
        .route("/studio.js", get(|| async { ([(header::CONTENT_TYPE, "text/javascript; charset=utf-8")], STUDIO_JS) }))
        .route("/style.css", get(|| async { ([(header::CONTENT_TYPE, "text/css; charset=utf-8")], STYLE_CSS) }))
        .route("/api/studio", get(snapshot))
        .route("/api/events", get(events))
        .route("/api/queue/{id}", get(one))
        .route("/api/queue/{id}/{action}", post(job_action))
        .route("/api/machines/{name}/{action}", post(machine_action))
        .route("/api/stop-all", post(stop_all))
        .layer(DefaultBodyLimit::max(64 * 1024))
        .merge(uploads)
        .layer(middleware::from_fn_with_state(state.clone(), guard))
        .with_state(state)
}

/// Refuse requests whose Host or Origin is not this server (another site's page, DNS rebinding).
async fn guard(State(s): State<StudioState>, req: Request, next: Next) -> Response {
    if let Err(refusal) = safety::check_request(req.headers(), s.local) {
        return ApiError::new(StatusCode::FORBIDDEN, refusal.to_string()).into_response();
    }
    next.run(req).await
}

async fn snapshot(State(s): State<StudioState>) -> ApiResult {
    Ok(Json(on_studio(&s, Studio::snapshot).await?).into_response())
}

async fn list(State(s): State<StudioState>) -> ApiResult {
    Ok(Json(on_studio(&s, Studio::jobs).await?).into_response())
}

async fn one(State(s): State<StudioState>, Path(id): Path<i64>) -> ApiResult {
    Ok(Json(on_studio(&s, move |st| st.job(id)).await?).into_response())
}

#[derive(Deserialize)]
struct AddQuery {
    name: String,
    machine: Option<String>,
    args: Option<String>,
}

async fn add(State(s): State<StudioState>, Query(q): Query<AddQuery>, body: Bytes) -> ApiResult {
    let args: Vec<String> = match q.args.as_deref() {
        None | Some("") => Vec::new(),
        Some(text) => serde_json::from_str(text).map_err(|e| {
            ApiError::new(StatusCode::BAD_REQUEST, format!("args must be a JSON list of flag words: {e}"))
        })?,
    };
    let mut job = NewJob::new(&q.name, body.to_vec()).with_options(json!({ "args": args }));
    job.machine = q.machine.filter(|m| !m.is_empty());
    let id = on_studio(&s, move |st| st.add(&job)).await?;
    Ok((StatusCode::CREATED, Json(json!({ "id": id }))).into_response())
}

#[derive(Deserialize, Default)]
struct MoveBody {
    before: Option<i64>,
    after: Option<i64>,
}

async fn job_action(State(s): State<StudioState>, Path((id, action)): Path<(i64, String)>, body: Bytes) -> ApiResult {
    match action.as_str() {
        "cancel" => {
            let done = on_studio(&s, move |st| st.cancel(id)).await?;
            let said = match done {
                plotter_host::studio::queue::Cancelled::Now => "cancelled",
                plotter_host::studio::queue::Cancelled::StopRequested => "stopping",
            };
            Ok(Json(json!({ "ok": true, "job": id, "state": said })).into_response())
        }
        "retry" => on_studio(&s, move |st| st.retry(id)).await.and_then(|()| ok()),
        "confirm" => on_studio(&s, move |st| st.confirm_resume(id)).await.and_then(|()| ok()),
        "move" => {
            let m: MoveBody = if body.is_empty() {
                MoveBody::default()
            } else {
                serde_json::from_slice(&body)
                    .map_err(|e| ApiError::new(StatusCode::BAD_REQUEST, format!("move: {e}")))?
            };
            let place = match (m.before, m.after) {
                (Some(b), None) => Place::Before(b),
                (None, Some(a)) => Place::After(a),
                _ => {
                    return Err(ApiError::new(
                        StatusCode::BAD_REQUEST,
                        "move: send {\"before\": JOB} or {\"after\": JOB}",
                    ));
                }
            };
            on_studio(&s, move |st| st.move_job(id, place)).await.and_then(|()| ok())
        }
        other => Err(ApiError::new(
            StatusCode::NOT_FOUND,
            format!("no job action \"{other}\" (cancel, retry, confirm or move)"),
        )),
    }
}

async fn machine_action(State(s): State<StudioState>, Path((name, action)): Path<(String, String)>) -> ApiResult {
    let st = &s.studio;
    let done = match action.as_str() {
        "pause" => st.pause(&name),
        "resume" => st.resume(&name),
        "stop" => st.stop(&name),
        "estop" => st.estop(&name),
        other => {
            return Err(ApiError::new(
                StatusCode::NOT_FOUND,
                format!("no machine action \"{other}\" (pause, resume, stop or estop)"),
            ));
        }
    };
    done.map_err(studio_error)?;
    ok()
}

async fn stop_all(State(s): State<StudioState>) -> ApiResult {
    s.studio.stop_all();
    ok()
}

/// Server-sent `studio` events: the whole studio on connect and after every change (looked for every
/// [`EVENT_TICK`]), so a page that falls behind simply gets the latest.
async fn events(
    State(s): State<StudioState>,
) -> Sse<impl Stream<Item = Result<axum::response::sse::Event, std::convert::Infallible>>> {
    let stream = stream::unfold((s, 0u64), |(s, seen)| async move {
        loop {
            let now = s.studio.version();
            if now != seen {
                // One snapshot per change, shared by every watching page.
                let snap = on_studio(&s, Studio::snapshot_json).await;
                let data = match snap {
                    Ok(text) => text.to_string(),
                    Err(ApiError(_, message)) => json!({ "error": message }).to_string(),
                };
                let event = axum::response::sse::Event::default().event("studio").data(data);
                return Some((Ok(event), (s, now)));
            }
            tokio::time::sleep(EVENT_TICK).await;
        }
    });
    Sse::new(stream).keep_alive(KeepAlive::default())
}
