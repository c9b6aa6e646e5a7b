//! `plotd serve`: the daemon.
//!
//! [`serve`] opens the spool (a restart pauses interrupted jobs: see
//! [`crate::job::after_restart`]), listens on the Unix socket (mode 0660, or
//! the socket systemd passes), starts one task per plotter, tells systemd it
//! is ready, and runs until `shutdown` resolves. Then every plotter finishes
//! its stroke, lifts the pen and saves its job before `serve` returns.
//!
//! Every decision about a job is the job's life's ([`crate::job::JobLife`]);
//! the modules here carry bytes, time and disk results to it and its
//! actions back out:
//! - `registry.rs`: the machine behind a lock; saves (then announces),
//!   removals, stops and wakes;
//! - `server.rs`: the socket protocol;
//! - `access.rs`: who may act on and read which job (operators, submitters);
//! - `connections.rs`: which connections are kept (limits, who gives way);
//! - `checks.rs`: the submit checks' bounded pool, each user's in turn;
//! - `plotter.rs`: one task per plotter, owning its port: probes, renders,
//!   locates, spans;
//! - `manual.rs`: a person's manual requests, carried out by the plotter's
//!   task (pen, move, jog, a job's frame);
//! - `rendering.rs`: a job's program, from the job worker's pages;
//! - `systemd.rs`: sd-notify;
//! - `web/`: the web page (`[web]`), answered as the socket is.

mod access;
mod checks;
mod connections;
mod manual;
mod plotter;
pub mod registry;
mod rendering;
mod server;
mod systemd;
mod web;

use crate::config::{Config, ConfigError};
use crate::job::JobLife;
use crate::spool::{JobId, Spool, SpoolError};
use registry::Registry;
use std::future::Future;
use std::os::unix::fs::{DirBuilderExt, PermissionsExt};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;
use thiserror::Error;
use tokio::net::UnixListener;

/// Why the daemon could not start or run.
#[derive(Debug, Error)]
pub enum DaemonError {
    /// The spool could not be opened or read.
    #[error(transparent)]
    Spool(#[from] SpoolError),
    /// The socket could not be set up.
    #[error("socket {path}: {message}")]
    Socket {
        /// The socket path.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// The configuration could not be used.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// The web page could not be served (`[web]`).
    #[error("web page: {0}")]
    Web(String),
}

/// Options of [`serve`] besides the configuration.
#[derive(Clone, Debug, Default)]
pub struct ServeOptions {
    /// The file the configuration came from: SIGHUP re-reads it.
    pub config_path: Option<PathBuf>,
    /// Use a listening socket passed by systemd (socket activation) when there is one.
    pub socket_activation: bool,
    /// The `plotd` binary, run as `plotd job-worker` to check and render
    /// jobs under the config's budget. `None` (tests of the library, which
    /// have no such binary): on a thread of the daemon, with no budget.
    pub worker_exe: Option<PathBuf>,
    /// Set to the web page's address once it listens (the port the system
    /// chose, for `listen = "127.0.0.1:0"`): what `plotd demo` prints.
    pub web_address: Arc<std::sync::OnceLock<std::net::SocketAddr>>,
    /// Where the kernel's device tree is read to find an EiBotBoard for
    /// `port = "auto"` and `nickname`; `None`: `/sys`. Tests pass a tree of
    /// their own.
    pub sysfs: Option<PathBuf>,
}

/// Runs the daemon until `shutdown` resolves.
///
/// # Errors
/// [`DaemonError`] when the spool or the socket cannot be set up. Once
/// running, errors are logged and put on the jobs they concern.
pub async fn serve(config: Config, options: ServeOptions, shutdown: impl Future<Output = ()>) -> Result<(), DaemonError> {
    process_settings();
    // Before anything reads or changes the spool: a second daemon on it
    // stops here, having touched nothing.
    let _lock = Spool::lock(&config.spool)?;
    let spool = Spool::open(&config.spool)?;
    // Ids follow every file on disk, before orphans are tidied away.
    let highest_id = spool.highest_id()?;
    let (jobs, bad) = spool.recover()?;
    for e in &bad {
        tracing::error!(error = %e, "unreadable job record moved to the spool's corrupt/ directory, its content kept");
    }
    let corrupt = spool.corrupt_records().unwrap_or_else(|e| {
        tracing::error!(error = %e, "cannot list the records kept aside");
        Vec::new()
    });
    let highest_id = corrupt.iter().map(|c| c.id).fold(highest_id, JobId::max);
    let (mut life, restarted) = JobLife::new(jobs, highest_id, &config.plotters, config.keep_finished);
    for p in &config.plotters {
        // Unreadable, the sheet is taken to be used: a person says when it is fresh.
        let state = spool.plotter_state(&p.name).unwrap_or_else(|e| {
            tracing::error!(plotter = %p.name, error = %e, "cannot read the plotter's state: its sheet is taken to be used");
            crate::spool::PlotterState { sheet: crate::spool::Sheet::Used, ..Default::default() }
        });
        life.restore_plotter(&p.name, state);
    }
    // What the restart changed, saved before anything reads or changes it.
    for record in &restarted {
        spool.save(record)?;
    }
    tracing::info!(spool = %config.spool.display(), jobs = life.shown_jobs().count(), "spool recovered");
    let (listener, activated) = listen(&config.socket, options.socket_activation)?;
    let worker = crate::worker::Worker { exe: options.worker_exe.clone(), budget: config.render_budget() };
    let reg = Registry::new(spool, life, corrupt, worker);
    reg.carry_out(reg.with(JobLife::prune));
    let mut tasks = tokio::task::JoinSet::new();
    let sysfs: Arc<Path> = options.sysfs.clone().unwrap_or_else(|| PathBuf::from("/sys")).into();
    for p in &config.plotters {
        tasks.spawn(plotter::run(reg.clone(), p.name.clone(), sysfs.clone()));
    }
    let status = tokio::spawn(systemd::status_feed(reg.clone()));
    let web = match &config.web {
        Some(_) => Some(web::start(&config, reg.clone()).await.map_err(DaemonError::Web)?),
        None => None,
    };
    if let Some(w) = &web {
        let _ = options.web_address.set(w.address);
    }
    systemd::ready(&format!("listening on {}", config.socket.display()));
    tracing::info!(socket = %config.socket.display(), plotters = config.plotters.len(), "plotd ready");

    let mut hup = tokio::signal::unix::signal(tokio::signal::unix::SignalKind::hangup()).ok();
    let mut watchdog = tokio::time::interval(systemd::watchdog_interval().unwrap_or(Duration::from_secs(3600)));
    let limit = config.max_request_bytes;
    let conns = connections::Connections::new(connection_limits(&config));
    let idle = Duration::from_secs_f64(config.idle_timeout_s);
    let mut accept_backoff = ACCEPT_BACKOFF_MIN;
    let mut current = config;
    tokio::pin!(shutdown);
    loop {
        tokio::select! {
            () = &mut shutdown => break,
            accepted = listener.accept() => match accepted {
                Ok((stream, _)) => {
                    accept_backoff = ACCEPT_BACKOFF_MIN;
                    if let Some(client) = server::admit(&stream, &conns) {
                        tokio::spawn(server::handle(reg.clone(), stream, client, limit, idle));
                    }
                }
                Err(e) => {
                    // Out of descriptors (or memory): wait, longer each time,
                    // so the loop does not spin; clients already connected
                    // go on, and closing ones frees room.
                    if accept_backoff == ACCEPT_BACKOFF_MIN {
                        tracing::warn!(error = %e, connections = conns.count(), "accept failed; backing off");
                    }
                    tokio::time::sleep(accept_backoff).await;
                    accept_backoff = (accept_backoff * 2).min(ACCEPT_BACKOFF_MAX);
                }
            },
            _ = watchdog.tick() => systemd::watchdog(),
            Some(()) = async { match hup.as_mut() { Some(h) => h.recv().await, None => std::future::pending().await } } => {
                if let Some(path) = &options.config_path {
                    reload(&reg, &mut current, path, &mut tasks, &sysfs);
                }
            }
        }
    }

    tracing::info!("shutting down: finishing strokes");
    systemd::stopping();
    reg.carry_out(reg.with(JobLife::shut_down));
    while tasks.join_next().await.is_some() {}
    status.abort();
    if let Some(w) = web {
        w.stop().await;
    }
    if !activated {
        let _ = std::fs::remove_file(&current.socket);
    }
    tracing::info!("plotd stopped");
    Ok(())
}

/// Process-wide settings of a daemon that runs for months on what clients send.
fn process_settings() {
    // A write past the file size limit fails with EFBIG (a spool error,
    // which pauses the job) instead of killing the daemon with SIGXFSZ.
    // SAFETY: SIG_IGN installs no handler code.
    if let Err(e) = unsafe { nix::sys::signal::signal(nix::sys::signal::Signal::SIGXFSZ, nix::sys::signal::SigHandler::SigIgn) } {
        tracing::warn!(error = %e, "cannot ignore SIGXFSZ");
    }
    // glibc serves large blocks from the heap once one large block has been
    // freed (its mmap threshold grows to 32 MiB), and a heap does not shrink
    // past its top: six 16 MiB submits left over 2 GB resident after they
    // were cancelled. A fixed threshold maps every block of 256 KiB or more
    // on its own, and gives it back when freed.
    #[cfg(target_env = "gnu")]
    // SAFETY: mallopt only sets an allocator parameter.
    unsafe {
        nix::libc::mallopt(nix::libc::M_MMAP_THRESHOLD, 256 * 1024);
    }
}

/// First wait after `accept` fails; doubles up to [`ACCEPT_BACKOFF_MAX`].
const ACCEPT_BACKOFF_MIN: Duration = Duration::from_millis(10);
/// Longest wait after `accept` fails.
const ACCEPT_BACKOFF_MAX: Duration = Duration::from_secs(1);
/// File descriptors kept for everything but client connections: the spool,
/// serial ports, job workers' pipes, systemd, logs.
const FD_RESERVE: u64 = 64;

/// The connection limits of `config`, the total capped so that connections
/// can never take the descriptors the spool and the ports need. Raises the
/// soft descriptor limit to the hard one first.
fn connection_limits(config: &Config) -> connections::Limits {
    use nix::sys::resource::{getrlimit, setrlimit, Resource};
    let fds: u64 = match getrlimit(Resource::RLIMIT_NOFILE) {
        Ok((soft, hard)) => {
            if soft < hard && setrlimit(Resource::RLIMIT_NOFILE, hard, hard).is_ok() {
                hard
            } else {
                soft
            }
        }
        Err(_) => 1024,
    };
    let room = usize::try_from(fds.saturating_sub(FD_RESERVE).max(1)).unwrap_or(usize::MAX);
    if config.max_connections > room {
        tracing::warn!(max_connections = config.max_connections, fds, "max_connections lowered to {room} to fit the descriptor limit");
    }
    let total = config.max_connections.min(room);
    connections::Limits { total, per_uid: config.max_connections_per_uid.min(total) }
}

/// SIGHUP: re-read the config. Plotters are updated in place (new port, rate,
/// handshake take effect at their next job or reopen) and new ones start;
/// `keep_finished` applies at once; socket and spool changes need a restart.
fn reload(reg: &Arc<Registry>, current: &mut Config, path: &Path, tasks: &mut tokio::task::JoinSet<()>, sysfs: &Arc<Path>) {
    let next = match Config::load(path) {
        Ok(c) => c,
        Err(e) => {
            tracing::error!(error = %e, "config reload failed; keeping the old one");
            return;
        }
    };
    if next.socket != current.socket || next.spool != current.spool {
        tracing::warn!("socket and spool changes take effect at the next restart");
    }
    let (actions, added) = reg.with(|l| l.reload(&next.plotters, next.keep_finished));
    for name in added {
        reg.add_plotter(&name);
        tasks.spawn(plotter::run(reg.clone(), name, sysfs.clone()));
    }
    reg.carry_out(actions);
    for p in &current.plotters {
        if !next.plotters.iter().any(|q| q.name == p.name) {
            tracing::warn!(plotter = %p.name, "plotter removed from the config keeps running until restart");
        }
    }
    tracing::info!(path = %path.display(), "config reloaded");
    *current = Config { socket: current.socket.clone(), spool: current.spool.clone(), ..next };
}

/// The listening socket, and whether systemd passed it.
fn listen(path: &Path, activation: bool) -> Result<(UnixListener, bool), DaemonError> {
    let err = |message: String| DaemonError::Socket { path: path.to_owned(), message };
    if activation {
        if let Some(l) = systemd::activated_listener() {
            let l = l.map_err(|e| err(e.to_string()))?;
            return Ok((l, true));
        }
    }
    // The directory is made private if it is new, and must be the daemon's
    // own whoever made it: one another user made first under /tmp would
    // receive every job submitted (issue #42).
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::DirBuilder::new().recursive(true).mode(0o700).create(dir).map_err(|e| err(format!("cannot create its directory: {e}")))?;
        crate::trusted_path::check_own_dir(dir).map_err(|e| err(format!("its directory {e}")))?;
    }
    if path.exists() {
        // A live daemon answers; a stale socket from a crash does not.
        if std::os::unix::net::UnixStream::connect(path).is_ok() {
            return Err(err("another plotd is listening there".into()));
        }
        std::fs::remove_file(path).map_err(|e| err(format!("cannot remove the stale socket: {e}")))?;
    }
    let listener = UnixListener::bind(path).map_err(|e| err(e.to_string()))?;
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o660)).map_err(|e| err(e.to_string()))?;
    Ok((listener, false))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[tokio::test]
    async fn the_socket_goes_only_in_a_directory_of_the_daemon_s_own() {
        let tmp = tempfile::tempdir().unwrap();
        // Made private when new.
        let fresh = tmp.path().join("plotd-1000/plotd.sock");
        let (_l, _) = listen(&fresh, false).unwrap();
        assert_eq!(std::fs::metadata(fresh.parent().unwrap()).unwrap().permissions().mode() & 0o777, 0o700);
        // Issue #42: a directory others can write (as another user left
        // under /tmp) was used as it was.
        let open = tmp.path().join("open");
        std::fs::create_dir(&open).unwrap();
        std::fs::set_permissions(&open, std::fs::Permissions::from_mode(0o777)).unwrap();
        let e = listen(&open.join("plotd.sock"), false).unwrap_err().to_string();
        assert!(e.contains("its directory") && e.contains("can be written by other users"), "{e}");
        assert!(!open.join("plotd.sock").exists());
        // A link in its place.
        let link = tmp.path().join("link");
        std::os::unix::fs::symlink(&open, &link).unwrap();
        let e = listen(&link.join("plotd.sock"), false).unwrap_err().to_string();
        assert!(e.contains("symbolic link"), "{e}");
    }
}
