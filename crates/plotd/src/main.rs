//! `plotd`: parse the command line, set up logging, run, map errors to exit code 1.
use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    let cli = plotd::cli::Cli::parse();
    cli.init_logging();
    match cli.run_as_binary() {
        Ok(code) => ExitCode::from(code),
        Err(e) => {
            // Errors quote names and input: shown escaped and cut short.
            eprintln!("plotd: error: {}", plotd::text::message(&format!("{e:#}")));
            ExitCode::from(1)
        }
    }
}
