//! A bounding-volume hierarchy over the occluders in screen space, with the
//! nearest depth of each subtree: a line visits only the faces whose boxes
//! its segment meets and that start in front of its farthest point
//! (Griffith's buckets and depth rejection, adaptive to where faces crowd,
//! such as near a horizon).

use glam::DVec2;

use super::faces::Occluder;

/// Faces per leaf: small, since testing a face is far dearer than a node.
const LEAF: usize = 4;

#[derive(Clone, Copy, Debug)]
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

impl Bvh {
    /// Builds by median splits along the longer axis of the box centres.
    pub fn new(faces: &[Occluder]) -> Bvh {
        let mut bvh = Bvh { nodes: Vec::with_capacity(faces.len() / 2 + 1), order: (0..faces.len() as u32).collect() };
        if !faces.is_empty() {
            let mut order = std::mem::take(&mut bvh.order);
            bvh.build(faces, &mut order, 0);
            bvh.order = order;
        }
        bvh
    }

    fn build(&mut self, faces: &[Occluder], ids: &mut [u32], offset: usize) -> usize {
        let (mut lo, mut hi) = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
        let (mut clo, mut chi) = (lo, hi);
        let mut zmin = f64::INFINITY;
        for &i in ids.iter() {
            let f = &faces[i as usize];
            lo = lo.min(f.lo);
            hi = hi.max(f.hi);
            let c = (f.lo + f.hi) * 0.5;
            clo = clo.min(c);
            chi = chi.max(c);
            zmin = zmin.min(f.zmin);
        }
        let me = self.nodes.len();
        self.nodes.push(Node { lo, hi, zmin, start: offset as u32, count: ids.len() as u32 });
        if ids.len() <= LEAF {
            return me;
        }
        let axis = if chi.x - clo.x >= chi.y - clo.y { 0 } else { 1 };
        let key = |i: &u32| {
            let f = &faces[*i as usize];
            (f.lo + f.hi)[axis]
        };
        let mid = ids.len() / 2;
        ids.select_nth_unstable_by(mid, |a, b| key(a).total_cmp(&key(b)));
        let (left, right) = ids.split_at_mut(mid);
        self.build(faces, left, offset);
        let r = self.build(faces, right, offset + mid);
        self.nodes[me].start = r as u32;
        self.nodes[me].count = 0;
        me
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
}
