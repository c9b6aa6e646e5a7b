//! `plotd render` as a user runs it: the binary, real files, exit codes.

use crate::repo;
use std::process::Command;

fn plotd(args: &[&std::ffi::OsStr]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_plotd")).args(args).output().unwrap()
}

#[test]
fn every_bundled_example_renders_to_svg() {
    let temp = crate::case_dir("render-cli", "examples");
    let dir = temp.path();
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
    let temp = crate::case_dir("render-cli", "bad");
    let dir = temp.path();
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

/// A dense surface with a 0.3 mm pen warns that its lines run together,
/// says how much and what helps; every fourth line, or a finer pen, does not
/// (issue 40 item 2: a 400 x 400 surface came out solid black, unwarned).
#[test]
fn a_surface_too_dense_for_the_pen_warns_and_says_what_helps() {
    let temp = crate::case_dir("render-cli", "crowded");
    let dir = temp.path();
    let render = |every: &str, pen_width: &str| {
        let scene = dir.join(format!("dense-{every}-{pen_width}.toml"));
        std::fs::write(
            &scene,
            format!(
                "[camera]\neye = [5.0, -6.5, 4.0]\ntarget = [0.0, 0.0, 0.0]\nfov_deg = 35.0\n\n[[surface]]\n\
                 z = \"0.8 * exp(-x^2 - y^2)\"\nx = {{ from = -2.0, to = 2.0, steps = 400 }}\n\
                 y = {{ from = -2.0, to = 2.0, steps = 400 }}\n{every}\n"
            ),
        )
        .unwrap();
        let out = scene.with_extension("svg");
        let o = plotd(&["render".as_ref(), scene.as_os_str(), "-o".as_ref(), out.as_os_str(), "--pen-width".as_ref(), pen_width.as_ref()]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        String::from_utf8_lossy(&o.stderr).into_owned()
    };
    let dense = render("", "0.3");
    let warning = dense.lines().find(|l| l.contains("solid band")).unwrap_or_else(|| panic!("no crowding warning: {dense}"));
    assert!(
        warning.contains("pen 1") && warning.contains("every = ") && warning.contains("closer than the pen's width (0.30 mm)"),
        "{warning}"
    );
    let share: f64 = warning.split(" % of its").next().and_then(|s| s.rsplit(' ').next()).and_then(|s| s.parse().ok()).unwrap();
    assert!(share > 20.0, "{warning}");
    for (every, width) in [("every = 4", "0.3"), ("", "0.05")] {
        let stderr = render(every, width);
        assert!(!stderr.contains("solid band"), "{every} with a {width} mm pen: {stderr}");
    }
}
