//! `plotd render` to and from device files: HP-GL and G-code outputs for the
//! bundled examples, `.hpgl` / `.gcode` inputs, and the bad-input cases.

use crate::repo;
use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::process::Command;

fn plotd(args: &[&OsStr]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_plotd")).args(args).output().unwrap()
}

fn render(input: &Path, out: &Path, extra: &[&str]) -> std::process::Output {
    let mut args: Vec<&OsStr> = vec!["render".as_ref(), input.as_os_str(), "-o".as_ref(), out.as_os_str()];
    args.extend(extra.iter().map(OsStr::new));
    plotd(&args)
}

#[test]
fn cube_to_hpgl_and_gcode_and_back() {
    let temp = crate::case_dir("render-device", "cube");
    let dir = temp.path();
    let scene = repo().join("examples/cube.toml");
    for (file, device) in [("cube.hpgl", "hp7475a"), ("cube.gcode", "grbl-servo"), ("cube_z.gcode", "grbl-z"), ("cube_a3.hpgl", "hp7585b")]
    {
        let out = dir.join(file);
        let o = render(&scene, &out, &["--device", device]);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success(), "{file}: {stderr}");
        let text = std::fs::read_to_string(&out).unwrap();
        let last = stderr.lines().last().unwrap();
        assert!(last.contains(&format!("{} bytes written", text.len())), "{last}");
        // One plot time, the device's.
        assert_eq!(last.matches("plot time").count(), 1, "{last}");
        let time = &last[last.find("est. plot time ").unwrap()..];
        assert!(time.split(',').next().unwrap().contains(&format!(" on {device} (")), "{last}");
        let strokes = if file.ends_with(".hpgl") {
            assert!(text.starts_with("IN;") && text.ends_with("PU;SP0;\n"));
            plotcode::hpgl::parse(text.as_bytes()).unwrap().strokes.len()
        } else {
            assert!(text.lines().all(|l| l.len() <= 79));
            let p = plotcode::DeviceProfile::builtin(device).unwrap();
            plotcode::gcode::parse(&text, &plotcode::gcode::ParseOptions::for_profile(&p)).unwrap().strokes.len()
        };
        assert!(strokes > 0, "{file}");
        // Read it back and re-emit in its own order: the same device file
        // again (true size, same paper), so reading and emitting lose nothing.
        let again = dir.join(format!("again_{file}"));
        let o = render(&out, &again, &["--device", device, "--no-optimize"]);
        assert!(o.status.success(), "{file} re-render: {}", String::from_utf8_lossy(&o.stderr));
        assert_eq!(std::fs::read_to_string(&again).unwrap(), text, "{file} re-emitted differs");
    }
    // Relative HP-GL is smaller on a drawing with many short strokes, and draws the same.
    let lattice = repo().join("examples/lattice.toml");
    let (abs, rel) = (dir.join("abs.hpgl"), dir.join("rel.hpgl"));
    assert!(render(&lattice, &abs, &[]).status.success());
    assert!(render(&lattice, &rel, &["--relative"]).status.success());
    let (abs, rel) = (std::fs::read(&abs).unwrap(), std::fs::read(&rel).unwrap());
    assert!(rel.len() < abs.len(), "relative {} bytes, absolute {}", rel.len(), abs.len());
    assert_eq!(plotcode::hpgl::parse(&rel).unwrap().strokes, plotcode::hpgl::parse(&abs).unwrap().strokes);
}

#[test]
fn bad_input_exits_1_with_a_clear_message() {
    let temp = crate::case_dir("render-device", "bad");
    let dir = temp.path();
    let scene = repo().join("examples/cube.toml");
    let write = |name: &str, text: &str| {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    };
    let missing_field = write("nounit.toml", &plotcode_profile_without("unit_mm"));
    let bad_hpgl = write("bad.hpgl", "IN;SP1;PU0,0;PD10,10,#;");
    let odd_hpgl = write("odd.hpgl", "IN;SP1;PD10,10,20;");
    let huge_hpgl = write("huge.hpgl", "IN;SP1;PA0,0;PD99999999999,0;");
    let bad_gcode = write("bad.gcode", "G21 G90\nG0 X1 Y1\nM3 S1\nG1 X2 Y\n");
    let cases: Vec<(PathBuf, PathBuf, Vec<&str>, Vec<String>)> = vec![
        (scene.clone(), dir.join("o.hpgl"), vec!["--device", "hp9999"], vec!["hp9999".into(), "hp7475a, hp7550a".into()]),
        (
            scene.clone(),
            dir.join("o.hpgl"),
            vec!["--device", missing_field.to_str().unwrap()],
            vec!["nounit.toml".into(), "unit_mm".into()],
        ),
        (scene.clone(), dir.join("o.gcode"), vec!["--device", "hp7475a"], vec!["hp7475a".into()]),
        (scene.clone(), dir.join("o.hpgl"), vec!["--paper", "B0"], vec!["B0".into(), "A4, A3".into()]),
        (bad_hpgl.clone(), dir.join("o.svg"), vec![], vec!["bad.hpgl".into(), "byte 21".into()]),
        (odd_hpgl.clone(), dir.join("o.svg"), vec![], vec!["odd.hpgl".into(), "byte 7".into(), "pairs".into()]),
        (huge_hpgl.clone(), dir.join("o.svg"), vec![], vec!["huge.hpgl".into(), "byte 13".into(), "out of range".into()]),
        (bad_gcode.clone(), dir.join("o.svg"), vec![], vec!["bad.gcode".into(), "line 4".into()]),
    ];
    for (input, out, extra, wanted) in cases {
        let o = render(&input, &out, &extra);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{input:?} {extra:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{stderr}");
        for w in wanted {
            assert!(stderr.contains(&w), "{input:?} {extra:?}: expected {w:?} in {stderr}");
        }
    }
}

/// The hp7475a profile with one key left out.
fn plotcode_profile_without(key: &str) -> String {
    let text = std::fs::read_to_string(repo().join("config/devices/hp7475a.toml")).unwrap();
    text.lines().filter(|l| !l.starts_with(&format!("{key} "))).collect::<Vec<_>>().join("\n")
}

#[test]
fn the_profiles_default_paper_unless_paper_says_otherwise_and_the_summary_names_it() {
    let temp = crate::case_dir("render-device", "paper");
    let dir = temp.path();
    // A 200 x 150 mm drawing: no sheet of that size; letter would be the
    // smallest that holds it, but hp7475a's default paper is A4.
    let input = dir.join("small.svg");
    std::fs::write(
        &input,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="200mm" height="150mm" viewBox="0 0 200 150"><path d="M 10 10 L 190 140" stroke="black"/></svg>"#,
    )
    .unwrap();
    let out = dir.join("small.hpgl");
    let summary = |extra: &[&str]| {
        let o = render(&input, &out, extra);
        let stderr = String::from_utf8_lossy(&o.stderr).to_string();
        assert!(o.status.success(), "{stderr}");
        stderr.lines().last().unwrap().to_owned()
    };
    let line = summary(&["--device", "hp7475a"]);
    assert!(line.contains("on hp7475a (A4)"), "{line}");
    let line = summary(&["--device", "hp7475a", "--paper", "letter"]);
    assert!(line.contains("on hp7475a (letter)"), "{line}");
    // A page that is one of the device's sheets goes on that sheet.
    let scene = repo().join("examples/cube.toml");
    std::fs::write(dir.join("a3.toml"), std::fs::read_to_string(&scene).unwrap().replace("size = \"A4\"", "size = \"A3\"")).unwrap();
    std::fs::copy(repo().join("examples/cube.obj"), dir.join("cube.obj")).unwrap();
    let o = render(&dir.join("a3.toml"), &out, &["--device", "hp7475a"]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success() && stderr.lines().last().unwrap().contains("on hp7475a (A3)"), "{stderr}");
}

/// Issue 17 (1): a scene's hidden lines come out dashed on the device, at
/// the `[render] hidden_dash_mm` it sets: HP-GL by line type, G-code by
/// dashes cut as strokes (before, both drew them solid). A bad setting is an
/// error naming the field.
#[test]
fn a_scenes_hidden_lines_are_dashed_on_the_device() {
    let temp = crate::case_dir("render-device", "dashed");
    let dir = temp.path();
    let example = std::fs::read_to_string(repo().join("examples/interpenetrating.toml")).unwrap();
    let scene = dir.join("dashed.toml");
    std::fs::copy(repo().join("examples/cube.obj"), dir.join("cube.obj")).unwrap();
    std::fs::write(&scene, example.replace("hidden_pen = 2", "hidden_pen = 2\nhidden_dash_mm = [2.0, 2.0]")).unwrap();
    let hpgl = dir.join("dashed.hpgl");
    let o = render(&scene, &hpgl, &["--device", "hp7475a"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(&hpgl).unwrap();
    // 50 % drawn: line type 2, a 4 mm period in percent of A4's diagonal.
    let percent = 100.0 * 4.0 / (11040.0f64.hypot(7721.0) * 0.02488);
    assert!(text.contains(&format!("SP2;\nLT2,{};\n", (percent * 1e4).round() / 1e4)), "{text}");
    let gcode = dir.join("dashed.gcode");
    let o = render(&scene, &gcode, &["--device", "grbl-servo"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let plot = plotcode::gcode::parse(&std::fs::read_to_string(&gcode).unwrap(), &Default::default()).unwrap();
    let hidden: Vec<f64> =
        plot.strokes.iter().filter(|s| s.pen == 2).map(|s| s.points.windows(2).map(|w| w[0].distance(w[1])).sum()).collect();
    // Every hidden stroke is a dash: 2 mm (to the 0.001 mm G-code writes), or
    // shorter at a line's end.
    assert!(hidden.len() > 20, "{} hidden strokes", hidden.len());
    assert!(hidden.iter().all(|&l| l <= 2.0 + 2e-3), "{hidden:?}");
    assert!(hidden.iter().filter(|&&l| (l - 2.0).abs() < 2e-3).count() > hidden.len() / 2, "{hidden:?}");
    std::fs::write(&scene, example.replace("hidden_pen = 2", "hidden_pen = 2\nhidden_dash_mm = [0.0, 2.0]")).unwrap();
    let o = render(&scene, &hpgl, &["--device", "hp7475a"]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && stderr.contains("render.hidden_dash_mm") && stderr.contains("0.2..=50 mm"), "{stderr}");
}

/// Issue 37: the cube for an AxiDraw. The `.ebb` file's moves, followed
/// step by step from home, draw every visible line of the plain SVG render
/// within 0.05 mm (a step is 0.0125 mm); the `--device axidraw` SVG is the
/// same strokes on the AxiDraw's sheet; the summary's plot time is the one
/// the daemon's chunks add up to (the planner's).
#[test]
fn the_cube_for_the_axidraw_draws_its_lines_and_its_sheet() {
    let temp = crate::case_dir("render-device", "axidraw");
    let dir = temp.path();
    let scene = repo().join("examples/cube.toml");
    let (ebb, sheet, plain) = (dir.join("cube.ebb"), dir.join("cube-axidraw.svg"), dir.join("cube.svg"));
    let o = render(&scene, &ebb, &["--device", "axidraw"]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    let last = stderr.lines().last().unwrap();
    let text = std::fs::read(&ebb).unwrap();
    let profile = plotcode::DeviceProfile::builtin("axidraw").unwrap();
    let seconds = plotcode::cut(&text, &profile).unwrap().seconds_from(0).round() as u64;
    assert!(last.contains(&format!("est. plot time {}:{:02} on axidraw (A4)", seconds / 60, seconds % 60)), "{last}");
    for (out, extra) in [(&sheet, &["--device", "axidraw"][..]), (&plain, &[][..])] {
        let o = render(&scene, out, extra);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let svg = |p: &Path| plotcode::svg_import::read(&std::fs::read_to_string(p).unwrap(), &Default::default()).unwrap();
    let (sheet, plain) = (svg(&sheet), svg(&plain));
    // Steps to sheet millimetres: home is the top-left corner, y down.
    let drawn: Vec<Vec<strokes::DVec2>> = plotcode::ebb::parse(&text)
        .unwrap()
        .strokes
        .iter()
        .map(|s| s.points.iter().map(|p| strokes::DVec2::new(p.x * 0.0125, 210.0 - p.y * 0.0125)).collect())
        .collect();
    let near = |p: strokes::DVec2, points: &[strokes::DVec2]| points.iter().any(|q| q.distance(p) <= 0.05);
    let visible: Vec<&strokes::Polyline> =
        plain.layers.iter().filter(|l| l.kind == strokes::LineKind::Visible).flat_map(|l| &l.polylines).collect();
    // The cube chains into 2 strokes (README: `2 strokes`, 831.6 mm; the
    // third starts where the second ends and is drawn on from it).
    assert_eq!(visible.len(), 2, "visible lines");
    for line in visible {
        assert!(drawn.iter().any(|s| line.points.iter().all(|&p| near(p, s))), "no stroke draws {:?}", line.points);
    }
    let on_sheet: Vec<&strokes::Polyline> = sheet.layers.iter().flat_map(|l| &l.polylines).collect();
    assert_eq!(on_sheet.len(), drawn.len(), "the sheet has the strokes the AxiDraw draws");
    for line in on_sheet {
        assert!(drawn.iter().any(|s| line.points.iter().all(|&p| near(p, s))), "the sheet's {:?} is not drawn", line.points);
    }
}
