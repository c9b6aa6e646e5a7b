//! What a handshake state machine ([`super::hpgl::HpglRun`],
//! [`super::grbl::GrblRun`]) says to the loop that drives it, and the one
//! interface that loop drives them through.
//!
//! A machine does no I/O and reads no clock: answer lines and the time go
//! in, [`Action`]s come out in order, and [`HandshakeMachine::deadline`] says when
//! to look again if nothing arrives. So every rule about the device is
//! tested with scripted answers on a hand-moved clock.

use super::{Hold, Outcome, Stop, StreamError, Written};
use plotcode::answer::AnswerLine;
use std::time::{Duration, Instant};

/// The waits of a run.
#[derive(Clone, Copy, Debug)]
pub(super) struct Timing {
    /// Longest wait for an immediate answer (ESC.B, ESC.L, `?`).
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
    /// Write a query or device-control instruction the device does not
    /// buffer (ESC.B, ESC.K, GRBL `?`).
    Query(&'static [u8]),
    /// Record how far the job has been handed to the device.
    Written(Written),
    /// Chunks `..k` are confirmed executed.
    Confirmed(usize),
    /// The device holds its work for a reason a person must act on (`Some`),
    /// or goes on again (`None`).
    Held(Option<Hold>),
}

/// What a run has decided and not yet handed over, and whether it was asked
/// to stop: the part every machine keeps the same way.
#[derive(Debug, Default)]
pub(super) struct Mailbox {
    /// Actions decided since the last [`HandshakeMachine::take_actions`].
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
}

/// A handshake: one run of chunks, driven by [`super::Streamer`].
pub(super) trait HandshakeMachine {
    /// Writes what may be written, sends the queries that are due and checks
    /// the deadlines; `xoff` is whether the device last said XOFF.
    ///
    /// # Errors
    /// The [`StreamError`] that ends the run (a timeout, a stall).
    fn poll(&mut self, now: Instant, xoff: bool) -> Result<(), StreamError>;
    /// Takes one answer line; `Some` when the run is over.
    ///
    /// # Errors
    /// The [`StreamError`] the answer means (a device error, a reset, garbage).
    fn answer(&mut self, line: &AnswerLine, now: Instant) -> Result<Option<Outcome>, StreamError>;
    /// When to call [`HandshakeMachine::poll`] again if no answer comes.
    fn deadline(&self, now: Instant) -> Instant;
    /// The run's actions and stop request.
    fn mailbox(&mut self) -> &mut Mailbox;
    /// The stop asked for so far.
    fn stop_asked(&self) -> Stop;
    /// Stops the pen where it is ([`Stop::Now`]): what the device holds is
    /// dropped, the pen lifted, and the run ends [`Outcome::Stopped`] once
    /// every chunk the device ran is confirmed.
    fn abort(&mut self, now: Instant);
    /// The actions decided since the last call.
    fn take_actions(&mut self) -> Vec<Action> {
        std::mem::take(&mut self.mailbox().actions)
    }
    /// Asks for a stop (a request for less than one already asked changes
    /// nothing).
    fn stop(&mut self, how: Stop, now: Instant) {
        let before = self.mailbox().stop;
        self.mailbox().stop = before.max(how);
        if how == Stop::Now && before < Stop::Now {
            self.abort(now);
        }
    }
}

#[cfg(test)]
pub(super) mod testing {
    //! What the machines' unit tests share: the daemon's default waits, and
    //! a program of numbered strokes cut for a device.

    use super::Timing;
    use crate::config::Handshake;
    use crate::stream::StreamSettings;
    use plotcode::{DeviceProfile, Program};

    /// The waits of a run with the daemon's defaults.
    pub fn timing() -> Timing {
        Timing::of(&StreamSettings::new(Handshake::Escb))
    }

    /// `head`, then `stroke(i)` for `i` in `0..strokes`, cut for `device`.
    pub fn program(device: &str, head: &str, strokes: usize, stroke: impl Fn(usize) -> String) -> Program {
        let text: String = std::iter::once(head.to_owned()).chain((0..strokes).map(stroke)).collect();
        plotcode::cut(text.as_bytes(), &DeviceProfile::builtin(device).expect("a built-in profile")).expect("the test program cuts")
    }
}
