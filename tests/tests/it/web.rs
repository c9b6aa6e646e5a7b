//! The web page over plain HTTP, as curl would use it: the page, the API
//! answered as the socket is, the event stream (its order and its
//! `Last-Event-ID` replay), and the guards (403 for another site's page or
//! a name rebound to us, 401 without the token, 413 past the size limit).
//! The daemon drives plotsim over a real pty ([`Rig`]).

use plotd::protocol::State;
use plotd_e2e::{hpgl_lines, DaemonHandle, Rig};
use plotsim::SimConfig;
use serde_json::{json, Value};
use std::io::{BufRead, BufReader, Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::sync::mpsc;
use std::time::Duration;

const LONG: Duration = Duration::from_secs(60);
const WEB: &str = "\n[web]\nlisten = \"127.0.0.1:0\"\n";

/// A response: status, head (lower-cased), body.
#[derive(Debug)]
pub struct Http {
    pub status: u16,
    pub head: String,
    pub body: String,
}

impl Http {
    /// The body as JSON.
    pub fn json(&self) -> Value {
        serde_json::from_str(&self.body).unwrap_or_else(|e| panic!("{e}: {}", self.body))
    }
}

/// Sends one HTTP/1.0 request (the server closes the connection after the
/// reply) with `Host` set to `addr` unless `headers` give one.
pub fn http(addr: SocketAddr, method: &str, path: &str, headers: &[(&str, &str)], body: &str) -> Http {
    let mut s = TcpStream::connect(addr).expect("connects");
    let mut req = format!("{method} {path} HTTP/1.0\r\n");
    if !headers.iter().any(|(k, _)| k.eq_ignore_ascii_case("host")) {
        req.push_str(&format!("Host: {addr}\r\n"));
    }
    for (k, v) in headers {
        req.push_str(&format!("{k}: {v}\r\n"));
    }
    if !headers.iter().any(|(k, _)| k.eq_ignore_ascii_case("content-length")) {
        req.push_str(&format!("Content-Length: {}\r\n", body.len()));
    }
    req.push_str("\r\n");
    req.push_str(body);
    s.write_all(req.as_bytes()).unwrap();
    let mut text = String::new();
    s.read_to_string(&mut text).unwrap();
    let (head, body) = text.split_once("\r\n\r\n").unwrap_or_else(|| panic!("no head in {text:?}"));
    let status = head.split(' ').nth(1).and_then(|s| s.parse().ok()).unwrap_or_else(|| panic!("no status in {head:?}"));
    Http { status, head: head.to_ascii_lowercase(), body: body.to_owned() }
}

/// One Server-Sent Event.
#[derive(Clone, Debug, PartialEq)]
pub struct Sse {
    pub id: String,
    pub event: String,
    pub data: String,
}

/// An open event stream, read on a thread.
pub struct Events {
    rx: mpsc::Receiver<Sse>,
}

impl Events {
    /// Opens `/api/events` with `headers`; returns once the daemon answered
    /// (it reads the feed from then on, so nothing later is missed).
    pub fn open(addr: SocketAddr, path: &str, headers: &[(&str, &str)]) -> Events {
        let mut s = TcpStream::connect(addr).expect("connects");
        let mut req = format!("GET {path} HTTP/1.0\r\nHost: {addr}\r\n");
        for (k, v) in headers {
            req.push_str(&format!("{k}: {v}\r\n"));
        }
        req.push_str("\r\n");
        s.write_all(req.as_bytes()).unwrap();
        let mut r = BufReader::new(s);
        let mut line = String::new();
        r.read_line(&mut line).unwrap();
        assert!(line.starts_with("HTTP/1.0 200") || line.starts_with("HTTP/1.1 200"), "{line}");
        loop {
            line.clear();
            r.read_line(&mut line).unwrap();
            if line.trim().is_empty() {
                break;
            }
            if let Some(v) = line.to_ascii_lowercase().strip_prefix("content-type:") {
                assert_eq!(v.trim(), "text/event-stream");
            }
        }
        let (tx, rx) = mpsc::channel();
        std::thread::spawn(move || {
            let mut ev = Sse { id: String::new(), event: String::new(), data: String::new() };
            for line in r.lines() {
                let Ok(line) = line else { return };
                if line.is_empty() {
                    if !ev.event.is_empty()
                        && tx
                            .send(std::mem::replace(&mut ev, Sse { id: String::new(), event: String::new(), data: String::new() }))
                            .is_err()
                    {
                        return;
                    }
                    continue;
                }
                match line.split_once(':') {
                    Some(("id", v)) => ev.id = v.trim_start().to_owned(),
                    Some(("event", v)) => ev.event = v.trim_start().to_owned(),
                    Some(("data", v)) => ev.data.push_str(v.trim_start()),
                    _ => {} // comments (keep-alives), retry
                }
            }
        });
        Events { rx }
    }

    /// The next event.
    pub fn next(&self, timeout: Duration) -> Sse {
        self.rx.recv_timeout(timeout).unwrap_or_else(|e| panic!("no event in {timeout:?}: {e}"))
    }
}

fn rig(extra: &str) -> Rig {
    Rig::start(SimConfig::hp7475a().with_speed_scale(0.0), "hp7475a", "xonxoff", extra)
}

fn submit(addr: SocketAddr, content: &str) -> u64 {
    let r = http(
        addr,
        "POST",
        "/api/request",
        &[],
        &json!({"cmd": "submit", "kind": "hpgl", "name": "web.hpgl", "content": content}).to_string(),
    );
    assert_eq!(r.status, 200, "{}", r.body);
    r.json()["id"].as_u64().expect("an id")
}

/// The events of the stream (jobs' and plotters') up to job `id`'s end.
fn until_done(events: &Events, id: u64) -> Vec<Sse> {
    let mut got = Vec::new();
    loop {
        let ev = events.next(LONG);
        let data: Value = serde_json::from_str(&ev.data).unwrap();
        assert!(ev.event == "job" || ev.event == "plotter", "{ev:?}");
        let end = ev.event == "job" && data["job"] == id && ["done", "failed", "cancelled"].contains(&data["state"].as_str().unwrap());
        got.push(ev);
        if end {
            return got;
        }
    }
}

/// The job events among `events`.
fn jobs_only(events: &[Sse]) -> Vec<Sse> {
    events.iter().filter(|e| e.event == "job").cloned().collect()
}

fn states(events: &[Sse]) -> Vec<String> {
    let mut s: Vec<String> =
        jobs_only(events).iter().map(|e| serde_json::from_str::<Value>(&e.data).unwrap()["state"].as_str().unwrap().to_owned()).collect();
    s.dedup();
    s
}

#[test]
fn the_page_and_the_api_answer_as_the_socket_does() {
    let rig = rig(WEB);
    let addr = rig.web_address();
    assert!(addr.ip().is_loopback());
    let page = http(addr, "GET", "/", &[], "");
    assert_eq!(page.status, 200);
    assert!(page.head.contains("content-type: text/html"), "{}", page.head);
    assert!(page.head.contains("frame-ancestors 'none'"), "{}", page.head);
    assert!(page.body.contains("<title>plotd</title>") && page.body.contains("/api/events"));

    let status = http(addr, "GET", "/api/status", &[], "");
    assert_eq!(status.status, 200, "{}", status.body);
    let status = status.json();
    assert_eq!(status["reply"], "status");
    assert_eq!(status["plotters"][0]["name"], "p");

    // A request as its JSON, pretty-printed as a person writes it.
    let id = submit(addr, &hpgl_lines(5, 1));
    let done = rig.wait_state(id, State::Done, LONG);
    assert_eq!(done.name, "web.hpgl");
    let me = std::os::unix::fs::MetadataExt::uid(&std::fs::metadata(rig.dir.path()).unwrap());
    assert_eq!(done.uid, me, "a job from the page is the daemon user's");
    let jobs = http(addr, "POST", "/api/request", &[("Content-Type", "application/json")], "{\n  \"cmd\": \"jobs\"\n}\n");
    assert_eq!(jobs.status, 200, "{}", jobs.body);
    assert_eq!(jobs.json()["jobs"][0]["state"], "done");
    assert_eq!(http(addr, "GET", "/api/jobs", &[], "").json()["jobs"][0]["id"], id);
    // The preview: the program as the daemon cut it, a line per stroke, in mm.
    let d = http(addr, "GET", &format!("/api/drawing?id={id}"), &[], "");
    assert_eq!(d.status, 200, "{}", d.body);
    let d = d.json();
    let chunks = d["chunks"].as_array().unwrap();
    assert_eq!(chunks.len(), done.total.unwrap());
    let lines: Vec<&Value> = chunks.iter().flat_map(|c| c["lines"].as_array().unwrap()).collect();
    assert_eq!(lines.len(), 5, "{lines:?}");
    assert_eq!(http(addr, "GET", "/api/drawing?id=99", &[], "").status, 404);

    // The socket's refusals, with status 400.
    let r = http(addr, "POST", "/api/request", &[], r#"{"cmd":"pause","id":99}"#);
    assert_eq!((r.status, r.json()["reply"].as_str()), (400, Some("error")));
    assert!(r.json()["message"].as_str().unwrap().contains("99"), "{}", r.body);
    let r = http(addr, "POST", "/api/request", &[], r#"{"cmd":"fly"}"#);
    assert_eq!(r.status, 400);
    assert!(r.json()["message"].as_str().unwrap().starts_with("malformed request: unknown variant `fly`"), "{}", r.body);
    let r = http(addr, "POST", "/api/request", &[], r#"{"cmd":"watch"}"#);
    assert!(r.status == 400 && r.body.contains("/api/events"), "{}", r.body);
    // Past max_request_bytes (16 MiB by default): refused before it is read.
    let r = http(addr, "POST", "/api/request", &[("Content-Length", "16777217")], "");
    assert_eq!(r.status, 413);
    assert!(r.body.contains("max_request_bytes"), "{}", r.body);
    assert_eq!(http(addr, "GET", "/nothing", &[], "").status, 404);
}

#[test]
fn another_sites_page_and_a_rebound_name_get_403() {
    let rig = rig(WEB);
    let addr = rig.web_address();
    let ours = format!("http://{addr}");
    let jobs = r#"{"cmd":"jobs"}"#;
    assert_eq!(http(addr, "POST", "/api/request", &[("Origin", &ours), ("Sec-Fetch-Site", "same-origin")], jobs).status, 200);
    // CSRF: a form or fetch from another page in the same browser.
    for (k, v) in [("Origin", "http://evil.example"), ("Origin", "null"), ("Sec-Fetch-Site", "cross-site")] {
        let r = http(addr, "POST", "/api/request", &[(k, v)], r#"{"cmd":"cancel","id":1}"#);
        assert_eq!(r.status, 403, "{k}: {v}: {}", r.body);
    }
    let r = http(addr, "GET", "/api/events", &[("Origin", "http://evil.example")], "");
    assert_eq!(r.status, 403);
    // DNS rebinding: another site's name pointed at 127.0.0.1.
    let rebound = format!("evil.example:{}", addr.port());
    let r = http(addr, "GET", "/api/status", &[("Host", &rebound)], "");
    assert_eq!(r.status, 403);
    assert!(r.body.contains("evil.example"), "{}", r.body);
    assert_eq!(http(addr, "GET", "/", &[("Host", &rebound)], "").status, 403);
    let local = format!("localhost:{}", addr.port());
    assert_eq!(http(addr, "GET", "/api/status", &[("Host", &local)], "").status, 200);
}

#[test]
fn without_the_token_401() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("web.token");
    let rig = rig(&format!("{WEB}token_file = \"{}\"\n", file.display()));
    let addr = rig.web_address();
    let token = std::fs::read_to_string(&file).unwrap().trim().to_owned();
    assert_eq!(token.len(), 64);
    // The page itself holds no data: it loads, and asks for the token.
    assert_eq!(http(addr, "GET", "/", &[], "").status, 200);
    for (path, method, body) in [("/api/status", "GET", ""), ("/api/events", "GET", ""), ("/api/request", "POST", r#"{"cmd":"jobs"}"#)] {
        let r = http(addr, method, path, &[], body);
        assert_eq!(r.status, 401, "{path}: {}", r.body);
        let r = http(addr, method, path, &[("Authorization", "Bearer nope")], body);
        assert_eq!(r.status, 401, "{path}");
    }
    let bearer = format!("Bearer {token}");
    assert_eq!(http(addr, "GET", "/api/status", &[("Authorization", &bearer)], "").status, 200);
    assert_eq!(http(addr, "POST", "/api/request", &[("Authorization", &bearer)], r#"{"cmd":"jobs"}"#).status, 200);
    // A browser's EventSource sends no headers of its own: the token rides in the query.
    let events = Events::open(addr, &format!("/api/events?token={token}"), &[]);
    let id = rig.submit(plotd::spool::JobKind::Hpgl, &hpgl_lines(2, 3));
    assert_eq!(states(&until_done(&events, id)).last().unwrap(), "done");
}

#[test]
fn the_event_stream_gives_a_job_s_states_in_order_and_resumes_where_it_broke() {
    let rig = rig(WEB);
    let addr = rig.web_address();
    let events = Events::open(addr, "/api/events", &[]);
    let id = submit(addr, &hpgl_lines(30, 2));
    let got = until_done(&events, id);
    assert_eq!(states(&got), ["queued", "rendering", "plotting", "done"]);
    // Numbered one by one, in this daemon run's ids.
    let seqs: Vec<u64> = got.iter().map(|e| e.id.rsplit_once('-').unwrap().1.parse().unwrap()).collect();
    assert!(seqs.windows(2).all(|w| w[1] == w[0] + 1), "{seqs:?}");
    let progress: Vec<u64> =
        jobs_only(&got).iter().map(|e| serde_json::from_str::<Value>(&e.data).unwrap()["strokes_done"].as_u64().unwrap()).collect();
    assert!(progress.windows(2).all(|w| w[0] <= w[1]), "{progress:?}");
    assert_eq!(*progress.last().unwrap(), 30);

    // A browser that lost the stream after the second event reconnects with
    // its id and is sent every event after it, the same ones.
    let resumed = Events::open(addr, "/api/events", &[("Last-Event-ID", &got[1].id)]);
    let again: Vec<Sse> = (2..got.len()).map(|_| resumed.next(LONG)).collect();
    assert_eq!(again, got[2..]);

    // An id from another daemon run (before a restart): reload first.
    let other = Events::open(addr, "/api/events", &[("Last-Event-ID", "1-3")]);
    assert_eq!(other.next(LONG).event, "resync");
    // The sheet was drawn on: the page says a fresh one is in, as a person would.
    let r = http(addr, "POST", "/api/request", &[], &json!({"cmd": "sheet-loaded", "plotter": "p"}).to_string());
    assert_eq!(r.status, 200, "{}", r.body);
    let id2 = submit(addr, &hpgl_lines(1, 4));
    assert_eq!(states(&until_done(&other, id2)), ["queued", "rendering", "plotting", "done"]);
}

/// A process that opens connection after connection cannot take the page
/// from everyone: past the limit (64 at once) one more is answered 503 and
/// closed at once, and a place freed is served again.
/// What changes at a plotter with no job's event is on the stream as a
/// `plotter` event with the plotter's state whole, numbered with the jobs'
/// events, and on the socket's `watch` of every job as `plotter-changed`:
/// an offset set, the cable pulled (offline, with its cause) and put back.
#[test]
fn the_event_stream_and_watch_carry_a_plotters_changes() {
    let rig = rig(WEB);
    let addr = rig.web_address();
    rig.wait_online(LONG);
    let events = Events::open(addr, "/api/events", &[]);
    let mut watcher = rig.client();
    watcher.watch(None).unwrap();
    let next_plotter = || loop {
        let ev = events.next(LONG);
        if ev.event == "plotter" {
            return serde_json::from_str::<Value>(&ev.data).unwrap();
        }
    };

    let r = http(addr, "POST", "/api/request", &[], &json!({"cmd": "offset", "plotter": "p", "dx_mm": 10.0, "dy_mm": 5.0}).to_string());
    assert_eq!(r.status, 200, "{}", r.body);
    assert_eq!(next_plotter(), json!({"plotter": "p", "link": "online", "sheet": "fresh", "offset_mm": [10.0, 5.0], "v": 1}));
    let change = loop {
        if let Some(plotd::client::Watched::PlotterChanged(c)) = watcher.next_watched().unwrap() {
            break c;
        }
    };
    assert_eq!((change.plotter.as_str(), change.offset_mm), ("p", [10.0, 5.0]));

    rig.sim.unplug(Duration::from_secs(5)).unwrap();
    let gone = next_plotter();
    assert_eq!(gone["link"], "offline", "{gone}");
    assert!(["port-closed", "no-such-port", "silent"].contains(&gone["cause"]["kind"].as_str().unwrap()), "{gone}");
    // Told again only when its cause changes, then when it is back.
    let mut last = gone;
    let back = loop {
        let ev = next_plotter();
        if ev["link"] == "online" {
            break ev;
        }
        assert_ne!(ev["cause"], last["cause"], "the same cause told twice running");
        last = ev;
    };
    assert_eq!(back, json!({"plotter": "p", "link": "online", "sheet": "fresh", "offset_mm": [10.0, 5.0], "v": 1}));
}

#[test]
fn connections_past_the_limit_are_answered_503_and_a_freed_place_serves() {
    let rig = rig(WEB);
    let addr = rig.web_address();
    // Each held connection served once (so it is surely admitted), then
    // kept open, idle, as HTTP/1.1 keeps it.
    let mut held: Vec<TcpStream> = (0..64)
        .map(|_| {
            let mut s = TcpStream::connect(addr).unwrap();
            write!(s, "GET /api/status HTTP/1.1\r\nHost: {addr}\r\n\r\n").unwrap();
            let mut r = BufReader::new(s.try_clone().unwrap());
            let mut line = String::new();
            r.read_line(&mut line).unwrap();
            assert!(line.starts_with("HTTP/1.1 200"), "{line}");
            s
        })
        .collect();
    let busy = http(addr, "GET", "/api/status", &[], "");
    assert_eq!(busy.status, 503, "{busy:?}");
    assert!(busy.body.contains("too many connections"), "{}", busy.body);
    // Freed: the server sees the close and gives the place back.
    drop(held.pop());
    let mut served = None;
    for _ in 0..200 {
        let r = http(addr, "GET", "/api/status", &[], "");
        if r.status == 200 {
            served = Some(r);
            break;
        }
        // Not yet given back: the next try waits on the server's answer.
    }
    assert!(served.is_some(), "a freed place was never served");
}
