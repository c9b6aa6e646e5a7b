//! GRBL's character-counting handshake as a state machine that does no I/O.
//!
//! [`GrblRun`] takes the board's answer lines and the time, and gives back
//! [`Action`]s in order: bytes to write (job lines, the marker after each
//! chunk, a dwell: [`plotcode::control::grbl::MARKER`], the pen-up lines of a stop), status
//! queries, written marks and
//! confirmed checkpoints; [`GrblRun::deadline`] says when to look again if
//! nothing arrives. The streamer feeds it from the port; unit tests feed it
//! scripted answers on a hand-moved clock.
//!
//! Rules:
//! - Lines go out while they fit in the receive buffer beside the lines not yet
//!   answered (one `ok` or `error:N` per line, in order).
//! - A chunk is confirmed by the `ok` to the dwell after it: GRBL answers a
//!   dwell only once the planner has drained. The next chunk's lines go out
//!   once every line before them is answered, so lines the board lost
//!   stall the run inside their own chunk: no later `ok` is taken for
//!   theirs, and the resume draws that chunk again.
//! - **Every wait has a deadline.** No answer to a status poll within the
//!   reply timeout is a timeout; lines in flight and no `ok` for the motion
//!   timeout, or the board reporting `Idle` with lines in flight and nothing
//!   answered for [`Timing::stall_after`], is a stall
//!   ([`StreamError::Stalled`]): the board lost lines, and the run cannot end
//!   by itself. The caller resyncs and resumes from the confirmed chunk.
//! - Unrecognised lines may be garbled `ok`s: when the board is `Idle` with
//!   lines unanswered, that many are taken as answered.
//! - A stop now ([`Stop::Now`]): feed hold (`!`), and once the board reports
//!   the hold complete (`Hold:0`: the tool stopped, so a reset keeps the
//!   position and raises no alarm), soft reset (0x18), which drops every
//!   line it holds. After its banner, a status report gives the position
//!   the board kept; a board in alarm (the hold did not complete in time)
//!   is unlocked ([`Op::Unlock`]); then the pen-up lines. **The `ok`s before the
//!   banner confirm chunks the board ran; the lines the reset dropped
//!   confirm nothing.**

use super::machine::{Action, Machine, Mailbox, Timing};
use super::plan::Plan;
use super::{Alarm, DeviceError, ErrorAt, Excerpt, Garbled, Reset, Unanswered};
use super::{Outcome, StreamError, Written};
use plotcode::answer::{AnswerLine, ErrorCode, GrblAnswer, GrblState};
use plotcode::control::grbl::Op;
use std::collections::VecDeque;
use std::time::Instant;

/// Unrecognised answers tolerated in one run before the link counts as garbled.
const MAX_NOISE: usize = 8;

/// Where a stop now ([`Stop::Now`]) has got.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Abort {
    /// `!` sent at this time: waiting for the hold to complete.
    Holding(Instant),
    /// Soft reset sent at this time: waiting for the banner.
    Resetting(Instant),
    /// Reset: waiting for a status report saying where the tool is and
    /// whether the board is locked.
    Recovering,
    /// The pen-up lines (after the unlock when locked) are written.
    Lifting,
}

/// One run of chunks on a GRBL board.
#[derive(Debug)]
pub(super) struct GrblRun {
    plan: Plan,
    /// Line ends in the plan's bytes.
    line_ends: Vec<usize>,
    /// The board's receive buffer.
    rx: usize,
    /// The job's pen-up lines, written after a stop.
    pen_up: Vec<u8>,
    timing: Timing,
    /// Bytes of the plan written.
    sent: usize,
    next_line: usize,
    /// Lines written and not yet answered: (end offset in plan, length).
    inflight: VecDeque<(usize, usize)>,
    inflight_bytes: usize,
    /// Chunks of the plan confirmed.
    done: usize,
    /// Pen-up lines written after a stop whose answers are still due;
    /// `None` before they are written.
    tail: Option<usize>,
    /// Unrecognised answers since the last resync: maybe garbled `ok`s.
    noise: usize,
    /// When the unanswered status poll was sent.
    status_sent: Option<Instant>,
    last_poll: Option<Instant>,
    last_heard: Instant,
    /// The last `ok` (or the start): progress.
    last_ok: Instant,
    /// The first `Idle` report with lines in flight since the last answer.
    idle_since: Option<Instant>,
    /// Integral of bytes in the receive buffer over time, and the time.
    fill: (f64, f64),
    /// A stop now under way.
    abort: Option<Abort>,
    last_change: Instant,
    /// What the run decided, and whether a stop was asked for.
    mailbox: Mailbox,
}

impl GrblRun {
    /// A run of `plan` against a receive buffer of `rx` bytes.
    pub fn new(plan: Plan, rx: usize, pen_up: Vec<u8>, timing: Timing, now: Instant) -> GrblRun {
        let mut line_ends: Vec<usize> = plan.data.iter().enumerate().filter(|(_, &b)| b == b'\n').map(|(i, _)| i + 1).collect();
        if plan.data.last().is_some_and(|&b| b != b'\n') {
            line_ends.push(plan.data.len());
        }
        GrblRun {
            plan,
            line_ends,
            rx,
            pen_up,
            timing,
            sent: 0,
            next_line: 0,
            inflight: VecDeque::new(),
            inflight_bytes: 0,
            done: 0,
            tail: None,
            noise: 0,
            status_sent: None,
            last_poll: None,
            last_heard: now,
            last_ok: now,
            idle_since: None,
            fill: (0.0, 0.0),
            abort: None,
            last_change: now,
            mailbox: Mailbox::default(),
        }
    }

    /// The receive buffer's average fill: (byte-seconds, seconds).
    pub fn fill(&self) -> (f64, f64) {
        self.fill
    }

    fn account_fill(&mut self, now: Instant) {
        let dt = now.saturating_duration_since(self.last_change).as_secs_f64();
        self.fill.0 += self.inflight_bytes as f64 * dt;
        self.fill.1 += dt;
        self.last_change = now;
    }

    fn limit(&self) -> usize {
        self.plan.limit(self.sent, self.mailbox.stopping())
    }

    /// An answer while stopping now, when it is one the stop decides on
    /// (`ok` and `error:N` are taken as always).
    fn aborting(&mut self, answer: &GrblAnswer, now: Instant) -> Option<Result<Option<Outcome>, StreamError>> {
        let abort = self.abort?;
        if let GrblAnswer::Status(_) = answer {
            self.status_sent = None;
        }
        match (abort, answer) {
            (_, GrblAnswer::Alarm(n)) => {
                // A reset before the hold completed: the status report that
                // follows says the board is locked, and it is unlocked.
                tracing::warn!(alarm = n, "GRBL alarm while stopping now");
            }
            (Abort::Holding(_), GrblAnswer::Status(st)) => {
                if matches!((st.state, st.sub), (GrblState::Hold, Some(0)) | (GrblState::Idle | GrblState::Alarm, _)) {
                    self.reset(now);
                }
            }
            (Abort::Resetting(_), GrblAnswer::Welcome(_)) => {
                // Every line the board held is gone, unanswered.
                self.account_fill(now);
                self.inflight.clear();
                self.inflight_bytes = 0;
                self.noise = 0;
                self.abort = Some(Abort::Recovering);
                self.last_poll = None;
            }
            (Abort::Recovering, GrblAnswer::Status(st)) => {
                tracing::info!(position = ?st.pos, state = ?st.state, "stopped now; the board keeps its position");
                let mut bytes = Vec::new();
                if st.state == GrblState::Alarm {
                    bytes.extend_from_slice(Op::Unlock.bytes());
                }
                bytes.extend_from_slice(&self.pen_up);
                self.tail = Some(bytes.split_inclusive(|&b| b == b'\n').count());
                self.mailbox.actions.push(Action::Write { bytes, payload: 0 });
                self.abort = Some(Abort::Lifting);
            }
            (Abort::Lifting, GrblAnswer::Status(st)) => {
                if st.state == GrblState::Idle && self.tail == Some(0) {
                    return Some(Ok(Some(Outcome::Stopped)));
                }
            }
            (_, GrblAnswer::Status(_)) => {}
            _ => return None,
        }
        Some(Ok(None))
    }

    fn reset(&mut self, now: Instant) {
        self.mailbox.actions.push(Action::Query(Op::SoftReset.bytes().to_vec()));
        self.abort = Some(Abort::Resetting(now));
    }

    /// Polls while stopping now: the status, often, and the stop's deadlines.
    fn poll_aborting(&mut self, abort: Abort, now: Instant) -> Result<(), StreamError> {
        match abort {
            // A hold that does not complete (a board that ignores `!`): reset all the same.
            Abort::Holding(t) if now.saturating_duration_since(t) >= self.timing.stall_after => self.reset(now),
            Abort::Resetting(t) if now.saturating_duration_since(t) > self.timing.reply_timeout => {
                return Err(StreamError::Timeout(Unanswered::ResetBanner));
            }
            _ => {}
        }
        if self.status_sent.is_some_and(|t| now.saturating_duration_since(t) > self.timing.reply_timeout && self.last_heard < t) {
            return Err(StreamError::Timeout(Unanswered::Grbl(Op::Status)));
        }
        if self.last_poll.is_none_or(|t| now.saturating_duration_since(t) >= self.timing.poll_interval * 5) {
            self.mailbox.actions.push(Action::Query(Op::Status.bytes().to_vec()));
            self.last_poll = Some(now);
            self.status_sent.get_or_insert(now);
        }
        Ok(())
    }

    fn confirm_through(&mut self, end: usize) {
        let past = self.plan.ends.iter().take_while(|&&e| e <= end).count();
        if past > self.done {
            self.done = past;
            self.mailbox.actions.push(Action::Confirmed(self.plan.from + past));
        }
    }

    /// Stops the pen where it is ([`Stop::Now`]): what the device holds is
    /// dropped, the pen lifted, and the run ends [`Outcome::Stopped`] once
    /// every chunk the device ran is confirmed.
    fn abort(&mut self, now: Instant) {
        // Nothing written yet, or the pen-up after a stop already on its
        // way: the stop's limit ends the run as soon.
        if self.sent == 0 || self.tail.is_some() {
            return;
        }
        self.mailbox.actions.push(Action::Query(Op::FeedHold.bytes().to_vec()));
        self.abort = Some(Abort::Holding(now));
        self.last_poll = None;
    }
}

/// Errors: [`StreamError::Device`] for `error:N`, [`StreamError::Alarm`]
/// for `ALARM:N` or a status in alarm,
/// [`StreamError::Reset`] for the welcome banner (the board reset or was
/// power-cycled), [`StreamError::Garbled`] for too much noise,
/// [`StreamError::Timeout`] when a status poll goes unanswered,
/// [`StreamError::Stalled`] when lines in flight get no `ok` for the motion
/// timeout or the board idles with them.
impl Machine for GrblRun {
    type Output = Outcome;

    fn answer(&mut self, line: &AnswerLine, now: Instant) -> Result<Option<Outcome>, StreamError> {
        let line = line.text.as_str();
        self.last_heard = now;
        let answer = GrblAnswer::parse(line);
        if let Some(r) = self.aborting(&answer, now) {
            return r;
        }
        match answer {
            answer @ (GrblAnswer::Ok | GrblAnswer::Error(_)) => {
                self.idle_since = None;
                let Some((end, len)) = self.inflight.pop_front() else {
                    // Answers to our pen-up lines after a stop, or stray.
                    if let Some(tail) = self.tail.as_mut() {
                        *tail = tail.saturating_sub(1);
                    }
                    return match answer {
                        GrblAnswer::Error(n) => Err(StreamError::Device(DeviceError::new(ErrorCode::Grbl(n)))),
                        _ => Ok(None),
                    };
                };
                self.account_fill(now);
                self.inflight_bytes -= len;
                if let GrblAnswer::Error(n) = answer {
                    return Err(StreamError::Device(DeviceError::at(ErrorCode::Grbl(n), ErrorAt::RunByte(end))));
                }
                self.last_ok = now;
                self.confirm_through(end);
                Ok(None)
            }
            // The board stopped its motors at once: its place is lost.
            GrblAnswer::Alarm(n) => Err(StreamError::Alarm(Alarm::Raised(n))),
            GrblAnswer::Welcome(banner) => Err(StreamError::Reset(Reset::Banner(Excerpt::of(&banner)))),
            GrblAnswer::Status(status) => {
                self.status_sent = None;
                match status.state {
                    GrblState::Alarm => return Err(StreamError::Alarm(Alarm::Unexplained)),
                    GrblState::Idle if !self.inflight.is_empty() && self.noise > 0 => {
                        // Idle with lines unanswered: the noise was their `ok`s.
                        while self.noise > 0 {
                            self.noise -= 1;
                            if let Some((end, len)) = self.inflight.pop_front() {
                                self.account_fill(now);
                                self.inflight_bytes -= len;
                                self.last_ok = now;
                                self.confirm_through(end);
                            }
                        }
                    }
                    GrblState::Idle if !self.inflight.is_empty() => {
                        let since = *self.idle_since.get_or_insert(now);
                        if now.saturating_duration_since(since) >= self.timing.stall_after {
                            return Err(StreamError::Stalled { unanswered: self.inflight.len() });
                        }
                    }
                    _ => self.idle_since = None,
                }
                let limit = self.limit();
                let tail_done = self.tail.is_none_or(|t| t == 0);
                if status.state == GrblState::Idle && self.sent == limit && self.inflight.is_empty() && tail_done {
                    self.account_fill(now);
                    return Ok(Some(if limit < self.plan.data.len() { Outcome::Stopped } else { Outcome::Finished }));
                }
                Ok(None)
            }
            GrblAnswer::Other(text) => {
                tracing::warn!(answer = %text, "unrecognised GRBL answer");
                self.noise += 1;
                if self.noise > MAX_NOISE {
                    return Err(StreamError::Garbled(Garbled::Noise { lines: self.noise, last: Excerpt::of(&text) }));
                }
                Ok(None)
            }
            // `[MSG:...]`, `[GC:...]` and the like carry nothing a run needs.
            GrblAnswer::Options { .. } | GrblAnswer::Version(_) | GrblAnswer::Modal(_) | GrblAnswer::Message(_) => Ok(None),
        }
    }

    fn poll(&mut self, now: Instant, _xoff: bool) -> Result<Option<Outcome>, StreamError> {
        if let Some(abort) = self.abort {
            return self.poll_aborting(abort, now).map(|()| None);
        }
        let limit = self.limit();
        if self.sent == limit && self.inflight.is_empty() && (limit < self.plan.data.len() || self.plan.lift) && self.tail.is_none() {
            // Stop: every chunk written is confirmed; lift the pen.
            let lines = self.pen_up.split_inclusive(|&b| b == b'\n').count();
            self.mailbox.actions.push(Action::Write { bytes: self.pen_up.clone(), payload: 0 });
            self.tail = Some(lines);
        }
        // Every whole line of one chunk that fits goes in one write (so the
        // written mark is exact): the buffer is topped up as soon as an `ok`
        // makes room.
        loop {
            let start = self.sent;
            let w = self.plan.ends.partition_point(|&e| e <= self.sent);
            let chunk_end = self.plan.ends.get(w).map_or(limit, |&e| e.min(limit));
            let was_empty = self.inflight.is_empty();
            if !was_empty && w > 0 && self.plan.ends.get(w - 1) == Some(&self.sent) {
                // A chunk goes out once every line before it is answered:
                // lines the board lost would shift the `ok`s of the next
                // chunk's lines onto them, confirming what was never drawn.
                // The chunk's dwell holds the board's parser until its
                // motion ends anyway, so this costs one line's trip.
                break;
            }
            let mut fitted = false;
            while let Some(&end) =
                self.line_ends.get(self.next_line).filter(|&&e| e <= chunk_end && self.inflight_bytes + (e - self.sent) <= self.rx)
            {
                if !fitted {
                    self.account_fill(now);
                    fitted = true;
                }
                self.inflight.push_back((end, end - self.sent));
                self.inflight_bytes += end - self.sent;
                self.sent = end;
                self.next_line += 1;
            }
            if self.sent == start {
                break;
            }
            if was_empty {
                // Progress is timed from the first line in flight.
                self.last_ok = now;
            }
            self.mailbox.actions.push(Action::Written(Written::Into(self.plan.from + w)));
            let payload = self.plan.payload(self.sent) - self.plan.payload(start);
            self.mailbox.actions.push(Action::Write { bytes: self.plan.data[start..self.sent].to_vec(), payload });
            if self.plan.ends.get(w) == Some(&self.sent) {
                self.mailbox.actions.push(Action::Written(Written::Through(self.plan.from + w + 1)));
            }
        }
        if !self.inflight.is_empty() && now.saturating_duration_since(self.last_ok) > self.timing.motion_timeout {
            return Err(StreamError::Stalled { unanswered: self.inflight.len() });
        }
        // Poll status, so that silence is noticed and the end (Idle) is seen.
        if self.status_sent.is_some_and(|t| now.saturating_duration_since(t) > self.timing.reply_timeout && self.last_heard < t) {
            return Err(StreamError::Timeout(Unanswered::Grbl(Op::Status)));
        }
        let poll_due = self.last_poll.is_none_or(|t| now.saturating_duration_since(t) >= self.timing.reply_timeout / 4);
        let quiet = now.saturating_duration_since(self.last_heard) > self.timing.poll_interval * 5;
        if poll_due && (self.inflight.is_empty() || quiet) {
            self.mailbox.actions.push(Action::Query(Op::Status.bytes().to_vec()));
            self.last_poll = Some(now);
            self.status_sent.get_or_insert(now);
        }
        Ok(None)
    }

    fn deadline(&self, now: Instant) -> Instant {
        let wait = if self.inflight.is_empty() || self.abort.is_some() { self.timing.poll_interval } else { self.timing.reply_timeout / 4 };
        now + wait
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
    use super::super::machine::testing::{self, timing};
    use super::super::plan::Span;
    use super::super::Stop;
    use super::*;
    use plotcode::answer::Terminator;
    use plotcode::control::grbl;
    use plotcode::Program;
    use std::time::Duration;

    fn program(strokes: usize) -> Program {
        testing::program(
            "grbl-servo",
            "G21 G90
",
            strokes,
            |i| {
                format!(
                    "G0 X{i} Y0
M3 S1000
G1 X{i} Y10 F3000
M5
"
                )
            },
        )
    }

    /// A run, a clock moved by hand, and what the board has been sent.
    struct Bench {
        run: GrblRun,
        now: Instant,
        lines: Vec<String>,
        queries: usize,
        /// Every query, in order.
        asked: Vec<Vec<u8>>,
        confirmed: usize,
    }

    impl Bench {
        fn new(strokes: usize, rx: usize) -> Bench {
            let p = program(strokes);
            let plan = Plan::new(Span::all(&p), grbl::MARKER, None);
            let now = Instant::now();
            Bench {
                run: GrblRun::new(plan, rx, p.pen_up.clone(), timing(), now),
                now,
                lines: Vec::new(),
                queries: 0,
                asked: Vec::new(),
                confirmed: 0,
            }
        }
        fn drain(&mut self) {
            for a in self.run.take_actions() {
                match a {
                    Action::Write { bytes, .. } => {
                        self.lines.extend(String::from_utf8(bytes).unwrap().lines().map(str::to_owned));
                    }
                    Action::Query(q) => {
                        self.queries += 1;
                        self.asked.push(q);
                    }
                    Action::Confirmed(k) => self.confirmed = k,
                    Action::Written(_) | Action::Held(_) => {}
                }
            }
        }
        fn poll(&mut self) -> Result<(), StreamError> {
            let r = self.run.poll(self.now, false);
            self.drain();
            r.map(|_| ())
        }
        fn answer(&mut self, line: &str) -> Result<Option<Outcome>, StreamError> {
            let r = self.run.answer(&AnswerLine { text: line.into(), terminator: Terminator::Lf }, self.now);
            self.drain();
            r
        }
        fn wait(&mut self, d: Duration) {
            self.now += d;
        }
    }

    #[test]
    fn lines_fit_the_buffer_and_oks_confirm_chunks() {
        let mut b = Bench::new(3, 64);
        b.poll().unwrap();
        let sent: usize = b.lines.iter().map(|l| l.len() + 1).sum();
        assert!(sent <= 64 && sent > 32, "{sent} bytes in a 64-byte buffer");
        // Answer everything written, line by line, until the end.
        let mut answered = 0;
        for _ in 0..100 {
            while answered < b.lines.len() {
                answered += 1;
                assert_eq!(b.answer("ok").unwrap(), None);
            }
            b.poll().unwrap();
            if answered == b.lines.len() {
                break;
            }
        }
        assert_eq!(b.confirmed, 3, "every chunk confirmed by its marker's ok");
        assert_eq!(b.lines.iter().filter(|l| (*l).clone() + "\n" == String::from_utf8_lossy(grbl::MARKER.bytes)).count(), 3);
        assert_eq!(b.answer("<Idle|MPos:2.000,10.000,0.000|FS:0,0>").unwrap(), Some(Outcome::Finished));
    }

    /// Seen in the end-to-end test of fault 1 (one run in five): the board
    /// lost a stroke's last two lines, the run went on writing the next
    /// strokes, and their `ok`s were taken for the lost lines' (GRBL's
    /// answers carry no line number), confirming a stroke never drawn; the
    /// stall came at the job's end and the resume skipped it. The next
    /// stroke now goes out only once every line before it is answered, so
    /// the stall comes inside the stroke that lost lines, unconfirmed.
    #[test]
    fn lines_the_board_lost_are_never_confirmed_by_the_next_strokes_oks() {
        let mut b = Bench::new(3, 128);
        b.poll().unwrap();
        let marker = String::from_utf8_lossy(grbl::MARKER.bytes).trim_end().to_owned();
        let first_marker = b.lines.iter().position(|l| *l == marker).expect("stroke 0's marker written");
        // The board loses stroke 0's last two lines (its pen-up and marker)
        // and answers every other line it is sent.
        let lost = [first_marker - 1, first_marker];
        let (mut answered, mut stalled) = (0, None);
        for _ in 0..200 {
            while answered < b.lines.len() {
                if !lost.contains(&answered) {
                    b.answer("ok").unwrap();
                }
                answered += 1;
                b.poll().unwrap();
            }
            b.wait(Duration::from_millis(100));
            if let Err(e) = b.poll() {
                stalled = Some(e);
                break;
            }
            if std::mem::take(&mut b.queries) > 0 {
                if let Err(e) = b.answer("<Idle|MPos:0.000,10.000,0.000|FS:0,0>") {
                    stalled = Some(e);
                    break;
                }
            }
        }
        let e = stalled.expect("a stall");
        assert!(matches!(e, StreamError::Stalled { unanswered: 2 }), "{e}");
        assert_eq!(b.confirmed, 0, "stroke 0 lost its end: nothing confirmed, so the resume draws it again");
        assert_eq!(b.lines.len(), first_marker + 1, "stroke 1 waited for stroke 0's answers: {:?}", b.lines);
    }

    /// Fault 1: the board went Idle with lines unanswered, and the run polled
    /// `?` for minutes. Idle with lines in flight and nothing answered is a
    /// stall within `stall_after`.
    #[test]
    fn idle_with_lines_in_flight_is_a_stall() {
        let mut b = Bench::new(3, 128);
        b.poll().unwrap();
        assert!(b.lines.len() > 3);
        b.answer("ok").unwrap();
        b.answer("ok").unwrap();
        // No more answers: the board lost the rest. It polls, hears Idle.
        let mut stalled = None;
        for step in 0..400 {
            b.wait(Duration::from_millis(100));
            if let Err(e) = b.poll() {
                stalled = Some((step, e));
                break;
            }
            if b.queries > 0 {
                b.queries = 0;
                if let Err(e) = b.answer("<Idle|MPos:0.000,10.000,0.000|FS:0,0>") {
                    stalled = Some((step, e));
                    break;
                }
            }
        }
        let (step, e) = stalled.expect("a stall, not a wait without end");
        // Two answered; the room they made was filled with more lines.
        assert!(matches!(e, StreamError::Stalled { unanswered } if unanswered == b.lines.len() - 2), "{e}");
        assert!(step * 100 <= 6_000, "noticed after {} ms", step * 100);
        // An `ok` in time keeps it going: progress resets the stall clock.
        let mut b = Bench::new(3, 128);
        b.poll().unwrap();
        for _ in 0..10 {
            b.wait(Duration::from_secs(1));
            b.answer("<Idle|MPos:0.000,0.000,0.000|FS:0,0>").unwrap();
            b.answer("ok").unwrap();
            b.poll().unwrap();
        }
    }

    /// Fault 1, the other half: a board that answers status reports as `Run`
    /// but never an `ok` is stalled too, after the motion timeout.
    #[test]
    fn no_ok_for_the_motion_timeout_is_a_stall() {
        let mut b = Bench::new(2, 128);
        b.poll().unwrap();
        let mut err = None;
        for _ in 0..200 {
            b.wait(Duration::from_secs(1));
            if let Err(e) = b.poll() {
                err = Some(e);
                break;
            }
            b.answer("<Run|MPos:0.000,0.000,0.000|FS:3000,1000>").unwrap();
        }
        assert!(matches!(err, Some(StreamError::Stalled { .. })), "{err:?}");
        assert!(b.now.saturating_duration_since(b.run.last_heard) < Duration::from_secs(2));
    }

    #[test]
    fn noise_counts_as_oks_when_the_board_is_idle() {
        let mut b = Bench::new(1, 128);
        b.poll().unwrap();
        let n = b.lines.len();
        for _ in 0..n {
            b.answer("o\u{fffd}").unwrap();
        }
        b.wait(Duration::from_secs(1));
        b.poll().unwrap();
        b.answer("<Idle|MPos:0.000,10.000,0.000|FS:0,0>").unwrap();
        assert_eq!(b.confirmed, 1);
        b.poll().unwrap();
        assert_eq!(b.answer("<Idle|MPos:0.000,10.000,0.000|FS:0,0>").unwrap(), Some(Outcome::Finished));
    }

    #[test]
    fn a_stop_lifts_the_pen_after_the_chunk_being_written() {
        let mut b = Bench::new(5, 40);
        b.poll().unwrap();
        b.run.stop(Stop::AfterStroke, b.now);
        let mut answered = 0;
        for _ in 0..50 {
            while answered < b.lines.len() {
                answered += 1;
                b.answer("ok").unwrap();
            }
            b.poll().unwrap();
        }
        assert_eq!(b.lines.last().map(String::as_str), Some("M5"), "{:?}", b.lines);
        assert!(b.confirmed < 5);
        assert_eq!(b.answer("<Idle|MPos:0.000,10.000,0.000|FS:0,0>").unwrap(), Some(Outcome::Stopped));
    }

    /// Answers `ok` line by line until `k` chunks are confirmed.
    fn confirm(b: &mut Bench, k: usize) {
        let mut answered = 0;
        while b.confirmed < k {
            assert!(answered < b.lines.len(), "only {} confirmed", b.confirmed);
            answered += 1;
            b.answer("ok").unwrap();
        }
    }

    /// Fault 9: a stop waited for the end of the stroke (over 15 s on a
    /// surface). A stop now holds, resets once the hold is complete (the
    /// board keeps its position), lifts the pen, and confirms only the
    /// chunks whose `ok`s came before the reset.
    #[test]
    fn a_stop_now_holds_resets_and_lifts_the_pen() {
        let mut b = Bench::new(5, 128);
        b.poll().unwrap();
        confirm(&mut b, 1);
        b.run.stop(Stop::Now, b.now);
        b.drain();
        assert_eq!(b.asked.last().map(Vec::as_slice), Some(Op::FeedHold.bytes()), "feed hold at once");
        let written = b.lines.len();
        b.wait(Duration::from_millis(100));
        b.poll().unwrap();
        assert_eq!(b.asked.last().map(Vec::as_slice), Some(Op::Status.bytes()));
        // Decelerating: no reset yet, which would lose the position.
        b.answer("<Hold:1|MPos:0.500,4.000,0.000|FS:2000,1000>").unwrap();
        assert!(!b.asked.iter().any(|q| q == Op::SoftReset.bytes()));
        b.wait(Duration::from_millis(100));
        b.poll().unwrap();
        b.answer("<Hold:0|MPos:1.000,5.000,0.000|FS:0,1000>").unwrap();
        assert_eq!(b.asked.last().map(Vec::as_slice), Some(Op::SoftReset.bytes()), "reset once the hold is complete");
        assert_eq!(b.answer("Grbl 1.1h ['$' for help]").unwrap(), None, "the reset's banner is no fault here");
        b.wait(Duration::from_millis(100));
        b.poll().unwrap();
        assert_eq!(b.lines.len(), written, "nothing written before the board says where it is");
        b.answer("<Idle|MPos:1.000,5.000,0.000|FS:0,0>").unwrap();
        assert_eq!(&b.lines[written..], ["M5"], "the pen lifted");
        b.answer("ok").unwrap();
        b.wait(Duration::from_millis(100));
        b.poll().unwrap();
        assert_eq!(b.answer("<Idle|MPos:1.000,5.000,0.000|FS:0,0>").unwrap(), Some(Outcome::Stopped));
        assert_eq!(b.confirmed, 1, "the lines the reset dropped confirm nothing");
    }

    /// A hold that never completes is reset all the same; the alarm that
    /// follows is unlocked before the pen is lifted.
    #[test]
    fn a_stop_now_unlocks_a_board_the_reset_alarmed() {
        let mut b = Bench::new(5, 128);
        b.poll().unwrap();
        b.run.stop(Stop::Now, b.now);
        for _ in 0..60 {
            b.wait(Duration::from_millis(100));
            b.poll().unwrap();
            if b.asked.last().map(Vec::as_slice) == Some(Op::Status.bytes()) {
                b.answer("<Run|MPos:0.000,1.000,0.000|FS:3000,1000>").unwrap();
            }
        }
        assert!(b.asked.iter().any(|q| q == Op::SoftReset.bytes()), "reset after stall_after");
        let written = b.lines.len();
        b.answer("ALARM:3").unwrap();
        b.answer("Grbl 1.1h ['$' for help]").unwrap();
        let unlock = String::from_utf8_lossy(Op::Unlock.bytes()).trim_end().to_owned();
        let home = String::from_utf8_lossy(Op::Home.bytes()).trim_end().to_owned();
        b.answer(&format!("[MSG:'{home}'|'{unlock}' to unlock]")).unwrap();
        b.wait(Duration::from_millis(100));
        b.poll().unwrap();
        b.answer("<Alarm|MPos:0.000,1.200,0.000|FS:0,0>").unwrap();
        assert_eq!(&b.lines[written..], [unlock.as_str(), "M5"]);
        b.answer("ok").unwrap();
        b.answer("[MSG:Caution: Unlocked]").unwrap();
        b.answer("ok").unwrap();
        assert_eq!(b.answer("<Idle|MPos:0.000,1.200,0.000|FS:0,0>").unwrap(), Some(Outcome::Stopped));
        assert_eq!(b.confirmed, 0);
    }

    #[test]
    fn a_banner_is_a_reset_and_an_alarm_an_error() {
        let mut b = Bench::new(1, 128);
        b.poll().unwrap();
        assert!(matches!(b.answer("Grbl 1.1h ['$' for help]"), Err(StreamError::Reset(_))));
        let mut b = Bench::new(1, 128);
        b.poll().unwrap();
        let e = b.answer("ALARM:1").unwrap_err();
        assert!(e.to_string().contains("hard limit"), "{e}");
    }
}
