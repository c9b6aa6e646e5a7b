//! `plotd render` as a user runs it: the binary, real files, exit codes.

use std::path::{Path, PathBuf};
use std::process::Command;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn out_dir(case: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("plotd-render-cli-{}-{case}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn plotd(args: &[&std::ffi::OsStr]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_plotd")).args(args).output().unwrap()
}

#[test]
fn every_bundled_example_renders_to_svg() {
    let dir = out_dir("examples");
    let mut n = 0;
    for entry in std::fs::read_dir(repo().join("examples")).unwrap() {
        let scene = entry.unwrap().path();
        if scene.extension().is_none_or(|e| e != "toml") {
            continue;
        }
        let out = dir.join(scene.file_stem().unwrap()).with_extension("svg");
        let o = plotd(&["render".as_ref(), scene.as_os_str(), "-o".as_ref(), out.as_os_str()]);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success(), "{}: {stderr}", scene.display());
        // The one-line summary names the output, the visible length and strokes.
        let last = stderr.lines().last().unwrap_or("");
        assert!(last.contains("visible length") && last.contains("strokes"), "{last}");
        // No device: the generic motion model's time, once.
        assert!(last.contains(" (generic plotter)") && last.matches("plot time").count() == 1, "{last}");
        let svg = std::fs::read_to_string(&out).unwrap();
        assert!(svg.contains("<svg") && (svg.contains("<path") || svg.contains("<polyline")), "{}", out.display());
        n += 1;
    }
    assert!(n >= 5, "only {n} examples");
}

#[test]
fn bad_scene_exits_1_naming_file_line_and_field() {
    let dir = out_dir("bad");
    let scene = dir.join("bad.toml");
    std::fs::write(
        &scene,
        "[camera]\neye = [1, 2, 3]\ntarget = [0, 0, 0]\nfov_deg = 30.0\n\n[[polygon]]\nouter = [[0, 0, 0], [1, 0, nan], [0, 1, 0]]\n",
    )
    .unwrap();
    let out = dir.join("bad.svg");
    let o = plotd(&["render".as_ref(), scene.as_os_str(), "-o".as_ref(), out.as_os_str()]);
    assert_eq!(o.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains(&format!("{}:6: polygon[0].outer[1]", scene.display())), "{stderr}");
    assert!(!out.exists());
    // Missing scene file and unknown output format: exit 1 too.
    let o = plotd(&["render".as_ref(), dir.join("nothere.toml").as_os_str(), "-o".as_ref(), out.as_os_str()]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("nothere.toml"));
    let o = plotd(&["render".as_ref(), repo().join("examples/cube.toml").as_os_str(), "-o".as_ref(), dir.join("x.pdf").as_os_str()]);
    assert_eq!(o.status.code(), Some(1));
}
