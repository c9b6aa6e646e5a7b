//! Collects the faces and edges every scene object lowers to into one
//! [`Model`], drawing each line once.

use crate::geometry::RingFit;
use crate::tolerance::COPLANAR_ANGLE;
use glam::DVec3;
use hiddenline::model::{Edge, Face, Model};

/// Builds a [`Model`] from the lowerings of all scene objects.
///
/// Edges are deduplicated exactly: the same segment (same endpoints, bit for
/// bit, either direction) added twice is drawn once, and lies on the union of
/// the faces both additions named. This is what makes two `[[polygon]]`s that
/// share an edge draw it once; and when those are exactly two coplanar faces
/// continuing each other across it (a floor made of two rectangles), the edge
/// is not drawn at all, as inside a mesh.
#[derive(Debug, Default)]
pub struct ModelBuilder {
    model: Model,
}

/// Order-independent identity of a segment: its endpoints' bits, smaller first.
fn key(e: &Edge) -> [u64; 6] {
    let (ka, kb) = (e.a.to_array().map(f64::to_bits), e.b.to_array().map(f64::to_bits));
    let (lo, hi) = if ka <= kb { (ka, kb) } else { (kb, ka) };
    [lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]]
}

impl ModelBuilder {
    /// An empty builder.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds an occluding face; returns its index in [`Model::faces`].
    pub fn add_face(&mut self, face: Face) -> u32 {
        self.model.faces.push(face);
        (self.model.faces.len() - 1) as u32
    }

    /// Adds a line to draw, lying on `faces`. Zero-length lines are dropped; a
    /// line added more than once is kept once (where first added, with its
    /// first pen), lying on all the faces its additions named.
    pub fn add_edge(&mut self, a: DVec3, b: DVec3, pen: u32, faces: &[u32]) {
        if a != b {
            self.model.edges.push(Edge { a, b, pen, faces: faces.to_vec() });
        }
    }

    /// Faces added so far.
    #[must_use]
    pub fn face_count(&self) -> usize {
        self.model.faces.len()
    }

    /// The finished model: duplicate edges merged (found by sorting, which
    /// stays fast and small for millions of edges), and edges between two
    /// coplanar faces of separate additions that continue each other dropped.
    #[must_use]
    pub fn finish(mut self) -> Model {
        let edges = &mut self.model.edges;
        let mut order: Vec<u32> = (0..edges.len() as u32).collect();
        order.sort_unstable_by_key(|&i| (key(&edges[i as usize]), i));
        let mut keep = vec![true; edges.len()];
        let mut merged = vec![false; edges.len()];
        let mut first = 0usize;
        for j in 1..order.len() {
            let (f, i) = (order[first] as usize, order[j] as usize);
            if key(&edges[f]) != key(&edges[i]) {
                first = j;
                continue;
            }
            // A duplicate of the run's first (lowest-index) edge: merge into it.
            let faces = std::mem::take(&mut edges[i].faces);
            for face in faces {
                if !edges[f].faces.contains(&face) {
                    edges[f].faces.push(face);
                }
            }
            keep[i] = false;
            merged[f] = true;
        }
        let faces = &self.model.faces;
        let mut index = 0..;
        edges.retain(|e| {
            let i = index.next().unwrap_or(0);
            let flat = match (merged[i], e.faces.as_slice()) {
                (true, &[f, g]) => match (faces.get(f as usize), faces.get(g as usize)) {
                    (Some(f), Some(g)) => flat_across(e.a, e.b, f, g),
                    _ => false,
                },
                _ => false,
            };
            keep[i] && !flat
        });
        self.model
    }
}

/// True when faces `f` and `g`, both holding the segment `a`-`b`, lie in one
/// plane on opposite sides of it (so the segment is no edge of their union).
fn flat_across(a: DVec3, b: DVec3, f: &Face, g: &Face) -> bool {
    let (Some(nf), Some(ng)) = (RingFit::of(&f.outer).normal(), RingFit::of(&g.outer).normal()) else {
        return false;
    };
    if nf.cross(ng).length() > COPLANAR_ANGLE {
        return false;
    }
    // Which side of the line a-b (within the common plane) a face extends to:
    // the sign of its farthest vertex from the line.
    let d = b - a;
    let side = |face: &Face| {
        let off = |p: &DVec3| d.cross(*p - a).dot(nf);
        face.outer.iter().map(off).fold(0.0, |m: f64, x| if x.abs() > m.abs() { x } else { m })
    };
    side(f) * side(g) < 0.0
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(pts: [(f64, f64, f64); 4]) -> Face {
        Face { outer: pts.iter().map(|&(x, y, z)| DVec3::new(x, y, z)).collect(), holes: vec![], pen: 1, outward: false }
    }

    #[test]
    fn coplanar_faces_of_separate_objects_hide_their_shared_edge() {
        let (p, q) = (DVec3::ZERO, DVec3::Y);
        for (second, drawn) in [
            // Flat continuation on the other side: not drawn.
            (square([(0., 0., 0.), (0., 1., 0.), (-1., 1., 0.), (-1., 0., 0.)]), 0),
            // Folded up at 90 degrees: drawn.
            (square([(0., 0., 0.), (0., 1., 0.), (0., 1., 1.), (0., 0., 1.)]), 1),
            // Coplanar but overlapping (same side): drawn.
            (square([(0., 0., 0.), (0., 1., 0.), (0.5, 1., 0.), (0.5, 0., 0.)]), 1),
        ] {
            let mut b = ModelBuilder::new();
            let f = b.add_face(square([(0., 0., 0.), (1., 0., 0.), (1., 1., 0.), (0., 1., 0.)]));
            let g = b.add_face(second);
            b.add_edge(p, q, 1, &[f]);
            b.add_edge(q, p, 1, &[g]);
            b.add_edge(p, DVec3::X, 1, &[f]);
            let m = b.finish();
            assert_eq!(m.edges.len(), 1 + drawn);
        }
    }

    #[test]
    fn shared_edges_are_drawn_once_on_both_faces() {
        let mut b = ModelBuilder::new();
        let (p, q) = (DVec3::ZERO, DVec3::X);
        b.add_edge(p, q, 1, &[0]);
        b.add_edge(q, p, 2, &[1, 0]);
        b.add_edge(p, p, 1, &[]);
        b.add_edge(p, DVec3::Y, 1, &[]);
        let m = b.finish();
        assert_eq!(m.edges.len(), 2);
        assert_eq!(m.edges[0].faces, vec![0, 1]);
        assert_eq!(m.edges[0].pen, 1);
    }
}
