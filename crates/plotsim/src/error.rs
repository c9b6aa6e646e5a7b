//! Errors of the simulator library.

use std::path::PathBuf;
use std::time::Duration;

/// What went wrong starting, driving or saving a simulator.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// A configuration field is out of range.
    #[error("bad simulator configuration: {field}: {why}")]
    Config {
        /// The `SimConfig` field.
        field: &'static str,
        /// What is wrong with it.
        why: String,
    },
    /// Opening or configuring the pseudo-terminal failed.
    #[error("pseudo-terminal: {what}: {source}")]
    Pty {
        /// The step that failed.
        what: &'static str,
        /// The system error.
        source: nix::Error,
    },
    /// Creating or replacing the `--link` symlink failed.
    #[error("link {path}: {source}")]
    Link {
        /// The link path.
        path: PathBuf,
        /// The system error.
        source: std::io::Error,
    },
    /// Writing a record, SVG or PNG file failed.
    #[error("writing {path}: {source}")]
    Write {
        /// The output path.
        path: PathBuf,
        /// The system error.
        source: std::io::Error,
    },
    /// Rendering the PNG failed.
    #[error("rendering PNG {path}: {why}")]
    Png {
        /// The output path.
        path: PathBuf,
        /// What failed.
        why: String,
    },
    /// A wait on the device's state did not succeed in time.
    #[error("timed out after {0:?} waiting for the simulated plotter")]
    Timeout(Duration),
    /// The fault does not exist for this personality.
    #[error("{0}")]
    Unsupported(String),
    /// The simulator thread has stopped.
    #[error("the simulator has shut down")]
    ShutDown,
}
