//! The tolerances and limits of scene loading and lowering, in one place.
//!
//! Which predicates are exact and which are not:
//! - Vertex welding and edge sharing are exact: two vertices are the same point
//!   only when their coordinates are bit-identical (mesh files repeat exact
//!   text, so shared corners parse to identical numbers).
//! - Planarity, degeneracy and coplanarity use the relative tolerances below,
//!   scaled by the size of the face, because coordinates typed in decimal
//!   (or rotated by a transform) are never exactly planar.

/// A face is planar when no vertex lies farther from its best plane (the Newell
/// plane through the centroid) than this fraction of the face's size (the
/// diagonal of its bounding box). OBJ files print about 6 significant digits;
/// 1e-5 accepts their rounding and rejects anything a viewer could see.
pub const PLANARITY_REL: f64 = 1e-5;

/// A face planar within the precision its file was written with is planar:
/// its vertices may lie off its plane by this many times the rounding of one
/// coordinate (half a unit of the last digit written). A vertex moves by up
/// to sqrt(3) roundings, and the Newell plane through the centroid of the
/// rounded ring may lie a further such amount off the true plane: 4 x sqrt(3)
/// covers both with room.
pub const ROUNDING_FACTOR: f64 = 7.0;

/// ... but never more than this fraction of the face's size: coordinates
/// written with few digits (a hand-typed integer file) are taken as meant,
/// and a face folded by more than this is folded.
pub const ROUNDING_MAX_REL: f64 = 5e-3;

/// Two planar faces sharing an edge are coplanar when the angle between
/// their normals is within what the rounding of their coordinates can turn
/// them by: this many roundings over each face's size, summed
/// (`mesh::coplanar_angle`). A well-shaped face's vertices each off by up
/// to a rounding turn its normal by up to about 4 roundings over its size;
/// two triangles of a rounded planar quad (a UV sphere's, a paraboloid's)
/// then keep their diagonal hidden, and the long thin triangles of a finely
/// tessellated cylinder (large, and folded by far more) keep their edges.
pub const ROUNDING_TURN: f64 = 4.0;

/// A face is planar to machine precision, and hides as one polygon, when no
/// vertex lies farther than this fraction of its size from its Newell plane;
/// a face planar only within the rounding hides as a triangulation of its own
/// vertices, so every face the engine sees is planar within the engine's
/// `PLANE_REL` of the scene size (1e-9), with two orders of magnitude room.
pub const EXACT_PLANAR_REL: f64 = 1e-11;

/// A face is degenerate (zero area, skipped with a warning) when its area is
/// below this fraction of the square of its size.
pub const DEGENERATE_AREA_REL: f64 = 1e-12;

/// Two faces sharing an edge are coplanar (the edge is not drawn) when the
/// angle between their normals, made consistent across the edge, is below this
/// many radians (about 0.006 degrees).
pub const COPLANAR_ANGLE: f64 = 1e-4;

/// Largest scene file read, bytes.
pub const MAX_SCENE_BYTES: u64 = 16 << 20;

/// Largest mesh file read, bytes (a binary STL of 10^7 triangles is 500 MB).
pub const MAX_MESH_BYTES: u64 = 1 << 30;

/// Most faces (after splitting) a whole scene may lower to.
pub const MAX_FACES: usize = 20_000_000;

/// Largest magnitude of any world coordinate, after transforms, projection,
/// scale and offset (vertices, points, the camera's eye and target, grid
/// points and heights, map outlines and places, symbol heights). Scenes
/// come in any unit, so this is generous (UTM metres fit), yet it keeps the
/// engines' arithmetic (cell sizes, products of coordinates) far from
/// overflow: a town at longitude -1e308 looped forever, a point at 1e10
/// beside a sphere took gigabytes.
pub const MAX_COORDINATE: f64 = 1e9;

/// The first component of `p` beyond [`MAX_COORDINATE`] (or not finite).
#[must_use]
pub fn beyond_limit(p: glam::DVec3) -> Option<f64> {
    p.to_array().into_iter().find(|c| !(c.abs() <= MAX_COORDINATE))
}

/// Most vertices one polygon or polyline may have.
pub const MAX_POLYGON_VERTICES: usize = 1_000_000;
