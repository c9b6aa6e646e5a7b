//! The bundled map's place names can be read (issue 40): every label's
//! every stroke is visible by the brute-force reference on the whole
//! scene, and no two labels' boxes overlap on the picture.

use hiddenline::model::{Edge, LineSource};
use hiddenline::reference;
use hiddenline::DVec2;
use scene::Scene;

#[test]
fn every_label_of_the_bundled_map_is_visible_and_apart() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../examples/map.toml");
    let scene = Scene::load(path).unwrap();
    let maps = scene.maps.as_ref().unwrap();
    let labels = maps.placed_labels(0, &scene.camera);
    assert_eq!(labels.len(), 12, "one label per town");
    // The labels' segments appended to the scene's model, where the
    // reference samples them as lines of their own.
    let mut model = scene.lower();
    let mut owner = Vec::new();
    for (n, (segments, pen, _)) in labels.iter().enumerate() {
        for &(a, b) in segments {
            owner.push((model.edges.len() as u32, n));
            model.edges.push(Edge { a, b, pen: *pen, faces: Vec::new() });
        }
    }
    let sampled = reference::sample(&model, &scene.camera, &reference::Options::default());
    let mut hidden = vec![0usize; labels.len()];
    for s in &sampled.samples {
        if let (LineSource::Edge(k), false) = (s.source, s.visible) {
            if let Ok(i) = owner.binary_search_by_key(&k, |&(e, _)| e) {
                hidden[owner[i].1] += 1;
            }
        }
    }
    let names = &maps.symbols[0].names;
    let cut: Vec<(&String, usize)> = names.iter().zip(&hidden).filter(|(_, &h)| h > 0).map(|(n, &h)| (n, h)).collect();
    assert!(cut.is_empty(), "labels with hidden samples: {cut:?}");
    let boxes: Vec<(DVec2, DVec2)> = labels
        .iter()
        .map(|(segments, _, _)| {
            let pts: Vec<DVec2> = segments.iter().flat_map(|&(a, b)| [a, b]).map(|p| scene.camera.project(p).unwrap().truncate()).collect();
            pts.iter().fold((pts[0], pts[0]), |(lo, hi), p| (lo.min(*p), hi.max(*p)))
        })
        .collect();
    for i in 0..boxes.len() {
        for j in i + 1..boxes.len() {
            assert!(!scene::map::labels::overlap(boxes[i], boxes[j]), "{} and {} overlap on the picture", names[i], names[j]);
        }
    }
}
