//! The accept loop: HTTP/1 connections served by hyper with the router as their service, within limits on how
//! many there are and how long they may take to say what they want ([`super::state::Limits`]).
//!
//! `axum::serve` has no connection limit and no header-read timeout, so a client could open connections and
//! send half a request on each until the process ran out of descriptors and memory. Here:
//! - at most `max_connections` connections are served at once. One over the limit is answered `503` and closed
//!   at once — not left waiting in a queue — so a client learns it, and the connections already open are not
//!   slowed. A slot is freed when its connection closes;
//! - a connection must send each request head within `header_timeout` of the server waiting for it (hyper's
//!   `header_read_timeout`, which also bounds how long a kept-alive connection may sit idle between requests);
//!   otherwise it is closed without an answer. Request bodies have their own deadline ([`super::deadline`]);
//! - hyper's read buffer (which bounds a request head) is capped at [`MAX_BUFFER`] bytes a connection.
//!
//! An event stream holds its connection as long as the page is open; it is a response in progress, which no
//! header timeout touches.

use std::sync::Arc;
use std::time::Duration;

use hyper_util::rt::{TokioIo, TokioTimer};
use hyper_util::service::TowerToHyperService;
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::Semaphore;

use super::state::Limits;

/// hyper's per-connection read buffer, bytes: ample for a browser's request head (a few KB).
const MAX_BUFFER: usize = 64 * 1024;

/// Serve `router` on `listener` within `limits`, until the process ends.
pub(crate) async fn serve(listener: TcpListener, router: axum::Router, limits: Limits) {
    let slots = Arc::new(Semaphore::new(limits.max_connections));
    let busy = busy_response(limits.max_connections);
    let mut http = hyper::server::conn::http1::Builder::new();
    http.timer(TokioTimer::new()).header_read_timeout(limits.header_timeout).max_buf_size(MAX_BUFFER);
    loop {
        let (stream, peer) = match listener.accept().await {
            Ok(accepted) => accepted,
            Err(e) => {
                // Out of descriptors, or a connection reset before it was taken: wait a little rather than spin.
                if !matches!(e.kind(), std::io::ErrorKind::ConnectionAborted | std::io::ErrorKind::ConnectionReset) {
                    eprintln!("warning: cannot accept a connection: {e}");
                }
                tokio::time::sleep(Duration::from_millis(100)).await;
                continue;
            }
        };
        let Ok(slot) = Arc::clone(&slots).try_acquire_owned() else {
            refuse(stream, &busy);
            continue;
        };
        // Events and small answers go out at once.
        let _ = stream.set_nodelay(true);
        // Each request carries the client's address (the sign-in's delay per address, see super::auth).
        let service = tower::ServiceExt::map_request(router.clone(), move |mut req: axum::extract::Request<_>| {
            req.extensions_mut().insert(axum::extract::ConnectInfo(peer));
            req
        });
        let connection = http.serve_connection(TokioIo::new(stream), TowerToHyperService::new(service));
        tokio::spawn(async move {
            // A timed-out or broken connection is the client's business: nothing to report.
            let _ = connection.await;
            drop(slot);
        });
    }
}

/// Answer a connection over the limit and close it. A fresh socket's send buffer takes the few bytes at once;
/// if it does not, the connection is closed all the same.
fn refuse(stream: TcpStream, busy: &[u8]) {
    let _ = stream.try_write(busy);
    drop(stream);
}

/// The whole answer to a connection over the limit of `max` (a JSON error like every other).
fn busy_response(max: usize) -> Vec<u8> {
    let body = serde_json::json!({
        "error": format!(
            "refused: the server already has {max} connections open, its limit (start it with --max-connections \
             to change it); close other pages of it or try again"
        )
    })
    .to_string();
    format!(
        "HTTP/1.1 503 Service Unavailable\r\ncontent-type: application/json\r\ncontent-length: {}\r\n\
         connection: close\r\nretry-after: 1\r\n\r\n{body}",
        body.len()
    )
    .into_bytes()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_busy_answer_is_a_complete_http_response() {
        let bytes = busy_response(7);
        let text = String::from_utf8(bytes).unwrap();
        let (head, body) = text.split_once("\r\n\r\n").unwrap();
        assert!(head.starts_with("HTTP/1.1 503 Service Unavailable\r\n"), "{head}");
        assert!(head.contains(&format!("content-length: {}\r\n", body.len())), "{head}");
        let v: serde_json::Value = serde_json::from_str(body).unwrap();
        assert!(v["error"].as_str().unwrap().contains("7 connections open"), "{v}");
    }
}
