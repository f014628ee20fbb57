//! Who drives the machine: one page at a time holds control, by a random token.
//!
//! A page claims control and gets a token ([`claim`]). It then opens its event stream with that token, and the
//! stream holds control ([`attach`] gives a [`Lease`]): when the page's last stream closes (the tab is closed or
//! reloaded), control is given up, and another page may claim it. A claim whose page never opens a stream — a
//! crashed page, a script that only posts — would otherwise hold control until the server restarts, so a claim
//! lapses after a grace period ([`super::state::Limits::claim_grace`]) unless a stream is open by then.
//! A page may also give control up itself ([`release`]).

use std::sync::Arc;

use super::safety;
use super::state::{Controller, Shared};

/// Why a claim is refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Taken;

impl std::fmt::Display for Taken {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("another page controls the plotter; this one is read-only")
    }
}

/// Take control, or confirm it for the page that sends the current token (`held`): the token. A fresh claim
/// lapses after the configured grace unless its page opens its event stream first. Needs a tokio runtime (the
/// lapse is a timer task).
pub(crate) fn claim(shared: &Arc<Shared>, held: Option<&str>) -> Result<String, Taken> {
    let token = {
        let mut i = shared.lock();
        match &i.controller {
            Some(c) if Some(c.token.as_str()) == held => return Ok(c.token.clone()),
            Some(_) => return Err(Taken),
            None => {
                let token = safety::new_token();
                i.controller = Some(Controller { token: token.clone(), streams: 0 });
                token
            }
        }
    };
    shared.publish();
    let lapse = Arc::clone(shared);
    let t = token.clone();
    tokio::spawn(async move {
        tokio::time::sleep(lapse.config.limits.claim_grace).await;
        let lapsed = give_up_if(&lapse, |c| c.token == t && c.streams == 0);
        if lapsed {
            lapse.hub.log("info", "control lapsed: the page that took it never opened its event stream");
        }
    });
    Ok(token)
}

/// Give control up, whoever holds it (the guard has checked the caller's token).
pub(crate) fn release(shared: &Shared) {
    give_up_if(shared, |_| true);
}

/// Clear the controller if `f` says so, and tell every page; whether it was cleared.
fn give_up_if(shared: &Shared, f: impl FnOnce(&Controller) -> bool) -> bool {
    let cleared = {
        let mut i = shared.lock();
        let clear = i.controller.as_ref().is_some_and(f);
        if clear {
            i.controller = None;
        }
        clear
    };
    if cleared {
        shared.publish();
    }
    cleared
}

/// An event stream opened with the controller's token holds control while it lives (`None` for any other token).
pub(crate) fn attach(shared: &Arc<Shared>, token: &str) -> Option<Lease> {
    let mut i = shared.lock();
    let c = i.controller.as_mut().filter(|c| c.token == token)?;
    c.streams += 1;
    Some(Lease { shared: Arc::clone(shared), token: token.to_string() })
}

/// Holds control for an open event stream; control is given up when the controller's last stream closes.
pub(crate) struct Lease {
    shared: Arc<Shared>,
    token: String,
}

impl Drop for Lease {
    fn drop(&mut self) {
        let last = {
            let mut i = self.shared.lock();
            match i.controller.as_mut().filter(|c| c.token == self.token) {
                Some(c) => {
                    c.streams = c.streams.saturating_sub(1);
                    c.streams == 0
                }
                None => false,
            }
        };
        if last {
            give_up_if(&self.shared, |c| c.token == self.token && c.streams == 0);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::serve::state::{Config, Limits};
    use std::time::Duration;

    fn shared(claim_grace: Duration) -> Arc<Shared> {
        let (tx, _rx) = std::sync::mpsc::channel();
        let config = Config {
            local: "127.0.0.1:8040".parse().unwrap(),
            max_upload: 1000,
            sim_speed: 1.0,
            extra_ports: Vec::new(),
            profiles: Vec::new(),
            limits: Limits { claim_grace, ..Limits::default() },
            journals: None,
        };
        Arc::new(Shared::new(config, tx))
    }

    fn holder(s: &Shared) -> Option<Controller> {
        s.lock().controller.clone()
    }

    #[tokio::test(start_paused = true)]
    async fn a_claim_without_a_stream_lapses_after_the_grace() {
        let s = shared(Duration::from_secs(15));
        let a = claim(&s, None).unwrap();
        assert_eq!(claim(&s, None), Err(Taken));
        assert_eq!(claim(&s, Some(&a)), Ok(a.clone()), "the holder's own claim is confirmed");
        tokio::time::sleep(Duration::from_millis(14_900)).await;
        assert_eq!(holder(&s).map(|c| c.token), Some(a.clone()), "still held just before the grace ends");
        tokio::time::sleep(Duration::from_millis(200)).await;
        assert_eq!(holder(&s), None);
        let b = claim(&s, Some(&a)).unwrap();
        assert_ne!(a, b, "the lapsed token is not renewed");
    }

    #[tokio::test(start_paused = true)]
    async fn a_stream_holds_control_until_the_last_one_closes() {
        let s = shared(Duration::from_secs(1));
        let a = claim(&s, None).unwrap();
        assert!(attach(&s, "someone else's token").is_none());
        let first = attach(&s, &a).unwrap();
        let second = attach(&s, &a).unwrap();
        assert_eq!(holder(&s).map(|c| c.streams), Some(2));
        tokio::time::sleep(Duration::from_secs(10)).await;
        drop(first);
        assert_eq!(holder(&s).map(|c| (c.token, c.streams)), Some((a, 1)), "no lapse while a stream is open");
        drop(second);
        assert_eq!(holder(&s), None);
    }

    #[tokio::test(start_paused = true)]
    async fn an_old_lapse_timer_never_releases_a_newer_claim() {
        let s = shared(Duration::from_secs(10));
        let a = claim(&s, None).unwrap();
        tokio::time::sleep(Duration::from_secs(6)).await;
        release(&s);
        let b = claim(&s, None).unwrap();
        // a's timer fires at 10 s, b's at 16 s.
        tokio::time::sleep(Duration::from_secs(6)).await;
        assert_ne!(a, b);
        assert_eq!(holder(&s).map(|c| c.token), Some(b));
        tokio::time::sleep(Duration::from_secs(5)).await;
        assert_eq!(holder(&s), None);
    }
}
