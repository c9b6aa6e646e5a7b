//! What a state machine for an exchange with the device (a run of chunks,
//! a ping, a sync, locating the pen) says to the loop that drives it, and
//! the one interface that loop drives them all through.
//!
//! A machine does no I/O and reads no clock: answer lines and the time go
//! in, [`Action`]s come out in order, and [`Machine::deadline`] says when
//! to look again if nothing arrives. So every rule about the device is
//! tested with scripted answers on a hand-moved clock.

use super::{Hold, Stop, StreamError, Written};
use plotcode::answer::AnswerLine;
use std::time::{Duration, Instant};

/// The waits of a run.
#[derive(Clone, Copy, Debug)]
pub(super) struct Timing {
    /// Longest wait for an immediate answer (HP-GL's device-control
    /// queries, GRBL's status report).
    pub reply_timeout: Duration,
    /// Longest wait for progress while the device holds work (a marker
    /// answered, an `ok`).
    pub motion_timeout: Duration,
    /// GRBL: how long the board may report `Idle` with lines in flight and
    /// nothing answered before it counts as stalled (a dwell longer than this
    /// in a job is taken for a stall: the job resumes from its checkpoint).
    pub stall_after: Duration,
    /// Pause between polls while waiting.
    pub poll_interval: Duration,
    /// HP-GL: silence while the device holds work after which it is asked
    /// for its free space (ESC.B), so that a power cycle or a dead device is
    /// noticed in seconds, not after [`Timing::motion_timeout`].
    pub probe_after: Duration,
}

impl Timing {
    /// The waits `settings` ask for.
    pub fn of(settings: &super::StreamSettings) -> Timing {
        Timing {
            reply_timeout: settings.reply_timeout,
            motion_timeout: settings.motion_timeout,
            stall_after: settings.stall_after,
            poll_interval: settings.poll_interval,
            probe_after: settings.probe_after,
        }
    }
}

/// What the streamer must do, in order.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum Action {
    /// Write job bytes (chunks, markers, the pen-up of a stop); `payload`
    /// of them are job bytes.
    Write {
        /// The bytes.
        bytes: Vec<u8>,
        /// Job bytes among them.
        payload: usize,
    },
    /// Write a query or control the device does not buffer
    /// ([`plotcode::control`]: HP-GL device-control, GRBL real-time and `$`
    /// commands).
    Query(Vec<u8>),
    /// Record how far the job has been handed to the device.
    Written(Written),
    /// Chunks `..k` are confirmed executed.
    Confirmed(usize),
    /// The device holds its work for a reason a person must act on (`Some`),
    /// or goes on again (`None`).
    Held(Option<Hold>),
}

/// What a machine has decided and not yet handed over, and the stop asked
/// of it: the part every machine keeps the same way.
#[derive(Debug, Default)]
pub(super) struct Mailbox {
    /// Actions decided since the last [`Machine::take_actions`].
    pub actions: Vec<Action>,
    /// The stop asked for.
    pub stop: Stop,
}

impl Mailbox {
    /// Whether any stop was asked for: nothing is written past the chunk
    /// being written.
    pub fn stopping(&self) -> bool {
        self.stop > Stop::Continue
    }

    /// Records a stop request (one for less than already asked changes
    /// nothing); true when it is the first stop now, which the machine acts
    /// on at once.
    pub fn ask(&mut self, how: Stop) -> bool {
        let before = self.stop;
        self.stop = before.max(how);
        how == Stop::Now && before < Stop::Now
    }
}

/// An exchange with the device, driven by [`super::Streamer`]'s one loop:
/// a run of chunks ([`super::hpgl::HpglRun`], [`super::grbl::GrblRun`]), or
/// the short exchanges around runs (a ping, GRBL's sync and unlock,
/// locating the pen after an interruption).
pub(super) trait Machine {
    /// What the exchange finds out when it ends.
    type Output;
    /// Writes what may be written, sends the questions that are due and
    /// checks the deadlines; `xoff` is whether the device last said XOFF.
    /// `Some` when the exchange is over (a question asked often enough
    /// without an answer may be an answer too).
    ///
    /// # Errors
    /// The [`StreamError`] that ends the exchange (a timeout, a stall).
    fn poll(&mut self, now: Instant, xoff: bool) -> Result<Option<Self::Output>, StreamError>;
    /// Takes one answer line; `Some` when the exchange is over.
    ///
    /// # Errors
    /// The [`StreamError`] the answer means (a device error, a reset, garbage).
    fn answer(&mut self, line: &AnswerLine, now: Instant) -> Result<Option<Self::Output>, StreamError>;
    /// When to call [`Machine::poll`] again if no answer comes.
    fn deadline(&self, now: Instant) -> Instant;
    /// The machine's actions and stop request.
    fn mailbox(&mut self) -> &mut Mailbox;
    /// The actions decided since the last call.
    fn take_actions(&mut self) -> Vec<Action> {
        std::mem::take(&mut self.mailbox().actions)
    }
    /// Whether it takes a stop: only runs of chunks do; the exchanges
    /// around them are short and write nothing of the job.
    const TAKES_STOP: bool = false;
    /// Stops the pen where it is: a run's first stop now.
    fn abort(&mut self, _now: Instant) {}
    /// Asks for a stop; the first stop now aborts at once.
    fn stop(&mut self, how: Stop, now: Instant) {
        if Self::TAKES_STOP && self.mailbox().ask(how) {
            self.abort(now);
        }
    }
    /// Whether a stop request can still change what the machine does.
    fn takes_stop(&mut self) -> bool {
        Self::TAKES_STOP && self.mailbox().stop < Stop::Now
    }
}

/// A question the device answers at once (GRBL's status report and build
/// info, HP-GL's free space), asked again when no answer comes in time.
#[derive(Clone, Copy, Debug)]
pub(super) struct Asking {
    query: &'static [u8],
    /// Times it may still be asked.
    left: u32,
    /// How long each asking waits.
    wait: Duration,
    /// When the last asking runs out; `None` before the first.
    until: Option<Instant>,
}

impl Asking {
    /// `query`, asked up to `times` times, waiting `wait` each time.
    pub fn new(query: &'static [u8], times: u32, wait: Duration) -> Asking {
        Asking { query, left: times, wait, until: None }
    }

    /// Asks when it is time to (first, or the last asking ran out); false
    /// when it ran out and may not be asked again.
    pub fn poll(&mut self, now: Instant, mailbox: &mut Mailbox) -> bool {
        if self.until.is_some_and(|t| now < t) {
            return true;
        }
        if self.left == 0 {
            return false;
        }
        self.left -= 1;
        mailbox.actions.push(Action::Query(self.query.to_vec()));
        self.until = Some(now + self.wait);
        true
    }

    /// Whether the last asking has run out (a machine that heard a first
    /// answer waits for the rest until then, and asks no more).
    pub fn expired(&self, now: Instant) -> bool {
        self.until.is_some_and(|t| now >= t)
    }

    /// When it runs out, or asks again.
    pub fn deadline(&self, now: Instant) -> Instant {
        self.until.unwrap_or(now)
    }
}

#[cfg(test)]
pub(super) mod testing {
    //! What the machines' unit tests share: the daemon's default waits, a
    //! program of numbered strokes cut for a device, and a machine driven
    //! by hand ([`Exchange`]).

    use super::{Action, Machine, Timing};
    use crate::stream::{StreamError, StreamSettings};
    use plotcode::answer::{AnswerLine, Terminator};
    use plotcode::control::ebb::ERASE_HALF_COMMAND;
    use plotcode::Handshake;
    use plotcode::{DeviceProfile, Program};
    use std::time::{Duration, Instant};

    /// The waits of a run with the daemon's defaults.
    pub fn timing() -> Timing {
        Timing::of(&StreamSettings::new(Handshake::Escb))
    }

    /// `head`, then `stroke(i)` for `i` in `0..strokes`, cut for `device`.
    pub fn program(device: &str, head: &str, strokes: usize, stroke: impl Fn(usize) -> String) -> Program {
        let text: String = std::iter::once(head.to_owned()).chain((0..strokes).map(stroke)).collect();
        plotcode::cut(text.as_bytes(), &DeviceProfile::builtin(device).expect("a built-in profile")).expect("the test program cuts")
    }

    /// A machine, a clock moved by hand, and what the machine sent.
    pub struct Exchange<M> {
        pub machine: M,
        pub now: Instant,
        start: Instant,
        /// Queries, in order, the erase before an EBB's `V` taken off
        /// (and counted in `erased`).
        pub asked: Vec<Vec<u8>>,
        /// Queries sent after [`ERASE_HALF_COMMAND`].
        pub erased: usize,
        /// Bytes written (not queries), in order.
        pub written: Vec<u8>,
        /// Written marks, in order.
        pub marks: Vec<crate::stream::Written>,
        /// The last checkpoint confirmed.
        pub confirmed: usize,
    }

    impl<M: Machine> Exchange<M> {
        pub fn new(machine: M) -> Exchange<M> {
            let now = Instant::now();
            Exchange { machine, now, start: now, asked: Vec::new(), erased: 0, written: Vec::new(), marks: Vec::new(), confirmed: 0 }
        }

        fn drain(&mut self) {
            for a in self.machine.take_actions() {
                match a {
                    Action::Query(q) => match q.strip_prefix(ERASE_HALF_COMMAND.as_slice()) {
                        Some(rest) => {
                            self.erased += 1;
                            self.asked.push(rest.to_vec());
                        }
                        None => self.asked.push(q),
                    },
                    Action::Write { bytes, .. } => self.written.extend_from_slice(&bytes),
                    Action::Written(mark) => self.marks.push(mark),
                    Action::Confirmed(k) => self.confirmed = k,
                    Action::Held(_) => {}
                }
            }
        }

        pub fn poll(&mut self) -> Result<Option<M::Output>, StreamError> {
            let r = self.machine.poll(self.now, false);
            self.drain();
            r
        }

        /// An answer ended by LF.
        pub fn answer(&mut self, text: &str) -> Result<Option<M::Output>, StreamError> {
            self.line(text, Terminator::Lf)
        }

        pub fn line(&mut self, text: &str, terminator: Terminator) -> Result<Option<M::Output>, StreamError> {
            let r = self.machine.answer(&AnswerLine { text: text.into(), terminator }, self.now);
            self.drain();
            r
        }

        pub fn wait(&mut self, d: Duration) {
            self.now += d;
        }

        /// Time since the exchange began.
        pub fn elapsed(&self) -> Duration {
            self.now - self.start
        }

        /// Polls in steps of `step`, no answer coming, until the machine
        /// ends or `limit` has passed (a panic: it waits for ever).
        pub fn run_out(&mut self, limit: Duration, step: Duration) -> Result<M::Output, StreamError> {
            let end = self.now + limit;
            loop {
                if let Some(out) = self.poll()? {
                    return Ok(out);
                }
                assert!(self.now < end, "still waiting after {limit:?}");
                self.wait(step);
            }
        }
    }
}
