//! Placing an object in the world: uniform scale, then rotations about the x,
//! y and z axes (in that order, degrees, right-handed), then translation.

use glam::{DMat4, DVec3};
use serde::Deserialize;

/// The `transform = { ... }` key of an object, as written in the scene file.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Transform {
    /// Moves the object by this vector, applied last.
    #[serde(default)]
    pub translate: [f64; 3],
    /// Rotations about the world x, y and z axes, degrees, applied in that order.
    #[serde(default)]
    pub rotate_deg: [f64; 3],
    /// Uniform scale factor, > 0, applied first.
    #[serde(default = "one")]
    pub scale: f64,
}

fn one() -> f64 {
    1.0
}

impl Default for Transform {
    fn default() -> Self {
        Transform { translate: [0.0; 3], rotate_deg: [0.0; 3], scale: 1.0 }
    }
}

impl Transform {
    /// The affine matrix, world from object.
    #[must_use]
    pub fn matrix(&self) -> DMat4 {
        let [rx, ry, rz] = self.rotate_deg.map(f64::to_radians);
        DMat4::from_translation(DVec3::from(self.translate))
            * DMat4::from_rotation_z(rz)
            * DMat4::from_rotation_y(ry)
            * DMat4::from_rotation_x(rx)
            * DMat4::from_scale(DVec3::splat(self.scale))
    }

    /// Checks the numbers: all finite, scale > 0. Returns the offending
    /// sub-field and a message.
    pub(crate) fn check(&self) -> Result<(), (&'static str, String)> {
        for (name, v) in [("translate", self.translate), ("rotate_deg", self.rotate_deg)] {
            if v.iter().any(|x| !x.is_finite()) {
                return Err((name, format!("{v:?} is not finite")));
            }
        }
        if !(self.scale > 0.0 && self.scale.is_finite()) {
            return Err(("scale", format!("scale = {} must be a finite number > 0", self.scale)));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identity_by_default() {
        assert_eq!(Transform::default().matrix(), DMat4::IDENTITY);
    }

    #[test]
    fn scale_then_rotate_then_translate() {
        let t = Transform { translate: [10.0, 0.0, 0.0], rotate_deg: [0.0, 0.0, 90.0], scale: 2.0 };
        let p = t.matrix().transform_point3(DVec3::X);
        // x scaled to 2, turned onto +y, moved by +10 in x.
        assert!((p - DVec3::new(10.0, 2.0, 0.0)).length() < 1e-12, "{p}");
        // x rotation comes before z rotation.
        let t = Transform { rotate_deg: [90.0, 0.0, 90.0], ..Transform::default() };
        let p = t.matrix().transform_point3(DVec3::Y);
        // y -> z under x-rotation; z stays z under z-rotation.
        assert!((p - DVec3::Z).length() < 1e-12, "{p}");
    }

    #[test]
    fn bad_numbers_are_rejected() {
        assert!(Transform { scale: 0.0, ..Transform::default() }.check().is_err());
        assert!(Transform { scale: -1.0, ..Transform::default() }.check().is_err());
        assert!(Transform { translate: [f64::NAN, 0.0, 0.0], ..Transform::default() }.check().is_err());
        assert!(Transform::default().check().is_ok());
    }
}
