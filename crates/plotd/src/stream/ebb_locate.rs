//! Where an EiBotBoard's carriage rests after an interruption (an unplugged
//! cable, a killed daemon), as a state machine that does no I/O
//! ([`EbbLocate`]).
//!
//! The board keeps its step counters while it is powered (a port opened
//! again does not reset it), and runs on through what its FIFO held. So:
//! `V` first (its bytes first erase what the lost link left of a command
//! cut in two, which would otherwise take `V` as its tail and might run
//! bent: [`plotcode::control::ebb::ERASE_HALF_COMMAND`]; the answers to the
//! earlier session's commands come before its answer and are dropped, and
//! after an error among them `V` is asked again); then `QE` (motors off:
//! the board was reset or power-cycled, its counters start from zero where
//! the carriage stands: the position is lost), `QC` (V+ under
//! [`plotcode::answer::ebb::MIN_MOTOR_POWER_ADC`]: the motors lost their steps: lost too), `QG`
//! until the FIFO is empty and the motors still (3.x: its power-lost bit
//! too), and `QS`: the counters, and the pen from `QG`, are where it rests.

use super::ebb::MAX_VERSION_RETRIES;
use super::locate::Rest;
use super::machine::{Action, Machine, Mailbox, Timing};
use super::{DeviceError, Reset, StreamError, Unanswered};
use plotcode::answer::ebb::{Line, MotorModes, Status, Steps, Voltages};
use plotcode::answer::{AnswerLine, ErrorCode};
use plotcode::control::ebb::Op;
use plotcode::ebb::Firmware;
use std::time::Instant;

/// Largest difference, in device units (steps along x and y), between
/// where the counters put the pen and where a chunk leaves it: less than
/// the half step one count of a motor makes, so only the exact counters
/// agree.
pub(super) const EBB_POSITION_TOLERANCE: f64 = 0.25;

/// Finds where the carriage rests: `None` when the board does not settle
/// within the motion timeout (plotting goes on from the checkpoint, whose
/// resume prefix moves to the chunk's start by the counters).
#[derive(Debug)]
pub(super) struct EbbLocate {
    timing: Timing,
    /// The question owed, and its data line once it came (read at its `OK`).
    owed: Option<(Op, Option<String>)>,
    /// When the question owed must have been answered.
    until: Instant,
    /// When the board must have settled.
    settle_by: Instant,
    /// `QG` is asked again then (the board is running what it holds).
    again_at: Option<Instant>,
    firmware: Option<Firmware>,
    version_retries: usize,
    /// The pen up, from the last `QG`.
    pen_up: Option<bool>,
    mailbox: Mailbox,
}

impl EbbLocate {
    /// A locate with `timing`'s waits, starting `now`.
    pub fn new(timing: Timing, now: Instant) -> EbbLocate {
        EbbLocate {
            timing,
            owed: None,
            until: now,
            settle_by: now + timing.motion_timeout,
            again_at: None,
            firmware: None,
            version_retries: 0,
            pen_up: None,
            mailbox: Mailbox::default(),
        }
    }

    fn ask(&mut self, op: Op, now: Instant) {
        self.mailbox.actions.push(Action::Query(op.bytes()));
        self.owed = Some((op, None));
        self.until = now + self.timing.reply_timeout;
    }

    /// The question answered (its data and, where it has one, its `OK`):
    /// what comes next.
    fn answered(&mut self, op: Op, data: &str, now: Instant) -> Result<Option<Option<Rest>>, StreamError> {
        let garbled = || StreamError::Garbled(super::Garbled::Noise { lines: 1, last: super::Excerpt::of(data) });
        match op {
            Op::Version => self.ask(Op::MotorModes, now),
            Op::MotorModes => {
                if !MotorModes::parse(data).ok_or_else(garbled)?.enabled() {
                    return Err(StreamError::Reset(Reset::MotorsOff));
                }
                self.ask(Op::Voltages, now);
            }
            Op::Voltages => {
                let v = Voltages::parse(data).ok_or_else(garbled)?;
                if !v.motor_power() {
                    return Err(StreamError::Reset(Reset::MotorPower { supply: Some(v.supply) }));
                }
                self.ask(Op::Status, now);
            }
            Op::Status => {
                let status = Status::parse(data).ok_or_else(garbled)?;
                if status.power_lost(self.firmware.is_some_and(Firmware::is_3x)) {
                    return Err(StreamError::Reset(Reset::MotorPower { supply: None }));
                }
                self.pen_up = Some(status.pen_up());
                if status.idle() {
                    self.ask(Op::Steps, now);
                } else if now >= self.settle_by {
                    tracing::info!("the EiBotBoard is still moving: it cannot say where it rests");
                    return Ok(Some(None));
                } else {
                    self.again_at = Some(now + self.timing.poll_interval);
                }
            }
            Op::Steps => {
                let Steps(at) = Steps::parse(data).ok_or_else(garbled)?;
                let down = self.pen_up.map(|up| !up);
                tracing::info!(m1 = at.m1, m2 = at.m2, ?down, "the EiBotBoard rests");
                return Ok(Some(Some(Rest { pos: at.xy(), down, z: None, tolerance: EBB_POSITION_TOLERANCE })));
            }
            _ => {}
        }
        Ok(None)
    }
}

/// Errors: [`StreamError::Reset`] when the board's motors are off or lost
/// their power, [`StreamError::Timeout`] when a question goes unanswered,
/// [`StreamError::Device`] when `V` keeps being refused, and
/// [`StreamError::Garbled`] for an answer that cannot be read.
impl Machine for EbbLocate {
    type Output = Option<Rest>;

    fn poll(&mut self, now: Instant, _xoff: bool) -> Result<Option<Option<Rest>>, StreamError> {
        match self.owed {
            None if self.firmware.is_none() => self.ask(Op::Version, now),
            None if self.again_at.is_some_and(|t| now >= t) => {
                self.again_at = None;
                self.ask(Op::Status, now);
            }
            Some((op, _)) if now >= self.until => return Err(StreamError::Timeout(Unanswered::Ebb(op))),
            _ => {}
        }
        Ok(None)
    }

    fn answer(&mut self, line: &AnswerLine, now: Instant) -> Result<Option<Option<Rest>>, StreamError> {
        let Some((op, data)) = self.owed.take() else { return Ok(None) };
        self.owed = Some((op, data.clone()));
        // A version line answers the `V` asked (or one asked again), never
        // a later question.
        let version = Firmware::from_version_answer(&line.text);
        match (op, Line::parse(&line.text, op.name())) {
            (_, None) => Ok(None),
            (Op::Version, Some(Line::Error { number, message })) => {
                // The earlier session's errors, or a line that took this `V`
                // as its end (the erase before it leaves none): ask again.
                tracing::info!(%message, "EBB error before the version: asking again");
                self.version_retries += 1;
                if self.version_retries > MAX_VERSION_RETRIES {
                    return Err(StreamError::Device(DeviceError::new(ErrorCode::Ebb(number))));
                }
                self.ask(Op::Version, now);
                Ok(None)
            }
            (Op::Version, Some(_)) => match version {
                Some(firmware) => {
                    self.firmware = Some(firmware);
                    self.owed = None;
                    self.answered(op, "", now)
                }
                // An answer to the earlier session's commands.
                None => Ok(None),
            },
            (_, Some(_)) if version.is_some() => Ok(None),
            (_, Some(Line::Error { number, .. })) => Err(StreamError::Device(DeviceError::new(ErrorCode::Ebb(number)))),
            (_, Some(Line::Data(text))) if data.is_none() && op.ends_with_ok() => {
                self.owed = Some((op, Some(text.to_owned())));
                Ok(None)
            }
            (_, Some(Line::Data(text))) if data.is_none() => {
                self.owed = None;
                self.answered(op, text, now)
            }
            (_, Some(Line::Ok)) => match data {
                Some(text) => {
                    self.owed = None;
                    self.answered(op, &text, now)
                }
                None => Ok(None),
            },
            (_, Some(Line::Data(_))) => Ok(None),
        }
    }

    fn deadline(&self, now: Instant) -> Instant {
        let next = if self.owed.is_some() { self.until } else { self.again_at.unwrap_or(now) };
        next.min(now + self.timing.poll_interval)
    }

    fn mailbox(&mut self) -> &mut Mailbox {
        &mut self.mailbox
    }
}

#[cfg(test)]
mod tests {
    use super::super::machine::testing::{timing, Exchange};
    use super::*;
    use plotcode::ebb::Motors;
    use std::time::Duration;

    const V281: &str = "EBBv13_and_above EB Firmware Version 2.8.1";
    const V302: &str = "EBBv13_and_above EB Firmware Version 3.0.2";

    fn locate() -> Exchange<EbbLocate> {
        let mut x = Exchange::new(EbbLocate::new(timing(), Instant::now()));
        x.poll().unwrap();
        x
    }

    fn asked(x: &Exchange<EbbLocate>) -> Vec<String> {
        x.asked.iter().map(|q| String::from_utf8_lossy(q).trim_end().to_owned()).collect()
    }

    /// Answers `V` (after the earlier session's answers), `QE` and `QC` as
    /// a board powered and enabled.
    fn up_to_status(x: &mut Exchange<EbbLocate>, version: &str) {
        for stale in ["OK", "OK", "0,0,0,0,0"] {
            assert_eq!(x.answer(stale).unwrap(), None, "{stale}");
        }
        x.answer(version).unwrap();
        x.answer("16,16").unwrap();
        x.answer("OK").unwrap();
        x.answer("0394,0300").unwrap();
        assert_eq!(x.answer("OK").unwrap(), None);
        let asked = asked(x);
        assert!(asked.ends_with(&["V", "QE", "QC", "QG"].map(String::from)), "{asked:?}");
    }

    #[test]
    fn the_counters_once_the_board_is_still_are_where_it_rests() {
        let mut x = locate();
        up_to_status(&mut x, V281);
        // Still running what its FIFO held: asked again a poll later.
        assert_eq!(x.answer("0E").unwrap(), None);
        x.poll().unwrap();
        assert_eq!(asked(&x), ["V", "QE", "QC", "QG"], "not at once");
        assert_eq!(x.erased, 1, "what the lost link left of a command erased before `V`");
        x.wait(timing().poll_interval);
        x.poll().unwrap();
        assert_eq!(asked(&x)[4..], ["QG"]);
        // Idle, the pen up.
        assert_eq!(x.answer("30").unwrap(), None);
        assert_eq!(asked(&x)[5..], ["QS"]);
        assert_eq!(x.answer("1200,-400").unwrap(), None, "read at its OK");
        let rest = x.answer("OK").unwrap().expect("over").expect("located");
        assert_eq!(rest.pos, Motors::new(1200, -400).xy());
        assert_eq!(rest.down, Some(false));
        assert!(rest.tolerance < 0.5, "one count of a motor is half a step: only the counters themselves agree");
    }

    #[test]
    fn a_version_swallowed_by_a_command_cut_in_two_is_asked_again() {
        let mut x = locate();
        // `LM,1000,40` + `V`: the board refuses the line.
        x.answer("!5 Err: Need comma next, found: 'V'").unwrap();
        assert_eq!(asked(&x), ["V", "V"]);
        up_to_status(&mut x, V281);
        // Not for ever: a board refusing every `V` is a device error after
        // the retries every session allows.
        let mut x = locate();
        for _ in 0..MAX_VERSION_RETRIES {
            x.answer("!8 Err: Unknown command").unwrap();
        }
        assert_eq!(asked(&x).len(), 1 + MAX_VERSION_RETRIES);
        let e = x.answer("!8 Err: Unknown command").unwrap_err();
        assert!(matches!(e, StreamError::Device(_)), "{e}");
    }

    #[test]
    fn motors_off_or_without_power_lose_the_position() {
        let mut x = locate();
        x.answer(V281).unwrap();
        x.answer("0,0").unwrap();
        let e = x.answer("OK").unwrap_err();
        assert!(matches!(e, StreamError::Reset(Reset::MotorsOff)), "{e}");
        let mut x = locate();
        x.answer(V281).unwrap();
        x.answer("16,16").unwrap();
        x.answer("OK").unwrap();
        x.answer("0394,0003").unwrap();
        let e = x.answer("OK").unwrap_err();
        assert!(matches!(e, StreamError::Reset(Reset::MotorPower { supply: Some(3) })), "{e}");
        assert!(e.to_string().contains("V+ read 3"), "{e}");
        // 3.x: the power-lost bit of QG, though V+ is back.
        let mut x = locate();
        up_to_status(&mut x, V302);
        let e = x.answer("70").unwrap_err();
        assert!(matches!(e, StreamError::Reset(Reset::MotorPower { supply: None })), "{e}");
    }

    #[test]
    fn a_question_unanswered_times_out_and_a_board_never_still_cannot_tell() {
        let mut x = locate();
        let e = x.run_out(Duration::from_secs(10), Duration::from_millis(100)).unwrap_err();
        assert!(matches!(e, StreamError::Timeout(Unanswered::Ebb(Op::Version))), "{e}");
        let mut x = locate();
        up_to_status(&mut x, V281);
        let mut out = None;
        for _ in 0..10_000 {
            if let Some(o) = x.answer("0E").unwrap() {
                out = Some(o);
                break;
            }
            x.wait(timing().poll_interval);
            x.poll().unwrap();
        }
        assert_eq!(out, Some(None), "moving for the motion timeout");
    }
}
