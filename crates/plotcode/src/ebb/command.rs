//! The commands an EBB program is made of, written and read back.
//!
//! A program is ASCII commands, each ended by a carriage return (`\r`; the
//! EBB takes nothing else as the end of a command, so a file of them shows
//! as one line to most tools: `tr '\r' '\n' < plot.ebb` reads it). Only
//! the motion vocabulary is here: what plotd writes (`SC`, `SP`, `EM`, `SL`,
//! `LM`, `SM`, and `HM` in resume prefixes) and `XM`, which other drivers
//! write; the board's queries and immediate controls are
//! [`crate::control::ebb`], their answers [`crate::answer::ebb`].

use super::lm::{Lm, LmAxis, Sm};
use super::motors::Motors;
use std::fmt;

/// The longest command the EBB takes, with its carriage return.
pub const MAX_COMMAND_BYTES: usize = 256;

/// `SL` values from this one up carry a pen number (`SL,128+pen`): the
/// AxiDraw software keeps its own codes, 1 to 121, in the same variable,
/// and must not take plotd's for its own.
pub const PEN_MARK: u32 = 128;

/// The highest pen number a program can carry.
pub const MAX_PEN: u32 = 255 - PEN_MARK;

/// One command of a program.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Command {
    /// `SC,param,value`: a servo setting (4: pen-up position, 5: pen-down
    /// position, 11: raising rate, 12: lowering rate).
    ServoConfig {
        /// Which setting.
        param: u8,
        /// Its value.
        value: u16,
    },
    /// `SP,1,ms` (up) or `SP,0,ms` (down): move the pen, and start the next
    /// command `ms` later (no duration written for 0).
    Pen {
        /// Up (`SP,1`, also `SP,2` and `SP,3` when read) or down (`SP,0`).
        up: bool,
        /// The wait, ms.
        ms: u32,
    },
    /// `EM,mode,mode`: enable both motors in a step mode (1: 1/16 steps);
    /// the step counters start again at 0 where the carriage is (home).
    EnableMotors {
        /// Motor 1's value, which sets the step mode (0 disables).
        mode: u8,
        /// Motor 2's value (0 disables).
        mode2: u8,
    },
    /// `SL,128+pen`: the pen the strokes after it are drawn with (the
    /// EBB stores the number and does nothing with it).
    PenNumber(u32),
    /// A low-level move.
    Lm(Lm),
    /// A constant-rate move of both motors (or a pause).
    Sm(Sm),
    /// `XM,ms,a,b`: an `SM` of motor 1 `a + b`, motor 2 `a - b`.
    Xm {
        /// Duration, ms.
        ms: u32,
        /// Steps along the mixed axes.
        a: i64,
        /// Steps along the mixed axes.
        b: i64,
    },
    /// `HM,rate` (home) or `HM,rate,m1,m2` (firmware 2.7.0: to these
    /// counters), the fastest motor at `rate` steps/s.
    Home {
        /// Step rate, 2 to 25,000 steps/s.
        rate: u32,
        /// Where to, `None` for home (0, 0).
        to: Option<Motors>,
    },
}

impl Command {
    /// The steps each motor turns, for the moves that say so (not `HM`).
    #[must_use]
    pub fn steps(&self) -> Option<Motors> {
        match *self {
            Command::Lm(lm) => Some(Motors::new(lm.axis1.steps, lm.axis2.steps)),
            Command::Sm(sm) => Some(sm.steps),
            Command::Xm { a, b, .. } => Some(Motors::new(a + b, a - b)),
            _ => None,
        }
    }

    /// Reads one command (without its carriage return).
    ///
    /// # Errors
    /// What is wrong with it: an unknown command, a missing, extra or bad
    /// number.
    pub fn parse(line: &str) -> Result<Command, String> {
        let mut words = line.trim().split(',');
        let name = words.next().unwrap_or_default().to_ascii_uppercase();
        let args: Vec<&str> = words.collect();
        let numbers = |min: usize, max: usize| -> Result<Vec<i64>, String> {
            if args.len() < min || args.len() > max {
                let want = if min == max { format!("{min}") } else { format!("{min} to {max}") };
                return Err(format!("{name} takes {want} numbers, got {}", args.len()));
            }
            args.iter()
                .enumerate()
                .map(|(i, a)| {
                    a.trim().parse::<i64>().map_err(|_| format!("{name} argument {}: {:?} is not a whole number", i + 1, short(a)))
                })
                .collect()
        };
        let within = |v: i64, lo: i64, hi: i64, what: &str| {
            if (lo..=hi).contains(&v) {
                Ok(v)
            } else {
                Err(format!("{name}: {what} {v} is outside {lo} to {hi}"))
            }
        };
        Ok(match name.as_str() {
            "SC" => {
                let v = numbers(2, 2)?;
                Command::ServoConfig { param: within(v[0], 0, 255, "setting")? as u8, value: within(v[1], 0, 65535, "value")? as u16 }
            }
            "SP" => {
                let v = numbers(1, 3)?;
                let state = within(v[0], 0, 3, "pen state")?;
                // SP,2 and SP,3 lift at once and take no duration.
                let ms = if state >= 2 { 0 } else { within(v.get(1).copied().unwrap_or(0), 0, 65535, "duration")? as u32 };
                Command::Pen { up: state != 0, ms }
            }
            "EM" => {
                let v = numbers(1, 2)?;
                let mode = within(v[0], 0, 5, "mode")? as u8;
                Command::EnableMotors { mode, mode2: within(v.get(1).copied().unwrap_or(mode.into()), 0, 5, "mode")? as u8 }
            }
            "SL" => {
                let v = numbers(1, 2)?;
                Command::PenNumber(within(v[0], 0, 255, "value")? as u32)
            }
            "LM" => {
                let v = numbers(6, 7)?;
                let axis = |r: i64, s: i64, a: i64| -> Result<LmAxis, String> {
                    let word = |v: i64| within(v, i64::from(i32::MIN), i64::from(i32::MAX), "argument");
                    Ok(LmAxis { rate: within(r, 0, i64::from(i32::MAX), "rate")?, steps: word(s)?, accel: word(a)? })
                };
                if let Some(&clear) = v.get(6) {
                    within(clear, 0, 3, "clear")?;
                }
                Command::Lm(Lm { axis1: axis(v[0], v[1], v[2])?, axis2: axis(v[3], v[4], v[5])? })
            }
            "SM" => {
                let v = numbers(2, 4)?;
                let steps = |v: i64| within(v, -16_777_215, 16_777_215, "steps");
                let ms = within(v[0], 1, 16_777_215, "duration")? as u32;
                Command::Sm(Sm { ms, steps: Motors::new(steps(v[1])?, steps(v.get(2).copied().unwrap_or(0))?) })
            }
            "XM" => {
                let v = numbers(3, 4)?;
                let steps = |v: i64| within(v, -16_777_215, 16_777_215, "steps");
                Command::Xm { ms: within(v[0], 1, 16_777_215, "duration")? as u32, a: steps(v[1])?, b: steps(v[2])? }
            }
            "HM" => {
                let v = numbers(1, 3)?;
                let rate = within(v[0], 2, 25_000, "rate")? as u32;
                let to = match v.len() {
                    1 => None,
                    3 => Some(Motors::new(v[1], v[2])),
                    _ => return Err("HM takes a rate, or a rate and two positions".to_owned()),
                };
                Command::Home { rate, to }
            }
            "" => return Err("empty command".to_owned()),
            _ => return Err(format!("{} is not a command of a plot", short(&name))),
        })
    }
}

impl fmt::Display for Command {
    /// The command as the EBB takes it, without its carriage return.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Command::ServoConfig { param, value } => write!(f, "SC,{param},{value}"),
            Command::Pen { up, ms: 0 } => write!(f, "SP,{}", u8::from(up)),
            Command::Pen { up, ms } => write!(f, "SP,{},{ms}", u8::from(up)),
            Command::EnableMotors { mode, mode2 } => write!(f, "EM,{mode},{mode2}"),
            Command::PenNumber(v) => write!(f, "SL,{v}"),
            Command::Lm(Lm { axis1: a, axis2: b }) => {
                write!(f, "LM,{},{},{},{},{},{},3", a.rate, a.steps, a.accel, b.rate, b.steps, b.accel)
            }
            Command::Sm(Sm { ms, steps }) => write!(f, "SM,{ms},{},{}", steps.m1, steps.m2),
            Command::Xm { ms, a, b } => write!(f, "XM,{ms},{a},{b}"),
            Command::Home { rate, to: None } => write!(f, "HM,{rate}"),
            Command::Home { rate, to: Some(m) } => write!(f, "HM,{rate},{},{}", m.m1, m.m2),
        }
    }
}

/// At most 20 characters of `s`, for messages.
fn short(s: &str) -> String {
    s.chars().take(20).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn commands_read_back_as_written() {
        let lm = Lm { axis1: LmAxis { rate: 85_899_346, steps: -10, accel: 0 }, axis2: LmAxis { rate: 0, steps: 3, accel: 17 } };
        for c in [
            Command::ServoConfig { param: 4, value: 20641 },
            Command::Pen { up: true, ms: 130 },
            Command::Pen { up: false, ms: 0 },
            Command::EnableMotors { mode: 1, mode2: 1 },
            Command::PenNumber(PEN_MARK + 2),
            Command::Lm(lm),
            Command::Sm(Sm { ms: 25, steps: Motors::new(-4, 9) }),
            Command::Xm { ms: 10, a: 3, b: -1 },
            Command::Home { rate: 4000, to: None },
            Command::Home { rate: 4000, to: Some(Motors::new(-7, 12)) },
        ] {
            assert_eq!(Command::parse(&c.to_string()), Ok(c), "{c}");
        }
        assert_eq!(Command::Lm(lm).to_string(), "LM,85899346,-10,0,0,3,17,3");
        assert_eq!(Command::parse("sp,3"), Ok(Command::Pen { up: true, ms: 0 }), "any case; SP,3 is up");
        assert_eq!(Command::parse("XM,10,3,-1").unwrap().steps(), Some(Motors::new(2, 4)));
    }

    #[test]
    fn bad_commands_say_what_is_wrong() {
        for (line, says) in [
            ("QS", "QS is not a command of a plot"),
            ("LM,1,2,3", "LM takes 6 to 7 numbers, got 3"),
            ("SM,0,1,1", "duration 0 is outside 1 to 16777215"),
            ("SP,1,x", "SP argument 2: \"x\" is not a whole number"),
            ("LM,-5,1,0,0,0,0", "rate -5"),
            ("HM,100,5", "HM takes a rate, or a rate and two positions"),
            ("", "empty command"),
        ] {
            let e = Command::parse(line).unwrap_err();
            assert!(e.contains(says), "{line}: {e}");
        }
    }
}
