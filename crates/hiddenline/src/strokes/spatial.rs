//! Points grouped by exact position, in a k-d tree (kiddo).
//!
//! kiddo's mutable tree cannot hold more than a bucket's worth of items at
//! one exact point, and stroke endpoints often coincide (a star's rays, the
//! ends of unchained segments). So the tree holds each distinct position
//! once, and a group lists the items at that position.

use super::graph::FastBuild;
use glam::DVec2;
use kiddo::{KdTree, SquaredEuclidean};
use std::collections::HashMap;

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
        let mut ids: HashMap<(u64, u64), u32, FastBuild> =
            HashMap::with_capacity_and_hasher(positions.len(), FastBuild::default());
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

    /// For each group, up to `k` other groups nearest to it, nearest first.
    pub fn neighbours(&self, k: usize) -> Vec<Vec<u32>> {
        let tree = self.tree(|_| true);
        self.points
            .iter()
            .enumerate()
            .map(|(g, p)| {
                tree.nearest_n::<SquaredEuclidean>(&[p.x, p.y], k + 1)
                    .into_iter()
                    .map(|n| n.item as u32)
                    .filter(|&h| h as usize != g)
                    .take(k)
                    .collect()
            })
            .collect()
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
        assert_eq!(n[0], vec![2, 1]);
        assert_eq!(n[2], vec![0, 1]);
    }
}
