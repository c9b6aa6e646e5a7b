//! The nearest live point, with points removed as the tour takes them: the
//! search behind the greedy nearest-neighbour tour.
//!
//! A [`CellGrid`] answers while the live points spread evenly (the usual
//! case); it is rebuilt, coarser, each time the live points fall to a
//! quarter, so empty cells never outnumber live points by much. When a grid
//! would be crowded the search moves to a kiddo k-d tree for good.

use super::cells::{bounds, CellGrid};
use super::spatial::Groups;
use glam::DVec2;
use kiddo::{KdTree, SquaredEuclidean};

/// Live points per grid cell: most searches end in the first ring of cells.
const POINTS_PER_CELL: f64 = 2.0;

/// Below this many live points the search structure is not rebuilt.
const MIN_REBUILD: usize = 1024;

/// The live points of a [`Groups`] and a search structure over them.
pub(crate) struct Nearest<'a> {
    groups: &'a Groups,
    /// Live items at each group; a group is live while this is positive.
    alive: Vec<u32>,
    live: usize,
    /// Box holding every group and the home position (every query point).
    lo: DVec2,
    hi: DVec2,
    index: Index,
}

enum Index {
    Cells {
        grid: CellGrid,
        /// Whether the group in each slot of the grid is live (in slot
        /// order, so that a search reads it from consecutive memory).
        live_slot: Vec<bool>,
        /// The slot of each group (`u32::MAX` if not in the grid).
        slot_of: Vec<u32>,
        /// Live groups when the grid was built.
        built_for: usize,
    },
    Tree {
        tree: KdTree<f64, 2>,
        /// Groups removed from the tree since it was built.
        dead_in_tree: usize,
    },
}

impl<'a> Nearest<'a> {
    /// Every group live, with as many live items as it has members; `home`
    /// is the first query point.
    pub fn new(groups: &'a Groups, home: DVec2) -> Self {
        let alive: Vec<u32> = (0..groups.points.len()).map(|g| groups.members(g).len() as u32).collect();
        let (lo, hi) = bounds(groups.points.iter().copied().chain([home]));
        let mut me = Nearest { groups, live: alive.len(), alive, lo, hi, index: Index::Tree { tree: KdTree::new(), dead_in_tree: 0 } };
        me.rebuild(true);
        me
    }

    /// The live group nearest to `at`, or `None` if none is live.
    pub fn nearest(&self, at: DVec2) -> Option<usize> {
        if self.live == 0 {
            return None;
        }
        let found = match &self.index {
            Index::Cells { grid, live_slot, .. } => Self::search_cells(grid, live_slot, at),
            Index::Tree { tree, .. } => {
                let g = tree.nearest_one::<SquaredEuclidean>(&[at.x, at.y]).item as usize;
                (self.alive[g] > 0).then_some(g)
            }
        };
        found.or_else(|| {
            // kiddo 5's mutable tree occasionally fails to remove a point
            // when many share a coordinate, and a non-finite point is never
            // nearest to anything: a scan of the live groups is always right.
            let points = &self.groups.points;
            (0..points.len())
                .filter(|&g| self.alive[g] > 0)
                .min_by(|&h, &k| at.distance_squared(points[h]).total_cmp(&at.distance_squared(points[k])))
        })
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
                        let (d2, g) = (grid.pos(slot).distance_squared(at), grid.id(slot));
                        if best.is_none_or(|b| (d2, g) < b) {
                            best = Some((d2, g));
                        }
                    }
                }
            });
        }
        best.map(|(_, g)| g as usize)
    }

    /// One item of group `g` is taken; the group dies with its last item.
    pub fn take(&mut self, g: usize) {
        self.alive[g] -= 1;
        if self.alive[g] > 0 {
            return;
        }
        self.live -= 1;
        let stale = match &mut self.index {
            Index::Cells { live_slot, slot_of, built_for, .. } => {
                live_slot[slot_of[g] as usize] = false;
                self.live * 4 < *built_for
            }
            Index::Tree { tree, dead_in_tree } => {
                let p = self.groups.points[g];
                // A failed removal (kiddo reports 0) is caught in `nearest`.
                tree.remove(&[p.x, p.y], g as u64);
                *dead_in_tree += 1;
                // Removed points leave empty leaves behind that slow the
                // search down; rebuild once they outnumber the live ones.
                *dead_in_tree > self.live
            }
        };
        if stale && self.live >= MIN_REBUILD {
            self.rebuild(matches!(self.index, Index::Cells { .. }));
        }
    }

    /// A fresh index of the live groups: a grid if `try_grid` and they
    /// spread well enough, else a k-d tree.
    fn rebuild(&mut self, try_grid: bool) {
        let ids: Vec<u32> = (0..self.alive.len() as u32).filter(|&g| self.alive[g as usize] > 0).collect();
        let grid = if try_grid { CellGrid::new(&self.groups.points, &ids, self.lo, self.hi, POINTS_PER_CELL) } else { None };
        self.index = match grid {
            Some(grid) => {
                let mut slot_of = vec![u32::MAX; self.alive.len()];
                for slot in 0..grid.slot_count() {
                    slot_of[grid.id(slot) as usize] = slot as u32;
                }
                let live_slot = vec![true; grid.slot_count()];
                Index::Cells { grid, live_slot, slot_of, built_for: ids.len() }
            }
            None => Index::Tree { tree: self.groups.tree(|g| self.alive[g] > 0), dead_in_tree: 0 },
        };
    }
}
