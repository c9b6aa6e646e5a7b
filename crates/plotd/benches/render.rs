//! The whole `plotd render`, as a user runs it: the release binary on smooth
//! surfaces from 50 x 50 to 2000 x 2000 grid points (SVG and HP-GL out),
//! beside gnuplot's `hidden3d` on the same surface up to 300 x 300 (when
//! `gnuplot` is on PATH), and a million-triangle height field (OBJ, general
//! engine), wall time and peak RSS of the child process beside the targets
//! of issue #19, and the time per grid point. Then drawings that draw one
//! shape many times over (issue 42). Prints tables.
//!
//! `cargo bench -p plotd --bench render` (add `-- quick` to stop at
//! 1000 x 1000 and skip the million triangles; `-- 10m` to add a height
//! field of 10^7 triangles, a 560 MB OBJ: a minute more and 4 GB of memory;
//! `-- stages N` instead times each stage of one render of the N x N surface in this process: load,
//! hidden lines, simplify, dedupe, chain, order, crowding, write SVG and HP-GL). Each
//! case gives the median wall time of 5 runs (3 at 2000 x 2000, one for the
//! terrain), as issue #19 measured, and the fastest beside it: on a shared
//! VM one run can be 20 % slower than the next, so the load average is
//! printed too, and the CPU time (user + system) of the median run. Peak
//! RSS is the child's own `ru_maxrss`: each run is measured by a fresh copy
//! of this bench (`--child`), so no run sees another's peak.

use nix::sys::resource::{getrusage, UsageWho};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

#[path = "../../scene/benches/shared/terrain.rs"]
mod terrain;
use terrain::terrain_obj;

/// Whole-process targets: (grid points per side, seconds, MB or 0 for none).
const SURFACE_TARGETS: [(usize, f64, f64); 2] = [(1000, 0.6, 0.0), (2000, 2.5, 600.0)];

/// A million triangles through the general engine: peak RSS under 1 GiB.
const TERRAIN_TARGET_MB: f64 = 1024.0;

/// Ten million triangles (a 2236 x 2236 terrain, issue 40): seconds and MB.
const TERRAIN_10M_TARGET: (f64, f64) = (30.0, 4096.0);

fn surface_scene(dir: &Path, n: usize) -> PathBuf {
    let path = dir.join(format!("surface{n}.toml"));
    let steps = n - 1;
    let text = format!(
        "[camera]\neye = [5.0, -6.5, 4.0]\ntarget = [0.0, 0.0, 0.0]\nfov_deg = 35.0\n\n[[surface]]\n\
         z = \"0.6 * exp(-(x^2 + y^2)) + 0.15 * sin(3 * x) * cos(2 * y)\"\n\
         x = {{ from = -2.0, to = 2.0, steps = {steps} }}\ny = {{ from = -2.0, to = 2.0, steps = {steps} }}\n"
    );
    std::fs::write(&path, text).expect("temp dir is writable");
    path
}

/// A bumpy height field of `2 m^2` triangles as an OBJ, and its scene
/// (feature edges, as a terrain is drawn).
fn terrain_scene(dir: &Path, m: usize) -> PathBuf {
    let s = terrain_obj(m);
    std::fs::write(dir.join("terrain.obj"), s).expect("temp dir is writable");
    let path = dir.join("terrain.toml");
    let toml = "[camera]\neye = [5.0, -6.0, 4.0]\ntarget = [0.0, 0.0, 0.0]\nfov_deg = 35.0\n\n\
                [[mesh]]\npath = \"terrain.obj\"\nedges = \"feature\"\n";
    std::fs::write(&path, toml).expect("temp dir is writable");
    path
}

/// One run of `plotd render SCENE -o OUT` in a child: (wall s, CPU s, peak
/// RSS MB). Called in a fresh copy of this bench (see [`child`]).
fn measure(scene: &Path, out: &Path) -> (f64, f64, f64) {
    let exe = std::env::current_exe().expect("own path");
    let output = Command::new(exe).arg("--child").arg(scene).arg(out).output().expect("bench runs itself");
    let text = String::from_utf8_lossy(&output.stdout);
    let v: Vec<f64> = text.split_whitespace().filter_map(|x| x.parse().ok()).collect();
    assert!(v.len() == 3, "child said {text:?}, stderr {}", String::from_utf8_lossy(&output.stderr));
    (v[0], v[1], v[2])
}

/// `--child SCENE OUT`: runs plotd once and prints wall s, CPU s and peak RSS
/// MB of that one child (this process has no other).
fn child(scene: &str, out: &str) {
    let t = Instant::now();
    let status = Command::new(env!("CARGO_BIN_EXE_plotd")).args(["render", scene, "-o", out]).output().expect("plotd runs");
    let wall = t.elapsed().as_secs_f64();
    assert!(status.status.success(), "plotd render failed: {}", String::from_utf8_lossy(&status.stderr));
    let usage = getrusage(UsageWho::RUSAGE_CHILDREN).expect("getrusage");
    let secs = |tv: nix::sys::time::TimeVal| tv.tv_sec() as f64 + tv.tv_usec() as f64 * 1e-6;
    let cpu = secs(usage.user_time()) + secs(usage.system_time());
    // Linux reports ru_maxrss in kilobytes.
    println!("{wall} {cpu} {}", usage.max_rss() as f64 / 1024.0);
}

/// `runs` runs, fastest first.
fn runs_of(scene: &Path, out: &Path, runs: usize) -> Vec<(f64, f64, f64)> {
    let mut all: Vec<_> = (0..runs).map(|_| measure(scene, out)).collect();
    let _ = std::fs::remove_file(out);
    all.sort_by(|a, b| a.0.total_cmp(&b.0));
    all
}

fn target_text(secs: Option<f64>, mb: Option<f64>) -> String {
    match (secs, mb) {
        (Some(s), Some(m)) => format!("< {s} s, < {m:.0} MB"),
        (Some(s), None) => format!("< {s} s"),
        (None, Some(m)) => format!("< {m:.0} MB"),
        (None, None) => String::new(),
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if let Some(i) = args.iter().position(|a| a == "--child") {
        child(&args[i + 1], &args[i + 2]);
        return;
    }
    if let Some(i) = args.iter().position(|a| a == "--strokes-child") {
        strokes_child(&args[i + 1]);
        return;
    }
    let quick = args.iter().any(|a| a == "quick");
    if let Some(i) = args.iter().position(|a| a == "stages") {
        let n = args.get(i + 1).and_then(|n| n.parse().ok()).unwrap_or(1000);
        stages(n);
        return;
    }
    let dir = std::env::temp_dir().join(format!("plotd-render-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    println!(
        "whole process: the plotd binary, median of 5 runs (3 at 2000^2, 1 for the terrain) and the fastest; \
         CPU and peak of the median run; load average {}",
        load.trim()
    );
    println!("| case                         | out  | median s | best s | CPU s  | peak MB | ns / grid point | target            | gnuplot s | x faster |");
    println!("|------------------------------|------|----------|--------|--------|---------|-----------------|-------------------|-----------|----------|");
    let sizes: &[usize] = if quick { &[50, 100, 300, 1000] } else { &[50, 100, 300, 1000, 2000] };
    for &n in sizes {
        let scene = surface_scene(&dir, n);
        // gnuplot's hidden3d on the same surface, up to 300 x 300 (it
        // takes seconds there), the median of 3.
        let gnuplot = (n <= 300).then(|| gnuplot_seconds(&dir, n)).flatten();
        for ext in ["svg", "hpgl"] {
            let all = runs_of(&scene, &dir.join(format!("out.{ext}")), if n >= 2000 { 3 } else { 5 });
            let ((wall, cpu, mb), best) = (all[all.len() / 2], all[0].0);
            let per_point = wall * 1e9 / (n * n) as f64;
            let target = SURFACE_TARGETS.iter().find(|t| t.0 == n);
            let text = target_text(target.map(|t| t.1), target.map(|t| t.2).filter(|&m| m > 0.0));
            let (g, ratio) = match gnuplot {
                Some(g) if ext == "svg" => (format!("{g:.3}"), format!("{:.0}", g / wall)),
                _ => (String::new(), String::new()),
            };
            println!(
                "| {:<28} | {ext:<4} | {wall:>8.3} | {best:>6.3} | {cpu:>6.2} | {mb:>7.0} | {per_point:>15.0} | {text:<17} | {g:>9} | {ratio:>8} |",
                format!("surface {n} x {n}")
            );
        }
    }
    stacks(&dir);
    if !quick {
        terrain_row(&dir, 708, "terrain 1,002,528 triangles", &target_text(None, Some(TERRAIN_TARGET_MB)));
    }
    if args.iter().any(|a| a == "10m") {
        // 2 x 2236^2 = 9,999,392 triangles; written, then the OBJ text freed
        // before the child runs, so the bench's own memory is not in the way.
        let target = target_text(Some(TERRAIN_10M_TARGET.0), Some(TERRAIN_10M_TARGET.1));
        terrain_row(&dir, 2236, "terrain 9,999,392 triangles", &target);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// One run of the `2 m^2`-triangle terrain, as a row of the table.
fn terrain_row(dir: &Path, m: usize, label: &str, target: &str) {
    let scene = terrain_scene(dir, m);
    let (wall, cpu, mb) = runs_of(&scene, &dir.join("out.svg"), 1)[0];
    println!("| {label:<28} | svg  | {wall:>8.2} | {wall:>6.2} | {cpu:>6.2} | {mb:>7.0} | {:>15} | {target:<17} |", "");
}

/// Wall seconds of gnuplot's `hidden3d` drawing the bench's surface on an
/// `n` x `n` grid to SVG, the median of 3; `None` without `gnuplot` on PATH
/// (with `CI` set, that is an error).
fn gnuplot_seconds(dir: &Path, n: usize) -> Option<f64> {
    let script = dir.join(format!("surface{n}.gp"));
    let text = format!(
        "set terminal svg size 1000,700\nset output '{}'\nset hidden3d\nset view 60, 320\nset isosamples {n}, {n}\nset samples {n}, {n}\n\
         splot [-2:2][-2:2] 0.6 * exp(-(x**2 + y**2)) + 0.15 * sin(3 * x) * cos(2 * y) with lines notitle\n",
        dir.join("gnuplot.svg").display()
    );
    std::fs::write(&script, text).expect("temp dir is writable");
    let mut times = Vec::new();
    for _ in 0..3 {
        let t = Instant::now();
        match Command::new("gnuplot").arg(&script).output() {
            Ok(o) if o.status.success() => times.push(t.elapsed().as_secs_f64()),
            Ok(o) => panic!("gnuplot failed: {}", String::from_utf8_lossy(&o.stderr)),
            Err(e) => {
                assert!(std::env::var_os("CI").is_none(), "gnuplot is not on PATH: {e}");
                return None;
            }
        }
    }
    times.sort_by(f64::total_cmp);
    Some(times[1])
}

/// Drawings that draw one shape many times over (issue 42): the whole
/// `plotd render` (median of 5) and, in a child of its own, the stroke
/// stages alone with the memory they add to the process's peak.
fn stacks(dir: &Path) {
    let square = dir.join("square10k.hpgl");
    let mut hpgl = String::from("IN;SP1;");
    for _ in 0..10_000 {
        hpgl.push_str("PU400,400;PD2400,400,2400,2400,400,2400,400,400;");
    }
    std::fs::write(&square, hpgl + "PU;SP0;").expect("temp dir is writable");
    let circles = dir.join("circles1k.svg");
    let shapes: String = (0..1_000).map(|_| r#"<circle cx="50" cy="50" r="20" stroke="black" fill="none"/>"#).collect();
    let svg = format!(r#"<svg xmlns="http://www.w3.org/2000/svg" width="100mm" height="100mm" viewBox="0 0 100 100">{shapes}</svg>"#);
    std::fs::write(&circles, svg).expect("temp dir is writable");
    println!("\nstacks: one shape drawn many times over; whole process (median of 5), and the stroke stages alone in a child");
    println!("| case                                   | median s | peak MB | strokes: s | strokes: MB added to the peak |");
    println!("|----------------------------------------|----------|---------|------------|-------------------------------|");
    for (name, input) in [("HP-GL, a square 10,000 times (480 KB)", &square), ("SVG, 1,000 identical circles (59 KB)", &circles)] {
        let all = runs_of(input, &dir.join("stack.svg"), 5);
        let (wall, _, mb) = all[all.len() / 2];
        let exe = std::env::current_exe().expect("own path");
        let o = Command::new(exe).arg("--strokes-child").arg(input).output().expect("bench runs itself");
        let v: Vec<f64> = String::from_utf8_lossy(&o.stdout).split_whitespace().filter_map(|x| x.parse().ok()).collect();
        assert!(v.len() == 2, "strokes child said {:?}", String::from_utf8_lossy(&o.stderr));
        println!("| {name:<38} | {wall:>8.3} | {mb:>7.0} | {:>10.4} | {:>29.1} |", v[0], v[1]);
    }
}

/// `--strokes-child FILE`: reads an HP-GL or SVG drawing and prints the
/// wall seconds of [`strokes::optimize`] on it and how far it raised the
/// process's peak RSS (MB).
fn strokes_child(path: &str) {
    let bytes = std::fs::read(path).expect("the bench wrote it");
    let drawing = if path.ends_with(".svg") {
        plotd::pipeline::read_svg(std::str::from_utf8(&bytes).expect("UTF-8"), None).expect("SVG reads").drawing
    } else {
        let profile = plotcode::profile::DeviceProfile::builtin("hp7475a").expect("built-in profile");
        plotcode::hpgl::parse(&bytes).expect("HP-GL parses").to_drawing(&profile, None)
    };
    let peak = || getrusage(UsageWho::RUSAGE_SELF).expect("getrusage").max_rss() as f64 / 1024.0;
    let before = peak();
    let t = Instant::now();
    let out = strokes::optimize(drawing, &strokes::StrokeOptions::default());
    let wall = t.elapsed().as_secs_f64();
    assert_eq!(out.stroke_count(), 1, "one shape, one stroke");
    println!("{wall} {}", peak() - before);
}

/// User + system CPU seconds of this process so far (all its threads).
fn cpu_seconds() -> f64 {
    let usage = getrusage(UsageWho::RUSAGE_SELF).expect("getrusage");
    let secs = |tv: nix::sys::time::TimeVal| tv.tv_sec() as f64 + tv.tv_usec() as f64 * 1e-6;
    secs(usage.user_time()) + secs(usage.system_time())
}

/// `-- stages N`: one render of the N x N surface, stage by stage, wall
/// and CPU seconds each (the stages run in parallel inside: on a shared
/// machine CPU seconds are the steadier measure). The stroke stages, the
/// ones issue #19 is about, are the best of 3 runs on the same input.
fn stages(n: usize) {
    let dir = std::env::temp_dir().join(format!("plotd-render-stages-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let path = surface_scene(&dir, n);
    let mut rows: Vec<(&'static str, f64, f64)> = Vec::new();
    let (scene, wall, cpu) = timed(|| scene::Scene::load(&path).expect("scene loads"));
    rows.push(("load", wall, cpu));
    let (drawing, wall, cpu) = timed(move || scene::render(scene).expect("scene renders"));
    rows.push(("hidden lines, on the page", wall, cpu));
    let opts = strokes::StrokeOptions::default();
    let strokes::Drawing { width_mm, height_mm, layers, hidden_dash } = drawing;
    let mut out = Vec::new();
    let mut counts = Vec::new();
    let mut sums = [(0.0, 0.0); 4];
    for layer in layers {
        let count = |p: &[strokes::Polyline]| (p.len(), p.iter().map(|p| p.points.len()).sum::<usize>());
        counts.push(("in", count(&layer.polylines)));
        let (simple, ws, cs) = best_of_3_on(&layer.polylines, |mut p| {
            strokes::simplify_polylines(&mut p);
            p
        });
        counts.push(("simplified", count(&simple)));
        let (once, w0, c0) = best_of_3_on(&simple, |p| strokes::dedupe(p, opts.tolerance_mm));
        counts.push(("deduped", count(&once.polylines)));
        println!("dedupe removed {:.3} mm", once.removed_mm);
        let (chains, w1, c1) = best_of_3(|| strokes::chain(&once.polylines, &opts));
        counts.push(("chained", count(&chains)));
        let (polylines, w2, c2) = best_of_3_on(&chains, |c| strokes::order(c, &opts));
        for (sum, (w, c)) in sums.iter_mut().zip([(ws, cs), (w0, c0), (w1, c1), (w2, c2)]) {
            *sum = (sum.0 + w, sum.1 + c);
        }
        out.push(strokes::Layer { pen: layer.pen, kind: layer.kind, polylines });
    }
    for (name, (w, c)) in ["simplify", "dedupe", "chain", "order"].into_iter().zip(sums) {
        rows.push((name, w, c));
    }
    let drawing = strokes::Drawing { width_mm, height_mm, layers: out, hidden_dash };
    // What `plotd render` runs beside writing: the pens' crowding.
    let (crowded, wall, cpu) = best_of_3(|| plotd::ink::crowding_warnings(&drawing, |_| plotd::ink::DEFAULT_PEN_WIDTH_MM));
    rows.push(("crowding (0.3 mm pen)", wall, cpu));
    println!("crowding: {crowded:?}");
    let (svg, wall, cpu) = timed(|| plotcode::svg::write(&drawing));
    rows.push(("write SVG", wall, cpu));
    let profile = plotcode::profile::DeviceProfile::builtin("hp7475a").expect("built-in profile");
    let (hpgl, wall, cpu) = timed(|| plotcode::emit(&drawing, &profile, &plotcode::EmitOptions::default()).expect("emits"));
    rows.push(("write HP-GL", wall, cpu));
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    println!("surface {n} x {n}, in this process; load average {}", load.trim());
    for (what, (lines, points)) in counts {
        println!("{what:>10}: {lines} polylines, {points} points");
    }
    println!("| stage                      | wall s | CPU s  |");
    println!("|----------------------------|--------|--------|");
    for (name, s, c) in &rows {
        println!("| {name:<26} | {s:>6.3} | {c:>6.3} |");
    }
    let (wall, cpu) = rows.iter().fold((0.0, 0.0), |(w, c), r| (w + r.1, c + r.2));
    println!("| {:<26} | {wall:>6.3} | {cpu:>6.3} |", "all");
    println!("({} SVG bytes, {} HP-GL bytes)", svg.len(), hpgl.text.len());
    let _ = std::fs::remove_dir_all(&dir);
}

/// `f()` with its wall and CPU seconds.
fn timed<T>(f: impl FnOnce() -> T) -> (T, f64, f64) {
    let (t, c) = (Instant::now(), cpu_seconds());
    let out = f();
    (out, t.elapsed().as_secs_f64(), cpu_seconds() - c)
}

/// The best (by wall time) of three runs of `f`, and its times.
fn best_of_3<T>(mut f: impl FnMut() -> T) -> (T, f64, f64) {
    best_of_3_on(&(), |()| f())
}

/// [`best_of_3`] of `f` on a fresh copy of `input` each time, the copy made
/// outside the timing (for the stages that take their input by value).
fn best_of_3_on<I: Clone, T>(input: &I, mut f: impl FnMut(I) -> T) -> (T, f64, f64) {
    let mut best: Option<(T, f64, f64)> = None;
    for _ in 0..3 {
        let copy = input.clone();
        let next = timed(|| f(copy));
        if best.as_ref().is_none_or(|b| next.1 < b.1) {
            best = Some(next);
        }
    }
    best.expect("three runs")
}
