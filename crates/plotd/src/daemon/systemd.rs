//! systemd integration: readiness, status text, watchdog pings, socket
//! activation. Every call is a no-op outside systemd.

use super::registry::Registry;
use crate::protocol::State;
use sd_notify::NotifyState;
use std::os::fd::FromRawFd;
use std::sync::Arc;
use std::time::Duration;

/// READY=1 with a status line.
pub fn ready(status: &str) {
    let _ = sd_notify::notify(false, &[NotifyState::Ready, NotifyState::Status(status)]);
}

/// STOPPING=1.
pub fn stopping() {
    let _ = sd_notify::notify(false, &[NotifyState::Stopping]);
}

/// WATCHDOG=1, sent from the main loop so a hung loop is noticed.
pub fn watchdog() {
    let _ = sd_notify::notify(false, &[NotifyState::Watchdog]);
}

/// Half the watchdog period systemd asks for, if it asks.
pub fn watchdog_interval() -> Option<Duration> {
    let mut usec = 0;
    sd_notify::watchdog_enabled(false, &mut usec).then(|| Duration::from_micros(usec / 2).max(Duration::from_millis(100)))
}

/// Keeps STATUS= up to date with the job being plotted.
pub async fn status_feed(reg: Arc<Registry>) {
    let mut rx = reg.events.subscribe();
    loop {
        match rx.recv().await {
            Ok(ev) => {
                let text = match (ev.state, ev.strokes_total) {
                    (State::Plotting, Some(t)) => format!("job {}: plotting, stroke {}/{}", ev.job, ev.strokes_done, t),
                    (s, _) => format!("job {}: {s}", ev.job),
                };
                let _ = sd_notify::notify(false, &[NotifyState::Status(&text)]);
            }
            Err(tokio::sync::broadcast::error::RecvError::Lagged(_)) => {}
            Err(_) => return,
        }
    }
}

/// The listening socket systemd passed (socket activation), if any.
pub fn activated_listener() -> Option<std::io::Result<tokio::net::UnixListener>> {
    let fd = sd_notify::listen_fds().ok()?.next()?;
    // SAFETY: systemd passed this descriptor to us (LISTEN_FDS) and nothing else owns it.
    let std_listener = unsafe { std::os::unix::net::UnixListener::from_raw_fd(fd) };
    Some(std_listener.set_nonblocking(true).and_then(|()| tokio::net::UnixListener::from_std(std_listener)))
}
