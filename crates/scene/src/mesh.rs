//! `[[mesh]]`: a polygon mesh from an OBJ or STL file, its topology (which
//! faces share which edge), and its lowering to faces and edges.
//!
//! Rules (issues 2 and 16):
//! - Faces are planar polygons, convex or concave. Whether a face is planar
//!   is decided once, here, within the precision its file was written with
//!   ([`planarity_tolerance`]: a quad written with 6 decimals is a hair off
//!   planar and still planar), and every stage uses that one decision: a
//!   planar face has one normal for creases and silhouettes, draws no inner
//!   edge, and hides as itself (as a triangulation of its own vertices when
//!   it is planar only within the rounding, so that every face the engine
//!   sees is planar to machine precision).
//! - A face that is not planar (a height field's quad) hides as the fan of
//!   triangles from its first vertex (v0-v2, v0-v3, ...); only its outline is
//!   drawn.
//! - An edge is drawn once however many faces share it, and lies on all of
//!   them. An edge between exactly two coplanar faces is not drawn; two
//!   planar faces are coplanar when their normals agree within what the
//!   rounding can turn faces of their size by ([`coplanar_angle`], at least
//!   [`COPLANAR_ANGLE`]), never merely because their vertices lie within the
//!   rounding of each other's plane: the small triangles of a finely
//!   tessellated curve do, and their edges are drawn.
//! - `edges = "feature"` draws boundaries, edges of more than two faces,
//!   creases sharper than `crease_deg` and silhouettes (one face turned to the
//!   eye, the other away), the last depending on the camera.
//! - Orientation is decided per shell (faces connected through shared
//!   edges), never assumed from vertex order: a shell's faces are marked
//!   `outward` (back-face culling allowed) only when the shell is closed and
//!   consistently oriented, every edge used by exactly two of its faces in
//!   opposite directions; its outer rings are then wound counter-clockwise
//!   seen from outside (flipped if the file winds that shell inward). Shells
//!   of one file may be wound either way.

use crate::builder::ModelBuilder;
use crate::geometry::RingFit;
use crate::tolerance::{COPLANAR_ANGLE, EXACT_PLANAR_REL, ROUNDING_FACTOR, ROUNDING_MAX_REL, ROUNDING_TURN};
use crate::transform::Transform;
use glam::DVec3;
use hiddenline::camera::{Camera, Projection};
use hiddenline::model::Face;
use rayon::prelude::*;
use serde::Deserialize;
use std::path::PathBuf;

/// A `[[mesh]]` table as written in the scene file.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshSpec {
    /// OBJ or STL file, relative to the scene file.
    pub path: PathBuf,
    /// Placement in the world.
    #[serde(default)]
    pub transform: Option<Transform>,
    /// Which edges to draw.
    #[serde(default)]
    pub edges: EdgeChoice,
    /// With `edges = "feature"`: creases sharper than this are drawn, degrees.
    #[serde(default = "default_crease")]
    pub crease_deg: f64,
    /// Pen for the mesh's lines.
    #[serde(default = "default_pen")]
    pub pen: u32,
}

fn default_crease() -> f64 {
    30.0
}

pub(crate) fn default_pen() -> u32 {
    1
}

/// The `edges` key of a mesh.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum EdgeChoice {
    /// Every polygon edge, except those between coplanar faces.
    #[default]
    All,
    /// Silhouettes, boundaries and creases only.
    Feature,
}

/// Which edges of a mesh are drawn.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum EdgeStyle {
    /// Every edge except those between two coplanar faces.
    All,
    /// Boundaries, non-manifold edges, creases sharper than `crease` radians,
    /// silhouettes.
    Feature {
        /// Crease threshold, radians.
        crease: f64,
    },
}

/// One polygon of a mesh.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshFace {
    /// Vertex indices, at least three, no two consecutive ones equal.
    pub vertices: Vec<u32>,
    /// False when the polygon is not planar within the precision its file
    /// was written with: it hides as a fan of triangles.
    pub planar: bool,
    /// True when the polygon is planar to machine precision: it hides as one
    /// polygon. A planar face that is not exact hides as a triangulation of
    /// its own vertices.
    pub exact: bool,
    /// Unit normal of the polygon's (Newell) plane, counter-clockwise winding
    /// seen from its tip.
    pub normal: DVec3,
}

/// One side of an edge: a face it bounds.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Side {
    /// Index into `Mesh::faces`.
    face: u32,
    /// The edge runs from `vertices[k]` to `vertices[k + 1]` of that face.
    k: u32,
    /// True when that face traverses the edge from `Edge::a` to `Edge::b`.
    forward: bool,
}

/// An undirected edge of the mesh; its sides are `Mesh::sides[start..start + len]`
/// (one flat array: a million-face mesh has 1.5 million edges, and a small
/// vector each would cost more than the mesh).
#[derive(Clone, Copy, Debug, PartialEq)]
struct MeshEdge {
    a: u32,
    b: u32,
    start: u32,
    len: u32,
}

/// A loaded mesh in world coordinates, with its topology worked out.
///
/// Built by the `[[mesh]]` loader, and usable by any object kind that makes
/// polyhedra (map symbols, boxes): build one with [`Mesh::new`] and call
/// [`Mesh::lower`].
#[derive(Clone, Debug)]
pub struct Mesh {
    /// Vertices, world space, welded (bit-identical positions merged).
    pub vertices: Vec<DVec3>,
    /// Non-degenerate faces.
    pub faces: Vec<MeshFace>,
    /// Which edges to draw.
    pub style: EdgeStyle,
    /// Pen for all lines of the mesh.
    pub pen: u32,
    /// Half a unit of the last digit the coordinates were written with,
    /// world units (0 for exact input): planarity allows for this rounding.
    rounding: f64,
    edges: Vec<MeshEdge>,
    sides: Vec<Side>,
    /// Per face: `Some(flip)` when its shell is closed and consistently
    /// oriented; `flip` when that shell winds inward and must be reversed to
    /// wind counter-clockwise seen from outside.
    orientation: Vec<Option<bool>>,
}

impl Mesh {
    /// Builds a mesh from vertices and polygons (indices into `vertices`).
    /// `name` appears in warnings. Polygons that are degenerate (fewer than
    /// three distinct vertices, zero area) or name missing vertices are skipped
    /// with a warning; vertices must be finite.
    #[must_use]
    pub fn new(name: &str, vertices: Vec<DVec3>, polygons: Vec<Vec<u32>>, style: EdgeStyle, pen: u32) -> Mesh {
        Mesh::rounded(name, vertices, polygons, 0.0, style, pen)
    }

    /// [`Mesh::new`] for coordinates that were rounded when written: each is
    /// within `rounding` (world units) of the true value, and a face planar
    /// before the rounding is planar ([`planarity_tolerance`]).
    #[must_use]
    pub fn rounded(name: &str, vertices: Vec<DVec3>, mut polygons: Vec<Vec<u32>>, rounding: f64, style: EdgeStyle, pen: u32) -> Mesh {
        let rounding = if rounding.is_finite() && rounding > 0.0 { rounding } else { 0.0 };
        let (vertices, remap) = weld(vertices);
        let mut faces = Vec::with_capacity(polygons.len());
        let mut skipped = 0usize;
        // Each face is checked on its own, a window of them at a time in
        // parallel (ten million faces took 3.5 s on one core, most of it
        // faulting in their memory), and kept or warned of in file order.
        for (w, window) in polygons.chunks_mut(FACE_WINDOW).enumerate() {
            let checked: Vec<Result<MeshFace, FaceFault>> =
                window.par_iter_mut().map(|poly| checked_face(std::mem::take(poly), &vertices, &remap, rounding)).collect();
            for (k, face) in checked.into_iter().enumerate() {
                let i = w * FACE_WINDOW + k;
                match face {
                    Ok(face) => faces.push(face),
                    Err(FaceFault::MissingVertex) => {
                        tracing::warn!("{name}: face {i} names a vertex that does not exist; skipped");
                        skipped += 1;
                    }
                    Err(FaceFault::Degenerate) => {
                        if skipped < 10 {
                            tracing::warn!("{name}: face {i} is degenerate (zero area); skipped");
                        }
                        skipped += 1;
                    }
                }
            }
        }
        drop(polygons);
        if skipped >= 10 {
            tracing::warn!("{name}: {skipped} degenerate faces skipped in all");
        }
        let mut mesh = Mesh { vertices, faces, style, pen, rounding, edges: Vec::new(), sides: Vec::new(), orientation: Vec::new() };
        (mesh.edges, mesh.sides) = mesh.build_edges();
        mesh.orientation = mesh.find_orientation();
        mesh
    }

    /// True when every shell of the mesh is closed and consistently
    /// oriented, so all its faces are marked `outward`.
    #[must_use]
    pub fn is_closed_oriented(&self) -> bool {
        !self.faces.is_empty() && self.orientation.iter().all(Option::is_some)
    }

    /// Faces this mesh lowers to, at most: one per exactly planar face, a
    /// triangle per vertex beyond two for the others.
    #[must_use]
    pub fn model_face_count(&self) -> usize {
        self.faces.iter().map(|f| if f.planar && f.exact { 1 } else { f.vertices.len() - 2 }).sum()
    }

    /// Number of distinct edges.
    #[must_use]
    pub fn edge_count(&self) -> usize {
        self.edges.len()
    }

    /// Unit normal of the (sub-)face of face `f` that holds its edge `k`.
    fn side_normal(&self, f: &MeshFace, k: usize) -> DVec3 {
        let n = f.vertices.len();
        let p = |i: usize| self.vertices[f.vertices[i] as usize];
        if f.planar {
            return f.normal;
        }
        let t = fan_triangle(k, n);
        (p(t + 1) - p(0)).cross(p(t + 2) - p(0)).normalize_or_zero()
    }

    /// Groups the sides of all faces by undirected edge. Sorting, not hashing:
    /// a million-face mesh has three million sides, and a hash table that size
    /// is all cache misses. Edges come out in order of first appearance, so
    /// a face's edges stay together (they chain into polylines later).
    fn build_edges(&self) -> (Vec<MeshEdge>, Vec<Side>) {
        let total: usize = self.faces.iter().map(|f| f.vertices.len()).sum();
        // (edge key, index into `all`), sorted: equal edges become adjacent,
        // each run in order of appearance.
        let mut keyed: Vec<(u64, u32)> = Vec::with_capacity(total);
        let mut all: Vec<Side> = Vec::with_capacity(total);
        for (fi, f) in self.faces.iter().enumerate() {
            let n = f.vertices.len();
            for k in 0..n {
                let (u, v) = (f.vertices[k], f.vertices[(k + 1) % n]);
                let (a, b) = (u.min(v), u.max(v));
                keyed.push(((u64::from(a) << 32) | u64::from(b), all.len() as u32));
                all.push(Side { face: fi as u32, k: k as u32, forward: u == a });
            }
        }
        // Keys are unique (the index breaks ties), so the parallel sort is
        // deterministic (ten million faces: 2.5 s on one core).
        keyed.par_sort_unstable();
        let sides: Vec<Side> = keyed.par_iter().map(|&(_, i)| all[i as usize]).collect();
        drop(all);
        // (first appearance, edge) per run of equal keys.
        let mut edges: Vec<(u32, MeshEdge)> = Vec::new();
        for (i, &(key, seq)) in keyed.iter().enumerate() {
            if i > 0 && keyed[i - 1].0 == key {
                edges.last_mut().expect("a run is open").1.len += 1;
            } else {
                edges.push((seq, MeshEdge { a: (key >> 32) as u32, b: key as u32, start: i as u32, len: 1 }));
            }
        }
        edges.par_sort_unstable_by_key(|&(first, _)| first);
        (edges.into_iter().map(|(_, e)| e).collect(), sides)
    }

    fn sides_of(&self, e: &MeshEdge) -> &[Side] {
        &self.sides[e.start as usize..(e.start + e.len) as usize]
    }

    /// Per face, `Some(flip)` when its shell (the faces connected to it
    /// through shared edges) is closed and consistently oriented.
    fn find_orientation(&self) -> Vec<Option<bool>> {
        // Shells: union-find over faces joined by an edge.
        let mut parent: Vec<u32> = (0..self.faces.len() as u32).collect();
        fn root(parent: &mut [u32], mut f: u32) -> u32 {
            while parent[f as usize] != f {
                parent[f as usize] = parent[parent[f as usize] as usize];
                f = parent[f as usize];
            }
            f
        }
        for e in &self.edges {
            let sides = self.sides_of(e);
            for s in &sides[1..] {
                let (a, b) = (root(&mut parent, sides[0].face), root(&mut parent, s.face));
                parent[a.max(b) as usize] = a.min(b);
            }
        }
        let shell: Vec<u32> = (0..self.faces.len() as u32).map(|f| root(&mut parent, f)).collect();
        // A shell is consistent when each of its edges has exactly two
        // sides, in opposite directions.
        let mut consistent = vec![true; self.faces.len()];
        for e in &self.edges {
            let sides = self.sides_of(e);
            if !matches!(sides, [s, t] if s.forward != t.forward) {
                consistent[shell[sides[0].face as usize] as usize] = false;
            }
        }
        // Signed volume (times 6) of each shell by the divergence theorem,
        // relative to its first vertex for precision: positive when its
        // faces wind outward.
        let mut origin: Vec<Option<DVec3>> = vec![None; self.faces.len()];
        let mut volume = vec![0.0; self.faces.len()];
        for (fi, f) in self.faces.iter().enumerate() {
            let r = shell[fi] as usize;
            let c = *origin[r].get_or_insert(self.vertices[f.vertices[0] as usize]);
            let p = |i: usize| self.vertices[f.vertices[i] as usize] - c;
            for t in 1..f.vertices.len() - 1 {
                volume[r] += p(0).dot(p(t).cross(p(t + 1)));
            }
        }
        shell.iter().map(|&r| consistent[r as usize].then_some(volume[r as usize] < 0.0)).collect()
    }

    /// Whether two planar faces sharing an edge, their normals `fold`
    /// radians apart, are coplanar: within [`coplanar_angle`] of their sizes
    /// and the rounding.
    fn coplanar(&self, f: &MeshFace, g: &MeshFace, fold: f64) -> bool {
        let size = |h: &MeshFace| {
            let first = self.vertices[h.vertices[0] as usize];
            let (lo, hi) = h.vertices.iter().map(|&v| self.vertices[v as usize]).fold((first, first), |(lo, hi), p| (lo.min(p), hi.max(p)));
            lo.distance(hi)
        };
        fold <= coplanar_angle(size(f), size(g), self.rounding)
    }

    /// The model faces of face `fi` (`f`), wound outward where its shell is
    /// oriented; `cutter` and `triangles` are the ear clipper's buffers.
    fn model_faces(&self, fi: usize, f: &MeshFace, cutter: &mut earcut::Earcut<f64>, triangles: &mut Vec<u32>) -> ModelFaces {
        let pos = |v: u32| self.vertices[v as usize];
        let (flip, outward) = match self.orientation[fi] {
            Some(flip) => (flip, true),
            None => (false, false),
        };
        let face = |mut outer: Vec<DVec3>| {
            if RingFit::of(&outer).is_degenerate() {
                return None;
            }
            if flip {
                outer.reverse();
            }
            Some(Face { outer, holes: Vec::new(), pen: self.pen, outward })
        };
        let v = &f.vertices;
        if f.planar && f.exact {
            ModelFaces::One(face(v.iter().map(|&i| pos(i)).collect()))
        } else if f.planar {
            triangulate(cutter, f, &self.vertices, triangles);
            // Each triangle wound as the face is (the ear clipping winds
            // them its own way), so that `outward` stays true.
            let wound = |t: &[u32]| {
                let [a, b, c] = [0, 1, 2].map(|k| pos(v[t[k] as usize]));
                if (b - a).cross(c - a).dot(f.normal) < 0.0 {
                    vec![a, c, b]
                } else {
                    vec![a, b, c]
                }
            };
            ModelFaces::Many(triangles.chunks_exact(3).map(|t| face(wound(t))).collect())
        } else {
            ModelFaces::Many((0..v.len() - 2).map(|t| face(vec![pos(v[0]), pos(v[t + 1]), pos(v[t + 2])])).collect())
        }
    }

    /// Adds this mesh's faces and the edges it draws, seen by `camera`, to `out`.
    pub fn lower(&self, camera: &Camera, out: &mut ModelBuilder) {
        let pos = |v: u32| self.vertices[v as usize];
        // Model face indices of each mesh face, `fi`'s at
        // `pieces[first[fi]..first[fi + 1]]`: one for an exactly planar
        // face; its triangles for a face planar within the rounding; one per
        // fan triangle for a folded face (None for a degenerate triangle,
        // which hides nothing). The faces are made a window at a time in
        // parallel (ten million took 3.5 s on one core, most of it faulting
        // in their memory) and added in order.
        let mut first: Vec<usize> = Vec::with_capacity(self.faces.len() + 1);
        let mut pieces: Vec<Option<u32>> = Vec::with_capacity(self.faces.len());
        first.push(0);
        for (w, window) in self.faces.chunks(FACE_WINDOW).enumerate() {
            let made: Vec<ModelFaces> = window
                .par_iter()
                .enumerate()
                .map_init(
                    || (earcut::Earcut::new(), Vec::new()),
                    |(cutter, triangles), (k, f)| self.model_faces(w * FACE_WINDOW + k, f, cutter, triangles),
                )
                .collect();
            for faces in made {
                match faces {
                    ModelFaces::One(face) => pieces.push(face.map(|face| out.add_face(face))),
                    ModelFaces::Many(faces) => pieces.extend(faces.into_iter().map(|face| face.map(|face| out.add_face(face)))),
                }
                first.push(pieces.len());
            }
        }
        let pieces_of = |fi: usize| &pieces[first[fi]..first[fi + 1]];
        let toward = |n: DVec3, p: DVec3| match camera.projection {
            Projection::Perspective { .. } => n.dot(camera.eye - p) > 0.0,
            Projection::Orthographic { .. } => n.dot(camera.eye - camera.target) > 0.0,
        };
        if let EdgeStyle::Feature { crease } = self.style {
            // The diagonals inside a folded face are silhouettes or creases
            // too when the fold across them is; without them a height field's
            // silhouette would break wherever it crosses a quad.
            for (fi, f) in self.faces.iter().enumerate().filter(|(_, f)| !f.planar) {
                let tris = pieces_of(fi);
                for t in 1..tris.len() {
                    let (Some(i), Some(j)) = (tris[t - 1], tris[t]) else { continue };
                    let v = &f.vertices;
                    let (a, b, c, d) = (pos(v[0]), pos(v[t]), pos(v[t + 1]), pos(v[t + 2]));
                    let (n1, n2) = ((b - a).cross(c - a).normalize_or_zero(), (c - a).cross(d - a).normalize_or_zero());
                    if n1.angle_between(n2) > crease.max(COPLANAR_ANGLE) || toward(n1, a) != toward(n2, a) {
                        out.add_edge(a, c, self.pen, &[i, j]);
                    }
                }
            }
        }
        // Which edges are drawn, decided for all at once in parallel (a
        // fold angle each: 15 million took over a second on one core).
        let drawn: Vec<bool> = self
            .edges
            .par_iter()
            .map(|e| match self.sides_of(e) {
                [s, t] => {
                    let (sf, tf) = (&self.faces[s.face as usize], &self.faces[t.face as usize]);
                    // Normals made consistent across the edge (a consistent
                    // pair traverses it in opposite directions).
                    let sn = self.side_normal(sf, s.k as usize);
                    let tn = self.side_normal(tf, t.k as usize);
                    let tn = if s.forward == t.forward { -tn } else { tn };
                    let fold = fold_angle(sn, tn);
                    let flat = if sf.planar && tf.planar { self.coplanar(sf, tf, fold) } else { fold <= COPLANAR_ANGLE };
                    !flat
                        && match self.style {
                            EdgeStyle::All => true,
                            EdgeStyle::Feature { crease } => fold > crease || toward(sn, pos(e.a)) != toward(tn, pos(e.a)),
                        }
                }
                _ => true,
            })
            .collect();
        let mut on: Vec<u32> = Vec::with_capacity(4);
        for (e, _) in self.edges.iter().zip(drawn).filter(|&(_, draw)| draw) {
            let (a, b) = (pos(e.a), pos(e.b));
            // The faces the edge lies on never hide it: all pieces of a
            // planar face (its triangles lie within the rounding of the
            // edge), the fan triangle holding it of a folded one.
            on.clear();
            for s in self.sides_of(e) {
                let f = &self.faces[s.face as usize];
                let pieces = pieces_of(s.face as usize);
                if f.planar {
                    on.extend(pieces.iter().flatten());
                } else if let Some(mf) = pieces[fan_triangle(s.k as usize, f.vertices.len())] {
                    on.push(mf);
                }
            }
            out.add_edge(a, b, self.pen, &on);
        }
    }
}

/// Triangles (as indices into `f.vertices`, three per triangle) covering the
/// planar face `f`: ear clipping in the plane of its normal, so that concave
/// faces are covered exactly; a fan if that fails.
fn triangulate(cutter: &mut earcut::Earcut<f64>, f: &MeshFace, vertices: &[DVec3], out: &mut Vec<u32>) {
    let n = f.normal.abs();
    let drop = |p: DVec3| -> [f64; 2] {
        if n.x >= n.y && n.x >= n.z {
            [p.y, p.z]
        } else if n.y >= n.z {
            [p.z, p.x]
        } else {
            [p.x, p.y]
        }
    };
    cutter.earcut(f.vertices.iter().map(|&v| drop(vertices[v as usize])), &[] as &[u32], out);
    if out.len() != 3 * (f.vertices.len() - 2) {
        out.clear();
        let count = f.vertices.len() as u32;
        out.extend((1..count - 1).flat_map(|t| [0, t, t + 1]));
    }
}

/// How far (world units) a vertex of a face of size `size` (its bounding
/// box's diagonal) may lie off the face's plane, the face still planar, when
/// its coordinates were rounded to within `rounding` of their true values:
/// [`ROUNDING_FACTOR`] roundings, at most [`ROUNDING_MAX_REL`] of the size,
/// and never less than the relative tolerance of exact input
/// ([`crate::tolerance::PLANARITY_REL`]).
#[must_use]
pub fn planarity_tolerance(size: f64, rounding: f64) -> f64 {
    (crate::tolerance::PLANARITY_REL * size).max((ROUNDING_FACTOR * rounding).min(ROUNDING_MAX_REL * size))
}

/// How far apart (radians) the normals of two planar faces sharing an edge,
/// of sizes `size_f` and `size_g` (their bounding boxes' diagonals), may be
/// and the faces still be coplanar, when their coordinates were rounded to
/// within `rounding` of their true values: [`COPLANAR_ANGLE`], or what the
/// rounding can turn the normals of faces that size by if more:
/// [`ROUNDING_TURN`] roundings over the size for each face, at most
/// [`ROUNDING_MAX_REL`] each. Never because their vertices lie within the
/// rounding of each other's plane: the long thin triangles of a finely
/// tessellated curve do, though their normals are far more apart than the
/// rounding explains (issue 40).
#[must_use]
pub fn coplanar_angle(size_f: f64, size_g: f64, rounding: f64) -> f64 {
    let turn = |size: f64| if size > 0.0 { (ROUNDING_TURN * rounding / size).min(ROUNDING_MAX_REL) } else { 0.0 };
    COPLANAR_ANGLE.max(turn(size_f) + turn(size_g))
}

/// Angle between the consistently oriented normals of two faces sharing an
/// edge: 0 for a flat continuation, pi for a fold back; pi when either is
/// unknown (a degenerate triangle of a split face), so the edge is drawn.
fn fold_angle(sn: DVec3, tn: DVec3) -> f64 {
    if sn == DVec3::ZERO || tn == DVec3::ZERO {
        return std::f64::consts::PI;
    }
    sn.angle_between(tn)
}

/// The fan triangle (v0, v[t+1], v[t+2]) of an `n`-gon that holds its edge `k`
/// (from v[k] to v[k+1]).
fn fan_triangle(k: usize, n: usize) -> usize {
    k.saturating_sub(1).min(n - 3)
}

/// Merges bit-identical vertices (-0 and +0 alike); returns the unique ones,
/// in order of first appearance, and the old-to-new map. Sorting, not
/// hashing, for the same reason as in `build_edges`.
fn weld(vertices: Vec<DVec3>) -> (Vec<DVec3>, Vec<u32>) {
    let key = |p: &DVec3| p.to_array().map(|c| (c + 0.0).to_bits());
    let mut order: Vec<u32> = (0..vertices.len() as u32).collect();
    // (The keys are unique, so any sort gives this order.)
    order.par_sort_unstable_by_key(|&i| (key(&vertices[i as usize]), i));
    // rep[i]: the first vertex with i's position (sorted runs start with it).
    let mut rep: Vec<u32> = vec![0; vertices.len()];
    for (j, &i) in order.iter().enumerate() {
        let first = j == 0 || key(&vertices[order[j - 1] as usize]) != key(&vertices[i as usize]);
        rep[i as usize] = if first { i } else { rep[order[j - 1] as usize] };
    }
    let mut unique = Vec::new();
    let mut remap: Vec<u32> = vec![0; vertices.len()];
    for i in 0..vertices.len() {
        remap[i] = if rep[i] as usize == i {
            unique.push(vertices[i]);
            (unique.len() - 1) as u32
        } else {
            remap[rep[i] as usize]
        };
    }
    (unique, remap)
}

/// Faces checked (`Mesh::rounded`) or lowered (`Mesh::lower`) at once, in
/// parallel: enough to keep the cores busy, few enough that a window's
/// results are a small part of the memory.
const FACE_WINDOW: usize = 1 << 14;

/// The model faces of one mesh face (None: a degenerate triangle).
enum ModelFaces {
    One(Option<Face>),
    Many(Vec<Option<Face>>),
}

/// Why a polygon is not a face of the mesh.
enum FaceFault {
    MissingVertex,
    Degenerate,
}

/// The face of polygon `ring` (indices into the unwelded vertices, which
/// `remap` maps to `vertices`): welded, consecutive repeats and a closing
/// repeat removed, its plane fitted and its planarity decided within
/// `rounding`.
fn checked_face(mut ring: Vec<u32>, vertices: &[DVec3], remap: &[u32], rounding: f64) -> Result<MeshFace, FaceFault> {
    if ring.iter().any(|&v| v as usize >= remap.len()) {
        return Err(FaceFault::MissingVertex);
    }
    for v in &mut ring {
        *v = remap[*v as usize];
    }
    ring.dedup();
    while ring.len() > 1 && ring.first() == ring.last() {
        ring.pop();
    }
    // (On the stack when the face has few points: ten million faces are ten
    // million allocations otherwise.)
    let pts: smallvec::SmallVec<[DVec3; 8]> = ring.iter().map(|&v| vertices[v as usize]).collect();
    let fit = RingFit::of(&pts);
    let Some(normal) = fit.normal().filter(|_| ring.len() >= 3) else { return Err(FaceFault::Degenerate) };
    let planar = fit.deviation <= planarity_tolerance(fit.size, rounding);
    let exact = fit.deviation <= EXACT_PLANAR_REL * fit.size;
    Ok(MeshFace { vertices: ring, planar, exact, normal })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cam(eye: DVec3) -> Camera {
        Camera::new(eye, DVec3::ZERO, DVec3::Z, Projection::Perspective { fov_deg: 30.0 }).unwrap()
    }

    /// Unit cube centred at the origin, faces wound outward (or inward).
    pub(crate) fn cube(inward: bool) -> (Vec<DVec3>, Vec<Vec<u32>>) {
        let v: Vec<DVec3> =
            (0..8).map(|i| DVec3::new((i & 1) as f64 - 0.5, ((i >> 1) & 1) as f64 - 0.5, ((i >> 2) & 1) as f64 - 0.5)).collect();
        let mut f = vec![
            vec![0, 2, 3, 1], // z- (normal -z)
            vec![4, 5, 7, 6], // z+
            vec![0, 1, 5, 4], // y-
            vec![2, 6, 7, 3], // y+
            vec![0, 4, 6, 2], // x-
            vec![1, 3, 7, 5], // x+
        ];
        if inward {
            f.iter_mut().for_each(|r| r.reverse());
        }
        (v, f)
    }

    fn lowered(mesh: &Mesh, eye: DVec3) -> hiddenline::model::Model {
        let mut b = ModelBuilder::new();
        mesh.lower(&cam(eye), &mut b);
        b.finish()
    }

    #[test]
    fn closed_cube_is_oriented_and_draws_twelve_edges() {
        for inward in [false, true] {
            let (v, f) = cube(inward);
            let m = Mesh::new("cube", v, f, EdgeStyle::All, 1);
            assert!(m.is_closed_oriented());
            let model = lowered(&m, DVec3::new(5.0, 4.0, 3.0));
            assert_eq!(model.faces.len(), 6);
            assert_eq!(model.edges.len(), 12);
            assert!(model.edges.iter().all(|e| e.faces.len() == 2));
            // Outward winding: the +z face's Newell normal points up.
            for face in &model.faces {
                assert!(face.outward);
                let n = RingFit::of(&face.outer).newell;
                let c = face.outer.iter().copied().sum::<DVec3>() / 4.0;
                assert!(n.dot(c) > 0.0, "face wound inward after lowering");
            }
        }
    }

    #[test]
    fn each_shell_is_oriented_on_its_own() {
        // Two cubes in one mesh, one wound outward and one inward: each shell
        // lowers wound outward (before, one winding was decided for the whole
        // mesh by its total volume, and one cube was culled inside out).
        let (v, f) = cube(false);
        let (w, g) = cube(true);
        let mut vertices = v;
        vertices.extend(w.iter().map(|p| *p + DVec3::new(3.0, 0.0, 0.0)));
        let mut faces = f;
        faces.extend(g.into_iter().map(|r| r.into_iter().map(|i| i + 8).collect::<Vec<u32>>()));
        // And an open shell: a lone square, never culled.
        let base = vertices.len() as u32;
        vertices.extend([DVec3::new(0.0, 3.0, 0.0), DVec3::new(1.0, 3.0, 0.0), DVec3::new(1.0, 4.0, 0.0), DVec3::new(0.0, 4.0, 0.0)]);
        faces.push(vec![base, base + 1, base + 2, base + 3]);
        let m = Mesh::new("cubes", vertices, faces, EdgeStyle::All, 1);
        assert!(!m.is_closed_oriented());
        let model = lowered(&m, DVec3::new(5.0, 4.0, 3.0));
        assert_eq!(model.faces.len(), 13);
        for face in &model.faces[..12] {
            assert!(face.outward);
            let c = face.outer.iter().copied().sum::<DVec3>() / 4.0;
            let centre = if c.x > 1.5 { DVec3::new(3.0, 0.0, 0.0) } else { DVec3::ZERO };
            assert!(RingFit::of(&face.outer).newell.dot(c - centre) > 0.0, "a face wound inward after lowering");
        }
        assert!(!model.faces[12].outward);
    }

    #[test]
    fn faces_planar_within_their_rounding_are_planar() {
        // A quad with one corner 1e-5 off: written with 5 decimals that is
        // rounding (planar, hides as two exact triangles, draws 4 edges); as
        // exact input it is a fold.
        let v = vec![DVec3::new(0.0, 0.0, 0.0), DVec3::new(0.1, 0.0, 0.0), DVec3::new(0.1, 0.1, 1e-5), DVec3::new(0.0, 0.1, 0.0)];
        let rounded = Mesh::rounded("quad", v.clone(), vec![vec![0, 1, 2, 3]], 5e-6, EdgeStyle::All, 1);
        assert!(rounded.faces[0].planar && !rounded.faces[0].exact);
        let model = lowered(&rounded, DVec3::new(0.3, -0.4, 0.5));
        assert_eq!(model.faces.len(), 2);
        assert_eq!(model.edges.len(), 4);
        // Every edge lies on both triangles of its face: neither hides it.
        assert!(model.edges.iter().all(|e| e.faces.len() == 2));
        let exact = Mesh::new("quad", v, vec![vec![0, 1, 2, 3]], EdgeStyle::All, 1);
        assert!(!exact.faces[0].planar);
        // Rounding never makes a real fold planar: the tolerance is at most
        // 0.5 % of the size. A corner 0.04 off a unit quad is 1 % off its
        // best-fit plane (0.02 was 0.5 % there, on the cap itself).
        let folded = vec![DVec3::new(0.0, 0.0, 0.0), DVec3::new(1.0, 0.0, 0.0), DVec3::new(1.0, 1.0, 0.04), DVec3::new(0.0, 1.0, 0.0)];
        assert!(!Mesh::rounded("fold", folded, vec![vec![0, 1, 2, 3]], 0.05, EdgeStyle::All, 1).faces[0].planar);
    }

    #[test]
    fn coplanar_within_the_rounding_draws_no_edge_between() {
        // Two triangles of a flat square, one corner 4e-5 off (4 decimals):
        // the diagonal is not drawn, as for exact input.
        let v = vec![DVec3::new(0.0, 0.0, 0.0), DVec3::new(0.1, 0.0, 0.0), DVec3::new(0.1, 0.1, 4e-5), DVec3::new(0.0, 0.1, 0.0)];
        let tris = vec![vec![0, 1, 2], vec![0, 2, 3]];
        let m = Mesh::rounded("flat", v.clone(), tris.clone(), 5e-5, EdgeStyle::All, 1);
        assert_eq!(lowered(&m, DVec3::new(0.3, -0.4, 0.5)).edges.len(), 4);
        let m = Mesh::new("fold", v, tris, EdgeStyle::All, 1);
        assert_eq!(lowered(&m, DVec3::new(0.3, -0.4, 0.5)).edges.len(), 5);
    }

    #[test]
    fn a_fold_the_rounding_cannot_explain_is_drawn() {
        // Two long thin triangles 0.05 wide folded by 0.005 rad, as on a
        // finely tessellated cylinder, written with 4 decimals: each one's
        // far vertex lies 2.5e-4 off the other's plane, within 7 roundings
        // (3.5e-4), but a rounding of 5e-5 turns faces that size (1.0) by
        // at most 4e-4 rad.
        let fold: f64 = 0.005;
        let v = vec![
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(0.0, 1.0, 0.0),
            DVec3::new(-0.05, 0.5, 0.0),
            DVec3::new(0.05 * fold.cos(), 0.5, 0.05 * fold.sin()),
        ];
        let tris = vec![vec![0, 1, 2], vec![1, 0, 3]];
        let m = Mesh::rounded("fold", v, tris, 5e-5, EdgeStyle::All, 1);
        assert_eq!(lowered(&m, DVec3::new(0.3, -0.4, 2.0)).edges.len(), 5, "the fold is drawn");
        assert!((coplanar_angle(1.0, 1.0, 5e-5) - 4e-4).abs() < 1e-12);
        assert_eq!(coplanar_angle(1.0, 1.0, 0.0), COPLANAR_ANGLE);
        assert_eq!(coplanar_angle(1.0, 1.0, 0.5), 2.0 * ROUNDING_MAX_REL, "few digits are taken as meant");
    }

    #[test]
    fn triangulated_cube_hides_its_diagonals() {
        let (v, f) = cube(false);
        let tris: Vec<Vec<u32>> = f.iter().flat_map(|r| [vec![r[0], r[1], r[2]], vec![r[0], r[2], r[3]]]).collect();
        let m = Mesh::new("cube", v, tris, EdgeStyle::All, 1);
        assert!(m.is_closed_oriented());
        let model = lowered(&m, DVec3::new(5.0, 4.0, 3.0));
        assert_eq!(model.faces.len(), 12);
        assert_eq!(model.edges.len(), 12);
    }

    #[test]
    fn inconsistent_orientation_is_not_outward_but_still_flat() {
        let (v, mut f) = cube(false);
        f[1].reverse();
        // Split one face into two triangles wound opposite ways.
        let r = f.remove(0);
        f.push(vec![r[0], r[1], r[2]]);
        f.push(vec![r[3], r[2], r[0]]);
        let m = Mesh::new("cube", v, f, EdgeStyle::All, 1);
        assert!(!m.is_closed_oriented());
        let model = lowered(&m, DVec3::new(5.0, 4.0, 3.0));
        assert!(model.faces.iter().all(|f| !f.outward));
        assert_eq!(model.edges.len(), 12, "the diagonal between coplanar triangles is not drawn");
    }

    #[test]
    fn open_mesh_draws_boundaries() {
        let (v, mut f) = cube(false);
        f.truncate(5);
        let m = Mesh::new("box", v, f, EdgeStyle::Feature { crease: 100f64.to_radians() }, 1);
        assert!(!m.is_closed_oriented());
        // From far above: the open top's rim (4 boundary edges) is drawn; the
        // other edges are 90 degree creases, below the threshold, between faces
        // all turned away from the eye, so no silhouettes.
        let model = lowered(&m, DVec3::new(0.1, 0.2, 50.0));
        let boundary = model.edges.iter().filter(|e| e.faces.len() == 1).count();
        assert_eq!(boundary, 4);
    }

    #[test]
    fn feature_edges_are_silhouettes_and_creases() {
        let (v, f) = cube(false);
        // Creases of 90 degrees are below a 100 degree threshold, so only the
        // silhouette is drawn: seen from a corner, the 6 edges of the outline.
        let m = Mesh::new("cube", v.clone(), f.clone(), EdgeStyle::Feature { crease: 100f64.to_radians() }, 1);
        let model = lowered(&m, DVec3::new(5.0, 4.0, 3.0));
        assert_eq!(model.edges.len(), 6);
        // With a 30 degree threshold every cube edge is a crease.
        let m = Mesh::new("cube", v, f, EdgeStyle::Feature { crease: 30f64.to_radians() }, 1);
        assert_eq!(lowered(&m, DVec3::new(5.0, 4.0, 3.0)).edges.len(), 12);
    }

    #[test]
    fn non_planar_quads_are_split_and_only_outlined() {
        let v = vec![DVec3::new(0.0, 0.0, 0.0), DVec3::new(1.0, 0.0, 0.0), DVec3::new(1.0, 1.0, 0.5), DVec3::new(0.0, 1.0, 0.0)];
        let m = Mesh::new("quad", v, vec![vec![0, 1, 2, 3]], EdgeStyle::All, 1);
        assert!(!m.faces[0].planar);
        let model = lowered(&m, DVec3::new(3.0, -4.0, 5.0));
        assert_eq!(model.faces.len(), 2);
        // v0-v2 is the split diagonal: both triangles contain vertex 0 and 2.
        for f in &model.faces {
            assert!(f.outer.contains(&DVec3::ZERO) && f.outer.contains(&DVec3::new(1.0, 1.0, 0.5)));
        }
        assert_eq!(model.edges.len(), 4);
        // Edge 1-2 lies on the first triangle, edge 2-3 on the second.
        for e in &model.edges {
            assert_eq!(e.faces.len(), 1);
            let f = &model.faces[e.faces[0] as usize];
            assert!(f.outer.contains(&e.a) && f.outer.contains(&e.b));
        }
    }

    #[test]
    fn feature_silhouettes_follow_split_diagonals() {
        // A quad folded along v0-v2 into a ridge; seen from the side where one
        // half faces the eye and the other faces away, the diagonal is a
        // silhouette; seen from above, it is not (the fold, 70.5 degrees
        // between the normals, is below the 80 degree crease threshold).
        let v = vec![DVec3::new(0.0, 0.0, 0.0), DVec3::new(1.0, 0.0, -0.5), DVec3::new(1.0, 1.0, 0.0), DVec3::new(0.0, 1.0, -0.5)];
        let m = Mesh::new("ridge", v, vec![vec![0, 1, 2, 3]], EdgeStyle::Feature { crease: 80f64.to_radians() }, 1);
        assert!(!m.faces[0].planar);
        let diagonal = |model: &hiddenline::model::Model| model.edges.iter().filter(|e| e.faces.len() == 2).count();
        // The eye in front of the first half (normal (1,-1,2)/..), behind the
        // second (normal (-1,1,2)/..).
        let grazing = lowered(&m, DVec3::new(3.0, -2.0, -1.2));
        let above = lowered(&m, DVec3::new(0.5, 0.5, 10.0));
        assert_eq!(diagonal(&above), 0);
        assert_eq!(diagonal(&grazing), 1);
        let e = grazing.edges.iter().find(|e| e.faces.len() == 2).unwrap();
        assert_eq!((e.a, e.b), (DVec3::ZERO, DVec3::new(1.0, 1.0, 0.0)));
        // A lower crease threshold draws the fold from anywhere.
        let m = Mesh::new("ridge", m.vertices.clone(), vec![vec![0, 1, 2, 3]], EdgeStyle::Feature { crease: 60f64.to_radians() }, 1);
        assert_eq!(diagonal(&lowered(&m, DVec3::new(0.5, 0.5, 10.0))), 1);
    }

    #[test]
    fn degenerate_faces_are_skipped() {
        let v = vec![DVec3::ZERO, DVec3::X, DVec3::new(2.0, 0.0, 0.0), DVec3::Y];
        let m = Mesh::new("d", v, vec![vec![0, 1, 2], vec![0, 0, 1], vec![0, 1, 3], vec![0, 9, 1]], EdgeStyle::All, 1);
        assert_eq!(m.faces.len(), 1);
    }

    #[test]
    fn edges_of_many_faces_are_drawn_once() {
        // Three fins sharing the edge along z.
        let v = vec![DVec3::ZERO, DVec3::Z, DVec3::X, DVec3::Y, DVec3::new(-1.0, -1.0, 0.0)];
        let m = Mesh::new("fins", v, vec![vec![0, 1, 2], vec![0, 1, 3], vec![1, 0, 4]], EdgeStyle::All, 1);
        let model = lowered(&m, DVec3::new(3.0, -4.0, 5.0));
        let spine: Vec<_> = model.edges.iter().filter(|e| e.faces.len() == 3).collect();
        assert_eq!(spine.len(), 1);
        assert_eq!(model.edges.len(), 7);
    }

    #[test]
    fn welding_merges_equal_positions_in_first_appearance_order() {
        let p = |x: f64| DVec3::new(x, 0.0, 0.0);
        let (u, remap) = weld(vec![p(2.0), p(1.0), p(2.0), p(-0.0), p(0.0), p(1.0)]);
        assert_eq!(u, vec![p(2.0), p(1.0), p(-0.0)]);
        assert_eq!(remap, vec![0, 1, 0, 2, 2, 1]);
        assert_eq!(weld(vec![]), (vec![], vec![]));
    }

    #[test]
    fn fan_triangle_holds_the_edge() {
        // Pentagon: triangles (0,1,2), (0,2,3), (0,3,4).
        assert_eq!((0..5).map(|k| fan_triangle(k, 5)).collect::<Vec<_>>(), vec![0, 0, 1, 2, 2]);
        assert_eq!((0..3).map(|k| fan_triangle(k, 3)).collect::<Vec<_>>(), vec![0, 0, 0]);
    }
}
