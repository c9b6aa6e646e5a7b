//! A plotter's pen table: one `[[plotter.pen]]` per pen it holds, with what
//! the person loading it knows (`name`, `colour`, `width` in mm) and what
//! the device draws it with where it can (`speed` in mm/s: HP-GL `VS`,
//! G-code feed; `force`: HP-GL `FS`). The device's part goes to the
//! emitters as plain data ([`plotcode::PenSettings`]).

use plotcode::{DeviceProfile, PenSetting, PenSettings};
use serde::Deserialize;

/// Highest pen force an HP-GL `FS` takes (the 7550A's eight steps).
pub const MAX_FORCE: u32 = 8;

/// One `[[plotter.pen]]`.
#[derive(Clone, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PenEntry {
    /// The pen's number (its carousel slot; a one-pen plotter's pens are
    /// the ones a person puts in).
    pub number: u32,
    /// What it is, for people (`"fine black"`).
    #[serde(default)]
    pub name: Option<String>,
    /// Its ink, as SVG names a colour (`"#1f4e79"`, `"red"`).
    #[serde(default)]
    pub colour: Option<String>,
    /// Its line width, mm.
    #[serde(default)]
    pub width: Option<f64>,
    /// Its drawing speed, mm/s.
    #[serde(default)]
    pub speed: Option<f64>,
    /// Its pressure (HP-GL `FS`, 1 to [`MAX_FORCE`]).
    #[serde(default)]
    pub force: Option<u32>,
}

/// Checks a plotter's pen table against its device: numbers the device
/// holds, each once; widths and speeds positive; a force only on HP-GL.
///
/// # Errors
/// The entry's index and key, and what is wrong.
pub fn check(pens: &[PenEntry], device: &DeviceProfile) -> Result<(), (usize, &'static str, String)> {
    for (i, p) in pens.iter().enumerate() {
        if p.number == 0 || (device.pens > 1 && p.number > device.pens) {
            return Err((i, "number", format!("{}: the {} has pens 1 to {}", p.number, device.name, device.pens)));
        }
        if pens[..i].iter().any(|q| q.number == p.number) {
            return Err((i, "number", format!("pen {} is listed twice", p.number)));
        }
        for (key, v) in [("width", p.width), ("speed", p.speed)] {
            if v.is_some_and(|v| !(v.is_finite() && v > 0.0)) {
                return Err((i, key, format!("{} is not a positive number", v.unwrap_or_default())));
            }
        }
        match p.force {
            Some(f) if device.protocol != plotcode::Protocol::Hpgl => {
                return Err((i, "force", format!("{f}: the {} sets no pen force (HP-GL FS only)", device.name)));
            }
            Some(f) if !(1..=MAX_FORCE).contains(&f) => return Err((i, "force", format!("{f} is not 1 to {MAX_FORCE}"))),
            _ => {}
        }
    }
    Ok(())
}

/// How each pen looks in an SVG dry run: its colour and width.
#[must_use]
pub fn looks(pens: &[PenEntry]) -> plotcode::svg::PenLooks {
    pens.iter().map(|p| (p.number, plotcode::svg::PenLook { colour: p.colour.clone(), width_mm: p.width })).collect()
}

/// What the device draws each pen with.
#[must_use]
pub fn settings(pens: &[PenEntry]) -> PenSettings {
    pens.iter()
        .filter(|p| p.speed.is_some() || p.force.is_some())
        .map(|p| (p.number, PenSetting { speed_mm_s: p.speed, force: p.force }))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pen(number: u32) -> PenEntry {
        PenEntry { number, ..PenEntry::default() }
    }

    #[test]
    fn a_table_is_checked_against_its_device() {
        let hp = DeviceProfile::builtin("hp7475a").unwrap();
        let grbl = DeviceProfile::builtin("grbl-servo").unwrap();
        assert!(check(&[pen(1), PenEntry { speed: Some(15.0), force: Some(3), ..pen(6) }], &hp).is_ok());
        assert_eq!(check(&[pen(7)], &hp).unwrap_err().2, "7: the hp7475a has pens 1 to 6");
        assert_eq!(check(&[pen(2), pen(2)], &hp).unwrap_err(), (1, "number", "pen 2 is listed twice".into()));
        assert_eq!(check(&[PenEntry { width: Some(0.0), ..pen(1) }], &hp).unwrap_err().1, "width");
        assert_eq!(check(&[PenEntry { force: Some(9), ..pen(1) }], &hp).unwrap_err().1, "force");
        // A one-pen plotter's pens are the ones a person puts in; it has no force.
        assert!(check(&[pen(9)], &grbl).is_ok());
        assert!(check(&[PenEntry { force: Some(2), ..pen(1) }], &grbl).unwrap_err().2.contains("sets no pen force"));
    }

    #[test]
    fn only_what_the_device_draws_with_goes_to_the_emitter() {
        let table = [PenEntry { colour: Some("red".into()), ..pen(1) }, PenEntry { speed: Some(15.0), ..pen(2) }];
        assert_eq!(settings(&table), PenSettings::from([(2, PenSetting { speed_mm_s: Some(15.0), force: None })]));
    }
}
