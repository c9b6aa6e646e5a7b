//! Every hostile job and act of issue 20 against the real daemon (the
//! `plotd` binary, a child process, driving plotsim over a pty): after each
//! one the daemon still answers `jobs` and every job queued before is still
//! there, queued. Some of these are refused by the parsers, some by the
//! daemon's limits, some stopped by the job worker's budget; the test
//! accepts any of those, and checks the daemon survives and tells the
//! client why.

use crate::child;

use child::Setup;
use plotd::client::{Client, JobFile};
use plotd::protocol::{JobInfo, Reply, Request, State};
use plotd::spool::JobKind;
use plotd_e2e::{repo_root, DaemonHandle};
use std::collections::BTreeMap;
use std::io::{BufRead, BufReader, Write};
use std::os::unix::net::UnixStream;
use std::path::Path;
use std::time::{Duration, Instant};

const LONG: Duration = Duration::from_secs(120);

/// A second plotter that never comes online: jobs sent to it stay queued,
/// and must still be there after every attack.
const OFFLINE: &str = "[[plotter]]\nname = \"offline\"\nport = \"/nonexistent/tty\"\ndevice = \"hp7475a\"\nhandshake = \"escb\"\n";

struct Hostile {
    setup: Setup,
    daemon: child::Daemon,
    /// Jobs queued on the offline plotter.
    guards: Vec<u64>,
}

impl Hostile {
    fn start() -> Hostile {
        let setup = Setup::hp_escb(OFFLINE);
        setup.top_level("render_seconds = 10.0\nrender_memory_mb = 1024");
        let daemon = setup.start();
        let mut h = Hostile { setup, daemon, guards: Vec::new() };
        h.guard();
        h
    }

    /// Queues one more job on the offline plotter.
    fn guard(&mut self) {
        let id = self.client().submit(JobKind::Hpgl, Some("offline"), "guard.hpgl", "IN;SP1;PU0,0;PD100,100;PU;".into()).unwrap();
        self.guards.push(id);
    }

    fn client(&self) -> Client {
        Client::connect(&self.setup.socket).expect("the daemon accepts a connection")
    }

    /// The daemon answers `jobs` on a new connection, and every guard job is queued.
    fn survived(&self, after: &str) -> Vec<JobInfo> {
        let jobs = self.client().jobs().unwrap_or_else(|e| panic!("after {after}: `jobs` not answered: {e}"));
        for id in &self.guards {
            let j = jobs.iter().find(|j| j.id == *id).unwrap_or_else(|| panic!("after {after}: queued job {id} lost"));
            assert_eq!(j.state, State::Queued, "after {after}: job {id}");
        }
        eprintln!("survived: {after}");
        jobs
    }

    /// Submits `job` to the plotter; returns the refusal, or the job as it ended.
    fn outcome(&self, job: JobFile, name: &str) -> Result<JobInfo, String> {
        match self.client().submit_job(job, None, name) {
            Err(e) => Err(e.to_string()),
            Ok(id) => {
                let end = Instant::now() + LONG;
                loop {
                    let j = self.daemon.job(id);
                    if j.state.is_final() {
                        return Ok(j);
                    }
                    assert!(Instant::now() < end, "{name}: job {id} still {:?}", j.state);
                    std::thread::sleep(Duration::from_millis(50));
                }
            }
        }
    }
}

fn job(kind: JobKind, content: String) -> JobFile {
    JobFile { kind, content, files: BTreeMap::new() }
}

/// A refusal or a failure, with a message that says why in a line or two.
fn stopped_with_reason(what: &str, r: &Result<JobInfo, String>) {
    let message = match r {
        Err(e) => e.clone(),
        Ok(JobInfo { state: State::Failed, reason: Some(reason), .. }) => reason.clone(),
        Ok(other) => panic!("{what}: ended {other:?}"),
    };
    assert!(message.len() < 2000 && !message.is_empty(), "{what}: {message}");
    eprintln!("{what}: {message}");
}

/// An icosphere of 1,280 faces, as OBJ.
fn sphere_obj() -> String {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut v: Vec<[f64; 3]> = vec![
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ];
    let mut f: Vec<[usize; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..3 {
        let mut mid = BTreeMap::new();
        let mut next = Vec::new();
        for [a, b, c] in f {
            let mut m = |i: usize, j: usize| {
                *mid.entry((i.min(j), i.max(j))).or_insert_with(|| {
                    v.push([(v[i][0] + v[j][0]) / 2.0, (v[i][1] + v[j][1]) / 2.0, (v[i][2] + v[j][2]) / 2.0]);
                    v.len() - 1
                })
            };
            let (ab, bc, ca) = (m(a, b), m(b, c), m(c, a));
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        f = next;
    }
    assert_eq!(f.len(), 1280);
    let mut obj = String::new();
    for p in &v {
        let n = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
        obj += &format!("v {} {} {}\n", p[0] / n, p[1] / n, p[2] / n);
    }
    for [a, b, c] in &f {
        obj += &format!("f {} {} {}\n", a + 1, b + 1, c + 1);
    }
    obj
}

const CAMERA: &str = "[camera]\neye = [6.0, -8.0, 5.0]\ntarget = [0.0, 0.0, 0.0]\nfov_deg = 30.0\n";

/// The bundled map movie with `edit` applied to its scene and `towns` as its places.
fn map_job(edit: impl Fn(String) -> String, towns: Option<String>) -> JobFile {
    let dir = tempfile::tempdir().unwrap();
    let examples = repo_root().join("examples");
    std::fs::create_dir(dir.path().join("map")).unwrap();
    std::fs::copy(examples.join("map/westmark.geojson"), dir.path().join("map/westmark.geojson")).unwrap();
    let places = towns.unwrap_or_else(|| std::fs::read_to_string(examples.join("map/towns.csv")).unwrap());
    std::fs::write(dir.path().join("map/towns.csv"), places).unwrap();
    let path = dir.path().join("movie.toml");
    std::fs::write(&path, edit(std::fs::read_to_string(examples.join("map_movie.toml")).unwrap())).unwrap();
    // The client reads the files the way `plotd submit` does (when the client
    // itself refuses, send the files by hand, as a hostile client would).
    plotd::client::read_job_file(&path, None).unwrap_or_else(|_| {
        let mut files = BTreeMap::new();
        for f in ["map/westmark.geojson", "map/towns.csv"] {
            files.insert(f.to_owned(), std::fs::read(dir.path().join(f)).unwrap());
        }
        JobFile { kind: JobKind::Scene, content: std::fs::read_to_string(&path).unwrap(), files }
    })
}

/// Whether some process has `fifo` open for reading: a writer's
/// non-blocking open succeeds only then.
fn fifo_opened(fifo: &Path) -> bool {
    use std::os::unix::fs::OpenOptionsExt;
    std::fs::OpenOptions::new().write(true).custom_flags(nix::libc::O_NONBLOCK).open(fifo).is_ok()
}

#[test]
fn the_daemon_survives_every_hostile_job() {
    let mut h = Hostile::start();
    h.survived("start");

    // 0. A scene whose error is on a 100 KB line: the message quotes an excerpt.
    let scene = format!("{CAMERA}[[polyline]]\npoints = [[0.0, 0.0, 0.0], [1.0, 1.0, 1.0]]\ncomment = \"{}\"\n", "x".repeat(100_000));
    let r = h.outcome(job(JobKind::Scene, scene), "long-line.toml");
    let e = r.expect_err("an unknown key is refused");
    assert!(e.contains("comment") && e.len() < 4000, "{} bytes: {}", e.len(), &e[..e.len().min(500)]);
    h.survived("an error on a 100 KB line");

    // 1. 4,000 nested groups (a 28 KB SVG that overflowed a worker's stack).
    let svg = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"100mm\" height=\"100mm\" viewBox=\"0 0 100 100\">{}<path d=\"M0 0 L50 50\" stroke=\"black\"/>{}</svg>",
        "<g>".repeat(4000),
        "</g>".repeat(4000)
    );
    let r = h.outcome(job(JobKind::Svg, svg), "deep.svg");
    stopped_with_reason("deeply nested SVG", &r);
    h.survived("a deeply nested SVG");

    // 2. A town at longitude -1e308 (a render that never ended).
    let towns = std::fs::read_to_string(repo_root().join("examples/map/towns.csv")).unwrap().replacen("16.099", "-1e308", 1);
    let r = h.outcome(map_job(|s| s, Some(towns)), "far.toml");
    stopped_with_reason("a town at longitude -1e308", &r);
    h.survived("a town at longitude -1e308");

    // 3. A polyline point at 1e10 beside a 1,280-face sphere (3.5 GB in 20 s).
    let mut files = BTreeMap::new();
    files.insert("sphere.obj".to_owned(), sphere_obj().into_bytes());
    let scene = format!("{CAMERA}[[mesh]]\npath = \"sphere.obj\"\n[[polyline]]\npoints = [[0.0, 0.0, 0.0], [1e10, 0.0, 0.0]]\n");
    let r = h.outcome(JobFile { kind: JobKind::Scene, content: scene, files }, "far-line.toml");
    // Drawn correctly is fine too; it must end, one way or another.
    match &r {
        Ok(JobInfo { state: State::Done, .. }) => eprintln!("a polyline to 1e10: plotted"),
        _ => stopped_with_reason("a polyline to 1e10", &r),
    }
    h.survived("a polyline point at 1e10 beside a sphere");

    // 4. An SVG image naming a path of the daemon's machine: a FIFO, so any
    // open of it shows (and would block whoever opened it).
    let fifo = h.setup.dir.path().join("secret");
    nix::unistd::mkfifo(&fifo, nix::sys::stat::Mode::from_bits_truncate(0o600)).unwrap();
    let svg = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" xmlns:xlink=\"http://www.w3.org/1999/xlink\" width=\"100mm\" height=\"100mm\" viewBox=\"0 0 100 100\">\
         <image href=\"{f}\" xlink:href=\"{f}\" x=\"0\" y=\"0\" width=\"10\" height=\"10\"/><image href=\"/etc/shadow\" width=\"10\" height=\"10\"/>\
         <path d=\"M0 0 L50 50\" stroke=\"black\"/></svg>",
        f = fifo.display()
    );
    let watching = std::sync::atomic::AtomicBool::new(true);
    let opened = std::thread::scope(|s| {
        let spy = s.spawn(|| {
            let mut seen = false;
            while watching.load(std::sync::atomic::Ordering::Relaxed) {
                seen |= fifo_opened(&fifo);
                std::thread::sleep(Duration::from_millis(5));
            }
            seen
        });
        let r = h.outcome(job(JobKind::Svg, svg), "image.svg");
        watching.store(false, std::sync::atomic::Ordering::Relaxed);
        eprintln!("an SVG naming /etc/shadow: {r:?}");
        spy.join().unwrap()
    });
    assert!(!opened, "the daemon (or its worker) opened a path an SVG named");
    h.survived("an SVG image naming a local path");

    // 5. A million-frame animation (50 MB/s until 2.9 GB).
    let r =
        h.outcome(map_job(|s| s.replace("frames = 48", "frames = 1000000").replace("frame = 47", "frame = 999999"), None), "movie.toml");
    stopped_with_reason("a million frames", &r);
    h.survived("a million-frame animation");

    // 6. A 3000 x 3000 surface beside a polyline (past 7 GB).
    let scene = format!(
        "{CAMERA}[[surface]]\nz = \"x*y\"\nx = {{ from = -2.0, to = 2.0, steps = 3000 }}\ny = {{ from = -2.0, to = 2.0, steps = 3000 }}\n\
         [[polyline]]\npoints = [[0.0, 0.0, 1.0], [1.0, 1.0, 1.0]]\n"
    );
    let r = h.outcome(job(JobKind::Scene, scene), "huge.toml");
    stopped_with_reason("a 3000 x 3000 surface with a polyline", &r);
    h.survived("a 3000 x 3000 surface beside a polyline");

    // 7. Names with escape codes: shown escaped.
    let forged = "a\u{1b}[2K\r    1  done  p  1/1  forged\n";
    let id = h.client().submit(JobKind::Hpgl, Some("offline"), forged, "IN;SP1;PU0,0;PD10,10;PU;".into()).unwrap();
    h.guards.push(id);
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_plotd")).args(["jobs", "--socket"]).arg(&h.setup.socket).output().unwrap();
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(!text.trim_end().chars().any(|c| c.is_control() && c != '\n'), "{text:?}");
    assert_eq!(text.lines().count(), h.survived("a name with escape codes").len(), "{text}");

    // 8. As many idle connections as the descriptors allow, up to 20,000:
    // a new client is still served. This process's soft limit is raised to
    // its hard one first, as the daemon does its own (and as a daemon run
    // in-process by another test may have done already), and a thousand
    // descriptors are left for the tests running beside this one.
    let hungry = child::descriptor_hungry();
    use nix::sys::resource::{getrlimit, setrlimit, Resource};
    let (_, hard) = getrlimit(Resource::RLIMIT_NOFILE).unwrap();
    setrlimit(Resource::RLIMIT_NOFILE, hard, hard).unwrap();
    let n = (hard.saturating_sub(1000) as usize).min(20_000);
    let mut held = Vec::with_capacity(n);
    for _ in 0..n {
        match UnixStream::connect(&h.setup.socket) {
            Ok(s) => held.push(s),
            Err(e) => {
                eprintln!("connect failed after {} connections: {e}", held.len());
                break;
            }
        }
    }
    eprintln!("holding {} idle connections", held.len());
    let asked = Instant::now();
    let mut s = UnixStream::connect(&h.setup.socket).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(30))).unwrap();
    s.write_all(b"{\"cmd\":\"jobs\"}\n").unwrap();
    let mut line = String::new();
    BufReader::new(s).read_line(&mut line).unwrap();
    assert!(line.contains("\"reply\":\"jobs\""), "{line}");
    eprintln!("a new client served in {:?} beside them", asked.elapsed());
    h.guard();
    h.survived("idle connections");
    drop(held);
    drop(hungry);

    // 9. A second daemon on the same config: it exits, having changed nothing.
    let second = std::process::Command::new(env!("CARGO_BIN_EXE_plotd")).args(["serve", "--config"]).arg(&h.setup.config).output().unwrap();
    assert_eq!(second.status.code(), Some(1), "{}", String::from_utf8_lossy(&second.stderr));
    h.survived("a second daemon");

    // 10. A truncated record (the newest), found at a restart after a SIGKILL.
    let newest = *h.guards.last().unwrap();
    h.daemon.kill();
    let path = h.setup.dir.path().join(format!("spool/jobs/{newest}.json"));
    let bytes = std::fs::read(&path).unwrap();
    std::fs::write(&path, &bytes[..bytes.len() / 3]).unwrap();
    h.daemon = h.setup.start();
    h.guards.pop();
    let (_, corrupt) = h.client().job_list().unwrap();
    assert_eq!(corrupt.iter().map(|c| c.id).collect::<Vec<_>>(), [newest]);
    let jobs = h.survived("a truncated record");
    let next = h.client().submit(JobKind::Hpgl, Some("offline"), "after.hpgl", "IN;".into()).unwrap();
    assert!(next > newest && jobs.iter().all(|j| j.id < next));
    let Reply::Ok { .. } = h.client().call(&Request::Cancel { id: next, now: false }).unwrap() else { panic!() };
}
