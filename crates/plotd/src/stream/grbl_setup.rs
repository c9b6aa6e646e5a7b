//! Bringing a GRBL link into step before a run, as state machines that do
//! no I/O: [`GrblSync`] reads the receive buffer size from the build info
//! ([`Op::BuildInfo`]; every answer before the report answers an earlier
//! session's lines, so the link is in step after it, and a banner among
//! them says the board restarted), and [`GrblRestore`] does what a person
//! said to a board in alarm: nothing, unlock ([`Op::Unlock`]) or home
//! ([`Op::Home`]); never [`Op::Unlock`] unasked. Both ask again, or give up, on a
//! hand-moved clock.

use super::machine::{Action, Asking, Machine, Mailbox, Timing};
use super::{Alarm, DeviceError, ErrorAt, Garbled, Restore, StreamError, Unanswered};
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
#[derive(Clone, Debug, PartialEq, Eq)]
pub(super) struct Synced {
    /// The receive buffer size.
    pub rx: usize,
    /// The last `ALARM:N` among the earlier session's answers: the reason
    /// of an alarm the board may still be in.
    pub alarm: Option<u32>,
    /// The last banner among them: the board restarted (reset, power cycle,
    /// an Arduino's reset on open) since the daemon last read it.
    pub restarted: Option<String>,
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
    restarted: Option<String>,
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
            restarted: None,
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
                return Ok(Some(Synced { rx: self.rx, alarm: self.alarm, restarted: self.restarted.take() }));
            }
            GrblAnswer::Error(n) if self.reported => return Err(StreamError::Device(DeviceError::new(ErrorCode::Grbl(n)))),
            // An earlier run's: the board may still be in that alarm.
            GrblAnswer::Alarm(n) => self.alarm = Some(n),
            // A soft reset keeps GRBL's alarm state: the alarm stays.
            GrblAnswer::Welcome(banner) => self.restarted = Some(banner),
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

/// A board in alarm (a limit switch, a reset in motion, or locked since it
/// started because homing is enabled) is locked and answers G-code with
/// `error:9`, and its position cannot be trusted: asks the status, and does
/// what the person said ([`Restore`]): nothing (the run ends with the
/// alarm), unlock ([`Op::Unlock`]: the pen was parked at the origin), or home ([`Op::Home`],
/// also on a board not in alarm: its zero is found again). The resume
/// prefix then sets the modal state and the position again.
#[derive(Debug)]
pub(super) struct GrblRestore {
    timing: Timing,
    restore: Restore,
    /// The last `ALARM:N` heard on the link before: why the board is in alarm.
    heard: Option<u32>,
    /// Asking the status; `None` once the unlock or homing is sent.
    status: Option<Asking>,
    /// What was sent, and when it must have been answered.
    sent: Option<(Op, Instant)>,
    mailbox: Mailbox,
}

impl GrblRestore {
    /// A restore with `timing`'s waits doing `restore`, after `heard` (the
    /// sync's [`Synced::alarm`]).
    pub fn new(timing: Timing, restore: Restore, heard: Option<u32>) -> GrblRestore {
        GrblRestore { timing, restore, heard, status: Some(status_asking(&timing)), sent: None, mailbox: Mailbox::default() }
    }

    fn send(&mut self, op: Op, now: Instant) {
        // Homing runs to the switches: a motion's wait, not a reply's.
        let wait = if op == Op::Home { self.timing.motion_timeout } else { self.timing.reply_timeout };
        self.mailbox.actions.push(Action::Query(op.bytes().to_vec()));
        self.status = None;
        self.sent = Some((op, now + wait));
    }
}

/// Errors: [`StreamError::Alarm`] for a board in alarm a person has not
/// answered for, or an alarm raised by the homing cycle;
/// [`StreamError::Timeout`] when no status report or no answer to the
/// unlock or homing comes; [`StreamError::Device`] when either is refused.
impl Machine for GrblRestore {
    type Output = ();

    fn poll(&mut self, now: Instant, _xoff: bool) -> Result<Option<()>, StreamError> {
        match (&mut self.status, self.sent) {
            (Some(asking), _) => {
                if !asking.poll(now, &mut self.mailbox) {
                    return Err(StreamError::Timeout(Unanswered::Grbl(Op::Status)));
                }
            }
            (None, Some((op, until))) if now >= until => return Err(StreamError::Timeout(Unanswered::Grbl(op))),
            (None, _) => {}
        }
        Ok(None)
    }

    fn answer(&mut self, line: &AnswerLine, now: Instant) -> Result<Option<()>, StreamError> {
        let answer = GrblAnswer::parse(&line.text);
        if self.status.is_some() {
            let GrblAnswer::Status(status) = answer else { return Ok(None) };
            let alarm = status.state == GrblState::Alarm;
            match (self.restore, alarm) {
                (Restore::Home, _) => {
                    tracing::warn!(?status, "homing the machine ({}), as a person asked", Op::Home);
                    self.send(Op::Home, now);
                }
                (Restore::Confirmed, true) => {
                    tracing::warn!(?status, "GRBL in alarm: unlocking ({}), the position confirmed by a person", Op::Unlock);
                    self.send(Op::Unlock, now);
                }
                (_, false) => return Ok(Some(())),
                (Restore::Nothing, true) => {
                    return Err(StreamError::Alarm(self.heard.map_or(Alarm::NeedsHoming, Alarm::Raised)));
                }
            }
            return Ok(None);
        }
        let at = if self.sent.is_some_and(|(op, _)| op == Op::Home) { ErrorAt::Homing } else { ErrorAt::Unlocking };
        match answer {
            GrblAnswer::Ok => Ok(Some(())),
            GrblAnswer::Error(n) => Err(StreamError::Device(DeviceError::at(ErrorCode::Grbl(n), at))),
            GrblAnswer::Alarm(n) if at == ErrorAt::Homing => Err(StreamError::Alarm(Alarm::Raised(n))),
            GrblAnswer::Alarm(n) => Err(StreamError::Device(DeviceError::at(ErrorCode::GrblAlarm(n), at))),
            _ => Ok(None),
        }
    }

    fn deadline(&self, now: Instant) -> Instant {
        match (&self.status, self.sent) {
            (Some(asking), _) => asking.deadline(now),
            (None, sent) => sent.map_or(now, |(_, until)| until),
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
        assert_eq!(x.answer("ok").unwrap(), Some(Synced { rx: 254, alarm: Some(1), restarted: Some("Grbl 1.1h ['$' for help]".into()) }));
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
        assert_eq!(x.answer("ok").unwrap(), Some(Synced { rx: 128, alarm: None, restarted: None }));
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

    const ALARM: &str = "<Alarm|MPos:0.000,0.000,0.000|FS:0,0>";
    const IDLE: &str = "<Idle|MPos:0.000,0.000,0.000|FS:0,0>";

    /// What GRBL 1.1 prints when it starts locked (`protocol.c`): its
    /// commands to home and to unlock, quoted.
    fn unlock_hint() -> String {
        let command = |op: Op| String::from_utf8_lossy(op.bytes()).trim_end().to_owned();
        format!("[MSG:'{}'|'{}' to unlock]", command(Op::Home), command(Op::Unlock))
    }

    /// Issue 36: a board in alarm is never unlocked unasked. Locked with no
    /// `ALARM:N` heard (homing enabled, `$22=1`: it starts so), the run ends
    /// `NeedsHoming`; after an alarm it raised, with that alarm. Nothing but
    /// the status is asked (before: unlocked at once, and it plotted unhomed).
    #[test]
    fn a_board_in_alarm_is_left_locked_unless_a_person_said() {
        for (heard, alarm) in [(None, Alarm::NeedsHoming), (Some(1), Alarm::Raised(1))] {
            let mut x = Exchange::new(GrblRestore::new(timing(), Restore::Nothing, heard));
            x.poll().unwrap();
            x.answer(&unlock_hint()).unwrap();
            let e = x.answer(ALARM).unwrap_err();
            assert!(matches!(e, StreamError::Alarm(a) if a == alarm), "{e}");
            assert_eq!(x.asked, [Op::Status.bytes()], "neither unlocked nor homed");
        }
        let mut x = Exchange::new(GrblRestore::new(timing(), Restore::Nothing, None));
        x.poll().unwrap();
        assert_eq!(x.answer(IDLE).unwrap(), Some(()));
        assert_eq!(x.asked, [Op::Status.bytes()], "nothing for an idle board");
    }

    /// The person parked the pen and confirmed: a board in alarm is
    /// unlocked ([`Op::Unlock`]), one that is not is left as it is.
    #[test]
    fn a_confirmed_position_unlocks_a_board_in_alarm() {
        let mut x = Exchange::new(GrblRestore::new(timing(), Restore::Confirmed, None));
        x.poll().unwrap();
        assert_eq!(x.answer(IDLE).unwrap(), Some(()));
        assert_eq!(x.asked, [Op::Status.bytes()], "no unlock for an idle board");

        let mut x = Exchange::new(GrblRestore::new(timing(), Restore::Confirmed, Some(1)));
        x.poll().unwrap();
        x.answer("ok").unwrap();
        assert_eq!(x.answer(ALARM).unwrap(), None);
        assert_eq!(x.asked, [Op::Status.bytes(), Op::Unlock.bytes()]);
        x.answer("[MSG:Caution: Unlocked]").unwrap();
        assert_eq!(x.answer("ok").unwrap(), Some(()));

        let mut x = Exchange::new(GrblRestore::new(timing(), Restore::Confirmed, None));
        x.poll().unwrap();
        x.answer(ALARM).unwrap();
        let e = x.answer("ALARM:1").unwrap_err();
        assert!(matches!(e, StreamError::Device(d) if d == DeviceError::at(ErrorCode::GrblAlarm(1), ErrorAt::Unlocking)), "{e}");
        assert!(e.to_string().contains("hard limit") && e.to_string().contains("unlocking"), "{e}");
    }

    /// A plotter with homing switches and a person's resume: homed, locked
    /// or not, and never unlocked; its `ok` comes once the cycle is done, which
    /// may take a motion's time, not a reply's. A failed cycle is an alarm.
    #[test]
    fn homing_is_sent_and_waited_for_a_motions_time() {
        for status in [ALARM, IDLE] {
            let mut x = Exchange::new(GrblRestore::new(timing(), Restore::Home, None));
            x.poll().unwrap();
            assert_eq!(x.answer(status).unwrap(), None);
            assert_eq!(x.asked, [Op::Status.bytes(), Op::Home.bytes()]);
            x.wait(timing().reply_timeout * 2);
            assert_eq!(x.poll().unwrap(), None, "homing is not a reply");
            assert_eq!(x.answer("<Home|MPos:-1.000,0.000,0.000|FS:500,0>").unwrap(), None);
            assert_eq!(x.answer("ok").unwrap(), Some(()));
        }
        let mut x = Exchange::new(GrblRestore::new(timing(), Restore::Home, None));
        x.poll().unwrap();
        x.answer(ALARM).unwrap();
        let e = x.answer("ALARM:9").unwrap_err();
        assert!(matches!(e, StreamError::Alarm(Alarm::Raised(9))), "{e}");
        let mut x = Exchange::new(GrblRestore::new(timing(), Restore::Home, None));
        x.poll().unwrap();
        x.answer(IDLE).unwrap();
        let e = x.run_out(timing().motion_timeout * 2, Duration::from_secs(1)).unwrap_err();
        assert!(matches!(e, StreamError::Timeout(Unanswered::Grbl(Op::Home))), "{e}");
        assert!(x.elapsed() >= timing().motion_timeout, "{:?}", x.elapsed());
    }

    #[test]
    fn unlock_times_out_on_a_silent_board() {
        let mut x = Exchange::new(GrblRestore::new(timing(), Restore::Confirmed, None));
        let e = x.run_out(Duration::from_secs(10), Duration::from_millis(50)).unwrap_err();
        assert!(matches!(e, StreamError::Timeout(Unanswered::Grbl(Op::Status))), "{e}");
        assert_eq!(x.asked.len(), 3);
        let mut x = Exchange::new(GrblRestore::new(timing(), Restore::Confirmed, None));
        x.poll().unwrap();
        x.answer(ALARM).unwrap();
        let e = x.run_out(Duration::from_secs(10), Duration::from_millis(50)).unwrap_err();
        assert!(matches!(e, StreamError::Timeout(Unanswered::Grbl(Op::Unlock))), "{e}");
    }
}
