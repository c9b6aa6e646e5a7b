//! How each firmware turns the arguments of SM, XM, HM, LM and LT into the
//! rates, step counts and accumulator treatment its ISR runs.
//!
//! Sources: `process_SM`, `parse_LM_packet`, `parse_LT_packet`,
//! `parse_HM_packet` of 2.8.1 and `process_simple_motor_move_fp`,
//! `process_simple_rate_move_fp`, `process_low_level_move` of 3.0.2
//! (`ebb.c`). The arithmetic is the firmware's: 2.8.1's SM rate is a 16.16
//! fixed-point quotient in unsigned 32-bit registers (whose remainder term
//! overflows for moves over 2621 ms, as on the board); 3.0.2 uses single
//! precision floats (IEEE-754 rounding is assumed for the PIC's float
//! library). Integer division by zero, which the PIC's library routine
//! answers with all ones, is taken to give `u32::MAX`.

use super::motion::{Command, Kind, CLEAR_ACC, DIR, NEGATE_ACC};

/// 2.8.1: `HIGH_ISR_TICKS_PER_MS`.
const TICKS_PER_MS: u32 = 25;

/// The PIC C library's unsigned division (x / 0 is all ones).
fn div(a: u32, b: u32) -> u32 {
    a.checked_div(b).unwrap_or(u32::MAX)
}

fn rem(a: u32, b: u32) -> u32 {
    a.checked_rem(b).unwrap_or(a)
}

/// A message the firmware prints while computing a move ("Major
/// malfunction ..."), and the move it queues anyway.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct Computed {
    pub command: Command,
    pub notes: Vec<String>,
}

/// 2.8.1 `process_SM`: a constant-rate move of `steps` on each axis in
/// `duration_ms`, or a delay when both are zero. `clear` is the accumulator
/// mask (0..=3).
pub(crate) fn v2_sm(duration_ms: u32, steps: [i32; 2], clear: u8) -> Computed {
    let mut c = Command { acc_init: clear.min(3), ..Command::default() };
    let mut notes = Vec::new();
    if steps == [0, 0] {
        c.kind = Kind::Delay;
        c.delay = TICKS_PER_MS.wrapping_mul(duration_ms);
        return Computed { command: c, notes };
    }
    c.kind = Kind::Move;
    // The second axis starts from the first axis's value when it has no
    // steps (the firmware reuses `temp`); it never steps, so it is harmless.
    let mut temp = 0u32;
    for axis in 0..2 {
        let mut s = steps[axis];
        if s < 0 {
            c.dir_bits |= DIR[axis];
            s = s.wrapping_neg();
        }
        let s = s as u32;
        if s != 0 {
            let mut remainder = 0u32;
            if s < 0x1FFFF {
                let ticks = TICKS_PER_MS.wrapping_mul(duration_ms);
                temp = div(s << 15, ticks);
                let left = rem(s << 15, ticks);
                if duration_ms > 30 {
                    remainder = div(left << 16, ticks);
                }
            } else {
                temp = div(div(s, duration_ms).wrapping_mul(0x8000), TICKS_PER_MS);
            }
            if temp > 0x8000 {
                notes.push(format!("Major malfunction Axis{} StepCounter too high : {temp}\n\r", axis + 1));
                temp = 0x8000;
            }
            if temp == 0 {
                notes.push(format!("Major malfunction Axis{} StepCounter zero\n\r", axis + 1));
                temp = 1;
            }
            temp = if duration_ms > 30 { (temp << 16).wrapping_add(remainder) } else { temp << 16 };
        } else if axis == 0 {
            temp = 0;
        }
        c.rate[axis] = temp.min(0x7FFF_FFFF) as i32;
        c.steps[axis] = s;
    }
    Computed { command: c, notes }
}

/// Why 2.8.1's SM or XM refuses a move: the line it prints (no OK follows).
pub(crate) fn v2_sm_limits(duration_ms: u32, steps: [i32; 2]) -> Option<&'static str> {
    if duration_ms > 0xFF_FFFF {
        return Some("!0 Err: <move_duration> larger than 16777215 ms.\n\r");
    }
    let msgs = [
        [
            "!0 Err: <axis1> larger than 16777215 steps.\n\r",
            "!0 Err: <axis1> step rate > 25K steps/second.\n\r",
            "!0 Err: <axis1> step rate < 1.31Hz.\n\r",
        ],
        [
            "!0 Err: <axis2> larger than 16777215 steps.\n\r",
            "!0 Err: <axis2> step rate > 25K steps/second.\n\r",
            "!0 Err: <axis2> step rate < 1.31Hz.\n\r",
        ],
    ];
    for axis in 0..2 {
        // The firmware's `Steps` is a signed 32-bit absolute value, compared
        // signed and divided unsigned.
        let s = steps[axis].wrapping_abs();
        if s > 0xFF_FFFF {
            return Some(msgs[axis][0]);
        }
        if div(s as u32, duration_ms) > TICKS_PER_MS {
            return Some(msgs[axis][1]);
        }
        if div(duration_ms, 1311) >= s as u32 && s != 0 {
            return Some(msgs[axis][2]);
        }
    }
    None
}

/// 2.8.1 `parse_LM_packet` after its checks: rates are unsigned (at most
/// 2^31-1), half the acceleration is taken off the rate (the ISR adds a
/// whole one before the first step), the step signs give the directions.
pub(crate) fn v2_lm(rate: [u32; 2], steps: [i32; 2], accel: [i32; 2], clear: u8) -> Command {
    let mut c = Command { kind: Kind::Move, acc_init: clear.min(3), accel, ..Command::default() };
    for axis in 0..2 {
        let r = rate[axis].min(0x7FFF_FFFF);
        let a = accel[axis];
        let r = if a < 0 { r.wrapping_add((a.wrapping_neg() >> 1) as u32) } else { r.wrapping_sub((a >> 1) as u32) };
        c.rate[axis] = r as i32;
        let mut s = steps[axis];
        if s < 0 {
            c.dir_bits |= DIR[axis];
            s = s.wrapping_neg();
        }
        c.steps[axis] = s as u32;
    }
    c
}

/// 2.8.1 `parse_LT_packet` after its checks: the rate signs give the
/// directions; `steps[0]` carries the intervals.
pub(crate) fn v2_lt(intervals: u32, rate: [i32; 2], accel: [i32; 2], clear: u8) -> Command {
    let mut c = Command { kind: Kind::Timed, acc_init: clear.min(3), accel, ..Command::default() };
    for axis in 0..2 {
        let mut r = rate[axis];
        if r < 0 {
            c.dir_bits |= DIR[axis];
            r = r.wrapping_neg();
        }
        let a = accel[axis];
        c.rate[axis] = if a < 0 { r.wrapping_add(a.wrapping_neg() >> 1) } else { r.wrapping_sub(a >> 1) };
    }
    c.steps = [intervals, 0];
    c
}

/// One axis of a move for [`v3_low_level`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Axis {
    pub rate: i32,
    pub steps: i32,
    pub accel: i32,
    pub jerk: i32,
}

/// Why 3.0.2 refuses an LM: a negative step count with a negative rate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct BadDirection;

/// 3.0.2 `process_low_level_move` for LM/L3 (`intervals` None) and LT/T3:
/// the legacy negative step count flips rate and acceleration; half the
/// acceleration comes off the rate and a sixth of the jerk goes on (C
/// division, towards zero), a whole jerk comes off the acceleration (the ISR
/// adds it back before the first step); a cleared accumulator starts at
/// 2^31-1 when the first tick's rate is negative (or zero and heading
/// negative), so the first step comes as early as it would going forwards.
pub(crate) fn v3_low_level(intervals: Option<u32>, mut axes: [Axis; 2], clear: u32) -> Result<Command, BadDirection> {
    let clear = clear.min(3) as u8;
    if intervals.is_none() {
        for a in &mut axes {
            if a.steps < 0 {
                if a.rate < 0 {
                    return Err(BadDirection);
                }
                a.steps = a.steps.wrapping_neg();
                a.rate = a.rate.wrapping_neg();
                a.accel = a.accel.wrapping_neg();
            }
        }
    }
    let mut c = Command { kind: if intervals.is_some() { Kind::Timed } else { Kind::Move }, ..Command::default() };
    for (axis, a) in axes.iter().enumerate() {
        let rate = a.rate.wrapping_sub(a.accel / 2).wrapping_add(a.jerk / 6);
        if clear & CLEAR_ACC[axis] != 0 {
            let first = rate.wrapping_add(a.accel);
            let then = a.accel.wrapping_add(a.jerk);
            let negative = first < 0 || (first == 0 && (then < 0 || (then == 0 && a.jerk < 0)));
            c.acc_init |= if negative { NEGATE_ACC[axis] } else { CLEAR_ACC[axis] };
        }
        c.rate[axis] = rate;
        c.accel[axis] = a.accel.wrapping_sub(a.jerk);
        c.jerk[axis] = a.jerk;
        c.steps[axis] = a.steps as u32;
    }
    if let Some(n) = intervals {
        c.steps = [n, 0];
    }
    Ok(c)
}

/// 3.0.2's SM/XM errors (printed, then the command still answers OK).
pub(crate) const V3_RATE_ERRORS: [[&str; 2]; 2] = [
    ["!0 Err: <axis1> step rate too high.", "!0 Err: <axis1> step rate too slow."],
    ["!0 Err: <axis2> step rate too high.", "!0 Err: <axis2> step rate too slow."],
];

/// 3.0.2 `process_simple_motor_move_fp` after its checks: a delay (capped
/// at 100 s) or a constant-rate move. With limit checks on, a rate above
/// 2^31 or of zero refuses the move and names the axis and which limit
/// (index into [`V3_RATE_ERRORS`]); with them off the rate is clamped.
pub(crate) fn v3_sm(duration_ms: u32, steps: [i32; 2], clear: u32, checks: bool) -> Result<Command, (usize, usize)> {
    let mut c = Command { acc_init: clear as u8, ..Command::default() };
    if steps == [0, 0] {
        c.kind = Kind::Delay;
        c.delay = TICKS_PER_MS.wrapping_mul(duration_ms.min(100_000));
        return Ok(c);
    }
    c.kind = Kind::Simple;
    let per_step = 85_899_345.92f32 / duration_ms as f32;
    for axis in 0..2 {
        let mut s = steps[axis];
        if s < 0 {
            c.dir_bits |= DIR[axis];
            s = s.wrapping_neg();
        }
        if s != 0 {
            let mut rate = (s as f32 * per_step) as u32;
            if rate > 0x8000_0000 {
                if checks {
                    return Err((axis, 0));
                }
                rate = 0x8000_0000;
            }
            if rate == 0 {
                if checks {
                    return Err((axis, 1));
                }
                rate = 1;
            }
            c.rate[axis] = rate as i32;
        }
        c.steps[axis] = s as u32;
    }
    Ok(c)
}

/// 3.0.2's `85899.34592f` (2^31 / 25000): as an f32 both it and this
/// literal are 85899.34375.
const STEPS_TO_RATE: f32 = 85_899.34;

/// 3.0.2 `process_simple_rate_move_fp` (HM): the axis with more steps runs
/// at `rate` steps/s, the other in proportion so the line is straight. None
/// when there is nothing to move.
pub(crate) fn v3_rate_move(rate: u32, steps: [i32; 2]) -> Option<Command> {
    if steps == [0, 0] {
        return None;
    }
    let mut c = Command { kind: Kind::Simple, ..Command::default() };
    let mut s = [0u32; 2];
    for axis in 0..2 {
        let mut v = steps[axis];
        if v < 0 {
            c.dir_bits |= DIR[axis];
            v = v.wrapping_neg();
        }
        s[axis] = v as u32;
    }
    let (major, minor) = if s[0] as i32 >= s[1] as i32 { (0, 1) } else { (1, 0) };
    c.rate[major] = (rate as f32 * STEPS_TO_RATE) as i32;
    if s[minor] != 0 {
        let f = (s[minor] as i32 as f32) * rate as f32 / (s[major] as i32 as f32) * STEPS_TO_RATE;
        c.rate[minor] = if f < 1.0 {
            1
        } else if f > 2_147_483_647.0 {
            i32::MAX
        } else {
            f as i32
        };
    }
    c.steps = s;
    Some(c)
}

/// 2.8.1 `parse_HM_packet` from the global step counters: the moves it
/// queues (one, or two when the minor axis would step below 1.31 Hz), or
/// the line it prints instead.
pub(crate) fn v2_home(rate: u32, counters: [i32; 2], target: [i32; 2]) -> Result<Vec<Computed>, &'static str> {
    let mut s = [target[0].wrapping_sub(counters[0]), target[1].wrapping_sub(counters[1])];
    let abs = [s[0].wrapping_abs(), s[1].wrapping_abs()];
    if abs[0] > 0xFF_FFFF || abs[1] > 0xFF_FFFF {
        return Err("!0 Err: steps to home larger than 16,777,215.\n\r");
    }
    // `(AbsSteps * 1000) / StepRate`: a signed 32-bit product, divided unsigned.
    let duration = |steps: i32| div(steps.wrapping_mul(1000) as u32, rate);
    let mut moves = Vec::new();
    let (major, minor) = if abs[0] > abs[1] { (0, 1) } else { (1, 0) };
    let mut d = duration(abs[major]);
    if div(rate, 1000) > TICKS_PER_MS {
        return Err(if major == 0 {
            "!0 Err: HM <axis1> step rate > 25K steps/second.\n\r"
        } else {
            "!0 Err: HM <axis2> step rate > 25K steps/second.\n\r"
        });
    }
    if div(d, 1311) >= abs[minor] as u32 && abs[minor] != 0 {
        // Dog-leg: first a diagonal that brings the minor axis home, with the
        // major axis moving as far in its own direction.
        let first = duration(abs[minor]);
        let x = if s[major] > 0 { abs[minor] } else { abs[minor].wrapping_neg() };
        let mut leg = [0; 2];
        leg[major] = x;
        leg[minor] = s[minor];
        moves.push(v2_sm(first, leg, 3));
        s[major] = s[major].wrapping_sub(x);
        s[minor] = 0;
        d = duration(abs[major]);
    }
    moves.push(v2_sm(d.max(10), s, 3));
    Ok(moves)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn v2_sm_rate_is_the_fixed_point_quotient() {
        // 1000 steps in 1000 ms: 1 step/ms = 1/25 step per tick = 2^31 / 25.
        let c = v2_sm(1000, [1000, -500], 0).command;
        assert_eq!(c.kind, Kind::Move);
        assert_eq!(c.steps, [1000, 500]);
        assert_eq!(c.dir_bits, DIR[1]);
        // temp = (1000 << 15) / 25000 = 1310, remainder (14_480_000 ... ) as the firmware computes.
        let ticks = 25_000u32;
        let q = (1000u32 << 15) / ticks;
        let r = ((1000u32 << 15) % ticks) << 16;
        assert_eq!(c.rate[0] as u32, (q << 16) + r / ticks);
        assert!((f64::from(c.rate[0]) - 85_899_345.92).abs() < 2.0, "{}", c.rate[0]);
    }
}
