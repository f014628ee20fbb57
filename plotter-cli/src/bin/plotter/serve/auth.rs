//! Signing in: who may watch and who may drive, when the server is reachable from other machines.
//!
//! # Tokens and roles
//! The server knows one operator token and, optionally, one viewer token (read from files or generated at start;
//! see `plotter serve --token-file`). An operator queues drawings and controls the machines; a viewer watches (the
//! pages, the event stream, the queue) and, like anyone signed in, may press a machine's emergency stop or "stop
//! all": stopping a plotter is never the thing to keep from someone standing in front of it.
//!
//! # How a request is signed in
//! - A script (`plotter queue --token …`) sends the token on every request: `Authorization: Bearer TOKEN`.
//! - A page exchanges the token, typed once on the sign-in page, for a session cookie (`POST /auth/signin` with
//!   `{"token": …}`): a random 128-bit id, `HttpOnly` (no script can read it) and `SameSite=Strict` (no other
//!   site's page can make the browser send it), naming a session held in memory here that ends after
//!   [`SESSION_LIFE`], on `POST /auth/signout` or when the server stops.
//!
//! Tokens are compared in constant time. A wrong token is answered 401 only after a delay that doubles with each
//! wrong try from the same address ([`FIRST_DELAY`] up to [`MAX_DELAY`]; forgotten after [`FORGET_AFTER`]
//! without one), slept on the async runtime so that no other client waits. Someone not signed in sees the
//! sign-in page and nothing else: no machine, job or drawing name. Cross-site requests are refused first, by the
//! Host/Origin checks of [`super::safety`].

use std::collections::HashMap;
use std::net::{IpAddr, Ipv4Addr, SocketAddr};
use std::path::Path;
use std::sync::{Arc, Mutex, PoisonError};
use std::time::Duration;

use anyhow::{Context as _, bail};
use axum::Json;
use axum::Router;
use axum::body::Bytes;
use axum::extract::{ConnectInfo, Request, State};
use axum::http::{HeaderMap, HeaderValue, Method, StatusCode, header};
use axum::middleware::{self, Next};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use serde_json::json;
use tokio::time::Instant;

use super::error::ApiError;
use super::safety;

/// How long a page stays signed in.
pub(crate) const SESSION_LIFE: Duration = Duration::from_secs(12 * 3600);
/// The delay before answering the first wrong token from an address; each further one doubles it.
pub(crate) const FIRST_DELAY: Duration = Duration::from_millis(100);
/// The longest delay before answering a wrong token.
pub(crate) const MAX_DELAY: Duration = Duration::from_secs(5);
/// An address's wrong tries are forgotten after this long without one.
pub(crate) const FORGET_AFTER: Duration = Duration::from_secs(15 * 60);
/// The most sessions held at once; signing in beyond it ends the session that would end soonest.
const MAX_SESSIONS: usize = 1024;
/// The most addresses whose wrong tries are remembered; beyond it, the longest-quiet one is forgotten.
const MAX_SOURCES: usize = 4096;
/// The shortest token accepted from a file.
pub(crate) const MIN_TOKEN_CHARS: usize = 16;

/// The sign-in page.
const SIGNIN_HTML: &str = include_str!("../../../../assets/signin.html");

/// What a signed-in client may do.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Role {
    /// Watch, and press an emergency stop.
    Viewer,
    /// Everything: queue, control, stop.
    Operator,
}

impl Role {
    fn name(self) -> &'static str {
        match self {
            Role::Viewer => "viewer",
            Role::Operator => "operator",
        }
    }
}

/// The tokens the server accepts.
#[derive(Clone)]
pub(crate) struct Tokens {
    /// The operator's token.
    pub(crate) operator: String,
    /// The viewers' token, if viewers may sign in.
    pub(crate) viewer: Option<String>,
}

impl std::fmt::Debug for Tokens {
    /// Never the tokens themselves (a debug print may end up in a log).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Tokens").field("viewer", &self.viewer.is_some()).finish_non_exhaustive()
    }
}

/// A fresh token: 128 bits from the operating system's random source, as 32 hex digits.
pub(crate) fn random_token() -> String {
    let mut bytes = [0u8; 16];
    // Without the system's random source there is no safe token: better to stop than to guess one.
    #[allow(clippy::expect_used)]
    getrandom::fill(&mut bytes).expect("the operating system's random source is readable");
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// Read a token from `path` (given to `flag`): its first line without surrounding blanks, at least
/// [`MIN_TOKEN_CHARS`] visible ASCII characters with no spaces (it travels in an HTTP header).
pub(crate) fn read_token_file(path: &Path, flag: &str) -> anyhow::Result<String> {
    let text = std::fs::read_to_string(path).with_context(|| format!("{flag} {}: cannot read it", path.display()))?;
    let token = text.lines().next().unwrap_or("").trim();
    if token.chars().count() < MIN_TOKEN_CHARS {
        bail!(
            "{flag} {}: the token on its first line has {} characters; use at least {MIN_TOKEN_CHARS} (e.g. the 32 \
             hex digits of `openssl rand -hex 16`)",
            path.display(),
            token.chars().count()
        );
    }
    if let Some(bad) = token.chars().find(|c| !c.is_ascii_graphic()) {
        bail!(
            "{flag} {}: the token holds {bad:?}; use letters, digits and punctuation only (no spaces)",
            path.display()
        );
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt as _;
        if let Ok(meta) = std::fs::metadata(path)
            && meta.permissions().mode() & 0o077 != 0
        {
            eprintln!(
                "warning: {flag} {}: other users of this computer can read it (chmod 600 {} to keep it yours)",
                path.display(),
                path.display()
            );
        }
    }
    Ok(token.to_string())
}

/// Whether `a` and `b` are equal, taking the same time whatever their contents (and however much of them
/// matches); only their lengths may show.
fn same(a: &[u8], b: &[u8]) -> bool {
    let mut diff = u8::from(a.len() != b.len());
    for (x, y) in a.iter().zip(b) {
        diff |= x ^ y;
    }
    std::hint::black_box(diff) == 0
}

struct Session {
    role: Role,
    ends: Instant,
}

struct Misses {
    count: u32,
    last: Instant,
}

/// The server's tokens, its sessions and the wrong tries per address.
pub(crate) struct Auth {
    tokens: Tokens,
    /// The address the server listens on (Host/Origin checks; the cookie's name).
    local: SocketAddr,
    sessions: Mutex<HashMap<String, Session>>,
    misses: Mutex<HashMap<IpAddr, Misses>>,
}

impl Auth {
    /// Sign-in for a server listening on `local` accepting `tokens`.
    pub(crate) fn new(tokens: Tokens, local: SocketAddr) -> Arc<Auth> {
        Arc::new(Auth { tokens, local, sessions: Mutex::default(), misses: Mutex::default() })
    }

    /// The role `token` signs in as (both tokens are always compared, in constant time).
    fn role_of(&self, token: &str) -> Option<Role> {
        let operator = same(token.as_bytes(), self.tokens.operator.as_bytes());
        let viewer = self.tokens.viewer.as_ref().is_some_and(|v| same(token.as_bytes(), v.as_bytes()));
        if operator {
            Some(Role::Operator)
        } else if viewer {
            Some(Role::Viewer)
        } else {
            None
        }
    }

    /// Count a wrong token from `from`; how long to wait before answering it.
    fn miss(&self, from: IpAddr) -> Duration {
        let now = Instant::now();
        let mut misses = self.misses.lock().unwrap_or_else(PoisonError::into_inner);
        if misses.len() >= MAX_SOURCES && !misses.contains_key(&from) {
            misses.retain(|_, m| now.duration_since(m.last) < FORGET_AFTER);
            if misses.len() >= MAX_SOURCES
                && let Some(oldest) = misses.iter().min_by_key(|(_, m)| m.last).map(|(ip, _)| *ip)
            {
                misses.remove(&oldest);
            }
        }
        let m = misses.entry(from).or_insert(Misses { count: 0, last: now });
        if now.duration_since(m.last) >= FORGET_AFTER {
            m.count = 0;
        }
        let delay = wrong_try_delay(m.count);
        m.count = m.count.saturating_add(1);
        m.last = now;
        delay
    }

    /// The answer to a wrong token from `from`, after its delay.
    async fn refuse(&self, from: IpAddr) -> Response {
        tokio::time::sleep(self.miss(from)).await;
        ApiError::new(StatusCode::UNAUTHORIZED, "wrong token: this server does not know it").into_response()
    }

    /// A new session for `role`; its id.
    fn open_session(&self, role: Role) -> String {
        let id = random_token();
        let now = Instant::now();
        let mut sessions = self.sessions.lock().unwrap_or_else(PoisonError::into_inner);
        if sessions.len() >= MAX_SESSIONS {
            sessions.retain(|_, s| s.ends > now);
            if sessions.len() >= MAX_SESSIONS
                && let Some(first) = sessions.iter().min_by_key(|(_, s)| s.ends).map(|(k, _)| k.clone())
            {
                sessions.remove(&first);
            }
        }
        sessions.insert(id.clone(), Session { role, ends: now + SESSION_LIFE });
        id
    }

    /// The role of the session `id`, if it is one and has not ended.
    fn session(&self, id: &str) -> Option<Role> {
        let mut sessions = self.sessions.lock().unwrap_or_else(PoisonError::into_inner);
        match sessions.get(id) {
            Some(s) if s.ends > Instant::now() => Some(s.role),
            Some(_) => {
                sessions.remove(id);
                None
            }
            None => None,
        }
    }

    /// The session cookie's name: with the port, since browsers share cookies between the ports of one host.
    fn cookie_name(&self) -> String {
        format!("plotter_session_{}", self.local.port())
    }

    /// The session id the request's cookies name, if any.
    fn cookie(&self, headers: &HeaderMap) -> Option<String> {
        let name = self.cookie_name();
        headers
            .get_all(header::COOKIE)
            .iter()
            .filter_map(|v| v.to_str().ok())
            .flat_map(|v| v.split(';'))
            .filter_map(|pair| pair.trim().split_once('='))
            .find(|(k, _)| *k == name)
            .map(|(_, v)| v.to_string())
    }
}

/// The delay before answering a wrong token, after `earlier` wrong ones from the same address:
/// [`FIRST_DELAY`] × 2^earlier, at most [`MAX_DELAY`].
pub(crate) fn wrong_try_delay(earlier: u32) -> Duration {
    FIRST_DELAY.checked_mul(1u32.checked_shl(earlier).unwrap_or(u32::MAX)).map_or(MAX_DELAY, |d| d.min(MAX_DELAY))
}

/// What a request needs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Need {
    /// Nothing: the sign-in itself.
    Nobody,
    /// Anyone signed in: watching, and stopping.
    Viewer,
    /// The operator: everything that changes something.
    Operator,
}

/// What `method path` needs: reading is for viewers, and so are the emergency stops; the rest is the operator's.
fn need(method: &Method, path: &str) -> Need {
    let is_post = method == Method::POST;
    if (is_post && path == "/auth/signin") || (method == Method::GET && path == "/style.css") {
        return Need::Nobody;
    }
    let reads = method == Method::GET || method == Method::HEAD;
    let stops = is_post
        && (path == "/api/stop-all"
            || path
                .strip_prefix("/api/machines/")
                .and_then(|rest| rest.strip_suffix("/estop"))
                .is_some_and(|name| !name.is_empty() && !name.contains('/')));
    if reads || stops || (is_post && path == "/auth/signout") { Need::Viewer } else { Need::Operator }
}

/// The address a request comes from (unspecified when unknown, as in tests that build requests by hand).
fn peer(req: &Request) -> IpAddr {
    req.extensions()
        .get::<ConnectInfo<SocketAddr>>()
        .map_or(IpAddr::V4(Ipv4Addr::UNSPECIFIED), |ConnectInfo(a)| a.ip().to_canonical())
}

/// The answer to someone not signed in: the sign-in page for a page load, a JSON error for the API.
fn not_signed_in(path: &str) -> Response {
    if path.starts_with("/api/") || path.starts_with("/auth/") {
        ApiError::new(
            StatusCode::UNAUTHORIZED,
            "sign in first: this server asks for a token (a page signs in on its sign-in form; plotter queue takes \
             --token-file or --token)",
        )
        .into_response()
    } else {
        (
            StatusCode::UNAUTHORIZED,
            [(header::CONTENT_TYPE, "text/html; charset=utf-8"), (header::CACHE_CONTROL, "no-store")],
            SIGNIN_HTML,
        )
            .into_response()
    }
}

/// `router` behind sign-in: the guard on every route, plus `POST /auth/signin`, `POST /auth/signout` and
/// `GET /auth/me` (the caller's role).
pub(crate) fn protect(router: Router, auth: Arc<Auth>) -> Router {
    let own = Router::new()
        .route("/auth/signin", post(sign_in))
        .route("/auth/signout", post(sign_out))
        .route("/auth/me", get(me))
        .with_state(Arc::clone(&auth));
    router.merge(own).layer(middleware::from_fn_with_state(auth, guard))
}

/// Refuse cross-site requests, then anyone not signed in or without the role the request needs.
async fn guard(State(auth): State<Arc<Auth>>, mut req: Request, next: Next) -> Response {
    if let Err(refusal) = safety::check_request(req.headers(), auth.local) {
        return ApiError::new(StatusCode::FORBIDDEN, refusal.to_string()).into_response();
    }
    let path = req.uri().path().to_string();
    let need = need(req.method(), &path);
    if need == Need::Nobody {
        return next.run(req).await;
    }
    let role = match req.headers().get(header::AUTHORIZATION) {
        Some(value) => {
            let Some(token) = value.to_str().ok().and_then(|v| v.strip_prefix("Bearer ")) else {
                return ApiError::new(StatusCode::UNAUTHORIZED, "the Authorization header must be `Bearer TOKEN`")
                    .into_response();
            };
            match auth.role_of(token.trim()) {
                Some(role) => role,
                None => return auth.refuse(peer(&req)).await,
            }
        }
        None => match auth.cookie(req.headers()).and_then(|id| auth.session(&id)) {
            Some(role) => role,
            None => return not_signed_in(&path),
        },
    };
    if need == Need::Operator && role == Role::Viewer {
        return ApiError::new(
            StatusCode::FORBIDDEN,
            "a viewer may watch and press an emergency stop; queueing and controlling the machines need the \
             operator's token",
        )
        .into_response();
    }
    req.extensions_mut().insert(role);
    next.run(req).await
}

/// `POST /auth/signin` with `{"token": …}`: a session cookie for the token's role.
async fn sign_in(State(auth): State<Arc<Auth>>, req: Request) -> Response {
    let from = peer(&req);
    let body = match axum::body::to_bytes(req.into_body(), 4096).await {
        Ok(b) => b,
        Err(_) => return ApiError::new(StatusCode::BAD_REQUEST, "sign in with {\"token\": \"…\"}").into_response(),
    };
    let Some(token) = token_of(&body) else {
        return ApiError::new(StatusCode::BAD_REQUEST, "sign in with {\"token\": \"…\"}").into_response();
    };
    let Some(role) = auth.role_of(token.trim()) else { return auth.refuse(from).await };
    let id = auth.open_session(role);
    let cookie =
        format!("{}={id}; HttpOnly; SameSite=Strict; Path=/; Max-Age={}", auth.cookie_name(), SESSION_LIFE.as_secs());
    let mut answer = Json(json!({ "role": role.name() })).into_response();
    if let Ok(v) = HeaderValue::from_str(&cookie) {
        answer.headers_mut().insert(header::SET_COOKIE, v);
    }
    answer
}

/// The `token` of a sign-in body.
fn token_of(body: &Bytes) -> Option<String> {
    let v: serde_json::Value = serde_json::from_slice(body).ok()?;
    v.get("token")?.as_str().map(str::to_string)
}

/// `POST /auth/signout`: end the page's session.
async fn sign_out(State(auth): State<Arc<Auth>>, headers: HeaderMap) -> Response {
    if let Some(id) = auth.cookie(&headers) {
        auth.sessions.lock().unwrap_or_else(PoisonError::into_inner).remove(&id);
    }
    let cookie = format!("{}=; HttpOnly; SameSite=Strict; Path=/; Max-Age=0", auth.cookie_name());
    let mut answer = Json(json!({ "ok": true })).into_response();
    if let Ok(v) = HeaderValue::from_str(&cookie) {
        answer.headers_mut().insert(header::SET_COOKIE, v);
    }
    answer
}

/// `GET /auth/me`: the caller's role.
async fn me(req: Request) -> Response {
    let role = req.extensions().get::<Role>().copied().unwrap_or(Role::Viewer);
    Json(json!({ "role": role.name() })).into_response()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_delay_doubles_from_100_ms_up_to_5_s() {
        let ms: Vec<u128> = (0..9).map(|n| wrong_try_delay(n).as_millis()).collect();
        assert_eq!(ms, [100, 200, 400, 800, 1600, 3200, 5000, 5000, 5000]);
        assert_eq!(wrong_try_delay(40), MAX_DELAY);
        assert_eq!(wrong_try_delay(u32::MAX), MAX_DELAY);
    }

    #[test]
    fn tokens_compare_whole() {
        assert!(same(b"abcdef0123456789", b"abcdef0123456789"));
        assert!(!same(b"abcdef0123456789", b"abcdef012345678"));
        assert!(!same(b"abcdef0123456789", b"abcdef0123456789x"));
        assert!(!same(b"abcdef0123456789", b"bbcdef0123456789"));
        assert!(!same(b"", b"a"));
        let auth = Auth::new(
            Tokens { operator: "o".repeat(16), viewer: Some("v".repeat(16)) },
            "127.0.0.1:1".parse().unwrap(),
        );
        assert_eq!(auth.role_of(&"o".repeat(16)), Some(Role::Operator));
        assert_eq!(auth.role_of(&"v".repeat(16)), Some(Role::Viewer));
        assert_eq!(auth.role_of(&"o".repeat(15)), None);
        assert_eq!(auth.role_of(""), None);
    }

    #[test]
    fn what_each_request_needs() {
        let (get, post) = (Method::GET, Method::POST);
        assert_eq!(need(&post, "/auth/signin"), Need::Nobody);
        assert_eq!(need(&get, "/style.css"), Need::Nobody);
        for path in ["/", "/studio.js", "/api/studio", "/api/events", "/api/queue", "/auth/me"] {
            assert_eq!(need(&get, path), Need::Viewer, "{path}");
        }
        for path in ["/api/machines/left/estop", "/api/stop-all", "/auth/signout"] {
            assert_eq!(need(&post, path), Need::Viewer, "{path}");
        }
        for path in [
            "/api/queue",
            "/api/queue/3/cancel",
            "/api/machines/left/pause",
            "/api/machines/left/stop",
            "/api/machines//estop",
            "/api/machines/a/b/estop",
            "/api/plot",
            "/api/control/claim",
        ] {
            assert_eq!(need(&post, path), Need::Operator, "{path}");
        }
        assert_eq!(need(&Method::DELETE, "/api/machines/left/estop"), Need::Operator);
    }

    #[test]
    fn token_files_are_checked() {
        let dir = std::env::temp_dir().join(format!("plotter-auth-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("token");
        std::fs::write(&file, "  0123456789abcdef0123  \nsecond line\n").unwrap();
        assert_eq!(read_token_file(&file, "--token-file").unwrap(), "0123456789abcdef0123");
        std::fs::write(&file, "short\n").unwrap();
        let e = read_token_file(&file, "--token-file").unwrap_err().to_string();
        assert!(e.contains("--token-file") && e.contains("5 characters") && e.contains("at least 16"), "{e}");
        std::fs::write(&file, "0123456789 abcdef0123\n").unwrap();
        let e = read_token_file(&file, "--viewer-token-file").unwrap_err().to_string();
        assert!(e.starts_with("--viewer-token-file") && e.contains("' '"), "{e}");
        let e = read_token_file(&dir.join("missing"), "--token-file").unwrap_err().to_string();
        assert!(e.contains("cannot read"), "{e}");
        let _ = std::fs::remove_dir_all(dir);
        let (a, b) = (random_token(), random_token());
        assert!(a.len() == 32 && a.chars().all(|c| c.is_ascii_hexdigit()) && a != b, "{a} {b}");
    }

    /// The studio's API behind sign-in, in process: one simulated machine `left` (no worker runs: requests only
    /// reach the queue and the machines' request flags).
    mod studio {
        use super::super::*;
        use crate::serve::studio_api::{StudioState, router};
        use axum::body::Body;
        use plotter_host::studio::machines::parse_machine;
        use plotter_host::studio::running::{Studio, StudioOptions};
        use tower::ServiceExt as _;

        const OPERATOR: &str = "operator-0123456789abcdef";
        const VIEWER: &str = "viewer-0123456789abcdef";
        const HOST: &str = "127.0.0.1:8040";
        const SVG: &str = r#"<svg xmlns="http://www.w3.org/2000/svg" width="20mm" height="20mm" viewBox="0 0 20 20"><path d="M 2 2 L 18 18" stroke="black"/></svg>"#;

        struct App {
            router: Router,
            _studio: Arc<Studio>,
            dir: std::path::PathBuf,
        }

        impl Drop for App {
            fn drop(&mut self) {
                let _ = std::fs::remove_dir_all(&self.dir);
            }
        }

        fn app(name: &str) -> App {
            let dir = std::env::temp_dir().join(format!("plotter-auth-studio-{}-{name}", std::process::id()));
            let _ = std::fs::remove_dir_all(&dir);
            let studio =
                Studio::open(&dir, vec![parse_machine("left=sim").unwrap()], StudioOptions::default()).unwrap();
            let local: SocketAddr = HOST.parse().unwrap();
            let tokens = Tokens { operator: OPERATOR.into(), viewer: Some(VIEWER.into()) };
            let router = protect(router(StudioState { studio: Arc::clone(&studio), local }), Auth::new(tokens, local));
            App { router, _studio: studio, dir }
        }

        struct Answer {
            status: StatusCode,
            headers: HeaderMap,
            body: String,
        }

        /// `method path` from the address `from`, with `headers` (and a Host of this server), `body`.
        async fn send(app: &App, method: &str, path: &str, headers: &[(&str, &str)], body: &str, from: u8) -> Answer {
            let mut req = axum::http::Request::builder().method(method).uri(path).header(header::HOST, HOST);
            for (k, v) in headers {
                req = req.header(*k, *v);
            }
            let mut req = req.body(Body::from(body.to_string())).unwrap();
            let peer: SocketAddr = ([192, 168, 1, from], 50000).into();
            req.extensions_mut().insert(ConnectInfo(peer));
            let r = app.router.clone().oneshot(req).await.unwrap();
            let status = r.status();
            let headers = r.headers().clone();
            let bytes = axum::body::to_bytes(r.into_body(), 1 << 20).await.unwrap();
            Answer { status, headers, body: String::from_utf8_lossy(&bytes).into_owned() }
        }

        fn bearer(token: &str) -> String {
            format!("Bearer {token}")
        }

        #[tokio::test(start_paused = true)]
        async fn a_wrong_token_is_answered_401_each_try_slower_and_no_one_else_waits() {
            let app = app("delay");
            let wrong = bearer("not-the-token-at-all");
            let mut waits = Vec::new();
            for _ in 0..3 {
                let t0 = Instant::now();
                let a = send(&app, "GET", "/api/queue", &[("authorization", &wrong)], "", 7).await;
                assert_eq!(a.status, StatusCode::UNAUTHORIZED, "{}", a.body);
                assert!(a.body.contains("wrong token"), "{}", a.body);
                waits.push(t0.elapsed());
            }
            // 100 ms, then 200 ms, then 400 ms: each wrong try from 192.168.1.7 waits twice the last.
            assert_eq!(waits, [100, 200, 400].map(Duration::from_millis));
            // The sign-in form's wrong tries count from the same address: the 4th waits 800 ms.
            let t0 = Instant::now();
            let a = send(&app, "POST", "/auth/signin", &[], r#"{"token": "guess-0123456789abcdef"}"#, 7).await;
            assert_eq!((a.status, t0.elapsed()), (StatusCode::UNAUTHORIZED, Duration::from_millis(800)));
            // Another address starts at 100 ms.
            let t0 = Instant::now();
            let a = send(&app, "GET", "/api/studio", &[("authorization", &wrong)], "", 8).await;
            assert_eq!((a.status, t0.elapsed()), (StatusCode::UNAUTHORIZED, Duration::from_millis(100)));
            // While the 5th wrong try from .7 waits its 1.6 s, the operator is answered at once.
            let app = Arc::new(app);
            let slow = {
                let app = Arc::clone(&app);
                let wrong = wrong.clone();
                tokio::spawn(async move {
                    let t0 = Instant::now();
                    let a = send(&app, "GET", "/api/queue", &[("authorization", &wrong)], "", 7).await;
                    (a.status, t0.elapsed())
                })
            };
            tokio::task::yield_now().await;
            let t0 = Instant::now();
            let a = send(&app, "GET", "/api/studio", &[("authorization", &bearer(OPERATOR))], "", 9).await;
            assert_eq!(a.status, StatusCode::OK, "{}", a.body);
            assert!(t0.elapsed() < Duration::from_millis(100), "{:?}", t0.elapsed());
            assert!(!slow.is_finished(), "the wrong try is still waiting");
            assert_eq!(slow.await.unwrap(), (StatusCode::UNAUTHORIZED, Duration::from_millis(1600)));
            // Quiet for the forgetting time: back to 100 ms.
            tokio::time::advance(FORGET_AFTER).await;
            let t0 = Instant::now();
            send(&app, "GET", "/api/queue", &[("authorization", &wrong)], "", 7).await;
            assert_eq!(t0.elapsed(), Duration::from_millis(100));
        }

        #[tokio::test(start_paused = true)]
        async fn a_viewer_watches_and_stops_but_cannot_queue_or_control() {
            let app = app("roles");
            let (op, view) = (bearer(OPERATOR), bearer(VIEWER));
            let queue = "/api/queue?name=line.svg&machine=left";
            let a = send(&app, "POST", queue, &[("authorization", &view)], SVG, 1).await;
            assert_eq!(a.status, StatusCode::FORBIDDEN, "{}", a.body);
            assert!(a.body.contains("operator's token"), "{}", a.body);
            let a = send(&app, "POST", queue, &[("authorization", &op)], SVG, 1).await;
            assert_eq!(a.status, StatusCode::CREATED, "{}", a.body);
            for path in [
                "/api/machines/left/pause",
                "/api/machines/left/resume",
                "/api/machines/left/stop",
                "/api/queue/1/cancel",
            ] {
                let a = send(&app, "POST", path, &[("authorization", &view)], "", 1).await;
                assert_eq!(a.status, StatusCode::FORBIDDEN, "{path}: {}", a.body);
            }
            for path in ["/api/studio", "/api/queue", "/api/queue/1", "/", "/auth/me"] {
                let a = send(&app, "GET", path, &[("authorization", &view)], "", 1).await;
                assert_eq!(a.status, StatusCode::OK, "{path}: {}", a.body);
            }
            let a = send(&app, "GET", "/api/queue", &[("authorization", &view)], "", 1).await;
            assert!(a.body.contains("line.svg"), "{}", a.body);
            for path in ["/api/machines/left/estop", "/api/stop-all"] {
                let a = send(&app, "POST", path, &[("authorization", &view)], "", 1).await;
                assert_eq!(a.status, StatusCode::OK, "{path}: {}", a.body);
            }
            let a = send(&app, "POST", "/api/machines/left/pause", &[("authorization", &op)], "", 1).await;
            assert_eq!(a.status, StatusCode::OK, "{}", a.body);
            let a = send(&app, "GET", "/auth/me", &[("authorization", &view)], "", 1).await;
            assert_eq!(a.body, r#"{"role":"viewer"}"#);
        }

        #[tokio::test(start_paused = true)]
        async fn the_unsigned_see_the_sign_in_page_and_nothing_of_the_studio() {
            let app = app("unsigned");
            let a =
                send(&app, "POST", "/api/queue?name=secret-duck.svg", &[("authorization", &bearer(OPERATOR))], SVG, 1)
                    .await;
            assert_eq!(a.status, StatusCode::CREATED, "{}", a.body);
            for path in ["/", "/studio.js", "/api/studio", "/api/events", "/api/queue", "/api/queue/1", "/auth/me"] {
                let a = send(&app, "GET", path, &[], "", 2).await;
                assert_eq!(a.status, StatusCode::UNAUTHORIZED, "{path}");
                assert!(!a.body.contains("secret-duck") && !a.body.contains("left"), "{path}: {}", a.body);
                if path.starts_with("/api/") || path.starts_with("/auth/") {
                    assert!(a.body.contains("sign in first"), "{path}: {}", a.body);
                } else {
                    assert!(a.body.contains("<form id=\"signin\">"), "{path}: {}", a.body);
                }
            }
            for path in ["/api/queue?name=x.svg", "/api/machines/left/estop", "/api/stop-all"] {
                let a = send(&app, "POST", path, &[], SVG, 2).await;
                assert_eq!(a.status, StatusCode::UNAUTHORIZED, "{path}: {}", a.body);
            }
            // A malformed header is not a token.
            let a = send(&app, "GET", "/api/studio", &[("authorization", OPERATOR)], "", 2).await;
            assert_eq!(a.status, StatusCode::UNAUTHORIZED, "{}", a.body);
            assert!(a.body.contains("Bearer TOKEN"), "{}", a.body);
            assert_eq!(send(&app, "GET", "/style.css", &[], "", 2).await.status, StatusCode::OK);
        }

        #[tokio::test(start_paused = true)]
        async fn a_page_trades_the_token_for_a_strict_http_only_cookie_that_ends() {
            let app = app("cookie");
            let a = send(&app, "POST", "/auth/signin", &[], &format!(r#"{{"token": "{VIEWER}"}}"#), 3).await;
            assert_eq!((a.status, a.body.as_str()), (StatusCode::OK, r#"{"role":"viewer"}"#));
            let set = a.headers.get(header::SET_COOKIE).unwrap().to_str().unwrap().to_string();
            let (pair, attributes) = set.split_once("; ").unwrap();
            assert_eq!(attributes, "HttpOnly; SameSite=Strict; Path=/; Max-Age=43200");
            let (name, id) = pair.split_once('=').unwrap();
            assert_eq!(name, "plotter_session_8040");
            assert!(id.len() == 32 && id.chars().all(|c| c.is_ascii_hexdigit()), "{id}");
            let cookie = format!("other=1; {pair}");
            let a = send(&app, "GET", "/api/studio", &[("cookie", &cookie)], "", 3).await;
            assert_eq!(a.status, StatusCode::OK, "{}", a.body);
            assert!(a.body.contains("\"left\""), "{}", a.body);
            // The viewer's session may stop, not control.
            assert_eq!(
                send(&app, "POST", "/api/machines/left/estop", &[("cookie", &cookie)], "", 3).await.status,
                StatusCode::OK
            );
            assert_eq!(
                send(&app, "POST", "/api/machines/left/pause", &[("cookie", &cookie)], "", 3).await.status,
                StatusCode::FORBIDDEN
            );
            // A made-up session id is no session.
            let forged = format!("{name}=0123456789abcdef0123456789abcdef");
            assert_eq!(
                send(&app, "GET", "/api/studio", &[("cookie", &forged)], "", 3).await.status,
                StatusCode::UNAUTHORIZED
            );
            // Signed out: the cookie is cleared and the session gone.
            let a = send(&app, "POST", "/auth/signout", &[("cookie", &cookie)], "", 3).await;
            assert_eq!(a.status, StatusCode::OK);
            assert!(a.headers.get(header::SET_COOKIE).unwrap().to_str().unwrap().ends_with("Max-Age=0"));
            assert_eq!(
                send(&app, "GET", "/api/studio", &[("cookie", &cookie)], "", 3).await.status,
                StatusCode::UNAUTHORIZED
            );
            // An operator's session lasts 12 hours.
            let a = send(&app, "POST", "/auth/signin", &[], &format!(r#"{{"token": "{OPERATOR}"}}"#), 3).await;
            let set = a.headers.get(header::SET_COOKIE).unwrap().to_str().unwrap().to_string();
            let cookie = set.split_once("; ").unwrap().0.to_string();
            let a = send(&app, "POST", "/api/machines/left/pause", &[("cookie", &cookie)], "", 3).await;
            assert_eq!(a.status, StatusCode::OK, "{}", a.body);
            tokio::time::advance(SESSION_LIFE - Duration::from_secs(1)).await;
            assert_eq!(send(&app, "GET", "/api/studio", &[("cookie", &cookie)], "", 3).await.status, StatusCode::OK);
            tokio::time::advance(Duration::from_secs(1)).await;
            assert_eq!(
                send(&app, "GET", "/api/studio", &[("cookie", &cookie)], "", 3).await.status,
                StatusCode::UNAUTHORIZED
            );
        }

        #[tokio::test(start_paused = true)]
        async fn a_cross_site_request_is_refused_whatever_it_carries() {
            let app = app("cross");
            let op = bearer(OPERATOR);
            let a = send(&app, "POST", "/auth/signin", &[], &format!(r#"{{"token": "{OPERATOR}"}}"#), 4).await;
            let set = a.headers.get(header::SET_COOKIE).unwrap().to_str().unwrap().to_string();
            let cookie = set.split_once("; ").unwrap().0.to_string();
            for creds in [("authorization", op.as_str()), ("cookie", cookie.as_str())] {
                for (k, v) in [
                    ("origin", "http://evil.example"),
                    ("sec-fetch-site", "cross-site"),
                    ("referer", "http://evil.example/x"),
                ] {
                    let a = send(&app, "POST", "/api/queue?name=x.svg", &[creds, (k, v)], SVG, 4).await;
                    assert_eq!(a.status, StatusCode::FORBIDDEN, "{k}: {}", a.body);
                    assert!(a.body.contains("refused"), "{}", a.body);
                }
            }
            // The sign-in itself too: another site cannot sign a browser in.
            let a = send(
                &app,
                "POST",
                "/auth/signin",
                &[("origin", "http://evil.example")],
                &format!(r#"{{"token": "{OPERATOR}"}}"#),
                4,
            )
            .await;
            assert_eq!(a.status, StatusCode::FORBIDDEN);
            assert!(a.headers.get(header::SET_COOKIE).is_none());
            let a = send(&app, "GET", "/api/queue", &[("authorization", &op)], "", 4).await;
            assert_eq!(a.body, "[]", "nothing was queued");
        }
    }
}
