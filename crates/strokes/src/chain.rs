//! Chaining: polylines in, the fewest strokes that draw the same lines out.

use super::{euler, graph, StrokeOptions, COLLINEAR_TOLERANCE_MM};
use crate::drawing::Polyline;
use glam::DVec2;
use rayon::prelude::*;

/// Joins `polylines` into the minimum number of strokes that draw every one
/// of them exactly once (per connected piece of the graph whose edges are
/// the polylines: one per pair of odd-degree vertices, at least one),
/// snapping their end points within `options.tolerance_mm` and, if `options.merge_collinear`, merging
/// consecutive collinear segments. The order of the result is not optimised;
/// see [`super::order`]. Closed strokes start and end on the same point.
#[must_use]
pub fn chain(polylines: &[Polyline], options: &StrokeOptions) -> Vec<Polyline> {
    let g = graph::build(polylines, options.tolerance_mm);
    let trails = euler::trails(&g);
    (0..trails.len())
        .into_par_iter()
        .map(|t| {
            let (verts, via) = (trails.get(t), trails.via(t));
            // Sized for every point at once: a surface's strokes run to
            // thousands of points, and growing them by doubling copied each
            // about twice over.
            let inner: usize = via.iter().filter(|&&e| e != euler::NONE).map(|&e| g.inner_len(e as usize)).sum();
            let mut points: Vec<DVec2> = Vec::with_capacity(verts.len() + inner);
            points.push(g.vertices[verts[0] as usize]);
            for k in 1..verts.len() {
                if via[k] != euler::NONE {
                    // Repeated points inside a polyline draw nothing.
                    for p in g.inner(via[k] as usize, verts[k - 1]) {
                        if points.last() != Some(&p) {
                            points.push(p);
                        }
                    }
                }
                let v = g.vertices[verts[k] as usize];
                if points.last() != Some(&v) {
                    points.push(v);
                }
            }
            if points.len() == 1 {
                // A dot.
                points.push(points[0]);
            }
            if options.merge_collinear {
                merge_collinear(&mut points);
            }
            Polyline::new(points)
        })
        .collect()
}

/// Drops every vertex where the path goes straight on (within
/// [`COLLINEAR_TOLERANCE_MM`] of the chord from the last kept vertex to the
/// next one, and strictly between them, so a path that doubles back keeps
/// its turning point).
pub(crate) fn merge_collinear(points: &mut Vec<DVec2>) {
    if points.len() < 3 {
        return;
    }
    let mut kept = 1;
    for i in 1..points.len() - 1 {
        let (a, b, c) = (points[kept - 1], points[i], points[i + 1]);
        if !straight_on(a, b, c) {
            points[kept] = b;
            kept += 1;
        }
    }
    let last = points[points.len() - 1];
    points[kept] = last;
    points.truncate(kept + 1);
}

/// Whether `b` lies on the segment from `a` to `c`, strictly inside it.
fn straight_on(a: DVec2, b: DVec2, c: DVec2) -> bool {
    let ac = c - a;
    let len2 = ac.length_squared();
    if len2 == 0.0 {
        return false;
    }
    let t = (b - a).dot(ac);
    if t <= 0.0 || t >= len2 {
        return false;
    }
    let off = ac.perp_dot(b - a).abs() / len2.sqrt();
    off <= COLLINEAR_TOLERANCE_MM
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pts(v: &[(f64, f64)]) -> Vec<DVec2> {
        v.iter().map(|&(x, y)| DVec2::new(x, y)).collect()
    }

    #[test]
    fn merges_straight_runs_only() {
        let mut p = pts(&[(0.0, 0.0), (1.0, 0.0), (2.0, 0.0), (2.0, 1.0), (2.0, 3.0)]);
        merge_collinear(&mut p);
        assert_eq!(p, pts(&[(0.0, 0.0), (2.0, 0.0), (2.0, 3.0)]));
    }

    #[test]
    fn keeps_the_turning_point_of_a_reversal() {
        let mut p = pts(&[(0.0, 0.0), (2.0, 0.0), (1.0, 0.0)]);
        merge_collinear(&mut p);
        assert_eq!(p.len(), 3);
    }

    #[test]
    fn keeps_closed_loops_closed_and_short_ones_alone() {
        let mut p = pts(&[(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 0.0)]);
        merge_collinear(&mut p);
        assert_eq!(p.len(), 4);
        let mut q = pts(&[(0.0, 0.0), (1.0, 0.0)]);
        merge_collinear(&mut q);
        assert_eq!(q.len(), 2);
        let mut dot = pts(&[(1.0, 1.0), (1.0, 1.0), (1.0, 1.0)]);
        merge_collinear(&mut dot);
        assert_eq!(dot.len(), 3);
    }

    #[test]
    fn chains_touching_segments_and_splits_at_branches() {
        let segs: Vec<Polyline> = [((0.0, 0.0), (1.0, 0.0)), ((1.0, 0.0), (2.0, 0.0)), ((1.0, 0.0), (1.0, 1.0))]
            .iter()
            .map(|&(a, b)| Polyline::new(pts(&[a, b])))
            .collect();
        let out = chain(&segs, &StrokeOptions::default());
        // A T: three odd vertices plus an odd centre, so two strokes.
        assert_eq!(out.len(), 2);
        let total: f64 = out.iter().map(Polyline::length).sum();
        assert!((total - 3.0).abs() < 1e-12);
    }
}
