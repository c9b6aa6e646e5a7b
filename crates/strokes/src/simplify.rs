//! Simplification: the vertices where a line goes straight on, dropped.
//!
//! Hidden-line output carries every grid crossing of a surface: at 2000 x
//! 2000 grid points, 7.6 million vertices, most of them within a fraction of
//! a micrometre of the straight segment from the vertex before to the one
//! after. The output formats cannot show them (SVG and G-code are written to
//! the micrometre, HP-GL in 25 µm plotter units), a plotter only slows down
//! at each, and every later stage pays for them. [`simplify()`] drops each
//! vertex that lies within [`SIMPLIFY_TOLERANCE_MM`] of the segment that
//! replaces it; at 2000 x 2000 that leaves a tenth of the points.
//!
//! Promises:
//! - **The ends stay**, and what is kept is a subsequence of the input: a
//!   closed line stays closed, a visibility change (always a polyline's end)
//!   stays where the engine put it.
//! - **Every dropped vertex lies within the tolerance of the kept segment
//!   that replaces it** (not only of the line through it: a line that turns
//!   back keeps its turning point). Errors never add up along a gently
//!   curving line, as a merge of one vertex at a time would let them.
//! - Linear time: each vertex is looked at once or twice, whatever the input.
//!
//! How (sleeve fitting): from the last kept vertex `a`, a vertex `q` farther
//! than the tolerance allows the segment's direction only within the cone
//! of half-angle `asin(tol / |q - a|)` around `q - a`. The segment is
//! extended to each next vertex whose direction lies in every cone so far
//! (kept as the two unit vectors that bound their intersection) and that is
//! at least as far from `a` as every vertex before it; the first that is
//! not ends it at the vertex before.

use crate::drawing::Polyline;
use glam::DVec2;
use rayon::prelude::*;

/// How far (mm) a dropped vertex may lie from the segment that replaces it:
/// the resolution SVG and G-code are written at, a twenty-fifth of an HP-GL
/// plotter unit, a tenth of the snapping tolerance.
pub const SIMPLIFY_TOLERANCE_MM: f64 = 1e-3;

/// [`simplify()`] on each of `polylines` at [`SIMPLIFY_TOLERANCE_MM`], in
/// parallel: the first stage of [`crate::optimize`].
pub fn simplify_polylines(polylines: &mut [Polyline]) {
    polylines.par_iter_mut().for_each(|p| simplify(&mut p.points, SIMPLIFY_TOLERANCE_MM));
}

/// Drops every vertex of `points` that lies within `tol` mm of the segment
/// that replaces it; see the module doc.
pub fn simplify(points: &mut Vec<DVec2>, tol: f64) {
    if points.len() < 3 {
        return;
    }
    let mut kept = 1;
    let mut at = 0;
    while at + 1 < points.len() {
        at = segment_end(points, at, tol);
        points[kept] = points[at];
        kept += 1;
    }
    points.truncate(kept);
}

/// The last vertex after `from` that the segment from `from` can reach with
/// every vertex between within `tol` of it (at least `from + 1`).
/// `from + 1 < points.len()`.
fn segment_end(points: &[DVec2], from: usize, tol: f64) -> usize {
    let a = points[from];
    // The directions allowed so far, counterclockwise from `lo` to `hi`
    // (less than a half turn); None while every vertex is within `tol` of `a`.
    let mut cone: Option<(DVec2, DVec2)> = None;
    let mut end = from + 1;
    loop {
        let d = points[end] - a;
        // Each vertex taken is at least as far from `a` as those before:
        // `r` is the farthest so far.
        let r = d.length();
        if r > tol {
            // The cone of `points[end]`: `d` turned by -w and +w, sin w = tol / r.
            let (s, u) = (tol / r, d / r);
            let c = (1.0 - s * s).sqrt();
            let lo = DVec2::new(u.x * c + u.y * s, u.y * c - u.x * s);
            let hi = DVec2::new(u.x * c - u.y * s, u.y * c + u.x * s);
            // The direction to `points[end]` was inside the cone so far, so
            // both cones lie within a half turn of it and the comparisons
            // below order their borders correctly.
            cone = Some(match cone {
                None => (lo, hi),
                Some((l, h)) => (if l.perp_dot(lo) > 0.0 { lo } else { l }, if hi.perp_dot(h) > 0.0 { hi } else { h }),
            });
        }
        let Some(&next) = points.get(end + 1) else { return end };
        let d = next - a;
        if d.length_squared() < r * r {
            return end;
        }
        if let Some((lo, hi)) = cone {
            if lo.perp_dot(d) < 0.0 || d.perp_dot(hi) < 0.0 {
                return end;
            }
        }
        end += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tests::dist_to_segment;
    use proptest::prelude::*;

    fn pts(v: &[(f64, f64)]) -> Vec<DVec2> {
        v.iter().map(|&(x, y)| DVec2::new(x, y)).collect()
    }

    #[test]
    fn merges_straight_runs_only() {
        let mut p = pts(&[(0.0, 0.0), (1.0, 0.0), (2.0, 0.0), (2.0, 1.0), (2.0, 3.0)]);
        simplify(&mut p, 1e-3);
        assert_eq!(p, pts(&[(0.0, 0.0), (2.0, 0.0), (2.0, 3.0)]));
    }

    #[test]
    fn keeps_the_turning_point_of_a_reversal() {
        let mut p = pts(&[(0.0, 0.0), (2.0, 0.0), (1.0, 0.0)]);
        simplify(&mut p, 1e-3);
        assert_eq!(p.len(), 3);
        // Turning back by more than the tolerance, then on past the turn.
        let mut p = pts(&[(0.0, 0.0), (2.0, 0.0), (1.9, 0.0), (3.0, 0.0)]);
        simplify(&mut p, 1e-3);
        assert_eq!(p, pts(&[(0.0, 0.0), (2.0, 0.0), (1.9, 0.0), (3.0, 0.0)]));
    }

    #[test]
    fn keeps_closed_loops_closed_and_short_ones_alone() {
        let mut p = pts(&[(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 0.0)]);
        simplify(&mut p, 1e-3);
        assert_eq!(p.len(), 4);
        let mut q = pts(&[(0.0, 0.0), (1.0, 0.0)]);
        simplify(&mut q, 1e-3);
        assert_eq!(q.len(), 2);
        let mut dot = pts(&[(1.0, 1.0), (1.0, 1.0), (1.0, 1.0)]);
        simplify(&mut dot, 1e-3);
        assert_eq!(dot, pts(&[(1.0, 1.0), (1.0, 1.0)]));
    }

    /// Each dropped vertex is judged against its replacing segment alone, so
    /// a gentle curve keeps a vertex every chord whose sagitta reaches the
    /// tolerance (about `sqrt(8 r tol)` long), not one per tolerance of
    /// drift: the error does not add up along the line.
    #[test]
    fn an_arc_keeps_a_vertex_per_chord_of_its_sagitta() {
        let (r, tol, angle) = (50.0, 1e-3, 1.0);
        let arc: Vec<DVec2> = (0..=10_000).map(|k| DVec2::from_angle(angle * k as f64 * 1e-4) * r).collect();
        let mut p = arc.clone();
        simplify(&mut p, tol);
        let chord = (8.0 * r * tol).sqrt();
        let expected = (r * angle / chord).ceil() as usize + 1;
        assert!(p.len() >= expected && p.len() <= expected + 2, "{} vertices, about {expected} expected", p.len());
        let worst = arc.iter().map(|&q| p.windows(2).map(|w| dist_to_segment(q, w[0], w[1])).fold(f64::MAX, f64::min)).fold(0.0, f64::max);
        assert!(worst <= tol * (1.0 + 1e-9), "{worst}");
    }

    proptest! {
        /// Brute force: every vertex between two kept ones lies within the
        /// tolerance of the segment between them; the ends are kept.
        #[test]
        fn every_dropped_vertex_lies_near_its_segment(
            steps in prop::collection::vec((-1.0f64..1.0, -1.0f64..1.0, 0u8..4), 2..200),
            tol in prop::sample::select(vec![1e-3, 1e-2, 0.5]),
        ) {
            // Random walks mostly straight on, some turning, some jittering
            // back and forth, some standing still.
            let mut at = DVec2::ZERO;
            let mut heading = DVec2::X;
            let points: Vec<DVec2> = steps.iter().map(|&(x, y, kind)| {
                match kind {
                    0 => heading = DVec2::new(x, y).try_normalize().unwrap_or(DVec2::X),
                    1 => at += DVec2::new(x, y) * tol,
                    _ => {}
                }
                if kind != 3 {
                    at += heading * (0.5 + x.abs()) * tol * 4.0;
                }
                at
            }).collect();
            let mut from = 0;
            while from + 1 < points.len() {
                let end = segment_end(&points, from, tol);
                prop_assert!(end > from);
                for &q in &points[from + 1..end] {
                    let d = dist_to_segment(q, points[from], points[end]);
                    prop_assert!(d <= tol * (1.0 + 1e-9), "{d} from the segment {from}..{end}");
                }
                from = end;
            }
            let mut kept = points.clone();
            simplify(&mut kept, tol);
            prop_assert_eq!(kept.first(), points.first());
            prop_assert_eq!(kept.last(), points.last());
        }
    }
}
