//! The nearest live point, with points removed as the tour takes them: the
//! search behind the greedy nearest-neighbour tour.
//!
//! A [`CellGrid`] of the points answers while the live ones spread evenly
//! (the usual case); it is rebuilt, coarser, each time the live points fall
//! to a quarter, so empty cells never outnumber live points by much. When a
//! grid would be crowded the search moves for good to a kiddo k-d tree of the
//! distinct places ([`Groups`]: kiddo cannot hold many items at one place).

use super::cells::{bounds, CellGrid};
use super::spatial::Groups;
use glam::DVec2;
use kiddo::{KdTree, SquaredEuclidean};

/// Live points per grid cell: most searches end in the first ring of cells.
const POINTS_PER_CELL: f64 = 2.0;

/// Below this many live points the search structure is not rebuilt.
const MIN_REBUILD: usize = 1024;

/// Live points and a search structure over them.
pub(crate) struct Nearest<'a> {
    points: &'a [DVec2],
    alive: Vec<bool>,
    live: usize,
    /// Box holding every point and the home position (every query point).
    lo: DVec2,
    hi: DVec2,
    index: Index,
}

enum Index {
    Cells {
        grid: CellGrid,
        /// Whether the point in each slot of the grid is live (in slot
        /// order, so that a search reads it from consecutive memory).
        live_slot: Vec<bool>,
        /// The slot of each point (`u32::MAX` if not in the grid).
        slot_of: Vec<u32>,
        /// Live points when the grid was built.
        built_for: usize,
    },
    Tree {
        /// The distinct places of the points live when the tree was first
        /// built (group members are indices into `ids`).
        groups: Groups,
        ids: Vec<u32>,
        /// Each point's index into `ids` (`u32::MAX` if not there).
        sub: Vec<u32>,
        /// Live points at each group; a group is in the tree while positive.
        live_in_group: Vec<u32>,
        tree: KdTree<f64, 2>,
        /// Groups removed from the tree since it was built.
        dead_in_tree: usize,
    },
}

impl<'a> Nearest<'a> {
    /// Every point live; `home` is the first query point.
    pub fn new(points: &'a [DVec2], home: DVec2) -> Self {
        let (lo, hi) = bounds(points.iter().copied().chain([home]));
        let ids: Vec<u32> = (0..points.len() as u32).collect();
        Nearest { points, alive: vec![true; points.len()], live: points.len(), lo, hi, index: index_of(points, &ids, lo, hi) }
    }

    /// The live point nearest to `at`, or `None` if none is live.
    pub fn nearest(&mut self, at: DVec2) -> Option<usize> {
        if self.live == 0 {
            return None;
        }
        for attempt in 0..2 {
            let found = match &self.index {
                Index::Cells { grid, live_slot, .. } => Self::search_cells(grid, live_slot, at),
                Index::Tree { groups, ids, live_in_group, tree, .. } => {
                    let g = tree.nearest_one::<SquaredEuclidean>(&[at.x, at.y]).item as usize;
                    let mut members = groups.members(g).iter().map(|&m| ids[m as usize] as usize);
                    (live_in_group[g] > 0).then(|| members.find(|&i| self.alive[i])).flatten()
                }
            };
            if found.is_some() {
                return found;
            }
            // kiddo 5's mutable tree occasionally fails to remove a point
            // when many share a coordinate: a fresh tree is right.
            if attempt == 0 && matches!(self.index, Index::Tree { .. }) {
                self.rebuild();
            } else {
                break;
            }
        }
        {
            // A non-finite point is never nearest to anything: a scan of the
            // live points is always right.
            (0..self.points.len())
                .filter(|&i| self.alive[i])
                .min_by(|&h, &k| at.distance_squared(self.points[h]).total_cmp(&at.distance_squared(self.points[k])))
        }
    }

    fn search_cells(grid: &CellGrid, live_slot: &[bool], at: DVec2) -> Option<usize> {
        let center = grid.cell_of(at);
        let mut best: Option<(f64, u32)> = None;
        for r in 0.. {
            if grid.beyond(r) {
                break;
            }
            if let Some((d2, _)) = best {
                let bound = grid.ring_distance(at, r);
                if d2 <= bound * bound {
                    break;
                }
            }
            grid.ring(center, r, |c| {
                for slot in grid.slots(c) {
                    if live_slot[slot] {
                        let (d2, i) = (grid.pos(slot).distance_squared(at), grid.id(slot));
                        if best.is_none_or(|b| (d2, i) < b) {
                            best = Some((d2, i));
                        }
                    }
                }
            });
        }
        best.map(|(_, i)| i as usize)
    }

    /// Point `i` is taken (it must be live).
    pub fn take(&mut self, i: usize) {
        self.alive[i] = false;
        self.live -= 1;
        let stale = match &mut self.index {
            Index::Cells { live_slot, slot_of, built_for, .. } => {
                live_slot[slot_of[i] as usize] = false;
                self.live * 4 < *built_for
            }
            Index::Tree { groups, sub, live_in_group, tree, dead_in_tree, .. } => {
                let g = groups.group_of[sub[i] as usize] as usize;
                live_in_group[g] -= 1;
                if live_in_group[g] > 0 {
                    return;
                }
                let p = groups.points[g];
                // A failed removal (kiddo reports 0) is caught in `nearest`.
                tree.remove(&[p.x, p.y], g as u64);
                *dead_in_tree += 1;
                // Removed points leave empty leaves behind that slow the
                // search down; rebuild once they outnumber the live ones.
                *dead_in_tree > self.live
            }
        };
        if stale && self.live >= MIN_REBUILD {
            self.rebuild();
        }
    }

    /// A fresh index of the live points: a grid while they spread well
    /// enough for one, else (from then on) a k-d tree.
    fn rebuild(&mut self) {
        if let Index::Tree { groups, live_in_group, tree, dead_in_tree, .. } = &mut self.index {
            *tree = groups.tree(|g| live_in_group[g] > 0);
            *dead_in_tree = 0;
            return;
        }
        let ids: Vec<u32> = (0..self.points.len() as u32).filter(|&i| self.alive[i as usize]).collect();
        self.index = index_of(self.points, &ids, self.lo, self.hi);
    }
}

/// A grid of the points `ids` if they spread well enough for one, else a
/// k-d tree of their distinct places.
fn index_of(points: &[DVec2], ids: &[u32], lo: DVec2, hi: DVec2) -> Index {
    if let Some(grid) = CellGrid::new(points, ids, lo, hi, POINTS_PER_CELL) {
        let mut slot_of = vec![u32::MAX; points.len()];
        for slot in 0..grid.slot_count() {
            slot_of[grid.id(slot) as usize] = slot as u32;
        }
        let live_slot = vec![true; grid.slot_count()];
        return Index::Cells { grid, live_slot, slot_of, built_for: ids.len() };
    }
    // Only the live points: the tree may take over late, with few left.
    let places: Vec<DVec2> = ids.iter().map(|&i| points[i as usize]).collect();
    let groups = Groups::new(&places);
    let mut sub = vec![u32::MAX; points.len()];
    for (k, &i) in ids.iter().enumerate() {
        sub[i as usize] = k as u32;
    }
    let live_in_group: Vec<u32> = (0..groups.points.len()).map(|g| groups.members(g).len() as u32).collect();
    let tree = groups.tree(|_| true);
    Index::Tree { groups, ids: ids.to_vec(), sub, live_in_group, tree, dead_in_tree: 0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Takes the nearest live point again and again from near the last one
    /// taken until none is left; every point is taken once. If `exact`, each
    /// is checked against a scan of the live points. (kiddo's mutable tree
    /// has been seen to miss the nearest point after many removals among
    /// points sharing coordinates, so the tree is only checked for taking
    /// live points.)
    fn drain(mut near: Nearest, mut at: DVec2, exact: bool) {
        let mut taken = vec![false; near.points.len()];
        while near.live > 0 {
            let got = near.nearest(at).expect("a live point");
            assert!(near.alive[got] && !taken[got]);
            if exact {
                let want = (0..near.points.len())
                    .filter(|&i| near.alive[i])
                    .min_by(|&a, &b| at.distance_squared(near.points[a]).total_cmp(&at.distance_squared(near.points[b])))
                    .expect("a live point");
                assert_eq!(at.distance(near.points[got]), at.distance(near.points[want]), "{} left", near.live);
            }
            taken[got] = true;
            near.take(got);
            at = near.points[got] + DVec2::new(0.3, 0.0);
        }
        assert_eq!(near.nearest(at), None);
    }

    fn points() -> Vec<DVec2> {
        // Odd points spread out, even ones in a speck sharing coordinates.
        (0..3000)
            .map(|i| {
                let t = f64::from(i);
                if i % 2 == 0 {
                    DVec2::new(50.0 + (t * 0.37).sin() * 0.01, 50.0 + f64::from(i % 7) * 1e-3)
                } else {
                    DVec2::new((t * 7.3) % 100.0, (t * 3.1) % 100.0)
                }
            })
            .collect()
    }

    #[test]
    fn grid_search_is_exact() {
        let spread: Vec<DVec2> = points().into_iter().skip(1).step_by(2).collect();
        let near = Nearest::new(&spread, DVec2::ZERO);
        assert!(matches!(near.index, Index::Cells { .. }));
        drain(near, DVec2::ZERO, true);
    }

    #[test]
    fn tree_search_takes_every_point_once() {
        let points = points();
        let near = Nearest::new(&points, DVec2::ZERO);
        assert!(matches!(near.index, Index::Tree { .. }));
        drain(near, DVec2::ZERO, false);
        // A tree of some points only, as when a grid gives way mid-tour.
        let (lo, hi) = bounds(points.iter().copied().chain([DVec2::ZERO]));
        let ids: Vec<u32> = (0..3000).step_by(2).collect();
        let index = index_of(&points, &ids, lo, hi);
        assert!(matches!(index, Index::Tree { .. }));
        let alive: Vec<bool> = (0..3000).map(|i| i % 2 == 0).collect();
        drain(Nearest { points: &points, alive, live: ids.len(), lo, hi, index }, DVec2::ZERO, false);
    }
}
