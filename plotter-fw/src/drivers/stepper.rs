//! The stepper: multi-axis Bresenham stepping in integer arithmetic, timed by a trapezoidal speed profile.
//!
//! # Blocks and events
//! A [`StepBlock`] moves each axis by a signed number of steps. Its *step events* are the ticks of the major axis
//! (the axis with the most steps, `n = max |Δ|` events): at every event the major axis steps, and each minor axis
//! steps when its Bresenham error term overflows. With the error term started at `⌊n/2⌋`, after `k` events a
//! minor axis with `|Δ| = d` has made exactly `⌊(k·d + ⌊n/2⌋)/n⌋` steps — the ideal `k·d/n` rounded — so it is
//! never more than half a step from the ideal line and ends with exactly `d` steps (the midpoint form of
//! Bresenham's line algorithm, generalised to several axes by giving each minor axis its own error term).
//!
//! Timing and the block contract are in [`crate::step_block`]: a block's step times are an integer recurrence
//! computed when the block is pushed ([`Stepper::push`], main context), so the timer interrupt ([`Stepper::tick`])
//! does integer adds, compares and pin writes only. A feed hold computes its deceleration the same way when it is
//! requested ([`Stepper::feed_hold`]); near a servo pen's drop commanded on the way it lands the pen on the stroke
//! instead (`stepper/landing.rs`, and [`Stepper::awaits_landing_move`]), waiting for the servo when the hold let it
//! swing on (`stepper/servo.rs`, [`Stepper::model_servo`]).

use crate::axis::{Axis, NUM_AXES};
use crate::config::PenConfig;
use crate::fmath::sqrt;
use crate::hal::{Endstops, StepPins, StepTimer};
use crate::step_block::{Cursor, Profile, StepBlock, StepTimes, Switches};

mod catch_up;
mod landing;
mod servo;

/// Depth of the stepper's own queue (the executing block is held separately). Blocks handed to the stepper are
/// frozen; the planner keeps re-planning the rest.
pub const STEPPER_QUEUE: usize = 2;

/// Feed-hold state of the stepper.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum HoldState {
    Running,
    /// Decelerating along step times computed when the hold was requested.
    Decelerating,
    /// Stopped with the queue kept.
    Stopped,
}

/// No stop inside the block.
const NO_STOP: u32 = u32::MAX;

/// Slots of the block ring: the executing block and the queue, rounded up to a power of two so that a slot index
/// is wrapped (and known to be in range) by a mask: no division, no bounds check in the interrupt.
const SLOTS: usize = (STEPPER_QUEUE + 1).next_power_of_two();

/// Wraps a ring slot index.
const SLOT_MASK: usize = SLOTS - 1;

/// The ring slot after `i`.
fn after(i: usize) -> usize {
    (i + 1) & SLOT_MASK
}

/// The ring slot `k` places after `i`.
fn nth_after(i: usize, k: usize) -> usize {
    (i + k) & SLOT_MASK
}

/// Most axes that step on some events only (every block has a major axis that steps at each event).
const MINORS: usize = NUM_AXES - 1;

// `Layout::minor_event` is written out for three minor axes.
const _: () = assert!(MINORS == 3);

/// An axis that steps on some of its block's events (`0 < |Δ| < n`): its Bresenham error term `e`, kept as the
/// room left below the step, `room = n − 1 − e`. An event takes `|Δ|` from it; when that borrows (`e + |Δ| ≥ n`)
/// the axis steps and `n` is added back — a subtraction, and on a step an add and an OR.
#[derive(Debug, Clone, Copy, Default)]
#[repr(C)]
struct Minor {
    room: u32,
    delta: u32,
    /// Its [`Axis::bit`].
    bit: u8,
    /// Its [`Axis::index`].
    axis: u8,
}

/// Most events of a block whose error terms fit the 16-bit lanes of [`Layout::fills`] (a guard bit above 15 bits).
const LANE_MAX: u32 = 0x7FFF;

/// The guard bit of each 16-bit lane of a [`Layout::fills`] word.
const GUARD: u32 = 0x8000_8000;

// The lanes hold the four axes, two per word.
const _: () = assert!(NUM_AXES == 4);

/// What the interrupt does at each event of a block, laid out when the block is pushed.
///
/// A block of at most [`LANE_MAX`] events keeps the error terms of all four axes in 16-bit lanes, two per word
/// (axis `i` in word `i / 2`, bits `16·(i % 2)..`), each as its *fill* `0x7FFF − room` (the room below the step as
/// a [`Minor`] keeps it, complemented: `e + 0x8000 − n`), below the lane's guard bit `0x8000`: one addition per word
/// gives every axis its `|Δ|`; a lane whose guard bit that sets has reached the step (the axis steps) and gives `n`
/// back — no branch, no per-axis work (an axis with `|Δ| = n` steps at every event, one with `|Δ| = 0` never). The
/// lanes cannot carry into each other: a fill stays below `0x8000` between events and gains at most
/// `n ≤ 0x7FFF`. (Guard bits that an addition sets are tested with an immediate mask: no register holds a
/// constant.) Longer blocks list the axes that step at every event, and the few that do not, as [`Minor`]s.
#[derive(Debug, Clone, Copy, Default)]
#[repr(C)]
struct Layout {
    /// The lanes' fills below their guard bits (a block of at most [`LANE_MAX`] events).
    fills: [u32; 2],
    /// The lanes' `|Δ|`.
    deltas: [u32; 2],
    /// Otherwise: axes with `|Δ| = n`, which step at every event, …
    always: u8,
    /// … and the minor axes; `minors` of them are used.
    minors: u8,
    minor: [Minor; MINORS],
}

/// One event of two lanes (see [`Layout`]): adds `delta` to `fill`, takes `n` back from the lanes that reached
/// their guard bit; returns those guard bits.
#[inline(always)]
fn lane_event(fill: &mut u32, delta: u32, n: u32) -> u32 {
    let x = fill.wrapping_add(delta);
    let stepped = x & GUARD;
    *fill = x.wrapping_sub((stepped >> 15).wrapping_mul(n));
    stepped
}

/// The axis mask of the guard bits [`lane_event`] returned for the low word (axes 0, 1 at bits 15, 31) and the high
/// word (axes 2, 3). `(low >> 2) | high` puts axes 0..=3 at bits 13, 29, 15, 31, all distinct; adding that word
/// shifted left by 15 copies bits 13 and 15 to 28 and 30 (no carries: the bits added are 0) and drops 29 and 31
/// off the top, so bits 28..=31 are axes 0..=3 in order: a shift, a shifted add and a shift, nothing above bit 3.
#[inline(always)]
fn gather_guards(low: u32, high: u32) -> u8 {
    let t = (low >> 2) | high;
    let top = t.wrapping_add(t << 15) >> 28;
    #[allow(clippy::cast_possible_truncation, reason = "the shift leaves four bits")]
    let mask = top as u8;
    mask
}

impl Layout {
    fn of(block: &StepBlock, n: u32) -> Self {
        let mut l = Layout::default();
        if n <= LANE_MAX {
            for axis in Axis::ALL {
                let i = axis.index();
                let d = block.steps[i].unsigned_abs();
                let shift = 16 * (i % 2);
                // Every lane starts with the error term ⌊n/2⌋: room n − 1 − ⌊n/2⌋ (none for a dwell).
                let room = if n > 0 { n - 1 - n / 2 } else { 0 };
                l.fills[i / 2] |= (LANE_MAX - room) << shift;
                l.deltas[i / 2] |= d << shift;
            }
            return l;
        }
        for axis in Axis::ALL {
            let d = block.steps[axis.index()].unsigned_abs();
            // n > LANE_MAX here: an axis with |Δ| = n moves.
            if d == n {
                l.always |= axis.bit();
            } else if d > 0
                // At most NUM_AXES − 1 axes are minor: the major one steps at every event.
                && let Some(m) = l.minor.get_mut(usize::from(l.minors))
            {
                #[allow(clippy::cast_possible_truncation, reason = "an axis index is below NUM_AXES")]
                let index = axis.index() as u8;
                *m = Minor { room: n - 1 - n / 2, delta: d, bit: axis.bit(), axis: index };
                l.minors += 1;
            }
        }
        l
    }

    /// One event of the Bresenham error terms: the mask of the axes that step.
    #[inline(always)]
    fn event(&mut self, n: u32) -> u8 {
        // The lanes' limit is a compare of `n`, already loaded: no flag to load.
        if n > LANE_MAX {
            return self.minor_event(n);
        }
        let low = lane_event(&mut self.fills[0], self.deltas[0], n);
        let high = lane_event(&mut self.fills[1], self.deltas[1], n);
        gather_guards(low, high)
    }

    /// [`Layout::event`] of a block too long for the lanes (out of line: the lanes are the straight path).
    #[cold]
    #[inline(never)]
    fn minor_event(&mut self, n: u32) -> u8 {
        // All three: an unused entry has |Δ| = 0 and bit 0, so it never borrows and adds nothing.
        self.always | self.minor[0].event(n) | self.minor[1].event(n) | self.minor[2].event(n)
    }

    /// Steps made by each axis (unsigned) after `k` of the `n` events: `k` for the axes of every event, and
    /// `(k·|Δ| + ⌊n/2⌋ − err)/n` for the others (exact: the error term is that sum's remainder). Main context.
    fn steps_after(&self, k: u32, n: u32) -> [u32; NUM_AXES] {
        let mut steps = [0; NUM_AXES];
        if n <= LANE_MAX {
            for (i, s) in steps.iter_mut().enumerate() {
                let shift = 16 * (i % 2);
                let room = LANE_MAX - ((self.fills[i / 2] >> shift) & LANE_MAX);
                let delta = (self.deltas[i / 2] >> shift) & 0xFFFF;
                *s = steps_of(k, n, room, delta);
            }
            return steps;
        }
        for axis in Axis::ALL {
            if self.always & axis.bit() != 0 {
                steps[axis.index()] = k;
            }
        }
        for m in &self.minor[..usize::from(self.minors)] {
            steps[usize::from(m.axis)] = steps_of(k, n, m.room, m.delta);
        }
        steps
    }
}

/// Steps of an axis with `|Δ| = delta` after `k` of `n` events, from its room: the error term is
/// `e = n − 1 − room` and `k·|Δ| + ⌊n/2⌋ = steps·n + e`.
fn steps_of(k: u32, n: u32, room: u32, delta: u32) -> u32 {
    let sum = (u64::from(k) * u64::from(delta) + u64::from(n / 2) + u64::from(room) + 1).saturating_sub(u64::from(n));
    u32::try_from(sum / u64::from(n.max(1))).unwrap_or(u32::MAX)
}

impl Minor {
    #[inline(always)]
    fn event(&mut self, n: u32) -> u8 {
        let (room, borrow) = self.room.overflowing_sub(self.delta);
        if borrow {
            self.room = room.wrapping_add(n);
            self.bit
        } else {
            self.room = room;
            0
        }
    }
}

/// A block in the stepper's ring (queued, or executing from where it was queued), its step times and per-event
/// layout already computed.
#[derive(Debug, Clone, Copy)]
struct Queued {
    block: StepBlock,
    profile: Profile,
    /// Step events.
    n: u32,
    /// The executing state at the block's first event, and the interval to it ([`Queued::prepare`]): loading the
    /// block in the interrupt is a copy.
    start: Active,
    first: u32,
    /// Axes that move, and the level of their direction pin (inversion applied).
    dir_axes: u8,
    dir_levels: u8,
    switches: Switches,
    /// A feed hold re-timed this block as the continuation of its deceleration.
    hold: bool,
    /// Event after which the hold stops ([`NO_STOP`]: none).
    stop_at: u32,
    /// A move planned to end moving (`exit_rate > 0` when pushed; a resume's re-profiling does not change it).
    exits_moving: bool,
    /// A servo block pushed after a move planned to end moving: a pen drop commanded on the way ([`landing`]).
    flying: bool,
    /// A move pushed right after a [`Queued::flying`] servo block: the rest of the travel the tip lands at the end
    /// of ([`landing`]).
    lands: bool,
    /// A servo block commanded while the previous command's swing is planned to be still under way: the ticks it
    /// waits when a hold defers it, the swing from that command's target to its own ([`servo`]; 0: none).
    swing_wait: u32,
}

impl Queued {
    /// Its execution time, ticks, as queued (its step times, possibly re-timed; a dwell takes at least one tick,
    /// as [`StepBlock::duration_ticks`] has it).
    fn duration_ticks(&self) -> u32 {
        if self.n == 0 { self.block.dwell_ticks.max(1) } else { self.profile.duration_ticks() }
    }

    /// Compute the executing state at the block's first event and the interval to it (main context, whenever the
    /// block's step times or stop change while it is queued).
    fn prepare(&mut self) {
        let home_mask = match self.switches {
            Switches::Limits => 0,
            Switches::Homing { axes } => axes,
        };
        let n = self.n;
        let mut act = Active {
            countdown: 0,
            runs: 0,
            n,
            cursor: self.profile.times().cursor(),
            layout: Layout::of(&self.block, n),
            target: 1,
            slot: 0,
            live: true,
            counted: home_mask != 0,
            limits: self.switches == Switches::Limits,
            offset: 0,
            home_mask,
            locked: 0,
            stop_at: self.stop_at,
        };
        self.first = if n == 0 {
            // A dwell of 0 ticks still takes one (the timer needs a delay ≥ 1).
            self.block.dwell_ticks.max(1)
        } else {
            let first = act.cursor.next(self.profile.times());
            act.arm(0, self.profile.times());
            first
        };
        self.start = act;
    }
}

/// The rate a decelerating hold carries out of the last block it has re-timed.
#[derive(Debug, Clone, Copy)]
struct Carry {
    /// Rate² at the block end, that block's units.
    v_sq: f32,
    /// That block's planned exit rate, for the conversion to the next block's units.
    planned_exit: u32,
}

impl Carry {
    /// The rate carried, in the units of `next`, the block after: converted by the ratio of the planned junction
    /// rates (`next`'s planned entry meets this carry's planned exit; events per mm differ from block to block).
    fn rate_into(&self, next: &StepBlock) -> f32 {
        #[allow(clippy::cast_precision_loss, reason = "rates are below 2^24, exact in f32")]
        let ratio = next.entry_rate as f32 / self.planned_exit as f32;
        sqrt(self.v_sq) * ratio
    }
}

/// The executing block's state (the block itself stays in its ring slot).
///
/// The interrupt's fast path runs while `countdown > 0`: it emits an event, counts down and returns the next
/// interval from the current segment of the step times, whose events it has taken ([`Cursor::reserve`]) for
/// the run. When the run ends and `runs > 0`, the next segment is entered and all its events are the next run: a
/// copy and a decrement, no comparison (the runs are whole segments: [`Active::arm`] ends them where a segment
/// ends, and the segment's events not taken stay 0 meanwhile). Everything else — the last event of the block, a
/// hold's last event, a dwell's end, a homing event, the idle stepper — is when both are 0, on the slow path.
///
/// Laid out in C order, the fields of the fast path first (near the struct's start: short load offsets).
#[derive(Debug, Clone, Copy)]
#[repr(C)]
struct Active {
    /// Events the fast path may still emit in the current run (the current segment's events it has taken).
    countdown: u32,
    /// Whole segments after the current run, each the next run, before the event at `target`.
    runs: u32,
    /// Events in the block.
    n: u32,
    cursor: Cursor,
    layout: Layout,
    /// The next event the slow path handles: the block's last, or where a hold stops; for a homing block (all its
    /// events on the slow path) the next event.
    target: u32,
    /// Ring slot of the block.
    slot: usize,
    /// A block is executing.
    live: bool,
    /// Homing: its steps are counted in the position at each event, not derived from the layout.
    counted: bool,
    /// The hard limits are armed (a [`Switches::Limits`] block).
    limits: bool,
    /// Event index the profile starts from (non-zero after a feed hold re-profiled the rest).
    offset: u32,
    /// Homing: axes stopped by their switch, and those already stopped.
    home_mask: u8,
    locked: u8,
    /// Event after which a feed hold stops ([`NO_STOP`]: none).
    stop_at: u32,
}

impl Active {
    /// No block executing.
    fn idle() -> Self {
        Active {
            countdown: 0,
            runs: 0,
            target: 1,
            n: 0,
            layout: Layout::default(),
            cursor: Cursor::default(),
            slot: 0,
            live: false,
            counted: false,
            limits: false,
            offset: 0,
            home_mask: 0,
            locked: 0,
            stop_at: NO_STOP,
        }
    }

    /// Become `from` (a prepared start), field by field: the compiler's whole-struct copy is a slow library call.
    #[inline(always)]
    fn load(&mut self, from: &Active) {
        self.countdown = from.countdown;
        self.runs = from.runs;
        self.n = from.n;
        self.cursor.set(&from.cursor);
        self.layout.fills = from.layout.fills;
        self.layout.deltas = from.layout.deltas;
        if from.n > LANE_MAX {
            // The list of a block too long for the lanes (a block on the lanes never reads it).
            self.layout.always = from.layout.always;
            self.layout.minors = from.layout.minors;
            self.layout.minor[0] = from.layout.minor[0];
            self.layout.minor[1] = from.layout.minor[1];
            self.layout.minor[2] = from.layout.minor[2];
        }
        self.target = from.target;
        self.live = from.live;
        self.counted = from.counted;
        self.limits = from.limits;
        self.offset = from.offset;
        self.home_mask = from.home_mask;
        self.locked = from.locked;
        self.stop_at = from.stop_at;
    }

    /// Events emitted so far, with `times` the block's step times (main context: it adds up the runs left).
    fn emitted(&self, times: &StepTimes) -> u32 {
        let seg = self.cursor.next_segment();
        let later: u32 = (0..self.runs as usize).map(|j| times.segment_known(seg + j).count).sum();
        self.target - 1 - self.countdown - later
    }

    /// After `k` events, the cursor at the interval after event `k` of `times`: hand the events before the next
    /// stop (block end or hold) to the fast path, the first run from the cursor's current segment, then whole
    /// segments. The slow path's next event (`target`) is the stop, or, should the stop fall inside a segment after
    /// the first (never, as the step times are cut: a block's and a hold's segments end at its last event), the
    /// event after the last whole segment before it: the slow path then goes on one event at a time.
    fn arm(&mut self, k: u32, times: &StepTimes) {
        self.cursor.give_back(self.countdown);
        if self.counted {
            self.target = k + 1;
            self.countdown = 0;
            self.runs = 0;
            return;
        }
        let goal = self.n.min(self.stop_at).max(k + 1);
        let avail = goal - k - 1;
        self.countdown = self.cursor.reserve(avail);
        // The current segment is used up when more is left (the cursor's events not taken are 0).
        let mut rest = avail - self.countdown;
        let mut runs = 0;
        // (A segment has at least one event: none fits once nothing is left.)
        while let Some(s) = times.segment(self.cursor.next_segment() + runs as usize)
            && s.count <= rest
        {
            rest -= s.count;
            runs += 1;
        }
        self.runs = runs;
        self.target = goal - rest;
    }
}

/// What stopped the stepper abnormally.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StepperFault {
    /// A switch was pressed outside homing (mask of the pressed axes).
    HardLimit(u8),
}

/// The stepper: a queue of [`StepBlock`]s and the executing block's Bresenham state.
#[derive(Debug)]
#[repr(C)]
pub struct Stepper {
    /// First: the interrupt's fields at the struct's start.
    act: Active,
    /// The executing block's slot (when one executes) is the one before `first`; `queued` blocks follow it.
    first: usize,
    queued: usize,
    /// Position in steps before the executing block's steps (which are added when it ends, or counted per event
    /// in a homing block).
    position: [i32; NUM_AXES],
    invert: u8,
    /// Axes whose switch, pressed during a normal move, is a hard-limit fault (0 disables).
    limit_mask: u8,
    hold: HoldState,
    /// While decelerating: the rate the hold carries into the next block pushed (`None`: it stops before it).
    carry: Option<Carry>,
    fault: Option<StepperFault>,
    /// Blocks finished since start.
    completed: u32,
    /// Result of the last homing block: axes whose switch stopped them.
    homing_hits: u8,
    /// Last: the block ring (the fields the slow path reads at a block end come before it, at short offsets).
    ring: [Queued; SLOTS],
    /// After a resume: the rate the last block handed over ends at, short of its plan, which the next pushed move
    /// starts from (`None`: none; main context only, see `catch_up.rs`).
    shortfall: Option<Carry>,
    /// The servo pen's modelled angle (`None`: no servo rate configured; main context only, see `servo.rs`).
    servo: Option<servo::ServoModel>,
}

impl Stepper {
    /// An idle stepper at position 0. `invert` is the mask of axes with an inverted direction pin; `limit_mask` the
    /// axes whose switch, pressed outside homing, is a hard-limit fault.
    pub fn new(invert: u8, limit_mask: u8) -> Self {
        let empty = StepBlock::dwell(0);
        let slot = Queued {
            block: empty,
            profile: empty.profile(),
            n: 0,
            start: Active::idle(),
            first: 1,
            dir_axes: 0,
            dir_levels: 0,
            switches: Switches::Limits,
            hold: false,
            stop_at: NO_STOP,
            exits_moving: false,
            flying: false,
            lands: false,
            swing_wait: 0,
        };
        Stepper {
            act: Active::idle(),
            ring: [slot; SLOTS],
            first: 0,
            queued: 0,
            position: [0; NUM_AXES],
            invert,
            limit_mask,
            hold: HoldState::Running,
            carry: None,
            shortfall: None,
            servo: None,
            fault: None,
            completed: 0,
            homing_hits: 0,
        }
    }

    /// Model the servo pen's angle with `pen`'s angles and swing time (`servo.rs`): a drop a feed hold defers while
    /// the lift before it still swings then waits for the servo. Without it (or when `pen` gives no rate) a
    /// deferred drop waits the plan's time only.
    pub fn model_servo(&mut self, pen: &PenConfig) {
        self.servo = servo::ServoModel::new(pen.servo_up_deg, pen.servo_down_deg, pen.servo_swing_ms);
    }

    /// Position in steps, as counted from emitted steps.
    pub fn position(&self) -> [i32; NUM_AXES] {
        let mut pos = self.position;
        if self.act.live && !self.act.counted && self.act.n > 0 {
            let times = self.ring[self.act.slot & SLOT_MASK].profile.times();
            let done = self.act.layout.steps_after(self.act.emitted(times), self.act.n);
            let steps = &self.ring[self.act.slot & SLOT_MASK].block.steps;
            for i in 0..NUM_AXES {
                let d = i32::try_from(done[i]).unwrap_or(i32::MAX);
                pos[i] += if steps[i] < 0 { -d } else { d };
            }
        }
        pos
    }

    /// Overwrite the position (G92, homing). Only while idle.
    pub fn set_position(&mut self, pos: [i32; NUM_AXES]) {
        self.position = pos;
    }

    /// Set one axis's position.
    pub fn set_axis_position(&mut self, axis: Axis, steps: i32) {
        self.position[axis.index()] = steps;
    }

    /// Whether another block can be queued.
    pub fn has_room(&self) -> bool {
        self.queued < STEPPER_QUEUE
    }

    /// Blocks queued plus the executing one.
    pub fn pending(&self) -> usize {
        self.queued + usize::from(self.act.live)
    }

    /// Nothing executing or queued.
    pub fn is_idle(&self) -> bool {
        !self.act.live && self.queued == 0
    }

    /// Axes stepping right now: those of the executing block (or, between two blocks, of the next one), none while
    /// a feed hold has stopped. A halt without deceleration may lose these axes' steps, and only these.
    pub fn moving_axes(&self) -> u8 {
        if self.hold == HoldState::Stopped {
            return 0;
        }
        let steps = if self.act.live {
            &self.ring[self.act.slot & SLOT_MASK].block.steps
        } else if self.queued > 0 {
            &self.ring[self.first & SLOT_MASK].block.steps
        } else {
            return 0;
        };
        Axis::ALL.iter().filter(|a| steps[a.index()] != 0).fold(0, |m, a| m | a.bit())
    }

    /// Blocks completed since start.
    pub fn completed(&self) -> u32 {
        self.completed
    }

    /// Axes stopped by their switch in the last homing block.
    pub fn homing_hits(&self) -> u8 {
        self.homing_hits
    }

    /// The latched fault, if any.
    pub fn fault(&self) -> Option<StepperFault> {
        self.fault
    }

    /// Queue a block (main context: its step times and per-event layout are computed here). `switches` says how
    /// the axis switches are treated during it (hard limits, or homing). Returns the block back when the queue is
    /// full.
    pub fn push(&mut self, block: StepBlock, switches: Switches) -> Result<(), StepBlock> {
        if self.queued >= STEPPER_QUEUE {
            return Err(block);
        }
        let n = block.events();
        let (mut dir_axes, mut dir_levels) = (0, 0);
        for axis in Axis::ALL {
            let s = block.steps[axis.index()];
            if s != 0 {
                dir_axes |= axis.bit();
                if (s < 0) ^ (self.invert & axis.bit() != 0) {
                    dir_levels |= axis.bit();
                }
            }
        }
        let planned_entry = block.entry_rate;
        let block = self.catch_up(block);
        let (flying, lands) = self.pushed_after(&block);
        let mut q = Queued {
            block,
            profile: block.profile(),
            n,
            start: Active::idle(),
            first: 1,
            dir_axes,
            dir_levels,
            switches,
            hold: false,
            stop_at: NO_STOP,
            exits_moving: n > 0 && block.exit_rate > 0,
            flying,
            lands,
            swing_wait: 0,
        };
        q.prepare();
        if let Some(servo) = &mut self.servo {
            q.swing_wait = servo.pushed(&block, q.duration_ticks());
        }
        // Never the executing block's slot: that one is just before `first`, and at most one block is queued.
        self.ring[nth_after(self.first, self.queued)] = q;
        self.queued += 1;
        match self.hold {
            HoldState::Decelerating => self.hold_pushed(),
            HoldState::Running if lands && block.entry_rate < planned_entry => self.slowed_landing_pushed(),
            _ => {}
        }
        Ok(())
    }

    /// If idle, start the next queued block: returns the ticks until its first event (the caller arms the timer).
    pub fn start<H: StepPins>(&mut self, hal: &mut H) -> Option<u32> {
        if self.act.live || self.fault.is_some() || self.hold != HoldState::Running {
            return None;
        }
        self.load_next(hal)
    }

    /// The switches read `pressed` (main context or the board's switch interrupt, never per step event): during a
    /// normal move, a pressed switch of an axis in the limit mask is a hard-limit fault — the stepper stops where
    /// it is and drops its queue. Returns whether it did (the caller stops the timer).
    pub fn limit_switches(&mut self, pressed: u8) -> bool {
        let hit = pressed & self.limit_mask;
        if hit == 0 || !self.act.live || !self.act.limits {
            return false;
        }
        self.fault = Some(StepperFault::HardLimit(hit));
        self.abort();
        true
    }

    /// Drop everything (reset or alarm): the executing block stops where it is.
    pub fn abort(&mut self) {
        self.position = self.position();
        self.queued = 0;
        self.act = Active::idle();
        self.hold = HoldState::Running;
        self.carry = None;
        self.shortfall = None;
        if let Some(servo) = &mut self.servo {
            servo.forget();
        }
    }

    /// Clear a latched fault (after reset).
    pub fn clear_fault(&mut self) {
        self.fault = None;
    }

    /// Request a feed hold (main context): decelerate to a stop at the block's acceleration, keeping the queue.
    /// The deceleration's step times are computed here, from the rate at the event already scheduled, for the
    /// executing block and as far into the queued ones as it reaches; the interrupt only follows them.
    pub fn feed_hold(&mut self) {
        if self.hold != HoldState::Running {
            return;
        }
        if !self.act.live {
            self.hold = HoldState::Stopped;
            return;
        }
        self.hold = HoldState::Decelerating;
        self.carry = None;
        if self.lands_now() {
            // The pen is landing: the hold stops where the tip lands, at the end of the travel ([`landing`]).
            return;
        }
        let act = &mut self.act;
        if act.n == 0 {
            // A dwell: the hold stops at its end; but a servo block between two moves (a drop commanded on the
            // way) hands the hold on to the move after it, which the carriage enters at its planned entry rate.
            let servo = self.ring[act.slot & SLOT_MASK].block.servo.is_some();
            if servo && self.queued > 0 {
                let entry = self.ring[self.first & SLOT_MASK].block.entry_rate;
                #[allow(clippy::cast_precision_loss, reason = "rates are below 2^24, exact in f32")]
                let v = entry as f32;
                let carry = (entry > 0).then_some(Carry { v_sq: v * v, planned_exit: entry });
                self.carry = self.hold_through(0, carry);
            }
            return;
        }
        let slot = &mut self.ring[act.slot & SLOT_MASK];
        let k = act.emitted(slot.profile.times());
        let scheduled = k + 1;
        if slot.block.accel == 0 {
            // No acceleration to slow down with: stop after the event already scheduled.
            act.stop_at = scheduled;
            act.arm(k, slot.profile.times());
            return;
        }
        let v = slot.profile.rate_at(scheduled - act.offset);
        let (times, left) = StepTimes::hold(act.cursor.time(), act.n - scheduled, v, slot.block.accel);
        // The new step times start with the interval after the scheduled event: nothing is taken from them yet.
        act.countdown = 0;
        act.cursor = times.cursor();
        slot.profile.set_times(times);
        if left.is_none() {
            // The stop comes within this block.
            act.stop_at = scheduled + times.events();
        }
        act.arm(k, slot.profile.times());
        if let Some(v_sq) = left {
            let carry = Some(Carry { v_sq, planned_exit: slot.block.exit_rate });
            self.carry = self.hold_through(0, carry);
        }
    }

    /// Whether a feed hold has brought the machine to rest.
    pub fn is_held(&self) -> bool {
        self.hold == HoldState::Stopped
    }

    /// Whether a feed hold is in progress or complete.
    pub fn is_holding(&self) -> bool {
        self.hold != HoldState::Running
    }

    /// Resume after a completed feed hold: the rest of the interrupted block and the queued blocks restart from
    /// rest and end at rest (the caller re-plans what follows from entry speed 0). Returns ticks until the next
    /// event, if any. While the hold is still decelerating it does nothing (the caller resumes once it stopped).
    pub fn resume<H: StepPins>(&mut self, hal: &mut H) -> Option<u32> {
        if self.hold != HoldState::Stopped {
            return None;
        }
        self.hold = HoldState::Running;
        self.carry = None;
        // Everything queued restarts from rest: a drop queued before the move it lands at would now be commanded
        // with that move still to run from rest, longer than planned.
        self.defer_queued_drops();
        self.note_resumed();
        for i in 0..self.queued {
            let q = &mut self.ring[nth_after(self.first, i)];
            q.block.entry_rate = 0;
            q.block.exit_rate = 0;
            q.profile = q.block.profile();
            q.hold = false;
            q.stop_at = NO_STOP;
            q.prepare();
        }
        if !self.act.live {
            return self.load_next(hal);
        }
        let act = &mut self.act;
        let slot = &mut self.ring[act.slot & SLOT_MASK];
        let k = act.emitted(slot.profile.times());
        act.offset = k;
        slot.profile = Profile::new(act.n - k, 0, slot.block.cruise_rate, 0, slot.block.accel);
        act.stop_at = NO_STOP;
        act.countdown = 0;
        act.cursor = slot.profile.times().cursor();
        let first = act.cursor.next(slot.profile.times());
        act.arm(k, slot.profile.times());
        Some(first)
    }

    /// Start the next queued block (its state was prepared when it was queued): directions, servo, a copy.
    fn load_next<H: StepPins>(&mut self, hal: &mut H) -> Option<u32> {
        self.load_next_inline(hal)
    }

    /// [`Stepper::load_next`] inlined into the caller: the block end in the interrupt's slow path, which is already
    /// out of line (a call there would save registers a second time).
    #[inline(always)]
    fn load_next_inline<H: StepPins>(&mut self, hal: &mut H) -> Option<u32> {
        if self.queued == 0 {
            return None;
        }
        let slot = self.first;
        self.first = after(slot);
        self.queued -= 1;
        let q = &self.ring[slot & SLOT_MASK];
        // Written out per axis (no loop through an array of the axes).
        set_dir(hal, Axis::X, q.dir_axes, q.dir_levels);
        set_dir(hal, Axis::Y, q.dir_axes, q.dir_levels);
        set_dir(hal, Axis::Z, q.dir_axes, q.dir_levels);
        set_dir(hal, Axis::E, q.dir_axes, q.dir_levels);
        if q.start.home_mask != 0 {
            self.homing_hits = 0;
        }
        if let Some(tenths) = q.block.servo {
            hal.set_servo(f32::from(tenths) / 10.0);
        }
        self.act.load(&q.start);
        self.act.slot = slot;
        Some(q.first)
    }

    /// The executing block is done: count it and go on with the next one, unless a hold stops here.
    #[inline(always)]
    fn finish_block<H: StepPins>(&mut self, hal: &mut H) -> Option<u32> {
        if !self.act.counted {
            let steps = &self.ring[self.act.slot & SLOT_MASK].block.steps;
            // Written out per axis (no loop through a copy).
            self.position[0] += steps[0];
            self.position[1] += steps[1];
            self.position[2] += steps[2];
            self.position[3] += steps[3];
        }
        self.act.live = false;
        self.completed = self.completed.wrapping_add(1);
        if self.hold != HoldState::Running && !(self.queued > 0 && self.ring[self.first & SLOT_MASK].hold) {
            self.hold = HoldState::Stopped;
            return None;
        }
        self.load_next_inline(hal)
    }

    /// The timer interrupt: emit the due step event and return the ticks until the next one (`None`: idle,
    /// held or faulted — the caller stops the timer). Integer adds, compares and pin writes only.
    #[inline(always)]
    pub fn tick<H: StepPins + Endstops>(&mut self, hal: &mut H) -> Option<u32> {
        let mut run = self.act.countdown;
        if run == 0 {
            if self.act.runs == 0 {
                return self.tick_slow(hal);
            }
            run = self.next_run();
        }
        Some(self.plain_event(hal, run).1)
    }

    /// The step timer's interrupt: [`Stepper::tick`], then the timer aimed at the next event
    /// ([`StepTimer::schedule_next`]) or stopped. Returns whether it runs on: [`Stepper::on_timer_fast`], else
    /// [`Stepper::on_timer_slow`].
    #[inline(always)]
    pub fn on_timer<H: StepPins + Endstops + StepTimer>(&mut self, hal: &mut H) -> bool {
        self.on_timer_fast(hal) || self.on_timer_slow(hal)
    }

    /// [`Stepper::on_timer`]'s events in the middle of a block (a plain event, or one that enters the next segment):
    /// returns whether it was one (and handled it); `false` leaves the event to [`Stepper::on_timer_slow`]. Inlined
    /// into the board's interrupt handler, straight through to the timer's compare register, and schedules with
    /// what its pin write returned ([`StepTimer::schedule_next_from`]: a board reads its counter once per event).
    /// It calls nothing but in tail position (a block too long for the lanes), so the handler needs no stack
    /// alignment and no more saved registers than its own work.
    #[inline(always)]
    pub fn on_timer_fast<H: StepPins + StepTimer>(&mut self, hal: &mut H) -> bool {
        let mut run = self.act.countdown;
        if run == 0 {
            if self.act.runs == 0 {
                return false;
            }
            run = self.next_run();
        }
        if self.act.n > LANE_MAX {
            return self.on_timer_long(hal, run);
        }
        let (read, interval) = self.plain_event(hal, run);
        hal.schedule_next_from(read, interval);
        true
    }

    /// [`Stepper::on_timer_fast`]'s event of a block too long for the lanes, out of line.
    #[cold]
    #[inline(never)]
    fn on_timer_long<H: StepPins + StepTimer>(&mut self, hal: &mut H, run: u32) -> bool {
        let (read, interval) = self.plain_event(hal, run);
        hal.schedule_next_from(read, interval);
        true
    }

    /// [`Stepper::on_timer`] off the fast path (when [`Stepper::on_timer_fast`] returned `false`): the block's last
    /// event, a hold's stop, a dwell's end, a homing event, a stale event. Returns whether the timer runs on. The
    /// caller keeps it out of its interrupt handler's straight path.
    #[inline(always)]
    pub fn on_timer_slow<H: StepPins + Endstops + StepTimer>(&mut self, hal: &mut H) -> bool {
        match self.tick_slow(hal) {
            Some(interval) => {
                hal.schedule_next(interval);
                true
            }
            None => {
                hal.cancel();
                false
            }
        }
    }

    /// The fast path, `run` (≥ 1) events left in the current run (`countdown`, or a run just entered): a countdown,
    /// the Bresenham terms of the block's moving axes, the pin write and the time recurrence (an event of the run,
    /// already taken from its segment). Returns what the pin write returned ([`StepPins::step_axes_read`], for
    /// [`StepTimer::schedule_next_from`]) and the interval.
    #[inline(always)]
    fn plain_event<H: StepPins>(&mut self, hal: &mut H, run: u32) -> (u32, u32) {
        let act = &mut self.act;
        act.countdown = run - 1;
        let read = hal.step_axes_read(act.layout.event(act.n));
        (read, act.cursor.advance())
    }

    /// The run ended with runs left (`countdown == 0 < runs`): enter the next segment, all its events the next run;
    /// returns them (the caller's event takes the first and stores the countdown). That segment exists (the runs
    /// are segments after the current one), so it is read by its index ([`StepTimes::segment_known`]), with no
    /// fallback past the last.
    #[inline(always)]
    fn next_run(&mut self) -> u32 {
        let act = &mut self.act;
        let times = self.ring[act.slot & SLOT_MASK].profile.times();
        act.runs -= 1;
        act.cursor.enter_whole(times.segment_known(act.cursor.next_segment()))
    }

    /// Everything but a plain event in the middle of a block. Inlined into its callers: the interrupt reaches it
    /// through [`Stepper::on_timer_slow`], which its caller keeps out of line, so a second call there would only save
    /// registers twice.
    #[inline(always)]
    fn tick_slow<H: StepPins + Endstops>(&mut self, hal: &mut H) -> Option<u32> {
        if !self.act.live || self.hold == HoldState::Stopped {
            // Not running (idle, held, or stopped by an abort): the timer was stopped when it stopped, so this is a
            // stale event (a board that does not mask its timer's flags with the interrupt enables may see one).
            // Nothing to emit, and no block to start: only `start` and `resume` start the stepper.
            return None;
        }
        if self.act.n == 0 {
            // A dwell ended.
            return self.finish_block(hal);
        }
        let k = self.act.target;
        let mut mask = self.act.layout.event(self.act.n);
        if self.act.counted {
            // Homing: the switches are read at each event; an axis stops the moment its switch reads pressed.
            let act = &mut self.act;
            let pressed = hal.pressed() & act.home_mask;
            if pressed != 0 {
                act.locked |= pressed;
                self.homing_hits = act.locked;
                if act.locked == act.home_mask {
                    self.act.live = false;
                    self.completed = self.completed.wrapping_add(1);
                    return self.load_next(hal);
                }
            }
            mask &= !act.locked;
            let steps = &self.ring[act.slot & SLOT_MASK].block.steps;
            for axis in Axis::ALL {
                let i = axis.index();
                if mask & axis.bit() != 0 {
                    self.position[i] += steps[i].signum();
                }
            }
        }
        if mask != 0 {
            hal.step_axes(mask);
        }
        // `k` events emitted (what a hold that stops here leaves).
        self.act.target = k + 1;
        self.act.countdown = 0;
        self.act.runs = 0;
        if k == self.act.n {
            return self.finish_block(hal);
        }
        if k == self.act.stop_at {
            self.hold = HoldState::Stopped;
            return None;
        }
        let act = &mut self.act;
        let times = self.ring[act.slot & SLOT_MASK].profile.times();
        let interval = act.cursor.next(times);
        act.arm(k, times);
        Some(interval)
    }
}

/// Set `axis`'s direction pin to its bit of `levels` if it is one of `axes`.
#[inline(always)]
fn set_dir<H: StepPins>(hal: &mut H, axis: Axis, axes: u8, levels: u8) {
    if axes & axis.bit() != 0 {
        hal.set_dir(axis, levels & axis.bit() != 0);
    }
}

/// A hold decelerating through a block boundary: re-time the queued block `q` to keep slowing down from the rate
/// reached (`carry`, converted by the ratio of the planned junction rates). Returns the rate carried out of `q`,
/// `None` when the hold stops within it or before it (a dwell, a block without acceleration, no speed left). A
/// servo block the carriage enters moving (a pen drop commanded on the way, between two moves) is no stop: the
/// hold runs through it (the servo is set as planned) and carries the same rate on into the move after it — unless
/// that move is queued too, when the drop is deferred past it ([`landing`]).
fn continue_hold(carry: Carry, q: &mut Queued) -> Option<Carry> {
    if landing::runs_through(&carry, q) {
        q.hold = true;
        return Some(carry);
    }
    if carry.v_sq <= 0.0 || carry.planned_exit == 0 || q.block.is_dwell() || q.block.accel == 0 {
        return None;
    }
    let v = carry.rate_into(&q.block);
    let n = q.block.events();
    let (times, left) = StepTimes::hold(q.profile.times().cursor().time(), n, v, q.block.accel);
    if times.events() == 0 && left.is_none() {
        // Not even one more step: stop before this block's first event.
        return None;
    }
    q.profile.set_times(times);
    q.hold = true;
    let carried = match left {
        None => {
            q.stop_at = times.events();
            None
        }
        Some(v_sq) => Some(Carry { v_sq, planned_exit: q.block.exit_rate }),
    };
    q.prepare();
    carried
}

/// A move for the stepper's tests: `steps` ([X, Y] events) entered at `entry`, cruising at `cruise` and left at
/// `exit` events/s, with `accel` events/s².
#[cfg(test)]
fn test_move(steps: [i32; 2], entry: u32, cruise: u32, exit: u32, accel: u32) -> StepBlock {
    StepBlock {
        steps: [steps[0], steps[1], 0, 0],
        entry_rate: entry,
        cruise_rate: cruise,
        exit_rate: exit,
        accel,
        dwell_ticks: 0,
        servo: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Records steps per tick; switches pressed at or below `switch_at` (per axis, when set).
    #[derive(Default)]
    struct Rec {
        dir: [bool; NUM_AXES],
        pos: [i64; NUM_AXES],
        dir_changes_during_block: u32,
        steps: [u32; NUM_AXES],
        switch_at: [Option<i64>; NUM_AXES],
        reads: u32,
    }
    impl StepPins for Rec {
        fn set_dir(&mut self, axis: Axis, level: bool) {
            self.dir[axis.index()] = level;
            self.dir_changes_during_block += 1;
        }
        fn step(&mut self, axis: Axis) {
            let i = axis.index();
            self.pos[i] += if self.dir[i] { -1 } else { 1 };
            self.steps[i] += 1;
        }
        fn enable_motors(&mut self, _on: bool) {}
    }
    impl Endstops for Rec {
        fn pressed(&mut self) -> u8 {
            self.reads += 1;
            (0..NUM_AXES).filter(|&i| self.switch_at[i].is_some_and(|at| self.pos[i] <= at)).fold(0, |m, i| m | 1 << i)
        }
    }

    fn as_i32(pos: &[i64; NUM_AXES]) -> [i32; NUM_AXES] {
        pos.map(|p| i32::try_from(p).unwrap())
    }

    fn run(block: StepBlock, mut check: impl FnMut(u32, &[i64; NUM_AXES])) -> (Rec, u64) {
        let mut s = Stepper::new(0, 0);
        let mut hal = Rec::default();
        s.push(block, Switches::Limits).unwrap();
        let mut t = u64::from(s.start(&mut hal).unwrap());
        let mut k = 0;
        while let Some(iv) = s.tick(&mut hal) {
            k += 1;
            check(k, &hal.pos);
            // The position the stepper reports (derived from its error terms) is the steps emitted, at every event.
            assert_eq!(s.position(), as_i32(&hal.pos), "event {k}");
            t += u64::from(iv);
        }
        assert_eq!(s.position(), as_i32(&hal.pos));
        assert_eq!(hal.reads, 0, "no switch read outside homing");
        // The last tick returned None at the last event; `t` is the time of that last event.
        (hal, t)
    }

    #[test]
    fn cruise_only_block_times() {
        let b = StepBlock {
            steps: [100, 0, 0, 0],
            entry_rate: 1000,
            cruise_rate: 1000,
            exit_rate: 1000,
            accel: 0,
            dwell_ticks: 0,
            servo: None,
        };
        assert_eq!(b.duration_ticks(), 100_000);
        let (hal, t) = run(b, |_, _| {});
        assert_eq!(hal.pos[0], 100);
        assert_eq!(t, 100_000);
    }

    #[test]
    fn trapezoid_matches_analytic_time() {
        // 0 → 1000 steps/s at 10000 steps/s²: 0.1 s and 50 steps each way, 900 steps cruise = 0.9 s.
        let b = StepBlock {
            steps: [1000, -300, 0, 0],
            entry_rate: 0,
            cruise_rate: 1000,
            exit_rate: 0,
            accel: 10_000,
            dwell_ticks: 0,
            servo: None,
        };
        assert_eq!(b.duration_ticks(), 1_100_000);
        let (hal, t) = run(b, |_, _| {});
        assert_eq!(hal.pos, [1000, -300, 0, 0]);
        assert_eq!(t, 1_100_000);
        // First event: √(2/a) = 14.142 ms.
        assert_eq!(b.profile().times().cursor().next(b.profile().times()), 14_142);
    }

    #[test]
    fn triangle_and_unreachable_exit() {
        let b = StepBlock {
            steps: [10, 0, 0, 0],
            entry_rate: 0,
            cruise_rate: 10_000,
            exit_rate: 0,
            accel: 1000,
            dwell_ticks: 0,
            servo: None,
        };
        let p = b.profile();
        // Peak √(a·n) = 100; time 2·100/1000 = 0.2 s.
        assert!((p.peak_rate() - 100.0).abs() < 1e-3);
        assert_eq!(p.duration_ticks(), 200_000);
        let b = StepBlock {
            steps: [10, 0, 0, 0],
            entry_rate: 0,
            cruise_rate: 10_000,
            exit_rate: 5000,
            accel: 1000,
            dwell_ticks: 0,
            servo: None,
        };
        let p = b.profile();
        assert!((p.exit_rate() - 141.42136).abs() < 1e-2);
    }

    #[test]
    fn dwell_lasts_its_ticks() {
        let mut s = Stepper::new(0, 0);
        let mut hal = Rec::default();
        s.push(StepBlock::dwell(5000), Switches::Limits).unwrap();
        assert_eq!(s.start(&mut hal), Some(5000));
        assert_eq!(s.tick(&mut hal), None);
        assert!(s.is_idle());
        assert_eq!(s.completed(), 1);
    }

    #[test]
    fn inverted_dir_pin() {
        let mut s = Stepper::new(Axis::Y.bit(), 0);
        let mut hal = Rec::default();
        s.push(StepBlock { steps: [0, 5, 0, 0], cruise_rate: 100, ..StepBlock::default() }, Switches::Limits).unwrap();
        s.start(&mut hal);
        while s.tick(&mut hal).is_some() {}
        assert_eq!(hal.pos[1], -5, "pin level inverted, physical motion reversed");
        assert_eq!(s.position()[1], 5, "logical position unaffected");
    }

    #[test]
    fn feed_hold_stops_and_resume_finishes_exactly() {
        let mut s = Stepper::new(0, 0);
        let mut hal = Rec::default();
        let b = StepBlock {
            steps: [4000, 1000, 0, 0],
            entry_rate: 0,
            cruise_rate: 4000,
            exit_rate: 0,
            accel: 20_000,
            dwell_ticks: 0,
            servo: None,
        };
        s.push(b, Switches::Limits).unwrap();
        s.push(b, Switches::Limits).unwrap();
        s.start(&mut hal);
        for _ in 0..2000 {
            s.tick(&mut hal).unwrap();
        }
        s.feed_hold();
        let mut during = 0;
        while s.tick(&mut hal).is_some() {
            during += 1;
        }
        assert!(s.is_held());
        // Stopping from 4000 steps/s at 20000 steps/s² takes 400 steps.
        assert!((395..=401).contains(&during), "{during}");
        // The rest of the first block runs from rest to rest: its first and its last interval are both
        // √(2/a) = √(2/20 000) s = 10 000 µs (to the ramps' accuracy: 1 tick + 0.025 % of the 0.2 s ramp at each end).
        // (`tick` returns the interval to the next event: the one before the event that ends the block is the
        // value returned by the tick before it.)
        let first = s.resume(&mut hal).expect("resumed");
        assert!((9_898..=10_102).contains(&first), "{first}");
        let (mut before, mut last_of_first) = (first, None);
        while let Some(iv) = s.tick(&mut hal) {
            if hal.pos[0] == 4000 && last_of_first.is_none() {
                last_of_first = Some(before);
            }
            before = iv;
        }
        let last = last_of_first.expect("the first block ends");
        assert!((9_898..=10_102).contains(&last), "{last}");
        assert!(s.is_idle());
        assert_eq!(hal.pos, [8000, 2000, 0, 0]);
    }

    /// 3000 X events toward 4000 events/s at 20 000 events/s², entering and leaving at the given rates.
    fn ramp_3000(entry: u32, exit: u32) -> StepBlock {
        super::test_move([3000, 0], entry, 4000, exit, 20_000)
    }

    #[test]
    fn a_block_pushed_while_a_hold_decelerates_continues_the_hold() {
        // As in `feed_hold_decelerates_through_a_block_boundary`, but the second block arrives only after the hold
        // began: it is re-timed as the hold's continuation when pushed, so the stop is the same 399 events after
        // the scheduled one, 299 of them in the second block.
        let mut s = Stepper::new(0, 0);
        let mut hal = Rec::default();
        s.push(ramp_3000(0, 4000), Switches::Limits).unwrap();
        s.start(&mut hal);
        for _ in 0..2899 {
            s.tick(&mut hal).unwrap();
        }
        s.feed_hold();
        for _ in 0..10 {
            s.tick(&mut hal).unwrap();
        }
        s.push(ramp_3000(4000, 0), Switches::Limits).unwrap();
        while s.tick(&mut hal).is_some() {}
        assert!(s.is_held());
        assert_eq!((hal.pos[0], s.completed()), (2900 + 399, 1));
    }

    #[test]
    fn feed_hold_decelerates_through_a_block_boundary() {
        let mut s = Stepper::new(0, 0);
        let mut hal = Rec::default();
        s.push(ramp_3000(0, 4000), Switches::Limits).unwrap();
        s.push(ramp_3000(4000, 0), Switches::Limits).unwrap();
        s.start(&mut hal);
        for _ in 0..2899 {
            s.tick(&mut hal).unwrap();
        }
        // `start` scheduled event 1 and each tick emitted one: event 2899 emitted, 2900 scheduled (cruise).
        s.feed_hold();
        let mut intervals = std::vec::Vec::new();
        while let Some(iv) = s.tick(&mut hal) {
            intervals.push(iv);
        }
        assert!(s.is_held());
        // From 4000 events/s at 20 000 events/s²: v² − 2aj > 0 for j < 400, so 399 events after the scheduled one;
        // 100 of them finish the first block, the other 299 run in the second.
        assert_eq!(hal.pos[0], 2900 + 399);
        assert_eq!(s.completed(), 1);
        // Slowing down all the way, across the boundary too: from the scheduled cruise interval (250 µs) on, no
        // interval is shorter than the one before by more than the rounding of the two event times around it.
        assert_eq!(intervals[0], 250);
        assert!(intervals.windows(2).all(|w| w[1] + 2 >= w[0]), "{intervals:?}");
        // The last interval: events 398 and 399 of the stop at (v − √(v² − 2aj))/a, i.e.
        // (√(16·10⁶ − 40 000·398) − √(16·10⁶ − 40 000·399))/20 000 s = (√80 000 − √40 000)/0.02 µs = 4142.1 µs.
        let last = *intervals.last().unwrap();
        assert!((4140..=4144).contains(&last), "{last}");
        assert!(s.resume(&mut hal).is_some());
        while s.tick(&mut hal).is_some() {}
        assert!(s.is_idle());
        assert_eq!(hal.pos[0], 6000);
        assert_eq!(s.completed(), 2);
        // Later, a hold during a dwell with nothing queued stops at its end, whatever the ring slots still
        // remember of the re-timed block: the blocks went into slots 0 and 1, the dwells go into 2, 3 and 0, so
        // during the third the slot after it is the second block's, which the hold above had marked.
        for _ in 0..2 {
            s.push(StepBlock::dwell(10), Switches::Limits).unwrap();
            s.start(&mut hal);
            assert_eq!(s.tick(&mut hal), None);
        }
        s.push(StepBlock::dwell(10), Switches::Limits).unwrap();
        s.start(&mut hal);
        assert_eq!((s.act.slot, s.first, s.queued), (0, 1, 0));
        assert!(s.ring[1].hold, "the stale mark");
        s.feed_hold();
        assert_eq!(s.tick(&mut hal), None);
        assert!(s.is_held());
        assert_eq!(s.completed(), 5);
    }

    #[test]
    fn a_hold_ending_with_a_dwell_stops_before_a_queued_block_it_did_not_retime() {
        let mut s = Stepper::new(0, 0);
        let mut hal = Rec::default();
        s.push(StepBlock::dwell(10), Switches::Limits).unwrap();
        let mv = StepBlock {
            steps: [5, 0, 0, 0],
            entry_rate: 0,
            cruise_rate: 1000,
            exit_rate: 0,
            accel: 0,
            dwell_ticks: 0,
            servo: None,
        };
        s.push(mv, Switches::Limits).unwrap();
        assert_eq!(s.start(&mut hal), Some(10));
        // A hold during the dwell stops at its end; the queued move (not a hold continuation) waits, unstarted.
        s.feed_hold();
        assert_eq!(s.tick(&mut hal), None);
        assert!(s.is_held());
        assert_eq!((s.completed(), s.pending(), hal.pos[0]), (1, 1, 0));
        // Resumed, the move runs from rest: 5 events 1 ms apart.
        assert_eq!(s.resume(&mut hal), Some(1000));
        let mut intervals = std::vec::Vec::new();
        while let Some(iv) = s.tick(&mut hal) {
            intervals.push(iv);
        }
        assert_eq!(intervals, [1000; 4]);
        assert_eq!((s.completed(), hal.pos[0]), (2, 5));
    }

    /// A timer event the stepper did not ask for (a board that does not mask its timer's flags may pass on a stale
    /// compare flag) while it is idle, held at a block end, held in the middle of a block or stopped by an abort:
    /// nothing steps, nothing starts, and it asks for the timer to stop.
    #[test]
    fn a_stale_timer_event_while_stopped_steps_nothing_and_starts_nothing() {
        let mv = StepBlock { steps: [40, 7, 0, 0], cruise_rate: 1000, ..StepBlock::default() };
        let stale = |s: &mut Stepper, hal: &mut Rec| {
            let (pos, pending, completed) = (hal.pos, s.pending(), s.completed());
            for _ in 0..3 {
                assert_eq!(s.tick(hal), None);
            }
            assert_eq!((hal.pos, s.pending(), s.completed()), (pos, pending, completed));
        };
        // Idle with a block queued but not started.
        let mut s = Stepper::new(0, 0);
        let mut hal = Rec::default();
        s.push(mv, Switches::Limits).unwrap();
        stale(&mut s, &mut hal);
        assert_eq!(hal.pos, [0; NUM_AXES]);
        // Held at the end of a dwell, the move queued behind it.
        let mut s = Stepper::new(0, 0);
        s.push(StepBlock::dwell(10), Switches::Limits).unwrap();
        s.push(mv, Switches::Limits).unwrap();
        s.start(&mut hal).unwrap();
        s.feed_hold();
        assert_eq!(s.tick(&mut hal), None);
        assert!(s.is_held());
        stale(&mut s, &mut hal);
        // Held in the middle of a move without acceleration: it stops after the event already scheduled (the 11th).
        let mut s = Stepper::new(0, 0);
        let mut hal = Rec::default();
        s.push(mv, Switches::Limits).unwrap();
        s.start(&mut hal).unwrap();
        for _ in 0..10 {
            s.tick(&mut hal).unwrap();
        }
        s.feed_hold();
        assert_eq!(s.tick(&mut hal), None);
        assert!(s.is_held());
        assert_eq!(hal.pos, [11, 2, 0, 0]);
        stale(&mut s, &mut hal);
        // The resume goes on from there and ends exactly.
        assert!(s.resume(&mut hal).is_some());
        while s.tick(&mut hal).is_some() {}
        assert_eq!(hal.pos, [40, 7, 0, 0]);
        // Stopped by an abort in the middle of a move, another block queued afterwards.
        s.push(mv, Switches::Limits).unwrap();
        s.start(&mut hal).unwrap();
        s.tick(&mut hal).unwrap();
        s.abort();
        s.push(mv, Switches::Limits).unwrap();
        stale(&mut s, &mut hal);
        // One event of the aborted move (its Y steps come from the third event on).
        assert_eq!((hal.pos, s.position()), ([41, 7, 0, 0], [41, 7, 0, 0]));
    }

    #[test]
    fn the_guard_bits_gather_into_the_axis_mask() {
        // Every combination of the four guard bits: axis 0 at bit 15 and axis 1 at bit 31 of the low word, axes 2
        // and 3 at the same bits of the high word.
        for mask in 0..16u8 {
            let bit = |axis: u8, at: u32| u32::from(mask >> axis & 1) << at;
            let (low, high) = (bit(0, 15) | bit(1, 31), bit(2, 15) | bit(3, 31));
            assert_eq!(gather_guards(low, high), mask, "{low:#x} {high:#x}");
        }
    }

    /// A stop inside a segment after the current run (the step times never put one there, but `arm` must not
    /// run past it): the fast path's runs end at the last whole segment before it, the slow path takes the events
    /// from there one at a time, and the stepper stops after exactly the stop's event, on the same intervals.
    #[test]
    fn a_stop_inside_a_later_segment_is_reached_event_by_event() {
        let b = StepBlock { steps: [200, 70, 0, 0], cruise_rate: 2000, accel: 40_000, ..StepBlock::default() };
        let (mut s, mut twin) = (Stepper::new(0, 0), Stepper::new(0, 0));
        let (mut hal, mut twin_hal) = (Rec::default(), Rec::default());
        s.push(b, Switches::Limits).unwrap();
        twin.push(b, Switches::Limits).unwrap();
        assert_eq!(s.start(&mut hal), twin.start(&mut twin_hal));
        for _ in 0..80 {
            assert_eq!(s.tick(&mut hal), twin.tick(&mut twin_hal));
        }
        // The first event of a segment of at least 3 events, well after the current run; the stop one event later.
        let times = *s.ring[s.act.slot].profile.times();
        let (mut first, mut at) = (1, None);
        for seg in times.segments() {
            if first > 160 && seg.count >= 3 {
                at = Some(first);
                break;
            }
            first += seg.count;
        }
        let first = at.expect("a long enough segment in the deceleration");
        let stop = first + 1;
        s.act.stop_at = stop;
        s.act.arm(80, &times);
        // The runs' last interval is the one to event `first − 1`, the last of the segment before: the slow path
        // takes that event, and from there one at a time.
        assert_eq!(s.act.target, first - 1, "the runs end before the segment with the stop");
        assert_eq!(s.act.emitted(&times), 80);
        let mut events = 80;
        while let Some(iv) = s.tick(&mut hal) {
            events += 1;
            assert_eq!(Some(iv), twin.tick(&mut twin_hal), "event {events}");
            assert_eq!(hal.pos, twin_hal.pos);
        }
        // The stop's event is emitted (its interval was the one before), then the stepper holds.
        twin.tick(&mut twin_hal);
        assert_eq!((events + 1, s.is_held(), hal.pos, s.position()), (stop, true, twin_hal.pos, as_i32(&hal.pos)));
    }

    #[test]
    fn re_arming_in_the_middle_of_a_run_gives_its_events_back() {
        // 0 → 2000 → 0 events/s at 40 000 events/s²: 50 events each way, the cruise's intervals (to events
        // 51..=150) one segment.
        let b = StepBlock { steps: [200, 0, 0, 0], cruise_rate: 2000, accel: 40_000, ..StepBlock::default() };
        let (mut s, mut twin) = (Stepper::new(0, 0), Stepper::new(0, 0));
        let mut hal = Rec::default();
        for st in [&mut s, &mut twin] {
            st.push(b, Switches::Limits).unwrap();
            st.start(&mut hal);
            for _ in 0..80 {
                st.tick(&mut hal).unwrap();
            }
        }
        // 80 events emitted: events 81..=149 compute their next interval in the cruise; 150..=199 in the
        // deceleration (its segments, whole runs), then the last event.
        let times = *s.ring[s.act.slot].profile.times();
        let decel = times.segments().len() - 1 - s.act.cursor.next_segment() + 1;
        let runs_events = |act: &Active| {
            (0..act.runs as usize).map(|j| times.segments()[act.cursor.next_segment() + j].count).sum::<u32>()
        };
        assert!(decel > 1, "{decel}");
        assert_eq!((s.act.emitted(&times), s.act.countdown, s.act.runs as usize), (80, 69, decel));
        assert_eq!((runs_events(&s.act), s.act.target), (50, 200));
        // Arming again (what a hold that cannot slow down does) takes the same run: the events taken before are
        // given back first.
        s.act.arm(80, &times);
        s.act.arm(80, &times);
        assert_eq!((s.act.emitted(&times), s.act.countdown, s.act.runs as usize), (80, 69, decel));
        assert_eq!((runs_events(&s.act), s.act.target), (50, 200));
        let rest = |st: &mut Stepper, hal: &mut Rec| core::iter::from_fn(|| st.tick(hal)).collect::<std::vec::Vec<_>>();
        let (mine, theirs) = (rest(&mut s, &mut hal), rest(&mut twin, &mut hal));
        assert_eq!(mine.len(), 119);
        assert_eq!(mine, theirs);
        assert_eq!(mine[..69], [500; 69]);
    }

    #[test]
    fn a_block_sets_only_the_direction_pins_of_its_moving_axes() {
        let mut s = Stepper::new(0, 0);
        let mut hal = Rec::default();
        s.push(StepBlock { steps: [0, -3, 0, 0], cruise_rate: 1000, ..StepBlock::default() }, Switches::Limits)
            .unwrap();
        s.push(StepBlock { steps: [2, 0, 0, 0], cruise_rate: 1000, ..StepBlock::default() }, Switches::Limits).unwrap();
        s.start(&mut hal);
        while s.tick(&mut hal).is_some() {}
        // Y's pin stays high (backwards) through the X move; one pin written per block.
        assert_eq!(hal.dir, [false, true, false, false]);
        assert_eq!((hal.dir_changes_during_block, hal.pos), (2, [2, -3, 0, 0]));
    }

    /// A 3000-event cruise at 4000 events/s (20 000 events/s²) and `next` queued; a hold with event 2900
    /// scheduled needs 399 more events (v² − 2aj > 0 for j < 400), 100 of them in this block: v² = 16·10⁶ −
    /// 40 000·100 = 12·10⁶ is carried into `next`. Returns the stepper run until it stops.
    fn hold_carried_into(next: StepBlock) -> (Stepper, Rec) {
        let mut s = Stepper::new(0, 0);
        let mut hal = Rec::default();
        let first = StepBlock {
            steps: [3000, 0, 0, 0],
            entry_rate: 0,
            cruise_rate: 4000,
            exit_rate: 4000,
            accel: 20_000,
            dwell_ticks: 0,
            servo: None,
        };
        s.push(first, Switches::Limits).unwrap();
        s.push(next, Switches::Limits).unwrap();
        s.start(&mut hal);
        for _ in 0..2899 {
            s.tick(&mut hal).unwrap();
        }
        s.feed_hold();
        while s.tick(&mut hal).is_some() {}
        (s, hal)
    }

    #[test]
    fn a_hold_carried_to_a_dwell_stops_before_it_even_with_an_acceleration_set() {
        let (s, hal) = hold_carried_into(StepBlock { accel: 20_000, ..StepBlock::dwell(10) });
        assert!(s.is_held());
        assert_eq!((s.completed(), s.pending(), hal.pos[0]), (1, 1, 3000));
    }

    #[test]
    fn a_hold_near_a_servo_block_between_two_moves_defers_the_drop_or_lets_it_land() {
        // A drop commanded on the way: the first move leaves off at 4000 events/s, the 1-tick servo block, the
        // next move enters at 4000 and decelerates to rest over its 400 events (4000²/(2·20 000), 0.2 s). A hold
        // with event 2900 scheduled needs 399 more events: 100 in the first move, then (v² = 12·10⁶)
        // √(12·10⁶)² / 40 000 = 300 events into the last move, where it stops. The last move arrives while the hold
        // decelerates, the drop still queued: the move takes the drop's place and the drop waits behind it, its
        // dwell 1 + the move's planned 0.2 s (the carriage slows down across the junction instead of stopping dead
        // at the command, and the pen is not dropped short of the stroke: `landing`).
        let last = StepBlock {
            steps: [400, 0, 0, 0],
            entry_rate: 4000,
            cruise_rate: 4000,
            exit_rate: 0,
            accel: 20_000,
            dwell_ticks: 0,
            servo: None,
        };
        let first = StepBlock {
            steps: [3000, 0, 0, 0],
            entry_rate: 0,
            cruise_rate: 4000,
            exit_rate: 4000,
            accel: 20_000,
            dwell_ticks: 0,
            servo: None,
        };
        // The last move is pushed before the hold (`None`) or the given number of events after it.
        let held = |hold_after: u32, late: Option<u32>, last: StepBlock| {
            let mut s = Stepper::new(0, 0);
            let mut hal = Rec::default();
            s.push(first, Switches::Limits).unwrap();
            s.push(StepBlock::servo(300, 1), Switches::Limits).unwrap();
            s.start(&mut hal);
            for _ in 0..hold_after {
                s.tick(&mut hal).unwrap();
            }
            if late.is_none() {
                s.push(last, Switches::Limits).unwrap();
            }
            s.feed_hold();
            if let Some(late) = late {
                for _ in 0..late {
                    s.tick(&mut hal).unwrap();
                }
                s.push(last, Switches::Limits).unwrap();
            }
            while s.tick(&mut hal).is_some() {}
            assert!(s.is_held());
            (s, hal)
        };
        let (s, hal) = held(2899, Some(0), last);
        assert_eq!((s.completed(), hal.pos[0]), (1, 3299));
        let drop = &s.ring[s.first & SLOT_MASK];
        assert_eq!(drop.block.servo, Some(300));
        assert!(drop.block.dwell_ticks.abs_diff(1 + 200_000) <= 1 + 50, "{}", drop.block.dwell_ticks);
        // The same move pushed once the drop has started (the host late with it): the hold runs through the drop
        // into the move, as before (the command is out).
        let (s, hal) = held(2899, Some(101), last);
        assert_eq!((s.completed(), hal.pos[0]), (2, 3299));
        // A hold during the servo block itself, the move queued: the pen is landing; the move runs as planned to
        // its end, where the hold stops.
        for late in [None, Some(0)] {
            let (s, hal) = held(3000, late, last);
            assert_eq!((s.completed(), hal.pos[0]), (3, 3400), "{late:?}");
        }
        // Unless the move does not end at rest (no plan of ours): the hold hands the move's entry rate on,
        // 4000²/40 000 = 400 events, less the last (the rate reaches zero there), as a hold at its first event.
        let (s, hal) = held(3000, None, StepBlock { steps: [1000, 0, 0, 0], exit_rate: 4000, ..last });
        assert_eq!((s.completed(), hal.pos[0]), (2, 3000 + 399));
    }

    #[test]
    fn a_hold_carried_across_a_junction_converts_the_rate_to_the_next_blocks_units() {
        // The next block enters at 3000 of its events/s where the first left at 4000: the rate carried is
        // √(12·10⁶)·3/4 = 2598.1, v²/2a = 6.75·10⁶/40 000 = 168.75, so 168 more events.
        let next = StepBlock {
            steps: [3000, 0, 0, 0],
            entry_rate: 3000,
            cruise_rate: 4000,
            exit_rate: 0,
            accel: 20_000,
            dwell_ticks: 0,
            servo: None,
        };
        let (s, hal) = hold_carried_into(next);
        assert!(s.is_held());
        assert_eq!((s.completed(), hal.pos[0]), (1, 3168));
    }

    #[test]
    fn a_second_hold_after_a_resume_slows_down_from_the_rate_at_its_place_in_the_rest() {
        // 0 → 2000 → 0 events/s at 20 000 events/s² over 6000 events: a hold at a cruise event stops
        // v²/2a − 1 = 99 events later (v² − 2aj > 0 for j < 100).
        let b = StepBlock { steps: [6000, 0, 0, 0], cruise_rate: 2000, accel: 20_000, ..StepBlock::default() };
        let mut s = Stepper::new(0, 0);
        let mut hal = Rec::default();
        s.push(b, Switches::Limits).unwrap();
        s.start(&mut hal);
        for _ in 0..999 {
            s.tick(&mut hal).unwrap();
        }
        s.feed_hold();
        while s.tick(&mut hal).is_some() {}
        assert_eq!(hal.pos[0], 1099);
        // The rest (4901 events) restarts from rest: cruise from its event 100 to 4801. Event 4100 of the block
        // is its 3001st: cruising, so the second hold again takes 99 events.
        assert!(s.resume(&mut hal).is_some());
        for _ in 0..3000 {
            s.tick(&mut hal).unwrap();
        }
        s.feed_hold();
        while s.tick(&mut hal).is_some() {}
        assert!(s.is_held());
        assert_eq!(hal.pos[0], 4199);
    }

    #[test]
    fn feed_hold_without_acceleration_stops_after_the_scheduled_event() {
        let mut s = Stepper::new(0, 0);
        let mut hal = Rec::default();
        s.push(StepBlock { steps: [0, 50, 0, 0], cruise_rate: 100, ..StepBlock::default() }, Switches::Limits).unwrap();
        s.start(&mut hal);
        for _ in 0..10 {
            s.tick(&mut hal).unwrap();
        }
        s.feed_hold();
        assert!(s.is_holding() && !s.is_held());
        assert_eq!(s.tick(&mut hal), None);
        assert!(s.is_held());
        assert_eq!(hal.pos[1], 11);
        assert_eq!(s.resume(&mut hal), Some(10_000));
        while s.tick(&mut hal).is_some() {}
        assert_eq!(hal.pos[1], 50);
    }

    #[test]
    fn layout_packs_the_axes_of_every_event_and_the_minor_ones() {
        // Longer than the lanes (n = 40 000 > 0x7FFF events): the axes of every event, and a list of the others.
        let b = StepBlock { steps: [40_000, -40_000, 3, 0], cruise_rate: 100, ..StepBlock::default() };
        let l = Layout::of(&b, 40_000);
        assert_eq!(l.fills, [0; 2]);
        assert_eq!((l.always, l.minors), (0b0011, 1));
        // Error term ⌊n/2⌋ = 20 000: room n − 1 − 20 000 = 19 999.
        assert_eq!((l.minor[0].delta, l.minor[0].room, l.minor[0].bit, l.minor[0].axis), (3, 19_999, 0b0100, 2));
        let b = StepBlock { steps: [10_000, -20_000, 30_000, 70_000], cruise_rate: 100, ..StepBlock::default() };
        let l = Layout::of(&b, 70_000);
        assert_eq!((l.always, l.minors), (0b1000, 3));
        assert_eq!(l.minor.map(|m| (m.delta, m.bit, m.axis)), [(10_000, 1, 0), (20_000, 2, 1), (30_000, 4, 2)]);
        // Steps after k events: k for the major axis, ⌊(k·d + ⌊n/2⌋)/n⌋ for the others: Y and Z step at event 2
        // (⌊75 000/70 000⌋, ⌊95 000/70 000⌋), X and Z at event 4; after 4 events 1, 1, 2 — ⌊(40 000 + 35 000)/70 000⌋,
        // ⌊(80 000 + 35 000)/70 000⌋, ⌊(120 000 + 35 000)/70 000⌋.
        let mut l2 = l;
        let masks: std::vec::Vec<u8> = (0..4).map(|_| l2.event(70_000)).collect();
        assert_eq!(masks, [0b1000, 0b1110, 0b1000, 0b1101]);
        assert_eq!(l2.steps_after(4, 70_000), [1, 1, 2, 4]);
        // The same proportions in 7 events fit the lanes: the same steps, no list.
        let b = StepBlock { steps: [1, -2, 3, 7], cruise_rate: 100, ..StepBlock::default() };
        let mut l = Layout::of(&b, 7);
        assert_eq!((l.always, l.minors), (0, 0));
        // Rooms 7 − 1 − 3 = 3: fills 0x7FFF − 3 in every lane.
        assert_eq!((l.fills, l.deltas), ([0x7FFC_7FFC; 2], [2 << 16 | 1, 7 << 16 | 3]));
        let masks: std::vec::Vec<u8> = (0..4).map(|_| l.event(7)).collect();
        assert_eq!(masks, [0b1000, 0b1110, 0b1000, 0b1101]);
        assert_eq!(l.steps_after(4, 7), [1, 1, 2, 4]);
        // The largest block the lanes take, and the smallest they do not.
        let l = Layout::of(&StepBlock { steps: [0x7FFF, 1, 0, 0], ..b }, 0x7FFF);
        assert_eq!((l.fills[0] & 0xFFFF, l.deltas[0], l.minors), (0x7FFF - 0x3FFF, 1 << 16 | 0x7FFF, 0));
        let l = Layout::of(&StepBlock { steps: [0x8000, 1, 0, 0], ..b }, 0x8000);
        assert_eq!((l.fills, l.always, l.minors), ([0; 2], 1, 1));
        assert_eq!(Layout::of(&StepBlock::dwell(5), 0).fills, [0x7FFF_7FFF; 2]);
    }

    #[test]
    fn a_block_longer_than_the_lanes_runs_on_the_list() {
        // 40 000 events (> 0x7FFF): exact counts, the position derived from the list's error terms at every event
        // (checked by `run`), and the time the contract gives.
        let b =
            StepBlock { steps: [-40_000, 15_001, 0, 3], cruise_rate: 20_000, accel: 200_000, ..StepBlock::default() };
        let (hal, t) = run(b, |_, _| {});
        assert_eq!(hal.pos, [-40_000, 15_001, 0, 3]);
        assert_eq!(hal.steps, [40_000, 15_001, 0, 3]);
        assert_eq!(t, u64::from(b.duration_ticks()));
    }

    #[test]
    fn blocks_on_the_lanes_and_on_the_list_follow_each_other() {
        // A short block, a long one (its list loaded), a short one again (the list left behind is not read), and
        // the position derived from the executing block's error terms at every event.
        let short = StepBlock { steps: [7, -3, 2, 0], cruise_rate: 1000, ..StepBlock::default() };
        let long = StepBlock { steps: [1, 33_000, -5, 2], cruise_rate: 20_000, ..StepBlock::default() };
        let mut s = Stepper::new(0, 0);
        let mut hal = Rec::default();
        s.push(short, Switches::Limits).unwrap();
        s.push(long, Switches::Limits).unwrap();
        s.start(&mut hal);
        let mut pushed = false;
        let mut events = 0;
        while s.tick(&mut hal).is_some() {
            events += 1;
            assert_eq!(s.position(), as_i32(&hal.pos), "event {events}");
            if !pushed && s.has_room() {
                s.push(short, Switches::Limits).unwrap();
                pushed = true;
            }
        }
        // The last event's tick returns None (not counted above).
        assert_eq!((events + 1, s.completed()), (7 + 33_000 + 7, 3));
        assert_eq!(s.position(), as_i32(&hal.pos));
        assert_eq!(hal.pos, [15, 33_000 - 6, -1, 2]);
        assert_eq!(hal.steps, [15, 33_006, 9, 2]);
    }

    #[test]
    fn the_lanes_step_like_the_list_at_every_event_of_a_long_block() {
        // 0x7FFF events with every axis's |Δ| different: each lane steps exactly when its minor term does (the
        // same error terms), over the whole block, and both end with exactly |Δ| steps.
        let n = 0x7FFF;
        let b = StepBlock { steps: [0x7FFF, -12_345, 1, 32_766], cruise_rate: 100, ..StepBlock::default() };
        let mut lanes = Layout::of(&b, n);
        let mut list = Layout::of(&StepBlock { steps: [40_000, 0, 0, 0], ..b }, 40_000);
        list.always = 1;
        list.minors = 3;
        for (i, d) in [(1u8, 12_345u32), (2, 1), (3, 32_766)] {
            list.minor[usize::from(i) - 1] = Minor { room: n - 1 - n / 2, delta: d, bit: 1 << i, axis: i };
        }
        let mut steps = [0u32; NUM_AXES];
        for k in 1..=n {
            let mask = lanes.event(n);
            assert_eq!(mask, list.minor_event(n), "event {k}");
            for (i, s) in steps.iter_mut().enumerate() {
                *s += u32::from(mask >> i & 1);
            }
            if k % 4099 == 0 {
                assert_eq!(lanes.steps_after(k, n), steps, "event {k}");
            }
        }
        assert_eq!(steps, [n, 12_345, 1, 32_766]);
        assert_eq!(lanes.steps_after(n, n), steps);
    }

    #[test]
    fn a_minor_axis_steps_on_the_midpoint_bresenham_pattern() {
        // n = 5, |Δ| = 3: after k events ⌊(3k + 2)/5⌋ = 1, 1, 2, 2, 3 steps, i.e. steps at events 1, 3 and 5.
        let b = StepBlock { steps: [5, 3, 0, 0], cruise_rate: 100, ..StepBlock::default() };
        let mut l = Layout::of(&b, 5);
        let masks: std::vec::Vec<u8> = (0..5).map(|_| l.event(5)).collect();
        assert_eq!(masks, [0b11, 0b01, 0b11, 0b01, 0b11]);
        // n = 4, |Δ| = 1: ⌊(k + 2)/4⌋ = 0, 1, 1, 1 — the one step at event 2; room n − 1 − ⌊n/2⌋ = 1 at the start.
        let b = StepBlock { steps: [0, 0, -1, 4], cruise_rate: 100, ..StepBlock::default() };
        let mut l = Layout::of(&b, 4);
        assert_eq!(0x7FFF - (l.fills[1] & 0x7FFF), 1);
        let masks: std::vec::Vec<u8> = (0..4).map(|_| l.event(4)).collect();
        assert_eq!(masks, [0b1000, 0b1100, 0b1000, 0b1000]);
        assert_eq!(l.steps_after(4, 4), [0, 0, 1, 4]);
    }

    /// A [`Rec`] with a step timer that records how it was driven: `('s', ticks)` for `schedule`, `('n', ticks)` for
    /// `schedule_next`, `('c', 0)` for `cancel`.
    #[derive(Default)]
    struct Timed(Rec, std::vec::Vec<(char, u32)>);
    impl StepPins for Timed {
        fn set_dir(&mut self, axis: Axis, level: bool) {
            self.0.set_dir(axis, level);
        }
        fn step(&mut self, axis: Axis) {
            self.0.step(axis);
        }
        fn enable_motors(&mut self, _on: bool) {}
    }
    impl Endstops for Timed {
        fn pressed(&mut self) -> u8 {
            self.0.pressed()
        }
    }
    impl StepTimer for Timed {
        fn schedule(&mut self, ticks: u32) {
            self.1.push(('s', ticks));
        }
        fn schedule_next(&mut self, ticks: u32) {
            self.1.push(('n', ticks));
        }
        fn cancel(&mut self) {
            self.1.push(('c', 0));
        }
    }

    #[test]
    fn on_timer_schedules_from_the_interrupt_and_stops_at_the_end() {
        let mut s = Stepper::new(0, 0);
        let mut hal = Timed::default();
        // 3 events at 1000 events/s, then a 7-tick dwell: the block change happens inside the interrupt.
        s.push(StepBlock { steps: [3, 0, 0, 0], cruise_rate: 1000, ..StepBlock::default() }, Switches::Limits).unwrap();
        s.push(StepBlock::dwell(7), Switches::Limits).unwrap();
        assert_eq!(s.start(&mut hal), Some(1000));
        let mut runs = 0;
        while s.on_timer(&mut hal) {
            runs += 1;
            assert!(runs < 10);
        }
        assert_eq!(hal.1, [('n', 1000), ('n', 1000), ('n', 7), ('c', 0)]);
        assert_eq!((hal.0.pos, s.completed()), ([3, 0, 0, 0], 2));
        assert!(s.is_idle());
    }

    #[test]
    fn on_timer_hands_the_pin_writes_reading_to_the_same_events_schedule() {
        /// A board whose pin write returns a reading (here: 100 + the events stepped so far) and whose timer
        /// records what it was scheduled from.
        #[derive(Default)]
        struct Board(Rec, u32, std::vec::Vec<(Option<u32>, u32)>);
        impl StepPins for Board {
            fn set_dir(&mut self, axis: Axis, level: bool) {
                self.0.set_dir(axis, level);
            }
            fn step(&mut self, axis: Axis) {
                self.0.step(axis);
            }
            fn step_axes_read(&mut self, mask: u8) -> u32 {
                self.step_axes(mask);
                self.1 += 1;
                100 + self.1
            }
            fn enable_motors(&mut self, _on: bool) {}
        }
        impl Endstops for Board {
            fn pressed(&mut self) -> u8 {
                0
            }
        }
        impl StepTimer for Board {
            fn schedule(&mut self, ticks: u32) {
                self.2.push((None, ticks));
            }
            fn schedule_next_from(&mut self, read: u32, ticks: u32) {
                self.2.push((Some(read), ticks));
            }
            fn cancel(&mut self) {}
        }
        let mut s = Stepper::new(0, 0);
        let mut hal = Board::default();
        // 4 events at 500 events/s: the first three are plain events (each hands on its own reading), the last is
        // the block end (slow path: stepped through `step_axes`, scheduled without a reading — none follows).
        s.push(StepBlock { steps: [4, 0, 0, 0], cruise_rate: 500, ..StepBlock::default() }, Switches::Limits).unwrap();
        assert_eq!(s.start(&mut hal), Some(2000));
        while s.on_timer(&mut hal) {}
        assert_eq!(hal.2, [(Some(101), 2000), (Some(102), 2000), (Some(103), 2000)]);
        assert_eq!((hal.0.pos, hal.1), ([4, 0, 0, 0], 3));
    }

    /// `on_timer` (its fast path inline, a block too long for the lanes out of line, the slow path) drives the same
    /// events as `tick`: a 40 000-event block with ramps between two short ones, every interval and every step.
    #[test]
    fn on_timer_and_tick_agree_on_long_and_short_blocks() {
        let short = StepBlock { steps: [30, -7, 2, 0], cruise_rate: 3000, accel: 90_000, ..StepBlock::default() };
        let long =
            StepBlock { steps: [-40_000, 15_001, 0, 3], cruise_rate: 20_000, accel: 200_000, ..StepBlock::default() };
        let (mut a, mut b) = (Stepper::new(0, 0), Stepper::new(0, 0));
        let (mut timed, mut rec) = (Timed::default(), Rec::default());
        for st in [&mut a, &mut b] {
            st.push(short, Switches::Limits).unwrap();
            st.push(long, Switches::Limits).unwrap();
        }
        let mut ticked = std::vec![b.start(&mut rec).unwrap()];
        let first = a.start(&mut timed).unwrap();
        timed.1.push(('s', first));
        let mut third = (Some(short), Some(short));
        loop {
            let on = a.on_timer(&mut timed);
            let iv = b.tick(&mut rec);
            assert_eq!(on, iv.is_some());
            ticked.extend(iv);
            assert_eq!(timed.0.pos, rec.pos, "event {}", ticked.len());
            if a.has_room()
                && let Some(blk) = third.0.take()
            {
                a.push(blk, Switches::Limits).unwrap();
            }
            if b.has_room()
                && let Some(blk) = third.1.take()
            {
                b.push(blk, Switches::Limits).unwrap();
            }
            if !on {
                break;
            }
        }
        // The intervals the timer was given (scheduled from the interrupt or not), not its final cancel.
        let given: std::vec::Vec<u32> = timed.1.iter().filter(|e| e.0 != 'c').map(|e| e.1).collect();
        assert_eq!(given, ticked);
        assert_eq!(rec.pos, [-40_000 + 60, 15_001 - 14, 4, 3]);
        // 40 060 events: the interval to the first from the start, then one after each event but the last.
        assert_eq!(ticked.len(), 40_000 + 60);
    }

    #[test]
    fn a_queued_block_starts_from_its_prepared_state() {
        // The prepared first interval is the profile's: √(2/a) = 14 142 µs from rest at 10⁴ events/s².
        let mut s = Stepper::new(0, 0);
        let mut hal = Rec::default();
        let b = StepBlock { steps: [100, 40, 0, 0], cruise_rate: 1000, accel: 10_000, ..StepBlock::default() };
        s.push(b, Switches::Limits).unwrap();
        let q = &s.ring[s.first];
        assert_eq!((q.first, q.start.n, q.start.target), (14_142, 100, 100));
        // The first segment from rest is the first event alone (its interval is `first`): no run taken from it
        // yet: the 99 events before the last one run on the intervals of the later segments.
        assert_eq!(q.profile.times().segments()[0].count, 1);
        let times = q.profile.times();
        assert_eq!(
            (q.start.countdown, q.start.runs as usize, q.start.emitted(times)),
            (0, times.segments().len() - 1, 0)
        );
        assert_eq!(times.segments()[1..].iter().map(|s| s.count).sum::<u32>(), 99);
        // 100 events: the lanes, X's |Δ| = 100 and Y's 40 in the low word; rooms 100 − 1 − 50 = 49, fills 0x7FFF − 49.
        let l = q.start.layout;
        assert_eq!((l.fills, l.deltas), ([0x7FCE_7FCE, 0x7FCE_7FCE], [40 << 16 | 100, 0]));
        assert!(q.start.live && q.start.limits && !q.start.counted);
        assert_eq!(s.start(&mut hal), Some(14_142));
        // A homing block: every event on the slow path.
        let mut s = Stepper::new(0, 0);
        s.push(
            StepBlock { steps: [0, 8, 0, 0], cruise_rate: 100, ..StepBlock::default() },
            Switches::Homing { axes: 2 },
        )
        .unwrap();
        let q = &s.ring[s.first];
        assert_eq!((q.first, q.start.countdown, q.start.home_mask), (10_000, 0, 2));
        assert!(q.start.counted && !q.start.limits);
    }

    #[test]
    fn direction_levels_follow_the_sign_and_the_inversion() {
        // X and Y inverted: X backwards is high ^ inverted = low, Y forwards low ^ inverted = high; Z backwards high.
        let mut s = Stepper::new(Axis::X.bit() | Axis::Y.bit(), 0);
        let mut hal = Rec::default();
        s.push(StepBlock { steps: [-4, 4, -2, 0], cruise_rate: 1000, ..StepBlock::default() }, Switches::Limits)
            .unwrap();
        s.start(&mut hal);
        assert_eq!(hal.dir, [false, true, true, false]);
    }

    #[test]
    fn start_does_nothing_while_a_block_runs_or_a_fault_is_latched() {
        let mut s = Stepper::new(0, Axis::X.bit());
        let mut hal = Rec::default();
        let b = StepBlock { steps: [5, 0, 0, 0], cruise_rate: 1000, ..StepBlock::default() };
        s.push(b, Switches::Limits).unwrap();
        s.push(b, Switches::Limits).unwrap();
        assert_eq!(s.start(&mut hal), Some(1000));
        assert_eq!(s.start(&mut hal), None, "running: the queued block waits");
        assert_eq!(s.pending(), 2);
        assert!(s.limit_switches(Axis::X.bit()));
        s.push(b, Switches::Limits).unwrap();
        assert_eq!(s.start(&mut hal), None, "faulted: nothing starts");
        assert_eq!(s.pending(), 1);
    }

    #[test]
    fn past_the_last_segment_the_cursor_steps_by_one_tick() {
        let mut s = Stepper::new(0, 0);
        let mut hal = Rec::default();
        s.push(StepBlock { steps: [2, 0, 0, 0], cruise_rate: 1000, ..StepBlock::default() }, Switches::Limits).unwrap();
        assert_eq!(s.start(&mut hal), Some(1000));
        // The first run took the segment's other interval.
        assert_eq!((s.act.countdown, s.act.runs), (1, 0));
        assert_eq!(s.act.cursor.advance(), 1000);
        // The block's one segment is used up: a run after it (never asked for) finds the sentinel past the last
        // segment, 1 tick each.
        s.act.runs = 1;
        assert_eq!((s.next_run(), s.act.runs), (u32::MAX, 0));
        assert_eq!([s.act.cursor.advance(), s.act.cursor.advance()], [1, 1]);
    }

    #[test]
    fn ring_slots_wrap_without_division() {
        assert_eq!(SLOTS, 4);
        assert_eq!([after(0), after(1), after(2), after(3)], [1, 2, 3, 0]);
        assert_eq!(
            [nth_after(1, 0), nth_after(1, 2), nth_after(2, 2), nth_after(3, 1), nth_after(3, 3)],
            [1, 3, 0, 0, 2]
        );
    }

    #[test]
    fn abort_keeps_the_position_reached() {
        let mut s = Stepper::new(0, 0);
        let mut hal = Rec::default();
        s.push(StepBlock { steps: [40, -30, 0, 7], cruise_rate: 1000, ..StepBlock::default() }, Switches::Limits)
            .unwrap();
        s.start(&mut hal);
        for _ in 0..17 {
            s.tick(&mut hal).unwrap();
        }
        // 17 of 40 events: X 17, Y ⌊(17·30 + 20)/40⌋ = 13 back, E ⌊(17·7 + 20)/40⌋ = 3.
        assert_eq!(s.position(), [17, -13, 0, 3]);
        assert_eq!(as_i32(&hal.pos), [17, -13, 0, 3]);
        assert_eq!(s.pending(), 1);
        s.abort();
        assert!(s.is_idle());
        assert_eq!(s.position(), [17, -13, 0, 3]);
        // The next move starts from there.
        s.push(StepBlock { steps: [3, 0, 0, 0], cruise_rate: 1000, ..StepBlock::default() }, Switches::Limits).unwrap();
        s.start(&mut hal);
        while s.tick(&mut hal).is_some() {}
        assert_eq!(s.position(), [20, -13, 0, 3]);
        assert_eq!(s.completed(), 1);
    }

    #[test]
    fn limit_switches_fault_only_during_a_normal_move() {
        let mut s = Stepper::new(0, Axis::X.bit() | Axis::Y.bit());
        let mut hal = Rec::default();
        assert!(!s.limit_switches(0b0011), "idle: nothing to stop");
        s.push(StepBlock { steps: [50, 0, 0, 0], cruise_rate: 1000, ..StepBlock::default() }, Switches::Limits)
            .unwrap();
        s.push(StepBlock { steps: [50, 0, 0, 0], cruise_rate: 1000, ..StepBlock::default() }, Switches::Limits)
            .unwrap();
        s.start(&mut hal);
        for _ in 0..10 {
            s.tick(&mut hal).unwrap();
        }
        assert!(!s.limit_switches(0), "nothing pressed");
        assert!(!s.limit_switches(Axis::Z.bit()), "Z has no hard limit");
        assert_eq!(s.fault(), None);
        assert!(s.limit_switches(Axis::Y.bit() | Axis::Z.bit()));
        assert_eq!(s.fault(), Some(StepperFault::HardLimit(Axis::Y.bit())));
        assert!(s.is_idle(), "queue dropped");
        assert_eq!(s.position(), [10, 0, 0, 0]);
        assert_eq!(s.start(&mut hal), None, "a fault keeps it stopped");
        s.clear_fault();
        assert_eq!(s.fault(), None);
        // A homing move does not treat its switches as limits.
        s.push(
            StepBlock { steps: [-50, 0, 0, 0], cruise_rate: 1000, ..StepBlock::default() },
            Switches::Homing { axes: 0 },
        )
        .unwrap();
        s.start(&mut hal);
        s.tick(&mut hal).unwrap();
        assert!(!s.limit_switches(Axis::X.bit()));
        assert_eq!(s.fault(), None);
    }

    #[test]
    fn homing_stops_each_axis_at_its_switch() {
        let mut s = Stepper::new(0, Axis::X.bit());
        let mut hal = Rec { switch_at: [Some(-100), Some(-250), None, None], ..Rec::default() };
        let block = StepBlock { steps: [-1000, -1000, -400, 0], cruise_rate: 1000, ..StepBlock::default() };
        s.push(block, Switches::Homing { axes: Axis::X.bit() | Axis::Y.bit() }).unwrap();
        s.start(&mut hal);
        let mut events = 0;
        while s.tick(&mut hal).is_some() {
            events += 1;
            assert_eq!(s.position(), as_i32(&hal.pos), "counted at each event");
            assert!(events <= 1000);
        }
        // The switch is read before each event: X stops where its switch closed, Y too; Z went on (2 in 5).
        assert_eq!(as_i32(&hal.pos), [-100, -250, -100, 0]);
        assert_eq!(s.position(), [-100, -250, -100, 0]);
        assert_eq!(s.homing_hits(), 0b0011);
        assert_eq!((events, s.completed()), (250, 1));
        assert!(s.is_idle());
        assert_eq!(s.fault(), None);
        // Both switches still pressed: the next homing move of both ends at its first event without a step.
        s.push(
            StepBlock { steps: [-10, -10, 0, 0], cruise_rate: 1000, ..StepBlock::default() },
            Switches::Homing { axes: 0b0011 },
        )
        .unwrap();
        s.start(&mut hal);
        assert_eq!(s.tick(&mut hal), None);
        assert_eq!((s.position(), s.completed()), ([-100, -250, -100, 0], 2));
        // A homing block of one axis whose switch is never hit runs to its end.
        hal.switch_at = [None; NUM_AXES];
        s.push(
            StepBlock { steps: [0, 0, 0, -5], cruise_rate: 1000, ..StepBlock::default() },
            Switches::Homing { axes: Axis::E.bit() },
        )
        .unwrap();
        s.start(&mut hal);
        while s.tick(&mut hal).is_some() {}
        assert_eq!(s.position(), [-100, -250, -100, -5]);
        assert_eq!(s.homing_hits(), 0);
    }

    #[test]
    fn a_homing_block_is_timed_by_its_own_slot() {
        // Every event of a homing block is on the slow path, which reads the step times of the block's ring slot.
        // The block goes into slot 1 (after a dwell); the other slots hold other times (the empty dwell's: one
        // tick per event). Its intervals are those of the same block as a normal move, and add up to its duration.
        let block = StepBlock {
            steps: [0, 0, 0, 300],
            entry_rate: 0,
            cruise_rate: 2000,
            exit_rate: 0,
            accel: 20_000,
            dwell_ticks: 0,
            servo: None,
        };
        let intervals = |switches: Switches| {
            let mut s = Stepper::new(0, 0);
            let mut hal = Rec::default();
            s.push(StepBlock::dwell(7), Switches::Limits).unwrap();
            s.push(block, switches).unwrap();
            assert_eq!(s.start(&mut hal), Some(7));
            let mut v = std::vec::Vec::new();
            while let Some(iv) = s.tick(&mut hal) {
                v.push(iv);
                assert_eq!(s.act.slot, 1);
            }
            assert_eq!((hal.pos, s.completed()), ([0, 0, 0, 300], 2));
            v
        };
        let homing = intervals(Switches::Homing { axes: Axis::E.bit() });
        // The dwell's end returns the interval to the block's first event; the block's last event returns None.
        assert_eq!(homing.len(), 300);
        assert_eq!(homing.iter().map(|&iv| u64::from(iv)).sum::<u64>(), u64::from(block.duration_ticks()));
        // 0 → 2000 events/s at 20 000 events/s²: 100 events each way, 100 cruise events 500 µs apart; the first
        // interval is √(2/a) = 10 000 µs (1 tick + 0.025 % of the ramp).
        assert!((9_997..=10_003).contains(&homing[0]), "{}", homing[0]);
        assert_eq!(homing[150], 500);
        assert_eq!(homing, intervals(Switches::Limits));
    }

    #[test]
    fn a_hold_during_homing_stops_and_resumes_counting() {
        let mut s = Stepper::new(0, 0);
        let mut hal = Rec::default();
        let block = StepBlock { steps: [0, 60, 0, 0], cruise_rate: 100, ..StepBlock::default() };
        s.push(block, Switches::Homing { axes: Axis::Y.bit() }).unwrap();
        s.start(&mut hal);
        for _ in 0..20 {
            s.tick(&mut hal).unwrap();
        }
        s.feed_hold();
        assert_eq!(s.tick(&mut hal), None);
        assert!(s.is_held());
        assert_eq!(s.position(), [0, 21, 0, 0]);
        assert_eq!(s.resume(&mut hal), Some(10_000));
        while s.tick(&mut hal).is_some() {}
        assert_eq!(s.position(), [0, 60, 0, 0]);
        assert_eq!(as_i32(&hal.pos), [0, 60, 0, 0]);
    }

    #[test]
    fn a_dwell_and_a_servo_block_keep_the_position_and_count() {
        #[derive(Default)]
        struct Servo(Rec, std::vec::Vec<f32>);
        impl StepPins for Servo {
            fn set_dir(&mut self, axis: Axis, level: bool) {
                self.0.set_dir(axis, level);
            }
            fn step(&mut self, axis: Axis) {
                self.0.step(axis);
            }
            fn enable_motors(&mut self, _on: bool) {}
            fn set_servo(&mut self, angle_deg: f32) {
                self.1.push(angle_deg);
            }
        }
        impl Endstops for Servo {
            fn pressed(&mut self) -> u8 {
                0
            }
        }
        let mut s = Stepper::new(0, 0);
        let mut hal = Servo::default();
        s.set_position([5, 6, 7, 8]);
        s.set_axis_position(Axis::Z, 9);
        s.push(StepBlock::servo(450, 300), Switches::Limits).unwrap();
        s.push(StepBlock::dwell(0), Switches::Limits).unwrap();
        assert!(!s.has_room());
        assert_eq!(s.pending(), 2);
        assert_eq!(s.start(&mut hal), Some(300));
        assert_eq!(hal.1, [45.0]);
        assert_eq!(s.position(), [5, 6, 9, 8]);
        // The servo block ends, the zero dwell starts (at least one tick).
        assert_eq!(s.tick(&mut hal), Some(1));
        assert_eq!(s.tick(&mut hal), None);
        assert_eq!((s.completed(), s.position()), (2, [5, 6, 9, 8]));
        assert!(s.is_idle());
    }

    fn block_strategy() -> impl Strategy<Value = StepBlock> {
        (proptest::array::uniform4(-3000i32..3000), 0u32..20_000, 1u32..20_000, 0u32..20_000, 0u32..200_000).prop_map(
            |(steps, e, c, x, a)| StepBlock {
                steps,
                entry_rate: e,
                cruise_rate: c,
                exit_rate: x,
                accel: a,
                dwell_ticks: 0,
                servo: None,
            },
        )
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(200))]
        /// Exact step counts and the half-step bound at every event; executed time equals `duration_ticks`.
        #[test]
        fn bresenham_exact_and_within_half_step(block in block_strategy()) {
            prop_assume!(block.events() > 0);
            let n = f64::from(block.events());
            let mut worst = 0.0f64;
            let (hal, t) = run(block, |k, pos| {
                for (p, s) in pos.iter().zip(block.steps) {
                    let ideal = f64::from(s) * f64::from(k) / n;
                    worst = worst.max((*p as f64 - ideal).abs());
                }
            });
            prop_assert!(worst <= 0.5 + 1e-9, "deviation {worst}");
            for i in 0..NUM_AXES {
                prop_assert_eq!(hal.pos[i], i64::from(block.steps[i]));
                prop_assert_eq!(hal.steps[i], block.steps[i].unsigned_abs());
            }
            prop_assert_eq!(t, u64::from(block.duration_ticks()));
            // Directions are set once per block, before the first step.
            prop_assert_eq!(hal.dir_changes_during_block, block.axis_mask().count_ones());
        }

        /// Event times never go backwards and a sequence of blocks takes the sum of their durations.
        #[test]
        fn sequence_time_is_sum(blocks in proptest::collection::vec(block_strategy(), 1..5)) {
            let mut s = Stepper::new(0, 0);
            let mut hal = Rec::default();
            let mut expect = 0u64;
            let mut t = 0u64;
            let mut pending = blocks.iter().filter(|b| !b.is_dwell()).copied().collect::<std::vec::Vec<_>>();
            pending.reverse();
            for b in &pending { expect += u64::from(b.duration_ticks()); }
            while let Some(b) = pending.pop() { if s.push(b, Switches::Limits).is_err() { pending.push(b); break; } }
            if let Some(first) = s.start(&mut hal) {
                t += u64::from(first);
                loop {
                    while s.has_room() {
                        match pending.pop() { Some(b) => s.push(b, Switches::Limits).unwrap(), None => break }
                    }
                    match s.tick(&mut hal) { Some(iv) => t += u64::from(iv), None => break }
                }
            }
            prop_assert_eq!(t, expect);
        }
    }
}
