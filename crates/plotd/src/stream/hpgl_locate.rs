//! Where an HP-GL plotter's pen rests after an interruption, as a state
//! machine that does no I/O ([`HpglLocate`]).
//!
//! It does not wait for the buffer to drain (a stale half-read `OE` can hold
//! it at one byte short for ever): ESC.K and ESC.J drop what the device
//! holds, and `OI` goes through the buffer (its letter ends a half-read
//! instruction; a bare `;` would be error 1 on a strict device), so every answer before the identification is stale and none
//! comes after it; an identification ended by CR (the power-on terminator)
//! is a plotter power-cycled since, which holds nothing of the job. ESC.O
//! then checks the buffer is empty, ESC.E that no I/O error was left, and
//! `OE` and `OA` give the last instruction error and the pen. Needs no ESC.L,
//! which older firmware does not answer, and no ESC.O, which clones do not
//! answer (issue 36): unanswered within the reply timeout, the buffer is
//! taken to be empty, as ESC.K left it, and `OA`, which every HP-GL device
//! answers, finds the pen.

use super::locate::{Rest, POSITION_TOLERANCE};
use super::machine::{Action, Machine, Mailbox, Timing};
use super::{DeviceError, Excerpt, Reset, StreamError, Unanswered};
use plotcode::answer::{is_identification, AnswerLine, ErrorCode, ExtendedStatus, HpglNumber, HpglPosition, Terminator};
use plotcode::control::hpgl::{sequence, Op};
use std::time::Instant;
use strokes::DVec2;

/// Drop what the device holds, then sync (`OI`'s letter ends a half-read
/// instruction).
const CLEAR: &[Op] = &[Op::Abort, Op::AbortDeviceControl, Op::Identify];

#[derive(Clone, Copy, Debug, PartialEq)]
enum Phase {
    /// Nothing sent yet.
    Start,
    /// Cleared: lines before the identification are stale.
    Clearing,
    /// ESC.O asked: is the buffer empty?
    Status,
    /// ESC.E asked: an I/O error left by lost bytes?
    Errors,
    /// `OE` and `OA` written: the `OE` answer first...
    Oe,
    /// ...then the `OA` answer.
    Oa { oe: i64 },
}

/// Finds where the pen rests: `None` when the plotter holds nothing of the
/// job (power-cycled since) or still holds bytes.
#[derive(Debug)]
pub(super) struct HpglLocate {
    timing: Timing,
    phase: Phase,
    /// When the current question must have been answered.
    until: Instant,
    mailbox: Mailbox,
}

impl HpglLocate {
    /// A locate with `timing`'s waits.
    pub fn new(timing: Timing, now: Instant) -> HpglLocate {
        HpglLocate { timing, phase: Phase::Start, until: now, mailbox: Mailbox::default() }
    }

    fn ask(&mut self, query: &[Op], phase: Phase, until: Instant) {
        self.mailbox.actions.push(Action::Query(sequence(query)));
        self.phase = phase;
        self.until = until;
    }

    fn what(&self) -> Unanswered {
        Unanswered::Hpgl(match self.phase {
            Phase::Start | Phase::Clearing => Op::Identify,
            Phase::Status => Op::ExtendedStatus,
            Phase::Errors => Op::ExtendedError,
            Phase::Oe => Op::LastError,
            Phase::Oa { .. } => Op::Position,
        })
    }
}

/// Errors: [`StreamError::Timeout`] naming the question not answered,
/// [`StreamError::Reset`] for an answer ended by the power-on CR after the
/// identification, [`StreamError::Device`] when the device reports an error
/// left by bytes whose answers were lost (`ESC.E` or `OE` not 0): the job
/// stops with the device's word rather than going on silently.
impl Machine for HpglLocate {
    type Output = Option<Rest>;

    fn poll(&mut self, now: Instant, _xoff: bool) -> Result<Option<Option<Rest>>, StreamError> {
        if self.phase == Phase::Start {
            self.ask(CLEAR, Phase::Clearing, now + self.timing.motion_timeout);
        } else if self.phase == Phase::Status && now >= self.until {
            // No ESC.O on this device: what ESC.K dropped is all it held.
            tracing::info!("no answer to ESC.O: a device without it; locating the pen by OA");
            self.ask(&[Op::ExtendedError], Phase::Errors, now + self.timing.reply_timeout);
        } else if now >= self.until {
            return Err(StreamError::Timeout(self.what()));
        }
        Ok(None)
    }

    fn answer(&mut self, line: &AnswerLine, now: Instant) -> Result<Option<Option<Rest>>, StreamError> {
        let text = line.text.as_str();
        if matches!(self.phase, Phase::Start | Phase::Clearing) {
            if !is_identification(text) {
                tracing::debug!(answer = %text, "dropped a stale answer before OI");
                return Ok(None);
            }
            if line.terminator == Terminator::Cr {
                // Power-cycled since: it holds nothing of the job.
                return Ok(Some(None));
            }
            self.ask(&[Op::ExtendedStatus], Phase::Status, now + self.timing.reply_timeout);
            return Ok(None);
        }
        // From here on answers end as this daemon set them up (LF).
        if line.terminator == Terminator::Cr {
            return Err(StreamError::Reset(Reset::PowerOnTerminator { answer: Excerpt::of(text) }));
        }
        match (self.phase, HpglNumber::parse(text).map(|n| n.0)) {
            (Phase::Status, Some(status)) => {
                if !ExtendedStatus(status).buffer_empty() {
                    return Ok(Some(None));
                }
                // ESC.E shares ESC.O's wait: both are answered at once.
                let until = self.until;
                self.ask(&[Op::ExtendedError], Phase::Errors, until);
            }
            (Phase::Errors, Some(0)) => self.ask(&[Op::LastError, Op::Position], Phase::Oe, now + self.timing.motion_timeout),
            (Phase::Errors, Some(e)) => {
                return Err(StreamError::Device(DeviceError::new(ErrorCode::DeviceControl(e))));
            }
            (Phase::Oe, Some(oe)) => self.phase = Phase::Oa { oe },
            (Phase::Oa { oe }, None) => {
                let Some(at) = HpglPosition::parse(text) else { return Ok(None) };
                if oe != 0 {
                    return Err(StreamError::Device(DeviceError::new(ErrorCode::Hpgl(oe))));
                }
                let rest = Rest { pos: DVec2::new(at.x, at.y), down: Some(at.down), z: None, tolerance: POSITION_TOLERANCE };
                return Ok(Some(Some(rest)));
            }
            // Other lines are not the answer waited for.
            _ => {}
        }
        Ok(None)
    }

    fn deadline(&self, now: Instant) -> Instant {
        if self.phase == Phase::Start {
            now
        } else {
            self.until
        }
    }

    fn mailbox(&mut self) -> &mut Mailbox {
        &mut self.mailbox
    }
}

#[cfg(test)]
mod tests {
    use super::super::machine::testing::{timing, Exchange};
    use super::*;
    use std::time::Duration;

    fn cleared() -> Exchange<HpglLocate> {
        let mut x = Exchange::new(HpglLocate::new(timing(), Instant::now()));
        x.poll().unwrap();
        assert_eq!(x.asked, [sequence(CLEAR)]);
        x
    }

    /// Fault 2: the stale `OE` of a killed session held ESC.B short of the
    /// brim, locate polled it for two minutes, and its reply was then
    /// counted for a new marker. Here nothing waits for the buffer to
    /// drain, and every answer before the identification is dropped.
    #[test]
    fn stale_answers_before_the_identification_are_dropped() {
        let mut x = cleared();
        for stale in ["0", "0", "1022", "1500,200,1"] {
            assert_eq!(x.answer(stale).unwrap(), None, "{stale}");
        }
        assert_eq!(x.asked.len(), 1, "nothing asked before the identification");
        x.answer("7475A").unwrap();
        assert_eq!(x.asked.last(), Some(&sequence(&[Op::ExtendedStatus])));
        x.answer("8").unwrap();
        assert_eq!(x.asked.last(), Some(&sequence(&[Op::ExtendedError])));
        x.answer("0").unwrap();
        assert_eq!(x.asked.last(), Some(&sequence(&[Op::LastError, Op::Position])));
        x.answer("0").unwrap();
        let rest = x.answer("1000,500,1").unwrap().expect("over").expect("located");
        assert_eq!((rest.pos, rest.down), (DVec2::new(1000.0, 500.0), Some(true)));
    }

    /// Fault 3: locate insisted on ESC.L. It never asks it.
    #[test]
    fn no_esc_l_is_asked() {
        let mut x = cleared();
        for line in ["7475A", "8", "0", "0"] {
            x.answer(line).unwrap();
        }
        assert!(x.answer("0,0,0").unwrap().is_some());
        let size = Op::BufferSize.bytes();
        assert!(!x.asked.iter().any(|q| q.windows(size.len()).any(|w| w == size)), "{:?}", x.asked);
    }

    #[test]
    fn a_power_cycled_or_busy_plotter_is_not_located() {
        let mut x = cleared();
        assert_eq!(x.line("7475A", Terminator::Cr).unwrap(), Some(None), "power-on terminator: holds nothing of the job");
        let mut x = cleared();
        x.answer("7475A").unwrap();
        assert_eq!(x.answer("0").unwrap(), Some(None), "the buffer still holds bytes");
        let mut x = cleared();
        x.answer("7475A").unwrap();
        assert!(matches!(x.line("8", Terminator::Cr), Err(StreamError::Reset(_))));
    }

    #[test]
    fn errors_left_by_lost_bytes_are_the_devices_word() {
        let mut x = cleared();
        x.answer("7475A").unwrap();
        x.answer("8").unwrap();
        let e = x.answer("3").unwrap_err();
        assert!(matches!(e, StreamError::Device(DeviceError { code: ErrorCode::DeviceControl(3), .. })), "{e}");
        assert!(e.to_string().contains("ESC.E error 3"), "{e}");
        let mut x = cleared();
        for line in ["7475A", "8", "0", "2"] {
            x.answer(line).unwrap();
        }
        let e = x.answer("10,10,0").unwrap_err();
        assert!(matches!(e, StreamError::Device(DeviceError { code: ErrorCode::Hpgl(2), .. })), "{e}");
        assert!(e.to_string().contains("HP-GL error 2"), "{e}");
    }

    #[test]
    fn every_question_has_a_deadline() {
        let step = Duration::from_millis(100);
        let mut x = cleared();
        let e = x.run_out(timing().motion_timeout * 2, step).unwrap_err();
        assert!(matches!(e, StreamError::Timeout(Unanswered::Hpgl(Op::Identify))), "{e}");
        let mut x = cleared();
        x.answer("7475A").unwrap();
        x.answer("8").unwrap();
        let e = x.run_out(Duration::from_secs(10), step).unwrap_err();
        assert!(matches!(e, StreamError::Timeout(Unanswered::Hpgl(Op::ExtendedError))), "{e}");
        assert!(x.elapsed() <= timing().reply_timeout + step);
        // Silent to ESC.O and to ESC.E: the second wait ends it.
        let mut x = cleared();
        x.answer("7475A").unwrap();
        let e = x.run_out(Duration::from_secs(10), step).unwrap_err();
        assert!(matches!(e, StreamError::Timeout(Unanswered::Hpgl(Op::ExtendedError))), "{e}");
        assert!(x.elapsed() <= 2 * (timing().reply_timeout + step), "{:?}", x.elapsed());
    }

    /// An HP-GL clone without ESC.O (issue 36): the question goes
    /// unanswered, and after the reply timeout the locate goes on to ESC.E,
    /// `OE` and `OA` (before: "no answer to ESC.O", and the resume redrew
    /// the whole buffer from the checkpoint, 7 strokes twice).
    #[test]
    fn a_device_without_esc_o_is_located_by_oa() {
        let mut x = cleared();
        x.answer("7475A").unwrap();
        assert_eq!(x.asked.last(), Some(&sequence(&[Op::ExtendedStatus])));
        x.wait(timing().reply_timeout);
        assert_eq!(x.poll().unwrap(), None);
        assert_eq!(x.asked.last(), Some(&sequence(&[Op::ExtendedError])));
        x.answer("0").unwrap();
        assert_eq!(x.asked.last(), Some(&sequence(&[Op::LastError, Op::Position])));
        x.answer("0").unwrap();
        let rest = x.answer("1000,500,0").unwrap().expect("over").expect("located");
        assert_eq!((rest.pos, rest.down), (DVec2::new(1000.0, 500.0), Some(false)));
    }
}
