//! The device side of a connection: writes bytes, reads the device's answers
//! as lines, tracks XON/XOFF, and turns silence into a timeout.
//!
//! Generic over any async byte stream; the daemon and the tests run it on a
//! [`super::port::SerialPort`] (the tests on plotsim's pty). The handshakes'
//! decisions are not here: they are state machines that do no I/O.

use super::StreamError;
use std::time::Duration;
use tokio::io::{AsyncRead, AsyncReadExt, AsyncWrite, AsyncWriteExt};
use tokio::time::Instant;

/// XON (DC1): the device may receive again.
pub const XON: u8 = 0x11;
/// XOFF (DC3): the device's buffer is nearly full.
pub const XOFF: u8 = 0x13;
/// Longest answer line kept; a device sending more without a terminator is
/// sending garbage, and the excess is dropped.
pub const MAX_ANSWER_BYTES: usize = 256;

/// A device connection.
#[derive(Debug)]
pub struct Link<T> {
    io: T,
    /// Device output not yet taken as lines (XON/XOFF removed).
    inbuf: Vec<u8>,
    /// Whether the device last said XOFF.
    xoff: bool,
    /// Total bytes written.
    pub written: u64,
    /// HP-GL session: we told the device to end answers with LF; an answer
    /// ending in CR means it lost that setting, i.e. it was power-cycled.
    pub expect_lf: bool,
    /// Set when an answer came back with the power-on terminator.
    pub reset_seen: bool,
}

impl<T: AsyncRead + AsyncWrite + Unpin> Link<T> {
    /// Wraps an open byte stream.
    pub fn new(io: T) -> Self {
        Link { io, inbuf: Vec::new(), xoff: false, written: 0, expect_lf: false, reset_seen: false }
    }

    /// Whether the device has asked us to stop sending (XOFF).
    #[must_use]
    pub fn xoff(&self) -> bool {
        self.xoff
    }

    /// Writes all of `bytes`.
    ///
    /// # Errors
    /// [`StreamError::Offline`] when the port is gone.
    pub async fn write(&mut self, bytes: &[u8]) -> Result<(), StreamError> {
        self.io.write_all(bytes).await.map_err(StreamError::offline)?;
        self.written += bytes.len() as u64;
        Ok(())
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
            Ok(r) => r.map_err(StreamError::offline)?,
        };
        if n == 0 {
            return Err(StreamError::offline(std::io::Error::from(std::io::ErrorKind::UnexpectedEof)));
        }
        for &b in &tmp[..n] {
            match b {
                XON => self.xoff = false,
                XOFF => self.xoff = true,
                _ => self.inbuf.push(b),
            }
        }
        if self.inbuf.len() > 4 * MAX_ANSWER_BYTES && !self.inbuf.iter().any(|&b| b == b'\r' || b == b'\n') {
            self.inbuf.clear();
        }
        Ok(true)
    }

    /// Reads without waiting: takes in whatever is already there.
    ///
    /// # Errors
    /// [`StreamError::Offline`].
    pub async fn poll_input(&mut self) -> Result<(), StreamError> {
        self.fill(Instant::now() + Duration::from_millis(0)).await.map(|_| ())
    }

    /// The next whole answer line (terminated by CR or LF), without its terminator;
    /// empty lines are skipped.
    pub fn take_line(&mut self) -> Option<String> {
        loop {
            let end = self.inbuf.iter().position(|&b| b == b'\r' || b == b'\n')?;
            let line: Vec<u8> = self.inbuf.drain(..=end).collect();
            if self.expect_lf && line[end] == b'\r' {
                self.reset_seen = true;
            }
            let line = &line[..end];
            if line.is_empty() {
                continue;
            }
            let line = &line[line.len().saturating_sub(MAX_ANSWER_BYTES)..];
            return Some(String::from_utf8_lossy(line).trim().to_owned());
        }
    }

    /// Waits for the next answer line until `deadline`.
    ///
    /// # Errors
    /// [`StreamError::Timeout`] naming `what`, or [`StreamError::Offline`].
    pub async fn line_until(&mut self, deadline: Instant, what: &str) -> Result<String, StreamError> {
        loop {
            if let Some(l) = self.take_line() {
                return Ok(l);
            }
            if !self.fill(deadline).await? {
                return Err(StreamError::Timeout(what.to_owned()));
            }
        }
    }
}

impl<T: AsyncRead + AsyncWrite + Unpin> Link<T> {
    /// Writes a query the device answers at once and does not buffer (ESC.B,
    /// GRBL `?`, `$I`): not counted in [`Link::written`].
    ///
    /// # Errors
    /// [`StreamError::Offline`].
    pub async fn write_query(&mut self, bytes: &[u8]) -> Result<(), StreamError> {
        self.io.write_all(bytes).await.map_err(StreamError::offline)
    }
}
