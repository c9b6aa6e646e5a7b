//! One task per plotter: it owns the serial port and carries out what the
//! job's life ([`crate::job`]) decides for its plotter: probes, waits, and
//! each run of a job (the render, locating the pen, spans of chunks
//! streamed) and a person's manual requests (`manual.rs`), bringing every
//! result back to the machine. No decision about
//! a job is made here.

use super::registry::{Next, Registry};
use super::rendering::NoProgram;
use crate::config::PlotterConfig;
use crate::job::{Action, ManualWork, Rendered, Save, Step};
use crate::protocol::{LinkCause, LinkFault, PlotterEvent};
use crate::spool::{JobId, JobKind, SpoolError, WrittenLog};
use crate::stream::usb_ports;
use crate::stream::{Hold, OpenError, Outcome, RunObserver, SerialPort, Span, Stop, StreamError, StreamSettings, Streamer, Written};
use plotcode::control::manual::{self, Motion};
use plotcode::Handshake;
use std::collections::VecDeque;
use std::sync::Arc;
use std::time::Instant;
use tokio::io::{AsyncRead, AsyncWrite};
use tokio::sync::{watch, Notify};

/// The task body for plotter `name`. Returns when the machine says so (the
/// daemon shuts down), after the current run has stopped at a stroke
/// boundary.
pub async fn run(reg: Arc<Registry>, name: String, sysfs: Arc<std::path::Path>) {
    let mut port: Option<Streamer<SerialPort>> = None;
    while let Some(Next { step, wake, stop }) = reg.poll(&name, Instant::now()) {
        match (step, stop) {
            (Step::Quit, _) => break,
            (Step::Wait(until), _) => wait(&wake, until).await,
            (Step::Act(actions), _) => {
                reg.carry_out(actions);
            }
            (Step::Manual(work), _) => {
                let done = manual(&reg, &name, &mut port, &work, &sysfs).await;
                reg.manual_done(&name, done);
            }
            (Step::Probe, _) => {
                let answered = answers(&name, &mut port, open(&reg, &name, &sysfs)).await;
                let next = reg.with(|l| l.probed(&name, answered, Instant::now()));
                reg.carry_out(next);
            }
            (Step::Reset(program), _) => {
                let ok = reset(&name, &mut port, &program).await;
                let next = reg.with(|l| l.reset_done(&name, ok, Instant::now()));
                reg.carry_out(next);
            }
            (Step::Run { actions, .. }, Some(stop)) => {
                // The plotter may have been power-cycled since the last job: set it up again.
                if let Some(streamer) = port.as_mut() {
                    streamer.forget_device();
                }
                if drive_run(&reg, &name, actions, &mut port, stop).await {
                    port = None;
                }
            }
            (Step::Run { job, .. }, None) => tracing::error!(plotter = %name, job, "a run without its stop channel"),
        }
    }
    tracing::info!(plotter = %name, "plotter task stopped");
}

/// Carries out a person's manual request on the port (opened if it is
/// closed): the answer for the person, and the event for watchers.
async fn manual(
    reg: &Arc<Registry>,
    name: &str,
    port: &mut Option<Streamer<SerialPort>>,
    work: &ManualWork,
    sysfs: &std::path::Path,
) -> Result<(String, PlotterEvent), String> {
    let plan = super::manual::plan(reg, name, work).await?;
    if let Err(cause) = answers(name, port, open(reg, name, sysfs)).await {
        return Err(format!("plotter {name} does not answer ({})", cause.message));
    }
    let Some(streamer) = port.as_mut() else { return Err(format!("plotter {name} does not answer")) };
    match super::manual::stream(streamer, &plan.programs, plan.restore).await {
        Ok(()) => Ok((plan.message, plan.event)),
        Err(e) => {
            if matches!(e, StreamError::Offline(_)) {
                *port = None;
            }
            Err(format!("plotter {name}: {e}"))
        }
    }
}

/// Waits until `until` (`None`: for ever) or a wake.
async fn wait(wake: &Notify, until: Option<Instant>) {
    match until {
        Some(t) => {
            let _ = tokio::time::timeout_at(tokio::time::Instant::from_std(t), wake.notified()).await;
        }
        None => wake.notified().await,
    }
}

/// Whether the device on `port` answers, or why not: opens the port
/// (`open`) if it is closed and asks the device something it answers at
/// once. A port that fails (an adapter replugged leaves the old descriptor
/// failing with EIO) is closed, so the next call opens it afresh instead of
/// resuming on the stale descriptor (issue #15, fault 7).
async fn answers<T: AsyncRead + AsyncWrite + Unpin>(
    name: &str,
    port: &mut Option<Streamer<T>>,
    open: impl std::future::Future<Output = Result<Streamer<T>, LinkCause>>,
) -> Result<(), LinkCause> {
    if port.is_none() {
        *port = Some(open.await?);
    }
    let Some(streamer) = port.as_mut() else { return Ok(()) };
    if let Err(e) = streamer.ping().await {
        tracing::debug!(plotter = %name, error = %e, "plotter not answering");
        let waited = streamer.reply_timeout();
        *port = None;
        return Err(e.link_cause(Some(waited)).unwrap_or_else(|| LinkCause::new(LinkFault::Unreadable, e.to_string())));
    }
    Ok(())
}

/// Resets the device on the open `port` after a cancelled job
/// ([`Streamer::reset`]); whether it worked. A port that fails is closed.
async fn reset<T: AsyncRead + AsyncWrite + Unpin>(name: &str, port: &mut Option<Streamer<T>>, program: &plotcode::Program) -> bool {
    let Some(streamer) = port.as_mut() else { return false };
    match streamer.reset(program).await {
        Ok(()) => true,
        Err(e) => {
            tracing::warn!(plotter = %name, error = %e, "cannot reset the device after a cancelled job");
            if e.link_lost() {
                *port = None;
            }
            false
        }
    }
}

/// Opens plotter `name`'s port as its configuration says now, or says why
/// it cannot: a port held names the plotter of this daemon that holds it.
/// `sysfs` is where `auto` and a nickname look for EiBotBoards.
async fn open(reg: &Registry, name: &str, sysfs: &std::path::Path) -> Result<Streamer<SerialPort>, LinkCause> {
    let config = reg.config(name).ok_or_else(|| LinkCause::new(LinkFault::CannotOpen, format!("plotter {name:?} was removed")))?;
    let streamer = open_port(&config, sysfs).await.map_err(|e| {
        let holder = matches!(e, OpenError::Held(_)).then(|| reg.sharing_port(name)).flatten();
        e.link_cause(holder.as_deref())
    })?;
    tracing::info!(plotter = %name, port = %config.port.display(), nickname = ?config.nickname, "port open");
    Ok(streamer)
}

async fn open_port(config: &PlotterConfig, sysfs: &std::path::Path) -> Result<Streamer<SerialPort>, OpenError> {
    // `auto` and a nickname are asked afresh each time: a board re-plugged
    // may come back under another name.
    if let Some(nickname) = &config.nickname {
        return board_named(config, nickname, sysfs).await;
    }
    let path = usb_ports::port_to_open(&config.port, sysfs)?;
    streamer_at(&path, config)
}

/// The port of the EiBotBoard that answers `nickname` to `QT`, open: each
/// EiBotBoard under `sysfs` is opened and asked in turn (one held by
/// another opener, another plotter streaming to it, is left alone).
async fn board_named(config: &PlotterConfig, nickname: &str, sysfs: &std::path::Path) -> Result<Streamer<SerialPort>, OpenError> {
    let mut seen = Vec::new();
    let mut named = Vec::new();
    for port in usb_ports::ebb_ports(sysfs) {
        let answer = match streamer_at(&port.path, config) {
            Ok(mut streamer) => match streamer.nickname().await {
                Ok(name) => {
                    if name == nickname {
                        named.push((port.path.clone(), streamer));
                    }
                    Ok(name)
                }
                Err(e) => Err(e.to_string()),
            },
            Err(e) => Err(e.to_string()),
        };
        seen.push(usb_ports::SeenBoard { port, answer });
    }
    let path = usb_ports::the_named_ebb(nickname, seen)?;
    let (_, streamer) = named.into_iter().find(|(p, _)| *p == path).ok_or(OpenError::Missing(path))?;
    Ok(streamer)
}

fn streamer_at(path: &std::path::Path, config: &PlotterConfig) -> Result<Streamer<SerialPort>, OpenError> {
    let handshake = config.handshake();
    let port = SerialPort::open(path, config.baud, handshake == Handshake::Hardware)?;
    let mut settings = StreamSettings::new(handshake);
    settings.reply_timeout = config.reply_timeout();
    settings.motion_timeout = config.motion_timeout();
    Ok(Streamer::new(port, settings))
}

/// The error of a run's step that needs the port while it is closed.
fn port_closed() -> StreamError {
    StreamError::Offline(std::io::Error::from(std::io::ErrorKind::NotConnected))
}

/// Carries out a run's actions, and what follows each, until the run ends;
/// returns whether the link was lost (the port must be opened afresh).
async fn drive_run(
    reg: &Arc<Registry>,
    name: &str,
    first: Vec<Action>,
    port: &mut Option<Streamer<SerialPort>>,
    mut stop: watch::Receiver<Stop>,
) -> bool {
    let mut todo: VecDeque<Action> = first.into();
    // This run's written mark; `None` once it could not be written: it
    // stays behind the device, which only makes a resume draw more again,
    // never skip a stroke.
    let mut mark: Option<WrittenLog> = None;
    while let Some(action) = todo.pop_front() {
        let next = match action {
            Action::Render { job, kind, offset_mm } => {
                let rendered = render(reg, name, job, kind, offset_mm, &mut stop).await;
                reg.with(|l| l.rendered(name, rendered))
            }
            Action::ReadMark(job) => {
                let written = reg.spool.written(job);
                reg.with(|l| l.mark_read(name, written))
            }
            Action::Locate { program, from, mark: written } => {
                let found = match port.as_mut() {
                    Some(streamer) => streamer.locate(&program, from, written).await,
                    None => Err(port_closed()),
                };
                reg.with(|l| l.located(name, found))
            }
            Action::StartMark(job) => {
                reg.spool.clear_written(job);
                mark = reg
                    .spool
                    .written_log(job)
                    .map_err(|e| tracing::warn!(job, error = %e, "no written mark: an interruption resumes from the checkpoint"))
                    .ok();
                Vec::new()
            }
            Action::Stream { program, from, until, resume, lift, restore } => {
                let span = Span { program: &program, from, until, resume, lift, restore };
                let outcome = stream(reg, name, port, span, &mut stop, &mut mark).await;
                reg.with(|l| l.span_ended(name, outcome))
            }
            Action::Park { at_mm } => {
                let parked = park(reg, name, port, at_mm).await;
                reg.with(|l| l.parked(name, parked))
            }
            Action::RunEnded { lost } => return lost,
            other => reg.carry_out_one(other, &mut None),
        };
        for a in next.into_iter().rev() {
            todo.push_front(a);
        }
    }
    false
}

/// Moves plotter `name`'s head, pen up, to `at_mm` for a person's pen
/// change, answered once the device confirmed it. A place the device's
/// commands cannot reach is not a failure of the job: it pauses where the
/// head is.
async fn park(reg: &Registry, name: &str, port: &mut Option<Streamer<SerialPort>>, at_mm: [f64; 2]) -> Result<(), StreamError> {
    let Some(streamer) = port.as_mut() else { return Err(port_closed()) };
    let program = reg
        .config(name)
        .ok_or_else(|| format!("plotter {name:?} is gone"))
        .and_then(|c| c.loaded_device())
        .and_then(|d| manual::program(&d, Motion::MoveTo(at_mm.into())).map_err(|e| e.to_string()));
    match program {
        Ok(program) => super::manual::stream(streamer, &[program], crate::stream::Restore::Nothing).await,
        Err(reason) => {
            tracing::warn!(plotter = name, reason, "the head is not parked for the pen change");
            Ok(())
        }
    }
}

/// Job `id`'s program for plotter `name`'s device; gives up when a stop is asked.
async fn render(reg: &Registry, name: &str, id: JobId, kind: JobKind, offset_mm: [f64; 2], stop: &mut watch::Receiver<Stop>) -> Rendered {
    let device = match reg.config(name).map(|c| c.loaded_device()) {
        Some(Ok(d)) => plotcode::DeviceProfile { origin_offset_mm: offset_mm, ..d },
        Some(Err(reason)) => return Rendered::Failed(reason),
        None => return Rendered::Failed(format!("plotter {name:?} is gone")),
    };
    let stopped = async {
        let _ = stop.changed().await;
    };
    match super::rendering::program(reg, id, kind, &device, stopped).await {
        Ok(program) => Rendered::Program { program, pens: device.pens },
        Err(NoProgram::Failed(reason)) => Rendered::Failed(reason),
        Err(NoProgram::Stopped) => Rendered::Stopped,
    }
}

/// Streams `span` on the port, the confirmations and holds going to the
/// machine and the checkpoints it decides to a [`CheckpointWriter`],
/// which has saved them all when this returns.
async fn stream(
    reg: &Arc<Registry>,
    name: &str,
    port: &mut Option<Streamer<SerialPort>>,
    span: Span<'_>,
    stop: &mut watch::Receiver<Stop>,
    mark: &mut Option<WrittenLog>,
) -> Result<Outcome, StreamError> {
    let Some(streamer) = port.as_mut() else { return Err(port_closed()) };
    let writer = CheckpointWriter::start(reg);
    let mut journal = Journal { reg, name, writer: &writer, total: span.program.chunks.len(), mark };
    let outcome = streamer.run(span, stop, &mut journal).await;
    writer.finish().await;
    outcome
}

/// Saves the checkpoints a run confirms on a task of its own, so that the
/// task reading the device's answers never waits for an fsync: answers left
/// unread in the line when a cable is pulled are lost, and each one lost is
/// a stroke drawn again. While the disk is slow, checkpoints coalesce (the
/// newest wins); the saved checkpoint may lag the device, which only ever
/// redraws, never skips. Each save's result goes to the machine, which
/// stops the run when one fails.
struct CheckpointWriter {
    /// The newest checkpoint to save.
    latest: watch::Sender<Option<Save>>,
    task: tokio::task::JoinHandle<()>,
}

impl CheckpointWriter {
    fn start(reg: &Arc<Registry>) -> CheckpointWriter {
        let (latest, mut rx) = watch::channel(None::<Save>);
        let reg = Arc::clone(reg);
        let task = tokio::spawn(async move {
            // `changed` still reports a value sent just before the sender is dropped.
            while rx.changed().await.is_ok() {
                let Some(save) = rx.borrow_and_update().clone() else { continue };
                let (reg2, save2) = (Arc::clone(&reg), save.clone());
                let result = tokio::task::spawn_blocking(move || reg2.persist(&save2)).await.unwrap_or_else(|e| {
                    let path = reg.spool.root().to_owned();
                    Err(SpoolError::Io { path, source: std::io::Error::other(format!("checkpoint writer crashed: {e}")) })
                });
                let next = reg.settle(&save, result);
                reg.carry_out(next);
            }
        });
        CheckpointWriter { latest, task }
    }

    fn save(&self, save: Save) {
        self.latest.send_replace(Some(save));
    }

    /// Waits until the newest checkpoint is saved.
    async fn finish(self) {
        drop(self.latest);
        if let Err(e) = self.task.await {
            tracing::error!(error = %e, "checkpoint writer crashed");
        }
    }
}

/// A span's observer: confirmations and holds to the machine, writes to the
/// job's written mark.
struct Journal<'a> {
    reg: &'a Arc<Registry>,
    name: &'a str,
    writer: &'a CheckpointWriter,
    /// Chunks in the job: no confirmation goes past it.
    total: usize,
    mark: &'a mut Option<WrittenLog>,
}

impl Journal<'_> {
    /// Carries out what the machine decided: checkpoints go to the writer.
    fn carry_out(&self, actions: Vec<Action>) {
        for a in actions {
            match a {
                Action::SaveCheckpoint(save) => self.writer.save(save),
                other => {
                    self.reg.carry_out(vec![other]);
                }
            }
        }
    }
}

impl RunObserver for Journal<'_> {
    fn confirmed(&mut self, k: usize) {
        let k = k.min(self.total);
        self.carry_out(self.reg.with(|l| l.confirmed(self.name, k)));
        // Beside the mark at once, while the checkpoint waits for its fsync.
        if let Some(log) = self.mark.as_mut() {
            if let Err(e) = log.confirmed(k) {
                tracing::warn!(error = %e, "cannot record the confirmation beside the written mark");
                *self.mark = None;
            }
        }
    }
    fn held(&mut self, why: Option<Hold>) {
        self.carry_out(self.reg.with(|l| l.held(self.name, why)));
    }
    fn written(&mut self, mark: Written) {
        if let Some(log) = self.mark.as_mut() {
            if let Err(e) = log.set(mark) {
                tracing::warn!(error = %e, "cannot record the written mark");
                *self.mark = None;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;
    use tokio::io::{AsyncReadExt, AsyncWriteExt, DuplexStream};

    fn streamer(port: DuplexStream) -> Streamer<DuplexStream> {
        let mut settings = StreamSettings::new(Handshake::Escb);
        settings.reply_timeout = Duration::from_millis(500);
        Streamer::new(port, settings)
    }

    /// An HP-GL plotter that answers every ESC.B with its free buffer space.
    fn plotter() -> DuplexStream {
        let (ours, mut device) = tokio::io::duplex(256);
        tokio::spawn(async move {
            let mut buf = [0u8; 64];
            while let Ok(n) = device.read(&mut buf).await {
                let free_space = plotcode::control::hpgl::Op::FreeSpace.bytes();
                let asked = buf[..n].windows(free_space.len()).filter(|w| *w == free_space).count();
                if n == 0 || device.write_all(&b"1024\r".repeat(asked)).await.is_err() {
                    break;
                }
            }
        });
        ours
    }

    #[tokio::test]
    async fn a_port_that_failed_is_opened_afresh_before_it_is_used_again() {
        // The descriptor a replugged adapter leaves behind: its device end
        // is gone, so every write fails.
        let (stale, gone) = tokio::io::duplex(256);
        drop(gone);
        let mut port = Some(streamer(stale));
        let mut opened = 0;
        let failed = answers("p", &mut port, async { unreachable!("the open port is tried first") }).await.unwrap_err();
        assert_eq!(failed.kind, LinkFault::PortClosed, "{failed}");
        assert!(port.is_none(), "the failed descriptor is closed");
        // The next use opens the port again, and the plotter answers there.
        assert_eq!(
            answers("p", &mut port, async {
                opened += 1;
                Ok(streamer(plotter()))
            })
            .await,
            Ok(())
        );
        assert_eq!(opened, 1);
        // Open and answering: used as it is.
        assert_eq!(answers("p", &mut port, async { unreachable!("the port is open") }).await, Ok(()));
        // A port that cannot be opened leaves it closed, and says why.
        let mut closed: Option<Streamer<DuplexStream>> = None;
        let missing = LinkCause::new(LinkFault::NoSuchPort, "/dev/ttyUSB0: no such file");
        assert_eq!(answers("p", &mut closed, async { Err(missing.clone()) }).await, Err(missing));
        assert!(closed.is_none());
    }

    /// Issue 36: a device that answered with a bare CR was "no answer": it
    /// answered, with nothing readable.
    #[tokio::test]
    async fn an_empty_answer_is_not_silence() {
        let (ours, mut device) = tokio::io::duplex(256);
        tokio::spawn(async move {
            let mut buf = [0u8; 64];
            while let Ok(n) = device.read(&mut buf).await {
                if n == 0 || device.write_all(b"\r").await.is_err() {
                    break;
                }
            }
        });
        let mut port = Some(streamer(ours));
        let empty = answers("p", &mut port, async { unreachable!() }).await.unwrap_err();
        assert_eq!((empty.kind, empty.message.as_str()), (LinkFault::Unreadable, "answered ESC.B with an empty line"));
    }

    /// Issue 36: a silent device says what it was asked and how long it was
    /// waited for.
    #[tokio::test]
    async fn a_silent_device_says_what_went_unanswered_for_how_long() {
        let (ours, _device) = tokio::io::duplex(256);
        let mut port = Some(streamer(ours));
        let silent = answers("p", &mut port, async { unreachable!() }).await.unwrap_err();
        assert_eq!((silent.kind, silent.message.as_str()), (LinkFault::Silent, "no answer to ESC.B for 0.5 s"));
    }
}
