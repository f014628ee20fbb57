//! The plotter model behind a serial line: [`Wire`] delivers bytes at the line's pace (10 bits a byte: 8N1), in
//! both directions, on whatever clock its owner keeps — the virtual clock of [`ModelLink`] (the in-process
//! [`HpglLink`] tests use) or the wall clock of `plotter sim --pty --hpgl`.

use std::collections::VecDeque;
use std::io;
use std::time::Duration;

use super::HpglLink;
use super::model::HpglModel;

/// The model and the two directions of its serial line.
pub struct Wire {
    model: HpglModel,
    byte_s: f64,
    /// When the host-to-plotter direction is free again, s.
    to_plotter_free: f64,
    /// Bytes on their way to the plotter with their arrival times.
    to_plotter: VecDeque<(f64, u8)>,
    /// When the plotter-to-host direction is free again, s.
    to_host_free: f64,
    /// Bytes on their way to the host with their arrival times.
    to_host: VecDeque<(f64, u8)>,
}

impl Wire {
    /// `model` behind a line of `baud` bits/s.
    pub fn new(model: HpglModel, baud: u32) -> Wire {
        Wire {
            model,
            byte_s: 10.0 / f64::from(baud.max(1)),
            to_plotter_free: 0.0,
            to_plotter: VecDeque::new(),
            to_host_free: 0.0,
            to_host: VecDeque::new(),
        }
    }

    /// The plotter.
    pub fn model(&self) -> &HpglModel {
        &self.model
    }

    /// The plotter, to change it (make it lie).
    pub fn model_mut(&mut self) -> &mut HpglModel {
        &mut self.model
    }

    /// Seconds one byte takes on the line.
    pub fn byte_seconds(&self) -> f64 {
        self.byte_s
    }

    /// The host writes `bytes` at time `now`: they are queued on the line; returns when the last one will have
    /// arrived.
    pub fn send(&mut self, now: f64, bytes: &[u8]) -> f64 {
        for &b in bytes {
            self.to_plotter_free = self.to_plotter_free.max(now) + self.byte_s;
            self.to_plotter.push_back((self.to_plotter_free, b));
        }
        self.to_plotter_free.max(now)
    }

    /// Run the plotter and the line until `t`: bytes arrive at their times, the plotter's answers are queued
    /// towards the host at the moments it sends them.
    pub fn run_until(&mut self, t: f64) {
        while let Some(&(at, b)) = self.to_plotter.front().filter(|(at, _)| *at <= t) {
            self.advance(at, false);
            self.model.receive(b);
            self.queue_output();
            self.to_plotter.pop_front();
        }
        self.advance(t, false);
    }

    /// Like [`Wire::run_until`], but stop as soon as the plotter has sent something (returns whether it did).
    pub fn run_until_output(&mut self, t: f64) -> bool {
        while let Some(&(at, b)) = self.to_plotter.front().filter(|(at, _)| *at <= t) {
            if self.advance(at, true) {
                return true;
            }
            self.model.receive(b);
            self.to_plotter.pop_front();
            if self.queue_output() {
                return true;
            }
        }
        self.advance(t, true)
    }

    /// Run the plotter alone to `t` (no byte arriving before), queueing what it sends; with `stop`, return at the
    /// first output. Returns whether it sent something.
    fn advance(&mut self, t: f64, stop: bool) -> bool {
        let mut sent = false;
        while self.model.clock() < t {
            self.model.run_until_output(t);
            sent |= self.queue_output();
            if sent && stop {
                return true;
            }
        }
        sent
    }

    /// Queue what the plotter sent (at its clock) towards the host; returns whether there was anything.
    fn queue_output(&mut self) -> bool {
        let now = self.model.clock();
        let out = self.model.take_output();
        for &b in &out {
            self.to_host_free = self.to_host_free.max(now) + self.byte_s;
            self.to_host.push_back((self.to_host_free, b));
        }
        !out.is_empty()
    }

    /// Bytes that have reached the host by `t`.
    pub fn received(&mut self, t: f64) -> Vec<u8> {
        let mut out = Vec::new();
        while let Some(&(at, b)) = self.to_host.front() {
            if at > t {
                break;
            }
            out.push(b);
            self.to_host.pop_front();
        }
        out
    }

    /// When the next byte reaches the host, if one is on its way.
    pub fn next_arrival(&self) -> Option<f64> {
        self.to_host.front().map(|&(at, _)| at)
    }
}

/// The model as an in-process [`HpglLink`] on a virtual clock: writing advances the clock by the bytes'
/// transmission time, reading runs the plotter until an answer arrives or the timeout has passed.
pub struct ModelLink {
    wire: Wire,
    now: f64,
    /// Whether the cable has the handshake lines (CTS readable).
    pub lines: bool,
}

impl ModelLink {
    /// `model` on a line of `baud` bits/s with handshake lines.
    pub fn new(model: HpglModel, baud: u32) -> ModelLink {
        ModelLink { wire: Wire::new(model, baud), now: 0.0, lines: true }
    }

    /// The plotter.
    pub fn model(&self) -> &HpglModel {
        self.wire.model()
    }

    /// The plotter, to change it (make it lie).
    pub fn model_mut(&mut self) -> &mut HpglModel {
        self.wire.model_mut()
    }

    /// Let the plotter finish what it holds (at most `limit` s); returns the time.
    pub fn finish(&mut self, limit: f64) -> f64 {
        let end = self.now + limit;
        while self.now < end && !(self.wire.model().idle() && self.wire.to_plotter.is_empty()) {
            self.now = (self.now + 0.01).min(end);
            self.wire.run_until(self.now);
        }
        self.now
    }
}

impl HpglLink for ModelLink {
    fn write(&mut self, bytes: &[u8]) -> io::Result<()> {
        let done = self.wire.send(self.now, bytes);
        self.wire.run_until(done);
        self.now = done;
        Ok(())
    }

    fn read(&mut self, timeout: Duration) -> io::Result<Vec<u8>> {
        let deadline = self.now + timeout.as_secs_f64();
        loop {
            let got = self.wire.received(self.now);
            if !got.is_empty() {
                return Ok(got);
            }
            if self.now >= deadline {
                return Ok(Vec::new());
            }
            // Up to the next byte's arrival at the host, or until the plotter sends one, or the deadline.
            let until = self.wire.next_arrival().map_or(deadline, |a| a.min(deadline));
            if self.wire.run_until_output(until) {
                // Sent at the plotter's clock: it reaches the host a byte's time later.
                let until = self.wire.next_arrival().map_or(deadline, |a| a.min(deadline)).max(self.now);
                self.wire.run_until(until);
                self.now = until;
            } else {
                self.now = until.max(self.now);
            }
        }
    }

    fn now(&self) -> Duration {
        Duration::from_secs_f64(self.now)
    }

    fn clear_to_send(&mut self) -> io::Result<Option<bool>> {
        Ok(self.lines.then(|| self.wire.model().clear_to_send()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::hpgl::model::ModelConfig;
    use plotter_path::geometry::hpgl_devices::device;

    #[test]
    fn bytes_take_their_line_time_both_ways() {
        let m = HpglModel::new(ModelConfig::new(device("7475a").unwrap()));
        let mut l = ModelLink::new(m, 9600);
        l.write(b"\x1b.L").unwrap();
        // Three bytes out at 1/960 s each.
        assert!((l.now().as_secs_f64() - 3.0 / 960.0).abs() < 1e-9);
        let got = l.read(Duration::from_secs(1)).unwrap();
        let mut all = got.clone();
        while !all.ends_with(b"\r") {
            all.extend(l.read(Duration::from_secs(1)).unwrap());
        }
        assert_eq!(all, b"1024\r");
        // The answer's five bytes took five byte times after the question arrived.
        assert!((l.now().as_secs_f64() - 8.0 / 960.0).abs() < 1e-6, "{:?}", l.now());
    }
}
