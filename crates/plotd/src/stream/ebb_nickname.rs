//! Asking an EiBotBoard its nickname (`QT`), for `nickname = "..."`, as a
//! state machine that does no I/O ([`AskNickname`]).
//!
//! `V` first (its bytes erase a half command a reconnect left in the
//! board's buffer; after an error `V` is asked again), then `QT` once the
//! version came: lines left from before come ahead of the version, so only
//! the lines after it answer `QT` (an `OK` left over would otherwise read
//! as a board with no name).

use super::ebb::MAX_VERSION_RETRIES;
use super::machine::{Action, Machine, Mailbox, Timing};
use super::{DeviceError, Excerpt, Garbled, StreamError, Unanswered};
use plotcode::answer::ebb::{is_error, Line, NicknameAnswer, NicknameLine};
use plotcode::answer::{AnswerLine, ErrorCode};
use plotcode::control::ebb::Op;
use plotcode::ebb::Firmware;
use std::time::Instant;

/// Lines before the version tolerated (left from before) before the board
/// counts as not an EBB.
const MAX_NOISE: usize = 8;

/// Asks once; ends with the nickname (empty when the board has none).
#[derive(Debug)]
pub(super) struct AskNickname {
    timing: Timing,
    /// When the answer must have come; `None` before asking.
    until: Option<Instant>,
    /// The version line came: the next lines are `QT`'s.
    versioned: bool,
    answer: NicknameAnswer,
    noise: usize,
    /// `V` asked again after an error.
    retries: usize,
    mailbox: Mailbox,
}

impl AskNickname {
    pub fn new(timing: Timing) -> AskNickname {
        AskNickname {
            timing,
            until: None,
            versioned: false,
            answer: NicknameAnswer::default(),
            noise: 0,
            retries: 0,
            mailbox: Mailbox::default(),
        }
    }
}

/// Errors: [`StreamError::Timeout`] when the answer does not come in the
/// reply timeout, [`StreamError::Device`] when the board refuses `QT`,
/// [`StreamError::Garbled`] when only lines that are not the answer come.
impl Machine for AskNickname {
    type Output = String;

    fn poll(&mut self, now: Instant, _xoff: bool) -> Result<Option<String>, StreamError> {
        match self.until {
            None => {
                self.mailbox.actions.push(Action::Query(Op::Version.bytes()));
                self.until = Some(now + self.timing.reply_timeout);
            }
            Some(t) if now >= t => {
                let asked = if self.versioned { Op::Nickname } else { Op::Version };
                return Err(StreamError::Timeout(Unanswered::Ebb(asked)));
            }
            Some(_) => {}
        }
        Ok(None)
    }

    fn answer(&mut self, line: &AnswerLine, now: Instant) -> Result<Option<String>, StreamError> {
        if self.versioned {
            return match self.answer.line(&line.text) {
                NicknameLine::Pending => Ok(None),
                NicknameLine::Name(name) => Ok(Some(name)),
                NicknameLine::Error(number) => Err(StreamError::Device(DeviceError::new(ErrorCode::Ebb(number)))),
            };
        }
        let reply = Line::parse(&line.text, Op::Version.name());
        let version = match reply {
            Some(Line::Data(text)) => Firmware::from_version_answer(text),
            _ => None,
        };
        if version.is_some() {
            self.versioned = true;
            self.mailbox.actions.push(Action::Query(Op::Nickname.bytes()));
            self.until = Some(now + self.timing.reply_timeout);
        } else if reply.is_some() {
            // Left from before; after a refusal (of a line that took `V`
            // as its tail) the buffer is empty: ask again.
            if is_error(&line.text) && self.retries < MAX_VERSION_RETRIES {
                self.retries += 1;
                self.mailbox.actions.push(Action::Query(Op::Version.bytes()));
                self.until = Some(now + self.timing.reply_timeout);
            }
            self.noise += 1;
            if self.noise > MAX_NOISE {
                return Err(StreamError::Garbled(Garbled::Noise { lines: self.noise, last: Excerpt::of(&line.text) }));
            }
        }
        Ok(None)
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

    const V281: &str = "EBBv13_and_above EB Firmware Version 2.8.1";

    /// `V`, then `QT` once the version came: the nickname, in both
    /// syntaxes; what came before the version discarded (an `OK` there is
    /// not an empty name), and `V` asked again after a refusal.
    #[test]
    fn the_nickname_after_the_version_in_both_syntaxes() {
        for (replies, name, asked) in [
            (&[V281, "axi1", "OK"][..], "axi1", &["V\r", "QT\r"][..]),
            (&["OK", V281, "OK"], "", &["V\r", "QT\r"]),
            (&["!5 Need comma next, found: 'V'", V281, "axi1", "OK"], "axi1", &["V\r", "V\r", "QT\r"]),
            (&["V,EBBv13_and_above EB Firmware Version 3.0.2", "QT,left"], "left", &["V\r", "QT\r"]),
            (&["SM!5 Err", "V,EBBv13_and_above EB Firmware Version 3.0.2", "QT,"], "", &["V\r", "V\r", "QT\r"]),
        ] {
            let mut x = Exchange::new(AskNickname::new(timing()));
            x.poll().unwrap();
            let (last, before) = replies.split_last().unwrap();
            for r in before {
                assert_eq!(x.answer(r).unwrap(), None, "{r}");
            }
            assert_eq!(x.answer(last).unwrap().as_deref(), Some(name), "{replies:?}");
            let asked: Vec<Vec<u8>> = asked.iter().map(|q| q.as_bytes().to_vec()).collect();
            assert_eq!(x.asked, asked, "{replies:?}");
            assert_eq!(x.erased, asked.iter().filter(|q| q == &b"V\r").count(), "a half command erased before each `V`");
        }
    }

    #[test]
    fn silence_is_a_timeout_and_a_refusal_a_device_error() {
        let mut x = Exchange::new(AskNickname::new(timing()));
        let e = x.run_out(Duration::from_secs(10), Duration::from_millis(100)).unwrap_err();
        assert!(matches!(e, StreamError::Timeout(Unanswered::Ebb(Op::Version))), "{e}");
        assert!(x.elapsed() <= timing().reply_timeout + Duration::from_millis(100));
        let mut x = Exchange::new(AskNickname::new(timing()));
        x.poll().unwrap();
        x.answer(V281).unwrap();
        let e = x.answer("!8 Err: Unknown command 'QT:5154'").unwrap_err();
        assert!(e.to_string().contains("EBB error !8"), "{e}");
    }
}
