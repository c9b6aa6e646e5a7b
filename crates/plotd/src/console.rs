//! Standard output for the commands that print results (`jobs`, `status`,
//! `watch`, `submit`'s job id, `completions`, `man`): written through
//! [`print`], so that a reader that went away (`plotd watch | head -1`) is an
//! error value, not a panic, and [`finish`] turns it into a quiet exit 0, as
//! `cat` and `grep` do.

use std::fmt::Display;
use std::io::{ErrorKind, Write};
use thiserror::Error;

/// Standard output could not be written.
#[derive(Debug, Error)]
#[error("writing to standard output: {0}")]
pub struct StdoutError(#[source] pub std::io::Error);

/// Writes `text` and a newline to stdout (line-buffered: a line goes out
/// at once, for `watch` piped into another program).
///
/// # Errors
/// [`StdoutError`] when stdout is closed or full.
pub fn print(text: impl Display) -> Result<(), StdoutError> {
    writeln!(std::io::stdout(), "{text}").map_err(StdoutError)
}

/// Writes bytes to stdout as they are (a generated script or man page).
///
/// # Errors
/// [`StdoutError`].
pub fn print_bytes(bytes: &[u8]) -> Result<(), StdoutError> {
    let mut out = std::io::stdout().lock();
    out.write_all(bytes).and_then(|()| out.flush()).map_err(StdoutError)
}

/// Maps a command's result to its exit code: stdout closed by its reader
/// (EPIPE) means the reader has all it wanted, so the command succeeded.
///
/// # Errors
/// Every other error, unchanged.
pub fn finish(result: anyhow::Result<u8>) -> anyhow::Result<u8> {
    match result {
        Err(e) if e.chain().any(|c| c.downcast_ref::<StdoutError>().is_some_and(|s| s.0.kind() == ErrorKind::BrokenPipe)) => Ok(0),
        other => other,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_a_closed_stdout_is_success() {
        let err = |kind| std::io::Error::from(kind);
        let closed = anyhow::Error::new(StdoutError(err(ErrorKind::BrokenPipe))).context("printing an event");
        assert_eq!(finish(Err(closed)).unwrap(), 0);
        assert_eq!(finish(Ok(4)).unwrap(), 4);
        assert!(finish(Err(StdoutError(err(ErrorKind::StorageFull)).into())).is_err());
        // A broken connection to the daemon is a failure, whatever its errno.
        assert!(finish(Err(crate::client::ClientError::Io(err(ErrorKind::BrokenPipe)).into())).is_err());
    }
}
