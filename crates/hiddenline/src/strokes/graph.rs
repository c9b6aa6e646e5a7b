//! Snapping endpoints within a tolerance and building the segment graph.
//!
//! Vertices are created greedily in input order: a point within the tolerance
//! of an existing vertex becomes that vertex, otherwise it starts a new one.
//! So any two vertices are more than the tolerance apart, and a point moves by
//! at most the tolerance. The index is a hash grid of cells twice the
//! tolerance wide, so a lookup probes four cells.

use crate::drawing::Polyline;
use glam::DVec2;
use std::collections::{HashMap, HashSet};
use std::hash::{BuildHasherDefault, Hasher};

/// Smallest tolerance used for snapping, mm; a zero or negative tolerance
/// still joins exactly coincident endpoints.
const MIN_TOLERANCE_MM: f64 = 1e-9;

const NONE: u32 = u32::MAX;

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

/// A fast, non-cryptographic hasher for integer keys (multiply-rotate, as in
/// rustc's FxHash); the std SipHash is several times slower on this hot path.
#[derive(Default)]
pub(crate) struct FastHasher(u64);

impl Hasher for FastHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u64(u64::from(b));
        }
    }
    fn write_u64(&mut self, x: u64) {
        self.0 = (self.0.rotate_left(5) ^ x).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }
    fn write_u32(&mut self, x: u32) {
        self.write_u64(u64::from(x));
    }
    fn write_i64(&mut self, x: i64) {
        self.write_u64(x as u64);
    }
}

pub(crate) type FastBuild = BuildHasherDefault<FastHasher>;

/// Hash-grid index of vertices for snapping.
struct SnapIndex {
    tol: f64,
    cell: f64,
    heads: HashMap<(i64, i64), u32, FastBuild>,
    /// Next vertex in the same cell, or `NONE`.
    next: Vec<u32>,
}

impl SnapIndex {
    fn new(tol: f64, capacity: usize) -> Self {
        let tol = if tol.is_finite() && tol > MIN_TOLERANCE_MM { tol } else { MIN_TOLERANCE_MM };
        SnapIndex {
            tol,
            cell: 2.0 * tol,
            heads: HashMap::with_capacity_and_hasher(capacity, FastBuild::default()),
            next: Vec::with_capacity(capacity),
        }
    }

    /// The vertex `p` snaps to, created if needed.
    fn snap(&mut self, p: DVec2, vertices: &mut Vec<DVec2>) -> u32 {
        let gx = p.x / self.cell;
        let gy = p.y / self.cell;
        let (ix, iy) = (gx.floor() as i64, gy.floor() as i64);
        // A vertex within `tol` = half a cell lies in this cell or in the
        // neighbours towards the nearer cell sides.
        let dx = if gx - gx.floor() < 0.5 { -1 } else { 1 };
        let dy = if gy - gy.floor() < 0.5 { -1 } else { 1 };
        let mut best = NONE;
        let mut best_d2 = self.tol * self.tol;
        for key in [(ix, iy), (ix.saturating_add(dx), iy), (ix, iy.saturating_add(dy)), (ix.saturating_add(dx), iy.saturating_add(dy))] {
            let mut v = self.heads.get(&key).copied().unwrap_or(NONE);
            while v != NONE {
                let d2 = vertices[v as usize].distance_squared(p);
                if d2 <= best_d2 {
                    best_d2 = d2;
                    best = v;
                }
                v = self.next[v as usize];
            }
            if best != NONE && best_d2 == 0.0 {
                return best;
            }
        }
        if best != NONE {
            return best;
        }
        let id = vertices.len() as u32;
        vertices.push(p);
        let head = self.heads.entry((ix, iy)).or_insert(NONE);
        self.next.push(*head);
        *head = id;
        id
    }
}

/// Builds the graph of all segments of `polylines`, snapping endpoints within
/// `tol` mm. Non-finite points break a polyline (they cannot be drawn).
pub(crate) fn build(polylines: &[Polyline], tol: f64) -> Graph {
    let npoints: usize = polylines.iter().map(|p| p.points.len()).sum();
    let mut index = SnapIndex::new(tol, npoints);
    let mut g = Graph { vertices: Vec::with_capacity(npoints), ..Graph::default() };
    let mut seen: HashSet<(u32, u32), FastBuild> =
        HashSet::with_capacity_and_hasher(npoints, FastBuild::default());
    let mut dot_candidates = Vec::new();
    for poly in polylines {
        if poly.points.len() < 2 {
            continue;
        }
        let mut prev = NONE;
        let mut first = NONE;
        let mut collapsed = true;
        for &p in &poly.points {
            if !p.is_finite() {
                prev = NONE;
                collapsed = false;
                continue;
            }
            let v = index.snap(p, &mut g.vertices);
            if first == NONE {
                first = v;
            }
            if v != first {
                collapsed = false;
            }
            if prev != NONE && prev != v {
                let key = if prev < v { (prev, v) } else { (v, prev) };
                if seen.insert(key) {
                    g.edges.push([prev, v]);
                }
            }
            prev = v;
        }
        if collapsed && first != NONE {
            dot_candidates.push(first);
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
        // The reference: each point, in order, joins the nearest earlier
        // vertex within the tolerance or becomes a vertex.
        let mut vertices: Vec<DVec2> = Vec::new();
        let mut edges = Vec::new();
        for p in &polys {
            let ids: Vec<u32> = p
                .points
                .iter()
                .map(|&q| {
                    let near = (0..vertices.len())
                        .filter(|&v| vertices[v].distance_squared(q) <= tol * tol)
                        .min_by(|&a, &b| vertices[a].distance_squared(q).total_cmp(&vertices[b].distance_squared(q)));
                    near.map_or_else(
                        || {
                            vertices.push(q);
                            vertices.len() as u32 - 1
                        },
                        |v| v as u32,
                    )
                })
                .collect();
            if ids[0] != ids[1] && !edges.iter().any(|e: &[u32; 2]| (e[0].min(e[1]), e[0].max(e[1])) == (ids[0].min(ids[1]), ids[0].max(ids[1]))) {
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
