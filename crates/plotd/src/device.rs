//! What the daemon needs to know about a device model: its command language,
//! how many pens it holds, its units and its speeds.
//!
//! The full profiles (and the emitters) live in `plotcode`; this is the
//! daemon's narrow view of one.

use hiddenline::MotionModel;
use thiserror::Error;

/// Command language a device speaks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Language {
    /// HP-GL (HP 7475A and kin).
    Hpgl,
    /// G-code for a GRBL board.
    Gcode,
}

/// The device profile name is not known.
#[derive(Debug, Error)]
#[error("unknown device profile {name:?} (known: {known})")]
pub struct UnknownDevice {
    /// The name asked for.
    pub name: String,
    /// The names that exist.
    pub known: String,
}

/// The daemon's view of a device model.
#[derive(Clone, Debug, PartialEq)]
pub struct Device {
    /// Profile name.
    pub name: String,
    /// Command language.
    pub language: Language,
    /// Pens the device holds and selects itself; 1 means a human changes pens.
    pub pens: u32,
    /// Device units per page millimetre (HP-GL: 40; G-code in mm: 1).
    pub units_per_mm: f64,
    /// Speeds for the plot-time estimate.
    pub motion: MotionModel,
}

impl Device {
    /// The profile called `name`.
    ///
    /// # Errors
    /// [`UnknownDevice`] listing the known names.
    pub fn lookup(name: &str) -> Result<Device, UnknownDevice> {
        let known = ["hp7475a", "hp7550a", "hpgl", "grbl"];
        let d = |language, pens, units_per_mm, motion| Device {
            name: name.to_owned(),
            language,
            pens,
            units_per_mm,
            motion,
        };
        match name {
            "hp7475a" | "hpgl" => Ok(d(Language::Hpgl, 6, 40.0, MotionModel::default())),
            "hp7550a" => Ok(d(Language::Hpgl, 8, 40.0, MotionModel::default())),
            "grbl" => Ok(d(
                Language::Gcode,
                1,
                1.0,
                MotionModel {
                    pen_down_speed: 50.0,
                    pen_up_speed: 100.0,
                    pen_lift_time: 0.2,
                    pen_drop_time: 0.2,
                    acceleration: Some(500.0),
                },
            )),
            _ => Err(UnknownDevice { name: name.to_owned(), known: known.join(", ") }),
        }
    }
}
