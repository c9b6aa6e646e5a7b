//! `plotd demo`, the README's first command, as a newcomer runs it: the
//! binary, a bundled scene through the daemon and a pty to plotsim, drawn as
//! `plotd render` draws it. `--quick` is the instant run; the showcase plots
//! at a visible speed and survives an unplugged cable.

use std::path::Path;
use std::process::Command;

#[test]
fn quick_demo_plots_the_dry_run_over_the_virtual_plotter() {
    let out = tempfile::tempdir().unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_plotd")).args(["demo", "--quick", "--out"]).arg(out.path()).output().unwrap();
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "demo failed: {stdout}\n{}", String::from_utf8_lossy(&o.stderr));

    // The demo's scene as `plotd render` draws it.
    let scene_path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/box_with_hole.toml");
    let scene = scene::Scene::load(&scene_path).unwrap();
    let want = plotd::pipeline::plotted_drawing(scene).unwrap().stroke_count();
    assert!(want > 0);
    let summary = stdout.lines().find(|l| l.contains(" strokes, ")).unwrap_or_else(|| panic!("no summary in {stdout}"));
    assert_eq!(summary, format!("{want} strokes, {} bytes over the line, 0 overruns", bytes_of(summary)), "{stdout}");

    // Both pictures hold every stroke, one polyline each.
    for file in ["dry-run.svg", "plotted.svg"] {
        let text = std::fs::read_to_string(out.path().join(file)).unwrap();
        assert_eq!(text.matches("<polyline").count(), want, "{file}");
    }
    let png = std::fs::read(out.path().join("plotted.png")).unwrap();
    assert!(png.starts_with(b"\x89PNG"), "plotted.png is not a PNG");

    // And they are the same strokes in the same order: the record against
    // `plotd render --device hp7475a`.
    let record: plotsim::Record = serde_json::from_slice(&std::fs::read(out.path().join("plotted.json")).unwrap()).unwrap();
    let got: Vec<_> = record.strokes.into_iter().map(|s| (s.pen, s.points)).collect();
    plotd_e2e::assert_drawn_once(&got, &plotd_e2e::strokes_of(&plotd_e2e::render_for(&scene_path, "hp7475a"), "hp7475a"), 0);
}

/// `plotd demo --quick --device axidraw`: the same scene through the daemon
/// to plotsim's virtual EiBotBoard; the board draws the strokes of
/// `plotd render --device axidraw`, in order, each point within a motor step.
#[test]
fn quick_demo_on_the_virtual_ebb_draws_the_axidraw_dry_run() {
    let out = tempfile::tempdir().unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_plotd"))
        .args(["demo", "--quick", "--device", "axidraw", "--out"])
        .arg(out.path())
        .output()
        .unwrap();
    let (stdout, stderr) = (String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr));
    assert!(o.status.success(), "demo failed: {stdout}\n{stderr}");
    assert!(stderr.contains("plotsim EiBotBoard (AxiDraw)"), "{stderr}");

    let scene_path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/box_with_hole.toml");
    let want = plotd_e2e::ebb::planned_strokes(&plotd_e2e::render_for(&scene_path, "axidraw"));
    assert!(!want.is_empty());
    let summary = stdout.lines().find(|l| l.contains(" strokes, ")).unwrap_or_else(|| panic!("no summary in {stdout}"));
    assert_eq!(summary, format!("{} strokes, {} bytes over the line, 0 overruns", want.len(), bytes_of(summary)), "{stdout}");

    let record: plotsim::Record = serde_json::from_slice(&std::fs::read(out.path().join("plotted.json")).unwrap()).unwrap();
    assert!(record.errors.is_empty(), "{:?}", record.errors);
    let drawn: Vec<_> = record.strokes.into_iter().map(|s| s.points).collect();
    assert_eq!(drawn.len(), want.len());
    for (i, (d, w)) in drawn.iter().zip(&want).enumerate() {
        assert!(plotd_e2e::ebb::same_stroke(d, w), "stroke {i} drawn {d:?}, planned {w:?}");
    }
}

/// The showcase: the surface with its box and contours, plotted at four
/// times a real 7475A's speed with progress lines, the cable unplugged 40 %
/// in and plugged back; the daemon resumes by itself, every stroke is drawn
/// (at most one again where it stopped), nothing overruns, and the summary
/// says what ordering saved and how the estimate compares.
#[test]
fn showcase_demo_survives_an_unplugged_cable_and_sums_up() {
    let out = tempfile::tempdir().unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_plotd")).args(["demo", "--out"]).arg(out.path()).output().unwrap();
    let (stdout, stderr) = (String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr));
    assert!(o.status.success(), "demo failed: {stdout}\n{stderr}");
    // Progress with an ETA, the fault and the resumption, as they happened.
    assert!(stderr.lines().any(|l| l.starts_with("job 1: ") && l.contains(" left")), "{stderr}");
    let unplugged = stderr.find("unplugging the cable").unwrap_or_else(|| panic!("{stderr}"));
    assert!(stderr[unplugged..].contains("paused: device offline"), "{stderr}");
    assert!(stderr[unplugged..].contains("cable back"), "{stderr}");
    let line = |key: &str| stdout.lines().find(|l| l.starts_with(key)).unwrap_or_else(|| panic!("no {key} in {stdout}")).to_owned();
    assert!(line("fault:").contains("resumed by itself"));
    assert!(line("plot time:").contains("estimated ") && line("plot time:").contains("simulated "));
    let travel = line("pen-up travel:");
    let saved: f64 = travel.split("saved ").nth(1).and_then(|s| s.split(' ').next()).and_then(|s| s.parse().ok()).unwrap();
    assert!(saved > 0.0, "{travel}");
    assert!(line("what plotsim drew:").contains("plotted.png"));
    assert!(stdout.lines().last().unwrap().ends_with(", 0 overruns"), "{stdout}");

    let scene_path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/surface_axes.toml");
    let record: plotsim::Record = serde_json::from_slice(&std::fs::read(out.path().join("plotted.json")).unwrap()).unwrap();
    assert_eq!(record.overruns, 0);
    assert!(record.faults.iter().any(|f| f.kind == "unplug"), "{:?}", record.faults);
    // The virtual plotter is a 7475A four times as fast and moves as its
    // profile says: the simulated plot time is a quarter of a real one's
    // estimate, plus the stroke drawn again after the fault.
    let scene = scene::Scene::load(&scene_path).unwrap();
    let drawing = plotd::pipeline::plotted_drawing(scene).unwrap();
    let hp = plotcode::DeviceProfile::builtin("hp7475a").unwrap();
    let estimate = plotcode::emit(&drawing, &hp, &plotcode::EmitOptions::default()).unwrap().stats.seconds / plotd::demo::SHOWCASE_SPEED;
    assert!(
        record.plot_seconds >= estimate * 0.99 && record.plot_seconds <= estimate * 1.05,
        "{} s simulated, {estimate} s estimated",
        record.plot_seconds
    );
    // The ETA counts down that plotter's seconds: the first one shown is
    // about the estimate (the job's whole plot time), not a real 7475A's.
    let first_eta =
        stderr.lines().find_map(|l| l.strip_prefix("job 1: ").and_then(|l| l.split("about ").nth(1))).unwrap_or_else(|| panic!("{stderr}"));
    let secs: f64 = first_eta.trim_end_matches(" left").trim_end_matches('s').parse().unwrap_or_else(|_| panic!("{first_eta}"));
    assert!(secs <= estimate * 1.1 + 1.0, "first ETA {secs} s for a {estimate} s plot");
    let got: Vec<_> = record.strokes.into_iter().map(|s| (s.pen, s.points)).collect();
    plotd_e2e::assert_drawn_once(&got, &plotd_e2e::strokes_of(&plotd_e2e::render_for(&scene_path, "hp7475a"), "hp7475a"), 1);
}

/// The AxiDraw's showcase: the surface on the virtual EiBotBoard at eight
/// times its speed, the cable unplugged 40 % in; the AxiDraw holds one pen,
/// so the demo swaps it when the job asks (the showcase stood at "insert pen
/// 2" before), and every stroke is drawn, at most one twice.
#[test]
fn axidraw_showcase_swaps_pens_survives_an_unplug_and_draws_every_stroke() {
    let out = tempfile::tempdir().unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_plotd")).args(["demo", "--device", "axidraw", "--out"]).arg(out.path()).output().unwrap();
    let (stdout, stderr) = (String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr));
    assert!(o.status.success(), "demo failed: {stdout}\n{stderr}");
    assert!(stderr.contains("insert pen 2: swapping the pen"), "{stderr}");
    assert!(stdout.lines().any(|l| l.starts_with("fault:") && l.contains("resumed by itself")), "{stdout}");

    let scene_path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/surface_axes.toml");
    let want = plotd_e2e::ebb::planned_strokes(&plotd_e2e::render_for(&scene_path, "axidraw"));
    let record: plotsim::Record = serde_json::from_slice(&std::fs::read(out.path().join("plotted.json")).unwrap()).unwrap();
    // The command the unplug cut in two was erased, neither run nor refused.
    assert!(record.errors.is_empty(), "{:?}", record.errors);
    let drawn: Vec<_> = record.strokes.into_iter().map(|s| s.points).collect();
    plotd_e2e::ebb::assert_drawn_once(&drawn, &want, 1);
}

/// The byte count in the summary line (checked for being a number > 0).
fn bytes_of(summary: &str) -> u64 {
    let n: u64 = summary.split(", ").nth(1).and_then(|s| s.split(' ').next()).and_then(|s| s.parse().ok()).unwrap();
    assert!(n > 0, "{summary}");
    n
}

/// The demo turns the web page on and says where: the page answers there
/// while the job plots (issue 39's first check, as curl would make it).
#[test]
fn the_demo_serves_the_web_page_at_the_address_it_prints() {
    use std::io::{BufRead, Read, Write};
    let out = tempfile::tempdir().unwrap();
    let mut demo = Command::new(env!("CARGO_BIN_EXE_plotd"))
        .args(["demo", "--speed", "1", "--out"])
        .arg(out.path())
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let stderr = std::io::BufReader::new(demo.stderr.take().unwrap());
    let mut seen = Vec::new();
    let mut address = None;
    for line in stderr.lines() {
        let line = line.unwrap();
        if let Some(a) = line.strip_prefix("plotd demo: web page on http://") {
            address = Some(a.trim_end_matches('/').to_owned());
            break;
        }
        seen.push(line);
    }
    let address = address.unwrap_or_else(|| panic!("no web page address in {seen:?}"));
    let mut s = std::net::TcpStream::connect(&address).unwrap();
    write!(s, "GET / HTTP/1.0\r\nHost: {address}\r\n\r\n").unwrap();
    let mut page = String::new();
    s.read_to_string(&mut page).unwrap();
    let _ = demo.kill();
    let _ = demo.wait();
    assert!(page.starts_with("HTTP/1.0 200"), "{page}");
    assert!(page.contains("<title>plotd</title>"), "{page}");
}
