//! Map scenes through the scene file: loading the bundled examples, frame
//! sequences, and the bad-input table of issue 7 (every error names the file
//! and the row, column or position; never a panic).

use hiddenline::DVec3;

use scene::Scene;
use std::path::{Path, PathBuf};

fn examples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples")
}

const CAMERA: &str = "[camera]\neye = [-9.0, -17.0, 10.0]\ntarget = [0.0, 0.0, 1.0]\nfov_deg = 32.0\n";

/// A scene file at `examples/` level (so `map/...` paths resolve), never
/// written to disk.
fn scene(text: &str) -> Result<Scene, scene::SceneError> {
    Scene::from_toml(text, &examples().join("inline.toml"))
}

#[test]
fn bundled_map_example_loads_and_lowers() {
    let s = Scene::load(examples().join("map.toml")).unwrap();
    assert_eq!(s.frame_count(), 1);
    let m = s.lower();
    // 12 hexagonal prisms: 8 faces and 18 edges each.
    assert_eq!(m.faces.len(), 12 * 8);
    // Free lines: the outline on pen 1 and the town labels on pen 2.
    let outline = m.edges.iter().filter(|e| e.faces.is_empty() && e.pen != 2).count();
    let labels = m.edges.iter().filter(|e| e.faces.is_empty() && e.pen == 2).count();
    assert_eq!(m.edges.len() - outline - labels, 12 * 18);
    // The boundary (48 segments), 3 region boundaries (6 each), an island (10).
    assert_eq!(outline, 48 + 18 + 10);
    assert!(labels >= 12 * 4, "every town is labelled: {labels} label strokes");
    // The outline lies on the ground; labels on it too, or upright over a
    // symbol where the ground around it is out of sight (issue 40).
    assert!(m.edges.iter().filter(|e| e.faces.is_empty() && e.pen != 2).all(|e| e.a.z == 0.0 && e.b.z == 0.0));
    let on_ground = m.edges.iter().filter(|e| e.faces.is_empty() && e.pen == 2 && e.a.z == 0.0 && e.b.z == 0.0).count();
    assert!(on_ground * 2 > labels, "most labels lie on the ground: {on_ground} of {labels} strokes");
    // The tallest prism is Gorlund's: 474.3 thousand x 0.01.
    let top = m.faces.iter().flat_map(|f| &f.outer).map(|p| p.z).fold(0.0, f64::max);
    assert!((top - 4.743).abs() < 1e-12, "{top}");
}

#[test]
fn movie_frames_start_and_end_on_the_data_columns() {
    let movie = Scene::load(examples().join("map_movie.toml")).unwrap();
    assert_eq!(movie.frame_count(), 48);
    let frames: Vec<Scene> = movie.frames().collect::<Result<_, _>>().unwrap();
    assert_eq!(frames.len(), 48);
    assert!(movie.frame(48).is_err());
    let still = |value: &str, eye: [f64; 3], target: [f64; 3]| {
        let text = std::fs::read_to_string(examples().join("map_movie.toml")).unwrap();
        let cut = text.find("[animation]").unwrap();
        let text = text[..cut]
            .replace("eye = [-9.0, -17.0, 10.0]", &format!("eye = {eye:?}"))
            .replace("target = [0.0, 0.0, 1.0]", &format!("target = {target:?}"))
            .replace("pen = 2", &format!("pen = 2\nvalue = \"{value}\""));
        Scene::from_toml(&text, &examples().join("map_movie.toml")).unwrap()
    };
    let first = still("pop1970", [-9.0, -17.0, 10.0], [0.0, 0.0, 1.0]);
    let last = still("pop2000", [12.0, -15.0, 6.0], [0.0, 0.0, 1.5]);
    assert_eq!(frames[0].camera, first.camera);
    assert_eq!(frames[0].lower(), first.lower(), "frame 0 is the 1970 map, bit for bit");
    assert_eq!(frames[47].camera, last.camera);
    assert_eq!(frames[47].lower(), last.lower(), "the last frame is the 2000 map, bit for bit");
    // In between the camera moves and the symbols grow or shrink.
    assert!(frames[20].camera.eye != first.camera.eye && frames[20].camera.eye != last.camera.eye);
    assert_ne!(frames[20].lower(), first.lower());
    // The middle frame (47 / 2 = 23.5 is between columns): frame 23 is just
    // before the 1985 column, and heights move monotonically per segment.
    let top = |s: &Scene| s.lower().faces.iter().flat_map(|f| f.outer.clone()).map(|p: DVec3| p.z).fold(0.0, f64::max);
    assert!(top(&frames[0]) < top(&frames[47]));
}

fn err(text: &str) -> String {
    match scene(text) {
        Ok(_) => panic!("loaded, expected an error:\n{text}"),
        Err(e) => e.to_string(),
    }
}

/// Writes `files` into a fresh directory and loads `text` from there.
fn err_with(case: &str, text: &str, files: &[(&str, &str)]) -> String {
    let dir = crate::case_dir("map-scene", case);
    for (name, body) in files {
        std::fs::write(dir.path().join(name), body).unwrap();
    }
    match Scene::from_toml(text, &dir.path().join("scene.toml")) {
        Ok(_) => panic!("{case}: loaded, expected an error"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn bad_input_table() {
    let outline = ("o.csv", "0,0,1\n10,0,0\n10,10,0\n");
    let map = "[[map]]\noutline = \"o.csv\"\n";
    let sym = |extra: &str| format!("{CAMERA}{map}[[symbols]]\ndata = \"p.csv\"\n{extra}");
    // (case, scene text, files, expected pieces of the message)
    // A table of cases: its row type spelled out is the clearest documentation.
    #[allow(clippy::type_complexity)]
    let cases: Vec<(&str, String, Vec<(&str, &str)>, Vec<&str>)> = vec![
        ("missing coordinate", sym(""), vec![outline, ("p.csv", "name,x,y,value\nA,1,2,3\nB,4,,5\n")], vec!["p.csv", "row 3", "column `y`", "missing"]),
        ("missing value", sym(""), vec![outline, ("p.csv", "name,x,y,value\nA,1,2\n")], vec!["p.csv", "row 2", "`value`"]),
        ("value not a number", sym(""), vec![outline, ("p.csv", "name,x,y,value\nA,1,2,many\n")], vec!["row 2", "`many` is not a number"]),
        ("negative value", sym(""), vec![outline, ("p.csv", "name,x,y,value\nA,1,2,-1\n")], vec!["row 2", "negative"]),
        ("no such column", sym("value = \"pop\"\n"), vec![outline, ("p.csv", "name,x,y,value\n")], vec!["no value column `pop`"]),
        (
            "invalid geojson",
            format!("{CAMERA}[[map]]\noutline = \"o.geojson\"\n"),
            vec![("o.geojson", "{\"type\": \"FeatureCollection\",\n \"features\": [\n  {\"type\": \"Feature\" \"geometry\": null}]}")],
            vec!["o.geojson", "line 3", "invalid GeoJSON"],
        ),
        (
            "geojson ring too short",
            format!("{CAMERA}[[map]]\noutline = \"o.geojson\"\n"),
            vec![("o.geojson", r#"{"type":"MultiPolygon","coordinates":[[[[0,0],[1,0],[1,1],[0,0]]],[[[0,0],[1,1],[0,0]]]]}"#)],
            vec!["geometry.coordinates[1][0]", "at least 4 positions"],
        ),
        (
            "not convex",
            sym("shape = \"s.obj\"\n"),
            vec![
                outline,
                ("p.csv", "name,x,y,value\nA,1,2,3\n"),
                (
                    "s.obj",
                    "v 0 0 0\nv 1 0 0\nv 0.5 0.2 0\nv 0.5 1 0\nv 0 0 1\nv 1 0 1\nv 0.5 0.2 1\nv 0.5 1 1\n\
                     f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n",
                ),
            ],
            vec!["s.obj", "not convex", "vertex"],
        ),
        ("unknown shape", sym("shape = \"sphere\"\n"), vec![outline, ("p.csv", "name,x,y,value\n")], vec!["symbols[0]", "`shape`", "sphere"]),
        ("bad size", sym("size = 0.0\n"), vec![outline, ("p.csv", "name,x,y,value\n")], vec!["symbols[0]", "`size`"]),
        ("missing data file", sym(""), vec![outline], vec!["p.csv", "cannot read"]),
        (
            "mercator pole",
            format!("{CAMERA}[[map]]\noutline = \"o.csv\"\nprojection = \"mercator\"\n"),
            vec![("o.csv", "0,0,1\n0,89.9,0\n")],
            vec!["o.csv", "row 2", "latitude"],
        ),
        (
            "lon/lat place off the globe",
            sym(""),
            vec![outline, ("p.csv", "name,lon,lat,value\nA,10,95,1\n")],
            vec!["p.csv", "row 2", "latitude"],
        ),
        ("labels without symbols", format!("{CAMERA}{map}[[labels]]\nsymbols = 2\n"), vec![outline], vec!["labels[0]", "no symbols[2]"]),
        ("zero frames", format!("{CAMERA}{map}[animation]\nframes = 0\n"), vec![outline], vec!["animation", "frames"]),
        (
            "keyframe on target",
            format!("{CAMERA}{map}[animation]\nframes = 3\n[[animation.camera]]\nframe = 0\neye = [1.0, 0.0, 1.0]\n[[animation.camera]]\nframe = 2\neye = [0.0, 0.0, 1.0]\n"),
            vec![outline],
            vec!["animation.camera (frame 2)"],
        ),
        ("unknown key", format!("{CAMERA}[[map]]\noutline = \"o.csv\"\nscael = 2.0\n"), vec![outline], vec!["scael"]),
    ];
    for (case, text, files, want) in cases {
        let msg = err_with(&case.replace(' ', "-"), &text, &files);
        for w in want {
            assert!(msg.contains(w), "{case}: {msg:?} lacks {w:?}");
        }
    }
    // Errors in a table point at its line in the scene file.
    let msg = err(&format!("{CAMERA}[[map]]\noutline = \"map/westmark.geojson\"\nscale = -1.0\n"));
    assert!(msg.contains("inline.toml:5") || msg.contains("inline.toml:6"), "{msg}");
}
