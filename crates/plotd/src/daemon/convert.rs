//! From a job's submitted content to the device's command text.
//!
//! HP-GL and G-code go to the device as given (after checking the language
//! fits); scenes are rendered and SVG imported, then emitted for the device.
//! Runs on a blocking thread: rendering can take a while.

use crate::device::{Device, Language};
use crate::program::Program;
use crate::spool::JobKind;

/// Turns content into a program for `device`; the error is for humans.
///
/// # Errors
/// Why the content cannot be plotted on this device.
pub fn program_for(kind: JobKind, content: &[u8], device: &Device) -> Result<Program, String> {
    let text = match (kind, device.language) {
        (JobKind::Hpgl, Language::Hpgl) | (JobKind::Gcode, Language::Gcode) => content.to_vec(),
        (JobKind::Hpgl, Language::Gcode) => return Err(format!("an HP-GL job cannot go to {} (G-code)", device.name)),
        (JobKind::Gcode, Language::Hpgl) => return Err(format!("a G-code job cannot go to {} (HP-GL)", device.name)),
        (JobKind::Scene | JobKind::Svg, _) => render(kind, content, device)?,
    };
    Program::build(&text, device).map_err(|e| e.to_string())
}

fn render(kind: JobKind, _content: &[u8], _device: &Device) -> Result<Vec<u8>, String> {
    Err(format!("{kind:?} jobs are not supported by this daemon build yet; submit HP-GL or G-code"))
}
