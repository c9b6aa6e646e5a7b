//! The command line: `plotd SUBCOMMAND ...` (clap). Each subcommand's
//! arguments live here; the work is done by the module named after it.

use clap::{Args, Parser, Subcommand};
use std::path::PathBuf;

/// Pen-plotter driver: exact hidden-line removal, HP-GL / G-code, a spooling daemon.
#[derive(Debug, Parser)]
#[command(name = "plotd", version, about)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Render a scene to a file (dry run: no plotter needed).
    Render(RenderArgs),
    /// `serve`, `demo` and the client commands (`submit`, `jobs`, `status`, ...).
    #[command(flatten)]
    Daemon(crate::commands::DaemonCommand),
}

/// `plotd render SCENE -o OUT`.
#[derive(Debug, Args)]
pub struct RenderArgs {
    /// The scene file (TOML), or a plain drawing to re-order: SVG, HP-GL (.hpgl, .plt) or G-code (.gcode, .nc).
    pub scene: PathBuf,
    /// Output file; its extension picks the format (.svg, .hpgl, .gcode).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Device for .hpgl / .gcode: a built-in profile name (hp7475a, hp7550a,
    /// hp7585b, roland-dxy1300, hpgl2-generic, grbl-servo, grbl-z) or a path to
    /// a profile TOML. Default: hp7475a for HP-GL, grbl-servo for G-code.
    #[arg(long)]
    pub device: Option<String>,
    /// Paper of the device profile (such as A3); default: the one matching the page.
    #[arg(long)]
    pub paper: Option<String>,
    /// HP-GL: relative coordinates (PR) after the first move; smaller files.
    #[arg(long)]
    pub relative: bool,
    /// Keep the strokes as rendered (raw order, no chaining), for comparison.
    #[arg(long)]
    pub no_optimize: bool,
    /// SVG input: scale and centre the drawing on an A4 landscape page with a
    /// 10 mm margin instead of keeping its own size and position.
    #[arg(long)]
    pub fit: bool,
}

impl Cli {
    /// Sets up logging for the chosen subcommand: the daemon logs at `info`
    /// (to journald under systemd), everything else at `warn` to stderr.
    pub fn init_logging(&self) {
        match &self.command {
            Command::Daemon(crate::commands::DaemonCommand::Serve { .. }) => crate::logging::init_daemon(),
            _ => crate::logging::init(),
        }
    }

    /// Runs the chosen subcommand; returns the process exit code.
    ///
    /// # Errors
    /// Whatever the subcommand reports; `main` prints it and exits with 1.
    pub fn run(self) -> anyhow::Result<u8> {
        match self.command {
            Command::Render(args) => crate::render::run(&args).map(|()| 0),
            Command::Daemon(cmd) => crate::commands::run(cmd),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn render_arguments() {
        let cli = Cli::try_parse_from(["plotd", "render", "a.toml", "-o", "a.svg"]).unwrap();
        let Command::Render(args) = cli.command else { panic!("not render") };
        assert_eq!((args.scene, args.output), (PathBuf::from("a.toml"), PathBuf::from("a.svg")));
        assert!(Cli::try_parse_from(["plotd", "render", "a.toml"]).is_err());
        let cli = Cli::try_parse_from(["plotd", "render", "a.svg", "-o", "b.svg", "--no-optimize", "--fit"]).unwrap();
        let Command::Render(args) = cli.command else { panic!("not render") };
        assert!(args.no_optimize && args.fit);
    }
}
