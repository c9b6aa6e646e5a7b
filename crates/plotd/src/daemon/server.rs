//! The socket side: accepts clients, reads requests line by line (bounded),
//! answers them. A bad request gets an error reply; the connection and the
//! daemon carry on.

use super::access::Caller;
use super::connections::{Connections, Slot};
use super::registry::Registry;
use crate::config::PlotterConfig;
use crate::job::{JobLife, Manual, NewJob, SubmitError, Target};
use crate::pen_map::{self, PenMap};
use crate::protocol::{encode, Event, Frame, LineDecoder, Manoeuvre, PlotterEvent, Reply, Request, EVENT_VERSION};
use crate::spool::{JobId, JobKind, JobRecord, Occult};
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
    // Idle since its admission, and again from each reply on (below).
    let mut lines = LineDecoder::new(limit);
    let mut tmp = vec![0u8; 64 * 1024];
    loop {
        let frame = lines.next_frame();
        let reply = match frame {
            Frame::Incomplete => {
                // Between requests a connection is idle and may give way to
                // a newer one; in the middle of one it keeps its place.
                if lines.mid_line() {
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
                        lines.extend(&tmp[..n]);
                        continue;
                    }
                }
            }
            Frame::TooLong => Reply::Error { message: format!("request longer than the limit of {limit} bytes (max_request_bytes in the daemon's config; a scene's files count, in base64)") },
            Frame::Line(Err(e)) => Reply::Error { message: e.to_string() },
            Frame::Line(Ok(Request::Watch { id })) => {
                slot.busy();
                watch(&reg, &mut stream, id, Caller::of(uid)).await;
                return;
            }
            Frame::Line(Ok(req)) => {
                slot.busy();
                answer(&reg, req, uid, pid).await
            }
        };
        // A large request's buffer is not kept for the next one.
        lines.shrink(KEPT_BUFFER);
        let reply = match reply {
            // Errors quote input: cut short, controls escaped.
            Reply::Error { message } => Reply::Error { message: crate::text::message(&message) },
            other => other,
        };
        // Idle from the moment its reply can be read: a client that has
        // its answer and opens another connection must find this one free
        // to give way (marked only on the next read, it was still busy, and
        // the newer connection was refused).
        slot.idle(Instant::now());
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

/// Answers every request but `watch` for the client `uid`/`pid`: the
/// socket's and the web page's.
pub(super) async fn answer(reg: &Arc<Registry>, req: Request, uid: u32, pid: i32) -> Reply {
    let caller = Caller::of(uid);
    match req {
        Request::Submit { kind, plotter, name, content, files, same_sheet, copies, pens, occult } => {
            match submit(reg, kind, plotter, name, content, files, (same_sheet, copies, pens, occult), uid, pid).await {
                Ok(id) => Reply::Submitted { id },
                Err(e) => Reply::Error { message: e.to_string() },
            }
        }
        Request::Jobs {} => {
            let jobs = reg.jobs().into_iter().map(|j| caller.sees(j)).collect();
            Reply::Jobs { jobs, corrupt: reg.corrupt().to_vec() }
        }
        Request::Status {} => {
            let active = reg.active_jobs().into_iter().map(|j| caller.sees(j)).collect();
            Reply::Status { version: env!("CARGO_PKG_VERSION").to_owned(), plotters: reg.plotter_infos(), active }
        }
        Request::Watch { .. } => Reply::Error { message: "watch is answered by events".into() },
        Request::Pen { plotter, down } => manual(reg, plotter, Manual::Pen { down }).await,
        Request::Move { plotter, x_mm, y_mm } => manual(reg, plotter, Manual::MoveTo { x_mm, y_mm }).await,
        Request::Jog { plotter, dx_mm, dy_mm } => manual(reg, plotter, Manual::Jog { dx_mm, dy_mm }).await,
        Request::Home { plotter } => manual(reg, plotter, Manual::Home).await,
        Request::Frame { id } => manual(reg, None, Manual::Frame { job: id }).await,
        control => {
            if let Err(message) = caller.may(reg, &control) {
                return Reply::Error { message };
            }
            // These save job states (an fsync each): off the runtime's threads.
            let reg = Arc::clone(reg);
            tokio::task::spawn_blocking(move || control_request(&reg, control))
                .await
                .unwrap_or_else(|e| Reply::Error { message: format!("internal error: {e}") })
        }
    }
}

/// A manual request: decided by the job's life, carried out by the
/// plotter's task, answered once the device has done it.
async fn manual(reg: &Arc<Registry>, plotter: Option<String>, op: Manual) -> Reply {
    // Accepting one forgets a paused job's written mark (a file): off the runtime's threads.
    let reg = Arc::clone(reg);
    let accepted = tokio::task::spawn_blocking(move || reg.manual(plotter.as_deref(), op)).await;
    let done = match accepted {
        Ok(Ok(done)) => done,
        Ok(Err(refused)) => return Reply::Error { message: refused.to_string() },
        Err(e) => return Reply::Error { message: format!("internal error: {e}") },
    };
    match done.await {
        Ok(Ok(message)) => Reply::Ok { message },
        Ok(Err(message)) => Reply::Error { message },
        Err(_) => Reply::Error { message: "the daemon stopped before the plotter did it".into() },
    }
}

/// `cancel`, `pause`, `resume`, `pen-changed`, `sheet-loaded`, `offset`: decided by the job's life,
/// carried out by the registry.
fn control_request(reg: &Registry, req: Request) -> Reply {
    let answer = match req {
        Request::Cancel { id, now } => reg.control(|l| l.cancel(id, now)),
        Request::Pause { id, now } => reg.control(|l| l.pause(id, now)),
        Request::Resume { id, position_confirmed } => reg.control(|l| l.resume(id, position_confirmed)),
        Request::PenChanged { plotter } => reg.control(|l| l.pen_changed(plotter.as_deref())),
        Request::SheetLoaded { plotter } => reg.control(|l| l.sheet_loaded(&plotter)),
        Request::Offset { plotter, dx_mm, dy_mm } => {
            let set = reg.control(|l| l.set_offset(&plotter, [dx_mm, dy_mm]));
            if set.is_ok() {
                // Watchers (the web page) see the plotter's new offset at once.
                let did = PlotterEvent { plotter, did: Manoeuvre::Offset, mm: Some([dx_mm, dy_mm]), job: None, v: EVENT_VERSION };
                let _ = reg.plotter_events.send(did);
            }
            set
        }
        _ => return Reply::Error { message: "not a control request".into() },
    };
    match answer {
        Ok(message) => Reply::Ok { message },
        Err(e) => Reply::Error { message: e.to_string() },
    }
}

#[allow(clippy::too_many_arguments)] // the submit request's fields, unpacked
async fn submit(
    reg: &Arc<Registry>,
    kind: JobKind,
    plotter: Option<String>,
    name: Option<String>,
    content: String,
    files: BTreeMap<String, String>,
    (same_sheet, copies, pens, occult): (bool, u32, PenMap, Option<Occult>),
    uid: u32,
    pid: i32,
) -> Result<JobId, SubmitError> {
    let files = decode_files(kind, files)?;
    JobLife::check_copies(copies)?;
    if occult.is_some() && kind != JobKind::Svg {
        return Err(SubmitError::Refused(
            "occult: only an SVG drawing's filled shapes hide lines (a scene hides by its faces; HP-GL and G-code are plotted as written)"
                .into(),
        ));
    }
    let asked = Asked { kind, content: &content, files: &files, pens: &pens, occult };
    let (plotter, class) = match reg.with(|l| l.admit(plotter.as_deref()))? {
        Target::Plotter(config) => {
            check_on(reg, &config, asked, uid).await?;
            (config.name.clone(), None)
        }
        Target::Class { name, plotters } => {
            let fits = fitting(reg, &name, &plotters, asked, uid).await?;
            (name.clone(), Some(crate::job::class(&name, &fits)))
        }
    };
    let _order = reg.submit_lock.lock().await;
    let new = NewJob { kind, plotter: plotter.clone(), class, name, uid, pid, submitted_at: now_secs(), same_sheet, copies, pens, occult };
    let record = reg.with(|l| l.new_job(new));
    // Durable before the client hears the id.
    let spool = reg.spool.clone();
    let rec = record.clone();
    tokio::task::spawn_blocking(move || spool.create_with_files(&rec, content.as_bytes(), &files.files))
        .await
        .map_err(|e| SubmitError::Spool(e.to_string()))?
        .map_err(|e| SubmitError::Spool(e.to_string()))?;
    let id = record.id;
    let created = reg.with(|l| l.created(record));
    reg.carry_out(created);
    tracing::info!(job = id, plotter = %plotter, uid, pid, "job queued");
    Ok(id)
}

/// What a submit asks to have drawn, as its checks read it.
#[derive(Clone, Copy)]
struct Asked<'a> {
    kind: JobKind,
    content: &'a str,
    files: &'a Attached,
    pens: &'a PenMap,
    occult: Option<Occult>,
}

/// The plotters of class `class` that can draw the job, in order: its
/// checks run for each (once for plotters of one device and pen table).
///
/// # Errors
/// [`SubmitError::NoneFits`] naming why for each, when none can.
async fn fitting(
    reg: &Arc<Registry>,
    class: &str,
    plotters: &[PlotterConfig],
    asked: Asked<'_>,
    uid: u32,
) -> Result<Vec<PlotterConfig>, SubmitError> {
    let (mut fits, mut why) = (Vec::new(), Vec::new());
    // Plotters alike are judged alike: the check is the worker's, and slow.
    let mut judged: Vec<((String, String), Result<(), String>)> = Vec::new();
    for config in plotters {
        let alike = (config.device.clone(), format!("{:?}", config.pen));
        let verdict = match judged.iter().find(|(k, _)| *k == alike) {
            Some((_, v)) => v.clone(),
            None => {
                let v = match check_on(reg, config, asked, uid).await {
                    Ok(()) => Ok(()),
                    Err(SubmitError::Refused(e) | SubmitError::Device(e)) => Err(e),
                    Err(e) => return Err(e),
                };
                judged.push((alike, v.clone()));
                v
            }
        };
        match verdict {
            Ok(()) => fits.push(config.clone()),
            Err(e) => why.push((config.name.clone(), e)),
        }
    }
    if fits.is_empty() {
        return Err(SubmitError::NoneFits { class: class.to_owned(), why });
    }
    Ok(fits)
}

/// Checks the job for plotter `config`: its pens, and (in the job worker,
/// under its budget) its content, so a bad one is refused with its reason
/// instead of failing later. A scene is only loaded and its work estimated
/// (rendering waits for the plotter): enough to refuse a bad one, one
/// naming a file that was not sent with it, or one asking for more work
/// than the limits allow.
///
/// # Errors
/// [`SubmitError`] saying why the plotter cannot draw it.
async fn check_on(reg: &Arc<Registry>, config: &PlotterConfig, asked: Asked<'_>, uid: u32) -> Result<(), SubmitError> {
    let Asked { kind, content, files, pens, occult } = asked;
    let device = config.loaded_device().map_err(SubmitError::Device)?;
    let language = match kind {
        JobKind::Hpgl => Some("HP-GL"),
        JobKind::Gcode => Some("G-code"),
        JobKind::Scene | JobKind::Svg => None,
    };
    pen_map::check(pens, language, &device).map_err(|e| SubmitError::Refused(e.to_string()))?;
    let pen_table = crate::pen_table::settings(&config.pen);
    let job = crate::worker::JobInput {
        kind,
        content: content.as_bytes(),
        files: &files.files,
        device: &device,
        pens,
        pen_table: &pen_table,
        occult,
    };
    // In the bounded pool, each user's in turn: K submits at once never
    // start K workers with the whole render budget each.
    let checked = reg.checks.run(uid, reg.worker.check(job)).await.map_err(|e| SubmitError::Refused(e.to_string()))?;
    checked.map_err(|e| SubmitError::Refused(e.to_string()))
}

/// The attachments of a submit, decoded; only scenes name files.
fn decode_files(kind: JobKind, files: BTreeMap<String, String>) -> Result<Attached, SubmitError> {
    if files.is_empty() {
        return Ok(Attached::default());
    }
    if kind != JobKind::Scene {
        return Err(SubmitError::Refused("only a scene job carries files".into()));
    }
    let mut out = Attached::default();
    for (name, b64) in files {
        let bytes = BASE64.decode(b64.as_bytes()).map_err(|e| SubmitError::Refused(format!("files.`{name}`: not base64: {e}")))?;
        out.files.insert(name, bytes);
    }
    Ok(out)
}

/// Streams events until the client goes, or until job `id` ends.
async fn watch(reg: &Arc<Registry>, stream: &mut UnixStream, id: Option<JobId>, caller: Caller) {
    let mut rx = reg.events.subscribe();
    let mut people = reg.plotter_events.subscribe();
    let mut changes = reg.plotter_changes.subscribe();
    // Start with the current state, so a watcher that comes late knows where things are.
    let initial: Vec<JobRecord> = match id {
        Some(id) => reg.job(id).into_iter().collect(),
        None => reg.with(|l| l.shown_jobs().filter(|j| !j.state.is_final()).cloned().collect()),
    };
    if id.is_some() && initial.is_empty() {
        let _ = stream.write_all(&encode(&Reply::Error { message: format!("no job {}", id.unwrap_or(0)) })).await;
        return;
    }
    for job in &initial {
        let ev = caller.sees_event(event_of(reg, job), Some(job.uid));
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
            // What people do at the plotters, for a watcher of every job.
            Ok(did) = people.recv(), if id.is_none() => {
                if wr.write_all(&encode(&Reply::Plotter(did))).await.is_err() {
                    return;
                }
                continue;
            }
            // The plotters' own changes, for a watcher of every job.
            Ok(change) = changes.recv(), if id.is_none() => {
                if wr.write_all(&encode(&Reply::PlotterChanged(change))).await.is_err() {
                    return;
                }
                continue;
            }
            // The client's only move is to go away.
            r = rd.read(&mut sink) => match r { Ok(0) | Err(_) => return, Ok(_) => continue },
        };
        let ev = match ev {
            Ok(ev) => ev,
            Err(RecvError::Lagged(_)) => match id.and_then(|i| reg.job(i)) {
                Some(job) => event_of(reg, &job),
                None => continue,
            },
            Err(RecvError::Closed) => return,
        };
        if id.is_some_and(|i| i != ev.job) {
            continue;
        }
        let last = id.is_some() && ev.state.is_final();
        let owner = reg.job(ev.job).map(|j| j.uid);
        let ev = caller.sees_event(ev, owner);
        if wr.write_all(&encode(&Reply::Event(ev))).await.is_err() || last {
            return;
        }
    }
}

/// The event that tells `job`'s state now, and what it waits for.
fn event_of(reg: &Registry, job: &JobRecord) -> Event {
    Event::waiting_on(job, &reg.with(|l| l.reach(&job.plotter)), 0, None)
}
