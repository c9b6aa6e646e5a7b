//! Ridgelines by the horizon method (Greenspun and Little, seed 001).
//!
//! Profiles lie in vertical planes `y = const`, each with an opaque curtain
//! hanging from it down to a common baseline. Curtains are processed front to
//! back; each profile is tested against the horizon of the curtains before
//! it, then its curtain (one trapezoid per profile segment) is merged in. The
//! horizon is the grid engine's ([`super::horizon`]), in device space along
//! the rays from the pole, with its exact crossings and its collapse of
//! collinear fragments.
//!
//! One upper horizon is enough when the eye is not below the baseline: on the
//! ray of any later point, every earlier curtain's image starts below that
//! point (a point farther away and not below the baseline is seen higher than
//! the baseline nearer to the eye), so the point is hidden exactly when it is
//! under the highest earlier profile there, whatever the gaps between the
//! earlier curtains. From below the baseline those gaps matter (a point can be
//! seen between one curtain's lower edge and another's top), and a lower
//! horizon alone does not describe them: [`visibility`] answers `None` and the
//! caller uses the general engine.

use super::sweep::{pole_of, Sweep};
use super::{clipped_ends, near_clipped};
use crate::camera::{Camera, Projection};
use crate::model::{LineSource, LineVisibility};
use glam::{DVec2, DVec3};

/// Whether the upper horizon alone decides visibility for curtains down to
/// `base` (see the module documentation).
#[must_use]
pub fn upper_horizon_suffices(camera: &Camera, base: f64) -> bool {
    match camera.projection {
        Projection::Perspective { .. } => camera.eye.z >= base,
        Projection::Orthographic { .. } => camera.direction().z <= 0.0,
    }
}

/// The visibility of every profile segment, numbered as
/// [`crate::scene::Ridgeline::lower`] adds them (profile by profile, segment
/// by segment; segments wholly behind the near plane left out), or `None`
/// when the eye is below the baseline and the general engine must decide.
///
/// `profiles[k]` must lie in one plane `y = const` with strictly increasing
/// x, and `base` below every point.
#[must_use]
pub fn visibility(profiles: &[Vec<DVec3>], base: f64, camera: &Camera, pen: u32) -> Option<Vec<LineVisibility>> {
    if !upper_horizon_suffices(camera, base) {
        return None;
    }
    let mut first = Vec::with_capacity(profiles.len());
    let mut count = 0usize;
    for p in profiles {
        first.push(count);
        count += p.len().saturating_sub(1);
    }
    let mut out: Vec<Option<LineVisibility>> = vec![None; count];
    let line = |e: usize, a: DVec2, b: DVec2, visible: Vec<(f64, f64)>| LineVisibility {
        source: LineSource::Edge(e as u32),
        pen,
        a,
        b,
        visible,
    };
    let Some(pole) = pole_of(camera) else {
        // Straight down or up: every curtain is seen edge-on.
        for (k, p) in profiles.iter().enumerate() {
            for (i, w) in p.windows(2).enumerate() {
                if let Some((a, b)) = clipped_ends(camera, w[0], w[1]) {
                    out[first[k] + i] = Some(line(first[k] + i, a, b, vec![(0.0, 1.0)]));
                }
            }
        }
        return Some(out.into_iter().flatten().collect());
    };
    let mut sweep = Sweep::new(pole);
    let mut vis = Vec::new();
    let mut poly = Vec::with_capacity(8);
    for k in front_to_back(profiles, camera) {
        let p = &profiles[k];
        // A profile lies in its own curtain's plane, which cannot hide it:
        // test all of it before merging the curtain.
        for (i, w) in p.windows(2).enumerate() {
            let Some((a, b)) = clipped_ends(camera, w[0], w[1]) else { continue };
            vis.clear();
            sweep.visible_keyed(a, b, None, &mut vis);
            out[first[k] + i] = Some(line(first[k] + i, a, b, vis.clone()));
        }
        for w in p.windows(2) {
            let quad = [w[0], w[1], DVec3::new(w[1].x, w[1].y, base), DVec3::new(w[0].x, w[0].y, base)];
            if near_clipped(camera, &quad, &mut poly) {
                sweep.add_polygon(&poly);
            }
        }
    }
    Some(out.into_iter().flatten().collect())
}

/// Profile indices in an occlusion-compatible order: a curtain can only hide
/// curtains on its own side of the eye and farther from it.
fn front_to_back(profiles: &[Vec<DVec3>], camera: &Camera) -> Vec<usize> {
    let y = |k: usize| profiles[k].first().map_or(0.0, |p| p.y);
    let mut order: Vec<usize> = (0..profiles.len()).collect();
    match camera.projection {
        Projection::Perspective { .. } => order.sort_by(|&a, &b| (y(a) - camera.eye.y).abs().total_cmp(&(y(b) - camera.eye.y).abs())),
        Projection::Orthographic { .. } => {
            let dy = camera.direction().y;
            order.sort_by(|&a, &b| (y(a) * dy).total_cmp(&(y(b) * dy)));
        }
    }
    order
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cam(eye: [f64; 3]) -> Camera {
        Camera::new(DVec3::from(eye), DVec3::new(2.0, 2.0, 0.0), DVec3::Z, Projection::Perspective { fov_deg: 40.0 }).unwrap()
    }

    #[test]
    fn a_tall_front_profile_hides_a_low_one_behind_it() {
        let front: Vec<DVec3> = (0..5).map(|i| DVec3::new(i as f64, 0.0, 2.0)).collect();
        let back: Vec<DVec3> = (0..5).map(|i| DVec3::new(i as f64, 1.0, 0.5)).collect();
        let c = cam([2.0, -6.0, 1.5]);
        let v = visibility(&[front, back], -0.1, &c, 1).unwrap();
        assert_eq!(v.len(), 8);
        // The front profile is all visible, the back one all hidden.
        assert!(v[..4].iter().all(|l| l.visible == vec![(0.0, 1.0)]), "{v:?}");
        assert!(v[4..].iter().all(|l| l.visible.is_empty()), "{v:?}");
    }

    #[test]
    fn from_below_the_baseline_is_left_to_the_general_engine() {
        let p: Vec<DVec3> = (0..3).map(|i| DVec3::new(i as f64, 0.0, 1.0)).collect();
        assert!(visibility(&[p.clone()], 0.0, &cam([1.0, -5.0, -1.0]), 1).is_none());
        assert!(visibility(&[p], 0.0, &cam([1.0, -5.0, 0.0]), 1).is_some(), "eye on the baseline");
    }
}
