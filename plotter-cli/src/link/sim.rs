//! The simulated plotter in-process: the firmware simulator behind the [`Transport`] trait, on virtual time.
//!
//! Sending feeds bytes onto the simulator's serial line (at the profile's baud rate when `baud` is set, so link
//! throughput is modelled exactly); receiving runs the simulation forward in small slices of virtual time until a
//! reply line is complete. The host therefore reacts to replies within one slice (one byte time at the baud rate),
//! like a host that is much faster than its link.

use std::io;
use std::time::Duration;

use plotter_fw::sim::{Sim, SimOptions};
use plotter_fw::{MachineConfig, TICK_HZ};

use super::faults::Noise;
use super::{LineSplitter, Transport};

/// The in-process simulated plotter.
pub struct SimTransport {
    sim: Sim,
    lines: LineSplitter,
    slice_ticks: u64,
    streaming: bool,
    was_moving: bool,
    underruns: u64,
    noise: Option<Noise>,
    reply_noise: Option<Noise>,
    wire_busy_ticks: u64,
}

impl SimTransport {
    /// A simulator for `cfg`; `baud` = `None` delivers bytes as fast as the firmware's buffer takes them.
    pub fn new(cfg: MachineConfig, baud: Option<u32>) -> Self {
        let mut opts = SimOptions::for_config(&cfg);
        opts.baud = baud;
        Self::from_sim(Sim::with_options(cfg, opts), baud)
    }

    /// Around an existing simulator (e.g. a printer with heaters); `baud` as in [`SimTransport::new`].
    pub fn from_sim(sim: Sim, baud: Option<u32>) -> Self {
        let slice_ticks = baud.map_or(100, |b| (u64::from(TICK_HZ) * 10).div_ceil(u64::from(b.max(1))));
        SimTransport {
            sim,
            lines: LineSplitter::default(),
            slice_ticks,
            streaming: false,
            was_moving: false,
            underruns: 0,
            noise: None,
            reply_noise: None,
            wire_busy_ticks: 0,
        }
    }

    /// The simulator, mutably (fault injection).
    pub fn sim_mut(&mut self) -> &mut Sim {
        &mut self.sim
    }

    /// Corrupt the bytes sent to the firmware with `noise`.
    pub fn with_noise(mut self, noise: Noise) -> Self {
        self.noise = Some(noise);
        self
    }

    /// Corrupt the firmware's replies with `noise` (line ends included, so lines can merge or split).
    pub fn with_reply_noise(mut self, noise: Noise) -> Self {
        self.reply_noise = Some(noise);
        self
    }

    /// The noise on each direction (to the firmware, from the firmware), for reports.
    pub fn noise(&self) -> (Option<&Noise>, Option<&Noise>) {
        (self.noise.as_ref(), self.reply_noise.as_ref())
    }

    /// Virtual time during which bytes were waiting on the wire (the link was busy), ticks.
    pub fn wire_busy_ticks(&self) -> u64 {
        self.wire_busy_ticks
    }

    /// The simulator (trace, executed time).
    pub fn sim(&self) -> &Sim {
        &self.sim
    }

    fn collect(&mut self) {
        for l in self.sim.take_replies() {
            match self.reply_noise.as_mut() {
                Some(n) => {
                    let mut bytes = l.into_bytes();
                    bytes.push(b'\n');
                    let noisy = n.apply(&bytes);
                    self.lines.push(&noisy);
                }
                None => {
                    self.lines.push(l.as_bytes());
                    self.lines.push(b"\n");
                }
            }
        }
    }

    fn watch_underrun(&mut self) {
        let moving = !self.sim.machine().stepper().is_idle();
        if self.streaming && self.was_moving && !moving {
            self.underruns += 1;
        }
        self.was_moving = moving;
    }
}

impl Transport for SimTransport {
    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        match self.noise.as_mut() {
            Some(n) => {
                let noisy = n.apply(bytes);
                self.sim.feed(&noisy);
            }
            None => self.sim.feed(bytes),
        }
        Ok(())
    }

    fn recv_line(&mut self, timeout: Duration) -> io::Result<Option<String>> {
        self.collect();
        if let Some(l) = self.lines.pop() {
            return Ok(Some(l));
        }
        let end = self.sim.now().saturating_add(u64::try_from(timeout.as_micros()).unwrap_or(u64::MAX));
        while self.sim.now() < end {
            let before = self.sim.now();
            let step = self.slice_ticks.min(end - before);
            let wire_busy = self.sim.wire_len() > 0;
            self.sim.run_for(step);
            if wire_busy {
                self.wire_busy_ticks += self.sim.now() - before;
            }
            self.watch_underrun();
            self.collect();
            if let Some(l) = self.lines.pop() {
                return Ok(Some(l));
            }
            if self.sim.now() == before {
                // Nothing left to simulate: no reply can come any more.
                return Ok(None);
            }
        }
        Ok(None)
    }

    fn now(&self) -> Duration {
        Duration::from_micros(self.sim.now())
    }

    fn set_streaming(&mut self, active: bool) {
        self.streaming = active;
    }

    fn underruns(&self) -> Option<u64> {
        Some(self.underruns)
    }
}
