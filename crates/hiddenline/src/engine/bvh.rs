//! A bounding-volume hierarchy over the occluders in screen space, with the
//! nearest depth of each subtree: a line visits only the faces whose boxes
//! its segment meets and that start in front of its farthest point
//! (Griffith's buckets and depth rejection, adaptive to where faces crowd,
//! such as near a horizon).

use glam::DVec2;
use rayon::prelude::*;

use super::faces::Occluder;

/// Faces per leaf: small, since testing a face is far dearer than a node.
const LEAF: usize = 4;

/// Subtrees of at least this many faces build their two halves at once, on
/// two threads: the median splits of ten million faces took 8 s on one core.
/// Below it a thread's start costs more than the subtree.
const PARALLEL_MIN: usize = 1 << 14;

#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Zeroable)]
struct Node {
    lo: DVec2,
    hi: DVec2,
    /// Nearest depth of any face below.
    zmin: f64,
    /// Leaf: range into `order`. Inner: `start` is the right child (the left
    /// child is the next node) and `count` is 0.
    start: u32,
    count: u32,
}

/// The hierarchy; faces are referred to by their index in the occluder list.
#[derive(Debug, Default)]
pub(crate) struct Bvh {
    nodes: Vec<Node>,
    order: Vec<u32>,
}

/// Nodes of the hierarchy over `n` faces (`n` at least 1): the median split
/// makes the shape depend on `n` alone, so each subtree's nodes can be
/// placed before it is built, and the whole array allocated once.
fn node_count(n: usize) -> usize {
    /// `(node_count(k), node_count(k + 1))`, from the pair at `k / 2`.
    fn pair(k: usize) -> (usize, usize) {
        if k <= 4 * LEAF {
            return (small(k), small(k + 1));
        }
        let (a, b) = pair(k / 2);
        if k % 2 == 0 {
            (1 + 2 * a, 1 + a + b)
        } else {
            (1 + a + b, 1 + 2 * b)
        }
    }
    fn small(k: usize) -> usize {
        if k <= LEAF {
            1
        } else {
            1 + small(k / 2) + small(k - k / 2)
        }
    }
    pair(n).0
}

/// A face as the build sorts it: the sum of its box's corners (twice its
/// centre, the key of the median splits) beside its index. The splits
/// move these, in order in memory, instead of reading each face's box from
/// wherever it lies (ten million faces: 4.5 s on two cores, most of it
/// waiting on memory).
#[derive(Clone, Copy)]
struct Entry {
    key: DVec2,
    id: u32,
}

/// The axis along which the faces' centres spread most: the one a node over
/// them is split across.
fn split_axis(ids: &[Entry]) -> usize {
    let (mut lo, mut hi) = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
    for e in ids {
        lo = lo.min(e.key);
        hi = hi.max(e.key);
    }
    if hi.x - lo.x >= hi.y - lo.y {
        0
    } else {
        1
    }
}

impl Bvh {
    /// Builds by median splits along the longer axis of the box centres.
    pub fn new(faces: &[Occluder]) -> Bvh {
        Bvh::built(faces, PARALLEL_MIN)
    }

    /// [`Bvh::new`], subtrees of `parallel_min` faces or more built two
    /// halves at once: the same tree whatever `parallel_min` is.
    fn built(faces: &[Occluder], parallel_min: usize) -> Bvh {
        if faces.is_empty() {
            return Bvh { nodes: Vec::new(), order: Vec::new() };
        }
        let mut entries: Vec<Entry> = faces.par_iter().enumerate().map(|(i, f)| Entry { key: f.lo + f.hi, id: i as u32 }).collect();
        // Zeroed, every node overwritten by the build: fresh memory that the
        // build's threads fault in as they write it (filling ten million
        // faces' nodes first took 2 s on one core).
        let mut nodes: Vec<Node> = bytemuck::zeroed_vec(node_count(faces.len()));
        Bvh::build(faces, &mut entries, 0, &mut nodes, 0, parallel_min);
        Bvh { nodes, order: entries.iter().map(|e| e.id).collect() }
    }

    /// Writes the subtree over `ids` (at `offset` in the order) to `nodes`,
    /// exactly its [`node_count`] long, whose first node has index `base`:
    /// the node, then its left subtree, then its right one. A leaf's box and
    /// depth come from its faces, an inner node's from its children's: the
    /// faces are read once, not once a level.
    fn build(faces: &[Occluder], ids: &mut [Entry], offset: usize, nodes: &mut [Node], base: usize, parallel_min: usize) {
        let (me, below) = nodes.split_first_mut().expect("a subtree has a node");
        if ids.len() <= LEAF {
            let (mut lo, mut hi, mut zmin) = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY), f64::INFINITY);
            for e in ids.iter() {
                let f = &faces[e.id as usize];
                lo = lo.min(f.lo);
                hi = hi.max(f.hi);
                zmin = zmin.min(f.zmin);
            }
            *me = Node { lo, hi, zmin, start: offset as u32, count: ids.len() as u32 };
            return;
        }
        let axis = split_axis(ids);
        let (len, mid) = (ids.len(), ids.len() / 2);
        ids.select_nth_unstable_by(mid, |a, b| a.key[axis].total_cmp(&b.key[axis]));
        let (left, right) = ids.split_at_mut(mid);
        let (left_nodes, right_nodes) = below.split_at_mut(node_count(mid));
        let right_base = base + 1 + left_nodes.len();
        let mut build_left = || Bvh::build(faces, left, offset, left_nodes, base + 1, parallel_min);
        let mut build_right = || Bvh::build(faces, right, offset + mid, right_nodes, right_base, parallel_min);
        if len >= parallel_min {
            rayon::join(build_left, build_right);
        } else {
            build_left();
            build_right();
        }
        let (l, r) = (left_nodes[0], right_nodes[0]);
        *me = Node { lo: l.lo.min(r.lo), hi: l.hi.max(r.hi), zmin: l.zmin.min(r.zmin), start: right_base as u32, count: 0 };
    }

    /// Calls `f` with every face whose box (padded by `pad`) the segment
    /// `a`-`b` may meet and whose nearest depth is at most `zmax`.
    #[allow(clippy::too_many_arguments)]
    pub fn visit_segment(
        &self,
        faces: &[Occluder],
        a: DVec2,
        b: DVec2,
        zmax: f64,
        pad: f64,
        stack: &mut Vec<usize>,
        mut f: impl FnMut(u32),
    ) {
        if self.nodes.is_empty() {
            return;
        }
        let (slo, shi) = (a.min(b) - pad, a.max(b) + pad);
        let d = b - a;
        let len = d.length();
        // The segment's line separates a box when all four corners lie on
        // one side of it, beyond the padding.
        let misses = |lo: DVec2, hi: DVec2| {
            if len == 0.0 {
                return false;
            }
            let s = |p: DVec2| d.perp_dot(p - a) / len;
            let c = [s(lo), s(DVec2::new(hi.x, lo.y)), s(hi), s(DVec2::new(lo.x, hi.y))];
            c.iter().all(|&v| v > pad) || c.iter().all(|&v| v < -pad)
        };
        let skip = |zmin: f64, lo: DVec2, hi: DVec2| zmin > zmax || lo.cmpgt(shi).any() || hi.cmplt(slo).any() || misses(lo, hi);
        stack.clear();
        stack.push(0);
        while let Some(n) = stack.pop() {
            let node = &self.nodes[n];
            if skip(node.zmin, node.lo, node.hi) {
                continue;
            }
            if node.count > 0 {
                for &i in &self.order[node.start as usize..(node.start + node.count) as usize] {
                    let face = &faces[i as usize];
                    if !skip(face.zmin, face.lo, face.hi) {
                        f(i);
                    }
                }
            } else {
                stack.push(node.start as usize);
                stack.push(n + 1);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    fn occ(lo: (f64, f64), hi: (f64, f64), zmin: f64) -> Occluder {
        Occluder {
            id: 0,
            rings: (0, 0),
            lo: DVec2::new(lo.0, lo.1),
            hi: DVec2::new(hi.0, hi.1),
            zmin,
            normal: DVec3::Z,
            offset: 0.0,
            eye_side: 1.0,
        }
    }

    fn visited(b: &Bvh, faces: &[Occluder], a: (f64, f64), c: (f64, f64), zmax: f64) -> Vec<u32> {
        let mut v = Vec::new();
        b.visit_segment(faces, DVec2::new(a.0, a.1), DVec2::new(c.0, c.1), zmax, 1e-9, &mut Vec::new(), |i| v.push(i));
        v.sort_unstable();
        v
    }

    #[test]
    fn finds_the_faces_the_segment_meets_and_no_others() {
        let faces: Vec<Occluder> = (0..10)
            .flat_map(|i| (0..10).map(move |j| occ((i as f64, j as f64), (i as f64 + 0.5, j as f64 + 0.5), (i + j) as f64)))
            .collect();
        let b = Bvh::new(&faces);
        let v = visited(&b, &faces, (0.1, 0.1), (9.4, 9.4), f64::INFINITY);
        assert_eq!(v, (0..10).map(|i| i * 11).collect::<Vec<u32>>(), "exactly the diagonal squares");
        // Depth rejection: only squares starting at depth <= 6.
        let v = visited(&b, &faces, (0.1, 0.1), (9.4, 9.4), 6.0);
        assert_eq!(v, vec![0, 11, 22, 33]);
        // A point, a vertical line touching box sides, and a miss.
        assert_eq!(visited(&b, &faces, (7.2, 7.2), (7.2, 7.2), f64::INFINITY), vec![77]);
        assert_eq!(visited(&b, &faces, (3.5, 0.0), (3.5, 1.0), f64::INFINITY), vec![30, 31]);
        assert!(visited(&b, &faces, (20.0, 20.0), (30.0, 30.0), f64::INFINITY).is_empty());
        assert!(Bvh::new(&[]).nodes.is_empty());
        assert!(visited(&Bvh::new(&[]), &[], (0.0, 0.0), (1.0, 1.0), 1.0).is_empty());
    }

    /// Boxes of pseudo-random places and sizes, some stacked on one centre.
    fn scattered(n: usize) -> Vec<Occluder> {
        let mut x: u64 = 0x9e37_79b9_7f4a_7c15;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 11) as f64 / (1u64 << 53) as f64
        };
        (0..n)
            .map(|i| {
                let (cx, cy) = if i % 7 == 0 { (0.5, 0.5) } else { (next(), next()) };
                let (w, h) = (0.05 * next(), 0.05 * next());
                occ((cx - w, cy - h), (cx + w, cy + h), next())
            })
            .collect()
    }

    #[test]
    fn node_count_is_that_of_the_median_splits() {
        fn by_splitting(n: usize) -> usize {
            if n <= LEAF {
                1
            } else {
                1 + by_splitting(n / 2) + by_splitting(n - n / 2)
            }
        }
        for n in 1..3000 {
            assert_eq!(node_count(n), by_splitting(n), "{n} faces");
        }
        assert_eq!(node_count(10_000_000), by_splitting(10_000_000));
    }

    /// The box and nearest depth of the faces `ids`, and the axis along
    /// which their centres spread most.
    fn extent(faces: &[Occluder], ids: &[u32]) -> (DVec2, DVec2, f64, usize) {
        let (mut lo, mut hi) = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
        let (mut clo, mut chi) = (lo, hi);
        let mut zmin = f64::INFINITY;
        for &i in ids {
            let f = &faces[i as usize];
            lo = lo.min(f.lo);
            hi = hi.max(f.hi);
            let c = (f.lo + f.hi) * 0.5;
            clo = clo.min(c);
            chi = chi.max(c);
            zmin = zmin.min(f.zmin);
        }
        let axis = if chi.x - clo.x >= chi.y - clo.y { 0 } else { 1 };
        (lo, hi, zmin, axis)
    }

    /// The tree as it was built before the node array was laid out ahead:
    /// each node pushed when its subtree starts, on one thread, every node's
    /// box and split read from the faces themselves.
    fn pushed(faces: &[Occluder]) -> Bvh {
        fn build(nodes: &mut Vec<Node>, faces: &[Occluder], ids: &mut [u32], offset: usize) -> usize {
            let (lo, hi, zmin, axis) = extent(faces, ids);
            let me = nodes.len();
            nodes.push(Node { lo, hi, zmin, start: offset as u32, count: ids.len() as u32 });
            if ids.len() <= LEAF {
                return me;
            }
            let key = |i: &u32| (faces[*i as usize].lo + faces[*i as usize].hi)[axis];
            let mid = ids.len() / 2;
            ids.select_nth_unstable_by(mid, |a, b| key(a).total_cmp(&key(b)));
            let (left, right) = ids.split_at_mut(mid);
            build(nodes, faces, left, offset);
            let r = build(nodes, faces, right, offset + mid);
            nodes[me].start = r as u32;
            nodes[me].count = 0;
            me
        }
        let mut order: Vec<u32> = (0..faces.len() as u32).collect();
        let mut nodes = Vec::new();
        if !faces.is_empty() {
            build(&mut nodes, faces, &mut order, 0);
        }
        Bvh { nodes, order }
    }

    #[test]
    fn halves_built_at_once_make_the_same_tree() {
        for n in [1, 4, 5, 9, 100, 1000, 5000] {
            let faces = scattered(n);
            let one_thread = pushed(&faces);
            assert_eq!(Bvh::built(&faces, usize::MAX).nodes, one_thread.nodes, "{n} faces on one thread");
            for parallel_min in [2, 8, 64] {
                let both = Bvh::built(&faces, parallel_min);
                assert_eq!(both.nodes, one_thread.nodes, "{n} faces, halves at once from {parallel_min}");
                assert_eq!(both.order, one_thread.order, "{n} faces, halves at once from {parallel_min}");
            }
            assert_eq!(one_thread.nodes.len(), node_count(n));
        }
    }
}
