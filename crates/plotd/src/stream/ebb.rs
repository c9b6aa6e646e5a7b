//! An EiBotBoard's (AxiDraw's) handshake as a state machine that does no I/O.
//!
//! [`EbbRun`] takes the board's reply lines and the time, and gives back
//! [`Action`]s in order, like [`super::grbl::GrblRun`]. The streamer feeds it
//! from the port; unit tests feed it scripted replies on a hand-moved clock.
//!
//! Rules:
//! - **Probe and set up first.** `V` gives the firmware; then `SR,0` keeps the
//!   servo powered (a weighted pen must not drop during a pause), and on 3.x
//!   `CU,4,n` makes the motion FIFO [`FIFO_DEPTH`] commands deep. The
//!   program's own first chunk enables the motors (`EM`, which zeroes the
//!   step counters: home) and sets the servo; a resumed run's prefix moves
//!   back without `EM`, so the counters keep meaning the same place.
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
//! - A stop now ([`Stop::Now`]): `ES` (the FIFO is dropped, the motors stop
//!   where they are), then the pen lifted at once ([`Op::lift_now`]); the
//!   commands the FIFO held when `ES` came confirm nothing.

use super::machine::{Action, Machine, Mailbox, Timing};
use super::plan::Plan;
use super::{DeviceError, Excerpt, Garbled, Unanswered};
use super::{Outcome, StreamError, Written};
use plotcode::answer::ebb::{EStop, Line, Status, Steps};
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

/// The motion FIFO depth set on firmware 3.x (`CU,4,n`); 2.x holds one.
pub(super) const FIFO_DEPTH: u16 = 3;

/// Unrecognised replies tolerated in one run before the link counts as garbled.
const MAX_NOISE: usize = 8;

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
    /// The pen-up of the run's end written.
    lifted: bool,
    noise: usize,
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
    /// counters.
    pub fn new(plan: Plan, targets: Vec<Option<Motors>>, pen_up: Vec<u8>, timing: Timing, now: Instant) -> EbbRun {
        let mut cmd_ends: Vec<usize> = plan.data.iter().enumerate().filter(|(_, &b)| b == b'\r').map(|(i, _)| i + 1).collect();
        if plan.data.last().is_some_and(|&b| b != b'\r') {
            cmd_ends.push(plan.data.len());
        }
        EbbRun {
            plan,
            cmd_ends,
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
            lifted: false,
            noise: 0,
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

    fn write_commands(&mut self, now: Instant) {
        let limit = self.limit();
        while self.sent < limit && self.in_flight() < WINDOW {
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
        }
    }

    /// The run is over: everything it may write answered and started, and
    /// the pen lifted when the run stops short.
    fn over(&self) -> Option<Outcome> {
        let limit = self.limit();
        let short = limit < self.cmd_ends.len() || self.phase == Phase::Aborting;
        let quiet = self.owed.is_empty() && self.sent == limit && self.started == self.sent;
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
                self.send(Op::ServoPowerTimeout(0), self.last_heard);
                if firmware.is_3x() {
                    self.send(Op::FifoDepth(FIFO_DEPTH), self.last_heard);
                }
                self.phase = Phase::SettingUp;
            }
            Op::Steps => self.counters = Some(Steps::parse(data).ok_or_else(garbled)?.0),
            Op::Status => {
                let status = Status::parse(data).ok_or_else(garbled)?;
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
            self.noise += 1;
            return if self.noise > MAX_NOISE {
                Err(StreamError::Garbled(Garbled::Noise { lines: self.noise, last: Excerpt::of(&line.text) }))
            } else {
                Ok(None)
            };
        };
        let Some(reply) = Line::parse(&line.text, owed.name()) else { return Ok(None) };
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
        Ok(self.over())
    }

    fn poll(&mut self, now: Instant, _xoff: bool) -> Result<Option<Outcome>, StreamError> {
        if self.asked_at.is_some_and(|t| now.saturating_duration_since(t) > self.timing.reply_timeout && self.last_heard < t) {
            let op = self.owed.iter().find_map(|o| if let Owed::Op { op, .. } = o { Some(*op) } else { None });
            return Err(StreamError::Timeout(Unanswered::Ebb(op.unwrap_or(Op::Version))));
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
        if let Some(out) = self.over() {
            return Ok(Some(out));
        }
        let queried = self.owed.iter().any(|o| matches!(o, Owed::Op { .. }));
        let due = self.last_poll.is_none_or(|t| now.saturating_duration_since(t) >= self.timing.poll_interval);
        if !queried && due && self.started < self.sent.max(1) {
            self.send(Op::Steps, now);
            self.send(Op::Status, now);
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
    use super::super::Stop;
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
        Exchange::new(EbbRun::new(plan, targets, program.pen_up.clone(), timing(), Instant::now()))
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
        assert_eq!(asked(&x), ["V", "SR,0"], "2.x: no CU");
        assert!(x.written.is_empty(), "nothing of the job before the set-up is answered");
        let mut x = run(&p);
        start(&mut x, V302);
        assert_eq!(asked(&x), ["V", "SR,0", &format!("CU,4,{FIFO_DEPTH}")]);
        assert_eq!(x.machine.firmware, Some(Firmware::new(3, 0, 2)));
        assert_eq!(x.machine.depth(), usize::from(FIFO_DEPTH));
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
