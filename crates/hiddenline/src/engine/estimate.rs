//! What the general engine's work will be, estimated before it starts
//! from the faces' screen boxes alone, in O(n log n).
//!
//! A line is tested against the faces whose boxes it crosses, and the lines
//! lying on a face (its edges, and its penetration lines: where it crosses
//! another face, which it can only do where their pictures overlap) lie in
//! its box. So a face `f` whose box overlaps those of `d` other faces brings
//! at most `e + d` lines (`e` its edges) tested against at most `d` faces
//! each: the estimate is the sum of `d (e + d)` over the faces, in face
//! tests. A height field's faces each overlap a few dozen others (a million
//! triangles seen at a slant: 61 each, 1.75 x 10^10 tests); n large
//! triangles that all cross each other overlap nearly all the others, about
//! n^3 tests, and their time grows as n^2.7 (1,000: 6.7 x 10^8 tests and
//! 1.7 s; 4,000: about 4 x 10^10 and 77 s; 16,000: 2.8 x 10^12 and an
//! hour).

use glam::DVec2;

use super::faces::{prepare, scene_scale};
use crate::camera::Camera;
use crate::model::Model;
use crate::tolerance::PLANE_REL;

/// The general engine's work on a model seen by a camera, estimated.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Estimate {
    /// Faces that can hide anything (in front of the near plane, not seen
    /// edge-on, not culled as back faces): the engine's occluders.
    pub faces: usize,
    /// Pairs of those faces whose screen boxes overlap (touching counts).
    pub overlaps: u64,
    /// Face tests: over the faces, the faces overlapping each times that
    /// count plus its edges (see the module's doc).
    pub tests: u64,
}

/// Estimates the general engine's work on `model` seen by `camera`: its
/// occluders, as [`super::visibility`] prepares them, how many pairs of
/// them overlap on screen, and the face tests that makes.
#[must_use]
pub fn estimate(model: &Model, camera: &Camera) -> Estimate {
    let eps = PLANE_REL * scene_scale(model, camera);
    let occluders = prepare(model, camera, eps);
    let boxes: Vec<(DVec2, DVec2)> = occluders.faces.iter().map(|f| (f.lo, f.hi)).collect();
    let overlaps = overlaps_of_each(&boxes);
    let mut tests = 0u64;
    for (f, &d) in occluders.faces.iter().zip(&overlaps) {
        let edges = model.faces[f.id as usize].outer.len() as u64;
        tests = tests.saturating_add(u64::from(d).saturating_mul(edges + u64::from(d)));
    }
    let twice: u64 = overlaps.iter().map(|&d| u64::from(d)).sum();
    Estimate { faces: boxes.len(), overlaps: twice / 2, tests }
}

/// For each of the closed boxes `(lo, hi)`, how many of the others overlap
/// it (touching counts).
///
/// All the others, plus those apart from it along both x and y, less those
/// apart along x and those apart along y (which takes the first off twice):
/// those beyond each corner by a sweep along x counting y ranks in a Fenwick
/// tree, the others by binary search among sorted coordinates.
#[must_use]
fn overlaps_of_each(boxes: &[(DVec2, DVec2)]) -> Vec<u32> {
    let n = boxes.len();
    let mut overlaps = vec![(n.saturating_sub(1)) as u32; n];
    // Beyond each corner: negating coordinates turns every corner into the
    // upper right one.
    for (sx, sy) in [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)] {
        let flip = |p: DVec2| DVec2::new(sx * p.x, sy * p.y);
        // The boxes' corners nearest the query's, and the query corners.
        let near = |b: &(DVec2, DVec2)| flip(DVec2::new(if sx > 0.0 { b.0.x } else { b.1.x }, if sy > 0.0 { b.0.y } else { b.1.y }));
        let far = |b: &(DVec2, DVec2)| flip(DVec2::new(if sx > 0.0 { b.1.x } else { b.0.x }, if sy > 0.0 { b.1.y } else { b.0.y }));
        let points: Vec<DVec2> = boxes.iter().map(near).collect();
        let queries: Vec<DVec2> = boxes.iter().map(far).collect();
        for (d, beyond) in overlaps.iter_mut().zip(upper_right(&points, &queries)) {
            *d += beyond;
        }
    }
    for axis in 0..2 {
        let mut los: Vec<f64> = boxes.iter().map(|b| b.0[axis]).collect();
        let mut his: Vec<f64> = boxes.iter().map(|b| b.1[axis]).collect();
        los.sort_unstable_by(f64::total_cmp);
        his.sort_unstable_by(f64::total_cmp);
        for (d, b) in overlaps.iter_mut().zip(boxes) {
            let before = his.partition_point(|&h| h < b.0[axis]);
            let after = n - los.partition_point(|&l| l <= b.1[axis]);
            *d -= (before + after) as u32;
        }
    }
    overlaps
}

/// For each query, how many points lie strictly above and to its right.
fn upper_right(points: &[DVec2], queries: &[DVec2]) -> Vec<u32> {
    // Ranks of the points' y, so that a Fenwick tree counts those above a y.
    let mut ys: Vec<f64> = points.iter().map(|p| p.y).collect();
    ys.sort_unstable_by(f64::total_cmp);
    let mut by_x: Vec<u32> = (0..points.len() as u32).collect();
    by_x.sort_unstable_by(|&a, &b| points[b as usize].x.total_cmp(&points[a as usize].x));
    let mut asked: Vec<u32> = (0..queries.len() as u32).collect();
    asked.sort_unstable_by(|&a, &b| queries[b as usize].x.total_cmp(&queries[a as usize].x));
    let mut tree = vec![0u32; ys.len() + 1];
    let mut out = vec![0u32; queries.len()];
    let mut inserted = 0usize;
    for &q in &asked {
        let q = q as usize;
        // Every point strictly right of the query, by decreasing x.
        while inserted < by_x.len() && points[by_x[inserted] as usize].x > queries[q].x {
            let mut i = ys.partition_point(|&y| y < points[by_x[inserted] as usize].y) + 1;
            while i < tree.len() {
                tree[i] += 1;
                i += i & i.wrapping_neg();
            }
            inserted += 1;
        }
        // Those of them at or below the query's y, taken from all of them.
        let (mut i, mut below) = (ys.partition_point(|&y| y <= queries[q].y), 0u32);
        while i > 0 {
            below += tree[i];
            i -= i & i.wrapping_neg();
        }
        out[q] = inserted as u32 - below;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// All pairs, one by one.
    fn brute(boxes: &[(DVec2, DVec2)]) -> u64 {
        let mut n = 0;
        for i in 0..boxes.len() {
            for j in i + 1..boxes.len() {
                let (a, b) = (boxes[i], boxes[j]);
                if a.0.x <= b.1.x && b.0.x <= a.1.x && a.0.y <= b.1.y && b.0.y <= a.1.y {
                    n += 1;
                }
            }
        }
        n
    }

    fn overlapping_pairs(boxes: &[(DVec2, DVec2)]) -> u64 {
        let each = overlaps_of_each(boxes);
        let twice: u64 = each.iter().map(|&d| u64::from(d)).sum();
        assert_eq!(twice % 2, 0);
        for (i, &d) in each.iter().enumerate() {
            let mine = (0..boxes.len()).filter(|&j| j != i && brute(&[boxes[i], boxes[j]]) == 1).count();
            assert_eq!(d as usize, mine, "box {i}");
        }
        twice / 2
    }

    #[test]
    fn counts_as_every_pair_compared() {
        // Boxes on a coarse lattice, so many edges touch and coordinates tie.
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut next = |m: u64| {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed % m) as f64
        };
        for n in [0, 1, 2, 5, 40, 300] {
            let boxes: Vec<(DVec2, DVec2)> = (0..n)
                .map(|_| {
                    let lo = DVec2::new(next(20), next(20));
                    (lo, lo + DVec2::new(next(6), next(6)))
                })
                .collect();
            assert_eq!(overlapping_pairs(&boxes), brute(&boxes), "{n} boxes");
        }
        let unit = (DVec2::ZERO, DVec2::ONE);
        assert_eq!(overlapping_pairs(&[unit; 4]), 6);
        let corner = (DVec2::ONE, DVec2::splat(2.0));
        assert_eq!(overlapping_pairs(&[unit, corner]), 1, "touching at a corner");
    }
}
