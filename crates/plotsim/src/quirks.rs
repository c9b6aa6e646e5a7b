//! Quirks: ways real devices differ from the reference firmware each
//! personality follows (an HP 7475A, GRBL 1.1 with its default settings),
//! switched on per simulator (`--quirks LIST`, [`crate::SimConfig::with_quirks`]).
//!
//! Each is something a device in the field does that a host must survive:
//! HP-GL clones and emulators that lack a device-control instruction or read
//! separators strictly, GRBL boards that demand homing or reset when their
//! port opens.

use crate::personality::Personality;
use std::fmt;

/// One way a device differs from the reference firmware.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Quirk {
    /// HP: no answer to `ESC.O` (extended status), and no error either: the
    /// device ignores it. (The 7475A manual's rule for a letter it does not
    /// know after `ESC.` is `ESC.E` error 11; plotsim keeps that for
    /// letters no HP-GL device has. A clone that lacks `ESC.O` or `ESC.L`
    /// says nothing to them, so a host cannot learn it from `ESC.E`.)
    NoEscO,
    /// HP: no answer to `ESC.L` (buffer size), as older firmware and some
    /// emulators; ignored like [`Quirk::NoEscO`].
    NoEscL,
    /// HP: `ESC.M` (output mode) is read and not honoured: answers keep the
    /// power-on terminator, CR.
    NoEscM,
    /// HP: where an instruction should begin, a bare `;` (an empty
    /// instruction) or a CR or LF is HP-GL error 1, instruction not
    /// recognised (`OE` answers 1, `OS` has bit 32), and does nothing else.
    /// Inside an instruction's parameters CR and LF still separate them.
    StrictSeparators,
    /// HP: `ESC.K` leaves a half-read instruction in place, its bytes still
    /// counted in the buffer, as on an emulator seen in the field: a chained
    /// `OE` left waiting for its next letter held `ESC.B` two bytes short of
    /// the size for ever, and answered once the next job's first letter came.
    AbortKeepsPartial,
    /// GRBL: homing is enabled (`$22=1`) and the machine has X and Y limit
    /// switches. The board boots, and comes back from a reset, locked in the
    /// alarm state until `$H` homes it or `$X` unlocks it without homing.
    HomingRequired,
    /// GRBL: opening the port resets the board, as an Arduino's DTR line
    /// does: the position is lost (the board's zero is where the carriage
    /// stands), buffers are dropped, input is lost while the bootloader
    /// runs, then the banner (and with `$22=1` the alarm lock).
    ResetOnOpen,
}

impl Quirk {
    /// Every quirk, in the order `--help` lists them.
    pub const ALL: [Quirk; 7] = [
        Quirk::NoEscO,
        Quirk::NoEscL,
        Quirk::NoEscM,
        Quirk::StrictSeparators,
        Quirk::AbortKeepsPartial,
        Quirk::HomingRequired,
        Quirk::ResetOnOpen,
    ];

    /// The name used on the command line.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Quirk::NoEscO => "no-esc-o",
            Quirk::NoEscL => "no-esc-l",
            Quirk::NoEscM => "no-esc-m",
            Quirk::StrictSeparators => "strict-separators",
            Quirk::AbortKeepsPartial => "abort-keeps-partial",
            Quirk::HomingRequired => "homing-required",
            Quirk::ResetOnOpen => "reset-on-open",
        }
    }

    /// The personality whose firmware has this quirk.
    #[must_use]
    pub fn personality(self) -> Personality {
        match self {
            Quirk::NoEscO | Quirk::NoEscL | Quirk::NoEscM | Quirk::StrictSeparators | Quirk::AbortKeepsPartial => Personality::Hp7475a,
            Quirk::HomingRequired | Quirk::ResetOnOpen => Personality::Grbl,
        }
    }

    /// Parses one command-line name.
    ///
    /// # Errors
    /// A message naming the word and listing the quirks there are.
    pub fn from_name(name: &str) -> Result<Quirk, String> {
        let name = name.trim();
        Quirk::ALL.into_iter().find(|q| q.name().eq_ignore_ascii_case(name)).ok_or_else(|| {
            let known: Vec<&str> = Quirk::ALL.iter().map(|q| q.name()).collect();
            format!("unknown quirk '{name}' (one of {})", known.join(", "))
        })
    }
}

impl fmt::Display for Quirk {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_name_reads_back_and_unknown_names_list_the_known_ones() {
        for q in Quirk::ALL {
            assert_eq!(Quirk::from_name(q.name()), Ok(q));
        }
        assert_eq!(Quirk::from_name(" No-Esc-O "), Ok(Quirk::NoEscO));
        let e = Quirk::from_name("no-esc-q").unwrap_err();
        assert!(e.contains("'no-esc-q'") && e.contains("strict-separators") && e.contains("reset-on-open"), "{e}");
    }
}
