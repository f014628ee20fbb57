//! The in-process simulator at the pace of a real machine: virtual time may not run ahead of the wall clock
//! (times a speed factor), so someone watching the plot (the web page, `plotter plot --sim-speed`) sees it move
//! as a plotter would, and has time to pause it.
//!
//! The simulator itself runs on virtual time as fast as it can; this wrapper only hands it slices of at most
//! `SLICE` of virtual time and sleeps whenever virtual time is ahead of `wall elapsed × speed`. After a pause
//! (nobody asked for replies for a while) the pace restarts from the current instant instead of rushing to catch up.

use std::io;
use std::time::{Duration, Instant};

use super::Transport;
use super::sim::SimTransport;

/// The most virtual time simulated in one go.
const SLICE: Duration = Duration::from_millis(10);
/// Falling further behind than this (virtual time) restarts the pace instead of catching up.
const MAX_LAG: Duration = Duration::from_millis(200);

/// A [`SimTransport`] paced to the wall clock (or not at all, at an infinite speed).
pub struct PacedSim {
    inner: SimTransport,
    speed: f64,
    base_wall: Instant,
    base_virtual: Duration,
}

impl PacedSim {
    /// Pace `inner` at `speed` × real time (`speed` > 0; e.g. 4 runs a 20 s plot in 5 s; infinity: as fast as
    /// the simulator runs).
    pub fn new(inner: SimTransport, speed: f64) -> Self {
        let base_virtual = inner.now();
        PacedSim { inner, speed: speed.max(1e-3), base_wall: Instant::now(), base_virtual }
    }

    /// The simulator (trace, executed time).
    pub fn inner(&self) -> &SimTransport {
        &self.inner
    }

    /// Sleep until the wall clock allows virtual time to pass `self.inner.now()`.
    fn keep_pace(&mut self) {
        if !self.speed.is_finite() {
            return;
        }
        let now_virtual = self.inner.now();
        let allowed = self.base_virtual + self.base_wall.elapsed().mul_f64(self.speed);
        if now_virtual > allowed {
            std::thread::sleep((now_virtual - allowed).div_f64(self.speed));
        } else if allowed - now_virtual > MAX_LAG {
            self.base_wall = Instant::now();
            self.base_virtual = now_virtual;
        }
    }
}

impl Transport for PacedSim {
    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.inner.send(bytes)
    }

    fn recv_line(&mut self, timeout: Duration) -> io::Result<Option<String>> {
        let end = self.inner.now() + timeout;
        loop {
            self.keep_pace();
            let before = self.inner.now();
            let slice = SLICE.min(end.saturating_sub(before));
            if let Some(line) = self.inner.recv_line(slice)? {
                return Ok(Some(line));
            }
            let after = self.inner.now();
            if after >= end || after == before {
                return Ok(None);
            }
        }
    }

    fn now(&self) -> Duration {
        self.inner.now()
    }

    fn set_streaming(&mut self, active: bool) {
        self.inner.set_streaming(active);
    }

    fn underruns(&self) -> Option<u64> {
        self.inner.underruns()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::session::Session;
    use plotter_path::MachineProfile;
    use plotter_path::motion::plan::machine_config;

    #[test]
    fn virtual_time_does_not_run_ahead_of_the_wall_clock() {
        let cfg = machine_config(&MachineProfile::default_plotter()).unwrap();
        let mut session = Session::connect(PacedSim::new(SimTransport::new(cfg, None), 10.0), "sim").unwrap();
        let wall = Instant::now();
        let virtual_start = session.transport.now();
        // A 30 mm move at 10 mm/s takes at least 3 s of machine time; at 10 x that is at least 0.3 s of wall time.
        session.command("G1 X30 F600", Duration::from_secs(5)).unwrap();
        let status = session.wait_idle(Duration::from_millis(50)).unwrap();
        assert!(status.is_idle());
        let virtual_elapsed = session.transport.now() - virtual_start;
        assert!(virtual_elapsed >= Duration::from_secs(3), "{virtual_elapsed:?}");
        // Virtual time never ran more than one slice ahead of 10 x the wall clock.
        assert!(wall.elapsed().mul_f64(10.0) + SLICE * 10 >= virtual_elapsed, "{:?}", wall.elapsed());
    }
}
