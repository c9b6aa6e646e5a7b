//! Properties of scene loading and lowering over random input: never a
//! panic, and the lowering's invariants hold.

use hiddenline::{Camera, DVec3, Projection};
use proptest::prelude::*;
use scene::mesh_file::{parse_obj, parse_stl};
use scene::Scene;
use scene::{EdgeStyle, Mesh, ModelBuilder};
use std::path::Path;

fn camera() -> Camera {
    Camera::new(DVec3::new(5.0, -4.0, 3.0), DVec3::ZERO, DVec3::Z, Projection::Perspective { fov_deg: 40.0 }).unwrap()
}

/// Small integer coordinates, so random faces share vertices, edges and planes.
fn vertex() -> impl Strategy<Value = DVec3> {
    (-2i32..=2, -2i32..=2, -2i32..=2).prop_map(|(x, y, z)| DVec3::new(x as f64, y as f64, z as f64))
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 200, ..ProptestConfig::default() })]

    #[test]
    fn random_meshes_lower_consistently(
        vertices in prop::collection::vec(vertex(), 3..20),
        faces in prop::collection::vec(prop::collection::vec(0u32..24, 3..6), 1..20),
        feature in any::<bool>(),
    ) {
        let style = if feature { EdgeStyle::Feature { crease: 0.5 } } else { EdgeStyle::All };
        let mesh = Mesh::new("random", vertices, faces, style, 1);
        let mut out = ModelBuilder::new();
        mesh.lower(&camera(), &mut out);
        let model = out.finish();
        let mut seen = std::collections::HashSet::new();
        for e in &model.edges {
            prop_assert!(e.a != e.b);
            // Each edge is drawn once...
            let key = if e.a.to_array() < e.b.to_array() { (e.a.to_array().map(f64::to_bits), e.b.to_array().map(f64::to_bits)) } else { (e.b.to_array().map(f64::to_bits), e.a.to_array().map(f64::to_bits)) };
            prop_assert!(seen.insert(key));
            // ...and lies on every face it names.
            for &f in &e.faces {
                let face = &model.faces[f as usize];
                prop_assert!(face.outer.contains(&e.a) && face.outer.contains(&e.b));
            }
        }
        for f in &model.faces {
            prop_assert!(f.outer.len() >= 3);
            prop_assert_eq!(f.outward, mesh.is_closed_oriented());
        }
    }

    #[test]
    fn random_bytes_never_panic_the_readers(bytes in prop::collection::vec(any::<u8>(), 0..400)) {
        let _ = parse_obj(&bytes);
        let _ = parse_stl(&bytes);
        let _ = Scene::from_toml(&String::from_utf8_lossy(&bytes), Path::new("random.toml"));
    }

    #[test]
    fn random_obj_text_never_panics(lines in prop::collection::vec(
        prop_oneof![
            (-3.0f64..3.0, -3.0f64..3.0, -3.0f64..3.0).prop_map(|(x, y, z)| format!("v {x} {y} {z}")),
            prop::collection::vec(-6i32..8, 0..6).prop_map(|ix| format!("f {}", ix.iter().map(i32::to_string).collect::<Vec<_>>().join(" "))),
            Just("o part".to_string()),
            Just("usemtl missing".to_string()),
            Just("v 1 2".to_string()),
            Just("f 1/2/3 2//3 3".to_string()),
        ], 0..30)) {
        let text = lines.join("\n");
        if let Ok(mesh) = parse_obj(text.as_bytes()) {
            let n = mesh.vertices.len() as u32;
            prop_assert!(mesh.polygons.iter().flatten().all(|&i| i < n));
        }
    }
}
