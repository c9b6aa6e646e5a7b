//! `plotd render` of drawings that draw one shape many times over itself
//! (issue 42): the shape comes out once, as one stroke. Before, an HP-GL
//! file drawing a square 10,000 times needed more than 8 GiB and stopped
//! at the memory budget, and an SVG of 1,000 identical circles took over
//! 10 s.

use std::ffi::OsStr;
use std::path::Path;
use std::process::Command;

/// `plotd render INPUT -o OUT`: its summary line.
fn render(input: &Path, out: &Path) -> String {
    let o = Command::new(env!("CARGO_BIN_EXE_plotd"))
        .args([OsStr::new("render"), input.as_os_str(), "-o".as_ref(), out.as_os_str()])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr).to_string();
    assert!(o.status.success(), "{}: {stderr}", input.display());
    stderr.lines().last().unwrap_or("").to_string()
}

/// The number before `what` in the summary line.
fn figure(summary: &str, what: &str) -> f64 {
    let at = summary.find(what).unwrap_or_else(|| panic!("no {what} in {summary}"));
    summary[..at].trim_end().rsplit([' ', ',']).next().unwrap().parse().unwrap()
}

#[test]
fn a_square_plotted_ten_thousand_times_is_plotted_once() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("square.hpgl");
    // A 50 mm square (2,000 plotter units a side), 10,000 times.
    let mut hpgl = String::from("IN;SP1;");
    for _ in 0..10_000 {
        hpgl.push_str("PU400,400;PD2400,400,2400,2400,400,2400,400,400;");
    }
    hpgl.push_str("PU;SP0;");
    std::fs::write(&input, hpgl).unwrap();
    let out = dir.path().join("square.hpgl.svg");
    let line = render(&input, &out);
    assert_eq!(figure(&line, "strokes"), 1.0, "{line}");
    // 8,000 plotter units of 0.025 mm (the 7475A's are a hair shorter).
    let drawn = figure(&line, "mm, est.");
    assert!((drawn - 200.0).abs() < 2.0, "{line}");
    assert!((figure(&line, "mm drawn twice removed") / drawn / 9_999.0 - 1.0).abs() < 1e-3, "{line}");
}

#[test]
fn a_thousand_identical_circles_are_one_circle() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("circles.svg");
    let circles: String = (0..1_000).map(|_| r#"<circle cx="50" cy="50" r="20" stroke="black" fill="none"/>"#).collect();
    std::fs::write(
        &input,
        format!(r#"<svg xmlns="http://www.w3.org/2000/svg" width="100mm" height="100mm" viewBox="0 0 100 100">{circles}</svg>"#),
    )
    .unwrap();
    let out = dir.path().join("circles.svg.hpgl");
    let line = render(&input, &out);
    assert_eq!(figure(&line, "strokes"), 1.0, "{line}");
    // The circle's chords: a little under its 125.7 mm circumference.
    let drawn = figure(&line, "mm, est.");
    assert!(drawn > 125.0 && drawn < 40.0 * std::f64::consts::PI, "{line}");
}
