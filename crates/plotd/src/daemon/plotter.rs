//! One task per plotter: it owns the serial port, takes that plotter's jobs
//! in id order, streams them, and turns every interruption into a persisted
//! `paused` state with a reason.
//!
//! The oldest unfinished job of a plotter holds it: a paused job blocks the
//! jobs behind it (they would be drawn on its paper).

use super::registry::{LinkState, Progress, Registry, StopReason};
use super::rendering::NoProgram;
use crate::config::{DeviceErrorPolicy, PenChangePolicy, PlotterConfig};
use crate::spool::{JobRecord, JobState, PauseCause, WrittenLog};
use crate::stream::{Hold, Outcome, RunObserver, SerialPort, Span, Stop, StreamError, StreamSettings, Streamer, Written};
use plotcode::{Handshake, Program};
use std::sync::Arc;
use std::time::Duration;
use tokio::io::{AsyncRead, AsyncWrite};
use tokio::sync::watch;

/// First wait before reopening a port that failed; doubles up to [`BACKOFF_MAX`].
const BACKOFF_MIN: Duration = Duration::from_millis(250);
/// Longest wait between attempts to reopen a port.
const BACKOFF_MAX: Duration = Duration::from_secs(30);
/// How often an idle plotter is asked whether it is there.
const IDLE_CHECK: Duration = Duration::from_secs(3);
/// Reason text of a pause caused by the link.
const OFFLINE: &str = "device offline";
/// Reason text of a pause because the spool could not be written.
const UNSAVED: &str = "paused: the spool cannot be written, so plotting stopped before the record fell behind the device";

/// The task body for plotter `name`. Returns when `shutdown` becomes true
/// and the current job has stopped at a stroke boundary.
pub async fn run(reg: Arc<Registry>, name: String, shutdown: watch::Receiver<bool>) {
    let mut port: Option<Streamer<SerialPort>> = None;
    let mut backoff = BACKOFF_MIN;
    loop {
        if *shutdown.borrow() {
            break;
        }
        let (config, wake, job) = {
            let st = reg.lock();
            let Some(slot) = st.plotters.iter().find(|p| p.config.name == name) else { break };
            let job = st.jobs.values().find(|j| j.plotter == name && !j.state.is_final()).cloned();
            (slot.config.clone(), slot.wake.clone(), job)
        };
        let wait = |d: Option<Duration>| {
            let wake = wake.clone();
            let mut shutdown = shutdown.clone();
            async move {
                tokio::select! {
                    _ = wake.notified() => {}
                    _ = shutdown.changed() => {}
                    _ = async { match d { Some(d) => tokio::time::sleep(d).await, None => std::future::pending().await } } => {}
                }
            }
        };
        let Some(job) = job else {
            // Idle: watch the port, so that `status` shows a dead plotter
            // before a job finds it.
            answering(&reg, &name, &config, &mut port).await;
            wait(Some(IDLE_CHECK)).await;
            continue;
        };
        if let Some(cause) = job.state.pause_cause() {
            let offline = cause == PauseCause::Offline;
            // Watched, so that `status` shows when it is back.
            let back = offline && answering(&reg, &name, &config, &mut port).await;
            if back && config.auto_resume {
                tracing::info!(job = job.id, "port back: resuming by config (auto_resume)");
                let _ = reg.update(job.id, Progress::default(), |j| j.state = JobState::Queued);
                continue;
            }
            wait(offline.then_some(backoff)).await;
            backoff = (backoff * 2).min(BACKOFF_MAX);
            continue;
        }
        // A job for a plotter that does not answer stays queued until it does.
        if !answering(&reg, &name, &config, &mut port).await {
            tracing::debug!(plotter = %name, "plotter not answering; retrying in {backoff:?}");
            wait(Some(backoff)).await;
            backoff = (backoff * 2).min(BACKOFF_MAX);
            continue;
        }
        backoff = BACKOFF_MIN;
        let Some(streamer) = port.as_mut() else { continue };
        // The plotter may have been power-cycled since the last job: set it up again.
        streamer.forget_device();
        if run_job(&reg, &name, &config, job, streamer).await {
            port = None;
            set_link(&reg, &name, LinkState::Offline);
        }
        let _ = shutdown.has_changed();
    }
    if let Some(slot) = reg.lock().plotter_mut(&name) {
        slot.job = None;
    }
    tracing::info!(plotter = %name, "plotter task stopped");
}

/// Whether the plotter answers (see [`answers`]), shown in `status`.
async fn answering(reg: &Registry, name: &str, config: &PlotterConfig, port: &mut Option<Streamer<SerialPort>>) -> bool {
    let ok = answers(name, port, || {
        let s = open(config)?;
        tracing::info!(plotter = %name, port = %config.port.display(), "port open");
        Ok(s)
    })
    .await;
    set_link(reg, name, if ok { LinkState::Online } else { LinkState::Offline });
    ok
}

/// Whether the device on `port` answers: opens the port (`open`) if it is
/// closed and asks the device something it answers at once. A port that
/// fails (an adapter replugged leaves the old descriptor failing with EIO)
/// is closed, so the next call opens it afresh instead of resuming on the
/// stale descriptor (issue #15, fault 7).
async fn answers<T: AsyncRead + AsyncWrite + Unpin>(
    name: &str,
    port: &mut Option<Streamer<T>>,
    open: impl FnOnce() -> std::io::Result<Streamer<T>>,
) -> bool {
    if port.is_none() {
        match open() {
            Ok(s) => *port = Some(s),
            Err(e) => {
                tracing::debug!(plotter = %name, error = %e, "port not available");
                return false;
            }
        }
    }
    let Some(streamer) = port.as_mut() else { return false };
    if let Err(e) = streamer.ping().await {
        tracing::info!(plotter = %name, error = %e, "plotter not answering");
        *port = None;
        return false;
    }
    true
}

fn set_link(reg: &Registry, name: &str, link: LinkState) {
    if let Some(p) = reg.lock().plotter_mut(name) {
        p.link = link;
    }
}

fn open(config: &PlotterConfig) -> std::io::Result<Streamer<SerialPort>> {
    let handshake = config.handshake();
    let port = SerialPort::open(&config.port, config.baud, handshake == Handshake::Hardware)?;
    let mut settings = StreamSettings::new(handshake);
    settings.reply_timeout = config.reply_timeout();
    settings.motion_timeout = config.motion_timeout();
    Ok(Streamer::new(port, settings))
}

/// Where the next pause for a human falls, from `from` on: the first chunk on
/// a page other than the one loaded (new paper), or with `pauses`, the first
/// drawing chunk whose pen is not the one loaded.
fn next_pen_change(program: &Program, from: usize, rec: &JobRecord, pauses: bool) -> usize {
    program.chunks[from..]
        .iter()
        .position(|c| c.page != rec.page_loaded || (pauses && c.draws && c.pen.is_some() && c.pen != rec.pen_loaded))
        .map_or(program.chunks.len(), |i| from + i)
}

/// Streams one job until it ends or stops. Returns true when the port was lost.
async fn run_job(reg: &Arc<Registry>, name: &str, config: &PlotterConfig, job: JobRecord, streamer: &mut Streamer<SerialPort>) -> bool {
    let id = job.id;
    let mut stop = {
        let mut st = reg.lock();
        let Some(slot) = st.plotter_mut(name) else { return false };
        slot.job = Some(id);
        slot.stop_reason = None;
        slot.stop.send_replace(Stop::Continue);
        slot.stop.subscribe()
    };
    // The job's last progress, which its final event carries too.
    let mut progress = Progress::default();
    let result = run_job_inner(reg, config, job, streamer, &mut stop, &mut progress).await;
    let stop_reason = {
        let mut st = reg.lock();
        let r = st.plotter_mut(name).and_then(|s| {
            s.job = None;
            s.stop.send_replace(Stop::Continue);
            s.stop_reason.take()
        });
        r.or(if st.shutting_down { Some(StopReason::Shutdown) } else { None })
    };
    let (state, lost) = match result {
        Ok(Some(state)) => (state, false),
        Ok(None) => {
            let state = match stop_reason {
                Some(StopReason::Cancel) => JobState::Cancelled,
                Some(StopReason::Shutdown) => JobState::paused(PauseCause::Interrupted, "interrupted: the daemon shut down"),
                Some(StopReason::Pause) | None => JobState::paused(PauseCause::Person, "paused by user"),
                // Set with an error the run returns; not reached.
                Some(StopReason::Unsaved) => JobState::paused(PauseCause::Unsaved, UNSAVED),
            };
            (state, false)
        }
        // The device lost what it held: nothing it reports tells how far it got.
        Err(e @ StreamError::Reset(_)) => {
            reg.spool.clear_written(id);
            (JobState::paused(PauseCause::Offline, format!("{OFFLINE}: {e}")), true)
        }
        Err(e) if e.link_lost() => (JobState::paused(PauseCause::Offline, format!("{OFFLINE}: {e}")), true),
        Err(e) => {
            // The streamer dropped what the device held after the error.
            reg.spool.clear_written(id);
            let text = e.to_string();
            let state = match config.on_device_error {
                DeviceErrorPolicy::Pause => JobState::paused(PauseCause::DeviceError, text),
                DeviceErrorPolicy::Fail => JobState::Failed { reason: text },
            };
            (state, false)
        }
    };
    if state.is_final() {
        reg.spool.clear_written(id);
    }
    tracing::info!(job = id, state = state.name(), "job stopped running");
    if let Err(e) = reg.update(id, progress, |j| j.state = state) {
        tracing::error!(job = id, error = %e, "cannot persist job state");
    }
    lost
}

/// The job's run; `Ok(Some(state))` is a final or pen-change state, `Ok(None)`
/// a stop on request.
async fn run_job_inner(
    reg: &Arc<Registry>,
    config: &PlotterConfig,
    job: JobRecord,
    streamer: &mut Streamer<SerialPort>,
    stop: &mut watch::Receiver<Stop>,
    progress: &mut Progress,
) -> Result<Option<JobState>, StreamError> {
    let id = job.id;
    // A state that cannot be saved stops the run: the job is paused (in
    // memory, and on disk once the spool can be written again).
    let persist = |change: &(dyn Fn(&mut JobRecord) + Sync), progress: Progress| {
        reg.update(id, progress, |j| change(j)).map_err(|e| {
            tracing::error!(job = id, error = %e, "cannot persist job");
            JobState::paused(PauseCause::Unsaved, format!("{UNSAVED}: {e}"))
        })
    };
    if let Err(paused) = persist(&|j| j.state = JobState::Rendering, Progress::default()) {
        return Ok(Some(paused));
    }
    let device = match config.loaded_device() {
        Ok(d) => d,
        Err(reason) => return Ok(Some(JobState::Failed { reason })),
    };
    let stopped = async {
        let _ = stop.changed().await;
    };
    let program = match super::rendering::program(reg, id, job.kind, &device, stopped).await {
        Ok(p) => Arc::new(p),
        Err(NoProgram::Failed(reason)) => return Ok(Some(JobState::Failed { reason: crate::text::message(&reason) })),
        // Nothing was drawn: a shutdown leaves the job queued for the next start.
        Err(NoProgram::Stopped) => {
            let shutdown = reg.lock().plotter_mut(&config.name).is_some_and(|s| s.stop_reason == Some(StopReason::Shutdown));
            return Ok(if shutdown { Some(JobState::Queued) } else { None });
        }
    };
    let total = program.chunks.len();
    // Prefix sums for progress events: bytes, and strokes (chunks that draw;
    // the job's tail and pen changes are chunks too, but no strokes).
    let mut acked = vec![0u64; total + 1];
    let mut drawn = vec![0usize; total + 1];
    for (i, c) in program.chunks.iter().enumerate() {
        acked[i + 1] = acked[i] + c.bytes.len() as u64;
        drawn[i + 1] = drawn[i] + usize::from(c.draws);
    }
    let first_pen = program.chunks.iter().find(|c| c.draws).and_then(|c| c.pen);
    let plotting = persist(
        &|j| {
            j.state = JobState::Plotting;
            j.total = Some(total);
            j.checkpoint = j.checkpoint.min(total);
            j.strokes_total = Some(drawn[total]);
            j.strokes_done = drawn[j.checkpoint];
            j.pen_loaded = j.pen_loaded.or(first_pen);
        },
        Progress { bytes_acked: acked[job.checkpoint.min(total)], eta_s: Some(program.seconds_from(job.checkpoint)) },
    );
    if let Err(paused) = plotting {
        return Ok(Some(paused));
    }
    let pauses = match config.pen_change {
        PenChangePolicy::Pause => true,
        PenChangePolicy::Ignore => false,
        PenChangePolicy::Auto => device.pens <= 1,
    };
    let checkpoint = locate(reg, id, &program, job.checkpoint, streamer).await?;
    if checkpoint > job.checkpoint {
        let located = persist(
            &|j| {
                j.checkpoint = j.checkpoint.max(checkpoint);
                j.strokes_done = drawn[j.checkpoint.min(total)];
            },
            Progress { bytes_acked: acked[checkpoint], eta_s: Some(program.seconds_from(checkpoint)) },
        );
        if let Err(paused) = located {
            return Ok(Some(paused));
        }
    }
    // From here on the mark describes this run's writes only.
    reg.spool.clear_written(id);
    let mut log = match reg.spool.written_log(id) {
        Ok(l) => Some(l),
        Err(e) => {
            tracing::warn!(job = id, error = %e, "no written mark: an interruption resumes from the checkpoint");
            None
        }
    };
    let mut resume = checkpoint > 0;
    // Stalls resynced in a row, and the bytes confirmed at the last one.
    let (mut stalls, mut stalled_at) = (0usize, 0u64);
    loop {
        let Some(rec) = reg.job(id) else { return Ok(Some(JobState::Cancelled)) };
        let from = rec.checkpoint.min(total);
        *progress = Progress { bytes_acked: acked[from], eta_s: Some(program.seconds_from(from)) };
        if from >= total {
            return Ok(Some(JobState::Done));
        }
        let change = next_pen_change(&program, from, &rec, pauses);
        if change == from {
            let chunk = &program.chunks[from];
            if chunk.page != rec.page_loaded {
                let reason = format!("load paper for frame {} of {}", chunk.page + 1, program.page_count());
                return Ok(Some(JobState::Paused { cause: PauseCause::Load, reason, insert_pen: None, load_page: Some(chunk.page) }));
            }
            let pen = chunk.pen.unwrap_or(0);
            let reason = format!("insert pen {pen}");
            return Ok(Some(JobState::Paused { cause: PauseCause::Load, reason, insert_pen: Some(pen), load_page: None }));
        }
        let checkpoints = CheckpointWriter::start(reg, &config.name, id, &program, &acked, &drawn);
        let mut on_confirm = Journal { checkpoints: &checkpoints, total, log: &mut log };
        let lift = change < total;
        let span = Span { program: &program, from, until: change, resume, lift };
        let outcome = streamer.run(span, stop, &mut on_confirm).await;
        if let Some(e) = checkpoints.finish().await {
            // The device stopped at a stroke boundary (the writer asked for
            // it); the checkpoint in memory is where it stands.
            return match outcome {
                Err(e) => Err(e),
                Ok(_) => Ok(Some(JobState::paused(PauseCause::Unsaved, format!("{UNSAVED}: {e}")))),
            };
        }
        if let Some(rec) = reg.job(id) {
            let k = rec.checkpoint.min(total);
            *progress = Progress { bytes_acked: acked[k], eta_s: Some(program.seconds_from(k)) };
        }
        match outcome {
            Ok(Outcome::Finished) => {
                resume = false;
                stalls = 0;
            }
            Ok(Outcome::Stopped) => {
                // The device holds nothing of the job (a stop now dropped
                // what it had not run): no write is left to locate.
                reg.spool.clear_written(id);
                return Ok(None);
            }
            // The board lost lines it was sent: resync (the next run asks
            // for the build info first, which every stale answer precedes) and go on from
            // the confirmed chunk, once per checkpoint; a second stall
            // without progress pauses the job with the reason.
            Err(e @ StreamError::Stalled { .. }) if stalls == 0 || progress.bytes_acked > stalled_at => {
                tracing::warn!(job = id, error = %e, "resyncing and resuming from the checkpoint");
                stalls += 1;
                stalled_at = progress.bytes_acked;
                resume = true;
            }
            Err(e) => return Err(e),
        }
    }
}

/// Persists confirmed checkpoints on a task of their own, so that the task
/// reading the device's answers never waits for an fsync: answers left unread
/// in the line when a cable is pulled are lost, and each one lost is a stroke
/// drawn again. While the disk is slow, confirmations coalesce (the latest
/// wins); the persisted checkpoint may lag the device, which only ever
/// redraws, never skips.
///
/// A checkpoint that cannot be saved asks the plotter to stop at the next
/// stroke boundary ([`StopReason::Unsaved`]); the registry keeps the
/// checkpoint in memory all the same, so nothing is streamed twice.
///
/// It also shows when the device holds the job ([`Hold`]: the paper lever
/// up): the job is `paused` with [`PauseCause::DeviceHold`] and the
/// device's reason while the run waits, and `plotting` again when the
/// device goes on. **A job the device holds is still the run's**: `resume`
/// refuses it, and a restart finds it interrupted.
struct CheckpointWriter {
    /// The latest report; the task persists the newest one it sees.
    latest: watch::Sender<RunReport>,
    /// The first save error, returned by [`CheckpointWriter::finish`].
    task: tokio::task::JoinHandle<Option<String>>,
}

impl CheckpointWriter {
    fn start(reg: &Arc<Registry>, plotter: &str, id: u64, program: &Arc<Program>, acked: &[u64], drawn: &[usize]) -> CheckpointWriter {
        let (latest, mut rx) = watch::channel(RunReport::default());
        let (reg, program, acked, drawn, plotter) =
            (Arc::clone(reg), Arc::clone(program), acked.to_vec(), Arc::new(drawn.to_vec()), plotter.to_owned());
        let task = tokio::spawn(async move {
            let mut failed = None;
            // `changed` still reports a value sent just before the sender is dropped.
            while rx.changed().await.is_ok() {
                let RunReport { confirmed: k, held } = *rx.borrow_and_update();
                let (reg2, progress) = (Arc::clone(&reg), Progress { bytes_acked: acked[k], eta_s: Some(program.seconds_from(k)) });
                let drawn = Arc::clone(&drawn);
                let saved = tokio::task::spawn_blocking(move || {
                    reg2.update(id, progress, |j| {
                        j.checkpoint = j.checkpoint.max(k);
                        j.strokes_done = drawn[j.checkpoint.min(drawn.len() - 1)];
                        match (held, j.state.pause_cause()) {
                            (Some(why), None) => j.state = JobState::paused(PauseCause::DeviceHold, format!("held by the plotter: {why}")),
                            (None, Some(PauseCause::DeviceHold)) => j.state = JobState::Plotting,
                            _ => {}
                        }
                    })
                })
                .await;
                let error = match saved {
                    Ok(Ok(())) => continue,
                    Ok(Err(e)) => e.to_string(),
                    Err(e) => format!("checkpoint writer crashed: {e}"),
                };
                if failed.is_none() {
                    tracing::error!(job = id, error = %error, "cannot persist the checkpoint: stopping the job");
                    reg.request_stop(&plotter, StopReason::Unsaved, Stop::AfterStroke);
                    failed = Some(error);
                }
            }
            failed
        });
        CheckpointWriter { latest, task }
    }

    fn confirmed(&self, k: usize) {
        self.latest.send_if_modified(|v| {
            let moved = k > v.confirmed;
            v.confirmed = v.confirmed.max(k);
            moved
        });
    }

    fn held(&self, why: Option<Hold>) {
        self.latest.send_if_modified(|v| std::mem::replace(&mut v.held, why) != why);
    }

    /// Waits until the last confirmation is persisted; returns the first
    /// error when one could not be.
    async fn finish(self) -> Option<String> {
        drop(self.latest);
        self.task.await.unwrap_or_else(|e| Some(format!("checkpoint writer crashed: {e}")))
    }
}

/// Where to resume job `id`: past its checkpoint when the device shows how
/// far it got in what the written mark says was written ([`Streamer::locate`]).
/// An unplugged adapter takes bytes written and not delivered with it: the
/// device just stopped earlier, which its position shows. The candidates
/// start at the last confirmation the run heard, which the written log
/// keeps: the saved checkpoint lags it (saved with fsync on a task of its
/// own), and under load by many strokes, each a candidate for a place the
/// pen rests at (issue #15: a GRBL job drew two strokes again after a
/// SIGKILL).
async fn locate(
    reg: &Registry,
    id: u64,
    program: &Program,
    checkpoint: usize,
    streamer: &mut Streamer<SerialPort>,
) -> Result<usize, StreamError> {
    let Some(w) = reg.spool.written(id) else { return Ok(checkpoint) };
    let checkpoint = checkpoint.max(w.confirmed.min(program.chunks.len()));
    if w.mark.resume_at() <= checkpoint {
        return Ok(checkpoint);
    }
    let found = streamer.locate(program, checkpoint, w.mark).await?;
    Ok(found.map_or(checkpoint, |k| k.clamp(checkpoint, program.chunks.len())))
}

/// What a run last reported to the [`CheckpointWriter`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct RunReport {
    /// Chunks confirmed.
    confirmed: usize,
    /// Why the device holds the job, while it does.
    held: Option<Hold>,
}

/// A run's progress: confirmations persisted as checkpoints, holds shown in
/// the job's state, writes recorded in the job's written mark.
struct Journal<'a> {
    checkpoints: &'a CheckpointWriter,
    /// Chunks in the job: no checkpoint goes past it.
    total: usize,
    /// `None` once the mark could not be written: it stays behind the device,
    /// which only makes a resume draw more again, never skip a stroke.
    log: &'a mut Option<WrittenLog>,
}

impl RunObserver for Journal<'_> {
    fn confirmed(&mut self, k: usize) {
        let k = k.min(self.total);
        self.checkpoints.confirmed(k);
        // Beside the mark at once, while the checkpoint waits for its fsync.
        if let Some(log) = self.log.as_mut() {
            if let Err(e) = log.confirmed(k) {
                tracing::warn!(error = %e, "cannot record the confirmation beside the written mark");
                *self.log = None;
            }
        }
    }
    fn held(&mut self, why: Option<Hold>) {
        self.checkpoints.held(why);
    }
    fn written(&mut self, mark: Written) {
        if let Some(log) = self.log.as_mut() {
            if let Err(e) = log.set(mark) {
                tracing::warn!(error = %e, "cannot record the written mark");
                *self.log = None;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
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
        assert!(!answers("p", &mut port, || unreachable!("the open port is tried first")).await);
        assert!(port.is_none(), "the failed descriptor is closed");
        // The next use opens the port again, and the plotter answers there.
        assert!(
            answers("p", &mut port, || {
                opened += 1;
                Ok(streamer(plotter()))
            })
            .await
        );
        assert_eq!(opened, 1);
        // Open and answering: used as it is.
        assert!(answers("p", &mut port, || unreachable!("the port is open")).await);
        // A port that cannot be opened leaves it closed.
        let mut closed: Option<Streamer<DuplexStream>> = None;
        assert!(!answers("p", &mut closed, || Err(std::io::Error::from_raw_os_error(2))).await);
        assert!(closed.is_none());
    }
}
