//! The studio drives three machines at once: one `plotter serve` with our simulator, the GRBL emulator and the EBB
//! emulator on pseudo-terminals (each paced to the wall clock), each given a different drawing with
//! `plotter queue add`. Each machine must execute exactly what a single `plotter plot` of the same drawing with the
//! same flags executes on a fresh emulator (the same step events; the motion time within 0.1 %), and the three
//! must plot side by side: the wall time close to the longest job's, not their sum.

use std::path::Path;
use std::time::Instant;

use plotter_e2e::{Served, SimPty, Trace, plotter, sample, scratch};

/// Three small drawings, a few seconds each.
const SQUARE: &str = r#"<svg xmlns="http://www.w3.org/2000/svg" width="60mm" height="60mm" viewBox="0 0 60 60">
  <rect x="10" y="10" width="40" height="40" fill="none" stroke="black"/>
  <path d="M 10 10 L 50 50 M 50 10 L 10 50" fill="none" stroke="black"/>
</svg>"#;
const CIRCLES: &str = r#"<svg xmlns="http://www.w3.org/2000/svg" width="60mm" height="60mm" viewBox="0 0 60 60">
  <circle cx="30" cy="30" r="20" fill="none" stroke="black"/>
  <circle cx="30" cy="30" r="10" fill="none" stroke="black"/>
</svg>"#;
const ZIGZAG: &str = r#"<svg xmlns="http://www.w3.org/2000/svg" width="60mm" height="60mm" viewBox="0 0 60 60">
  <polyline points="5,10 15,40 25,10 35,40 45,10 55,40" fill="none" stroke="black"/>
  <rect x="5" y="45" width="50" height="10" fill="none" stroke="black"/>
</svg>"#;

struct Machine {
    name: &'static str,
    sim_flags: &'static [&'static str],
    firmware: &'static str,
    profile: Option<String>,
    file: &'static str,
    svg: &'static str,
}

fn machines() -> Vec<Machine> {
    let axidraw = sample("axidraw-v3.toml").to_str().expect("utf-8 path").to_string();
    vec![
        Machine { name: "ours", sim_flags: &[], firmware: "ours", profile: None, file: "square.svg", svg: SQUARE },
        Machine {
            name: "grbl",
            sim_flags: &["--grbl"],
            firmware: "grbl",
            profile: None,
            file: "circles.svg",
            svg: CIRCLES,
        },
        Machine {
            name: "ebb",
            sim_flags: &["--ebb"],
            firmware: "ebb",
            profile: Some(axidraw),
            file: "zigzag.svg",
            svg: ZIGZAG,
        },
    ]
}

/// The plot flags every job is queued (and plotted alone) with.
const FLAGS: [&str; 4] = ["--paper", "a6", "--margin", "15"];

fn run_ok(dir: &Path, args: &[&str]) -> String {
    let out = plotter(dir, args);
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(out.status.success(), "plotter {args:?} failed:\n{}\n{stdout}", String::from_utf8_lossy(&out.stderr));
    stdout
}

/// The executed motion time of a trace, s.
fn motion_s(t: &Trace) -> f64 {
    // Microsecond ticks of a short plot: exact in f64.
    #[allow(clippy::cast_precision_loss)]
    let s = t.busy_ticks as f64 / 1e6;
    s
}

#[test]
fn one_server_plots_on_three_machines_at_once_as_three_single_plots_would() {
    let dir = scratch("studio-three");
    let ms = machines();
    for m in &ms {
        std::fs::write(dir.join(m.file), m.svg).expect("write drawing");
    }
    // The studio: three emulators at the machine's own pace, one server.
    let sims: Vec<SimPty> = ms.iter().map(|m| SimPty::start(&dir, m.sim_flags)).collect();
    let state = dir.join("studio");
    let machine_flags: Vec<String> = ms
        .iter()
        .zip(&sims)
        .map(|(m, s)| {
            let mut f = format!("{}={},firmware={}", m.name, s.port, m.firmware);
            if let Some(p) = &m.profile {
                f.push_str(&format!(",profile={p}"));
            }
            f
        })
        .collect();
    let mut args = vec!["--listen", "127.0.0.1:0", "--state", state.to_str().expect("utf-8")];
    for f in &machine_flags {
        args.extend(["--machine", f.as_str()]);
    }
    let served = Served::start(&args);
    let server = served.url.clone();
    let start = Instant::now();
    let ids: Vec<String> = ms
        .iter()
        .map(|m| {
            let mut a = vec!["queue", "add", m.file, "--machine", m.name, "--server", &server];
            a.extend(FLAGS);
            run_ok(&dir, &a).trim().to_string()
        })
        .collect();
    for id in &ids {
        let out = run_ok(&dir, &["queue", "wait", id, "--server", &server, "--timeout", "120"]);
        assert!(out.contains(&format!("job {id}: done")), "{out}");
    }
    let wall = start.elapsed().as_secs_f64();
    let listed = run_ok(&dir, &["queue", "list", "--json", "--server", &server]);
    let jobs: serde_json::Value = serde_json::from_str(&listed).expect("JSON list");
    let plot_s: Vec<f64> = ids
        .iter()
        .map(|id| {
            let job = jobs
                .as_array()
                .unwrap()
                .iter()
                .find(|j| j["id"].as_i64().map(|n| n.to_string()).as_deref() == Some(id.as_str()))
                .expect("the job listed");
            assert_eq!(job["state"], "done", "{job}");
            job["history"][0]["plot_s"].as_f64().expect("a plot time")
        })
        .collect();
    drop(served);
    let traces: Vec<Trace> = sims.into_iter().map(SimPty::stop).collect();

    // Each machine alone, with `plotter plot` on a fresh emulator (as fast as it goes: the same steps).
    for ((m, studio_trace), id) in ms.iter().zip(&traces).zip(&ids) {
        let sim = SimPty::start(&dir, &[m.sim_flags, &["--fast"][..]].concat());
        let mut a = vec!["plot", m.file, "--port", &sim.port, "--firmware", m.firmware];
        if let Some(p) = &m.profile {
            a.extend(["--profile", p.as_str()]);
        }
        a.extend(FLAGS);
        run_ok(&dir, &a);
        let alone = sim.stop();
        assert!(alone.positions.len() > 100, "{}: the drawing moved the machine", m.name);
        assert_eq!(
            studio_trace.positions.len(),
            alone.positions.len(),
            "{} (job {id}): step events in the studio vs alone",
            m.name
        );
        assert!(studio_trace.positions == alone.positions, "{}: the studio's steps differ from the plot's", m.name);
        let (s, a) = (motion_s(studio_trace), motion_s(&alone));
        assert!((s - a).abs() <= a * 1e-3, "{}: motion time {s:.4} s in the studio, {a:.4} s alone", m.name);
        eprintln!("{}: {} step events, motion {s:.3} s (alone {a:.3} s)", m.name, alone.positions.len());
    }
    let longest = plot_s.iter().copied().fold(0.0, f64::max);
    let sum: f64 = plot_s.iter().sum();
    eprintln!("wall {wall:.2} s for jobs of {plot_s:.2?} s (longest {longest:.2} s, sum {sum:.2} s)");
    assert!(wall < longest + 2.5, "wall {wall:.2} s, longest job {longest:.2} s");
    assert!(wall < 0.75 * sum, "wall {wall:.2} s against a sum of {sum:.2} s: the machines did not plot together");
}
