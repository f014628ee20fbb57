//! The studio from the outside, signed in: its page in Debian's headless Chromium (the DevTools client of
//! `browser.rs`) with three machines — our simulator, the GRBL emulator and the EBB emulator on pseudo-terminals,
//! in real time — signing in with the operator's token, queueing a drawing for each machine, showing all three
//! plotting at once and emergency-stopping one while the other two finish; and `plotter queue` against a studio
//! that asks for a token, with the operator's, a viewer's, a wrong one and none.
//!
//! The browser test needs `chromium` (or `PLOTTER_CHROMIUM=/path`); without it it says so and passes, except under
//! CI (`CI` set), where a missing browser is a failure.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use plotter_e2e::{Served, SimPty, plotter, sample, scratch};
use serde_json::json;

use crate::browser::{Cdp, ONE_BROWSER, chromium};

/// The operator's token of these tests' studios.
const OPERATOR: &str = "studio-operator-0123456789abcdef";
/// The viewers' token.
const VIEWER: &str = "studio-viewer-0123456789abcdef";

/// Three small drawings of a few seconds each at the machines' own pace.
const SQUARE: &str = r#"<svg xmlns="http://www.w3.org/2000/svg" width="60mm" height="60mm" viewBox="0 0 60 60">
  <rect x="10" y="10" width="40" height="40" fill="none" stroke="black"/>
</svg>"#;
const CIRCLE: &str = r#"<svg xmlns="http://www.w3.org/2000/svg" width="60mm" height="60mm" viewBox="0 0 60 60">
  <circle cx="30" cy="30" r="15" fill="none" stroke="black"/>
</svg>"#;
const ZIGZAG: &str = r#"<svg xmlns="http://www.w3.org/2000/svg" width="60mm" height="60mm" viewBox="0 0 60 60">
  <polyline points="5,10 15,40 25,10 35,40 45,10 55,40" fill="none" stroke="black"/>
</svg>"#;

/// A 2 mm line: a copy takes a moment.
const DASH: &str = r#"<svg xmlns="http://www.w3.org/2000/svg" width="60mm" height="60mm" viewBox="0 0 60 60">
  <path d="M 10 10 L 12 10" fill="none" stroke="black"/>
</svg>"#;

/// A token file readable by its owner only.
fn token_file(dir: &Path, name: &str, token: &str) -> PathBuf {
    use std::os::unix::fs::PermissionsExt as _;
    let path = dir.join(name);
    std::fs::write(&path, format!("{token}\n")).expect("write the token file");
    std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o600)).expect("chmod 600");
    path
}

fn utf8(p: &Path) -> &str {
    p.to_str().expect("a UTF-8 path")
}

/// What the page shows of `machine`'s card and the job rows, for messages.
const SEEN: &str = "[...document.querySelectorAll('.machine')].map((c) => c.dataset.name + ': ' + \
                    c.querySelector('.state').textContent + ' ' + c.querySelector('.percent').textContent).join(', ') \
                    + ' | jobs: ' + [...document.querySelectorAll('#jobs tr')].map((r) => r.children[0].textContent \
                    + ' ' + r.children[3].textContent).join(', ')";

#[test]
fn the_page_signs_in_shows_three_machines_plotting_and_stops_one_while_two_finish() {
    let _one = ONE_BROWSER.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let Some(browser) = chromium() else { return };
    let t0 = Instant::now();
    let dir = scratch("studio-browser");
    let token = token_file(&dir, "operator-token", OPERATOR);
    let profile = sample("axidraw-v3.toml");
    let sims = [SimPty::start(&dir, &[]), SimPty::start(&dir, &["--grbl"]), SimPty::start(&dir, &["--ebb"])];
    let machines = [
        format!("ours={},firmware=ours", sims[0].port),
        format!("grbl={},firmware=grbl", sims[1].port),
        format!("ebb={},firmware=ebb,profile={}", sims[2].port, utf8(&profile)),
    ];
    let state = dir.join("studio");
    let mut args = vec!["--listen", "127.0.0.1:0", "--state", utf8(&state), "--token-file", utf8(&token)];
    for m in &machines {
        args.extend(["--machine", m.as_str()]);
    }
    let served = Served::start(&args);
    let (_chromium, mut cdp) = Cdp::launch(&browser, &dir.join("profile"));
    cdp.shown = vec!["#signin-message", "#message", "#status"];

    // Not signed in: the sign-in form, and nothing of the studio.
    cdp.call("Page.navigate", json!({ "url": served.url }));
    // Loaded, its script included (a form submitted before its handler is there would just reload the page).
    cdp.wait_for(
        "the sign-in form",
        "!!document.getElementById('signin') && document.readyState === 'complete'",
        Duration::from_secs(10),
    );
    assert_eq!(cdp.eval("document.querySelectorAll('#machines, .machine, #jobs').length"), json!(0));
    let text = cdp.eval("document.body.innerText").as_str().unwrap_or("").to_string();
    assert!(!text.contains("grbl") && !text.contains("ebb"), "{text}");
    let sign_in = |cdp: &mut Cdp, token: &str| {
        cdp.eval(&format!(
            "document.getElementById('token').value = '{token}'; document.getElementById('signin').requestSubmit()"
        ));
    };
    sign_in(&mut cdp, "a-wrong-token-0123456789");
    cdp.wait_for(
        "the wrong token's refusal",
        "document.getElementById('signin-message').textContent.includes('wrong token')",
        Duration::from_secs(10),
    );
    sign_in(&mut cdp, OPERATOR);
    // The page reloads itself once signed in: look again after that, not while its document is being replaced.
    std::thread::sleep(Duration::from_secs(1));
    cdp.wait_for(
        "the studio, signed in",
        "document.getElementById('who').textContent === 'signed in: operator' && \
         document.querySelectorAll('.machine').length === 3 && \
         [...document.querySelectorAll('.machine .state')].every((s) => s.textContent === 'idle')",
        Duration::from_secs(20),
    );
    assert_eq!(
        cdp.eval("[...document.querySelectorAll('.machine')].map((c) => c.dataset.name)"),
        json!(["ours", "grbl", "ebb"])
    );

    // A drawing queued for each machine through the page's form.
    let root = cdp.call("DOM.getDocument", json!({}))["root"]["nodeId"].clone();
    let input = cdp.call("DOM.querySelector", json!({ "nodeId": root, "selector": "#file" }))["nodeId"].clone();
    for (k, (machine, (file, svg))) in ["ours", "grbl", "ebb"]
        .iter()
        .zip([("square.svg", SQUARE), ("circle.svg", CIRCLE), ("zigzag.svg", ZIGZAG)])
        .enumerate()
    {
        let path = dir.join(file);
        std::fs::write(&path, svg).expect("write the drawing");
        cdp.call("DOM.setFileInputFiles", json!({ "nodeId": input, "files": [utf8(&path)] }));
        cdp.eval(&format!(
            "document.getElementById('machine').value = '{machine}'; \
             document.getElementById('flags').value = '--paper a6 --margin 15'; document.getElementById('add').click()"
        ));
        cdp.wait_for(
            "the job queued",
            &format!("document.getElementById('message').textContent === 'queued as job {}'", k + 1),
            Duration::from_secs(10),
        );
    }

    // All three plotting at once, as the page shows them.
    cdp.wait_for(
        "all three machines plotting",
        "[...document.querySelectorAll('.machine')].every((c) => c.querySelector('.state').textContent === 'plotting' \
         && parseFloat(c.querySelector('.percent').textContent) > 0)",
        Duration::from_secs(20),
    );
    let seen = cdp.eval(SEEN);
    eprintln!("all plotting: {seen}");
    // The emergency stop of one machine, clicked on its card.
    cdp.eval("document.querySelector('.machine[data-name=\"ours\"] button.estop').click()");
    cdp.wait_for(
        "the stopped job, cancelled, and its machine idle",
        "document.querySelector('.machine[data-name=\"ours\"] .state').textContent === 'idle' && \
         [...document.querySelectorAll('#jobs tr')].some((r) => r.children[0].textContent === '#1' && \
         r.children[3].textContent === 'cancelled')",
        Duration::from_secs(10),
    );
    let at_stop = cdp.eval(SEEN);
    // While the other two finish, the stopped machine takes a job of two copies of a 2 mm line: it parks for the
    // second copy's paper, its card says so with a "Done: resume" button, and pressing it plots the second copy.
    let parked_at = Instant::now();
    let path = dir.join("dash.svg");
    std::fs::write(&path, DASH).expect("write the drawing");
    cdp.call("DOM.setFileInputFiles", json!({ "nodeId": input, "files": [utf8(&path)] }));
    cdp.eval(
        "document.getElementById('machine').value = 'ours'; \
         document.getElementById('flags').value = '--paper a6 --margin 15 --copies 2'; \
         document.getElementById('add').click()",
    );
    let card = "document.querySelector('.machine[data-name=\"ours\"]')";
    cdp.wait_for(
        "the parked machine's prompt and its button on its card",
        &format!(
            "{card}.querySelector('.prompt p')?.textContent === 'put in fresh paper for copy 2 of 2' && \
             {card}.querySelector('.prompt button')?.textContent === 'Done: resume' && \
             {card}.querySelector('.state').textContent === 'paused' && \
             {card}.querySelector('.copy').textContent === 'copy 2 of 2'"
        ),
        Duration::from_secs(30),
    );
    cdp.eval(&format!("{card}.querySelector('.prompt button').click()"));
    cdp.wait_for(
        "the two-copy job done once resumed, its prompt gone",
        &format!(
            "!{card}.querySelector('.prompt') && [...document.querySelectorAll('#jobs tr')].some((r) => \
             r.children[0].textContent === '#4' && r.children[3].textContent === 'done')"
        ),
        Duration::from_secs(30),
    );
    eprintln!("parked, resumed and done: {:.1} s", parked_at.elapsed().as_secs_f64());
    // The other two finish.
    cdp.wait_for(
        "the other two jobs done",
        "['#2', '#3'].every((id) => [...document.querySelectorAll('#jobs tr')].some((r) => \
         r.children[0].textContent === id && r.children[3].textContent === 'done'))",
        Duration::from_secs(30),
    );
    let end = cdp.eval(SEEN);
    eprintln!("at the stop: {at_stop}\nat the end: {end}");
    assert_eq!(
        cdp.eval("[...document.querySelectorAll('.machine .state')].map((s) => s.textContent)"),
        json!(["idle", "idle", "idle"])
    );
    // Only the stopped machine's plot was cut short: its emulator moved less than a whole square's outline.
    drop(served);
    let traces: Vec<_> = sims.into_iter().map(SimPty::stop).collect();
    assert!(traces.iter().all(|t| !t.positions.is_empty()), "every machine moved");
    eprintln!("studio page test: {:.1} s", t0.elapsed().as_secs_f64());
    let _ = std::fs::remove_dir_all(dir);
}

/// Runs `plotter queue …` and returns (success, stdout, stderr).
fn queue(dir: &Path, args: &[&str]) -> (bool, String, String) {
    let out = plotter(dir, &[&["queue"], args].concat());
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn plotter_queue_signs_in_with_the_operators_token_and_says_what_is_missing() {
    let dir = scratch("studio-queue-token");
    let operator = token_file(&dir, "operator-token", OPERATOR);
    let viewer = token_file(&dir, "viewer-token", VIEWER);
    let state = dir.join("studio");
    let served = Served::start(&[
        "--listen",
        "127.0.0.1:0",
        "--state",
        utf8(&state),
        "--machine",
        "a=sim",
        "--sim-speed",
        "200",
        "--token-file",
        utf8(&operator),
        "--viewer-token-file",
        utf8(&viewer),
    ]);
    let server = served.url.as_str();
    std::fs::write(dir.join("line.svg"), ZIGZAG).expect("write the drawing");
    // No token: refused, and told what to pass.
    let (ok, out, err) = queue(&dir, &["list", "--server", server]);
    assert!(!ok && out.is_empty(), "{out}");
    assert!(err.contains("refused") && err.contains("asks for a token: pass --token-file FILE"), "{err}");
    let (ok, _, err) = queue(&dir, &["add", "line.svg", "--server", server, "--paper", "a6"]);
    assert!(!ok && err.contains("asks for a token"), "{err}");
    // A wrong token: refused as such.
    let (ok, _, err) = queue(&dir, &["add", "line.svg", "--server", server, "--token", "not-the-token-0123456789"]);
    assert!(!ok && err.contains("not one it accepts") && err.contains("wrong token"), "{err}");
    // A viewer's token lists but does not queue.
    let (ok, out, err) = queue(&dir, &["add", "line.svg", "--server", server, "--token-file", utf8(&viewer)]);
    assert!(!ok && err.contains("403") && err.contains("operator's token"), "{out}{err}");
    let (ok, out, err) = queue(&dir, &["list", "--server", server, "--token-file", utf8(&viewer)]);
    assert!(ok && out.trim() == "the queue is empty", "{out}{err}");
    // The operator's token (from its file, or typed): queued, listed, waited for.
    let (ok, out, err) =
        queue(&dir, &["add", "line.svg", "--server", server, "--token-file", utf8(&operator), "--paper", "a6"]);
    assert!(ok && out.trim() == "1", "{out}{err}");
    let (ok, out, err) = queue(&dir, &["list", "--json", "--server", server, "--token", OPERATOR]);
    assert!(ok, "{err}");
    let jobs: serde_json::Value = serde_json::from_str(&out).expect("JSON");
    assert_eq!((&jobs[0]["id"], &jobs[0]["drawing"]), (&json!(1), &json!("line.svg")), "{jobs}");
    let (ok, out, err) =
        queue(&dir, &["wait", "1", "--server", server, "--token-file", utf8(&viewer), "--timeout", "60"]);
    assert!(ok && out.contains("job 1: done"), "{out}{err}");
    drop(served);
    let _ = std::fs::remove_dir_all(dir);
}
