//! The EBB's step generator in numbers: the `LM` that carries out one
//! planned block and how long the firmware takes over it; the `SM` time
//! slices that stand in for it on firmware before 2.7.0.
//!
//! `LM,Rate1,Steps1,Accel1,Rate2,Steps2,Accel2,Clear` (firmware 2.7.0 and
//! later; EggBot `docs/ebb.html`): each axis keeps a 32-bit accumulator
//! (zeroed at the start with `Clear` = 3, which every `LM` plotd writes
//! has, so that a move runs the same whatever ran before it and on 2.x and
//! 3.x alike). The rate starts at `Rate - Accel/2` (integer division,
//! towards zero); every 40 µs tick the firmware adds `Accel` to the rate
//! and the rate to the accumulator, and steps once when the accumulator
//! reaches 2^31, taking 2^31 off. An axis stops after `|Steps|` steps (the
//! sign is the direction); the command ends when both have. A rate of `F`
//! steps/s is `F x 2^31 x 40 µs` = `F x 85,899.35`, so it must stay below
//! 2^31 (25,000 steps/s) and must not fall to 0 before the last step (the
//! firmware's rate cannot go negative: the axis would never finish).
//!
//! After `k` ticks the accumulator holds `S(k) = k (Rate - Accel/2) +
//! Accel k (k + 1) / 2` (the closed form of plotink's `ebb_calc`), so the
//! tick of the last step is the least `k` with `S(k) >= Steps x 2^31`,
//! found here exactly in integers.
//!
//! `SM,ms,Steps1,Steps2` moves both axes at constant rates for `ms`
//! milliseconds (2.x limits: 1.31 to 25,000 steps/s on an axis that moves,
//! at most 16,777,215 steps and milliseconds).

use super::motors::Motors;
use super::plan::Block;

/// Step generator ticks a second (one every 40 µs).
pub const TICKS_PER_SECOND: f64 = 25_000.0;

/// The accumulator's step threshold, 2^31.
const STEP: i128 = 1 << 31;

/// The largest rate an axis may have: below one step a tick.
pub const MAX_RATE: i64 = (1 << 31) - 1;

/// `LM`'s rate for one step a second.
pub const RATE_PER_STEP_S: f64 = (1u64 << 31) as f64 / TICKS_PER_SECOND;

/// `SM`'s slowest allowed rate on a moving axis (2.x), steps/s.
pub const SM_MIN_RATE: f64 = 1.31;

/// `SM`'s fastest allowed rate, steps/s.
pub const SM_MAX_RATE: f64 = 25_000.0;

/// Length of one `SM` time slice, seconds (the AxiDraw software's
/// `time_slice`).
pub const SM_SLICE_S: f64 = 0.025;

/// One axis of an `LM`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LmAxis {
    /// Starting rate (0 ..= [`MAX_RATE`]).
    pub rate: i64,
    /// Steps, signed by direction.
    pub steps: i64,
    /// Added to the rate every tick.
    pub accel: i64,
}

/// An `LM` command (with `Clear` = 3).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Lm {
    /// Motor 1.
    pub axis1: LmAxis,
    /// Motor 2.
    pub axis2: LmAxis,
}

/// An `SM` command.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Sm {
    /// Duration, ms (at least 1).
    pub ms: u32,
    /// Steps of motor 1 and motor 2.
    pub steps: Motors,
}

impl LmAxis {
    /// The tick of this axis's last step (0 for no steps); why not, when
    /// the axis would never finish or would need more than one step a tick.
    ///
    /// # Errors
    /// A message saying what is wrong with the numbers.
    pub fn ticks(&self) -> Result<u64, &'static str> {
        if self.steps == 0 {
            return Ok(0);
        }
        if self.rate < 0 || self.rate > MAX_RATE {
            return Err("rate outside 0 to 2147483647");
        }
        let n = i128::from(self.steps.unsigned_abs()) * STEP;
        let (rate, accel) = (i128::from(self.rate), i128::from(self.accel));
        // The rate after k ticks is c + accel k; the accumulator S(k).
        let c = rate - accel / 2;
        let sum = |k: i128| c * k + accel * k * (k + 1) / 2;
        let rate_at = |k: i128| c + accel * k;
        if rate_at(1) < 0 {
            return Err("the rate is negative at the first tick");
        }
        // The least k with S(k) >= n: from the quadratic's root, then exact.
        let guess = if accel == 0 {
            if c <= 0 {
                return Err("no rate and no acceleration: the axis never moves");
            }
            (n + c - 1) / c
        } else {
            let (a, b) = (accel as f64 / 2.0, c as f64 + accel as f64 / 2.0);
            let disc = b * b + 4.0 * a * n as f64;
            if disc < 0.0 {
                return Err("the rate falls to zero before the last step");
            }
            ((-b + disc.sqrt()) / (2.0 * a)).max(1.0) as i128
        };
        let mut k = guess.max(1);
        // A slowing axis whose rate reaches 0 first never gets there.
        let stall = if accel < 0 { Some(c / -accel) } else { None };
        while sum(k) < n {
            if stall.is_some_and(|s| k > s) {
                return Err("the rate falls to zero before the last step");
            }
            k += 1;
        }
        while k > 1 && sum(k - 1) >= n {
            k -= 1;
        }
        if rate_at(k) <= 0 {
            return Err("the rate falls to zero before the last step");
        }
        if rate_at(1).max(rate_at(k)) > i128::from(MAX_RATE) {
            return Err("more than one step a tick (25,000 steps/s)");
        }
        u64::try_from(k).map_err(|_| "too long")
    }
}

impl Lm {
    /// Ticks until both axes have made their last step.
    ///
    /// # Errors
    /// An axis that never finishes ([`LmAxis::ticks`]), or one that does
    /// not move at all on both.
    pub fn ticks(&self) -> Result<u64, &'static str> {
        if self.axis1.steps == 0 && self.axis2.steps == 0 {
            return Err("no steps on either axis");
        }
        Ok(self.axis1.ticks()?.max(self.axis2.ticks()?))
    }

    /// The `LM` that carries out `block`: each motor's rate ramps from the
    /// block's start speed to its end speed in proportion to its share of
    /// the steps, over the block's planned time rounded up to whole ticks;
    /// the firmware
    /// then makes exactly the block's steps on each motor, the last of them
    /// on that tick.
    #[must_use]
    pub fn of(block: &Block) -> Lm {
        let steps = block.from.to(block.to);
        let len = block.length();
        // Up to whole ticks: never faster, nor harder, than planned.
        let ticks = (block.seconds() * TICKS_PER_SECOND - 1e-6).ceil().max(1.0) as i64;
        let axis = |n: i64| {
            let share = n.unsigned_abs() as f64 / len;
            axis_for(n, block.v0 * share, block.v1 * share, ticks)
        };
        Lm { axis1: axis(steps.m1), axis2: axis(steps.m2) }
    }
}

/// One axis making `steps` steps at rates from `f0` to `f1` steps/s in
/// `ticks` ticks. The acceleration is the rate's change over the ticks; the
/// starting rate is then the least that brings the accumulator to `steps x
/// 2^31` on the last tick (short of it by less than one tick's rate the
/// tick before): the integer rounding of both goes into the start rate,
/// less than a step a second, and none into where the last step falls,
/// which a slowly moving axis would otherwise shift by many ticks. A
/// stopping axis ends at half a tick's deceleration, above 0.
fn axis_for(steps: i64, f0: f64, f1: f64, ticks: i64) -> LmAxis {
    if steps == 0 {
        return LmAxis { rate: 0, steps: 0, accel: 0 };
    }
    let n = i128::from(steps.unsigned_abs()) * STEP;
    let t = i128::from(ticks.max(1));
    let accel = ((f1 - f0) * RATE_PER_STEP_S / t as f64).round() as i64;
    let a = i128::from(accel);
    // S(t) = t c + a t (t + 1) / 2 >= n with c = rate - a/2 as small as can be.
    let need = n - a * t * (t + 1) / 2;
    let c = need.div_euclid(t) + i128::from(need.rem_euclid(t) != 0);
    let rate = (c + a / 2).clamp(0, i128::from(MAX_RATE)) as i64;
    let mut axis = LmAxis { rate, steps, accel };
    // An axis whose share of a slow block is a few steps can still round to
    // a stall; a little less deceleration gets it there.
    for _ in 0..64 {
        if axis.ticks().is_ok() {
            return axis;
        }
        axis.accel += 1;
    }
    // Not reached for planned blocks; a steady rate that finishes in time.
    let steady = n as f64 / t as f64;
    LmAxis { rate: (steady.ceil() as i64).clamp(1, MAX_RATE), steps, accel: 0 }
}

/// The `SM` slices that carry out `block` on firmware before 2.7.0: the
/// block's time rounded up to whole milliseconds and shared out in slices
/// of about [`SM_SLICE_S`], each at the block's mean speed over it (motor
/// positions rounded from the block's start, nothing carried); a slice with
/// no steps merged into the next, and a slice lengthened to keep each moving
/// axis within 25,000 steps/s.
#[must_use]
pub fn sm_slices(block: &Block) -> Vec<Sm> {
    let steps = block.from.to(block.to);
    let (t, len, a) = (block.seconds(), block.length(), block.acceleration());
    // Up, never faster than planned; SM takes whole milliseconds.
    let total_ms = ((t * 1000.0) - 1e-9).ceil().max(1.0) as i64;
    let count = (total_ms as f64 / (SM_SLICE_S * 1000.0)).ceil().max(1.0) as i64;
    let mut out = Vec::with_capacity(count as usize);
    let (mut done, mut done_ms) = (Motors::default(), 0_i64);
    for j in 1..=count {
        // Slice ends at whole milliseconds, evenly spread.
        let ms_end = total_ms * j / count;
        let pos = if j == count {
            steps
        } else {
            let tau = t * ms_end as f64 / total_ms as f64;
            let along = ((block.v0 * tau + a * tau * tau / 2.0) / len).clamp(0.0, 1.0);
            let at = |n: i64| (n as f64 * along).round() as i64;
            Motors::new(at(steps.m1), at(steps.m2))
        };
        let d = done.to(pos);
        if d == Motors::default() {
            continue;
        }
        let mut ms = (ms_end - done_ms).max(1);
        let fastest = d.m1.unsigned_abs().max(d.m2.unsigned_abs()) as f64;
        while fastest * 1000.0 / ms as f64 > SM_MAX_RATE {
            ms += 1;
        }
        let slowest = [d.m1, d.m2].into_iter().filter(|&n| n != 0).map(i64::unsigned_abs).min().unwrap_or(1) as f64;
        ms = ms.min((slowest * 1000.0 / SM_MIN_RATE).floor() as i64).max(1);
        out.push(Sm { ms: ms as u32, steps: d });
        done = pos;
        done_ms = ms_end.max(done_ms + ms);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn seconds(lm: &Lm) -> f64 {
        lm.ticks().unwrap() as f64 / TICKS_PER_SECOND
    }

    fn one_axis(rate: i64, steps: i64, accel: i64) -> Lm {
        Lm { axis1: LmAxis { rate, steps, accel }, axis2: LmAxis { rate: 0, steps: 0, accel: 0 } }
    }

    /// The examples in the LM documentation (EggBot `docs/ebb.html`), with
    /// the durations it gives.
    #[test]
    fn the_documented_examples_take_the_documented_time() {
        // Example 1: 45 to 250 steps/s over 60 steps, "0.4068 seconds".
        assert!((seconds(&one_axis(3_865_471, 60, 1732)) - 0.4068).abs() < 0.001);
        // Example 2: 45 steps/s (the text's rate has a stray digit: 33865471
        // is 394 steps/s) for 1000 steps.
        assert!((seconds(&one_axis(3_865_471, 1000, 0)) - 1000.0 / 45.0).abs() < 0.001);
        // Example 3: 10 ms, axis 1 every 1 ms, axis 2 every 5 ms.
        let ex3 = Lm { axis1: LmAxis { rate: 85_899_346, steps: 10, accel: 0 }, axis2: LmAxis { rate: 17_180_814, steps: 2, accel: 0 } };
        assert_eq!(ex3.ticks(), Ok(250));
        // Example 6: 500 to 800 steps/s over 50 steps, "77 ms".
        assert!((seconds(&one_axis(42_950_000, 50, 13_400)) - 0.077).abs() < 0.0005);
        // Example 7: 200 down to 100 and 100 up to 200 steps/s, 75 steps each, "500 ms".
        let ex7 =
            Lm { axis1: LmAxis { rate: 17_179_000, steps: 75, accel: -687 }, axis2: LmAxis { rate: 8_592_000, steps: 75, accel: 687 } };
        assert!((seconds(&ex7) - 0.5).abs() < 0.001, "{}", seconds(&ex7));
    }

    /// The closed form against the firmware's loop, tick by tick.
    #[test]
    fn ticks_are_where_the_tick_loop_takes_the_last_step() {
        let by_loop = |a: LmAxis| {
            let (mut rate, mut acc, mut made, mut k) = (a.rate - a.accel / 2, 0_i64, 0, 0_u64);
            while made < a.steps.abs() {
                k += 1;
                rate += a.accel;
                assert!(rate >= 0 && k < 10_000_000, "{a:?}");
                acc += rate;
                if acc >= 1 << 31 {
                    acc -= 1 << 31;
                    made += 1;
                }
            }
            k
        };
        for a in [
            LmAxis { rate: 0, steps: 37, accel: 5_000 },
            LmAxis { rate: 1_000_000_000, steps: -4_000, accel: -3 },
            LmAxis { rate: 85_899_346, steps: 1, accel: 0 },
            LmAxis { rate: 2_000_000_000, steps: 900, accel: -1_999 },
            LmAxis { rate: 123_456_789, steps: 7, accel: 3 },
            LmAxis { rate: 9_000, steps: 1, accel: 0 },
        ] {
            assert_eq!(a.ticks(), Ok(by_loop(a)), "{a:?}");
        }
        assert!(LmAxis { rate: 1_000_000, steps: 1_000, accel: -1_000 }.ticks().is_err(), "stalls");
        assert!(LmAxis { rate: 0, steps: 3, accel: 0 }.ticks().is_err());
        assert!(LmAxis { rate: 2_100_000_000, steps: 90, accel: 10_000_000 }.ticks().is_err(), "too fast");
    }

    #[test]
    fn a_planned_block_becomes_an_lm_of_its_steps_and_time() {
        // 0 to 4000 steps/s along x over 500 steps (0.25 s): both motors.
        let block = Block { from: Motors::new(0, 0), to: Motors::new(500, 500), v0: 0.0, v1: 4000.0 };
        let lm = Lm::of(&block);
        assert_eq!((lm.axis1.steps, lm.axis2.steps), (500, 500));
        // Both motors make their last step on the block's last tick.
        assert_eq!((lm.axis1.ticks(), lm.axis2.ticks()), (Ok(6250), Ok(6250)));
        // Stopping from speed: on time, the rate still above 0.
        let stop = Block { from: Motors::new(500, 500), to: Motors::new(1000, 0), v0: 4000.0, v1: 0.0 };
        let lm = Lm::of(&stop);
        assert_eq!((lm.axis1.steps, lm.axis2.steps), (500, -500));
        assert_eq!(lm.ticks(), Ok((stop.seconds() * TICKS_PER_SECOND).ceil() as u64));
        // A motor with a small share of a slow block still finishes.
        let crawl = Block { from: Motors::new(0, 0), to: Motors::new(3, 1), v0: 30.0, v1: 0.0 };
        assert!(Lm::of(&crawl).ticks().is_ok());
    }

    #[test]
    fn sm_slices_add_up_to_the_block() {
        let block = Block { from: Motors::new(10, 0), to: Motors::new(1010, -333), v0: 0.0, v1: 3000.0 };
        let slices = sm_slices(&block);
        let total = slices.iter().fold(Motors::default(), |a, s| a.plus(s.steps));
        assert_eq!(total, Motors::new(1000, -333));
        let ms: u32 = slices.iter().map(|s| s.ms).sum();
        assert_eq!(f64::from(ms), (block.seconds() * 1000.0).ceil(), "whole milliseconds, rounded up");
        for s in &slices {
            for n in [s.steps.m1, s.steps.m2] {
                let rate = n.unsigned_abs() as f64 * 1000.0 / f64::from(s.ms);
                assert!(n == 0 || (SM_MIN_RATE..=SM_MAX_RATE).contains(&rate), "{s:?}");
            }
        }
    }
}
