//! `plotd render` with SVG input, `--fit` and `--no-optimize`: the binary,
//! real files, the summary line.

use std::path::PathBuf;
use std::process::Command;

fn out_dir(case: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("plotd-render-svg-{}-{case}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

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
    let dir = out_dir("grid");
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
    let dir = out_dir("bad");
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
