//! The whole scene pipeline, stage by stage: load (TOML + OBJ parsing, mesh
//! topology), lower (faces and edges for the camera), engine (exact
//! visibility), assemble (pieces -> page polylines). Prints a table.
//!
//! `cargo bench -p scene --bench pipeline` (add `-- quick` for the small
//! sizes only, `-- big` for the 10^6-triangle terrain only). The engine's own benches measure the engine in isolation;
//! this one shows what the scene side adds around it.

use hiddenline::engine;

use scene::{render, Scene};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

#[path = "shared/terrain.rs"]
mod terrain;
use terrain::terrain_obj;

/// An OBJ of an n x n x n lattice of unit cubes at pitch 2 (Griffith's test).
fn lattice_obj(n: usize) -> String {
    let mut s = String::new();
    let mut base = 1;
    for i in 0..n {
        for j in 0..n {
            for k in 0..n {
                let c = [2.0 * i as f64, 2.0 * j as f64, 2.0 * k as f64];
                for v in 0..8 {
                    let _ = writeln!(s, "v {} {} {}", c[0] + (v & 1) as f64, c[1] + ((v >> 1) & 1) as f64, c[2] + ((v >> 2) & 1) as f64);
                }
                for f in [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]] {
                    let _ = writeln!(s, "f {} {} {} {}", base + f[0], base + f[1], base + f[2], base + f[3]);
                }
                base += 8;
            }
        }
    }
    s
}

fn scene_file(dir: &Path, name: &str, obj: &str, eye: [f64; 3], target: [f64; 3], edges: &str) -> PathBuf {
    std::fs::write(dir.join(format!("{name}.obj")), obj).unwrap();
    let toml =
        format!("[camera]\neye = {eye:?}\ntarget = {target:?}\nfov_deg = 35.0\n\n[[mesh]]\npath = \"{name}.obj\"\nedges = \"{edges}\"\n");
    let path = dir.join(format!("{name}.toml"));
    std::fs::write(&path, toml).unwrap();
    path
}

fn secs(t: Instant) -> f64 {
    t.elapsed().as_secs_f64()
}

fn row(label: &str, path: &Path) {
    if std::env::var_os("PIPELINE_SPLIT").is_some() {
        let obj = path.with_extension("obj");
        let t = Instant::now();
        let raw = scene::mesh_file::read_mesh(&obj, &scene::FileSystem).unwrap();
        let read = secs(t);
        let t = Instant::now();
        let mesh = scene::Mesh::new("m", raw.vertices, raw.polygons, scene::EdgeStyle::All, 1);
        eprintln!("  read {read:.3} s, topology {:.3} s ({} faces)", secs(t), mesh.faces.len());
    }
    let t = Instant::now();
    let scene = Scene::load(path).unwrap();
    let load = secs(t);
    let t = Instant::now();
    let model = scene.lower();
    let lower = secs(t);
    let t = Instant::now();
    let lines = engine::visibility(&model, &scene.camera);
    let vis = secs(t);
    let t = Instant::now();
    let drawing = render(scene).unwrap();
    let total = secs(t);
    let assemble = (total - lower - vis).max(0.0);
    println!(
        "{label:<22} {:>9} {:>9} {:>8.3} {:>8.3} {:>8.3} {:>8.3} {:>8.3} {:>8}",
        model.faces.len(),
        lines.len(),
        load,
        lower,
        vis,
        assemble,
        load + total,
        drawing.stroke_count()
    );
}

fn main() {
    let quick = std::env::args().any(|a| a == "quick");
    let dir = std::env::temp_dir().join(format!("plotd-pipeline-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    println!(
        "{:<22} {:>9} {:>9} {:>8} {:>8} {:>8} {:>8} {:>8} {:>8}",
        "scene", "faces", "lines", "load s", "lower s", "engine s", "asm s", "total s", "strokes"
    );
    let lattices: &[usize] = if std::env::args().any(|a| a == "big") {
        &[]
    } else if quick {
        &[2, 5]
    } else {
        &[2, 5, 10, 15, 20]
    };
    for &n in lattices {
        let c = 2.0 * n as f64;
        let path = scene_file(&dir, &format!("lattice{n}"), &lattice_obj(n), [c * 1.9, c * 1.4, c * 1.1], [c / 2.0 - 0.5; 3], "all");
        row(&format!("lattice {n}^3"), &path);
    }
    let big = std::env::args().any(|a| a == "big");
    let terrains: &[usize] = if big {
        &[708]
    } else if quick {
        &[71]
    } else {
        &[71, 224, 708]
    };
    for &m in terrains {
        let path = scene_file(&dir, &format!("terrain{m}"), &terrain_obj(m), [5.0, -6.0, 4.0], [0.0; 3], "feature");
        row(&format!("terrain {}k tris", 2 * m * m / 1000), &path);
    }
    let _ = std::fs::remove_dir_all(&dir);
}
