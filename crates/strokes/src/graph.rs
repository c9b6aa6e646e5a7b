//! The graph of segments between snapped vertices.
//!
//! Endpoints within the tolerance become one vertex ([`super::snap`]);
//! duplicate segments (either way round) are dropped, keeping the first, and
//! zero-length ones too, found by sorting rather than hashing.

use super::snap::{snap, NONE};
use crate::drawing::Polyline;
use glam::DVec2;
use rayon::prelude::*;

/// Segments between snapped vertices, without duplicates or zero-length ones.
#[derive(Debug, Default)]
pub(crate) struct Graph {
    /// Vertex positions (the first input point that created each vertex).
    pub vertices: Vec<DVec2>,
    /// Undirected edges as vertex index pairs, each pair at most once.
    pub edges: Vec<[u32; 2]>,
    /// Vertices that are whole input polylines shorter than the tolerance and
    /// touch no edge: drawn as dots.
    pub dots: Vec<u32>,
}

/// Builds the graph of all segments of `polylines`, snapping endpoints within
/// `tol` mm. Non-finite points break a polyline (they cannot be drawn).
pub(crate) fn build(polylines: &[Polyline], tol: f64) -> Graph {
    // Polylines of fewer than two points draw nothing and make no vertex.
    let drawn = || polylines.iter().filter(|p| p.points.len() >= 2);
    let mut points = Vec::with_capacity(drawn().map(|p| p.points.len()).sum());
    for poly in drawn() {
        points.extend_from_slice(&poly.points);
    }
    let snapped = snap(&points, tol);
    // A copy of every point: gone before the edges are built and sorted.
    drop(points);
    let mut g = Graph { vertices: snapped.vertices, ..Graph::default() };
    let mut edges: Vec<[u32; 2]> = Vec::with_capacity(snapped.vertex_of.len());
    let mut dot_candidates = Vec::new();
    let mut at = 0;
    for poly in drawn() {
        let ids = &snapped.vertex_of[at..at + poly.points.len()];
        at += poly.points.len();
        let mut prev = NONE;
        let first = ids.iter().copied().find(|&v| v != NONE).unwrap_or(NONE);
        let mut collapsed = true;
        for &v in ids {
            if v == NONE || v != first {
                collapsed = false;
            }
            if prev != NONE && v != NONE && prev != v {
                edges.push([prev, v]);
            }
            prev = v;
        }
        if collapsed && first != NONE {
            dot_candidates.push(first);
        }
    }
    g.edges = first_of_each(edges);
    if !dot_candidates.is_empty() {
        let mut touched = vec![false; g.vertices.len()];
        for e in &g.edges {
            touched[e[0] as usize] = true;
            touched[e[1] as usize] = true;
        }
        for v in dot_candidates {
            if !touched[v as usize] {
                touched[v as usize] = true;
                g.dots.push(v);
            }
        }
    }
    g
}

/// `edges` without repeats of a vertex pair (either way round), keeping the
/// first of each in order.
fn first_of_each(edges: Vec<[u32; 2]>) -> Vec<[u32; 2]> {
    let mut keyed: Vec<(u64, u32)> =
        edges.par_iter().enumerate().map(|(i, e)| ((u64::from(e[0].min(e[1])) << 32) | u64::from(e[0].max(e[1])), i as u32)).collect();
    keyed.par_sort_unstable();
    let mut keep = vec![false; edges.len()];
    for (j, &(k, i)) in keyed.iter().enumerate() {
        if j == 0 || keyed[j - 1].0 != k {
            keep[i as usize] = true;
        }
    }
    edges.into_iter().zip(keep).filter_map(|(e, k)| k.then_some(e)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pl(pts: &[(f64, f64)]) -> Polyline {
        Polyline::new(pts.iter().map(|&(x, y)| DVec2::new(x, y)).collect())
    }

    #[test]
    fn snaps_within_tolerance_only() {
        let g = build(&[pl(&[(0.0, 0.0), (1.0, 0.0)]), pl(&[(1.005, 0.004), (2.0, 0.0)]), pl(&[(2.02, 0.0), (3.0, 0.0)])], 0.01);
        // (1.005, 0.004) is 0.0064 from (1, 0): joined; (2.02, 0) is 0.02 away: not.
        assert_eq!(g.vertices.len(), 5);
        assert_eq!(g.edges, vec![[0, 1], [1, 2], [3, 4]]);
    }

    #[test]
    fn snapping_matches_brute_force_greedy() {
        // Dense random endpoints, so that many snap, across many cell borders.
        let mut s = 5u64;
        let mut next = || {
            s = s.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            (s >> 11) as f64 / (1u64 << 53) as f64 * 0.4 - 0.2
        };
        let polys: Vec<Polyline> = (0..1500).map(|_| pl(&[(next(), next()), (next(), next())])).collect();
        let tol = 0.01;
        let g = build(&polys, tol);
        let points: Vec<DVec2> = polys.iter().flat_map(|p| p.points.iter().copied()).collect();
        let (vertices, ids) = super::super::snap::brute(&points, tol);
        let mut edges = Vec::new();
        for ids in ids.chunks(2) {
            if ids[0] != ids[1]
                && !edges.iter().any(|e: &[u32; 2]| (e[0].min(e[1]), e[0].max(e[1])) == (ids[0].min(ids[1]), ids[0].max(ids[1])))
            {
                edges.push([ids[0], ids[1]]);
            }
        }
        assert!(vertices.len() < 2900, "the test should snap: {}", vertices.len());
        assert_eq!(g.vertices, vertices);
        assert_eq!(g.edges, edges);
    }

    #[test]
    fn snapping_across_cell_borders() {
        // The two points straddle a grid-cell border at x = 0.
        let g = build(&[pl(&[(-0.004, 5.0), (-3.0, 5.0)]), pl(&[(0.004, 5.0), (3.0, 5.0)])], 0.01);
        assert_eq!(g.vertices.len(), 3);
    }

    #[test]
    fn duplicate_reversed_and_zero_length_segments_dropped() {
        let g = build(&[pl(&[(0.0, 0.0), (1.0, 0.0), (1.0, 0.0)]), pl(&[(1.0, 0.0), (0.0, 0.0)])], 0.01);
        assert_eq!(g.edges.len(), 1);
        assert!(g.dots.is_empty());
    }

    #[test]
    fn tiny_polyline_is_a_dot_and_single_points_are_nothing() {
        let g = build(&[pl(&[(5.0, 5.0), (5.001, 5.0)]), pl(&[(9.0, 9.0)])], 0.01);
        assert!(g.edges.is_empty());
        assert_eq!(g.dots, vec![0]);
    }

    #[test]
    fn non_finite_points_break_the_line() {
        let g = build(&[pl(&[(0.0, 0.0), (f64::NAN, 1.0), (1.0, 1.0), (2.0, 1.0)])], 0.01);
        assert_eq!(g.edges.len(), 1);
    }

    #[test]
    fn zero_tolerance_joins_exact_coincidences() {
        let g = build(&[pl(&[(0.0, 0.0), (1.0, 0.0)]), pl(&[(1.0, 0.0), (1.0, 1.0)])], 0.0);
        assert_eq!(g.vertices.len(), 3);
    }
}
