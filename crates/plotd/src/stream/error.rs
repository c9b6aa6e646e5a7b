//! Why streaming stopped short ([`StreamError`]).

use thiserror::Error;

/// Why streaming stopped short.
#[derive(Debug, Error)]
pub enum StreamError {
    /// The port is gone (EIO, EOF, unplugged adapter).
    #[error("the port failed: {0}")]
    Offline(std::io::Error),
    /// The device did not answer in time.
    #[error("no answer to {0}")]
    Timeout(String),
    /// The device reported an error.
    #[error("device error: {0}")]
    Device(String),
    /// The device answered with something that is not an answer.
    #[error("device sends garbage: {0:?}")]
    Garbled(String),
    /// The device was power-cycled or reset: its buffer and state are lost.
    #[error("power cycle: {0}")]
    Reset(String),
    /// The device stopped answering lines it was sent while the link works
    /// (a GRBL board `Idle` with lines unanswered): resync and resume from
    /// the confirmed chunk.
    #[error("device stalled with {unanswered} lines unanswered")]
    Stalled {
        /// Lines written and never answered.
        unanswered: usize,
    },
}

impl StreamError {
    /// Whether the link should be dropped and reopened (as opposed to a device
    /// error with the link still fine).
    #[must_use]
    pub fn link_lost(&self) -> bool {
        matches!(self, StreamError::Offline(_) | StreamError::Timeout(_) | StreamError::Garbled(_) | StreamError::Reset(_))
    }
}
