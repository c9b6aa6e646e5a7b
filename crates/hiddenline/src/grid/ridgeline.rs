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
use crate::model::{Intervals, LineSource, LineVisibility};
use glam::{DVec2, DVec3};

/// One ridgeline as the horizon method sees it: its profiles, the height of
/// its curtains' lower edge, its pen.
#[derive(Clone, Copy, Debug)]
pub struct Curtains<'a> {
    /// Profiles, each in one plane `y = const` with strictly increasing x.
    pub profiles: &'a [Vec<DVec3>],
    /// Height of the curtains' lower edge, below every point of `profiles`.
    pub base: f64,
    /// Pen of the profiles.
    pub pen: u32,
}

/// Whether the upper horizon alone decides visibility for `sets` (see the
/// module documentation): the eye is not below the highest baseline, and no
/// profile point is below it either. Then no sight line to a profile point
/// passes under any curtain in front of it, whichever ridgeline that
/// curtain belongs to.
#[must_use]
pub fn upper_horizon_suffices(camera: &Camera, sets: &[Curtains<'_>]) -> bool {
    let top = sets.iter().map(|s| s.base).fold(f64::NEG_INFINITY, f64::max);
    let lowest = sets.iter().flat_map(|s| s.profiles.iter().flatten()).map(|p| p.z).fold(f64::INFINITY, f64::min);
    let eye = match camera.projection {
        Projection::Perspective { .. } => camera.eye.z >= top,
        Projection::Orthographic { .. } => camera.direction().z <= 0.0,
    };
    eye && lowest >= top
}

/// The visibility of every profile segment of every set, numbered as
/// `scene::Ridgeline::lower` adds them, set after set (profile by
/// profile, segment by segment; segments wholly behind the near plane left
/// out), or `None` when the upper horizon does not suffice
/// ([`upper_horizon_suffices`]) and the general engine must decide.
#[must_use]
pub fn visibility(sets: &[Curtains<'_>], camera: &Camera) -> Option<Vec<LineVisibility>> {
    if !upper_horizon_suffices(camera, sets) {
        return None;
    }
    // Every profile of every set, with its set and its first edge number.
    let mut all: Vec<(&[DVec3], f64, u32, usize)> = Vec::new();
    let mut count = 0usize;
    for s in sets {
        for p in s.profiles {
            all.push((p, s.base, s.pen, count));
            count += p.len().saturating_sub(1);
        }
    }
    let mut out: Vec<Option<LineVisibility>> = vec![None; count];
    let line = |e: usize, pen: u32, a: DVec2, b: DVec2, visible: &[(f64, f64)]| LineVisibility {
        source: LineSource::Edge(e as u32),
        pen,
        a,
        b,
        visible: Intervals::from_slice(visible),
    };
    let Some(pole) = pole_of(camera) else {
        // Straight down or up: every curtain is seen edge-on.
        for &(p, _, pen, first) in &all {
            for (i, w) in p.windows(2).enumerate() {
                if let Some((a, b)) = clipped_ends(camera, w[0], w[1]) {
                    out[first + i] = Some(line(first + i, pen, a, b, &[(0.0, 1.0)]));
                }
            }
        }
        return Some(out.into_iter().flatten().collect());
    };
    let mut sweep = Sweep::new(pole);
    let mut vis = Vec::new();
    let mut poly = Vec::with_capacity(8);
    let order = front_to_back(&all, camera);
    for group in order.chunk_by(|a, b| a.0 == b.0) {
        // A profile lies in its own curtain's plane, which cannot hide it, nor
        // can another curtain in that plane (coplanar faces never hide each
        // other) or one as far from the eye on the other side: test every
        // profile of the group before merging their curtains.
        for &(_, k) in group {
            let (p, _, pen, first) = all[k];
            for (i, w) in p.windows(2).enumerate() {
                let Some((a, b)) = clipped_ends(camera, w[0], w[1]) else { continue };
                vis.clear();
                sweep.visible_keyed(a, b, None, &mut vis);
                out[first + i] = Some(line(first + i, pen, a, b, &vis));
            }
        }
        for &(_, k) in group {
            let (p, base, _, _) = all[k];
            for w in p.windows(2) {
                let quad = [w[0], w[1], DVec3::new(w[1].x, w[1].y, base), DVec3::new(w[0].x, w[0].y, base)];
                if near_clipped(camera, &quad, &mut poly) {
                    sweep.add_polygon(&poly);
                }
            }
        }
    }
    Some(out.into_iter().flatten().collect())
}

/// Profile indices in an occlusion-compatible order, each with its sort key:
/// a curtain can only hide curtains on its own side of the eye and farther
/// from it. Profiles with equal keys cannot hide one another.
fn front_to_back(all: &[(&[DVec3], f64, u32, usize)], camera: &Camera) -> Vec<(f64, usize)> {
    let y = |k: usize| all[k].0.first().map_or(0.0, |p| p.y);
    let mut order: Vec<(f64, usize)> = match camera.projection {
        Projection::Perspective { .. } => (0..all.len()).map(|k| ((y(k) - camera.eye.y).abs(), k)).collect(),
        Projection::Orthographic { .. } => {
            let dy = camera.direction().y;
            (0..all.len()).map(|k| (y(k) * dy, k)).collect()
        }
    };
    order.sort_by(|a, b| a.0.total_cmp(&b.0));
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
        let profiles = [front, back];
        let v = visibility(&[Curtains { profiles: &profiles, base: -0.1, pen: 1 }], &c).unwrap();
        assert_eq!(v.len(), 8);
        // The front profile is all visible, the back one all hidden.
        assert!(v[..4].iter().all(|l| l.visible[..] == [(0.0, 1.0)]), "{v:?}");
        assert!(v[4..].iter().all(|l| l.visible.is_empty()), "{v:?}");
    }

    #[test]
    fn from_below_the_baseline_is_left_to_the_general_engine() {
        let p: Vec<DVec3> = (0..3).map(|i| DVec3::new(i as f64, 0.0, 1.0)).collect();
        let set = [Curtains { profiles: std::slice::from_ref(&p), base: 0.0, pen: 1 }];
        assert!(visibility(&set, &cam([1.0, -5.0, -1.0])).is_none());
        assert!(visibility(&set, &cam([1.0, -5.0, 0.0])).is_some(), "eye on the baseline");
    }
}
