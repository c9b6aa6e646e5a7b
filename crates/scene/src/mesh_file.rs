//! Reading mesh files: OBJ (tobj) and STL (stl_io, ASCII and binary) into
//! vertices and polygons, with errors naming the file and line.

use crate::error::{SceneError, SceneErrorKind};
use crate::resolver::{ReadError, Resolver};
use crate::tolerance::MAX_MESH_BYTES;
use glam::DVec3;
use std::io::Cursor;
use std::path::Path;

/// Vertices and polygons as read from a file, in file coordinates.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RawMesh {
    /// Vertex positions.
    pub vertices: Vec<DVec3>,
    /// Polygons as 0-based indices into `vertices`.
    pub polygons: Vec<Vec<u32>>,
}

/// Reads an `.obj` or `.stl` file (by extension, case-insensitive) through `files`.
///
/// # Errors
/// Unreadable, unserved or oversized file, unknown extension, a malformed
/// file, a face index out of range (OBJ), a non-finite coordinate.
pub fn read_mesh(path: &Path, files: &dyn Resolver) -> Result<RawMesh, SceneError> {
    let err = |kind| SceneError::new(path, kind);
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    let is_obj = match ext.as_deref() {
        Some("obj") => true,
        Some("stl") => false,
        _ => return Err(err(SceneErrorKind::UnknownMeshFormat)),
    };
    let bytes = read_limited(files, path, MAX_MESH_BYTES)?;
    let mesh =
        if is_obj { parse_obj(&bytes).map_err(|(line, kind)| with_line(err(kind), line))? } else { parse_stl(&bytes).map_err(err)? };
    Ok(mesh)
}

fn with_line(e: SceneError, line: Option<usize>) -> SceneError {
    match line {
        Some(l) => e.at_line(l),
        None => e,
    }
}

/// Reads a whole file through `files`, refusing more than `limit` bytes.
pub(crate) fn read_limited(files: &dyn Resolver, path: &Path, limit: u64) -> Result<Vec<u8>, SceneError> {
    files.read(path, limit).map_err(|e| {
        let kind = match e {
            ReadError::Io(e) => SceneErrorKind::Io(e),
            ReadError::TooLarge { size, limit } => SceneErrorKind::FileTooLarge { size, limit },
            ReadError::Refused(m) => SceneErrorKind::Refused(m),
        };
        SceneError::new(path, kind)
    })
}

type Located = (Option<usize>, SceneErrorKind);

/// Parses OBJ text: polygons kept as written (not triangulated), all objects
/// and groups merged, points, lines and materials ignored.
pub fn parse_obj(bytes: &[u8]) -> Result<RawMesh, Located> {
    let text = String::from_utf8_lossy(bytes);
    // tobj does not say where a bad index or number is; find it first.
    check_obj_text(&text)?;
    let opts = tobj::LoadOptions { single_index: false, triangulate: false, ignore_points: true, ignore_lines: true };
    let (models, _) = tobj::load_obj_buf(&mut Cursor::new(text.as_bytes()), &opts, |_| Err(tobj::LoadError::MaterialParseError))
        .map_err(|e| (None, SceneErrorKind::Obj(e.to_string())))?;
    let mut mesh = RawMesh::default();
    for m in models {
        let m = m.mesh;
        let base = mesh.vertices.len() as u32;
        for p in m.positions.chunks_exact(3) {
            // Finiteness was checked line by line in `check_obj_text`.
            mesh.vertices.push(DVec3::new(p[0], p[1], p[2]));
        }
        if m.face_arities.is_empty() {
            mesh.polygons.extend(m.indices.chunks_exact(3).map(|t| t.iter().map(|i| i + base).collect()));
        } else {
            let mut at = 0;
            for &n in &m.face_arities {
                let n = n as usize;
                mesh.polygons.push(m.indices[at..at + n].iter().map(|i| i + base).collect());
                at += n;
            }
        }
    }
    Ok(mesh)
}

/// Finds the first vertex with a non-finite coordinate, or face vertex index
/// that refers to no vertex defined before it, with its line.
fn check_obj_text(text: &str) -> Result<(), Located> {
    let mut count: usize = 0;
    for (n, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                count += 1;
                if let Some(bad) = words.take(3).filter_map(|w| w.parse::<f64>().ok()).find(|c| !c.is_finite()) {
                    return Err((Some(n + 1), SceneErrorKind::NotFinite(bad)));
                }
            }
            Some("f") => {
                for w in words {
                    let Ok(idx) = w.split('/').next().unwrap_or("").parse::<i64>() else {
                        return Err((Some(n + 1), SceneErrorKind::Obj(format!("bad face vertex {w:?}"))));
                    };
                    let ok = if idx > 0 { idx as u64 <= count as u64 } else { idx < 0 && idx.unsigned_abs() <= count as u64 };
                    if !ok {
                        return Err((Some(n + 1), SceneErrorKind::ObjIndexOutOfRange { index: idx, count }));
                    }
                }
            }
            _ => {}
        }
    }
    Ok(())
}

/// Parses an ASCII or binary STL file.
pub fn parse_stl(bytes: &[u8]) -> Result<RawMesh, SceneErrorKind> {
    let stl = stl_io::read_stl(&mut Cursor::new(bytes)).map_err(|e| SceneErrorKind::Stl(e.to_string()))?;
    let mut mesh = RawMesh { vertices: Vec::with_capacity(stl.vertices.len()), polygons: Vec::with_capacity(stl.faces.len()) };
    for v in &stl.vertices {
        let p = DVec3::new(f64::from(v[0]), f64::from(v[1]), f64::from(v[2]));
        if !p.is_finite() {
            let bad = p.to_array().into_iter().find(|c| !c.is_finite()).unwrap_or(f64::NAN);
            return Err(SceneErrorKind::NotFinite(bad));
        }
        mesh.vertices.push(p);
    }
    for f in &stl.faces {
        if f.vertices.iter().any(|&i| i >= mesh.vertices.len()) {
            return Err(SceneErrorKind::Stl("triangle refers to a missing vertex".into()));
        }
        mesh.polygons.push(f.vertices.iter().map(|&i| i as u32).collect());
    }
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;

    const SQUARE: &str = "# a square and a triangle\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\nf 1/1 2/2 -1\n";

    #[test]
    fn obj_polygons_are_kept_whole() {
        let m = parse_obj(SQUARE.as_bytes()).unwrap();
        assert_eq!(m.vertices.len(), 4);
        assert_eq!(m.polygons, vec![vec![0, 1, 2, 3], vec![0, 1, 3]]);
    }

    #[test]
    fn obj_index_out_of_range_names_the_line() {
        let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\nf 1 2 4\n";
        let (line, kind) = parse_obj(text.as_bytes()).unwrap_err();
        assert_eq!(line, Some(5));
        assert!(matches!(kind, SceneErrorKind::ObjIndexOutOfRange { index: 4, count: 3 }));
        let (line, _) = parse_obj(b"v 0 0 0\nf 1 -2 1\n").unwrap_err();
        assert_eq!(line, Some(2));
        let (line, _) = parse_obj(b"v 0 0 0\nf 0 1 1\n").unwrap_err();
        assert_eq!(line, Some(2));
    }

    #[test]
    fn obj_nan_names_the_vertex_line() {
        let (line, kind) = parse_obj(b"v 0 0 0\n\nv nan 0 0\nv 1 1 0\nf 1 2 3\n").unwrap_err();
        assert_eq!(line, Some(3));
        assert!(matches!(kind, SceneErrorKind::NotFinite(_)));
    }

    #[test]
    fn stl_ascii_and_binary() {
        let ascii = "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\n\
                     facet normal 0 0 1\nouter loop\nvertex 1 0 0\nvertex 1 1 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid t\n";
        let m = parse_stl(ascii.as_bytes()).unwrap();
        assert_eq!(m.polygons.len(), 2);
        assert_eq!(m.vertices.len(), 4, "stl_io shares identical vertices");
        let mut bin = vec![0u8; 80];
        bin.extend(1u32.to_le_bytes());
        for f in [0.0f32, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
            bin.extend(f.to_le_bytes());
        }
        bin.extend([0, 0]);
        let m = parse_stl(&bin).unwrap();
        assert_eq!(m.polygons, vec![vec![0, 1, 2]]);
        assert!(parse_stl(b"solid broken\nfacet nonsense").is_err());
    }

    #[test]
    fn unknown_extension_and_missing_file() {
        let e = read_mesh(Path::new("model.ply"), &crate::resolver::FileSystem).unwrap_err();
        assert!(matches!(e.kind, SceneErrorKind::UnknownMeshFormat));
        let e = read_mesh(Path::new("/nonexistent/model.obj"), &crate::resolver::FileSystem).unwrap_err();
        assert!(matches!(e.kind, SceneErrorKind::Io(_)));
        assert!(e.to_string().starts_with("/nonexistent/model.obj: cannot read the file"));
    }
}
