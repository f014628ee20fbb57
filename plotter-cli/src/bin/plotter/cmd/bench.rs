//! `plotter bench-link` (hidden): the link benchmark. A dense drawing — epicycloids flattened at 0.01 mm, thousands
//! of short segments — is planned and streamed to the simulated firmware over a simulated 115200-baud link (byte
//! timing exact), and the table reports the sustained block rate of the link, bytes per block, queue underruns, and
//! the plot time with the whole-drawing look-ahead against the same planner limited to a 16-block window. The same
//! plan is then streamed as G-code to the GRBL emulator over the same simulated link (character counting into
//! its 128-byte buffer, its 16-block planner), for lines/s and underruns against our step blocks.

use std::f64::consts::TAU;
use std::time::Instant;

use plotter_fw::TICK_HZ;
use plotter_path::geometry::steps::drawing_to_steps;
use plotter_path::kurbo::Point;
use plotter_path::motion::plan::{self, Lookahead};
use plotter_path::{Drawing, MachineProfile, Polyline};

use plotter_host::link::grbl::emulator::GrblEmulator;
use plotter_host::link::grbl::emulator_transport::EmulatorTransport;
use plotter_host::link::grbl::session::GrblSession;
use plotter_host::link::machine::Firmware;
use plotter_host::link::session::Session;
use plotter_host::link::sim::SimTransport;
use plotter_host::link::stream::{self, Quiet, StreamOptions};

/// Arguments of `plotter bench-link`.
#[derive(clap::Args, Debug, Clone)]
pub(crate) struct BenchArgs {
    /// Flattening tolerance of the epicycloids, mm.
    #[arg(long, default_value_t = 0.01)]
    pub(crate) tolerance: f64,
    /// Link speed.
    #[arg(long, default_value_t = 115_200)]
    pub(crate) baud: u32,
    /// Number of nested epicycloids.
    #[arg(long, default_value_t = 6)]
    pub(crate) curves: u32,
    /// Drawing feed, mm/s [default: the profile's].
    #[arg(long)]
    pub(crate) draw_feed: Option<f64>,
}

/// An epicycloid (circle of radius `r` rolling outside one of radius `big`) centred at `c`, flattened so that no
/// chord deviates more than `tol` from the curve: the step in the parameter is chosen from the local radius of
/// curvature ρ and speed |p'| so that the sagitta (chord length)²/(8ρ) stays within `tol`.
pub(crate) fn epicycloid(c: Point, big: f64, r: f64, tol: f64) -> Polyline {
    let k = (big + r) / r;
    let p = |t: f64| {
        Point::new(c.x + (big + r) * t.cos() - r * (k * t).cos(), c.y + (big + r) * t.sin() - r * (k * t).sin())
    };
    let d1 = |t: f64| ((big + r) * (-t.sin() + (k * t).sin()), (big + r) * (t.cos() - (k * t).cos()));
    let d2 = |t: f64| ((big + r) * (-t.cos() + k * (k * t).cos()), (big + r) * (-t.sin() + k * (k * t).sin()));
    let mut pts = vec![p(0.0)];
    let mut t = 0.0;
    while t < TAU {
        let (dx, dy) = d1(t);
        let (ddx, ddy) = d2(t);
        let speed = dx.hypot(dy);
        let cross = (dx * ddy - dy * ddx).abs();
        let rho = if cross > 1e-12 { speed.powi(3) / cross } else { f64::INFINITY };
        let chord = (8.0 * rho * tol).sqrt().min(2.0);
        let dt = if speed > 1e-9 { (chord / speed).clamp(1e-6, 0.02) } else { 1e-4 };
        t = (t + dt).min(TAU);
        pts.push(if t >= TAU { pts[0] } else { p(t) });
    }
    Polyline::new(pts)
}

/// Run the benchmark and print the table.
pub(crate) fn run(args: &BenchArgs) -> anyhow::Result<()> {
    let mut profile = MachineProfile::default_plotter();
    if let Some(f) = args.draw_feed {
        profile.pen.draw_feed_mm_s = f;
    }
    let paths: Vec<Polyline> = (0..args.curves)
        .map(|i| {
            let s = 1.0 - 0.12 * f64::from(i);
            epicycloid(Point::new(150.0, 140.0), 60.0 * s, 12.0 * s, args.tolerance)
        })
        .collect();
    let segments: usize = paths.iter().map(Polyline::segment_count).sum();
    let drawing = Drawing::single_layer("epicycloids", paths);
    let steps = drawing_to_steps(&profile, &drawing)?;
    let cfg = plan::machine_config(&profile)?;
    let mut session = Session::connect(SimTransport::new(cfg, Some(args.baud)), "simulated plotter")?;
    session.home()?;
    let start = session.status()?.steps;
    let t = Instant::now();
    let whole = plan::plan(&profile, &steps, start, Lookahead::Whole)?;
    let plan_wall = t.elapsed();
    let window = plan::plan(&profile, &steps, start, Lookahead::Window(16))?;
    let busy0 = session.transport.sim().hal().busy_ticks();
    let wire0 = session.transport.wire_busy_ticks();
    let t = Instant::now();
    let (_, stats) = stream::stream_plan(&mut session, &whole, StreamOptions::default(), &mut Quiet)?;
    let sim_wall = t.elapsed();
    let executed = session.transport.sim().hal().busy_ticks() - busy0;
    let wire = session.transport.wire_busy_ticks() - wire0;
    // Display arithmetic on counts far below 2^53.
    #[allow(clippy::cast_precision_loss)]
    let (frames, bytes, wire_s) = (stats.frames as f64, stats.frame_bytes as f64, wire as f64 / f64::from(TICK_HZ));
    let secs = |ticks: u64| {
        #[allow(clippy::cast_precision_loss)]
        let s = ticks as f64 / f64::from(TICK_HZ);
        s
    };
    println!(
        "link benchmark: {} epicycloids flattened at {} mm, {} baud, drawing at {} mm/s",
        args.curves, args.tolerance, args.baud, profile.pen.draw_feed_mm_s
    );
    println!("| measure | value |");
    println!("|---|---|");
    println!("| polyline segments | {segments} |");
    println!("| step blocks (incl. pen moves) | {} |", stats.frames);
    println!("| average bytes per block | {:.2} |", bytes / frames);
    println!(
        "| link capacity at {} baud | {:.0} blocks/s |",
        args.baud,
        f64::from(args.baud) / 10.0 / (bytes / frames)
    );
    // The simulator delivers the first byte of a burst at once, so this can read slightly above the capacity.
    println!("| sustained blocks/s while the wire was busy | {:.0} |", frames / wire_s.max(1e-9));
    println!("| sustained blocks/s over the plot | {:.0} |", frames / secs(executed).max(1e-9));
    println!("| queue underruns | {} |", stats.underruns.unwrap_or(0));
    println!("| resends | {} |", stats.resends);
    println!("| plot time, whole-drawing look-ahead | {:.3} s |", whole.seconds());
    println!("| plot time, 16-block window | {:.3} s |", window.seconds());
    println!("| executed time (simulator) | {:.3} s |", secs(executed));
    println!("| host plan time (wall) | {:.1} ms |", plan_wall.as_secs_f64() * 1e3);
    println!("| simulation wall time | {:.2} s |", sim_wall.as_secs_f64());

    // The same drawing as G-code to the GRBL emulator.
    let emu = GrblEmulator::new(&profile, Some(args.baud))?;
    let mut grbl = GrblSession::connect(EmulatorTransport::new(emu), "GRBL emulator", &profile)?;
    grbl.home()?;
    let start = grbl.position()?;
    // Planned for GRBL, as a plot on it is (a servo pen's drop stops the carriage there).
    let grbl_profile = plotter_host::link::machine::profile_for(&profile, Firmware::Grbl);
    let gplan = plan::plan(&grbl_profile, &steps, start, Lookahead::Whole)?;
    let busy0 = grbl.transport.emulator().backend().hal().busy_ticks();
    let t = Instant::now();
    let gstats = grbl.stream(&gplan, &mut Quiet)?;
    let gwall = t.elapsed();
    let gexec = grbl.transport.emulator().backend().hal().busy_ticks() - busy0;
    #[allow(clippy::cast_precision_loss)]
    let (lines, gbytes) = (gstats.frames as f64, gstats.frame_bytes as f64);
    let emu_stats = grbl.transport.emulator().stats();
    println!();
    println!("| same drawing, {} baud | our firmware (step blocks) | GRBL 1.1 emulator (G-code) |", args.baud);
    println!("|---|---|---|");
    println!("| blocks / lines | {} | {} |", stats.frames, gstats.frames);
    println!("| bytes per block / line | {:.2} | {:.2} |", bytes / frames, gbytes / lines);
    println!(
        "| link capacity | {:.0} blocks/s | {:.0} lines/s |",
        f64::from(args.baud) / 10.0 / (bytes / frames),
        f64::from(args.baud) / 10.0 / (gbytes / lines)
    );
    println!(
        "| sustained over the plot | {:.0} blocks/s | {:.0} lines/s |",
        frames / secs(executed).max(1e-9),
        lines / secs(gexec).max(1e-9)
    );
    println!(
        "| all accepted after | {:.3} s | {:.3} s |",
        stats.accept_elapsed.as_secs_f64(),
        gstats.accept_elapsed.as_secs_f64()
    );
    println!("| queue underruns | {} | {} |", stats.underruns.unwrap_or(0), gstats.underruns.unwrap_or(0));
    println!("| executed motion time | {:.3} s | {:.3} s |", secs(executed), secs(gexec));
    println!(
        "| plot wall time on the link | {:.3} s | {:.3} s |",
        stats.elapsed.as_secs_f64(),
        gstats.elapsed.as_secs_f64()
    );
    println!(
        "| most bytes in flight | ≤ {} (announced) | {} of 128 (peak buffer {}, overflow {}) |",
        session.info.rx_bytes, grbl.peak_in_flight, emu_stats.peak_rx, emu_stats.overflow_bytes
    );
    println!("| simulation wall time | {:.2} s | {:.2} s |", sim_wall.as_secs_f64(), gwall.as_secs_f64());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use plotter_path::geometry::flatten::point_segment_distance;

    #[test]
    fn epicycloid_is_closed_and_within_tolerance() {
        let tol = 0.01;
        let (big, r) = (30.0, 6.0);
        let e = epicycloid(Point::ZERO, big, r, tol);
        assert!(e.is_closed());
        assert!(e.segment_count() > 300, "{}", e.segment_count());
        // Check the chord error at parameter midpoints against a dense sampling of the true curve.
        let k = (big + r) / r;
        let curve =
            |t: f64| Point::new((big + r) * t.cos() - r * (k * t).cos(), (big + r) * t.sin() - r * (k * t).sin());
        for i in 0..20_000 {
            let q = curve(TAU * f64::from(i) / 20_000.0);
            let d = e.points.windows(2).map(|w| point_segment_distance(q, w[0], w[1])).fold(f64::INFINITY, f64::min);
            assert!(d <= tol * 1.05, "{d} at sample {i}");
        }
    }
}
