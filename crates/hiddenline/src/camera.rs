//! The camera: from world space to normalised device space.
//!
//! World space is right-handed. The camera sits at `eye`, looks at `target`, and
//! `up` is screen-up. View space puts the eye at the origin looking down -Z with
//! +Y up. Device space ("NDC") is what every hidden-line test works in:
//!
//! - `x`, `y`: screen position; the vertical field of view spans y in [-1, 1]
//!   (for orthographic cameras, `ortho_height` spans it), x is scaled the same.
//! - `z`: depth, strictly increasing with distance from the eye along every
//!   sight line.
//!
//! The perspective map is projective, so straight lines stay straight and planes
//! stay planes: after [`Camera::project`], occlusion can be decided as if the
//! view were orthographic, by comparing `z` along the screen direction.
//! Points closer than the near plane (or behind the eye) have no image; callers
//! clip segments and polygons against it first ([`Camera::clip_segment`]), so an
//! eye inside the scene is ordinary input.

use glam::{DMat4, DVec3};
use thiserror::Error;

/// How the camera maps depth to the picture.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// Perspective with the given vertical field of view in degrees.
    Perspective {
        /// Vertical field of view, degrees, in (0, 180).
        fov_deg: f64,
    },
    /// Parallel projection; the picture is `height` world units tall.
    Orthographic {
        /// Height of the picture in world units, > 0.
        height: f64,
    },
}

/// A validated camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Eye position, world space.
    pub eye: DVec3,
    /// Point looked at, world space.
    pub target: DVec3,
    /// Screen-up direction, world space (need not be orthogonal to the view).
    pub up: DVec3,
    /// Perspective or orthographic.
    pub projection: Projection,
    /// Distance from the eye to the near clipping plane, world units, > 0.
    pub near: f64,
    world_to_view: DMat4,
}

/// Why a camera description cannot be used.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum CameraError {
    /// A coordinate is NaN or infinite.
    #[error("camera.{field} is not a finite number")]
    NotFinite {
        /// The offending field.
        field: &'static str,
    },
    /// Eye and target coincide, so there is no view direction.
    #[error("camera.eye equals camera.target: there is no view direction")]
    EyeAtTarget,
    /// `up` is zero or parallel to the view direction.
    #[error("camera.up is parallel to the view direction (or zero)")]
    UpParallel,
    /// Field of view out of (0, 180) degrees.
    #[error("camera.fov_deg = {0} is outside (0, 180)")]
    BadFov(f64),
    /// Orthographic height not positive.
    #[error("camera.ortho_height = {0} must be > 0")]
    BadOrthoHeight(f64),
}

/// The near plane sits at this fraction of the eye-target distance: far enough
/// that depths keep about 10 significant digits in f64 across the scene, near
/// enough that nothing a user means to see is clipped.
pub const NEAR_FRACTION: f64 = 1e-4;

impl Camera {
    /// A camera looking from `eye` at `target`.
    ///
    /// # Errors
    /// Non-finite input, `eye == target`, `up` parallel to the view direction, or
    /// a field of view / orthographic height out of range.
    pub fn new(eye: DVec3, target: DVec3, up: DVec3, projection: Projection) -> Result<Camera, CameraError> {
        for (field, v) in [("eye", eye), ("target", target), ("up", up)] {
            if !v.is_finite() {
                return Err(CameraError::NotFinite { field });
            }
        }
        let dist = eye.distance(target);
        if dist == 0.0 || !(dist > 1e-12 * eye.length().max(target.length())) {
            return Err(CameraError::EyeAtTarget);
        }
        let dir = (target - eye) / dist;
        let up_n = up.try_normalize().ok_or(CameraError::UpParallel)?;
        if dir.cross(up_n).length() < 1e-9 {
            return Err(CameraError::UpParallel);
        }
        match projection {
            Projection::Perspective { fov_deg } if !(fov_deg > 0.0 && fov_deg < 180.0) => return Err(CameraError::BadFov(fov_deg)),
            Projection::Orthographic { height } if !(height > 0.0 && height.is_finite()) => {
                return Err(CameraError::BadOrthoHeight(height))
            }
            _ => {}
        }
        Ok(Camera { eye, target, up, projection, near: dist * NEAR_FRACTION, world_to_view: DMat4::look_at_rh(eye, target, up) })
    }

    /// World to view space (eye at origin, looking down -Z).
    #[must_use]
    pub fn to_view(&self, p: DVec3) -> DVec3 {
        self.world_to_view.transform_point3(p)
    }

    /// Unit view direction in world space.
    #[must_use]
    pub fn direction(&self) -> DVec3 {
        (self.target - self.eye).normalize()
    }

    /// View space to device space. The point must be in front of the near
    /// plane (`-v.z >= near`); use [`Camera::clip_segment`] first.
    #[must_use]
    pub fn view_to_device(&self, v: DVec3) -> DVec3 {
        to_device(v, self.scale(), self.near, self.is_perspective())
    }

    /// [`Camera::view_to_device`] with the projection's constants (a
    /// tangent) computed once, for mapping many points.
    pub(crate) fn view_to_device_map(&self) -> impl Fn(DVec3) -> DVec3 + Copy {
        let (scale, near, perspective) = (self.scale(), self.near, self.is_perspective());
        move |v| to_device(v, scale, near, perspective)
    }

    /// Device units per view unit: at depth 1 for perspective, everywhere
    /// for orthographic.
    fn scale(&self) -> f64 {
        match self.projection {
            Projection::Perspective { fov_deg } => 1.0 / (fov_deg.to_radians() * 0.5).tan(),
            Projection::Orthographic { height } => 2.0 / height,
        }
    }

    fn is_perspective(&self) -> bool {
        matches!(self.projection, Projection::Perspective { .. })
    }

    /// World space to device space, or `None` when the point is nearer than the
    /// near plane (or behind the eye).
    #[must_use]
    pub fn project(&self, p: DVec3) -> Option<DVec3> {
        let v = self.to_view(p);
        (-v.z >= self.near).then(|| self.view_to_device(v))
    }

    /// [`Camera::project`] with its per-camera constants (the field of view's
    /// tangent) computed once, for callers projecting many points.
    #[must_use]
    pub fn projector(&self) -> Projector {
        Projector { world_to_view: self.world_to_view, near: self.near, scale: self.scale(), perspective: self.is_perspective() }
    }

    /// The part of segment `a`-`b` (world space) in front of the near plane, as
    /// parameters `(t0, t1)` with `0 <= t0 < t1 <= 1` along `a + t (b - a)`;
    /// `None` when none of it is (or only a single point).
    #[must_use]
    pub fn clip_segment(&self, a: DVec3, b: DVec3) -> Option<(f64, f64)> {
        let da = -self.to_view(a).z - self.near;
        let db = -self.to_view(b).z - self.near;
        match (da >= 0.0, db >= 0.0) {
            (true, true) => Some((0.0, 1.0)),
            (false, false) => None,
            (true, false) => {
                let t = da / (da - db);
                (t > 0.0).then_some((0.0, t))
            }
            (false, true) => {
                let t = da / (da - db);
                (t < 1.0).then_some((t, 1.0))
            }
        }
    }

    /// Signed distance of a world point in front of the near plane (negative
    /// behind it). Polygon clipping against the near plane uses this.
    #[must_use]
    pub fn near_distance(&self, p: DVec3) -> f64 {
        -self.to_view(p).z - self.near
    }
}

/// View space to device space (see the module notes).
fn to_device(v: DVec3, scale: f64, near: f64, perspective: bool) -> DVec3 {
    let d = -v.z;
    if perspective {
        // Depth 1 - near/d is affine in 1/d, so the whole map is projective
        // (planes stay planes); it runs from 0 at the near plane towards 1
        // at infinity.
        DVec3::new(scale * v.x / d, scale * v.y / d, 1.0 - near / d)
    } else {
        DVec3::new(scale * v.x, scale * v.y, d)
    }
}

/// A camera's projection with its constants precomputed ([`Camera::projector`]);
/// gives exactly what [`Camera::project`] gives.
#[derive(Clone, Copy, Debug)]
pub struct Projector {
    world_to_view: DMat4,
    near: f64,
    scale: f64,
    perspective: bool,
}

impl Projector {
    /// World space to device space, or `None` when the point is nearer than
    /// the near plane (or behind the eye); as [`Camera::project`].
    #[must_use]
    pub fn project(&self, p: DVec3) -> Option<DVec3> {
        let v = self.world_to_view.transform_point3(p);
        (-v.z >= self.near).then(|| to_device(v, self.scale, self.near, self.perspective))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn persp() -> Camera {
        Camera::new(DVec3::new(0.0, -10.0, 0.0), DVec3::ZERO, DVec3::Z, Projection::Perspective { fov_deg: 90.0 }).unwrap()
    }

    #[test]
    fn target_projects_to_centre_and_up_is_up() {
        let c = persp();
        let t = c.project(DVec3::ZERO).unwrap();
        assert!(t.x.abs() < 1e-12 && t.y.abs() < 1e-12);
        let up = c.project(DVec3::new(0.0, 0.0, 1.0)).unwrap();
        assert!(up.y > 0.0 && up.x.abs() < 1e-12);
        // World +x is screen right when looking along +y with z up.
        let right = c.project(DVec3::new(1.0, 0.0, 0.0)).unwrap();
        assert!(right.x > 0.0);
        // 90 degree fov: a point at 45 degrees up lands on the frame edge.
        let edge = c.project(DVec3::new(0.0, 0.0, 10.0)).unwrap();
        assert!((edge.y - 1.0).abs() < 1e-12);
    }

    #[test]
    fn depth_increases_with_distance() {
        let c = persp();
        let z1 = c.project(DVec3::new(0.3, -5.0, 0.2)).unwrap().z;
        let z2 = c.project(DVec3::new(0.3, 0.0, 0.2)).unwrap().z;
        let z3 = c.project(DVec3::new(0.3, 50.0, 0.2)).unwrap().z;
        assert!(z1 < z2 && z2 < z3 && z3 < 1.0);
    }

    #[test]
    fn projection_keeps_lines_straight() {
        let c = persp();
        let a = DVec3::new(-3.0, -2.0, 1.0);
        let b = DVec3::new(4.0, 7.0, -2.0);
        let (pa, pb) = (c.project(a).unwrap(), c.project(b).unwrap());
        for i in 1..10 {
            let p = c.project(a.lerp(b, i as f64 / 10.0)).unwrap();
            // p lies on the device-space line pa-pb (3-D collinearity).
            let cross = (p - pa).cross(pb - pa).length();
            assert!(cross < 1e-9, "{cross}");
        }
    }

    #[test]
    fn near_clipping() {
        let c = persp();
        // Behind the eye entirely.
        assert_eq!(c.clip_segment(DVec3::new(0.0, -20.0, 0.0), DVec3::new(1.0, -11.0, 0.0)), None);
        // Crossing the eye plane: keeps the front part.
        let (t0, t1) = c.clip_segment(DVec3::new(0.0, -20.0, 0.0), DVec3::new(0.0, 0.0, 0.0)).unwrap();
        assert!((t0 - (0.5 + NEAR_FRACTION * 0.5)).abs() < 1e-9 && t1 == 1.0);
        assert!(c.project(DVec3::new(0.0, -10.0, 0.0)).is_none());
    }

    #[test]
    fn bad_cameras_are_errors() {
        let p = Projection::Perspective { fov_deg: 30.0 };
        assert_eq!(Camera::new(DVec3::ONE, DVec3::ONE, DVec3::Z, p), Err(CameraError::EyeAtTarget));
        assert_eq!(Camera::new(DVec3::Z, DVec3::ZERO, DVec3::Z, p), Err(CameraError::UpParallel));
        assert_eq!(Camera::new(DVec3::X, DVec3::ZERO, DVec3::ZERO, p), Err(CameraError::UpParallel));
        assert!(matches!(
            Camera::new(DVec3::new(f64::NAN, 0.0, 0.0), DVec3::ZERO, DVec3::Z, p),
            Err(CameraError::NotFinite { field: "eye" })
        ));
        let bad = Projection::Perspective { fov_deg: 180.0 };
        assert_eq!(Camera::new(DVec3::X, DVec3::ZERO, DVec3::Z, bad), Err(CameraError::BadFov(180.0)));
        let bad = Projection::Orthographic { height: 0.0 };
        assert_eq!(Camera::new(DVec3::X, DVec3::ZERO, DVec3::Z, bad), Err(CameraError::BadOrthoHeight(0.0)));
    }

    #[test]
    fn projector_matches_project() {
        let o = Camera::new(DVec3::new(1.0, -10.0, 3.0), DVec3::ZERO, DVec3::Z, Projection::Orthographic { height: 4.0 }).unwrap();
        for c in [persp(), o] {
            let pr = c.projector();
            for p in [DVec3::new(0.3, -5.0, 0.2), DVec3::new(-3.0, 40.0, 7.0), DVec3::new(0.0, -10.0, 0.0), DVec3::new(0.0, -30.0, 1.0)] {
                assert_eq!(pr.project(p), c.project(p), "{p}");
            }
        }
        assert!(persp().projector().project(DVec3::new(0.0, -10.0, 0.0)).is_none());
    }

    #[test]
    fn orthographic_depth_is_distance() {
        let c = Camera::new(DVec3::new(0.0, -10.0, 0.0), DVec3::ZERO, DVec3::Z, Projection::Orthographic { height: 4.0 }).unwrap();
        let p = c.project(DVec3::new(2.0, 0.0, 2.0)).unwrap();
        assert!((p - DVec3::new(1.0, 1.0, 10.0)).length() < 1e-12);
    }
}
