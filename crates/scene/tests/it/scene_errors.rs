//! Every kind of bad scene input gives a clear error naming the file, the
//! line and the field, never a panic (issue 2, "Bad input").

use scene::Scene;
use scene::SceneErrorKind;
use tempfile::TempDir;

const CAMERA: &str = "[camera]\neye = [6.0, 8.0, 3.0]\ntarget = [0.0, 0.0, 0.0]\nfov_deg = 30.0\n";
const TRI: &str = "\n[[polygon]]\nouter = [[0, 0, 0], [1, 0, 0], [0, 1, 0]]\n";
const CUBE_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
                        f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";

/// A fresh directory holding `files` (name, contents), removed when dropped.
fn dir_with(case: &str, files: &[(&str, &[u8])]) -> TempDir {
    let dir = crate::case_dir("scene-errors", case);
    for (name, body) in files {
        std::fs::write(dir.path().join(name), body).unwrap();
    }
    dir
}

/// Loads `scene` (with `files` beside it) and checks the error: its file
/// ends with `file`, its line, a predicate on its kind, and that its message
/// contains `text`.
fn check(case: &str, scene: &str, files: &[(&str, &[u8])], file: &str, line: Option<usize>, kind: fn(&SceneErrorKind) -> bool, text: &str) {
    let dir = dir_with(case, files);
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, scene).unwrap();
    let err = match Scene::load(&path) {
        Ok(_) => panic!("{case}: loaded, expected an error"),
        Err(e) => e,
    };
    let msg = err.to_string();
    assert!(err.file.ends_with(file), "{case}: file {} (message: {msg})", err.file.display());
    assert_eq!(err.line, line, "{case}: line (message: {msg})");
    assert!(kind(&err.kind), "{case}: kind {:?}", err.kind);
    assert!(msg.contains(text), "{case}: message {msg:?} lacks {text:?}");
    assert!(msg.starts_with(&err.file.display().to_string()), "{case}: message does not start with the file: {msg}");
}

#[test]
fn every_bad_input_names_file_line_and_field() {
    use SceneErrorKind as K;
    let broken_obj = format!("{CAMERA}\n[[mesh]]\npath = \"m.obj\"\n");
    // A table of cases: its row type spelled out is the clearest documentation.
    #[allow(clippy::type_complexity)]
    let cases: &[(&str, String, &[(&str, &[u8])], &str, Option<usize>, fn(&K) -> bool, &str)] = &[
        ("malformed", format!("{CAMERA}\n[[polygon]\nouter = 1\n"), &[], "scene.toml", Some(6), |k| matches!(k, K::Toml(_)), ""),
        ("unknown-key", format!("{CAMERA}{TRI}colour = 3\n"), &[], "scene.toml", Some(8), |k| matches!(k, K::Toml(_)), "colour"),
        ("wrong-type", format!("{CAMERA}{TRI}pen = \"red\"\n"), &[], "scene.toml", Some(8), |k| matches!(k, K::Toml(_)), "pen"),
        ("no-camera", TRI.to_string(), &[], "scene.toml", Some(1), |k| matches!(k, K::Toml(_)), "camera"),
        // The TOML parser's recursion limit comes with no place (found by
        // the fuzz campaign): the line is found by parsing prefixes.
        (
            "dotted-key-too-deep",
            format!("{CAMERA}\n[page]\nsize{} = 1\n", ".a".repeat(200)),
            &[],
            "scene.toml",
            Some(7),
            |k| matches!(k, K::Toml(_)),
            "recursion limit",
        ),
        (
            "missing-mesh",
            format!("{CAMERA}\n\n[[mesh]]\npath = \"nothere.obj\"\n"),
            &[],
            "scene.toml",
            Some(7),
            |k| matches!(k, K::MeshFile { .. }),
            "mesh[0].path: mesh file",
        ),
        (
            "mesh-format",
            format!("{CAMERA}\n[[mesh]]\npath = \"m.ply\"\n"),
            &[("m.ply", b"ply\n")],
            "scene.toml",
            Some(6),
            |k| matches!(k, K::MeshFile { .. }),
            "unknown mesh format",
        ),
        (
            "obj-index",
            broken_obj.clone(),
            &[("m.obj", b"v 0 0 0\nv 1 0 0\nv 1 1 0\n\nf 1 2 3\nf 1 2 7\n")],
            "m.obj",
            Some(6),
            |k| matches!(k, K::ObjIndexOutOfRange { index: 7, count: 3 }),
            "vertex 7",
        ),
        (
            "obj-nan",
            broken_obj.clone(),
            &[("m.obj", b"v 0 0 0\nv 1 nan 0\nv 1 1 0\nf 1 2 3\n")],
            "m.obj",
            Some(2),
            |k| matches!(k, K::NotFinite(_)),
            "not a finite",
        ),
        (
            "stl-garbage",
            format!("{CAMERA}\n[[mesh]]\npath = \"m.stl\"\n"),
            &[("m.stl", b"solid x\nfacet normal what\n")],
            "m.stl",
            Some(2),
            |k| matches!(k, K::Stl(_)),
            "STL",
        ),
        (
            "non-planar",
            format!("{CAMERA}\n[[polygon]]\nouter = [[0, 0, 0], [1, 0, 0], [1, 1, 0.5], [0, 1, 0]]\n"),
            &[],
            "scene.toml",
            Some(6),
            |k| matches!(k, K::NonPlanar { .. }),
            "polygon[0].outer: polygon is not planar",
        ),
        (
            "nan-polygon",
            format!("{CAMERA}{TRI}\n[[polygon]]\nouter = [[0, 0, 0], [1, nan, 0], [0, 1, 0]]\n"),
            &[],
            "scene.toml",
            Some(9),
            |k| matches!(k, K::NotFinite(_)),
            "polygon[1].outer[1]",
        ),
        (
            "inf-polyline",
            format!("{CAMERA}\n[[polyline]]\npoints = [[0, 0, 0], [1, 0, inf]]\n"),
            &[],
            "scene.toml",
            Some(6),
            |k| matches!(k, K::NotFinite(_)),
            "polyline[0].points[1]",
        ),
        (
            "eye-at-target",
            format!("[camera]\neye = [1.0, 1.0, 1.0]\ntarget = [1.0, 1.0, 1.0]\nfov_deg = 30.0\n{TRI}"),
            &[],
            "scene.toml",
            Some(1),
            |k| matches!(k, K::Camera(hiddenline::CameraError::EyeAtTarget)),
            "camera.eye equals camera.target",
        ),
        (
            "up-parallel",
            format!("[camera]\neye = [0.0, 0.0, 5.0]\ntarget = [0.0, 0.0, 0.0]\nup = [0, 0, 2]\nfov_deg = 30.0\n{TRI}"),
            &[],
            "scene.toml",
            Some(1),
            |k| matches!(k, K::Camera(hiddenline::CameraError::UpParallel)),
            "parallel",
        ),
        (
            "nan-eye",
            format!("[camera]\neye = [nan, 0.0, 5.0]\ntarget = [0.0, 0.0, 0.0]\nfov_deg = 30.0\n{TRI}"),
            &[],
            "scene.toml",
            Some(1),
            |k| matches!(k, K::Camera(hiddenline::CameraError::NotFinite { field: "eye" })),
            "camera.eye",
        ),
        (
            "two-projections",
            format!("{CAMERA}ortho_height = 3.0\n{TRI}"),
            &[],
            "scene.toml",
            Some(1),
            |k| matches!(k, K::Projection),
            "exactly one",
        ),
        ("empty", CAMERA.to_string(), &[], "scene.toml", None, |k| matches!(k, K::Empty), "empty"),
        (
            "only-degenerate",
            format!("{CAMERA}\n[[polygon]]\nouter = [[0, 0, 0], [1, 1, 1], [2, 2, 2]]\n"),
            &[],
            "scene.toml",
            None,
            |k| matches!(k, K::Empty),
            "empty",
        ),
        (
            "bad-page",
            format!("{CAMERA}{TRI}\n[page]\nsize = \"B7\"\n"),
            &[],
            "scene.toml",
            Some(9),
            |k| matches!(k, K::OutOfRange(_)),
            "page: unknown paper size",
        ),
        (
            "bad-margin",
            format!("{CAMERA}{TRI}\n[page]\nmargin_mm = 200.0\n"),
            &[],
            "scene.toml",
            Some(9),
            |k| matches!(k, K::OutOfRange(_)),
            "margin",
        ),
        (
            "bad-scale",
            format!("{CAMERA}\n[[mesh]]\npath = \"m.obj\"\ntransform = {{ scale = 0.0 }}\n"),
            &[("m.obj", CUBE_OBJ.as_bytes())],
            "scene.toml",
            Some(6),
            |k| matches!(k, K::OutOfRange(_)),
            "mesh[0].transform.scale",
        ),
        (
            "bad-edges",
            format!("{CAMERA}\n[[mesh]]\npath = \"m.obj\"\nedges = \"some\"\n"),
            &[("m.obj", CUBE_OBJ.as_bytes())],
            "scene.toml",
            Some(8),
            |k| matches!(k, K::Toml(_)),
            "some",
        ),
    ];
    for (case, scene, files, file, line, kind, text) in cases {
        check(case, scene, files, file, *line, *kind, text);
    }
}

/// Issue #20: coordinates past any sensible magnitude made the engines loop
/// (a town at longitude -1e308) or take gigabytes (a point at 1e10 beside a
/// sphere). Every coordinate beyond `MAX_COORDINATE` (after transforms,
/// projection, scale and offset) is an error naming the field.
#[test]
fn coordinates_beyond_the_limit_name_their_field() {
    use SceneErrorKind as K;
    let far = |k: &K| matches!(k, K::TooFar(_));
    let map = |k: &K| matches!(k, K::Map(_));
    let towns = b"name,lon,lat,value\nNear,10,50,1\nFar,-1e308,50,2\n" as &[u8];
    let outline = b"{\"type\":\"LineString\",\"coordinates\":[[0,0],[1e10,0]]}" as &[u8];
    #[allow(clippy::type_complexity)]
    let cases: &[(&str, String, &[(&str, &[u8])], Option<usize>, fn(&K) -> bool, &str)] = &[
        (
            "far-polyline",
            format!("{CAMERA}\n[[polyline]]\npoints = [[0, 0, 0], [1e10, 0, 0]]\n"),
            &[],
            Some(6),
            far,
            "polyline[0].points[1]: 1e10 is beyond",
        ),
        (
            "far-translate",
            format!("{CAMERA}\n[[polygon]]\nouter = [[0, 0, 0], [1, 0, 0], [0, 1, 0]]\ntransform = {{ translate = [0, 2e9, 0] }}\n"),
            &[],
            Some(6),
            far,
            "polygon[0].outer[0]: 2e9",
        ),
        (
            "far-mesh",
            format!("{CAMERA}\n[[mesh]]\npath = \"m.obj\"\ntransform = {{ scale = 2e9 }}\n"),
            &[("m.obj", CUBE_OBJ.as_bytes())],
            Some(6),
            far,
            "mesh[0] (vertex 2): 2e9",
        ),
        (
            "far-eye",
            "[camera]\neye = [1e10, 0, 0]\ntarget = [0, 0, 0]\nfov_deg = 30\n".to_owned() + TRI,
            &[],
            Some(1),
            far,
            "camera.eye: 1e10",
        ),
        (
            "far-surface",
            format!(
                "{CAMERA}\n[[surface]]\nz = \"1e12 * x\"\nx = {{ from = 0, to = 1, steps = 2 }}\ny = {{ from = 0, to = 1, steps = 2 }}\n"
            ),
            &[],
            Some(6),
            far,
            "surface[0]: 5e11",
        ),
        (
            "far-town",
            format!("{CAMERA}\n[[map]]\noutline = \"o.geojson\"\n\n[[symbols]]\ndata = \"towns.csv\"\n"),
            &[("o.geojson", b"{\"type\":\"LineString\",\"coordinates\":[[0,0],[1,0]]}"), ("towns.csv", towns)],
            None,
            map,
            "towns.csv: row 3: the place is at -1e308",
        ),
        (
            "far-outline",
            format!("{CAMERA}\n[[map]]\noutline = \"o.geojson\"\n"),
            &[("o.geojson", outline)],
            Some(6),
            map,
            "map[0]: `outline`: point 2 of line 1 is at 1e10",
        ),
    ];
    for (case, scene, files, line, kind, text) in cases {
        check(case, scene, files, "scene.toml", *line, *kind, text);
    }
}

#[test]
fn degenerate_faces_are_skipped_not_fatal() {
    let obj = format!("{CUBE_OBJ}f 1 2 1\nf 1 2 3 2 1\n");
    let dir = dir_with("degenerate", &[("m.obj", obj.as_bytes())]);
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, format!("{CAMERA}\n[[mesh]]\npath = \"m.obj\"\n\n[[polygon]]\nouter = [[0, 0, 0], [0, 0, 0], [0, 0, 0]]\n"))
        .unwrap();
    let scene = Scene::load(&path).unwrap();
    assert_eq!(scene.meshes[0].faces.len(), 6);
    assert!(scene.polygons.is_empty());
    let model = scene.lower();
    assert_eq!((model.faces.len(), model.edges.len()), (6, 12));
}

#[test]
fn a_scene_file_that_is_not_there() {
    let err = Scene::load("/nonexistent/scene.toml").unwrap_err();
    assert!(matches!(err.kind, SceneErrorKind::Io(_)));
    assert!(err.to_string().starts_with("/nonexistent/scene.toml: cannot read the file"));
}
