//! Collects the faces and edges every scene object lowers to into one
//! [`Model`], drawing each line once.

use crate::model::{Edge, Face, Model};
use glam::DVec3;
use std::collections::HashMap;

/// Builds a [`Model`] from the lowerings of all scene objects.
///
/// Edges are deduplicated exactly: the same segment (same endpoints, bit for
/// bit, either direction) added twice is drawn once, and lies on the union of
/// the faces both additions named. This is what makes two `[[polygon]]`s that
/// share an edge draw it once.
#[derive(Debug, Default)]
pub struct ModelBuilder {
    model: Model,
    edge_index: HashMap<[u64; 6], usize>,
}

fn key(a: DVec3, b: DVec3) -> [u64; 6] {
    let (ka, kb) = (a.to_array().map(f64::to_bits), b.to_array().map(f64::to_bits));
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
    /// line already present gets `faces` added to its own.
    pub fn add_edge(&mut self, a: DVec3, b: DVec3, pen: u32, faces: &[u32]) {
        if a == b {
            return;
        }
        match self.edge_index.get(&key(a, b)) {
            Some(&i) => {
                let e = &mut self.model.edges[i];
                for f in faces {
                    if !e.faces.contains(f) {
                        e.faces.push(*f);
                    }
                }
            }
            None => {
                self.edge_index.insert(key(a, b), self.model.edges.len());
                self.model.edges.push(Edge { a, b, pen, faces: faces.to_vec() });
            }
        }
    }

    /// Faces added so far.
    #[must_use]
    pub fn face_count(&self) -> usize {
        self.model.faces.len()
    }

    /// The finished model.
    #[must_use]
    pub fn finish(self) -> Model {
        self.model
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
