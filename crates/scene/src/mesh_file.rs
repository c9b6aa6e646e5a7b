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
    /// How far a coordinate may be from the value it stands for, because of
    /// how it was written (0 when exact): [`written_rounding`] for OBJ; for
    /// STL, the rounding of its largest coordinate to f32.
    pub rounding: f64,
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
    let parsed = if is_obj { parse_obj(&bytes) } else { parse_stl(&bytes) };
    parsed.map_err(|(line, kind)| with_line(err(kind), line))
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
///
/// # Errors
/// The line (1-based) and what is wrong: a malformed line, a face index that
/// refers to no vertex, a coordinate that is not finite.
pub fn parse_obj(bytes: &[u8]) -> Result<RawMesh, Located> {
    let text = String::from_utf8_lossy(bytes);
    // tobj does not say where a bad index or number is: the check's finding
    // comes first. The check and the written precision read the text while
    // tobj parses it, on another core (the three took 8 s one after another
    // for a 560 MB OBJ of ten million triangles).
    let ((checked, rounding), models) = rayon::join(|| (check_obj_text(&text), written_rounding(&text)), || load_obj(&text));
    checked?;
    let models = models.map_err(|e| (Some(first_failing_line(&text)), SceneErrorKind::Obj(e.to_string())))?;
    let mut mesh = RawMesh { rounding, ..RawMesh::default() };
    for m in models {
        let m = m.mesh;
        let base = mesh.vertices.len() as u32;
        for p in m.positions.chunks_exact(3) {
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
    // A weight `w` divides a vertex by itself: finite words can still make
    // an infinite vertex (`v 1 1 1 1e-320`).
    if let Some(bad) = mesh.vertices.iter().flat_map(|v| v.to_array()).find(|c| !c.is_finite()) {
        return Err((Some(first_failing_line(&text)), SceneErrorKind::NotFinite(bad)));
    }
    Ok(mesh)
}

fn load_obj(text: &str) -> Result<Vec<tobj::Model>, tobj::LoadError> {
    let opts = tobj::LoadOptions { single_index: false, triangulate: false, ignore_points: true, ignore_lines: true };
    let (models, _) = tobj::load_obj_buf(&mut Cursor::new(text.as_bytes()), &opts, |_| Err(tobj::LoadError::MaterialParseError))?;
    if models.iter().flat_map(|m| &m.mesh.positions).all(|c| c.is_finite()) {
        Ok(models)
    } else {
        Err(tobj::LoadError::PositionParseError)
    }
}

/// The line at which `text` stops loading: the shortest run of whole
/// lines from the start that fails, found by bisection (tobj names no line).
fn first_failing_line(text: &str) -> usize {
    let ends: Vec<usize> = text.match_indices('\n').map(|(i, _)| i + 1).chain([text.len()]).collect();
    let (mut ok, mut bad) = (0, ends.len());
    while bad - ok > 1 {
        let mid = (ok + bad) / 2;
        if load_obj(&text[..ends[mid - 1]]).is_ok() {
            ok = mid;
        } else {
            bad = mid;
        }
    }
    bad
}

/// The largest rounding of an OBJ file's vertex coordinates as written: how
/// far a coordinate may be from the value it stands for. Integers are taken
/// as exact (typed by hand, or exact in `%g` output). Two ways of writing
/// are told apart:
/// - The same number of decimals `d` everywhere, or trailing zeros kept
///   (`%.6f`, as Blender writes): half a unit of the last digit, `0.5 *
///   10^-d`, of the coarsest (`1.5e-3` has 4 decimals). `%.6f` gives 5e-7.
/// - Trailing zeros dropped and the decimals varying (`%g`, as CAD
///   exporters write, or numbers rounded to `d` places and printed
///   shortest): every coordinate was written to at most the most decimals
///   any has and at most the most significant digits any has, the zeros
///   after its last digit dropped (`15.5` is `15.5000` to 6 digits), so half
///   a unit of the last digit that leaves at the largest (non-integer)
///   coordinate: `%g` at coordinates near 15 gives 5e-5, where the coarsest
///   last digit written (of `15.5`) would say 0.05.
#[must_use]
pub fn written_rounding(text: &str) -> f64 {
    // The coarsest last digit and the finest, as decimals; whether a
    // fraction ends in 0; the most significant digits and the largest
    // leading digit's power of ten of a non-integer.
    let (mut coarsest, mut finest) = (i32::MAX, i32::MIN);
    let mut zeros_kept = false;
    let (mut digits, mut lead) = (0i32, i32::MIN);
    for line in text.lines() {
        let mut words = line.split_whitespace();
        if words.next() != Some("v") {
            continue;
        }
        for w in words.take(3) {
            let (mantissa, exp) = match w.find(['e', 'E']) {
                Some(at) => (&w[..at], w[at + 1..].parse::<i32>().unwrap_or(0)),
                None => (w, 0),
            };
            let mantissa = mantissa.trim_start_matches(['+', '-']);
            let (whole, fraction) = match mantissa.find('.') {
                Some(dot) => (&mantissa[..dot], Some(&mantissa[dot + 1..])),
                None => (mantissa, None),
            };
            let fraction = fraction.map(|f| &f[..f.bytes().take_while(u8::is_ascii_digit).count()]);
            let places = fraction.map_or(0, str::len) as i32 - exp;
            let all: String = whole.chars().chain(fraction.unwrap_or("").chars()).filter(char::is_ascii_digit).collect();
            if places <= 0 {
                // An integer: exact.
                continue;
            }
            let significant = all.trim_start_matches('0').len() as i32;
            if significant > 0 {
                digits = digits.max(significant);
                lead = lead.max(significant - 1 - places);
            }
            coarsest = coarsest.min(places);
            finest = finest.max(places);
            zeros_kept |= fraction.is_some_and(|f| f.len() > 1 && f.ends_with('0'));
        }
    }
    if coarsest == i32::MAX {
        return 0.0;
    }
    let last = if zeros_kept || coarsest == finest || lead == i32::MIN { coarsest } else { finest.min(digits - 1 - lead) };
    0.5 * 10f64.powi(-last)
}

/// Finds the first vertex with a non-finite coordinate, or face vertex index
/// (position, texture or normal) that refers to nothing defined before it,
/// with its line.
fn check_obj_text(text: &str) -> Result<(), Located> {
    let (mut v, mut vt, mut vn) = (0usize, 0usize, 0usize);
    let any_vt = text.lines().any(|l| l.split_whitespace().next() == Some("vt"));
    let any_vn = text.lines().any(|l| l.split_whitespace().next() == Some("vn"));
    for (n, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                v += 1;
                if let Some(bad) = words.take(3).filter_map(|w| w.parse::<f64>().ok()).find(|c| !c.is_finite()) {
                    return Err((Some(n + 1), SceneErrorKind::NotFinite(bad)));
                }
            }
            Some("vt") => vt += 1,
            Some("vn") => vn += 1,
            Some("f") => {
                for w in words {
                    let mut parts = w.split('/');
                    let Ok(idx) = parts.next().unwrap_or("").parse::<i64>() else {
                        return Err((Some(n + 1), SceneErrorKind::Obj(format!("bad face vertex `{}`", crate::excerpt::excerpt(w)))));
                    };
                    if !in_range(idx, v) {
                        return Err((Some(n + 1), SceneErrorKind::ObjIndexOutOfRange { index: idx, count: v }));
                    }
                    // Texture and normal indices are only used when the file has some.
                    for (part, count, used, what) in [(parts.next(), vt, any_vt, "texture"), (parts.next(), vn, any_vn, "normal")] {
                        let Some(part) = part.filter(|p| !p.is_empty()) else { continue };
                        let ok = part.parse::<i64>().is_ok_and(|i| !used || in_range(i, count));
                        if !ok {
                            let m = format!("bad {what} index in face vertex `{}` ({count} defined before it)", crate::excerpt::excerpt(w));
                            return Err((Some(n + 1), SceneErrorKind::Obj(m)));
                        }
                    }
                }
            }
            _ => {}
        }
    }
    Ok(())
}

/// Whether a 1-based (or negative, from the end) OBJ index refers to one of `count` items.
fn in_range(idx: i64, count: usize) -> bool {
    if idx > 0 {
        idx as u64 <= count as u64
    } else {
        idx < 0 && idx.unsigned_abs() <= count as u64
    }
}

/// Parses an ASCII or binary STL file.
///
/// # Errors
/// Where the file is wrong: the line (ASCII), or the byte offset (binary:
/// a file shorter than its triangle count says, a coordinate that is not
/// finite), and what is wrong.
pub fn parse_stl(bytes: &[u8]) -> Result<RawMesh, Located> {
    // stl_io's own test: ASCII when the first line starts with "solid ".
    let ascii = bytes.starts_with(b"solid ");
    if !ascii {
        check_binary_stl(bytes).map_err(|m| (None, SceneErrorKind::Stl(m)))?;
    }
    let stl = stl_io::read_stl(&mut Cursor::new(bytes)).map_err(|e| match ascii.then(|| ascii_stl_problem(bytes)).flatten() {
        Some((line, message)) => (Some(line), SceneErrorKind::Stl(message)),
        None => (None, SceneErrorKind::Stl(crate::excerpt::excerpt_of(&e.to_string(), 200))),
    })?;
    let mut mesh =
        RawMesh { vertices: Vec::with_capacity(stl.vertices.len()), polygons: Vec::with_capacity(stl.faces.len()), rounding: 0.0 };
    // An f32 is within half a unit in its last place (2^-24 relative) of the
    // value it was rounded from.
    let largest = stl.vertices.iter().flat_map(|v| v.0.iter()).map(|c| c.abs()).fold(0.0f32, f32::max);
    mesh.rounding = f64::from(largest) * f64::from(f32::EPSILON) * 0.5;
    for v in &stl.vertices {
        mesh.vertices.push(DVec3::new(f64::from(v[0]), f64::from(v[1]), f64::from(v[2])));
    }
    for f in &stl.faces {
        if f.vertices.iter().any(|&i| i >= mesh.vertices.len()) {
            return Err((None, SceneErrorKind::Stl("triangle refers to a missing vertex".into())));
        }
        mesh.polygons.push(f.vertices.iter().map(|&i| i as u32).collect());
    }
    Ok(mesh)
}

/// Bytes of a binary STL's header (80) and triangle count (4), and of one triangle.
const STL_HEADER: usize = 84;
const STL_TRIANGLE: usize = 50;

/// A binary STL must hold the triangles its header counts, with finite vertices.
fn check_binary_stl(bytes: &[u8]) -> Result<(), String> {
    let Some(count) = bytes.get(80..84) else {
        return Err(format!("binary STL of {} bytes ends inside its {STL_HEADER}-byte header", bytes.len()));
    };
    let count = u32::from_le_bytes([count[0], count[1], count[2], count[3]]) as usize;
    let need = STL_HEADER + count * STL_TRIANGLE;
    if bytes.len() < need {
        let k = (bytes.len() - STL_HEADER) / STL_TRIANGLE;
        return Err(format!(
            "truncated binary STL: the header counts {count} triangles ({need} bytes), the file ends at byte {} inside triangle {k}",
            bytes.len()
        ));
    }
    for k in 0..count {
        let at = STL_HEADER + k * STL_TRIANGLE + 12;
        for c in 0..9 {
            let o = at + 4 * c;
            let v = f32::from_le_bytes([bytes[o], bytes[o + 1], bytes[o + 2], bytes[o + 3]]);
            if !v.is_finite() {
                return Err(format!("byte {o}: triangle {k}: vertex coordinate {v} is not a finite number"));
            }
        }
    }
    Ok(())
}

/// Where an ASCII STL that stl_io refused goes wrong: the 1-based line and
/// what was expected there (stl_io names neither). Follows stl_io's grammar:
/// `solid`, then `facet normal x y z`, `outer loop`, three `vertex x y z`,
/// `endloop`, `endfacet` per triangle, then `endsolid`; blank lines skipped.
fn ascii_stl_problem(bytes: &[u8]) -> Option<(usize, String)> {
    let text = match std::str::from_utf8(bytes) {
        Ok(t) => t,
        Err(e) => {
            let line = 1 + bytes[..e.valid_up_to()].iter().filter(|&&b| b == b'\n').count();
            return Some((line, "not UTF-8 text".to_owned()));
        }
    };
    let mut lines = text.lines().enumerate().map(|(n, l)| (n + 1, l.split_whitespace().collect::<Vec<_>>())).filter(|(_, w)| !w.is_empty());
    lines.next()?;
    let last = text.lines().count().max(1);
    let finite = |ws: &[&str]| ws.iter().all(|w| w.parse::<f32>().is_ok_and(f32::is_finite));
    let wrong = |n: usize, expected: &str, got: &[&str]| {
        Some((n, format!("expected `{expected}`, found `{}`", crate::excerpt::excerpt(&got.join(" ")))))
    };
    loop {
        let Some((n, w)) = lines.next() else { return Some((last, "the file ends before `endsolid`".to_owned())) };
        if w[0] == "endsolid" {
            return None;
        }
        if !(w.len() == 5 && w[0] == "facet" && w[1] == "normal" && finite(&w[2..])) {
            return wrong(n, "facet normal x y z", &w);
        }
        let mut expect = vec![("outer loop", 2)];
        expect.extend([("vertex x y z", 4); 3]);
        expect.extend([("endloop", 1), ("endfacet", 1)]);
        for (what, len) in expect {
            let Some((n, w)) = lines.next() else { return Some((last, format!("the file ends where `{what}` should be"))) };
            let head: Vec<&str> = what.split(' ').take_while(|t| !["x", "y", "z"].contains(t)).collect();
            if !(w.len() == len && w[..head.len()] == head[..] && finite(&w[head.len()..])) {
                return wrong(n, what, &w);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SQUARE: &str = "# a square and a triangle\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\nf 1/1 2/2 -1\n";

    #[test]
    fn rounding_is_half_a_unit_of_the_coarsest_last_digit() {
        assert_eq!(written_rounding("v 0 1 2\nv 1 1 1\n"), 0.0);
        assert_eq!(written_rounding("v 0.000000 1.000000 -2.500000\n"), 0.5e-6);
        assert_eq!(written_rounding("v 0.1200 1.5000 2\nf 1 2 3\nvt 0.1 0.2\n"), 0.5e-4);
        assert_eq!(written_rounding("v 0.1200 1.5 2\n"), 0.05, "zeros kept: the coarsest last digit");
        assert!((written_rounding("v 1.5e-3 2.25E-4 1.00e-5\n") - 0.5e-4).abs() < 1e-18);
        assert_eq!(parse_obj(b"v 0.12 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap().rounding, 0.005);
    }

    #[test]
    fn rounding_of_significant_digits_with_zeros_dropped() {
        // `%g`: 6 significant digits, trailing zeros dropped. `15.5` is
        // 15.5000, not a coordinate rounded to 0.05.
        let r = written_rounding("v 15.1234 15.5 14\nv 14.9 15.0625 15.9999\nv 0.123457 1.23457e-05 -15.1111\n");
        assert!((r - 0.5e-4).abs() < 1e-18, "{r}");
        // The largest coordinate sets it: 6 digits at 150 leave 3 decimals.
        assert!((written_rounding("v 15.1234 150.5 1.5\n") - 0.5e-3).abs() < 1e-18);
        // Rounded to 4 places and printed shortest: 0.5 is 0.5000.
        assert!((written_rounding("v -0.9667 0.5 0.1234\nv -1 0.25 -0.0321\n") - 0.5e-4).abs() < 1e-18);
        // Varying decimals of fewer digits, typed by hand: 1.5 is 1.50.
        assert!((written_rounding("v 0.1234 1.5 2\nf 1 2 3\n") - 0.5e-3).abs() < 1e-18);
    }

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

    /// Issue #20: tobj's errors (a malformed line anywhere) named no line.
    #[test]
    fn obj_errors_name_their_line() {
        let cases: &[(&str, usize)] = &[
            ("v 0 0 0\nv 1 0 0\nv 1 x 0\nf 1 2 3\n", 3),
            ("v 0 0 0\nv 1 0 0\n\nv 0 1 0 0\nf 1 2 3\n", 4),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0\nf 1 2 3\n", 4),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//9 3//1\n", 5),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl\n", 4),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 1 1e-320\nf 1 2 4\n", 5),
        ];
        for (text, line) in cases {
            let (at, kind) = parse_obj(text.as_bytes()).unwrap_err();
            assert_eq!(at, Some(*line), "{text:?}: {kind}");
        }
    }

    /// Issue #20: a truncated binary STL gave no offset.
    #[test]
    fn stl_errors_name_their_byte_or_line() {
        let mut bin = vec![0u8; 80];
        bin.extend(3u32.to_le_bytes());
        bin.extend([0u8; 70]);
        let (_, kind) = parse_stl(&bin).unwrap_err();
        let m = kind.to_string();
        assert!(m.contains("counts 3 triangles (234 bytes)") && m.contains("ends at byte 154 inside triangle 1"), "{m}");
        let (_, kind) = parse_stl(&bin[..40]).unwrap_err();
        assert!(kind.to_string().contains("40 bytes ends inside its 84-byte header"), "{kind}");
        bin.truncate(84);
        bin[80] = 1;
        bin.extend([0u8; 50]);
        bin[84 + 12 + 4..84 + 12 + 8].copy_from_slice(&f32::NAN.to_le_bytes());
        let (_, kind) = parse_stl(&bin).unwrap_err();
        assert!(kind.to_string().contains("byte 100: triangle 0"), "{kind}");
        let ascii =
            "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n\nvertex 0 nan 0\nendloop\nendfacet\nendsolid t\n";
        let (line, kind) = parse_stl(ascii.as_bytes()).unwrap_err();
        assert_eq!(line, Some(7), "{kind}");
        assert!(kind.to_string().contains("expected `vertex x y z`, found `vertex 0 nan 0`"), "{kind}");
        let (line, kind) = parse_stl(b"solid t\nfacet normal 0 0 1\nouter loop\n").unwrap_err();
        assert_eq!(line, Some(3), "{kind}");
        let long = format!("solid t\nfacet normal 0 0 1\nouter loop\nvertex {}\n", "1".repeat(100_000));
        let (line, kind) = parse_stl(long.as_bytes()).unwrap_err();
        assert!(line == Some(4) && kind.to_string().len() < 200, "{kind}");
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
