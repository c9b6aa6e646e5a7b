//! Snapping points that lie within a tolerance of each other onto one vertex.
//!
//! The rule is greedy in input order: each point, in turn, joins the nearest
//! vertex made so far that lies within the tolerance (ties: the older
//! vertex), or else becomes a new vertex. So any two vertices are more than
//! the tolerance apart, and a point moves by at most the tolerance.
//!
//! Followed literally that is a sequential walk with a spatial lookup per
//! point, a cache miss or several each on a million points. Instead the
//! points are sorted by grid cell (in parallel), which brings together the
//! few that could interact: only points within the tolerance of another
//! point depend on the input order at all, and on random drawings they are a
//! few percent. Points at the same exact place form one group, and a group
//! can make at most one vertex (its first point's, if any), so crowds of
//! coincident endpoints (a star's centre, a mesh's vertices) cost no pairs.

use super::cells::bounds;
use glam::DVec2;
use rayon::prelude::*;

/// Smallest tolerance used for snapping, mm; a zero or negative tolerance
/// still joins exactly coincident points.
const MIN_TOLERANCE_MM: f64 = 1e-9;

/// Marks a point that is not finite, so snaps to nothing.
pub(crate) const NONE: u32 = u32::MAX;

/// Grid coordinates are kept below this, so that a cell key packs column and
/// row into one `u64` and the next column or row never overflows.
const MAX_CELLS_PER_AXIS: f64 = (1u64 << 30) as f64;

/// Where each point went.
pub(crate) struct Snapped {
    /// Vertex positions, in the order the greedy rule creates them (each the
    /// first point that made it).
    pub vertices: Vec<DVec2>,
    /// The vertex of each input point; [`NONE`] for non-finite points.
    pub vertex_of: Vec<u32>,
}

/// Points at one exact place, in cell order.
struct Groups {
    pos: Vec<DVec2>,
    /// The lowest input index at this place.
    first: Vec<u32>,
    /// Group of each input point ([`NONE`] if not finite).
    of_point: Vec<u32>,
    /// Distinct cells: (key, first group in the cell); groups of a cell are
    /// consecutive.
    cells: Vec<(u64, u32)>,
}

/// Snaps `points` within `tol` mm; see the module doc for the rule.
pub(crate) fn snap(points: &[DVec2], tol: f64) -> Snapped {
    let tol = if tol.is_finite() && tol > MIN_TOLERANCE_MM { tol } else { MIN_TOLERANCE_MM };
    let (lo, hi) = bounds(points.iter().copied());
    if !lo.is_finite() {
        return Snapped { vertices: Vec::new(), vertex_of: vec![NONE; points.len()] };
    }
    // Cells at least `tol` wide, so that points within `tol` of each other
    // are in the same or adjacent cells; twice that keeps most cells to one
    // point on dense drawings.
    let cell = (2.0 * tol).max((hi - lo).max_element() / MAX_CELLS_PER_AXIS);
    let mut groups = group(points, lo, cell);
    let near = near_pairs(&groups, tol);
    let n_groups = groups.pos.len();

    // Contested groups (another place within `tol`) are decided in input
    // order; all others make a vertex. The groups in that order: by their
    // first points, which are distinct point indices, so placed, not sorted.
    let mut in_order = vec![NONE; points.len()];
    for (g, &f) in groups.first.iter().enumerate() {
        in_order[f as usize] = g as u32;
    }
    in_order.retain(|&g| g != NONE);
    let mut makes = vec![true; n_groups];
    for &g in &in_order {
        let others = near.of(g);
        if !others.is_empty() {
            let f = groups.first[g as usize];
            makes[g as usize] = !others.iter().any(|&h| groups.first[h as usize] < f && makes[h as usize]);
        }
    }

    // The cell list was for finding near pairs: free it before the arrays
    // below (on millions of points every array counts at the peak).
    groups.cells = Vec::new();
    // Vertex ids in order of creation: by the input index of the first point.
    let makers: Vec<u32> = in_order.into_iter().filter(|&g| makes[g as usize]).collect();
    let vertices: Vec<DVec2> = makers.iter().map(|&g| points[groups.first[g as usize] as usize]).collect();
    let mut vertex_of_group = vec![NONE; n_groups];
    for (v, &g) in makers.iter().enumerate() {
        vertex_of_group[g as usize] = v as u32;
    }
    drop((makers, makes));
    let vertex_of = (0..points.len())
        .into_par_iter()
        .map(|i| {
            let g = groups.of_point[i];
            if g == NONE {
                return NONE;
            }
            let own = vertex_of_group[g as usize];
            if own != NONE {
                // At distance zero, and made no later than this point.
                return own;
            }
            // The nearest vertex within reach that exists by point i's turn;
            // there is one, since the group's first point snapped to it.
            let p = groups.pos[g as usize];
            let mut best = (f64::INFINITY, NONE);
            for &h in near.of(g) {
                let v = vertex_of_group[h as usize];
                if v != NONE && (groups.first[h as usize] as usize) < i {
                    let d2 = groups.pos[h as usize].distance_squared(p);
                    if (d2, v) < best {
                        best = (d2, v);
                    }
                }
            }
            best.1
        })
        .collect();
    Snapped { vertices, vertex_of }
}

/// Sorts the finite points by cell, then by place, and groups them.
fn group(points: &[DVec2], lo: DVec2, cell: f64) -> Groups {
    let key = |p: DVec2| {
        let q = (p - lo) / cell;
        ((q.x as u64) << 32) | q.y as u64
    };
    // Non-finite points get the largest key and are cut off after the sort:
    // a filtered parallel collect would build the list twice over.
    let mut sorted: Vec<(u64, u32)> =
        points.par_iter().enumerate().map(|(i, &p)| (if p.is_finite() { key(p) } else { u64::MAX }, i as u32)).collect();
    sorted.par_sort_unstable();
    // Finite keys stay below 2^62 (`MAX_CELLS_PER_AXIS`).
    let finite = sorted.partition_point(|&(k, _)| k != u64::MAX);
    sorted.truncate(finite);
    // Within a cell, by exact place (+0.0 makes -0.0 and 0.0 one place),
    // then by input index.
    let place = |i: u32| {
        let p = points[i as usize] + DVec2::ZERO;
        (p.x.to_bits(), p.y.to_bits(), i)
    };
    sorted.par_chunk_by_mut(|a, b| a.0 == b.0).filter(|r| r.len() > 1).for_each(|r| r.sort_unstable_by_key(|e| place(e.1)));

    // Sized exactly (a first pass counts), not grown by doubling: on
    // millions of points the doubling's spare room would be the peak.
    let new_place = |w: &[(u64, u32)]| w[0].0 != w[1].0 || points[w[0].1 as usize] != points[w[1].1 as usize];
    let new_cell = |w: &[(u64, u32)]| w[0].0 != w[1].0;
    let n_groups = usize::from(!sorted.is_empty()) + sorted.windows(2).filter(|w| new_place(w)).count();
    let n_cells = usize::from(!sorted.is_empty()) + sorted.windows(2).filter(|w| new_cell(w)).count();
    let mut g = Groups {
        pos: Vec::with_capacity(n_groups),
        first: Vec::with_capacity(n_groups),
        of_point: vec![NONE; points.len()],
        cells: Vec::with_capacity(n_cells),
    };
    let mut last: Option<(u64, DVec2)> = None;
    for &(k, i) in &sorted {
        let p = points[i as usize];
        if last.is_none_or(|(lk, lp)| lk != k || lp != p) {
            if last.is_none_or(|(lk, _)| lk != k) {
                g.cells.push((k, g.pos.len() as u32));
            }
            g.pos.push(p);
            g.first.push(i);
            last = Some((k, p));
        }
        g.of_point[i as usize] = g.pos.len() as u32 - 1;
    }
    g
}

/// For each group, the other groups within the tolerance (compressed rows).
struct Near {
    start: Vec<u32>,
    list: Vec<u32>,
}

impl Near {
    fn of(&self, g: u32) -> &[u32] {
        &self.list[self.start[g as usize] as usize..self.start[g as usize + 1] as usize]
    }
}

/// Every pair of groups within `tol`: each cell against itself and the four
/// neighbours after it in key order (up, and the three in the next column),
/// found by a merge walk since both lists are sorted.
fn near_pairs(groups: &Groups, tol: f64) -> Near {
    let cells = &groups.cells;
    let groups_of = |c: usize| {
        let end = cells.get(c + 1).map_or(groups.pos.len() as u32, |e| e.1);
        cells[c].1..end
    };
    let mut pairs: Vec<(u32, u32)> = Vec::new();
    let mut check = |a: std::ops::Range<u32>, b: std::ops::Range<u32>, same: bool| {
        for g in a {
            let from = if same { g + 1 } else { b.start };
            for h in from..b.end {
                if groups.pos[g as usize].distance_squared(groups.pos[h as usize]) <= tol * tol {
                    pairs.push((g, h));
                }
            }
        }
    };
    let mut q = 0;
    for c in 0..cells.len() {
        let k = cells[c].0;
        let (x, y) = (k >> 32, k & 0xffff_ffff);
        check(groups_of(c), groups_of(c), true);
        if cells.get(c + 1).is_some_and(|e| e.0 == k + 1) {
            check(groups_of(c), groups_of(c + 1), false);
        }
        let from = ((x + 1) << 32) | y.saturating_sub(1);
        let to = ((x + 1) << 32) | (y + 1);
        while q < cells.len() && cells[q].0 < from {
            q += 1;
        }
        let mut r = q;
        while r < cells.len() && cells[r].0 <= to {
            check(groups_of(c), groups_of(r), false);
            r += 1;
        }
    }
    let mut start = vec![0u32; groups.pos.len() + 1];
    for &(g, h) in &pairs {
        start[g as usize + 1] += 1;
        start[h as usize + 1] += 1;
    }
    for i in 0..groups.pos.len() {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut list = vec![0u32; 2 * pairs.len()];
    for &(g, h) in &pairs {
        list[fill[g as usize] as usize] = h;
        fill[g as usize] += 1;
        list[fill[h as usize] as usize] = g;
        fill[h as usize] += 1;
    }
    Near { start, list }
}

/// The rule of the module doc, by brute force: each point, in order, joins
/// the nearest earlier vertex within `tol` or becomes a vertex (tests only).
#[cfg(test)]
pub(crate) fn brute(points: &[DVec2], tol: f64) -> (Vec<DVec2>, Vec<u32>) {
    let mut vertices: Vec<DVec2> = Vec::new();
    let ids = points
        .iter()
        .map(|&q| {
            if !q.is_finite() {
                return NONE;
            }
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
    (vertices, ids)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_brute_force_with_crowds_and_coincidences() {
        let mut s = 9u64;
        let mut next = || {
            s = s.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut points: Vec<DVec2> = (0..3000).map(|_| DVec2::new(next() * 0.3, next() * 0.3)).collect();
        // Exact repeats of earlier points, some far later, and -0.0.
        for i in 0..600 {
            let j = (next() * points.len() as f64) as usize;
            points.push(points[j]);
            if i % 100 == 0 {
                points.push(DVec2::new(-0.0, 0.0));
                points.push(DVec2::new(f64::NAN, 1.0));
            }
        }
        for tol in [0.0, 0.004, 0.01] {
            let got = snap(&points, tol);
            let (vertices, ids) = brute(&points, tol.max(MIN_TOLERANCE_MM));
            assert_eq!(got.vertices, vertices, "tol {tol}");
            assert_eq!(got.vertex_of, ids, "tol {tol}");
        }
    }

    #[test]
    fn a_repeated_point_may_join_a_newer_vertex() {
        // 0.009 joins the vertex at 0; 0.0105 is too far from 0, so is a
        // vertex of its own; the repeat of 0.009 is now nearer to it.
        let p = |x: f64| DVec2::new(x, 0.0);
        let got = snap(&[p(0.0), p(0.009), p(0.0105), p(0.009)], 0.01);
        assert_eq!(got.vertices, vec![p(0.0), p(0.0105)]);
        assert_eq!(got.vertex_of, vec![0, 0, 1, 1]);
    }

    #[test]
    fn nothing_finite() {
        let got = snap(&[DVec2::NAN, DVec2::INFINITY], 0.01);
        assert!(got.vertices.is_empty());
        assert_eq!(got.vertex_of, vec![NONE, NONE]);
    }
}
