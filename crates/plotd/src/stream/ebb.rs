//! An EiBotBoard's (AxiDraw's) handshake as a state machine that does no I/O.
//!
//! [`EbbRun`] takes the board's reply lines and the time, and gives back
//! [`Action`]s in order, like [`super::grbl::GrblRun`]. The streamer feeds it
//! from the port; unit tests feed it scripted replies on a hand-moved clock.
//!
//! Rules:
//! - **Probe and set up first.** `V` gives the firmware (its bytes first
//!   erase a half command a lost link left in the board's line buffer,
//!   which would otherwise take `V` as its tail and might run:
//!   [`plotcode::control::ebb::ERASE_HALF_COMMAND`]; replies before the
//!   version line are discarded, and after an error among them `V` is
//!   asked again); then `SR,0` keeps the
//!   servo powered (a weighted pen must not drop during a pause), and on 3.x
//!   `CU,4,n` makes the motion FIFO [`FIFO_DEPTH`] commands deep and `CU,60`
//!   has `QG` latch a drop of the motor supply. The program's own first
//!   chunk enables the motors (`EM`, which zeroes the step counters: home)
//!   and sets the servo; a resumed run's prefix moves back without `EM`, so
//!   the counters keep meaning the same place, once `QE` says the motors
//!   are still on (off: the board was reset, its home is lost). After a
//!   person confirmed the carriage at home, `EM` makes it home again first.
//! - **The motor supply is watched.** `QC` at the set-up and with every
//!   poll, and 3.x's `QG` bit (a drop latched before the set-up matters
//!   only to a run going on where the last left the carriage): V+ under the least the motors run on means
//!   they lost their steps: `ES`, the pen lifted, the motors turned off (so
//!   a person can push the carriage home), and the run ends with a
//!   [`Reset`]: the position is lost.
//! - **Flow control is the board's delayed `OK`**: a command is answered once
//!   it is in the motion FIFO, which has room only when the command
//!   [`EbbRun::depth`] places ahead of it has started. At most [`WINDOW`] job
//!   commands are unanswered at a time; every reply is read in the order of
//!   what was sent (the queries among them).
//! - **Progress is the step counters, not bytes written.** Chunk `k` is
//!   confirmed when a command after it has started (everything of `k` ran
//!   to its end), or when every command of `k` has started and `QS` reads
//!   the counters at `k`'s end position. `QS` and `QG` are asked together
//!   every poll interval while work is in flight; `QG` saying the FIFO is
//!   empty and the motors still means every answered command has started.
//! - **Every wait has a deadline**: a query unanswered for the reply timeout
//!   is a timeout; job commands unanswered for the motion timeout a stall.
//! - **The PRG button pauses.** Its latch is read with every poll (`QG`):
//!   pressed, the run stops at the end of the stroke under way, as a
//!   person's pause ([`Outcome::ButtonPressed`]).
//! - A stop now ([`Stop::Now`]): `ES` (the FIFO is dropped, the motors stop
//!   where they are), then the pen lifted at once ([`Op::lift_now`]); the
//!   commands the FIFO held when `ES` came confirm nothing.

use super::machine::{Action, Machine, Mailbox, Timing};
use super::plan::Plan;
use super::{DeviceError, Excerpt, Garbled, Reset, Unanswered};
use super::{Outcome, Stop, StreamError, Written};
use plotcode::answer::ebb::{is_error, EStop, Line, MotorModes, Status, Steps, Voltages, MIN_MOTOR_POWER_ADC};
use plotcode::answer::{AnswerLine, ErrorCode};
use plotcode::control::ebb::Op;
use plotcode::control::Marker;
use plotcode::ebb::{Firmware, Motors};
use std::collections::VecDeque;
use std::time::Instant;

/// What follows an EBB chunk: nothing; the step counters confirm it.
pub(super) const MARKER: Marker = Marker { bytes: b"", chained: None };

/// Job commands written and not yet answered, at most: enough that the
/// next command is on the wire when the FIFO makes room (no stutter
/// between 2 ms moves), few enough that `ES` and the queries behind them
/// are answered within a few moves.
pub(super) const WINDOW: usize = 3;

/// Motion kept in flight, at most: commands beyond [`WINDOW`] are written
/// while those in flight take less than this to run. Short moves (a curve's
/// 2 ms segments) then stay ahead of the host's latency in answering an
/// `OK` (a scheduler's hiccup, a poll's queries), so the FIFO never runs
/// dry; `ES` waits behind at most this much motion plus one command.
pub(super) const LEAD: std::time::Duration = std::time::Duration::from_millis(50);

/// Job commands in flight at most, however short.
pub(super) const MAX_WINDOW: usize = 32;

/// The motion FIFO depth set on firmware 3.x (`CU,4,n`); 2.x holds one.
pub(super) const FIFO_DEPTH: u16 = 3;

/// How many times `V` is asked again after an error before the version,
/// by every session (run, locate, nickname, ping): an error there is a line
/// left from before, or one that took `V` as its tail (the erase before
/// `V` leaves none), and the board's buffer is empty after it.
pub(super) const MAX_VERSION_RETRIES: usize = 2;

/// Unrecognised replies tolerated in one run before the link counts as garbled.
const MAX_NOISE: usize = 8;

/// The `EM` that enables `program`'s motors (in its first chunk), which
/// makes where the carriage stands home; 1/16 steps when it has none.
pub(super) fn enable_motors(program: &plotcode::Program) -> Op {
    let first = program.chunks.first().map_or(&[][..], |c| &c.bytes[..]);
    let mode = first
        .split(|&b| b == b'\r' || b == b'\n')
        .find_map(|line| line.strip_prefix(b"EM,"))
        .and_then(|args| std::str::from_utf8(args).ok()?.split(',').next()?.trim().parse().ok())
        .unwrap_or(1);
    Op::EnableMotors(mode)
}

/// How long a command of the program runs on the board, seconds; infinite
/// when that depends on where the carriage is (`HM`) or the line does not
/// read as a command.
fn command_seconds(line: &[u8]) -> f64 {
    use plotcode::ebb::Command;
    let text = std::str::from_utf8(line).unwrap_or("").trim_end_matches(['\r', '\n']);
    match Command::parse(text) {
        Ok(Command::Sm(sm)) => f64::from(sm.ms) / 1000.0,
        Ok(Command::Xm { ms, .. }) => f64::from(ms) / 1000.0,
        Ok(Command::Pen { ms, .. }) => f64::from(ms) / 1000.0,
        Ok(Command::Lm(lm)) => lm.ticks().map_or(f64::INFINITY, |t| t as f64 / plotcode::ebb::lm::TICKS_PER_SECOND),
        Ok(Command::ServoConfig { .. } | Command::EnableMotors { .. } | Command::PenNumber(_)) => 0.0,
        Ok(Command::Home { .. }) | Err(_) => f64::INFINITY,
    }
}

/// A reply the board still owes, in the order it comes.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Owed {
    /// The `OK` of a job command ending at this offset of the plan.
    Job,
    /// A pen-up of the run's end.
    Lift,
    /// A query or set-up command; `data` once its data line came.
    Op { op: Op, data: bool },
}

impl Owed {
    fn name(self) -> &'static str {
        match self {
            Owed::Job | Owed::Lift => "",
            Owed::Op { op, .. } => op.name(),
        }
    }
}

/// Where a run has got.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Phase {
    /// `V` asked (or to ask).
    Probing,
    /// The set-up commands written, their `OK`s due.
    SettingUp,
    /// Streaming chunks.
    Streaming,
    /// `ES` and the pen lift written: waiting for their answers and a last
    /// reading of the counters.
    Aborting,
}

/// One run of chunks on an EiBotBoard.
#[derive(Debug)]
pub(super) struct EbbRun {
    plan: Plan,
    /// End offset in the plan's bytes of each command (CR-terminated).
    cmd_ends: Vec<usize>,
    /// How long each command runs, seconds (infinite when unknown: `HM`).
    cmd_seconds: Vec<f64>,
    /// Each chunk's end position in step counters.
    targets: Vec<Option<Motors>>,
    pen_up: Vec<u8>,
    timing: Timing,
    phase: Phase,
    firmware: Option<Firmware>,
    /// Job commands written.
    sent: usize,
    /// Job commands answered `OK`.
    answered: usize,
    /// Job commands known started (out of the FIFO).
    started: usize,
    owed: VecDeque<Owed>,
    /// Chunks of the plan confirmed.
    done: usize,
    /// The last `QS` reading.
    counters: Option<Motors>,
    /// A `QS` read after the board was seen idle with every command
    /// started: the counters where the run's last move ended. One read in
    /// the same poll as that status may have come while the move still ran.
    counters_at_rest: bool,
    /// The pen-up of the run's end written.
    lifted: bool,
    /// The run goes on from a chunk after an interruption: the motors must
    /// still be on.
    resumed: bool,
    /// The `EM` that makes where the carriage stands home, when a person
    /// confirmed it there.
    home_here: Option<Op>,
    /// The board lost its place mid-run: the run ends with it once stopped.
    lost: Option<Reset>,
    /// The PRG button was pressed: the run stops at the stroke's end.
    button: bool,
    noise: usize,
    /// `V` asked again after an error.
    version_retries: usize,
    /// When the oldest query still owed was sent.
    asked_at: Option<Instant>,
    last_poll: Option<Instant>,
    last_heard: Instant,
    /// The last job `OK` (or the first job command in flight).
    last_ok: Instant,
    mailbox: Mailbox,
}

impl EbbRun {
    /// A run of `plan`; `targets[i]` is chunk `plan.from + i`'s end in step
    /// counters; `resumed` when it goes on after an interruption, and
    /// `home_here` the `EM` to send first when a person confirmed the
    /// carriage at home.
    pub fn new(
        plan: Plan,
        targets: Vec<Option<Motors>>,
        pen_up: Vec<u8>,
        start: (bool, Option<Op>),
        timing: Timing,
        now: Instant,
    ) -> EbbRun {
        let (resumed, home_here) = start;
        let mut cmd_ends: Vec<usize> = plan.data.iter().enumerate().filter(|(_, &b)| b == b'\r').map(|(i, _)| i + 1).collect();
        if plan.data.last().is_some_and(|&b| b != b'\r') {
            cmd_ends.push(plan.data.len());
        }
        let cmd_seconds = cmd_ends
            .iter()
            .scan(0, |start, &end| {
                let line = &plan.data[std::mem::replace(start, end)..end];
                Some(command_seconds(line))
            })
            .collect();
        EbbRun {
            plan,
            cmd_ends,
            cmd_seconds,
            targets,
            pen_up,
            timing,
            phase: Phase::Probing,
            firmware: None,
            sent: 0,
            answered: 0,
            started: 0,
            owed: VecDeque::new(),
            done: 0,
            counters: None,
            counters_at_rest: false,
            lifted: false,
            resumed,
            home_here,
            lost: None,
            button: false,
            noise: 0,
            version_retries: 0,
            asked_at: None,
            last_poll: None,
            last_heard: now,
            last_ok: now,
            mailbox: Mailbox::default(),
        }
    }

    /// Commands the motion FIFO holds besides the one executing.
    fn depth(&self) -> usize {
        match self.firmware {
            Some(f) if f.is_3x() => usize::from(FIFO_DEPTH),
            _ => 1,
        }
    }

    fn send(&mut self, op: Op, now: Instant) {
        self.mailbox.actions.push(Action::Query(op.bytes()));
        self.owed.push_back(Owed::Op { op, data: false });
        self.asked_at.get_or_insert(now);
    }

    /// Job commands that may be written: up to the stop's limit.
    fn limit(&self) -> usize {
        if self.phase == Phase::Aborting {
            return self.sent;
        }
        let sent_bytes = self.sent.checked_sub(1).map_or(0, |i| self.cmd_ends[i]);
        let bytes = self.plan.limit(sent_bytes, self.mailbox.stopping());
        self.cmd_ends.partition_point(|&e| e <= bytes)
    }

    /// The board lost its place: stops it where it is (a run under way), or
    /// ends the run at once.
    fn lose(&mut self, reset: Reset, now: Instant) -> Result<(), StreamError> {
        tracing::warn!(%reset, "the EiBotBoard lost its place");
        if self.phase != Phase::Streaming || self.sent == 0 {
            return Err(StreamError::Reset(reset));
        }
        if self.lost.is_none() {
            self.abort(now);
            // The carriage free, for a person to push home.
            self.send(Op::DisableMotors, now);
            self.lost = Some(reset);
        }
        Ok(())
    }

    /// The run's end: the outcome, or the lost place once the board stopped.
    fn ended(&self) -> Result<Option<Outcome>, StreamError> {
        match (self.over(), &self.lost) {
            (Some(_), Some(reset)) => Err(StreamError::Reset(reset.clone())),
            (Some(Outcome::Stopped), None) if self.button => Ok(Some(Outcome::ButtonPressed)),
            (out, _) => Ok(out),
        }
    }

    fn in_flight(&self) -> usize {
        self.sent - self.answered
    }

    /// Confirms what the commands started and the counters say ran.
    fn confirm(&mut self) {
        let started_end = self.started.checked_sub(1).map_or(0, |i| self.cmd_ends[i]);
        // A command after chunk k has started: k ran to its end.
        let mut past = self.plan.ends.iter().take_while(|&&e| e < started_end).count();
        // Every command of chunk k started and the motors at its end.
        let whole = self.plan.ends.iter().take_while(|&&e| e <= started_end).count();
        if whole > past && self.counters.is_some() && self.targets.get(whole - 1).copied().flatten() == self.counters {
            past = whole;
        }
        if past > self.done {
            self.done = past;
            self.mailbox.actions.push(Action::Confirmed(self.plan.from + past));
        }
    }

    /// Whether another job command may be in flight: fewer than
    /// [`WINDOW`], or fewer than [`MAX_WINDOW`] taking less than [`LEAD`].
    fn room_in_flight(&self) -> bool {
        let n = self.in_flight();
        n < WINDOW || (n < MAX_WINDOW && self.cmd_seconds[self.answered..self.sent].iter().sum::<f64>() < LEAD.as_secs_f64())
    }

    fn write_commands(&mut self, now: Instant) {
        let limit = self.limit();
        while self.sent < limit && self.room_in_flight() {
            let start = self.sent.checked_sub(1).map_or(0, |i| self.cmd_ends[i]);
            let end = self.cmd_ends[self.sent];
            if self.in_flight() == 0 {
                self.last_ok = now;
            }
            let w = self.plan.ends.partition_point(|&e| e <= start);
            self.mailbox.actions.push(Action::Written(Written::Into(self.plan.from + w)));
            let payload = self.plan.payload(end) - self.plan.payload(start);
            self.mailbox.actions.push(Action::Write { bytes: self.plan.data[start..end].to_vec(), payload });
            if self.plan.ends.get(w) == Some(&end) {
                self.mailbox.actions.push(Action::Written(Written::Through(self.plan.from + w + 1)));
            }
            self.owed.push_back(Owed::Job);
            self.sent += 1;
            self.counters_at_rest = false;
        }
    }

    /// The run is over: everything it may write answered and started, and
    /// the pen lifted when the run stops short.
    fn over(&self) -> Option<Outcome> {
        let limit = self.limit();
        let short = limit < self.cmd_ends.len() || self.phase == Phase::Aborting;
        // Finished only once the counters were read at rest: a last chunk
        // still unconfirmed then was not drawn as planned (steps lost).
        let read = short || self.done == self.plan.ends.len() || self.counters_at_rest;
        let quiet = self.owed.is_empty() && self.sent == limit && self.started == self.sent && read;
        let lifted = self.lifted || !(short || self.plan.lift);
        (quiet && lifted && self.phase != Phase::Probing && self.phase != Phase::SettingUp).then_some(if short {
            Outcome::Stopped
        } else {
            Outcome::Finished
        })
    }

    fn data(&mut self, op: Op, data: &str) -> Result<(), StreamError> {
        let garbled = || StreamError::Garbled(Garbled::Noise { lines: 1, last: Excerpt::of(data) });
        match op {
            Op::Version => {
                let firmware = Firmware::from_version_answer(data).ok_or_else(garbled)?;
                tracing::info!(%firmware, "EiBotBoard");
                self.firmware = Some(firmware);
                let now = self.last_heard;
                self.send(Op::ServoPowerTimeout(0), now);
                if firmware.is_3x() {
                    self.send(Op::FifoDepth(FIFO_DEPTH), now);
                    self.send(Op::PowerThreshold(MIN_MOTOR_POWER_ADC), now);
                }
                self.send(Op::Voltages, now);
                self.send(Op::Status, now);
                match self.home_here {
                    Some(enable) => self.send(enable, now),
                    None if self.resumed => self.send(Op::MotorModes, now),
                    None => {}
                }
                self.phase = Phase::SettingUp;
            }
            Op::Steps => {
                self.counters = Some(Steps::parse(data).ok_or_else(garbled)?.0);
                self.counters_at_rest = self.started == self.sent;
            }
            Op::Voltages => {
                let v = Voltages::parse(data).ok_or_else(garbled)?;
                if !v.motor_power() {
                    self.lose(Reset::MotorPower { supply: Some(v.supply) }, self.last_heard)?;
                }
            }
            Op::MotorModes if !MotorModes::parse(data).ok_or_else(garbled)?.enabled() => {
                return Err(StreamError::Reset(Reset::MotorsOff));
            }
            Op::Status => {
                let status = Status::parse(data).ok_or_else(garbled)?;
                // At the set-up, a drop latched before matters only to a run
                // that goes on where the last one left the carriage.
                let earlier = self.phase == Phase::SettingUp && (self.home_here.is_some() || !self.resumed);
                if status.power_lost(self.firmware.is_some_and(Firmware::is_3x)) && !earlier {
                    self.lose(Reset::MotorPower { supply: None }, self.last_heard)?;
                }
                // The PRG button (latched, cleared by this reading): a
                // pause at the stroke's end, as a person's.
                if status.button_pressed() && self.phase == Phase::Streaming && !self.button {
                    tracing::info!("the EiBotBoard's button was pressed: pausing at the stroke's end");
                    self.button = true;
                    self.mailbox.ask(Stop::AfterStroke);
                }
                if status.idle() {
                    self.started = self.answered;
                }
                self.confirm();
            }
            Op::Stop => {
                let stop = EStop::parse(data).ok_or_else(garbled)?;
                tracing::info!(interrupted = stop.interrupted, "stopped now (ES)");
                // The FIFO is dropped: what it held never starts.
                self.answered = self.started;
                self.sent = self.started;
                self.confirm();
            }
            _ => {}
        }
        Ok(())
    }

    /// One more line that answers nothing: tolerated up to [`MAX_NOISE`].
    fn noisy(&mut self, text: &str) -> Result<Option<Outcome>, StreamError> {
        self.noise += 1;
        if self.noise > MAX_NOISE {
            return Err(StreamError::Garbled(Garbled::Noise { lines: self.noise, last: Excerpt::of(text) }));
        }
        Ok(None)
    }

    /// Stops the motors where they are and lifts the pen.
    fn abort(&mut self, now: Instant) {
        if self.phase != Phase::Streaming || self.sent == 0 {
            return;
        }
        self.send(Op::Stop, now);
        let lift = Op::lift_now(self.firmware.unwrap_or(plotcode::ebb::OLDEST_FIRMWARE));
        self.send(lift, now);
        self.lifted = true;
        self.phase = Phase::Aborting;
        self.last_poll = None;
    }
}

/// Errors: [`StreamError::Device`] for `!N Err`, [`StreamError::Garbled`]
/// for a version or reading that cannot be read or too much noise,
/// [`StreamError::Timeout`] for a query unanswered, [`StreamError::Stalled`]
/// for job commands unanswered for the motion timeout.
impl Machine for EbbRun {
    type Output = Outcome;

    fn answer(&mut self, line: &AnswerLine, now: Instant) -> Result<Option<Outcome>, StreamError> {
        self.last_heard = now;
        let Some(&owed) = self.owed.front() else {
            tracing::warn!(answer = %line.text, "EBB reply to nothing sent");
            return self.noisy(&line.text);
        };
        let Some(reply) = Line::parse(&line.text, owed.name()) else { return Ok(None) };
        if self.phase == Phase::Probing && !matches!(reply, Line::Data(text) if Firmware::from_version_answer(text).is_some()) {
            // Not the version: an answer left from before a reconnect. An
            // error may be a line that took `V` as its tail (the erase
            // before `V` leaves none): the board's buffer is empty, ask again.
            tracing::info!(answer = %line.text, "EBB reply before the version: discarded");
            if is_error(&line.text) && self.version_retries < MAX_VERSION_RETRIES {
                self.version_retries += 1;
                self.mailbox.actions.push(Action::Query(Op::Version.bytes()));
                self.asked_at = Some(now);
            }
            return self.noisy(&line.text);
        }
        match (owed, reply) {
            (_, Line::Error { number, message }) => {
                tracing::warn!(%message, "EBB error");
                return Err(StreamError::Device(DeviceError::new(ErrorCode::Ebb(number))));
            }
            (Owed::Job | Owed::Lift, Line::Ok) => {
                self.owed.pop_front();
                if owed == Owed::Job {
                    self.answered += 1;
                    self.last_ok = now;
                    self.started = self.started.max(self.answered.saturating_sub(self.depth()));
                    self.confirm();
                }
            }
            (Owed::Op { op, data }, Line::Data(text)) if op.answers_data() && !data => {
                if op.ends_with_ok() {
                    self.owed[0] = Owed::Op { op, data: true };
                } else {
                    self.owed.pop_front();
                }
                self.data(op, text)?;
            }
            (Owed::Op { .. }, Line::Ok) => {
                self.owed.pop_front();
            }
            (_, Line::Data(text)) => {
                tracing::warn!(answer = %text, "unexpected EBB reply");
                self.noise += 1;
                if self.noise > MAX_NOISE {
                    return Err(StreamError::Garbled(Garbled::Noise { lines: self.noise, last: Excerpt::of(text) }));
                }
            }
        }
        if !self.owed.iter().any(|o| matches!(o, Owed::Op { .. })) {
            self.asked_at = None;
        }
        if self.phase == Phase::SettingUp && self.owed.is_empty() {
            self.phase = Phase::Streaming;
        }
        self.ended()
    }

    fn poll(&mut self, now: Instant, _xoff: bool) -> Result<Option<Outcome>, StreamError> {
        // A query is answered after the job commands written before it,
        // whose OKs wait for room in the FIFO (the motion timeout's
        // business): its own wait starts once it is the next answer due.
        if let (Some(Owed::Op { op, .. }), Some(t)) = (self.owed.front(), self.asked_at) {
            if now.saturating_duration_since(t.max(self.last_heard)) > self.timing.reply_timeout {
                return Err(StreamError::Timeout(Unanswered::Ebb(*op)));
            }
        }
        match self.phase {
            Phase::Probing => {
                if self.owed.is_empty() {
                    self.send(Op::Version, now);
                }
                return Ok(None);
            }
            Phase::SettingUp => return Ok(None),
            Phase::Streaming => {
                self.write_commands(now);
                let limit = self.limit();
                if self.sent == limit && self.owed.is_empty() && self.started == self.sent && !self.lifted {
                    let short = limit < self.cmd_ends.len();
                    if short || self.plan.lift {
                        self.mailbox.actions.push(Action::Write { bytes: self.pen_up.clone(), payload: 0 });
                        self.owed.push_back(Owed::Lift);
                        self.lifted = true;
                    }
                }
            }
            Phase::Aborting => {}
        }
        if self.in_flight() > 0 && now.saturating_duration_since(self.last_ok) > self.timing.motion_timeout {
            return Err(StreamError::Stalled { unanswered: self.in_flight() });
        }
        if let Some(out) = self.ended()? {
            return Ok(Some(out));
        }
        let queried = self.owed.iter().any(|o| matches!(o, Owed::Op { .. }));
        let due = self.last_poll.is_none_or(|t| now.saturating_duration_since(t) >= self.timing.poll_interval);
        let unread = self.started == self.sent && !self.counters_at_rest && self.done < self.plan.ends.len();
        if !queried && due && (self.started < self.sent.max(1) || unread) {
            self.send(Op::Steps, now);
            self.send(Op::Status, now);
            self.send(Op::Voltages, now);
            self.last_poll = Some(now);
        }
        Ok(None)
    }

    fn deadline(&self, now: Instant) -> Instant {
        now + self.timing.poll_interval
    }

    fn mailbox(&mut self) -> &mut Mailbox {
        &mut self.mailbox
    }

    const TAKES_STOP: bool = true;

    fn abort(&mut self, now: Instant) {
        Self::abort(self, now);
    }
}

#[cfg(test)]
mod tests {
    use super::super::machine::testing::{self, timing, Exchange};
    use super::super::plan::Span;
    use super::super::{Restore, Stop};
    use super::*;
    use plotcode::Program;
    use std::time::Duration;

    const V281: &str = "EBBv13_and_above EB Firmware Version 2.8.1";
    const V302: &str = "EBBv13_and_above EB Firmware Version 3.0.2";

    /// Strokes `i` from (100 i, 0) to (100 i, 400) steps, the pen lifted and
    /// carried to the next one: four commands a chunk.
    fn program(strokes: usize) -> Program {
        testing::program("axidraw", "SC,4,20641\rEM,1,1\r", strokes, |i| {
            let back = if i == 0 { String::new() } else { "SM,100,-400,400\r".to_owned() };
            format!("{back}SM,100,100,100\rSP,0,100\rSM,100,400,-400\rSP,1,100\r")
        })
    }

    fn run(program: &Program) -> Exchange<EbbRun> {
        let plan = Plan::new(Span::all(program), MARKER, None);
        let targets = program.chunks.iter().map(|c| c.end.map(|e| Motors::nearest(e.pos))).collect();
        Exchange::new(EbbRun::new(plan, targets, program.pen_up.clone(), (false, None), timing(), Instant::now()))
    }

    fn commands(bytes: &[u8]) -> Vec<String> {
        String::from_utf8_lossy(bytes).split('\r').filter(|c| !c.is_empty()).map(str::to_owned).collect()
    }

    fn asked(x: &Exchange<EbbRun>) -> Vec<String> {
        x.asked.iter().flat_map(|q| commands(q)).collect()
    }

    /// Probes `V` and answers the set-up: the run is streaming after.
    fn start(x: &mut Exchange<EbbRun>, version: &str) {
        x.poll().unwrap();
        assert_eq!(asked(x), ["V"]);
        x.answer(version).unwrap();
        while x.machine.phase == Phase::SettingUp {
            x.answer("OK").unwrap();
        }
    }

    #[test]
    fn probes_the_version_keeps_the_servo_powered_and_deepens_the_fifo_on_3x() {
        let p = program(2);
        let mut x = run(&p);
        start(&mut x, V281);
        assert_eq!(asked(&x), ["V", "SR,0", "QC", "QG"], "2.x: no CU");
        assert_eq!(x.erased, 1, "a half command in the board erased before `V`");
        assert!(x.written.is_empty(), "nothing of the job before the set-up is answered");
        let mut x = run(&p);
        start(&mut x, V302);
        assert_eq!(asked(&x), ["V", "SR,0", &format!("CU,4,{FIFO_DEPTH}"), &format!("CU,60,{MIN_MOTOR_POWER_ADC}"), "QC", "QG"]);
        assert_eq!(x.machine.firmware, Some(Firmware::new(3, 0, 2)));
        assert_eq!(x.machine.depth(), usize::from(FIFO_DEPTH));
    }

    /// Issue 37: a reconnect after an unplug may find half a command in the
    /// board's line buffer, from before the unplug; it took the probe's `V`
    /// as its tail and the run failed with "!5 Need comma next, found 'V'".
    /// The refusal emptied the buffer: `V` is asked again. Other replies
    /// before the version (a half query's answer, in either syntax) are
    /// discarded.
    #[test]
    fn the_probe_asks_again_after_a_half_command_took_its_v() {
        let p = program(1);
        for (leftovers, again) in [
            (&["!5 Need comma next, found: 'V'"][..], true),
            (&["SM!5 Err: Need comma next, found: 'V'"], true),
            (&["OK"], false),
            (&["0,0", "OK"], false),
            (&[], false),
        ] {
            let mut x = run(&p);
            x.poll().unwrap();
            for line in leftovers {
                assert_eq!(x.answer(line).unwrap(), None, "{line}: discarded");
            }
            assert_eq!(x.asked.len(), 1 + usize::from(again), "{leftovers:?}: {:?}", asked(&x));
            x.answer(V281).unwrap();
            assert_eq!(x.machine.phase, Phase::SettingUp, "{leftovers:?}");
            assert_eq!(asked(&x)[usize::from(again)..], ["V", "SR,0", "QC", "QG"]);
        }
        // A board that only ever refuses is not asked for ever, and one
        // that only answers something else is not an EBB.
        let mut x = run(&p);
        x.poll().unwrap();
        let e = (0..=MAX_NOISE).map(|_| x.answer("!8 Err: Unknown command")).find_map(Result::err).expect("garbled");
        assert!(matches!(e, StreamError::Garbled(_)), "{e}");
        assert_eq!(x.asked.len(), 1 + MAX_VERSION_RETRIES);
    }

    #[test]
    fn a_window_of_commands_in_flight_each_ok_lets_one_more_go() {
        let p = program(3);
        let mut x = run(&p);
        start(&mut x, V281);
        x.poll().unwrap();
        assert_eq!(commands(&x.written), ["SC,4,20641", "EM,1,1", "SM,100,100,100"], "a window of {WINDOW}");
        x.poll().unwrap();
        assert_eq!(commands(&x.written).len(), WINDOW, "no more without an OK");
        x.answer("OK").unwrap();
        x.poll().unwrap();
        assert_eq!(commands(&x.written).len(), WINDOW + 1);
    }

    /// Issue 37 item 3: strokes of 2 ms moves stuttered (the bench
    /// `ebb_stutter`: the FIFO stood empty 19 ms on 2.8.1 and 58 ms on
    /// 3.0.2 over 1200 moves) because [`WINDOW`] commands in flight are
    /// only 6 ms of such moves: less than the host takes to answer an `OK`
    /// now and then. Short moves are kept in flight up to [`LEAD`] of
    /// motion (at most [`MAX_WINDOW`] commands); long ones still [`WINDOW`],
    /// so that `ES` is not held behind seconds of moves.
    #[test]
    fn short_moves_are_kept_in_flight_up_to_the_lead_and_long_ones_by_the_window() {
        let short = testing::program("axidraw", "EM,1,1\r", 1, |_| "SM,2,8,8\r".repeat(100));
        let mut x = run(&short);
        start(&mut x, V281);
        x.poll().unwrap();
        let in_flight = commands(&x.written).len();
        let lead_moves = (LEAD.as_secs_f64() / 0.002) as usize;
        assert_eq!(in_flight, MAX_WINDOW.min(1 + lead_moves), "EM, then 2 ms moves up to the lead");
        let long = testing::program("axidraw", "EM,1,1\r", 1, |_| "SM,500,800,800\r".repeat(10));
        let mut x = run(&long);
        start(&mut x, V281);
        x.poll().unwrap();
        assert_eq!(commands(&x.written).len(), WINDOW, "0.5 s moves: the window");
    }

    /// Ends the program: every command answered, the counters read at `at`
    /// with the board idle.
    fn answer_all(x: &mut Exchange<EbbRun>, at: Motors) -> Option<Outcome> {
        for _ in 0..200 {
            x.wait(Duration::from_millis(10));
            x.poll().unwrap();
            while x.machine.in_flight() > 0 || !x.machine.owed.is_empty() {
                let out = match x.machine.owed.front() {
                    Some(Owed::Op { op: Op::Steps, data: false }) => x.answer(&format!("{},{}", at.m1, at.m2)),
                    Some(Owed::Op { op: Op::Status, .. }) => x.answer("00"),
                    _ => x.answer("OK"),
                }
                .unwrap();
                if out.is_some() {
                    return out;
                }
            }
            if let Some(out) = x.poll().unwrap() {
                return Some(out);
            }
        }
        None
    }

    /// Answers the queries owed first (the counters far off, the board busy),
    /// then one job command's `OK`.
    fn ok(x: &mut Exchange<EbbRun>) {
        loop {
            match x.machine.owed.front() {
                Some(Owed::Op { op: Op::Steps, data: false }) => x.answer("99999,99999").unwrap(),
                Some(Owed::Op { op: Op::Status, .. }) => x.answer("03").unwrap(),
                Some(Owed::Op { .. }) => x.answer("OK").unwrap(),
                Some(_) => break,
                None => panic!("nothing owed"),
            };
        }
        x.answer("OK").unwrap();
    }

    #[test]
    fn oks_alone_confirm_only_chunks_a_later_command_has_started_after() {
        let p = program(3);
        let mut x = run(&p);
        start(&mut x, V281);
        x.poll().unwrap();
        // The whole first chunk answered: its last command may still wait
        // in the FIFO; nothing confirmed.
        let first = p.chunks[0].bytes.iter().filter(|&&b| b == b'\r').count();
        for _ in 0..first {
            ok(&mut x);
            x.poll().unwrap();
        }
        assert_eq!(x.confirmed, 0, "{first} OKs");
        // The next chunk's first command is in the FIFO, so the last of
        // chunk 0 has started; the counters are elsewhere: still nothing.
        ok(&mut x);
        assert_eq!(x.confirmed, 0);
        // One more OK: chunk 1's first command has started.
        ok(&mut x);
        assert_eq!(x.confirmed, 1);
    }

    #[test]
    fn the_counters_at_the_last_chunks_end_with_the_board_idle_finish_the_run() {
        let p = program(2);
        let end = Motors::nearest(p.chunks.last().unwrap().end.unwrap().pos);
        let mut x = run(&p);
        start(&mut x, V281);
        assert_eq!(answer_all(&mut x, end), Some(Outcome::Finished));
        assert_eq!(x.confirmed, p.chunks.len());
        // Counters elsewhere (the board lost steps): the last chunk is
        // not confirmed and the run does not claim it.
        let mut x = run(&p);
        start(&mut x, V281);
        let _ = answer_all(&mut x, Motors::new(end.m1 + 7, end.m2));
        assert_eq!(x.confirmed, p.chunks.len() - 1);
    }

    /// Found by the suite under load (8 tests at once on 2 cores): `QS` and
    /// `QG` are asked together, and the counters were read while the last
    /// move still ran, the status after it ended. The board idle and every
    /// command started, the run finished with the last chunk unconfirmed,
    /// and the job asked for that chunk again and again, a span every 20 ms
    /// for a minute. The counters are read again once the board is idle.
    #[test]
    fn counters_read_while_the_last_move_ran_are_read_again_once_the_board_is_idle() {
        let p = program(2);
        let end = Motors::nearest(p.chunks.last().unwrap().end.unwrap().pos);
        let short = Motors::new(end.m1 - 40, end.m2);
        let mut x = run(&p);
        start(&mut x, V281);
        let mut out = None;
        'run: for _ in 0..200 {
            x.wait(Duration::from_millis(10));
            if let Some(o) = x.poll().unwrap() {
                out = Some(o);
                break;
            }
            while x.machine.in_flight() > 0 || !x.machine.owed.is_empty() {
                // The motors reach the end only once every command started.
                let at = if x.machine.started == x.machine.sent { end } else { short };
                let reply = match x.machine.owed.front() {
                    Some(Owed::Op { op: Op::Steps, data: false }) => x.answer(&format!("{},{}", at.m1, at.m2)),
                    Some(Owed::Op { op: Op::Status, .. }) => x.answer("00"),
                    _ => x.answer("OK"),
                };
                if let Some(o) = reply.unwrap() {
                    out = Some(o);
                    break 'run;
                }
            }
        }
        assert_eq!(out, Some(Outcome::Finished));
        assert_eq!(x.confirmed, p.chunks.len(), "the last chunk confirmed before the run ends");
    }

    #[test]
    fn a_stop_now_sends_es_then_lifts_the_pen_at_once_and_the_fifo_confirms_nothing() {
        for (version, lift) in [(V281, "SP,1"), (V302, "SP,3")] {
            let p = program(4);
            let mut x = run(&p);
            start(&mut x, version);
            x.poll().unwrap();
            for _ in 0..8 {
                x.answer("OK").unwrap();
                x.poll().unwrap();
            }
            let confirmed = x.confirmed;
            let written = x.written.len();
            x.machine.stop(Stop::Now, x.now);
            x.poll().unwrap();
            let n = asked(&x).len();
            assert_eq!(asked(&x)[n - 2..], ["ES", lift], "{version}");
            assert_eq!(x.written.len(), written, "nothing more of the job");
            // The commands in flight are answered before ES is read.
            while x.machine.in_flight() > 0 {
                x.answer("OK").unwrap();
            }
            let es = if version == V281 { "1,0,0,40,-40" } else { "1" };
            assert_eq!(x.answer(es).unwrap(), None);
            assert_eq!(x.answer("OK").unwrap(), None);
            assert_eq!(x.answer("OK").unwrap(), Some(Outcome::Stopped), "{version}");
            assert!(x.confirmed >= confirmed && x.confirmed < p.chunks.len());
            // What the FIFO held at ES did not start: not confirmed.
            let started_end = x.machine.cmd_ends[x.machine.started - 1];
            assert!(x.machine.plan.ends[..x.confirmed].iter().all(|&e| e < started_end));
        }
    }

    /// A run of `program`'s chunks from 1 on, as after an interruption;
    /// `home_here` when a person confirmed the carriage at home.
    fn resumed(program: &Program, home_here: bool) -> Exchange<EbbRun> {
        let restore = if home_here { Restore::Confirmed } else { Restore::Nothing };
        let plan = Plan::new(Span { from: 1, resume: true, restore, ..Span::all(program) }, MARKER, None);
        let targets = program.chunks[1..].iter().map(|c| c.end.map(|e| Motors::nearest(e.pos))).collect();
        let start = (true, home_here.then(|| enable_motors(program)));
        Exchange::new(EbbRun::new(plan, targets, program.pen_up.clone(), start, timing(), Instant::now()))
    }

    #[test]
    fn a_resumed_run_needs_the_motors_on_unless_a_person_put_the_carriage_home() {
        let p = program(3);
        let mut x = resumed(&p, false);
        x.poll().unwrap();
        x.answer(V281).unwrap();
        assert_eq!(asked(&x), ["V", "SR,0", "QC", "QG", "QE"]);
        x.answer("OK").unwrap();
        x.answer("0394,0300").unwrap();
        x.answer("OK").unwrap();
        x.answer("30").unwrap();
        // Reset while unplugged: its counters count from another place.
        let e = x.answer("0,0").unwrap_err();
        assert!(matches!(e, StreamError::Reset(Reset::MotorsOff)), "{e}");
        // Confirmed home: the program's EM makes it home; no QE.
        let mut x = resumed(&p, true);
        start(&mut x, V281);
        assert_eq!(asked(&x), ["V", "SR,0", "QC", "QG", "EM,1,1"]);
        x.poll().unwrap();
        assert!(commands(&x.written)[0].starts_with("SC,4"), "then the resume prefix: {:?}", commands(&x.written));
    }

    /// 3.x latches a drop of V+ in `QG` until it is read: one latched
    /// since the last run is a lost place for a run that goes on from the
    /// counters, and nothing to one whose home a person just confirmed.
    #[test]
    fn a_drop_latched_before_a_resumed_run_loses_the_place_unless_home_was_confirmed() {
        let p = program(3);
        for (home_here, lost) in [(false, true), (true, false)] {
            let mut x = resumed(&p, home_here);
            x.poll().unwrap();
            x.answer(V302).unwrap();
            for answer in ["OK", "OK", "OK", "394,300", "OK"] {
                x.answer(answer).unwrap();
            }
            let r = x.answer("70");
            assert_eq!(matches!(r, Err(StreamError::Reset(Reset::MotorPower { supply: None }))), lost, "{home_here}: {r:?}");
        }
    }

    #[test]
    fn the_motor_supply_lost_mid_run_stops_the_board_frees_the_motors_and_loses_the_place() {
        for (version, lift, low) in [(V281, "SP,1", "0394,0012"), (V302, "SP,3", "394,12")] {
            let p = program(4);
            let mut x = run(&p);
            start(&mut x, version);
            x.poll().unwrap();
            for _ in 0..6 {
                x.answer("OK").unwrap();
                x.poll().unwrap();
            }
            let written = x.written.len();
            // The next poll's QC reads V+ low.
            x.wait(timing().poll_interval);
            x.poll().unwrap();
            while x.machine.in_flight() > 0 {
                x.answer("OK").unwrap();
            }
            assert_eq!(x.machine.owed.front(), Some(&Owed::Op { op: Op::Steps, data: false }));
            x.answer("0,0").unwrap();
            x.answer("OK").unwrap();
            x.answer("08").unwrap();
            assert_eq!(x.answer(low).unwrap(), None);
            let n = asked(&x).len();
            assert_eq!(asked(&x)[n - 3..], ["ES", lift, "EM,0,0"], "{version}");
            assert_eq!(x.written.len(), written, "nothing more of the job");
            let mut end = None;
            while !x.machine.owed.is_empty() {
                let r = match x.machine.owed.front() {
                    Some(Owed::Op { op: Op::Stop, data: false }) => x.answer(if version == V281 { "1,0,0,40,-40" } else { "1" }),
                    _ => x.answer("OK"),
                };
                if let Err(e) = r {
                    end = Some(e);
                    break;
                }
            }
            let e = end.expect("the run ends with the lost place");
            assert!(matches!(e, StreamError::Reset(Reset::MotorPower { supply: Some(12) })), "{version}: {e}");
        }
    }

    #[test]
    fn an_error_reply_is_a_device_error_and_silence_a_timeout() {
        let p = program(1);
        let mut x = run(&p);
        start(&mut x, V281);
        x.poll().unwrap();
        let e = x.answer("!8 Err: Unknown command 'XX:'").unwrap_err();
        assert!(e.to_string().contains("EBB error !8"), "{e}");
        let mut x = run(&p);
        x.poll().unwrap();
        let e = x.run_out(Duration::from_secs(60), Duration::from_millis(100)).unwrap_err();
        assert!(matches!(e, StreamError::Timeout(Unanswered::Ebb(Op::Version))), "{e}");
    }

    /// The PRG button's latch in a poll's `QG`: nothing more is written
    /// past the chunk under way, and once it is drawn the run ends
    /// [`Outcome::ButtonPressed`].
    #[test]
    fn the_button_stops_the_run_at_the_strokes_end() {
        let p = program(4);
        let mut x = run(&p);
        start(&mut x, V281);
        x.poll().unwrap();
        // The first poll's queries, behind the first commands: the button
        // pressed, the board busy.
        loop {
            match x.machine.owed.front() {
                Some(Owed::Op { op: Op::Steps, data: false }) => x.answer("0,0"),
                Some(Owed::Op { op: Op::Voltages, data: false }) => x.answer("0394,0300"),
                Some(Owed::Op { op: Op::Status, .. }) => break,
                _ => x.answer("OK"),
            }
            .unwrap();
        }
        x.answer("28").unwrap();
        assert_eq!(x.machine.mailbox.stop, Stop::AfterStroke);
        let first = p.chunks[0].bytes.iter().filter(|&&b| b == b'\r').count();
        let end = Motors::nearest(p.chunks[0].end.unwrap().pos);
        assert_eq!(answer_all(&mut x, end), Some(Outcome::ButtonPressed));
        let written = commands(&x.written);
        assert_eq!(written.len(), first + 1, "the first chunk, then only the pen lifted: {written:?}");
        assert_eq!(written[first], commands(&p.pen_up)[0]);
        assert_eq!(x.confirmed, 1);
    }

    /// A long move (an `HM` back to a far chunk's start) holds the OKs of
    /// the commands behind it, and the queries behind those: they are not
    /// late until they are the next answer due (before: "no answer to EBB
    /// QS" after the reply timeout, and the job paused offline).
    #[test]
    fn queries_behind_a_long_move_wait_for_it() {
        let p = program(3);
        let mut x = run(&p);
        start(&mut x, V281);
        x.poll().unwrap();
        x.wait(timing().poll_interval);
        x.poll().unwrap();
        assert_eq!(asked(&x)[asked(&x).len() - 3..], ["QS", "QG", "QC"]);
        x.wait(timing().reply_timeout * 3);
        assert!(x.poll().is_ok(), "the job commands' OKs are due first");
        while x.machine.in_flight() > 0 {
            x.answer("OK").unwrap();
        }
        x.wait(timing().reply_timeout * 2);
        let e = x.poll().unwrap_err();
        assert!(matches!(e, StreamError::Timeout(Unanswered::Ebb(Op::Steps))), "{e}");
    }

    #[test]
    fn commands_unanswered_for_the_motion_timeout_are_a_stall() {
        let p = program(2);
        let mut x = run(&p);
        start(&mut x, V281);
        let mut err = None;
        for _ in 0..400 {
            x.wait(Duration::from_secs(1));
            if let Err(e) = x.poll() {
                err = Some(e);
                break;
            }
            // The board answers queries but no job command.
            x.machine.owed.retain(|o| *o == Owed::Job);
            x.machine.asked_at = None;
        }
        assert!(matches!(err, Some(StreamError::Stalled { unanswered: WINDOW })), "{err:?}");
    }
}
