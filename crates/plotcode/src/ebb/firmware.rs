//! The EBB firmware version, and what each version can do.
//!
//! The board says its version in answer to `V`
//! (`EBBv13_and_above EB Firmware Version 2.8.1`); a profile names the
//! version its commands are written for (`firmware = "2.8.1"`). The
//! command choices that depend on it are methods here, each with the release
//! that brought it (EggBot `docs/EBBReleaseNotes.html`).

use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;

/// A firmware version, `major.minor.patch` (in a profile, the string
/// `"2.8.1"`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Deserialize, Serialize)]
#[serde(try_from = "String", into = "String")]
pub struct Firmware {
    /// Major version (2 or 3 on boards in use).
    pub major: u16,
    /// Minor version.
    pub minor: u16,
    /// Patch version.
    pub patch: u16,
}

/// The oldest firmware plotd drives: `HM` (the way back to a chunk's start
/// on resume) and `QG` (the status a daemon polls) arrived in 2.6.2.
pub const OLDEST_FIRMWARE: Firmware = Firmware::new(2, 6, 2);

impl Firmware {
    /// `major.minor.patch`.
    #[must_use]
    pub const fn new(major: u16, minor: u16, patch: u16) -> Firmware {
        Firmware { major, minor, patch }
    }

    /// The version in a `V` answer: its last word, as in
    /// `EBBv13_and_above EB Firmware Version 2.8.1` (the future syntax's
    /// `V,` prefix taken off first). `None` when the last word is not a
    /// version.
    #[must_use]
    pub fn from_version_answer(line: &str) -> Option<Firmware> {
        let line = line.trim();
        let line = line.strip_prefix("V,").unwrap_or(line);
        line.split_whitespace().last()?.parse().ok()
    }

    /// The rewritten `LM` (firmware 2.7.0): its per-tick arithmetic is the
    /// one [`super::lm`] computes, it takes the accumulator-clearing fifth
    /// argument, and `HM` takes an absolute position. Older boards are sent
    /// `SM` time slices.
    #[must_use]
    pub fn low_level_moves(self) -> bool {
        self >= Firmware::new(2, 7, 0)
    }

    /// `SP,3` lifts the pen at once, past the motion FIFO (3.0.1).
    #[must_use]
    pub fn lifts_pen_at_once(self) -> bool {
        self >= Firmware::new(3, 0, 1)
    }

    /// A motion FIFO deeper than one command (`CU,4`), the future reply
    /// syntax (`CU,10`), the power-lost flag in `QG` bit 6 and the
    /// one-number `ES` answer (3.0.0).
    #[must_use]
    pub fn is_3x(self) -> bool {
        self.major >= 3
    }
}

impl fmt::Display for Firmware {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}.{}.{}", self.major, self.minor, self.patch)
    }
}

/// A version that is not `major.minor.patch`.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{0:?} is not a firmware version such as \"2.8.1\"")]
pub struct BadVersion(pub String);

impl FromStr for Firmware {
    type Err = BadVersion;

    fn from_str(s: &str) -> Result<Firmware, BadVersion> {
        let bad = || BadVersion(s.chars().take(40).collect());
        let mut parts = s.trim().split('.').map(|p| p.parse::<u16>().map_err(|_| bad()));
        let (Some(major), Some(minor), Some(patch), None) = (parts.next(), parts.next(), parts.next(), parts.next()) else {
            return Err(bad());
        };
        Ok(Firmware::new(major?, minor?, patch?))
    }
}

impl TryFrom<String> for Firmware {
    type Error = BadVersion;
    fn try_from(s: String) -> Result<Firmware, BadVersion> {
        s.parse()
    }
}

impl From<Firmware> for String {
    fn from(f: Firmware) -> String {
        f.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn versions_from_v_answers_and_profiles() {
        assert_eq!(Firmware::from_version_answer("EBBv13_and_above EB Firmware Version 2.8.1"), Some(Firmware::new(2, 8, 1)));
        assert_eq!(Firmware::from_version_answer("V,EBBv13_and_above EB Firmware Version 3.0.2\n"), Some(Firmware::new(3, 0, 2)));
        assert_eq!(Firmware::from_version_answer("OK"), None);
        assert_eq!(Firmware::from_version_answer(""), None);
        assert_eq!("2.7.0".parse::<Firmware>(), Ok(Firmware::new(2, 7, 0)));
        for bad in ["2.7", "2.7.0.1", "two", "2.x.0", "-1.0.0"] {
            assert!(bad.parse::<Firmware>().is_err(), "{bad}");
        }
    }

    #[test]
    fn command_choices_by_version() {
        let v = |s: &str| s.parse::<Firmware>().unwrap();
        assert!(!v("2.6.5").low_level_moves() && v("2.7.0").low_level_moves() && v("3.0.2").low_level_moves());
        assert!(!v("3.0.0").lifts_pen_at_once() && v("3.0.1").lifts_pen_at_once());
        assert!(!v("2.8.1").is_3x() && v("3.0.0").is_3x());
        assert!(v("2.10.0") > v("2.9.9"), "numbers, not text");
    }
}
