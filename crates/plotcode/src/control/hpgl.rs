//! What a host sends an HP-GL plotter on RS-232 besides the job: the
//! device-control instructions (`ESC .` and a letter, taken as they arrive,
//! ahead of the buffer) and the output instructions (`OE`, `OI`, `OA`,
//! answered once the buffer has run up to them), as [`Op`]s; and the
//! [`MARKER`] after every chunk. HP 7475A Interfacing and Programming
//! Manual: device-control instructions in the RS-232-C chapter.
//!
//! Answers are read by [`crate::answer`]: [`crate::answer::HpglNumber`],
//! [`crate::answer::HpglPosition`], [`crate::answer::is_identification`].

use super::Marker;

/// One instruction a host sends an HP-GL plotter to run the line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Op {
    /// `ESC.B`: the free space in the buffer, answered at once.
    FreeSpace,
    /// `ESC.L`: the buffer's size (free space when empty), answered at
    /// once; older firmware does not answer it.
    BufferSize,
    /// `ESC.O`: the extended status, answered at once
    /// ([`crate::answer::ExtendedStatus`]: buffer empty, paper lever up).
    ExtendedStatus,
    /// `ESC.E`: the last device-control or I/O error (0: none), answered at once.
    ExtendedError,
    /// `ESC.K`: abort graphics. Drops every instruction in the buffer; the
    /// one running finishes. A stop now.
    Abort,
    /// `ESC.J`: abort device control. Drops a device-control instruction
    /// left half read.
    AbortDeviceControl,
    /// `ESC.M;;;10:`: answers end with LF from now on (the power-on
    /// terminator is CR, so a CR again tells a power cycle).
    AnswersEndWithLf,
    /// `ESC.I128;;17:` and `ESC.N;19:`: XON/XOFF on. The plotter sends
    /// XOFF (DC3) when fewer than 128 bytes are free, XON (DC1) when there
    /// is room again.
    XonXoff,
    /// `;`: ends an instruction the plotter is still reading (an `OE` that
    /// waits for its next letter). Only ever right after one: where an
    /// instruction should begin, a strict device reads a bare `;` as error 1;
    /// there the next instruction's letter ends it.
    EndInstruction,
    /// `OE;`: the last instruction error (0: none, else 1 to 7), answered
    /// once everything before it has run.
    LastError,
    /// `OI;`: the identification (the model, `7475A`), answered once
    /// everything before it has run: every answer before it is older.
    Identify,
    /// `OA;`: where the pen is and whether it is down (`x,y,pen`),
    /// answered once everything before it has run.
    Position,
}

impl Op {
    /// The bytes on the line.
    #[must_use]
    pub const fn bytes(self) -> &'static [u8] {
        match self {
            Op::FreeSpace => b"\x1b.B",
            Op::BufferSize => b"\x1b.L",
            Op::ExtendedStatus => b"\x1b.O",
            Op::ExtendedError => b"\x1b.E",
            Op::Abort => b"\x1b.K",
            Op::AbortDeviceControl => b"\x1b.J",
            Op::AnswersEndWithLf => b"\x1b.M;;;10:",
            Op::XonXoff => b"\x1b.I128;;17:\x1b.N;19:",
            Op::EndInstruction => b";",
            Op::LastError => b"OE;",
            Op::Identify => b"OI;",
            Op::Position => b"OA;",
        }
    }
}

impl std::fmt::Display for Op {
    /// The instruction as the manual names it (`ESC.B`, `OE`).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Op::FreeSpace => "ESC.B",
            Op::BufferSize => "ESC.L",
            Op::ExtendedStatus => "ESC.O",
            Op::ExtendedError => "ESC.E",
            Op::Abort => "ESC.K",
            Op::AbortDeviceControl => "ESC.J",
            Op::AnswersEndWithLf => "ESC.M",
            Op::XonXoff => "ESC.I and ESC.N",
            Op::EndInstruction => "`;`",
            Op::LastError => "OE",
            Op::Identify => "OI",
            Op::Position => "OA",
        })
    }
}

/// The bytes of `ops`, one after the other.
#[must_use]
pub fn sequence(ops: &[Op]) -> Vec<u8> {
    ops.iter().flat_map(|op| op.bytes()).copied().collect()
}

/// Follows every chunk: `OE;`, whose answer (0) says the chunk has run.
/// Before a chunk that starts with a mnemonic, `OE` alone: its letter ends
/// the instruction, a byte saved per stroke.
pub const MARKER: Marker = Marker { bytes: b"OE;", chained: Some(b"OE") };

#[cfg(test)]
mod tests {
    use super::*;

    /// The bytes each operation has always had on the line (HP 7475A
    /// Interfacing and Programming Manual).
    #[test]
    fn each_operation_is_its_instruction() {
        let expected: [(Op, &[u8]); 12] = [
            (Op::FreeSpace, &[0x1b, b'.', b'B']),
            (Op::BufferSize, &[0x1b, b'.', b'L']),
            (Op::ExtendedStatus, &[0x1b, b'.', b'O']),
            (Op::ExtendedError, &[0x1b, b'.', b'E']),
            (Op::Abort, &[0x1b, b'.', b'K']),
            (Op::AbortDeviceControl, &[0x1b, b'.', b'J']),
            (Op::AnswersEndWithLf, b"\x1b.M;;;10:"),
            (Op::XonXoff, b"\x1b.I128;;17:\x1b.N;19:"),
            (Op::EndInstruction, b";"),
            (Op::LastError, b"OE;"),
            (Op::Identify, b"OI;"),
            (Op::Position, b"OA;"),
        ];
        for (op, bytes) in expected {
            assert_eq!(op.bytes(), bytes, "{op}");
        }
        assert_eq!(sequence(&[Op::EndInstruction, Op::Identify]), b";OI;");
    }

    #[test]
    fn the_marker_chains_only_before_a_mnemonic() {
        assert_eq!(MARKER.chained_before(b"PU10,10;"), Some(b"OE".as_slice()));
        assert_eq!(MARKER.chained_before(b";PU;"), None);
        assert_eq!(MARKER.chained_before(b""), None);
        assert!(MARKER.bytes.starts_with(MARKER.chained.unwrap()));
    }
}
