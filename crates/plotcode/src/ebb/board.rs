//! What an EBB does with each command of a program, as far as chunks, plot
//! times and the strokes read back need it: the step counters, the pen, the
//! pen number, the servo settings to restore on resume. The emitter, the
//! cutter and the reader all run their commands through [`Board`], so a
//! file's chunks add up to the estimate of the render that wrote it, and
//! both are the durations the firmware takes.

use super::command::{Command, PEN_MARK};
use super::lm::TICKS_PER_SECOND;
use super::motors::Motors;
use crate::clock::Clock;
use crate::program::PenAt;

/// What a command did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Effect {
    /// Nothing that moves (a setting, a pen number).
    Still,
    /// The pen lowered (`down`) or raised, and the wait that comes with it.
    Pen { down: bool, seconds: f64 },
    /// A move to these counters, and how long it takes.
    Move { seconds: f64 },
}

/// The board's state after the commands seen so far.
#[derive(Clone, Debug, Default)]
pub(crate) struct Board {
    /// The step counters (`QS`): where the carriage is since `EM`.
    pub at: Motors,
    /// Where the last `EM` zeroed the counters, in the counters before it:
    /// the carriage's place is `origin + at`.
    origin: Motors,
    /// Whether the pen is down.
    pub pen_down: bool,
    /// The pen the last `SL,128+pen` named.
    pub pen: Option<u32>,
    /// The servo settings given (`SC`), each as last given, in the order
    /// first given: what a board that restarted needs again.
    pub servo: Vec<(u8, u16)>,
    /// The last command that raised the pen, with its wait.
    pub pen_up: Option<Command>,
}

impl Board {
    /// Carries out `cmd`.
    ///
    /// # Errors
    /// A move the firmware would never finish (an `LM` whose rate runs out
    /// or is too fast), saying why.
    pub fn apply(&mut self, cmd: &Command) -> Result<Effect, String> {
        let moved = |board: &mut Board, to: Motors, seconds: f64| {
            board.at = to;
            Ok(Effect::Move { seconds })
        };
        match *cmd {
            Command::ServoConfig { param, value } => {
                match self.servo.iter_mut().find(|(p, _)| *p == param) {
                    Some(s) => s.1 = value,
                    None => self.servo.push((param, value)),
                }
                Ok(Effect::Still)
            }
            Command::Pen { up, ms } => {
                self.pen_down = !up;
                if up {
                    self.pen_up = Some(*cmd);
                }
                Ok(Effect::Pen { down: !up, seconds: f64::from(ms) / 1000.0 })
            }
            Command::EnableMotors { .. } => {
                self.origin = self.origin.plus(self.at);
                self.at = Motors::default();
                Ok(Effect::Still)
            }
            Command::PenNumber(v) => {
                // Lower values are other software's codes, not pens.
                if v >= PEN_MARK {
                    self.pen = Some(v - PEN_MARK);
                }
                Ok(Effect::Still)
            }
            Command::Lm(lm) => {
                let ticks = lm.ticks().map_err(|e| format!("this LM never finishes as the firmware runs it: {e}"))?;
                let to = self.at.plus(cmd.steps().expect("LM steps"));
                moved(self, to, ticks as f64 / TICKS_PER_SECOND)
            }
            Command::Sm(sm) => {
                let to = self.at.plus(sm.steps);
                moved(self, to, f64::from(sm.ms) / 1000.0)
            }
            Command::Xm { ms, .. } => {
                let to = self.at.plus(cmd.steps().expect("XM steps"));
                moved(self, to, f64::from(ms) / 1000.0)
            }
            Command::Home { rate, to } => {
                let to = to.unwrap_or_default();
                let d = self.at.to(to);
                let steps = d.m1.unsigned_abs().max(d.m2.unsigned_abs());
                moved(self, to, steps as f64 / f64::from(rate))
            }
        }
    }

    /// Carries out `cmd` and times it on `clock`; the seconds.
    ///
    /// # Errors
    /// As [`Board::apply`].
    pub fn run(&mut self, cmd: &Command, clock: &mut Clock) -> Result<f64, String> {
        Ok(match self.apply(cmd)? {
            Effect::Still => 0.0,
            Effect::Pen { down, seconds } => clock.timed_pen(down, seconds),
            Effect::Move { seconds } => clock.timed_move(self.origin.plus(self.at).xy(), seconds),
        })
    }

    /// Where the pen is and whether it is down, in device units.
    pub fn pen_at(&self) -> PenAt {
        PenAt { pos: self.at.xy(), down: self.pen_down, z: None }
    }
}
