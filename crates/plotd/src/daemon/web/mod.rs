//! The web page (`[web]` in the config): one page, embedded in the binary,
//! and the small HTTP API it uses. A request is turned into the same typed
//! [`Request`] the socket takes and answered by the same function
//! (`server::answer`); the live view is the same event broadcast `watch`
//! reads, numbered in a ring ([`feed`]) so a reconnecting browser misses
//! nothing. [`guard`] keeps other sites and other users out; [`limit`]
//! bounds the connections.
//!
//! - `GET /`: the page;
//! - `GET /api/status`, `GET /api/jobs`: the `status` and `jobs` replies;
//! - `POST /api/request`: any request as its JSON (`{"cmd": "pause", "id": 3}`),
//!   answered with the reply's JSON (status 400 for an error reply);
//! - `GET /api/events`: Server-Sent Events, one `job` event per job event
//!   and one `plotter` event per plotter change, as `watch` sends them;
//! - `GET /api/drawing?id=N`: the job's drawing for the preview ([`drawing`]).

mod drawing;
mod feed;
mod guard;
mod limit;
mod token;

use super::registry::Registry;
use crate::config::Config;
use crate::protocol::{decode_request, Reply, Request};
use axum::body::Body;
use axum::extract::{RawQuery, Request as HttpRequest, State};
use axum::http::{header, HeaderMap, HeaderValue, StatusCode};
use axum::middleware::Next;
use axum::response::sse::{Event as SseEvent, KeepAlive, Sse};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use axum::Router;
use feed::{Entry, Feed, Since};
use guard::Guard;
use std::collections::VecDeque;
use std::convert::Infallible;
use std::net::SocketAddr;
use std::sync::{Arc, Mutex};
use tokio::sync::watch;

/// The page, whole: markup, style and script in one file, no other asset.
const PAGE: &str = include_str!("page.html");

/// What every handler needs.
#[derive(Clone)]
struct App {
    reg: Arc<Registry>,
    feed: Arc<Feed>,
    guard: Arc<Guard>,
    /// `max_request_bytes`: a request body longer than this is refused, as on the socket.
    limit: usize,
    /// Jobs submitted from the page are the daemon user's.
    uid: u32,
    /// Set when the daemon stops: event streams end, so the server can.
    stopping: watch::Receiver<bool>,
    /// The last drawing made (the job's id and its JSON): every open page
    /// asks for the plotting job's.
    drawn: Arc<Mutex<Option<(u64, axum::body::Bytes)>>>,
}

/// The page's server, running.
#[derive(Debug)]
pub struct Web {
    /// Where it listens (the port the system gave, for `:0`).
    pub address: SocketAddr,
    stop: watch::Sender<bool>,
    task: tokio::task::JoinHandle<()>,
}

impl Web {
    /// Ends every event stream and stops serving.
    pub async fn stop(self) {
        let _ = self.stop.send(true);
        let _ = self.task.await;
    }
}

/// Starts serving the page as `daemon`'s `[web]` says, for the daemon `reg`.
///
/// # Errors
/// The token file's problem, or why the address cannot be listened on.
pub async fn start(daemon: &Config, reg: Arc<Registry>) -> Result<Web, String> {
    let Some(config) = &daemon.web else { return Err("no [web] table".into()) };
    let token = match &config.token_file {
        Some(path) => Some(token::load_or_create(path)?),
        None => None,
    };
    let listener = tokio::net::TcpListener::bind(config.listen).await.map_err(|e| format!("{}: {e}", config.listen))?;
    let address = listener.local_addr().map_err(|e| e.to_string())?;
    let run = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs());
    let feed = Feed::new(feed::RING_EVENTS, run);
    tokio::spawn(feed.clone().copy(reg.events.subscribe(), reg.plotter_changes.subscribe()));
    let (stop, stopping) = watch::channel(false);
    let guard = Guard { port: address.port(), names: guard::machine_names(), token };
    let app = App {
        reg,
        feed,
        guard: Arc::new(guard),
        limit: daemon.max_request_bytes,
        uid: nix::unistd::geteuid().as_raw(),
        stopping: stopping.clone(),
        drawn: Arc::default(),
    };
    let router = Router::new()
        .route("/", get(page))
        .route("/api/status", get(status))
        .route("/api/jobs", get(jobs))
        .route("/api/request", post(request))
        .route("/api/events", get(events))
        .route("/api/drawing", get(job_drawing))
        .layer(axum::middleware::from_fn_with_state(app.clone(), checks))
        .with_state(app);
    let mut until = stopping;
    let task = tokio::spawn(async move {
        let served = axum::serve(limit::Limited::new(listener), router).with_graceful_shutdown(async move {
            let _ = until.wait_for(|s| *s).await;
        });
        if let Err(e) = served.await {
            tracing::error!(error = %e, "web page stopped");
        }
    });
    tracing::info!(address = %address, token = config.token_file.is_some(), "web page on http://{address}/");
    Ok(Web { address, stop, task })
}

/// Host and Origin on every request; the token on the API's.
async fn checks(State(app): State<App>, req: HttpRequest, next: Next) -> Response {
    let checked = app.guard.same_origin(req.headers()).and_then(|()| {
        if req.uri().path().starts_with("/api/") {
            app.guard.authorised(req.headers(), req.uri().query())
        } else {
            Ok(())
        }
    });
    match checked {
        Ok(()) => next.run(req).await,
        Err(refusal) => {
            tracing::info!(status = %refusal.status, why = %refusal.message, path = %req.uri().path(), "web request refused");
            reply_with(refusal.status, &Reply::Error { message: refusal.message })
        }
    }
}

async fn page() -> Response {
    let mut r = PAGE.into_response();
    let h = r.headers_mut();
    h.insert(header::CONTENT_TYPE, HeaderValue::from_static("text/html; charset=utf-8"));
    // Nothing but this page's own script, and no other site may frame it
    // (a framed page's buttons could be clicked for the person).
    h.insert(
        header::CONTENT_SECURITY_POLICY,
        HeaderValue::from_static(
            "default-src 'self'; script-src 'unsafe-inline'; style-src 'unsafe-inline'; img-src 'self' data:; frame-ancestors 'none'",
        ),
    );
    h.insert(header::X_FRAME_OPTIONS, HeaderValue::from_static("DENY"));
    h.insert(header::CACHE_CONTROL, HeaderValue::from_static("no-store"));
    r
}

async fn status(State(app): State<App>) -> Response {
    answer(&app, Request::Status {}).await
}

async fn jobs(State(app): State<App>) -> Response {
    answer(&app, Request::Jobs {}).await
}

/// Any request, as the socket takes it.
async fn request(State(app): State<App>, headers: HeaderMap, body: Body) -> Response {
    let too_long = || {
        let message = format!("request longer than the limit of {} bytes (max_request_bytes in the daemon's config)", app.limit);
        reply_with(StatusCode::PAYLOAD_TOO_LARGE, &Reply::Error { message })
    };
    // Refused before it is read, when it says how long it is.
    let declared = headers.get(header::CONTENT_LENGTH).and_then(|v| v.to_str().ok()).and_then(|v| v.parse::<u64>().ok());
    if declared.is_some_and(|n| n > app.limit as u64) {
        return too_long();
    }
    let Ok(bytes) = axum::body::to_bytes(body, app.limit).await else { return too_long() };
    match decode_request(&bytes) {
        Ok(Request::Watch { .. }) => {
            reply_with(StatusCode::BAD_REQUEST, &Reply::Error { message: "watch from the page is GET /api/events".into() })
        }
        Ok(req) => answer(&app, req).await,
        Err(e) => reply_with(StatusCode::BAD_REQUEST, &Reply::Error { message: e.to_string() }),
    }
}

async fn answer(app: &App, req: Request) -> Response {
    match super::server::answer(&app.reg, req, app.uid, 0).await {
        // Errors quote input: cut short, controls escaped, as on the socket.
        Reply::Error { message } => reply_with(StatusCode::BAD_REQUEST, &Reply::Error { message: crate::text::message(&message) }),
        reply => reply_with(StatusCode::OK, &reply),
    }
}

fn reply_with(status: StatusCode, reply: &Reply) -> Response {
    let body = serde_json::to_vec(reply).expect("replies serialise");
    (
        status,
        [
            (header::CONTENT_TYPE, HeaderValue::from_static("application/json")),
            (header::CACHE_CONTROL, HeaderValue::from_static("no-store")),
        ],
        body,
    )
        .into_response()
}

/// `?id=N`: job N's drawing, from its program rendered and cut by the
/// daemon as for plotting (the job worker renders it again: the plotter's
/// own program is not shared yet).
async fn job_drawing(State(app): State<App>, RawQuery(query): RawQuery) -> Response {
    let error = |status, message: String| reply_with(status, &Reply::Error { message });
    let id = query.as_deref().unwrap_or_default().split('&').find_map(|kv| kv.strip_prefix("id=")).and_then(|v| v.parse::<u64>().ok());
    let Some(id) = id else { return error(StatusCode::BAD_REQUEST, "say which job: /api/drawing?id=N".into()) };
    let cached = app.drawn.lock().unwrap_or_else(std::sync::PoisonError::into_inner).clone();
    if let Some((_, json)) = cached.filter(|(j, _)| *j == id) {
        return json_response(json);
    }
    let Some(job) = app.reg.job(id) else { return error(StatusCode::NOT_FOUND, format!("no job {id}")) };
    let Some(plotter) = app.reg.config(&job.plotter) else {
        return error(StatusCode::NOT_FOUND, format!("job {id}'s plotter {:?} is not configured", job.plotter));
    };
    let device = match plotter.loaded_device() {
        Ok(d) => d,
        Err(e) => return error(StatusCode::INTERNAL_SERVER_ERROR, e),
    };
    let program = match super::rendering::program(&app.reg, id, job.kind, &device, std::future::pending()).await {
        Ok(p) => p,
        Err(super::rendering::NoProgram::Failed(why)) => return error(StatusCode::BAD_REQUEST, crate::text::message(&why)),
        Err(super::rendering::NoProgram::Stopped) => return error(StatusCode::SERVICE_UNAVAILABLE, "stopped".into()),
    };
    let json = axum::body::Bytes::from(serde_json::to_vec(&drawing::of(id, &program, &device)).expect("drawings serialise"));
    *app.drawn.lock().unwrap_or_else(std::sync::PoisonError::into_inner) = Some((id, json.clone()));
    json_response(json)
}

fn json_response(json: axum::body::Bytes) -> Response {
    ([(header::CONTENT_TYPE, HeaderValue::from_static("application/json"))], json).into_response()
}

/// The event stream: from the entry after `Last-Event-ID`, or from now.
async fn events(State(app): State<App>, headers: HeaderMap) -> Response {
    let last = headers.get("last-event-id").and_then(|v| v.to_str().ok());
    let mut reader = Reader {
        next: app.feed.next(),
        wake: app.feed.subscribe(),
        stopping: app.stopping.clone(),
        queue: VecDeque::new(),
        feed: app.feed,
    };
    match last.map(|id| parse_id(id, reader.feed.run)) {
        None => {}
        Some(Some(seq)) => reader.next = seq + 1,
        // Another run's id (the daemon restarted), or none of ours.
        Some(None) => reader.queue.push_back(resync(reader.feed.run, reader.next)),
    }
    let stream = futures_util::stream::unfold(reader, Reader::step);
    Sse::new(stream).keep_alive(KeepAlive::default()).into_response()
}

/// `RUN-SEQ`, this run's ids; `None` for any other.
fn parse_id(id: &str, run: u64) -> Option<u64> {
    let (r, seq) = id.trim().split_once('-')?;
    (r.parse() == Ok(run)).then(|| seq.parse().ok()).flatten()
}

/// One client's place in the feed.
struct Reader {
    feed: Arc<Feed>,
    /// The number of the next entry to send.
    next: u64,
    wake: watch::Receiver<u64>,
    stopping: watch::Receiver<bool>,
    queue: VecDeque<SseEvent>,
}

impl Reader {
    async fn step(mut self) -> Option<(Result<SseEvent, Infallible>, Reader)> {
        loop {
            if let Some(e) = self.queue.pop_front() {
                return Some((Ok(e), self));
            }
            if *self.stopping.borrow() {
                return None;
            }
            // Marked seen before the ring is read: an entry pushed after
            // the read wakes the wait below.
            self.wake.borrow_and_update();
            match self.feed.since(self.next) {
                Since::Missed { next } => {
                    self.queue.push_back(resync(self.feed.run, next));
                    self.next = next;
                }
                Since::Entries(entries) if !entries.is_empty() => {
                    for (seq, entry) in entries {
                        self.queue.push_back(match entry {
                            Entry::Job(ev) => SseEvent::default()
                                .id(format!("{}-{seq}", self.feed.run))
                                .event("job")
                                .data(serde_json::to_string(&ev).expect("events serialise")),
                            Entry::Plotter(change) => SseEvent::default()
                                .id(format!("{}-{seq}", self.feed.run))
                                .event("plotter")
                                .data(serde_json::to_string(&change).expect("events serialise")),
                            Entry::Gap => resync(self.feed.run, seq + 1),
                        });
                        self.next = seq + 1;
                    }
                }
                Since::Entries(_) => tokio::select! {
                    r = self.wake.changed() => if r.is_err() { return None },
                    r = self.stopping.changed() => if r.is_err() { return None },
                },
            }
        }
    }
}

/// Tells the page to reload the whole state: what happened before `next`
/// is not in the feed any more. Its id makes a reconnect go on from `next`.
fn resync(run: u64, next: u64) -> SseEvent {
    SseEvent::default().id(format!("{run}-{}", next.saturating_sub(1))).event("resync").data("{}")
}
