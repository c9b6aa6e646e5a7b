//! The command line: `plotd SUBCOMMAND ...` (clap). [`Cli`] and [`Command`]
//! list the subcommands; each subcommand's arguments live in the module that
//! does its work ([`crate::render::RenderArgs`], [`crate::commands::DaemonCommand`]),
//! so no module reaches back up into this one.

use crate::render::RenderArgs;
use clap::{CommandFactory, Parser, Subcommand};

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
    /// Print the shell completion script (bash: save it as
    /// /usr/share/bash-completion/completions/plotd).
    Completions {
        /// The shell.
        #[arg(value_enum)]
        shell: clap_complete::Shell,
    },
    /// Print the man page plotd(1), in roff (save it as /usr/share/man/man1/plotd.1).
    Man,
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

    /// Runs the chosen subcommand; returns the process exit code (0 when
    /// stdout's reader went away: `plotd watch | head -1`).
    ///
    /// # Errors
    /// Whatever the subcommand reports; `main` prints it and exits with 1.
    pub fn run(self) -> anyhow::Result<u8> {
        crate::console::finish(match self.command {
            Command::Render(args) => crate::render::run(&args).map(|()| 0),
            Command::Daemon(cmd) => crate::commands::run(cmd),
            Command::Completions { shell } => Ok(crate::shell_docs::completions(Cli::command(), shell).map(|()| 0)?),
            Command::Man => Ok(crate::shell_docs::man_page(&Cli::command()).map(|()| 0)?),
        })
    }

    /// [`Cli::run`] for the `plotd` binary: `render` with a budget
    /// (`--time-limit`, `--memory-limit`) runs this binary again under it,
    /// so a scene that would never end, or eat the machine, stops with an
    /// error ([`crate::render::run_as_binary`]).
    ///
    /// # Errors
    /// As [`Cli::run`], and a render past its budget.
    pub fn run_as_binary(self) -> anyhow::Result<u8> {
        match &self.command {
            Command::Render(args) => crate::console::finish(crate::render::run_as_binary(args)),
            _ => self.run(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

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

    #[test]
    fn pause_and_cancel_take_now() {
        use crate::commands::DaemonCommand;
        let cli = Cli::try_parse_from(["plotd", "pause", "--now"]).unwrap();
        assert!(matches!(cli.command, Command::Daemon(DaemonCommand::Pause { id: None, now: true, .. })));
        let cli = Cli::try_parse_from(["plotd", "pause", "4"]).unwrap();
        assert!(matches!(cli.command, Command::Daemon(DaemonCommand::Pause { id: Some(4), now: false, .. })));
        let cli = Cli::try_parse_from(["plotd", "cancel", "7", "--now"]).unwrap();
        assert!(matches!(cli.command, Command::Daemon(DaemonCommand::Cancel { id: 7, now: true, .. })));
    }
}
