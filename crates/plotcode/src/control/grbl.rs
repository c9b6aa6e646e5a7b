//! What a host sends a GRBL 1.1 board besides the job: the real-time
//! commands (one byte, acted on at once, never buffered) and the `$`
//! system commands it needs, as [`Op`]s; and the [`MARKER`] after every
//! chunk. GRBL 1.1 wiki: "Grbl v1.1 Commands", "Interfacing with Grbl".
//!
//! Answers are read by [`crate::answer::GrblAnswer`].

use super::Marker;

/// One command a host sends a GRBL board to run the line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Op {
    /// `?`: a status report (state, position), real-time.
    Status,
    /// `!`: feed hold, real-time: decelerates to a stop, keeping the
    /// position (`Hold:0` once stopped).
    FeedHold,
    /// Ctrl-X: soft reset, real-time. Drops every line the board holds;
    /// the board greets with its banner.
    SoftReset,
    /// `$X`: unlocks a board in alarm.
    Unlock,
    /// `$H`: the homing cycle (to the limit switches; the machine's zero
    /// found again), answered `ok` once it is done.
    Home,
    /// `$I`: the build info (`[VER:...]`, `[OPT:...]` with the receive
    /// buffer's size), then `ok`; every answer before it is older.
    BuildInfo,
    /// `$G`: the modal state (`[GC:...]`: feed, spindle), then `ok`.
    ModalState,
}

impl Op {
    /// The bytes on the line (a `$` command with its line end).
    #[must_use]
    pub const fn bytes(self) -> &'static [u8] {
        match self {
            Op::Status => b"?",
            Op::FeedHold => b"!",
            Op::SoftReset => &[0x18],
            Op::Unlock => b"$X\n",
            Op::Home => b"$H\n",
            Op::BuildInfo => b"$I\n",
            Op::ModalState => b"$G\n",
        }
    }

    /// Whether the board acts on it at once, ahead of the lines it holds
    /// (a real-time command), rather than as a line it answers in turn.
    #[must_use]
    pub const fn real_time(self) -> bool {
        matches!(self, Op::Status | Op::FeedHold | Op::SoftReset)
    }
}

impl std::fmt::Display for Op {
    /// The command as GRBL's documentation names it.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Op::Status => "status report (?)",
            Op::FeedHold => "feed hold (!)",
            Op::SoftReset => "soft reset (ctrl-X)",
            Op::Unlock => "$X",
            Op::Home => "$H",
            Op::BuildInfo => "$I",
            Op::ModalState => "$G",
        })
    }
}

/// Follows every chunk: a dwell of 0 s. GRBL answers `ok` to a motion line
/// once it has *planned* it, but to a dwell only once the planner has
/// drained, so this `ok` says the chunk has been drawn, not just queued.
pub const MARKER: Marker = Marker { bytes: b"G4P0\n", chained: None };

#[cfg(test)]
mod tests {
    use super::*;

    /// The bytes each command has always had on the line (GRBL 1.1).
    #[test]
    fn each_operation_is_its_command() {
        let expected: [(Op, &[u8], bool); 7] = [
            (Op::Status, b"?", true),
            (Op::FeedHold, b"!", true),
            (Op::SoftReset, &[0x18], true),
            (Op::Unlock, b"$X\n", false),
            (Op::Home, b"$H\n", false),
            (Op::BuildInfo, b"$I\n", false),
            (Op::ModalState, b"$G\n", false),
        ];
        for (op, bytes, real_time) in expected {
            assert_eq!((op.bytes(), op.real_time()), (bytes, real_time), "{op}");
        }
        assert_eq!(MARKER, Marker { bytes: b"G4P0\n", chained: None });
        assert_eq!(MARKER.chained_before(b"G1 X1"), None);
    }
}
