//! Who may talk to the server, and who may drive the machine.
//!
//! # Host and Origin
//! A page on another site can make a browser send requests to `127.0.0.1`: cross-site form posts and `fetch`es
//! (the `Origin` header names the other site), and DNS rebinding, where the attacker's own host name is made to
//! resolve to 127.0.0.1 so the browser thinks the page is same-origin (the `Host` header then holds the attacker's
//! name). So every request must carry a `Host` that is this server's own authority — an IP literal or `localhost`,
//! with the port it listens on; other names are refused, since a rebinding attack needs one — and, when an
//! `Origin` is sent, it must be `http://` plus that same `Host`.
//!
//! Off loopback (`--allow-remote`) people reach the server by name too (`plotter.local`): the names it is known by
//! are accepted as well — the computer's own host name, that name under `.local` (mDNS), and those given with
//! `--host-name` — and no other, so a rebinding name is still refused ([`accept_names`]).
//!
//! Browsers send no `Origin` on simple `GET`s (links, images, scripts) and older ones on few requests at all; then
//! the other signs of where a request comes from are checked: a `Referer` must be a page of this same origin, and
//! `Sec-Fetch-Site` (sent by current browsers on every request, and not settable by scripts) must be
//! `same-origin` or `none` (typed or bookmarked). `same-site` is refused too: another server on this machine, on
//! another port, is the same site to the browser.
//!
//! # One controller
//! Many pages may watch; one drives. A page claims control and gets a random token; every request that changes
//! something must carry it in the `X-Plotter-Token` header. How control is held and given up:
//! [`super::control`].

use std::hash::{BuildHasher as _, Hasher as _};
use std::net::{IpAddr, SocketAddr};
use std::sync::OnceLock;

use axum::http::{HeaderMap, header};

/// The header that carries the controller's token.
pub(crate) const TOKEN_HEADER: &str = "x-plotter-token";

/// Why a request is refused.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum Refusal {
    /// No or a foreign `Host`.
    Host(String),
    /// A foreign `Origin`.
    Origin(String),
    /// A foreign `Referer` (no `Origin` sent).
    Referer(String),
    /// A `Sec-Fetch-Site` other than `same-origin` or `none`.
    FetchSite(String),
}

impl std::fmt::Display for Refusal {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Refusal::Host(h) => {
                write!(f, "refused: Host {h:?} is not this server (open the address plotter serve printed)")
            }
            Refusal::Origin(o) => write!(f, "refused: requests from {o:?} are not accepted (cross-site request)"),
            Refusal::Referer(r) => {
                write!(f, "refused: requests from the page {r:?} are not accepted (cross-site request)")
            }
            Refusal::FetchSite(s) => write!(
                f,
                "refused: the browser says this request comes from another site (Sec-Fetch-Site: {s}); open the \
                 address plotter serve printed"
            ),
        }
    }
}

/// The host names this server accepts in `Host` besides `localhost` (set once, at start, off loopback).
static NAMES: OnceLock<Vec<String>> = OnceLock::new();

/// Accept `names` (already checked with [`host_names`]) in the `Host` of every request from now on; called once,
/// when the server listens off loopback.
pub(crate) fn accept_names(names: Vec<String>) {
    let _ = NAMES.set(names);
}

/// The names a server listening off loopback is known by: this computer's host name and that name under
/// `.local` (when the system says it), then `given` (`--host-name`), each checked to be a host name; lowercase,
/// each once. An error names the first bad one.
pub(crate) fn host_names(system: Option<&str>, given: &[String]) -> anyhow::Result<Vec<String>> {
    let mut names: Vec<String> = Vec::new();
    let mut add = |n: &str| {
        let n = n.trim_end_matches('.').to_ascii_lowercase();
        if !names.contains(&n) {
            names.push(n);
        }
    };
    if let Some(own) = system.map(str::trim).filter(|n| is_host_name(n)) {
        add(own);
        if !own.contains('.') {
            add(&format!("{own}.local"));
        }
    }
    for n in given {
        if !is_host_name(n) {
            anyhow::bail!(
                "--host-name {n:?}: give a host name the server is reached by, such as plotter.local (letters, \
                 digits and hyphens, in labels joined by dots; an IP address needs no --host-name)"
            );
        }
        add(n);
    }
    Ok(names)
}

/// This computer's host name, as the system knows it (none when it cannot be read).
pub(crate) fn system_host_name() -> Option<String> {
    ["/proc/sys/kernel/hostname", "/etc/hostname"]
        .iter()
        .find_map(|f| std::fs::read_to_string(f).ok())
        .map(|n| n.trim().to_string())
        .filter(|n| !n.is_empty())
}

/// Whether `name` is a DNS host name (labels of letters, digits and inner hyphens, at most 63 bytes each and
/// 253 in all, joined by dots, a trailing dot allowed), and not an IP literal.
fn is_host_name(name: &str) -> bool {
    let name = name.strip_suffix('.').unwrap_or(name);
    let label = |l: &str| {
        (1..=63).contains(&l.len())
            && l.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'-')
            && !l.starts_with('-')
            && !l.ends_with('-')
    };
    !name.is_empty() && name.len() <= 253 && name.split('.').all(label) && name.parse::<IpAddr>().is_err()
}

/// Whether `host` (a `Host` header value) names this server listening on `local`: `localhost` or an IP literal,
/// with `local`'s port, or off loopback one of the names given to [`accept_names`]. A wildcard listen address
/// (0.0.0.0, ::) accepts any IP literal, since the server then answers on every interface; a specific one
/// accepts itself and loopback.
pub(crate) fn host_is_ours(host: &str, local: SocketAddr) -> bool {
    host_is_named(host, local, NAMES.get().map_or(&[], Vec::as_slice))
}

/// [`host_is_ours`] with `names` the names accepted besides `localhost` (taken only when `local` is off
/// loopback).
fn host_is_named(host: &str, local: SocketAddr, names: &[String]) -> bool {
    let Some((name, port)) = split_authority(host) else { return false };
    if port != local.port() {
        return false;
    }
    if name.eq_ignore_ascii_case("localhost") {
        return true;
    }
    let Ok(ip) = name.parse::<IpAddr>() else {
        let name = name.strip_suffix('.').unwrap_or(name);
        return !local.ip().to_canonical().is_loopback() && names.iter().any(|n| n.eq_ignore_ascii_case(name));
    };
    local.ip().is_unspecified() || ip == local.ip() || ip.is_loopback()
}

/// `name:port` or `[v6]:port` → (name, port). A `Host` without a port is refused: browsers always send it for a
/// non-default port, and we never listen on port 80.
fn split_authority(host: &str) -> Option<(&str, u16)> {
    let (name, port) = host.rsplit_once(':')?;
    let name = name.strip_prefix('[').and_then(|n| n.strip_suffix(']')).unwrap_or(name);
    Some((name, port.parse().ok()?))
}

/// Check a request's `Host` and `Origin` headers for the server listening on `local`.
pub(crate) fn check_request(headers: &HeaderMap, local: SocketAddr) -> Result<(), Refusal> {
    let host = headers.get(header::HOST).and_then(|h| h.to_str().ok()).unwrap_or("");
    if !host_is_ours(host, local) {
        return Err(Refusal::Host(host.to_string()));
    }
    if let Some(site) = headers.get(FETCH_SITE) {
        let site = site.to_str().unwrap_or("");
        if !matches!(site, "same-origin" | "none") {
            return Err(Refusal::FetchSite(site.to_string()));
        }
    }
    if let Some(origin) = headers.get(header::ORIGIN) {
        let origin = origin.to_str().unwrap_or("");
        if origin.strip_prefix("http://") != Some(host) {
            return Err(Refusal::Origin(origin.to_string()));
        }
    } else if let Some(referer) = headers.get(header::REFERER) {
        let referer = referer.to_str().unwrap_or("");
        if referer_authority(referer) != Some(host) {
            return Err(Refusal::Referer(referer.to_string()));
        }
    }
    Ok(())
}

/// The header in which browsers say where a request comes from relative to its target.
const FETCH_SITE: &str = "sec-fetch-site";

/// The authority of an `http://` URL (`http://host:port/path?query` → `host:port`); `None` for other schemes.
fn referer_authority(url: &str) -> Option<&str> {
    let rest = url.strip_prefix("http://")?;
    Some(rest.split(['/', '?', '#']).next().unwrap_or(rest))
}

/// A fresh random token: 128 bits from the standard library's randomly keyed hasher (seeded from the operating
/// system's random source once per process, then a counter and the clock).
pub(crate) fn new_token() -> String {
    use std::sync::atomic::{AtomicU64, Ordering};
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let word = || {
        let mut h = std::collections::hash_map::RandomState::new().build_hasher();
        h.write_u64(COUNTER.fetch_add(1, Ordering::Relaxed));
        h.write_u128(std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).unwrap_or_default().as_nanos());
        h.finish()
    };
    format!("{:016x}{:016x}", word(), word())
}

#[cfg(test)]
mod tests {
    use super::*;
    use axum::http::HeaderValue;

    fn headers(host: &str, origin: Option<&str>) -> HeaderMap {
        let mut h = HeaderMap::new();
        h.insert(header::HOST, HeaderValue::from_str(host).unwrap());
        if let Some(o) = origin {
            h.insert(header::ORIGIN, HeaderValue::from_str(o).unwrap());
        }
        h
    }

    #[test]
    fn loopback_server_accepts_only_its_own_authority() {
        let local: SocketAddr = "127.0.0.1:8040".parse().unwrap();
        for ok in ["127.0.0.1:8040", "localhost:8040", "LOCALHOST:8040", "[::1]:8040"] {
            assert!(host_is_ours(ok, local), "{ok}");
        }
        for bad in ["evil.example:8040", "127.0.0.1:8041", "127.0.0.1", "", "192.168.1.5:8040", "[::1]", "a:b:c"] {
            assert!(!host_is_ours(bad, local), "{bad}");
        }
    }

    #[test]
    fn wildcard_listener_accepts_ip_literals_but_never_names() {
        let local: SocketAddr = "0.0.0.0:9000".parse().unwrap();
        assert!(host_is_ours("192.168.1.5:9000", local));
        assert!(!host_is_ours("plotter.attacker.example:9000", local));
        let specific: SocketAddr = "10.1.2.3:9000".parse().unwrap();
        assert!(host_is_ours("10.1.2.3:9000", specific));
        assert!(!host_is_ours("10.1.2.4:9000", specific));
    }

    /// Off loopback the names the server is known by are taken (its host name, that name under .local, the
    /// --host-name ones; any case, a trailing dot), with the server's port only; any other name (a rebinding
    /// attacker's) is still refused, and on loopback no name but localhost is taken.
    #[test]
    fn off_loopback_the_servers_own_names_are_accepted_and_no_others() {
        let names = host_names(Some("studio-pc\n"), &["plotter.example.org".into(), "Plotter.LOCAL".into()]).unwrap();
        assert_eq!(names, ["studio-pc", "studio-pc.local", "plotter.example.org", "plotter.local"]);
        let any: SocketAddr = "0.0.0.0:8040".parse().unwrap();
        let lan: SocketAddr = "192.168.1.5:8040".parse().unwrap();
        for local in [any, lan] {
            for ok in ["studio-pc:8040", "studio-pc.local:8040", "PLOTTER.local:8040", "plotter.local.:8040"] {
                assert!(host_is_named(ok, local, &names), "{ok} on {local}");
            }
            for bad in ["plotter.local:9000", "rebind.attacker.example:8040", "studio-pc.attacker.example:8040"] {
                assert!(!host_is_named(bad, local, &names), "{bad} on {local}");
            }
        }
        let loopback: SocketAddr = "127.0.0.1:8040".parse().unwrap();
        assert!(!host_is_named("plotter.local:8040", loopback, &names));
        assert!(host_is_named("localhost:8040", loopback, &names));
        // Without names (no --allow-remote, nothing given): names refused as before.
        assert!(!host_is_named("plotter.local:8040", any, &[]));
        // A dotted system name has no .local twin; bad names are refused with the flag named.
        assert_eq!(host_names(Some("box.lan"), &[]).unwrap(), ["box.lan"]);
        assert!(host_names(None, &[]).unwrap().is_empty());
        for bad in ["", "192.168.1.5", "-x.local", "a..b", "pl otter", "x_y.local", "evil.com:80"] {
            let e = host_names(None, &[bad.to_string()]).unwrap_err().to_string();
            assert!(e.starts_with(&format!("--host-name {bad:?}: give a host name")), "{e}");
        }
    }

    #[test]
    fn origin_must_match_the_host() {
        let local: SocketAddr = "127.0.0.1:8040".parse().unwrap();
        assert_eq!(check_request(&headers("127.0.0.1:8040", None), local), Ok(()));
        assert_eq!(check_request(&headers("127.0.0.1:8040", Some("http://127.0.0.1:8040")), local), Ok(()));
        assert_eq!(
            check_request(&headers("127.0.0.1:8040", Some("http://evil.example")), local),
            Err(Refusal::Origin("http://evil.example".into()))
        );
        // Same host, other scheme or another loopback spelling: still not the page we served.
        assert!(check_request(&headers("127.0.0.1:8040", Some("https://127.0.0.1:8040")), local).is_err());
        assert!(check_request(&headers("127.0.0.1:8040", Some("http://localhost:8040")), local).is_err());
        assert!(check_request(&headers("127.0.0.1:8040", Some("null")), local).is_err());
        assert_eq!(
            check_request(&headers("rebind.example:8040", None), local),
            Err(Refusal::Host("rebind.example:8040".into()))
        );
    }

    #[test]
    fn without_origin_referer_and_fetch_site_must_say_same_origin() {
        let local: SocketAddr = "127.0.0.1:8040".parse().unwrap();
        let with = |name: &'static str, value: &str| {
            let mut h = headers("127.0.0.1:8040", None);
            h.insert(name, HeaderValue::from_str(value).unwrap());
            check_request(&h, local)
        };
        for ok in ["http://127.0.0.1:8040/", "http://127.0.0.1:8040", "http://127.0.0.1:8040/?x=1#y"] {
            assert_eq!(with("referer", ok), Ok(()), "{ok}");
        }
        for bad in [
            "http://evil.example/page",
            "http://127.0.0.1:8041/",
            "https://127.0.0.1:8040/",
            "http://127.0.0.1:8040@evil.example/",
            "http://localhost:8040/",
            "about:blank",
            "",
        ] {
            assert_eq!(with("referer", bad), Err(Refusal::Referer(bad.into())), "{bad}");
        }
        for ok in ["same-origin", "none"] {
            assert_eq!(with("sec-fetch-site", ok), Ok(()), "{ok}");
        }
        for bad in ["cross-site", "same-site", "CROSS-SITE", ""] {
            assert_eq!(with("sec-fetch-site", bad), Err(Refusal::FetchSite(bad.into())), "{bad}");
        }
        // Sec-Fetch-Site is checked even beside a matching Origin; a Referer is not looked at beside one (the
        // browser's Origin is the authority).
        let mut h = headers("127.0.0.1:8040", Some("http://127.0.0.1:8040"));
        h.insert("sec-fetch-site", HeaderValue::from_static("cross-site"));
        assert!(matches!(check_request(&h, local), Err(Refusal::FetchSite(_))));
        let mut h = headers("127.0.0.1:8040", Some("http://127.0.0.1:8040"));
        h.insert(header::REFERER, HeaderValue::from_static("http://evil.example/"));
        assert_eq!(check_request(&h, local), Ok(()));
        assert!(Refusal::FetchSite("cross-site".into()).to_string().contains("another site"));
    }

    #[test]
    fn tokens_are_distinct_and_long() {
        let (a, b) = (new_token(), new_token());
        assert_eq!(a.len(), 32);
        assert_ne!(a, b);
    }
}
