//! A plotter's pen table as the emitters take it: for each pen number what
//! it draws differently from the profile's defaults. Plain data: the daemon
//! reads it from its config (`[[plotter.pen]]`) and hands it over here;
//! which instruction carries each setting is the emitter's (HP-GL `VS` and
//! `FS` after the pen's `SP`, G-code the feed of the pen's strokes).

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// What one pen draws with, where it differs from the profile's defaults.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PenSetting {
    /// Drawing speed, mm/s (HP-GL `VS` in cm/s; G-code feed in mm/min).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub speed_mm_s: Option<f64>,
    /// Pen force (HP-GL `FS`, 1 to 8 on the devices that have it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub force: Option<u32>,
}

/// Pen number -> its setting; a pen not listed draws with the defaults.
pub type PenSettings = BTreeMap<u32, PenSetting>;

/// Whether any pen in `pens` sets what `f` reads: the emitter then sets it
/// at every pen change, a pen without its own going back to the default.
pub(crate) fn any_sets<T>(pens: &PenSettings, f: impl Fn(&PenSetting) -> Option<T>) -> bool {
    pens.values().any(|p| f(p).is_some())
}
