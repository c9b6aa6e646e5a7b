//! What the daemon needs to know about a device model: its command language,
//! how many pens it holds, its units and its speeds. A narrow view of
//! `plotcode`'s [`plotcode::DeviceProfile`], which it keeps for emitting.

use plotcode::{DeviceProfile, Protocol};

pub use plotcode::ProfileError as UnknownDevice;

/// Command language a device speaks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Language {
    /// HP-GL (HP 7475A and kin).
    Hpgl,
    /// G-code for a GRBL board.
    Gcode,
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
    /// Device units per page millimetre (HP-GL: about 40; G-code in mm: 1).
    pub units_per_mm: f64,
    /// Speeds for the plot-time estimate.
    pub motion: strokes::MotionModel,
    /// The full profile, for emitting rendered jobs.
    pub profile: DeviceProfile,
}

impl Device {
    /// The built-in profile called `name` (see `config/devices/`).
    ///
    /// # Errors
    /// [`UnknownDevice`] listing the known names.
    pub fn lookup(name: &str) -> Result<Device, UnknownDevice> {
        Ok(Device::from_profile(DeviceProfile::builtin(name)?))
    }

    /// Whether a `device` setting names a profile file rather than a built-in
    /// profile: it has a path separator or ends in `.toml`.
    #[must_use]
    pub fn names_a_file(spec: &str) -> bool {
        spec.contains('/') || spec.contains('\\') || spec.ends_with(".toml")
    }

    /// The daemon's view of `profile`.
    #[must_use]
    pub fn from_profile(profile: DeviceProfile) -> Device {
        Device {
            name: profile.name.clone(),
            language: match profile.protocol {
                Protocol::Hpgl => Language::Hpgl,
                Protocol::Gcode => Language::Gcode,
            },
            pens: profile.pens,
            units_per_mm: 1.0 / profile.unit_mm,
            motion: profile.motion_model(),
            profile,
        }
    }
}
