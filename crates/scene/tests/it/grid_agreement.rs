//! The fast grid engine against the general engine and the brute-force
//! reference, on the same surfaces given as `[[surface]]` grids and as meshes
//! of two triangles per cell (issue 6): precision and recall >= 0.995 both ways.

use hiddenline::grid::{visibility, Grid, GridLines};
use hiddenline::reference;
use hiddenline::{engine, Camera, DVec3, LineSource, LineVisibility, Projection};
use scene::{ModelBuilder, Surface};
use std::collections::HashMap;

fn persp(eye: [f64; 3], target: [f64; 3]) -> Camera {
    let up = if eye[0] == target[0] && eye[1] == target[1] { DVec3::Y } else { DVec3::Z };
    Camera::new(DVec3::from(eye), DVec3::from(target), up, Projection::Perspective { fov_deg: 40.0 }).unwrap()
}

fn ortho(eye: [f64; 3], target: [f64; 3]) -> Camera {
    Camera::new(DVec3::from(eye), DVec3::from(target), DVec3::Z, Projection::Orthographic { height: 6.0 }).unwrap()
}

/// Heights `f(x, y)` taken row by row in order (`noise` keeps state).
fn uniform(n: usize, mut f: impl FnMut(f64, f64) -> f64) -> Grid {
    let xs = Grid::linspace(-2.0, 2.0, n);
    let z = xs.iter().flat_map(|&y| xs.iter().map(move |&x| (x, y))).map(|(x, y)| f(x, y)).collect();
    Grid::new(xs.clone(), xs, z).unwrap()
}

fn noise(seed: u64) -> impl FnMut(f64, f64) -> f64 {
    let mut s = seed | 1;
    move |_, _| {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn waves(x: f64, y: f64) -> f64 {
    0.5 * (2.0 * x).sin() * (1.5 * y).cos()
}

/// Visible device length per line, and the length both answers draw.
fn overlap(a: &[LineVisibility], b: &[LineVisibility]) -> (f64, f64, f64) {
    let len = |l: &LineVisibility, iv: &[(f64, f64)]| iv.iter().map(|(t0, t1)| (t1 - t0) * l.a.distance(l.b)).sum::<f64>();
    let by: HashMap<LineSource, &LineVisibility> = b.iter().map(|l| (l.source, l)).collect();
    let (mut la, mut lb, mut both) = (0.0, 0.0, 0.0);
    for l in a {
        la += len(l, &l.visible);
        if let Some(m) = by.get(&l.source) {
            let mut common = Vec::new();
            for &(p0, p1) in &l.visible {
                for &(q0, q1) in &m.visible {
                    let (lo, hi) = (p0.max(q0), p1.min(q1));
                    if hi > lo {
                        common.push((lo, hi));
                    }
                }
            }
            both += len(l, &common);
        }
    }
    for l in b {
        lb += len(l, &l.visible);
    }
    (la, lb, both)
}

fn check(name: &str, grid: Grid, cam: Camera) {
    check_every(name, grid, cam, 1);
}

/// [`check`] drawing every `every`-th grid line: hidden by the whole surface.
fn check_every(name: &str, grid: Grid, cam: Camera, every: usize) {
    let surface = Surface { grid, lines: GridLines::Both, every, pen: 1 };
    let mut b = ModelBuilder::new();
    surface.lower(&mut b);
    let model = b.finish();
    let fast = visibility(&surface.grid, &cam, surface.drawn(), 1);
    let general = engine::visibility(&model, &cam);
    let score = reference::check(&model, &cam, &fast);
    assert!(score.passes(0.995), "{name}: grid engine vs reference: {score:?}");
    let (lf, lg, both) = overlap(&fast, &general);
    let (p, r) = (both / lf.max(1e-300), both / lg.max(1e-300));
    assert!(p >= 0.995 && r >= 0.995, "{name}: grid vs general engine: precision {p:.4} recall {r:.4}");
    // Guard: the scene must hide something, or it tests nothing.
    let total: f64 = fast.iter().map(|l| l.a.distance(l.b)).sum();
    assert!(lf < total, "{name}: nothing is hidden");
}

/// Issue 40: `every = N` draws every N-th grid line, each still hidden by
/// every cell of the surface (the lines between hide, though not drawn).
#[test]
fn every_third_line_is_hidden_by_the_whole_surface() {
    check_every("random, every 3", uniform(13, noise(9)), persp([5.0, -6.0, 4.0], [0.0, 0.0, 0.0]), 3);
    check_every("bump very low, every 4", uniform(14, |x, y| 1.5 * (-(x * x + y * y)).exp()), persp([-3.0, -7.0, 0.3], [0.0, 0.0, 0.5]), 4);
    // Every 3rd of 14 lines (0, 3, ..., 12) and the border (13), both ways:
    // 6 x 13 edges each way, numbered as the lowering numbers them.
    let surface = Surface { grid: uniform(13, waves), lines: GridLines::Both, every: 3, pen: 1 };
    let mut b = ModelBuilder::new();
    surface.lower(&mut b);
    let model = b.finish();
    assert_eq!(model.faces.len(), 2 * 13 * 13, "every cell hides");
    assert_eq!(model.edges.len(), 2 * 6 * 13);
    assert_eq!(surface.drawn().edge_count(&surface.grid), model.edges.len());
}

#[test]
fn random_heights_oblique() {
    check("random oblique", uniform(12, noise(5)), persp([5.0, -6.0, 4.0], [0.0, 0.0, 0.0]));
}

#[test]
fn gaussian_bump_from_very_low() {
    check("bump very low", uniform(14, |x, y| 1.5 * (-(x * x + y * y)).exp()), persp([-3.0, -7.0, 0.3], [0.0, 0.0, 0.5]));
}

#[test]
fn saddle_face_on() {
    let saddle = |x: f64, y: f64| 0.5 * (x * x - y * y) + 0.3 * (4.0 * x).sin() * (4.0 * y).sin();
    check("saddle face-on", uniform(14, saddle), persp([0.1, 0.15, 1.2], [0.0, 0.0, 0.0]));
}

#[test]
fn non_uniform_grid() {
    let xs = vec![-2.0, -1.7, -1.0, -0.9, -0.2, 0.0, 0.5, 1.4, 1.5, 2.0, 3.0];
    let ys = vec![-2.0, -1.0, -0.5, -0.4, 0.1, 0.9, 1.0, 1.8, 2.5];
    check("non-uniform", Grid::from_fn(xs, ys, waves).unwrap(), persp([4.0, -5.0, 3.0], [0.0, 0.0, 0.0]));
}

#[test]
fn eye_above_the_surface_inside_the_grid() {
    // Seed 000, figure 1: the view earlier algorithms got wrong.
    check("above, inside", uniform(12, waves), persp([0.5, -0.4, 2.0], [0.0, 2.0, 0.0]));
}

#[test]
fn edge_on_and_corner_on() {
    check("edge-on", uniform(12, waves), persp([0.0, -8.0, 3.0], [0.0, 0.0, 0.0]));
    check("corner-on", uniform(12, waves), persp([-6.0, -6.0, 3.0], [0.0, 0.0, 0.0]));
}

#[test]
fn eye_on_a_grid_plane_and_above_a_grid_point() {
    let g = uniform(12, waves);
    let (x4, y7) = (g.xs[4], g.ys[7]);
    check("on plane x = x4", g.clone(), persp([x4, -7.0, 3.0], [x4, 0.0, 0.0]));
    check("above grid point", g.clone(), persp([x4, y7, 1.0], [2.0, -2.0, 0.0]));
    check("in the boundary plane x = 2", g.clone(), persp([2.0, -7.0, 3.0], [0.0, 0.0, 0.0]));
    check("in the boundary plane y = -2, from behind", g, persp([-6.0, -2.0, 2.5], [0.0, 0.0, 0.0]));
}

#[test]
fn horizontal_view_and_eye_below() {
    check("horizontal", uniform(12, waves), persp([0.5, -7.0, 0.8], [0.5, 0.0, 0.8]));
    check("below, looking up", uniform(12, waves), persp([0.7, -3.0, -3.0], [0.0, 0.0, 0.0]));
}

#[test]
fn orthographic() {
    check("ortho oblique", uniform(12, noise(9)), ortho([5.0, -6.0, 4.0], [0.0, 0.0, 0.0]));
}

// Ridgelines: the horizon method (`grid::ridgeline`) against the curtain
// faces of `Ridgeline::lower` through the general engine and the reference.

use hiddenline::grid::ridgeline;
use scene::Ridgeline;

/// `rows` profiles of `cols` points, `spacing` apart in y, with bumps that
/// make near profiles hide parts of far ones (and some rows low enough to
/// leave gaps between curtains).
fn ridges(rows: usize, cols: usize, seed: u64) -> Ridgeline {
    let mut n = noise(seed);
    let profiles: Vec<Vec<DVec3>> = (0..rows)
        .map(|k| {
            let y = k as f64 * 0.6;
            let lift = if k % 3 == 1 { 0.1 } else { 1.0 };
            (0..cols)
                .map(|i| {
                    let x = -3.0 + 6.0 * i as f64 / (cols - 1) as f64;
                    let z = lift * (1.2 * (-(x - 0.4 * k as f64 + 1.0).powi(2)).exp() + 0.4 * n(x, y));
                    DVec3::new(x, y, z)
                })
                .collect()
        })
        .collect();
    Ridgeline { profiles, base: -0.05, pen: 1 }
}

fn check_ridges(name: &str, r: &Ridgeline, cam: Camera) {
    check_ridge_sets(name, std::slice::from_ref(r), cam);
}

/// Several ridgelines in one scene, lowered in order as `Scene::lower` does;
/// false when the fast path declines (and must).
fn check_ridge_sets(name: &str, rs: &[Ridgeline], cam: Camera) -> bool {
    let mut b = ModelBuilder::new();
    for r in rs {
        r.lower(&mut b);
    }
    let model = b.finish();
    let general = engine::visibility(&model, &cam);
    let sets: Vec<_> = rs.iter().map(Ridgeline::curtains).collect();
    let Some(fast) = ridgeline::visibility(&sets, &cam) else {
        assert!(!ridgeline::upper_horizon_suffices(&cam, &sets), "{name}: the fast path declined a view it handles");
        return false;
    };
    let score = reference::check(&model, &cam, &fast);
    assert!(score.passes(0.995), "{name}: ridgeline horizon vs reference: {score:?}");
    let (lf, lg, both) = overlap(&fast, &general);
    let (p, r) = (both / lf.max(1e-300), both / lg.max(1e-300));
    assert!(p >= 0.995 && r >= 0.995, "{name}: ridgeline horizon vs general engine: precision {p:.4} recall {r:.4}");
    let total: f64 = fast.iter().map(|l| l.a.distance(l.b)).sum();
    assert!(lf < 0.98 * total, "{name}: almost nothing is hidden ({lf} of {total})");
    true
}

#[test]
fn ridgelines_agree_with_curtain_faces() {
    let r = ridges(9, 40, 3);
    let mid = [0.0, 2.4, 0.3];
    check_ridges("from above", &r, persp([0.5, -5.0, 4.0], mid));
    check_ridges("from low", &r, persp([-1.0, -6.0, 0.4], mid));
    check_ridges("face-on", &r, persp([0.0, -7.0, 1.5], [0.0, 2.4, 0.5]));
    check_ridges("oblique", &r, persp([-6.0, -4.0, 2.0], mid));
    check_ridges("from behind", &r, persp([1.0, 10.0, 2.0], mid));
    check_ridges("eye between the profiles", &r, persp([0.0, 2.1, 0.9], [0.0, 4.8, 0.3]));
    check_ridges("eye between the profiles, looking along them", &r, persp([-6.0, 2.1, 0.4], [0.0, 3.6, 0.4]));
    check_ridges("eye on the baseline", &r, persp([0.3, -6.0, -0.05], mid));
    check_ridges("orthographic", &r, ortho([4.0, -6.0, 3.0], mid));
    check_ridges("orthographic, horizontal", &r, ortho([0.5, -6.0, 0.3], [0.5, 0.0, 0.3]));
    // From below the baseline the general engine decides (checked above).
    check_ridges("from below", &r, persp([0.5, -6.0, -1.0], mid));
}

#[test]
fn several_ridgelines_in_one_scene() {
    // A second set whose planes interleave with the first's (and share y = 0
    // and y = 2.4 with it), over a different x range, on another pen, with a
    // higher baseline, still below every point of both.
    let a = ridges(9, 40, 3);
    let mut b = ridges(7, 25, 11);
    for (k, p) in b.profiles.iter_mut().enumerate() {
        for q in p.iter_mut() {
            q.x = 0.5 * q.x + 1.0;
            q.y = k as f64 * 0.4;
            q.z += 0.2;
        }
    }
    b.base = -0.02;
    b.pen = 2;
    let mut sets = [a, b];
    let mid = [0.0, 2.4, 0.3];
    let views = [
        ("from above", persp([0.5, -5.0, 4.0], mid)),
        ("from low", persp([-1.0, -6.0, 0.4], mid)),
        ("from behind", persp([1.0, 10.0, 2.0], mid)),
        ("oblique", persp([-6.0, -4.0, 2.0], mid)),
        ("orthographic", ortho([4.0, -6.0, 3.0], mid)),
    ];
    for (name, cam) in views {
        assert!(check_ridge_sets(&format!("two sets, {name}"), &sets, cam), "two sets, {name}: the fast path declined");
    }
    // Points of the first set below the second's baseline: a sight line can
    // pass under a curtain of the second set, so the general engine decides
    // (and its answer is checked against the reference above).
    sets[1].base = 0.1;
    assert!(sets[0].profiles.iter().flatten().any(|p| p.z < sets[1].base), "the test needs points below the second baseline");
    assert!(!check_ridge_sets("two sets, a baseline above points", &sets, persp([0.5, -5.0, 4.0], mid)));
}

// A surface with its axes and base-plane contours (`grid::free`): the fast
// path against the general engine and the reference on the lowered scene.

use hiddenline::grid::free::visibility_with_free;
use scene::Scene;

/// Loads a scene of one surface, a box with labels, and contours on a base
/// plane (and, with `on_surface`, contours on the surface too).
fn secondary_scene(name: &str, eye: [f64; 3], target: [f64; 3], ortho: bool, on_surface: bool) -> Scene {
    // Tests run in parallel and share view names: the directory says which.
    let dir = std::env::temp_dir().join(format!("hiddenline-grid-free-{}-{name}-{on_surface}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let projection = if ortho { "ortho_height = 7.0\n" } else { "fov_deg = 40.0\n" };
    let mut text = format!(
        "[camera]\neye = {eye:?}\ntarget = {target:?}\n{projection}\n\
         [[surface]]\nz = \"0.9 * exp(-x^2 - y^2) + 0.25 * sin(2 * x) * cos(3 * y)\"\n\
         x = {{ from = -2.0, to = 2.0, steps = 14 }}\ny = {{ from = -2.0, to = 2.0, steps = 12 }}\n\n\
         [[axes]]\nstyle = \"box\"\nticks = 4\ntitles = [\"x\", \"y\", \"z\"]\n\n\
         [[contours]]\nlevels = 6\non = \"base\"\npen = 2\n"
    );
    if on_surface {
        text.push_str("\n[[contours]]\nlevels = 3\non = \"surface\"\npen = 3\n");
    }
    let path = dir.join("scene.toml");
    std::fs::write(&path, text).unwrap();
    let scene = Scene::load(&path).unwrap();
    std::fs::remove_dir_all(&dir).ok();
    scene
}

/// Checks the fast path on a scene it takes; returns false when it declines.
fn check_free(name: &str, scene: &Scene) -> bool {
    let free = scene.grid_free_segments().expect("a surface with axes and base contours");
    let s = &scene.surfaces[0];
    let Some(fast) = visibility_with_free(&s.grid, &scene.camera, s.lines, s.pen, &free) else { return false };
    let model = scene.lower();
    assert_eq!(model.edges.len(), fast.len(), "{name}: the numbering must be the lowering's");
    let general = engine::visibility(&model, &scene.camera);
    let score = reference::check(&model, &scene.camera, &fast);
    assert!(score.passes(0.995), "{name}: surface + axes + contours vs reference: {score:?}");
    let (lf, lg, both) = overlap(&fast, &general);
    let (p, r) = (both / lf.max(1e-300), both / lg.max(1e-300));
    assert!(p >= 0.995 && r >= 0.995, "{name}: surface + axes + contours vs general engine: precision {p:.4} recall {r:.4}");
    // Guard: some free line must be partly hidden, or the test shows nothing.
    let first_free = (model.edges.len() - free.len()) as u32;
    let hidden_free: f64 = fast
        .iter()
        .filter(|l| matches!(l.source, LineSource::Edge(k) if k >= first_free))
        .map(|l| (1.0 - l.visible.iter().map(|(a, b)| b - a).sum::<f64>()) * l.a.distance(l.b))
        .sum();
    assert!(hidden_free > 0.0, "{name}: no free line is hidden");
    true
}

#[test]
fn surface_with_axes_and_base_contours() {
    let views: &[(&str, [f64; 3], [f64; 3], bool)] = &[
        ("oblique", [6.0, -7.5, 5.0], [0.0, 0.0, -0.3], false),
        ("from low", [-5.0, -6.0, 0.6], [0.0, 0.0, 0.0], false),
        ("corner-on", [-6.0, -6.0, 3.0], [0.0, 0.0, 0.0], false),
        // The eye in the grid's boundary plane x = 2: every line in that
        // plane is seen along one ray, grazing the boundary profile.
        ("from behind, in the boundary plane", [2.0, 7.0, 3.5], [0.0, 0.0, 0.0], false),
        ("eye over the grid", [0.5, -0.8, 2.5], [0.0, 1.5, 0.0], false),
        ("orthographic", [5.0, -6.0, 4.0], [0.0, 0.0, 0.0], true),
    ];
    for &(name, eye, target, ortho) in views {
        let scene = secondary_scene(name, eye, target, ortho, false);
        assert!(check_free(name, &scene), "{name}: the fast path declined");
    }
}

#[test]
fn surface_with_contours_on_it() {
    // Contours in the facets, tested when their facet is visited; with the
    // box and the base-plane contours as well.
    let views: &[(&str, [f64; 3], [f64; 3], bool)] = &[
        ("oblique", [6.0, -7.5, 5.0], [0.0, 0.0, -0.3], false),
        ("from low", [-5.0, -6.0, 0.6], [0.0, 0.0, 0.0], false),
        ("eye over the grid", [0.5, -0.8, 2.5], [0.0, 1.5, 0.0], false),
        ("orthographic", [5.0, -6.0, 4.0], [0.0, 0.0, 0.0], true),
    ];
    for &(name, eye, target, ortho) in views {
        let scene = secondary_scene(name, eye, target, ortho, true);
        assert!(check_free(name, &scene), "{name}: the fast path declined");
    }
}

#[test]
fn secondary_lines_the_complete_picture_cannot_settle_go_to_the_general_engine() {
    // Eye below the base plane: the contours under the surface are seen from
    // below it.
    let below = secondary_scene("below", [4.0, -6.0, -3.0], [0.0, 0.0, 0.0], false, false);
    assert!(!check_free("below", &below));
}

#[test]
fn a_surface_too_large_for_the_general_engine_loads_when_its_axes_keep_it_on_the_fast_path() {
    // 3200 x 3200 points lower to 20.5 M triangles, over the general
    // engine's limit; with a box and base-plane contours the grid engine
    // still draws it from above, not from below (where the general engine
    // would have to: see the test above).
    let load = |eye: &str| {
        let dir = std::env::temp_dir().join(format!("hiddenline-grid-huge-{}-{}", std::process::id(), eye.len()));
        std::fs::create_dir_all(&dir).unwrap();
        let text = format!(
            "[camera]\neye = {eye}\ntarget = [0.0, 0.0, 0.0]\nfov_deg = 40.0\n\n\
             [[surface]]\nz = \"0.3 * x * y\"\n\
             x = {{ from = -2.0, to = 2.0, steps = 3199 }}\ny = {{ from = -2.0, to = 2.0, steps = 3199 }}\n\n\
             [[axes]]\nstyle = \"box\"\n\n[[contours]]\nlevels = 3\non = \"base\"\n"
        );
        let path = dir.join("scene.toml");
        std::fs::write(&path, text).unwrap();
        let scene = Scene::load(&path);
        std::fs::remove_dir_all(&dir).ok();
        scene
    };
    let above = load("[6.0, -7.5, 5.0]").map_err(|e| e.to_string()).expect("the fast path draws it");
    assert!(hiddenline::grid::free::takes(&above.surfaces[0].grid, &above.camera, &above.grid_free_segments().unwrap()));
    let err = load("[4.0, -6.0, -3.0]").expect_err("the general engine would draw it").to_string();
    assert!(err.contains("faces"), "{err}");
}

/// A lone surface's visible lines come straight from the grid engine's
/// joined polylines; with a hidden pen the same scene goes through the
/// per-edge visibility and pieces. Both must draw the same visible lines:
/// the same length, every vertex of one on a segment of the other.
#[test]
fn lone_surface_renders_the_same_by_polylines_and_by_pieces() {
    let dir = std::env::temp_dir().join(format!("hiddenline-grid-render-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let scene = |name: &str, extra: &str| {
        let path = dir.join(format!("{name}.toml"));
        std::fs::write(
            &path,
            format!(
                "[camera]\neye = [5.0, -6.5, 3.0]\ntarget = [0.0, 0.0, 0.0]\nfov_deg = 35.0\n{extra}\n[[surface]]\n\
                 z = \"0.6 * exp(-(x^2 + y^2)) + 0.3 * sin(3 * x) * cos(2 * y)\"\n\
                 x = {{ from = -2.0, to = 2.0, steps = 30 }}\ny = {{ from = -2.0, to = 2.0, steps = 24 }}\n"
            ),
        )
        .unwrap();
        scene::render(scene::Scene::load(&path).unwrap()).unwrap()
    };
    let direct = scene("direct", "");
    let pieces = scene("pieces", "[render]\nhidden_pen = 2\n");
    let _ = std::fs::remove_dir_all(&dir);
    assert_eq!(direct.layers.len(), 1);
    let visible = |d: &strokes::Drawing| d.layers.iter().find(|l| l.kind == strokes::LineKind::Visible).unwrap().polylines.clone();
    let (a, b) = (visible(&direct), visible(&pieces));
    let len = |p: &[strokes::Polyline]| p.iter().map(strokes::Polyline::length).sum::<f64>();
    assert!((len(&a) - len(&b)).abs() < 1e-6 * len(&a), "{} vs {}", len(&a), len(&b));
    let on = |from: &[strokes::Polyline], to: &[strokes::Polyline]| {
        let segs: Vec<(strokes::DVec2, strokes::DVec2)> = to.iter().flat_map(|p| p.points.windows(2).map(|w| (w[0], w[1]))).collect();
        from.iter().flat_map(|p| &p.points).all(|&q| {
            segs.iter().any(|&(s, e)| {
                let d = e - s;
                let t = ((q - s).dot(d) / d.length_squared().max(f64::MIN_POSITIVE)).clamp(0.0, 1.0);
                q.distance(s + d * t) < 1e-6
            })
        })
    };
    assert!(on(&a, &b) && on(&b, &a));
}
