//! Journals live in the state directory (`PLOTTER_STATE_DIR` here), never beside the drawing: a plot on a port
//! (`plotter sim --pty`) leaves nothing next to its input, `plotter resume --list` shows an interrupted plot with
//! its drawing, machine and progress, `plotter resume NUMBER --port` finishes it, and resuming the finished plot
//! says so with exit status 0.

use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use nix::sys::signal::{Signal, kill};
use nix::unistd::Pid;
use plotter_e2e::{SimPty, plotter_bin, sample, scratch};

/// `plotter` with `args` in `dir`, its state directory `state`, stdin empty.
fn run(dir: &Path, state: &Path, args: &[&str]) -> Output {
    Command::new(plotter_bin())
        .args(args)
        .current_dir(dir)
        .env("PLOTTER_STATE_DIR", state)
        .stdin(Stdio::null())
        .output()
        .expect("plotter runs")
}

fn text(o: &Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr))
}

/// The files in `dir`, sorted.
fn files(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .map(|r| r.filter_map(Result::ok).map(|e| e.file_name().to_string_lossy().into_owned()).collect())
        .unwrap_or_default();
    v.sort();
    v
}

#[test]
fn a_finished_plot_leaves_nothing_beside_its_input() {
    let dir = scratch("journal-dir-done");
    let drawings = dir.join("drawings");
    std::fs::create_dir_all(&drawings).unwrap();
    std::fs::copy(sample("duck.svg"), drawings.join("duck.svg")).unwrap();
    let state = dir.join("state");
    let sim = SimPty::start(&dir, &["--fast"]);
    let out = run(&drawings, &state, &["plot", "duck.svg", "--port", &sim.port]);
    assert!(out.status.success(), "{}", text(&out));
    assert_eq!(files(&drawings), ["duck.svg"]);
    // The journal is in the state directory, named by the drawing and the machine, and says the plot finished.
    let journals = files(&state.join("journals"));
    assert_eq!(journals.len(), 1, "{journals:?}");
    let name = &journals[0];
    assert!(name.starts_with("duck-xy-plotter-kit-a3-frame-") && name.ends_with(".journal"), "{journals:?}");
    let journal = state.join("journals").join(name);
    assert!(std::fs::read_to_string(&journal).unwrap().lines().any(|l| l == "complete"));
    // Nothing to resume; resuming the finished plot says so and succeeds.
    let list = run(&drawings, &state, &["resume", "--list"]);
    assert!(list.status.success() && text(&list).contains("no interrupted plots to resume"), "{}", text(&list));
    let again = run(&drawings, &state, &["resume", journal.to_str().unwrap(), "--port", &sim.port]);
    assert_eq!(again.status.code(), Some(0), "{}", text(&again));
    assert!(text(&again).contains("that plot already finished; nothing to resume"), "{}", text(&again));
    let old_way = run(&drawings, &state, &["plot", "--resume", journal.to_str().unwrap(), "--port", &sim.port]);
    assert_eq!(old_way.status.code(), Some(0), "{}", text(&old_way));
}

#[test]
fn an_interrupted_plot_is_listed_and_resumed_by_number() {
    let dir = scratch("journal-dir-cut");
    std::fs::copy(sample("duck.svg"), dir.join("duck.svg")).unwrap();
    let state = dir.join("state");
    // Paced at four times real time, the 13 s duck (3.3 s here) is still plotting when SIGTERM comes.
    let sim = SimPty::start(&dir, &["--pace", "4"]);
    let child = Command::new(plotter_bin())
        .args(["plot", "duck.svg", "--port", &sim.port])
        .current_dir(&dir)
        .env("PLOTTER_STATE_DIR", &state)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("plotter runs");
    // Wait for the plot to be under way (the journal has 20 blocks executed), then stop it.
    let start = Instant::now();
    loop {
        let executed = |t: String| {
            let last = t.lines().rfind(|l| l.starts_with("progress ")).map(str::to_string);
            last.and_then(|l| l.split(' ').nth(2).and_then(|e| e.parse::<usize>().ok())).unwrap_or(0)
        };
        let progressed = files(&state.join("journals"))
            .iter()
            .any(|j| std::fs::read_to_string(state.join("journals").join(j)).is_ok_and(|t| executed(t) >= 20));
        if progressed {
            break;
        }
        assert!(start.elapsed() < Duration::from_secs(15), "the plot did not start");
        std::thread::sleep(Duration::from_millis(50));
    }
    kill(Pid::from_raw(i32::try_from(child.id()).unwrap()), Signal::SIGTERM).unwrap();
    let out = child.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(5), "{}", text(&out));
    assert_eq!(files(&dir).iter().filter(|f| f.ends_with(".journal")).count(), 0, "{:?}", files(&dir));
    let list = run(&dir, &state, &["resume", "--list"]);
    let shown = text(&list);
    assert!(list.status.success(), "{shown}");
    let duck = std::path::absolute(dir.join("duck.svg")).unwrap();
    let first = shown.lines().nth(1).unwrap_or_default().to_string();
    assert!(first.starts_with(&format!("  1  {} on XY plotter kit (A3 frame)", duck.display())), "{shown}");
    assert!(first.ends_with("% plotted, just now") && !first.contains(": 100%"), "{shown}");
    let resumed = run(&dir, &state, &["resume", "1", "--port", &sim.port, "--trust-position"]);
    assert!(resumed.status.success(), "{}", text(&resumed));
    let list = run(&dir, &state, &["resume", "--list"]);
    assert!(text(&list).contains("no interrupted plots to resume"), "{}", text(&list));
}

/// A journal the web app wrote (its source names the front end) is listed, but `plotter resume` sends the user back
/// to the page instead of failing on "an unreadable source line".
#[test]
fn a_web_plot_is_resumed_from_the_page() {
    let dir = scratch("journal-dir-web");
    let state = dir.join("state");
    let journals = state.join("journals");
    std::fs::create_dir_all(&journals).unwrap();
    let path = journals.join("duck-web.journal");
    let source = r#"{"front_end":"plotter serve","drawing":"duck.svg","machine":"XY plotter kit (A3 frame)","start":[0,0,1600,0]}"#;
    let mut j = plotter_host::link::journal::Journal::create(&path, source, 7, 100).unwrap();
    j.record(10, 5, 11).unwrap();
    drop(j);
    let out = run(&dir, &state, &["resume", path.to_str().unwrap(), "--port", "/dev/null"]);
    assert_eq!(out.status.code(), Some(1), "{}", text(&out));
    assert!(text(&out).contains("that plot was started by plotter serve; resume it there"), "{}", text(&out));
}
