//! Ordering benchmark on real drawings: imports each SVG given (or listed in a file) the way `plotter stats` does on
//! the built-in XY plotter kit, then optimizes it with the options `plotter stats` uses by default (merge within half
//! the pen width, bridges below it, pen-up time from the profile, order from home), and prints per file the wall
//! and CPU time of the optimization and its pen-up figures.
//!
//! `cargo bench -p plotter-path --bench order -- FILE.svg ...` or `-- --list FILE` (one path a line, e.g. the list
//! `benches/vs_vpype.py --list FILE` writes); `--repeat R` runs each file R times and reports the median wall time
//! (the pen-up figures of the last run); `--work W[,W…]` sets the improvement's work budget in candidate moves per
//! path (default: as the CLI; 0 = none; several: one row per budget, the import shared); `--kicks K` kicks per path (default as the CLI, 2).

use std::time::Instant;

use plotter_path::MachineProfile;
use plotter_path::input::svg::{self, SvgOptions};
use plotter_path::optimize::{Objective, OptimizeOptions, TravelTimeModel, optimize};

/// CPU time of this process in seconds (`/proc/self/stat` user + system ticks, 100 Hz).
fn cpu_s() -> f64 {
    std::fs::read_to_string("/proc/self/stat")
        .ok()
        .and_then(|s| {
            let rest = s.rsplit_once(')')?.1;
            let f: Vec<&str> = rest.split_whitespace().collect();
            Some(f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?)
        })
        .map_or(f64::NAN, |ticks| ticks / 100.0)
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).filter(|a| a != "--bench").collect();
    let mut files = Vec::new();
    let (mut repeat, mut budget, mut kicks) = (1usize, vec![plotter_path::optimize::DEFAULT_WORK_PER_PATH], 2.0f64);
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--list" => {
                let list = std::fs::read_to_string(it.next().expect("--list FILE")).expect("readable list");
                files.extend(list.lines().map(str::trim).filter(|l| !l.is_empty()).map(String::from));
            }
            "--repeat" => repeat = it.next().and_then(|v| v.parse().ok()).expect("--repeat N"),
            "--work" => {
                let list = it.next().expect("--work W[,W…]");
                budget = list.split(',').map(|v| v.trim().parse().expect("--work W[,W…]: numbers")).collect();
            }
            "--kicks" => kicks = it.next().and_then(|v| v.parse().ok()).expect("--kicks K"),
            f => files.push(f.to_string()),
        }
    }
    let profile = MachineProfile::default_plotter();
    let width = profile.pen.width_mm;
    let base = OptimizeOptions {
        merge_tolerance_mm: width / 2.0,
        bridge_mm: width,
        start: Some(plotter_path::motion::plan::home_on_page(&profile).expect("kit profile has a home")),
        objective: Objective::Time,
        time_model: Some(TravelTimeModel::from_profile(&profile)),
        kicks_per_path: kicks,
        ..OptimizeOptions::default()
    };
    let svg_opts = SvgOptions { pen_width_mm: width, pens: profile.pens.clone(), ..SvgOptions::default() };
    println!(
        "| input | paths | import s | work/path | optimize wall s (median) | cpu s | pen-up mm | pen-up time s | kicks kept/tried | work done |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    let (mut tw, mut tmm, mut ts) = (0.0, 0.0, 0.0);
    for f in files {
        let t = Instant::now();
        let Ok(imported) = svg::load_svg(std::path::Path::new(&f), &svg_opts) else {
            println!("| {f} | import failed | | | | | | | | |");
            continue;
        };
        let import_s = t.elapsed().as_secs_f64();
        let d = imported.drawing;
        for &w in &budget {
            let opts = OptimizeOptions { work_per_path: (w > 0.0).then_some(w), ..base.clone() };
            let mut walls = Vec::with_capacity(repeat);
            let mut last = None;
            let mut cpu = 0.0;
            for _ in 0..repeat.max(1) {
                let mut out = d.clone();
                let (w, c) = (Instant::now(), cpu_s());
                let r = optimize(&mut out, &opts).expect("valid drawing");
                walls.push(w.elapsed().as_secs_f64());
                cpu = cpu_s() - c;
                last = Some(r);
            }
            walls.sort_by(f64::total_cmp);
            let wall = walls[walls.len() / 2];
            let Some(r) = last else { continue };
            tw += wall;
            tmm += r.pen_up_after_mm;
            ts += r.travel_time_after_s.unwrap_or(0.0);
            let name =
                std::path::Path::new(&f).file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
            println!(
                "| {name} | {} | {import_s:.3} | {w} | {wall:.3} | {cpu:.2} | {:.1} | {:.1} | {}/{}{} | {} |",
                d.path_count(),
                r.pen_up_after_mm,
                r.travel_time_after_s.unwrap_or(f64::NAN),
                r.improve.kicks_kept,
                r.improve.kicks_tried,
                if r.improve.budget_exhausted { " (budget)" } else { "" },
                r.improve.work
            );
        }
    }
    println!("| **total** | | | | {tw:.3} | | {tmm:.1} | {ts:.1} | | |");
}
