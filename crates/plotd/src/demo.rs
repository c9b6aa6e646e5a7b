//! `plotd demo`: the whole path on a virtual plotter.

use clap::Args;
use std::path::PathBuf;

/// Options of `plotd demo`.
#[derive(Args, Clone, Debug)]
pub struct DemoArgs {
    /// Where to write the results (default: a new temporary directory).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// Runs the demo; returns the exit code.
///
/// # Errors
/// Anything that stops it.
pub fn run(_args: &DemoArgs) -> anyhow::Result<u8> {
    anyhow::bail!("plotd demo needs the plotsim simulator, which this build does not have yet")
}
