//! What the hidden-line engine works on: planar faces that hide, and straight
//! lines that are drawn, in world space; and what it answers: the visible
//! parameter intervals of every line in device space.
//!
//! Scene objects (meshes, inline polygons, free polylines, surfaces, map
//! symbols) are all lowered to a [`Model`] before the engine sees them, so the
//! engine knows nothing about files or object kinds.

use glam::{DVec2, DVec3};

/// A planar polygon that hides what lies behind it. Convex or concave, with any
/// number of holes; vertex order (orientation) carries no meaning unless
/// `outward` says so.
#[derive(Clone, Debug, PartialEq)]
pub struct Face {
    /// Outer boundary, at least three vertices, implicitly closed.
    pub outer: Vec<DVec3>,
    /// Inner boundaries (holes), each implicitly closed.
    pub holes: Vec<Vec<DVec3>>,
    /// Pen for the lines where this face penetrates another.
    pub pen: u32,
    /// True only when the face belongs to a closed, consistently oriented mesh
    /// and `outer` winds counter-clockwise seen from outside. Lets the engine
    /// skip faces turned away from the eye; never needed for correctness.
    pub outward: bool,
}

/// A straight line to draw, hidden by faces.
#[derive(Clone, Debug, PartialEq)]
pub struct Edge {
    /// One end, world space.
    pub a: DVec3,
    /// Other end, world space.
    pub b: DVec3,
    /// Pen it is drawn with.
    pub pen: u32,
    /// Indices into [`Model::faces`] of faces this line lies on (a mesh edge's
    /// adjacent faces): those faces never hide it. Empty for free lines.
    pub faces: Vec<u32>,
}

/// Everything the engine needs besides the camera.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Model {
    /// Occluders.
    pub faces: Vec<Face>,
    /// Lines to draw.
    pub edges: Vec<Edge>,
}

/// Where a line of the answer came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum LineSource {
    /// `Model::edges[i]`.
    Edge(u32),
    /// The line along which faces `i` and `j` (`i < j`) penetrate each other.
    Intersection(u32, u32),
}

/// The visibility of one line, in device space (see [`crate::camera`]).
#[derive(Clone, Debug, PartialEq)]
pub struct LineVisibility {
    /// The line this answers for.
    pub source: LineSource,
    /// Pen to draw it with.
    pub pen: u32,
    /// Device-space start of the part in front of the near plane.
    pub a: DVec2,
    /// Device-space end of that part.
    pub b: DVec2,
    /// Sorted, disjoint parameter intervals `(t0, t1)` of `a + t (b - a)` that
    /// are visible; the rest of `[0, 1]` is hidden.
    pub visible: Intervals,
}

/// Parameter intervals of a line. Almost every line is wholly visible,
/// wholly hidden or cut once or twice, so up to two are held inline: a grid
/// of a million edges answers without a heap allocation per edge.
pub type Intervals = smallvec::SmallVec<[(f64, f64); 2]>;
