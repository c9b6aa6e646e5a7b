//! Model-level scenes built in code, each judged against the brute-force
//! reference (`hiddenline::reference`): precision and recall of drawn length
//! at least 0.995 at 0.1 % of the drawing diagonal.

use hiddenline::engine::visibility;
use hiddenline::reference::{self, Options};
use hiddenline::{Camera, DVec2, DVec3, Edge, Face, LineSource, LineVisibility, Model, Projection};

fn v(x: f64, y: f64, z: f64) -> DVec3 {
    DVec3::new(x, y, z)
}

fn persp(eye: DVec3, target: DVec3, fov: f64) -> Camera {
    Camera::new(eye, target, DVec3::Z, Projection::Perspective { fov_deg: fov }).unwrap()
}

/// Adds polygons as faces, and every boundary segment as an edge listing the
/// faces it lies on (shared segments once).
fn add_faces(model: &mut Model, polys: Vec<(Vec<DVec3>, Vec<Vec<DVec3>>)>, outward: bool) {
    let base = model.faces.len() as u32;
    let mut edges: Vec<(DVec3, DVec3, Vec<u32>)> = Vec::new();
    for (k, (outer, holes)) in polys.iter().enumerate() {
        for ring in std::iter::once(outer).chain(holes) {
            for i in 0..ring.len() {
                let (a, b) = (ring[i], ring[(i + 1) % ring.len()]);
                match edges.iter_mut().find(|e| (e.0 == a && e.1 == b) || (e.0 == b && e.1 == a)) {
                    Some(e) => e.2.push(base + k as u32),
                    None => edges.push((a, b, vec![base + k as u32])),
                }
            }
        }
    }
    for (outer, holes) in polys {
        model.faces.push(Face { outer, holes, pen: 1, outward });
    }
    for (a, b, faces) in edges {
        model.edges.push(Edge { a, b, pen: 1, faces });
    }
}

/// An axis-aligned box, faces counter-clockwise seen from outside.
fn cuboid(lo: DVec3, hi: DVec3) -> Vec<(Vec<DVec3>, Vec<Vec<DVec3>>)> {
    let c = |x: usize, y: usize, z: usize| v([lo.x, hi.x][x], [lo.y, hi.y][y], [lo.z, hi.z][z]);
    let quads = [
        [c(0, 0, 0), c(0, 1, 0), c(1, 1, 0), c(1, 0, 0)], // bottom, -z
        [c(0, 0, 1), c(1, 0, 1), c(1, 1, 1), c(0, 1, 1)], // top, +z
        [c(0, 0, 0), c(1, 0, 0), c(1, 0, 1), c(0, 0, 1)], // -y
        [c(0, 1, 0), c(0, 1, 1), c(1, 1, 1), c(1, 1, 0)], // +y
        [c(0, 0, 0), c(0, 0, 1), c(0, 1, 1), c(0, 1, 0)], // -x
        [c(1, 0, 0), c(1, 1, 0), c(1, 1, 1), c(1, 0, 1)], // +x
    ];
    quads.iter().map(|q| (q.to_vec(), vec![])).collect()
}

fn boxed(lo: DVec3, hi: DVec3) -> Model {
    let mut m = Model::default();
    add_faces(&mut m, cuboid(lo, hi), true);
    m
}

fn judge_with(name: &str, model: &Model, camera: &Camera, options: Options) -> Vec<LineVisibility> {
    let answer = visibility(model, camera);
    let r = reference::sample(model, camera, &options);
    let score = reference::compare(&answer, &r, hiddenline::tolerance::COMPARE_TOL);
    assert!(score.passes(0.995), "{name}: {score:?}");
    assert!(score.expected > 0.0, "{name}: the reference sees nothing");
    answer
}

fn judge(name: &str, model: &Model, camera: &Camera) -> Vec<LineVisibility> {
    judge_with(name, model, camera, Options::default())
}

fn drawn_edges(answer: &[LineVisibility]) -> usize {
    answer
        .iter()
        .filter(|l| matches!(l.source, LineSource::Edge(_)))
        .filter(|l| l.visible.iter().map(|(a, b)| b - a).sum::<f64>() > 1e-6)
        .count()
}

#[test]
fn cube_from_a_corner_shows_nine_edges() {
    let m = boxed(v(-1.0, -1.0, -1.0), v(1.0, 1.0, 1.0));
    let cam = persp(v(5.0, -4.0, 3.0), DVec3::ZERO, 40.0);
    let answer = judge("cube", &m, &cam);
    assert_eq!(drawn_edges(&answer), 9);
    // Every drawn edge is drawn whole, every other edge not at all.
    for l in &answer {
        assert!(l.visible.is_empty() || l.visible[..] == [(0.0, 1.0)], "{l:?}");
    }
    // Orthographic, and without back-face culling: the same nine.
    let ortho = Camera::new(v(5.0, -4.0, 3.0), DVec3::ZERO, DVec3::Z, Projection::Orthographic { height: 5.0 }).unwrap();
    assert_eq!(drawn_edges(&judge("cube ortho", &m, &ortho)), 9);
    let mut open = m.clone();
    open.faces.iter_mut().for_each(|f| f.outward = false);
    assert_eq!(drawn_edges(&judge("cube no culling", &open, &cam)), 9);
}

#[test]
fn lattice_of_cubes() {
    let mut m = Model::default();
    for i in 0..3 {
        for j in 0..3 {
            for k in 0..3 {
                let lo = v(i as f64 * 2.0, j as f64 * 2.0, k as f64 * 2.0);
                add_faces(&mut m, cuboid(lo, lo + DVec3::ONE), true);
            }
        }
    }
    judge("lattice", &m, &persp(v(14.0, -9.0, 11.0), v(2.5, 2.5, 2.5), 40.0));
    // Looking straight down a row: back cubes' edges line up behind front ones.
    judge("lattice head-on", &m, &persp(v(0.5, -12.0, 0.5), v(0.5, 0.0, 0.5), 50.0));
}

#[test]
fn box_with_a_square_hole_through_it() {
    // A frame: outer 4x4, hole 2x2, depth 1, as faces with holes plus the
    // four tunnel walls.
    let (o, h) = (2.0, 1.0);
    let ring = |y: f64, s: f64| vec![v(-s, y, -s), v(s, y, -s), v(s, y, s), v(-s, y, s)];
    let mut polys = vec![(ring(0.0, o), vec![ring(0.0, h)]), (ring(1.0, o), vec![ring(1.0, h)])];
    for (a, b) in [(0, 1), (1, 2), (2, 3), (3, 0)] {
        let (f, r) = (ring(0.0, o), ring(1.0, o));
        polys.push((vec![f[a], f[b], r[b], r[a]], vec![]));
        let (f, r) = (ring(0.0, h), ring(1.0, h));
        polys.push((vec![f[a], f[b], r[b], r[a]], vec![]));
    }
    let mut m = Model::default();
    add_faces(&mut m, polys, false);
    // A line behind the frame, partly seen through the hole.
    m.edges.push(Edge { a: v(-4.0, 3.0, 0.3), b: v(4.0, 3.0, 0.3), pen: 2, faces: vec![] });
    let answer = judge("frame", &m, &persp(v(1.5, -9.0, 2.0), v(0.0, 0.5, 0.0), 40.0));
    let last = answer.iter().find(|l| l.source == LineSource::Edge(m.edges.len() as u32 - 1)).unwrap();
    assert_eq!(last.visible.len(), 3, "either side of the frame and through the hole: {last:?}");
}

#[test]
fn two_interpenetrating_boxes() {
    let mut m = boxed(v(0.0, 0.0, 0.0), v(2.0, 2.0, 2.0));
    add_faces(&mut m, cuboid(v(1.0, 1.0, 1.0), v(3.0, 3.0, 2.5)), true);
    let cam = persp(v(8.0, -6.0, 7.0), v(1.5, 1.5, 1.0), 40.0);
    let answer = judge("interpenetrating", &m, &cam);
    let seen: Vec<_> = answer.iter().filter(|l| matches!(l.source, LineSource::Intersection(..)) && !l.visible.is_empty()).collect();
    assert!(seen.len() >= 2, "penetration lines are drawn: {seen:?}");
}

#[test]
fn plate_piercing_a_box() {
    let mut m = boxed(v(0.0, 0.0, 0.0), v(2.0, 2.0, 2.0));
    add_faces(&mut m, vec![(vec![v(-1.0, 0.5, 1.2), v(3.0, 0.5, 0.8), v(3.0, 1.5, 0.8), v(-1.0, 1.5, 1.2)], vec![])], false);
    judge("plate", &m, &persp(v(6.0, -7.0, 5.0), v(1.0, 1.0, 1.0), 45.0));
    judge("plate from below", &m, &persp(v(-3.0, -5.0, -4.0), v(1.0, 1.0, 1.0), 45.0));
}

#[test]
fn concave_l_prism() {
    let l = [(0.0, 0.0), (3.0, 0.0), (3.0, 1.0), (1.0, 1.0), (1.0, 3.0), (0.0, 3.0)];
    let bottom: Vec<DVec3> = l.iter().rev().map(|&(x, y)| v(x, y, 0.0)).collect();
    let top: Vec<DVec3> = l.iter().map(|&(x, y)| v(x, y, 1.0)).collect();
    let mut polys = vec![(bottom, vec![]), (top, vec![])];
    for i in 0..l.len() {
        let (a, b) = (l[i], l[(i + 1) % l.len()]);
        polys.push((vec![v(a.0, a.1, 0.0), v(b.0, b.1, 0.0), v(b.0, b.1, 1.0), v(a.0, a.1, 1.0)], vec![]));
    }
    let mut m = Model::default();
    add_faces(&mut m, polys, true);
    judge("L prism", &m, &persp(v(7.0, 6.0, 4.0), v(1.0, 1.0, 0.5), 40.0));
    judge("L prism other side", &m, &persp(v(-4.0, -5.0, 3.0), v(1.0, 1.0, 0.5), 40.0));
}

#[test]
fn polygon_with_two_holes_and_free_lines() {
    let sq =
        |cx: f64, cz: f64, s: f64| vec![v(cx - s, 0.0, cz - s), v(cx + s, 0.0, cz - s), v(cx + s, 0.0, cz + s), v(cx - s, 0.0, cz + s)];
    let mut m = Model::default();
    add_faces(&mut m, vec![(sq(0.0, 0.0, 3.0), vec![sq(-1.2, 0.5, 0.8), sq(1.3, -0.7, 0.6)])], false);
    // Free lines: behind (through the holes), in front, piercing, in the plane.
    for (a, b) in [
        (v(-5.0, 2.0, 0.5), v(5.0, 2.0, -0.7)),
        (v(-5.0, 2.0, -2.0), v(5.0, 2.0, 2.5)),
        (v(-4.0, -1.0, 1.0), v(4.0, -1.0, 1.5)),
        (v(-4.0, -2.0, -2.5), v(4.0, 3.0, -2.0)),
        (v(-2.0, 0.0, -2.0), v(2.0, 0.0, 2.0)),
    ] {
        m.edges.push(Edge { a, b, pen: 1, faces: vec![] });
    }
    let answer = judge("two holes", &m, &persp(v(2.0, -12.0, 3.0), DVec3::ZERO, 45.0));
    let in_plane = answer.iter().find(|l| l.source == LineSource::Edge(m.edges.len() as u32 - 1)).unwrap();
    assert_eq!(in_plane.visible[..], [(0.0, 1.0)], "a line in the face's plane is not hidden by it");
}

#[test]
fn face_seen_edge_on_hides_nothing() {
    let mut m = Model::default();
    // A vertical wall in the plane x = 0, eye on that plane.
    add_faces(&mut m, vec![(vec![v(0.0, 0.0, -2.0), v(0.0, 3.0, -2.0), v(0.0, 3.0, 2.0), v(0.0, 0.0, 2.0)], vec![])], false);
    m.edges.push(Edge { a: v(-2.0, 5.0, 0.0), b: v(2.0, 5.0, 0.0), pen: 1, faces: vec![] });
    let answer = judge("edge-on", &m, &persp(v(0.0, -8.0, 1.0), v(0.0, 0.0, 0.0), 40.0));
    let free = answer.iter().find(|l| l.source == LineSource::Edge(4)).unwrap();
    assert_eq!(free.visible[..], [(0.0, 1.0)]);
}

#[test]
fn eye_inside_a_room_of_boxes() {
    let mut m = Model::default();
    // The room: a closed box around the eye, seen from inside.
    add_faces(&mut m, cuboid(v(-10.0, -10.0, 0.0), v(10.0, 10.0, 6.0)), true);
    for (x, y) in [(3.0, 4.0), (-5.0, 2.0), (1.0, -6.0), (6.0, -1.0), (-2.0, 7.0)] {
        add_faces(&mut m, cuboid(v(x, y, 0.0), v(x + 1.5, y + 1.0, 1.0 + x.abs() * 0.3)), true);
    }
    let options = Options { window: Some((DVec2::splat(-1.5), DVec2::splat(1.5))), ..Options::default() };
    for (eye, target) in [
        (v(0.0, 0.0, 1.7), v(3.0, 4.0, 1.0)),
        (v(-1.0, 1.0, 2.0), v(-5.0, -3.0, 0.0)),
        (v(0.0, 0.0, 1.7), v(10.0, 10.0, 3.0)),
        (v(8.0, -8.0, 5.0), v(1.0, -6.0, 0.0)),
    ] {
        judge_with("room", &m, &persp(eye, target, 70.0), options);
    }
}

#[test]
fn coplanar_overlaps_and_t_junctions() {
    let mut m = Model::default();
    // Two coplanar overlapping squares: both outlines are drawn.
    add_faces(&mut m, vec![(vec![v(0.0, 0.0, 0.0), v(2.0, 0.0, 0.0), v(2.0, 2.0, 0.0), v(0.0, 2.0, 0.0)], vec![])], false);
    add_faces(&mut m, vec![(vec![v(1.0, 1.0, 0.0), v(3.0, 1.0, 0.0), v(3.0, 3.0, 0.0), v(1.0, 3.0, 0.0)], vec![])], false);
    // A big face with two small ones along its edge (T-junctions), standing up.
    add_faces(&mut m, vec![(vec![v(0.0, 4.0, 0.0), v(4.0, 4.0, 0.0), v(4.0, 4.0, 2.0), v(0.0, 4.0, 2.0)], vec![])], false);
    add_faces(
        &mut m,
        vec![
            (vec![v(0.0, 4.0, 2.0), v(2.0, 4.0, 2.0), v(2.0, 5.0, 2.0), v(0.0, 5.0, 2.0)], vec![]),
            (vec![v(2.0, 4.0, 2.0), v(4.0, 4.0, 2.0), v(4.0, 5.0, 2.0), v(2.0, 5.0, 2.0)], vec![]),
        ],
        false,
    );
    // A triangulated quad in front: the line behind its diagonal stays hidden.
    add_faces(
        &mut m,
        vec![
            (vec![v(-1.0, -2.0, -1.0), v(5.0, -2.0, -1.0), v(5.0, -2.0, 0.5)], vec![]),
            (vec![v(-1.0, -2.0, -1.0), v(5.0, -2.0, 0.5), v(-1.0, -2.0, 0.5)], vec![]),
        ],
        false,
    );
    let cam = persp(v(2.0, -12.0, 6.0), v(2.0, 2.0, 0.0), 40.0);
    judge("coplanar", &m, &cam);
    // Now from exactly in line with the diagonal's plane: a line behind the
    // diagonal, in the plane through the eye and the diagonal.
    let eye = v(2.0, -12.0, 6.0);
    let (d0, d1) = (v(-1.0, -2.0, -1.0), v(5.0, -2.0, 0.5));
    let far = |p: DVec3| p + (p - eye) * 0.5;
    m.edges.push(Edge { a: far(d0.lerp(d1, 0.2)), b: far(d0.lerp(d1, 0.8)), pen: 3, faces: vec![] });
    let answer = judge("behind a diagonal", &m, &cam);
    let last = answer.last().filter(|l| l.source == LineSource::Edge(m.edges.len() as u32 - 1));
    let last = answer.iter().find(|l| l.source == LineSource::Edge(m.edges.len() as u32 - 1)).or(last).unwrap();
    assert!(last.visible.is_empty(), "no leak through the crack between two triangles: {last:?}");
}

#[test]
fn lines_behind_the_eye_and_end_on_are_left_out() {
    let m = Model {
        faces: vec![],
        edges: vec![
            Edge { a: v(0.0, -20.0, 0.0), b: v(1.0, -30.0, 0.0), pen: 1, faces: vec![] },
            Edge { a: v(0.0, 0.0, 0.0), b: v(0.0, 5.0, 0.0), pen: 1, faces: vec![] },
            Edge { a: v(0.0, -20.0, 1.0), b: v(0.0, 20.0, 1.0), pen: 1, faces: vec![] },
        ],
    };
    let answer = visibility(&m, &persp(v(0.0, -10.0, 0.0), DVec3::ZERO, 40.0));
    assert_eq!(answer.len(), 1);
    assert_eq!(answer[0].source, LineSource::Edge(2));
    assert_eq!(answer[0].visible[..], [(0.0, 1.0)]);
}

#[test]
fn non_finite_and_degenerate_input_does_not_panic() {
    let nan = f64::NAN;
    let mut m = boxed(v(0.0, 0.0, 0.0), v(1.0, 1.0, 1.0));
    m.faces.push(Face { outer: vec![v(nan, 0.0, 0.0), v(1.0, 0.0, 0.0), v(1.0, 1.0, 0.0)], holes: vec![], pen: 1, outward: false });
    m.faces.push(Face {
        outer: vec![v(0.0, 0.0, 0.0), v(f64::INFINITY, 0.0, 0.0), v(1.0, 1.0, 0.0)],
        holes: vec![],
        pen: 1,
        outward: false,
    });
    m.faces.push(Face { outer: vec![v(0.0, 0.0, 0.0)], holes: vec![vec![]], pen: 1, outward: false });
    m.edges.push(Edge { a: v(nan, 0.0, 0.0), b: v(1.0, 1.0, 1.0), pen: 1, faces: vec![] });
    m.edges.push(Edge { a: v(2.0, 2.0, 2.0), b: v(2.0, 2.0, 2.0), pen: 1, faces: vec![99] });
    let cam = persp(v(5.0, -4.0, 3.0), v(0.5, 0.5, 0.5), 40.0);
    let answer = visibility(&m, &cam);
    // The cube's nine visible edges survive the garbage around them.
    assert_eq!(drawn_edges(&answer), 9);
    assert!(visibility(&Model::default(), &cam).is_empty());
}
