//! The client side of the socket protocol, and the `submit`, `jobs`,
//! `status`, `cancel`, `pause`, `resume`, `pen-changed`, `watch` commands.
//!
//! The client finds the daemon by `--socket PATH`, else `$PLOTD_SOCKET`, else
//! the user's daemon's socket, else the system daemon's ([`socket_path`]). It reads files itself and sends their
//! bytes, a scene's named files included: the daemon never opens paths named
//! by a client.

use crate::protocol::{encode, Event, JobInfo, PlotterChange, PlotterEvent, Reply, Request, State};
use crate::spool::{CorruptRecord, JobId, JobKind};
use base64::engine::general_purpose::STANDARD as BASE64;
use base64::Engine as _;
use std::collections::BTreeMap;
use std::io::IsTerminal;
use std::io::{BufRead, BufReader, Write};
use std::os::unix::net::UnixStream;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};
use thiserror::Error;

/// Exit code of `submit --follow` when the job was cancelled.
pub const EXIT_CANCELLED: u8 = 3;
/// Exit code of `submit --follow` when the job failed.
pub const EXIT_FAILED: u8 = 4;

/// A client-side failure.
#[derive(Debug, Error)]
pub enum ClientError {
    /// The daemon's socket could not be reached.
    #[error("cannot reach plotd at {path}: {reason}{}", connect_hint(reason))]
    Connect {
        /// The socket path tried.
        path: PathBuf,
        /// What the OS said (in the message, not a source: said once).
        reason: std::io::Error,
    },
    /// The socket's directory may be another user's: nothing was sent.
    #[error("will not connect to plotd at a socket in {0}")]
    Untrusted(#[from] crate::trusted_path::UntrustedPath),
    /// The connection broke.
    #[error("connection to plotd: {0}")]
    Io(#[from] std::io::Error),
    /// The daemon's answer is not protocol.
    #[error("bad reply from plotd: {0}")]
    Protocol(String),
    /// The daemon refused the request.
    #[error("{0}")]
    Refused(String),
    /// A file to submit could not be read or is not text.
    #[error("{path}: {message}")]
    File {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
}

/// What to try when the socket cannot be reached.
fn connect_hint(e: &std::io::Error) -> &'static str {
    match e.kind() {
        std::io::ErrorKind::PermissionDenied => " (the socket admits its owner and group: under systemd, users in group plotd)",
        std::io::ErrorKind::NotFound | std::io::ErrorKind::ConnectionRefused => {
            " (is `plotd serve` running? --socket or $PLOTD_SOCKET set the path)"
        }
        _ => "",
    }
}

/// The socket path from `--socket`, else `$PLOTD_SOCKET`, else the
/// default: the user's own daemon's (`$XDG_RUNTIME_DIR/plotd.sock`) when it
/// exists, else the system daemon's ([`crate::config::SYSTEM_SOCKET`]) when
/// that exists, else the user's (named in the connection error).
#[must_use]
pub fn socket_path(flag: Option<&Path>) -> PathBuf {
    let own = crate::config::default_socket_path();
    let system = Path::new(crate::config::SYSTEM_SOCKET);
    choose_socket(flag, std::env::var_os("PLOTD_SOCKET"), &own, system, |p| p.exists())
}

fn choose_socket(
    flag: Option<&Path>,
    env: Option<std::ffi::OsString>,
    own: &Path,
    system: &Path,
    exists: impl Fn(&Path) -> bool,
) -> PathBuf {
    if let Some(p) = flag {
        return p.to_owned();
    }
    match env {
        Some(p) if !p.is_empty() => PathBuf::from(p),
        _ if !exists(own) && exists(system) => system.to_owned(),
        _ => own.to_owned(),
    }
}

/// A connection to the daemon.
#[derive(Debug)]
pub struct Client {
    reader: BufReader<UnixStream>,
    writer: UnixStream,
}

/// What `watch` of every job sends.
#[derive(Clone, Debug, PartialEq)]
pub enum Watched {
    /// A job's state or progress.
    Job(Event),
    /// What a person did at a plotter.
    Plotter(PlotterEvent),
    /// A plotter's state now, after it changed.
    PlotterChanged(PlotterChange),
}

/// Where a submitted job is drawn.
#[derive(Clone, Copy, Debug)]
pub struct Placing<'a> {
    /// The plotter (`None`: the first configured).
    pub plotter: Option<&'a str>,
    /// On the sheet already in it, never waiting for a fresh one.
    pub same_sheet: bool,
    /// Sheets to draw it on, one after another (default 1).
    pub copies: u32,
    /// The plotter's pen for each pen of the job drawn with another.
    pub pens: Option<&'a crate::pen_map::PenMap>,
    /// For an SVG drawing: what its fills hide.
    pub occult: Option<crate::spool::Occult>,
}

impl Default for Placing<'_> {
    fn default() -> Self {
        Placing { plotter: None, same_sheet: false, copies: 1, pens: None, occult: None }
    }
}

impl Client {
    /// Connects to the daemon at `path`.
    ///
    /// # Errors
    /// [`ClientError::Connect`].
    pub fn connect(path: &Path) -> Result<Client, ClientError> {
        // A socket in a directory another user controls may be theirs:
        // refuse it before sending a job there (issue #42).
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            if dir.exists() {
                crate::trusted_path::check_socket_dir(dir, nix::unistd::getuid().as_raw())?;
            }
        }
        let s = UnixStream::connect(path).map_err(|reason| ClientError::Connect { path: path.to_owned(), reason })?;
        let writer = s.try_clone()?;
        Ok(Client { reader: BufReader::new(s), writer })
    }

    /// Sends one request.
    ///
    /// # Errors
    /// [`ClientError::Io`].
    pub fn send(&mut self, req: &Request) -> Result<(), ClientError> {
        self.writer.write_all(&encode(req))?;
        Ok(())
    }

    /// Reads one reply; an `error` reply becomes [`ClientError::Refused`].
    ///
    /// # Errors
    /// [`ClientError`].
    pub fn recv(&mut self) -> Result<Reply, ClientError> {
        let mut line = String::new();
        if self.reader.read_line(&mut line)? == 0 {
            return Err(ClientError::Protocol("the daemon closed the connection".into()));
        }
        match serde_json::from_str(&line) {
            Ok(Reply::Error { message }) => Err(ClientError::Refused(message)),
            Ok(r) => Ok(r),
            Err(e) => Err(ClientError::Protocol(format!("{e}: {}", line.trim()))),
        }
    }

    /// One request, one reply.
    ///
    /// # Errors
    /// [`ClientError`].
    pub fn call(&mut self, req: &Request) -> Result<Reply, ClientError> {
        self.send(req)?;
        self.recv()
    }

    /// Submits content (on the plotter's next fresh sheet); returns the job id once the daemon has spooled it.
    ///
    /// # Errors
    /// [`ClientError`].
    pub fn submit(&mut self, kind: JobKind, plotter: Option<&str>, name: &str, content: String) -> Result<JobId, ClientError> {
        self.submit_job(JobFile { kind, content, files: BTreeMap::new() }, &Placing { plotter, ..Placing::default() }, name)
    }

    /// Submits a job read by [`read_job_file`], with its attachments.
    ///
    /// # Errors
    /// [`ClientError`]; a request over the daemon's size limit is refused
    /// with a message naming the limit.
    pub fn submit_job(&mut self, job: JobFile, placing: &Placing<'_>, name: &str) -> Result<JobId, ClientError> {
        let files = job.files.iter().map(|(k, v)| (k.clone(), BASE64.encode(v))).collect();
        let req = Request::Submit {
            kind: job.kind,
            plotter: placing.plotter.map(str::to_owned),
            name: Some(name.to_owned()),
            content: job.content,
            files,
            same_sheet: placing.same_sheet,
            copies: placing.copies,
            pens: placing.pens.cloned().unwrap_or_default(),
            occult: placing.occult,
        };
        match self.call(&req)? {
            Reply::Submitted { id } => Ok(id),
            other => Err(ClientError::Protocol(format!("unexpected reply {other:?}"))),
        }
    }

    /// Starts watching job `id` (or all): read events with [`Client::next_event`].
    ///
    /// # Errors
    /// [`ClientError`].
    pub fn watch(&mut self, id: Option<JobId>) -> Result<(), ClientError> {
        self.send(&Request::Watch { id })
    }

    /// The next job event (what people do at the plotters passed over);
    /// `None` when the daemon ends the stream.
    ///
    /// # Errors
    /// [`ClientError`].
    pub fn next_event(&mut self) -> Result<Option<Event>, ClientError> {
        loop {
            match self.next_watched()? {
                Some(Watched::Job(e)) => return Ok(Some(e)),
                Some(Watched::Plotter(_) | Watched::PlotterChanged(_)) => {}
                None => return Ok(None),
            }
        }
    }

    /// The next event of a job or a plotter; `None` when the daemon ends
    /// the stream.
    ///
    /// # Errors
    /// [`ClientError`].
    pub fn next_watched(&mut self) -> Result<Option<Watched>, ClientError> {
        match self.recv() {
            Ok(Reply::Event(e)) => Ok(Some(Watched::Job(e))),
            Ok(Reply::Plotter(e)) => Ok(Some(Watched::Plotter(e))),
            Ok(Reply::PlotterChanged(e)) => Ok(Some(Watched::PlotterChanged(e))),
            Ok(other) => Err(ClientError::Protocol(format!("unexpected reply {other:?}"))),
            Err(ClientError::Protocol(m)) if m.contains("closed") => Ok(None),
            Err(e) => Err(e),
        }
    }

    /// The job list.
    ///
    /// # Errors
    /// [`ClientError`].
    pub fn jobs(&mut self) -> Result<Vec<JobInfo>, ClientError> {
        self.job_list().map(|(jobs, _)| jobs)
    }

    /// The job list, and the records the daemon found unreadable.
    ///
    /// # Errors
    /// [`ClientError`].
    pub fn job_list(&mut self) -> Result<(Vec<JobInfo>, Vec<CorruptRecord>), ClientError> {
        match self.call(&Request::Jobs {})? {
            Reply::Jobs { jobs, corrupt } => Ok((jobs, corrupt)),
            other => Err(ClientError::Protocol(format!("unexpected reply {other:?}"))),
        }
    }
}

/// A job as read from disk, ready to submit.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct JobFile {
    /// Content kind.
    pub kind: JobKind,
    /// The file's text.
    pub content: String,
    /// For a scene: every file it names, by the relative name written in the
    /// scene (see [`scene::Recorder`]).
    pub files: BTreeMap<String, Vec<u8>>,
}

/// Reads a file to submit and works out its kind (from `kind` or the
/// extension). A scene is loaded here, through a recording resolver, so
/// that every file it names (meshes, height tables, map outlines, places,
/// symbol OBJs) is read with the loaders' own limits and attached: the
/// daemon never opens a path a client names.
///
/// # Errors
/// [`ClientError::File`]: the file cannot be read or is not text; for a scene,
/// its load error (naming the line and field, or the data file and row), or a
/// named file that is absolute or outside the scene's directory.
pub fn read_job_file(path: &Path, kind: Option<JobKind>) -> Result<JobFile, ClientError> {
    let file_err = |message: String| ClientError::File { path: path.to_owned(), message };
    let kind = kind
        .or_else(|| JobKind::from_path(path))
        .ok_or_else(|| file_err("cannot tell the kind from the extension (.toml, .hpgl/.plt, .gcode/.nc, .svg); use --kind".into()))?;
    let bytes = std::fs::read(path).map_err(|e| file_err(e.to_string()))?;
    let content = String::from_utf8(bytes).map_err(|e| file_err(format!("not UTF-8 text at byte {}", e.utf8_error().valid_up_to())))?;
    let files = match kind {
        JobKind::Scene => {
            let dir = path.parent().unwrap_or(Path::new(""));
            let name = path.file_name().map_or_else(|| Path::new("scene.toml").to_owned(), PathBuf::from);
            let recorder = scene::Recorder::new(dir);
            // The scene's path without its directory: the recorder is then
            // asked for each name exactly as written, which is its key.
            scene::Scene::from_toml_in(&content, &name, &recorder).map_err(|e| file_err(format!("the scene does not load: {e}")))?;
            recorder.into_files()
        }
        _ => BTreeMap::new(),
    };
    Ok(JobFile { kind, content, files })
}

/// Follows job `id` until it ends; returns the exit code (0 done,
/// [`EXIT_FAILED`], [`EXIT_CANCELLED`]). On a terminal it draws a progress
/// bar on stderr (cleared of nothing: its last state stays, on a line of its
/// own); otherwise, for logs and CI, it writes a plain line to stderr per
/// state change and per progress step, at most one every
/// [`PLAIN_PROGRESS_EVERY`] while the state stays the same.
///
/// # Errors
/// [`ClientError`] when the connection breaks.
pub fn follow(socket: &Path, id: JobId, quiet: bool) -> Result<u8, ClientError> {
    let mut c = Client::connect(socket)?;
    c.watch(Some(id))?;
    let mut shown = if quiet {
        FollowView::Quiet
    } else if std::io::stderr().is_terminal() {
        FollowView::Bar(progress_bar(id))
    } else {
        FollowView::Lines { last: None }
    };
    while let Some(ev) = c.next_event()? {
        let code = match ev.state {
            State::Done => Some(0),
            State::Failed => Some(EXIT_FAILED),
            State::Cancelled => Some(EXIT_CANCELLED),
            _ => None,
        };
        shown.show(&ev, code.is_some());
        if let Some(code) = code {
            return Ok(code);
        }
    }
    if let FollowView::Bar(bar) = shown {
        bar.abandon();
    }
    Err(ClientError::Protocol("the daemon stopped before the job ended".into()))
}

/// Least time between two plain progress lines of the same state.
pub const PLAIN_PROGRESS_EVERY: Duration = Duration::from_secs(2);

/// How [`follow`] shows progress.
enum FollowView {
    /// Nothing (the caller prints its own summary).
    Quiet,
    /// A progress bar on a terminal.
    Bar(indicatif::ProgressBar),
    /// Plain lines: the state and when the last line was written.
    Lines { last: Option<(State, Instant)> },
}

impl FollowView {
    fn show(&mut self, ev: &Event, end: bool) {
        match self {
            FollowView::Quiet => {}
            FollowView::Bar(bar) => {
                if let Some(t) = ev.strokes_total {
                    bar.set_length(t as u64);
                }
                bar.set_position(ev.strokes_done as u64);
                bar.set_message(progress_message(ev));
                if end {
                    bar.finish();
                }
            }
            FollowView::Lines { last } => {
                let due = match last {
                    Some((state, at)) => *state != ev.state || at.elapsed() >= PLAIN_PROGRESS_EVERY,
                    None => true,
                };
                if due || end {
                    eprintln!("{}", progress_line(ev));
                    *last = Some((ev.state, Instant::now()));
                }
            }
        }
    }
}

fn progress_bar(id: JobId) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(1);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{spinner} job {prefix} [{bar:40}] {pos}/{len} strokes  {msg}")
            .expect("static template")
            .progress_chars("=> "),
    );
    bar.set_prefix(id.to_string());
    bar.enable_steady_tick(Duration::from_millis(200));
    bar
}

/// The state, and what is left or why it stopped.
fn progress_message(ev: &Event) -> String {
    match &ev.reason {
        Some(r) => format!("{}: {}", ev.state, crate::text::escaped(r)),
        None if ev.state == State::Plotting => {
            format!("{}{}", ev.state, ev.eta_s.map(|s| format!(", about {} left", fmt_secs(s))).unwrap_or_default())
        }
        None => ev.state.to_string(),
    }
}

/// One plain progress line: `job 3: 12/84 strokes, plotting, about 1m02s left`.
#[must_use]
pub fn progress_line(ev: &Event) -> String {
    let strokes = match ev.strokes_total {
        Some(t) => format!("{}/{t} strokes", ev.strokes_done),
        None => format!("{} strokes", ev.strokes_done),
    };
    format!("job {}: {strokes}, {}", ev.job, progress_message(ev))
}

/// Seconds as people read a duration: `45s`, `1m02s`, `1h05m`.
#[must_use]
pub fn fmt_secs(s: f64) -> String {
    let s = s.max(0.0).round() as u64;
    if s >= 3600 {
        format!("{}h{:02}m", s / 3600, s / 60 % 60)
    } else if s >= 60 {
        format!("{}m{:02}s", s / 60, s % 60)
    } else {
        format!("{s}s")
    }
}

/// One line per job, for `plotd jobs`.
#[must_use]
pub fn format_job(j: &JobInfo) -> String {
    let progress = match j.strokes_total {
        Some(t) => format!("{}/{t}", j.strokes_done),
        None => "-".into(),
    };
    let reason = j.reason.as_deref().map(|r| format!("  ({})", crate::text::escaped(r))).unwrap_or_default();
    // Names and reasons come from clients and their files: escaped, so
    // they cannot forge a line or move the cursor.
    let (mut plotter, name) = (crate::text::escaped(&j.plotter), crate::text::escaped(&j.name));
    // A job for a class: which plotter took it, and for what.
    if let Some(class) = j.class.as_deref().filter(|c| *c != j.plotter) {
        plotter = format!("{plotter} ({})", crate::text::escaped(class)).into();
    }
    let copy = if j.copies > 1 { format!(" [copy {} of {}]", j.copy, j.copies) } else { String::new() };
    format!("{:>5}  {:<10} {:<10} {:>11}  {}{}{}", j.id, j.state.name(), plotter, progress, name, copy, reason)
}

/// One line for a record the daemon could not read, for `plotd jobs`.
#[must_use]
pub fn format_corrupt(c: &CorruptRecord) -> String {
    let path = c.path.display().to_string();
    format!("{:>5}  {:<10} record kept as {} ({})", c.id, "corrupt", crate::text::escaped(&path), crate::text::escaped(&c.reason))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_socket_in_a_directory_others_can_write_is_not_connected_to() {
        use std::os::unix::fs::PermissionsExt;
        // Issue #42: the client used the socket path whoever made its directory.
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path().join("plotd-1000");
        std::fs::create_dir(&dir).unwrap();
        std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o777)).unwrap();
        let sock = dir.join("plotd.sock");
        let _listener = std::os::unix::net::UnixListener::bind(&sock).unwrap();
        let e = Client::connect(&sock).unwrap_err();
        assert!(matches!(e, ClientError::Untrusted(_)), "{e}");
        assert!(e.to_string().contains("can be written by other users"), "{e}");
        std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o700)).unwrap();
        Client::connect(&sock).unwrap();
    }

    /// A job for `any` shows the class until a plotter takes it, then the
    /// plotter and the class.
    #[test]
    fn a_job_line_shows_which_plotter_took_a_job_for_a_class() {
        let mut record = crate::spool::JobRecord {
            class: Some(crate::spool::PlotterClass { name: "any".into(), fits: vec!["hp".into(), "hp2".into()] }),
            ..crate::spool::JobRecord::queued(7, "any", "a.hpgl")
        };
        assert_eq!(format_job(&JobInfo::of(&record)), "    7  queued     any                  -  a.hpgl");
        record.plotter = "hp2".into();
        record.class.as_mut().unwrap().fits.clear();
        assert_eq!(format_job(&JobInfo::of(&record)), "    7  queued     hp2 (any)            -  a.hpgl");
    }

    #[test]
    fn a_job_line_shows_control_characters_escaped() {
        let job = JobInfo::of(&crate::spool::JobRecord {
            state: crate::spool::JobState::Failed { reason: "bad\u{1b}]0;title\u{7}".into() },
            ..crate::spool::JobRecord::queued(7, "hp", "a.hpgl\r\u{1b}[2K   99  done       hp          10/10  forged\n")
        });
        let line = format_job(&job);
        assert!(!line.chars().any(char::is_control), "{line:?}");
        assert!(
            line.starts_with("    7  failed") && line.contains(r"a.hpgl\r\u{1b}[2K") && line.contains(r"(bad\u{1b}]0;title\u{7})"),
            "{line}"
        );
    }

    #[test]
    fn socket_discovery_order() {
        let (own, system) = (Path::new("/u/plotd.sock"), Path::new("/run/plotd/plotd.sock"));
        let env = || Some(std::ffi::OsString::from("/env.sock"));
        let pick = |flag: Option<&str>, env, live: &[&Path]| choose_socket(flag.map(Path::new), env, own, system, |p| live.contains(&p));
        // --socket beats everything, then $PLOTD_SOCKET (an empty one is unset).
        assert_eq!(pick(Some("/flag.sock"), env(), &[own, system]), Path::new("/flag.sock"));
        assert_eq!(pick(None, env(), &[own, system]), Path::new("/env.sock"));
        assert_eq!(pick(None, Some("".into()), &[system]), system);
        // Then the user's own daemon, else the system one, else the user's (for the error).
        assert_eq!(pick(None, None, &[own, system]), own);
        assert_eq!(pick(None, None, &[system]), system);
        assert_eq!(pick(None, None, &[]), own);
    }

    #[test]
    fn a_scene_is_sent_with_exactly_the_files_it_names() {
        let dir = tempfile::tempdir().unwrap();
        let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples");
        std::fs::create_dir(dir.path().join("m")).unwrap();
        std::fs::copy(repo.join("cube.obj"), dir.path().join("m/cube.obj")).unwrap();
        std::fs::copy(repo.join("terrain.csv"), dir.path().join("t.csv")).unwrap();
        std::fs::write(dir.path().join("unused.csv"), "1,2\n3,4\n").unwrap();
        let cam = "[camera]\neye = [5.0, -9.0, 6.0]\ntarget = [0.0, 0.0, 0.0]\nfov_deg = 40.0\n";
        let scene = dir.path().join("s.toml");
        std::fs::write(&scene, format!("{cam}[[mesh]]\npath = \"m/cube.obj\"\n[[surface]]\ndata = \"t.csv\"\n")).unwrap();
        let job = read_job_file(&scene, None).unwrap();
        assert_eq!(job.kind, JobKind::Scene);
        assert_eq!(job.files.keys().collect::<Vec<_>>(), ["m/cube.obj", "t.csv"]);
        assert_eq!(job.files["t.csv"], std::fs::read(repo.join("terrain.csv")).unwrap());
        // A path the daemon would never serve is refused here, before sending.
        std::fs::write(&scene, format!("{cam}[[mesh]]\npath = \"{}\"\n", dir.path().join("m/cube.obj").display())).unwrap();
        let e = read_job_file(&scene, None).unwrap_err().to_string();
        assert!(e.contains("mesh[0].path") && e.contains("absolute"), "{e}");
        // Non-scenes carry no files.
        std::fs::write(dir.path().join("a.hpgl"), "IN;").unwrap();
        assert!(read_job_file(&dir.path().join("a.hpgl"), None).unwrap().files.is_empty());
    }
}
