//! The loop that drives a handshake, and finding the pen after an
//! interruption.
//!
//! [`Streamer::run`] feeds a handshake state machine ([`HpglRun`] for
//! `escb`, `xonxoff` and `hardware`; [`GrblRun`] for `grbl`) from the link:
//! answer lines and the time in, its [`Action`]s carried out in order. Every
//! protocol decision is in the machines; this loop only reads, writes and
//! waits until the machine's deadline or a stop request.
//!
//! A stop request finishes the chunk being written, waits for the device to
//! confirm everything written, lifts the pen and returns [`Outcome::Stopped`];
//! a stop now ([`Stop::Now`]) has the machine drop what the device holds
//! first.
//!
//! Around every write the run reports a [`Written`] mark, and after an
//! interruption [`Streamer::locate`] asks the device where its pen rests,
//! which tells how far it got in what was written, so plotting can go on
//! past the checkpoint.

use super::grbl::{GrblRun, GRBL_MARKER};
use super::hpgl::{HpglRun, Start, HPGL_CHAINED_MARKER, HPGL_MARKER};
use super::machine::{Action, HandshakeMachine, Timing};
use super::plan::Plan;
use super::{Hold, Link, Stop, StreamError, Written};
use crate::config::Handshake;
use plotcode::answer::{
    device_control_error_text, grbl_alarm_text, hpgl_error_text, is_identification, AnswerLine, ExtendedStatus, GrblAnswer, GrblState,
    GrblStatus, HpglNumber, HpglPosition, Terminator,
};
use plotcode::{PenAt, Program, Protocol};
use std::time::Duration;
use strokes::DVec2;
use tokio::io::{AsyncRead, AsyncWrite};
use tokio::sync::watch;
use tokio::time::Instant;

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
    /// The device holds its work until a person acts (`Some`), or goes on
    /// again (`None`); the run goes on waiting meanwhile.
    fn held(&mut self, _why: Option<Hold>) {}
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
    /// HP-GL: silence while the device holds work before it is asked for
    /// its free space (a power cycle or dead link shows within seconds).
    pub probe_after: Duration,
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
            probe_after: Duration::from_secs(1),
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

impl<T: AsyncRead + AsyncWrite + Unpin> Streamer<T> {
    /// A streamer on a freshly opened link.
    pub fn new(io: T, settings: StreamSettings) -> Self {
        Streamer { link: Link::new(io), settings, stats: StreamStats::default(), buffer: None, lift: false }
    }

    /// Streams chunks `from..until` of `program`. With `resume`, the device is
    /// first given the state it had at chunk `from` (pen up, modal state,
    /// position); with `lift`, the pen is lifted after the last chunk.
    /// `on_confirm` hears each new checkpoint `k` (chunks `..k` executed) and
    /// the [`Written`] mark around every write. `stop` asks for a stop at
    /// the next stroke boundary, or now ([`Stop`]).
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
        stop: &mut watch::Receiver<Stop>,
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
        if r.is_err() || *stop.borrow() == Stop::Now {
            // Answers to what this run wrote may still come (or a reset
            // dropped the settings): the next run syncs the link again
            // before it trusts one.
            self.buffer = None;
        }
        r
    }

    /// Forgets what was set up on the device (the next run sets it up
    /// again): a job starts on a device that may have been power-cycled
    /// since the last one.
    pub fn forget_device(&mut self) {
        self.buffer = None;
    }

    /// Asks the device something it answers at once and does not buffer
    /// (HP-GL `ESC.B`, GRBL `?`): whether it is there, on an idle port.
    ///
    /// # Errors
    /// [`StreamError::Offline`] when the port failed, [`StreamError::Timeout`]
    /// when nothing answered.
    pub async fn ping(&mut self) -> Result<(), StreamError> {
        let grbl = self.settings.handshake == Handshake::Grbl;
        self.link.write_query(if grbl { b"?" } else { b"\x1b.B" }).await?;
        let deadline = Instant::now() + self.settings.reply_timeout;
        loop {
            let line = self.link.line_until(deadline, if grbl { "?" } else { "ESC.B" }).await?;
            if if grbl { line.text.starts_with('<') } else { HpglNumber::parse(&line.text).is_some() } {
                return Ok(());
            }
        }
    }

    fn timing(&self) -> Timing {
        Timing::of(&self.settings)
    }

    /// After an interruption (daemon restart, link lost), finds out how far
    /// the device got between the confirmed `checkpoint` and what `mark`
    /// says was written: its answers still end as this daemon set them up
    /// (no power cycle or reset since), nothing left in its buffer, and its
    /// pen at rest where exactly one of those chunks leaves it
    /// ([`first_match`]). Returns the chunk to resume from (one the pen
    /// stopped inside is drawn again); `None` when anything disagrees or
    /// cannot be read: resume from the checkpoint.
    ///
    /// # Errors
    /// [`StreamError::Offline`] when the port is gone;
    /// [`StreamError::Device`] when the device reports an error left by
    /// bytes whose answers were lost (HP-GL `ESC.E` or `OE` not 0, GRBL in
    /// an alarm that `$X` cannot clear).
    pub async fn locate(&mut self, program: &Program, checkpoint: usize, mark: Written) -> Result<Option<usize>, StreamError> {
        self.buffer = None;
        let found = match (self.settings.handshake, program.protocol) {
            (Handshake::Grbl, _) | (_, Protocol::Gcode) => self.grbl_locate(program, checkpoint, mark).await,
            (Handshake::Escb | Handshake::Xonxoff | Handshake::Hardware, Protocol::Hpgl) => {
                self.hpgl_locate(program, checkpoint, mark).await
            }
        };
        match found {
            Err(e @ (StreamError::Offline(_) | StreamError::Device(_))) => Err(e),
            Err(e) => {
                tracing::info!(error = %e, "cannot tell where the device got; resuming from the checkpoint");
                Ok(None)
            }
            Ok(None) => {
                tracing::info!(checkpoint, ?mark, "the device is not where a chunk written leaves it; resuming from the checkpoint");
                Ok(None)
            }
            Ok(Some(k)) => {
                tracing::info!(checkpoint, ?mark, resume_at = k, "found where the device got");
                Ok(Some(k))
            }
        }
    }

    /// The next HP-GL answer line before `deadline`, as the last session
    /// left the terminator (LF): a CR is the power-on one.
    async fn hpgl_line(&mut self, deadline: Instant, what: &str) -> Result<AnswerLine, StreamError> {
        let line = self.link.line_until(deadline, what).await?;
        if line.terminator == Terminator::Cr {
            return Err(StreamError::Reset("the plotter answered with its power-on terminator".into()));
        }
        Ok(line)
    }

    /// The next HP-GL numeric answer; other lines are dropped.
    async fn hpgl_number(&mut self, deadline: Instant, what: &str) -> Result<i64, StreamError> {
        loop {
            if let Some(n) = HpglNumber::parse(&self.hpgl_line(deadline, what).await?.text) {
                return Ok(n.0);
            }
        }
    }

    /// HP-GL side of [`Self::locate`]. It does not wait for the buffer to
    /// drain (a stale half-read `OE` can hold it at one byte short for
    /// ever): ESC.K and ESC.J drop what the device holds, a `;` ends a
    /// half-read instruction, and `OI;` goes through the buffer, so every
    /// answer before the identification is stale and none comes after it;
    /// ESC.O then checks the buffer is empty. Needs no ESC.L, which older
    /// firmware does not answer.
    async fn hpgl_locate(&mut self, program: &Program, checkpoint: usize, mark: Written) -> Result<Option<usize>, StreamError> {
        self.link.write_query(b"\x1b.K\x1b.J;OI;").await?;
        let deadline = Instant::now() + self.settings.motion_timeout;
        loop {
            let line = self.link.line_until(deadline, "OI").await?;
            if is_identification(&line.text) {
                if line.terminator == Terminator::Cr {
                    // Power-cycled since: it holds nothing of the job.
                    return Ok(None);
                }
                break;
            }
            tracing::debug!(answer = %line.text, "dropped a stale answer before OI");
        }
        let deadline = Instant::now() + self.settings.reply_timeout;
        self.link.write_query(b"\x1b.O").await?;
        if !ExtendedStatus(self.hpgl_number(deadline, "ESC.O").await?).buffer_empty() {
            return Ok(None);
        }
        // An I/O error, or an instruction error after the last marker that
        // ran (its answer was never read), is the device's word on bytes of
        // this job: the job stops with it rather than going on silently.
        self.link.write_query(b"\x1b.E").await?;
        let e = self.hpgl_number(deadline, "ESC.E").await?;
        if e != 0 {
            return Err(StreamError::Device(format!("ESC.E error {e} ({})", device_control_error_text(e))));
        }
        self.link.write_query(b"OE;OA;").await?;
        let deadline = Instant::now() + self.settings.motion_timeout;
        let oe = self.hpgl_number(deadline, "OE").await?;
        let at = loop {
            if let Some(at) = HpglPosition::parse(&self.hpgl_line(deadline, "OA").await?.text) {
                break at;
            }
        };
        if oe != 0 {
            return Err(StreamError::Device(format!("HP-GL error {oe} ({})", hpgl_error_text(oe))));
        }
        let rest = Rest { pos: DVec2::new(at.x, at.y), down: Some(at.down), z: None, tolerance: POSITION_TOLERANCE };
        Ok(first_match(program, checkpoint, mark, &rest))
    }

    /// HP-GL, every handshake: the [`HpglRun`] machine fed from the link.
    async fn run_hpgl(
        &mut self,
        program: &Program,
        from: usize,
        until: usize,
        resume: bool,
        stop: &mut watch::Receiver<Stop>,
        on_confirm: &mut dyn RunObserver,
    ) -> Result<Outcome, StreamError> {
        let start = Start {
            size: self.buffer,
            xonxoff: self.settings.handshake == Handshake::Xonxoff,
            margin: self.settings.escb_margin,
            window: self.settings.hpgl_window,
        };
        // The window is known once the size is: a run on a new link sizes
        // the buffer first, then plans with the window it allows.
        let size = match self.buffer {
            Some(size) => size,
            None => {
                let empty = Plan::new(program, from, from, false, HPGL_MARKER, None);
                let mut setup = HpglRun::new(empty, start, Vec::new(), self.timing(), Instant::now().into_std());
                let r = self.drive(&mut setup, stop, on_confirm).await;
                let size = setup.buffer_size();
                r?;
                size.ok_or_else(|| StreamError::Timeout("ESC.L".into()))?
            }
        };
        self.buffer = Some(size);
        self.stats.buffer_size = Some(size);
        let window = size.saturating_sub(self.settings.escb_margin).min(self.settings.hpgl_window);
        let mut plan = Plan::new(program, from, until, resume, HPGL_MARKER, Some((HPGL_CHAINED_MARKER, window)));
        plan.lift = self.lift;
        let start = Start { size: Some(size), ..start };
        let mut run = HpglRun::new(plan, start, program.pen_up.clone(), self.timing(), Instant::now().into_std());
        self.drive(&mut run, stop, on_confirm).await
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
    async fn grbl_sync(&mut self) -> Result<(usize, Option<u32>), StreamError> {
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
                r => r?.text,
            };
            match GrblAnswer::parse(&line) {
                GrblAnswer::Version(_) => reported = true,
                GrblAnswer::Options { rx_buffer } => {
                    reported = true;
                    rx = rx_buffer.unwrap_or(rx);
                }
                GrblAnswer::Ok if reported => break,
                GrblAnswer::Error(n) if reported => return Err(StreamError::Device(format!("GRBL error:{n}"))),
                // An earlier run's: the board may still be in that alarm.
                GrblAnswer::Alarm(n) => alarm = Some(n),
                // Other answers before the report answer an earlier run's lines.
                _ => {}
            }
        }
        if rx < 16 {
            return Err(StreamError::Garbled(format!("receive buffer of {rx} bytes")));
        }
        Ok((rx, alarm))
    }

    /// The next status report, asking up to three times; `None` when none comes.
    async fn grbl_status(&mut self) -> Result<Option<GrblStatus>, StreamError> {
        for _ in 0..3 {
            self.link.write_query(b"?").await?;
            let deadline = Instant::now() + self.settings.reply_timeout / 3;
            loop {
                match self.link.line_until(deadline, "?").await {
                    Ok(line) => {
                        if let GrblAnswer::Status(status) = GrblAnswer::parse(&line.text) {
                            return Ok(Some(status));
                        }
                    }
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
    /// `MPos` z. A board in alarm cannot be located: the run starts from the
    /// checkpoint and unlocks it.
    async fn grbl_locate(&mut self, program: &Program, checkpoint: usize, mark: Written) -> Result<Option<usize>, StreamError> {
        self.buffer = None;
        let alarm = self.grbl_sync().await?.1;
        let deadline = Instant::now() + self.settings.motion_timeout;
        let status = loop {
            let Some(status) = self.grbl_status().await? else { return Ok(None) };
            match status.state {
                GrblState::Idle => break status,
                GrblState::Alarm => {
                    // The alarm says nothing of how far the board got:
                    // plotting goes on from the checkpoint, and the run's
                    // start unlocks the board with `$X` (issue #15 fault 8:
                    // a resume the user asked for is not turned into a
                    // second pause).
                    let text = alarm.map_or_else(|| "GRBL in alarm".to_owned(), grbl_alarm_message);
                    tracing::warn!(alarm = %text, "board in alarm: resuming from the checkpoint, unlocked");
                    return Ok(None);
                }
                GrblState::Run if Instant::now() < deadline => tokio::time::sleep(self.settings.poll_interval).await,
                _ => return Ok(None),
            }
        };
        let Some(at) = status.pos else { return Ok(None) };
        // `[GC:G1 G54 G17 G21 G90 G94 M3 M9 T0 F3000 S1000]`: the feed rate
        // the job set survives everything but a reset; M3 with S above 0 is
        // a pen on a servo down.
        self.link.write_query(b"$G\n").await?;
        let deadline = Instant::now() + self.settings.reply_timeout;
        let mut modal = None;
        loop {
            match GrblAnswer::parse(&self.link.line_until(deadline, "$G").await?.text) {
                GrblAnswer::Modal(m) => modal = Some(m),
                GrblAnswer::Ok => break,
                GrblAnswer::Alarm(n) => return Err(StreamError::Device(grbl_alarm_message(n))),
                GrblAnswer::Error(_) => return Ok(None),
                _ => {}
            }
        }
        let Some(modal) = modal.filter(|m| m.feed.is_some_and(|f| f > 0.0)) else { return Ok(None) };
        let Some(spindle_on) = modal.spindle_on else { return Ok(None) };
        let rest = Rest {
            pos: DVec2::new(at[0], at[1]),
            down: Some(spindle_on && modal.speed > 0.0),
            z: Some(at[2]),
            tolerance: GCODE_POSITION_TOLERANCE,
        };
        Ok(first_match(program, checkpoint, mark, &rest))
    }

    /// A board left in alarm (a limit switch, a reset in motion) is locked
    /// and answers G-code with `error:9`: unlock it with `$X`. The resume
    /// prefix then sets the modal state and the position again.
    async fn grbl_unlock(&mut self) -> Result<(), StreamError> {
        let Some(status) = self.grbl_status().await? else { return Err(StreamError::Timeout("GRBL status poll".into())) };
        if status.state != GrblState::Alarm {
            return Ok(());
        }
        tracing::info!(?status, "GRBL in alarm: unlocking with $X");
        self.link.write_query(b"$X\n").await?;
        let deadline = Instant::now() + self.settings.reply_timeout;
        loop {
            match GrblAnswer::parse(&self.link.line_until(deadline, "$X").await?.text) {
                GrblAnswer::Ok => return Ok(()),
                GrblAnswer::Error(n) => return Err(StreamError::Device(format!("GRBL error:{n} (unlocking with $X)"))),
                GrblAnswer::Alarm(n) => return Err(StreamError::Device(format!("{} (unlocking with $X)", grbl_alarm_message(n)))),
                _ => {}
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
        stop: &mut watch::Receiver<Stop>,
        on_confirm: &mut dyn RunObserver,
    ) -> Result<Outcome, StreamError> {
        let rx = self.grbl_rx().await?;
        let mut plan = Plan::new(program, from, until, resume, GRBL_MARKER, None);
        plan.lift = self.lift;
        let mut run = GrblRun::new(plan, rx, program.pen_up.clone(), self.timing(), Instant::now().into_std());
        let outcome = self.drive(&mut run, stop, on_confirm).await;
        let (integral, time) = run.fill();
        self.stats.fill_integral += integral;
        self.stats.fill_time += time;
        outcome
    }

    /// Feeds `run` from the link until it ends: the thin loop.
    async fn drive(
        &mut self,
        run: &mut (impl HandshakeMachine + Send),
        stop: &mut watch::Receiver<Stop>,
        on_confirm: &mut dyn RunObserver,
    ) -> Result<Outcome, StreamError> {
        run.stop(*stop.borrow_and_update(), std::time::Instant::now());
        loop {
            let polled = run.poll(std::time::Instant::now(), self.link.xoff());
            self.carry_out(run.take_actions(), on_confirm).await?;
            polled?;
            let deadline = Instant::from_std(run.deadline(std::time::Instant::now()));
            tokio::select! {
                r = self.link.fill(deadline) => { r?; }
                _ = stop.changed(), if run.stop_asked() < Stop::Now => {
                    run.stop(*stop.borrow_and_update(), std::time::Instant::now());
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
                Action::Held(why) => on_confirm.held(why),
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

/// `GRBL ALARM:N (meaning)`.
fn grbl_alarm_message(n: u32) -> String {
    format!("GRBL ALARM:{n} ({})", grbl_alarm_text(n))
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
