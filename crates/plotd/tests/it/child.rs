//! The `plotd` binary as a child process (`plotd serve --config`), driving a
//! plotsim plotter on a pty in this process: for the tests that kill the
//! daemon, or measure it from outside.

#![allow(dead_code)] // each test file uses its own part

use plotd_e2e::DaemonHandle;
use plotsim::{SimConfig, Simulator};
use std::os::unix::net::UnixStream;
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

    /// Puts `keys` (top-level config keys, one per line) at the head of the config.
    pub fn top_level(&self, keys: &str) -> &Setup {
        let text = std::fs::read_to_string(&self.config).expect("config");
        std::fs::write(&self.config, format!("{keys}\n{text}")).expect("config written");
        self
    }

    /// Starts `plotd serve` on this config and waits until it answers.
    pub fn start(&self) -> Daemon {
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_plotd"));
        cmd.args(["serve", "--config"]).arg(&self.config);
        self.start_command(cmd)
    }

    /// Starts `cmd` (a `plotd serve` on this config, perhaps wrapped, with
    /// its own environment) and waits until the daemon answers.
    pub fn start_command(&self, cmd: Command) -> Daemon {
        self.start_logging_to(cmd, Stdio::inherit())
    }

    /// Starts `plotd serve` on this config, its log (warnings and worse)
    /// written to `log`.
    pub fn start_logging(&self, log: &Path) -> Daemon {
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_plotd"));
        cmd.args(["serve", "--config"]).arg(&self.config);
        self.start_logging_to(cmd, std::fs::File::create(log).expect("log file").into())
    }

    fn start_logging_to(&self, mut cmd: Command, stderr: Stdio) -> Daemon {
        let child = cmd.env("RUST_LOG", "warn").stdout(Stdio::null()).stderr(stderr).spawn().expect("plotd starts");
        let d = Daemon { child, socket: self.socket.clone() };
        let end = Instant::now() + Duration::from_secs(30);
        while UnixStream::connect(&self.socket).is_err() {
            assert!(Instant::now() < end, "plotd did not open its socket");
            std::thread::sleep(Duration::from_millis(10));
        }
        d
    }
}

/// Held by a test while it holds thousands of this process's descriptors
/// (idle connections to a daemon): the tests of this binary run on threads
/// of one process, with one descriptor table, so two such tests at once
/// could exhaust it.
pub fn descriptor_hungry() -> std::sync::MutexGuard<'static, ()> {
    static HUNGRY: std::sync::Mutex<()> = std::sync::Mutex::new(());
    HUNGRY.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
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

    /// Sets a resource limit of the running daemon (`prlimit(2)`), as a
    /// full disk or an exhausted descriptor table would be felt.
    pub fn prlimit(&self, resource: nix::sys::resource::Resource, soft: u64, hard: u64) {
        let new = nix::libc::rlimit { rlim_cur: soft, rlim_max: hard };
        // SAFETY: plain system call on valid pointers.
        let r = unsafe { nix::libc::prlimit(self.pid().as_raw(), resource as _, &new, std::ptr::null_mut()) };
        assert_eq!(r, 0, "prlimit: {}", std::io::Error::last_os_error());
    }

    /// A resource limit of the running daemon: (soft, hard).
    pub fn rlimit(&self, resource: nix::sys::resource::Resource) -> (u64, u64) {
        let mut old = nix::libc::rlimit { rlim_cur: 0, rlim_max: 0 };
        // SAFETY: plain system call on valid pointers.
        let r = unsafe { nix::libc::prlimit(self.pid().as_raw(), resource as _, std::ptr::null(), &mut old) };
        assert_eq!(r, 0, "prlimit: {}", std::io::Error::last_os_error());
        (old.rlim_cur, old.rlim_max)
    }

    /// The lowest descriptor number the daemon has free between its saves:
    /// a descriptor limit of this makes its next `open` fail. The least of
    /// samples over a quarter second, so that a file open for a moment (a
    /// checkpoint being saved, under load for milliseconds) is not counted:
    /// once it closed, its number would be free under the limit.
    pub fn lowest_free_fd(&self) -> u64 {
        let sample = || {
            let open: std::collections::BTreeSet<u64> = std::fs::read_dir(format!("/proc/{}/fd", self.child.id()))
                .expect("/proc fd")
                .filter_map(|e| e.ok()?.file_name().to_str()?.parse().ok())
                .collect();
            (0..).find(|n| !open.contains(n)).expect("a free number")
        };
        (0..50)
            .map(|_| {
                std::thread::sleep(std::time::Duration::from_millis(5));
                sample()
            })
            .min()
            .expect("samples")
    }

    /// The daemon's child processes (its job workers).
    pub fn children(&self) -> Vec<u32> {
        let mut out = Vec::new();
        for task in std::fs::read_dir(format!("/proc/{}/task", self.child.id())).expect("/proc task") {
            let path = task.expect("task").path().join("children");
            let text = std::fs::read_to_string(path).unwrap_or_default();
            out.extend(text.split_whitespace().filter_map(|p| p.parse::<u32>().ok()));
        }
        out
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
