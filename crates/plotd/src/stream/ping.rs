//! Whether a device on an idle port is there, as a state machine that does
//! no I/O ([`Ping`]): one question it answers at once and does not buffer
//! (HP-GL's free space, GRBL's status report), and the reply timeout. A
//! device that sent only lines that are not the answer is told apart from a
//! silent one: its answers cannot be read (garbage, the wrong line rate).

use super::ebb::MAX_VERSION_RETRIES;
use super::machine::{Action, Machine, Mailbox, Timing};
use super::{Excerpt, Garbled, StreamError, Unanswered};
use plotcode::answer::ebb as ebb_answer;
use plotcode::answer::{is_grbl_status, AnswerLine, GrblAnswer, HpglNumber};
use plotcode::control::{ebb, grbl, hpgl};
use plotcode::ebb::Firmware;
use plotcode::Handshake;
use std::time::Instant;

/// Asks once (an EiBotBoard again after an error); ends at the first answer to the question (lines before it
/// answer something else), or fails at the reply timeout.
#[derive(Debug)]
pub(super) struct Ping {
    handshake: Handshake,
    timing: Timing,
    /// When the answer must have come; `None` before asking.
    until: Option<Instant>,
    /// Lines that were not the answer, and the last of them.
    unread: Option<(usize, Excerpt)>,
    /// EBB: `V` asked again after an error.
    retries: usize,
    mailbox: Mailbox,
}

impl Ping {
    /// A ping of a device streamed through `handshake`.
    pub fn new(handshake: Handshake, timing: Timing) -> Ping {
        Ping { handshake, timing, until: None, unread: None, retries: 0, mailbox: Mailbox::default() }
    }

    /// GRBL's status report, an EBB's version, else HP-GL's free space.
    fn question(&self) -> Vec<u8> {
        match self.handshake {
            Handshake::Grbl => grbl::Op::Status.bytes().to_vec(),
            Handshake::Ebb => ebb::Op::Version.bytes(),
            _ => hpgl::Op::FreeSpace.bytes().to_vec(),
        }
    }
}

/// The answer: a GRBL banner when that was it (the board restarted: its
/// greeting says it is there as well as a status would).
///
/// Errors: [`StreamError::Timeout`] when nothing comes,
/// [`StreamError::Garbled`] when only lines that are not the answer came.
impl Machine for Ping {
    type Output = Option<String>;

    fn poll(&mut self, now: Instant, _xoff: bool) -> Result<Option<Option<String>>, StreamError> {
        match self.until {
            None => {
                self.mailbox.actions.push(Action::Query(self.question()));
                self.until = Some(now + self.timing.reply_timeout);
                Ok(None)
            }
            Some(t) if now >= t => match self.unread.take() {
                Some((lines, last)) => Err(StreamError::Garbled(Garbled::Noise { lines, last })),
                None => Err(StreamError::Timeout(match self.handshake {
                    Handshake::Grbl => Unanswered::Grbl(grbl::Op::Status),
                    Handshake::Ebb => Unanswered::Ebb(ebb::Op::Version),
                    _ => Unanswered::Hpgl(hpgl::Op::FreeSpace),
                })),
            },
            Some(_) => Ok(None),
        }
    }

    fn answer(&mut self, line: &AnswerLine, _now: Instant) -> Result<Option<Option<String>>, StreamError> {
        if self.handshake == Handshake::Grbl {
            if let GrblAnswer::Welcome(banner) = GrblAnswer::parse(&line.text) {
                return Ok(Some(Some(banner)));
            }
        }
        let answered = match self.handshake {
            Handshake::Grbl => is_grbl_status(&line.text),
            Handshake::Ebb => Firmware::from_version_answer(&line.text).is_some(),
            _ => HpglNumber::parse(&line.text).is_some(),
        };
        if !answered {
            let lines = self.unread.as_ref().map_or(0, |(n, _)| *n) + 1;
            self.unread = Some((lines, Excerpt::of(&line.text)));
            let refused = ebb_answer::is_error(&line.text);
            if self.handshake == Handshake::Ebb && refused && self.retries < MAX_VERSION_RETRIES {
                // A line that took `V` as its tail (the erase before `V`
                // leaves none) or one left from before: the buffer is empty,
                // ask again.
                self.retries += 1;
                self.mailbox.actions.push(Action::Query(self.question()));
            }
        }
        Ok(answered.then_some(None))
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
        for (handshake, query, answer) in [
            (Handshake::Grbl, grbl::Op::Status.bytes().to_vec(), "<Idle|MPos:0.000,0.000,0.000|FS:0,0>"),
            (Handshake::Escb, hpgl::Op::FreeSpace.bytes().to_vec(), "1024"),
            (Handshake::Ebb, b"V\r".to_vec(), "EBBv13_and_above EB Firmware Version 2.8.1"),
        ] {
            let mut x = Exchange::new(Ping::new(handshake, timing()));
            let e = x.run_out(Duration::from_secs(10), Duration::from_millis(100)).unwrap_err();
            assert!(matches!(e, StreamError::Timeout(_)), "{e}");
            assert!(x.elapsed() <= timing().reply_timeout + Duration::from_millis(100));
            assert_eq!(x.asked, [query], "asked once");
            assert_eq!(x.erased, usize::from(handshake == Handshake::Ebb), "an EBB's half command erased first");
            let mut x = Exchange::new(Ping::new(handshake, timing()));
            x.poll().unwrap();
            assert_eq!(x.answer("ok").unwrap(), None, "not the answer");
            assert_eq!(x.answer(answer).unwrap(), Some(None));
        }
    }

    /// Issue 36: a device spewing garbage was "no answer to ESC.B". Lines
    /// that are not the answer, and no answer by the timeout: its answers
    /// cannot be read, the last one quoted.
    #[test]
    fn only_garbage_by_the_timeout_is_unreadable_not_silent() {
        let mut x = Exchange::new(Ping::new(Handshake::Escb, timing()));
        x.poll().unwrap();
        assert_eq!(x.answer("##garbage##").unwrap(), None);
        assert_eq!(x.answer("#\u{7}#").unwrap(), None);
        let e = x.run_out(Duration::from_secs(10), Duration::from_millis(100)).unwrap_err();
        let StreamError::Garbled(Garbled::Noise { lines, last }) = &e else { panic!("{e}") };
        assert_eq!((*lines, last.to_string()), (2, "\"#\\u{7}#\"".to_owned()));
    }

    /// Issue 37: after a reconnect the board's line buffer may hold half a
    /// command from before the unplug, which took `V` as its tail and was
    /// refused ("!5 Need comma next, found 'V'"): the ping failed. (`V`
    /// now erases it first.) After a refusal the buffer is empty; `V`
    /// asked again is answered.
    #[test]
    fn an_ebb_ping_asks_again_after_a_half_command_took_its_question() {
        let mut x = Exchange::new(Ping::new(Handshake::Ebb, timing()));
        x.poll().unwrap();
        assert_eq!(x.answer("!5 Need comma next, found: 'V'").unwrap(), None);
        assert_eq!(x.asked, [b"V\r".to_vec(), b"V\r".to_vec()], "asked again");
        assert_eq!(x.answer("EBBv13_and_above EB Firmware Version 2.8.1").unwrap(), Some(None));
        // Not for ever: a board refusing every `V` is not answering it.
        let mut x = Exchange::new(Ping::new(Handshake::Ebb, timing()));
        x.poll().unwrap();
        for _ in 0..10 {
            x.answer("!8 Err: Unknown command").unwrap();
        }
        assert_eq!(x.asked.len(), 1 + MAX_VERSION_RETRIES);
    }

    /// A GRBL board that resets when its port opens (an Arduino) greets
    /// instead of answering the status asked in its bootloader: it is there,
    /// and the ping says it restarted, so a job it was in the middle of does
    /// not go on in its new zero (issue 36).
    #[test]
    fn a_grbl_banner_answers_and_says_the_board_restarted() {
        let mut x = Exchange::new(Ping::new(Handshake::Grbl, timing()));
        x.poll().unwrap();
        let banner = "Grbl 1.1h ['$' for help]";
        assert_eq!(x.answer(banner).unwrap(), Some(Some(banner.to_owned())));
        // An HP-GL device's line that looks like one is not.
        let mut x = Exchange::new(Ping::new(Handshake::Escb, timing()));
        x.poll().unwrap();
        assert_eq!(x.answer(banner).unwrap(), None);
    }
}
