//! Helpers for the end-to-end tests in `tests/tests/it/`: a daemon and a virtual
//! plotter wired together over a real pseudo-terminal.
//!
//! [`Rig`] starts a `plotsim` simulator (its pty reached through a symlink, as
//! a USB adapter's `/dev/serial/by-id` name would be) and `plotd serve` on a
//! temporary socket and spool, in-process. Waits are explicit, with timeouts.

pub mod ebb;

use plotd::client::Client;
use plotd::config::Config;
use plotd::protocol::{Event, JobInfo, LinkState, Reply, Request, State};
use plotd::spool::JobKind;
use plotsim::{SimConfig, Simulator};
use std::io::Write;
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::sync::{Arc, OnceLock};
use std::time::{Duration, Instant};

/// Repository root (for `examples/`).
#[must_use]
pub fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("tests/ is in the repo").to_owned()
}

/// A daemon, a simulator, a temporary directory.
pub struct Rig {
    /// The virtual plotter.
    pub sim: Simulator,
    /// The daemon's socket.
    pub socket: PathBuf,
    /// Holds the socket, spool and pty link.
    pub dir: tempfile::TempDir,
    /// The device profile the plotter is configured with.
    pub device: String,
    /// The web page's address, once it listens (`[web]` in `extra`).
    pub web: Arc<OnceLock<SocketAddr>>,
    stop: Option<tokio::sync::oneshot::Sender<()>>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Rig {
    /// Starts a simulator with `sim` and a daemon driving it as `device` with
    /// `handshake`; `extra` is added to the `[[plotter]]` table.
    #[must_use]
    pub fn start(sim: SimConfig, device: &str, handshake: &str, extra: &str) -> Rig {
        Rig::launch(sim, None, device, handshake, extra)
    }

    /// Starts a simulator with `sim` (an EBB) and a daemon that finds it as
    /// `found` says (`port = "auto"`, `nickname = "..."`) among the USB
    /// serial ports of a sysfs tree of the rig's own, where the
    /// simulator's pty is an EiBotBoard (04D8:FD92) beside an FTDI adapter.
    #[must_use]
    pub fn start_found(sim: SimConfig, found: &str, extra: &str) -> Rig {
        Rig::launch(sim, Some(found), "axidraw", "ebb", extra)
    }

    fn launch(sim: SimConfig, found: Option<&str>, device: &str, handshake: &str, extra: &str) -> Rig {
        // The daemon runs on this process's threads: with `RUST_LOG` set its
        // log goes to stderr, as the binary's would.
        if std::env::var_os("RUST_LOG").is_some() {
            plotd::logging::init();
        }
        let dir = tempfile::tempdir().expect("tempdir");
        let link = dir.path().join("tty");
        let baud = if sim.baud == 0 { 9600 } else { sim.baud };
        let sim = Simulator::start(sim.with_link(&link)).expect("simulator starts");
        let sysfs = found.map(|_| {
            let root = dir.path().join("sys");
            let pty = sim.slave_path().expect("the simulator's pty");
            let name = pty.strip_prefix("/dev").expect("a pty under /dev").to_string_lossy().replace('/', "!");
            fake_usb_tty(&root, &name, "04d8", "fd92", "EiBotBoard");
            fake_usb_tty(&root, "ttyUSB7", "0403", "6001", "FT232R USB UART");
            root
        });
        let port = found.map_or_else(|| format!("port = \"{}\"", link.display()), str::to_owned);
        let text = format!(
            "socket = \"{d}/plotd.sock\"\nspool = \"{d}/spool\"\n[[plotter]]\nname = \"p\"\n{port}\nbaud = {baud}\ndevice = \"{device}\"\nhandshake = \"{handshake}\"\n{timeouts}{extra}\n",
            // `extra` may set its own timeouts (a stall test wants short ones).
            timeouts = if extra.contains("timeout_s") { "" } else { "reply_timeout_s = 1.0\nmotion_timeout_s = 20.0\n" },
            d = dir.path().display(),
        );
        let config = Config::from_toml(&text, "rig").expect("rig config");
        let socket = config.socket.clone();
        let (tx, rx) = tokio::sync::oneshot::channel::<()>();
        let web = Arc::new(OnceLock::new());
        let options = plotd::daemon::ServeOptions { web_address: Arc::clone(&web), sysfs, ..Default::default() };
        let thread = std::thread::spawn(move || {
            let rt = tokio::runtime::Runtime::new().expect("runtime");
            rt.block_on(plotd::daemon::serve(config, options, async {
                let _ = rx.await;
            }))
            .expect("daemon runs");
        });
        let s = socket.clone();
        wait_for("the daemon's socket", Duration::from_secs(20), || std::os::unix::net::UnixStream::connect(&s).is_ok());
        Rig { sim, socket, dir, device: device.to_owned(), web, stop: Some(tx), thread: Some(thread) }
    }

    /// The web page's address, once it listens (the socket accepts
    /// connections a moment before).
    ///
    /// # Panics
    /// When it does not listen within 20 s (the config has no `[web]`?).
    #[must_use]
    pub fn web_address(&self) -> SocketAddr {
        wait_for("the web page to listen (is there a [web] table?)", Duration::from_secs(20), || self.web.get().is_some());
        *self.web.get().expect("set")
    }
}

/// Lays out a USB serial tty in a fake sysfs tree at `root` as the kernel
/// does for a CDC ACM device: `class/tty/NAME/device` links to the USB
/// interface, whose parent holds the device's ids and product string.
pub fn fake_usb_tty(root: &Path, name: &str, vendor: &str, product_id: &str, product: &str) {
    let class = root.join("class/tty").join(name);
    std::fs::create_dir_all(&class).expect("sysfs class dir");
    let usb = root.join("devices/usb1").join(format!("1-{name}"));
    let interface = usb.join("1.0");
    std::fs::create_dir_all(&interface).expect("sysfs usb dir");
    for (file, text) in [("idVendor", vendor), ("idProduct", product_id), ("product", product)] {
        std::fs::write(usb.join(file), format!("{text}\n")).expect("sysfs file");
    }
    std::os::unix::fs::symlink(&interface, class.join("device")).expect("sysfs device link");
}

/// A second virtual plotter for a [`Rig`]: the simulator, and the
/// `[[plotter]]` table named `name` that drives it as `device` with
/// `handshake` (pass it as the rig's `extra`; its timeouts are the
/// daemon's defaults). Its pty link lives in `dir`.
#[must_use]
pub fn second_plotter(dir: &Path, name: &str, sim: SimConfig, device: &str, handshake: &str) -> (Simulator, String) {
    let link = dir.join(format!("tty-{name}"));
    let baud = if sim.baud == 0 { 9600 } else { sim.baud };
    let sim = Simulator::start(sim.with_link(&link)).expect("simulator starts");
    let table = format!(
        "\n[[plotter]]\nname = \"{name}\"\nport = \"{l}\"\nbaud = {baud}\ndevice = \"{device}\"\nhandshake = \"{handshake}\"\n",
        l = link.display()
    );
    (sim, table)
}

/// What a test does with a running daemon, through its socket. [`Rig`] (the
/// daemon in-process) and the child-process daemon of `crates/plotd/tests`
/// both have it.
pub trait DaemonHandle {
    /// The daemon's socket.
    fn socket(&self) -> &Path;

    /// A new client connection.
    fn client(&self) -> Client {
        Client::connect(self.socket()).expect("client connects")
    }

    /// Submits content to the plotter, drawn on the sheet in it (the tests
    /// of other things than sheets never wait for a fresh one); returns the
    /// job id.
    fn submit(&self, kind: JobKind, content: &str) -> u64 {
        let job = plotd::client::JobFile { kind, content: content.to_owned(), files: std::collections::BTreeMap::new() };
        self.client()
            .submit_job(job, &plotd::client::Placing { same_sheet: true, ..plotd::client::Placing::default() }, "test")
            .expect("job accepted")
    }

    /// The job, as `jobs` lists it.
    fn job(&self, id: u64) -> JobInfo {
        self.client().jobs().expect("jobs").into_iter().find(|j| j.id == id).expect("job exists")
    }

    /// Waits until job `id` is in `state`; fails on timeout, or if the job
    /// reaches a final state other than the one waited for.
    fn wait_state(&self, id: u64, state: State, timeout: Duration) -> JobInfo {
        let end = Instant::now() + timeout;
        loop {
            let j = self.job(id);
            if j.state == state {
                return j;
            }
            assert!(!j.state.is_final(), "job {id} ended {} ({:?}) while waiting for {state}", j.state, j.reason);
            assert!(Instant::now() < end, "timed out waiting for job {id} to be {state}; it is {} ({:?})", j.state, j.reason);
            std::thread::sleep(Duration::from_millis(10));
        }
    }

    /// Waits until job `id` is paused; returns the reason.
    fn paused_reason(&self, id: u64, timeout: Duration) -> String {
        self.wait_state(id, State::Paused, timeout).reason.expect("a paused job says why")
    }

    /// Waits until the (first) plotter's port is back online.
    fn wait_online(&self, timeout: Duration) {
        wait_for("the port to come back", timeout, || {
            let Ok(Reply::Status { plotters, .. }) = self.client().call(&Request::Status {}) else { return false };
            plotters[0].link == LinkState::Online
        });
    }

    /// `plotd resume ID`.
    fn resume(&self, id: u64) {
        self.client().call(&Request::Resume { id: Some(id), position_confirmed: false }).expect("resume answered");
    }

    /// `plotd resume ID --position-confirmed`: the pen is at the origin.
    fn resume_position_confirmed(&self, id: u64) {
        self.client().call(&Request::Resume { id: Some(id), position_confirmed: true }).expect("resume answered");
    }

    /// Watches job `id` (`plotd watch ID`) from its state now on.
    fn watch_job(&self, id: u64) -> JobEvents {
        JobEvents::watch(self.socket(), id)
    }
}

/// The `watch` events of one job, read on a thread as the daemon sends them:
/// what a test waits on to see states that may not last (a pause that
/// resumes by itself) or to check a state was never taken.
pub struct JobEvents {
    id: u64,
    rx: mpsc::Receiver<Event>,
    /// The events taken off the channel so far.
    seen: Vec<Event>,
    /// How many of `seen` a wait has looked at: the state the watch began
    /// with is looked at by the first `until`, so a change made before the
    /// watch began is not waited for in vain.
    looked_at: usize,
}

impl JobEvents {
    /// Watches job `id` on `socket`; returns once the daemon has sent its
    /// state now (it subscribes before it sends that), so no later change is
    /// missed.
    ///
    /// # Panics
    /// When the daemon does not answer, or has no job `id`.
    #[must_use]
    pub fn watch(socket: &Path, id: u64) -> JobEvents {
        let mut client = Client::connect(socket).expect("client connects");
        client.watch(Some(id)).expect("watch asked");
        let (tx, rx) = mpsc::channel();
        // Ends when the daemon ends the stream (after the job's last event)
        // or goes away.
        std::thread::spawn(move || {
            while let Ok(Some(ev)) = client.next_event() {
                if tx.send(ev).is_err() {
                    return;
                }
            }
        });
        let mut events = JobEvents { id, rx, seen: Vec::new(), looked_at: 0 };
        events.next(Duration::from_secs(20)).unwrap_or_else(|| panic!("no state of job {id} from `watch`"));
        events.looked_at = 0;
        events
    }

    /// The next event, or `None` once the job has ended (the daemon ends a
    /// job's stream after its last event).
    ///
    /// # Panics
    /// After `timeout` without an event.
    pub fn next(&mut self, timeout: Duration) -> Option<&Event> {
        match self.rx.recv_timeout(timeout) {
            Ok(ev) => {
                self.seen.push(ev);
                self.looked_at = self.seen.len();
                self.seen.last()
            }
            Err(mpsc::RecvTimeoutError::Disconnected) => None,
            Err(mpsc::RecvTimeoutError::Timeout) => panic!("no event of job {} in {timeout:?}; so far {:?}", self.id, self.seen),
        }
    }

    /// The first event that `wanted` holds for, the job's state when the
    /// watch began included if no wait has looked at it yet; `None` when
    /// the job ends first.
    ///
    /// # Panics
    /// After `timeout` without such an event.
    pub fn until(&mut self, timeout: Duration, wanted: impl Fn(&Event) -> bool) -> Option<&Event> {
        let end = Instant::now() + timeout;
        while self.looked_at < self.seen.len() {
            self.looked_at += 1;
            if wanted(&self.seen[self.looked_at - 1]) {
                return self.seen.get(self.looked_at - 1);
            }
        }
        loop {
            let ev = self.next(end.saturating_duration_since(Instant::now()))?;
            if wanted(ev) {
                break;
            }
        }
        self.seen.last()
    }

    /// The events taken so far, the job's state when the watch began first.
    #[must_use]
    pub fn seen(&self) -> &[Event] {
        &self.seen
    }

    /// Every event up to the job's end (`done`, `failed`, `cancelled`),
    /// those already seen included.
    ///
    /// # Panics
    /// After `timeout` without the end.
    #[must_use]
    pub fn until_end(mut self, timeout: Duration) -> Vec<Event> {
        let end = Instant::now() + timeout;
        while self.next(end.saturating_duration_since(Instant::now())).is_some() {}
        self.seen
    }
}

impl Rig {
    /// After an unplug: waits for job `id` to pause as "device offline", for
    /// the plotter to be plugged back and its port online, then resumes it.
    pub fn resume_after_replug(&self, id: u64, timeout: Duration) {
        let reason = self.paused_reason(id, timeout);
        assert!(reason.contains("offline"), "{reason}");
        self.sim.wait_connected(timeout).expect("the plotter comes back");
        self.wait_online(timeout);
        self.resume(id);
    }
}

impl DaemonHandle for Rig {
    fn socket(&self) -> &Path {
        &self.socket
    }
}

impl Drop for Rig {
    fn drop(&mut self) {
        if let Some(tx) = self.stop.take() {
            let _ = tx.send(());
        }
        if let Some(t) = self.thread.take() {
            // The daemon stops once the stroke in hand is finished. A failed
            // test may have left the device unable to finish it (its paper
            // lever up): then the daemon is not waited for beyond a deadline,
            // so the failure shows instead of a hang; the simulator, dropped
            // next, takes its port away and it ends.
            if std::thread::panicking() {
                let end = Instant::now() + Duration::from_secs(10);
                while !t.is_finished() && Instant::now() < end {
                    std::thread::sleep(Duration::from_millis(10));
                }
                if !t.is_finished() {
                    return;
                }
            }
            let _ = t.join();
        }
    }
}

/// `n` strokes of HP-GL, each a short line of two segments (about 30 bytes,
/// 3 ms at 9600 baud), placed by `seed`: a job whose strokes are told apart
/// by where they are.
#[must_use]
pub fn hpgl_lines(n: usize, seed: usize) -> String {
    let mut t = String::from("IN;SP1;");
    for k in 0..n {
        let (x, y) = ((seed * 997 + k * 131) % 9000, (seed * 31 + k * 71) % 7000);
        t += &format!("PU{x},{y};PD{},{},{},{};", x + 300, y + 40, x + 300, y + 400);
    }
    t + "PU;SP0;"
}

/// Whether a test that needs a program `.ci/run` installs may run:
/// `missing` says what is missing, or is `None`. Outside CI the test is
/// skipped, and says why on the terminal (past the harness's capture); under
/// CI (`CI` set, as `.ci/run` runs the tests) the program is missing from a
/// machine that must have it, and the test fails naming it.
///
/// # Panics
/// Under CI when something is missing.
#[must_use]
pub fn present_or_skip(test: &str, missing: Option<String>) -> bool {
    let Some(why) = missing else { return true };
    assert!(std::env::var_os("CI").is_none(), "{test}: {why}; CI (`CI` is set) must have it: `.ci/run` installs it");
    let _ = writeln!(std::io::stderr(), "skipping {test}: {why}");
    false
}

/// Why `program` cannot be run (it is nowhere on `PATH`), naming it and
/// the Debian `package` that has it; `None` when it is there.
#[must_use]
pub fn program_missing(program: &str, package: &str) -> Option<String> {
    use std::os::unix::fs::PermissionsExt;
    let path = std::env::var_os("PATH").unwrap_or_default();
    let found = std::env::split_paths(&path)
        .any(|dir| std::fs::metadata(dir.join(program)).is_ok_and(|m| m.is_file() && m.permissions().mode() & 0o111 != 0));
    (!found).then(|| format!("`{program}` is not installed (Debian package {package})"))
}

/// Polls `f` every 10 ms until it holds; panics after `timeout`.
pub fn wait_for(what: &str, timeout: Duration, mut f: impl FnMut() -> bool) {
    let end = Instant::now() + timeout;
    while !f() {
        assert!(Instant::now() < end, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// What `plotd render --device DEVICE` produces for a scene: the device's
/// command text.
#[must_use]
pub fn render_for(scene: &Path, device: &str) -> String {
    let scene = scene::Scene::load(scene).expect("scene loads");
    emit_for(scene, device)
}

/// The command text of every frame of an animated scene for `device`, as
/// `plotd render scene.toml -o f-%04d.hpgl --device` writes them.
#[must_use]
pub fn frames_for(scene: &Path, device: &str) -> Vec<String> {
    let scene = scene::Scene::load(scene).expect("scene loads");
    scene.frames().map(|f| emit_for(f.expect("frame builds"), device)).collect()
}

fn emit_for(scene: scene::Scene, device: &str) -> String {
    let drawing = plotd::pipeline::plotted_drawing(scene).expect("scene renders");
    let profile = plotcode::DeviceProfile::builtin(device).expect("profile");
    plotcode::emit(&drawing, &profile, &plotcode::EmitOptions::default()).expect("emits").text
}

/// The strokes a command text draws on `device` (pen, device points), read by
/// plotcode's own reader.
#[must_use]
pub fn strokes_of(text: &str, device: &str) -> Vec<(u32, Vec<[f64; 2]>)> {
    let profile = plotcode::DeviceProfile::builtin(device).expect("profile");
    let plot = match profile.protocol {
        plotcode::Protocol::Hpgl => plotcode::hpgl::parse(text.as_bytes()).expect("HP-GL parses"),
        plotcode::Protocol::Gcode => {
            plotcode::gcode::parse(text, &plotcode::gcode::ParseOptions::for_profile(&profile)).expect("G-code parses")
        }
        plotcode::Protocol::Ebb => plotcode::ebb::parse(text.as_bytes()).expect("EBB text parses"),
    };
    plot.strokes.into_iter().map(|s| (s.pen, s.points.iter().map(|p| [p.x, p.y]).collect())).collect()
}

/// The strokes the simulator recorded.
#[must_use]
pub fn recorded(sim: &Simulator) -> Vec<(u32, Vec<[f64; 2]>)> {
    sim.record().strokes.into_iter().map(|s| (s.pen, s.points)).collect()
}

/// Checks what the simulator drew: `want` exactly once (as
/// [`assert_drawn_once`], at most `max_repeats` strokes again), no buffer
/// overrun and no device error. Returns the number of repeats.
///
/// # Panics
/// With the first difference, or the overruns or errors.
pub fn assert_plotted(sim: &Simulator, want: &[(u32, Vec<[f64; 2]>)], max_repeats: usize) -> usize {
    let repeats = assert_drawn_once(&recorded(sim), want, max_repeats);
    let rec = sim.record();
    assert_eq!(rec.overruns, 0);
    assert!(rec.errors.is_empty(), "{:?}", rec.errors);
    repeats
}

fn same_points(a: &[[f64; 2]], b: &[[f64; 2]]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(p, q)| (p[0] - q[0]).abs() < 1e-6 && (p[1] - q[1]).abs() < 1e-6)
}

/// Checks that `got` is `want` drawn exactly once, in order, except for at
/// most `max_repeats` strokes drawn again at interruptions: a repeat is a
/// stroke equal to, or a beginning of, the expected stroke it precedes or the
/// one just drawn. Returns the number of repeats.
///
/// # Panics
/// With the first difference.
pub fn assert_drawn_once(got: &[(u32, Vec<[f64; 2]>)], want: &[(u32, Vec<[f64; 2]>)], max_repeats: usize) -> usize {
    let is_part = |g: &(u32, Vec<[f64; 2]>), w: &(u32, Vec<[f64; 2]>)| {
        g.0 == w.0 && !g.1.is_empty() && g.1.len() <= w.1.len() && same_points(&g.1[..1], &w.1[..1])
    };
    let (mut i, mut j, mut repeats) = (0, 0, 0);
    while j < got.len() {
        if i < want.len() && got[j].0 == want[i].0 && same_points(&got[j].1, &want[i].1) {
            i += 1;
            j += 1;
        } else if (i < want.len() && is_part(&got[j], &want[i])) || (i > 0 && is_part(&got[j], &want[i - 1])) {
            repeats += 1;
            j += 1;
        } else {
            panic!("stroke {j} drawn ({:?}) is not expected stroke {i} ({:?})", got[j], want.get(i));
        }
    }
    assert_eq!(i, want.len(), "only {i} of {} strokes drawn", want.len());
    assert!(repeats <= max_repeats, "{repeats} strokes repeated, at most {max_repeats} allowed");
    repeats
}
