//! The motion FIFO and the 25 kHz stepper interrupt, computed the way each
//! firmware computes them, with its integer types and overflow.
//!
//! Every tick the ISR works on the command it holds ("current"): a step move
//! adds its rate to a 32-bit accumulator per axis and takes a step when bit
//! 31 becomes set (the bit is then cleared); an accelerating move first adds
//! its acceleration to the rate; a delay or a servo move counts its delay
//! down. When the current command is done the ISR takes the next one from the
//! FIFO in the same tick, so back-to-back moves leave no gap; the first tick
//! of the new command is the next one.
//!
//! Where the releases differ (source: `ebb.c`, `high_ISR`, of each release):
//! - 2.8.1 runs SM, XM, HM and LM through one accelerating branch; a rate
//!   that goes negative is folded back by adding 2^31 (so it never reverses);
//!   LT counts its intervals down before it steps and ends in the tick of its
//!   last interval. Any command's delay counts down in every tick, and a delay
//!   above 25 × 65536 ticks is dropped (treated as zero). Loading a command
//!   copies all of it; ES removes only step-limited moves.
//! - 3.0.2 has a branch per kind: SM/XM/HM without acceleration, LM/L3 and
//!   LT/T3 with a signed rate (and an acceleration that takes the jerk first)
//!   whose sign is the direction of each step (a rate that passes through
//!   zero reverses the axis). LT's last interval holds the ISR
//!   one more tick. Loading copies only the fields of the command's kind, so
//!   the step counts of an interrupted move linger until the next move (and
//!   `QM` reports motors moving during a servo move after an `ES`). ES drops
//!   the current command of any kind and the whole FIFO.

use super::firmware::Firmware;
use std::collections::VecDeque;

/// Direction bit of axis 1 and 2 in `dir_bits` (the firmware's DIR1/DIR2).
pub(crate) const DIR: [u8; 2] = [0x01, 0x02];
/// Accumulator treatment when a move is loaded (the firmware's SEState bits):
/// clear axis 1, clear axis 2, start axis 1 at 2^31-1, start axis 2 at 2^31-1.
pub(crate) const CLEAR_ACC: [u8; 2] = [0x01, 0x02];
pub(crate) const NEGATE_ACC: [u8; 2] = [0x04, 0x08];
/// 3.0.2 only: load the accumulator from the delay field (a test hook of the
/// firmware that an SM with a large `Clear` argument reaches, limit checks off).
const DELAY_ACC: [u8; 2] = [0x10, 0x20];
/// Bit 31 of an accumulator: a step is due.
const STEP_BIT: u32 = 0x8000_0000;
/// 2.8.1 drops a delay longer than this many ticks (about 65.5 s).
const V2_MAX_DELAY: u32 = 25 * 0x1_0000;

/// What a command in the FIFO does.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) enum Kind {
    /// Nothing (an empty slot, or the ISR between commands).
    #[default]
    None,
    /// Wait `delay` ticks (SM with zero steps).
    Delay,
    /// Start a servo channel towards a pulse width, then wait `delay` ticks.
    Servo,
    /// Enable or disable the motors and set the step mode (EM).
    Enable,
    /// Step-limited move: 2.8.1 SM/XM/HM/LM; 3.0.2 LM.
    Move,
    /// 3.0.2 SM/XM/HM: step-limited, constant rate, direction from `dir_bits`.
    Simple,
    /// Time-limited move (LT): `steps[0]` counts the remaining intervals.
    Timed,
}

impl Kind {
    pub fn is_motion(self) -> bool {
        matches!(self, Kind::Move | Kind::Simple | Kind::Timed)
    }
}

/// One command of the motion queue, with the firmware's fields.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Command {
    pub kind: Kind,
    /// `DIR` bits: the direction of each axis for moves whose direction is fixed.
    pub dir_bits: u8,
    /// Ticks to wait (delays and servo moves).
    pub delay: u32,
    /// `CLEAR_ACC` / `NEGATE_ACC` bits.
    pub acc_init: u8,
    /// Added to the accumulator every tick (signed on 3.0.2's LM/LT).
    pub rate: [i32; 2],
    /// Steps left per axis (LT: intervals left on axis 1).
    pub steps: [u32; 2],
    /// Added to the rate every tick.
    pub accel: [i32; 2],
    /// 3.0.2 L3/T3: added to the acceleration every tick.
    pub jerk: [i32; 2],
    /// Servo moves: channel (1-based), RPn pin, target pulse width, slew rate.
    pub servo: ServoTarget,
    /// EM: the two enable arguments.
    pub enable: [u8; 2],
}

/// Where a servo move sends one RC channel.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct ServoTarget {
    pub channel: u8,
    pub rpn: u8,
    pub position: u16,
    pub rate: u16,
}

/// What one tick did, for the rest of the board.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Tick {
    /// A step on an axis, in this direction (+1 or -1).
    pub step: [i8; 2],
    /// An axis finished its steps (a corner in the drawn path).
    pub axis_done: [bool; 2],
    /// The current servo move is (re)applied, as the ISR does every tick it holds one.
    pub servo: Option<ServoTarget>,
    /// An EM command ran.
    pub enable: Option<[u8; 2]>,
    /// A command ended (the next, if any, was loaded in this tick).
    pub ended: Option<Kind>,
    /// A command was taken from the FIFO.
    pub loaded: bool,
}

/// Why `ES` reported what it did (2.8.1 reports steps, 3.0.2 only the flag).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Stopped {
    pub interrupted: bool,
    pub fifo_steps: [u32; 2],
    pub remaining: [u32; 2],
}

/// The motion queue and the ISR state.
#[derive(Clone, Debug)]
pub(crate) struct Engine {
    fw: Firmware,
    /// The command the ISR holds.
    pub current: Command,
    /// Axes with steps (LT: intervals) left in the current command.
    pub active: [bool; 2],
    /// The step accumulators.
    pub acc: [u32; 2],
    /// Commands waiting for the ISR.
    fifo: VecDeque<Command>,
    /// How many commands the FIFO holds (1 on 2.8.1; `CU,4` on 3.0.2).
    depth: usize,
    /// The global step counters (`QS`), signed 32-bit.
    pub counters: [i32; 2],
}

impl Engine {
    pub fn new(fw: Firmware) -> Engine {
        Engine { fw, current: Command::default(), active: [false; 2], acc: [0; 2], fifo: VecDeque::new(), depth: 1, counters: [0; 2] }
    }

    pub fn has_room(&self) -> bool {
        self.fifo.len() < self.depth
    }

    pub fn fifo_len(&self) -> usize {
        self.fifo.len()
    }

    #[cfg(test)]
    pub fn depth(&self) -> usize {
        self.depth
    }

    /// `CU,4`: the firmware takes any depth up to its maximum; a depth of 0
    /// (or a negative one) leaves no room at all, and the next queued command
    /// waits for ever, as on the board.
    pub fn set_depth(&mut self, depth: usize) {
        self.depth = depth.min(self.fw.max_fifo());
    }

    /// Queues a command; the caller has checked [`Engine::has_room`].
    pub fn push(&mut self, c: Command) {
        debug_assert!(self.has_room());
        self.fifo.push_back(c);
    }

    /// `process_QM`: command executing, motor 1 moving, motor 2 moving, FIFO
    /// not empty, as bits 3..0.
    pub fn status_bits(&self) -> u8 {
        let executing = self.current.delay != 0 || self.current.kind != Kind::None || !self.fifo.is_empty();
        let m1 = executing && self.current.steps[0] != 0;
        let m2 = executing && self.current.steps[1] != 0;
        u8::from(executing) << 3 | u8::from(m1) << 2 | u8::from(m2) << 1 | u8::from(!self.fifo.is_empty())
    }

    /// Nothing held, nothing queued.
    pub fn idle(&self) -> bool {
        self.status_bits() == 0
    }

    /// The ISR holds a command (or a delay counts down): motion time.
    pub fn executing(&self) -> bool {
        self.current.kind != Kind::None || self.current.delay != 0
    }

    /// Queued commands, for 3.0.2's `SP,3`, which rewrites pen moves in place.
    pub fn queued_mut(&mut self) -> impl Iterator<Item = &mut Command> {
        self.fifo.iter_mut()
    }

    /// `EM` and `CS` clear the step counters and both accumulators.
    pub fn clear_counters(&mut self) {
        self.counters = [0; 2];
        self.acc = [0; 2];
    }

    /// `ES`: stop now and flush, as each release does.
    pub fn stop(&mut self) -> Stopped {
        let mut s = Stopped::default();
        if self.fw.is_v3() {
            s.interrupted = self.current.kind.is_motion() || !self.fifo.is_empty();
            self.current.kind = Kind::None;
            self.fifo.clear();
        } else {
            // Only step-limited moves (SM, XM, HM, LM) are stopped or removed;
            // LT, delays, servo and EM commands stay.
            let queued_move = self.fifo.front().is_some_and(|c| c.kind == Kind::Move);
            s.interrupted = queued_move || self.current.kind == Kind::Move;
            if queued_move {
                let c = self.fifo.pop_front().expect("checked");
                s.fifo_steps = c.steps;
            }
            if self.current.kind == Kind::Move {
                self.current.kind = Kind::None;
                s.remaining = self.current.steps;
                self.current.steps = [0; 2];
                self.current.accel = [0; 2];
            }
        }
        s
    }

    /// One tick of the stepper interrupt.
    pub fn tick(&mut self) -> Tick {
        if self.fw.is_v3() {
            self.tick_v3()
        } else {
            self.tick_v2()
        }
    }

    /// Ticks from now in which the ISR only counts: a delay counting down,
    /// or a constant-rate move between steps. The caller may skip that many
    /// at once with [`Engine::skip`].
    pub fn quiet_ticks(&self) -> u64 {
        let c = &self.current;
        match c.kind {
            Kind::None if self.fifo.is_empty() && c.delay == 0 => u64::MAX,
            Kind::Delay if c.delay > 1 && (self.fw.is_v3() || c.delay <= V2_MAX_DELAY) => u64::from(c.delay - 1),
            Kind::Simple | Kind::Move | Kind::Timed if c.accel == [0; 2] && c.jerk == [0; 2] && c.delay == 0 => {
                let mut quiet = if c.kind == Kind::Timed { u64::from(c.steps[0].saturating_sub(1)) } else { u64::MAX };
                for axis in 0..2 {
                    if c.kind != Kind::Timed && !self.active[axis] {
                        continue;
                    }
                    let (rate, acc) = (c.rate[axis], i64::from(self.acc[axis]));
                    quiet = quiet.min(match c.kind {
                        // SM/XM/HM add the rate unsigned (2^31 steps every tick).
                        Kind::Simple => between_steps(acc, i64::from(rate as u32)),
                        // 2.8.1 would fold a negative rate; it has none here.
                        _ if !self.fw.is_v3() && rate < 0 => 0,
                        _ if rate < 0 => (acc / -i64::from(rate)) as u64,
                        _ => between_steps(acc, i64::from(rate)),
                    });
                }
                quiet
            }
            _ => 0,
        }
    }

    /// Skips `n` ticks that [`Engine::quiet_ticks`] allowed.
    pub fn skip(&mut self, n: u64) {
        debug_assert!(n <= self.quiet_ticks());
        let c = &mut self.current;
        match c.kind {
            Kind::Delay => c.delay -= n as u32,
            Kind::Simple | Kind::Move | Kind::Timed => {
                for axis in 0..2 {
                    if c.kind == Kind::Timed || self.active[axis] {
                        let rate = if c.kind == Kind::Simple { i64::from(c.rate[axis] as u32) } else { i64::from(c.rate[axis]) };
                        self.acc[axis] = (i64::from(self.acc[axis]) + rate * n as i64) as u32;
                    }
                }
                if c.kind == Kind::Timed {
                    c.steps[0] -= n as u32;
                }
            }
            _ => {}
        }
    }

    #[allow(clippy::needless_range_loop)]
    fn tick_v2(&mut self) -> Tick {
        let mut out = Tick::default();
        let c = &mut self.current;
        let mut all_done = true;
        if c.delay != 0 {
            c.delay = if c.delay > V2_MAX_DELAY { 0 } else { c.delay - 1 };
        }
        if c.delay != 0 {
            all_done = false;
        }
        match c.kind {
            Kind::Move | Kind::Timed if self.active[0] || self.active[1] => {
                let mut stepped = [false; 2];
                if c.kind == Kind::Timed {
                    if self.active[0] {
                        c.steps[0] = c.steps[0].wrapping_sub(1);
                        if c.steps[0] == 0 {
                            self.active[0] = false;
                        }
                        for (axis, s) in stepped.iter_mut().enumerate() {
                            *s = v2_accumulate(&mut c.rate[axis], c.accel[axis], &mut self.acc[axis]);
                        }
                    }
                } else {
                    for (axis, s) in stepped.iter_mut().enumerate() {
                        if self.active[axis] && v2_accumulate(&mut c.rate[axis], c.accel[axis], &mut self.acc[axis]) {
                            *s = true;
                            count_step(&mut c.steps[axis], &mut self.active[axis], &mut out.axis_done[axis]);
                        }
                    }
                }
                if self.active[0] || self.active[1] {
                    all_done = false;
                }
                for axis in 0..2 {
                    if stepped[axis] {
                        let dir = if c.dir_bits & DIR[axis] != 0 { -1 } else { 1 };
                        self.counters[axis] = self.counters[axis].wrapping_add(i32::from(dir));
                        out.step[axis] = dir;
                    }
                }
            }
            Kind::Servo => out.servo = Some(c.servo),
            Kind::Enable => {
                out.enable = Some(c.enable);
                self.counters = [0; 2];
                self.acc = [0; 2];
            }
            _ => {}
        }
        if all_done && self.current.delay == 0 {
            self.finish(&mut out);
        }
        out
    }

    // The ISR works on parallel per-axis arrays, as the firmware does.
    #[allow(clippy::needless_range_loop)]
    fn tick_v3(&mut self) -> Tick {
        let mut out = Tick::default();
        let c = &mut self.current;
        let mut all_done = true;
        match c.kind {
            Kind::Simple | Kind::Move => {
                for axis in 0..2 {
                    if !self.active[axis] {
                        continue;
                    }
                    if c.kind == Kind::Move {
                        c.accel[axis] = c.accel[axis].wrapping_add(c.jerk[axis]);
                        c.rate[axis] = c.rate[axis].wrapping_add(c.accel[axis]);
                    }
                    self.acc[axis] = self.acc[axis].wrapping_add(c.rate[axis] as u32);
                    if self.acc[axis] & STEP_BIT == 0 {
                        continue;
                    }
                    self.acc[axis] &= !STEP_BIT;
                    if c.kind == Kind::Move {
                        // LM: the sign of the rate is the direction of this step.
                        set_dir(&mut c.dir_bits, axis, c.rate[axis] < 0);
                    }
                    out.step[axis] = if c.dir_bits & DIR[axis] != 0 { -1 } else { 1 };
                    count_step(&mut c.steps[axis], &mut self.active[axis], &mut out.axis_done[axis]);
                }
                if self.active[0] || self.active[1] {
                    all_done = false;
                }
            }
            Kind::Timed => {
                if self.active[0] {
                    all_done = false;
                    c.steps[0] = c.steps[0].wrapping_sub(1);
                    if c.steps[0] == 0 {
                        self.active[0] = false;
                    }
                    for axis in 0..2 {
                        c.accel[axis] = c.accel[axis].wrapping_add(c.jerk[axis]);
                        c.rate[axis] = c.rate[axis].wrapping_add(c.accel[axis]);
                        self.acc[axis] = self.acc[axis].wrapping_add(c.rate[axis] as u32);
                        if self.acc[axis] & STEP_BIT != 0 {
                            self.acc[axis] &= !STEP_BIT;
                            set_dir(&mut c.dir_bits, axis, c.rate[axis] < 0);
                            out.step[axis] = if c.rate[axis] < 0 { -1 } else { 1 };
                        }
                    }
                }
            }
            Kind::Servo | Kind::Delay => {
                if c.kind == Kind::Servo {
                    out.servo = Some(c.servo);
                }
                if c.delay != 0 {
                    c.delay -= 1;
                    if c.delay != 0 {
                        all_done = false;
                    }
                }
            }
            Kind::Enable => {
                out.enable = Some(c.enable);
                self.counters = [0; 2];
                self.acc = [0; 2];
            }
            Kind::None => {}
        }
        for axis in 0..2 {
            self.counters[axis] = self.counters[axis].wrapping_add(i32::from(out.step[axis]));
        }
        if all_done {
            self.finish(&mut out);
        }
        out
    }

    /// The current command is done: load the next one in this tick.
    fn finish(&mut self, out: &mut Tick) {
        let ended = self.current.kind;
        if ended != Kind::None {
            out.ended = Some(ended);
        }
        self.current.kind = Kind::None;
        let Some(next) = self.fifo.pop_front() else {
            self.current.delay = 0;
            return;
        };
        out.loaded = true;
        if self.fw.is_v3() {
            self.load_v3(next);
        } else {
            self.current = next;
        }
        let c = self.current;
        if c.kind.is_motion() {
            for axis in 0..2 {
                if self.fw.is_v3() && c.acc_init & DELAY_ACC[axis] != 0 {
                    self.acc[axis] = c.delay;
                }
                if c.acc_init & CLEAR_ACC[axis] != 0 {
                    self.acc[axis] = 0;
                }
                if c.acc_init & NEGATE_ACC[axis] != 0 {
                    self.acc[axis] = 0x7FFF_FFFF;
                }
                self.active[axis] = c.steps[axis] != 0;
            }
        }
    }

    /// 3.0.2 copies only the fields the next command's kind uses.
    fn load_v3(&mut self, n: Command) {
        let c = &mut self.current;
        c.kind = n.kind;
        match n.kind {
            Kind::Simple | Kind::Move => {
                (c.rate, c.steps, c.dir_bits, c.delay, c.acc_init) = (n.rate, n.steps, n.dir_bits, n.delay, n.acc_init);
                if n.kind == Kind::Move {
                    (c.accel, c.jerk) = (n.accel, n.jerk);
                }
            }
            Kind::Timed => {
                (c.rate, c.accel, c.jerk, c.dir_bits, c.delay, c.acc_init) = (n.rate, n.accel, n.jerk, n.dir_bits, n.delay, n.acc_init);
                c.steps[0] = n.steps[0];
            }
            Kind::Servo => (c.delay, c.servo) = (n.delay, n.servo),
            Kind::Delay => c.delay = n.delay,
            Kind::Enable => c.enable = n.enable,
            Kind::None => {}
        }
    }
}

/// A step-limited axis took a step: count it down; at zero the axis is done.
fn count_step(steps: &mut u32, active: &mut bool, done: &mut bool) {
    *steps = steps.wrapping_sub(1);
    if *steps == 0 {
        *active = false;
        *done = true;
    }
}

/// Ticks an accumulator at `acc` takes before the one that steps, adding
/// `rate` >= 0 (no step ever: `u64::MAX`).
fn between_steps(acc: i64, rate: i64) -> u64 {
    if rate == 0 {
        return u64::MAX;
    }
    let to_step = (i64::from(STEP_BIT) - acc + rate - 1) / rate;
    (to_step - 1).max(0) as u64
}

fn set_dir(bits: &mut u8, axis: usize, negative: bool) {
    if negative {
        *bits |= DIR[axis];
    } else {
        *bits &= !DIR[axis];
    }
}

/// 2.8.1's per-axis step: the rate takes the acceleration, a rate with bit 31
/// set is folded back by adding 2^31 (`Rate.bytes.b4 += 0x80`), the
/// accumulator takes the rate, and bit 31 of the accumulator is a step.
fn v2_accumulate(rate: &mut i32, accel: i32, acc: &mut u32) -> bool {
    *rate = rate.wrapping_add(accel);
    if *rate < 0 {
        *rate = (*rate as u32).wrapping_add(STEP_BIT) as i32;
    }
    *acc = acc.wrapping_add(*rate as u32);
    if *acc & STEP_BIT != 0 {
        *acc &= !STEP_BIT;
        true
    } else {
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ebb::rates::{self, Axis};

    /// A small deterministic generator (xorshift) for test moves.
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> u64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            self.0
        }
        fn range(&mut self, lo: i64, hi: i64) -> i64 {
            lo + (self.next() % (hi - lo) as u64) as i64
        }
    }

    /// Every step as (tick, axis, direction), the accumulators and counters at the end.
    type Run = (Vec<(u64, usize, i8)>, [u32; 2], [i32; 2]);

    fn run(mut e: Engine, skipping: bool) -> Run {
        let mut steps = Vec::new();
        let mut tick = 0;
        loop {
            if skipping {
                let q = e.quiet_ticks();
                if q == u64::MAX {
                    break;
                }
                e.skip(q);
                tick += q;
            } else if e.idle() {
                break;
            }
            tick += 1;
            let t = e.tick();
            for axis in 0..2 {
                if t.step[axis] != 0 {
                    steps.push((tick, axis, t.step[axis]));
                }
            }
        }
        (steps, e.acc, e.counters)
    }

    #[test]
    fn skipping_quiet_ticks_changes_nothing() {
        let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
        for fw in Firmware::ALL {
            for _ in 0..300 {
                let mut e = Engine::new(fw);
                e.set_depth(fw.max_fifo());
                e.acc = [rng.range(0, 1 << 31) as u32, rng.range(0, 1 << 31) as u32];
                let axis = |rng: &mut Rng| Axis {
                    rate: rng.range(-400_000_000, 400_000_000) as i32,
                    steps: rng.range(-300, 300) as i32,
                    accel: if rng.next() % 3 == 0 { rng.range(-20_000, 20_000) as i32 } else { 0 },
                    jerk: 0,
                };
                let cmd = match rng.next() % 3 {
                    0 => rates::v2_sm(rng.range(1, 400) as u32, [rng.range(-2000, 2000) as i32, rng.range(-2000, 2000) as i32], 0).command,
                    1 if fw.is_v3() => rates::v3_low_level(None, [axis(&mut rng), axis(&mut rng)], 0).unwrap_or_default(),
                    _ => {
                        let a = [axis(&mut rng), axis(&mut rng)];
                        if fw.is_v3() {
                            rates::v3_low_level(Some(rng.range(1, 3000) as u32), a, 0).unwrap()
                        } else {
                            rates::v2_lt(rng.range(1, 3000) as u32, [a[0].rate, a[1].rate], [a[0].accel, a[1].accel], 0)
                        }
                    }
                };
                let cmd = if fw.is_v3() && cmd.kind == Kind::Move && rng.next() % 2 == 0 {
                    Command { kind: Kind::Simple, accel: [0; 2], rate: [cmd.rate[0].abs(), cmd.rate[1].abs()], ..cmd }
                } else {
                    cmd
                };
                if cmd.kind == Kind::None {
                    continue;
                }
                e.push(cmd);
                assert_eq!(run(e.clone(), false), run(e, true), "{fw} {cmd:?}");
            }
        }
    }
}
