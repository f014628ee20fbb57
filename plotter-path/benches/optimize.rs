//! Path-optimization benchmark: prints tables of time and pen-up travel for greedy only, greedy + improvement,
//! and the lower bound, on random segment sets of growing size and on the realistic synthetic drawings
//! (`plotter_path::optimize::synth`). Run with `cargo bench -p plotter-path --bench optimize`; pass `quick` to skip
//! the one-million case (`cargo bench -p plotter-path --bench optimize -- quick`).

use std::time::Instant;

use plotter_path::Drawing;
use plotter_path::input::svg::{self, SvgOptions};
use plotter_path::optimize::{OptimizeOptions, SeamMode, optimize, synth, travel_lower_bound};

/// CPU time of this thread in seconds (Linux `schedstat`), so figures stay meaningful on a loaded machine.
fn cpu_s() -> f64 {
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()
        .and_then(|s| s.split_whitespace().next().and_then(|v| v.parse::<u64>().ok()))
        .map_or(f64::NAN, |ns| {
            #[allow(clippy::cast_precision_loss, reason = "nanoseconds of a benchmark run")]
            let s = ns as f64 / 1e9;
            s
        })
}

/// Wall and CPU seconds of `f`.
fn timed<T>(f: impl FnOnce() -> T) -> (T, f64, f64) {
    let (w, c) = (Instant::now(), cpu_s());
    let out = f();
    (out, w.elapsed().as_secs_f64(), cpu_s() - c)
}

struct Row {
    greedy_cpu: f64,
    greedy_mm: f64,
    default_wall: f64,
    default_cpu: f64,
    default_mm: f64,
    converge_cpu: f64,
    converge_mm: f64,
    bound_cpu: f64,
    bound_mm: f64,
}

fn run(d: &Drawing, converge: bool) -> Row {
    let greedy_opts = OptimizeOptions { improve: false, lower_bound: false, ..OptimizeOptions::default() };
    let mut g = d.clone();
    let (rg, _, greedy_cpu) = timed(|| optimize(&mut g, &greedy_opts).expect("valid input"));

    let default_opts = OptimizeOptions { lower_bound: false, ..OptimizeOptions::default() };
    let mut i = d.clone();
    let (ri, default_wall, default_cpu) = timed(|| optimize(&mut i, &default_opts).expect("valid input"));

    // Local search alone, run to convergence without a budget: the n log n growth figure.
    let (converge_cpu, converge_mm) = if converge {
        let opts = OptimizeOptions { lower_bound: false, work_per_path: None, kicks_per_path: 0.0, ..default_opts };
        let mut c = d.clone();
        let (rc, _, cpu) = timed(|| optimize(&mut c, &opts).expect("valid input"));
        (cpu, rc.pen_up_after_mm)
    } else {
        (f64::NAN, f64::NAN)
    };

    // The bound of the paths as the optimizer saw them (after merging).
    let ((bound_mm, _), _, bound_cpu) = timed(|| travel_lower_bound(&g, SeamMode::Any, None, None));
    Row {
        greedy_cpu,
        greedy_mm: rg.pen_up_after_mm,
        default_wall,
        default_cpu,
        default_mm: ri.pen_up_after_mm,
        converge_cpu,
        converge_mm,
        bound_cpu,
        bound_mm,
    }
}

fn main() {
    let quick = std::env::args().any(|a| a == "quick");
    println!("## Random segment sets (400 x 280 mm page), one thread");
    println!("greedy = merge + greedy order; default = greedy + 2-opt/Or-opt + kicks within the default 1.5 s wall");
    println!("budget; converged = greedy + local search to its optimum (no kicks, no budget). cpu = this thread's");
    println!("CPU time (the machine may be shared); per n·log2 n = converged cpu / (n log2 n), relative to 10k.\n");
    println!(
        "| n | greedy cpu s | greedy mm | default wall s | default cpu s | default mm | default/greedy | converged cpu s | converged mm | converged/greedy | per n·log2 n | bound cpu s | bound mm | gap default/bound |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let sizes: &[usize] = if quick { &[1_000, 10_000, 100_000] } else { &[1_000, 10_000, 100_000, 1_000_000] };
    let mut base = None;
    for &n in sizes {
        let d = synth::random_segments(n, 42);
        let r = run(&d, true);
        #[allow(clippy::cast_precision_loss, reason = "benchmark sizes")]
        let nlogn = n as f64 * (n as f64).log2();
        let per = r.converge_cpu / nlogn;
        if n == 10_000 {
            base = Some(per);
        }
        let rel = base.map_or("-".to_string(), |b| format!("{:.2}", per / b));
        println!(
            "| {n} | {:.3} | {:.0} | {:.3} | {:.3} | {:.0} | {:.3} | {:.3} | {:.0} | {:.3} | {rel} | {:.3} | {:.0} | {:.3} |",
            r.greedy_cpu,
            r.greedy_mm,
            r.default_wall,
            r.default_cpu,
            r.default_mm,
            r.default_mm / r.greedy_mm,
            r.converge_cpu,
            r.converge_mm,
            r.converge_mm / r.greedy_mm,
            r.bound_cpu,
            r.bound_mm,
            r.default_mm / r.bound_mm
        );
    }

    println!("\n## Realistic synthetic drawings (synth::realistic_set(1)), default options\n");
    println!("| drawing | paths | greedy mm | improved mm | improved / greedy | bound mm | gap | wall s |");
    println!("|---|---|---|---|---|---|---|---|");
    let (mut tg, mut ti) = (0.0, 0.0);
    for (name, d) in synth::realistic_set(1) {
        let r = run(&d, false);
        tg += r.greedy_mm;
        ti += r.default_mm;
        println!(
            "| {name} | {} | {:.0} | {:.0} | {:.3} | {:.0} | {:.3} | {:.3} |",
            d.path_count(),
            r.greedy_mm,
            r.default_mm,
            r.default_mm / r.greedy_mm,
            r.bound_mm,
            r.default_mm / r.bound_mm,
            r.default_wall
        );
    }
    println!("| **total** | | {tg:.0} | {ti:.0} | **{:.3}** | | | |", ti / tg);

    println!("\n## samples/*.svg (imported with default options), default optimization\n");
    println!("| sample | paths | input order mm | greedy mm | improved mm | bound mm | gap | wall s |");
    println!("|---|---|---|---|---|---|---|---|");
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../samples");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .map(|rd| {
            rd.filter_map(Result::ok).map(|e| e.path()).filter(|p| p.extension().is_some_and(|x| x == "svg")).collect()
        })
        .unwrap_or_default();
    files.sort();
    for f in files {
        let Ok(imported) = svg::load_svg(&f, &SvgOptions::default()) else { continue };
        let d = imported.drawing;
        let before = plotter_path::geometry::travel::pen_up_length(&d);
        let r = run(&d, false);
        println!(
            "| {} | {} | {before:.1} | {:.1} | {:.1} | {:.1} | {:.3} | {:.4} |",
            f.file_name().map(|n| n.to_string_lossy()).unwrap_or_default(),
            d.path_count(),
            r.greedy_mm,
            r.default_mm,
            r.bound_mm,
            r.default_mm / r.bound_mm,
            r.default_wall
        );
    }
}
