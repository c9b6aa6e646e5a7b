//! G-code for GRBL pen plotters: [`parse_line`] (one line, as GRBL reads it),
//! [`parse`] (a whole program into strokes), [`emit`], and [`cut`] (a
//! submitted file into chunks).

mod cut;
mod emit;
mod interp;
mod line;
mod state;

pub use cut::cut;
pub use emit::emit;
pub use interp::{parse, GcodeError, ParseOptions, ARC_TOLERANCE_MM};
pub use line::{parse_line, Block, Line, LineError, Word, MAX_LINE_CHARS};

use crate::profile::DeviceProfile;

impl ParseOptions {
    /// How to read G-code written for `profile`.
    #[must_use]
    pub fn for_profile(profile: &DeviceProfile) -> ParseOptions {
        ParseOptions {
            z_down_at_or_below: profile.gcode.as_ref().and_then(|g| g.z_down_at_or_below).unwrap_or(0.0),
            unit_mm: profile.unit_mm,
        }
    }
}
