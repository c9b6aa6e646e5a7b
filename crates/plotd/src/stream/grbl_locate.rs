//! Where a GRBL board's tool rests after an interruption, as a state
//! machine that does no I/O ([`GrblLocate`]): the link brought into step
//! ([`GrblSync`]), then the board idle (planner drained, nothing
//! executing; waited for while it reports `Run`), its modal feed not the
//! power-on 0 (a power cycle or reset since would show), and the tool's
//! place: `MPos` (z included, for a pen on a Z axis) and the pen of a servo
//! as the spindle state ([`Op::ModalState`]). A board that restarted since
//! (its banner heard) or is in alarm cannot be located, and its place is
//! not the paper's: the locate fails with the reset or the alarm, and the
//! job waits for a person.

use super::grbl_setup::{status_asking, GrblSync, Synced};
use super::locate::{Rest, GCODE_POSITION_TOLERANCE};
use super::machine::{Action, Asking, Machine, Mailbox, Timing};
use super::{Alarm, Excerpt, Reset, StreamError, Unanswered};
use plotcode::answer::{AnswerLine, GrblAnswer, GrblModal, GrblState};
use plotcode::control::grbl::Op;
use std::time::Instant;
use strokes::DVec2;

#[derive(Debug)]
enum Phase {
    /// The sync: answers to the earlier session's lines come first.
    Sync(GrblSync),
    /// Asking the status until the board is idle.
    Status { asking: Asking, alarm: Option<u32> },
    /// The board is running what it holds: the status is asked again then.
    Waiting { until: Instant, alarm: Option<u32> },
    /// The modal state asked with the tool idle at `at`: it, once it came.
    Modal { at: [f64; 3], until: Instant, modal: Option<GrblModal> },
}

/// Finds where the tool rests: `None` when the board cannot tell (in alarm,
/// reset since, no status), so that plotting goes on from the checkpoint.
#[derive(Debug)]
pub(super) struct GrblLocate {
    timing: Timing,
    phase: Phase,
    /// How long the board may run what it holds.
    idle_by: Option<Instant>,
    mailbox: Mailbox,
}

impl GrblLocate {
    /// A locate that takes `default_rx` for the receive buffer when the
    /// build info does not give it.
    pub fn new(timing: Timing, default_rx: usize) -> GrblLocate {
        GrblLocate { timing, phase: Phase::Sync(GrblSync::new(&timing, default_rx)), idle_by: None, mailbox: Mailbox::default() }
    }

    fn ask_status(&mut self, alarm: Option<u32>, now: Instant) {
        let mut asking = status_asking(&self.timing);
        asking.poll(now, &mut self.mailbox);
        self.phase = Phase::Status { asking, alarm };
    }

    /// The sync's own actions are this machine's.
    fn synced(&mut self, r: Result<Option<Synced>, StreamError>, now: Instant) -> Result<Option<Option<Rest>>, StreamError> {
        if let Phase::Sync(sync) = &mut self.phase {
            self.mailbox.actions.append(&mut sync.take_actions());
        }
        if let Some(synced) = r? {
            if let Some(banner) = synced.restarted {
                return Err(StreamError::Reset(Reset::Banner(Excerpt::of(&banner))));
            }
            self.idle_by = Some(now + self.timing.motion_timeout);
            self.ask_status(synced.alarm, now);
        }
        Ok(None)
    }
}

/// Errors: those of [`GrblSync`]; [`StreamError::Timeout`] when the modal
/// state is not given; [`StreamError::Reset`] for a board that restarted
/// since it was last read; [`StreamError::Alarm`] for one in alarm.
impl Machine for GrblLocate {
    type Output = Option<Rest>;

    fn poll(&mut self, now: Instant, xoff: bool) -> Result<Option<Option<Rest>>, StreamError> {
        match &mut self.phase {
            Phase::Sync(sync) => {
                let r = sync.poll(now, xoff);
                self.synced(r, now)
            }
            Phase::Status { asking, .. } => Ok((!asking.poll(now, &mut self.mailbox)).then_some(None)),
            Phase::Waiting { until, alarm } if now >= *until => {
                let alarm = *alarm;
                self.ask_status(alarm, now);
                Ok(None)
            }
            Phase::Modal { until, .. } if now >= *until => Err(StreamError::Timeout(Unanswered::Grbl(Op::ModalState))),
            Phase::Waiting { .. } | Phase::Modal { .. } => Ok(None),
        }
    }

    fn answer(&mut self, line: &AnswerLine, now: Instant) -> Result<Option<Option<Rest>>, StreamError> {
        let alarm = match &mut self.phase {
            Phase::Sync(sync) => {
                let r = sync.answer(line, now);
                return self.synced(r, now);
            }
            Phase::Status { alarm, .. } => *alarm,
            Phase::Waiting { .. } => return Ok(None),
            Phase::Modal { at, modal, .. } => {
                return match GrblAnswer::parse(&line.text) {
                    GrblAnswer::Modal(m) => {
                        *modal = Some(m);
                        Ok(None)
                    }
                    GrblAnswer::Ok => Ok(Some(rest(*at, *modal))),
                    GrblAnswer::Alarm(n) => Err(StreamError::Alarm(Alarm::Raised(n))),
                    GrblAnswer::Error(_) => Ok(Some(None)),
                    _ => Ok(None),
                };
            }
        };
        let GrblAnswer::Status(status) = GrblAnswer::parse(&line.text) else { return Ok(None) };
        match status.state {
            GrblState::Idle => {
                let Some(at) = status.pos else { return Ok(Some(None)) };
                // `[GC:G1 G54 G17 G21 G90 G94 M3 M9 T0 F3000 S1000]`: the
                // feed rate the job set survives everything but a reset; M3
                // with S above 0 is a pen on a servo down.
                self.mailbox.actions.push(Action::Query(Op::ModalState.bytes().to_vec()));
                self.phase = Phase::Modal { at, until: now + self.timing.reply_timeout, modal: None };
                Ok(None)
            }
            // The board stopped at once (a limit, a reset in motion): its
            // place cannot be trusted, whatever it reports (issue 36; issue
            // 15's fault 8 unlocked it silently).
            GrblState::Alarm => Err(StreamError::Alarm(alarm.map_or(Alarm::Unexplained, Alarm::Raised))),
            GrblState::Run if self.idle_by.is_some_and(|t| now < t) => {
                self.phase = Phase::Waiting { until: now + self.timing.poll_interval, alarm };
                Ok(None)
            }
            _ => Ok(Some(None)),
        }
    }

    fn deadline(&self, now: Instant) -> Instant {
        match &self.phase {
            Phase::Sync(sync) => sync.deadline(now),
            Phase::Status { asking, .. } => asking.deadline(now),
            Phase::Waiting { until, .. } | Phase::Modal { until, .. } => *until,
        }
    }

    fn mailbox(&mut self) -> &mut Mailbox {
        &mut self.mailbox
    }
}

/// Where the tool at `at` rests, when the modal state shows the job's feed
/// (no reset since) and the spindle state.
fn rest(at: [f64; 3], modal: Option<GrblModal>) -> Option<Rest> {
    let modal = modal.filter(|m| m.feed.is_some_and(|f| f > 0.0))?;
    let spindle_on = modal.spindle_on?;
    Some(Rest {
        pos: DVec2::new(at[0], at[1]),
        down: Some(spindle_on && modal.speed > 0.0),
        z: Some(at[2]),
        tolerance: GCODE_POSITION_TOLERANCE,
    })
}

#[cfg(test)]
mod tests {
    use super::super::machine::testing::{timing, Exchange};
    use super::*;
    use std::time::Duration;

    const IDLE: &str = "<Idle|MPos:10.000,5.000,0.000|FS:0,0>";

    /// Past the sync: the earlier session's answers, then the build info.
    fn synced(alarm: Option<&str>) -> Exchange<GrblLocate> {
        let mut x = Exchange::new(GrblLocate::new(timing(), 128));
        x.poll().unwrap();
        for line in ["ok", "ok"].into_iter().chain(alarm) {
            x.answer(line).unwrap();
        }
        for line in ["[VER:1.1h.20190825:]", "[OPT:V,15,128]", "ok"] {
            assert_eq!(x.answer(line).unwrap(), None);
        }
        assert_eq!(x.asked, [Op::BuildInfo.bytes(), Op::Status.bytes()], "the status asked as soon as the link is in step");
        x
    }

    #[test]
    fn an_idle_board_with_the_jobs_feed_is_located() {
        let mut x = synced(None);
        x.answer(IDLE).unwrap();
        assert_eq!(x.asked.last().map(Vec::as_slice), Some(Op::ModalState.bytes()));
        x.answer("[GC:G1 G54 G17 G21 G90 G94 M3 M9 T0 F3000 S1000]").unwrap();
        let rest = x.answer("ok").unwrap().expect("over").expect("located");
        assert_eq!((rest.pos, rest.down, rest.z), (DVec2::new(10.0, 5.0), Some(true), Some(0.0)));
        // M5, or M3 with S0: a servo's pen up.
        for modal in ["[GC:G0 G54 G17 G21 G90 G94 M5 M9 T0 F3000 S1000]", "[GC:G0 G54 G17 G21 G90 G94 M3 M9 T0 F3000 S0]"] {
            let mut x = synced(None);
            x.answer(IDLE).unwrap();
            x.answer(modal).unwrap();
            assert_eq!(x.answer("ok").unwrap().flatten().and_then(|r| r.down), Some(false), "{modal}");
        }
    }

    /// A reset or power cycle since the job set its feed: nothing of where
    /// the job got can be read from the board.
    #[test]
    fn a_board_reset_since_is_not_located() {
        let mut x = synced(None);
        x.answer(IDLE).unwrap();
        x.answer("[GC:G0 G54 G17 G21 G90 G94 M5 M9 T0 F0 S0]").unwrap();
        assert_eq!(x.answer("ok").unwrap(), Some(None));
    }

    /// A banner before the report: the board restarted since (a reset, a
    /// power cycle, an Arduino's reset on open), so its zero is where the
    /// carriage stood: the locate ends with the reset (issue 36), the job
    /// waits for a person.
    #[test]
    fn a_banner_heard_in_the_sync_is_a_reset() {
        let mut x = Exchange::new(GrblLocate::new(timing(), 128));
        x.poll().unwrap();
        for line in ["Grbl 1.1h ['$' for help]", "[VER:1.1h.20190825:]", "[OPT:V,15,128]"] {
            assert_eq!(x.answer(line).unwrap(), None);
        }
        let e = x.answer("ok").unwrap_err();
        assert!(matches!(e, StreamError::Reset(Reset::Banner(_))), "{e}");
        assert_eq!(x.asked, [Op::BuildInfo.bytes()], "nothing asked after the sync");
    }

    /// The board still runs what it held: asked again until it is idle,
    /// for at most the motion timeout.
    #[test]
    fn a_running_board_is_waited_for() {
        let mut x = synced(None);
        for _ in 0..5 {
            assert_eq!(x.answer("<Run|MPos:1.000,0.000,0.000|FS:3000,1000>").unwrap(), None);
            let asked = x.asked.len();
            x.wait(timing().poll_interval);
            x.poll().unwrap();
            assert_eq!(x.asked.len(), asked + 1, "asked again after the poll interval");
        }
        x.answer(IDLE).unwrap();
        assert_eq!(x.asked.last().map(Vec::as_slice), Some(Op::ModalState.bytes()));
        // One that runs past the motion timeout cannot be located.
        let mut x = synced(None);
        x.answer("<Run|MPos:1.000,0.000,0.000|FS:3000,1000>").unwrap();
        x.wait(timing().motion_timeout);
        x.poll().unwrap();
        assert_eq!(x.answer("<Run|MPos:1.000,0.000,0.000|FS:3000,1000>").unwrap(), Some(None));
    }

    /// Issue 36: a board found in alarm stopped at once, its place not to
    /// be trusted: the locate ends with the alarm (the job waits for a
    /// person), not a device error, nor a silent unlock (issue 15's fault 8).
    #[test]
    fn a_board_in_alarm_is_not_located_its_alarm_told() {
        let mut x = synced(Some("ALARM:1"));
        let e = x.answer("<Alarm|MPos:0.000,0.000,0.000|FS:0,0>").unwrap_err();
        assert!(matches!(e, StreamError::Alarm(Alarm::Raised(1))), "{e}");
        let mut x = synced(None);
        let e = x.answer("<Alarm|MPos:0.000,0.000,0.000|FS:0,0>").unwrap_err();
        assert!(matches!(e, StreamError::Alarm(Alarm::Unexplained)), "{e}");
    }

    #[test]
    fn silence_is_not_a_place() {
        let mut x = synced(None);
        assert_eq!(x.run_out(Duration::from_secs(10), Duration::from_millis(50)).unwrap(), None);
        assert_eq!(x.asked.iter().filter(|q| *q == Op::Status.bytes()).count(), 3);
        let mut x = synced(None);
        x.answer(IDLE).unwrap();
        let e = x.run_out(Duration::from_secs(10), Duration::from_millis(50)).unwrap_err();
        assert!(matches!(e, StreamError::Timeout(Unanswered::Grbl(Op::ModalState))), "{e}");
    }
}
