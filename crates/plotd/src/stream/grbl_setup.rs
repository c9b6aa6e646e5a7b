//! Bringing a GRBL link into step before a run, as state machines that do
//! no I/O: [`GrblSync`] reads the receive buffer size from the build info
//! ([`Op::BuildInfo`]; every answer before the report answers an earlier
//! session's lines, so the link is in step after it), and [`GrblUnlock`]
//! unlocks a board left in alarm ([`Op::Unlock`]). Both ask again, or give
//! up, on a hand-moved clock.

use super::machine::{Action, Asking, Machine, Mailbox, Timing};
use super::{DeviceError, ErrorAt, Garbled, StreamError, Unanswered};
use plotcode::answer::{AnswerLine, ErrorCode, GrblAnswer, GrblState};
use plotcode::control::grbl::Op;
use std::time::Instant;

/// Smallest receive buffer a run can count characters in.
const MIN_RX: usize = 16;

/// GRBL's status report, asked up to three times within the reply timeout:
/// a board that has just been powered ignores input while it boots.
pub(super) fn status_asking(timing: &Timing) -> Asking {
    Asking::new(Op::Status.bytes(), 3, timing.reply_timeout / 3)
}

/// What the build info told.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Synced {
    /// The receive buffer size.
    pub rx: usize,
    /// The last `ALARM:N` among the earlier session's answers: the reason
    /// of an alarm the board may still be in.
    pub alarm: Option<u32>,
}

/// Reads the receive buffer size from the build info (asked up to three times; the
/// size given when the report does not say it); the `ok` after the report
/// ends it.
#[derive(Debug)]
pub(super) struct GrblSync {
    asking: Asking,
    /// The size so far.
    rx: usize,
    alarm: Option<u32>,
    /// Whether the report came: answers before it are an earlier session's.
    reported: bool,
    mailbox: Mailbox,
}

impl GrblSync {
    /// A sync that takes `default_rx` when the build info does not give the size.
    pub fn new(timing: &Timing, default_rx: usize) -> GrblSync {
        GrblSync {
            asking: Asking::new(Op::BuildInfo.bytes(), 3, timing.reply_timeout / 3),
            rx: default_rx,
            alarm: None,
            reported: false,
            mailbox: Mailbox::default(),
        }
    }
}

/// Errors: [`StreamError::Timeout`] when no report (or no `ok` after it)
/// comes, [`StreamError::Device`] for an `error:N` after the report,
/// [`StreamError::Garbled`] for a buffer too small to count characters in.
impl Machine for GrblSync {
    type Output = Synced;

    fn poll(&mut self, now: Instant, _xoff: bool) -> Result<Option<Synced>, StreamError> {
        let asking = if self.reported { !self.asking.expired(now) } else { self.asking.poll(now, &mut self.mailbox) };
        if !asking {
            return Err(StreamError::Timeout(Unanswered::Grbl(Op::BuildInfo)));
        }
        Ok(None)
    }

    fn answer(&mut self, line: &AnswerLine, _now: Instant) -> Result<Option<Synced>, StreamError> {
        match GrblAnswer::parse(&line.text) {
            GrblAnswer::Version(_) => self.reported = true,
            GrblAnswer::Options { rx_buffer } => {
                self.reported = true;
                self.rx = rx_buffer.unwrap_or(self.rx);
            }
            GrblAnswer::Ok if self.reported => {
                if self.rx < MIN_RX {
                    return Err(StreamError::Garbled(Garbled::ReceiveBuffer { bytes: self.rx, least: MIN_RX }));
                }
                return Ok(Some(Synced { rx: self.rx, alarm: self.alarm }));
            }
            GrblAnswer::Error(n) if self.reported => return Err(StreamError::Device(DeviceError::new(ErrorCode::Grbl(n)))),
            // An earlier run's: the board may still be in that alarm.
            GrblAnswer::Alarm(n) => self.alarm = Some(n),
            // Other answers before the report answer an earlier run's lines.
            _ => {}
        }
        Ok(None)
    }

    fn deadline(&self, now: Instant) -> Instant {
        self.asking.deadline(now)
    }

    fn mailbox(&mut self) -> &mut Mailbox {
        &mut self.mailbox
    }
}

/// A board left in alarm (a limit switch, a reset in motion) is locked and
/// answers G-code with `error:9`: asks the status, and when it is `Alarm`
/// unlocks the board ([`Op::Unlock`]). The resume prefix then sets the modal state
/// and the position again.
#[derive(Debug)]
pub(super) struct GrblUnlock {
    timing: Timing,
    /// Asking the status; `None` once the unlock is sent.
    status: Option<Asking>,
    /// When the unlock must have been answered.
    until: Option<Instant>,
    mailbox: Mailbox,
}

impl GrblUnlock {
    /// An unlock with `timing`'s waits.
    pub fn new(timing: Timing) -> GrblUnlock {
        GrblUnlock { timing, status: Some(status_asking(&timing)), until: None, mailbox: Mailbox::default() }
    }
}

/// Errors: [`StreamError::Timeout`] when no status report or no answer to
/// the unlock comes, [`StreamError::Device`] when the unlock is refused.
impl Machine for GrblUnlock {
    type Output = ();

    fn poll(&mut self, now: Instant, _xoff: bool) -> Result<Option<()>, StreamError> {
        match (&mut self.status, self.until) {
            (Some(asking), _) => {
                if !asking.poll(now, &mut self.mailbox) {
                    return Err(StreamError::Timeout(Unanswered::Grbl(Op::Status)));
                }
            }
            (None, Some(until)) if now >= until => return Err(StreamError::Timeout(Unanswered::Grbl(Op::Unlock))),
            (None, _) => {}
        }
        Ok(None)
    }

    fn answer(&mut self, line: &AnswerLine, now: Instant) -> Result<Option<()>, StreamError> {
        let answer = GrblAnswer::parse(&line.text);
        if self.status.is_some() {
            let GrblAnswer::Status(status) = answer else { return Ok(None) };
            if status.state != GrblState::Alarm {
                return Ok(Some(()));
            }
            tracing::info!(?status, "GRBL in alarm: unlocking");
            self.mailbox.actions.push(Action::Query(Op::Unlock.bytes().to_vec()));
            self.status = None;
            self.until = Some(now + self.timing.reply_timeout);
            return Ok(None);
        }
        match answer {
            GrblAnswer::Ok => Ok(Some(())),
            GrblAnswer::Error(n) => Err(StreamError::Device(DeviceError::at(ErrorCode::Grbl(n), ErrorAt::Unlocking))),
            GrblAnswer::Alarm(n) => Err(StreamError::Device(DeviceError::at(ErrorCode::GrblAlarm(n), ErrorAt::Unlocking))),
            _ => Ok(None),
        }
    }

    fn deadline(&self, now: Instant) -> Instant {
        match (&self.status, self.until) {
            (Some(asking), _) => asking.deadline(now),
            (None, until) => until.unwrap_or(now),
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

    /// Fault 6 on GRBL: a board power-cycled between jobs greets with its
    /// banner; the next job's sync takes it for an earlier session's answer,
    /// not a reset, and the job plots.
    #[test]
    fn sync_drops_an_earlier_sessions_answers_and_keeps_its_alarm() {
        let mut x = Exchange::new(GrblSync::new(&timing(), 128));
        assert_eq!(x.poll().unwrap(), None);
        assert_eq!(x.asked, [Op::BuildInfo.bytes()]);
        // Answers to lines the last session wrote come first: none is the sync's.
        for stale in ["ok", "error:9", "ALARM:1", "Grbl 1.1h ['$' for help]", "<Idle|MPos:0.000,0.000,0.000|FS:0,0>", "ok"] {
            assert_eq!(x.answer(stale).unwrap(), None, "{stale}");
        }
        x.answer("[VER:1.1h.20190825:]").unwrap();
        assert_eq!(x.answer("[OPT:V,15,254]").unwrap(), None);
        assert_eq!(x.answer("ok").unwrap(), Some(Synced { rx: 254, alarm: Some(1) }));
    }

    #[test]
    fn sync_asks_three_times_then_times_out() {
        let mut x = Exchange::new(GrblSync::new(&timing(), 128));
        let e = x.run_out(Duration::from_secs(10), Duration::from_millis(50)).unwrap_err();
        assert!(matches!(e, StreamError::Timeout(Unanswered::Grbl(Op::BuildInfo))), "{e}");
        assert_eq!(x.asked.len(), 3, "a board booting ignores the first");
        // Each asking is seen up to one step late.
        assert!(x.elapsed() <= timing().reply_timeout + 3 * Duration::from_millis(50), "{:?}", x.elapsed());
        // A report, then no `ok`: no more asking, and the same timeout.
        let mut x = Exchange::new(GrblSync::new(&timing(), 128));
        x.poll().unwrap();
        x.answer("[VER:1.1h.20190825:]").unwrap();
        assert!(x.run_out(Duration::from_secs(10), Duration::from_millis(50)).is_err());
        assert_eq!(x.asked.len(), 1);
        // An answer to the second asking is in time.
        let mut x = Exchange::new(GrblSync::new(&timing(), 128));
        x.poll().unwrap();
        x.wait(timing().reply_timeout / 2);
        x.poll().unwrap();
        assert_eq!(x.asked.len(), 2);
        x.answer("[OPT:V,15,128]").unwrap();
        assert_eq!(x.answer("ok").unwrap(), Some(Synced { rx: 128, alarm: None }));
    }

    #[test]
    fn sync_refuses_a_buffer_too_small_and_an_error_after_the_report() {
        let mut x = Exchange::new(GrblSync::new(&timing(), 128));
        x.poll().unwrap();
        x.answer("[OPT:V,15,8]").unwrap();
        assert!(matches!(x.answer("ok"), Err(StreamError::Garbled(Garbled::ReceiveBuffer { bytes: 8, least: MIN_RX }))));
        let mut x = Exchange::new(GrblSync::new(&timing(), 128));
        x.poll().unwrap();
        x.answer("[VER:1.1h.20190825:]").unwrap();
        assert!(matches!(x.answer("error:3"), Err(StreamError::Device(DeviceError { code: ErrorCode::Grbl(3), .. }))));
    }

    /// Fault 8: a board in alarm is unlocked on the first resume.
    #[test]
    fn unlock_is_sent_only_to_a_board_in_alarm() {
        let mut x = Exchange::new(GrblUnlock::new(timing()));
        x.poll().unwrap();
        assert_eq!(x.answer("<Idle|MPos:0.000,0.000,0.000|FS:0,0>").unwrap(), Some(()));
        assert_eq!(x.asked, [Op::Status.bytes()], "no unlock for an idle board");

        let mut x = Exchange::new(GrblUnlock::new(timing()));
        x.poll().unwrap();
        x.answer("ok").unwrap();
        assert_eq!(x.answer("<Alarm|MPos:0.000,0.000,0.000|FS:0,0>").unwrap(), None);
        assert_eq!(x.asked, [Op::Status.bytes(), Op::Unlock.bytes()]);
        x.answer("[MSG:Caution: Unlocked]").unwrap();
        assert_eq!(x.answer("ok").unwrap(), Some(()));

        let mut x = Exchange::new(GrblUnlock::new(timing()));
        x.poll().unwrap();
        x.answer("<Alarm|MPos:0.000,0.000,0.000|FS:0,0>").unwrap();
        let e = x.answer("ALARM:1").unwrap_err();
        assert!(matches!(e, StreamError::Device(d) if d == DeviceError::at(ErrorCode::GrblAlarm(1), ErrorAt::Unlocking)), "{e}");
        assert!(e.to_string().contains("hard limit") && e.to_string().contains("unlocking"), "{e}");
    }

    #[test]
    fn unlock_times_out_on_a_silent_board() {
        let mut x = Exchange::new(GrblUnlock::new(timing()));
        let e = x.run_out(Duration::from_secs(10), Duration::from_millis(50)).unwrap_err();
        assert!(matches!(e, StreamError::Timeout(Unanswered::Grbl(Op::Status))), "{e}");
        assert_eq!(x.asked.len(), 3);
        let mut x = Exchange::new(GrblUnlock::new(timing()));
        x.poll().unwrap();
        x.answer("<Alarm|MPos:0.000,0.000,0.000|FS:0,0>").unwrap();
        let e = x.run_out(Duration::from_secs(10), Duration::from_millis(50)).unwrap_err();
        assert!(matches!(e, StreamError::Timeout(Unanswered::Grbl(Op::Unlock))), "{e}");
    }
}
