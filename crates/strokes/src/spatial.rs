//! Points grouped by exact position, and their nearest neighbours.
//!
//! kiddo's mutable tree cannot hold more than a bucket's worth of items at
//! one exact point, and stroke endpoints often coincide (a star's rays, the
//! ends of unchained segments). So the tree holds each distinct position
//! once, and a group lists the items at that position.

use super::cells::{bounds, CellGrid, KNN_POINTS_PER_CELL, NO_NEIGHBOUR};
use glam::DVec2;
use kiddo::{KdTree, SquaredEuclidean};
use rayon::prelude::*;
use rustc_hash::FxHashMap;

/// Items grouped by exact position.
pub(crate) struct Groups {
    /// The distinct positions.
    pub points: Vec<DVec2>,
    /// Items of group `g` are `items[start[g]..start[g + 1]]`.
    pub start: Vec<u32>,
    /// Item ids, grouped.
    pub items: Vec<u32>,
    /// The group of each item id.
    pub group_of: Vec<u32>,
}

impl Groups {
    /// Groups `positions[i]` (item `i`) by exact coordinates.
    pub fn new(positions: &[DVec2]) -> Self {
        let mut ids: FxHashMap<(u64, u64), u32> = FxHashMap::with_capacity_and_hasher(positions.len(), Default::default());
        let mut points = Vec::new();
        let mut group_of = Vec::with_capacity(positions.len());
        let mut count: Vec<u32> = Vec::new();
        for p in positions {
            // +0.0 so that -0.0 and 0.0 are one position.
            let key = ((p.x + 0.0).to_bits(), (p.y + 0.0).to_bits());
            let g = *ids.entry(key).or_insert_with(|| {
                points.push(*p);
                count.push(0);
                (points.len() - 1) as u32
            });
            count[g as usize] += 1;
            group_of.push(g);
        }
        let mut start = vec![0u32; points.len() + 1];
        for (g, c) in count.iter().enumerate() {
            start[g + 1] = start[g] + c;
        }
        let mut fill = start.clone();
        let mut items = vec![0u32; positions.len()];
        for (i, &g) in group_of.iter().enumerate() {
            items[fill[g as usize] as usize] = i as u32;
            fill[g as usize] += 1;
        }
        Groups { points, start, items, group_of }
    }

    /// The items at group `g`'s position.
    pub fn members(&self, g: usize) -> &[u32] {
        &self.items[self.start[g] as usize..self.start[g + 1] as usize]
    }

    /// A k-d tree of the groups for which `keep` holds, items = group ids.
    pub fn tree(&self, keep: impl Fn(usize) -> bool) -> KdTree<f64, 2> {
        let mut tree = KdTree::with_capacity(self.points.len());
        for (g, p) in self.points.iter().enumerate() {
            if keep(g) {
                tree.add(&[p.x, p.y], g as u64);
            }
        }
        tree
    }

    /// For each group, up to `k` other groups nearest to it, nearest first:
    /// `k` slots per group, [`NO_NEIGHBOUR`] in those left over. One pass
    /// over a [`CellGrid`] if the points spread well enough for one, else
    /// over a k-d tree built once from all the points (kiddo's immutable
    /// one: nothing is removed here, and it answers about a fifth faster
    /// than the tree [`Groups::tree`] makes); in parallel either way. The
    /// ends of a surface's strokes crowd where its lines were cut, near the
    /// silhouettes, and take the tree.
    pub fn neighbours(&self, k: usize) -> Vec<u32> {
        let mut near = vec![NO_NEIGHBOUR; self.points.len() * k];
        if k == 0 {
            return near;
        }
        let ids: Vec<u32> = (0..self.points.len() as u32).collect();
        let (lo, hi) = bounds(self.points.iter().copied());
        if let Some(grid) = CellGrid::new(&self.points, &ids, lo, hi, KNN_POINTS_PER_CELL) {
            near = grid.all_nearest_k(self.points.len(), k, |_, _| false);
        } else {
            let at: Vec<[f64; 2]> = self.points.iter().map(|p| [p.x, p.y]).collect();
            let tree: kiddo::ImmutableKdTree<f64, 2> = kiddo::ImmutableKdTree::new_from_slice(&at);
            let wanted = std::num::NonZero::<usize>::MIN.saturating_add(k);
            near.par_chunks_mut(k).enumerate().for_each(|(g, row)| {
                let p = self.points[g];
                let found = tree.nearest_n::<SquaredEuclidean>(&[p.x, p.y], wanted);
                let others = found.into_iter().map(|n| n.item as u32).filter(|&h| h as usize != g);
                for (slot, h) in row.iter_mut().zip(others) {
                    *slot = h;
                }
            });
        }
        near
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn many_items_at_one_point() {
        let mut pos = vec![DVec2::new(1.0, 1.0); 200];
        pos.push(DVec2::new(3.0, 3.0));
        pos.push(DVec2::new(-0.0, 0.0));
        pos.push(DVec2::new(0.0, 0.0));
        let g = Groups::new(&pos);
        assert_eq!(g.points.len(), 3);
        assert_eq!(g.members(0).len(), 200);
        assert_eq!(g.members(2), &[201, 202]);
        let n = g.neighbours(5);
        assert_eq!(n[0..5], [2, 1, NO_NEIGHBOUR, NO_NEIGHBOUR, NO_NEIGHBOUR]);
        assert_eq!(n[10..12], [0, 1]);
    }

    #[test]
    fn neighbours_match_brute_force_spread_or_crowded() {
        let spread: Vec<DVec2> =
            (0..3000).map(|i| DVec2::new(f64::from(i * 37 % 101), f64::from(i * 53 % 97) + f64::from(i) * 1e-3)).collect();
        // A speck and one far point: too crowded for a grid, the tree answers.
        let mut speck: Vec<DVec2> = spread.iter().map(|p| *p * 1e-3).collect();
        speck.push(DVec2::splat(1e4));
        // Three columns of a thousand points each in a speck, and one far
        // point: the tree then splits among many points of one x.
        let mut columns: Vec<DVec2> = (0..3000).map(|i| DVec2::new(f64::from(i % 3), f64::from(i)) * 1e-6).collect();
        columns.push(DVec2::splat(1e4));
        for pos in [spread, speck, columns] {
            let g = Groups::new(&pos);
            let near = g.neighbours(4);
            for i in (0..g.points.len()).step_by(13) {
                let mut all: Vec<(f64, usize)> =
                    (0..g.points.len()).filter(|&j| j != i).map(|j| (g.points[i].distance_squared(g.points[j]), j)).collect();
                all.sort_by(|a, b| a.0.total_cmp(&b.0));
                // Compare distances: equally near neighbours may come in either order.
                let got: Vec<f64> = near[4 * i..4 * i + 4].iter().map(|&j| g.points[i].distance_squared(g.points[j as usize])).collect();
                let want: Vec<f64> = all[..4].iter().map(|e| e.0).collect();
                assert_eq!(got, want, "point {i}");
            }
        }
    }
}
