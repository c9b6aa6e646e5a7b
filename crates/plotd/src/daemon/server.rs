//! The socket side: accepts clients, reads requests line by line (bounded),
//! answers them. A bad request gets an error reply; the connection and the
//! daemon carry on.

use super::connections::{Connections, Slot};
use super::registry::{Progress, Registry, StopReason};
use crate::protocol::{decode_line, encode, Event, Frame, JobInfo, Reply, Request};
use crate::spool::{JobId, JobKind, JobRecord, JobState, PauseCause};
use crate::stream::Stop;
use base64::engine::general_purpose::STANDARD as BASE64;
use base64::Engine as _;
use scene::Attached;
use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::{Duration, Instant};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::UnixStream;
use tokio::sync::broadcast::error::RecvError;

/// A client admitted under the connection limits, and who it is.
#[derive(Debug)]
pub struct Admitted {
    slot: Slot,
    uid: u32,
    pid: i32,
}

/// Admits the connection just accepted ([`Connections::admit`]); one refused
/// is told why, and closed when dropped. Called in the accept loop, not in
/// the connection's own task: connections are then admitted in the order
/// they came, so a newer one never gives way to an older one whose task
/// happened to run later (under load the runtime runs tasks in any order).
pub fn admit(stream: &UnixStream, conns: &Arc<Connections>) -> Option<Admitted> {
    let (uid, pid) = match stream.peer_cred() {
        Ok(c) => (c.uid(), c.pid().unwrap_or(0)),
        Err(_) => (u32::MAX, 0),
    };
    match conns.admit(uid, Instant::now()) {
        Ok(slot) => Some(Admitted { slot, uid, pid }),
        Err(refused) => {
            let _ = stream.try_write(&encode(&Reply::Error { message: refused.message }));
            None
        }
    }
}

/// Serves one admitted client until it disconnects, goes silent for `idle`,
/// is displaced by a newer connection ([`Connections`]), or the daemon stops.
pub async fn handle(reg: Arc<Registry>, mut stream: UnixStream, client: Admitted, limit: usize, idle: Duration) {
    let Admitted { slot, uid, pid } = client;
    // Idle since its admission until it has asked something: it keeps the
    // place it came in.
    let mut asked = false;
    let mut buf = Vec::new();
    let mut skipping = false;
    let mut tmp = vec![0u8; 64 * 1024];
    loop {
        let frame = decode_line(&mut buf, limit, &mut skipping);
        let reply = match frame {
            Frame::Incomplete => {
                // Between requests a connection is idle and may give way to
                // a newer one; in the middle of one it keeps its place.
                if buf.is_empty() && !skipping {
                    if asked {
                        slot.idle(Instant::now());
                    }
                } else {
                    slot.busy();
                }
                let read = tokio::select! {
                    r = tokio::time::timeout(idle, stream.read(&mut tmp)) => r,
                    () = slot.displaced() => {
                        let message = "connection closed: a newer one took its place (too many open; see max_connections)".to_owned();
                        let _ = stream.try_write(&encode(&Reply::Error { message }));
                        return;
                    }
                };
                match read {
                    Err(_) => {
                        let message = format!("connection closed: nothing received for {} s (idle_timeout_s)", idle.as_secs_f64());
                        let _ = stream.try_write(&encode(&Reply::Error { message }));
                        return;
                    }
                    Ok(Ok(0) | Err(_)) => return, // disconnected, maybe mid-request: nothing was queued
                    Ok(Ok(n)) => {
                        buf.extend_from_slice(&tmp[..n]);
                        continue;
                    }
                }
            }
            Frame::TooLong => Reply::Error { message: format!("request longer than the limit of {limit} bytes (max_request_bytes in the daemon's config; a scene's files count, in base64)") },
            Frame::Line(Err(e)) => Reply::Error { message: e.to_string() },
            Frame::Line(Ok(Request::Watch { id })) => {
                slot.busy();
                watch(&reg, &mut stream, id).await;
                return;
            }
            Frame::Line(Ok(req)) => {
                slot.busy();
                answer(&reg, req, uid, pid).await
            }
        };
        asked = true;
        // A large request's buffer is not kept for the next one.
        if buf.capacity() > KEPT_BUFFER && buf.len() <= KEPT_BUFFER {
            buf.shrink_to(KEPT_BUFFER);
        }
        let reply = match reply {
            // Errors quote input: cut short, controls escaped.
            Reply::Error { message } => Reply::Error { message: crate::text::message(&message) },
            other => other,
        };
        if stream.write_all(&encode(&reply)).await.is_err() {
            return;
        }
    }
}

/// Capacity of a connection's read buffer kept between requests, bytes.
const KEPT_BUFFER: usize = 64 * 1024;

fn now_secs() -> u64 {
    std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs())
}

async fn answer(reg: &Arc<Registry>, req: Request, uid: u32, pid: i32) -> Reply {
    match req {
        Request::Submit { kind, plotter, name, content, files } => submit(reg, kind, plotter, name, content, files, uid, pid).await,
        Request::Jobs {} => {
            let st = reg.lock();
            Reply::Jobs { jobs: st.jobs.values().map(JobInfo::of).collect(), corrupt: st.corrupt.clone() }
        }
        Request::Status {} => Reply::Status {
            version: env!("CARGO_PKG_VERSION").to_owned(),
            plotters: reg.plotter_infos(),
            active: reg.lock().jobs.values().filter(|j| !j.state.is_final()).map(JobInfo::of).collect(),
        },
        Request::Watch { .. } => Reply::Error { message: "watch is answered by events".into() },
        control => {
            // These persist job states (an fsync each): off the runtime's threads.
            let reg = Arc::clone(reg);
            tokio::task::spawn_blocking(move || control_request(&reg, control))
                .await
                .unwrap_or_else(|e| Reply::Error { message: format!("internal error: {e}") })
        }
    }
}

/// `cancel`, `pause`, `resume`, `pen-changed`.
fn control_request(reg: &Registry, req: Request) -> Reply {
    let err = |message: String| Reply::Error { message };
    match req {
        Request::Cancel { id, now } => {
            let Some(job) = reg.job(id) else { return err(format!("no job {id}")) };
            if job.state.is_final() {
                return err(format!("job {id} is already {}", job.state.name()));
            }
            let running = reg.lock().plotters.iter().any(|p| p.job == Some(id));
            if running {
                reg.request_stop(&job.plotter, StopReason::Cancel, Stop::asked(now));
                let when = if now { "now" } else { "at the end of the current stroke" };
                Reply::Ok { message: format!("job {id} stops {when}") }
            } else {
                let saved = reg.update(id, Progress::default(), |j| j.state = JobState::Cancelled);
                reg.wake(&job.plotter);
                match saved {
                    Ok(()) => Reply::Ok { message: format!("job {id} cancelled") },
                    // A full disk: a cancelled job needs nothing on disk, and
                    // deleting takes no space (the record goes first).
                    Err(e) => match reg.spool.remove(id) {
                        Ok(()) => {
                            Reply::Ok { message: format!("job {id} cancelled (the spool cannot be written: {e}; its files were deleted)") }
                        }
                        Err(e2) => err(format!("job {id} is cancelled until the daemon restarts: the spool cannot record it ({e}; {e2})")),
                    },
                }
            }
        }
        Request::Pause { id, now } => {
            // A job the device holds is still running: it can be paused.
            let targets: Vec<JobRecord> = select(reg, id, |s| !s.is_final() && s.pause_cause().is_none_or(|c| c == PauseCause::DeviceHold));
            if id.is_some() && targets.is_empty() {
                return err(format!("no job {} that can be paused", id.unwrap_or_default()));
            }
            let mut n = 0;
            for job in targets {
                let running = reg.lock().plotters.iter().any(|p| p.job == Some(job.id));
                if running {
                    reg.request_stop(&job.plotter, StopReason::Pause, Stop::asked(now));
                } else if id.is_some() {
                    // Held before it starts: the plotter waits for it.
                    if let Err(e) =
                        reg.update(job.id, Progress::default(), |j| j.state = JobState::paused(PauseCause::Person, "paused by user"))
                    {
                        return err(e.to_string());
                    }
                } else {
                    continue;
                }
                n += 1;
            }
            let when = if now { "now" } else { "at the next stroke boundary" };
            Reply::Ok { message: format!("{n} job(s) pausing {when}") }
        }
        Request::Resume { id } => resume(reg, id, None),
        Request::PenChanged { plotter } => resume(reg, None, Some(plotter)),
        _ => err("not a control request".into()),
    }
}

fn select(reg: &Registry, id: Option<JobId>, pred: impl Fn(&JobState) -> bool) -> Vec<JobRecord> {
    reg.lock().jobs.values().filter(|j| id.is_none_or(|i| i == j.id) && pred(&j.state)).cloned().collect()
}

/// Resumes paused jobs: one, all, or (for `pen-changed`) those waiting for a
/// pen on the given plotter(s).
fn resume(reg: &Registry, id: Option<JobId>, pen_changed: Option<Option<String>>) -> Reply {
    // A job the device holds goes on by itself, in the run that holds it.
    let jobs = select(reg, id, |s| match s {
        JobState::Paused { cause: PauseCause::DeviceHold, .. } => false,
        JobState::Paused { insert_pen, .. } => pen_changed.is_none() || insert_pen.is_some(),
        _ => false,
    });
    let jobs: Vec<JobRecord> = match &pen_changed {
        Some(Some(p)) => jobs.into_iter().filter(|j| &j.plotter == p).collect(),
        _ => jobs,
    };
    if jobs.is_empty() {
        let message = match (id, pen_changed.is_some()) {
            (_, true) => "no job is waiting for a pen".to_owned(),
            (Some(id), _) if reg.job(id).is_some_and(|j| j.state.pause_cause() == Some(PauseCause::DeviceHold)) => {
                format!("job {id} is held by the plotter and goes on by itself once the plotter does (for a paper lever: lower it)")
            }
            (Some(id), _) => format!("job {id} is not paused"),
            (None, _) => "no paused job".to_owned(),
        };
        return Reply::Error { message };
    }
    for job in &jobs {
        let r = reg.update(job.id, Progress::default(), |j| {
            if let JobState::Paused { insert_pen: Some(p), .. } = j.state {
                j.pen_loaded = Some(p);
            }
            if let JobState::Paused { load_page: Some(p), .. } = j.state {
                j.page_loaded = p;
            }
            j.state = JobState::Queued;
        });
        if let Err(e) = r {
            return Reply::Error { message: e.to_string() };
        }
        reg.wake(&job.plotter);
    }
    let ids: Vec<String> = jobs.iter().map(|j| j.id.to_string()).collect();
    Reply::Ok { message: format!("resumed job(s) {}", ids.join(", ")) }
}

#[allow(clippy::too_many_arguments)] // the submit request's fields, unpacked
async fn submit(
    reg: &Arc<Registry>,
    kind: JobKind,
    plotter: Option<String>,
    name: Option<String>,
    content: String,
    files: BTreeMap<String, String>,
    uid: u32,
    pid: i32,
) -> Reply {
    let err = |message: String| Reply::Error { message };
    let files = match decode_files(kind, files) {
        Ok(f) => f,
        Err(e) => return err(format!("job refused: {e}")),
    };
    let (config, shutting_down) = {
        let st = reg.lock();
        let p = match &plotter {
            Some(n) => st.plotters.iter().find(|p| &p.config.name == n),
            None => st.plotters.first(),
        };
        (p.map(|p| p.config.clone()), st.shutting_down)
    };
    if shutting_down {
        return err("the daemon is shutting down".into());
    }
    let Some(config) = config else {
        let names: Vec<String> = reg.plotter_infos().into_iter().map(|p| p.name).collect();
        return err(match plotter {
            Some(n) => format!("no plotter {n:?} (configured: {})", names.join(", ")),
            None => "no plotter configured".into(),
        });
    };
    // Check the job now, in the job worker (under its budget), so a bad one
    // is refused with its reason instead of failing later. A scene is only
    // loaded and its work estimated (rendering waits for the plotter):
    // enough to refuse a bad one, one naming a file that was not sent with
    // it, or one asking for more work than the limits allow.
    let device = match config.loaded_device() {
        Ok(d) => d,
        Err(e) => return err(e),
    };
    let job = crate::worker::JobInput { kind, content: content.as_bytes(), files: &files.files, device: &device };
    if let Err(e) = reg.worker.check(job).await {
        return err(format!("job refused: {e}"));
    }
    let _order = reg.submit_lock.lock().await;
    let id = {
        let mut st = reg.lock();
        let id = st.next_id;
        st.next_id += 1;
        id
    };
    let record = JobRecord {
        id,
        kind,
        plotter: config.name.clone(),
        name: name.unwrap_or_else(|| format!("job-{id}")),
        uid,
        pid,
        submitted_at: now_secs(),
        state: JobState::Queued,
        checkpoint: 0,
        total: None,
        strokes_done: 0,
        strokes_total: None,
        pen_loaded: None,
        page_loaded: 0,
    };
    // Durable before the client hears the id.
    let spool = reg.spool.clone();
    let rec = record.clone();
    let stored = tokio::task::spawn_blocking(move || spool.create_with_files(&rec, content.as_bytes(), &files.files)).await;
    match stored {
        Ok(Ok(())) => {}
        Ok(Err(e)) => return err(format!("cannot spool the job: {e}")),
        Err(e) => return err(format!("cannot spool the job: {e}")),
    }
    reg.lock().jobs.insert(id, record.clone());
    reg.emit(&record, Progress::default());
    reg.wake(&config.name);
    tracing::info!(job = id, plotter = %config.name, uid, pid, "job queued");
    Reply::Submitted { id }
}

/// The attachments of a submit, decoded; only scenes name files.
fn decode_files(kind: JobKind, files: BTreeMap<String, String>) -> Result<Attached, String> {
    if files.is_empty() {
        return Ok(Attached::default());
    }
    if kind != JobKind::Scene {
        return Err("only a scene job carries files".into());
    }
    let mut out = Attached::default();
    for (name, b64) in files {
        let bytes = BASE64.decode(b64.as_bytes()).map_err(|e| format!("files.`{name}`: not base64: {e}"))?;
        out.files.insert(name, bytes);
    }
    Ok(out)
}

/// Streams events until the client goes, or until job `id` ends.
async fn watch(reg: &Arc<Registry>, stream: &mut UnixStream, id: Option<JobId>) {
    let mut rx = reg.events.subscribe();
    // Start with the current state, so a watcher that comes late knows where things are.
    let initial: Vec<JobRecord> = match id {
        Some(id) => reg.job(id).into_iter().collect(),
        None => reg.lock().jobs.values().filter(|j| !j.state.is_final()).cloned().collect(),
    };
    if id.is_some() && initial.is_empty() {
        let _ = stream.write_all(&encode(&Reply::Error { message: format!("no job {}", id.unwrap_or(0)) })).await;
        return;
    }
    for job in &initial {
        let ev = event_of(job);
        if stream.write_all(&encode(&Reply::Event(ev))).await.is_err() {
            return;
        }
        if id.is_some() && job.state.is_final() {
            return;
        }
    }
    let (mut rd, mut wr) = stream.split();
    let mut sink = [0u8; 256];
    loop {
        let ev = tokio::select! {
            ev = rx.recv() => ev,
            // The client's only move is to go away.
            r = rd.read(&mut sink) => match r { Ok(0) | Err(_) => return, Ok(_) => continue },
        };
        let ev = match ev {
            Ok(ev) => ev,
            Err(RecvError::Lagged(_)) => match id.and_then(|i| reg.job(i)) {
                Some(job) => event_of(&job),
                None => continue,
            },
            Err(RecvError::Closed) => return,
        };
        if id.is_some_and(|i| i != ev.job) {
            continue;
        }
        let last = id.is_some() && ev.state.is_final();
        if wr.write_all(&encode(&Reply::Event(ev))).await.is_err() || last {
            return;
        }
    }
}

fn event_of(job: &JobRecord) -> Event {
    Event::of(job, 0, None)
}
