//! Logging to stderr through `tracing`; `RUST_LOG` overrides the default
//! level (warnings, so skipped degenerate faces are reported). Colour only
//! when stderr is a terminal: a log file or a pipe gets plain text.

use std::io::IsTerminal;
use tracing_subscriber::EnvFilter;

/// Whether log lines may carry ANSI colour codes: only on a terminal.
fn colour() -> bool {
    std::io::stderr().is_terminal()
}

/// Installs the stderr subscriber once; later calls do nothing.
pub fn init() {
    let filter = EnvFilter::try_from_default_env().unwrap_or_else(|_| EnvFilter::new("warn"));
    let _ = tracing_subscriber::fmt().with_env_filter(filter).with_writer(std::io::stderr).with_ansi(colour()).without_time().try_init();
}

/// The daemon's logging: `info` by default; to journald when run under
/// systemd (`JOURNAL_STREAM` set), else plain text on stderr.
pub fn init_daemon() {
    use tracing_subscriber::prelude::*;
    let filter = EnvFilter::try_from_default_env().unwrap_or_else(|_| EnvFilter::new("info"));
    let registry = tracing_subscriber::registry().with(filter);
    if std::env::var_os("JOURNAL_STREAM").is_some() {
        if let Ok(journald) = tracing_journald::layer() {
            let _ = registry.with(journald).try_init();
            return;
        }
    }
    let _ = registry.with(tracing_subscriber::fmt::layer().with_writer(std::io::stderr).with_ansi(colour())).try_init();
}
