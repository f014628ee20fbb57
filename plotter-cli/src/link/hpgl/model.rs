//! An HP-GL plotter of our own, for tests and for `plotter sim --pty --hpgl`: the input buffer of the chosen
//! device (or a smaller one), which **loses** bytes that arrive while it is full — as the real ones do — and
//! counts them (and reports error 16 to `ESC . E`); the device-control answers (`ESC . B` free space, `ESC . L`
//! buffer size, `ESC . E` error, `ESC . K` abort); the HP-GL answers `OI` (identity) and `OE` (error); Xon/Xoff
//! when the plotter supports it and was told to (`ESC . I` threshold, `ESC . N` Xoff character); a CTS line
//! that drops when the free space falls below the same margin; the pen carousel (`SP`, error 3 past the last
//! pen); and a clock: the plotter takes bytes out of its buffer only while it is not moving, and every move
//! takes the time [`super::timing`] gives for the `VS` speed (pen down) or the top speed (pen up).
//!
//! The parser takes one byte at a time and executes each coordinate pair as soon as its second number has
//! ended, so an instruction longer than the buffer (a long `PD` list) still runs, as on the real plotters.
//!
//! The trace is what was drawn: every pen-down polyline in plotter units, in order.
//!
//! A model can also **lie** ([`Lie`], `plotter sim --pty --hpgl --hpgl-lie MODE[@N]`), from the moment `N` HP-GL
//! bytes have entered its buffer: withhold buffer space (`ESC . B` answering 0, or an Xoff never followed by an
//! Xon), babble (a line every 20 ms, as a wrong port or an auto-reporting GRBL does), or answer the buffer
//! queries with garbage or not at all. The host must end every one of these with a message, within a deadline,
//! and still lift the pen.
//!
//! Time is in seconds of the model's own clock, advanced by [`HpglModel::run_until`]; bytes arrive with
//! [`HpglModel::receive`] (device-control instructions are executed on arrival, everything else enters the buffer).

use std::collections::VecDeque;

use plotter_path::geometry::hpgl_devices::HpglDevice;

use super::handshake::threshold;
use super::messages::{CR, ESC, XOFF, XON};
use super::timing::{PEN_CHANGE_S, PEN_LIFT_S, accel_plu, cm_s_to_plu, move_seconds};

/// Longest number the parser keeps, characters (longer ones are error 3).
const MAX_NUMBER: usize = 24;
/// Most parameters kept for one instruction (coordinate pairs run as they come and are not kept).
const MAX_PARAMS: usize = 16;
/// Longest device-control parameter string, bytes (longer is error 14).
const MAX_ESC: usize = 40;

/// How the model is built.
#[derive(Debug, Clone, Copy)]
pub struct ModelConfig {
    /// The device it plays.
    pub device: &'static HpglDevice,
    /// Its input buffer, bytes (the device's by default).
    pub buffer: usize,
    /// Whether it does Xon/Xoff at all (when told to with `ESC . N`).
    pub xon_xoff: bool,
}

impl ModelConfig {
    /// The device with its own buffer and Xon/Xoff support.
    pub fn new(device: &'static HpglDevice) -> ModelConfig {
        ModelConfig { device, buffer: device.buffer_bytes, xon_xoff: true }
    }
}

/// A way for the model to misbehave, for the tests of the host's waits and stops.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Lie {
    /// An honest plotter.
    #[default]
    None,
    /// `ESC . B` always answers 0 (no room), whatever the buffer holds.
    NoRoom,
    /// An Xoff (whether or not Xon/Xoff was asked for), and never an Xon after it.
    XoffForever,
    /// A junk line (a GRBL status report) every 20 ms, whatever it is asked.
    Chatter,
    /// `ESC . B` and `ESC . K` answered with garbage (`ESC . K` still empties the buffer).
    EscbGarbage,
    /// `ESC . B` never answered.
    EscbSilent,
}

impl Lie {
    /// The lies by their command-line names.
    pub const NAMES: [(&'static str, Lie); 5] = [
        ("no-room", Lie::NoRoom),
        ("xoff-forever", Lie::XoffForever),
        ("chatter", Lie::Chatter),
        ("escb-garbage", Lie::EscbGarbage),
        ("escb-silent", Lie::EscbSilent),
    ];

    /// Parse `MODE` or `MODE@N` (the lie starts once `N` HP-GL bytes have entered the buffer; 0 by default).
    pub fn parse(spec: &str) -> Result<(Lie, u64), String> {
        let (name, at) = spec.split_once('@').unwrap_or((spec, "0"));
        let names = || Lie::NAMES.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", ");
        let lie =
            Lie::NAMES.iter().find(|(n, _)| *n == name).map(|(_, l)| *l).ok_or_else(|| {
                format!("{spec:?}: not a lie the model tells (use {} with an optional @BYTES)", names())
            })?;
        let at = at.parse().map_err(|_| format!("{spec:?}: @{at} is not a byte count"))?;
        Ok((lie, at))
    }
}

/// Seconds between two lines of [`Lie::Chatter`].
pub const CHATTER_S: f64 = 0.02;
/// The line [`Lie::Chatter`] sends (a GRBL 1.1 status report, with the LF a GRBL ends it with).
pub const CHATTER_LINE: &[u8] = b"<Idle|MPos:0.000,0.000,0.000|FS:0,0>\r\n";

/// What the model counted.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ModelStats {
    /// Bytes that entered the buffer.
    pub buffered: u64,
    /// Bytes lost because the buffer was full.
    pub overflow: u64,
    /// Most bytes the buffer held at once.
    pub peak: usize,
    /// HP-GL instructions executed.
    pub instructions: u64,
    /// HP-GL errors (each counted when it happened).
    pub errors: u64,
    /// Xoffs sent.
    pub xoffs: u64,
    /// `ESC . K` aborts.
    pub aborts: u64,
}

/// Where the byte parser is.
#[derive(Debug, Clone, PartialEq)]
enum Parse {
    /// Between instructions.
    Idle,
    /// Read the first letter of a mnemonic.
    Letter(u8),
    /// Reading the parameters of `mnemonic`: the number being read and those complete.
    Params { mnemonic: [u8; 2], number: String, numbers: Vec<f64>, pairs: usize },
}

/// The HP-GL plotter model (see the module docs).
pub struct HpglModel {
    cfg: ModelConfig,
    buffer: VecDeque<u8>,
    clock: f64,
    busy_until: f64,
    busy_s: f64,
    parse: Parse,
    esc: Option<Vec<u8>>,
    pen: u32,
    velocity: Option<f64>,
    pos: (i32, i32),
    down: bool,
    trace: Vec<Vec<(i32, i32)>>,
    drawing: bool,
    out: Vec<u8>,
    oe: u32,
    esc_error: u32,
    xon_enabled: bool,
    xoff_threshold: usize,
    xoff_sent: bool,
    stats: ModelStats,
    lie: Lie,
    lie_from: u64,
    chatter_at: f64,
}

impl HpglModel {
    /// A plotter switched on: pen up in the holder, buffer empty, Xon/Xoff off.
    pub fn new(cfg: ModelConfig) -> HpglModel {
        HpglModel {
            cfg,
            buffer: VecDeque::with_capacity(cfg.buffer),
            clock: 0.0,
            busy_until: 0.0,
            busy_s: 0.0,
            parse: Parse::Idle,
            esc: None,
            pen: 0,
            velocity: None,
            pos: (0, 0),
            down: false,
            trace: Vec::new(),
            drawing: false,
            out: Vec::new(),
            oe: 0,
            esc_error: 0,
            xon_enabled: false,
            xoff_threshold: threshold(cfg.buffer),
            xoff_sent: false,
            stats: ModelStats::default(),
            lie: Lie::None,
            lie_from: 0,
            chatter_at: CHATTER_S,
        }
    }

    /// Tell `lie` once `from` HP-GL bytes have entered the buffer (see [`Lie`]).
    pub fn set_lie(&mut self, lie: Lie, from: u64) {
        self.lie = lie;
        self.lie_from = from;
        self.lying_now();
    }

    /// The lie being told now, if any (an Xoff-forever sends its Xoff when it starts).
    fn lying_now(&mut self) -> Lie {
        if self.lie == Lie::None || self.stats.buffered < self.lie_from {
            return Lie::None;
        }
        if self.lie == Lie::XoffForever && !self.xoff_sent {
            self.out.push(XOFF);
            self.xoff_sent = true;
            self.stats.xoffs += 1;
        }
        self.lie
    }

    /// How it was built.
    pub fn config(&self) -> &ModelConfig {
        &self.cfg
    }

    /// Its clock, s.
    pub fn clock(&self) -> f64 {
        self.clock
    }

    /// Seconds spent moving, lifting and changing pens.
    pub fn busy_seconds(&self) -> f64 {
        self.busy_s
    }

    /// The pen-down polylines drawn, plotter units.
    pub fn trace(&self) -> &[Vec<(i32, i32)>] {
        &self.trace
    }

    /// What it counted.
    pub fn stats(&self) -> ModelStats {
        self.stats
    }

    /// Whether the pen is up.
    pub fn pen_up(&self) -> bool {
        !self.down
    }

    /// The pen in the holder (0: none).
    pub fn pen(&self) -> u32 {
        self.pen
    }

    /// Where the pen is, plotter units.
    pub fn position(&self) -> (i32, i32) {
        self.pos
    }

    /// Whether it has nothing left to do (buffer empty, not moving).
    pub fn idle(&self) -> bool {
        self.buffer.is_empty() && self.busy_until <= self.clock
    }

    /// Free space in the buffer, bytes.
    pub fn free(&self) -> usize {
        self.cfg.buffer - self.buffer.len()
    }

    /// The CTS line: up while the free space is at least the margin.
    pub fn clear_to_send(&self) -> bool {
        self.free() >= self.xoff_threshold
    }

    /// The bytes it sent since the last call.
    pub fn take_output(&mut self) -> Vec<u8> {
        std::mem::take(&mut self.out)
    }

    /// A byte arrives (at the current clock).
    pub fn receive(&mut self, b: u8) {
        if let Some(esc) = self.esc.as_mut() {
            esc.push(b);
            self.device_control();
            return;
        }
        if b == ESC {
            self.esc = Some(Vec::new());
            return;
        }
        if self.buffer.len() >= self.cfg.buffer {
            self.stats.overflow += 1;
            self.esc_error = 16;
            return;
        }
        self.buffer.push_back(b);
        self.stats.buffered += 1;
        self.stats.peak = self.stats.peak.max(self.buffer.len());
        self.flow();
    }

    /// Run until `t` (s): take bytes from the buffer and execute them while not moving.
    pub fn run_until(&mut self, t: f64) {
        self.run(t, false);
    }

    /// Run until `t`, or until the plotter has something to send (an answer, Xon/Xoff): its clock then stands
    /// at the moment it was sent. Output not yet taken stops it at once.
    pub fn run_until_output(&mut self, t: f64) {
        self.run(t, true);
    }

    fn run(&mut self, t: f64, stop_on_output: bool) {
        while self.clock < t {
            if stop_on_output && !self.out.is_empty() {
                return;
            }
            // A babbling plotter speaks at its own times, whatever it is doing.
            let mut until = t;
            if self.lying_now() == Lie::Chatter {
                if self.clock >= self.chatter_at {
                    self.out.extend_from_slice(CHATTER_LINE);
                    self.chatter_at = self.clock + CHATTER_S;
                    continue;
                }
                until = until.min(self.chatter_at);
            }
            if self.busy_until > self.clock {
                self.clock = self.busy_until.min(until);
                continue;
            }
            let Some(b) = self.buffer.pop_front() else {
                self.clock = until;
                continue;
            };
            self.flow();
            self.parse_byte(b);
        }
    }

    /// Xon/Xoff after the buffer changed.
    fn flow(&mut self) {
        if !self.xon_enabled {
            return;
        }
        let free = self.free();
        if !self.xoff_sent && free < self.xoff_threshold {
            self.out.push(XOFF);
            self.xoff_sent = true;
            self.stats.xoffs += 1;
        } else if self.xoff_sent
            && free >= (2 * self.xoff_threshold).min(self.cfg.buffer)
            && self.lying_now() != Lie::XoffForever
        {
            self.out.push(XON);
            self.xoff_sent = false;
        }
    }

    fn answer(&mut self, text: &str) {
        self.out.extend_from_slice(text.as_bytes());
        self.out.push(CR);
    }

    /// A device-control instruction, byte by byte after its ESC.
    fn device_control(&mut self) {
        let Some(esc) = self.esc.clone() else { return };
        if esc[0] != b'.' {
            self.esc_error = 11;
            self.esc = None;
            return;
        }
        let Some(&letter) = esc.get(1) else { return };
        let done = |s: &mut Self| s.esc = None;
        match letter {
            b'B' => {
                match self.lying_now() {
                    Lie::NoRoom => self.answer("0"),
                    Lie::EscbGarbage => self.answer("#?&"),
                    Lie::EscbSilent => {}
                    _ => {
                        let f = self.free();
                        self.answer(&f.to_string());
                    }
                }
                done(self);
            }
            b'L' => {
                let n = self.cfg.buffer;
                self.answer(&n.to_string());
                done(self);
            }
            b'E' => {
                let e = std::mem::take(&mut self.esc_error);
                self.answer(&e.to_string());
                done(self);
            }
            b'K' => {
                self.buffer.clear();
                self.parse = Parse::Idle;
                self.busy_until = self.clock;
                self.stats.aborts += 1;
                self.flow();
                if self.lying_now() == Lie::EscbGarbage {
                    self.answer("K?");
                }
                done(self);
            }
            b'R' => {
                self.xon_enabled = false;
                self.xoff_sent = false;
                self.xoff_threshold = threshold(self.cfg.buffer);
                done(self);
            }
            b'J' => done(self),
            b'I' | b'N' | b'M' | b'@' | b'H' | b'T' | b'S' => {
                let Some(&last) = esc.last() else { return };
                if esc.len() > MAX_ESC {
                    self.esc_error = 14;
                    done(self);
                } else if last == b':' {
                    let params = String::from_utf8_lossy(&esc[2..esc.len() - 1]).into_owned();
                    let p: Vec<Option<usize>> = params.split(';').map(|x| x.trim().parse().ok()).collect();
                    match letter {
                        b'I' => {
                            if let Some(Some(t)) = p.first() {
                                if (1..=self.cfg.buffer).contains(t) {
                                    self.xoff_threshold = *t;
                                } else {
                                    self.esc_error = 13;
                                }
                            }
                        }
                        b'N' if self.cfg.xon_xoff && p.get(1).copied().flatten() == Some(usize::from(XOFF)) => {
                            self.xon_enabled = true;
                            self.flow();
                        }
                        _ => {}
                    }
                    done(self);
                }
            }
            _ => {
                self.esc_error = 11;
                done(self);
            }
        }
    }

    fn error(&mut self, code: u32) {
        self.stats.errors += 1;
        if self.oe == 0 {
            self.oe = code;
        }
    }

    /// One byte of HP-GL from the buffer.
    fn parse_byte(&mut self, b: u8) {
        match std::mem::replace(&mut self.parse, Parse::Idle) {
            Parse::Idle => {
                if b.is_ascii_alphabetic() {
                    self.parse = Parse::Letter(b.to_ascii_uppercase());
                } else if !(b.is_ascii_whitespace() || b == b';') {
                    self.error(1);
                }
            }
            Parse::Letter(a) => {
                if b.is_ascii_alphabetic() {
                    self.parse = Parse::Params {
                        mnemonic: [a, b.to_ascii_uppercase()],
                        number: String::new(),
                        numbers: Vec::new(),
                        pairs: 0,
                    };
                } else {
                    self.error(1);
                }
            }
            Parse::Params { mnemonic, mut number, mut numbers, mut pairs } => {
                let ends_number =
                    b == b',' || b == b' ' || b == b';' || b.is_ascii_alphabetic() || b == b'\n' || b == b'\r';
                if !ends_number {
                    if (b.is_ascii_digit() || b == b'-' || b == b'+' || b == b'.') && number.len() < MAX_NUMBER {
                        number.push(char::from(b));
                    } else if number.len() >= MAX_NUMBER {
                        self.error(3);
                    } else {
                        self.error(1);
                    }
                    self.parse = Parse::Params { mnemonic, number, numbers, pairs };
                    return;
                }
                if !number.is_empty() {
                    match number.parse::<f64>() {
                        // More parameters than any instruction takes are dropped (bounded memory): error 2.
                        Ok(_) if numbers.len() >= MAX_PARAMS => self.error(2),
                        Ok(v) => numbers.push(v),
                        Err(_) => self.error(3),
                    }
                    number.clear();
                    if numbers.len() == 2 && matches!(&mnemonic, b"PU" | b"PD" | b"PA") {
                        self.pen_command(&mnemonic, Some((numbers[0], numbers[1])));
                        numbers.clear();
                        pairs += 1;
                    }
                }
                if b == b';' || b.is_ascii_alphabetic() {
                    self.finish(&mnemonic, &numbers, pairs);
                    if b.is_ascii_alphabetic() {
                        self.parse = Parse::Letter(b.to_ascii_uppercase());
                    }
                } else {
                    self.parse = Parse::Params { mnemonic, number, numbers, pairs };
                }
            }
        }
    }

    /// The end of an instruction: `numbers` are its parameters not yet used (coordinate pairs ran already).
    fn finish(&mut self, mnemonic: &[u8; 2], numbers: &[f64], pairs: usize) {
        self.stats.instructions += 1;
        match mnemonic {
            b"PU" | b"PD" | b"PA" => {
                if !numbers.is_empty() {
                    self.error(2);
                } else if pairs == 0 {
                    self.pen_command(mnemonic, None);
                }
            }
            b"IN" => {
                self.lift();
                self.velocity = None;
                self.oe = 0;
            }
            b"SP" => {
                let n = numbers.first().copied().unwrap_or(0.0);
                if !(0.0..=f64::from(self.cfg.device.pens)).contains(&n) {
                    self.error(3);
                    return;
                }
                self.lift();
                // In 0..=pens, checked above.
                #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
                let n = n.trunc() as u32;
                if n != self.pen {
                    self.pen = n;
                    self.busy(PEN_CHANGE_S);
                }
            }
            b"VS" => match numbers.first() {
                Some(&v) if v > 0.0 && v <= 127.9 => self.velocity = Some(v),
                None => self.velocity = None,
                Some(_) => self.error(3),
            },
            b"OE" => {
                let e = std::mem::take(&mut self.oe);
                self.answer(&e.to_string());
            }
            b"OI" => {
                let id = self.cfg.device.identity;
                self.answer(id);
            }
            b"IW" | b"IP" | b"SC" | b"LT" | b"PS" | b"DF" | b"FS" | b"VA" | b"VN" => {}
            _ => self.error(1),
        }
    }

    /// `PU`/`PD`/`PA` with one coordinate pair (or none).
    fn pen_command(&mut self, mnemonic: &[u8; 2], to: Option<(f64, f64)>) {
        match mnemonic {
            b"PU" => self.lift(),
            b"PD" => self.lower(),
            _ => {}
        }
        let Some((x, y)) = to else { return };
        if x.abs() > 32_767.0 || y.abs() > 32_767.0 {
            self.error(6);
            return;
        }
        // Within ±32767, checked above.
        #[allow(clippy::cast_possible_truncation)]
        let to = (x.round() as i32, y.round() as i32);
        let d = f64::from(to.0 - self.pos.0).hypot(f64::from(to.1 - self.pos.1));
        let dev = self.cfg.device;
        let v = if self.down {
            cm_s_to_plu(self.velocity.unwrap_or(dev.max_velocity_cm_s).min(dev.max_velocity_cm_s))
        } else {
            cm_s_to_plu(dev.max_velocity_cm_s)
        };
        self.busy(move_seconds(d, v, accel_plu(dev)));
        self.pos = to;
        if self.down
            && let Some(l) = self.trace.last_mut().filter(|_| self.drawing)
        {
            l.push(to);
        }
    }

    fn lift(&mut self) {
        if self.down {
            self.down = false;
            self.drawing = false;
            self.busy(PEN_LIFT_S);
        }
    }

    fn lower(&mut self) {
        if !self.down && self.pen > 0 {
            self.down = true;
            self.drawing = true;
            self.trace.push(vec![self.pos]);
            self.busy(PEN_LIFT_S);
        }
    }

    fn busy(&mut self, s: f64) {
        self.busy_until = self.busy_until.max(self.clock) + s;
        self.busy_s += s;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use plotter_path::geometry::hpgl_devices::device;

    fn model(buffer: usize, xon_xoff: bool) -> HpglModel {
        HpglModel::new(ModelConfig { device: device("7475a").unwrap(), buffer, xon_xoff })
    }

    fn feed(m: &mut HpglModel, bytes: &[u8]) {
        for &b in bytes {
            m.receive(b);
        }
    }

    #[test]
    fn draws_answers_and_times_a_square() {
        let mut m = model(1024, true);
        feed(&mut m, b"IN;SP1;VS6;PU800,6240;PD1200,6240,1200,5840;PU;OI;OE;");
        m.run_until(100.0);
        assert_eq!(m.trace(), [vec![(800, 6240), (1200, 6240), (1200, 5840)]]);
        assert_eq!(m.take_output(), b"7475A\r0\r");
        assert!(m.pen_up() && m.idle());
        // Pen change 2 s, travel at top speed, two 400-unit sides at 6 cm/s, lowering and lifting.
        let a = 784_532.0;
        let travel = move_seconds((800f64 * 800.0 + 6240.0 * 6240.0).sqrt(), 15_240.0, a);
        let want = 2.0 + travel + 2.0 * move_seconds(400.0, 2400.0, a) + 2.0 * PEN_LIFT_S;
        assert!((m.busy_seconds() - want).abs() < 1e-9, "{} {want}", m.busy_seconds());
    }

    #[test]
    fn a_full_buffer_loses_bytes_and_says_so() {
        let mut m = model(10, true);
        feed(&mut m, b"PU100,100;PU200,200;");
        assert_eq!(m.stats().overflow, 10);
        feed(&mut m, b"\x1b.E\x1b.B");
        assert_eq!(m.take_output(), b"16\r0\r");
        feed(&mut m, b"\x1b.E");
        assert_eq!(m.take_output(), b"0\r", "ESC . E clears the error");
    }

    #[test]
    fn errors_are_reported_by_oe() {
        let mut m = model(1024, true);
        feed(&mut m, b"IN;SP7;OE;OE;XY;OE;PD1;OE;");
        m.run_until(10.0);
        assert_eq!(m.take_output(), b"3\r0\r1\r2\r", "pen 7 of 6, none, unknown, odd coordinates");
    }

    #[test]
    fn xon_xoff_only_when_supported_and_enabled() {
        for supported in [true, false] {
            let mut m = model(40, supported);
            feed(&mut m, b"\x1b.I10;;17:\x1b.N;19:");
            feed(&mut m, &[b'P'; 31]);
            assert_eq!(m.take_output(), if supported { vec![XOFF] } else { vec![] });
            assert!(!m.clear_to_send());
            // Draining to 20 free bytes (twice the threshold) sends Xon.
            m.run_until(1.0);
            assert_eq!(m.take_output(), if supported { vec![XON] } else { vec![] });
            assert!(m.clear_to_send());
        }
    }

    #[test]
    fn abort_graphics_empties_the_buffer() {
        let mut m = model(100, true);
        feed(&mut m, b"SP1;PD4000,4000;PU0,0;");
        // The pen change takes 2 s, then the 5657-unit diagonal takes more than 0.3 s.
        m.run_until(2.1);
        assert!(!m.idle());
        feed(&mut m, b"\x1b.KPU;SP0;");
        m.run_until(10.0);
        assert!(m.pen_up() && m.pen() == 0 && m.stats().aborts == 1);
        assert_eq!(m.position(), (4000, 4000), "the move under way stops (here: at its end), PU0,0 is dropped");
    }

    #[test]
    fn each_lie_starts_at_its_byte_count() {
        assert_eq!(Lie::parse("no-room"), Ok((Lie::NoRoom, 0)));
        assert_eq!(Lie::parse("escb-garbage@300"), Ok((Lie::EscbGarbage, 300)));
        assert!(Lie::parse("sulk").unwrap_err().contains("no-room, xoff-forever, chatter"));
        assert!(Lie::parse("chatter@x").is_err());
        // No room: honest until 10 bytes have entered the buffer, then ESC . B answers 0 with 1014 bytes free.
        let mut m = model(1024, true);
        m.set_lie(Lie::NoRoom, 10);
        feed(&mut m, b"\x1b.BPU100,100;\x1b.B");
        assert_eq!(m.take_output(), b"1024\r0\r");
        // Garbage: ESC . B and ESC . K answer what no plotter says; ESC . K still empties the buffer.
        let mut m = model(1024, true);
        m.set_lie(Lie::EscbGarbage, 0);
        feed(&mut m, b"PU100,100;\x1b.B\x1b.K");
        assert_eq!(m.take_output(), b"#?&\rK?\r");
        assert_eq!((m.free(), m.stats().aborts), (1024, 1));
        // Silent: no answer at all.
        let mut m = model(1024, true);
        m.set_lie(Lie::EscbSilent, 0);
        feed(&mut m, b"\x1b.B\x1b.L");
        assert_eq!(m.take_output(), b"1024\r");
    }

    #[test]
    fn xoff_forever_never_sends_xon_and_chatter_speaks_every_20_ms() {
        let mut m = model(40, true);
        feed(&mut m, b"\x1b.I10;;17:\x1b.N;19:");
        m.set_lie(Lie::XoffForever, 5);
        feed(&mut m, b"PU1,1;");
        m.run_until(1.0);
        assert_eq!(m.take_output(), vec![XOFF], "an Xoff once the lie starts");
        assert!(m.idle() && m.free() == 40);
        m.run_until(2.0);
        assert!(m.take_output().is_empty(), "no Xon with an empty buffer");
        let mut m = model(1024, true);
        m.set_lie(Lie::Chatter, 0);
        m.run_until(0.101);
        let out = m.take_output();
        assert_eq!(out.len(), 5 * CHATTER_LINE.len(), "at 20, 40, 60, 80 and 100 ms");
        assert!(out.starts_with(CHATTER_LINE));
        // It still plots.
        feed(&mut m, b"PU100,100;");
        m.run_until(1.0);
        assert_eq!(m.position(), (100, 100));
    }
}
