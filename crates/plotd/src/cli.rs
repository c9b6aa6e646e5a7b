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
}

/// `plotd render SCENE -o OUT`.
#[derive(Debug, Args)]
pub struct RenderArgs {
    /// The scene file (TOML).
    pub scene: PathBuf,
    /// Output file; its extension picks the format (.svg).
    #[arg(short, long)]
    pub output: PathBuf,
}

impl Cli {
    /// Runs the chosen subcommand.
    ///
    /// # Errors
    /// Whatever the subcommand reports; `main` prints it and exits with 1.
    pub fn run(self) -> anyhow::Result<()> {
        match self.command {
            Command::Render(args) => crate::render::run(&args),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn render_arguments() {
        let cli = Cli::try_parse_from(["plotd", "render", "a.toml", "-o", "a.svg"]).unwrap();
        let Command::Render(args) = cli.command;
        assert_eq!((args.scene, args.output), (PathBuf::from("a.toml"), PathBuf::from("a.svg")));
        assert!(Cli::try_parse_from(["plotd", "render", "a.toml"]).is_err());
    }
}
