//! `config/plotd.service` and `config/plotd.socket` under a real systemd:
//! `.ci/systemd-sandbox` boots systemd as pid 1 of new namespaces with the
//! units installed as their header says, and this test drives it with
//! `systemctl` against a plotsim plotter on a pty (the plotter's pty is made
//! `root:dialout 0660`, as a USB adapter's node is).
//!
//! Needs util-linux (`unshare`, `nsenter`, `runuser`), `useradd` and
//! systemd, which `.ci/run` installs: without them it fails under CI (`CI`
//! set) and is skipped elsewhere, saying what is missing. It needs root and
//! namespaces too: without them it is skipped, saying why, CI or not.

use plotd::client::Client;
use plotd::protocol::{Reply, Request, State};
use plotd::spool::JobKind;
use plotd_e2e::{assert_plotted, hpgl_lines, present_or_skip, program_missing, recorded, repo_root, strokes_of, wait_for, DaemonHandle};
use plotsim::{SimConfig, Simulator};
use std::io::Write;
use std::os::unix::fs::{MetadataExt, PermissionsExt};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::Duration;

const LONG: Duration = Duration::from_secs(60);
const SYSTEMD: &str = "/lib/systemd/systemd";
const SOCKET: &str = "/run/plotd/plotd.sock";

/// A program the sandbox needs that is not installed (`.ci/run` installs
/// them all), if one is not.
fn missing_program() -> Option<String> {
    for (tool, package) in [
        ("unshare", "util-linux"),
        ("nsenter", "util-linux"),
        ("runuser", "util-linux"),
        ("useradd", "passwd"),
        ("systemctl", "systemd"),
        ("journalctl", "systemd"),
    ] {
        if let Some(why) = program_missing(tool, package) {
            return Some(why);
        }
    }
    (!Path::new(SYSTEMD).exists()).then(|| format!("{SYSTEMD} is not installed (Debian package systemd)"))
}

/// Why this machine cannot make the sandbox's namespaces, if it cannot:
/// not root, or a container that forbids them. No install mends that.
fn cannot_sandbox() -> Option<String> {
    if !nix::unistd::geteuid().is_root() {
        return Some("not root (the sandbox needs new pid and mount namespaces)".into());
    }
    let probe = Command::new("unshare").args(["--pid", "--fork", "--mount", "--cgroup", "true"]).output();
    match probe {
        Ok(o) if o.status.success() => None,
        Ok(o) => Some(format!("unshare cannot make namespaces here: {}", String::from_utf8_lossy(&o.stderr).trim())),
        Err(e) => Some(format!("unshare: {e}")),
    }
}

/// A systemd booted by `.ci/systemd-sandbox`, killed (namespace and all) when dropped.
struct Sandbox {
    script: Child,
    dir: tempfile::TempDir,
    pid: i32,
}

impl Sandbox {
    fn boot(config: &str) -> Sandbox {
        let dir = tempfile::tempdir().expect("tempdir");
        let toml = dir.path().join("plotd.toml");
        std::fs::write(&toml, config).expect("config written");
        let script = Command::new(repo_root().join(".ci/systemd-sandbox"))
            .arg(dir.path())
            .arg(env!("CARGO_BIN_EXE_plotd"))
            .arg(&toml)
            .stdin(Stdio::null())
            .spawn()
            .expect("sandbox starts");
        let pid_file = dir.path().join("pid");
        let mut sb = Sandbox { script, dir, pid: 0 };
        wait_for("systemd's pid", LONG, || std::fs::read_to_string(&pid_file).is_ok_and(|s| s.ends_with('\n')));
        sb.pid = std::fs::read_to_string(&pid_file).unwrap().trim().parse().expect("a pid");
        // No bus, then "offline", until systemd listens; then --wait waits for the boot to end.
        let mut state = String::new();
        wait_for("systemd to boot", LONG, || {
            let o = sb.run(&["systemctl", "is-system-running", "--wait"]);
            state = format!("{}{}", text(&o.stdout), text(&o.stderr)).trim().to_owned();
            ["running", "degraded", "maintenance", "stopping"].contains(&state.as_str())
        });
        assert_eq!(state, "running", "systemd did not come up");
        sb
    }

    /// Runs a command inside (as root), killed after [`LONG`].
    fn run(&self, args: &[&str]) -> Output {
        Command::new("timeout")
            .args([&LONG.as_secs().to_string(), "nsenter", "-t", &self.pid.to_string(), "-m", "-p", "--"])
            .args(args)
            .stdin(Stdio::null())
            .output()
            .expect("nsenter runs")
    }

    /// Runs a command inside; it must succeed. Returns its stdout.
    fn ok(&self, args: &[&str]) -> String {
        let o = self.run(args);
        assert!(o.status.success(), "{args:?} failed: {}{}", text(&o.stdout), text(&o.stderr));
        text(&o.stdout)
    }

    /// `systemctl show -P PROPERTY UNIT`.
    fn show(&self, unit: &str, property: &str) -> String {
        self.ok(&["systemctl", "show", "-P", property, unit]).trim().to_owned()
    }

    /// A path inside, seen from here.
    fn path(&self, inside: &str) -> PathBuf {
        let rel = inside.trim_start_matches('/');
        let (top, rest) = rel.split_once('/').unwrap_or((rel, ""));
        assert!(["etc", "run", "var"].contains(&top), "{inside} is not visible from outside");
        self.dir.path().join(top).join(rest)
    }

    /// A user's uid and gid from the sandbox's /etc/passwd.
    fn ids(&self, user: &str) -> (u32, u32) {
        let passwd = std::fs::read_to_string(self.path("/etc/passwd")).unwrap();
        let f: Vec<&str> = passwd.lines().find(|l| l.starts_with(&format!("{user}:"))).expect("user exists").split(':').collect();
        (f[2].parse().unwrap(), f[3].parse().unwrap())
    }

    /// The journal lines of plotd.service as JSON objects.
    fn journal(&self) -> Vec<serde_json::Value> {
        self.ok(&["journalctl", "-u", "plotd.service", "-o", "json", "--no-pager"])
            .lines()
            .map(|l| serde_json::from_str(l).expect("journal JSON"))
            .collect()
    }
}

impl Drop for Sandbox {
    fn drop(&mut self) {
        // A failure under load once left nothing to go on: show what
        // systemd and plotd said before the sandbox goes.
        if std::thread::panicking() && self.pid > 0 {
            let o = self.run(&["journalctl", "-u", "plotd.service", "-u", "plotd.socket", "--no-pager", "-n", "200"]);
            eprintln!("journal of plotd.service and plotd.socket:\n{}{}", text(&o.stdout), text(&o.stderr));
        }
        if self.pid > 0 {
            let _ = nix::sys::signal::kill(nix::unistd::Pid::from_raw(self.pid), nix::sys::signal::Signal::SIGKILL);
        }
        // The script removes the sandbox's cgroups once systemd is gone.
        let _ = self.script.wait();
    }
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// The daemon's socket, seen from outside.
struct Socket(PathBuf);
impl DaemonHandle for Socket {
    fn socket(&self) -> &Path {
        &self.0
    }
}

#[test]
fn units_run_under_a_real_systemd() {
    const TEST: &str = "units_run_under_a_real_systemd";
    if !present_or_skip(TEST, missing_program()) {
        return;
    }
    if let Some(why) = cannot_sandbox() {
        let _ = writeln!(std::io::stderr(), "skipping {TEST}: {why}");
        return;
    }
    let sim = Simulator::start(SimConfig::hp7475a().with_speed_scale(0.0).with_baud(19200)).expect("simulator");
    let tty = sim.slave_path().expect("pty");
    // As a USB serial adapter's node: only the dialout group may open it.
    let dialout = nix::unistd::Group::from_name("dialout").unwrap().expect("dialout group").gid;
    nix::unistd::chown(&tty, Some(nix::unistd::Uid::from_raw(0)), Some(dialout)).unwrap();
    std::fs::set_permissions(&tty, std::fs::Permissions::from_mode(0o660)).unwrap();
    // No socket or spool keys: the defaults under systemd are what is tested.
    let plotter =
        format!("[[plotter]]\nname = \"hp\"\nport = \"{}\"\nbaud = 19200\ndevice = \"hp7475a\"\nhandshake = \"escb\"\n", tty.display());
    let sb = Sandbox::boot(&plotter);

    // systemd itself finds nothing to say about either unit.
    let verify = sb.run(&["systemd-analyze", "verify", "plotd.service", "plotd.socket"]);
    assert!(verify.status.success() && verify.stderr.is_empty(), "systemd-analyze verify: {}", text(&verify.stderr));
    // A watchdog much shorter than the unit's 30 s, so a missing ping would show within this test.
    let dropin = sb.path("/etc/systemd/system/plotd.service.d/watchdog.conf");
    std::fs::write(dropin, "[Service]\nWatchdogSec=2\n").unwrap();
    sb.ok(&["systemctl", "daemon-reload"]);

    // Type=notify: `start` returns once READY=1 came, after the socket listens.
    sb.ok(&["systemctl", "start", "plotd.service"]);
    assert_eq!(sb.show("plotd.service", "ActiveState"), "active");
    assert_eq!(sb.show("plotd.service", "WatchdogUSec"), "2s");
    assert_eq!(sb.show("plotd.service", "StatusText"), format!("listening on {SOCKET}"));
    let main_pid = sb.show("plotd.service", "MainPID");
    let (plotd_uid, plotd_gid) = sb.ids("plotd");
    let ps = sb.ok(&["ps", "-o", "user=,group=,supgrp=", "-p", &main_pid]);
    assert!(ps.starts_with("plotd") && ps.contains("dialout"), "plotd runs as: {ps}");

    // The socket: mode 0660, group plotd, in /run/plotd; the spool in $STATE_DIRECTORY.
    let socket = Socket(sb.path(SOCKET));
    let meta = std::fs::metadata(&socket.0).expect("socket exists");
    assert_eq!((meta.mode() & 0o777, meta.uid(), meta.gid()), (0o660, plotd_uid, plotd_gid));
    assert_eq!(std::fs::metadata(sb.path("/var/lib/plotd/spool")).expect("spool dir").uid(), plotd_uid);

    // A user in group plotd submits with `plotd submit --follow`, the socket
    // found through $PLOTD_SOCKET; a user outside the group is refused.
    sb.ok(&["useradd", "--groups", "plotd", "alice"]);
    sb.ok(&["useradd", "mallory"]);
    let first = hpgl_lines(40, 1);
    std::fs::write(sb.path("/run/first.hpgl"), &first).unwrap();
    let follow = sb.run(&[
        "runuser",
        "-u",
        "alice",
        "--",
        "env",
        &format!("PLOTD_SOCKET={SOCKET}"),
        "plotd",
        "submit",
        "/run/first.hpgl",
        "--follow",
    ]);
    assert!(follow.status.success(), "alice's submit --follow: {}{}", text(&follow.stdout), text(&follow.stderr));
    let id: u64 = text(&follow.stdout).lines().next().unwrap().trim().parse().expect("job id printed");
    let rec = socket.job(id);
    assert_eq!((rec.state, rec.uid), (State::Done, sb.ids("alice").0));
    let refused = sb.run(&["runuser", "-u", "mallory", "--", "plotd", "status", "--socket", SOCKET]);
    assert!(!refused.status.success() && text(&refused.stderr).contains("ermission denied"), "{}", text(&refused.stderr));
    sim.wait_idle(LONG).unwrap();
    let mut want = strokes_of(&first, "hp7475a");
    assert_plotted(&sim, &want, 0);

    // Logs reach the journal through tracing-journald (TARGET is its field;
    // a line on stderr would not carry it).
    let journal = sb.journal();
    assert!(
        journal.iter().any(|e| e["MESSAGE"] == "plotd ready" && e["TARGET"].is_string()),
        "no structured \"plotd ready\" in the journal: {journal:?}"
    );

    // `systemctl reload` (SIGHUP) re-reads /etc/plotd.toml in the same process.
    let second = "[[plotter]]\nname = \"spare\"\nport = \"/dev/ttyUSB7\"\ndevice = \"hp7550a\"\nhandshake = \"escb\"\n";
    std::fs::write(sb.path("/etc/plotd.toml"), format!("{plotter}{second}")).unwrap();
    sb.ok(&["systemctl", "reload", "plotd.service"]);
    wait_for(
        "the reloaded config",
        LONG,
        || matches!(socket.client().call(&Request::Status {}), Ok(Reply::Status { plotters, .. }) if plotters.len() == 2),
    );
    assert_eq!(sb.show("plotd.service", "MainPID"), main_pid);

    // `systemctl stop` mid-job: SIGTERM, the stroke finished, pen up, exit 0.
    let long = hpgl_lines(400, 2);
    let id = socket.submit(JobKind::Hpgl, &long);
    wait_for("a few confirmed strokes", LONG, || socket.job(id).checkpoint >= 5);
    sb.ok(&["systemctl", "stop", "plotd.service"]);
    assert_eq!(
        (sb.show("plotd.service", "Result"), sb.show("plotd.service", "ExecMainStatus"), sb.show("plotd.service", "NRestarts")),
        ("success".into(), "0".into(), "0".into())
    );
    let journal = sb.journal();
    assert!(!journal.iter().any(|e| e["MESSAGE"].as_str().is_some_and(|m| m.contains("Watchdog timeout"))), "{journal:?}");
    sim.wait_idle(LONG).unwrap();
    assert!(!sim.status().device.pen_down, "the pen is left down");
    let long_strokes = strokes_of(&long, "hp7475a");
    let drawn = recorded(&sim);
    let stopped_at = drawn.len() - want.len();
    assert!(stopped_at > 0 && stopped_at < long_strokes.len(), "{stopped_at} strokes drawn before the stop");
    // Whole strokes only: what was drawn is the job's first strokes, exactly.
    want.extend_from_slice(&long_strokes[..stopped_at]);
    assert_plotted(&sim, &want, 0);

    // plotd.socket: systemd listens, and the first client (alice, in group
    // plotd) starts the service; the interrupted job waits, paused.
    sb.ok(&["systemctl", "start", "plotd.socket"]);
    assert_eq!(sb.show("plotd.service", "ActiveState"), "inactive");
    // No --socket, no $PLOTD_SOCKET, no socket of her own: the client finds the system one.
    let status = sb.run(&["runuser", "-u", "alice", "--", "plotd", "status"]);
    assert!(status.status.success(), "alice's first connection: {}", text(&status.stderr));
    assert_eq!(sb.show("plotd.service", "ActiveState"), "active");
    let state = socket.job(id).state;
    assert_eq!(state, State::Paused, "an interrupted job came back {state}, not paused");
    assert_eq!(recorded(&sim).len(), want.len(), "the pen moved after the restart");
    socket.resume(id);
    socket.wait_state(id, State::Done, LONG);
    sim.wait_idle(LONG).unwrap();
    let mut all = strokes_of(&first, "hp7475a");
    all.extend(long_strokes);
    assert_plotted(&sim, &all, 1);

    // Stopping the service leaves the socket to systemd: the next client starts it again.
    sb.ok(&["systemctl", "stop", "plotd.service"]);
    assert_eq!(sb.show("plotd.socket", "ActiveState"), "active");
    let mut c = Client::connect(&socket.0).expect("the socket is still there after the service stopped");
    assert!(matches!(c.call(&Request::Status {}), Ok(Reply::Status { .. })));
    assert_eq!(sb.show("plotd.service", "ActiveState"), "active");
    sb.ok(&["systemctl", "stop", "plotd.socket", "plotd.service"]);
    assert_eq!(sb.show("plotd.service", "Result"), "success");
}
