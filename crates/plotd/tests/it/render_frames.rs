//! `plotd render` of an animated scene: one file per frame.

use crate::repo;
use std::path::Path;
use std::process::Command;

fn render(scene: &Path, out: &Path) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_plotd")).arg("render").arg(scene).arg("-o").arg(out).output().unwrap()
}

#[test]
fn animated_scene_writes_one_file_per_frame() {
    let temp = crate::case_dir("render-frames", "movie");
    let dir = temp.path();
    let scene = repo().join("examples/map_movie.toml");
    let o = render(&scene, &dir.join("frames/frame-%04d.svg"));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    let mut names: Vec<String> =
        std::fs::read_dir(dir.join("frames")).unwrap().map(|e| e.unwrap().file_name().into_string().unwrap()).collect();
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
    let temp = crate::case_dir("render-frames", "still");
    let dir = temp.path();
    let o = render(&repo().join("examples/map.toml"), &dir.join("f-%d.svg"));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(dir.join("f-0.svg").exists());
    let o = render(&repo().join("examples/map.toml"), &dir.join("f-%s.svg"));
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("frame number"));
}

/// Each frame's device file is what a single render of that frame emits for
/// the device, byte for byte: HP-GL for the default device, G-code for `--device`.
#[test]
fn animated_scene_writes_one_device_file_per_frame() {
    let scene_path = repo().join("examples/surface_orbit.toml");
    let scene = scene::Scene::load(&scene_path).unwrap();
    assert!(scene.frame_count() > 2);
    for (ext, device, extra) in [("hpgl", "hp7475a", None), ("gcode", "grbl-servo", Some("grbl-servo"))] {
        let temp = crate::case_dir("render-frames", ext);
        let dir = temp.path();
        let pattern = dir.join(format!("f-%02d.{ext}"));
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_plotd"));
        cmd.arg("render").arg(&scene_path).arg("-o").arg(&pattern);
        if let Some(d) = extra {
            cmd.args(["--device", d]);
        }
        let o = cmd.output().unwrap();
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success(), "{stderr}");
        assert_eq!(stderr.lines().filter(|l| l.contains(device)).count(), scene.frame_count(), "{stderr}");
        let profile = plotcode::DeviceProfile::builtin(device).unwrap();
        let mut texts = Vec::new();
        for i in 0..scene.frame_count() {
            let drawing = plotd::pipeline::plotted_drawing(scene.frame(i).unwrap()).unwrap();
            let want = plotcode::emit(&drawing, &profile, &plotcode::EmitOptions::default()).unwrap().text;
            let got = std::fs::read_to_string(dir.join(format!("f-{i:02}.{ext}"))).unwrap();
            assert_eq!(got, want, "frame {i} ({ext})");
            texts.push(got);
        }
        assert_ne!(texts[0], texts[texts.len() - 1], "the camera moves");
    }
}
