//! Path-optimization benchmark: prints tables of time and pen-up travel for greedy only, greedy + improvement,
//! and the lower bound, on random segment sets of growing size and on the realistic synthetic drawings
//! (`plotter_path::optimize::synth`). Run with `cargo bench -p plotter-path --bench optimize`; pass `quick` to skip
//! the one-million case (`cargo bench -p plotter-path --bench optimize -- quick`).

use std::time::{Duration, Instant};

use plotter_path::Drawing;
use plotter_path::optimize::{OptimizeOptions, SeamMode, optimize, synth, travel_lower_bound};

struct Row {
    greedy_s: f64,
    greedy_mm: f64,
    improved_s: f64,
    improved_mm: f64,
    converge_s: f64,
    converge_mm: f64,
    bound_s: f64,
    bound_mm: f64,
}

fn run(d: &Drawing, converge: bool) -> Row {
    let greedy_opts = OptimizeOptions { improve: false, lower_bound: false, ..OptimizeOptions::default() };
    let mut g = d.clone();
    let t = Instant::now();
    let rg = optimize(&mut g, &greedy_opts).expect("valid input");
    let greedy_s = t.elapsed().as_secs_f64();

    let default_opts = OptimizeOptions { lower_bound: false, ..OptimizeOptions::default() };
    let mut i = d.clone();
    let t = Instant::now();
    let ri = optimize(&mut i, &default_opts).expect("valid input");
    let improved_s = t.elapsed().as_secs_f64();

    // Local search alone, run to convergence without a budget: the n log n growth figure.
    let (converge_s, converge_mm) = if converge {
        let opts = OptimizeOptions { lower_bound: false, time_budget: None, kicks_per_path: 0.0, ..default_opts };
        let mut c = d.clone();
        let t = Instant::now();
        let rc = optimize(&mut c, &opts).expect("valid input");
        (t.elapsed().as_secs_f64(), rc.pen_up_after_mm)
    } else {
        (f64::NAN, f64::NAN)
    };

    // The bound of the paths as ordered (after merging, as the optimizer saw them).
    let t = Instant::now();
    let (bound_mm, _) = travel_lower_bound(&g, SeamMode::Any, None, None);
    let bound_s = t.elapsed().as_secs_f64();
    Row {
        greedy_s,
        greedy_mm: rg.pen_up_after_mm,
        improved_s,
        improved_mm: ri.pen_up_after_mm,
        converge_s,
        converge_mm,
        bound_s,
        bound_mm,
    }
}

fn main() {
    let quick = std::env::args().any(|a| a == "quick");
    println!("## Random segment sets (400 x 280 mm page), one core");
    println!("default = greedy + 2-opt/Or-opt + kicks within the default 1.5 s budget; converged = greedy + local");
    println!(
        "search to its optimum, no kicks, no budget; per n·log2 n = converged time / (n log2 n), relative to 10k\n"
    );
    println!(
        "| n | greedy s | greedy mm | default s | default mm | vs greedy | converged s | converged mm | per n·log2 n | bound s | bound mm | gap (default/bound) |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    let sizes: &[usize] = if quick { &[1_000, 10_000, 100_000] } else { &[1_000, 10_000, 100_000, 1_000_000] };
    let mut base = None;
    for &n in sizes {
        let d = synth::random_segments(n, 42);
        let r = run(&d, true);
        #[allow(clippy::cast_precision_loss, reason = "benchmark sizes")]
        let nlogn = n as f64 * (n as f64).log2();
        let per = r.converge_s / nlogn;
        if n == 10_000 {
            base = Some(per);
        }
        let rel = base.map_or("-".to_string(), |b| format!("{:.2}", per / b));
        println!(
            "| {n} | {:.3} | {:.0} | {:.3} | {:.0} | {:.3} | {:.3} | {:.0} | {rel} | {:.3} | {:.0} | {:.3} |",
            r.greedy_s,
            r.greedy_mm,
            r.improved_s,
            r.improved_mm,
            r.improved_mm / r.greedy_mm,
            r.converge_s,
            r.converge_mm,
            r.bound_s,
            r.bound_mm,
            r.improved_mm / r.bound_mm
        );
    }

    println!("\n## Realistic synthetic drawings (synth::realistic_set(1)), default options\n");
    println!("| drawing | paths | greedy mm | improved mm | improved / greedy | bound mm | gap | time s |");
    println!("|---|---|---|---|---|---|---|---|");
    let (mut tg, mut ti) = (0.0, 0.0);
    for (name, d) in synth::realistic_set(1) {
        let r = run(&d, false);
        tg += r.greedy_mm;
        ti += r.improved_mm;
        println!(
            "| {name} | {} | {:.0} | {:.0} | {:.3} | {:.0} | {:.3} | {:.3} |",
            d.path_count(),
            r.greedy_mm,
            r.improved_mm,
            r.improved_mm / r.greedy_mm,
            r.bound_mm,
            r.improved_mm / r.bound_mm,
            r.improved_s
        );
    }
    println!("| **total** | | {tg:.0} | {ti:.0} | **{:.3}** | | | |", ti / tg);
    let _ = Duration::ZERO;
}
