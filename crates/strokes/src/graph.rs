//! The graph of polylines between snapped end vertices.
//!
//! Each input polyline (cut where a point is not finite) is one edge between
//! its two end points; the ends within the tolerance of each other become
//! one vertex ([`super::snap`]) and the points between them travel with the
//! edge, untouched. Only ends are snapped: the points inside a polyline are
//! millions on a surface and need no vertex, since where a line ends on
//! another's inner point the end is odd either way, so the fewest strokes
//! are the same (only a closed loop touching another line at an inner point
//! is drawn as its own stroke). Duplicate straight segments (either way
//! round) are dropped, keeping the first, and zero-length ones too, found by
//! sorting rather than hashing.

use super::snap::snap;
use crate::drawing::Polyline;
use glam::DVec2;
use rayon::prelude::*;

/// Polylines between snapped vertices, without duplicate or zero-length
/// straight segments.
#[derive(Debug, Default)]
pub(crate) struct Graph<'a> {
    /// Vertex positions (the first input end point that created each vertex).
    pub vertices: Vec<DVec2>,
    /// Undirected edges as vertex index pairs; two edges share a pair only
    /// when at least one of them is not straight.
    pub edges: Vec<[u32; 2]>,
    /// The input points of each edge, from the end at `edges[e][0]` to the
    /// one at `edges[e][1]` (its end points are drawn at the vertices);
    /// empty: every edge is the straight segment between its vertices.
    pub paths: Vec<&'a [DVec2]>,
    /// Vertices that are whole input polylines shorter than the tolerance and
    /// touch no edge: drawn as dots.
    pub dots: Vec<u32>,
}

impl Graph<'_> {
    /// For each edge, the point next to its first vertex along it and the
    /// point next to its second: the directions it leaves and reaches its
    /// ends by (for a straight edge, the other vertex), in parallel. The
    /// Euler walk asks for them at every step, and reading them out of the
    /// input polylines there is a cache miss each.
    pub fn next_to_ends(&self) -> Vec<[DVec2; 2]> {
        (0..self.edges.len())
            .into_par_iter()
            .map(|e| {
                let [a, b] = self.edges[e];
                match self.paths.get(e) {
                    Some(path) if path.len() > 2 => [path[1], path[path.len() - 2]],
                    _ => [self.vertices[b as usize], self.vertices[a as usize]],
                }
            })
            .collect()
    }

    /// How many points lie strictly inside edge `e`.
    pub fn inner_len(&self, e: usize) -> usize {
        self.paths.get(e).map_or(0, |p| p.len().saturating_sub(2))
    }

    /// The points strictly inside edge `e` walked from vertex `from`
    /// (forward for a loop).
    pub fn inner(&self, e: usize, from: u32) -> impl Iterator<Item = DVec2> + '_ {
        let path: &[DVec2] = self.paths.get(e).map_or(&[], |p| if p.len() > 2 { &p[1..p.len() - 1] } else { &[] });
        let forward = self.edges[e][0] == from;
        let (f, r) = if forward { (Some(path.iter()), None) } else { (None, Some(path.iter().rev())) };
        f.into_iter().flatten().chain(r.into_iter().flatten()).copied()
    }
}

/// Builds the graph of `polylines`, snapping their end points within `tol`
/// mm. Non-finite points break a polyline (they cannot be drawn).
pub(crate) fn build(polylines: &[Polyline], tol: f64) -> Graph<'_> {
    // Runs of at least two finite points: a polyline, or its pieces between
    // points that cannot be drawn. A single point draws nothing.
    let runs: Vec<&[DVec2]> =
        polylines.par_iter().flat_map_iter(|p| p.points.split(|q| !q.is_finite()).filter(|run| run.len() >= 2)).collect();
    let ends: Vec<DVec2> = runs.iter().flat_map(|r| [r[0], r[r.len() - 1]]).collect();
    let snapped = snap(&ends, tol);
    drop(ends);
    let vertex_of = snapped.vertex_of;
    let vertices = snapped.vertices;
    // A run whose points all lie within the tolerance of its (one) vertex is
    // a dot, not an edge. A run with no point but its two ends (repeated,
    // perhaps) is straight: dropped if its ends are one vertex, and drawn
    // once however often it is given.
    let (collapsed, straight_run): (Vec<bool>, Vec<bool>) = runs
        .par_iter()
        .enumerate()
        .map(|(i, run)| {
            let (u, v) = (vertex_of[2 * i], vertex_of[2 * i + 1]);
            let (a, b) = (run[0], run[run.len() - 1]);
            (u == v && run.iter().all(|p| p.distance(vertices[u as usize]) <= tol), run.iter().all(|&p| p == a || p == b))
        })
        .unzip();
    let mut edges: Vec<[u32; 2]> = Vec::with_capacity(runs.len());
    let mut paths: Vec<&[DVec2]> = Vec::with_capacity(runs.len());
    let mut dot_candidates = Vec::new();
    let mut straight: Vec<(u64, u32)> = Vec::new();
    for (i, run) in runs.iter().enumerate() {
        let (u, v) = (vertex_of[2 * i], vertex_of[2 * i + 1]);
        if collapsed[i] {
            dot_candidates.push(u);
            continue;
        }
        if straight_run[i] {
            if u == v {
                continue;
            }
            straight.push(((u64::from(u.min(v)) << 32) | u64::from(u.max(v)), edges.len() as u32));
        }
        edges.push([u, v]);
        paths.push(run);
    }
    drop((collapsed, straight_run));
    let keep = first_of_each(straight, edges.len());
    let mut g = Graph { vertices, ..Graph::default() };
    if keep.iter().all(|&k| k) {
        g.edges = edges;
        g.paths = paths;
    } else {
        for ((e, p), k) in edges.into_iter().zip(paths).zip(keep) {
            if k {
                g.edges.push(e);
                g.paths.push(p);
            }
        }
    }
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

/// Which of `n` edges to keep: all but the later straight segments of each
/// vertex pair in `keyed` ((pair key, edge index), edge indices ascending).
fn first_of_each(mut keyed: Vec<(u64, u32)>, n: usize) -> Vec<bool> {
    let mut keep = vec![true; n];
    keyed.par_sort_unstable();
    for (j, &(k, i)) in keyed.iter().enumerate() {
        if j > 0 && keyed[j - 1].0 == k {
            keep[i as usize] = false;
        }
    }
    keep
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pl(pts: &[(f64, f64)]) -> Polyline {
        Polyline::new(pts.iter().map(|&(x, y)| DVec2::new(x, y)).collect())
    }

    #[test]
    fn snaps_within_tolerance_only() {
        let input = [pl(&[(0.0, 0.0), (1.0, 0.0)]), pl(&[(1.005, 0.004), (2.0, 0.0)]), pl(&[(2.02, 0.0), (3.0, 0.0)])];
        let g = build(&input, 0.01);
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
        let input = [pl(&[(-0.004, 5.0), (-3.0, 5.0)]), pl(&[(0.004, 5.0), (3.0, 5.0)])];
        let g = build(&input, 0.01);
        assert_eq!(g.vertices.len(), 3);
    }

    #[test]
    fn duplicate_reversed_and_zero_length_segments_dropped() {
        let input = [pl(&[(0.0, 0.0), (1.0, 0.0), (1.0, 0.0)]), pl(&[(1.0, 0.0), (0.0, 0.0)])];
        let g = build(&input, 0.01);
        assert_eq!(g.edges.len(), 1);
        assert!(g.dots.is_empty());
    }

    #[test]
    fn tiny_polyline_is_a_dot_and_single_points_are_nothing() {
        let input = [pl(&[(5.0, 5.0), (5.001, 5.0)]), pl(&[(9.0, 9.0)])];
        let g = build(&input, 0.01);
        assert!(g.edges.is_empty());
        assert_eq!(g.dots, vec![0]);
    }

    #[test]
    fn non_finite_points_break_the_line() {
        let input = [pl(&[(0.0, 0.0), (f64::NAN, 1.0), (1.0, 1.0), (2.0, 1.0)])];
        let g = build(&input, 0.01);
        assert_eq!(g.edges.len(), 1);
    }

    #[test]
    fn zero_tolerance_joins_exact_coincidences() {
        let input = [pl(&[(0.0, 0.0), (1.0, 0.0)]), pl(&[(1.0, 0.0), (1.0, 1.0)])];
        let g = build(&input, 0.0);
        assert_eq!(g.vertices.len(), 3);
    }
}
