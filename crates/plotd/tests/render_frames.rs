//! `plotd render` of an animated scene: one file per frame.

use std::path::{Path, PathBuf};
use std::process::Command;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn out_dir(case: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("plotd-render-frames-{}-{case}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn render(scene: &Path, out: &Path) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_plotd")).arg("render").arg(scene).arg("-o").arg(out).output().unwrap()
}

#[test]
fn animated_scene_writes_one_file_per_frame() {
    let dir = out_dir("movie");
    let scene = repo().join("examples/map_movie.toml");
    let o = render(&scene, &dir.join("frames/frame-%04d.svg"));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    let mut names: Vec<String> = std::fs::read_dir(dir.join("frames"))
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    names.sort();
    assert_eq!(names.len(), 48);
    assert_eq!((names[0].as_str(), names[47].as_str()), ("frame-0000.svg", "frame-0047.svg"));
    // One summary line per frame.
    assert_eq!(stderr.lines().filter(|l| l.contains("visible length")).count(), 48);
    // A single-file render of an animated scene is its frame 0, byte for byte.
    let single = dir.join("single.svg");
    let o = render(&scene, &single);
    assert!(o.status.success());
    let first = std::fs::read(dir.join("frames/frame-0000.svg")).unwrap();
    assert_eq!(std::fs::read(&single).unwrap(), first);
    assert_ne!(std::fs::read(dir.join("frames/frame-0047.svg")).unwrap(), first);
}

#[test]
fn still_scene_with_a_pattern_writes_one_frame_and_bad_patterns_fail() {
    let dir = out_dir("still");
    let o = render(&repo().join("examples/map.toml"), &dir.join("f-%d.svg"));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(dir.join("f-0.svg").exists());
    let o = render(&repo().join("examples/map.toml"), &dir.join("f-%s.svg"));
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("frame number"));
}
