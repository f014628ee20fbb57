//! Line-noise injection for testing the protocol's recovery: each byte is, with a given probability, flipped in
//! one bit or dropped. Deterministic for a seed (xorshift64*), so a failing run can be replayed.
//!
//! A corrupted byte is never turned into one of the real-time command bytes (`?`, `!`, `~`, Ctrl-X): those act
//! outside the framing by design (a reset or feed hold cannot wait for a checksum), so noise that forges one is a
//! different failure (a spurious hold or reset) from the one this harness measures (damaged frames and resends).
//! Stray real-time bytes are injected separately, at their own rate ([`Noise::with_realtime`]): in framed mode the
//! firmware must take them for data, never for commands.

use plotter_fw::protocol::{RT_FEED_HOLD, RT_RESET, RT_RESUME, RT_STATUS, is_realtime};

/// Byte corruption at a fixed rate.
#[derive(Debug, Clone)]
pub struct Noise {
    state: u64,
    /// Probability per byte, in 1/2³² units.
    threshold: u64,
    /// Bytes flipped so far.
    pub flipped: u64,
    /// Bytes dropped so far.
    pub dropped: u64,
    /// Probability of a stray real-time byte after each byte, in 1/2³² units.
    realtime_threshold: u64,
    /// Real-time bytes injected so far.
    pub injected: u64,
}

fn threshold(rate: f64) -> u64 {
    let scaled = (rate.clamp(0.0, 1.0) * 4_294_967_296.0).round();
    // Clamped to [0, 2^32] just above.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let t = scaled as u64;
    t
}

impl Noise {
    /// Corrupt each byte with probability `rate` (0..=1); half of the faults flip a bit, half drop the byte.
    pub fn new(rate: f64, seed: u64) -> Self {
        Noise {
            state: seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1,
            threshold: threshold(rate),
            flipped: 0,
            dropped: 0,
            realtime_threshold: 0,
            injected: 0,
        }
    }

    /// Also insert a stray real-time byte (`?`, `!`, `~` or Ctrl-X, at random) after each byte with probability
    /// `rate`.
    pub fn with_realtime(mut self, rate: f64) -> Self {
        self.realtime_threshold = threshold(rate);
        self
    }

    fn next(&mut self) -> u64 {
        let mut x = self.state;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.state = x;
        x.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    /// Apply the noise to `bytes`.
    pub fn apply(&mut self, bytes: &[u8]) -> Vec<u8> {
        let mut out = Vec::with_capacity(bytes.len());
        for &b in bytes {
            if self.realtime_threshold > 0 {
                let r = self.next();
                if (r >> 32) < self.realtime_threshold {
                    self.injected += 1;
                    out.push(
                        [RT_STATUS, RT_FEED_HOLD, RT_RESUME, RT_RESET][usize::from(u8::try_from(r & 3).unwrap_or(0))],
                    );
                }
            }
            let r = self.next();
            if (r >> 32) >= self.threshold {
                out.push(b);
                continue;
            }
            if r & 1 == 0 {
                self.dropped += 1;
                continue;
            }
            let mut bit = (r >> 1) % 8;
            let mut c = b ^ (1 << bit);
            while is_realtime(c) {
                bit = (bit + 1) % 8;
                c = b ^ (1 << bit);
            }
            self.flipped += 1;
            out.push(c);
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rate_and_determinism() {
        let data = vec![0x41u8; 200_000];
        let mut a = Noise::new(0.01, 7);
        let out = a.apply(&data);
        let faults = a.flipped + a.dropped;
        // 2000 expected; binomial σ ≈ 44.
        assert!((1800..2200).contains(&faults), "{faults}");
        assert_eq!(out.len() as u64, 200_000 - a.dropped);
        assert!(out.iter().all(|&b| !is_realtime(b)));
        let mut b = Noise::new(0.01, 7);
        assert_eq!(b.apply(&data), out);
        assert_eq!(Noise::new(0.0, 1).apply(&data), data);
    }
}
