//! Hidden-line engine benchmark: prints a table of time, time per face and
//! peak memory for a lattice of n x n x n cubes (n = 2..20) and for generated
//! triangle meshes (a bumpy sphere, a terrain) of 10^4..10^6 triangles.
//!
//! `cargo bench -p hiddenline --bench engine [-- lattice|sphere|terrain [MAX_FACES]]`
//!
//! "us / face" is wall time per face. Peak memory is the process's VmHWM from /proc/self/status after the run
//! (so it includes building the model); cases run smallest first.

use std::collections::HashMap;
use std::time::Instant;

use hiddenline::engine::visibility;
use hiddenline::{Camera, DVec3, Edge, Face, Model, Projection};

/// A model from an indexed triangle/quad mesh: every polygon a face, every
/// distinct edge drawn once with the faces it lies on.
fn indexed(vertices: &[DVec3], polys: &[Vec<u32>], outward: bool, model: &mut Model) {
    let base = model.faces.len() as u32;
    let mut edges: HashMap<(u32, u32), Vec<u32>> = HashMap::with_capacity(polys.len() * 2);
    for (k, p) in polys.iter().enumerate() {
        for i in 0..p.len() {
            let (a, b) = (p[i], p[(i + 1) % p.len()]);
            edges.entry((a.min(b), a.max(b))).or_default().push(base + k as u32);
        }
        model.faces.push(Face { outer: p.iter().map(|&i| vertices[i as usize]).collect(), holes: vec![], pen: 1, outward });
    }
    let mut edges: Vec<_> = edges.into_iter().collect();
    edges.sort_unstable_by_key(|e| e.0);
    for ((a, b), faces) in edges {
        model.edges.push(Edge { a: vertices[a as usize], b: vertices[b as usize], pen: 1, faces });
    }
}

fn lattice(n: usize) -> (Model, Camera) {
    let mut model = Model::default();
    for i in 0..n {
        for j in 0..n {
            for k in 0..n {
                let o = DVec3::new(i as f64, j as f64, k as f64) * 2.0;
                let v: Vec<DVec3> = (0..8).map(|b| o + DVec3::new((b & 1) as f64, (b >> 1 & 1) as f64, (b >> 2) as f64)).collect();
                let quads = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
                let polys: Vec<Vec<u32>> = quads.iter().map(|q| q.to_vec()).collect();
                indexed(&v, &polys, true, &mut model);
            }
        }
    }
    let c = (n as f64 * 2.0 - 1.0) * 0.5;
    let centre = DVec3::splat(c);
    let eye = centre + DVec3::new(1.3, -1.0, 0.8) * (n as f64 * 4.0 + 4.0);
    (model, Camera::new(eye, centre, DVec3::Z, Projection::Perspective { fov_deg: 40.0 }).unwrap())
}

/// A closed UV sphere with `rings` latitude bands and `2 * rings` segments,
/// its radius rippled: about `4 * rings^2` triangles.
fn sphere(rings: usize) -> (Model, Camera) {
    let seg = 2 * rings;
    let mut v = vec![DVec3::new(0.0, 0.0, -1.0)];
    for r in 1..rings {
        let th = std::f64::consts::PI * r as f64 / rings as f64;
        for s in 0..seg {
            let ph = std::f64::consts::TAU * s as f64 / seg as f64;
            let rad = 1.0 + 0.08 * (7.0 * th).sin() * (5.0 * ph).cos() + 0.03 * (23.0 * th).cos() * (17.0 * ph).sin();
            v.push(DVec3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), -th.cos()) * rad);
        }
    }
    v.push(DVec3::new(0.0, 0.0, 1.0));
    let top = (v.len() - 1) as u32;
    let at = |r: usize, s: usize| (1 + (r - 1) * seg + s % seg) as u32;
    let mut polys = Vec::new();
    for s in 0..seg {
        polys.push(vec![0, at(1, s + 1), at(1, s)]);
        polys.push(vec![top, at(rings - 1, s), at(rings - 1, s + 1)]);
    }
    for r in 1..rings - 1 {
        for s in 0..seg {
            polys.push(vec![at(r, s), at(r, s + 1), at(r + 1, s + 1)]);
            polys.push(vec![at(r, s), at(r + 1, s + 1), at(r + 1, s)]);
        }
    }
    let mut model = Model::default();
    indexed(&v, &polys, true, &mut model);
    let cam = Camera::new(DVec3::new(3.0, -2.5, 1.5), DVec3::ZERO, DVec3::Z, Projection::Perspective { fov_deg: 40.0 });
    (model, cam.unwrap())
}

/// A triangulated height field of `k x k` quads: `2 k^2` triangles.
fn terrain(k: usize) -> (Model, Camera) {
    let h = |x: f64, y: f64| 0.15 * (3.0 * x).sin() * (2.0 * y).cos() + 0.05 * (11.0 * x + 7.0 * y).sin() + 0.3 * (-(x * x + y * y)).exp();
    let mut v = Vec::with_capacity((k + 1) * (k + 1));
    for j in 0..=k {
        for i in 0..=k {
            let (x, y) = (-2.0 + 4.0 * i as f64 / k as f64, -2.0 + 4.0 * j as f64 / k as f64);
            v.push(DVec3::new(x, y, h(x, y)));
        }
    }
    let at = |i: usize, j: usize| (j * (k + 1) + i) as u32;
    let mut polys = Vec::with_capacity(2 * k * k);
    for j in 0..k {
        for i in 0..k {
            polys.push(vec![at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            polys.push(vec![at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    let mut model = Model::default();
    indexed(&v, &polys, false, &mut model);
    let cam = Camera::new(DVec3::new(4.0, -5.0, 2.5), DVec3::ZERO, DVec3::Z, Projection::Perspective { fov_deg: 40.0 });
    (model, cam.unwrap())
}

fn peak_rss_mib() -> f64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<f64>().ok())
        .map_or(f64::NAN, |kb| kb / 1024.0)
}

/// User + system CPU time of this process so far (all threads), from
/// /proc/self/stat in clock ticks of 1/100 s: the machine is shared, so wall
/// time alone says little.
fn cpu_seconds() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let after = stat.rsplit_once(')').map_or("", |(_, r)| r);
    let f: Vec<&str> = after.split_whitespace().collect();
    // Fields 14 and 15 (utime, stime) are the 12th and 13th after the ')'.
    let tick = |i: usize| f.get(i).and_then(|v| v.parse::<f64>().ok()).unwrap_or(f64::NAN);
    (tick(11) + tick(12)) / 100.0
}

fn run(name: &str, (model, camera): (Model, Camera)) {
    let (start, cpu0) = (Instant::now(), cpu_seconds());
    let answer = visibility(&model, &camera);
    let secs = start.elapsed().as_secs_f64();
    let cpu = cpu_seconds() - cpu0;
    let visible = answer.iter().filter(|l| !l.visible.is_empty()).count();
    println!(
        "| {name:<16} | {:>9} | {:>9} | {:>9.3} | {:>9.3} | {:>10.3} | {:>8} | {:>9.0} |",
        model.faces.len(),
        model.edges.len(),
        secs,
        cpu,
        secs * 1e6 / model.faces.len() as f64,
        visible,
        peak_rss_mib()
    );
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).filter(|a| !a.starts_with("--")).collect();
    let only = args.first().map(String::as_str);
    let max_faces: usize = args.get(1).and_then(|a| a.parse().ok()).unwrap_or(usize::MAX);
    let want = |kind: &str| only.is_none_or(|o| o == kind);
    println!("| scene            |     faces |     edges |  wall s   |  CPU s    | us / face  | visible  | peak MiB  |");
    println!("|------------------|-----------|-----------|-----------|-----------|------------|----------|-----------|");
    if want("lattice") {
        for n in [2, 4, 6, 8, 10, 12, 14, 16, 18, 20] {
            if 6 * n * n * n <= max_faces {
                run(&format!("lattice {n}^3"), lattice(n));
            }
        }
    }
    if want("sphere") {
        for rings in [50, 158, 354, 500] {
            if 4 * rings * rings <= max_faces {
                run(&format!("sphere r={rings}"), sphere(rings));
            }
        }
    }
    if want("terrain") {
        for k in [71, 224, 500, 707] {
            if 2 * k * k <= max_faces {
                run(&format!("terrain {k}x{k}"), terrain(k));
            }
        }
    }
}
