//! The handshakes, and the checkpoint rule.
//!
//! A run streams chunks `from..until` of a [`Program`] and calls back with the
//! new checkpoint each time the device confirms it got past a chunk:
//! - HP-GL, every handshake (`escb`, `xonxoff`, `hardware`): an in-band `OE`
//!   follows each chunk (ended by the next chunk's first letter when that
//!   chunk fits the window beside it, else by `;`, also written when a stop
//!   leaves the run waiting on it: two bytes a stroke, not three, about 3 %
//!   of a 9600-baud line). The device answers it when it executes it, so an
//!   answer of 0 confirms exactly that chunk, and a non-zero one puts the
//!   device's error in exactly that chunk (the checkpoint stays on it). An
//!   answer sent before a power cut still arrives, so after a power cycle
//!   only the stroke in flight is drawn again. Bytes written and not yet
//!   confirmed stay under [`StreamSettings::hpgl_window`] and under the
//!   buffer size (ESC.L, or ESC.B when idle) minus
//!   [`StreamSettings::escb_margin`]: since everything confirmed has left the
//!   buffer, that is never more than the free space ESC.B would report, with
//!   no poll, and the buffer cannot overflow whatever the handshake lines do
//!   (a pty has no CTS). XOFF is honoured on top. ESC.B polls are not used
//!   while streaming: their numeric answers could not be told apart from the
//!   markers'.
//! - `grbl`: character counting against the receive buffer (size from `$I`),
//!   one `ok` per line. A `G4P0` follows each chunk: GRBL answers a motion
//!   line once it is *planned*, but a dwell only once the planner has
//!   drained, so its `ok` confirms the chunk drawn (an `ok` for the chunk's
//!   last line could come strokes before the pen got there, and a power cut
//!   would lose them). `?` polls status while waiting, and at the end until
//!   the board is `Idle`.
//!
//! A stop request finishes the chunk being written, waits for the device to
//! confirm everything written, lifts the pen and returns [`Outcome::Stopped`].
//!
//! Around every write the run reports a [`Written`] mark (HP-GL writes go
//! one whole chunk at a time, except a chunk longer than the window), and
//! after an interruption [`Streamer::locate`] asks the device where its pen
//! rests, which tells how far it got in what was written, so plotting can go
//! on past the checkpoint.

use super::grbl::{Action, GrblRun, Timing, GRBL_MARKER};
use super::plan::Plan;
use super::{Link, StreamError, Written};
use crate::config::Handshake;
use plotcode::{PenAt, Program, Protocol};
use std::time::Duration;
use strokes::DVec2;
use tokio::io::{AsyncRead, AsyncWrite};
use tokio::sync::watch;
use tokio::time::Instant;

/// Follows every HP-GL chunk: the device answers it when it has executed the
/// chunk, with the number of the last instruction error (0: none).
const HPGL_MARKER: &[u8] = b"OE;";
/// The marker before a chunk that starts with a letter and fits beside it in
/// the window: the next mnemonic ends `OE` (HP-GL syntax), a byte saved per
/// stroke. The device answers it only once that letter comes, so a run that
/// stops or waits there (a pause, XON) writes the `;`.
const HPGL_CHAINED_MARKER: &[u8] = b"OE";
/// Unrecognised answers tolerated in one run before the link counts as garbled.
const MAX_NOISE: usize = 8;
/// Largest difference, in device units, between where the device says its
/// pen is and where a chunk leaves it, for the two to agree: HP-GL `OA`
/// answers whole plotter units, and chunk ends may be fractional.
const POSITION_TOLERANCE: f64 = 1.0;
/// The same for G-code, in millimetres: GRBL reports three decimals.
const GCODE_POSITION_TOLERANCE: f64 = 0.01;

/// Where a run reports what it did.
pub trait RunObserver: Send {
    /// Chunks `..k` are confirmed executed: the new checkpoint.
    fn confirmed(&mut self, k: usize);
    /// How far the job has been handed to the device; called before and
    /// after every write of job bytes.
    fn written(&mut self, _mark: Written) {}
}

impl<F: FnMut(usize) + Send> RunObserver for F {
    fn confirmed(&mut self, k: usize) {
        self(k);
    }
}

/// How a run ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// Every chunk up to `until` is confirmed.
    Finished,
    /// A stop was requested; the pen is up and every chunk written is confirmed.
    Stopped,
}

/// Tuning of the handshakes.
#[derive(Clone, Debug)]
pub struct StreamSettings {
    /// Flow control.
    pub handshake: Handshake,
    /// Longest wait for an immediate answer (ESC.B, `?`, `$I`).
    pub reply_timeout: Duration,
    /// Longest wait for an answer that waits on motion (OA, `ok`).
    pub motion_timeout: Duration,
    /// Bytes of free space left unused under ESC.B, against miscounting.
    pub escb_margin: usize,
    /// Pause between polls when the device buffer is full.
    pub poll_interval: Duration,
    /// GRBL: how long the board may report `Idle` with lines in flight and
    /// nothing answered before the run counts it stalled.
    pub stall_after: Duration,
    /// GRBL receive buffer size when `$I` does not say.
    pub grbl_rx_default: usize,
    /// HP-GL: most bytes written and not yet confirmed executed. Bytes the
    /// device has run but not yet confirmed are drawn again after a power cut;
    /// this bounds them while covering the answer's round trip at the line rate.
    pub hpgl_window: usize,
}

impl StreamSettings {
    /// Defaults for `handshake`.
    #[must_use]
    pub fn new(handshake: Handshake) -> Self {
        StreamSettings {
            handshake,
            reply_timeout: Duration::from_secs(2),
            motion_timeout: Duration::from_secs(120),
            escb_margin: 16,
            poll_interval: Duration::from_millis(20),
            stall_after: Duration::from_secs(5),
            grbl_rx_default: 128,
            hpgl_window: 256,
        }
    }
}

/// What a streamer measured, for benchmarks and status.
#[derive(Clone, Debug, Default)]
pub struct StreamStats {
    /// Job bytes written (queries and HP-GL markers excluded).
    pub bytes: u64,
    /// Time spent in runs.
    pub busy: Duration,
    /// Device buffer size learnt from the device.
    pub buffer_size: Option<usize>,
    /// GRBL: integral of bytes in the receive buffer over time (byte-seconds).
    pub fill_integral: f64,
    /// GRBL: time over which [`Self::fill_integral`] was taken.
    pub fill_time: f64,
}

impl StreamStats {
    /// GRBL: the receive buffer's average fill, 0..=1.
    #[must_use]
    pub fn average_fill(&self) -> Option<f64> {
        let size = self.buffer_size? as f64;
        (self.fill_time > 0.0).then(|| self.fill_integral / self.fill_time / size)
    }
}

/// Streams programs to one device over one open link.
#[derive(Debug)]
pub struct Streamer<T> {
    /// The connection.
    pub link: Link<T>,
    /// Tuning.
    pub settings: StreamSettings,
    /// Measurements.
    pub stats: StreamStats,
    /// The device's buffer size, once learnt (per link).
    buffer: Option<usize>,
    /// Lift the pen at the end of the current run (a pen change follows).
    lift: bool,
}

/// Confirmation bookkeeping shared by the handshakes.
struct Confirm {
    /// Chunks (relative to the plan) confirmed.
    done: usize,
}

impl Confirm {
    fn advance(&mut self, to: usize, plan: &Plan, on_confirm: &mut dyn RunObserver) {
        if to > self.done {
            self.done = to;
            on_confirm.confirmed(plan.from + to);
        }
    }
}

fn parse_int(line: &str) -> Option<i64> {
    line.trim().parse().ok()
}

impl<T: AsyncRead + AsyncWrite + Unpin> Streamer<T> {
    /// A streamer on a freshly opened link.
    pub fn new(io: T, settings: StreamSettings) -> Self {
        Streamer { link: Link::new(io), settings, stats: StreamStats::default(), buffer: None, lift: false }
    }

    /// Streams chunks `from..until` of `program`. With `resume`, the device is
    /// first given the state it had at chunk `from` (pen up, modal state,
    /// position); with `lift`, the pen is lifted after the last chunk.
    /// `on_confirm` hears each new checkpoint `k` (chunks `..k` executed) and
    /// the [`Written`] mark around every write. `stop` becoming true asks for a stop at the
    /// next stroke boundary.
    ///
    /// # Errors
    /// [`StreamError`]; chunks confirmed before it stay confirmed.
    // The streamer's loop state comes in as arguments until the handshakes
    // become state machines of their own (issue #15).
    #[allow(clippy::too_many_arguments)]
    pub async fn run(
        &mut self,
        program: &Program,
        from: usize,
        until: usize,
        resume: bool,
        lift: bool,
        stop: &mut watch::Receiver<bool>,
        on_confirm: &mut dyn RunObserver,
    ) -> Result<Outcome, StreamError> {
        let started = Instant::now();
        self.lift = lift;
        let until = until.min(program.chunks.len());
        let from = from.min(until);
        let r = match (self.settings.handshake, program.protocol) {
            (Handshake::Grbl, _) | (_, Protocol::Gcode) => self.run_grbl(program, from, until, resume, stop, on_confirm).await,
            (Handshake::Escb | Handshake::Xonxoff | Handshake::Hardware, Protocol::Hpgl) => {
                self.run_hpgl(program, from, until, resume, stop, on_confirm).await
            }
        };
        self.stats.busy += started.elapsed();
        if r.is_err() {
            // Answers to what this run wrote may still come: the next run
            // syncs the link again before it trusts one.
            self.buffer = None;
        }
        r
    }

    fn stopping(stop: &watch::Receiver<bool>) -> bool {
        *stop.borrow()
    }

    /// Sends a device-control query (not buffered by the device) and reads its
    /// numeric answer.
    async fn query_number(&mut self, q: &[u8], what: &str) -> Result<i64, StreamError> {
        for _ in 0..3 {
            self.link.write_query(q).await?;
            let deadline = Instant::now() + self.settings.reply_timeout;
            let line = self.link.line_until(deadline, what).await?;
            self.check_reset()?;
            if let Some(n) = parse_int(&line) {
                return Ok(n);
            }
            // Noise instead of the answer: ask again.
            tracing::warn!(answer = %line, "unexpected answer to {what}");
        }
        Err(StreamError::Garbled(format!("no number in answers to {what}")))
    }

    fn check_reset(&self) -> Result<(), StreamError> {
        if self.link.reset_seen {
            return Err(StreamError::Reset("the plotter lost its settings (power cycle?)".into()));
        }
        Ok(())
    }

    /// After an interruption (daemon restart, link lost), finds out how far
    /// the device got between the confirmed `checkpoint` and what `mark`
    /// says was written: its answers still end as this daemon set them up
    /// (no power cycle or reset since), its buffer drained, and its pen at
    /// rest where exactly one of those chunks leaves it ([`first_match`]).
    /// Returns the chunk to resume from (one the pen stopped inside is drawn
    /// again); `None` when anything disagrees or cannot be read: resume from
    /// the checkpoint. Whatever the device still held is dropped (ESC.K)
    /// before this returns.
    ///
    /// # Errors
    /// [`StreamError::Offline`] when the port is gone;
    /// [`StreamError::Device`] when the device reports an error left by
    /// bytes whose answers were lost (HP-GL `ESC.E` or `OE` not 0, GRBL in
    /// alarm).
    pub async fn locate(&mut self, program: &Program, checkpoint: usize, mark: Written) -> Result<Option<usize>, StreamError> {
        let found = match (self.settings.handshake, program.protocol) {
            (Handshake::Grbl, _) | (_, Protocol::Gcode) => self.grbl_locate(program, checkpoint, mark).await,
            (Handshake::Escb | Handshake::Xonxoff | Handshake::Hardware, Protocol::Hpgl) => {
                self.hpgl_locate(program, checkpoint, mark).await
            }
        };
        match found {
            Err(e @ (StreamError::Offline(_) | StreamError::Device(_))) => {
                self.buffer = None;
                Err(e)
            }
            Err(e) => {
                tracing::info!(error = %e, "cannot tell where the device got; resuming from the checkpoint");
                self.buffer = None;
                Ok(None)
            }
            Ok(None) => {
                tracing::info!(checkpoint, ?mark, "the device is not where a chunk written leaves it; resuming from the checkpoint");
                self.buffer = None;
                Ok(None)
            }
            Ok(Some(k)) => {
                tracing::info!(checkpoint, ?mark, resume_at = k, "found where the device got");
                Ok(Some(k))
            }
        }
    }

    async fn hpgl_locate(&mut self, program: &Program, checkpoint: usize, mark: Written) -> Result<Option<usize>, StreamError> {
        // The LF terminator (ESC.M) the last session set survives anything
        // but a power cycle or a handshake reset: a CR on any answer is one.
        self.link.expect_lf = true;
        self.link.reset_seen = false;
        let size = self.sync_number(b"\x1b.L", "ESC.L", 2 * self.settings.escb_margin + 1).await?;
        let deadline = Instant::now() + self.settings.motion_timeout;
        loop {
            let free = self.query_number(b"\x1b.B", "ESC.B").await?;
            if usize::try_from(free).is_ok_and(|f| f >= size) {
                break;
            }
            if Instant::now() >= deadline {
                return Ok(None);
            }
            tokio::time::sleep(self.settings.poll_interval).await;
        }
        // The buffer is empty: only a half-written instruction (of the chunk
        // being written) can be left in the parser; drop it before asking.
        self.link.write_query(b"\x1b.K").await?;
        // Answers to the last run's markers may have come between the ESC.B
        // answers and put them out of step: the identification, not a
        // number, comes after everything asked before it.
        self.link.write_query(b"OI;").await?;
        let deadline = Instant::now() + self.settings.motion_timeout;
        loop {
            let line = self.link.line_until(deadline, "OI").await?;
            self.check_reset()?;
            if line.bytes().any(|b| b.is_ascii_alphabetic()) {
                break;
            }
        }
        // An I/O error, or an instruction error after the last marker that
        // ran (its answer was never read), is the device's word on bytes of
        // this job: the job stops with it rather than going on silently.
        let e = self.query_number(b"\x1b.E", "ESC.E").await?;
        if e != 0 {
            return Err(StreamError::Device(format!("ESC.E error {e} ({})", escb_error_text(e))));
        }
        self.link.write_query(b"OE;OA;").await?;
        let deadline = Instant::now() + self.settings.motion_timeout;
        let oe = loop {
            let line = self.link.line_until(deadline, "OE").await?;
            self.check_reset()?;
            if let Some(n) = parse_int(&line) {
                break n;
            }
        };
        let at: Vec<f64> = loop {
            let line = self.link.line_until(deadline, "OA").await?;
            self.check_reset()?;
            let v: Vec<f64> = line.split(',').filter_map(|w| w.trim().parse().ok()).collect();
            if v.len() == 3 {
                break v;
            }
        };
        if oe != 0 {
            return Err(StreamError::Device(format!("HP-GL error {oe} ({})", hpgl_error_text(oe))));
        }
        let rest = Rest { pos: DVec2::new(at[0], at[1]), down: Some(at[2] != 0.0), z: None, tolerance: POSITION_TOLERANCE };
        Ok(first_match(program, checkpoint, mark, &rest))
    }

    /// HP-GL link set-up, once per open port: whatever the device still holds
    /// from an earlier session is dropped (ESC.K: the checkpoint, not the
    /// leftovers, decides what is drawn next), answers end with LF (so a power
    /// cycle shows), XON/XOFF is set up when that is the handshake, and the
    /// buffer size is read with ESC.L.
    async fn hpgl_init(&mut self) -> Result<usize, StreamError> {
        if let Some(b) = self.buffer {
            return Ok(b);
        }
        self.link.write_query(b"\x1b.K\x1b.M;;;10:").await?;
        if self.settings.handshake == Handshake::Xonxoff {
            // XOFF when fewer than 128 bytes are free; XON (DC1) / XOFF (DC3) characters.
            self.link.write_query(b"\x1b.I128;;17:\x1b.N;19:").await?;
        }
        let min = 2 * self.settings.escb_margin + 1;
        // Answers to an earlier session's markers (small numbers, OA triples,
        // CR-terminated after a power cycle) may come first; the line answers
        // in order, so nothing of theirs follows the size.
        let size = match self.sync_number(b"\x1b.L", "ESC.L", min).await {
            Ok(n) => n,
            Err(e @ StreamError::Offline(_)) => return Err(e),
            // Older firmware may not answer ESC.L; an idle device's free space is its size.
            Err(_) => self.sync_number(b"\x1b.B", "ESC.B", min).await?,
        };
        self.link.expect_lf = true;
        self.link.reset_seen = false;
        self.buffer = Some(size);
        self.stats.buffer_size = Some(size);
        Ok(size)
    }

    /// Sends `q` and reads lines until one is a number of at least `min`;
    /// other lines are stale and dropped.
    async fn sync_number(&mut self, q: &[u8], what: &str, min: usize) -> Result<usize, StreamError> {
        self.link.write_query(q).await?;
        let deadline = Instant::now() + self.settings.reply_timeout;
        loop {
            let line = self.link.line_until(deadline, what).await?;
            match parse_int(&line).and_then(|n| usize::try_from(n).ok()) {
                Some(n) if n >= min => return Ok(n),
                _ => tracing::debug!(answer = %line, "dropped stale answer before {what}"),
            }
        }
    }

    /// HP-GL end of run: `OE;OA;` must come back (everything before them is
    /// done) and OE must be 0.
    async fn hpgl_finish(&mut self) -> Result<(), StreamError> {
        self.link.write(b"OE;OA;").await?;
        self.stats.bytes += 6;
        let deadline = Instant::now() + self.settings.motion_timeout;
        let mut oe = None;
        for _ in 0..8 {
            let line = self.link.line_until(deadline, "OE;OA;").await?;
            self.check_reset()?;
            if oe.is_none() {
                match parse_int(&line) {
                    Some(n) => oe = Some(n),
                    None => continue,
                }
            } else if line.split(',').count() == 3 {
                if let Some(n) = oe.filter(|&n| n != 0) {
                    return Err(StreamError::Device(format!("HP-GL error {n} ({})", hpgl_error_text(n))));
                }
                // Device-control and I/O errors (overrun, framing) are kept apart.
                let e = self.query_number(b"\x1b.E", "ESC.E").await?;
                if e != 0 {
                    return Err(StreamError::Device(format!("ESC.E error {e} ({})", escb_error_text(e))));
                }
                return Ok(());
            }
        }
        Err(StreamError::Garbled("no OA answer".into()))
    }

    /// HP-GL, every handshake: each chunk is followed by an in-band `OE`,
    /// which the device answers when it executes it, so an answer of 0
    /// confirms exactly that chunk and a non-zero answer puts the error in it.
    /// Bytes written and not yet confirmed stay under the window, which is
    /// under the free space the device reported (ESC.L minus the margin), so
    /// the buffer cannot overflow whatever the handshake lines do (a pty has
    /// no CTS); XOFF is honoured on top.
    async fn run_hpgl(
        &mut self,
        program: &Program,
        from: usize,
        until: usize,
        resume: bool,
        stop: &mut watch::Receiver<bool>,
        on_confirm: &mut dyn RunObserver,
    ) -> Result<Outcome, StreamError> {
        let size = self.hpgl_init().await?;
        let window = (size - self.settings.escb_margin).min(self.settings.hpgl_window);
        let mut plan = Plan::new(program, from, until, resume, HPGL_MARKER, Some((HPGL_CHAINED_MARKER, window)));
        plan.lift = self.lift;
        let mut sent = 0usize;
        let mut ok = Confirm { done: 0 };
        // Lines that answered nothing we asked: maybe a garbled marker answer.
        let mut noise = 0usize;
        // An `OA;` written to resynchronise after noise: chunks written before it.
        let mut resync: Option<usize> = None;
        let mut last_heard = Instant::now();
        // Bytes ESC.B said may still be written (inside a chunk longer than the window).
        let mut credit = 0usize;
        // The chunk whose open marker was ended with a `;`.
        let mut ended: Option<usize> = None;
        loop {
            self.link.poll_input().await?;
            let written_chunks = plan.ends.iter().take_while(|&&e| e <= sent).count();
            while let Some(line) = self.link.take_line() {
                // An answer after a power cycle says nothing about what ran before it.
                self.check_reset()?;
                last_heard = Instant::now();
                if line.split(',').count() == 3 {
                    // The resync OA: everything written before it has run.
                    if let Some(upto) = resync.take() {
                        ok.advance(upto, &plan, on_confirm);
                        noise = 0;
                    }
                    continue;
                }
                match parse_int(&line) {
                    Some(0) if ok.done < written_chunks => ok.advance(ok.done + 1, &plan, on_confirm),
                    Some(n) if n > 0 && ok.done < written_chunks => {
                        // Drop what the device holds after the failed stroke, so
                        // that it stops as near to it as the line allows.
                        self.link.write_query(b"\x1b.K").await?;
                        return Err(StreamError::Device(format!(
                            "HP-GL error {n} ({}) in stroke {}",
                            hpgl_error_text(n),
                            plan.from + ok.done
                        )));
                    }
                    _ => {
                        tracing::warn!(answer = %line, "unexpected HP-GL answer");
                        noise += 1;
                        if noise > MAX_NOISE {
                            return Err(StreamError::Garbled(line));
                        }
                    }
                }
            }
            let stopping = Self::stopping(stop);
            let limit = plan.limit(sent, stopping);
            if sent == limit && ok.done == written_chunks {
                if limit < plan.data.len() || plan.lift {
                    self.link.write(&program.pen_up).await?;
                }
                self.hpgl_finish().await?;
                return Ok(if limit < plan.data.len() { Outcome::Stopped } else { Outcome::Finished });
            }
            let confirmed_at = if ok.done == 0 { 0 } else { plan.ends[ok.done - 1] };
            // One chunk per write, and a chunk only when all of it fits (one
            // longer than the window goes in pieces): so the written mark
            // says exactly which chunk the device may hold in part.
            let chunk_start = if written_chunks == 0 { 0 } else { plan.ends[written_chunks - 1] };
            let chunk_end = plan.ends.get(written_chunks).map_or(limit, |&e| e.min(limit));
            let room = window.saturating_sub(sent - confirmed_at).max(credit);
            let room = if chunk_end - sent <= room || chunk_end - chunk_start > window { room } else { 0 };
            if room == 0 && ok.done == written_chunks && sent < limit && !self.link.xoff() && resync.is_none() {
                // A chunk longer than the window: no marker answer is due, so
                // an ESC.B answer cannot be mistaken for one; write into the
                // free space it reports.
                let free = self.query_number(b"\x1b.B", "ESC.B").await?;
                credit = usize::try_from(free).unwrap_or(0).min(size).saturating_sub(self.settings.escb_margin);
                if credit == 0 {
                    tokio::select! {
                        _ = tokio::time::sleep(self.settings.poll_interval) => {}
                        _ = stop.changed(), if !stopping => {}
                    }
                }
                continue;
            }
            let blocked = self.link.xoff() || sent == limit || room == 0;
            if blocked {
                let last = written_chunks.wrapping_sub(1);
                if ok.done == last
                    && ended != Some(last)
                    && !self.link.xoff()
                    && plan.ends.get(last) == Some(&sent)
                    && plan.open_marker(last, HPGL_MARKER)
                {
                    // Only the last marker is unanswered, and the letter that
                    // would end it is not coming now (a stop request moved
                    // the limit). At most one such `;` is in the buffer
                    // unconfirmed: the margin covers it.
                    self.link.write(b";").await?;
                    ended = Some(last);
                }
                if ok.done == written_chunks && !self.link.xoff() {
                    last_heard = Instant::now();
                }
                if noise > 0 && resync.is_none() && Instant::now() - last_heard > self.settings.reply_timeout {
                    // A marker answer may have been garbled: an OA round trip
                    // says when everything written so far has run.
                    self.link.write(b"OA;").await?;
                    resync = Some(written_chunks);
                }
                let deadline = last_heard + self.settings.motion_timeout;
                tokio::select! {
                    r = self.link.fill(deadline) => {
                        if !r? {
                            return Err(StreamError::Timeout(if self.link.xoff() { "XOFF (never XON)".into() } else { "OE".into() }));
                        }
                    }
                    _ = stop.changed(), if !stopping => {}
                }
                continue;
            }
            if written_chunks == ok.done {
                last_heard = Instant::now();
            }
            let n = (chunk_end - sent).min(room);
            on_confirm.written(Written::Into(plan.from + written_chunks));
            self.link.write(&plan.data[sent..sent + n]).await?;
            if sent + n == chunk_end {
                on_confirm.written(Written::Through(plan.from + written_chunks + 1));
            }
            self.stats.bytes += (plan.payload(sent + n) - plan.payload(sent)) as u64;
            sent += n;
            credit = credit.saturating_sub(n);
        }
    }

    async fn grbl_rx(&mut self) -> Result<usize, StreamError> {
        if let Some(b) = self.buffer {
            return Ok(b);
        }
        let rx = self.grbl_sync().await?.0;
        self.grbl_unlock().await?;
        self.buffer = Some(rx);
        self.stats.buffer_size = Some(rx);
        Ok(rx)
    }

    /// Reads the receive buffer size from `$I`; every answer before the
    /// report answers an earlier run's lines, so the link is in step after.
    /// Also returns the last `ALARM:N` among those earlier answers: the
    /// reason of an alarm the board may still be in.
    async fn grbl_sync(&mut self) -> Result<(usize, Option<String>), StreamError> {
        let mut rx = self.settings.grbl_rx_default;
        let mut alarm = None;
        // `ok`s before the `$I` report answer an earlier session's lines.
        let mut reported = false;
        // A board that has just been powered ignores input while it boots: ask again.
        let mut asked = 0;
        let mut deadline = Instant::now();
        loop {
            if Instant::now() >= deadline && !reported {
                if asked == 3 {
                    return Err(StreamError::Timeout("$I".into()));
                }
                self.link.write_query(b"$I\n").await?;
                asked += 1;
                deadline = Instant::now() + self.settings.reply_timeout / 3;
            }
            let line = match self.link.line_until(deadline, "$I").await {
                Err(StreamError::Timeout(_)) if !reported => continue,
                r => r?,
            };
            if line.starts_with("[VER:") {
                reported = true;
            } else if let Some(opt) = line.strip_prefix("[OPT:") {
                reported = true;
                if let Some(n) = opt.trim_end_matches(']').split(',').nth(2).and_then(|s| s.trim().parse().ok()) {
                    rx = n;
                }
            } else if line == "ok" && reported {
                break;
            } else if line.starts_with("error:") && reported {
                return Err(StreamError::Device(format!("GRBL {line}")));
            } else if line.starts_with("ALARM:") {
                // An earlier run's: the board may still be in that alarm.
                alarm = Some(line);
            }
            // Other answers before the report answer an earlier run's lines.
        }
        if rx < 16 {
            return Err(StreamError::Garbled(format!("receive buffer of {rx} bytes")));
        }
        Ok((rx, alarm))
    }

    /// The next status report (`<...>`), asking up to three times; `None`
    /// when none comes.
    async fn grbl_status(&mut self) -> Result<Option<String>, StreamError> {
        for _ in 0..3 {
            self.link.write_query(b"?").await?;
            let deadline = Instant::now() + self.settings.reply_timeout / 3;
            loop {
                match self.link.line_until(deadline, "?").await {
                    Ok(line) if line.starts_with('<') => return Ok(Some(line)),
                    Ok(_) => {}
                    Err(StreamError::Timeout(_)) => break,
                    Err(e) => return Err(e),
                }
            }
        }
        Ok(None)
    }

    /// GRBL side of [`Self::locate`]: idle (planner drained, nothing
    /// executing), its modal feed not the power-on 0 (a power cycle or reset
    /// since would show), and the tool at rest where a chunk written leaves
    /// it, the pen too: a servo's as the spindle state (`$G`), a Z axis's as
    /// `MPos` z. A board in alarm is an error: the job stops with it.
    async fn grbl_locate(&mut self, program: &Program, checkpoint: usize, mark: Written) -> Result<Option<usize>, StreamError> {
        self.buffer = None;
        let alarm = self.grbl_sync().await?.1;
        let deadline = Instant::now() + self.settings.motion_timeout;
        let status = loop {
            let Some(status) = self.grbl_status().await? else { return Ok(None) };
            if status.starts_with("<Idle") {
                break status;
            }
            if status.starts_with("<Alarm") {
                let text = alarm.map_or_else(|| format!("GRBL in alarm ({status})"), |a| grbl_alarm_message(&a));
                return Err(StreamError::Device(text));
            }
            if !status.starts_with("<Run") || Instant::now() >= deadline {
                return Ok(None);
            }
            tokio::time::sleep(self.settings.poll_interval).await;
        };
        let at: Option<Vec<f64>> = status.trim_matches(|c| c == '<' || c == '>').split('|').find_map(|f| {
            let v = f.strip_prefix("MPos:").or_else(|| f.strip_prefix("WPos:"))?;
            v.split(',').map(|w| w.trim().parse().ok()).collect()
        });
        let Some(at) = at.filter(|v| v.len() >= 2) else { return Ok(None) };
        // `[GC:G1 G54 G17 G21 G90 G94 M3 M9 T0 F3000 S1000]`: the feed rate
        // the job set survives everything but a reset; M3 with S above 0 is
        // a pen on a servo down.
        self.link.write_query(b"$G\n").await?;
        let deadline = Instant::now() + self.settings.reply_timeout;
        let (mut feed, mut spindle_on, mut speed) = (None, None, 0.0);
        loop {
            let line = self.link.line_until(deadline, "$G").await?;
            if let Some(gc) = line.strip_prefix("[GC:") {
                for w in gc.trim_end_matches(']').split_whitespace() {
                    match w {
                        "M3" | "M4" => spindle_on = Some(true),
                        "M5" => spindle_on = Some(false),
                        _ => {}
                    }
                    let number = |prefix: char| w.strip_prefix(prefix)?.parse::<f64>().ok();
                    feed = number('F').or(feed);
                    speed = number('S').unwrap_or(speed);
                }
            } else if line == "ok" {
                break;
            } else if line.starts_with("ALARM") {
                return Err(StreamError::Device(grbl_alarm_message(&line)));
            } else if line.starts_with("error:") {
                return Ok(None);
            }
        }
        if !feed.is_some_and(|f| f > 0.0) {
            return Ok(None);
        }
        let Some(spindle_on) = spindle_on else { return Ok(None) };
        let rest = Rest {
            pos: DVec2::new(at[0], at[1]),
            down: Some(spindle_on && speed > 0.0),
            z: at.get(2).copied(),
            tolerance: GCODE_POSITION_TOLERANCE,
        };
        Ok(first_match(program, checkpoint, mark, &rest))
    }

    /// A board left in alarm (a limit switch, a reset in motion) is locked
    /// and answers G-code with `error:9`: unlock it with `$X`. The resume
    /// prefix then sets the modal state and the position again.
    async fn grbl_unlock(&mut self) -> Result<(), StreamError> {
        let Some(status) = self.grbl_status().await? else { return Err(StreamError::Timeout("GRBL status poll".into())) };
        if !status.starts_with("<Alarm") {
            return Ok(());
        }
        tracing::info!(%status, "GRBL in alarm: unlocking with $X");
        self.link.write_query(b"$X\n").await?;
        let deadline = Instant::now() + self.settings.reply_timeout;
        loop {
            let line = self.link.line_until(deadline, "$X").await?;
            if line == "ok" {
                return Ok(());
            }
            if line.starts_with("error:") || line.starts_with("ALARM") {
                return Err(StreamError::Device(format!("GRBL {line} (unlocking with $X)")));
            }
        }
    }

    /// GRBL: the character-counting state machine ([`GrblRun`]) fed from the
    /// link until it ends.
    async fn run_grbl(
        &mut self,
        program: &Program,
        from: usize,
        until: usize,
        resume: bool,
        stop: &mut watch::Receiver<bool>,
        on_confirm: &mut dyn RunObserver,
    ) -> Result<Outcome, StreamError> {
        let rx = self.grbl_rx().await?;
        let mut plan = Plan::new(program, from, until, resume, GRBL_MARKER, None);
        plan.lift = self.lift;
        let timing = Timing {
            reply_timeout: self.settings.reply_timeout,
            motion_timeout: self.settings.motion_timeout,
            stall_after: self.settings.stall_after,
            poll_interval: self.settings.poll_interval,
        };
        let mut run = GrblRun::new(plan, rx, program.pen_up.clone(), timing, Instant::now().into_std());
        let outcome = self.drive_grbl(&mut run, stop, on_confirm).await;
        let (integral, time) = run.fill();
        self.stats.fill_integral += integral;
        self.stats.fill_time += time;
        outcome
    }

    async fn drive_grbl(
        &mut self,
        run: &mut GrblRun,
        stop: &mut watch::Receiver<bool>,
        on_confirm: &mut dyn RunObserver,
    ) -> Result<Outcome, StreamError> {
        if Self::stopping(stop) {
            run.stop();
        }
        loop {
            let polled = run.poll(std::time::Instant::now());
            self.carry_out(run.take_actions(), on_confirm).await?;
            polled?;
            let deadline = Instant::from_std(run.deadline(std::time::Instant::now()));
            tokio::select! {
                r = self.link.fill(deadline) => { r?; }
                _ = stop.changed(), if !run.stopping() => {
                    if Self::stopping(stop) {
                        run.stop();
                    }
                }
            }
            while let Some(line) = self.link.take_line() {
                let answered = run.answer(&line, std::time::Instant::now());
                self.carry_out(run.take_actions(), on_confirm).await?;
                if let Some(outcome) = answered? {
                    return Ok(outcome);
                }
            }
        }
    }

    /// Does what a handshake decided, in order.
    async fn carry_out(&mut self, actions: Vec<Action>, on_confirm: &mut dyn RunObserver) -> Result<(), StreamError> {
        for a in actions {
            match a {
                Action::Write { bytes, payload } => {
                    self.link.write(&bytes).await?;
                    self.stats.bytes += payload as u64;
                }
                Action::Query(q) => self.link.write_query(q).await?,
                Action::Written(mark) => on_confirm.written(mark),
                Action::Confirmed(k) => on_confirm.confirmed(k),
            }
        }
        Ok(())
    }
}

/// Where the device says its pen is at rest.
struct Rest {
    pos: DVec2,
    /// Whether the pen is down, when the device tells.
    down: Option<bool>,
    /// G-code: the Z position (compared when the job set one).
    z: Option<f64>,
    /// Largest difference per axis for a position to agree with it.
    tolerance: f64,
}

impl Rest {
    fn is(&self, p: &PenAt) -> bool {
        (p.pos - self.pos).abs().max_element() <= self.tolerance
            && self.down.is_none_or(|d| d == p.down)
            && p.z.is_none_or(|z| self.z.is_some_and(|at| (at - z).abs() <= self.tolerance))
    }
}

/// The chunk to resume from when the device, which ran whatever it received
/// of what `mark` says was written, has its pen at `rest`: going through the
/// chunks from `checkpoint` on in the order the device runs them, the first
/// place that agrees. Where chunk `i` leaves the pen: chunks `..=i` drawn,
/// resume at `i + 1`; a place before that in chunk `i`: it stopped inside,
/// resume at `i` (drawn again). The first, so that when several agree no
/// chunk is skipped that was not provably drawn. `None` when none agrees, or
/// a chunk is reached whose moves are not known.
fn first_match(program: &Program, checkpoint: usize, mark: Written, rest: &Rest) -> Option<usize> {
    let chunks = &program.chunks;
    let written = mark.reached().min(chunks.len());
    if let Some(before) = checkpoint.checked_sub(1) {
        if rest.is(chunks.get(before)?.end.as_ref()?) {
            return Some(checkpoint);
        }
    }
    for (i, c) in chunks.iter().enumerate().take(written).skip(checkpoint) {
        let end = c.end?;
        let path = c.path.as_deref()?;
        if path.strip_suffix(&[end]).unwrap_or(path).iter().any(|p| rest.is(p)) {
            return Some(i);
        }
        if rest.is(&end) {
            return Some(i + 1);
        }
    }
    None
}

/// Meaning of an HP-GL `OE` error number.
fn hpgl_error_text(n: i64) -> &'static str {
    match n {
        1 => "instruction not recognised",
        2 => "wrong number of parameters",
        3 => "out-of-range parameter",
        5 => "unknown character set",
        6 => "position overflow",
        7 => "buffer overflow for polygons or labels",
        _ => "unknown error",
    }
}

/// `GRBL ALARM:N (meaning)` for an `ALARM:N` line.
fn grbl_alarm_message(line: &str) -> String {
    let meaning = line.strip_prefix("ALARM:").and_then(|n| n.trim().parse().ok()).map_or("unknown alarm", grbl_alarm_text);
    format!("GRBL {line} ({meaning})")
}

/// Meaning of a GRBL 1.1 `ALARM:N`.
fn grbl_alarm_text(n: u32) -> &'static str {
    match n {
        1 => "hard limit triggered",
        2 => "soft limit: motion target beyond travel",
        3 => "reset while in motion",
        4 | 5 => "probe fail",
        6..=9 => "homing fail",
        _ => "unknown alarm",
    }
}

/// Meaning of an `ESC.E` (device control / I/O) error number.
fn escb_error_text(n: i64) -> &'static str {
    match n {
        10 => "output instruction received while another is being processed",
        11 => "invalid byte after ESC .",
        12 => "invalid byte in a device-control instruction",
        13 => "device-control parameter out of range",
        14 => "too many parameters",
        15 => "framing, parity or overrun error",
        16 => "input buffer overflow",
        _ => "unknown error",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hpgl_plan(text: &str, window: usize) -> Plan {
        let program = plotcode::cut(text.as_bytes(), &plotcode::DeviceProfile::builtin("hp7475a").unwrap()).unwrap();
        let n = program.chunks.len();
        Plan::new(&program, 0, n, false, HPGL_MARKER, Some((HPGL_CHAINED_MARKER, window)))
    }

    #[test]
    fn an_open_marker_only_before_a_stroke_that_can_share_the_window() {
        // Three 16-byte strokes: the first two markers are ended by the next
        // stroke's `PU`, the last by its own `;`.
        let short = "IN;SP1;PU0,0;PD10,10;PU20,0;PD30,10;PU40,0;PD50,10;";
        let plan = hpgl_plan(short, 256);
        assert_eq!(plan.marks.len(), 3, "{short}");
        assert_eq!(plan.marks, [2, 2, 3]);
        // The same strokes in a window one byte too small for any two
        // neighbours with their markers: every marker ends itself, or each
        // stroke would wait a round trip for its `;`.
        let len = |i: usize| plan.ends[i] - if i == 0 { 0 } else { plan.ends[i - 1] } - plan.marks[i];
        let tightest = (0..2).map(|i| len(i) + len(i + 1)).min().unwrap();
        let fits = |window| hpgl_plan(short, window).marks;
        assert_eq!(fits(tightest + 4), [3, 3, 3]);
        assert_eq!(hpgl_plan(short, tightest + 4).marked, [0, 3, 6, 9]);
        assert_ne!(fits(tightest + 5), [3, 3, 3]);
    }
}
