//! A deadline on request bodies. hyper bounds the time to send a request's head (see [`super::listen`]) but not
//! its body, so a client could send an upload's declared length a byte a minute and hold a connection and a
//! handler forever. Every request body is wrapped here: if it has not all arrived within
//! [`super::state::Limits::body_timeout`] of the request's head, reading it fails, and the request is answered
//! `408 Request Timeout` with the connection closed (whatever the handler made of the failed read).

use std::pin::Pin;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::task::{Context, Poll};
use std::time::Duration;

use axum::body::{Body, Bytes, HttpBody};
use axum::extract::{Request, State};
use axum::http::{HeaderValue, StatusCode, header};
use axum::middleware::Next;
use axum::response::{IntoResponse as _, Response};
use hyper::body::{Frame, SizeHint};

use super::error::ApiError;
use super::state::Shared;

/// Reading a body failed: it did not arrive in time.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct BodyTimedOut(pub(crate) Duration);

impl std::fmt::Display for BodyTimedOut {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "the request body did not arrive within {:.1} s", self.0.as_secs_f64())
    }
}

impl std::error::Error for BodyTimedOut {}

/// A body that fails with [`BodyTimedOut`] once its deadline passes before its end.
struct Deadline {
    inner: Body,
    sleep: Pin<Box<tokio::time::Sleep>>,
    limit: Duration,
    fired: Arc<AtomicBool>,
}

impl HttpBody for Deadline {
    type Data = Bytes;
    type Error = axum::Error;

    fn poll_frame(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<Option<Result<Frame<Bytes>, axum::Error>>> {
        let this = self.get_mut();
        if let Poll::Ready(frame) = Pin::new(&mut this.inner).poll_frame(cx) {
            return Poll::Ready(frame);
        }
        if this.sleep.as_mut().poll(cx).is_ready() {
            this.fired.store(true, Ordering::Relaxed);
            return Poll::Ready(Some(Err(axum::Error::new(BodyTimedOut(this.limit)))));
        }
        Poll::Pending
    }

    fn is_end_stream(&self) -> bool {
        self.inner.is_end_stream()
    }

    fn size_hint(&self) -> SizeHint {
        self.inner.size_hint()
    }
}

/// Middleware: put the deadline on the request's body (a request without one passes as it is).
pub(crate) async fn body_deadline(State(shared): State<Arc<Shared>>, req: Request, next: Next) -> Response {
    if req.body().is_end_stream() {
        return next.run(req).await;
    }
    let limit = shared.config.limits.body_timeout;
    let fired = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&fired);
    let req =
        req.map(|inner| Body::new(Deadline { inner, sleep: Box::pin(tokio::time::sleep(limit)), limit, fired: flag }));
    let response = next.run(req).await;
    if !fired.load(Ordering::Relaxed) {
        return response;
    }
    let mut timed_out =
        ApiError::new(StatusCode::REQUEST_TIMEOUT, format!("refused: {}", BodyTimedOut(limit))).into_response();
    timed_out.headers_mut().insert(header::CONNECTION, HeaderValue::from_static("close"));
    timed_out
}

#[cfg(test)]
mod tests {
    use super::*;
    use axum::body::to_bytes;

    fn slow_body(fired: &Arc<AtomicBool>, limit: Duration, parts: Vec<(u64, &'static str)>) -> Body {
        let chunks = futures_util::stream::unfold(parts.into_iter(), |mut it| async move {
            let (after_ms, text) = it.next()?;
            tokio::time::sleep(Duration::from_millis(after_ms)).await;
            Some((Ok::<_, std::io::Error>(Bytes::from_static(text.as_bytes())), it))
        });
        let inner = Body::from_stream(chunks);
        Body::new(Deadline { inner, sleep: Box::pin(tokio::time::sleep(limit)), limit, fired: Arc::clone(fired) })
    }

    #[tokio::test(start_paused = true)]
    async fn a_body_in_time_reads_whole_and_a_late_one_fails_with_the_limit() {
        let fired = Arc::new(AtomicBool::new(false));
        let body = slow_body(&fired, Duration::from_secs(5), vec![(2000, "ab"), (2900, "cd")]);
        assert_eq!(to_bytes(body, 100).await.unwrap(), "abcd");
        assert!(!fired.load(Ordering::Relaxed));

        let body = slow_body(&fired, Duration::from_secs(5), vec![(2000, "ab"), (3100, "cd")]);
        let err = to_bytes(body, 100).await.unwrap_err();
        assert!(fired.load(Ordering::Relaxed));
        let mut cause: Option<&(dyn std::error::Error + 'static)> = Some(&err);
        while let Some(e) = cause.filter(|e| !e.is::<BodyTimedOut>()) {
            cause = e.source();
        }
        let cause = cause.and_then(|e| e.downcast_ref::<BodyTimedOut>());
        assert_eq!(cause, Some(&BodyTimedOut(Duration::from_secs(5))), "{err}");
        assert_eq!(
            BodyTimedOut(Duration::from_millis(500)).to_string(),
            "the request body did not arrive within 0.5 s"
        );
    }
}
