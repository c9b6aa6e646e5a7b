//! The device side of a connection: writes bytes, reads the device's answers
//! as lines ([`plotcode::answer::AnswerLines`]: XON/XOFF taken out, each line
//! with its terminator), and turns silence into a timeout.
//!
//! Generic over any async byte stream; the daemon and the tests run it on a
//! [`super::port::SerialPort`] (the tests on plotsim's pty). The handshakes'
//! decisions are not here: they are state machines that do no I/O.

use super::StreamError;
use plotcode::answer::{AnswerLine, AnswerLines};
use tokio::io::{AsyncRead, AsyncReadExt, AsyncWrite, AsyncWriteExt};
use tokio::time::Instant;

/// A device connection.
#[derive(Debug)]
pub struct Link<T> {
    io: T,
    /// Device output not yet taken as lines.
    answers: AnswerLines,
    /// Total bytes written.
    pub written: u64,
}

impl<T: AsyncRead + AsyncWrite + Unpin> Link<T> {
    /// Wraps an open byte stream.
    pub fn new(io: T) -> Self {
        Link { io, answers: AnswerLines::default(), written: 0 }
    }

    /// Whether the device has asked us to stop sending (XOFF).
    #[must_use]
    pub fn xoff(&self) -> bool {
        self.answers.xoff()
    }

    /// Writes all of `bytes`.
    ///
    /// # Errors
    /// [`StreamError::Offline`] when the port is gone.
    pub async fn write(&mut self, bytes: &[u8]) -> Result<(), StreamError> {
        self.io.write_all(bytes).await.map_err(StreamError::Offline)?;
        self.written += bytes.len() as u64;
        Ok(())
    }

    /// Writes a query or control the device does not buffer
    /// ([`plotcode::control`]): not counted in [`Link::written`].
    ///
    /// # Errors
    /// [`StreamError::Offline`].
    pub async fn write_query(&mut self, bytes: &[u8]) -> Result<(), StreamError> {
        self.io.write_all(bytes).await.map_err(StreamError::Offline)
    }

    /// Reads whatever the device sends next, waiting at most until `deadline`.
    /// Returns `false` on timeout.
    ///
    /// # Errors
    /// [`StreamError::Offline`] on EOF or a read error.
    pub async fn fill(&mut self, deadline: Instant) -> Result<bool, StreamError> {
        let mut tmp = [0u8; 512];
        let n = match tokio::time::timeout_at(deadline, self.io.read(&mut tmp)).await {
            Err(_) => return Ok(false),
            Ok(r) => r.map_err(StreamError::Offline)?,
        };
        if n == 0 {
            return Err(StreamError::Offline(std::io::Error::from(std::io::ErrorKind::UnexpectedEof)));
        }
        self.answers.feed(&tmp[..n]);
        Ok(true)
    }

    /// Empty answers the device sent so far (a terminator alone).
    #[must_use]
    pub fn empty_answers(&self) -> usize {
        self.answers.empty_answers()
    }

    /// The next whole answer line; empty lines are skipped.
    pub fn take_line(&mut self) -> Option<AnswerLine> {
        self.answers.next_line()
    }
}
