//! Whether a device on an idle port is there, as a state machine that does
//! no I/O ([`Ping`]): one question it answers at once and does not buffer
//! (HP-GL's free space, GRBL's status report), and the reply timeout.

use super::machine::{Action, Machine, Mailbox, Timing};
use super::{StreamError, Unanswered};
use plotcode::answer::{is_grbl_status, AnswerLine, HpglNumber};
use plotcode::control::{grbl, hpgl};
use std::time::Instant;

/// Asks once; ends at the first answer to the question (lines before it
/// answer something else), or fails at the reply timeout.
#[derive(Debug)]
pub(super) struct Ping {
    grbl: bool,
    timing: Timing,
    /// When the answer must have come; `None` before asking.
    until: Option<Instant>,
    mailbox: Mailbox,
}

impl Ping {
    /// A ping of a GRBL board (`grbl`) or an HP-GL plotter.
    pub fn new(grbl: bool, timing: Timing) -> Ping {
        Ping { grbl, timing, until: None, mailbox: Mailbox::default() }
    }

    fn question(&self) -> &'static [u8] {
        if self.grbl {
            grbl::Op::Status.bytes()
        } else {
            hpgl::Op::FreeSpace.bytes()
        }
    }
}

/// Errors: [`StreamError::Timeout`] when no answer comes.
impl Machine for Ping {
    type Output = ();

    fn poll(&mut self, now: Instant, _xoff: bool) -> Result<Option<()>, StreamError> {
        match self.until {
            None => {
                self.mailbox.actions.push(Action::Query(self.question().to_vec()));
                self.until = Some(now + self.timing.reply_timeout);
                Ok(None)
            }
            Some(t) if now >= t => Err(StreamError::Timeout(if self.grbl {
                Unanswered::Grbl(grbl::Op::Status)
            } else {
                Unanswered::Hpgl(hpgl::Op::FreeSpace)
            })),
            Some(_) => Ok(None),
        }
    }

    fn answer(&mut self, line: &AnswerLine, _now: Instant) -> Result<Option<()>, StreamError> {
        let answered = if self.grbl { is_grbl_status(&line.text) } else { HpglNumber::parse(&line.text).is_some() };
        Ok(answered.then_some(()))
    }

    fn deadline(&self, now: Instant) -> Instant {
        self.until.unwrap_or(now)
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

    /// Fault 4: a dead idle port went unnoticed. The ping fails within the
    /// reply timeout.
    #[test]
    fn a_silent_device_times_out_and_an_answer_ends_it() {
        for (grbl, query, answer) in
            [(true, grbl::Op::Status.bytes(), "<Idle|MPos:0.000,0.000,0.000|FS:0,0>"), (false, hpgl::Op::FreeSpace.bytes(), "1024")]
        {
            let mut x = Exchange::new(Ping::new(grbl, timing()));
            let e = x.run_out(Duration::from_secs(10), Duration::from_millis(100)).unwrap_err();
            assert!(matches!(e, StreamError::Timeout(_)), "{e}");
            assert!(x.elapsed() <= timing().reply_timeout + Duration::from_millis(100));
            assert_eq!(x.asked, [query], "asked once");
            let mut x = Exchange::new(Ping::new(grbl, timing()));
            x.poll().unwrap();
            assert_eq!(x.answer("ok").unwrap(), None, "not the answer");
            assert_eq!(x.answer(answer).unwrap(), Some(()));
        }
    }
}
