//! Logging to stderr through `tracing`; `RUST_LOG` overrides the default
//! level (warnings, so skipped degenerate faces are reported). Colour only
//! when stderr is a terminal: a log file or a pipe gets plain text.
//!
//! `RUST_LOG` is a list of `level` and `target=level` directives
//! (`plotd=debug,warn`): tracing's `Targets` filter, which needs no regular
//! expressions (the span and field filters of its `EnvFilter` went unused).

use std::io::IsTerminal;
use tracing_subscriber::filter::Targets;

/// The filter `RUST_LOG` asks for, or `default` when it is unset or not
/// a list of directives.
fn filter(default: tracing::Level) -> Targets {
    std::env::var("RUST_LOG").ok().and_then(|v| v.parse().ok()).unwrap_or_else(|| Targets::new().with_default(default))
}

/// Whether log lines may carry ANSI colour codes: only on a terminal.
fn colour() -> bool {
    std::io::stderr().is_terminal()
}

/// Installs the stderr subscriber once; later calls do nothing.
pub fn init() {
    use tracing_subscriber::prelude::*;
    let layer = tracing_subscriber::fmt::layer().with_writer(std::io::stderr).with_ansi(colour()).without_time();
    let _ = tracing_subscriber::registry().with(filter(tracing::Level::WARN)).with(layer).try_init();
}

/// The daemon's logging: `info` by default; to journald when run under
/// systemd (`JOURNAL_STREAM` set), else plain text on stderr.
pub fn init_daemon() {
    use tracing_subscriber::prelude::*;
    let registry = tracing_subscriber::registry().with(filter(tracing::Level::INFO));
    if std::env::var_os("JOURNAL_STREAM").is_some() {
        if let Ok(journald) = tracing_journald::layer() {
            let _ = registry.with(journald).try_init();
            return;
        }
    }
    let _ = registry.with(tracing_subscriber::fmt::layer().with_writer(std::io::stderr).with_ansi(colour())).try_init();
}
