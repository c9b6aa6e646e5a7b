//! `plotsim`: a virtual pen plotter on a pseudo-terminal. See `plotsim --help`.

use clap::Parser;
use tokio::signal::unix::{signal, SignalKind};
use tracing_subscriber::prelude::*;

#[tokio::main]
async fn main() -> anyhow::Result<()> {
    let args = plotsim::cli::Args::parse();
    // `RUST_LOG`: `level` and `target=level` directives (tracing's
    // Targets); errors only without it.
    let filter = std::env::var("RUST_LOG")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| tracing_subscriber::filter::Targets::new().with_default(tracing::Level::ERROR));
    tracing_subscriber::registry().with(filter).with(tracing_subscriber::fmt::layer()).init();
    let mut term = signal(SignalKind::terminate())?;
    let mut int = signal(SignalKind::interrupt())?;
    let shutdown = async move {
        tokio::select! {
            _ = term.recv() => {}
            _ = int.recv() => {}
        }
    };
    plotsim::cli::run(args, shutdown).await?;
    Ok(())
}
