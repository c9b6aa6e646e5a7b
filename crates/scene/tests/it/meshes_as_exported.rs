//! Meshes as people export them (issue 16): a corpus generated here, each
//! mesh written as an OBJ file with 4, 5 or 6 decimals (as Blender's exporter
//! writes them; curved surfaces also with 6 significant digits, as `%g`
//! writes them, and a height field rounded and printed shortest) and loaded
//! through a scene file, judged against the brute-force reference on the
//! same mesh written exactly:
//! - precision and recall >= 0.999 at 0.05 % of the drawing diagonal, with
//!   `edges = "all"` and `"feature"`;
//! - no length drawn twice: the engine's answer re-traces no more than the
//!   reference itself does ([`reference::retraced`]), and the plotted drawing
//!   (after `strokes::optimize`) re-traces nothing.

use hiddenline::reference::{self, Options};

use hiddenline::{engine, DVec3};
use scene::Scene;
use std::fmt::Write as _;

/// Vertices and polygons (0-based), exact.
#[derive(Clone, Default)]
struct Mesh {
    v: Vec<DVec3>,
    f: Vec<Vec<u32>>,
}

impl Mesh {
    fn add(mut self, other: Mesh) -> Mesh {
        let base = self.v.len() as u32;
        self.v.extend(other.v);
        self.f.extend(other.f.into_iter().map(|r| r.into_iter().map(|i| i + base).collect()));
        self
    }

    fn inward(mut self) -> Mesh {
        self.f.iter_mut().for_each(|r| r.reverse());
        self
    }

    /// Every vertex `k` times as far from the origin.
    fn scaled(mut self, k: f64) -> Mesh {
        self.v.iter_mut().for_each(|p| *p *= k);
        self
    }

    /// Each quad split into two triangles along its v0-v2 diagonal, as CAD
    /// exporters write a surface; other polygons as they are.
    fn triangulated(mut self) -> Mesh {
        self.f = self
            .f
            .into_iter()
            .flat_map(|r| if r.len() == 4 { vec![vec![r[0], r[1], r[2]], vec![r[0], r[2], r[3]]] } else { vec![r] })
            .collect();
        self
    }

    /// OBJ text, its coordinates written as `written` says.
    fn obj(&self, written: Written) -> String {
        let mut s = String::new();
        for p in &self.v {
            let [x, y, z] = p.to_array().map(|c| written.text(c));
            writeln!(s, "v {x} {y} {z}").unwrap();
        }
        for r in &self.f {
            s.push('f');
            for i in r {
                write!(s, " {}", i + 1).unwrap();
            }
            s.push('\n');
        }
        s
    }
}

/// How a mesh's coordinates are written.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Written {
    /// 17 significant digits: exactly.
    Exact,
    /// This many digits after the point (`%.6f`, as Blender writes).
    Decimals(usize),
    /// Rounded to this many places and printed shortest (`0.5`, `-0.0321`),
    /// as a script's `str(round(z, 4))` writes them.
    Rounded(usize),
    /// This many significant digits, trailing zeros dropped (`%g` with
    /// `%.6g`, as many CAD exporters write: 4 decimals at 15, 6 at 0.5).
    Significant(usize),
}

impl Written {
    fn text(self, c: f64) -> String {
        match self {
            Written::Exact => format!("{c:.17e}"),
            Written::Decimals(d) => format!("{c:.d$}"),
            Written::Rounded(d) => {
                let scale = 10f64.powi(d as i32);
                format!("{}", (c * scale).round() / scale)
            }
            Written::Significant(digits) => {
                // %g: fixed notation for exponents -4 ..= digits - 1.
                let e = format!("{c:.*e}", digits - 1);
                let exp: i32 = e[e.find('e').unwrap() + 1..].parse().unwrap();
                if c == 0.0 {
                    "0".to_string()
                } else if (-4..digits as i32).contains(&exp) {
                    let d = (digits as i32 - 1 - exp) as usize;
                    let t = format!("{c:.d$}");
                    if t.contains('.') {
                        t.trim_end_matches('0').trim_end_matches('.').to_string()
                    } else {
                        t
                    }
                } else {
                    let (m, x) = e.split_at(e.find('e').unwrap());
                    let m = if m.contains('.') { m.trim_end_matches('0').trim_end_matches('.') } else { m };
                    format!("{m}{x}")
                }
            }
        }
    }

    fn name(self) -> String {
        match self {
            Written::Exact => "exact".to_string(),
            Written::Decimals(d) => format!("{d} decimals"),
            Written::Rounded(d) => format!("{d} places printed shortest"),
            Written::Significant(d) => format!("{d} significant digits"),
        }
    }
}

/// A torus of `nu` x `nv` quads (every quad planar: an isosceles trapezoid),
/// wound outward; `arc` < 1 leaves it open (a part of the ring).
fn torus(big: f64, small: f64, nu: usize, nv: usize, arc: f64) -> Mesh {
    let closed = arc >= 1.0;
    let cols = if closed { nu } else { nu + 1 };
    let mut m = Mesh::default();
    for i in 0..cols {
        for j in 0..nv {
            let (u, v) = (std::f64::consts::TAU * arc * i as f64 / nu as f64, std::f64::consts::TAU * j as f64 / nv as f64);
            let r = big + small * v.cos();
            m.v.push(DVec3::new(r * u.cos(), r * u.sin(), small * v.sin()));
        }
    }
    let id = |i: usize, j: usize| ((i % cols) * nv + j % nv) as u32;
    for i in 0..nu {
        for j in 0..nv {
            m.f.push(vec![id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    m
}

/// A prism over the counter-clockwise polygon `ring` (x, y), from z0 to z1,
/// wound outward: the caps are n-gons.
fn prism(ring: &[(f64, f64)], z0: f64, z1: f64) -> Mesh {
    let n = ring.len() as u32;
    let mut m = Mesh::default();
    for &z in &[z0, z1] {
        m.v.extend(ring.iter().map(|&(x, y)| DVec3::new(x, y, z)));
    }
    m.f.push((0..n).rev().collect());
    m.f.push((n..2 * n).collect());
    for i in 0..n {
        let j = (i + 1) % n;
        m.f.push(vec![i, j, n + j, n + i]);
    }
    m
}

fn rect(x0: f64, y0: f64, x1: f64, y1: f64) -> Vec<(f64, f64)> {
    vec![(x0, y0), (x1, y0), (x1, y1), (x0, y1)]
}

fn ngon(n: usize, cx: f64, cy: f64, r: f64, phase: f64) -> Vec<(f64, f64)> {
    (0..n)
        .map(|k| {
            let a = phase + std::f64::consts::TAU * k as f64 / n as f64;
            (cx + r * a.cos(), cy + r * a.sin())
        })
        .collect()
}

/// An L-shaped (concave) outline, starting where a fan from the first
/// vertex would cover the notch.
fn ell(x: f64, y: f64, s: f64) -> Vec<(f64, f64)> {
    vec![(x + 2.0 * s, y + 0.8 * s), (x + 0.8 * s, y + 0.8 * s), (x + 0.8 * s, y + 2.0 * s), (x, y + 2.0 * s), (x, y), (x + 2.0 * s, y)]
}

/// A UV sphere about `c` of `n` quads around and `m` rings from pole to
/// pole (triangle fans at the poles), wound outward: every quad an
/// isosceles trapezoid, planar.
fn uv_sphere(c: DVec3, radius: f64, n: usize, m: usize) -> Mesh {
    let mut s = Mesh::default();
    s.v.push(c + DVec3::new(0.0, 0.0, radius));
    for r in 1..m {
        let (sc, cc) = (std::f64::consts::PI * r as f64 / m as f64).sin_cos();
        for k in 0..n {
            let (st, ct) = (std::f64::consts::TAU * k as f64 / n as f64).sin_cos();
            s.v.push(c + DVec3::new(sc * ct, sc * st, cc) * radius);
        }
    }
    s.v.push(c - DVec3::new(0.0, 0.0, radius));
    let bottom = (s.v.len() - 1) as u32;
    let at = |r: usize, k: usize| (1 + (r - 1) * n + k % n) as u32;
    for k in 0..n {
        s.f.push(vec![0, at(1, k), at(1, k + 1)]);
        s.f.push(vec![bottom, at(m - 1, k + 1), at(m - 1, k)]);
        for r in 1..m - 1 {
            s.f.push(vec![at(r, k), at(r + 1, k), at(r + 1, k + 1), at(r, k + 1)]);
        }
    }
    s
}

/// A heightfield z = `f(x, y)` of `n` x `n` cells on [-1, 1]^2, two
/// triangles per cell.
fn terrain(n: usize, f: impl Fn(f64, f64) -> f64) -> Mesh {
    let mut m = Mesh::default();
    for j in 0..=n {
        for i in 0..=n {
            let (x, y) = (-1.0 + 2.0 * i as f64 / n as f64, -1.0 + 2.0 * j as f64 / n as f64);
            m.v.push(DVec3::new(x, y, f(x, y)));
        }
    }
    let id = |i: usize, j: usize| (j * (n + 1) + i) as u32;
    for j in 0..n {
        for i in 0..n {
            m.f.push(vec![id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            m.f.push(vec![id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    m
}

/// A mesh, how to look at it, and what it exercises.
struct Case {
    name: &'static str,
    mesh: Mesh,
    eye: [f64; 3],
    target: [f64; 3],
}

fn corpus() -> Vec<Case> {
    let tunnel_box = prism(&rect(-1.0, -0.6, 1.0, 0.6), 0.0, 1.0);
    let mut t_junction = prism(&rect(-1.0, -0.6, 1.0, 0.6), 0.0, 0.8);
    // Split the top face in two at x = 0.1: its neighbours' top edges now
    // run past a vertex they do not have (T-junctions).
    let (a, b) = (t_junction.v.len() as u32, t_junction.v.len() as u32 + 1);
    t_junction.v.push(DVec3::new(0.1, -0.6, 0.8));
    t_junction.v.push(DVec3::new(0.1, 0.6, 0.8));
    t_junction.f[1] = vec![4, a, b, 7];
    t_junction.f.push(vec![a, 5, 6, b]);
    let mut dup = prism(&ngon(6, 0.0, 0.0, 1.0, 0.3), 0.0, 0.9);
    dup.f.push(dup.f[3].clone());
    let flipped: Vec<u32> = dup.f[1].iter().rev().copied().collect();
    dup.f.push(flipped);
    let mut fins = prism(&rect(-1.0, -0.5, 1.0, 0.5), 0.0, 0.7);
    // A fin on the box's top front edge: three faces on one edge.
    let (c, d) = (fins.v.len() as u32, fins.v.len() as u32 + 1);
    fins.v.push(DVec3::new(-1.0, -1.1, 1.2));
    fins.v.push(DVec3::new(1.0, -1.1, 1.2));
    fins.f.push(vec![4, 5, d, c]);
    let mut open_box = prism(&rect(-1.0, -0.7, 1.0, 0.7), 0.0, 0.9);
    open_box.f.remove(1);
    vec![
        Case { name: "torus 48 x 24 quads", mesh: torus(1.0, 0.35, 48, 24, 1.0), eye: [3.2, -2.6, 2.1], target: [0.0, 0.0, 0.0] },
        Case {
            name: "n-gon prisms, convex and concave",
            mesh: prism(&ngon(24, 0.0, 0.0, 0.8, 0.1), 0.0, 0.6).add(prism(&ngon(7, 1.6, 0.9, 0.5, 0.2), 0.0, 1.1)).add(prism(
                &ell(-1.9, 0.5, 0.7),
                0.0,
                0.9,
            )),
            eye: [3.5, -4.0, 3.0],
            target: [0.0, 0.3, 0.4],
        },
        Case {
            name: "mixed winding: box outward, L prism inward",
            mesh: tunnel_box.add(prism(&ell(-0.6, -2.2, 0.8), 0.0, 1.4).inward()),
            eye: [1.5, -6.0, 2.5],
            target: [0.0, -0.5, 0.5],
        },
        Case { name: "T-junctions", mesh: t_junction, eye: [2.6, -3.1, 2.4], target: [0.0, 0.0, 0.4] },
        Case { name: "duplicate and flipped faces", mesh: dup, eye: [2.8, -2.2, 2.6], target: [0.0, 0.0, 0.4] },
        Case { name: "non-manifold edge", mesh: fins, eye: [2.4, -3.3, 2.2], target: [0.0, -0.2, 0.5] },
        Case {
            name: "flat triangulated regions",
            // Flat (z = 0) where the bump is not positive.
            mesh: terrain(24, |x, y| (0.6 * (1.0 - 2.5 * ((x - 0.2).powi(2) + (y + 0.1).powi(2)))).max(0.0)),
            eye: [2.2, -2.8, 1.8],
            target: [0.0, 0.0, 0.1],
        },
        Case {
            name: "open meshes: a box without a lid, half a torus",
            mesh: open_box.add(torus(0.8, 0.25, 24, 12, 0.5).add(Mesh::default())),
            eye: [1.8, -3.0, 3.4],
            target: [0.0, 0.0, 0.3],
        },
    ]
}

/// The scene of `case`, its mesh written as `written` says.
fn load(case: &Case, written: Written, edges: &str) -> Scene {
    let d = crate::case_dir("meshes", case.name);
    let file = format!("m-{}-{edges}.obj", written.name().replace(' ', "-"));
    std::fs::write(d.path().join(&file), case.mesh.obj(written)).unwrap();
    let toml = format!(
        "[camera]\neye = {:?}\ntarget = {:?}\nfov_deg = 35.0\n\n[[mesh]]\npath = \"{file}\"\nedges = \"{edges}\"\ncrease_deg = 30.0\n",
        case.eye, case.target
    );
    let path = d.path().join(format!("{file}.toml"));
    std::fs::write(&path, toml).unwrap();
    Scene::load(&path).unwrap_or_else(|e| panic!("{}: {e}", case.name))
}

const MIN_SCORE: f64 = 0.999;
const TOL: f64 = 5e-4;

/// Judges `case` written each way of `written`, drawing `edges`, against
/// the reference on the mesh written exactly; returns the failures found
/// (empty when it draws exactly and nothing twice).
fn judge(case: &Case, edges: &str, written: &[Written]) -> Vec<String> {
    let truth = load(case, Written::Exact, edges);
    let reference = reference::sample(&truth.lower(), &truth.camera, &Options::default());
    let mut failures = Vec::new();
    for &w in written {
        let label = format!("{} ({}, edges = {edges})", case.name, w.name());
        let rounded = load(case, w, edges);
        let answer = engine::visibility(&rounded.lower(), &rounded.camera);
        let score = reference::compare(&answer, &reference, TOL);
        if !score.passes(MIN_SCORE) {
            failures.push(format!("{label}: precision {:.5}, recall {:.5}", score.precision, score.recall));
        }
        // Re-tracing, in device units, against what the scene itself overlaps.
        let tol = 1e-4 * reference.diagonal;
        let drawn = reference::retraced(&reference::answer_segments(&answer), tol);
        let expected = reference::retraced(&reference.segments(), tol);
        if drawn > expected + 1e-3 * score.expected {
            failures.push(format!("{label}: the engine draws {drawn:.4} twice, the reference {expected:.4} (of {:.3})", score.expected));
        }
        // The plotted drawing (page mm, after `strokes::optimize`): nothing
        // within the snapping tolerance of an earlier, nearly parallel line.
        let plotted = strokes::optimize(scene::render(rounded.clone()).unwrap(), &strokes::StrokeOptions::default());
        let segments: Vec<_> =
            plotted.layers.iter().flat_map(|l| &l.polylines).flat_map(|p| p.points.windows(2).map(|w| (w[0], w[1]))).collect();
        let twice = reference::retraced(&segments, strokes::DEFAULT_TOLERANCE_MM);
        // The ordering draws a fold's tip (at most 2 mm where a line turns
        // back on itself) again rather than lift the pen around it (README,
        // "Stroke ordering"): a rolling field's many silhouette folds add
        // up to about 0.14 % of its length; and it draws removed overlaps
        // again where they join two loose ends, at most
        // `strokes::rejoin::REJOIN_SHARE` of the drawing (0.37 % here).
        if twice > (2e-3 + strokes::rejoin::REJOIN_SHARE) * plotted.drawn_length() {
            failures.push(format!("{label}: the plot draws {twice:.2} mm of {:.1} mm twice", plotted.drawn_length()));
        }
    }
    failures
}

fn run(case_names: &[&str]) {
    let mut failures = Vec::new();
    for case in corpus().iter().filter(|c| case_names.iter().any(|n| c.name.starts_with(n))) {
        for edges in ["all", "feature"] {
            failures.extend(judge(case, edges, &[4, 5, 6].map(Written::Decimals)));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn near_planar_quads_of_a_torus() {
    run(&["torus"]);
}

#[test]
fn near_planar_n_gons_convex_and_concave() {
    run(&["n-gon"]);
}

#[test]
fn shells_of_mixed_winding_in_one_file() {
    run(&["mixed winding"]);
}

#[test]
fn t_junctions_duplicate_faces_and_non_manifold_edges() {
    run(&["T-junctions", "duplicate", "non-manifold"]);
}

#[test]
fn flat_triangulated_regions_and_open_meshes() {
    run(&["flat", "open"]);
}

/// The eye exactly level with a flat part of a surface: that part's grid
/// lines all project onto its horizon. The grid engine and the general
/// engine (the same surface with a line out of view beside it) then hand
/// over different pieces of the one line, but once plotted both draw it
/// once, and the same length (issue 16: on main the horizon was drawn about
/// ten times, and the two engines disagreed by a fifth).
#[test]
fn a_horizon_seen_edge_on_is_drawn_once_by_either_engine() {
    let d = crate::case_dir("meshes", "horizon");
    let scene = |extra: &str| {
        let toml = format!(
            "[camera]\neye = [-7.0, -5.0, 0.0]\ntarget = [0.0, 0.0, 0.0]\nfov_deg = 40.0\nframe = \"fov\"\n\n\
             [[surface]]\nz = \"0.4 * max(0, x + 0.5)^2\"\nx = {{ from = -2.0, to = 2.0, steps = 24 }}\n\
             y = {{ from = -2.0, to = 2.0, steps = 24 }}\n{extra}"
        );
        let path = d.path().join(format!("horizon-{}.toml", extra.len()));
        std::fs::write(&path, toml).unwrap();
        Scene::load(&path).unwrap()
    };
    let grid = scene("");
    // Far behind the eye: out of view, but the scene is no longer one
    // surface alone, so the general engine draws it.
    let general = scene("\n[[polyline]]\npoints = [[-60.0, -60.0, 0.5], [-61.0, -60.0, 0.5]]\n");
    let plot = |s: &Scene| strokes::optimize(scene::render(s.clone()).unwrap(), &strokes::StrokeOptions::default());
    let (a, b) = (plot(&grid), plot(&general));
    let (la, lb) = (a.drawn_length(), b.drawn_length());
    assert!((la - lb).abs() <= 2e-3 * la.max(lb), "grid engine {la:.1} mm, general engine {lb:.1} mm");
    for (name, p) in [("grid", &a), ("general", &b)] {
        let segments: Vec<_> = p.layers.iter().flat_map(|l| &l.polylines).flat_map(|q| q.points.windows(2).map(|w| (w[0], w[1]))).collect();
        let twice = reference::retraced(&segments, strokes::DEFAULT_TOLERANCE_MM);
        assert!(twice <= 1e-3 * p.drawn_length(), "{name} engine: {twice:.1} of {:.1} mm drawn twice", p.drawn_length());
    }
}

/// `mesh` seen from `offset` away from `target`.
fn case(name: &'static str, mesh: Mesh, target: [f64; 3], offset: [f64; 3]) -> Case {
    let eye = [0, 1, 2].map(|k| target[k] + offset[k]);
    Case { name, mesh, eye, target }
}

/// Sides of the test cylinder, and quads around and rings of the test sphere:
/// their folds are 0.016 and 0.1 rad.
const CYLINDER_SIDES: usize = 400;
const SPHERE_AROUND: usize = 64;
const SPHERE_RINGS: usize = 32;

/// Finely tessellated curved surfaces written with 6 significant digits
/// (`%g`: 4 decimals at coordinates near 15), as a CAD exporter writes
/// them: every edge between two faces that meet at an angle is drawn, as
/// for the mesh written exactly (issue 40 item 0: a fold of a hundredth of
/// a radian between triangles a few hundredths wide is far more than a
/// rounding of 5e-5 can make, yet their vertices lie within 7 roundings of
/// each other's plane, and the rule of that time dropped the edge).
#[test]
fn finely_tessellated_curves_written_with_six_significant_digits_draw_every_edge() {
    let centre = DVec3::splat(15.0);
    let cylinder = prism(&ngon(CYLINDER_SIDES, 15.0, 15.0, 1.0, 0.1), 14.0, 16.0).triangulated();
    let cases = [
        case("cylinder of triangle strips", cylinder, [15.0, 15.0, 15.0], [3.2, -2.6, 2.1]),
        case("UV sphere of quads", uv_sphere(centre, 2.0, SPHERE_AROUND, SPHERE_RINGS), [15.0, 15.0, 15.0], [6.4, -5.2, 4.2]),
    ];
    let failures: Vec<String> = cases.iter().flat_map(|c| judge(c, "all", &[Written::Significant(6)])).collect();
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Cells a side of the rolling height field.
const TERRAIN_CELLS: usize = 24;

/// A rolling height field (24 x 24 cells 40 across, hills 10 high) written as an OBJ with
/// 4 decimals, as `%.4f` writes them and as a script rounding to 4 places
/// prints them (`0.5`, `-12.0321`), and with 6 decimals, draws every edge
/// (issue 40 item 0: with 4 decimals printed shortest, `0.5` made the file's
/// rounding 0.05, and faces folded by up to a hundredth of a radian were
/// taken as coplanar).
#[test]
fn a_rolling_height_field_written_with_4_and_6_decimals_draws_every_edge() {
    let rolling = terrain(TERRAIN_CELLS, |x, y| 0.36 * (2.1 * x + 0.3).sin() * (1.7 * y - 0.4).cos() + 0.15 * (3.3 * x + 2.2 * y).sin());
    let c = case("rolling height field", rolling.scaled(20.0), [0.0, 0.0, 0.0], [44.0, -56.0, 36.0]);
    let failures = judge(&c, "all", &[Written::Decimals(4), Written::Rounded(4), Written::Decimals(6)]);
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
