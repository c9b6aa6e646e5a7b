//! `[[axes]]` labels as a reader sees them in the bundled example
//! (`examples/surface_axes.toml`) and from other sides: every tick label and
//! title of the three axes is visible, judged by the brute-force ray-casting
//! reference against the surface's faces, and no two labels overlap on the
//! picture.

use glam::DVec2;
use hiddenline::model::{Edge, LineSource, Model};
use hiddenline::reference;
use scene::Scene;
use std::path::Path;

fn example() -> String {
    std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/surface_axes.toml")).unwrap()
}

/// Checks every label of `scene`'s axes: visible and apart, at least
/// `min_ticks[axis]` tick labels and a title per axis.
fn check_labels(name: &str, scene: &Scene, min_ticks: [usize; 3]) {
    let axes = &scene.axes[0];
    for (axis, &min) in min_ticks.iter().enumerate() {
        let ticks = axes.labels.iter().filter(|l| l.axis == axis && !l.title).count();
        let titles = axes.labels.iter().filter(|l| l.axis == axis && l.title).count();
        assert!(ticks >= min && titles == 1, "{name}: axis {axis} has {ticks} tick labels and {titles} titles");
    }
    // The surface's faces (and the base plane's contours, which hide
    // nothing), with only the labels' strokes as lines to judge.
    let lowered = scene.lower();
    let edges: Vec<Edge> = axes.segments.iter().map(|&(a, b)| Edge { a, b, pen: 1, faces: Vec::new() }).collect();
    let model = Model { faces: lowered.faces, edges };
    let r = reference::sample(&model, &scene.camera, &reference::Options::default());
    for label in &axes.labels {
        let (mut seen, mut all) = (0.0, 0.0);
        for s in r.samples.iter() {
            if let LineSource::Edge(i) = s.source {
                if label.segments.contains(&(i as usize)) {
                    all += s.length;
                    if s.visible {
                        seen += s.length;
                    }
                }
            }
        }
        assert!(all > 0.0, "{name}: label {:?} was not sampled", label.text);
        assert!(seen >= 0.999 * all, "{name}: axis {} label {:?} is {:.1}% hidden", label.axis, label.text, 100.0 * (1.0 - seen / all));
    }
    // Picture boxes of the labels, pairwise apart.
    let boxes: Vec<(DVec2, DVec2)> = axes
        .labels
        .iter()
        .map(|l| {
            let pts: Vec<DVec2> = axes.segments[l.segments.clone()]
                .iter()
                .flat_map(|s| [s.0, s.1])
                .map(|p| scene.camera.project(p).map(|d| DVec2::new(d.x, d.y)).expect("label in front of the eye"))
                .collect();
            (pts.iter().copied().reduce(DVec2::min).unwrap(), pts.iter().copied().reduce(DVec2::max).unwrap())
        })
        .collect();
    for i in 0..boxes.len() {
        for j in i + 1..boxes.len() {
            let (a, b) = (boxes[i], boxes[j]);
            let apart = a.1.x < b.0.x || b.1.x < a.0.x || a.1.y < b.0.y || b.1.y < a.0.y;
            let (la, lb) = (&axes.labels[i], &axes.labels[j]);
            assert!(apart, "{name}: labels {:?} (axis {}) and {:?} (axis {}) overlap", la.text, la.axis, lb.text, lb.axis);
        }
    }
}

#[test]
fn the_bundled_example_labels_all_three_axes_visibly_and_apart() {
    let scene = Scene::from_toml(&example(), Path::new("examples/surface_axes.toml")).unwrap();
    check_labels("surface_axes.toml", &scene, [3, 3, 3]);
}

/// From each side (the eye outside the box's x and y ranges, where the
/// edges facing it lie on faces turned towards it).
#[test]
fn labels_stay_visible_and_apart_from_every_side_and_for_a_flat_surface() {
    let text = example();
    for (k, eye) in [[6.0, -7.5, 5.0], [-7.0, -6.0, 4.0], [-6.0, 7.5, 5.0], [7.5, 6.0, 3.0], [9.0, -3.0, 8.0]].iter().enumerate() {
        let t = text.replace("eye = [6.0, -7.5, 5.0]", &format!("eye = {eye:?}"));
        let scene = Scene::from_toml(&t, Path::new("examples/surface_axes.toml")).unwrap();
        check_labels(&format!("eye {eye:?} ({k})"), &scene, [2, 2, 2]);
    }
    // A small z range: z ticks by that range, thinned until they keep apart
    // (the box is lower than two labels on the picture: one stays).
    let flat = text.replace("z = \"exp(-x^2 - y^2) - 0.6 * exp(-(x - 1)^2 - (y + 1)^2)\"", "z = \"0.02 * exp(-x^2 - y^2)\"");
    let scene = Scene::from_toml(&flat, Path::new("examples/surface_axes.toml")).unwrap();
    check_labels("flat surface", &scene, [2, 2, 1]);
}
