//! The grid engine against brute force: every grid edge is sampled densely and
//! each sample is ray-cast against every facet of the surface.

use super::*;
use crate::camera::Projection;

/// The brute-force verdict for a world point on the grid edge `(va, vb)`:
/// hidden when some facet not containing the edge projects over it and is
/// nearer the eye there.
fn ray_hidden(grid: &Grid, cam: &Camera, p: DVec3, edge: (usize, usize)) -> bool {
    let Some(d) = cam.project(p) else { return true };
    let sp = DVec2::new(d.x, d.y);
    let nx = grid.nx();
    for j in 0..grid.ny() - 1 {
        for i in 0..nx - 1 {
            let v00 = j * nx + i;
            let tris = [[v00, v00 + 1, v00 + nx + 1], [v00, v00 + nx + 1, v00 + nx]];
            for tri in tris {
                if tri.contains(&edge.0) && tri.contains(&edge.1) {
                    continue;
                }
                let w: Vec<DVec3> = tri.iter().map(|&v| grid.point(v % nx, v / nx)).collect();
                if let Some(depth) = facet_depth_at(cam, &w, sp) {
                    if depth < d.z - 1e-9 * (1.0 + d.z.abs()) {
                        return true;
                    }
                }
            }
        }
    }
    false
}

/// Device depth of the triangle `w` at screen point `s`, if it covers `s`:
/// found by intersecting the sight ray with the world-space plane.
fn facet_depth_at(cam: &Camera, w: &[DVec3], s: DVec2) -> Option<f64> {
    // The sight ray through screen point s, in world space.
    let (origin, dir) = sight_ray(cam, s);
    let n = (w[1] - w[0]).cross(w[2] - w[0]);
    let den = n.dot(dir);
    if den.abs() < 1e-300 {
        return None;
    }
    let t = n.dot(w[0] - origin) / den;
    let x = origin + dir * t;
    // Inside test with barycentrics.
    let area = n.length_squared();
    for k in 0..3 {
        let e = w[(k + 1) % 3] - w[k];
        if e.cross(x - w[k]).dot(n) < -1e-12 * area {
            return None;
        }
    }
    cam.project(x).map(|p| p.z)
}

fn sight_ray(cam: &Camera, s: DVec2) -> (DVec3, DVec3) {
    let inv = DMat4::look_at_rh(cam.eye, cam.target, cam.up).inverse();
    match cam.projection {
        Projection::Perspective { fov_deg } => {
            let f = 1.0 / (fov_deg.to_radians() * 0.5).tan();
            let v = DVec3::new(s.x / f, s.y / f, -1.0);
            (cam.eye, inv.transform_vector3(v))
        }
        Projection::Orthographic { height } => {
            let v = DVec3::new(s.x * height / 2.0, s.y * height / 2.0, 0.0);
            (inv.transform_point3(v), cam.direction())
        }
    }
}

use glam::DMat4;

/// Precision and recall of the engine's visible length against brute force,
/// sampling every grid edge at `samples` points.
fn agreement(grid: &Grid, cam: &Camera, samples: usize) -> (f64, f64) {
    let engine = Engine::new(grid, cam, GridLines::Both.into()).compute();
    let nx = grid.nx();
    let ny = grid.ny();
    let (mut both, mut eng, mut refv) = (0.0, 0.0, 0.0);
    let mut check = |va: usize, vb: usize, run: Slot| {
        let (a, b) = (grid.point(va % nx, va / nx), grid.point(vb % nx, vb / nx));
        let ends = engine.edge_ends(va, vb);
        let pieces: Vec<(DVec2, DVec2)> =
            engine.visible(run).iter().filter_map(|&(t0, t1)| ends.map(|(p, q)| (p.lerp(q, t0), p.lerp(q, t1)))).collect();
        for s in 0..samples {
            let t = (s as f64 + 0.5) / samples as f64;
            let p = a.lerp(b, t);
            let Some(d) = cam.project(p) else { continue };
            // Weight by device length so both measures are of drawn length.
            let w = match (cam.project(a.lerp(b, t - 0.5 / samples as f64)), cam.project(a.lerp(b, t + 0.5 / samples as f64))) {
                (Some(x), Some(y)) => DVec2::new(x.x - y.x, x.y - y.y).length(),
                _ => 0.0,
            };
            let sp = DVec2::new(d.x, d.y);
            let e = pieces.iter().any(|&(pa, pb)| seg_dist(sp, pa, pb) < 1e-9);
            let r = !ray_hidden(grid, cam, p, (va, vb));
            if e {
                eng += w;
            }
            if r {
                refv += w;
            }
            if e && r {
                both += w;
            }
        }
    };
    for j in 0..ny {
        for i in 0..nx - 1 {
            let v = j * nx + i;
            check(v, v + 1, engine.h_run[j * (nx - 1) + i]);
        }
    }
    for i in 0..nx {
        for j in 0..ny - 1 {
            let v = j * nx + i;
            check(v, v + nx, engine.v_run[j * nx + i]);
        }
    }
    let precision = if eng > 0.0 { both / eng } else { 1.0 };
    let recall = if refv > 0.0 { both / refv } else { 1.0 };
    (precision, recall)
}

fn seg_dist(p: DVec2, a: DVec2, b: DVec2) -> f64 {
    let d = b - a;
    let t = if d.length_squared() > 0.0 { ((p - a).dot(d) / d.length_squared()).clamp(0.0, 1.0) } else { 0.0 };
    p.distance(a + d * t)
}

fn persp(eye: [f64; 3], target: [f64; 3]) -> Camera {
    Camera::new(DVec3::from(eye), DVec3::from(target), DVec3::Z, Projection::Perspective { fov_deg: 40.0 }).unwrap()
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

/// A small deterministic pseudo-random generator (xorshift), so tests need no
/// seed crate and never vary.
fn noise(seed: u64) -> impl FnMut(f64, f64) -> f64 {
    let mut s = seed | 1;
    move |_, _| {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64 * 1.5
    }
}

fn bump(x: f64, y: f64) -> f64 {
    1.5 * (-(x * x + y * y)).exp()
}

fn waves(x: f64, y: f64) -> f64 {
    0.5 * (2.0 * x).sin() * (1.5 * y).cos()
}

fn assert_agrees(name: &str, grid: &Grid, cam: &Camera) {
    let (p, r) = agreement(grid, cam, 24);
    assert!(p >= 0.995 && r >= 0.995, "{name}: precision {p:.4} recall {r:.4}");
}

#[test]
fn oblique_perspective_above_the_surface() {
    assert_agrees("waves oblique", &uniform(14, waves), &persp([6.0, -7.0, 5.0], [0.0, 0.0, 0.0]));
    assert_agrees("bump oblique", &uniform(14, bump), &persp([-5.0, -6.0, 4.0], [0.0, 0.0, 0.0]));
}

#[test]
fn eye_above_the_interior_face_on() {
    // Seed 000, figure 1: perspective, eye above the surface inside the grid.
    let down =
        Camera::new(DVec3::new(0.3, 0.2, 6.0), DVec3::new(0.3, 0.2, 0.0), DVec3::Y, Projection::Perspective { fov_deg: 50.0 }).unwrap();
    assert_agrees("straight down", &uniform(12, waves), &down);
    assert_agrees("above, looking across", &uniform(12, bump), &persp([0.5, -0.4, 3.0], [0.0, 2.0, 0.0]));
    assert_agrees("saddle face-on", &uniform(12, |x, y| 0.4 * (x * x - y * y)), &persp([0.1, 0.15, 5.0], [0.0, 0.0, 0.0]));
}

#[test]
fn edge_on_and_corner_on() {
    assert_agrees("edge-on", &uniform(12, waves), &persp([0.0, -8.0, 3.0], [0.0, 0.0, 0.0]));
    assert_agrees("corner-on", &uniform(12, waves), &persp([-6.0, -6.0, 3.0], [0.0, 0.0, 0.0]));
}

#[test]
fn eye_exactly_on_a_grid_plane_and_above_a_grid_point() {
    let g = uniform(12, waves);
    let x4 = g.xs[4];
    let y7 = g.ys[7];
    assert_agrees("on plane x = x4, outside", &g, &persp([x4, -7.0, 3.0], [x4, 0.0, 0.0]));
    assert_agrees("on plane x = x4, above", &g, &persp([x4, 0.3, 3.0], [0.0, 1.0, 0.0]));
    assert_agrees("above grid point", &g, &persp([x4, y7, 3.0], [0.0, 0.0, 0.0]));
}

#[test]
fn horizontal_view_and_eye_below() {
    let g = uniform(12, waves);
    assert_agrees("horizontal", &g, &persp([0.5, -7.0, 0.8], [0.5, 0.0, 0.8]));
    assert_agrees("below, looking up", &g, &persp([0.7, -3.0, -3.0], [0.0, 0.0, 0.0]));
    assert_agrees("below, inside", &g, &persp([0.2, 0.1, -3.0], [0.0, 0.5, 0.0]));
}

#[test]
fn random_heights_low_views_and_nonuniform_grids() {
    assert_agrees("random", &uniform(12, noise(7)), &persp([5.0, -6.0, 4.0], [0.0, 0.0, 0.0]));
    assert_agrees("random inside", &uniform(10, noise(11)), &persp([0.3, 0.2, 3.0], [1.0, 1.0, 0.0]));
    assert_agrees("bump very low", &uniform(14, bump), &persp([-3.0, -7.0, 0.3], [0.0, 0.0, 0.5]));
    let xs = vec![-2.0, -1.7, -1.0, -0.9, -0.2, 0.0, 0.5, 1.4, 1.5, 2.0, 3.0];
    let ys = vec![-2.0, -1.0, -0.5, -0.4, 0.1, 0.9, 1.0, 1.8, 2.5];
    let g = Grid::from_fn(xs, ys, waves).unwrap();
    assert_agrees("non-uniform", &g, &persp([4.0, -5.0, 3.0], [0.0, 0.0, 0.0]));
    assert_agrees("non-uniform inside", &g, &persp([-0.5, 0.3, 2.5], [1.0, 0.0, 0.0]));
}

#[test]
fn orthographic_views() {
    let g = uniform(12, waves);
    assert_agrees("ortho oblique", &g, &ortho([5.0, -6.0, 4.0], [0.0, 0.0, 0.0]));
    assert_agrees("ortho edge-on", &g, &ortho([0.0, -6.0, 2.0], [0.0, 0.0, 0.0]));
    assert_agrees("ortho from +x +y", &g, &ortho([6.0, 5.0, 2.0], [0.0, 0.0, 0.0]));
    assert_agrees("ortho horizontal", &g, &ortho([6.0, 0.0, 0.0], [0.0, 0.0, 0.0]));
    let down = Camera::new(DVec3::new(0.0, 0.0, 5.0), DVec3::ZERO, DVec3::Y, Projection::Orthographic { height: 6.0 }).unwrap();
    assert_agrees("ortho straight down", &g, &down);
}

#[test]
fn some_lines_are_hidden_in_a_low_view() {
    // Guards the agreement tests against a trivially "all visible" engine.
    let g = uniform(14, bump);
    let cam = persp([-3.0, -7.0, 0.3], [0.0, 0.0, 0.5]);
    let all = Engine::new(&g, &cam, GridLines::Both.into()).all_visible().assemble();
    let vis = visible_lines(&g, &cam, GridLines::Both);
    let len = |v: &[DevicePolyline]| v.iter().flat_map(|p| p.windows(2)).map(|w| w[0].distance(w[1])).sum::<f64>();
    assert!(len(&vis) < 0.8 * len(&all), "{} vs {}", len(&vis), len(&all));
}

#[test]
fn line_selection_and_joined_polylines() {
    let g = uniform(8, |_, _| 0.0);
    let cam = persp([1.0, -6.0, 5.0], [0.0, 0.0, 0.0]);
    // A flat grid seen from above: every line visible, one polyline per line.
    assert_eq!(visible_lines(&g, &cam, GridLines::Both).len(), 18);
    assert_eq!(visible_lines(&g, &cam, GridLines::X).len(), 9);
    assert_eq!(visible_lines(&g, &cam, GridLines::Y).len(), 9);
}

#[test]
fn bad_grids_are_errors() {
    assert_eq!(Grid::new(vec![0.0], vec![0.0, 1.0], vec![0.0, 0.0]), Err(GridError::TooFewPoints { axis: "x", count: 1 }));
    assert!(matches!(
        Grid::new(vec![0.0, 1.0, 1.0], vec![0.0, 1.0], vec![0.0; 6]),
        Err(GridError::NotIncreasing { axis: "x", index: 2, .. })
    ));
    assert!(matches!(Grid::new(vec![0.0, 1.0], vec![0.0, 1.0], vec![0.0; 3]), Err(GridError::WrongSize { .. })));
    let e = Grid::from_fn(vec![0.0, 1.0], vec![0.0, 2.0], |x, y| if x == 1.0 && y == 2.0 { f64::NAN } else { 0.0 });
    assert!(matches!(e, Err(GridError::NotFinite { x, y, .. }) if x == 1.0 && y == 2.0));
}

#[test]
fn cell_lookup_and_outward_order() {
    let v = [0.0, 1.0, 2.0, 3.0];
    assert_eq!(cell_of(&v, -1.0), -1);
    assert_eq!(cell_of(&v, 0.0), 0);
    assert_eq!(cell_of(&v, 1.5), 1);
    assert_eq!(cell_of(&v, 3.0), 2);
    assert_eq!(cell_of(&v, 4.0), 3);
    assert_eq!(outward(3, -1), vec![0, 1, 2]);
    assert_eq!(outward(3, 3), vec![2, 1, 0]);
    assert_eq!(outward(3, 1), vec![1, 2, 0]);
}

#[test]
fn random_grid_at_bench_view() {
    let g = uniform(40, noise(3));
    let cam = Camera::new(DVec3::new(5.0, -6.5, 4.0), DVec3::ZERO, DVec3::Z, Projection::Perspective { fov_deg: 35.0 }).unwrap();
    let (p, r) = agreement(&g, &cam, 8);
    assert!(p >= 0.995 && r >= 0.995, "precision {p:.4} recall {r:.4}");
}

/// The two halves of the picture swept at once find what one sweep of both
/// finds, edge by edge, on the views above (the pole far below the
/// picture, inside it, on a grid plane) and random heights.
#[test]
fn two_half_sweeps_find_what_one_sweep_finds() {
    let views = [
        persp([6.0, -7.0, 5.0], [0.0, 0.0, 0.0]),
        persp([0.5, -0.4, 3.0], [0.0, 2.0, 0.0]),
        persp([0.1, 0.15, 5.0], [0.0, 0.0, 0.0]),
        persp([-6.0, -6.0, 3.0], [0.0, 0.0, 0.0]),
        persp([0.7, -3.0, -3.0], [0.0, 0.0, 0.0]),
        Camera::new(DVec3::new(5.0, -6.5, 4.0), DVec3::ZERO, DVec3::Z, Projection::Perspective { fov_deg: 35.0 }).unwrap(),
    ];
    let mut split = 0;
    for (n, grid) in [uniform(40, waves), uniform(33, noise(5)), uniform(25, bump)].iter().enumerate() {
        for (k, cam) in views.iter().enumerate() {
            let one = Engine::new(grid, cam, GridLines::Both.into()).compute_in_halves(false);
            let two = Engine::new(grid, cam, GridLines::Both.into()).compute_in_halves(true);
            assert_eq!(one.picture.len(), 1);
            split += usize::from(two.picture.len() == 2);
            for (lines, a, b) in [("along x", &one.h_run, &two.h_run), ("along y", &one.v_run, &two.v_run)] {
                for (e, (&ra, &rb)) in a.iter().zip(b).enumerate() {
                    let (va, vb) = (one.visible(ra), two.visible(rb));
                    let same = va.len() == vb.len() && va.iter().zip(vb).all(|(x, y)| (x.0 - y.0).abs() < 1e-9 && (x.1 - y.1).abs() < 1e-9);
                    assert!(same, "grid {n}, view {k}, edge {e} {lines}: {va:?} vs {vb:?}");
                }
            }
        }
    }
    assert_eq!(split, 3 * views.len(), "every view here has a finite pole and every vertex in front");
}
