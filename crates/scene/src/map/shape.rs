//! Symbol shapes: convex solids with a unit footprint, base on z = 0 and top
//! at z = 1, stretched per place to the symbol's width and height.
//!
//! Every shape is a closed convex polyhedron with faces wound counter-clockwise
//! seen from outside, so its faces can be handed to the engine with
//! `outward = true` (back faces skipped) and its edges carry their two faces.

use super::error::MapError;
use super::limits::{self, COPLANAR_DOT_TOL, FLAT_HEIGHT_FRACTION, SHAPE_PLANE_TOL};
use crate::builder::ModelBuilder;
use glam::DVec3;
use hiddenline::model::Face;
use std::collections::HashMap;
use std::path::Path;

/// A convex unit solid.
#[derive(Clone, Debug, PartialEq)]
pub struct Solid {
    /// Vertices; x, y within the unit footprint, z in [0, 1].
    pub vertices: Vec<DVec3>,
    /// Faces as vertex indices, counter-clockwise seen from outside.
    pub faces: Vec<Vec<usize>>,
    /// Edges to draw: `(a, b, face_left, face_right)`, each once, without the
    /// diagonals between coplanar faces.
    pub edges: Vec<(usize, usize, usize, usize)>,
    /// Edges of the footprint (both ends on z = 0, not between two faces
    /// lying on z = 0): what is drawn for a flat symbol.
    pub footprint: Vec<(usize, usize)>,
}

impl Solid {
    /// An upright prism over a regular `n`-gon whose corners lie on the circle
    /// of the given `radius`, the first corner at angle `phase` (radians).
    fn prism(n: usize, radius: f64, phase: f64) -> Solid {
        let ring = |z: f64| {
            (0..n).map(move |i| {
                let a = phase + std::f64::consts::TAU * i as f64 / n as f64;
                DVec3::new(radius * a.cos(), radius * a.sin(), z)
            })
        };
        let vertices: Vec<DVec3> = ring(0.0).chain(ring(1.0)).collect();
        let mut faces = vec![(0..n).rev().collect::<Vec<_>>(), (n..2 * n).collect()];
        for i in 0..n {
            let j = (i + 1) % n;
            faces.push(vec![i, j, n + j, n + i]);
        }
        Solid::from_faces(vertices, faces)
    }

    /// The unit cube standing on the footprint [-0.5, 0.5]².
    #[must_use]
    pub fn unit_box() -> Solid {
        Solid::prism(4, std::f64::consts::FRAC_1_SQRT_2, std::f64::consts::FRAC_PI_4)
    }

    /// A hexagonal prism, corners on the circle of diameter 1, two corners on
    /// the x axis.
    #[must_use]
    pub fn hex_prism() -> Solid {
        Solid::prism(6, 0.5, 0.0)
    }

    /// A cylinder of diameter 1 approximated by `segments` flat sides.
    #[must_use]
    pub fn cylinder(segments: u32) -> Solid {
        Solid::prism(segments as usize, 0.5, 0.0)
    }

    /// A square pyramid on the footprint [-0.5, 0.5]², apex over the centre.
    #[must_use]
    pub fn pyramid() -> Solid {
        let h = 0.5;
        let vertices =
            vec![DVec3::new(-h, -h, 0.0), DVec3::new(h, -h, 0.0), DVec3::new(h, h, 0.0), DVec3::new(-h, h, 0.0), DVec3::new(0.0, 0.0, 1.0)];
        let faces = vec![vec![3, 2, 1, 0], vec![0, 1, 4], vec![1, 2, 4], vec![2, 3, 4], vec![3, 0, 4]];
        Solid::from_faces(vertices, faces)
    }

    /// A symbol from a convex OBJ file. Its z range is mapped to [0, 1] (the
    /// base is put on the ground and the height becomes the data value);
    /// x and y are taken as they are (a unit footprint centred on the origin
    /// is expected). Faces may be wound either way: each is turned to face
    /// away from the solid's centroid.
    ///
    /// # Errors
    /// The file cannot be read or parsed, is empty or flat, has too many
    /// vertices, is not closed (an edge not shared by exactly two faces), has
    /// a non-planar or degenerate face, or is not convex. The message says
    /// which face or edge.
    pub fn from_obj(path: &Path, files: &dyn crate::resolver::Resolver) -> Result<Solid, MapError> {
        let text = limits::read_text(path, files)?;
        let err = |message: String| MapError::Shape { path: path.to_owned(), message };
        let opts = tobj::LoadOptions { triangulate: false, ignore_points: true, ignore_lines: true, ..Default::default() };
        let (models, _) = tobj::load_obj_buf(&mut text.as_bytes(), &opts, |_| Err(tobj::LoadError::OpenFileFailed))
            .map_err(|e| err(format!("cannot parse OBJ: {e}")))?;
        let mut vertices = Vec::new();
        let mut faces = Vec::new();
        for m in &models {
            let base = vertices.len();
            let mesh = &m.mesh;
            vertices.extend(mesh.positions.chunks_exact(3).map(|c| DVec3::new(c[0], c[1], c[2])));
            let mut k = 0usize;
            let arities: Vec<usize> = if mesh.face_arities.is_empty() {
                vec![3; mesh.indices.len() / 3]
            } else {
                mesh.face_arities.iter().map(|&a| a as usize).collect()
            };
            for a in arities {
                let f: Vec<usize> = mesh.indices[k..k + a].iter().map(|&i| base + i as usize).collect();
                k += a;
                faces.push(f);
            }
        }
        // Merge vertices written twice at the same position, so that faces
        // sharing a corner share its index (the closedness check needs it).
        let mut first: HashMap<[u64; 3], usize> = HashMap::new();
        let remap: Vec<usize> =
            vertices.iter().enumerate().map(|(i, v)| *first.entry(v.to_array().map(f64::to_bits)).or_insert(i)).collect();
        for f in &mut faces {
            for i in f.iter_mut() {
                *i = remap[*i];
            }
        }
        if vertices.len() > limits::MAX_SHAPE_VERTICES {
            return Err(err(format!("{} vertices, more than {}", vertices.len(), limits::MAX_SHAPE_VERTICES)));
        }
        if faces.len() < 4 {
            return Err(err(format!("{} faces: a closed solid needs at least 4", faces.len())));
        }
        let (zmin, zmax) = vertices.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(v.z), hi.max(v.z)));
        if !(zmax - zmin > 0.0) || vertices.iter().any(|v| !v.is_finite()) {
            return Err(err("the solid has no height (or a non-finite vertex)".into()));
        }
        for v in &mut vertices {
            v.z = (v.z - zmin) / (zmax - zmin);
        }
        let faces = orient_convex(&vertices, faces).map_err(err)?;
        Ok(Solid::from_faces(vertices, faces))
    }

    /// Builds the edge lists from faces that are already wound outward.
    fn from_faces(vertices: Vec<DVec3>, faces: Vec<Vec<usize>>) -> Solid {
        let normals: Vec<DVec3> = faces.iter().map(|f| newell(&vertices, f).normalize_or_zero()).collect();
        // Directed edge (a, b) -> the face it bounds; the twin (b, a) bounds
        // the neighbour on the other side.
        let mut directed: HashMap<(usize, usize), usize> = HashMap::new();
        for (fi, f) in faces.iter().enumerate() {
            for k in 0..f.len() {
                directed.insert((f[k], f[(k + 1) % f.len()]), fi);
            }
        }
        let mut edges = Vec::new();
        let mut footprint = Vec::new();
        let mut keys: Vec<_> = directed.iter().filter(|((a, b), _)| a < b).map(|(&k, &f)| (k, f)).collect();
        keys.sort_unstable();
        for ((a, b), fl) in keys {
            let Some(&fr) = directed.get(&(b, a)) else { continue };
            let on_ground = |f: usize| faces[f].iter().all(|&v| vertices[v].z == 0.0);
            if vertices[a].z == 0.0 && vertices[b].z == 0.0 && !(on_ground(fl) && on_ground(fr)) {
                footprint.push((a, b));
            }
            if normals[fl].dot(normals[fr]) > 1.0 - COPLANAR_DOT_TOL {
                continue;
            }
            edges.push((a, b, fl, fr));
        }
        Solid { vertices, faces, edges, footprint }
    }

    /// Adds this solid to `model`, its footprint centred on `base` (on the
    /// ground), `width` wide and `height` tall. A flat symbol (height below
    /// [`FLAT_HEIGHT_FRACTION`] of its width) adds only its footprint lines.
    pub fn emit(&self, base: DVec3, width: f64, height: f64, pen: u32, out: &mut ModelBuilder) {
        let s = DVec3::new(width, width, height);
        let at = |i: usize| base + self.vertices[i] * s;
        if !(height > FLAT_HEIGHT_FRACTION * width) {
            let flat = |i: usize| {
                let v = at(i);
                DVec3::new(v.x, v.y, base.z)
            };
            for &(a, b) in &self.footprint {
                out.add_edge(flat(a), flat(b), pen, &[]);
            }
            return;
        }
        let f0 = out.face_count() as u32;
        for f in &self.faces {
            out.add_face(Face { outer: f.iter().map(|&i| at(i)).collect(), holes: Vec::new(), pen, outward: true });
        }
        for &(a, b, fl, fr) in &self.edges {
            out.add_edge(at(a), at(b), pen, &[f0 + fl as u32, f0 + fr as u32]);
        }
    }
}

/// Newell's normal of a polygon: robust for any planar polygon, its length
/// twice the area.
fn newell(v: &[DVec3], f: &[usize]) -> DVec3 {
    let mut n = DVec3::ZERO;
    for k in 0..f.len() {
        let (p, q) = (v[f[k]], v[f[(k + 1) % f.len()]]);
        n += DVec3::new((p.y - q.y) * (p.z + q.z), (p.z - q.z) * (p.x + q.x), (p.x - q.x) * (p.y + q.y));
    }
    n
}

/// Checks that `faces` bound a closed convex solid and winds each one
/// counter-clockwise seen from outside.
fn orient_convex(v: &[DVec3], mut faces: Vec<Vec<usize>>) -> Result<Vec<Vec<usize>>, String> {
    let (lo, hi) = v.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
    let tol = SHAPE_PLANE_TOL * (hi - lo).length();
    let used: std::collections::BTreeSet<usize> = faces.iter().flatten().copied().collect();
    let centroid = used.iter().map(|&i| v[i]).sum::<DVec3>() / used.len() as f64;
    for (fi, f) in faces.iter_mut().enumerate() {
        let n = newell(v, f).normalize_or_zero();
        if n == DVec3::ZERO {
            return Err(format!("face {} (1-based) is degenerate: it has no area", fi + 1));
        }
        let p0 = v[f[0]];
        if let Some(&k) = f.iter().find(|&&k| n.dot(v[k] - p0).abs() > tol) {
            return Err(format!("face {} is not planar (vertex {} is off its plane)", fi + 1, k + 1));
        }
        let sign = if n.dot(centroid - p0) > 0.0 { -1.0 } else { 1.0 };
        if sign < 0.0 {
            f.reverse();
        }
        if let Some(&k) = used.iter().find(|&&k| sign * n.dot(v[k] - p0) > tol) {
            return Err(format!(
                "not convex: vertex {} lies {:.3e} outside the plane of face {}; \
                 symbols must be convex solids (split a concave one into convex parts)",
                k + 1,
                sign * n.dot(v[k] - p0),
                fi + 1
            ));
        }
    }
    let mut count: HashMap<(usize, usize), usize> = HashMap::new();
    for f in &faces {
        for k in 0..f.len() {
            let (a, b) = (f[k], f[(k + 1) % f.len()]);
            *count.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    if let Some(((a, b), n)) = count.iter().find(|(_, &n)| n != 2) {
        return Err(format!("not a closed solid: the edge between vertices {} and {} belongs to {n} face(s), not 2", a + 1, b + 1));
    }
    Ok(faces)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Closed, outward-wound, and every drawn edge separates its two faces.
    fn check_solid(s: &Solid) {
        let vol: f64 = s
            .faces
            .iter()
            .map(|f| (1..f.len() - 1).map(|k| s.vertices[f[0]].dot(s.vertices[f[k]].cross(s.vertices[f[k + 1]]))).sum::<f64>())
            .sum::<f64>()
            / 6.0;
        assert!(vol > 0.0, "faces must wind outward, volume {vol}");
        let c = s.vertices.iter().sum::<DVec3>() / s.vertices.len() as f64;
        for f in &s.faces {
            let n = newell(&s.vertices, f);
            assert!(n.dot(s.vertices[f[0]] - c) > 0.0, "face {f:?} winds inward");
        }
        for &(a, b, fl, fr) in &s.edges {
            assert!(s.faces[fl].contains(&a) && s.faces[fl].contains(&b));
            assert!(s.faces[fr].contains(&a) && s.faces[fr].contains(&b));
            assert_ne!(fl, fr);
        }
        for v in &s.vertices {
            assert!(v.z >= 0.0 && v.z <= 1.0 && v.x.abs() <= 0.5 + 1e-12 && v.y.abs() <= 0.5 + 1e-12);
        }
    }

    #[test]
    fn builtin_shapes_are_closed_convex_and_outward() {
        let b = Solid::unit_box();
        check_solid(&b);
        assert_eq!((b.vertices.len(), b.faces.len(), b.edges.len(), b.footprint.len()), (8, 6, 12, 4));
        assert!((b.vertices[0].x.abs() - 0.5).abs() < 1e-12 && (b.vertices[0].y.abs() - 0.5).abs() < 1e-12);
        let h = Solid::hex_prism();
        check_solid(&h);
        assert_eq!((h.faces.len(), h.edges.len()), (8, 18));
        let c = Solid::cylinder(24);
        check_solid(&c);
        assert_eq!(c.edges.len(), 72);
        let p = Solid::pyramid();
        check_solid(&p);
        assert_eq!((p.faces.len(), p.edges.len(), p.footprint.len()), (5, 8, 4));
    }

    #[test]
    fn emit_places_and_links_faces() {
        let mut b = ModelBuilder::new();
        b.add_face(Face { outer: vec![DVec3::ZERO, DVec3::X, DVec3::Y], holes: vec![], pen: 1, outward: false });
        Solid::unit_box().emit(DVec3::new(10.0, 20.0, 0.0), 2.0, 5.0, 3, &mut b);
        let m = b.finish();
        assert_eq!(m.faces.len(), 7);
        assert_eq!(m.edges.len(), 12);
        for e in &m.edges {
            assert_eq!(e.pen, 3);
            for &f in &e.faces {
                assert!(f >= 1, "face indices are offset past existing faces");
                let face = &m.faces[f as usize];
                assert!(face.outer.contains(&e.a) && face.outer.contains(&e.b));
            }
            for p in [e.a, e.b] {
                assert!((p.x - 10.0).abs() == 1.0 && (p.y - 20.0).abs() == 1.0 && (p.z == 0.0 || p.z == 5.0));
            }
        }
    }

    #[test]
    fn flat_symbol_draws_its_footprint_only() {
        let mut b = ModelBuilder::new();
        Solid::cylinder(8).emit(DVec3::ZERO, 1.0, 0.0, 1, &mut b);
        let m = b.finish();
        assert!(m.faces.is_empty());
        assert_eq!(m.edges.len(), 8);
        assert!(m.edges.iter().all(|e| e.a.z == 0.0 && e.b.z == 0.0 && e.faces.is_empty()));
    }

    fn obj(name: &str, text: &str) -> Result<Solid, MapError> {
        let dir = tempfile::Builder::new().prefix("plotd-map-shape-").tempdir().unwrap();
        let p = dir.path().join(name);
        std::fs::write(&p, text).unwrap();
        Solid::from_obj(&p, &crate::resolver::FileSystem)
    }

    const TETRA: &str = "v -0.5 -0.5 0\nv 0.5 -0.5 0\nv 0 0.5 0\nv 0 0 2\nf 1 2 3\nf 1 2 4\nf 2 3 4\nf 3 1 4\n";

    #[test]
    fn obj_symbol_is_oriented_and_normalised() {
        // Faces deliberately wound inconsistently: they are turned outward.
        let s = obj("tetra.obj", TETRA).unwrap();
        check_solid(&s);
        assert_eq!(s.edges.len(), 6);
        assert!(s.vertices.iter().any(|v| v.z == 1.0), "height normalised to 1");
        // A triangulated cube: the face diagonals are not drawn.
        let cube = "v -.5 -.5 0\nv .5 -.5 0\nv .5 .5 0\nv -.5 .5 0\nv -.5 -.5 1\nv .5 -.5 1\nv .5 .5 1\nv -.5 .5 1\n\
            f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 2 3 7\nf 2 7 6\nf 3 4 8\nf 3 8 7\nf 4 1 5\nf 4 5 8\n";
        let s = obj("cube.obj", cube).unwrap();
        check_solid(&s);
        assert_eq!(s.faces.len(), 12);
        assert_eq!(s.edges.len(), 12, "diagonals of coplanar triangles are dropped");
        assert_eq!(s.footprint.len(), 4);
    }

    #[test]
    fn bad_obj_symbols_are_refused_with_a_reason() {
        // A concave "arrow" prism: vertex 3 is a reflex corner.
        let concave = "v 0 0 0\nv 1 0 0\nv 0.5 0.2 0\nv 0.5 1 0\nv 0 0 1\nv 1 0 1\nv 0.5 0.2 1\nv 0.5 1 1\n\
            f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";
        let e = obj("concave.obj", concave).unwrap_err();
        assert!(e.to_string().contains("not convex"), "{e}");
        let open = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\nf 2 3 4\n";
        let e = obj("open.obj", open).unwrap_err();
        assert!(e.to_string().contains("at least 4"), "{e}");
        let open = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nv 1 1 1\nf 1 2 3\nf 1 2 4\nf 2 3 4\nf 2 3 5\n";
        let e = obj("open2.obj", open).unwrap_err();
        assert!(e.to_string().contains("closed") || e.to_string().contains("convex"), "{e}");
        let e = obj("flat.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\nf 1 3 2\nf 2 3 4\n").unwrap_err();
        assert!(e.to_string().contains("no height"), "{e}");
        let e = obj("junk.obj", "this is not an obj\nf 1 2 3\n").unwrap_err();
        assert!(e.to_string().contains("symbol shape"), "{e}");
        // Malformed indices, degenerate faces and stray lines never panic.
        for (name, text) in [
            ("range.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99\n"),
            ("dup.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 1 2\nf 1 2 4\nf 2 3 4\nf 3 1 4\n"),
            ("zero.obj", "v 0 0 0\nf 0 0 0\n"),
            ("nan.obj", "v 0 0 nan\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\nf 2 3 4\nf 3 1 4\n"),
            ("lines.obj", "v 0 0 0\nv 1 0 0\nl 1 2\np 1\n"),
        ] {
            assert!(obj(name, text).is_err(), "{name}");
        }
        let e = Solid::from_obj(Path::new("/nonexistent/x.obj"), &crate::resolver::FileSystem).unwrap_err();
        assert!(matches!(e, MapError::Io { .. }));
    }
}
