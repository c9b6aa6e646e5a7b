//! The `plotd` binary as a child process (`plotd serve --config`), driving a
//! plotsim plotter on a pty in this process: for the tests that kill the
//! daemon, or measure it from outside.

#![allow(dead_code)] // each test file uses its own part

use plotsim::{SimConfig, Simulator};
use std::os::unix::net::UnixStream;
use plotd_e2e::DaemonHandle;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

/// A simulator and a config file; daemons are started (and restarted) on them.
pub struct Setup {
    /// The virtual plotter (outlives the daemons).
    pub sim: Simulator,
    /// Holds the config, socket, spool and pty link.
    pub dir: tempfile::TempDir,
    /// The config file.
    pub config: PathBuf,
    /// The daemon's socket.
    pub socket: PathBuf,
}

impl Setup {
    /// An HP 7475A at 9600 baud (instant motion, so the line is the pace),
    /// driven with ESC.B polling; `extra` goes into the `[[plotter]]` table.
    pub fn hp_escb(extra: &str) -> Setup {
        Setup::new(SimConfig::hp7475a().with_speed_scale(0.0).with_baud(9600), "hp7475a", "escb", extra)
    }

    /// A simulator with `sim` and a config driving it as `device` with `handshake`.
    pub fn new(sim: SimConfig, device: &str, handshake: &str, extra: &str) -> Setup {
        let dir = tempfile::tempdir().expect("tempdir");
        let link = dir.path().join("tty");
        let baud = if sim.baud == 0 { 9600 } else { sim.baud };
        let sim = Simulator::start(sim.with_link(&link)).expect("simulator starts");
        let socket = dir.path().join("plotd.sock");
        let text = format!(
            "socket = \"{s}\"\nspool = \"{d}/spool\"\n[[plotter]]\nname = \"p\"\nport = \"{l}\"\nbaud = {baud}\ndevice = \"{device}\"\nhandshake = \"{handshake}\"\nreply_timeout_s = 1.0\nmotion_timeout_s = 20.0\n{extra}\n",
            s = socket.display(),
            d = dir.path().display(),
            l = link.display(),
        );
        let config = dir.path().join("plotd.toml");
        std::fs::write(&config, text).expect("config written");
        Setup { sim, dir, config, socket }
    }

    /// Starts `plotd serve` on this config and waits until it answers.
    pub fn start(&self) -> Daemon {
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_plotd"));
        cmd.args(["serve", "--config"]).arg(&self.config);
        self.start_command(cmd)
    }

    /// Starts `cmd` (a `plotd serve` on this config, perhaps wrapped, with
    /// its own environment) and waits until the daemon answers.
    pub fn start_command(&self, mut cmd: Command) -> Daemon {
        let child = cmd.env("RUST_LOG", "warn").stdout(Stdio::null()).stderr(Stdio::inherit()).spawn().expect("plotd starts");
        let d = Daemon { child, socket: self.socket.clone() };
        let end = Instant::now() + Duration::from_secs(30);
        while UnixStream::connect(&self.socket).is_err() {
            assert!(Instant::now() < end, "plotd did not open its socket");
            std::thread::sleep(Duration::from_millis(10));
        }
        d
    }
}

impl DaemonHandle for Daemon {
    fn socket(&self) -> &Path {
        &self.socket
    }
}

/// A running `plotd serve`; killed when dropped.
pub struct Daemon {
    /// The process.
    pub child: Child,
    socket: PathBuf,
}

impl Daemon {
    /// The process id.
    pub fn pid(&self) -> nix::unistd::Pid {
        nix::unistd::Pid::from_raw(i32::try_from(self.child.id()).expect("pid fits"))
    }

    /// SIGKILL, and reap it.
    pub fn kill(&mut self) {
        nix::sys::signal::kill(self.pid(), nix::sys::signal::Signal::SIGKILL).expect("kill");
        self.child.wait().expect("reaped");
    }

    /// SIGTERM, then waits for the exit (failing after `timeout`).
    pub fn terminate(&mut self, timeout: Duration) -> ExitStatus {
        nix::sys::signal::kill(self.pid(), nix::sys::signal::Signal::SIGTERM).expect("kill");
        let end = Instant::now() + timeout;
        loop {
            if let Some(status) = self.child.try_wait().expect("try_wait") {
                return status;
            }
            assert!(Instant::now() < end, "plotd did not exit after SIGTERM");
            std::thread::sleep(Duration::from_millis(10));
        }
    }

    /// Resident memory, kB, from `/proc/PID/status`.
    pub fn rss_kb(&self) -> u64 {
        let status = std::fs::read_to_string(format!("/proc/{}/status", self.child.id())).expect("/proc status");
        status
            .lines()
            .find_map(|l| l.strip_prefix("VmRSS:"))
            .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
            .expect("VmRSS in /proc status")
    }
}

impl Drop for Daemon {
    fn drop(&mut self) {
        if self.child.try_wait().ok().flatten().is_none() {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

/// Strokes as (pen, device points).
pub type Strokes = [(u32, Vec<[f64; 2]>)];

fn same(a: &(u32, Vec<[f64; 2]>), b: &(u32, Vec<[f64; 2]>)) -> bool {
    a.0 == b.0 && a.1.len() == b.1.len() && a.1.iter().zip(&b.1).all(|(p, q)| (p[0] - q[0]).abs() < 1e-6 && (p[1] - q[1]).abs() < 1e-6)
}

/// Checks a drawing interrupted by a daemon that died while the device still
/// held commands: `got` must be `want[..a]` (the device ran out of commands
/// there, perhaps in the middle of stroke `a`), then `want[resumed..]` to the
/// end, with `resumed <= a`. Returns `a - resumed`, the strokes drawn twice.
///
/// # Panics
/// With the first stroke that fits neither part.
pub fn assert_drawn_with_replay(got: &Strokes, want: &Strokes, resumed: usize) -> usize {
    let a = got.iter().zip(want).take_while(|(g, w)| same(g, w)).count();
    let mut j = a;
    // A stroke cut short when the device's commands ran out.
    if j < got.len() && a < want.len() && !same(&got[j], &want[resumed.min(want.len() - 1)]) {
        let (g, w) = (&got[j], &want[a]);
        assert!(g.0 == w.0 && g.1.len() < w.1.len() && g.1.iter().zip(&w.1).all(|(p, q)| p == q), "stroke {j} drawn ({g:?}) is neither stroke {a} nor its beginning");
        j += 1;
    }
    assert!(resumed <= a, "resumed at stroke {resumed}, but only {a} strokes were drawn before: strokes lost");
    let rest = &got[j..];
    assert_eq!(rest.len(), want.len() - resumed, "after the restart, {} strokes drawn; expected strokes {resumed}.. ({})", rest.len(), want.len() - resumed);
    for (k, (g, w)) in rest.iter().zip(&want[resumed..]).enumerate() {
        assert!(same(g, w), "after the restart, stroke {} drawn ({g:?}) is not expected stroke {} ({w:?})", j + k, resumed + k);
    }
    a - resumed
}
