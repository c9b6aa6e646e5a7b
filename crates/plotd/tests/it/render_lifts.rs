//! No pen lift travels nowhere (issue 40): in every bundled example's
//! output, as SVG, HP-GL and G-code read back with plotcode's parsers, each
//! pen-up move between two strokes of one pen is longer than the snapping
//! tolerance. (Before, `examples/lattice.toml` lifted the pen 101 times, 15
//! of them to put it down where it was, and the cube 1 of 3.)

use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::process::Command;
use strokes::{Drawing, DEFAULT_TOLERANCE_MM};

fn examples() -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples");
    let mut scenes: Vec<PathBuf> =
        std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().path()).filter(|p| p.extension().is_some_and(|e| e == "toml")).collect();
    scenes.sort();
    scenes
}

/// The drawing `plotd render SCENE -o OUT` writes, read back.
fn rendered(scene: &Path, out: &Path) -> Drawing {
    let o = Command::new(env!("CARGO_BIN_EXE_plotd"))
        .args([OsStr::new("render"), scene.as_os_str(), "-o".as_ref(), out.as_os_str()])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}: {}", scene.display(), String::from_utf8_lossy(&o.stderr));
    let bytes = std::fs::read(out).unwrap();
    let text = String::from_utf8(bytes.clone()).unwrap();
    match out.extension().and_then(OsStr::to_str) {
        Some("svg") => plotcode::svg_import::read(&text, &plotcode::svg_import::ImportOptions::default()).unwrap(),
        Some("hpgl") => {
            let profile = plotcode::DeviceProfile::builtin("hp7475a").unwrap();
            plotcode::hpgl::parse(&bytes).unwrap().to_drawing(&profile, None)
        }
        _ => {
            let profile = plotcode::DeviceProfile::builtin("grbl-servo").unwrap();
            plotcode::gcode::parse(&text, &plotcode::gcode::ParseOptions::for_profile(&profile)).unwrap().to_drawing(&profile, None)
        }
    }
}

#[test]
fn no_bundled_example_lifts_the_pen_to_put_it_down_where_it_was() {
    let dir = tempfile::tempdir().unwrap();
    let mut checked = 0;
    let mut short = Vec::new();
    for scene in examples() {
        for ext in ["svg", "hpgl", "gcode"] {
            let out = dir.path().join(scene.file_stem().unwrap()).with_extension(ext);
            let drawing = rendered(&scene, &out);
            for layer in &drawing.layers {
                for w in layer.polylines.windows(2) {
                    let (end, start) = (w[0].points[w[0].points.len() - 1], w[1].points[0]);
                    checked += 1;
                    if end.distance(start) <= DEFAULT_TOLERANCE_MM {
                        short.push(format!("{}: pen {} up at {end} for {:.4} mm", out.display(), layer.pen, end.distance(start)));
                    }
                }
            }
        }
    }
    assert!(checked > 300, "only {checked} pen-up moves: the examples draw too little to test");
    assert!(short.is_empty(), "{} pen lifts travel nowhere:\n{}", short.len(), short.join("\n"));
}
