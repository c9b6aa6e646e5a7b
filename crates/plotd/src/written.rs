//! How far a job has been handed to the device ([`Written`]): what the
//! streamer reports around every write, and what the spool keeps so that
//! after an interruption the daemon knows which bytes the device may hold.

/// How far a job has been handed to the device: recorded before and after
/// every write, so that after an interruption the daemon knows which bytes
/// the device may hold (see [`crate::stream::Streamer::locate`]).
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
