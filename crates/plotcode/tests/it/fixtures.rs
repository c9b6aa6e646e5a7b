//! Files on disk: golden HP-GL / G-code for bundled examples, HP-GL in the
//! styles other programs write, and an independent interpreter (hp2xx) that
//! must draw our golden files where we do.
//!
//! Golden files are regenerated only on purpose:
//! `PLOTCODE_BLESS=1 cargo test -p plotcode --test it fixtures::`, then look at them.

use plotcode::{DeviceProfile, EmitOptions, Plot};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;
use strokes::DVec2;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn fixtures() -> PathBuf {
    repo().join("hpgl-fixtures")
}

/// Golden files: `golden/<example>.<device>.<hpgl|gcode>`, from `examples/<example>.toml`.
fn golden_files() -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(fixtures().join("golden"))
        .expect("hpgl-fixtures/golden exists")
        .map(|e| e.unwrap().path())
        .filter(|p| matches!(p.extension().and_then(|e| e.to_str()), Some("hpgl" | "gcode")))
        .collect();
    v.sort();
    v
}

fn emit_example(golden: &Path) -> String {
    let name = golden.file_name().unwrap().to_str().unwrap();
    let mut parts = name.split('.');
    let (example, device) = (parts.next().unwrap(), parts.next().unwrap());
    let scene_path = repo().join("examples").join(format!("{example}.toml"));
    let scene = scene::Scene::load(&scene_path).unwrap_or_else(|e| panic!("{}: {e}", scene_path.display()));
    let drawing = scene::render(scene).unwrap_or_else(|e| panic!("{example}: {e}"));
    let profile = DeviceProfile::builtin(device).unwrap();
    plotcode::emit(&drawing, &profile, &EmitOptions::default()).unwrap().text
}

#[test]
fn golden_files_match() {
    let files = golden_files();
    assert!(files.len() >= 6, "expected golden files, found {}", files.len());
    let bless = std::env::var_os("PLOTCODE_BLESS").is_some();
    let mut stale = Vec::new();
    for g in &files {
        let now = emit_example(g);
        if bless {
            std::fs::write(g, &now).unwrap();
        } else if std::fs::read_to_string(g).unwrap() != now {
            stale.push(g.display().to_string());
        }
    }
    assert!(
        stale.is_empty(),
        "emitted output differs from golden files {stale:?}; if the change is intended (engine or \
         emitter changed), regenerate with PLOTCODE_BLESS=1 cargo test -p plotcode --test it fixtures:: \
         and review the result"
    );
}

fn strokes(plot: &Plot) -> Vec<(u32, Vec<(f64, f64)>)> {
    plot.strokes.iter().map(|s| (s.pen, s.points.iter().map(|p| (p.x, p.y)).collect())).collect()
}

#[test]
fn other_programs_styles_parse() {
    type Expected = &'static [(u32, &'static [(f64, f64)])];
    let cases: &[(&str, Expected, &[&str])] = &[
        (
            "relative.hpgl",
            &[(1, &[(0.0, 0.0), (1000.0, 0.0), (1000.0, 1000.0), (0.0, 1000.0), (0.0, 0.0)]), (1, &[(2000.0, 0.0), (2500.0, 500.0)])],
            &[],
        ),
        (
            "spaces_no_terminators.hpgl",
            &[(1, &[(100.0, 100.0), (1100.0, 100.0), (1100.0, 1100.0)]), (2, &[(2000.0, 2000.0), (3000.0, 3000.0)])],
            &[],
        ),
        (
            "labels.hpgl",
            &[(1, &[(500.0, 500.0), (1500.0, 500.0)]), (1, &[(500.0, 1000.0), (1500.0, 1000.0)])],
            &["byte 17: skipped LB", "byte 53: skipped LB"],
        ),
        ("escapes_lowercase_crlf.hpgl", &[(1, &[(0.0, 0.0), (200.0, 0.0), (200.0, 200.0)])], &[]),
        ("scaled.hpgl", &[(1, &[(1000.0, 1000.0), (9000.0, 1000.0), (9000.0, 9000.0)])], &[]),
        (
            "unsupported_skipped.hpgl",
            &[(1, &[(100.0, 100.0)]), (1, &[(2000.0, 100.0), (2500.0, 100.0)])],
            &["byte 20: skipped CI", "byte 60: skipped AA"],
        ),
    ];
    for (file, want, warnings) in cases {
        let bytes = std::fs::read(fixtures().join("styles").join(file)).unwrap();
        let plot = plotcode::hpgl::parse(&bytes).unwrap_or_else(|e| panic!("{file}: {e}"));
        let want: Vec<(u32, Vec<(f64, f64)>)> = want.iter().map(|(p, pts)| (*p, pts.to_vec())).collect();
        assert_eq!(strokes(&plot), want, "{file}");
        let got: Vec<String> = plot.warnings.iter().map(ToString::to_string).collect();
        assert_eq!(got.len(), warnings.len(), "{file}: {got:?}");
        for (g, w) in got.iter().zip(*warnings) {
            assert!(g.starts_with(w), "{file}: {g:?} should start with {w:?}");
        }
    }
}

/// Side of the coarse occupancy grid laid over a drawing's bounding box.
const GRID: usize = 24;

/// Cells of a GRID x GRID grid over `lo..hi` that a segment crosses.
fn occupancy(segments: &[(DVec2, DVec2)], lo: DVec2, hi: DVec2) -> Vec<bool> {
    let mut grid = vec![false; GRID * GRID];
    let size = (hi - lo).max(DVec2::splat(1e-9));
    for &(a, b) in segments {
        let steps = (((b - a) / size * GRID as f64).abs().max_element() * 4.0).ceil() as usize + 1;
        for k in 0..=steps {
            let p = a + (b - a) * (k as f64 / steps as f64);
            let c = ((p - lo) / size * GRID as f64).floor();
            let (x, y) = ((c.x as usize).min(GRID - 1), (c.y as usize).min(GRID - 1));
            grid[y * GRID + x] = true;
        }
    }
    grid
}

/// Reads a binary PBM (P4): width, height, rows of bits (1 = black).
fn read_pbm(bytes: &[u8]) -> (usize, usize, Vec<bool>) {
    let mut fields = Vec::new();
    let mut i = 0;
    while fields.len() < 3 {
        while bytes[i].is_ascii_whitespace() {
            i += 1;
        }
        if bytes[i] == b'#' {
            while bytes[i] != b'\n' {
                i += 1;
            }
            continue;
        }
        let s = i;
        while !bytes[i].is_ascii_whitespace() {
            i += 1;
        }
        fields.push(String::from_utf8_lossy(&bytes[s..i]).into_owned());
    }
    assert_eq!(fields[0], "P4");
    let (w, h): (usize, usize) = (fields[1].parse().unwrap(), fields[2].parse().unwrap());
    let data = &bytes[i + 1..];
    let row = w.div_ceil(8);
    let mut px = vec![false; w * h];
    for y in 0..h {
        for x in 0..w {
            px[y * w + x] = data[y * row + x / 8] & (0x80 >> (x % 8)) != 0;
        }
    }
    (w, h, px)
}

/// Whether hp2xx runs here. `.ci/run` installs it: under CI (`CI` set) its
/// absence fails `test`, naming it; elsewhere `test` is skipped, saying so
/// on the terminal (past the harness's capture of `eprintln!`).
fn hp2xx_available(test: &str) -> bool {
    if Command::new("hp2xx").arg("-V").output().is_ok() {
        return true;
    }
    let why = "`hp2xx` is not installed (Debian package hp2xx)";
    assert!(std::env::var_os("CI").is_none(), "{test}: {why}; CI (`CI` is set) must have it: `.ci/run` installs it");
    let _ = writeln!(std::io::stderr(), "skipping {test}: {why}");
    false
}

/// hp2xx, reading our HP-GL of a hidden line, draws it dashed: along the
/// line, runs of ink as many as the line has periods, about 70 % of it inked
/// (line type 3); the visible line above it is one run.
#[test]
fn hp2xx_draws_hidden_lines_dashed() {
    if !hp2xx_available("hp2xx_draws_hidden_lines_dashed") {
        return;
    }
    let mut d = strokes::Drawing::new(297.0, 210.0);
    let line = |y: f64| strokes::Polyline::new(vec![DVec2::new(48.5, y), DVec2::new(248.5, y)]);
    d.layer_mut(1, strokes::LineKind::Visible).polylines.push(line(150.0));
    d.layer_mut(2, strokes::LineKind::Hidden).polylines.push(line(60.0));
    let text = plotcode::emit(&d, &DeviceProfile::builtin("hp7475a").unwrap(), &EmitOptions::default()).unwrap().text;
    let temp = tempfile::Builder::new().prefix("plotcode-hp2xx-dash-").tempdir().unwrap();
    let tmp = temp.path();
    let (file, out) = (tmp.join("dashed.hpgl"), tmp.join("dashed.pbm"));
    std::fs::write(&file, &text).unwrap();
    let o = Command::new("hp2xx").args(["-m", "pbm", "-d", "100", "-f"]).arg(&out).arg(&file).output().unwrap();
    let log = String::from_utf8_lossy(&o.stderr).into_owned() + &String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success() && log.contains("HPGL command(s) ignored: 0"), "hp2xx: {log}");
    let (w, h, px) = read_pbm(&std::fs::read(&out).unwrap());
    // Runs of ink along the most inked row in each half of the picture
    // (y down: the visible line on top).
    let runs = |rows: std::ops::Range<usize>| {
        let y = rows.max_by_key(|&y| (0..w).filter(|&x| px[y * w + x]).count()).unwrap();
        let row: Vec<bool> = (0..w).map(|x| px[y * w + x]).collect();
        let starts = (0..w).filter(|&x| row[x] && (x == 0 || !row[x - 1])).count();
        (starts, row.iter().filter(|&&b| b).count() as f64 / w as f64)
    };
    let (visible_runs, visible_ink) = runs(0..h / 2);
    let (hidden_runs, hidden_ink) = runs(h / 2..h);
    assert_eq!(visible_runs, 1);
    assert!(visible_ink > 0.95, "{visible_ink}");
    // 200 mm in 5 mm periods; a dash at each end may merge with a neighbour's pixel.
    assert!((38..=41).contains(&hidden_runs), "{hidden_runs} runs of ink along the hidden line");
    assert!((0.6..0.8).contains(&hidden_ink), "{hidden_ink} of the hidden line inked");
}

/// hp2xx renders every golden and style HP-GL file without complaint, and its
/// picture has ink in the same coarse cells as our reading of the file.
#[test]
fn hp2xx_draws_where_we_do() {
    if !hp2xx_available("hp2xx_draws_where_we_do") {
        return;
    }
    let mut files: Vec<PathBuf> = golden_files().into_iter().filter(|p| p.extension().unwrap() == "hpgl").collect();
    for entry in std::fs::read_dir(fixtures().join("styles")).unwrap() {
        let p = entry.unwrap().path();
        // hp2xx draws labels and circles that we skip; compare only what both draw.
        let name = p.file_name().unwrap().to_str().unwrap();
        if !name.starts_with("labels") && !name.starts_with("unsupported") {
            files.push(p);
        }
    }
    assert!(files.len() >= 6);
    let temp = tempfile::Builder::new().prefix("plotcode-hp2xx-").tempdir().unwrap();
    let tmp = temp.path();
    for file in files {
        let name = file.file_name().unwrap().to_str().unwrap().to_owned();
        let out = tmp.join(format!("{name}.pbm"));
        let o = Command::new("hp2xx").args(["-m", "pbm", "-d", "100", "-f"]).arg(&out).arg(&file).output().unwrap();
        let log = String::from_utf8_lossy(&o.stderr).into_owned() + &String::from_utf8_lossy(&o.stdout);
        assert!(o.status.success(), "{name}: hp2xx failed: {log}");
        assert!(log.contains("HPGL command(s) ignored: 0"), "{name}: hp2xx ignored commands: {log}");
        assert!(log.contains("Unexpected event(s):  0"), "{name}: hp2xx had unexpected events: {log}");

        // Our strokes, gridded over their bounding box.
        let plot = plotcode::hpgl::parse(&std::fs::read(&file).unwrap()).unwrap();
        let mut segs = Vec::new();
        for s in &plot.strokes {
            if s.points.len() == 1 {
                segs.push((s.points[0], s.points[0]));
            }
            segs.extend(s.points.windows(2).map(|w| (w[0], w[1])));
        }
        let pts = segs.iter().flat_map(|s| [s.0, s.1]);
        let lo = pts.clone().fold(DVec2::splat(f64::MAX), DVec2::min);
        let hi = pts.fold(DVec2::splat(f64::MIN), DVec2::max);
        let ours = occupancy(&segs, lo, hi);

        // hp2xx's bitmap covers the same bounding box (its "coordinate range"),
        // y down; grid its black pixels the same way.
        let (w, h, px) = read_pbm(&std::fs::read(&out).unwrap());
        let mut theirs = vec![false; GRID * GRID];
        for y in 0..h {
            for x in 0..w {
                if px[y * w + x] {
                    let gx = (x * GRID / w).min(GRID - 1);
                    let gy = ((h - 1 - y) * GRID / h).min(GRID - 1);
                    theirs[gy * GRID + gx] = true;
                }
            }
        }
        // Allow one cell of slack for pen width and hp2xx's rounding at cell edges.
        let near = |g: &[bool], i: usize| {
            let (x, y) = ((i % GRID) as i64, (i / GRID) as i64);
            (-1..=1).any(|dy| {
                (-1..=1).any(|dx| {
                    let (a, b) = (x + dx, y + dy);
                    a >= 0 && b >= 0 && a < GRID as i64 && b < GRID as i64 && g[(b as usize) * GRID + a as usize]
                })
            })
        };
        let inked: Vec<usize> = (0..ours.len()).filter(|&i| ours[i]).collect();
        let missed = inked.iter().filter(|&&i| !near(&theirs, i)).count();
        let extra = (0..theirs.len()).filter(|&i| theirs[i] && !near(&ours, i)).count();
        assert!(!inked.is_empty(), "{name}: nothing drawn");
        assert_eq!(missed, 0, "{name}: hp2xx left {missed} of our {} inked cells blank", inked.len());
        assert_eq!(extra, 0, "{name}: hp2xx inked {extra} cells where we draw nothing");
    }
}
