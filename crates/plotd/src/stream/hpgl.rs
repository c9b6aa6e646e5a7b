//! The HP-GL handshakes (`escb`, `xonxoff`, `hardware`) as one state machine
//! that does no I/O: [`HpglRun`] takes answer lines and the time and gives
//! back [`Action`]s. The three differ only in set-up (XON/XOFF is switched
//! on by ESC.I / ESC.N) and in the port (RTS/CTS); the streaming rule is the
//! same for all.
//!
//! The bytes are plotcode's ([`Op`], [`plotcode::control::hpgl::MARKER`]); this machine says
//! when each is sent and what its answer means.
//!
//! Set-up, once per open port: ESC.K and ESC.J drop whatever the device
//! still holds from an earlier session, ESC.M makes answers end with LF,
//! and `OI` goes through the buffer: every answer before the identification
//! is stale, and none comes after it. Its first letter ends an instruction
//! left half read (a chained `OE` waiting for its next letter); nothing
//! plotd writes begins with a bare `;` or a line feed, which a strict device
//! (a clone, an emulator) reads as HP-GL error 1. Then ESC.L gives the
//! buffer size, or ESC.B when the firmware does not answer ESC.L (an idle
//! device's free space is its size).
//!
//! What the device answers is learnt once per link by the set-up
//! ([`HpglCapabilities`]), as clones and emulators lack some of it: ESC.L
//! (the size then comes from ESC.B), ESC.M (answers keep the power-on CR,
//! which then tells no power cycle), ESC.O (asked once with the reply
//! timeout; without it the paper lever is not seen and a device whose
//! free space stands still is drawing a long stroke).
//!
//! Streaming: an `OE` marker follows each chunk (see [`Plan`]); its answer
//! 0 confirms exactly that chunk, a non-zero one puts the device's error in
//! it. Bytes written and not confirmed stay under the window, which is under
//! the buffer size minus the margin. Rules:
//! - **An answer never confirms a marker it cannot belong to.** `OE`
//!   answers 0..=7; ESC.B answers the free space, which is at least the
//!   margin (16) because the unconfirmed bytes never exceed the size minus
//!   the margin; ESC.O answers a multiple of 8. A 0 while an ESC.O is
//!   unanswered is taken for the ESC.O's (a marker's answer taken late is
//!   safe; one taken early is a stroke skipped after a power cut), and
//!   given back to the marker if the ESC.O's answer then comes.
//! - **Every wait has a deadline.** Silence for [`Timing::probe_after`]
//!   while the device holds work sends ESC.B: no answer within the reply
//!   timeout is a dead link; an answer ended by CR (the power-on
//!   terminator) is a power cycle. No progress (a marker answered, the free
//!   space moving) for the motion timeout is a timeout, except while the
//!   device holds its work with the paper lever up. The motion timeout
//!   grows to [`STALL_FACTOR`] times the estimated plot time of the chunk
//!   whose marker is due, so a long stroke is never a timeout.
//!   A device without ESC.O is never asked it.
//! - Two ESC.B answers alike with nothing confirmed between send ESC.O: the
//!   paper lever up (bit 5) is [`Hold::PaperLever`], reported until the
//!   device goes on.
//!
//! The end: the stop's pen-up, then `OE` and `OA` must come back (everything
//! before them done, `OE` 0), then ESC.E must be 0.
//!
//! A stop now ([`Stop::Now`]): ESC.K drops the device's buffer (the
//! instruction running finishes), then the pen-up and `OI` are written. Marker answers before the identification confirm, in order, the
//! chunks that ran; **the markers dropped with the buffer confirm nothing**,
//! so the checkpoint is the last chunk the device finished, and a resume
//! draws again at most the one it was in.

use super::machine::{Action, Machine, Mailbox, Timing};
use super::plan::Plan;
use super::{DeviceError, ErrorAt, Excerpt, Garbled, Reset, Unanswered};
use super::{Hold, Outcome, StreamError, Written};
use plotcode::answer::{is_identification, AnswerLine, ErrorCode, ExtendedStatus, HpglNumber, HpglPosition, Terminator, MAX_HPGL_ERROR};
use plotcode::control::hpgl::{sequence, Op};
use std::time::{Duration, Instant};

/// Unrecognised answers tolerated in one run before the link counts as garbled.
const MAX_NOISE: usize = 8;

/// How many times its estimated plot time a chunk may take before its
/// marker is answered (when that is longer than the motion timeout): the
/// plot-time model is close for a device that follows its profile, and a
/// slower one (a clone, a worn pen carriage) is seldom twice as slow.
pub(super) const STALL_FACTOR: f64 = 2.0;

/// The device-control instructions an HP-GL device answers, of those plotd
/// can do without: learnt once per link by the set-up, kept by the
/// streamer for the plotter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct HpglCapabilities {
    /// ESC.L (buffer size) is answered; else ESC.B sizes an idle buffer.
    pub buffer_size: bool,
    /// ESC.M is honoured: answers end with LF, so one ended by the
    /// power-on CR tells a power cycle.
    pub output_mode: bool,
    /// ESC.O (extended status) is answered: a paper lever up is seen.
    pub extended_status: bool,
}

impl HpglCapabilities {
    /// What an HP 7475A answers: everything.
    pub const FULL: HpglCapabilities = HpglCapabilities { buffer_size: true, output_mode: true, extended_status: true };
}

/// How a run starts.
#[derive(Clone, Copy, Debug)]
pub(super) struct Start {
    /// The buffer size learnt on this link; `None` runs the set-up first.
    pub size: Option<usize>,
    /// What the device answers, once learnt; `None`: the set-up probes it.
    pub caps: Option<HpglCapabilities>,
    /// Switch XON/XOFF on in the set-up.
    pub xonxoff: bool,
    /// Free bytes left unused, against miscounting; at least 8, so that no
    /// ESC.B answer is a possible `OE` answer.
    pub margin: usize,
    /// Most bytes written and not confirmed.
    pub window: usize,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Phase {
    /// Set-up written: lines before the identification are stale.
    Clearing,
    /// Asked ESC.L for the buffer size (`false`), or ESC.B (`true`).
    Sizing {
        by_free_space: bool,
    },
    /// Asked ESC.O once, to learn whether the device answers it.
    Probing,
    Streaming,
    /// ESC.K sent and the pen lifted, `OI` after it: marker answers
    /// before the identification confirm chunks that ran (in order); none
    /// comes after it.
    Aborting,
    /// `OE` and `OA` written after the last chunk: the `OE` answer once it came.
    Finishing {
        oe: Option<i64>,
    },
    /// ESC.E asked after the end.
    Checking,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Probe {
    /// ESC.B: `credit` when asked for room to write a chunk longer than the
    /// window, else to hear from a silent device.
    Free { credit: bool },
    /// ESC.O, after the free space stood still.
    Status,
}

/// One run of chunks on an HP-GL device.
#[derive(Debug)]
pub(super) struct HpglRun {
    plan: Plan,
    start: Start,
    timing: Timing,
    pen_up: Vec<u8>,
    phase: Phase,
    /// The buffer size, once known.
    size: Option<usize>,
    /// What the device answers: as learnt, or being learnt by this set-up.
    caps: HpglCapabilities,
    /// The set-up learns [`Self::caps`].
    probing: bool,
    /// When the current phase's question was asked.
    asked: Instant,
    /// Bytes of the plan written.
    sent: usize,
    /// Chunks of the plan confirmed.
    done: usize,
    /// The outcome the end will report.
    outcome: Outcome,
    /// The chunk whose open marker was ended with a `;`.
    ended: Option<usize>,
    /// Lines that answered nothing asked: maybe a garbled marker answer.
    noise: usize,
    /// An `OA;` written to resynchronise after noise: chunks written before it.
    resync: Option<usize>,
    /// Bytes ESC.B said may be written (inside a chunk longer than the window).
    credit: usize,
    /// When to ask for credit again after an answer of none.
    credit_after: Option<Instant>,
    /// The unanswered probe and when it was sent.
    probe: Option<(Probe, Instant)>,
    /// A 0 taken for an ESC.O's answer while a marker was unanswered.
    zero_taken: Option<Instant>,
    /// The last ESC.B answer, and whether a chunk was confirmed since.
    last_free: Option<i64>,
    confirmed_since_free: bool,
    /// Ask ESC.O at the next chance.
    ask_status: bool,
    held: Option<Hold>,
    xoff: bool,
    last_heard: Instant,
    /// The last progress: a marker answered, the free space moving, a write
    /// into an idle device.
    last_progress: Instant,
    /// What the run decided, and whether a stop was asked for.
    mailbox: Mailbox,
}

impl HpglRun {
    /// A run of `plan`; `pen_up` lifts the pen after a stop.
    pub fn new(plan: Plan, start: Start, pen_up: Vec<u8>, timing: Timing, now: Instant) -> HpglRun {
        debug_assert!(start.margin as i64 > MAX_HPGL_ERROR, "an ESC.B answer could be taken for an OE answer");
        let mut run = HpglRun {
            plan,
            start,
            timing,
            pen_up,
            phase: Phase::Streaming,
            size: start.size,
            caps: start.caps.unwrap_or(HpglCapabilities::FULL),
            probing: start.caps.is_none(),
            asked: now,
            sent: 0,
            done: 0,
            outcome: Outcome::Finished,
            ended: None,
            noise: 0,
            resync: None,
            credit: 0,
            credit_after: None,
            probe: None,
            zero_taken: None,
            last_free: None,
            confirmed_since_free: false,
            ask_status: false,
            held: None,
            xoff: false,
            last_heard: now,
            last_progress: now,
            mailbox: Mailbox::default(),
        };
        if start.size.is_none() {
            // Drop what the device holds, answers end with LF, the
            // handshake's own set-up; the identification's letter ends a
            // half-read instruction and its answer comes after every stale one.
            let mut setup = vec![Op::Abort, Op::AbortDeviceControl, Op::AnswersEndWithLf];
            if start.xonxoff {
                setup.push(Op::XonXoff);
            }
            setup.push(Op::Identify);
            run.mailbox.actions.push(Action::Write { bytes: sequence(&setup), payload: 0 });
            run.phase = Phase::Clearing;
        }
        run
    }

    /// The buffer size, once known (the next run on this link skips the set-up).
    pub fn buffer_size(&self) -> Option<usize> {
        self.size
    }

    /// What the device answers, once the set-up has learnt it.
    pub fn capabilities(&self) -> Option<HpglCapabilities> {
        (!self.probing).then_some(self.caps)
    }

    /// How long the run waits for progress: the motion timeout, or longer
    /// for a chunk whose estimated plot time says it takes longer.
    fn stall_limit(&self) -> Duration {
        let estimate = self.plan.seconds.get(self.done).map_or(0.0, |s| s * STALL_FACTOR);
        self.timing.motion_timeout.max(Duration::try_from_secs_f64(estimate).unwrap_or(Duration::MAX))
    }

    fn window(&self) -> usize {
        self.size.map_or(0, |s| s.saturating_sub(self.start.margin).min(self.start.window))
    }

    fn written_chunks(&self) -> usize {
        self.plan.ends.partition_point(|&e| e <= self.sent)
    }

    /// Whether a marker (or the end's `OE`) is unanswered.
    fn marker_due(&self) -> bool {
        match self.phase {
            Phase::Streaming | Phase::Aborting => self.done < self.written_chunks(),
            Phase::Finishing { oe } => oe.is_none(),
            _ => false,
        }
    }

    /// Whether the device holds work the run waits on.
    fn waiting(&self) -> bool {
        self.marker_due() || (self.phase == Phase::Streaming && self.xoff) || self.resync.is_some() || self.phase == Phase::Aborting
    }

    fn progress(&mut self, now: Instant) {
        self.last_progress = now;
        if self.held.take().is_some() {
            self.mailbox.actions.push(Action::Held(None));
        }
    }

    fn confirm(&mut self, now: Instant) {
        self.done += 1;
        self.confirmed_since_free = true;
        self.mailbox.actions.push(Action::Confirmed(self.plan.from + self.done));
        self.progress(now);
    }

    fn noise(&mut self, text: &str) -> Result<(), StreamError> {
        tracing::warn!(answer = %text, "unexpected HP-GL answer");
        self.noise += 1;
        if self.noise > MAX_NOISE {
            return Err(StreamError::Garbled(Garbled::Noise { lines: self.noise, last: Excerpt::of(text) }));
        }
        Ok(())
    }

    /// An `OE` answer to the marker due.
    fn marker(&mut self, n: i64, now: Instant) -> Result<(), StreamError> {
        if let Phase::Finishing { oe: None } = self.phase {
            self.phase = Phase::Finishing { oe: Some(n) };
            self.progress(now);
            return Ok(());
        }
        if n == 0 {
            self.confirm(now);
            return Ok(());
        }
        // Drop what the device holds after the failed stroke, so that it
        // stops as near to it as the line allows.
        self.mailbox.actions.push(Action::Query(Op::Abort.bytes().to_vec()));
        Err(StreamError::Device(DeviceError::at(ErrorCode::Hpgl(n), ErrorAt::Stroke(self.plan.from + self.done))))
    }

    fn status(&mut self, n: i64, now: Instant) {
        if ExtendedStatus(n).paper_lever_up() {
            self.last_progress = now;
            if self.held.is_none() {
                self.held = Some(Hold::PaperLever);
                self.mailbox.actions.push(Action::Held(Some(Hold::PaperLever)));
            }
        } else if self.held.take().is_some() {
            self.mailbox.actions.push(Action::Held(None));
        }
    }

    fn free(&mut self, n: i64, credit: bool, now: Instant) {
        if credit {
            let size = self.size.unwrap_or(0);
            self.credit = usize::try_from(n).unwrap_or(0).min(size).saturating_sub(self.start.margin);
            if self.credit == 0 {
                self.credit_after = Some(now + self.timing.poll_interval);
            }
        }
        if self.last_free.is_some_and(|f| f != n) {
            // The device took bytes from its buffer.
            self.progress(now);
        } else if self.last_free.is_some() && !self.confirmed_since_free && self.marker_due() && self.caps.extended_status {
            // Nothing taken, nothing answered: ask why.
            self.ask_status = true;
        }
        self.last_free = Some(n);
        self.confirmed_since_free = false;
    }

    /// A number while streaming or finishing: whose answer it is.
    fn number(&mut self, n: i64, now: Instant) -> Result<(), StreamError> {
        let due = self.marker_due();
        match self.probe {
            Some((Probe::Free { credit }, _)) if n > MAX_HPGL_ERROR => {
                self.probe = None;
                self.free(n, credit, now);
                return Ok(());
            }
            Some((Probe::Status, _)) if ExtendedStatus::possible(n) => {
                self.probe = None;
                if n == 0 && due {
                    self.zero_taken = Some(now);
                }
                self.status(n, now);
                return Ok(());
            }
            _ => {}
        }
        if n > MAX_HPGL_ERROR && ExtendedStatus::possible(n) && self.zero_taken.take().is_some() {
            // ESC.O's answer after a 0 taken for it: that 0 was a marker's.
            if self.marker_due() {
                self.marker(0, now)?;
            }
            self.status(n, now);
            return Ok(());
        }
        if (0..=MAX_HPGL_ERROR).contains(&n) && due {
            return self.marker(n, now);
        }
        self.noise(&n.to_string())
    }

    /// The buffer size is known: learn whether ESC.O is answered, or stream.
    fn sized(&mut self, size: usize, now: Instant) {
        self.size = Some(size);
        if self.probing {
            self.mailbox.actions.push(Action::Query(Op::ExtendedStatus.bytes().to_vec()));
            self.phase = Phase::Probing;
            self.asked = now;
        } else {
            self.begin_streaming(now);
        }
    }

    fn begin_streaming(&mut self, now: Instant) {
        if std::mem::take(&mut self.probing) {
            tracing::info!(capabilities = ?self.caps, "learnt what the HP-GL device answers");
        }
        self.phase = Phase::Streaming;
        self.last_progress = now;
    }

    fn end(&mut self, now: Instant) {
        let limit = self.plan.limit(self.sent, self.mailbox.stopping());
        if limit < self.plan.data.len() {
            self.outcome = Outcome::Stopped;
        }
        if limit < self.plan.data.len() || self.plan.lift {
            self.mailbox.actions.push(Action::Write { bytes: self.pen_up.clone(), payload: 0 });
        }
        self.mailbox.actions.push(Action::Write { bytes: sequence(&[Op::LastError, Op::Position]), payload: 0 });
        self.phase = Phase::Finishing { oe: None };
        self.asked = now;
        self.last_progress = now;
    }

    fn stream(&mut self, now: Instant) {
        loop {
            let written = self.written_chunks();
            let limit = self.plan.limit(self.sent, self.mailbox.stopping());
            if self.sent == limit && self.done == written {
                self.end(now);
                return;
            }
            let window = self.window();
            let confirmed_at = if self.done == 0 { 0 } else { self.plan.ends[self.done - 1] };
            // One chunk per write, and a chunk only when all of it fits (one
            // longer than the window goes in pieces): so the written mark
            // says exactly which chunk the device may hold in part.
            let chunk_start = if written == 0 { 0 } else { self.plan.ends[written - 1] };
            let chunk_end = self.plan.ends.get(written).map_or(limit, |&e| e.min(limit));
            let room = window.saturating_sub(self.sent - confirmed_at).max(self.credit);
            let room = if chunk_end - self.sent <= room || chunk_end - chunk_start > window { room } else { 0 };
            if room == 0 && self.done == written && self.sent < limit && !self.xoff && self.resync.is_none() {
                // A chunk longer than the window and no marker due: write
                // into the free space ESC.B reports.
                if self.probe.is_none() && self.credit_after.is_none_or(|t| now >= t) {
                    self.credit_after = None;
                    self.ask(Probe::Free { credit: true }, now);
                }
                return;
            }
            if self.xoff || self.sent == limit || room == 0 {
                let last = written.wrapping_sub(1);
                if self.done == last
                    && self.ended != Some(last)
                    && !self.xoff
                    && self.plan.ends.get(last) == Some(&self.sent)
                    && self.plan.open_marker(last)
                {
                    // Only the last marker is unanswered, and the letter that
                    // would end it is not coming now (a stop moved the limit,
                    // or the window is full). At most one such `;` is in the
                    // buffer unconfirmed: the margin covers it.
                    self.mailbox.actions.push(Action::Write { bytes: Op::EndInstruction.bytes().to_vec(), payload: 0 });
                    self.ended = Some(last);
                }
                return;
            }
            if self.done == written {
                // Writing into an idle device: progress is timed from here.
                self.last_progress = now;
            }
            let n = (chunk_end - self.sent).min(room);
            self.mailbox.actions.push(Action::Written(Written::Into(self.plan.from + written)));
            let payload = self.plan.payload(self.sent + n) - self.plan.payload(self.sent);
            self.mailbox.actions.push(Action::Write { bytes: self.plan.data[self.sent..self.sent + n].to_vec(), payload });
            if self.sent + n == chunk_end {
                self.mailbox.actions.push(Action::Written(Written::Through(self.plan.from + written + 1)));
            }
            self.sent += n;
            self.credit = self.credit.saturating_sub(n);
        }
    }

    fn ask(&mut self, probe: Probe, now: Instant) {
        let op = match probe {
            Probe::Free { .. } => Op::FreeSpace,
            Probe::Status => Op::ExtendedStatus,
        };
        self.mailbox.actions.push(Action::Query(op.bytes().to_vec()));
        self.probe = Some((probe, now));
    }

    /// Stops the pen where it is ([`Stop::Now`]): what the device holds is
    /// dropped, the pen lifted, and the run ends [`Outcome::Stopped`] once
    /// every chunk the device ran is confirmed.
    fn abort(&mut self, now: Instant) {
        // Before streaming nothing of the job is written (the stop's limit
        // keeps it so); once finishing, the end is as near as an abort's.
        if self.phase != Phase::Streaming {
            return;
        }
        // ESC.K drops the buffer (the instruction running finishes), the
        // pen-up's letter ends one it left half read, and `OI` comes back
        // once the pen is up.
        self.mailbox.actions.push(Action::Query(Op::Abort.bytes().to_vec()));
        let mut bytes = self.pen_up.clone();
        bytes.extend_from_slice(Op::Identify.bytes());
        self.mailbox.actions.push(Action::Write { bytes, payload: 0 });
        self.phase = Phase::Aborting;
        self.outcome = Outcome::Stopped;
        self.credit = 0;
        self.asked = now;
        self.last_progress = now;
    }
}

impl Machine for HpglRun {
    type Output = Outcome;

    fn poll(&mut self, now: Instant, xoff: bool) -> Result<Option<Outcome>, StreamError> {
        self.xoff = xoff;
        let reply = self.timing.reply_timeout;
        match self.phase {
            Phase::Clearing if now.saturating_duration_since(self.asked) > reply => {
                return Err(StreamError::Timeout(Unanswered::Hpgl(Op::Identify)));
            }
            Phase::Sizing { by_free_space: false } if !self.caps.buffer_size || now.saturating_duration_since(self.asked) > reply => {
                // Older firmware does not answer ESC.L; an idle device's free
                // space is its size.
                self.caps.buffer_size = false;
                self.mailbox.actions.push(Action::Query(Op::FreeSpace.bytes().to_vec()));
                self.phase = Phase::Sizing { by_free_space: true };
                self.asked = now;
            }
            Phase::Sizing { by_free_space: true } if now.saturating_duration_since(self.asked) > reply => {
                return Err(StreamError::Timeout(Unanswered::BufferSize));
            }
            Phase::Probing if now.saturating_duration_since(self.asked) > reply => {
                // Some clones and emulators ignore ESC.O: not asked again.
                self.caps.extended_status = false;
                self.begin_streaming(now);
                self.stream(now);
            }
            Phase::Checking if now.saturating_duration_since(self.asked) > reply => {
                return Err(StreamError::Timeout(Unanswered::Hpgl(Op::ExtendedError)));
            }
            Phase::Streaming => self.stream(now),
            _ => {}
        }
        if let Some((probe, sent)) = self.probe {
            if now.saturating_duration_since(sent) > reply {
                return Err(StreamError::Timeout(Unanswered::Hpgl(match probe {
                    Probe::Free { .. } => Op::FreeSpace,
                    Probe::Status => Op::ExtendedStatus,
                })));
            }
        }
        if self.zero_taken.is_some_and(|t| now.saturating_duration_since(t) > reply) {
            self.zero_taken = None;
        }
        if !self.waiting() {
            return Ok(None);
        }
        if self.held.is_none() && now.saturating_duration_since(self.last_progress) > self.stall_limit() {
            return Err(StreamError::Timeout(if self.xoff { Unanswered::Xon } else { Unanswered::Hpgl(Op::LastError) }));
        }
        if self.probe.is_none() && std::mem::take(&mut self.ask_status) {
            self.ask(Probe::Status, now);
        } else if self.probe.is_none() && now.saturating_duration_since(self.last_heard) >= self.timing.probe_after {
            self.ask(Probe::Free { credit: false }, now);
        }
        if self.noise > 0
            && self.resync.is_none()
            && self.phase == Phase::Streaming
            && now.saturating_duration_since(self.last_heard) > reply
        {
            // A marker answer may have been garbled: an OA round trip says
            // when everything written so far has run.
            self.mailbox.actions.push(Action::Write { bytes: Op::Position.bytes().to_vec(), payload: 0 });
            self.resync = Some(self.written_chunks());
        }
        Ok(None)
    }

    fn answer(&mut self, line: &AnswerLine, now: Instant) -> Result<Option<Outcome>, StreamError> {
        self.last_heard = now;
        let text = line.text.as_str();
        if self.phase == Phase::Clearing {
            // Everything before the identification answers an earlier
            // session; the identification comes after ESC.M took effect
            // (ended by CR, it was not honoured).
            let lf = line.terminator == Terminator::Lf;
            if is_identification(text) && (lf || self.probing || !self.caps.output_mode) {
                if self.probing {
                    self.caps.output_mode = lf;
                }
                self.mailbox.actions.push(Action::Query(Op::BufferSize.bytes().to_vec()));
                self.phase = Phase::Sizing { by_free_space: false };
                self.asked = now;
            }
            return Ok(None);
        }
        // From here on answers end with LF: a CR is the power-on terminator.
        if line.terminator == Terminator::Cr && self.caps.output_mode {
            return Err(StreamError::Reset(Reset::PowerOnTerminator { answer: Excerpt::of(text) }));
        }
        let number = HpglNumber::parse(text).map(|n| n.0);
        match (self.phase, number) {
            (Phase::Sizing { .. }, Some(n)) => {
                match usize::try_from(n) {
                    Ok(size) if size > 2 * self.start.margin => self.sized(size, now),
                    _ => tracing::debug!(answer = %text, "dropped a stale answer before the buffer size"),
                }
                Ok(None)
            }
            (Phase::Sizing { .. }, None) => Ok(None),
            (Phase::Probing, Some(n)) if ExtendedStatus::possible(n) => {
                self.caps.extended_status = true;
                self.begin_streaming(now);
                Ok(None)
            }
            (Phase::Probing, _) => Ok(None),
            (Phase::Checking, Some(_)) if self.probe.is_some() => {
                // Escape sequences are answered in the order they came: a
                // probe asked before ESC.E is answered first.
                self.probe = None;
                Ok(None)
            }
            (Phase::Checking, Some(0)) => Ok(Some(self.outcome)),
            (Phase::Checking, Some(e)) => Err(StreamError::Device(DeviceError::new(ErrorCode::DeviceControl(e)))),
            (Phase::Streaming | Phase::Aborting | Phase::Finishing { .. }, Some(n)) => self.number(n, now).map(|()| None),
            (Phase::Aborting, None) if is_identification(text) => {
                // Every marker the device ran has been answered; the rest
                // were dropped with the buffer.
                self.mailbox.actions.push(Action::Query(Op::ExtendedError.bytes().to_vec()));
                self.phase = Phase::Checking;
                self.asked = now;
                Ok(None)
            }
            (Phase::Finishing { oe: Some(oe) }, None) if HpglPosition::parse(text).is_some() => {
                if oe != 0 {
                    return Err(StreamError::Device(DeviceError::new(ErrorCode::Hpgl(oe))));
                }
                // Device-control and I/O errors (overrun, framing) are kept apart.
                self.mailbox.actions.push(Action::Query(Op::ExtendedError.bytes().to_vec()));
                self.phase = Phase::Checking;
                self.asked = now;
                Ok(None)
            }
            (Phase::Streaming | Phase::Aborting, None) if HpglPosition::parse(text).is_some() && self.resync.is_some() => {
                // The resync OA: everything written before it has run.
                let upto = self.resync.take().unwrap_or(0);
                while self.done < upto {
                    self.confirm(now);
                }
                self.noise = 0;
                Ok(None)
            }
            _ => self.noise(text).map(|()| None),
        }
    }

    fn deadline(&self, now: Instant) -> Instant {
        now + self.timing.poll_interval.max(self.timing.probe_after / 10)
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
    use plotcode::Program;
    use std::time::Duration;

    fn program(strokes: usize) -> Program {
        testing::program("hp7475a", "IN;SP1;", strokes, |i| format!("PU{},0;PD{},500;", i * 100, i * 100))
    }

    fn lf(text: &str) -> AnswerLine {
        AnswerLine { text: text.into(), terminator: Terminator::Lf }
    }

    fn cr(text: &str) -> AnswerLine {
        AnswerLine { text: text.into(), terminator: Terminator::Cr }
    }

    /// A run, a clock moved by hand, and what the device has been sent.
    struct Bench {
        run: HpglRun,
        now: Instant,
        /// Job bytes and markers written.
        data: Vec<u8>,
        queries: Vec<Vec<u8>>,
        confirmed: usize,
        held: Vec<Option<Hold>>,
    }

    impl Bench {
        fn new(strokes: usize, size: Option<usize>) -> Bench {
            Bench::with(&program(strokes), size, size.map(|_| HpglCapabilities::FULL))
        }
        /// A run of `p` on a link that knows `size` and `caps` (`None`: the set-up learns them).
        fn with(p: &Program, size: Option<usize>, caps: Option<HpglCapabilities>) -> Bench {
            let start = Start { size, caps, xonxoff: false, margin: 16, window: 256 };
            let window = size.map_or(256, |s| (s - 16).min(256));
            let plan = Plan::new(Span::all(p), plotcode::control::hpgl::MARKER, Some(window));
            let now = Instant::now();
            let mut b = Bench {
                run: HpglRun::new(plan, start, b"PU;".to_vec(), timing(), now),
                now,
                data: Vec::new(),
                queries: Vec::new(),
                confirmed: 0,
                held: Vec::new(),
            };
            b.drain();
            b
        }
        fn drain(&mut self) {
            for a in self.run.take_actions() {
                match a {
                    Action::Write { bytes, .. } => self.data.extend_from_slice(&bytes),
                    Action::Query(q) => self.queries.push(q),
                    Action::Confirmed(k) => self.confirmed = k,
                    Action::Held(h) => self.held.push(h),
                    Action::Written(_) => {}
                }
            }
        }
        fn poll(&mut self) -> Result<(), StreamError> {
            let r = self.run.poll(self.now, false);
            self.drain();
            r.map(|_| ())
        }
        fn answer(&mut self, line: AnswerLine) -> Result<Option<Outcome>, StreamError> {
            let r = self.run.answer(&line, self.now);
            self.drain();
            r
        }
        fn wait(&mut self, d: Duration) {
            self.now += d;
        }
        /// Markers written so far (`OE` followed by `;` or a letter).
        fn markers(&self) -> usize {
            let oe = plotcode::control::hpgl::MARKER.chained.expect("HP-GL's marker chains");
            self.data.windows(oe.len()).filter(|w| *w == oe).count()
        }
        /// Polls in steps of `step` until `until` has passed or the run fails.
        fn idle(&mut self, until: Duration, step: Duration) -> Result<(), StreamError> {
            let end = self.now + until;
            while self.now < end {
                self.wait(step);
                self.poll()?;
            }
            Ok(())
        }
    }

    /// The offset of the first byte a strict HP-GL device reads as error 1
    /// (plotsim's `strict-separators`): a `;`, CR or LF where an
    /// instruction should begin. Device-control sequences with parameters
    /// end at their `:`.
    fn strict_error(b: &[u8]) -> Option<usize> {
        let mut i = 0;
        while i < b.len() {
            match b[i] {
                0x1b => {
                    let letter = *b.get(i + 2)?;
                    i += 3;
                    if b"@HIMN".contains(&letter) {
                        i += b[i..].iter().position(|&c| c == b':')? + 1;
                    }
                }
                c if c.is_ascii_alphabetic() => {
                    i += 2;
                    while b.get(i).is_some_and(|c| b"0123456789.,+- ".contains(c)) {
                        i += 1;
                    }
                    if b.get(i) == Some(&b';') {
                        i += 1;
                    }
                }
                _ => return Some(i),
            }
        }
        None
    }

    /// Issue 36: plotd's own identification query began with a bare `;`, which a strict
    /// device (a clone, an emulator) reads as HP-GL error 1 and blames on the
    /// drawing. The set-up, the stream with its markers, the end and a stop
    /// now read as instructions from their first byte.
    #[test]
    fn what_the_run_writes_reads_on_a_strict_device() {
        let mut b = Bench::new(3, None);
        assert_eq!(strict_error(&b.data), None, "set-up: {:?}", String::from_utf8_lossy(&b.data));
        b.answer(lf("7475A")).unwrap();
        b.answer(lf("1024")).unwrap();
        b.answer(lf("8")).unwrap();
        b.poll().unwrap();
        for _ in 0..b.run.plan.ends.len() {
            b.answer(lf("0")).unwrap();
        }
        b.poll().unwrap();
        assert_eq!(strict_error(&b.data), None, "{:?}", String::from_utf8_lossy(&b.data));

        let mut b = Bench::new(6, Some(1024));
        b.poll().unwrap();
        b.answer(lf("0")).unwrap();
        let before = b.data.len();
        b.run.stop(Stop::Now, b.now);
        b.drain();
        assert_eq!(strict_error(&b.data[before..]), None, "stop now: {:?}", String::from_utf8_lossy(&b.data[before..]));
    }

    /// Issue 36: a clone that ignores ESC.O and ESC.M. The set-up learns it
    /// once (the identification ended by CR, ESC.O unanswered for the reply
    /// timeout), and the run then takes its CR-ended answers for answers,
    /// never asks ESC.O, and plots.
    #[test]
    fn a_device_without_esc_o_and_esc_m_is_learnt_once_and_plotted() {
        let mut b = Bench::new(3, None);
        b.answer(cr("7475A")).unwrap();
        b.answer(cr("1024")).unwrap();
        assert_eq!(b.queries.last().map(Vec::as_slice), Some(Op::ExtendedStatus.bytes()));
        b.idle(Duration::from_millis(2100), Duration::from_millis(100)).unwrap();
        let caps = HpglCapabilities { buffer_size: true, output_mode: false, extended_status: false };
        assert_eq!(b.run.capabilities(), Some(caps));
        assert_eq!(b.markers(), 3, "streaming once ESC.O went unanswered");
        for _ in 0..3 {
            b.answer(cr("0")).unwrap();
        }
        assert_eq!(b.confirmed, 3);
        // The next run on the link knows: no set-up question asked again.
        let mut next = Bench::with(&program(2), None, Some(caps));
        next.answer(cr("7475A")).unwrap();
        assert_eq!(next.queries, [Op::BufferSize.bytes()]);
        next.answer(cr("1024")).unwrap();
        next.poll().unwrap();
        assert_eq!(next.markers(), 2);
        assert_eq!(next.queries, [Op::BufferSize.bytes()], "ESC.O not asked again");
    }

    /// Issue 36: on a device without ESC.O a stroke over two seconds was
    /// "offline: no answer to ESC.O". Its free space stands still while it
    /// draws; the run waits as long as the stroke's estimated plot time says
    /// (here 300 s, past the 120 s motion timeout), asking only ESC.B, and
    /// times out at twice the estimate.
    #[test]
    fn a_long_stroke_on_a_device_without_esc_o_is_waited_for_by_its_estimate() {
        let mut p = program(2);
        p.chunks[0].seconds = 300.0;
        let caps = HpglCapabilities { extended_status: false, ..HpglCapabilities::FULL };
        let mut b = Bench::with(&p, Some(1024), Some(caps));
        b.poll().unwrap();
        let t0 = b.now;
        while b.now - t0 < Duration::from_secs(500) {
            b.wait(Duration::from_millis(500));
            b.poll().unwrap();
            for q in std::mem::take(&mut b.queries) {
                assert_eq!(q, Op::FreeSpace.bytes(), "only ESC.B is asked");
                b.answer(lf("900")).unwrap();
            }
        }
        b.answer(lf("0")).unwrap();
        assert_eq!(b.confirmed, 1, "the long stroke drawn");

        let mut b = Bench::with(&p, Some(1024), Some(caps));
        b.poll().unwrap();
        let t0 = b.now;
        let e = loop {
            b.wait(Duration::from_millis(500));
            if let Err(e) = b.poll() {
                break e;
            }
            for _ in std::mem::take(&mut b.queries) {
                b.answer(lf("900")).unwrap();
            }
        };
        assert!(matches!(e, StreamError::Timeout(Unanswered::Hpgl(Op::LastError))), "{e}");
        let waited = b.now - t0;
        assert!(waited >= Duration::from_secs(600) && waited < Duration::from_secs(602), "twice the estimate: {waited:?}");
    }

    /// Fault 6: a plotter power-cycled between jobs answers with its
    /// power-on CR; the next job's set-up takes that for an earlier
    /// session's answer, not a reset, and the job plots.
    #[test]
    fn setup_drops_stale_answers_and_reads_the_size() {
        let mut b = Bench::new(3, None);
        let setup = String::from_utf8_lossy(&b.data).into_owned();
        let clear = sequence(&[Op::Abort, Op::AbortDeviceControl, Op::AnswersEndWithLf]);
        assert!(b.data.starts_with(&clear), "{setup:?}");
        assert!(b.data.ends_with(Op::Identify.bytes()), "OI syncs (its letter ends a half-read OE): {setup:?}");
        // An earlier session's marker answers (one with the power-on CR)
        // come before the identification, and are not this run's.
        for stale in [cr("0"), lf("0"), lf("1500,200,1")] {
            assert_eq!(b.answer(stale).unwrap(), None);
        }
        assert!(b.queries.is_empty(), "nothing asked before the identification");
        b.answer(lf("7475A")).unwrap();
        assert_eq!(b.queries, [Op::BufferSize.bytes()]);
        b.answer(lf("1024")).unwrap();
        assert_eq!(b.run.buffer_size(), Some(1024));
        // Whether ESC.O is answered is learnt once.
        assert_eq!(b.queries.last().map(Vec::as_slice), Some(Op::ExtendedStatus.bytes()));
        b.answer(lf("8")).unwrap();
        assert_eq!(b.run.capabilities(), Some(HpglCapabilities::FULL));
        b.poll().unwrap();
        assert_eq!(b.markers(), 3, "every chunk written with its marker");
    }

    #[test]
    fn firmware_without_esc_l_is_sized_by_esc_b() {
        let mut b = Bench::new(2, None);
        b.answer(lf("7475A")).unwrap();
        b.wait(Duration::from_millis(2100));
        b.poll().unwrap();
        assert_eq!(b.queries, [Op::BufferSize.bytes(), Op::FreeSpace.bytes()]);
        b.answer(lf("1024")).unwrap();
        assert_eq!(b.run.buffer_size(), Some(1024));
        b.answer(lf("8")).unwrap();
        assert_eq!(b.run.capabilities(), Some(HpglCapabilities { buffer_size: false, ..HpglCapabilities::FULL }));
    }

    #[test]
    fn markers_confirm_chunks_and_the_end_checks_errors() {
        let mut b = Bench::new(3, Some(1024));
        b.poll().unwrap();
        let n = b.run.plan.ends.len();
        for _ in 0..n {
            b.answer(lf("0")).unwrap();
        }
        assert_eq!(b.confirmed, n);
        b.poll().unwrap();
        assert!(b.data.ends_with(&sequence(&[Op::LastError, Op::Position])), "{:?}", String::from_utf8_lossy(&b.data));
        b.answer(lf("0")).unwrap();
        b.answer(lf("4000,500,0")).unwrap();
        assert_eq!(b.queries.last().map(Vec::as_slice), Some(Op::ExtendedError.bytes()));
        assert_eq!(b.answer(lf("0")).unwrap(), Some(Outcome::Finished));
    }

    #[test]
    fn an_error_answer_puts_the_error_in_its_stroke() {
        let mut b = Bench::new(3, Some(1024));
        b.poll().unwrap();
        b.answer(lf("0")).unwrap();
        let e = b.answer(lf("3")).unwrap_err();
        assert!(matches!(e, StreamError::Device(d) if d == DeviceError::at(ErrorCode::Hpgl(3), ErrorAt::Stroke(1))), "{e}");
        assert!(e.to_string().contains("error 3") && e.to_string().contains("stroke 1"), "{e}");
        assert_eq!(b.queries, [Op::Abort.bytes()], "what the device holds after it is dropped");
    }

    /// Fault 5: a power cycle mid-job was noticed only at the motion timeout
    /// (120 s). Silence while markers are due asks ESC.B; the power-cycled
    /// device answers with its power-on CR.
    #[test]
    fn a_power_cycle_mid_job_is_noticed_within_seconds() {
        let mut b = Bench::new(3, Some(1024));
        b.poll().unwrap();
        b.answer(lf("0")).unwrap();
        // The device loses its buffer: no more marker answers.
        b.idle(Duration::from_millis(1100), Duration::from_millis(100)).unwrap();
        assert_eq!(b.queries, [Op::FreeSpace.bytes()], "asked after a second of silence");
        let e = b.answer(cr("1024")).unwrap_err();
        assert!(matches!(e, StreamError::Reset(_)), "{e}");
        assert!(e.to_string().contains("power cycle"), "{e}");
        // A device that does not answer at all is a dead link, in seconds too.
        let mut b = Bench::new(3, Some(1024));
        b.poll().unwrap();
        let e = b.idle(Duration::from_secs(5), Duration::from_millis(100)).unwrap_err();
        assert!(matches!(e, StreamError::Timeout(Unanswered::Hpgl(Op::FreeSpace))), "{e}");
    }

    /// Fault 2: an answer must never confirm a marker it cannot belong to.
    /// A probe's answer is never taken for a marker's.
    #[test]
    fn probe_answers_never_confirm_a_marker() {
        let mut b = Bench::new(3, Some(1024));
        b.poll().unwrap();
        b.idle(Duration::from_millis(1100), Duration::from_millis(100)).unwrap();
        assert_eq!(b.queries.len(), 1);
        // ESC.B's answer is the free space, at least the margin: not an OE answer.
        b.answer(lf("980")).unwrap();
        assert_eq!(b.confirmed, 0);
        // The same free space again and nothing confirmed: ESC.O is asked.
        b.idle(Duration::from_millis(1100), Duration::from_millis(100)).unwrap();
        b.answer(lf("980")).unwrap();
        b.poll().unwrap();
        assert_eq!(b.queries.last().map(Vec::as_slice), Some(Op::ExtendedStatus.bytes()));
        // ESC.O says 0 (lever down, buffer not empty): indistinguishable
        // from a marker's 0, so it is not taken as one...
        b.answer(lf("0")).unwrap();
        assert_eq!(b.confirmed, 0, "a 0 while ESC.O is unanswered is not a confirmation");
        // ...but when it really was the marker's, ESC.O's own answer gives it back.
        b.answer(lf("8")).unwrap();
        assert_eq!(b.confirmed, 1);
        b.answer(lf("0")).unwrap();
        assert_eq!(b.confirmed, 2);
    }

    /// Fault 10: the paper lever up held the job "plotting" until the motion
    /// timeout. It is reported with the device's reason, no timeout runs
    /// while it lasts, and the run goes on when the lever is down.
    #[test]
    fn paper_lever_up_holds_the_run_with_the_device_reason() {
        let mut b = Bench::new(3, Some(1024));
        b.poll().unwrap();
        b.answer(lf("0")).unwrap();
        for _ in 0..2 {
            b.idle(Duration::from_millis(1100), Duration::from_millis(100)).unwrap();
            b.answer(lf("990")).unwrap();
        }
        b.poll().unwrap();
        assert_eq!(b.queries.last().map(Vec::as_slice), Some(Op::ExtendedStatus.bytes()));
        b.answer(lf("32")).unwrap();
        assert_eq!(b.held, [Some(Hold::PaperLever)]);
        // Ten minutes with the lever up: still held, still alive.
        for _ in 0..600 {
            b.idle(Duration::from_secs(1), Duration::from_millis(500)).unwrap();
            match b.queries.last().map(Vec::as_slice) {
                Some(q) if q == Op::ExtendedStatus.bytes() => b.answer(lf("32")).unwrap(),
                _ => b.answer(lf("990")).unwrap(),
            };
        }
        assert_eq!(b.held, [Some(Hold::PaperLever)]);
        // Lever down: the device answers the marker, the run goes on.
        b.answer(lf("0")).unwrap();
        assert_eq!(b.held, [Some(Hold::PaperLever), None]);
        assert_eq!(b.confirmed, 2);
    }

    /// Fault 9: a stop waited for the end of the stroke. A stop now drops
    /// the device's buffer, lifts the pen and ends once the device says
    /// which markers it ran; the dropped ones confirm nothing.
    #[test]
    fn a_stop_now_drops_the_buffer_and_confirms_only_what_ran() {
        let mut b = Bench::new(6, Some(1024));
        b.poll().unwrap();
        assert_eq!(b.markers(), 6, "all six strokes in the device's buffer");
        b.answer(lf("0")).unwrap();
        b.run.stop(Stop::Now, b.now);
        b.drain();
        assert_eq!(b.queries, [Op::Abort.bytes()], "the buffer dropped at once");
        let tail = String::from_utf8_lossy(&b.data).into_owned();
        let lifted = [b"PU;".as_slice(), Op::Identify.bytes()].concat();
        assert!(b.data.ends_with(&lifted), "the pen lifted (its letter ends a half-read instruction), then OI: {tail:?}");
        // The second stroke's marker was answered before ESC.K arrived.
        b.answer(lf("0")).unwrap();
        assert_eq!(b.answer(lf("7475A")).unwrap(), None);
        assert_eq!(b.confirmed, 2, "the four dropped markers confirm nothing");
        assert_eq!(b.queries.last().map(Vec::as_slice), Some(Op::ExtendedError.bytes()));
        assert_eq!(b.answer(lf("0")).unwrap(), Some(Outcome::Stopped));
        // Nothing more is written after the stop.
        let len = b.data.len();
        b.idle(Duration::from_secs(1), Duration::from_millis(100)).unwrap();
        assert_eq!(b.data.len(), len);
    }

    /// A stop now before the set-up has sized the buffer writes nothing of
    /// the job.
    #[test]
    fn a_stop_now_before_streaming_writes_nothing_of_the_job() {
        let mut b = Bench::new(3, None);
        b.run.stop(Stop::Now, b.now);
        b.answer(lf("7475A")).unwrap();
        b.answer(lf("1024")).unwrap();
        b.answer(lf("8")).unwrap();
        b.poll().unwrap();
        assert_eq!(b.markers(), 1, "only the end's OE: {:?}", String::from_utf8_lossy(&b.data));
        b.answer(lf("0")).unwrap();
        b.answer(lf("0,0,0")).unwrap();
        assert_eq!(b.answer(lf("0")).unwrap(), Some(Outcome::Stopped));
        assert_eq!(b.confirmed, 0);
    }

    #[test]
    fn no_progress_for_the_motion_timeout_is_a_timeout() {
        let mut b = Bench::new(3, Some(1024));
        b.poll().unwrap();
        let t0 = b.now;
        let mut free = 900;
        // The device takes bytes for a minute (a slow stroke), then stands
        // still with the lever down and answers no marker.
        let e = loop {
            b.wait(Duration::from_millis(500));
            if let Err(e) = b.poll() {
                break e;
            }
            for q in std::mem::take(&mut b.queries) {
                if q == Op::FreeSpace.bytes() && b.now - t0 < Duration::from_secs(60) {
                    free += 1;
                }
                let answer = if q == Op::ExtendedStatus.bytes() { 0 } else { free };
                b.answer(lf(&answer.to_string())).unwrap();
            }
            assert!(b.now - t0 < Duration::from_secs(300), "no timeout");
        };
        assert!(matches!(e, StreamError::Timeout(Unanswered::Hpgl(Op::LastError))), "{e}");
        assert!(b.now - t0 >= Duration::from_secs(175), "progress for a minute, then the motion timeout: {:?}", b.now - t0);
        assert_eq!(b.confirmed, 0);
    }

    /// Seen on a loaded machine: an ESC.B asked while the last stroke ran
    /// was answered after the end's `OE` and `OA`, once ESC.E had been
    /// asked, and its free space (1024) was taken for ESC.E's error code:
    /// the finished job paused "device error: ESC.E error 1024". Escape
    /// sequences are answered in the order they arrive, so the first number
    /// after ESC.E while a probe is unanswered is the probe's.
    #[test]
    fn a_probe_answered_after_the_end_is_not_taken_for_esc_e() {
        let caps = HpglCapabilities { extended_status: false, ..HpglCapabilities::FULL };
        let mut b = Bench::with(&program(2), Some(1024), Some(caps));
        b.poll().unwrap();
        b.answer(lf("0")).unwrap();
        // Silence while the last stroke runs: ESC.B asked.
        b.wait(Duration::from_secs(2));
        b.poll().unwrap();
        assert_eq!(b.queries.last().map(Vec::as_slice), Some(Op::FreeSpace.bytes()));
        // The stroke's marker, then the end's OE and OA, before ESC.B's answer.
        b.answer(lf("0")).unwrap();
        b.poll().unwrap();
        b.answer(lf("0")).unwrap();
        b.answer(lf("100,0,0")).unwrap();
        assert_eq!(b.queries.last().map(Vec::as_slice), Some(Op::ExtendedError.bytes()));
        assert_eq!(b.answer(lf("1024")).unwrap(), None, "ESC.B's answer, not ESC.E's");
        assert_eq!(b.answer(lf("0")).unwrap(), Some(Outcome::Finished));
        assert_eq!(b.confirmed, 2);
    }

    /// On a slow link ESC.L's answer came after its reply timeout, once
    /// ESC.B had been asked instead, and ESC.B's answer (the idle buffer's
    /// 1024 bytes, a multiple of 8) came while ESC.O was asked: it was taken
    /// for ESC.O's, and a clone without ESC.O was then asked it mid-job. An
    /// extended status is one byte, so a number over 255 is never its answer.
    #[test]
    fn a_late_size_answer_is_not_taken_for_esc_o() {
        let mut b = Bench::new(3, None);
        b.answer(lf("7475A")).unwrap();
        b.idle(timing().reply_timeout + Duration::from_millis(200), Duration::from_millis(100)).unwrap();
        assert_eq!(b.queries.last().map(Vec::as_slice), Some(Op::FreeSpace.bytes()), "ESC.B asked for the size");
        b.answer(lf("1024")).unwrap();
        assert_eq!(b.queries.last().map(Vec::as_slice), Some(Op::ExtendedStatus.bytes()), "ESC.O asked once the size is known");
        b.answer(lf("1024")).unwrap();
        b.idle(timing().reply_timeout + Duration::from_millis(200), Duration::from_millis(100)).unwrap();
        assert!(!b.run.capabilities().unwrap().extended_status, "ESC.O unanswered: {:?}", b.run.capabilities());
        assert_eq!(b.markers(), 3, "streaming");
    }
}
