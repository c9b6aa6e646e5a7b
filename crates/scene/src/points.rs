//! Reading coordinate lists from the scene file into world space.

use crate::error::SceneErrorKind;
use crate::tolerance::MAX_POLYGON_VERTICES;
use glam::{DMat4, DVec3};

/// An error in a sub-field of an object (`outer[2]`), before the object's own
/// name and line are known.
pub type FieldError = (String, SceneErrorKind);

/// Checks and transforms the points of field `field`: finite, at least `min`
/// of them, at most [`MAX_POLYGON_VERTICES`].
pub(crate) fn world_points(field: &str, pts: &[[f64; 3]], m: &DMat4, min: usize) -> Result<Vec<DVec3>, FieldError> {
    if pts.len() < min {
        return Err((field.into(), SceneErrorKind::TooFewPoints { need: min, got: pts.len() }));
    }
    if pts.len() > MAX_POLYGON_VERTICES {
        return Err((field.into(), SceneErrorKind::TooMany { what: "points", count: pts.len(), limit: MAX_POLYGON_VERTICES }));
    }
    pts.iter()
        .enumerate()
        .map(|(i, p)| match p.iter().find(|c| !c.is_finite()) {
            Some(&bad) => Err((format!("{field}[{i}]"), SceneErrorKind::NotFinite(bad))),
            None => {
                let w = m.transform_point3(DVec3::from(*p));
                match crate::tolerance::beyond_limit(w) {
                    Some(far) => Err((format!("{field}[{i}]"), SceneErrorKind::TooFar(far))),
                    None => Ok(w),
                }
            }
        })
        .collect()
}
