//! Streaming a job's chunks to a device with flow control, and confirming
//! which chunks the device has executed.
//!
//! - `port.rs`: the serial port (transport);
//! - `link.rs`: bytes out, answer lines in, with deadlines;
//! - `plan.rs`: what a run streams ([`Span`]) and its bytes;
//! - `machine.rs`: what every exchange with the device is, as a state
//!   machine that does no I/O; the handshakes `hpgl.rs` and `grbl.rs`,
//!   with the checkpoint rule: a chunk is confirmed only when the device
//!   says it has got past it; the exchanges around runs: `ping.rs`,
//!   `grbl_setup.rs` (`$I` sync, `$X` unlock), `hpgl_locate.rs` and
//!   `grbl_locate.rs` (where the pen rests after an interruption), and
//!   `locate.rs` (which chunk that place says to resume from);
//! - `streamer.rs`: the one loop that feeds a machine from the link;
//!   `settings.rs`: its tuning and measurements.

mod grbl;
mod grbl_locate;
mod grbl_setup;
mod hpgl;
mod hpgl_locate;
pub mod link;
mod locate;
mod machine;
mod ping;
mod plan;
pub mod port;
mod settings;
pub mod streamer;

pub use link::Link;
pub use plan::Span;
pub use port::SerialPort;
pub use settings::{StreamSettings, StreamStats};
pub use streamer::{Outcome, RunObserver, Streamer};

/// What a run is asked to do about stopping; the latest request counts
/// when it asks for more (a stop now outranks one at the stroke's end).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord)]
pub enum Stop {
    /// Go on.
    #[default]
    Continue,
    /// Stop at the end of the chunk being written; everything written is
    /// drawn and confirmed.
    AfterStroke,
    /// Stop the pen where it is (`pause --now`, `cancel --now`): HP-GL
    /// drops the device's buffer (ESC.K), GRBL holds (`!`) and resets; the
    /// pen is lifted. Chunks not confirmed are drawn again on resume, at
    /// most the interrupted one in part.
    Now,
}

impl Stop {
    /// A person's stop: [`Stop::Now`] when `now`, else [`Stop::AfterStroke`].
    #[must_use]
    pub fn asked(now: bool) -> Stop {
        if now {
            Stop::Now
        } else {
            Stop::AfterStroke
        }
    }
}

/// How far a job has been handed to the device: recorded before and after
/// every write, so that after an interruption the daemon knows which bytes
/// the device may hold (see [`Streamer::locate`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Written {
    /// Chunks `..k` written in full (with their markers), nothing after them.
    Through(usize),
    /// Chunks `..k` written in full, and chunk `k` perhaps in part: a write
    /// into it was about to start, or ended inside it.
    Into(usize),
}

impl Written {
    /// The first chunk that was not surely executed, if the device ran
    /// everything written: the one resumed from.
    #[must_use]
    pub fn resume_at(self) -> usize {
        match self {
            Written::Through(k) | Written::Into(k) => k,
        }
    }

    /// How many chunks the device may have received, in full or in part.
    #[must_use]
    pub fn reached(self) -> usize {
        match self {
            Written::Through(k) => k,
            Written::Into(k) => k + 1,
        }
    }
}

use thiserror::Error;

/// Why a device holds its work and waits for a person.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Hold {
    /// HP-GL ESC.O bit 5: the paper lever is raised.
    PaperLever,
}

impl std::fmt::Display for Hold {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Hold::PaperLever => "paper lever raised",
        })
    }
}

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
