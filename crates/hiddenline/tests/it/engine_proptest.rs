//! Random small scenes of triangles and free segments: the engine agrees
//! with the brute-force reference.

use hiddenline::engine::visibility;
use hiddenline::reference;
use hiddenline::{Camera, DVec3, Edge, Face, Model, Projection};
use proptest::prelude::*;

fn point() -> impl Strategy<Value = DVec3> {
    (-2.0..2.0f64, -2.0..2.0f64, -2.0..2.0f64).prop_map(|(x, y, z)| DVec3::new(x, y, z))
}

fn triangle() -> impl Strategy<Value = [DVec3; 3]> {
    (point(), point(), point()).prop_map(|(c, a, b)| [c, c + a * 0.6, c + b * 0.6])
}

fn scene() -> impl Strategy<Value = (Model, Camera)> {
    (
        prop::collection::vec(triangle(), 1..10),
        prop::collection::vec((point(), point()), 0..6),
        (-1.0..1.0f64, 0.2..1.0f64, 0.0..std::f64::consts::TAU, any::<bool>()),
    )
        .prop_map(|(tris, segs, (h, dist, angle, ortho))| {
            let mut model = Model::default();
            for (k, t) in tris.iter().enumerate() {
                model.faces.push(Face { outer: t.to_vec(), holes: vec![], pen: 1, outward: false });
                for i in 0..3 {
                    model.edges.push(Edge { a: t[i], b: t[(i + 1) % 3], pen: 1, faces: vec![k as u32] });
                }
            }
            for (a, b) in segs {
                model.edges.push(Edge { a, b, pen: 2, faces: vec![] });
            }
            let r = 6.0 + 10.0 * dist;
            let eye = DVec3::new(r * angle.cos(), r * angle.sin(), r * h);
            let projection = if ortho { Projection::Orthographic { height: 6.0 } } else { Projection::Perspective { fov_deg: 45.0 } };
            (model, Camera::new(eye, DVec3::ZERO, DVec3::Z, projection).unwrap())
        })
}

/// Vertices on a coarse integer lattice: coplanar faces, shared edges and
/// vertices, collinear overlaps and T-junctions on purpose; the camera on a
/// lattice direction too, so faces are often seen exactly edge-on.
fn lattice_scene() -> impl Strategy<Value = (Model, Camera)> {
    let p = || (-2..=2i32, -2..=2i32, -2..=2i32).prop_map(|(x, y, z)| DVec3::new(x as f64, y as f64, z as f64));
    (
        prop::collection::vec((p(), p(), p()), 1..12),
        prop::collection::vec((p(), p()), 0..6),
        (-3..=3i32, -3..=3i32, 1..=3i32, any::<bool>()),
    )
        .prop_filter_map("degenerate camera", |(tris, segs, (ex, ey, ez, ortho))| {
            let mut model = Model::default();
            for (a, b, c) in tris {
                let k = model.faces.len() as u32;
                model.faces.push(Face { outer: vec![a, b, c], holes: vec![], pen: 1, outward: false });
                for (u, v) in [(a, b), (b, c), (c, a)] {
                    model.edges.push(Edge { a: u, b: v, pen: 1, faces: vec![k] });
                }
            }
            for (a, b) in segs {
                model.edges.push(Edge { a, b, pen: 2, faces: vec![] });
            }
            let eye = DVec3::new(ex as f64, ey as f64, ez as f64) * 4.0 + DVec3::new(0.0, 0.0, 1.0);
            let projection = if ortho { Projection::Orthographic { height: 8.0 } } else { Projection::Perspective { fov_deg: 60.0 } };
            let camera = Camera::new(eye, DVec3::ZERO, DVec3::Z, projection).ok()?;
            Some((model, camera))
        })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, ..ProptestConfig::default() })]

    #[test]
    fn random_scenes_agree_with_the_reference((model, camera) in scene()) {
        let answer = visibility(&model, &camera);
        let score = reference::check(&model, &camera, &answer);
        prop_assert!(score.passes(0.995), "{score:?}");
    }

    #[test]
    fn degenerate_lattice_scenes_agree_with_the_reference((model, camera) in lattice_scene()) {
        let answer = visibility(&model, &camera);
        let score = reference::check(&model, &camera, &answer);
        prop_assert!(score.passes(0.995), "{score:?}");
    }
}
