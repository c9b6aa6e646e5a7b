//! A uniform grid of cells over points, for nearest-neighbour searches.
//!
//! Stroke endpoints of a drawing are spread fairly evenly over the page, and
//! then a grid with a couple of points per cell answers "nearest point" and
//! "k nearest points" by looking at a few cells around the query, with no
//! tree to walk and no allocation. A crowded grid (most points in a few
//! cells: a small detailed drawing with a far-away frame) would make that
//! quadratic, so [`CellGrid::new`] refuses one and callers fall back to the
//! k-d tree of [`super::spatial`].

use glam::DVec2;
use rayon::prelude::*;

/// Marks an empty slot in a list of neighbours.
pub(crate) const NO_NEIGHBOUR: u32 = u32::MAX;

/// Points per cell for k-nearest searches: with eight neighbours wanted, a
/// search then mostly ends after the 3 x 3 cells around a point.
pub(crate) const KNN_POINTS_PER_CELL: f64 = 4.0;

/// Searches per parallel work item of [`CellGrid::all_nearest_k`].
const CHUNK: usize = 4096;

/// A grid is refused when the sum over cells of the squared number of points
/// exceeds this many times the number of points (about 3 for points spread
/// at random; each point's search looks at its neighbours' cells, so this
/// bounds the work per point).
const MAX_CROWDING: usize = 24;

/// Points bucketed by cell; see the module doc.
pub(crate) struct CellGrid {
    lo: DVec2,
    cell: f64,
    nx: usize,
    ny: usize,
    /// The points of cell `c` are in slots `start[c]..start[c + 1]`.
    start: Vec<u32>,
    /// Point id in each slot.
    items: Vec<u32>,
    /// Point position in each slot: a search reads neighbouring cells'
    /// points from consecutive memory, not from all over `points`.
    pos: Vec<DVec2>,
}

impl CellGrid {
    /// A grid over the points `points[i]` for `i` in `ids`, covering the box
    /// from `lo` to `hi` (which must hold every point that will be put in or
    /// asked about), with cells sized for `per_cell` points on average, or
    /// `None` if the points crowd into few cells.
    pub fn new(points: &[DVec2], ids: &[u32], lo: DVec2, hi: DVec2, per_cell: f64) -> Option<CellGrid> {
        let cells = (ids.len() as f64 / per_cell).max(1.0);
        let span = (hi - lo).max(DVec2::splat(0.0));
        let cell = (span.x * span.y / cells).sqrt().max(span.max_element() / cells);
        if !cell.is_finite() {
            return None;
        }
        let cell = if cell > 0.0 { cell } else { 1.0 };
        let (nx, ny) = ((span.x / cell) as usize + 1, (span.y / cell) as usize + 1);
        let mut grid =
            CellGrid { lo, cell, nx, ny, start: vec![0; nx * ny + 1], items: vec![0; ids.len()], pos: vec![DVec2::ZERO; ids.len()] };
        let mut cell_of = Vec::with_capacity(ids.len());
        for &i in ids {
            let c = grid.index(grid.cell_of(points[i as usize]));
            grid.start[c + 1] += 1;
            cell_of.push(c as u32);
        }
        let crowding: usize = grid.start.iter().map(|&k| (k as usize) * (k as usize)).sum();
        if crowding > MAX_CROWDING * ids.len().max(1) {
            return None;
        }
        for c in 0..nx * ny {
            grid.start[c + 1] += grid.start[c];
        }
        let mut fill = grid.start.clone();
        for (&i, &c) in ids.iter().zip(&cell_of) {
            let slot = fill[c as usize] as usize;
            grid.items[slot] = i;
            grid.pos[slot] = points[i as usize];
            fill[c as usize] += 1;
        }
        Some(grid)
    }

    /// Column and row of the cell holding `p` (clamped to the grid).
    pub fn cell_of(&self, p: DVec2) -> (usize, usize) {
        let q = (p - self.lo) / self.cell;
        // `as` saturates, and sends NaN to 0.
        ((q.x as usize).min(self.nx - 1), (q.y as usize).min(self.ny - 1))
    }

    /// Index of the cell at `(column, row)`.
    pub fn index(&self, (x, y): (usize, usize)) -> usize {
        y * self.nx + x
    }

    /// The slots of cell `c`.
    pub fn slots(&self, c: usize) -> std::ops::Range<usize> {
        self.start[c] as usize..self.start[c + 1] as usize
    }

    /// The id of the point in `slot`.
    pub fn id(&self, slot: usize) -> u32 {
        self.items[slot]
    }

    /// The position of the point in `slot`.
    pub fn pos(&self, slot: usize) -> DVec2 {
        self.pos[slot]
    }

    /// Number of slots (points).
    pub fn slot_count(&self) -> usize {
        self.items.len()
    }

    /// Whether ring `r` around `p`'s cell lies wholly outside the grid, so
    /// that rings `r` and beyond hold nothing.
    pub fn beyond(&self, r: usize) -> bool {
        r > self.nx.max(self.ny)
    }

    /// A lower bound on the distance from `p` (inside the grid's box) to any
    /// point in a cell of ring `r` or beyond around `p`'s cell.
    pub fn ring_distance(&self, p: DVec2, r: usize) -> f64 {
        if r == 0 {
            return 0.0;
        }
        let (cx, cy) = self.cell_of(p);
        let f = p - self.lo - DVec2::new(cx as f64, cy as f64) * self.cell;
        let edge = f.x.min(self.cell - f.x).min(f.y).min(self.cell - f.y).max(0.0);
        (r - 1) as f64 * self.cell + edge
    }

    /// Calls `visit` with the index of every cell of ring `r` (the cells
    /// whose column and row are both within `r` of `center`'s and one of
    /// them exactly `r` away) that lies in the grid.
    pub fn ring(&self, (cx, cy): (usize, usize), r: usize, mut visit: impl FnMut(usize)) {
        if r == 0 {
            visit(self.index((cx, cy)));
            return;
        }
        let (x0, x1) = (cx.saturating_sub(r), (cx + r).min(self.nx - 1));
        for y in [cy.checked_sub(r), Some(cy + r).filter(|&y| y < self.ny)].into_iter().flatten() {
            for x in x0..=x1 {
                visit(self.index((x, y)));
            }
        }
        let (y0, y1) = ((cy + 1).saturating_sub(r), (cy + r - 1).min(self.ny - 1));
        for x in [cx.checked_sub(r), Some(cx + r).filter(|&x| x < self.nx)].into_iter().flatten() {
            for y in y0..=y1 {
                visit(self.index((x, y)));
            }
        }
    }

    /// The `k` points nearest to `p` (nearest first, ties by id) among those
    /// for which `skip` is false, into `out` as (squared distance, id).
    pub fn nearest_k(&self, p: DVec2, k: usize, skip: impl Fn(u32) -> bool, out: &mut Vec<(f64, u32)>) {
        out.clear();
        if k == 0 {
            return;
        }
        let center = self.cell_of(p);
        for r in 0.. {
            if self.beyond(r) {
                break;
            }
            if out.len() == k {
                let bound = self.ring_distance(p, r);
                if out[k - 1].0 <= bound * bound {
                    break;
                }
            }
            self.ring(center, r, |c| {
                for slot in self.slots(c) {
                    let i = self.items[slot];
                    let d2 = self.pos[slot].distance_squared(p);
                    if out.len() == k && (d2, i) >= out[k - 1] || skip(i) {
                        continue;
                    }
                    if out.len() == k {
                        out.pop();
                    }
                    let at = out.partition_point(|&e| e < (d2, i));
                    out.insert(at, (d2, i));
                }
            });
        }
    }
}

/// The points of the 3 x 3 cells around one cell, gathered for
/// [`CellGrid::nearest_k_of`].
pub(crate) struct Block {
    cell: usize,
    points: Vec<(DVec2, u32)>,
}

impl Block {
    /// An empty block, for no cell yet.
    pub fn new() -> Self {
        Block { cell: usize::MAX, points: Vec::new() }
    }
}

impl CellGrid {
    /// What [`Self::nearest_k`] gives for the point in `slot`, excluding
    /// itself, but faster when called for the slots in order: the points of
    /// the 3 x 3 cells around the slot's cell are gathered into `block` once
    /// per cell, and the search goes further only when they cannot prove the
    /// `k` nearest.
    pub fn nearest_k_of(&self, slot: usize, k: usize, skip: impl Fn(u32) -> bool, block: &mut Block, out: &mut Vec<(f64, u32)>) {
        let (p, id) = (self.pos[slot], self.items[slot]);
        let center = self.cell_of(p);
        if block.cell != self.index(center) {
            block.cell = self.index(center);
            block.points.clear();
            for r in 0..=1 {
                self.ring(center, r, |c| block.points.extend(self.slots(c).map(|s| (self.pos[s], self.items[s]))));
            }
        }
        out.clear();
        out.extend(block.points.iter().filter(|e| e.1 != id && !skip(e.1)).map(|&(q, i)| (q.distance_squared(p), i)));
        if k > 0 && out.len() >= k {
            let order = |a: &(f64, u32), b: &(f64, u32)| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1));
            out.select_nth_unstable_by(k - 1, order);
            out.truncate(k);
            out.sort_unstable_by(order);
            let bound = self.ring_distance(p, 2);
            if out[k - 1].0 <= bound * bound {
                return;
            }
        }
        self.nearest_k(p, k, |i| i == id || skip(i), out);
    }

    /// For every point id `0..n` in the grid, its `k` nearest other points
    /// for which `skip(id, other)` is false, nearest first: `k` slots per id,
    /// [`NO_NEIGHBOUR`] in those left over. In parallel, in cell order (so
    /// that consecutive searches read the same cells).
    pub fn all_nearest_k(&self, n: usize, k: usize, skip: impl Fn(u32, u32) -> bool + Sync) -> Vec<u32> {
        let mut near = vec![NO_NEIGHBOUR; n * k];
        if k == 0 {
            return near;
        }
        let mut by_slot = vec![NO_NEIGHBOUR; self.items.len() * k];
        by_slot.par_chunks_mut(k * CHUNK).enumerate().for_each(|(chunk, rows)| {
            let mut found = Vec::new();
            let mut block = Block::new();
            for (j, row) in rows.chunks_mut(k).enumerate() {
                let slot = chunk * CHUNK + j;
                let id = self.items[slot];
                self.nearest_k_of(slot, k, |other| skip(id, other), &mut block, &mut found);
                for (cell, &(_, h)) in row.iter_mut().zip(&found) {
                    *cell = h;
                }
            }
        });
        // Back to id order: a parallel gather, as a scatter would be sequential.
        let mut slot_of = vec![u32::MAX; n];
        for (slot, &id) in self.items.iter().enumerate() {
            slot_of[id as usize] = slot as u32;
        }
        near.par_chunks_mut(k).zip(slot_of.par_iter()).for_each(|(row, &slot)| {
            if slot != u32::MAX {
                let at = slot as usize * k;
                row.copy_from_slice(&by_slot[at..at + k]);
            }
        });
        near
    }
}

/// Interleaves the bits of two 16-bit coordinates (Z-order).
pub(crate) fn morton(x: u32, y: u32) -> u64 {
    fn spread(mut v: u64) -> u64 {
        v &= 0xffff;
        v = (v | (v << 8)) & 0x00ff_00ff;
        v = (v | (v << 4)) & 0x0f0f_0f0f;
        v = (v | (v << 2)) & 0x3333_3333;
        (v | (v << 1)) & 0x5555_5555
    }
    spread(u64::from(x)) | (spread(u64::from(y)) << 1)
}

/// The box holding every finite point of `points`.
pub(crate) fn bounds(points: impl IntoIterator<Item = DVec2>) -> (DVec2, DVec2) {
    points.into_iter().filter(|p| p.is_finite()).fold((DVec2::INFINITY, DVec2::NEG_INFINITY), |(lo, hi), p| (lo.min(p), hi.max(p)))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn brute(points: &[DVec2], p: DVec2, k: usize) -> Vec<u32> {
        let mut all: Vec<(f64, u32)> = points.iter().enumerate().map(|(i, q)| (q.distance_squared(p), i as u32)).collect();
        all.sort_by(|a, b| a.partial_cmp(b).unwrap());
        all.into_iter().take(k).map(|e| e.1).collect()
    }

    #[test]
    fn nearest_k_matches_brute_force() {
        // A deterministic scatter with a dense corner and a long thin strip.
        let mut points = Vec::new();
        let mut s = 7u64;
        let mut next = || {
            s = s.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        for i in 0..2000 {
            let (x, y) = (next(), next());
            points.push(if i % 3 == 0 { DVec2::new(x * 5.0, y * 5.0) } else { DVec2::new(x * 100.0, y * 3.0) });
        }
        let ids: Vec<u32> = (0..points.len() as u32).collect();
        let (lo, hi) = bounds(points.iter().copied());
        let grid = CellGrid::new(&points, &ids, lo, hi, 2.0).expect("balanced");
        let mut out = Vec::new();
        for (i, &p) in points.iter().enumerate().step_by(7) {
            grid.nearest_k(p, 6, |j| j as usize == i, &mut out);
            let want: Vec<u32> = brute(&points, p, 7).into_iter().filter(|&j| j as usize != i).take(6).collect();
            assert_eq!(out.iter().map(|e| e.1).collect::<Vec<_>>(), want, "point {i}");
        }
        let mut block = Block::new();
        for slot in 0..grid.slot_count() {
            let i = grid.id(slot) as usize;
            grid.nearest_k_of(slot, 6, |_| false, &mut block, &mut out);
            let want: Vec<u32> = brute(&points, points[i], 7).into_iter().filter(|&j| j as usize != i).take(6).collect();
            assert_eq!(out.iter().map(|e| e.1).collect::<Vec<_>>(), want, "slot {slot}, point {i}");
        }
    }

    #[test]
    fn rings_cover_the_grid_once() {
        let points: Vec<DVec2> = (0..40).map(|i| DVec2::new(f64::from(i % 8), f64::from(i / 8))).collect();
        let ids: Vec<u32> = (0..40).collect();
        let grid = CellGrid::new(&points, &ids, DVec2::ZERO, DVec2::new(7.0, 4.0), 2.0).expect("balanced");
        for center in [(0, 0), (grid.nx - 1, 0), (grid.nx / 2, grid.ny / 2)] {
            let mut seen = vec![0; grid.nx * grid.ny];
            for r in 0..=grid.nx.max(grid.ny) {
                grid.ring(center, r, |c| seen[c] += 1);
            }
            assert!(seen.iter().all(|&k| k == 1), "{center:?}: {seen:?}");
        }
    }

    #[test]
    fn crowded_and_degenerate_grids() {
        // Everything in one corner but one far point: refused.
        let mut points: Vec<DVec2> = (0..1000).map(|i| DVec2::new(f64::from(i) * 1e-4, 0.0)).collect();
        points.push(DVec2::new(1000.0, 1000.0));
        let ids: Vec<u32> = (0..points.len() as u32).collect();
        let (lo, hi) = bounds(points.iter().copied());
        assert!(CellGrid::new(&points, &ids, lo, hi, 2.0).is_none());
        // All on one vertical line, or at one point: fine.
        let line: Vec<DVec2> = (0..100).map(|i| DVec2::new(3.0, f64::from(i))).collect();
        let (lo, hi) = bounds(line.iter().copied());
        let grid = CellGrid::new(&line, &ids[..100], lo, hi, 2.0).expect("a line spreads over cells");
        let mut out = Vec::new();
        grid.nearest_k(DVec2::new(3.0, 50.2), 2, |_| false, &mut out);
        assert_eq!(out.iter().map(|e| e.1).collect::<Vec<_>>(), vec![50, 51]);
        let one = [DVec2::ONE];
        assert!(CellGrid::new(&one, &[0], DVec2::ONE, DVec2::ONE, 2.0).is_some());
    }
}
