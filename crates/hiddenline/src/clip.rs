//! Clipping a segment to an axis-aligned box, on its parameter: the page's
//! `fov` frame cuts visible intervals exactly, and the reference checker
//! clips the same way.

use glam::DVec2;

/// The parameter interval `(t0, t1)` of segment `a + t (b - a)`, `t` in
/// `[0, 1]`, that lies inside the axis-aligned box `lo`..`hi` (Liang-Barsky);
/// `None` when no piece of positive length does.
#[must_use]
pub fn clip_segment_t(a: DVec2, b: DVec2, lo: DVec2, hi: DVec2) -> Option<(f64, f64)> {
    let d = b - a;
    if d == DVec2::ZERO {
        return None;
    }
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (p, q) in [(-d.x, a.x - lo.x), (d.x, hi.x - a.x), (-d.y, a.y - lo.y), (d.y, hi.y - a.y)] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else {
            let r = q / p;
            if p < 0.0 {
                t0 = t0.max(r);
            } else {
                t1 = t1.min(r);
            }
        }
    }
    (t0 < t1).then_some((t0, t1))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn liang_barsky() {
        let (lo, hi) = (DVec2::new(-1.0, -1.0), DVec2::new(1.0, 1.0));
        assert_eq!(clip_segment_t(DVec2::new(-2.0, 0.0), DVec2::new(2.0, 0.0), lo, hi), Some((0.25, 0.75)));
        assert_eq!(clip_segment_t(DVec2::new(0.0, 0.0), DVec2::new(0.5, 0.5), lo, hi), Some((0.0, 1.0)));
        assert_eq!(clip_segment_t(DVec2::new(-2.0, 2.0), DVec2::new(2.0, 2.0), lo, hi), None);
        // Touching a corner only: no positive length.
        assert_eq!(clip_segment_t(DVec2::new(0.0, 2.0), DVec2::new(2.0, 0.0), lo, hi), None);
        // Along an edge: kept (the frame edge is inside).
        assert_eq!(clip_segment_t(DVec2::new(-2.0, 1.0), DVec2::new(2.0, 1.0), lo, hi), Some((0.25, 0.75)));
        // Zero length.
        assert_eq!(clip_segment_t(DVec2::ZERO, DVec2::ZERO, lo, hi), None);
    }
}
