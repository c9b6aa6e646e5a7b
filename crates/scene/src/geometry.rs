//! Small polygon measures shared by the object kinds: the Newell normal, size,
//! planarity and degeneracy, with the tolerances of [`crate::tolerance`].

use crate::tolerance::{DEGENERATE_AREA_REL, PLANARITY_REL};
use glam::DVec3;

/// How a closed ring of points sits in space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RingFit {
    /// Newell normal: its direction is the ring's plane normal (counter-clockwise
    /// winding seen from its tip), its length twice the enclosed (projected) area.
    pub newell: DVec3,
    /// Diagonal of the axis-aligned bounding box.
    pub size: f64,
    /// Largest distance of a vertex from the plane through the centroid with
    /// the Newell normal; 0 for a degenerate ring.
    pub deviation: f64,
}

impl RingFit {
    /// Measures the ring `points` (implicitly closed).
    #[must_use]
    pub fn of(points: &[DVec3]) -> RingFit {
        let n = points.len();
        if n == 0 {
            return RingFit { newell: DVec3::ZERO, size: 0.0, deviation: 0.0 };
        }
        let mut newell = DVec3::ZERO;
        let (mut lo, mut hi) = (points[0], points[0]);
        let mut centroid = DVec3::ZERO;
        for i in 0..n {
            let (p, q) = (points[i], points[(i + 1) % n]);
            newell += DVec3::new((p.y - q.y) * (p.z + q.z), (p.z - q.z) * (p.x + q.x), (p.x - q.x) * (p.y + q.y));
            lo = lo.min(p);
            hi = hi.max(p);
            centroid += p;
        }
        centroid /= n as f64;
        let deviation = match newell.try_normalize() {
            Some(u) => points.iter().map(|p| (*p - centroid).dot(u).abs()).fold(0.0, f64::max),
            None => 0.0,
        };
        RingFit { newell, size: lo.distance(hi), deviation }
    }

    /// The unit normal, if the ring encloses any area.
    #[must_use]
    pub fn normal(&self) -> Option<DVec3> {
        (!self.is_degenerate()).then(|| self.newell.normalize())
    }

    /// True when the ring encloses no area worth the name.
    #[must_use]
    pub fn is_degenerate(&self) -> bool {
        let area = 0.5 * self.newell.length();
        !(area > DEGENERATE_AREA_REL * self.size * self.size) || !area.is_finite()
    }

    /// The distance a vertex may lie off the plane and the ring still count as planar.
    #[must_use]
    pub fn planarity_tolerance(&self) -> f64 {
        PLANARITY_REL * self.size
    }

    /// True when every vertex lies within tolerance of the plane.
    #[must_use]
    pub fn is_planar(&self) -> bool {
        self.deviation <= self.planarity_tolerance()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(x: f64, y: f64, z: f64) -> DVec3 {
        DVec3::new(x, y, z)
    }

    #[test]
    fn unit_square() {
        let f = RingFit::of(&[v(0., 0., 0.), v(1., 0., 0.), v(1., 1., 0.), v(0., 1., 0.)]);
        assert_eq!(f.newell, v(0., 0., 2.));
        assert!(f.is_planar() && !f.is_degenerate());
        assert_eq!(f.normal(), Some(DVec3::Z));
        // Clockwise: normal flips.
        let f = RingFit::of(&[v(0., 0., 0.), v(0., 1., 0.), v(1., 1., 0.), v(1., 0., 0.)]);
        assert_eq!(f.normal(), Some(-DVec3::Z));
    }

    #[test]
    fn degenerate_rings() {
        assert!(RingFit::of(&[]).is_degenerate());
        assert!(RingFit::of(&[v(1., 1., 1.); 3]).is_degenerate());
        // Collinear.
        assert!(RingFit::of(&[v(0., 0., 0.), v(1., 1., 1.), v(2., 2., 2.)]).is_degenerate());
    }

    #[test]
    fn a_twisted_quad_is_not_planar() {
        let f = RingFit::of(&[v(0., 0., 0.), v(1., 0., 0.), v(1., 1., 0.3), v(0., 1., 0.)]);
        assert!(!f.is_planar());
        // Rounding at the 7th digit is accepted.
        let f = RingFit::of(&[v(0., 0., 0.), v(1., 0., 0.), v(1., 1., 1e-7), v(0., 1., 0.)]);
        assert!(f.is_planar());
    }
}
