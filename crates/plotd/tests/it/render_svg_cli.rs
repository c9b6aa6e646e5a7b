//! `plotd render` with SVG input, `--fit` and `--no-optimize`: the binary,
//! real files, the summary line.

use std::process::Command;

fn plotd(args: &[&std::ffi::OsStr]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_plotd")).args(args).output().unwrap()
}

/// `N` from "..., N <what>, ..." in the summary line.
fn count(summary: &str, what: &str) -> usize {
    let at = summary.find(what).unwrap_or_else(|| panic!("no {what} in {summary}"));
    summary[..at].trim_end().rsplit([' ', ',']).next().unwrap().parse().unwrap()
}

/// A 10 x 10 grid of separate unit segments, listed in a scrambled order.
fn grid_svg() -> String {
    let mut lines = Vec::new();
    for i in 0..=10 {
        for j in 0..10 {
            lines.push(format!(r#"<line x1="{i}" y1="{j}" x2="{i}" y2="{}" stroke="black"/>"#, j + 1));
            lines.push(format!(r#"<line x1="{j}" y1="{i}" x2="{}" y2="{i}" stroke="black"/>"#, j + 1));
        }
    }
    let n = lines.len();
    let scrambled: String = (0..n).map(|k| lines[(k * 37) % n].as_str()).collect();
    format!(r#"<svg xmlns="http://www.w3.org/2000/svg" width="100mm" height="100mm" viewBox="0 0 20 20">{scrambled}</svg>"#)
}

#[test]
fn svg_input_is_chained_and_ordered_unless_told_not_to() {
    let temp = crate::case_dir("render-svg", "grid");
    let dir = temp.path();
    let input = dir.join("grid.svg");
    std::fs::write(&input, grid_svg()).unwrap();
    let out = dir.join("out.svg");
    let run = |extra: &[&str]| {
        let mut args: Vec<&std::ffi::OsStr> = vec!["render".as_ref(), input.as_os_str(), "-o".as_ref(), out.as_os_str()];
        args.extend(extra.iter().map(std::ffi::OsStr::new));
        let o = plotd(&args);
        let stderr = String::from_utf8_lossy(&o.stderr).to_string();
        assert!(o.status.success(), "{stderr}");
        stderr.lines().last().unwrap().to_string()
    };
    let raw = run(&["--no-optimize"]);
    assert!(raw.ends_with("(raw order)"), "{raw}");
    assert_eq!(count(&raw, "strokes"), 220);
    let optimized = run(&[]);
    // Euler bound for a 10 x 10 grid: 2 * 9 + 2 * 9 odd boundary vertices.
    assert_eq!(count(&optimized, "strokes"), 18, "{optimized}");
    assert_eq!(count(&optimized, "pen lifts"), 18);
    let drawn = |s: &str| s.split("drawn ").nth(1).unwrap().split(' ').next().unwrap().parse::<f64>().unwrap();
    // 220 segments of 5 mm each, drawn once either way.
    assert!((drawn(&raw) - 1100.0).abs() < 0.1 && (drawn(&optimized) - 1100.0).abs() < 0.1, "{raw} / {optimized}");
    let svg = std::fs::read_to_string(&out).unwrap();
    assert!(svg.contains("<svg") && svg.contains("100"), "page size kept");
    let fitted = run(&["--fit"]);
    // Fitted to A4 landscape: the 50 mm grid grows to the 190 mm drawable height.
    assert!((drawn(&fitted) - 1100.0 * 190.0 / 50.0).abs() < 0.5, "{fitted}");
}

#[test]
fn bad_svg_exits_1_naming_file_and_line() {
    let temp = crate::case_dir("render-svg", "bad");
    let dir = temp.path();
    let input = dir.join("bad.svg");
    std::fs::write(&input, "<svg xmlns=\"http://www.w3.org/2000/svg\">\n<line x1=\"0\" <</svg>").unwrap();
    let out = dir.join("out.svg");
    let o = plotd(&["render".as_ref(), input.as_os_str(), "-o".as_ref(), out.as_os_str()]);
    assert_eq!(o.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("bad.svg") && stderr.contains("line 2"), "{stderr}");
    assert!(!out.exists());
    // --fit is for SVG input only.
    let scene = dir.join("s.toml");
    std::fs::write(&scene, "").unwrap();
    let o = plotd(&["render".as_ref(), scene.as_os_str(), "-o".as_ref(), out.as_os_str(), "--fit".as_ref()]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--fit"));
}

/// The `id` of every top-level `<g>` (Inkscape layer) of an SVG, in order.
fn layer_ids(svg: &str) -> Vec<String> {
    svg.lines()
        .filter(|l| l.starts_with("  <g ") && l.contains("inkscape:groupmode=\"layer\""))
        .map(|l| l.split(" id=\"").nth(1).unwrap().split('"').next().unwrap().to_owned())
        .collect()
}

/// (pen, kind, drawn length) of each layer of a drawing, sorted by pen.
fn pens_of(d: &strokes::Drawing) -> Vec<(u32, strokes::LineKind, f64)> {
    let mut v: Vec<_> = d.layers.iter().map(|l| (l.pen, l.kind, l.polylines.iter().map(strokes::Polyline::length).sum())).collect();
    v.sort_by_key(|&(pen, kind, _)| (pen, kind == strokes::LineKind::Hidden));
    v
}

#[test]
fn svg_layers_are_numbered_by_pen_and_read_back_unchanged() {
    let temp = crate::case_dir("render-svg", "pens");
    let dir = temp.path();
    let scene = dir.join("pens.toml");
    // A box on pen 1 hiding a square on pen 4 behind it; hidden lines on pen 2.
    std::fs::write(
        &scene,
        "[camera]\neye = [0.5, -8.0, 3.0]\ntarget = [0.0, 0.0, 0.0]\nfov_deg = 35.0\n\
         [render]\nhidden_pen = 2\n\
         [[polygon]]\nouter = [[-1, 0, -1], [1, 0, -1], [1, 0, 1], [-1, 0, 1]]\npen = 1\n\
         [[polygon]]\nouter = [[-1.5, 2, -0.5], [0.5, 2, -0.5], [0.5, 2, 1.5], [-1.5, 2, 1.5]]\npen = 4\n",
    )
    .unwrap();
    let first = dir.join("first.svg");
    let o = plotd(&["render".as_ref(), scene.as_os_str(), "-o".as_ref(), first.as_os_str()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(&first).unwrap();
    assert_eq!(layer_ids(&text), ["layer1", "layer4", "layer2"], "{text}");
    // plotd reads its own SVG back with every pen (and the hidden lines' kind) unchanged.
    let back = plotcode::svg_import::read(&text, &plotcode::svg_import::ImportOptions::default()).unwrap();
    let scene_drawing = plotd::pipeline::plotted_drawing(scene::Scene::load(&scene).unwrap()).unwrap();
    let (want, got) = (pens_of(&scene_drawing), pens_of(&back));
    assert_eq!(
        want.iter().map(|p| (p.0, p.1)).collect::<Vec<_>>(),
        [(1, strokes::LineKind::Visible), (2, strokes::LineKind::Hidden), (4, strokes::LineKind::Visible)]
    );
    assert_eq!(got.iter().map(|p| (p.0, p.1)).collect::<Vec<_>>(), want.iter().map(|p| (p.0, p.1)).collect::<Vec<_>>());
    for (w, g) in want.iter().zip(&got) {
        assert!((w.2 - g.2).abs() < 0.01, "pen {}: {} mm drawn, {} read back", w.0, w.2, g.2);
    }
    // And `plotd render` of that SVG writes the same layers again.
    let second = dir.join("second.svg");
    let o = plotd(&["render".as_ref(), first.as_os_str(), "-o".as_ref(), second.as_os_str()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(layer_ids(&std::fs::read_to_string(&second).unwrap()), ["layer1", "layer4", "layer2"]);
}

/// An SVG that overlaps itself (a frame drawn as a rectangle, then again as
/// four lines; a line traced there and back) is drawn with each place once,
/// and the summary says how much was removed. Failed before `strokes::dedupe`:
/// exact duplicates were dropped but the partial one was not (drawn 310 mm),
/// and no removal was reported.
#[test]
fn svg_that_overlaps_itself_is_drawn_once_and_the_removal_reported() {
    let temp = crate::case_dir("render-svg", "overlap");
    let dir = temp.path();
    let input = dir.join("overlap.svg");
    let svg = r#"<svg xmlns="http://www.w3.org/2000/svg" width="100mm" height="100mm" viewBox="0 0 100 100">
<rect x="10" y="10" width="80" height="60" fill="none" stroke="black"/>
<line x1="10" y1="10" x2="90" y2="10" stroke="black"/>
<line x1="90" y1="10" x2="90" y2="70" stroke="black"/>
<line x1="90" y1="70" x2="10" y2="70" stroke="black"/>
<polyline points="10,70 10,10 10,40" fill="none" stroke="black"/>
</svg>"#;
    std::fs::write(&input, svg).unwrap();
    let out = dir.join("out.svg");
    let o = plotd(&["render".as_ref(), input.as_os_str(), "-o".as_ref(), out.as_os_str()]);
    let stderr = String::from_utf8_lossy(&o.stderr).to_string();
    assert!(o.status.success(), "{stderr}");
    let line = stderr.lines().last().unwrap();
    let drawn: f64 = line.split("drawn ").nth(1).unwrap().split(' ').next().unwrap().parse().unwrap();
    // The frame once: 2 * (80 + 60) mm. Input: 280 + 220 + 90.
    assert!((drawn - 280.0).abs() < 0.1, "{line}");
    let removed: f64 = line.split(" mm drawn twice removed").next().unwrap().rsplit(", ").next().unwrap().parse().unwrap();
    assert!((removed - 310.0).abs() < 0.1, "{line}");
    // One closed stroke.
    assert_eq!(count(line, "strokes"), 1, "{line}");
}
