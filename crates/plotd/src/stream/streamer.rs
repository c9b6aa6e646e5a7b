//! The one loop that drives every exchange with the device, and the
//! streamer's public face.
//!
//! [`Streamer::run`] streams a [`Span`] of chunks through a handshake state
//! machine (`HpglRun` for `escb`, `xonxoff` and `hardware`; `GrblRun`
//! for `grbl`, after `GrblSync` and `GrblRestore` on a new link);
//! [`Streamer::ping`] and [`Streamer::locate`] run machines of their own
//! (`Ping`, `HpglLocate`, `GrblLocate`). Each is fed from the link by
//! `Streamer::drive`: answer lines and the time in, its `Action`s
//! carried out in order. Every protocol decision is in the machines; this
//! loop only reads, writes and waits until the machine's deadline or a stop
//! request.
//!
//! A stop request finishes the chunk being written, waits for the device to
//! confirm everything written, lifts the pen and returns [`Outcome::Stopped`];
//! a stop now ([`Stop::Now`]) has the machine drop what the device holds
//! first.
//!
//! Around every write the run reports a [`Written`] mark, and after an
//! interruption [`Streamer::locate`] asks the device where its pen rests,
//! which tells how far it got in what was written (`first_match`), so
//! plotting can go on past the checkpoint.

use super::ebb::{self, EbbRun};
use super::ebb_locate::EbbLocate;
use super::grbl::GrblRun;
use super::grbl_locate::GrblLocate;
use super::grbl_setup::{GrblRestore, GrblSync};
use super::hpgl::{HpglCapabilities, HpglRun, Start};
use super::hpgl_locate::HpglLocate;
use super::locate::first_match;
use super::machine::{Action, Machine, Timing};
use super::ping::Ping;
use super::plan::{Plan, Span};
use super::settings::{StreamSettings, StreamStats};
use super::{Excerpt, Hold, Link, Outcome, Reset, Restore, Stop, StreamError, Unanswered, Written};
use plotcode::control::{grbl, hpgl};
use plotcode::Handshake;
use plotcode::{Program, Protocol};
use tokio::io::{AsyncRead, AsyncWrite};
use tokio::sync::watch;
use tokio::time::Instant;

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
    /// What an HP-GL device answers, learnt by the first set-up on the
    /// link and kept: its firmware does not change with a power cycle.
    hpgl_caps: Option<HpglCapabilities>,
    /// A GRBL banner a ping heard and no run has yet answered for: the
    /// board restarted (an Arduino resets when its port opens), so a job
    /// it was in the middle of has lost its place.
    restarted: Option<String>,
}

impl<T: AsyncRead + AsyncWrite + Unpin> Streamer<T> {
    /// A streamer on a freshly opened link.
    pub fn new(io: T, settings: StreamSettings) -> Self {
        Streamer { link: Link::new(io), settings, stats: StreamStats::default(), buffer: None, hpgl_caps: None, restarted: None }
    }

    /// What the HP-GL device on this link answers, once a run has learnt it.
    pub fn hpgl_capabilities(&self) -> Option<HpglCapabilities> {
        self.hpgl_caps
    }

    /// Streams `span`. `on_confirm` hears each new checkpoint `k` (chunks
    /// `..k` executed) and the [`Written`] mark around every write. `stop`
    /// asks for a stop at the next stroke boundary, or now ([`Stop`]).
    ///
    /// # Errors
    /// [`StreamError`]; chunks confirmed before it stay confirmed.
    pub async fn run(
        &mut self,
        span: Span<'_>,
        stop: &mut watch::Receiver<Stop>,
        on_confirm: &mut dyn RunObserver,
    ) -> Result<Outcome, StreamError> {
        let started = Instant::now();
        let span = span.clamped();
        let r = if span.program.protocol == Protocol::Ebb {
            self.run_ebb(span, stop, on_confirm).await
        } else if self.grbl(span.program) {
            self.run_grbl(span, stop, on_confirm).await
        } else {
            self.run_hpgl(span, stop, on_confirm).await
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

    /// Whether `program` goes to the device through the GRBL handshake.
    fn grbl(&self, program: &Program) -> bool {
        self.settings.handshake == Handshake::Grbl || program.protocol == Protocol::Gcode
    }

    /// Forgets what was set up on the device (the next run sets it up
    /// again): a job starts on a device that may have been power-cycled
    /// since the last one.
    pub fn forget_device(&mut self) {
        self.buffer = None;
    }

    /// Brings the device to a known state after a cancelled job it could
    /// not be told to stop (the link lost, the device stalled): what it
    /// holds is dropped (HP-GL: the set-up's ESC.K and ESC.J; GRBL: a soft
    /// reset, and the unlock of the alarm it may leave) and the pen lifted
    /// as `program` lifts it, which the device confirms as it confirms a
    /// run's end. An EiBotBoard's FIFO (three moves at most) runs out before
    /// its pen is lifted.
    ///
    /// # Errors
    /// As [`Streamer::run`].
    pub async fn reset(&mut self, program: &Program) -> Result<(), StreamError> {
        self.forget_device();
        if self.grbl(program) {
            self.link.write_query(grbl::Op::SoftReset.bytes()).await?;
        }
        let end = program.chunks.len();
        let (_asked, mut stop) = watch::channel(Stop::Continue);
        let lift = Span { program, from: end, until: end, resume: false, lift: true, restore: Restore::Nothing };
        self.run(lift, &mut stop, &mut |_| {}).await.map(|_| ())
    }

    /// Asks the device something it answers at once and does not buffer
    /// (HP-GL `ESC.B`, GRBL `?`): whether it is there, on an idle port.
    ///
    /// # Errors
    /// [`StreamError::Offline`] when the port failed, [`StreamError::Timeout`]
    /// when nothing answered, [`StreamError::Empty`] or
    /// [`StreamError::Garbled`] when what answered cannot be read.
    pub async fn ping(&mut self) -> Result<(), StreamError> {
        let mut ping = Ping::new(self.settings.handshake, self.timing());
        if let Some(banner) = self.drive(&mut ping, None, &mut |_| {}).await? {
            tracing::info!(banner, "the device restarted");
            self.restarted = Some(banner);
        }
        Ok(())
    }

    /// Asks an EiBotBoard its nickname (`QT`); empty when it has none.
    ///
    /// # Errors
    /// [`StreamError::Offline`] when the port failed, [`StreamError::Timeout`]
    /// when nothing answered, [`StreamError::Device`] when the board refused,
    /// [`StreamError::Garbled`] when what answered is not an EBB's answer.
    pub async fn nickname(&mut self) -> Result<String, StreamError> {
        let mut ask = super::ebb_nickname::AskNickname::new(self.timing());
        self.drive(&mut ask, None, &mut |_| {}).await
    }

    /// How long a question is waited for.
    #[must_use]
    pub fn reply_timeout(&self) -> std::time::Duration {
        self.settings.reply_timeout
    }

    fn timing(&self) -> Timing {
        Timing::of(&self.settings)
    }

    /// After an interruption (daemon restart, link lost), finds out how far
    /// the device got between the confirmed `checkpoint` and what `mark`
    /// says was written: its answers still end as this daemon set them up
    /// (no power cycle or reset since), nothing left in its buffer, and its
    /// pen at rest where one of those chunks puts it (`first_match`).
    /// Returns the chunk to resume from (one the pen stopped inside is drawn
    /// again); `None` when anything disagrees or cannot be read: resume
    /// from the checkpoint.
    ///
    /// # Errors
    /// [`StreamError::Offline`] when the port is gone;
    /// [`StreamError::Reset`] when an EiBotBoard lost its place (its motors
    /// off, or without power);
    /// [`StreamError::Device`] when the device reports an error left by
    /// bytes whose answers were lost (HP-GL `ESC.E` or `OE` not 0);
    /// [`StreamError::Reset`] and [`StreamError::Alarm`] when the device's
    /// place cannot be trusted (a GRBL board restarted or in alarm).
    pub async fn locate(&mut self, program: &Program, checkpoint: usize, mark: Written) -> Result<Option<usize>, StreamError> {
        self.buffer = None;
        if let Some(banner) = self.restarted.take() {
            return Err(StreamError::Reset(Reset::Banner(Excerpt::of(&banner))));
        }
        let rest = if program.protocol == Protocol::Ebb {
            // A board reset or without motor power mid-job has lost its
            // place: that is the answer, not a reason to guess.
            match self.drive(&mut EbbLocate::new(self.timing(), std::time::Instant::now()), None, &mut |_| {}).await {
                Err(e @ StreamError::Reset(_)) => return Err(e),
                rest => rest,
            }
        } else if self.grbl(program) {
            self.drive(&mut GrblLocate::new(self.timing(), self.settings.grbl_rx_default), None, &mut |_| {}).await
        } else {
            self.drive(&mut HpglLocate::new(self.timing(), std::time::Instant::now()), None, &mut |_| {}).await
        };
        match rest.map(|rest| rest.and_then(|rest| first_match(program, checkpoint, mark, &rest))) {
            Err(e @ (StreamError::Offline(_) | StreamError::Device(_) | StreamError::Reset(_) | StreamError::Alarm(_))) => Err(e),
            // A person should know: strokes will be drawn twice on the sheet.
            Err(e) => {
                tracing::warn!(error = %e, checkpoint, "cannot tell where the device got: resuming from the checkpoint, strokes will be drawn again");
                Ok(None)
            }
            Ok(None) => {
                tracing::warn!(
                    checkpoint,
                    ?mark,
                    "the device is not where a chunk written leaves it: resuming from the checkpoint, strokes will be drawn again"
                );
                Ok(None)
            }
            Ok(Some(k)) => {
                tracing::info!(checkpoint, ?mark, resume_at = k, "found where the device got");
                Ok(Some(k))
            }
        }
    }

    /// HP-GL, every handshake: the [`HpglRun`] machine fed from the link.
    async fn run_hpgl(
        &mut self,
        span: Span<'_>,
        stop: &mut watch::Receiver<Stop>,
        on_confirm: &mut dyn RunObserver,
    ) -> Result<Outcome, StreamError> {
        let start = Start {
            size: self.buffer,
            caps: self.hpgl_caps,
            xonxoff: self.settings.handshake == Handshake::XonXoff,
            margin: self.settings.escb_margin,
            window: self.settings.hpgl_window,
        };
        // The window is known once the size is: a run on a new link sizes
        // the buffer first, then plans with the window it allows.
        let size = match self.buffer {
            Some(size) => size,
            None => {
                let empty = Plan::new(Span { until: span.from, resume: false, lift: false, ..span }, hpgl::MARKER, None);
                let mut setup = HpglRun::new(empty, start, Vec::new(), self.timing(), std::time::Instant::now());
                let r = self.drive(&mut setup, Some(&mut *stop), on_confirm).await;
                let size = setup.buffer_size();
                self.hpgl_caps = self.hpgl_caps.or(setup.capabilities());
                r?;
                size.ok_or(StreamError::Timeout(Unanswered::BufferSize))?
            }
        };
        self.buffer = Some(size);
        self.stats.buffer_size = Some(size);
        let window = size.saturating_sub(self.settings.escb_margin).min(self.settings.hpgl_window);
        let plan = Plan::new(span, hpgl::MARKER, Some(window));
        let start = Start { size: Some(size), caps: self.hpgl_caps, ..start };
        let mut run = HpglRun::new(plan, start, span.program.pen_up.clone(), self.timing(), std::time::Instant::now());
        self.drive(&mut run, Some(stop), on_confirm).await
    }

    /// GRBL: on a new link the sync ([`GrblSync`]), then what a person
    /// allowed for a board in alarm ([`GrblRestore`]), then the
    /// character-counting state machine ([`GrblRun`]) fed from the link
    /// until it ends. A board that restarted since the job began has lost
    /// its place: a run that goes on mid-job ends with the reset unless a
    /// person confirmed the position or asked for homing.
    async fn run_grbl(
        &mut self,
        span: Span<'_>,
        stop: &mut watch::Receiver<Stop>,
        on_confirm: &mut dyn RunObserver,
    ) -> Result<Outcome, StreamError> {
        let rx = match self.buffer {
            Some(rx) => rx,
            None => {
                let synced = self.drive(&mut GrblSync::new(&self.timing(), self.settings.grbl_rx_default), None, &mut |_| {}).await?;
                let restarted = synced.restarted.or(self.restarted.take());
                if let Some(banner) = restarted.filter(|_| span.resume && span.restore == Restore::Nothing) {
                    return Err(StreamError::Reset(Reset::Banner(Excerpt::of(&banner))));
                }
                let rx = synced.rx;
                self.drive(&mut GrblRestore::new(self.timing(), span.restore, synced.alarm), None, &mut |_| {}).await?;
                self.buffer = Some(rx);
                self.stats.buffer_size = Some(rx);
                rx
            }
        };
        let plan = Plan::new(span, grbl::MARKER, None);
        let mut run = GrblRun::new(plan, rx, span.program.pen_up.clone(), self.timing(), std::time::Instant::now());
        let outcome = self.drive(&mut run, Some(stop), on_confirm).await;
        let (integral, time) = run.fill();
        self.stats.fill_integral += integral;
        self.stats.fill_time += time;
        outcome
    }

    /// EiBotBoard: the version probe, the set-up and the stream confirmed
    /// by the step counters ([`EbbRun`]), fed from the link until it ends.
    async fn run_ebb(
        &mut self,
        span: Span<'_>,
        stop: &mut watch::Receiver<Stop>,
        on_confirm: &mut dyn RunObserver,
    ) -> Result<Outcome, StreamError> {
        let plan = Plan::new(span, ebb::MARKER, None);
        let targets = span.program.chunks[plan.from..].iter().map(|c| c.end.map(|e| plotcode::ebb::Motors::nearest(e.pos))).collect();
        // A person confirmed the carriage at home (or asked to go on): an
        // EiBotBoard, without home switches, makes where it stands home.
        let start = (span.resume, (span.restore != Restore::Nothing).then(|| ebb::enable_motors(span.program)));
        let mut run = EbbRun::new(plan, targets, span.program.pen_up.clone(), start, self.timing(), std::time::Instant::now());
        self.drive(&mut run, Some(stop), on_confirm).await
    }

    /// Feeds `machine` from the link until it ends ([`Streamer::feed`]); a
    /// question unanswered where the device sent empty answers meanwhile
    /// was answered, with nothing readable ([`StreamError::Empty`]).
    async fn drive<M: Machine + Send>(
        &mut self,
        machine: &mut M,
        stop: Option<&mut watch::Receiver<Stop>>,
        on_confirm: &mut dyn RunObserver,
    ) -> Result<M::Output, StreamError> {
        let empty_before = self.link.empty_answers();
        match self.feed(machine, stop, on_confirm).await {
            Err(StreamError::Timeout(asked)) if self.link.empty_answers() > empty_before => Err(StreamError::Empty(asked)),
            r => r,
        }
    }

    /// The thin loop. The machine writes and asks what is due, takes the
    /// answers already read (left over from the last exchange, or read
    /// since), and the loop waits for the device until the machine's
    /// deadline, or for a stop request when the machine takes one.
    async fn feed<M: Machine + Send>(
        &mut self,
        machine: &mut M,
        mut stop: Option<&mut watch::Receiver<Stop>>,
        on_confirm: &mut dyn RunObserver,
    ) -> Result<M::Output, StreamError> {
        if let Some(stop) = stop.as_deref_mut() {
            machine.stop(*stop.borrow_and_update(), std::time::Instant::now());
        }
        loop {
            let polled = machine.poll(std::time::Instant::now(), self.link.xoff());
            self.carry_out(machine.take_actions(), on_confirm).await?;
            if let Some(out) = polled? {
                return Ok(out);
            }
            if let Some(out) = self.answer_lines(machine, on_confirm).await? {
                return Ok(out);
            }
            let deadline = Instant::from_std(machine.deadline(std::time::Instant::now()));
            let listening = machine.takes_stop() && stop.is_some();
            tokio::select! {
                r = self.link.fill(deadline) => { r?; }
                _ = async { stop.as_deref_mut()?.changed().await.ok() }, if listening => {
                    if let Some(stop) = stop.as_deref_mut() {
                        machine.stop(*stop.borrow_and_update(), std::time::Instant::now());
                    }
                }
            }
            if let Some(out) = self.answer_lines(machine, on_confirm).await? {
                return Ok(out);
            }
        }
    }

    /// Gives `machine` every whole answer line read, doing what it decides
    /// after each; `Some` when one ended it.
    async fn answer_lines<M: Machine + Send>(
        &mut self,
        machine: &mut M,
        on_confirm: &mut dyn RunObserver,
    ) -> Result<Option<M::Output>, StreamError> {
        while let Some(line) = self.link.take_line() {
            let answered = machine.answer(&line, std::time::Instant::now());
            self.carry_out(machine.take_actions(), on_confirm).await?;
            if let Some(out) = answered? {
                return Ok(Some(out));
            }
        }
        Ok(None)
    }

    /// Does what a machine decided, in order.
    async fn carry_out(&mut self, actions: Vec<Action>, on_confirm: &mut dyn RunObserver) -> Result<(), StreamError> {
        for a in actions {
            match a {
                Action::Write { bytes, payload } => {
                    self.link.write(&bytes).await?;
                    self.stats.bytes += payload as u64;
                }
                Action::Query(q) => self.link.write_query(&q).await?,
                Action::Written(mark) => on_confirm.written(mark),
                Action::Confirmed(k) => on_confirm.confirmed(k),
                Action::Held(why) => on_confirm.held(why),
            }
        }
        Ok(())
    }
}
