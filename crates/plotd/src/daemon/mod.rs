//! `plotd serve`: the daemon.
//!
//! [`serve`] opens the spool (recovering interrupted jobs as `paused`), listens
//! on the Unix socket (mode 0660, or the socket systemd passes), starts one
//! task per plotter, tells systemd it is ready, and runs until `shutdown`
//! resolves. Then every plotter finishes its stroke, lifts the pen and
//! persists its job before `serve` returns.
//!
//! - `registry.rs`: shared state; every change is persisted, then announced;
//! - `server.rs`: the socket protocol;
//! - `plotter.rs`: one task per plotter, owning its port;
//! - `convert.rs`: job content to device commands;
//! - `systemd.rs`: sd-notify.

mod convert;
mod plotter;
pub mod registry;
mod server;
mod systemd;

use crate::config::{Config, ConfigError};
use crate::spool::{Spool, SpoolError};
use registry::{Registry, StopReason};
use std::future::Future;
use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;
use thiserror::Error;
use tokio::net::UnixListener;
use tokio::sync::watch;

pub use convert::program_for;

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
}

/// Options of [`serve`] besides the configuration.
#[derive(Clone, Debug, Default)]
pub struct ServeOptions {
    /// The file the configuration came from: SIGHUP re-reads it.
    pub config_path: Option<PathBuf>,
    /// Use a listening socket passed by systemd (socket activation) when there is one.
    pub socket_activation: bool,
}

/// Runs the daemon until `shutdown` resolves.
///
/// # Errors
/// [`DaemonError`] when the spool or the socket cannot be set up. Once
/// running, errors are logged and put on the jobs they concern.
pub async fn serve(config: Config, options: ServeOptions, shutdown: impl Future<Output = ()>) -> Result<(), DaemonError> {
    let spool = Spool::open(&config.spool)?;
    let (jobs, bad) = spool.recover()?;
    for e in &bad {
        tracing::error!(error = %e, "unreadable job record left in the spool");
    }
    tracing::info!(spool = %config.spool.display(), jobs = jobs.len(), "spool recovered");
    let (listener, activated) = listen(&config.socket, options.socket_activation)?;
    let reg = Registry::new(spool, jobs, &config.plotters, config.keep_finished);
    let (stop_tx, stop_rx) = watch::channel(false);
    let mut tasks = tokio::task::JoinSet::new();
    for p in &config.plotters {
        tasks.spawn(plotter::run(reg.clone(), p.name.clone(), stop_rx.clone()));
    }
    let status = tokio::spawn(systemd::status_feed(reg.clone()));
    systemd::ready(&format!("listening on {}", config.socket.display()));
    tracing::info!(socket = %config.socket.display(), plotters = config.plotters.len(), "plotd ready");

    let mut hup = tokio::signal::unix::signal(tokio::signal::unix::SignalKind::hangup()).ok();
    let mut watchdog = tokio::time::interval(systemd::watchdog_interval().unwrap_or(Duration::from_secs(3600)));
    let limit = config.max_request_bytes;
    let mut current = config;
    tokio::pin!(shutdown);
    loop {
        tokio::select! {
            () = &mut shutdown => break,
            accepted = listener.accept() => match accepted {
                Ok((stream, _)) => { tokio::spawn(server::handle(reg.clone(), stream, limit)); }
                Err(e) => { tracing::warn!(error = %e, "accept failed"); tokio::time::sleep(Duration::from_millis(50)).await; }
            },
            _ = watchdog.tick() => systemd::watchdog(),
            Some(()) = async { match hup.as_mut() { Some(h) => h.recv().await, None => std::future::pending().await } } => {
                if let Some(path) = &options.config_path {
                    reload(&reg, &mut current, path, &stop_rx, &mut tasks);
                }
            }
        }
    }

    tracing::info!("shutting down: finishing strokes");
    systemd::stopping();
    let names: Vec<String> = {
        let mut st = reg.lock();
        st.shutting_down = true;
        st.plotters.iter().map(|p| p.config.name.clone()).collect()
    };
    for n in &names {
        reg.request_stop(n, StopReason::Shutdown);
    }
    let _ = stop_tx.send(true);
    while tasks.join_next().await.is_some() {}
    status.abort();
    if !activated {
        let _ = std::fs::remove_file(&current.socket);
    }
    tracing::info!("plotd stopped");
    Ok(())
}

/// SIGHUP: re-read the config. Plotters are updated in place (new port, rate,
/// handshake take effect at their next job or reopen) and new ones start;
/// `keep_finished` applies at once; socket and spool changes need a restart.
fn reload(reg: &Arc<Registry>, current: &mut Config, path: &Path, stop_rx: &watch::Receiver<bool>, tasks: &mut tokio::task::JoinSet<()>) {
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
    let mut st = reg.lock();
    st.keep_finished = next.keep_finished;
    for p in &next.plotters {
        match st.plotter_mut(&p.name) {
            Some(slot) => {
                slot.config = p.clone();
                slot.wake.notify_one();
            }
            None => {
                st.plotters.push(registry::PlotterSlot::added(p.clone()));
                tasks.spawn(plotter::run(reg.clone(), p.name.clone(), stop_rx.clone()));
            }
        }
    }
    for p in &current.plotters {
        if !next.plotters.iter().any(|q| q.name == p.name) {
            tracing::warn!(plotter = %p.name, "plotter removed from the config keeps running until restart");
        }
    }
    drop(st);
    reg.prune();
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
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(|e| err(format!("cannot create its directory: {e}")))?;
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
