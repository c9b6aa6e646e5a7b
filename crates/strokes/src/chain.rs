//! Chaining: polylines in, the fewest strokes that draw the same lines out.

use super::{euler, graph, simplify, StrokeOptions};
use crate::drawing::Polyline;
use glam::DVec2;
use rayon::prelude::*;

/// Joins `polylines` into the minimum number of strokes that draw every one
/// of them exactly once (per connected piece of the graph whose edges are
/// the polylines: one per pair of odd-degree vertices, at least one),
/// snapping their end points within `options.tolerance_mm` and, if
/// `options.simplify`, dropping the vertices where a stroke goes straight on
/// ([`simplify::simplify`]; its pieces come simplified, so this is where
/// they join). The order of the result is not optimised; see
/// [`super::order`]. Closed strokes start and end on the same point.
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
            if options.simplify {
                simplify::simplify(&mut points, simplify::SIMPLIFY_TOLERANCE_MM);
            }
            Polyline::new(points)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pts(v: &[(f64, f64)]) -> Vec<DVec2> {
        v.iter().map(|&(x, y)| DVec2::new(x, y)).collect()
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
